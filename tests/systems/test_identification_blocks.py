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


def test_two_simulators_on_one_identifier_block_give_identical_logs():
    # Bank -> identifier on random rows (seed 3); two Simulators on the one diagram,
    # advanced interleaved: state kept on the Python objects would make them differ.
    from pydrake.systems.primitives import LogVectorOutput

    rng = np.random.default_rng(3)
    m, p = 1, 2
    bank = modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0, 2.0])
    samples = rng.normal(size=(60, modulating.num_channels(m, p)))
    builder = DiagramBuilder()
    times = H * np.arange(61)
    source = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.ZeroOrderHold(
                times, np.vstack([samples, samples[-1:]]).T
            )
        )
    )
    flags = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, np.ones((1, 61))))
    )
    block = builder.AddSystem(ModulatingIntegralBank(bank, m, p, offset=H / 2))
    builder.Connect(source.get_output_port(), block.get_input_port_channels())
    builder.Connect(flags.get_output_port(), block.get_input_port_sample_valid())
    identifier = builder.AddSystem(
        SlidingQRIdentifier(p, block.num_rows, 2 * H, offset=0.75 * H)
    )
    builder.Connect(block.get_output_port_A(), identifier.get_input_port_A())
    builder.Connect(block.get_output_port_B(), identifier.get_input_port_B())
    builder.Connect(
        block.get_output_port_valid(), identifier.get_input_port_window_valid()
    )
    logs = [
        LogVectorOutput(port, builder, 2 * H)
        for port in (
            identifier.get_output_port_theta(),
            identifier.get_output_port_status(),
        )
    ]
    diagram = builder.Build()
    first, second = Simulator(diagram), Simulator(diagram)
    first.AdvanceTo(0.3)
    second.AdvanceTo(0.55)
    first.AdvanceTo(0.55)
    for sink in logs:
        one, two = sink.FindLog(first.get_context()), sink.FindLog(second.get_context())
        np.testing.assert_array_equal(one.data(), two.data())
    status = logs[1].FindLog(first.get_context()).data()[0]
    assert status[0] == 1 and status[-1] == 0  # not ready, then solved
    assert np.abs(logs[0].FindLog(first.get_context()).data()).max() > 0


def test_identifier_state_groups_follow_the_core_step():
    from drake_dynid.core.identifier import Status, identifier_init, identifier_update

    rng = np.random.default_rng(5)
    a = rng.normal(size=(30, 2))
    b = a @ np.array([0.5, -1.0]) + 0.01 * rng.normal(size=30)
    block, context = _identifier_context(a, b, 1.0)
    assert block.num_discrete_state_groups() == 6  # one per quantity
    assert block.status(context) is Status.WINDOW_NOT_READY
    _step(block, context)
    core = identifier_update(identifier_init(2), True, a, b, names=("a", "b"))
    state = block.state(context)
    np.testing.assert_array_equal(state.theta, core.theta)
    np.testing.assert_array_equal(state.std, core.std)
    assert state.status is Status.OK and block.status(context) == 0
    assert state.condition_number == core.condition_number


def test_port_accessors_name_the_ports():
    from drake_dynid.systems.friction import JointFriction

    rows = ModelRows(Planar2RRows(L1=1.0), "power")
    assert [
        rows.get_input_port_q().get_name(),
        rows.get_input_port_v().get_name(),
        rows.get_input_port_tau().get_name(),
        rows.get_output_port_channels().get_name(),
    ] == ["q", "v", "tau", "channels"]
    bank = ModulatingIntegralBank(
        modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0]), 1, 2
    )
    assert bank.get_input_port_channels().get_name() == "channels"
    assert bank.get_input_port_sample_valid().get_name() == "sample_valid"
    assert bank.get_output_port_A().get_name() == "A"
    assert bank.get_output_port_B().get_name() == "B"
    assert bank.get_output_port_valid().get_name() == "valid"
    identifier = SlidingQRIdentifier(2, 10, 0.1)
    for name in ("A", "B", "window_valid"):
        assert getattr(identifier, f"get_input_port_{name}")().get_name() == name
    for name in (
        "theta",
        "theta_std",
        "condition_number",
        "valid",
        "unidentified",
        "status",
    ):
        assert getattr(identifier, f"get_output_port_{name}")().get_name() == name
    friction = JointFriction([0.1], [0.2])
    assert friction.get_input_port_state().get_name() == "state"
    assert (
        friction.get_output_port_generalized_force().get_name() == "generalized_force"
    )


def test_model_rows_generic_provider_packs_the_rows():
    # RobotModel has no single-sample fast path: the block packs its batch rows.
    from drake_dynid.robot import RobotModel
    from drake_dynid.urdf import model_path

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    block = ModelRows(robot, "power")
    context = block.CreateDefaultContext()
    q, v, tau = np.array([0.3, -0.2]), np.array([1.0, 2.0]), np.array([0.5, -0.1])
    block.get_input_port_q().FixValue(context, q)
    block.get_input_port_v().FixValue(context, v)
    block.get_input_port_tau().FixValue(context, tau)
    expected = modulating.pack_rows(*robot.model_rows("power", q, v, tau))
    np.testing.assert_allclose(
        block.get_output_port_channels().Eval(context), expected, rtol=1e-12
    )


def test_model_rows_outputs_nan_for_a_non_finite_sample_whatever_the_provider():
    # A review: a provider that rejects non-finite signals (the power rows' noise
    # compensation, OnlineSettings.row_provider with position_noise) made the
    # block raise on a NaN sample (a log's end, a sensor dropout) where the bank
    # stores it as invalid. The block now outputs NaN channels without calling
    # the provider, as RawModelRows does.
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.robot import RobotModel
    from drake_dynid.urdf import model_path

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    settings = OnlineSettings.for_model("power", position_noise=1e-4).on_grid(1e-3)
    rows = settings.row_provider(robot.rows_provider(), 1e-3)
    for kind in ("power", "lagrangian"):
        block = ModelRows(rows, kind)
        context = block.CreateDefaultContext()
        block.get_input_port_q().FixValue(context, [np.nan, 0.2])
        block.get_input_port_v().FixValue(context, [1.0, 2.0])
        block.get_input_port_tau().FixValue(context, [0.5, -0.1])
        out = block.get_output_port_channels().Eval(context)
        assert out.shape == (block.get_output_port_channels().size(),)
        assert np.all(np.isnan(out)), kind


class _WrappedBank:
    """Another 'family' for the protocol test: delegates to a FourierBank."""

    def __init__(self, bank):
        self._bank = bank
        self.window, self.time_step = bank.window, bank.time_step
        self.num_samples = bank.num_samples
        self.pushes = 0

    def num_rows(self, m):
        return self._bank.num_rows(m)

    def row_frequencies(self, m):
        return self._bank.row_frequencies(m)

    def row_functions(self, m):
        return self._bank.row_functions(m)

    def init_state(self, num_channels):
        return self._bank.init_state(num_channels)

    def push(self, state, sample, *, valid=True):
        self.pushes += 1
        return self._bank.push(state, sample, valid=valid)

    def push_many(self, state, samples, *, valid=None):
        return self._bank.push_many(state, samples, valid=valid)

    def window_valid(self, state):
        return self._bank.window_valid(state)

    def equations(self, state, m, p):
        return self._bank.equations(state, m, p)


def test_bank_block_takes_any_modulating_bank_design():
    from drake_dynid.core.bank import ModulatingBank

    rng = np.random.default_rng(6)
    m, p = 1, 2
    fourier = modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0])
    assert isinstance(fourier, ModulatingBank)
    wrapped = _WrappedBank(fourier)
    samples = rng.normal(size=(30, modulating.num_channels(m, p)))
    outputs = []
    for design in (fourier, wrapped):
        diagram, block = _bank_diagram(samples, np.ones(30), design, m, p)
        simulator = Simulator(diagram)
        simulator.AdvanceTo(29 * H + 1e-9)
        context = block.GetMyContextFromRoot(simulator.get_context())
        outputs.append(block.get_output_port_B().Eval(context).copy())
    np.testing.assert_array_equal(outputs[0], outputs[1])
    assert wrapped.pushes == 30


@pytest.mark.parametrize("rows", [2, 3])
def test_a_window_that_can_never_be_solved_is_refused(rows):
    """Found by a review: num_rows <= num_parameters built, then every solve was
    status 2 with a NaN condition number and nothing flagged."""
    from drake_dynid.systems.identifier import SlidingQRIdentifier
    from drake_dynid.systems.payload import PayloadIdentifier

    for block in (SlidingQRIdentifier, PayloadIdentifier):
        with pytest.raises(ValueError, match="num_rows must exceed num_parameters"):
            block(3, rows, 0.1)


def test_raw_model_rows_is_told_its_differentiator_s_period():
    """Found by a review: RawModelRows was not told the period of the ring it
    reads, so a 2 kHz differentiator's history read with a 1 ms design built
    and gave v' = 0.47 for q̇ = 0.94 (the taps are in 1/s). Its ``time_step``
    (the differentiator's) must now be the design's."""
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.core.raw_rows import raw_channels
    from drake_dynid.systems.identification import RawModelRows
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    rows = Planar2RRows(L1=1.0)
    settings = OnlineSettings.for_model("lagrangian", rows_from="raw")
    design = settings.on_grid(1e-3).raw_design(1e-3)
    fast = CausalJacobiDifferentiator(
        4, 5e-4, **settings.on_grid(5e-4).jacobi_parameters()
    )
    assert fast.history_length >= design.history  # long enough: it used to build
    with pytest.raises(ValueError, match="time_step must be the design's signal"):
        RawModelRows(
            rows, "lagrangian", design, fast.history_length, time_step=fast.time_step
        )
    with pytest.raises(ValueError, match="time_step must be finite"):
        RawModelRows(rows, "lagrangian", design, 401, time_step=float("nan"))
    # On the design's grid: the core's raw channels of the ring it reads.
    block = RawModelRows(rows, "lagrangian", design, 401, time_step=1e-3)
    assert block.time_step == 1e-3
    history = np.random.default_rng(3).normal(size=(401, 4))
    context = block.CreateDefaultContext()
    block.get_input_port_history().FixValue(context, history.ravel())
    np.testing.assert_array_equal(
        block.get_output_port_channels().Eval(context),
        raw_channels(design, rows, "lagrangian", history),
    )


def test_solver_blocks_refuse_names_as_a_string_and_fractional_groups():
    """Found by a review: names="abc" built (one letter per parameter) and
    jackknife or row groups of 0.7 were truncated to group 0; a row_noise
    without num_rows was an AttributeError."""
    from drake_dynid.systems.payload import PayloadIdentifier

    for block in (SlidingQRIdentifier, PayloadIdentifier):
        with pytest.raises(TypeError, match="names must be a sequence of 3"):
            block(3, 10, 0.1, names="abc")
        with pytest.raises(ValueError, match="jackknife_groups must hold whole"):
            block(3, 10, 0.1, jackknife_groups=np.full(10, 0.7))
        with pytest.raises(ValueError, match="row_group must hold whole"):
            block(3, 10, 0.1, row_weighting=(np.zeros(10), np.full(10, 1.5)))
        with pytest.raises(TypeError, match=r"row_noise must be a core\.row_noise"):
            block(3, 10, 0.1, row_noise=object())
        block(3, 10, 0.1, names=("a", "b", "c"), jackknife_groups=np.arange(10.0))


def test_a_cloned_bank_context_fed_other_samples_does_not_touch_the_original():
    """The bank's window is a persistent ring whose chunks are shared between
    states (cheap copies): a Context cloned mid-run and fed other samples must
    give the outputs of a fresh run on those samples, and the original those of
    its own samples."""
    rng = np.random.default_rng(8)
    m, p = 1, 2
    bank = modulating.fourier_bank(0.2, H, order=1, ell=[0.0, 1.0, 2.0])
    block = ModulatingIntegralBank(bank, m, p, offset=H / 2)
    first, other = rng.normal(size=(2, 90, modulating.num_channels(m, p)))

    def run(context, samples, start, stop):
        simulator = Simulator(block, context)
        for k in range(start, stop):
            block.get_input_port_channels().FixValue(context, samples[k])
            block.get_input_port_sample_valid().FixValue(context, [1.0])
            simulator.AdvanceTo(k * H + 0.6 * H)

    def outputs(context):
        return [block.GetOutputPort(name).Eval(context).copy() for name in "AB"]

    original = block.CreateDefaultContext()
    run(original, first, 0, 37)
    clone = original.Clone()
    run(original, first, 37, 90)
    run(clone, other, 37, 90)
    for context, samples in (
        (original, first),
        (clone, np.vstack([first[:37], other[37:]])),
    ):
        fresh = block.CreateDefaultContext()
        run(fresh, samples, 0, 90)
        for got, want in zip(outputs(context), outputs(fresh), strict=True):
            np.testing.assert_array_equal(got, want)


def test_the_solver_blocks_name_a_wrong_abstract_input_or_covariance():
    """Found by a review (a Drake user unit-testing single blocks): a
    ChangeTrackingIdentifier whose ``window_state`` was fixed to anything but
    the bank's state failed with "'NoneType' object has no attribute 'count'";
    a ``covariance`` that is not a (design, rows) pair with "cannot unpack" or
    "'NoneType' object has no attribute 'num_rows'"; a ``window_signals`` value
    that is not the SignalWindow's triple with "cannot unpack"."""
    from drake_dynid.core.change import change_design
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.systems.change import ChangeTrackingIdentifier

    h, rows = 1e-3, Planar2RRows(L1=1.0)
    tracked = OnlineSettings(detect_changes=True).for_robot(h, 2, 8)
    r = tracked.bank().num_rows(2)
    block = ChangeTrackingIdentifier(8, r, 0.1, change_design(tracked, h, 2, 8))
    a = np.random.default_rng(1).normal(size=(r, 8))
    context = block.CreateDefaultContext()
    block.get_input_port_A().FixValue(context, a.ravel())
    block.get_input_port_B().FixValue(context, a @ np.arange(1.0, 9.0))
    block.get_input_port_window_valid().FixValue(context, [1.0])
    for wrong in (None, 3, np.zeros(5)):
        block.get_input_port_window_state().FixValue(context, wrong)
        with pytest.raises(TypeError, match="window_state must be the bank's stream"):
            block.EvalUniquePeriodicDiscreteUpdate(context)
    block.get_input_port_window_state().FixValue(context, tracked.bank().init_state(34))
    assert block.EvalUniquePeriodicDiscreteUpdate(context).get_vector(0).size() == 8

    weighted = OnlineSettings(
        weighting="covariance", position_noise=1e-4, torque_noise=0.01
    ).for_robot(h, 2, 8)
    design = weighted.covariance_design(h, 2)
    r = weighted.bank().num_rows(2)
    for wrong, match in (
        (design, "covariance must be a pair"),
        ((None, rows), "covariance design must be a core.row_covariance"),
        ((design, object()), "rows must be a row provider"),
    ):
        with pytest.raises(TypeError, match=match):
            SlidingQRIdentifier(8, r, 1.0, covariance=wrong)
    block = SlidingQRIdentifier(8, r, 1.0, covariance=(design, rows))
    a = np.random.default_rng(2).normal(size=(r, 8))
    context = block.CreateDefaultContext()
    block.get_input_port_A().FixValue(context, a.ravel())
    block.get_input_port_B().FixValue(context, a @ np.arange(1.0, 9.0))
    block.get_input_port_window_valid().FixValue(context, [1.0])
    block.get_input_port_window_signals().FixValue(context, 3)
    with pytest.raises(TypeError, match="window_signals must be a SignalWindow's"):
        block.EvalUniquePeriodicDiscreteUpdate(context)


def test_forced_events_run_one_update_of_every_stateful_block():
    """Found by a review (a Drake user unit-testing single blocks):
    ``ExecuteForcedEvents`` and ``CalcForcedDiscreteVariableUpdate`` left every
    block's state as it was (no forced events declared), and the bank and the
    signal window, whose updates are unrestricted, could only be stepped by a
    Simulator. Now, as Drake's DiscreteDerivative, a forced update is the
    periodic one."""
    from drake_dynid.core.payload import payload_rows
    from drake_dynid.plants import RobotModel, model_path
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator
    from drake_dynid.systems.payload import PayloadIdentifier
    from drake_dynid.systems.signal_window import SignalWindow

    rng = np.random.default_rng(3)

    def fixed(block):
        context = block.CreateDefaultContext()
        for i in range(block.num_input_ports()):
            port = block.get_input_port(i)
            port.FixValue(context, rng.normal(size=port.size()))
        return context

    differentiator = CausalJacobiDifferentiator(2, H, 0.05, kappa=0, mu=0, q=1)
    bank = modulating.fourier_bank(0.5, H, order=1, ell=[0.0, 1.0, 2.0])
    rows = payload_rows(RobotModel.from_urdf(model_path("planar_2r")))
    blocks = (
        differentiator,
        SlidingQRIdentifier(2, 12, 0.1),
        PayloadIdentifier(rows.num_payload, 12, 0.1),
    )
    contexts = [fixed(block) for block in blocks]
    for block, context in zip(blocks, contexts, strict=True):
        if block is not differentiator:  # a window to solve
            block.get_input_port_window_valid().FixValue(context, [1.0])
        periodic = block.EvalUniquePeriodicDiscreteUpdate(context)
        forced = block.AllocateDiscreteVariables()
        block.CalcForcedDiscreteVariableUpdate(context, forced)
        for group in range(periodic.num_groups()):
            np.testing.assert_array_equal(
                forced.get_vector(group).value(), periodic.get_vector(group).value()
            )
        block.ExecuteForcedEvents(context)
        for group in range(periodic.num_groups()):
            np.testing.assert_array_equal(
                context.get_discrete_state(group).get_value(),
                periodic.get_vector(group).value(),
            )
    assert differentiator.get_output_port_history().Eval(contexts[0]).any()

    block = ModulatingIntegralBank(bank, 1, 2)
    context = fixed(block)
    block.get_input_port_sample_valid().FixValue(context, [1.0])
    for _ in range(3):
        block.ExecuteForcedEvents(context)
    assert block.get_output_port_window_state().Eval(context).count == 3
    window = SignalWindow(2, 2, 0.02)
    context = fixed(window)
    assert window.get_output_port_window().Eval(context) is None
    window.ExecuteForcedEvents(context)
    window.ExecuteForcedEvents(context)
    assert window.get_output_port_window().Eval(context)[0].shape == (2, 2)


def test_a_forced_event_on_a_diagram_steps_every_block_once_whatever_its_period():
    """What README Compose says of ExecuteForcedEvents on a whole chain (found
    by helper-79's review; not a bug, undocumented): every block makes its update
    once (the differentiator one sample, the bank one push, though its period is
    20 samples, the identifier one solve), the loggers record one row, and the
    Context's time does not move: not a Simulator's step."""
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_dynid.diagrams import OnlineSettings, add_online_identifier
    from drake_dynid.plants import RobotModel, model_path
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator
    from drake_dynid.systems.modulating_bank import ModulatingIntegralBank

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.array([0.3, -0.2, 1.0, 0.5])))
    settings = OnlineSettings(window=0.5)
    chain = add_online_identifier(
        builder, robot, source.get_output_port(), 1e-3, settings
    )
    assert chain.settings.bank_time_step == pytest.approx(0.02)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    blocks = {type(s): s for s in diagram.GetSystems()}
    bank = blocks[ModulatingIntegralBank]
    differentiator = blocks[CausalJacobiDifferentiator]
    for _ in range(3):
        diagram.ExecuteForcedEvents(context)
    assert context.get_time() == 0.0
    state = bank.get_output_port_window_state().Eval(
        diagram.GetSubsystemContext(bank, context)
    )
    assert state.count == 3  # three bank steps (0.06 s) for three samples
    history = differentiator.get_output_port_history().Eval(
        diagram.GetSubsystemContext(differentiator, context)
    )
    assert history.any()  # its samples taken
    for s in diagram.GetSystems():
        if type(s).__name__ == "VectorLogSink":
            assert s.FindLog(context).num_samples() == 3
