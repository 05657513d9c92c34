"""``dynid payload`` on a simulated pick of the iiwa; bad input -> exit 2."""

import csv
import json
import re
from pathlib import Path

import numpy as np
import pytest
from test_examples import load_example

from drake_dynid import cli
from drake_dynid.logs import write_log
from drake_dynid.robot import RobotModel
from drake_dynid.simulation import SimulationSettings, simulate_identification
from drake_dynid.urdf import model_path

URDF = str(model_path("iiwa7"))
SMOOTHING = 0.01


@pytest.fixture(scope="module")
def log_file(tmp_path_factory):
    """Drake simulates the iiwa picking the example's payload at 1.5 s (3 s log)."""
    example = load_example("payload_pick")
    robot = RobotModel.from_urdf(URDF, coulomb_width=SMOOTHING)
    from drake_dynid.core.payload import payload_parameters
    from drake_dynid.core.trajectory import random_fourier_trajectory

    theta = payload_parameters(example.MASS, example.COM, example.INERTIA)
    trajectory = random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        rng=np.random.default_rng(5),
    )
    result = simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=3.0, snr_db=None, coulomb_smoothing=SMOOTHING),
        [],
        events=[(1.5, example.payload_event("iiwa_link_7", theta))],
    )
    rng = np.random.default_rng(2)
    path = tmp_path_factory.mktemp("logs") / "pick.csv"
    write_log(
        path,
        result.t,
        result.q_true + 1e-4 * rng.normal(size=result.q_true.shape),
        result.tau_true + 0.05 * rng.normal(size=result.q_true.shape),
        robot.joint_names,
    )
    return str(path)


COMMON = ["--coulomb-width", str(SMOOTHING), "--dead-zone", "none"]


def test_payload_command_prints_and_writes_the_estimate(log_file, tmp_path, capsys):
    out, csv_path = tmp_path / "payload.json", tmp_path / "payload.csv"
    argv = ["payload", log_file, "--urdf", URDF, *COMMON, "--every", "0.5"]
    code = cli.main([*argv, "--json", str(out), "--out", str(csv_path)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "payload: on link 7 (iiwa_joint_7), frame iiwa_link_7" in printed
    mass = float(re.search(r"^mass: ([0-9.]+) ± ([0-9.e-]+) kg$", printed, re.M)[1])
    assert abs(mass - 2.0) < 0.02
    com_z = float(re.search(r"^centre of mass z: ([0-9.]+) ± ", printed, re.M)[1])
    assert abs(com_z - 0.1) < 0.01
    assert re.search(r"^2\.5 +1\.99[0-9]* ± ", printed, re.M)  # --every 0.5
    document = json.loads(out.read_text())
    payload = document["payload"]
    assert payload["link"] == "iiwa_joint_7" and payload["frame"] == "iiwa_link_7"
    assert abs(payload["mass"]["value"] - 2.0) < 0.02 and payload["mass"]["identified"]
    assert abs(payload["com"]["z"]["value"] - 0.1) < 0.01
    assert [p["name"] for p in payload["parameters"]][-1] == "M"
    assert set(payload["inertia"]) == {"XX", "XY", "XZ", "YY", "YZ", "ZZ"}
    assert payload["not_identifiable"] == []
    assert document["valid"] and document["arm"]["source"] == "urdf"
    assert document["settings"]["window"] == 0.75
    with csv_path.open() as stream:
        rows = list(csv.reader(stream))
    assert rows[0][:3] == ["t", "valid", "XX"] and len(rows) > 50
    # The final row (printed, --out's last) is the solve at the log's last sample
    # (3 s), at t_N = 3.001 s: before, the last row (3 s) held the solve at 2.95 s.
    assert "final estimate (t = 3.001 s)" in printed
    assert [row[0] for row in rows[-2:]] == ["3", "3.001"] and len(rows) - 1 == 62


def test_arm_parameters_from_a_results_file_and_the_blocks_engine(
    log_file, tmp_path, capsys
):
    arm = tmp_path / "arm.json"
    assert cli.main(["params", URDF, "--json", str(arm)]) == 0
    first, second = tmp_path / "a.json", tmp_path / "b.json"
    base = ["payload", log_file, "--urdf", URDF, *COMMON, "--quiet"]
    assert cli.main([*base, "--json", str(first)]) == 0
    assert cli.main([*base, "--params", str(arm), "--json", str(second)]) == 0
    blocks = tmp_path / "c.json"
    assert cli.main([*base, "--engine", "blocks", "--json", str(blocks)]) == 0
    one, two, three = (
        json.loads(p.read_text())["payload"] for p in (first, second, blocks)
    )
    assert two["mass"]["value"] == pytest.approx(one["mass"]["value"], rel=1e-9)
    assert three["mass"]["value"] == pytest.approx(one["mass"]["value"], rel=1e-9)
    assert json.loads(second.read_text())["arm"]["source"] == str(arm)


def test_offset_frames_and_bad_input(log_file, tmp_path, capsys):
    base = ["payload", log_file, "--urdf", URDF, *COMMON, "--quiet"]
    out = tmp_path / "offset.json"
    # The same payload about a frame 0.1 m along the flange's z: MZ = m(c_z - 0.1).
    assert cli.main([*base, "--offset", "0,0,0.1", "--json", str(out)]) == 0
    payload = json.loads(out.read_text())["payload"]
    assert abs(payload["com"]["z"]["value"]) < 0.01
    assert payload["offset"] == {"xyz": [0.0, 0.0, 0.1], "rpy": [0.0, 0.0, 0.0]}
    capsys.readouterr()
    # A frame on the first link: the first joint sees only ZZ (printed over time).
    first = ["payload", log_file, "--urdf", URDF, *COMMON, "--frame", "iiwa_link_1"]
    assert cli.main([*first, "--every", "1"]) == 0
    printed = capsys.readouterr().out
    assert "t [s]     ZZ (* %σ > 30)" in printed and "mass: not identifiable" in printed
    assert "not identifiable from these joints: XX, XY, XZ, YY, YZ, MX, MY, MZ, M" in (
        printed
    )
    planar = tmp_path / "planar.json"
    assert (
        cli.main(["params", str(model_path("planar_2r")), "--json", str(planar)]) == 0
    )
    short = tmp_path / "short.csv"
    with open(log_file) as stream:
        lines = stream.read().splitlines()
    short.write_text("\n".join(lines[:600]) + "\n")
    cases = [
        (["--frame", "gripper"], "--frame must be a body or frame of the URDF"),
        (["--frame", "iiwa_link_0"], "does not move rigidly with any identified link"),
        (["--offset", "1,2"], "--offset must be X,Y,Z"),
        (["--offset", "1e300,0,0"], "|X|, |Y|, |Z| <= 100 m"),  # was NaN rows
        (["--frequencies", "0"], "use more modulating functions (--frequencies"),
        (["--every", "-1"], "--every must be > 0"),
        (["--window", "-1"], "--window must be > 0"),
        (["--params", str(planar)], "holds 8 base parameters"),
        (["--json", log_file], "--json"),
    ]
    for extra, message in cases:
        assert cli.main([*base, *extra]) == 2, extra
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, (extra, err)
    assert cli.main(["payload", str(short), "--urdf", URDF, *COMMON]) == 2
    assert "--window" in capsys.readouterr().err


def test_the_readme_makes_this_log_with_the_example(log_file, tmp_path, capsys):
    """README "Payload identification": `python examples/payload_pick.py --pick 1.5
    --duration 3 --seed 2 --log pick.csv` writes this test's log (a review could
    not reproduce the README's numbers: no command made pick.csv)."""
    from drake_dynid.logs import read_log

    example = load_example("payload_pick")
    path = tmp_path / "pick.csv"
    argv = ["--pick", "1.5", "--duration", "3", "--seed", "2", "--log", str(path)]
    assert example.main([*argv, "--out", str(tmp_path / "out")]) == 0
    capsys.readouterr()
    names = RobotModel.from_urdf(URDF).joint_names
    made, fixture = read_log(path, names), read_log(log_file, names)
    np.testing.assert_array_equal(made.q, fixture.q)
    np.testing.assert_array_equal(made.tau, fixture.tau)


def test_an_invalid_final_window_labels_the_table_with_its_estimates_time(
    log_file, tmp_path, capsys
):
    """The pick log, then 1 s at rest: the final window is not valid and the table
    holds the last valid window's estimate. Its heading said "final estimate (t =
    4.001 s)" above the estimate of 3.8 s (the TIAGo recording: t = 80.22 s above
    the window of 68.75 s), which only a line below the table corrected."""
    from drake_dynid.logs import read_log

    names = RobotModel.from_urdf(URDF).joint_names
    log = read_log(log_file, names)
    q, tau = np.asarray(log.q), np.asarray(log.tau)
    rng = np.random.default_rng(0)
    rest = 1000
    path = tmp_path / "pick_rest.csv"
    write_log(
        path,
        np.arange(q.shape[0] + rest) * log.time_step,
        np.vstack([q, q[-1] + 1e-4 * rng.normal(size=(rest, 7))]),
        np.vstack([tau, tau[-1] + 0.05 * rng.normal(size=(rest, 7))]),
        names,
    )
    assert cli.main(["payload", str(path), "--urdf", URDF, *COMMON]) == 0
    printed = capsys.readouterr().out
    last = re.search(r"the last valid estimate \(t = ([0-9.]+) s\) is shown", printed)
    assert last, printed
    assert "final estimate (t = 4.001 s)" not in printed
    assert (
        f"last valid estimate (t = {last[1]} s; the final window, t = 4.001 s, is "
        "not valid), about the attachment frame, in its axes:"
    ) in printed


@pytest.mark.parametrize(
    "option, message",
    [
        ("--window", "--window must be > 0"),
        ("--jacobi-window", "--jacobi-window must be > 0"),
        ("--update-period", "--update-period must be > 0"),
        ("--raw-window", "--raw-window must be > 0"),
        ("--bank-time-step", "--bank-time-step must be > 0"),
        ("--max-condition", "--max-condition must be in (1"),
    ],
)
def test_a_zero_setting_is_refused_not_replaced_by_the_default(
    option, message, tmp_path, capsys
):
    """`--window 0` (or any zero setting) ran with the default 0.75 s and exit 0:
    the options were kept only when truthy, so 0 counted as not given."""
    log = tmp_path / "log.csv"
    names = RobotModel.from_urdf(URDF).joint_names
    t = 1e-3 * np.arange(2000)
    write_log(log, t, np.zeros((t.size, 7)), np.zeros((t.size, 7)), names)
    assert cli.main(["payload", str(log), "--urdf", URDF, option, "0"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err, err


def test_a_100_hz_log_gets_the_default_periods_on_its_grid(log_file, tmp_path, capsys):
    """Found by a review: on the TIAGo's 100 Hz recording the command stopped
    with '--bank-time-step must be a multiple of the signal period; got 0.002
    with h 0.01 (leave it unset ...)', the option left unset: the default 2 ms
    is now the nearest multiple of the log's step, as on_grid does."""
    lines = Path(log_file).read_text().splitlines()
    slow = tmp_path / "pick_100hz.csv"
    slow.write_text("\n".join([lines[0], *lines[1::10]]) + "\n")  # every 10 ms
    out = tmp_path / "slow.json"
    argv = ["payload", str(slow), "--urdf", URDF, *COMMON, "--quiet"]
    assert cli.main([*argv, "--json", str(out)]) == 0, capsys.readouterr().err
    settings = json.loads(out.read_text())["settings"]
    assert settings["bank_time_step"] == pytest.approx(0.01)
    assert settings["update_period"] == pytest.approx(0.05)
    # Given off the grid, it is still refused, naming the option.
    assert cli.main([*argv, "--bank-time-step", "0.002"]) == 2
    assert "--bank-time-step must be a multiple" in capsys.readouterr().err


def test_the_params_file_gives_the_friction_columns_and_dead_zone(
    log_file, tmp_path, capsys
):
    """Found by a review: --params of a fit with --friction viscous,coulomb,offset
    was refused ("holds 64 base parameters but ... (friction viscous,coulomb)"),
    and the fit's dead-zone widths were replaced by ones measured on the payload's
    log: payload's --friction and --dead-zone defaults hid the results file's."""
    arm = tmp_path / "arm.json"
    argv = ["params", URDF, "--friction", "viscous,coulomb,offset"]
    assert cli.main([*argv, "--json", str(arm)]) == 0
    document = json.loads(arm.read_text())
    joints = document["joints"]
    document["settings"]["coulomb_dead_zone"] = dict.fromkeys(joints, 0.025)
    arm.write_text(json.dumps(document))
    capsys.readouterr()
    base = ["payload", log_file, "--urdf", URDF, "--params", str(arm)]
    assert cli.main(base) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    assert "(64 base parameters, known; no covariance in the file" in printed
    assert "iiwa_joint_1 0.025 rad/s" in printed


def _still_log(path, rate, seconds=3.0):
    """A log of the iiwa at ``rate`` [Hz] (the checks below stop before a fit)."""
    t = np.arange(0.0, seconds, 1.0 / rate)
    q = 0.3 * np.sin(np.outer(t, np.arange(1, 8)))
    names = [f"iiwa_joint_{i}" for i in range(1, 8)]
    write_log(path, t, q, np.ones_like(q), names)
    return str(path)


def test_a_log_too_slow_for_the_jacobi_window_names_the_option(tmp_path, capsys):
    """Found by a review: at 50 Hz the default bank step moved to 20 ms, above
    the Jacobi window's tenth, and the command stopped on 'OnlineSettings:
    bank_time_step must be <= jacobi_window/10 ... got 0.02', a field and a value
    the user never gave; the log's step is what is too coarse for --jacobi-window
    (as dynid identify says)."""
    log = _still_log(tmp_path / "slow.csv", 50.0)
    assert cli.main(["payload", log, "--urdf", URDF, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "--jacobi-window must be >= 10 signal periods" in err, err
    assert "OnlineSettings" not in err and "bank_time_step" not in err, err


def test_the_default_bank_step_follows_the_jacobi_window(tmp_path, capsys):
    """Found by a review: --jacobi-window 0.01 (or 0.015) alone was refused
    ('--jacobi-window must be >= 10 x --bank-time-step ... with
    --bank-time-step's default 0.002'), where dynid identify derives its bank
    step from the Jacobi window. The default is now min(2 ms, Tj/10) on the
    log's grid, as identify's rule (1 ms for both at 1 kHz, 2 ms for 0.1 s);
    given both, or the bank step alone, the conflict is said both ways."""
    log = _still_log(tmp_path / "log.csv", 1000.0)
    argv = ["payload", log, "--urdf", URDF, "--quiet"]
    out = tmp_path / "p.json"
    for window, step in (("0.01", 0.001), ("0.015", 0.001), ("0.1", 0.002)):
        options = ["--jacobi-window", window, "--json", str(out)]
        assert cli.main([*argv, *options]) == 0, capsys.readouterr().err
        settings = json.loads(out.read_text())["settings"]
        assert settings["bank_time_step"] == pytest.approx(step), window
    both = ["--jacobi-window", "0.01", "--bank-time-step", "0.002"]
    for options in (both, ["--bank-time-step", "0.05"]):
        assert cli.main([*argv, *options]) == 2
        err = capsys.readouterr().err
        assert "error: --bank-time-step must be <= --jacobi-window/10" in err, err
        assert "lengthen --jacobi-window to at least" in err
        assert "or shorten --bank-time-step to at most" in err


def test_the_arm_line_says_a_files_physical_estimate_is_not_used(
    log_file, tmp_path, capsys
):
    """--params of a `dynid offline --physical --json` file takes its fit (whose
    covariance the file records), not its physical estimate; the arm line named
    the file alone ('arm: fit.json (57 base parameters, known; ...)'), so a user
    who ran --physical for a consistent arm could not tell which was used."""
    arm = tmp_path / "apriori.json"
    assert cli.main(["params", URDF, "--json", str(arm)]) == 0
    document = json.loads(arm.read_text())
    document["physical"] = {"parameters": document["parameters"]}
    both = tmp_path / "both.json"
    both.write_text(json.dumps(document))
    argv = ["payload", log_file, "--urdf", URDF, *COMMON]
    assert cli.main([*argv, "--params", str(both)]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("arm:"))
    assert "known, the fit's estimate; not the file's physical one" in line
    assert cli.main([*argv, "--params", str(arm)]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if x.startswith("arm:"))
    assert "physical" not in line


def test_a_params_file_without_a_coulomb_law_gets_the_auto_dead_zone(
    log_file, tmp_path
):
    """Found by a review: --params of a `dynid params --json` file (the URDF's
    a-priori values: no dead zone recorded) gave the exact sign(v), where the
    help says '(default: the --params file's widths, else auto)' and the command
    measured the widths on the log before --params files gave theirs."""
    import argparse

    from drake_dynid.commands import payload
    from drake_dynid.core.friction import DeadZoneSign

    arm = tmp_path / "apriori.json"
    assert cli.main(["params", URDF, "--json", str(arm)]) == 0
    parser = argparse.ArgumentParser()
    payload.add_arguments(parser)
    plain, with_params = (
        payload._robot(parser.parse_args([log_file, "--urdf", URDF, *extra]))[0]
        for extra in ([], ["--params", str(arm)])
    )
    assert isinstance(plain.sign, DeadZoneSign)
    assert isinstance(with_params.sign, DeadZoneSign)
    np.testing.assert_allclose(with_params.sign.width, plain.sign.width)


def test_the_params_files_covariance_widens_sigma_and_is_recorded(
    log_file, tmp_path, capsys
):
    """A results file with the arm's covariance (dynid offline --json writes it):
    its image through each window's solve adds to σ (docs/PAYLOAD.md §4), the
    estimate unchanged; the printout and the JSON say which σ terms are in. A
    covariance that is none is refused, naming the file."""
    arm = tmp_path / "arm.json"
    assert cli.main(["params", URDF, "--json", str(arm)]) == 0
    document = json.loads(arm.read_text())
    values = np.array([p["value"] for p in document["parameters"]])
    document["covariance"] = np.diag((0.002 * np.abs(values) + 1e-5) ** 2).tolist()
    given = tmp_path / "arm_cov.json"
    given.write_text(json.dumps(document))
    capsys.readouterr()
    base = ["payload", log_file, "--urdf", URDF, *COMMON]
    one, two = tmp_path / "a.json", tmp_path / "b.json"
    assert cli.main([*base, "--params", str(arm), "--json", str(one)]) == 0
    assert "known; no covariance in the file" in capsys.readouterr().out
    assert cli.main([*base, "--params", str(given), "--json", str(two)]) == 0
    assert "known; their covariance propagated to σ" in capsys.readouterr().out
    plain, wide = (json.loads(p.read_text()) for p in (one, two))
    assert plain["sigma_terms"] == {
        "rows_noise": True,
        "arm_covariance": False,
        "arm_model_error": False,
    }
    assert wide["sigma_terms"]["arm_covariance"] is True
    mass = plain["payload"]["mass"], wide["payload"]["mass"]
    assert mass[1]["value"] == mass[0]["value"]
    assert mass[1]["std"] > 1.2 * mass[0]["std"], mass
    gautier = tmp_path / "c.json"
    argv = [*base, "--params", str(given), "--uncertainty", "gautier"]
    assert cli.main([*argv, "--json", str(gautier)]) == 0
    assert "not propagated under --uncertainty gautier" in capsys.readouterr().out
    assert json.loads(gautier.read_text())["sigma_terms"]["arm_covariance"] is False
    # Found by a review: a file without one said "their covariance not propagated
    # under --uncertainty gautier" too.
    argv = [*base, "--params", str(arm), "--uncertainty", "gautier"]
    assert cli.main(argv) == 0
    assert "known; no covariance in the file" in capsys.readouterr().out
    for bad, message in (
        ([[1.0, 2.0]], "'covariance' must be a 57 × 57 matrix"),
        ((-np.eye(57)).tolist(), "'covariance' must be positive semi-definite"),
    ):
        document["covariance"] = bad
        given.write_text(json.dumps(document))
        assert cli.main([*base, "--params", str(given), "--quiet"]) == 2
        err = capsys.readouterr().err
        assert f"--params {given}: {message}" in err and "Traceback" not in err, err


def test_the_params_files_model_notes_name_dynid_payload(tmp_path, capsys):
    """Found by a review: with --params, the model's notes (Drake's parser's
    warnings on the TIAGo URDF) were printed as 'dynid validate: note:'."""
    arm = tmp_path / "arm.json"
    argv = ["--urdf", "tiago_no_hand", "--joints", "arm_1_joint,arm_2_joint"]
    assert cli.main(["params", "tiago_no_hand", *argv[2:], "--json", str(arm)]) == 0
    capsys.readouterr()
    missing = str(tmp_path / "missing.csv")
    assert cli.main(["payload", missing, *argv, "--params", str(arm)]) == 2
    err = capsys.readouterr().err
    assert "dynid payload: note: Drake's parser" in err, err
    assert "dynid validate" not in err, err
