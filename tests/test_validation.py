"""Held-out validation (library and ``dynid validate``) on independent 2R logs.

The logs come from Pinocchio's inverse dynamics (``pin.rnea``) plus the URDF's
viscous and Coulomb friction along Fourier trajectories (seeds 4 and 5), never from
drake_dynid's regressor.
"""

import csv
import json
import os
import re
import shutil
import types

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.plants import RobotModel, model_path
from drake_dynid.validation import (
    check_parameters,
    read_estimates,
    read_results,
    split_log,
    validate_torques,
)

pin = pytest.importorskip("pinocchio")

URDF = model_path("planar_2r")
FV = np.array([0.3, 0.15])
FC = np.array([0.4, 0.25])
H = 1e-3


def _pinocchio_log(seed, duration, noise=0.0):
    model = pin.buildModelFromUrdf(URDF)
    data = model.createData()
    rng = np.random.default_rng(seed)
    trajectory = random_fourier_trajectory(
        2, harmonics=3, base_frequency=2 * np.pi * 0.5, max_velocity=3.0, rng=rng
    )
    t = H * np.arange(round(duration / H) + 1)
    q, v, a = trajectory.evaluate(t)
    # Continuous joints: Pinocchio's configuration is (cos q, sin q).
    config = np.stack([np.cos(q), np.sin(q)], axis=-1).reshape(t.size, -1)
    tau = np.array(
        [pin.rnea(model, data, config[k], v[k], a[k]) for k in range(t.size)]
    )
    tau += FV * v + FC * np.sign(v)
    q = q + noise * 0.01 * rng.normal(size=q.shape)
    tau = tau + noise * 0.2 * rng.normal(size=tau.shape)
    return RobotLog(t, q, tau, ("joint1", "joint2"), H)


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(URDF)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("validation")
    out = {}
    for name, seed in (("fit", 4), ("held", 5)):
        log = _pinocchio_log(seed, 4.0, noise=1.0)
        path = folder / f"{name}.csv"
        write_log(path, log.t, log.q, log.tau, log.joint_names)
        out[name] = (str(path), log)
    return out


def test_true_parameters_predict_an_independent_log(robot):
    log = _pinocchio_log(5, 4.0)
    result = validate_torques(log, robot, robot.base_values)
    assert result.joint_names == ("joint1", "joint2")
    # Noise-free: only the filters' bias remains (nonlinear W of filtered q).
    assert np.all(result.relative_rms_percent < 0.2), result.relative_rms_percent
    assert np.all(result.r_squared > 0.99999)
    assert np.all(result.raw_relative_rms_percent < 1.0)
    settings = result.settings
    assert (
        settings["cutoff_rule"] == "auto"
        and settings["decimation_cutoff_rule"] == "auto"
    )
    assert 0.5 < settings["decimation_cutoff_hz"] <= settings["cutoff_hz"]
    assert result.num_samples == log.num_samples
    assert result.num_samples_used == log.num_samples - 2 * settings["trim"]
    # A wrong model is seen: ZZ2 10 % too large.
    wrong = robot.base_values.copy()
    wrong[1] *= 1.1
    worse = validate_torques(log, robot, wrong)
    assert worse.relative_rms_percent[1] > 10 * result.relative_rms_percent[1]


def test_reported_errors_follow_their_definitions(robot, logs):
    log = logs["held"][1]
    result = validate_torques(log, robot, robot.base_values, cutoff_hz=5.0)
    assert (
        result.settings["cutoff_hz"] == 5.0
        and result.settings["cutoff_rule"] == "given"
    )
    residual = result.measured - result.predicted
    rms = np.sqrt(np.mean(result.measured**2, axis=0))
    np.testing.assert_allclose(result.rms_measured, rms)
    np.testing.assert_allclose(
        result.relative_rms_percent, 100 * np.sqrt(np.mean(residual**2, axis=0)) / rms
    )
    centred = result.measured - result.measured.mean(axis=0)
    np.testing.assert_allclose(
        result.r_squared,
        1 - np.sum(residual**2, axis=0) / np.sum(centred**2, axis=0),
    )
    np.testing.assert_allclose(result.residual_std, residual.std(axis=0))
    # The raw comparison holds the torque noise (0.2 N·m) and the noise of v̇
    # between the band and the 5 Hz cutoff; the low-pass removes most of both.
    raw = result.raw_measured - result.raw_predicted
    assert np.all(raw.std(axis=0) > 0.18)
    assert np.all(result.residual_std < 0.25 * raw.std(axis=0))
    # The compared samples are the logged ones, in order.
    k = np.searchsorted(log.t, result.t[0])
    np.testing.assert_array_equal(result.raw_measured[:10], log.tau[k : k + 10])
    # θ = 0 predicts nothing: 100 % error.
    zero = validate_torques(log, robot, np.zeros(robot.num_parameters))
    np.testing.assert_allclose(zero.relative_rms_percent, 100.0)
    assert zero.total_relative_rms_percent == pytest.approx(100.0)


def test_bad_samples_split_the_log_into_segments(robot):
    log = _pinocchio_log(5, 4.0)
    q = log.q.copy()
    q[2000:2010] = np.nan
    gappy = RobotLog(log.t, q, log.tau, log.joint_names, H)
    result = validate_torques(gappy, robot, robot.base_values)
    assert set(result.segment.tolist()) == {0, 1}
    assert np.all(np.isfinite(result.predicted))
    assert np.all(result.relative_rms_percent < 0.3)
    first, rest = split_log(log, 0.25)
    assert first.num_samples == 1000 and rest.num_samples == 3001
    assert rest.t[0] == log.t[1000]
    with pytest.raises(ValueError, match=r"fraction must be in \(0, 1\)"):
        split_log(log, 1.0)
    with pytest.raises(ValueError, match="log joints must be the robot's"):
        validate_torques(
            RobotLog(log.t, log.q, log.tau, ("a", "b"), H), robot, robot.base_values
        )
    with pytest.raises(ValueError, match=r"theta must have shape \(8,\)"):
        validate_torques(log, robot, np.zeros(3))
    with pytest.raises(ValueError, match="cutoff_hz must be >= 1 Hz on this log"):
        validate_torques(log, robot, robot.base_values, cutoff_hz=0.05)


def test_results_files_of_another_model_are_refused(robot, tmp_path):
    document = {
        "parameters": [
            {"name": name, "value": float(value), "definition": dict(definition)}
            for name, value, definition in zip(
                robot.base.names, robot.base_values, robot.base.definitions, strict=True
            )
        ]
    }
    estimates = read_estimates(document, robot, "r.json")
    np.testing.assert_array_equal(estimates["fit"], robot.base_values)
    other = json.loads(json.dumps(document))
    other["parameters"][0]["definition"]["M2"] = 0.49  # L1 = 0.7 m
    with pytest.raises(ValueError, match="parameter ZZ1R is defined as"):
        check_parameters(robot, other["parameters"], "r.json")
    with pytest.raises(
        ValueError, match="differ at position 5: 'FC1' in the file, 'FV1' expected"
    ):
        check_parameters(
            robot, document["parameters"][:4] + document["parameters"][5:], "r.json"
        )
    other = json.loads(json.dumps(document))
    other["parameters"][2]["value"] = None
    with pytest.raises(ValueError, match="parameter MX2 has no finite value"):
        check_parameters(robot, other["parameters"], "r.json")
    iiwa = RobotModel.from_urdf(model_path("iiwa7"))
    with pytest.raises(ValueError, match=r"holds 8 base parameters but .*iiwa7.urdf"):
        read_estimates(document, iiwa, "r.json")
    # Found by a review: other joints (--joints, --lock) were not among the causes.
    with pytest.raises(ValueError, match=r"on other joints \(--joints, --lock\)"):
        read_estimates(document, iiwa, "r.json")
    # Found by a new user's walk-through (a Kinova fit validated on the UR5, 48
    # base parameters each): "holds 48 base parameters but ... has 48".
    swapped = document["parameters"][:4] + document["parameters"][5:4:-1]
    swapped += document["parameters"][4:5] + document["parameters"][6:]
    with pytest.raises(ValueError) as raised:
        check_parameters(robot, swapped, "r.json")
    text = str(raised.value)
    assert "holds" not in text, text
    assert text.startswith("r.json's 8 base parameters are not those of ")
    assert "they differ at position 5: 'FC1' in the file, 'FV1' expected" in text
    path = tmp_path / "broken.json"
    path.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_results(path)
    # Found by the same walk-through: excite's traj.json given as --params.
    path.write_text('{"joints": ["joint1"], "a": [], "b": []}')
    with pytest.raises(ValueError, match=r"written by dynid offline, identify or "):
        read_results(path)
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_results(tmp_path / "missing.json")


def _error(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_offline_fits_validates_and_writes(logs, tmp_path, capsys):
    fit_path, held_path = logs["fit"][0], logs["held"][0]
    out_json, out_csv, out_png = (
        tmp_path / "r.json",
        tmp_path / "e.csv",
        tmp_path / "t.png",
    )
    argv = ["offline", fit_path, "--urdf", URDF, "--validate", held_path, "--physical"]
    argv += ["--json", str(out_json), "--out", str(out_csv), "--plot", str(out_png)]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "physical check of the estimate: physically consistent" in out
    assert re.search(r"^physically consistent estimate \(Clarabel", out, re.M)
    assert f"validation on {held_path} (4001 samples)" in out
    assert re.search(r"^estimate: idim-ls$", out, re.M)
    assert re.search(r"^estimate: physical$", out, re.M)
    assert re.search(
        r"^joint\s+RMS τ\s+residual σ\s+error %\s+moving error %\s+R²\s+raw error %$",
        out,
        re.M,
    )
    document = json.loads(out_json.read_text())
    validation = document["validation"]
    assert set(validation["estimates"]) == {"idim-ls", "physical"}
    joints = validation["estimates"]["idim-ls"]["joints"]
    assert [j["name"] for j in joints] == ["joint1", "joint2"]
    assert all(j["relative_rms_percent"] < 2.0 for j in joints)
    assert document["physical_check"]["consistent"] is True
    assert document["physical"]["solver"] == "Clarabel"
    with open(out_csv, newline="") as stream:
        rows = list(csv.reader(stream))
    names = [p["name"] for p in document["parameters"]]
    assert rows[0] == ["t", "valid", *names, *(f"std_{n}" for n in names)]
    assert len(rows) == 2 and rows[1][:2] == ["4", "1"]
    assert float(rows[1][2]) == document["parameters"][0]["value"]
    assert float(rows[1][10]) == document["parameters"][0]["std"]
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # dynid validate on the same file reports the same numbers.
    out_val = tmp_path / "v.json"
    argv = ["validate", held_path, "--urdf", URDF, "--params", str(out_json)]
    assert cli.main([*argv, "--json", str(out_val), "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    again = json.loads(out_val.read_text())
    assert again["estimates"] == validation["estimates"]
    # --split: fit on 60 %, validate on the rest.
    argv = [
        "offline",
        fit_path,
        "--urdf",
        URDF,
        "--split",
        "0.6",
        "--json",
        str(out_json),
    ]
    assert cli.main([*argv, "--quiet"]) == 0
    document = json.loads(out_json.read_text())
    assert document["log"]["samples"] == 2401
    assert document["validation"]["log"]["samples"] == 1600
    assert document["validation"]["log"]["description"].endswith("after the first 60 %")


def test_identify_validates_its_final_estimate(logs, tmp_path, capsys):
    out_json = tmp_path / "i.json"
    argv = ["identify", logs["fit"][0], "--urdf", URDF, "--window", "2"]
    argv += ["--jacobi-window", "0.2"]  # its pass band holds the window's 4 Hz
    argv += ["--validate", logs["held"][0], "--json", str(out_json)]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert re.search(r"^estimate: lagrangian$", out, re.M)
    document = json.loads(out_json.read_text())
    joints = document["validation"]["estimates"]["lagrangian"]["joints"]
    assert all(j["relative_rms_percent"] < 3.0 for j in joints)
    assert document["physical_check"]["consistent"] is True


def test_bad_validation_input_exits_2(logs, tmp_path, capsys):
    fit_path, held_path = logs["fit"][0], logs["held"][0]
    result = tmp_path / "r.json"
    assert (
        cli.main(
            ["offline", fit_path, "--urdf", URDF, "--json", str(result), "--quiet"]
        )
        == 0
    )
    base = ["validate", held_path, "--urdf", URDF, "--params", str(result)]
    # Another robot's URDF, other friction columns, other definitions.
    assert cli.main([*base[:2], "--urdf", model_path("iiwa7"), *base[4:]]) == 2
    assert "holds 8 base parameters but" in _error(capsys)
    assert cli.main([*base, "--friction", "viscous"]) == 2
    assert "other --friction" in _error(capsys)
    document = json.loads(result.read_text())
    document["parameters"][0]["definition"] = {"ZZ1": 1.0, "M2": 0.49}
    other = tmp_path / "other.json"
    other.write_text(json.dumps(document))
    assert cli.main([*base[:4], "--params", str(other)]) == 2
    assert "parameter ZZ1R is defined as" in _error(capsys)
    # A log without the torque of joint 2.
    short = tmp_path / "short.csv"
    short.write_text("t,q_joint1,q_joint2,tau_joint1\n0,0,0,0\n0.001,0,0,0\n")
    assert cli.main(["validate", str(short), *base[2:]]) == 2
    assert "missing column(s) tau_joint2" in _error(capsys)
    # Outputs never overwrite inputs.
    assert cli.main([*base, "--json", held_path]) == 2
    assert "--json" in _error(capsys)
    argv = ["offline", fit_path, "--urdf", URDF, "--urdf-out", URDF]
    assert cli.main(argv) == 2
    assert "--urdf-out" in _error(capsys)
    argv = [
        "offline",
        fit_path,
        "--urdf",
        URDF,
        "--split",
        "0.5",
        "--validate",
        held_path,
    ]
    assert cli.main(argv) == 2
    assert "not both" in _error(capsys)
    assert cli.main(["offline", fit_path, "--urdf", URDF, "--split", "1.5"]) == 2
    assert "--split must be in (0, 1)" in _error(capsys)
    assert cli.main([*base[:4], "--params", str(tmp_path / "none.json")]) == 2
    assert "no such file" in _error(capsys)


@pytest.mark.parametrize("stored", [False, True])
def test_the_streamed_validation_is_the_whole_segment_chain(
    robot, tmp_path, monkeypatch, stored
):
    """validate_torques filters a block at a time (core.idim_stream, D = 1); it
    equals the chain on whole segments (offline_derivatives, W·θ, the parallel
    decimation's low-pass) to the blocks' 1e-12, and a long log's compared samples
    stay in temporary files."""
    from drake_dynid import log_store
    from drake_dynid.core import idim_stream
    from drake_dynid.core.blocks import is_stored
    from drake_dynid.core.idim import offline_derivatives, parallel_decimation
    from drake_dynid.logs import read_log

    log = _pinocchio_log(5, 4.0, noise=1.0)
    q = log.q.copy()
    q[2500:2510] = np.nan  # two segments
    path = tmp_path / "gappy.csv"
    write_log(path, log.t, q, log.tau, log.joint_names)
    theta = robot.base_values * 1.05
    if stored:  # every array on disk; the filters in blocks of 700 samples
        monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
        monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
        monkeypatch.setattr(idim_stream, "BLOCK_SAMPLES", 700)
    gappy = read_log(path, log.joint_names)
    assert is_stored(gappy.q) == stored
    result = validate_torques(gappy, robot, theta, cutoff_hz=6.0)
    assert is_stored(result.predicted) == stored
    settings = result.settings
    trim, padding = settings["trim"], settings["padding"]
    parts = {k: [] for k in ("t", "m", "p", "rm", "rp", "s")}
    q_all, tau_all = np.asarray(gappy.q), np.asarray(gappy.tau)
    for index, (start, stop) in enumerate(gappy.good_segments()):
        q_f, v, vdot = offline_derivatives(
            q_all[start:stop], H, cutoff_hz=6.0, trim=trim, padding=padding
        )
        predicted = robot.idim_rows(q_f, v, vdot) @ theta
        measured = tau_all[start + trim : stop - trim]
        smooth, smooth_measured = parallel_decimation(
            predicted[..., None],
            measured,
            1,
            cutoff=settings["decimation_cutoff_hz"] * H,
        )
        for key, value in zip(
            parts,
            (
                np.asarray(gappy.t)[start + trim : stop - trim],
                smooth_measured,
                smooth[..., 0],
                measured,
                predicted,
                np.full(measured.shape[0], index),
            ),
            strict=True,
        ):
            parts[key].append(value)
    whole = {k: np.concatenate(v) for k, v in parts.items()}
    scale = np.abs(whole["rm"]).max()
    np.testing.assert_array_equal(np.asarray(result.t), whole["t"])
    np.testing.assert_array_equal(np.asarray(result.segment), whole["s"])
    np.testing.assert_array_equal(np.asarray(result.raw_measured), whole["rm"])
    # The filtered torque to a few 1e-11 (core.iir's and scipy's round-off through
    # the narrow order-8 low-pass). The predictions hold v̇, a second difference
    # (1/h² = 1e6) of q_f, whose round-off differs by 1e-12 between the filters'
    # implementations: 1e-8 of the torques.
    for name, key, tolerance in (
        ("measured", "m", 1e-10),
        ("raw_predicted", "rp", 1e-7),
        ("predicted", "p", 1e-7),
    ):
        np.testing.assert_allclose(
            np.asarray(getattr(result, name)),
            whole[key],
            rtol=0,
            atol=tolerance * scale,
        )
    residual = whole["m"] - whole["p"]
    rms = np.sqrt(np.mean(whole["m"] ** 2, axis=0))
    np.testing.assert_allclose(
        result.relative_rms_percent,
        100 * np.sqrt(np.mean(residual**2, axis=0)) / rms,
        rtol=1e-6,
    )
    np.testing.assert_allclose(result.residual_std, residual.std(axis=0), rtol=1e-6)
    centred = whole["m"] - whole["m"].mean(axis=0)
    np.testing.assert_allclose(
        result.r_squared,
        1 - np.sum(residual**2, axis=0) / np.sum(centred**2, axis=0),
        rtol=1e-9,
    )
    raw = whole["rm"] - whole["rp"]
    np.testing.assert_allclose(
        result.raw_relative_rms_percent,
        100 * np.sqrt(np.sum(raw**2, axis=0) / np.sum(whole["rm"] ** 2, axis=0)),
        rtol=1e-6,
    )


def test_splitting_a_stored_log_keeps_it_on_disk(tmp_path, monkeypatch):
    from drake_dynid import log_store
    from drake_dynid.core.blocks import is_stored
    from drake_dynid.logs import read_log

    log = _pinocchio_log(4, 1.0)
    path = tmp_path / "log.csv"
    write_log(path, 1e9 + log.t, log.q, log.tau, log.joint_names)  # epoch seconds
    memory = read_log(path, log.joint_names)
    monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
    stored = read_log(path, log.joint_names)
    assert is_stored(stored.q) and stored.time_offset == memory.time_offset == 1e9
    for whole, parts in (
        (memory, split_log(memory, 0.3)),
        (stored, split_log(stored, 0.3)),
    ):
        assert [part.num_samples for part in parts] == [300, 701]
        for part, rows in zip(parts, (slice(0, 300), slice(300, None)), strict=True):
            assert is_stored(part.q) == (whole is stored)
            assert part.time_offset == 1e9 and part.filled.shape == (part.num_samples,)
            for name in ("t", "q", "tau"):
                np.testing.assert_array_equal(
                    np.asarray(getattr(part, name)),
                    np.asarray(getattr(memory, name))[rows],
                )


def test_several_estimates_are_validated_in_one_pass(robot):
    from drake_dynid.validation import validate_estimates

    log = _pinocchio_log(5, 3.0, noise=1.0)
    estimates = {"fit": robot.base_values * 1.02, "a-priori": robot.base_values}
    together = validate_estimates(log, robot, estimates, cutoff_hz=6.0)
    assert list(together) == ["fit", "a-priori"]
    assert together["fit"].measured is together["a-priori"].measured  # shared
    scale = np.abs(log.tau).max()
    for label, theta in estimates.items():
        alone = validate_torques(log, robot, theta, cutoff_hz=6.0)
        both = together[label]
        # W·[θ_1 θ_2] and W·θ differ in the last bit; the narrow low-pass filters
        # amplify that to about 1e-12 of the torques.
        for name in ("predicted", "raw_predicted"):
            np.testing.assert_allclose(
                getattr(both, name), getattr(alone, name), rtol=0, atol=1e-10 * scale
            )
        for name in ("relative_rms_percent", "r_squared", "residual_std"):
            np.testing.assert_allclose(
                getattr(both, name), getattr(alone, name), rtol=1e-7
            )
        # The measured torques are filtered beside different columns in the two
        # paths: equal to the last bits (bit for bit before numpy 2.4.6/scipy
        # 1.17.1), which the narrow low-pass amplifies as above.
        np.testing.assert_allclose(
            both.measured, alone.measured, rtol=0, atol=1e-10 * scale
        )
        assert both.settings == alone.settings
    # θ = 0 next to the truth: 100 % against ~0 %.
    pair = validate_estimates(
        log, robot, {"zero": np.zeros(robot.num_parameters), "true": robot.base_values}
    )
    np.testing.assert_allclose(pair["zero"].relative_rms_percent, 100.0)
    assert np.all(pair["true"].relative_rms_percent < 5.0)
    with pytest.raises(ValueError, match=r"theta 'bad' must have shape \(8,\)"):
        validate_estimates(log, robot, {"fit": robot.base_values, "bad": np.ones(3)})
    with pytest.raises(ValueError, match="at least one"):
        validate_estimates(log, robot, {})


def test_the_metrics_summed_by_blocks_equal_the_whole_arrays():
    from drake_dynid.validation import _Moments

    rng = np.random.default_rng(3)
    measured = 5.0 + rng.standard_normal((1000, 3))
    measured[:, 2] = 0.3  # a constant torque: R² undefined (NaN)
    predicted = measured + 0.01 * rng.standard_normal((1000, 3))
    raw_m, raw_p = measured + 0.1, predicted - 0.1
    moving = rng.random((1000, 3)) < 0.6
    moving[:, 1] = False  # a joint that never moves: no moving error (NaN)
    whole, blocks = _Moments(3, 1), _Moments(3, 1)  # one estimate
    whole.add(measured, predicted[..., None], raw_m, raw_p[..., None], moving)
    for a, b in ((0, 1), (1, 1), (1, 250), (250, 999), (999, 1000)):
        blocks.add(
            measured[a:b],
            predicted[a:b, :, None],
            raw_m[a:b],
            raw_p[a:b, :, None],
            moving[a:b],
        )
    residual = measured - predicted
    got = blocks.metrics(0)
    for j in (0, 2):  # over the moving samples only
        at = moving[:, j]
        expected = 100 * np.sqrt(
            np.sum(residual[at, j] ** 2) / np.sum(measured[at, j] ** 2)
        )
        np.testing.assert_allclose(got["moving_relative_rms_percent"][j], expected)
    assert np.isnan(got["moving_relative_rms_percent"][1])
    np.testing.assert_allclose(got["moving_fraction"], moving.mean(axis=0))
    expected = 100 * np.sqrt(
        np.sum(residual**2 * moving) / np.sum(measured**2 * moving)
    )
    np.testing.assert_allclose(got["total_moving_relative_rms_percent"], expected)
    np.testing.assert_allclose(got["residual_std"], residual.std(axis=0), rtol=1e-12)
    centred = np.sum((measured - measured.mean(axis=0)) ** 2, axis=0)[:2]
    np.testing.assert_allclose(
        got["r_squared"][:2], 1 - np.sum(residual**2, axis=0)[:2] / centred, rtol=1e-12
    )
    assert np.isnan(got["r_squared"][2]) and np.isnan(whole.metrics(0)["r_squared"][2])
    for key, value in whole.metrics(0).items():
        np.testing.assert_allclose(got[key], value, rtol=1e-12)


def test_a_held_out_part_too_short_is_refused_before_the_fit(logs, tmp_path, capsys):
    """Found by a review: --split 0.999 ran the whole fit (and wrote --out) before
    the validation found 30 samples for 103 needed."""
    log_path = logs["fit"][0]
    out = tmp_path / "fit.csv"
    argv = ["offline", log_path, "--urdf", URDF, "--split", "0.99", "--out", str(out)]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "is long enough" in err or "at least 64 are needed" in err, err
    assert "use a smaller --split" in err and not out.exists()


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("friction", ["viscous", "bogus"], "settings.friction"),
        ("locked", {"joint2": "abc"}, "settings.locked"),
        (
            "coulomb_dead_zone",
            {"joint1": "x", "joint2": 0.01},
            "settings.coulomb_dead_zone",
        ),
    ],
)
def test_a_bad_setting_of_the_results_file_is_named(
    logs, tmp_path, capsys, key, value, expected
):
    # A review: a hand-edited results file with a bad friction kind was reported
    # as "its joints and locks do not apply to the URDF ... Give --joints/--lock",
    # and a locked position "abc" as "could not convert string to float: 'abc'".
    fit_path, held_path = logs["fit"][0], logs["held"][0]
    result = tmp_path / "r.json"
    argv = ["offline", fit_path, "--urdf", URDF, "--json", str(result), "--quiet"]
    assert cli.main(argv) == 0
    document = json.loads(result.read_text())
    document["settings"][key] = value
    if key == "locked":
        document["settings"]["joints"] = ["joint1"]
    edited = tmp_path / "edited.json"
    edited.write_text(json.dumps(document))
    argv = ["validate", held_path, "--urdf", URDF, "--params", str(edited)]
    assert cli.main(argv) == 2
    line = _error(capsys)
    assert f"results file {edited}: {expected}" in line, line
    assert "Give --joints/--lock" not in line, line


def test_a_results_file_validates_on_the_urdf_it_wrote(tmp_path, capsys):
    # A review: the URDF written by --urdf-out fixes the joints the fit locked;
    # validating the fit's results file on it failed (exit 2: "locked joint
    # 'joint2' is not a movable joint ... leave it out of --lock. Give
    # --joints/--lock") although the user gave no --lock: the file's lock of a
    # joint the URDF fixes is already in the URDF.
    from drake_dynid.urdf_writer import write_identified_urdf

    robot = RobotModel.from_urdf(URDF, joints=("joint1",), locked={"joint2": 0.3})
    written = tmp_path / "identified.urdf"
    write_identified_urdf(robot, robot.standard_values, written)
    params = tmp_path / "p.json"
    argv = ["params", URDF, "--joints", "joint1", "--lock", "joint2=0.3"]
    assert cli.main([*argv, "--json", str(params)]) == 0
    trajectory = random_fourier_trajectory(
        1,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(6),
    )
    t = H * np.arange(4001)
    q, v, a = trajectory.evaluate(t)
    log = tmp_path / "log.csv"
    write_log(log, t, q, robot.idim_rows(q, v, a) @ robot.base_values, ("joint1",))
    capsys.readouterr()
    out = tmp_path / "v.json"
    argv = ["validate", str(log), "--urdf", str(written), "--params", str(params)]
    assert cli.main([*argv, "--json", str(out), "--quiet"]) == 0, _error(capsys)
    (joint,) = json.loads(out.read_text())["estimates"]["URDF a-priori"]["joints"]
    assert joint["relative_rms_percent"] < 0.1


def test_a_bad_lock_option_is_not_blamed_on_the_results_file(logs, tmp_path, capsys):
    # A review: validate --lock joint9=0 (a typo on the command line) said "results
    # file r.json: its joints and locks (settings.joints, settings.locked) do not
    # apply to the URDF ... Give --joints/--lock".
    fit_path, held_path = logs["fit"][0], logs["held"][0]
    result = tmp_path / "r.json"
    argv = ["offline", fit_path, "--urdf", URDF, "--json", str(result), "--quiet"]
    assert cli.main(argv) == 0
    argv = ["validate", held_path, "--urdf", URDF, "--params", str(result)]
    assert cli.main([*argv, "--lock", "joint9=0"]) == 2
    line = _error(capsys)
    assert "locked joint 'joint9' is not a movable joint" in line, line
    assert "settings.locked" not in line, line


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_urdf_that_cannot_be_written_keeps_the_other_outputs(logs, tmp_path, capsys):
    # A review: --urdf-out on a full disk (/dev/full) raised the OSError past the
    # writer's guard: the JSON was never written and the message ("[Errno 28] No
    # space left on device") did not name --urdf-out. The README: "If the file
    # cannot be written, the other outputs still are, then the command exits 2
    # naming why."
    fit_path = logs["fit"][0]
    result = tmp_path / "r.json"
    argv = ["offline", fit_path, "--urdf", URDF, "--quiet", "--json", str(result)]
    assert cli.main([*argv, "--urdf-out", "/dev/full"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    line = err.strip().splitlines()[-1]  # after the warning on unidentified ones
    assert "--urdf-out /dev/full was not written (the other outputs were)" in line
    document = json.loads(result.read_text())
    assert "urdf_error" in document["physical"]


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_json_that_cannot_be_written_is_named(logs, tmp_path, capsys):
    # A review: --json on a full disk said only "[Errno 28] No space left on
    # device", not which of the outputs failed.
    argv = ["offline", logs["fit"][0], "--urdf", URDF, "--quiet", "--json"]
    assert cli.main([*argv, "/dev/full"]) == 2
    assert "No space left on device: '/dev/full'" in _error(capsys)


def test_no_smaller_split_is_suggested_when_the_whole_log_is_too_short(
    logs, tmp_path, capsys
):
    """Found by a review: a TIAGo log read in the wrong time unit (h = 10 µs) was
    told 'use a smaller --split', which no split satisfies: the whole log is
    shorter than the cutoff's start-up. Here the log's stamps divided by 50
    (4001 samples at 20 µs: the automatic cutoff of at most 40 Hz drops 2501 at
    each end; a step under 10 µs is refused before, naming --time-unit)."""
    _, log = logs["fit"]
    fast = tmp_path / "fast.csv"
    write_log(fast, log.t / 50.0, log.q, log.tau, log.joint_names)
    argv = ["offline", str(fast), "--urdf", URDF, "--split", "0.5"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "use a smaller --split" not in err, err
    assert "the whole log is too short for it too" in err, err


def test_the_dead_zone_is_measured_on_the_fitted_part_of_a_split(tmp_path, capsys):
    """Found by a review: the Coulomb dead zone was measured on the whole log
    before ``--split``, so the held-out part shaped the model it then judged."""
    from drake_dynid.offline import standstill_widths
    from drake_dynid.validation import split_log

    log = _pinocchio_log(4, 6.0, noise=0.1)
    q = np.array(log.q)
    q[3700:] += 0.01 * np.random.default_rng(9).normal(size=q[3700:].shape)
    log = RobotLog(log.t, q, log.tau, log.joint_names, H)
    path = tmp_path / "log.csv"
    write_log(path, log.t, log.q, log.tau, log.joint_names)
    fitted = split_log(log, 0.6)[0]
    expected = standstill_widths(fitted)
    assert np.all(standstill_widths(log) > 2 * expected)  # the noisy end counts
    for command in ("offline", "identify"):
        out = tmp_path / f"{command}.json"
        argv = [command, str(path), "--urdf", URDF, "--split", "0.6"]
        argv += ["--json", str(out), "--quiet"]
        if command == "identify":
            argv += ["--window", "2", "--jacobi-window", "0.2", "--bootstrap", "0"]
        assert cli.main(argv) == 0, capsys.readouterr().err
        widths = json.loads(out.read_text())["settings"]["coulomb_dead_zone"]
        np.testing.assert_allclose(list(widths.values()), expected, rtol=1e-6)


def test_a_results_files_joints_and_locks_read_the_urdf_once(monkeypatch):
    """A review: results_robot parsed the URDF three times (its mimic joints, its
    joint types, and the types again when the file's joints and locks did not
    apply); one parse gives both, whatever the path taken."""
    import argparse

    from drake_dynid import urdf
    from drake_dynid.commands import _arguments, _results

    parses = []
    real = urdf.parse_urdf_xml

    def counted(file):
        parses.append(file)
        return real(file)

    def robot_from_args(args, command, **options):
        if "locked" in options:  # the file's joints and locks do not apply
            raise ValueError("joint 'nope' is not a joint of the URDF.")
        return "robot"

    monkeypatch.setattr(urdf, "parse_urdf_xml", counted)
    monkeypatch.setattr(_arguments, "robot_from_args", robot_from_args)
    args = argparse.Namespace(
        urdf=model_path("planar_2r"),
        params="results.json",
        joints=None,
        lock=None,
        friction=None,
        rotor_inertia=False,
        coulomb_width=0.0,
        drive=None,
    )
    document = {"settings": {"joints": ["joint1"], "locked": {"nope": 0.5}}}
    assert _results.results_robot(args, document) == "robot"
    assert len(parses) == 1
    parses.clear()
    document = {"settings": {"joints": ["joint1"], "locked": {"joint2": 0.5}}}
    with pytest.raises(ValueError, match="do not apply to"):
        _results.results_robot(args, document)
    assert len(parses) == 1


def test_the_validation_predicts_a_dead_zones_reversals_as_the_fit_models_them():
    """The fit restores the sign at a moving joint's reversals through the dead
    zone (core.standstill.reversal_signs); the validation predicted 0 there: the
    noise-free 2R log (Drake's inverse dynamics, sign(v) friction) with its true
    parameters and a 3 mrad/s zone gave 0.0087 % error on joint 2 (raw 0.32 %)
    against 0.0014 % (0.010 %) with the exact sign. Now the same."""
    from _drake_dynamics import exact_paper_2r

    from drake_dynid.core.friction import DeadZoneSign

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = exact_paper_2r(robot)
    log = RobotLog(t, q, tau, robot.joint_names, H)
    # A 3 mrad/s zone is a noisy log's, filtered well below 30 Hz: at this
    # noise-free log's automatic 34.8 Hz a reversal may take at most 3 samples
    # (core.standstill.reversal_run), fewer than its slowest spends in the zone.
    exact = validate_torques(log, robot, robot.base_values, cutoff_hz=28.25)
    zoned = validate_torques(
        log,
        robot.with_sign(DeadZoneSign((0.003, 0.003))),
        robot.base_values,
        cutoff_hz=28.25,
    )
    np.testing.assert_allclose(
        zoned.relative_rms_percent, exact.relative_rms_percent, rtol=1e-6
    )
    np.testing.assert_allclose(
        zoned.raw_relative_rms_percent, exact.raw_relative_rms_percent, rtol=1e-6
    )


def test_another_robots_results_with_a_drive_file_are_named_as_such(
    logs, tmp_path, capsys
):
    """Found by a review: the TIAGo's results (fitted with its drive file) given to
    `validate`/`payload` on another URDF failed as "drive file tiago.toml:
    motors.torso_lift_motor.joint: unknown joint 'torso_lift_joint'", though no
    drive file was given: the file's drive file, its own robot's, was loaded on the
    other robot. It is left out with the file's joints; the parameter check names
    the mismatch."""
    from drake_dynid.plants import MODELS_DIR

    fit_path, held_path = logs["fit"][0], logs["held"][0]
    result = tmp_path / "r.json"
    argv = ["offline", fit_path, "--urdf", URDF, "--json", str(result), "--quiet"]
    assert cli.main(argv) == 0
    document = json.loads(result.read_text())
    document["parameters"][0]["name"] = "M1R"  # the TIAGo's first base parameter
    document["settings"]["joints"] = ["torso_lift_joint", "arm_1_joint"]
    document["settings"]["drive"] = str(MODELS_DIR / "tiago.toml")
    edited = tmp_path / "tiago_like.json"
    edited.write_text(json.dumps(document))
    for command in ("validate", "payload"):
        argv = [command, held_path, "--urdf", URDF, "--params", str(edited)]
        assert cli.main(argv) == 2
        line = _error(capsys)
        assert "'M1R' in the file" in line and "another robot" in line, line
        assert "drive file" not in line, line


@pytest.mark.parametrize("command", ["offline", "identify"])
def test_compare_urdf_without_held_out_data_is_named(logs, command, capsys):
    """Found by a review: `dynid offline LOG --urdf U --compare-urdf` (no --split,
    no --validate) printed no comparison and said nothing."""
    argv = [command, logs["fit"][0], "--urdf", URDF, "--compare-urdf", "--quiet"]
    assert cli.main(argv) == 2
    line = _error(capsys)
    assert "--compare-urdf predicts held-out torques" in line, line
    assert "--validate LOG2 or --split FRACTION" in line, line


def test_a_physical_estimate_worse_than_the_fit_is_named():
    """Found by a review: on the TIAGo (whose torso effort leaves gravity out) the
    physical estimate predicted the held-out torques at 20.8 % against the fit's
    14.5 % (torso 185 % against 35.5 %), and nothing said so."""

    from drake_dynid.commands.validate import physical_worse

    def result(per_joint, total):
        return types.SimpleNamespace(
            joint_names=("torso", "arm_1"),
            relative_rms_percent=np.array(per_joint),
            total_relative_rms_percent=total,
        )

    fit = result([35.5, 23.6], 14.5)
    worse = physical_worse(
        {"idim-ls": fit, "physical": result([185.0, 24.0], 20.8), "URDF a-priori": fit}
    )
    assert worse.startswith("the physical estimate predicts the held-out torques")
    assert "20.8 % against 14.5 %" in worse and "torso 185 % against 35.5 %" in worse
    assert "arm_1" not in worse
    assert (
        physical_worse({"idim-ls": fit, "physical": result([36.0, 24.0], 15.0)}) is None
    )
    assert physical_worse({"idim-ls": fit}) is None
    # Found by a review: the total had no floor, the joints 1 point: on a clean log
    # 0.07 % against 0.05 % said "prefer the fit's estimate" and named no joint.
    clean = result([0.06, 0.04], 0.05)
    assert (
        physical_worse({"idim-ls": clean, "physical": result([0.09, 0.05], 0.07)})
        is None
    )


def test_the_moving_error_leaves_out_the_torque_static_friction_holds(robot):
    """A joint at rest is held by static friction at a torque no model here
    predicts (the real TIAGo's efforts drift at rest). The 2R (Pinocchio's inverse
    dynamics + viscous and sign(v) friction, the true parameters) moves for 4 s
    and rests 2 s with 0.3 N·m held beyond gravity: the error over every sample
    counts the hold, the moving error only the motion."""
    from drake_dynid.core.friction import DeadZoneSign

    model = pin.buildModelFromUrdf(URDF)
    data = model.createData()
    t = H * np.arange(6001)
    period, w = 2.0, 2 * np.pi / 2.0
    inside = t < 2 * period  # (1 - cos)²: v and v̇ reach 0 at the rest
    c, s = np.cos(w * t), np.sin(w * t)
    amplitude = np.array([0.6, -0.8])
    q = np.where(inside, 1.0, 0.0)[:, None] * amplitude * (1 - c[:, None]) ** 2
    v = np.where(inside, 1.0, 0.0)[:, None] * amplitude * (2 * w * (1 - c) * s)[:, None]
    a = (
        np.where(inside, 1.0, 0.0)[:, None]
        * amplitude
        * (2 * w**2 * (s**2 + (1 - c) * c))[:, None]
    )
    config = np.stack([np.cos(q), np.sin(q)], axis=-1).reshape(t.size, -1)
    tau = np.array(
        [pin.rnea(model, data, config[k], v[k], a[k]) for k in range(t.size)]
    )
    tau += FV * v + FC * np.sign(v)
    tau[~inside] += 0.3  # held by static friction
    rng = np.random.default_rng(0)
    log = RobotLog(
        t, q + 1e-6 * rng.standard_normal(q.shape), tau, robot.joint_names, H
    )
    result = validate_torques(log, robot, robot.base_values)
    assert result.moving_rule == "measured"
    moving = result.moving_relative_rms_percent
    assert np.all(moving < 0.5), moving
    assert np.all(result.relative_rms_percent > 8 * moving), result.relative_rms_percent
    assert result.total_moving_relative_rms_percent < 0.5
    assert np.all(np.abs(result.moving_fraction - 2 / 3) < 0.04), result.moving_fraction
    # The fit's dead zone is the moving threshold when the robot has one.
    zoned = validate_torques(
        log, robot.with_sign(DeadZoneSign((0.01, 0.02))), robot.base_values
    )
    assert zoned.moving_rule == "dead zone"
    np.testing.assert_array_equal(zoned.moving_widths, [0.01, 0.02])
    assert np.all(zoned.moving_relative_rms_percent < 0.5)


def test_a_joint_whose_position_never_changes_never_moves(robot):
    """A frozen encoder (q_j constant on the whole log): the standstill width
    measured on it is round-off (3.1e-14 rad/s on the iiwa7's joint 7), and the
    round-off velocities of its filtered constant passed it on 3 % of the
    samples, which counted as moving (`100.00 (3 %)`, and in the all-joint
    moving error). README: 'nan (0 %) for a joint that never moves'."""
    log = _pinocchio_log(5, 4.0, noise=1.0)
    q = np.array(log.q)
    q[:, 1] = 0.07  # joint 2's encoder frozen (its torque as recorded)
    frozen = RobotLog(log.t, q, log.tau, log.joint_names, H)
    result = validate_torques(frozen, robot, robot.base_values)
    assert result.moving_rule == "measured"
    assert result.moving_fraction[1] == 0.0 and np.isinf(result.moving_widths[1])
    assert np.isnan(result.moving_relative_rms_percent[1])
    assert np.isfinite(result.moving_widths[0]) and result.moving_fraction[0] > 0.3
    assert np.isfinite(result.moving_relative_rms_percent[0])


def test_a_log_too_short_to_measure_the_standstill_keeps_the_validations_message(
    robot,
):
    """The standstill widths need longer segments than the validation: a log the
    validation refuses keeps its own message (not the width measure's), and one
    it accepts but too short for the measure gets NaN moving errors ("none")."""
    t = H * np.arange(120)
    q = np.column_stack([np.sin(3 * t), np.cos(2 * t)])
    log = RobotLog(t, q, np.ones((120, 2)), robot.joint_names, H)
    result = validate_torques(log, robot, robot.base_values)
    assert result.moving_rule == "none"
    assert np.all(np.isnan(result.moving_relative_rms_percent))
    short = RobotLog(t[:40], q[:40], np.ones((40, 2)), robot.joint_names, H)
    # (Too short for the automatic cutoff's spectrum: 64 samples are needed.)
    with pytest.raises(ValueError, match="validate_torques: the longest finite"):
        validate_torques(short, robot, robot.base_values)


def test_validate_does_not_call_its_log_held_out(monkeypatch, capsys):
    """Found by a new user's pass: ``dynid validate`` of the fitted log itself said
    the physical estimate 'predicts the held-out torques worse'."""
    from drake_dynid.commands import validate as command

    def result(total):
        return types.SimpleNamespace(
            joint_names=("j",),
            relative_rms_percent=np.array([total]),
            total_relative_rms_percent=total,
        )

    found = {"idim-ls": result(1.0), "physical": result(30.0)}
    monkeypatch.setattr(command, "run_validations", lambda *a, **k: found)
    monkeypatch.setattr(command, "validation_document", lambda *a: {})
    for name, words in (
        ("validate", "predicts the torques of the validated log worse"),
        ("offline", "predicts the held-out torques worse"),
    ):
        args = types.SimpleNamespace(command=name, quiet=True, plot=None)
        command.report_validation(args, None, None, "log.csv", {})
        assert words in capsys.readouterr().err


def test_validating_the_fitted_log_says_the_errors_are_in_sample(
    logs, tmp_path, capsys, monkeypatch
):
    """Found by a new user's walk-through: `dynid validate` of the log the results
    file was fitted on (the TIAGo's two files after `offline --split 0.6`) printed
    its errors as a validation (all joints 10.3 % against 14.5 % held out), while
    `offline --validate` refuses that log."""
    fit_path, held_path = logs["fit"][0], logs["held"][0]
    folder = os.path.dirname(fit_path)
    monkeypatch.chdir(folder)  # the results file records the log as given
    results = tmp_path / "r.json"
    argv = ["offline", "fit.csv", "--urdf", URDF, "--split", "0.6"]
    assert cli.main([*argv, "--json", str(results), "--quiet"]) == 0
    capsys.readouterr()
    argv = ["validate", fit_path, "--urdf", URDF, "--params", str(results), "--quiet"]
    assert cli.main(argv) == 0
    err = capsys.readouterr().err
    assert re.search(
        rf"^dynid validate: note: {re.escape(fit_path)} is the log these "
        r"parameters were fitted on \(its first 2401 of 4001 samples\): the errors "
        r"are in-sample there, not a prediction of another recording\.$",
        err,
        re.M,
    ), err
    argv = ["validate", held_path, "--urdf", URDF, "--params", str(results), "--quiet"]
    assert cli.main(argv) == 0
    assert "in-sample" not in capsys.readouterr().err
    # A fit.csv beside the results file too, another file: which of the two was
    # fitted is not known (the fit may have run in either folder): no note.
    shutil.copyfile(held_path, tmp_path / "fit.csv")
    argv = ["validate", fit_path, "--urdf", URDF, "--params", str(results), "--quiet"]
    assert cli.main(argv) == 0
    assert "in-sample" not in capsys.readouterr().err
