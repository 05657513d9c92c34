"""Excitation bandwidth estimate and the modulating set that covers it."""

import numpy as np
import pytest

from drake_dynid.core.excitation import (
    estimate_bandwidth,
    frequencies_for,
    velocity_spectrum,
)

H = 1e-3


def multisine(freqs, duration=21.0, velocity_amplitude=1.0):
    """q_j = Σ (a/(2πf)) sin(2πf t + φ): every line has velocity amplitude a."""
    t = np.arange(0.0, duration, H)
    q = np.zeros((t.size, len(freqs)))
    for j, fj in enumerate(freqs):
        for i, f in enumerate(fj):
            q[:, j] += (
                velocity_amplitude / (2 * np.pi * f) * np.sin(2 * np.pi * f * t + i)
            )
    return q


FREQS = [[0.11, 0.23, 0.37, 0.53], [0.13, 0.29, 0.43, 0.61]]


def test_known_multisine_gives_its_top_line_within_the_resolution():
    q = multisine(FREQS)
    band = estimate_bandwidth(q, H)
    # Highest line 0.61 Hz; the Hann main lobe adds at most 2/duration Hz.
    assert 0.61 - 1 / 21 <= band <= 0.61 + 2 / 21


def test_energy_fraction_selects_lower_lines():
    # Four lines of equal velocity power: 70 % of it lies at or below the third one.
    q = multisine([[0.1, 0.3, 0.5, 0.9]], duration=40.0)
    assert 0.45 <= estimate_bandwidth(q, H, energy=0.70) <= 0.55
    assert 0.85 <= estimate_bandwidth(q, H, energy=0.99) <= 0.95


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_robust_to_30_db_noise(seed):
    q = multisine(FREQS)
    sigma = q.std(axis=0) * 10 ** (-30 / 20)
    noisy = q + np.random.default_rng(seed).standard_normal(q.shape) * sigma
    assert estimate_bandwidth(noisy, H) == pytest.approx(estimate_bandwidth(q, H))


def test_noise_would_dominate_without_the_floor_removal():
    # Sanity of the design: at 30 dB the f²-weighted noise is > 5 % of the velocity
    # power up to 20 Hz, which the threshold removes.
    q = multisine(FREQS)
    noise = np.random.default_rng(0).standard_normal(q.shape) * q.std(0) * 10**-1.5
    f, p = velocity_spectrum(q + noise, H)
    assert np.all(p[f > 2.0] == 0.0)
    from scipy import signal

    _, s = signal.periodogram(noise, fs=1 / H, window="hann", axis=0)
    raw = ((2 * np.pi * f[:, None]) ** 2 * s)[f <= 20.0].sum(0) * (f[1] - f[0])
    assert np.all(raw > 0.05 * 2.0)  # velocity power of the signal: 4 lines × ½


def test_single_channel_and_frequencies_for():
    q = multisine([[0.2, 0.4]])[:, 0]
    assert 0.35 <= estimate_bandwidth(q, H) <= 0.5
    np.testing.assert_array_equal(frequencies_for(20.0, 0.55), np.arange(11.0))
    # At least MIN_FUNCTIONS = 8 integers when the band holds fewer (T = 7 s: 4).
    np.testing.assert_array_equal(frequencies_for(20.0, 0.01), np.arange(8.0))
    np.testing.assert_array_equal(frequencies_for(7.0, 0.62), np.arange(8.0))
    np.testing.assert_array_equal(
        frequencies_for(7.0, 0.62, min_count=4), np.arange(4.0)
    )
    assert frequencies_for(20.0, 0.55, spacing=0.05)[-1] == pytest.approx(10.0)


def test_validation_errors():
    q = multisine(FREQS)
    with pytest.raises(ValueError, match="energy must be in"):
        estimate_bandwidth(q, H, energy=0.0)
    with pytest.raises(ValueError, match="time_step must be > 0"):
        estimate_bandwidth(q, 0.0)
    with pytest.raises(ValueError, match="threshold must be > 1"):
        estimate_bandwidth(q, H, threshold=1.0)
    with pytest.raises(ValueError, match="N >= 64"):
        estimate_bandwidth(np.zeros((10, 2)), H)
    with pytest.raises(ValueError, match="must be finite"):
        estimate_bandwidth(np.full((100, 2), np.nan), H)
    with pytest.raises(ValueError, match="no motion above the noise"):
        estimate_bandwidth(np.random.default_rng(0).standard_normal((4000, 2)), H)
    with pytest.raises(ValueError, match="no motion above the noise"):
        estimate_bandwidth(np.ones((4000, 2)), H)
    with pytest.raises(TypeError, match="energy must be a real number"):
        estimate_bandwidth(q, H, energy="all")
    with pytest.raises(ValueError, match="bandwidth_hz must be > 0"):
        frequencies_for(20.0, 0.0)
    with pytest.raises(ValueError, match="min_count must be >= 1"):
        frequencies_for(20.0, 0.5, min_count=0)


def test_torque_noise_is_not_inflated_by_coulomb_steps():
    """Found by a review: the periodogram's floor above f_s/4 counts a Coulomb
    reversal's step (its power spreads over the whole spectrum) as noise; the
    median deviation of the half band does not (Drake's inverse dynamics of the
    paper's 2R with the URDF's sign(v) friction, 0.01 N·m of white noise)."""
    from _drake_dynamics import exact_paper_2r

    from drake_dynid.core.excitation import (
        half_band_share,
        position_noise_std,
        torque_noise_std,
    )
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    _, _, tau = exact_paper_2r(robot)
    sigma = np.array([0.01, 0.003])
    noisy = tau + sigma * np.random.default_rng(0).standard_normal(tau.shape)
    np.testing.assert_allclose(torque_noise_std(noisy, 1e-3), sigma, rtol=0.05)
    assert np.all(position_noise_std(noisy, 1e-3) > 1.3 * sigma)  # the floor's excess
    # White noise alone, and c against scipy's filter.
    from scipy import signal

    x = np.random.default_rng(1).standard_normal((50000, 2)) * [1.0, 1e-3]
    np.testing.assert_allclose(torque_noise_std(x, 0.01), [1.0, 1e-3], rtol=0.02)
    sos = signal.butter(8, 25.0, fs=100.0, output="sos")
    w, response = signal.sosfreqz(sos, worN=1 << 16)
    c = np.trapezoid((1 - np.abs(response) ** 2) ** 2, w) / np.pi
    assert half_band_share() == pytest.approx(c, rel=1e-4)
    with pytest.raises(ValueError, match="N >= 64"):
        torque_noise_std(x[:63], 0.01)


def test_an_exactly_constant_torque_has_no_noise():
    """Found by a review: a constant channel measured the filter's round-off
    (4.75e-16 N·m for 1.25 N·m), which passed for a noise where zero is checked
    (the covariance weighting refuses a joint whose rows have none)."""
    from drake_dynid.core.excitation import torque_noise_std

    tau = np.tile([1.25, -7.0, 0.0], (500, 1))
    np.testing.assert_array_equal(torque_noise_std(tau, 1e-3), [0.0, 0.0, 0.0])
    noisy = tau + 0.01 * np.random.default_rng(3).standard_normal(tau.shape)
    np.testing.assert_allclose(torque_noise_std(noisy, 1e-3), 0.01, rtol=0.15)


def _lines(fs, duration, noise_std, seed=3):
    """(t, q): five lines of 0.2 Hz (top 1 Hz) per joint at ``fs`` [Hz], plus
    white noise (``_motions.band_limited``)."""
    from _motions import band_limited

    return band_limited(fs, duration, noise_std, seed)[:2]


def test_position_noise_of_resampled_quantized_and_held_channels():
    """Found by a review: the position noise (the dead zone's σ_q) was read
    from the periodogram above f_s/4 alone. 100 Hz positions (σ = 0.01 rad)
    interpolated linearly onto 1 kHz hold only faded images there: 1.5e-4 rad
    (held: 2.1e-3 rad); a 12-bit joint's rounding error (Δ/√12 = 4.4e-4 rad)
    read 3.8e-5 rad on a slow sine and 1.4e-11 rad on ten whole periods of a
    1 rad one (its error a few lines); a joint held at 0.3 rad read the
    detrending's round-off, 2.4e-18 rad. Now: the floor below the channel's own
    Nyquist frequency (its noise's shape sinc^(2k) divided out), at least Δ/√12
    for a quantized channel, and 0 for a constant one. The velocity band, from
    the same floor, came out at 252 Hz (interpolated) and 500 Hz (held) instead
    of 0.95 Hz: the images of the lines near the kernel's zeros stood above it;
    nothing above the channel's own Nyquist frequency counts now."""
    from drake_dynid.core.excitation import (
        motion_and_noise,
        position_noise_std,
        quantum,
        resampling,
    )

    t, q = _lines(100.0, 20.0, 1e-2)
    native = position_noise_std(q, 0.01)
    np.testing.assert_allclose(native, 0.01, rtol=0.08)  # 500 bins: 0.97, 1.05
    for offset in (0.0, 3.7e-4):
        fine = np.arange(offset, t[-1], H)
        linear = np.column_stack([np.interp(fine, t, q[:, j]) for j in range(2)])
        assert resampling(linear[:, 0]) == (pytest.approx(10.0, rel=1e-3), 2)
        np.testing.assert_allclose(position_noise_std(linear, H), native, rtol=0.03)
        np.testing.assert_allclose(motion_and_noise(linear, H)[1], native, rtol=0.03)
    held = np.repeat(q, 10, axis=0)
    assert resampling(held[:, 1]) == (10.0, 1)
    np.testing.assert_allclose(position_noise_std(held, H), native, rtol=0.03)
    # The velocity band sees no motion among the images (it was 252 Hz, 500 Hz).
    band = estimate_bandwidth(q, 0.01)  # 0.95 Hz
    for resampled in (linear, held):
        assert estimate_bandwidth(resampled, H) == pytest.approx(band, abs=0.01)
    slow = np.arange(0.0, 20.0, 1 / 30)
    q30 = _lines(30.0, 20.0, 1e-3)[1][: slow.size]
    fine = np.arange(0.0, slow[-1], H)
    onto = np.column_stack([np.interp(fine, slow, q30[:, j]) for j in range(2)])
    np.testing.assert_allclose(
        position_noise_std(onto, H), position_noise_std(q30, 1 / 30), rtol=0.05
    )
    # Not resampled: 1 kHz noise, a smooth noise-free motion, encoder counts.
    assert resampling(_lines(1000.0, 5.0, 1e-4)[1][:, 0]) == (1.0, 0)
    assert resampling(_lines(1000.0, 5.0, 0.0)[1][:, 0]) == (1.0, 0)
    count = 2 * np.pi / 4096
    t = np.arange(20000) * H
    for amplitude, frequency in ((0.01, 0.1), (1.0, 0.5)):
        true = 0.3 + amplitude * np.sin(2 * np.pi * frequency * t)
        joint = np.round(true / count) * count
        assert quantum(joint) == pytest.approx(count) and resampling(joint) == (1, 0)
        sigma = position_noise_std(joint, H)[0]
        assert sigma == pytest.approx(count / np.sqrt(12.0))
        assert sigma == pytest.approx(np.std(joint - true), rel=0.06)
    for value in (0.3, 1.2345678, 195 * count):
        assert position_noise_std(np.full(1000, value), H)[0] == 0.0
    assert quantum(q[:, 0]) == 0.0 and quantum(np.full(9, 0.3)) == 0.0


def test_a_sensor_slower_than_the_log_clock_is_not_resampled():
    """Found by a review: a 1 kHz sensor read by a log clock 2 % faster (980
    Hz, σ = 1e-4 rad) repeats one sample in 50; ``resampling`` called each
    run of moving samples between repeats a knot and judged the channel held
    from 20 Hz (50, 1): position_noise_std 2.1e-5 rad instead of 1.1e-4, and
    ``dynid offline`` would name it held. A held channel moves at one sample
    per knot (k-th differences nonzero on runs of at most k); here it moves
    on 49 of 50."""
    from drake_dynid.core.excitation import position_noise_std, resampling

    n = 20000
    for every in (20, 50):
        sensor = np.arange(n) * H * every / (every - 1)  # its own sample times
        t, q = _lines(1.0 / H, n * H, 0.0)
        y = np.column_stack([np.interp(sensor, t, q[:, j]) for j in range(2)])
        y += np.random.default_rng(5).normal(0.0, 1e-4, y.shape)
        # The log's clock holds the last sensor sample: a repeat every `every`.
        logged = y[np.searchsorted(sensor, t, side="right") - 1]
        assert resampling(logged[:, 0]) == (1.0, 0)
        assert resampling(logged[:, 1]) == (1.0, 0)
        assert np.all(position_noise_std(logged, H) > 0.9e-4)


def test_velocity_band_of_a_quantized_joint_sees_its_staircase_as_noise():
    """Found by a review: the velocity band read a 12-bit joint's staircase
    (Δ = 2π/4096) against the white floor above f_s/4, and its harmonics, 1/f²
    down to a few hundred Hz, as motion: 482 Hz for a 1 rad sine of 0.5 Hz, 497
    Hz for 0.01 rad at 0.1 Hz, a log's band 497 Hz instead of the other joint's
    0.62 Hz (the off-line decimation cutoff min(f_c, 1.5 B) then f_c, 2.98 Hz,
    instead of 0.93). The staircase floor of the automatic cutoff
    (Δ²·r/(24·max(f, r)²), r the count changes a second) now applies to the
    velocity band too; position_noise_std keeps Δ/√12."""
    from drake_dynid.core.excitation import position_noise_std

    t = np.arange(60000) * H
    count = 2 * np.pi / 4096
    moving = 0.5 * np.sin(2 * np.pi * 0.2 * t) + 0.3 * np.sin(2 * np.pi * 0.6 * t + 1)
    moving += np.random.default_rng(2).normal(0.0, 1e-4, t.size)
    alone = estimate_bandwidth(moving, H)  # 0.62 Hz
    for amplitude, frequency in ((1.0, 0.5), (0.01, 0.1)):
        joint = np.round((0.3 + amplitude * np.sin(2 * np.pi * frequency * t)) / count)
        joint *= count
        assert estimate_bandwidth(joint, H) < 5.0 * frequency
        both = np.column_stack([moving, joint])
        assert estimate_bandwidth(both, H) == pytest.approx(alone, abs=0.05)
        sigma = position_noise_std(joint, H)[0]
        assert sigma == pytest.approx(count / np.sqrt(12.0), rel=0.02)


def test_encoder_counts_written_with_six_decimals_are_still_counts():
    """Found by a review: ``quantum`` asked every change to be a whole number of
    the smallest within 1e-3 of a step, and a CSV's ``%.6f`` rounds each value by
    up to 5e-7 rad, 0.5 % of a 16-bit count (9.6e-5 rad): a noise-free 16-bit
    joint moving 0.05 rad at 0.05 Hz was not quantized, σ 1.46e-5 rad instead
    of its rounding's 2.78e-5, its automatic cutoff 40 Hz instead of the exact
    counts' 1.33 Hz. The values' decimal step (1e-6) is allowed for
    now (up to 0.05 Δ), and Δ fitted over the changes' counts."""
    from drake_dynid.core.excitation import (
        decimal_step,
        piece_quanta,
        piece_quantum,
        position_noise_std,
        quantum,
    )
    from drake_dynid.core.idim_auto import auto_cutoff

    t = np.arange(40000) * H
    true = 0.3 + 0.05 * np.sin(2 * np.pi * 0.05 * t)
    for bits in (12, 16, 20):
        count = 2 * np.pi / 2**bits
        exact = np.round(true / count) * count
        written = np.round(exact, 6)  # what "%.6f" then float() gives
        assert decimal_step(written) == 1e-6 and decimal_step(exact) == 0.0
        sigma = position_noise_std(written, H)[0]
        truth = np.std(written - true)  # 4.31e-4, 2.78e-5, 1.75e-6 rad
        # 0.70, 1.33 (was 40) and 1.85 Hz; 1.83 Hz from the exact counts.
        assert auto_cutoff(written, H) == pytest.approx(auto_cutoff(exact, H), 0.02)
        if bits == 20:  # 1e-6 is 0.17 Δ: the rounding dithers, the floor is white
            assert quantum(written) == 0.0 and sigma == pytest.approx(truth, 0.2)
            continue
        assert quantum(written) == pytest.approx(count, rel=1e-4)
        assert sigma == pytest.approx(truth, rel=0.06)  # was 1.46e-5 for 16 bits
        halves = [piece_quantum(written[:20000]), piece_quantum(written[20000:])]
        assert piece_quanta(halves) == pytest.approx([count, count], rel=1e-4)
    assert decimal_step(np.arange(5.0)) == 1.0
    # Noise written with 6 decimals is no 16-bit count (the 0.05 Δ limit).
    noisy = np.round(true + np.random.default_rng(1).normal(0.0, 1e-4, t.size), 6)
    assert position_noise_std(noisy, H)[0] == pytest.approx(1e-4, rel=0.05)


def test_an_exact_ramp_is_not_quantized():
    """Found by a review: an exactly linear channel changes by v·h at every
    sample, which ``quantum`` took for a count (Δ = v·h): a noise-free ramp of
    0.1 rad/s at 1 kHz got σ = Δ/√12 = 2.9e-5 rad. A quantum needs changes of
    different counts (or repeats): a ramp is exactly linear, σ 0 (2e-17)."""
    from drake_dynid.core.excitation import position_noise_std, quantum

    t = np.arange(20000) * H
    for ramp in (0.2 + 0.1 * t, 0.2 - 0.1 * t, np.round(0.2 + 0.1 * t, 6)):
        assert quantum(ramp) == 0.0
        assert position_noise_std(ramp, H)[0] < 1e-12
    count = 2 * np.pi / 4096  # a slow encoder ramp: counts 0 and 1, quantized
    slow = np.round((0.2 + 0.1 * t) / count) * count
    assert quantum(slow) == pytest.approx(count)


def test_a_log_joined_from_two_encoders_keeps_their_rounding_noise():
    """Found by a review: a joint joined from a 12-bit and a 5000-count encoder
    (150 s then 50 s at 1 kHz, steps not whole numbers of each other) is not
    counts as a whole, and its σ read its staircases' white floor: 5.6e-5 rad,
    below either encoder's rounding (Δ/√12: 4.43e-4 and 3.63e-4 rad; their mean
    square over the log 4.24e-4). Each 8192-sample piece now bounds it by its own
    quantum: 4.17e-4 rad (the other order: 3.75e-4 for 3.84e-4). A noisy float
    channel, a ramp and a constant channel keep theirs."""
    from drake_dynid.core.excitation import position_noise_std

    t = np.arange(200000) * H
    true = 0.3 + 0.5 * np.sin(2 * np.pi * 0.3 * t) ** 2
    coarse, fine = 2 * np.pi / 4096, 2 * np.pi / 5000
    first, second = np.round(true / coarse) * coarse, np.round(true / fine) * fine
    for a, b in ((coarse, fine), (fine, coarse)):
        head, tail = (first, second) if a == coarse else (second, first)
        joined = np.r_[head[:150000], tail[150000:]]
        expected = np.sqrt((0.75 * a**2 + 0.25 * b**2) / 12.0)
        sigma = position_noise_std(joined, H)[0]
        assert 0.9 * expected < sigma <= 1.01 * expected, (sigma, expected)
    noisy = true + np.random.default_rng(2).normal(0.0, 1e-4, t.size)
    assert position_noise_std(noisy, H)[0] == pytest.approx(1e-4, rel=0.05)
    assert position_noise_std(0.2 + 0.1 * t, H)[0] < 1e-12
    assert position_noise_std(np.full(t.size, 0.3), H)[0] == 0.0


def test_a_joint_at_rest_with_a_few_flickers_is_not_counts():
    """Found by a review: two changes may be off the counts (one glitched sample
    of an encoder), but a float joint at rest for 20 s at 1 kHz but for two
    flickers (1.3e-4 and 0.5e-4 rad: 4 changes) was then counts of 1.3e-4, σ
    3.75e-5 rad where its deviation is 1e-6 (1.1e-6 before that rule, and
    now); the odd changes need 16 on the counts beside them. Its 8192-sample
    pieces, a flicker each, do not bound σ either."""
    from drake_dynid.core.excitation import position_noise_std, quantum

    joint = np.full(20000, 0.3)
    joint[5000] += 1.3e-4
    joint[12000] -= 0.5e-4
    assert quantum(joint) == 0.0
    assert position_noise_std(joint, H)[0] < 3e-6
    joint[16000] += 2.6e-4  # a third one
    assert quantum(joint) == 0.0
    assert position_noise_std(joint, H)[0] < 3e-6
