"""JointFriction: ports, values, smoothing, a discrete 2R plant that settles."""

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

from drake_dynid.plants import RobotModel, load_plant, model_path
from drake_dynid.systems.friction import JointFriction, joint_friction_force


def test_ports_and_values():
    block = JointFriction([0.3, 0.15], [0.4, 0.25], [0.01, -0.02], smoothing=0.0)
    assert block.num_input_ports() == 1 and block.num_output_ports() == 1
    assert block.get_input_port(0).get_name() == "state"
    assert block.get_input_port(0).size() == 4
    assert block.get_output_port(0).get_name() == "generalized_force"
    assert block.get_output_port(0).size() == 2
    context = block.CreateDefaultContext()
    block.get_input_port(0).FixValue(context, [1.0, 2.0, 0.5, -2.0])
    force = block.get_output_port(0).Eval(context)
    expected = -np.array([0.3 * 0.5 + 0.4 + 0.01, 0.15 * -2.0 - 0.25 - 0.02])
    np.testing.assert_allclose(force, expected, atol=1e-15)


def test_smoothing_is_tanh():
    v = np.array([-1.0, -1e-3, 0.0, 1e-3, 1.0])
    one = np.ones(5)
    smooth = joint_friction_force(v, 0 * one, one, 0 * one, smoothing=1e-2)
    np.testing.assert_allclose(smooth, np.tanh(v / 1e-2), atol=1e-15)
    exact = joint_friction_force(v, 0 * one, one, 0 * one, smoothing=0.0)
    np.testing.assert_array_equal(exact, np.sign(v))


def test_from_model_excludes_viscous_by_default():
    model = RobotModel.from_urdf(model_path("planar_2r"))
    block = JointFriction.from_model(model)
    context = block.CreateDefaultContext()
    block.get_input_port(0).FixValue(context, [0.0, 0.0, 10.0, -10.0])
    np.testing.assert_allclose(
        block.get_output_port(0).Eval(context), [-0.4, 0.25], atol=1e-12
    )
    with_viscous = JointFriction.from_model(model, include_viscous=True)
    context = with_viscous.CreateDefaultContext()
    with_viscous.get_input_port(0).FixValue(context, [0.0, 0.0, 10.0, -10.0])
    np.testing.assert_allclose(
        with_viscous.get_output_port(0).Eval(context), [-3.4, 1.75], atol=1e-12
    )


def test_discrete_2r_with_coulomb_comes_to_rest():
    builder = DiagramBuilder()
    plant = load_plant(model_path("planar_2r"), 1e-3, builder=builder)
    model = RobotModel.from_plant(plant, coulomb={"joint1": 0.4, "joint2": 0.25})
    friction = builder.AddSystem(JointFriction.from_model(model, smoothing=1e-2))
    builder.Connect(plant.get_state_output_port(), friction.get_input_port(0))
    builder.Connect(
        friction.get_output_port(0), plant.get_applied_generalized_force_input_port()
    )
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.get_actuation_input_port().FixValue(plant_context, [0.0, 0.0])
    plant.SetVelocities(plant_context, [0.5, -0.5])
    simulator = Simulator(diagram, context)
    simulator.AdvanceTo(8.0)
    v = plant.GetVelocities(plant_context)
    assert np.all(np.abs(v) < 1e-6)  # settled, no sign() limit cycle


def test_errors():
    with pytest.raises(ValueError, match=r"viscous must have shape \(2\)"):
        JointFriction([0.1], [0.1, 0.2])
    with pytest.raises(ValueError, match="coulomb must be >= 0"):
        JointFriction([0.1], [-0.1])
    with pytest.raises(ValueError, match="smoothing must be >= 0"):
        JointFriction([0.1], [0.1], smoothing=-1.0)
    with pytest.raises(ValueError, match="at least one joint"):
        JointFriction([], [])


@pytest.mark.parametrize("smoothing", [0.0, 1e-2])
def test_block_equals_the_core_function(smoothing):
    rng = np.random.default_rng(8)
    viscous, coulomb, offset = rng.uniform(0, 1, (3, 3))
    block = JointFriction(viscous, coulomb, offset, smoothing=smoothing)
    context = block.CreateDefaultContext()
    for v in (rng.normal(size=3), np.array([0.0, 1e-3, -1e-3])):
        block.get_input_port(0).FixValue(context, np.concatenate([np.zeros(3), v]))
        np.testing.assert_allclose(
            block.get_output_port(0).Eval(context),
            -joint_friction_force(v, viscous, coulomb, offset, smoothing),
            rtol=1e-14,
            atol=1e-15,
        )


def test_a_single_number_for_every_joint_is_named_as_such():
    """Found by a review: "coulomb must have shape (any); got ()"."""
    from drake_dynid.systems.friction import JointFriction
    from drake_dynid.systems.signal_window import SignalWindow

    with pytest.raises(ValueError, match=r"coulomb must have shape \(N,\), a 1-D"):
        JointFriction(0.1, 0.2)
    with pytest.raises(ValueError, match="SignalWindow: num_samples must be >= 1"):
        SignalWindow(2, 0, 0.02)
