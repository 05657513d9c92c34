"""The repair layer of the log reader: time stamps → uniform grid → filled samples.

Shared by :func:`drake_dynid.logs.read_log` (file rows) and
:meth:`drake_dynid.logs.RobotLog.from_arrays` (array samples); the policy is described
in the ``drake_dynid.logs`` docstring and the README "Bad data" table. The grid fit and
the interpolation of short runs are in ``drake_dynid.core.timestamps``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drake_dynid.core.blocks import BLOCK_ROWS, blocks, is_stored
from drake_dynid.core.timestamps import (
    NonUniformSampling,
    TimeGrid,
    fill_short_runs,
    fit_time_grid,
    nominal_step,
    phase_breaks,
)
from drake_dynid.log_store import GridTimes, RowSink

JITTER_TOLERANCE = 0.25  # [steps] default snapping tolerance
FILL_GAPS = 5  # [samples] default longest interpolated run
MAX_FILLED_FRACTION = 0.05  # more filled samples than this is an error
NANOSECONDS = 1e17  # integer stamps from here on: nanoseconds since the epoch
MAX_SECONDS = 1e11  # |t| beyond (year 5000) cannot be seconds
RESAMPLE_ROUNDING = 1e-2  # a resampling grid takes a round step within 1 %
REPORTED_JITTER = 1e-3  # [steps] smaller deviations are round-off, not reported
_PLACE_SLOTS = 1 << 14  # grid slots placed and filled at a time


@dataclass(frozen=True)
class Options:
    """The reader's options, checked (see ``read_log``)."""

    jitter_tolerance: float
    resample: bool
    fill_gaps: int
    min_duration: float | None

    @classmethod
    def checked(cls, owner, jitter_tolerance, resample, fill_gaps, min_duration):
        """The options, or a TypeError/ValueError naming the bad one."""
        if isinstance(jitter_tolerance, bool) or not isinstance(
            jitter_tolerance, (int, float, np.integer, np.floating)
        ):
            raise TypeError(
                f"{owner}: jitter_tolerance must be a real number [steps]; got "
                f"{jitter_tolerance!r}."
            )
        if not 0.0 < jitter_tolerance <= 0.25:
            raise ValueError(
                f"{owner}: jitter_tolerance must be in (0, 0.25] [steps]; got "
                f"{jitter_tolerance}."
            )
        if isinstance(fill_gaps, bool) or not isinstance(fill_gaps, (int, np.integer)):
            raise TypeError(
                f"{owner}: fill_gaps must be an integer [samples]; got {fill_gaps!r}."
            )
        if fill_gaps < 0:
            raise ValueError(
                f"{owner}: fill_gaps must be >= 0 [samples]; got {fill_gaps}."
            )
        if min_duration is not None and not (
            isinstance(min_duration, (int, float, np.integer, np.floating))
            and not isinstance(min_duration, bool)
            and math.isfinite(min_duration)
            and min_duration >= 0
        ):
            raise ValueError(
                f"{owner}: min_duration must be None or a finite number >= 0 [s]; got "
                f"{min_duration!r}."
            )
        return cls(
            float(jitter_tolerance), bool(resample), int(fill_gaps), min_duration
        )


@dataclass(frozen=True)
class Repaired:
    """A uniformly sampled log before it gets its joint names.

    Attributes: as :class:`drake_dynid.logs.RobotLog`.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    time_step: float
    warnings: tuple[str, ...]
    time_offset: float
    filled: np.ndarray


def rows_text(noun: str, labels: Sequence[int], limit: int = 4) -> str:
    """'row 12', 'rows 3, 8', 'rows 101 to 30001, every 100', 'rows 3, 9, ... (40)'."""
    labels = sorted(int(x) for x in labels)
    if len(labels) == 1:
        return f"{noun} {labels[0]}"
    steps = set(np.diff(labels).tolist())
    if len(labels) > limit and len(steps) == 1:
        step = steps.pop()
        every = "" if step == 1 else f", every {step}"
        return f"{noun}s {labels[0]} to {labels[-1]}{every}"
    if len(labels) <= limit:
        return f"{noun}s {', '.join(map(str, labels))}"
    head = ", ".join(map(str, labels[: limit - 1]))
    return f"{noun}s {head}, ..., {labels[-1]} ({len(labels)} in all)"


def _seconds(owner, t, exact) -> tuple[np.ndarray, float, list[str]]:
    """Time stamps in seconds relative to a base, the base [s], and a note.

    ``exact``: (N,) int64 stamps as written (integer nanoseconds), or None. A
    stored t (a long log) is checked a block at a time and loaded only when its
    stamps are epoch nanoseconds.
    """
    if is_stored(t):
        low, high = math.inf, -math.inf
        for _, block in blocks(t):
            block = block[np.isfinite(block)]
            if block.size:
                low, high = min(low, float(block.min())), max(high, float(block.max()))
        if low > high or max(abs(low), abs(high)) < MAX_SECONDS:
            return t, 0.0, []
        t = np.asarray(t)
    finite = np.isfinite(t)
    if not finite.any():
        return t, 0.0, []
    if finite.all():  # no copy of t
        big = max(abs(float(t.max())), abs(float(t.min())))
    else:
        big = float(np.max(np.abs(t[finite])))
    if big < MAX_SECONDS:
        return t, 0.0, []
    if float(t[finite].min()) < NANOSECONDS:
        raise ValueError(
            f"{owner}: time stamps up to {big:.6g} cannot be seconds (year > 5000); "
            "t must be in seconds (integers >= 1e17 are read as nanoseconds since "
            "the epoch)."
        )
    first = int(np.flatnonzero(finite)[0])
    s = np.full(t.size, np.nan)
    if exact is not None:
        base = int(exact[first])
        s[finite] = (exact[finite] - base).astype(float) * 1e-9
    else:
        base = int(t[first])
        s[finite] = (t[finite] - t[first]) * 1e-9
    note = (
        f"time stamps read as integer nanoseconds since the epoch (t = {base}); "
        "converted to seconds."
    )
    return s, base * 1e-9, [note]


def stamps_droppable(bad: int, count: int) -> bool:
    """Whether ``bad`` empty or non-finite stamps of ``count`` rows may be dropped.

    At most 3 + 1 in 1000 of them (``core.timestamps``' outlier limit), with at
    least 10 rows left; else the reader names the first and stops.
    """
    return bad <= 3 + count // 1000 and count - bad >= 10


def repair(
    owner,
    noun,
    t,
    exact,
    q,
    tau,
    labels,
    options,
    notes=(),
    bad=None,
    joined=None,
    *,
    unit_given=False,
):
    """Time stamps → uniform grid → filled or bad samples.

    Args:
        owner: prefix of the messages (``log PATH``).
        noun: what a label counts (``row`` of a file, ``sample`` of arrays).
        t: (N,) time stamps as read [s, or ns when >= 1e17].
        exact: (N,) int64 stamps as written (integer nanoseconds), or None.
        q: (N, n) joint positions [rad or m]: an array, or a stored array
            (``drake_dynid.log_store``) read a block at a time.
        tau: (N, n) joint torques [N·m or N], likewise.
        labels: (N,) int label of each sample in messages.
        options: the checked options.
        notes: warnings of the earlier layers.
        bad: (N,) bool, True where a q or tau cell is not finite (None: computed).
        joined: ``(filled, kept_bad)``, (N,) bool each, or None: samples of a
            multi-file log inside a gap of a joined file (``drake_dynid.raw_log``),
            decided in that file's own samples: of up to ``fill_gaps`` of them
            (values interpolated by the join: counted as filled), or longer (NaN:
            kept bad, however short their run in these samples).
        unit_given: the caller was told the time unit (``--time-unit``, a drive
            file's ``[log] time_unit``, ``read_log``'s ``time_unit``; a ROS bag's
            ns): a step >= ``SLOW_STEP`` is then a warning, else an error.

    Returns:
        The :class:`Repaired` log; its q and tau are stored arrays when larger
        than ``drake_dynid.log_store.SPILL_BYTES`` (t then a ``GridTimes``).
    """
    warnings = list(notes)
    shown = t
    t, base, epoch_note = _seconds(owner, t, exact)  # [] unless epoch ns
    warnings += epoch_note
    bad = _bad(q, tau) if bad is None else bad
    soft = hard = None  # no joined file: no masks (a plain log's memory)
    if joined is not None:
        soft, hard = (np.asarray(mask, dtype=bool) for mask in joined)
    index = None  # working sample -> row of q and tau (None: the same row)
    bad_t = np.concatenate(
        [start + np.flatnonzero(~np.isfinite(block)) for start, block in blocks(t)]
    ).astype(np.int64)
    if bad_t.size:
        first = int(bad_t[0])
        if not stamps_droppable(bad_t.size, t.size):
            raise ValueError(
                f"{owner}: the time stamp of {noun} {labels[first]} is empty or not "
                f"finite (got {shown[first]})."
            )
        warnings.append(
            f"dropped {rows_text(noun, labels[bad_t])}: time stamp empty or not finite."
        )
        t = shown = np.asarray(t)
        keep = np.isfinite(t)
        index = np.flatnonzero(keep)
        t, shown, labels, bad = t[keep], shown[keep], labels[keep], bad[keep]
        if soft is not None and hard is not None:
            soft, hard = soft[keep], hard[keep]
    if t.size < 2:
        raise ValueError(f"{owner}: needs at least 2 samples; got {t.size}.")
    i = _repeated(t)
    if i:
        raise ValueError(
            f"{owner}: duplicated time stamp at {noun} {labels[i]} (t = {shown[i]:.16g}"
            f", the same as {noun} {labels[i - 1]})."
        )

    def where(i: int) -> str:
        return f"{noun} {labels[i]} (t = {shown[i]:.16g})"

    i = _swapped(t)
    if i:  # not one corrupted stamp (an outlier, dropped below): unsorted rows
        raise ValueError(
            f"{owner}: time stamps are not increasing at {where(i)} after "
            f"{where(i - 1)}: the two are in the wrong order; sort the log by time."
        )

    part = None  # (N,) int: the part of each sample between restarts (None: one)
    if joined is None:  # a joined file's parts are on their own grids (raw_log)
        t, part, restart_notes = _restarts(t, shown, labels, noun)
        warnings += restart_notes

    grid: TimeGrid | None = None
    try:
        grid = fit_time_grid(
            t,
            options.jitter_tolerance,
            edge_gap=options.fill_gaps,
            owner=owner,
            where=where,
        )
    except NonUniformSampling as error:
        if not options.resample:
            raise
        kept, step, reason = error.kept, error.step, "non-uniform sampling"
    if grid is not None:
        kept, step = grid.kept, grid.fitted_step
        reason = "jittered time stamps"
    if not step >= FAST_STEP:
        raise ValueError(
            f"{owner}: the time step is {step:.6g} s, too short for a robot log (1e-4 "
            f"to 0.1 s; at least {FAST_STEP:g} s): t must be in seconds, or in the "
            "unit that --time-unit (or a drive file's [log] time_unit, docs/DRIVE.md) "
            "gives; check that unit."
        )
    if step >= SLOW_STEP and not unit_given:
        raise ValueError(f"{owner}: {_slow_step_text(step, epoch=bool(epoch_note))}")
    if kept.sum() < kept.size:
        out = np.flatnonzero(~kept)
        times = ", ".join(f"{shown[i]:.16g}" for i in out[:3])
        warnings.append(
            f"dropped {rows_text(noun, labels[out])} (t = {times}"
            f"{', ...' if out.size > 3 else ''}): time stamp(s) off the grid of the "
            "other samples (outliers)."
        )
        rows = np.flatnonzero(kept)
        index = rows if index is None else index[rows]
        t, shown = np.asarray(t)[kept], np.asarray(shown)[kept]
        labels, bad = labels[kept], bad[kept]
        if soft is not None and hard is not None:
            soft, hard = soft[kept], hard[kept]
        if part is not None:
            part = part[kept]
    jitter = 0.0 if grid is None else grid.jitter
    if options.resample and (grid is None or jitter > REPORTED_JITTER):
        log = _resampled(
            owner,
            noun,
            np.asarray(t),
            (q, tau, index, bad),
            labels,
            step,
            grid,
            options,
            warnings,
            reason,
            (soft, hard),
            part,
        )
    else:
        assert grid is not None
        log = _snapped(
            owner,
            noun,
            grid,
            (q, tau, index, bad),
            labels,
            shown,
            options,
            warnings,
            (soft, hard),
            part,
        )
    samples = log.t.size
    duration = (samples - 1) * log.time_step
    unit_hint = _unit_hint(log.time_step) if unit_given else ""
    if unit_hint:
        warnings.append(unit_hint)
    if options.min_duration is not None and duration < options.min_duration:
        raise ValueError(
            f"{owner}: the log lasts {duration:.6g} s ({samples} samples of "
            f"{log.time_step:.6g} s); at least {options.min_duration:.6g} s are needed."
            + (f" ({unit_hint})" if unit_hint else "")
        )
    return Repaired(
        log.t,
        log.q,
        log.tau,
        log.time_step,
        tuple(warnings),
        base + log.time_offset,
        log.filled,
    )


#: A fitted step at or above this [s] is an error unless the time unit was given
#: (then a warning): robot logs are sampled at 10 Hz to 10 kHz; stamps in ms, µs or
#: ns read as seconds give 1 s and more.
SLOW_STEP = 0.5
#: A fitted step below this [s] is an error: no robot logger samples at 100 kHz, and
#: 1/h (the cutoff choice's sampling frequency) overflows for subnormal steps;
#: stamps in seconds read with --time-unit ms give 1e-6 s at 1 kHz.
FAST_STEP = 1e-5


def _likely_unit(step: float) -> str:
    """The units in which ``step`` [s] is a robot's step, with the rates they give.

    Each of ms, us, ns giving 1e-4 s to under ``SLOW_STEP``, e.g. ``ms gives
    1000 Hz`` for 1.0, ``ms gives 5 Hz or us gives 5000 Hz`` for 200 ('' if
    none): a 5 Hz log in ms and a 5 kHz log in µs read alike.
    """
    from drake_dynid.core.drive_log import TIME_UNITS

    return " or ".join(
        f"{unit} gives {1.0 / (step * TIME_UNITS[unit]):.4g} Hz"
        for unit in ("ms", "us", "ns")
        if 1e-4 <= step * TIME_UNITS[unit] < SLOW_STEP
    )


def _slow_step_text(step: float, epoch: bool = False) -> str:
    """The error on a step >= ``SLOW_STEP`` [s] whose unit was not given.

    ``epoch``: the stamps were read as integer nanoseconds since the epoch, so no
    other unit is likely; the message says how to confirm the rate.
    """
    rate = f"{1.0 / step:.4g} Hz"
    head = (
        f"the time step is {step:.6g} s ({rate}), long for a robot log "
        "(1e-4 to 0.1 s: 10 Hz to 10 kHz)"
    )
    if epoch:
        return (
            f"{head}, the stamps read as integer nanoseconds since the epoch: if the "
            f"log is truly sampled at {rate}, say so with --time-unit ns (read_log's "
            "time_unit, or a drive file's [log] time_unit, docs/DRIVE.md)."
        )
    likely = _likely_unit(step)
    unit = " or ".join(part.split(" ", 1)[0] for part in likely.split(" or "))
    unit = unit or "UNIT"
    return (
        f"{head}: the time column is likely not in seconds"
        + (f" ({likely})" if likely else "")
        + f"; say its unit with --time-unit {unit} (read_log's time_unit, or a "
        "drive file's [log] time_unit, docs/DRIVE.md), or --time-unit s if the log "
        f"is truly sampled at {rate}."
    )


def _unit_hint(step: float) -> str:
    """A warning when the step suggests time stamps in another unit ('' if not)."""
    if step < SLOW_STEP:
        return ""
    return (
        f"the time step is {step:.6g} s, long for a robot log (1e-4 to 0.1 s), "
        "with the time unit given: if the time column is in ms, us or ns, say so "
        "with --time-unit (or a drive file's [log] time_unit, docs/DRIVE.md)."
    )


def _repeated(t) -> int:
    """The first i with t[i] == t[i - 1] (0: none), a block at a time."""
    previous = None
    for start, block in blocks(t):
        steps = np.diff(block if previous is None else np.r_[previous, block])
        same = np.flatnonzero(steps == 0.0)
        if same.size:  # steps[k] ends at sample start + k (+ 1 in the first block)
            return start + int(same[0]) + (1 if previous is None else 0)
        previous = block[-1]
    return 0


def _swapped(t) -> int:
    """The first i where samples i - 1 and i are swapped (0: none), by blocks.

    Swapped: t[i] < t[i - 1], and the other way round they are in order among
    their neighbours (t[i - 2] < t[i], t[i - 1] < t[i + 1] where these exist):
    unsorted rows, which the drive reader refuses as well (``raw_log``), not one
    corrupted stamp (``t = 1e6`` or ``-5`` amid good ones: an outlier). Only the
    steps going back (few) are looked at closely.
    """
    n = len(t)
    for start in range(0, n, BLOCK_ROWS):
        lo, hi = max(0, start - 2), min(n, start + BLOCK_ROWS + 1)
        part = np.asarray(t[lo:hi], dtype=float)
        back = np.flatnonzero(part[1:] < part[:-1]) + 1 + lo  # t[i] < t[i - 1]
        back = back[(back >= max(start, 1)) & (back < start + BLOCK_ROWS)]
        if back.size == 0:
            continue
        here, before = part[back - lo], part[back - 1 - lo]
        earlier = np.where(back >= 2, part[np.maximum(back - 2, lo) - lo], -np.inf)
        later = np.where(back + 1 < n, part[np.minimum(back + 1, hi - 1) - lo], np.inf)
        found = np.flatnonzero((earlier < here) & (before < later))
        if found.size:
            return int(back[found[0]])
    return 0


def _rows_of(values, index, a: int, b: int) -> np.ndarray:
    """Working samples [a, b) of an array or a stored array (``index``: their rows)."""
    if index is None:
        return np.asarray(values[a:b], dtype=float)
    rows = index[a:b]
    if rows.size == 0:
        return np.empty((0, values.shape[1]))
    span = np.asarray(values[int(rows[0]) : int(rows[-1]) + 1], dtype=float)
    return span[rows - rows[0]]


def _check_filled(owner, count: int, total: int, what: str) -> None:
    """Filling more than 5 % of the samples is an error."""
    if count > MAX_FILLED_FRACTION * total:
        raise ValueError(
            f"{owner}: {count} of {total} samples "
            f"({100 * count / total:.3g} %) would be interpolated ({what}); "
            "filling more than "
            f"{100 * MAX_FILLED_FRACTION:g} % would invent data: repair the log, or "
            "keep them as bad samples that the windows skip (--fill-gaps 0; "
            "read_log(..., fill_gaps=0))."
        )


def _bad_cells_note(noun, labels, bad_before, bad_after, fill_gaps) -> str:
    count = int(bad_before.sum())
    kept_bad = int((bad_before & bad_after).sum())
    where = rows_text(noun, labels[bad_before])
    return (
        f"{count} sample(s) with an empty, NaN or infinite q/tau cell ({where}): "
        f"{count - kept_bad} filled by interpolation (runs of up to {fill_gaps} "
        f"samples), {kept_bad} kept as bad samples (longer runs; the windows "
        "containing them are flagged invalid)."
    )


def _bad(q, tau) -> np.ndarray:
    """(N,) bool: a non-finite q or tau cell (a block of rows at a time)."""
    out = np.empty(len(q), bool)
    for start in range(0, len(q), BLOCK_ROWS):
        stop = start + BLOCK_ROWS
        a, b = np.asarray(q[start:stop]), np.asarray(tau[start:stop])
        finite = np.all(np.isfinite(a), axis=1) & np.all(np.isfinite(b), axis=1)
        out[start:stop] = ~finite
    return out


def _placed(grid, samples, options, kept_bad):
    """q, τ on the grid with the short runs filled, a chunk of slots at a time.

    ``kept_bad``: (num_slots,) bool, slots never filled (nor a run holding one),
    or None.

    Slot chunks of :data:`_PLACE_SLOTS` with ``fill_gaps + 2`` slots of margin on
    each side: a run of at most ``fill_gaps`` missing slots and the four nodes
    of its cubic lie inside, so each chunk is filled exactly as the whole grid
    would be (``fill_short_runs``). Returns (q, tau, filled, bad after) with
    q and τ arrays or stored arrays (``log_store.RowSink``).
    """
    q, tau, index, _ = samples
    total, slots = grid.num_slots, grid.slots
    n = q.shape[1]
    margin = options.fill_gaps + 2
    # A stored log stays stored (beyond log_store.SPILL_BYTES); arrays stay arrays.
    limit = None if is_stored(q) or is_stored(tau) else math.inf
    sinks = RowSink(n, limit), RowSink(n, limit)
    filled = np.zeros(total, bool)
    bad_after = np.zeros(slots.size, bool)
    for g0 in range(0, total, _PLACE_SLOTS):
        g1 = min(total, g0 + _PLACE_SLOTS)
        lo, hi = max(0, g0 - margin), min(total, g1 + margin)
        j0, j1 = np.searchsorted(slots, [lo, hi])
        k0, k1 = np.searchsorted(slots, [g0, g1])
        core = slice(g0 - lo, g1 - lo)
        masks = []
        for values, sink, cubic in zip((q, tau), sinks, (True, False), strict=True):
            block = np.full((hi - lo, n), np.nan)
            block[slots[j0:j1] - lo] = _rows_of(values, index, j0, j1)
            block, mask = fill_short_runs(
                block,
                options.fill_gaps,
                cubic=cubic,
                keep=None if kept_bad is None else kept_bad[lo:hi],
            )
            sink.append(block[core])
            masks.append(mask[core])
            bad_after[k0:k1] |= ~np.all(np.isfinite(block[slots[k0:k1] - lo]), axis=1)
        filled[g0:g1] = np.any(masks[0], axis=1) | np.any(masks[1], axis=1)
    return sinks[0].finish(), sinks[1].finish(), filled, bad_after


def _restarts(t, shown, labels, noun):
    """Stamps with each restart's later part moved onto the earlier part's grid.

    A gap whose length is not a whole number of steps (``core.timestamps.
    phase_breaks``: a logger paused and resumed, a clock stepped forward) would
    put the later stamps half a step off any grid: snapped (timing wrong by up to
    half a step), or refused as non-uniform. The later stamps are moved by the
    gap's missing fraction of a step (always later: at least one slot stays
    empty at the break); ``_snapped`` and ``_resampled`` never fill across a
    break, so the log is split there. Returns (t, part, notes): part the (N,)
    index of each sample's part, or None without a break.
    """
    indices, shifts, h = phase_breaks(t)
    if indices.size == 0:
        return t, None, []
    t = np.asarray(t, dtype=float)
    start = np.zeros(t.size, bool)
    start[indices + 1] = True
    part = np.cumsum(start)
    before = t[indices + 1] - t[indices]
    moved = np.zeros(t.size)
    moved[indices + 1] = shifts
    t = t + np.cumsum(moved)
    notes = []
    for i, gap, shift in zip(indices[:3], before[:3], shifts[:3], strict=False):
        notes.append(
            f"a gap of {gap * 1e3:.6g} ms, {gap / h - 1.0:.6g} steps of {h:.6g} s, "
            f"between {noun} {labels[i]} and {noun} {labels[i + 1]} (t = "
            f"{shown[i]:.16g} to {shown[i + 1]:.16g}): the logger restarted or its "
            "clock stepped; the parts are read on their own grids (same step, the "
            f"later one placed {shift * 1e3:.3g} ms later), the gap never filled: "
            "the log is split there."
        )
    if indices.size > 3:
        notes.append(f"{indices.size - 3} more such gap(s) split the log.")
    return t, part, notes


def _snapped(
    owner, noun, grid, samples, labels, shown, options, warnings, joined, part=None
):
    """Samples placed on their grid slots; dropped samples and bad cells filled.

    ``samples`` = (q, tau, index, bad): the read rows (arrays or stored arrays),
    the row of each kept sample (None: the same), and its bad-cell flags;
    ``joined`` = (filled, kept_bad) of each kept sample (``repair``; None each
    without a joined file).
    """
    total, slots = grid.num_slots, grid.slots
    h = grid.step
    jitter = grid.jitter
    if jitter > REPORTED_JITTER:
        warnings.append(
            f"time stamp jitter up to {jitter * h:.3g} s ({100 * jitter:.3g} % of the "
            f"step {h:.6g} s); time stamps snapped to the uniform grid fitted by least "
            f"squares (tolerance {100 * options.jitter_tolerance:g} %)."
        )
    q, tau, index, bad_before = samples
    soft, hard = joined
    breaks = np.zeros(total, bool)  # empty slots of a restart: never filled
    if part is not None:
        for j in np.flatnonzero(np.diff(part)):
            breaks[slots[j] + 1 : slots[j + 1]] = True
    if index is None and total == slots.size and not bad_before.any():
        filled = np.zeros(total, bool)  # every slot read, every cell finite
        if soft is not None:
            filled[slots[soft]] = True
            _check_filled(owner, int(filled.sum()), total, "gaps of joined files")
    else:
        kept_bad = None
        if hard is not None and hard.any():
            kept_bad = np.zeros(total, bool)
            kept_bad[slots[hard]] = True
        if breaks.any():
            kept_bad = breaks if kept_bad is None else kept_bad | breaks
        q, tau, filled, bad_after = _placed(grid, samples, options, kept_bad)
        if soft is not None:
            filled[slots[soft]] = True
        _check_filled(
            owner,
            int(filled.sum()),
            total,
            "dropped samples, bad cells and gaps of joined files",
        )
        if bad_before.any():
            warnings.append(
                _bad_cells_note(noun, labels, bad_before, bad_after, options.fill_gaps)
            )
    if total > slots.size:  # slots increase from 0: gaps iff the last exceeds
        gaps = np.diff(slots) - 1
        missing = np.ones(total, bool)
        missing[slots] = False
        count = int(missing.sum())
        done = int((missing & filled).sum())
        g = int(np.argmax(gaps))
        warnings.append(
            f"{count} dropped sample(s) (missing time stamps) in "
            f"{int(np.count_nonzero(gaps))} gap(s) (the longest: {int(gaps[g])} "
            f"sample{'s' if gaps[g] > 1 else ''} "
            f"between {noun} {labels[g]} and {noun} {labels[g + 1]}, t = "
            f"{shown[g]:.16g} to {shown[g + 1]:.16g}): {done} filled by interpolation "
            f"(gaps of up to {options.fill_gaps} samples: cubic for q, linear for "
            f"tau), {count - done} inserted as bad samples (the windows containing "
            "them are flagged invalid)."
        )
    t = GridTimes(h, total) if is_stored(q) else h * np.arange(total)
    return Repaired(t, q, tau, h, (), grid.origin, filled)


def _resampled(
    owner,
    noun,
    s,
    samples,
    labels,
    step,
    grid,
    options,
    warnings,
    reason,
    joined,
    part=None,
):
    """Linear interpolation from the stamps onto the fitted uniform grid.

    ``samples`` = (q, tau, index, bad): the read rows (arrays or stored arrays),
    the row of each working sample (None: the same) and its bad-cell flags; ``s``
    the working samples' stamps; ``joined`` = (filled, kept_bad) of each working
    sample (``repair``): a grid sample next to a filled one is bridged, none is
    interpolated across a kept-bad one. The grid is filled :data:`_PLACE_SLOTS` samples
    at a time from the working samples around them, ``fill_gaps + 2`` of margin
    on each side: a neighbour further away has more than ``fill_gaps`` bad
    samples before it, so the grid sample is bad either way, and every chunk is
    what the whole grid would be. A stored log stays stored (bounded memory).
    """
    q, tau, index, bad_before = samples
    soft, hard = joined
    # Kept-bad working samples up to each one (None: no joined file).
    hard_count = None if hard is None else np.cumsum(hard)
    zero = float(s[0])
    s = s - zero  # precision with epoch stamps
    if grid is not None:
        origin, h = grid.origin - zero, grid.step
    else:
        span = float(s[-1])
        h = nominal_step(span / max(1, round(span / step)), RESAMPLE_ROUNDING)
        origin = 0.0
    k0 = math.ceil((s[0] - origin) / h - 1e-9)
    k1 = math.floor((s[-1] - origin) / h + 1e-9)
    count = k1 - k0 + 1
    if count > 2 * s.size or count < 2:
        raise ValueError(
            f"{owner}: resampling onto a grid of step {h:.6g} s would give {count} "
            f"samples from {s.size} rows; the time stamps are too irregular to "
            "resample."
        )
    n = q.shape[1]
    limit = None if is_stored(q) or is_stored(tau) else math.inf
    sinks = RowSink(n, limit), RowSink(n, limit)
    bridged = np.zeros(count, bool)
    longest = (options.fill_gaps + 1) * h
    margin = options.fill_gaps + 2
    bad_after = 0
    for c0 in range(0, count, _PLACE_SLOTS):
        c1 = min(count, c0 + _PLACE_SLOTS)
        times = origin + h * np.arange(k0 + c0, k0 + c1)
        a = max(0, int(np.searchsorted(s, times[0], side="right")) - 1 - margin)
        b = min(s.size, int(np.searchsorted(s, times[-1], side="left")) + 1 + margin)
        values = np.hstack([_rows_of(q, index, a, b), _rows_of(tau, index, a, b)])
        out = np.full((c1 - c0, 2 * n), np.nan)
        for j in range(2 * n):
            finite = np.flatnonzero(np.isfinite(values[:, j]))
            if finite.size < 2:
                continue
            xs = s[a:b][finite]
            right = np.clip(np.searchsorted(xs, times, side="right"), 1, xs.size - 1)
            left = right - 1
            skipped = finite[right] - finite[left] - 1
            gap = xs[right] - xs[left]
            inside = (times >= xs[0]) & (times <= xs[-1])
            ok = inside & (skipped <= options.fill_gaps)
            ok &= gap <= longest * (1 + 1e-9)
            before, after = a + finite[left], a + finite[right]
            if hard_count is not None:
                ok &= hard_count[after] == hard_count[before]
            if part is not None:  # never across a restart
                ok &= part[after] == part[before]
            out[ok, j] = np.interp(times[ok], xs, values[finite, j])
            bridge = (skipped > 0) | (gap > 1.5 * h)
            if soft is not None:
                bridge |= soft[before] | soft[after]
            bridged[c0:c1] |= ok & bridge
        sinks[0].append(out[:, :n])
        sinks[1].append(out[:, n:])
        bad_after += int(_bad(out[:, :n], out[:, n:]).sum())
    q_grid, tau_grid = sinks[0].finish(), sinks[1].finish()
    if bridged.sum() > MAX_FILLED_FRACTION * count:
        raise ValueError(
            f"{owner}: {int(bridged.sum())} of {count} resampled samples bridge gaps "
            f"or bad cells; more than {100 * MAX_FILLED_FRACTION:g} % would invent "
            "data: repair the log."
        )
    if bad_before.any():
        warnings.append(
            f"{int(bad_before.sum())} sample(s) with an empty, NaN or infinite q/tau "
            f"cell ({rows_text(noun, labels[bad_before])}): interpolated over when "
            f"in runs of up to {options.fill_gaps} samples, else the resampled "
            "samples around them are bad."
        )
    warnings.append(
        f"{reason}: resampled by linear interpolation onto a uniform grid of step "
        f"{h:.6g} s ({count} samples); {bad_after} bad, "
        f"{int(bridged.sum())} interpolated across more than 1.5 steps between "
        "stamps or across bad cells."
    )
    t = GridTimes(h, count) if is_stored(q_grid) else h * np.arange(count)
    return Repaired(t, q_grid, tau_grid, h, (), origin + h * k0 + zero, bridged)
