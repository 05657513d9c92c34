"""Options and inputs shared by several ``dynid`` subcommands (not a subcommand)."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any


def add_friction_argument(parser: argparse.ArgumentParser) -> None:
    """Adds ``--friction`` (the friction columns) and ``--coulomb-width`` (its law)."""
    parser.add_argument(
        "--friction",
        default="viscous,coulomb",
        help=(
            "comma-separated friction columns per joint among viscous, coulomb, "
            "offset, or 'none' (default: viscous,coulomb)"
        ),
    )
    parser.add_argument(
        "--coulomb-width",
        type=float,
        default=0.0,
        metavar="W",
        help=(
            "smooth Coulomb friction: the Coulomb column is tanh(v/W) instead of "
            "sign(v), W in rad/s (or m/s); 0 (default): sign(v)"
        ),
    )


def parse_friction(text: str) -> tuple[str, ...]:
    """``"viscous,coulomb"`` -> ``("viscous", "coulomb")``; ``"none"`` -> ``()``."""
    if text.strip().lower() in ("", "none"):
        return ()
    return tuple(item.strip() for item in text.split(",") if item.strip())


def add_joint_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds ``--joints`` (the identified joints) and ``--lock`` (locked positions)."""
    parser.add_argument(
        "--joints",
        metavar="A,B,...",
        help=(
            "comma-separated joints to identify (default: every movable joint that "
            "is not a mimic joint); every other movable joint is locked, at 0 "
            "unless --lock gives its position; mimic joints follow their leader"
        ),
    )
    parser.add_argument(
        "--lock",
        metavar="NAME=VALUE,...",
        help=(
            "positions [rad or m] of locked joints, e.g. head_1_joint=0.2,"
            "head_2_joint=-0.1; without --joints, the joints not locked are "
            "identified"
        ),
    )


def parse_joints(text: str | None) -> tuple[str, ...] | None:
    """``"a, b"`` -> ``("a", "b")``; None or blank -> None (every joint).

    Raises:
        ValueError: an empty name (``"a,,b"``).
    """
    if text is None or not text.strip():
        return None
    names = tuple(item.strip() for item in text.split(","))
    if any(not name for name in names):
        raise ValueError(f"--joints must be comma-separated joint names; got {text!r}.")
    return names


def parse_locked(text: str | None) -> dict[str, float]:
    """``"a=0.2,b=-1"`` -> ``{"a": 0.2, "b": -1.0}`` [rad or m]; None -> ``{}``.

    Raises:
        ValueError: an item without ``=``, an empty name, a value that is not a
            finite number, or a joint given twice.
    """
    out: dict[str, float] = {}
    if text is None or not text.strip():
        return out
    for item in text.split(","):
        name, sep, value = item.partition("=")
        name = name.strip()
        try:
            position = float(value)
        except ValueError:
            position = math.nan
        if not sep or not name or not math.isfinite(position):
            raise ValueError(
                "--lock must be NAME=VALUE pairs with finite values [rad or m] "
                f"separated by commas; got {item.strip()!r}."
            )
        if name in out:
            raise ValueError(f"--lock gives joint {name!r} twice.")
        out[name] = position
    return out


def robot_from_args(args: argparse.Namespace, command: str, **kwargs: Any) -> Any:
    """Builds the ``RobotModel`` of ``args`` and prints its notes on stderr.

    Reads ``args.urdf``, ``args.friction``, ``args.coulomb_width``, ``args.joints``
    and ``args.lock`` (each optional on ``args``; see :func:`add_friction_argument` and
    :func:`add_joint_arguments`) and ``args.rotor_inertia`` when present. Each note
    of the load (joints treated as actuated, Drake's parser warnings summarised,
    an unclear rank decision) is one line ``dynid COMMAND: note: ...`` on stderr.

    Args:
        args: the parsed arguments.
        command: the subcommand name, for the notes.
        **kwargs: further ``RobotModel.from_urdf`` arguments (they win over
            ``args``).

    Raises:
        ValueError: bad ``--joints``/``--lock`` syntax, or the model's errors (an
            unknown joint names the available ones).
    """
    from drake_dynid.robot import RobotModel

    options: dict[str, Any] = {
        "friction": parse_friction(getattr(args, "friction", "viscous,coulomb")),
        "joints": parse_joints(getattr(args, "joints", None)),
        "locked": parse_locked(getattr(args, "lock", None)),
        "coulomb_width": getattr(args, "coulomb_width", 0.0),
    }
    if hasattr(args, "rotor_inertia"):
        options["rotor_inertia"] = bool(args.rotor_inertia)
    options.update(kwargs)
    robot = RobotModel.from_urdf(args.urdf, **options)
    for note in robot.notes:
        print(f"dynid {command}: note: {note}", file=sys.stderr)
    return robot


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments shared by ``dynid identify`` and ``dynid offline``."""
    parser.add_argument("log", metavar="LOG.csv", help="the robot log (CSV)")
    parser.add_argument(
        "--urdf", required=True, metavar="MODEL.urdf", help="the robot's URDF file"
    )
    add_friction_argument(parser)
    add_joint_arguments(parser)
    parser.add_argument(
        "--resample",
        action="store_true",
        help="accept a non-uniformly sampled log by linear interpolation onto the "
        "grid of its median step (off by default: it changes the data)",
    )
    parser.add_argument("--json", metavar="FILE", help="write a JSON summary to FILE")
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="print nothing on stdout (log warnings and errors still go to stderr)",
    )


def load_robot_and_log(args: argparse.Namespace, command: str):
    """Loads the URDF model and the log; prints the reader's warnings on stderr."""
    from drake_dynid.logs import read_log

    robot = robot_from_args(args, command)
    log = read_log(args.log, robot.joint_names, resample=args.resample)
    for warning in log.warnings:
        print(f"dynid {command}: warning: log {args.log}: {warning}", file=sys.stderr)
    return robot, log
