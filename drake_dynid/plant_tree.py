"""The numeric kinematic tree and link inertias of a ``MultibodyPlant``.

:func:`extract_tree` reads, from a finalized fixed-base plant, the joint geometry
(:class:`drake_dynid.core.kinematics.KinematicTree`) and the standard inertial
parameters of every moving link, with the bodies welded to a link lumped into it
and the bodies welded to the world dropped (their energy is constant).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from drake_dynid.core.kinematics import KinematicTree

__all__ = ["extract_tree"]


def _pose_matrix(transform: Any) -> np.ndarray:
    return np.asarray(transform.GetAsMatrix4(), dtype=float)


def extract_tree(plant: Any) -> tuple[KinematicTree, list[Any], np.ndarray]:
    """Reads the joint geometry and the lumped link inertias from a plant.

    Returns:
        ``(tree, joints, inertial)`` with ``joints`` the moving joints in velocity
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
