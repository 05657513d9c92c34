"""``dynid simulate``: rehearse an identification experiment in Drake."""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.commands._arguments import (
    DRIVE_METAVAR,
    URDF_HELP,
    absolute,
    add_friction_argument,
    add_joint_arguments,
    drive_argument,
    parse_friction,
    parse_joints,
    parse_locked,
    short_packaged,
    urdf_argument,
)
from drake_dynid.commands._paths import check_output_paths
from drake_dynid.core._validate import listed
from drake_dynid.files import json_text, write_text_whole

HELP = "simulate a robot log (the URDF arm tracking a trajectory, with noise)"
DESCRIPTION = (
    "Simulates the URDF arm in Drake (discrete MultibodyPlant at 1 kHz, viscous "
    "friction from the URDF damping, Coulomb friction from the URDF <dynamics "
    "friction> as an applied force) tracking a trajectory file (CSV: t, q_<joint>, "
    "v_<joint>, e.g. from dynid excite; cubic Hermite interpolation) with Drake's "
    "InverseDynamicsController plus a Coulomb feedforward (each plant step the "
    "midpoint step: the velocity terms at the central difference of the positions, "
    "as the identification evaluates them), adds seeded white noise, "
    "and writes the log (t, q_<joint>, tau_<joint>) at the given rate and the true "
    "base parameters next to it (LOG.truth.json, the dynid params --json format). "
    "Stops with exit code 2, naming the joint, the time and the limit, if the "
    "motion leaves the position limits or the simulation diverges (non-finite "
    "state, a command beyond 10 times the effort limit, tracking error beyond "
    "--max-tracking-error), or the log would have fewer than 16 samples. With "
    "--drive the arm also has the drive file's motors (reflected rotor inertia, "
    "motor friction, coupled motors) and the log is written in the drive file's "
    "raw columns (motor side, units, currents, offsets), read back by dynid "
    "offline/identify/validate --drive. --joints/--lock simulate part of the "
    "robot (the other joints welded at their positions; the trajectory and the "
    "log have the chosen joints' columns). --meshcat replays the simulated motion "
    "in Drake's Meshcat viewer."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid simulate`` arguments."""
    parser.add_argument(
        "urdf", metavar="MODEL.urdf", type=urdf_argument, help=URDF_HELP
    )
    parser.add_argument(
        "--trajectory",
        required=True,
        metavar="TRAJ.csv",
        help="the reference (CSV of dynid excite, or its --json coefficients)",
    )
    add_friction_argument(parser, simulated=1e-2)  # ExperimentSettings default
    add_joint_arguments(parser, "simulate", "simulated")
    parser.add_argument(
        "--drive",
        metavar=DRIVE_METAVAR,
        type=drive_argument,
        help="drive file (docs/DRIVE.md; or a packaged one's name: tiago): simulate "
        "its motors (rotor inertia "
        "reflected through the gear ratios, motor friction, coupled motors) and "
        "write the log in its raw columns and units; the truth then holds the "
        "motor parameters (IAj, IAmk, FVmk, ...)",
    )
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
        "--rate",
        type=float,
        default=1000.0,
        metavar="HZ",
        help="log rate [Hz] (default 1000)",
    )
    parser.add_argument(
        "--seed", type=int, default=0, metavar="S", help="noise seed (default 0)"
    )
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
    parser.add_argument(
        "--meshcat",
        action="store_true",
        help="replay the simulated motion in Drake's Meshcat viewer: print its "
        "URL, write the replay as a standalone page LOG.meshcat.html, and exit "
        "(the live page closes with the command; see --meshcat-wait)",
    )
    parser.add_argument(
        "--meshcat-wait",
        action="store_true",
        help="with --meshcat: keep the live page served until Enter or Ctrl-C",
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
    "coulomb_smoothing": "--coulomb-width",
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


#: How a simulation that ran and then failed begins its message (experiment.py).
_RUN_FAILURES = (
    "the simulation diverged",
    "the tracking error of joint",
    "the motion left the position limits",
)


@contextlib.contextmanager
def _implausible_links_named(urdf: str):
    """A failed run of a file --urdf-out wrote with implausible links says so.

    Such a file's header names the links written nearly empty or with their
    centre of mass far off (``urdf_writer.implausible_links``): a small mass
    metres from its joint is a large inertia and gravity torque no controller
    tuned for the robot drives, which a run stopping on its effort, tracking or
    limits then shows without naming the cause.
    """
    from drake_dynid.urdf_writer import implausible_links

    try:
        yield
    except ValueError as error:
        message = str(error)
        if not any(failure in message for failure in _RUN_FAILURES):
            raise
        try:
            links = implausible_links(
                Path(urdf).read_text(encoding="utf-8", errors="replace")
            )
        except OSError:
            links = ()
        if not links:
            raise
        name, mass, distance, mass0, distance0 = max(
            links, key=lambda e: e[1] * e[2] ** 2
        )
        # Facts, both ways: a link is named for a mass far below or above the
        # URDF's, or a centre of mass far out (urdf_writer.doubtful_links).
        raise ValueError(
            f"{message.rstrip('.')}. {Path(urdf).name} was written by dynid "
            f"--urdf-out with {len(links)} implausible link(s) (its header: "
            f"{listed(e[0] for e in links)}): a mass or centre of mass far from "
            "the URDF's changes the inertia and gravity torques that a controller "
            "tuned for the robot drives; the largest inertia about its origin "
            f"({name}: "
            f"{mass:.3g} kg at {distance:.3g} m from its origin, "
            f"{mass * distance**2:.3g} kg·m² about it; the URDF's {mass0:.3g} kg at "
            f"{distance0:.3g} m). Simulate the URDF it was "
            "identified from, or identify it again with a larger --regularization "
            "(which pulls the links towards that URDF's)."
        ) from None


def truth_path(out: str, suffix: str = ".truth.json") -> Path:
    """``LOG.csv`` -> ``LOG.truth.json`` (or another ``suffix``)."""
    path = Path(out)
    return path.with_name(f"{path.stem if path.suffix else path.name}{suffix}")


def _beyond_limits(reference: Any, log: Any, limits: Any) -> list[str]:
    """The joints whose reference speed or simulated torque exceeds its limit.

    The run stops on position limits and on commands beyond 10x the effort
    limit; a trajectory designed against other limits (the URDF's inflated ones
    instead of ``--limits``) is said here (a review found an iiwa at 6.6 rad/s
    against a datasheet 1.48 rad/s without a word).
    """
    out = []
    simulated = np.asarray(reference.t) - reference.t[0] <= log.t[-1] + 1e-9
    speed = np.max(np.abs(np.asarray(reference.v, dtype=float)[simulated]), axis=0)
    torque = np.max(np.abs(np.asarray(log.tau_true, dtype=float)), axis=0)
    for j, name in enumerate(limits.joint_names):
        units = limits.units(j)
        for what, value, limit, unit in (
            ("speed", speed[j], limits.velocity[j], units[1]),
            ("torque", torque[j], limits.effort[j], units[3]),
        ):
            if np.isfinite(limit) and value > limit * (1 + 1e-9):
                out.append(
                    f"joint {name}'s {what} reaches {value:.4g} {unit}, "
                    f"{value / limit:.2g}x its limit {limit:.4g} {unit}"
                )
    return out


def simulates_coulomb(drive: Any) -> bool:
    """Whether the simulated drive applies any Coulomb friction (joint or motor).

    A URDF without ``<dynamics friction>`` (and a drive file without motor
    ``coulomb``) has FC = 0 everywhere: the law tanh(v/ε) then changes nothing.
    """
    motors = drive.motors
    motor_fc = (
        []
        if motors is None
        else [
            value
            for name, value in zip(motors.names, motors.values, strict=True)
            if name.startswith("FCm")
        ]
    )
    return bool(np.any(drive.coulomb > 0.0) or np.any(np.asarray(motor_fc) > 0.0))


def _identify_hint(
    args: argparse.Namespace, robot, smoothing: float, coulomb: bool = True
) -> str:
    """The dynid offline command line that scores the log against its truth.

    With ``--coulomb-width`` of the simulated Coulomb law tanh(v/ε) (``smoothing``
    ε [rad/s]) when the simulation applied Coulomb friction (``coulomb``): the
    identified model then has the simulator's friction law (the README's iiwa7
    run: the well-excited parameters within 1.02 % off-line, 1.39 % with sign(v)
    and the dead zone; on-line within 1.05 % and 0.90 %). Without any Coulomb
    friction in the model (FC = 0) the width is not suggested: it changes nothing
    in the log.
    """
    import shlex

    parts = ["dynid", "offline", str(args.out), "--urdf", short_packaged(args.urdf)]
    if args.joints:
        parts += ["--joints", ",".join(robot.joint_names)]
    if args.lock:
        parts += [
            "--lock",
            ",".join(f"{k}={v!r}" for k, v in parse_locked(args.lock).items()),
        ]
    if coulomb and "coulomb" in robot.friction and smoothing > 0.0:
        parts += ["--coulomb-width", f"{smoothing:g}"]
    if args.drive:
        parts += ["--drive", short_packaged(args.drive, ".toml")]
    if robot.rotor_inertia:
        parts.append("--rotor-inertia")
    if tuple(robot.friction) != ("viscous", "coulomb"):
        parts += ["--friction", ",".join(robot.friction) or "none"]
    if _slow_unsaid(args, robot):
        parts += ["--time-unit", "s"]
    return shlex.join(parts)  # a path with a space quoted as a shell reads it


def _slow_unsaid(args: argparse.Namespace, robot) -> bool:
    """Whether the log's step 1/--rate [s] is one its readers refuse unsaid.

    A step >= ``log_repair.SLOW_STEP`` (0.5 s: --rate 2 Hz or less) is read as
    stamps in ms, µs or ns unless the time unit is given (``--time-unit``, or the
    drive file's ``[log] time_unit``, in which the log is then written): the
    hint then says ``--time-unit s``. Found by a review: ``--rate 2`` wrote a log
    that the printed ``dynid offline`` command refused (exit 2).
    """
    from drake_dynid.log_repair import SLOW_STEP

    said = robot.drive is not None and robot.drive.log.time_unit_given
    return 1.0 / args.rate >= SLOW_STEP and not said


def _zero_friction(robot: Any, friction: Sequence[str]) -> str:
    """`` (... all 0 in the model)`` for the simulated kinds that are 0 throughout.

    A URDF without ``<dynamics damping/friction>`` (example-robot-data's Kinova)
    simulates no friction whatever ``--friction`` lists: the line says so.
    """
    from drake_dynid.core.friction import FRICTION_PREFIX

    values = dict(zip(robot.standard_names, robot.standard_values, strict=True))
    zero = [
        kind
        for kind in friction
        if all(
            value == 0.0
            for name, value in values.items()
            # A joint's (FV2) or a coupled motor's (FVm6) parameters of the kind.
            if re.fullmatch(rf"{FRICTION_PREFIX[kind]}m?\d+", name)
        )
    ]
    if not zero:
        return ""
    if len(zero) == len(friction):
        return " (all 0 in the model)"
    return f" ({', '.join(zero)} all 0 in the model)"


def run(args: argparse.Namespace) -> int:
    """Simulates, writes the log and its truth. Returns 0."""
    from drake_dynid.commands.params import params_document
    from drake_dynid.experiment import (
        MIN_LOG_SAMPLES,
        ExperimentSettings,
        simulate_experiment,
    )
    from drake_dynid.experiment_drive import simulated_drive_of, truth_model
    from drake_dynid.limits import joint_limits
    from drake_dynid.trajectory_file import read_trajectory

    truth = truth_path(args.out)
    html = truth_path(args.out, ".meshcat.html") if args.meshcat else None
    check_output_paths(
        args, outputs={"the truth file": truth, "the Meshcat page": html}
    )
    if args.snr is not None and (
        args.noise_q is not None or args.noise_tau is not None
    ):
        raise ValueError("give either --snr or --noise-q/--noise-tau, not both.")
    if args.meshcat_wait and not args.meshcat:
        raise ValueError("--meshcat-wait needs --meshcat.")
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
            coulomb_smoothing=args.coulomb_width,
        )
    robot = truth_model(
        args.urdf,
        friction,
        drive=args.drive,
        joints=parse_joints(args.joints),
        locked=parse_locked(args.lock),
    )
    say = (lambda *a: None) if args.quiet else print
    for note in robot.notes:
        print(f"dynid simulate: note: {note}", file=sys.stderr)
    # More torque equations than base parameters (n per sample), and the floor.
    fewest = max(MIN_LOG_SAMPLES, robot.base.num_base // robot.num_joints + 1)
    settings = dataclasses.replace(settings, min_samples=fewest)
    limits = joint_limits(robot, args.limits)
    reference = read_trajectory(args.trajectory, robot.joint_names)
    unchecked = [
        name
        for j, name in enumerate(limits.joint_names)
        if not (np.isfinite(limits.lower[j]) and np.isfinite(limits.upper[j]))
    ]
    if unchecked:
        say(f"note: no position limits for {listed(unchecked)}: not checked")
    drive = simulated_drive_of(robot, settings.coulomb_smoothing)
    start = time.perf_counter()
    with _in_option_names(), _implausible_links_named(args.urdf):
        log = simulate_experiment(
            args.urdf,
            reference,
            limits,
            settings,
            gravity=robot.gravity,
            drive=drive,
            locked=robot.locked,
        )
    elapsed = time.perf_counter() - start
    _write_log(args.out, robot, log)
    document = params_document(robot, args.urdf, args.drive)
    document["simulation"] = _simulation_entry(args, settings, log, robot)
    if "coulomb" in robot.friction:  # the simulated law (read back by validate)
        document["settings"]["coulomb_width"] = settings.coulomb_smoothing
    write_text_whole(truth, json_text(document))
    say(f"robot: {args.urdf}; trajectory: {args.trajectory}")
    say(
        f"simulated {log.t[-1]:g} s at {1.0 / args.time_step:g} Hz in {elapsed:.1f} s "
        f"({_speed(log.t[-1] / elapsed)}× real time); friction: "
        f"{', '.join(friction) or 'none'}{_zero_friction(robot, friction)}"
    )
    if robot.drive is not None:
        say(_drive_line(robot, drive))
    prismatic = tuple(getattr(robot, "prismatic", ())) or (False,)
    unit = "m" if all(prismatic) else "rad or m" if any(prismatic) else "rad"
    noise = (
        f"SNR {args.snr:g} dB"
        if args.snr is not None
        else f"σ_q = {settings.noise_q:g} {unit}, σ_τ = {settings.noise_tau:g} × std(τ)"
    )
    worst = int(np.argmax(log.max_tracking_error))
    worst_unit = "m" if worst < len(prismatic) and prismatic[worst] else "rad"
    say(
        f"log: {log.t.size} samples at {args.rate:g} Hz, seeded noise ({noise}); "
        f"largest tracking error {log.max_tracking_error.max():.3g} {worst_unit} "
        f"(joint {robot.joint_names[worst]})"
    )
    for note in (*log.notes, *_beyond_limits(reference, log, limits)):
        print(f"dynid simulate: warning: {note}", file=sys.stderr)
    if log.saturated:
        say(
            f"warning: the command exceeded the URDF effort limit in {log.saturated} "
            "samples; the log holds the applied (clipped) torque"
        )
    if _slow_unsaid(args, robot):
        print(
            f"dynid simulate: warning: the log's step 1/--rate = {1.0 / args.rate:g} s "
            "is >= 0.5 s: dynid reads it only with --time-unit s (else as stamps in "
            "ms, us or ns read as seconds: refused)",
            file=sys.stderr,
        )
    say(f"wrote {args.out} and {truth} (true base parameters)")
    hint = _identify_hint(
        args, robot, settings.coulomb_smoothing, simulates_coulomb(drive)
    )
    say(f"score it with: {hint}")
    if args.meshcat:
        _replay(args, log, robot, html, say)
    return 0


def _write_log(out: str, robot, log) -> None:
    """The plain log format, or the drive file's raw columns (``--drive``)."""
    if robot.drive is None:
        from drake_dynid.logs import write_log

        write_log(out, log.t, log.q, log.tau, robot.joint_names)
    else:
        from drake_dynid.raw_log import write_raw_log

        write_raw_log(out, robot.drive, log.t, log.q, log.tau)


def _simulation_entry(args, settings, log, robot) -> dict:
    """The ``simulation`` entry of the truth file."""
    n = robot.num_joints
    return {
        "trajectory": str(args.trajectory),
        "duration": float(log.t[-1]),
        "rate": float(args.rate),
        "time_step": float(args.time_step),
        "seed": int(args.seed),
        "friction": list(settings.friction),
        "drive": absolute(args.drive),
        "rotor_inertia": bool(robot.rotor_inertia),
        "snr_db": args.snr,
        "noise_std_q": log.noise_std[:n].tolist(),
        "noise_std_tau": log.noise_std[n:].tolist(),
        "max_tracking_error": log.max_tracking_error.tolist(),
        "saturated_samples": int(log.saturated),
        "coulomb_smoothing": settings.coulomb_smoothing,
    }


def _drive_line(robot, drive) -> str:
    chain = robot.drive
    coupled = listed(chain.motor_names[k] for k in chain.coupled_motors)
    inertia = (
        "none"
        if drive.rotor_inertia is None
        else f"IAj up to {float(np.max(drive.rotor_inertia)):.3g}"
    )
    return (
        f"drive: {chain.source}; {chain.num_motors} motors"
        + (f" (coupled: {coupled})" if coupled else "")
        + f"; reflected inertia {inertia}; log in its raw columns "
        f"({chain.log.position_side}-side positions, {chain.log.torque_side}-side "
        f"{chain.log.torque_unit})"
    )


def _replay(args, log, robot, html, say) -> None:
    """``--meshcat``: the simulated (noise-free) motion as a Meshcat animation."""
    from drake_dynid.meshcat_replay import replay_in_meshcat

    replay = replay_in_meshcat(
        args.urdf, log.t, log.q_true, robot.joint_names, html=html, locked=robot.locked
    )
    for note in replay.notes:
        print(f"dynid simulate: note: Meshcat: {note}", file=sys.stderr)
    say(
        f"Meshcat: {replay.url} ({replay.frames} frames); standalone page {replay.html}"
    )
    if args.meshcat_wait:
        print("Meshcat: serving the live page; press Enter (or Ctrl-C) to exit")
        with contextlib.suppress(EOFError, KeyboardInterrupt):
            input()


def _speed(ratio: float) -> str:
    """A real-time ratio: one decimal, or two significant digits below 1.

    A 5 µs step simulates at 0.04× real time, which one decimal printed as 0.0.
    """
    return f"{ratio:.1f}" if ratio >= 1.0 else f"{ratio:.2g}"
