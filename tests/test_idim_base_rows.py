"""The inverse-dynamics rows in base columns come from the fused batch plan
(``core.batch_rows``; ``RobotRows._idim_base``): they must equal the standard rows'
base columns (the general path, ``core.rigid_body``) to round-off, and Pinocchio's
joint-torque regressor (a test-only oracle) to 1e-12. The Lagrangian rows in base
columns (``_lagrangian_base``) and their block means (``mean_packed_rows``, the raw
rows) must equal the standard rows' base columns and the means of the packed rows.

Pinocchio and Drake also check the standard rows themselves (tests/test_models_7dof.py,
tests/test_any_urdf.py); here the fused path is checked against the general one on
models with rotor inertia, offsets, locked joints, a dead zone, a prismatic joint and
a branched tree, and in blocks of samples (batches larger than ``BLOCK``).
"""

import numpy as np
import pytest
from test_plants import random_tree_urdf

from drake_dynid.core.batch_rows import BLOCK
from drake_dynid.core.friction import DeadZoneSign
from drake_dynid.plants import RobotModel, model_path

MODELS = [
    ("iiwa7", {}),
    ("iiwa7", {"rotor_inertia": True, "friction": "viscous,coulomb,offset"}),
    ("ur5", {"rotor_inertia": True, "locked": {"wrist_3_joint": 0.3}}),
    ("planar_2r", {"friction": "viscous"}),
]


PIN_ORDER = [4, 5, 7, 6, 8, 9, 1, 2, 3, 0]  # Pinocchio's [m, mc, Ixx Ixy Iyy ...]


@pytest.mark.parametrize(
    ("name", "options"),
    [
        ("iiwa7", {}),
        ("iiwa7", {"rotor_inertia": True, "friction": "viscous,coulomb,offset"}),
        ("ur5", {"rotor_inertia": True, "locked": {"wrist_3_joint": 0.3}}),
        ("planar_2r", {"friction": "viscous"}),
        ("tiago_no_hand", {"joints": ("torso_lift_joint", "arm_1_joint")}),
        ("tree", {"friction": "viscous,coulomb,offset"}),
    ],
)
def test_base_rows_are_the_standard_rows_base_columns(name, options, tmp_path):
    path = random_tree_urdf(tmp_path / "tree.urdf") if name == "tree" else None
    robot = RobotModel.from_urdf(path or model_path(name), **options)
    assert robot._batch_plan is not None  # the fused path is taken
    assert robot._batch_plan.serial == (name != "tree")
    widths = tuple(0.05 * (1 + j) for j in range(robot.num_joints))
    rng = np.random.default_rng(8)
    for model in (robot, robot.with_sign(DeadZoneSign(widths))):
        for size in (1, 5, BLOCK + 44):
            q, v, vdot = rng.normal(size=(3, size, robot.num_joints))
            v[0] *= 0.01  # some velocities inside the dead zone
            base = model.idim_rows(q, v, vdot)
            standard = model.idim_rows(q, v, vdot, columns="standard")
            expected = standard[..., list(model.base.independent)]
            scale = np.abs(expected).max()
            np.testing.assert_allclose(base, expected, rtol=0, atol=1e-14 * scale)
            # Friction and rotor columns are copies, not sums: exactly equal.
            copied = _copied_columns(model)
            np.testing.assert_array_equal(base[..., copied], expected[..., copied])
    single = robot.idim_rows(q[0], v[0], vdot[0])
    np.testing.assert_array_equal(single, robot.idim_rows(q[:1], v[:1], vdot[:1])[0])


def _copied_columns(model):
    prefixes = ("FV", "FC", "OFF", "IA")
    return [k for k, name in enumerate(model.base_names) if name.startswith(prefixes)]


@pytest.mark.parametrize("name", ["iiwa7", "ur5"])
def test_fused_base_rows_equal_pinocchios_regressor(name):
    pin = pytest.importorskip("pinocchio")
    robot = RobotModel.from_urdf(model_path(name), friction=())
    assert robot._batch_plan is not None
    model = pin.buildModelFromUrdf(str(model_path(name)))
    data = model.createData()
    n = robot.num_joints
    rng = np.random.default_rng(7)
    size = BLOCK + 20
    q = rng.uniform(-np.pi, np.pi, (size, n))
    v, vdot = rng.normal(size=(2, size, n))
    rows = robot.idim_rows(q, v, vdot)
    columns = list(robot.base.independent)
    for k in range(0, size, 7):
        oracle = pin.computeJointTorqueRegressor(model, data, q[k], v[k], vdot[k])
        oracle = oracle.reshape(n, n, 10)[:, :, PIN_ORDER].reshape(n, -1)[:, columns]
        scale = np.abs(oracle).max()
        np.testing.assert_allclose(rows[k], oracle, rtol=0, atol=1e-12 * scale)


@pytest.mark.parametrize(("name", "options"), MODELS)
def test_lagrangian_base_rows_are_the_standard_rows_base_columns(name, options):
    robot = RobotModel.from_urdf(model_path(name), **options)
    assert robot._base_sources is not None
    rng = np.random.default_rng(9)
    q, v = rng.normal(size=(2, 40, robot.num_joints))
    gathered = robot._lagrangian_base(q, v)
    for fast, general in zip(gathered, robot._lagrangian_standard(q, v), strict=True):
        np.testing.assert_array_equal(fast, general[..., list(robot.base.independent)])
    assert len(gathered) == 3


@pytest.mark.parametrize(("name", "options"), [*MODELS, ("tree", {})])
def test_mean_packed_rows_are_the_block_means_of_the_packed_rows(
    name, options, tmp_path
):
    """The Lagrangian means come from ``core.batch_rows`` (one product per block,
    batches of whole blocks up to ``BLOCK`` samples): 300 samples cross a batch."""
    from drake_dynid.core.rows import pack_rows

    path = random_tree_urdf(tmp_path / "tree.urdf") if name == "tree" else None
    robot = RobotModel.from_urdf(path or model_path(name), **options)
    assert robot._batch_plan is not None  # the fused Lagrangian means
    widths = tuple(0.05 * (1 + j) for j in range(robot.num_joints))
    rng = np.random.default_rng(10)
    q, v, tau = rng.normal(size=(3, 300, robot.num_joints))
    v[:20] *= 0.01  # some velocities inside the dead zone
    for model in (robot, robot.with_sign(DeadZoneSign(widths))):
        for kind in ("lagrangian", "power"):
            packed = pack_rows(*model.model_rows(kind, q, v, tau))
            for block in (1, 10, 30):
                expected = packed.reshape(300 // block, block, -1).mean(axis=1)
                got = model.mean_packed_rows(kind, q, v, tau, block)
                np.testing.assert_allclose(
                    got, expected, rtol=0, atol=1e-14 * abs(expected).max()
                )
