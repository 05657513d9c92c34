"""One function run in a forked child process while this process goes on.

``dynid identify``'s parametric bootstrap of the final window (``core.bootstrap``)
needs only the log and the settings, not the replay's trace: on a machine with two
or more CPUs it runs in a child process beside the replay, which takes it off the
command's critical path (7-DOF 60 s log: about 0.45 s of 1.9 s, README
"Performance"). The child is a ``fork`` of this process: it shares the loaded
modules, the URDF's model and the log's arrays without copying or pickling them,
and sends back only its result, pickled through a pipe (the bootstrap's σ: small;
``dynid identify``'s log read beside the URDF's load: the log's arrays, a file of
at most 32 MB, ``commands._arguments.load_robot_and_log``).

Nothing is lost when that cannot be done: off Linux, with fewer than 2 CPUs
available, with other threads running (a fork copies only the calling thread; a
lock another thread holds would stay locked in the child: :func:`can_fork`), or
when the child dies without an answer (or its value does not pickle, or it ran
out of memory), :meth:`Background.result` calls the function in this process
instead. The child dies with its parent (Linux's ``PR_SET_PDEATHSIG``). An
exception the function raises in the child is raised again by
:meth:`Background.result`, as if it had been called here, with the child's
traceback as a note. The result is the same either way: the function must be
deterministic (the bootstrap's draws are seeded).

A child that has not answered when :meth:`Background.result` has waited for it
as long again as it has already run (at least :data:`PATIENCE` seconds) is
presumed stuck (stopped, or blocked on a lock a library's hidden thread held at
the fork): it is killed and the function computed here, so a stuck child costs
time, never the result.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import select
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from types import TracebackType
from typing import Any, Generic, TypeVar

from drake_dynid.core._threads import available_cpus

__all__ = ["PATIENCE", "Background", "available_cpus", "can_fork", "native_threads"]

T = TypeVar("T")

#: The least time [s] :meth:`Background.result` waits for a silent child.
PATIENCE = 10.0


def native_threads() -> int | None:
    """Threads of this process (Linux: ``/proc/self/task``; None elsewhere)."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return None


def can_fork() -> bool:
    """A fork is possible and safe here.

    Linux (``os.fork``; elsewhere a fork is not tried: macOS's system libraries
    are not fork-safe), 2+ CPUs, this process has one thread (a lock another
    thread holds at the fork, Python's or a library's, would stay locked in the
    child; with ``DYNID_THREADS=auto`` the BLAS pool's threads count), and
    SIGCHLD is not ignored (the system would reap the child itself, and its
    process id could be another process's by the time it is cancelled).
    """
    return (
        sys.platform.startswith("linux")
        and hasattr(os, "fork")
        and available_cpus() >= 2
        and threading.active_count() == 1
        and native_threads() == 1
        and signal.getsignal(signal.SIGCHLD) != signal.SIG_IGN
    )


def _message(function: Callable[[], Any]) -> bytes | None:
    """The child's pickled ``(kind, payload, traceback)``; None: nothing to send.

    None (the parent then computes it itself) for a value that does not pickle
    and for a MemoryError (the parent has the child's memory back).
    """
    try:
        value = function()
    except MemoryError:
        return None
    except Exception as error:  # raised again in the parent
        where = traceback.format_exc()
        try:
            return pickle.dumps(("error", error, where))
        except Exception:
            return pickle.dumps(("error", RuntimeError(repr(error)), where))
    try:
        return pickle.dumps(("value", value, ""))
    except Exception:
        return None


def _die_with_parent(parent: int) -> None:
    """Asks Linux to kill this (child) process when its parent dies."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # it died before the request
        os._exit(1)


class Background(Generic[T]):
    """``function()`` computed in a forked child (or here, later, when it cannot be).

    Use as a context manager: leaving the block before :meth:`result` was called
    (an error in the caller's own work) kills and reaps the child.

    Args:
        function: takes no argument; its value and its exceptions must pickle.
        enabled: False computes ``function()`` here, at :meth:`result`.
    """

    def __init__(self, function: Callable[[], T], *, enabled: bool = True) -> None:
        self._function = function
        self._pid: int | None = None
        self._read: int | None = None
        self._started = time.monotonic()
        self._done = False
        self._value: Any = None
        if enabled and can_fork():
            self._start()

    @property
    def forked(self) -> bool:
        """Whether a child process is computing the function."""
        return self._pid is not None

    def _start(self) -> None:
        read, write = os.pipe()
        # Python's own buffers go to the child too: flushed first, so that the
        # child never writes the parent's pending output a second time.
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        parent = os.getpid()
        try:
            pid = os.fork()
        except OSError:  # no process left: compute here instead
            os.close(read)
            os.close(write)
            return
        if pid == 0:  # the child: compute, send, leave without any clean-up
            status = 1  # nothing sent: the parent computes it itself
            try:
                os.close(read)
                signal.signal(signal.SIGINT, signal.SIG_DFL)
                _die_with_parent(parent)
                message = _message(self._function)
                if message is not None:
                    with os.fdopen(write, "wb") as stream:
                        stream.write(message)
                    status = 0
            except BaseException:
                pass
            finally:
                os._exit(status)
        os.close(write)
        self._pid, self._read = pid, read
        self._started = time.monotonic()

    def result(self) -> T:
        """The function's value (or its exception raised), from the child or here.

        Computed once: a second call returns the same value.
        """
        if not self._done:
            self._value = self._compute()
            self._done = True
        return self._value

    def _compute(self) -> T:
        if self._pid is None:
            return self._function()
        message = self._collect()
        if message is None:  # the child died without an answer
            return self._function()
        kind, payload, where = message
        if kind == "error":
            payload.add_note(f"(raised in dynid's forked child process)\n{where}")
            raise payload
        return payload  # type: ignore[no-any-return]

    def _collect(self) -> tuple[str, Any, str] | None:
        """Reads the child's message and reaps it; None if it sent none.

        None too, the child killed, when it stays silent past the deadline (the
        module docstring).
        """
        assert self._pid is not None and self._read is not None
        now = time.monotonic()
        deadline = now + max(PATIENCE, now - self._started)
        chunks = []
        poller = select.poll()  # not select(): any descriptor number
        poller.register(self._read, select.POLLIN)
        while True:
            left = deadline - time.monotonic()
            if not poller.poll(max(0, math.ceil(1000.0 * left))):
                self.cancel()  # stuck: killed and reaped, computed here
                return None
            chunk = os.read(self._read, 1 << 16)
            if not chunk:
                break
            chunks.append(chunk)
            # Sending: it has PATIENCE more for its next part.
            deadline = max(deadline, time.monotonic() + PATIENCE)
        os.close(self._read)
        self._read = None
        try:
            _, status = os.waitpid(self._pid, 0)
        except ChildProcessError:  # reaped by the system: the message decides
            status = 0
        self._pid = None
        if status != 0 or not chunks:
            return None
        try:
            message = pickle.loads(b"".join(chunks))
        except Exception:
            return None
        return message  # type: ignore[no-any-return]

    def cancel(self) -> None:
        """Kills and reaps the child, if any (the result is no longer wanted)."""
        if self._read is not None:
            os.close(self._read)
            self._read = None
        if self._pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self._pid, signal.SIGKILL)
            with contextlib.suppress(ChildProcessError):
                os.waitpid(self._pid, 0)
            self._pid = None

    def __del__(self) -> None:
        with contextlib.suppress(Exception):
            self.cancel()

    def __enter__(self) -> Background[T]:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.cancel()
