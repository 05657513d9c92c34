r"""The linearised noise covariance of a window's rows, and the solve it weights.

A window's rows (docs/MATH.md §3) are ``r_i = B_i - A_i θ = Σ_k [Mg_i(k)(y - Gθ)_k +
Mġ_i(k)(Dθ)_k]`` over its bank samples k, with ``Mg_i(k)``, ``Mġ_i(k)`` the
quadrature weights of the row's modulating function g_ℓ and of ġ_ℓ at sample k (real
or imaginary part) and ``(D, G, y)`` the model rows of the filtered signals
``s = (q̂, v̂, τ̂)``. White noise of std σ_q,j on the position and σ_τ,j on the torque
of joint j reaches the bank samples (t_k = t_0 + kD, D signal periods apart) through
the matched filters' taps c₀ (smoothing) and c₁ (velocity):

    δq̂_j(k) = Σ_m c₀[m] e_q,j(t_k - m),   δv̂_j(k) = Σ_m c₁[m] e_q,j(t_k - m),
    δτ̂_j(k) = Σ_m c₀[m] e_τ,j(t_k - m),

so a row changes, to first order in the noise, by

    δr_i = Σ_k Σ_s J_s[i, k] δs(k),
    J_s[i, k] = Mg_i(k) ∂(y - Gθ)_k/∂s + Mġ_i(k) ∂(Dθ)_k/∂s

and the rows' covariance is

    Σ = Σ_j [ σ_q,j² Σ_{s,s' ∈ {q̂_j, v̂_j}} J_s Γ_ss' J_s'ᵀ + σ_τ,j² J_τ̂j Γ_00 J_τ̂jᵀ ],
    Γ_ss'[k, k'] = Γ_ss'(k - k') = Σ_u c_s[u + (k - k')D] c_s'[u]

(Γ is banded: the filters are a few bank steps long). The derivatives ∂/∂s are
central differences of the row provider at the window's samples over ±√3 σ_s, σ_s
the noise std of the signal s (σ_q‖c₀‖₂, σ_q‖c₁‖₂, σ_τ‖c₀‖₂): the three-point
Gauss-Hermite rule of d/ds E[rows(s + σ_s z)], z ~ N(0, 1) (a statistical
linearisation: exact for the rows' terms up to cubic, and it spreads the jump of
a Coulomb sign(v̂) over the noise that makes it flip, where a tangent would see
nothing, or 1/step at a sample next to v̂ = 0). Uncompensated rows: the
noise-bias compensation of ``core.noise_bias`` changes them at second order only.
Σ depends on θ through them. For the power model the noise of v̂ enters
through the momentum ``∂(Dθ)/∂v̂ = M(q̂)v̂`` times ġ_ℓ and through ``∂(vᵀτ)/∂v̂ = τ̂``
times g_ℓ: its size follows the motion, and rows of different ℓ share it (one noise
process seen through every g_ℓ). Σ is far from diagonal, which is why a weighting
per row (``core.weighted_lsq``) cannot use it.

The covariance-weighted solve (``OnlineSettings.weighting = "covariance"``) is a
feasible generalised least squares: θ̂₀ by ordinary least squares, then
:data:`ITERATIONS` times ``θ̂ = argmin ‖L⁻¹(B - Aθ)‖`` with ``Σ(θ̂) = L Lᵀ``
(Cholesky), σ Gautier's on the whitened rows (``core.lsq``): with the true Σ the
whitened residual has unit variance and σ̂_ρ ≈ 1 scales Σ when the stds given are
off. Only the ratios of the stds change θ̂. First order only: the squared noise
(E[v̂²] = v² + σ_v², ``core.noise_bias``) is a bias, not part of Σ. Cost per solve:
6n batch evaluations of the rows at the window's K samples and 3n products of
(r × K) by (K × r) matrices.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.equations import direct_fourier_integrals, modulated_integrals
from drake_dynid.core.lsq import (
    DEFAULT_MAX_CONDITION,
    LeastSquaresResult,
    solve_least_squares,
)

__all__ = [
    "DIFFERENCE_STEP",
    "ITERATIONS",
    "CovarianceDesign",
    "covariance_design",
    "covariance_weighted_fit",
    "covariance_weighted_solve",
    "row_covariance",
    "sample_sensitivities",
]

_OWNER = "row_covariance"

#: Re-solves with Σ(θ̂) after the ordinary least squares: on the paper's 2R at SNR
#: 30 dB (benchmarks/bench_accuracy.py) a third changes the friction error by 0.1 %.
ITERATIONS = 2

#: Central-difference step of the rows' derivatives for a noise-free signal,
#: relative to 1 + max|s| over the window (the others: √3 times their noise std).
DIFFERENCE_STEP = 1e-6


@dataclass(frozen=True, eq=False)
class CovarianceDesign:
    """What :func:`row_covariance` needs besides the window (fixed per identifier).

    Attributes:
        model: ``"power"`` or ``"lagrangian"`` (the rows' kind).
        num_equations: m, equations per sample.
        g_map: (2L, K) the real rows' quadrature weights of g_ℓ at the window's K
            bank samples (rows ℓ-major, then real/imaginary part).
        dg_map: (2L, K) the same of ġ_ℓ.
        keep: (2L·m,) the rows ``core.equations.assemble_equations`` keeps.
        kernels: (3, 2M + 1) Γ_00, Γ_01, Γ_11 at the bank lags -M..M.
        position_std: (n,) σ_q per joint [rad or m].
        torque_std: (n,) σ_τ per joint [N·m or N].
        signal_std: (3n,) the noise std of q̂_j, v̂_j, τ̂_j (the filters' gains).
    """

    model: str
    num_equations: int
    g_map: np.ndarray
    dg_map: np.ndarray
    keep: np.ndarray
    kernels: np.ndarray
    position_std: np.ndarray
    torque_std: np.ndarray
    signal_std: np.ndarray

    @property
    def num_samples(self) -> int:
        """K, the bank samples of a window."""
        return int(self.g_map.shape[1])

    @property
    def num_rows(self) -> int:
        """r, the rows of the window's equations."""
        return int(np.count_nonzero(self.keep))


def _lag_kernel(a: np.ndarray, b: np.ndarray, step: int, lags: int) -> np.ndarray:
    """Γ(Δ) = Σ_u a[u + Δ·step] b[u] for Δ = -lags..lags."""
    full = np.correlate(a, b, mode="full")  # full[i]: lag i - (len(b) - 1)
    out = np.zeros(2 * lags + 1)
    for index, delta in enumerate(range(-lags, lags + 1)):
        position = delta * step + len(b) - 1
        if 0 <= position < full.size:
            out[index] = full[position]
    return out


def _stds(name: str, value: Any, n: int, unit: str) -> np.ndarray:
    array = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
    if not np.all(np.isfinite(array)) or np.any(array < 0.0):
        check.fail(
            "covariance_design",
            f"{name} must be finite and >= 0 [{unit}], one or one per joint ({n}); "
            f"got {value!r}.",
        )
    array.flags.writeable = False
    return array


def covariance_design(
    bank: Any,
    num_equations: int,
    smooth_taps: Any,
    velocity_taps: Any,
    decimation: int,
    position_std: Any,
    torque_std: Any,
    *,
    model: str,
    num_joints: int,
) -> CovarianceDesign:
    """The fixed part of the rows' covariance (module docstring).

    Args:
        bank: the window's ``FourierBank``.
        num_equations: m.
        smooth_taps: c₀, the smoothing filter's taps (newest sample first).
        velocity_taps: c₁, the velocity filter's taps [1/s].
        decimation: D, signal periods per bank step.
        position_std: σ_q, one or one per joint [rad or m].
        torque_std: σ_τ, one or one per joint [N·m or N].
        model: the rows' kind.
        num_joints: n.
    """
    owner = "covariance_design"
    m = check.integer(owner, "num_equations", num_equations, minimum=1)
    step = check.integer(owner, "decimation", decimation, minimum=1)
    n = check.integer(owner, "num_joints", num_joints, minimum=1)
    c0 = np.asarray(smooth_taps, dtype=float)
    c1 = np.asarray(velocity_taps, dtype=float)
    sigma_q = _stds("position_std", position_std, n, "rad or m")
    sigma_tau = _stds("torque_std", torque_std, n, "N·m or N")
    if not (sigma_q.any() or sigma_tau.any()):
        check.fail(owner, "position_std and torque_std must not both be 0.")
    count = bank.num_samples
    integrals = direct_fourier_integrals(bank, np.eye(count))
    maps = []
    for derivative in (0, 1):
        weights = modulated_integrals(bank, integrals, derivative=derivative)
        maps.append(np.stack([weights.real, weights.imag], axis=1).reshape(-1, count))
    lags = max(c0.size, c1.size) // step + 1
    kernels = np.array(
        [
            _lag_kernel(c0, c0, step, lags),
            _lag_kernel(c0, c1, step, lags),
            _lag_kernel(c1, c1, step, lags),
        ]
    )
    keep = np.repeat(bank.row_mask.ravel(), m)
    gains = np.sqrt(kernels[[0, 2], lags])  # ‖c₀‖₂, ‖c₁‖₂
    signal_std = np.concatenate(
        [sigma_q * gains[0], sigma_q * gains[1], sigma_tau * gains[0]]
    )
    for array in (*maps, keep, kernels, signal_std):
        array.flags.writeable = False
    return CovarianceDesign(
        model, m, maps[0], maps[1], keep, kernels, sigma_q, sigma_tau, signal_std
    )


def sample_sensitivities(
    rows: Any,
    model: str,
    q_hat: Any,
    v_hat: Any,
    tau_hat: Any,
    theta: Any,
    signal_std: Any = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``(E, Y)``: ∂(Dθ)/∂s and ∂(y - Gθ)/∂s at each sample, each (K, m, 3n).

    s runs over q̂_1..q̂_n, v̂_1..v̂_n, τ̂_1..τ̂_n; central differences of
    ``rows.model_rows`` (one batch call per step) over ±√3 σ_s (``signal_std``
    (3n,), module docstring), or :data:`DIFFERENCE_STEP`·(1 + max|s|) where σ_s
    is 0 or not given.
    """
    signals = [np.asarray(x, dtype=float) for x in (q_hat, v_hat, tau_hat)]
    theta = np.asarray(theta, dtype=float)
    count, n = signals[0].shape
    spread = np.zeros(3 * n) if signal_std is None else np.asarray(signal_std)
    e_out = y_out = np.empty(0)
    for part in range(3):
        for joint in range(n):
            step = math.sqrt(3.0) * float(spread[part * n + joint])
            if not step > 0.0:
                step = DIFFERENCE_STEP * (1.0 + np.abs(signals[part][:, joint]).max())
            values = []
            for sign in (1.0, -1.0):
                moved = [x.copy() for x in signals]
                moved[part][:, joint] += sign * step
                d, g, y = rows.model_rows(model, *moved)
                values.append((np.asarray(d) @ theta, np.asarray(y) - g @ theta))
            column = part * n + joint
            if not e_out.size:
                shape = (count, values[0][1].shape[-1], 3 * n)
                e_out, y_out = np.empty(shape), np.empty(shape)
            e_out[:, :, column] = (values[0][0] - values[1][0]) / (2.0 * step)
            y_out[:, :, column] = (values[0][1] - values[1][1]) / (2.0 * step)
    return e_out, y_out


def _lagged(values: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Z[:, k] = Σ_Δ kernel(Δ) values[:, k - Δ] (zero outside the window).

    ``kernel`` holds the odd number 2M + 1 of lags -M..M; a convolution along the
    samples (``scipy.ndimage.convolve1d``, 3× numpy's shifted sums).
    """
    from scipy.ndimage import convolve1d

    if kernel.size % 2 != 1:
        check.fail(_OWNER, f"a lag kernel must be odd-sized; got {kernel.size}.")
    return convolve1d(values, kernel, axis=1, mode="constant", cval=0.0)


def row_covariance(
    design: CovarianceDesign,
    rows: Any,
    q_hat: Any,
    v_hat: Any,
    tau_hat: Any,
    theta: Any,
) -> np.ndarray:
    """Σ, the (r, r) covariance of the window's rows at θ (module docstring).

    Args:
        design: :func:`covariance_design` of the identifier.
        rows: the row provider (uncompensated).
        q_hat: (K, n) the filtered positions at the window's bank samples, oldest
            first [rad or m].
        v_hat: (K, n) the velocities there [rad/s or m/s].
        tau_hat: (K, n) the filtered torques there [N·m or N].
        theta: (p,) the parameters at which the rows are linearised.
    """
    count = design.num_samples
    for name, value in (("q_hat", q_hat), ("v_hat", v_hat), ("tau_hat", tau_hat)):
        shape = np.shape(value)
        if len(shape) != 2 or shape[0] != count:
            check.fail(
                _OWNER,
                f"{name} must hold the window's {count} bank samples (K, n); got "
                f"shape {shape}.",
            )
    e_sens, y_sens = sample_sensitivities(
        rows, design.model, q_hat, v_hat, tau_hat, theta, design.signal_std
    )
    n = e_sens.shape[2] // 3

    def jacobian(column: int) -> np.ndarray:
        full = (
            design.g_map[:, None, :] * y_sens[:, :, column].T[None]
            + design.dg_map[:, None, :] * e_sens[:, :, column].T[None]
        )  # (2L, m, K): rows ℓ-major, then part, then equation
        return full.reshape(-1, count)[design.keep]

    g00, g01, g11 = design.kernels
    cov = np.zeros((design.num_rows, design.num_rows))
    for joint in range(n):
        sigma_q, sigma_tau = design.position_std[joint], design.torque_std[joint]
        if sigma_q > 0.0:
            jq, jv = jacobian(joint), jacobian(n + joint)
            zq = _lagged(jq, g00) + _lagged(jv, g01)
            zv = _lagged(jq, g01[::-1]) + _lagged(jv, g11)
            cov += sigma_q**2 * (jq @ zq.T + jv @ zv.T)
        if sigma_tau > 0.0:
            jt = jacobian(2 * n + joint)
            cov += sigma_tau**2 * (jt @ _lagged(jt, g00).T)
    return 0.5 * (cov + cov.T)


def _whitened_solve(
    A: np.ndarray,
    B: np.ndarray,
    cov: np.ndarray,
    max_condition: float,
    names: Sequence[str] | None,
) -> tuple[LeastSquaresResult, np.ndarray, np.ndarray]:
    """``argmin ‖L⁻¹(B - Aθ)‖`` with Σ = L Lᵀ (a ridge of 1e-12·mean diag if needed).

    Returns the result and the whitened ``L⁻¹A``, ``L⁻¹B``.
    """
    try:
        factor = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        ridge = 1e-12 * float(np.mean(np.diag(cov))) + 1e-300
        factor = np.linalg.cholesky(cov + ridge * np.eye(cov.shape[0]))
    from scipy.linalg import solve_triangular

    white_a = solve_triangular(factor, A, lower=True)
    white_b = solve_triangular(factor, B, lower=True)
    result = solve_least_squares(
        white_a, white_b, max_condition=max_condition, names=names
    )
    return result, white_a, white_b


def covariance_weighted_solve(
    A: Any,
    B: Any,
    covariance: Callable[[np.ndarray], np.ndarray],
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    iterations: int = ITERATIONS,
    jackknife: Any = None,
) -> LeastSquaresResult:
    """The covariance-weighted solve of one window (module docstring).

    θ̂₀ by ordinary least squares; then ``iterations`` times the generalised
    least squares with ``covariance(θ̂)``. An invalid step's result is returned
    as it is (the ordinary solve's, or the whitened one's: its condition number
    is the whitened, column-scaled A's).

    Args:
        A: (r, p) the window's regressor.
        B: (r,) its right-hand side.
        covariance: θ -> Σ (r, r) of the rows, e.g. :func:`row_covariance` of the
            window's samples.
        max_condition: largest accepted scaled condition number.
        names: p parameter names.
        iterations: re-solves with Σ(θ̂), >= 1.
        jackknife: None, or the (r,) group of every row (its pair of modulating
            functions): σ is then, per parameter, the larger of the generalised
            least squares' σ and the delete-one-group jackknife's on the whitened
            rows (``core.jackknife``). Σ models the noise only; the jackknife
            also sees a misfit that differs between modulating functions (the
            filtered rows' bias on a multi-joint arm: on the iiwa7 benchmark the
            GLS σ alone gives err/σ p90 3-5, with the jackknife 1.3-1.6).
    """
    return covariance_weighted_fit(
        A,
        B,
        covariance,
        max_condition=max_condition,
        names=names,
        iterations=iterations,
        jackknife=jackknife,
    )[0]


def covariance_weighted_fit(
    A: Any,
    B: Any,
    covariance: Callable[[np.ndarray], np.ndarray],
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    iterations: int = ITERATIONS,
    jackknife: Any = None,
) -> tuple[LeastSquaresResult, np.ndarray | None, np.ndarray | None]:
    """:func:`covariance_weighted_solve` and its whitened rows ``L⁻¹A``, ``L⁻¹B``.

    The rows are None when the ordinary first solve is not valid. The
    generalised least squares' covariance is ``σ̂_ρ² (ÃᵀÃ)⁻¹`` of the whitened
    Ã = L⁻¹A (``core.weighted_lsq.window_covariance``).
    """
    iterations = check.integer(_OWNER, "iterations", iterations, minimum=1)
    result = solve_least_squares(A, B, max_condition=max_condition, names=names)
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    white_a = white_b = None
    for _ in range(iterations):
        if not result.valid:
            return result, white_a, white_b
        cov = np.asarray(covariance(np.asarray(result.theta)), dtype=float)
        if cov.shape != (A.shape[0], A.shape[0]) or not np.all(np.isfinite(cov)):
            check.fail(
                _OWNER,
                f"covariance must return a finite ({A.shape[0]}, {A.shape[0]}) "
                f"matrix; got shape {cov.shape}.",
            )
        result, white_a, white_b = _whitened_solve(A, B, cov, max_condition, names)
    if jackknife is None or white_a is None:
        return result, white_a, white_b
    from drake_dynid.core.weighted_lsq import with_jackknife

    return with_jackknife(result, white_a, white_b, jackknife, None), white_a, white_b
