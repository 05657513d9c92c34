"""Timing helper shared by the benchmark scripts (not a benchmark itself)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable


def time_call(function: Callable[[], object], repeats: int, min_time: float) -> float:
    """Median seconds per call over ``repeats`` runs of at least ``min_time`` [s].

    One warm-up call first; each run repeats the call until ``min_time`` has passed.
    """
    function()
    samples = []
    for _ in range(repeats):
        calls, start = 0, time.perf_counter()
        while True:
            function()
            calls += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_time:
                break
        samples.append(elapsed / calls)
    return statistics.median(samples)
