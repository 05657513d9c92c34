"""The on-line identifier's bias without noise, on independently computed torques.

Logs: a trajectory evaluated exactly (random Fourier series), torques from Drake's
``CalcInverseDynamics`` (gravity and the URDF damping as force elements) plus the
URDF's Coulomb friction FC·sign(v): never the library's regressor. The filtered
rows (the matched filter applied before the nonlinear rows) keep a bias; the raw
rows (``rows_from="raw"``, core.raw_rows) remove it.
"""

import numpy as np
import pytest
from _drake_dynamics import drake_torques

from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path

H = 1e-3


def exact_log(robot, trajectory, duration):
    t = H * np.arange(round(duration / H) + 1)
    q, v, vdot = trajectory.evaluate(t)
    return RobotLog(t, q, drake_torques(robot, q, v, vdot), robot.joint_names, H)


def final_estimates(log, robot, **settings):
    (trace,) = replay_log_core(
        log, robot, [OnlineSettings.for_model("lagrangian", **settings)]
    )
    final = trace.final()
    assert final["valid"]
    return final["theta"], final["std"]


@pytest.fixture(scope="module")
def iiwa():
    return RobotModel.from_urdf(model_path("iiwa7"))


def test_raw_rows_remove_the_bias_on_a_7dof_arm(iiwa):
    """iiwa7, window 10 s, period 5 s (0.2-1 Hz, |v| <= 1 rad/s), default_rng(0)."""
    trajectory = random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi * 0.2,
        max_velocity=1.0,
        max_position=1.0,
        rng=np.random.default_rng(0),
    )
    log = exact_log(iiwa, trajectory, 11.0)
    common = dict(window=10.0, bandwidth=2.0, update_period=0.5)
    raw, raw_std = final_estimates(log, iiwa, rows_from="raw", raw_window=0.1, **common)
    filtered, _ = final_estimates(log, iiwa, **common)
    truth = iiwa.base_values
    well = raw_std < 0.01 * np.abs(truth)  # well identified (a fixed set)
    assert well.sum() >= 25
    error_raw = np.abs(raw - truth)[well] / np.abs(truth[well])
    error_filtered = np.abs(filtered - truth)[well] / np.abs(truth[well])
    assert np.median(error_raw) < 2e-4  # measured 1.8e-5
    assert np.median(error_filtered) > 1e-2  # measured 3.4e-2
    # Torque prediction on another trajectory (default_rng(1)), per joint.
    check = random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi * 0.2,
        max_velocity=1.0,
        max_position=1.0,
        rng=np.random.default_rng(1),
    )
    q, v, vdot = check.evaluate(np.arange(0.0, 5.0, 0.01))
    tau = drake_torques(iiwa, q, v, vdot)
    rows = iiwa.idim_rows(q, v, vdot)

    def prediction_error(theta):
        return np.sqrt(np.mean((rows @ theta - tau) ** 2, axis=0) / np.mean(tau**2, 0))

    assert prediction_error(raw).max() < 2e-3  # measured 1.4e-5
    assert prediction_error(filtered).max() > 5e-3  # measured 4.2e-2 (joint 1)


def test_raw_rows_remove_the_friction_bias_of_the_1hz_2r_trajectory():
    """The paper's 2R on a 0.25-1 Hz trajectory (default_rng(5)), window 20 s."""
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    trajectory = random_fourier_trajectory(
        2,
        harmonics=4,
        base_frequency=2 * np.pi * 0.25,
        max_velocity=4.0,
        rng=np.random.default_rng(5),
    )
    log = exact_log(robot, trajectory, 21.0)
    rows = robot.rows_provider()
    truth = robot.base_values
    errors = {}
    for rows_from in ("filtered", "raw"):
        theta, _ = final_estimates(
            log, rows, rows_from=rows_from, window=20.0, bandwidth=1.05
        )
        errors[rows_from] = np.abs(theta - truth) / truth
    assert errors["raw"][4:].mean() < 0.01  # friction, measured 0.43 %
    assert errors["raw"][:4].mean() < 0.001  # measured 0.018 %
    assert errors["filtered"][4:].mean() > 0.02  # measured 6.8 %
