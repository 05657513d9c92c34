"""Solve time of the physically consistent identification (dynid offline --physical).

The 7-DOF iiwa7 (57 base, 84 standard parameters, gravity, viscous and Coulomb
friction): a 20 s log at 500 Hz along a random Fourier trajectory (5 harmonics of
0.2 Hz, default_rng(1)), torques W·θ from the URDF values with one link made
non-physical (ZZ7 < 0, so that constraints bind) plus noise (σ_τ = 0.05 N·m,
σ_q = 1e-4 rad), identified by ``identify_offline(keep_rows=True)``; then the
timed calls on its decimated rows:

* ``solve_physical`` (QR reduction + semidefinite program, Clarabel), the whole
  ``--physical`` step, wall time of the call (goal < 2 s);
* ``check_physical`` of the unconstrained estimate (feasibility SDP);
* ``project_physical`` of the estimate with its covariance (the on-line use).

Medians of ``--repeats`` runs; BLAS pinned to one thread (environment variables
set before numpy is imported).
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from _timing import quick_or  # noqa: E402

from drake_dynid.core.trajectory import random_fourier_trajectory  # noqa: E402
from drake_dynid.logs import RobotLog  # noqa: E402
from drake_dynid.offline import identify_offline  # noqa: E402
from drake_dynid.physical import (  # noqa: E402
    check_physical,
    project_physical,
    solve_physical,
)
from drake_dynid.plants import RobotModel, model_path  # noqa: E402

GOAL = 2.0  # [s] for solve_physical on the 7-DOF arm


def _median_seconds(function, repeats: int) -> tuple[float, object]:
    samples, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = function()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples), out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=None, help="default 5")
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    duration = 4.0 if args.quick else 20.0
    repeats = quick_or(args.repeats, args.quick, 1, 5)

    robot = RobotModel.from_urdf(model_path("iiwa7"))
    h = 2e-3
    rng = np.random.default_rng(1)
    trajectory = random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi / 5.0,
        max_velocity=1.5,
        max_position=1.5,
        rng=rng,
    )
    t = h * np.arange(round(duration / h) + 1)
    q, v, vdot = trajectory.evaluate(t)
    theta = robot.base_values.copy()
    theta[robot.base.names.index("ZZ7")] = -0.002
    tau = robot.idim_rows(q, v, vdot) @ theta + 0.05 * rng.normal(size=q.shape)
    q = q + 1e-4 * rng.normal(size=q.shape)
    log = RobotLog(t, q, tau, robot.joint_names, h)
    fit = identify_offline(log, robot, keep_rows=True)
    W, torques = fit.rows, fit.torques
    covariance = np.diag(fit.std**2)

    solve, result = _median_seconds(lambda: solve_physical(robot, W, torques), repeats)
    check, checked = _median_seconds(lambda: check_physical(robot, fit.theta), repeats)
    project, _ = _median_seconds(
        lambda: project_physical(robot, fit.theta, covariance), repeats
    )
    print(
        f"iiwa7: {robot.num_parameters} base / {len(robot.standard_names)} standard "
        f"parameters; {W.shape[0]} decimated samples x 7 joints = "
        f"{W.shape[0] * 7} equations; median of {repeats} run(s), BLAS 1 thread"
    )
    print(f"unconstrained estimate: {checked.summary()}")
    print(f"active constraints of the consistent fit: {', '.join(result.active)}")
    print()
    print("| call | median wall time [s] | solver time [s] | goal |")
    print("|---|---|---|---|")
    print(
        f"| solve_physical (--physical) | {solve:.4f} | {result.solve_time:.4f} | "
        f"< {GOAL:g} s: {'met' if solve < GOAL else 'NOT met'} |"
    )
    print(f"| check_physical | {check:.4f} | | |")
    print(f"| project_physical | {project:.4f} | | |")
    if args.json:
        document = {
            "solve_physical_s": solve,
            "solver_s": result.solve_time,
            "check_physical_s": check,
            "project_physical_s": project,
            "repeats": repeats,
        }
        with open(args.json, "w", encoding="utf-8") as stream:
            json.dump(document, stream, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
