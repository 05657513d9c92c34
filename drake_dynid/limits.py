"""Joint limits of a robot: from its URDF, overridden by a limits file.

The URDF gives ``<limit lower upper velocity effort>`` per joint (Drake reads them:
a missing attribute is ±inf). A limits file (JSON, or TOML with Python >= 3.11)
overrides or completes them, joint by joint::

    {"_source": "KUKA LBR iiwa 14 R820 datasheet",
     "iiwa_joint_1": {"velocity": 1.48, "effort": 320},
     "iiwa_joint_2": {"lower": -2.09, "upper": 2.09, "acceleration": 8.0}}

Keys: ``lower``, ``upper`` [rad or m], ``velocity`` [rad/s or m/s],
``acceleration`` [rad/s² or m/s²] (not in URDF), ``effort`` [N·m or N]. Top-level
keys starting with ``_`` are comments.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.joint_limits import JointLimits

__all__ = ["joint_limits", "read_limits_file", "urdf_limits"]


def urdf_limits(robot: Any) -> JointLimits:
    """The limits a ``RobotModel``'s plant read from its URDF (±inf if missing).

    Effort limits are the actuators' (a joint without actuator gets inf).
    """
    check.having(
        "urdf_limits", "robot", robot, ("plant", "joint_names"), "a RobotModel"
    )
    plant = robot.plant
    names = tuple(robot.joint_names)
    lower, upper, velocity, prismatic = [], [], [], []
    for name in names:
        joint = plant.GetJointByName(name)
        lower.append(float(joint.position_lower_limits()[0]))
        upper.append(float(joint.position_upper_limits()[0]))
        velocity.append(float(joint.velocity_upper_limits()[0]))
        prismatic.append(joint.type_name() == "prismatic")
    effort = np.full(len(names), np.inf)
    for index in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(index)
        if actuator.joint().name() in names and actuator.effort_limit() > 0.0:
            effort[names.index(actuator.joint().name())] = actuator.effort_limit()
    return JointLimits(
        names,
        np.array(lower),
        np.array(upper),
        np.array(velocity),
        effort,
        prismatic=tuple(prismatic),
    )


def _no_duplicate(file: Path) -> Any:
    """A ``json`` object hook refusing a key given twice (JSON keeps the last)."""

    def pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, value in items:
            if key in out:
                raise ValueError(
                    f"limits file {file}: {key!r} is given twice in one object; give "
                    "each joint (and each of its limits) once."
                )
            out[key] = value
        return out

    return pairs


def read_limits_file(path: str | Path) -> dict[str, dict[str, float]]:
    """Reads a limits file (JSON, or TOML by extension) into ``{joint: {key: value}}``.

    Raises:
        ValueError: unreadable or malformed file (the message says what to fix).
    """
    file = Path(path)
    if file.is_dir():
        raise ValueError(f"limits file {file} is a directory, expected a file.")
    if not file.is_file():
        raise ValueError(f"limits file not found: {file}.")
    text = check.utf8_text(file.read_bytes(), f"limits file {file}")
    if file.suffix.lower() == ".toml":
        try:
            import tomllib
        except ImportError:  # Python 3.10
            raise ValueError(
                f"limits file {file}: TOML needs Python >= 3.11; write it as JSON."
            ) from None
        try:
            document = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise ValueError(
                f"limits file {file} is not valid TOML: {error}."
            ) from None
    else:
        try:
            document = json.loads(text, object_pairs_hook=_no_duplicate(file))
        except json.JSONDecodeError as error:
            raise ValueError(
                f"limits file {file} is not valid JSON: {error} (TOML files need the "
                ".toml extension)."
            ) from None
    if not isinstance(document, dict):
        raise ValueError(
            f"limits file {file}: expected an object of joints, e.g. "
            '{"joint1": {"velocity": 2.0, "effort": 50}}.'
        )
    out: dict[str, dict[str, float]] = {}
    for joint, entries in document.items():
        if str(joint).startswith("_"):
            continue
        if not isinstance(entries, dict):
            raise ValueError(
                f"limits file {file}: the entry of joint {joint!r} must be an object "
                f"of limits (lower, upper, velocity, acceleration, effort); got "
                f"{entries!r}."
            )
        for key, value in entries.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(
                    f"limits file {file}: {joint}.{key} must be a number; got "
                    f"{value!r}."
                )
        out[str(joint)] = {str(k): float(value) for k, value in entries.items()}
    return out


def joint_limits(robot: Any, limits_file: str | Path | None = None) -> JointLimits:
    """The URDF's limits, completed or overridden by ``limits_file`` when given.

    A limits file of the whole robot serves any ``--joints``: the entries of the
    URDF's joints that are not identified (locked or mimic: the experiment does
    not move them on their own) are not used.

    Raises:
        ValueError: a malformed file, an unknown joint or key in it, or bad values.
    """
    limits = urdf_limits(robot)
    if limits_file is None:
        return limits
    outside = {*getattr(robot, "locked", {}), *getattr(robot, "mimic", {})}
    overrides = {
        joint: entries
        for joint, entries in read_limits_file(limits_file).items()
        if joint not in outside
    }
    try:
        return limits.with_overrides(overrides)
    except ValueError as error:
        raise ValueError(f"limits file {limits_file}: {error}") from None
