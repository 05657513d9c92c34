"""``dynid identify`` reads a log in a forked child while the URDF loads
(``commands._arguments.load_robot_and_log``): the same log, warnings and errors
as the read in the command's own process (``--parallel off``)."""

import os

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.commands import _arguments
from drake_dynid.commands._background import can_fork
from drake_dynid.logs import header_joints, write_log
from drake_dynid.plants import model_path

URDF = model_path("planar_2r")


def _messy_log(path, n=3000, seed=5):
    """A 2R log whose columns are not in the robot's order, with an extra column,
    jittered stamps, three dropped rows and a bad cell (each one a repair)."""
    rng = np.random.default_rng(seed)
    h = 1e-3
    t = (h * np.arange(n) + 0.2 * h * rng.uniform(-1, 1, n) + 1.7e9).tolist()
    q = np.cumsum(1e-3 * rng.standard_normal((n, 2)), axis=0).tolist()
    tau = rng.standard_normal((n, 2)).tolist()
    lines = ["tau_joint2,q_joint2,temperature,t,q_joint1,tau_joint1"]
    for k in range(n):
        if k in (500, 501, 502):
            continue
        q1 = "nan" if k == 900 else repr(q[k][0])
        lines.append(f"{tau[k][1]!r},{q[k][1]!r},40.5,{t[k]!r},{q1},{tau[k][0]!r}")
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def _load(argv, monkeypatch):
    """(robot, log, reads in this process) of ``load_robot_and_log``."""
    reads = []
    original = _arguments.read_robot_log

    def counted(*args, **kwargs):
        reads.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(_arguments, "read_robot_log", counted)
    args = cli.build_parser().parse_args(argv)
    robot, log = _arguments.load_robot_and_log(args, "identify")
    return robot, log, len(reads)


def _same_log(a, b):
    assert a.joint_names == b.joint_names
    assert a.warnings == b.warnings
    assert a.time_step == b.time_step and a.time_offset == b.time_offset
    for name in ("t", "q", "tau", "filled"):
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.dtype == y.dtype, name
        # The same memory layout too (reductions may round by it).
        assert x.flags.c_contiguous == y.flags.c_contiguous, name
        assert x.flags.f_contiguous == y.flags.f_contiguous, name
        np.testing.assert_array_equal(x, y, err_msg=name)


def _clean_log(path, n=500):
    """A log that needs no repair, its columns not in the robot's order."""
    rng = np.random.default_rng(2)
    t = 1e-3 * np.arange(n)
    q, tau = rng.standard_normal((n, 2)), rng.standard_normal((n, 2))
    write_log(path, t, q[:, ::-1], tau[:, ::-1], ["joint2", "joint1"])
    return str(path)


def test_header_joints_are_the_q_and_tau_pairs_in_column_order(tmp_path):
    path = tmp_path / "h.csv"
    path.write_text(
        '\ufeff\n  \nt,q_b,q_a,tau_a,x,tau_b,q_c,"q_d,1","tau_d,1"\n'
        "0,1,2,3,4,5,6,7,8\n",
        encoding="utf-8",
    )
    assert header_joints(path) == ("b", "a", "d,1")
    (tmp_path / "empty.csv").write_text("\n\n")
    with pytest.raises(ValueError, match="empty"):
        header_joints(tmp_path / "empty.csv")


@pytest.mark.parametrize("resample", [False, True])
def test_the_log_read_beside_the_urdf_is_the_log_read_here(
    tmp_path, monkeypatch, capfd, resample
):
    path = _messy_log(tmp_path / "messy.csv")
    argv = ["identify", path, "--urdf", URDF] + (["--resample"] if resample else [])
    _, here, reads_here = _load([*argv, "--parallel", "off"], monkeypatch)
    printed_here = capfd.readouterr().err
    robot, beside, reads_beside = _load(argv, monkeypatch)
    printed_beside = capfd.readouterr().err
    assert reads_here == 1
    assert reads_beside == (0 if can_fork() else 1)  # the child's log was used
    assert robot.joint_names == ("joint1", "joint2")
    assert len(here.warnings) >= 3  # ignored column, filled rows, bad cell, ...
    _same_log(beside, here)
    assert printed_beside == printed_here and "temperature" in printed_here


def test_a_clean_log_keeps_the_readers_memory_layout(tmp_path, monkeypatch):
    """Nothing repaired: the reader's q and τ are in Fortran order, whatever the
    column order; the child's log, reordered, keeps that layout."""
    path = _clean_log(tmp_path / "clean.csv")
    argv = ["identify", path, "--urdf", URDF]
    _, here, _ = _load([*argv, "--parallel", "off"], monkeypatch)
    _, beside, reads = _load(argv, monkeypatch)
    assert reads == (0 if can_fork() else 1)
    assert here.q.flags.f_contiguous and not here.q.flags.c_contiguous
    _same_log(beside, here)


def test_only_a_regular_file_is_read_beside(tmp_path, monkeypatch):
    """A FIFO (or a pipe) can be read once: read here, not by a child first."""
    import subprocess

    path = _clean_log(tmp_path / "clean.csv")
    fifo = tmp_path / "log.fifo"
    os.mkfifo(fifo)
    writer = subprocess.Popen(["sh", "-c", f"cat '{path}' > '{fifo}'"])
    try:
        _, piped, reads = _load(["identify", str(fifo), "--urdf", URDF], monkeypatch)
    finally:
        writer.wait(timeout=30)
    _, here, _ = _load(
        ["identify", path, "--urdf", URDF, "--parallel", "off"], monkeypatch
    )
    assert reads == 1
    np.testing.assert_array_equal(piped.q, here.q)


def test_a_log_that_would_spill_to_disk_is_read_here(tmp_path, monkeypatch):
    """Its arrays could not be sent back: no child is started (estimated on the
    file's start: commas and line ends)."""
    from drake_dynid import log_store

    path = _messy_log(tmp_path / "messy.csv")
    args = cli.build_parser().parse_args(["identify", path, "--urdf", URDF])
    assert _arguments._log_prefetch([path], args) is not None
    size = os.path.getsize(path)
    monkeypatch.setattr(log_store, "SPILL_BYTES", size // 10)
    assert _arguments._log_prefetch([path], args) is None


def test_the_header_is_read_alone(tmp_path):
    """Bad bytes below the header do not concern it (the log's read names them)."""
    path = tmp_path / "bad.csv"
    path.write_bytes(b"\n t,q_a,tau_a\n0,1,2\n\xff\xfe,1,2\n" + b"0,1,2\n" * 100000)
    assert header_joints(path) == ("a",)


def test_a_log_of_other_joints_is_read_here(tmp_path, monkeypatch):
    """The child reads both joints; the robot identifies one: the header says so,
    the child is not waited for, and the log is read here."""
    from drake_dynid.commands import _background

    waited = []

    class Spy(_background.Background):
        def result(self):
            waited.append(self.forked)
            return super().result()

    monkeypatch.setattr(_background, "Background", Spy)
    path = _messy_log(tmp_path / "messy.csv")
    argv = ["identify", path, "--urdf", URDF, "--joints", "joint2"]
    _, here, _ = _load([*argv, "--parallel", "off"], monkeypatch)
    _, beside, reads = _load(argv, monkeypatch)
    assert reads == 1 and beside.joint_names == ("joint2",)
    assert waited == []
    _same_log(beside, here)


def test_a_malformed_log_gives_the_usual_error(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text(
        "t,q_joint1,q_joint2,tau_joint1,tau_joint2\n0,0,0,0,0\n0.001,0,zz,0,0\n"
    )
    messages = []
    for extra in ([], ["--parallel", "off"]):
        argv = ["identify", str(path), "--urdf", URDF, *extra]
        assert cli.main(argv) == 2
        messages.append(capsys.readouterr().err)
    assert messages[0] == messages[1]
    assert "row 3, column 'q_joint2': 'zz' is not a number" in messages[0]


def test_a_bad_urdf_stops_the_read_beside_it(tmp_path, capsys, monkeypatch):
    """The URDF's error is the message; the child reading the log is killed and
    reaped (no process left behind)."""
    from drake_dynid.commands import _background

    children = []

    class Spy(_background.Background):
        def _start(self):
            super()._start()
            children.append(self._pid)

    monkeypatch.setattr(_background, "Background", Spy)
    path = _messy_log(tmp_path / "messy.csv")
    urdf = tmp_path / "bad.urdf"
    urdf.write_text("<robot name='x'><link name='a'/>")
    assert cli.main(["identify", path, "--urdf", str(urdf)]) == 2
    assert "bad.urdf" in capsys.readouterr().err
    assert len(children) == (1 if can_fork() else 0)
    for pid in children:
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)


def test_a_log_measures_its_longest_run_once(tmp_path):
    import pickle

    from drake_dynid.logs import RobotLog

    t = 1e-3 * np.arange(400)
    q = np.column_stack([np.sin(t), np.cos(t)])
    q[100, 0] = np.nan  # runs [0, 100), [101, 250), [251, 400): the first longest
    q[250, 1] = np.nan
    log = RobotLog(t, q, np.zeros_like(q), ("a", "b"), 1e-3)
    calls = []

    def measure(q_run, h):
        calls.append((q_run.shape, h))
        return float(q_run[0, 0])

    assert log.on_longest_run(measure) == q[101, 0]
    assert log.on_longest_run(measure) == q[101, 0]
    assert calls == [((149, 2), 1e-3)]
    copy = pickle.loads(pickle.dumps(log))  # a local function as a key
    copy.on_longest_run(measure)
    assert len(calls) == 2

    def failing(q_run, h):
        calls.append("failed")
        raise ValueError("no motion")

    for _ in range(2):
        with pytest.raises(ValueError, match="no motion"):
            log.on_longest_run(failing)
    assert calls[2:] == ["failed", "failed"]
    empty = RobotLog(t[:2], np.full((2, 2), np.nan), np.zeros((2, 2)), ("a", "b"), 1e-3)
    with pytest.raises(ValueError, match="no finite sample"):
        empty.on_longest_run(measure)


@pytest.mark.parametrize("command", ["identify", "offline"])
def test_the_commands_measure_the_velocity_band_once(tmp_path, monkeypatch, command):
    """The dead zone, the off-line chain and identify's band share the measure
    (with the position noise: ``core.excitation.motion_noise_band``)."""
    from drake_dynid.core import excitation

    calls = []
    original = excitation.motion_noise_band

    def counted(q, h):
        calls.append(q.shape)
        return original(q, h)

    monkeypatch.setattr(excitation, "motion_noise_band", counted)
    path = _messy_log(tmp_path / "messy.csv", n=6000)
    argv = [command, path, "--urdf", URDF, "--quiet", "--parallel", "off"]
    if command == "identify":
        argv += ["--window", "2", "--jacobi-window", "0.05", "--bootstrap", "0"]
        argv += ["--bank-time-step", "0.005", "--update-period", "0.05"]
    else:
        argv.remove("--parallel")
        argv.remove("off")
    assert cli.main(argv) == 0
    assert len(calls) == 1


@pytest.mark.parametrize("kind", ["clean", "quoted", "unended", "bad cells"])
def test_half_the_file_parsed_beside_gives_the_same_table(tmp_path, monkeypatch, kind):
    """``read_table(beside=Background)``: the second half of the blocks parsed in a
    forked child (``dynid identify``'s read of the log) gives the same table,
    notes and row numbers, for blocks the fast parser declines too."""
    import dataclasses

    from drake_dynid import log_table
    from drake_dynid.commands._background import Background

    monkeypatch.setattr(log_table, "BLOCK_BYTES", 1 << 12)  # many small blocks
    rng = np.random.default_rng(9)
    rows = [",".join(f"{x:.17g}" for x in row) for row in rng.normal(size=(900, 4))]
    lines = [f"{0.001 * k:.17g},{row}" for k, row in enumerate(rows)]
    if kind == "quoted":  # a quoted cell: the fast parser declines its block
        cells = lines[700].split(",")
        lines[700] = ",".join([cells[0], f'"{cells[1]}"', *cells[2:]])
    if kind == "bad cells":
        lines[650] = lines[650].rsplit(",", 1)[0] + ",nan"
        lines[820] = lines[820].rsplit(",", 1)[0] + ",oops"
    text = "t,q_a,q_b,tau_a,tau_b\n" + "\n".join(lines)
    path = tmp_path / "log.csv"
    path.write_text(text if kind == "unended" else text + "\n")
    wanted, groups = ["t", "q_a", "q_b", "tau_a", "tau_b"], (2, 2)

    def read(beside):
        with open(path, "rb") as stream:
            try:
                return log_table.read_table(str(path), stream, wanted, groups,
                                            beside=beside)  # fmt: skip
            except ValueError as error:
                return str(error)

    here, split = read(None), read(Background)
    if kind == "bad cells":  # 'oops' is an error, the same one
        assert "'oops' is not a number" in here and split == here
        return
    assert not isinstance(here, str), here
    assert here.t.size == 900 - (kind == "unended")
    for field in dataclasses.fields(here):
        a, b = getattr(here, field.name), getattr(split, field.name)
        if isinstance(a, tuple) and a and isinstance(a[0], np.ndarray):
            for x, y in zip(a, b, strict=True):
                np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
        elif isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        elif isinstance(a, log_table.LineNumbers):
            assert (a.first, a.count) == (b.first, b.count)
        else:
            assert a == b, field.name
