"""Payload identification against Drake: the transform, the rows, the on-line estimate.

Every reference here is Drake's (``SpatialInertia`` shifts, ``CalcInverseDynamics``
of the plant with the payload added to a body in the Context), never the library's
regressor.
"""

import numpy as np
import pytest

from drake_dynid.core.payload import (
    payload_parameters,
    payload_rows,
    shift_parameters,
)
from drake_dynid.core.payload_replay import replay_payload_core
from drake_dynid.core.payload_step import payload_settings
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog
from drake_dynid.payload import attachment_pose, payload_model
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path, read_urdf_friction

H = 1e-3


@pytest.fixture(scope="module")
def iiwa():
    return RobotModel.from_urdf(model_path("iiwa7"))


@pytest.fixture(scope="module")
def planar():
    return RobotModel.from_urdf(model_path("planar_2r"))


def _spatial(theta):
    """Drake's SpatialInertia of standard parameters about a frame's origin."""
    from pydrake.multibody.tree import SpatialInertia, UnitInertia

    m = theta[9]
    g = theta[:6] / m
    return SpatialInertia(
        m, theta[6:9] / m, UnitInertia(g[0], g[3], g[5], g[1], g[2], g[4])
    )


def _standard(spatial):
    m = spatial.get_mass()
    inertia = spatial.CalcRotationalInertia().CopyToFullMatrix3()
    return np.array(
        [
            inertia[0, 0],
            inertia[0, 1],
            inertia[0, 2],
            inertia[1, 1],
            inertia[1, 2],
            inertia[2, 2],
            *(m * np.asarray(spatial.get_com())),
            m,
        ]
    )


PAYLOAD = payload_parameters(
    1.5,
    [0.02, -0.03, 0.08],
    [[0.01, 0.001, 0.0], [0.001, 0.012, 0.002], [0.0, 0.002, 0.008]],
)


def test_shift_equals_drakes_reexpress_and_shift():
    from pydrake.math import RigidTransform, RollPitchYaw

    pose = RigidTransform(RollPitchYaw(0.3, -0.7, 1.9), [0.1, -0.2, 0.35])
    drake = _spatial(PAYLOAD).ReExpress(pose.rotation()).Shift(-pose.translation())
    ours = shift_parameters(PAYLOAD, pose.rotation().matrix(), pose.translation())
    np.testing.assert_allclose(ours, _standard(drake), atol=1e-14)


def _drake_torques(robot, q, v, vdot, payload=None, body=None, pick=0):
    """Drake's inverse dynamics (+ URDF Coulomb·sign); payload added from ``pick``.

    ``payload``: a SpatialInertia about the body's origin, in its frame.
    """
    from pydrake.multibody.tree import MultibodyForces

    coulomb = read_urdf_friction(robot.path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    plant = robot.plant
    context = plant.CreateDefaultContext()
    out = np.empty_like(q)
    for k in range(len(q)):
        if payload is not None and k == pick:
            target = plant.GetBodyByName(body)
            total = target.CalcSpatialInertiaInBodyFrame(context)
            total += payload
            target.SetSpatialInertiaInBodyFrame(context, total)
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        out[k] = plant.CalcInverseDynamics(context, vdot[k], forces)
    return out + fc * np.sign(v)


def _in_body(robot, frame, xyz, rpy):
    """The payload's SpatialInertia about the body origin, by Drake's transforms."""
    from pydrake.math import RigidTransform, RollPitchYaw

    plant = robot.plant
    target = plant.GetFrameByName(frame)
    offset = RigidTransform(RollPitchYaw(rpy), xyz)
    x_bf = target.GetFixedPoseInBodyFrame() @ offset
    spatial = _spatial(PAYLOAD).ReExpress(x_bf.rotation()).Shift(-x_bf.translation())
    return spatial, target.body().name()


def test_payload_rows_are_drakes_torque_difference(iiwa):
    xyz, rpy = [0.05, 0.0, 0.1], [0.2, 0.1, -0.4]
    rows = payload_model(iiwa, "iiwa_link_6", xyz=xyz, rpy=rpy)
    assert rows.link == 5 and rows.link_name == "iiwa_joint_6"
    assert rows.payload_names == (
        "XX",
        "XY",
        "XZ",
        "YY",
        "YZ",
        "ZZ",
        "MX",
        "MY",
        "MZ",
        "M",
    )
    rng = np.random.default_rng(0)
    q = rng.uniform(-2.0, 2.0, (6, 7))
    v, vdot = rng.normal(size=(2, 6, 7))
    spatial, body = _in_body(iiwa, "iiwa_link_6", xyz, rpy)
    difference = _drake_torques(iiwa, q, v, vdot, spatial, body) - _drake_torques(
        iiwa, q, v, vdot
    )
    predicted = rows.idim_rows(q, v, vdot) @ (rows.base.matrix @ PAYLOAD)
    np.testing.assert_allclose(predicted, difference, atol=1e-10)


def test_lagrangian_rows_with_the_known_column_give_drakes_torques(iiwa):
    # d/dt(D [θ; 1]) + G [θ; 1] = τ along a trajectory (central differences).
    rows = payload_model(iiwa)
    trajectory = random_fourier_trajectory(
        7,
        harmonics=3,
        base_frequency=2.0,
        max_velocity=1.5,
        rng=np.random.default_rng(1),
    )
    t, step = np.array([0.3, 0.9, 1.7]), 1e-5
    coefficients = np.append(rows.base.matrix @ PAYLOAD, 1.0)
    momentum = []
    for shift in (-step, step):
        q, v, _ = trajectory.evaluate(t + shift)
        momentum.append(rows.model_rows("lagrangian", q, v, np.zeros_like(q))[0])
    q, v, vdot = trajectory.evaluate(t)
    _, g_rows, _ = rows.model_rows("lagrangian", q, v, np.zeros_like(q))
    derivative = (momentum[1] - momentum[0]) @ coefficients / (2 * step)
    spatial, body = _in_body(iiwa, "iiwa_link_7", [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    tau = _drake_torques(iiwa, q, v, vdot, spatial, body)
    np.testing.assert_allclose(derivative + g_rows @ coefficients, tau, atol=1e-5)


def test_the_joints_see_only_some_payload_parameters(iiwa, planar):
    assert payload_rows(planar).payload_names == ("ZZ", "MX", "MY", "M")
    assert payload_rows(iiwa).num_payload == 10
    assert payload_rows(planar).names[-1] == "arm"
    with pytest.raises(ValueError, match="link must be a moving link of the robot"):
        payload_rows(planar, 2)
    with pytest.raises(ValueError, match="arm must have shape \\(8\\)"):
        payload_rows(planar, arm=np.zeros(3))


def test_attachment_frames_resolve_to_their_link(iiwa):
    link, pose = attachment_pose(iiwa, "iiwa_link_3")
    assert link == 2
    np.testing.assert_allclose(pose, np.eye(4), atol=1e-12)
    assert attachment_pose(iiwa) == (6, pytest.approx(np.eye(4)))
    with pytest.raises(ValueError, match="frame must be a body or frame of the URDF"):
        payload_model(iiwa, "gripper")
    with pytest.raises(ValueError, match="does not move rigidly with any identified"):
        payload_model(iiwa, "iiwa_link_0")


def _pick_log(robot, seed, duration=3.2, pick=1.5, q_std=1e-4, tau_std=0.02):
    """An exact trajectory, Drake's torques with a payload from ``pick``, noise."""
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        rng=np.random.default_rng(5),
    )
    t = H * np.arange(round(duration / H) + 1)
    q, v, vdot = trajectory.evaluate(t)
    body = robot._link_bodies[-1].name()
    tau = _drake_torques(robot, q, v, vdot, _spatial(PAYLOAD), body, round(pick / H))
    rng = np.random.default_rng(seed)
    noisy_q = q + q_std * rng.normal(size=q.shape)
    noisy_tau = tau + tau_std * rng.normal(size=q.shape)
    return RobotLog(t, noisy_q, noisy_tau, robot.joint_names, H)


def test_online_estimate_follows_a_pick_within_a_second(iiwa):
    rows = payload_rows(iiwa)
    log = _pick_log(iiwa, seed=3)
    trace = replay_payload_core(log, rows, payload_settings())
    mass = trace.theta[:, rows.payload_names.index("M")]
    before = (trace.t > 1.0) & (trace.t < 1.5)
    assert np.all(np.abs(mass[before]) < 0.05)  # no payload yet
    outside = np.flatnonzero((trace.t >= 1.5) & (np.abs(mass - 1.5) > 0.05 * 1.5))
    settle = trace.t[outside[-1] + 1] - 1.5
    assert settle <= 1.0
    final, std = trace.theta[-1], trace.std[-1]
    error = np.abs(final - rows.base.matrix @ PAYLOAD)
    identified = std <= 0.3 * np.abs(final)
    # Mass and the first moments along the link are identified; every identified
    # parameter is within 3 σ.
    for name in ("M", "MZ"):
        assert identified[rows.payload_names.index(name)]
    assert np.all(error[identified] <= 3.0 * std[identified])
    assert error[rows.payload_names.index("M")] < 0.01 * 1.5
