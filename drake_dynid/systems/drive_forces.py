"""A drive chain's friction and coupled motors on a simulated plant.

The numerics live in :mod:`drake_dynid.core.drive_dynamics`; these blocks read the
plant's state (and, for the coupled motors' inertia, its mass matrix and bias)
and apply them. Used by ``drake_dynid.experiment`` (``dynid simulate``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    InputPort,
    LeafSystem,
    OutputPort,
    ValueProducer,
)

from drake_dynid.core import _validate
from drake_dynid.core.drive_dynamics import SimulatedDrive, midpoint_step_force
from drake_dynid.core.friction import friction_force_scalar

__all__ = ["DriveFeedforward", "DriveForces"]


def _check_drive(owner: str, drive: Any) -> SimulatedDrive:
    return _validate.instance(
        owner, "drive", drive, SimulatedDrive, "a SimulatedDrive (simulated_drive)"
    )


def _joint_friction(drive: SimulatedDrive, v: Any) -> np.ndarray:
    """``drive.applied_friction(v)`` without coupled motors, with plain floats.

    Runs at every plant step: on a few joints plain floats beat numpy (the same
    law, ``core.friction``; a test checks they agree).
    """
    sign, out = drive.sign, np.empty(drive.num_joints)
    for j, (fc, off) in enumerate(zip(drive.coulomb, drive.offset, strict=True)):
        out[j] = friction_force_scalar(float(v[j]), 0.0, float(fc), float(off), sign)
    return out


class DriveForces(LeafSystem):
    """The drive's forces, and the midpoint step, of a discrete ``MultibodyPlant``.

    .. pydrake_system::

        name: DriveForces
        input_ports:
        - state
        - actuation
        output_ports:
        - generalized_force

    For the plant's applied generalized force input (docs/DRIVE.md §6c),
    ``core.drive_dynamics.midpoint_step_force``: with M, c = C v - g and D of
    ``plant`` at the current state, u the ``actuation`` clipped to the actuators'
    effort limits (as the plant applies it), F the drive's Coulomb friction and
    offsets (joints and coupled motors, ``SimulatedDrive.applied_friction``) and
    K, B the coupled motors' inertia and damping, the force f for which the
    plant's step (M + h D) a = u + f - c(q, v) - D v takes the a of::

        (M + K) a + c(q, v̄) + (D + B) v̄ + F(v̄) = u,    v̄ = v + (h/2) a   [N·m or N]

    v̄ = (q_{k+1} - q_{k-1})/2h the central difference of the positions, at which
    every identification path evaluates the model: a noise-free log of the plant
    obeys it to round-off (docs/CONVENTIONS.md §2), where Drake's own step has
    the bias and the friction at v_k and the damping at v_{k+1}, O(h) off. The
    plant's joint damping (FV) and reflected inertia (IA) must be set by the
    caller (``rotor_inertia``, ``viscous`` of the drive).

    Connect the plant's state output to ``state`` (size 2n), the command given to
    its actuation input to ``actuation`` (size n) and ``generalized_force`` to its
    ``get_applied_generalized_force_input_port()``. No state: the plant context
    used for M and c is a cache entry. Double only (a plain Python
    ``LeafSystem``).

    Args:
        drive: the :class:`drake_dynid.core.drive_dynamics.SimulatedDrive`.
        plant: the discrete ``MultibodyPlant`` simulated (a copy with the same
            parameters).
        plant_context: its context holding those parameters (rotor inertia,
            damping); default the plant's default context.
    """

    def __init__(self, drive: SimulatedDrive, plant: Any, plant_context: Any = None):
        super().__init__()
        owner = "DriveForces"
        self._drive = _check_drive(owner, drive)
        n = drive.num_joints
        self._state = self.DeclareVectorInputPort("state", 2 * n)
        self._actuation = self.DeclareVectorInputPort("actuation", n)
        if not (
            hasattr(plant, "num_velocities")
            and plant.num_velocities() == n
            and plant.time_step() > 0.0
        ):
            _validate.fail(
                owner,
                f"plant must be a discrete MultibodyPlant with {n} velocities; got "
                + (
                    f"{plant.num_velocities()} and time_step {plant.time_step()}."
                    if hasattr(plant, "num_velocities")
                    else f"{type(plant).__name__}."
                ),
            )
        context = (
            plant.CreateDefaultContext() if plant_context is None else plant_context
        )
        self._plant = plant
        self._time_step = float(plant.time_step())
        self._damping, self._effort = _damping_and_effort(plant, context)
        template = AbstractValue.Make(context.Clone())
        self._plant_state = self.DeclareCacheEntry(
            description="the plant model at the current state",
            value_producer=ValueProducer(
                allocate=template.Clone, calc=self._CalcPlantState
            ),
            prerequisites_of_calc={self.input_port_ticket(self._state.get_index())},
        )
        self._force = self.DeclareVectorOutputPort(
            "generalized_force", n, self._CalcForce
        )

    @property
    def drive(self) -> SimulatedDrive:
        """The simulated drive."""
        return self._drive

    def get_input_port_state(self) -> InputPort:
        """The input port ``state`` ([q; v], size 2n)."""
        return self._state

    def get_input_port_actuation(self) -> InputPort:
        """The input port ``actuation`` (the command, size n, before clipping)."""
        return self._actuation

    def get_output_port_generalized_force(self) -> OutputPort:
        """The output port ``generalized_force`` (size n)."""
        return self._force

    def _CalcPlantState(self, context: Any, value: AbstractValue) -> None:
        plant_context = value.get_mutable_value()
        self._plant.SetPositionsAndVelocities(plant_context, self._state.Eval(context))

    def _CalcForce(self, context: Any, output: BasicVector) -> None:
        n = self._drive.num_joints
        x = np.asarray(self._state.Eval(context), dtype=float)
        plant = self._plant
        # The cached context at the current q; the bias is evaluated on it at
        # other velocities (every reader sets them first).
        plant_context = self._plant_state.Eval(context)
        gravity = plant.CalcGravityGeneralizedForces(plant_context)

        def bias(velocity: np.ndarray) -> np.ndarray:
            plant.SetVelocities(plant_context, velocity)
            return plant.CalcBiasTerm(plant_context) - gravity

        actuation = np.clip(self._actuation.Eval(context), -self._effort, self._effort)
        force = midpoint_step_force(
            self._drive,
            plant.CalcMassMatrix(plant_context),
            self._damping,
            self._time_step,
            bias,
            x[n:],
            actuation,
        )
        plant.SetVelocities(plant_context, x[n:])
        output.SetFromVector(force)


class DriveFeedforward(LeafSystem):
    """The drive's terms a tracking controller adds to its command.

    .. pydrake_system::

        name: DriveFeedforward
        input_ports:
        - state
        - reference
        output_ports:
        - feedforward

    With the reference [q_r; v_r; v̇_r] (size 3n) and the state [q; v]::

        feedforward = FC ⊙ s(v_r) + OFF + Σ_k R_kᵀ [Fc_k s(R_k v_r/ρ_k) + off_k]
                      + (K + (h/2) B) (v̇_r + kp (q_r - q) + kd (v_r - v)) + B v
                                                                    [N·m or N]

    i.e. the friction the plant gets from :class:`DriveForces` and the coupled
    motors' inertia, which Drake's ``InverseDynamicsController`` (M(q), c, D of
    its plant) does not know; with it the tracking error has the controller's
    gains on every joint. :class:`DriveForces` makes the discrete plant step
    with the damping at the midpoint velocity v + (h/2) a, (M + K + (h/2)(D +
    B)) a = u - c - (D + B) v - F, so the command a needs (K + (h/2) B) a + B v
    (the controller's plant gives (M + (h/2) D) a + D v:
    ``experiment_drive.implicit_damping_context``); with B v_r instead of B v,
    B (v_r - v) was extra velocity feedback. No state; double only (a plain
    Python ``LeafSystem``).

    Args:
        drive: the :class:`drake_dynid.core.drive_dynamics.SimulatedDrive`.
        kp: the controller's position gain [1/s²].
        kd: the controller's velocity gain [1/s].
        time_step: the discrete plant's step h [s] (0: (h/2) B left out).
    """

    def __init__(
        self, drive: SimulatedDrive, *, kp: float, kd: float, time_step: float = 0.0
    ) -> None:
        super().__init__()
        owner = "DriveFeedforward"
        self._drive = _check_drive(owner, drive)
        self._kp = _validate.positive(owner, "kp", kp, "1/s²")
        self._kd = _validate.positive(owner, "kd", kd, "1/s")
        h = float(time_step)
        if not (math.isfinite(h) and h >= 0.0):
            _validate.fail(owner, f"time_step must be finite and >= 0 [s]; got {h}.")
        self._inertia = drive.coupled_inertia
        if h > 0.0:
            self._inertia = self._inertia + 0.5 * h * drive.coupled_damping
        self._viscous = drive.coupled_damping
        n = drive.num_joints
        self._state = self.DeclareVectorInputPort("state", 2 * n)
        self._reference = self.DeclareVectorInputPort("reference", 3 * n)
        self._feedforward = self.DeclareVectorOutputPort(
            "feedforward", n, self._CalcFeedforward
        )

    def get_input_port_state(self) -> InputPort:
        """The input port ``state`` ([q; v], size 2n)."""
        return self._state

    def get_input_port_reference(self) -> InputPort:
        """The input port ``reference`` ([q_r; v_r; v̇_r], size 3n)."""
        return self._reference

    def get_output_port_feedforward(self) -> OutputPort:
        """The output port ``feedforward`` (size n)."""
        return self._feedforward

    def _CalcFeedforward(self, context: Any, output: BasicVector) -> None:
        drive = self._drive
        n = drive.num_joints
        r = self._reference.Eval(context)
        if drive.motors is None:
            output.SetFromVector(_joint_friction(drive, r[n : 2 * n]))
            return
        x = np.asarray(self._state.Eval(context), dtype=float)
        r = np.asarray(r, dtype=float)
        q_r, v_r, a_r = r[:n], r[n : 2 * n], r[2 * n :]
        v = x[n:]
        command = a_r + self._kp * (q_r - x[:n]) + self._kd * (v_r - v)
        output.SetFromVector(
            drive.applied_friction(v_r) + self._inertia @ command + self._viscous @ v
        )


def _damping_and_effort(plant: Any, context: Any) -> tuple[np.ndarray, np.ndarray]:
    """(n,) joint damping (velocity order) and actuator effort limits (inf: none)."""
    n = plant.num_velocities()
    damping = np.zeros(n)
    for i in plant.GetJointIndices():
        joint = plant.get_joint(i)
        if joint.num_velocities() == 1:
            damping[joint.velocity_start()] = joint.GetDamping(context)
    effort = np.full(n, np.inf)
    for i in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(i)
        effort[actuator.joint().velocity_start()] = actuator.effort_limit()
    return damping, effort
