"""``dynid params``: the rank decision, --joints / --lock, notes, bad joint input."""

import json
import pathlib

import pytest

from drake_dynid import cli
from drake_dynid.urdf import model_path

ROOT = pathlib.Path(__file__).resolve().parents[1]

TIAGO_ARM = ",".join(["torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8))])


def test_rank_decision_and_round_off_columns(tmp_path, capsys):
    out_file = tmp_path / "iiwa.json"
    argv = ["params", model_path("iiwa7"), "--json", str(out_file)]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "standard parameters: 84; base parameters: 57" in captured.out
    assert "rank: 57 of 84 columns, clear: |R_kk| of unit columns kept" in captured.out
    # M2 is zero or round-off depending on the order of the products.
    assert "round-off, not exactly zero: MZ2" in captured.out
    assert captured.err == ""  # a clean description: no note
    rank = json.loads(out_file.read_text())["rank"]
    assert rank["round_off_columns"] in (["MZ2"], ["MZ2", "M2"])
    assert rank["clear"] is True
    assert rank["smallest_kept"] > 0.1 and rank["largest_dropped"] < 1e-12
    assert rank["gap"] > 1e8 and rank["singular_gap"] > 1e8
    assert rank["margin_kept"] > 1e4 and rank["margin_dropped"] < 1e-2
    assert rank["tolerance"] == 1e-8 and rank["column_tolerance"] == 1e-10


def test_joints_and_lock_on_tiago(tmp_path, capsys):
    out_file = tmp_path / "tiago.json"
    argv = ["params", model_path("tiago_no_hand"), "--joints", TIAGO_ARM]
    argv += ["--lock", "head_1_joint=0.3, head_2_joint=-0.1", "--json", str(out_file)]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert "joints (8): torso_lift_joint, arm_1_joint" in captured.out
    assert (
        "locked (4): wheel_right_joint=0, wheel_left_joint=0, head_1_joint=0.3, "
        "head_2_joint=-0.1" in captured.out
    )
    assert "standard parameters: 96; base parameters: 60" in captured.out
    notes = captured.err.strip().splitlines()
    assert len(notes) == 3 and all(n.startswith("dynid params: note: ") for n in notes)
    assert "treated as actuated" in notes[0] and "Drake's parser: 15" in notes[1]
    assert "link 'arm_1_link': principal moments" in notes[2]
    document = json.loads(out_file.read_text())
    assert document["locked"]["head_1_joint"] == 0.3 and document["mimic"] == {}
    assert document["joints"] == TIAGO_ARM.split(",") == document["links"]
    assert len(document["notes"]) == 3


def test_lock_alone_identifies_the_other_joints(capsys):
    argv = ["params", model_path("ur5"), "--lock", "wrist_3_joint=0.5"]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "joints (5): shoulder_pan_joint" in out and "wrist_3_joint=0.5" in out


def test_bad_joint_input_exits_2_with_one_line(capsys):
    cases = [
        (["--joints", "torso_lift_joint,elbow"], "'elbow' is not a movable joint"),
        (["--joints", "a,,b"], "--joints must be comma-separated joint names"),
        # Found by a review: a trailing comma was not named as the problem.
        (["--joints", f"{TIAGO_ARM},"], "empty name (a trailing comma)"),
        (["--joints", "a,,b"], "empty name (two commas in a row)"),
        # Found by a review: --joints "$J" with J unset meant every joint, silently.
        (["--joints", ""], "--joints is empty (an unset shell variable?)"),
        (["--joints", "  "], "--joints is empty"),
        # Found by a review: --lock "$L" with L unset locked every joint at 0.
        (["--lock", ""], "--lock is empty (an unset shell variable?)"),
        (["--lock", "head_1_joint"], "--lock must be NAME=VALUE pairs"),
        (["--lock", "head_1_joint=inf"], "--lock must be NAME=VALUE pairs"),
        (
            ["--lock", "head_1_joint=1,head_1_joint=2"],
            "gives joint 'head_1_joint' twice",
        ),
        (
            ["--joints", TIAGO_ARM, "--lock", "arm_1_joint=0"],
            "'arm_1_joint' is both identified and locked",
        ),
    ]
    for extra, message in cases:
        assert cli.main(["params", model_path("tiago_no_hand"), *extra]) == 2
        err = capsys.readouterr().err
        lines = [line for line in err.splitlines() if "note:" not in line]
        assert len(lines) == 1 and message in lines[0] and "Traceback" not in err
    assert cli.main(["params", model_path("tiago_no_hand"), "--joints", "x"]) == 2
    err = capsys.readouterr().err
    assert "available: wheel_right_joint, wheel_left_joint, torso_lift_joint" in err
    # Found by a review: --drive "$D" with D unset meant no drive file (with
    # validate --params, the results file's), silently.
    for command in ("params", "simulate", "replay"):
        with pytest.raises(SystemExit) as exit_:
            cli.main([command, model_path("tiago_no_hand"), "--drive", ""])
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert "argument --drive: empty (an unset shell variable?)" in err, err


def test_a_results_file_with_a_locked_mimic_leader_validates(tmp_path, capsys):
    """Found by a review (every Panda fit with its fingers locked): settings.locked
    lists the mimic follower of a locked leader, which cannot be locked on its
    own; validate then fell back to the default joints and said "another robot".
    The gripper test robot: j1, j2 identified, finger fa locked, fb follows it."""
    import numpy as np

    from drake_dynid.logs import write_log
    from drake_dynid.plants import RobotModel
    from tests.test_any_urdf import gripper_urdf

    urdf = str(gripper_urdf(tmp_path / "g.urdf"))
    params = tmp_path / "p.json"
    argv = ["params", urdf, "--joints", "j1,j2", "--lock", "fa=0.02"]
    assert cli.main([*argv, "--json", str(params)]) == 0
    assert json.loads(params.read_text())["locked"] == {"fa": 0.02, "fb": 0.04}
    robot = RobotModel.from_urdf(urdf, joints=("j1", "j2"), locked={"fa": 0.02})
    t = 0.01 * np.arange(3000)
    q = np.column_stack([np.sin(0.5 * t), 0.8 * np.sin(0.3 * t + 1.0)])
    v = np.column_stack([0.5 * np.cos(0.5 * t), 0.24 * np.cos(0.3 * t + 1.0)])
    a = np.column_stack([-0.25 * np.sin(0.5 * t), -0.072 * np.sin(0.3 * t + 1.0)])
    tau = robot.idim_rows(q, v, a) @ robot.base_values
    log = tmp_path / "log.csv"
    write_log(log, t, q, tau, robot.joint_names)
    capsys.readouterr()
    out = tmp_path / "v.json"
    argv = ["validate", str(log), "--urdf", urdf, "--params", str(params)]
    assert cli.main([*argv, "--json", str(out), "--quiet"]) == 0, capsys.readouterr()
    # Locks that name this URDF's joints but do not apply are an error, not
    # another robot's default model.
    document = json.loads(params.read_text())
    document["locked"] = {"j1": 0.1}  # j1 identified and locked
    params.write_text(json.dumps(document))
    assert cli.main(argv) == 2
    assert "its joints and locks (settings.joints" in capsys.readouterr().err


def test_a_lock_beyond_the_urdf_limits_is_said(tmp_path, capsys):
    # A review: --lock panda_finger_joint1=20 (limits 0-0.04 m) was taken silently.
    from tests.test_any_urdf import gripper_urdf

    urdf = str(gripper_urdf(tmp_path / "g.urdf"))
    argv = ["params", urdf, "--joints", "j1,j2", "--lock"]
    assert cli.main([*argv, "fa=20"]) == 0
    assert "--lock fa=20 is outside its URDF limits [0, 0.04] m" in (
        capsys.readouterr().err
    )
    assert cli.main([*argv, "fa=0.02"]) == 0
    assert "outside" not in capsys.readouterr().err


def test_the_untransmitted_note_names_only_joints_the_drive_file_does_not_drive(
    capsys,
):
    """A review found 'treated as actuated' said of joints whose motors the drive
    file gives (the TIAGo's differential wrist, the wrist4's four joints)."""
    assert cli.main(["params", model_path("tiago_no_hand"), "--joints", TIAGO_ARM]) == 0
    assert "2 joints without a (simple) <transmission>" in capsys.readouterr().err
    argv = ["params", model_path("tiago_no_hand"), "--joints", TIAGO_ARM]
    argv += ["--drive", str(ROOT / "models" / "tiago.toml")]
    assert cli.main(argv) == 0
    assert "treated as actuated" not in capsys.readouterr().err
    wrist = ["params", str(ROOT / "tests" / "data" / "wrist4.urdf")]
    assert cli.main(wrist) == 0
    assert "4 joints without a (simple) <transmission>" in capsys.readouterr().err
    assert (
        cli.main([*wrist, "--drive", str(ROOT / "tests" / "data" / "wrist4.toml")]) == 0
    )
    assert "treated as actuated" not in capsys.readouterr().err


def test_the_untransmitted_note_names_a_joint_the_drive_file_gives_no_motor(
    tmp_path, capsys
):
    """A review: with a drive file every identified joint was taken as driven, so
    a joint with neither a <transmission> nor a motor of the drive file (its
    implicit direct drive) was no longer said to be treated as actuated."""
    text = (ROOT / "tests" / "data" / "wrist4.toml").read_text()
    text = text[: text.index("[motors.m1]")] + text[text.index("[motors.m2]") :]
    text = text.replace("m1 = 12.0\n", "").replace('"mA"', '"N*m"')
    drive = tmp_path / "no_m1.toml"
    drive.write_text(text)
    wrist = ["params", str(ROOT / "tests" / "data" / "wrist4.urdf")]
    assert cli.main([*wrist, "--drive", str(drive)]) == 0
    err = capsys.readouterr().err
    assert "1 joint without a (simple) <transmission>" in err
    assert "treated as actuated" in err and ": j1" in err


def test_a_params_file_validates_as_the_urdf_a_priori_model(tmp_path, capsys):
    """Found by a review (the Unitree Z1's `dynid params --json` validated on a
    log): the URDF's values were labelled "estimate: fit" (and "fit" in the
    JSON), as if identified; --compare-urdf calls them "URDF a-priori"."""
    import numpy as np

    from drake_dynid.logs import write_log
    from drake_dynid.plants import RobotModel, model_path

    urdf = str(model_path("planar_2r"))
    params = tmp_path / "p.json"
    assert cli.main(["params", urdf, "--json", str(params)]) == 0
    robot = RobotModel.from_urdf(urdf)
    t = 0.01 * np.arange(3000)
    q = np.column_stack([np.sin(0.5 * t), 0.8 * np.sin(0.3 * t + 1.0)])
    v = np.column_stack([0.5 * np.cos(0.5 * t), 0.24 * np.cos(0.3 * t + 1.0)])
    a = np.column_stack([-0.25 * np.sin(0.5 * t), -0.072 * np.sin(0.3 * t + 1.0)])
    log = tmp_path / "log.csv"
    write_log(
        log, t, q, robot.idim_rows(q, v, a) @ robot.base_values, robot.joint_names
    )
    capsys.readouterr()
    out = tmp_path / "v.json"
    argv = ["validate", str(log), "--urdf", urdf, "--params", str(params)]
    assert cli.main([*argv, "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "p.json (URDF a-priori, 8 base parameters)" in printed
    assert "estimate: URDF a-priori" in printed and "estimate: fit" not in printed
    assert list(json.loads(out.read_text())["estimates"]) == ["URDF a-priori"]


def test_the_untransmitted_note_names_only_identified_joints(capsys):
    """A review: identifying arm_1..arm_4 of the TIAGo, the note said the locked
    (welded) arm_6_joint, arm_7_joint were 'treated as actuated'."""
    joints = ",".join(f"arm_{k}_joint" for k in range(1, 5))
    argv = ["params", model_path("tiago_no_hand"), "--joints", joints]
    assert cli.main(argv) == 0
    assert "treated as actuated" not in capsys.readouterr().err
    argv = ["params", model_path("tiago_no_hand"), "--joints", "arm_6_joint"]
    assert cli.main(argv) == 0
    assert "1 joint without a (simple) <transmission>" in capsys.readouterr().err
