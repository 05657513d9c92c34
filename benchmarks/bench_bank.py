"""Cost of the modulating bank core and of the least-squares solve.

* ``sliding_push``: µs per pushed sample (window full, steady state) for the paper's
  ℓ set (ℓ = 0:0.05:10, k = 1, so K = 221 frequencies), T = 20 s, h = 1 ms, with
  c = 34 channels (Lagrangian 2R rows: m = 2, p = 8) and c = 17 (power model, m = 1).
* ``copy.deepcopy`` of the sliding state (the Simulator deep-copies abstract state
  twice per step) at T = 20 s with h = 1 ms and h = 5 ms, next to a naive state (a
  plain numpy window plus the running sums) for comparison.
* ``sliding_fourier_integrals`` + ``assemble_equations`` (the bank's output),
  ``sliding_push_many`` per sample (log replay) and one ``sliding_resync``.
* ``solve_least_squares`` for A of 804 × 8 and 442 × 8.

Medians over repeats; data from default_rng(0). Timings on a shared machine move
by about ±30 %.
"""

from __future__ import annotations

import argparse
import copy
import json
import statistics
import time

import numpy as np
from _timing import quick_or, time_call  # benchmarks/_timing.py

from drake_dynid.core.lsq import solve_least_squares
from drake_dynid.core.modulating import (
    assemble_equations,
    fourier_bank,
    paper_frequencies,
    sliding_fourier_integrals,
    sliding_init,
    sliding_push,
    sliding_push_many,
    sliding_resync,
)


def _push_cost(bank, state, samples: np.ndarray, repeats: int) -> float:
    """Median µs per sliding_push over ``repeats`` runs of len(samples) pushes."""
    results = []
    for _ in range(repeats):
        current = state
        start = time.perf_counter()
        for row in samples:
            current = sliding_push(bank, current, row)
        results.append((time.perf_counter() - start) / len(samples))
    return 1e6 * statistics.median(results)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--window", type=float, default=None, help="T [s] (20)")
    parser.add_argument("--repeats", type=int, default=None, help="default 5")
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    repeats = quick_or(args.repeats, args.quick, 1, 5)
    window = quick_or(args.window, args.quick, 1.0, 20.0)
    min_time, pushes = (0.0, 20) if args.quick else (0.2, 2000)
    rng = np.random.default_rng(0)
    rows = []

    def record(operation: str, setting: str, microseconds: float) -> None:
        rows.append({"operation": operation, "setting": setting, "us": microseconds})

    for time_step in (1e-3, 5e-3):
        bank = fourier_bank(window, time_step, order=1, ell=paper_frequencies())
        for channels in (34, 17):
            m = 2 if channels == 34 else 1
            data = rng.standard_normal((bank.num_samples + pushes, channels))
            state = sliding_push_many(
                bank, sliding_init(bank, channels), data[: bank.num_samples]
            )
            setting = (
                f"K={bank.num_frequencies}, c={channels}, T={window:g} s, "
                f"h={time_step * 1e3:g} ms"
            )
            if time_step == 1e-3:
                cost = _push_cost(bank, state, data[bank.num_samples :], repeats)
                record("sliding_push", setting, cost)
                block = data[bank.num_samples : bank.num_samples + pushes]
                many = time_call(
                    lambda b=bank, s=state, x=block: sliding_push_many(b, s, x),
                    repeats,
                    min_time,
                )
                record("sliding_push_many (per sample)", setting, 1e6 * many / pushes)
                record(
                    "sliding_resync (once)",
                    setting,
                    1e6
                    * time_call(lambda b=bank, s=state: sliding_resync(b, s), 1, 0.0),
                )
                outputs = time_call(
                    lambda b=bank, s=state, m=m: assemble_equations(
                        b, sliding_fourier_integrals(b, s), m, 8
                    ),
                    repeats,
                    min_time,
                )
                record("integrals + assemble_equations", setting, 1e6 * outputs)
            # Deep copy in the middle of a chunk (the usual case).
            state = sliding_push_many(bank, state, data[:7])
            record(
                "deepcopy(sliding state)",
                setting,
                1e6 * time_call(lambda s=state: copy.deepcopy(s), repeats, min_time),
            )
            naive = {"window": state.ring.window(), "sums": np.array(state.sums)}
            record(
                "deepcopy(naive numpy window + sums)",
                setting,
                1e6 * time_call(lambda s=naive: copy.deepcopy(s), repeats, min_time),
            )

    for shape in ((804, 8), (442, 8)):
        A = rng.standard_normal(shape) * np.logspace(0, 3, shape[1])
        B = A @ np.ones(shape[1]) + 0.01 * rng.standard_normal(shape[0])
        cost = time_call(lambda A=A, B=B: solve_least_squares(A, B), repeats, min_time)
        record("solve_least_squares", f"A {shape[0]}x{shape[1]}", 1e6 * cost)

    print("| operation | setting | µs |")
    print("|---|---|---:|")
    for row in rows:
        print(f"| {row['operation']} | {row['setting']} | {row['us']:.1f} |")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as stream:
            json.dump(rows, stream, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
