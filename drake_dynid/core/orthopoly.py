"""Jacobi polynomials and Gauss-Jacobi rules in numpy (docs/MATH.md §1).

The Jacobi differentiator's design (``core.jacobi_design``) needs
``P_n^{(α,β)}(x)``, the roots of ``P_{q+1}`` and Gauss-Jacobi quadrature. These
are the textbook three-term recurrence and the Golub-Welsch eigenvalue method,
written here so that designing a filter does not import ``scipy.special`` (about
0.1-0.2 s at the start of every ``dynid identify``); they equal
``scipy.special.eval_jacobi`` / ``roots_jacobi`` to round-off
(tests/core/test_orthopoly.py).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["gauss_jacobi", "jacobi_polynomial", "log_gamma"]


def log_gamma(x: float) -> float:
    """ln|Γ(x)| (``scipy.special.gammaln``), x not a non-positive integer."""
    return math.lgamma(float(x))


def jacobi_polynomial(n: int, alpha: float, beta: float, x: Any) -> np.ndarray:
    """``P_n^{(α,β)}(x)`` by the three-term recurrence, α, β > -1, n >= 0.

    ``P_0 = 1``, ``P_1 = (α+1) + (α+β+2)(x-1)/2`` and, with c = 2m + α + β,
    ``2(m+1)(m+α+β+1) c P_{m+1} = (c+1)[(c+2) c x + α² - β²] P_m
    - 2(m+α)(m+β)(c+2) P_{m-1}`` (DLMF 18.9.2). Dimensionless.
    """
    x = np.asarray(x, dtype=float)
    previous = np.ones_like(x)
    if n == 0:
        return previous
    current = (alpha + 1.0) + (alpha + beta + 2.0) * (x - 1.0) / 2.0
    for m in range(1, n):
        c = 2 * m + alpha + beta
        previous, current = current, (
            (c + 1.0) * ((c + 2.0) * c * x + alpha**2 - beta**2) * current
            - 2.0 * (m + alpha) * (m + beta) * (c + 2.0) * previous
        ) / (2.0 * (m + 1) * (m + alpha + beta + 1.0) * c)
    return current


def gauss_jacobi(
    points: int, alpha: float, beta: float
) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of the Gauss-Jacobi rule, α, β > -1.

    ``∫_{-1}^{1} (1-x)^α (1+x)^β f(x) dx ≈ Σ w_i f(x_i)``, exact for polynomials of
    degree 2·points - 1. Golub-Welsch: the nodes are the eigenvalues of the
    symmetric tridiagonal matrix of the monic recurrence (diagonal a_m, off
    diagonal √b_m), the weights μ₀ v_{0,i}² with v_i the unit eigenvectors and
    μ₀ = 2^{α+β+1} Γ(α+1) Γ(β+1) / Γ(α+β+2). The nodes are the roots of
    ``P_points^{(α,β)}``, increasing.
    """
    m = np.arange(points, dtype=float)
    c = 2.0 * m + alpha + beta
    diagonal = np.empty(points)
    diagonal[0] = (beta - alpha) / (alpha + beta + 2.0)
    diagonal[1:] = (beta**2 - alpha**2) / (c[1:] * (c[1:] + 2.0))
    k = m[1:]
    ck = c[1:]
    # b_1 written without its (α+β+1)/(α+β+1) factor (finite at α+β = -1).
    off = np.empty(points - 1)
    if points > 1:
        first = 2.0 + alpha + beta
        off[0] = 4.0 * (1.0 + alpha) * (1.0 + beta) / (first**2 * (first + 1.0))
        off[1:] = (
            4.0 * k[1:] * (k[1:] + alpha) * (k[1:] + beta) * (k[1:] + alpha + beta)
            / (ck[1:] ** 2 * (ck[1:] + 1.0) * (ck[1:] - 1.0))
        )
    matrix = np.diag(diagonal) + np.diag(np.sqrt(off), 1) + np.diag(np.sqrt(off), -1)
    nodes, vectors = np.linalg.eigh(matrix)
    log_mu0 = (
        (alpha + beta + 1.0) * math.log(2.0)
        + log_gamma(alpha + 1.0)
        + log_gamma(beta + 1.0)
        - log_gamma(alpha + beta + 2.0)
    )
    weights = math.exp(log_mu0) * vectors[0] ** 2
    return nodes, weights
