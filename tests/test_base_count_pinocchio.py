"""The number of base parameters agrees with an independent oracle (Pinocchio).

Pinocchio's joint-torque regressor (10 inertial columns per link) stacked at random
states (default_rng(0)) has the rank of the identifiable inertial combinations;
drake_dynid's base set must have exactly that many inertial parameters (plus two
friction columns per joint). A round-off column kept as independent (MZ2 of the
iiwa7, whose joint 1 is vertical) once made it 58 instead of 57.
"""

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from drake_dynid.plants import RobotModel, model_path  # noqa: E402


@pytest.mark.parametrize(("name", "inertial"), [("iiwa7", 43), ("ur5", 36)])
def test_base_count_matches_pinocchio_rank(name, inertial):
    model = pin.buildModelFromUrdf(model_path(name))
    data = model.createData()
    rng = np.random.default_rng(0)
    rows = [
        pin.computeJointTorqueRegressor(
            model,
            data,
            rng.uniform(-3.0, 3.0, model.nq),
            rng.normal(size=model.nv),
            rng.normal(size=model.nv),
        ).copy()
        for _ in range(150)
    ]
    singular = np.linalg.svd(np.vstack(rows), compute_uv=False)
    rank = int(np.sum(singular > 1e-10 * singular[0]))
    assert rank == inertial
    robot = RobotModel.from_urdf(model_path(name))
    assert robot.num_parameters == rank + 2 * robot.num_joints
    assert "MZ2" not in robot.base.names or name != "iiwa7"
