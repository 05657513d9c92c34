"""Input files named the way users name them, and broken the way real ones break
(found by a review): a packaged robot by its name, a URDF, limits or results file
that is a folder or not UTF-8 text, a URDF whose visual mesh is missing."""

import json
from pathlib import Path

import pytest
from _cli import error_line

from drake_dynid import cli
from drake_dynid.plants import model_path


def test_a_packaged_robot_by_its_name(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no file of that name here
    assert cli.main(["params", "iiwa7"]) == 0
    assert f"robot: {model_path('iiwa7')}" in capsys.readouterr().out
    assert cli.main(["params", "no_such_robot"]) == 2
    line = error_line(capsys)
    assert "URDF file not found: no_such_robot" in line and "iiwa7" in line
    (tmp_path / "iiwa7").mkdir()  # a folder is no URDF: the packaged robot
    assert cli.main(["params", "iiwa7"]) == 0
    assert f"robot: {model_path('iiwa7')}" in capsys.readouterr().out
    (tmp_path / "ur5").write_text(Path(model_path("planar_2r")).read_text())
    assert cli.main(["params", "ur5"]) == 2  # a file of that name wins (Drake
    assert "could not parse ur5" in error_line(capsys)  # wants its extension)


def test_files_that_are_not_utf8_text_are_named(tmp_path, capsys):
    urdf = tmp_path / "robot.urdf"
    urdf.write_bytes(Path(model_path("planar_2r")).read_text().encode("utf-16"))
    assert cli.main(["params", str(urdf)]) == 2
    assert f"URDF {urdf}: not UTF-8 text (byte 0)" in error_line(capsys)
    limits = tmp_path / "limits.json"
    limits.write_bytes(json.dumps({"joint1": {"position": 1.0}}).encode("utf-16"))
    argv = ["excite", model_path("planar_2r"), "--limits", str(limits)]
    assert cli.main([*argv, "--out", str(tmp_path / "t.csv")]) == 2
    assert f"limits file {limits}: not UTF-8 text (byte 0)" in error_line(capsys)
    params = tmp_path / "fit.json"
    params.write_bytes(b"\xff\xfe{")
    log = tmp_path / "log.csv"
    log.write_text("t,q_joint1,q_joint2,tau_joint1,tau_joint2\n0,0,0,0,0\n1,0,0,0,0\n")
    argv = ["validate", str(log), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--params", str(params)]) == 2
    assert f"results file {params}: not UTF-8 text" in error_line(capsys)
    assert cli.main([*argv, "--params", str(tmp_path)]) == 2
    assert "is a directory, expected a file" in error_line(capsys)


def test_a_missing_visual_mesh_does_not_stop_the_collision_check(tmp_path, capsys):
    """excite loads the collision geometry only; a missing visual mesh was an
    error there while every other command read the URDF."""
    geometry = '<mesh filename="meshes/missing.dae"/>'
    argv = _excite_with(tmp_path, f"<visual><geometry>{geometry}</geometry></visual>")
    assert cli.main(argv) == 0, capsys.readouterr().err
    assert (tmp_path / "t.csv").is_file()


def _excite_with(tmp_path, element: str) -> list[str]:
    """``dynid excite`` of the 2R arm with ``element`` added to its first link."""
    text = Path(model_path("planar_2r")).read_text()
    link = text.index("<inertial>")
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(text[:link] + element + text[link:])
    limits = tmp_path / "limits.json"
    joint = {"lower": -3.0, "upper": 3.0, "velocity": 3.0, "effort": 100.0}
    limits.write_text(json.dumps({"joint1": joint, "joint2": joint}))
    argv = ["excite", str(urdf), "--limits", str(limits), "--duration", "10"]
    return [*argv, "--out", str(tmp_path / "t.csv")]


def test_replay_shows_bad_samples_at_the_last_good_pose(capsys):
    """Found by a review: a log with a run of NaN samples (read as bad samples by
    identify and offline) failed replay with "q must be finite"."""
    import numpy as np

    from drake_dynid.commands.replay import _held_over_bad_samples

    q = np.arange(12.0).reshape(6, 2)
    q[0] = np.nan
    q[3:5, 1] = np.nan
    held = _held_over_bad_samples(q)
    np.testing.assert_array_equal(held[:, 0], [2, 2, 4, 4, 4, 10])
    assert "3 bad sample(s) shown at the last good pose" in capsys.readouterr().err


def test_a_log_file_given_twice_is_named(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    log = tmp_path / "log.csv"
    log.write_text("t,q_joint1,q_joint2,tau_joint1,tau_joint2\n0,0,0,0,0\n1,0,0,0,0\n")
    argv = ["offline", "log.csv", "./log.csv", "--urdf", model_path("planar_2r")]
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert "a file is given twice: log.csv and ./log.csv are the same file" in line


def test_a_trajectory_file_without_rows_is_said_without_numpys_warning(
    tmp_path, capsys
):
    trajectory = tmp_path / "t.csv"
    trajectory.write_text("t,q_joint1,q_joint2,v_joint1,v_joint2\n")
    argv = ["simulate", model_path("planar_2r"), "--trajectory", str(trajectory)]
    assert cli.main([*argv, "--out", str(tmp_path / "log.csv")]) == 2
    assert "got no data rows" in error_line(capsys)


def test_an_unloadable_collision_mesh_skips_the_check_with_its_reason(tmp_path, capsys):
    """Found by a review: excite failed on the shipped TIAGo (package:// collision
    meshes of another workspace) with a misleading "Fix the URDF" hint."""
    mesh = '<mesh filename="package://no_such_package/arm.stl"/>'
    argv = _excite_with(tmp_path, f"<collision><geometry>{mesh}</geometry></collision>")
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "self-collision: not checked (its collision geometry cannot be loaded" in out
    assert "no_such_package" in out


def test_replay_shows_a_log_of_positions_only(tmp_path, capsys):
    """Found by a review: a log without tau columns was refused by replay, which
    only shows positions."""
    from _motions import fourier_2r

    from drake_dynid.logs import write_log

    robot, t, q, tau = fourier_2r(2001)
    full = tmp_path / "full.csv"
    write_log(full, t, q, tau, robot.joint_names)
    lines = full.read_text().splitlines()
    (tmp_path / "q.csv").write_text(
        "\n".join(",".join(line.split(",")[:3]) for line in lines) + "\n"
    )
    argv = ["replay", model_path("planar_2r"), str(tmp_path / "q.csv")]
    assert cli.main([*argv, "--html", str(tmp_path / "q.html"), "--fps", "4"]) == 0
    captured = capsys.readouterr()
    assert "log (positions)" in captured.out
    assert "never change" not in captured.err  # its torques are filled in
    assert (tmp_path / "q.html").stat().st_size > 0


def test_replay_with_a_drive_file_or_several_files_needs_no_effort(tmp_path, capsys):
    """Found by a review: dynid replay --drive (and a plain log split over two
    files) refused a log without its effort columns, which replay never shows;
    the positions are read (no torque warning), and a log with its efforts is
    read as before."""
    from _motions import fourier_2r

    from drake_dynid.logs import write_log

    robot, t, q, tau = fourier_2r(2001)
    write_log(tmp_path / "full.csv", t, q, tau, robot.joint_names)
    lines = (tmp_path / "full.csv").read_text().splitlines()
    (tmp_path / "q.csv").write_text(
        "\n".join(",".join(line.split(",")[:3]) for line in lines) + "\n"
    )
    (tmp_path / "tau1.csv").write_text(  # one effort column of two
        "\n".join(",".join(line.split(",")[::3]) for line in lines) + "\n"
    )
    drive = tmp_path / "drive.toml"
    drive.write_text('[log]\ntime = "t"\nposition = "q_{joint}"\n')
    urdf = model_path("planar_2r")
    for logs in (["q.csv", "--drive", str(drive)], ["q.csv", "tau1.csv"]):
        files = [str(tmp_path / x) if x.endswith(".csv") else x for x in logs]
        html = ["--html", str(tmp_path / "r.html"), "--fps", "4"]
        assert cli.main(["replay", urdf, *files, *html]) == 0
        captured = capsys.readouterr()
        assert "2001 samples over 2 s" in captured.out, captured.err
        assert "never change" not in captured.err  # no torque was read
    argv = ["replay", urdf, str(tmp_path / "full.csv"), "--drive", str(drive)]
    assert cli.main([*argv, "--html", str(tmp_path / "f.html"), "--fps", "4"]) == 0
    assert "not used" not in capsys.readouterr().err


def test_replay_reads_a_log_stamped_in_ms_with_time_unit(tmp_path, capsys):
    """``dynid replay --time-unit`` (a review: the identification commands had it,
    replay showed an ms log 1000 times too slow, with the long-step warning)."""
    from _motions import fourier_2r

    from drake_dynid.logs import write_log

    robot, t, q, tau = fourier_2r(2001)
    write_log(tmp_path / "ms.csv", 1e3 * t, q, tau, robot.joint_names)
    lines = (tmp_path / "ms.csv").read_text().splitlines()
    (tmp_path / "q.csv").write_text(
        "\n".join(",".join(line.split(",")[:3]) for line in lines) + "\n"
    )
    span = f"over {t[-1] - t[0]:g} s"
    for name in ("ms.csv", "q.csv"):
        argv = ["replay", model_path("planar_2r"), str(tmp_path / name)]
        html = ["--html", str(tmp_path / f"{name}.html"), "--fps", "4"]
        assert cli.main([*argv, *html, "--time-unit", "ms"]) == 0
        captured = capsys.readouterr()
        assert span in captured.out, captured.out
        assert "--time-unit" not in captured.err
    trajectory = tmp_path / "t.csv"
    trajectory.write_text("t,q_joint1,q_joint2,v_joint1,v_joint2\n0,0,0,0,0\n")
    argv = ["replay", model_path("planar_2r"), str(trajectory), "--time-unit", "ms"]
    assert cli.main(argv) == 2
    assert "is a trajectory file, whose times are seconds" in error_line(capsys)


def test_a_trajectory_file_is_read_as_logs_are(tmp_path):
    """Found by a review: a byte-order mark hid the t column ("missing column(s)
    t"), a Latin-1 byte was "'utf-8' codec can't decode byte 0xb0" naming no
    file, and an empty cell was numpy's "at row 50, column 2.." (0-based) for
    the file's line 52."""
    import pytest

    from drake_dynid.trajectory_file import read_trajectory

    header = "t,q_a,v_a\n"
    rows = [f"{0.01 * k},{0.1 * k},0.1\n" for k in range(60)]
    path = tmp_path / "t.csv"
    path.write_bytes(("\ufeff" + header + "".join(rows)).encode())
    assert read_trajectory(path, ["a"]).t.size == 60
    path.write_bytes(header.replace("t,", "t,°,").encode("latin-1"))
    with pytest.raises(
        ValueError, match=r"trajectory .*t.csv: not UTF-8 text \(byte 2"
    ):
        read_trajectory(path, ["a"])
    rows[50] = "0.5,,0.1\n"
    path.write_text(header + "".join(rows))
    with pytest.raises(
        ValueError, match=r"t.csv: row 52, column 'q_a': '' is not a number"
    ):
        read_trajectory(path, ["a"])


@pytest.mark.parametrize(
    ("setting", "value", "message"),
    [
        (
            "friction",
            ["bogus"],
            r"settings.friction must list names among viscous, coulomb, offset; "
            r"got \['bogus'\]",
        ),
        ("locked", {"joint2": "x"}, r"settings.locked.joint2 must be a number"),
        (
            "coulomb_dead_zone",
            {"joint1": None, "joint2": 0.1},
            r"settings.coulomb_dead_zone.joint1 must be a number >= 0 \[rad/s or "
            r"m/s\]; got None",
        ),
        (
            "coulomb_dead_zone",
            {"joint1": -1.0, "joint2": 0.1},
            r"settings.coulomb_dead_zone.joint1 must be a number >= 0",
        ),
        # A review: a NaN or negative width was ignored (the exact sign used).
        ("coulomb_width", -0.01, r"settings.coulomb_width must be a number >= 0"),
        ("coulomb_width", "0.01", r"settings.coulomb_width must be a number >= 0"),
    ],
)
def test_a_results_files_bad_settings_are_named(
    tmp_path, capsys, setting, value, message
):
    """Found by a review: a bad settings.friction was blamed on settings.joints
    and settings.locked; a lock of "x" was "could not convert string to float"
    naming no file; a dead-zone width of null was a TypeError (exit 1), -1 an
    error about DeadZoneSign."""
    import re

    from _motions import fourier_2r

    from drake_dynid.logs import write_log

    robot, t, q, tau = fourier_2r(2001)
    log = tmp_path / "log.csv"
    write_log(log, t, q, tau, robot.joint_names)
    params = tmp_path / "p.json"
    assert cli.main(["params", model_path("planar_2r"), "--json", str(params)]) == 0
    document = json.loads(params.read_text())
    document["settings"][setting] = value
    params.write_text(json.dumps(document))
    argv = ["validate", str(log), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--params", str(params)]) == 2
    line = error_line(capsys)
    assert line.startswith(f"dynid validate: error: results file {params}: "), line
    assert re.search(message, line), line


def test_the_fitted_log_is_no_validation_log(tmp_path, capsys, monkeypatch):
    """Found by a review: offline --validate with the fitted log itself printed its
    in-sample residual as a validation."""
    from _motions import fourier_2r

    from drake_dynid.logs import write_log

    monkeypatch.chdir(tmp_path)
    robot, t, q, tau = fourier_2r(2001)
    write_log(tmp_path / "log.csv", t, q, tau, robot.joint_names)
    argv = ["offline", "log.csv", "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--validate", "./log.csv"]) == 2
    line = error_line(capsys)
    assert "--validate ./log.csv is the fitted log (log.csv)" in line
    assert "--split" in line


def test_files_in_other_column_names_are_pointed_to_a_drive_file(tmp_path, capsys):
    """Positions and efforts apart in ROS-export names (the TIAGo's '- <joint>_
    position'), given without --drive: one file of them named a drive file in its
    message, two joined on time did not (a new user's first run on the TIAGo)."""
    rows = range(40)
    (tmp_path / "p.csv").write_text(
        "t,- joint1_position,- joint2_position\n"
        + "".join(f"{0.01 * k},{0.01 * k},{-0.01 * k}\n" for k in rows)
    )
    (tmp_path / "e.csv").write_text(
        "t,- joint1_effort,- joint2_effort\n"
        + "".join(f"{0.01 * k},1,2\n" for k in rows)
    )
    files = [str(tmp_path / "p.csv"), str(tmp_path / "e.csv")]
    for logs in (files[:1], files):
        assert cli.main(["offline", *logs, "--urdf", "planar_2r"]) == 2
        line = error_line(capsys)
        assert "column(s)" in line and "described in a drive file" in line, line


def test_replay_without_the_urdfs_geometry_does_not_say_it_has_no_visual(
    tmp_path, capsys
):
    """Found by a new user's walk-through: `dynid replay` of example-robot-data's
    Kinova (.dae collision meshes, which Drake cannot hull) said "shown without its
    geometry (...)" and then "no <visual> geometry", though the URDF has visuals."""
    from _motions import fourier_2r

    from drake_dynid.logs import write_log

    text = Path(model_path("planar_2r")).read_text()
    link = text.index("<inertial>")
    box = "<geometry><box size='0.1 0.1 0.1'/></geometry>"
    mesh = "<geometry><mesh filename='arm.dae'/></geometry>"
    shapes = f"<visual>{box}</visual><collision>{mesh}</collision>"
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(text[:link] + shapes + text[link:])
    (tmp_path / "arm.dae").write_text("")
    robot, t, q, tau = fourier_2r(201)
    write_log(tmp_path / "log.csv", t, q, tau, robot.joint_names)
    argv = ["replay", str(urdf), str(tmp_path / "log.csv"), "--fps", "4"]
    assert cli.main([*argv, "--html", str(tmp_path / "r.html")]) == 0
    err = capsys.readouterr().err
    assert "shown without its geometry" in err and ".dae" in err
    assert "the links are shown by their inertia" in err
    assert "no <visual> geometry" not in err
