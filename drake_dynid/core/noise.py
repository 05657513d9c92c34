"""Measurement noise at a given signal-to-noise ratio (docs/MATH.md §6).

Definition used everywhere in drake_dynid (state it with any result)::

    SNR = 10 log10( var(x) / σ² )   [dB], per channel,

with ``var(x)`` the variance of the clean channel over the record (its mean
removed) and σ the standard deviation of the added white Gaussian noise. So at
30 dB the noise std is ``std(x) / 10^(30/20) ≈ 3.2 %`` of the signal's std.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = ["add_noise", "noise_std_for_snr"]


def noise_std_for_snr(x: Any, snr_db: Any) -> np.ndarray:
    """Noise std per channel for a given SNR: ``σ = std(x) · 10^(-SNR/20)``.

    ``SNR = 10 log10(var(x)/σ²)`` [dB] with ``var`` over the samples (axis 0).

    Args:
        x: (N,) or (N, c) clean signal.
        snr_db: SNR [dB], a scalar or one value per channel (c,).

    Returns:
        σ, a float for 1-D ``x`` or (c,) [unit of x]. A constant channel gets 0.
    """
    owner = "noise_std_for_snr"
    x = v.array(owner, "x", x)
    if x.ndim not in (1, 2) or x.shape[0] < 2:
        v.fail(owner, f"x must have shape (N,) or (N, c) with N >= 2; got {x.shape}.")
    snr = v.array(owner, "snr_db", snr_db)
    channels = () if x.ndim == 1 else (x.shape[1],)
    if snr.shape not in ((), channels):
        v.fail(
            owner,
            f"snr_db must be a scalar or have shape {channels}; got {snr.shape}.",
        )
    return np.std(x, axis=0) * 10.0 ** (-snr / 20.0)


def add_noise(x: Any, snr_db: Any, rng: np.random.Generator) -> np.ndarray:
    """Returns ``x + σ·N(0, 1)`` with σ from :func:`noise_std_for_snr` per channel.

    ``SNR = 10 log10(var(x)/σ²)`` [dB]; white Gaussian noise, independent across
    samples and channels.

    Args:
        x: (N,) or (N, c) clean signal.
        snr_db: SNR [dB], scalar or (c,).
        rng: a seeded ``np.random.Generator`` (e.g. ``np.random.default_rng(0)``).

    Returns:
        The noisy copy of x.
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"add_noise: rng must be a numpy.random.Generator; got "
            f"{type(rng).__name__} (use np.random.default_rng(seed))."
        )
    sigma = noise_std_for_snr(x, snr_db)
    x = np.asarray(x, dtype=float)
    return x + sigma * rng.standard_normal(x.shape)
