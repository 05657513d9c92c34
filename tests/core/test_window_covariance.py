"""core.weighted_lsq.window_covariance: the solve_window result and the full
covariance of its estimator (sandwich, generalised least squares, Gautier), its
diagonal the σ the solve reports exactly."""

import numpy as np
import pytest

from drake_dynid.core.row_noise import RowNoise
from drake_dynid.core.weighted_lsq import solve_window, window_covariance


def _correlation(covariance):
    scale = np.sqrt(np.diag(covariance))
    return covariance / np.outer(scale, scale)


def _problem(seed=0, groups=2, per_group=30, p=4, rho=0.6):
    rng = np.random.default_rng(seed)
    r = groups * per_group
    A = rng.standard_normal((r, p)) + np.linspace(0, 1, r)[:, None]
    lags = np.abs(np.subtract.outer(np.arange(per_group), np.arange(per_group)))
    C = rho**lags  # rows of one equation share noise (AR(1))
    values, vectors = np.linalg.eigh(C)
    noise = RowNoise(
        frequency=np.zeros(r),  # a constant noise model per equation
        group=np.repeat(np.arange(groups), per_group),
        correlation=C,
        factor=vectors * np.sqrt(values),
    )
    Sigma = np.kron(np.eye(groups), C)
    B = A @ np.arange(1.0, p + 1) + np.linalg.cholesky(Sigma) @ rng.standard_normal(r)
    return A, B, noise, Sigma


def test_the_sandwich_correlation_is_that_of_the_estimators_covariance():
    A, B, noise, Sigma = _problem(groups=1, per_group=60)  # one noise level
    found = window_covariance(A, B, noise=noise)
    plain = solve_window(A, B, noise=noise)
    np.testing.assert_array_equal(found.result.theta, plain.theta)
    np.testing.assert_array_equal(found.result.std, plain.std)
    assert found.method == "sandwich"
    np.testing.assert_array_equal(np.diag(found.covariance), plain.std**2)
    np.testing.assert_array_equal(found.covariance, found.covariance.T)
    # OLS of rows with covariance Σ: (AᵀA)⁻¹ AᵀΣA (AᵀA)⁻¹.
    inverse = np.linalg.inv(A.T @ A)
    exact = inverse @ A.T @ Sigma @ A @ inverse
    np.testing.assert_allclose(found.correlation, _correlation(exact), atol=1e-10)
    # Not the correlation of (AᵀA)⁻¹ alone (the approximate metric of before).
    assert np.abs(found.correlation - _correlation(inverse)).max() > 0.02


def test_the_jackknife_scales_rows_and_columns_keeping_the_correlation():
    A, B, noise, _ = _problem(seed=1, groups=2, per_group=40)
    groups = np.tile(np.repeat(np.arange(8), 5), 2)
    found = window_covariance(A, B, noise=noise, jackknife=groups)
    plain = solve_window(A, B, noise=noise, jackknife=groups)
    sandwich = window_covariance(A, B, noise=noise)
    np.testing.assert_array_equal(found.result.std, plain.std)
    assert np.any(plain.std > sandwich.result.std * (1 + 1e-9))  # the jackknife's
    np.testing.assert_array_equal(np.diag(found.covariance), plain.std**2)
    np.testing.assert_allclose(found.correlation, sandwich.correlation, atol=1e-14)
    assert np.linalg.eigvalsh(found.covariance).min() > -1e-12 * found.covariance.max()


def test_the_covariance_weighting_gives_the_generalised_least_squares_covariance():
    A, B, _, Sigma = _problem(seed=2)
    found = window_covariance(A, B, covariance=lambda theta: Sigma)
    plain = solve_window(A, B, covariance=lambda theta: Sigma)
    np.testing.assert_array_equal(found.result.theta, plain.theta)
    assert found.method == "gls"
    exact = np.linalg.inv(A.T @ np.linalg.solve(Sigma, A))
    np.testing.assert_allclose(found.correlation, _correlation(exact), atol=1e-10)
    np.testing.assert_array_equal(np.diag(found.covariance), plain.std**2)


@pytest.mark.parametrize("weighted", [False, True])
def test_gautiers_covariance_without_a_noise_model(weighted):
    A, B, _, _ = _problem(seed=3)
    weighting = (
        (np.tile(np.arange(30.0), 2), np.repeat([0, 1], 30)) if weighted else None
    )
    found = window_covariance(A, B, weighting)
    plain = solve_window(A, B, weighting)
    assert found.method == "gautier"
    np.testing.assert_array_equal(found.result.theta, plain.theta)
    np.testing.assert_allclose(np.sqrt(np.diag(found.covariance)), plain.std, rtol=0)
    if not weighted:
        exact = plain.residual_std**2 * np.linalg.inv(A.T @ A)
        np.testing.assert_allclose(found.covariance, exact, rtol=1e-9)


def test_an_invalid_window_gives_nan():
    A = np.ones((10, 2))
    found = window_covariance(A, np.ones(10))
    assert not found.result.valid
    assert np.isnan(found.covariance).all() and np.isnan(found.correlation).all()
