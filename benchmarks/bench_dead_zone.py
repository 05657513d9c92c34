"""The Coulomb dead zone at velocity reversals: what it costs `dynid offline`.

The dead zone (docs/MATH.md §2) sets the Coulomb column to 0 where |v̂_j| <= w_j.
At rest that is its purpose; at a reversal of a moving joint the samples that
fall inside the zone are not at rest, and where the friction law has an exact
sign a 0 there is a model error of FC_j per sample that σ does not hold. The
off-line stream therefore gives a short run inside the zone between long runs of
opposite signs outside it the sign of the line through its neighbours
(``core.standstill.reversal_signs``). Side by side on the same noisy logs, three
Coulomb columns:

* ``dead zone``: the library's (``--dead-zone auto``, widths measured on each log,
  ``offline.standstill_widths``; reversals restored);
* ``dead zone per sample``: the same widths, 0 at every sample inside the zone
  (the library's before the reversal rule);
* ``exact sign``: sign(v̂) (``--dead-zone none``).

Logs: the iiwa7 and the UR5 (``models/``) on the multi-sine of
``bench_sigma_offline`` (60 s), sampled at 125, 500 and 1000 Hz, torques from
Drake's ``CalcInverseDynamics`` + the URDF's Coulomb friction FC·s(v) with
s = sign(v) (``truth: sign``) or tanh(v/0.005 rad/s) (``truth: tanh``, a smooth
passage through zero as real drives have), never the library's regressor; white
noise per seed: 1e-4 rad on q, 1 % of each joint's torque std on τ. ``ur5-wrist``
is the UR5 with a differential wrist (a drive chain, :func:`wrist_drive`: motors
m5 and m6 turn with N (q5 + q6) and N (q5 - q6), each with its own viscous and
Coulomb friction, columns ``FVm5 FCm5 FVm6 FCm6``); its torques add, in numpy,
Rᵀ [Fv ⊙ R v + Fc ⊙ s(R v)] of those motors. Over the
parameters whose median reported σ is <= 5 % of the true value: ``p90`` of
|θ̂ - θ|/σ (1.64 for an honest σ), and ``bias``: the largest |mean θ̂ - θ| over the
seeds in units of the median σ (the seed mean's own spread is about 0.2 of it).

Run: ``python benchmarks/bench_dead_zone.py [--seeds 20] [--quick] [--robot NAME]
[--rates 125,500,1000] [--truth sign|tanh] [--duration 60] [--json FILE]``
(``--robot`` ur5, iiwa7 or ur5-wrist, repeatable; default all three; ``--rates``
to choose among 125, 500 and 1000 Hz).
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import numpy as np
from _independent import exact_log, with_noise
from _timing import quick_or
from bench_sigma_offline import trajectory

from drake_dynid.core._threads import configure_process
from drake_dynid.core.drive import DriveChain
from drake_dynid.core.friction import DeadZoneSign
from drake_dynid.core.standstill import combined_widths
from drake_dynid.logs import RobotLog
from drake_dynid.offline import identify_offline, standstill_widths
from drake_dynid.plants import RobotModel, model_path

TANH_WIDTH = 0.005  # [rad/s] the smooth truth's tanh(v/W)
ROBOTS = ("ur5", "iiwa7", "ur5-wrist")
WRIST_RATIO = 50.0  # N of the differential wrist's motors
#: Motor-side (viscous [N·m·s/rad], Coulomb [N·m]) of m5 and m6: 0.25-0.3 N·m·s/rad
#: and 0.3-0.35 N·m on the joints, as the UR5's own wrist friction.
WRIST_FRICTION = ((1.0e-4, 0.006), (1.2e-4, 0.007))


def wrist_drive(joint_names) -> DriveChain:
    """The UR5's drive, its wrist differential: R_5 = N (e5 + e6), R_6 = N (e5 - e6)."""
    a, b = joint_names[4], joint_names[5]
    motors = {
        f"m{k}": {
            "joints": {a: WRIST_RATIO, b: sign * WRIST_RATIO},
            "viscous": viscous,
            "coulomb": coulomb,
        }
        for k, sign, (viscous, coulomb) in zip(
            (5, 6), (1.0, -1.0), WRIST_FRICTION, strict=True
        )
    }
    return DriveChain.from_dict({"motors": motors}, joint_names)


def _robot(name: str) -> RobotModel:
    if name != "ur5-wrist":
        return RobotModel.from_urdf(model_path(name))
    plain = RobotModel.from_urdf(model_path("ur5"))
    return RobotModel.from_urdf(model_path("ur5"), drive=wrist_drive(plain.joint_names))


def _log(robot: RobotModel, h: float, width: float, duration: float) -> RobotLog:
    """The exact log; with coupled motors, their friction through R added."""
    log, v = exact_log(robot, trajectory(robot.num_joints), duration, h, width)
    chain = robot.drive
    if chain is None or not chain.coupled_motors:
        return log
    motors = [chain.motors[k] for k in chain.coupled_motors]
    rows = np.array([motor.row for motor in motors])
    rho = np.max(np.abs(rows), axis=1)
    u = v @ rows.T
    s = np.tanh(u / rho / width) if width > 0.0 else np.sign(u)
    viscous = np.array([motor.viscous for motor in motors])
    coulomb = np.array([motor.coulomb for motor in motors])
    tau = log.tau + (viscous * u + coulomb * s) @ rows
    return RobotLog(log.t, log.q, tau, log.joint_names, log.time_step)


@dataclasses.dataclass(frozen=True)
class SampleDeadZone:
    """The dead zone sample by sample (the library's before the reversals).

    A ``SignLaw`` that is not a ``DeadZoneSign``, so the off-line stream applies
    it as it is: 0 inside the zone at every sample, reversals included. With
    coupled motors (``motors``: their combined widths, ``RobotModel.with_sign``
    gives them this law as it is) the velocities' last axis tells the joints'
    (n) from the motors' (c != n).
    """

    width: tuple[float, ...]
    motors: tuple[float, ...] = ()

    def __post_init__(self):
        if len(self.motors) == len(self.width):
            raise ValueError("SampleDeadZone: as many motors as joints: ambiguous")

    def __call__(self, v):  # noqa: D102
        v = np.asarray(v)
        width = self.motors if v.shape[-1] == len(self.motors) else self.width
        return DeadZoneSign(width)(v)

    def scalar(self, v: float) -> float:  # noqa: D102
        raise TypeError("per-joint widths: no scalar form")


def _laws(robot, widths):
    chain = robot.drive
    motors = ()
    if chain is not None and chain.coupled_motors:
        rows = [chain.motors[k].row for k in chain.coupled_motors]
        motors = tuple(map(float, combined_widths(widths, rows)))
    return {
        "dead zone": DeadZoneSign(widths),
        "per sample": SampleDeadZone(widths, motors),
        "exact sign": None,
    }


def _metrics(estimates, stds, truth, chosen=None):
    """(p90 |err|/σ, largest |bias|/σ) over the well-identified (and ``chosen``)."""
    estimates, stds = np.array(estimates), np.array(stds)
    sigma = np.median(stds, axis=0)
    well = sigma <= 0.05 * np.abs(truth)
    if chosen is not None:
        well &= chosen
    z = np.abs(estimates[:, well] - truth[well]) / stds[:, well]
    bias = np.abs(estimates.mean(axis=0) - truth)[well] / sigma[well]
    return float(np.percentile(z, 90)), float(bias.max())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=None, help="default 20")
    parser.add_argument("--quick", action="store_true", help="4 seeds, UR5 only")
    parser.add_argument(
        "--robot", action="append", choices=ROBOTS, help="default: all three"
    )
    parser.add_argument(
        "--rates",
        type=lambda text: tuple(int(x) for x in text.split(",")),
        default=(125, 500, 1000),
        help="sample rates [Hz], comma-separated (default 125,500,1000)",
    )
    parser.add_argument(
        "--truth",
        action="append",
        choices=("sign", "tanh"),
        help="the logs' friction law (default both)",
    )
    parser.add_argument(
        "--duration", type=float, default=60.0, help="log length [s] (default 60)"
    )
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    if not args.duration > 0.0:
        parser.error(f"--duration must be > 0 s; got {args.duration:g}")
    configure_process()
    seeds = quick_or(args.seeds, args.quick, 4, 20)
    robots = args.robot or (("ur5",) if args.quick else ROBOTS)
    print(
        f"dynid offline with three Coulomb columns ({seeds} seeds, "
        f"{args.duration:g} s, Drake inverse dynamics, σ_q 1e-4 rad, τ 1 %): "
        "p90 |err|/σ, largest |bias|/σ"
    )
    print()
    table = []
    print("| robot | truth | rate | dead zone | dead zone per sample | exact sign |")
    print("|---|---|---|---|---|---|")
    for name in robots:
        robot = _robot(name)
        truth = robot.base_values
        laws = {"sign": 0.0, "tanh": TANH_WIDTH}
        for law_name in args.truth or laws:
            width = laws[law_name]
            for rate in args.rates:
                log = _log(robot, 1.0 / rate, width, args.duration)
                runs: dict[str, tuple[list, list]] = {}
                for seed in range(seeds):
                    noisy = with_noise(log, 1e-4, 0.01 * log.tau.std(axis=0), seed)
                    widths = tuple(map(float, standstill_widths(noisy)))
                    for label, sign in _laws(robot, widths).items():
                        model = robot if sign is None else robot.with_sign(sign)
                        result = identify_offline(noisy, model)
                        est, std = runs.setdefault(label, ([], []))
                        est.append(result.theta)
                        std.append(result.std)
                rows = {"": None}
                if robot.drive is not None:  # the Coulomb parameters apart
                    coulomb = np.array([x.startswith("FC") for x in robot.base.names])
                    rows[", FC only"] = coulomb
                for suffix, chosen in rows.items():
                    metrics = {
                        label: _metrics(e, s, truth, chosen)
                        for label, (e, s) in runs.items()
                    }
                    table.append(
                        {
                            "robot": name + suffix,
                            "truth": law_name,
                            "rate": rate,
                            **{
                                label: {"p90": p90, "bias": bias}
                                for label, (p90, bias) in metrics.items()
                            },
                        }
                    )
                    cells = [
                        "{:.2f} / {:.1f}".format(*value) for value in metrics.values()
                    ]
                    print(
                        f"| {name}{suffix} | {law_name} | {rate} Hz | "
                        + " | ".join(cells)
                        + " |",
                        flush=True,
                    )
    if args.json:
        with open(args.json, "w") as stream:
            json.dump(
                {"seeds": seeds, "duration": args.duration, "rows": table}, stream
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
