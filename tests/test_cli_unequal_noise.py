"""dynid offline tells IDIM-LS users when the joints' equation errors differ by
more than 10× (a review: the Panda's wrist, 600× below the shoulder, predicted
worse than the URDF with IDIM-LS, and well with --weighted)."""

import json

import numpy as np
import pytest
from _drake_dynamics import exact_paper_2r

from drake_dynid import cli
from drake_dynid.logs import write_log
from drake_dynid.plants import RobotModel, model_path


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("unequal")
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = exact_paper_2r(robot)
    rng = np.random.default_rng(4)
    out = {}
    for name, scale in (("unequal", [0.3, 0.001]), ("equal", [0.01, 0.01])):
        path = folder / f"{name}.csv"
        noisy = tau + rng.normal(size=tau.shape) * np.array(scale)
        write_log(path, t, q, noisy, robot.joint_names)
        out[name] = path
    return out


def _offline(path, *extra, capsys, tmp_path):
    out = tmp_path / "fit.json"
    argv = ["offline", str(path), "--urdf", "planar_2r", "--json", str(out)]
    assert cli.main([*argv, "--quiet", *extra]) == 0
    return json.loads(out.read_text()), capsys.readouterr().err


def test_unequal_joint_noise_is_named_with_the_weighted_fix(logs, capsys, tmp_path):
    document, err = _offline(logs["unequal"], capsys=capsys, tmp_path=tmp_path)
    sigma = document["joint_noise_std"]
    assert sigma["joint1"] > 10 * sigma["joint2"]
    assert "dynid offline: note: the joints' equation errors differ by" in err
    assert "--weighted" in err and "(σ joint1 " in err
    document, err = _offline(
        logs["unequal"], "--weighted", capsys=capsys, tmp_path=tmp_path
    )
    assert "equation errors differ" not in err and document["model"] == "idim-wls"
    document, err = _offline(logs["equal"], capsys=capsys, tmp_path=tmp_path)
    assert "equation errors differ" not in err
    ratio = (
        document["joint_noise_std"]["joint1"] / document["joint_noise_std"]["joint2"]
    )
    assert 0.5 < ratio < 2.0
