"""Smooth Coulomb friction tanh(v/W) as a model option (RobotModel.coulomb_width).

Independent data: the 2R arm's torques come from Drake's ``CalcInverseDynamics``
(gravity and the URDF damping as force elements) plus FC·tanh(v/W), on a random
Fourier trajectory (default_rng(3)) evaluated exactly (no simulation).
"""

import json

import numpy as np
import pytest
from pydrake.multibody.tree import MultibodyForces

from drake_dynid import cli
from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.offline import identify_offline
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path

WIDTH = 0.1  # [rad/s]
H = 2e-3


def drake_torques(robot, q, v, vdot, coulomb, sign):
    """Drake's inverse dynamics (gravity, damping) + coulomb·sign(v), per sample."""
    plant = robot.plant
    context = plant.CreateDefaultContext()
    out = []
    for k in range(len(q)):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        out.append(plant.CalcInverseDynamics(context, vdot[k], forces))
    return np.array(out) + coulomb * sign(v)


@pytest.fixture(scope="module")
def tanh_log():
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    trajectory = random_fourier_trajectory(
        2,
        harmonics=4,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=2.0,
        rng=np.random.default_rng(3),
    )
    t = H * np.arange(10001)
    q, v, vdot = trajectory.evaluate(t)
    coulomb = np.array([0.4, 0.25])
    tau = drake_torques(robot, q, v, vdot, coulomb, lambda x: np.tanh(x / WIDTH))
    return RobotLog(t, q, tau, robot.joint_names, H)


def test_every_row_of_the_model_uses_the_tanh_law():
    robot = RobotModel.from_urdf(model_path("planar_2r"), coulomb_width=WIDTH)
    assert robot.coulomb_width == WIDTH
    rng = np.random.default_rng(5)
    q, v, vdot, tau = rng.normal(size=(4, 6, 2))
    fc = [robot.names.index("FC1"), robot.names.index("FC2")]
    idim = robot.idim_rows(q, v, vdot)
    np.testing.assert_allclose(idim[:, 0, fc[0]], np.tanh(v[:, 0] / WIDTH))
    np.testing.assert_allclose(idim[:, 1, fc[1]], np.tanh(v[:, 1] / WIDTH))
    _, g, _ = robot.model_rows("lagrangian", q, v, tau)
    np.testing.assert_allclose(g[:, 1, fc[1]], np.tanh(v[:, 1] / WIDTH))
    _, g, _ = robot.model_rows("power", q, v, tau)
    np.testing.assert_allclose(g[:, 0, fc[0]], v[:, 0] * np.tanh(v[:, 0] / WIDTH))
    # The 2R fast path takes the same law (rows_provider checks it against the
    # model's rows), in its batch and single-sample forms.
    fast = robot.rows_provider()
    assert isinstance(fast, Planar2RRows) and fast.coulomb_width == WIDTH
    for kind in ("lagrangian", "power"):
        d, g, y = fast.model_rows(kind, q[0], v[0], tau[0])
        packed = np.concatenate([d.ravel(), g.ravel(), y.ravel()])
        np.testing.assert_allclose(fast.packed_rows(kind, q[0], v[0], tau[0]), packed)
        for a, b in zip(
            fast.model_rows(kind, q, v, tau),
            robot.model_rows(kind, q, v, tau),
            strict=True,
        ):
            np.testing.assert_allclose(a, b, atol=1e-12)
    # Width 0: the exact sign, as before.
    exact = RobotModel.from_urdf(model_path("planar_2r"))
    assert np.array_equal(exact.idim_rows(q, v, vdot)[:, 0, fc[0]], np.sign(v[:, 0]))


def test_offline_identification_needs_the_matching_coulomb_law(tanh_log):
    errors = {}
    for width in (0.0, WIDTH):
        robot = RobotModel.from_urdf(model_path("planar_2r"), coulomb_width=width)
        result = identify_offline(tanh_log, robot)
        truth = robot.base_values
        errors[width] = np.abs(result.theta - truth) / np.abs(truth)
    assert errors[WIDTH].max() < 5e-4  # the matching law: filter round-off only
    assert errors[0.0][4:].max() > 1e-2  # sign(v) misses tanh friction by > 1 %


def test_cli_takes_and_echoes_the_coulomb_width(tanh_log, tmp_path, capsys):
    path = tmp_path / "log.csv"
    write_log(path, tanh_log.t, tanh_log.q, tanh_log.tau, tanh_log.joint_names)
    out = tmp_path / "offline.json"
    argv = ["offline", str(path), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--coulomb-width", str(WIDTH), "--json", str(out)]) == 0
    assert f"tanh(v/{WIDTH:g})" in capsys.readouterr().out
    document = json.loads(out.read_text())
    assert document["settings"]["coulomb_width"] == WIDTH
    fc1 = next(p for p in document["parameters"] if p["name"] == "FC1")
    assert fc1["value"] == pytest.approx(0.4, rel=1e-3)
    # validate reads the width back from the results file: the tanh model predicts
    # the log's torques (sign(v) would miss them at every velocity reversal).
    report = tmp_path / "validate.json"
    argv_v = ["validate", str(path), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv_v, "--params", str(out), "--json", str(report)]) == 0
    capsys.readouterr()
    checked = json.loads(report.read_text())
    assert checked["settings"]["coulomb_width"] == WIDTH
    assert cli.main([*argv, "--coulomb-width", "-1"]) == 2
    err = capsys.readouterr().err
    assert "--coulomb-width must be >= 0 [rad/s or m/s]" in err and "-1" in err
    # Found by a review: a dead-zone width beside a smooth law was dropped without
    # a word (offline fitted tanh(v/W); validate too, with the file's width).
    for extra in ([*argv, "--coulomb-width", str(WIDTH)], [*argv_v, "--params", out]):
        assert cli.main([*map(str, extra), "--dead-zone", "0.05"]) == 2
        err = capsys.readouterr().err
        assert "--dead-zone 0.05: the Coulomb law is already smooth" in err, err
        assert "Traceback" not in err


def test_bad_widths_are_rejected():
    with pytest.raises(ValueError, match="coulomb_width must be >= 0"):
        Planar2RRows(coulomb_width=-0.1)
    with pytest.raises(TypeError, match="coulomb_width must be a real number"):
        Planar2RRows(coulomb_width="wide")
