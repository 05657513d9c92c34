"""Exact regressor rows of a :class:`drake_dynid.robot.RobotModel`.

:class:`RobotRows` holds the row methods of ``RobotModel`` (a mixin: the data lives
on the model): energy, Lagrangian, inverse-dynamics, power and model rows, in
standard or base columns, vectorised over a leading sample axis. They are computed
on the tree of moving links (``drake_dynid.core.rigid_body``) at q_tree = P q + c,
v_tree = P v, v̇_tree = P v̇ (identified joints, then moving mimic joints;
``drake_dynid.core.joint_map``), and every per-joint row is reduced by Pᵀ:
τ = Pᵀ τ_tree by virtual work. Rotor inertia (IAj) and friction (FVj, FCj, OFFj)
columns exist only for the n identified joints. The coupled motors of a drive chain
add ``IAmk`` (after the links) and ``FVmk FCmk OFFmk`` (after the joint friction),
``drake_dynid.core.drive_columns``; every Coulomb column uses the model's ``sign``.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any

import numpy as np

from drake_dynid.core.batch_rows import (
    BatchRowsPlan,
    batch_idim_rows,
    batch_lagrangian_mean_rows,
)
from drake_dynid.core.friction import friction_idim_columns
from drake_dynid.core.rigid_body import (
    energy_blocks,
    idim_blocks,
    lagrangian_blocks,
    link_terms,
)
from drake_dynid.core.rows import (
    as_batches,
    check_model_kind,
    lagrangian_friction_part,
    model_rows_from_parts,
    pack_rows,
)
from drake_dynid.core.sample_rows import SampleRowsPlan, packed_sample_rows
from drake_dynid.plant_tree import drake_forward
from drake_dynid.robot_plans import base_sources, batch_plan, sample_plan

__all__ = ["RobotRows"]

_COLUMNS = ("base", "standard")


class RobotRows:
    """Row methods of ``RobotModel`` (see the module docstring).

    Uses the model's ``joint_names``, ``links``, ``mimic``, ``gravity``,
    ``friction``, ``sign``, ``rotor_inertia``, ``standard_names``, ``base``,
    ``kinematics``, ``plant`` and its private tree and joint map.
    """

    # Provided by RobotModel (a frozen dataclass).
    base: Any
    friction: tuple[str, ...]
    gravity: np.ndarray
    kinematics: str
    links: tuple[str, ...]
    mimic: Any
    plant: Any
    rotor_inertia: bool
    sign: Any
    standard_names: tuple[str, ...]
    _chain: Any
    _motors: Any
    _joint_frames: tuple[Any, ...]
    _link_bodies: tuple[Any, ...]
    _map: Any
    joint_names: tuple[str, ...]

    # ---------------------------------------------------------------- sizes, maps
    @property
    def _block(self) -> int:
        """Standard columns per identified link: 10 inertial (+ IAj)."""
        return 11 if self.rotor_inertia else 10

    @property
    def num_joints(self) -> int:
        """Number of identified joints n (the length of q, v, τ)."""
        return len(self.joint_names)

    @property
    def num_links(self) -> int:
        """Number of moving links: n identified + the moving mimic joints."""
        return len(self.links)

    @property
    def num_parameters(self) -> int:
        """Number of base parameters p."""
        return self.base.num_base

    def plant_positions(self, q) -> np.ndarray:
        """Plant positions q_full = P q + c, ``(N, plant.num_positions())``.

        Locked joints at their locked positions, mimic joints following their
        leader (``drake_dynid.core.joint_map``) [rad or m].
        """
        q, single = self._batches(q=q)
        out = q @ self._map.matrix.T + self._map.offset
        return out[0] if single else out

    def plant_velocities(self, v) -> np.ndarray:
        """Plant velocities v_full = P v, ``(N, plant.num_velocities())``."""
        v, single = self._batches(v=v)
        out = v @ self._map.matrix.T
        return out[0] if single else out

    # ------------------------------------------------------------------ kinematics
    def _tree_map(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(P, c) of the moving links' joints (None: no moving mimic joint)."""
        if not self.mimic:
            return None
        return self._map.rows(self.links)

    def _to_tree(self, x: np.ndarray, offset: bool = False) -> np.ndarray:
        """Identified coordinates (N, n) -> moving-joint coordinates (N, n_links)."""
        tree = self._tree_map()
        if tree is None:
            return x
        return x @ tree[0].T + (tree[1] if offset else 0.0)

    def _reduce_joints(self, rows: np.ndarray) -> np.ndarray:
        """Per-joint rows (N, n_links, ...) -> (N, n, ...): Pᵀ (virtual work)."""
        tree = self._tree_map()
        if tree is None:
            return rows
        return np.einsum("ti,nt...->ni...", tree[0], rows)

    def _forward(self, q: np.ndarray):
        if self.kinematics == "numpy":
            return self._chain.forward(self._to_tree(q, offset=True))
        return drake_forward(
            self.plant,
            self.plant_positions(q),
            self._link_bodies,
            self._joint_frames,
            self._chain,
        )

    def _terms(self, q, v, *, derivatives=False, vdot=None):
        """Per-link spatial quantities shared by the rows (core.rigid_body)."""
        return link_terms(
            self._chain,
            self._forward(q),
            self._to_tree(v),
            self.gravity,
            derivatives=derivatives,
            vdot=None if vdot is None else self._to_tree(vdot),
        )

    # ------------------------------------------------------- rows, standard columns
    def _assemble(self, inertial: np.ndarray, extra: np.ndarray | None):
        """(..., n_links, 10) inertial blocks (+ IA columns) -> (..., p_std)."""
        n = self.num_joints
        block = self._block
        lead = inertial.shape[:-2]
        out = np.zeros((*lead, len(self.standard_names)))
        body = out[..., : n * block].reshape(*lead, n, block)
        body[..., :10] = inertial[..., :n, :]
        if extra is not None and self.rotor_inertia:
            body[..., 10] = extra
        extra_links = self.num_links - n
        if extra_links:
            start = n * block
            out[..., start : start + 10 * extra_links] = inertial[..., n:, :].reshape(
                *lead, 10 * extra_links
            )
        return out

    def _motor_inertia_slice(self) -> slice:
        """Standard columns ``IAmk`` of the coupled motors (empty without)."""
        start = self.num_joints * self._block + 10 * (self.num_links - self.num_joints)
        width = 0 if self._motors is None else len(self._motors.inertia_names)
        return slice(start, start + width)

    def _friction_slice(self) -> slice:
        """Standard columns of the joint friction (n·len(friction))."""
        start = self._motor_inertia_slice().stop
        return slice(start, start + self.num_joints * len(self.friction))

    def _motor_friction_slice(self) -> slice:
        """Standard columns ``FVmk FCmk OFFmk`` of the coupled motors (to the end)."""
        return slice(self._friction_slice().stop, len(self.standard_names))

    def _energy_standard(self, q, v):
        kinetic, potential = energy_blocks(self._terms(q, v), self.gravity)
        kinetic = self._assemble(kinetic, 0.5 * v * v)
        if self._motors is not None:
            inertia = self._motor_inertia_slice()
            width = inertia.stop - inertia.start
            kinetic[..., inertia] = self._motors.energy_columns(v)[..., :width]
        return kinetic, self._assemble(potential, np.zeros_like(v))

    def _lagrangian_standard(self, q, v):
        n = self.num_joints
        dhe_dv, dhe_dq, dhu_dq = (
            self._reduce_joints(a)
            for a in lagrangian_blocks(self._terms(q, v, derivatives=True))
        )
        zero = np.zeros((*v.shape, n))
        momentum = self._assemble(dhe_dv, np.eye(n)[None] * v[:, None, :])
        if self._motors is not None:
            inertia = self._motor_inertia_slice()
            width = inertia.stop - inertia.start
            momentum[..., inertia] = self._motors.momentum_columns(v)[..., :width]
        return (
            momentum,
            self._assemble(dhe_dq, zero),
            self._assemble(dhu_dq, zero),
        )

    def _idim_standard(self, q, v, vdot):
        rows = idim_blocks(
            self._terms(q, v, derivatives=True, vdot=vdot),
            self._to_tree(v),
            self._to_tree(vdot),
        )
        out = self._assemble(
            self._reduce_joints(rows),
            np.eye(self.num_joints)[None] * vdot[:, None, :],
        )
        out[..., self._friction_slice()] = friction_idim_columns(
            v, self.friction, self.sign
        )
        if self._motors is not None:
            inertia = self._motor_inertia_slice()
            width = inertia.stop - inertia.start
            motors = self._motors.idim_columns(v, vdot)
            out[..., inertia] = motors[..., :width]
            out[..., self._motor_friction_slice()] = motors[..., width:]
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

        Includes gravity and the friction columns v_j, s(v_j), 1 (joint j's row;
        s: the model's ``sign`` law: sign, tanh(v/ε) or a dead zone);
        equals ``CalcInverseDynamics`` (gravity as a force element) + friction.
        """
        q, v, vdot, single = self._batches(q=q, v=v, vdot=vdot)
        if columns == "base" and self._base_sources is not None:
            out = self._idim_base(q, v, vdot)
        else:
            out = self._columns(self._idim_standard(q, v, vdot), columns)
        return out[0] if single else out

    def _idim_base(self, q, v, vdot):
        """:meth:`_idim_standard` in base columns, gathered from the blocks.

        No standard array in between: the same numbers, fewer passes. With numpy
        kinematics and no mimic joint or coupled motor, the fused batch plan
        (``drake_dynid.core.batch_rows``) computes them, equal to round-off.
        """
        plan = self._batch_plan
        if plan is not None:
            return batch_idim_rows(plan, q, v, vdot, self.sign)
        sources = self._base_sources
        assert sources is not None
        inertial_columns, inertial, rotor_columns, rotor, friction_columns = sources
        rows = self._reduce_joints(
            idim_blocks(
                self._terms(q, v, derivatives=True, vdot=vdot),
                self._to_tree(v),
                self._to_tree(vdot),
            )
        )
        num_samples, n = v.shape
        out = np.zeros((num_samples, n, self.num_parameters))
        out[..., inertial_columns] = rows.reshape(num_samples, n, -1)[..., inertial]
        if rotor_columns.size:
            out[:, rotor, rotor_columns] = vdot[:, rotor]
        out[..., friction_columns] = friction_idim_columns(v, self.friction, self.sign)
        return out

    def _lagrangian_base(self, q, v):
        """:meth:`_lagrangian_standard` in base columns, gathered from the blocks.

        As :meth:`_idim_base`: the same numbers without the standard arrays.
        """
        sources = self._base_sources
        if sources is None:
            return tuple(
                self._columns(a, "base") for a in self._lagrangian_standard(q, v)
            )
        inertial_columns, inertial, rotor_columns, rotor, _ = sources
        num_samples, n = v.shape
        out = []
        blocks = lagrangian_blocks(self._terms(q, v, derivatives=True))
        for k, block in enumerate(blocks):
            rows = self._reduce_joints(block).reshape(num_samples, n, -1)
            gathered = np.zeros((num_samples, n, self.num_parameters))
            gathered[..., inertial_columns] = rows[..., inertial]
            if k == 0 and rotor_columns.size:  # ∂h_E/∂v of IA_j v_j²/2
                gathered[:, rotor, rotor_columns] = v[:, rotor]
            out.append(gathered)
        return tuple(out)

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
          [v_i, s(v_i), 1] in joint i's columns, y = τ [N·m, N] (s: :attr:`sign`).

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
        fslice = self._friction_base_slice()

        def energy():
            kinetic, potential = self._energy_standard(q, v)
            return self._columns(kinetic + potential, "base")

        def lagrangian():
            return self._lagrangian_base(q, v)

        check_model_kind("RobotModel", kind)
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
            self.sign,
        )
        if self._motors is not None:
            self._add_motor_friction(kind, v, out[1])
        return tuple(a[0] for a in out) if single else out  # type: ignore[return-value]

    def lagrangian_friction_rows(
        self, v, block: int = 1
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """G's friction part of the Lagrangian rows: ``(columns, values)``.

        ``core.rows.lagrangian_friction_part`` on the joint friction's base columns:
        v (N, n) [rad/s or m/s] -> the columns (k,) and the means of their values
        in G over consecutive blocks of ``block`` samples, (N/block, n, k). None
        with drive motors (their friction columns are added elsewhere,
        ``_add_motor_friction``).
        """
        if self._motors is not None:
            return None
        if self.friction:
            self._check_friction_columns()
        return lagrangian_friction_part(
            np.asarray(v, dtype=float),
            self._friction_base_slice(),
            self.friction,
            self.num_parameters,
            self.sign,
            block,
        )

    def _friction_base_slice(self) -> slice:
        """Base columns of the joint friction (contiguous; empty without)."""
        if not self.friction:
            return slice(self.num_parameters, None)
        first = self.base.independent.index(self._friction_slice().start)
        return slice(first, first + self.num_joints * len(self.friction))

    def mean_packed_rows(self, kind: str, q, v, tau, block: int) -> np.ndarray:
        """Means of the packed rows over consecutive blocks of ``block`` samples.

        ``pack_rows(*model_rows(kind, q, v, tau))`` averaged over samples
        ``k·block .. (k+1)·block - 1`` (the raw rows' boxcar, ``core.raw_rows``),
        shape ``(N/block, 2mp + m)``. The Lagrangian rows are products
        ``S_iᵀ X_bᵀ K`` per sample: with the fused batch plan their block means are
        one matrix product per block (``core.batch_rows.batch_lagrangian_mean_rows``,
        3.4 µs per sample on a 7-DOF arm); otherwise the link blocks of
        ``core.rigid_body.lagrangian_blocks`` are averaged first and gathered into
        base columns once per block. The same numbers to round-off.
        """
        q, v, tau, _ = self._batches(q=q, v=v, tau=tau)
        count = v.shape[0] // block
        plan = self._batch_plan
        if kind == "lagrangian" and plan is not None:  # fused: core.batch_rows
            if self.friction:
                self._check_friction_columns()
            return batch_lagrangian_mean_rows(plan, q, v, tau, block, self.sign)
        sources = self._base_sources
        if kind != "lagrangian" or sources is None or self._motors is not None:
            packed = pack_rows(*self.model_rows(kind, q, v, tau))
            return packed.reshape(count, block, -1).mean(axis=1)
        inertial_columns, inertial, rotor_columns, rotor, _ = sources
        n, p = self.num_joints, self.num_parameters

        def mean(a: np.ndarray) -> np.ndarray:
            return a.reshape(count, block, *a.shape[1:]).mean(axis=1)

        dhe_dv, dhe_dq, dhu_dq = (
            mean(self._reduce_joints(b).reshape(v.shape[0], n, -1))
            for b in lagrangian_blocks(self._terms(q, v, derivatives=True))
        )
        d_rows = np.zeros((count, n, p))
        d_rows[..., inertial_columns] = dhe_dv[..., inertial]
        if rotor_columns.size:
            d_rows[:, rotor, rotor_columns] = mean(v[:, rotor])
        g_rows = np.zeros((count, n, p))
        g_rows[..., inertial_columns] = (dhu_dq - dhe_dq)[..., inertial]
        if self.friction:
            self._check_friction_columns()
            g_rows[..., self._friction_base_slice()] += mean(
                friction_idim_columns(v, self.friction, self.sign)
            )
        return pack_rows(d_rows, g_rows, mean(tau))

    def _add_motor_friction(self, kind: str, v: np.ndarray, g_rows: np.ndarray):
        """Adds the kept motor friction columns to G (base columns), in place.

        A motor friction column that the reduction regrouped (e.g. both motors of a
        differential with the joint friction of both joints) is dropped: its
        model rows are the same combination of the kept ones as its IDIM rows.
        """
        friction = self._motor_friction_slice()
        width = self._motor_inertia_slice().stop - self._motor_inertia_slice().start
        index = {column: k for k, column in enumerate(self.base.independent)}
        _, g_motors = self._motors.model_columns(kind, v)
        for offset, column in enumerate(range(friction.start, friction.stop)):
            if column in index:
                g_rows[..., index[column]] += g_motors[..., width + offset]

    def packed_rows(self, kind: str, q, v, tau) -> np.ndarray:
        """One sample's rows, packed: ``pack_rows(*model_rows(kind, q, v, tau))``.

        The ``ModelRows`` block's per-sample path: q, v, τ of shape (n,), no
        sample axis and no input checks beyond numpy's; computed by the
        precomputed single-sample plan (``drake_dynid.core.sample_rows``) with
        numpy kinematics and the model's Coulomb sign law, else by
        :meth:`model_rows` (Drake kinematics, mimic joints, coupled motors).
        Equal to round-off.
        """
        plan = self._sample_plan
        if plan is None or self._motors is not None:
            d_rows, g_rows, y = self.model_rows(kind, q, v, tau)
            return pack_rows(d_rows, g_rows, y)
        return packed_sample_rows(plan, kind, q, v, tau, self.sign)

    # The fast paths' plans (drake_dynid.robot_plans), built once per model.
    @cached_property
    def _sample_plan(self) -> SampleRowsPlan | None:
        return sample_plan(self)

    @cached_property
    def _batch_plan(self) -> BatchRowsPlan | None:
        return batch_plan(self)

    @cached_property
    def _base_sources(self) -> tuple[np.ndarray, ...] | None:
        return base_sources(self)

    def _check_friction_columns(self) -> None:
        friction = self._friction_slice()
        kept = [i for i in self.base.independent if friction.start <= i < friction.stop]
        if kept != list(range(friction.start, friction.stop)):
            names = self.base.standard_names
            lost = [
                names[i]
                for i in range(friction.start, friction.stop)
                if i not in self.base.independent
            ]
            where = []
            for name in lost:
                into = [
                    base
                    for base, definition in zip(
                        self.base.names, self.base.definitions, strict=True
                    )
                    if definition.get(name, 0.0) != 0.0
                ]
                where.append(
                    f"{name} (regrouped into {', '.join(into)})"
                    if into
                    else f"{name} (not seen)"
                )
            raise ValueError(
                "RobotModel: a friction column is not identifiable (all must be): "
                f"{'; '.join(where)}; leave out that friction kind (--friction) or "
                "the parameter it shares its column with (e.g. a vertical prismatic "
                "joint's offset is its mass's gravity column)."
            )
