"""Base (identifiable) parameters by numerical reduction (Gautier & Khalil 1990).

Given regressor rows ``W`` (r × p_std) of a model linear in the standard parameters
θ_std, stacked at many random states, only combinations of θ_std are identifiable.
With the columns in a preferred order (inertias and first moments before masses,
links from the base outwards, friction last), the greedy rule keeps a column when it
is not in the span of the columns kept before it::

    W = [W_I  W_D] (permuted),   W_D = W_I β   (exactly, for noise-free rows)
    W θ_std = W_I θ_base,         θ_base = θ_I + β θ_D

The test is a QR factorisation *without* pivoting of the column-normalised rows:
``|R_kk|`` is the distance of unit column k from the span of columns 0..k-1, so
column k is independent when ``|R_kk| > tolerance``. Columns whose norm is below
``ZERO_COLUMN`` (1e-10) of the largest are zero (round-off) and dropped first.
With Khalil's column order this returns Khalil's base set (e.g. the 2R arm gives
ZZ1R = ZZ1 + L1²·M2, ZZ2, MX2, MY2).

Reduce on inverse-dynamics rows or power rows (energy differences), never on raw
energies: a constant energy column (potential energy along a vertical axis) is not
identifiable. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from drake_dynid.core import _validate

_OWNER = "base_parameters"

ZERO_COLUMN = 1e-10
"""A column whose norm is below this fraction of the largest column norm is zero
(round-off, e.g. MZ2 of an arm whose joint 1 is vertical: its column is ~1e-14)."""


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
    """

    standard_names: tuple[str, ...]
    names: tuple[str, ...]
    independent: tuple[int, ...]
    matrix: np.ndarray
    definitions: tuple[Mapping[str, float], ...]
    tolerance: float = 1e-8
    smallest_kept: float = float("nan")
    largest_dropped: float = 0.0

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
            raise ValueError(
                f"BaseParameters: name must be one of {', '.join(self.names)}; "
                f"got {name!r}."
            )
        return format_definition(self.definitions[self.names.index(name)])


def base_parameters(
    rows,
    standard_names: Sequence[str],
    *,
    tolerance: float = 1e-8,
    decimals: int = 10,
) -> BaseParameters:
    """Base parameters from regressor rows stacked at many random states.

    Column k (in the given, preferred order) is kept when the distance of the
    normalised column from the span of the columns before it, |R_kk| of an unpivoted
    QR, exceeds ``tolerance``; zero columns are dropped. The dropped columns are
    regrouped by least squares, W_D = W_I β, and each base parameter is
    θ_I,i + Σ_k β_ik θ_D,k. Coefficients are rounded to ``decimals`` significant
    digits, and those below 10^-decimals (relative to the column scales) are set to
    zero, so exact structural coefficients come out exact (``1.0``).

    Args:
        rows: ``(r, p_std)`` noise-free regressor rows (IDIM or power rows) at
            random states, r ≥ p_std; more rows than columns by a factor 2-5 is
            plenty.
        standard_names: the p_std column names in preferred order.
        tolerance: rank tolerance on the normalised |R_kk|, in (0, 1).
        decimals: significant digits kept in the coefficients β.

    Returns:
        The immutable :class:`BaseParameters`.
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
    decimals = _validate.integer(_OWNER, "decimals", decimals, minimum=1)

    scale = np.linalg.norm(w, axis=0)
    # A column of round-off (a parameter that does not enter the model, computed
    # as 1e-15-sized products) is zero: normalised, it would look independent.
    nonzero = scale > ZERO_COLUMN * scale.max()
    normalised = np.zeros_like(w)
    normalised[:, nonzero] = w[:, nonzero] / scale[nonzero]
    diagonal = np.abs(np.diag(np.linalg.qr(normalised, mode="r")))
    kept = nonzero & (diagonal > tolerance)
    independent = np.flatnonzero(kept)
    dependent = np.flatnonzero(~kept)
    if independent.size == 0:
        raise ValueError(f"{_OWNER}: rows are all zero; nothing is identifiable.")

    beta = np.zeros((independent.size, dependent.size))
    if dependent.size:
        beta = np.linalg.lstsq(w[:, independent], w[:, dependent], rcond=None)[0]
        # Scale-free size of each coefficient: β_ik · |W_D,k| / |W_I,i|.
        scale_dependent = scale[dependent]
        relative = np.abs(beta) * scale[independent][:, None]
        relative = np.divide(
            relative,
            scale_dependent[None, :],
            out=np.zeros_like(relative),
            where=nonzero[dependent][None, :],  # zero columns regroup nowhere
        )
        beta = np.where(relative < 10.0**-decimals, 0.0, beta)
        beta = np.vectorize(lambda b: _snap(b, decimals), otypes=[float])(beta)

    matrix = np.zeros((independent.size, len(names)))
    matrix[np.arange(independent.size), independent] = 1.0
    matrix[:, dependent] = beta
    base_names = []
    definitions = []
    for i, column in enumerate(independent):
        definition = {names[column]: 1.0}
        for k, dep in enumerate(dependent):
            if beta[i, k] != 0.0:
                definition[names[dep]] = float(beta[i, k])
        definitions.append(definition)
        base_names.append(names[column] + ("R" if len(definition) > 1 else ""))
    dropped = diagonal[dependent][nonzero[dependent]]
    return BaseParameters(
        standard_names=names,
        names=tuple(base_names),
        independent=tuple(int(i) for i in independent),
        matrix=matrix,
        definitions=tuple(definitions),
        tolerance=tolerance,
        smallest_kept=float(diagonal[independent].min()),
        largest_dropped=float(dropped.max()) if dropped.size else 0.0,
    )
