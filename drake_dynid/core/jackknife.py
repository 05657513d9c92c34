"""Delete-one-group jackknife of a least-squares solution (docs/MATH.md §4).

Gautier's σ (``core.lsq``) assumes rows with independent errors of one variance
(per weight). The modulated equations of the on-line identifier are neither:
adjacent modulating functions share Fourier lines (correlation -0.5 for white
noise), the velocity-estimate noise enters the regressor itself, and a filter
bias differs from one modulating frequency to the next. The jackknife over groups
of rows (one group per pair of adjacent modulating functions) measures the spread
of the estimate between them instead of modelling it; the identifier reports the
larger of the two per parameter (``core.lsq.solve_window``,
``OnlineSettings.uncertainty``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = ["jackknife_std"]


def jackknife_std(
    A: Any,
    B: Any,
    groups: Any,
    *,
    weights: Any = None,
    factor: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Delete-one-group jackknife standard deviations of the least-squares solution.

    With θ̂_(g) the solution without the rows of group g (G groups) and θ̄ their
    mean::

        σ_J² = (G - 1)/G · Σ_g (θ̂_(g) - θ̄)²

    (docs/MATH.md §4). Each θ̂_(g) is a downdate of the full solution, not a new
    solve: with A S⁻¹ = Q R (S the column norms), e the residuals and Q_g, e_g the
    rows of group g, ``θ̂_(g) = θ̂ - S⁻¹ R⁻¹ Q_gᵀ (I - Q_g Q_gᵀ)⁻¹ e_g``. Unlike
    Gautier's σ it does not assume independent rows of equal variance: it follows
    the spread of the estimate between groups of rows (for the modulated
    equations, one group per pair of modulating functions).

    Args:
        A: (r, p) regressor, full column rank.
        B: (r,) observations.
        groups: (r,) integer group of every row.
        weights: optional (r,) row weights (the weighted problem's jackknife).
        factor: optional ``(R_inv, norms)`` of the solve that produced θ̂ (R⁻¹
            of the QR of the weighted, column-scaled A and the column norms S,
            ``core.lsq``), from a solve that found A full rank and well
            conditioned: then ``Q = A S⁻¹ R⁻¹`` and no new QR is taken.

    Returns:
        (p,) σ_J in the units of θ; NaN when there are fewer than 2 groups or
        deleting a group leaves a rank-deficient system.
    """
    owner = "jackknife_std"
    A = v.array(owner, "A", A)
    if A.ndim != 2:
        v.fail(owner, f"A must have shape (rows, p); got {A.shape}.")
    rows, p = A.shape
    B = v.array(owner, "B", B, shape=(rows,))
    groups = np.asarray(groups)
    if groups.shape != (rows,):
        v.fail(owner, f"groups must have shape ({rows},); got {groups.shape}.")
    if weights is not None:
        w = v.array(owner, "weights", weights, shape=(rows,))
        A, B = A * w[:, None], B * w
    labels = np.unique(groups)
    nan = np.full(p, np.nan)
    if factor is not None:
        R_inv, norms = factor
        if labels.size < 2 or rows <= p:
            return nan
        Q = (A / norms) @ R_inv
    else:
        norms = np.sqrt(np.einsum("ij,ij->j", A, A))
        if labels.size < 2 or rows <= p or np.any(norms <= 0.0):
            return nan
        Q, R = np.linalg.qr(A / norms)
        singular = np.linalg.svd(R, compute_uv=False)
        if singular[-1] <= singular[0] * max(rows, p) * np.finfo(float).eps:
            return nan
        R_inv = np.linalg.inv(R)
    residual = B - Q @ (Q.T @ B)
    # Groups of one size (the modulated equations' pairs of functions): all the
    # downdates in stacked calls; else one group at a time.
    sizes = np.unique(np.bincount(np.searchsorted(labels, groups)))
    if sizes.size == 1:
        order = np.argsort(groups, kind="stable")
        g = labels.size
        stacks = [(Q[order].reshape(g, -1, p), residual[order].reshape(g, -1))]
    else:
        stacks = [
            (Q[groups == label][None], residual[groups == label][None])
            for label in labels
        ]
    deleted = []
    for Qg, eg in stacks:
        leverage = np.eye(Qg.shape[1]) - Qg @ np.swapaxes(Qg, -1, -2)
        if np.linalg.eigvalsh(leverage)[:, 0].min() <= 1e-10:
            return nan  # the other groups alone do not determine θ
        solved = np.linalg.solve(leverage, eg[..., None])
        deleted.append((np.swapaxes(Qg, -1, -2) @ solved)[..., 0] @ R_inv.T)
    estimates = np.concatenate(deleted)
    spread = estimates - estimates.mean(axis=0)
    count = labels.size
    return np.sqrt((count - 1) / count * np.sum(spread**2, axis=0)) / norms
