"""core.jackknife: delete-one-group σ (downdates equal re-solves; honest spread)."""

import numpy as np
import pytest

from drake_dynid.core.jackknife import jackknife_std
from drake_dynid.core.lsq import solve_least_squares, solve_window


def _resolved(A, B, groups, weights):
    """The definition: one least-squares solve per deleted group."""
    A, B = A * weights[:, None], B * weights
    labels = np.unique(groups)
    thetas = np.array(
        [np.linalg.lstsq(A[groups != g], B[groups != g], rcond=None)[0] for g in labels]
    )
    spread = thetas - thetas.mean(axis=0)
    return np.sqrt((len(labels) - 1) / len(labels) * (spread**2).sum(axis=0))


@pytest.mark.parametrize(
    "groups",
    [
        np.repeat(np.arange(12), 5),  # one size: stacked downdates
        np.tile(np.arange(12), 5),  # one size, interleaved (the windows' order)
        np.repeat(np.arange(6), [5, 15, 10, 10, 8, 12]),  # one at a time
    ],
)
def test_downdates_equal_explicit_solves(groups):
    rng = np.random.default_rng(11)
    A = rng.normal(size=(60, 4)) * [1.0, 10.0, 0.1, 3.0]
    B = A @ [1.0, -2.0, 3.0, 0.5] + rng.normal(size=60)
    weights = rng.uniform(0.5, 2.0, 60)
    np.testing.assert_allclose(
        jackknife_std(A, B, groups, weights=weights),
        _resolved(A, B, groups, weights),
        rtol=1e-10,
    )


def test_the_jackknife_follows_heteroscedastic_noise_that_gautier_misses():
    """Noise std ∝ |x| (seeds 0..399): Gautier's σ of the slope is 40 % low."""
    rng = np.random.default_rng(0)
    x = np.linspace(-1.0, 1.0, 80)
    A = np.stack([np.ones_like(x), x], axis=1)
    groups = np.arange(80) // 4
    estimates, gautier, jackknife = [], [], []
    for _ in range(400):
        B = A @ [0.5, 2.0] + 0.1 * np.abs(x) * 3 * rng.normal(size=80)
        result = solve_least_squares(A, B)
        estimates.append(result.theta)
        gautier.append(result.std)
        jackknife.append(jackknife_std(A, B, groups))
    spread = np.std(estimates, axis=0)[1]
    assert np.mean(gautier, axis=0)[1] < 0.75 * spread
    assert np.mean(jackknife, axis=0)[1] == pytest.approx(spread, rel=0.15)


def test_undetermined_deletions_and_single_groups_give_nan():
    A = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    B = np.array([1.0, 2.0, 3.1, 4.0])
    assert np.isnan(jackknife_std(A, B, np.zeros(4))).all()
    # Deleting group 0 removes every row that sees the second parameter alone.
    A = np.array([[0.0, 1.0], [0.0, 1.0], [1.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    B = np.array([1.0, 1.1, 2.0, 2.1, 4.0])
    assert np.isnan(jackknife_std(A, B, [0, 0, 1, 1, 2])).all()


def test_solve_window_reports_the_larger_sigma_per_parameter():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(48, 3))
    B = A @ [1.0, 2.0, 3.0] + 0.1 * rng.normal(size=48) * (1 + 3 * (A[:, 0] > 1))
    groups = np.arange(48) // 6
    plain = solve_window(A, B)
    both = solve_window(A, B, jackknife=groups)
    np.testing.assert_array_equal(both.theta, plain.theta)
    np.testing.assert_allclose(
        both.std, np.maximum(plain.std, jackknife_std(A, B, groups)), rtol=1e-12
    )
    np.testing.assert_allclose(
        both.relative_std_percent, 100 * both.std / np.abs(both.theta)
    )
    # With the frequency-weighted solve the jackknife uses its weights.
    weighted = solve_window(A, B, (np.arange(48) % 6, np.zeros(48)), jackknife=groups)
    assert np.all(
        weighted.std >= solve_window(A, B, (np.arange(48) % 6, np.zeros(48))).std
    )


def test_online_groups_are_pairs_of_adjacent_modulating_functions():
    from drake_dynid.core.online import OnlineSettings

    settings = OnlineSettings(window=2.0, frequencies=np.arange(11.0))
    bank = settings.bank()
    functions = bank.row_functions(3)  # 2 parts x 3 equations per function
    np.testing.assert_array_equal(functions, np.repeat(np.arange(11), 6))
    np.testing.assert_array_equal(
        settings.jackknife_groups(3, bank), np.repeat(np.arange(11) // 2, 6)
    )
    # Fewer than MIN_JACKKNIFE_GROUPS pairs (a short window): the sandwich σ alone.
    short = OnlineSettings(window=2.0, frequencies=[0.0, 1.0, 2.0, 3.0, 4.0])
    assert short.jackknife_groups(3) is None
    for kind in ("gautier", "sandwich"):
        assert OnlineSettings(uncertainty=kind).jackknife_groups(3) is None
    assert OnlineSettings(uncertainty="gautier").row_noise(3) is None
    with pytest.raises(ValueError, match="uncertainty must be one of"):
        OnlineSettings(uncertainty="bootstrap")


def _one_group_carries(rng):
    """Rows whose second column group 0 alone sees (as ℓ = 0 the gravity columns).

    10 groups of 8 rows; column 1 is 1 in group 0 and 1e-4·N(0, 1) elsewhere:
    deleting group 0 keeps ~1e-7 of that direction's information (TIAGo: 8e-7).
    """
    groups = np.repeat(np.arange(10), 8)
    A = np.stack([rng.normal(size=80), 1e-4 * rng.normal(size=80)], axis=1)
    A[groups == 0, 1] = 1.0
    return A, groups


def _monte_carlo(A, groups, std, rng, runs=300):
    """Spread of θ̂ over noise draws and the draws' σ (Gautier, jackknives)."""
    estimates, gautier, jackknife, plain = [], [], [], []
    for _ in range(runs):
        B = A @ [1.0, 2.0] + std * rng.normal(size=A.shape[0])
        result = solve_least_squares(A, B)
        estimates.append(result.theta)
        gautier.append(result.std)
        jackknife.append(jackknife_std(A, B, groups))
        plain.append(jackknife_std(A, B, groups, min_information=0.0))
    rms = [np.sqrt(np.mean(np.square(x), axis=0)) for x in (gautier, jackknife, plain)]
    return np.std(estimates, axis=0), *rms


def test_a_group_that_alone_carries_a_direction_does_not_blow_sigma_up():
    # The plain deletion (min_information 0) leaves θ_1 almost undetermined: its
    # jackknife σ is ~1000 times the spread. The bias-reduced deviation of that
    # group has the variance of its share of θ̂ (here all of θ_1's): about the
    # spread (one group: a one-degree-of-freedom estimate, hence RMS over draws).
    rng = np.random.default_rng(5)
    A, groups = _one_group_carries(rng)
    spread, gautier, jackknife, plain = _monte_carlo(A, groups, 0.1, rng)
    ratio = jackknife / spread
    assert np.all((ratio > 0.7) & (ratio < 1.4)), ratio
    assert plain[1] > 30 * spread[1]  # the blow-up it replaces
    assert gautier[1] == pytest.approx(spread[1], rel=0.2)


def test_with_such_a_group_heteroscedastic_noise_still_inflates_sigma():
    # Noise std ∝ |x| in every row: Gautier's σ of θ_0 is low, the jackknife
    # follows the spread (its other groups keep their deletions).
    rng = np.random.default_rng(6)
    A, groups = _one_group_carries(rng)
    spread, gautier, jackknife, _ = _monte_carlo(A, groups, 0.3 * np.abs(A[:, 0]), rng)
    assert gautier[0] < 0.75 * spread[0]
    assert jackknife[0] == pytest.approx(spread[0], rel=0.2)


def test_without_min_information_it_is_the_plain_deletion_jackknife():
    rng = np.random.default_rng(7)
    A, groups = _one_group_carries(rng)
    B = A @ [1.0, 2.0] + 0.1 * rng.normal(size=80)
    np.testing.assert_allclose(
        jackknife_std(A, B, groups, min_information=0.0),
        _resolved(A, B, groups, np.ones(80)),
        rtol=1e-6,
    )
