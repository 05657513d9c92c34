"""Bad values beyond the options (issue 14): URDF inertias, API misuse, glitches.

Logs: the paper's 2R arm on a random Fourier reference (numpy default_rng(4)),
torques from the library's inverse dynamic model (no Drake simulation needed),
noise from the seeds stated in each test.
"""

import math

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core import idim, idim_auto
from drake_dynid.core.jacobi_stream import jacobi_apply, jacobi_batch
from drake_dynid.core.online import OnlineSettings, nearest_multiple
from drake_dynid.core.replay import replay_log_core
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.limits import joint_limits
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.physical import check_physical
from drake_dynid.plants import RobotModel, model_path

URDF = model_path("planar_2r")

BAD_URDF = """<?xml version="1.0"?>
<robot name="r">
  <link name="world"/>
  <link name="a"><inertial><origin xyz="0.5 0 0"/><mass value="1"/>
    <inertia ixx="0.1" iyy="0.1" izz="5" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="world"/><child link="a"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
  <link name="b"><inertial><origin xyz="0.5 0 0"/><mass value="-2"/>
    <inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="3"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(URDF)


def _log(robot, duration=30.0, noise=(5e-3, 0.05), seed=1):
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.25,
        max_velocity=2.0,
        rng=np.random.default_rng(4),
    )
    t = np.arange(round(duration * 1000) + 1) * 1e-3
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    rng = np.random.default_rng(seed)
    q = q + rng.normal(0.0, noise[0], q.shape)
    tau = tau + rng.normal(0.0, noise[1], tau.shape)
    return RobotLog(t, q, tau, robot.joint_names, 1e-3)


def test_nonphysical_urdf_inertias_are_named_with_drakes_substitutes(tmp_path, capsys):
    path = tmp_path / "bad.urdf"
    path.write_text(BAD_URDF)
    model = RobotModel.from_urdf(str(path))
    (note,) = [n for n in model.notes if "non-physical <inertial>" in n]
    assert "link 'a': principal moments 0.1, 0.1, 5 kg·m² break the triangle" in note
    assert "link 'b': mass -2 kg < 0; Drake holds mass 1 kg" in note
    assert "are Drake's values, not the file's" in note
    assert cli.main(["params", str(path)]) == 0
    assert "note: non-physical <inertial> in bad.urdf (link 'a'" in (
        capsys.readouterr().err
    )
    # A physical URDF gets no such note.
    assert not [n for n in RobotModel.from_urdf(URDF).notes if "inertial" in n]


def test_block_offsets_must_be_finite_and_non_negative():
    from drake_dynid.core.modulating import fourier_bank
    from drake_dynid.systems.identifier import SlidingQRIdentifier
    from drake_dynid.systems.modulating_bank import ModulatingIntegralBank

    bank = fourier_bank(1.0, 0.01, order=1, ell=[0.0, 1.0])
    with pytest.raises(ValueError, match=r"ModulatingIntegralBank: offset must be"):
        ModulatingIntegralBank(bank, 1, 2, offset=math.nan)
    with pytest.raises(ValueError, match=r"offset must be >= 0 \[s\]"):
        ModulatingIntegralBank(bank, 1, 2, offset=-0.1)
    with pytest.raises(ValueError, match=r"SlidingQRIdentifier: offset must be"):
        SlidingQRIdentifier(2, 4, 0.1, offset=math.inf)


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (
            lambda r: replay_log_core("x", r, [OnlineSettings()]),
            TypeError,
            "log must be a RobotLog",
        ),
        (lambda r: nearest_multiple(1.0, 0.0), ValueError, "step must be > 0"),
        (lambda r: nearest_multiple(math.inf, 1.0), ValueError, "value must be finite"),
        (
            lambda r: OnlineSettings().on_grid(1e-3).decimation(0.0),
            ValueError,
            "time_step must be > 0",
        ),
        (
            lambda r: check_physical("x", np.zeros(8)),
            TypeError,
            "robot must be a RobotModel",
        ),
        (lambda r: joint_limits(1.0), TypeError, "robot must be a RobotModel"),
        (
            lambda r: jacobi_batch(1.0, np.zeros(5)),
            TypeError,
            "filt must be a JacobiFilter",
        ),
        (lambda r: jacobi_apply(0.0, 1.0), ValueError, "taps must be"),
        (lambda r: idim.default_trim(1e-3, 1e-320), ValueError, "fewer than 2"),
        (
            lambda r: idim_auto.auto_decimation(1e-300, 1e-300),
            ValueError,
            "must be finite",
        ),
    ],
)
def test_api_misuse_gives_type_or_value_errors(robot, call, error, match):
    with pytest.raises(error, match=match):
        call(robot.rows_provider())


def test_a_finite_glitch_corrupts_no_window_after_it_has_left(robot):
    # τ = 1e20 on one sample at t = 2 s: the windows after it has left the bank's
    # window (and the differentiator's) equal those of the clean log to 1e-9.
    clean = _log(robot)
    tau = clean.tau.copy()
    tau[2000, 0] = 1e20
    glitch = RobotLog(clean.t, clean.q, tau, clean.joint_names, 1e-3)
    settings = [OnlineSettings(window=5.0)]
    (reference,) = replay_log_core(clean, robot.rows_provider(), settings)
    (trace,) = replay_log_core(glitch, robot.rows_provider(), settings)
    after = reference.t > 2.0 + 5.0 + 1.0
    assert np.all(trace.valid[after] == reference.valid[after])
    scale = np.max(np.abs(reference.theta[after]), axis=0)
    assert np.max(np.abs(trace.theta[after] - reference.theta[after]) / scale) < 1e-9


def test_pure_noise_with_the_papers_dense_set_identifies_nothing(robot):
    # Pure noise on q and τ (seed 11): Gautier's σ of the paper's ℓ = 0:0.05:10 is
    # 5-10 times too small and used to report parameters identified; the honest σ
    # flags them all in almost every valid window.
    rng = np.random.default_rng(11)
    t = np.arange(25001) * 1e-3
    log = RobotLog(
        t,
        rng.normal(0, 0.05, (t.size, 2)),
        rng.normal(0, 1.0, (t.size, 2)),
        robot.joint_names,
        1e-3,
    )
    settings = [OnlineSettings(window=5.0, frequencies="paper")]
    (trace,) = replay_log_core(log, robot.rows_provider(), settings)
    valid = trace.valid > 0.5
    assert valid.sum() > 50
    relative = 100.0 * trace.std[valid] / np.abs(trace.theta[valid])
    assert np.mean(relative <= 30.0) < 0.02


def test_numeric_warnings_never_reach_the_user(robot, tmp_path, capsys):
    log = _log(robot, duration=25.0)
    path = tmp_path / "tiny.csv"
    write_log(path, log.t, log.q * 1e-160, log.tau * 1e-160, log.joint_names)
    for command in ("identify", "offline"):
        assert cli.main([command, str(path), "--urdf", URDF, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert "Warning" not in err and len(err.strip().splitlines()) == 1, err
