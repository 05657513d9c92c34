"""Fused regressor rows: the batch rows against Pinocchio, one sample against batches.

* ``RobotModel.idim_rows`` (``core.rigid_body``, the batch path) equals Pinocchio's
  joint-torque regressor (``pin.computeJointTorqueRegressor``, a test-only oracle)
  column by column, per link [m, mc, I] permuted to [XX XY XZ YY YZ ZZ MX MY MZ M].
* ``RobotModel.packed_rows`` (``core.sample_rows``, the blocks' per-sample path)
  equals ``pack_rows(*model_rows(...))`` for both model kinds, with rotor inertia,
  offset friction and a prismatic joint (TIAGo's torso), at seeded random states.
* Models it does not cover (mimic joints, Drake kinematics) take the batch path.
"""

import numpy as np
import pytest

from drake_dynid.core.rows import pack_rows
from drake_dynid.plants import RobotModel, model_path

PIN_ORDER = [4, 5, 7, 6, 8, 9, 1, 2, 3, 0]  # Pinocchio's [m, mc, Ixx Ixy Iyy ...]


@pytest.mark.parametrize("name", ["iiwa7", "ur5"])
def test_batch_idim_rows_equal_pinocchios_regressor(name):
    pin = pytest.importorskip("pinocchio")
    robot = RobotModel.from_urdf(model_path(name), friction=())
    model = pin.buildModelFromUrdf(str(model_path(name)))
    data = model.createData()
    assert list(model.names)[1:] == list(robot.joint_names)
    n = robot.num_joints
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (40, n))
    v, vdot = rng.normal(size=(2, 40, n))
    rows = robot.idim_rows(q, v, vdot, columns="standard")
    for k in range(40):
        oracle = pin.computeJointTorqueRegressor(model, data, q[k], v[k], vdot[k])
        oracle = oracle.reshape(n, n, 10)[:, :, PIN_ORDER].reshape(n, -1)
        scale = np.abs(oracle).max()
        np.testing.assert_allclose(rows[k], oracle, rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize(
    ("name", "options"),
    [
        ("iiwa7", {}),
        (
            "iiwa7",
            {"rotor_inertia": True, "friction": ("viscous", "coulomb", "offset")},
        ),
        ("ur5", {"friction": ()}),
        ("planar_2r", {}),
        (
            "tiago_no_hand",
            {"joints": ("torso_lift_joint", "arm_1_joint", "arm_2_joint")},
        ),
    ],
)
@pytest.mark.parametrize("kind", ["lagrangian", "power"])
def test_one_sample_equals_the_batch_rows(name, options, kind):
    robot = RobotModel.from_urdf(model_path(name), **options)
    assert robot._sample_plan is not None
    n = robot.num_joints
    rng = np.random.default_rng(11)
    for _ in range(10):
        q = rng.uniform(-np.pi, np.pi, n)
        v, tau = rng.normal(size=(2, n))
        v[0] = 0.0  # the Coulomb column at rest
        batch = pack_rows(*robot.model_rows(kind, q[None], v[None], tau[None]))[0]
        one = robot.packed_rows(kind, q, v, tau)
        assert one.shape == batch.shape
        np.testing.assert_allclose(
            one, batch, rtol=0, atol=1e-13 * max(1.0, np.abs(batch).max())
        )


def test_drake_kinematics_take_the_batch_path():
    robot = RobotModel.from_urdf(model_path("iiwa7"), kinematics="drake")
    assert robot._sample_plan is None
    q, v, tau = np.random.default_rng(2).normal(size=(3, 7))
    batch = pack_rows(*robot.model_rows("lagrangian", q, v, tau))
    np.testing.assert_array_equal(robot.packed_rows("lagrangian", q, v, tau), batch)


def test_unknown_kind_is_rejected():
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    with pytest.raises(ValueError, match="kind must be one of"):
        robot.packed_rows("energy", np.zeros(2), np.zeros(2), np.zeros(2))
