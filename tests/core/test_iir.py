"""core.iir (numpy Butterworth, blocked sosfilt, Welch) against scipy.signal."""

import numpy as np
import pytest
from scipy import signal

from drake_dynid.core import iir

DESIGNS = [
    (4, 20.0, 1000.0),
    (8, 0.75, 1000.0),
    (4, 0.5, 100.0),
    (8, 40.0, 1000.0),
    (2, 100.0, 1000.0),
    (6, 3.0, 500.0),
]


@pytest.mark.parametrize("order, cutoff, fs", DESIGNS)
def test_butter_lowpass_and_filtering_equal_scipy(order, cutoff, fs):
    sos = iir.butter_lowpass(order, cutoff, fs)
    reference = signal.butter(order, cutoff, fs=fs, output="sos")
    np.testing.assert_allclose(sos, reference, rtol=0, atol=1e-14)
    np.testing.assert_allclose(
        iir.sosfilt_zi(sos), signal.sosfilt_zi(reference), rtol=1e-10, atol=1e-12
    )
    rng = np.random.default_rng(order)
    x = np.cumsum(rng.standard_normal((2003, 3)), axis=0)  # not a multiple of BLOCK
    zi = iir.sosfilt_zi(sos)[:, :, None] * x[:1]
    expected, _ = signal.sosfilt(reference, x, axis=0, zi=zi)
    got = iir.sosfilt(sos, x, zi)
    scale = np.max(np.abs(expected))
    np.testing.assert_allclose(got / scale, expected / scale, rtol=0, atol=1e-9)


def test_butter_lowpass_rejects_bad_settings():
    with pytest.raises(ValueError, match="order must be even"):
        iir.butter_lowpass(3, 10.0, 1000.0)
    with pytest.raises(ValueError, match="cutoff_hz must be < fs/2"):
        iir.butter_lowpass(4, 600.0, 1000.0)


@pytest.mark.parametrize("segment", [400, 401])
def test_welch_equals_scipy(segment):
    x = np.cumsum(np.random.default_rng(1).standard_normal((3000, 2)), axis=0)
    f, density = iir.welch(x, 1000.0, segment)
    f_ref, reference = signal.welch(
        x,
        fs=1000.0,
        window="blackmanharris",
        nperseg=segment,
        detrend="linear",
        axis=0,
    )
    np.testing.assert_allclose(f, f_ref)
    np.testing.assert_allclose(
        density, reference, rtol=1e-10, atol=1e-12 * reference.max()
    )
