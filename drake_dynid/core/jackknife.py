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

A group that alone carries most of a direction (the modulating function ℓ = 0,
the only one with a non-zero mean, carries the nearly constant gravity columns)
leaves a replicate without it almost undetermined there, and the plain deletion
blows its σ up: on the real TIAGo's final window (README) the replicate without
ℓ = 0, 1 keeps 8e-7 of one direction's information and the total mass M1R got
0.87 kg, 208 times the window's sandwich σ (the off-line fit: 0.0084 kg). Such a
group enters with its bias-reduced deviation instead, and a group near the limit
with a blend of the two that is continuous in μ (:data:`MIN_INFORMATION`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = [
    "MIN_INFORMATION",
    "deviation_power",
    "jackknife_std",
    "stacked_jackknife_std",
]

#: Where a group's deletion stops being trusted: the centre, in log μ, of the
#: decade over which a group whose deletion leaves the share μ_g of some
#: direction's information (the smallest eigenvalue of I - Q_g Q_gᵀ) passes from
#: the deletion's deviation S⁻¹ R⁻¹ Q_gᵀ (I - Q_g Q_gᵀ)⁻¹ e_g, whose variance
#: along that direction is 1/μ_g times the group's share, to the bias-reduced
#: S⁻¹ R⁻¹ Q_gᵀ (I - Q_g Q_gᵀ)^(-1/2) e_g (Bell and McCaffrey's CR2: unbiased
#: for independent rows of one variance); in between (I - Q_g Q_gᵀ)^(-p) with p
#: linear in log μ_g (:func:`deviation_power`, docs/MATH.md §4). Before, a
#: step at μ_g = 1e-5: σ fell 340 times as μ_g crossed it (tests). The TIAGo's
#: final window (μ = 8e-7): σ of M1R 0.87 -> 0.0042 kg. Low on purpose: the
#: Lagrangian benchmarks' windows (μ_g >= 3.6e-5, above the blend) keep their
#: deletions, whose larger σ covers a bias of the rows (at 0.05 the iiwa7's
#: err/σ p90 rose to 2.7-3.4 with filtered rows).
MIN_INFORMATION = 1e-5


def jackknife_std(
    A: Any,
    B: Any,
    groups: Any,
    *,
    weights: Any = None,
    factor: tuple[np.ndarray, np.ndarray] | None = None,
    min_information: float = MIN_INFORMATION,
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
    equations, one group per pair of modulating functions). A group whose
    deletion keeps little of some direction's information (μ_g, the smallest
    eigenvalue of I - Q_g Q_gᵀ, below √10 · ``min_information``) enters with
    ``S⁻¹ R⁻¹ Q_gᵀ (I - Q_g Q_gᵀ)^(-p) e_g`` in place of θ̂ - θ̂_(g), p from 1
    (the deletion) down to 1/2 (the bias-reduced deviation) a decade lower
    (:func:`deviation_power`, :data:`MIN_INFORMATION`).

    Args:
        A: (r, p) regressor, full column rank.
        B: (r,) observations.
        groups: (r,) integer group of every row.
        weights: optional (r,) row weights (the weighted problem's jackknife).
        factor: optional ``(R_inv, norms)`` of the solve that produced θ̂ (R⁻¹
            of the QR of the weighted, column-scaled A and the column norms S,
            ``core.lsq``), from a solve that found A full rank and well
            conditioned: then ``Q = A S⁻¹ R⁻¹`` and no new QR is taken.
        min_information: the centre of the decade of μ_g over which a
            group's deviation passes from the deletion's to the bias-reduced
            one; 0: every group's is the deletion's (the plain jackknife).

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
    return stacked_jackknife_std(
        Q[None], residual[None], groups, R_inv[None], norms[None], min_information
    )[0]


def stacked_jackknife_std(
    Q: np.ndarray,
    residual: np.ndarray,
    groups: np.ndarray,
    R_inv: np.ndarray,
    norms: np.ndarray,
    min_information: float = MIN_INFORMATION,
) -> np.ndarray:
    """:func:`jackknife_std` of K solves with the same row groups, stacked.

    Args:
        Q: (K, r, p) orthonormal factors ``A S⁻¹ R⁻¹`` of the (weighted) regressors.
        residual: (K, r) their residuals ``B - Q Qᵀ B``.
        groups: (r,) integer group of every row (at least two groups).
        R_inv: (K, p, p) the triangular factors' inverses.
        norms: (K, p) the column norms S.
        min_information: as :func:`jackknife_std`.

    Returns:
        (K, p) σ_J; NaN for a solve where deleting a group leaves θ undetermined.
    """
    K, _, p = Q.shape
    labels = np.unique(groups)
    # Groups of one size (the modulated equations' pairs of functions): all the
    # downdates in stacked calls; else one group at a time.
    sizes = np.unique(np.bincount(np.searchsorted(labels, groups)))
    if sizes.size == 1:
        order = np.argsort(groups, kind="stable")
        g = labels.size
        stacks = [
            (Q[:, order].reshape(K, g, -1, p), residual[:, order].reshape(K, g, -1))
        ]
    else:
        stacks = [
            (Q[:, groups == label][:, None], residual[:, groups == label][:, None])
            for label in labels
        ]
    determined = np.ones(K, dtype=bool)
    deleted = []
    for Qg, eg in stacks:
        Qg_t = np.swapaxes(Qg, -1, -2)
        leverage = np.eye(Qg.shape[2]) - Qg @ Qg_t
        # Below 1e-10 the other groups alone do not determine θ.
        fine = _smallest_above(leverage, 1e-10)
        determined &= fine
        leverage[~fine] = np.eye(Qg.shape[2])
        if min_information <= 0.0 or _all_above(leverage, _HALF * min_information):
            solved = np.linalg.solve(leverage, eg[..., None])
        else:  # a group within or below the blend somewhere: group by group
            solved = np.stack(
                [
                    _deviation(leverage[:, j], eg[:, j], min_information)
                    for j in range(Qg.shape[1])
                ],
                axis=1,
            )
        deleted.append((Qg_t @ solved)[..., 0] @ np.swapaxes(R_inv, 1, 2))
    estimates = np.concatenate(deleted, axis=1)  # (K, G, p)
    spread = estimates - estimates.mean(axis=1, keepdims=True)
    count = labels.size
    out = np.sqrt((count - 1) / count * np.sum(spread**2, axis=1)) / norms
    out[~determined] = np.nan
    return out


#: Half the blend's width in log μ: √10, the blend spans a decade.
_HALF = np.sqrt(10.0)


def deviation_power(mu: Any, centre: float = MIN_INFORMATION) -> np.ndarray:
    """The power p of a group's deviation ``S⁻¹ R⁻¹ Q_gᵀ (I - Q_g Q_gᵀ)^(-p) e_g``.

    ::

        p(μ) = 1/2 + 1/2 · clip(log10(μ / centre) + 1/2, 0, 1)

    μ: the group's μ_g (dimensionless, a share of information). p = 1 (the
    deletion, θ̂ - θ̂_(g)) for μ >= √10 · centre, p = 1/2 (the bias-reduced
    deviation) for μ <= centre/√10, linear in log μ between: a geometric blend
    of the two, each direction's factor (1/μ_k)^w (1/√μ_k)^(1 - w) with
    w = 2p - 1, continuous in μ (docs/MATH.md §4).
    """
    share = np.maximum(np.asarray(mu, dtype=float), np.finfo(float).tiny)
    return 0.5 + 0.5 * np.clip(np.log10(share / centre) + 0.5, 0.0, 1.0)


def _deviation(leverage: np.ndarray, e: np.ndarray, centre: float) -> np.ndarray:
    """L^(-p(μ)) e, L = I - Q_g Q_gᵀ, p from the smallest eigenvalue μ of L.

    ``leverage``: (K, n, n) L of one group in K solves; ``e``: (K, n). Returns
    (K, n, 1). One power per solve, for every direction of the group: the other
    directions of a group that alone carries one keep little information too
    (the TIAGo's final (ℓ = 0, 1): 1.4e-4, 1.7e-4, 7e-4 besides 8e-7), and
    their deletions gave σ of MX3R 2.04 kg·m instead of 0.106 (sandwich 0.064,
    off-line fit 0.021). The eigenvalues only when a Cholesky test fails.
    """
    if _all_above(leverage, _HALF * centre):
        return np.linalg.solve(leverage, e[..., None])
    mu, vectors = np.linalg.eigh(leverage)
    power = deviation_power(mu[:, :1], centre)  # (K, 1): per solve
    mu = np.maximum(mu, np.finfo(float).tiny)  # the undetermined: NaN in the caller
    projected = np.swapaxes(vectors, -1, -2) @ e[..., None]
    return vectors @ (projected / (mu**power)[..., None])


def _smallest_above(matrices: np.ndarray, limit: float) -> np.ndarray:
    """Whether the smallest eigenvalue of each symmetric (K, g, n, n) is > ``limit``.

    Per K: all g of them. ``M - limit·I`` has a Cholesky factor exactly when every
    eigenvalue of M is above the limit (to round-off): one stacked factorisation,
    a tenth of the eigenvalues' cost; when one fails, the eigenvalues decide.
    """
    if _all_above(matrices, limit):
        return np.ones(matrices.shape[0], dtype=bool)
    return np.linalg.eigvalsh(matrices)[..., 0].min(axis=1) > limit


def _all_above(matrices: np.ndarray, limit: float) -> bool:
    """Whether every eigenvalue of every symmetric matrix is above ``limit``.

    ``M - limit·I`` has a Cholesky factor exactly then (to round-off).
    """
    try:
        np.linalg.cholesky(matrices - limit * np.eye(matrices.shape[-1]))
    except np.linalg.LinAlgError:
        return False
    return True
