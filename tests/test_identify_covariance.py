"""dynid identify --json writes the final estimate's covariance: the exact
covariance model of the final window's solve (its correlation K), scaled to the
σ it prints (S K S: the diagonal is σ² exactly, the bootstrap's inflation
included); --physical projects in that metric; dynid payload --params
propagates it.

Data: the paper's 2R trajectory with torques from Drake's inverse dynamics
(tests/_drake_dynamics.py) and white torque noise."""

import json

import numpy as np
import pytest
from _drake_dynamics import exact_paper_2r

from drake_dynid import cli
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.plants import RobotModel, model_path

URDF = model_path("planar_2r")


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(URDF)


@pytest.fixture(scope="module")
def noisy(robot):
    t, q, tau = exact_paper_2r(robot)
    rng = np.random.default_rng(3)
    return (
        t,
        q + 1e-4 * rng.standard_normal(q.shape),
        tau + 0.05 * (rng.standard_normal(tau.shape)),
    )


@pytest.fixture(scope="module")
def identified(robot, noisy, tmp_path_factory):
    """dynid identify --json on the noisy 2R log (10 s window, the bootstrap)."""
    folder = tmp_path_factory.mktemp("cov")
    log = folder / "log.csv"
    write_log(log, *noisy, robot.joint_names)
    fit = folder / "online.json"
    argv = ["identify", str(log), "--urdf", URDF, "--window", "10"]
    argv += ["--dead-zone", "none", "--json", str(fit), "--quiet"]
    assert cli.main(argv) == 0
    return log, fit, json.loads(fit.read_text())


def test_the_covariance_diagonal_is_the_printed_sigma(identified):
    _, _, document = identified
    std = np.array([p["std"] for p in document["parameters"]])
    covariance = np.array(document["covariance"], dtype=float)
    p = std.size
    assert covariance.shape == (p, p)
    assert document["covariance_method"] == "sandwich"
    assert document["covariance_reason"] == ""
    # The σ printed is the larger of the window's and the bootstrap's.
    assert document["bootstrap"]["applied"] is True
    bootstrap = np.array(document["bootstrap"]["std"])
    assert np.all(std >= bootstrap) and np.any(std == bootstrap)  # 6 of 8 here
    np.testing.assert_array_equal(np.sqrt(np.diag(covariance)), std)
    np.testing.assert_array_equal(covariance, covariance.T)
    assert np.linalg.eigvalsh(covariance).min() > -1e-12 * np.abs(covariance).max()
    correlation = covariance / np.outer(std, std)
    assert np.abs(correlation[~np.eye(p, dtype=bool)]).max() > 0.05


def test_the_correlation_is_the_final_solves_sandwich(robot, noisy):
    """K of the final window's frequency-weighted solve (the sandwich of
    core.row_noise), and S the σ given: with the window's σ the covariance is
    the sandwich's itself, every entry (not the unweighted (AᵀA)⁻¹ of before)."""
    from drake_dynid.commands.identify import final_covariance_of
    from drake_dynid.core.replay import window_estimate_covariance

    t, q, tau = noisy
    log = RobotLog(t, q, tau, robot.joint_names, 1e-3)
    settings = OnlineSettings(window=10.0, bandwidth=1.0).on_grid(1e-3)
    (trace,) = replay_log_core(log, robot.rows_provider(), [settings])
    last = len(trace.t) - 1
    std = np.asarray(trace.std[last])
    found = final_covariance_of(log, robot, settings, trace, last, std)
    assert found["method"] == "sandwich" and found["reason"] == ""
    s = settings.for_robot(1e-3, robot.num_joints, robot.num_parameters)
    window = window_estimate_covariance(
        robot.rows_provider(), s, np.asarray(q), np.asarray(tau), len(t) - 1, 1e-3
    )
    np.testing.assert_allclose(window.result.theta, trace.theta[last], rtol=1e-7)
    tolerance = 1e-12 * np.abs(window.covariance).max()
    np.testing.assert_allclose(
        found["covariance"], window.covariance, rtol=1e-6, atol=tolerance
    )
    # A larger σ (the bootstrap's) scales its row and column: S K S.
    wider = std.copy()
    wider[1] *= 3.0
    inflated = final_covariance_of(log, robot, settings, trace, last, wider)
    np.testing.assert_allclose(inflated["covariance"][1, 1], wider[1] ** 2, rtol=1e-15)
    np.testing.assert_allclose(
        inflated["covariance"][1, 0], 3.0 * found["covariance"][1, 0], rtol=1e-12
    )
    # A σ that is not finite: its row and column are NaN (null in the JSON).
    wider[2] = np.inf
    unknown = final_covariance_of(log, robot, settings, trace, last, wider)
    assert np.isnan(unknown["covariance"][2]).all()
    assert np.isnan(unknown["covariance"][:, 2]).all()
    assert np.isfinite(np.delete(np.delete(unknown["covariance"], 2, 0), 2, 1)).all()


def test_the_payload_propagates_the_identify_covariance(identified, tmp_path, capsys):
    """dynid payload --params identify.json: σ holds the arm's covariance; the
    same file without it (an identify JSON written before) is taken as exact and
    says so; a parameter whose row and column are null is taken as exact, named;
    a diagonal one (after a detected change) is said to be."""
    log, _, document = identified
    base = ["payload", str(log), "--urdf", URDF, "--dead-zone", "none"]
    capsys.readouterr()
    runs = {}
    old = dict(document)
    for key in ("covariance", "covariance_method", "covariance_reason"):
        old.pop(key)
    nulls = json.loads(json.dumps(document))
    for row in nulls["covariance"]:
        row[0] = None
    nulls["covariance"][0] = [None] * len(nulls["covariance"])
    nulls["covariance_method"] = "diagonal"  # as after a detected change
    for name, content in (("new", document), ("old", old), ("nulls", nulls)):
        given = tmp_path / f"{name}.json"
        given.write_text(json.dumps(content))
        out = tmp_path / f"{name}_payload.json"
        assert cli.main([*base, "--params", str(given), "--json", str(out)]) == 0
        runs[name] = (capsys.readouterr().out, json.loads(out.read_text()))
    printed, new = runs["new"]
    assert "known; their covariance propagated to σ)" in printed
    assert new["sigma_terms"]["arm_covariance"] is True
    assert new["arm"]["covariance_method"] == "sandwich"
    assert new["arm"]["taken_as_exact"] == []
    printed, old = runs["old"]
    assert "known; no covariance in the file: taken as exact" in printed
    assert old["sigma_terms"]["arm_covariance"] is False
    assert old["arm"]["covariance_method"] is None
    mass = new["payload"]["mass"], old["payload"]["mass"]
    assert mass[0]["value"] == mass[1]["value"]
    assert mass[0]["std"] > mass[1]["std"], mass
    printed, nulls = runs["nulls"]
    first = document["parameters"][0]["name"]
    assert "σ (the file's is diagonal: their correlation not known); " in printed
    assert f"; {first} without a finite σ in the file: taken as exact)" in printed
    assert nulls["arm"]["taken_as_exact"] == [first]
    assert nulls["sigma_terms"]["arm_covariance"] is True


def test_a_null_entry_outside_a_whole_row_is_refused(identified, tmp_path, capsys):
    log, _, document = identified
    broken = json.loads(json.dumps(document))
    broken["covariance"][0][1] = None
    given = tmp_path / "broken.json"
    given.write_text(json.dumps(broken))
    argv = ["payload", str(log), "--urdf", URDF, "--params", str(given), "--quiet"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "a null or non-finite entry outside a whole row and column" in err
    assert "Traceback" not in err


def test_the_covariance_computed_beside_the_replay_is_the_one_computed_after(
    identified, tmp_path, monkeypatch
):
    """The final window's covariance runs in the forked child beside the replay
    (with the bootstrap: off dynid identify's main path, issue 15); with
    --parallel off it runs after the replay, here. The same file either way."""
    from drake_dynid.commands import _background, identify

    log, _, document = identified
    calls = []
    original = identify.window_covariance_at

    def counted(*args):
        calls.append(1)  # in this process only (a forked child's do not count)
        return original(*args)

    monkeypatch.setattr(identify, "window_covariance_at", counted)
    fit = tmp_path / "off.json"
    argv = ["identify", str(log), "--urdf", URDF, "--window", "10"]
    argv += ["--dead-zone", "none", "--quiet", "--json"]
    assert cli.main([*argv, str(fit), "--parallel", "off"]) == 0
    assert calls == [1]
    here = json.loads(fit.read_text())
    np.testing.assert_array_equal(
        np.array(here["covariance"], dtype=float),
        np.array(document["covariance"], dtype=float),
    )
    assert here["covariance_method"] == document["covariance_method"]
    calls.clear()
    assert cli.main([*argv, str(tmp_path / "auto.json")]) == 0
    assert calls == ([] if _background.can_fork() else [1])


def test_the_covariance_beside_the_replay_reuses_the_bootstraps_rows(
    robot, noisy, monkeypatch
):
    """The final window's covariance computed beside the replay takes the
    bootstrap's raw rows of that window (its unperturbed channels) instead of
    evaluating them again (0.1 s of CPU on the 7-DOF 60 s log): no second
    raw_channels_batch, the same covariance bit for bit, and the channels are
    not carried back in the bootstrap's result."""
    from drake_dynid.commands import identify
    from drake_dynid.core import raw_rows, replay

    t, q, tau = noisy
    log = RobotLog(t, q, tau, robot.joint_names, 1e-3)
    settings = OnlineSettings(window=10.0, bandwidth=1.0, rows_from="raw").on_grid(1e-3)
    end = len(t) - 1
    alone = identify.window_covariance_at(log, robot, settings, end)
    calls = []
    counted = raw_rows.raw_channels_batch

    def counting(*args, **kwargs):
        calls.append(1)
        return counted(*args, **kwargs)

    monkeypatch.setattr(replay, "raw_channels_batch", counting)
    beside = identify._beside_replay(4, log, robot, settings, end, True)
    assert calls == []  # the bootstrap's channels, no second evaluation
    assert beside["bootstrap"]["result"].method == "linearized"
    assert beside["bootstrap"]["result"].channels is None
    found = beside["covariance"][1]
    assert found.method == alone.method == "sandwich"
    np.testing.assert_array_equal(found.covariance, alone.covariance)
    np.testing.assert_array_equal(found.result.theta, alone.result.theta)
