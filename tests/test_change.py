"""Change detection (core.change): the paper's Fig. 4 jump, logs without a change.

Fig. 4 set-up: the paper's 2R arm simulated by Drake (discrete plant, inverse-
dynamics tracking of ``paper_trajectory``, SNR 30 dB noise, seed 0) with the
identifier blocks in the loop; at 9.4 s ``paper.zz1_jump`` raises link 1's
inertia in the plant, so ZZ1R goes 3.9 -> 4.5. Logs without a change: the same
simulation without the event, and an iiwa7 log with torques from Drake's
``CalcInverseDynamics`` (never the library's regressor) and encoder-grade noise;
the same iiwa7 log with the torques of the arm carrying 1 kg in link 7 from 16 s.
"""

import dataclasses
import pathlib

import numpy as np
import pytest
from _drake_dynamics import drake_torques

from drake_dynid.core.change import (
    ChangeDetection,
    change_design,
    tracker_from_vector,
    tracker_init,
    tracker_vector,
)
from drake_dynid.core.isolation import isolate_change
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.core.segment import segment_equations
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog
from drake_dynid.paper import paper_trajectory, zz1_jump
from drake_dynid.plants import RobotModel, model_path
from drake_dynid.simulation import SimulationSettings, simulate_identification

JUMP = 9.4
TRACKED = OnlineSettings.for_model(
    "lagrangian", window=7.0, update_period=0.05, detect_changes=True
)
PLAIN = dataclasses.replace(TRACKED, detect_changes=False)


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def fig4(robot):
    return simulate_identification(
        robot,
        paper_trajectory(),
        SimulationSettings(duration=12.0, snr_db=30.0, seed=0),
        [TRACKED, PLAIN],
        events=[(JUMP, zz1_jump(0.6))],
    )


def _settle(trace, target=4.5, tolerance=0.02):
    """Seconds after the jump from which ZZ1R stays within 2 % of the target."""
    bad = np.flatnonzero(
        (trace.t >= JUMP) & (np.abs(trace.theta[:, 0] - target) > tolerance * target)
    )
    assert bad.size == 0 or bad[-1] + 1 < len(trace.t), "not within 2 % at the end"
    return 0.0 if bad.size == 0 else trace.t[bad[-1] + 1] - JUMP


def test_fig4_jump_is_detected_and_tracked_within_2_seconds(fig4):
    tracked, plain = fig4.traces
    (found,) = tracked.detections()
    assert JUMP < found["t"] <= JUMP + 1.5  # measured 0.9 s
    assert abs(found["change_time"] - JUMP) < 0.5  # measured -0.02 s
    assert found["changed"] == ["ZZ1R"]
    assert _settle(tracked) <= 1.8  # measured 1.35 s
    # The sliding window alone is still off when the tracked estimate has settled
    # (it needs 3.85 s).
    late = np.searchsorted(plain.t, JUMP + 2.0)
    assert abs(plain.theta[late, 0] - 4.5) > 0.02 * 4.5
    assert abs(tracked.theta[late, 0] - 4.5) < 0.02 * 4.5
    # Before the jump the outputs equal the plain identifier's.
    before = tracked.t < JUMP
    np.testing.assert_array_equal(tracked.theta[before], plain.theta[before])
    assert tracked.change[before].sum() == 0.0


def test_cli_prints_and_writes_the_detections(fig4, tmp_path, capsys):
    import json

    from drake_dynid import cli
    from drake_dynid.logs import write_log

    log = tmp_path / "fig4.csv"
    write_log(log, fig4.t, fig4.q, fig4.tau, fig4.joint_names)
    out = tmp_path / "fig4.json"
    argv = [
        "identify",
        str(log),
        "--urdf",
        model_path("planar_2r"),
        "--window",
        "7",
        "--update-period",
        "0.05",
        "--detect-changes",
    ]
    assert cli.main([*argv, "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "changes detected: 1" in printed
    assert "parameters changed: ZZ1R" in printed
    document = json.loads(out.read_text())
    (found,) = document["changes"]
    assert JUMP < found["t"] < JUMP + 1.5 and found["changed"] == ["ZZ1R"]
    assert document["settings"]["detect_changes"] is True
    # The final estimate's window started at the change: no bootstrap of a full
    # sliding window (core.bootstrap), and the report says why.
    assert document["bootstrap"]["applied"] is False
    assert "a detected change restarted it" in document["bootstrap"]["reason"]
    assert "no bootstrap: the final window is not the sliding window" in printed
    # Nor the final solve's correlation: the covariance is σ² on its diagonal,
    # and the file says so (dynid payload propagates it as such).
    assert document["covariance_method"] == "diagonal"
    assert "a detected change restarted it" in document["covariance_reason"]
    std = np.array([p["std"] for p in document["parameters"]])
    np.testing.assert_array_equal(np.array(document["covariance"]), np.diag(std**2))
    assert cli.main([*argv, "--engine", "blocks", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["changes"] == document["changes"]
    assert cli.main([*argv[:-1], "--json", str(out), "--quiet"]) == 0
    assert json.loads(out.read_text())["changes"] is None  # not asked


def test_core_replay_equals_the_blocks_in_the_loop(fig4, robot):
    """The recorded noisy log through the core gives the in-loop blocks' trace."""
    log = RobotLog(fig4.t, fig4.q, fig4.tau, fig4.joint_names, 1e-3)
    (fast,) = replay_log_core(log, robot.rows_provider(), [TRACKED])
    blocks = fig4.traces[0]
    count = blocks.t.size  # the replay's final row at t_N (the log's end) apart
    assert fast.t.size == count + 1
    np.testing.assert_allclose(fast.theta[:count], blocks.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fast.std[:count], blocks.std, rtol=1e-7, atol=1e-12)
    for name in ("valid", "status", "change", "tracking", "changed"):
        np.testing.assert_array_equal(
            getattr(fast, name)[:count], getattr(blocks, name)
        )
    np.testing.assert_array_equal(fast.change_time[:count], blocks.change_time)


def test_no_false_alarm_without_a_change(robot):
    result = simulate_identification(
        robot,
        paper_trajectory(),
        SimulationSettings(duration=16.0, snr_db=30.0, seed=0),
        [TRACKED],
    )
    (trace,) = result.traces
    assert trace.detections() == []
    assert trace.t[-1] > 7.5 + 2.0 + 5.0  # the test ran armed for > 5 s


@pytest.fixture(scope="module")
def iiwa_logs(tmp_path_factory):
    """22 s of the iiwa7 (0.1 Hz multi-sine, default_rng(0)); the same arm picking
    up 1 kg in link 7 at 16 s (a URDF with link 7's compound inertia)."""
    import re

    iiwa = RobotModel.from_urdf(model_path("iiwa7"))
    text = pathlib.Path(model_path("iiwa7")).read_text()
    loaded_link = (  # 0.3 kg at z = 0.02 m and 1 kg at (0.02, 0, 0.08) m
        '<inertial><origin xyz="0.015385 0 0.066154" rpy="0 0 0"/><mass value="1.3"/>'
        '<inertia ixx="0.002331" ixy="0" ixz="-0.000277" iyy="0.002423" iyz="0" '
        'izz="0.001592"/></inertial>'
    )
    text = re.sub(
        r'(<link name="iiwa_link_7">\s*)<inertial>.*?</inertial>',
        lambda match: match.group(1) + loaded_link,
        text,
        flags=re.S,
    )
    path = tmp_path_factory.mktemp("urdf") / "iiwa7_payload.urdf"
    path.write_text(text)
    heavy = RobotModel.from_urdf(path)
    trajectory = random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        max_position=1.0,
        rng=np.random.default_rng(0),
    )
    h = 1e-3
    t = h * np.arange(22001)
    q, v, vdot = trajectory.evaluate(t)
    tau = drake_torques(iiwa, q, v, vdot)
    after = t >= 16.0
    tau_loaded = tau.copy()
    tau_loaded[after] = drake_torques(heavy, q[after], v[after], vdot[after])
    rng = np.random.default_rng(1)
    q_noise = 1e-4 * rng.standard_normal(q.shape)  # encoder-grade noise
    tau_noise = 0.01 * tau.std(axis=0) * rng.standard_normal(tau.shape)
    logs = [
        RobotLog(t, q + q_noise, torques + tau_noise, iiwa.joint_names, h)
        for torques in (tau, tau_loaded)
    ]
    check = (q[-2000:], v[-2000:], vdot[-2000:], tau_loaded[-2000:])
    return iiwa, heavy, logs, check


IIWA = OnlineSettings.for_model(
    "lagrangian", window=10.0, rows_from="raw", update_period=0.2, detect_changes=True
)


def test_no_false_alarm_on_a_7dof_log_from_drake_inverse_dynamics(iiwa_logs):
    iiwa, _, (log, _), _ = iiwa_logs
    (trace,) = replay_log_core(log, iiwa.rows_provider(), [IIWA])
    assert trace.valid[-1] == 1.0
    assert trace.detections() == []  # armed from 12.4 s to 22 s


def test_a_payload_on_a_7dof_arm_is_detected_and_tracked(iiwa_logs):
    iiwa, heavy, (_, log), (q, v, vdot, tau) = iiwa_logs
    plain = dataclasses.replace(IIWA, detect_changes=False)
    tracked, sliding = replay_log_core(log, iiwa.rows_provider(), [IIWA, plain])
    (found,) = tracked.detections()
    assert 16.0 < found["t"] <= 17.0  # measured 16.4 s
    assert abs(found["change_time"] - 16.0) < 0.5
    changed = np.abs(heavy.base_values - iiwa.base_values) > 1e-9
    names = set(found["changed"])
    true = {n for n, c in zip(iiwa.names, changed, strict=True) if c}
    assert len(names & true) >= 6 and len(names - true) <= 3  # measured 10 and 0

    def prediction(theta):  # largest joint's RMS error on the last 2 s [%]
        error = iiwa.idim_rows(q, v, vdot) @ theta - tau
        return 100 * np.max(np.sqrt((error**2).mean(axis=0) / (tau**2).mean(axis=0)))

    assert prediction(tracked.theta[-1]) < 3.0  # measured 1.0 %
    assert prediction(sliding.theta[-1]) > 30.0  # measured 98 %: old and new mixed


# ------------------------------------------------------------------- core units


def test_segment_equations_hold_for_the_true_parameters(fig4, robot):
    """A noise-free segment: the residual of the true θ is tiny against B."""
    from drake_dynid.core.replay import bank_channels, filtered_signals

    settings = PLAIN.on_grid(1e-3)
    index = np.arange(2000, 5001, 20)  # 3 s of bank samples, before the jump
    q_hat, v_hat, tau_hat, _, _ = filtered_signals(
        fig4.q_true, fig4.tau_true, settings, 1e-3
    )
    channels = bank_channels(
        robot, "lagrangian", *(a[index] for a in (q_hat, v_hat, tau_hat))
    )
    A, B = segment_equations(channels, 0.02, 8, 2, 8)
    assert A.shape == (16, 8)
    residual = B - A @ robot.base_values
    assert np.linalg.norm(residual) < 0.02 * np.linalg.norm(B)


def test_isolation_finds_the_changed_column():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((40, 6)) * [1.0, 10.0, 0.1, 1.0, 1.0, 1.0]
    before = np.array([1.0, 0.2, 5.0, -1.0, 0.5, 2.0])
    after = before.copy()
    after[2] += 1.0
    noise = 0.01 * rng.standard_normal(40)
    std = np.full(6, 0.01)
    found = isolate_change(A, A @ after + noise, before, std)
    assert found.selected.tolist() == [False, False, True, False, False, False]
    assert abs(found.theta[2] - after[2]) < 0.05
    np.testing.assert_array_equal(found.theta[~found.selected], before[~found.selected])
    unchanged = isolate_change(A, A @ before + noise, before, std)
    assert not unchanged.selected.any()
    np.testing.assert_array_equal(unchanged.theta, before)


def test_tracker_state_round_trips_through_a_vector():
    settings = dataclasses.replace(PLAIN, detect_changes=ChangeDetection(window=0.5))
    design = change_design(settings, 1e-3, 2, 8)
    state = dataclasses.replace(
        tracker_init(design), cusum=0.25, onset=17, restart=12, changes=3
    )
    back = tracker_from_vector(tracker_vector(state, design), design)
    assert (back.cusum, back.onset, back.restart, back.changes) == (0.25, 17, 12, 3)
    np.testing.assert_array_equal(back.long.std, state.long.std)
    assert change_design(PLAIN, 1e-3, 2, 8) is None


def test_bad_settings_are_refused():
    with pytest.raises(TypeError, match="detect_changes must be True, False or a "):
        OnlineSettings(detect_changes="yes")
    with pytest.raises(ValueError, match="ChangeDetection: drift must be > 0"):
        ChangeDetection(drift=0.0)
    with pytest.raises(ValueError, match="lookback must be in"):
        ChangeDetection(lookback=2.0)
    settings = dataclasses.replace(PLAIN, detect_changes=ChangeDetection(window=8.0))
    with pytest.raises(ValueError, match="shorter than the sliding window"):
        change_design(settings, 1e-3, 2, 8)
