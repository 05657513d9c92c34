"""Robot logs: the CSV format of ``dynid identify`` and ``dynid offline``.

Format (DESIGN.md): a header row, then one row per sample::

    t,q_<joint 1>,...,q_<joint n>,tau_<joint 1>,...,tau_<joint n>

``t`` in seconds; ``q_<joint>`` in rad (revolute) or m (prismatic); ``tau_<joint>`` in
N·m or N, named after the URDF joints. Column order is free. Row k is sample k of the
timing convention (``docs/CONVENTIONS.md`` §2): ``q_k = q(t_k)`` and ``tau_k`` the
torque acting at ``t_k``.

What the reader does with imperfect logs (each case is tested):

* missing file, empty file, no data rows: error.
* missing ``t``, ``q_<joint>`` or ``tau_<joint>`` column, duplicated column: error
  naming it.
* extra columns (``v_*``, temperatures, ...): ignored, with a warning naming them.
* non-numeric cell: error naming the row and the column.
* empty, ``nan`` or ``inf`` cell in ``q`` or ``tau``: kept as NaN (a bad sample), with a
  warning; the on-line blocks flag the windows that contain it invalid.
* non-finite, unsorted or duplicated time stamps: error naming the row.
* jitter up to ``jitter_tolerance``·h: time stamps snapped to the uniform grid (step
  and origin fitted by least squares), with a warning.
* dropped samples (gaps of whole multiples of h): the missing rows are inserted as
  bad (NaN) samples, with a warning.
* any other non-uniform sampling: error, unless ``resample=True``: linear
  interpolation onto the uniform grid of the median step, with a warning.

Errors are ``ValueError`` (``OSError`` for an unreadable file) whose message names the
file and what to fix; the ``dynid`` command turns them into exit code 2.
"""

from __future__ import annotations

import csv
import math
import os
import warnings as warnings_module
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["RobotLog", "read_log", "write_log"]


@dataclass(frozen=True)
class RobotLog:
    """A uniformly sampled robot log.

    Attributes:
        t: (N,) sample times [s], uniform with step ``time_step``.
        q: (N, n) joint positions [rad or m]; NaN marks a bad or missing sample.
        tau: (N, n) joint torques [N·m or N]; NaN marks a bad or missing sample.
        joint_names: the n joint names, in the column order of ``q`` and ``tau``.
        time_step: the sample period h [s].
        warnings: what the reader repaired or ignored, one sentence each.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    joint_names: tuple[str, ...]
    time_step: float
    warnings: tuple[str, ...] = field(default=())

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
        """(N,) bool: samples with a non-finite q or tau."""
        return ~(
            np.all(np.isfinite(self.q), axis=1) & np.all(np.isfinite(self.tau), axis=1)
        )

    def good_segments(self) -> list[tuple[int, int]]:
        """[start, stop) sample ranges of the runs of good (finite) samples."""
        good = np.concatenate([[False], ~self.bad_samples, [False]]).astype(np.int8)
        edges = np.flatnonzero(np.diff(good))
        return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def write_log(
    path: str | os.PathLike,
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    joint_names: Sequence[str],
) -> None:
    """Writes a log in the CSV format above (17 significant digits, lossless)."""
    t = np.asarray(t, dtype=float)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    tau = np.atleast_2d(np.asarray(tau, dtype=float))
    n = len(joint_names)
    if q.shape != (t.shape[0], n) or tau.shape != (t.shape[0], n):
        raise ValueError(
            f"write_log: q and tau must have shape (N, n) = ({t.shape[0]}, {n}); "
            f"got {q.shape} and {tau.shape}."
        )
    header = ["t", *(f"q_{j}" for j in joint_names), *(f"tau_{j}" for j in joint_names)]
    data = np.column_stack([t, q, tau])
    with open(path, "w", newline="") as stream:
        stream.write(",".join(header) + "\n")
        np.savetxt(stream, data, delimiter=",", fmt="%.17g")


def _parse_cell(text: str, row: int, column: str, path: str) -> float:
    text = text.strip()
    if text == "":
        return math.nan
    try:
        return float(text)
    except ValueError:
        raise ValueError(
            f"log {path}: row {row}, column '{column}': '{text}' is not a number."
        ) from None


def read_log(
    path: str | os.PathLike,
    joint_names: Sequence[str],
    *,
    jitter_tolerance: float = 0.1,
    resample: bool = False,
) -> RobotLog:
    """Reads and checks a robot log; see the module docstring for what is repaired.

    Args:
        path: CSV file.
        joint_names: the actuated joints of the robot, in the order wanted for q, tau.
        jitter_tolerance: largest accepted deviation of a time stamp from the uniform
            grid, as a fraction of the median step h (default 0.1).
        resample: allow linear interpolation of a non-uniformly sampled log onto the
            uniform grid of its median step (off by default: it changes the data).

    Returns:
        The uniformly sampled log, with the warnings of what was repaired.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"log {path}: no such file.")
    if os.path.isdir(path):
        raise IsADirectoryError(f"log {path}: is a directory, expected a CSV file.")
    if not 0.0 < jitter_tolerance < 0.5:
        raise ValueError(
            f"read_log: jitter_tolerance must be in (0, 0.5); got {jitter_tolerance}."
        )
    table = _fast_table(path)
    if table is None:
        with open(path, newline="") as stream:
            rows = [r for r in csv.reader(stream) if any(cell.strip() for cell in r)]
        if not rows:
            raise ValueError(f"log {path}: the file is empty; expected a header row.")
        header = [cell.strip() for cell in rows[0]]
        body: Any = rows[1:]
    else:
        header, body = table
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        raise ValueError(f"log {path}: duplicated column(s) {', '.join(duplicated)}.")
    if len(body) == 0:
        raise ValueError(f"log {path}: the header has no data rows below it.")
    wanted = ["t", *(f"q_{j}" for j in joint_names), *(f"tau_{j}" for j in joint_names)]
    missing = [name for name in wanted if name not in header]
    if missing:
        raise ValueError(
            f"log {path}: missing column(s) {', '.join(missing)}; the header must hold "
            f"t, q_<joint> and tau_<joint> for the joints {', '.join(joint_names)} "
            f"(found: {', '.join(header)})."
        )
    warnings: list[str] = []
    extra = [name for name in header if name not in wanted]
    if extra:
        warnings.append(f"ignored extra column(s) {', '.join(extra)}.")
    index = [header.index(name) for name in wanted]
    if isinstance(body, np.ndarray):
        data = body[:, index]
    else:
        data = _parse_rows(path, body, header, index, wanted)
    t = data[:, 0]
    n = len(joint_names)
    q = data[:, 1 : 1 + n]
    tau = data[:, 1 + n :]
    return _uniform(
        path, t, q, tau, tuple(joint_names), jitter_tolerance, resample, warnings
    )


def _fast_table(path: str) -> tuple[list[str], np.ndarray] | None:
    """Header and numbers of a clean log with numpy's C parser, else None.

    Clean: the first line is the header and every other line holds exactly as many
    numbers (``nan``/``inf`` included) as the header has names. Anything else goes
    to the cell-by-cell reader, whose messages name the row and the column.
    """
    with open(path) as stream:
        first = stream.readline()
    header = [cell.strip() for cell in first.strip().split(",")]
    if not first.strip() or '"' in first:
        return None
    try:
        with warnings_module.catch_warnings():
            warnings_module.simplefilter("error")  # "input contained no data"
            body = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=float)
    except (ValueError, UserWarning):
        return None
    if body.shape[1] != len(header):
        return None
    return header, body


def _parse_rows(path, body, header, index, wanted) -> np.ndarray:
    """Cell by cell, with a message naming the row and column of a bad cell."""
    data = np.empty((len(body), len(wanted)))
    for r, row in enumerate(body):
        line = r + 2  # 1-based, after the header
        if len(row) != len(header):
            raise ValueError(
                f"log {path}: row {line} has {len(row)} cells; the header has "
                f"{len(header)}."
            )
        for c, i in enumerate(index):
            data[r, c] = _parse_cell(row[i], line, wanted[c], path)
    return data


def _uniform(path, t, q, tau, joint_names, jitter_tolerance, resample, warnings):
    bad_t = np.flatnonzero(~np.isfinite(t))
    if bad_t.size:
        raise ValueError(
            f"log {path}: time stamp of row {bad_t[0] + 2} is empty or not finite."
        )
    if t.size < 2:
        raise ValueError(f"log {path}: needs at least 2 samples; got {t.size}.")
    dt = np.diff(t)
    if np.any(dt == 0.0):
        row = int(np.flatnonzero(dt == 0.0)[0]) + 3
        raise ValueError(
            f"log {path}: duplicated time stamp at row {row} (t = {t[row - 2]})."
        )
    if np.any(dt < 0.0):
        row = int(np.flatnonzero(dt < 0.0)[0]) + 3
        raise ValueError(
            f"log {path}: time stamps are not increasing at row {row} "
            f"(t = {t[row - 2]} after {t[row - 3]}); sort the log by time."
        )
    bad = ~(np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(tau), axis=1))
    if np.any(bad):
        warnings.append(
            f"{int(bad.sum())} sample(s) with an empty, NaN or infinite q/tau "
            f"(first at row {int(np.flatnonzero(bad)[0]) + 2}); the windows containing "
            "them are flagged invalid."
        )
    h = float(np.median(dt))
    index = np.rint((t - t[0]) / h).astype(np.int64)
    if np.all(np.diff(index) >= 1):
        # Refine step and origin by least squares on the grid index (jittered clocks).
        h, t0 = np.polyfit(index.astype(float), t, 1)
        index = np.rint((t - t0) / h).astype(np.int64)
        index -= index[0]
    else:
        t0 = t[0]
    steps = (t - t0) / h
    deviation = np.abs(steps - index)
    regular = np.all(deviation <= jitter_tolerance) and np.all(np.diff(index) >= 1)
    if regular:
        if np.max(deviation) > 1e-6:
            warnings.append(
                f"time stamp jitter up to {np.max(deviation) * h:.3g} s "
                f"({100 * np.max(deviation):.2g}% of the step {h:.6g} s); time stamps "
                "snapped to the uniform grid."
            )
        total = int(index[-1]) + 1
        if total != t.size:
            gaps = int(total - t.size)
            warnings.append(
                f"{gaps} dropped sample(s) (gaps in the time stamps) inserted as bad "
                "samples."
            )
            q_full = np.full((total, q.shape[1]), np.nan)
            tau_full = np.full((total, tau.shape[1]), np.nan)
            q_full[index] = q
            tau_full[index] = tau
            q, tau = q_full, tau_full
        grid = t0 + h * np.arange(total)
        return RobotLog(grid, q, tau, joint_names, h, tuple(warnings))
    worst = int(np.argmax(deviation))
    if not resample:
        raise ValueError(
            f"log {path}: non-uniform sampling (row {worst + 2} is "
            f"{deviation[worst]:.2f} steps off the grid of the median step {h:.6g} s); "
            "resample it onto a uniform grid first, or allow linear interpolation "
            "(dynid: --resample)."
        )
    if np.any(bad):
        raise ValueError(
            f"log {path}: cannot resample a non-uniform log that has bad samples; "
            "remove or repair the rows with empty, NaN or infinite cells."
        )
    grid = t[0] + h * np.arange(int(np.floor((t[-1] - t[0]) / h + 1e-9)) + 1)
    q = np.column_stack([np.interp(grid, t, q[:, j]) for j in range(q.shape[1])])
    tau = np.column_stack([np.interp(grid, t, tau[:, j]) for j in range(tau.shape[1])])
    warnings.append(
        f"non-uniform sampling: resampled by linear interpolation onto a uniform grid "
        f"of step {h:.6g} s ({grid.size} samples)."
    )
    return RobotLog(grid, q, tau, joint_names, h, tuple(warnings))
