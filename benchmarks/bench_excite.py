"""Exciting-trajectory design: time, condition numbers, and identification accuracy.

For the iiwa7 (7 DOF, 58 base parameters) and the UR5 (6 DOF, 48), with the
datasheet limits shipped next to their URDFs (``models/<robot>_limits.json``) and
with the URDFs' own (inflated) limits:

1. ``design_excitation`` with the ``dynid excite`` defaults (60 s, f0 = 0.2 Hz,
   H = 5, margins 0.1 rad / 20 %, 100 SLSQP iterations): wall time and condition
   number, against (a) the default random trajectory of the same seed, (b) the
   median over 10 seeds of that random trajectory, and (c) a random search of the
   same wall-time budget (random trajectories of new seeds, scaled to the same
   kinematic limits, kept when their torques also meet the effort limits; the best
   condition number found).
2. (datasheet limits only) ``simulate_experiment`` (1 kHz plant, default noise:
   σ_q = 1e-4 rad, σ_τ = 1 % of each joint's torque std, seed 0) and
   ``identify_offline`` on the log: for the parameters that ``dynid excite``
   predicts well excited (%σ <= 0.1 with torque noise alone), how many and the
   largest |relative error| against the URDF values; also with a 0.5 ms plant
   (the same log rate; the plant's midpoint step, docs/DRIVE.md §6c, makes the
   1 ms log already obey the model at its central differences).

BLAS is pinned to one thread. ``--quick``: iiwa7 only, 10 s, 20 iterations, no
0.5 ms run.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from drake_dynid.core.excite import (  # noqa: E402
    ExcitationSettings,
    _baseline,
    design_excitation,
)
from drake_dynid.core.excite_problem import (  # noqa: E402
    ExcitationProblem,
    batched_rows,
    condition_number,
)
from drake_dynid.core.excite_report import excitation_report  # noqa: E402
from drake_dynid.core.friction import TanhSign  # noqa: E402
from drake_dynid.core.joint_limits import Margins  # noqa: E402
from drake_dynid.experiment import ExperimentSettings, simulate_experiment  # noqa: E402
from drake_dynid.limits import joint_limits  # noqa: E402
from drake_dynid.logs import RobotLog  # noqa: E402
from drake_dynid.offline import identify_offline  # noqa: E402
from drake_dynid.robot import RobotModel  # noqa: E402
from drake_dynid.trajectory_file import SampledTrajectory  # noqa: E402
from drake_dynid.urdf import MODELS_DIR, model_path  # noqa: E402

WELL_EXCITED_PERCENT = 0.1


def _random_condition(robot, limits, settings, seed):
    """Condition number of the seed's random trajectory, inf if over the effort."""
    problem = ExcitationProblem(
        robot.idim_rows,
        robot.base_values,
        limits,
        ExcitationSettings(
            duration=settings.duration,
            harmonics=settings.harmonics,
            base_frequency=settings.base_frequency,
            seed=seed,
        ),
        Margins(),
        None,
    )
    W = batched_rows(robot.idim_rows, *_baseline(problem).evaluate(problem.t))
    effort = np.abs(W @ robot.base_values).max(axis=0)
    condition = condition_number(W[..., problem.active])
    return condition, bool(np.all(effort <= problem.emax))


def design_row(robot, limits, settings, label):
    start = time.perf_counter()
    design = design_excitation(robot.idim_rows, robot.base_values, limits, settings)
    seconds = time.perf_counter() - start
    medians = [
        _random_condition(robot, limits, settings, seed)[0] for seed in range(10)
    ]
    best, draws, seed = np.inf, 0, 1000
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        condition, feasible = _random_condition(robot, limits, settings, seed)
        seed += 1
        draws += 1
        if feasible:
            best = min(best, condition)
    return design, {
        "robot": robot.path.split("/")[-1],
        "limits": label,
        "seconds": seconds,
        "iterations": design.iterations,
        "condition": design.condition_number,
        "baseline_seed0": design.baseline_condition_number,
        "baseline_median10": float(np.median(medians)),
        "random_search_best": float(best),
        "random_search_draws": draws,
    }


def accuracy_row(robot, limits, design, settings, time_step):
    report = excitation_report(
        robot.idim_rows,
        design.trajectory,
        robot.base_values,
        robot.base_names,
        duration=settings.duration,
    )
    well = report.relative_std_percent <= WELL_EXCITED_PERCENT
    reference = SampledTrajectory.from_fourier(
        design.trajectory, robot.joint_names, settings.duration, 100.0
    )
    start = time.perf_counter()
    log = simulate_experiment(
        robot.path, reference, limits, ExperimentSettings(time_step=time_step)
    )
    simulated = time.perf_counter() - start
    row = {
        "robot": robot.path.split("/")[-1],
        "time_step": time_step,
        "simulation_seconds": simulated,
        "well_excited": int(well.sum()),
        "num_parameters": robot.num_parameters,
    }
    # The model's Coulomb law: sign(v), or the simulator's tanh(v/ε) (what
    # ``dynid simulate`` prints: ``--coulomb-width ε``).
    smoothing = ExperimentSettings().coulomb_smoothing
    names = np.array(robot.base_names)[well]
    models = (("sign", robot), ("tanh", robot.with_sign(TanhSign(smoothing))))
    for key, model in models:
        result = identify_offline(
            RobotLog(log.t, log.q, log.tau, robot.joint_names, 1e-3), model
        )
        error = 100 * np.abs(result.theta - robot.base_values)
        error = error[well] / np.abs(robot.base_values[well])
        worst = int(np.argmax(error))
        over = [f"{n} {e:.2f}" for n, e in zip(names, error, strict=True) if e > 1.0]
        row[key] = {
            "max_error_percent": float(error[worst]),
            "median_error_percent": float(np.median(error)),
            "worst": str(names[worst]),
            "over_1_percent": over,
        }
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    robots = ("iiwa7",) if args.quick else ("iiwa7", "ur5")
    settings = (
        ExcitationSettings(duration=10.0, iterations=20)
        if args.quick
        else ExcitationSettings()
    )
    steps = (1e-3,) if args.quick else (1e-3, 5e-4)
    designs, accuracy = [], []
    for name in robots:
        robot = RobotModel.from_urdf(model_path(name))
        for label, file in (("datasheet", MODELS_DIR / f"{name}_limits.json"),
                            ("URDF", None)):  # fmt: skip
            limits = joint_limits(robot, file)
            design, row = design_row(robot, limits, settings, label)
            designs.append(row)
            if label == "datasheet":
                for step in steps:
                    accuracy.append(accuracy_row(robot, limits, design, settings, step))
    print(
        f"design: {settings.duration:g} s, f0 = {settings.base_frequency:g} Hz, "
        f"H = {settings.harmonics}, {settings.iterations} iterations max\n"
    )
    print(
        "| robot | limits | excite time [s] | iterations | cond | random, seed 0 | "
        "random, median of 10 | random search, same time (draws) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in designs:
        print(
            f"| {r['robot']} | {r['limits']} | {r['seconds']:.1f} | "
            f"{r['iterations']} | {r['condition']:.3g} | {r['baseline_seed0']:.3g} | "
            f"{r['baseline_median10']:.3g} | {r['random_search_best']:.3g} "
            f"({r['random_search_draws']}) |"
        )
    print(
        "\n| robot | plant step | simulate [s] | well excited | Coulomb law of the "
        "model | median error [%] | max error [%] | > 1 % |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in accuracy:
        laws = (("sign", "sign(v)"), ("tanh", "tanh(v/0.01), the simulator's"))
        for key, law in laws:
            e = r[key]
            print(
                f"| {r['robot']} | {r['time_step'] * 1e3:g} ms | "
                f"{r['simulation_seconds']:.1f} | {r['well_excited']} of "
                f"{r['num_parameters']} | {law} | {e['median_error_percent']:.2f} | "
                f"{e['max_error_percent']:.2f} ({e['worst']}) | "
                f"{', '.join(e['over_1_percent']) or 'none'} |"
            )
    if args.json:
        with open(args.json, "w") as stream:
            json.dump({"designs": designs, "accuracy": accuracy}, stream, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
