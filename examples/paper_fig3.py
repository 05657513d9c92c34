"""Paper Fig. 3: on-line estimates of the 2R arm over time, T = 12 s, SNR 30 dB.

The paper's 2R arm (``models/planar_2r.urdf``) tracks the documented exciting
trajectory (``drake_dynid.paper.paper_trajectory``) in a Drake simulation at 1 kHz;
white Gaussian noise at SNR 30 dB is added to the measured q and τ. Two on-line
identifiers run in the loop on the same measurements:

* the paper's: power model, ℓ = 0:0.05:10, sliding window T = 12 s;
* the Lagrangian model (this library's extension), same window, default ℓ set.

Before the window has filled (and the differentiator's window on top) the identifier
reports ``valid = 0``; the figure shows only valid estimates. Prints the final
estimates and their errors; writes ``fig3_estimates.png``.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from _example import run_example

from drake_dynid.diagrams import (
    OnlineSettings,
    SimulationSettings,
    simulate_identification,
)
from drake_dynid.paper import paper_trajectory
from drake_dynid.plants import RobotModel, model_path


def _plot(result, truth, names, path, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        len(result.traces), 2, figsize=(12, 3.5 * len(result.traces))
    )
    axes = np.atleast_2d(axes)
    for row, trace in zip(axes, result.traces, strict=True):
        theta = np.where(trace.valid[:, None] > 0, trace.theta, np.nan)
        row[0].plot(trace.t, theta[:, 0], label="estimated ZZ1R")
        row[0].axhline(truth[0], color="k", ls="--", lw=1, label="real ZZ1R")
        row[0].set_ylim(0.9 * truth[0], 1.1 * truth[0])
        for index in (1, 2, 3):
            (line,) = row[1].plot(
                trace.t, theta[:, index], label=f"estimated {names[index]}"
            )
            row[1].axhline(truth[index], color=line.get_color(), ls="--", lw=1)
        row[1].set_ylim(0.0, 0.6)
        for ax in row:
            ax.set_xlabel("t [s]")
            ax.set_title(f"{trace.settings.model} model")
            ax.legend(fontsize=7, loc="lower right")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


#: --quick's presets: defaults that an explicit option overrides.
QUICK = {"window": 3.0, "duration": 4.0}


def main(argv=None) -> int:
    """Runs the example; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1, help="noise seed (default 1)")
    parser.add_argument("--window", type=float, default=12.0, help="T [s] (12)")
    parser.add_argument("--duration", type=float, default=25.0, help="[s] (25)")
    parser.add_argument("--out", default="out", help="output folder (out/)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="tiny run for tests (--window 3 --duration 4)",
    )
    return run_example(parser, argv, _run, QUICK)


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The example with parsed arguments; returns 0 (``parser.error`` exits 2)."""
    if not (0 < args.window < args.duration):
        parser.error("--window must be > 0 and shorter than --duration")
    window, duration = args.window, args.duration
    try:  # a file of that name (or under one) was a FileExistsError traceback
        os.makedirs(args.out, exist_ok=True)
    except OSError as error:
        parser.error(f"--out {args.out}: not a folder ({error.strerror})")
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    settings = [
        OnlineSettings.for_model("power", window=window, frequencies="paper"),
        OnlineSettings.for_model("lagrangian", window=window),
    ]
    result = simulate_identification(
        robot,
        paper_trajectory(),
        SimulationSettings(duration=duration, snr_db=30.0, seed=args.seed),
        settings,
        progress=sys.stderr.isatty(),
    )
    truth = robot.base_values
    print(f"2R, SNR 30 dB (seed {args.seed}), T = {window:g} s, t = {duration:g} s")
    print("| model | " + " | ".join(robot.names) + " |")
    print("|---|" + "---|" * len(robot.names))
    print("| true | " + " | ".join(f"{x:.4g}" for x in truth) + " |")
    for trace in result.traces:
        final = trace.final()
        first_valid = (
            f"{trace.t[np.argmax(trace.valid > 0)]:.4g} s"
            if trace.valid.any()
            else "never"
        )
        errors = ", ".join(f"{e:.4g}" for e in 100 * (final["theta"] - truth) / truth)
        print(
            f"| {trace.settings.model} | "
            + " | ".join(f"{x:.4g}" for x in final["theta"])
            + f" |  (error % {errors}; first valid at t = {first_valid}, "
            f"cond {final['condition_number']:.3g})"
        )
    path = os.path.join(args.out, "fig3_estimates.png")
    _plot(result, truth, robot.names, path, f"Fig. 3: T = {window:g} s, SNR 30 dB")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
