"""The covariance weighting: the rows' linearised covariance and the solve it weights.

Independent references: a Monte-Carlo covariance of the rows over noise draws (for
``core.row_covariance.row_covariance``), and an exact log (the paper trajectory
evaluated, torques from Drake's ``CalcInverseDynamics`` + the URDF's Coulomb
friction) with SNR 30 dB noise for the accuracy of the power model.
"""

import dataclasses

import numpy as np
import pytest
from _drake_dynamics import exact_paper_2r

from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import (
    filtered_signals,
    window_covariance_at,
    window_equations,
    window_estimate,
)
from drake_dynid.core.row_covariance import (
    covariance_design,
    covariance_weighted_solve,
)
from drake_dynid.core.signal_ring import ring_init, ring_push, ring_window
from drake_dynid.plants import RobotModel, model_path

H = 1e-3


@pytest.fixture(scope="module")
def arm2():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def exact_2r(arm2):
    """The paper trajectory evaluated for 21 s: q, τ (Drake + Coulomb), θ."""
    _, q, tau = exact_paper_2r(arm2)
    return q, tau


def _snr_30_db(clean: np.ndarray, seed: int) -> np.ndarray:
    std = clean.std(axis=0) / np.sqrt(10.0**3)
    return clean + std * np.random.default_rng(seed).standard_normal(clean.shape)


@pytest.mark.parametrize(
    ("model", "sigma_q", "sigma_tau"),
    [
        ("power", (0.02, 0.01), (0.3, 0.05)),  # position noise dominates
        ("power", (0.0, 0.0), (1.0, 0.2)),  # torque noise alone
        ("lagrangian", (0.02, 0.01), (0.3, 0.05)),
    ],
)
def test_row_covariance_matches_monte_carlo(arm2, exact_2r, model, sigma_q, sigma_tau):
    # A 4 s window: the rows' residual at the true θ over 300 noise draws has the
    # covariance Σ computed from one draw's signals (to first order in the noise).
    rows = arm2.rows_provider()
    sigma_q, sigma_tau = np.array(sigma_q), np.array(sigma_tau)
    settings = OnlineSettings.for_model(
        model,
        window=4.0,
        weighting="covariance",
        position_noise=tuple(sigma_q),
        torque_noise=tuple(sigma_tau),
    ).for_robot(H, 2, 8)
    q0, tau0 = (x[:4500] for x in exact_2r)
    end = 4499
    truth = arm2.base_values
    rng = np.random.default_rng(3)
    residuals = []
    for _ in range(300):
        q = q0 + sigma_q * rng.standard_normal(q0.shape)
        tau = tau0 + sigma_tau * rng.standard_normal(tau0.shape)
        a, b = window_equations(rows, settings, q, tau, end, H)
        residuals.append(b - a @ truth)
    measured = np.cov(np.array(residuals).T)
    q = q0 + sigma_q * rng.standard_normal(q0.shape)
    tau = tau0 + sigma_tau * rng.standard_normal(tau0.shape)
    model_cov = window_covariance_at(rows, settings, q, tau, end, H)(truth)
    rows_count = settings.bank().num_rows(settings.num_equations(2))
    assert model_cov.shape == measured.shape == (rows_count, rows_count)
    # Whitened by the model, the draws' covariance is the identity.
    factor = np.linalg.cholesky(model_cov)
    white = np.linalg.solve(factor, np.linalg.solve(factor, measured).T)
    diagonal = np.diag(white)
    assert abs(diagonal.mean() - 1.0) < 0.1
    # 300 draws: 8 % std per entry. The Lagrangian rows' Coulomb sign(v̂) flips
    # near a velocity reversal, a noise that is not Gaussian: its first-order
    # model is looser there (the power rows have |v̂|, continuous).
    assert np.all(np.abs(diagonal - 1.0) < (0.4 if model == "power" else 1.0))
    off = white[~np.eye(len(white), dtype=bool)]
    assert np.sqrt(np.mean(off**2)) < 0.1  # 1/√300 = 0.058 for independent draws
    # The rows of different ℓ are strongly correlated (why a weight per row is
    # not enough): the model says so and the draws agree.
    std = np.sqrt(np.diag(model_cov))
    correlation = model_cov / np.outer(std, std)
    strong = np.abs(correlation[~np.eye(len(std), dtype=bool)]).max()
    assert strong > 0.5


def test_banded_covariance_equals_the_sum_over_raw_samples(arm2, exact_2r):
    # Σ from the bank-rate lag kernels equals σ² R Rᵀ with R the rows' sensitivity
    # to every raw sample's noise (the filters' taps applied explicitly).
    from drake_dynid.core.row_covariance import row_covariance, sample_sensitivities

    rows = arm2.rows_provider()
    sigma_q, sigma_tau = np.array([0.02, 0.01]), np.array([0.3, 0.05])
    settings = OnlineSettings.for_model(
        "power",
        window=1.0,
        weighting="covariance",
        position_noise=tuple(sigma_q),
        torque_noise=tuple(sigma_tau),
        frequencies=np.arange(6.0),
    ).for_robot(H, 2, 8)
    design = settings.covariance_design(H, 2)
    q, tau = (x[:1500] for x in exact_2r)
    end, step = 1499, settings.decimation(H)
    index = end - step * np.arange(design.num_samples - 1, -1, -1)
    signals = [x[index] for x in filtered_signals(q, tau, settings, H)[:3]]
    theta = arm2.base_values
    banded = row_covariance(design, rows, *signals, theta)
    e_sens, y_sens = sample_sensitivities(
        rows, "power", *signals, theta, design.signal_std
    )
    smooth, velocity = settings.jacobi_filters(H)
    brute = np.zeros_like(banded)
    for joint in range(2):
        for parts, sigma in (
            (((joint, smooth.taps), (2 + joint, velocity.taps)), sigma_q[joint]),
            (((4 + joint, smooth.taps),), sigma_tau[joint]),
        ):
            raw = np.zeros((banded.shape[0], end + 1))
            for column, taps in parts:
                jac = (
                    design.g_map * y_sens[:, 0, column]
                    + design.dg_map * (e_sens[:, 0, column])
                )
                for k, sample in enumerate(index):
                    raw[:, sample - np.arange(taps.size)] += jac[:, k, None] * taps
            brute += sigma**2 * raw @ raw.T
    np.testing.assert_allclose(banded, brute, rtol=1e-9, atol=1e-12 * abs(brute).max())


def test_power_model_friction_halves_at_snr_30_db(arm2, exact_2r):
    # The paper's set-up on an exact log (T = 20 s, SNR 30 dB on q and τ, the noise
    # stds measured as dynid identify does): the covariance weighting's friction
    # and inertial errors against the frequency weighting's, 6 noise draws.
    from drake_dynid.core.excitation import estimate_bandwidth, position_noise_std

    rows = arm2.rows_provider()
    truth = arm2.base_values
    q0, tau0 = exact_2r
    band = estimate_bandwidth(q0, H)
    errors = {"frequency": [], "covariance": []}
    for seed in range(6):
        q, tau = _snr_30_db(q0, seed), _snr_30_db(tau0, 100 + seed)
        noise = tuple(position_noise_std(q, H))
        for weighting, extra in (
            ("frequency", {}),
            ("covariance", {"torque_noise": tuple(position_noise_std(tau, H))}),
        ):
            settings = OnlineSettings.for_model(
                "power",
                window=20.0,
                bandwidth=band,
                weighting=weighting,
                position_noise=noise,
                **extra,
            )
            result = window_estimate(rows, settings, q, tau, len(q) - 1, H)
            assert result.valid
            errors[weighting].append(100 * np.abs(result.theta - truth) / truth)
    median = {key: np.median(value, axis=0) for key, value in errors.items()}
    friction = {key: value[4:].mean() for key, value in median.items()}
    inertial = {key: value[:4].mean() for key, value in median.items()}
    assert friction["covariance"] < 0.6 * friction["frequency"]
    assert friction["covariance"] < 12.0
    assert inertial["covariance"] < inertial["frequency"]


def test_covariance_settings_are_checked():
    with pytest.raises(ValueError, match=r"position_noise and torque_noise not given"):
        OnlineSettings(model="power", weighting="covariance")
    with pytest.raises(ValueError, match=r"torque_noise not given"):
        OnlineSettings(model="power", weighting="covariance", position_noise=0.01)
    with pytest.raises(ValueError, match=r"are all 0"):
        OnlineSettings(
            weighting="covariance", position_noise=0.0, torque_noise=(0.0, 0.0)
        )
    # Found by a review: position noise 0 and a joint's torque noise 0 left that
    # joint's rows without noise, a singular covariance the whitened solve trusted
    # without limit (FC1 1.31 ± 2.8e4 for 1.50 on a 4R log, 'valid').
    with pytest.raises(ValueError, match=r"the rows of joint\(s\) 2, 3 \(torque_noise"):
        OnlineSettings(
            weighting="covariance", position_noise=0.0, torque_noise=(0.1, 0.0, 0.0)
        )
    # Found by a review: a Lagrangian joint without a noise of its own (σ_q = σ_τ
    # = 0) gets only the other joints' through the coupling terms; the covariance
    # was nearly singular and every window ill-conditioned, blamed on excitation
    # (a 4-joint UR5 log, σ_q = 0, 0, 0, 1e-4: condition 3.3e4, 191 unweighted).
    with pytest.raises(
        ValueError, match=r"joint\(s\) 1, 2, 3 have position_noise 0 and torque_noise"
    ):
        OnlineSettings(
            weighting="covariance", position_noise=(0, 0, 0, 1e-4), torque_noise=0
        )
    with pytest.raises(ValueError, match=r"joint\(s\) 2 have position_noise 0"):
        OnlineSettings(
            weighting="covariance", position_noise=(1e-4, 0), torque_noise=(0, 0)
        )
    OnlineSettings(  # the power model's one equation sums every joint's noise
        model="power",
        weighting="covariance",
        position_noise=(0, 1e-4),
        torque_noise=0,
    )
    for position, torque in ((0.0, 0.1), ((0.0, 1e-4), (0.1, 0.0))):
        OnlineSettings(  # a noise in every joint's rows
            weighting="covariance", position_noise=position, torque_noise=torque
        )
    with pytest.raises(ValueError, match=r"models the noise of the filtered rows"):
        OnlineSettings(
            weighting="covariance",
            position_noise=0.01,
            torque_noise=0.1,
            rows_from="raw",
        )
    with pytest.raises(ValueError, match=r"torque_noise is used by weighting"):
        OnlineSettings(model="power", torque_noise=0.1)
    with pytest.raises(ValueError, match=r"torque_noise must be None, a std >= 0"):
        OnlineSettings(weighting="covariance", position_noise=0.1, torque_noise=-1)
    settings = OnlineSettings(
        weighting="covariance", position_noise=0.01, torque_noise=[0.1, 0.2, 0.3]
    )
    assert settings.torque_noise == (0.1, 0.2, 0.3)
    with pytest.raises(ValueError, match=r"torque_noise must hold one std per joint"):
        settings.for_robot(H, 2, 8)
    # The Lagrangian model takes position_noise for the covariance only.
    assert (
        OnlineSettings(
            weighting="covariance", position_noise=0.01, torque_noise=0.1
        ).row_provider("rows", H)
        == "rows"
    )


def test_covariance_set_covers_the_pass_band():
    # Every integer ℓ up to the differentiator's pass band (0.2 s: 5.8 Hz), where
    # the frequency weighting keeps its band's set.
    base = OnlineSettings.for_model("power", window=20.0, bandwidth=0.6)
    weighted = dataclasses.replace(
        base, weighting="covariance", position_noise=0.05, torque_noise=0.5
    )
    assert len(base.for_robot(H, 2, 8).ell()) == 24
    ell = weighted.for_robot(H, 2, 8).ell()
    assert len(ell) == 116 and (ell[-1] + 1) / 20.0 <= 5.81


def test_design_rejects_bad_values(arm2):
    settings = OnlineSettings.for_model(
        "power",
        window=2.0,
        weighting="covariance",
        position_noise=0.01,
        torque_noise=0.1,
    ).for_robot(H, 2, 8)
    smooth, velocity = settings.jacobi_filters(H)
    args = (settings.bank(), 1, smooth.taps, velocity.taps, 20)
    with pytest.raises(ValueError, match=r"must not both be 0"):
        covariance_design(*args, 0.0, 0.0, model="power", num_joints=2)
    with pytest.raises(ValueError, match=r"position_std must be finite and >= 0"):
        covariance_design(*args, -1.0, 0.1, model="power", num_joints=2)
    design = settings.covariance_design(H, 2)
    assert design.num_rows == settings.bank().num_rows(1)
    q, tau = np.zeros((3000, 2)), np.zeros((3000, 2))
    signals = filtered_signals(q, tau, settings, H)
    with pytest.raises(ValueError, match=r"must hold the window's 101 bank samples"):
        from drake_dynid.core.row_covariance import row_covariance

        row_covariance(design, arm2.rows_provider(), *signals[:3], arm2.base_values)
    with pytest.raises(ValueError, match=r"covariance must return a finite"):
        covariance_weighted_solve(np.eye(4)[:, :2], np.ones(4), lambda theta: np.eye(3))


def test_signal_ring_keeps_the_last_samples_in_order():
    ring = ring_init(3, 1)
    assert ring_window(ring) is None
    for k in range(5):
        ring = ring_push(ring, [k], [10 + k], [20 + k])
    q, v, tau = ring_window(ring)
    np.testing.assert_array_equal(q[:, 0], [2, 3, 4])
    np.testing.assert_array_equal(v[:, 0], [12, 13, 14])
    np.testing.assert_array_equal(tau[:, 0], [22, 23, 24])
    with pytest.raises(ValueError, match=r"must have 1 entries each; got 4"):
        ring_push(ring, [1, 2], [1], [1])


def test_payload_identifier_refuses_the_covariance_weighting():
    from drake_dynid.core.payload_step import payload_settings

    with pytest.raises(ValueError, match=r"payload_settings: settings.weighting must"):
        payload_settings(
            weighting="covariance",
            position_noise=0.01,
            torque_noise=0.1,
            rows_from="filtered",
        )


@pytest.mark.parametrize("count", [3, 7, 40])
def test_lagged_matches_its_definition(count):
    # Z[:, k] = Σ_Δ kernel(Δ) values[:, k - Δ], zero outside the window, also
    # when the kernel (2M + 1 = 9 lags) is longer than the window.
    from drake_dynid.core.row_covariance import _lagged

    rng = np.random.default_rng(count)
    values, kernel = rng.standard_normal((5, count)), rng.standard_normal(9)
    expected = np.zeros_like(values)
    for k in range(count):
        for index, weight in enumerate(kernel):
            source = k - (index - 4)
            if 0 <= source < count:
                expected[:, k] += weight * values[:, source]
    np.testing.assert_allclose(_lagged(values, kernel), expected, atol=1e-12)


def test_covariance_weighting_solves_every_second_by_default():
    # Each covariance-weighted solve builds Σ (tens of ms): 1 s unless given.
    from drake_dynid.core.online import (
        NOMINAL_COVARIANCE_UPDATE_PERIOD,
        NOMINAL_UPDATE_PERIOD,
    )

    noise = dict(weighting="covariance", position_noise=0.01, torque_noise=0.1)
    grid = OnlineSettings(**noise).on_grid(1e-3)
    assert grid.update_period == NOMINAL_COVARIANCE_UPDATE_PERIOD == 1.0
    assert OnlineSettings().on_grid(1e-3).update_period == NOMINAL_UPDATE_PERIOD
    given = OnlineSettings(**noise, update_period=0.2).on_grid(1e-3)
    assert given.update_period == 0.2


def test_covariance_solve_jackknife_sees_a_misfit_between_groups():
    # Σ models white noise of std 0.01, but each group of rows carries its own
    # error in the first column (a misfit no noise model holds): over 40 draws the
    # GLS σ alone is overconfident on θ_0 (err/σ p90 > 3), the larger of it and the
    # jackknife over the groups of the whitened rows is not; θ̂ is unchanged.
    from drake_dynid.core.row_covariance import covariance_weighted_solve
    from drake_dynid.core.weighted_lsq import solve_window

    rows, groups = 120, np.arange(120) // 10
    theta = np.array([1.0, -2.0, 0.5])

    def cov(_theta):
        return 1e-4 * np.eye(rows)

    ratios = []
    for seed in range(40):
        rng = np.random.default_rng(seed)
        A = rng.standard_normal((rows, 3))
        B = A @ theta + 0.01 * rng.standard_normal(rows)
        B += (0.3 * rng.standard_normal(12))[groups] * A[:, 0]
        plain = covariance_weighted_solve(A, B, cov)
        jack = covariance_weighted_solve(A, B, cov, jackknife=groups)
        np.testing.assert_array_equal(jack.theta, plain.theta)
        assert np.all(jack.std >= plain.std)
        error = np.abs(plain.theta - theta)
        ratios.append((error[0] / plain.std[0], error[0] / jack.std[0]))
    p90 = np.percentile(ratios, 90, axis=0)
    assert p90[0] > 3.0 and p90[1] < 2.5, p90
    window = solve_window(A, B, covariance=cov, jackknife=groups)
    np.testing.assert_array_equal(window.std, jack.std)
    np.testing.assert_allclose(
        jack.relative_std_percent, 100 * jack.std / np.abs(jack.theta)
    )
