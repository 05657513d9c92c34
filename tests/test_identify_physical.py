"""dynid identify --physical / --urdf-out: the on-line estimate projected onto the
consistent set in its window's covariance metric and written as a URDF.

Data: the paper's 2R trajectory with torques from Drake's inverse dynamics
(tests/_drake_dynamics.py), never the library's regressor; the written file is
checked with Drake's inverse dynamics again."""

import json

import numpy as np
import pytest
from _drake_dynamics import drake_torques, exact_paper_2r

from drake_dynid import cli, paper
from drake_dynid.commands.identify import final_covariance_of, projection_covariance
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.plants import RobotModel, model_path


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


def test_identify_writes_a_urdf_that_drake_reproduces(robot, tmp_path, capsys):
    t, q, tau = exact_paper_2r(robot)
    log = tmp_path / "log.csv"
    write_log(log, t, q, tau, robot.joint_names)
    out, fit = tmp_path / "online.urdf", tmp_path / "online.json"
    argv = ["identify", str(log), "--urdf", model_path("planar_2r"), "--window", "10"]
    argv += ["--dead-zone", "none", "--urdf-out", str(out), "--json", str(fit)]
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    assert "physically consistent estimate (" in printed
    assert "Mahalanobis distance²" in printed and f"wrote {out}" in printed
    document = json.loads(fit.read_text())
    physical = document["physical"]
    assert physical["urdf"] == str(out) and physical["urdf_skipped"] == []
    # A noise-free log of a consistent robot: the projection hardly moves it.
    estimate = np.array([p["value"] for p in document["parameters"]])
    projected = np.array([p["value"] for p in physical["parameters"]])
    std = np.array([p["std"] for p in document["parameters"]])
    assert np.all(np.abs(projected - estimate) <= 0.5 * std + 1e-9)
    # Drake on the written file predicts the log's torques (0.002 % measured).
    written = RobotModel.from_urdf(out)
    qq, v, vdot = paper.paper_trajectory().evaluate(t[::50])
    predicted = drake_torques(written, qq, v, vdot)
    error = np.sqrt(np.mean((predicted - tau[::50]) ** 2, axis=0)) / np.sqrt(
        np.mean(tau[::50] ** 2, axis=0)
    )
    assert np.all(error < 1e-3), error


def test_the_projection_metric_is_the_final_covariance(robot):
    """--physical projects in the metric --json writes (final_covariance_of: the
    final solve's sandwich correlation scaled by σ); a σ that is not finite
    becomes 1e3 times the largest, uncorrelated: the projection moves it freely."""
    t, q, tau = exact_paper_2r(robot)
    rng = np.random.default_rng(3)
    log = RobotLog(t, q, tau + 0.05 * rng.standard_normal(tau.shape),
                   robot.joint_names, 1e-3)  # fmt: skip
    settings = OnlineSettings(window=10.0, bandwidth=1.0).on_grid(1e-3)
    (trace,) = replay_log_core(log, robot.rows_provider(), [settings])
    p = robot.num_parameters
    std = np.linspace(0.01, 0.08, p)
    std[3] = np.inf  # a parameter the window does not see
    last = len(trace.t) - 1
    found = final_covariance_of(log, robot, settings, trace, last, std)
    assert found["method"] == "sandwich"
    covariance = projection_covariance(found["covariance"])
    assert covariance.shape == (p, p)
    np.testing.assert_allclose(covariance, covariance.T, rtol=0, atol=0)
    finite = np.isfinite(std)
    np.testing.assert_allclose(np.diag(covariance)[finite], std[finite] ** 2)
    assert covariance[3, 3] == pytest.approx((1e3 * 0.08) ** 2)
    assert np.all(np.delete(covariance[3], 3) == 0.0)
    assert np.linalg.eigvalsh(covariance).min() > -1e-12 * covariance.max()
    # Correlated, not diagonal: the window's solve couples the parameters.
    off = np.abs(
        covariance / np.sqrt(np.outer(np.diag(covariance), np.diag(covariance)))
    )
    assert off[~np.eye(p, dtype=bool)].max() > 0.05


def test_identify_refuses_a_bad_regularization_before_the_replay(tmp_path, capsys):
    argv = ["identify", str(tmp_path / "none.csv"), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--regularization", "-1"]) == 2
    assert "--regularization" in capsys.readouterr().err


def test_the_regularizer_is_recorded_and_an_unknown_one_refused(
    robot, tmp_path, capsys
):
    """--regularizer entropic (the log-det divergence from the URDF's
    pseudo-inertias) reaches offline's solve and identify's projection, is
    printed beside λ and recorded in the JSON; the default is euclidean."""
    t, q, tau = exact_paper_2r(robot, duration_samples=12001)
    rng = np.random.default_rng(4)
    log = tmp_path / "log.csv"
    write_log(log, t, q, tau + 0.02 * rng.standard_normal(tau.shape), robot.joint_names)
    base = [str(log), "--urdf", model_path("planar_2r"), "--dead-zone", "none"]
    runs = {
        "offline": ["offline", *base],
        "identify": ["identify", *base, "--window", "10"],
    }
    for command, argv in runs.items():
        for choice in (None, "entropic"):
            out = tmp_path / f"{command}-{choice}.json"
            extra = [] if choice is None else ["--regularizer", choice]
            assert cli.main([*argv, "--physical", *extra, "--json", str(out)]) == 0
            printed = capsys.readouterr().out
            physical = json.loads(out.read_text())["physical"]
            expected = choice or "euclidean"
            assert physical["regularizer"] == expected, command
            assert f"λ = 0.001, {expected})" in printed
    for argv in runs.values():
        with pytest.raises(SystemExit) as exit_code:  # argparse's choices
            cli.main([*argv, "--physical", "--regularizer", "logdet"])
        assert exit_code.value.code == 2
        err = capsys.readouterr().err
        assert "argument --regularizer: invalid choice: 'logdet'" in err, err
        assert cli.main([*argv, "--regularizer", "entropic"]) == 2
        err = capsys.readouterr().err
        assert "--regularizer chooses what --regularization weighs" in err, err
        assert (
            "give it with --physical (or --urdf-out)" in err and "Traceback" not in err
        )
