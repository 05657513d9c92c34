"""``dynid bag2csv``: a ROS bag's JointState messages as a CSV log."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
from collections.abc import Iterator
from typing import Any

from drake_dynid.commands._arguments import (
    DRIVE_METAVAR,
    URDF_HELP,
    bag_options,
    drive_argument,
    parse_joints,
    robot_from_args,
    urdf_argument,
)
from drake_dynid.commands._paths import check_output_paths

HELP = "write a ROS bag's sensor_msgs/JointState messages as a CSV log"
DESCRIPTION = (
    "Writes the sensor_msgs/JointState messages of a ROS bag (a ROS 1 .bag; a ROS 2 "
    "bag folder, or its .db3/.mcap file) as a log in the plain CSV format: t (the "
    "header stamps: integer nanoseconds since the epoch; the receive times when "
    "every stamp is 0, or with --stamps receive), q_<joint> (position[]) and "
    "tau_<joint> (effort[], when the messages have efforts), one row per message, "
    "row 2 the first. It is the file the other commands read when given the bag "
    "(their messages name its rows); "
    "with a drive file they read the drive file's [log] columns instead, in its "
    "time unit: give --drive with the command's --urdf (and --joints, --lock) to "
    "write those, the file the command then reads as it reads the bag. Messages "
    "without every joint (another publisher on the topic) are skipped, with a "
    "note. --from and --to read a bag time range only (seconds after the bag's "
    "first message, in receive time): the other messages are not read, so that "
    "each side of a header clock set back, which the error names with the "
    "commands to run, can be exported. Needs the rosbags package (pip install "
    "'drake_dynid[ros]')."
)


def seconds_argument(text: str) -> float:
    """A bag time of ``--from`` / ``--to`` [s]: a finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(
            f"{text!r}: seconds of bag time after the bag's first message, a "
            "finite number >= 0"
        )
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid bag2csv`` arguments."""
    parser.add_argument("bag", metavar="BAG", help="the ROS bag")
    parser.add_argument(
        "--out",
        required=True,
        metavar="LOG.csv",
        help="the CSV log to write (-: standard output)",
    )
    parser.add_argument(
        "--topic",
        metavar="NAME",
        help="the sensor_msgs/JointState topic (default: the bag's one topic of "
        "that type)",
    )
    parser.add_argument(
        "--joints",
        metavar="J1,J2,...",
        help="the joints written, in this order (default: the joints of the "
        "topic's most frequent message, in its order); with --drive, the "
        "command's --joints: the joints whose drive columns are written",
    )
    parser.add_argument(
        "--drive",
        metavar=DRIVE_METAVAR,
        type=drive_argument,
        help="write the columns of this drive file's [log] table (its time column "
        "and unit, e.g. tiago's '- <joint>_position' and '- <joint>_effort' in "
        "seconds) instead of the plain format: the export that the commands read "
        "when given the bag with this drive file; needs --urdf",
    )
    parser.add_argument(
        "--urdf",
        metavar="MODEL.urdf",
        type=urdf_argument,
        help=f"with --drive: {URDF_HELP}, whose joints the drive file's motors drive",
    )
    parser.add_argument(
        "--lock",
        metavar="NAME=VALUE,...",
        help="with --drive: the command's --lock (locked joints' positions)",
    )
    parser.add_argument(
        "--stamps",
        choices=("header", "receive"),
        default="header",
        help="the time t of a message: its header.stamp (default; the receive "
        "time when every stamp is 0), or the bag's receive time (for a bag "
        "whose header clock was set back, e.g. re-synchronised by NTP)",
    )
    parser.add_argument(
        "--from",
        dest="start",
        type=seconds_argument,
        metavar="S",
        help="read only the messages received at or after S seconds of bag time "
        "(the receive time after the bag's first message, any topic; as 'ros2 bag "
        "info' and 'rosbag info' count it): the others are not read at all (one "
        "side of a header clock set back, which the error names with these "
        "values)",
    )
    parser.add_argument(
        "--to",
        dest="stop",
        type=seconds_argument,
        metavar="S",
        help="read only the messages received before S seconds of bag time "
        "(--from's; 0 <= --from < --to, both within the bag; the bag's length: "
        "to its end, the last message too)",
    )
    parser.add_argument("--quiet", action="store_true", help="print nothing on stdout")


def run(args: argparse.Namespace) -> int:
    """Writes the CSV log. Returns 0.

    SIGTERM from the start on is Ctrl-C's interruption (exit 1, the export's
    incomplete line when rows were written: :func:`_terminated_as_interrupted`).
    """
    with _terminated_as_interrupted():
        return _run(args)


def _run(args: argparse.Namespace) -> int:
    from drake_dynid.ros_bag import export_bag

    args.log = args.bag  # an input: --out is checked against it
    check_output_paths(args)
    if args.drive is None:
        for option, value in (("--urdf", args.urdf), ("--lock", args.lock)):
            if value is not None:
                raise ValueError(
                    f"{option} is for --drive (the drive file's columns are "
                    "resolved against the robot's joints); without --drive the "
                    "plain format needs no robot: leave it out."
                )
        joints = parse_joints(args.joints)
        time, unit = "t", None

        def columns(names: tuple[str, ...], efforts: bool) -> list[str]:
            out = [f"q_{name}" for name in names]
            return out + [f"tau_{name}" for name in names] * efforts

    else:
        from drake_dynid.commands._arguments import bag_layout

        if args.urdf is None:
            raise ValueError(
                f"--drive {args.drive} needs --urdf (with the command's --joints "
                "and --lock): the drive file's motors and columns are resolved "
                "against the robot's joints."
            )
        layout = bag_layout(robot_from_args(args, "bag2csv"), args.bag)
        joints, time, unit = layout.joints, layout.time, layout.time_unit

        def columns(names: tuple[str, ...], efforts: bool) -> list[str]:
            return [*layout.positions, *layout.torques * efforts]

    done = export_bag(
        args.bag,
        args.out,
        joints,
        columns,
        topic=args.topic,
        time=time,
        time_unit=unit,
        stamps=args.stamps,
        span=(args.start, args.stop),
        options=bag_options(args),
    )
    names = done.joint_names
    for note in done.notes:
        print(f"dynid bag2csv: note: {note}", file=sys.stderr)
    if not done.efforts:
        print(
            f"dynid bag2csv: note: the messages on {done.topic} carry no effort[]: "
            "no torque column written.",
            file=sys.stderr,
        )
    if not args.quiet:
        from drake_dynid.core._validate import listed

        print(
            f"wrote {args.out}: {done.rows} messages of {done.topic}, "
            f"joints {listed(names)}"
        )
    return 0


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised as Ctrl-C's interruption (:func:`_terminated_as_interrupted`).

    A subclass, not KeyboardInterrupt itself: CPython marks a KeyboardInterrupt
    that leaves code run from a string (``exec`` of text: a dataclass's or
    namedtuple's methods being made, an import's) as unhandled even when it is
    caught after, and ``python -m drake_dynid.cli`` then ended by SIGINT (-2)
    after printing 'interrupted' and returning 1; the check is on the exact type.
    """


@contextlib.contextmanager
def _terminated_as_interrupted() -> Iterator[None]:
    """SIGTERM raised as KeyboardInterrupt (Ctrl-C's, :class:`Terminated`) inside.

    Python's default SIGTERM ends the process at once: an export to standard
    output kept its whole rows and no incomplete-export line (read as the
    whole bag), a file's temporary copy was left beside it. Interrupted, the
    export ends with that line, the temporary file is removed (exit 1). Raised
    once (a second SIGTERM while it unwinds is ignored). The handler before
    is restored after, also when the signal lands while it is restored (then
    raised after); outside the main thread, or over a handler that is not
    Python's (``signal.getsignal`` None), nothing is set. SIGKILL cannot be
    caught.
    """
    import signal
    import threading

    raised: list[int] = []

    def interrupt(signum: int, frame: Any) -> None:
        if not raised:
            raised.append(signum)
            raise Terminated("terminated (SIGTERM)")

    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGTERM) if main else None
    if before is None:
        yield
        return
    try:
        # Inside the try: a signal raised as soon as the handler is set is
        # still followed by the restore.
        signal.signal(signal.SIGTERM, interrupt)
        yield
    finally:
        late: Terminated | None = None
        for _ in range(2):  # the handler raises once: at most one retry
            try:
                signal.signal(signal.SIGTERM, before)
                break
            except Terminated as error:  # pending as the handler was restored
                late = error
        if late is not None:
            raise late
