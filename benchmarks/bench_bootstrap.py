"""The final σ's bootstrap: linearised raw-row replicates against exact re-solves.

``dynid identify``'s parametric bootstrap (``core.bootstrap.bootstrap_std``, K = 16
replicates, seed 0, the noise measured on the log) solves each replicate's window
with raw rows either exactly (``linearized=False``: the raw rows of every
perturbed sample, D row evaluations per bank sample) or to first order
(``core.raw_rows.linearized_channels``: the rows at each bank sample's mean
perturbed signals, one evaluation per bank sample, G's friction part exact per
sample). Both use the same noise draws, so their σ_B differ only by the
linearisation. Printed per case: the ratio σ_B(linearised)/σ_B(exact) over all
parameters and runs (median, min, max) and the time of each, medians over the runs.

Cases: the seven 2R scenarios of the accuracy benchmark (benchmarks/_scenarios.py;
closed-loop logs, SNR 30 dB white noise on q and τ, ``default_rng(1000 + seed)``,
library defaults with the measured band, rows forced to "raw" even where the log
would choose the filtered rows: the noisiest case for the linearisation); the
7-DOF arm of ``bench_accuracy.py --robot iiwa7`` (benchmarks/_accuracy_arm7.py:
Drake's inverse dynamics + Coulomb friction, 60 s, raw rows) with the "encoder"
and "high" noise levels. The window: the last 20 s of each log.

Run: ``python benchmarks/bench_bootstrap.py [--seeds S] [--quick] [--json FILE]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import tempfile
import time
from pathlib import Path

import bench_accuracy as ba
import numpy as np
from _scenarios import robots, scenarios
from _timing import quick_or

from drake_dynid.core._threads import configure_process
from drake_dynid.core.bootstrap import bootstrap_std
from drake_dynid.core.excitation import (
    estimate_bandwidth,
    position_noise_std,
    torque_noise_std,
)

H = 1e-3


def compare(rows, settings, q, tau, replicates: int) -> dict:
    """σ_B both ways on the window ending at the last sample, and their times."""
    noise = (position_noise_std(q, H), torque_noise_std(tau, H))
    args = (rows, settings, q, tau, len(q) - 1, H, noise)
    start = time.perf_counter()
    exact = bootstrap_std(*args, replicates=replicates, linearized=False)
    middle = time.perf_counter()
    fast = bootstrap_std(*args, replicates=replicates)
    end = time.perf_counter()
    assert fast.method == "linearized", fast.method
    return {
        "ratio": (fast.std / exact.std).tolist(),
        "exact_s": middle - start,
        "linearized_s": end - middle,
    }


def two_r_cases(seeds, replicates: int, quick: bool) -> dict:
    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        models = robots(Path(tmp))
        chosen = scenarios(False)
        if quick:
            chosen = dict(list(chosen.items())[:1])
        method = ba.method_table()[ba.BOOTSTRAPPED]
        for label, (name, trajectory) in chosen.items():
            robot = models[name]
            log = ba.simulate(robot, trajectory)
            bandwidth = estimate_bandwidth(log.q, H)
            settings = dataclasses.replace(method(bandwidth), rows_from="raw")
            runs = []
            for seed in seeds:
                q, tau = ba.noisy(log.q_true, log.tau_true, log.noise_std, seed)
                runs.append(
                    compare(robot.rows_provider(), settings, q, tau, replicates)
                )
            out[f"2R {label}"] = runs
    return out


def arm_cases(seeds, replicates: int) -> dict:
    import _accuracy_arm7 as arm7

    arm = arm7.Arm7()
    settings = arm.settings("raw")
    out = {}
    for level in ("encoder", "high"):
        runs = []
        for seed in seeds:
            log = arm.noisy(level, seed)
            runs.append(compare(arm.robot, settings, log.q, log.tau, replicates))
        out[f"iiwa7, {level} noise"] = runs
    return out


def summary(runs: list[dict]) -> dict:
    ratio = np.concatenate([r["ratio"] for r in runs])
    return {
        "runs": len(runs),
        "ratio_median": float(np.median(ratio)),
        "ratio_min": float(ratio.min()),
        "ratio_max": float(ratio.max()),
        "exact_s": statistics.median(r["exact_s"] for r in runs),
        "linearized_s": statistics.median(r["linearized_s"] for r in runs),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--seeds", type=int, default=None, help="noise seeds per case (default 5)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="one 2R scenario, one seed, K = 4"
    )
    parser.add_argument("--json", metavar="FILE")
    args = parser.parse_args(argv)
    configure_process()  # one BLAS thread, as dynid
    seeds = range(quick_or(args.seeds, args.quick, 1, 5))
    replicates = 4 if args.quick else 16
    cases = two_r_cases(seeds, replicates, args.quick)
    if not args.quick:
        cases.update(arm_cases(range(min(len(seeds), 3)), replicates))
    table = {label: summary(runs) for label, runs in cases.items()}
    print(
        f"\n## Bootstrap σ_B: linearised raw-row replicates / exact re-solves "
        f"(K = {replicates}, same draws; medians over the runs)\n"
    )
    print(
        "| case | runs | σ_B ratio: median | min | max | exact [s] | "
        "linearised [s] | speed-up |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for label, row in table.items():
        print(
            f"| {label} | {row['runs']} | {row['ratio_median']:.3f} | "
            f"{row['ratio_min']:.3f} | {row['ratio_max']:.3f} | {row['exact_s']:.2f} | "
            f"{row['linearized_s']:.2f} | "
            f"{row['exact_s'] / row['linearized_s']:.1f}x |"
        )
    if args.json:
        Path(args.json).write_text(json.dumps({"cases": table}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
