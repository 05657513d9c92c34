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


def _carried_with_share(share):
    """(A, B, groups): group 0 alone carries θ_1's direction, keeping ``share``.

    As :func:`_one_group_carries` with column 1 ε·z outside group 0 (z, column 0
    and the noise fixed), ε solved so that μ_0, the smallest eigenvalue of
    I - Q_0 Q_0ᵀ, is ``share``: σ_J as a function of μ_0 alone.
    """
    from scipy.optimize import brentq

    rng = np.random.default_rng(5)
    groups = np.repeat(np.arange(10), 8)
    column, z, noise = rng.normal(size=(3, 80))

    def build(eps):
        A = np.stack([column, eps * z], axis=1)
        A[groups == 0, 1] = 1.0
        return A

    def log_mu(log_eps):
        Q0 = np.linalg.qr(build(np.exp(log_eps)))[0][groups == 0]
        return np.log(np.linalg.eigvalsh(np.eye(8) - Q0 @ Q0.T)[0] / share)

    A = build(np.exp(brentq(log_mu, np.log(1e-6), np.log(10.0), xtol=1e-13)))
    return A, A @ [1.0, 2.0] + 0.1 * noise, groups


def test_sigma_is_continuous_in_the_share_a_carrying_group_leaves():
    """No step at MIN_INFORMATION: a sliding window's μ_0 drifts across it.

    Asserted (σ_J of both parameters as μ_0 varies, everything else fixed):
    * across the old step (μ_0 = 0.99 and 1.01 times 1e-5) σ changes < 2×
      (before: 340× on θ_1, 2.84 -> 0.0084);
    * on a sweep 1e-7..1e-3 in steps of 0.05 decade no step exceeds 10^(0.05·3.5)
      (|d log σ / d log μ| <= 3.5: the blend's steepest is 2.75, the
      deletion's 0.5);
    * θ_1's σ is unimodal: flat (bias-reduced) up to 1e-5/√10, rising through
      the blend, then falling as the deletion's 1/√μ: one change of direction;
    * above the blend it is the plain deletion's, below it flat (to 1 %).
    """
    from drake_dynid.core.jackknife import MIN_INFORMATION

    def sigma(share, **kw):
        return jackknife_std(*_carried_with_share(share), **kw)

    below, above = sigma(0.99 * MIN_INFORMATION), sigma(1.01 * MIN_INFORMATION)
    assert np.all(np.abs(np.log(above / below)) < np.log(2.0)), (below, above)

    shares = np.logspace(-7, -3, 81)
    sigmas = np.array([sigma(m) for m in shares])
    steps = np.diff(np.log10(sigmas), axis=0)
    assert np.abs(steps).max() <= 0.05 * 3.5, np.abs(steps).max(axis=0)
    moves = np.sign(steps[:, 1][np.abs(steps[:, 1]) > 1e-3])
    assert np.count_nonzero(np.diff(moves)) <= 1, moves
    high = shares >= np.sqrt(10.0) * MIN_INFORMATION
    plain = np.array([sigma(m, min_information=0.0) for m in shares[high]])
    np.testing.assert_allclose(sigmas[high], plain, rtol=1e-10)
    low = shares <= MIN_INFORMATION / np.sqrt(10.0)
    np.testing.assert_allclose(
        sigmas[low], np.broadcast_to(sigmas[0], sigmas[low].shape), rtol=0.01
    )
