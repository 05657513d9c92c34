"""A drive chain's dynamics in a simulated plant (docs/DRIVE.md §3 and §6c).

The identification model of a robot with a drive chain (v_m = R v, τ = Rᵀ τ_m)::

    τ = τ_rigid(q, v, v̇) + IA ⊙ v̇ + FV ⊙ v + FC ⊙ s(v) + OFF
        + Σ_k R_kᵀ [Ia_k R_k v̇ + Fv_k R_k v + Fc_k s(R_k v / ρ_k) + off_k]

(IAj, FVj, FCj, OFFj: joint columns, the simple motors folded in; k: the coupled
motors, ρ_k = max_j |R_kj|). A simulation splits it between Drake's plant and an
applied generalized force:

* the plant models τ_rigid, the diagonal reflected inertia IA (actuator rotor
  inertia) and the joint damping FV;
* :meth:`SimulatedDrive.applied_friction` F: the Coulomb and offset terms of the
  joints and of the coupled motors (s = tanh(·/ε));
* the coupled motors' inertia and viscous friction, the constant matrices::

      K = Σ_k Ia_k R_kᵀ R_k  [kg·m²],      B = Σ_k Fv_k R_kᵀ R_k  [N·m·s/rad],

  which no joint or actuator of Drake's plant can carry (off-diagonal).

A discrete ``MultibodyPlant`` without contact steps as (measured, Drake 1.51, SAP;
docs/CONVENTIONS.md §7)::

    (M + h D) a = u + f - c(q, v) - D v,      v⁺ = v + h a,      q⁺ = q + h v⁺

(M with the reflected inertia, D the joint damping, u the clipped actuation, f the
applied force, c = C(q, v) v - g(q)): its velocity terms sit half a step either
side of the central difference (q⁺ - q⁻)/2h = v + (h/2) a. The applied force of
:func:`midpoint_step_force` makes it the step of the plant with mass matrix
M + K, damping D + B and friction F, every velocity term at that midpoint::

    (M + K) a + c(q, v̄) + (D + B) v̄ + F(v̄) = u,      v̄ = v + (h/2) a

so a log of the plant obeys the model at the central differences of its
positions, as every identification path evaluates it. Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.drive_columns import MotorColumns
from drake_dynid.core.friction import SignLaw, TanhSign, friction_force

__all__ = [
    "SimulatedDrive",
    "midpoint_step_force",
    "simulated_drive",
]

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


#: Newton iterations of :func:`midpoint_step_force` before it gives up.
MIDPOINT_ITERATIONS = 50
#: A step that stops without reaching the tolerance (1e-10 of the torques) is
#: accepted up to this many times it (1e-6 of the torques), else refused.
MIDPOINT_ACCEPT = 1e4


def _friction_law(
    drive: SimulatedDrive,
) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """The friction law v -> (F(v), ∂F/∂v (n, n)) of ``drive.applied_friction``.

    Analytic for the tanh laws of a simulation (evaluated several times per plant
    step); else central differences (the joints' law is elementwise; every
    column with coupled motors).
    """
    n = drive.num_joints
    width = getattr(drive.sign, "width", None)
    coulomb, offset = np.asarray(drive.coulomb), np.asarray(drive.offset)
    motors = drive.motors
    motor_sign = None if motors is None else motors.sign
    if isinstance(drive.sign, TanhSign) and (
        motors is None or isinstance(motor_sign, TanhSign)
    ):
        # F = FC ⊙ tanh(v/ε) + OFF + Σ_k R_kᵀ [Fc_k tanh(R_k v/(ρ_k ε_m)) + off_k]
        scale = coulomb / width
        rows = np.zeros((0, n)) if motors is None else np.asarray(motors.rows)
        rho = np.max(np.abs(rows), axis=1) if rows.size else np.zeros(0)
        motor_width = rho * (
            motor_sign.width if isinstance(motor_sign, TanhSign) else 1.0
        )
        motor_coulomb = drive._motor_values("FCm")
        motor_offset = drive._motor_values("OFFm")

        def tanh_law(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            s = np.tanh(v / width)
            force = coulomb * s + offset
            jacobian = np.diag(scale * (1.0 - s * s))
            if rows.size:
                s_m = np.tanh((rows @ v) / motor_width)
                force = force + rows.T @ (motor_coulomb * s_m + motor_offset)
                slope = motor_coulomb * (1.0 - s_m * s_m) / motor_width
                jacobian = jacobian + rows.T @ (slope[:, None] * rows)
            return force, jacobian

        return tanh_law
    step = 1e-4 * float(width or 1e-2)

    def differenced(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if drive.motors is None:
            zero = np.zeros(n)
            forward = friction_force(v + step, zero, coulomb, offset, drive.sign)
            backward = friction_force(v - step, zero, coulomb, offset, drive.sign)
            jacobian = np.diag((forward - backward) / (2.0 * step))
        else:
            jacobian = np.empty((n, n))
            for j in range(n):
                delta = np.zeros(n)
                delta[j] = step
                jacobian[:, j] = (
                    drive.applied_friction(v + delta)
                    - drive.applied_friction(v - delta)
                ) / (2.0 * step)
        return drive.applied_friction(v), jacobian

    return differenced


def midpoint_step_force(
    drive: SimulatedDrive,
    mass: np.ndarray,
    damping: np.ndarray,
    time_step: float,
    bias: Callable[[np.ndarray], np.ndarray],
    v: np.ndarray,
    actuation: np.ndarray,
) -> np.ndarray:
    """The applied force that makes a discrete plant's step the midpoint step.

    Drake's step (module docstring) evaluates the bias c and any applied friction
    at v_k, half a step before the central difference of the positions, and the
    damping at v_{k+1}, half a step after: a log of it obeys the model at the
    central differences only to O(h) (docs/CONVENTIONS.md §2). With v̄ the
    midpoint velocity and a the step's acceleration::

        v̄ = v + (h/2) a = (q_{k+1} - q_{k-1}) / 2h
        a = (q_{k+1} - 2 q_k + q_{k-1}) / h²

    this solves, by Newton's method on a (Jacobian M + K + (h/2)(D + B + ∂F/∂v);
    c's velocity Jacobian, of relative size h|v|, is left out and the iteration
    converges linearly at that rate; steps halved until |r| decreases)::

        r(a) = (M + K) a + c(q, v̄) + (D + B) v̄ + F(v̄) - u = 0

    (F = ``drive.applied_friction``: Coulomb and offsets of the joints and of the
    coupled motors; K, B the coupled motors' inertia and damping), and returns::

        f = (M + h D) a - u + c(q, v) + D v                        [N·m or N]

    so that the plant's step (M + h D) a = u + f - c(q, v) - D v takes that a:
    every velocity term of the logged τ_k = u_k is then at the central
    difference, as every identification path evaluates it. Implicit in F, the
    step is stable for any Coulomb stiffness h·FC/(ε·inertia) (the explicit
    law chattered beyond 2); within |v̄| < ε a very stiff joint's velocity rings
    about v̄ = 0 by at most about ε.

    Args:
        drive: the drive (F, K = ``coupled_inertia``, B = ``coupled_damping``).
        mass: (n, n) the plant's mass matrix M(q) (with its reflected inertia).
        damping: (n,) the plant's joint damping D.
        time_step: the plant's step h [s].
        bias: velocity (n,) -> c(q, velocity) = C(q, velocity) velocity - g(q),
            at the step's q.
        v: (n,) the velocities v_k.
        actuation: (n,) the actuation u the plant applies (after its effort
            limits).

    Returns:
        (n,) the applied generalized force f to give the plant.

    Raises:
        ValueError: Newton's method did not converge (a non-finite state, or a
            residual above 1e-6 of the torques after its iterations).
    """
    h = float(time_step)
    inertia = mass + drive.coupled_inertia
    viscous = np.diag(damping) + drive.coupled_damping
    law = _friction_law(drive)
    at_v = bias(v)
    friction, slope = law(v)
    a = np.linalg.solve(
        inertia + 0.5 * h * (viscous + slope),
        actuation - at_v - viscous @ v - friction,
    )
    tolerance = 1e-10 * (np.max(np.abs(actuation)) + np.max(np.abs(at_v)) + 1e-300)

    def midpoint_residual(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """r(a) and ∂F/∂v at v̄ = v + (h/2) a."""
        middle = v + 0.5 * h * a
        friction, slope = law(middle)
        r = inertia @ a + bias(middle) + viscous @ middle + friction - actuation
        return r, slope

    size, last = math.inf, None
    for _ in range(MIDPOINT_ITERATIONS):
        r, slope = midpoint_residual(a)
        new_size = float(np.max(np.abs(r)))
        if not new_size < size:  # no decrease: halve the last step, or stop
            if not np.all(np.isfinite(a)) or last is None or new_size <= tolerance:
                break
            last = 0.5 * last
            a = a + last  # back towards the previous iterate
            continue
        size = new_size
        if size <= tolerance:
            break
        last = np.linalg.solve(inertia + 0.5 * h * (viscous + slope), r)
        a = a - last
    if not np.all(np.isfinite(a)):
        _validate.fail(
            "midpoint_step_force",
            "the midpoint step did not converge (a non-finite acceleration).",
        )
    if not size <= tolerance:  # stopped without converging: check where it ends
        residual = float(np.max(np.abs(midpoint_residual(a)[0])))
        if not residual <= MIDPOINT_ACCEPT * tolerance:
            _validate.fail(
                "midpoint_step_force",
                f"the midpoint step did not converge: the equation's residual is "
                f"{residual:.3g} [N·m or N] after {MIDPOINT_ITERATIONS} Newton "
                "iterations (the velocity terms are too stiff for the step: a "
                "smaller time step).",
            )
    return (mass + h * np.diag(damping)) @ a - actuation + at_v + damping * v
