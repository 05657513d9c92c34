"""``dynid bag2csv``: a ROS bag's JointState messages as a CSV log."""

from __future__ import annotations

import argparse
import sys

from drake_dynid.commands._arguments import parse_joints
from drake_dynid.commands._paths import check_output_paths

HELP = "write a ROS bag's sensor_msgs/JointState messages as a CSV log"
DESCRIPTION = (
    "Writes the sensor_msgs/JointState messages of a ROS bag (a ROS 1 .bag; a ROS 2 "
    "bag folder, or its .db3/.mcap file) as a log in the plain CSV format: t (the "
    "header stamps: integer nanoseconds since the epoch; the receive times when "
    "every stamp is 0), q_<joint> (position[]) and tau_<joint> (effort[], when the "
    "messages have efforts), one row per message, row 2 the first. It is the file "
    "the other commands read when given the bag (their messages name its rows); "
    "messages without every joint (another publisher on the topic) are skipped, "
    "with a note. Needs the rosbags package (pip install 'drake_dynid[ros]')."
)


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
        "topic's most frequent message, in its order)",
    )
    parser.add_argument("--quiet", action="store_true", help="print nothing on stdout")


def run(args: argparse.Namespace) -> int:
    """Writes the CSV log. Returns 0."""
    from drake_dynid.ros_bag import export_bag

    args.log = args.bag  # an input: --out is checked against it
    check_output_paths(args)
    joints = parse_joints(args.joints)

    def columns(names: tuple[str, ...], efforts: bool) -> list[str]:
        out = [f"q_{name}" for name in names]
        return out + [f"tau_{name}" for name in names] * efforts

    done = export_bag(args.bag, args.out, joints, columns, topic=args.topic)
    names = done.joint_names
    for note in done.notes:
        print(f"dynid bag2csv: note: {note}", file=sys.stderr)
    if not done.efforts:
        print(
            f"dynid bag2csv: note: the messages on {done.topic} carry no effort[]: "
            "no tau_<joint> column written.",
            file=sys.stderr,
        )
    if not args.quiet:
        from drake_dynid.core._validate import listed

        print(
            f"wrote {args.out}: {done.rows} messages of {done.topic}, "
            f"joints {listed(names)}"
        )
    return 0
