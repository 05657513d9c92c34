"""Least squares by QR with Gautier's standard deviations and a scaled condition number.

Solves the over-determined system ``A X ≈ B`` (docs/MATH.md §4)::

    X̂ = argmin ‖B - A X‖₂            A: r × p, B: r, by QR of the column-scaled A
    σ_ρ² = ‖B - A X̂‖² / (r - p)       residual variance [unit of B]²
    C_X = σ_ρ² (AᵀA)⁻¹ = σ_ρ² S⁻¹ R⁻¹ R⁻ᵀ S⁻¹    (A S⁻¹ = Q R, S: column norms)
    σ_Xi = √C_X[i, i],    %σ_Xi = 100 σ_Xi / |X̂_i|

The covariance comes from the triangular factor R of the QR decomposition, never
from a pseudo-inverse (which makes unidentifiable parameters look precise). The
condition number is the one of ``A S⁻¹`` (unit-norm columns), so it does not
depend on the units of the parameters.

A window that cannot identify every parameter (robot at rest, start-up, a joint
that does not move) gives ``valid = False``, NaN estimates and a ``reason`` that
names the parameters involved, instead of noise: the Drake identifier block then
holds its last valid estimate. Invalid outcomes are results, not exceptions; only
malformed arguments (shapes, types) raise.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.jackknife import jackknife_std

__all__ = [
    "DEFAULT_MAX_CONDITION",
    "LeastSquaresResult",
    "frequency_noise_weights",
    "solve_frequency_weighted_least_squares",
    "solve_least_squares",
    "solve_weighted_least_squares",
    "solve_window",
]

#: Largest accepted condition number of the column-scaled A, the one default of the
#: library (on-line settings, the identifier block, the least-squares functions and
#: the off-line IDIM). Well-excited robot regressors are typically below 1e2-1e3;
#: a window above 1e4 is reported as not identifiable rather than solved.
DEFAULT_MAX_CONDITION = 1e4

_WEAK_SHARE = 0.05  # a parameter is "involved" if ≥ 5 % of a weak direction's energy


@dataclass(frozen=True, eq=False)
class LeastSquaresResult:
    """Outcome of :func:`solve_least_squares`.

    Attributes:
        theta: (p,) estimate X̂ (NaN when not valid) [units of the parameters].
        std: (p,) Gautier standard deviations σ_X (NaN when not valid).
        relative_std_percent: (p,) 100 σ_X/|X̂| (inf where X̂ = 0; NaN when not
            valid). Above 30 % a parameter is usually considered not identified.
        condition_number: condition number of A with unit-norm columns (inf when
            rank deficient, NaN when it could not be computed).
        rank: numerical rank of the column-scaled A (0 when not computed).
        residual_std: σ_ρ = ‖B - A X̂‖/√(r - p) [unit of B] (NaN when not valid).
        num_rows: r, the rows of A.
        valid: True when X̂ and σ_X are meaningful.
        reason: empty when valid; otherwise what is wrong (too few rows, non-finite
            input, rank deficient, ill-conditioned with the condition number and
            the threshold), naming the parameters involved.
        names: (p,) parameter names (``x0``, ``x1``, ... when not given).
        unidentified: names of the parameters that are not excited: zero columns
            and the columns that carry the weak (near-null) directions of A.
        unidentified_indices: their column indices.
    """

    theta: np.ndarray
    std: np.ndarray
    relative_std_percent: np.ndarray
    condition_number: float
    rank: int
    residual_std: float
    num_rows: int
    valid: bool
    reason: str
    names: tuple[str, ...]
    unidentified: tuple[str, ...]
    unidentified_indices: tuple[int, ...]

    def poorly_identified(self, threshold_percent: float = 30.0) -> tuple[str, ...]:
        """Names whose relative standard deviation exceeds ``threshold_percent``."""
        if not self.valid:
            return self.names
        bad = np.flatnonzero(~(self.relative_std_percent <= threshold_percent))
        return tuple(self.names[i] for i in bad)


def _describe(names: Sequence[str], indices: Iterable[int]) -> str:
    return ", ".join(f"{names[i]} (column {i})" for i in indices)


def _weak_columns(R: np.ndarray, limit: float) -> tuple[int, ...]:
    """Columns involved in the directions whose singular value is below ``limit``.

    ``R`` is the triangular factor of the column-scaled A, which has the same
    singular values and right singular vectors.
    """
    _, singular, vt = np.linalg.svd(R)
    weak = vt[singular < limit]
    if weak.size == 0:  # only when rounding puts the smallest exactly at the limit
        weak = vt[-1:]
    share = np.sum(weak**2, axis=0)
    return tuple(int(i) for i in np.flatnonzero(share >= _WEAK_SHARE))


def solve_least_squares(
    A: Any,
    B: Any,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
) -> LeastSquaresResult:
    """Least squares ``X̂ = argmin ‖B - A X‖`` by QR, with Gautier's σ.

    ``σ_ρ² = ‖B - A X̂‖²/(r - p)``, ``C_X = σ_ρ² (AᵀA)⁻¹`` from the QR's R,
    ``σ_Xi = √C_X[i,i]``; condition number of A after scaling its columns to unit
    norm (docs/MATH.md §4).

    Args:
        A: (r, p) regressor [unit of B / unit of X].
        B: (r,) observations.
        max_condition: largest accepted scaled condition number (> 1).
        names: p parameter names used in ``reason`` and ``unidentified``.

    Returns:
        A :class:`LeastSquaresResult`; ``valid`` is False (with NaN estimates and a
        ``reason``) for too few rows, non-finite input, a rank-deficient or an
        ill-conditioned A.

    Raises:
        ValueError: A is not 2-D with p >= 1, B does not have r entries, names do
            not have p entries, or max_condition <= 1.
        TypeError: A or B are not arrays of real numbers.
    """
    owner = "solve_least_squares"
    A = v.array(owner, "A", A, finite=False)
    if A.ndim != 2 or A.shape[1] < 1:
        v.fail(owner, f"A must have shape (rows, p) with p >= 1; got {A.shape}.")
    rows, p = A.shape
    B = v.array(owner, "B", B, shape=(rows,), finite=False)
    max_condition = v.greater_than(owner, "max_condition", max_condition, 1.0)
    if names is None:
        names = tuple(f"x{i}" for i in range(p))
    else:
        names = tuple(str(name) for name in names)
        if len(names) != p:
            v.fail(owner, f"names must have {p} entries; got {len(names)}.")

    def invalid(
        reason: str,
        condition: float = np.nan,
        rank: int = 0,
        indices: Iterable[int] = (),
    ) -> LeastSquaresResult:
        nan = np.full(p, np.nan)
        nan.flags.writeable = False
        return LeastSquaresResult(
            theta=nan,
            std=nan,
            relative_std_percent=nan,
            condition_number=float(condition),
            rank=int(rank),
            residual_std=np.nan,
            num_rows=rows,
            valid=False,
            reason=reason,
            names=names,
            unidentified=tuple(names[i] for i in indices),
            unidentified_indices=tuple(int(i) for i in indices),
        )

    finite_a, finite_b = np.isfinite(A), np.isfinite(B)
    if not (finite_a.all() and finite_b.all()):
        bad_a = int(A.size - np.count_nonzero(finite_a))
        bad_b = int(B.size - np.count_nonzero(finite_b))
        columns = np.flatnonzero(~finite_a.all(axis=0))
        return invalid(
            f"non-finite input: {bad_a} NaN or infinite value(s) in A"
            + (f" (columns: {_describe(names, columns)})" if columns.size else "")
            + f", {bad_b} in B.",
            indices=columns,
        )
    if rows <= p:
        return invalid(
            f"too few rows: {rows} rows for {p} parameters (need more than {p})."
        )
    norms = np.sqrt(np.einsum("ij,ij->j", A, A))
    zero = np.flatnonzero(norms <= np.finfo(float).tiny)
    if zero.size:
        return invalid(
            f"rank deficient: zero column(s), parameter(s) not excited: "
            f"{_describe(names, zero)}.",
            condition=np.inf,
            rank=p - zero.size,
            indices=zero,
        )
    # One QR of the scaled, augmented [A S⁻¹ | B] (R only, Q never formed) gives
    # R, z = QᵀB and the residual norm ρ = ‖B - A X̂‖ in its last column.
    augmented = np.empty((rows, p + 1))
    np.divide(A, norms, out=augmented[:, :p])
    augmented[:, p] = B
    # (numpy's stubs type mode="r" as a tuple; it is the array R.)
    R_aug = np.asarray(np.linalg.qr(augmented, mode="r"))
    R = R_aug[:p, :p]
    singular = np.linalg.svd(R, compute_uv=False)
    tolerance = singular[0] * max(rows, p) * np.finfo(float).eps
    rank = int(np.count_nonzero(singular > tolerance))
    condition = singular[0] / singular[-1] if singular[-1] > 0 else np.inf
    if rank < p:
        weak = _weak_columns(R, tolerance)
        return invalid(
            f"rank deficient: rank {rank} < {p} parameters; dependent or not "
            f"excited: {_describe(names, weak)}.",
            condition=np.inf,
            rank=rank,
            indices=weak,
        )
    if condition > max_condition:
        weak = _weak_columns(R, singular[0] / max_condition)
        return invalid(
            f"ill-conditioned: condition number {condition:.3g} > max_condition "
            f"{max_condition:.3g} (columns scaled to unit norm); poorly excited: "
            f"{_describe(names, weak)}.",
            condition=condition,
            rank=rank,
            indices=weak,
        )
    R_inv = np.linalg.inv(R)
    theta = (R_inv @ R_aug[:p, p]) / norms
    sigma2 = float(R_aug[p, p] ** 2) / (rows - p)
    std = np.sqrt(sigma2 * np.einsum("ij,ij->i", R_inv, R_inv)) / norms
    magnitude = np.abs(theta)
    relative = np.full(p, np.inf)
    np.divide(100.0 * std, magnitude, out=relative, where=magnitude > 0)
    for array in (theta, std, relative):
        array.flags.writeable = False
    return LeastSquaresResult(
        theta=theta,
        std=std,
        relative_std_percent=relative,
        condition_number=float(condition),
        rank=rank,
        residual_std=float(np.sqrt(sigma2)),
        num_rows=rows,
        valid=True,
        reason="",
        names=names,
        unidentified=(),
        unidentified_indices=(),
    )


def solve_weighted_least_squares(
    A: Any,
    B: Any,
    weights: Any,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
) -> LeastSquaresResult:
    """Weighted least squares ``X̂ = argmin ‖W (B - A X)‖``, W = diag(weights).

    Solves ``(W A) X ≈ W B`` with :func:`solve_least_squares`: with weights
    ``w_i = 1/σ_i`` (σ_i the noise std of row i, as in IDIM-WLS) the weighted
    residual variance σ_ρ² is ≈ 1 and ``C_X = σ_ρ² (Aᵀ W² A)⁻¹``;
    ``residual_std`` is the one of the weighted residual (dimensionless then).

    Args:
        A: (r, p) regressor.
        B: (r,) observations.
        weights: (r,) finite weights > 0 [1/unit of B].
        max_condition: largest accepted scaled condition number of W A.
        names: p parameter names.
    """
    owner = "solve_weighted_least_squares"
    A = v.array(owner, "A", A, finite=False)
    if A.ndim != 2:
        v.fail(owner, f"A must have shape (rows, p); got {A.shape}.")
    w = v.array(owner, "weights", weights, shape=(A.shape[0],))
    if np.any(w <= 0):
        v.fail(owner, f"weights must be > 0; got minimum {w.min():g}.")
    B = v.array(owner, "B", B, shape=(A.shape[0],), finite=False)
    return solve_least_squares(
        A * w[:, None], B * w, max_condition=max_condition, names=names
    )


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

    Args:
        residual: (r,) first-pass residuals ``B - A X̂`` [unit of B].
        frequency: (r,) frequency index ν of each row (>= 0) [dimensionless].
        group: (r,) integer group of each row.
        floor: relative floor of σ² in (0, 1].

    Returns:
        (r,) weights ``1/σ_i`` [1/unit of B] (all ones for a group whose residuals
        are all zero).
    """
    from scipy.optimize import nnls

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
    weights = np.ones_like(residual)
    for g in np.unique(group):
        rows = group == g
        model = np.stack([np.ones(rows.sum()), frequency[rows] ** 2], axis=1)
        coefficients, _ = nnls(model, residual[rows] ** 2)
        variance = model @ coefficients
        top = float(variance.max())
        if top > 0.0:
            weights[rows] = 1.0 / np.sqrt(np.maximum(variance, floor * top))
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

    1. ``X̂₀ = argmin ‖B - A X‖`` (:func:`solve_least_squares`);
    2. weights ``w = 1/σ`` from :func:`frequency_noise_weights` of its residuals;
    3. ``X̂ = argmin ‖w (B - A X)‖`` (:func:`solve_weighted_least_squares`), with
       Gautier's σ from the weighted problem (C_X = σ_ρ² (Aᵀ W² A)⁻¹).

    A feasible generalised least squares: with the modulated equations of the
    on-line identifier (docs/MATH.md §3), whose high-ℓ rows carry most of the
    velocity-estimate noise, it halved the inertial error on the 2R benchmark
    (benchmarks/bench_accuracy.py). When step 1 is not valid, its result is
    returned unchanged.

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
    first = solve_least_squares(A, B, max_condition=max_condition, names=names)
    if not first.valid:
        return first, None
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    weights = frequency_noise_weights(B - A @ first.theta, frequency, group)
    result = solve_weighted_least_squares(
        A, B, weights, max_condition=max_condition, names=names
    )
    return result, weights


def solve_window(
    A: Any,
    B: Any,
    weighting: tuple[Any, Any] | None = None,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    jackknife: Any = None,
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
        jackknife: None (Gautier's σ), or the (r,) group of every row (e.g. its
            pair of modulating functions): σ is then the larger of Gautier's and the
            delete-one-group jackknife's (``core.jackknife.jackknife_std``, with
            the solve's weights), per parameter (docs/MATH.md §4).
    """
    if weighting is None:
        result = solve_least_squares(A, B, max_condition=max_condition, names=names)
        weights = None
    else:
        frequency, group = weighting
        result, weights = _frequency_weighted(
            A, B, frequency, group, max_condition, names
        )
    if jackknife is None or not result.valid:
        return result
    spread = jackknife_std(A, B, jackknife, weights=weights)
    std = np.fmax(result.std, spread)  # NaN jackknife: Gautier's σ alone
    magnitude = np.abs(result.theta)
    relative = np.full(std.shape, np.inf)
    np.divide(100.0 * std, magnitude, out=relative, where=magnitude > 0)
    for array in (std, relative):
        array.flags.writeable = False
    return dataclasses.replace(result, std=std, relative_std_percent=relative)
