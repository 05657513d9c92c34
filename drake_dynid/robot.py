"""The robot description used for identification: parameters and exact regressors.

``RobotModel`` is the immutable description of a fixed-base URDF robot: joint names,
standard parameters read from the URDF, base parameters
(``drake_dynid.core.base_parameters``) and exact regressors (``core.rigid_body``),
vectorised over a leading sample axis.

Standard parameters (Khalil-Kleinfinger names, docs/CONVENTIONS.md §4), per joint j
(1-based, in Drake's generalized-velocity order, which runs along the chain): ``XXj
XYj XZj YYj YZj ZZj`` (inertia tensor entries about the origin of joint j's
child-link frame, in that frame [kg·m²]; ``XYj`` is the tensor entry, i.e. -∫xy dm),
``MXj MYj MZj`` (first moments m·c [kg·m]), ``Mj`` [kg], optional ``IAj`` (rotor
inertia reflected to the joint [kg·m²]), then the friction columns ``FVj FCj OFFj``
of every joint. Bodies welded to a child link are lumped into it; bodies welded to
the world are dropped (their energy is constant).

Identified joints (``joints=``): every other movable joint is locked (at 0 or at the
position given in ``locked=``) and is then a weld, so the bodies beyond it are
lumped like welded ones; a URDF ``<mimic>`` joint follows its leader. The links of
moving mimic joints come after the identified ones (links n+1 …, names ``XXn+1``
…, listed in :attr:`RobotModel.links`); they have no friction or rotor columns.
Rows are computed on the tree of moving joints (identified + mimic) with
q_tree = P q + c, v_tree = P v, v̇_tree = P v̇, and every per-joint row is reduced
by Pᵀ (τ = Pᵀ τ_tree, virtual work; ``drake_dynid.core.joint_map``).

Drive chain (``drive=``, docs/DRIVE.md): motors, gears and coupled joints. Motors
that drive one joint are folded into its ``IAj`` and friction columns; a coupled
motor k adds ``IAmk`` (with rotor inertia) and ``FVmk FCmk OFFmk`` (the friction
kinds), after the links and after the joint friction respectively
(``drake_dynid.robot_drive``).

Coulomb sign (``sign``, ``with_sign``): the friction columns use a pluggable
``drake_dynid.core.friction.SignLaw``, the exact sign by default; on real logs the
commands use a standstill dead zone whose width follows from the log's velocity
noise (``drake_dynid.core.standstill``, docs/MATH.md §2).

The kinematics (poses and screws) come from the joint geometry read from the plant
(``drake_dynid.plant_tree``), either evaluated in numpy over the whole batch
(``kinematics="numpy"``, the default, fast) or from Drake per sample
(``kinematics="drake"``: ``EvalBodyPoseInWorld``); the two agree to round-off.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from drake_dynid.core._validate import listed
from drake_dynid.core.base_parameters import BaseParameters, base_parameters
from drake_dynid.core.drive import DriveChain
from drake_dynid.core.drive_columns import MotorColumns
from drake_dynid.core.friction import (
    EXACT_SIGN,
    ExactSign,
    SignLaw,
    TanhSign,
    check_coulomb_width,
    check_friction,
)
from drake_dynid.core.joint_map import JointMap
from drake_dynid.core.kinematics import KinematicTree
from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.plant_tree import INERTIAL_NAMES, describe_plant
from drake_dynid.robot_drive import (
    drive_table,
    motor_sign,
    rescale_base,
    resolve_drive,
)
from drake_dynid.robot_rows import RobotRows
from drake_dynid.urdf import (
    load_urdf,
    read_urdf_friction,
    read_urdf_mimic,
    untransmitted_note,
)
from drake_dynid.urdf_writer import (
    drive_totals,
    motor_friction,
    totals_words,
    unwritten,
)

__all__ = ["INERTIAL_NAMES", "RobotModel"]

_KINEMATICS = ("numpy", "drake")
_LOGGER = logging.getLogger("drake_dynid")


def _rotor_note(plant: Any, joints: Sequence[str]) -> str:
    """A note naming the identified joints whose actuator has a rotor inertia.

    Drake's plant of the URDF reflects N²·Ia on them (``drake:rotor_inertia``,
    ``drake:gear_ratio``); a model without ``IAj`` columns leaves it out of its
    a-priori values and of the identification ("" when there is none).
    """
    reflected = []
    for index in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(index)
        name = actuator.joint().name()
        value = actuator.default_rotor_inertia() * actuator.default_gear_ratio() ** 2
        if name in joints and value > 0.0:
            unit = "kg" if actuator.joint().type_name() == "prismatic" else "kg·m²"
            reflected.append(f"{name} ({value:.3g} {unit})")
    if not reflected:
        return ""
    return (
        f"the URDF's rotor inertia of {listed(reflected)} is not modelled "
        "without rotor inertia columns (--rotor-inertia)"
    )


@dataclass(frozen=True, eq=False)
class RobotModel(RobotRows):
    """Immutable description of a fixed-base robot for identification.

    Build it with :meth:`from_urdf` (or :meth:`from_plant`). All row methods take
    batches with a leading sample axis, ``q``, ``v``, ``vdot``, ``tau`` of shape
    ``(N, n)`` (or ``(n,)`` for one sample, which drops the sample axis of the
    results), in Drake's generalized-velocity order (``joint_names``), and return
    base-parameter columns (``columns="base"``, default) or standard ones
    (``columns="standard"``). The contract used by the on-line blocks is
    :meth:`model_rows` ``(kind, q, v, tau) -> (D, G, y)``. The rows are
    :class:`drake_dynid.robot_rows.RobotRows`'s.

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
        links: the joint moving each link: ``joint_names``, then the moving mimic
            joints (links n+1 …).
        locked: ``{joint: position [rad or m]}`` for every movable joint of the
            plant that is not identified and does not move (a weld at that
            position; the default position is 0).
        mimic: ``{joint: (leader, multiplier, offset)}`` for the mimic joints that
            move with an identified leader (q = multiplier·q_leader + offset).
        notes: one-line remarks made while loading (joints treated as actuated,
            Drake's parser warnings summarised, an unclear rank decision, drive
            values not modelled).
        drive: the drive chain (``drake_dynid.core.drive.DriveChain``: motors,
            coupling R, log format), or None.
        sign: the Coulomb sign law of every friction column (joints and motors):
            the exact sign by default; see :meth:`with_sign`.
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
    links: tuple[str, ...] = ()
    locked: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    mimic: Mapping[str, tuple[str, float, float]] = field(
        default_factory=lambda: MappingProxyType({})
    )
    notes: tuple[str, ...] = ()
    drive: DriveChain | None = None
    sign: SignLaw = EXACT_SIGN
    _motors: MotorColumns | None = field(repr=False, default=None)
    _map: JointMap = field(repr=False, default=None)  # type: ignore[assignment]
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
        joints: Sequence[str] | None = None,
        locked: Mapping[str, float] | None = None,
        drive: Any = None,
        coulomb_width: float = 0.0,
    ) -> RobotModel:
        """Loads a URDF (see :func:`drake_dynid.urdf.load_plant`) and its parameters.

        Any fixed-base description is accepted: joints without a ``<transmission>``
        are treated as actuated, meshes are not needed (``<visual>`` and
        ``<collision>`` are stripped), Drake's parser warnings are summarised in
        one line of :attr:`notes` (each note is also logged once at INFO on the
        ``drake_dynid`` logger).

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
            joints: the identified joints (any order; kept in the plant's order);
                default every movable joint that is not a mimic and not locked.
            locked: ``{joint: position [rad or m]}`` for joints that are not
                identified; the other ones are locked at 0. A mimic joint follows
                its leader (``<mimic>``: q = multiplier·q_leader + offset).
            drive: the drive chain: a TOML drive file (resolved against the URDF's
                ``<transmission>`` elements, docs/DRIVE.md) or a ``DriveChain``
                of the identified joints; None (default): no motor model (the URDF
                transmissions give only the ``IAj`` values).
            coulomb_width: ε >= 0 of a smooth Coulomb law s(v) = tanh(v/ε) of the
                friction columns [rad/s or m/s] (``with_sign(TanhSign(ε))``); 0
                (default): the exact sign.

        Raises:
            ValueError: the loader's errors, an unknown joint name (the message
                lists the movable joints), a joint both identified and locked, a
                mimic joint identified or locked on its own, a drive file that does
                not match the URDF (the message names the field).
        """
        loaded = load_urdf(path, time_step, gravity=gravity)
        # The note on joints without a <transmission> is from_plant's: it names
        # only the joints the drive chain (once resolved) does not drive.
        untransmitted = (loaded.untransmitted, loaded.untransmitted_limited)
        own = untransmitted_note(*untransmitted)
        notes = tuple(note for note in loaded.notes if note != own)
        for note in notes:
            _LOGGER.info("RobotModel: %s.", note)
        # A file dynid --urdf-out wrote with a drive file holds the joint-side
        # totals: read as they are, the same drive file adds nothing again.
        totals: frozenset[str] = frozenset()
        missing: frozenset[str] = frozenset()
        if drive is not None:
            text = Path(path).read_text(encoding="utf-8", errors="replace")
            totals, missing = drive_totals(text), unwritten(text)
        model = cls.from_plant(
            loaded.plant,
            friction=friction,
            rotor_inertia=rotor_inertia,
            coulomb=read_urdf_friction(path),
            kinematics=kinematics,
            seed=seed,
            path=str(path),
            joints=joints,
            locked=locked,
            mimic=read_urdf_mimic(path),
            notes=notes,
            drive=drive,
            coulomb_width=coulomb_width,
            untransmitted=untransmitted,
            totals=totals,
            unwritten=missing,
        )
        if model.drive is not None and totals:
            frictions = [k for k in ("viscous", "coulomb") if k in totals]
            given = rotor_inertia and any(
                not motor.coupled and motor.rotor_inertia is not None
                for motor in model.drive.motors
            )
            kept = [
                *(
                    ["the drive file's motor friction is not added to them again"]
                    if frictions and motor_friction(model.drive, frictions)
                    else []
                ),
                *(
                    ["its rotor inertia does not replace them"]
                    if "inertia" in totals and given
                    else []
                ),
            ]
            if kept:
                note = (
                    f"{Path(path).name} was written by dynid --urdf-out with a drive "
                    f"file: its joint {totals_words(totals)} are joint-side "
                    f"totals, the motors' reflected values included, read as they are "
                    f"({'; '.join(kept)})"
                )
                _LOGGER.info("RobotModel: %s.", note)
                object.__setattr__(model, "notes", (*model.notes, note))
        return model

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
        joints: Sequence[str] | None = None,
        locked: Mapping[str, float] | None = None,
        mimic: Mapping[str, tuple[str, float, float]] | None = None,
        notes: Sequence[str] = (),
        drive: Any = None,
        coulomb_width: float = 0.0,
        untransmitted: tuple[Sequence[str], Collection[str]] = ((), ()),
        totals: Collection[str] = (),
        unwritten: Collection[str] = (),
    ) -> RobotModel:
        """Builds the description of a finalized fixed-base plant.

        ``coulomb`` maps joint names to Coulomb friction values (Drake does not
        store them); the viscous values are the joints' default damping.
        ``joints``, ``locked`` and ``mimic`` (``{joint: (leader, multiplier,
        offset)}``, see :func:`drake_dynid.urdf.read_urdf_mimic`) choose the
        identified joints as in :meth:`from_urdf`; ``coulomb_width`` as there.
        ``untransmitted``: (joints without a ``<transmission>``, those of them with
        an effort limit) whose note (``urdf.untransmitted_note``) the caller left to
        this method: with a drive chain it names the joints the chain does not
        drive. ``totals``: the kinds among ``"viscous"``, ``"coulomb"``,
        ``"inertia"`` whose plant values already hold a drive chain's reflected
        values (``urdf_writer.drive_totals``; ``robot_drive.drive_table``);
        ``unwritten``: the standard names such a file does not hold
        (``urdf_writer.unwritten``).
        """
        owner = "RobotModel"
        friction = check_friction(owner, friction)
        coulomb_width = check_coulomb_width(owner, coulomb_width)
        if kinematics not in _KINEMATICS:
            raise ValueError(
                f"{owner}: kinematics must be one of {', '.join(_KINEMATICS)}; got "
                f"{kinematics!r}."
            )
        tree = describe_plant(
            owner,
            plant,
            joints=joints,
            locked=locked,
            mimic=mimic,
            friction=friction,
            rotor_inertia=rotor_inertia,
            coulomb=coulomb,
        )
        jmap, moving = tree.joint_map, tree.moving
        n = len(jmap.names)
        chain = resolve_drive(
            drive,
            path,
            jmap.names,
            [bool(p) for p in tree.chain.prismatic[:n]],
        )
        names, values = tree.standard_names, tree.standard_values
        scales = None
        notes = tuple(notes)
        motors = None
        if chain is not None:
            table = drive_table(
                chain,
                names,
                values,
                num_joints=n,
                rotor_inertia=bool(rotor_inertia),
                friction=friction,
                totals=totals,
                unwritten=unwritten,
            )
            names, values, scales = table.names, table.values, table.scales
            motors = table.columns
            notes += tuple(chain.notes) + table.notes
        # The joints a motor of the drive file (or the URDF) drives; a joint
        # left with its implicit direct drive is as untransmitted as without one.
        # A locked joint is welded: whether it is actuated does not matter.
        driven = (
            set()
            if chain is None
            else {
                chain.joint_names[j]
                for motor in chain.motors
                if motor.source != "implicit"
                for j in np.flatnonzero(motor.row)
            }
        )
        if chain is None and not rotor_inertia:  # a drive chain notes its own
            unmodelled = _rotor_note(plant, jmap.names)
            if unmodelled:
                notes += (unmodelled,)
        left = untransmitted_note(
            [
                name
                for name in untransmitted[0]
                if name not in driven and name in jmap.names
            ],
            untransmitted[1],
        )
        if left:
            _LOGGER.info("RobotModel: %s.", left)
            notes = (left, *notes)
        gravity = np.array(plant.gravity_field().gravity_vector(), dtype=float)
        gravity.setflags(write=False)
        model = cls(
            plant=plant,
            path=path,
            joint_names=jmap.names,
            gravity=gravity,
            friction=friction,
            rotor_inertia=bool(rotor_inertia),
            standard_names=names,
            standard_values=values,
            base=None,  # type: ignore[arg-type]
            kinematics=kinematics,
            links=jmap.moving,
            locked=jmap.locked,
            mimic=jmap.mimic,
            notes=notes,
            drive=chain,
            _motors=motors,
            _map=jmap,
            _chain=tree.chain,
            _link_bodies=tuple(joint.child_body() for joint in moving),
            _joint_frames=tuple(joint.frame_on_child() for joint in moving),
        )
        base = model._reduce(seed, scales)
        object.__setattr__(model, "base", base)
        if not base.clear:
            note = (
                f"the base-parameter rank decision is not clear (|R_kk| kept/dropped "
                f"{base.smallest_kept:.2g}/{base.largest_dropped:.2g}, singular "
                f"values {base.singular_kept:.2g}/{base.singular_dropped:.2g}); "
                "check the description for a near-singular geometry"
            )
            _LOGGER.info("RobotModel: %s.", note)
            object.__setattr__(model, "notes", (*model.notes, note))
        if coulomb_width > 0.0:
            return model.with_sign(TanhSign(coulomb_width))
        return model

    def _reduce(self, seed: int, scales: Any = None) -> BaseParameters:
        """Base parameters from IDIM rows at random states (seeded).

        Rows: inverse dynamics with gravity and friction at ``max(20, 4 p_std / n)``
        states, q uniform in ±π rad (prismatic: ±1 m), q̇ and q̈ standard normal
        [rad/s, rad/s², m/s, m/s²], no row weighting; the rank decision is
        relative to the largest column (``drake_dynid.core.base_parameters``).
        Motor columns are divided by ``scales`` for the decision and mapped back
        (``drake_dynid.robot_drive.rescale_base``).
        """
        rng = np.random.default_rng(seed)
        n = self.num_joints
        p_std = len(self.standard_names)
        num_samples = max(20, math.ceil(4 * p_std / n))
        q = rng.uniform(-np.pi, np.pi, (num_samples, n))
        for j in np.flatnonzero(self._chain.prismatic[:n]):
            q[:, j] = rng.uniform(-1.0, 1.0, num_samples)
        v = rng.normal(size=(num_samples, n))
        vdot = rng.normal(size=(num_samples, n))
        rows = self._idim_standard(q, v, vdot).reshape(-1, p_std)
        if not np.all(np.isfinite(rows)):  # products of lengths, masses overflow
            raise ValueError(
                f"RobotModel: the regressor of {self.path or 'the plant'} overflows "
                "at ordinary joint states (|q| <= pi, unit speeds): a joint "
                "<origin>, <axis> or link <inertial> value too large for float64 "
                "(above about 1e100); fix the URDF."
            )
        if scales is None:
            return base_parameters(rows, self.standard_names)
        base = base_parameters(rows / scales, self.standard_names)
        return rescale_base(base, scales)

    # ---------------------------------------------------------------- properties
    @property
    def base_names(self) -> tuple[str, ...]:
        """Base parameter names (``self.base.names``)."""
        return self.base.names

    @property
    def base_values(self) -> np.ndarray:
        """Base parameter values from the URDF, θ_base = matrix·θ_std, ``(p,)``."""
        return self.base.values(self.standard_values)

    @property
    def names(self) -> tuple[str, ...]:
        """Column names of the rows (base parameters), as ``Planar2RRows.names``."""
        return self.base.names

    @property
    def prismatic(self) -> tuple[bool, ...]:
        """(n,) True for a prismatic identified joint [m], False for revolute [rad]."""
        return tuple(bool(p) for p in self._chain.prismatic[: self.num_joints])

    @property
    def plant_joint_names(self) -> tuple[str, ...]:
        """Every movable joint of ``plant``, in its position order."""
        return self._map.movable

    def standard_parameters(self) -> dict[str, float]:
        """Returns ``{standard name: value}``."""
        return dict(
            zip(self.standard_names, self.standard_values.tolist(), strict=True)
        )

    @property
    def motor_columns(self) -> MotorColumns | None:
        """The coupled motors' columns, or None without a coupled motor.

        ``core.drive_columns.MotorColumns``, with their Coulomb law (:meth:`with_sign`).
        """
        return self._motors

    @property
    def coulomb_width(self) -> float:
        """ε of a smooth Coulomb law tanh(v/ε) [rad/s or m/s]; 0 for any other law."""
        return self.sign.width if isinstance(self.sign, TanhSign) else 0.0

    def with_sign(self, sign: SignLaw | None) -> RobotModel:
        """A copy whose friction columns use the Coulomb law ``sign``.

        ``sign`` is a ``drake_dynid.core.friction.SignLaw`` (``DeadZoneSign`` with
        one width per joint for real logs, see ``drake_dynid.core.standstill``);
        None is the exact sign. Coupled motors use it on u_k/ρ_k (per-joint
        dead-zone widths combine per motor). The base parameters are unchanged.
        """
        sign = EXACT_SIGN if sign is None else sign
        if not isinstance(sign, SignLaw):
            raise TypeError(
                "RobotModel: sign must be a SignLaw (a vectorised __call__ and a "
                f"scalar method) or None; got {type(sign).__name__}."
            )
        motors = self._motors
        if motors is not None:
            motors = dataclasses.replace(motors, sign=motor_sign(sign, motors))
        return dataclasses.replace(self, sign=sign, _motors=motors)

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
        if self.num_joints != 2 or self.rotor_inertia or self.mimic:
            return self
        if self.drive is not None or not isinstance(self.sign, (ExactSign, TanhSign)):
            return self
        if self.base.names[:4] != ("ZZ1R", "ZZ2", "MX2", "MY2"):
            return self
        length_squared = self.base.definitions[0].get("M2", 0.0)
        if length_squared <= 0.0:
            return self
        fast = Planar2RRows(
            L1=math.sqrt(length_squared),
            friction=self.friction,
            coulomb_width=self.coulomb_width,
        )
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
