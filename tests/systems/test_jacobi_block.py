"""CausalJacobiDifferentiator block: topology, core agreement, timing convention.

Timing observed (and documented in the block): the block updates at t_k = k·h
(offset 0); a LogVectorOutput with publish_period h logs at t_k the state after
the update at t_{k-1}, i.e. the estimate from samples up to t_{k-1}, which refers
to t_{k-1} - delay. The ``valid`` flag in such a log switches to 1 at t_{N+1}.
Seed: np.random.default_rng(20140701).
"""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_dynid.core.jacobi import (
    jacobi_batch,
    jacobi_filters,
    jacobi_initial_state,
    jacobi_outputs,
    jacobi_ring,
    jacobi_sinusoid_error,
    jacobi_step,
)
from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

SEED = 20140701
H = 1e-3


def make_block(**overrides):
    args = dict(
        num_signals=2, time_step=H, window=0.02, kappa=1.0, mu=1.0, q=1, orders=(0, 1)
    )
    args.update(overrides)
    return CausalJacobiDifferentiator(
        args.pop("num_signals"), args.pop("time_step"), args.pop("window"), **args
    )


def simulate(source, block, duration, num_signals):
    """Source -> block -> loggers at period h. Returns (times, logs by port name)."""
    builder = DiagramBuilder()
    src = builder.AddSystem(source)
    blk = builder.AddSystem(block)
    builder.Connect(src.get_output_port(0), blk.get_input_port_u())
    names = [f"derivative_{f.order}" for f in block.filters] + ["valid"]
    loggers = {
        name: LogVectorOutput(blk.GetOutputPort(name), builder, publish_period=H)
        for name in names
    }
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(duration)
    context = simulator.get_context()
    logs = {name: log.FindLog(context) for name, log in loggers.items()}
    times = logs["valid"].sample_times()
    return times, {name: log.data() for name, log in logs.items()}


def ramp_source(slope, offset, duration, num_signals):
    values = np.array([[offset, offset + slope * duration]] * num_signals)
    return TrajectorySource(PiecewisePolynomial.FirstOrderHold([0.0, duration], values))


# ---------------------------------------------------------------------- topology


def test_ports_properties_and_no_direct_feedthrough():
    block = make_block(num_signals=3, orders=(0, 1, 2), window=0.05)
    assert block.num_input_ports() == 1
    assert block.get_input_port(0).get_name() == "u"
    assert block.get_input_port(0).size() == 3
    names = [
        block.get_output_port(i).get_name() for i in range(block.num_output_ports())
    ]
    assert names == ["derivative_0", "derivative_1", "derivative_2", "valid", "history"]
    sizes = [block.get_output_port(i).size() for i in range(block.num_output_ports())]
    assert sizes == [3, 3, 3, 1, 51 * 3] and block.history_length == 51
    assert not block.HasAnyDirectFeedthrough()
    assert block.get_output_port_derivative(2).get_name() == "derivative_2"
    assert block.get_output_port_valid().get_name() == "valid"
    bank = jacobi_filters((0, 1, 2), 0.05, H, kappa=1.0, mu=1.0, q=1)
    assert block.xi == bank[0].xi
    assert block.delay == pytest.approx(0.05 * bank[0].xi, rel=1e-15)
    assert [f.order for f in block.filters] == [0, 1, 2]
    for mine, theirs in zip(block.filters, bank, strict=True):
        np.testing.assert_array_equal(mine.taps, theirs.taps)
    assert block.num_signals == 3 and block.time_step == H


def test_the_derivative_getter_wants_one_of_the_block_s_orders():
    """Found by a review: ``get_output_port_derivative(1.7)`` returned
    ``derivative_1`` (int() truncated it)."""
    block = make_block(orders=(0, 1))
    assert block.get_output_port_derivative(np.int64(1)).get_name() == "derivative_1"
    with pytest.raises(TypeError, match=r"order must be an integer; got 1\.7"):
        block.get_output_port_derivative(1.7)
    with pytest.raises(ValueError, match=r"order must be one of .*\(0, 1\); got 2"):
        block.get_output_port_derivative(2)


def test_explicit_xi_and_single_order():
    block = make_block(orders=(1,), xi=0.0)
    assert block.delay == 0.0
    names = [
        block.get_output_port(i).get_name() for i in range(block.num_output_ports())
    ]
    assert names == ["derivative_1", "valid", "history"]


@pytest.mark.parametrize(
    "overrides,error,match",
    [
        (dict(window=0.0105), ValueError, "window must be a multiple of time_step"),
        (dict(time_step=0.0), ValueError, "time_step must be > 0"),
        (dict(kappa=-1.0), ValueError, "kappa must be > -1"),
        (dict(mu=-2.0), ValueError, "mu must be > -1"),
        (dict(q=-1), ValueError, "q must be >= 0"),
        (dict(q=0.5), ValueError, "q must be an integer"),
        (dict(xi=1.5), ValueError, "xi must be in"),
        (dict(orders=(1, 1)), ValueError, "orders must be distinct"),
        (dict(orders=()), ValueError, "orders must hold at least one order"),
        (dict(orders=(-1,)), ValueError, "orders must be >= 0"),
        (dict(num_signals=0), ValueError, "num_signals must be >= 1"),
        (dict(num_signals=1.5), TypeError, "num_signals must be an integer"),
    ],
)
def test_invalid_arguments_name_the_block(overrides, error, match):
    with pytest.raises(error, match="CausalJacobiDifferentiator: " + match):
        make_block(**overrides)


def test_window_message_is_the_house_format():
    with pytest.raises(ValueError) as info:
        make_block(window=0.0105)
    assert str(info.value) == (
        "CausalJacobiDifferentiator: window must be a multiple of time_step [s]; "
        "got 0.0105 with time_step 0.001."
    )


# --------------------------------------------------------------- core agreement


def test_block_equals_core_on_random_samples():
    rng = np.random.default_rng(SEED)
    block = make_block(num_signals=3, orders=(2, 0, 1), window=0.015, kappa=-0.4, mu=2)
    ring = jacobi_ring(block.filters, 3)
    context = block.CreateDefaultContext()
    state = jacobi_initial_state(ring)
    samples = rng.normal(size=(40, 3))
    outputs = []
    for sample in samples:
        block.get_input_port(0).FixValue(context, sample)
        update = block.EvalUniquePeriodicDiscreteUpdate(context).get_value(0)
        context.SetDiscreteState(0, update)
        state = jacobi_step(ring, state, sample)
        np.testing.assert_array_equal(update, state)
        for index, filt in enumerate(block.filters):
            got = block.get_output_port_derivative(filt.order).Eval(context)
            np.testing.assert_array_equal(got, jacobi_outputs(ring, state, index))
        outputs.append(
            [
                block.get_output_port_derivative(f.order).Eval(context)
                for f in block.filters
            ]
        )
    outputs = np.array(outputs)  # (T, K, m)
    for index, filt in enumerate(block.filters):
        batch = jacobi_batch(filt, samples)
        scale = np.abs(batch).max()
        np.testing.assert_allclose(outputs[:, index], batch, rtol=0, atol=1e-13 * scale)


def test_two_simulators_on_one_block_give_identical_logs():
    # One diagram (hence one block object), two Simulators with their own Contexts,
    # advanced in an interleaved order: any state kept on the Python object would
    # make the logs differ.
    rng = np.random.default_rng(SEED)
    knots = np.arange(0, 0.06 + 1e-12, 0.005)
    values = rng.normal(size=(2, knots.size))
    builder = DiagramBuilder()
    source = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.FirstOrderHold(knots, values))
    )
    block = builder.AddSystem(make_block(num_signals=2))
    builder.Connect(source.get_output_port(0), block.get_input_port_u())
    logger = LogVectorOutput(block.GetOutputPort("derivative_1"), builder, H)
    diagram = builder.Build()
    first, second = Simulator(diagram), Simulator(diagram)
    first.AdvanceTo(0.03)
    second.AdvanceTo(0.06)
    first.AdvanceTo(0.06)
    log1 = logger.FindLog(first.get_context())
    log2 = logger.FindLog(second.get_context())
    np.testing.assert_array_equal(log1.sample_times(), log2.sample_times())
    np.testing.assert_array_equal(log1.data(), log2.data())
    assert np.abs(log1.data()).max() > 0  # something happened


# ------------------------------------------------------------------ timing


def test_ramp_gives_exact_slope_and_delayed_value_and_valid_timing():
    slope, offset, duration = 2.0, 0.3, 0.06
    block = make_block(num_signals=2, window=0.02, kappa=1.5, mu=0.5, q=1)
    n = round(0.02 / H)
    times, logs = simulate(ramp_source(slope, offset, duration, 2), block, duration, 2)
    np.testing.assert_allclose(times, np.arange(times.size) * H, atol=1e-12)
    # valid in the log: 0 up to t_N (it shows the state after the update at t_{k-1}),
    # 1 from t_{N+1} on: the update at t_N completes the N+1 samples.
    valid = logs["valid"][0]
    assert np.all(valid[: n + 1] == 0.0) and np.all(valid[n + 1 :] == 1.0)
    after = np.arange(n + 1, times.size)
    np.testing.assert_allclose(logs["derivative_1"][:, after], slope, rtol=1e-11)
    # log at t_k: estimate from samples up to t_{k-1}, refers to t_{k-1} - delay
    refers_to = times[after] - H - block.delay
    expected = offset + slope * refers_to
    for channel in range(2):
        np.testing.assert_allclose(
            logs["derivative_0"][channel, after], expected, rtol=0, atol=1e-12
        )
    # and not (for example) t_k - delay: the test can tell one step apart
    assert (
        np.abs(
            logs["derivative_0"][0, after]
            - (offset + slope * (times[after] - block.delay))
        ).min()
        > 1e-3
    )


def test_sine_through_simulator():
    omega, duration = 4.0, 0.5
    block = make_block(num_signals=1, window=0.1, kappa=1.0, mu=1.0, q=1, orders=(0, 1))
    knots = np.arange(0.0, duration + 1e-12, 1e-3)
    values = np.sin(omega * knots)[None, :]
    source = TrajectorySource(
        PiecewisePolynomial.CubicHermite(
            knots, values, omega * np.cos(omega * knots)[None, :]
        )
    )
    times, logs = simulate(source, block, duration, 1)
    n = round(0.1 / H)
    after = np.arange(n + 1, times.size)
    refers_to = times[after] - H - block.delay
    # the outputs are time-aligned at t_{k-1} - delay, within the closed-form
    # steady-state error of each filter at this frequency (jacobi_sinusoid_error)
    truths = {0: np.sin(omega * refers_to), 1: omega * np.cos(omega * refers_to)}
    for f in block.filters:
        bound = jacobi_sinusoid_error(f, [omega])[0]
        error = np.abs(logs[f"derivative_{f.order}"][0, after] - truths[f.order])
        assert error.max() <= bound * 1.01 + 1e-9
        assert error.max() >= bound * 0.5  # the bound is the actual error amplitude
    assert np.abs(logs["derivative_1"][0, after] - truths[1]).max() < 2e-3
    # and equal the batch filter on the sampled sine, one sample later in the log
    samples = np.sin(omega * knots)
    for f in block.filters:
        batch = jacobi_batch(f, samples)
        np.testing.assert_allclose(
            logs[f"derivative_{f.order}"][0, 1:],
            batch[: times.size - 1],
            rtol=0,
            atol=1e-10,
        )


def test_matched_block_uses_shifted_weights_and_one_xi():
    block = CausalJacobiDifferentiator(
        2, 1e-3, 0.1, kappa=1.0, mu=0.5, q=1, orders=(0, 1), matched=True
    )
    f0, f1 = block.filters
    assert (f0.kappa, f0.mu, f1.kappa, f1.mu) == (2.0, 1.5, 1.0, 0.5)
    assert f0.delay == f1.delay == block.delay


def test_history_port_is_the_ring_in_time_order():
    """After the update at t_k, history holds samples k - N .. k (zeros before 0)."""
    block = make_block(num_signals=2, window=0.005)  # 6 samples
    samples = np.random.default_rng(SEED).normal(size=(9, 2))
    source = TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(
            H * (np.arange(10) - 0.5), np.vstack([samples, samples[-1:]]).T
        )
    )
    builder = DiagramBuilder()
    src = builder.AddSystem(source)
    blk = builder.AddSystem(block)
    builder.Connect(src.get_output_port(0), blk.get_input_port_u())
    simulator = Simulator(builder.Build())
    for k in range(len(samples)):
        simulator.AdvanceTo(k * H + H / 2)
        context = blk.GetMyContextFromRoot(simulator.get_context())
        history = blk.get_output_port_history().Eval(context).reshape(6, 2)
        expected = np.vstack([np.zeros((6, 2)), samples[: k + 1]])[-6:]
        np.testing.assert_array_equal(history, expected)


def test_a_non_finite_sample_makes_valid_0_while_it_is_in_the_ring():
    # The documented behaviour (a review found the docstring said "then 1" for
    # good): a NaN sample of one signal makes that signal's estimates NaN and
    # ``valid`` 0 for the N+1 updates it stays in the ring, then 1 again.
    block = CausalJacobiDifferentiator(2, H, 0.01, kappa=0, mu=0, q=1, orders=(0, 1))
    context = block.CreateDefaultContext()

    def update(u):
        block.get_input_port_u().FixValue(context, u)
        context.SetDiscreteState(block.EvalUniquePeriodicDiscreteUpdate(context))
        return (
            block.get_output_port_valid().Eval(context)[0],
            block.get_output_port_derivative(0).Eval(context).copy(),
        )

    for _ in range(11):  # N + 1 = 11 samples
        valid, _ = update([1.0, 2.0])
    assert valid == 1.0
    valid, smoothed = update([np.nan, 2.0])
    assert valid == 0.0 and np.isnan(smoothed[0]) and np.isfinite(smoothed[1])
    flags = [update([1.0, 2.0])[0] for _ in range(11)]
    assert flags == [0.0] * 10 + [1.0]
