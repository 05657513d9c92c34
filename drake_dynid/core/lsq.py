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
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = [
    "DEFAULT_MAX_CONDITION",
    "NOT_IDENTIFIED_PERCENT",
    "LeastSquaresResult",
    "relative_std_percent",
    "solve_least_squares",
    "solve_weighted_least_squares",
]

#: Largest accepted condition number of the column-scaled A, the one default of the
#: library (on-line settings, the identifier block, the least-squares functions and
#: the off-line IDIM). Well-excited robot regressors are typically below 1e2-1e3;
#: a window above 1e4 is reported as not identifiable rather than solved.
DEFAULT_MAX_CONDITION = 1e4

#: A parameter whose σ exceeds this percentage of its magnitude is not identified
#: (the ``*`` of every table, ``identified`` false in every JSON).
NOT_IDENTIFIED_PERCENT = 30.0


def relative_std_percent(value: float, sigma: float) -> float:
    """%σ = 100·σ/|value| [%]; inf for a zero or non-finite value or σ."""
    value, sigma = float(value), float(sigma)
    if math.isfinite(value) and math.isfinite(sigma) and value != 0.0:
        return 100.0 * sigma / abs(value)
    return math.inf


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

    def poorly_identified(
        self, threshold_percent: float = NOT_IDENTIFIED_PERCENT
    ) -> tuple[str, ...]:
        """Names whose relative standard deviation exceeds ``threshold_percent``."""
        if not self.valid:
            return self.names
        bad = np.flatnonzero(~(self.relative_std_percent <= threshold_percent))
        return tuple(self.names[i] for i in bad)


def _describe(names: Sequence[str], indices: Iterable[int]) -> str:
    return v.listed(f"{names[i]} (column {i})" for i in indices)


_BLOCK_ENTRIES = 1 << 19
"""A larger A (4 MB) is scaled and factored a block of rows at a time."""


def _block_rows(p: int) -> int:
    """Rows per block of an A with p columns."""
    return max(4 * (p + 1), _BLOCK_ENTRIES // (p + 1))


#: A column whose norm is at most this fraction of the largest column's is not
#: excited: round-off, not data (a frozen encoder's filtered velocity is 1e-13 of
#: the moving joints'; scaled to unit norm, such a column gave FV1 = -4.7e16 with
#: %σ 29, "identified"). Real columns differ by units and excitation, never by 10
#: orders of magnitude.
ROUND_OFF_COLUMN = 1e-10


def round_off_floor(norms: np.ndarray) -> float:
    """The norm at or below which a column is zero (:data:`ROUND_OFF_COLUMN`)."""
    largest = float(np.max(norms)) if np.size(norms) else 0.0
    return max(np.finfo(float).tiny, ROUND_OFF_COLUMN * largest)


def _column_norms(A: np.ndarray) -> np.ndarray:
    """‖A_:j‖, scaled by the column's largest entry (no overflow).

    The scaling keeps entries up to the largest float (squares of 1e160 would
    overflow). A block of rows at a time beyond :data:`_BLOCK_ENTRIES` (the
    same sums, taken in pieces).
    """
    step = _block_rows(A.shape[1])
    peak = np.zeros(A.shape[1])
    for a in range(0, A.shape[0], step):
        np.maximum(peak, np.max(np.abs(A[a : a + step]), axis=0), out=peak)
    safe = np.where(peak > 0.0, peak, 1.0)
    squares = np.zeros(A.shape[1])
    for a in range(0, A.shape[0], step):
        block = A[a : a + step] / safe
        squares += np.einsum("ij,ij->j", block, block)
    return peak * np.sqrt(squares)


def _r_factor(A: np.ndarray, B: np.ndarray, norms: np.ndarray, scale: float):
    """R of the QR of the scaled, augmented [A S⁻¹ | B/scale] (Q never formed).

    Its last column holds z = QᵀB and the residual norm ρ = ‖B - A X̂‖. Beyond
    :data:`_BLOCK_ENTRIES` a block of rows at a time: R of [R_previous; block]
    (the R of the whole up to the signs of its rows, which no result depends
    on), in memory of one block.
    """
    rows, p = A.shape
    step = _block_rows(p)
    R_aug = np.empty((0, p + 1))
    for a in range(0, rows, step):
        b = min(rows, a + step)
        block = np.empty((R_aug.shape[0] + b - a, p + 1))
        block[: R_aug.shape[0]] = R_aug
        np.divide(A[a:b], norms, out=block[R_aug.shape[0] :, :p])
        np.divide(B[a:b], scale, out=block[R_aug.shape[0] :, p])
        # (numpy's stubs type mode="r" as a tuple; it is the array R.)
        R_aug = np.asarray(np.linalg.qr(block, mode="r"))
    return R_aug


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


@dataclass(frozen=True, eq=False)
class _Factor:
    """The QR of a valid problem: R of [A S⁻¹ | B], the column norms S, R⁻¹.

    ``condition`` is NaN when only a bound showed it below ``max_condition``.
    """

    R_aug: np.ndarray
    norms: np.ndarray
    condition: float
    rank: int
    rows: int
    names: tuple[str, ...]
    R_inv: np.ndarray | None = None
    b_scale: float = 1.0  # B is divided by it in R_aug (no overflow)


def _with_inverse(factor: _Factor) -> _Factor:
    """``factor`` with R⁻¹ formed (once, shared by X̂, σ and the jackknife)."""
    if factor.R_inv is not None:
        return factor
    p = factor.norms.size
    return dataclasses.replace(factor, R_inv=np.linalg.inv(factor.R_aug[:p, :p]))


def _with_std(result: LeastSquaresResult, std: np.ndarray) -> LeastSquaresResult:
    """``result`` with the standard deviations ``std`` (and their relative %)."""
    magnitude = np.abs(result.theta)
    relative = np.full(std.shape, np.inf)
    np.divide(100.0 * std, magnitude, out=relative, where=magnitude > 0)
    for array in (std, relative):
        array.flags.writeable = False
    return dataclasses.replace(result, std=std, relative_std_percent=relative)


def _decompose(
    A: Any,
    B: Any,
    max_condition: float,
    names: Sequence[str] | None,
    *,
    bound_first: bool = False,
    num_rows: int | None = None,
) -> tuple[np.ndarray, np.ndarray, LeastSquaresResult | _Factor]:
    """Checks and factors ``A X ≈ B``: (A, B as arrays, an invalid result or the QR).

    Every validity decision of :func:`solve_least_squares` is taken here. With
    ``bound_first`` (a first pass that needs X̂ only), R⁻¹ is formed first and the
    SVD skipped when ``‖R‖_F ‖R⁻¹‖_F``, an upper bound of the condition number,
    already shows the problem valid (full rank and cond <= ``max_condition``):
    the same decision, without the condition number's value. ``num_rows``: the
    equations A and B stand for when they are a QR reduction (see
    :func:`solve_least_squares`).
    """
    owner = "solve_least_squares"
    A = v.array(owner, "A", A, finite=False)
    if A.ndim != 2 or A.shape[1] < 1:
        v.fail(owner, f"A must have shape (rows, p) with p >= 1; got {A.shape}.")
    rows, p = A.shape
    B = v.array(owner, "B", B, shape=(rows,), finite=False)
    if num_rows is not None:
        rows = v.integer(owner, "num_rows", num_rows, minimum=0)
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
        return (
            A,
            B,
            invalid(
                f"non-finite input: {bad_a} NaN or infinite value(s) in A"
                + (f" (columns: {_describe(names, columns)})" if columns.size else "")
                + f", {bad_b} in B.",
                indices=columns,
            ),
        )
    if rows <= p:
        return (
            A,
            B,
            invalid(
                f"too few rows: {rows} rows for {p} parameters (need more than {p})."
            ),
        )
    norms = _column_norms(A)
    zero = np.flatnonzero(norms <= round_off_floor(norms))
    if zero.size:
        return (
            A,
            B,
            invalid(
                "rank deficient: zero or round-off column(s) (at most "
                f"{ROUND_OFF_COLUMN:g} of the largest), parameter(s) not excited: "
                f"{_describe(names, zero)}.",
                condition=np.inf,
                rank=p - zero.size,
                indices=zero,
            ),
        )
    b_scale = float(np.max(np.abs(B))) or 1.0
    R_aug = _r_factor(A, B, norms, b_scale)
    R = R_aug[:p, :p]
    R_inv = None
    if bound_first:
        with np.errstate(all="ignore"):
            try:
                R_inv = np.linalg.inv(R)
            except np.linalg.LinAlgError:  # exactly singular: the SVD reports it
                R_inv = None
            if R_inv is not None:
                bound = np.linalg.norm(R) * np.linalg.norm(R_inv)
                # cond <= bound < 1/(max(r, p)·eps): full rank as well.
                limit = min(max_condition, 1.0 / (max(rows, p) * np.finfo(float).eps))
                if bound <= limit:
                    return (
                        A,
                        B,
                        _Factor(R_aug, norms, np.nan, p, rows, names, R_inv, b_scale),
                    )
    singular = np.linalg.svd(R, compute_uv=False)
    tolerance = singular[0] * max(rows, p) * np.finfo(float).eps
    rank = int(np.count_nonzero(singular > tolerance))
    condition = singular[0] / singular[-1] if singular[-1] > 0 else np.inf
    if rank < p:
        weak = _weak_columns(R, tolerance)
        return (
            A,
            B,
            invalid(
                f"rank deficient: rank {rank} < {p} parameters; dependent or not "
                f"excited: {_describe(names, weak)}.",
                condition=np.inf,
                rank=rank,
                indices=weak,
            ),
        )
    if condition > max_condition:
        weak = _weak_columns(R, singular[0] / max_condition)
        return (
            A,
            B,
            invalid(
                f"ill-conditioned: condition number {condition:.3g} > max_condition "
                f"{max_condition:.3g} (columns scaled to unit norm); poorly excited: "
                f"{_describe(names, weak)}.",
                condition=condition,
                rank=rank,
                indices=weak,
            ),
        )
    return (
        A,
        B,
        _Factor(R_aug, norms, float(condition), rank, rows, names, R_inv, b_scale),
    )


def _estimate(factor: _Factor) -> LeastSquaresResult:
    """X̂ and Gautier's σ from the QR of a valid problem."""
    R_aug, norms, rows = factor.R_aug, factor.norms, factor.rows
    p = norms.size
    R_inv = factor.R_inv if factor.R_inv is not None else np.linalg.inv(R_aug[:p, :p])
    theta = (R_inv @ R_aug[:p, p]) * factor.b_scale / norms
    residual_std = abs(float(R_aug[p, p])) / np.sqrt(rows - p) * factor.b_scale
    std = residual_std * np.sqrt(np.einsum("ij,ij->i", R_inv, R_inv)) / norms
    magnitude = np.abs(theta)
    relative = np.full(p, np.inf)
    np.divide(100.0 * std, magnitude, out=relative, where=magnitude > 0)
    for array in (theta, std, relative):
        array.flags.writeable = False
    return LeastSquaresResult(
        theta=theta,
        std=std,
        relative_std_percent=relative,
        condition_number=factor.condition,
        rank=factor.rank,
        residual_std=float(residual_std),
        num_rows=rows,
        valid=True,
        reason="",
        names=factor.names,
        unidentified=(),
        unidentified_indices=(),
    )


def solve_least_squares(
    A: Any,
    B: Any,
    *,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    num_rows: int | None = None,
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
        num_rows: None, or r when ``[A | B]`` is the R factor of a taller system
            of r equations (``‖A X - B‖`` equal to its residual for every X, e.g.
            ``core.idim.reduce_rows``): the rows check, σ_ρ's r - p and the rank
            tolerance use r.

    Returns:
        A :class:`LeastSquaresResult`; ``valid`` is False (with NaN estimates and a
        ``reason``) for too few rows, non-finite input, a rank-deficient or an
        ill-conditioned A.

    Raises:
        ValueError: A is not 2-D with p >= 1, B does not have r entries, names do
            not have p entries, or max_condition <= 1.
        TypeError: A or B are not arrays of real numbers.
    """
    _, _, factor = _decompose(A, B, max_condition, names, num_rows=num_rows)
    return factor if isinstance(factor, LeastSquaresResult) else _estimate(factor)


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


# The frequency-weighted solves and the on-line window solve live in
# ``drake_dynid.core.weighted_lsq``; their former import path still works.
_WEIGHTED = (
    "frequency_noise_weights",
    "solve_frequency_weighted_least_squares",
    "solve_window",
)


def __getattr__(name: str) -> Any:
    if name in _WEIGHTED:
        from drake_dynid.core import weighted_lsq

        return getattr(weighted_lsq, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
