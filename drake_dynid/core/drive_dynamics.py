"""A drive chain's dynamics in a simulated plant (docs/DRIVE.md §3 and §6c).

The identification model of a robot with a drive chain (v_m = R v, τ = Rᵀ τ_m)::

    τ = τ_rigid(q, v, v̇) + IA ⊙ v̇ + FV ⊙ v + FC ⊙ s(v) + OFF
        + Σ_k R_kᵀ [Ia_k R_k v̇ + Fv_k R_k v + Fc_k s(R_k v / ρ_k) + off_k]

(IAj, FVj, FCj, OFFj: joint columns, the simple motors folded in; k: the coupled
motors, ρ_k = max_j |R_kj|). A simulation splits it between Drake's plant and an
applied generalized force:

* the plant models τ_rigid, the diagonal reflected inertia IA (actuator rotor
  inertia) and the joint damping FV (implicit in a discrete step);
* :meth:`SimulatedDrive.applied_friction`, applied as -f: the Coulomb and offset
  terms of the joints and of the coupled motors (explicit, s = tanh(·/ε));
* the coupled motors' inertia and viscous friction, the constant matrices::

      K = Σ_k Ia_k R_kᵀ R_k  [kg·m²],      B = Σ_k Fv_k R_kᵀ R_k  [N·m·s/rad],

  which no joint or actuator of Drake's plant can carry (off-diagonal), are
  applied exactly by :func:`coupled_motor_force`.

A discrete ``MultibodyPlant`` without contact steps as (measured, Drake 1.51, SAP;
docs/CONVENTIONS.md §7)::

    (M + h D) a = u + f - c(q, v) - D v,      v⁺ = v + h a,      q⁺ = q + h v⁺

(M with the reflected inertia, D the joint damping, u the clipped actuation, f the
applied force, c = C(q, v) v - g(q)). The plant moves as if its mass matrix were
M + K and its damping D + B (B implicit, as D) when f = f₀ - K a - B (v + h a) with
``(M + h D + K + h B) a = u + f₀ - c - (D + B) v``: substituting gives (M + h D) a
on both sides, so the step is exact, not lagged. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.drive_columns import MotorColumns
from drake_dynid.core.friction import SignLaw, friction_force

__all__ = ["SimulatedDrive", "coupled_motor_force", "simulated_drive"]

_OWNER = "SimulatedDrive"


@dataclass(frozen=True, eq=False)
class SimulatedDrive:
    """What a simulated plant needs of a robot's joint friction and drive chain.

    Attributes:
        joint_names: the n joints (plant velocity order).
        rotor_inertia: (n,) reflected inertia IAj [kg·m² or kg] to give the plant's
            actuators (rotor inertia IAj, gear ratio 1), or None to keep the URDF's.
        viscous: (n,) FVj [N·m·s/rad or N·s/m]: the plant's joint damping.
        coulomb: (n,) FCj [N·m or N], >= 0.
        offset: (n,) OFFj [N·m or N].
        motors: the coupled motors' columns with their values (``IAmk`` first when
            ``motors.inertia``, then ``FVmk FCmk OFFmk`` of ``motors.friction``)
            and the Coulomb law ``motors.sign`` (applied on u_k/ρ_k); None without
            coupled motors.
        sign: the Coulomb law s of the joints (``TanhSign`` in a simulation).
    """

    joint_names: tuple[str, ...]
    rotor_inertia: np.ndarray | None
    viscous: np.ndarray
    coulomb: np.ndarray
    offset: np.ndarray
    motors: MotorColumns | None
    sign: SignLaw

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        if n == 0:
            _validate.fail(_OWNER, "joint_names must name at least one joint.")
        for name in ("viscous", "coulomb", "offset"):
            value = _validate.array(_OWNER, name, getattr(self, name), shape=(n,))
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        if np.any(self.coulomb < 0.0) or np.any(self.viscous < 0.0):
            _validate.fail(_OWNER, "viscous and coulomb must be >= 0.")
        if self.rotor_inertia is not None:
            inertia = _validate.array(
                _OWNER, "rotor_inertia", self.rotor_inertia, shape=(n,)
            )
            if np.any(inertia < 0.0):
                _validate.fail(
                    _OWNER,
                    f"rotor_inertia must be >= 0 [kg·m² or kg]; got {inertia}.",
                )
            inertia.setflags(write=False)
            object.__setattr__(self, "rotor_inertia", inertia)
        if self.motors is not None:
            _validate.instance(
                _OWNER, "motors", self.motors, MotorColumns, "a MotorColumns"
            )
            if self.motors.num_joints != n:
                _validate.fail(
                    _OWNER,
                    f"motors must have rows over the {n} joints; got "
                    f"{self.motors.num_joints}.",
                )
            if self.motors.sign is None:
                _validate.fail(_OWNER, "motors.sign must be set (the Coulomb law).")
        if not callable(self.sign):
            raise TypeError(f"{_OWNER}: sign must be a SignLaw (callable).")

    @property
    def num_joints(self) -> int:
        """Number of joints n."""
        return len(self.joint_names)

    def _motor_values(self, prefix: str) -> np.ndarray:
        motors = self.motors
        if motors is None:
            return np.zeros(0)
        index = [i for i, name in enumerate(motors.names) if name.startswith(prefix)]
        values = np.zeros(motors.rows.shape[0])
        numbers = [int(motors.names[i][len(prefix) :]) for i in index]
        given = np.asarray(motors.values, dtype=float)
        for i, number in zip(index, numbers, strict=True):
            values[motors.numbers.index(number)] = given[i]
        return values

    @property
    def coupled_inertia(self) -> np.ndarray:
        """K = Σ_k Ia_k R_kᵀ R_k over the coupled motors, (n, n) [kg·m²]."""
        return self._coupled_matrix("IAm")

    @property
    def coupled_damping(self) -> np.ndarray:
        """B = Σ_k Fv_k R_kᵀ R_k over the coupled motors, (n, n) [N·m·s/rad]."""
        return self._coupled_matrix("FVm")

    def _coupled_matrix(self, prefix: str) -> np.ndarray:
        n = self.num_joints
        if self.motors is None:
            return np.zeros((n, n))
        rows = self.motors.rows
        return rows.T @ (self._motor_values(prefix)[:, None] * rows)

    @property
    def needs_plant_step(self) -> bool:
        """Whether K or B is non-zero (the force needs the plant's step)."""
        return bool(np.any(self.coupled_inertia) or np.any(self.coupled_damping))

    def applied_friction(self, v: np.ndarray) -> np.ndarray:
        """The friction the plant does not model itself, (n,) [N·m or N].

        ``f = FC ⊙ s(v) + OFF + Σ_k R_kᵀ [Fc_k s(u_k/ρ_k) + off_k]``, u_k = R_k v
        (apply -f; the viscous terms are the plant's damping D and B).
        """
        v = np.asarray(v, dtype=float)
        out = friction_force(v, np.zeros_like(v), self.coulomb, self.offset, self.sign)
        motors = self.motors
        if motors is not None:
            viscous = [name.startswith("FVm") for name in motors.names]
            values = np.where(viscous, 0.0, np.asarray(motors.values, dtype=float))
            out = out + motors.friction_columns(v) @ values
        return out


def simulated_drive(
    names: Sequence[str],
    values: np.ndarray,
    joint_names: Sequence[str],
    motors: MotorColumns | None,
    sign: SignLaw,
) -> SimulatedDrive:
    """A :class:`SimulatedDrive` from a standard-parameter table.

    Args:
        names: the standard names (``IAj``, ``FVj``, ``FCj``, ``OFFj`` are read;
            an absent column is 0, an absent ``IAj`` everywhere gives
            ``rotor_inertia = None``).
        values: their values (the simulated truth).
        joint_names: the n joints; j in the names is 1-based in this order.
        motors: the coupled motors' columns (values replaced by the table's
            ``IAmk``, ``FVmk``, ... of the same names), or None.
        sign: the Coulomb law of the simulation (joints and motors).
    """
    table = dict(zip(names, np.asarray(values, dtype=float), strict=True))
    n = len(joint_names)

    def column(prefix: str) -> np.ndarray:
        return np.array([table.get(f"{prefix}{j + 1}", 0.0) for j in range(n)])

    inertia = column("IA") if any(f"IA{j + 1}" in table for j in range(n)) else None
    if motors is not None:
        motors = MotorColumns(
            rows=motors.rows,
            numbers=motors.numbers,
            inertia=motors.inertia,
            friction=motors.friction,
            values=np.array([table.get(name, 0.0) for name in motors.names]),
            sign=sign,
        )
    return SimulatedDrive(
        joint_names=tuple(joint_names),
        rotor_inertia=inertia,
        viscous=column("FV"),
        coulomb=column("FC"),
        offset=column("OFF"),
        motors=motors,
        sign=sign,
    )


def coupled_motor_force(
    drive: SimulatedDrive,
    mass: np.ndarray,
    damping: np.ndarray,
    time_step: float,
    bias: np.ndarray,
    v: np.ndarray,
    actuation: np.ndarray,
    applied: np.ndarray,
) -> np.ndarray:
    """The applied force that gives a discrete plant the coupled motors' K and B.

    (Module docstring.) With c the plant's bias, u the actuation it applies and
    f₀ the other applied forces::

        (M + h D + K + h B) a = u + f₀ - c - (D + B) v
        f = f₀ - K a - B (v + h a)                                  [N·m or N]

    Args:
        drive: the drive (K = ``coupled_inertia``, B = ``coupled_damping``).
        mass: (n, n) the plant's mass matrix M(q) (with its reflected inertia).
        damping: (n,) the plant's joint damping D.
        time_step: the plant's step h [s].
        bias: (n,) c = C(q, v) v - g(q) (Drake's bias term minus its gravity
            generalized forces).
        v: (n,) the velocities.
        actuation: (n,) the actuation u the plant applies (after its effort
            limits).
        applied: (n,) f₀.

    Returns:
        (n,) the applied generalized force f to give the plant.
    """
    inertia, viscous = drive.coupled_inertia, drive.coupled_damping
    h = time_step
    system = mass + h * np.diag(damping) + inertia + h * viscous
    rhs = actuation + applied - bias - damping * v - viscous @ v
    a = np.linalg.solve(system, rhs)
    return applied - inertia @ a - viscous @ (v + h * a)
