"""ModelRows, ModulatingIntegralBank and SlidingQRIdentifier blocks."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_dynid.core import lsq, modulating
from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.systems.identification import (
    ModelRows,
    ModulatingIntegralBank,
    SlidingQRIdentifier,
)

H = 0.01  # bank sample period [s] in these tests


def test_model_rows_equals_provider():
    rows = Planar2RRows(L1=1.0)
    block = ModelRows(rows, "lagrangian")
    context = block.CreateDefaultContext()
    q, v, tau = np.array([0.3, -0.2]), np.array([1.0, 2.0]), np.array([0.5, -0.1])
    for port, value in zip(("q", "v", "tau"), (q, v, tau), strict=True):
        block.GetInputPort(port).FixValue(context, value)
    d, g, y = rows.model_rows("lagrangian", q[None], v[None], tau[None])
    expected = modulating.pack_rows(d[0], g[0], y[0])
    np.testing.assert_array_equal(block.get_output_port().Eval(context), expected)
    assert block.num_equations == 2 and block.num_parameters == 8
    with pytest.raises(ValueError, match="kind must be one of"):
        ModelRows(rows, "hamiltonian")


def _bank_diagram(samples, valid, bank, m, p):
    builder = DiagramBuilder()
    times = H * np.arange(len(samples) + 1)
    values = np.vstack([samples, samples[-1:]]).T
    source = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, values))
    )
    flags = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.ZeroOrderHold(times, np.append(valid, valid[-1])[None])
        )
    )
    block = builder.AddSystem(ModulatingIntegralBank(bank, m, p))
    builder.Connect(source.get_output_port(), block.GetInputPort("channels"))
    builder.Connect(flags.get_output_port(), block.GetInputPort("sample_valid"))
    return builder.Build(), block


def test_bank_block_equals_direct_quadrature_and_has_no_feedthrough():
    rng = np.random.default_rng(0)
    m, p = 1, 2
    bank = modulating.fourier_bank(0.5, H, order=1, ell=[0.0, 1.0, 2.5])
    samples = rng.normal(size=(80, modulating.num_channels(m, p)))
    diagram, block = _bank_diagram(samples, np.ones(80), bank, m, p)
    assert not block.HasAnyDirectFeedthrough()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(79 * H + 1e-9)  # updates at samples 0..79 processed
    context = block.GetMyContextFromRoot(simulator.get_context())
    window = samples[80 - bank.num_samples : 80]
    a, b = modulating.assemble_equations(
        bank, modulating.direct_fourier_integrals(bank, window), m, p
    )
    np.testing.assert_allclose(
        block.GetOutputPort("A").Eval(context), a.ravel(), rtol=1e-9, atol=1e-12
    )
    np.testing.assert_allclose(block.GetOutputPort("B").Eval(context), b, rtol=1e-9)
    assert block.GetOutputPort("valid").Eval(context)[0] == 1.0


def test_bank_window_invalid_while_a_bad_sample_is_inside():
    m, p = 1, 2
    bank = modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0])
    c = modulating.num_channels(m, p)
    samples = np.ones((60, c))
    samples[30, 0] = np.nan
    valid = np.ones(60)
    valid[5] = 0.0
    diagram, block = _bank_diagram(samples, valid, bank, m, p)
    simulator = Simulator(diagram)
    flags = []
    for k in range(60):
        simulator.AdvanceTo(k * H + 1e-9)
        context = block.GetMyContextFromRoot(simulator.get_context())
        flags.append(block.GetOutputPort("valid").Eval(context)[0])
        assert np.all(np.isfinite(block.GetOutputPort("A").Eval(context)))
    flags = np.array(flags)
    n1 = bank.num_samples  # 21
    # Window k holds samples k-20..k: valid once full, without sample 5 or 30.
    expected = [
        1.0
        if (k >= n1 - 1 and not (k - n1 < 5 <= k) and not (k - n1 < 30 <= k))
        else 0.0
        for k in range(60)
    ]
    np.testing.assert_array_equal(flags, expected)


def _identifier_context(a, b, window_valid, **kwargs):
    r, p = a.shape
    block = SlidingQRIdentifier(p, r, 0.1, names=["a", "b", "c"][:p], **kwargs)
    context = block.CreateDefaultContext()
    block.GetInputPort("A").FixValue(context, a.ravel())
    block.GetInputPort("B").FixValue(context, b)
    block.GetInputPort("window_valid").FixValue(context, [window_valid])
    return block, context


def _step(block, context):
    # One periodic solve; every discrete state group (one per quantity) is updated.
    context.SetDiscreteState(block.EvalUniquePeriodicDiscreteUpdate(context))


def test_identifier_solves_like_the_core_and_holds_invalid_windows():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(40, 3))
    theta = np.array([1.0, -2.0, 0.5])
    b = a @ theta + 0.01 * rng.normal(size=40)
    block, context = _identifier_context(a, b, 1.0)
    assert not block.HasAnyDirectFeedthrough()
    assert np.all(np.isinf(block.GetOutputPort("theta_std").Eval(context)))
    assert block.GetOutputPort("valid").Eval(context)[0] == 0.0
    _step(block, context)
    core = lsq.solve_least_squares(a, b)
    np.testing.assert_allclose(block.GetOutputPort("theta").Eval(context), core.theta)
    np.testing.assert_allclose(block.GetOutputPort("theta_std").Eval(context), core.std)
    assert block.GetOutputPort("valid").Eval(context)[0] == 1.0
    held = block.GetOutputPort("theta").Eval(context).copy()
    # Window not ready: hold, valid = 0.
    block.GetInputPort("window_valid").FixValue(context, [0.0])
    _step(block, context)
    np.testing.assert_array_equal(block.GetOutputPort("theta").Eval(context), held)
    assert block.GetOutputPort("valid").Eval(context)[0] == 0.0
    # Rank-deficient window (column c never excited): hold and name it.
    deficient = a.copy()
    deficient[:, 2] = 0.0
    block.GetInputPort("window_valid").FixValue(context, [1.0])
    block.GetInputPort("A").FixValue(context, deficient.ravel())
    _step(block, context)
    np.testing.assert_array_equal(block.GetOutputPort("theta").Eval(context), held)
    assert block.GetOutputPort("valid").Eval(context)[0] == 0.0
    np.testing.assert_array_equal(
        block.GetOutputPort("unidentified").Eval(context), [0.0, 0.0, 1.0]
    )
    assert np.all(np.isfinite(block.GetOutputPort("theta").Eval(context)))


def test_identifier_argument_checks():
    with pytest.raises(ValueError, match="update_period must be > 0"):
        SlidingQRIdentifier(2, 10, 0.0)
    with pytest.raises(ValueError, match="names must have 2 entries"):
        SlidingQRIdentifier(2, 10, 0.1, names=["a"])
    with pytest.raises(ValueError, match=r"initial_theta must have shape \(2\)"):
        SlidingQRIdentifier(2, 10, 0.1, initial_theta=[1.0, 2.0, 3.0])


def test_two_simulators_on_one_bank_block_give_identical_outputs():
    rng = np.random.default_rng(2)
    bank = modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0])
    samples = rng.normal(size=(40, modulating.num_channels(1, 2)))
    diagram, block = _bank_diagram(samples, np.ones(40), bank, 1, 2)
    outputs = []
    for _ in range(2):
        simulator = Simulator(diagram)
        simulator.AdvanceTo(39 * H + 1e-9)
        context = block.GetMyContextFromRoot(simulator.get_context())
        outputs.append(block.GetOutputPort("B").Eval(context).copy())
    np.testing.assert_array_equal(outputs[0], outputs[1])


def test_bank_block_checks_its_design():
    with pytest.raises(TypeError, match="bank must be a modulating bank design"):
        ModulatingIntegralBank({"window": 1.0}, 1, 2)
    bank = modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0])
    with pytest.raises(ValueError, match="num_equations must be >= 1"):
        ModulatingIntegralBank(bank, 0, 2)
