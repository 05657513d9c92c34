"""core.standstill and DeadZoneSign: the Coulomb dead zone and its width."""

import math

import numpy as np
import pytest
from scipy import signal

from drake_dynid.core.friction import DeadZoneSign, SignLaw
from drake_dynid.core.standstill import (
    combined_widths,
    dead_zone_widths,
    velocity_noise,
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
