"""Rehearse an identification experiment: simulate a robot log from a trajectory.

The arm of a URDF in Drake, tracking a reference trajectory (``dynid simulate``)::

    reference (cubic Hermite through the trajectory's q, v samples)
        ──► InverseDynamicsController (kp, kd; compensates the URDF damping)
              + Coulomb feedforward FC·tanh(v_ref/ε)
        ──► discrete MultibodyPlant (1 kHz, URDF damping = viscous friction)
              ◄── JointFriction (Coulomb -FC·tanh(v/ε), applied force)

logged at every step as (q_k, τ_k), τ_k the command at t_k (docs/CONVENTIONS.md
§2) clipped to the URDF's effort limits as the plant applies it, decimated to the
log rate, with seeded white noise added afterwards (the controller sees the true
state, as a robot with fine encoders).

The run is watched at every step and stops with a ``ValueError`` naming the
joint, the time and the limit when the motion leaves the position limits, the
state becomes non-finite, a command exceeds ``effort_factor`` (10) times the
effort limit, or the tracking error exceeds ``max_tracking_error``: a diverging
simulation never produces a log.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.joint_limits import JointLimits
from drake_dynid.core.noise import noise_std_for_snr

__all__ = ["ExperimentLog", "ExperimentSettings", "simulate_experiment"]

FRICTION_KINDS = ("viscous", "coulomb", "offset")


#: Most plant steps of one simulated experiment (duration / time_step).
MAX_STEPS = 1e7


@dataclass(frozen=True)
class ExperimentSettings:
    """Settings of a simulated experiment.

    Attributes:
        friction: friction simulated, among "viscous" (URDF damping, else set to 0)
            and "coulomb" (URDF ``friction``, else none); "offset" is accepted and
            simulated as 0 (the URDF has none).
        noise_q: std of the white noise on q [rad or m] (ignored with snr_db).
        noise_tau: std of the noise on τ_j as a fraction of std(τ_j) (ignored with
            snr_db).
        snr_db: SNR on every q and τ channel, SNR = 10 log10(var(x)/σ²) (None: use
            noise_q and noise_tau).
        rate: log rate [Hz]; 1/(rate·time_step) must be an integer.
        seed: seed of the noise (``numpy.random.default_rng(seed)``).
        duration: simulated time [s] (None: the trajectory's).
        time_step: plant period h [s].
        kp, kd: controller gains [1/s², 1/s] (ω = 50 rad/s, critically damped:
            stiff enough for light wrists whose damping time constant J/d is
            below the 1 ms step).
        coulomb_smoothing: ε of tanh(v/ε) [rad/s].
        max_tracking_error: largest |q - q_ref| before the run is stopped [rad or m].
        effort_factor: a command beyond this times the effort limit is a divergence.
    """

    friction: tuple[str, ...] = ("viscous", "coulomb")
    noise_q: float = 1e-4
    noise_tau: float = 0.01
    snr_db: float | None = None
    rate: float = 1000.0
    seed: int = 0
    duration: float | None = None
    time_step: float = 1e-3
    kp: float = 2500.0
    kd: float = 100.0
    coulomb_smoothing: float = 1e-2
    max_tracking_error: float = 0.1
    effort_factor: float = 10.0

    def __post_init__(self) -> None:
        owner = "ExperimentSettings"
        unknown = [kind for kind in self.friction if kind not in FRICTION_KINDS]
        if unknown:
            check.fail(
                owner,
                f"friction kinds must be among {', '.join(FRICTION_KINDS)}; got "
                f"{', '.join(unknown)}.",
            )
        for name, top in (("noise_q", 1e99), ("noise_tau", 1e6)):
            if not 0.0 <= check.real(owner, name, getattr(self, name)) <= top:
                check.fail(
                    owner, f"{name} must be in [0, {top:g}]; got {getattr(self, name)}."
                )
        if self.snr_db is not None:
            check.in_range(owner, "snr_db", self.snr_db, -100.0, 400.0, "dB")
        check.positive(owner, "rate", self.rate, "Hz")
        check.integer(owner, "seed", self.seed, minimum=0)
        if self.duration is not None:
            check.positive(owner, "duration", self.duration, "s")
        h = check.positive(owner, "time_step", self.time_step, "s")
        ratio = 1.0 / (self.rate * h)
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            check.fail(
                owner,
                f"rate must divide 1/time_step = {1.0 / h:g} Hz [Hz] (the log is "
                f"decimated from the simulation); got {self.rate:g}.",
            )
        check.positive(owner, "kp", self.kp, "1/s²")
        check.positive(owner, "kd", self.kd, "1/s")
        check.positive(owner, "coulomb_smoothing", self.coulomb_smoothing, "rad/s")
        check.positive(owner, "max_tracking_error", self.max_tracking_error, "rad")
        check.greater_than(owner, "effort_factor", self.effort_factor, 1.0)

    @property
    def decimation(self) -> int:
        """Simulation steps per log sample."""
        return round(1.0 / (self.rate * self.time_step))


@dataclass(frozen=True, eq=False)
class ExperimentLog:
    """A simulated robot log.

    Attributes:
        t: (N,) sample times [s] from 0.
        q, tau: (N, n) measured (noisy) positions and torques.
        q_true, tau_true: (N, n) noise-free ones (τ: the applied torque).
        noise_std: (2n,) std of the noise added to [q; τ].
        joint_names: the n joints.
        max_tracking_error: (n,) largest |q - q_ref| per joint [rad or m].
        saturated: samples whose command exceeded the URDF effort limit (clipped).
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    q_true: np.ndarray
    tau_true: np.ndarray
    noise_std: np.ndarray
    joint_names: tuple[str, ...]
    max_tracking_error: np.ndarray
    saturated: int


def _reference_checks(reference: Any, limits: JointLimits, duration: float) -> None:
    """The reference itself must stay inside the position limits."""
    keep = reference.t - reference.t[0] <= duration + 1e-9
    q = reference.q[keep]
    for j, name in enumerate(limits.joint_names):
        unit = limits.units(j)[0]
        for bound, side in ((limits.lower[j], -1.0), (limits.upper[j], 1.0)):
            excess = side * (q[:, j] - bound)
            k = int(np.argmax(excess))
            if np.isfinite(bound) and excess[k] > 0.0:
                check.fail(
                    "simulate_experiment",
                    f"the trajectory leaves the position limits: joint {name} "
                    f"reaches {q[k, j]:.4g} {unit} at t = "
                    f"{reference.t[keep][k] - reference.t[0]:.3f} s (limit "
                    f"{bound:.4g} {unit}).",
                )


def _set_friction(plant: Any, context: Any, names, keep_viscous: bool) -> None:
    if keep_viscous:
        return
    for name in names:
        plant.GetJointByName(name).SetDamping(context, 0.0)


def simulate_experiment(
    urdf: str,
    reference: Any,
    limits: JointLimits,
    settings: ExperimentSettings | None = None,
    *,
    gravity: Any = None,
) -> ExperimentLog:
    """Simulates the arm tracking ``reference``; returns the log (module docstring).

    Args:
        urdf: the robot's URDF.
        reference: a ``drake_dynid.trajectory_file.SampledTrajectory`` whose joints
            are the URDF's (in generalized-velocity order); t is shifted to start
            at 0.
        limits: the limits the run is checked against (position, effort).
        settings: the experiment (default ``ExperimentSettings()``).
        gravity: gravity vector [m/s²] (default Drake's).

    Returns:
        The :class:`ExperimentLog`.

    Raises:
        ValueError: bad settings, a reference outside the position limits or
            shorter than the duration, or a run that leaves the limits or diverges
            (the message names the joint, the time and the limit).
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder, EventStatus
    from pydrake.systems.primitives import LogVectorOutput, TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    from drake_dynid.simulation import add_tracking_controller
    from drake_dynid.urdf import load_plant

    owner = "simulate_experiment"
    check.having(
        owner, "reference", reference, ("t", "q", "joint_names"), "a SampledTrajectory"
    )
    check.instance(owner, "limits", limits, JointLimits, "a JointLimits (joint_limits)")
    settings = ExperimentSettings() if settings is None else settings
    check.instance(
        owner, "settings", settings, ExperimentSettings, "ExperimentSettings"
    )
    names = tuple(limits.joint_names)
    if tuple(reference.joint_names) != names:
        check.fail(owner, "the reference's joints must be the limits' joints.")
    n, h = len(names), settings.time_step
    available = float(reference.t[-1] - reference.t[0])
    duration = available if settings.duration is None else settings.duration
    if duration > available + 1e-9:
        check.fail(
            owner,
            f"duration must be <= the trajectory's {available:g} s [s]; got "
            f"{duration:g}.",
        )
    steps = duration / h
    if steps > MAX_STEPS:
        check.fail(
            owner,
            f"duration / time_step must be at most {MAX_STEPS:g} simulation steps; got "
            f"{duration:g} s / {h:g} s = {steps:.3g}.",
        )
    _reference_checks(reference, limits, duration)

    builder = DiagramBuilder()
    plant = builder.AddSystem(load_plant(urdf, h, gravity=gravity))
    controller_plant = load_plant(urdf, h, gravity=gravity)
    if plant.num_velocities() != n or plant.num_actuators() != n:
        check.fail(
            owner,
            f"every one of the {n} joints must be actuated; the URDF has "
            f"{plant.num_actuators()} actuators.",
        )
    controller_context = controller_plant.CreateDefaultContext()
    _set_friction(
        controller_plant, controller_context, names, "viscous" in settings.friction
    )
    t_ref = reference.t - reference.t[0]
    source = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.CubicHermite(t_ref, reference.q.T, reference.v.T),
            output_derivative_order=2,
        )
    )
    controller, desired_state = add_tracking_controller(
        builder,
        plant,
        controller_plant,
        source.get_output_port(),
        kp=settings.kp,
        kd=settings.kd,
        controller_context=controller_context,
    )
    control = controller.get_output_port_control()
    if "coulomb" in settings.friction:
        control = _add_coulomb(
            builder,
            plant,
            desired_state,
            control,
            urdf,
            names,
            settings.coulomb_smoothing,
        )
    builder.Connect(control, plant.get_actuation_input_port())
    state_log = LogVectorOutput(plant.get_state_output_port(), builder, h)
    command_log = LogVectorOutput(control, builder, h)
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    _set_friction(plant, plant_context, names, "viscous" in settings.friction)
    plant.SetPositions(plant_context, reference.q[0])
    plant.SetVelocities(plant_context, reference.v[0])
    source_context = source.GetMyContextFromRoot(context)
    effort_cap = settings.effort_factor * limits.effort
    failure: list[str] = []
    worst = np.zeros(n)

    def monitor(root: Any) -> Any:
        t = root.get_time()
        x = plant.GetPositionsAndVelocities(plant_context)
        q = x[:n]
        if not np.all(np.isfinite(x)):
            failure.append(
                f"the simulation diverged: non-finite state at t = {t:.3f} s"
            )
        else:
            failure.extend(_step_failures(t, q, limits, names))
            command = control.Eval(control.get_system().GetMyContextFromRoot(root))
            over = np.abs(command) > effort_cap
            if np.any(over):
                j = int(np.argmax(np.abs(command) / effort_cap))
                failure.append(
                    f"the simulation diverged: joint {names[j]} was commanded "
                    f"{command[j]:.4g} {limits.units(j)[3]} at t = {t:.3f} s, more "
                    f"than {settings.effort_factor:g}× its effort limit "
                    f"{limits.effort[j]:.4g} {limits.units(j)[3]}"
                )
            error = np.abs(q - source.get_output_port().Eval(source_context)[:n])
            np.maximum(worst, error, out=worst)
            if np.any(error > settings.max_tracking_error):
                j = int(np.argmax(error))
                failure.append(
                    f"the tracking error of joint {names[j]} reached {error[j]:.4g} "
                    f"{limits.units(j)[0]} at t = {t:.3f} s (threshold "
                    f"{settings.max_tracking_error:g}; the controller cannot follow "
                    "the trajectory: lower its speed or raise the gains)"
                )
        if failure:
            return EventStatus.ReachedTermination(diagram, failure[0])
        return EventStatus.Succeeded()

    simulator.set_monitor(monitor)
    steps = round(duration / h)
    try:
        simulator.AdvanceTo(steps * h)
    except RuntimeError as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else ""
        raise ValueError(
            f"{owner}: the simulation diverged at t = {context.get_time():.3f} s "
            f"(Drake: {first})."
        ) from None
    if failure:
        raise ValueError(f"{owner}: {failure[0]}.")

    state = state_log.FindLog(context).data().T
    command = command_log.FindLog(context).data().T
    count = min(state.shape[0], command.shape[0], steps + 1)
    keep = np.arange(0, count, settings.decimation)
    urdf_effort = np.array(
        [plant.GetJointActuatorByName(a).effort_limit() for a in _actuators(plant)]
    )
    applied = np.clip(command[keep], -urdf_effort, urdf_effort)
    saturated = int(np.count_nonzero(np.any(applied != command[keep], axis=1)))
    q_true, tau_true = state[keep, :n], applied
    noise_std = _noise_std(q_true, tau_true, settings)
    draws = np.random.default_rng(settings.seed).standard_normal((keep.size, 2 * n))
    return ExperimentLog(
        t=keep * h,
        q=q_true + draws[:, :n] * noise_std[:n],
        tau=tau_true + draws[:, n:] * noise_std[n:],
        q_true=q_true,
        tau_true=tau_true,
        noise_std=noise_std,
        joint_names=names,
        max_tracking_error=worst,
        saturated=saturated,
    )


def _add_coulomb(builder, plant, desired_state, control, urdf, names, smoothing):
    """Coulomb friction on the plant, and its feedforward added to the command.

    The plant gets -FC·tanh(v/ε) (``JointFriction``); the command gets
    +FC·tanh(v_ref/ε) from the desired velocity, as a robot controller compensates
    its friction model (without it a light wrist lags by FC/(J·kp)). Returns the
    output port of the total command.
    """
    from pydrake.systems.primitives import Adder, Gain

    from drake_dynid.systems.friction import JointFriction
    from drake_dynid.urdf import read_urdf_friction

    n = len(names)
    values = read_urdf_friction(urdf)
    coulomb = np.array([values.get(name, 0.0) for name in names])
    blocks = []
    for state in (plant.get_state_output_port(), desired_state):
        friction = builder.AddSystem(
            JointFriction(
                viscous=np.zeros(n),
                coulomb=coulomb,
                offset=np.zeros(n),
                smoothing=smoothing,
            )
        )
        builder.Connect(state, friction.get_input_port())
        blocks.append(friction)
    builder.Connect(
        blocks[0].get_output_port(), plant.get_applied_generalized_force_input_port()
    )
    feedforward = builder.AddSystem(Gain(-1.0, n))
    builder.Connect(blocks[1].get_output_port(), feedforward.get_input_port())
    total = builder.AddSystem(Adder(2, n))
    builder.Connect(control, total.get_input_port(0))
    builder.Connect(feedforward.get_output_port(), total.get_input_port(1))
    return total.get_output_port()


def _actuators(plant: Any) -> list[str]:
    """Actuator names in generalized-velocity order of their joints."""
    from pydrake.multibody.tree import JointActuatorIndex

    actuators = [
        plant.get_joint_actuator(JointActuatorIndex(i))
        for i in range(plant.num_actuators())
    ]
    actuators.sort(key=lambda a: a.joint().velocity_start())
    return [a.name() for a in actuators]


def _step_failures(t: float, q: np.ndarray, limits: JointLimits, names) -> list[str]:
    out = []
    for j in np.flatnonzero((q < limits.lower) | (q > limits.upper)):
        bound = limits.lower[j] if q[j] < limits.lower[j] else limits.upper[j]
        unit = limits.units(int(j))[0]
        out.append(
            f"the motion left the position limits: joint {names[j]} reached "
            f"{q[j]:.4g} {unit} at t = {t:.3f} s (limit {bound:.4g} {unit})"
        )
    return out


def _noise_std(q: np.ndarray, tau: np.ndarray, settings: ExperimentSettings):
    """σ of the noise on [q; τ]: from the SNR, or noise_q and noise_tau·std(τ).

    Raises:
        ValueError: a σ that is not finite or exceeds the largest log value the
            identification accepts (``core._validate.MAX_LOG_MAGNITUDE``).
    """
    if settings.snr_db is not None:
        with np.errstate(over="ignore"):
            out = np.concatenate(
                [
                    noise_std_for_snr(q, settings.snr_db),
                    noise_std_for_snr(tau, settings.snr_db),
                ]
            )
    else:
        n = q.shape[1]
        out = np.concatenate(
            [np.full(n, settings.noise_q), settings.noise_tau * np.std(tau, axis=0)]
        )
    top = float(np.max(out, initial=0.0))
    if not top <= check.MAX_LOG_MAGNITUDE / 10.0:
        source = (
            f"snr_db {settings.snr_db:g}"
            if settings.snr_db is not None
            else f"noise_q {settings.noise_q:g} and noise_tau {settings.noise_tau:g}"
        )
        check.fail(
            "simulate_experiment",
            f"the noise std must be <= {check.MAX_LOG_MAGNITUDE / 10.0:g} (a log the "
            f"identification can read); {source} give {top:.3g}.",
        )
    return out
