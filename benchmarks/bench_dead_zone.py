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
noise per seed: 1e-4 rad on q, 1 % of each joint's torque std on τ. Over the
parameters whose median reported σ is <= 5 % of the true value: ``p90`` of
|θ̂ - θ|/σ (1.64 for an honest σ), and ``bias``: the largest |mean θ̂ - θ| over the
seeds in units of the median σ (the seed mean's own spread is about 0.2 of it).

Run: ``python benchmarks/bench_dead_zone.py [--seeds 20] [--quick]`` (about a
minute with 20 seeds on one core).
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from _independent import exact_log, with_noise
from _timing import quick_or
from bench_sigma_offline import trajectory

from drake_dynid.core._threads import configure_process
from drake_dynid.core.friction import DeadZoneSign
from drake_dynid.offline import identify_offline, standstill_widths
from drake_dynid.plants import RobotModel, model_path

TANH_WIDTH = 0.005  # [rad/s] the smooth truth's tanh(v/W)


@dataclasses.dataclass(frozen=True)
class SampleDeadZone:
    """The dead zone sample by sample (the library's before the reversals).

    A ``SignLaw`` that is not a ``DeadZoneSign``, so the off-line stream applies
    it as it is: 0 inside the zone at every sample, reversals included.
    """

    width: tuple[float, ...]

    def __call__(self, v):  # noqa: D102
        return DeadZoneSign(self.width)(v)

    def scalar(self, v: float) -> float:  # noqa: D102
        raise TypeError("per-joint widths: no scalar form")


def _laws(widths):
    return {
        "dead zone": DeadZoneSign(widths),
        "per sample": SampleDeadZone(widths),
        "exact sign": None,
    }


def _metrics(estimates, stds, truth):
    estimates, stds = np.array(estimates), np.array(stds)
    sigma = np.median(stds, axis=0)
    well = sigma <= 0.05 * np.abs(truth)
    z = np.abs(estimates[:, well] - truth[well]) / stds[:, well]
    bias = np.abs(estimates.mean(axis=0) - truth)[well] / sigma[well]
    return float(np.percentile(z, 90)), float(bias.max())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=None, help="default 20")
    parser.add_argument("--quick", action="store_true", help="4 seeds, UR5 only")
    args = parser.parse_args(argv)
    configure_process()
    seeds = quick_or(args.seeds, args.quick, 4, 20)
    robots = ("ur5",) if args.quick else ("ur5", "iiwa7")
    print(
        f"dynid offline with three Coulomb columns ({seeds} seeds, 60 s, Drake inverse "
        "dynamics, σ_q 1e-4 rad, τ 1 %): p90 |err|/σ, largest |bias|/σ"
    )
    print()
    print("| robot | truth | rate | dead zone | dead zone per sample | exact sign |")
    print("|---|---|---|---|---|---|")
    for name in robots:
        robot = RobotModel.from_urdf(model_path(name))
        truth = robot.base_values
        for law_name, width in (("sign", 0.0), ("tanh", TANH_WIDTH)):
            for rate in (125, 500, 1000):
                h = 1.0 / rate
                log, _ = exact_log(robot, trajectory(robot.num_joints), 60.0, h, width)
                runs: dict[str, tuple[list, list]] = {}
                for seed in range(seeds):
                    noisy = with_noise(log, 1e-4, 0.01 * log.tau.std(axis=0), seed)
                    widths = tuple(map(float, standstill_widths(noisy)))
                    for label, sign in _laws(widths).items():
                        model = robot if sign is None else robot.with_sign(sign)
                        result = identify_offline(noisy, model)
                        est, std = runs.setdefault(label, ([], []))
                        est.append(result.theta)
                        std.append(result.std)
                cells = [
                    "{:.2f} / {:.1f}".format(*_metrics(e, s, truth))
                    for e, s in runs.values()
                ]
                print(
                    f"| {name} | {law_name} | {rate} Hz | " + " | ".join(cells) + " |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
