"""An output never overwrites an input, in every subcommand (issue 14).

Each case names an output option and an input of one subcommand; the command
exits 2 with one line naming both, before reading anything, and every input file
is left byte for byte as it was (also through a hard link and a ./ prefix).
"""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from drake_dynid import cli
from drake_dynid.plants import model_path


@pytest.fixture
def files(tmp_path):
    urdf = tmp_path / "robot.urdf"
    shutil.copy(model_path("planar_2r"), urdf)
    log = tmp_path / "log.csv"
    log.write_text("t,q_joint1,q_joint2,tau_joint1,tau_joint2\n0,0,0,0,0\n")
    held = tmp_path / "held.csv"
    held.write_text(log.read_text())
    params = tmp_path / "fit.json"
    params.write_text("{}")
    limits = tmp_path / "limits.json"
    limits.write_text("{}")
    trajectory = tmp_path / "traj.csv"
    trajectory.write_text("t,q_joint1,q_joint2\n0,0,0\n")
    link = tmp_path / "link.csv"
    os.link(log, link)
    drive = tmp_path / "drive.toml"
    drive.write_text("")
    page = tmp_path / "replay.meshcat.html"
    page.write_text("{}")
    return {
        "urdf": str(urdf),
        "log": str(log),
        "held": str(held),
        "params": str(params),
        "limits": str(limits),
        "trajectory": str(trajectory),
        "link": str(link),
        "drive": str(drive),
        "page": str(page),
        "page_log": str(tmp_path / "replay.csv"),
        "dot_log": os.path.join(str(tmp_path), ".", "log.csv"),
    }


CASES = [
    ("params {urdf} --json {urdf}", "--json", "the URDF"),
    ("identify {log} --urdf {urdf} --out {log}", "--out", "the log"),
    ("identify {log} --urdf {urdf} --json {log}", "--json", "the log"),
    ("identify {log} --urdf {urdf} --json {urdf}", "--json", "the URDF"),
    ("identify {log} --urdf {urdf} --plot {dot_log}", "--plot", "the log"),
    ("identify {log} --urdf {urdf} --json {link}", "--json", "the log"),
    (
        "identify {log} --urdf {urdf} --validate {held} --out {held}",
        "--out",
        "--validate",
    ),
    ("offline {log} --urdf {urdf} --urdf-out {urdf}", "--urdf-out", "the URDF"),
    ("offline {log} --urdf {urdf} --out {log}", "--out", "the log"),
    ("offline {log} --urdf {urdf} --plot {urdf}", "--plot", "the URDF"),
    (
        "validate {log} --urdf {urdf} --params {params} --json {params}",
        "--json",
        "--params",
    ),
    (
        "validate {log} --urdf {urdf} --params {params} --plot {log}",
        "--plot",
        "the log",
    ),
    ("excite {urdf} --out {urdf}", "--out", "the URDF"),
    (
        "excite {urdf} --limits {limits} --out t.csv --json {limits}",
        "--json",
        "--limits",
    ),
    (
        "simulate {urdf} --trajectory {trajectory} --out {trajectory}",
        "--out",
        "--trajectory",
    ),
    ("simulate {urdf} --trajectory {trajectory} --out {urdf}", "--out", "the URDF"),
    (
        "simulate {urdf} --trajectory {trajectory} --drive {drive} --out {drive}",
        "--out",
        "--drive",
    ),
    (
        "simulate {urdf} --trajectory {trajectory} --limits {page} --meshcat "
        "--out {page_log}",
        "the Meshcat page",
        "--limits",
    ),
]


@pytest.mark.parametrize(("command", "option", "input_name"), CASES)
def test_an_output_never_overwrites_an_input(
    files, capsys, command, option, input_name
):
    before = {
        name: Path(path).read_bytes()
        for name, path in files.items()
        if name not in ("dot_log", "page_log")
    }
    argv = command.format(**files).split()
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"{option} " in err and "is an input of this command" in err, err
    assert f"({input_name} " in err, err
    after = {name: Path(files[name]).read_bytes() for name in before}
    assert after == before


def test_two_outputs_are_never_one_file(files, capsys):
    argv = ["identify", files["log"], "--urdf", files["urdf"]]
    argv += ["--json", "same.json", "--out", "./same.json"]
    assert cli.main(argv) == 2
    assert "are the same file" in capsys.readouterr().err


MISSING_FOLDER = [
    "identify {log} --urdf {urdf} --plot {missing}/p.png",
    "offline {log} --urdf {urdf} --json {missing}/out.json",
    "validate {log} --urdf {urdf} --params {params} --json {missing}/v.json",
    "simulate {urdf} --trajectory {trajectory} --out {missing}/log.csv",
    "excite {urdf} --out {missing}/t.csv",
    "params {urdf} --json {missing}/p.json",
]


@pytest.mark.parametrize("command", MISSING_FOLDER)
def test_an_output_in_a_missing_folder_is_refused_before_any_work(
    files, capsys, tmp_path, command
):
    """Found by a review: ``--plot nodir/p.png`` failed after the whole run."""
    missing = tmp_path / "no" / "such"
    argv = command.format(missing=missing, **files).split()
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"the folder {missing} does not exist" in err, err
    assert not (tmp_path / "no").exists()


def test_an_output_in_a_folder_that_cannot_be_written_is_refused(
    files, capsys, tmp_path, monkeypatch
):
    """The permission test is ``os.access`` (root may write anywhere: patched)."""
    from drake_dynid.commands import _paths

    locked = tmp_path / "locked"
    locked.mkdir()
    real = os.access
    monkeypatch.setattr(
        _paths.os, "access", lambda p, mode: Path(p) != locked and real(p, mode)
    )
    argv = ["offline", files["log"], "--urdf", files["urdf"]]
    argv += ["--json", str(locked / "out.json")]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert f"the folder {locked} cannot be written" in err, err


@pytest.mark.parametrize("name", ["fit.xyz", "fit"])
def test_a_plot_in_an_unknown_format_is_refused_before_any_work(files, capsys, name):
    """Found by a review: "Format 'xyz' is not supported" after the whole fit."""
    argv = ["offline", files["log"], "--urdf", files["urdf"], "--plot", name]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert f"--plot {name}: a figure file ends in " in err and ".png" in err, err


def test_bootstrap_has_a_ceiling(files, capsys):
    """Found by a review: --bootstrap 1000000 ran for minutes."""
    argv = ["identify", files["log"], "--urdf", files["urdf"], "--bootstrap", "1001"]
    assert cli.main(argv) == 2
    assert "--bootstrap must be 0 (no bootstrap) or a number of replicates in 2" in (
        capsys.readouterr().err
    )


def test_regularization_beyond_its_range_is_refused_before_the_fit(files, capsys):
    """Found by a review: --regularization 1e300 failed in the solver after the fit."""
    argv = ["offline", files["log"], "--urdf", files["urdf"], "--physical"]
    assert cli.main([*argv, "--regularization", "1e300"]) == 2
    assert "--regularization must be in [0, 1e6]" in capsys.readouterr().err
    # Found by a review: without --physical (or --urdf-out) it was ignored.
    for command in ("offline", "identify"):
        argv = [command, files["log"], "--urdf", files["urdf"]]
        assert cli.main([*argv, "--regularization", "0.1"]) == 2
        assert "give it with --physical (or --urdf-out)" in capsys.readouterr().err


def test_an_existing_writable_file_in_a_locked_folder_is_accepted(
    files, capsys, tmp_path, monkeypatch
):
    """Found by a review: --json /dev/null (a writable file in a folder a user
    cannot write) was refused: the file is written in place."""
    from drake_dynid.commands import _paths

    locked = tmp_path / "locked"
    locked.mkdir()
    target = locked / "out.json"
    target.write_text("{}")
    real = os.access
    monkeypatch.setattr(
        _paths.os, "access", lambda p, mode: Path(p) != locked and real(p, mode)
    )
    argv = ["offline", files["log"], "--urdf", files["urdf"], "--json", str(target)]
    cli.main(argv)  # the one-row log fails later, on its own terms
    assert "cannot be written" not in capsys.readouterr().err


def test_a_meshcat_page_that_is_not_html_is_refused(files, capsys):
    argv = ["replay", files["urdf"], files["log"], "--html", "page.txt"]
    assert cli.main(argv) == 2
    assert "--html page.txt: a page file ends in .html" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("command", "option"),
    [
        (["offline", "{log}", "--urdf", "{urdf}", "--urdf-out", ""], "--urdf-out"),
        (["offline", "{log}", "--urdf", "{urdf}", "--json", ""], "--json"),
        (["params", "{urdf}", "--json", ""], "--json"),
        (
            [
                "validate",
                "{held}",
                "--urdf",
                "{urdf}",
                "--params",
                "{params}",
                "--plot",
                "",
            ],
            "--plot",
        ),
    ],
)
def test_an_empty_output_path_is_refused(files, capsys, command, option):
    # A review: --urdf-out "" (an unset shell variable) ran the fit, wrote no
    # identified URDF, skipped --physical and exited 0.
    argv = [part.format(**files) for part in command]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"{option}: the path is empty" in err, err


REFUSED_ON_STDOUT = [
    ("identify {log} --urdf {urdf} --plot -", "--plot"),
    ("offline {log} --urdf {urdf} --urdf-out -", "--urdf-out"),
    ("validate {log} --urdf {urdf} --params {params} --plot -", "--plot"),
    ("simulate {urdf} --trajectory {trajectory} --out -", "--out"),
    ("replay {urdf} {log} --html -", "--html"),
    ("fleet offline {log} --urdf {urdf} --out-dir -", "--out-dir"),
    ("offline {log} --urdf {urdf} --json - --out -", "--out and --json"),
]


@pytest.mark.parametrize(("command", "option"), REFUSED_ON_STDOUT)
def test_an_output_that_is_no_text_for_a_pipe_refuses_dash(
    files, capsys, monkeypatch, tmp_path, command, option
):
    """``-`` wrote a file named "-" (after the whole run); a figure, a URDF, a
    page, a simulated log with its truth file and a fleet's folder refuse it,
    and so do two outputs on standard output, before any work."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(command.format(**files).split()) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"error: {option} " in err and "'-'" in err, err
    assert not (tmp_path / "-").exists()


def test_dash_writes_the_json_and_csv_outputs_to_standard_output(
    capsys, monkeypatch, tmp_path
):
    """``--json -`` and ``--out -`` (JSON, CSV) are standard output, holding
    that file alone (the report is not printed, as with --quiet): the bytes
    of the file the option writes; no file named "-"."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["params", "planar_2r", "--json", "p.json"]) == 0
    capsys.readouterr()
    assert cli.main(["params", "planar_2r", "--json", "-"]) == 0
    assert capsys.readouterr().out == (tmp_path / "p.json").read_text()
    trajectory = ["excite", "iiwa7", "--duration", "5", "--sample-rate", "50"]
    assert cli.main([*trajectory, "--out", "t.csv", "--json", "t.json"]) == 0
    capsys.readouterr()
    assert cli.main([*trajectory, "--out", "-", "--json", "e.json"]) == 0
    out = capsys.readouterr().out
    assert out == (tmp_path / "t.csv").read_text()
    assert out.startswith("t,q_iiwa_joint_1,") and out.count("\n") == 252
    assert not (tmp_path / "-").exists()


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_standard_output_is_named(tmp_path):
    """``--json - > /dev/full`` said '[Errno 28] No space left on device' and
    named nothing (a file output names its path)."""
    argv = [sys.executable, "-m", "drake_dynid.cli", "params", "planar_2r"]
    with open("/dev/full", "w") as full:
        done = subprocess.run(
            [*argv, "--json", "-"], stdout=full, stderr=subprocess.PIPE, check=False
        )
    assert done.returncode == 2
    err = done.stderr.decode()
    assert "No space left on device: 'standard output'" in err, err
    assert "Traceback" not in err
