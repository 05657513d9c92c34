"""Bad option values (issue 14): checked before any allocation, in the user's words.

Logs: the paper's 2R arm on a random Fourier reference (numpy default_rng(4)),
torques from the library's inverse dynamic model plus white noise from
default_rng(1) (these checks never reach the identification: no Drake
simulation needed). Every refused value: exit 2, one line naming the option, its
constraint and value, no internal name, and a small peak allocation (tracemalloc).
"""

import dataclasses
import math
import re
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import write_log
from drake_dynid.plants import RobotModel, model_path

URDF = model_path("planar_2r")
INTERNAL = ("OnlineSettings", "fourier_bank", "jacobi_filters", "identify_offline")
INTERNAL += ("Maximum allowed size", "estimate_bandwidth", "Traceback")


def _write(path, rate, duration, noise_q, noise_tau):
    robot = RobotModel.from_urdf(URDF)
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.25,
        max_velocity=2.0,
        rng=np.random.default_rng(4),
    )
    t = np.arange(round(duration * rate) + 1) / rate
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    rng = np.random.default_rng(1)
    q = q + rng.normal(0.0, noise_q, q.shape)
    tau = tau + rng.normal(0.0, noise_tau, tau.shape)
    write_log(path, t, q, tau, robot.joint_names)
    return str(path)


@pytest.fixture(scope="module")
def log_file(tmp_path_factory):
    # 30 s at 1 kHz, positions with 5 mrad of noise (as SNR ~40 dB).
    path = tmp_path_factory.mktemp("options") / "robot.csv"
    return _write(path, 1000.0, 30.0, 5e-3, 0.05)


def _refused(argv, capsys, budget=64e6):
    tracemalloc.start()
    try:
        code = cli.main(argv)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert not any(word in err for word in INTERNAL), err
    assert peak < budget, f"{peak / 1e6:.0f} MB allocated before refusing: {err}"
    return lines[0]


IDENTIFY_CASES = [
    # (options, the option named, a word of the constraint)
    (["--window", "1e6"], "--window", "at most 500 modulating functions"),
    (["--bandwidth", "1e5"], "--bandwidth", "at most 500 modulating functions"),
    (["--frequencies", "0:1e-7:100"], "--frequencies", "at most 500 indices"),
    (["--frequencies", "0:1:inf"], "--frequencies", "finite start >= 0"),
    (["--frequencies", "0,0,1"], "--frequencies", "must not repeat"),
    (["--frequencies", "nan"], "--frequencies", "finite indices"),
    (["--bandwidth", "1e308"], "--bandwidth", "at most 500"),
    (["--bandwidth", "-1"], "--bandwidth", "must be > 0 [Hz]"),
    (["--window", "5", "--bandwidth", "20"], "--bandwidth", "pass band"),
    (
        ["--window", "2", "--jacobi-window", "0.2", "--bandwidth", "100"],
        "--bandwidth",
        "Nyquist",
    ),
    (["--jacobi-q", "1000"], "--jacobi-q", "integer in [0, 10]"),
    (["--kappa", "1e6"], "--kappa", "(-1, 100]"),
    (["--mu", "-1"], "--mu", "(-1, 100]"),
    (["--kappa", "nan"], "--kappa", "finite"),
    (["--window", "0.02"], "--jacobi-window", "< --window"),
    (["--window", "2", "--jacobi-window", "3"], "--jacobi-window", "< --window"),
    (["--window", "2"], "--jacobi-window", "pass band"),
    (["--window", "40"], "--window", "lasts 30 s"),
    (["--window", "inf"], "--window", "finite"),
    (["--jacobi-window", "1e-9"], "--jacobi-window", ">= 10 signal periods"),
    (
        ["--jacobi-window", "1e5", "--window", "1e6", "--bandwidth", "1e-4"],
        "--window",
        "lasts",
    ),
    (["--bank-time-step", "1e-9"], "--bank-time-step", "multiple of the signal"),
    (["--update-period", "1e9"], "--update-period", "<= 1e+06 [s]"),
    (["--update-period", "20"], "--update-period", "leave a solve"),
    (["--max-condition", "1e300"], "--max-condition", "(1, 1e+08]"),
    (["--friction", ",,"], "--friction", "empty name"),
    (["--friction", "viscous,"], "--friction", "empty name"),
    # A review: "" (an unset shell variable) meant the default viscous,coulomb.
    (["--friction", ""], "--friction", "got an empty text"),
]


@pytest.mark.parametrize(("options", "option", "constraint"), IDENTIFY_CASES)
def test_identify_refuses_bad_values_before_any_allocation(
    log_file, capsys, options, option, constraint
):
    line = _refused(["identify", log_file, "--urdf", URDF, *options], capsys)
    assert option in line and constraint in line, line
    assert re.search(r"got |lasts ", line), line


OFFLINE_CASES = [
    (["--cutoff", "1e-320"], "--cutoff", "must be >= 0.133 Hz on this log"),
    (["--cutoff", "0.01"], "--cutoff", "must be >= 0.133 Hz on this log"),
    (["--cutoff", "499.9"], "--cutoff", "errors in variables"),
    (["--cutoff", "nan"], "--cutoff", "(0, 500) [Hz]"),
    (["--cutoff", "600"], "--cutoff", "(0, 500) [Hz]"),
    (["--decimation-cutoff", "1e-300"], "--decimation-cutoff", ">= 0.133 Hz"),
    (["--decimation", "100000"], "--decimation", "more equations than"),
    (["--decimation", "0"], "--decimation", ">= 1"),
]


@pytest.mark.parametrize(("options", "option", "constraint"), OFFLINE_CASES)
def test_offline_refuses_bad_values_before_any_allocation(
    log_file, capsys, options, option, constraint
):
    line = _refused(["offline", log_file, "--urdf", URDF, *options], capsys)
    assert option in line and constraint in line, line


def test_a_cutoff_below_the_noise_limit_is_accepted_and_honest(log_file, capsys):
    # The noise-limited cutoff of this log (5 mrad noise) is about 25 Hz: 10 Hz is
    # accepted and every estimate is within 4 σ of the model's values.
    import json

    out = log_file.replace("robot.csv", "fit10.json")
    argv = ["offline", log_file, "--urdf", URDF, "--cutoff", "10", "--json", out]
    assert cli.main([*argv, "--quiet"]) == 0
    robot = RobotModel.from_urdf(URDF)
    document = json.loads(Path(out).read_text())
    for entry, truth in zip(document["parameters"], robot.base_values, strict=True):
        assert abs(entry["value"] - truth) < 4 * entry["std"], entry


@pytest.mark.parametrize(("rate", "duration"), [(125.0, 30.0), (909.0, 30.0)])
def test_defaults_accept_125_hz_and_909_hz_logs(tmp_path, capsys, rate, duration):
    path = _write(tmp_path / "log.csv", rate, duration, 5e-3, 0.05)
    assert cli.main(["identify", path, "--urdf", URDF, "--quiet"]) == 0
    assert cli.main(["offline", path, "--urdf", URDF, "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_a_20_hz_log_names_only_options_the_user_can_set(tmp_path, capsys):
    path = _write(tmp_path / "log.csv", 20.0, 60.0, 5e-3, 0.05)
    line = _refused(["identify", path, "--urdf", URDF], capsys)
    assert "--jacobi-window must be >= 10 signal periods (0.5 s)" in line


def test_huge_log_values_are_refused_with_their_units(tmp_path, capsys):
    from drake_dynid.logs import read_log

    log = read_log(
        _write(tmp_path / "a.csv", 1000.0, 25.0, 5e-3, 0.05), ("joint1", "joint2")
    )
    path = tmp_path / "scaled.csv"
    write_log(path, log.t, log.q, log.tau * 1e160, log.joint_names)
    for command in ("identify", "offline"):
        line = _refused([command, str(path), "--urdf", URDF], capsys)
        assert "|tau| must be <= 1e+100 [N·m or N]" in line and "units" in line
    # Found by a review: validate printed inf and nan errors and exited 0, and a
    # drive file's position offset of 1e300 reached the dead zone first (an error
    # about DeadZoneSign's width).
    params = tmp_path / "p.json"
    assert cli.main(["params", URDF, "--json", str(params)]) == 0
    argv = ["validate", str(path), "--urdf", URDF, "--params", str(params)]
    line = _refused(argv, capsys)
    assert f"log {path}: |tau| must be <= 1e+100" in line
    drive = tmp_path / "d.toml"
    drive.write_text(
        "[log.position_offset]\njoint1 = 1e300\n[motors.a]\n"
        'joints = { joint1 = 1, joint2 = 1 }\n[motors.b]\njoint = "joint2"\n'
    )
    argv = ["offline", str(tmp_path / "a.csv"), "--urdf", URDF, "--drive", str(drive)]
    assert cli.main(argv) == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "|q| must be <= 1e+100 [rad or m]" in line


def test_online_settings_refuse_huge_values_at_once():
    # OnlineSettings(bandwidth=1e6) used to try 38 GiB; now a message, no work.
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"window x bandwidth must give at most"):
            OnlineSettings(bandwidth=1e6)
        with pytest.raises(
            ValueError, match=r"jacobi_q must be an integer in \[0, 10\]"
        ):
            OnlineSettings(jacobi_q=1000)
        with pytest.raises(ValueError, match=r"kappa must be in \(-1, 100\]"):
            OnlineSettings(kappa=1e6)
        with pytest.raises(ValueError, match=r"frequencies must hold at most 500"):
            OnlineSettings(frequencies=np.arange(501.0))
        with pytest.raises(ValueError, match=r"jacobi_window must be < window"):
            OnlineSettings(window=2.0, jacobi_window=3.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 1e6


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"window": "20"}, TypeError, "window must be a real number"),
        ({"window": True}, TypeError, "window must be a real number"),
        ({"model": ["power"]}, ValueError, "model must be one of"),
        ({"jacobi_q": 1.5}, TypeError, "jacobi_q must be an integer"),
        ({"frequencies": 3.0}, TypeError, "frequencies must be None, 'paper'"),
        ({"frequencies": ["a", "b"]}, TypeError, "frequencies must be None"),
        ({"frequencies": [[0.0, 1.0]]}, ValueError, "non-empty list of reals"),
        ({"frequencies": [0.0, math.inf]}, ValueError, "finite indices"),
        ({"weighting": None}, ValueError, "weighting must be one of"),
        ({"max_condition": 1.0}, ValueError, r"max_condition must be in \(1, 1e\+08\]"),
        ({"order": 9}, ValueError, r"order must be an integer in \[1, 8\]"),
        ({"bank_time_step": -0.02}, ValueError, "bank_time_step must be > 0"),
    ],
)
def test_online_settings_types_and_ranges(kwargs, error, match):
    with pytest.raises(error, match=match):
        OnlineSettings(**kwargs)


def test_for_log_checks_against_the_log_with_the_names_given():
    settings = OnlineSettings(window=2.0, jacobi_window=0.2, bandwidth=100.0)
    with pytest.raises(
        ValueError, match=r"OnlineSettings: bandwidth must keep .*Nyquist"
    ):
        settings.for_log(1e-3, 30.0)
    names = {"bandwidth": "--bandwidth", "bank_time_step": "--bank-time-step"}
    with pytest.raises(ValueError, match=r"^--bandwidth must keep .*--bank-time-step"):
        settings.for_log(1e-3, 30.0, owner=None, names=names)
    with pytest.raises(ValueError, match=r"the log lasts 10 s"):
        OnlineSettings().for_log(1e-3, 10.0)
    # Too few independent rows for an honest σ with 40 parameters: the power
    # model has one equation per function; the message says how many are needed.
    power = OnlineSettings(
        model="power", window=2.0, jacobi_window=0.05, frequencies=[0, 1, 2]
    )
    with pytest.raises(
        ValueError,
        match=r"gives 6 independent rows \(3 modulating functions x 2 rows x 1 "
        r"equation of the power model\) for 40 parameters; an honest σ needs at "
        r"least 44: use at least 22 integer ℓ \(frequencies 0:1:21, up to 11 Hz",
    ):
        power.for_log(1e-3, 30.0, num_joints=6, num_parameters=40)
    # The default set is given twice the rows needed (core.ell_rule), up to the
    # pass band of the differentiator.
    power = OnlineSettings(model="power", window=2.0, jacobi_window=0.05)
    grid = power.for_log(1e-3, 30.0, num_joints=6, num_parameters=40)
    assert grid.min_functions == 44 and len(grid.ell()) == 44
    grid = OnlineSettings().for_log(1e-3, 30.0, num_joints=2, num_parameters=8)
    assert grid == dataclasses.replace(OnlineSettings().on_grid(1e-3), min_functions=8)


@pytest.mark.parametrize(
    ("rate", "kwargs"),
    [
        (1000.0, {}),
        (1000.0, {"rows_from": "raw", "update_period": 0.25}),
        (125.0, {}),
    ],
)
def test_the_shortest_accepted_log_records_a_valid_estimate(rate, kwargs):
    # A log that ends before the first full window's estimate is recorded (at the
    # solve after the one that sees it full) is refused with its length. It used
    # to pass (longer than window + jacobi window) and then fail on "no window
    # gave a valid estimate ... not all excited" (a review, 20.45 s with T = 20 s).
    from drake_dynid.core.replay import replay_log_core
    from drake_dynid.logs import RobotLog

    robot = RobotModel.from_urdf(URDF)
    h = 1.0 / rate
    settings = OnlineSettings(window=4.0, jacobi_window=0.2, bandwidth=1.0, **kwargs)
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.25,
        max_velocity=2.0,
        rng=np.random.default_rng(4),
    )

    def replay(count):
        t = h * np.arange(count)
        q, v, vdot = trajectory.evaluate(t)
        tau = robot.idim_rows(q, v, vdot) @ robot.base_values
        tau += np.random.default_rng(1).normal(0.0, 0.05, tau.shape)
        log = RobotLog(t, q, tau, robot.joint_names, h)
        (trace,) = replay_log_core(log, robot, [settings.for_log(h, log.duration)])
        return trace

    trace = replay(round(6.0 / h))
    first = round(trace.t[np.flatnonzero(trace.valid)[0]] / h)  # recorded there
    with pytest.raises(ValueError, match=r"must leave a solve of a full window"):
        settings.for_log(h, (first - 2) * h)  # `first - 1` samples: no record
    trace = replay(first)
    assert trace.valid[-1] == 1.0 and not trace.valid[:-1].any()


@pytest.fixture(scope="module")
def trajectory_file(tmp_path_factory):
    # A 1 s rest trajectory of the 2R arm at 100 Hz (t, q_*, v_*, a_* columns).
    path = tmp_path_factory.mktemp("traj") / "traj.csv"
    t = np.arange(101) * 0.01
    zeros = np.zeros(t.size)
    columns = [t] + [zeros] * 6
    header = "t,q_joint1,q_joint2,v_joint1,v_joint2,a_joint1,a_joint2"
    np.savetxt(
        path,
        np.column_stack(columns),
        delimiter=",",
        header=header,
        comments="",
        fmt="%.6g",
    )
    return str(path)


EXCITE_CASES = [
    (["--duration", "1e9"], "--duration must be <= 100000 [s]"),
    # A review: 1e6 s was accepted, and its coefficient JSON refused by simulate.
    (["--duration", "2e5"], "--duration must be <= 100000 [s]"),
    (["--harmonics", "1000000"], "--harmonics must be <= 50"),
    (["--sample-rate", "1e12"], "--sample-rate x --duration must give at most 1e+07"),
    (["--log-rate", "nan"], "--log-rate must be finite and > 0 [Hz]"),
    (["--online-window", "1e9"], "--online-window must be <= 1e+06 [s]"),
    (["--online-window", "100"], "--online-window must be <= --duration 60 s"),
]


@pytest.mark.parametrize(("options", "message"), EXCITE_CASES)
def test_excite_refuses_bad_values_before_the_design(
    tmp_path, capsys, options, message
):
    out = str(tmp_path / "traj.csv")
    line = _refused(["excite", URDF, "--out", out, *options], capsys)
    assert message in line, line


SIMULATE_CASES = [
    (["--time-step", "1e-12", "--rate", "1e12"], "at most 1e+07 simulation steps"),
    (["--snr=-1e308"], "--snr must be in [0, 400] [dB]"),
    (["--noise-q", "1e300"], "--noise-q must be below the motion"),
    (["--rate", "333"], "--rate must divide 1/--time-step = 1000 Hz"),
]


@pytest.mark.parametrize(("options", "message"), SIMULATE_CASES)
def test_simulate_refuses_bad_values_before_simulating(
    tmp_path, capsys, trajectory_file, options, message
):
    argv = ["simulate", URDF, "--trajectory", trajectory_file]
    argv += ["--out", str(tmp_path / "sim.csv"), *options]
    line = _refused(argv, capsys)
    assert message in line, line
