"""Payload core (no pydrake): the frame transform, the known column, the step, σ."""

import numpy as np
import pytest

from drake_dynid.core.identifier import Status, identifier_init, identifier_update
from drake_dynid.core.payload import (
    eliminate_known,
    payload_parameters,
    payload_transform,
    shift_parameters,
)
from drake_dynid.core.payload_report import payload_summary
from drake_dynid.core.payload_step import (
    PAYLOAD_DEFAULTS,
    payload_init,
    payload_settings,
    payload_update,
    solve_correlation,
)


def _rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _point_masses(rng, count=4):
    masses = rng.uniform(0.2, 2.0, count)
    points = rng.normal(scale=0.3, size=(count, 3))
    return masses, points


def _standard_of_points(masses, points):
    """θ about the origin of the points' frame, summed over point masses."""
    theta = np.zeros(10)
    for m, r in zip(masses, points, strict=True):
        tensor = m * (r @ r * np.eye(3) - np.outer(r, r))
        theta[:6] += [
            tensor[0, 0],
            tensor[0, 1],
            tensor[0, 2],
            tensor[1, 1],
            tensor[1, 2],
            tensor[2, 2],
        ]
        theta[6:9] += m * r
        theta[9] += m
    return theta


def test_shift_of_point_masses_is_the_sum_in_the_new_frame():
    # Independent reference: point masses written directly in L (s = p + R r).
    rng = np.random.default_rng(0)
    masses, points = _point_masses(rng)
    rotation, translation = _rotation(rng), rng.normal(size=3)
    in_f = _standard_of_points(masses, points)
    in_l = _standard_of_points(masses, translation + points @ rotation.T)
    np.testing.assert_allclose(
        shift_parameters(in_f, rotation, translation), in_l, atol=1e-12
    )
    np.testing.assert_allclose(
        payload_transform(rotation, translation) @ in_f, in_l, atol=1e-12
    )


def test_shifts_compose_and_batch():
    rng = np.random.default_rng(1)
    theta = rng.normal(size=(5, 10))
    r1, p1, r2, p2 = (
        _rotation(rng),
        rng.normal(size=3),
        _rotation(rng),
        rng.normal(size=3),
    )
    twice = shift_parameters(shift_parameters(theta, r1, p1), r2, p2)
    once = shift_parameters(theta, r2 @ r1, p2 + r2 @ p1)
    np.testing.assert_allclose(twice, once, atol=1e-12)
    assert payload_transform(r1, p1).flags.writeable is False


def test_payload_parameters_of_a_box_about_an_offset_frame():
    # A body at c with central inertia I_c: I_F = I_c + m(|c|² 1 - c cᵀ).
    theta = payload_parameters(2.0, [0.1, 0.0, 0.0], np.diag([1.0, 2.0, 3.0]))
    np.testing.assert_allclose(
        theta, [1.0, 0.0, 0.0, 2.02, 0.0, 3.02, 0.2, 0.0, 0.0, 2.0], atol=1e-15
    )
    with pytest.raises(ValueError, match="mass must be > 0 \\[kg\\]"):
        payload_parameters(0.0, [0, 0, 0], np.eye(3))
    with pytest.raises(ValueError, match="inertia must be symmetric"):
        payload_parameters(1.0, [0, 0, 0], [[1, 1, 0], [0, 1, 0], [0, 0, 1]])


def test_bad_poses_name_the_problem():
    with pytest.raises(ValueError, match="rotation must be a rotation matrix"):
        payload_transform(2.0 * np.eye(3), np.zeros(3))
    with pytest.raises(ValueError, match="rotation must be a rotation matrix"):
        payload_transform(np.diag([1.0, 1.0, -1.0]), np.zeros(3))
    with pytest.raises(
        ValueError, match="payload_transform: translation must have shape \\(3\\)"
    ):
        payload_transform(np.eye(3), np.zeros(2))
    with pytest.raises(ValueError, match="theta must have shape"):
        shift_parameters(np.zeros(9), np.eye(3), np.zeros(3))


def test_eliminate_known_moves_the_last_column():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(12, 4))
    theta = rng.normal(size=3)
    b = a[:, :3] @ theta + a[:, 3]  # known coefficient 1
    a_payload, b_payload = eliminate_known(a, b)
    np.testing.assert_allclose(
        np.linalg.lstsq(a_payload, b_payload, rcond=None)[0], theta
    )
    with pytest.raises(ValueError, match="A must have shape \\(r, p \\+ 1\\)"):
        eliminate_known(a[:, :1], b)


def test_update_solves_the_payload_and_holds_invalid_windows():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(40, 3))
    theta = np.array([0.5, -0.2])
    b = a[:, :2] @ theta + a[:, 2] + 1e-3 * rng.normal(size=40)
    state = payload_init(2)
    assert state.estimate.status is Status.WINDOW_NOT_READY
    np.testing.assert_array_equal(state.correlation, np.eye(2))
    solved = payload_update(state, True, a, b, names=("M", "MX"))
    core = identifier_update(identifier_init(2), True, a[:, :2], b - a[:, 2])
    np.testing.assert_array_equal(solved.estimate.theta, core.theta)
    np.testing.assert_array_equal(solved.estimate.std, core.std)
    np.testing.assert_allclose(solved.estimate.theta, theta, atol=1e-3)
    assert solved.correlation[0, 0] == pytest.approx(1.0)
    held = payload_update(solved, False, None, None)
    np.testing.assert_array_equal(held.estimate.theta, solved.estimate.theta)
    assert held.estimate.status is Status.WINDOW_NOT_READY and not held.estimate.valid
    rank_deficient = a.copy()
    rank_deficient[:, 1] = 0.0
    refused = payload_update(solved, True, rank_deficient, b)
    assert refused.estimate.status is Status.NOT_IDENTIFIABLE
    np.testing.assert_array_equal(refused.correlation, solved.correlation)
    with pytest.raises(ValueError, match="A must have 3 columns"):
        payload_update(state, True, a[:, :2], b)


def test_correlation_matches_the_covariance_of_the_solution():
    rng = np.random.default_rng(4)
    a = rng.normal(size=(50, 3)) @ np.array([[1, 0.9, 0], [0, 1, 0], [0, 0, 5.0]])
    covariance = np.linalg.inv(a.T @ a)
    expected = covariance / np.sqrt(np.outer(np.diag(covariance), np.diag(covariance)))
    np.testing.assert_allclose(solve_correlation(a), expected, atol=1e-12)


class _Base:
    def __init__(self, definitions):
        self.definitions = definitions


class _Rows:
    def __init__(self, definitions):
        self.base = _Base(definitions)


def test_summary_propagates_sigma_to_the_centre_of_mass():
    # c = h/m by Monte Carlo with correlated (h_x, m) against the first-order σ.
    rows = _Rows([{"MX": 1.0}, {"MY": 1.0}, {"MZ": 1.0}, {"M": 1.0}])
    theta = np.array([0.2, -0.1, 0.05, 2.0])
    std = np.array([0.004, 0.003, 0.002, 0.01])
    correlation = np.eye(4)
    correlation[0, 3] = correlation[3, 0] = 0.8
    summary = payload_summary(rows, theta, std, correlation)
    draws = np.random.default_rng(5).multivariate_normal(
        theta, correlation * np.outer(std, std), size=200_000
    )
    spread = np.std(draws[:, :3] / draws[:, 3:], axis=0)
    for axis, expected in zip("xyz", spread, strict=True):
        assert summary["com"][axis]["std"] == pytest.approx(expected, rel=0.02)
    assert summary["com"]["x"]["value"] == pytest.approx(0.1)
    assert summary["mass"]["identified"] and summary["mass"]["value"] == 2.0
    assert summary["not_identifiable"] == ["XX", "XY", "XZ", "YY", "YZ", "ZZ"]


def test_summary_of_regrouped_parameters_states_what_is_unknown():
    rows = _Rows([{"XX": 1.0, "YY": -1.0}, {"ZZ": 1.0}, {"MX": 1.0}, {"M": 1.0}])
    summary = payload_summary(rows, [0.1, 0.2, 0.0, 1.0], [np.inf] * 4)
    assert summary["standard"]["XX"] is None and summary["com"] is None
    assert summary["standard"]["ZZ"]["identified"] is False  # σ = inf
    assert summary["standard"]["MX"]["relative_std_percent"] == np.inf
    assert "XX" in summary["not_identifiable"] and "MZ" in summary["not_identifiable"]


def test_settings_are_the_documented_defaults_and_accept_overrides():
    settings = payload_settings()
    for name, value in PAYLOAD_DEFAULTS.items():
        if name == "frequencies":
            np.testing.assert_array_equal(settings.ell(), value)
        else:
            assert getattr(settings, name) == value
    assert payload_settings(window=1.0).window == 1.0
    with pytest.raises(ValueError, match="window must be > 0"):
        payload_settings(window=-1.0)


@pytest.mark.parametrize(
    ("jacobi_window", "time_step", "step"),
    [
        (0.1, None, 0.002),  # the documented default
        (0.1, 1e-3, 0.002),
        (0.01, None, 0.001),  # Tj/10 below 2 ms: Tj/10, as identify's rule
        (0.01, 1e-3, 0.001),
        (0.015, 1e-3, 0.001),  # the multiple of h at most Tj/10
        (0.03, 2e-3, 0.002),
        (0.1, 1e-2, 0.01),  # 100 Hz: at least one step
        (0.1, 5e-3, 0.005),
    ],
)
def test_the_default_bank_step_follows_the_jacobi_window(
    jacobi_window, time_step, step
):
    """Found by a review: the bank step stayed 2 ms under any Jacobi window, and
    jacobi_window 0.01 was refused; identify's unset bank step is at most
    jacobi_window/10 (OnlineSettings.on_grid). The payload's is too."""
    settings = payload_settings(time_step, jacobi_window=jacobi_window)
    assert settings.bank_time_step == pytest.approx(step, rel=1e-12)
    if time_step is not None:
        grid = settings.on_grid(time_step)
        assert grid.bank_time_step == pytest.approx(step, rel=1e-12)
    given = payload_settings(time_step, jacobi_window=0.1, bank_time_step=0.01)
    assert given.bank_time_step == 0.01  # a given step is kept


def test_dilution_weighs_down_only_the_frequencies_near_the_noise():
    from drake_dynid.core.payload_noise import DILUTION_SNR, dilution

    frequency = np.array([1, 1, 2, 2, 3, 3])
    variance = np.ones(6)
    # S_ν = ΣK²/Σv: 1e6, S₀ and 1 per frequency.
    known = np.sqrt(np.array([1e6, 1e6, DILUTION_SNR, DILUTION_SNR, 1.0, 1.0]))
    weight = dilution(known, variance, frequency)
    np.testing.assert_allclose(weight[:2], 1.0, atol=1e-6)
    np.testing.assert_allclose(weight[2:4], 0.5)
    assert (weight[4:] < 1e-4).all()


def _pooled_windows(rng, k, count=12):
    """``count`` windows (r = 16 rows: 2 equations) of 2 payload columns, k arm's
    error columns and the known column; B = A θ + K + noise."""
    settings = payload_settings()
    noise = settings.row_noise(2, settings.bank())
    r = noise.num_rows
    theta = np.array([0.5, -0.2])
    windows = []
    for _ in range(count):
        a = rng.normal(size=(r, 2 + k + 1))
        b = a[:, :2] @ theta + a[:, -1] + 0.01 * rng.normal(size=r)
        windows.append((a, b))
    return noise, windows


def test_the_arms_error_columns_add_their_image_to_sigma():
    # The arm's parameters off by z ~ N(0, Σ), Σ = L Lᵀ: the known column is off
    # by K_L z, the estimate by -G K_L z. With ordinary least squares (weighting
    # None) G = (AᵀA)⁻¹Aᵀ, computed here independently of the solver: σ² must
    # grow by diag(G K_L K_Lᵀ Gᵀ) exactly, θ̂ and the pool stay the same.
    rng = np.random.default_rng(7)
    k = 3
    noise, windows = _pooled_windows(rng, k)
    with_arm = without = payload_init(2)
    for a, b in windows:
        with_arm = payload_update(with_arm, True, a, b, noise=noise, arm_columns=k)
        plain = np.concatenate([a[:, :2], a[:, -1:]], axis=1)
        without = payload_update(without, True, plain, b, noise=noise)
    assert with_arm.estimate.valid and without.estimate.valid
    np.testing.assert_array_equal(with_arm.estimate.theta, without.estimate.theta)
    a = windows[-1][0]
    image = np.linalg.pinv(a[:, :2]) @ a[:, 2 : 2 + k]
    grown = with_arm.estimate.std**2 - without.estimate.std**2
    np.testing.assert_allclose(grown, np.sum(image**2, axis=1), rtol=1e-9)
    assert (grown > 0.05 * without.estimate.std**2).all()  # a visible term
    with pytest.raises(ValueError, match="A must have 6 columns"):
        payload_update(with_arm, True, a[:, :-1], windows[-1][1], arm_columns=k)


def test_arm_factor_reproduces_the_covariance_and_refuses_non_covariances():
    from drake_dynid.core.payload import arm_factor

    rng = np.random.default_rng(8)
    root = rng.normal(size=(5, 3))
    covariance = root @ root.T  # rank 3
    factor = arm_factor(covariance, 5)
    assert factor.shape == (5, 3)
    np.testing.assert_allclose(factor @ factor.T, covariance, atol=1e-12)
    with pytest.raises(ValueError, match="must be symmetric"):
        arm_factor(covariance + np.triu(np.ones((5, 5)), 1), 5)
    with pytest.raises(ValueError, match="positive semi-definite"):
        arm_factor(covariance - np.eye(5), 5)
    with pytest.raises(ValueError, match="shape"):
        arm_factor(covariance, 4)
