"""``dynid simulate``: rehearse an identification experiment in Drake."""

from __future__ import annotations

import argparse
import contextlib
import json
import time
from pathlib import Path

import numpy as np

from drake_dynid.commands._arguments import add_friction_argument, parse_friction
from drake_dynid.commands._paths import check_output_paths

HELP = "simulate a robot log (the URDF arm tracking a trajectory, with noise)"
DESCRIPTION = (
    "Simulates the URDF arm in Drake (discrete MultibodyPlant at 1 kHz, viscous "
    "friction from the URDF damping, Coulomb friction from the URDF <dynamics "
    "friction> as an applied force) tracking a trajectory file (CSV: t, q_<joint>, "
    "v_<joint>, e.g. from dynid excite; cubic Hermite interpolation) with Drake's "
    "InverseDynamicsController plus a Coulomb feedforward, adds seeded white noise, "
    "and writes the log (t, q_<joint>, tau_<joint>) at the given rate and the true "
    "base parameters next to it (LOG.truth.json, the dynid params --json format). "
    "Stops with exit code 2, naming the joint, the time and the limit, if the "
    "motion leaves the position limits or the simulation diverges (non-finite "
    "state, a command beyond 10 times the effort limit, tracking error beyond "
    "--max-tracking-error)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid simulate`` arguments."""
    parser.add_argument("urdf", metavar="MODEL.urdf", help="the robot's URDF file")
    parser.add_argument(
        "--trajectory",
        required=True,
        metavar="TRAJ.csv",
        help="the reference (CSV of dynid excite, or its --json coefficients)",
    )
    add_friction_argument(parser)
    parser.add_argument(
        "--snr",
        type=float,
        metavar="DB",
        help="white noise at this SNR on every q and tau channel, SNR = 10 "
        "log10(var(x)/σ²) (instead of --noise-q/--noise-tau)",
    )
    parser.add_argument(
        "--noise-q",
        type=float,
        metavar="RAD",
        help="std of the position noise [rad or m] (default 1e-4)",
    )
    parser.add_argument(
        "--noise-tau",
        type=float,
        metavar="FRAC",
        help="std of the torque noise as a fraction of each joint's torque std "
        "(default 0.01: SNR 40 dB)",
    )
    parser.add_argument(
        "--rate", type=float, default=1000.0, metavar="HZ", help="log rate [Hz]"
    )
    parser.add_argument("--seed", type=int, default=0, metavar="S", help="noise seed")
    parser.add_argument(
        "--duration",
        type=float,
        metavar="S",
        help="simulated time [s] (default: the trajectory's)",
    )
    parser.add_argument(
        "--limits",
        metavar="FILE",
        help="per-joint limits file (JSON/TOML) completing the URDF's, as in "
        "dynid excite",
    )
    parser.add_argument(
        "--max-tracking-error",
        type=float,
        default=0.1,
        metavar="RAD",
        help="stop when |q - q_ref| exceeds this [rad or m] (default 0.1)",
    )
    parser.add_argument(
        "--time-step",
        type=float,
        default=1e-3,
        metavar="S",
        help="plant period [s] (default 0.001; the log rate must divide 1/S)",
    )
    parser.add_argument(
        "--out",
        required=True,
        metavar="LOG.csv",
        help="write the log here and the truth to LOG.truth.json",
    )
    parser.add_argument("--quiet", action="store_true", help="print nothing")


#: ExperimentSettings field -> the option that sets it.
OPTION_NAMES = {
    "noise_q": "--noise-q",
    "noise_tau": "--noise-tau",
    "snr_db": "--snr",
    "rate": "--rate",
    "seed": "--seed",
    "duration": "--duration",
    "time_step": "--time-step",
    "max_tracking_error": "--max-tracking-error",
}


@contextlib.contextmanager
def _in_option_names():
    """ValueErrors of the settings and the simulation in the command's options."""
    from drake_dynid.commands._options import option_message

    try:
        yield
    except ValueError as error:
        owners = ("ExperimentSettings", "simulate_experiment")
        raise ValueError(option_message(str(error), OPTION_NAMES, owners)) from None


def truth_path(out: str) -> Path:
    """``LOG.csv`` -> ``LOG.truth.json``."""
    path = Path(out)
    return path.with_name(f"{path.stem if path.suffix else path.name}.truth.json")


def run(args: argparse.Namespace) -> int:
    """Simulates, writes the log and its truth. Returns 0."""
    from drake_dynid.commands.params import params_document
    from drake_dynid.experiment import ExperimentSettings, simulate_experiment
    from drake_dynid.limits import joint_limits
    from drake_dynid.logs import write_log
    from drake_dynid.robot import RobotModel
    from drake_dynid.trajectory_file import read_trajectory

    truth = truth_path(args.out)
    check_output_paths(args, outputs={"the truth file": truth})
    if args.snr is not None and (
        args.noise_q is not None or args.noise_tau is not None
    ):
        raise ValueError("give either --snr or --noise-q/--noise-tau, not both.")
    friction = parse_friction(args.friction)
    with _in_option_names():
        settings = ExperimentSettings(
            friction=friction,
            noise_q=1e-4 if args.noise_q is None else args.noise_q,
            noise_tau=0.01 if args.noise_tau is None else args.noise_tau,
            snr_db=args.snr,
            rate=args.rate,
            seed=args.seed,
            duration=args.duration,
            time_step=args.time_step,
            max_tracking_error=args.max_tracking_error,
        )
    robot = RobotModel.from_urdf(args.urdf, friction=friction)
    limits = joint_limits(robot, args.limits)
    reference = read_trajectory(args.trajectory, robot.joint_names)
    say = (lambda *a: None) if args.quiet else print
    unchecked = [
        name
        for j, name in enumerate(limits.joint_names)
        if not (np.isfinite(limits.lower[j]) and np.isfinite(limits.upper[j]))
    ]
    if unchecked:
        say(f"note: no position limits for {', '.join(unchecked)}: not checked")
    start = time.perf_counter()
    with _in_option_names():
        log = simulate_experiment(
            args.urdf, reference, limits, settings, gravity=robot.gravity
        )
    elapsed = time.perf_counter() - start
    write_log(args.out, log.t, log.q, log.tau, robot.joint_names)
    document = params_document(robot, args.urdf)
    n = robot.num_joints
    document["simulation"] = {
        "trajectory": str(args.trajectory),
        "duration": float(log.t[-1]),
        "rate": float(args.rate),
        "time_step": float(args.time_step),
        "seed": int(args.seed),
        "friction": list(friction),
        "snr_db": args.snr,
        "noise_std_q": log.noise_std[:n].tolist(),
        "noise_std_tau": log.noise_std[n:].tolist(),
        "max_tracking_error": log.max_tracking_error.tolist(),
        "saturated_samples": int(log.saturated),
        "coulomb_smoothing": settings.coulomb_smoothing,
    }
    truth.write_text(json.dumps(document, indent=2) + "\n")
    say(f"robot: {args.urdf}; trajectory: {args.trajectory}")
    say(
        f"simulated {log.t[-1]:g} s at {1.0 / args.time_step:g} Hz in {elapsed:.1f} s "
        f"({log.t[-1] / elapsed:.1f}× real time); friction: "
        f"{', '.join(friction) or 'none'}"
    )
    noise = (
        f"SNR {args.snr:g} dB"
        if args.snr is not None
        else f"σ_q = {settings.noise_q:g}, σ_τ = {settings.noise_tau:g} × std(τ)"
    )
    say(
        f"log: {log.t.size} samples at {args.rate:g} Hz, seeded noise ({noise}); "
        f"largest tracking error {log.max_tracking_error.max():.3g} "
        f"(joint {robot.joint_names[int(np.argmax(log.max_tracking_error))]})"
    )
    if log.saturated:
        say(
            f"warning: the command exceeded the URDF effort limit in {log.saturated} "
            "samples; the log holds the applied (clipped) torque"
        )
    say(f"wrote {args.out} and {truth} (true base parameters)")
    return 0
