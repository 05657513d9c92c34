"""The inverse-dynamics and Lagrangian rows in base columns are gathered straight
from the link blocks (``RobotRows._idim_base``, ``_lagrangian_base``): they must
equal the standard rows' base columns.

Pinocchio and Drake check the standard rows themselves (tests/test_models_7dof.py,
tests/test_any_urdf.py); here the gather is checked against the general path on
models with rotor inertia, offsets, locked joints and a dead zone.
"""

import numpy as np
import pytest

from drake_dynid.core.friction import DeadZoneSign
from drake_dynid.plants import RobotModel, model_path

MODELS = [
    ("iiwa7", {}),
    ("iiwa7", {"rotor_inertia": True, "friction": "viscous,coulomb,offset"}),
    ("ur5", {"rotor_inertia": True, "locked": {"wrist_3_joint": 0.3}}),
    ("planar_2r", {"friction": "viscous"}),
]


@pytest.mark.parametrize(("name", "options"), MODELS)
def test_base_rows_are_the_standard_rows_base_columns(name, options):
    robot = RobotModel.from_urdf(model_path(name), **options)
    assert robot._base_sources is not None  # the gathered path is taken
    widths = tuple(0.05 * (1 + j) for j in range(robot.num_joints))
    rng = np.random.default_rng(8)
    for model in (robot, robot.with_sign(DeadZoneSign(widths))):
        for size in (1, 5, 300):
            q, v, vdot = rng.normal(size=(3, size, robot.num_joints))
            v[0] *= 0.01  # some velocities inside the dead zone
            base = model.idim_rows(q, v, vdot)
            standard = model.idim_rows(q, v, vdot, columns="standard")
            np.testing.assert_array_equal(
                base, standard[..., list(model.base.independent)]
            )
    single = robot.idim_rows(q[0], v[0], vdot[0])
    np.testing.assert_array_equal(single, robot.idim_rows(q[:1], v[:1], vdot[:1])[0])


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


@pytest.mark.parametrize(("name", "options"), MODELS)
def test_mean_packed_rows_are_the_block_means_of_the_packed_rows(name, options):
    from drake_dynid.core.rows import pack_rows

    robot = RobotModel.from_urdf(model_path(name), **options)
    rng = np.random.default_rng(10)
    q, v, tau = rng.normal(size=(3, 60, robot.num_joints))
    for kind in ("lagrangian", "power"):
        packed = pack_rows(*robot.model_rows(kind, q, v, tau))
        expected = packed.reshape(6, 10, -1).mean(axis=1)
        got = robot.mean_packed_rows(kind, q, v, tau, 10)
        np.testing.assert_allclose(
            got, expected, rtol=0, atol=1e-14 * abs(expected).max()
        )
