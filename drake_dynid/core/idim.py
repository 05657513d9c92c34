"""Off-line inverse-dynamics identification, IDIM-LS and IDIM-WLS (docs/MATH.md §5).

The inverse dynamic model is linear in the base parameters X::

    τ(t_k) = W(q_k, v_k, v̇_k) X + e_k,      W: n × p per sample, τ: n

Sampled over a whole trajectory and stacked, ``Y = W X`` is solved by least squares.
Gautier's off-line practice, implemented here as plain functions:

1. :func:`offline_derivatives`: zero-phase Butterworth low-pass of q
   (``scipy.signal.sosfiltfilt``), then central differences for v and v̇ (off-line
   may be non-causal).
2. :func:`parallel_decimation`: the same zero-phase low-pass + down-sampling applied
   to every column of W and to τ, which removes the equation noise above the
   dynamics bandwidth while keeping ``τ = W X``.
3. :func:`idim_least_squares`: ordinary LS, or weighted LS with one weight
   ``1/σ_j`` per joint, ``σ_j`` from a per-joint OLS. Both from the equations
   reduced by QR per joint (:func:`reduce_rows`, :func:`idim_solve`): a log's
   rows can be reduced a block at a time, in memory independent of its length.

Everything is generic: W comes from any rows callable (analytic 2R rows, the
numeric Drake regressor, ...).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.lsq import (
    DEFAULT_MAX_CONDITION,
    LeastSquaresResult,
    solve_least_squares,
)

__all__ = [
    "DECIMATION_FILTER_ORDER",
    "ReducedRows",
    "default_padding",
    "default_trim",
    "idim_covariance",
    "idim_least_squares",
    "idim_solve",
    "joint_noise_fits",
    "joint_noise_std",
    "joint_noise_std_of",
    "joint_weighted",
    "offline_derivatives",
    "parallel_decimation",
    "reduce_rows",
]


def default_trim(time_step: float, cutoff_hz: float) -> int:
    """Samples dropped at each end by :func:`offline_derivatives` by default.

    ``1 + ceil(2 / (cutoff_hz · h))``: the central-difference neighbour plus two
    periods of the cutoff frequency. With the long odd padding of
    :func:`default_padding` the zero-phase filter's edge transient is small after
    two periods (noise-free 2R logs: the identified parameters agree with the
    full-trim ones to 0.1 %); a longer trim only throws away data, which costs more
    accuracy on a 20 s log than the transient (benchmarks/bench_accuracy.py).
    """
    return 1 + _cutoff_periods("default_trim", 2.0, time_step, cutoff_hz)


def default_padding(time_step: float, cutoff_hz: float) -> int:
    """Edge padding of the zero-phase filters: ``ceil(4 / (cutoff_hz · h))`` samples.

    Four periods of the cutoff, so that the filter's start-up transient dies out
    inside the padding instead of inside the data (scipy's default pads only
    ``3·(2·sections + 1)`` samples).
    """
    return _cutoff_periods("default_padding", 4.0, time_step, cutoff_hz)


def _cutoff_periods(owner: str, periods: float, time_step: Any, cutoff_hz: Any) -> int:
    """``ceil(periods / (cutoff_hz · h))``: samples in ``periods`` cutoff periods."""
    time_step = v.positive(owner, "time_step", time_step, "s")
    cutoff_hz = v.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    samples = periods / time_step / cutoff_hz
    if not samples < 2**53:
        v.fail(
            owner,
            f"cutoff_hz must give fewer than 2^53 samples per {periods:g} periods; "
            f"got cutoff_hz {cutoff_hz:g} Hz with time_step {time_step:g} s.",
        )
    return math.ceil(samples)


def offline_derivatives(
    q: Any,
    time_step: float,
    *,
    cutoff_hz: float,
    filter_order: int = 4,
    trim: int | None = None,
    padding: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zero-phase filtered positions with central-difference velocity and acceleration.

    ``q_f = sosfiltfilt(butter(filter_order, cutoff_hz), q)`` (zero phase, so the
    magnitude response is squared: effective order ``2·filter_order``), then::

        v_k = (q_f[k+1] - q_f[k-1]) / (2h)            [rad/s]
        v̇_k = (q_f[k+1] - 2 q_f[k] + q_f[k-1]) / h²   [rad/s²]

    Edge handling: q is extended at both ends by ``padding`` samples of its odd
    reflection (``2 q_0 - q_k``: continuous value and slope, so the extrapolated
    motion stays smooth), and the first and last ``trim`` samples of the result are
    **dropped** (central differences need one neighbour on each side, and the
    residual edge transient lasts about a cutoff period). The outputs therefore
    have ``N - 2·trim`` rows, row i referring to sample ``trim + i``: slice the
    torques with ``tau[trim:N - trim]`` to stay aligned.

    Args:
        q: (N,) or (N, n) positions sampled every ``time_step`` [rad or m].
        time_step: sample period h [s].
        cutoff_hz: low-pass cutoff [Hz], below the Nyquist frequency 1/(2h).
        filter_order: Butterworth order (>= 1).
        trim: samples dropped at each end (>= 1); default
            :func:`default_trim` ``(time_step, cutoff_hz)``.
        padding: odd-reflection samples added at each end before filtering
            (>= 0, at most N - 1 are used); default :func:`default_padding`.

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
    if padding is None:
        padding = default_padding(time_step, cutoff_hz)
    padding = v.integer(owner, "padding", padding, minimum=0)
    q = v.array(owner, "q", q)
    if q.ndim not in (1, 2):
        v.fail(owner, f"q must have shape (N,) or (N, n); got {q.shape}.")
    minimum = 2 * trim + 1
    if q.shape[0] < minimum:
        v.fail(
            owner,
            f"q must have at least {minimum} samples for trim {trim}; "
            f"got {q.shape[0]}.",
        )
    from scipy import signal  # lazily: a slow import, not needed by dynid identify

    sos = signal.butter(filter_order, cutoff_hz, fs=1.0 / time_step, output="sos")
    q_f = signal.sosfiltfilt(
        sos, q, axis=0, padtype="odd", padlen=min(padding, q.shape[0] - 1)
    )
    keep = slice(trim, q.shape[0] - trim)
    ahead = slice(trim + 1, q.shape[0] - trim + 1)
    behind = slice(trim - 1, q.shape[0] - trim - 1)
    velocity = (q_f[ahead] - q_f[behind]) / (2.0 * time_step)
    acceleration = (q_f[ahead] - 2.0 * q_f[keep] + q_f[behind]) / time_step**2
    return q_f[keep], velocity, acceleration


DECIMATION_FILTER_ORDER = 8
"""Butterworth order of :func:`parallel_decimation` (zero phase: effective 16)."""


def parallel_decimation(
    W: Any,
    tau: Any,
    factor: int,
    *,
    cutoff: float | None = None,
    padding: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Gautier's parallel decimation: the same low-pass + down-sampling on W and τ.

    Every column of W and τ goes through the zero-phase order-8 Butterworth
    low-pass at ``cutoff`` (``sosfiltfilt``, |H|² = 1/(1 + (f/f_d)^16)), then every
    ``factor``-th sample is kept. The filter is linear and the same on both sides,
    so ``τ = W X`` still holds on the decimated data, edges included, whatever the
    filter does to the dynamics band; it removes the equation noise above f_d.

    Edges: both ends are extended by ``padding`` samples of the **even** reflection
    (``x_{-k} = x_k``). An odd reflection would pivot on the first sample, whose
    torque noise (not in W) would then ring through the first filter periods as
    an equation error; the even one keeps the noise at its own level.

    Args:
        W: (N, n, p) or (N, p) regressor samples.
        tau: (N, n) or (N,) torques.
        factor: decimation factor (>= 1).
        cutoff: low-pass cutoff in cycles per sample (f_d·h, in (0, 0.5));
            default ``0.25 / factor`` (the decimated Nyquist frequency is then
            twice the cutoff). ``factor = 1`` with no cutoff returns copies.
        padding: even-reflection samples at each end (>= 0, at most N - 1 used);
            default four cutoff periods, ``ceil(4 / cutoff)`` (as
            :func:`default_padding`).

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
    if W.shape[0] < 1:
        v.fail(owner, "W must have at least one sample.")
    if cutoff is None:
        if factor == 1:
            return W.copy(), tau.copy()
        cutoff = 0.25 / factor
    cutoff = v.positive(owner, "cutoff", cutoff, "cycles/sample")
    if cutoff >= 0.5:
        v.fail(owner, f"cutoff must be < 0.5 cycles/sample; got {cutoff:g}.")
    if padding is None:
        padding = default_padding(1.0, cutoff)  # one "second" per sample
    padding = v.integer(owner, "padding", padding, minimum=0)
    columns = np.concatenate(
        [W.reshape(W.shape[0], -1), tau.reshape(tau.shape[0], -1)], axis=1
    )
    from scipy import signal

    sos = signal.butter(DECIMATION_FILTER_ORDER, 2.0 * cutoff, output="sos")
    filtered = signal.sosfiltfilt(
        sos, columns, axis=0, padtype="even", padlen=min(padding, W.shape[0] - 1)
    )[::factor]
    count = filtered.shape[0]
    split = math.prod(W.shape[1:])
    return (
        filtered[:, :split].reshape(count, *W.shape[1:]),
        filtered[:, split:].reshape(count, *tau.shape[1:]),
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


@dataclass(frozen=True, eq=False)
class ReducedRows:
    """The equations ``τ = W X`` of K samples reduced by QR, joint by joint.

    Attributes:
        R: (n, p + 1, p + 1) the upper-triangular R_j of ``[W_j | τ_j]`` (joint
            j's K rows; zero rows below while K < p + 1), so that
            ``‖W_j X - τ_j‖ = ‖R_j [X; -1]‖`` for every X.
        num_samples: K.
    """

    R: np.ndarray
    num_samples: int

    @property
    def num_parameters(self) -> int:
        """The number of parameters p."""
        return int(self.R.shape[2] - 1)


def reduce_rows(W: Any, tau: Any, previous: ReducedRows | None = None) -> ReducedRows:
    """``[W_j | τ_j]`` of every joint reduced to its R factor (Q never formed).

    With ``previous``, the R of ``[R_previous; new rows]``: the reduction of
    every row so far (that of the whole up to the signs of its rows, which no
    result depends on), so a log's rows can be reduced a block at a time in
    memory of one block.

    Args:
        W: (K, n, p) regressor samples [unit of τ / unit of X].
        tau: (K, n) torques.
        previous: the reduction of the earlier rows (same n and p), or None.
    """
    owner = "reduce_rows"
    W, tau = _stacked(owner, W, tau)
    samples, joints, p = W.shape
    stack = np.concatenate([W, tau[..., None]], axis=2).transpose(1, 0, 2)
    done = 0
    if previous is not None:
        if previous.R.shape != (joints, p + 1, p + 1):
            v.fail(
                owner,
                f"previous must reduce {joints} joints and {p} parameters; got R "
                f"{previous.R.shape}.",
            )
        stack = np.concatenate([previous.R, stack], axis=1)
        done = previous.num_samples
    R = np.zeros((joints, p + 1, p + 1))
    if stack.shape[1]:
        factor = np.asarray(np.linalg.qr(stack, mode="r"))
        R[:, : factor.shape[1]] = factor
    return ReducedRows(R=R, num_samples=done + samples)


def joint_noise_std_of(reduced: ReducedRows) -> np.ndarray:
    """:func:`joint_noise_std` of the reduced equations (the same numbers) [unit of τ].

    ``‖W_j X - τ_j‖² = ‖R_j[:p, :p] X - R_j[:p, p]‖² + R_j[p, p]²``: the per-joint
    least squares of R_j, its rank decided with the tolerance numpy's ``lstsq``
    gives the K × p W_j (same singular values).
    """
    return joint_noise_fits(reduced)[0]


def joint_noise_fits(reduced: ReducedRows) -> tuple[np.ndarray, np.ndarray]:
    """``(σ_j, rank_j)``: :func:`joint_noise_std_of` and each joint's fitted rank.

    σ_j = ‖ρ_j‖/√(K − rank_j) with K rows per joint. Its residual degrees of
    freedom K − rank_j are few where a joint's own fit has nearly as many
    parameters as rows (a shoulder's, on a short log): the decimated rows are
    correlated by the anti-alias low-pass, so such a fit absorbs part of the
    noise and σ_j comes out low (an iiwa7 20 s log, K = 61: joints 1-2 with
    rank 40-44 at 0.4 of the distal joints' σ_j, all joints' noise equal).
    """
    samples = reduced.num_samples
    p = reduced.num_parameters
    out = np.empty(reduced.R.shape[0])
    ranks = np.empty(reduced.R.shape[0], dtype=int)
    rcond = np.finfo(float).eps * max(samples, p)
    for j, R in enumerate(reduced.R):
        fit, _, rank, _ = np.linalg.lstsq(R[:p, :p], R[:p, p], rcond=rcond)
        if samples <= rank:
            v.fail(
                "joint_noise_std",
                f"joint {j} needs more than {rank} samples; got {samples}.",
            )
        residual = np.append(R[:p, :p] @ fit - R[:p, p], R[p, p])
        # ‖residual‖ by hypot: no square overflows (entries up to 1e308).
        out[j] = float(np.hypot.reduce(residual)) / math.sqrt(samples - rank)
        ranks[j] = rank
    return out, ranks


def joint_weighted(reduced: ReducedRows) -> np.ndarray:
    """IDIM-WLS's rows: each R_j divided by σ_j (:func:`joint_noise_std_of`).

    A joint fitted exactly (σ_j = 0, noise-free data) would get an infinite
    weight: σ_j is floored at 1e-12 of the largest (or 1 if all are zero).
    Returns the (n, p + 1, p + 1) weighted R_j.
    """
    sigma = joint_noise_std_of(reduced)
    floor = 1e-12 * sigma.max() if sigma.max() > 0 else 1.0
    return reduced.R / np.maximum(sigma, floor)[:, None, None]


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
    return joint_noise_std_of(reduce_rows(W, tau))


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
    if not (np.isfinite(W).all() and np.isfinite(tau).all()):
        # The solver names the non-finite values and their columns.
        A = W.reshape(samples * joints, p)
        return solve_least_squares(
            A, tau.reshape(-1), max_condition=max_condition, names=names
        )
    return idim_solve(
        reduce_rows(W, tau), weighted=weighted, names=names, max_condition=max_condition
    )


def idim_solve(
    reduced: ReducedRows,
    *,
    weighted: bool = False,
    names: Sequence[str] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
) -> LeastSquaresResult:
    """:func:`idim_least_squares` of equations reduced by :func:`reduce_rows`.

    IDIM-LS: ``solve_least_squares`` of the stacked R_j, counted as the K·n
    equations they reduce (``num_rows``: the same X̂, σ, condition number and
    residual σ). IDIM-WLS: each R_j divided by σ_j first (:func:`joint_weighted`).

    Args:
        reduced: the reduced equations (finite).
        weighted: IDIM-WLS instead of IDIM-LS.
        names: p parameter names.
        max_condition: largest accepted scaled condition number.
    """
    R = reduced.R
    joints, width, _ = R.shape
    # Non-finite rows: unweighted, the solver reports the non-finite columns.
    if weighted and reduced.num_samples > 0 and np.isfinite(R).all():
        R = joint_weighted(reduced)
    stack = R.reshape(joints * width, width)
    return solve_least_squares(
        stack[:, :-1],
        stack[:, -1],
        max_condition=max_condition,
        names=names,
        num_rows=reduced.num_samples * joints,
    )


def idim_covariance(reduced: ReducedRows, std: Any, *, weighted: bool = False):
    """The (p, p) covariance of :func:`idim_solve`'s estimate, its σ given.

    ``C = S K S``: S = diag(σ) (``std``: the solve's σ, e.g. Gautier's times the
    decimated rows' correlation factor of ``drake_dynid.offline``), K the
    correlation of the solve's errors, (AᵀA)⁻¹ of the stacked R_j (each divided
    by σ_j for IDIM-WLS, as :func:`idim_solve` solves) normalised to a unit
    diagonal::

        A S_A⁻¹ = Q R  (S_A: column norms),  (AᵀA)⁻¹ ∝ S_A⁻¹ R⁻¹ R⁻ᵀ S_A⁻¹

    so that ``diag(C) = σ²`` [units of the parameters, squared]. Used by
    ``dynid payload --params`` (the arm's parameters' error propagated to the
    payload's σ, docs/PAYLOAD.md §4).

    Raises:
        ValueError: ``std`` not (p,) finite and positive, or rows that do not
            determine every parameter (rank deficient).
    """
    owner = "idim_covariance"
    p = reduced.num_parameters
    sigma = v.array(owner, "std", std, (p,))
    if not (np.isfinite(sigma).all() and (sigma > 0.0).all()):
        v.fail(owner, "std must be finite and > 0 for every parameter.")
    R = reduced.R
    if weighted and reduced.num_samples > 0 and np.isfinite(R).all():
        R = joint_weighted(reduced)
    a = R.reshape(-1, p + 1)[:, :-1]
    norms = np.linalg.norm(a, axis=0)
    if not (np.isfinite(a).all() and (norms > 0.0).all()):
        v.fail(owner, "the rows must be finite, with no zero column.")
    r = np.linalg.qr(a / norms, mode="r")
    if not np.all(np.abs(np.diag(r)) > 1e-12 * np.abs(np.diag(r)).max()):
        v.fail(owner, "the rows are rank deficient: no covariance.")
    inverse = np.linalg.solve(r, np.eye(p))
    k = inverse @ inverse.T
    d = 1.0 / np.sqrt(np.diag(k))
    k = k * d[:, None] * d[None, :]
    return k * sigma[:, None] * sigma[None, :]
