"""Weighted least squares: noise growing with frequency, and the window solve.

The on-line identifier's rows (modulated equations, docs/MATH.md §3-4) carry
noise that grows with the modulating function's frequency ν (the velocity
estimate's noise) and, within a window, rows that share noise. This module
holds the two-step frequency-weighted least squares (feasible GLS: OLS, fit
σ_i² = a + b ν_i² per equation group, re-solve with 1/σ_i) and
:func:`solve_window`, the one solve of a window that the Drake block and the
core replay both call, optionally with the honest sandwich σ of
``core.row_noise``. The QR, the validity checks and Gautier's σ are those of
:mod:`drake_dynid.core.lsq`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.lsq import (
    DEFAULT_MAX_CONDITION,
    ROUND_OFF_COLUMN,
    LeastSquaresResult,
    _decompose,
    _estimate,
    _with_inverse,
    _with_std,
    solve_least_squares,
)

__all__ = [
    "WindowCovariance",
    "covariance_correlation",
    "frequency_noise_weights",
    "scaled_covariance",
    "solve_frequency_weighted_least_squares",
    "solve_window",
    "solve_windows",
    "too_few_dof",
    "window_covariance",
    "with_jackknife",
]


def _nonnegative_lines(
    x: np.ndarray, y: np.ndarray, index: np.ndarray, count: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per group g: ``argmin ‖a + b x - y‖²`` over rows of g with a, b >= 0.

    A two-column non-negative least squares in closed form, vectorised over the
    groups (``index`` (r,) in 0..count-1) and over the leading axes of ``y``
    (..., r), ``x`` (r,) shared: the unconstrained line when both coefficients
    are >= 0, else the best of the one-coefficient fits a = max(0, ȳ), b = max(0,
    Σxy/Σx²) and a = b = 0 (the optimum of a convex problem lies on one of these
    faces). The fitted values a + b x are unique: those of scipy's ``nnls`` to
    round-off. Returns a, b of shape (..., count).
    """
    member = (index == np.arange(count)[:, None]).astype(float)
    x = np.broadcast_to(x, y.shape)
    moments = np.stack((np.ones_like(y), x, y, x * x, x * y), axis=-1)
    rows, sx, sy, sxx, sxy = np.moveaxis(member @ moments, -1, 0)
    mean_x, mean_y = sx / rows, sy / rows
    # Centred moments (a well-conditioned 2×2 system).
    spread = sxx - sx * mean_x
    zero = np.zeros_like(spread)
    slope = np.divide(sxy - sx * mean_y, spread, out=zero.copy(), where=spread > 0)
    free = (mean_y - slope * mean_x, slope)
    only_b = np.divide(sxy, sxx, out=zero.copy(), where=sxx > 0)
    faces = ((np.maximum(mean_y, 0.0), zero), (zero, np.maximum(only_b, 0.0)))
    # ‖a + b x - y‖² - Σy² from the group sums, for each face.
    costs = [
        a * (a * rows + 2 * b * sx - 2 * sy) + b * (b * sxx - 2 * sxy) for a, b in faces
    ]
    use_b = costs[1] < np.minimum(costs[0], 0.0)
    use_a = ~use_b & (costs[0] < 0.0)
    best_a = np.where(use_a, faces[0][0], 0.0)
    best_b = np.where(use_b, faces[1][1], 0.0)
    feasible = (spread > 0) & (free[0] >= 0.0) & (free[1] >= 0.0)
    return np.where(feasible, free[0], best_a), np.where(feasible, free[1], best_b)


def _frequency_weights(
    residual: np.ndarray,
    frequency: np.ndarray,
    index: np.ndarray,
    count: int,
    floor: float,
) -> np.ndarray:
    """:func:`frequency_noise_weights` of the (K, r) residuals of K windows.

    ``index`` (r,): the rows' groups in 0..count-1. Returns (K, r) weights.
    """
    # Residuals scaled by their largest magnitude: squares never overflow.
    scale = np.max(np.abs(residual), axis=-1, initial=0.0)
    safe = np.where(scale > 0.0, scale, 1.0)[:, None]
    squared = frequency**2
    a, b = _nonnegative_lines(squared, (residual / safe) ** 2, index, count)
    variance = a[:, index] + b[:, index] * squared
    windows = np.arange(residual.shape[0])[:, None]
    top = np.zeros(a.shape)
    np.maximum.at(top, (windows, index), variance)
    bottom = floor * top[:, index]
    weights = np.ones_like(residual)
    fitted = (top[:, index] > 0.0) & (scale > 0.0)[:, None]
    sigma = safe * np.sqrt(np.maximum(variance, bottom))
    weights[fitted] = 1.0 / sigma[fitted]
    return weights


def frequency_noise_weights(
    residual: Any, frequency: Any, group: Any, *, floor: float = 1e-3
) -> np.ndarray:
    """Row weights ``1/σ_i`` from a noise model that grows with the row's frequency.

    For every group g of rows (one equation of the model), fits::

        σ_g²(ν) = a_g + b_g ν²,    a_g, b_g >= 0    (non-negative LS)

    to the squared residuals ``ρ_i²`` of its rows, ν_i the row's frequency index.
    A modulated row of frequency ν multiplies the measurement noise by the
    modulating function's derivative (∝ ν) wherever a velocity estimate enters, and
    by the function itself (∝ 1) for the torque: ``a`` is the torque-noise floor,
    ``b ν²`` the velocity-noise share. σ_i² is floored at ``floor`` times the group's
    largest value (a fit that is zero somewhere must not give an infinite weight).
    The non-negative fits are in closed form for all groups at once (no scipy).

    Args:
        residual: (r,) first-pass residuals ``B - A X̂`` [unit of B].
        frequency: (r,) frequency index ν of each row (>= 0) [dimensionless].
        group: (r,) integer group of each row.
        floor: relative floor of σ² in (0, 1].

    Returns:
        (r,) weights ``1/σ_i`` [1/unit of B] (all ones for a group whose residuals
        are all zero).
    """
    owner = "frequency_noise_weights"
    residual = v.array(owner, "residual", residual)
    frequency = v.array(owner, "frequency", frequency, shape=residual.shape)
    group = np.asarray(group)
    if residual.ndim != 1 or group.shape != residual.shape:
        v.fail(
            owner,
            f"residual, frequency and group must have one shape (r,); got "
            f"{residual.shape}, {frequency.shape} and {group.shape}.",
        )
    floor = v.positive(owner, "floor", floor)
    if floor > 1.0:
        v.fail(owner, f"floor must be in (0, 1]; got {floor:g}.")
    labels, index = np.unique(group, return_inverse=True)
    return _frequency_weights(
        residual[None], frequency, index.reshape(-1), labels.size, floor
    )[0]


def solve_frequency_weighted_least_squares(
    A: Any,
    B: Any,
    frequency: Any,
    group: Any,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
) -> LeastSquaresResult:
    """Two-step weighted least squares for rows whose noise grows with frequency.

    1. ``X̂₀ = argmin ‖B - A X‖`` (the QR and validity checks of
       :func:`solve_least_squares`; X̂₀ from R, without its σ);
    2. weights ``w = 1/σ`` from :func:`frequency_noise_weights` of its residuals;
    3. ``X̂ = argmin ‖w (B - A X)‖`` (:func:`solve_weighted_least_squares`), with
       Gautier's σ from the weighted problem (C_X = σ_ρ² (Aᵀ W² A)⁻¹).

    A feasible generalised least squares: with the modulated equations of the
    on-line identifier (docs/MATH.md §3), whose high-ℓ rows carry most of the
    velocity-estimate noise, it halved the inertial error on the 2R benchmark
    (benchmarks/bench_accuracy.py). When step 1 is not valid, its result (that of
    :func:`solve_least_squares`) is returned unchanged.

    Args:
        A: (r, p) regressor.
        B: (r,) observations.
        frequency: (r,) frequency index ν of each row.
        group: (r,) integer noise group of each row (one per model equation).
        max_condition: largest accepted scaled condition number.
        names: p parameter names.
    """
    return _frequency_weighted(A, B, frequency, group, max_condition, names)[0]


def _frequency_weighted(
    A: Any,
    B: Any,
    frequency: Any,
    group: Any,
    max_condition: float,
    names: Sequence[str] | None,
) -> tuple[LeastSquaresResult, np.ndarray | None]:
    """:func:`solve_frequency_weighted_least_squares` and its weights (None: OLS)."""
    A, B, first = _decompose(A, B, max_condition, names, bound_first=True)
    if isinstance(first, LeastSquaresResult):
        return first, None
    p = first.norms.size
    theta = (first.R_inv @ first.R_aug[:p, p]) * first.b_scale / first.norms
    weights = frequency_noise_weights(B - A @ theta, frequency, group)
    _, _, second = _decompose(A * weights[:, None], B * weights, max_condition, names)
    result = second if isinstance(second, LeastSquaresResult) else _estimate(second)
    return result, weights


def solve_window(
    A: Any,
    B: Any,
    weighting: tuple[Any, Any] | None = None,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    noise: Any = None,
    jackknife: Any = None,
    covariance: Any = None,
) -> LeastSquaresResult:
    """The on-line identifier's solve of one window (block and core replay alike).

    Args:
        A: (r, p) regressor.
        B: (r,) observations.
        weighting: None for ordinary least squares (:func:`solve_least_squares`),
            or ``(frequency, group)`` of the rows for
            :func:`solve_frequency_weighted_least_squares`.
        max_condition: largest accepted scaled condition number.
        names: p parameter names.
        noise: the rows' ``core.row_noise.RowNoise`` (their frequencies, groups
            and correlation): σ is then the honest sandwich σ of
            ``core.row_noise.honest_std`` (correlated rows, noise growing with the
            frequency), and a window whose residual has fewer than
            ``core.row_noise.MIN_RESIDUAL_DOF`` effective degrees of freedom is
            not valid. None: Gautier's σ (independent rows of equal noise).
        jackknife: None, or the (r,) group of every row (e.g. its pair of
            modulating functions): σ is then, per parameter, the larger of the σ
            above and the delete-one-group jackknife's
            (``core.jackknife.jackknife_std``, with the solve's weights;
            docs/MATH.md §4).
        covariance: None, or θ -> Σ (r, r), the rows' noise covariance at θ (the
            window's ``core.row_covariance.row_covariance``): the solve is then
            the covariance-weighted one
            (``core.row_covariance.covariance_weighted_solve``, with the
            jackknife on the whitened rows) and ``weighting`` and ``noise`` are
            not used.
    """
    return _solve_window(
        A, B, weighting, max_condition, names, noise, jackknife, covariance, False
    )[0]


@dataclasses.dataclass(frozen=True, eq=False)
class WindowCovariance:
    """:func:`window_covariance`'s outcome: the solve and its full covariance.

    Attributes:
        result: the window's :func:`solve_window` result (the same θ̂ and σ).
        correlation: (p, p) K, the correlation of the estimator's covariance
            model (NaN when ``result`` is not valid).
        covariance: (p, p) S K S with S = diag(``result.std``): its diagonal is
            σ² exactly [units of the parameters, squared].
        method: the covariance model K comes from: ``"sandwich"`` (the honest
            sandwich of the frequency-weighted or ordinary solve,
            ``core.row_noise``), ``"gls"`` (the covariance-weighted solve's
            Gautier covariance of the whitened rows), ``"gautier"`` (σ_ρ²
            (ÃᵀÃ)⁻¹ of the (weighted) rows).
    """

    result: LeastSquaresResult
    correlation: np.ndarray
    covariance: np.ndarray
    method: str


def window_covariance(
    A: Any,
    B: Any,
    weighting: tuple[Any, Any] | None = None,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    noise: Any = None,
    jackknife: Any = None,
    covariance: Any = None,
) -> WindowCovariance:
    """:func:`solve_window` (same arguments, same result) and its full covariance.

    The covariance model of the estimator the solve uses, every entry, not only
    its diagonal: with ``noise`` the sandwich (``core.row_noise``,
    ``C_X = σ̂² S⁻¹ (ÃᵀÃ)⁻¹ M (ÃᵀÃ)⁻¹ S⁻¹``, Ã the weighted rows); with
    ``covariance`` the generalised least squares' ``σ̂_ρ² (ÃᵀÃ)⁻¹``, Ã the
    whitened rows; else Gautier's ``σ_ρ² (ÃᵀÃ)⁻¹`` of the (frequency-weighted or
    ordinary) rows. K is its correlation, and the returned covariance ``S K S``
    with S = diag(σ) the σ the solve reports: where the jackknife's σ is the
    larger one (``jackknife``), the row and column of that parameter are scaled
    up with it (first order: the jackknife's own cross terms are not used, its
    few groups determine a p × p matrix poorly). One more p × p product than
    the solve: for the final estimate, not every solve.
    """
    result, model, method = _solve_window(
        A, B, weighting, max_condition, names, noise, jackknife, covariance, True
    )
    p = result.theta.size
    if not result.valid or model is None:
        nan = np.full((p, p), np.nan)
        return WindowCovariance(result, nan, nan.copy(), method)
    correlation = covariance_correlation(model)
    std = np.asarray(result.std, dtype=float)
    return WindowCovariance(
        result, correlation, scaled_covariance(correlation, std), method
    )


def covariance_correlation(covariance: np.ndarray) -> np.ndarray:
    """K = D⁻¹ C D⁻¹ (D = diag(√C_ii)), symmetric, unit diagonal exactly.

    A zero or non-finite variance gets a unit row and column of zeros off the
    diagonal (no correlation known).
    """
    covariance = 0.5 * (covariance + covariance.T)
    scale = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    good = np.isfinite(scale) & (scale > 0.0)
    safe = np.where(good, scale, 1.0)
    with np.errstate(invalid="ignore"):
        correlation = covariance / np.outer(safe, safe)
    correlation[~good, :] = 0.0
    correlation[:, ~good] = 0.0
    correlation = np.clip(correlation, -1.0, 1.0)
    np.fill_diagonal(correlation, 1.0)
    return correlation


def scaled_covariance(correlation: np.ndarray, std: np.ndarray) -> np.ndarray:
    """S K S, S = diag(``std``): the covariance whose diagonal is σ² exactly.

    Symmetric by construction; positive semi-definite when K is.
    """
    std = np.asarray(std, dtype=float)
    out = std[:, None] * correlation * std[None, :]
    out = 0.5 * (out + out.T)
    np.fill_diagonal(out, std * std)
    return out


def _gautier_covariance(Aw: np.ndarray, residual_std: float) -> np.ndarray:
    """σ_ρ² (ÃᵀÃ)⁻¹ of the (weighted or whitened) rows Ã, by the column-scaled QR."""
    norms = np.sqrt(np.einsum("ij,ij->j", Aw, Aw))
    R = np.asarray(np.linalg.qr(Aw / norms, mode="r"))
    R_inv = np.linalg.inv(R)
    inverse = (R_inv @ R_inv.T) / np.outer(norms, norms)
    return residual_std**2 * inverse


def _solve_window(
    A: Any,
    B: Any,
    weighting: tuple[Any, Any] | None,
    max_condition: float,
    names: Sequence[str] | None,
    noise: Any,
    jackknife: Any,
    covariance: Any,
    full: bool,
) -> tuple[LeastSquaresResult, np.ndarray | None, str]:
    """:func:`solve_window`; with ``full`` also the estimator's (p, p) covariance.

    Returns ``(result, C or None, method)`` (:class:`WindowCovariance`); C is
    None without ``full`` or when the result is not valid.
    """
    if covariance is not None:
        from drake_dynid.core.row_covariance import covariance_weighted_fit

        result, white_a, _ = covariance_weighted_fit(
            A,
            B,
            covariance,
            max_condition=max_condition,
            names=names,
            jackknife=jackknife,
        )
        model = None
        if full and result.valid and white_a is not None:
            model = _gautier_covariance(white_a, result.residual_std)
        return result, model, "gls"
    if noise is None:
        if weighting is None:
            result = solve_least_squares(A, B, max_condition=max_condition, names=names)
            weights = None
        else:
            frequency, group = weighting
            result, weights = _frequency_weighted(
                A, B, frequency, group, max_condition, names
            )
        model = None
        if full and result.valid:
            Aw = np.asarray(A, dtype=float)
            if weights is not None:
                Aw = Aw * weights[:, None]
            model = _gautier_covariance(Aw, result.residual_std)
        return with_jackknife(result, A, B, jackknife, weights), model, "gautier"
    from drake_dynid.core.row_noise import (
        MIN_RESIDUAL_DOF,
        honest_std,
        noise_model_std,
        sandwich_covariance,
    )

    # First pass: X̂₀ only when it is re-solved with weights (no SVD then).
    A, B, first = _decompose(
        A, B, max_condition, names, bound_first=weighting is not None
    )
    if isinstance(first, LeastSquaresResult):
        return first, None, "sandwich"
    if A.shape[0] != noise.num_rows:
        v.fail(
            "solve_window",
            f"noise must describe the {A.shape[0]} rows of A; got {noise.num_rows}.",
        )
    first = _with_inverse(first)
    p = first.norms.size
    theta = (first.R_inv @ first.R_aug[:p, p]) * first.b_scale / first.norms
    model = frequency_noise_weights(B - A @ theta, noise.frequency, noise.group)
    if weighting is None:
        weights = np.ones_like(B)
        factor = first
    else:
        weights = model
        _, _, second = _decompose(
            A * weights[:, None], B * weights, max_condition, names
        )
        if isinstance(second, LeastSquaresResult):
            return second, None, "sandwich"
        factor = _with_inverse(second)
    result = _estimate(factor)
    assert factor.R_inv is not None
    reuse = (factor.R_inv, factor.norms)  # honest σ and jackknife: no new QR
    relative = noise_model_std(B - A @ result.theta, noise.frequency, noise.group)
    honest = honest_std(A, B, result.theta, weights, relative, noise, factor=reuse)
    if not honest.dof >= MIN_RESIDUAL_DOF:
        return too_few_dof(result, honest.dof), None, "sandwich"
    result = dataclasses.replace(
        _with_std(result, honest.std), residual_std=honest.residual_std
    )
    full_covariance = None
    if full:
        full_covariance = sandwich_covariance(
            A, B, result.theta, weights, relative, noise, *reuse
        )
    return (
        with_jackknife(result, A, B, jackknife, weights, factor=reuse),
        full_covariance,
        "sandwich",
    )


def too_few_dof(result: LeastSquaresResult, dof: float) -> LeastSquaresResult:
    """``result`` made invalid: ``dof`` < ``core.row_noise.MIN_RESIDUAL_DOF``.

    The residual's effective degrees of freedom cannot give an honest σ; the
    reason says so and what to change.
    """
    from drake_dynid.core.row_noise import MIN_RESIDUAL_DOF

    nan = np.full(result.theta.shape, np.nan)
    nan.flags.writeable = False
    return dataclasses.replace(
        result,
        theta=nan,
        std=nan,
        relative_std_percent=nan,
        residual_std=np.nan,
        valid=False,
        reason=(
            f"too few independent equations for an honest σ: the residual has "
            f"{dof:.3g} effective degrees of freedom (< {MIN_RESIDUAL_DOF:g}) for "
            f"{result.theta.size} parameters; use a longer window or more "
            "modulating functions within the excitation band."
        ),
    )


def with_jackknife(
    result: LeastSquaresResult,
    A: Any,
    B: Any,
    groups: Any,
    weights: Any,
    factor: tuple[np.ndarray, np.ndarray] | None = None,
) -> LeastSquaresResult:
    """σ = max(result's σ, the delete-one-group jackknife's), per parameter.

    A NaN jackknife (fewer than two groups, or a group whose removal leaves θ
    undetermined) keeps the result's σ. ``factor``: the solve's (R⁻¹, norms).
    """
    if groups is None or not result.valid:
        return result
    from drake_dynid.core.jackknife import jackknife_std

    spread = jackknife_std(A, B, groups, weights=weights, factor=factor)
    return _with_std(result, np.fmax(result.std, spread))


def _stacked_factor(
    A: np.ndarray, B: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """R of ``[A S⁻¹ | B/b]`` for each of K windows: (R_aug, norms S, b).

    The scaling of ``core.lsq._decompose`` (columns by their norms, B by its
    largest magnitude), every window's QR in one stacked call. The caller has
    checked every entry finite and every column non-zero.
    """
    peak = np.max(np.abs(A), axis=1)
    scaled = A / peak[:, None, :]
    norms = peak * np.sqrt(np.einsum("kij,kij->kj", scaled, scaled))
    b_scale = np.max(np.abs(B), axis=1)
    b_scale[b_scale == 0.0] = 1.0
    augmented = np.empty((A.shape[0], A.shape[1], A.shape[2] + 1))
    np.divide(A, norms[:, None, :], out=augmented[..., :-1])
    np.divide(B, b_scale[:, None], out=augmented[..., -1])
    return np.asarray(np.linalg.qr(augmented, mode="r")), norms, b_scale


def _invertible(R_aug: np.ndarray, p: int) -> np.ndarray:
    """Whether each triangular R (K, ≥p, p + 1) has no zero on its diagonal."""
    return (np.diagonal(R_aug[:, :p, :p], axis1=1, axis2=2) != 0.0).all(axis=1)


def _stacked_solve(
    A: np.ndarray,
    B: np.ndarray,
    weighting: tuple[Any, Any] | None,
    max_condition: float,
    noise: Any,
    jackknife: Any,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The steps of :func:`solve_window` (with ``noise``) for K windows, stacked.

    Returns ``(done, values)``: which windows took the common path (finite,
    first pass shown valid by the condition bound, full rank, condition <=
    ``max_condition``, enough residual degrees of freedom), and their theta,
    std, condition and residual_std (rows of the windows done, in order). The
    others are left to :func:`solve_window`, which gives their reasons.
    """
    from drake_dynid.core.jackknife import stacked_jackknife_std
    from drake_dynid.core.row_noise import (
        MIN_RESIDUAL_DOF,
        noise_model_std,
        stacked_honest_std,
    )

    _, rows, p = A.shape
    done = np.isfinite(A).all(axis=(1, 2)) & np.isfinite(B).all(axis=1)
    # Windows that may hold a zero or round-off column (core.lsq: a norm at most
    # ROUND_OFF_COLUMN of the largest; peak <= norm <= sqrt(rows)·peak) go to
    # solve_window, which names them.
    peaks = np.max(np.abs(A[done]), axis=1)  # (windows, p)
    floor = ROUND_OFF_COLUMN * math.sqrt(rows) * np.max(peaks, axis=1, initial=0.0)
    floor = np.maximum(floor, np.finfo(float).tiny)
    done[done] = (peaks > floor[:, None]).all(axis=1)
    if rows <= p:
        done[:] = False
    eps = np.finfo(float).eps
    frequency = np.asarray(noise.frequency, dtype=float)
    labels, index = np.unique(noise.group, return_inverse=True)
    index = index.reshape(-1)

    def keep(mask: np.ndarray, *arrays: np.ndarray) -> list[np.ndarray]:
        done[np.flatnonzero(done)[~mask]] = False
        return [x[mask] for x in arrays]

    def fit(A, B, R_inv, R_aug, b_scale, norms) -> tuple[np.ndarray, np.ndarray]:
        """(X̂, B - A X̂) of stacked windows, from their scaled QR."""
        theta = (R_inv @ R_aug[:, :p, p, None])[..., 0] * (b_scale[:, None] / norms)
        return theta, B - (A @ theta[..., None])[..., 0]

    A, B = A[done], B[done]
    if not done.any():
        return done, {}
    try:
        if weighting is None:
            weights = np.ones_like(B)
        else:
            # First pass: X̂₀ when the bound ‖R‖_F ‖R⁻¹‖_F shows it valid (an
            # exactly singular R, a zero on its diagonal, to solve_window).
            R_aug, norms, b_scale = _stacked_factor(A, B)
            A, B, R_aug, norms, b_scale = keep(
                _invertible(R_aug, p), A, B, R_aug, norms, b_scale
            )
            if not done.any():
                return done, {}
            with np.errstate(all="ignore"):  # a huge R⁻¹ only fails the bound
                R_inv = np.linalg.inv(R_aug[:, :p, :p])
                bound = np.linalg.norm(R_aug[:, :p, :p], axis=(1, 2)) * np.linalg.norm(
                    R_inv, axis=(1, 2)
                )
            limit = min(max_condition, 1.0 / (max(rows, p) * eps))
            A, B, R_aug, norms, b_scale, R_inv = keep(
                bound <= limit, A, B, R_aug, norms, b_scale, R_inv
            )
            if not done.any():
                return done, {}
            _, residual = fit(A, B, R_inv, R_aug, b_scale, norms)
            weights = _frequency_weights(residual, frequency, index, labels.size, 1e-3)
        Aw, Bw = A * weights[..., None], B * weights
        R_aug, norms, b_scale = _stacked_factor(Aw, Bw)
        singular = np.linalg.svd(R_aug[:, :p, :p], compute_uv=False)
        tolerance = singular[:, 0] * max(rows, p) * eps
        with np.errstate(divide="ignore"):
            condition = singular[:, 0] / singular[:, -1]
        good = (singular[:, -1] > tolerance) & (condition <= max_condition)
        good &= _invertible(R_aug, p)
        A, B, weights, Aw, Bw, R_aug, norms, b_scale, condition = keep(
            good, A, B, weights, Aw, Bw, R_aug, norms, b_scale, condition
        )
        if not done.any():
            return done, {}
        R_inv = np.linalg.inv(R_aug[:, :p, :p])
    except np.linalg.LinAlgError:  # LAPACK failed (no convergence): one by one
        done[:] = False
        return done, {}
    theta, residual = fit(A, B, R_inv, R_aug, b_scale, norms)
    relative = noise_model_std(residual, frequency, noise.group)
    std, residual_std, dof = stacked_honest_std(
        A, B, theta, weights, relative, noise, R_inv, norms
    )
    enough = dof >= MIN_RESIDUAL_DOF
    values = dict(theta=theta, std=std, condition=condition, residual_std=residual_std)
    if jackknife is not None and np.unique(jackknife).size >= 2:
        Q = (Aw / norms[:, None, :]) @ R_inv
        left = Bw - (Q @ (np.swapaxes(Q, 1, 2) @ Bw[..., None]))[..., 0]
        spread = stacked_jackknife_std(Q, left, np.asarray(jackknife), R_inv, norms)
        values["std"] = np.fmax(std, spread)
    arrays = keep(enough, *values.values())
    return done, dict(zip(values, arrays, strict=True))


def solve_windows(
    A: Any,
    B: Any,
    weighting: tuple[Any, Any] | None = None,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    noise: Any = None,
    jackknife: Any = None,
) -> list[LeastSquaresResult]:
    """:func:`solve_window` of K windows with the same rows: the same results.

    With ``noise`` (the honest σ) the common path of every window (the two QR,
    the noise models, the sandwich σ and the jackknife) runs in stacked numpy
    calls, a fraction of K separate solves' Python overhead; a window off that
    path (non-finite, an exactly singular R, rank deficient, ill-conditioned,
    too few residual degrees of freedom, or a first pass the condition bound
    does not show valid) is solved by :func:`solve_window`, which gives its
    reason (the whole stack only when LAPACK itself fails). Without ``noise``,
    :func:`solve_window` one window at a time.

    Args:
        A: (K, r, p) regressors.
        B: (K, r) observations.
        weighting: as :func:`solve_window`.
        max_condition: as :func:`solve_window`.
        names: as :func:`solve_window`.
        noise: as :func:`solve_window` (one for every window).
        jackknife: as :func:`solve_window` (one for every window).

    Returns:
        K :class:`~drake_dynid.core.lsq.LeastSquaresResult`, in order.
    """
    owner = "solve_windows"
    A = v.array(owner, "A", A, finite=False)
    if A.ndim != 3 or A.shape[2] < 1:
        v.fail(owner, f"A must have shape (K, rows, p) with p >= 1; got {A.shape}.")
    K, rows, p = A.shape
    B = v.array(owner, "B", B, shape=(K, rows), finite=False)
    max_condition = v.greater_than(owner, "max_condition", max_condition, 1.0)
    if names is not None and len(names) != p:
        v.fail(owner, f"names must have {p} entries; got {len(names)}.")
    if jackknife is not None and np.shape(jackknife) != (rows,):
        v.fail(
            owner,
            f"jackknife must have shape ({rows},); got {np.shape(jackknife)}.",
        )

    def one(k: int) -> LeastSquaresResult:
        return solve_window(
            A[k],
            B[k],
            weighting,
            max_condition=max_condition,
            names=names,
            noise=noise,
            jackknife=jackknife,
        )

    if noise is None or K == 0 or rows != noise.num_rows:
        return [one(k) for k in range(K)]
    done, values = _stacked_solve(A, B, weighting, max_condition, noise, jackknife)
    labels = (
        tuple(f"x{i}" for i in range(p))
        if names is None
        else tuple(str(name) for name in names)
    )
    out: list[LeastSquaresResult] = []
    row = 0
    for k in range(K):
        if not done[k]:
            out.append(one(k))
            continue
        theta, std = values["theta"][row], values["std"][row]
        theta.flags.writeable = False
        result = LeastSquaresResult(
            theta=theta,
            std=std,
            relative_std_percent=std,
            condition_number=float(values["condition"][row]),
            rank=p,
            residual_std=float(values["residual_std"][row]),
            num_rows=rows,
            valid=True,
            reason="",
            names=labels,
            unidentified=(),
            unidentified_indices=(),
        )
        out.append(_with_std(result, std))
        row += 1
    return out
