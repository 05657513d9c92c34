"""Cost of the regressor rows: microseconds per sample, single sample and batches.

Providers: the analytic 2R rows (``Planar2RRows``, pure numpy), the generic
``RobotModel`` on the 2R URDF and on the UR5 (6 DOF, gravity) with numpy forward
kinematics, and the UR5 with Drake kinematics (``kinematics="drake"``, per-sample
``EvalBodyPoseInWorld``). Rows: energy h, Lagrangian (dh_E/dv, dh_E/dq, dh_U/dq),
IDIM W(q, v, vdot), and the (D, G, y) contract for the power and Lagrangian models,
all in base columns. Medians over repeats; states from default_rng(0).
"""

from __future__ import annotations

import argparse
import json

import numpy as np
from _timing import quick_or, time_call  # benchmarks/_timing.py

from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.plants import RobotModel, model_path

OPERATIONS = {
    "energy h": lambda m, q, v, a, t: m.energy_rows(q, v),
    "dh/dv + dh/dq": lambda m, q, v, a, t: m.lagrangian_rows(q, v),
    "IDIM W": lambda m, q, v, a, t: m.idim_rows(q, v, a),
    "D,G,y power": lambda m, q, v, a, t: m.model_rows("power", q, v, t),
    "D,G,y lagrangian": lambda m, q, v, a, t: m.model_rows("lagrangian", q, v, t),
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--batch", type=int, default=None, help="batch size N (1000)")
    parser.add_argument("--repeats", type=int, default=None, help="default 5")
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    repeats = quick_or(args.repeats, args.quick, 1, 5)
    batch = quick_or(args.batch, args.quick, 10, 1000)
    min_time = 0.0 if args.quick else 0.2

    generic_2r = RobotModel.from_urdf(model_path("planar_2r"))
    providers = {
        "2R analytic": Planar2RRows(L1=1.0),
        "2R generic": generic_2r,
        "UR5 generic": RobotModel.from_urdf(model_path("ur5")),
        "UR5 drake kinematics": RobotModel.from_urdf(
            model_path("ur5"), kinematics="drake"
        ),
    }
    rng = np.random.default_rng(0)
    results = []
    for provider_name, provider in providers.items():
        n = 2 if isinstance(provider, Planar2RRows) else provider.num_joints
        for size in (1, batch):
            q, v, a, t = rng.normal(size=(4, size, n))
            if size == 1:
                q, v, a, t = q[0], v[0], a[0], t[0]
            for operation, function in OPERATIONS.items():
                seconds = time_call(
                    lambda f=function, m=provider, q=q, v=v, a=a, t=t: f(m, q, v, a, t),
                    repeats,
                    min_time,
                )
                results.append(
                    {
                        "provider": provider_name,
                        "operation": operation,
                        "batch": size,
                        "us_per_sample": 1e6 * seconds / size,
                    }
                )
    sizes = (1, batch)
    print(f"µs per sample (median of {repeats}), batch sizes 1 and {batch}\n")
    header = "| provider | rows | " + " | ".join(f"N={s}" for s in sizes) + " |"
    print(header)
    print("|---|---|" + "---:|" * len(sizes))
    for provider_name in providers:
        for operation in OPERATIONS:
            cells = [
                next(
                    r["us_per_sample"]
                    for r in results
                    if r["provider"] == provider_name
                    and r["operation"] == operation
                    and r["batch"] == s
                )
                for s in sizes
            ]
            print(
                f"| {provider_name} | {operation} | "
                + " | ".join(f"{c:.1f}" for c in cells)
                + " |"
            )
    if args.json:
        with open(args.json, "w") as file:
            json.dump({"results": results, "repeats": repeats}, file, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
