"""dynid with --drive: raw motor-side logs in several files, coupled motors, bad input.

The robot is tests/data/wrist4.urdf with a coupled wrist (motor 4 turns with
q3 + q4). The raw files are written with ``DriveChain.to_columns`` (the inverse of
the conversion) from a joint-space log, so the same data exists in both formats:
the CLI must give the same estimates from either.
"""

import json
import pathlib
import re

import numpy as np
import pytest
from _cli import error_line

from drake_dynid import cli
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import write_log
from drake_dynid.robot import RobotModel

DATA = pathlib.Path(__file__).parent / "data"
URDF = str(DATA / "wrist4.urdf")
DRIVE = """
[log]
time = "stamp"
time_unit = "ms"
position = "enc_{motor}"
position_side = "motor"
angle_unit = "deg"
torque = "cur_{motor}"
torque_side = "motor"
torque_unit = "A"

[log.position_offset]
m4 = 90.0

[motors.m1]
joint = "j1"
gear_ratio = 50
torque_constant = 0.1
[motors.m2]
joint = "j2"
gear_ratio = 60
torque_constant = 0.1
[motors.m3]
joint = "j3"
gear_ratio = 30
torque_constant = -0.05
[motors.m4]
joints = { j3 = 25, j4 = 25 }
torque_constant = 0.05
rotor_inertia = 5e-5
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """(plain joint-space log, [raw encoders, raw currents], drive file)."""
    folder = tmp_path_factory.mktemp("cli_drive")
    drive = folder / "wrist4.toml"
    drive.write_text(DRIVE)
    robot = RobotModel.from_urdf(URDF, drive=drive, rotor_inertia=True)
    trajectory = random_fourier_trajectory(
        4,
        harmonics=4,
        base_frequency=2 * np.pi / 8.0,
        max_velocity=1.0,
        max_position=1.2,
        rng=np.random.default_rng(11),
    )
    h = 0.01
    t = h * np.arange(int(32.0 / h) + 1)
    q, v, vdot = trajectory.evaluate(t)
    rng = np.random.default_rng(12)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    tau = tau + 0.02 * rng.normal(size=tau.shape)
    q = q + 1e-5 * rng.normal(size=q.shape)
    plain = folder / "plain.csv"
    write_log(plain, t, q, tau, robot.joint_names)
    columns = robot.drive.to_columns(t, q, tau)
    stamp = columns["stamp"]
    encoders, currents = folder / "enc.csv", folder / "cur.csv"
    names = [f"m{k}" for k in range(1, 5)]
    np.savetxt(
        encoders,
        np.column_stack([stamp, *(columns[f"enc_{m}"] for m in names)]),
        delimiter=",",
        header="stamp," + ",".join(f"enc_{m}" for m in names),
        comments="",
        fmt="%.17g",
    )
    np.savetxt(
        currents,
        np.column_stack([stamp, *(columns[f"cur_{m}"] for m in names)]),
        delimiter=",",
        header="stamp," + ",".join(f"cur_{m}" for m in names),
        comments="",
        fmt="%.17g",
    )
    return plain, [str(encoders), str(currents)], drive


def _run(argv, tmp_path, name):
    out = tmp_path / f"{name}.json"
    assert cli.main([*argv, "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


def test_raw_files_with_a_drive_give_the_plain_log_estimates(files, tmp_path):
    plain, raw, drive = files
    common = ["--urdf", URDF, "--rotor-inertia", "--split", "0.7"]
    # The plain log is joint side: the same motors without the [log] table.
    joint_drive = tmp_path / "joint_side.toml"
    joint_drive.write_text(DRIVE[DRIVE.index("[motors.m1]") :])
    want = _run(
        ["offline", str(plain), *common, "--drive", str(joint_drive)], tmp_path, "plain"
    )
    got = _run(["offline", *raw, *common, "--drive", str(drive)], tmp_path, "raw")
    names = [p["name"] for p in got["parameters"]]
    assert names == [p["name"] for p in want["parameters"]]
    assert {"IAm4", "FVm4", "FCm4"} <= set(names)
    np.testing.assert_allclose(
        [p["value"] for p in got["parameters"]],
        [p["value"] for p in want["parameters"]],
        rtol=1e-6,
        atol=1e-9,
    )
    settings = got["settings"]
    assert settings["drive"] == str(drive) and settings["rotor_inertia"] is True
    assert settings["drive_chain"]["motors"][3]["joints"] == {"j3": 25.0, "j4": 25.0}
    assert set(settings["coulomb_dead_zone"]) == {"j1", "j2", "j3", "j4"}
    assert got["log"]["path"] == raw
    # dynid validate reads the drive, rotor inertia and dead zone from the file.
    check = _run(
        ["validate", *raw, "--urdf", URDF, "--params", str(tmp_path / "raw.json")],
        tmp_path,
        "check",
    )
    errors = [
        j["relative_rms_percent"] for j in check["estimates"]["idim-ls"]["joints"]
    ]
    assert max(errors) < 5.0


def test_params_prints_the_drive(files, capsys):
    _, _, drive = files
    assert cli.main(["params", URDF, "--drive", str(drive), "--rotor-inertia"]) == 0
    out = capsys.readouterr().out
    assert "drive: drive file" in out and "4 motors (v_m = R v)" in out
    assert "m4 m4 (coupled, drive): 25 j3 + 25 j4; k_t 0.05, Ia 5e-05" in out
    assert "IAm4" in out and "FVm4" in out


def test_identify_reads_raw_files_through_the_drive(files, tmp_path):
    _, raw, drive = files
    got = _run(
        ["identify", *raw, "--urdf", URDF, "--drive", str(drive), "--window", "20"],
        tmp_path,
        "online",
    )
    assert got["valid"] and "FCm4" in [p["name"] for p in got["parameters"]]


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            ('joint = "j2"', 'joint = "j9"'),
            "motors.m2.joint: unknown joint 'j9'",
        ),
        (
            ('joint = "j3"\ngear_ratio = 30', "joints = { j3 = 30, j4 = 30 }"),
            "must have rank 4 .* singular coupling",
        ),
        (
            ('position = "enc_{motor}"', 'position = "pos_{motor}"'),
            r"no column\(s\) 'pos_m1'",
        ),
        (
            ('angle_unit = "deg"', 'angle_unit = "degree"'),
            "log.angle_unit must be one of rad, deg, rev; got 'degree'",
        ),
        (
            ('torque_unit = "A"', 'torque_units = "A"'),
            r"unknown key\(s\) torque_units in log",
        ),
        # A field of the wrong type (found by a review: a traceback, exit 1).
        (
            ("gear_ratio = 50", 'gear_ratio = "50"'),
            "motors.m1.gear_ratio must be a real number; got '50' of type str",
        ),
        (
            ("m4 = 90.0", 'm4 = "a"'),
            r"log.position_offset.m4 must be a real number \[deg\]",
        ),
        (("gear_ratio = 50", "gear_ratio = 1e300"), "motors.m1.gear_ratio must be "),
    ],
)
def test_bad_drive_input_exits_2_naming_the_field(
    files, tmp_path, capsys, edit, message
):
    _, raw, _ = files
    bad = tmp_path / "bad.toml"
    assert edit[0] in DRIVE
    bad.write_text(DRIVE.replace(*edit))
    assert cli.main(["offline", *raw, "--urdf", URDF, "--drive", str(bad)]) == 2
    line = error_line(capsys)
    assert line.startswith("dynid offline: error: ")
    assert re.search(message, line), line


def test_bad_options_exit_2(files, tmp_path, capsys):
    plain, raw, drive = files
    base = ["offline", *raw, "--urdf", URDF, "--drive", str(drive)]
    assert cli.main([*base, "--dead-zone", "wide"]) == 2
    assert "--dead-zone must be auto, none or a width >= 0" in error_line(capsys)
    assert cli.main([*base, "--json", raw[1]]) == 2
    assert f"--json {raw[1]} is an input of this command (the log" in error_line(capsys)
    assert cli.main([*base, "--json", str(drive)]) == 2
    assert "is an input of this command (--drive" in error_line(capsys)
    assert cli.main(["offline", str(plain), raw[0], "--urdf", URDF]) == 2
    assert "enc.csv: no time column 't'; every file of a multi-file" in error_line(
        capsys
    )
    missing = tmp_path / "none.toml"
    assert cli.main(["offline", *raw, "--urdf", URDF, "--drive", str(missing)]) == 2
    assert "none.toml: no such file" in error_line(capsys)
    # A mistyped packaged name is told the packaged drive files (as a URDF's).
    assert cli.main(["offline", *raw, "--urdf", URDF, "--drive", "TIAGO"]) == 2
    assert (
        "TIAGO: no such file (the dynid command also takes the name of a "
        "packaged drive file: tiago)" in error_line(capsys)
    )


def test_power_model_noise_options_with_a_drive_name_the_options(files, capsys):
    # The power rows' noise compensation does not cover the motor columns: a
    # given --position-noise, or --weighting covariance (which needs it), is
    # refused with the options to change (it was core.noise_bias's own message,
    # "NoiseCompensatedRows: rows must be a provider ...").
    _, raw, drive = files
    base = ["identify", *raw, "--urdf", URDF, "--drive", str(drive)]
    base += ["--model", "power"]
    assert cli.main([*base, "--position-noise", "0.001"]) == 2
    error = error_line(capsys)
    assert "--position-noise compensates the noise bias of the power rows' joint" in (
        error
    )
    assert "use --position-noise none" in error
    assert cli.main([*base, "--weighting", "covariance"]) == 2
    error = error_line(capsys)
    assert "--weighting covariance needs --position-noise" in error
    assert "use --weighting frequency" in error
    assert "NoiseCompensatedRows" not in error


def test_excite_designs_for_the_motor_columns(files, tmp_path, capsys):
    _, _, drive = files
    limits = tmp_path / "limits.json"
    limits.write_text(json.dumps({f"j{k}": {"effort": 300.0} for k in range(1, 5)}))
    argv = ["excite", URDF, "--drive", str(drive), "--rotor-inertia", "--limits"]
    argv += [str(limits), "--duration", "5", "--iterations", "2"]
    assert cli.main([*argv, "--out", str(tmp_path / "traj.csv")]) == 0
    out = capsys.readouterr().out
    assert "base parameters)" in out and "FCm4" in out


def test_physical_fit_and_urdf_with_coupled_motor_columns(files, tmp_path, capsys):
    _, raw, drive = files
    argv = ["offline", *raw, "--urdf", URDF, "--drive", str(drive)]
    fit = tmp_path / "fit.json"
    assert cli.main([*argv, "--rotor-inertia", "--physical", "--json", str(fit)]) == 0
    physical = json.loads(fit.read_text())["physical"]
    values = {p["name"]: p["value"] for p in physical["parameters"]}
    # The motor's inertia stays near the truth (drive file: Ia = 5e-5), and its
    # friction (0 in the data) is not negative.
    assert values["IAm4"] == pytest.approx(5e-5, rel=0.05)
    assert values["FVm4"] >= -1e-12 and values["FCm4"] >= -1e-12
    capsys.readouterr()
    urdf_out = tmp_path / "identified.urdf"
    assert cli.main([*argv, "--urdf-out", str(urdf_out)]) == 0
    assert "not written, no URDF field: FVm4, FCm4" in capsys.readouterr().out
    assert urdf_out.is_file()
    # With rotor inertia on this URDF without <transmission>: each joint gets one
    # (the writer refused after the whole fit, and --json was lost); the motor
    # columns are listed in the JSON and the file's header too.
    both = [*argv, "--rotor-inertia", "--urdf-out", str(urdf_out), "--json", str(fit)]
    assert cli.main([*both, "--quiet"]) == 0
    physical = json.loads(fit.read_text())["physical"]
    assert physical["urdf_skipped"] == ["IAm4", "FVm4", "FCm4"]
    text = urdf_out.read_text()
    assert "no URDF field (not written): IAm4, FVm4, FCm4" in text
    assert text.count("_dynid_transmission") == 4
    # Loaded again with the same drive file, which gives no motor friction:
    # nothing is counted twice, and no note says so (test_urdf_writer.py has a
    # drive file with motor friction, where it is said).
    robot = RobotModel.from_urdf(urdf_out, drive=drive, rotor_inertia=True)
    assert not any("reflected" in n for n in robot.notes)
    assert not any(
        "reflected" in n for n in RobotModel.from_urdf(URDF, drive=drive).notes
    )


def test_validate_finds_the_results_drive_file_or_says_it_is_missing(
    files, tmp_path, capsys, monkeypatch
):
    """Found by two reviews: a drive path recorded relative to the fit's folder was
    dropped without a word when validating from elsewhere, then not found. It is
    recorded absolute, and looked for beside the results file when both moved."""
    import shutil

    _, raw, drive = files
    fit_folder = tmp_path / "fit"
    fit_folder.mkdir()
    (fit_folder / "wrist4.toml").write_text(drive.read_text())
    monkeypatch.chdir(fit_folder)
    common = ["--urdf", URDF, "--rotor-inertia", "--split", "0.7"]
    fit = _run(["offline", *raw, *common, "--drive", "wrist4.toml"], tmp_path, "fit")
    assert fit["settings"]["drive"] == str(fit_folder / "wrist4.toml")  # absolute
    results = fit_folder / "fit.json"
    results.write_text(json.dumps(fit))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)

    def check(params):
        argv = ["validate", *raw, "--urdf", URDF, "--params", str(params)]
        document = _run(argv, tmp_path, "check")
        joints = document["estimates"]["idim-ls"]["joints"]
        assert max(j["relative_rms_percent"] for j in joints) < 5.0
        return argv

    argv = check(results)  # from another folder: the absolute path
    # An output never overwrites the drive file found that way.
    before = drive.read_text()
    assert cli.main([*argv, "--json", str(fit_folder / "wrist4.toml")]) == 2
    assert "drive file" in error_line(capsys)
    assert (fit_folder / "wrist4.toml").read_text() == before
    # Both moved together: found beside the results file, by its name.
    moved = shutil.move(str(fit_folder), str(tmp_path / "moved"))
    argv = check(pathlib.Path(moved) / "fit.json")
    # Not found at all: an error naming it, never a silent drop.
    (pathlib.Path(moved) / "wrist4.toml").unlink()
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert "wrist4.toml (settings.drive) is not found" in line and "--drive" in line


def test_a_drive_file_that_is_not_utf8_text_or_a_folder_is_named(
    files, tmp_path, capsys
):
    _, raw, _ = files
    for name, content in [
        ("utf16.toml", DRIVE.encode("utf-16")),
        ("bom.toml", b"\xef\xbb\xbf" + DRIVE.encode()),
    ]:
        path = tmp_path / name
        path.write_bytes(content)
        code = cli.main(["offline", *raw, "--urdf", URDF, "--drive", str(path)])
        if name == "bom.toml":  # a byte-order mark is accepted, as in logs
            assert code == 0
            capsys.readouterr()
        else:
            assert code == 2
            assert "not UTF-8 text (byte 0); save it as UTF-8" in error_line(capsys)
    assert cli.main(["offline", *raw, "--urdf", URDF, "--drive", str(tmp_path)]) == 2
    assert "is a directory, expected a file" in error_line(capsys)


def test_a_drive_file_of_the_whole_robot_serves_a_subset_of_its_joints(
    tmp_path, capsys
):
    """Found by a review: the shipped TIAGo drive file with --joints arm_1..arm_4
    was refused ("unknown joint 'torso_lift_joint'"). A motor that drives only URDF
    joints outside --joints is skipped (a note); one that also drives identified
    joints is an error naming the joint; a name the URDF lacks stays a typo."""
    from drake_dynid.plants import model_path

    urdf = model_path("tiago_no_hand")
    drive = str(pathlib.Path(urdf).with_name("tiago.toml"))
    joints = "arm_1_joint,arm_2_joint,arm_3_joint,arm_4_joint"
    argv = ["params", urdf, "--joints", joints, "--drive", drive]
    assert cli.main(argv) == 0
    err = capsys.readouterr().err
    assert "motors.torso_lift_motor drives torso_lift_joint, not identified" in err
    assert "motors.arm_5_motor drives arm_5_joint, not identified" in err
    # The URDF's differential wrist (arm_6, arm_7) split by --joints: the drive
    # file's simple row for arm_6_motor replaces the URDF's mixed one.
    to_6 = f"{joints},arm_5_joint,arm_6_joint"
    assert cli.main(["params", urdf, "--joints", to_6, "--drive", drive]) == 0
    err = capsys.readouterr().err
    assert "motors.arm_7_motor drives arm_7_joint, not identified" in err
    assert (
        "URDF actuator arm_6_motor {arm_6_joint = -1, arm_7_joint = 1} (it also" in err
    )
    text = pathlib.Path(drive).read_text()
    coupled = tmp_path / "coupled.toml"
    old = 'joint = "arm_1_joint"'
    assert old in text
    coupled.write_text(
        text.replace(
            old, "joints = { arm_1_joint = 100, arm_5_joint = 100 }", 1
        ).replace("gear_ratio = 100.0\n", "", 1)
    )
    assert cli.main([*argv[:-1], str(coupled)]) == 2
    line = error_line(capsys)
    assert "joint 'arm_5_joint' is not identified (--joints) but this motor" in line
    typo = tmp_path / "typo.toml"
    typo.write_text(text.replace(old, 'joint = "arm_9_joint"', 1))
    assert cli.main([*argv[:-1], str(typo)]) == 2
    assert "unknown joint 'arm_9_joint'" in error_line(capsys)


def test_time_unit_reads_a_plain_log_stamped_in_ms(files, tmp_path, capsys):
    """``--time-unit`` for a log without a drive file (a review: stamps in ms were
    only warned about, the fix being a drive file); with a drive file the two
    must agree."""
    plain, raw, drive = files
    text = pathlib.Path(plain).read_text().splitlines()
    rows = [line.split(",", 1) for line in text[1:]]
    ms = tmp_path / "ms.csv"
    ms.write_text(
        "\n".join([text[0], *(f"{1e3 * float(t)!r},{rest}" for t, rest in rows)]) + "\n"
    )
    common = ["--urdf", URDF, "--friction", "viscous"]
    want = _run(["offline", str(plain), *common], tmp_path, "s")
    got = _run(["offline", str(ms), *common, "--time-unit", "ms"], tmp_path, "ms")
    np.testing.assert_allclose(
        [p["value"] for p in got["parameters"]],
        [p["value"] for p in want["parameters"]],
        rtol=1e-9,
    )
    assert got["settings"]["time_unit"] == "ms" and "time_unit" not in want["settings"]
    params = ["--urdf", URDF, "--params", str(tmp_path / "ms.json")]
    held = _run(["validate", str(plain), *params], tmp_path, "held")
    check = _run(["validate", str(ms), *params, "--time-unit", "ms"], tmp_path, "check")
    assert check["estimates"] == held["estimates"]
    capsys.readouterr()
    # Without it: the warning names the option.
    assert cli.main(["offline", str(ms), *common, "--quiet"]) in (0, 2)
    assert "--time-unit" in capsys.readouterr().err
    # The drive file says ms: --time-unit ms agrees, --time-unit us contradicts.
    argv = ["offline", *raw, "--urdf", URDF, "--drive", str(drive), "--quiet"]
    assert cli.main([*argv, "--time-unit", "ms"]) == 0
    capsys.readouterr()
    assert cli.main([*argv, "--time-unit", "us"]) == 2
    line = error_line(capsys)
    assert "--time-unit us contradicts the drive file's [log] time_unit = 'ms'" in line


def test_time_unit_against_a_drive_file_that_says_seconds():
    """A drive file that writes ``time_unit = "s"`` is told from one that says
    nothing (a review: ``--time-unit ms`` overrode the explicit s silently)."""
    from drake_dynid.commands._arguments import _with_time_unit
    from drake_dynid.core.drive import DriveChain

    names = ["j1", "j2"]
    said = DriveChain.from_dict({"log": {"time_unit": "s"}}, names, source="d.toml")
    silent = DriveChain.from_dict({"log": {"time": "t"}}, names, source="d.toml")
    with pytest.raises(ValueError, match=r"--time-unit ms contradicts .* = 's'"):
        _with_time_unit(said, names, "ms")
    assert _with_time_unit(said, names, "s").log.time_scale == 1.0
    assert _with_time_unit(silent, names, "ms").log.time_scale == 1e-3


def test_validate_says_when_the_drive_file_differs_from_the_fit(
    files, tmp_path, capsys
):
    """Found by a review: validating the TIAGo's fit with a drive file whose arm
    gear ratios read 50 for 100 gave 111 % error for 14.5 %, without a word that
    the log was converted otherwise than for the fit (settings.drive_chain)."""
    _, raw, drive = files
    common = ["--urdf", URDF, "--rotor-inertia"]
    fit = tmp_path / "fit.json"
    assert (
        cli.main(
            [
                "offline",
                *raw,
                *common,
                "--drive",
                str(drive),
                "--json",
                str(fit),
                "--quiet",
            ]
        )
        == 0
    )
    capsys.readouterr()
    argv = ["validate", *raw, "--urdf", URDF, "--params", str(fit), "--quiet"]
    assert cli.main(argv) == 0
    assert "differ" not in capsys.readouterr().err  # the fit's own drive file
    edited = tmp_path / "edited.toml"
    edited.write_text(drive.read_text().replace("gear_ratio = 60", "gear_ratio = 30"))
    assert cli.main([*argv, "--drive", str(edited)]) == 0
    err = capsys.readouterr().err
    assert "motors differ from those the parameters were fitted with" in err, err
    assert "m2 {j2 = 30} k_t 0.1 (fitted: {j2 = 60} k_t 0.1)" in err
    assert "m1 " not in err  # the motors that agree are not listed


def test_a_malformed_recorded_drive_chain_is_a_difference_not_a_crash():
    """Found by a review: a hand-edited results file whose settings.drive_chain
    gives a motor's joints as a list or a ratio as text stopped dynid validate
    with a traceback ('list' object has no attribute 'items') or "Unknown format
    code 'g' for object of type 'str'"; the note on the drive chain says they
    differ instead."""
    from drake_dynid.commands._results import drive_mismatch

    robot = RobotModel.from_urdf(URDF, drive=str(DATA / "wrist4.toml"))
    summary = robot.drive.summary()
    assert drive_mismatch({"settings": {"drive_chain": summary}}, robot) is None
    for bad in ({"joints": ["j1"]}, {"joints": {"j1": "60"}}, {"joints": None}):
        motors = [{**summary["motors"][0], **bad}, *summary["motors"][1:]]
        document = {"settings": {"drive_chain": {**summary, "motors": motors}}}
        note = drive_mismatch(document, robot)
        assert note is not None and "m1 {j1 = 60} k_t 0.12 (fitted: " in note, note
        assert "m2 " not in note
    motors = [{**summary["motors"][0], "torque_constant": "x"}]
    document = {"settings": {"drive_chain": {"motors": motors}}}
    assert "(fitted: {j1 = 60} k_t 'x')" in drive_mismatch(document, robot)
    document = {"settings": {"drive_chain": {"motors": 5}}}
    assert "m1 {j1 = 60} k_t 0.12 (fitted: none)" in drive_mismatch(document, robot)


def test_a_dead_zone_wider_than_every_speed_is_named_with_a_drive(files, capsys):
    """Found by a review: the hint naming a dead zone wider than every speed was
    left out with a drive chain, whose FCj and FCmk columns it zeroes just as
    well (wrist4 with --dead-zone 1e300: 'FC1 ... FCm4 not excited' alone)."""
    _, raw, drive = files
    argv = ["offline", *raw, "--urdf", URDF, "--drive", str(drive)]
    assert cli.main([*argv, "--dead-zone", "1e300"]) == 2
    error = error_line(capsys)
    assert "FCm4" in error
    assert "The Coulomb dead zone is wider than every speed of j1 (width 1e+300" in (
        error
    )
    assert "motor m4 (width 1.41e+300" in error
    # Found by a review: with --joints j3,j4 the motor's columns are FCm2 (the
    # second motor of those joints' chain) and the hint said "motor m2", the
    # drive file's motor of j2; now the drive file's name, m4.
    joints = ["--joints", "j3,j4", "--dead-zone", "1e300"]
    assert cli.main([*argv, *joints]) == 2
    error = capsys.readouterr().err  # a warning first: enc_m1 ... not used
    assert "Traceback" not in error
    assert "FCm2" in error and "motor m4 (width 1.41e+300" in error, error
    assert "motor m2" not in error
