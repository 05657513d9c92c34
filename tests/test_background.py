"""``commands._background.Background``: a function computed in a forked child."""

import os
import signal
import sys
import threading
import time

import numpy as np
import pytest

from drake_dynid.commands import _background
from drake_dynid.commands._background import Background, can_fork, native_threads


@pytest.fixture
def forking():
    """Skips off Linux or on one CPU; elsewhere a fork must be possible (the
    conftest pins the BLAS pools to one thread, as ``dynid`` does: the process
    has one thread once a finished thread is gone)."""
    if not sys.platform.startswith("linux") or _background.available_cpus() < 2:
        pytest.skip("needs Linux and 2+ CPUs")
    deadline = time.monotonic() + 5.0
    while not can_fork() and time.monotonic() < deadline:
        time.sleep(0.01)
    if not can_fork() and "distributed" in sys.modules:
        # tests/test_fleet.py's in-process Dask cluster leaves its event-loop
        # threads behind (the whole suite runs this file first).
        pytest.skip("an earlier test's Dask cluster left threads in this process")
    assert can_fork(), f"{native_threads()} threads in the test process"


def _joined(thread: threading.Thread) -> None:
    """Joins ``thread`` and waits until the system no longer lists it."""
    thread.join()
    deadline = time.monotonic() + 5.0
    while native_threads() not in (None, 1) and time.monotonic() < deadline:
        time.sleep(0.001)


def _in_child() -> int:
    return os.getpid()


def test_the_value_comes_from_a_child_process(forking):
    parent = os.getpid()
    with Background(_in_child) as background:
        assert background.forked
        child = background.result()
    assert child != parent
    assert not background.forked  # reaped


def test_arrays_cross_and_the_caller_works_meanwhile(forking):
    x = np.random.default_rng(0).standard_normal((300, 50))

    def work() -> np.ndarray:
        return np.linalg.qr(x)[1]

    with Background(work) as background:
        here = np.linalg.qr(x)[1]  # the caller's own work, at the same time
        there = background.result()
    np.testing.assert_array_equal(there, here)


def test_an_exception_in_the_child_is_raised_again(forking):
    def bad() -> None:
        raise ValueError("bootstrap_std: the window ending at sample 3 is not full")

    with (
        Background(bad) as background,
        pytest.raises(ValueError, match="not full") as raised,
    ):
        background.result()
    notes = "".join(getattr(raised.value, "__notes__", []))
    assert "forked child" in notes and "in bad" in notes  # the child's traceback


def test_an_exception_that_does_not_pickle_still_says_what_failed(forking):
    class Local(Exception):  # a local class does not pickle
        pass

    def bad() -> None:
        raise Local("lost?")

    with Background(bad) as background, pytest.raises(RuntimeError, match="lost"):
        background.result()


def test_a_child_that_dies_without_an_answer_is_computed_here(forking):
    parent = os.getpid()

    def dies_in_the_child() -> str:
        if os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)
        return "computed here"

    with Background(dies_in_the_child) as background:
        assert background.forked
        assert background.result() == "computed here"


def test_disabled_it_computes_here_when_asked():
    calls = []

    def work() -> int:
        calls.append(os.getpid())
        return 7

    background = Background(work, enabled=False)
    assert not background.forked and calls == []  # nothing before result()
    assert background.result() == 7 and calls == [os.getpid()]


def test_no_fork_with_other_python_threads_or_one_cpu(monkeypatch):
    stop = threading.Event()
    thread = threading.Thread(target=stop.wait)
    thread.start()
    try:
        assert not can_fork()
        assert not Background(_in_child).forked
    finally:
        stop.set()
        _joined(thread)
    monkeypatch.setattr(_background, "available_cpus", lambda: 1)
    assert not can_fork()
    assert Background(_in_child).result() == os.getpid()


def test_leaving_the_block_kills_the_child(forking):
    start = time.perf_counter()
    with pytest.raises(KeyError), Background(lambda: time.sleep(30)) as background:
        assert background.forked
        pid = background._pid
        raise KeyError("the caller's own error")
    assert time.perf_counter() - start < 10.0
    with pytest.raises(ChildProcessError):  # reaped: no such child any more
        os.waitpid(pid, os.WNOHANG)


def test_a_value_that_does_not_pickle_or_no_memory_is_computed_here(forking):
    parent = os.getpid()

    def lock() -> object:
        return threading.Lock()  # does not pickle

    with Background(lock) as background:
        assert background.forked
        assert type(background.result()) is type(threading.Lock())

    def memory() -> str:
        if os.getpid() != parent:
            raise MemoryError
        return "computed here"

    with Background(memory) as background:
        assert background.forked
        assert background.result() == "computed here"


def test_the_result_is_computed_once(forking):
    calls = []

    def work() -> int:
        calls.append(1)  # in this process only when computed here
        return 3

    with Background(work) as background:
        assert background.result() == background.result() == 3
    assert calls == []  # the child's list, not this one
    here = Background(work, enabled=False)
    assert here.result() == here.result() == 3 and calls == [1]


def test_no_fork_when_sigchld_is_ignored():
    """The system would reap the child itself (its id free for another process
    before a cancel): computed here instead."""
    previous = signal.signal(signal.SIGCHLD, signal.SIG_IGN)
    try:
        assert not can_fork()
        background = Background(_in_child)
        assert not background.forked and background.result() == os.getpid()
    finally:
        signal.signal(signal.SIGCHLD, previous)


def test_the_child_dies_with_its_parent(tmp_path):
    """A parent killed mid-work takes its child with it (PR_SET_PDEATHSIG)."""
    import subprocess

    pid_file = tmp_path / "child.pid"
    code = (
        "import os, time, pathlib\n"
        "from drake_dynid.commands._background import Background, can_fork\n"
        "if not can_fork(): raise SystemExit(3)\n"
        "def work():\n"
        f"    pathlib.Path({str(pid_file)!r}).write_text(str(os.getpid()))\n"
        "    time.sleep(60)\n"
        "b = Background(work)\n"
        "time.sleep(60)\n"
    )
    parent = subprocess.Popen([sys.executable, "-c", code])
    deadline = time.monotonic() + 30.0
    while not pid_file.exists() and parent.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.01)
    if parent.poll() == 3:
        pytest.skip("no fork in the subprocess")
    while not pid_file.read_text():
        time.sleep(0.01)
    child = int(pid_file.read_text())
    parent.kill()
    parent.wait()
    deadline = time.monotonic() + 10.0
    while _alive(child):
        assert time.monotonic() < deadline, "the child outlived its parent"
        time.sleep(0.01)


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        with open(f"/proc/{pid}/stat") as stream:
            return stream.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize("how", ["blocked", "stopped"])
def test_a_stuck_child_is_killed_and_computed_here(forking, monkeypatch, how):
    """A child silent for as long again as it ran (at least PATIENCE) is presumed
    stuck: killed, reaped, and the value computed here."""
    monkeypatch.setattr(_background, "PATIENCE", 0.3)
    parent = os.getpid()

    def stuck_in_the_child() -> str:
        if os.getpid() != parent:
            time.sleep(60.0)  # a lock that never comes free
        return "computed here"

    with Background(stuck_in_the_child) as background:
        assert background.forked
        pid = background._pid
        if how == "stopped":
            os.kill(pid, signal.SIGSTOP)
        start = time.monotonic()
        assert background.result() == "computed here"
        waited = time.monotonic() - start
    assert 0.25 < waited < 5.0, waited
    assert not background.forked
    with pytest.raises(ChildProcessError):  # reaped
        os.waitpid(pid, os.WNOHANG)


def test_a_slow_child_gets_as_long_again_as_it_ran(forking, monkeypatch):
    monkeypatch.setattr(_background, "PATIENCE", 0.1)
    parent = os.getpid()

    def slow() -> int:
        time.sleep(0.6)
        return os.getpid()

    with Background(slow) as background:
        time.sleep(0.5)  # the caller's own work: the child then gets 0.5 s more
        assert background.result() != parent  # the child's answer, not a rerun


def test_a_child_sending_a_large_value_is_not_cut_off(forking, monkeypatch):
    """The wait is renewed while the answer arrives: 2 MB read 64 KB at a time,
    each read slowed to 0.05 s, take 1.6 s, three times the first wait (0.5 s:
    the time the child has already had, more than PATIENCE), and the value still
    comes from the child. The child is given that 0.5 s to start sending, so that
    the machine's load cannot make it miss the first wait (a fixed allowance of
    PATIENCE = 0.3 s for 100 MB did on a busy machine)."""
    monkeypatch.setattr(_background, "PATIENCE", 0.3)
    read = os.read

    def slow_read(fd: int, size: int) -> bytes:
        time.sleep(0.05)
        return read(fd, size)

    def large() -> tuple[int, bytes]:
        return os.getpid(), bytes(2 << 20)

    parent = os.getpid()
    with Background(large) as background:
        time.sleep(0.5)
        monkeypatch.setattr(_background.os, "read", slow_read)
        pid, value = background.result()
    assert pid != parent and len(value) == 2 << 20


def test_it_waits_on_a_descriptor_above_1024(forking):
    """poll(), not select(): a process with many files open still gets the child's
    value."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 1200:
        pytest.skip(f"the hard limit on open files is {hard}")
    resource.setrlimit(resource.RLIMIT_NOFILE, (max(soft, 1200), hard))
    opened = [os.open(os.devnull, os.O_RDONLY) for _ in range(1100)]
    try:
        parent = os.getpid()
        with Background(_in_child) as background:
            assert background._read > 1024
            assert background.result() != parent
    finally:
        for fd in opened:
            os.close(fd)
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
