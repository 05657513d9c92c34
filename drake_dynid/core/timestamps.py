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

A gap would insert missing slots: their total is bounded by ``max_inserted`` and
checked before anything is allocated. Pure numpy; no file or row notions: the caller
names the samples through ``where`` (e.g. ``"row 12 (t = 0.011)"``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = [
    "NonUniformSampling",
    "TimeGrid",
    "fill_short_runs",
    "fit_time_grid",
    "nominal_step",
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
        deviation: (M,) signed deviation e_j/h of each kept stamp [steps].
    """

    step: float
    fitted_step: float
    origin: float
    kept: np.ndarray
    slots: np.ndarray
    deviation: np.ndarray

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


def _nominal(s, slots, h, c, deviation, tolerance):
    """(step, origin, deviation) on the simplest round step fitting the stamps.

    The step is within ``MAX_RATE_ERROR`` of h and every deviation within tolerance.
    """
    for step in _step_candidates(h):
        if abs(step / h - 1.0) > MAX_RATE_ERROR:
            continue
        origin = float(np.mean(s - step * slots))
        fresh = (s - origin) / step - slots
        if np.all(np.abs(fresh) <= tolerance):
            return step, origin, fresh
    return h, c, deviation


def _fit(s: np.ndarray, k: np.ndarray) -> tuple[float, float]:
    """Least squares s ≈ c + h·k; returns (h, c)."""
    kf = k.astype(float)
    k_mean = kf.mean()
    s_mean = s.mean()
    dk = kf - k_mean
    denominator = float(dk @ dk)
    if denominator == 0.0:
        return math.nan, math.nan
    h = float(dk @ (s - s_mean)) / denominator
    return h, float(s_mean - h * k_mean)


def _drop_outliers(t, h0, gaps, max_outliers, run, owner, where) -> np.ndarray:
    """Stage 1: rows whose stamps break the chain of steps in (0, gap·h₀].

    ``gaps`` = (longest gap, longest gap next to the first or last ``run`` rows)
    [missing samples].
    """
    n = t.size
    d_max = (gaps[0] + 1.5) * h0
    d_edge = (min(gaps) + 1.5) * h0
    with np.errstate(over="ignore", invalid="ignore"):
        dt = np.diff(t)
    edge = np.zeros(dt.size, bool)
    edge[:run] = edge[-run:] = True
    good = (dt > 0.0) & (dt <= np.where(edge, d_edge, d_max))
    broken = np.flatnonzero(~good)
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
    t = np.asarray(t, dtype=float)
    n = t.size
    max_inserted = n if max_inserted is None else int(max_inserted)
    max_outliers = 3 + n // 1000 if max_outliers is None else int(max_outliers)
    gaps = (max_inserted, max_inserted if edge_gap is None else int(edge_gap))
    with np.errstate(over="ignore", invalid="ignore"):
        dt = np.diff(t)
        h0 = float(np.median(dt))
    if not (math.isfinite(h0) and h0 > 0.0):
        b = int(np.flatnonzero(~(dt > 0.0))[0]) + 1
        raise ValueError(
            f"{owner}: time stamps are not increasing at {where(b)} after "
            f"{where(b - 1)}; sort the log by time."
        )
    keep = _drop_outliers(t, h0, gaps, max_outliers, max_outlier_run, owner, where)
    for attempt in range(2):
        rows = np.flatnonzero(keep)
        if rows.size < 2:
            raise ValueError(
                f"{owner}: fewer than 2 samples left after dropping "
                f"{np.count_nonzero(~keep)} outlier time stamp(s)."
            )
        with np.errstate(over="ignore", invalid="ignore"):
            s = t[rows] - t[rows[0]]
        if not np.all(np.isfinite(s)):
            raise ValueError(f"{owner}: the time stamps span more than 1e308 s.")
        ratio = np.diff(s) / h0  # <= max_inserted + 1.5 after stage 1
        slots = np.concatenate([[0], np.cumsum(np.maximum(1, np.rint(ratio)))])
        slots = slots.astype(np.int64)
        h, c = _fit(s, slots)
        for _ in range(2):  # slots re-read from the fitted grid, then refit
            if not (math.isfinite(h) and h > 0.0):
                break
            fresh = np.rint((s - c) / h).astype(np.int64)
            fresh -= fresh[0]
            if np.array_equal(fresh, slots) or np.any(np.diff(fresh) < 1):
                break
            slots = fresh
            h, c = _fit(s, slots)
        deviation = (s - c) / h - slots if h > 0.0 else np.full(s.size, np.inf)
        off = ~(np.abs(deviation) <= tolerance)
        if not np.any(off):
            break
        budget = max_outliers - int(np.count_nonzero(~keep))
        isolated = not np.any(off[1:] & off[:-1])
        if attempt or np.count_nonzero(off) > budget or not isolated or rows.size < 5:
            size = np.where(np.isfinite(deviation), np.abs(deviation), np.inf)
            worst = int(np.argmax(size))
            raise NonUniformSampling(
                f"{owner}: non-uniform sampling: {where(int(rows[worst]))} is "
                f"{abs(deviation[worst]):.2f} steps off the uniform grid of step "
                f"{h:.6g} s fitted to the time stamps ({np.count_nonzero(off)} "
                f"stamp(s) beyond the tolerance of {tolerance:g} step); resample it "
                "onto a uniform grid first, or allow linear interpolation "
                "(dynid: --resample).",
                keep,
                h0,
            )
        keep[rows[off]] = False
    inserted = int(slots[-1]) + 1 - slots.size
    if inserted > max_inserted:
        gap = int(np.argmax(np.diff(slots)))
        a, b = int(rows[gap]), int(rows[gap + 1])
        raise ValueError(
            f"{owner}: the gaps in the time stamps would insert {inserted} missing "
            f"samples, more than the {max_inserted} allowed (the number of rows "
            f"read); the longest is {int(slots[gap + 1] - slots[gap]) - 1} samples "
            f"between {where(a)} and {where(b)}; split the log there."
        )
    step, c, deviation = _nominal(s, slots, h, c, deviation, tolerance)
    if abs(c) <= 1e-6 * step:  # round-off: the first stamp is the origin
        c = 0.0
    return TimeGrid(step, h, float(t[rows[0]] + c), keep, slots, deviation)


def fill_short_runs(
    x: np.ndarray, max_run: int, cubic: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Interpolates the interior runs of at most ``max_run`` non-finite samples.

    Each column of ``x`` (N, n) on a uniform grid is treated alone. A run of missing
    samples with finite neighbours a (before) and b (after) is filled linearly, or
    with the cubic through a - 1, a, b, b + 1 when ``cubic`` and those are finite.
    Runs at either end, and longer runs, stay non-finite.

    Returns:
        The filled copy of ``x`` and the (N, n) bool mask of the filled entries.
    """
    x = np.array(x, dtype=float, copy=True)
    filled = np.zeros(x.shape, bool)
    if max_run < 1:
        return x, filled
    n = x.shape[0]
    idx = np.arange(n)
    for j in range(x.shape[1]):
        col = x[:, j]
        finite = np.isfinite(col)
        if finite.all() or not finite.any():
            continue
        left = np.maximum.accumulate(np.where(finite, idx, -1))
        right = np.minimum.accumulate(np.where(finite, idx, n)[::-1])[::-1]
        p = np.flatnonzero(~finite)
        a, b = left[p], right[p]
        use = (a >= 0) & (b < n) & (b - a - 1 <= max_run)
        p, a, b = p[use], a[use], b[use]
        if p.size == 0:
            continue
        w = (p - a) / (b - a)
        value = (1.0 - w) * col[a] + w * col[b]
        if cubic:
            a0 = np.maximum(a - 1, 0)
            b1 = np.minimum(b + 1, n - 1)
            four = (a - 1 >= 0) & (b + 1 < n) & finite[a0] & finite[b1]
            nodes = [a0[four], a[four], b[four], b1[four]]
            at = p[four]
            cubic_value = np.zeros(at.size)
            for i in range(4):  # Lagrange polynomial through the four nodes
                term = col[nodes[i]]
                for m in range(4):
                    if m != i:
                        term = term * (at - nodes[m]) / (nodes[i] - nodes[m])
                cubic_value += term
            value[four] = cubic_value
        col[p] = value
        filled[p, j] = True
    return x, filled
