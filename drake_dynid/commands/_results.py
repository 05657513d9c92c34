"""The model a results file was identified with (``dynid validate``; not a subcommand).

A results file (``dynid offline/identify --json``, or ``dynid params --json`` for the
URDF's a-priori model) records the friction kinds, identified joints, locks, rotor
inertia, drive file and Coulomb dead-zone widths in ``settings``; ``dynid validate``
rebuilds the same model from them, command-line options winning (a lock of a joint
the URDF fixes, as the URDF ``--urdf-out`` wrote does, is left out: it is there
already).
"""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from drake_dynid.commands._arguments import parse_dead_zone, parse_friction
from drake_dynid.core._validate import listed
from drake_dynid.core.friction import FRICTION_KINDS


def _friction(args: argparse.Namespace, document: Mapping[str, Any]) -> Sequence[str]:
    if args.friction is not None:
        return parse_friction(args.friction)
    settings = document.get("settings")
    if isinstance(settings, dict) and isinstance(settings.get("friction"), list):
        kinds = settings["friction"]
        if not all(kind in FRICTION_KINDS for kind in kinds):
            raise ValueError(
                f"results file {args.params}: settings.friction must list names "
                f"among {', '.join(FRICTION_KINDS)}; got {kinds!r}: give --friction."
            )
        return tuple(kinds)
    return ("viscous", "coulomb")


def _number(
    args: argparse.Namespace, field: str, value: Any, unit: str, signed: bool
) -> float:
    """A finite number of the results file's ``settings`` (>= 0 unless ``signed``)."""
    import math

    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not ok or not math.isfinite(value) or (not signed and value < 0):
        raise ValueError(
            f"results file {args.params}: settings.{field} must be a number"
            f"{'' if signed else ' >= 0'} [{unit}]; got {value!r}."
        )
    return float(value)


def _from_results(document: Mapping[str, Any], key: str) -> Any:
    """``settings[key]`` of a results file, else its top-level ``key``, else None."""
    settings = document.get("settings")
    if isinstance(settings, dict) and key in settings:
        return settings[key]
    return document.get(key)


def results_drive(args: argparse.Namespace, drive: str) -> str:
    """The drive file a results file names (``settings.drive``), found on disk.

    The path as recorded (absolute since this was written; older files hold it as
    given, relative to the folder the fit ran in), else relative to the results
    file's folder, else a file of its name beside the results file (both moved
    together). A drive file that cannot be found is an error
    (never dropped: the log would be read without the drive's units and
    columns); no output of the command may overwrite it.

    Raises:
        ValueError: naming the results file, the drive file and ``--drive``.
    """
    from drake_dynid.commands._paths import check_output_paths

    recorded = Path(drive)
    beside = Path(args.params).parent
    candidates = [recorded, beside / recorded.name]
    if not recorded.is_absolute():
        candidates.insert(1, beside / recorded)
    for candidate in candidates:
        if candidate.is_file():
            check_output_paths(
                args, inputs={"the results file's drive file": str(candidate)}
            )
            return str(candidate)
    raise ValueError(
        f"results file {args.params}: its drive file {drive} (settings.drive) is not "
        f"found from {Path.cwd()} nor next to the results file; give --drive FILE."
    )


def results_robot(args: argparse.Namespace, document: Mapping[str, Any]) -> Any:
    """The model of the results file: its joints, locks, rotor inertia, drive.

    Options given on the command line win; the others come from the results file
    (``dynid offline/identify --json`` settings, or ``dynid params --json``).
    """
    from drake_dynid.commands._arguments import robot_from_args

    # The notes name the command running (dynid payload --params reads one too).
    command = getattr(args, "command", None) or "validate"
    parsed: list[tuple[dict[str, str], set[str]]] = []

    def urdf_joints() -> tuple[dict[str, str], set[str]]:
        if not parsed:  # the URDF read once, when needed
            parsed.append(_urdf_joints(args.urdf))
        return parsed[0]

    joints = _from_results(document, "joints")
    locked = _from_results(document, "locked")
    options: dict[str, Any] = {"friction": _friction(args, document)}
    if args.joints is None and isinstance(joints, list):
        options["joints"] = [str(name) for name in joints]
    if args.lock is None and isinstance(locked, dict):
        # settings.locked lists every joint held still, the mimic joints of locked
        # leaders too, which cannot be locked on their own: they follow. A joint
        # the URDF fixes is locked already (--urdf-out writes the fit's locked
        # joints as fixed joints at their positions): validating the fit on the
        # URDF it wrote needs no --lock.
        types, followers = urdf_joints()
        fixed = {name for name, kind in types.items() if kind == "fixed"}
        options["locked"] = {
            str(k): _number(args, f"locked.{k}", v, "rad or m", signed=True)
            for k, v in locked.items()
            if str(k) not in followers | fixed
        }
    if not args.rotor_inertia:
        options["rotor_inertia"] = bool(_from_results(document, "rotor_inertia"))
    width = _from_results(document, "coulomb_width")
    if not getattr(args, "coulomb_width", 0.0) and width is not None:
        # 0: sign(v); a NaN, negative or text width is named, not ignored.
        width = _number(args, "coulomb_width", width, "rad/s or m/s", signed=False)
        if width > 0:
            options["coulomb_width"] = width
    drive = _from_results(document, "drive")
    if not args.drive and isinstance(drive, str) and drive:
        options["drive"] = results_drive(args, drive)
    try:
        return robot_from_args(args, command, **options)
    except ValueError as error:
        if "joints" not in options and "locked" not in options:
            raise
        failure = str(error)
    named = [*options.get("joints", ()), *options.get("locked", {})]
    # Without the file's joints and locks: the command line's own errors (a
    # --lock typo) are raised as they are, not blamed on the results file.
    options.pop("joints", None)
    options.pop("locked", None)
    if named and set(named) - set(urdf_joints()[0]):
        # The file's joints are not this URDF's (another robot): the default
        # joints, and not the file's drive file, which is that robot's (found by
        # a review: a TIAGo fit on the iiwa failed as "drive file tiago.toml:
        # unknown joint 'torso_lift_joint'", no drive file having been given);
        # the parameter check then names the mismatch.
        if not args.drive:
            options.pop("drive", None)
        return robot_from_args(args, command, **options)
    robot = robot_from_args(args, command, **options)
    if named:
        raise ValueError(
            f"results file {args.params}: its joints and locks (settings.joints, "
            f"settings.locked) do not apply to {args.urdf}: {failure} Give "
            "--joints/--lock."
        )
    return robot


def drive_mismatch(document: Mapping[str, Any], robot: Any) -> str | None:
    """A note when the drive chain differs from the one the results were fitted with.

    Compares each motor's row (gear ratios, coupling) and torque constant with
    the results file's ``drive_chain`` (``settings.drive_chain``): another drive
    file given with ``--drive``, or the recorded one edited since, converts the
    log otherwise than the fit's did (a gear ratio of 50 for 100 halves that
    joint's torques), which the errors alone do not tell apart from a bad model.
    None when they agree or the results file records no chain.
    """
    recorded = _from_results(document, "drive_chain")
    chain = getattr(robot, "drive", None)
    if not isinstance(recorded, dict) or chain is None:
        return None

    def number(value: Any) -> str:  # a hand-edited file may hold anything
        plain = isinstance(value, int | float) and not isinstance(value, bool)
        return f"{value:g}" if plain else repr(value)

    def described(motor: Mapping[str, Any]) -> str:
        row = motor.get("joints")
        joints = (
            ", ".join(f"{j} = {number(r)}" for j, r in row.items())
            if isinstance(row, dict)
            else repr(row)
        )
        constant = motor.get("torque_constant")
        return f"{{{joints}}}" + (
            "" if constant is None else f" k_t {number(constant)}"
        )

    motors = recorded.get("motors")
    fitted = {
        str(m.get("name")): described(m)
        for m in (motors if isinstance(motors, list) else ())
        if isinstance(m, dict)
    }
    now = {str(m["name"]): described(m) for m in chain.summary()["motors"]}
    changed = [
        f"{name} {now.get(name, 'none')} (fitted: {fitted.get(name, 'none')})"
        for name in dict.fromkeys([*fitted, *now])
        if fitted.get(name) != now.get(name)
    ]
    if not changed:
        return None
    return (
        f"the {chain.source}'s motors differ from those the parameters were "
        f"fitted with (settings.drive_chain): {listed(changed, sep='; ')}. The log "
        "is "
        "converted with the drive file given, the parameters are the fit's"
    )


def _urdf_joints(urdf: Any) -> tuple[dict[str, str], set[str]]:
    """The URDF's ``{joint: type}`` and its ``<mimic>`` joints, of one parse.

    None of either when it cannot be read, no mimic joint when a ``<mimic>`` is
    malformed: the model's load says why.
    """
    from drake_dynid.urdf import read_urdf_joints

    try:
        types, mimic = read_urdf_joints(urdf)
    except (OSError, ValueError):
        return {}, set()
    return types, set(mimic or ())


def results_sign(
    args: argparse.Namespace, document: Mapping[str, Any], robot, log
) -> Any:
    """The Coulomb sign: ``--dead-zone``, else the results file's widths."""
    from drake_dynid.commands._arguments import apply_dead_zone
    from drake_dynid.core.friction import DeadZoneSign

    if args.dead_zone is not None:
        parse_dead_zone(args.dead_zone)
        return apply_dead_zone(args, robot, log)
    widths = _from_results(document, "coulomb_dead_zone")
    if not isinstance(widths, dict) or "coulomb" not in robot.friction:
        return robot
    missing = [name for name in robot.joint_names if name not in widths]
    if missing:
        raise ValueError(
            f"results file {args.params}: settings.coulomb_dead_zone has no width "
            f"for {listed(missing)}; give --dead-zone."
        )
    field = "coulomb_dead_zone"
    return robot.with_sign(
        DeadZoneSign(
            tuple(
                _number(args, f"{field}.{name}", widths[name], "rad/s or m/s", False)
                for name in robot.joint_names
            )
        )
    )
