"""The paper's simulated set-up (paper §V) with on-line identifiers in the loop.

A discrete ``MultibodyPlant`` from URDF at 1 kHz, Coulomb friction as an applied
generalized force (``JointFriction``; viscous friction through the URDF damping,
implicit in the plant), a finite-Fourier-series reference tracked by Drake's
``InverseDynamicsController`` (which does not compensate Coulomb friction), seeded
white measurement noise on q and τ at a given SNR (docs/MATH.md §6), and loggers.
The torque fed to identification is the controller's command at t_k, clipped
to the actuators' effort limits as the plant applies it (the plant's
``net_actuation`` with its live output ports; with Drake's default sampled ports
that port lags one sample; docs/CONVENTIONS.md §2). The on-line
identifiers are the chains of :func:`drake_dynid.diagrams.add_online_identifier`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.online import OnlineSettings, OnlineTrace
from drake_dynid.diagrams import add_online_identifiers, advance, chain_trace

__all__ = [
    "SimulationResult",
    "SimulationSettings",
    "reference_noise_std",
    "simulate_identification",
]


#: Most plant steps of one simulated run (duration / time_step), as ``dynid
#: simulate``'s ``experiment_settings.MAX_STEPS``.
MAX_STEPS = 1e7


@dataclass(frozen=True)
class SimulationSettings:
    """Settings of the simulated set-up (paper §V).

    Attributes:
        duration: simulated time [s]; duration / time_step at most
            :data:`MAX_STEPS`.
        time_step: plant and sampling period h [s].
        snr_db: SNR of the white Gaussian noise added to every q and τ channel,
            SNR = 10 log10(var(x)/σ²) with var(x) of the noise-free reference signal
            (q of the reference trajectory, τ of its inverse dynamics); None: no
            noise.
        seed: seed of the noise (``numpy.random.default_rng(seed)``, one standard
            normal draw per sample and channel, scaled by σ).
        kp, kd: position and velocity gains of the inverse-dynamics controller
            [1/s², 1/s].
        coulomb_smoothing: ε of tanh(v/ε) in the simulated Coulomb friction [rad/s]
            (a discrete plant chatters with an exact sign()).
    """

    duration: float = 25.0
    time_step: float = 1e-3
    snr_db: float | None = 30.0
    seed: int = 0
    kp: float = 400.0
    kd: float = 40.0
    coulomb_smoothing: float = 1e-2

    def __post_init__(self):
        owner = "SimulationSettings"
        duration = check.positive(owner, "duration", self.duration, "s")
        h = check.positive(owner, "time_step", self.time_step, "s")
        if duration / h > MAX_STEPS:  # its per-step arrays: 745 GiB for 1e9 s
            check.fail(
                owner,
                f"duration / time_step must be at most {MAX_STEPS:g} simulation "
                f"steps; got {duration:g} s / {h:g} s = {duration / h:.3g}.",
            )
        if self.snr_db is not None:
            check.real(owner, "snr_db", self.snr_db, "dB")
        check.integer(owner, "seed", self.seed, 0)
        check.positive(owner, "kp", self.kp, "1/s²")
        check.positive(owner, "kd", self.kd, "1/s")
        check.real(owner, "coulomb_smoothing", self.coulomb_smoothing, "rad/s")
        if self.coulomb_smoothing < 0:
            check.fail(
                owner,
                "coulomb_smoothing must be >= 0 [rad/s]; got "
                f"{self.coulomb_smoothing}.",
            )


@dataclass
class SimulationResult:
    """Logs of a simulated identification run.

    Attributes:
        t: (N,) sample times [s].
        q: (N, n) measured (noisy) joint positions, the log the identifiers saw.
        tau: (N, n) measured (noisy) joint torques (commands at t_k clipped to
            the actuators' effort limits, as the plant applies them, plus noise).
        q_true: (N, n) noise-free joint positions.
        tau_true: (N, n) noise-free applied torques (the clipped commands).
        noise_std: (2n,) standard deviations of the noise on [q; τ].
        traces: one :class:`OnlineTrace` per identifier.
        joint_names: the joints.
        simulator: the Simulator at the end of the run (for inspection).
        chains: handles to the blocks of each identifier.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    q_true: np.ndarray
    tau_true: np.ndarray
    noise_std: np.ndarray
    traces: list[OnlineTrace]
    joint_names: tuple[str, ...]
    simulator: Any = None
    chains: list[Any] = field(default_factory=list)


def reference_noise_std(
    robot: Any, trajectory: Any, duration: float, snr_db: float | None, time_step: float
) -> np.ndarray:
    """σ of the noise on [q; τ] for an SNR on the noise-free reference signals.

    σ_i = std(x_i)/10^(SNR/20) with x = q of the reference and τ = its inverse
    dynamics (inertial + friction with the robot's base values).
    """
    n = robot.num_joints
    if snr_db is None:
        return np.zeros(2 * n)
    t = np.arange(0.0, duration, time_step)
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    scale = 10.0 ** (-snr_db / 20.0)
    return np.concatenate([q.std(axis=0), tau.std(axis=0)]) * scale


def simulate_identification(
    robot: Any,
    trajectory: Any,
    simulation: SimulationSettings,
    settings: Sequence[OnlineSettings],
    *,
    rows: Any = None,
    events: Sequence[tuple[float, Callable[[Any, Any], None]]] = (),
    progress: bool = False,
) -> SimulationResult:
    """Simulates the paper's set-up and runs on-line identifiers in the loop.

    Args:
        robot: ``RobotModel`` of the simulated robot (its URDF is loaded again as a
            discrete plant, and as the controller's model).
        trajectory: reference with ``evaluate(t) -> (q, v, vdot)`` (e.g. a
            ``FourierTrajectory``); the plant starts on it.
        simulation: set-up settings.
        settings: one entry per on-line identifier.
        rows: row provider for identification (default ``robot.rows_provider()``).
        events: (time, callback(plant, plant_context)) pairs applied when the
            simulation reaches that time [s] (finite, >= 0; one at or after
            ``simulation.duration`` is never reached), e.g. a change of an
            inertial parameter.
        progress: print the progress on stderr.

    Returns:
        The logs and one estimate trace per identifier.
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import (
        Adder,
        Demultiplexer,
        LogVectorOutput,
        Multiplexer,
        TrajectorySource,
    )
    from pydrake.trajectories import PiecewisePolynomial

    from drake_dynid.systems.friction import JointFriction
    from drake_dynid.systems.held_samples import HeldSamples
    from drake_dynid.urdf import load_plant, read_urdf_friction

    h = simulation.time_step
    n = robot.num_joints
    if getattr(trajectory, "num_joints", n) != n:
        check.fail(
            "simulate_identification",
            f"trajectory has {trajectory.num_joints} joints; the robot has {n}.",
        )
    if getattr(robot, "locked", None) or getattr(robot, "mimic", None):
        check.fail(
            "simulate_identification",
            "robot has locked or mimic joints; the simulation drives every movable "
            "joint of its URDF, so load the RobotModel without joints=/locked= (or "
            "simulate with dynid simulate, which takes the full URDF).",
        )
    events = _checked_events(events)  # before anything is built
    rows = robot.rows_provider() if rows is None else rows
    builder = DiagramBuilder()
    plant = builder.AddSystem(load_plant(robot.path, h, gravity=robot.gravity))
    plant.set_name("plant")
    controller_plant = load_plant(robot.path, h, gravity=robot.gravity)

    # Coulomb friction as an applied generalized force (viscous: URDF damping).
    coulomb = read_urdf_friction(robot.path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    friction = builder.AddSystem(
        JointFriction(
            viscous=np.zeros(n),
            coulomb=fc,
            offset=np.zeros(n),
            smoothing=simulation.coulomb_smoothing,
        )
    )
    builder.Connect(plant.get_state_output_port(), friction.get_input_port())
    builder.Connect(
        friction.get_output_port(), plant.get_applied_generalized_force_input_port()
    )

    # Reference: cubic Hermite through the exact trajectory every 10 ms.
    knots = np.arange(0.0, simulation.duration + 0.02, 0.01)
    q_ref, v_ref, _ = trajectory.evaluate(knots)
    reference = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.CubicHermite(knots, q_ref.T, v_ref.T),
            output_derivative_order=2,
        )
    )
    controller, _ = add_tracking_controller(
        builder,
        plant,
        controller_plant,
        reference.get_output_port(),
        kp=simulation.kp,
        kd=simulation.kd,
    )
    # Joint order; clipped to the actuators' effort limits as the plant applies
    # them, so the measured τ is the applied one (a review: a joint limited to
    # 8 N·m logged commands up to 14 000 N·m and gave ZZ1R = 2145 for 3.9, "valid").
    torques = applied_torques(
        builder, plant, controller.get_output_port_generalized_force()
    )
    builder.Connect(
        actuation_of_joint_torques(builder, plant, torques),
        plant.get_actuation_input_port(),
    )

    # Measurement [q; τ] (τ: the applied command at t_k) plus seeded white noise.
    plant_state = builder.AddSystem(Demultiplexer([n, n]))  # [q; v] -> q, v
    builder.Connect(plant.get_state_output_port(), plant_state.get_input_port())
    clean = builder.AddSystem(Multiplexer([n, n]))
    builder.Connect(plant_state.get_output_port(0), clean.get_input_port(0))
    builder.Connect(torques, clean.get_input_port(1))
    noise_std = reference_noise_std(
        robot, trajectory, simulation.duration, simulation.snr_db, h
    )
    # White noise: sample k drawn from numpy.random.default_rng(seed) and held over
    # [t_k - h/2, t_k + h/2), so every block reading it at t_k and the logger see
    # the same value (Drake's RandomSource updates before discrete updates, which
    # would make the log one sample off what the blocks saw). HeldSamples, not a
    # zero-order-hold TrajectorySource: 2 KB per step of a 7-DOF arm's Polynomials.
    steps = round(simulation.duration / h) + 2
    draws = np.random.default_rng(int(simulation.seed)).standard_normal((steps, 2 * n))
    noise = builder.AddSystem(HeldSamples([draws * noise_std], h))
    measured = builder.AddSystem(Adder(2, 2 * n))
    builder.Connect(clean.get_output_port(), measured.get_input_port(0))
    builder.Connect(noise.get_output_port(), measured.get_input_port(1))
    measurement = measured.get_output_port()

    chains = add_online_identifiers(builder, rows, measurement, h, settings)
    measured_log = LogVectorOutput(measurement, builder, h)
    clean_log = LogVectorOutput(clean.get_output_port(), builder, h)

    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, q_ref[0])
    plant.SetVelocities(plant_context, v_ref[0])
    simulator.Initialize()
    t_end = float(simulation.duration)
    for when, callback in events:
        if when < t_end:
            advance(simulator, when, progress, "simulating")
            callback(plant, plant.GetMyMutableContextFromRoot(context))
    advance(simulator, t_end, progress, "simulating")

    measured_data = measured_log.FindLog(context)
    clean_data = clean_log.FindLog(context).data().T
    data = measured_data.data().T
    return SimulationResult(
        t=measured_data.sample_times().copy(),
        q=data[:, :n].copy(),
        tau=data[:, n:].copy(),
        q_true=clean_data[:, :n].copy(),
        tau_true=clean_data[:, n:].copy(),
        noise_std=noise_std,
        traces=[chain_trace(chain, context, h) for chain in chains],
        joint_names=tuple(robot.joint_names),
        simulator=simulator,
        chains=chains,
    )


def _checked_events(
    events: Sequence[tuple[float, Callable[[Any, Any], None]]],
) -> list[tuple[float, Callable[[Any, Any], None]]]:
    """The events sorted by time, each checked: a finite time >= 0 [s], a callable.

    An event at t < 0 asked Drake's Simulator to go back in time, which aborted
    the Python process (a C++ assertion in ``AdvanceTo``); one at NaN was
    silently skipped; a callback that cannot be called failed only when reached.
    """
    owner = "simulate_identification"
    checked = []
    for index, event in enumerate(events):
        if not isinstance(event, (tuple, list)) or len(event) != 2:
            raise TypeError(
                f"{owner}: events[{index}] must be a (time, callback) pair; got "
                f"{event!r:.60}."
            )
        when = check.real(owner, f"events[{index}] time", event[0], "s")
        if when < 0.0:
            check.fail(owner, f"events[{index}] time must be >= 0 [s]; got {when}.")
        if not callable(event[1]):
            raise TypeError(
                f"{owner}: events[{index}] callback must be callable as "
                f"callback(plant, plant_context); got {type(event[1]).__name__}."
            )
        checked.append((when, event[1]))
    return sorted(checked, key=lambda event: event[0])


def applied_torques(builder: Any, plant: Any, torques: Any) -> Any:
    """Joint torques clipped to the plant's actuator effort limits [N·m or N].

    A ``MultibodyPlant`` clamps its actuation to each actuator's effort limit
    (the URDF's ``<limit effort>``); the clipped command is what it applies. A
    ``Saturation`` block when some limit is finite, else ``torques`` itself.
    """
    from pydrake.systems.primitives import Saturation

    effort = np.full(plant.num_velocities(), np.inf)
    for index in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(index)
        effort[actuator.joint().velocity_start()] = actuator.effort_limit()
    if not np.isfinite(effort).any():
        return torques
    saturation = builder.AddSystem(Saturation(-effort, effort))
    builder.Connect(torques, saturation.get_input_port())
    return saturation.get_output_port()


def actuation_of_joint_torques(builder: Any, plant: Any, torques: Any) -> Any:
    """The plant's actuation u = B⁻¹ τ of joint torques τ (generalized-velocity order).

    Drake's actuation input is in actuator order (``JointActuatorIndex``: the
    URDF's transmissions first, in file order), which is the joints' order only
    when B = ``plant.MakeActuationMatrix()`` is the identity (a review found the
    TIAGo's columns shifted: arm_5's transmission comes first). Every joint must
    be actuated once (B square). Returns ``torques`` itself when B = I.
    """
    from pydrake.systems.primitives import MatrixGain

    actuation = np.asarray(plant.MakeActuationMatrix(), dtype=float)
    if actuation.shape[0] == actuation.shape[1] and np.array_equal(
        actuation, np.eye(actuation.shape[0])
    ):
        return torques
    gain = builder.AddSystem(MatrixGain(np.linalg.inv(actuation)))
    builder.Connect(torques, gain.get_input_port())
    return gain.get_output_port()


def add_tracking_controller(
    builder: Any,
    plant: Any,
    controller_plant: Any,
    reference: Any,
    *,
    kp: float,
    kd: float,
    controller_context: Any = None,
) -> tuple[Any, Any]:
    """Adds Drake's ``InverseDynamicsController`` tracking a reference [q; v; v̇].

    ``reference`` is an output port of size 3n (a ``TrajectorySource`` with
    ``output_derivative_order=2``); a ``Demultiplexer`` splits it into the desired
    state [q; v] and the reference acceleration v̇. The control law is
    τ = M(q)(v̇_ref + kp (q_ref - q) + kd (v_ref - v)) + c(q, v) - g(q) of
    ``controller_plant`` (gains [1/s²], [1/s], the same on every joint). The
    controller's state input is wired to ``plant``; its control output is left to
    the caller (feedforward terms may be added before the actuation port).

    Returns:
        ``(controller, desired_state_port)``.
    """
    from pydrake.systems.controllers import InverseDynamicsController
    from pydrake.systems.primitives import Demultiplexer

    n = plant.num_velocities()
    parts = builder.AddSystem(Demultiplexer([2 * n, n]))
    builder.Connect(reference, parts.get_input_port())
    options = (
        {} if controller_context is None else {"plant_context": controller_context}
    )
    controller = builder.AddSystem(
        InverseDynamicsController(
            controller_plant,
            kp=np.full(n, kp),
            ki=np.zeros(n),
            kd=np.full(n, kd),
            has_reference_acceleration=True,
            **options,
        )
    )
    builder.Connect(
        plant.get_state_output_port(), controller.get_input_port_estimated_state()
    )
    builder.Connect(parts.get_output_port(0), controller.get_input_port_desired_state())
    builder.Connect(
        parts.get_output_port(1), controller.get_input_port_desired_acceleration()
    )
    return controller, parts.get_output_port(0)
