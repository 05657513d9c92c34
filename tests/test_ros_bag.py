"""ROS bags of sensor_msgs/JointState read as logs (``drake_dynid.ros_bag``).

The bags are written with rosbags' own writers (ROS 1 .bag, ROS 2 sqlite3 and
mcap) from a log simulated independently (Drake's inverse dynamics of the packaged
2R, ``tests/_drake_dynamics.py``) and from the packaged TIAGo recording; the same
samples are written as the CSV log a user would export. A bag is read as its CSV
export (one row per message, the stamps as integer nanoseconds, 17 digits), so
the estimates on the bag are the CSV's bit for bit (the same numbers reach the
same reader).
"""

import io
import json
import pathlib
import sys

import numpy as np
import pytest

pytest.importorskip("rosbags")

from _cli import error_line
from _drake_dynamics import exact_paper_2r
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from drake_dynid import cli
from drake_dynid.logs import read_log
from drake_dynid.robot import RobotModel
from drake_dynid.ros_bag import MISSING, read_joint_states
from drake_dynid.urdf import MODELS_DIR

ROOT = pathlib.Path(__file__).resolve().parents[1]
TIAGO = ROOT / "examples" / "data" / "tiago"
TIAGO_JOINTS = ["torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8))]
EPOCH = 1_700_000_000 * 10**9  # header stamps [ns]
STATE = "sensor_msgs/msg/JointState"


def write_bag(path, kind, messages, topics=("/joint_states",), others=(), setup=None):
    """A bag of JointState messages: ``(topic index, stamp ns, receive ns, names,
    positions, efforts)`` each; ``others``: extra ``(topic, type)`` connections
    (no message). ``kind``: ros1, sqlite3 or mcap; ``setup(writer)`` before it
    opens (a ROS 1 bag's chunk size, compression)."""
    store = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    types = store.types
    joint_state, header, stamp_type = (
        types[STATE],
        types["std_msgs/msg/Header"],
        types["builtin_interfaces/msg/Time"],
    )
    if kind == "ros1":
        writer, serialize = Writer1(path), store.serialize_ros1
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
        serialize = store.serialize_cdr
    if setup is not None:
        setup(writer)
    with writer:
        connections = [
            writer.add_connection(topic, STATE, typestore=store) for topic in topics
        ]
        for topic, kind_ in others:
            writer.add_connection(topic, kind_, typestore=store)
        for k, (which, stamp, received, names, p, e) in enumerate(messages):
            time = stamp_type(sec=int(stamp // 10**9), nanosec=int(stamp % 10**9))
            fields = {"seq": k} if kind == "ros1" else {}
            message = joint_state(
                header=header(**fields, stamp=time, frame_id=""),
                name=list(names),
                position=np.array(p, dtype=float),
                velocity=np.array([], dtype=float),
                effort=np.array(e, dtype=float),
            )
            writer.write(connections[which], int(received), serialize(message, STATE))


@pytest.fixture(scope="module")
def arm():
    """The packaged 2R's exact log: 8 s at 1 kHz, τ from Drake's inverse dynamics."""
    robot = RobotModel.from_urdf(str(MODELS_DIR / "planar_2r.urdf"))
    t, q, tau = exact_paper_2r(robot, 8001)
    stamps = EPOCH + np.arange(t.size, dtype=np.int64) * 10**6
    return list(robot.joint_names), stamps, q, tau


def csv_log(path, arm, rows=slice(None)):
    """The CSV export a user would write: integer ns stamps, 17 digits."""
    names, stamps, q, tau = arm
    header = ["t", *(f"q_{j}" for j in names), *(f"tau_{j}" for j in names)]
    lines = [",".join(header)]
    for k in np.arange(stamps.size)[rows]:
        cells = [f"{x:.17g}" for x in (*q[k], *tau[k])]
        lines.append(",".join([str(stamps[k]), *cells]))
    path.write_text("\n".join(lines) + "\n")
    return path


def arm_messages(arm, rows=slice(None), shuffled=True, zero_stamps=False):
    """One message a sample; the joint order reversed on every other message."""
    names, stamps, q, tau = arm
    out = []
    for k in np.arange(stamps.size)[rows]:
        order = slice(None, None, -1) if shuffled and k % 2 else slice(None)
        stamp = 0 if zero_stamps else stamps[k]
        received = stamps[k] if zero_stamps else stamps[k] + 350_000
        out.append((0, stamp, received, names[order], q[k][order], tau[k][order]))
    return out


def run_json(capsys, argv, path):
    code = cli.main([*argv, "--json", str(path)])
    err = capsys.readouterr().err
    assert code == 0, err
    document = json.loads(path.read_text())
    document.pop("log")
    return document, err


def offline(capsys, log, path, *options):
    return run_json(
        capsys, ["offline", str(log), "--urdf", "planar_2r", *options], path
    )


def bag_fit_is_the_csv_fit(capsys, tmp_path, arm, bag, kind, messages):
    """Writes ``messages`` as a ``kind`` bag at ``bag``, asserts that ``dynid
    offline`` on it gives the JSON of the arm's CSV export: (that JSON, the bag
    run's stderr)."""
    write_bag(bag, kind, messages)
    on_bag, err = offline(capsys, bag, tmp_path / "bag.json")
    on_csv, _ = offline(capsys, csv_log(tmp_path / "log.csv", arm), tmp_path / "c.json")
    assert on_bag == on_csv
    return on_csv, err


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_offline_on_a_bag_is_the_csv_estimate_bit_for_bit(arm, tmp_path, capsys, kind):
    bag = tmp_path / ("log.bag" if kind == "ros1" else "log")
    on_csv, err = bag_fit_is_the_csv_fit(
        capsys, tmp_path, arm, bag, kind, arm_messages(arm)
    )
    assert "warning" not in err  # integer ns stamps: no note for a bag
    if kind != "ros1":  # the storage file names the bag too
        storage = next(bag.glob("*.db3" if kind == "sqlite3" else "*.mcap"))
        again, _ = offline(capsys, storage, tmp_path / "again.json")
        assert again == on_csv


def test_identify_on_a_bag_is_the_csv_estimate(arm, tmp_path, capsys):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm))
    options = ["--urdf", "planar_2r", "--window", "4", "--quiet"]
    on_bag, _ = run_json(capsys, ["identify", str(bag), *options], tmp_path / "b.json")
    log = csv_log(tmp_path / "log.csv", arm)
    on_csv, _ = run_json(capsys, ["identify", str(log), *options], tmp_path / "c.json")
    for document in (on_bag, on_csv):  # the CSV's note on its ns stamps apart
        document.pop("warnings", None)
    assert on_bag == on_csv


def test_another_publisher_on_the_topic_is_skipped_and_counted(arm, tmp_path, capsys):
    messages = []
    for k, message in enumerate(arm_messages(arm)):
        messages.append(message)
        if k % 10 == 0:  # a gripper's publisher, 100 Hz, between the arm's
            stamp = message[1] + 500_000
            messages.append((0, stamp, stamp, ["gripper_joint"], [0.01], [0.5]))
    bag = tmp_path / "log.bag"
    _, err = bag_fit_is_the_csv_fit(capsys, tmp_path, arm, bag, "ros1", messages)
    assert (
        f"log {bag}: skipped 801 of 8802 message(s) on /joint_states that lack "
        "joint(s) of joint1, joint2 (their joints: gripper_joint): another "
        "publisher on the topic." in err
    )


def test_no_message_with_every_joint_names_the_joints_the_topic_has(tmp_path, capsys):
    bag = tmp_path / "log.bag"
    messages = [
        (0, EPOCH + k, EPOCH + k, ["a", "joint1"], [0, 0], [0, 0]) for k in (1, 2)
    ]
    write_bag(bag, "ros1", messages)
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    assert error_line(capsys).endswith(
        f"ROS bag {bag}: no message on /joint_states holds every joint needed "
        "(joint1, joint2); its messages name: [a, joint1]."
    )


def test_zero_header_stamps_take_the_receive_times(arm, tmp_path, capsys):
    bag = tmp_path / "log.db3.d"
    _, err = bag_fit_is_the_csv_fit(
        capsys, tmp_path, arm, bag, "sqlite3", arm_messages(arm, zero_stamps=True)
    )
    assert (
        "every header.stamp on /joint_states is 0: the bag's receive times are used."
        in err
    )


def test_gaps_and_nan_are_repaired_as_in_the_csv(arm, tmp_path, capsys):
    names, stamps, q, tau = arm
    q = q.copy()
    q[3000, 1] = np.nan  # a bad cell: filled
    broken = (names, stamps, q, tau)
    rows = np.r_[0:1000, 1003 : stamps.size]  # 3 dropped messages: filled
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(broken, rows))
    on_bag, err = offline(capsys, bag, tmp_path / "bag.json")
    log = csv_log(tmp_path / "log.csv", broken, rows)
    on_csv, csv_err = offline(capsys, log, tmp_path / "c.json")
    assert on_bag == on_csv
    said = [line.split(": ", 3)[3] for line in err.splitlines() if "warning" in line]
    csv_said = [
        line.split(": ", 3)[3]
        for line in csv_err.splitlines()
        if "warning" in line and "nanoseconds" not in line
    ]
    assert said == csv_said and len(said) == 2, err  # the dropped rows, the NaN


def test_several_joint_state_topics_need_topic(arm, tmp_path, capsys):
    messages = arm_messages(arm)
    extra = [(1, m[1], m[2], ["x"], [0.0], [0.0]) for m in messages[:5]]
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", messages + extra, topics=("/joint_states", "/head/states"))
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    assert error_line(capsys).endswith(
        f"ROS bag {bag}: 2 topics of type {STATE} (/head/states, /joint_states): "
        "name the one to read with --topic."
    )
    on_bag, _ = offline(capsys, bag, tmp_path / "b.json", "--topic", "/joint_states")
    on_csv, _ = offline(capsys, csv_log(tmp_path / "log.csv", arm), tmp_path / "c.json")
    assert on_bag["settings"].pop("topic") == "/joint_states"  # recorded
    assert on_bag == on_csv
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r", "--topic", "/j"]) == 2
    assert "--topic /j: no such topic; the bag's" in error_line(capsys)


def test_a_bag_without_joint_states_lists_its_topics(tmp_path, capsys):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", [], topics=(), others=[("/imu", "sensor_msgs/msg/Imu")])
    assert cli.main(["bag2csv", str(bag), "--out", str(tmp_path / "x.csv")]) == 2
    assert error_line(capsys).endswith(
        f"ROS bag {bag}: no topic of type {STATE}; its topics: /imu "
        "(sensor_msgs/msg/Imu)."
    )


def test_without_rosbags_a_bag_is_a_clear_error(arm, tmp_path, capsys, monkeypatch):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 10)))
    monkeypatch.setitem(sys.modules, "rosbags", None)  # import rosbags fails
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    assert error_line(capsys) == f"dynid offline: error: {MISSING}"
    assert MISSING == (
        "reading a ROS bag needs the rosbags package: pip install 'drake_dynid[ros]'"
    )
    log = csv_log(tmp_path / "log.csv", arm)  # a CSV log needs no rosbags
    assert cli.main(["offline", str(log), "--urdf", "planar_2r", "--quiet"]) == 0


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_a_truncated_bag_names_the_file(arm, tmp_path, capsys, kind):
    bag = tmp_path / ("log.bag" if kind == "ros1" else "log")
    write_bag(bag, kind, arm_messages(arm, slice(0, 500)))
    storage = bag if kind == "ros1" else next(bag.glob("*.mcap"))
    data = storage.read_bytes()
    storage.write_bytes(data[: len(data) // 2])
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    line = error_line(capsys)
    assert line.startswith(f"dynid offline: error: ROS bag {bag}: cannot be read (")
    assert "is it a complete ROS 1 .bag or ROS 2 bag?" in line


def test_an_output_never_overwrites_the_bag(arm, tmp_path, capsys):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 10)))
    before = bag.read_bytes()
    assert (
        cli.main(["offline", str(bag), "--urdf", "planar_2r", "--json", str(bag)]) == 2
    )
    assert f"--json {bag} is an input of this command (the log {bag})" in error_line(
        capsys
    )
    folder = tmp_path / "ros2"
    write_bag(folder, "mcap", arm_messages(arm, slice(0, 10)))
    for target in (folder / "metadata.yaml", next(folder.glob("*.mcap"))):
        argv = ["bag2csv", str(folder), "--out", str(target)]
        assert cli.main(argv) == 2
        assert f"is an input of this command (the log {folder})" in error_line(capsys)
    assert bag.read_bytes() == before


def test_bag2csv_writes_the_log_the_commands_read(arm, tmp_path, capsys):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm))
    out = tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out), "--quiet"]) == 0
    names, stamps, q, _ = arm
    log = read_log(out, names)
    reference = read_log(csv_log(tmp_path / "log.csv", arm), names)
    assert np.array_equal(log.q, reference.q) and np.array_equal(log.tau, reference.tau)
    assert log.time_offset == reference.time_offset
    states = read_joint_states(bag, ["joint2"])
    assert np.array_equal(states.position[:, 0], q[:, 1])
    assert np.array_equal(states.stamps, stamps)


def test_the_tiago_recording_as_a_bag_reads_through_the_drive_file(tmp_path, capsys):
    """The TIAGo's two CSV files as one JointState bag (20 s excerpt, with a head
    joint in each message): --drive tiago reads its `- <joint>_position` and
    `- <joint>_effort` columns from the bag; the estimate is the CSV files'."""

    def columns(path):
        lines = path.read_text().splitlines()
        header = lines[0].split(",")
        rows = np.array(
            [[float(x) for x in line.split(",")] for line in lines[2001:4001]]
        )
        return header, rows, lines[0] + "\n" + "\n".join(lines[2001:4001]) + "\n"

    p_header, p_rows, p_text = columns(TIAGO / "tiago_position.csv")
    e_header, e_rows, e_text = columns(TIAGO / "tiago_effort.csv")
    (tmp_path / "p.csv").write_text(p_text)
    (tmp_path / "e.csv").write_text(e_text)
    messages = []
    for k in range(p_rows.shape[0]):
        stamp = EPOCH + round(p_rows[k, 0] * 1e9)
        names = ["head_1_joint", *TIAGO_JOINTS[::-1]]
        p = [0.1, *(p_rows[k, p_header.index(f"- {j}_position")] for j in names[1:])]
        e = [0.0, *(e_rows[k, e_header.index(f"- {j}_effort")] for j in names[1:])]
        messages.append((0, stamp, stamp, names, p, e))
    bag = tmp_path / "tiago"
    write_bag(bag, "mcap", messages)
    options = ["--urdf", "tiago_no_hand", "--joints", ",".join(TIAGO_JOINTS)]
    options += ["--drive", "tiago", "--split", "0.6", "--quiet"]
    on_bag, _ = run_json(capsys, ["offline", str(bag), *options], tmp_path / "b.json")
    files = [str(tmp_path / "p.csv"), str(tmp_path / "e.csv")]
    on_csv, _ = run_json(capsys, ["offline", *files, *options], tmp_path / "c.json")
    assert on_bag["parameters"] == on_csv["parameters"]
    assert on_bag["validation"]["estimates"] == on_csv["validation"]["estimates"]
    # dynid bag2csv with the command's --urdf, --joints and --drive writes the
    # export that command read (the drive file's columns, its time unit): the
    # same estimate. Its plain-format file (q_, tau_, ns stamps) was all it wrote,
    # which --drive tiago refuses ("no column(s) '- torso_lift_joint_position'").
    export = tmp_path / "export.csv"
    argv = ["bag2csv", str(bag), "--out", str(export), *options[:6]]
    assert cli.main(argv) == 0, capsys.readouterr().err
    header = export.read_text().split("\n", 1)[0].split(",")
    assert header[:2] == ["t", "- torso_lift_joint_position"]
    assert header[-1] == "- arm_7_joint_effort" and len(header) == 17
    on_export, _ = run_json(
        capsys, ["offline", str(export), *options], tmp_path / "x.json"
    )
    assert on_export["parameters"] == on_bag["parameters"]
    assert on_export["validation"]["estimates"] == on_bag["validation"]["estimates"]


def test_a_drive_file_whose_columns_no_message_gives_is_named_once(
    arm, tmp_path, capsys
):
    """The wrist4 drive file names motor encoders ('enc_m1'), which no JointState
    field gives: the message said '--drive drive file F: column ...'."""
    names, stamps, q, tau = arm
    bag = tmp_path / "log.bag"
    write_bag(
        bag, "ros1", [(0, stamps[k], stamps[k], names, q[k], tau[k]) for k in range(20)]
    )
    data = ROOT / "tests" / "data"
    options = [
        "--urdf",
        str(data / "wrist4.urdf"),
        "--drive",
        str(data / "wrist4.toml"),
    ]
    for argv in (
        ["offline", str(bag), *options],
        ["bag2csv", str(bag), "--out", str(tmp_path / "x.csv"), *options],
    ):
        assert cli.main(argv) == 2
        line = error_line(capsys)
        assert f"log {bag}: drive file {data / 'wrist4.toml'}: column 'enc_m1'" in line
        assert "--drive drive file" not in line


def test_bag2csv_takes_urdf_and_lock_only_with_a_drive_file(arm, tmp_path, capsys):
    names, stamps, q, tau = arm
    bag = tmp_path / "log.bag"
    write_bag(
        bag, "ros1", [(0, stamps[k], stamps[k], names, q[k], tau[k]) for k in range(20)]
    )
    out = str(tmp_path / "out.csv")
    assert cli.main(["bag2csv", str(bag), "--out", out, "--urdf", "planar_2r"]) == 2
    assert "--urdf is for --drive" in error_line(capsys)
    assert cli.main(["bag2csv", str(bag), "--out", out, "--drive", "tiago"]) == 2
    assert "needs --urdf" in error_line(capsys)
    assert not pathlib.Path(out).exists()


def test_bag2csv_keeps_the_most_frequent_joints_and_empty_efforts(
    arm, tmp_path, capsys
):
    names, stamps, q, tau = arm
    messages = []
    for k in range(40):
        e = [] if k == 7 else tau[k]  # one message without efforts
        messages.append((0, stamps[k], stamps[k], names, q[k], e))
        if k % 4 == 0:
            messages.append((0, stamps[k], stamps[k], ["gripper"], [0.0], [0.0]))
    messages.append((0, stamps[40], stamps[40], names, q[40][:1], tau[40]))  # bad
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", messages)
    out = tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "wrote" in captured.out and "joints joint1, joint2" in captured.out
    assert "skipped 10 of 51 message(s)" in captured.err
    assert "(their joints: gripper)" in captured.err
    assert "skipped 1 message(s) on /joint_states whose position[]" in captured.err
    assert "1 message(s) on /joint_states have an empty effort[]" in captured.err
    rows = out.read_text().splitlines()
    assert len(rows) == 41 and rows[8].endswith(",nan,nan")


def test_a_bag_of_positions_is_replayed_and_refused_for_identification(
    arm, tmp_path, capsys
):
    names, stamps, q, _ = arm
    messages = [(0, stamps[k], stamps[k], names, q[k], []) for k in range(0, 2000)]
    bag = tmp_path / "positions.bag"
    write_bag(bag, "ros1", messages)
    html = tmp_path / "page.html"
    argv = ["replay", "planar_2r", str(bag), "--html", str(html), "--quiet"]
    assert cli.main(argv) == 0
    assert html.stat().st_size > 0
    capsys.readouterr()
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    assert error_line(capsys).endswith(
        f"ROS bag {bag}: the messages on /joint_states carry no effort[] (torques), "
        "needed for column 'tau_joint1'."
    )


def test_validate_and_payload_read_a_bag_as_the_csv(arm, tmp_path, capsys):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm))
    log = csv_log(tmp_path / "log.csv", arm)
    fit = tmp_path / "fit.json"
    offline(capsys, log, fit)
    for command in ("validate", "payload"):
        argv = [command, "--urdf", "planar_2r", "--params", str(fit), "--quiet"]
        on_bag, _ = run_json(capsys, [*argv, str(bag)], tmp_path / "b.json")
        on_csv, _ = run_json(capsys, [*argv, str(log)], tmp_path / "c.json")
        assert on_bag == on_csv, command
    held = ["offline", str(log), "--urdf", "planar_2r", "--validate", str(bag)]
    on_bag, _ = run_json(capsys, held, tmp_path / "v.json")
    assert on_bag["validation"]["log"]["description"] == str(bag)
    assert on_bag["validation"]["log"]["samples"] == 8001


def test_the_export_is_written_a_block_at_a_time(arm, tmp_path, capsys, monkeypatch):
    from drake_dynid import ros_bag

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 100)))
    whole = tmp_path / "whole.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(whole), "--quiet"]) == 0
    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 7)  # 100 = 14 blocks of 7 + 2
    blocks = tmp_path / "blocks.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(blocks), "--quiet"]) == 0
    assert blocks.read_bytes() == whole.read_bytes()
    assert len(whole.read_text().splitlines()) == 101


def test_a_locked_joint_moving_in_the_bag_is_named_as_in_the_csv(arm, tmp_path, capsys):
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm))
    log = csv_log(tmp_path / "log.csv", arm)
    said = {}
    for path in (bag, log):
        argv = ["offline", str(path), "--urdf", "planar_2r", "--joints", "joint1"]
        cli.main([*argv, "--quiet"])
        err = capsys.readouterr().err
        said[path] = [
            line.split(": ", 3)[3]
            for line in err.splitlines()
            if "not identified move" in line
        ]
    assert said[bag] == said[log] and len(said[bag]) == 1
    assert said[bag][0].startswith(
        "joint(s) not identified move in the log (joint2 from -2.36 to 1.9)"
    )


@pytest.mark.parametrize("kind", ["sqlite3", "ros1"])
def test_a_bag_is_exported_in_bounded_memory(tmp_path, capsys, monkeypatch, kind):
    """dynid bag2csv's Python peak (tracemalloc, a warmed second run) on 2000 and
    8000 messages, 256 a block: 0.60 and 0.79 MB (before: every message's
    arrays, 0.60 and 1.21 MB). rosbags reads a sqlite3 bag without a
    per-message index; a ROS 1 bag (16 kB chunks) is read a chunk at a time
    (ros_bag._Ros1Chunks): 0.65 and 0.84 MB (rosbags' reader, its index of
    every message: 0.92 and 1.94 MB). The smaller of two measured runs: a
    one-off resize of the interpreter's tables (sys.intern's, 3.7 MB after
    the tests before it) can land in one."""
    import gc
    import tracemalloc

    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 64)  # held back for the order
    peaks = []
    for count in (2000, 8000):
        messages = [
            (0, EPOCH + k * 10**6, EPOCH + k * 10**6, ["a", "b"], [k, -k], [1.0, 2.0])
            for k in range(count)
        ]
        bag = tmp_path / (f"log{count}" + (".bag" if kind == "ros1" else ""))
        write_bag(bag, kind, messages, setup=small_chunks)
        argv = ["bag2csv", str(bag), "--out", str(tmp_path / "out.csv"), "--quiet"]
        assert cli.main(argv) == 0  # imports, caches
        measured = []
        for _ in range(2):
            gc.collect()
            tracemalloc.start()
            try:
                assert cli.main(argv) == 0
                measured.append(tracemalloc.get_traced_memory()[1])
            finally:
                tracemalloc.stop()
        peaks.append(min(measured))
        lines = (tmp_path / "out.csv").read_text().splitlines()
        assert len(lines) == count + 1
    assert peaks[1] < 1.6 * peaks[0], peaks


def small_chunks(writer):
    """A ROS 1 writer's chunks of 16 kB (1 MB by default): a long bag's many."""
    if isinstance(writer, Writer1):
        writer.chunk_threshold = 16 << 10


@pytest.mark.parametrize("compression", [None, "BZ2", "LZ4"])
def test_a_ros1_bag_is_read_a_chunk_at_a_time_as_rosbags_reads_it(
    arm, tmp_path, monkeypatch, compression
):
    """The chunks read one at a time (ros_bag._Ros1Chunks, bounded memory)
    give the export of rosbags' reader byte for byte: 16 kB chunks, receive
    times out of order inside them and across their ends, another JointState
    topic interleaved, a receive clock that jumps back (chunks overlapping in
    time: merged); more than ROS1_OVERLAP chunks at one instant are left to
    rosbags' reader."""
    from drake_dynid import ros_bag

    def setup(writer):
        small_chunks(writer)
        if compression:
            writer.set_compression(Writer1.CompressionFormat[compression])

    messages = arm_messages(arm, slice(0, 3000))
    for k in range(0, 3000, 7):  # received in another order than recorded
        messages[k], messages[k + 1] = messages[k + 1], messages[k]
    messages += [(1, m[1], m[2] + 1, ["x"], [0.0], [0.0]) for m in messages[::5]]
    messages.sort(key=lambda m: m[2] // 10**7)  # the head's among them
    late = messages[2000:] + messages[:2000]  # a receive clock that jumps back
    opened = ros_bag._Ros1Chunks.open
    walked = []

    def export(bag, out, walk):
        def spy(path):
            walked.append(opened(path) if walk else None)
            return walked[-1]

        monkeypatch.setattr(ros_bag._Ros1Chunks, "open", spy)
        ros_bag.export_bag(
            bag,
            out,
            None,
            lambda names, efforts: [f"q_{n}" for n in names],
            topic="/joint_states",
        )
        return out.read_bytes()

    for name, order in (("ordered", messages), ("late", late)):
        bag = tmp_path / f"{name}.bag"
        write_bag(bag, "ros1", order, ("/joint_states", "/head/states"), setup=setup)
        chunks = export(bag, tmp_path / f"{name}.csv", True)
        assert chunks == export(bag, tmp_path / f"{name}-rosbags.csv", False), name
        assert chunks.count(b"\n") == 3001
    assert walked[0] is not None and len(walked[0].chunks) > 10
    assert walked[2] is not None  # the jump back: two chunks at a time
    monkeypatch.setattr(ros_bag, "ROS1_OVERLAP", 1)
    assert opened(str(tmp_path / "late.bag")) is None


def test_a_first_block_that_misjudges_the_bag_is_written_again(
    arm, tmp_path, capsys, monkeypatch
):
    """Blocks of 7: the first blocks have zero stamps, no efforts and a gripper's
    messages only; the export (to a file, and to a named pipe: a reading pass first) is
    that of one block holding the whole bag, written in a second pass."""
    from drake_dynid import ros_bag

    names, stamps, q, tau = arm
    messages = [(0, 0, stamps[k], ["g"], [0.5], []) for k in range(12)]
    for k in range(12, 60):
        stamp = 0 if k < 30 else stamps[k]
        e = [] if k < 40 else tau[k]
        messages.append((0, stamp, stamps[k], names, q[k], e))
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", messages)
    whole = tmp_path / "whole.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(whole), "--quiet"]) == 0
    notes = capsys.readouterr().err
    assert "skipped 12 of 60" in notes and "28 message(s)" in notes
    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 7)
    blocks = tmp_path / "blocks.csv"
    done = ros_bag.export_bag(
        bag,
        blocks,
        None,
        lambda n, e: [*(f"q_{j}" for j in n), *(f"tau_{j}" for j in n)],
    )
    assert done.passes == 3 and done.joint_names == tuple(names)
    assert blocks.read_bytes() == whole.read_bytes()
    import os
    import threading

    pipe = tmp_path / "pipe"
    os.mkfifo(pipe)
    read = []
    reader = threading.Thread(target=lambda: read.append(pipe.read_bytes()))
    reader.start()
    try:
        assert cli.main(["bag2csv", str(bag), "--out", str(pipe), "--quiet"]) == 0
    finally:
        reader.join(timeout=30)
    assert read == [whole.read_bytes()]
    rows = whole.read_text().splitlines()
    assert len(rows) == 49 and rows[1].startswith("0,") and rows[1].endswith(",nan,nan")


def test_bag2csv_of_a_file_that_is_no_bag_says_so(tmp_path, capsys):
    """It said 'a ROS 2 storage file is read with its bag folder's metadata.yaml'
    of a CSV file."""
    log = tmp_path / "log.csv"
    log.write_text("t,q_a\n0,0\n")
    assert cli.main(["bag2csv", str(log), "--out", str(tmp_path / "o.csv")]) == 2
    assert error_line(capsys).endswith(
        f"ROS bag {log}: not a ROS bag by its name (a ROS 1 .bag file, a ROS 2 bag "
        "folder holding metadata.yaml, or its .db3 / .mcap file)."
    )


def test_messages_recorded_out_of_stamp_order_are_written_in_stamp_order(
    arm, tmp_path, capsys
):
    """header.stamp is when q and τ were measured; the receive order is the
    transport's. Twelve pairs of messages swapped in the bag: the estimate is the
    clean log's (before: 'time stamps are not increasing at row 103 ... sort the
    log by time', which a bag's user cannot do; helper-79's review)."""
    messages = arm_messages(arm)
    for k in range(100, 7900, 700):  # received in order, stamps swapped
        early, late = messages[k], messages[k + 1]
        messages[k] = (0, late[1], early[2], *late[3:])
        messages[k + 1] = (0, early[1], late[2], *early[3:])
    bag = tmp_path / "log.bag"
    _, err = bag_fit_is_the_csv_fit(capsys, tmp_path, arm, bag, "ros1", messages)
    assert (
        f"log {bag}: 12 message(s) on /joint_states were recorded after one with a "
        "later header.stamp: written in stamp order." in err
    )


def test_a_message_later_than_the_hold_back_is_placed_and_a_late_repeat_dropped(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: the export holds back REORDER_ROWS messages to put them
    in stamp order (bounded memory); a message recorded later than that stayed
    where it was, and the CSV reader dropped it as a stamp going back ('dropped
    row 2718 (t = 1.700000001e+18): time stamp(s) off the grid'), its sample
    then made up by the gap filling; a message repeated that late was written
    twice and dropped so too. Such messages are now kept aside (LATE_RUN rows in
    memory, then sorted temporary files) and merged into the export at its end,
    a repeat (the same stamp and values) dropped there: four messages 900 to
    4500 messages late and a repeat 3000 messages after its first give the
    export of the bag in order, byte for byte, and the clean CSV's estimate.
    Written to standard output, which cannot be rewritten, they are refused
    with their count and lateness."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    monkeypatch.setattr(ros_bag, "LATE_RUN", 3)  # sorted runs in temporary files
    ordered = arm_messages(arm)
    messages = list(ordered)
    moves = ((7000, 7900), (1000, 3000), (1500, 6000), (1501, 6000))
    for k, after in moves:  # received just after message `after`
        late = ordered[k]
        messages.remove(late)
        at = messages.index(ordered[after]) + 1
        while messages[at][1] < late[1]:  # after the ones moved there before
            at += 1
        messages.insert(at, (0, late[1], messages[at - 1][2] + 1, *late[3:]))
    at = messages.index(ordered[5000]) + 1
    repeat = ordered[2000]
    messages.insert(at, (0, repeat[1], messages[at - 1][2] + 1, *repeat[3:]))
    bag = tmp_path / "late.bag"
    _, err = bag_fit_is_the_csv_fit(capsys, tmp_path, arm, bag, "ros1", messages)
    said = [line for line in err.splitlines() if "stamp order" in line]
    assert len(said) == 1, err
    assert (
        f"log {bag}: 4 message(s) on /joint_states were recorded after one with a "
        "later header.stamp: written in stamp order (4 of them more than 100 "
        "messages late, up to 4." in said[0]
    ), said
    assert said[0].endswith(" s: placed by a merge of the export at its end).")
    assert (
        f"log {bag}: dropped 1 message(s) on /joint_states repeating the one before "
        "(the same header.stamp and values)." in err
    )
    assert "off the grid" not in err and "filled" not in err, err
    in_order = tmp_path / "ordered.bag"
    write_bag(in_order, "ros1", ordered)
    exports = []
    for source in (bag, in_order):
        out = tmp_path / f"{source.stem}.csv"
        assert cli.main(["bag2csv", str(source), "--out", str(out), "--quiet"]) == 0
        exports.append(out.read_bytes())
    assert exports[0] == exports[1]
    assert cli.main(["bag2csv", str(bag), "--out", "-"]) == 2
    line = error_line(capsys)
    assert (
        f"ROS bag {bag}: 5 message(s) were recorded more than 100 messages after "
        "a later-stamped one (up to 4." in line
    ), line
    assert "write it to a file (--out FILE)" in line, line


def test_messages_without_one_value_per_name_are_named_not_joints_missing(
    tmp_path, capsys
):
    """A publisher that names 3 joints but sends 2 efforts (every message malformed)
    was told 'no message on /joint_states holds every joint needed (a, b, c)',
    though every message holds them; and without --joints the most frequent set
    was chosen counting the malformed messages: 24 such messages beat 16 good
    ones of [a, b], and the export failed. Now the most frequent set of
    well-formed messages is read (the 16) and the error says what is wrong."""

    def message(k, names, efforts):
        p = [0.1 * k, -0.1 * k, 0.3][: len(names)]
        return (0, EPOCH + k * 10**6, EPOCH + k * 10**6, names, p, efforts)

    messages = [message(k, ["a", "b"], [1.0, 2.0]) for k in range(16)]
    messages += [message(k, ["a", "b", "c"], [1.0, 2.0]) for k in range(16, 40)]
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", messages)
    out = tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert out.read_text().splitlines()[0] == "t,q_a,q_b,tau_a,tau_b"
    assert len(out.read_text().splitlines()) == 17
    assert "skipped 24 of 40 message(s)" in err
    argv = ["bag2csv", str(bag), "--out", str(out), "--joints", "a,b,c"]
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert "24 message(s) on /joint_states hold every joint needed" in line, line
    assert "one value per name[]" in line, line


def test_a_full_disk_while_exporting_names_the_bag_and_the_temporary_folder(
    arm, tmp_path, capsys, monkeypatch
):
    """The commands export a bag to a temporary folder: a full disk there said
    '[Errno 28] No space left on device: '/tmp/dynid-bag-60t35d_9/log.bag.csv'',
    a file the user never named and that is gone when the message is read. Now
    the bag, the temporary folder and TMPDIR are named."""
    import errno
    import tempfile

    from drake_dynid import ros_bag

    def full(stream, cells, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 200)))
    monkeypatch.setattr(ros_bag, "_write_block", full)
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    line = error_line(capsys)
    assert line.startswith(f"dynid offline: error: ROS bag {bag}: "), line
    assert f"its CSV export in {tempfile.gettempdir()}" in line, line
    assert "No space left on device" in line and "TMPDIR" in line, line
    assert "dynid-bag-" not in line, line


def test_a_message_recorded_twice_is_written_once(arm, tmp_path, capsys):
    """A message recorded twice (the same header.stamp and values: a bag recorded
    from two bridges, a replayed topic) was 'duplicated time stamp', exit 2; it
    is dropped with a warning counting it (helper-79's review). Two messages with
    one stamp and different values stay the reader's error."""
    messages = arm_messages(arm)
    for k in (2000, 5000):
        messages.insert(k + 1, messages[k])
    bag = tmp_path / "log.bag"
    _, err = bag_fit_is_the_csv_fit(capsys, tmp_path, arm, bag, "ros1", messages)
    assert (
        f"log {bag}: dropped 2 message(s) on /joint_states repeating the one before "
        "(the same header.stamp and values)." in err
    )
    k = 3000
    other = messages[k]
    messages.insert(k + 1, (*other[:4], other[4] + 0.1, other[5]))
    bag = tmp_path / "other.bag"
    write_bag(bag, "ros1", messages)
    argv = ["offline", str(bag), "--urdf", "planar_2r", "--quiet"]
    assert cli.main(argv) == 2
    assert "duplicated time stamp at row 3002" in capsys.readouterr().err


def test_a_bag_of_many_joints_is_named_in_short_lines(tmp_path, capsys):
    """A bag of 2000 joints: every list of its joints (the error's sets of
    names, the skipped messages' note) names the first 20 and counts the rest
    (16 kB lines before)."""
    wide = [f"j{k}" for k in range(2000)]
    bag = tmp_path / "log.bag"
    messages = [(0, EPOCH + k, EPOCH + k, wide, [0.0] * 2000, []) for k in (1, 2)]
    write_bag(bag, "ros1", messages)
    assert cli.main(["bag2csv", str(bag), "--out", str(tmp_path / "wide.csv")]) == 0
    assert capsys.readouterr().out.endswith(
        "2 messages of /joint_states, joints j0, j1, j2, j3, j4, j5, j6, j7, j8, "
        "j9, j10, j11, j12, j13, j14, j15, j16, j17, j18, j19 and 1980 more\n"
    )
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    assert error_line(capsys).endswith(
        "holds every joint needed (joint1, joint2); its messages name: [j0, j1, "
        "j10, j100, j1000, j1001, j1002, j1003, j1004, j1005, j1006, j1007, j1008, "
        "j1009, j101, j1010, j1011, j1012, j1013, j1014 and 1980 more]."
    )
    many = [(0, EPOCH + k, EPOCH + k, ["a"], [k], [0.0]) for k in range(3, 9)]
    write_bag(tmp_path / "two.bag", "ros1", messages + many)
    out = tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(tmp_path / "two.bag"), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "(their joints: j0, j1, j10, " in err and "j1014 and 1980 more)" in err
    assert max(len(line) for line in err.splitlines()) < 600, err


def test_topic_without_a_bag_is_refused(arm, tmp_path, capsys):
    """--topic with CSV logs only was ignored without a word (a bag's fit then
    validated on a CSV file by mistake): an error naming the option and the
    file, in every command taking it and in a fleet; with a bag among the logs
    (--validate's included) it is read for the bag."""
    log = csv_log(tmp_path / "log.csv", arm)
    other = csv_log(tmp_path / "other.csv", arm, slice(0, 4000))
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm))
    fit = tmp_path / "fit.json"
    offline(capsys, log, fit)
    topic = ["--topic", "/joint_states"]
    model = ["--urdf", "planar_2r"]
    refused = {
        "offline": ["offline", str(log), *model],
        "identify": ["identify", str(log), *model],
        "payload": ["payload", str(log), *model, "--params", str(fit)],
        "validate": ["validate", str(log), *model, "--params", str(fit)],
        "replay": ["replay", "planar_2r", str(log), "--html", str(tmp_path / "r.html")],
        "offline --validate": ["offline", str(log), *model, "--validate", str(other)],
    }
    for name, argv in refused.items():
        assert cli.main([*argv, *topic]) == 2, name
        line = error_line(capsys)
        assert "error: --topic /joint_states: no log is a ROS bag (" in line, name
        assert line.endswith(
            "a CSV log has no topic: leave the option out, or give the bag."
        ), name
    assert cli.main([*refused["offline"], *topic]) == 2
    assert error_line(capsys) == (
        f"dynid offline: error: --topic /joint_states: no log is a ROS bag ({log}); "
        "a CSV log has no topic: leave the option out, or give the bag."
    )
    # A bag among the logs: the topic is the bag's.
    on_bag, _ = run_json(
        capsys,
        ["offline", str(log), *model, "--validate", str(bag), *topic],
        tmp_path / "v.json",
    )
    assert on_bag["validation"]["log"]["description"] == str(bag)
    out = tmp_path / "fleet"
    fleet = ["fleet", "offline", str(log), str(other), *model, "--out-dir", str(out)]
    assert cli.main([*fleet, "--jobs", "1", *topic]) == 2
    assert error_line(capsys).endswith(
        f"--topic /joint_states: no log is a ROS bag ({log}, {other}); a CSV log "
        "has no topic: leave the option out, or give the bag."
    )
    fleet[2] = str(bag)  # a bag and a CSV file: each read, the topic the bag's
    assert cli.main([*fleet, "--jobs", "1", "--quiet", *topic]) == 0
    capsys.readouterr()
    settings = [
        json.loads((out / f"{name}.json").read_text())["settings"]
        for name in ("log", "other")
    ]
    assert settings[0]["topic"] == "/joint_states" and "topic" not in settings[1]


def test_bag2csv_out_dash_writes_the_export_to_standard_output(
    arm, tmp_path, capsys, monkeypatch
):
    """--out - wrote a file named "-"; it is standard output (read in a first
    pass, never rewound: a redirected output may hold more), the bytes of the
    exported file."""
    monkeypatch.chdir(tmp_path)
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 500)))
    assert cli.main(["bag2csv", str(bag), "--out", "log.csv", "--quiet"]) == 0
    assert cli.main(["bag2csv", str(bag), "--out", "-"]) == 0
    captured = capsys.readouterr()
    assert captured.out == (tmp_path / "log.csv").read_text(), captured.err
    assert not (tmp_path / "-").exists()


@pytest.mark.parametrize(
    ("compression", "damage"),
    [(None, b"\xff\xff\xff\x7f"), ("BZ2", b"\x00" * 16), ("LZ4", b"\x00" * 16)],
)
def test_a_ros1_chunk_that_cannot_be_read_names_the_bag(
    arm, tmp_path, capsys, compression, damage
):
    """A damaged record inside a chunk (the index intact; uncompressed: its
    first record's size): read a chunk at a time, the error names the bag, as
    rosbags' reader's did. Found by a review: a compressed chunk whose bytes
    are damaged raised the decompressor's own error (bz2: OSError 'Invalid data
    stream'), which named no bag."""
    import struct

    from drake_dynid import ros_bag

    def setup(writer):
        small_chunks(writer)
        if compression:
            writer.set_compression(Writer1.CompressionFormat[compression])

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 3000)), setup=setup)
    with ros_bag._Ros1Chunks.open(str(bag)) as chunks:
        position = chunks.chunks[3][1]
    data = bytearray(bag.read_bytes())
    (size,) = struct.unpack_from("<I", data, position)
    start = position + 4 + size + 4  # the chunk's data
    data[start : start + len(damage)] = damage
    bag.write_bytes(bytes(data))
    assert cli.main(["bag2csv", str(bag), "--out", str(tmp_path / "x.csv")]) == 2
    line = error_line(capsys)
    assert line.startswith(f"dynid bag2csv: error: ROS bag {bag}: cannot be read ("), (
        line
    )


def test_a_missing_bag_is_named_not_the_output(tmp_path, capsys):
    """A bag path that does not exist: the error names the bag (it read
    '[Errno None] None: OUT.csv' in bag2csv, and in offline a full temporary
    folder), exit 2."""
    bag, out = tmp_path / "gone.bag", tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out)]) == 2
    assert error_line(capsys) == (
        f"dynid bag2csv: error: ROS bag {bag}: no such file or folder."
    )
    assert not out.exists()
    urdf = str(MODELS_DIR / "planar_2r.urdf")
    assert cli.main(["offline", str(bag), "--urdf", urdf]) == 2
    assert error_line(capsys) == (
        f"dynid offline: error: ROS bag {bag}: no such file or folder."
    )


def test_a_ros1_chunk_info_of_another_version_is_left_to_rosbags(arm, tmp_path, capsys):
    """The ROS bag 2.0 format's CHUNK_INFO records are version 1. Found by a
    review: the chunk-at-a-time reader (ros_bag._Ros1Chunks) read one of any
    version as if it were 1. Another version now leaves the bag to rosbags'
    reader, which refuses it by name (exit 2, the bag named)."""
    import struct

    from drake_dynid import ros_bag

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 300)))
    data = bytearray(bag.read_bytes())
    (index,) = struct.unpack_from("<Q", data, data.index(b"index_pos=") + 10)
    field = b"ver=" + struct.pack("<I", 1)
    at = data.index(field, index)  # the first CHUNK_INFO record's version
    data[at + 4 : at + 8] = struct.pack("<I", 2)
    bag.write_bytes(bytes(data))
    assert ros_bag._Ros1Chunks.open(str(bag)) is None
    assert cli.main(["bag2csv", str(bag), "--out", str(tmp_path / "x.csv")]) == 2
    line = error_line(capsys)
    assert line.startswith(f"dynid bag2csv: error: ROS bag {bag}: cannot be read ("), (
        line
    )
    assert "CHUNK_INFO version 2 is not supported" in line, line


def test_a_bag_of_non_uniform_stamps_is_refused_by_name(arm, tmp_path, capsys):
    """Found by a review: the CSV reader's refusal of non-uniform stamps
    (NonUniformSampling, which also carries the rows kept and the step) was
    raised again with the bag's name as ``type(error)(message)``, a TypeError:
    'internal error (a bug in drake_dynid ...)', exit 1, with a traceback. A
    bag whose steps range from 0.4 to 1.6 ms (a publisher without a timer) is
    now refused as its CSV export is, naming the bag, exit 2."""
    names, stamps, q, tau = arm
    steps = np.random.default_rng(0).uniform(0.4e6, 1.6e6, stamps.size - 1)
    uneven = stamps[0] + np.concatenate([[0], np.cumsum(steps)]).astype(np.int64)
    bag = tmp_path / "uneven.bag"
    write_bag(bag, "ros1", arm_messages((names, uneven, q, tau)))
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    line = error_line(capsys)
    assert f"log {bag}: non-uniform sampling: " in line, line
    assert "--resample" in line and "dynid-bag-" not in line, line


def test_a_full_tmpdir_is_named_not_the_export(arm, tmp_path, capsys, monkeypatch):
    """Found by a review: the messages recorded late are kept in temporary
    files (TMPDIR) and merged into the export at its end; a full TMPDIR (a
    small tmpfs) was said as the export's own error, '[Errno 28] No space left
    on device: OUT.csv', though OUT's disk had room. It now names the
    temporary folder and TMPDIR, exit 2, and OUT is not written."""
    import errno
    import tempfile

    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    monkeypatch.setattr(ros_bag, "LATE_RUN", 3)
    messages = arm_messages(arm, slice(0, 2000))
    late = messages.pop(300)  # received 1000 messages late
    messages.insert(1300, (0, late[1], messages[1299][2] + 1, *late[3:]))
    bag = tmp_path / "late.bag"
    write_bag(bag, "ros1", messages)

    class Full(io.StringIO):
        def write(self, text):
            raise OSError(errno.ENOSPC, "No space left on device")

        def writelines(self, lines):
            self.write("")

    monkeypatch.setattr(tempfile, "TemporaryFile", lambda *a, **k: Full())
    out = tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out)]) == 2
    line = error_line(capsys)
    assert (
        f"temporary files in {tempfile.gettempdir()} (the 1 message(s) recorded "
        "late, merged into the export at its end): No space left on device; set "
        "TMPDIR to a folder with room." in line
    ), line
    assert str(out) not in line and not out.exists(), line


def test_late_messages_are_placed_in_a_file_written_in_place(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: the merge of the messages recorded late reads the
    export back; files.write_whole opened its temporary file read-write for
    that, but a file it writes in place (a container's bind mount of one file:
    the rename fails with EBUSY; a folder where no other file can be made) was
    opened write-only, and such a bag was refused as if written to standard
    output ('... which standard output or a pipe cannot; write it to a file
    (--out FILE)'), exit 2, though --out named a file. Now written as the
    temporary file is: the export of the bag in order."""
    import errno

    from drake_dynid import files, ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    ordered = arm_messages(arm, slice(0, 2000))
    messages = list(ordered)
    late = messages.pop(300)  # received 1000 messages late
    messages.insert(1300, (0, late[1], messages[1299][2] + 1, *late[3:]))
    exports = []
    for name, source in (("late", messages), ("ordered", ordered)):
        bag = tmp_path / f"{name}.bag"
        write_bag(bag, "ros1", source)
        out = tmp_path / f"{name}.csv"
        out.write_text("previous")
        with monkeypatch.context() as patch:

            def busy(*args, **kwargs):
                raise OSError(errno.EBUSY, "Device or resource busy")

            patch.setattr(files.os, "replace", busy)
            assert cli.main(["bag2csv", str(bag), "--out", str(out), "--quiet"]) == 0
        exports.append(out.read_bytes())
    assert exports[0] == exports[1]
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_the_lateness_said_is_from_the_newest_message_recorded(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: the note gave a late message's lateness from the
    newest message written, which lags the newest recorded by the messages held
    back and the block being read (up to 20 480 messages: 20 s at 1 kHz): a
    message recorded 0.999 s after its time was said 'up to 0.88 s' late."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    messages = arm_messages(arm, slice(0, 2000))
    late = messages.pop(300)  # stamp 0.300 s, received after the one of 1.299 s
    messages.insert(1299, (0, late[1], messages[1298][2] + 1, *late[3:]))
    bag = tmp_path / "late.bag"
    write_bag(bag, "ros1", messages)
    out = tmp_path / "out.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out)]) == 0
    assert "(1 of them more than 100 messages late, up to 0.999 s: placed" in (
        capsys.readouterr().err
    )


def test_late_messages_keep_few_temporary_files_open(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: the messages recorded late were sorted into one
    temporary file per LATE_RUN (16 384) of them, all open until the merge at
    the end: the open-file limit (1024) was reached at some 8 M late messages.
    Now LATE_FAN_IN runs of a level are merged into one of the next: with runs
    of 3 rows or more and a fan-in of 3, 60 late messages (15 runs: 16 files
    open at once before, the runs and the export's copy) keep at most 7 open
    (6 measured: 2 a level and the merge's new run), and the export is the
    bag in order, byte for byte."""
    import tempfile

    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 12)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    monkeypatch.setattr(ros_bag, "LATE_RUN", 3)
    monkeypatch.setattr(ros_bag, "LATE_FAN_IN", 3, raising=False)
    ordered = arm_messages(arm, slice(0, 1200))
    messages = list(ordered)
    for j in range(60):  # one message in five of 200-499, each 400 messages late
        late = ordered[200 + 5 * j]
        messages.remove(late)
        at = messages.index(ordered[600 + 5 * j]) + 1
        messages.insert(at, (0, late[1], messages[at - 1][2] + 1, *late[3:]))
    opened = []
    temporary = tempfile.TemporaryFile

    def counted(*args, **kwargs):
        stream = temporary(*args, **kwargs)
        opened.append(stream)
        most[0] = max(most[0], sum(not s.closed for s in opened))
        return stream

    most = [0]
    monkeypatch.setattr(tempfile, "TemporaryFile", counted)
    exports = [
        _exported(tmp_path, name, source, "--quiet")
        for name, source in (("late", messages), ("ordered", ordered))
    ]
    assert "(60 of them more than 100 messages late" in capsys.readouterr().err
    assert exports[0] == exports[1]
    assert 0 < most[0] <= 7, most
    assert all(s.closed for s in opened)


def test_late_messages_are_refused_on_standard_output_before_a_row_is_written(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: ``bag2csv --out -`` refused a bag whose messages are
    to be merged in (standard output cannot be rewritten) only at the end of
    the export, after streaming its rows (1301 lines here) to the pipe, exit 2
    after them. The pass that reads the bag before writing to standard output
    now counts those messages (the export's own rules, writing nothing): the
    same error, and nothing written."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    messages = arm_messages(arm, slice(0, 2000))
    late = messages.pop(300)  # received 1000 messages late
    messages.insert(1300, (0, late[1], messages[1299][2] + 1, *late[3:]))
    bag = tmp_path / "late.bag"
    write_bag(bag, "ros1", messages)
    assert cli.main(["bag2csv", str(bag), "--out", "-"]) == 2
    captured = capsys.readouterr()
    assert captured.out == "", captured.out[:200]
    assert (
        f"ROS bag {bag}: 1 message(s) were recorded more than 100 messages after "
        "a later-stamped one (up to 1 s late)" in captured.err
    ), captured.err


def _exported(tmp_path, name, messages, *options):
    """The bytes ``bag2csv`` writes (exit 0) for ``messages`` as a ROS 1 bag."""
    bag = tmp_path / f"{name}.bag"
    write_bag(bag, "ros1", messages)
    out = tmp_path / f"{name}.csv"
    code = cli.main(["bag2csv", str(bag), "--out", str(out), *options])
    assert code == 0, code
    return out.read_bytes()


def _export_stopped(arm, tmp_path, capsys, monkeypatch, error):
    """``(exit code, captured)`` of ``bag2csv --out -`` on a 2000-message bag
    whose third block's write raises ``error`` (blocks of 300, hold-back 100)."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 300)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 2000)))
    written = ros_bag._write_block
    calls = [0]

    def stopping(stream, cells, data):
        calls[0] += 1
        if calls[0] > 2:
            raise error
        written(stream, cells, data)

    monkeypatch.setattr(ros_bag, "_write_block", stopping)
    code = cli.main(["bag2csv", str(bag), "--out", "-"])
    return code, capsys.readouterr()


def test_an_export_to_standard_output_cut_by_an_error_is_never_read_whole(
    arm, tmp_path, capsys, monkeypatch
):
    """An export to standard output that stops on an error (here made to stop
    after its second block) cannot be taken back: its rows ended on a whole
    line, and a log saved from the pipe was read as the whole bag (500 of
    2000 messages, exit 0). Its last line now says it is incomplete, a row
    that the CSV readers refuse (exit 2)."""
    from drake_dynid import ros_bag

    written = ros_bag._write_block
    code, captured = _export_stopped(
        arm, tmp_path, capsys, monkeypatch, ValueError("made to fail")
    )
    assert code == 2
    assert "made to fail" in captured.err
    lines = captured.out.splitlines()
    assert len(lines) == 1 + 200 + 300 + 1, len(lines)  # the header, 2 blocks
    assert lines[-1] == (
        "# dynid: this export is incomplete; it stopped on an error: made to fail"
    )
    saved = tmp_path / "saved.csv"
    saved.write_text(captured.out)
    monkeypatch.setattr(ros_bag, "_write_block", written)
    assert cli.main(["offline", str(saved), "--urdf", "planar_2r"]) == 2
    # Named as such (a review: "row 502 has 1 cells; the header has 5." said
    # nothing of a cut export), by the plain reader, a joined file's, and
    # raw_log.read_raw_table, whose np.loadtxt skipped the '#' line: it read
    # the 500 rows as the whole log.
    said = (
        "row 502 says 'this export is incomplete; it stopped on an error: made "
        "to fail': the ROS bag's export to a pipe was cut short there, its rows "
        "are not the whole bag; export it again to a file (dynid bag2csv BAG "
        "--out LOG.csv)."
    )
    assert error_line(capsys).endswith(f"log {saved}: {said}")
    lines = saved.read_text().splitlines()
    times = tmp_path / "times.csv"
    times.write_text("".join(f"{line.split(',')[0]},0\n" for line in lines[:-1]))
    argv = ["offline", str(times), str(saved), "--urdf", "planar_2r"]
    assert cli.main(argv) == 2
    assert error_line(capsys).endswith(f"log {saved}: {said}")
    from drake_dynid.raw_log import read_raw_table

    with pytest.raises(ValueError, match=r"its last line says 'this export is"):
        read_raw_table(saved, ["q_joint1"], "t")


def test_an_export_to_standard_output_interrupted_says_it_is_incomplete(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: the incomplete-export line was written on an
    Exception only; Ctrl-C (KeyboardInterrupt) after the second block left
    501 whole lines on the pipe, read as the whole bag. Now it ends with the
    line too."""
    code, captured = _export_stopped(
        arm, tmp_path, capsys, monkeypatch, KeyboardInterrupt()
    )
    assert code != 0
    assert "dynid bag2csv: interrupted" in captured.err
    lines = captured.out.splitlines()
    assert len(lines) == 1 + 200 + 300 + 1, len(lines)
    assert lines[-1] == (
        "# dynid: this export is incomplete; it stopped on an error: KeyboardInterrupt"
    )


def stepped_back(messages, at, step):
    """``messages`` whose header clock is set back by ``step`` ns from ``at`` on
    (the receive times unchanged)."""
    return [
        (w, s - step if k >= at else s, *rest)
        for k, (w, s, *rest) in enumerate(messages)
    ]


def test_a_header_clock_set_back_is_named_with_when_and_how_much(arm, tmp_path, capsys):
    """Found by a review: a robot's clock set back (re-synchronised by NTP) 5 s
    into a recording made every later message older than the ones before it;
    they were put in stamp order, interleaving two stretches of the recording,
    and the reader refused the log for another cause: '1999 of 10000 samples
    (20 %) would be interpolated'. The messages late in a row (4001, to the
    end) are now named a clock set back: where (message, bag time), from and
    to which stamp, and what to do; 'bag2csv --stamps receive' exports the
    receive times, which the commands read (8001 rows, the clean 1 kHz grid)."""
    stamps = arm[1]
    messages = stepped_back(arm_messages(arm), 4000, 5 * 10**9 + 500_000)
    bag = tmp_path / "step.bag"
    write_bag(bag, "ros1", messages)
    assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
    line = error_line(capsys)
    assert line == (
        f"dynid offline: error: ROS bag {bag}: header.stamp on /joint_states steps "
        "back 4.9995 s at message 4001 (bag time 1700000004.00035 s, 4 s after "
        "the bag's first message): from 1700000003.999 s to 1699999998.9995 s, "
        "4001 message(s) in a row older than one recorded before them, a clock "
        "set back (a robot's clock re-synchronised, e.g. by NTP), not a "
        "transport's reordering; put in stamp order they would interleave the "
        "recording before and after the step. Export the bag with its receive "
        f"times, 'dynid bag2csv {bag} --joints joint1,joint2 --out LOG.csv "
        "--stamps receive', and give LOG.csv; or export each side of the step: "
        f"'dynid bag2csv {bag} --joints joint1,joint2 --out before.csv --to 4' "
        f"and 'dynid bag2csv {bag} --joints joint1,joint2 --out after.csv --from "
        "4' (the messages received before and from bag time 4 s), and give one."
    )
    with pytest.raises(ValueError, match=r"steps back 4\.9995 s at message 4001"):
        read_joint_states(bag)
    out = tmp_path / "received.csv"
    argv = ["bag2csv", str(bag), "--out", str(out), "--stamps", "receive"]
    assert cli.main([*argv, "--quiet"]) == 0
    assert "header.stamp" not in capsys.readouterr().err
    rows = out.read_text().splitlines()
    assert len(rows) == 8002 and rows[1].startswith(f"{stamps[0] + 350_000},")
    assert cli.main(["offline", str(out), "--urdf", "planar_2r", "--quiet"]) == 0


def test_a_clock_set_back_is_refused_on_standard_output_before_a_row(
    arm, tmp_path, capsys
):
    """A clock set back 0.2005 s, which the stamps pass again 200 messages
    later: named with those 200 messages, on standard output before a row is
    written (the pass that reads the bag first), and by read_joint_states."""
    messages = stepped_back(arm_messages(arm, slice(0, 3000)), 2000, 200_500_000)
    bag = tmp_path / "step"
    write_bag(bag, "mcap", messages)
    assert cli.main(["bag2csv", str(bag), "--out", "-"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert (
        "steps back 0.1995 s at message 2001 (bag time 1700000002.00035 s, 2 s "
        "after the bag's first message): from 1700000001.999 s to 1700000001.7995 s, "
        "200 message(s) in a row" in captured.err
    ), captured.err
    with pytest.raises(ValueError, match=r"steps back 0\.1995 s at message 2001"):
        read_joint_states(bag)


@pytest.mark.parametrize("run", [9, 10, 40])
def test_late_messages_in_a_row_filling_the_gap_they_left_are_no_clock_step(
    arm, tmp_path, capsys, run
):
    """A transport's reordering makes a message late alone; CLOCK_STEP_RUN (10)
    in a row were named a clock set back, 10 messages received 500 messages
    late in a row refused. They fill the gap they left, and the messages
    after them return to the original sequence (a clock set back makes every
    later message late: _Candidate): 9, 10 or 40 are placed, the export of
    the bag in order."""
    ordered = arm_messages(arm, slice(0, 2000))
    messages = list(ordered)
    moved = messages[1000 : 1000 + run]
    del messages[1000 : 1000 + run]
    at = messages.index(ordered[1500]) + 1
    received = messages[at - 1][2]
    messages[at:at] = [(0, m[1], received + 1 + j, *m[3:]) for j, m in enumerate(moved)]
    exports = [
        _exported(tmp_path, name, source, "--quiet")
        for name, source in (("late", messages), ("ordered", ordered))
    ]
    assert exports[0] == exports[1]


def test_a_clock_step_is_found_across_blocks():
    """The run of late messages is counted across the blocks fed (any split:
    the same step and length)."""
    from drake_dynid import ros_bag

    times = np.concatenate([np.arange(100), np.arange(50, 200)]) * 1000
    received = np.arange(times.size) + 7
    found = set()
    for size in (1, 3, 9, 10, 11, 64, 250):
        steps = ros_bag._Steps()
        for start in range(0, times.size, size):
            part = slice(start, start + size)
            values = received[part, None].astype(float)  # no two alike
            block = ros_bag._Block(times[part], received[part], values, values, None, 0)
            steps.add(times[part], block)
        steps.finish()
        found.add((steps.step, steps.length))
    assert found == {((100, 50_000, 107, 99_000), 49)}  # 50 to 98: older than 99


def test_a_burst_of_messages_sent_again_is_no_clock_step(arm, tmp_path, capsys):
    """Found by a review: 20 messages sent again in a burst (the same stamps
    and values, e.g. a driver re-sending its buffer after a reconnect) are
    older than the newest before them, 19 in a row: named a clock set back
    ('steps back 0.019 s at message 1501'), though the export drops them as
    repeats. A late message repeating one recorded before it is no longer
    counted late: the export is the bag without the burst's, 20 dropped."""
    ordered = arm_messages(arm, slice(0, 2000))
    received = ordered[1499][2]
    burst = [
        (0, m[1], received + 1 + j, *m[3:]) for j, m in enumerate(ordered[1480:1500])
    ]
    exports = [
        _exported(tmp_path, name, source)
        for name, source in (
            ("burst", [*ordered[:1500], *burst, *ordered[1500:]]),
            ("ordered", ordered),
        )
    ]
    assert exports[0] == exports[1]
    err = capsys.readouterr().err
    assert "dropped 20 message(s) on /joint_states repeating" in err, err
    states = read_joint_states(tmp_path / "burst.bag")
    assert states.stamps.size == 2000


def test_a_late_repeat_is_noted_dropped_not_written_in_stamp_order(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: a message recorded again 50 messages later (inside
    the hold-back) was noted twice by the export, '1 message(s) ... written in
    stamp order' and 'dropped 1 message(s) ... repeating', while it was only
    dropped (read_joint_states and a repeat merged at the end said so). Now
    the export counts a late message once its repeats are dropped: the
    notes of read_joint_states."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    messages = arm_messages(arm, slice(0, 1000))
    again = messages[250]
    messages.insert(301, (0, again[1], messages[300][2] + 1, *again[3:]))
    bag = tmp_path / "again.bag"
    write_bag(bag, "ros1", messages)
    out = tmp_path / "again.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out), "--quiet"]) == 0
    notes = [
        line.removeprefix("dynid bag2csv: note: ")
        for line in capsys.readouterr().err.splitlines()
    ]
    assert notes == [
        "dropped 1 message(s) on /joint_states repeating the one before (the "
        "same header.stamp and values)."
    ]
    assert list(read_joint_states(bag).notes) == notes


def test_read_joint_states_is_the_export_in_stamp_order_without_repeats(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: read_joint_states (the in-memory API) kept the bag's
    order and its repeats, while the export puts the messages in stamp order
    and drops a message repeating the one before: the two disagreed on any
    bag out of order (write_export of its arrays gave rows going back in
    time, twice the repeated ones). Now the arrays are the export's rows, byte
    for byte, with the same notes: 12 pairs swapped, a message 1000 late, 2
    messages recorded twice."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "EXPORT_ROWS", 256)
    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 100)
    messages = arm_messages(arm, slice(0, 2000))
    for k in range(100, 1300, 100):  # received in order, stamps swapped
        early, late = messages[k], messages[k + 1]
        messages[k] = (0, late[1], early[2], *late[3:])
        messages[k + 1] = (0, early[1], late[2], *early[3:])
    late = messages.pop(1450)  # received 400 messages late
    messages.insert(1850, (0, late[1], messages[1849][2] + 1, *late[3:]))
    for k in (500, 1600):
        messages.insert(k + 1, messages[k])
    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", messages)
    out = tmp_path / "export.csv"
    assert cli.main(["bag2csv", str(bag), "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    states = read_joint_states(bag)
    names = states.joint_names
    columns = [*(f"q_{j}" for j in names), *(f"tau_{j}" for j in names)]
    again = tmp_path / "again.csv"
    ros_bag.write_export(again, states, columns)
    assert again.read_bytes() == out.read_bytes()
    assert states.stamps.size == 2000 and np.all(np.diff(states.stamps) > 0)
    assert states.notes == (
        "13 message(s) on /joint_states were recorded after one with a later "
        "header.stamp: written in stamp order.",
        "dropped 2 message(s) on /joint_states repeating the one before (the same "
        "header.stamp and values).",
    )
    assert (
        "13 message(s) on /joint_states were recorded after one with a later "
        "header.stamp: written in stamp order (1 of them more than 100" in err
    ), err
    assert "dropped 2 message(s) on /joint_states repeating" in err, err


def advised(line):
    """The commands an error advises, quoted '...' (argv lists, 'dynid' dropped)."""
    import re
    import shlex

    return [shlex.split(c)[1:] for c in re.findall(r"'(dynid bag2csv [^']*)'", line)]


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_a_clock_step_error_gives_the_commands_that_export_each_side(
    arm, tmp_path, capsys, monkeypatch, kind
):
    """Found by a review: a header clock set back was refused with the advice
    'cut the bag at that bag time and read one side', but no dynid option cut
    a bag. bag2csv now reads a bag time range (--from, --to: seconds after
    the bag's first message, received at or after --from and before --to),
    and the error gives the commands with the step's bag time: run as
    printed, they export the two sides (2000 and 1000 rows, the stamps in
    order), and the receive-time export, without error."""
    messages = stepped_back(arm_messages(arm, slice(0, 3000)), 2000, 3 * 10**9)
    bag = tmp_path / ("step.bag" if kind == "ros1" else "step")
    write_bag(bag, kind, messages)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["bag2csv", str(bag), "--out", "log.csv"]) == 2
    commands = advised(error_line(capsys))
    assert [c[3:] for c in commands] == [
        ["LOG.csv", "--stamps", "receive"],
        ["before.csv", "--to", "2"],
        ["after.csv", "--from", "2"],
    ], commands
    stamps = arm[1]
    for argv, rows in zip(commands, (3000, 2000, 1000), strict=True):
        assert cli.main([*argv, "--quiet"]) == 0, capsys.readouterr().err
        assert read_log(argv[3], arm[0]).t.size == rows
    before = np.loadtxt(tmp_path / "before.csv", delimiter=",", skiprows=1)
    after = np.loadtxt(tmp_path / "after.csv", delimiter=",", skiprows=1)
    assert before[0, 0] == stamps[0] and before[-1, 0] == stamps[1999]
    assert after[0, 0] == stamps[2000] - 3 * 10**9
    assert after[-1, 0] == stamps[2999] - 3 * 10**9
    # Within a range given, the advice keeps its other bound.
    argv = ["bag2csv", str(bag), "--out", "log.csv", "--from", "0.5", "--to", "2.5"]
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert "at message 1501 in the bag time range read (0.5 s to 2.5 s)" in line
    assert [c[3:] for c in advised(line)][1:] == [
        ["before.csv", "--from", "0.5", "--to", "2"],
        ["after.csv", "--from", "2", "--to", "2.5"],
    ]


def test_a_bag_time_range_reads_only_its_messages(arm, tmp_path, capsys, monkeypatch):
    """--from and --to: the messages received in the range only, not read
    outside it (a clock step outside it is not seen: the export of 1.0 s to
    1.5 s of a bag whose clock steps back at 2 s is rows 1000 to 1499 of the
    CSV log, byte for byte), by the ROS 1 chunk reader (small chunks: those
    outside the range skipped), rosbags' ROS 1 reader and the ROS 2 one."""
    from drake_dynid import ros_bag

    messages = stepped_back(arm_messages(arm, slice(0, 3000)), 2000, 3 * 10**9)
    expected = csv_log(tmp_path / "expected.csv", arm, slice(1000, 1500)).read_bytes()
    opened = ros_bag._Ros1Chunks.open
    for kind, chunks in (("ros1", True), ("ros1", False), ("mcap", False)):
        bag = tmp_path / (f"{chunks}.bag" if kind == "ros1" else "b")
        write_bag(bag, kind, messages, setup=small_chunks if kind == "ros1" else None)
        monkeypatch.setattr(
            ros_bag._Ros1Chunks, "open", opened if chunks else lambda path: None
        )
        out = tmp_path / "range.csv"
        argv = ["bag2csv", str(bag), "--out", str(out), "--quiet"]
        code = cli.main([*argv, "--from", "1", "--to", "1.5"])
        assert code == 0, capsys.readouterr().err
        assert out.read_bytes() == expected, (kind, chunks)
        states = read_joint_states(bag, span=(1.0, 1.5))
        assert states.stamps.size == 500
    monkeypatch.setattr(ros_bag._Ros1Chunks, "open", opened)
    with opened(str(tmp_path / "True.bag")) as reader:
        assert len(reader.chunks) > 10
        origin = reader.start_time
        assert origin == EPOCH + 350_000
        second = reader.messages(reader.connections, origin + 10**9, origin + 2 * 10**9)
        read = [t - origin for _, t, _ in second]
        assert read == [k * 10**6 for k in range(1000, 2000)]


@pytest.mark.parametrize(
    ("options", "said"),
    [
        (["--from", "2", "--to", "1"], "--from 2.0 is not before --to 1.0"),
        (["--from", "1", "--to", "1"], "--from 1.0 is not before --to 1.0"),
        (["--from", "5"], "--from 5.0: beyond the bag, whose messages span 2.999 s"),
        (["--to", "3.5"], "--to 3.5: beyond the bag"),
    ],
)
def test_a_bag_time_range_outside_the_bag_is_refused(
    arm, tmp_path, capsys, options, said
):
    bag = tmp_path / "b.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 3000)))
    argv = ["bag2csv", str(bag), "--out", str(tmp_path / "o.csv"), *options]
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert said in line, line


@pytest.mark.parametrize("value", ["-1", "nan", "inf", "x"])
def test_a_bag_time_that_is_no_number_of_seconds_is_refused(tmp_path, capsys, value):
    argv = ["bag2csv", str(tmp_path / "b.bag"), "--out", "o.csv", "--from", value]
    with pytest.raises(SystemExit) as exit_:
        cli.main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert "seconds of bag time after the bag's first message" in err, err
    assert "Traceback" not in err


def test_a_bag_time_range_without_a_message_says_so(arm, tmp_path, capsys):
    """A range between two stretches of a recording holds no message: named
    with the range read."""
    messages = arm_messages(arm, slice(0, 3000))
    bag = tmp_path / "gap.bag"
    write_bag(bag, "ros1", messages[:1000] + messages[2000:])
    argv = ["bag2csv", str(bag), "--out", str(tmp_path / "o.csv")]
    assert cli.main([*argv, "--from", "1.2", "--to", "1.8"]) == 2
    line = error_line(capsys)
    assert line.endswith(
        "topic /joint_states holds no message in the bag time range read (1.2 s "
        "to 1.8 s)."
    ), line


def test_a_failed_merge_of_late_runs_closes_its_new_file(monkeypatch):
    """Found by a review: when the merge of LATE_FAN_IN runs into one of the
    next level failed (a full TMPDIR), the new temporary file was left open
    (deleted only when collected). It is now closed on the error, which
    names TMPDIR."""
    import errno
    import tempfile

    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "LATE_RUN", 2)
    monkeypatch.setattr(ros_bag, "LATE_FAN_IN", 2)
    made = []
    opened = tempfile.TemporaryFile

    class Full:
        """A temporary file whose writelines fails as on a full disk."""

        def __init__(self, file):
            self.file = file

        def __getattr__(self, name):
            return getattr(self.file, name)

        def __iter__(self):
            return iter(self.file)

        def writelines(self, lines):
            list(lines)
            raise OSError(errno.ENOSPC, "No space left on device")

    def temporary(*args, **kwargs):
        file = opened(*args, **kwargs)
        made.append(file)
        return Full(file) if len(made) == 3 else file  # the first merged run

    monkeypatch.setattr(tempfile, "TemporaryFile", temporary)
    late = ros_bag._Late()
    late.add("1,0\n2,0\n", "")
    with pytest.raises(OSError, match="No space left on device; set TMPDIR"):
        late.add("3,0\n4,0\n", "")
    assert len(made) == 3 and made[2].closed
    late.close()
    assert all(file.closed for file in made)


def test_a_clock_set_back_by_a_few_periods_is_named_a_clock_step(arm, tmp_path, capsys):
    """Found by a review: a header clock set back by fewer than CLOCK_STEP_RUN
    periods was refused downstream for another cause: 5.5 ms at 1 kHz (5
    messages late) as 'non-uniform sampling: 7031 of 8001 stamps ...', back
    0.2 s for 8 messages then forward as 'duplicated time stamp at row 3803'.
    Late messages stamped between, or on, the stamps of on-time messages
    recorded before them where none was missing (no gap a reordering left),
    SHORT_STEP_RUN (3) or more in a row, are now named a clock set back."""
    messages = arm_messages(arm)
    cases = (
        (
            stepped_back(messages, 4000, 5_500_000),
            "steps back 0.0045 s at message 4001 (bag time 1700000004.00035 s, 4 s "
            "after the bag's first message): from 1700000003.999 s to "
            "1700000003.9945 s, 5 message(s) in a row older than one recorded "
            "before them (fewer than 10, but each stamped between or on the stamps "
            "of messages recorded before it where none was missing: no gap that a "
            "transport's reordering left), a clock set back",
        ),
        (
            [
                (w, s - 200_000_000 if 3900 <= k < 3908 else s, *rest)
                for k, (w, s, *rest) in enumerate(messages)
            ],
            "steps back 0.199 s at message 3901 (bag time 1700000003.90035 s, 3.9 s "
            "after the bag's first message): from 1700000003.899 s to 1700000003.7 "
            "s, 8 message(s) in a row older than one recorded before them (fewer "
            "than 10",
        ),
    )
    for k, (source, said) in enumerate(cases):
        bag = tmp_path / f"step{k}.bag"
        write_bag(bag, "ros1", source)
        assert cli.main(["offline", str(bag), "--urdf", "planar_2r"]) == 2
        line = error_line(capsys)
        assert said in line, line


def test_late_bursts_filling_gaps_are_no_short_clock_step(arm, tmp_path):
    """No false alarm: two publishers interleaved (even and odd milliseconds),
    the odd one's messages received in bursts of 3 to 6 after the even one's
    later ones; and stamps with a 20 % jitter, bursts of 3 to 6 messages
    received 20 messages late: each late message fills the gap it left, the
    export is the bag in order's, byte for byte."""
    names, stamps, q, tau = arm
    rng = np.random.default_rng(1)
    jitter = (rng.uniform(-0.2, 0.2, 3000) * 1e6).astype(np.int64)
    jittered = (names, stamps[:3000] + jitter, q[:3000], tau[:3000])
    publishers = arm_messages(arm, slice(0, 3000))  # one connection: the stamps'
    for name, ordered in (
        ("publishers", publishers),
        ("jitter", arm_messages(jittered)),
    ):
        messages = list(ordered)
        for start, size in ((500, 3), (1200, 4), (2000, 6)):
            if name == "publishers":  # the odd ones after the even ones
                window = messages[start : start + 2 * size + 1]
                moved, rest = window[1::2], window[0::2]
                received = [m[2] for m in window]
                block = rest + moved
            else:  # received after the 20 next
                moved = messages[start : start + size]
                rest = messages[start + size : start + size + 20]
                received = [m[2] for m in moved + rest]
                block = rest + moved
            block = [
                (m[0], m[1], r, *m[3:]) for m, r in zip(block, received, strict=True)
            ]
            messages[start : start + len(block)] = block
        exports = [
            _exported(tmp_path, f"{name}-{label}", source, "--quiet")
            for label, source in (("late", messages), ("ordered", ordered))
        ]
        assert exports[0] == exports[1], name


def test_a_second_publisher_always_received_in_bursts_is_no_short_clock_step(
    arm, tmp_path
):
    """Found by a review: two publishers on one topic (even and odd
    milliseconds), the odd one's messages always received late, 4 at a time
    every 8 ms (a batching transport): the pool of on-time stamps held only
    the even one's 2 ms spacing, so each burst's stamps, 1 ms from an on-time
    one, were 'nearer than their smallest step' and the good bag was refused
    as a clock set back ('steps back 0.007 s at message 14 ... 4 message(s)
    in a row'). The smallest step is now that of every stamp recorded before
    the run, late ones too (the odd one's earlier bursts): exported as the
    bag in order, byte for byte."""
    ordered = arm_messages(arm, slice(0, 2000))
    arrival = [
        (k // 8 + 1) * 8 + 0.5 if k % 2 else k for k in range(len(ordered))
    ]  # [ms]: the odd ones after the even ones, in bursts of 4
    messages = [ordered[k] for k in np.argsort(arrival, kind="stable")]
    messages = [
        (m[0], m[1], o[2], *m[3:]) for m, o in zip(messages, ordered, strict=True)
    ]  # received in that order
    exports = [
        _exported(tmp_path, label, source, "--quiet")
        for label, source in (("late", messages), ("ordered", ordered))
    ]
    assert exports[0] == exports[1]


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_a_bag_time_range_ends_at_the_last_message_in_every_format(
    arm, tmp_path, capsys, kind
):
    """Found by a review: rosbags' ROS 2 end_time is the last message's
    receive time + 1 ns (its ROS 1 one the last message's), so a ROS 2 bag of
    3000 messages 1 ms apart was said to span 2.999000001 s, and --to
    2.999000001 read all 3000 where a ROS 1 bag refused it. Every format now
    spans 2.999 s, --to 2.999000001 is beyond the bag. Then found: --to the
    bag's length (2.999) read 2999 messages, the last one left out (received
    at --to, not before it); --to the bag's length now reads to its end (a
    bound inside the bag still excludes what is received at it: --to 2.998,
    2998 messages), --from 0 from its first message, --from 2.999 the last."""
    bag = tmp_path / ("b.bag" if kind == "ros1" else "b")
    write_bag(bag, kind, arm_messages(arm, slice(0, 3000)))
    out = tmp_path / "o.csv"
    argv = ["bag2csv", str(bag), "--out", str(out), "--quiet"]
    for options, rows in (
        (["--to", "2.999"], 3000),
        (["--from", "0", "--to", "2.999"], 3000),
        (["--to", "2.998"], 2998),
        (["--from", "0"], 3000),
        (["--from", "2.999"], 1),
        (["--from", "2.998", "--to", "2.999"], 2),
    ):
        assert cli.main([*argv, *options]) == 0, capsys.readouterr().err
        assert len(out.read_text().splitlines()) == rows + 1
        out.unlink()
    assert cli.main([*argv, "--to", "2.999000001"]) == 2
    line = error_line(capsys)
    assert line.endswith(
        "--to 2.999000001: beyond the bag, whose messages span 2.999 s of bag time "
        "(from its first message)."
    ), line


def test_a_clock_step_error_repeats_the_options_that_choose_the_columns(
    arm, tmp_path, capsys, monkeypatch
):
    """Found by a review: bag2csv --joints j2,j1 on a bag whose header clock
    is set back printed commands without --joints: run as printed, they
    exported the joints in the message's order (q_j1 first), not the export
    asked for. The commands now repeat --joints (and --drive, --urdf, --lock),
    quoted for a shell (a folder with a space and a quote in its name): run as
    printed, the three exports have the columns asked for (3000, 2000 and
    1000 rows)."""
    import re
    import shlex

    names = arm[0]
    messages = stepped_back(arm_messages(arm, slice(0, 3000)), 2000, 3 * 10**9)
    folder = tmp_path / "a robot's bags"
    folder.mkdir()
    bag = folder / "step.bag"
    write_bag(bag, "ros1", messages)
    monkeypatch.chdir(tmp_path)
    joints = f"{names[1]},{names[0]}"
    argv = ["bag2csv", str(bag), "--out", "log.csv", "--joints", joints]
    assert cli.main(argv) == 2
    line = error_line(capsys)
    commands = [
        shlex.split(c)[1:]
        for c in re.findall(r"'(dynid bag2csv .*?)'(?=,| and| \()", line)
    ]
    assert len(commands) == 3, line
    assert "the command's --drive" not in line, line
    header = f"t,q_{names[1]},q_{names[0]},tau_{names[1]},tau_{names[0]}"
    for argv, rows in zip(commands, (3000, 2000, 1000), strict=True):
        assert argv[1] == str(bag) and "--joints" in argv, argv
        assert cli.main([*argv, "--quiet"]) == 0, capsys.readouterr().err
        text = (tmp_path / argv[argv.index("--out") + 1]).read_text()
        assert text.splitlines()[0] == header
        assert len(text.splitlines()) == rows + 1


def _bursts(ordered, begin, every, sent=None):
    """``ordered`` (the arm's messages) received so that those of odd
    milliseconds from ``begin`` [ms] on (a second publisher) arrive late,
    after the even ones, every ``every`` ms (the receive times kept in
    order); ``sent``: the messages sent then (``ordered`` stepped back)."""
    ms = [(m[1] - EPOCH) // 10**6 for m in ordered]
    arrival = [
        (t // every + 1) * every + 0.5 if t % 2 and t >= begin else t for t in ms
    ]
    sent = ordered if sent is None else sent
    messages = [sent[k] for k in np.argsort(arrival, kind="stable")]
    return [(m[0], m[1], o[2], *m[3:]) for m, o in zip(messages, ordered, strict=True)]


@pytest.mark.parametrize(
    ("begin", "every"),
    [(1000, 8), (1000, 6), (1000, 20), (0, 20), (1000, 40)],
)
def test_a_second_publisher_received_in_batches_is_no_clock_step(
    arm, tmp_path, begin, every
):
    """Found by a review: a second publisher on the topic (odd milliseconds)
    that starts mid-bag, received in bursts of 3 or 4 after the first one's
    messages (every 6 or 8 ms), was named a clock set back (the bursts'
    stamps, 1 ms from the first publisher's, nearer than any spacing
    recorded before it started); one batched every 20 or 40 ms (10 or 20
    late in a row) too, from CLOCK_STEP_RUN. A clock set back makes every
    later message late by the same amount (the recording goes on from the
    late stamps: after the newest stamp the messages come as densely as
    before the step); these late runs return to the original sequence, the
    messages after them as dense as the late ones and the first
    publisher's together. Exported as the bag in order, byte for byte."""
    ordered = [
        m
        for k, m in enumerate(arm_messages(arm, slice(0, 3000)))
        if k >= begin or k % 2 == 0
    ]
    messages = _bursts(ordered, begin, every)
    exports = [
        _exported(tmp_path, label, source, "--quiet")
        for label, source in (("late", messages), ("ordered", ordered))
    ]
    assert exports[0] == exports[1]


@pytest.mark.parametrize(
    ("step", "said"),
    [
        (5_500_000, "0.0035 s at message 1991"),
        (200_500_000, "0.1985 s at message 1991"),
    ],
)
def test_a_clock_set_back_under_a_second_publishers_batches_is_named(
    arm, tmp_path, capsys, step, said
):
    """The second publisher's batches (odd milliseconds, every 20 ms) are no
    step; a header clock set back under them (both publishers' stamps, 5.5 ms
    or 0.2005 s from 2 s on) still is: the messages after it come half as
    densely as in the stretch of time the late ones fill."""
    ordered = arm_messages(arm, slice(0, 3000))
    messages = _bursts(ordered, 0, 20, stepped_back(ordered, 2000, step))
    bag = tmp_path / "step.bag"
    write_bag(bag, "ros1", messages)
    assert cli.main(["bag2csv", str(bag), "--out", str(tmp_path / "o.csv")]) == 2
    line = error_line(capsys)
    # Message 2001, stamped 1.9945 s, is received before the batch of 1.981 s
    # to 1.999 s: 1.998 s the newest before it.
    assert f"steps back {said} (bag time 1700000001.99035 s" in line, line


@pytest.mark.parametrize(("count", "late"), [(20, 20), (2, 2000)])
def test_a_burst_sent_again_within_round_off_is_dropped_as_repeats(
    arm, tmp_path, capsys, monkeypatch, count, late
):
    """Found by a review: a driver re-sending its last 20 messages with their
    stamps but values x (1 + 1e-15) (recomputed: round-off) was named a clock
    set back ('20 message(s) in a row'), an exact re-send being dropped. Values
    within REPEAT_RTOL (1e-9) of each other, far below any joint sensor's
    resolution (a 24-bit encoder's 3.7e-7 rad), far above recomputing's
    round-off (a few 1e-16), now repeat: the export is the bag in order's,
    the re-sent ones dropped and noted, as exact repeats; also 2 received
    2000 messages later, past the hold-back (here 1000: merged in at the
    end), which were written as two rows of one stamp."""
    from drake_dynid import ros_bag

    monkeypatch.setattr(ros_bag, "REORDER_ROWS", 1000)
    ordered = arm_messages(arm, slice(0, 4000))
    at = 1500 + late
    received = ordered[at - 1][2]
    again = ordered[1500 - count : 1500]
    burst = [
        (0, m[1], received + 1 + j, m[3], np.asarray(m[4]) * (1 + 1e-15), m[5])
        for j, m in enumerate(again)
    ]
    pairs = zip(burst, again, strict=True)
    assert any(not np.array_equal(b[4], m[4]) for b, m in pairs)
    exports = [
        _exported(tmp_path, name, source)
        for name, source in (
            ("burst", [*ordered[:at], *burst, *ordered[at:]]),
            ("ordered", ordered),
        )
    ]
    assert exports[0] == exports[1]
    err = capsys.readouterr().err
    assert f"dropped {count} message(s) on /joint_states repeating" in err, err
    assert read_joint_states(tmp_path / "burst.bag").stamps.size == 4000


def _bag2csv_to_stdout(arm, tmp_path):
    """``python -m drake_dynid.cli bag2csv BAG --out -`` of the arm's bag, and
    the environment that runs it from this checkout (a subprocess)."""
    import os

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    argv = [sys.executable, "-m", "drake_dynid.cli", "bag2csv", str(bag), "--out", "-"]
    return argv, env


def test_an_export_to_a_pipe_closed_by_its_reader_stops_with_an_error(arm, tmp_path):
    """Found by a review: 'dynid bag2csv BAG --out - | head' exited 0, the
    export written on to os.devnull to the bag's end once head had gone (the
    printout rule of every command: a closed pipe is no error): a pipeline
    with pipefail, or a script reading the export from a process that died,
    was told the export was whole. It now stops at the closed pipe, exit 2,
    one line on standard error (no traceback); the incomplete-export line
    cannot reach a closed pipe (README)."""
    import subprocess

    argv, env = _bag2csv_to_stdout(arm, tmp_path)
    with subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    ) as process:
        head = process.stdout.read(20_000)  # then gone, as head
        process.stdout.close()
        err = process.stderr.read().decode()
        code = process.wait()
    assert head.startswith(b"t,q_joint1,q_joint2,tau_joint1,tau_joint2\n")
    assert code == 2, err
    assert "Traceback" not in err
    assert err.splitlines() == [
        "dynid bag2csv: error: standard output was closed before the export's end "
        "(its reader stopped reading, e.g. head): what it read is not the whole "
        "bag, and the line saying so cannot reach it; export to a file (--out "
        "LOG.csv) for the whole log."
    ], err


def test_an_export_to_standard_output_terminated_says_it_is_incomplete(arm, tmp_path):
    """Found by a review: SIGTERM (kill, timeout, a service stopped) ended
    'dynid bag2csv BAG --out - > LOG.csv' at once, LOG.csv holding the whole
    rows written so far and no incomplete-export line (28 673 of 50 000, exit
    143): read as the whole bag. bag2csv now turns SIGTERM into the
    interruption Ctrl-C is: the export ends with the line, on a line of its
    own (the signal may cut a row), exit 1. (SIGKILL cannot be caught.)"""
    import signal
    import subprocess

    argv, env = _bag2csv_to_stdout(arm, tmp_path)
    with subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    ) as process:
        head = process.stdout.read(100)  # writing: the pipe fills, not read
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate()
    lines = (head + out).decode().splitlines()
    assert process.returncode == 1, err
    assert err.decode() == "dynid bag2csv: interrupted\n", err
    assert 1 < len(lines) < 8002
    assert lines[-1] == (
        "# dynid: this export is incomplete; it stopped on an error: terminated "
        "(SIGTERM)"
    )


def test_sigterm_in_code_run_from_a_string_ends_bag2csv_with_exit_1(arm, tmp_path):
    """Found by a review: 'python -m drake_dynid.cli bag2csv' given SIGTERM
    in its first moments printed 'interrupted', returned 1, and then died by
    SIGINT (-2; 3 of 40 runs): the KeyboardInterrupt had left code run from
    a string (a dataclass's methods being made, exec of text), which CPython
    marks as unhandled even once caught. The signal is now raised as
    bag2csv.Terminated, a subclass (CPython checks the exact type): exit 1."""
    import os
    import subprocess

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 50)))
    (tmp_path / "sigterm_probe.py").write_text(
        "import sys\n"
        "from drake_dynid import cli, ros_bag\n"
        "real = ros_bag.export_bag\n"
        "def export(*args, **kwargs):\n"
        "    exec('import os, signal\\nos.kill(os.getpid(), signal.SIGTERM)\\n"
        "for _ in range(9): pass')\n"
        "    return real(*args, **kwargs)\n"
        "ros_bag.export_bag = export\n"
        "sys.exit(cli.main(sys.argv[1:]))\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    argv = [sys.executable, "-m", "sigterm_probe", "bag2csv", str(bag), "--out", "-"]
    done = subprocess.run(argv, capture_output=True, env=env, timeout=120)
    assert done.returncode == 1, done
    assert done.stderr.decode() == "dynid bag2csv: interrupted\n"


def test_bag2csv_restores_the_sigterm_handler_when_the_signal_lands_then(
    arm, tmp_path, monkeypatch, capsys
):
    """Found by a review: a SIGTERM pending as bag2csv put the handler back
    (CPython runs pending handlers in signal.signal) raised there and left
    bag2csv's handler installed: cli.main called from user code then turned
    every later SIGTERM into a KeyboardInterrupt. It is restored now (and
    the interruption raised after: exit 1); in a thread nothing is set."""
    import signal
    import threading

    bag = tmp_path / "log.bag"
    write_bag(bag, "ros1", arm_messages(arm, slice(0, 50)))
    out = tmp_path / "log.csv"
    argv = ["bag2csv", str(bag), "--out", str(out), "--quiet"]
    before = signal.getsignal(signal.SIGTERM)
    real = signal.signal
    pending = [True]

    def with_pending(signum, handler):
        current = signal.getsignal(signum)
        if pending and handler is before and callable(current):
            pending.clear()
            current(signum, None)  # the pending signal, run first
        return real(signum, handler)

    monkeypatch.setattr(signal, "signal", with_pending)
    try:
        assert cli.main(argv) == 1
        assert capsys.readouterr().err == "dynid bag2csv: interrupted\n"
        assert signal.getsignal(signal.SIGTERM) is before
    finally:
        real(signal.SIGTERM, before)
    codes = []
    thread = threading.Thread(target=lambda: codes.append(cli.main(argv)))
    thread.start()
    thread.join()
    assert codes == [0] and out.exists()
    assert signal.getsignal(signal.SIGTERM) is before


@pytest.mark.parametrize("drive", [False, True])
def test_a_command_given_a_stepped_bag_prints_bag2csv_commands_that_run(
    arm, tmp_path, capsys, monkeypatch, drive
):
    """Found by a review: offline (and identify, validate, payload, replay,
    reading a bag) refused a clock set back with bag2csv commands to complete
    'with the command's --drive, --urdf, --joints and --lock when it has
    them', and 'the same options': without --drive, bag2csv refuses --urdf
    ('--urdf is for --drive'). They now give whole commands: without --drive
    the joints the command reads (--joints), with it the command's own
    --urdf, --joints, --lock and --drive; run as printed, each writes the log
    the command reads (3000, 2000 and 1000 rows)."""
    names = arm[0]
    messages = stepped_back(arm_messages(arm, slice(0, 3000)), 2000, 3 * 10**9)
    bag = tmp_path / "step.bag"
    write_bag(bag, "ros1", messages)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "drive.toml").write_text(
        '[log]\nposition = "{joint}_position"\ntorque = "{joint}_effort"\n'
    )
    options = ["--urdf", "planar_2r", "--joints", f"{names[1]},{names[0]}"]
    options += ["--drive", "drive.toml"] if drive else []
    assert cli.main(["offline", str(bag), *options]) == 2
    line = error_line(capsys)
    assert "the command's --drive" not in line and "the same options" not in line
    commands = advised(line)
    assert len(commands) == 3, line
    expected = ["--joints", f"{names[0]},{names[1]}"]  # the robot's order
    if drive:
        expected = ["--joints", f"{names[1]},{names[0]}", "--drive", "drive.toml"]
        expected += ["--urdf", "planar_2r"]
    for argv, rows in zip(commands, (3000, 2000, 1000), strict=True):
        own = list(argv[2:])
        for option in ("--out", "--from", "--to", "--stamps"):
            if option in own:
                del own[own.index(option) : own.index(option) + 2]
        assert argv[:2] == ["bag2csv", str(bag)] and own == expected, argv
        assert cli.main([*argv, "--quiet"]) == 0, capsys.readouterr().err
        out = argv[argv.index("--out") + 1]
        assert len((tmp_path / out).read_text().splitlines()) == rows + 1
        code = cli.main(["offline", out, *options, "--quiet"])
        assert code == 0, capsys.readouterr().err


def test_a_header_clock_stepped_forward_off_the_grid_splits_the_log(
    arm, tmp_path, capsys
):
    """A robot's clock stepped forward 0.2005 s at message 4001 (200.5 steps):
    the stamps were snapped to one grid of step 0.0010001 s, 'jitter up to 24 %',
    each part a quarter step off. The gap is now a restart: each side on its own
    grid of 0.001 s, never filled, the log split there (2 segments)."""
    messages = stepped_back(arm_messages(arm), 4000, -200_500_000)
    bag = tmp_path / "forward.bag"
    write_bag(bag, "ros1", messages)
    document, err = offline(capsys, bag, tmp_path / "f.json")
    gap = "a gap of 201.5 ms, 200.5 steps of 0.001 s, between row 4001 and row 4002"
    assert gap in err
    assert "the logger restarted or its clock stepped" in err
    assert "jitter" not in err
    fit = json.dumps(document)
    assert '"segments": 2' in fit and '"segments_used": 2' in fit
