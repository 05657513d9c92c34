"""``dynid replay``: a log or a trajectory in Drake's Meshcat viewer."""

from __future__ import annotations

import argparse
import contextlib
import sys
from typing import Any

import numpy as np

from drake_dynid.commands._arguments import (
    DRIVE_METAVAR,
    URDF_HELP,
    add_joint_arguments,
    add_log_argument,
    add_time_unit_argument,
    bag_options,
    check_topic,
    drive_argument,
    log_files,
    read_robot_log,
    robot_from_args,
    urdf_argument,
)
from drake_dynid.commands._paths import check_output_paths

HELP = "replay a log or a trajectory in Drake's Meshcat viewer (browser)"
DESCRIPTION = (
    "Replays the joint positions of a robot log (the plain CSV format, several "
    "files, a drive file's raw columns with --drive, or a ROS bag of "
    "sensor_msgs/JointState) or of a trajectory file "
    "(dynid excite's CSV: t, q_<joint>, v_<joint>; or its JSON coefficients) as an "
    "animation in Drake's Meshcat viewer: prints the URL of the live page (served "
    "on localhost while the command runs), writes a standalone copy (--html, "
    "default FILE.meshcat.html next to the first file) and exits; --wait keeps "
    "the live page until Enter or Ctrl-C. A URDF without <visual> geometry is "
    "shown by its links' inertia ellipsoids."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid replay`` arguments."""
    parser.add_argument(
        "urdf", metavar="MODEL.urdf", type=urdf_argument, help=URDF_HELP
    )
    add_log_argument(parser)
    parser.add_argument(
        "--drive",
        metavar=DRIVE_METAVAR,
        type=drive_argument,
        help="drive file (docs/DRIVE.md; or a packaged one's name: tiago) of a raw "
        "log: its columns and units",
    )
    add_joint_arguments(parser, "replay from the log", "replayed")
    add_time_unit_argument(parser)
    parser.add_argument(
        "--fps",
        type=float,
        default=32.0,
        metavar="HZ",
        help="animation frames per second of motion (default 32)",
    )
    parser.add_argument(
        "--html",
        metavar="PAGE.html",
        help="write the standalone page here (default: FILE.meshcat.html)",
    )
    parser.add_argument(
        "--wait",
        action="store_true",
        help="keep the live page served until Enter or Ctrl-C",
    )
    parser.add_argument("--quiet", action="store_true", help="print only the URL")


def _is_trajectory(path: str, joint_names) -> bool:
    """A trajectory file: JSON coefficients, or a CSV with every v_<joint>."""
    if path.lower().endswith(".json"):
        return True
    try:
        with open(path, encoding="utf-8") as stream:
            header = {cell.strip() for cell in stream.readline().split(",")}
    except OSError:
        return False
    return all(f"v_{name}" in header for name in joint_names)


def _positions_only(path: str, robot: Any) -> bool:
    """A plain log with t and every q_<joint> but not every tau_<joint>."""
    from drake_dynid.log_table import read_header

    try:
        with open(path, "rb") as stream:
            header = set(read_header(path, stream))
    except (OSError, ValueError):
        return False  # the reader names the problem
    names = robot.joint_names
    return (
        "t" in header
        and all(f"q_{name}" in header for name in names)
        and not all(f"tau_{name}" in header for name in names)
    )


def _read_positions(path: str, robot: Any, time_unit: str | None) -> Any:
    """A log's t and q, with the reader's time grid and repairs (zero torques).

    Its torques are not needed to show the motion; resampled when not uniform:
    an animation only needs poses on the grid. ``time_unit``: ``--time-unit``.
    """
    from drake_dynid.logs import read_log

    log = read_log(
        path,
        robot.joint_names,
        resample=True,
        torques=False,
        time_unit=time_unit,
    )
    for warning in log.warnings:  # not the constant-column check: τ is filled in
        print(f"dynid replay: warning: log {path}: {warning}", file=sys.stderr)
    return log


def _held_over_bad_samples(q: np.ndarray) -> np.ndarray:
    """Q with each bad sample (a non-finite cell) shown at the last good pose.

    The identification skips bad samples; an animation needs a pose at every
    frame (the first good one before any). A note says how many were held.
    """
    bad = ~np.isfinite(q).all(axis=1)
    if not bad.any():
        return q
    good = np.flatnonzero(~bad)
    if good.size == 0:
        raise ValueError("the log has no sample with finite positions to show.")
    source = np.maximum.accumulate(np.where(bad, 0, np.arange(q.shape[0])))
    source[: good[0]] = good[0]
    print(
        f"dynid replay: note: {int(bad.sum())} bad sample(s) shown at the last good "
        "pose.",
        file=sys.stderr,
    )
    return q[source]


def run(args: argparse.Namespace) -> int:
    """Replays the file(s) in Meshcat. Returns 0."""
    from drake_dynid.commands._options import option_message
    from drake_dynid.commands.simulate import truth_path
    from drake_dynid.meshcat_replay import replay_in_meshcat
    from drake_dynid.ros_bag import is_bag
    from drake_dynid.trajectory_file import read_trajectory

    files = log_files(args)
    if args.html is None:
        args.html = str(truth_path(files[0], ".meshcat.html"))
    check_output_paths(args)
    check_topic(args)
    robot = robot_from_args(args, "replay", rotor_inertia=True)
    say = (lambda *a: None) if args.quiet else print
    bag = any(is_bag(path) for path in files)  # read by read_robot_log
    if (
        len(files) == 1
        and not args.drive
        and not bag
        and _is_trajectory(files[0], robot.joint_names)
    ):
        if args.time_unit not in (None, "s"):
            raise ValueError(
                f"--time-unit {args.time_unit}: {files[0]} is a trajectory file, "
                "whose times are seconds; the option is for logs."
            )
        motion = read_trajectory(files[0], robot.joint_names)
        kind = "trajectory"
    elif (
        len(files) == 1
        and not args.drive
        and not bag
        and _positions_only(files[0], robot)
    ):
        motion = _read_positions(files[0], robot, args.time_unit)
        kind = "log (positions)"
    else:
        motion = read_robot_log(
            files,
            robot,
            resample=False,
            command="replay",
            time_unit=args.time_unit,
            torques_optional=True,  # only the positions are shown
            topic=args.topic,
            options=bag_options(args),
        )
        kind = "log"
    q = _held_over_bad_samples(np.asarray(motion.q, dtype=float))
    try:
        replay = replay_in_meshcat(
            args.urdf,
            motion.t,
            q,
            robot.joint_names,
            html=args.html,
            frames_per_second=args.fps,
        )
    except ValueError as error:
        names = {"frames_per_second": "--fps"}
        raise ValueError(
            option_message(str(error), names, ("replay_in_meshcat",))
        ) from None
    for note in replay.notes:
        print(f"dynid replay: note: {note}", file=sys.stderr)
    say(
        f"{kind} {args.log}: {motion.t.size} samples over "
        f"{motion.t[-1] - motion.t[0]:g} s; {replay.frames} frames at {args.fps:g} "
        f"per second; standalone page {replay.html}"
    )
    print(f"Meshcat: {replay.url}")
    if args.wait:
        print("Meshcat: serving the live page; press Enter (or Ctrl-C) to exit")
        with contextlib.suppress(EOFError, KeyboardInterrupt):
            input()
    return 0
