r"""The payload solve's row noise, pooled across windows (docs/PAYLOAD.md §3).

The payload's short window has only R1 = 8 rows per equation (4 modulating
functions, real and imaginary parts). A noise model fitted to one window's
residuals (``core.row_noise``: 3 coefficients per equation; the weights: 2) is
fitted to the very residuals it then weighs: the sandwich σ came out 0.3-0.8
times the Monte-Carlo spread, and the delete-one-function jackknife that covered
it (4 groups, below ``core.online.MIN_JACKKNIFE_GROUPS``) overstated the mass σ
up to 40 times, scattering 230 times between noise seeds. Here the row noise is
learned across windows instead, and only one level per equation is taken from
the current window:

**Pool.** For every row i (equation j, modulating row ℓ) the leverage-corrected
squared residuals ``e_i² = ρ_i²/(1 - h_i)`` [unit of B²] of the accepted windows
are averaged with exponential forgetting (memory :data:`POOL_MEMORY` solves)::

    P_i ← λ P_i + min(e_i², c v_i),   N ← λ N + 1,   λ = exp(-1/POOL_MEMORY)
    v_i = model of (k_c P_i/N)  (``core.row_noise.noise_model_std``:
          a_j + b_j ν² + c_j ν⁴ per equation, fitted to the pooled moments)

with the clip c = :data:`POOL_CLIP` (k_c = 1/0.9 makes the clipped mean of a χ²₁
unbiased). A window whose mean ``e_i²/v_i`` exceeds :data:`POOL_GATE` (the
payload changed inside it: its residual is the change, not noise) is not pooled,
unless :data:`POOL_LOCK` windows in a row were refused (a lasting change of the
noise is learned).

**Solve.** With ``v`` the pool's variances (ones before the first window):

1. θ̂₀ = argmin ‖(B - A θ)/√v‖; per equation the level
   ``κ0_j² = Σ_j ρ_i²/v_i / Σ_j (1 - h_i)``, clipped to [0.1, 100] (one number per
   equation from its 8 rows: a joint passing zero velocity in this window is
   noisier than the pool's average);
2. θ̂ = argmin ‖W (B - A θ)‖, ``W_i = √(λ_ν / (v_i κ0_j²))`` (``weighting``
   None: W = 1, ordinary least squares), with the **dilution factor** λ_ν of
   the rows of modulating frequency ν (:func:`dilution`)::

       S_ν = Σ_{i: ν_i = ν} K_i² / Σ_{i: ν_i = ν} v_i,   λ_ν = S_ν² / (S_ν² + S₀²)

   (K: the known column, the arm's own rows [unit of B]; S₀ =
   :data:`DILUTION_SNR`). The payload's columns carry the noise of the velocity
   estimate as the known column does (errors in variables): where the arm's
   motion at ν is within S₀ of the rows' noise power (a slow arm's highest ν),
   A's own noise correlates with the residual and biases θ̂ beyond its σ
   (on the slow iiwa, the first moments' error with A's noise was twice that
   with the same rows on noise-free A). λ leaves the frequencies that carry
   the motion (S_ν ≫ S₀) as they were;
3. the sandwich covariance (docs/MATH.md §4) with the pooled rows' covariance,
   a per-frequency scale (>= t₀) and a per-equation scale (>= 1) taken from
   this window's residuals::

       C_θ = (ÃᵀÃ)⁻¹ (Σ_j s_j² Ã_jᵀ Σ̃_j Ã_j) (ÃᵀÃ)⁻¹,   Ã = W A,
       Σ̃_j = W_j U_j C U_j W_j   (C: ``RowNoise.correlation``),
       U_i = √(v_i t_ν),  t_ν = max(t₀, Σ_ν W_i² ρ_i² / Σ_ν W_i² v_i (1 - h_i))
       s_j² = max(1, ‖W_j ρ_j‖² / (tr Σ̃_j - tr((ÃᵀÃ)⁻¹ Ã_jᵀ Σ̃_j Ã_j)))

   (σ [units of θ] = √diag C_θ; Σ_ν over the rows of frequency ν, all
   equations; t₀ = :data:`FREQUENCY_SCALE_FLOOR`). With the arm's error
   columns K_L of the window (``core.payload.PayloadRows.arm_factor``: the
   known column's error is K_L z, z ~ N(0, 1_k)), their image through the
   solve is added, exact to first order (the weights held)::

       C_θ += G K_L K_Lᵀ Gᵀ,   G = (ÃᵀÃ)⁻¹ Ãᵀ W   (θ̂ = G B)

   (docs/PAYLOAD.md §4). The weights' estimation
   enters through t_ν and s_j: a window whose rows are noisier than the pool
   says inflates σ, one quieter at ν lowers it, by √t₀ at most. On a slow arm the
   noise of a frequency changes from window to window (the velocity estimate's
   noise seen through each modulating function): without t_ν the slow iiwa's
   first moments' σ was 0.63 of their RMS error, the UR5's mass σ 0.68.

Before :data:`MIN_POOLED_WINDOWS` windows are pooled the estimate is not valid
(``core.payload_step.payload_update``: the noise model has no data yet).

Measured (benchmarks/_accuracy_payload.py, 16 noise seeds, all parameters):
err/σ p90 0.7-2.0 and the seeds' σ within a factor 1.2-6.8 of each other, where
the one-window model with the 4-group jackknife gave σ/RMS error up to 42 (the
UR5's mass) and a σ spread up to 230 (docs/PAYLOAD.md §3).

Pure numpy; the state is a :class:`PooledNoise` (immutable).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.lsq import (
    LeastSquaresResult,
    _decompose,
    _estimate,
    _Factor,
    _with_inverse,
    _with_std,
)
from drake_dynid.core.row_noise import (
    MIN_RESIDUAL_DOF,
    RowNoise,
    honest_std,
    noise_model_std,
)

__all__ = [
    "DILUTION_SNR",
    "FREQUENCY_SCALE_FLOOR",
    "MIN_POOLED_WINDOWS",
    "POOL_CLIP",
    "POOL_GATE",
    "POOL_LOCK",
    "POOL_MEMORY",
    "PooledNoise",
    "PooledSolve",
    "dilution",
    "pooled_noise_init",
    "pooled_solve",
    "pooled_variance",
]

#: Memory of the pool in solves (λ = exp(-1/POOL_MEMORY)): 2 s at the payload's
#: 50 ms update period, about 3 windows of 0.75 s.
POOL_MEMORY = 40.0

#: Windows pooled before the estimate is reported valid (0.5 s at 50 ms): a pool of
#: fewer overlapping windows is about one window's residuals again.
MIN_POOLED_WINDOWS = 10

#: A row's squared residual enters the pool clipped at POOL_CLIP times its pooled
#: variance (a burst raises the pool by at most 1 + (POOL_CLIP - 1)/POOL_MEMORY
#: per solve).
POOL_CLIP = 4.0

#: k_c: the mean of min(χ²₁, 4u) is u at u = 0.9, so the clipped pool is 0.9 times
#: the variance; dividing by 0.9 unbiases it.
_CLIP_BIAS = 0.9

#: A window whose mean e_i²/v_i exceeds POOL_GATE is not pooled (a change of the
#: payload inside the window).
POOL_GATE = 4.0

#: ... unless that many windows in a row were refused: then the noise changed.
POOL_LOCK = 30

_LEVEL_RANGE = (0.1, 100.0)

#: S₀ of the dilution factor λ_ν = S_ν²/(S_ν² + S₀²) (module docstring, step 2):
#: the power ratio of the arm's rows to their noise below which a modulating
#: frequency is weighed down (benchmarks/_accuracy_payload.py, 16 seeds: 300
#: takes the slow iiwa's err/σ p90 from 2.66 to 2.02 and its errors down
#: 10-15 %, the UR5's mass p90 from 2.91 to 2.29; 1000 also weighs down the fast
#: iiwa's ν = 4).
DILUTION_SNR = 300.0

#: Floor of the per-frequency scale t_ν of the sandwich (module docstring, step 3):
#: a window quieter than the pool at ν lowers σ down to √0.7 of the pool's
#: (bench_accuracy.py --robot payload, 16 seeds: the closed loop's σ/RMS error
#: 2.1-2.9 -> 1.8-2.4; 0.5: 1.5-2.1 but the UR5's mass σ 0.65 of its error).
FREQUENCY_SCALE_FLOOR = 0.7


@dataclass(frozen=True, eq=False)
class PooledNoise:
    """The pooled squared residuals of the rows (module docstring).

    Attributes:
        moments: (r,) P_i, the forgotten sums of e_i² [unit of B²].
        weight: N, the forgotten count of the windows pooled.
        count: windows pooled since the start.
        refused: windows refused in a row by the gate.
    """

    moments: np.ndarray
    weight: float
    count: int
    refused: int

    @property
    def num_rows(self) -> int:
        """r, the rows of a window."""
        return int(self.moments.shape[0])

    @property
    def ready(self) -> bool:
        """Whether :data:`MIN_POOLED_WINDOWS` windows are pooled."""
        return self.count >= MIN_POOLED_WINDOWS


@dataclass(frozen=True, eq=False)
class PooledSolve:
    """Outcome of :func:`pooled_solve`.

    Attributes:
        result: the ``core.lsq`` result with the sandwich σ (an invalid one: rank
            deficient or ill-conditioned).
        weights: (r,) the row weights W of the solve (None when not valid).
        correlation: (p, p) correlation of θ̂'s errors, the sandwich covariance
            normalised to a unit diagonal (None when not valid).
        pool: the pool with this window (unchanged when not valid).
    """

    result: LeastSquaresResult
    weights: np.ndarray | None
    correlation: np.ndarray | None
    pool: PooledNoise


def pooled_noise_init(num_rows: int) -> PooledNoise:
    """The empty pool of ``num_rows`` rows."""
    r = check.integer("pooled_noise_init", "num_rows", num_rows, 1)
    moments = np.zeros(r)
    moments.flags.writeable = False
    return PooledNoise(moments=moments, weight=0.0, count=0, refused=0)


def pooled_variance(pool: PooledNoise, noise: RowNoise) -> np.ndarray:
    """The modelled noise variance v (r,) of every row [unit of B²].

    ``noise_model_std`` (a_j + b_j ν² + c_j ν⁴ per equation) of the pooled mean
    squares k_c P_i/N; ones while the pool is empty.
    """
    if pool.count == 0 or pool.weight <= 0.0:
        return np.ones(pool.num_rows)
    mean = pool.moments / (_CLIP_BIAS * pool.weight)
    std = noise_model_std(np.sqrt(mean), noise.frequency, noise.group)
    return std * std


def dilution(known: Any, variance: Any, frequency: Any) -> np.ndarray:
    """λ (r,), the dilution factor of every row (module docstring, step 2).

    Args:
        known: (r,) the window's known column K (the arm's rows) [unit of B].
        variance: (r,) the rows' modelled noise variances v [unit of B²].
        frequency: (r,) the rows' modulating frequency index ν.

    Returns:
        λ_ν = S_ν²/(S_ν² + S₀²) of each row's ν, S_ν = Σ K_i²/Σ v_i over the
        rows of that ν (all equations), S₀ = :data:`DILUTION_SNR`.
    """
    known = np.asarray(known, dtype=float)
    _, index = np.unique(np.asarray(frequency), return_inverse=True)
    index = index.reshape(-1)
    power = np.bincount(index, known * known)
    noise = np.bincount(index, np.asarray(variance, dtype=float))
    ratio = np.zeros_like(power)
    np.divide(power, noise, out=ratio, where=noise > 0.0)
    ratio = ratio * ratio
    return (ratio / (ratio + DILUTION_SNR * DILUTION_SNR))[index]


def _leverage(factor: _Factor, weighted: np.ndarray) -> np.ndarray:
    """h_i, the diagonal of the hat matrix of the weighted solve (r,)."""
    q = (weighted / factor.norms) @ factor.R_inv
    return np.einsum("ij,ij->i", q, q)


def pooled_solve(
    A: Any,
    B: Any,
    pool: PooledNoise,
    noise: RowNoise,
    *,
    weighted: bool = True,
    max_condition: float,
    names: Any = None,
    known: Any = None,
    arm: Any = None,
) -> PooledSolve:
    """One window's solve with the pooled noise (module docstring, steps 1-3).

    Args:
        A: (r, p) the window's payload columns (the known column eliminated).
        B: (r,) right-hand side [N·m·s and N·m rows of the bank].
        pool: the pool before this window.
        noise: the rows' ``core.row_noise.RowNoise`` (frequencies, equations,
            correlation of one equation's rows).
        weighted: False: ordinary least squares (σ still the pooled sandwich).
        max_condition: largest accepted condition number (both solves).
        names: p parameter names (messages).
        known: (r,) the window's known column (the arm's rows, [unit of B]) for
            the dilution factor (:func:`dilution`), or None: λ = 1.
        arm: (r, k) the window's arm's error columns K_L [unit of B] (module
            docstring, step 3), or None: the arm taken as exact.

    Returns:
        :class:`PooledSolve` (an invalid result, rank deficient or
        ill-conditioned, leaves the pool unchanged).
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    if A.shape[0] != noise.num_rows or pool.num_rows != noise.num_rows:
        check.fail(
            "pooled_solve",
            f"A, noise and pool must describe the same rows; got {A.shape[0]}, "
            f"{noise.num_rows} and {pool.num_rows}.",
        )
    group = np.asarray(noise.group)
    labels, index = np.unique(group, return_inverse=True)
    index = index.reshape(-1)
    count = labels.size
    variance = pooled_variance(pool, noise)
    scale = 1.0 / np.sqrt(variance)
    if weighted:
        # 1. One level per equation from this window, on the pool's shape.
        _, _, first = _decompose(A * scale[:, None], B * scale, max_condition, names)
        if isinstance(first, LeastSquaresResult):
            return PooledSolve(first, None, None, pool)
        first = _with_inverse(first)
        theta0 = _estimate(first).theta
        rho0 = (B - A @ theta0) * scale
        free0 = 1.0 - _leverage(first, A * scale[:, None])
        level = np.bincount(index, rho0 * rho0, count) / np.maximum(
            np.bincount(index, free0, count), 0.5
        )
        level = np.clip(level, *_LEVEL_RANGE)
        weights = scale / np.sqrt(level[index])
        if known is not None and pool.count > 0:
            weights = weights * np.sqrt(dilution(known, variance, noise.frequency))
    else:
        weights = np.ones_like(B)
    # 2. The solve.
    Aw = A * weights[:, None]
    _, _, second = _decompose(Aw, B * weights, max_condition, names)
    if isinstance(second, LeastSquaresResult):
        return PooledSolve(second, None, None, pool)
    factor = _with_inverse(second)
    result = _estimate(factor)
    residual = B - A @ result.theta
    leverage = _leverage(factor, Aw)
    # 3. Sandwich with the pooled rows' covariance, per-equation scale >= 1.
    R_inv, norms = factor.R_inv, factor.norms
    assert R_inv is not None
    # The residual's effective degrees of freedom (Satterthwaite, core.row_noise):
    # too few, and the per-equation scales are guesses (the window is refused as
    # core.weighted_lsq.solve_window refuses it).
    dof = honest_std(
        A, B, result.theta, weights, np.sqrt(variance), noise, factor=(R_inv, norms)
    ).dof
    if not dof >= MIN_RESIDUAL_DOF:
        from drake_dynid.core.weighted_lsq import too_few_dof

        return PooledSolve(too_few_dof(result, dof), None, None, pool)
    As = (Aw / norms) @ R_inv  # Q: the bread is then the identity
    ws = weights * np.sqrt(variance)
    # Per modulating frequency (all equations), this window's residual over the
    # pool's expectation, never below FREQUENCY_SCALE_FLOOR (module docstring,
    # step 3); the per-equation scale below stays >= 1 against it.
    _, at = np.unique(np.asarray(noise.frequency), return_inverse=True)
    at = at.reshape(-1)
    observed_nu = np.bincount(at, (weights * residual) ** 2)
    expected_nu = np.bincount(at, ws * ws * np.maximum(1.0 - leverage, 0.05))
    excess = np.ones_like(observed_nu)
    np.divide(observed_nu, expected_nu, out=excess, where=expected_nu > 0.0)
    ws = ws * np.sqrt(np.maximum(FREQUENCY_SCALE_FLOOR, excess))[at]
    F = noise.factor  # (R1, k), F Fᵀ = C
    p = A.shape[1]
    meat = np.zeros((p, p))
    for j in range(count):
        rows = np.flatnonzero(index == j)
        SF = ws[rows, None] * F  # Σ̃_j = (S F)(S F)ᵀ
        Y = SF.T @ As[rows]
        meat_j = Y.T @ Y
        expected = float(np.sum(SF * SF)) - float(np.trace(meat_j))
        observed = float(np.sum((weights[rows] * residual[rows]) ** 2))
        ratio = observed / expected if expected > 0.0 else np.inf
        meat += max(1.0, ratio) * meat_j
    if arm is not None:
        # The arm's error K_L z moves θ̂ by -G K_L z: in the scaled columns,
        # -R⁻¹ Qᵀ W K_L z (As = Q).
        image = As.T @ (weights[:, None] * np.asarray(arm, dtype=float))
        meat += image @ image.T
    covariance = R_inv @ meat @ R_inv.T
    diagonal = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    std = diagonal / norms
    safe = np.where(diagonal > 0.0, diagonal, 1.0)
    correlation = covariance / safe[:, None] / safe[None, :]
    result = _with_std(result, std)
    correlation.flags.writeable = False
    return PooledSolve(
        result, weights, correlation, _pooled(pool, residual, leverage, variance)
    )


def _pooled(
    pool: PooledNoise,
    residual: np.ndarray,
    leverage: np.ndarray,
    variance: np.ndarray,
) -> PooledNoise:
    """The pool with one more window (module docstring: clip, gate, forget)."""
    squared = residual * residual / np.maximum(1.0 - leverage, 0.05)
    decay = float(np.exp(-1.0 / POOL_MEMORY))
    if pool.count == 0:
        moments, weight = squared, 1.0
    else:
        if np.mean(squared / variance) > POOL_GATE and pool.refused < POOL_LOCK:
            return dataclasses.replace(pool, refused=pool.refused + 1)
        moments = decay * pool.moments + np.minimum(squared, POOL_CLIP * variance)
        weight = decay * pool.weight + 1.0
    moments = np.array(moments, dtype=float)
    moments.flags.writeable = False
    return PooledNoise(
        moments=moments, weight=float(weight), count=pool.count + 1, refused=0
    )
