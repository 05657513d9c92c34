"""Timing helper shared by the benchmark scripts (not a benchmark itself)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Mapping


def time_call(
    function: Callable[[], object],
    repeats: int,
    min_time: float,
    clock: Callable[[], float] = time.perf_counter,
) -> float:
    """Median seconds per call over ``repeats`` runs of at least ``min_time`` [s].

    One warm-up call first; each run repeats the call until ``min_time`` of
    ``clock`` has passed (see :func:`time_side_by_side` for ``time.process_time``).
    """
    function()
    return statistics.median(
        _per_call(function, min_time, clock) for _ in range(repeats)
    )


def _per_call(
    function: Callable[[], object], min_time: float, clock: Callable[[], float]
) -> float:
    """Seconds per call of ``function``, called until ``min_time`` [s] of ``clock``."""
    calls, start = 0, clock()
    while True:
        function()
        calls += 1
        elapsed = clock() - start
        if elapsed >= min_time:
            return elapsed / calls


def time_side_by_side(
    functions: Mapping[str, Callable[[], object]],
    rounds: int,
    min_time: float,
    clock: Callable[[], float] = time.perf_counter,
) -> dict[str, list[float]]:
    """Seconds per call of each function, measured in alternation, per round.

    One warm-up call each; then ``rounds`` rounds, each running every function in
    turn until ``min_time`` [s] of ``clock`` has passed. On a shared machine the
    functions of one round see about the same load, so the median of the ratios of
    one round (:func:`median_ratio`) moves less than a ratio of medians taken
    apart; ``clock=time.process_time`` (the process's CPU time) also leaves out the
    time the process waited for a core (single-threaded code only).
    """
    for function in functions.values():
        function()
    samples: dict[str, list[float]] = {name: [] for name in functions}
    for _ in range(rounds):
        for name, function in functions.items():
            samples[name].append(_per_call(function, min_time, clock))
    return samples


def median_ratio(samples: Mapping[str, list[float]], over: str, under: str) -> float:
    """Median over rounds of ``samples[over][k] / samples[under][k]``."""
    pairs = zip(samples[over], samples[under], strict=True)
    return statistics.median(a / b for a, b in pairs)


def quick_or(given, quick: bool, quick_value, value):
    """An option's value: as given, else ``quick_value`` (``--quick``) or ``value``.

    ``--quick`` changes the defaults only: an option typed on the command line
    wins (``--quick --seeds 10`` runs 10 seeds). ``given`` is None when the option
    was not typed (its argparse default).
    """
    if given is not None:
        return given
    return quick_value if quick else value
