r"""Honest standard deviations of a window's solve: correlated, unequal row noise.

Gautier's ``C_X = σ_ρ² (AᵀA)⁻¹`` (``core.lsq``) assumes independent rows of equal
noise. The rows of a modulated window are neither (docs/MATH.md §4): rows of
nearby modulating functions share noise (the paper's ℓ = 0:0.05:10 repeats each
independent row about twenty times, and Gautier's σ comes out 5-10 times too
small), and rows of higher frequency carry more velocity-estimate noise. With the
row noise modelled as ``Σ = σ² S C S`` per equation (``C`` the correlation of the
rows of one equation under white noise, ``FourierBank.row_correlation``; ``S`` the
relative noise std of each row from :func:`noise_model_std`, the variance model
``a_j + b_j ν² + c_j ν⁴`` fitted to the residuals of equation j: torque noise
enters every row alike, the velocity estimate's noise through ġ (∝ ν) in the
friction and Coriolis terms and, with its spectrum ∝ f², through ġ·v̂ (∝ ν²) in
the inertial ones), the estimate ``X̂ = (ÃᵀÃ)⁻¹ Ãᵀ B̃`` of the (weighted) rows
``Ã = W A`` has the sandwich covariance::

    C_X = σ̂² (ÃᵀÃ)⁻¹ M (ÃᵀÃ)⁻¹,      M = Σ_j Ã_jᵀ S_j C S_j Ã_j
    σ̂²  = ‖W (B - A X̂)‖² / (tr(S C S) - tr((ÃᵀÃ)⁻¹ M))     (E‖ρ̃‖² = σ² tr((I-H)SCS))

and the residual's effective degrees of freedom (Satterthwaite)::

    ν_eff = tr((I-H) SCS)² / tr(((I-H) SCS)²)

which measure how well σ̂ itself is known: a window with ν_eff below
:data:`MIN_RESIDUAL_DOF` cannot give an honest σ and is reported invalid. With
independent equal rows (C = S = 1) this is Gautier's formula and ν_eff = r - p.
Everything is computed from p × p matrices and a factor of C (R1 × k, k its
numerical rank) per equation: the cost is small beside the solve.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = [
    "MIN_RESIDUAL_DOF",
    "HonestStd",
    "RowNoise",
    "honest_std",
    "noise_model_std",
    "row_noise",
    "sandwich_covariance",
    "stacked_honest_std",
]

#: Fewest effective residual degrees of freedom of a window reported valid: with
#: ν_eff = 4 the estimated σ is within a factor 0.5-1.4 of the true one in 80 %
#: of the windows (χ² quantiles) and its median within 10 %; below it σ itself is
#: a guess (ν_eff = 1: a factor 0.16-1.6).
MIN_RESIDUAL_DOF = 4.0


@dataclass(frozen=True, eq=False)
class RowNoise:
    """The noise structure of the rows of a window (see the module docstring).

    Attributes:
        frequency: (r,) frequency index ν of each row (``bank.row_frequencies``).
        group: (r,) equation j of each row (its noise group).
        correlation: (R1, R1) correlation of the rows of one equation, in their
            order (the same for every group; R1 = r / m).
        factor: (R1, k) with ``factor @ factor.T == correlation`` (eigenvalues
            below 1e-12 of the largest dropped): the sandwich costs R1·k·p per
            equation (k ≈ 27 for the paper's 402 correlated rows).
    """

    frequency: np.ndarray
    group: np.ndarray
    correlation: np.ndarray
    factor: np.ndarray

    @property
    def num_rows(self) -> int:
        """r, the rows of the window."""
        return int(self.frequency.shape[0])


def row_noise(bank: Any, m: int) -> RowNoise:
    """The :class:`RowNoise` of ``bank``'s rows for ``m`` equations per sample.

    A bank without ``row_correlation`` (another modulating family) gets C = 1
    (independent rows).
    """
    owner = "row_noise"
    m = v.integer(owner, "m", m, minimum=1)
    frequency, group = bank.row_frequencies(m)
    frequency = np.asarray(frequency, dtype=float)
    group = np.asarray(group, dtype=int)
    per_group = frequency.shape[0] // m
    if hasattr(bank, "row_correlation"):
        correlation = np.asarray(bank.row_correlation(), dtype=float)
    else:
        correlation = np.eye(per_group)
    if correlation.shape != (per_group, per_group):
        v.fail(
            owner,
            f"the bank's row_correlation must have shape ({per_group}, {per_group}); "
            f"got {correlation.shape}.",
        )
    values, vectors = np.linalg.eigh(correlation)
    keep = values > 1e-12 * values.max()
    factor = vectors[:, keep] * np.sqrt(values[keep])
    for array in (frequency, group, correlation, factor):
        array.flags.writeable = False
    return RowNoise(
        frequency=frequency, group=group, correlation=correlation, factor=factor
    )


def noise_model_std(
    residual: np.ndarray, frequency: np.ndarray, group: np.ndarray
) -> np.ndarray:
    """Modelled noise std of every row, from its equation's residuals.

    Per equation j, ``σ_j²(ν) = a_j + b_j ν² + c_j ν⁴`` (a, b, c >= 0, non-negative
    least squares on the squared residuals, scaled so that no square overflows),
    floored at 1e-3 of the equation's largest variance. A model with one term
    less (the weights' a + bν²) leaves σ of the inertial parameters up to 2.5
    times too large on 5 s windows (benchmarks/bench_sigma.py).

    Args:
        residual: (r,) residuals ``B - A X̂`` [unit of B], or (K, r): K windows
            with the same rows, each fitted apart.
        frequency: (r,) frequency index ν of each row.
        group: (r,) equation of each row.

    Returns:
        σ_i [unit of B] of the shape of ``residual`` (ones for an equation whose
        residuals are all 0).
    """
    labels, index = np.unique(group, return_inverse=True)
    index = index.reshape(-1)
    count = labels.size
    if index.size == 0:
        return np.ones(np.shape(residual))
    stacked = np.reshape(residual, (-1, index.size))
    windows = np.arange(stacked.shape[0])[:, None]
    scale = np.zeros((stacked.shape[0], count))
    np.maximum.at(scale, (windows, index), np.abs(stacked))
    nu2 = frequency**2
    model = np.stack([np.ones_like(nu2), nu2, nu2 * nu2], axis=1)
    top = np.zeros((count, 3))
    np.maximum.at(top, index, model)
    top[top == 0.0] = 1.0
    fitted = scale > 0.0
    safe = np.where(fitted, scale, 1.0)[:, index]
    model = model / top[index]
    coefficients = nonnegative_fit(model, (stacked / safe) ** 2, index, count)
    variance = np.einsum("ik,wik->wi", model, coefficients[:, index])
    peak = np.zeros(scale.shape)
    np.maximum.at(peak, (windows, index), variance)
    use = (fitted & (peak > 0.0))[:, index]
    out = np.ones_like(stacked)
    out[use] = (safe * np.sqrt(np.maximum(variance, 1e-3 * peak[:, index])))[use]
    return out.reshape(np.shape(residual))


def nonnegative_fit(
    model: np.ndarray, y: np.ndarray, index: np.ndarray, count: int
) -> np.ndarray:
    """Per group g: ``argmin ‖M_g x - y_g‖²`` subject to x >= 0, for 3 columns.

    The non-negative least squares of three columns by enumeration: the optimum
    is the unconstrained least squares on its own support, so it is the
    feasible (all coefficients >= 0) support solution of least cost among the 8
    supports (the empty one costs 0). The support solves use the groups' Gram
    matrices (columns scaled to at most 1 by the caller) in closed form,
    vectorised over groups and over the leading axes of ``y``; the fitted values
    equal scipy's ``nnls`` to round-off (tests/core/test_row_noise.py).

    Args:
        model: (r, 3) columns M of every row.
        y: (r,) observations, or (..., r): as many fits of the same M.
        index: (r,) group of every row, in 0..count-1.
        count: number of groups.

    Returns:
        (..., count, 3) coefficients (zeros for a group whose best fit is 0).
    """
    rows = model.shape[0]
    member = np.zeros((count, rows))
    member[index, np.arange(rows)] = 1.0
    products = (model[:, :, None] * model[:, None, :]).reshape(rows, 9)
    gram = (member @ products).reshape(count, 3, 3)
    c = member @ (model * y[..., None])  # (..., count, 3)
    d = np.diagonal(gram, axis1=1, axis2=2)
    # Supports: {}, 3 singles, 3 pairs, all; usable (count, 8) from M alone.
    candidates = np.zeros((*c.shape[:-1], 8, 3))
    usable = np.zeros((count, 8), dtype=bool)
    usable[:, 0] = True
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(3):  # one column
            usable[:, 1 + k] = d[:, k] > 0.0
            candidates[..., 1 + k, k] = c[..., k] / d[:, k]
        for slot, (i, j) in enumerate(((0, 1), (0, 2), (1, 2))):  # two, Cramer
            g = gram[:, i, j]
            det = d[:, i] * d[:, j] - g * g
            # Hadamard ratio det/(g_ii g_jj) near 0: a dependent pair.
            usable[:, 4 + slot] = det > 1e-10 * d[:, i] * d[:, j]
            candidates[..., 4 + slot, i] = (c[..., i] * d[:, j] - c[..., j] * g) / det
            candidates[..., 4 + slot, j] = (c[..., j] * d[:, i] - c[..., i] * g) / det
        det = np.linalg.det(gram)
        full = det > 1e-10 * np.prod(d, axis=1)
        usable[:, 7] = full
        if full.any():
            candidates[..., full, 7, :] = np.linalg.solve(
                gram[full], c[..., full, :, None]
            )[..., 0]
    candidates[..., ~usable, :] = 0.0
    cost = -np.einsum("...gsk,...gk->...gs", candidates, c)  # ‖y-Mx‖² - ‖y‖² at LS
    feasible = usable & (candidates >= 0.0).all(axis=-1)
    best = np.argmin(np.where(feasible, cost, np.inf), axis=-1)
    return np.take_along_axis(candidates, best[..., None, None], axis=-2)[..., 0, :]


@dataclass(frozen=True)
class HonestStd:
    """Outcome of :func:`honest_std`.

    Attributes:
        std: (p,) standard deviations of X̂ [units of X].
        residual_std: σ̂, the noise scale of the weighted rows.
        dof: effective residual degrees of freedom ν_eff.
    """

    std: np.ndarray
    residual_std: float
    dof: float


def honest_std(
    A: np.ndarray,
    B: np.ndarray,
    theta: np.ndarray,
    weights: np.ndarray,
    relative_std: np.ndarray,
    noise: RowNoise,
    *,
    factor: tuple[np.ndarray, np.ndarray] | None = None,
) -> HonestStd:
    """Sandwich standard deviations of ``X̂ = argmin ‖W (B - A X)‖`` (module doc).

    Args:
        A: (r, p) regressor (unweighted).
        B: (r,) observations.
        theta: (p,) the estimate.
        weights: (r,) row weights W of the solve (ones for ordinary LS).
        relative_std: (r,) modelled noise std of each row, up to one scale (e.g.
            ``1/frequency_noise_weights``).
        noise: the rows' :class:`RowNoise`.
        factor: optional ``(R_inv, norms)`` of the weighted solve (R⁻¹ of the QR
            of ``W A`` with its columns divided by ``norms``, ``core.lsq``):
            reused instead of a new QR.

    Returns:
        :class:`HonestStd` (std NaN and dof 0 when the residual has no degree of
        freedom left).
    """
    if factor is None:
        Aw = A * weights[:, None]
        scale = np.max(np.abs(Aw), axis=0)
        scale[scale == 0.0] = 1.0
        norms = scale * np.sqrt(np.einsum("ij,ij->j", Aw / scale, Aw / scale))
        R_inv = np.linalg.inv(np.asarray(np.linalg.qr(Aw / norms, mode="r")))
    else:
        R_inv, norms = factor
    std, residual_std, dof = stacked_honest_std(
        A[None],
        B[None],
        theta[None],
        weights[None],
        relative_std[None],
        noise,
        R_inv[None],
        norms[None],
    )
    std = std[0]
    std.flags.writeable = False
    return HonestStd(std=std, residual_std=float(residual_std[0]), dof=float(dof[0]))


def stacked_honest_std(
    A: np.ndarray,
    B: np.ndarray,
    theta: np.ndarray,
    weights: np.ndarray,
    relative_std: np.ndarray,
    noise: RowNoise,
    R_inv: np.ndarray,
    norms: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`honest_std` of K windows with the same rows, in stacked products.

    Args:
        A: (K, r, p) regressors (unweighted).
        B: (K, r) observations.
        theta: (K, p) the estimates.
        weights: (K, r) row weights of the solves.
        relative_std: (K, r) modelled noise std of the rows.
        noise: the rows' :class:`RowNoise`.
        R_inv: (K, p, p) R⁻¹ of the QR of each ``W A`` with its columns divided by
            ``norms``.
        norms: (K, p) those column norms.

    Returns:
        ``(std (K, p), residual_std (K,), dof (K,))``: NaN, NaN and 0 for a window
        whose residual has no degree of freedom left.
    """
    std, sigma, dof, _ = _sandwich(
        A, B, theta, weights, relative_std, noise, R_inv, norms
    )
    return std, sigma, dof


def sandwich_covariance(
    A: np.ndarray,
    B: np.ndarray,
    theta: np.ndarray,
    weights: np.ndarray,
    relative_std: np.ndarray,
    noise: RowNoise,
    R_inv: np.ndarray,
    norms: np.ndarray,
) -> np.ndarray:
    """The full (p, p) sandwich covariance C_X of one window (module docstring).

    Arguments as :func:`honest_std` with its ``factor`` ``(R_inv, norms)``
    (one window, unstacked): every entry of
    ``C_X = σ̂² S⁻¹ (ÃᵀÃ)⁻¹ M (ÃᵀÃ)⁻¹ S⁻¹``, whose diagonal is
    :func:`honest_std`'s σ² to round-off [units of X, squared]; symmetric
    positive semi-definite. NaN when the residual has no degree of freedom left.
    For the final solve only (``core.weighted_lsq.window_covariance``): the
    identifier's every solve keeps the diagonal.
    """
    _, _, _, covariance = _sandwich(
        A[None],
        B[None],
        theta[None],
        weights[None],
        relative_std[None],
        noise,
        R_inv[None],
        norms[None],
        full=True,
    )
    assert covariance is not None
    return covariance[0]


def _sandwich(
    A: np.ndarray,
    B: np.ndarray,
    theta: np.ndarray,
    weights: np.ndarray,
    relative_std: np.ndarray,
    noise: RowNoise,
    R_inv: np.ndarray,
    norms: np.ndarray,
    *,
    full: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """:func:`stacked_honest_std` and, with ``full``, the (K, p, p) covariances."""
    K, _, p = A.shape
    As = (A * weights[..., None]) / norms[:, None, :]
    inverse = R_inv @ np.swapaxes(R_inv, 1, 2)
    s = weights * relative_std
    s = s / np.sqrt(np.mean(s * s, axis=1, keepdims=True))  # one scale, fitted below
    # Σ_j = S_j C S_j = (S_j F)(S_j F)ᵀ with F the correlation's factor (R1 × k):
    # Ãᵀ Σ Ã = YᵀY with Y = (S F)ᵀ Ã, (Σ Ã)ᵀ(Σ Ã) = Yᵀ G Y with G = (S F)ᵀ(S F),
    # every group j (R1 rows each, in order) in stacked products.
    F = noise.factor
    order = np.argsort(noise.group, kind="stable")
    count = order.size // F.shape[0]
    SF = s[:, order].reshape(K, count, -1, 1) * F  # (K, g, R1, k)
    SFt = np.swapaxes(SF, 2, 3)
    Y = SFt @ As[:, order].reshape(K, count, -1, p)  # (K, g, k, p)
    G = SFt @ SF  # (K, g, k, k)
    stacked = Y.reshape(K, -1, p)
    stacked_t = np.swapaxes(stacked, 1, 2)
    meat = stacked_t @ stacked
    meat_sq = stacked_t @ (G @ Y).reshape(K, -1, p)
    trace_s = np.sum(s * s, axis=1)
    trace_s2 = np.sum(G * G, axis=(1, 2, 3))
    hat = inverse @ meat
    if full:  # C_X = σ̂² S⁻¹ (ÃᵀÃ)⁻¹ M (ÃᵀÃ)⁻¹ S⁻¹, every entry (final solve only)
        sandwich = (hat @ inverse) / (norms[:, :, None] * norms[:, None, :])
    dof_num = trace_s - np.trace(hat, axis1=1, axis2=2)
    denominator = (
        trace_s2
        - 2.0 * np.einsum("kij,kji->k", inverse, meat_sq)
        + np.sum(hat * np.swapaxes(hat, 1, 2), axis=(1, 2))
    )
    has_dof = dof_num > 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        dof = np.where(has_dof & (denominator > 0.0), dof_num**2 / denominator, 0.0)
        residual = (B - (A @ theta[..., None])[..., 0]) * weights
        r_scale = np.max(np.abs(residual), axis=1)
        r_scale[r_scale == 0.0] = 1.0
        sigma2 = (
            r_scale**2 * np.sum((residual / r_scale[:, None]) ** 2, axis=1) / dof_num
        )
        variance = sigma2[:, None] * np.einsum("kij,kji->ki", hat, inverse)
    std = np.sqrt(np.clip(variance, 0.0, None)) / norms
    std[~has_dof] = np.nan
    sigma = np.where(has_dof, np.sqrt(np.where(has_dof, sigma2, 0.0)), np.nan)
    if full:
        with np.errstate(invalid="ignore"):
            covariance = sigma2[:, None, None] * sandwich
        covariance = 0.5 * (covariance + np.swapaxes(covariance, 1, 2))
        covariance[~has_dof] = np.nan
        return std, sigma, dof, covariance
    return std, sigma, dof, None
