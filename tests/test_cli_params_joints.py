"""``dynid params``: the rank decision, --joints / --lock, notes, bad joint input."""

import json

from drake_dynid import cli
from drake_dynid.urdf import model_path

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
