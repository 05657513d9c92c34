"""The simulated robot of ``dynid simulate``: its true model and the plant set-up.

The simulation and the truth file come from one :class:`~drake_dynid.robot.
RobotModel` (:func:`truth_model`): the URDF's links, its joint friction
(``<dynamics damping friction>``) and, with a drive file (docs/DRIVE.md), the
motors' reflected rotor inertia and friction. :func:`simulated_drive_of` reads the
values the plant needs from that model's standard table (so the simulated robot
is the truth, column by column), and :func:`configure_plant` and
:func:`add_drive_forces` give them to the Drake diagram::

    IAj  -> the joint's actuator (rotor inertia IAj, gear ratio 1): Drake adds it
            to the mass matrix
    FVj  -> the joint's damping (implicit in the discrete step)
    FCj, OFFj, coupled motors' Fc, off -> DriveForces (applied force, tanh law)
    coupled motors' Ia, Fv (K, B: off-diagonal) -> DriveForces (exact, through
            the plant's step; docs/DRIVE.md §6c)

and the controller gets the same parameters (its plant) plus ``DriveFeedforward``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from drake_dynid.core.drive_columns import motor_columns
from drake_dynid.core.drive_dynamics import SimulatedDrive, simulated_drive
from drake_dynid.core.friction import TanhSign

__all__ = [
    "add_drive_forces",
    "configure_plant",
    "implicit_damping_context",
    "simulated_drive_of",
    "truth_model",
]


def truth_model(
    urdf: str,
    friction: tuple[str, ...],
    *,
    drive: Any = None,
    gravity: Any = None,
    joints: Sequence[str] | None = None,
    locked: Mapping[str, float] | None = None,
) -> Any:
    """The ``RobotModel`` a simulation of ``urdf`` (and ``drive``) reproduces.

    With rotor inertia columns (``IAj``, ``IAmk``) when any of them is non-zero
    (a drive file's ``rotor_inertia``, or the URDF's ``drake:rotor_inertia``),
    without them otherwise.

    Args:
        urdf: the URDF.
        friction: the friction kinds simulated (``ExperimentSettings.friction``).
        drive: a drive file or ``DriveChain`` (None: none).
        gravity: gravity [m/s²] (default Drake's).
        joints: the simulated joints (``RobotModel.from_urdf``'s; default every
            movable joint that is not a mimic).
        locked: the other joints' positions [rad or m] (``RobotModel.from_urdf``'s;
            default 0).
    """
    from drake_dynid.robot import RobotModel

    options = {
        "friction": friction,
        "drive": drive,
        "gravity": gravity,
        "joints": None if joints is None else tuple(joints),
        "locked": None if locked is None else dict(locked),
    }
    robot = RobotModel.from_urdf(urdf, rotor_inertia=True, **options)
    inertia = [
        value
        for name, value in zip(robot.standard_names, robot.standard_values, strict=True)
        if name.startswith("IA")
    ]
    if not np.any(inertia):
        robot = RobotModel.from_urdf(urdf, rotor_inertia=False, **options)
    return robot


def simulated_drive_of(robot: Any, smoothing: float) -> SimulatedDrive:
    """The plant's share of ``robot``'s friction and drive chain.

    Args:
        robot: the :func:`truth_model`.
        smoothing: ε of the simulated Coulomb law tanh(v/ε) [rad/s or m/s].
    """
    sign = TanhSign(float(smoothing))
    motors = None
    chain = robot.drive
    if chain is not None and chain.coupled_motors:
        motors = motor_columns(
            chain, inertia=robot.rotor_inertia, friction=robot.friction, sign=sign
        )
    return simulated_drive(
        robot.standard_names, robot.standard_values, robot.joint_names, motors, sign
    )


def configure_plant(plant: Any, context: Any, drive: SimulatedDrive) -> None:
    """Sets the plant's joint damping (FVj) and reflected inertia (IAj) in context.

    The reflected inertia goes to each joint's actuator as rotor inertia IAj with
    gear ratio 1 (Drake adds ρ² I_r to the mass matrix); without ``IAj`` columns
    (``drive.rotor_inertia`` None) the URDF's actuators are left unchanged.
    """
    for j, name in enumerate(drive.joint_names):
        plant.GetJointByName(name).SetDamping(context, float(drive.viscous[j]))
    if drive.rotor_inertia is None:
        return
    index = {name: j for j, name in enumerate(drive.joint_names)}
    for i in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(i)
        joint = index.get(actuator.joint().name())
        if joint is not None:
            actuator.SetRotorInertia(context, float(drive.rotor_inertia[joint]))
            actuator.SetGearRatio(context, 1.0)


def implicit_damping_context(plant: Any, context: Any, h: float) -> Any:
    """A clone of ``context`` whose joints carry (h/2)·FVj more reflected inertia.

    The simulated step damps at the midpoint velocity v + (h/2) a
    (``systems.drive_forces.DriveForces``): with joint damping D = diag(FVj),
    (M + (h/2) D) a = τ − c − g − D v − F. A controller commanding
    τ = M a + c − g + D v (the feedforward of FVj) gives the plant the
    acceleration (M + (h/2) D)⁻¹ M a: on the TIAGo's wrist (FV 1 N·m·s/rad on
    4e-6 kg·m², h = 1 ms) a 126th of it, and the joint does not track. The
    inverse-dynamics controller evaluated on this context commands
    (M + (h/2) D) a instead, which the step turns back into a. Each actuated
    joint's rotor inertia becomes ρ² I_r + (h/2)·FVj with gear ratio 1 (ρ, I_r
    the context's); the plant, the truth and the drive forces keep ``context``.
    """
    clone = context.Clone()
    for i in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(i)
        joint = actuator.joint()
        extra = 0.5 * h * float(joint.GetDamping(context))
        if extra > 0.0:
            reflected = actuator.calc_reflected_inertia(context)
            actuator.SetRotorInertia(clone, float(reflected) + extra)
            actuator.SetGearRatio(clone, 1.0)
    return clone


def add_drive_forces(
    builder: Any,
    plant: Any,
    model_plant: Any,
    model_context: Any,
    reference: Any,
    control: Any,
    drive: SimulatedDrive,
    *,
    kp: float,
    kd: float,
) -> Any:
    """Wires the drive's forces on the plant and its feedforward on the command.

    Args:
        builder: the ``DiagramBuilder``.
        plant: the simulated plant (in the builder).
        model_plant: a copy of it outside the builder (the controller's plant):
            ``DriveForces`` evaluates M and c on it.
        model_context: its context, with the plant's parameters
            (:func:`configure_plant`).
        reference: the output port of the reference [q_r; v_r; v̇_r] (3n).
        control: the output port of the controller's command (n).
        drive: the :class:`SimulatedDrive`.
        kp: the controller's position gain [1/s²].
        kd: the controller's velocity gain [1/s].

    Returns:
        The output port of the total command (controller + feedforward), which
        the caller connects to the plant's actuation input.
    """
    from pydrake.systems.primitives import Adder

    from drake_dynid.systems.drive_forces import DriveFeedforward, DriveForces

    n = drive.num_joints
    feedforward = builder.AddSystem(
        DriveFeedforward(drive, kp=kp, kd=kd, time_step=float(plant.time_step()))
    )
    builder.Connect(plant.get_state_output_port(), feedforward.get_input_port_state())
    builder.Connect(reference, feedforward.get_input_port_reference())
    total = builder.AddSystem(Adder(2, n))
    builder.Connect(control, total.get_input_port(0))
    builder.Connect(feedforward.get_output_port_feedforward(), total.get_input_port(1))
    forces = builder.AddSystem(DriveForces(drive, model_plant, model_context))
    builder.Connect(plant.get_state_output_port(), forces.get_input_port_state())
    builder.Connect(total.get_output_port(), forces.get_input_port_actuation())
    builder.Connect(
        forces.get_output_port_generalized_force(),
        plant.get_applied_generalized_force_input_port(),
    )
    return total.get_output_port()
