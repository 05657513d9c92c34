"""``--fill-gaps N``: the reader's longest interpolated run, from the command line.

Found by a review: a log with 6 % bad cells was refused with "read it with
fill_gaps=0", an option only the Python API had. The log: the 2R test motion of
tests/_motions.py, 40 s, with every other row's torque cells empty from 30 to
34.4 s (5.5 % of the samples: a logger that dropped half its messages for a
while).
"""

import json

import numpy as np
import pytest
from _motions import URDF_2R as URDF
from _motions import fourier_2r

from drake_dynid import cli
from drake_dynid.logs import write_log


@pytest.fixture(scope="module")
def holed(tmp_path_factory):
    robot, t, q, tau = fourier_2r(40001)
    tau[30000:34400:2] = np.nan
    path = tmp_path_factory.mktemp("fill_gaps") / "holed.csv"
    write_log(path, t, q, tau, robot.joint_names)
    return str(path)


def test_too_many_bad_cells_name_the_option(holed, capsys):
    assert cli.main(["offline", holed, "--urdf", URDF]) == 2
    err = capsys.readouterr().err
    assert "would invent data" in err and "--fill-gaps 0" in err, err
    assert "Traceback" not in err


@pytest.mark.parametrize("command", ["offline", "identify"])
def test_fill_gaps_0_keeps_them_bad_and_the_fit_runs(holed, tmp_path, command):
    out = tmp_path / "fit.json"
    argv = [command, holed, "--urdf", URDF, "--fill-gaps", "0", "--quiet"]
    assert cli.main([*argv, "--json", str(out)]) == 0
    document = json.loads(out.read_text())
    assert document["settings"]["fill_gaps"] == 0
    assert document["log"]["bad_samples"] == 2200
    assert all(np.isfinite(p["value"]) for p in document["parameters"])


@pytest.mark.parametrize("value", ["-1", "2.5", "x"])
def test_bad_fill_gaps_values_exit_2(holed, capsys, value):
    with pytest.raises(SystemExit) as stop:
        cli.main(["offline", holed, "--urdf", URDF, "--fill-gaps", value])
    assert stop.value.code == 2
    assert "--fill-gaps" in capsys.readouterr().err


def test_the_help_states_how_a_joined_files_gap_is_counted(capsys):
    """--fill-gaps counts a gap of a joined file in that file's own samples
    (drake_dynid.raw_log; one dropped 100 Hz effort under 1 kHz positions is one
    sample, not 20): the option's help says so."""
    with pytest.raises(SystemExit):
        cli.main(["offline", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "a gap of a file joined onto the first one counts in that file's own" in text
