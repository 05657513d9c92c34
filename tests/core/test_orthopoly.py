"""core.orthopoly against scipy.special (the oracle it replaces at start-up)."""

import numpy as np
import pytest
from scipy import special

from drake_dynid.core.orthopoly import gauss_jacobi, jacobi_polynomial, log_gamma

SHAPES = [(0.0, 0.0), (1.0, 1.0), (0.5, 2.0), (2.0, 0.5), (-0.5, -0.5), (3.0, 5.0)]


@pytest.mark.parametrize("alpha, beta", SHAPES)
@pytest.mark.parametrize("points", [1, 2, 3, 4, 20, 22])
def test_gauss_jacobi_equals_scipy_roots_jacobi(alpha, beta, points):
    nodes, weights = gauss_jacobi(points, alpha, beta)
    reference_nodes, reference_weights = special.roots_jacobi(points, alpha, beta)
    np.testing.assert_allclose(nodes, reference_nodes, rtol=0, atol=1e-13)
    np.testing.assert_allclose(weights, reference_weights, rtol=1e-11)


@pytest.mark.parametrize("alpha, beta", SHAPES)
def test_jacobi_polynomial_equals_scipy_eval_jacobi(alpha, beta):
    x = np.linspace(-1.0, 1.0, 9)
    for n in range(8):
        np.testing.assert_allclose(
            jacobi_polynomial(n, alpha, beta, x),
            special.eval_jacobi(n, alpha, beta, x),
            rtol=1e-12,
            atol=1e-12,
        )


def test_log_gamma_equals_scipy_gammaln():
    for x in (0.5, 1.0, 2.5, 7.0, 30.5):
        assert log_gamma(x) == pytest.approx(special.gammaln(x), rel=1e-14)
