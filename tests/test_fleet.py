"""``dynid fleet``: many logs, one JSON each, equal to the single-log command.

Logs: random Fourier motions of the 2R arm (numpy default_rng(1) and (2)), τ from
its inverse-dynamics rows with the URDF's base values plus 1 % noise
(default_rng(0)), written as CSV logs. The Dask test runs an in-process cluster
(``distributed.LocalCluster(processes=False)``, one worker thread).
"""

import json
import os
import pathlib

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import write_log
from drake_dynid.plants import RobotModel, model_path

URDF = str(model_path("planar_2r"))


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("logs")
    robot = RobotModel.from_urdf(URDF)
    paths = []
    for seed in (1, 2):
        trajectory = random_fourier_trajectory(
            2,
            harmonics=5,
            base_frequency=2 * np.pi / 10.0,
            max_velocity=4.0,
            rng=np.random.default_rng(seed),
        )
        t = 1e-3 * np.arange(12001)
        q, v, vdot = trajectory.evaluate(t)
        tau = robot.idim_rows(q, v, vdot) @ robot.base_values
        tau += 0.01 * tau.std(axis=0) * np.random.default_rng(0).normal(size=tau.shape)
        path = folder / f"robot{seed}.csv"
        write_log(path, t, q, tau, robot.joint_names)
        paths.append(str(path))
    return paths


def _parameters(path):
    document = json.loads(pathlib.Path(path).read_text(encoding="utf-8"))
    return {p["name"]: p["value"] for p in document["parameters"]}


def _single(command, log, out, *options):
    argv = [command, log, "--urdf", URDF, "--json", str(out), "--quiet", *options]
    assert cli.main(argv) == 0
    return _parameters(out)


def test_fleet_on_a_local_dask_cluster(logs, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        argv = ["fleet", "offline", *logs, "--urdf", URDF]
        argv += ["--out-dir", str(tmp_path / "out")]
        argv += ["--scheduler", cluster.scheduler_address]
        assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "| log | status | valid |" in out and out.count("| ok | true |") == 2
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [item["log"] for item in summary] == logs
    for log, item in zip(logs, summary, strict=True):
        assert item["status"] == "ok" and item["valid"] is True
        single = _single("offline", log, tmp_path / "single.json")
        assert _parameters(item["json"]) == pytest.approx(single, rel=1e-12)


def test_fleet_identify_in_this_process_and_offline_in_two(logs, tmp_path, capsys):
    options = ["--window", "5", "--urdf", URDF]
    argv = ["fleet", "identify", *logs, *options, "--out-dir", str(tmp_path / "a")]
    assert cli.main([*argv, "--jobs", "1", "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    first = tmp_path / "a" / "robot1.json"
    single = _single("identify", logs[0], tmp_path / "single.json", "--window", "5")
    assert _parameters(first) == pytest.approx(single, rel=1e-12)
    argv = ["fleet", "offline", *logs, "--urdf", URDF, "--out-dir", str(tmp_path / "b")]
    assert cli.main([*argv, "--jobs", "2", "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == [
        "robot1.json",
        "robot2.json",
        "summary.json",
    ]


def test_fleet_errors(logs, tmp_path, capsys):
    out_dir = str(tmp_path / "out")
    base = ["fleet", "offline", "--urdf", URDF, "--out-dir", out_dir, "--jobs", "1"]
    # A missing log fails alone: the others are done, exit 2 with one line.
    assert cli.main([*base, logs[0], str(tmp_path / "missing.csv")]) == 2
    err = capsys.readouterr().err
    assert "1 of 2 logs failed" in err and "missing.csv: no such file" in err
    assert (tmp_path / "out" / "robot1.json").exists()
    # One output file for every log is refused, as is an output onto an input.
    assert cli.main([*base, logs[0], "--out", str(tmp_path / "x.csv")]) == 2
    assert "--out would write one file for every log" in capsys.readouterr().err
    # Found by a review: --json (which the command's README names a per-log
    # output) was argparse's "unrecognized arguments: --json a.json".
    assert cli.main([*base, logs[0], "--json", str(tmp_path / "a.json")]) == 2
    assert "--json would write one file for every log" in capsys.readouterr().err
    clash = tmp_path / "out" / "robot9.json"
    clash.write_text("{}")
    assert cli.main([*base, str(clash)]) == 2
    assert "never overwrites an input" in capsys.readouterr().err
    assert cli.main(["fleet"]) == 2  # no command
    assert "choose the command" in capsys.readouterr().err


def test_logs_run_in_parallel_do_not_fork_a_second_process_each():
    """``identify --parallel off`` per log when the fleet's workers run in
    parallel (they fill the CPUs), unless the user chose ``--parallel``."""
    from drake_dynid.fleet import task_options

    given = {"urdf": "r.urdf", "parallel": None}
    assert task_options("identify", given, parallel=True)["parallel"] == "off"
    assert task_options("identify", given, parallel=False) is given
    chosen = {**given, "parallel": "auto"}
    assert task_options("identify", chosen, parallel=True) is chosen
    assert "parallel" not in task_options("offline", {}, parallel=True)


def test_output_names_never_collide_nor_take_the_summary():
    """Found by a review: a log named summary.csv had its JSON overwritten by the
    summary, and a third log named log-2.csv took the second log.csv's name."""
    from drake_dynid.fleet import output_paths

    paths = output_paths(["a/log.csv", "b/log.csv", "log-2.csv", "summary.csv"], "o")
    assert paths == ["o/log.json", "o/log-2.json", "o/log-2-2.json", "o/summary-2.json"]
    assert len(set(paths)) == 4
    # One file on macOS and Windows (case-insensitive): a review.
    paths = output_paths(["a/Log.csv", "b/log.csv", "SUMMARY.csv"], "o")
    assert paths == ["o/Log.json", "o/log-2.json", "o/SUMMARY-2.json"]


def test_out_dir_that_is_a_file_is_named(tmp_path, capsys):
    from drake_dynid import cli

    log = tmp_path / "log.csv"
    log.write_text("t,q_joint1,q_joint2,tau_joint1,tau_joint2\n0,0,0,0,0\n")
    argv = ["fleet", "offline", str(log), "--urdf", "planar_2r", "--out-dir", str(log)]
    assert cli.main(argv) == 2
    assert f"--out-dir {log} is a file; give a folder" in capsys.readouterr().err
    # Found by a review: "fleet: jobs must be >= 1", not the option's name.
    argv = ["fleet", "offline", str(log), "--urdf", "planar_2r", "--jobs", "0"]
    assert cli.main([*argv, "--out-dir", str(tmp_path / "out")]) == 2
    assert "dynid fleet: error: --jobs must be >= 1; got 0." in capsys.readouterr().err


def _log_with_warnings(source, path, row):
    """``source`` with a NaN cell at ``row`` and the row after the next dropped:
    two reader warnings (a filled cell, a filled gap) that name the log."""
    lines = pathlib.Path(source).read_text().splitlines()
    cells = lines[row].split(",")
    cells[1] = "nan"
    lines[row] = ",".join(cells)
    del lines[row + 2]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_each_logs_stderr_is_printed_whole_and_named(logs, tmp_path, capfd, jobs):
    """Found by a review: with --jobs 2 the workers wrote their notes and warnings
    on the terminal as they came, the two logs' lines interleaved (and a Dask
    worker's stayed on its machine). Each log's lines are captured, kept in
    summary.json and printed together, each prefixed by the log."""
    bad = [
        _log_with_warnings(log, tmp_path / f"w{k}.csv", 100 + 50 * k)
        for k, log in enumerate(logs)
    ]
    argv = ["fleet", "offline", *bad, "--urdf", URDF, "--jobs", jobs, "--quiet"]
    assert cli.main([*argv, "--out-dir", str(tmp_path / "out")]) == 0
    err = capfd.readouterr().err.splitlines()
    assert len(err) == 4, err
    owners = [next(log for log in bad if line.startswith(f"{log}: ")) for line in err]
    assert owners[0] == owners[1] and owners[2] == owners[3] != owners[0]
    assert all("dynid offline: warning: log " in line for line in err)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    for item in summary:
        assert len(item["stderr"]) == 2
        assert all(f"{item['log']}: {text}" in err for text in item["stderr"])


def test_stderr_capture_is_per_thread_and_restores_stderr(capsys):
    """A Dask worker runs tasks in threads of one process: each capture gets its
    own thread's lines only; the others' go on to the stream it replaced."""
    import sys
    import threading

    from drake_dynid.fleet import captured_stderr

    original = sys.stderr
    barrier = threading.Barrier(2)
    got = {}

    def task(name):
        with captured_stderr() as buffer:
            for k in range(3):
                print(f"{name} {k}", file=sys.stderr)
                barrier.wait()
        got[name] = buffer.getvalue().splitlines()

    threads = [threading.Thread(target=task, args=(n,)) for n in "ab"]
    for thread in threads:
        thread.start()
    print("main", file=sys.stderr)
    for thread in threads:
        thread.join()
    assert got == {n: [f"{n} 0", f"{n} 1", f"{n} 2"] for n in "ab"}
    assert sys.stderr is original
    assert capsys.readouterr().err == "main\n"


def _fake_run(command, options, log, json_path):
    """A stand-in for run_one in the pool's workers: "crash" logs kill their
    process, "slow" logs take a minute, the others return at once."""
    import os
    import time

    if "crash" in log:
        os._exit(9)
    if "slow" in log:
        time.sleep(60)
    return {"log": log, "json": json_path, "status": "ok", "message": ""}


def test_a_worker_that_dies_fails_its_log_alone():
    """Found by a review: a worker killed (out of memory, a crash in native
    code) broke the process pool: the fleet stopped with a BrokenProcessPool
    traceback (exit 1), no summary, the other logs not done and the culprit not
    named. The logs not done are run again, each alone: only the one whose
    process dies fails."""
    from drake_dynid.fleet import _run_local

    logs = ["a.csv", "crash.csv", "b.csv", "c.csv", "d.csv"]
    tasks = [("offline", {}, log, f"{log}.json") for log in logs]
    results = {}
    _run_local(tasks, 2, results.__setitem__, function=_fake_run)
    assert sorted(results) == list(range(5))
    statuses = {results[k]["log"]: results[k]["status"] for k in results}
    assert statuses == {log: "ok" for log in logs} | {"crash.csv": "internal error"}
    assert "process running it died" in results[1]["message"]


def test_an_interrupt_stops_the_workers_at_once():
    """Found by a review: Ctrl-C (SIGINT to dynid alone, e.g. from a job
    scheduler) left the pool running every queued log to its end before dynid
    exited (8 logs of 4 s on 2 workers: 23.7 s)."""
    import multiprocessing
    import time

    from drake_dynid.fleet import _run_local

    tasks = [("offline", {}, log, "x.json") for log in ("a", "slow1", "slow2")]
    tasks += [("offline", {}, f"slow{k}", "x.json") for k in range(3, 9)]

    def interrupt(index, item):
        raise KeyboardInterrupt

    start = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        _run_local(tasks, 2, interrupt, function=_fake_run)
    assert time.perf_counter() - start < 20
    time.sleep(0.5)
    assert multiprocessing.active_children() == []


def _fails_on_bad(command, options, log, json_path):
    if "bad" in log:
        raise RuntimeError("the worker lost its task")
    return {"log": log, "json": json_path, "status": "ok", "message": ""}


def test_a_task_lost_on_the_dask_cluster_fails_its_log_alone(tmp_path):
    """Found by a review: a task that Dask gives up on (KilledWorker after a
    worker died, a result that cannot be unpickled) re-raised in dynid and
    stopped the fleet with a traceback, the other logs' results lost."""
    distributed = pytest.importorskip("distributed")
    from drake_dynid.fleet import _run_on_dask

    tasks = [("offline", {}, log, "x.json") for log in ("a", "bad", "b")]
    results = {}
    with distributed.LocalCluster(
        processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        _run_on_dask(
            cluster.scheduler_address, tasks, results.__setitem__, _fails_on_bad
        )
    assert [results[k]["status"] for k in range(3)] == ["ok", "internal error", "ok"]
    assert "RuntimeError: the worker lost its task" in results[1]["message"]


def test_a_recording_split_in_two_files_is_named_as_such(tmp_path, capsys):
    """Found by a review: the TIAGo's positions and efforts (two files of one
    recording) given to a fleet failed each with "no column(s) '- ..._effort'",
    not saying that a fleet's LOGs are each one file and the two are one run."""
    data = pathlib.Path(__file__).parent / "data" / "tiago"
    position = str(data / "tiago_position_excerpt.csv")
    effort = str(data / "tiago_effort_excerpt.csv")
    joints = ",".join(["torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8))])
    argv = ["fleet", "offline", position, effort, "--urdf", "tiago_no_hand"]
    drive = pathlib.Path(model_path("tiago_no_hand")).with_name("tiago.toml")
    argv += ["--joints", joints, "--drive", str(drive)]
    argv += ["--jobs", "1", "--quiet", "--out-dir", str(tmp_path / "out")]
    assert cli.main(argv) == 2
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    for item, other in zip(summary, (effort, position), strict=True):
        assert item["status"] == "bad input"
        assert "no column(s)" in item["message"]
        assert f"if {item['log']} and {other} are one recording" in item["message"]
        assert f"dynid offline {position} {effort}" in item["message"]
    assert "one recording split over files" in capsys.readouterr().err


def test_a_log_of_other_joints_beside_a_good_one_gets_no_split_hint(logs, tmp_path):
    other = tmp_path / "other.csv"
    other.write_text("t,q_a,tau_a\n0,0,0\n")
    argv = ["fleet", "offline", logs[0], str(other), "--urdf", URDF, "--jobs", "1"]
    assert cli.main([*argv, "--quiet", "--out-dir", str(tmp_path / "o")]) == 2
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summary[1]["status"] == "bad input"
    assert "column(s)" in summary[1]["message"]
    assert "one recording" not in summary[1]["message"]


def test_an_internal_error_of_a_log_exits_1(tmp_path, monkeypatch, capsys):
    """A review: a log that hit a bug made the fleet exit 2, the code of bad
    input; docs/CONVENTIONS.md: a bug exits 1."""
    import drake_dynid.fleet
    from drake_dynid import cli

    def fake(command, options, logs, out_dir, **kwargs):
        pathlib.Path(out_dir).mkdir(parents=True, exist_ok=True)
        paths = [f"{out_dir}/a.json", f"{out_dir}/b.json"]
        return [
            {"log": logs[0], "json": paths[0], "status": "ok", "message": "",
             "seconds": 0.1, "valid": True, "condition_number": 1.0},
            {"log": logs[1], "json": paths[1], "status": "internal error",
             "message": "Traceback: boom", "seconds": 0.1},
        ]  # fmt: skip

    monkeypatch.setattr(drake_dynid.fleet, "run_fleet", fake)
    logs = [str(tmp_path / "a.csv"), str(tmp_path / "b.csv")]
    for log in logs:
        pathlib.Path(log).write_text("t,q_joint1\n0,0\n")
    argv = ["fleet", "offline", *logs, "--urdf", "planar_2r", "--quiet"]
    assert cli.main([*argv, "--out-dir", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert "1 of 2 logs met an internal error (first: " in err


def test_a_bad_scheduler_address_names_the_option(tmp_path, capsys):
    """A review: --scheduler nonsense said only 'missing port number in address'."""
    pytest.importorskip("distributed")
    from drake_dynid import cli

    log = tmp_path / "log.csv"
    log.write_text("t,q_joint1,q_joint2,tau_joint1,tau_joint2\n0,0,0,0,0\n")
    argv = ["fleet", "offline", str(log), "--urdf", "planar_2r"]
    argv += ["--out-dir", str(tmp_path / "out"), "--scheduler", "nonsense"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "--scheduler 'nonsense' is not a Dask scheduler address" in err
    assert "Traceback" not in err


def test_default_jobs_are_the_cpus_this_process_may_use(logs, tmp_path, monkeypatch):
    """A review: ``--jobs`` defaulted to ``os.cpu_count()``, the machine's CPUs,
    where a container or ``taskset`` allows fewer; one allowed CPU runs the
    logs in this process, without a pool."""
    from drake_dynid import fleet

    monkeypatch.setattr(os, "cpu_count", lambda: 64)
    monkeypatch.setattr(fleet, "available_cpus", lambda: 1)

    def no_pool(*args, **kwargs):
        raise AssertionError("a process pool for one allowed CPU")

    monkeypatch.setattr(fleet, "_run_local", no_pool)
    argv = ["fleet", "offline", *logs, "--urdf", URDF, "--quiet"]
    assert cli.main([*argv, "--out-dir", str(tmp_path / "out")]) == 0


def test_an_empty_per_log_output_is_refused_before_any_log(logs, tmp_path, capsys):
    # A review: --urdf-out "" passed the fleet's check (an empty string is false)
    # and every log then failed on its own; it is refused as any --urdf-out.
    out_dir = tmp_path / "out"
    argv = ["fleet", "offline", logs[0], "--urdf", URDF, "--out-dir", str(out_dir)]
    assert cli.main([*argv, "--jobs", "1", "--urdf-out", ""]) == 2
    assert "--urdf-out would write one file for every log" in capsys.readouterr().err
    assert not out_dir.exists()


def test_a_log_given_twice_is_refused(logs, tmp_path, capsys, monkeypatch):
    """A review: ``fleet offline log.csv ./log.csv`` identified it twice
    (log.json, log-2.json), where ``dynid offline`` refuses a file given twice."""
    monkeypatch.chdir(pathlib.Path(logs[0]).parent)
    name = pathlib.Path(logs[0]).name
    out_dir = tmp_path / "out"
    argv = ["fleet", "offline", name, f"./{name}", "--urdf", URDF]
    assert cli.main([*argv, "--out-dir", str(out_dir), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert f"a log is given twice: {name} and ./{name} are the same file" in err
    assert not out_dir.exists()


def test_a_failed_rerun_does_not_present_an_earlier_runs_json(logs, tmp_path, capsys):
    """Found by a review: a log that failed on a rerun kept the previous run's
    JSON beside the new summary, which pointed at it as the log's result; then
    (a second review) it stayed in the folder under the log's result name, only
    the summary saying it was stale: a user opening the folder took it for the
    current result. It is moved aside to <name>.stale.json now (never over a
    file: robot.stale-2.json the next time), named in the summary and on
    stderr; a log that fails without such a file has ``json`` null too."""
    log = tmp_path / "robot.csv"
    good = pathlib.Path(logs[0]).read_text()
    log.write_text(good)
    out_dir = tmp_path / "out"
    options = ["--urdf", URDF, "--jobs", "1", "--out-dir", str(out_dir)]
    assert cli.main(["fleet", "offline", str(log), *options, "--quiet"]) == 0
    earlier = (out_dir / "robot.json").read_text()
    log.write_text("t,q_joint1\n0,0\n")  # the rerun fails on this log
    capsys.readouterr()
    logs_now = [str(log), str(tmp_path / "missing.csv")]
    assert cli.main(["fleet", "offline", *logs_now, *options]) == 2
    captured = capsys.readouterr()
    assert not (out_dir / "robot.json").exists()  # not taken for this run's
    assert (out_dir / "robot.stale.json").read_text() == earlier  # kept
    summary = json.loads((out_dir / "summary.json").read_text())
    assert [item["status"] for item in summary] == ["bad input", "bad input"]
    assert summary[0]["json"] is None
    assert summary[0]["stale_json"] == str(out_dir / "robot.stale.json")
    assert summary[1]["json"] is None and "stale_json" not in summary[1]
    moved = f"an earlier run's JSON, not this one's result, moved to {out_dir}"
    assert moved in captured.out, captured.out
    assert "1 failed log(s) had a JSON" in captured.err
    assert "moved aside to <name>.stale.json" in captured.err
    # Failing again: nothing left to move; ok, then failing: a new stale name.
    assert cli.main(["fleet", "offline", str(log), *options, "--quiet"]) == 2
    assert "stale_json" not in json.loads((out_dir / "summary.json").read_text())[0]
    log.write_text(good)
    assert cli.main(["fleet", "offline", str(log), *options, "--quiet"]) == 0
    log.write_text("t,q_joint1\n0,0\n")
    assert cli.main(["fleet", "offline", str(log), *options, "--quiet"]) == 2
    assert (out_dir / "robot.stale.json").read_text() == earlier  # not replaced
    assert (out_dir / "robot.stale-2.json").exists()
    assert sorted(p.name for p in out_dir.iterdir()) == [
        "robot.stale-2.json",
        "robot.stale.json",
        "summary.json",
    ]


def test_a_stale_json_that_cannot_be_moved_stays_named(tmp_path, monkeypatch):
    """Where the file cannot be moved aside it stays, named in the summary with
    the reason (the earlier behaviour), never lost."""
    from drake_dynid import fleet

    path = tmp_path / "robot.json"
    path.write_text("{}")
    before = {str(path): fleet._signature(str(path))}

    def refuse(*args, **kwargs):
        raise PermissionError("read-only folder")

    monkeypatch.setattr(fleet.os, "link", refuse)
    monkeypatch.setattr(fleet.os, "rename", refuse)
    item = {"status": "bad input", "json": str(path)}
    fleet._name_stale_json(item, before)
    assert item["json"] is None and item["stale_json"] == str(path)
    assert "read-only folder" in item["stale_json_error"]
    assert path.read_text() == "{}"


def test_output_checks_are_linear_in_the_number_of_logs(tmp_path, monkeypatch):
    """A review: check_outputs compared every output with every input and every
    other output (same_file per pair: n² stat calls for a fleet of n logs). One
    key a path now; the same answers."""
    from drake_dynid import files
    from drake_dynid.commands._paths import check_outputs

    n = 300
    inputs = {"a log": [str(tmp_path / f"log{k}.csv") for k in range(n)]}
    for path in inputs["a log"]:
        pathlib.Path(path).write_text("t\n")
    outputs = {f"json {k}": str(tmp_path / f"out{k}.json") for k in range(n)}
    calls = []
    real = files.os.stat

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(files.os, "stat", counted)
    check_outputs(outputs, inputs)
    assert len(calls) <= 10 * n  # a few a path (its folder...), 180000 before
    monkeypatch.undo()
    clash = {**outputs, "json last": inputs["a log"][7]}
    with pytest.raises(ValueError, match=r"json last .*log7.csv is an input"):
        check_outputs(clash, inputs)
    twice = {**outputs, "--plot": outputs["json 5"]}
    with pytest.raises(ValueError, match="json 5 and --plot are the same file"):
        check_outputs(twice, inputs)


def test_relative_paths_reach_a_dask_worker_started_in_another_folder(
    logs, tmp_path, monkeypatch, capsys
):
    """Found by a review: a Dask worker runs in the folder it was started in; the
    relative log, --urdf and --out-dir of `dynid fleet offline robot1.csv --urdf
    planar_2r.urdf --out-dir out --scheduler ...` were looked for there, and every
    log failed ("the folder out does not exist"). A worker is stood in for by
    running each task after a chdir to another folder."""
    import shutil

    from drake_dynid import fleet

    project, elsewhere = tmp_path / "project", tmp_path / "elsewhere"
    project.mkdir()
    elsewhere.mkdir()
    for log in logs:
        shutil.copy(log, project)
    shutil.copy(URDF, project / "planar_2r.urdf")

    def worker_in_another_folder(scheduler, tasks, done, function=fleet.run_one):
        here = os.getcwd()
        os.chdir(elsewhere)
        try:
            for index, task in enumerate(tasks):
                done(index, function(*task))
        finally:
            os.chdir(here)

    monkeypatch.setattr(fleet, "_run_on_dask", worker_in_another_folder)
    monkeypatch.chdir(project)
    argv = ["fleet", "offline", "robot1.csv", "robot2.csv", "--urdf", "planar_2r.urdf"]
    argv += ["--out-dir", "out", "--scheduler", "tcp://127.0.0.1:8786"]
    assert cli.main(argv) == 0, capsys.readouterr().err
    summary = json.loads((project / "out" / "summary.json").read_text())
    # Named as the user named them; the results are the single-log command's.
    assert [item["log"] for item in summary] == ["robot1.csv", "robot2.csv"]
    assert [item["json"] for item in summary] == [
        os.path.join("out", "robot1.json"),
        os.path.join("out", "robot2.json"),
    ]
    single = _single("offline", logs[0], tmp_path / "single.json")
    assert _parameters(project / "out" / "robot1.json") == pytest.approx(
        single, rel=1e-12
    )
    assert not list(elsewhere.iterdir())


def test_a_missing_urdf_or_drive_file_is_refused_once_before_any_log(
    logs, tmp_path, capsys
):
    """Found by a review: a mistyped --urdf failed every log on its own (a worker
    process started for each), the same message in every row of the table."""
    out_dir = tmp_path / "out"
    base = ["fleet", "offline", *logs, "--out-dir", str(out_dir), "--jobs", "2"]
    cases = [
        (["--urdf", str(tmp_path / "robot.urdf")], "robot.urdf: no such file (or the"),
        (["--urdf", URDF, "--drive", str(tmp_path / "d.toml")], "d.toml: no such file"),
        (["--urdf", URDF, "--drive", "TIAGO"], "packaged drive file: tiago)"),
        (["--urdf", URDF, "--validate", str(tmp_path / "v.csv")], "v.csv: no such"),
        # Text options every log reads alike: refused once too.
        (["--urdf", URDF, "--joints", ""], "--joints is empty"),
        (["--urdf", URDF, "--lock", " "], "--lock is empty"),
    ]
    for extra, message in cases:
        assert cli.main([*base, *extra]) == 2
        err = capsys.readouterr().err
        assert message in err
        if "empty" not in message:
            assert "every log would fail on it" in err
        assert len(err.strip().splitlines()) == 1
        assert not out_dir.exists()


def test_a_packaged_model_reaches_a_dask_worker_by_its_name(
    logs, tmp_path, monkeypatch, capsys
):
    """Found by a review: `--urdf planar_2r` is resolved by dynid to this
    installation's drake_dynid/models/planar_2r.urdf, and that path was sent to
    the cluster, whose workers' installation may lie elsewhere. The task holds the
    name; the worker resolves it (here: its result equals the local run's)."""
    from drake_dynid import fleet

    sent = []

    def worker(scheduler, tasks, done, function=fleet.run_one):
        for index, task in enumerate(tasks):
            sent.append(task[1]["urdf"])
            done(index, function(*task))

    monkeypatch.setattr(fleet, "_run_on_dask", worker)
    argv = ["fleet", "offline", logs[0], "--urdf", "planar_2r"]
    argv += ["--out-dir", str(tmp_path / "out"), "--scheduler", "tcp://h:8786"]
    assert cli.main(argv) == 0, capsys.readouterr().err
    assert sent == ["packaged model:planar_2r.urdf"]
    single = _single("offline", logs[0], tmp_path / "single.json")
    assert _parameters(tmp_path / "out" / "robot1.json") == pytest.approx(
        single, rel=1e-12
    )


def test_a_packaged_drive_file_is_named_and_sent_by_its_name(tmp_path, monkeypatch):
    """`--drive tiago` is drake_dynid/models/tiago.toml from any folder (as `--urdf
    iiwa7`), and a cluster's task carries its name, not this installation's path."""
    from drake_dynid import fleet
    from drake_dynid.urdf import MODELS_DIR

    monkeypatch.chdir(tmp_path)
    args = cli.build_parser().parse_args(
        ["offline", "log.csv", "--urdf", "tiago_no_hand", "--drive", "tiago"]
    )
    assert args.drive == str(MODELS_DIR / "tiago.toml")
    (tmp_path / "tiago").write_text("")  # a file of that name here is that file
    argv = ["offline", "log.csv", "--urdf", "iiwa7", "--drive", "tiago"]
    args = cli.build_parser().parse_args(argv)
    assert args.drive == "tiago"
    options = {"urdf": str(MODELS_DIR / "iiwa7.urdf")}
    options["drive"] = str(MODELS_DIR / "tiago.toml")
    _, sent, _, _ = fleet._absolute_paths("offline", options, "a.csv", "a.json")
    assert sent["urdf"] == "packaged model:iiwa7.urdf"
    assert sent["drive"] == "packaged model:tiago.toml"


@pytest.mark.parametrize("command", ["identify", "offline"])
def test_the_help_does_not_offer_the_refused_per_log_outputs(command, capsys):
    """Found by a review: 'dynid fleet offline -h' described '--out FILE.csv ...
    -: standard output', an option the fleet refuses."""
    with pytest.raises(SystemExit):
        cli.main(["fleet", command, "-h"])
    text = capsys.readouterr().out
    assert "--out-dir" in text
    for option in ("--out FILE", "--plot", "--urdf-out", "--json"):
        assert option not in text, option
