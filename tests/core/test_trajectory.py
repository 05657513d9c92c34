"""Fourier exciting trajectories: derivatives, limits, condition-number optimisation."""

import numpy as np
import pytest

from drake_dynid.core.trajectory import (
    FourierTrajectory,
    optimize_fourier_trajectory,
    random_fourier_trajectory,
    regressor_condition_number,
)


def _planar_2r_idim_rows(q, v, vdot):
    """IDIM rows of the paper's 2R arm (docs/MATH.md §2), L1 = 1 m: (N, 2, 8)."""
    c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
    v1, v2 = v[:, 0], v[:, 1]
    a1, a2 = vdot[:, 0], vdot[:, 1]
    zero = np.zeros_like(v1)
    tau1 = [
        a1,
        a1 + a2,
        c2 * (2 * a1 + a2) - s2 * (2 * v1 * v2 + v2**2),
        -(s2 * (2 * a1 + a2) + c2 * (2 * v1 * v2 + v2**2)),
        v1,
        np.sign(v1),
        zero,
        zero,
    ]
    tau2 = [zero, a1 + a2, c2 * a1 + s2 * v1**2, -s2 * a1 + c2 * v1**2, zero, zero]
    tau2 += [v2, np.sign(v2)]
    return np.stack([np.stack(tau1, -1), np.stack(tau2, -1)], axis=1)


def _trajectory():
    rng = np.random.default_rng(41)  # seed 41
    return FourierTrajectory(
        q0=[0.1, -0.2],
        a=rng.normal(size=(2, 4)),
        b=rng.normal(size=(2, 4)),
        base_frequency=2 * np.pi / 5,
    )


def test_derivatives_match_finite_differences_and_the_series_is_periodic():
    trajectory = _trajectory()
    t = np.linspace(0.0, 10.0, 101)
    q, v, vdot = trajectory.evaluate(t)
    assert q.shape == v.shape == vdot.shape == (101, 2)
    dt = 1e-5
    q_plus, v_plus, _ = trajectory.evaluate(t + dt)
    q_minus, v_minus, _ = trajectory.evaluate(t - dt)
    np.testing.assert_allclose((q_plus - q_minus) / (2 * dt), v, atol=1e-8)
    np.testing.assert_allclose((v_plus - v_minus) / (2 * dt), vdot, atol=1e-7)
    later = trajectory.evaluate(t + trajectory.period)
    for now, then in zip((q, v, vdot), later, strict=True):
        np.testing.assert_allclose(then, now, atol=1e-12)
    # Scalar time and the Swevers form at t = 0.
    q0, v0, _ = trajectory.evaluate(0.0)
    omega_l = trajectory.base_frequency * np.arange(1, 5)
    np.testing.assert_allclose(q0, trajectory.q0 - (trajectory.b / omega_l).sum(1))
    np.testing.assert_allclose(v0, trajectory.a.sum(1))


def test_random_trajectory_respects_its_limits_on_a_dense_grid():
    limits = np.array([5.0, 2.0])
    trajectory = random_fourier_trajectory(
        2,
        harmonics=6,
        base_frequency=2 * np.pi / 4,
        max_velocity=limits,
        rng=np.random.default_rng(42),  # seed 42
    )
    t = np.linspace(0.0, trajectory.period, 200_001)
    _, v, _ = trajectory.evaluate(t)
    peak = np.abs(v).max(axis=0)
    assert np.all(peak <= limits)
    assert np.all(peak > 0.99 * limits)  # the bound is not wasteful
    again = random_fourier_trajectory(
        2,
        harmonics=6,
        base_frequency=2 * np.pi / 4,
        max_velocity=limits,
        rng=np.random.default_rng(42),
    )
    np.testing.assert_array_equal(again.a, trajectory.a)
    # Acceleration and position limits bind when tighter.
    tight = random_fourier_trajectory(
        2,
        harmonics=6,
        base_frequency=2 * np.pi / 4,
        max_velocity=5.0,
        max_acceleration=1.0,
        max_position=[0.3, 10.0],
        rng=np.random.default_rng(43),
    )
    q, v, vdot = tight.evaluate(t)
    assert np.all(np.abs(vdot).max(0) <= 1.0)
    assert np.abs(q[:, 0] - tight.q0[0]).max() <= 0.3
    assert np.all(np.abs(v).max(0) <= 5.0)


def test_optimisation_reduces_the_condition_number_within_limits():
    common = dict(harmonics=3, base_frequency=2 * np.pi / 5, max_velocity=3.0)
    start = random_fourier_trajectory(2, rng=np.random.default_rng(0), **common)
    times = start.period * np.arange(200) / 200
    before = regressor_condition_number(_planar_2r_idim_rows, start, times)
    best = optimize_fourier_trajectory(
        _planar_2r_idim_rows, 2, seed=0, iterations=200, **common
    )
    after = regressor_condition_number(_planar_2r_idim_rows, best, times)
    assert after < 0.8 * before  # measured 4.66 -> 3.24
    assert np.all(best.extrema()[1] <= 3.0 + 1e-12)
    again = optimize_fourier_trajectory(
        _planar_2r_idim_rows, 2, seed=0, iterations=200, **common
    )
    np.testing.assert_array_equal(again.a, best.a)  # deterministic with the seed


def test_condition_number_of_an_unexcited_column_is_infinite():
    rest = FourierTrajectory([0.0, 0.0], np.zeros((2, 1)), np.zeros((2, 1)), 1.0)
    assert regressor_condition_number(_planar_2r_idim_rows, rest, [0.0, 1.0]) == np.inf


def test_validation():
    with pytest.raises(ValueError, match=r"a must have shape \(2, H >= 1\)"):
        FourierTrajectory([0.0, 0.0], np.zeros((3, 2)), np.zeros((3, 2)), 1.0)
    with pytest.raises(ValueError, match=r"b must have shape \(2, 2\)"):
        FourierTrajectory([0.0, 0.0], np.zeros((2, 2)), np.zeros((2, 3)), 1.0)
    with pytest.raises(ValueError, match="base_frequency must be > 0"):
        FourierTrajectory([0.0], np.zeros((1, 2)), np.zeros((1, 2)), 0.0)
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="max_velocity must be > 0"):
        random_fourier_trajectory(
            2, harmonics=2, base_frequency=1.0, max_velocity=-1.0, rng=rng
        )
    with pytest.raises(
        ValueError, match=r"max_velocity must be a scalar or have shape"
    ):
        random_fourier_trajectory(
            2, harmonics=2, base_frequency=1.0, max_velocity=[1.0, 2.0, 3.0], rng=rng
        )
    with pytest.raises(TypeError, match="rng must be a numpy"):
        random_fourier_trajectory(
            2, harmonics=2, base_frequency=1.0, max_velocity=1.0, rng=0
        )
    with pytest.raises(ValueError, match="harmonics must be >= 1"):
        random_fourier_trajectory(
            2, harmonics=0, base_frequency=1.0, max_velocity=1.0, rng=rng
        )
    with pytest.raises(TypeError, match="rows_fn must be callable"):
        optimize_fourier_trajectory(
            None, 2, harmonics=2, base_frequency=1.0, max_velocity=1.0
        )
