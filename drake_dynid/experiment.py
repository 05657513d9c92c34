"""Rehearse an identification experiment: simulate a robot log from a trajectory.

The arm of a URDF in Drake, tracking a reference trajectory (``dynid simulate``)::

    reference (cubic Hermite through the trajectory's q, v samples)
        ──► InverseDynamicsController (kp, kd; its plant has the damping and the
            reflected inertia below)
              + DriveFeedforward: FC·tanh(v_ref/ε) + OFF (+ coupled motors)
        ──► discrete MultibodyPlant (1 kHz; joint damping FV; actuator rotor
            inertia IA)
              ◄── DriveForces (Coulomb -FC·tanh(v/ε) - OFF, applied force; the
                  coupled motors of a drive file; the midpoint step below)

with the friction and motor values of the true model
(``drake_dynid.experiment_drive``: the URDF's ``<dynamics>``, and with a drive
file the motors' reflected inertia and friction, docs/DRIVE.md §6c),
logged at every step as (q_k, τ_k), τ_k the command at t_k (docs/CONVENTIONS.md
§2) clipped to the URDF's effort limits as the plant applies it, decimated to the
log rate, with seeded white noise added afterwards (the controller sees the true
state, as a robot with fine encoders). ``DriveForces`` makes every step the
midpoint step: the velocity terms (Coriolis, damping, Coulomb friction) at
v̄_k = (q_{k+1} - q_{k-1})/2h, so that a noise-free log is the model's inverse
dynamics at the central differences of its positions to round-off, as every
identification path evaluates it (Drake's own step is O(h) off:
``core.drive_dynamics.midpoint_step_force``), and a light joint's Coulomb
friction, implicit, no longer chatters.

The run is watched at every step and stops with a ``ValueError`` naming the
joint, the time and the limit when the motion leaves the position limits, the
state becomes non-finite, a command exceeds ``effort_factor`` (10) times the
effort limit, or the tracking error exceeds ``max_tracking_error``: a diverging
simulation never produces a log.

Memory: the Simulator advances :data:`CHUNK_SECONDS` at a time; after each
chunk the loggers hand over the rows the log keeps (positions and commands at
the log rate) and are cleared, and the reference source holds the cubic Hermite
pieces of that chunk only (Drake's ``PiecewisePolynomial`` takes about 4 KB per
knot of a 7-DOF trajectory: 250 MB for 10 minutes at 100 Hz). Each Hermite piece
depends only on its two knots, so the chunks give the same log bit for bit
(tests/test_simulate.py).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.joint_limits import JointLimits
from drake_dynid.core.noise import noise_std_for_snr
from drake_dynid.experiment_settings import (
    MAX_STEPS,
    MIN_LOG_SAMPLES,
    ExperimentLog,
    ExperimentSettings,
)

__all__ = [
    "MIN_LOG_SAMPLES",
    "ExperimentLog",
    "ExperimentSettings",
    "simulate_experiment",
]

#: Simulated time between the loggers' hand-overs [s] (module docstring).
CHUNK_SECONDS = 10.0


def _sample_checks(reference: Any, settings: ExperimentSettings, duration: float):
    """Enough log samples for an identification; position noise below the motion."""
    owner = "simulate_experiment"
    decimation, h = settings.decimation, settings.time_step
    samples = round(duration / h) // decimation + 1
    if samples < settings.min_samples:
        shortest = (settings.min_samples - 1) * decimation * h
        count = f"{samples} sample{'s' if samples != 1 else ''}"
        given = (
            f"got duration {duration:g} ({count})"
            if settings.duration is not None
            else f"the trajectory lasts {duration:g} s ({count}): give a longer one "
            "or a higher rate"
        )
        check.fail(
            owner,
            f"the log must have at least {settings.min_samples} samples (fewer "
            "cannot be identified: the off-line fit's automatic cutoff needs 16, "
            "the least squares more torque equations than base parameters): at "
            f"rate {settings.rate:g} Hz that is duration >= {shortest:g} [s]; "
            f"{given}.",
        )
    if settings.snr_db is None and settings.noise_q > 0.0:
        keep = reference.t - reference.t[0] <= duration + 1e-9
        motion = float(np.max(np.std(reference.q[keep], axis=0)))
        if settings.noise_q >= motion:
            check.fail(
                owner,
                "noise_q must be below the motion it is added to: the largest std "
                f"of a joint's reference position is {motion:.3g} [rad or m]; got "
                f"{settings.noise_q:g}.",
            )


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


def simulate_experiment(
    urdf: str,
    reference: Any,
    limits: JointLimits,
    settings: ExperimentSettings | None = None,
    *,
    gravity: Any = None,
    drive: Any = None,
    locked: Mapping[str, float] | None = None,
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
        drive: the robot's joint friction and drive chain as simulated, a
            ``drake_dynid.core.drive_dynamics.SimulatedDrive`` of the limits'
            joints (``experiment_drive.simulated_drive_of(truth_model(...))``);
            default the URDF's friction of ``settings.friction``, without motors.
        locked: ``{joint: position [rad or m]}`` of the URDF's joints that are not
            simulated: each is a weld at that position (a mimic joint of a locked
            leader follows it; ``urdf.load_urdf``), as ``RobotModel(joints=,
            locked=)`` models them (``RobotModel.locked``). The reference, the
            limits and the drive are then the other joints'.

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

    from drake_dynid.core.drive_dynamics import SimulatedDrive
    from drake_dynid.experiment_drive import (
        add_drive_forces,
        configure_plant,
        implicit_damping_context,
        simulated_drive_of,
        truth_model,
    )
    from drake_dynid.simulation import (
        actuation_of_joint_torques,
        add_tracking_controller,
    )
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
    if drive is not None:
        check.instance(
            owner, "drive", drive, SimulatedDrive, "a SimulatedDrive (or None)"
        )
        if drive.joint_names != names:
            check.fail(owner, "the drive's joints must be the limits' joints.")
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
    _sample_checks(reference, settings, duration)
    _reference_checks(reference, limits, duration)
    if drive is None:
        model = truth_model(
            urdf, settings.friction, gravity=gravity, joints=names, locked=locked
        )
        drive = simulated_drive_of(model, settings.coulomb_smoothing)

    builder = DiagramBuilder()
    plant = builder.AddSystem(load_plant(urdf, h, gravity=gravity, locked=locked))
    controller_plant = load_plant(urdf, h, gravity=gravity, locked=locked)
    simulated = tuple(a.joint().name() for a in _actuators(plant))
    if simulated != names or plant.num_velocities() != n:
        passive = sorted(
            plant.get_joint(i).name()
            for i in plant.GetJointIndices()
            if plant.get_joint(i).num_velocities() == 1
            and plant.get_joint(i).name() not in simulated
        )
        from drake_dynid.urdf import read_urdf_mimic

        # A mimic joint with a <transmission> is actuated (Drake gives it an
        # actuator) but follows its leader in the model: say so, as for a passive one.
        mimic = sorted(set(simulated) & set(read_urdf_mimic(urdf)))
        check.fail(
            owner,
            f"the simulated joints must be the reference's {n} joints "
            f"({check.listed(names)}), each actuated; the plant's actuated joints are "
            f"{check.listed(simulated) or 'none'}"
            + (
                f" and {check.listed(passive)} move unactuated (a mimic joint, which "
                "the simulator does not couple to its leader: lock the leader, "
                "or simulate without it)"
                if passive
                else ""
            )
            + (
                f"; {check.listed(mimic)}: a <mimic> joint with a <transmission>, "
                "which "
                "the simulator does not couple to its leader: lock the leader "
                "(--lock), or remove the <mimic> from the URDF"
                if mimic
                else ""
            )
            + ".",
        )
    controller_context = controller_plant.CreateDefaultContext()
    configure_plant(controller_plant, controller_context, drive)
    t_ref = np.asarray(reference.t - reference.t[0], dtype=float)
    q_ref, v_ref = np.asarray(reference.q), np.asarray(reference.v)

    def piece(start: float, stop: float) -> Any:
        """The reference's cubic Hermite over [start, stop] (and a knot more)."""
        a = max(0, int(np.searchsorted(t_ref, start, "right")) - 2)
        b = min(t_ref.size, int(np.searchsorted(t_ref, stop, "left")) + 2)
        return PiecewisePolynomial.CubicHermite(t_ref[a:b], q_ref[a:b].T, v_ref[a:b].T)

    chunk = max(1, round(CHUNK_SECONDS / h))  # steps per chunk
    source = builder.AddSystem(
        TrajectorySource(
            piece(0.0, min(chunk * h, t_ref[-1])), output_derivative_order=2
        )
    )
    controller, _ = add_tracking_controller(
        builder,
        plant,
        controller_plant,
        source.get_output_port(),
        kp=settings.kp,
        kd=settings.kd,
        controller_context=implicit_damping_context(
            controller_plant, controller_context, h
        ),
    )
    control = add_drive_forces(
        builder,
        plant,
        controller_plant,
        controller_context,
        source.get_output_port(),
        controller.get_output_port_generalized_force(),  # joint order
        drive,
        kp=settings.kp,
        kd=settings.kd,
    )
    builder.Connect(
        actuation_of_joint_torques(builder, plant, control),
        plant.get_actuation_input_port(),
    )
    state_log = LogVectorOutput(plant.get_state_output_port(), builder, h)
    command_log = LogVectorOutput(control, builder, h)
    diagram = builder.Build()

    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    configure_plant(plant, plant_context, drive)
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
                    "the trajectory: lower its speed)"
                )
        if failure:
            return EventStatus.ReachedTermination(diagram, failure[0])
        return EventStatus.Succeeded()

    simulator.set_monitor(monitor)
    steps = round(duration / h)
    # The loggers' rows at the log rate (sample k kept when k % decimation = 0),
    # handed over and cleared after every chunk (module docstring).
    kept: dict[str, list[np.ndarray]] = {"q": [], "command": []}
    logged = {"q": 0, "command": 0}

    def hand_over() -> None:
        for key, logger, width in (("q", state_log, n), ("command", command_log, n)):
            log = logger.FindMutableLog(context)
            data = log.data()
            first = (-logged[key]) % settings.decimation
            kept[key].append(np.array(data[:width, first :: settings.decimation].T))
            logged[key] += data.shape[1]
            log.Clear()

    done = 0
    try:
        while True:
            stop = min(steps, done + chunk)
            if done:  # the first piece is in the source already
                source.UpdateTrajectory(piece(done * h, stop * h))
            simulator.AdvanceTo(stop * h)
            hand_over()
            done = stop
            if done >= steps or failure:  # the monitor stopped the run
                break
    except RuntimeError as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else ""
        raise ValueError(
            f"{owner}: the simulation diverged at t = {context.get_time():.3f} s "
            f"(Drake: {first})."
        ) from None
    if failure:
        raise ValueError(f"{owner}: {failure[0]}.")

    count = min(logged["q"], logged["command"], steps + 1)
    keep = np.arange(0, count, settings.decimation)
    state = np.concatenate(kept["q"])[: keep.size]
    command = np.concatenate(kept["command"])[: keep.size]
    urdf_effort = np.array([a.effort_limit() for a in _actuators(plant)])
    applied = np.clip(command, -urdf_effort, urdf_effort)
    saturated = int(np.count_nonzero(np.any(applied != command, axis=1)))
    q_true, tau_true = state, applied
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


def _actuators(plant: Any) -> list[Any]:
    """The plant's joint actuators in generalized-velocity order of their joints."""
    actuators = [plant.get_joint_actuator(i) for i in plant.GetJointActuatorIndices()]
    actuators.sort(key=lambda a: a.joint().velocity_start())
    return actuators


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
