"""Robot logs: the CSV format of ``dynid identify`` and ``dynid offline``.

Format (README "Log format"): UTF-8 text, a header row, then one row per sample::

    t,q_<joint 1>,...,q_<joint n>,tau_<joint 1>,...,tau_<joint n>

``t`` in seconds (integers >= 1e17 are read as nanoseconds since the epoch);
``q_<joint>`` in rad (revolute) or m (prismatic); ``tau_<joint>`` in N·m or N, named
after the URDF joints. Column order is free. Row k is sample k of the timing
convention (``docs/CONVENTIONS.md`` §2): ``q_k = q(t_k)`` and ``tau_k`` the torque
acting at ``t_k``. The log read has ``t_k = k·h`` (``time_offset`` holds the original
time of sample 0).

Time stamps (``drake_dynid.core.timestamps``): the uniform grid t0 + h·k is fitted by
least squares on the sample slots read from the local steps, so jitter never drifts
over long logs. Stamps within ``jitter_tolerance``·h (default and largest 0.25: ROS
loggers jitter by ±20 %) are snapped to the grid; with ``resample=True`` the samples
are instead interpolated linearly from their stamps onto the grid (for samples really
taken at the jittered times), and a non-uniformly sampled log is accepted. Outlier
stamps are dropped with a warning naming the rows: at most 3 + N/1000 rows, in runs
of at most 3, whose stamps go back, jump beyond the other rows or lie off the grid
between good neighbours, and up to 3 first or last rows cut off by a gap longer than
``fill_gaps``. Missing slots (dropped samples) and runs of empty/NaN/inf cells of up
to ``fill_gaps`` samples (default 5) are interpolated (cubic for q, linear for tau)
and flagged in ``RobotLog.filled``; longer runs stay bad (NaN) samples. The gaps may
insert at most as many samples as the rows read (checked before any allocation);
filling more than 5 % of the samples is an error. Every repair is a warning on the
log; every problem a ``ValueError`` (``OSError`` for an unreadable file) naming the
file, the rows and what to do.

Long logs: the file is parsed a block of text at a time (``drake_dynid.log_table``)
and, beyond ``drake_dynid.log_store.SPILL_BYTES`` per array, ``t``, ``q`` and
``tau`` stay in temporary files, read a block at a time by the streamed consumers
(``drake_dynid.core.blocks``); the numbers are those of the whole file read at once.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np

from drake_dynid.core._threads import release_heap
from drake_dynid.core._validate import listed
from drake_dynid.core.blocks import blocks, segment
from drake_dynid.core.drive_log import TIME_UNITS
from drake_dynid.files import write_whole
from drake_dynid.log_repair import (
    FILL_GAPS,
    JITTER_TOLERANCE,
    NANOSECONDS,
    Options,
    Repaired,
    repair,
)
from drake_dynid.log_table import (
    LISTED_COLUMNS,
    listed_columns,
    read_header,
    read_table,
    unused_columns,
)

__all__ = ["RobotLog", "header_joints", "read_log", "write_log"]


def _extra_note(extra: list[str]) -> str:
    """The warning naming the extra columns (the first few of many, and a count)."""
    if len(extra) <= LISTED_COLUMNS:
        return f"ignored extra column(s) {listed_columns(extra)}."
    return f"ignored {len(extra)} extra column(s): {listed_columns(extra)}."


T = TypeVar("T")


@dataclass(frozen=True)
class RobotLog:
    """A uniformly sampled robot log.

    A long log read from a file (q and τ beyond
    ``drake_dynid.log_store.SPILL_BYTES`` each, 32 MiB: about 10 minutes of a
    7-DOF arm at 1 kHz) keeps q and τ in temporary files: ``t``, ``q`` and ``tau`` are
    then array-likes read a block at a time when indexed
    (``drake_dynid.log_store``); ``np.asarray`` loads them whole.

    Attributes:
        t: (N,) sample times [s], uniform with step ``time_step``.
        q: (N, n) joint positions [rad or m]; NaN marks a bad or missing sample.
        tau: (N, n) joint torques [N·m or N]; NaN marks a bad or missing sample.
        joint_names: the n joint names, in the column order of ``q`` and ``tau``.
        time_step: the sample period h [s].
        warnings: what the reader repaired or ignored, one sentence each.
        time_offset: original time of the grid's sample 0 [s] (e.g. epoch seconds).
        filled: (N,) bool, True where q or tau was interpolated (dropped samples,
            short runs of bad cells); all False when None is given.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    joint_names: tuple[str, ...]
    time_step: float
    warnings: tuple[str, ...] = field(default=())
    time_offset: float = 0.0
    filled: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.filled is None:
            object.__setattr__(self, "filled", np.zeros(len(self.t), bool))

    @classmethod
    def from_arrays(
        cls,
        t: Any,
        q: Any,
        tau: Any,
        joint_names: Sequence[str],
        *,
        jitter_tolerance: float = JITTER_TOLERANCE,
        resample: bool = False,
        fill_gaps: int = FILL_GAPS,
        min_duration: float | None = None,
    ) -> RobotLog:
        """A log from arrays, checked and repaired as :func:`read_log` does a file.

        Args:
            t: (N,) time stamps [s] (an integer array >= 1e17: nanoseconds).
                Seconds by this method's contract, so a fitted step >= 0.5 s
                (``log_repair.SLOW_STEP``) is read with a warning, not refused as
                by :func:`read_log` without ``time_unit`` (a file's column has no
                stated unit; arrays given here do): scale stamps in ms, µs or ns
                to seconds first (``t * 1e-3`` for ms).
            q: (N, n) joint positions [rad or m] ((N,) when n = 1).
            tau: (N, n) joint torques [N·m or N] ((N,) when n = 1).
            joint_names: the n joint names.
            jitter_tolerance: as for :func:`read_log`.
            resample: as for :func:`read_log`.
            fill_gaps: as for :func:`read_log`.
            min_duration: as for :func:`read_log`.
        """
        owner = "RobotLog.from_arrays"
        names = _joint_names(owner, joint_names)
        options = Options.checked(
            owner, jitter_tolerance, resample, fill_gaps, min_duration
        )
        raw_t = np.asarray(t)
        if raw_t.ndim != 1 or raw_t.dtype.kind not in "iuf":
            raise ValueError(
                f"{owner}: t must be a 1-D array of real numbers [s]; got shape "
                f"{raw_t.shape} of dtype {raw_t.dtype}."
            )
        arrays = []
        for name, value, unit in (("q", q, "rad or m"), ("tau", tau, "N·m or N")):
            array = np.asarray(value)
            if array.ndim == 1 and len(names) == 1:
                array = array[:, None]
            if array.shape != (raw_t.size, len(names)) or array.dtype.kind not in "iuf":
                raise ValueError(
                    f"{owner}: {name} must be a real array of shape (N, n) = "
                    f"({raw_t.size}, {len(names)}) [{unit}]; got shape {array.shape} "
                    f"of dtype {array.dtype}."
                )
            arrays.append(array.astype(float))
        exact = None
        if raw_t.dtype.kind in "iu" and raw_t.size and raw_t.min() >= NANOSECONDS:
            if raw_t.max() <= np.iinfo(np.int64).max:
                exact = raw_t.astype(np.int64)  # exact nanoseconds
        labels = np.arange(raw_t.size, dtype=np.int64)
        q_, tau_ = arrays
        # t is [s] by this method's contract: a step >= 0.5 s is a warning.
        repaired = repair(
            owner,
            "sample",
            raw_t.astype(float),
            exact,
            q_,
            tau_,
            labels,
            options,
            unit_given=True,
        )
        return cls._named(repaired, names)

    @classmethod
    def _named(cls, repaired: Repaired, names: tuple[str, ...]) -> RobotLog:
        r = repaired
        return cls(
            r.t, r.q, r.tau, names, r.time_step, r.warnings, r.time_offset, r.filled
        )

    @property
    def num_samples(self) -> int:
        """Number of samples N."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """t[-1] - t[0] [s]."""
        return float(self.t[-1] - self.t[0]) if self.num_samples else 0.0

    @property
    def bad_samples(self) -> np.ndarray:
        """(N,) bool: samples with a non-finite q or tau (a block at a time)."""
        out = np.empty(self.num_samples, bool)
        for start, q in blocks(self.q):
            tau = np.asarray(self.tau[start : start + len(q)])
            out[start : start + len(q)] = ~(
                np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(tau), axis=1)
            )
        return out

    def good_segments(self) -> list[tuple[int, int]]:
        """[start, stop) sample ranges of the runs of good (finite) samples.

        Found once per log (a pass over q and τ, read from disk on a long log; a
        log is a value: its arrays are not changed in place); a new list each call.
        """
        runs = self.__dict__.get("_good_segments")
        if runs is None:
            good = np.concatenate([[False], ~self.bad_samples, [False]])
            edges = np.flatnonzero(np.diff(good.astype(np.int8)))
            runs = tuple(
                (int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)
            )
            self.__dict__["_good_segments"] = runs
        return list(runs)

    def on_longest_run(self, function: Callable[[Any, float], T]) -> T:
        """``function(q[a:b], time_step)`` on the longest run of good samples.

        Computed once per log and function. The automatic filter rules measure a log's
        longest finite run (its position spectrum: ``core.idim_auto.auto_cutoff``; its
        velocity band and position noise, one periodogram:
        ``core.excitation.motion_noise_band``). The dead zone, the off-line chain,
        the validation and ``dynid identify`` ask the same log for the same measure; it
        is computed for the first (a 7-DOF 60 s log: 0.035 s per velocity band).
        ``function`` must be a pure function of its arguments, and the log's arrays are
        not changed in place (a log is a value). An exception is not kept: the next call
        raises it again. The run is the first of the longest ones; on a long log its q
        is a stored segment (``core.blocks.segment``). The kept values are not pickled.

        Raises:
            ValueError: the log has no good sample.
        """
        measures = self.__dict__.setdefault("_measures", {})
        if function not in measures:
            runs = self.good_segments()
            if not runs:
                raise ValueError("the log has no finite sample (every row has a NaN).")
            start, stop = max(runs, key=lambda run: run[1] - run[0])
            measures[function] = function(segment(self.q, start, stop), self.time_step)
        return measures[function]  # type: ignore[no-any-return]

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("_measures", None)  # functions as keys: not all pickle
        return state


def write_log(
    path: str | os.PathLike,
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    joint_names: Sequence[str],
) -> None:
    """Writes a log in the CSV format above (17 significant digits, lossless).

    Joint names holding commas or quotes are quoted (RFC 4180); :func:`read_log`
    reads them back.
    """
    names = _joint_names("write_log", joint_names)
    for name in names:
        if "\n" in name or "\r" in name or name != name.strip():
            raise ValueError(
                f"write_log: joint name {name!r} must not hold a line break or "
                "start or end with white space."
            )
    t = np.asarray(t, dtype=float)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    tau = np.atleast_2d(np.asarray(tau, dtype=float))
    n = len(names)
    if q.shape != (t.shape[0], n) or tau.shape != (t.shape[0], n):
        raise ValueError(
            f"write_log: q and tau must have shape (N, n) = ({t.shape[0]}, {n}); "
            f"got {q.shape} and {tau.shape}."
        )
    header = ["t", *(f"q_{j}" for j in names), *(f"tau_{j}" for j in names)]
    data = np.column_stack([t, q, tau])

    def write(stream):
        csv.writer(stream, lineterminator="\n").writerow(header)
        np.savetxt(stream, data, delimiter=",", fmt="%.17g")

    write_whole(path, write)  # a full disk leaves no truncated log


def read_log(
    path: str | os.PathLike,
    joint_names: Sequence[str],
    *,
    jitter_tolerance: float = JITTER_TOLERANCE,
    resample: bool = False,
    fill_gaps: int = FILL_GAPS,
    min_duration: float | None = None,
    torques: bool = True,
    parse_beside: Any = None,
    time_unit: str | None = None,
) -> RobotLog:
    """Reads and checks a robot log; see the module docstring for what is repaired.

    Args:
        path: CSV file (UTF-8, a byte-order mark is accepted).
        joint_names: the actuated joints of the robot, in the order wanted for q, tau.
        jitter_tolerance: largest deviation of a time stamp from the fitted uniform
            grid that is snapped, as a fraction of the step h, in (0, 0.25]
            (default 0.25).
        resample: interpolate linearly from the stamps onto the fitted grid instead
            of snapping; accepts non-uniform sampling (off by default: it changes
            the data).
        fill_gaps: longest run of missing samples or bad cells interpolated
            [samples], >= 0 (0: never interpolate; default 5).
        min_duration: shortest accepted duration (N - 1)·h [s] (the caller knows
            what it needs, e.g. window + differentiator window); None: no check.
        torques: False reads ``t`` and the ``q_<joint>`` columns only, τ = 0 (to
            show a motion: ``dynid replay`` of a log of positions).
        parse_beside: ``log_table.read_table``'s ``beside`` (half the file parsed
            in another process; the same log).
        time_unit: the unit of the ``t`` column, ``s``, ``ms``, ``us`` or ``ns``
            (``core.drive_log.TIME_UNITS``); t is scaled to seconds before the
            grid is fitted. None (the default): s, not said, and a fitted step
            >= 0.5 s (``log_repair.SLOW_STEP``) is then an error (stamps in ms,
            µs or ns: the error suggests the unit), as with ``dynid`` without
            ``--time-unit``; a unit given (s too) makes it a warning. In s
            (given or not), integers >= 1e17 are read as epoch ns.

    Returns:
        The uniformly sampled log, with the warnings of what was repaired.
    """
    names = _joint_names("read_log", joint_names)
    unit_given = time_unit is not None
    if time_unit is None:
        time_unit = "s"
    if time_unit not in TIME_UNITS:
        raise ValueError(
            f"read_log: time_unit must be one of {', '.join(TIME_UNITS)}; got "
            f"{time_unit!r}."
        )
    options = Options.checked(
        "read_log", jitter_tolerance, resample, fill_gaps, min_duration
    )
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"log {path}: no such file.")
    if os.path.isdir(path):
        raise IsADirectoryError(f"log {path}: is a directory, expected a CSV file.")
    positions = ["t", *(f"q_{j}" for j in names)]
    wanted = [*positions, *(f"tau_{j}" for j in names)]
    n = len(names)
    with open(path, "rb") as stream:
        if torques:
            table = read_table(path, stream, wanted, (n, n), beside=parse_beside)
            q, tau = table.parts
        else:
            table = read_table(path, stream, positions, (n,), beside=parse_beside)
            (q,) = table.parts
            tau = np.zeros(q.shape)
    t, exact = table.t, table.exact
    if time_unit != "s":
        t, exact = np.asarray(t, dtype=float) * TIME_UNITS[time_unit], None
    extra = unused_columns(table.header, wanted)
    notes = [_extra_note(extra)] if extra else []
    repaired = repair(
        f"log {path}",
        "row",
        t,
        exact,
        q,
        tau,
        table.rows,
        options,
        notes + table.notes,
        table.bad,
        unit_given=unit_given,
    )
    del table
    release_heap()  # the reader's temporaries: not under the next phase's peak
    return RobotLog._named(repaired, names)


def header_joints(path: str | os.PathLike) -> tuple[str, ...]:
    """The joints a log's header names, in its column order.

    Each ``<joint>`` with both a ``q_<joint>`` and a ``tau_<joint>`` column.
    Reads only the header. What a log holds before the robot is known: ``dynid
    identify`` reads the log with these names while the URDF loads, and uses that
    read when they are the robot's joints (``commands._arguments.
    load_robot_and_log``).

    Raises:
        OSError: the file cannot be opened.
        ValueError: an empty file or a header that is not CSV (named).
    """
    path = os.fspath(path)
    with open(path, "rb") as stream:
        header = read_header(path, stream)
    torques = {name[4:] for name in header if name.startswith("tau_")}
    return tuple(
        name[2:] for name in header if name.startswith("q_") and name[2:] in torques
    )


def _joint_names(owner: str, joint_names: Any) -> tuple[str, ...]:
    if isinstance(joint_names, str) or not isinstance(joint_names, Sequence):
        raise TypeError(
            f"{owner}: joint_names must be a sequence of joint names (str); got "
            f"{joint_names!r}."
        )
    names = tuple(joint_names)
    if not names or not all(isinstance(name, str) and name for name in names):
        raise TypeError(
            f"{owner}: joint_names must be one or more non-empty str; got {names!r}."
        )
    duplicated = sorted({name for name in names if names.count(name) > 1})
    if duplicated:
        raise ValueError(f"{owner}: joint_names repeats {listed(duplicated)}.")
    return names
