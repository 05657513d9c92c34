"""Logged positions far beyond the URDF's joint limits are said: a unit misread.

Found by a review: the TIAGo recording written in degrees (and the torso in mm)
and read with ``angle_unit = "rad"`` (the drive file's default) was identified
without a word about the log, the arm joints at up to 115 "rad" and the torso at
331 "m" (limits 2.7 rad and 0.35 m), and a held-out error of 176 % instead of
14.5 %. Data: the TIAGo excerpt of tests/data/tiago (200 real samples, within
its limits) read through the shipped drive file, then converted.
"""

import pathlib

import numpy as np

from drake_dynid import cli
from drake_dynid.commands._arguments import outside_limits
from drake_dynid.logs import RobotLog
from drake_dynid.plants import RobotModel, model_path
from drake_dynid.raw_log import read_raw_log

DATA = pathlib.Path(__file__).parent / "data" / "tiago"
FILES = [DATA / "tiago_position_excerpt.csv", DATA / "tiago_effort_excerpt.csv"]
DRIVE = pathlib.Path(model_path("tiago_no_hand")).parent / "tiago.toml"
JOINTS = ["torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8))]


def _robot_and_log():
    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"), joints=JOINTS, drive=DRIVE
    )
    return robot, read_raw_log([str(f) for f in FILES], robot.drive)


def _with_q(log, q):
    return RobotLog(log.t, q, log.tau, log.joint_names, log.time_step)


def test_positions_in_another_unit_are_said_and_the_real_ones_are_not():
    robot, log = _robot_and_log()
    q = np.asarray(log.q)
    assert outside_limits(log, robot) is None
    degrees = q.copy()
    degrees[:, 1:] = np.degrees(q[:, 1:])
    warning = outside_limits(_with_q(log, degrees), robot)
    assert warning is not None and "arm_1_joint from " in warning
    assert "torso_lift_joint" not in warning and "angle_unit" in warning
    millimetres = q.copy()
    millimetres[:, 0] *= 1000.0
    warning = outside_limits(_with_q(log, millimetres), robot)
    assert warning.startswith("position(s) beyond the URDF's joint limits: ")
    assert "torso_lift_joint from " in warning and " m (limits 0 .. 0.35)" in warning
    # Within 10 % of the range beyond a limit (an encoder offset): not said.
    near = q.copy()
    near[0, 1] = 2.749 + 0.05 * 2.749
    assert outside_limits(_with_q(log, near), robot) is None


def test_the_command_prints_it(tmp_path, capsys):
    lines = FILES[0].read_text().splitlines()
    header, rows = lines[0], [line.split(",") for line in lines[1:]]
    for row in rows:  # the arm's positions in degrees
        row[2:] = [repr(float(np.degrees(float(x)))) for x in row[2:]]
    degrees = tmp_path / "position_deg.csv"
    degrees.write_text("\n".join([header, *(",".join(r) for r in rows)]) + "\n")
    argv = ["offline", str(degrees), str(FILES[1]), "--urdf"]
    argv += [model_path("tiago_no_hand"), "--joints", ",".join(JOINTS)]
    argv += ["--drive", str(DRIVE), "--quiet"]
    cli.main(argv)  # 2 s of log: the fit may fail, after the log's warnings
    err = capsys.readouterr().err
    assert "beyond the URDF's joint limits: arm_1_joint from " in err, err
