"""A joint outside ``--joints`` that moves in the log is said (a review: it was
welded at 0 with only "ignored extra column(s)" said, and the held-out error grew
tenfold). The 2R arm identified as one joint; its log from a random Fourier
reference (tests/_motions.py), joint 2 moving, still at 0, or still at 0.5 rad."""

import pathlib

import numpy as np
import pytest
from _motions import fourier_2r

from drake_dynid import cli
from drake_dynid.commands._arguments import locked_motion
from drake_dynid.logs import write_log
from drake_dynid.plants import RobotModel, model_path

URDF = model_path("planar_2r")


def _log(path, joint2):
    _, t, q, _ = fourier_2r(30001)
    if joint2 is not None:
        q[:, 1] = joint2
    write_log(path, t, q, np.ones_like(q), ("joint1", "joint2"))
    return str(path)


@pytest.mark.parametrize(
    ("joint2", "lock", "said"),
    [(None, None, True), (0.0, None, False), (0.5, 0.5, False), (0.5, None, True)],
)
def test_a_locked_joint_that_moves_is_said(tmp_path, joint2, lock, said):
    path = _log(tmp_path / "log.csv", joint2)
    locked = None if lock is None else {"joint2": lock}
    robot = RobotModel.from_urdf(URDF, joints=["joint1"], locked=locked)
    warning = locked_motion(path, robot)
    assert (warning is not None) == said, warning
    if said:
        assert "joint2 from " in warning and "--joints" in warning


def test_the_command_prints_it(tmp_path, capsys):
    path = _log(tmp_path / "log.csv", None)
    cli.main(["offline", path, "--urdf", URDF, "--joints", "joint1", "--quiet"])
    err = capsys.readouterr().err
    assert "joint(s) not identified move in the log (joint2 from " in err, err
    cli.main(["offline", path, "--urdf", URDF, "--quiet"])
    assert "not identified move" not in capsys.readouterr().err


def test_columns_that_never_change_are_said(tmp_path, capsys):
    """Found by a review: all-zero torques gave "final window: valid" and an
    all-zero estimate, and a frozen encoder confident nonsense, without a word
    about the log."""
    from drake_dynid.commands._arguments import constant_channels
    from drake_dynid.logs import read_log

    path = _log(tmp_path / "log.csv", None)
    log = read_log(path, ("joint1", "joint2"))  # tau = 1 everywhere in _log
    warning = constant_channels(log)
    assert "tau_joint1 = 1, tau_joint2 = 1 never change" in warning
    assert "q_" not in warning
    frozen = _log(tmp_path / "frozen.csv", 0.25)
    cli.main(["offline", frozen, "--urdf", URDF, "--quiet"])
    err = capsys.readouterr().err
    assert "q_joint2 = 0.25 never change: a joint that does not move" in err, err


def test_a_mimic_joint_that_does_not_follow_its_leader_is_said(tmp_path):
    """Found by a review: with a URDF whose joint2 mimics 2·joint1, a log where
    joint2 moves on its own was read without a word."""
    text = pathlib.Path(URDF).read_text()
    anchor = '<joint name="joint2" type="continuous">'
    assert anchor in text
    urdf = tmp_path / "mimic.urdf"
    urdf.write_text(
        text.replace(anchor, anchor + '<mimic joint="joint1" multiplier="2"/>', 1)
    )
    robot = RobotModel.from_urdf(str(urdf))
    assert dict(robot.mimic) == {"joint2": ("joint1", 2.0, 0.0)}
    _, t, q, _ = fourier_2r(30001)
    own = tmp_path / "own.csv"
    write_log(own, t, q, np.ones_like(q), ("joint1", "joint2"))
    warning = locked_motion(str(own), robot)
    assert "mimic joint(s) do not follow their URDF relation" in warning
    assert "joint2 departs from 2·joint1 + 0 by up to " in warning
    q[:, 1] = 2.0 * q[:, 0]
    follows = tmp_path / "follows.csv"
    write_log(follows, t, q, np.ones_like(q), ("joint1", "joint2"))
    assert locked_motion(str(follows), robot) is None


def test_cells_the_sampler_cannot_read_say_nothing(tmp_path):
    """Found by a review: a locked joint's column all NaN, or every cell quoted,
    gave "iiwa_joint_7 from inf to -inf"."""
    robot = RobotModel.from_urdf(URDF, joints=["joint1"])
    _, t, q, _ = fourier_2r(3001)
    q[:, 1] = np.nan
    empty = tmp_path / "nan.csv"
    write_log(empty, t, q, np.ones_like(q), ("joint1", "joint2"))
    assert locked_motion(str(empty), robot) is None
    _, t, q, _ = fourier_2r(3001)
    lines = ["t,q_joint1,q_joint2,tau_joint1,tau_joint2"]
    rows = zip(t, q[:, 0], q[:, 1], strict=True)
    lines += [f'"{a}","{b}","{c}","1","1"' for a, b, c in rows]
    quoted = tmp_path / "quoted.csv"
    quoted.write_text("\n".join(lines) + "\n")
    warning = locked_motion(str(quoted), robot)
    assert warning is not None and "joint2 from -" in warning, warning


def test_a_drive_file_log_of_moving_locked_joints_is_said(capsys):
    """The TIAGo recording identified for arm_1..arm_4 with the robot's drive file
    (its torso and wrist move): the joint-side template names their columns."""
    data = pathlib.Path(__file__).parent / "data" / "tiago"
    logs = [
        str(data / "tiago_position_excerpt.csv"),
        str(data / "tiago_effort_excerpt.csv"),
    ]
    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"),
        joints=[f"arm_{k}_joint" for k in range(1, 5)],
        drive=pathlib.Path(model_path("tiago_no_hand")).with_name("tiago.toml"),
    )
    warning = locked_motion(logs, robot)
    assert warning is not None and "joint(s) not identified move in the log" in warning
    assert "arm_5_joint from " in warning, warning


def test_a_locked_prismatic_joint_is_read_in_the_length_unit(tmp_path):
    """Found by a review: a drive log's locked prismatic torso was read in the
    angle unit (a millimetre log held still was "moving")."""
    from drake_dynid.commands._arguments import _motion_checks

    data = pathlib.Path(__file__).parent / "data" / "tiago"
    drive = pathlib.Path(model_path("tiago_no_hand")).with_name("tiago.toml")
    text = drive.read_text()
    old = 'length_unit = "m"'
    assert old in text
    mm = tmp_path / "tiago_mm.toml"
    mm.write_text(text.replace(old, 'length_unit = "mm"', 1))
    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"),
        joints=[f"arm_{k}_joint" for k in range(1, 8)],
        locked={"torso_lift_joint": 0.2},
        drive=mm,
    )
    logs = [str(data / "tiago_position_excerpt.csv")]
    ((_, _, checks),) = _motion_checks(logs, robot)
    scales = {name: scale for name, _, _, _, _, scale in checks}
    assert scales == {"torso_lift_joint": 1e-3}


def test_a_plain_log_of_a_locked_prismatic_joint(tmp_path, capsys):
    """Found by a review (a Panda log with its finger columns): a plain log
    holding a locked prismatic joint's column crashed with a NameError (exit 1).
    The gripper test robot: j1, j2 identified, finger fa locked (fb mimics it)."""
    from test_any_urdf import gripper_urdf

    urdf = gripper_urdf(tmp_path / "g.urdf")
    robot = RobotModel.from_urdf(urdf, joints=("j1", "j2"), locked={"fa": 0.02})
    _, t, q, _ = fourier_2r(3001)
    finger = 0.02 + 0.01 * np.sin(t)  # the finger moves: 1 cm
    columns = np.column_stack([q, finger, 1.5 * finger + 0.01])
    names = ("j1", "j2", "fa", "fb")
    log = tmp_path / "log.csv"
    write_log(log, t, columns, np.ones_like(columns), names)
    warning = locked_motion(str(log), robot)
    assert "fa" in warning and "0.02" in warning
    still = tmp_path / "still.csv"
    columns[:, 2], columns[:, 3] = 0.02, 0.04
    write_log(still, t, columns, np.ones_like(columns), names)
    assert locked_motion(str(still), robot) is None
