"""Is `dynid offline`'s σ honest? Monte-Carlo spread against the reported σ.

Logs: the iiwa7 (``models/iiwa7.urdf``) and the UR5 (``models/ur5.urdf``) on a
multi-sine trajectory (5 harmonics of 0.1 Hz, |q̇| ≤ 1 rad/s, |q - q0| ≤ 1 rad,
as ``benchmarks/_accuracy_arm7.trajectory(0)``), 60 s at 1 kHz, torques from Drake's
``CalcInverseDynamics`` + the URDF's Coulomb friction (never the library's
regressor), plus white noise per seed (``_independent.with_noise``): torque noise
1 % of each joint's torque std alone, then with position noise 1e-4 rad.

For each case ``identify_offline`` (defaults; IDIM-LS and IDIM-WLS) runs on every
seed; over the parameters whose reported %σ ≤ 5 (well excited):

* ``spread/σ``: the std of the estimates over the seeds divided by the median
  reported σ, median over those parameters (1 for an honest σ);
* ``p90 |err|/σ``: the 90th percentile of |θ̂ - θ|/σ over parameters and seeds
  (1.64 for a Gaussian error with an honest σ; a bias raises it).

Both with the reported σ (Gautier's σ × ``settings.sigma_correlation_factor``,
``core.idim_auto.decimated_noise_factor``) and with Gautier's σ alone (the same
σ divided by that factor), side by side on the same runs; also at a forced
decimation of a quarter of the automatic one (rows four times as dense).

Run: ``python benchmarks/bench_sigma_offline.py [--seeds 20] [--quick] [--json F]``
(prints a table; about 1 minute with 20 seeds on one core).
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from _independent import exact_log, with_noise
from _timing import quick_or

from drake_dynid.core._threads import configure_process
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.offline import identify_offline
from drake_dynid.plants import RobotModel, model_path

CASES = {
    "torque noise 1 %": (0.0, 0.01),
    "+ position noise 1e-4 rad": (1e-4, 0.01),
}


def trajectory(num_joints: int, seed: int = 0):
    """The multi-sine of ``_accuracy_arm7.trajectory`` for ``num_joints`` joints."""
    return random_fourier_trajectory(
        num_joints,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        max_position=1.0,
        rng=np.random.default_rng(seed),
    )


def _run(robot, log, q_std, tau_std, seeds, weighted, decimation=None):
    estimates, stds, factor = [], [], np.nan
    for seed in range(seeds):
        noisy = with_noise(log, q_std, tau_std * log.tau.std(axis=0), seed)
        result = identify_offline(
            noisy, robot, weighted=weighted, decimation=decimation
        )
        estimates.append(result.theta)
        stds.append(result.std)
        factor = result.settings["sigma_correlation_factor"]
        auto = result.settings["decimation"]
    return np.array(estimates), np.array(stds), factor, auto


def _metrics(estimates, stds, truth, divide=1.0):
    stds = stds / divide
    sigma = np.median(stds, axis=0)
    well = sigma <= 0.05 * np.abs(truth)
    spread = estimates.std(axis=0, ddof=1)
    z = np.abs(estimates[:, well] - truth[well]) / stds[:, well]
    return float(np.median(spread[well] / sigma[well])), float(np.percentile(z, 90))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=None, help="default 20")
    parser.add_argument("--quick", action="store_true", help="8 seeds, iiwa7 only")
    parser.add_argument("--json", metavar="FILE", help="write the rows as JSON")
    args = parser.parse_args(argv)
    configure_process()
    seeds = quick_or(args.seeds, args.quick, 8, 20)
    robots = ("iiwa7",) if args.quick else ("iiwa7", "ur5")
    print(
        f"dynid offline σ against the Monte-Carlo spread ({seeds} seeds, 60 s at "
        "1 kHz, Drake inverse dynamics; medians over the well-excited parameters)"
    )
    print()
    print(
        "| robot | noise | method | D | factor | spread/σ reported | spread/σ Gautier "
        "| p90 err/σ reported | p90 err/σ Gautier |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    rows = []
    for name in robots:
        robot = RobotModel.from_urdf(model_path(name))
        log, _ = exact_log(robot, trajectory(robot.num_joints), 60.0, 1e-3)
        truth = robot.base_values
        for label, (q_std, tau_std) in CASES.items():
            for weighted in (False, True):
                method = "IDIM-WLS" if weighted else "IDIM-LS"
                est, std, factor, auto = _run(
                    robot, log, q_std, tau_std, seeds, weighted
                )
                runs = [(auto, est, std, factor)]
                if not weighted and q_std == 0.0:
                    dense = max(1, auto // 4)
                    est4, std4, factor4, _ = _run(
                        robot, log, q_std, tau_std, seeds, weighted, dense
                    )
                    runs.append((dense, est4, std4, factor4))
                for decimation, e, s, f in runs:
                    ours = _metrics(e, s, truth)
                    gautier = _metrics(e, s, truth, f)
                    rows.append(
                        {
                            "robot": name,
                            "noise": label,
                            "method": method,
                            "decimation": int(decimation),
                            "factor": float(f),
                            "spread_over_sigma": ours[0],
                            "spread_over_gautier": gautier[0],
                            "p90": ours[1],
                            "p90_gautier": gautier[1],
                        }
                    )
                    print(
                        f"| {name} | {label} | {method} | {decimation} | {f:.2f} | "
                        f"{ours[0]:.2f} | {gautier[0]:.2f} | {ours[1]:.2f} | "
                        f"{gautier[1]:.2f} |",
                        flush=True,
                    )
    if args.json:
        with open(args.json, "w", encoding="utf-8") as stream:
            json.dump({"seeds": seeds, "rows": rows}, stream, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
