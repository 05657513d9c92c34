"""The precomputed plans of a ``RobotModel``'s fast row paths.

The fast paths of :class:`drake_dynid.robot_rows.RobotRows` read their rows straight
into base columns, so they need to know where each base column comes from: a
link's inertial parameter, a joint's rotor inertia ``IAj`` or a joint's friction
parameter. These functions find it once per model by probing the model's own
assembly of the standard columns (``RobotRows._assemble``) with labels, and build:

* :func:`sample_plan`: the single-sample plan (``core.sample_rows``, the
  ``ModelRows`` block's path);
* :func:`batch_plan`: the fused batch plan of the inverse-dynamics rows
  (``core.batch_rows``, the replay and off-line path);
* :func:`base_sources`: the gather of the inverse-dynamics rows from the link
  blocks of ``core.rigid_body`` (Drake kinematics, mimic joints).

Each returns None where its path does not apply; the caller then takes the
general path, which reports bad models with its own messages.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from drake_dynid.core.batch_rows import BatchRowsPlan, batch_rows_plan
from drake_dynid.core.sample_rows import SampleRowsPlan, sample_rows_plan

__all__ = ["base_sources", "batch_plan", "sample_plan", "standard_columns"]


def standard_columns(model: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard columns of the link parameters, IAj and joint friction of a model.

    Returns:
        (links·10,) the standard column of each link's inertial parameter
        [XX … M] (links, then parameters), (n,) that of each ``IAj`` (-1: none)
        and (n, len(friction)) that of each joint's friction parameter.
    """
    links, n = model.num_links, model.num_joints
    labels = 1.0 + np.arange(links * 10.0).reshape(1, links, 10)
    placed = model._assemble(labels, np.zeros((1, n)))[0]
    inertial = np.full(links * 10, -1)
    for column in np.flatnonzero(placed):
        inertial[int(placed[column]) - 1] = column
    rotor = np.full(n, -1)
    if model.rotor_inertia:
        placed = model._assemble(np.zeros((1, links, 10)), 1.0 + np.arange(n)[None])
        for column in np.flatnonzero(placed[0]):
            rotor[int(placed[0, column]) - 1] = column
    width = len(model.friction)
    start = model._friction_slice().start
    friction = start + np.arange(n * width).reshape(n, width)
    return inertial, rotor, friction


def sample_plan(model: Any) -> SampleRowsPlan | None:
    """The single-sample plan, or None (Drake kinematics, mimic joints).

    None also when a friction column is not identifiable: ``model_rows`` then
    raises with its message.
    """
    if model.kinematics != "numpy" or model.mimic:
        return None
    # A ValueError: model_rows reports it with its own message.
    return _numpy_plan(model, sample_rows_plan)


def batch_plan(model: Any) -> BatchRowsPlan | None:
    """The fused batch plan of the inverse-dynamics rows, or None.

    None with Drake kinematics, mimic joints or coupled motors, or a base column
    the plan does not know: :func:`base_sources` or the standard rows then.
    """
    if model.kinematics != "numpy" or model.mimic or model._motors is not None:
        return None
    return _numpy_plan(model, batch_rows_plan)


def _numpy_plan(model: Any, build: Callable[..., Any]) -> Any:
    """``build`` (a plan builder of ``core``) on the model's tree and columns.

    None when it raises ValueError (a column the plan cannot hold).
    """
    inertial, rotor, friction = standard_columns(model)
    try:
        return build(
            model._chain.plan,
            model.gravity,
            model.base.independent,
            inertial,
            rotor,
            model.friction,
            friction,
        )
    except ValueError:
        return None


def base_sources(model: Any) -> tuple[np.ndarray, ...] | None:
    """Where each base column of the inverse-dynamics rows comes from, or None.

    Returns:
        (base columns of link parameters, their index in the flattened
        (links, 10) blocks, base columns of IAj, their joints j, base columns of
        the joint friction in order), or None with coupled motors or a base
        column none of these (the standard rows then).
    """
    if model._motors is not None:
        return None
    position = {column: c for c, column in enumerate(model.base.independent)}
    inertial, rotor, friction = standard_columns(model)
    pairs = [(position[c], k) for k, c in enumerate(inertial.tolist()) if c in position]
    joints = [(position[c], j) for j, c in enumerate(rotor.tolist()) if c in position]
    friction_columns = [position.get(c) for c in friction.ravel().tolist()]
    known = len(pairs) + len(joints) + len(friction_columns)
    if None in friction_columns or known != len(position):
        return None  # a column this gather does not know: the general path
    link_pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
    joint_pairs = np.array(joints, dtype=np.int64).reshape(-1, 2)
    return (
        link_pairs[:, 0],
        link_pairs[:, 1],
        joint_pairs[:, 0],
        joint_pairs[:, 1],
        np.array(friction_columns, dtype=np.int64),
    )
