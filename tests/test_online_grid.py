"""Bank and solve periods on the signal grid: logs at 125 Hz and 909 Hz.

OnlineSettings.on_grid puts the settings on the log's grid (the periods the user did
not set become the multiples of h closest to their nominal values); both drivers, the
Drake blocks and the core replay, run with default settings on such logs and agree.
Logs: closed-loop simulations of the 2R arm (SNR 30 dB, seed 3) on a random Fourier
reference (numpy default_rng(4)).
"""

import numpy as np
import pytest

from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import replay_log
from drake_dynid.logs import RobotLog
from drake_dynid.robot import RobotModel
from drake_dynid.simulation import SimulationSettings, simulate_identification
from drake_dynid.urdf import model_path


def test_defaults_at_1khz_are_unchanged_and_exact():
    grid = OnlineSettings().on_grid(1e-3)
    assert grid.bank_time_step == 0.02 and grid.update_period == 0.1
    assert grid.window == 20.0 and grid.jacobi_window == 0.4
    assert grid.on_grid(1e-3) == grid  # idempotent
    assert OnlineSettings(bank_time_step=0.005).on_grid(1e-3).bank_time_step == 0.005


def test_defaults_follow_125_hz_and_909_hz():
    grid = OnlineSettings().on_grid(0.008)
    assert grid.bank_time_step == pytest.approx(0.016)  # 2.5 steps: the smaller
    assert grid.update_period == pytest.approx(0.096)  # 12.5 steps: the smaller
    assert grid.window == 20.0 and grid.jacobi_window == 0.4  # already on the grid
    power = OnlineSettings.for_model("power").on_grid(0.008)
    assert power.jacobi_window == pytest.approx(25 * 0.008)  # 0.2 s, on the grid
    power = OnlineSettings.for_model("power", jacobi_window=0.3).on_grid(0.008)
    assert power.jacobi_window == pytest.approx(37 * 0.008)  # 0.3 s = 37.5 steps
    h = 1.0 / 909.0
    grid = OnlineSettings().on_grid(h)
    assert grid.bank_time_step == pytest.approx(18 * h)
    assert grid.update_period == pytest.approx(91 * h)
    assert grid.jacobi_window == pytest.approx(364 * h)
    assert grid.window == pytest.approx(1010 * 18 * h)
    grid.bank()  # a valid design: the window is a multiple of the bank step
    # A 1.1 ms step: the window moves to the nearest multiple of the bank step.
    grid = OnlineSettings().on_grid(0.0011)
    assert grid.window == pytest.approx(1010 * 18 * 0.0011)
    # The bank never samples slower than jacobi_window/10.
    assert OnlineSettings(jacobi_window=0.05).on_grid(1e-3).bank_time_step == 0.005


def test_given_periods_must_be_on_the_grid():
    with pytest.raises(ValueError, match=r"bank_time_step must be a multiple of the"):
        OnlineSettings(bank_time_step=0.02).on_grid(0.008)
    with pytest.raises(ValueError, match=r"update_period must be a multiple .* 0.008"):
        OnlineSettings(update_period=0.1).on_grid(0.008)
    with pytest.raises(ValueError, match=r"jacobi_window must be >= 10 signal periods"):
        OnlineSettings(jacobi_window=0.05).on_grid(0.008)
    with pytest.raises(ValueError, match="time_step must be > 0"):
        OnlineSettings().on_grid(0.0)


def test_a_power_set_above_the_pass_band_names_the_bandwidth():
    """Found by a review: the power model's default ℓ set reaches 2B by design;
    with --bandwidth 3 it reached 6 Hz above the 5.8 Hz pass band, and the message
    blamed the set's minimum number of functions instead of the bandwidth."""
    from drake_dynid.core.online_checks import check_log

    settings = OnlineSettings(model="power", bandwidth=3.0, window=4.0)
    with pytest.raises(ValueError, match=r"--bandwidth must keep every .* lower"):
        check_log(settings, 1e-3, 20.0, owner=None, names={"bandwidth": "--bandwidth"})
    lagrangian = OnlineSettings(bandwidth=1.0, window=0.5)  # 8 functions: 14 Hz
    with pytest.raises(ValueError, match=r"the default ℓ set \(at least 8"):
        check_log(lagrangian, 1e-3, 20.0, owner=None)


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


def _log(robot, time_step, duration):
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )
    result = simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=duration, time_step=time_step, seed=3),
        [],
    )
    return RobotLog(result.t, result.q, result.tau, result.joint_names, time_step)


@pytest.mark.parametrize("time_step", [0.008, 1.0 / 909.0])
def test_both_drivers_run_default_periods_on_odd_rates(robot, time_step):
    log = _log(robot, time_step, 3.0)
    power = OnlineSettings.for_model("power", window=2.0)
    settings = [OnlineSettings(window=2.0), power]
    rows = robot.rows_provider()
    core = replay_log_core(log, rows, settings)
    blocks = replay_log(log, rows, settings)
    for got, want in zip(core, blocks, strict=True):
        assert got.settings == want.settings
        assert got.settings.bank_time_step == pytest.approx(
            round(0.02 / time_step) * time_step
        )
        np.testing.assert_array_equal(got.valid, want.valid)
        np.testing.assert_allclose(got.theta, want.theta, rtol=1e-9, atol=1e-12)
        assert got.valid[-1] == 1.0
    # The Lagrangian estimate of the 125 Hz / 909 Hz log is close to the truth:
    # within 5 %, or 2σ for MY2 (σ 16 % at 125 Hz: its error drifts from 0.9 to
    # 7.8 % over the log's last 0.12 s, which the final solve now sees).
    error = np.abs(core[0].theta[-1] - robot.base_values)
    bound = np.maximum(0.05 * np.abs(robot.base_values), 2.0 * core[0].std[-1])
    assert np.all(error[:4] < bound[:4]), error / np.abs(robot.base_values)


def test_dynid_identify_runs_a_125_hz_log_with_default_settings(robot, tmp_path):
    # The paper's trajectory simulated without noise at 1 kHz, logged at 125 Hz.
    import json

    from drake_dynid import cli
    from drake_dynid.logs import write_log
    from drake_dynid.paper import paper_trajectory

    result = simulate_identification(
        robot, paper_trajectory(), SimulationSettings(duration=21.0, snr_db=None), []
    )
    log_file = tmp_path / "log_125hz.csv"
    write_log(
        log_file, result.t[::8], result.q[::8], result.tau[::8], robot.joint_names
    )
    out = tmp_path / "id.json"
    argv = ["identify", str(log_file), "--urdf", model_path("planar_2r")]
    assert cli.main([*argv, "--json", str(out), "--quiet"]) == 0
    document = json.loads(out.read_text())
    assert document["settings"]["bank_time_step"] == pytest.approx(0.016)
    assert document["settings"]["update_period"] == pytest.approx(0.096)
    assert document["log"]["time_step"] == pytest.approx(0.008)
    zz1r = document["parameters"][0]
    assert zz1r["name"] == "ZZ1R" and zz1r["value"] == pytest.approx(3.9, rel=0.02)
