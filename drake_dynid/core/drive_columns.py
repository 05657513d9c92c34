"""Regressor columns of motors: rotor inertia and friction through R (docs/DRIVE.md).

With motor velocities v_m = R v (``drake_dynid.core.drive``), motor k has the kinetic
energy ½ Ia_k (R_k v)² and the friction torque Fv_k (R_k v) + Fc_k sign(R_k v) + off_k
on its shaft, both acting on the joints through R_kᵀ (R_k: row k of R)::

    τ = τ_rigid(q, v, v̇) + Σ_k R_kᵀ [Ia_k R_k v̇ + Fv_k R_k v + Fc_k s_k + off_k]

Columns of motor k (motor-side parameters IAmk [kg·m²], FVmk [N·m·s/rad], FCmk [N·m],
OFFmk [N·m]; u_k = R_k v, a_k = R_k v̇, s_k = sign(u_k / ρ_k), ρ_k = max_j |R_kj|)::

    column  IDIM row (n)  energy   momentum ∂E/∂v (n)  friction (n)  friction power
    IAmk    R_kᵀ a_k      ½ u_k²   R_kᵀ u_k            0             0
    FVmk    R_kᵀ u_k      0        0                   R_kᵀ u_k      u_k²
    FCmk    R_kᵀ s_k      0        0                   R_kᵀ s_k      u_k s_k
    OFFmk   R_kᵀ          0        0                   R_kᵀ          u_k

The energy does not depend on q (∂E/∂q = 0) and vᵀ(IDIM column) = d/dt(energy) +
friction power. The sign is evaluated on u_k / ρ_k (joint units: ρ_k = |N| for a
simple drive, N6 for the TX40 motor 6, whose u_6/ρ_6 = v5 + v6), so a dead-zone or
tanh width designed for joint velocities [rad/s] applies unchanged; it is the
``sign`` callable (default ``np.sign``).

Naming rule (Khalil): only coupled motors (several non-zeros in their row) get these
motor columns (``motor_columns``); a motor driving one joint j is in that joint's
columns, IAj = N² Ia, and its friction merges with FVj, FCj, OFFj
(``DriveChain.reflected_inertia``/``reflected_friction`` give the a-priori values).
``MotorColumns`` takes any rows, so the same equations serve simple rows in tests.
Everything is vectorised over a leading sample axis; pure numpy.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.planar2r import (
    FRICTION_PREFIX,
    MODEL_KINDS,
    as_batches,
    check_friction,
)

__all__ = ["MotorColumns", "motor_columns"]

_OWNER = "MotorColumns"
#: Motor value read for each friction kind (``Motor`` attribute names).
_FRICTION_VALUE = {"viscous": "viscous", "coulomb": "coulomb", "offset": "offset"}


@dataclass(frozen=True, eq=False)
class MotorColumns:
    """Motor columns for given rows of R (see the module docstring).

    Column order: ``IAm<k>`` for every motor (when ``inertia``), then per motor the
    friction kinds (``FVm<k> FCm<k> OFFm<k>``), as the joint friction columns.

    Attributes:
        rows: (c, n) rows R_k of the motors that get columns.
        numbers: (c,) 1-based motor numbers k used in the names.
        inertia: include the rotor-inertia columns ``IAmk``.
        friction: friction kinds among ``viscous``, ``coulomb``, ``offset``.
        values: (num_columns,) a-priori values (motor side, SI); 0 when unknown.
        sign: callable for sign(x), x = u_k / ρ_k in joint units [rad/s or m/s];
            None for ``np.sign``.
    """

    rows: np.ndarray
    numbers: tuple[int, ...]
    inertia: bool = True
    friction: tuple[str, ...] = ("viscous", "coulomb")
    values: np.ndarray | None = None
    sign: Callable[[np.ndarray], np.ndarray] | None = None

    def __post_init__(self) -> None:
        rows = _validate.array(_OWNER, "rows", self.rows)
        if rows.ndim != 2 or rows.shape[1] == 0:
            raise ValueError(
                f"{_OWNER}: rows must have shape (c, n) with n >= 1; got {rows.shape}."
            )
        if rows.shape[0] and not np.all(np.any(rows != 0.0, axis=1)):
            raise ValueError(f"{_OWNER}: rows must not be all zeros.")
        numbers = tuple(int(k) for k in self.numbers)
        if len(numbers) != rows.shape[0]:
            raise ValueError(
                f"{_OWNER}: numbers must have one entry per row ({rows.shape[0]}); "
                f"got {len(numbers)}."
            )
        rows = rows.copy()
        rows.setflags(write=False)
        object.__setattr__(self, "rows", rows)
        object.__setattr__(self, "numbers", numbers)
        object.__setattr__(self, "friction", check_friction(_OWNER, self.friction))
        size = len(self.names)
        values = np.zeros(size) if self.values is None else self.values
        values = _validate.array(_OWNER, "values", values, shape=(size,)).copy()
        values.setflags(write=False)
        object.__setattr__(self, "values", values)
        if self.sign is not None and not callable(self.sign):
            raise TypeError(f"{_OWNER}: sign must be callable or None.")

    # ---------------------------------------------------------------- names
    @property
    def num_joints(self) -> int:
        """Number of joints n."""
        return int(self.rows.shape[1])

    @property
    def inertia_names(self) -> tuple[str, ...]:
        """``IAm<k>`` per motor (empty without inertia)."""
        return tuple(f"IAm{k}" for k in self.numbers) if self.inertia else ()

    @property
    def friction_names(self) -> tuple[str, ...]:
        """Per motor, ``FVm<k> FCm<k> OFFm<k>`` for the enabled kinds."""
        return tuple(
            f"{FRICTION_PREFIX[kind]}m{k}"
            for k in self.numbers
            for kind in self.friction
        )

    @property
    def names(self) -> tuple[str, ...]:
        """All column names: inertia first, then friction."""
        return self.inertia_names + self.friction_names

    @property
    def num_columns(self) -> int:
        """Number of columns."""
        return len(self.names)

    # ------------------------------------------------------------ helpers
    def _batch(self, **arrays):
        return as_batches(_OWNER, self.num_joints, **arrays)

    def _friction_factors(self, u: np.ndarray) -> np.ndarray:
        """(N, c, w): per motor and kind, u_k, s_k or 1."""
        scale = np.max(np.abs(self.rows), axis=1) if self.rows.size else np.ones(0)
        sign = np.sign if self.sign is None else self.sign
        parts = []
        for kind in self.friction:
            if kind == "viscous":
                parts.append(u)
            elif kind == "coulomb":
                parts.append(np.asarray(sign(u / scale), dtype=float))
            else:
                parts.append(np.ones_like(u))
        return np.stack(parts, axis=-1) if parts else np.zeros((*u.shape, 0))

    def _joint_block(self, factor: np.ndarray) -> np.ndarray:
        """R_kᵀ·factor_k per joint: (N, c[, w]) -> (N, n, c·w)."""
        if factor.ndim == 2:
            factor = factor[..., None]
        out = self.rows.T[None, :, :, None] * factor[:, None, :, :]
        width = factor.shape[1] * factor.shape[2]
        return out.reshape(factor.shape[0], self.num_joints, width)

    def _assemble(self, inertia: np.ndarray | None, friction: np.ndarray | None, lead):
        """Concatenates the inertia and friction blocks (zeros where None)."""
        c, w = self.rows.shape[0], len(self.friction)
        blocks = []
        if self.inertia:
            blocks.append(np.zeros((*lead, c)) if inertia is None else inertia)
        blocks.append(np.zeros((*lead, c * w)) if friction is None else friction)
        return np.concatenate(blocks, axis=-1)

    # -------------------------------------------------------------- columns
    def idim_columns(self, v, vdot) -> np.ndarray:
        """IDIM columns, (N, n, num_columns): τ_motors = columns·values [N·m, N]."""
        v, vdot, single = self._batch(v=v, vdot=vdot)
        out = self._idim(v, vdot)
        return out[0] if single else out

    def _idim(self, v, vdot):
        u = v @ self.rows.T
        a = vdot @ self.rows.T
        lead = (v.shape[0], self.num_joints)
        friction = self._joint_block(self._friction_factors(u))
        return self._assemble(self._joint_block(a), friction, lead)

    def energy_columns(self, v) -> np.ndarray:
        """Kinetic-energy columns, (N, num_columns): ½ (R_k v)² for IAmk [J/unit]."""
        (v, single) = self._batch(v=v)
        u = v @ self.rows.T
        out = self._assemble(0.5 * u * u, None, (v.shape[0],))
        return out[0] if single else out

    def momentum_columns(self, v) -> np.ndarray:
        """Momentum columns ∂E/∂v, (N, n, num_columns): R_kᵀ (R_k v) for IAmk."""
        (v, single) = self._batch(v=v)
        out = self._momentum(v)
        return out[0] if single else out

    def _momentum(self, v):
        u = v @ self.rows.T
        lead = (v.shape[0], self.num_joints)
        return self._assemble(self._joint_block(u), None, lead)

    def friction_columns(self, v) -> np.ndarray:
        """Friction columns of the joint rows, (N, n, num_columns) [N·m per unit]."""
        (v, single) = self._batch(v=v)
        out = self._friction(v)
        return out[0] if single else out

    def _friction(self, v):
        u = v @ self.rows.T
        lead = (v.shape[0], self.num_joints)
        friction = self._joint_block(self._friction_factors(u))
        return self._assemble(None, friction, lead)

    def friction_power_columns(self, v) -> np.ndarray:
        """Dissipated power columns, (N, num_columns): u_k², u_k s_k, u_k [W/unit]."""
        (v, single) = self._batch(v=v)
        out = self._friction_power(v)
        return out[0] if single else out

    def _friction_power(self, v):
        u = v @ self.rows.T
        factors = self._friction_factors(u)
        power = (u[..., None] * factors).reshape(v.shape[0], factors[0].size)
        return self._assemble(None, power, (v.shape[0],))

    def power_columns(self, v, vdot) -> np.ndarray:
        """vᵀ(IDIM columns), (N, num_columns) [W/unit]."""
        v, vdot, single = self._batch(v=v, vdot=vdot)
        out = np.einsum("ni,nip->np", v, self._idim(v, vdot))
        return out[0] if single else out

    def model_columns(self, kind: str, v) -> tuple[np.ndarray, np.ndarray]:
        """Motor columns of the (D, G) rows of docs/CONVENTIONS.md §3.

        Append them to the robot's rows (y is unchanged): d/dt(D·θ) + G·θ = y.

        Args:
            kind: ``"power"`` (m = 1: D = energy, G = friction power) or
                ``"lagrangian"`` (m = n: D = ∂E/∂v, G = friction; ∂E/∂q = 0).
            v: joint velocities, (N, n) or (n,) [rad/s, m/s].

        Returns:
            ``D``, ``G`` of shape (N, m, num_columns) (no sample axis for (n,)).
        """
        (v, single) = self._batch(v=v)
        if kind == "power":
            u = v @ self.rows.T
            d = self._assemble(0.5 * u * u, None, (v.shape[0],))[:, None, :]
            g = self._friction_power(v)[:, None, :]
        elif kind == "lagrangian":
            d, g = self._momentum(v), self._friction(v)
        else:
            raise ValueError(
                f"{_OWNER}: kind must be one of {', '.join(MODEL_KINDS)}; got {kind!r}."
            )
        return (d[0], g[0]) if single else (d, g)


def motor_columns(
    chain,
    *,
    inertia: bool = True,
    friction: Sequence[str] | str = ("viscous", "coulomb"),
    sign: Callable[[np.ndarray], np.ndarray] | None = None,
) -> MotorColumns:
    """The motor columns of a drive chain's coupled motors (Khalil's naming).

    Args:
        chain: a ``DriveChain``.
        inertia: include ``IAmk`` (a-priori value: the motor's rotor_inertia).
        friction: kinds among ``viscous``, ``coulomb``, ``offset`` (a-priori: the
            motor's viscous, coulomb, offset). ``OFFmk`` = Σ_j R_kj OFFj columns:
            it always regroups into the joint offsets when those are modelled.
        sign: the sign function of the Coulomb columns (joint units), default
            ``np.sign``.

    Returns:
        ``MotorColumns`` for the motors that drive several joints (none: zero
        columns).
    """
    kinds = check_friction(_OWNER, friction)
    indices = chain.coupled_motors
    motors = [chain.motors[k] for k in indices]
    values = []
    if inertia:
        values += [motor.rotor_inertia or 0.0 for motor in motors]
    values += [
        getattr(motor, _FRICTION_VALUE[kind]) or 0.0
        for motor in motors
        for kind in kinds
    ]
    rows = np.array([motor.row for motor in motors]).reshape(-1, chain.num_joints)
    return MotorColumns(
        rows=rows,
        numbers=tuple(k + 1 for k in indices),
        inertia=bool(inertia),
        friction=kinds,
        values=np.array(values, dtype=float),
        sign=sign,
    )
