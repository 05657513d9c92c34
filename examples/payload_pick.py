"""A 7-DOF arm picks up a payload; the payload identifier reports it within a second.

A KUKA iiwa (``model_path("iiwa7")``) is simulated by Drake (a discrete
``MultibodyPlant`` at 1 kHz tracking a slow random Fourier motion with an
inverse-dynamics controller that ignores the payload; Coulomb friction
tanh(v/0.01)), ``drake_dynid.simulation.simulate_identification``. Between two
``Simulator.AdvanceTo`` calls the payload is added to the last link's spatial
inertia in the plant's Context (the pick) and, in the full run, removed again (the
place). White noise is added to the recorded q and τ (seeded).

The payload identifier (``drake_dynid.payload_model`` + ``payload_settings``: the
arm's URDF parameters known, window 0.75 s) runs over the log, with the core
replay or, with ``--engine blocks``, the Drake blocks. Prints the time after the
pick until the mass stays within 5 %, the final estimate (mass, centre of mass,
inertia about the flange with σ; %σ > 30 flagged) against the payload's true
values, and writes ``payload_pick.png``.
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from _example import run_example

from drake_dynid.core.payload import payload_parameters
from drake_dynid.core.payload_report import payload_summary
from drake_dynid.core.payload_step import payload_settings
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.payload import payload_model
from drake_dynid.robot import RobotModel
from drake_dynid.simulation import SimulationSettings, simulate_identification
from drake_dynid.urdf import model_path

#: The payload: mass [kg], centre of mass in the flange frame [m], central inertia.
MASS = 2.0
COM = np.array([0.01, -0.02, 0.1])
INERTIA = np.diag([0.01, 0.012, 0.008])
#: Coulomb friction law of the simulation (SimulationSettings.coulomb_smoothing),
#: the arm's known model uses the same (RobotModel coulomb_width).
SMOOTHING = 0.01


def payload_event(body_name: str, theta: np.ndarray, sign: float = 1.0):
    """Event callback adding (sign = 1) or removing (-1) a payload to a body.

    ``theta``: the payload's 10 standard parameters about the body's origin, in
    its frame (``core.payload.PAYLOAD_NAMES``).
    """

    def callback(plant, context) -> None:
        from pydrake.multibody.tree import SpatialInertia, UnitInertia

        body = plant.GetBodyByName(body_name)
        mass = theta[9]
        unit = theta[:6] / mass
        payload = SpatialInertia(
            mass,
            theta[6:9] / mass,
            UnitInertia(unit[0], unit[3], unit[5], unit[1], unit[2], unit[4]),
        )
        current = body.CalcSpatialInertiaInBodyFrame(context)
        if sign > 0:
            current += payload
        else:
            current = SpatialInertia(
                current.get_mass() - mass,
                (current.get_mass() * np.asarray(current.get_com()) - theta[6:9])
                / (current.get_mass() - mass),
                UnitInertia(
                    *(
                        (
                            current.CalcRotationalInertia().CopyToFullMatrix3()
                            - _tensor(theta)
                        )
                        / (current.get_mass() - mass)
                    )[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]
                ),
            )
        body.SetSpatialInertiaInBodyFrame(context, current)

    return callback


def _tensor(theta: np.ndarray) -> np.ndarray:
    xx, xy, xz, yy, yz, zz = theta[:6]
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def settling_time(t, estimate, target, after, tolerance=0.05) -> float:
    """Time after ``after`` until ``estimate`` stays within ``tolerance`` of target.

    inf when it is outside the band at the end.
    """
    inside = np.abs(estimate - target) <= tolerance * abs(target)
    mask = t >= after
    t, inside = t[mask], inside[mask]
    if len(t) == 0 or not inside[-1]:
        return np.inf
    outside = np.flatnonzero(~inside)
    return float(t[outside[-1] + 1] - after) if outside.size else float(t[0] - after)


#: Seconds after the pick before the estimate is reported: the payload window
#: (0.75 s) fills, and the noise model pools its windows (docs/PAYLOAD.md §3).
FILL = 1.0
#: --quick's presets: defaults that an explicit option overrides (no place).
QUICK = {"pick": 1.5, "place": np.inf, "duration": 3.2}


def main(argv=None) -> int:
    """Runs the example; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1, help="noise seed (default 1)")
    parser.add_argument("--pick", type=float, default=4.0, help="pick time [s] (4)")
    parser.add_argument("--place", type=float, default=7.0, help="place time [s] (7)")
    parser.add_argument("--duration", type=float, default=9.0, help="[s] (9)")
    parser.add_argument(
        "--q-noise", type=float, default=1e-4, help="σ of q [rad] (1e-4)"
    )
    parser.add_argument(
        "--tau-noise", type=float, default=0.05, help="σ of τ [N·m] (0.05)"
    )
    parser.add_argument("--engine", choices=("core", "blocks"), default="core")
    parser.add_argument("--out", default="out", help="output folder (out/)")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="tiny run for tests (--pick 1.5 --duration 3.2, no place)",
    )
    parser.add_argument(
        "--log",
        metavar="FILE.csv",
        help="also write the noisy log (for dynid payload, README)",
    )
    return run_example(parser, argv, _run, QUICK)


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The example with parsed arguments; returns 0 (``parser.error`` exits 2)."""
    if args.log and (
        not args.log.lower().endswith(".csv")
        or (os.path.exists(args.log) and not os.path.isfile(args.log))
    ):
        parser.error(f"--log must name a .csv file; got {args.log!r}")
    for name in ("pick", "duration"):
        if not np.isfinite(getattr(args, name)):
            parser.error(f"--{name} must be a finite time [s]")
    if args.seed < 0:  # numpy's "expected non-negative integer" named no option
        parser.error(f"--seed must be >= 0; got {args.seed}")
    if args.pick < 0.0:
        parser.error("--pick must be >= 0 s (the log starts at t = 0)")
    for name in ("q_noise", "tau_noise"):
        if not (np.isfinite(getattr(args, name)) and getattr(args, name) >= 0.0):
            parser.error(f"--{name.replace('_', '-')} must be a finite σ >= 0")
    if not args.pick < min(args.place, args.duration):
        parser.error("--pick must come before --place and --duration")
    if min(args.place, args.duration) - args.pick < FILL:
        parser.error(
            f"--place and --duration must come at least {FILL:g} s after --pick: "
            "the identifier's 0.75 s window must fill with the payload before its "
            "estimate is reported"
        )
    pick, place, duration = args.pick, args.place, args.duration
    try:  # a file of that name (or under one) was a FileExistsError traceback
        os.makedirs(args.out, exist_ok=True)
    except OSError as error:
        parser.error(f"--out {args.out}: not a folder ({error.strerror})")

    robot = RobotModel.from_urdf(model_path("iiwa7"), coulomb_width=SMOOTHING)
    rows = payload_model(robot)  # the last link, iiwa_link_7 (the flange)
    truth = payload_parameters(MASS, COM, INERTIA)
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        rng=np.random.default_rng(5),
    )
    body = rows.frame_name
    events = [(pick, payload_event(body, truth))]
    if place < duration:
        events.append((place, payload_event(body, truth, sign=-1.0)))
    result = simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=duration, snr_db=None, coulomb_smoothing=SMOOTHING),
        [],
        events=events,
    )
    rng = np.random.default_rng(args.seed)
    log = RobotLog(
        result.t,
        result.q_true + args.q_noise * rng.normal(size=result.q_true.shape),
        result.tau_true + args.tau_noise * rng.normal(size=result.tau_true.shape),
        robot.joint_names,
        robot.plant.time_step() or 1e-3,
    )
    if args.log:
        write_log(args.log, log.t, log.q, log.tau, log.joint_names)
        print(f"wrote {args.log}")
    settings = payload_settings()
    if args.engine == "blocks":
        from drake_dynid.payload_diagrams import replay_payload_log as replay
    else:
        from drake_dynid.core.payload_replay import replay_payload_core as replay
    trace = replay(log, rows, settings)
    names = rows.payload_names
    mass = trace.theta[:, names.index("M")]
    held = trace.t < place  # the settling time of the pick, before any place
    settle = settling_time(trace.t[held], mass[held], MASS, pick)
    print(
        f"iiwa7 picks {MASS:g} kg at t = {pick:g} s"
        + (f", places it at {place:g} s" if place < duration else "")
        + f"; noise σ_q = {args.q_noise:g} rad, σ_τ = {args.tau_noise:g} N·m "
        f"(seed {args.seed}); window {settings.window:g} s, engine {args.engine}"
    )
    print(
        f"mass within 5 % of {MASS:g} kg from {settle:.2f} s after the pick "
        f"(latency {trace.delay:.3f} s)"
    )
    # Before the place: the row at it (a row holds the solve of the period before,
    # whose window ends before the place: docs/CONVENTIONS.md §2); without one,
    # the final row (t_N: the solve at the log's last sample).
    end = (
        int(np.searchsorted(trace.t, place + 1e-9)) - 1
        if place < duration
        else len(trace.t) - 1
    )
    summary = payload_summary(
        rows, trace.theta[end], trace.std[end], trace.correlation[end]
    )
    expected = rows.base.matrix @ truth
    print(f"\nestimate at t = {trace.t[end]:.2f} s (about the flange, in its axes):")
    print("| parameter | true | estimate | σ | identified |")
    print("|---|---|---|---|---|")
    for k, name in enumerate(names):
        flag = "yes" if trace.std[end, k] <= 0.3 * abs(trace.theta[end, k]) else "no"
        print(
            f"| {name} | {expected[k]:.4g} | {trace.theta[end, k]:.4g} | "
            f"{trace.std[end, k]:.2g} | {flag} |"
        )
    error = 100.0 * (summary["mass"]["value"] - MASS) / MASS
    print(f"\nmass error: {error:+.2f} %")
    if summary["com"] is not None:
        com = [summary["com"][a]["value"] for a in "xyz"]
        sigma = [summary["com"][a]["std"] for a in "xyz"]
        print(
            "centre of mass: ("
            + ", ".join(f"{c:.4f} ± {s:.4f}" for c, s in zip(com, sigma, strict=True))
            + f") m; true ({', '.join(f'{c:g}' for c in COM)})"
        )
    if place < duration:
        after = mass[trace.t >= place + 1.0]  # the window has forgotten the payload
        if after.size:
            print(f"after the place: mass {after[-1]:+.3f} kg (payload gone)")
        else:
            print("after the place: the log ends less than 1 s after it")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    valid = trace.valid > 0.5
    first = int(np.argmax(valid))
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = trace.t[first:]
    m = mass[first:]
    s = trace.std[first:, names.index("M")]
    axes[0].plot(t, m, label="estimate")
    axes[0].fill_between(t, m - s, m + s, alpha=0.3, lw=0, label="±σ")
    true_mass = np.where((t >= pick) & (t < place), MASS, 0.0)
    axes[0].plot(t, true_mass, "k--", lw=1, label="true")
    axes[0].set_ylabel("m [kg]")
    axes[0].set_ylim(-0.5, 1.5 * MASS)
    axes[0].legend(fontsize=8)
    for k, name in enumerate(("MX", "MY", "MZ")):
        index = names.index(name)
        axes[1].plot(t, trace.theta[first:, index], f"C{k}", label=name)
        truth_line = np.where((t >= pick) & (t < place), expected[index], 0.0)
        axes[1].plot(t, truth_line, f"C{k}--", lw=0.8)
    axes[1].set_ylim(-0.2, 0.4)
    axes[1].set_ylabel("m·c [kg·m]")
    axes[1].set_xlabel("t [s]")
    axes[1].legend(fontsize=8)
    fig.suptitle(f"payload identification, window {settings.window:g} s")
    fig.tight_layout()
    path = os.path.join(args.out, "payload_pick.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
