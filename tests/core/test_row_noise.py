"""Honest σ of correlated, unequal rows; glitch resynchronisation; bank limits.

Seeds are stated per test (np.random.default_rng(seed)).
"""

import numpy as np
import pytest

from drake_dynid.core import lsq
from drake_dynid.core.equations import direct_fourier_integrals
from drake_dynid.core.fourier_bank import (
    MAX_FUNCTIONS,
    default_frequencies,
    fourier_bank,
    paper_frequencies,
)
from drake_dynid.core.row_noise import (
    MIN_RESIDUAL_DOF,
    honest_std,
    noise_model_std,
    nonnegative_fit,
    row_noise,
)
from drake_dynid.core.sliding import (
    RESYNC_RATIO,
    sliding_fourier_integrals,
    sliding_init,
    sliding_push,
    sliding_push_many,
)


def test_row_correlation_is_a_correlation_and_orthogonal_for_integer_nu():
    bank = fourier_bank(20.0, 0.02, order=1, ell=np.arange(10.0))
    C = bank.row_correlation()
    assert C.shape == (20, 20)
    np.testing.assert_allclose(np.diag(C), 1.0)
    np.testing.assert_allclose(C, C.T, atol=1e-15)
    assert np.min(np.linalg.eigvalsh(C)) > -1e-12
    # Check against quadrature of the functions' real and imaginary parts.
    s = np.linspace(0.0, 20.0, 20001)
    g = np.exp(-1j * np.outer(bank.ell, 2 * np.pi * s / 20.0)) * (
        np.exp(-1j * 2 * np.pi * s / 20.0) - 1.0
    )
    parts = np.stack([g.real, g.imag], axis=1).reshape(20, -1)
    weights = np.full(s.size, s[1] - s[0])
    weights[[0, -1]] /= 2.0  # trapezoid rule
    gram = (parts * weights) @ parts.T
    scale = np.sqrt(np.diag(gram))
    np.testing.assert_allclose(C, gram / np.outer(scale, scale), atol=1e-6)
    # The paper's ℓ = 0:0.05:10: 402 rows of one equation, about 27 independent.
    dense = fourier_bank(20.0, 0.02, order=1, ell=paper_frequencies())
    eigenvalues = np.linalg.eigvalsh(dense.row_correlation())
    assert np.count_nonzero(eigenvalues > 1e-6 * eigenvalues.max()) < 40


@pytest.mark.parametrize("weighted", [False, True])
def test_honest_std_matches_the_spread_where_gautier_is_5_times_too_small(weighted):
    # Rows of the paper's dense ℓ set for m = 2 equations; noise drawn with the
    # rows' correlation and a variance growing like ν² (seed 3). A fixed, and as
    # the modulated integrals of smooth signals are, in the span of the same
    # functions (A_j = F·Z with F the correlation's factor).
    bank = fourier_bank(20.0, 0.02, order=1, ell=paper_frequencies())
    noise = row_noise(bank, 2)
    rng = np.random.default_rng(3)
    r, p = noise.num_rows, 5
    A = np.empty((r, p))
    for j in (0, 1):
        rows = noise.group == j
        A[rows] = noise.factor @ rng.standard_normal((noise.factor.shape[1], p))
    theta = np.arange(1.0, p + 1.0)
    stdev = 0.1 * np.sqrt(1.0 + 0.05 * noise.frequency**2)
    F = noise.factor
    estimates, honest, gautier = [], [], []
    for _ in range(300):
        e = np.empty(r)
        for j in (0, 1):
            rows = noise.group == j
            e[rows] = F @ rng.standard_normal(F.shape[1])
        B = A @ theta + stdev * e
        weighting = (noise.frequency, noise.group) if weighted else None
        fit = lsq.solve_window(A, B, weighting, noise=noise)
        old = lsq.solve_window(A, B, weighting)
        assert fit.valid
        estimates.append(fit.theta)
        honest.append(fit.std)
        gautier.append(old.std)
    spread = np.std(estimates, axis=0)
    ratio = np.median(honest, axis=0) / spread
    assert np.all((ratio > 0.75) & (ratio < 1.33)), ratio
    assert np.all(np.median(gautier, axis=0) / spread < 0.4)


def test_honest_std_is_gautier_for_independent_equal_rows():
    rng = np.random.default_rng(8)
    A = rng.standard_normal((40, 3))
    B = A @ np.array([1.0, -2.0, 0.5]) + 0.1 * rng.standard_normal(40)
    fit = lsq.solve_least_squares(A, B)
    group = np.zeros(40, dtype=int)

    class Independent:
        num_rows = 40
        frequency = np.zeros(40)
        correlation = np.eye(40)
        factor = np.eye(40)

    Independent.group = group
    result = honest_std(A, B, fit.theta, np.ones(40), np.ones(40), Independent())
    np.testing.assert_allclose(result.std, fit.std, rtol=1e-10)
    assert result.dof == pytest.approx(37.0)


def test_too_few_independent_rows_make_the_window_invalid():
    # 8 functions of a short window, one equation, 12 parameters: no honest σ.
    bank = fourier_bank(2.0, 0.01, order=1, ell=np.arange(8.0))
    noise = row_noise(bank, 1)
    rng = np.random.default_rng(2)
    A = rng.standard_normal((noise.num_rows, 12))
    B = rng.standard_normal(noise.num_rows)
    result = lsq.solve_window(A, B, (noise.frequency, noise.group), noise=noise)
    assert not result.valid
    assert "honest σ" in result.reason and f"< {MIN_RESIDUAL_DOF:g}" in result.reason


def test_noise_model_std_fits_a_nu4_law_without_overflow():
    rng = np.random.default_rng(5)
    nu = np.tile(np.arange(1.0, 41.0), 50)
    truth = np.sqrt(1.0 + 1e-4 * nu**4)
    residual = truth * rng.standard_normal(nu.size) * 1e160
    model = noise_model_std(residual, nu, np.zeros(nu.size, dtype=int))
    assert np.all(np.isfinite(model))
    np.testing.assert_allclose(model / 1e160, truth, rtol=0.25)


@pytest.mark.parametrize("seed", range(4))
def test_nonnegative_fit_equals_scipy_nnls_per_group(seed):
    from scipy.optimize import nnls

    rng = np.random.default_rng(seed)
    frequency_sets = (np.arange(10.0), rng.uniform(0, 20, 12), np.full(8, 3.0))
    for nu in frequency_sets:
        nu = np.tile(np.repeat(nu, 2), 4)
        index = np.repeat(np.arange(4), nu.size // 4)
        model = np.stack([np.ones_like(nu), nu**2, nu**4], axis=1)
        model /= model.max(axis=0)
        truth = rng.uniform(-1, 1, (4, 3)) * (rng.uniform(size=(4, 3)) < 0.7)
        y = np.einsum("ik,ik->i", model, truth[index])
        y += 0.3 * rng.standard_normal(nu.size)
        ours = nonnegative_fit(model, y, index, 4)
        assert np.all(ours >= 0.0)
        for g in range(4):
            rows = index == g
            reference, _ = nnls(model[rows], y[rows])
            np.testing.assert_allclose(
                model[rows] @ ours[g], model[rows] @ reference, rtol=1e-7, atol=1e-9
            )


def test_least_squares_of_data_scaled_by_1e160():
    rng = np.random.default_rng(6)
    A = rng.standard_normal((50, 4))
    B = A @ np.array([1.0, 2.0, 3.0, 4.0]) + 0.01 * rng.standard_normal(50)
    reference = lsq.solve_least_squares(A, B)
    scaled = lsq.solve_least_squares(A * 1e160, B * 1e160)
    assert scaled.valid and scaled.rank == 4
    np.testing.assert_allclose(scaled.theta, reference.theta, rtol=1e-10)
    np.testing.assert_allclose(scaled.std, reference.std, rtol=1e-10)
    np.testing.assert_allclose(scaled.residual_std, reference.residual_std * 1e160)


@pytest.mark.parametrize("many", [False, True])
def test_a_finite_glitch_leaves_no_trace_once_it_has_left_the_window(many):
    # τ = 1e20 in one sample (seed 9 data): once it has left the window the
    # sliding integrals equal direct quadrature, as if it had never been there.
    bank = fourier_bank(1.0, 0.01, order=1, ell=np.arange(6.0))
    rng = np.random.default_rng(9)
    x = rng.standard_normal((400, 3)) + 2.0
    x[50, 1] = 1e20
    state = sliding_init(bank, 3, resync_every=0)  # no periodic resynchronisation
    if many:
        for start in range(0, 400, 7):
            state = sliding_push_many(bank, state, x[start : start + 7])
    else:
        for row in x:
            state = sliding_push(bank, state, row)
    direct = direct_fourier_integrals(bank, x[-bank.num_samples :])
    sliding = sliding_fourier_integrals(bank, state)
    assert np.max(np.abs(sliding - direct)) <= 1e-12 * np.max(np.abs(direct))
    assert RESYNC_RATIO >= 10.0


def test_bank_limits_refuse_before_allocating():
    with pytest.raises(ValueError, match=r"Nyquist frequency 1/\(2·time_step\) = 25"):
        fourier_bank(2.0, 0.02, order=1, ell=np.arange(60.0))
    with pytest.raises(ValueError, match=f"at most {MAX_FUNCTIONS} modulating"):
        fourier_bank(2000.0, 0.02, order=1, ell=np.arange(501.0))
    with pytest.raises(ValueError, match="order must be <= 8"):
        fourier_bank(20.0, 0.02, order=9, ell=[0.0])
    with pytest.raises(ValueError, match="at most 500 modulating functions"):
        default_frequencies(20.0, 1e308)
    with pytest.raises(ValueError, match="at most 500 modulating functions"):
        default_frequencies(20.0, 0.6, spacing=1e-300)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: sliding_init(1.0, 3), TypeError, "bank must be a FourierBank"),
        (
            lambda: sliding_push(fourier_bank(1.0, 0.1, ell=[0.0]), 2.0, [1.0]),
            TypeError,
            "state must be a SlidingState",
        ),
        (
            lambda: direct_fourier_integrals("x", np.zeros(3)),
            TypeError,
            "bank must be a FourierBank",
        ),
        (lambda: lsq.solve_window(np.eye(3), np.ones(3), noise=None), None, None),
    ],
)
def test_wrong_argument_types_are_type_errors(call, error, match):
    if error is None:
        call()
        return
    with pytest.raises(error, match=match):
        call()
