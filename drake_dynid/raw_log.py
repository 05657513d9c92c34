"""Raw robot logs: one or several CSV files read through a drive chain (docs/DRIVE.md).

A real recording is rarely one file of joint angles and torques: ROS gives positions
and efforts in separate files, with their own time stamps, motor-side units and
currents. :func:`read_raw_log` reads such a log:

1. every file's header (a CSV header row; a UTF-8 byte-order mark is dropped) and
   the columns the drive chain needs (``DriveChain.required_columns()``: time,
   positions, torques; extra columns are not parsed, one warning counts them);
2. with several files, joins them on their time column (the drive file's
   ``[log] time``, the same name and unit in every file): the first file's stamps
   are the time base; each other file's columns are interpolated linearly onto
   the first file's stamps inside the common time span (rows of the first file
   outside it are dropped), with a warning naming the file; a file whose stamps
   equal the first file's is taken as is. A gap of another file (slots of its
   own grid between two of its stamps that no stamp took, read from the
   stamps' phases, late stamps told from drops, a buffered publisher's bursts
   counted by burst, each part of a file whose rate changes on its own grid:
   samples of that file missing, :func:`_missing`, with a note naming the
   bursts or the rates) is counted in that file's own samples, as
   ``fill_gaps`` counts a gap of one file: the first-file stamps inside a gap
   of up to ``fill_gaps`` of its samples keep the join's linear interpolation
   and are flagged filled; inside a longer one they get no value (NaN) and
   stay bad samples, however few of them the first file has there (never a
   straight line drawn across the gap);
3. ``DriveChain.convert``: units, motor side, currents, offsets, time origin;
4. the uniform-grid checks and repairs of ``drake_dynid.logs`` (jitter, dropped
   samples, ``resample``: ``drake_dynid.log_repair.repair``).

Everything is streamed (:func:`_read_streamed`): each file is parsed by the plain
reader's block parser (``drake_dynid.log_table``), the join, the conversion and the
repair run a block at a time on row stores. Memory: a few blocks and the stamps (8
bytes a row of each file): a 3.6 M-sample 8-joint TIAGo drive log, 216 MB peak in
one file and 270 MB in two (1.7 GB when read whole); messages name the first
file's rows. :func:`read_raw_table` is the whole-column join (the reference).

:func:`write_raw_log` writes the inverse: joint signals in a drive chain's raw
columns (``DriveChain.to_columns``), one file that :func:`read_raw_log` reads back
(``dynid simulate --drive``).

Errors are ``ValueError`` (``OSError`` for a missing file) whose message names the
file, the column and the row: a needed column found in no file (naming the drive
file's ``[log]`` key to fix), or in two files, a file without the time column, a
non-numeric cell, unsorted time stamps of a joined file, files that do not overlap
in time. The first file's stamps (the time base) go to the plain reader's checks
(``repair``): an isolated corrupted stamp (``1e6``, going back, NaN) is dropped
with its warning, the join bridging it (:func:`_join_stamps`); swapped rows are
refused. A joined file's empty or NaN stamp is dropped too, with a note
(:func:`_drop_empty_stamps`).
"""

from __future__ import annotations

import csv
import itertools
import math
import os
import warnings as warnings_module
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import minimum_filter1d

from drake_dynid.core import blocks as _blocks
from drake_dynid.core._validate import listed
from drake_dynid.core.drive import DriveChain
from drake_dynid.files import (
    incomplete_export,
    refuse_incomplete,
    repeated_file,
    write_whole,
)
from drake_dynid.log_repair import (
    FILL_GAPS,
    JITTER_TOLERANCE,
    Options,
    rows_text,
    stamps_droppable,
)
from drake_dynid.log_table import (
    listed_columns,
    parse_cell,
    read_header,
    unused_columns,
)

__all__ = ["RawTable", "read_raw_log", "read_raw_table", "write_raw_log"]

#: A joined (not first) file's grid phase is read over blocks of this many of
#: its stamps (:func:`_cuts`), each judged with this many stamps either side.
SLOT_BLOCK = 32
SLOT_CONTEXT = 16
#: The widest empty arcs of a block's stamp phases tried as its slot border.
CUTS = 8
#: The first guesses of a joined file's step: its median step and its median
#: mean steps over these many intervals (bursts and catch-ups average out over
#: 8 and 120; :func:`_file_step`).
STEP_SPANS = (1, 8, 120)
#: An arc narrower than this share of the block's widest is no slot border
#: (stamps without jitter: a border between two phases 0.02 step apart
#: in one block and across the arc in the next hid a drop in the shift).
ARC_SHARE = 0.05
#: Least-squares refits of each guess on its slots, at most.
REFITS = 4
#: Grids whose stamps sharing a slot and slots inserted exceed the fewest by
#: up to this share (and 2) are compared by their fit to the stamps.
SPAN_SLACK = 0.05
#: A grid's gap counts as at most this many slots inserted in its cost
#: (:func:`_span`): a pause of a minute in 300 stamps at 1 kHz made a grid of
#: a 0.5 s step, its stamps all sharing slots (82 samples missing for 60 000,
#: the drops lost), cheaper than the file's own (60 000 slots inserted).
GAP_CAP = 64
#: A file of up to this many stamps also tries steps within ±3 % of its first
#: guess, 0.1 % apart (a drop beside late stamps moves a short file's fit).
SHORT_FILE = 256
#: A grid from which the stamps lie this share of its step or less (RMS),
#: without two in one slot and its step at least 3/4 of the mean step, is
#: chosen over the others (of such, the fewest slots inserted): stamps without
#: jitter (a simulated log) with 3 drops in 400 were counted on a grid 3 steps
#: coarser, whose phase drift hid the drops.
TIGHT = 0.15
#: Blocks of :data:`SLOT_BLOCK` stamps handled at a time (bounded temporaries).
_SLOT_CHUNK = 1 << 10


def _file_step(stamps: np.ndarray, span: int = 8) -> float:
    """A joined file's step guess: the median of its mean steps over ``span`` intervals.

    0 with fewer than 2 stamps.
    """
    span = min(span, stamps.size - 1)
    if span < 1:
        return 0.0
    return float(np.median((stamps[span:] - stamps[:-span]) / span))


def _grid_missing(stamps: np.ndarray) -> tuple[np.ndarray, int, float]:
    """(missing, shared, h): the samples missing in each interval of one grid.

    ``missing``: (len(stamps) - 1,) int; ``shared``: how many stamps share a
    slot with the one before them on the grid chosen, 0 within the bound below
    (every case of ``tests/test_raw_log.py`` and of two reviews' measurements),
    more beyond it: a note says so (:func:`_beyond_note`); ``h``: the grid's
    step [s] (0: fewer than 2 stamps). :func:`_missing` calls it on each part
    of a file at one rate, on the stamps of a bursty one spread back over
    their burst's span.

    The file's samples were taken on a grid t_j = c + h·k_j + e_j, each stamp
    late or early by e_j; a drop is a slot k not taken: interval i misses
    k_(i+1) - k_i - 1 samples. The slots are read from the stamps' phases
    x_j = (t_j - t_0)/h mod 1, which a drop leaves as they were (:func:`_slots`,
    :func:`_cuts`): in each block of :data:`SLOT_BLOCK` stamps the slot border
    φ is the middle of one of the widest empty arcs of the phases of its stamps
    and :data:`SLOT_CONTEXT` either side, the one whose slots k_j = ⌊(t_j -
    t_0)/h - φ⌋ put fewest two stamps in one slot, then insert fewest (a border
    among the late stamps puts a late one and the next in one slot at each
    catch-up); φ is unwrapped from block to block (a slow drift of the phase).
    The step h: each first guess (:func:`_step_guesses`) refitted by least
    squares on its slots (up to :data:`REFITS` times); of those whose stamps
    sharing a slot and slots inserted number at most :data:`SPAN_SLACK` more
    than the fewest (a finer grid inserts a slot every few stamps), the one
    closest to the stamps (RMS, :func:`_misfit`: a slightly coarser grid can
    hide a drop in a drift of its phase), unless a grid fits them within
    :data:`TIGHT` of its step without two in one slot (not finer than 3/4 of
    the mean step): of those the one inserting the fewest slots. Two stamps
    left in one slot (stamps off beyond the bound below) cancel samples counted
    missing up to :data:`SLOT_CONTEXT` intervals away.

    Bound: every drop is counted once, in its interval, and a log without one
    has none, when the stamps' offsets e_j from the grid span less than one
    step over the :data:`SLOT_BLOCK` + 2·:data:`SLOT_CONTEXT` stamps around
    each block (±45 % jitter; stamps up to 0.8 step late, 3 or 4 in a row
    later and later, then one on time; every 4th stamp 0.75 step late; pairs
    0.1 step apart), the phase drifting less than a quarter step over them,
    and, where they span more than half a step, a late stamp followed by an
    earlier one in each such window (the order that tells a late stamp from a
    drop; ``tests/test_raw_log.py`` drops every sample in turn). Beyond it (a
    file of a dozen stamps, one drop in ten beside late stamps, ±70 % jitter)
    a drop may be missed or placed an interval off (bursts and a rate change
    are handled before, :func:`_missing`). There stamps share a slot of the
    chosen grid (none within the bound), and the reader names the file in a
    note (:func:`_beyond_note`). Memory: the slots (8 bytes a stamp) and a
    chunk's windows (a 3.6 M-stamp file: 88 MB peak, as before; 1.0-1.3 s CPU,
    1.5-2.3 s when the chosen grid's slots were read again, 0.1 s before
    phases were read, :func:`_cancel_shared`).
    """
    missing = np.zeros(max(stamps.size - 1, 0), np.int64)
    if stamps.size < 2:
        return missing, 0, 0.0
    found: list[tuple[int, int, float, float]] = []  # shared, span, misfit, h
    first: np.ndarray | None = None  # the first grid's slots (reused if chosen)
    for step in _step_guesses(stamps):
        if not step > 0.0 or any(abs(step - f[3]) < 1e-4 * f[3] for f in found):
            continue  # refits to a step already tried
        slots = _slots(stamps, step)
        for _ in range(REFITS):  # the step refitted on its slots
            fitted = _fitted_step(stamps, slots)
            if not fitted > 0.0 or abs(fitted - step) < 1e-9 * step:
                break  # converged: the slots are this step's
            step = fitted
            slots = _slots(stamps, step)
        span = _span(slots)
        found.append((_shared(slots), span, _misfit(stamps, slots, step), step))
        first = slots if len(found) == 1 else None
        del slots
    if not found:
        return missing, 0, 0.0
    # The fewest stamps sharing a slot and slots inserted (a finer grid inserts a
    # slot every few stamps); of the grids about as good, the one closest to the
    # stamps (a slightly coarser one hides a drop in a drift of its phase).
    least = min(_cost(f, stamps.size) for f in found)
    slack = SPAN_SLACK * abs(least) + 2  # least < 0: spread stamps going back
    near = [f for f in found if _cost(f, stamps.size) <= least + slack]
    chosen = min(near, key=lambda f: f[2])
    # A grid the stamps fit closely, without two in one slot, and not finer than
    # the mean step: its slots inserted are drops (a coarser grid's phase drift
    # would hide them).
    typical = 0.75 * (stamps[-1] - stamps[0]) / (stamps.size - 1)
    tight = [f for f in found if not f[0] and f[2] <= TIGHT * f[3] and f[3] >= typical]
    if tight:
        chosen = min(tight, key=lambda f: (_cost(f, stamps.size), f[2]))
    slots = first if first is not None else _slots(stamps, chosen[3])
    del first
    for a in range(0, missing.size, _SLOT_CHUNK * SLOT_BLOCK):
        b = min(missing.size, a + _SLOT_CHUNK * SLOT_BLOCK)
        missing[a:b] = np.diff(slots[a : b + 1]) - 1
    del slots
    _cancel_shared(missing)
    return missing, int(chosen[0]), float(chosen[3])


#: An interval shorter than this share of a joined file's mean step joins two
#: stamps of one burst (:func:`_bursts`; a buffered publisher's stamps lie
#: microseconds apart, a late stamp's catch-up 0.2 step or more).
BURST_GAP = 0.05
#: A stretch of a file not bursty as a whole holding this many intervals of
#: bursts, each within BURST_REACH of the next, is counted by burst
#: (:func:`_burst_regions`).
BURST_STRETCH = 8
BURST_REACH = 5
#: A file with this many stretches of bursts or more is counted by burst as a
#: whole (:func:`_bursts`): its bursts recur (network latency's).
BURST_STRETCHES = 4
#: A file is bursty when at least this share of its intervals join a burst
#: (bursts of 2 stamps: a half; a late stamp every 4th: none below BURST_GAP).
BURSTY = 0.4
#: A joined file's local steps are read over blocks of this many intervals
#: (:func:`_rate_cuts`); a part at one rate spans at least 2 of them (of
#: a quarter as many intervals in a short file: :data:`SHORT_RATE`).
RATE_BLOCK = 64
#: A block's interval over this many times its 4th longest is left out of its
#: step (:func:`_rate_cuts`): a pause (a minute in a 1 kHz file was a rate
#: change to a 0.5 s step, the part holding it counted on that grid: 86
#: samples missing for 60 000, its drops lost), not its rate; up to 3 such a
#: block. A buffered publisher's holes (bursts of up to 16 in a block of 64:
#: 4 or more holes) are within it.
PAUSE = 4.0
#: A file of fewer intervals than this, not bursty, is read in blocks of a
#: quarter of :data:`RATE_BLOCK` (:func:`_rate_cuts`): the last 10 % of 500
#: stamps at 100 Hz recorded at 50 Hz (under 2 blocks of 64) was no rate
#: change, its 50 intervals counted a sample missing each.
SHORT_RATE = RATE_BLOCK * RATE_BLOCK
#: Parts whose steps differ by more than this factor are counted on their own
#: grids (a rate change mid-file); closer ones on the whole file's.
RATE_CHANGE = 1.05


def _missing(
    stamps: np.ndarray, stretches: bool = True
) -> tuple[np.ndarray, int, list[str]]:
    """(missing, shared, found): the samples of a joined file missing in each interval.

    ``missing``: (len(stamps) - 1,) int, counted by :func:`_grid_missing`;
    ``shared``: its stamps sharing a slot of the grid chosen (beyond its bound,
    :func:`_beyond_note`); ``found``: clauses naming what the count read
    (:func:`_found_note`): bursts, rate changes.

    A rate change (:func:`_rate_cuts`: parts whose local steps differ by more
    than :data:`RATE_CHANGE`) splits the stamps in parts that share their end
    stamps, each counted on its own grid (one grid for a file at 100 then 50 Hz
    fitted a step between the two: 221 false samples missing on 2000 stamps);
    neighbour parts whose fitted steps differ by less than :data:`RATE_CHANGE`
    are joined and counted again (a long gap or a run of drops is no rate
    change). A bursty part (:func:`_bursts`) is counted by burst
    (:func:`_burst_missing`): the samples received by each burst's end against
    the time elapsed (a buffered publisher sends the samples it holds at once,
    bursts of equal sizes or not), a sample missing where that deficit's floor
    rises by one for good, counted in the hole before the burst (where the
    join reads the file between bursts); a drop in the first or last burst is
    unseen (the note says so). Unequal bursts (a 1 kHz stream flushed every
    4 ms as 3 then 5 messages, 1600 stamps) counted 398 false samples missing
    when each burst was spread over the span before it at the median per-burst
    step: now 0. A file not bursty as a whole is first split at its stretches
    of bursts (:func:`_burst_regions`), each part counted as above (a third of
    a file in bursts, counted on the file's grid: 1-3 false samples at the
    switch, hundreds of stamps sharing a slot).

    Measured (30 files a case of 399-401 stamps, bursts of b stamps 0.02 step
    apart then a b-step hole, each burst jittered by up to 0-40 % of a step,
    1 or 3 drops): bursts of 3 were counted right in 0-19 of 30 files, of 4
    in 0-1, of 2 jittered in 0-14 (complete ones: up to 21 false samples),
    now in 30 (10 drops: 27-30, the misses at 40 % jitter, as without
    bursts); a 3.6 M-stamp file at 1 then 0.5 kHz: 715 127 false samples
    missing, 9.7 s CPU, now 0 and 0.7 s; in bursts of 4: 7.6 s, now 1.0 s
    (peak 241 -> 257 MB: the stamps spread over their bursts); a file at one
    rate: as before.
    """
    n = stamps.size
    missing = np.zeros(max(n - 1, 0), np.int64)
    found: list[str] = []
    if n < 2:
        return missing, 0, found
    if stretches:
        paused = _long_pauses(stamps)
        if paused.size:  # each side counted on its own, the pause by its length
            return _cut_pauses(stamps, paused)
    regions = _burst_regions(stamps) if stretches else []
    if regions:  # each bursty stretch counted by burst, the rest on its grid
        mean = _file_step(stamps, STEP_SPANS[-1])
        stalls = [r for r in regions if _stall(stamps, *r, mean)]
        # A stall counts up to the stamp after its burst, the next part from it
        # (a catch-up's last interval on a part of 3 stamps read a short grid).
        held = {a: min(b + 1, n - 1) for a, b in stalls}
        cut = [(a, held.get(a, b)) for a, b in regions]
        ends = sorted({0, n - 1, *(c for r in cut for c in r)})
        shared = 0
        for a, b in itertools.pairwise(ends):
            if a in held:
                continue  # counted below, up to the stamp after its burst
            part, common, said = _missing(stamps[a : b + 1], stretches=False)
            missing[a:b] = part
            shared += common
            found += [f"from {stamps[a]:.16g} on, {c}" for c in said]
        for a, b in stalls:
            missing[a] = _stall_missing(stamps, a, b, _stall_step(stamps, a, b, mean))
        found[:0] = _regions_said(stamps, regions, stalls)
        return missing, shared, found
    cuts = _rate_cuts(stamps)
    parts = [_part_missing(stamps[a : b + 1]) for a, b in itertools.pairwise(cuts)]
    kept = [0]  # the cuts between parts whose steps differ by RATE_CHANGE
    for k in range(1, len(parts)):
        x, y = parts[kept[-1]][2], parts[k][2]
        if min(x, y) > 0.0 and max(x, y) > RATE_CHANGE * min(x, y):
            kept.append(k)
    if len(kept) < len(parts):  # parts at about one rate joined: counted again
        ends = [*kept, len(parts)]
        parts = [
            parts[i] if j == i + 1 else _part_missing(stamps[cuts[i] : cuts[j] + 1])
            for i, j in itertools.pairwise(ends)
        ]
        cuts = [cuts[i] for i in ends]
    if len(parts) == 1:
        missing, shared, _, found = parts[0]
        return missing, shared, found
    shared = 0
    for (a, b), (part, common, _, said) in zip(
        itertools.pairwise(cuts), parts, strict=True
    ):
        missing[a:b] = part
        shared += common
        found += [f"from {stamps[a]:.16g} on, {c}" for c in said]  # which part
    steps = listed((f"{p[2]:.4g}" for p in parts), sep=" then ")
    changes = listed(f"{stamps[c]:.16g}" for c in cuts[1:-1])
    found.insert(
        0,
        f"its rate changes (steps {steps} in its time unit, at {changes}): each "
        "part's gaps are counted on its own grid",
    )
    return missing, shared, found


#: An interval over this many times a joined file's step (:func:`_long_pauses`)
#: is a pause, cut out before the bursts and rate changes are read: a minute's
#: pause in 200 stamps of bursts of 4 at 1 then 0.5 kHz read a step of 0.6 s
#: over the spans holding it, 66 samples missing for 60 000, 99 stamps sharing
#: a slot and a false rate change. Receive stamps' stalls are 10-25 steps, a
#: buffered publisher's holes up to its bursts' size.
LONG_PAUSE = 64.0


def _long_pauses(stamps: np.ndarray) -> np.ndarray:
    """The intervals i (t_i to t_(i+1)) over :data:`LONG_PAUSE` steps: pauses.

    The step: the longer :func:`_file_step` over 8 and over min(:data:`STEP_SPANS`'
    longest, n/6) intervals (a pause holds a fifth of the spans or fewer; bursts
    of up to a span's intervals leave a hole in each; over n/8 a stall's
    catch-up of 25 of 100 receive stamps read 0.35 step, its 25-step stall a
    pause). Only in a file holding :data:`BURST_STRETCH` intervals of bursts
    or more (under :data:`BURST_GAP` steps): without, the rate cuts leave a
    pause out and the grid counts it (a minute in 3000 stamps at 1 kHz:
    within 3 samples; cut out: within 22).
    """
    n = stamps.size
    if n < 16:
        return np.zeros(0, np.int64)
    step = max(_file_step(stamps, w) for w in (8, max(8, min(STEP_SPANS[-1], n // 6))))
    if not step > 0.0:
        return np.zeros(0, np.int64)
    d = np.diff(stamps)
    if np.count_nonzero(d < BURST_GAP * step) < BURST_STRETCH:
        return np.zeros(0, np.int64)  # no bursts: its grid reads the pause
    return np.flatnonzero(d > LONG_PAUSE * step)


def _pause_step(stamps: np.ndarray, at_end: bool) -> tuple[int, float]:
    """(stamps, h [s]) of the part at one rate at a side's end next to a pause.

    ``stamps``: up to :data:`SHORT_RATE` of a side (:func:`_cut_pauses`),
    the pause after them (``at_end``) or before; the part: the last or first
    between its rate cuts (:func:`_rate_cuts`), h its fitted step
    (:func:`_part_missing`, drops counted: a minute among 400 stamps in
    bursts of 4 at 1 kHz counted within 15 samples in 40 files; at the
    median step over 32 intervals near it: within 62).
    """
    if stamps.size < 2:
        return 0, 0.0
    cuts = _rate_cuts(stamps)
    part = stamps[cuts[-2] :] if at_end else stamps[: cuts[1] + 1]
    return part.size, _part_missing(part)[2]


def _cut_pauses(
    stamps: np.ndarray, paused: np.ndarray
) -> tuple[np.ndarray, int, list[str]]:
    """(missing, shared, found) of a file with long pauses (:func:`_long_pauses`).

    The stretches between them each counted on their own (:func:`_missing`);
    pause i's samples missing at the step h of the longer part at one rate
    next to it (:func:`_pause_step`): round((t_j - t_i)/h) - (j - i), t_j
    the end of the first burst after it (its first stamp without bursts; a
    buffered publisher flushes a burst at its last sample).
    """
    n = stamps.size
    missing = np.zeros(n - 1, np.int64)
    starts = np.concatenate([[0], paused + 1])
    stops = np.concatenate([paused, [n - 1]])
    shared, found = 0, []
    for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
        if b > a:
            part, common, said = _missing(stamps[a : b + 1])
            missing[a:b] = part
            shared += common
            found += [f"from {stamps[a]:.16g} on, {c}" for c in said]
    for k, i in enumerate(paused.tolist()):
        a, b = int(starts[k]), int(stops[k + 1])
        before = _pause_step(stamps[max(a, i + 1 - SHORT_RATE) : i + 1], at_end=True)
        after = _pause_step(stamps[i + 1 : min(b, i + SHORT_RATE) + 1], at_end=False)
        step = max(before, after)[1]  # the longer part's
        if not step > 0.0:
            continue
        j = i + 1  # the end of the first burst after the pause
        while j < b and stamps[j + 1] - stamps[j] < BURST_GAP * step:
            j += 1
        missing[i] = max(round((stamps[j] - stamps[i]) / step) - (j - i), 0)
    where = listed(f"{stamps[i]:.16g} to {stamps[i + 1]:.16g}" for i in paused.tolist())
    found.insert(
        0,
        f"its bursts pause from {where}: each stretch between pauses is counted "
        "on its own, a pause's samples against the time elapsed",
    )
    return missing, shared, found


def _burst_regions(stamps: np.ndarray) -> list[tuple[int, int]]:
    """[(a, b), ...]: the stretches of a file not bursty as a whole that are.

    A stretch: :data:`BURST_STRETCH` or more intervals shorter than
    :data:`BURST_GAP` of the mean step, each within :data:`BURST_REACH`
    intervals of the next (bursts of any size leave 2 between them: the hole,
    then the next burst's first; two bursts of 2 each short of a sample, 4);
    ``a`` the stamp before its first burst, ``b`` its last burst's last stamp
    (each part counted on its own, :func:`_missing`: 10-50 % of a file in
    bursts of 2-8 counted on the file's grid put 1-3 false samples missing at
    the switch and hundreds of stamps in a shared slot, a beyond-bound note;
    a drop in a stretch's first or last burst is unseen).
    """
    if stamps.size < 8 or _bursts(stamps) is not None:
        return []
    return _stretches(stamps, _file_step(stamps, STEP_SPANS[-1]))


def _stall(stamps: np.ndarray, a: int, b: int, mean: float) -> bool:
    """Whether the stretch of bursts (a, b) of :func:`_burst_regions` is one burst.

    One burst after stamp ``a``: a stall, the stamps held then received at
    once (:func:`_stall_missing`); ``mean``: the file's mean step.
    """
    return bool(np.all(np.diff(stamps[a + 1 : b + 1]) < BURST_GAP * mean))


def _stall_step(stamps: np.ndarray, a: int, b: int, mean: float) -> float:
    """The step [s] a stall (a, b) (:func:`_stall`) is counted at.

    The file's mean step ``mean``, unless the median step of the 8-interval
    spans within 4 :data:`RATE_BLOCK` intervals before stamp a and after the
    burst (from b + 1) differs by more than :data:`RATE_CHANGE`: a stall in the
    500 Hz half of a file at 1 then 0.5 kHz, counted at the file's mean step,
    was 4 false samples missing (receive stamps' latency leaves the local step
    within 1-3 % of the file's, the mean kept).
    """
    reach = 4 * RATE_BLOCK
    near = [stamps[max(a - reach, 0) : a + 1], stamps[b + 1 : b + 2 + reach]]
    spans = [(s[8:] - s[:-8]) / 8 for s in near if s.size > 8]
    if not spans or not mean > 0.0:
        return mean
    local = float(np.median(np.concatenate(spans)))
    return local if not 1 / RATE_CHANGE <= local / mean <= RATE_CHANGE else mean


def _stall_missing(stamps: np.ndarray, a: int, b: int, step: float) -> int:
    """The samples missing in a stall (a, b) (:func:`_stall`), counted at ``a``.

    The samples due from stamp a to the next after the burst, b + 1, at the
    ``step`` h of :func:`_stall_step`, round((t_(b+1) - t_a)/h), less the
    b + 1 - a received (the next part counted from b + 1 on: its grid read
    from the catch-up's end, 3 stamps after a stall counted 1 false sample
    missing). The burst's last stamp is the stall's end, up to a step after
    its last sample: a 10 ms EtherCAT stall caught up by 10 stamps 1 us apart
    was counted on a grid of its own, 9 stamps sharing a slot (a beyond-bound
    note on a complete file). A stall at the file's end: the whole samples
    due up to t_b (a drop at its very end may go unseen).
    """
    if not step > 0.0:
        return 0
    if b + 1 < stamps.size:
        due = round((stamps[b + 1] - stamps[a]) / step) - (b + 1 - a)
    else:
        due = math.floor((stamps[b] - stamps[a]) / step) - (b - a)
    return max(int(due), 0)


def _regions_said(
    stamps: np.ndarray,
    regions: list[tuple[int, int]],
    stalls: list[tuple[int, int]],
) -> list[str]:
    """The clauses naming a file's stretches of bursts (:func:`_burst_regions`).

    A stretch that is one burst is a stall (``stalls``, :func:`_stall`): a
    10 ms EtherCAT stall caught up by 10 stamps 1 us apart was named 'bursts';
    the others are named as bursts.
    """
    said = []
    bursty = [r for r in regions if r not in stalls]
    if bursty:
        where = listed(f"{stamps[a]:.16g} to {stamps[b]:.16g}" for a, b in bursty)
        said.append(f"its stamps come in bursts from {where} only")
    if stalls:
        where = listed(
            f"{stamps[a]:.16g} to {stamps[b]:.16g} ({b - a} stamps)" for a, b in stalls
        )
        said.append(
            f"it stalls, then catches up in one burst, from {where}: the "
            "samples held by a stall are counted against the time elapsed"
        )
    return said


def _stretches(stamps: np.ndarray, mean: float) -> list[tuple[int, int]]:
    """The stretches of bursts of :func:`_burst_regions`, ``mean`` the mean step."""
    if not mean > 0.0:
        return []
    short = np.flatnonzero(np.diff(stamps) < BURST_GAP * mean)
    if short.size < BURST_STRETCH:
        return []
    breaks = np.flatnonzero(np.diff(short) > BURST_REACH)
    starts = np.concatenate([[0], breaks + 1])
    stops = np.concatenate([breaks, [short.size - 1]])
    return [
        (max(int(short[i]) - 1, 0), int(short[j]) + 1)
        for i, j in zip(starts.tolist(), stops.tolist(), strict=True)
        if j - i + 1 >= BURST_STRETCH
    ]


def _part_missing(stamps: np.ndarray) -> tuple[np.ndarray, int, float, list[str]]:
    """(missing, shared, h, found) of stamps at one rate (:func:`_missing`)."""
    bursts = _bursts(stamps)
    if bursts is None:
        missing, shared, step = _grid_missing(stamps)
        return missing, shared, step, []
    first, count, _ = bursts
    after = _burst_pauses(stamps, first, count)
    if after.size:  # each stretch between pauses counted on its own
        return _paused_missing(stamps, first, count, after)
    missing, step, tail, fewer = _burst_missing(stamps, first, count)
    if not step > 0.0:  # no step read from the bursts: counted on a grid
        missing, shared, step = _grid_missing(stamps)
        return missing, shared, step, []
    size = float(np.median(count))
    said = (
        f"its stamps come in bursts ({first.size} bursts, {size:.3g} stamps "
        f"each at the median, a step of {step:.4g} in its time unit): each "
        "burst's samples are counted against the time elapsed since the first "
        "burst (a drop in the first or last burst cannot be seen, one in the "
        f"{tail - 1} before the last only beyond the bursts' spread)"
    )
    if fewer:  # a step nearly as close to the bursts counts fewer
        said += (
            f"; a step nearly as close to its bursts counts {fewer} fewer "
            "samples missing in it: the count is uncertain (its stamps' "
            "latency blurs the bursts' floor)"
        )
    return missing, 0, step, [said]


#: A burst whose step (the time to its last stamp over its stamps) is over this
#: many times the 90th percentile of its part's follows a pause
#: (:func:`_burst_pauses`): receive stamps' latency (up to 8 steps late, 12 %
#: of them) reads up to 8.8, stalls caught up and drops up to 2.4.
BURST_PAUSE = 16.0
#: A burst whose step is over :data:`PAUSE` times that 90th percentile follows
#: a pause too if the deficit's floor (:func:`_burst_missing`) over the
#: bursts of :data:`BURST_RUN` stamps after it lies this many samples above the
#: floor before it (:func:`_burst_pauses`).
PAUSE_RISE = 8.0


def _burst_pauses(
    stamps: np.ndarray, first: np.ndarray, count: np.ndarray
) -> np.ndarray:
    """The bursts after a pause in a bursty part (:func:`_part_missing`).

    Burst m (its last stamp T_m, C_m stamps) follows a pause where its step
    (T_m - T_(m-1))/max(C_m, the median C) (a last burst cut short by the
    log's end is no pause) is over :data:`BURST_PAUSE` times the 90th
    percentile of the part's: a minute's pause in 400 stamps of a 1 kHz
    publisher flushing bursts of 4 read a step of 0.3 s, all its samples
    missing and drops unseen. Or over :data:`PAUSE` times it where the deficit
    r_m = (T_m - T_0)/h - (last_m - last_0) (h the median burst step) has its
    least over the bursts of :data:`BURST_RUN` stamps after m
    :data:`PAUSE_RISE` samples or more above its least over those before: a
    50 ms pause among bursts of 4 at 1 kHz (13.5 times the 90th percentile)
    read a step of 1.25 ms, 0 counted, drops lost (40 of 40 seeds; 20-50 ms
    now 0 of 40 wrong); a late burst or a stall is caught up, its floor back.
    """
    last = first + count - 1
    if last.size < 3:
        return np.zeros(0, np.int64)
    step = np.diff(stamps[last]) / np.maximum(count[1:], np.median(count))
    high = np.quantile(step, 0.9)
    paused = step > BURST_PAUSE * high
    # Shorter: a pause if the deficit's floor rises for good by PAUSE_RISE
    # (latency's late burst and a stall are caught up: the floor comes back).
    near = np.flatnonzero(~paused & (step > PAUSE * high))
    h = float(np.median(np.diff(stamps[last]) / count[1:]))
    if near.size and h > 0.0:
        deficit = (stamps[last] - stamps[last[0]]) / h - (last - last[0])
        reach = max(2, math.ceil(BURST_RUN / float(np.median(count))))
        for m in (near + 1).tolist():
            before = deficit[max(0, m - reach) : m].min()
            after = deficit[m : m + reach].min()
            paused[m - 1] = after - before >= PAUSE_RISE
    return np.flatnonzero(paused) + 1


def _paused_missing(
    stamps: np.ndarray, first: np.ndarray, count: np.ndarray, after: np.ndarray
) -> tuple[np.ndarray, int, float, list[str]]:
    """(missing, shared, h, found) of a bursty part with pauses (:func:`_part_missing`).

    The stretches between the pauses (before burst m of ``after``: the hole
    from stamp first_m - 1 to first_m) each counted on their own; a pause's
    samples missing at the longest stretch's step h: round((T_m - t_(first_m -
    1))/h) - C_m, T_m burst m's last stamp, C_m its stamps.
    """
    missing = np.zeros(stamps.size - 1, np.int64)
    holes = first[after] - 1
    starts = np.concatenate([[0], holes + 1])
    stops = np.concatenate([holes, [stamps.size - 1]])
    shared, found, steps = 0, [], []
    for a, b in zip(starts.tolist(), stops.tolist(), strict=True):
        if b - a < 1:
            steps.append((0, 0.0))
            continue
        part, common, step, said = _part_missing(stamps[a : b + 1])
        missing[a:b] = part
        shared += common
        steps.append((b - a, step))
        found += [f"from {stamps[a]:.16g} on, {c}" for c in said]
    step = max(steps)[1]
    if step > 0.0:
        for m, hole in zip(after.tolist(), holes.tolist(), strict=True):
            end = stamps[first[m] + count[m] - 1]
            due = round((end - stamps[hole]) / step) - int(count[m])
            missing[hole] = max(due, 0)
    where = listed(f"{stamps[h]:.16g} to {stamps[h + 1]:.16g}" for h in holes)
    found.insert(
        0,
        f"its bursts pause from {where}: each stretch between pauses is counted "
        "on its own, a pause's samples against the time elapsed",
    )
    return missing, shared, step, found


#: A bursty file's step is read over runs of bursts holding at least this many
#: stamps (:func:`_burst_missing`; unequal bursts, 3 then 5, average out).
BURST_RUN = 16
#: A bursty file's deficit is read again this many times with its step refitted
#: on the samples counted (:func:`_burst_missing`).
BURST_REFITS = 2
#: Steps putting 2 fewer to this many more samples in a bursty file than its
#: fit are tried (:func:`_burst_missing`): 5 drops in 464 stamps tilted it
#: 1.2 %, all hidden.
BURST_MORE = 8
#: A step whose floor bursts' RMS is within this many times the least (and
#: :data:`BURST_SPREAD`) counting fewer samples missing makes a bursty part's
#: count uncertain, a note says so (:func:`_burst_missing`): receive stamps'
#: latency (0-2.5 steps) blurs the floor, its step misfit up to 1.5 %, 1-7
#: false samples missing on complete files; taking the fewest among those
#: would hide most drops (34 of 40 files with 1-5 counted wrong).
BURST_BLUR = 2.0
#: Of the steps tried (:data:`BURST_MORE`), those whose floor bursts' RMS off
#: their line is within this share of a step of the least are as good: the
#: one counting fewest samples missing is taken (a part of 13 bursts of 2 then
#: 10 at 10 ms read 9.25 ms, 3 false samples, at the least alone).
BURST_SPREAD = 0.05


def _burst_missing(
    stamps: np.ndarray, first: np.ndarray, count: np.ndarray
) -> tuple[np.ndarray, float, int, int]:
    """(missing, h, tail, fewer): a bursty part's samples missing, by its deficit.

    Burst m ends at T_m with C_m stamps received before its last; with a step
    h the deficit r_m = (T_m - T_0)/h - (C_m - C_0) is the samples due but not
    received: a complete file's stays within a band (a buffered publisher
    flushing 3 then 5 samples every 4 ms at 1 kHz: 1 sample wide), a drop
    raises it by 1 for good. The level F_m = min_(j >= m) r_j (the band's
    floor from m on) rises by D_m, the samples missing up to burst m: D_m =
    round(F_m - F_0), taken at the bursts on the floor (r_m - F_m < 1/2; one
    above it holds samples back) and counted in the hole before the burst
    where it rises (where the join reads the file between bursts). Near the
    end F_m reads few bursts: in the last ``tail`` bursts (2, or those of the
    last :data:`BURST_RUN` stamps, or one more than the longest run of bursts
    above the floor before them, :func:`_burst_tail`) a rise counts only
    beyond the band's width
    max_m (r_m - F_m) before them, not at all in the last (a burst cut by the
    log's end; nor can the first burst's drops be seen: the note says so).

    h [s]: from the whole span and count, then the median of (T_b - T_a)/(C_b
    - C_a) between floor bursts (:func:`_burst_floor`, those that emptied the
    buffer, on a line whatever the bursts' sizes) 2·:data:`BURST_RUN` stamps
    apart, refitted :data:`BURST_REFITS` times by least squares of the floor
    bursts' T_m over C_m + D_m; a drop unseen tilts such a fit to hide it (0.3 %
    over 400 stamps), so of the steps putting 2 samples fewer to
    :data:`BURST_MORE` more in the file, those whose floor bursts lie within
    :data:`BURST_SPREAD` of a step of the closest to their line, the one
    counting fewest missing; ``fewer``: how many fewer the steps within
    :data:`BURST_BLUR` times the least RMS count at least (0: none; else the
    count is uncertain, a note says so). The per-
    burst median step read 1.07 ms for the 3-then-5 file (398 false samples
    missing in 1600 stamps): now 1 ms, 0.
    """
    missing = np.zeros(stamps.size - 1, np.int64)
    last = first + count - 1
    ends = stamps[last] - stamps[last[0]]
    received = (last - last[0]).astype(np.float64)
    bursts = last.size
    run = int(min(max(1, math.ceil(BURST_RUN / float(np.median(count)))), bursts - 1))
    tail = int(min(bursts - 1, max(2, np.count_nonzero(last > last[-1] - BURST_RUN))))
    lost = np.zeros(bursts)
    step = float(ends[-1] / received[-1])  # drops spread over the file
    if not step > 0.0:
        return missing, 0.0, tail, 0
    floor = _burst_floor(ends, received, step, run)
    at = np.flatnonzero(floor)
    near = int(np.searchsorted(received[at] - received[at[0]], 2 * BURST_RUN))
    apart = min(max(1, near), at.size - 1)
    if apart >= 1:
        steps = (ends[at[apart:]] - ends[at[:-apart]]) / (
            received[at[apart:]] - received[at[:-apart]]
        )
        step = float(np.median(steps))
    for _ in range(BURST_REFITS):  # least squares on the floor, the drops counted
        if not step > 0.0:
            return missing, 0.0, tail, 0
        lost = _burst_lost(ends, received, step, tail)
        floor = _burst_floor(ends, received + lost, step, run)
        fitted = _fitted_step(ends[floor], (received + lost)[floor])
        if not fitted > 0.0:
            break
        step = fitted
    tail = _burst_tail(ends, received, step, tail)
    # A drop unseen (or one too many) tilts the fit to hide it: of the steps
    # that put 2 fewer to BURST_MORE more samples in the file, those whose floor
    # bursts lie within BURST_SPREAD of a step as close to their line as the
    # closest, the one counting fewest missing (then the closest).
    total = received[-1] + _burst_lost(ends, received, step, tail)[-1]
    tried: list[tuple[float, float, float, np.ndarray]] = []
    for more in range(-2, BURST_MORE + 1):
        if total + more < received[-1] or not total + more > 0:
            continue
        guess = step * total / (total + more)
        counted = _burst_lost(ends, received, guess, tail)
        floor = _burst_floor(ends, received + counted, guess, run)
        fitted = _fitted_step(ends[floor], (received + counted)[floor])
        if not fitted > 0.0:
            continue
        counted = _burst_lost(ends, received, fitted, tail)
        floor = _burst_floor(ends, received + counted, fitted, run)
        off = ends[floor] - fitted * (received + counted)[floor]
        tried.append((float(np.std(off)) / fitted, counted[-1], fitted, counted))
    if not tried:
        return missing, 0.0, tail, 0
    best = min(t[0] for t in tried)
    _, _, chosen, lost = min(
        (t for t in tried if t[0] <= best + BURST_SPREAD), key=lambda t: t[1::-1]
    )
    # Latency blurs the floor (its bursts' RMS 0.1-0.3 step off their line):
    # a step within twice the least RMS counting fewer makes the count uncertain.
    fewest = min(t[1] for t in tried if t[0] <= BURST_BLUR * best + BURST_SPREAD)
    rise = np.diff(lost).astype(np.int64)
    where = np.flatnonzero(rise)
    missing[first[where + 1] - 1] = rise[where]
    return missing, chosen, tail, int(lost[-1] - fewest)


def _burst_tail(ends: np.ndarray, received: np.ndarray, step: float, tail: int) -> int:
    """The last bursts where a rise of the floor counts only beyond the spread.

    (:func:`_burst_missing`): at least ``tail``, and one more than the longest
    run of bursts above the floor (r_m - F_m >= 1/2) before them. The level
    near the end is the least of the few bursts after: receive stamps with
    network latency (0-2.5 steps late, a third of them more than a half) lie
    above the floor up to 5-11 bursts in a row, and the last 3-4 all above it
    read as a drop (1 false sample missing in 3 of 40 complete files of 1000
    stamps, 500 Hz, 5 % stalls).
    """
    deficit = ends / step - received
    level = np.minimum.accumulate(deficit[::-1])[::-1]
    above = deficit[: ends.size - tail] - level[: ends.size - tail] >= 0.5
    edges = np.flatnonzero(np.diff(np.concatenate([[0], above.astype(np.int8), [0]])))
    longest = int(np.max(edges[1::2] - edges[::2], initial=0))
    return int(min(ends.size - 1, max(tail, longest + 1)))


def _burst_floor(
    ends: np.ndarray, slots: np.ndarray, step: float, run: int
) -> np.ndarray:
    """The bursts whose deficit is within half a sample of the least within ``run``.

    (:func:`_burst_missing`): the bursts that emptied the publisher's buffer,
    on a line of slope h whatever the bursts' sizes.
    """
    deficit = ends / step - slots
    least = minimum_filter1d(deficit, 2 * run + 1, mode="nearest")
    return deficit <= least + 0.5


def _burst_lost(
    ends: np.ndarray, received: np.ndarray, step: float, tail: int
) -> np.ndarray:
    """D_m: the samples missing up to each burst at step h (:func:`_burst_missing`)."""
    deficit = ends / step - received
    level = np.minimum.accumulate(deficit[::-1])[::-1]
    base = level[0]
    body = ends.size - tail
    found = np.maximum(np.rint(level[:body] - base), 0.0)
    # Counted where a burst reaches the new level: one above it (samples left
    # in the publisher's buffer) keeps the count before it.
    floor = np.flatnonzero(deficit[:body] - level[:body] < 0.5)
    held = np.zeros(body, np.int64)
    held[floor] = floor
    found = found[np.maximum.accumulate(held)]
    width = float(np.max(deficit[:body] - level[:body]))
    late = np.maximum(np.rint(level[body:-1] - base - width), found[-1])
    return np.maximum.accumulate(np.concatenate([found, late, [found[-1]]]))


def _bursts(stamps: np.ndarray) -> tuple[np.ndarray, np.ndarray, float] | None:
    """(first, count, h) of a bursty file's bursts, or None for a file without.

    Bursts: runs of stamps less than :data:`BURST_GAP` of the mean step apart
    (:func:`_file_step` over :data:`STEP_SPANS`' longest span), in a file where
    at least :data:`BURSTY` of the intervals are such or that holds
    :data:`BURST_STRETCHES` stretches of them or more (:func:`_stretches`;
    receive stamps, network latency's bursts: a file of 300-3000 at 1 in 8
    stamps 2-8 steps late, the rest on time, split in its stretches counted
    59 of 59 files wrong, 1 900 false samples missing; counted whole by burst
    2 of 59, none false); ``first``/``count``: the
    index of each burst's first stamp and its stamps; ``h``: the step [s], the
    median of the intervals between the bursts' last stamps over the later
    burst's stamps (a burst short of a sample or a burst missing is an outlier).
    """
    if stamps.size < 8:
        return None
    mean = _file_step(stamps, STEP_SPANS[-1])
    if not mean > 0.0:
        return None
    rows = _SLOT_CHUNK * SLOT_BLOCK  # counted a chunk at a time (bounded temporaries)
    short = sum(
        int(np.count_nonzero(np.diff(stamps[a : a + rows + 1]) < BURST_GAP * mean))
        for a in range(0, stamps.size - 1, rows)
    )
    if short < BURSTY * (stamps.size - 1):
        if len(_stretches(stamps, mean)) < BURST_STRETCHES:
            return None  # no bursts, or a few stretches (_burst_regions)
    joined = np.diff(stamps) < BURST_GAP * mean
    first = np.flatnonzero(np.concatenate([[True], ~joined]))
    count = np.diff(np.append(first, stamps.size))
    last = first + count - 1
    if first.size < 3:
        return None
    step = float(np.median(np.diff(stamps[last]) / count[1:]))
    if not step > 0.0:
        return None
    return first, count, step


def _rate_cuts(stamps: np.ndarray) -> list[int]:
    """[0, c_1, ..., n - 1]: the stamps where a joined file's rate changes.

    The mean step of each block of :data:`RATE_BLOCK` intervals (in a file of
    fewer than :data:`SHORT_RATE` intervals a quarter as many, or, bursty
    with bursts of 2 or more at the median, 8 times its 90th-percentile burst
    if more: bursts of 2-4, 160-240 stamps at 1 then 0.5 kHz, under 4 blocks
    of 64, had no cut, 20-33 false samples missing; a latency's bursts of 1
    keep 64; a short bursty file with bursts of 1 at the median or under 4
    blocks: blocks of whole bursts, :func:`_burst_blocks`); the
    blocks' ends spread over the file, the last interval in one; bursts and
    late stamps average out) without its intervals over :data:`PAUSE` times its
    4th longest (a pause or a run of drops, not its rate), on a log scale,
    split where the split leaves the least squared spread about each side's
    mean, recursively while the two sides' means differ by more than
    :data:`RATE_CHANGE` and each side spans 2 blocks or more; each cut then
    moved to the stamp of the 2 blocks either side that leaves the fewest
    intervals off one step of its side (:func:`_refined_cut`), and kept if
    the sides' median steps over 8 intervals (:func:`_file_step`) differ by
    more than :data:`RATE_CHANGE` too (3 drops in a row in a block of 16
    moved its mean by 19 %).
    """
    n = stamps.size
    block = RATE_BLOCK  # intervals a block (a short file's: fewer)
    read: list[Any] = []  # _bursts(stamps), read once when needed

    def bursts() -> tuple[np.ndarray, np.ndarray, float] | None:
        if not read:
            read.append(_bursts(stamps))
        return read[0]

    if n - 1 < SHORT_RATE:  # a buffered publisher's: 8 of its longest bursts
        found_bursts = bursts()
        size = 1.0 if found_bursts is None else np.percentile(found_bursts[1], 90)
        if found_bursts is None or np.median(found_bursts[1]) >= 2:
            block = min(RATE_BLOCK, max(RATE_BLOCK // 4, 8 * math.ceil(size)))
    blocks = (n - 1) // block
    by_burst = None
    found_bursts = bursts() if n - 1 < SHORT_RATE else None
    if found_bursts is not None and (blocks < 4 or np.median(found_bursts[1]) < 2):
        by_burst = _burst_blocks(stamps, found_bursts, block)
    if by_burst is not None:  # a short file of long bursts: blocks of whole bursts
        ends, steps, block = by_burst
        blocks = steps.size
    elif blocks < 4:
        return [0, n - 1]
    else:
        ends = np.arange(blocks + 1) * (n - 1) // blocks  # block .. 2·block - 1
        steps = _block_steps(stamps, ends, block)
    if not (steps > 0.0).all():
        return [0, n - 1]
    level = np.log(steps)
    found: list[int] = []

    def split(a: int, b: int) -> None:  # blocks a .. b - 1
        if b - a < 4:
            return
        x = level[a:b]
        s1, s2 = np.cumsum(x), np.cumsum(x * x)
        k = np.arange(1, b - a)  # the left side's blocks
        left = s2[:-1] - s1[:-1] ** 2 / k
        right = (s2[-1] - s2[:-1]) - (s1[-1] - s1[:-1]) ** 2 / (b - a - k)
        cost = np.where((k >= 2) & (b - a - k >= 2), left + right, np.inf)
        best = int(np.argmin(cost))
        if not np.isfinite(cost[best]):
            return
        m = best + 1
        before, after = s1[best] / m, (s1[-1] - s1[best]) / (b - a - m)
        if abs(before - after) <= math.log(RATE_CHANGE):
            return
        steps = math.exp(before), math.exp(after)
        cut = _refined_cut(stamps, int(ends[a + m]), *steps, block, bursts())
        h1 = _file_step(stamps[ends[a] : cut + 1])
        h2 = _file_step(stamps[cut : ends[b] + 1])
        if not (min(h1, h2) > 0.0 and max(h1, h2) > RATE_CHANGE * min(h1, h2)):
            return  # a block of drops (the sides' median 8-interval steps agree)
        found.append(cut)
        split(a, a + m)
        split(a + m, b)

    split(0, blocks)
    cuts = [0, n - 1]
    for c in found:  # the wider splits' first (a nested one may find it again)
        if all(abs(c - other) >= block for other in cuts):
            cuts.append(c)
    return sorted(cuts)


def _block_steps(stamps: np.ndarray, ends: np.ndarray, block: int) -> np.ndarray:
    """Each block's mean step [s] without its pauses (:func:`_rate_cuts`).

    Block j: the intervals from stamp ``ends[j]`` to ``ends[j + 1]`` (at least
    ``block``), those over :data:`PAUSE` times its 4th longest left out.
    """
    blocks = ends.size - 1
    rank = block - 4
    steps = np.empty(blocks)
    rows = _SLOT_CHUNK * 16  # blocks a chunk (bounded temporaries)
    for a in range(0, blocks, rows):
        b = min(blocks, a + rows)
        d = np.diff(stamps[ends[a] : ends[b] + 1])
        starts = ends[a:b] - ends[a]
        high = np.partition(d[starts[:, None] + np.arange(block)], rank, axis=1)
        limit = np.repeat(PAUSE * high[:, rank], np.diff(ends[a : b + 1]))
        kept = d <= limit  # a pause or a run of drops: not the block's rate
        total = np.add.reduceat(np.where(kept, d, 0.0), starts)
        steps[a:b] = total / np.add.reduceat(kept.astype(np.float64), starts)
    return steps


def _burst_blocks(
    stamps: np.ndarray, bursts: tuple[np.ndarray, np.ndarray, float] | None, block: int
) -> tuple[np.ndarray, np.ndarray, int] | None:
    """(ends, steps, block) of a short bursty file read in blocks of whole bursts.

    (:func:`_rate_cuts`): ``block`` bursts at the median a block, or, if that
    gives under 4 blocks, a quarter of :data:`RATE_BLOCK` stamps (at least 2
    bursts each): 120-240 stamps in bursts of 8 at 1 then 0.5 kHz read in
    blocks of 64 intervals had under 4, no rate change, 15-33 false samples
    missing. ``ends``: the blocks' ends, bursts' last stamps; ``steps`` [s]:
    each block's mean step between them, exact wherever a block starts in a
    burst, without its bursts whose step (the interval before a burst's last
    stamp over its stamps) is over :data:`PAUSE` times the block's median
    burst step (a pause; with 4 bursts a block or more); ``block``: the
    stamps of a block at the median. Receive stamps of a 500 Hz topic with 5
    % stalls (20-50 ms, each caught up by one burst) read in blocks of 64
    intervals left a stall's hole out as a pause and kept its catch-up: the
    blocks with stalls read 6 % faster, a rate change, 4-5 false samples
    missing on a complete file of 1000 stamps. None for a file without
    bursts or with fewer than 4 such blocks.
    """
    if bursts is None:
        return None
    first, count, _ = bursts
    size = float(np.median(count))
    last = first + count - 1
    group = max(2, math.ceil(block / size))  # bursts a block
    if (last.size - 1) // group < 4:
        group = max(2, math.ceil(RATE_BLOCK / 4 / size))
    blocks = (last.size - 1) // group
    if blocks < 4:
        return None
    at = np.arange(blocks + 1) * (last.size - 1) // blocks  # in bursts
    ends = last[at]
    held = np.diff(stamps[last])  # the time to each burst's last stamp
    each = np.diff(last).astype(np.float64)  # its stamps
    steps = np.empty(blocks)
    for k, (a, b) in enumerate(itertools.pairwise(at.tolist())):
        dt, c = held[a:b], each[a:b]
        if b - a >= 4:  # a pause: a burst step over PAUSE times the median
            kept = dt / c <= PAUSE * np.median(dt / c)
            dt, c = dt[kept], c[kept]
        steps[k] = dt.sum() / c.sum()
    return ends, steps, int(group * size)


def _refined_cut(
    stamps: np.ndarray,
    near: int,
    before: float,
    after: float,
    block: int,
    bursts: tuple[np.ndarray, np.ndarray, float] | None = None,
) -> int:
    """The stamp within 2 blocks of ``block`` intervals of ``near``: a rate change.

    ``before``/``after``: the steps either side [s]; the cut c leaves the
    least sum of min(|Δt_i/h - 1|, 1) (a drop costs 1) with h = ``before``
    for the intervals i < c, ``after`` from c on (ties: the first). In a
    bursty file (``bursts``: :func:`_bursts`) Δt_i is the interval between
    the bursts' last stamps over the later one's stamps, and c the last stamp
    of a burst (its stamps' intervals, 0 or a hole, cost 1 at either step: a
    file in bursts of 4 at 1 then 0.5 kHz was cut 111 stamps late, 111 false
    samples missing).
    """
    a = max(0, near - 2 * block)
    b = min(stamps.size - 1, near + 2 * block)
    ends = np.arange(a, b + 1)
    count: np.ndarray | float = 1.0
    if bursts is not None:
        first, counts, _ = bursts
        last = first + counts - 1
        i, j = np.searchsorted(last, [a, b], side="right")
        i = max(i - 1, 0)  # the burst ending at or before a
        if j - i >= 2:
            ends, count = last[i:j], counts[i + 1 : j]
    d = np.diff(stamps[ends]) / count
    off_before = np.minimum(np.abs(d / before - 1.0), 1.0)
    off_after = np.minimum(np.abs(d / after - 1.0), 1.0)
    cost = np.concatenate([[0.0], np.cumsum(off_before)]) + np.concatenate(
        [np.cumsum(off_after[::-1])[::-1], [0.0]]
    )
    return int(ends[int(np.argmin(cost))])


#: A joined file sampled this many times more slowly than the first is named.
DENSER_RATIO = 2.0


def _denser_note(
    path: str, stamps: Any, base: str, t: Any, positions: set[str], scale: float
) -> str:
    """The clause on a joined file's positions interpolated onto denser stamps, or "".

    ``stamps``/``t``: the file's and the time base's stamps in the log's time
    unit, ``scale`` [s] a unit (the rates named in Hz: a drive file's ms or ns
    stamps named rates 1e3 or 1e9 times too low before); ``positions``: the
    position columns read from that file (none: ""). They
    then hold nothing above the file's own Nyquist frequency, and the
    interpolation's images, not its noise, fill the log's band above fs/4, where
    the automatic off-line cutoff read the noise floor: 100 Hz positions with
    noise interpolated onto 1 kHz stamps gave 40 Hz (the cap) instead of 1.67 Hz
    (a review). It now recognizes linearly interpolated positions and reads
    their noise below their own Nyquist frequency (1.69 Hz,
    ``core.idim_auto.auto_cutoff``); the other measures of the log still see the
    interpolation.
    """
    if not positions:
        return ""
    own = scale * _file_step(np.asarray(stamps))
    first = scale * _file_step(np.asarray(t))
    if not (own > 0.0 and first > 0.0 and own >= DENSER_RATIO * first):
        return ""
    return (
        f" Its samples ({1.0 / own:.4g} Hz) are {own / first:.3g}× sparser than "
        f"{base}'s ({1.0 / first:.4g} Hz): above {0.5 / own:.4g} Hz its positions "
        "hold only the interpolation (the automatic off-line position cutoff reads "
        f"their noise below it): list {path} first to keep them as measured."
    )


def _beyond_note(path: str, shared: int, count: int) -> str:
    """The note on a joined file whose stamps lie beyond :func:`_missing`'s bound."""
    return (
        f"file {path}: {shared} of its {count} time stamps fall in the slot of the "
        "stamp before them on its best-fitting grid (stamps off it by a step or "
        "more: wide jitter, irregular bursts): its gaps, counted on that grid, may "
        "be missed or misplaced near them."
    )


def _found_note(path: str, found: Sequence[str]) -> str:
    """The note on what :func:`_missing` read in a joined file's stamps, or ""."""
    return f"file {path}: {'; '.join(found)}." if found else ""


def _cancel_shared(missing: np.ndarray) -> None:
    """Two stamps in one slot (``missing`` < 0) cancel samples missing nearby, in place.

    Each such interval, in order, takes its excess from the intervals with
    samples missing up to :data:`SLOT_CONTEXT` away, the nearest first, and is
    set to 0. One without any such interval within that reach (counts missing
    only decrease) is only set to 0, without a Python loop: a file whose rate
    halves mid-file puts two stamps in one slot at every other stamp of its
    faster part (3.6 M stamps: 900 000 of them).
    """
    shared = np.flatnonzero(missing < 0)
    if not shared.size:
        return
    lacking = np.flatnonzero(missing > 0)
    after = np.searchsorted(lacking, shared - SLOT_CONTEXT)  # the first in reach
    near = after < lacking.size
    near[near] = lacking[after[near]] <= shared[near] + SLOT_CONTEXT
    missing[shared[~near]] = 0
    shared = shared[near]
    nearest = [0] + [d * s for d in range(1, SLOT_CONTEXT + 1) for s in (-1, 1)]
    for i in shared.tolist():  # two stamps in one slot
        excess = int(-missing[i])
        missing[i] = 0
        for j in (i + d for d in nearest):
            if excess <= 0:
                break
            if 0 <= j < missing.size and missing[j] > 0:
                taken = min(excess, int(missing[j]))
                missing[j] -= taken
                excess -= taken


def _span(slots: np.ndarray) -> int:
    """The slots' span, each gap counted as at most :data:`GAP_CAP` slots."""
    rows = _SLOT_CHUNK * SLOT_BLOCK
    inserted = sum(
        int(np.minimum(np.diff(slots[a : a + rows + 1]) - 1, GAP_CAP).sum())
        for a in range(0, max(slots.size - 1, 0), rows)
    )
    return slots.size - 1 + inserted


def _cost(found: tuple[int, int, float, float], count: int) -> int:
    """Stamps sharing a slot plus slots inserted, of ``count`` stamps' grid."""
    shared, span = found[0], found[1]
    return 2 * shared + span - (count - 1)


def _step_guesses(stamps: np.ndarray) -> list[float]:
    """First guesses of a joined file's step [s] (:func:`_missing`), best first.

    The least-squares step of the slots read from the local steps (with drops
    and jitter below half a step), then :func:`_file_step` over each of
    :data:`STEP_SPANS` (bursts, catch-ups).
    """
    guesses = [_file_step(stamps, span) for span in STEP_SPANS]
    if guesses[0] > 0.0:
        slots = np.zeros(stamps.size, np.int64)
        rows = _SLOT_CHUNK * SLOT_BLOCK
        for a in range(1, stamps.size, rows):
            b = min(stamps.size, a + rows)
            steps = np.maximum(1, np.rint(np.diff(stamps[a - 1 : b]) / guesses[0]))
            slots[a:b] = slots[a - 1] + np.cumsum(steps.astype(np.int64))
        guesses.insert(0, _fitted_step(stamps, slots))
    if stamps.size <= SHORT_FILE and guesses[0] > 0.0:  # few stamps: a scan too
        guesses += [guesses[0] * (1.0 + 1e-3 * j) for j in range(-30, 31)]
    return guesses


def _shared(slots: np.ndarray) -> int:
    """How many stamps share a slot with the stamp before them."""
    rows = _SLOT_CHUNK * SLOT_BLOCK
    return sum(
        int(np.count_nonzero(np.diff(slots[a : a + rows + 1]) < 1))
        for a in range(0, max(slots.size - 1, 0), rows)
    )


def _misfit(stamps: np.ndarray, slots: np.ndarray, step: float) -> float:
    """RMS distance of the stamps from the grid ``step``·k_j through their mean [s]."""
    rows = _SLOT_CHUNK * SLOT_BLOCK
    total = offset = 0.0
    for a in range(0, slots.size, rows):
        e = stamps[a : a + rows] - stamps[0] - step * (slots[a : a + rows] - slots[0])
        offset += float(e.sum())
    offset /= slots.size
    for a in range(0, slots.size, rows):
        e = stamps[a : a + rows] - stamps[0] - step * (slots[a : a + rows] - slots[0])
        total += float(np.dot(e - offset, e - offset))
    return math.sqrt(total / slots.size)


def _fitted_step(stamps: np.ndarray, slots: np.ndarray) -> float:
    """The least-squares slope of the stamps over their slots [s] (0: none)."""
    rows = _SLOT_CHUNK * SLOT_BLOCK
    mean = float(slots[-1] + slots[0]) / 2.0  # centring: round-off only
    kk = kt = k1 = t1 = 0.0
    for a in range(0, slots.size, rows):
        k = slots[a : a + rows] - mean
        t = stamps[a : a + rows] - stamps[0]
        kk, kt = kk + float(np.dot(k, k)), kt + float(np.dot(k, t))
        k1, t1 = k1 + float(k.sum()), t1 + float(t.sum())
    den = kk - k1 * k1 / slots.size
    if not den > 0.0:
        return 0.0
    return (kt - k1 * t1 / slots.size) / den


def _slots(stamps: np.ndarray, step: float) -> np.ndarray:
    """(N,) int64 slots k_j = ⌊(t_j - t_0)/h - φ_b⌋ of the stamps (:func:`_missing`)."""
    n = stamps.size
    cuts = _cuts(stamps, step)
    out = np.empty(n, np.int64)
    rows = _SLOT_CHUNK * SLOT_BLOCK
    for a in range(0, n, rows):
        b = min(n, a + rows)
        x = (stamps[a:b] - stamps[0]) / step
        out[a:b] = np.floor(x - cuts[np.arange(a, b) // SLOT_BLOCK])
    return out


def _cuts(stamps: np.ndarray, step: float) -> np.ndarray:
    """(blocks,) the slot border φ_b of each block of stamps, unwrapped [steps].

    :func:`_missing`: the middle of one of the :data:`CUTS` widest empty arcs
    of the phases in the block and its context, the one with fewest stamps
    sharing a slot, then the fewest slots (ties: the widest arc).
    """
    n = stamps.size
    blocks = -(-n // SLOT_BLOCK)
    width = SLOT_BLOCK + 2 * SLOT_CONTEXT
    cuts = min(CUTS, width)
    out = np.empty(blocks)
    for first in range(0, blocks, _SLOT_CHUNK):
        count = min(_SLOT_CHUNK, blocks - first)
        starts = np.arange(first, first + count) * SLOT_BLOCK - SLOT_CONTEXT
        index = np.clip(starts[:, None] + np.arange(width), 0, n - 1)
        x = (stamps[index] - stamps[0]) / step
        phase = np.sort(x % 1.0, axis=1)
        arcs = np.diff(phase, axis=1, append=phase[:, :1] + 1.0)
        widest = np.argsort(-arcs, axis=1, kind="stable")[:, :cuts]
        middle = np.take_along_axis(phase, widest, 1)
        middle = (middle + np.take_along_axis(arcs, widest, 1) / 2) % 1.0
        slots = np.floor(x[:, None, :] - middle[:, :, None])
        repeated = np.diff(index, axis=1) == 0  # clipped at the ends
        shared = np.count_nonzero(
            (np.diff(slots, axis=2) < 1) & ~repeated[:, None, :], axis=2
        )
        span = slots[:, :, -1] - slots[:, :, 0]
        span -= span.min(axis=1, keepdims=True)
        narrow = (
            np.take_along_axis(arcs, widest, 1) < ARC_SHARE * arcs.max(axis=1)[:, None]
        )
        key = (shared * (width + 2) + span) * cuts + np.arange(cuts)
        key = np.where(narrow, np.inf, key)  # the widest arc is never narrow
        chosen = np.argmin(key, axis=1)
        out[first : first + count] = middle[np.arange(count), chosen]
    return np.unwrap(out, period=1.0)


def _gap_marks(
    target: np.ndarray, stamps: np.ndarray, missing: np.ndarray, fill_gaps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(filled, bad, interval)`` of target stamps against a joined file's gaps.

    ``filled``/``bad``: (len(target),) True where a target stamp lies strictly
    inside an interval of ``stamps`` missing 1 .. ``fill_gaps`` samples, or more
    (``missing``: the first of :func:`_missing`); ``interval``: the interval of
    each target. ``stamps`` cover ``target``.
    """
    if stamps.size < 2:
        none = np.zeros(target.shape, dtype=bool)
        return none, none, np.zeros(target.shape, np.int64)
    right = np.clip(np.searchsorted(stamps, target, side="right"), 1, stamps.size - 1)
    before, after = stamps[right - 1], stamps[right]
    count = missing[right - 1]
    inside = (count > 0) & (before != target) & (after != target)
    return inside & (count <= fill_gaps), inside & (count > fill_gaps), right - 1


@dataclass
class _Gaps:
    """What the join met in one joined file's gaps (for its warning)."""

    filled: int = 0
    bad: int = 0
    intervals: set[int] | None = None

    def add(self, filled: np.ndarray, bad: np.ndarray, interval: np.ndarray) -> None:
        self.filled += int(filled.sum())
        self.bad += int(bad.sum())
        if self.intervals is None:
            self.intervals = set()
        self.intervals.update(interval[filled | bad].tolist())

    def warning(self, path: str, stamps: np.ndarray, missing: np.ndarray, fill_gaps):
        """The sentence naming the gaps, or None without any."""
        if not self.intervals:
            return None
        where = sorted(self.intervals)
        longest = max(where, key=lambda i: missing[i])
        return (
            f"file {path}: {len(where)} gap(s) of its time stamps ("
            f"{int(missing[where].sum())} of its samples missing; the longest: "
            f"{int(missing[longest])} between {stamps[longest]:.16g} and "
            f"{stamps[longest + 1]:.16g}), counted in its own samples: "
            f"{self.filled} time stamp(s) of the first file in gaps of up to "
            f"{fill_gaps} samples (--fill-gaps) interpolated linearly (filled), "
            f"{self.bad} in longer gaps without a value (bad samples, not a line "
            "across the gap)."
        )


@dataclass(frozen=True)
class RawTable:
    """Named columns of one or several joined files.

    Attributes:
        columns: ``{name: (N,) array}``: the requested columns, on the first file's
            (common-span) time stamps.
        warnings: what was joined, interpolated or not read, one sentence each.
        extra: names of the columns present in the files and not requested.
        gap_filled: (N,) bool, the rows inside a gap of a joined file of up to
            ``fill_gaps`` of its samples (interpolated: filled), or None.
        gap_bad: (N,) bool, the rows inside a longer gap (NaN: bad), or None.
    """

    columns: dict[str, np.ndarray]
    warnings: tuple[str, ...] = ()
    extra: tuple[str, ...] = ()
    gap_filled: np.ndarray | None = None
    gap_bad: np.ndarray | None = None


def _header(path: str) -> list[str]:
    if not os.path.exists(path):
        raise FileNotFoundError(f"log {path}: no such file.")
    if os.path.isdir(path):
        raise IsADirectoryError(f"log {path}: is a directory, expected a CSV file.")
    with open(path, "rb") as stream:  # the readers' header: encoding, BOM, blanks
        header = read_header(path, stream)
    duplicated = sorted({h for h in header if header.count(h) > 1})
    if duplicated:
        raise ValueError(f"log {path}: duplicated column(s) {listed(duplicated)}.")
    return header


def _read_columns(path: str, header: list[str], names: list[str]) -> np.ndarray:
    """(N, len(names)) numbers of the named columns; fast path, then cell by cell."""
    index = [header.index(name) for name in names]
    refuse_incomplete(path)  # np.loadtxt skips a '#' line
    try:
        with warnings_module.catch_warnings():
            warnings_module.simplefilter("error")  # "input contained no data"
            data = np.loadtxt(
                path,
                delimiter=",",
                skiprows=1,
                usecols=index,
                ndmin=2,
                dtype=float,
                encoding="utf-8",
            )
        if data.shape[1] == len(names) and data.shape[0] > 0:
            return data
    except (ValueError, UserWarning, IndexError):
        pass
    with open(path, newline="", encoding="utf-8") as stream:
        rows = [r for r in csv.reader(stream) if any(cell.strip() for cell in r)]
    body = rows[1:]
    if not body:
        raise ValueError(f"log {path}: the header has no data rows below it.")
    out = np.empty((len(body), len(names)))
    for r, row in enumerate(body):
        line = r + 2  # 1-based, after the header
        if len(row) != len(header):
            cut = row and incomplete_export(path, line, row[0])
            if cut:
                raise ValueError(cut)
            raise ValueError(
                f"log {path}: row {line} has {len(row)} cells; the header has "
                f"{len(header)}."
            )
        for c, i in enumerate(index):
            out[r, c] = parse_cell(path, row[i], line, names[c])
    return out


def _check_stamps(path: str, t: np.ndarray, time: str) -> None:
    """Finite, increasing stamps of a file (data row i is the file's row i + 2)."""
    _check_block_stamps(path, t, 0, None, np.arange(2, t.size + 2), time)


def _checked_headers(
    files: list[str], wanted: list[str], time: str
) -> tuple[dict[str, list[str]], dict[str, str]]:
    """``({file: header}, {column: the file holding it})``, or the error.

    A file given twice, missing or without a header, a column in no file or in
    two, a file of a multi-file log without the ``time`` column.
    """
    _check_distinct(files)
    headers = {path: _header(path) for path in files}
    owner = _owners(files, headers, wanted, time)
    if len(files) > 1:
        lacking = [path for path in files if time not in headers[path]]
        if lacking:
            raise ValueError(
                f"log {lacking[0]}: no time column '{time}'; every file of a "
                "multi-file log needs it (the files are joined on it)."
            )
    return headers, owner


def _owners(
    files: list[str], headers: dict[str, list[str]], wanted: list[str], time: str
) -> dict[str, str]:
    """``{column: the file holding it}``; a column in no file or in two is an error."""
    owner: dict[str, str] = {}
    for name in wanted:
        holders = [path for path in files if name in headers[path]]
        if name != time and len(holders) > 1:
            raise ValueError(
                f"log: column '{name}' is in several files ({listed(holders)}); "
                "keep it in one."
            )
        if holders:
            owner[name] = holders[0]
    missing = [name for name in wanted if name not in owner]
    if missing:
        found = listed((f"{p}: {listed(headers[p])}" for p in files), sep="; ")
        # A header of one cell holding ; tab or |: another separator (the plain
        # reader's hint, log_table._format_hint).
        other = [
            p
            for p in files
            if len(headers[p]) == 1 and any(sep in headers[p][0] for sep in ";\t|")
        ]
        hint = (
            f"; the header of {listed(other)} looks separated by another "
            "character than a comma: the log must be comma-separated (CSV)"
            if other
            else ""
        )
        raise ValueError(
            f"log {listed(files)}: no column(s) {listed(map(repr, missing))} "
            f"(found: {found}){hint}."
        )
    return owner


def read_raw_table(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    columns: Sequence[str],
    time: str,
    fill_gaps: int = FILL_GAPS,
) -> RawTable:
    """Reads the named columns of one or several CSV files, joined on ``time``.

    Args:
        paths: one file or several (module docstring, step 2).
        columns: the columns to read (``time`` among them or not).
        time: the name of the time column (raw units, the same in every file).
        fill_gaps: the longest gap of a joined file, in its own samples, whose
            first-file stamps keep the join's interpolation (module docstring).

    Returns:
        The :class:`RawTable`.

    Raises:
        FileNotFoundError: a missing file. ValueError: a column in no file or in
            two, a file without the time column, bad cells, unsorted stamps, files
            without a common time span.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    files = [os.fspath(p) for p in paths]
    if not files:
        raise ValueError("log: no file given.")
    Options.checked(
        f"log {listed(files, sep=' + ')}", JITTER_TOLERANCE, False, fill_gaps, None
    )
    wanted = [name for name in dict.fromkeys([time, *columns])]
    headers, owner = _checked_headers(files, wanted, time)
    warnings: list[str] = []
    data: dict[str, np.ndarray] = {}
    stamps: dict[str, np.ndarray] = {}
    for path in files:
        names = [time] + [n for n in wanted if n != time and owner[n] == path]
        if len(names) == 1 and path != files[0]:
            warnings.append(f"file {path}: holds no needed column; not used.")
            continue
        block = _read_columns(path, headers[path], names)
        _check_stamps(path, block[:, 0], time)
        stamps[path] = block[:, 0]
        for k, name in enumerate(names[1:], start=1):
            data[name] = block[:, k]
    base = files[0]
    t = stamps[base]
    keep = np.ones(t.size, dtype=bool)
    for path, other in stamps.items():
        if path == base:
            continue
        keep &= (t >= other[0]) & (t <= other[-1])
    if not keep.any():
        raise ValueError(
            f"log {listed(files)}: the files have no common time span "
            f"('{time}' of {base}: {t[0]:.16g} .. {t[-1]:.16g})."
        )
    out = {time: t[keep]}
    gap_filled = np.zeros(int(keep.sum()), bool)
    gap_bad = np.zeros(int(keep.sum()), bool)
    for path, other in stamps.items():
        names = [n for n in wanted if n != time and owner[n] == path]
        same = other.shape == t.shape and np.array_equal(other, t)
        if path == base or same:  # read at its own stamps: no gap to count
            for name in names:
                out[name] = data[name][keep]
            continue
        missing, shared, found = _missing(other)
        filled, bad, interval = _gap_marks(t[keep], other, missing, fill_gaps)
        for name in names:
            out[name] = np.interp(t[keep], other, data[name])
            out[name][bad] = np.nan
        if names:
            warnings.append(
                f"file {path}: {len(names)} column(s) interpolated linearly onto "
                f"the time stamps of {base} over the common span "
                f"{t[keep][0]:.16g} .. {t[keep][-1]:.16g} ('{time}')."
            )
            gaps = _Gaps()
            gaps.add(filled, bad, interval)
            gap_filled |= filled
            gap_bad |= bad
            note = gaps.warning(path, other, missing, fill_gaps)
            if note:
                warnings.append(note)
            if found:
                warnings.append(_found_note(path, found))
            if shared:
                warnings.append(_beyond_note(path, shared, other.size))
    dropped = int(t.size - keep.sum())
    if dropped:
        warnings.append(
            f"{dropped} row(s) of {base} outside the common time span of the files "
            "dropped."
        )
    extra = tuple(
        dict.fromkeys(
            name for path in files for name in unused_columns(headers[path], owner)
        )
    )
    return RawTable(out, tuple(warnings), extra, gap_filled, gap_bad)


def read_raw_log(
    paths: str | os.PathLike | Sequence[str | os.PathLike],
    chain: DriveChain,
    *,
    jitter_tolerance: float = JITTER_TOLERANCE,
    resample: bool = False,
    fill_gaps: int = FILL_GAPS,
):
    """Reads a raw log through a drive chain into a ``drake_dynid.logs.RobotLog``.

    Args:
        paths: one CSV file or several joined on the time column (module
            docstring).
        chain: the drive chain (``RobotModel.drive``, or an identity chain for the
            plain ``t, q_<joint>, tau_<joint>`` format split over several files).
        jitter_tolerance: as ``drake_dynid.logs.read_log``.
        resample: as ``drake_dynid.logs.read_log``.
        fill_gaps: as ``drake_dynid.logs.read_log``.

    Returns:
        The uniformly sampled log in joint space (SI units, ``chain.joint_names``
        order), with the warnings of the join, the conversion and the grid.
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    files = [os.fspath(p) for p in paths]
    if not files:
        raise ValueError("log: no file given.")
    return _read_streamed(files, chain, jitter_tolerance, resample, fill_gaps)


def _check_distinct(files: Sequence[str]) -> None:
    """ValueError when one file is given twice (by any spelling or link)."""
    repeated = repeated_file(files)
    if repeated:
        raise ValueError(
            f"log: a file is given twice: {repeated[0]} and {repeated[1]} are the "
            "same file; give each file of the log once."
        )


def _extra_note(extra: Sequence[str]) -> list[str]:
    """The warning that counts the columns the drive chain does not use."""
    if not extra:
        return []
    listed = listed_columns(extra)
    return [f"{len(extra)} column(s) not used by the drive chain: {listed}."]


def _read_streamed(
    files: list[str],
    chain: DriveChain,
    jitter_tolerance: float,
    resample: bool,
    fill_gaps: int = FILL_GAPS,
) -> Any:
    """One or several raw files, streamed (module docstring).

    Each file's needed columns are read by ``drake_dynid.log_table``'s block
    parser (a long log's numbers go to temporary files) and a joined file's
    stamps checked a block at a time; the first file's stamps are the time base
    (its rows inside the files' common span; an outlier stamp bridged for the
    join, :func:`_join_stamps`), every other file's columns are taken as they are
    when its stamps equal the base's, else interpolated linearly onto them, a
    block of base rows at a time (the same numbers as :func:`read_raw_table`'s
    ``np.interp`` over whole columns); ``chain.convert`` then runs a block at a
    time (the time origin ``first``: the first kept stamp) into row stores, and
    ``drake_dynid.log_repair.repair`` puts them on the grid. The numbers are those
    of the whole-column path (``read_raw_table``, ``convert``,
    ``RobotLog.from_arrays``): bit for bit with a diagonal drive, to round-off
    (4e-16) with a coupled one (its matrix products by blocks). Memory: a few
    blocks and the stamps (8 bytes a row of each file); messages name the first
    file's rows. Stricter than ``read_raw_table``'s ``np.loadtxt`` (as the plain
    reader): a row with an extra non-empty cell or a ``#`` comment line is an
    error naming the row, a cut-short last row is dropped with a warning;
    trailing commas (empty extra cells) are read.
    """
    from drake_dynid.core._threads import release_heap
    from drake_dynid.log_repair import repair
    from drake_dynid.log_store import RowSink
    from drake_dynid.log_table import LineNumbers
    from drake_dynid.logs import RobotLog

    log = chain.log
    time = log.time
    label = listed(files, sep=" + ")
    options = Options.checked(
        f"log {label}", jitter_tolerance, resample, fill_gaps, None
    )
    wanted = list(dict.fromkeys([time, *chain.required_columns()]))
    positions = set(chain.log.position_columns)
    headers, owner = _checked_headers(files, wanted, time)
    warnings: list[str] = []
    notes: list[str] = []
    tables: dict[str, tuple[list[str], Any, Any, Any]] = {}  # names, t, values, rows
    for path in files:
        names = [n for n in wanted if n != time and owner[n] == path]
        if not names and path != files[0]:
            warnings.append(f"file {path}: holds no needed column; not used.")
            continue
        stamps, values, rows, read_notes = _read_file(path, names, time)
        tables[path] = (names, stamps, values, rows)
        notes += read_notes
    base = files[0]
    stamps = tables[base][1]
    same = {
        path: other is stamps
        or (
            other.shape == stamps.shape
            and bool(np.array_equal(other, stamps, equal_nan=True))
        )
        for path, (_, other, _, _) in tables.items()
    }
    for path, (names, other, values, rows) in list(tables.items()):
        if not same[path]:  # interpolated over: finite and increasing
            other, values, rows, dropped = _drop_empty_stamps(
                path, other, values, rows, time
            )
            tables[path] = (names, other, values, rows)
            notes += dropped
            _check_file_stamps(path, other, rows, time)
    # The time base's stamps (and a file's equal to them) go to repair's checks.
    t = _join_stamps(f"log {label}", stamps, tables[base][3], fill_gaps)
    low, high = 0, t.size  # the base rows inside every file's span
    for path, (_, other, _, _) in tables.items():
        if not same[path]:
            low = max(low, int(np.searchsorted(t, other[0], side="left")))
            high = min(high, int(np.searchsorted(t, other[-1], side="right")))
    if high <= low:
        raise ValueError(
            f"log {listed(files)}: the files have no common time span "
            f"('{time}' of {base}: {t[0]:.16g} .. {t[-1]:.16g})."
        )
    for path, (names, _, _, _) in tables.items():
        if not same[path] and names:
            warnings.append(
                f"file {path}: {len(names)} column(s) interpolated linearly onto "
                f"the time stamps of {base} over the common span "
                f"{t[low]:.16g} .. {t[high - 1]:.16g} ('{time}')."
                + _denser_note(
                    path,
                    tables[path][1],
                    base,
                    t,
                    positions & set(names),
                    log.time_scale,
                )
            )
    if t.size - (high - low):
        warnings.append(
            f"{t.size - (high - low)} row(s) of {base} outside the common time span "
            "of the files dropped."
        )
    extra = tuple(
        dict.fromkeys(
            name for path in files for name in unused_columns(headers[path], owner)
        )
    )
    n = len(chain.joint_names)
    sinks = RowSink(1), RowSink(n), RowSink(n)
    first = float(t[low])
    counted = {
        path: _missing(other)
        for path, (names, other, _, _) in tables.items()
        if names and not same[path]
    }
    missing = {path: found[0] for path, found in counted.items()}
    gaps = {path: _Gaps() for path in missing}
    gap_filled = np.zeros(high - low, bool)
    gap_bad = np.zeros(high - low, bool)
    for start in range(low, high, _blocks.BLOCK_ROWS):
        stop = min(high, start + _blocks.BLOCK_ROWS)
        here = t[start:stop]
        columns = {time: stamps[start:stop]}  # as read: repair drops the outliers
        for path, (names, other, values, _) in tables.items():
            if not names:
                continue
            if same[path]:
                block = np.asarray(values[start:stop], dtype=float)
            else:  # the other file's rows around these stamps, interpolated
                a = max(0, int(np.searchsorted(other, here[0], side="right")) - 1)
                b = int(np.searchsorted(other, here[-1], side="left")) + 1
                part = np.asarray(values[a:b], dtype=float)
                block = np.column_stack(
                    [np.interp(here, other[a:b], column) for column in part.T]
                )
                filled, bad, interval = _gap_marks(
                    here, other, missing[path], fill_gaps
                )
                block[bad] = np.nan
                gaps[path].add(filled, bad, interval)
                gap_filled[start - low : stop - low] |= filled
                gap_bad[start - low : stop - low] |= bad
            columns.update(zip(names, block.T, strict=True))
        converted = chain.convert(columns, first_stamp=first)
        for sink, values_ in zip(sinks, converted, strict=True):
            sink.append(values_)
    rows = tables[base][3]
    if isinstance(rows, LineNumbers):
        rows = LineNumbers(rows.first + low, high - low)
    else:
        rows = np.asarray(rows[low:high])
    for path, found in gaps.items():
        note = found.warning(path, tables[path][1], missing[path], fill_gaps)
        if note:
            warnings.append(note)
        if counted[path][2]:
            warnings.append(_found_note(path, counted[path][2]))
        if counted[path][1]:
            warnings.append(_beyond_note(path, counted[path][1], tables[path][1].size))
    del tables
    q_t, q, tau = (sink.finish(vector=k == 0) for k, sink in enumerate(sinks))
    notes = warnings + _extra_note(extra) + notes
    repaired = repair(
        f"log {label}",
        "row",
        q_t,
        None,
        q,
        tau,
        rows,
        options,
        notes,
        joined=(gap_filled, gap_bad),
        unit_given=log.time_unit_given,
    )
    release_heap()  # the reader's temporaries: not under the next phase's peak
    return RobotLog._named(repaired, tuple(chain.joint_names))


def _join_stamps(owner: str, t: np.ndarray, rows: Any, fill_gaps: int) -> np.ndarray:
    """The time base's stamps for the join: increasing, outliers bridged.

    ``t`` itself when it is finite and increasing; else a copy in which the rows
    that ``repair`` drops first (``core.timestamps.order_outliers``: a stamp not
    finite, or one corrupted amid good ones, as in the plain reader) take the
    stamps interpolated linearly between their kept neighbours (held at the
    ends), so that the other files are joined onto an ordered base. The rows
    keep their stamps as read: ``repair`` drops them and says so (the plain
    reader's warning). A break that is no outlier is the plain reader's error.
    """
    from drake_dynid.core.timestamps import order_outliers

    steps = np.diff(t)
    if np.all(np.isfinite(t)) and np.all(steps > 0.0):
        return t

    def where(i: int) -> str:
        return f"row {rows[i]} (t = {t[i]:.16g})"

    keep = order_outliers(t, edge_gap=fill_gaps, owner=owner, where=where)
    if np.count_nonzero(keep) < 2:
        return t  # repair refuses it (too few stamps), naming the rows
    out = t.copy()
    kept = np.flatnonzero(keep)
    dropped = np.flatnonzero(~keep)
    out[dropped] = np.interp(dropped, kept, t[kept])
    return out


def _drop_empty_stamps(
    path: str, stamps: np.ndarray, values: Any, rows: Any, time: str
) -> tuple[np.ndarray, Any, Any, list[str]]:
    """A joined file's rows whose stamp is empty or not finite, dropped.

    As the plain reader drops a corrupted stamp (``log_repair.repair``): at most
    3 + 1 in 1000 of the file's rows (more, or fewer than 10 left: the error
    naming the first), each named in a note; the file then misses those samples
    (a gap of its own, bridged as any other, :func:`_missing`). ``values`` is
    read through the kept rows (:class:`_KeptRows`). Returns ``(stamps, values,
    rows, notes)``.
    """
    keep = np.isfinite(stamps)
    bad = np.flatnonzero(~keep)
    if not bad.size:
        return stamps, values, rows, []
    if not stamps_droppable(bad.size, stamps.size):
        raise ValueError(
            f"log {path}: time stamp ('{time}') of row {rows[int(bad[0])]} is "
            f"empty or not finite ({bad.size} such rows of {stamps.size}; up to "
            "3 + 1 in 1000 are dropped)."
        )
    note = (
        f"file {path}: dropped {rows_text('row', rows[bad])}: time stamp "
        f"('{time}') empty or not finite."
    )
    index = np.flatnonzero(keep)
    kept_values = None if values is None else _KeptRows(values, index)
    return stamps[keep], kept_values, np.asarray(rows[keep]), [note]


class _KeptRows:
    """Rows ``index`` of a file's values (an array or a stored array), by slices.

    The join reads a joined file's values as ``values[a:b]``; with rows dropped
    (:func:`_drop_empty_stamps`) slice ``a:b`` of the kept rows is
    ``values[index[a:b]]``, read from the store a slice at a time.
    """

    def __init__(self, values: Any, index: np.ndarray):
        self.values, self.index = values, index

    def __len__(self) -> int:
        return int(self.index.size)

    def __getitem__(self, rows: slice) -> np.ndarray:
        return np.asarray(self.values[self.index[rows]], dtype=float)


def _check_file_stamps(path: str, stamps: np.ndarray, rows: Any, time: str) -> None:
    """Finite, increasing stamps of a joined file, checked a block at a time."""
    previous = None
    for start, block in _blocks.blocks(stamps, _blocks.BLOCK_ROWS):
        _check_block_stamps(path, block, start, previous, rows, time)
        previous = float(block[-1])


def _read_file(
    path: str, names: list[str], time: str
) -> tuple[np.ndarray, Any, Any, list[str]]:
    """``(stamps, values, rows, notes)`` of one file of a raw log, streamed.

    ``drake_dynid.log_table.read_table`` of the ``time`` column and ``names``
    (values: (R, len(names)), an array or a stored array; None without names),
    the stamps kept (8 bytes a row: the join needs them; checked by the caller),
    the file's row numbers and the parser's notes.
    """
    from drake_dynid.log_table import read_table

    with open(path, "rb") as stream:
        groups = (len(names),) if names else ()
        table = read_table(path, stream, [time, *names], groups)
    stamps = np.empty(len(table.rows))
    for start, block in _blocks.blocks(table.t, _blocks.BLOCK_ROWS):
        stamps[start : start + block.size] = block
    return stamps, table.parts[0] if names else None, table.rows, table.notes


def _check_block_stamps(
    path: str,
    t: np.ndarray,
    start: int,
    previous: float | None,
    rows: Any,
    time: str,
) -> None:
    """Finite, increasing stamps ``t`` of the data rows ``start ..`` of a file.

    ``previous``: the stamp of the row before them (None: they are the first);
    ``rows[i]``: the file's row number of data row i, for the messages.
    """
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ValueError(
            f"log {path}: time stamp ('{time}') of row {rows[start + bad[0]]} is "
            "empty or not finite."
        )
    joined = t if previous is None else np.concatenate(([previous], t))
    steps = np.diff(joined)
    if np.any(steps <= 0.0):
        k = int(np.flatnonzero(steps <= 0.0)[0])  # joined[k] then joined[k + 1]
        i = k + (1 if previous is None else 0)
        raise ValueError(
            f"log {path}: time stamps ('{time}') are not increasing at row "
            f"{rows[start + i]} (t = {joined[k + 1]:.16g}) after row "
            f"{rows[start + i - 1]} (t = {joined[k]:.16g}); sort the file by time "
            "and remove duplicated rows."
        )


def write_raw_log(
    path: str | os.PathLike,
    chain: DriveChain,
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
) -> None:
    """Writes joint signals as one CSV file in ``chain``'s raw conventions.

    The columns are ``chain.required_columns()`` (time, positions, torques, in
    that order), the values ``chain.to_columns(t, q, tau)``: time in the
    ``[log] time_unit``, positions on the ``position_side`` in its units with its
    offsets, torques on the ``torque_side`` (motor torques τ_m = R⁻ᵀ τ, the
    minimum-norm solution with more motors than joints) or currents
    i = τ_m / (k_t s_i); 17 significant digits, so that :func:`read_raw_log`
    gives back t, q, τ to round-off.

    Args:
        path: the output file.
        chain: the drive chain.
        t: (N,) time [s] (from 0).
        q: (N, n) joint positions [rad or m], ``chain.joint_names`` order.
        tau: (N, n) joint torques [N·m or N].
    """
    columns = chain.to_columns(t, q, tau)
    names = chain.required_columns()
    data = np.column_stack([columns[name] for name in names])

    def write(stream):
        csv.writer(stream, lineterminator="\n").writerow(names)
        np.savetxt(stream, data, delimiter=",", fmt="%.17g")

    write_whole(path, write)  # a full disk leaves no truncated log
