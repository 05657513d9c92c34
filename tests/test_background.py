"""``commands._background.Background``: a function computed in a forked child."""

import os
import signal
import threading
import time

import numpy as np
import pytest

from drake_dynid.commands import _background
from drake_dynid.commands._background import Background, can_fork

forking = pytest.mark.skipif(not can_fork(), reason="needs os.fork and 2+ CPUs")


def _in_child() -> int:
    return os.getpid()


@forking
def test_the_value_comes_from_a_child_process():
    parent = os.getpid()
    with Background(_in_child) as background:
        assert background.forked
        child = background.result()
    assert child != parent
    assert not background.forked  # reaped


@forking
def test_arrays_cross_and_the_caller_works_meanwhile():
    x = np.random.default_rng(0).standard_normal((300, 50))

    def work() -> np.ndarray:
        return np.linalg.qr(x)[1]

    with Background(work) as background:
        here = np.linalg.qr(x)[1]  # the caller's own work, at the same time
        there = background.result()
    np.testing.assert_array_equal(there, here)


@forking
def test_an_exception_in_the_child_is_raised_again():
    def bad() -> None:
        raise ValueError("bootstrap_std: the window ending at sample 3 is not full")

    with (
        Background(bad) as background,
        pytest.raises(ValueError, match="not full") as raised,
    ):
        background.result()
    notes = "".join(getattr(raised.value, "__notes__", []))
    assert "forked child" in notes and "in bad" in notes  # the child's traceback


@forking
def test_an_exception_that_does_not_pickle_still_says_what_failed():
    class Local(Exception):  # a local class does not pickle
        pass

    def bad() -> None:
        raise Local("lost?")

    with Background(bad) as background, pytest.raises(RuntimeError, match="lost"):
        background.result()


@forking
def test_a_child_that_dies_without_an_answer_is_computed_here():
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
        thread.join()
    monkeypatch.setattr(_background, "available_cpus", lambda: 1)
    assert not can_fork()
    assert Background(_in_child).result() == os.getpid()


@forking
def test_leaving_the_block_kills_the_child():
    start = time.perf_counter()
    with pytest.raises(KeyError), Background(lambda: time.sleep(30)) as background:
        pid = background._pid
        raise KeyError("the caller's own error")
    assert time.perf_counter() - start < 10.0
    with pytest.raises(ChildProcessError):  # reaped: no such child any more
        os.waitpid(pid, os.WNOHANG)
