"""Process settings: BLAS/OpenMP pools of one thread, and the allocator's thresholds.

drake_dynid's linear algebra is small (QR of a few hundred rows by at most a few
hundred columns, filters over n columns), where a multi-threaded BLAS only adds
synchronisation. On a busy machine it is far worse: with OpenBLAS's default pool
on a loaded 2-core machine one 168×58 QR took 822 ms instead of 1.3 ms, and
``dynid identify`` on a 180 s 7-DOF log 97.5 s instead of 9.3 s (issue 15). So
(README "Performance"):

* ``dynid`` pins every pool before numpy is imported (:func:`configure_process`,
  the first call of ``drake_dynid.cli.main``): it sets ``OPENBLAS_NUM_THREADS``,
  ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``, ``VECLIB_MAXIMUM_THREADS`` and
  ``NUMEXPR_NUM_THREADS`` to ``DYNID_THREADS`` (default 1) unless the user set
  them (a variable the user set wins for its library); ``dynid --threads N``
  sets them all to N, whatever the environment. Child processes (``dynid
  fleet``'s workers) inherit the variables.
* In a Python process where numpy is already loaded, :func:`thread_limit` sets
  the pools of the loaded OpenBLAS, MKL, BLIS and OpenMP libraries at run time
  (``openblas_set_num_threads`` and its scipy-openblas variants, ...) through
  ctypes, and restores them on exit; the log replays
  (:func:`drake_dynid.core.replay.replay_log_core`,
  :func:`drake_dynid.diagrams.replay_log`) and
  :func:`drake_dynid.offline.identify_offline` run inside it. It only touches
  libraries already loaded by the process (found in ``/proc/self/maps``, or next
  to numpy and scipy elsewhere), never loads one. Like threadpoolctl (which it
  avoids as a dependency) it changes process-wide settings: another Python
  thread doing BLAS work meanwhile runs with the same limit.
* The allocator (glibc only, :func:`tune_allocator`, called by
  :func:`configure_process`): numpy's temporaries of a few hundred kB are
  allocated and freed at every call of the vectorised rows; with glibc's default
  thresholds the freed top of the heap goes back to the system and every call
  page-faults it in again, which doubled the cost of the 7-DOF regressor rows
  (15 vs 7 µs per sample). ``dynid`` keeps up to 64 MiB of freed heap and maps
  only blocks above 32 MiB (the log's arrays) directly.

``DYNID_THREADS``: a positive integer (threads per pool), or ``0`` / ``auto`` to
leave the libraries' own defaults alone (e.g. to let a big BLAS call use all
cores).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator, MutableMapping
from pathlib import Path
from typing import Any

__all__ = [
    "ENVIRONMENT",
    "available_cpus",
    "configure_process",
    "loaded_pools",
    "pin_environment",
    "release_heap",
    "requested_threads",
    "thread_counts",
    "thread_limit",
    "tune_allocator",
]

DYNID_THREADS = "DYNID_THREADS"

# Environment variable -> the library family it configures.
ENVIRONMENT = {
    "OPENBLAS_NUM_THREADS": "openblas",
    "OMP_NUM_THREADS": "openmp",
    "MKL_NUM_THREADS": "mkl",
    "VECLIB_MAXIMUM_THREADS": "accelerate",
    "NUMEXPR_NUM_THREADS": "numexpr",
}

# family -> (file-name markers, [(setter, getter)] symbol pairs, tried in order).
_FAMILIES = {
    "openblas": (
        ("openblas",),
        [
            ("openblas_set_num_threads", "openblas_get_num_threads"),
            ("openblas_set_num_threads64_", "openblas_get_num_threads64_"),
            ("scipy_openblas_set_num_threads", "scipy_openblas_get_num_threads"),
            ("scipy_openblas_set_num_threads64_", "scipy_openblas_get_num_threads64_"),
        ],
    ),
    "mkl": (("mkl_rt",), [("MKL_Set_Num_Threads", "MKL_Get_Max_Threads")]),
    "blis": (("blis",), [("bli_thread_set_num_threads", "bli_thread_get_num_threads")]),
    "openmp": (
        ("libgomp", "libomp", "libiomp"),
        [("omp_set_num_threads", "omp_get_max_threads")],
    ),
}
_VARIABLE = {family: variable for variable, family in ENVIRONMENT.items()}
_VARIABLE["blis"] = "BLIS_NUM_THREADS"


def available_cpus() -> int:
    """CPUs this process may run on (its affinity mask where known).

    ``os.cpu_count()`` counts the machine's; a container or ``taskset`` may
    allow fewer (the default of the fleet's local workers and of the forked
    helpers of ``dynid identify``).
    """
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def requested_threads(environ: MutableMapping[str, str] | None = None) -> int | None:
    """Threads per pool asked by ``DYNID_THREADS`` (default 1; None: leave alone).

    Raises:
        ValueError: ``DYNID_THREADS`` is neither a non-negative integer nor "auto".
    """
    environ = os.environ if environ is None else environ
    text = environ.get(DYNID_THREADS, "1").strip().lower()
    if text in ("0", "auto"):
        return None
    try:
        count = int(text)
    except ValueError:
        count = -1
    if count < 0:
        raise ValueError(
            f"{DYNID_THREADS} must be a positive integer, 0 or 'auto'; got {text!r}."
        )
    return count


def pin_environment(environ: MutableMapping[str, str] | None = None) -> dict[str, str]:
    """Sets the unset thread variables to ``DYNID_THREADS`` (default 1).

    Takes effect for libraries loaded afterwards (numpy's and scipy's OpenBLAS read
    it when they are loaded, i.e. at ``import numpy``) and in child processes.

    Returns:
        The variables it set.
    """
    environ = os.environ if environ is None else environ
    count = requested_threads(environ)
    if count is None:
        return {}
    set_here = {}
    for variable in ENVIRONMENT:
        if variable not in environ:
            environ[variable] = set_here[variable] = str(count)
    return set_here


def _library_paths() -> list[str]:
    """Paths of the loaded shared libraries that may hold a thread pool."""
    markers = tuple(m for markers, _ in _FAMILIES.values() for m in markers)
    try:
        with open("/proc/self/maps") as stream:
            paths = {line.split(maxsplit=5)[-1].strip() for line in stream}
    except OSError:  # not Linux: look next to numpy and scipy
        paths = set()
        for name in ("numpy", "scipy"):
            module = sys.modules.get(name)
            file = getattr(module, "__file__", None)
            if not file:
                continue
            root = Path(file).parent
            for folder in (root / ".dylibs", root.parent / f"{name}.libs"):
                if folder.is_dir():
                    paths.update(str(p) for p in folder.iterdir())
    return sorted(
        path
        for path in paths
        if path.startswith("/") and any(m in Path(path).name for m in markers)
    )


def loaded_pools() -> list[tuple[str, str, Any, Any]]:
    """(family, library path, setter, getter) of every loaded thread pool."""
    pools = []
    mode = getattr(os, "RTLD_NOLOAD", 0) | getattr(os, "RTLD_LAZY", 1)
    for path in _library_paths():
        try:
            library = ctypes.CDLL(path, mode=mode)
        except OSError:  # not loaded (RTLD_NOLOAD) or not loadable
            continue
        for family, (markers, symbols) in _FAMILIES.items():
            if not any(m in Path(path).name for m in markers):
                continue
            for setter, getter in symbols:
                if hasattr(library, setter) and hasattr(library, getter):
                    pools.append((family, path, library[setter], library[getter]))
                    break
    return pools


def thread_counts() -> dict[str, int]:
    """``{library path: threads}`` of the loaded BLAS and OpenMP pools."""
    return {path: int(getter()) for _, path, _, getter in loaded_pools()}


def _target(family: str, environ: MutableMapping[str, str]) -> int | None:
    text = environ.get(_VARIABLE[family], "")
    if text.strip().isdigit() and int(text) > 0:
        return int(text)
    return requested_threads(environ)


def _apply(count: int | None) -> tuple[list[tuple[Any, int]], dict[str, int]]:
    """Sets the loaded pools; returns (setter, previous count) pairs and the counts."""
    previous = []
    applied = {}
    for family, path, setter, getter in loaded_pools():
        wanted = count if count is not None else _target(family, os.environ)
        if wanted is None:
            continue
        before = int(getter())
        if before != wanted:
            setter(ctypes.c_int(wanted))
            previous.append((setter, before))
        applied[path] = wanted
    return previous, applied


@contextlib.contextmanager
def thread_limit(count: int | None = None) -> Iterator[dict[str, int]]:
    """Limits the loaded BLAS/OpenMP pools while the block runs, then restores them.

    Args:
        count: threads per pool; None: the library's own variable if the user set
            it (``OPENBLAS_NUM_THREADS``, ...), else ``DYNID_THREADS`` (default 1;
            0 or "auto": leave the pool alone).

    Yields:
        ``{library path: threads}`` set inside the block.
    """
    previous, applied = _apply(count)
    try:
        yield applied
    finally:
        for setter, before in reversed(previous):
            setter(ctypes.c_int(before))


#: glibc mallopt parameters and the values :func:`tune_allocator` sets [bytes].
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
TRIM_THRESHOLD = 64 << 20
MMAP_THRESHOLD = 32 << 20


def tune_allocator() -> bool:
    """Keeps freed heap memory in the process (glibc only; see the module doc).

    Sets ``M_TRIM_THRESHOLD`` to 64 MiB and ``M_MMAP_THRESHOLD`` to 32 MiB with
    ``mallopt`` (process-wide, for good). Returns False where there is no glibc
    ``mallopt`` (nothing changed).
    """
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    done = mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    done &= mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
    return bool(done)


def release_heap() -> bool:
    """Returns the freed heap memory to the system now (glibc ``malloc_trim(0)``).

    :func:`tune_allocator` keeps up to 64 MiB of freed heap in the process, for
    the row loops' sake; a long log's phases (reading, automatic settings, the
    streamed rows) each free tens of MB of large temporaries, and kept, those
    would stack with the next phase's under the process's high-water mark. The
    streamed off-line chain calls this between them (a few ms). Returns False
    where there is no glibc (nothing done).
    """
    try:
        trim = ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError):
        return False
    trim.argtypes = (ctypes.c_size_t,)
    trim.restype = ctypes.c_int
    trim(0)
    return True


def configure_process(threads: int | None = None) -> None:
    """``dynid``'s process settings: pools of one thread, the allocator tuned.

    Sets the environment (:func:`pin_environment`) for the libraries not loaded
    yet and for child processes; if numpy is already loaded (``dynid`` called from
    Python), also sets the loaded pools now, for good; then
    :func:`tune_allocator`.

    Args:
        threads: threads per pool (``dynid --threads``): overrides
            ``DYNID_THREADS`` and the libraries' own variables; None: the
            environment decides (``DYNID_THREADS``, default 1).

    Raises:
        ValueError: ``threads`` < 1, or a bad ``DYNID_THREADS``.
    """
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(
                f"configure_process: threads must be an integer >= 1; got {threads!r}."
            )
        os.environ[DYNID_THREADS] = str(threads)
        for variable in ENVIRONMENT:
            os.environ[variable] = str(threads)
    pin_environment()
    if "numpy" in sys.modules:
        _apply(None)
    tune_allocator()
