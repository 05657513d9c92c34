"""Which parameters changed: forward selection on the residual of a reference.

After an abrupt change (``core.change``) the segment of data since the change is
short: its equations ``A θ = B`` (``core.segment``) cannot determine all p
parameters (a second of a 0.1-0.6 Hz motion excites few directions; the full
solve of a 1 s window misses ZZ1R of the paper's 2R arm by 30-90 %), but they
can say which parameters moved. With the estimate before the change θ_ref and
its residual ``r₀ = B - A θ_ref``, forward selection adds, one at a time, the
parameter whose column explains most of the remaining residual, while the
addition is significant (docs/MATH.md §4, change detection)::

    gain_j = (a_j⊥ᵀ r)² / ‖a_j⊥‖²          (a_j⊥: column j orthogonal to the chosen)
    F = gain_j / (RSS_new / (r - k - 1)) > F_{1, r-k-1}(α / candidates)

(k the parameters already chosen, r the rows, RSS_new = ‖r‖² - gain_j; the level
α is divided by the number of candidates: the best of many columns is tested).
The chosen set S is then solved, ``Δ = argmin ‖A_S Δ - r₀‖``, θ = θ_ref + Δ on S,
θ_ref elsewhere, with Gautier's σ on S (``core.lsq``) and the reference σ
elsewhere. Columns are scaled to unit norm; a column whose part orthogonal to
the chosen ones is below 1/max_condition of its norm is not a candidate.

Pure numpy and ``scipy.stats`` (the F quantile).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION, solve_least_squares

__all__ = ["MIN_DOF", "Isolation", "isolate_change"]

#: Fewest residual degrees of freedom left after a selection (r - k - 1).
MIN_DOF = 4


@dataclass(frozen=True, eq=False)
class Isolation:
    """Outcome of :func:`isolate_change`.

    Attributes:
        theta: (p,) θ_ref with the chosen parameters re-estimated.
        std: (p,) Gautier's σ of the chosen, the reference σ of the others.
        selected: (p,) bool, the chosen parameters (the ones found changed).
        condition_number: of the chosen columns, scaled (1 when none).
        valid: False when the chosen columns could not be solved.
    """

    theta: np.ndarray
    std: np.ndarray
    selected: np.ndarray
    condition_number: float
    valid: bool


def _critical(alpha: float, dof: int) -> float:
    from scipy.stats import f

    return float(f.isf(alpha, 1, dof))


def isolate_change(
    A: Any,
    B: Any,
    reference: Any,
    reference_std: Any,
    *,
    alpha: float = 1e-3,
    max_condition: float = DEFAULT_MAX_CONDITION,
) -> Isolation:
    """Forward selection of the changed parameters (module docstring).

    Args:
        A: (r, p) equations of the segment since the change.
        B: (r,) their right-hand side.
        reference: (p,) θ_ref, the estimate before the change.
        reference_std: (p,) its σ.
        alpha: level of each addition's F-test, before the division by the
            number of candidates, in (0, 1).
        max_condition: largest accepted condition number of the chosen columns
            (scaled).
    """
    owner = "isolate_change"
    A = v.array(owner, "A", A)
    if A.ndim != 2:
        v.fail(owner, f"A must be 2-D (rows, p); got shape {A.shape}.")
    rows, p = A.shape
    B = v.array(owner, "B", B, shape=(rows,))
    theta_ref = v.array(owner, "reference", reference, shape=(p,))
    std_ref = np.asarray(reference_std, dtype=float)
    if std_ref.shape != (p,):
        v.fail(owner, f"reference_std must have shape ({p},); got {std_ref.shape}.")
    alpha = v.positive(owner, "alpha", alpha)
    if alpha >= 1.0:
        v.fail(owner, f"alpha must be in (0, 1); got {alpha:g}.")
    residual0 = B - A @ theta_ref
    norms = np.linalg.norm(A, axis=0)
    usable = norms > 0.0
    unit = np.divide(A, norms, out=np.zeros_like(A), where=usable)
    basis = np.zeros((rows, 0))
    residual = residual0.copy()
    chosen: list[int] = []
    while len(chosen) < p:
        dof = rows - len(chosen) - 1
        if dof < MIN_DOF:
            break
        orth = unit - basis @ (basis.T @ unit)
        length = np.linalg.norm(orth, axis=0)
        candidate = usable & (length > 1.0 / max_condition)
        candidate[chosen] = False
        count = int(candidate.sum())
        if count == 0:
            break
        safe = np.where(candidate, length, 1.0)
        gain = np.where(candidate, (orth.T @ residual / safe) ** 2, -1.0)
        best = int(np.argmax(gain))
        rss = float(residual @ residual) - gain[best]
        if not rss > 0.0:
            rss = np.finfo(float).tiny
        if gain[best] * dof / rss <= _critical(alpha / count, dof):
            break
        direction = orth[:, best] / length[best]
        basis = np.column_stack((basis, direction))
        residual = residual - direction * (direction @ residual)
        chosen.append(best)
    selected = np.zeros(p, dtype=bool)
    theta = theta_ref.copy()
    std = std_ref.copy()
    if not chosen:
        return Isolation(theta, std, selected, 1.0, True)
    order = sorted(chosen)
    fit = solve_least_squares(A[:, order], residual0, max_condition=max_condition)
    if not fit.valid:
        return Isolation(theta, std, selected, float(fit.condition_number), False)
    selected[order] = True
    theta[order] += fit.theta
    std[order] = fit.std
    return Isolation(theta, std, selected, float(fit.condition_number), True)
