"""Off-line inverse-dynamics identification, IDIM-LS and IDIM-WLS (MATH.md §5).

The inverse dynamic model is linear in the base parameters X::

    τ(t_k) = W(q_k, v_k, v̇_k) X + e_k,      W: n × p per sample, τ: n

Sampled over a whole trajectory and stacked, ``Y = W X`` is solved by least squares.
Gautier's off-line practice, implemented here as plain functions:

1. :func:`offline_derivatives`: zero-phase Butterworth low-pass of q
   (``scipy.signal.sosfiltfilt``), then central differences for v and v̇ (off-line
   may be non-causal).
2. :func:`parallel_decimation`: the same low-pass + down-sampling applied to every
   column of W and to τ (``scipy.signal.decimate``, zero phase), which removes the
   torque ripple above the dynamics bandwidth while keeping ``τ = W X``.
3. :func:`idim_least_squares`: ordinary LS, or weighted LS with one weight
   ``1/σ_j`` per joint, ``σ_j`` from a per-joint OLS.

Everything is generic: W comes from any rows callable (analytic 2R rows, the
numeric Drake regressor, ...).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import signal

from drake_dynid.core import _validate as v
from drake_dynid.core.lsq import (
    DEFAULT_MAX_CONDITION,
    LeastSquaresResult,
    solve_least_squares,
    solve_weighted_least_squares,
)

__all__ = [
    "default_trim",
    "idim_least_squares",
    "joint_noise_std",
    "offline_derivatives",
    "parallel_decimation",
]


def default_trim(time_step: float, cutoff_hz: float) -> int:
    """Samples dropped at each end by :func:`offline_derivatives` by default.

    ``1 + ceil(4 / (cutoff_hz · h))``: the central-difference neighbour plus four
    periods of the cutoff frequency. The zero-phase filter's edge transient (the
    odd padding of ``sosfiltfilt`` flips the curvature at the ends) decays by about
    10× per cutoff period; after four periods the velocity and acceleration edge
    errors are ~1e-4 of the signal (measured on sinusoids).
    """
    owner = "default_trim"
    time_step = v.positive(owner, "time_step", time_step, "s")
    cutoff_hz = v.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    return 1 + math.ceil(4.0 / (cutoff_hz * time_step))


def offline_derivatives(
    q: Any,
    time_step: float,
    *,
    cutoff_hz: float,
    filter_order: int = 4,
    trim: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zero-phase filtered positions with central-difference velocity and acceleration.

    ``q_f = sosfiltfilt(butter(filter_order, cutoff_hz), q)`` (zero phase, so the
    magnitude response is squared: effective order ``2·filter_order``), then::

        v_k = (q_f[k+1] - q_f[k-1]) / (2h)            [rad/s]
        v̇_k = (q_f[k+1] - 2 q_f[k] + q_f[k-1]) / h²   [rad/s²]

    Edge handling: the first and last ``trim`` samples are **dropped** (central
    differences need one neighbour on each side, and the filter's edge transients
    last a few cutoff periods, see :func:`default_trim`). The outputs therefore
    have ``N - 2·trim`` rows, row i referring to sample ``trim + i``: slice the
    torques with ``tau[trim:N - trim]`` to stay aligned.

    Args:
        q: (N,) or (N, n) positions sampled every ``time_step`` [rad or m].
        time_step: sample period h [s].
        cutoff_hz: low-pass cutoff [Hz], below the Nyquist frequency 1/(2h).
        filter_order: Butterworth order (>= 1).
        trim: samples dropped at each end (>= 1); default
            :func:`default_trim` ``(time_step, cutoff_hz)``.

    Returns:
        ``(q_f, v, vdot)``, each (N - 2·trim, n) (or (N - 2·trim,) for 1-D q).
    """
    owner = "offline_derivatives"
    time_step = v.positive(owner, "time_step", time_step, "s")
    nyquist = 0.5 / time_step
    cutoff_hz = v.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    if cutoff_hz >= nyquist:
        v.fail(
            owner,
            f"cutoff_hz must be < the Nyquist frequency {nyquist:g} [Hz]; "
            f"got {cutoff_hz:g}.",
        )
    filter_order = v.integer(owner, "filter_order", filter_order, minimum=1)
    if trim is None:
        trim = default_trim(time_step, cutoff_hz)
    trim = v.integer(owner, "trim", trim, minimum=1)
    q = v.array(owner, "q", q)
    if q.ndim not in (1, 2):
        v.fail(owner, f"q must have shape (N,) or (N, n); got {q.shape}.")
    sos = signal.butter(filter_order, cutoff_hz, fs=1.0 / time_step, output="sos")
    # sosfiltfilt pads with 3·(2·sections + 1) samples; require the trimmed output
    # to keep at least one sample.
    minimum = max(2 * trim + 1, 3 * (2 * len(sos) + 1) + 1)
    if q.shape[0] < minimum:
        v.fail(
            owner,
            f"q must have at least {minimum} samples for trim {trim} and filter "
            f"order {filter_order}; got {q.shape[0]}.",
        )
    q_f = signal.sosfiltfilt(sos, q, axis=0)
    keep = slice(trim, q.shape[0] - trim)
    ahead = slice(trim + 1, q.shape[0] - trim + 1)
    behind = slice(trim - 1, q.shape[0] - trim - 1)
    velocity = (q_f[ahead] - q_f[behind]) / (2.0 * time_step)
    acceleration = (q_f[ahead] - 2.0 * q_f[keep] + q_f[behind]) / time_step**2
    return q_f[keep], velocity, acceleration


def parallel_decimation(W: Any, tau: Any, factor: int) -> tuple[np.ndarray, np.ndarray]:
    """Gautier's parallel decimation: the same low-pass + down-sampling on W and τ.

    Every column of W and τ goes through ``scipy.signal.decimate(x, factor,
    zero_phase=True)`` (order-8 Chebyshev type I low-pass at 0.8·(fs/2)/factor,
    applied forwards and backwards, then every ``factor``-th sample). The filter is
    linear, so ``τ = W X`` still holds on the decimated data.

    Args:
        W: (N, n, p) or (N, p) regressor samples.
        tau: (N, n) or (N,) torques.
        factor: decimation factor (>= 1; 1 returns copies). scipy advises calling
            it in stages for factors above 13.

    Returns:
        ``(W_d, tau_d)`` with ``ceil(N / factor)`` samples.
    """
    owner = "parallel_decimation"
    W = v.array(owner, "W", W)
    tau = v.array(owner, "tau", tau)
    factor = v.integer(owner, "factor", factor, minimum=1)
    if W.ndim not in (2, 3) or tau.shape != W.shape[:-1]:
        v.fail(
            owner,
            f"W must have shape (N, n, p) and tau (N, n) (or (N, p) and (N,)); "
            f"got W {W.shape} and tau {tau.shape}.",
        )
    if factor == 1:
        return W.copy(), tau.copy()
    minimum = 28  # filtfilt's default padding for the order-8 IIR (3·9) + 1
    if W.shape[0] < minimum:
        v.fail(
            owner,
            f"W must have at least {minimum} samples to decimate; got {W.shape[0]}.",
        )
    columns = np.concatenate(
        [W.reshape(W.shape[0], -1), tau.reshape(tau.shape[0], -1)], axis=1
    )
    decimated = signal.decimate(columns, factor, axis=0, zero_phase=True)
    count = decimated.shape[0]
    split = math.prod(W.shape[1:])
    return (
        decimated[:, :split].reshape(count, *W.shape[1:]),
        decimated[:, split:].reshape(count, *tau.shape[1:]),
    )


def _stacked(owner: str, W: Any, tau: Any) -> tuple[np.ndarray, np.ndarray]:
    W = v.array(owner, "W", W, finite=False)
    tau = v.array(owner, "tau", tau, finite=False)
    if W.ndim == 2 and tau.ndim == 1:
        W, tau = W[:, None, :], tau[:, None]
    if W.ndim != 3 or tau.shape != W.shape[:2]:
        v.fail(
            owner,
            f"W must have shape (N, n, p) and tau (N, n); got W {W.shape} and "
            f"tau {tau.shape}.",
        )
    return W, tau


def joint_noise_std(W: Any, tau: Any) -> np.ndarray:
    """Per-joint error std σ_j from an OLS on joint j's equations alone (Gautier).

    ``σ_j² = ‖τ_j - W_j X̂_j‖² / (N - r_j)`` with ``X̂_j`` the least-squares
    solution of joint j's rows ``τ_j = W_j X_j`` on its own (minimum-norm if
    W_j does not excite every parameter; used only for its residual) and
    ``r_j = rank(W_j)``.

    Args:
        W: (N, n, p) regressor samples.
        tau: (N, n) torques.

    Returns:
        (n,) σ_j [unit of τ_j].
    """
    W, tau = _stacked("joint_noise_std", W, tau)
    samples, joints, _ = W.shape
    out = np.empty(joints)
    for j in range(joints):
        fit, _, rank, _ = np.linalg.lstsq(W[:, j, :], tau[:, j], rcond=None)
        if samples <= rank:
            v.fail(
                "joint_noise_std",
                f"joint {j} needs more than {rank} samples; got {samples}.",
            )
        residual = tau[:, j] - W[:, j, :] @ fit
        out[j] = math.sqrt(float(residual @ residual) / (samples - rank))
    return out


def idim_least_squares(
    W: Any,
    tau: Any,
    *,
    weighted: bool = False,
    names: Sequence[str] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
) -> LeastSquaresResult:
    """IDIM-LS / IDIM-WLS estimate of X from ``τ = W X`` over a whole trajectory.

    The rows are stacked sample-major, joint-minor (row ``k·n + j`` is joint j at
    sample k). IDIM-LS solves ``min ‖τ - W X‖``; IDIM-WLS (Gautier) first estimates
    each joint's error std σ_j (:func:`joint_noise_std`) and solves
    ``min Σ_j ‖(τ_j - W_j X)/σ_j‖²``, so a joint with a noisy torque counts less.
    With WLS, ``result.residual_std`` is the weighted one (≈ 1).

    Args:
        W: (N, n, p) regressor samples [unit of τ / unit of X].
        tau: (N, n) torques [N·m or N].
        weighted: IDIM-WLS instead of IDIM-LS.
        names: p parameter names.
        max_condition: largest accepted scaled condition number.

    Returns:
        The :class:`~drake_dynid.core.lsq.LeastSquaresResult` (check ``valid``).
    """
    W, tau = _stacked("idim_least_squares", W, tau)
    samples, joints, p = W.shape
    A = W.reshape(samples * joints, p)
    B = tau.reshape(samples * joints)
    if not weighted:
        return solve_least_squares(A, B, max_condition=max_condition, names=names)
    if not (np.isfinite(W).all() and np.isfinite(tau).all()):
        # Let the solver report the non-finite input.
        return solve_least_squares(A, B, max_condition=max_condition, names=names)
    sigma = joint_noise_std(W, tau)
    # A joint fitted exactly (σ_j = 0, noise-free data) would get an infinite
    # weight: floor σ_j at 1e-12 of the largest (or 1 if all are zero).
    floor = 1e-12 * sigma.max() if sigma.max() > 0 else 1.0
    weights = np.tile(1.0 / np.maximum(sigma, floor), samples)
    return solve_weighted_least_squares(
        A, B, weights, max_condition=max_condition, names=names
    )
