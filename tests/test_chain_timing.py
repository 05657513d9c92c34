"""A chain of blocks in a Simulator over a replayed log: the timing of its traces
and what it does past the log's end (both found by a review). The 2R arm on a
random Fourier reference (default_rng(4)), torques from the library's rows (the
timing is checked, not the accuracy: tests/_motions.py)."""

import numpy as np
from _motions import fourier_2r


def test_a_chain_run_past_the_end_of_its_log_holds_its_last_valid_estimate():
    """Found by a review: a Simulator advanced past the log's end read the last
    sample repeated and reported "valid" estimates of it (FV1 -78 ± 34 for 0.3,
    later ZZ1R = 299 held)."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.diagrams import add_online_identifier, log_source
    from drake_dynid.logs import RobotLog

    h = 1e-3
    robot, t, q, tau = fourier_2r(8001, h)
    log = RobotLog(t, q, tau, robot.joint_names, h)
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    settings = OnlineSettings.for_model("lagrangian", window=5.0)
    chain = add_online_identifier(
        builder, robot.rows_provider(), source.get_output_port(), h, settings
    )
    simulator = Simulator(builder.Build())
    identifier = chain.identifier

    def outputs():
        context = identifier.GetMyContextFromRoot(simulator.get_context())
        return (
            identifier.get_output_port_valid().Eval(context)[0],
            identifier.get_output_port_theta().Eval(context).copy(),
        )

    simulator.AdvanceTo(8.0)
    assert outputs()[0] == 1.0
    # Once the window reaches the end (the bank lags by the Jacobi delay) the
    # solves are invalid and the last valid estimate, of real samples, is held.
    simulator.AdvanceTo(9.0)
    valid, last = outputs()
    assert valid == 0.0
    np.testing.assert_allclose(last[:4], robot.base_values[:4], rtol=0.02)
    for end in (10.0, 14.0):
        simulator.AdvanceTo(end)
        valid, theta = outputs()
        assert valid == 0.0, end
        np.testing.assert_array_equal(theta, last)


def test_a_trace_row_is_the_solve_one_update_period_before():
    """The documented timing of ``OnlineTrace.t`` (a review found the docstring's
    "times of the solves, the window ends at t - delay" one period U off): the
    row logged at t_s is the solve at t_s - U + 3h/4."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.core.online import SOLVE_OFFSET, OnlineSettings
    from drake_dynid.diagrams import add_online_identifier, chain_trace, log_source
    from drake_dynid.logs import RobotLog

    h = 1e-3
    robot, t, q, tau = fourier_2r(7001, h)
    log = RobotLog(t, q, tau, robot.joint_names, h)
    settings = OnlineSettings.for_model("lagrangian", window=5.0)
    period = settings.on_grid(h).resolved("update_period")

    def run(end):
        builder = DiagramBuilder()
        source = builder.AddSystem(log_source(log))
        chain = add_online_identifier(
            builder, robot.rows_provider(), source.get_output_port(), h, settings
        )
        simulator = Simulator(builder.Build())
        simulator.AdvanceTo(end)
        context = chain.identifier.GetMyContextFromRoot(simulator.get_context())
        valid = chain.identifier.get_output_port_valid().Eval(context)[0]
        theta = chain.identifier.get_output_port_theta().Eval(context).copy()
        return chain_trace(chain, simulator.get_context(), h), valid, theta

    trace, _, _ = run(6.0)
    first = int(np.flatnonzero(trace.valid > 0.5)[0])
    solve = trace.t[first] - period + SOLVE_OFFSET * h
    _, before, _ = run(solve - h / 8)
    _, after, theta = run(solve + h / 8)
    assert before == 0.0 and after == 1.0
    np.testing.assert_array_equal(theta, trace.theta[first])


def test_a_noise_compensated_power_chain_run_past_the_end_of_its_log_holds():
    """Found by a review: with ``position_noise`` (the power rows' noise-bias
    compensation, a row provider that rejects non-finite signals) the ModelRows
    block passed the NaN that ``log_source`` outputs past the log's end to the
    provider, and the Simulator raised "q must be finite" instead of reporting
    valid = 0 and holding the last estimate as the README says."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.diagrams import add_online_identifier, log_source
    from drake_dynid.logs import RobotLog

    h = 1e-3
    robot, t, q, tau = fourier_2r(8001, h)
    log = RobotLog(t, q, tau, robot.joint_names, h)
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    settings = OnlineSettings.for_model(
        "power", window=5.0, weighting="frequency", position_noise=1e-5
    )
    chain = add_online_identifier(
        builder, robot.rows_provider(), source.get_output_port(), h, settings
    )
    simulator = Simulator(builder.Build())
    identifier = chain.identifier
    context = identifier.GetMyContextFromRoot(simulator.get_context())
    simulator.AdvanceTo(8.0)
    assert identifier.get_output_port_valid().Eval(context)[0] == 1.0
    simulator.AdvanceTo(9.0)
    last = identifier.get_output_port_theta().Eval(context).copy()
    assert identifier.get_output_port_valid().Eval(context)[0] == 0.0
    simulator.AdvanceTo(10.0)
    assert identifier.get_output_port_valid().Eval(context)[0] == 0.0
    np.testing.assert_array_equal(
        identifier.get_output_port_theta().Eval(context), last
    )


def test_net_actuation_lags_only_with_sampled_output_ports():
    """README Timing (a review found it said net_actuation always reports
    τ_{k-1}): with ``load_plant``'s live output ports a logger and a discrete
    update at t_k both read the command τ_k from it, clipped as applied; with
    Drake's default sampled ports the logger reads τ_{k-1}."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import (
        LogVectorOutput,
        TrajectorySource,
        ZeroOrderHold,
    )
    from pydrake.trajectories import PiecewisePolynomial

    from drake_dynid.urdf import load_plant, model_path

    h = 1e-3
    ramp = PiecewisePolynomial.FirstOrderHold([0.0, 1.0], [[0.0, 1e3], [0.0, 0.0]])
    for sampled, lag in ((False, 0), (True, 1)):
        builder = DiagramBuilder()
        plant = builder.AddSystem(
            load_plant(model_path("planar_2r"), h, sampled_output_ports=sampled)
        )
        command = builder.AddSystem(TrajectorySource(ramp))
        builder.Connect(command.get_output_port(), plant.get_actuation_input_port())
        net = plant.get_net_actuation_output_port()
        held = builder.AddSystem(ZeroOrderHold(h, 2))  # a discrete update at t_k
        builder.Connect(net, held.get_input_port())
        logs = [
            LogVectorOutput(port, builder, h)
            for port in (command.get_output_port(), net, held.get_output_port())
        ]
        simulator = Simulator(builder.Build())
        simulator.AdvanceTo(0.01)
        tau, logged, read = (
            sink.FindLog(simulator.get_context()).data()[0] for sink in logs
        )
        k = np.arange(3, 9)
        np.testing.assert_allclose(logged[k], tau[k - lag], atol=1e-9)
        np.testing.assert_allclose(read[k + 1], tau[k], atol=1e-9)  # held at t_k
