"""``dynid identify`` and ``dynid offline`` on a simulated 2R log; bad input -> 2."""

import csv
import json
import re
import subprocess
import sys

import numpy as np
import pytest
from _cli import error_line

from drake_dynid import cli, paper
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import SimulationSettings, simulate_identification
from drake_dynid.logs import write_log
from drake_dynid.plants import RobotModel, model_path

URDF = model_path("planar_2r")
TRUTH = dict(zip(paper.BASE_NAMES, paper.TRUE_VALUES, strict=True))
# A 2 s window on a 3 s log: short Jacobi window and the integer ℓ set 0..7.
FAST = [
    "--window",
    "2",
    "--jacobi-window",
    "0.05",
    "--bank-time-step",
    "0.005",
    "--update-period",
    "0.05",
    "--frequencies",
    "0:1:7",
]


@pytest.fixture(scope="module")
def simulation():
    robot = RobotModel.from_urdf(URDF)
    # Seed 4: period 2 s, 3 harmonics, |v| <= 3 rad/s; noise-free, 3 s at 1 kHz.
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )
    result = simulate_identification(
        robot, trajectory, SimulationSettings(duration=3.0, snr_db=None), []
    )
    return result


@pytest.fixture(scope="module")
def log_file(simulation, tmp_path_factory):
    path = tmp_path_factory.mktemp("logs") / "robot.csv"
    write_log(path, simulation.t, simulation.q, simulation.tau, simulation.joint_names)
    return str(path)


def _table(out):
    """name -> (value, %σ) from the estimates table."""
    rows = {}
    for line in out.splitlines():
        match = re.match(r"^(\w+)\s+(-?[\d.e+-]+)\s+([\d.e+-]+)\s+([\d.]+|inf)", line)
        if match and match.group(1) in TRUTH:
            rows[match.group(1)] = (float(match.group(2)), float(match.group(4)))
    return rows


def test_identify_prints_the_table_and_writes_csv_json_png(log_file, tmp_path, capsys):
    out_csv = tmp_path / "estimates.csv"
    out_json = tmp_path / "result.json"
    out_png = tmp_path / "estimates.png"
    argv = ["identify", log_file, "--urdf", URDF, *FAST]
    argv += ["--out", str(out_csv), "--json", str(out_json), "--plot", str(out_png)]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # no warnings, no progress (not a terminal)
    out = captured.out
    assert re.search(r"^name\s+value\s+σ\s+%σ$", out, flags=re.M)
    assert "model: lagrangian; window: 2 s; 8 modulating functions" in out
    assert "rows: raw (raw velocity noise" in out  # a noise-free log: raw rows
    assert re.search(r"^condition number: [\d.]+$", out, flags=re.M)
    assert "final window: valid" in out
    table = _table(out)
    assert list(table) == list(TRUTH)
    for name, (value, percent) in table.items():
        assert abs(value - TRUTH[name]) < 0.03 * TRUTH[name], (name, value)
        assert percent < 30.0
    # CSV: exactly t,valid,<names>,std_<names>, one row per solve (every 0.05 s)
    # from t = 0 to 3 s and the final one at t = N·h = 3.001 s (the solve at the
    # last sample, t = 3 s: before, it ran but no row showed it); empty cells
    # before the first valid estimate.
    with open(out_csv, newline="") as stream:
        rows = list(csv.reader(stream))
    assert rows[0] == ["t", "valid", *TRUTH, *(f"std_{name}" for name in TRUTH)]
    assert len(rows) - 1 == 62 and [row[0] for row in rows[-2:]] == ["3", "3.001"]
    assert rows[1][:2] == ["0", "0"] and rows[-1][1] == "1"
    assert rows[1][2:] == [""] * 16
    first = next(k for k, row in enumerate(rows[1:], 1) if row[1] == "1")
    assert all(cell != "" for cell in rows[first][2:])
    assert all(row[2:] == [""] * 16 for row in rows[1:first])
    assert float(rows[-1][2]) == pytest.approx(table["ZZ1R"][0], rel=1e-5)
    assert float(rows[-1][10]) > 0.0  # σ of ZZ1R
    # JSON: the keys of the README (JSON (--json)), σ and definitions.
    document = json.loads(out_json.read_text())
    for key in ("parameters", "condition_number", "window", "model", "settings"):
        assert key in document
    assert document["model"] == "lagrangian" and document["window"] == 2.0
    assert document["valid"] is True
    first = document["parameters"][0]
    assert first["name"] == "ZZ1R" and first["definition"] == {"ZZ1": 1.0, "M2": 1.0}
    assert first["std"] > 0 and abs(first["value"] - 3.9) < 0.03 * 3.9
    settings = document["settings"]
    assert settings["frequencies"] == [float(i) for i in range(8)]
    assert settings["jacobi_window"] == 0.05 and settings["update_period"] == 0.05
    assert settings["bank_time_step"] == 0.005
    assert settings["rows_from"] == "raw" and settings["rows_from_measured"] is True
    assert settings["raw_window"] == pytest.approx(0.046)  # fits the 0.05 s ring
    assert 0.0 <= settings["raw_noise_ratio"] < 1e-3
    # Unset options echo the OnlineSettings defaults.
    from drake_dynid.diagrams import OnlineSettings

    defaults = OnlineSettings()
    assert settings["kappa"] == defaults.kappa
    assert settings["mu"] == defaults.mu
    assert settings["max_condition"] == defaults.max_condition
    assert settings["weighting"] == defaults.weighting == "frequency"
    assert settings["friction"] == ["viscous", "coulomb"]
    log = document["log"]
    assert log["samples"] == 3001 and log["time_step"] == pytest.approx(1e-3)
    assert log["warnings"] == [] and log["path"] == log_file
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_identify_quiet_power_model(log_file, tmp_path, capsys):
    out_json = tmp_path / "power.json"
    argv = ["identify", log_file, "--urdf", URDF, *FAST[:6], "--model", "power"]
    argv += ["--frequencies", "0:0.25:7", "--json", str(out_json), "--quiet"]
    argv += ["--weighting", "none"]
    assert cli.main(argv) == 0
    assert capsys.readouterr().out == ""
    document = json.loads(out_json.read_text())
    assert document["model"] == "power"
    assert document["settings"]["weighting"] == "none"
    values = {p["name"]: p["value"] for p in document["parameters"]}
    for name in ("ZZ1R", "ZZ2", "MX2", "MY2"):
        assert abs(values[name] - TRUTH[name]) < 0.05 * TRUTH[name], name


def test_identify_reports_an_invalid_final_window(simulation, tmp_path, capsys):
    # 0.3 s of dropped samples (NaN rows) at the end of the log.
    t = np.append(simulation.t, simulation.t[-1] + 1e-3 * np.arange(1, 301))
    pad = np.full((300, 2), np.nan)
    path = tmp_path / "gap.csv"
    q = np.vstack([simulation.q, pad])
    tau = np.vstack([simulation.tau, pad])
    write_log(path, t, q, tau, simulation.joint_names)
    assert cli.main(["identify", str(path), "--urdf", URDF, *FAST]) == 0
    captured = capsys.readouterr()
    assert "warning: log" in captured.err and "300 sample(s)" in captured.err
    assert "final window: INVALID" in captured.out
    assert "contains bad (NaN) samples" in captured.out
    assert "the estimates above are the last valid ones" in captured.out
    table = _table(captured.out)
    assert abs(table["ZZ1R"][0] - 3.9) < 0.03 * 3.9


def test_identify_without_any_valid_window_exits_2(tmp_path, capsys):
    # The robot at rest: nothing is excited.
    t = 1e-3 * np.arange(2500)
    zeros = np.zeros((t.size, 2))
    path = tmp_path / "rest.csv"
    write_log(path, t, zeros + 0.3, zeros, ("joint1", "joint2"))
    assert cli.main(["identify", str(path), "--urdf", URDF, *FAST]) == 2
    err = capsys.readouterr().err
    assert "no window of the log gave a valid estimate" in err
    assert "more exciting trajectory" in err
    warning, error = err.strip().splitlines()  # the log's constant columns, said
    assert "q_joint1 = 0.3, q_joint2 = 0.3 never change" in warning
    assert "tau_joint1 = 0, tau_joint2 = 0 never change" in warning
    assert "Traceback" not in err and error.startswith("dynid identify: error: ")


def test_a_lagrangian_joint_without_noise_of_its_own_is_refused(log_file, capsys):
    # Found by a review: --position-noise 0,1e-4 --torque-noise 0 left joint 1's
    # rows with the coupling's noise only, a nearly singular covariance (on a
    # 4-joint arm every window ill-conditioned, the message blaming excitation).
    args = ["identify", log_file, "--urdf", URDF, *FAST, "--weighting", "covariance"]
    args += ["--position-noise", "0,1e-4", "--torque-noise", "0"]
    assert cli.main(args) == 2
    line = error_line(capsys)
    assert "joint(s) 1 have --position-noise 0 and --torque-noise 0" in line
    assert "nearly singular" in line and "--weighting 'frequency'" in line


def test_no_valid_window_with_the_covariance_weighting_names_the_noise(
    tmp_path, capsys
):
    t = 1e-3 * np.arange(2500)
    zeros = np.zeros((t.size, 2))
    path = tmp_path / "rest.csv"
    write_log(path, t, zeros + 0.3, zeros, ("joint1", "joint2"))
    args = ["identify", str(path), "--urdf", URDF, *FAST, "--weighting", "covariance"]
    args += ["--position-noise", "1e-4", "--torque-noise", "0.01"]
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert "no window of the log gave a valid estimate" in err
    assert "stds near 0 on some joints (--position-noise, --torque-noise)" in err


def test_the_covariance_weighting_says_it_does_not_use_the_bandwidth(
    log_file, tmp_path, capsys
):
    # Found by a review: its default ℓ set is every integer ℓ within the pass band;
    # --bandwidth 0.5 was ignored without a word, and a --bandwidth whose power
    # band 2B is above the pass band refused the run for a set it does not choose.
    fast = [*FAST[:-2], "--model", "power", "--quiet"]  # the default ℓ set
    documents = []
    for band in ([], ["--bandwidth", "0.5"], ["--bandwidth", "20"]):
        out = tmp_path / f"{len(documents)}.json"
        args = ["identify", log_file, "--urdf", URDF, *fast, *band, "--json", str(out)]
        assert cli.main(args) == 0
        err = capsys.readouterr().err
        assert ("--bandwidth" in err and "is not used" in err) == bool(band)
        documents.append(json.loads(out.read_text()))
    assert all(d["settings"]["weighting"] == "covariance" for d in documents)
    values = [[p["value"] for p in d["parameters"]] for d in documents]
    assert values[1] == values[0] and values[2] == values[0]


def test_no_valid_window_with_near_silent_joints_leads_with_the_noise():
    """Found by a review: --position-noise 1e-12,1e-4 --torque-noise 0 (near 0,
    not 0: past the up-front check) made every window invalid on a 4-joint arm,
    and the message began by blaming excitation. It now names the joints."""
    import types

    from drake_dynid.commands.identify import (
        near_silent_joints,
        no_valid_window_message,
    )
    from drake_dynid.core.online import OnlineSettings

    robot = RobotModel.from_urdf(URDF)
    trace = types.SimpleNamespace(
        condition_number=np.array([np.inf, 4e7]), t=np.zeros(2), names=("a",) * 8
    )
    log = types.SimpleNamespace(q=np.zeros((10, 2)), t=np.arange(10) * 1e-3)
    quiet = OnlineSettings(
        weighting="covariance", position_noise=(1e-12, 1e-4), torque_noise=0.0
    )
    assert near_silent_joints(quiet, 2) == [0]
    message = no_valid_window_message(trace, quiet, robot, log)
    assert "with --weighting covariance, joint1 have --position-noise" in message
    assert "not all excited" not in message and "best condition number 4e+07" in message
    loud = OnlineSettings(
        weighting="covariance", position_noise=(1e-5, 1e-4), torque_noise=1e-2
    )
    assert near_silent_joints(loud, 2) == []
    assert near_silent_joints(OnlineSettings(), 2) == []  # frequency weighting


def test_offline_prints_the_table_and_writes_json(log_file, tmp_path, capsys):
    out_json = tmp_path / "offline.json"
    argv = ["offline", log_file, "--urdf", URDF, "--weighted", "--json", str(out_json)]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert re.search(r"^model: idim-wls; cutoff [\d.]+ Hz \(auto\)", out, flags=re.M)
    assert "samples used" in out and "of 3001 in 1 of 1 segment(s)" in out
    table = _table(out)
    assert list(table) == list(TRUTH)
    for name, (value, percent) in table.items():
        # Within 1 % or 3 σ (FV1: about 1 % off at %σ 0.5-1, depending on the
        # dead zone measured on the log).
        tolerance = max(0.01, 0.03 * percent) * TRUTH[name]
        assert abs(value - TRUTH[name]) < tolerance, (name, value, percent)
    document = json.loads(out_json.read_text())
    assert document["model"] == "idim-wls" and document["valid"] is True
    assert document["window"] == pytest.approx(3.0)
    assert document["settings"]["cutoff_rule"] == "auto"
    assert document["settings"]["weighted"] is True
    assert document["samples_used"] < 3001
    assert [p["name"] for p in document["parameters"]] == list(TRUTH)
    assert document["parameters"][0]["definition"] == {"ZZ1": 1.0, "M2": 1.0}
    # The fit's covariance (dynid payload --params propagates it): σ² on its
    # diagonal, symmetric, a correlation within [-1, 1].
    covariance = np.array(document["covariance"])
    std = np.array([p["std"] for p in document["parameters"]])
    np.testing.assert_allclose(np.diag(covariance), std**2, rtol=1e-9)
    np.testing.assert_allclose(covariance, covariance.T, rtol=1e-12)
    assert (np.abs(covariance / np.outer(std, std)) <= 1.0 + 1e-9).all()
    assert np.linalg.eigvalsh(covariance).min() > 0.0
    # Given cutoff and decimation are echoed.
    argv = ["offline", log_file, "--urdf", URDF, "--cutoff", "20", "--decimation"]
    argv += ["20", "--json", str(out_json), "--quiet"]
    assert cli.main(argv) == 0
    assert capsys.readouterr().out == ""
    settings = json.loads(out_json.read_text())["settings"]
    assert settings["cutoff_hz"] == 20.0 and settings["decimation"] == 20
    assert settings["cutoff_rule"] == "given"
    # D given: the automatic decimation low-pass stays below 0.8 x its Nyquist.
    assert settings["decimation_cutoff_rule"] == "auto"
    assert settings["decimation_cutoff_hz"] <= 0.4 / (20 * 1e-3)
    argv = ["offline", log_file, "--urdf", URDF, "--decimation-cutoff", "2.5"]
    argv += ["--json", str(out_json), "--quiet"]
    assert cli.main(argv) == 0
    settings = json.loads(out_json.read_text())["settings"]
    assert settings["decimation_cutoff_hz"] == 2.5
    assert settings["decimation_cutoff_rule"] == "given"
    # floor(0.25 · 1000 Hz / 2.5 Hz) = 100, rounded down to a multiple of D1 (the
    # rigid-body columns are evaluated every D1-th sample).
    assert settings["decimation"] <= 100
    assert settings["decimation"] % settings["regressor_decimation"] == 0
    assert settings["decimation"] > 100 - settings["regressor_decimation"]


def _error(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.mark.parametrize("command", ["identify", "offline"])
def test_bad_files_exit_2_with_one_line(command, log_file, tmp_path, capsys):
    missing = str(tmp_path / "missing.csv")
    assert cli.main([command, missing, "--urdf", URDF]) == 2
    assert "no such file" in _error(capsys)
    malformed = tmp_path / "malformed.csv"
    malformed.write_text("t,q_joint1,q_joint2,tau_joint1\n0,0,0,0\n0.001,0,0,0\n")
    assert cli.main([command, str(malformed), "--urdf", URDF]) == 2
    assert "missing column(s) tau_joint2" in _error(capsys)
    assert cli.main([command, log_file, "--urdf", str(tmp_path / "none.urdf")]) == 2
    assert "URDF file not found" in _error(capsys)
    bad_urdf = tmp_path / "bad.urdf"
    bad_urdf.write_text('<robot name="r"><link name="a"></robot>')
    assert cli.main([command, log_file, "--urdf", str(bad_urdf)]) == 2
    assert "not well-formed XML" in _error(capsys)
    assert cli.main([command, log_file, "--urdf", URDF, "--friction", "dry"]) == 2
    assert "friction kinds must be among" in _error(capsys)


def test_identify_bad_options_exit_2(log_file, capsys):
    base = ["identify", log_file, "--urdf", URDF]
    # The 3 s log is shorter than window + Jacobi window.
    assert cli.main([*base, "--window", "5"]) == 2
    message = _error(capsys)
    assert "lasts 3 s" in message and "shorten --window" in message
    # With --split, the fitted part is what is too short: the message said 'log
    # LOG lasts 1.499 s' of this 3 s log ('--split 0.3' of the iiwa7's 60 s log:
    # 'lasts 17.999 s').
    assert cli.main([*base, "--window", "2", "--split", "0.5"]) == 2
    message = _error(capsys)
    assert "its first 50 % (--split 0.5) lasts 1.499 s" in message
    assert "raise --split" in message
    assert cli.main([*base, "--window", "-1"]) == 2
    assert "window must be > 0" in _error(capsys)
    assert cli.main([*base, *FAST[2:], "--window", "2", "--frequencies", "a,b"]) == 2
    assert "--frequencies must be" in _error(capsys)
    # An empty item is refused, not dropped (a review: "1,,2" ran with ℓ = 1, 2).
    assert cli.main([*base, *FAST[2:], "--window", "2", "--frequencies", "1,,2"]) == 2
    assert "--frequencies must be" in (message := _error(capsys))
    assert "(an empty item)" in message
    for bad in (["--model", "energy"], ["--window", "long"]):
        with pytest.raises(SystemExit) as exit_info:
            cli.main([*base, *bad])
        assert exit_info.value.code == 2
        assert "invalid" in capsys.readouterr().err


def test_offline_bad_options_exit_2(log_file, capsys):
    base = ["offline", log_file, "--urdf", URDF]
    assert cli.main([*base, "--cutoff", "600"]) == 2
    assert "--cutoff must be in (0, 500) [Hz]" in _error(capsys)
    assert cli.main([*base, "--decimation", "0"]) == 2
    assert "--decimation must be >= 1" in _error(capsys)
    assert cli.main([*base, "--decimation-cutoff", "-1"]) == 2
    assert "--decimation-cutoff must be in (0, 500) [Hz]" in _error(capsys)
    assert cli.main([*base, "--cutoff", "0.5"]) == 2
    assert "--cutoff must be >= 1.33 Hz on this log" in _error(capsys)
    # The fitted part of --split is named, not the log ('log LOG: the longest
    # finite segment has 3 samples' of a 3001-sample log).
    assert cli.main([*base, "--split", "0.001"]) == 2
    message = _error(capsys)
    assert "robot.csv, its first 0.1 % (--split 0.001): the longest finite" in message


def test_installed_entry_point_runs_offline(log_file, tmp_path):
    out_json = tmp_path / "entry.json"
    argv = [sys.executable, "-m", "drake_dynid.cli", "offline", log_file]
    argv += ["--urdf", URDF, "--json", str(out_json)]
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    assert "ZZ1R" in done.stdout and "condition number" in done.stdout
    assert json.loads(out_json.read_text())["model"] == "idim-ls"
    missing = [sys.executable, "-m", "drake_dynid.cli", "identify", "nope.csv"]
    done = subprocess.run(
        [*missing, "--urdf", URDF], capture_output=True, text=True, check=False
    )
    assert done.returncode == 2
    assert done.stderr.startswith("dynid identify: error: log nope.csv: no such file")


def test_a_closed_stdout_drops_the_printout_not_the_run(log_file, tmp_path):
    """``dynid offline ... | head``: the reader has gone away (here before the
    first line, so that every write meets the closed pipe); the command still
    runs to its end and writes its JSON, with no error."""
    import os

    out_json = tmp_path / "piped.json"
    argv = [sys.executable, "-m", "drake_dynid.cli", "offline", log_file]
    argv += ["--urdf", URDF, "--json", str(out_json)]
    read, write = os.pipe()
    os.close(read)
    try:
        done = subprocess.run(argv, stdout=write, stderr=subprocess.PIPE, check=False)
    finally:
        os.close(write)
    assert done.returncode == 0, done.stderr.decode()
    assert done.stderr == b""
    assert json.loads(out_json.read_text())["model"] == "idim-ls"


def _run_dynid(argv, **streams):
    import os

    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    command = [sys.executable, "-m", "drake_dynid.cli", *argv]
    return subprocess.run(command, check=False, env=env, **streams)


def test_no_stdout_and_a_full_disk(log_file, tmp_path):
    """``>&-`` (no standard output: Python's sys.stdout is None) runs as before;
    a standard output that cannot be written (``> /dev/full``) is one line on
    stderr and exit 2, not a traceback; a closed stderr (``2>&1 | head``) loses
    the message, not the exit code."""
    import os

    out_json = tmp_path / "none.json"
    argv = ["offline", log_file, "--urdf", URDF, "--json", str(out_json)]
    done = _run_dynid(argv, stderr=subprocess.PIPE, preexec_fn=lambda: os.close(1))
    assert done.returncode == 0, done.stderr.decode()
    assert json.loads(out_json.read_text())["model"] == "idim-ls"
    if os.path.exists("/dev/full"):
        with open("/dev/full", "w") as full:
            done = _run_dynid(argv, stdout=full, stderr=subprocess.PIPE)
        assert done.returncode == 2
        assert done.stderr.decode().splitlines()[-1].startswith("dynid")
        assert "No space left on device" in done.stderr.decode()
        assert "Traceback" not in done.stderr.decode()
    read, write = os.pipe()
    os.close(read)
    try:
        bad = ["offline", str(tmp_path / "missing.csv"), "--urdf", URDF]
        done = _run_dynid(bad, stdout=write, stderr=write)
    finally:
        os.close(write)
    assert done.returncode == 2


def test_identify_engines_agree(log_file, tmp_path):
    # The default engine (vectorised core) and the Drake blocks give the same JSON.
    import json

    documents = []
    for engine in ("core", "blocks"):
        out = tmp_path / f"{engine}.json"
        args = ["identify", str(log_file), "--urdf", model_path("planar_2r")]
        args += ["--window", "2", "--jacobi-window", "0.1", "--quiet"]
        args += ["--engine", engine, "--json", str(out)]
        assert cli.main(args) == 0
        documents.append(json.loads(out.read_text()))
    core, blocks = documents
    assert (
        core["settings"]["engine"] == "core"
        and blocks["settings"]["engine"] == "blocks"
    )
    for mine, reference in zip(core["parameters"], blocks["parameters"], strict=True):
        assert mine["value"] == pytest.approx(reference["value"], rel=1e-9, abs=1e-12)
    assert core["valid"] == blocks["valid"]


def test_identify_measures_the_excitation_band_unless_given(log_file, tmp_path):
    import json

    from drake_dynid.commands.identify import measured_bandwidth
    from drake_dynid.logs import read_log
    from drake_dynid.plants import RobotModel

    log = read_log(log_file, RobotModel.from_urdf(URDF).joint_names)
    band = measured_bandwidth(log, 2.0)
    assert 0.3 < band < 3.0
    # A NaN burst does not stop the measurement (longest finite run).
    q = log.q.copy()
    q[100:110] = np.nan
    gappy = type(log)(log.t, q, log.tau, log.joint_names, log.time_step)
    assert measured_bandwidth(gappy, 2.0) == pytest.approx(band, rel=0.3)
    out = tmp_path / "band.json"
    base = ["identify", str(log_file), "--urdf", URDF, "--window", "2", "--quiet"]
    base += ["--jacobi-window", "0.1"]  # its pass band holds the 8 functions' 4 Hz
    assert cli.main([*base, "--json", str(out)]) == 0
    settings = json.loads(out.read_text())["settings"]
    assert settings["bandwidth_measured"] is True
    assert settings["bandwidth"] == pytest.approx(max(band, 1.0), rel=1e-9)
    assert cli.main([*base, "--bandwidth", "1.5", "--json", str(out)]) == 0
    settings = json.loads(out.read_text())["settings"]
    assert settings["bandwidth_measured"] is False and settings["bandwidth"] == 1.5


def test_measured_bandwidth_of_a_log_without_finite_samples_is_a_clear_error():
    from drake_dynid.commands.identify import measured_bandwidth
    from drake_dynid.logs import RobotLog

    nan = np.full((100, 2), np.nan)
    log = RobotLog(np.arange(100) * 1e-3, nan, nan, ("joint1", "joint2"), 1e-3)
    with pytest.raises(ValueError, match="no run of 64 finite samples"):
        measured_bandwidth(log, 2.0)


def test_identify_reports_the_larger_of_the_window_and_bootstrap_sigma(
    simulation, tmp_path, capsys
):
    """σ of the final estimate = max(the window's σ, the parametric bootstrap's);
    ``--bootstrap 0`` reports the window's σ alone (the last row of ``--out``)."""
    noisy = tmp_path / "noisy.csv"
    rng = np.random.default_rng(2)
    q = simulation.q + 1e-3 * rng.standard_normal(simulation.q.shape)
    tau = simulation.tau + 0.02 * rng.standard_normal(simulation.tau.shape)
    write_log(noisy, simulation.t, q, tau, simulation.joint_names)
    documents, window_std = {}, {}
    for replicates in ("0", "8"):
        out_json, out_csv = tmp_path / f"b{replicates}.json", tmp_path / "e.csv"
        argv = ["identify", str(noisy), "--urdf", URDF, *FAST, "--quiet"]
        argv += ["--bootstrap", replicates, "--json", str(out_json)]
        # A fixed dead zone: with it the bootstrap's σ is the larger for some
        # parameters (checked below), whatever width the log would measure.
        argv += ["--dead-zone", "0.01"]
        assert cli.main([*argv, "--out", str(out_csv)]) == 0
        documents[replicates] = json.loads(out_json.read_text())
        with open(out_csv, newline="") as stream:
            last = list(csv.reader(stream))[-1]
        window_std[replicates] = np.array([float(x) for x in last[2 + 8 :]])
    off, on = documents["0"]["bootstrap"], documents["8"]["bootstrap"]
    assert off["applied"] is False and off["reason"] == "--bootstrap 0"
    assert on["applied"] is True and on["valid_replicates"] == 8
    rows_from = documents["8"]["settings"]["rows_from"]  # raw: first-order replicates
    assert on["method"] == {"raw": "linearized", "filtered": "exact"}[rows_from]
    assert off["method"] is None
    np.testing.assert_allclose(on["position_noise"], 1e-3, rtol=0.1)
    np.testing.assert_array_equal(window_std["0"], window_std["8"])  # the on-line σ
    reported = {
        key: np.array([p["std"] for p in document["parameters"]])
        for key, document in documents.items()
    }
    np.testing.assert_allclose(reported["0"], window_std["0"], rtol=1e-12)
    expected = np.fmax(window_std["0"], on["std"])
    np.testing.assert_allclose(reported["8"], expected, rtol=1e-12)
    assert np.any(np.asarray(on["std"]) > window_std["0"])  # it mattered here
    assert cli.main(["identify", str(noisy), "--urdf", URDF, "--bootstrap", "1"]) == 2
    assert "--bootstrap must be 0 (no bootstrap) or" in capsys.readouterr().err


def test_final_bootstrap_skips_a_window_that_is_not_full(simulation):
    """A final estimate whose window is not a full sliding window (as a detected
    change can leave it) gets the window's σ and the reason, never an error."""
    from types import SimpleNamespace

    from drake_dynid.commands.identify import final_bootstrap
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.logs import RobotLog

    robot = RobotModel.from_urdf(URDF)
    log = RobotLog(
        simulation.t, simulation.q, simulation.tau, simulation.joint_names, 1e-3
    )
    settings = OnlineSettings(window=2.0, bandwidth=2.0).on_grid(1e-3)
    trace = SimpleNamespace(theta=np.ones((20, 8)), std=np.ones((20, 8)))
    out = final_bootstrap(4, log, robot, settings, trace, 3)  # end = 0.2 s
    assert out["applied"] is False and out["std"] is None
    assert "is not full" in out["reason"] and "no bootstrap" in out["line"]


def test_the_bootstrap_beside_the_replay_gives_the_same_result(
    simulation, tmp_path, monkeypatch
):
    """By default the final window's bootstrap runs in a forked child beside the
    replay (2+ CPUs); ``--parallel off`` computes it here: the same JSON."""
    from drake_dynid.commands import identify
    from drake_dynid.commands._background import Background, can_fork

    forked = []

    class Spy(Background):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            forked.append(self.forked)

    monkeypatch.setattr(identify, "Background", Spy)
    noisy = tmp_path / "noisy.csv"
    rng = np.random.default_rng(3)
    q = simulation.q + 1e-3 * rng.standard_normal(simulation.q.shape)
    write_log(noisy, simulation.t, q, simulation.tau, simulation.joint_names)
    documents = []
    for extra in ([], ["--parallel", "off"]):
        out = tmp_path / f"b{len(extra)}.json"
        argv = ["identify", str(noisy), "--urdf", URDF, *FAST, "--quiet"]
        assert cli.main([*argv, "--bootstrap", "4", "--json", str(out), *extra]) == 0
        documents.append(json.loads(out.read_text()))
    assert forked == [can_fork(), False]
    assert documents[0]["bootstrap"]["applied"] is True
    assert documents[0] == documents[1]


def test_a_final_solve_that_is_not_valid_gets_its_own_window_bootstrap(simulation):
    """The window computed beside the replay is the last solve's: when the
    estimate comes from an earlier solve, that child's work is dropped and the
    estimate's own window is bootstrapped (here: not full, so skipped)."""
    from types import SimpleNamespace

    from drake_dynid.commands._background import Background
    from drake_dynid.commands.identify import _final_bootstrap
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.logs import RobotLog

    robot = RobotModel.from_urdf(URDF)
    log = RobotLog(
        simulation.t, simulation.q, simulation.tau, simulation.joint_names, 1e-3
    )
    settings = OnlineSettings(window=2.0, bandwidth=2.0).on_grid(1e-3)
    valid = np.zeros(20)
    valid[3] = 1.0  # only the estimate logged at index 3 (end = 0.2 s)

    def not_wanted() -> dict:
        raise AssertionError("the last solve's window was not the estimate's")

    trace = SimpleNamespace(theta=np.ones((20, 8)), std=np.ones((20, 8)), valid=valid)
    background = Background(not_wanted, enabled=False)
    out, beside = _final_bootstrap(
        4, log, robot, settings, trace, valid > 0.5, background, 19
    )
    assert out["applied"] is False and "is not full" in out["reason"]
    assert beside is None  # nor its covariance
    none = np.zeros(20, bool)
    assert _final_bootstrap(4, log, robot, settings, trace, none, background, 19) == (
        {},
        None,
    )


def test_the_readme_json_example_has_the_keys_identify_writes(log_file, tmp_path):
    """The README's JSON block names every key identify writes at the top level and
    in settings, and no key it does not write (a review found it drifted)."""
    import pathlib

    out = tmp_path / "id.json"
    argv = ["identify", log_file, "--urdf", URDF, *FAST, "--json", str(out)]
    assert cli.main([*argv, "--quiet"]) == 0
    document = json.loads(out.read_text())
    readme = (pathlib.Path(__file__).resolve().parents[1] / "README.md").read_text()
    block = readme.split("### JSON (`--json`)", 1)[1].split("```json\n", 1)[1]
    block = block.split("```", 1)[0]
    shown = set(re.findall(r'"(\w+)":', block))
    written = set(document) | set(document["settings"]) | set(document["bootstrap"])
    written |= set(document["log"]) | set(document["physical_check"])
    written |= set(document["parameters"][0]) | set(document["log"])
    written |= set(document["parameters"][0]["definition"])
    written |= set(document["settings"]["coulomb_dead_zone"])
    top = set(document) | set(document["settings"])
    assert top <= shown, sorted(top - shown)
    assert shown <= written, sorted(shown - written)


def test_the_position_noise_spectrum_is_measured_once_per_log(log_file, monkeypatch):
    """The dead zone's white floor, the rows' choice and the excitation band
    read the same periodogram of the same run: ``RobotLog.on_longest_run``
    computes it once (``motion_noise_band``). Found by a profile: the velocity
    band (``measured_velocity_band``) took a second periodogram of the run,
    0.05 s of a 7-DOF 60 s log's 1.5 s."""
    import drake_dynid.core.excitation as excitation

    calls = []
    measure = excitation._periodogram

    def counted(q, time_step):
        calls.append(np.shape(q))
        return measure(q, time_step)

    monkeypatch.setattr(excitation, "_periodogram", counted)
    argv = ["identify", log_file, "--urdf", URDF, *FAST, "--quiet", "--bootstrap", "0"]
    assert cli.main([*argv, "--parallel", "off"]) == 0
    assert len(calls) == 1, calls


def test_a_dead_zone_wider_than_every_speed_is_named(log_file, capsys):
    """Found by a review: --dead-zone 1e300 zeroes every Coulomb column, and the
    error named unexcited FCj without the option that did it."""
    for command in ("offline", "identify"):
        argv = [command, log_file, "--urdf", URDF, "--dead-zone", "1e300"]
        if command == "identify":
            argv += FAST
        assert cli.main(argv) == 2
        err = capsys.readouterr().err
        assert "The Coulomb dead zone is wider than every speed of joint1" in err, err
        assert "give a smaller --dead-zone, or none." in err
    # A dead zone that leaves the columns alone is not blamed.
    argv = ["offline", log_file, "--urdf", URDF, "--dead-zone", "0.01"]
    assert cli.main([*argv, "--friction", "viscous,coulomb", "--quiet"]) == 0


def test_a_terminal_without_unicode_gets_escapes_not_an_error(log_file, tmp_path):
    """Found by a review: on a terminal that cannot encode σ or × (a C locale,
    PYTHONIOENCODING=ascii) the first such character of a report stopped the
    command ('ascii' codec can't encode character '\\u03c3', exit 2)."""
    import io
    import os

    from drake_dynid.cli import _ClosableStream

    raw = io.BytesIO()
    stream = _ClosableStream(io.TextIOWrapper(raw, encoding="ascii"))
    assert stream.write("σ = 2 × h\n") == len("σ = 2 × h\n")
    stream.flush()
    assert raw.getvalue() == b"\\u03c3 = 2 \\xd7 h\n"
    env = {**os.environ, "PYTHONIOENCODING": "ascii"}
    argv = [sys.executable, "-m", "drake_dynid.cli", "offline", log_file]
    done = subprocess.run(
        [*argv, "--urdf", URDF], capture_output=True, env=env, check=False
    )
    assert done.returncode == 0, done.stderr.decode()
    assert b"\\u03c3" in done.stdout  # the table's σ column
