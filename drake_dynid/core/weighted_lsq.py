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
from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.lsq import (
    DEFAULT_MAX_CONDITION,
    LeastSquaresResult,
    _decompose,
    _estimate,
    _Factor,
    solve_least_squares,
)

__all__ = [
    "frequency_noise_weights",
    "solve_frequency_weighted_least_squares",
    "solve_window",
    "with_jackknife",
]


def _nonnegative_lines(
    x: np.ndarray, y: np.ndarray, index: np.ndarray, count: int
) -> tuple[np.ndarray, np.ndarray]:
    """Per group g: ``argmin ‖a + b x - y‖²`` over rows of g with a, b >= 0.

    A two-column non-negative least squares in closed form, vectorised over the
    groups (``index`` (r,) in 0..count-1): the unconstrained line when both
    coefficients are >= 0, else the best of the one-coefficient fits a = max(0,
    ȳ), b = max(0, Σxy/Σx²) and a = b = 0 (the optimum of a convex problem lies
    on one of these faces). The fitted values a + b x are unique: those of
    scipy's ``nnls`` to round-off.
    """
    member = (index == np.arange(count)[:, None]).astype(float)
    moments = np.stack((np.ones_like(x), x, y, x * x, x * y), axis=1)
    rows, sx, sy, sxx, sxy = (member @ moments).T
    mean_x, mean_y = sx / rows, sy / rows
    # Centred moments (a well-conditioned 2×2 system).
    spread = sxx - sx * mean_x
    slope = np.divide(sxy - sx * mean_y, spread, out=np.zeros(count), where=spread > 0)
    free = (mean_y - slope * mean_x, slope)
    only_b = np.divide(sxy, sxx, out=np.zeros(count), where=sxx > 0)
    zero = np.zeros(count)
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
    # Residuals scaled by their largest magnitude: squares never overflow.
    scale = float(np.max(np.abs(residual), initial=0.0))
    if scale == 0.0:
        return np.ones_like(residual)
    labels, index = np.unique(group, return_inverse=True)
    index = index.reshape(-1)
    squared = frequency**2
    a, b = _nonnegative_lines(squared, (residual / scale) ** 2, index, labels.size)
    variance = a[index] + b[index] * squared
    top = np.zeros(labels.size)
    np.maximum.at(top, index, variance)
    bottom = floor * top[index]
    weights = np.ones_like(residual)
    fitted = top[index] > 0.0
    weights[fitted] = 1.0 / (scale * np.sqrt(np.maximum(variance, bottom)[fitted]))
    return weights


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
    if covariance is not None:
        from drake_dynid.core.row_covariance import covariance_weighted_solve

        return covariance_weighted_solve(
            A,
            B,
            covariance,
            max_condition=max_condition,
            names=names,
            jackknife=jackknife,
        )
    if noise is None:
        if weighting is None:
            result = solve_least_squares(
                A, B, max_condition=max_condition, names=names
            )
            weights = None
        else:
            frequency, group = weighting
            result, weights = _frequency_weighted(
                A, B, frequency, group, max_condition, names
            )
        return with_jackknife(result, A, B, jackknife, weights)
    from drake_dynid.core.row_noise import (
        MIN_RESIDUAL_DOF,
        honest_std,
        noise_model_std,
    )

    # First pass: X̂₀ only when it is re-solved with weights (no SVD then).
    A, B, first = _decompose(
        A, B, max_condition, names, bound_first=weighting is not None
    )
    if isinstance(first, LeastSquaresResult):
        return first
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
            return second
        factor = _with_inverse(second)
    result = _estimate(factor)
    assert factor.R_inv is not None
    reuse = (factor.R_inv, factor.norms)  # honest σ and jackknife: no new QR
    relative = noise_model_std(B - A @ result.theta, noise.frequency, noise.group)
    honest = honest_std(A, B, result.theta, weights, relative, noise, factor=reuse)
    if not honest.dof >= MIN_RESIDUAL_DOF:
        nan = np.full(A.shape[1], np.nan)
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
                f"{honest.dof:.3g} effective degrees of freedom (< "
                f"{MIN_RESIDUAL_DOF:g}) for {A.shape[1]} parameters; use a longer "
                "window or more modulating functions within the excitation band."
            ),
        )
    result = dataclasses.replace(
        _with_std(result, honest.std), residual_std=honest.residual_std
    )
    return with_jackknife(result, A, B, jackknife, weights, factor=reuse)


def _with_std(result: LeastSquaresResult, std: np.ndarray) -> LeastSquaresResult:
    """``result`` with the standard deviations ``std`` (and their relative %)."""
    magnitude = np.abs(result.theta)
    relative = np.full(std.shape, np.inf)
    np.divide(100.0 * std, magnitude, out=relative, where=magnitude > 0)
    for array in (std, relative):
        array.flags.writeable = False
    return dataclasses.replace(result, std=std, relative_std_percent=relative)


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


def _with_inverse(factor: _Factor) -> _Factor:
    """``factor`` with R⁻¹ formed (once, shared by X̂, σ and the jackknife)."""
    if factor.R_inv is not None:
        return factor
    p = factor.norms.size
    return dataclasses.replace(factor, R_inv=np.linalg.inv(factor.R_aug[:p, :p]))
