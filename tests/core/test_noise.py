"""Noise at a given SNR: SNR = 10 log10(var(x)/σ²) per channel."""

import numpy as np
import pytest

from drake_dynid.core.noise import add_noise, noise_std_for_snr


def test_noise_std_follows_the_definition():
    t = np.linspace(0, 10, 10001)
    x = np.stack([3 * np.sin(t), 5 + 0.5 * np.cos(3 * t), np.full_like(t, 2.0)], 1)
    sigma = noise_std_for_snr(x, 30.0)
    np.testing.assert_allclose(
        10 * np.log10(np.var(x[:, :2], axis=0) / sigma[:2] ** 2), 30.0, rtol=1e-12
    )
    assert sigma[2] == 0.0  # a constant channel gets no noise
    per_channel = noise_std_for_snr(x, [20.0, 40.0, 0.0])
    np.testing.assert_allclose(per_channel[:2], np.std(x[:, :2], 0) * [0.1, 0.01])
    assert np.ndim(noise_std_for_snr(x[:, 0], 20.0)) == 0


def test_add_noise_reaches_the_requested_snr_and_is_reproducible():
    t = np.linspace(0, 100, 200_001)
    x = np.stack([np.sin(t), 10 * np.cos(0.3 * t)], 1)
    noisy = add_noise(x, 30.0, np.random.default_rng(31))  # seed 31
    noise = noisy - x
    measured = 10 * np.log10(np.var(x, 0) / np.var(noise, 0))
    np.testing.assert_allclose(measured, 30.0, atol=0.05)
    assert abs(np.corrcoef(noise.T)[0, 1]) < 0.01
    again = add_noise(x, 30.0, np.random.default_rng(31))
    np.testing.assert_array_equal(again, noisy)
    assert (
        add_noise(x[:, 0], 20.0, np.random.default_rng(1)).shape
        == x[:, :1].ravel().shape
    )


def test_validation():
    x = np.zeros((10, 2))
    with pytest.raises(
        ValueError, match=r"snr_db must be a scalar or have shape \(2,\)"
    ):
        noise_std_for_snr(x, [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="x must have shape"):
        noise_std_for_snr(np.zeros((10, 2, 2)), 1.0)
    with pytest.raises(ValueError, match="x must be finite"):
        noise_std_for_snr([0.0, np.nan], 1.0)
    with pytest.raises(ValueError, match="snr_db must be finite"):
        noise_std_for_snr(x, np.inf)
    with pytest.raises(TypeError, match=r"rng must be a numpy\.random\.Generator"):
        add_noise(x, 30.0, 3)
