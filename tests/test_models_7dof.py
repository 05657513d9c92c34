"""The 7-DOF iiwa7 URDF loads, has physical inertias, friction and base parameters."""

import numpy as np

from drake_dynid.plants import RobotModel, model_path, read_urdf_friction


def test_iiwa7_loads_with_gravity_friction_and_base_parameters():
    robot = RobotModel.from_urdf(model_path("iiwa7"))
    assert robot.num_joints == 7
    assert len(robot.standard_names) == 7 * 10 + 7 * 2  # inertial + FV, FC
    # 43 inertial (Pinocchio and an SVD gap agree: tests/test_real_robots.py) + 14;
    # MZ2 is round-off of the URDF's π rotations, not a parameter; M2 (link 2's
    # origin on axes 1 and 2) is zero or round-off depending on the order of the
    # products (world-frame rows: round-off).
    assert robot.num_parameters == 43 + 14
    assert set(robot.base.round_off_columns) <= {"MZ2", "M2"}
    assert "MZ2" in robot.base.round_off_columns and robot.base.clear
    assert robot.names[-14:] == tuple(
        f"{kind}{j}" for j in range(1, 8) for kind in ("FV", "FC")
    )
    assert np.linalg.norm(robot.gravity) > 9.0
    friction = read_urdf_friction(model_path("iiwa7"))
    assert len(friction) == 7 and all(value > 0 for value in friction.values())
    # Seeded states (default_rng(3)): the Lagrangian rows are finite and the base
    # values reproduce the inverse dynamics rows' torques with gravity.
    rng = np.random.default_rng(3)
    q, v, vdot = rng.normal(size=(3, 5, 7))
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    d, g, y = robot.model_rows("lagrangian", q, v, tau)
    assert d.shape == g.shape == (5, 7, robot.num_parameters)
    assert np.all(np.isfinite(d)) and np.all(np.isfinite(g))
    np.testing.assert_allclose(y, tau)
    at_rest = robot.idim_rows(q, np.zeros_like(q), np.zeros_like(q))
    assert np.abs(at_rest @ robot.base_values).max() > 1.0  # gravity torques


def test_iiwa7_link_inertias_are_physical():
    robot = RobotModel.from_urdf(model_path("iiwa7"))
    values = robot.standard_parameters()
    for j in range(1, 8):
        assert values[f"M{j}"] > 0
        # Inertia about the joint frame origin: positive definite.
        inertia = np.array(
            [
                [values[f"XX{j}"], values[f"XY{j}"], values[f"XZ{j}"]],
                [values[f"XY{j}"], values[f"YY{j}"], values[f"YZ{j}"]],
                [values[f"XZ{j}"], values[f"YZ{j}"], values[f"ZZ{j}"]],
            ]
        )
        eigenvalues = np.linalg.eigvalsh(inertia)
        assert eigenvalues.min() > 0
        assert eigenvalues.sum() - 2 * eigenvalues.max() >= -1e-12  # triangle
