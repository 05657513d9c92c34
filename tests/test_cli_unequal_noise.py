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


def test_joints_with_few_residual_degrees_of_freedom_are_not_compared():
    """A review: equal noise on every joint of 20 s iiwa7 logs (61 decimated rows
    per joint) gave σ_j 12.6× apart: the shoulder's own fit (rank 40-44) absorbs
    part of its noise. Such joints (K - rank_j < rank_j) are left out."""
    from types import SimpleNamespace

    from drake_dynid.commands.offline import _unequal_noise

    robot = SimpleNamespace(joint_names=("a", "b", "c"))
    sigma, rank = np.array([1.0, 0.05, 2.0]), np.array([9, 44, 12])

    def result(rows):
        reduced = SimpleNamespace(num_samples=rows)
        return SimpleNamespace(model="idim-ls", reduced=reduced)

    assert _unequal_noise(robot, sigma, rank, result(61)) == ""
    note = _unequal_noise(robot, sigma, rank, result(88))
    assert "differ by 40×" in note and "(σ c 2, b 0.05)" in note
    assert _unequal_noise(robot, np.array([1.0, 0.5, 2.0]), rank, result(88)) == ""


def test_joint_noise_fits_gives_each_joints_rank():
    from drake_dynid.core.idim import joint_noise_fits, joint_noise_std, reduce_rows

    rng = np.random.default_rng(0)
    W = rng.normal(size=(50, 2, 4))
    W[:, 1, :2] = 0.0  # joint 2 sees two parameters
    tau = rng.normal(size=(50, 2))
    sigma, rank = joint_noise_fits(reduce_rows(W, tau))
    assert rank.tolist() == [4, 2]
    np.testing.assert_allclose(sigma, joint_noise_std(W, tau), rtol=1e-12)
    for j in range(2):
        columns = W[:, j, rank[j] - 4 :] if j else W[:, j]
        fit = np.linalg.lstsq(columns, tau[:, j], rcond=None)[0]
        residual = columns @ fit - tau[:, j]
        assert sigma[j] == pytest.approx(
            np.linalg.norm(residual) / np.sqrt(50 - rank[j])
        )


def test_weights_on_few_degrees_of_freedom_are_named():
    """A review: with --weighted, the joints whose own fit leaves fewer residual
    degrees of freedom than parameters get σ_j too low (WLS 1.2× worse than LS
    on 20 s iiwa7 logs): named."""
    from types import SimpleNamespace

    from drake_dynid.commands.offline import _shaky_weights

    robot = SimpleNamespace(joint_names=("a", "b", "c"))
    rank = np.array([40, 44, 9])

    def result(model, rows):
        reduced = SimpleNamespace(num_samples=rows)
        return SimpleNamespace(model=model, reduced=reduced)

    note = _shaky_weights(robot, rank, result("idim-wls", 61))
    assert "a, b leave fewer residual degrees of freedom" in note
    assert "(21, 17 for 40, 44)" in note
    assert _shaky_weights(robot, rank, result("idim-wls", 88)) == ""
    assert _shaky_weights(robot, rank, result("idim-ls", 61)) == ""
