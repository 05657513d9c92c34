"""One function run in a forked child process while this process goes on.

``dynid identify``'s parametric bootstrap of the final window (``core.bootstrap``)
needs only the log and the settings, not the replay's trace: on a machine with two
or more CPUs it runs in a child process beside the replay, which takes it off the
command's critical path (7-DOF 60 s log: about 0.45 s of 1.9 s, README
"Performance"). The child is a ``fork`` of this process: it shares the loaded
modules, the URDF's model and the log's arrays without copying or pickling them,
and sends back only its (small) result, pickled through a pipe.

Nothing is lost when that cannot be done: off Linux, with fewer than 2 CPUs
available, with other threads running (a fork copies only the calling thread; a
lock another thread holds would stay locked in the child: :func:`can_fork`), or
when the child dies without an answer, :meth:`Background.result`
calls the function in this process instead. An exception the function raises in
the child is raised again by :meth:`Background.result`, as if it had been
called here. The result is the same either way: the function must be
deterministic (the bootstrap's draws are seeded).
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import sys
import threading
import traceback
from collections.abc import Callable
from types import TracebackType
from typing import Any, Generic, TypeVar

__all__ = ["Background", "available_cpus", "can_fork", "native_threads"]

T = TypeVar("T")


def available_cpus() -> int:
    """CPUs this process may run on (its affinity mask where known)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def native_threads() -> int | None:
    """Threads of this process (Linux: ``/proc/self/task``; None elsewhere)."""
    try:
        return len(os.listdir("/proc/self/task"))
    except OSError:
        return None


def can_fork() -> bool:
    """A fork is possible and safe here.

    Linux (``os.fork``; elsewhere a fork is not tried: macOS's system libraries
    are not fork-safe), 2+ CPUs, and this process has one thread (a lock another
    thread holds at the fork, Python's or a library's, would stay locked in the
    child; with ``DYNID_THREADS=auto`` the BLAS pool's threads count).
    """
    return (
        sys.platform.startswith("linux")
        and hasattr(os, "fork")
        and available_cpus() >= 2
        and threading.active_count() == 1
        and native_threads() == 1
    )


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
        try:
            pid = os.fork()
        except OSError:  # no process left: compute here instead
            os.close(read)
            os.close(write)
            return
        if pid == 0:  # the child: compute, send, leave without any clean-up
            status = 0
            try:
                os.close(read)
                signal.signal(signal.SIGINT, signal.SIG_DFL)
                try:
                    message = pickle.dumps(("value", self._function(), ""))
                except Exception as error:  # raised again in the parent
                    where = traceback.format_exc()
                    try:
                        message = pickle.dumps(("error", error, where))
                    except Exception:
                        unpicklable = RuntimeError(repr(error))
                        message = pickle.dumps(("error", unpicklable, where))
                with os.fdopen(write, "wb") as stream:
                    stream.write(message)
            except BaseException:  # nothing sent: the parent computes it itself
                status = 1
            finally:
                os._exit(status)
        os.close(write)
        self._pid, self._read = pid, read

    def result(self) -> T:
        """The function's value (or its exception raised), from the child or here."""
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
        """Reads the child's message and reaps it; None if it sent none."""
        assert self._pid is not None and self._read is not None
        chunks = []
        with os.fdopen(self._read, "rb") as stream:
            self._read = None
            while chunk := stream.read(1 << 16):
                chunks.append(chunk)
        _, status = os.waitpid(self._pid, 0)
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

    def __enter__(self) -> Background[T]:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.cancel()
