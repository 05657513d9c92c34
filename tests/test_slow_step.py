"""A fitted time step >= 0.5 s (``log_repair.SLOW_STEP``): stamps in ms, µs or ns
read as seconds. An error naming the step, its rate and the likely unit, unless
the time unit was given (``--time-unit``, a drive file's ``[log] time_unit``,
``read_log``'s ``time_unit``): then a warning (a log truly sampled at 1 Hz).

Found by a new user's walk-through: ``dynid offline ms.csv`` of a 1 kHz log in ms
only warned and gave ZZ2R = 570050 at %σ 3.59, exit 0.
"""

import json
import re

import numpy as np
import pytest
from _cli import error_line
from _motions import fourier_2r

from drake_dynid import cli
from drake_dynid.logs import read_log, write_log
from drake_dynid.plants import model_path

URDF = model_path("planar_2r")
SAID = "the time step is 1 s (1 Hz), long for a robot log"


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """The same 1 kHz log, 6 s, stamped in s and in ms; a fit of the first."""
    folder = tmp_path_factory.mktemp("slow")
    robot, t, q, tau = fourier_2r(6001)
    write_log(folder / "s.csv", t, q, tau, robot.joint_names)
    write_log(folder / "ms.csv", 1e3 * t, q, tau, robot.joint_names)
    params = folder / "fit.json"
    argv = ["offline", str(folder / "s.csv"), "--urdf", URDF, "--json", str(params)]
    assert cli.main([*argv, "--quiet"]) == 0
    return folder, robot.joint_names, params


def _argv(command, log, folder, params):
    if command == "validate":
        return ["validate", str(log), "--urdf", URDF, "--params", str(params)]
    out = folder / f"{command}-{log.stem}.json"
    window = ["--window", "4"] if command == "identify" else []  # a 6 s log
    return [command, str(log), "--urdf", URDF, "--json", str(out), "--quiet", *window]


@pytest.mark.parametrize("command", ["offline", "identify", "validate"])
def test_ms_stamps_read_as_seconds_are_an_error(logs, command, capsys):
    folder, _, params = logs
    argv = _argv(command, folder / "ms.csv", folder, params)
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert SAID in line, line
    assert "ms gives 1000 Hz" in line and "--time-unit ms" in line, line
    assert "--time-unit s if the log is truly sampled at 1 Hz" in line, line


@pytest.mark.parametrize("command", ["offline", "identify", "validate"])
def test_time_unit_s_keeps_the_warning_and_ms_runs_clean(logs, command, capsys):
    folder, _, params = logs
    argv = _argv(command, folder / "ms.csv", folder, params)
    # The log is read (identify then refuses its windows for h = 1 s: exit 2).
    assert cli.main([*argv, "--time-unit", "s"]) in (0, 1, 2)
    captured = capsys.readouterr()
    assert "the time step is 1 s, long for a robot log" in captured.err
    assert "truly sampled at" not in captured.err
    assert "Traceback" not in captured.err
    assert cli.main([*argv, "--time-unit", "ms"]) == 0
    assert "long for a robot log" not in capsys.readouterr().err


def test_the_fit_with_time_unit_ms_is_the_fit_in_seconds(logs, capsys):
    folder, _, params = logs
    argv = _argv("offline", folder / "ms.csv", folder, params)
    assert cli.main([*argv, "--time-unit", "ms"]) == 0
    got = json.loads((folder / "offline-ms.json").read_text())
    want = json.loads(params.read_text())
    np.testing.assert_allclose(
        [p["value"] for p in got["parameters"]],
        [p["value"] for p in want["parameters"]],
        rtol=1e-9,
    )


def test_read_log_behaves_like_the_cli(logs):
    folder, names, _ = logs
    with pytest.raises(ValueError, match=r"1 s \(1 Hz\).*ms gives 1000 Hz"):
        read_log(folder / "ms.csv", names)
    said = read_log(folder / "ms.csv", names, time_unit="s")
    assert said.time_step == 1.0
    assert any("long for a robot log" in w for w in said.warnings)
    log = read_log(folder / "ms.csv", names, time_unit="ms")
    assert log.time_step == pytest.approx(1e-3)
    assert not any("long for a robot log" in w for w in log.warnings)


@pytest.mark.parametrize(
    ("scale", "likely"),
    [
        (1e6, "us gives 1000 Hz"),
        (1e9, "ns gives 1000 Hz"),
        # A 5 Hz log in ms reads as a 5 kHz one in µs (a review: only 'us' was
        # said, the first unit giving 1e-4 to 0.1 s): both are named.
        (
            2e5,
            "ms gives 5 Hz or us gives 5000 Hz); say its unit with "
            "--time-unit ms or us",
        ),
    ],
)
def test_the_error_names_the_likely_unit(logs, tmp_path, scale, likely):
    _, names, _ = logs
    _, t, q, tau = fourier_2r(1001)
    write_log(tmp_path / "x.csv", scale * t, q, tau, names)
    with pytest.raises(ValueError, match=re.escape(likely)):
        read_log(tmp_path / "x.csv", names)


def test_a_drive_file_that_says_the_unit_keeps_the_warning(logs, tmp_path, capsys):
    folder, _, _ = logs
    for unit, code in (("s", 0), (None, 2)):
        drive = tmp_path / f"{unit}.toml"
        drive.write_text(
            f'[log]\ntime_unit = "{unit}"\n' if unit else '[log]\ntime = "t"\n'
        )
        argv = ["offline", str(folder / "ms.csv"), "--urdf", URDF, "--quiet"]
        out = ["--json", str(tmp_path / f"{unit}.json"), "--drive", str(drive)]
        assert cli.main([*argv, *out]) == code
        err = capsys.readouterr().err
        assert ("long for a robot log" in err) and "Traceback" not in err


def test_joined_files_in_ms_are_an_error_unless_the_unit_is_given(logs, capsys):
    """Positions and torques apart, joined on time (``raw_log``)."""
    folder, _, params = logs
    rows = [line.split(",") for line in (folder / "ms.csv").read_text().splitlines()]
    for name, columns in (("q", [0, 1, 2]), ("tau", [0, 3, 4])):
        lines = [",".join(row[k] for k in columns) for row in rows]
        (folder / f"{name}.csv").write_text("\n".join(lines) + "\n")
    files = [str(folder / "q.csv"), str(folder / "tau.csv")]
    argv = ["offline", *files, "--urdf", URDF, "--quiet"]
    assert cli.main([*argv, "--json", str(folder / "joined.json")]) == 2
    assert "ms gives 1000 Hz" in error_line(capsys)
    out = ["--json", str(folder / "joined-ms.json"), "--time-unit", "ms"]
    assert cli.main([*argv, *out]) == 0
    got = json.loads((folder / "joined-ms.json").read_text())
    want = json.loads(params.read_text())
    np.testing.assert_allclose(
        [p["value"] for p in got["parameters"]],
        [p["value"] for p in want["parameters"]],
        rtol=1e-6,
    )


@pytest.mark.parametrize("epoch", [False, True])
def test_a_slow_ros_bag_is_read_with_the_warning(logs, tmp_path, capsys, epoch):
    """A bag's header stamps are ns: its step is known in seconds, so a 1 Hz bag
    is a warning (a step of 1 s there is not ms read as s)."""
    pytest.importorskip("rosbags")
    from test_ros_bag import write_bag

    _, names, _ = logs
    _, t, q, tau = fourier_2r(40, h=1.0)
    start = 1_700_000_000 * 10**9 if epoch else 10**9
    messages = [
        (0, start + k * 10**9, start + k * 10**9 + 1000, names, q[k], tau[k])
        for k in range(t.size)
    ]
    bag = tmp_path / "slow.bag"
    write_bag(bag, "ros1", messages)
    argv = ["offline", str(bag), "--urdf", URDF, "--quiet"]
    assert cli.main([*argv, "--json", str(tmp_path / "bag.json")]) in (0, 1, 2)
    err = capsys.readouterr().err
    assert "the time step is 1 s, long for a robot log" in err, err
    assert "truly sampled at" not in err and "Traceback" not in err


def test_integer_epoch_nanoseconds_at_1_hz_are_not_called_another_unit(tmp_path):
    # Integer stamps >= 1e17 are read as ns since the epoch; a 1 Hz log of them
    # was told 'the time column is likely not in seconds; ... --time-unit UNIT'.
    _, t, q, tau = fourier_2r(301)
    stamps = 1_700_000_000 * 10**9 + np.arange(t.size, dtype=np.int64) * 10**9
    lines = ["t,q_joint1,q_joint2,tau_joint1,tau_joint2"]
    lines += [
        f"{s},{a:.9g},{b:.9g},{c:.9g},{d:.9g}"
        for s, (a, b), (c, d) in zip(stamps, q, tau, strict=True)
    ]
    (tmp_path / "ns.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError) as error:
        read_log(tmp_path / "ns.csv", ["joint1", "joint2"])
    said = str(error.value)
    assert "read as integer nanoseconds since the epoch" in said
    assert "--time-unit ns" in said and "likely not in seconds" not in said
    read_log(tmp_path / "ns.csv", ["joint1", "joint2"], time_unit="ns")  # accepted


def test_a_simulated_log_at_2_hz_is_scored_by_the_printed_command(tmp_path, capsys):
    """``dynid simulate --rate 2`` wrote a log (step 0.5 s) that the printed
    ``dynid offline`` command then refused as stamps in ms (exit 2): the command
    now says ``--time-unit s``, and a warning says why."""
    import shlex

    from drake_dynid.trajectory_file import SampledTrajectory, write_trajectory

    t = np.arange(0.0, 8.0 + 1e-9, 0.01)
    w = 2 * np.pi * 0.25
    q = np.column_stack([np.sin(w * t), 0.5 * np.sin(2 * w * t)])
    v = np.column_stack([w * np.cos(w * t), w * np.cos(2 * w * t)])
    names = ("joint1", "joint2")
    reference = SampledTrajectory(t, q, v, np.full_like(q, np.nan), names)
    write_trajectory(tmp_path / "traj.csv", reference)
    limits = {"lower": -3.0, "upper": 3.0, "velocity": 3.0, "effort": 100.0}
    (tmp_path / "limits.json").write_text(json.dumps(dict.fromkeys(names, limits)))
    log = tmp_path / "sim.csv"
    argv = [
        "simulate", URDF, "--trajectory", str(tmp_path / "traj.csv"), "--limits",
        str(tmp_path / "limits.json"), "--rate", "2", "--time-step", "0.01",
        "--out", str(log),
    ]  # fmt: skip
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "reads it only with --time-unit s" in captured.err, captured.err
    hint = captured.out.split("score it with: ", 1)[1].splitlines()[0]
    words = shlex.split(hint)
    assert words[-2:] == ["--time-unit", "s"], hint
    cli.main([*words[1:], "--json", str(tmp_path / "fit.json"), "--quiet"])
    err = capsys.readouterr().err
    assert "truly sampled at" not in err and "Traceback" not in err, err
    assert "the time step is 0.5 s, long for a robot log" in err, err
    read_log(log, list(names), time_unit="s")  # readable with the unit said
