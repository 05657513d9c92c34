"""A payload on a robot described by a URDF: where it is attached, what is known.

:func:`payload_model` builds the payload's row provider
(``drake_dynid.core.payload.PayloadRows``) of a ``RobotModel`` from the names of
the description: the attachment frame F is a body or frame of the plant (default:
the last identified link's body), optionally moved by an offset (xyz [m], rpy
[rad], as a URDF ``<origin>``); the carrying link is the moving link F is rigidly
attached to (a body welded to it, or behind a locked joint, belongs to it). The
arm's known parameters are the URDF's values unless given (a previous
identification: ``dynid offline/identify --json``, read with
``drake_dynid.validation.read_estimates``).

pydrake is imported inside the functions.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.payload import PayloadRows, payload_rows

__all__ = ["attachment_pose", "payload_model"]

_PROBES = 3  # random configurations that must agree on X_LF


def _frame(robot: Any, name: str) -> Any:
    plant = robot.plant
    if plant.HasFrameNamed(name):
        return plant.GetFrameByName(name)
    bodies = check.choices((body.name() for body in robot._link_bodies), name)
    check.fail(
        "payload_model",
        f"frame must be a body or frame of the URDF; got {name!r} (the identified "
        f"links' bodies: {bodies}).",
    )
    return None


def attachment_pose(robot: Any, frame: str | None = None) -> tuple[int, np.ndarray]:
    """``(link, X_LF)``: the moving link a frame is rigidly attached to, its pose.

    Args:
        robot: a ``drake_dynid.RobotModel``.
        frame: a body or frame name of the plant (default: the body of the last
            identified link).

    Returns:
        The link index (0-based, ``robot.links`` order) and X_LF (4, 4): F's pose
        in the link's frame (the child body of the link's joint, the frame of its
        standard parameters) [m].

    Raises:
        ValueError: an unknown name, or a frame that does not move with any link
            (welded to the world, or moved by a joint that is not identified
            and not locked).
    """
    links = robot._link_bodies
    if frame is None:
        return robot.num_joints - 1, np.eye(4)
    target = _frame(robot, str(frame))
    plant = robot.plant
    context = plant.CreateDefaultContext()
    rng = np.random.default_rng(0)
    poses = []
    for _ in range(_PROBES):
        q = rng.uniform(-np.pi, np.pi, robot.num_joints)
        plant.SetPositions(context, robot.plant_positions(q))
        poses.append(
            [
                plant.CalcRelativeTransform(
                    context, body.body_frame(), target
                ).GetAsMatrix4()
                for body in links
            ]
        )
    poses_array = np.asarray(poses)  # (probes, links, 4, 4)
    spread = np.abs(poses_array - poses_array[0]).max(axis=(0, 2, 3))
    fixed = np.flatnonzero(spread <= 1e-9)
    if fixed.size == 0:
        check.fail(
            "payload_model",
            f"frame {frame!r} does not move rigidly with any identified link (it is "
            "welded to the world or moved by a joint that is neither identified nor "
            "locked).",
        )
    link = int(fixed[0])
    return link, poses_array[0, link]


def payload_model(
    robot: Any,
    frame: str | None = None,
    *,
    xyz: Sequence[float] | None = None,
    rpy: Sequence[float] | None = None,
    arm: Any = None,
    arm_covariance: Any = None,
    seed: int = 0,
) -> PayloadRows:
    """The row provider of a payload attached to ``frame`` of ``robot``.

    F = ``frame`` moved by the offset (``xyz`` [m], then ``rpy`` [rad]: R =
    Rz(yaw) Ry(pitch) Rx(roll), as a URDF ``<origin>``); the payload's parameters
    are expressed about F's origin in F's axes (``core.payload``).

    Args:
        robot: the arm (``drake_dynid.RobotModel``).
        frame: a body or frame of the URDF (default: the last identified link).
        xyz: the offset's translation [m] (default 0).
        rpy: the offset's roll, pitch, yaw [rad] (default 0).
        arm: the arm's base parameters (default: the URDF's, ``robot.base_values``).
        arm_covariance: their (p_arm, p_arm) covariance, or None (the arm taken
            as exact; ``core.payload.payload_rows``).
        seed: seed of the structural reduction's random states.

    Raises:
        ValueError: see :func:`attachment_pose` and ``core.payload.payload_rows``.
    """
    from pydrake.math import RigidTransform, RollPitchYaw

    owner = "payload_model"
    check.having(
        owner,
        "robot",
        robot,
        ("plant", "plant_positions", "_link_bodies", "num_joints"),
        "a RobotModel",
    )
    link, pose = attachment_pose(robot, frame)
    offset = np.eye(4)
    if xyz is not None or rpy is not None:
        translation = check.array(
            owner, "xyz", np.zeros(3) if xyz is None else xyz, (3,)
        )
        angles = check.array(owner, "rpy", np.zeros(3) if rpy is None else rpy, (3,))
        offset = RigidTransform(RollPitchYaw(angles), translation).GetAsMatrix4()
    pose = pose @ offset
    name = frame if frame is not None else robot._link_bodies[link].name()
    return payload_rows(
        robot,
        link,
        rotation=pose[:3, :3],
        translation=pose[:3, 3],
        arm=arm,
        arm_covariance=arm_covariance,
        frame_name=str(name),
        seed=seed,
    )
