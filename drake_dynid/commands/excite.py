"""``dynid excite``: design an exciting trajectory for a URDF robot."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import sys
import time
from typing import Any

import numpy as np

from drake_dynid.commands._arguments import (
    URDF_HELP,
    add_drive_arguments,
    add_friction_argument,
    add_joint_arguments,
    robot_from_args,
    urdf_argument,
)
from drake_dynid.commands._options import option_message
from drake_dynid.commands._paths import check_output_paths
from drake_dynid.core._validate import listed

HELP = "design an exciting trajectory (optimal Fourier series within the limits)"
DESCRIPTION = (
    "Optimises a periodic finite Fourier series per joint (base frequency f0, H "
    "harmonics, repeated over the duration) for the condition number of the "
    "column-scaled base regressor of the URDF robot, within its position, velocity "
    "and effort limits (with margins; the torques from the URDF's inverse dynamics) "
    "and free of self-collision where the URDF has collision geometry. Writes the "
    "sampled trajectory (CSV: t, q_<joint>, v_<joint>, a_<joint>) and optionally its "
    "Fourier coefficients (JSON) and a figure; prints the condition number (and the "
    "default random trajectory's), the limits used and the base parameters that "
    "stay weakly excited (predicted relative σ of a noisy log)."
)

MARGIN_KINDS = (
    "position",
    "prismatic",
    "velocity",
    "acceleration",
    "effort",
    "collision",
)
#: Most samples of the written trajectory or of the predicted-σ log (rate x duration).
MAX_SAMPLES = 1e7
WELL_EXCITED_PERCENT = 0.1
"""Predicted %σ (torque noise only) at or below which a parameter is well excited:
10 times below a 1 % target, leaving room for the position noise, the filters and
model mismatch that the prediction does not include (benchmarks/bench_excite.py)."""
WEAK_PERCENT = 1.0
"""Predicted %σ above which a parameter is reported as weakly excited."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid excite`` arguments."""
    parser.add_argument(
        "urdf", metavar="MODEL.urdf", type=urdf_argument, help=URDF_HELP
    )
    add_joint_arguments(parser)
    add_drive_arguments(parser)
    parser.add_argument(
        "--duration",
        type=float,
        default=60.0,
        metavar="S",
        help="experiment length [s], whole periods 1/f0 (default 60)",
    )
    parser.add_argument(
        "--harmonics",
        type=int,
        default=5,
        metavar="H",
        help="harmonics per joint (default 5)",
    )
    parser.add_argument(
        "--f0",
        type=float,
        default=0.2,
        metavar="HZ",
        help="base frequency [Hz]; band H·f0 (default 0.2)",
    )
    parser.add_argument(
        "--margin",
        default="",
        metavar="KIND=V[,...]",
        help="margins kept from the limits: position=RAD at each end of a revolute "
        "joint's range (default 0.1), prismatic=M at each end of a prismatic "
        "joint's stroke (0.02), velocity=FRAC (0.2), acceleration=FRAC (0.2), "
        "effort=FRAC (0.2), collision=M (0.01)",
    )
    parser.add_argument(
        "--limits",
        metavar="FILE",
        help="JSON (or TOML) of per-joint limits overriding or completing the "
        'URDF\'s: {"joint": {"lower": .., "upper": .., "velocity": .., "effort": '
        '.., "acceleration": ..}}',
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        metavar="S",
        help="seed of the random start (default 0)",
    )
    parser.add_argument(
        "--iterations",
        type=int,
        default=100,
        metavar="N",
        help="SLSQP iterations (default 100); where the effort or clearance passes "
        "its margin between the samples, up to 3 re-solves of min(N, 30) more",
    )
    parser.add_argument(
        "--rest-start",
        action="store_true",
        help="start and end every period at rest (v = v̇ = 0); costs friction "
        "accuracy in identification",
    )
    add_friction_argument(parser)
    parser.add_argument(
        "--out",
        required=True,
        metavar="TRAJ.csv",
        help="write the sampled trajectory (CSV; -: standard output)",
    )
    parser.add_argument(
        "--json",
        metavar="COEFFS.json",
        help="write the Fourier coefficients and the report (JSON; named .json, "
        "as simulate and replay read it back)",
    )
    parser.add_argument(
        "--plot",
        metavar="FILE.png",
        help="figure of the motion against the limits and of %%σ",
    )
    parser.add_argument(
        "--sample-rate",
        type=float,
        default=100.0,
        metavar="HZ",
        help="sample rate of TRAJ.csv [Hz] (default 100)",
    )
    parser.add_argument(
        "--online-window",
        type=float,
        metavar="T",
        help="also report the condition number of the on-line (Lagrangian, "
        "modulating-function) equations over windows of T seconds",
    )
    parser.add_argument(
        "--noise-tau",
        type=float,
        default=0.01,
        metavar="FRAC",
        help="torque noise of the predicted %%σ, as a fraction of each joint's "
        "torque std (default 0.01, as dynid simulate)",
    )
    parser.add_argument(
        "--log-rate",
        type=float,
        default=1000.0,
        metavar="HZ",
        help="log rate of the predicted %%σ [Hz] (default 1000)",
    )
    parser.add_argument("--quiet", action="store_true", help="print nothing")


def parse_margins(text: str) -> Any:
    """``"position=0.05,effort=0.3"`` -> ``Margins``."""
    from drake_dynid.core.joint_limits import Margins

    values: dict[str, float] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        kind, _, value = item.partition("=")
        kind = kind.strip()
        if kind not in MARGIN_KINDS or not value:
            raise ValueError(
                f"--margin: expected KIND=VALUE with KIND among "
                f"{', '.join(MARGIN_KINDS)}; got {item!r}."
            )
        try:
            values[kind] = float(value)
        except ValueError:
            # excite prints the fractions as percentages ('velocity 20%').
            unit = (
                " [rad]"
                if kind == "position"
                else " [m]"
                if kind in ("prismatic", "collision")
                else ", a fraction of the limit (0.2 for 20 %)"
            )
            raise ValueError(
                f"--margin: {kind} must be a number{unit}; got {value!r}."
            ) from None
    return Margins(**values)


#: The position range [rad] the design gives a revolute joint without position
#: limits (a URDF ``continuous`` joint: a PR2 forearm or wrist roll), centred
#: on 0: one turn, so that the trajectory's amplitude stays the velocity
#: limit's and the design needs no limits file for it.
CONTINUOUS_RANGE = (-math.pi, math.pi)


def _limits(robot: Any, args: argparse.Namespace) -> Any:
    """The design's limits: the URDF's, ``--limits``, a continuous joint's range.

    A revolute joint whose position limits are both infinite after both
    sources (a continuous joint) gets :data:`CONTINUOUS_RANGE`, with a note on
    stderr; other missing limits are an error naming them.
    """
    from drake_dynid.limits import joint_limits

    limits = joint_limits(robot, args.limits)
    free = [
        name
        for j, name in enumerate(limits.joint_names)
        if not robot.prismatic[j]
        and np.isinf(limits.lower[j])
        and np.isinf(limits.upper[j])
    ]
    if free:
        low, high = CONTINUOUS_RANGE
        limits = limits.with_overrides(
            {name: {"lower": low, "upper": high} for name in free}
        )
        print(
            f"dynid excite: note: {listed(free)} ha{'s' if len(free) == 1 else 've'}"
            f" no position limits (continuous): the design keeps "
            f"{'it' if len(free) == 1 else 'them'} within [{low:.4g}, {high:.4g}] rad "
            "(give lower/upper in --limits FILE for another range).",
            file=sys.stderr,
        )
    missing = limits.missing()
    if missing:
        source = f"{args.urdf} and {args.limits}" if args.limits else args.urdf
        raise ValueError(
            f"{source} lack(s) limits that the design needs: "
            f"{listed(missing, sep='; ')}. "
            'Give them in a limits file, --limits FILE (JSON: {"<joint>": '
            '{"lower": -2.9, "upper": 2.9, "velocity": 1.5, "effort": 100}}).'
        )
    return limits


def _position_margins(robot: Any, margins: Any) -> str:
    """The position margins of the robot's joint types.

    ``0.1 rad``, ``0.02 m (prismatic torso_lift_joint)`` or both: a revolute
    joint keeps ``--margin position`` [rad], a prismatic one ``--margin
    prismatic`` [m] (one number for both kept 0.1 m at each end of the TIAGo
    torso's 0.35 m stroke).
    """
    prismatic = [
        name
        for name, slider in zip(robot.joint_names, robot.prismatic, strict=True)
        if slider
    ]
    parts = []
    if len(prismatic) < robot.num_joints:
        parts.append(f"{margins.position:g} rad")
    if prismatic:
        parts.append(f"{margins.prismatic:g} m (prismatic {', '.join(prismatic)})")
    return ", ".join(parts)


def _percent(value: float) -> str:
    return f"{value:.2g}" if math.isfinite(value) else "inf"


def _json_named(path: str) -> bool:
    """Whether simulate and replay read ``path`` back as --json's coefficients.

    They read a trajectory named ``.json`` (any case) as the coefficients and
    any other as --out's CSV samples; standard output (``-``) and an existing
    file that is no regular file (``/dev/null``, a named pipe) are read by no
    one as a trajectory.
    """
    import os
    import stat

    from drake_dynid.files import is_stdout

    if is_stdout(path) or path.lower().endswith(".json"):
        return True
    try:
        return not stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


def run(args: argparse.Namespace) -> int:
    """Designs the trajectory, prints the report, writes the files. Returns 0."""
    from drake_dynid.collision import SelfCollision
    from drake_dynid.core.excite import ExcitationSettings, design_excitation
    from drake_dynid.core.excite_report import excitation_report
    from drake_dynid.trajectory_file import (
        SampledTrajectory,
        write_coefficients,
        write_trajectory,
    )
    from drake_dynid.urdf import MissingFileError

    check_output_paths(args)
    # simulate and replay read a .json trajectory as --json's coefficients and
    # any other as --out's CSV samples: a file named as the other format is read
    # as it, and refused there with a message that does not say why (--json
    # coeffs.txt: 'missing column(s) t, ... (found: {)').
    if args.out.lower().endswith(".json"):
        raise ValueError(
            f"--out {args.out}: --out writes the sampled trajectory as CSV, and a "
            ".json trajectory is read as the coefficients of --json; name it .csv "
            "(the coefficients: --json FILE.json)."
        )
    if args.json and not _json_named(args.json):
        raise ValueError(
            f"--json {args.json}: --json writes the coefficients as JSON, and a "
            "trajectory not named .json is read as the CSV samples of --out; name "
            "it .json."
        )
    margins = parse_margins(args.margin)
    try:
        settings = ExcitationSettings(
            duration=args.duration,
            harmonics=args.harmonics,
            base_frequency=args.f0,
            iterations=args.iterations,
            seed=args.seed,
            rest_start=args.rest_start,
        )
    except ValueError as error:
        names = {
            "duration": "--duration",
            "harmonics": "--harmonics",
            "base_frequency": "--f0",
            "iterations": "--iterations",
            "seed": "--seed",
        }
        raise ValueError(
            option_message(str(error), names, ("ExcitationSettings",))
        ) from None
    for option, rate in (
        ("--sample-rate", args.sample_rate),
        ("--log-rate", args.log_rate),
    ):
        if not (math.isfinite(rate) and rate > 0.0):
            raise ValueError(f"{option} must be finite and > 0 [Hz]; got {rate}.")
        samples = rate * settings.duration
        if samples > MAX_SAMPLES:
            raise ValueError(
                f"{option} x --duration must give at most {MAX_SAMPLES:g} samples; "
                f"got {rate:g} Hz x {settings.duration:g} s = {samples:.3g}."
            )
    if not (math.isfinite(args.noise_tau) and args.noise_tau > 0.0):
        raise ValueError(
            "--noise-tau must be > 0 (the torque noise as a fraction of each joint's "
            f"torque std); got {args.noise_tau:g}."
        )
    robot = robot_from_args(args, "excite")
    if args.online_window is not None:
        _check_online_window(args, robot)  # before the (long) design
    rows = robot.rows_provider()
    limits = _limits(robot, args)
    say = (lambda *a: None) if args.quiet else print
    mid = 0.5 * (limits.lower + limits.upper)
    unchecked = "the URDF has no collision geometry"
    try:
        collision = SelfCollision.from_urdf(args.urdf, mid, robot, margins.collision)
    except MissingFileError as error:
        # A collision mesh the loader cannot find (package:// paths of another
        # workspace: the shipped TIAGo): the design goes on without the check.
        collision = None
        unchecked = f"its collision geometry cannot be loaded: {error.detail}"
    say(
        f"robot: {args.urdf} ({robot.num_joints} joints, "
        f"{robot.num_parameters} base parameters)"
    )
    say(
        f"limits: {'URDF + ' + args.limits if args.limits else 'URDF'}; margins: "
        f"position {_position_margins(robot, margins)}, velocity "
        f"{margins.velocity:.0%}, "
        f"effort {margins.effort:.0%}, collision {margins.collision:g} m"
    )
    if collision is None:
        say(f"self-collision: not checked ({unchecked})")
    else:
        ignored = f"; ignored (in contact at mid-range): {listed(collision.ignored)}"
        held = (
            "; closer than the margin at mid-range, held no closer than half "
            f"that: {listed(collision.held)}"
        )
        say(
            f"self-collision: {collision.num_geometries} collision geometries"
            f"{ignored if collision.ignored else ''}{held if collision.held else ''}"
        )
    start = time.perf_counter()
    design = design_excitation(
        rows.idim_rows,
        robot.base_values,
        limits,
        settings,
        margins,
        clearance_fn=collision,
    )
    elapsed = time.perf_counter() - start
    report = excitation_report(
        rows.idim_rows,
        design.trajectory,
        robot.base_values,
        robot.base_names,
        duration=settings.duration,
        rate=args.log_rate,
        noise_fraction=args.noise_tau,
        threshold_percent=WEAK_PERCENT,
    )
    periods = round(settings.duration * settings.base_frequency)
    say(
        f"trajectory: {periods} period(s) of {settings.period:g} s (f0 = "
        f"{settings.base_frequency:g} Hz), {settings.harmonics} harmonics (band "
        f"{settings.harmonics * settings.base_frequency:g} Hz), "
        f"{'starts at rest' if settings.rest_start else 'periodic, v(0) != 0'}"
    )
    say(
        f"condition number: {design.condition_number:.4g} (default random "
        f"trajectory, seed {settings.seed}: {design.baseline_condition_number:.4g}); "
        f"{design.iterations} SLSQP iterations, {elapsed:.1f} s"
    )
    if design.condition_number > design.baseline_condition_number:
        # The random start breaks these limits; the feasible design found is worse.
        stopped = "iteration limit" in design.message.lower()
        print(
            "dynid excite: warning: the design is worse conditioned than the random "
            "trajectory it is compared with, which does not keep these limits"
            + (
                f" (the optimiser stopped at --iterations {args.iterations})"
                if stopped
                else ""
            )
            + ": loosen --margin, or give more --iterations or --harmonics.",
            file=sys.stderr,
        )
    say("")
    width = max(16, *(len(name) for name in limits.joint_names))
    say(f"{'joint':<{width}} position  velocity  effort   (max % of the limit)")
    for j, name in enumerate(limits.joint_names):
        usage = [100 * design.usage[k][j] for k in ("position", "velocity", "effort")]
        say(f"{name:<{width}} {usage[0]:8.1f}  {usage[1]:8.1f}  {usage[2]:6.1f}")
    if math.isfinite(design.clearance):
        say(f"smallest self-collision clearance: {design.clearance:.3g} m")
    between = between_samples(design, limits.joint_names, margins)
    if between:
        print(f"dynid excite: {between}", file=sys.stderr)
    say("")
    _print_report(say, robot, design, report, args)
    if args.online_window is not None:
        _online(say, robot, design, args.online_window)
    sampled = SampledTrajectory.from_fourier(
        design.trajectory, robot.joint_names, settings.duration, args.sample_rate
    )
    write_trajectory(args.out, sampled)
    written = [f"{args.out} ({sampled.t.size} samples at {args.sample_rate:g} Hz)"]
    if args.json:
        write_coefficients(
            args.json,
            design.trajectory,
            robot.joint_names,
            settings.duration,
            _json_extra(args, robot, limits, margins, design, report),
        )
        written.append(args.json)
    if args.plot:
        _plot(args.plot, robot, limits, design, report)
        written.append(args.plot)
    say(f"\nwrote {', '.join(written)}")
    return 0


#: Relative excess over a margined limit below which the dense grid is not named
#: (the optimiser's own tolerance on the grid is 1e-6).
_EXCESS = 1e-4


def between_samples(design: Any, names: Any, margins: Any) -> str | None:
    """A note (or warning) when the dense grid exceeds the margined effort or clearance.

    The effort and the clearance are constrained on the optimisation grid; the
    design re-solves with tightened bounds where its 16x denser check finds them
    beyond the margins between the samples (the xArm7 had effort 80.07 % of
    joint2's limit and clearance 0.00982 m, with the default 20 % and 0.01 m). When
    the re-solves do not remove the excess, this says it.
    """
    effort = np.asarray(design.usage["effort"], dtype=float)
    allowed = 1.0 - margins.effort
    over = [
        f"the effort of {names[j]} reaches {100 * effort[j]:.2f} % of its limit "
        f"(--margin effort={margins.effort:g} keeps {100 * allowed:.4g} %)"
        for j in np.flatnonzero(np.isfinite(effort) & (effort > allowed + _EXCESS))
    ]
    clearance = float(design.clearance)
    if math.isfinite(clearance) and clearance < margins.collision - _EXCESS * max(
        margins.collision, 0.01
    ):
        over.append(
            f"the self-collision clearance falls to {clearance:.3g} m "
            f"(--margin collision={margins.collision:g} m)"
        )
    if not over:
        return None
    broken = bool(np.any(effort > 1.0)) or clearance < 0.0
    return (
        ("warning: " if broken else "note: ")
        + "between the samples of the optimisation grid (checked on a 16x denser "
        "grid, after re-solving with tightened bounds), "
        + "; ".join(over)
        + (
            ": the limits themselves are exceeded; raise --margin"
            if broken
            else ": the margins absorb it, the limits themselves hold; a larger "
            "--margin keeps the margins too"
        )
        + "."
    )


def _print_report(say, robot, design, report, args) -> None:
    relative = report.relative_std_percent
    names = robot.base_names
    finite = relative[np.isfinite(relative)]
    well = int(np.count_nonzero(relative <= WELL_EXCITED_PERCENT))
    say(
        f"predicted %σ of offline --weighted (τ noise {args.noise_tau:g} × each "
        "joint's torque std, "
        f"{args.log_rate:g} Hz, {report.num_samples} samples): median "
        f"{_percent(float(np.median(finite)))}, "
        f"well excited (%σ <= {WELL_EXCITED_PERCENT:g}): {well} of {len(names)}"
    )
    unexcitable = {names[i] for i in design.unexcitable}
    weak_names = [name for name in report.weak if name not in unexcitable]
    if weak_names:
        weak = ", ".join(
            f"{name} ({_percent(relative[names.index(name)])})" for name in weak_names
        )
        say(f"weakly excited (%σ > {WEAK_PERCENT:g}): {weak}")
    if report.zero:
        say(f"zero in the model (relative %σ undefined): {', '.join(report.zero)}")
    if design.unexcitable:
        say(
            "not excitable by any motion (zero regressor column; left out of the "
            f"condition numbers): {', '.join(names[i] for i in design.unexcitable)}"
        )
    terms = " ".join(f"{c:+.2f} {n}" for n, c in report.weakest)
    say(f"weakest direction: {terms}")


def _check_online_window(args: argparse.Namespace, robot: Any) -> None:
    """Checks ``--online-window`` before the design.

    A valid window for the designed band, within the experiment and the on-line
    identifier's window memory ceiling.
    """
    from drake_dynid.core.online import NOMINAL_BANK_TIME_STEP
    from drake_dynid.core.online_checks import MAX_WINDOW_BYTES, check_values
    from drake_dynid.core.rows import num_channels

    window, band = args.online_window, args.harmonics * args.f0
    names = {"window": "--online-window", "bandwidth": "--harmonics x --f0"}
    check_values({"window": window, "bandwidth": band}, owner=None, names=names)
    size = (
        (window / NOMINAL_BANK_TIME_STEP + 1.0)
        * num_channels(robot.num_joints, robot.num_parameters)
        * 8.0
    )
    if window > args.duration or size > MAX_WINDOW_BYTES:
        raise ValueError(
            f"--online-window must be <= --duration {args.duration:g} s and keep the "
            f"window's samples within {MAX_WINDOW_BYTES / 2**30:g} GiB; got "
            f"{window:g} s ({size / 2**30:.3g} GiB)."
        )


def _online(say, robot, design, window: float) -> None:
    from drake_dynid.core.excite_report import modulated_condition_numbers
    from drake_dynid.diagrams import OnlineSettings

    trajectory = design.trajectory
    band = trajectory.harmonics * trajectory.base_frequency / (2 * math.pi)
    settings = OnlineSettings(window=window, bandwidth=band)
    bank = settings.bank()
    starts = trajectory.period * np.arange(4) / 4
    conditions = modulated_condition_numbers(
        functools.partial(robot.model_rows, "lagrangian"),
        robot.idim_rows,
        robot.base_values,
        trajectory,
        bank,
        starts,
    )
    say(
        f"on-line window {window:g} s (Lagrangian model, {bank.num_functions} "
        f"modulating functions up to {band:g} Hz): condition number "
        f"{conditions.min():.4g}-{conditions.max():.4g} over {len(starts)} window "
        "positions"
    )


def _json_extra(args, robot, limits, margins, design, report) -> dict:
    def number(value: float) -> float | None:
        return float(value) if math.isfinite(value) else None

    return {
        "urdf": str(args.urdf),
        "seed": int(args.seed),
        "rest_start": bool(args.rest_start),
        "condition_number": design.condition_number,
        "baseline_condition_number": design.baseline_condition_number,
        "margins": dataclasses.asdict(margins),
        "limits": {
            name: {
                key: number(getattr(limits, key)[j])
                for key in ("lower", "upper", "velocity", "acceleration", "effort")
            }
            for j, name in enumerate(limits.joint_names)
        },
        # A joint without a limit of that kind (acceleration, usually): null.
        "usage": {k: _usage(limits, k, v) for k, v in design.usage.items()},
        "predicted": [
            {
                "name": name,
                "value": float(value),
                "std": float(std),
                "relative_std_percent": number(rel),
            }
            for name, value, std, rel in zip(
                robot.base_names,
                robot.base_values,
                report.std,
                report.relative_std_percent,
                strict=True,
            )
        ],
        "noise_tau": float(args.noise_tau),
        "log_rate": float(args.log_rate),
    }


def _plot(path, robot, limits, design, report) -> None:
    from drake_dynid.commands._report import matplotlib_pyplot

    plt = matplotlib_pyplot()
    trajectory = design.trajectory
    t = np.linspace(0.0, trajectory.period, 400)
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    mid = 0.5 * (limits.lower + limits.upper)
    half = 0.5 * (limits.upper - limits.lower)
    figure, axes = plt.subplots(4, 1, figsize=(9, 10), constrained_layout=True)
    panels = [
        ((q - mid) / half, "position (-1, 1 = limits)"),
        (v / limits.velocity, "velocity / limit"),
        (tau / limits.effort, "torque / effort limit"),
    ]
    for axis, (values, label) in zip(axes, panels, strict=False):
        axis.plot(t, values)
        axis.axhline(1.0, color="k", lw=0.8)
        axis.axhline(-1.0, color="k", lw=0.8)
        axis.set_ylabel(label)
        axis.set_xlim(0.0, trajectory.period)
    axes[0].legend(limits.joint_names, fontsize=7, ncol=4)
    axes[2].set_xlabel("time in one period [s]")
    relative = np.where(
        np.isfinite(report.relative_std_percent), report.relative_std_percent, np.nan
    )
    relative[list(design.unexcitable)] = np.nan
    axes[3].bar(np.arange(len(robot.base_names)), relative)
    axes[3].set_yscale("log")
    axes[3].axhline(WEAK_PERCENT, color="r", lw=0.8)
    axes[3].set_xticks(np.arange(len(robot.base_names)))
    axes[3].set_xticklabels(robot.base_names, rotation=90, fontsize=6)
    axes[3].set_ylabel("predicted %σ")
    figure.suptitle(f"exciting trajectory, cond = {design.condition_number:.3g}")
    figure.savefig(path, dpi=110)
    plt.close(figure)


def _usage(limits: Any, kind: str, values: Any) -> list[float | None]:
    """The usage of ``kind`` per joint, None where the joint has no such limit."""
    bound = getattr(limits, kind, None)
    return [
        None if bound is not None and not math.isfinite(float(bound[j])) else float(u)
        for j, u in enumerate(values)
    ]
