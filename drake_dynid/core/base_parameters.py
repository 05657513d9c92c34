"""Base (identifiable) parameters by numerical reduction (Gautier & Khalil 1990).

Given regressor rows ``W`` (r × p_std) of a model linear in the standard parameters
θ_std, stacked at many random states, only combinations of θ_std are identifiable.
With the columns in a preferred order (inertias and first moments before masses,
links from the base outwards, friction last), the greedy rule keeps a column when it
is not in the span of the columns kept before it::

    W = [W_I  W_D] (permuted),   W_D = W_I β   (exactly, for noise-free rows)
    W θ_std = W_I θ_base,         θ_base = θ_I + β θ_D

The rank decision (:func:`base_parameters`) is relative to the largest column:

* ``ρ_k = |W_k| / max_j |W_j|``. A column with ρ_k ≤ ``column_tolerance`` (1e-10) is
  a **zero column**: its parameter does not act on the rows. Such a column is often
  not exactly zero: a URDF that writes a π rotation with 11 digits leaves round-off
  of about 1e-13 of the largest column in columns that are zero in exact arithmetic
  (products of two such errors: 1e-30 … 1e-59). Normalised to unit length, round-off
  is a random direction that looks independent; it must never become a parameter.
* ``d_k = |R_kk|`` of the column-normalised QR without pivoting, computed by
  Gram-Schmidt (twice) against the columns kept so far: the distance of the unit
  column k from their span. Column k is kept when ``d_k > tolerance`` (1e-8) **and**
  ``ρ_k·d_k > column_tolerance``: ρ_k·d_k is the distance of the unnormalised
  column from the span, relative to the largest column, so a small column whose
  component outside the span is round-off of the large ones is regrouped too.

Why these values: the rows (:meth:`drake_dynid.robot.RobotModel` stacks inverse-
dynamics rows at random states, q uniform in ±π rad or ±1 m, q̇ and q̈ standard
normal in SI units, the model's gravity, no row weighting) have columns that are
kinematic quantities of order 1-10 (angular accelerations for inertias, g plus
lever-arm accelerations for first moments and masses), so round-off in a column is
of order ε_machine × the largest column. Measured on the shipped robots and on 13
real descriptions (UR3/5/10, iiwa7, Panda, Kinova j2s6s200, Unitree Z1, xArm7,
SO-100/101, TIAGo, a double pendulum, FINGER-edu), with and without friction:
round-off columns have ρ ≤ 1.3e-13, the other columns ρ ≥ 1.7e-7 (genuine small
columns come from small tilts written in a description: the SO-100 has independent
ones at 3e-6); independent columns have |R_kk| ≥ 0.09, dependent ones
|R_kk| ≤ 2e-11, except a tiny dependent column (the Kinova's M2, ρ = 2e-7) whose unit
form amplifies round-off to |R_kk| = 1e-9: its distance relative to the largest
column, ρ·|R_kk| = 2e-16, is why both tests are applied. The same tiny column
regrouped by least squares picks up round-off coefficients on unrelated independent
columns (the Kinova's FV1 = FV1 + 3e-16 M2, named FV1R): a coefficient β_ik whose
contribution |β_ik|·|W_I,i| is at most ``ROUND_OFF_CONTRIBUTION`` (5e-13) of the
largest column is zero. Over six seeds of the rows such round-off contributions
reach 6.5e-14 (Kinova), and the smallest genuine ones are 4.7e-12 (the SO-101's
MX1R = MX1 + 3.7e-6 (MZ2 + MZ3 + MZ4), a product of two small tilts), the
xArm7's 9e-10, the others' 2e-7 or more. Each tolerance sits at
least a decade (mostly four or more) from both sides. They are fixed rather than
moved per robot: a tolerance placed in "the largest gap" of a spectrum always finds
a gap, even in a full-rank set. The decision is checked instead by a second rank
rule: the singular values σ of the normalised non-zero columns must drop at the
same rank p; :attr:`BaseParameters.clear` says whether σ_p / σ_p+1 exceeds 1e4 and
every column passes or fails its tests by a factor of 100 or more. With Khalil's
column order this returns Khalil's base set (e.g. the 2R arm gives ZZ1R = ZZ1 +
L1²·M2, ZZ2, MX2, MY2).

Reduce on inverse-dynamics rows or power rows (energy differences), never on raw
energies: a constant energy column (potential energy along a vertical axis) is not
identifiable. Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from drake_dynid.core import _validate

_OWNER = "base_parameters"

#: Default zero-column tolerance on |W_k| / max_j |W_j| (see the module docstring).
COLUMN_TOLERANCE = 1e-10
#: Default rank tolerance on |R_kk| of the column-normalised QR.
RANK_TOLERANCE = 1e-8
#: A regrouping coefficient whose contribution |β_ik|·|W_I,i| is at most this
#: fraction of the largest column is round-off, set to zero (module docstring).
ROUND_OFF_CONTRIBUTION = 5e-13
#: A rank decision is "clear" when σ_p / σ_p+1 exceeds this ...
CLEAR_GAP = 1e4
#: ... and every column's decision statistic is this far from its threshold.
CLEAR_MARGIN = 100.0


def _snap(value: float, decimals: int) -> float:
    """Rounds ``value`` to ``decimals`` significant digits (1.0000000000000002 -> 1)."""
    return float(f"{value:.{decimals}g}")


def format_definition(definition: Mapping[str, float]) -> str:
    """Returns ``"ZZ1 + 1.0 M2"`` for ``{"ZZ1": 1.0, "M2": 1.0}``.

    The leading standard parameter (coefficient 1) is written bare; the others as
    ``± |coefficient| NAME`` with ``repr`` of the coefficient (shortest round trip).
    """
    parts: list[str] = []
    for k, (name, coefficient) in enumerate(definition.items()):
        if k == 0 and coefficient == 1.0:
            parts.append(name)
            continue
        sign = "-" if coefficient < 0 else "+"
        magnitude = repr(abs(float(coefficient)))
        if k == 0:
            parts.append(f"{'-' if coefficient < 0 else ''}{magnitude} {name}")
        else:
            parts.append(f"{sign} {magnitude} {name}")
    return " ".join(parts)


@dataclass(frozen=True, eq=False)
class BaseParameters:
    """Base parameters of a model: names, definitions and the standard -> base map.

    θ_base = ``matrix`` @ θ_std and W_base = W_std[:, ``independent``], so
    W_std θ_std = W_base θ_base for every regressor row of the model.

    Attributes:
        standard_names: names of the p_std standard parameters (column order).
        names: names of the p base parameters; a regrouped one carries the suffix
            ``R`` (``ZZ1R``).
        independent: for each base parameter, the column index of its leading
            standard parameter.
        matrix: ``(p, p_std)`` read-only array, θ_base = matrix @ θ_std.
        definitions: for each base parameter, ``{standard name: coefficient}`` with
            the leading parameter first (coefficient 1).
        tolerance: the rank tolerance used on the normalised |R_kk|.
        smallest_kept: the smallest |R_kk| of a kept column (the rank margin).
        largest_dropped: the largest |R_kk| of a dropped non-zero column (0 if none).
        column_tolerance: a column whose norm relative to the largest column is at
            most this is a zero column (round-off; never a parameter).
        relative_norms: ``(p_std,)`` read-only, |W_k| / max_j |W_j| (empty when
            unknown).
        singular_kept: σ_p / σ_1, the p-th singular value of the normalised
            non-zero columns relative to the largest (NaN when unknown).
        singular_dropped: σ_(p+1) / σ_1 (0 when every non-zero column is kept).
        margin_kept: the smallest decision margin of a kept column,
            min(|R_kk| / tolerance, ρ_k |R_kk| / column_tolerance) (> 1).
        margin_dropped: the largest decision margin of a dropped non-zero column
            (≤ 1; 0 if none).
    """

    standard_names: tuple[str, ...]
    names: tuple[str, ...]
    independent: tuple[int, ...]
    matrix: np.ndarray
    definitions: tuple[Mapping[str, float], ...]
    tolerance: float = RANK_TOLERANCE
    smallest_kept: float = float("nan")
    largest_dropped: float = 0.0
    column_tolerance: float = COLUMN_TOLERANCE
    relative_norms: np.ndarray = field(default_factory=lambda: np.zeros(0))
    singular_kept: float = float("nan")
    singular_dropped: float = 0.0
    margin_kept: float = float("nan")
    margin_dropped: float = 0.0

    def __post_init__(self) -> None:
        matrix = np.array(self.matrix, dtype=float)
        p, p_std = len(self.names), len(self.standard_names)
        if matrix.shape != (p, p_std) or len(self.independent) != p:
            raise ValueError(
                f"BaseParameters: matrix must have shape ({p}, {p_std}) and "
                f"independent {p} entries; got {matrix.shape} and "
                f"{len(self.independent)}."
            )
        matrix.setflags(write=False)
        object.__setattr__(self, "matrix", matrix)
        norms = np.array(self.relative_norms, dtype=float).reshape(-1)
        if norms.size not in (0, p_std):
            raise ValueError(
                f"BaseParameters: relative_norms must have {p_std} entries (or none); "
                f"got {norms.size}."
            )
        norms.setflags(write=False)
        object.__setattr__(self, "relative_norms", norms)
        object.__setattr__(self, "standard_names", tuple(self.standard_names))
        object.__setattr__(self, "names", tuple(self.names))
        object.__setattr__(self, "independent", tuple(int(i) for i in self.independent))
        object.__setattr__(
            self,
            "definitions",
            tuple(MappingProxyType(dict(d)) for d in self.definitions),
        )

    @property
    def num_base(self) -> int:
        """Number of base parameters p."""
        return len(self.names)

    @property
    def num_standard(self) -> int:
        """Number of standard parameters p_std."""
        return len(self.standard_names)

    @property
    def zero_columns(self) -> tuple[str, ...]:
        """Standard parameters whose column is zero (ρ ≤ column_tolerance)."""
        if self.relative_norms.size == 0:
            return ()
        zero = self.relative_norms <= self.column_tolerance
        return tuple(n for n, z in zip(self.standard_names, zero, strict=True) if z)

    @property
    def round_off_columns(self) -> tuple[str, ...]:
        """Zero columns that are not exactly zero (0 < ρ ≤ column_tolerance).

        These are round-off (e.g. of π rotations written with 11 digits); before
        drake_dynid 0.2 they became spurious base parameters.
        """
        if self.relative_norms.size == 0:
            return ()
        norms = self.relative_norms
        odd = (norms > 0.0) & (norms <= self.column_tolerance)
        return tuple(n for n, z in zip(self.standard_names, odd, strict=True) if z)

    @property
    def gap(self) -> float:
        """smallest_kept / largest_dropped (|R_kk| of unit columns; inf if none)."""
        if self.largest_dropped <= 0.0:
            return math.inf
        return self.smallest_kept / self.largest_dropped

    @property
    def singular_gap(self) -> float:
        """singular_kept / singular_dropped (inf when nothing non-zero is dropped)."""
        if self.singular_dropped <= 0.0:
            return math.inf
        return self.singular_kept / self.singular_dropped

    @property
    def clear(self) -> bool:
        """Whether the rank decision is clear.

        Every kept column passes both tests by a factor of at least 100
        (``margin_kept``), every dropped non-zero column fails one of them by a
        factor of at least 100 (``margin_dropped``), and the singular values of
        the normalised non-zero columns drop by at least 1e4 at the same rank
        (``singular_gap``). Otherwise a parameter sits between "identifiable" and
        "a round-off combination": check the description (a near-singular
        geometry) or reduce on more random states.
        """
        if math.isnan(self.margin_kept) or math.isnan(self.singular_gap):
            return False
        return (
            self.margin_kept >= CLEAR_MARGIN
            and self.margin_dropped <= 1.0 / CLEAR_MARGIN
            and self.singular_gap >= CLEAR_GAP
        )

    def rows(self, standard_rows) -> np.ndarray:
        """Maps regressor rows in standard columns (..., p_std) to base (..., p)."""
        rows = np.asarray(standard_rows, dtype=float)
        if rows.shape[-1:] != (self.num_standard,):
            raise ValueError(
                f"BaseParameters: standard_rows must have {self.num_standard} "
                f"columns in the last axis; got shape {rows.shape}."
            )
        return rows[..., list(self.independent)]

    def values(self, standard_values) -> np.ndarray:
        """Maps standard values θ_std (..., p_std) to base values θ_base (..., p)."""
        theta = np.asarray(standard_values, dtype=float)
        if theta.shape[-1:] != (self.num_standard,):
            raise ValueError(
                f"BaseParameters: standard_values must have {self.num_standard} "
                f"entries in the last axis; got shape {theta.shape}."
            )
        return theta @ self.matrix.T

    def definition_text(self, name: str) -> str:
        """Returns the definition of base parameter ``name``, e.g. ``ZZ1 + 1.0 M2``."""
        if name not in self.names:
            choices = _validate.choices(self.names, name)
            raise ValueError(
                f"BaseParameters: name must be one of {choices}; got {name!r}."
            )
        return format_definition(self.definitions[self.names.index(name)])


def _greedy_distances(
    unit: np.ndarray, relative: np.ndarray, tolerance: float, column_tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """Distances d_k of unit columns from the span of the kept ones; kept mask.

    Classical Gram-Schmidt applied twice ("twice is enough") against an orthonormal
    basis of the kept columns only: a dropped column never enters the basis, so its
    round-off cannot hide a later independent column.
    """
    rows, width = unit.shape
    basis = np.empty((rows, width))
    size = 0
    distance = np.zeros(width)
    kept = np.zeros(width, dtype=bool)
    for k in range(width):
        x = unit[:, k]
        if size:
            q = basis[:, :size]
            x = x - q @ (q.T @ x)
            x = x - q @ (q.T @ x)
        d = float(np.linalg.norm(x))
        distance[k] = d
        if d > tolerance and relative[k] * d > column_tolerance:
            basis[:, size] = x / d
            size += 1
            kept[k] = True
    return distance, kept


def base_parameters(
    rows,
    standard_names: Sequence[str],
    *,
    tolerance: float = RANK_TOLERANCE,
    decimals: int = 10,
    column_tolerance: float = COLUMN_TOLERANCE,
) -> BaseParameters:
    """Base parameters from regressor rows stacked at many random states.

    The rank decision is the module docstring's: zero columns (|W_k| ≤
    ``column_tolerance``·max_j |W_j|) are dropped with no regrouping; column k is
    kept when the distance of the unit column from the span of the columns kept
    before it, |R_kk|, exceeds ``tolerance`` and |R_kk|·|W_k|/max_j |W_j| exceeds
    ``column_tolerance``. The other non-zero columns are regrouped by least squares,
    W_D = W_I β, and each base parameter is θ_I,i + Σ_k β_ik θ_D,k. Coefficients are
    rounded to ``decimals`` significant digits, and those below 10^-decimals
    (relative to the column scales) or whose contribution |β_ik|·|W_I,i| is at
    most ``ROUND_OFF_CONTRIBUTION`` of the largest column (round-off) are set to
    zero, so exact structural coefficients come out exact (``1.0``).

    Args:
        rows: ``(r, p_std)`` noise-free regressor rows (IDIM or power rows) at
            random states, r ≥ p_std; more rows than columns by a factor 2-5 is
            plenty.
        standard_names: the p_std column names in preferred order.
        tolerance: rank tolerance on the normalised |R_kk|, in (0, 1).
        decimals: significant digits kept in the coefficients β.
        column_tolerance: zero-column tolerance relative to the largest column
            norm, in [0, 1).

    Returns:
        The immutable :class:`BaseParameters`, with the decision's margins
        (``smallest_kept``, ``largest_dropped``, ``singular_kept``,
        ``singular_dropped``, ``relative_norms``).
    """
    w = _validate.array(_OWNER, "rows", rows, shape=(None, None))
    names = tuple(str(name) for name in standard_names)
    if w.shape[1] != len(names):
        raise ValueError(
            f"{_OWNER}: rows must have one column per standard name; got "
            f"{w.shape[1]} columns and {len(names)} names."
        )
    if w.shape[0] < w.shape[1]:
        raise ValueError(
            f"{_OWNER}: rows must have at least as many rows as columns "
            f"({w.shape[1]}); got {w.shape[0]}. Stack more random states."
        )
    tolerance = _validate.in_range(_OWNER, "tolerance", tolerance, 0.0, 1.0)
    column_tolerance = _validate.in_range(
        _OWNER, "column_tolerance", column_tolerance, 0.0, 1.0
    )
    decimals = _validate.integer(_OWNER, "decimals", decimals, minimum=1)

    scale = np.linalg.norm(w, axis=0)
    largest = float(scale.max()) if scale.size else 0.0
    if largest == 0.0:
        raise ValueError(f"{_OWNER}: rows are all zero; nothing is identifiable.")
    relative = scale / largest
    nonzero = np.flatnonzero(relative > column_tolerance)
    unit = w[:, nonzero] / scale[nonzero]
    distance, kept_nonzero = _greedy_distances(
        unit, relative[nonzero], tolerance, column_tolerance
    )
    diagonal = np.zeros(len(names))
    diagonal[nonzero] = distance
    kept = np.zeros(len(names), dtype=bool)
    kept[nonzero[kept_nonzero]] = True
    independent = np.flatnonzero(kept)
    regrouped = nonzero[~kept_nonzero]  # non-zero dependent columns
    singular = np.linalg.svd(unit, compute_uv=False)
    singular = singular / singular[0]

    beta = np.zeros((independent.size, regrouped.size))
    if regrouped.size:
        # On unit columns: β_unit[i, k] = β_ik · |W_I,i| / |W_D,k| (scale-free).
        beta_unit = np.linalg.lstsq(
            w[:, independent] / scale[independent],
            w[:, regrouped] / scale[regrouped],
            rcond=None,
        )[0]
        # Round-off: below 10^-decimals of the unit column, or a contribution
        # |β_ik|·|W_I,i| of at most ROUND_OFF_CONTRIBUTION of the largest column.
        contribution = np.abs(beta_unit) * relative[regrouped][None, :]
        beta_unit = np.where(
            (np.abs(beta_unit) < 10.0**-decimals)
            | (contribution <= ROUND_OFF_CONTRIBUTION),
            0.0,
            beta_unit,
        )
        beta = beta_unit * scale[regrouped][None, :] / scale[independent][:, None]
        beta = np.vectorize(lambda b: _snap(b, decimals), otypes=[float])(beta)

    matrix = np.zeros((independent.size, len(names)))
    matrix[np.arange(independent.size), independent] = 1.0
    matrix[:, regrouped] = beta
    base_names = []
    definitions = []
    for i, column in enumerate(independent):
        definition = {names[column]: 1.0}
        for k, dep in enumerate(regrouped):
            if beta[i, k] != 0.0:
                definition[names[dep]] = float(beta[i, k])
        definitions.append(definition)
        base_names.append(names[column] + ("R" if len(definition) > 1 else ""))
    dropped = diagonal[regrouped]
    margin = np.full(len(names), np.inf)
    if tolerance > 0.0:
        margin = np.minimum(margin, diagonal / tolerance)
    if column_tolerance > 0.0:
        margin = np.minimum(margin, relative * diagonal / column_tolerance)
    p = independent.size
    return BaseParameters(
        standard_names=names,
        names=tuple(base_names),
        independent=tuple(int(i) for i in independent),
        matrix=matrix,
        definitions=tuple(definitions),
        tolerance=tolerance,
        smallest_kept=float(diagonal[independent].min()),
        largest_dropped=float(dropped.max()) if dropped.size else 0.0,
        column_tolerance=column_tolerance,
        relative_norms=relative,
        singular_kept=float(singular[p - 1]),
        singular_dropped=float(singular[p]) if p < singular.size else 0.0,
        margin_kept=float(margin[independent].min()),
        margin_dropped=float(margin[regrouped].max()) if regrouped.size else 0.0,
    )
