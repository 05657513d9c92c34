"""Lists of names in messages: the first 20, then "and N more" (core._validate.listed).

Found by a review: after the ROS bag's lists were capped, other messages still
joined every name they had (the `dynid params` joint line, the drive file's
joint and key lists, a multi-file log's file list) or capped in their own way
(the log reader's hint: 4 joints then ", ...", the URDF's untransmitted joints:
8 then ", … (N in all)"). Each is checked on a fake of 2000 names where one
is cheap (a 25-joint chain for the commands that build a model).
"""

import pytest

from drake_dynid import cli
from drake_dynid.core.drive import DriveChain
from drake_dynid.logs import read_log
from drake_dynid.raw_log import read_raw_table
from drake_dynid.urdf import untransmitted_note

WIDE = [f"j{k}" for k in range(2000)]
FIRST = ", ".join(WIDE[:20])


def _chain_urdf(path, n):
    """A serial chain of n revolute joints j0..j(n-1), no transmissions."""
    parts = ['<robot name="chain">', '<link name="base"/>']
    parent = "base"
    for i in range(n):
        parts.append(
            f'<link name="l{i}"><inertial><mass value="1"/><origin xyz="0.05 0 0"/>'
            '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>'
            "</inertial></link>"
        )
        axis = "0 0 1" if i % 2 == 0 else "0 1 0"
        parts.append(
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/>'
            f'<child link="l{i}"/><origin xyz="0.1 0 0"/><axis xyz="{axis}"/>'
            '<limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
        )
        parent = f"l{i}"
    path.write_text("\n".join([*parts, "</robot>"]))
    return path


def test_params_lists_the_first_20_joints(tmp_path, capsys):
    # Before: 'joints (25): j0, ..., j24' and the untransmitted note's own cap
    # '..., j7, … (25 in all)'.
    urdf = _chain_urdf(tmp_path / "chain.urdf", 25)
    assert cli.main(["params", str(urdf)]) == 0
    captured = capsys.readouterr()
    first = ", ".join(f"j{k}" for k in range(20))
    assert f"joints (25): {first} and 5 more\n" in captured.out
    note = f"treated as actuated (effort limit from the URDF's <limit>): {first} and 5"
    assert note in captured.err


def test_the_untransmitted_note_lists_the_first_20_joints():
    note = untransmitted_note(WIDE, ())
    assert note.endswith(f"(no effort limit): {FIRST} and 1980 more"), note


def test_a_drive_files_joint_and_key_lists_are_capped():
    motors = {"motors": {"m1": {"joint": "nope", "gear_ratio": 2.0}}}
    with pytest.raises(ValueError, match="unknown joint 'nope'") as raised:
        DriveChain.from_dict(motors, WIDE, source="d.toml")
    assert str(raised.value).endswith(f"are {FIRST} and 1980 more."), raised.value
    keys = {name: 1 for name in WIDE}
    with pytest.raises(ValueError, match="unknown key") as raised:
        DriveChain.from_dict(keys, ["a"], source="d.toml")
    assert f"unknown key(s) {FIRST} and 1980 more; allowed" in str(raised.value)
    # 300 joints: 2000 take 2.7 s (the rank check's SVD of a 2000 × 2000 R).
    names = WIDE[:300]
    columns = {"log": {"position": {name: f"p_{name}" for name in names[:-1]}}}
    with pytest.raises(ValueError, match="must name a column") as raised:
        DriveChain.from_dict(columns, names, source="d.toml")
    assert f"every joint ({FIRST} and 280 more); unknown: none; missing: j299." in (
        str(raised.value)
    ), raised.value


def test_a_multi_file_logs_file_list_is_capped(tmp_path):
    files = []
    for k in range(25):
        path = tmp_path / f"f{k}.csv"
        path.write_text(f"stamp,a{k}\n0,1\n1,2\n")
        files.append(str(path))
    with pytest.raises(ValueError, match="no column") as raised:
        read_raw_table(files, ["stamp", "absent"], "stamp")
    text = str(raised.value)
    assert text.startswith(f"log {', '.join(files[:20])} and 5 more: no column(s) ")
    assert text.count("stamp, a") == 20 and "a19; " not in text, text


def test_the_log_readers_hint_lists_the_first_20_joints(tmp_path):
    header = ["t", *(f"q_{n}" for n in WIDE), *(f"tau_{n}" for n in WIDE)]
    path = tmp_path / "wide.csv"
    path.write_text(",".join(header) + "\n" + ",".join(["0"] * len(header)) + "\n")
    # None of the robot's joints: was 'j0, j1, j2, j3, ...'.
    with pytest.raises(ValueError, match="missing column") as raised:
        read_log(path, ("shoulder", "elbow"))
    assert f"holds the joints {FIRST} and 1980 more, not the ones" in str(raised.value)
    # Some of them: was every name, twice (the --joints value to copy).
    with pytest.raises(ValueError, match="missing column") as raised:
        read_log(path, (*WIDE, "elbow"))
    text = str(raised.value)
    assert f"holds {FIRST} and 1980 more only: --joints with those" in text, text
    assert len(text) < 1500, len(text)
    # A review: 30 of 31 joints gave no value to copy ('--joints with those
    # names'), where the 20 listed were not all of them. Up to 100, the value.
    with pytest.raises(ValueError, match="missing column") as raised:
        read_log(path, (*WIDE[:30], "elbow"))
    text = str(raised.value)
    value = ",".join(WIDE[:30])
    assert f"holds 30 of the 31 joints only: --joints {value} identifies" in text


def test_a_log_in_another_joint_order_says_where_beyond_the_listed_names():
    """Found by a review: with both lists cut at 20 names, a log whose joints
    21 and 22 are swapped was refused with the same list twice ('must be the
    robot's j0, ..., j19 and 5 more in that order; got j0, ..., j19 and 5
    more'). The message now names the first difference."""
    from types import SimpleNamespace

    from drake_dynid import offline, validation

    robot = SimpleNamespace(joint_names=tuple(f"j{k}" for k in range(25)))
    names = list(robot.joint_names)
    names[20], names[21] = names[21], names[20]
    log = SimpleNamespace(t=0, q=0, tau=0, time_step=0.01, joint_names=tuple(names))
    with pytest.raises(ValueError) as offline_error:
        offline._check_log("OfflineIdentifier", log, robot, None)
    with pytest.raises(ValueError) as validation_error:
        validation._validate("validate", log, robot, {}, None, None, 4)
    for error in (offline_error, validation_error):
        message = str(error.value)
        assert f"in that order; got {FIRST} and 5 more" in message, message
        assert "(name 21 of 25: 'j20' expected, 'j21' given)." in message, message
    short = SimpleNamespace(**{**vars(log), "joint_names": robot.joint_names[:24]})
    with pytest.raises(ValueError, match=r"name 25 of 25: 'j24' expected, none given"):
        offline._check_log("OfflineIdentifier", short, robot, None)


def test_a_refused_name_is_followed_by_the_closest_valid_ones():
    """Found by a review: a list cut at 20 could leave out the very name meant
    (a humanoid's flange among its 40 links, a friction parameter behind 40
    inertial ones); the closest valid names now follow the cut list."""
    from drake_dynid.core._validate import choices

    names = [f"link_{k}" for k in range(40)] + ["tool_flange"]
    text = choices(names, "tool_flang")
    assert text.endswith("and 21 more; the closest to 'tool_flang': tool_flange"), text
    assert choices(["a", "b"], "tool") == "a, b"  # short lists: all of them


def test_a_base_parameter_name_error_names_the_closest(tmp_path):
    from drake_dynid.robot import RobotModel

    robot = RobotModel.from_urdf(_chain_urdf(tmp_path / "chain.urdf", 6))
    base = robot.base
    assert len(base.names) > 20
    with pytest.raises(ValueError, match=r"and \d+ more; the closest to 'FV06': FV6"):
        base.definition_text("FV06")


def test_a_payload_frame_error_names_the_closest_body(tmp_path):
    from drake_dynid.payload import payload_model
    from drake_dynid.robot import RobotModel

    robot = RobotModel.from_urdf(_chain_urdf(tmp_path / "chain.urdf", 21))
    with pytest.raises(ValueError, match=r"and 1 more; the closest to 'l_20': l20"):
        payload_model(robot, "l_20")


def test_noise_bias_names_the_friction_columns_it_has():
    from drake_dynid.core.noise_bias import _friction_names

    names = [f"XX{k}" for k in range(30)] + ["FV1", "FC1", "OFF1", "FCm4", "FV12"]
    assert _friction_names(names) == ["FV1", "FC1", "OFF1", "FV12"]
