"""URDF robots: Drake plants, standard and base parameters, numeric regressors.

``load_plant`` turns a URDF into a finalized ``MultibodyPlant`` and checks that
drake_dynid can handle it (fixed base; revolute, prismatic and fixed joints; at least
one actuator). ``RobotModel`` is the immutable robot description used by the
identification blocks: joint names, standard parameters read from the URDF, base
parameters (``drake_dynid.core.base_parameters``) and exact regressors, vectorised
over a leading sample axis.

Standard parameters (Khalil-Kleinfinger names, MATH.md §2), per joint j (1-based, in
Drake's generalized-velocity order, which runs along the chain): ``XXj XYj XZj YYj
YZj ZZj`` (inertia tensor entries about the origin of joint j's child-link frame, in
that frame [kg·m²]; ``XYj`` is the tensor entry, i.e. -∫xy dm), ``MXj MYj MZj`` (first
moments m·c [kg·m]), ``Mj`` [kg], optional ``IAj`` (rotor inertia reflected to the
joint [kg·m²]), then the friction columns ``FVj FCj OFFj`` of every joint. Bodies
welded to a child link are lumped into it; bodies welded to the world are dropped
(their energy is constant).

Regressors. For link b with pose X_WB = (R, p), body-frame twist V_b = [ω; v_o] and the
6×10 momentum map K(V) (M(θ_b)·V = K(V)·θ_b, θ_b = [XX XY XZ YY YZ ZZ MX MY MZ M])::

    E_b = ½ V_bᵀ K(V_b) θ_b = ½ m v_o·v_o + (m c)·(v_o × ω) + ½ ωᵀ I_o ω      [J]
    U_b = -m g·p - g·(R m c)                                                 [J]

With world-frame joint screws S_i (revolute: [a; p_joint × a], prismatic: [0; a]),
J_b,i = Ad(X_WB⁻¹) S_i for every joint i on the path of b, and the screw identity
∂S_j/∂q_i = ad(S_i) S_j (i ancestor of j)::

    ∂E_b/∂v_i = J_b,iᵀ K(V_b) θ_b
    ∂E_b/∂q_i = (Ad(X_WB⁻¹) ad(V_parent(i)) S_i)ᵀ K(V_b) θ_b
    ∂U_b/∂q_i = -J_b,iᵀ K([0; Rᵀg]) θ_b
    τ_i = Σ_b J_b,iᵀ [K(V̇_b - [0; Rᵀg]) - ad(V_b)ᵀ K(V_b)] θ_b      (Newton-Euler)

all exact (no finite differences). The kinematics (poses and screws) come from the
joint geometry read from the plant, either evaluated in numpy over the whole batch
(``kinematics="numpy"``, the default, fast) or from Drake per sample
(``kinematics="drake"``: ``EvalBodyPoseInWorld``); the two agree to round-off.
"""

from __future__ import annotations

import logging
import math
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.base_parameters import BaseParameters, base_parameters
from drake_dynid.core.planar2r import (
    FRICTION_PREFIX,
    MODEL_KINDS,
    Planar2RRows,
    as_batches,
    check_friction,
    friction_idim_columns,
    model_rows_from_parts,
)

__all__ = [
    "INERTIAL_NAMES",
    "MODELS_DIR",
    "RobotModel",
    "load_plant",
    "model_path",
    "read_urdf_friction",
]

#: The 10 inertial parameters of one link, in Khalil's (and the preferred) order.
INERTIAL_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")

#: Directory of the URDF robots shipped with drake_dynid.
MODELS_DIR = Path(__file__).resolve().parent / "models"

_SUPPORTED_JOINTS = ("revolute", "prismatic", "weld")
_FRICTION_WARNING = "does not currently support non-zero joint friction"


def model_path(name: str) -> str:
    """Returns the path of a URDF robot shipped with drake_dynid.

    Args:
        name: the model name without extension, e.g. ``"planar_2r"`` (the paper's
            2R arm) or ``"ur5"``.

    Raises:
        ValueError: no such model (the message lists the available ones).
    """
    path = MODELS_DIR / f"{name}.urdf"
    if not isinstance(name, str) or not path.is_file():
        available = ", ".join(sorted(p.stem for p in MODELS_DIR.glob("*.urdf")))
        raise ValueError(
            f"model_path: name must be one of the packaged models ({available}); "
            f"got {name!r}."
        )
    return str(path)


def _check_file(owner: str, path: Any) -> Path:
    if not isinstance(path, (str, Path)):
        raise TypeError(f"{owner}: path must be a str or Path; got {type(path)}.")
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"{owner}: URDF file not found: {file}.")
    return file


def _read_urdf(owner: str, file: Path) -> Any:
    try:
        return ElementTree.parse(file).getroot()
    except ElementTree.ParseError as error:
        raise ValueError(f"{owner}: {file} is not well-formed XML: {error}.") from None


_URDF_JOINTS = ("revolute", "continuous", "prismatic", "fixed")


def read_urdf_friction(path: str | Path) -> dict[str, float]:
    """Returns ``{joint name: Coulomb friction [N·m or N]}`` from URDF ``<dynamics>``.

    Drake ignores the ``friction`` attribute of ``<dynamics>`` (it warns), so it is
    read here. Joints without it are absent from the result.

    Raises:
        ValueError: the file is missing, is not XML, or has a non-numeric value.
    """
    file = _check_file("read_urdf_friction", path)
    root = _read_urdf("read_urdf_friction", file)
    out: dict[str, float] = {}
    for joint in root.iter("joint"):
        dynamics = joint.find("dynamics")
        if dynamics is None or "friction" not in dynamics.attrib:
            continue
        text = dynamics.attrib["friction"]
        try:
            out[joint.attrib.get("name", "")] = float(text)
        except ValueError:
            raise ValueError(
                f"read_urdf_friction: joint {joint.attrib.get('name')!r} in {file} "
                f"has a non-numeric friction {text!r}."
            ) from None
    return out


class _DropFrictionWarning(logging.Filter):
    """Drops Drake's warning that URDF joint friction is ignored (we read it)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return _FRICTION_WARNING not in record.getMessage()


def load_plant(
    path: str | Path,
    time_step: float = 0.0,
    *,
    builder: Any = None,
    gravity: Sequence[float] | None = None,
    weld_root: bool = True,
    sampled_output_ports: bool = False,
) -> Any:
    """Loads a URDF robot into a finalized ``MultibodyPlant``.

    Args:
        path: the URDF file.
        time_step: plant period [s]; 0.0 gives a continuous plant, > 0 a discrete
            one (drake_dynid's simulations use 1e-3).
        builder: optional ``DiagramBuilder``; when given the plant is added with
            ``AddMultibodyPlantSceneGraph`` (so it has a SceneGraph).
        gravity: gravity vector in the world [m/s²]; default Drake's (0, 0, -9.81).
        weld_root: weld a root link that has no joint to the world (a URDF without a
            ``world`` link) at the world origin, as fixed-base arms are described.
            With False such a link is a floating base, which is rejected.
        sampled_output_ports: for a discrete plant, keep Drake's default sampled
            output ports (True) or use live ones (False, drake_dynid's default).
            With sampled ports (pydrake 1.51), a discrete-update handler at t_k that
            reads the plant's state port sees the post-step state x_{k+1}, while a
            logger at t_k sees x_k: the identification blocks would then pair
            q_{k+1} with the torque computed from x_k. Live ports give every block
            x_k at t_k (docs/CONVENTIONS.md §2; tested).

    Returns:
        The finalized plant. Its joint ``friction`` attributes are ignored by Drake:
        read them with :func:`read_urdf_friction` and apply them with
        ``drake_dynid.systems.friction.JointFriction``.

    Raises:
        ValueError: missing or malformed file, a floating base, a joint other than
            revolute, prismatic or fixed, or no actuated joint.
    """
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant

    owner = "load_plant"
    file = _check_file(owner, path)
    time_step = _validate.real(owner, "time_step", time_step, "s")
    if time_step < 0.0:
        raise ValueError(f"{owner}: time_step must be >= 0 [s]; got {time_step}.")
    if file.suffix.lower() == ".urdf":
        for joint in _read_urdf(owner, file).iter("joint"):
            kind = joint.attrib.get("type", "")
            if joint.find("parent") is not None and kind not in _URDF_JOINTS:
                raise ValueError(
                    f"{owner}: joint {joint.attrib.get('name')!r} of {file} has type "
                    f"{kind!r}; only revolute, continuous, prismatic and fixed joints "
                    "are supported (no floating, planar or ball joints)."
                )
    if builder is None:
        plant = MultibodyPlant(time_step)
    else:
        plant, _ = AddMultibodyPlantSceneGraph(builder, time_step)
    if time_step > 0.0:
        plant.SetUseSampledOutputPorts(bool(sampled_output_ports))
    drake_logger = logging.getLogger("drake")
    quiet = _DropFrictionWarning()
    drake_logger.addFilter(quiet)
    try:
        instances = Parser(plant).AddModels(str(file))
    except RuntimeError as error:
        message = str(error).strip().splitlines()[0] if str(error).strip() else ""
        raise ValueError(
            f"{owner}: could not parse {file}: {message}. Fix the URDF (valid XML, "
            "every joint's parent and child links defined)."
        ) from None
    finally:
        drake_logger.removeFilter(quiet)
    if gravity is not None:
        g = _validate.array(owner, "gravity", gravity, shape=(3,))
        plant.mutable_gravity_field().set_gravity_vector(g)

    from pydrake.multibody.tree import JointIndex

    joints = [plant.get_joint(JointIndex(i)) for i in range(plant.num_joints())]
    children = {joint.child_body().index() for joint in joints}
    roots = [
        plant.get_body(index)
        for instance in instances
        for index in plant.GetBodyIndices(instance)
        if index not in children and index != plant.world_body().index()
    ]
    if roots and not weld_root:
        raise ValueError(
            f"{owner}: link {roots[0].name()!r} of {file} has no joint to the world "
            "(a floating base), which is not supported; add a 'world' link and a "
            "fixed joint, or pass weld_root=True."
        )
    if len(roots) > 1:
        raise ValueError(
            f"{owner}: {file} has {len(roots)} root links "
            f"({', '.join(b.name() for b in roots)}); a fixed-base robot has one."
        )
    for body in roots:
        plant.WeldFrames(plant.world_frame(), body.body_frame())
    plant.Finalize()
    for index in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(index))
        kind = joint.type_name()
        if kind not in _SUPPORTED_JOINTS:
            raise ValueError(
                f"{owner}: joint {joint.name()!r} of {file} has type {kind!r}; only "
                "revolute (and continuous), prismatic and fixed joints are supported "
                "(no floating, ball or planar joints)."
            )
    if plant.num_actuators() == 0:
        raise ValueError(
            f"{owner}: {file} has no actuated joint; add a <transmission> per joint "
            "(drake_dynid identifies actuated robots)."
        )
    return plant


# ----------------------------------------------------------------------------------
# Numeric kinematic structure and vectorised spatial algebra.


def _pose_matrix(transform: Any) -> np.ndarray:
    return np.asarray(transform.GetAsMatrix4(), dtype=float)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product along the last axis (faster than np.cross for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), -1)


def _ad(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Lie bracket of twists [ω; v]: ad(x) y = [ωx × ωy; ωx × vy + vx × ωy]."""
    wx, vx = x[..., :3], x[..., 3:]
    wy, vy = y[..., :3], y[..., 3:]
    return np.concatenate((_cross(wx, wy), _cross(wx, vy) + _cross(vx, wy)), -1)


def _ad_inverse(rotation: np.ndarray, position: np.ndarray, twist: np.ndarray):
    """Ad(X_WB⁻¹) of world twists [ω; v_O]: [Rᵀω; Rᵀ(v_O + ω × p)] (body frame)."""
    w, v = twist[..., :3], twist[..., 3:]
    rt = np.swapaxes(rotation, -1, -2)
    wb = np.einsum("...ij,...j->...i", rt, w)
    vb = np.einsum("...ij,...j->...i", rt, v + _cross(w, position))
    return np.concatenate((wb, vb), -1)


def momentum_matrix(twist: np.ndarray) -> np.ndarray:
    """K(V), shape (..., 6, 10): spatial momentum M(θ_b)·V = K(V)·θ_b.

    θ_b = [XX XY XZ YY YZ ZZ MX MY MZ M], V = [ω; v_o] (body frame):
    angular = I_o ω + (m c) × v_o, linear = m v_o + ω × (m c).
    """
    w0, w1, w2 = twist[..., 0], twist[..., 1], twist[..., 2]
    u0, u1, u2 = twist[..., 3], twist[..., 4], twist[..., 5]
    out = np.zeros((*twist.shape[:-1], 6, 10))
    out[..., 0, 0] = w0
    out[..., 0, 1] = w1
    out[..., 1, 1] = w0
    out[..., 0, 2] = w2
    out[..., 2, 2] = w0
    out[..., 1, 3] = w1
    out[..., 1, 4] = w2
    out[..., 2, 4] = w1
    out[..., 2, 5] = w2
    # (m c) × v_o in the angular rows; ω × (m c) in the linear rows.
    out[..., 1, 6], out[..., 2, 6] = -u2, u1
    out[..., 4, 6], out[..., 5, 6] = w2, -w1
    out[..., 0, 7], out[..., 2, 7] = u2, -u0
    out[..., 3, 7], out[..., 5, 7] = -w2, w0
    out[..., 0, 8], out[..., 1, 8] = -u1, u0
    out[..., 3, 8], out[..., 4, 8] = w1, -w0
    out[..., 3, 9] = u0
    out[..., 4, 9] = u1
    out[..., 5, 9] = u2
    return out


def _ad_transpose_momentum(twist: np.ndarray, k: np.ndarray) -> np.ndarray:
    """-ad(V)ᵀ applied to each column [n; f] of k: [ω × n + v × f; ω × f]."""
    w = twist[..., None, :3]
    v = twist[..., None, 3:]
    n = np.swapaxes(k[..., :3, :], -1, -2)
    f = np.swapaxes(k[..., 3:, :], -1, -2)
    out = np.concatenate((_cross(w, n) + _cross(v, f), _cross(w, f)), -1)
    return np.swapaxes(out, -1, -2)


def _rotation_about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: R = I + sin(θ)[a]× + (1 - cos θ)[a]×², shape (N, 3, 3)."""
    skew = np.array(
        [[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]]
    )
    s = np.sin(angle)[:, None, None]
    c = np.cos(angle)[:, None, None]
    return np.eye(3) + s * skew + (1.0 - c) * (skew @ skew)


@dataclass(frozen=True, eq=False)
class _Chain:
    """Numeric joint geometry of a fixed-base tree (one link per moving joint).

    Joint j (velocity order) connects parent link ``parent[j]`` (-1: the world
    group) to link j. ``X_parent_F[j]``: pose of the joint frame F in the parent
    link frame (or in the world); ``X_M_B[j]``: pose of link j's frame in the
    joint's child frame M; ``axis[j]`` in F (= in M); ``prismatic[j]``.
    ``ancestors[b, i]``: joint i is on the path from the world to link b (b
    included).
    """

    parent: np.ndarray
    X_parent_F: np.ndarray
    X_M_B: np.ndarray
    axis: np.ndarray
    prismatic: np.ndarray
    ancestors: np.ndarray
    order: tuple[int, ...]

    def forward(self, q: np.ndarray):
        """Link poses and world joint screws: R (N,n,3,3), p (N,n,3), S (N,n,6)."""
        num_samples, n = q.shape
        rotation = np.empty((num_samples, n, 3, 3))
        position = np.empty((num_samples, n, 3))
        screws = np.empty((num_samples, n, 6))
        for j in self.order:
            xpf = self.X_parent_F[j]
            parent = self.parent[j]
            if parent < 0:
                rf = np.broadcast_to(xpf[:3, :3], (num_samples, 3, 3))
                pf = np.broadcast_to(xpf[:3, 3], (num_samples, 3))
            else:
                rp, pp = rotation[:, parent], position[:, parent]
                rf = rp @ xpf[:3, :3]
                pf = pp + rp @ xpf[:3, 3]
            axis = rf @ self.axis[j]
            if self.prismatic[j]:
                rm = rf
                pm = pf + axis * q[:, j, None]
                screws[:, j, :3] = 0.0
                screws[:, j, 3:] = axis
            else:
                rm = rf @ _rotation_about(self.axis[j], q[:, j])
                pm = pf
                screws[:, j, :3] = axis
                screws[:, j, 3:] = _cross(pm, axis)
            xmb = self.X_M_B[j]
            rotation[:, j] = rm @ xmb[:3, :3]
            position[:, j] = pm + rm @ xmb[:3, 3]
        return rotation, position, screws


def _extract_chain(plant: Any):
    """Reads the joint geometry and the lumped link inertias from a plant.

    Returns:
        ``(chain, joints, inertial)`` with ``joints`` the moving joints in velocity
        order and ``inertial`` the ``(n, 10)`` standard inertial values.
    """
    from pydrake.multibody.tree import JointIndex

    all_joints = [plant.get_joint(JointIndex(i)) for i in range(plant.num_joints())]
    moving = sorted(
        (j for j in all_joints if j.type_name() != "weld"),
        key=lambda j: j.velocity_start(),
    )
    n = len(moving)
    link_of_joint = {joint.index(): k for k, joint in enumerate(moving)}
    by_parent: dict[Any, list[Any]] = {}
    for joint in all_joints:
        by_parent.setdefault(joint.parent_body().index(), []).append(joint)

    world = plant.world_body().index()
    # group[body] = (link index or -1 for the world, X_link_body 4×4)
    group: dict[Any, tuple[int, np.ndarray]] = {world: (-1, np.eye(4))}
    parent = np.full(n, -1)
    x_parent_f = np.zeros((n, 4, 4))
    x_m_b = np.zeros((n, 4, 4))
    axis = np.zeros((n, 3))
    prismatic = np.zeros(n, dtype=bool)
    queue = [world]
    order: list[int] = []
    while queue:
        body = queue.pop(0)
        link, x_link_body = group[body]
        for joint in by_parent.get(body, []):
            child = joint.child_body().index()
            x_p_f = _pose_matrix(joint.frame_on_parent().GetFixedPoseInBodyFrame())
            x_c_m = _pose_matrix(joint.frame_on_child().GetFixedPoseInBodyFrame())
            if joint.type_name() == "weld":
                x_p_c = x_p_f @ _pose_matrix(joint.X_FM()) @ np.linalg.inv(x_c_m)
                group[child] = (link, x_link_body @ x_p_c)
            else:
                k = link_of_joint[joint.index()]
                parent[k] = link
                x_parent_f[k] = x_link_body @ x_p_f
                x_m_b[k] = np.linalg.inv(x_c_m)
                if joint.type_name() == "prismatic":
                    axis[k] = joint.translation_axis()
                    prismatic[k] = True
                else:
                    axis[k] = joint.revolute_axis()
                group[child] = (k, np.eye(4))
                order.append(k)
            queue.append(child)

    ancestors = np.zeros((n, n), dtype=bool)
    for b in range(n):
        i = b
        while i >= 0:
            ancestors[b, i] = True
            i = parent[i]

    from pydrake.math import RigidTransform, RotationMatrix

    inertial = np.zeros((n, 10))
    for body_index, (link, x_link_body) in group.items():
        if link < 0:
            continue
        body = plant.get_body(body_index)
        spatial = body.default_spatial_inertia()
        if math.isnan(spatial.get_mass()) or spatial.get_mass() == 0.0:
            continue
        transform = RigidTransform(x_link_body)
        spatial = spatial.ReExpress(RotationMatrix(transform.rotation())).Shift(
            -transform.translation()
        )
        mass = spatial.get_mass()
        first_moment = mass * np.asarray(spatial.get_com())
        inertia = spatial.CalcRotationalInertia().CopyToFullMatrix3()
        inertial[link] += [
            inertia[0, 0],
            inertia[0, 1],
            inertia[0, 2],
            inertia[1, 1],
            inertia[1, 2],
            inertia[2, 2],
            *first_moment,
            mass,
        ]
    chain = _Chain(
        parent=parent,
        X_parent_F=x_parent_f,
        X_M_B=x_m_b,
        axis=axis,
        prismatic=prismatic,
        ancestors=ancestors,
        order=tuple(order),
    )
    for array in (parent, x_parent_f, x_m_b, axis, prismatic, ancestors):
        array.setflags(write=False)
    return chain, moving, inertial


# ----------------------------------------------------------------------------------
# The robot description.

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
    _chain: _Chain = field(repr=False, default=None)  # type: ignore[assignment]
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
        chain, joints, inertial = _extract_chain(plant)
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

    def _terms(self, q, v, vdot=None, *, derivatives=False):
        """Per-link spatial quantities shared by the rows (see module docstring)."""
        chain = self._chain
        rotation, position, screws = self._forward(q)
        anc = chain.ancestors.astype(float)
        # World twists of the links and of each joint's parent link.
        twist_world = np.einsum("bi,nis,ni->nbs", anc, screws, v)
        parent_twist = np.zeros_like(screws)
        has_parent = chain.parent >= 0
        parent_twist[:, has_parent] = twist_world[:, chain.parent[has_parent]]
        # Body-frame Jacobians J[n, b, i] (zero unless i is an ancestor of b).
        jac = _ad_inverse(
            rotation[:, :, None], position[:, :, None], screws[:, None, :, :]
        )
        jac *= anc[None, :, :, None]
        twist = np.einsum("nbis,ni->nbs", jac, v)
        k_twist = momentum_matrix(twist)
        gravity_body = np.einsum("nbji,j->nbi", rotation, self.gravity)
        out = {
            "rotation": rotation,
            "position": position,
            "jac": jac,
            "twist": twist,
            "k": k_twist,
            "gravity_body": gravity_body,
        }
        if derivatives or vdot is not None:
            # ∂V_b/∂q_i = Ad(X_WB⁻¹) ad(V_parent(i)) S_i for i ancestor of b.
            dscrew = _ad(parent_twist, screws)
            dtwist = _ad_inverse(
                rotation[:, :, None], position[:, :, None], dscrew[:, None, :, :]
            )
            dtwist *= anc[None, :, :, None]
            out["dtwist"] = dtwist
        return out

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

    def _energy_standard(self, q, v, terms=None):
        t = terms if terms is not None else self._terms(q, v)
        kinetic = 0.5 * np.einsum("nbs,nbsk->nbk", t["twist"], t["k"])
        potential = np.zeros_like(kinetic)
        potential[..., 6:9] = -t["gravity_body"]
        potential[..., 9] = -np.einsum("nbi,i->nb", t["position"], self.gravity)
        return (
            self._assemble(kinetic, 0.5 * v * v),
            self._assemble(potential, np.zeros_like(v)),
        )

    def _lagrangian_standard(self, q, v):
        t = self._terms(q, v, derivatives=True)
        n = self.num_joints
        eye = np.eye(n)
        dhe_dv = np.einsum("nbis,nbsk->nibk", t["jac"], t["k"])
        dhe_dq = np.einsum("nbis,nbsk->nibk", t["dtwist"], t["k"])
        gravity_twist = np.zeros_like(t["twist"])
        gravity_twist[..., 3:] = t["gravity_body"]
        k_gravity = momentum_matrix(gravity_twist)
        dhu_dq = -np.einsum("nbis,nbsk->nibk", t["jac"], k_gravity)
        zero = np.zeros((*v.shape, n))
        return (
            self._assemble(dhe_dv, eye[None] * v[:, None, :]),
            self._assemble(dhe_dq, zero),
            self._assemble(dhu_dq, zero),
        )

    def _idim_standard(self, q, v, vdot):
        t = self._terms(q, v, vdot)
        n = self.num_joints
        acceleration = np.einsum("nbis,ni->nbs", t["jac"], vdot) + np.einsum(
            "nbis,ni->nbs", t["dtwist"], v
        )
        acceleration[..., 3:] -= t["gravity_body"]
        force = momentum_matrix(acceleration) + _ad_transpose_momentum(
            t["twist"], t["k"]
        )
        rows = np.einsum("nbis,nbsk->nibk", t["jac"], force)
        out = self._assemble(rows, np.eye(n)[None] * vdot[:, None, :])
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
