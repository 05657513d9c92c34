"""Speed of the causal Jacobi differentiator: Drake block, core step, batch filter.

For windows 0.1, 0.3 and 1 s at h = 1 ms (num_signals 4, orders 0 and 1, κ = μ = 1,
q = 1) it measures, as medians over repeats:

* block in a Simulator: µs per 1 ms step of ConstantVectorSource -> block ->
  two VectorLogSinks (every output evaluated each step), and the same without
  consumers (update only: ring write, no FIR);
* the core step alone: ``jacobi_step`` (in place, as the block) + ``jacobi_outputs``
  per sample, and the functional (copying) ``jacobi_step`` alone;
* the batch function ``jacobi_batch`` (scipy.signal.lfilter), µs per sample for
  both orders and all channels, over a 20 s log;
* the floor: the same diagram with the loggers on the source and no block;
* the design time of the bank (``jacobi_filters``), ms.

Usage: ``python benchmarks/bench_jacobi.py [--repeats 5] [--seconds 2] [--json FILE]``
(``--quick``: one repeat of 0.1 s, the 0.1 s window only; a smoke test).
Timings on a shared 2-core machine move by about ±30 %.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import numpy as np
from _timing import quick_or

TIME_STEP = 1e-3
WINDOWS = (0.1, 0.3, 1.0)
NUM_SIGNALS = 4
SETTINGS = dict(kappa=1.0, mu=1.0, q=1)
SEED = 7


def _median_time(function, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def bench_simulator(window, seconds, repeats, consume):
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.arange(1.0, NUM_SIGNALS + 1)))
    if window is None:  # floor: the two loggers on the source, no block
        for _ in range(2):
            LogVectorOutput(source.get_output_port(), builder, TIME_STEP)
    else:
        block = builder.AddSystem(
            CausalJacobiDifferentiator(NUM_SIGNALS, TIME_STEP, window, **SETTINGS)
        )
        builder.Connect(source.get_output_port(), block.get_input_port_u())
    if window is not None and consume:
        for order in (0, 1):
            LogVectorOutput(block.get_output_port_derivative(order), builder, TIME_STEP)
    diagram = builder.Build()

    def run():
        simulator = Simulator(diagram)
        simulator.Initialize()
        simulator.AdvanceTo(seconds)

    run()  # warm-up
    steps = round(seconds / TIME_STEP)
    return 1e6 * _median_time(run, repeats) / steps


def bench_core(window, repeats, samples=2000):
    from drake_dynid.core.jacobi import (
        jacobi_filters,
        jacobi_initial_state,
        jacobi_outputs,
        jacobi_ring,
        jacobi_step,
    )

    ring = jacobi_ring(jacobi_filters((0, 1), window, TIME_STEP, **SETTINGS), 4)
    data = np.random.default_rng(SEED).normal(size=(samples, NUM_SIGNALS))

    def in_place():
        state = jacobi_initial_state(ring)
        for sample in data:
            jacobi_step(ring, state, sample, out=state)
            jacobi_outputs(ring, state)

    def functional():
        state = jacobi_initial_state(ring)
        for sample in data:
            state = jacobi_step(ring, state, sample)

    return (
        1e6 * _median_time(in_place, repeats) / samples,
        1e6 * _median_time(functional, repeats) / samples,
    )


def bench_batch(window, repeats, samples=20_000):
    from drake_dynid.core.jacobi import jacobi_batch, jacobi_filters

    bank = jacobi_filters((0, 1), window, TIME_STEP, **SETTINGS)
    data = np.random.default_rng(SEED).normal(size=(samples, NUM_SIGNALS))

    def run():
        for filt in bank:
            jacobi_batch(filt, data)

    design = 1e3 * _median_time(
        lambda: jacobi_filters((0, 1), window, TIME_STEP, **SETTINGS), repeats
    )
    return 1e6 * _median_time(run, repeats) / samples, design


def main(argv=None) -> int:
    """Runs the benchmark, prints a markdown table; returns the exit code."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=None, help="repeats (median; 5)")
    parser.add_argument(
        "--seconds", type=float, default=None, help="simulated seconds per run (2)"
    )
    parser.add_argument("--json", metavar="FILE", help="also write the rows as JSON")
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    args = parser.parse_args(argv)
    windows = WINDOWS[:1] if args.quick else WINDOWS
    args.repeats = quick_or(args.repeats, args.quick, 1, 5)
    args.seconds = quick_or(args.seconds, args.quick, 0.1, 2.0)

    floor = bench_simulator(None, args.seconds, args.repeats, consume=True)
    rows = []
    for window in windows:
        sim = bench_simulator(window, args.seconds, args.repeats, consume=True)
        update_only = bench_simulator(window, args.seconds, args.repeats, consume=False)
        core_step, functional = bench_core(window, args.repeats)
        batch, design = bench_batch(window, args.repeats)
        rows.append(
            dict(
                window=window,
                taps=round(window / TIME_STEP) + 1,
                simulator_us_per_step=sim,
                simulator_update_only_us_per_step=update_only,
                core_step_and_outputs_us=core_step,
                core_functional_step_us=functional,
                batch_us_per_sample=batch,
                design_ms=design,
            )
        )
    print(
        f"Causal Jacobi differentiator, h = 1 ms, {NUM_SIGNALS} signals, orders 0 and "
        f"1, κ = μ = 1, q = 1; medians of {args.repeats} repeats, "
        f"{args.seconds:g} s simulated per run. Floor (source + 2 loggers, no "
        f"block): {floor:.1f} µs/step.\n"
    )
    print(
        "| window [s] | taps | Simulator: block + 2 loggers [µs/step] "
        "| Simulator: update only [µs/step] | core step + outputs [µs] "
        "| core functional step [µs] | batch [µs/sample] | design [ms] |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {r['window']:g} | {r['taps']} | {r['simulator_us_per_step']:.1f} "
            f"| {r['simulator_update_only_us_per_step']:.1f} "
            f"| {r['core_step_and_outputs_us']:.1f} "
            f"| {r['core_functional_step_us']:.1f} "
            f"| {r['batch_us_per_sample']:.2f} | {r['design_ms']:.1f} |"
        )
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(
                dict(
                    benchmark="bench_jacobi",
                    time_step=TIME_STEP,
                    num_signals=NUM_SIGNALS,
                    settings=SETTINGS,
                    repeats=args.repeats,
                    seconds=args.seconds,
                    floor_us_per_step=floor,
                    rows=rows,
                ),
                handle,
                indent=2,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
