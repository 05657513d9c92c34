"""Many logs through one ``dynid`` command: local processes or a Dask cluster.

A fleet of robots, a parameter study, a day of recordings: :func:`run_fleet` runs
``dynid identify`` or ``dynid offline`` on each log with the same options, each
writing its own JSON, in parallel:

* by default on this machine, in a ``concurrent.futures.ProcessPoolExecutor`` of
  ``jobs`` worker processes (spawned: each worker imports drake_dynid and pydrake
  once, and inherits ``dynid``'s one-thread BLAS settings,
  ``drake_dynid.core._threads``); ``jobs=1`` runs the logs one after the other
  in this process;
* with ``scheduler`` (the address of a Dask ``distributed`` scheduler, e.g.
  ``tcp://10.0.0.5:8786``), on that cluster: Dask is the Python ecosystem's
  engine for distributing Python functions over machines, and an optional
  dependency (``pip install drake-dynid[fleet]``); it is imported only then.

Each task (:func:`run_one`) is independent: it loads the URDF and the log, runs
the command's own ``run`` with ``--json`` set to its output and ``--quiet``, and
returns a one-line summary (:class:`FleetItem` as a dict, so that it crosses
process and network boundaries). A bad log (``ValueError``/``OSError``: the
message the command would print) fails its item only; a bug is reported with its
traceback in the item. What the command prints on stderr (its notes and the log's
warnings) is captured in the item's ``stderr`` lines (:func:`captured_stderr`),
so that parallel logs' lines do not interleave and a Dask worker's reach the user.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import json
import os
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drake_dynid.core._threads import available_cpus, configure_process
from drake_dynid.files import repeated_file

if TYPE_CHECKING:  # imported where a pool runs: every `dynid` parser imports this
    from concurrent.futures import ProcessPoolExecutor

__all__ = [
    "FLEET_COMMANDS",
    "captured_stderr",
    "output_paths",
    "run_fleet",
    "run_one",
    "task_options",
]

#: The commands a fleet runs (each has ``run(args)`` and a ``--json`` output).
FLEET_COMMANDS = ("identify", "offline")


def output_paths(logs: Sequence[str], out_dir: str | os.PathLike) -> list[str]:
    """One JSON path per log in ``out_dir``: ``<stem>.json``, ``<stem>-2.json``, ...

    Every path is distinct, also on a case-insensitive file system (a log named
    ``log-2.csv`` beside two ``log.csv`` gets ``log-2-2.json``; ``a/Log.csv``
    beside ``b/log.csv`` gets ``log-2.json``), and none is ``summary.json``, the
    fleet's summary.

    Raises:
        ValueError: an output path is one of the logs (never overwrite an input).
    """
    folder = Path(out_dir)
    taken = {"summary"}  # the fleet's own summary.json
    out = []
    for log in logs:
        stem = Path(log).stem or "log"
        name, k = stem, 1
        while name.casefold() in taken:  # a later log's own name is kept
            k += 1
            name = f"{stem}-{k}"
        taken.add(name.casefold())
        out.append(str(folder / f"{name}.json"))
    inputs = {Path(log).resolve() for log in logs}
    for path in out:
        if Path(path).resolve() in inputs:
            raise ValueError(
                f"fleet: the output {path} is one of the logs; an output never "
                "overwrites an input: choose another --out-dir."
            )
    return out


def task_options(
    command: str, options: dict[str, Any], *, parallel: bool
) -> dict[str, Any]:
    """The options each log runs with: ``--parallel off`` if the logs run in parallel.

    For ``identify``, unless ``--parallel`` was given: the workers fill the CPUs,
    and a second process per log would only compete with them.
    """
    if command == "identify" and parallel and options.get("parallel") is None:
        return {**options, "parallel": "off"}
    return options


class _ThreadStderr:
    """``sys.stderr`` whose writes go to the calling thread's capture, if any.

    A Dask worker runs several tasks at once in threads of one process: each
    thread's capture must get its own lines only, and the other threads'
    (and the worker's own) output goes on to the stream it replaced.
    """

    def __init__(self, stream: Any) -> None:
        self.stream = stream
        self.local = threading.local()
        self.users = 0  # captures under way, in any thread

    def _target(self) -> Any:
        buffer = getattr(self.local, "buffer", None)
        return self.stream if buffer is None else buffer

    def write(self, text: str) -> int:
        return int(self._target().write(text))

    def flush(self) -> None:
        self._target().flush()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._target(), name)


_STDERR_LOCK = threading.Lock()


@contextlib.contextmanager
def captured_stderr() -> Iterator[io.StringIO]:
    """What this thread writes on ``sys.stderr`` meanwhile, in a ``StringIO``.

    ``sys.stderr`` is restored when the last capture ends (unless something
    else replaced it meanwhile); other threads' writes are not captured.
    """
    with _STDERR_LOCK:
        current: Any = sys.stderr
        proxy = current if isinstance(current, _ThreadStderr) else None
        if proxy is None:
            proxy = _ThreadStderr(current)
            sys.stderr = proxy  # type: ignore[assignment]
        proxy.users += 1
    buffer = io.StringIO()
    previous = getattr(proxy.local, "buffer", None)
    proxy.local.buffer = buffer
    try:
        yield buffer
    finally:
        proxy.local.buffer = previous
        with _STDERR_LOCK:
            proxy.users -= 1
            if proxy.users == 0 and sys.stderr is proxy:
                sys.stderr = proxy.stream


def run_one(
    command: str, options: dict[str, Any], log: str, json_path: str
) -> dict[str, Any]:
    """Runs ``dynid COMMAND`` on one log; returns its summary (never raises).

    Args:
        command: ``"identify"`` or ``"offline"``.
        options: the command's parsed options (``argparse.Namespace`` as a dict),
            the same for every log; ``log``, ``json`` and ``quiet`` are set here.
        log: the log file.
        json_path: where the command writes its JSON.

    Returns:
        ``{"log", "json", "status" ("ok", "bad input" or "internal error"),
        "message", "seconds", "valid", "condition_number", "model", "stderr"}``,
        ``stderr`` the lines the command printed on stderr (notes, warnings).
        :func:`run_fleet` sets a failed log's ``json`` to None unless the run
        wrote it, and moves an earlier run's file there aside, to
        ``<name>.stale.json``, named in ``stale_json``.
    """
    configure_process()  # a Dask worker may not have been started by dynid
    start = time.perf_counter()
    item: dict[str, Any] = {
        "log": log,
        "json": json_path,
        "status": "ok",
        "message": "",
        "valid": None,
        "condition_number": None,
        "model": None,
    }
    args = argparse.Namespace(**options)
    args.log, args.json, args.quiet = log, json_path, True
    if getattr(args, "topic", None) is not None:
        from drake_dynid.commands._arguments import log_files
        from drake_dynid.ros_bag import is_bag

        # --topic is a bag's (checked on the whole fleet): not a CSV log's.
        if not any(is_bag(path) for path in [log, *log_files(args, "validate")]):
            args.topic = None
    for option in _PACKAGED_OPTIONS:
        value = getattr(args, option, None)
        if isinstance(value, str) and value.startswith(_PACKAGED):
            from drake_dynid.urdf import MODELS_DIR  # this worker's installation

            setattr(args, option, str(MODELS_DIR / value[len(_PACKAGED) :]))
    with captured_stderr() as stderr:
        try:
            module = importlib.import_module(f"drake_dynid.commands.{command}")
            module.run(args)
            with open(json_path, encoding="utf-8") as stream:
                document = json.load(stream)
            for key in ("valid", "condition_number", "model"):
                item[key] = document.get(key)
        except (ValueError, OSError) as error:
            item["status"], item["message"] = "bad input", str(error)
        except Exception:  # a bug: keep the traceback, go on with the other logs
            item["status"] = "internal error"
            item["message"] = traceback.format_exc()
    item["seconds"] = time.perf_counter() - start
    item["stderr"] = stderr.getvalue().splitlines()
    return item


def run_fleet(
    command: str,
    options: dict[str, Any],
    logs: Sequence[str],
    out_dir: str | os.PathLike,
    *,
    jobs: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[dict[str, Any], int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """Runs ``dynid COMMAND`` on every log; one JSON per log in ``out_dir``.

    Args:
        command: ``"identify"`` or ``"offline"``.
        options: the command's options as a dict (see :func:`run_one`).
        logs: the log files (one recording each).
        out_dir: folder of the JSON outputs (created if needed).
        jobs: local worker processes (default: the CPUs this process may run on,
            ``core._threads.available_cpus``, at most the number of logs); 1 runs
            in this process. Ignored with ``scheduler``.
        scheduler: address of a Dask ``distributed`` scheduler; None: local.
        progress: called with (item, done, total) as each log finishes.

    Returns:
        The items of :func:`run_one`, in the order of ``logs``.

    Raises:
        ValueError: an unknown command, no log, ``jobs`` < 1, a log given twice
            (by any name: ``files.same_file``), an output that is an input, or
            Dask not installed when ``scheduler`` is given.
    """
    if command not in FLEET_COMMANDS:
        raise ValueError(
            f"fleet: command must be one of {', '.join(FLEET_COMMANDS)}; got "
            f"{command!r}."
        )
    logs = [str(log) for log in logs]
    if not logs:
        raise ValueError("fleet: no log given.")
    if jobs is not None and jobs < 1:
        raise ValueError(f"fleet: jobs must be >= 1; got {jobs}.")
    repeated = repeated_file(logs)
    if repeated:
        raise ValueError(
            f"fleet: a log is given twice: {repeated[0]} and {repeated[1]} are the "
            "same file (it would be identified twice, as two logs)."
        )
    paths = output_paths(logs, out_dir)
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    before = {path: _signature(path) for path in paths}  # an earlier run's JSON
    local = min(jobs or available_cpus(), len(logs))
    options = task_options(
        command, options, parallel=scheduler is not None or local > 1
    )
    tasks = [
        (command, options, log, path) for log, path in zip(logs, paths, strict=True)
    ]
    results: list[dict[str, Any] | None] = [None] * len(tasks)

    def done(index: int, item: dict[str, Any]) -> None:
        results[index] = item
        if progress is not None:
            progress(item, sum(r is not None for r in results), len(tasks))

    if scheduler is not None:
        cluster_tasks = [_absolute_paths(*task) for task in tasks]

        def named(index: int, item: dict[str, Any]) -> None:
            # The summary names the log and its JSON as the user did.
            item["log"], item["json"] = tasks[index][2], tasks[index][3]
            done(index, item)

        _run_on_dask(scheduler, cluster_tasks, named)
    elif local == 1:
        for index, task in enumerate(tasks):
            done(index, run_one(*task))
    else:
        _run_local(tasks, local, done)
    items = [item for item in results if item is not None]
    _hint_split_recordings(command, items)
    for item in items:
        _name_stale_json(item, before)
    return items


#: Prefix of a packaged model's name in a task sent to a cluster (``--urdf iiwa7``).
_PACKAGED = "packaged model:"
#: The options that may name a packaged file (``--urdf iiwa7``, ``--drive tiago``).
_PACKAGED_OPTIONS = ("urdf", "drive")

#: The command options that name input files (``commands._paths.INPUTS``).
_PATH_OPTIONS = ("urdf", "drive", "params", "validate", "trajectory", "limits")


def _absolute_paths(
    command: str, options: dict[str, Any], log: str, json_path: str
) -> tuple[str, dict[str, Any], str, str]:
    """A task whose relative paths are made absolute for a cluster's workers.

    A Dask worker runs in the folder it was started in, not the user's: the
    relative ``logs/robot1.csv``, ``--urdf robot.urdf`` and ``--out-dir results``
    were read or written there (found by a review: every log failed, "the folder
    results does not exist"). The log and the JSON are made absolute, and the
    input options (``--urdf``, ``--drive``, ``--validate``, ...) when they name a
    file here. A packaged model (``--urdf iiwa7``, which ``dynid`` resolved to
    this installation's ``drake_dynid/models/iiwa7.urdf``; ``--drive tiago``
    likewise) is sent by its file name,
    and :func:`run_one` resolves it in the worker's installation, which may lie
    elsewhere.
    """
    from drake_dynid.urdf import MODELS_DIR

    def absolute(value: Any) -> Any:
        if isinstance(value, str) and value and os.path.exists(value):
            return os.path.abspath(value)
        if isinstance(value, list):
            return [absolute(item) for item in value]
        return value

    options = {
        key: absolute(value) if key in _PATH_OPTIONS else value
        for key, value in options.items()
    }
    for option in _PACKAGED_OPTIONS:
        value = options.get(option)
        if isinstance(value, str) and Path(value).parent == MODELS_DIR.resolve():
            options[option] = _PACKAGED + Path(value).name
    return command, options, os.path.abspath(log), os.path.abspath(json_path)


def _signature(path: str) -> tuple[int, int, int] | None:
    """(inode, size, modification time [ns]) of a file, None if there is none."""
    try:
        found = os.stat(path)
    except OSError:
        return None
    return found.st_ino, found.st_size, found.st_mtime_ns


def _name_stale_json(
    item: dict[str, Any], before: dict[str, tuple[int, int, int] | None]
) -> None:
    """A failed log's ``json`` is None unless this run wrote it.

    The file at its path, left by an earlier run and not replaced by this one,
    is moved aside to ``<name>.stale.json`` (:func:`move_aside`) and named in
    ``stale_json``: nothing is lost, and the folder holds no file a user would
    take for this run's result of a log that failed. Where it cannot be moved
    (``stale_json_error`` says why) it stays, named as well.
    """
    if item["status"] == "ok":
        return
    path = item["json"]
    now = _signature(path)
    if now is None or now == before.get(path):
        item["json"] = None
    if now is not None and now == before.get(path):
        try:
            item["stale_json"] = move_aside(path)
        except OSError as error:
            item["stale_json"] = path
            item["stale_json_error"] = str(error)


def move_aside(path: str) -> str:
    """Renames ``DIR/NAME.json`` to ``DIR/NAME.stale.json`` and returns the new path.

    The new name is taken only if no file has it (``NAME.stale-2.json``, ... when
    one has: an earlier stale result, a log's input): an existing file is never
    replaced. A hard link then the old name removed; where the file system has no
    hard links, a rename (after the same check).

    Raises:
        OSError: the file could not be moved (it is left where it was).
    """
    folder, name = os.path.split(path)
    stem = name[: -len(".json")] if name.endswith(".json") else name
    for k in range(1, 1000):
        suffix = ".stale" if k == 1 else f".stale-{k}"
        target = os.path.join(folder, f"{stem}{suffix}.json")
        try:
            os.link(path, target)
        except FileExistsError:
            continue
        except OSError:  # no hard links here: rename, never over a file
            if os.path.lexists(target):
                continue
            os.rename(path, target)
            return target
        try:
            os.unlink(path)
        except OSError:
            os.unlink(target)  # as it was: one file, at its old name
            raise
        return target
    raise OSError(f"{path}: no free name {stem}.stale-N.json to move it aside to.")


def _hint_split_recordings(command: str, items: list[dict[str, Any]]) -> None:
    """Names, in a failed log's message, a recording split over two of the logs.

    Two logs that both lack columns and share only their first (time) column
    are most likely one recording's two files (positions and efforts apart, as
    the TIAGo's): one ``dynid COMMAND A B`` run, not two logs of a fleet.
    """
    headers = {
        k: _header_cells(item["log"])
        for k, item in enumerate(items)
        if item["status"] == "bad input" and "column(s)" in item["message"]
    }
    lacking = [k for k, header in headers.items() if len(header) > 1]
    for k in lacking:
        for j in lacking:
            if j != k and set(headers[k]) & set(headers[j]) == {headers[k][0]}:
                a, b = sorted((k, j))
                items[k]["message"] = items[k]["message"].rstrip() + (
                    f" A fleet's LOGs are each one recording in one file: if "
                    f"{items[k]['log']} and {items[j]['log']} are one recording "
                    "split over files (e.g. positions and efforts apart), they are "
                    f"one run, dynid {command} {items[a]['log']} {items[b]['log']} "
                    "..., not two logs of a fleet."
                )
                break


def _header_cells(path: str) -> list[str]:
    """The header cells of a CSV log (``log_table.read_header``; [] if unreadable)."""
    from drake_dynid.log_table import read_header

    try:
        with open(path, "rb") as stream:
            return read_header(path, stream)
    except (OSError, ValueError):
        return []


def _run_local(
    tasks: list[tuple],
    workers: int,
    done: Callable[[int, dict[str, Any]], None],
    function: Callable[..., dict[str, Any]] = run_one,
) -> None:
    """Runs the tasks in ``workers`` spawned processes; ``done`` as each finishes.

    A worker that dies (killed when out of memory, a crash in native code)
    breaks the pool: the tasks not done are then run again one after the other,
    each in a process of its own, so that only the log whose process dies fails
    (:func:`_died`). An interrupt (or any exception) stops the workers at once:
    the queued logs are not run.
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool

    context = multiprocessing.get_context("spawn")
    left = dict(enumerate(tasks))
    with _stopped_on_exit(ProcessPoolExecutor(workers, mp_context=context)) as pool:
        futures = {pool.submit(function, *task): i for i, task in left.items()}
        for future in as_completed(futures):
            if isinstance(future.exception(), BrokenProcessPool):
                continue  # run again below
            done(futures[future], future.result())
            del left[futures[future]]
    for index, task in left.items():
        with _stopped_on_exit(ProcessPoolExecutor(1, mp_context=context)) as pool:
            try:
                item = pool.submit(function, *task).result()
            except BrokenProcessPool:
                item = _died(*task)
        done(index, item)


@contextlib.contextmanager
def _stopped_on_exit(pool: ProcessPoolExecutor) -> Iterator[ProcessPoolExecutor]:
    """``pool``, shut down at the end; its workers killed if an exception ends it.

    ``with ProcessPoolExecutor()`` would wait for every queued task on Ctrl-C.
    """
    try:
        yield pool
    except BaseException:
        processes = list((getattr(pool, "_processes", None) or {}).values())
        for process in processes:
            with contextlib.suppress(Exception):
                process.terminate()
        # The pool, its workers gone, is broken: its thread ends at once.
        pool.shutdown(wait=True, cancel_futures=True)
        raise
    pool.shutdown()


def _died(command: str, options: dict[str, Any], log: str, json_path: str) -> dict:
    """The item of a log whose worker process died while running it."""
    return {
        "log": log,
        "json": json_path,
        "status": "internal error",
        "message": (
            "the process running it died (killed by the system, e.g. out of "
            "memory, or a crash in a native library): run dynid "
            f"{command} {log} alone to see why."
        ),
        "valid": None,
        "condition_number": None,
        "model": None,
        "seconds": 0.0,
        "stderr": [],
    }


def _run_on_dask(
    scheduler: str,
    tasks: list[tuple],
    done: Callable[[int, dict[str, Any]], None],
    function: Callable[..., dict[str, Any]] = run_one,
) -> None:
    """Submits every task to the Dask scheduler and collects them as they finish.

    A task that Dask gives up on (``KilledWorker``: its workers died) or whose
    result does not come back fails its log alone (:func:`_died`'s item, the
    error as message).
    """
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise ValueError(
            "fleet: --scheduler needs Dask's distributed package: pip install "
            "'drake-dynid[fleet]'."
        ) from None
    try:
        client = Client(scheduler, timeout=30)
    except OSError as error:
        raise OSError(
            f"fleet: cannot reach the Dask scheduler {scheduler}: {error}"
        ) from None
    except (ValueError, TypeError) as error:  # "missing port number in address"
        raise ValueError(
            f"fleet: --scheduler {scheduler!r} is not a Dask scheduler address "
            f"(tcp://HOST:PORT): {error}"
        ) from None
    try:
        futures = [client.submit(function, *task, pure=False) for task in tasks]
        index = {future.key: k for k, future in enumerate(futures)}
        for future in dask_completed(futures):
            k = index[future.key]
            try:
                item = future.result()
            except Exception as error:  # lost by the cluster, not the log's doing
                item = _died(*tasks[k])
                item["message"] = (
                    f"the cluster did not return its result: "
                    f"{type(error).__name__}: {error}"
                )
            done(k, item)
    finally:
        client.close()
