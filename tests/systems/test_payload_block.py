"""The PayloadIdentifier block and its chain: equal to the core replay, state in the
Context."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_dynid.core.identifier import Status
from drake_dynid.core.payload import payload_parameters, payload_rows
from drake_dynid.core.payload_noise import MIN_POOLED_WINDOWS
from drake_dynid.core.payload_replay import replay_payload_core
from drake_dynid.core.payload_step import payload_init, payload_settings, payload_update
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import log_source
from drake_dynid.logs import RobotLog
from drake_dynid.payload_diagrams import add_payload_identifier, replay_payload_log
from drake_dynid.robot import RobotModel
from drake_dynid.systems.payload import PayloadIdentifier
from drake_dynid.urdf import model_path

H = 1e-3


@pytest.fixture(scope="module")
def case():
    """The 2R arm; a log whose torques hold the arm and a 0.5 kg payload from 1 s.

    τ = the payload rows' own inverse dynamics (the blocks and the core are
    compared with each other here, not with a truth), seeded noise.
    """
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    rows = payload_rows(robot)
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )
    t = H * np.arange(1801)
    q, v, vdot = trajectory.evaluate(t)
    theta = rows.base.matrix @ payload_parameters(
        0.5, [0.05, 0.02, 0.0], np.eye(3) * 1e-3
    )
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    tau[t >= 1.0] += rows.idim_rows(q, v, vdot)[t >= 1.0] @ theta
    rng = np.random.default_rng(0)
    log = RobotLog(
        t,
        q + 1e-5 * rng.normal(size=q.shape),
        tau + 1e-3 * rng.normal(size=q.shape),
        robot.joint_names,
        H,
    )
    return rows, log


@pytest.mark.parametrize("rows_from", ["raw", "filtered"])
def test_blocks_equal_the_core_replay(case, rows_from):
    rows, log = case
    settings = payload_settings(rows_from=rows_from, window=0.5)
    core = replay_payload_core(log, rows, settings)
    blocks = replay_payload_log(log, rows, settings)
    np.testing.assert_allclose(core.t, blocks.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(blocks.theta, core.theta, rtol=1e-9, atol=1e-12)
    finite = np.isfinite(core.std)
    np.testing.assert_array_equal(finite, np.isfinite(blocks.std))
    np.testing.assert_allclose(blocks.std[finite], core.std[finite], rtol=1e-7)
    np.testing.assert_allclose(blocks.correlation, core.correlation, atol=1e-9)
    for name in ("valid", "status", "unidentified"):
        np.testing.assert_array_equal(getattr(blocks, name), getattr(core, name))
    assert blocks.delay == core.delay
    assert core.status[0] == Status.WINDOW_NOT_READY and core.valid[-1] == 1
    assert abs(core.theta[-1, rows.payload_names.index("M")] - 0.5) < 0.01


@pytest.mark.parametrize("count", [1751, 1800, 1787])
def test_the_final_estimate_uses_the_log_up_to_its_last_sample(case, count):
    """Found by a review (as for dynid identify, commit ca095dc): the trace ended
    with the solve one to two solve periods before the log's end, whose last
    samples never entered the estimate. The final row, at t_N = N·h, is now the
    solve at the last sample t_{N-1}, in both engines: N - 1 a solve time (the
    row appended), N one (the loggers' row at t_N replaced), neither (a solve
    added and a row appended)."""
    rows, log = case
    settings = payload_settings(window=0.5)
    short = RobotLog(log.t[:count], log.q[:count], log.tau[:count], log.joint_names, H)
    core = replay_payload_core(short, rows, settings)
    blocks = replay_payload_log(short, rows, settings)
    np.testing.assert_allclose(blocks.t, core.t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(blocks.theta, core.theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(blocks.std, core.std, rtol=1e-7)
    np.testing.assert_allclose(blocks.correlation, core.correlation, atol=1e-9)
    for name in ("valid", "status", "unidentified"):
        np.testing.assert_array_equal(getattr(blocks, name), getattr(core, name))
    every = 50  # the solve period, 50 ms, in samples
    assert core.t[-1] == pytest.approx(count * H, abs=1e-12)
    np.testing.assert_allclose(core.t[:-1], H * np.arange(0, count, every), atol=1e-12)
    assert core.valid[-1] == 1
    # The whole log (1801 samples) records at t_s the solves before t_s: its row
    # at 1.8 s holds the solve at 1.75 s.
    full = replay_payload_core(log, rows, settings)
    if (count - 1) % every == 0:  # the last sample is a solve time: causal, equal
        at = np.flatnonzero(np.isclose(full.t, (count - 1 + every) * H))[0]
        np.testing.assert_allclose(core.theta[-1], full.theta[at], rtol=1e-12)
        np.testing.assert_allclose(core.std[-1], full.std[at], rtol=1e-12)
    else:  # the final solve at t_{N-1} saw the samples after the periodic one
        at = np.flatnonzero(np.isclose(full.t, 1.8))[0]
        change = np.abs(core.theta[-1] - full.theta[at]) / core.std[-1]
        assert change.max() > 0.1, change  # 0.26-0.62 σ here


def test_two_simulators_on_one_chain_give_identical_logs(case):
    rows, log = case
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    chain = add_payload_identifier(
        builder, rows, source.get_output_port(), H, payload_settings(window=0.5)
    )
    diagram = builder.Build()
    first, second = Simulator(diagram), Simulator(diagram)
    first.AdvanceTo(0.9)
    second.AdvanceTo(1.8)  # the pooled noise is ready about 1.7 s (after the pick)
    first.AdvanceTo(1.8)
    for sink in chain.logs.values():
        one, two = sink.FindLog(first.get_context()), sink.FindLog(second.get_context())
        np.testing.assert_array_equal(one.data(), two.data())
    theta = chain.logs["theta"].FindLog(first.get_context()).data()
    assert np.abs(theta).max() > 0.1


def test_block_state_follows_the_core_step():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(30, 3))
    b = a[:, :2] @ np.array([0.5, -1.0]) + a[:, 2] + 0.01 * rng.normal(size=30)
    a = np.vstack([a, rng.normal(size=(2, 3))])
    b = np.concatenate([b, a[30:, :2] @ np.array([0.5, -1.0]) + a[30:, 2]])
    noise = row_noise_of(32)
    block = PayloadIdentifier(2, 32, 1.0, names=("M", "MX"), row_noise=noise)
    # One per output, and the pooled row noise (moments, counts).
    assert block.num_discrete_state_groups() == 9
    context = block.CreateDefaultContext()
    block.get_input_port_A().FixValue(context, a.reshape(-1))
    block.get_input_port_B().FixValue(context, b)
    block.get_input_port_window_valid().FixValue(context, [1.0])
    initial = block.state(context)
    assert initial.estimate.status is Status.WINDOW_NOT_READY
    np.testing.assert_array_equal(initial.estimate.theta, np.zeros(2))
    assert not block.HasAnyDirectFeedthrough()
    core = payload_init(2)
    for _ in range(MIN_POOLED_WINDOWS + 1):
        context.SetDiscreteState(block.EvalUniquePeriodicDiscreteUpdate(context))
        core = payload_update(core, True, a, b, names=("M", "MX"), noise=noise)
    state = block.state(context)
    np.testing.assert_array_equal(state.estimate.theta, core.estimate.theta)
    np.testing.assert_array_equal(state.estimate.std, core.estimate.std)
    np.testing.assert_array_equal(state.correlation, core.correlation)
    np.testing.assert_array_equal(state.pool.moments, core.pool.moments)
    assert state.pool.count == core.pool.count == MIN_POOLED_WINDOWS + 1
    assert state.estimate.status is Status.OK


def row_noise_of(rows):
    """A RowNoise of ``rows`` rows: 4 equations of the payload bank's 8 rows."""
    from drake_dynid.core.row_noise import row_noise

    return row_noise(payload_settings().on_grid(H).bank(), rows // 8)


def test_ports_and_argument_checks():
    block = PayloadIdentifier(2, 10, 0.1)
    for name in ("A", "B", "window_valid"):
        assert getattr(block, f"get_input_port_{name}")().get_name() == name
    outputs = (
        "theta",
        "theta_std",
        "condition_number",
        "valid",
        "unidentified",
        "status",
        "correlation",
    )
    for name in outputs:
        assert getattr(block, f"get_output_port_{name}")().get_name() == name
    assert block.get_input_port_A().size() == 30
    assert block.get_output_port_correlation().size() == 4
    with pytest.raises(
        ValueError, match="PayloadIdentifier: update_period must be > 0"
    ):
        PayloadIdentifier(2, 10, 0.0)
    with pytest.raises(ValueError, match="names must have 2 entries"):
        PayloadIdentifier(2, 10, 0.1, names=("M",))


def test_chain_checks_its_arguments(case):
    rows, log = case
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    with pytest.raises(TypeError, match="rows must be a PayloadRows"):
        add_payload_identifier(
            builder, rows.robot, source.get_output_port(), H, payload_settings()
        )
    with pytest.raises(ValueError, match="the log has 2 joints; the robot has 7"):
        replay_payload_log(
            log,
            payload_rows(RobotModel.from_urdf(model_path("iiwa7"))),
            payload_settings(),
        )


def test_settings_the_payload_solve_does_not_have_are_refused(case):
    """Found by a review: ``detect_changes`` and ``position_noise`` (the power
    rows' noise compensation) were accepted by ``payload_settings`` and silently
    ignored by the payload chain and its core replay (no change tracking, no
    compensation)."""
    from drake_dynid.core.online import OnlineSettings

    rows, log = case
    with pytest.raises(ValueError, match=r"payload_settings: settings\.detect_changes"):
        payload_settings(detect_changes=True)
    with pytest.raises(ValueError, match=r"payload_settings: settings\.position_noise"):
        payload_settings(model="power", position_noise=1e-4)
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    given = OnlineSettings(**{**payload_settings().as_dict(), "detect_changes": True})
    with pytest.raises(
        ValueError, match=r"add_payload_identifier: settings\.detect_changes"
    ):
        add_payload_identifier(builder, rows, source.get_output_port(), H, given)
    with pytest.raises(
        ValueError, match=r"replay_payload_core: settings\.detect_changes"
    ):
        replay_payload_core(log, rows, given)


def test_blocks_equal_the_core_with_the_arms_covariance(case):
    """The arm's error columns (payload_rows(arm_covariance=...)) go through the
    blocks' bank as through the core's: the same σ, which the covariance widens."""
    rows, log = case
    robot = rows.robot
    theta = np.asarray(robot.base_values, dtype=float)
    covariance = np.diag((0.01 * np.abs(theta) + 1e-4) ** 2)
    wide = payload_rows(robot, arm_covariance=covariance)
    assert wide.num_parameters == rows.num_parameters + wide.num_arm_columns
    settings = payload_settings(window=0.5)
    core = replay_payload_core(log, wide, settings)
    blocks = replay_payload_log(log, wide, settings)
    np.testing.assert_allclose(blocks.theta, core.theta, rtol=1e-9, atol=1e-12)
    finite = np.isfinite(core.std)
    np.testing.assert_array_equal(finite, np.isfinite(blocks.std))
    np.testing.assert_allclose(blocks.std[finite], core.std[finite], rtol=1e-7)
    plain = replay_payload_core(log, rows, settings)
    np.testing.assert_array_equal(plain.theta, core.theta)
    assert (core.std[-1] > plain.std[-1]).all()
