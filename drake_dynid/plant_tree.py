"""The numeric kinematic tree and link inertias of a ``MultibodyPlant``.

:func:`extract_tree` reads, from a finalized fixed-base plant, the joint geometry
(:class:`drake_dynid.core.kinematics.KinematicTree`) and the standard inertial
parameters of every moving link, with the bodies welded to a link lumped into it
and the bodies welded to the world dropped (their energy is constant). A locked
joint is a weld at its locked position: the bodies beyond it are lumped the same
way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core.friction import FRICTION_PREFIX
from drake_dynid.core.joint_map import JointMap, joint_map
from drake_dynid.core.kinematics import KinematicTree, rotation_about

__all__ = [
    "INERTIAL_NAMES",
    "MOVABLE_JOINTS",
    "PlantDescription",
    "describe_plant",
    "drake_forward",
    "extract_tree",
    "locked_pose",
    "movable_joints",
    "standard_table",
]

#: The 10 inertial parameters of one link, in Khalil's (and the preferred) order.
INERTIAL_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")


#: Drake joint types drake_dynid identifies (a URDF continuous joint is revolute).
MOVABLE_JOINTS = ("revolute", "prismatic")


def _pose_matrix(transform: Any) -> np.ndarray:
    return np.asarray(transform.GetAsMatrix4(), dtype=float)


def movable_joints(plant: Any) -> list[Any]:
    """The plant's non-weld joints in generalized-velocity order."""
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    return sorted(
        (j for j in joints if j.type_name() != "weld"), key=lambda j: j.velocity_start()
    )


def locked_pose(joint: Any, position: float) -> np.ndarray:
    """X_FM of a revolute or prismatic joint at ``position`` [rad or m], 4×4."""
    pose = np.eye(4)
    if joint.type_name() == "prismatic":
        pose[:3, 3] = np.asarray(joint.translation_axis()) * position
    else:
        axis = np.asarray(joint.revolute_axis(), dtype=float)
        pose[:3, :3] = rotation_about(axis, np.array([position]))[0]
    return pose


def extract_tree(
    plant: Any,
    moving: list[Any] | None = None,
    locked: dict[str, float] | None = None,
) -> tuple[KinematicTree, list[Any], np.ndarray]:
    """Reads the joint geometry and the lumped link inertias from a plant.

    Args:
        plant: a finalized fixed-base plant with revolute, prismatic and weld joints.
        moving: the joints that move, in the order of the tree's links (link k is
            the child of ``moving[k]``); default every non-weld joint in
            generalized-velocity order.
        locked: ``{joint name: position [rad or m]}`` for the other non-weld joints
            (missing ones: 0). A locked joint is treated as a weld at that position.

    Returns:
        ``(tree, joints, inertial)`` with ``joints`` the moving joints (link order)
        and ``inertial`` the ``(n, 10)`` standard inertial values.
    """
    all_joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    moving = list(movable_joints(plant) if moving is None else moving)
    locked = dict(locked or {})
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
            if joint.index() not in link_of_joint:
                if joint.type_name() == "weld":
                    x_f_m = _pose_matrix(joint.X_FM())
                else:
                    x_f_m = locked_pose(joint, locked.get(joint.name(), 0.0))
                x_p_c = x_p_f @ x_f_m @ np.linalg.inv(x_c_m)
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
    tree = KinematicTree(
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
    return tree, moving, inertial


def standard_table(
    plant: Any,
    moving: list[Any],
    num_identified: int,
    inertial: np.ndarray,
    *,
    friction: tuple[str, ...],
    rotor_inertia: bool,
    coulomb: dict[str, float] | None,
    mimic: Mapping[str, tuple[str, float, float]] | None = None,
) -> tuple[tuple[str, ...], np.ndarray]:
    """Standard parameter names and values, in the preferred column order.

    Link j (1-based) of ``moving``: ``XXj … Mj`` (+ ``IAj`` for an identified
    joint with ``rotor_inertia``: the actuator's rotor inertia times its gear ratio
    squared [kg·m²]); then, per identified joint, the friction columns: ``FVj``
    (the joint's damping [N·m·s/rad or N·s/m]), ``FCj`` (``coulomb[name]``, 0 when
    missing [N·m or N]), ``OFFj`` (0). The friction of a moving mimic joint f
    (q_f = a q_i + b) acts on its leader i through τ_i = a τ_f: FVi += a² FVf and
    FCi += |a| FCf.

    Returns:
        ``(names, values)``; ``values`` is read-only.
    """
    identified = [joint.name() for joint in moving[:num_identified]]
    rotor = np.zeros(num_identified)
    for index in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(index)
        if actuator.joint().name() in identified:
            gear = actuator.default_gear_ratio()
            rotor[identified.index(actuator.joint().name())] = (
                actuator.default_rotor_inertia() * gear**2
            )
    coulomb = dict(coulomb or {})
    damping = {j.name(): float(j.default_damping_vector()[0]) for j in moving}
    dry = {j.name(): float(coulomb.get(j.name(), 0.0)) for j in moving}
    for follower, (leader, a, _) in dict(mimic or {}).items():
        damping[leader] += a * a * damping[follower]
        dry[leader] += abs(a) * dry[follower]
    names: list[str] = []
    values: list[float] = []
    for j in range(len(moving)):
        names += [f"{name}{j + 1}" for name in INERTIAL_NAMES]
        values += list(inertial[j])
        if rotor_inertia and j < num_identified:
            names.append(f"IA{j + 1}")
            values.append(rotor[j])
    for j, joint in enumerate(moving[:num_identified]):
        for kind in friction:
            names.append(f"{FRICTION_PREFIX[kind]}{j + 1}")
            if kind == "viscous":
                values.append(damping[joint.name()])
            elif kind == "coulomb":
                values.append(dry[joint.name()])
            else:
                values.append(0.0)
    out = np.array(values)
    out.setflags(write=False)
    return tuple(names), out


def drake_forward(
    plant: Any,
    q_plant: np.ndarray,
    bodies: tuple[Any, ...],
    frames: tuple[Any, ...],
    tree: KinematicTree,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Link poses and world joint screws from Drake, one sample at a time.

    The same outputs as ``KinematicTree.forward`` (R (N, b, 3, 3), p (N, b, 3),
    S (N, b, 6)), from ``EvalBodyPoseInWorld`` of each link body and the pose of
    each joint's child frame, with the plant at ``q_plant`` (N, num_positions).
    """
    context = plant.CreateDefaultContext()
    num_samples, links = q_plant.shape[0], len(bodies)
    rotation = np.empty((num_samples, links, 3, 3))
    position = np.empty((num_samples, links, 3))
    screws = np.zeros((num_samples, links, 6))
    for k in range(num_samples):
        plant.SetPositions(context, q_plant[k])
        for j, (body, frame) in enumerate(zip(bodies, frames, strict=True)):
            x_wb = plant.EvalBodyPoseInWorld(context, body)
            rotation[k, j] = x_wb.rotation().matrix()
            position[k, j] = x_wb.translation()
            x_wm = frame.CalcPoseInWorld(context)
            axis = x_wm.rotation().matrix() @ tree.axis[j]
            if tree.prismatic[j]:
                screws[k, j, 3:] = axis
            else:
                screws[k, j, :3] = axis
                screws[k, j, 3:] = np.cross(x_wm.translation(), axis)
    return rotation, position, screws


@dataclass(frozen=True, eq=False)
class PlantDescription:
    """What :func:`describe_plant` reads: joint map, moving joints, tree, table."""

    joint_map: JointMap
    moving: tuple[Any, ...]
    chain: KinematicTree
    standard_names: tuple[str, ...]
    standard_values: np.ndarray


def describe_plant(
    owner: str,
    plant: Any,
    *,
    joints: Sequence[str] | None,
    locked: Mapping[str, float] | None,
    mimic: Mapping[str, tuple[str, float, float]] | None,
    friction: tuple[str, ...],
    rotor_inertia: bool,
    coulomb: dict[str, float] | None,
) -> PlantDescription:
    """Checks a finalized fixed-base plant and reads what identification needs.

    The identified joints, locked positions and mimic joints
    (``drake_dynid.core.joint_map.joint_map``), the tree of the moving joints
    with the locked ones welded (:func:`extract_tree`) and the standard parameter
    table (:func:`standard_table`).

    Raises:
        ValueError: the plant is not finalized, not fixed-base, has a joint other
            than revolute, prismatic or weld, or the joint choice is invalid.
    """
    if not plant.is_finalized():
        raise ValueError(f"{owner}: plant must be finalized.")
    movable = movable_joints(plant)
    if (
        any(j.type_name() not in MOVABLE_JOINTS for j in movable)
        or plant.num_positions() != len(movable)
        or plant.num_velocities() != len(movable)
        or any(j.position_start() != j.velocity_start() for j in movable)
    ):
        raise ValueError(
            f"{owner}: plant must have only revolute, prismatic and fixed joints "
            f"on a fixed base; got {plant.num_positions()} positions for "
            f"{len(movable)} joints."
        )
    jmap = joint_map(
        [j.name() for j in movable],
        joints=joints,
        locked=locked,
        mimic=mimic,
        owner=owner,
    )
    by_name = {j.name(): j for j in movable}
    moving = [by_name[name] for name in jmap.moving]
    chain, _, inertial = extract_tree(plant, moving, dict(jmap.locked))
    names, values = standard_table(
        plant,
        moving,
        len(jmap.names),
        inertial,
        friction=friction,
        rotor_inertia=rotor_inertia,
        coulomb=coulomb,
        mimic=jmap.mimic,
    )
    return PlantDescription(jmap, tuple(moving), chain, names, values)
