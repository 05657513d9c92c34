"""The robot description used for identification: parameters and exact regressors.

``RobotModel`` is the immutable description of a fixed-base URDF robot: joint names,
standard parameters read from the URDF, base parameters
(``drake_dynid.core.base_parameters``) and exact regressors (``core.rigid_body``),
vectorised over a leading sample axis.

Standard parameters (Khalil-Kleinfinger names, docs/MATH.md §2), per joint j (1-based,
in Drake's generalized-velocity order, which runs along the chain): ``XXj XYj XZj YYj
YZj ZZj`` (inertia tensor entries about the origin of joint j's child-link frame, in
that frame [kg·m²]; ``XYj`` is the tensor entry, i.e. -∫xy dm), ``MXj MYj MZj`` (first
moments m·c [kg·m]), ``Mj`` [kg], optional ``IAj`` (rotor inertia reflected to the
joint [kg·m²]), then the friction columns ``FVj FCj OFFj`` of every joint. Bodies
welded to a child link are lumped into it; bodies welded to the world are dropped
(their energy is constant).

The kinematics (poses and screws) come from the joint geometry read from the plant
(``drake_dynid.plant_tree``), either evaluated in numpy over the whole batch
(``kinematics="numpy"``, the default, fast) or from Drake per sample
(``kinematics="drake"``: ``EvalBodyPoseInWorld``); the two agree to round-off.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.core.base_parameters import BaseParameters, base_parameters
from drake_dynid.core.kinematics import KinematicTree
from drake_dynid.core.planar2r import (
    FRICTION_PREFIX,
    MODEL_KINDS,
    Planar2RRows,
    as_batches,
    check_friction,
    friction_idim_columns,
    model_rows_from_parts,
)
from drake_dynid.core.rigid_body import (
    energy_blocks,
    idim_blocks,
    lagrangian_blocks,
    link_terms,
)
from drake_dynid.plant_tree import extract_tree
from drake_dynid.urdf import load_plant, read_urdf_friction

__all__ = ["INERTIAL_NAMES", "RobotModel"]

#: The 10 inertial parameters of one link, in Khalil's (and the preferred) order.
INERTIAL_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")

_KINEMATICS = ("numpy", "drake")
_COLUMNS = ("base", "standard")


@dataclass(frozen=True, eq=False)
class RobotModel:
    """Immutable description of a fixed-base robot for identification.

    Build it with :meth:`from_urdf` (or :meth:`from_plant`). All row methods take
    batches with a leading sample axis, ``q``, ``v``, ``vdot``, ``tau`` of shape
    ``(N, n)`` (or ``(n,)`` for one sample, which drops the sample axis of the
    results), in Drake's generalized-velocity order (``joint_names``), and return
    base-parameter columns (``columns="base"``, default) or standard ones
    (``columns="standard"``). The contract used by the on-line blocks is
    :meth:`model_rows` ``(kind, q, v, tau) -> (D, G, y)``.

    Attributes:
        plant: the finalized ``MultibodyPlant`` (continuous unless a time step was
            given). Do not mutate it: the parameters below were read from it.
        path: the URDF path ("" when built from a plant).
        joint_names: the n moving joints in generalized-velocity order.
        gravity: gravity vector [m/s²].
        friction: friction kinds per joint (subset of viscous, coulomb, offset).
        rotor_inertia: whether the ``IAj`` columns are present.
        standard_names: the p_std standard parameter names (preferred order).
        standard_values: their values read from the plant/URDF (``(p_std,)``).
        base: the base parameters (names, definitions, standard -> base map).
        kinematics: ``"numpy"`` (vectorised forward kinematics from the joint
            geometry, default) or ``"drake"`` (``EvalBodyPoseInWorld`` per sample).
    """

    plant: Any
    path: str
    joint_names: tuple[str, ...]
    gravity: np.ndarray
    friction: tuple[str, ...]
    rotor_inertia: bool
    standard_names: tuple[str, ...]
    standard_values: np.ndarray
    base: BaseParameters
    kinematics: str = "numpy"
    _chain: KinematicTree = field(repr=False, default=None)  # type: ignore[assignment]
    _link_bodies: tuple[Any, ...] = field(repr=False, default=())
    _joint_frames: tuple[Any, ...] = field(repr=False, default=())

    # ------------------------------------------------------------------ builders
    @classmethod
    def from_urdf(
        cls,
        path: str | Path,
        *,
        friction: Sequence[str] | str = ("viscous", "coulomb"),
        rotor_inertia: bool = False,
        gravity: Sequence[float] | None = None,
        time_step: float = 0.0,
        kinematics: str = "numpy",
        seed: int = 0,
    ) -> RobotModel:
        """Loads a URDF (see :func:`load_plant`) and computes its parameters.

        Args:
            path: the URDF file (``model_path("planar_2r")`` for the paper's arm).
            friction: friction columns per joint among ``"viscous"`` (FVj, from
                ``<dynamics damping>``), ``"coulomb"`` (FCj, from ``<dynamics
                friction>``) and ``"offset"`` (OFFj, 0 in a URDF).
            rotor_inertia: add the ``IAj`` columns (values from the actuators'
                rotor inertia times gear ratio squared; 0 for a plain URDF).
            gravity: gravity vector [m/s²]; default (0, 0, -9.81).
            time_step: period of the plant held in ``plant`` [s] (0: continuous).
            kinematics: ``"numpy"`` or ``"drake"`` (see the class docstring).
            seed: seed of the random states used for the base-parameter reduction.
        """
        plant = load_plant(path, time_step, gravity=gravity)
        coulomb = read_urdf_friction(path)
        return cls.from_plant(
            plant,
            friction=friction,
            rotor_inertia=rotor_inertia,
            coulomb=coulomb,
            kinematics=kinematics,
            seed=seed,
            path=str(path),
        )

    @classmethod
    def from_plant(
        cls,
        plant: Any,
        *,
        friction: Sequence[str] | str = ("viscous", "coulomb"),
        rotor_inertia: bool = False,
        coulomb: dict[str, float] | None = None,
        kinematics: str = "numpy",
        seed: int = 0,
        path: str = "",
    ) -> RobotModel:
        """Builds the description of a finalized fixed-base plant.

        ``coulomb`` maps joint names to Coulomb friction values (Drake does not
        store them); the viscous values are the joints' default damping.
        """
        owner = "RobotModel"
        friction = check_friction(owner, friction)
        if kinematics not in _KINEMATICS:
            raise ValueError(
                f"{owner}: kinematics must be one of {', '.join(_KINEMATICS)}; got "
                f"{kinematics!r}."
            )
        if not plant.is_finalized():
            raise ValueError(f"{owner}: plant must be finalized.")
        chain, joints, inertial = extract_tree(plant)
        n = len(joints)
        if plant.num_positions() != n or plant.num_velocities() != n:
            raise ValueError(
                f"{owner}: plant must have only revolute, prismatic and fixed joints "
                f"on a fixed base; got {plant.num_positions()} positions for {n} "
                "joints."
            )
        coulomb = dict(coulomb or {})
        rotor = np.zeros(n)
        from pydrake.multibody.tree import JointActuatorIndex

        for index in range(plant.num_actuators()):
            actuator = plant.get_joint_actuator(JointActuatorIndex(index))
            k = actuator.joint().velocity_start()
            rotor[k] = actuator.default_rotor_inertia() * (
                actuator.default_gear_ratio() ** 2
            )

        names: list[str] = []
        values: list[float] = []
        for j in range(n):
            names += [f"{name}{j + 1}" for name in INERTIAL_NAMES]
            values += list(inertial[j])
            if rotor_inertia:
                names.append(f"IA{j + 1}")
                values.append(rotor[j])
        for j, joint in enumerate(joints):
            for kind in friction:
                names.append(f"{FRICTION_PREFIX[kind]}{j + 1}")
                if kind == "viscous":
                    values.append(float(joint.default_damping_vector()[0]))
                elif kind == "coulomb":
                    values.append(float(coulomb.get(joint.name(), 0.0)))
                else:
                    values.append(0.0)
        standard_values = np.array(values)
        standard_values.setflags(write=False)
        gravity = np.array(plant.gravity_field().gravity_vector(), dtype=float)
        gravity.setflags(write=False)
        model = cls(
            plant=plant,
            path=path,
            joint_names=tuple(joint.name() for joint in joints),
            gravity=gravity,
            friction=friction,
            rotor_inertia=bool(rotor_inertia),
            standard_names=tuple(names),
            standard_values=standard_values,
            base=None,  # type: ignore[arg-type]
            kinematics=kinematics,
            _chain=chain,
            _link_bodies=tuple(joint.child_body() for joint in joints),
            _joint_frames=tuple(joint.frame_on_child() for joint in joints),
        )
        object.__setattr__(model, "base", model._reduce(seed))
        return model

    def _reduce(self, seed: int) -> BaseParameters:
        """Base parameters from IDIM rows at random states (seeded)."""
        rng = np.random.default_rng(seed)
        n = self.num_joints
        p_std = len(self.standard_names)
        num_samples = max(20, math.ceil(4 * p_std / n))
        q = rng.uniform(-np.pi, np.pi, (num_samples, n))
        for j in np.flatnonzero(self._chain.prismatic):
            q[:, j] = rng.uniform(-1.0, 1.0, num_samples)
        v = rng.normal(size=(num_samples, n))
        vdot = rng.normal(size=(num_samples, n))
        rows = self._idim_standard(q, v, vdot).reshape(-1, p_std)
        return base_parameters(rows, self.standard_names)

    # ---------------------------------------------------------------- properties
    @property
    def _block(self) -> int:
        """Standard columns per link: 10 inertial (+ IAj)."""
        return 11 if self.rotor_inertia else 10

    @property
    def num_joints(self) -> int:
        """Number of moving joints n (= positions = velocities)."""
        return len(self.joint_names)

    @property
    def base_names(self) -> tuple[str, ...]:
        """Base parameter names (``self.base.names``)."""
        return self.base.names

    @property
    def base_values(self) -> np.ndarray:
        """Base parameter values from the URDF, θ_base = matrix·θ_std, ``(p,)``."""
        return self.base.values(self.standard_values)

    @property
    def num_parameters(self) -> int:
        """Number of base parameters p."""
        return self.base.num_base

    @property
    def names(self) -> tuple[str, ...]:
        """Column names of the rows (base parameters), as ``Planar2RRows.names``."""
        return self.base.names

    def standard_parameters(self) -> dict[str, float]:
        """Returns ``{standard name: value}``."""
        return dict(
            zip(self.standard_names, self.standard_values.tolist(), strict=True)
        )

    # ------------------------------------------------------------------ kinematics
    def _forward(self, q: np.ndarray):
        if self.kinematics == "numpy":
            return self._chain.forward(q)
        return self._forward_drake(q)

    def _forward_drake(self, q: np.ndarray):
        plant = self.plant
        context = plant.CreateDefaultContext()
        num_samples, n = q.shape
        rotation = np.empty((num_samples, n, 3, 3))
        position = np.empty((num_samples, n, 3))
        screws = np.zeros((num_samples, n, 6))
        for k in range(num_samples):
            plant.SetPositions(context, q[k])
            for j, (body, frame) in enumerate(
                zip(self._link_bodies, self._joint_frames, strict=True)
            ):
                x_wb = plant.EvalBodyPoseInWorld(context, body)
                rotation[k, j] = x_wb.rotation().matrix()
                position[k, j] = x_wb.translation()
                x_wm = frame.CalcPoseInWorld(context)
                axis = x_wm.rotation().matrix() @ self._chain.axis[j]
                if self._chain.prismatic[j]:
                    screws[k, j, 3:] = axis
                else:
                    screws[k, j, :3] = axis
                    screws[k, j, 3:] = np.cross(x_wm.translation(), axis)
        return rotation, position, screws

    def _terms(self, q, v, *, derivatives=False):
        """Per-link spatial quantities shared by the rows (core.rigid_body)."""
        return link_terms(
            self._chain, self._forward(q), v, self.gravity, derivatives=derivatives
        )

    # ------------------------------------------------------- rows, standard columns
    def _assemble(self, inertial: np.ndarray, extra: dict[int, np.ndarray] | None):
        """(..., n_links, 10) inertial blocks (+ IA columns) -> (..., p_std)."""
        n = self.num_joints
        block = self._block
        lead = inertial.shape[:-2]
        out = np.zeros((*lead, len(self.standard_names)))
        body = out[..., : n * block].reshape(*lead, n, block)
        body[..., :10] = inertial
        if extra is not None and self.rotor_inertia:
            body[..., 10] = extra
        return out

    def _friction_slice(self) -> slice:
        return slice(self.num_joints * self._block, None)

    def _energy_standard(self, q, v):
        kinetic, potential = energy_blocks(self._terms(q, v), self.gravity)
        return (
            self._assemble(kinetic, 0.5 * v * v),
            self._assemble(potential, np.zeros_like(v)),
        )

    def _lagrangian_standard(self, q, v):
        n = self.num_joints
        dhe_dv, dhe_dq, dhu_dq = lagrangian_blocks(self._terms(q, v, derivatives=True))
        zero = np.zeros((*v.shape, n))
        return (
            self._assemble(dhe_dv, np.eye(n)[None] * v[:, None, :]),
            self._assemble(dhe_dq, zero),
            self._assemble(dhu_dq, zero),
        )

    def _idim_standard(self, q, v, vdot):
        rows = idim_blocks(self._terms(q, v, derivatives=True), v, vdot)
        out = self._assemble(rows, np.eye(self.num_joints)[None] * vdot[:, None, :])
        out[..., self._friction_slice()] = friction_idim_columns(v, self.friction)
        return out

    def _columns(self, rows: np.ndarray, columns: str) -> np.ndarray:
        if columns == "base":
            return rows[..., list(self.base.independent)]
        if columns == "standard":
            return rows
        raise ValueError(
            f"RobotModel: columns must be one of {', '.join(_COLUMNS)}; got "
            f"{columns!r}."
        )

    def _batches(self, **arrays):
        return as_batches("RobotModel", self.num_joints, **arrays)

    # ---------------------------------------------------------------- public rows
    def energy_rows(self, q, v, *, columns: str = "base") -> np.ndarray:
        """Energy rows h(q, v) = h_E + h_U, shape ``(N, p)``: H = E + U = h·θ [J].

        U is Drake's gravity potential up to a constant (bodies welded to the world
        are not included). Friction columns are zero.
        """
        q, v, single = self._batches(q=q, v=v)
        kinetic, potential = self._energy_standard(q, v)
        out = self._columns(kinetic + potential, columns)
        return out[0] if single else out

    def kinetic_potential_rows(
        self, q, v, *, columns: str = "base"
    ) -> tuple[np.ndarray, np.ndarray]:
        """Returns ``(h_E, h_U)`` separately, each ``(N, p)`` [J per unit]."""
        q, v, single = self._batches(q=q, v=v)
        kinetic, potential = self._energy_standard(q, v)
        out = (self._columns(kinetic, columns), self._columns(potential, columns))
        return (out[0][0], out[1][0]) if single else out

    def momentum_rows(self, q, v, *, columns: str = "base") -> np.ndarray:
        """Generalized-momentum rows ∂h_E/∂v, ``(N, n, p)``: momentum = (∂h_E/∂v)·θ."""
        return self.lagrangian_rows(q, v, columns=columns)[0]

    def lagrangian_rows(
        self, q, v, *, columns: str = "base"
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Returns ``(∂h_E/∂v, ∂h_E/∂q, ∂h_U/∂q)``, each ``(N, n, p)``, exact.

        Lagrange's equations: d/dt(∂h_E/∂v)·θ - ∂h_E/∂q·θ + ∂h_U/∂q·θ + τ_f = τ.
        """
        q, v, single = self._batches(q=q, v=v)
        out = tuple(self._columns(a, columns) for a in self._lagrangian_standard(q, v))
        return tuple(a[0] for a in out) if single else out  # type: ignore[return-value]

    def idim_rows(self, q, v, vdot, *, columns: str = "base") -> np.ndarray:
        """Inverse-dynamics rows W(q, v, v̇), shape ``(N, n, p)``: τ = W·θ [N·m, N].

        Includes gravity and the friction columns v_j, sign v_j, 1 (joint j's row);
        equals ``CalcInverseDynamics`` (gravity as a force element) + friction.
        """
        q, v, vdot, single = self._batches(q=q, v=v, vdot=vdot)
        out = self._columns(self._idim_standard(q, v, vdot), columns)
        return out[0] if single else out

    def power_rows(self, q, v, vdot, *, columns: str = "base") -> np.ndarray:
        """Power rows vᵀW = [d/dt h, friction power], shape ``(N, p)`` [W per unit]."""
        q, v, vdot, single = self._batches(q=q, v=v, vdot=vdot)
        rows = np.einsum("ni,nip->np", v, self._idim_standard(q, v, vdot))
        out = self._columns(rows, columns)
        return out[0] if single else out

    def model_rows(
        self, kind: str, q, v, tau
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Model rows (D, G, y) of docs/CONVENTIONS.md §3 in base columns.

        The modulated equation of the bank is -M_ġ(D)·θ + M_g(G)·θ = M_g(y), from
        d/dt(D·θ) + G·θ = y:

        * ``"power"`` (m = 1): D = h = h_E + h_U, G = friction power
          [v_j², |v_j|, v_j] in the friction columns, y = vᵀτ [W].
        * ``"lagrangian"`` (m = n): D = ∂h_E/∂v, G = ∂h_U/∂q - ∂h_E/∂q + friction
          [v_i, sign v_i, 1] in joint i's columns, y = τ [N·m, N].

        Args:
            kind: ``"power"`` or ``"lagrangian"``.
            q: joint positions ``(N, n)`` [rad, m] (or ``(n,)``).
            v: joint velocities ``(N, n)`` [rad/s, m/s].
            tau: joint torques ``(N, n)`` [N·m, N], generalized-velocity order.

        Returns:
            ``D``, ``G`` of shape ``(N, m, p)`` and ``y`` of shape ``(N, m)``
            (no sample axis for a single sample).
        """
        q, v, tau, single = self._batches(q=q, v=v, tau=tau)
        fslice = slice(
            self.base.independent.index(self._friction_slice().start)
            if self.friction
            else self.num_parameters,
            None,
        )

        def energy():
            kinetic, potential = self._energy_standard(q, v)
            return self._columns(kinetic + potential, "base")

        def lagrangian():
            return tuple(
                self._columns(a, "base") for a in self._lagrangian_standard(q, v)
            )

        if kind not in MODEL_KINDS:
            raise ValueError(
                f"RobotModel: kind must be one of {', '.join(MODEL_KINDS)}; got "
                f"{kind!r}."
            )
        if self.friction:
            self._check_friction_columns()
        out = model_rows_from_parts(
            kind,
            "RobotModel",
            v,
            tau,
            energy,
            lagrangian,
            fslice,
            self.friction,
            self.num_parameters,
        )
        return tuple(a[0] for a in out) if single else out  # type: ignore[return-value]

    def _check_friction_columns(self) -> None:
        start = self._friction_slice().start
        kept = [i for i in self.base.independent if i >= start]
        if kept != list(range(start, len(self.standard_names))):
            raise ValueError(
                "RobotModel: a friction column is not identifiable (all must be); "
                "check the friction kinds."
            )

    # ------------------------------------------------------------ fast 2R provider
    def rows_provider(self, *, tolerance: float = 1e-9) -> Any:
        """Returns the fastest row provider with this model's interface.

        For a robot that matches the paper's 2R arm (two parallel vertical revolute
        axes, base parameters ZZ1R, ZZ2, MX2, MY2 + friction, no rotor inertia) it
        returns ``drake_dynid.core.planar2r.Planar2RRows`` with L1 read from the
        definition of ZZ1R (= ZZ1 + L1²·M2), after checking that its energy and
        inverse-dynamics rows equal this model's at seeded random states; otherwise
        ``self``. Both have ``names``, ``num_parameters`` and ``model_rows(kind, q,
        v, tau)``.
        """
        if self.num_joints != 2 or self.rotor_inertia:
            return self
        if self.base.names[:4] != ("ZZ1R", "ZZ2", "MX2", "MY2"):
            return self
        length_squared = self.base.definitions[0].get("M2", 0.0)
        if length_squared <= 0.0:
            return self
        fast = Planar2RRows(L1=math.sqrt(length_squared), friction=self.friction)
        if fast.names != self.base.names:
            return self
        rng = np.random.default_rng(12345)
        q = rng.uniform(-np.pi, np.pi, (8, 2))
        v = rng.normal(size=(8, 2))
        vdot = rng.normal(size=(8, 2))
        pairs = [
            (fast.idim_rows(q, v, vdot), self.idim_rows(q, v, vdot)),
            (fast.energy_rows(q, v), self.energy_rows(q, v)),
        ]
        for a, b in pairs:
            if not np.allclose(a, b, rtol=tolerance, atol=tolerance):
                return self
        return fast
