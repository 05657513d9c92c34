"""Options and inputs shared by several ``dynid`` subcommands (not a subcommand)."""

from __future__ import annotations

import argparse
import sys


def add_friction_argument(parser: argparse.ArgumentParser) -> None:
    """Adds ``--friction`` (the friction columns per joint)."""
    parser.add_argument(
        "--friction",
        default="viscous,coulomb",
        help=(
            "comma-separated friction columns per joint among viscous, coulomb, "
            "offset, or 'none' (default: viscous,coulomb)"
        ),
    )


def parse_friction(text: str) -> tuple[str, ...]:
    """``"viscous,coulomb"`` -> ``("viscous", "coulomb")``; ``"none"`` -> ``()``."""
    if text.strip().lower() in ("", "none"):
        return ()
    return tuple(item.strip() for item in text.split(",") if item.strip())


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments shared by ``dynid identify`` and ``dynid offline``."""
    parser.add_argument("log", metavar="LOG.csv", help="the robot log (CSV)")
    parser.add_argument(
        "--urdf", required=True, metavar="MODEL.urdf", help="the robot's URDF file"
    )
    add_friction_argument(parser)
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
    from drake_dynid.robot import RobotModel

    robot = RobotModel.from_urdf(args.urdf, friction=parse_friction(args.friction))
    log = read_log(args.log, robot.joint_names, resample=args.resample)
    for warning in log.warnings:
        print(f"dynid {command}: warning: log {args.log}: {warning}", file=sys.stderr)
    return robot, log
