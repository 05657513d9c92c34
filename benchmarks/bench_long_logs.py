"""Long drive logs: ``dynid offline`` time and peak memory against the log's length.

A synthetic TIAGo drive log in the real recording's layout (examples/data/tiago:
torso + 7-DOF arm, ``models/tiago_no_hand.urdf`` with ``drake_dynid/models/tiago.toml``,
100 Hz, one file with the time column ``t``, positions ``- {joint}_position`` and
motor currents ``- {joint}_effort``): a 60 s random Fourier period (numpy
default_rng(7), 4 harmonics of 1/60 Hz, |v| <= 0.5 rad/s; the torso lift scaled
to 0.05-0.30 m) tiled to the
length, τ from the inverse-dynamics rows at the URDF's base values, converted to
currents with the drive file's chain (current = τ / (ratio · motor constant),
docs/DRIVE.md), white noise on q (1e-4) and on the currents (1 % of their std),
numpy default_rng(0). Each length runs ``dynid offline`` once in a fresh process
(``_arm7.run_case``: end to end, its own resident high-water mark); with
``--identify``, ``dynid identify`` too (about 1 s per minute of log); with
``--validate``, ``dynid validate`` of the off-line estimate on the same log with
``--plot`` (the compared samples stay on disk, the plot draws envelopes); with
``--bag``, ``dynid offline`` on the same samples as a ROS 2 mcap bag of
``/joint_states`` (rosbags' writer; the two head joints in each message too,
not read; stamps 1.7e9 s + t; full-precision values, so not the CSV's
estimate bit for bit). The peak must not grow with the length: the reader
streams the CSV into temporary files (a bag: decoded into its CSV export a
block at a time) and the off-line fit reduces its rows by QR as they come
(README, Performance).

Usage: ``python benchmarks/bench_long_logs.py [--hours 2.5 10] [--identify]
[--validate] [--bag]``
(the 10-hour log is a 1.3 GB CSV in a temporary folder).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

import numpy as np
from _arm7 import run_case
from _timing import quick_or

from drake_dynid.core._threads import configure_process
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.plants import RobotModel

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
URDF = os.path.join(ROOT, "drake_dynid", "models", "tiago_no_hand.urdf")
DRIVE = os.path.join(ROOT, "drake_dynid", "models", "tiago.toml")
JOINTS = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
# docs/DRIVE.md and the drive file's provenance: τ = ratio · constant · current.
RATIO = np.array([1.0, 100.0, 100.0, 100.0, 100.0, 336.0, 336.0, 336.0])
CONSTANT = np.array([1.0, 0.136, 0.136, -0.087, -0.087, -0.0613, -0.0613, -0.0613])
H = 0.01
PERIOD = 60.0


def period_samples() -> tuple[np.ndarray, np.ndarray]:
    """(q, current) of one period, (6000, 8) each, noise-free."""
    robot = RobotModel.from_urdf(URDF, joints=JOINTS)
    trajectory = random_fourier_trajectory(
        len(JOINTS),
        harmonics=4,
        base_frequency=2 * np.pi / PERIOD,
        max_velocity=0.5,
        rng=np.random.default_rng(7),
    )
    t = H * np.arange(round(PERIOD / H))
    q, v, vdot = trajectory.evaluate(t)
    # The torso lift (prismatic) within 0.05-0.30 m: q0 -> a + b q0 (v, v̇ by b).
    b = 0.25 / np.ptp(q[:, 0])
    q[:, 0] = 0.05 + b * (q[:, 0] - q[:, 0].min())
    v[:, 0] *= b
    vdot[:, 0] *= b
    tau = np.einsum("nip,p->ni", robot.idim_rows(q, v, vdot), robot.base_values)
    return q, tau / (RATIO * CONSTANT)


def write_drive_log(path: str, hours: float) -> None:
    """Writes the drive log of ``hours`` to ``path``, a period at a time."""
    q, current = period_samples()
    rng = np.random.default_rng(0)
    scale = 0.01 * current.std(axis=0)
    header = ",".join(
        ["t"] + [f"- {j}_position" for j in JOINTS] + [f"- {j}_effort" for j in JOINTS]
    )
    periods = round(hours * 3600.0 / PERIOD)
    with open(path, "w", encoding="utf-8") as handle:
        handle.write(header + "\n")
        for k in range(periods):
            t = H * (np.arange(q.shape[0]) + k * q.shape[0])
            noisy_q = q + 1e-4 * rng.standard_normal(q.shape)
            noisy_i = current + scale * rng.standard_normal(current.shape)
            np.savetxt(
                handle,
                np.column_stack([t, noisy_q, noisy_i]),
                delimiter=",",
                fmt="%.10g",
            )


def write_drive_bag(path: str, hours: float) -> None:
    """Writes the drive log of ``hours`` as a ROS 2 mcap bag at ``path`` (a folder)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    kind = "sensor_msgs/msg/JointState"
    state, header, stamp_type = (
        store.types[kind],
        store.types["std_msgs/msg/Header"],
        store.types["builtin_interfaces/msg/Time"],
    )
    q, current = period_samples()
    rng = np.random.default_rng(0)
    scale = 0.01 * current.std(axis=0)
    names = ["head_1_joint", "head_2_joint", *JOINTS]
    head = np.array([0.1, -0.2])
    epoch = 1_700_000_000 * 10**9
    step = round(H * 1e9)
    periods = round(hours * 3600.0 / PERIOD)
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer:
        topic = writer.add_connection("/joint_states", kind, typestore=store)
        for k in range(periods):
            noisy_q = q + 1e-4 * rng.standard_normal(q.shape)
            noisy_i = current + scale * rng.standard_normal(current.shape)
            for i in range(q.shape[0]):
                stamp = epoch + (k * q.shape[0] + i) * step
                message = state(
                    header=header(
                        stamp=stamp_type(sec=stamp // 10**9, nanosec=stamp % 10**9),
                        frame_id="",
                    ),
                    name=names,
                    position=np.concatenate([head, noisy_q[i]]),
                    velocity=np.zeros(0),
                    effort=np.concatenate([np.zeros(2), noisy_i[i]]),
                )
                writer.write(topic, stamp, store.serialize_cdr(message, kind))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--hours", type=float, nargs="+", default=None, help="default 2.5 10"
    )
    parser.add_argument("--identify", action="store_true", help="also dynid identify")
    parser.add_argument(
        "--validate",
        action="store_true",
        help="also dynid validate --plot of the off-line estimate",
    )
    parser.add_argument(
        "--bag",
        action="store_true",
        help="also dynid offline on the log as a ROS 2 mcap bag (needs rosbags)",
    )
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    configure_process()
    hours = quick_or(args.hours, args.quick, [2.0 / 60.0], [2.5, 10.0])
    commands = ["offline"] + ["identify"] * args.identify
    commands += ["validate"] * (args.validate or args.quick)
    if args.bag or args.quick:
        try:
            import rosbags  # noqa: F401
        except ImportError:
            if args.bag:
                raise
        else:
            commands.append("offline-bag")
    results: dict[str, dict] = {}
    lines = [
        "\n### Long TIAGo drive logs (8 joints, 100 Hz, --drive), end to end\n",
        "| log | command | wall [s] | × real time | peak memory [MB] |",
        "|---|---|---:|---:|---:|",
    ]
    with tempfile.TemporaryDirectory() as folder:
        for length in hours:
            path = os.path.join(folder, f"tiago{length:g}h.csv")
            start = time.perf_counter()
            write_drive_log(path, length)
            written = time.perf_counter() - start
            for command in commands:
                out = os.path.join(folder, f"{command}.json")
                log, size, made = path, os.path.getsize(path) / 1e6, written
                if command == "offline-bag":
                    log = os.path.join(folder, f"tiago{length:g}h")
                    start = time.perf_counter()
                    write_drive_bag(log, length)
                    made = time.perf_counter() - start
                    size = sum(
                        os.path.getsize(os.path.join(log, name))
                        for name in os.listdir(log)
                    )
                    size /= 1e6
                argv_case = [
                    command.split("-")[0],
                    log,
                    "--urdf",
                    URDF,
                    "--joints",
                    ",".join(JOINTS),
                    "--drive",
                    DRIVE,
                    "--json",
                    out,
                    "--quiet",
                ]
                if command == "validate":  # the off-line estimate, plotted
                    params = os.path.join(folder, "offline.json")
                    plot = os.path.join(folder, "validate.png")
                    argv_case += ["--params", params, "--plot", plot]
                case = run_case({"kind": "cli", "argv": argv_case})
                key = f"{command}_{length:g}h"
                results[key] = {
                    "hours": length,
                    "csv_mb": size,
                    "bag": command == "offline-bag",
                    "csv_write_s": made,
                    "wall_s": case["wall"],
                    "peak_mb": case["peak_mb"],
                    "real_time": length * 3600.0 / case["wall"],
                }
                what = "bag" if log != path else "CSV"
                lines.append(
                    f"| {length:.3g} h ({size:.0f} MB {what}) "
                    f"| {command.replace('-bag', ' (mcap bag)')} | "
                    f"{case['wall']:.3g} | {length * 3600.0 / case['wall']:.0f} | "
                    f"{case['peak_mb']:.0f} |"
                )
    print("\n".join(lines))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(results, handle, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
