"""core.standstill and DeadZoneSign: the Coulomb dead zone and its width."""

import math

import numpy as np
import pytest
from scipy import signal

from drake_dynid.core.friction import DeadZoneSign, SignLaw
from drake_dynid.core.standstill import (
    combined_widths,
    dead_zone_widths,
    reversal_run,
    reversal_signs,
    velocity_noise,
    velocity_noise_gain,
)

H = 0.01  # 100 Hz
FC, FD = 5.0, 0.75  # position cutoff and dynamics band [Hz]


def test_dead_zone_sign():
    zone = DeadZoneSign(0.01)
    assert isinstance(zone, SignLaw)
    v = np.array([-0.5, -0.01, -0.005, 0.0, 0.009, 0.02, np.nan])
    np.testing.assert_array_equal(zone(v)[:-1], [-1, 0, 0, 0, 0, 1])
    assert math.isnan(zone(v)[-1])  # a bad sample stays bad
    assert [zone.scalar(x) for x in (-0.5, 0.005, 0.02)] == [-1.0, 0.0, 1.0]
    per_joint = DeadZoneSign([0.1, 0.001])
    assert per_joint.width == (0.1, 0.001)
    np.testing.assert_array_equal(per_joint(np.array([[0.05, 0.05]])), [[0, 1]])
    with pytest.raises(TypeError, match="per-joint width has no scalar form"):
        per_joint.scalar(0.5)
    for bad in (-1.0, math.inf, [[0.1]]):
        with pytest.raises(ValueError, match=r"DeadZoneSign: width must be"):
            DeadZoneSign(bad)


def test_reversal_signs_restore_a_moving_joints_reversal_only():
    """Found by a benchmark (bench_dead_zone.py): at a moving joint's reversal the
    samples inside the zone got 0 where an exact-sign friction jumps: on the UR5
    at 125 Hz a bias of 5.5 σ. A short run between long runs of opposite signs
    takes the sign of the line through its neighbours; rest, dither and runs cut
    by the series' ends keep 0.
    """
    w, L = 0.1, 3
    # Joint 0: a reversal from -1 to +1 through the zone in 3 samples (-0.15,
    # -0.05, 0.05, 0.15 …): the line through -0.15 and 0.15 is 0 between the two
    # inside samples, which take its signs -1, +1.
    # Joint 1: at rest (inside), then a dither spike of +1 and one of -1 with one
    # sample between them: not a reversal (too short an excursion either side).
    # Joint 2: a reversal whose run is longer than L: stays 0.
    n = 40
    v = np.zeros((n, 3))
    v[:, 0] = np.linspace(-1.95, 1.95, n)
    v[:, 1] = 0.01
    v[18, 1], v[20, 1] = 0.5, -0.5
    v[:, 2] = np.where(np.arange(n) < 15, -1.0, 1.0)
    v[15:20, 2] = 0.0
    inside = np.flatnonzero(np.abs(v[:, 0]) <= w)
    assert inside.size == 2  # samples 19, 20 of joint 0
    out = reversal_signs(v, w, L)
    before = DeadZoneSign(w)(v)
    np.testing.assert_array_equal(before[inside, 0], [0, 0])
    np.testing.assert_array_equal(out[inside, 0], [-1, 1])
    np.testing.assert_array_equal(out[:, 1:], before[:, 1:])
    # The same reversal at the series' end (its context cut): 0.
    cut = reversal_signs(v[: inside[-1] + 2], w, L)
    np.testing.assert_array_equal(cut[inside, 0], 0)
    # Per-joint widths; a longer allowed run restores joint 2 (the line through
    # -1 and 1 over 5 samples: signs -1, -1, 0, 1, 1).
    wide = reversal_signs(v, [w, w, 0.5], 5)
    np.testing.assert_array_equal(wide[15:20, 2], [-1, -1, 0, 1, 1])
    # Each value needs 2L + 1 samples of context only: blocks with it agree.
    rng = np.random.default_rng(3)
    noisy = np.repeat(np.sin(np.linspace(0, 12, 600))[:, None], 2, axis=1)
    noisy += 0.05 * rng.standard_normal(noisy.shape)
    whole = reversal_signs(noisy, 0.1, L)
    c = 2 * L + 1
    for a, b in ((c, 200), (200, 450), (450, 600 - c)):
        part = reversal_signs(noisy[a - c : b + c], 0.1, L)[c:-c]
        np.testing.assert_array_equal(part, whole[a:b])
    assert math.isnan(reversal_signs(np.array([[np.nan]]), w, L)[0, 0])


def test_reversal_signs_reads_one_series_and_names_bad_arguments():
    """Found in review: a 1-D series (one joint) came back with its reversal's 0s
    (the rule was skipped for v.ndim != 2), a negative or NaN width gave the exact
    sign, L = 0 or -1 the zone sample by sample and L = 2.5 a bare IndexError."""
    v = np.array([-1.0, -1.0, -1.0, -0.05, 0.05, 1.0, 1.0, 1.0])
    np.testing.assert_array_equal(
        reversal_signs(v, 0.1, 2), [-1, -1, -1, -1, 1, 1, 1, 1]
    )
    np.testing.assert_array_equal(
        reversal_signs(v, 0.1, 2), reversal_signs(v[:, None], [0.1], 2)[:, 0]
    )
    for width in (-0.1, np.nan, [0.1, 0.1], [[0.1]]):
        with pytest.raises(ValueError, match="width"):
            reversal_signs(v[:, None], width, 2)
    for longest in (0, -1, 2.5):
        with pytest.raises(ValueError, match="longest"):
            reversal_signs(v[:, None], 0.1, longest)
    with pytest.raises(ValueError, match="v must be"):
        reversal_signs(np.zeros((2, 2, 2)), 0.1, 2)


def test_reversal_run_is_an_eighth_of_the_cutoffs_period():
    assert reversal_run(1 / 125, 1.5) == 10
    assert reversal_run(1e-3, 1.5) == 83
    assert reversal_run(1e-3, 400.0) == 1  # at least one sample
    with pytest.raises(ValueError, match="cutoff_hz"):
        reversal_run(1e-3, 0.0)


def test_filtered_noise_at_rest_has_no_reversal():
    """The rule's premise (reversal_run's docstring): the off-line velocity of
    white position noise, with the zone at 3 σ_v, never leaves it on both sides
    within an eighth of f_c's period: at rest the dead zone is unchanged."""
    h, fc = 1 / 125, 1.5
    q = np.random.default_rng(0).standard_normal((200_000, 1))
    q_f = signal.sosfiltfilt(signal.butter(4, fc, fs=1 / h, output="sos"), q, axis=0)
    v = (q_f[2:] - q_f[:-2]) / (2 * h)
    w = 3 * 1.4826 * np.median(np.abs(v))
    np.testing.assert_array_equal(
        reversal_signs(v, w, reversal_run(h, fc)), DeadZoneSign(w)(v)
    )


def _predicted_noise(sigma, h=H, fc=FC, fd=FD):
    """σ_v of white position noise σ through the module's chain, in frequency.

    Zero-phase Butterworth (order 4) at fc: |H|²; central difference:
    |sin(2πfh)|/h; minus the zero-phase order-8 low-pass at fd: 1 - |L|².
    """
    f = np.linspace(0.0, 0.5 / h, 20001)
    _, bw = signal.freqz(*signal.butter(4, fc, fs=1 / h), worN=f, fs=1 / h)
    sos = signal.butter(8, fd, fs=1 / h, output="sos")
    _, low = signal.sosfreqz(sos, worN=f, fs=1 / h)
    gain = np.abs(bw) ** 2 * np.abs(np.sin(2 * np.pi * f * h)) / h
    gain *= 1.0 - np.abs(low) ** 2
    # One-sided white noise density 2 σ² h over [0, fs/2].
    return sigma * math.sqrt(2 * h * np.trapezoid(gain**2, f))


def test_velocity_noise_of_white_noise_matches_the_filter_response():
    rng = np.random.default_rng(0)
    t = H * np.arange(20000)
    # Well inside the band (the order-8 low-pass keeps 1 - 4e-7 of 0.3 Hz).
    motion = 0.5 * np.sin(2 * np.pi * 0.2 * t) + 0.2 * np.cos(2 * np.pi * 0.3 * t)
    sigma = np.array([1e-4, 1e-3])
    q = motion[:, None] + sigma * rng.normal(size=(t.size, 2))
    measured = velocity_noise([q], H, cutoff_hz=FC, band_cutoff_hz=FD)
    np.testing.assert_allclose(measured, _predicted_noise(sigma), rtol=0.05)
    # The motion itself (inside the band) does not count.
    clean = velocity_noise(motion[:, None], H, cutoff_hz=FC, band_cutoff_hz=FD)
    assert clean[0] < 1e-3 * measured[0]
    widths = dead_zone_widths([q], H, cutoff_hz=FC, band_cutoff_hz=FD)
    np.testing.assert_allclose(widths, 3 * measured)


def test_a_burst_and_short_runs_do_not_move_the_measure():
    rng = np.random.default_rng(1)
    q = 1e-3 * rng.normal(size=(20000, 1))
    base = velocity_noise([q], H, cutoff_hz=FC, band_cutoff_hz=FD)[0]
    spiky = q.copy()
    spiky[3000:3010] += 0.05  # an encoder glitch: the MAD ignores it
    burst = velocity_noise([spiky], H, cutoff_hz=FC, band_cutoff_hz=FD)[0]
    assert burst == pytest.approx(base, rel=0.05)
    # Runs shorter than the filter's edges are skipped, the others pooled.
    runs = [q[:3000], q[3000:3020], q[3020:]]
    pooled = velocity_noise(runs, H, cutoff_hz=FC, band_cutoff_hz=FD)[0]
    assert pooled == pytest.approx(base, rel=0.05)
    with pytest.raises(ValueError, match="needs a finite run of at least"):
        velocity_noise([q[:20]], H, cutoff_hz=FC, band_cutoff_hz=FD)
    with pytest.raises(ValueError, match="must be < the Nyquist frequency 50"):
        velocity_noise([q], H, cutoff_hz=60.0, band_cutoff_hz=FD)
    with pytest.raises(ValueError, match="factor must be > 0"):
        dead_zone_widths([q], H, cutoff_hz=FC, band_cutoff_hz=FD, factor=0.0)


def test_joints_filtered_together_or_apart_give_the_same_noise(monkeypatch):
    """``velocity_noise`` filters as many joints at once as GROUP_ENTRIES allows
    (all on a short log, one at a time on hours): the same σ_v either way."""
    from drake_dynid.core import standstill

    rng = np.random.default_rng(2)
    t = H * np.arange(6000)
    motion = np.sin(2 * np.pi * 0.2 * t)[:, None] * np.arange(1, 6)
    q = motion + np.array([1e-4, 3e-4, 1e-3, 2e-3, 5e-4]) * rng.normal(size=(6000, 5))
    runs = [q[:2500], q[2600:]]
    together = velocity_noise(runs, H, cutoff_hz=FC, band_cutoff_hz=FD)
    for entries in (1, 2 * 5800, 3 * 5800):  # groups of 1, 2 and 3 joints
        monkeypatch.setattr(standstill, "GROUP_ENTRIES", entries)
        apart = velocity_noise(runs, H, cutoff_hz=FC, band_cutoff_hz=FD)
        np.testing.assert_allclose(apart, together, rtol=1e-9)


@pytest.mark.parametrize(
    ("h", "fc"), [(1e-3, 20.0), (1e-3, 0.5), (0.01, 5.0), (0.01, 40.0), (1e-3, 450.0)]
)
def test_velocity_noise_gain_is_the_filter_chains_noise_gain(h, fc):
    # Independent: scipy's Butterworth response, integrated on a fine grid
    # (zero phase: |H|² twice; central difference: |sin ωh|/h).
    f = np.linspace(0.0, 0.5 / h, 400001)
    sos = signal.butter(4, fc, fs=1 / h, output="sos")
    _, response = signal.sosfreqz(sos, worN=f, fs=1 / h)
    density = np.abs(response) ** 4 * (np.sin(2 * np.pi * f * h) / h) ** 2
    expected = math.sqrt(2 * h * np.trapezoid(density, f))
    assert velocity_noise_gain(h, fc) == pytest.approx(expected, rel=1e-6)


def test_velocity_noise_gain_matches_filtered_white_noise():
    h, fc = 1e-3, 20.0
    x = np.random.default_rng(0).standard_normal(400000)
    y = signal.sosfiltfilt(signal.butter(4, fc, fs=1 / h, output="sos"), x)
    v = (y[2:] - y[:-2]) / (2 * h)
    assert v[2000:-2000].std() == pytest.approx(velocity_noise_gain(h, fc), rel=0.01)
    for bad, match in (
        ((0.0, 5.0), "time_step must be > 0"),
        ((0.01, 50.0), "cutoff_hz must be < the Nyquist frequency 50"),
        ((0.01, -1.0), "cutoff_hz must be > 0"),
    ):
        with pytest.raises(ValueError, match=match):
            velocity_noise_gain(*bad)


BAND = {"cutoff_hz": FC, "band_cutoff_hz": FD}


def test_dead_zone_widths_take_the_larger_of_the_two_noise_measures():
    rng = np.random.default_rng(4)
    q = 1e-4 * rng.normal(size=(20000, 2))
    residual = velocity_noise([q], H, cutoff_hz=FC, band_cutoff_hz=FD)
    white = velocity_noise_gain(H, FC) * np.array([1e-4, 1e-2])
    assert white[0] > residual[0] and white[1] > residual[1]  # f_n < f_c sees part
    widths = dead_zone_widths(
        [q], H, cutoff_hz=FC, band_cutoff_hz=FD, position_noise=[0.0, 1e-2]
    )
    np.testing.assert_allclose(widths, 3 * np.array([residual[0], white[1]]))
    with pytest.raises(ValueError, match="position_noise must be >= 0"):
        dead_zone_widths([q], H, **BAND, position_noise=[-1, 0])
    with pytest.raises(ValueError, match="position_noise must have shape"):
        dead_zone_widths([q], H, **BAND, position_noise=[0])


def _log(q, h=1e-3):
    from drake_dynid.logs import RobotLog

    t = h * np.arange(q.shape[0])
    names = [f"j{k}" for k in range(q.shape[1])]
    return RobotLog(t, q, np.zeros_like(q), names, h)


def test_standstill_widths_of_a_noisy_log_are_three_velocity_noise_stds():
    from drake_dynid.offline import auto_cutoff, standstill_widths

    rng = np.random.default_rng(0)
    t = 1e-3 * np.arange(40000)
    motion = 0.5 * np.sin(2 * np.pi * 0.2 * t) + 0.2 * np.cos(2 * np.pi * 1.3 * t)
    sigma = np.array([1e-5, 1e-4, 1e-3])
    q = motion[:, None] + sigma * rng.normal(size=(t.size, 3))
    log = _log(q)
    fc = auto_cutoff(q, 1e-3)
    widths = standstill_widths(log)
    np.testing.assert_allclose(
        widths, 3 * sigma * velocity_noise_gain(1e-3, fc), rtol=0.05
    )
    # --cutoff: the gain of that cutoff.
    np.testing.assert_allclose(
        standstill_widths(log, cutoff_hz=10.0),
        3 * sigma * velocity_noise_gain(1e-3, 10.0),
        rtol=0.05,
    )
    # An encoder glitch (ten samples 50σ off) moves the measure by a few %.
    spiky = q.copy()
    spiky[3000:3010] += 50 * sigma
    np.testing.assert_allclose(standstill_widths(_log(spiky)), widths, rtol=0.05)


def test_standstill_widths_of_a_noise_free_log_are_nothing():
    """Found by a review: the old measure (the velocity above the dynamics band)
    let the motion itself through and gave ~1e-3 rad/s on a noise-free UR5 log,
    a dead zone that biased every off-line estimate."""
    from drake_dynid.offline import standstill_widths

    t = 1e-3 * np.arange(30000)
    w = 2 * np.pi * 0.1
    q = np.stack(
        [sum(np.sin(k * w * t + k) / k for k in range(1, 6)), np.cos(3 * w * t)], axis=1
    )
    widths = standstill_widths(_log(q))
    assert np.all(widths < 1e-7), widths


def test_standstill_widths_of_a_short_log_are_none():
    from drake_dynid.offline import standstill_widths

    q = 1e-3 * np.random.default_rng(3).normal(size=(63, 2))
    assert standstill_widths(_log(q)) is None
    q[10] = np.nan  # the longest good run counts
    longer = np.vstack([q, q])
    assert standstill_widths(_log(longer)) is None


def test_combined_widths_of_coupled_motors():
    # TX40 motor 6: row N (e5 + e6): u/ρ = v5 + v6, independent noises.
    rows = np.array([[45.0, 0.0], [32.0, 32.0]])
    np.testing.assert_allclose(
        combined_widths([0.03, 0.04], rows), [0.03, 0.05], rtol=1e-12
    )
    assert combined_widths([0.1, 0.2], np.zeros((0, 2))).shape == (0,)
    with pytest.raises(ValueError, match="rows must not be all zeros"):
        combined_widths([0.1, 0.2], np.zeros((1, 2)))
    # Found by a review: --dead-zone 1e300 with a coupled motor squared to inf,
    # then 0·inf = NaN, an error about DeadZoneSign's width.
    np.testing.assert_allclose(
        combined_widths([1e300, 1e300], rows), [1e300, 2**0.5 * 1e300], rtol=1e-12
    )
    assert combined_widths([0.0, 0.0], rows).tolist() == [0.0, 0.0]


def test_runs_that_end_moving_do_not_widen_the_dead_zone():
    """Found by a review: the velocity noise kept the residual two f_n periods
    from each end of a run, where the filters' transients on a joint still moving
    (odd padding) decay by only 0.29 a period; a run too short for that kept
    everything. A 10 s simulated wrist log split at 30 % measured 50 times its
    white noise (widths 8-14 mrad/s for 0.19); several short runs as well."""
    from drake_dynid.core.standstill import shortest_run

    rng = np.random.default_rng(5)
    h, fc = 1e-3, 2.5
    t = h * np.arange(12000)
    motion = 0.5 * np.sin(2 * np.pi * 0.5 * t + 0.7) + 0.2 * np.sin(2 * np.pi * t)
    sigma = 1e-4
    q = (motion + sigma * rng.normal(size=t.size))[:, None]
    white = 3 * sigma * velocity_noise_gain(h, fc)
    # One long run: the residual away from its moving ends (below the white gain:
    # f_n = f_c sees part of it).
    whole = dead_zone_widths([q], h, cutoff_hz=fc, band_cutoff_hz=fc)[0]
    assert whole < white
    # Runs too short to hold an interior clear of the edges: none is measured;
    # the white floor's bound alone.
    assert shortest_run(h, fc, fc) > 3000
    runs = [q[k : k + 3000] for k in range(0, 12000, 3000)]
    with pytest.raises(ValueError, match="needs a finite run of at least"):
        velocity_noise(runs, h, cutoff_hz=fc, band_cutoff_hz=fc)
    widths = dead_zone_widths(
        runs, h, cutoff_hz=fc, band_cutoff_hz=fc, position_noise=[sigma]
    )
    assert widths[0] == pytest.approx(white, rel=1e-12)
    # A run long enough next to short ones: the short ones are left out.
    mixed = [q[:2500], q[2600:]]
    np.testing.assert_allclose(
        velocity_noise(mixed, h, cutoff_hz=fc, band_cutoff_hz=fc),
        velocity_noise([q[2600:]], h, cutoff_hz=fc, band_cutoff_hz=fc),
    )
    assert dead_zone_widths(mixed, h, cutoff_hz=fc, band_cutoff_hz=fc)[0] < white
