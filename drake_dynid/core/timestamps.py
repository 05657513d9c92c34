"""Uniform time grids fitted to recorded time stamps, and short-gap interpolation.

Model of a logger (README "Log format"): sample j was taken at slot k_j of a uniform
grid of step h and origin t0, and its time stamp carries a jitter e_j::

    t_j = t0 + h·k_j + e_j,     0 = k_0 < k_1 < ... ,     |e_j| <= tolerance·h

Missing slots (k_{j+1} - k_j > 1) are dropped samples. The fit (``fit_time_grid``):

1. first guess h₀ = median step; a step is broken when it is <= 0 (a time stamp going
   back) or longer than the largest gap the caller accepts. Up to ``max_outliers``
   rows whose stamps break the chain (an isolated corrupted stamp in the middle, a
   few at either end) are dropped as outliers; any other break is an error naming
   the rows;
2. slots from the local steps, k_{j+1} - k_j = max(1, round((t_{j+1} - t_j)/h₀)):
   a small error of h₀ never accumulates over a long log (the median step is off by
   about 3·10⁻⁴·h with ±5 % jitter, 9 steps of drift over 30 000 samples);
3. t0 and h by least squares over the accepted samples, slots re-read from the fitted
   grid, fit repeated; the deviations e_j/h [steps] must be within ``tolerance``,
   except for a few isolated rows (outliers, dropped);
4. the nominal step is the simplest round number (a decimal with few digits, or 1/f
   with f an integer rate in Hz) within 10⁻⁴ of the fitted step (a clock-rate error
   no identification can see) on which every kept stamp is still within the
   tolerance (origin refitted), else the fitted step: the step then divides the
   periods of the on-line blocks exactly.

A gap whose length is not a whole number of steps, by more than the jitter of the
other steps (``phase_breaks``: a logger restarted, a clock stepped forward), is no
jitter: the caller moves the later stamps onto the earlier grid and keeps the gap
unfilled (``drake_dynid.log_repair``), the log split there.

A gap would insert missing slots: their total is bounded by ``max_inserted`` and
checked before anything is allocated. Pure numpy; no file or row notions: the caller
names the samples through ``where`` (e.g. ``"row 12 (t = 0.011)"``).

Memory: the fit holds the slots (int64) and a few (N,) masks, never a copy of the
stamps; ``t`` may be a stored array of a long log (``core.blocks``), read a chunk
of ``_CHUNK`` samples at a time. Up to ``_CHUNK`` samples the sums are those of one
piece; beyond, they are taken in pieces (the same to round-off). The short-run
interpolation is ``core.short_runs.fill_short_runs`` (re-exported here).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core.blocks import is_stored
from drake_dynid.core.short_runs import fill_short_runs

__all__ = [
    "NonUniformSampling",
    "TimeGrid",
    "fill_short_runs",
    "fit_time_grid",
    "nominal_step",
    "order_outliers",
    "phase_breaks",
]

STEP_AGREEMENT = 1e-5  # nominal_step: relative agreement (10 ppm)
MAX_RATE_ERROR = 1e-4  # fit_time_grid: largest clock-rate change of the nominal step


class NonUniformSampling(ValueError):
    """The time stamps are not a jittered uniform grid (a resampling may help)."""

    def __init__(self, message: str, kept: np.ndarray, step: float):
        super().__init__(message)
        self.kept = kept  # (N,) bool: rows left after dropping outlier stamps
        self.step = step  # the first guess h₀ [s]


@dataclass(frozen=True)
class TimeGrid:
    """A uniform grid fitted to time stamps.

    Attributes:
        step: nominal step h [s] (the fitted step, rounded when within 10⁻⁵).
        fitted_step: least-squares step [s].
        origin: grid origin t0 [s], in the time base of the stamps given.
        kept: (N,) bool, False for the rows dropped as outlier stamps.
        slots: (M,) int64 slot k_j of each kept row, slots[0] == 0, increasing.
        jitter: the largest deviation |e_j|/h of a kept stamp from the grid
            [steps].
    """

    step: float
    fitted_step: float
    origin: float
    kept: np.ndarray
    slots: np.ndarray
    jitter: float

    @property
    def num_slots(self) -> int:
        """Number of grid slots from the first to the last kept sample."""
        return int(self.slots[-1]) + 1

    @property
    def outliers(self) -> np.ndarray:
        """Indices of the rows dropped as outlier stamps."""
        return np.flatnonzero(~self.kept)


def _default_where(i: int) -> str:
    return f"sample {i}"


def _step_candidates(h: float):
    """Round steps near ``h``, simplest first.

    1-4 significant digits, 1/f with f an integer rate [Hz], then 5-6 digits.
    """
    for digits in range(1, 5):
        yield float(f"{h:.{digits}g}")
    rate = round(1.0 / h)
    if rate >= 1:
        yield 1.0 / rate
    for digits in (5, 6):
        yield float(f"{h:.{digits}g}")


def nominal_step(h: float, agreement: float = STEP_AGREEMENT) -> float:
    """The simplest round step within ``agreement`` (relative) of ``h``, else ``h``.

    Candidates, in order: ``h`` rounded to 1-4 significant digits, 1/f for the
    integer rate f = round(1/h) [Hz], ``h`` rounded to 5-6 digits.
    """
    if not (math.isfinite(h) and h > 0.0):
        return h
    for candidate in _step_candidates(h):
        if abs(candidate / h - 1.0) <= agreement:
            return candidate
    return h


_CHUNK = 1 << 18
"""Samples per pass of the grid fit: a log up to this length is fitted in one
piece; a longer one chunk by chunk (the same arithmetic, its sums taken in
pieces), in memory of a few (N,) arrays whatever N."""


class _Stamps:
    """The relative stamps s_j = t[rows_j] - t[rows_0] of the kept rows, by chunks.

    Never holds s itself: a chunk is computed from t when needed (the same
    subtraction, element by element); ``rows`` is None when every row is kept.
    """

    def __init__(self, t: Any, keep: np.ndarray):
        self.t = t
        self.rows = None if keep.all() else np.flatnonzero(keep)
        self.count = len(t) if self.rows is None else int(self.rows.size)
        self.first = float(t[self.row(0)]) if self.count else math.nan

    def row(self, j: int) -> int:
        """The row of t of kept sample j."""
        return j if self.rows is None else int(self.rows[j])

    def chunk(self, a: int, b: int) -> np.ndarray:
        """s_j for j in [a, b)."""
        rows = slice(a, b) if self.rows is None else self.rows[a:b]
        with np.errstate(over="ignore", invalid="ignore"):
            return np.asarray(self.t[rows], dtype=float) - self.first

    def spans(self) -> list[tuple[int, int]]:
        """The [a, b) chunks covering the kept samples."""
        return [(a, min(self.count, a + _CHUNK)) for a in range(0, self.count, _CHUNK)]

    def total(self, term: Callable[[int, int], Any]) -> float:
        """Σ over the chunks of ``term(a, b)`` (one chunk: that one sum)."""
        out = 0.0
        for a, b in self.spans():
            out += float(term(a, b))
        return out


def _nominal(s: _Stamps, slots, h, c, jitter, tolerance):
    """(step, origin, jitter) on the simplest round step fitting the stamps.

    The step is within ``MAX_RATE_ERROR`` of h and every deviation within tolerance.
    """
    for step in _step_candidates(h):
        if abs(step / h - 1.0) > MAX_RATE_ERROR:
            continue

        def shifted(a: int, b: int, w: float = step) -> float:
            return float(np.sum(s.chunk(a, b) - w * slots[a:b]))

        origin = float(s.total(shifted) / s.count)

        def fresh(a: int, b: int, w: float = step, o: float = origin) -> np.ndarray:
            return (s.chunk(a, b) - o) / w - slots[a:b]

        largest = 0.0
        for a, b in s.spans():
            size = np.abs(fresh(a, b))
            if not np.all(size <= tolerance):
                break
            largest = max(largest, float(size.max()))
        else:
            return step, origin, largest
    return h, c, jitter


def _fit(s: _Stamps, k: np.ndarray) -> tuple[float, float]:
    """Least squares s ≈ c + h·k; returns (h, c)."""
    k_mean = s.total(lambda a, b: np.sum(k[a:b].astype(float))) / s.count
    s_mean = s.total(lambda a, b: np.sum(s.chunk(a, b))) / s.count

    def dk(a: int, b: int) -> np.ndarray:
        return k[a:b].astype(float) - k_mean

    denominator = s.total(lambda a, b: dk(a, b) @ dk(a, b))
    if denominator == 0.0:
        return math.nan, math.nan
    h = s.total(lambda a, b: dk(a, b) @ (s.chunk(a, b) - s_mean)) / denominator
    return h, float(s_mean - h * k_mean)


def _steps(t: Any) -> np.ndarray:
    """(N - 1,) t[i+1] - t[i] (``np.diff``), a chunk of t at a time."""
    out = np.empty(max(0, len(t) - 1))
    with np.errstate(over="ignore", invalid="ignore"):
        for a in range(0, out.size, _CHUNK):
            b = min(out.size, a + _CHUNK)
            np.subtract(*_pair(t, a, b), out=out[a:b])
    return out


def _pair(t: Any, a: int, b: int) -> tuple[np.ndarray, np.ndarray]:
    """(t[a+1 : b+1], t[a:b]), read once."""
    x = np.asarray(t[a : b + 1], dtype=float)
    return x[1:], x[:-1]


def _steps_ok(t: Any, d_max: float, d_edge: float, run: int) -> np.ndarray:
    """(N - 1,) bool: each step t[i+1] - t[i] in (0, d], a chunk at a time.

    d = d_edge for the ``run`` first and last steps (every step when run = 0, as
    ``edge[-0:]``), d_max elsewhere.
    """
    good = np.empty(max(0, t.size - 1), bool)
    tail = good.size - min(run, good.size) if run else 0
    with np.errstate(over="ignore", invalid="ignore"):
        for a in range(0, good.size, _CHUNK):
            b = min(good.size, a + _CHUNK)
            later, earlier = _pair(t, a, b)
            dt = later - earlier
            good[a:b] = (dt > 0.0) & (dt <= d_max)
        for a, b in ((0, min(run, good.size)), (tail, good.size)):
            later, earlier = _pair(t, a, b)
            dt = later - earlier
            good[a:b] = (dt > 0.0) & (dt <= d_edge)
    return good


def _drop_outliers(t, h0, gaps, max_outliers, run, owner, where) -> np.ndarray:
    """Stage 1: rows whose stamps break the chain of steps in (0, gap·h₀].

    ``gaps`` = (longest gap, longest gap next to the first or last ``run`` rows)
    [missing samples].
    """
    n = t.size
    d_max = (gaps[0] + 1.5) * h0
    d_edge = (min(gaps) + 1.5) * h0
    broken = np.flatnonzero(~_steps_ok(t, d_max, d_edge, run))
    keep = np.ones(n, bool)
    if broken.size == 0:
        return keep

    def ok(a: int, b: int) -> bool:
        with np.errstate(over="ignore", invalid="ignore"):
            d = t[b] - t[a]
        near_edge = a < run or b >= n - run
        return bool(0.0 < d <= (d_edge if near_edge else d_max))

    def fail(p: int, b: int) -> None:
        with np.errstate(over="ignore", invalid="ignore"):
            d = float(t[b] - t[p])
        if d <= 0.0:
            raise ValueError(
                f"{owner}: time stamps are not increasing at {where(b)} after "
                f"{where(p)}; sort the log by time."
            )
        if d > d_max:
            raise ValueError(
                f"{owner}: a gap of {d:.6g} s between {where(p)} and {where(b)} would "
                f"insert about {d / h0 - 1:.0f} missing samples of {h0:.6g} s, more "
                f"than the {gaps[0]} allowed (the number of rows read); split the log "
                "there."
            )
        raise ValueError(
            f"{owner}: more than {max_outliers} time stamps off the grid of the "
            f"others (outliers), the last between {where(p)} and {where(b)}; repair "
            "the time stamps or split the log."
        )

    if broken.size > 2 * max_outliers + 2:
        b = int(broken[0])
        fail(b, b + 1)
    start = 0
    for b in (int(i) for i in broken):
        if not keep[b + 1]:
            continue
        p = b
        while p >= start and not keep[p]:
            p -= 1
        bridged = False
        for r in range(b + 1, min(b + 1 + run, n - 1) + 1):
            if p >= start and ok(p, r):
                keep[b + 1 : r] = False
                bridged = True
                break
        if not bridged and n - 1 - b <= run:
            keep[b + 1 :] = False  # a few trailing rows
            bridged = True
        if not bridged and start == 0 and p + 1 <= run:
            keep[: b + 1] = False  # a few leading rows
            start = b + 1
            bridged = True
        if not bridged:
            fail(p, b + 1)
        if int(np.count_nonzero(~keep)) > max_outliers:
            fail(p, b + 1)
    return keep


#: phase_breaks: a gap is a restart only when its fractional part [steps] exceeds
#: this, and PHASE_MARGIN times the largest deviation of the normal steps.
PHASE_FLOOR = 0.1
PHASE_MARGIN = 1.25


def phase_breaks(t: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """Gaps whose length is not a whole number of steps: a logger restarted.

    With r_i = (t[i+1] - t[i]) / h̄, h̄ the mean of the normal steps (r in
    (0.5, 1.5) of the median step; their mean is exact to the jitter over the
    log's length, not the median's 3·10⁻⁴ h), a gap i is a break when::

        r_i >= 1.5  and  |r_i - round(r_i)| > max(PHASE_FLOOR,
                                                  PHASE_MARGIN · max |r_normal - 1|)

    (the normal steps' deviation read against the median step), and the steps
    on either side of it are normal (not a corrupted stamp, which
    the grid fit drops as an outlier). A gap of a dropped sample carries the
    jitter of two stamps, as a normal step does: a jittery log (±20 %: the
    threshold reaches 0.5 step) is never split; a clean one is split where its
    clock stepped. Each break's shift [s] is (ceil(r_i) - r_i)·h̄: the later
    stamps, moved by it, sit on the grid of the earlier ones with at least one
    slot missing at the break.

    Args:
        t: (N,) increasing finite stamps [s] (an array or a stored array), read
            a chunk at a time: memory of one (N,) array of steps (the median).

    Returns:
        (indices, shifts, step): the i of each break (between t[i] and t[i+1]),
        its shift [s], and h̄ [s]. Empty arrays when none.
    """
    none = np.zeros(0, np.int64), np.zeros(0), math.nan
    d = _steps(t)  # the only (N,) array; then a chunk of t at a time
    if d.size < 10 or not np.all(np.isfinite(d)):
        return none
    h0 = float(np.median(d, overwrite_input=True))
    del d
    if not h0 > 0.0:
        return none
    total, count, spread, gaps = 0.0, 0, 0.0, []
    with np.errstate(over="ignore", invalid="ignore"):
        for a in range(0, len(t) - 1, _CHUNK):
            later, earlier = _pair(t, a, min(len(t) - 1, a + _CHUNK))
            step = later - earlier
            normal = (step > 0.5 * h0) & (step < 1.5 * h0)
            total += float(np.sum(step[normal]))
            count += int(np.count_nonzero(normal))
            if normal.any():
                spread = max(spread, float(np.max(np.abs(step[normal] / h0 - 1.0))))
            gaps.append(a + np.flatnonzero(step >= 1.5 * h0))
    if count < 10:
        return none
    h = total / count
    threshold = max(PHASE_FLOOR, PHASE_MARGIN * spread * h0 / h)
    if threshold >= 0.5:
        return none
    indices, shifts = [], []
    for i in (int(i) for i in np.concatenate(gaps)):
        r = float(t[i + 1] - t[i]) / h
        if not (r >= 1.5 and abs(r - round(r)) > threshold):
            continue
        neighbours = [j for j in (i - 1, i + 1) if 0 <= j < len(t) - 1]
        if all(0.5 < float(t[j + 1] - t[j]) / h0 < 1.5 for j in neighbours):
            indices.append(i)
            shifts.append((math.ceil(r) - r) * h)
    return np.array(indices, np.int64), np.array(shifts, float), h


def order_outliers(
    t: Any,
    *,
    max_outlier_run: int = 3,
    edge_gap: int | None = None,
    owner: str = "order_outliers",
    where: Callable[[int], str] | None = None,
) -> np.ndarray:
    """The rows whose stamps ``fit_time_grid`` drops before anything else.

    Stage 1 of the fit (module docstring) over the finite stamps: a row whose
    stamp is not finite, or breaks the chain of steps in (0, gap·h₀] (an isolated
    corrupted stamp, a few at either end), is an outlier; the kept stamps are
    increasing. A reader that must order rows before the fit (a join of files on
    time, ``drake_dynid.raw_log``) uses the kept ones; the fit itself, on the
    same stamps, drops the same rows and reports them.

    Args:
        t: (N,) time stamps [s, or any one unit].
        max_outlier_run: longest run of consecutive outlier rows.
        edge_gap: longest gap [missing samples] accepted after the first or
            before the last ``max_outlier_run`` rows (default N).
        owner: prefix of the error messages.
        where: names sample i in messages (default ``"sample i"``).

    Returns:
        (N,) bool, False for the outlier rows.

    Raises:
        ValueError: a break that is not an outlier (as ``fit_time_grid``).
    """
    where = where or _default_where
    t = np.asarray(t, dtype=float)
    finite = np.isfinite(t)
    rows = np.flatnonzero(finite)
    if rows.size < 2:
        return finite
    s = t[rows]
    n = s.size
    h0 = float(np.median(np.diff(s)))
    if not (math.isfinite(h0) and h0 > 0.0):
        b = int(np.flatnonzero(~(np.diff(s) > 0.0))[0]) + 1
        raise ValueError(
            f"{owner}: time stamps are not increasing at {where(int(rows[b]))} after "
            f"{where(int(rows[b - 1]))}; sort the log by time."
        )
    gaps = (n, n if edge_gap is None else int(edge_gap))
    keep = _drop_outliers(
        s,
        h0,
        gaps,
        3 + n // 1000,
        max_outlier_run,
        owner,
        lambda i: where(int(rows[i])),
    )
    finite[rows[~keep]] = False
    return finite


def fit_time_grid(
    t: np.ndarray,
    tolerance: float = 0.25,
    *,
    max_inserted: int | None = None,
    max_outliers: int | None = None,
    max_outlier_run: int = 3,
    edge_gap: int | None = None,
    owner: str = "fit_time_grid",
    where: Callable[[int], str] | None = None,
) -> TimeGrid:
    """Fits the uniform grid of a logger to its time stamps (see module docstring).

    Args:
        t: (N,) finite time stamps [s], N >= 2, no two equal.
        tolerance: largest accepted |e_j|/h of a kept stamp [steps], in (0, 0.25]
            (the slots are read from the local steps, which must be within ±50 %
            of h).
        max_inserted: largest total number of missing slots (dropped samples) the
            grid may hold; default N (the grid is at most twice the rows read).
        max_outliers: largest number of rows dropped as outlier stamps; default
            3 + N // 1000.
        max_outlier_run: longest run of consecutive outlier rows.
        edge_gap: longest gap [missing samples] accepted after the first or before
            the last ``max_outlier_run`` rows; those rows are dropped as outliers
            beyond it (default ``max_inserted``).
        owner: prefix of the error messages.
        where: names sample i in messages (default ``"sample i"``).

    Returns:
        The fitted grid.

    Raises:
        NonUniformSampling: the stamps are increasing but not on a jittered grid.
        ValueError: stamps going back, or a gap longer than ``max_inserted`` slots.
    """
    where = where or _default_where
    t = t if is_stored(t) else np.asarray(t, dtype=float)
    n = len(t)
    max_inserted = n if max_inserted is None else int(max_inserted)
    max_outliers = 3 + n // 1000 if max_outliers is None else int(max_outliers)
    gaps = (max_inserted, max_inserted if edge_gap is None else int(edge_gap))
    h0 = float(np.median(_steps(t), overwrite_input=True))
    if not (math.isfinite(h0) and h0 > 0.0):
        b = int(np.flatnonzero(~(_steps(t) > 0.0))[0]) + 1
        raise ValueError(
            f"{owner}: time stamps are not increasing at {where(b)} after "
            f"{where(b - 1)}; sort the log by time."
        )
    keep = _drop_outliers(t, h0, gaps, max_outliers, max_outlier_run, owner, where)
    for attempt in range(2):
        s = _Stamps(t, keep)
        if s.count < 2:
            raise ValueError(
                f"{owner}: fewer than 2 samples left after dropping "
                f"{np.count_nonzero(~keep)} outlier time stamp(s)."
            )
        if not all(np.all(np.isfinite(s.chunk(a, b))) for a, b in s.spans()):
            raise ValueError(f"{owner}: the time stamps span more than 1e308 s.")
        slots = _first_slots(s, h0)
        h, c = _fit(s, slots)
        for _ in range(2):  # slots re-read from the fitted grid, then refit
            if not (math.isfinite(h) and h > 0.0) or not _reread(s, slots, h, c):
                break
            h, c = _fit(s, slots)
        off, worst, jitter = _deviations(s, slots, h, c, tolerance)
        if not np.any(off):
            break
        budget = max_outliers - int(np.count_nonzero(~keep))
        isolated = not np.any(off[1:] & off[:-1])
        if attempt or np.count_nonzero(off) > budget or not isolated or s.count < 5:
            if np.count_nonzero(off) > 0.1 * s.count:
                # Most stamps off: the grid fit itself failed; the spread of the
                # steps says more than the worst stamp against a wrong grid.
                low, high = np.quantile(_steps(t) / h0, [0.001, 0.999])
                detail = (
                    f"{np.count_nonzero(off)} of {s.count} stamps are more than "
                    f"{tolerance:g} step off any uniform grid: the steps between "
                    f"stamps range from {low:.2f} to {high:.2f} times their median "
                    f"{h0:.6g} s"
                )
            else:
                detail = (
                    f"{where(s.row(worst))} is {jitter:.2f} steps off the uniform "
                    f"grid of step {h:.6g} s fitted to the time stamps "
                    f"({np.count_nonzero(off)} stamp(s) beyond the tolerance of "
                    f"{tolerance:g} step)"
                )
            raise NonUniformSampling(
                f"{owner}: non-uniform sampling: {detail}; resample it onto a "
                "uniform grid first, or allow linear interpolation "
                "(dynid: --resample).",
                keep,
                h0,
            )
        keep[np.flatnonzero(off) if s.rows is None else s.rows[off]] = False
    inserted = int(slots[-1]) + 1 - slots.size
    if inserted > max_inserted:
        gap = int(np.argmax(np.diff(slots)))
        a, b = s.row(gap), s.row(gap + 1)
        raise ValueError(
            f"{owner}: the gaps in the time stamps would insert {inserted} missing "
            f"samples, more than the {max_inserted} allowed (the number of rows "
            f"read); the longest is {int(slots[gap + 1] - slots[gap]) - 1} samples "
            f"between {where(a)} and {where(b)}; split the log there."
        )
    step, c, jitter = _nominal(s, slots, h, c, jitter, tolerance)
    if abs(c) <= 1e-6 * step:  # round-off: the first stamp is the origin
        c = 0.0
    return TimeGrid(step, h, float(t[s.row(0)] + c), keep, slots, jitter)


def _deviations(s: _Stamps, slots: np.ndarray, h: float, c: float, tolerance: float):
    """(off, worst, largest) of the deviations e_j/h from the grid c + h·k.

    ``off``: (M,) the stamps beyond ``tolerance``; ``worst``: the first of the
    largest |e_j|/h (non-finite: inf); ``largest``: that value [steps].
    """
    off = np.ones(s.count, bool)
    if not h > 0.0:
        return off, 0, math.inf
    worst, largest = 0, -1.0
    for a, b in s.spans():
        size = np.abs((s.chunk(a, b) - c) / h - slots[a:b])
        off[a:b] = ~(size <= tolerance)
        size[~np.isfinite(size)] = np.inf
        k = int(np.argmax(size))
        if size[k] > largest:
            worst, largest = a + k, float(size[k])
    return off, worst, largest


def _first_slots(s: _Stamps, h0: float) -> np.ndarray:
    """Slots from the local steps: k_j - k_{j-1} = max(1, round((s_j - s_{j-1})/h₀)).

    The ratios are <= max_inserted + 1.5 after stage 1; their cumulative sum is
    exact in float64 (integers), chunk by chunk as at once.
    """
    slots = np.zeros(s.count, np.int64)
    carry = 0.0
    for a in range(1, s.count, _CHUNK):
        b = min(s.count, a + _CHUNK)
        ratio = np.diff(s.chunk(a - 1, b)) / h0
        steps = np.cumsum(np.maximum(1, np.rint(ratio))) + carry
        slots[a:b] = steps
        carry = float(steps[-1])
    return slots


def _reread(s: _Stamps, slots: np.ndarray, h: float, c: float) -> bool:
    """Slots re-read from the grid c + h·k, in place.

    False when they are unchanged or not increasing (``slots`` left as it was).
    """
    zero = int(np.rint((s.chunk(0, 1)[0] - c) / h))

    def fresh(a: int, b: int) -> np.ndarray:
        out = np.rint((s.chunk(a, b) - c) / h).astype(np.int64)
        out -= zero
        return out

    equal, last = True, None
    for a, b in s.spans():
        part = fresh(a, b)
        equal = equal and np.array_equal(part, slots[a:b])
        steps = np.diff(part if last is None else np.concatenate([[last], part]))
        if np.any(steps < 1):
            return False
        last = int(part[-1])
    if equal:
        return False
    for a, b in s.spans():
        slots[a:b] = fresh(a, b)
    return True
