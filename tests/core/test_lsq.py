"""QR least squares: values, Gautier σ, conditioning and failure reporting."""

import numpy as np
import pytest

from drake_dynid.core import lsq
from drake_dynid.core.lsq import (
    DEFAULT_MAX_CONDITION,
    solve_least_squares,
    solve_weighted_least_squares,
)
from drake_dynid.core.weighted_lsq import (
    frequency_noise_weights,
    solve_frequency_weighted_least_squares,
    solve_window,
)


def test_former_import_path_of_the_weighted_solves_still_works():
    assert lsq.solve_window is solve_window
    assert lsq.frequency_noise_weights is frequency_noise_weights


NAMES = ("ZZ1R", "ZZ2", "FV1", "FC1")


def _system(seed, rows=80, p=4, noise=0.1):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((rows, p)) * np.array([1.0, 1e3, 1e-3, 5.0])[:p]
    theta = np.array([3.9, 0.25, 0.3, 0.4])[:p]
    return A, theta, A @ theta + noise * rng.standard_normal(rows)


def test_matches_lstsq_and_the_textbook_covariance():
    A, _, B = _system(seed=1)  # seed 1
    result = solve_least_squares(A, B, names=NAMES)
    assert result.valid and result.reason == ""
    assert result.rank == 4 and result.num_rows == 80
    expected, residual, *_ = np.linalg.lstsq(A, B, rcond=None)
    np.testing.assert_allclose(result.theta, expected, rtol=1e-10)
    sigma2 = residual[0] / (80 - 4)
    np.testing.assert_allclose(result.residual_std, np.sqrt(sigma2), rtol=1e-10)
    covariance = sigma2 * np.linalg.inv(A.T @ A)
    np.testing.assert_allclose(result.std, np.sqrt(np.diag(covariance)), rtol=1e-8)
    np.testing.assert_allclose(
        result.relative_std_percent, 100 * result.std / np.abs(result.theta)
    )
    # Condition number of the unit-norm-column matrix, independent of units.
    scaled = A / np.linalg.norm(A, axis=0)
    assert result.condition_number == pytest.approx(np.linalg.cond(scaled), rel=1e-9)
    assert result.condition_number < 10 < np.linalg.cond(A)
    with pytest.raises(ValueError):
        result.theta[0] = 0.0


def test_sigma_agrees_with_monte_carlo():
    # Known Gaussian model: the spread of θ̂ over 2000 noise draws (seed 7) must
    # match the σ reported from a single draw, and σ_ρ must estimate the noise.
    rng = np.random.default_rng(7)  # seed 7
    A = rng.standard_normal((40, 3)) * [1.0, 10.0, 0.1]
    theta = np.array([1.0, -2.0, 0.5])
    noise = 0.2
    estimates, stds, residual_stds = [], [], []
    for _ in range(2000):
        result = solve_least_squares(A, A @ theta + noise * rng.standard_normal(40))
        estimates.append(result.theta)
        stds.append(result.std)
        residual_stds.append(result.residual_std)
    empirical = np.std(estimates, axis=0, ddof=1)
    exact = noise * np.sqrt(np.diag(np.linalg.inv(A.T @ A)))
    np.testing.assert_allclose(empirical, exact, rtol=0.05)
    np.testing.assert_allclose(np.mean(stds, axis=0), exact, rtol=0.03)
    np.testing.assert_allclose(np.mean(np.square(residual_stds)), noise**2, rtol=0.03)
    bias = np.abs(np.mean(estimates, axis=0) - theta)
    assert np.all(bias < 4 * exact / np.sqrt(2000))


def test_zero_column_is_reported_by_name():
    A, _, B = _system(seed=2)
    A[:, 2] = 0.0
    result = solve_least_squares(A, B, names=NAMES)
    assert not result.valid
    assert "rank deficient" in result.reason and "FV1 (column 2)" in result.reason
    assert result.unidentified == ("FV1",) and result.unidentified_indices == (2,)
    assert np.isnan(result.theta).all() and np.isnan(result.std).all()
    assert result.condition_number == np.inf


def test_dependent_columns_are_reported_by_name():
    A, _, B = _system(seed=3)
    A[:, 3] = 2.0 * A[:, 0]  # FC1 is not separable from ZZ1R
    result = solve_least_squares(A, B, names=NAMES)
    assert not result.valid and result.rank == 3
    assert result.reason.startswith("rank deficient: rank 3 < 4 parameters")
    assert result.unidentified == ("ZZ1R", "FC1")
    assert np.isnan(result.theta).all()


def test_ill_conditioned_window_names_the_condition_number_and_parameters():
    A, _, B = _system(seed=4)
    rng = np.random.default_rng(44)  # seed 44
    A[:, 1] = 1e3 * (A[:, 2] * 1e3 + 1e-8 * rng.standard_normal(80))
    result = solve_least_squares(A, B, names=NAMES, max_condition=1e4)
    assert not result.valid and result.rank == 4
    assert result.condition_number > 1e4
    assert "ill-conditioned: condition number" in result.reason
    assert "> max_condition 1e+04" in result.reason
    assert result.unidentified == ("ZZ2", "FV1")
    assert "ZZ2 (column 1), FV1 (column 2)" in result.reason
    # The same system passes with a looser threshold.
    loose = solve_least_squares(A, B, max_condition=10 * result.condition_number)
    assert loose.valid


def test_robot_at_rest_gives_invalid_not_noise():
    rows = np.zeros((50, 4))
    result = solve_least_squares(rows, np.zeros(50), names=NAMES)
    assert not result.valid and result.unidentified == NAMES


def test_too_few_rows_and_non_finite_input():
    A, _, B = _system(seed=5, rows=4)
    result = solve_least_squares(A, B)
    assert not result.valid
    assert result.reason == "too few rows: 4 rows for 4 parameters (need more than 4)."
    A, _, B = _system(seed=5)
    A[3, 1] = np.nan
    B[7] = np.inf
    result = solve_least_squares(A, B, names=NAMES)
    assert not result.valid
    assert result.reason == (
        "non-finite input: 1 NaN or infinite value(s) in A "
        "(columns: ZZ2 (column 1)), 1 in B."
    )


def test_poorly_identified_uses_the_relative_std():
    A, _, B = _system(seed=6, noise=0.1)
    A[:, 2] *= 1e-3  # FV1 barely excited: large relative σ
    result = solve_least_squares(A, B, names=NAMES)
    assert result.valid
    assert result.relative_std_percent[2] > 30
    assert result.poorly_identified() == ("FV1",)
    assert result.poorly_identified(threshold_percent=1e9) == ()


def test_weighted_least_squares_equals_scaled_rows_and_helps_heteroscedastic_noise():
    rng = np.random.default_rng(8)  # seed 8
    A = rng.standard_normal((200, 2))
    theta = np.array([1.0, 2.0])
    sigma = np.where(np.arange(200) < 100, 0.01, 1.0)
    weights = 1.0 / sigma
    B = A @ theta + sigma * rng.standard_normal(200)
    weighted = solve_weighted_least_squares(A, B, weights, names=("a", "b"))
    plain = solve_least_squares(A * weights[:, None], B * weights, names=("a", "b"))
    np.testing.assert_allclose(weighted.theta, plain.theta, rtol=1e-12)
    np.testing.assert_allclose(weighted.std, plain.std, rtol=1e-12)
    assert weighted.residual_std == pytest.approx(1.0, abs=0.15)
    ordinary = solve_least_squares(A, B)
    assert np.all(weighted.std < ordinary.std / 3)
    assert np.all(np.abs(weighted.theta - theta) < 4 * weighted.std)


def test_argument_errors():
    A, _, B = _system(seed=9)
    with pytest.raises(ValueError, match=r"A must have shape \(rows, p\) with p >= 1"):
        solve_least_squares(B, B)
    with pytest.raises(ValueError, match=r"B must have shape \(80\)"):
        solve_least_squares(A, B[:-1])
    with pytest.raises(ValueError, match="names must have 4 entries; got 2"):
        solve_least_squares(A, B, names=("a", "b"))
    with pytest.raises(ValueError, match=r"max_condition must be > 1\.0"):
        solve_least_squares(A, B, max_condition=0.5)
    with pytest.raises(TypeError, match="max_condition must be a real number"):
        solve_least_squares(A, B, max_condition="big")
    with pytest.raises(TypeError, match="A must be an array of real numbers"):
        solve_least_squares([["a"]], [1.0])
    with pytest.raises(ValueError, match="weights must be > 0"):
        solve_weighted_least_squares(A, B, np.zeros(80))
    with pytest.raises(ValueError, match=r"weights must have shape \(80\)"):
        solve_weighted_least_squares(A, B, np.ones(3))
    # One default for the whole library: the least squares, the on-line settings,
    # the identifier step and the off-line IDIM.
    from drake_dynid.core.online import OnlineSettings

    assert DEFAULT_MAX_CONDITION == 1e4
    assert OnlineSettings().max_condition == DEFAULT_MAX_CONDITION


def _heteroscedastic_problem(seed, rows_per_group=400):
    """Two groups of rows whose noise std is sqrt(a + b ν²), known a, b."""
    rng = np.random.default_rng(seed)
    nu = np.tile(np.linspace(0.5, 20.0, rows_per_group), 2)
    group = np.repeat([0, 1], rows_per_group)
    a = np.where(group == 0, 0.01, 0.04)
    b = np.where(group == 0, 0.01, 0.0025)
    sigma = np.sqrt(a + b * nu**2)
    A = rng.standard_normal((2 * rows_per_group, 3))
    X = np.array([1.0, -2.0, 0.5])
    return A, A @ X + sigma * rng.standard_normal(len(nu)), nu, group, sigma, X


def test_frequency_noise_weights_recover_the_noise_model():
    A, B, nu, group, sigma, X = _heteroscedastic_problem(seed=31)  # seed 31
    w = frequency_noise_weights(B - A @ X, nu, group)
    # The fitted σ follows the true one within the scatter of 400 squared residuals.
    ratio = (1.0 / w) / sigma
    assert 0.4 < ratio.min() and ratio.max() < 1.6
    assert np.median(np.abs(ratio - 1.0)) < 0.25
    # Group 0's noise grows 18x from ν = 0.5 to ν = 20; the weights follow.
    first, last = 0, np.flatnonzero(group == 0)[-1]
    assert w[first] / w[last] > 8.0
    # A zero-residual group keeps unit weights; the floor bounds the weights.
    flat = frequency_noise_weights(np.zeros(4), np.arange(4.0), np.zeros(4, int))
    np.testing.assert_array_equal(flat, np.ones(4))
    steep = frequency_noise_weights(nu * 0.1, nu, group, floor=0.5)
    assert steep.max() / steep.min() <= np.sqrt(2.0) + 1e-12


def test_frequency_weighted_least_squares_beats_ols_on_heteroscedastic_rows():
    errors: dict[str, list[float]] = {"ols": [], "weighted": [], "residual": []}
    for seed in range(20):  # seeds 0-19
        A, B, nu, group, _, X = _heteroscedastic_problem(seed)
        ols = solve_least_squares(A, B)
        fit = solve_frequency_weighted_least_squares(A, B, nu, group)
        assert fit.valid
        errors["residual"].append(fit.residual_std)
        errors["ols"].append(np.linalg.norm(ols.theta - X))
        errors["weighted"].append(np.linalg.norm(fit.theta - X))
    assert np.median(errors["weighted"]) < 0.8 * np.median(errors["ols"])
    # The weighted residual is about unit (σ from the fitted noise model).
    assert 0.8 < np.median(errors["residual"]) < 1.25
    # solve_window dispatches to both.
    A, B, nu, group, _, _ = _heteroscedastic_problem(0)
    np.testing.assert_array_equal(
        solve_window(A, B).theta, solve_least_squares(A, B).theta
    )
    np.testing.assert_array_equal(
        solve_window(A, B, (nu, group)).theta,
        solve_frequency_weighted_least_squares(A, B, nu, group).theta,
    )


def test_frequency_weighted_least_squares_passes_invalid_windows_through():
    A = np.ones((10, 2))  # rank 1
    result = solve_frequency_weighted_least_squares(
        A, np.ones(10), np.arange(10.0), np.zeros(10, int), names=("a", "b")
    )
    assert not result.valid and np.all(np.isnan(result.theta))
    with pytest.raises(ValueError, match="must have one shape"):
        frequency_noise_weights(np.ones(4), np.ones(4), np.zeros(3))
    with pytest.raises(ValueError, match="floor must be in"):
        frequency_noise_weights(np.ones(4), np.ones(4), np.zeros(4), floor=2.0)


def _reference_weights(residual, nu, group, floor=1e-3):
    """The former implementation: scipy's nnls per group (the oracle)."""
    from scipy.optimize import nnls

    weights = np.ones_like(residual)
    for g in np.unique(group):
        rows = group == g
        model = np.stack([np.ones(rows.sum()), nu[rows] ** 2], axis=1)
        coefficients, _ = nnls(model, residual[rows] ** 2)
        variance = model @ coefficients
        top = float(variance.max())
        if top > 0.0:
            weights[rows] = 1.0 / np.sqrt(np.maximum(variance, floor * top))
    return weights


def test_closed_form_noise_fit_equals_scipys_nnls():
    # Seeds 0-39: residuals growing, falling (b < 0 unconstrained: a face), flat,
    # one group with a single frequency, and an all-zero group.
    for seed in range(40):
        rng = np.random.default_rng(seed)
        nu = np.tile(np.arange(0.0, 12.0, 0.5), 3)
        group = np.repeat([0, 1, 2], 24)
        slope = rng.choice([-0.05, 0.0, 0.05])
        residual = rng.normal(size=72) * np.sqrt(np.abs(1.0 + slope * nu**2))
        nu[group == 2] = 3.0
        if seed % 5 == 0:
            residual[group == 1] = 0.0
        new = frequency_noise_weights(residual, nu, group)
        old = _reference_weights(residual, nu, group)
        np.testing.assert_allclose(new, old, rtol=1e-12, atol=0)


def test_lean_weighted_solve_equals_the_two_full_solves():
    # The former composition: full first solve, nnls weights, full weighted solve.
    # Conditions from 1 to past max_condition (bound path, SVD path, invalid).
    conditions = []
    for seed, spread in enumerate((0.0, 1.5, 2.5, 3.3, 5.0)):  # seeds 100-104
        rng = np.random.default_rng(100 + seed)
        A = rng.normal(size=(120, 9)) @ np.diag(np.logspace(0, 2, 9))
        A[:, 1] = A[:, 0] * 3.0 + 10.0**-spread * A[:, 1]  # near-dependent
        nu = np.tile(np.arange(20.0), 6)
        group = np.repeat(np.arange(3), 40)
        B = A @ rng.normal(size=9) + rng.normal(size=120) * (0.01 + 0.002 * nu)
        first = solve_least_squares(A, B)
        if first.valid:
            weights = _reference_weights(B - A @ first.theta, nu, group)
            old = solve_weighted_least_squares(A, B, weights)
        else:
            old = first
        new = solve_frequency_weighted_least_squares(A, B, nu, group)
        conditions.append(first.condition_number)
        assert new.valid == old.valid and new.reason == old.reason
        # The weights differ by round-off (~1e-15), which the solve amplifies by
        # the condition number: equal to 1e-12 of each vector's scale, or 1e-14
        # times the condition number above 100 (numpy 2.4.6's LAPACK measured
        # 7e-15 times it on one seed, where an earlier build stayed under 2e-15).
        relative = max(1e-12, 1e-14 * first.condition_number)
        for name in ("theta", "std", "condition_number", "residual_std"):
            expected = np.asarray(getattr(old, name))
            scale = np.nanmax(np.abs(expected)) if np.any(np.isfinite(expected)) else 0
            np.testing.assert_allclose(
                getattr(new, name), expected, rtol=0, atol=relative * scale
            )
    # Well conditioned (R's Frobenius bound suffices), moderate (the SVD decides),
    # ill-conditioned (the first pass's invalid result).
    assert conditions[0] < 20 and 1e3 < conditions[3] < 1e4 < conditions[4]


def test_a_round_off_column_is_not_excited():
    """Found by a review: a frozen encoder's filtered velocity (1e-13 of the other
    columns) passed the exact-zero test; scaled to unit norm it gave FV1 = -4.7e16
    with %σ 29, not flagged. A column at most 1e-10 of the largest is zero."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(60, 3))
    B = A @ np.array([1.0, 2.0, 3.0]) + 0.01 * rng.normal(size=60)
    A[:, 1] = 1e-13 * rng.normal(size=60)
    result = solve_least_squares(A, B, names=("a", "b", "c"))
    assert not result.valid and result.unidentified == ("b",)
    assert "round-off" in result.reason
    A[:, 1] *= 1e6  # 1e-7 of the others: data (the floor is 1e-10)
    assert solve_least_squares(A, B).valid
