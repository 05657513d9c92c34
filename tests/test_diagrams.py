"""Closed-loop simulation and log replay through the on-line identification blocks."""

import dataclasses
import pathlib

import numpy as np
import pytest

from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import (
    OnlineSettings,
    SimulationSettings,
    replay_log,
    simulate_identification,
)
from drake_dynid.logs import RobotLog
from drake_dynid.plants import RobotModel, model_path


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def trajectory():
    # Seed 4: period 2 s, 3 harmonics, |v| <= 3 rad/s.
    return random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )


SETTINGS = [
    OnlineSettings(
        model="lagrangian",
        window=2.0,
        frequencies=np.arange(8.0),
        jacobi_window=0.05,
        bank_time_step=0.005,
        update_period=0.05,
    ),
    OnlineSettings(
        model="power",
        window=2.0,
        frequencies=np.arange(0, 7.01, 0.25),
        jacobi_window=0.05,
        bank_time_step=0.005,
        update_period=0.05,
    ),
]


@pytest.fixture(scope="module")
def noise_free(robot, trajectory):
    return simulate_identification(
        robot, trajectory, SimulationSettings(duration=2.6, snr_db=None), SETTINGS
    )


def test_noise_free_closed_loop_recovers_the_parameters(robot, noise_free):
    truth = robot.base_values
    for trace, inertial_tol, friction_tol in zip(
        noise_free.traces, (0.01, 0.03), (0.05, 0.15), strict=True
    ):
        final = trace.final()
        assert final["valid"]
        error = np.abs(final["theta"] - truth) / truth
        assert np.all(error[:4] < inertial_tol), (trace.settings.model, error)
        assert np.all(error[4:] < friction_tol), (trace.settings.model, error)
        # Before the window has filled the block reports invalid and holds zeros.
        assert trace.valid[0] == 0.0 and np.all(trace.theta[0] == 0.0)


def test_replay_of_the_recorded_log_gives_the_closed_loop_estimates(robot, noise_free):
    log = RobotLog(
        noise_free.t, noise_free.q, noise_free.tau, noise_free.joint_names, 1e-3
    )
    traces = replay_log(log, robot.rows_provider(), SETTINGS)
    for replayed, online in zip(traces, noise_free.traces, strict=True):
        # The replay ends with one more row, at t_N: its final solve at the last
        # sample (core.replay.solve_samples); the closed loop has no log end.
        count = online.t.size
        assert replayed.t.size == count + 1
        assert replayed.t[-1] == pytest.approx(len(noise_free.t) * 1e-3)
        np.testing.assert_allclose(replayed.t[:count], online.t, atol=1e-12)
        np.testing.assert_allclose(
            replayed.theta[:count], online.theta, rtol=1e-9, atol=1e-12
        )
        np.testing.assert_array_equal(replayed.valid[:count], online.valid)


def test_noise_matches_the_requested_snr(robot, trajectory):
    result = simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=0.5, snr_db=20.0, seed=3),
        [],
    )
    noise = np.hstack([result.q - result.q_true, result.tau - result.tau_true])
    measured_std = noise[1:].std(axis=0)  # the first sample has no noise yet
    np.testing.assert_allclose(measured_std, result.noise_std, rtol=0.15)
    assert np.all(result.noise_std > 0)


def test_settings_validation():
    with pytest.raises(ValueError, match="model must be"):
        OnlineSettings(model="energy")
    with pytest.raises(ValueError, match="window must be > 0"):
        OnlineSettings(window=0.0)
    with pytest.raises(ValueError, match="frequencies must be None, 'paper'"):
        OnlineSettings(frequencies="dense")
    with pytest.raises(ValueError, match="weighting must be one of 'frequency'"):
        OnlineSettings(weighting="gls")


def test_row_weighting_follows_the_bank_rows():
    from drake_dynid.core.modulating import row_frequencies

    settings = OnlineSettings(window=4.0, frequencies=[0.0, 1.0, 2.0])
    weighting = settings.row_weighting(2)
    assert weighting is not None
    frequency, group = weighting
    # The same rows from an already built bank.
    np.testing.assert_array_equal(
        settings.row_weighting(2, settings.bank())[0], frequency
    )
    assert frequency.shape == group.shape == (settings.bank().num_rows(2),)
    # ℓ-major, (real, imaginary), joint: ν = ℓ + 1 for k = 1.
    np.testing.assert_array_equal(group[:4], [0, 1, 0, 1])
    np.testing.assert_array_equal(frequency[:4], [1.0] * 4)
    assert frequency[-1] == 3.0
    assert OnlineSettings(weighting="none").row_weighting(2) is None
    # Order 2 drops the identically zero part of ℓ = -1 (row_mask).
    bank = OnlineSettings(order=2, frequencies=[-1.0, 0.0]).bank()
    frequency, group = row_frequencies(bank, 1)
    assert len(frequency) == bank.num_rows(1) == 3
    np.testing.assert_array_equal(frequency, [0.5, 1.5, 1.5])


def test_per_model_defaults_and_overrides():
    from drake_dynid.diagrams import MODEL_DEFAULTS

    power = OnlineSettings.for_model("power", window=7.0)
    assert power.model == "power" and power.window == 7.0
    assert power.jacobi_window == MODEL_DEFAULTS["power"]["jacobi_window"]
    assert OnlineSettings.for_model("lagrangian") == OnlineSettings()
    with pytest.raises(ValueError, match="model must be"):
        OnlineSettings.for_model("energy")


def test_paper_trajectory_is_documented_and_reproducible():
    from drake_dynid.paper import paper_trajectory

    t = np.arange(0.0, 40.0, 1e-3)
    _, v, _ = paper_trajectory().evaluate(t)
    np.testing.assert_allclose(np.abs(v).max(axis=0), 5.0, rtol=1e-9)
    _, v2, _ = paper_trajectory().evaluate(t[:10])
    np.testing.assert_array_equal(v[:10], v2)


def test_zz1_jump_is_tracked(robot):
    from drake_dynid.paper import paper_trajectory, zz1_jump

    settings = OnlineSettings(
        window=2.0, frequencies=np.arange(11.0), jacobi_window=0.3
    )
    result = simulate_identification(
        robot,
        paper_trajectory(),
        SimulationSettings(duration=6.0, snr_db=None),
        [settings],
        events=[(3.0, zz1_jump(0.6))],
    )
    trace = result.traces[0]
    before = trace.theta[np.searchsorted(trace.t, 2.9)]
    after = trace.theta[-1]
    assert before[0] == pytest.approx(3.9, rel=0.01)
    assert after[0] == pytest.approx(4.5, rel=0.01)
    # The other inertial parameters stay put (MY2 = 0.1 is the least precise one
    # with a 2 s window).
    np.testing.assert_allclose(after[1:4], robot.base_values[1:4], rtol=0.06)


def test_default_frequencies_follow_the_band_and_stay_well_posed():
    from drake_dynid.diagrams import MIN_FUNCTIONS

    long = OnlineSettings(window=20.0, bandwidth=0.6)
    np.testing.assert_array_equal(long.ell(), np.arange(12.0))  # (11 + 1)/20 = 0.6 Hz
    # A short window: the band's integer bins extended to MIN_FUNCTIONS integers.
    short = OnlineSettings(window=4.0, bandwidth=0.6)
    np.testing.assert_array_equal(short.ell(), np.arange(float(MIN_FUNCTIONS)))
    # One rule: the settings and core.excitation.frequencies_for agree (T = 7 s).
    from drake_dynid.core.excitation import frequencies_for

    for window, band in ((7.0, 0.62), (20.0, 0.62), (4.0, 0.6), (12.0, 1.3)):
        np.testing.assert_array_equal(
            OnlineSettings(window=window, bandwidth=band).ell(),
            frequencies_for(window, band),
        )
    np.testing.assert_array_equal(
        OnlineSettings(frequencies="paper").ell(), np.round(0.05 * np.arange(201), 12)
    )


def test_trace_reports_status_and_unexcited_parameters(robot):
    # Joint 2 never moves: with q2 constant the columns of ZZ1R, ZZ2 and MX2 all
    # scale with joint 1's motion (dependent), the identifier names them and never
    # reports a valid estimate.
    from drake_dynid.core.trajectory import FourierTrajectory

    still = FourierTrajectory(
        np.zeros(2), np.array([[2.0, 1.0], [0.0, 0.0]]), np.zeros((2, 2)), 2 * np.pi / 2
    )
    result = simulate_identification(
        robot,
        still,
        SimulationSettings(duration=2.5, snr_db=None),
        [
            OnlineSettings(
                window=2.0,
                jacobi_window=0.05,
                bank_time_step=0.005,
                update_period=0.1,
                # 12 functions within 0.5 Hz: no bin reaches the small coupling
                # motion of q2 (1.3 mrad) that integer bins up to 4 Hz would excite.
                frequencies=np.round(np.linspace(0.0, 1.0, 12), 12),
            )
        ],
    )
    trace = result.traces[0]
    final = trace.final()
    assert not final["valid"] and final["status"] == 2
    assert {"ZZ2", "MX2"} <= set(final["unidentified"])
    assert np.all(trace.valid == 0) and np.all(trace.theta == 0.0)
    assert trace.status[0] == 1  # window not ready at the start


def test_diagram_argument_checks(robot, trajectory):
    from drake_dynid.core.trajectory import FourierTrajectory

    with pytest.raises(ValueError, match="duration must be > 0"):
        SimulationSettings(duration=0.0)
    with pytest.raises(ValueError, match="kd must be > 0"):
        SimulationSettings(kd=-1.0)
    with pytest.raises(ValueError, match="coulomb_smoothing must be >= 0"):
        SimulationSettings(coulomb_smoothing=-0.1)
    one = FourierTrajectory(np.zeros(1), np.ones((1, 1)), np.zeros((1, 1)), 1.0)
    with pytest.raises(ValueError, match="trajectory has 1 joints; the robot has 2"):
        simulate_identification(robot, one, SimulationSettings(duration=0.1), [])
    log = RobotLog(
        np.arange(3) * 1e-3, np.zeros((3, 1)), np.zeros((3, 1)), ("a",), 1e-3
    )
    with pytest.raises(ValueError, match="the log has 1 joints; the robot has 2"):
        replay_log(log, robot.rows_provider(), [OnlineSettings()])
    with pytest.raises(TypeError, match="rows must be a row provider"):
        replay_log(log, object(), [OnlineSettings()])


def test_a_shared_differentiator_must_be_the_chain_s(robot):
    """Found by a review: ``differentiator=`` was wired unchecked. One sampling
    every 2 ms (window 0.8 s) under a 1 ms chain with raw rows gave ZZ1R 49 %
    off with σ 1 % ("valid"); another window gave the trace a wrong delay."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_dynid.diagrams import add_online_identifier
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    h = 1e-3
    settings = OnlineSettings.for_model("lagrangian", window=5.0, rows_from="raw")
    jacobi = settings.jacobi_parameters()

    def chain(num_signals, time_step, **overrides):
        builder = DiagramBuilder()
        source = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
        differentiator = builder.AddSystem(
            CausalJacobiDifferentiator(
                num_signals, time_step, **{**jacobi, **overrides}
            )
        )
        return add_online_identifier(
            builder,
            robot.rows_provider(),
            source.get_output_port(),
            h,
            settings,
            differentiator=differentiator,
        )

    assert chain(4, h).differentiator.time_step == h  # the chain's own: accepted
    with pytest.raises(ValueError, match=r"differentiator must sample every 0\.001 s"):
        chain(4, 2e-3, window=0.8)
    with pytest.raises(ValueError, match="differentiator must differentiate 4 signals"):
        chain(6, h)
    with pytest.raises(
        ValueError, match="differentiator must have the settings' Jacobi"
    ):
        chain(4, h, window=0.5)
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    with pytest.raises(TypeError, match="differentiator must be a"):
        add_online_identifier(
            builder,
            robot.rows_provider(),
            source.get_output_port(),
            h,
            settings,
            differentiator=object(),
        )


def test_replay_of_a_noisy_closed_loop_log_is_exact(robot, trajectory):
    # The recorded (noisy) measurements are exactly what the in-loop blocks saw.
    settings = [SETTINGS[0]]
    noisy = simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=2.6, snr_db=30.0, seed=7),
        settings,
    )
    log = RobotLog(noisy.t, noisy.q, noisy.tau, noisy.joint_names, 1e-3)
    (replayed,) = replay_log(log, robot.rows_provider(), settings)
    online = noisy.traces[0]  # the replay's final row (t_N) apart
    np.testing.assert_allclose(
        replayed.theta[: online.t.size], online.theta, rtol=1e-9, atol=1e-12
    )
    again = simulate_identification(
        robot, trajectory, SimulationSettings(duration=0.2, snr_db=30.0, seed=7), []
    )
    # Seeded: the same standard normal draws (σ depends on the duration).
    np.testing.assert_allclose(
        (again.q - again.q_true)[:150] / again.noise_std[:2],
        (noisy.q - noisy.q_true)[:150] / noisy.noise_std[:2],
        rtol=1e-9,
    )


def test_bank_step_must_follow_the_differentiator_low_pass():
    with pytest.raises(ValueError, match=r"bank_time_step must be <= jacobi_window/10"):
        OnlineSettings(jacobi_window=0.05, bank_time_step=0.02)
    default = OnlineSettings().on_grid(1e-3)
    assert default.bank_time_step <= default.jacobi_window / 10


def test_chain_builders_name_what_is_wrong(robot):
    """Found by a review: ``chain_trace`` of a chain built with ``log=False`` was a
    bare KeyError 'theta'; ``add_online_identifiers`` given one OnlineSettings
    (not a list) or a list holding something else raised a TypeError or an
    AttributeError about iteration and ``on_grid``."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_dynid.core.payload import payload_rows
    from drake_dynid.core.payload_step import payload_settings
    from drake_dynid.diagrams import (
        add_online_identifier,
        add_online_identifiers,
        chain_trace,
    )
    from drake_dynid.payload_diagrams import (
        add_payload_identifier,
        payload_chain_trace,
    )

    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    rows = robot.rows_provider()
    port = source.get_output_port()
    chain = add_online_identifier(builder, rows, port, 1e-3, SETTINGS[0], log=False)
    payload = add_payload_identifier(
        builder, payload_rows(robot), port, 1e-3, payload_settings(), log=False
    )
    with pytest.raises(TypeError, match=r"settings must be a sequence of Online"):
        add_online_identifiers(builder, rows, port, 1e-3, SETTINGS[0])
    with pytest.raises(TypeError, match=r"settings\[1\] must be an OnlineSettings"):
        add_online_identifiers(builder, rows, port, 1e-3, [SETTINGS[0], {}])
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.01)
    context = simulator.get_context()
    with pytest.raises(ValueError, match="chain_trace: the chain has no logger of"):
        chain_trace(chain, context, 1e-3)
    with pytest.raises(ValueError, match="payload_chain_trace: the chain has no"):
        payload_chain_trace(payload, context, 1e-3)


def test_a_chain_trace_wants_the_chain_s_signal_period(robot):
    """Found by a review: chain_trace(chain, context, 2e-3) of a 1 ms chain
    gave the trace a delay of 0.1259 s for 0.1252 s, silently."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_dynid.core.payload import payload_rows
    from drake_dynid.core.payload_step import payload_settings
    from drake_dynid.diagrams import add_online_identifier, chain_trace
    from drake_dynid.payload_diagrams import (
        add_payload_identifier,
        payload_chain_trace,
    )

    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    port = source.get_output_port()
    chain = add_online_identifier(
        builder, robot.rows_provider(), port, 1e-3, SETTINGS[0]
    )
    payload = add_payload_identifier(
        builder, payload_rows(robot), port, 1e-3, payload_settings()
    )
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(0.1)
    context = simulator.get_context()
    assert chain_trace(chain, context, 1e-3).t.size == 3
    assert payload_chain_trace(payload, context, 1e-3).t.size == 3
    message = r"time_step must be the chain's signal period 0\.001 \[s\]"
    with pytest.raises(ValueError, match="chain_trace: " + message):
        chain_trace(chain, context, 2e-3)
    with pytest.raises(ValueError, match="payload_chain_trace: " + message):
        payload_chain_trace(payload, context, 2e-3)


def test_contexts_clone_and_reset_as_the_readme_says(robot, trajectory):
    """README (Compose): ``context.Clone()``, two Simulators of one diagram and
    ``SetDefaultContext`` all work. Every block kind of the chain is in the
    diagram (differentiator, ModelRows, RawModelRows, bank, SignalWindow,
    SlidingQRIdentifier, ChangeTrackingIdentifier); a re-initialised Simulator
    reproduces the first run bit for bit, and a Context cloned mid-run continues
    as the original did (tests/systems: a clone fed other samples than the
    original)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.diagrams import add_online_identifiers, chain_trace, log_source

    h = 1e-3
    t = h * np.arange(3001)
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    rng = np.random.default_rng(5)
    q = q + 1e-4 * rng.normal(size=q.shape)
    tau = tau + 1e-2 * rng.normal(size=tau.shape)
    log = RobotLog(t, q, tau, robot.joint_names, h)
    settings = [
        dataclasses.replace(SETTINGS[0], rows_from="raw", detect_changes=True),
        dataclasses.replace(
            SETTINGS[1],
            weighting="covariance",
            position_noise=1e-4,
            torque_noise=1e-2,
            frequencies=None,
            update_period=0.1,
        ),
    ]
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    chains = add_online_identifiers(
        builder, robot.rows_provider(), source.get_output_port(), h, settings
    )
    diagram = builder.Build()
    t_end = h * log.num_samples
    simulator = Simulator(diagram)
    simulator.AdvanceTo(t_end)
    context = simulator.get_mutable_context()
    first = [chain_trace(chain, context, h) for chain in chains]
    assert all(trace.valid[-1] == 1 for trace in first)

    # Re-initialised on the same Context (Drake's SetDefaultContext keeps the
    # time): the same traces, bit for bit.
    diagram.SetDefaultContext(context)
    context.SetTime(0.0)
    for chain in chains:
        for sink in chain.logs.values():
            sink.FindMutableLog(context).Clear()
    simulator.Initialize()
    simulator.AdvanceTo(t_end)
    again = [chain_trace(chain, context, h) for chain in chains]
    for one, two in zip(first, again, strict=True):
        for name in ("t", "theta", "std", "condition_number", "valid", "status"):
            np.testing.assert_array_equal(getattr(one, name), getattr(two, name))

    # A Context cloned mid-run, advanced after the original went to the end.
    other = Simulator(diagram)
    other.AdvanceTo(0.5 * t_end)
    clone = other.get_context().Clone()
    other.AdvanceTo(t_end)
    resumed = Simulator(diagram, clone)
    resumed.AdvanceTo(t_end)
    for chain in chains:
        for port in ("theta", "theta_std", "status"):
            values = [
                chain.identifier.GetOutputPort(port).Eval(
                    chain.identifier.GetMyContextFromRoot(run.get_context())
                )
                for run in (simulator, other, resumed)
            ]
            np.testing.assert_array_equal(values[0], values[1])
            np.testing.assert_array_equal(values[0], values[2])


def test_simulation_events_are_checked_before_the_run(robot, trajectory):
    """Found by a review: an event at t < 0 made Drake's Simulator go back in
    time, a C++ assertion that aborted the Python process; one at NaN was
    silently skipped; a callback that is not callable failed when reached."""
    import subprocess
    import sys

    short = SimulationSettings(duration=0.05, snr_db=None)

    def simulate(events):
        return simulate_identification(robot, trajectory, short, [], events=events)

    with pytest.raises(ValueError, match=r"events\[0\] time must be finite \[s\]"):
        simulate([(float("nan"), lambda plant, context: None)])
    with pytest.raises(TypeError, match=r"events\[1\] callback must be callable"):
        simulate([(0.01, lambda plant, context: None), (0.02, "ZZ1 + 1")])
    with pytest.raises(TypeError, match=r"events\[0\] must be a \(time, callback\)"):
        simulate([0.01])
    seen = []
    simulate([(0.03, lambda p, c: seen.append(3)), (0.01, lambda p, c: seen.append(1))])
    assert seen == [1, 3]  # in time order
    # In a child process: without the check the abort would end this test run.
    code = (
        "from drake_dynid.diagrams import SimulationSettings, simulate_identification\n"
        "from drake_dynid.paper import paper_trajectory\n"
        "from drake_dynid.plants import RobotModel, model_path\n"
        "robot = RobotModel.from_urdf(model_path('planar_2r'))\n"
        "try:\n"
        "    simulate_identification(robot, paper_trajectory(),\n"
        "        SimulationSettings(duration=0.05), [], events=[(-1.0, print)])\n"
        "except ValueError as error:\n"
        "    print(error)\n"
    )
    child = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300
    )
    assert child.returncode == 0, child.stderr[-500:]
    assert "events[0] time must be >= 0 [s]; got -1.0." in child.stdout


def test_the_bank_front_wants_settings_on_the_signal_grid(robot):
    """Found by a review: add_bank_front said its settings must be on the grid
    of time_step but built with any: at 3 ms the nominal 20 ms bank step (6.67
    samples) read the differentiator at lags varying by up to 3 ms."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_dynid.diagrams import add_bank_front

    def front(settings, time_step):
        builder = DiagramBuilder()
        source = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
        port = source.get_output_port()
        return add_bank_front(builder, robot.rows_provider(), settings, port, time_step)

    settings = OnlineSettings(jacobi_window=0.3)
    with pytest.raises(ValueError, match="settings must be on the grid of time_step"):
        front(settings, 3e-3)
    with pytest.raises(ValueError, match="bank_time_step must be a multiple"):
        front(settings.on_grid(1e-3), 3e-3)
    _, _, bank, design = front(settings.on_grid(3e-3), 3e-3)
    assert design.time_step == pytest.approx(0.021) and bank.bank is design


def test_the_simulated_torque_is_the_one_the_plant_applies(trajectory, tmp_path):
    """Found by a review: simulate_identification logged the controller's
    command while the plant clamps it to the URDF's effort limit: with joint1
    limited to 8 N·m (paper trajectory, 21 s) the log held commands up to
    14 000 N·m and the identifier gave ZZ1R = 2145 for 3.9, "valid". The
    measured τ is now the command clipped as the plant applies it."""
    text = pathlib.Path(model_path("planar_2r")).read_text()
    urdf = tmp_path / "planar_2r_8Nm.urdf"
    urdf.write_text(text.replace('effort="10000"', 'effort="8"', 1))
    limited = RobotModel.from_urdf(urdf)
    result = simulate_identification(
        limited, trajectory, SimulationSettings(duration=2.6, snr_db=None), SETTINGS[:1]
    )
    assert np.abs(result.tau_true[:, 0]).max() == 8.0  # it saturates, as applied
    assert np.abs(result.tau_true[:, 1]).max() > 8.0  # joint2: 10 000 N·m
    np.testing.assert_array_equal(result.tau, result.tau_true)  # noise-free
    theta = result.traces[0].final()["theta"]
    np.testing.assert_allclose(theta[:4], limited.base_values[:4], rtol=0.02)


@pytest.mark.parametrize("sampled", [False, True])
def test_a_plant_with_sampled_output_ports_feeding_the_chain_is_flagged(robot, sampled):
    """Found by a review: a Drake user's own discrete plant keeps Drake's default
    sampled output ports, whose q is one step off the commanded τ; the paper's
    2R closed loop (21 s) around one gave FV1 = -1.41 for 0.3, FC1 -98 %,
    ZZ1R -4.2 %, all "valid", silently (live ports: within 0.6 %)."""
    import warnings

    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import (
        ConstantVectorSource,
        MatrixGain,
        Multiplexer,
    )

    from drake_dynid.diagrams import add_online_identifier
    from drake_dynid.urdf import load_plant

    builder = DiagramBuilder()
    plant = builder.AddSystem(
        load_plant(robot.path, 1e-3, sampled_output_ports=sampled)
    )
    torque = builder.AddSystem(ConstantVectorSource(np.zeros(2)))
    builder.Connect(torque.get_output_port(), plant.get_actuation_input_port())
    measured = builder.AddSystem(Multiplexer([4, 2]))
    builder.Connect(plant.get_state_output_port(), measured.get_input_port(0))
    builder.Connect(torque.get_output_port(), measured.get_input_port(1))
    selected = builder.AddSystem(MatrixGain(np.eye(6)[[0, 1, 4, 5]]))  # [q; τ]
    builder.Connect(measured.get_output_port(), selected.get_input_port())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        add_online_identifier(
            builder,
            robot.rows_provider(),
            selected.get_output_port(),
            1e-3,
            SETTINGS[0],
        )
    messages = [str(w.message) for w in caught if w.category is UserWarning]
    if sampled:
        assert len(messages) == 1 and "with sampled output ports" in messages[0]
        assert "SetUseSampledOutputPorts(False)" in messages[0]
    else:
        assert messages == []


def test_advance_goes_forward_from_the_simulator_s_time():
    """Found by a review: ``simulate_identification(..., events=[(1.5, f)],
    progress=True)`` of 2 s aborted the Python process: ``advance``'s first
    chunk after the event went back to 1 s, a C++ assertion in Drake's
    Simulator. Run in a child process, which the abort would end."""
    import subprocess
    import sys

    code = (
        "from drake_dynid.diagrams import SimulationSettings, advance, "
        "simulate_identification\n"
        "from drake_dynid.paper import paper_trajectory\n"
        "from drake_dynid.plants import RobotModel, model_path\n"
        "robot = RobotModel.from_urdf(model_path('planar_2r'))\n"
        "seen = []\n"
        "result = simulate_identification(robot, paper_trajectory(),\n"
        "    SimulationSettings(duration=2.0), [], progress=True,\n"
        "    events=[(1.5, lambda plant, context: seen.append(1.5))])\n"
        "print('ran', seen, result.t[-1])\n"
        "try:\n"
        "    advance(result.simulator, 1.0, True, 'back')\n"
        "except ValueError as error:\n"
        "    print(error)\n"
    )
    child = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300
    )
    assert child.returncode == 0, child.stderr[-500:]
    lines = child.stdout.splitlines()
    assert lines[0] == "ran [1.5] 2.0"
    assert lines[1] == (
        "advance: t_end must be >= the simulator's time 2 [s] (a Simulator cannot "
        "go back); got 1."
    )


def test_the_measurement_must_be_a_q_tau_output_port(robot):
    """Found by a review (a Drake user wiring the chain): the plant's state port,
    [q; v] of size 2n, was taken for [q; τ] (the 2R closed loop, 25 s: FV1 = FV2
    = 1.000 ± 0.0005, every other parameter 0, "valid"); a system, an input port
    or an abstract port given as the measurement failed with an AttributeError
    or Drake's message about Connect's arguments."""
    from pydrake.common.value import AbstractValue
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantValueSource, ConstantVectorSource

    from drake_dynid.core.payload import payload_rows
    from drake_dynid.core.payload_step import payload_settings
    from drake_dynid.diagrams import add_bank_front, add_online_identifier
    from drake_dynid.payload_diagrams import add_payload_identifier
    from drake_dynid.urdf import load_plant

    builder = DiagramBuilder()
    plant = builder.AddSystem(load_plant(robot.path, 1e-3))
    source = builder.AddSystem(ConstantVectorSource(np.zeros(4)))
    text = builder.AddSystem(ConstantValueSource(AbstractValue.Make("q, tau")))
    rows = robot.rows_provider()
    settings = SETTINGS[0]
    for port in (
        plant.get_state_output_port(),
        plant.get_state_output_port(plant.GetModelInstanceByName("planar_2r")),
    ):
        with pytest.raises(ValueError, match="measurement is the MultibodyPlant's"):
            add_online_identifier(builder, rows, port, 1e-3, settings)
        with pytest.raises(ValueError, match=r"state port .*\[q; v\]"):
            add_payload_identifier(
                builder, payload_rows(robot), port, 1e-3, payload_settings()
            )
    wrong = (source, plant.get_actuation_input_port(), text.get_output_port())
    for measurement in wrong:
        with pytest.raises(TypeError, match="measurement must be the vector Output"):
            add_online_identifier(builder, rows, measurement, 1e-3, settings)
    with pytest.raises(TypeError, match="got the abstract-valued port"):
        add_bank_front(
            builder, rows, settings.on_grid(1e-3), text.get_output_port(), 1e-3
        )
    assert builder.GetSystems() == [plant, source, text]  # nothing added


def test_final_row_gives_identify_s_estimate_and_the_ports_then_hold_it(
    robot, noise_free
):
    """The README (Compose): after a Simulator run to N·h the ports hold the solve
    of the last multiple of U, chain_trace's last row the one before, and
    ``final_row`` runs the solve at the log's last sample that ``dynid identify``
    (``replay_log_core``) reports. A review found the README saying that
    chain_trace(...).final() was identify's (stale since the final solve)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.core.replay import replay_log_core
    from drake_dynid.diagrams import (
        add_online_identifier,
        chain_trace,
        final_row,
        log_source,
    )

    count = 2575  # last sample 2.574 s: not a solve time (U = 0.05 s)
    log = RobotLog(
        noise_free.t[:count],
        noise_free.q[:count],
        noise_free.tau[:count],
        noise_free.joint_names,
        1e-3,
    )
    settings = SETTINGS[0]
    core = replay_log_core(log, robot.rows_provider(), [settings])[0].final()
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    chain = add_online_identifier(
        builder, robot.rows_provider(), source.get_output_port(), 1e-3, settings
    )
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(count * 1e-3)
    context = simulator.get_mutable_context()
    own = chain.identifier.GetMyContextFromRoot(context)
    ports = chain.identifier.get_output_port_theta().Eval(own).copy()
    logged = chain_trace(chain, context, 1e-3).final()["theta"]
    assert core["valid"] and np.abs(ports - core["theta"]).max() > 1e-6
    assert np.abs(logged - core["theta"]).max() > np.abs(ports - core["theta"]).max()
    _, row = final_row(chain, context, count, 1e-3)
    np.testing.assert_allclose(row["theta"], core["theta"], rtol=1e-9)
    np.testing.assert_allclose(
        chain.identifier.get_output_port_theta().Eval(own), core["theta"], rtol=1e-9
    )
