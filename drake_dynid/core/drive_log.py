"""The ``[log]`` table of a drive file: column names, units, sides (docs/DRIVE.md).

A log gives raw columns: time stamps, positions and torques, on the joint side or on
the motor side, in the units of the robot's software. ``parse_log`` validates the
``[log]`` table and resolves every column name; ``DriveChain.convert``
(``drake_dynid.core.drive``) applies it::

    t = s_t·t_raw          s_t: s 1, ms 1e-3, us 1e-6, ns 1e-9
    p_SI = s_p·(p - offset)  s_p: rad 1, deg π/180, rev 2π; m 1, mm 1e-3
    τ_m = k_t·s_i·i          s_i: A 1, mA 1e-3 (currents; N*m and N are SI)

Column names come from a template with ``{joint}`` (joint name) or ``{motor}``
(motor name; ``{joint}`` is allowed on the motor side for a motor that drives one
joint), e.g. ``"- {joint}_position"``, or from an explicit table ``{name = column}``
covering every joint (or motor). Pure standard library and numpy.
"""

from __future__ import annotations

import math
import string
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core._validate import listed

__all__ = [
    "ANGLE_UNITS",
    "CURRENT_UNITS",
    "EFFORT_UNITS",
    "LENGTH_UNITS",
    "TIME_UNITS",
    "LogFormat",
    "check_table",
    "parse_log",
    "real",
]

#: Time units and their scale to seconds.
TIME_UNITS = MappingProxyType({"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9})
#: Angle units (revolute joints, rotary motors) and their scale to radians.
ANGLE_UNITS = MappingProxyType({"rad": 1.0, "deg": math.pi / 180.0, "rev": 2 * math.pi})
#: Length units (prismatic joints, linear motors) and their scale to metres.
LENGTH_UNITS = MappingProxyType({"m": 1.0, "mm": 1e-3})
#: SI effort units: N·m for revolute joints and rotary motors, N for prismatic/linear.
EFFORT_UNITS = ("N*m", "N")
#: Current units and their scale to amperes (τ_m = k_t·i).
CURRENT_UNITS = MappingProxyType({"A": 1.0, "mA": 1e-3})
SIDES = ("joint", "motor")
TIME_ORIGINS = ("log", "first")

_LOG_KEYS = (
    "time",
    "time_unit",
    "time_origin",
    "position",
    "position_side",
    "angle_unit",
    "length_unit",
    "position_offset",
    "torque",
    "torque_side",
    "torque_unit",
)
_DEFAULTS = MappingProxyType(
    {
        "time": "t",
        "time_unit": "s",
        "time_origin": "log",
        "position": "q_{joint}",
        "position_side": "joint",
        "angle_unit": "rad",
        "length_unit": "m",
        "torque": "tau_{joint}",
        "torque_side": "joint",
        "torque_unit": "N*m",
    }
)


def real(owner: str, field: str, value: Any, unit: str | None = None) -> float:
    """A finite number (TOML integer or float, not a boolean), else raises."""
    return _validate.real(owner, field, value, unit)


def check_table(
    owner: str,
    field: str,
    table: Any,
    allowed: Sequence[str],
    *,
    required: bool = False,
) -> None:
    """Raises unless ``table`` is a mapping whose keys are among ``allowed``.

    Unknown keys are errors (nothing in a drive file is silently ignored); with
    ``required`` every allowed key must be present.
    """
    if not isinstance(table, Mapping):
        raise TypeError(f"{owner}: {field} must be a table; got {table!r}.")
    unknown = [str(key) for key in table if key not in allowed]
    where = "" if field == "the drive file" else f" in {field}"
    if unknown:
        raise ValueError(
            f"{owner}: unknown key(s) {listed(unknown)}{where}; allowed: "
            f"{', '.join(allowed)}."
        )
    if required:
        missing = [key for key in allowed if key not in table]
        if missing:
            raise ValueError(f"{owner}: missing key(s) {listed(missing)}{where}.")


@dataclass(frozen=True, eq=False)
class LogFormat:
    """The resolved ``[log]`` table (see the module docstring).

    Attributes:
        time: name of the time column.
        time_unit: its unit; ``time_scale`` its scale to seconds.
        time_origin: ``"log"`` (keep the stamps) or ``"first"`` (subtract the
            first stamp, e.g. for epoch stamps).
        position_side: ``"joint"`` or ``"motor"``.
        position_names: the joint (or motor) names of the position columns.
        position_columns: the position column names, same order.
        angle_unit, length_unit: the position units.
        position_scale: (s,) scale of each position column to rad or m.
        position_offset: (s,) raw reading at the URDF zero, in the column's unit.
        torque_side: ``"joint"`` or ``"motor"``.
        torque_names: the joint (or motor) names of the torque columns.
        torque_columns: the torque column names, same order.
        torque_unit: ``"N*m"``/``"N"`` (SI) or ``"A"``/``"mA"`` (currents).
        current_scale: scale of a current to A, None for SI efforts.
        joint_position_template: ``log.position`` when it is a joint-side
            template with ``{joint}`` (the column of any joint, identified or
            not: the check that a locked joint does not move reads it), else None.
        time_unit_given: the table says ``time_unit`` (False: the default s), so
            that ``--time-unit`` can tell an explicit s from the default; also
            True with ``--time-unit`` or a ROS bag's export. A fitted step >= 0.5 s
            is then read with a warning, else refused (``log_repair.SLOW_STEP``).
    """

    time: str
    time_unit: str
    time_scale: float
    time_origin: str
    position_side: str
    position_names: tuple[str, ...]
    position_columns: tuple[str, ...]
    angle_unit: str
    length_unit: str
    position_scale: np.ndarray
    position_offset: np.ndarray
    torque_side: str
    torque_names: tuple[str, ...]
    torque_columns: tuple[str, ...]
    torque_unit: str
    current_scale: float | None
    joint_position_template: str | None = None
    time_unit_given: bool = False


def _choice(owner: str, field: str, value: Any, choices: Sequence[str]) -> str:
    if not isinstance(value, str) or value not in choices:
        raise ValueError(
            f"{owner}: {field} must be one of {', '.join(choices)}; got {value!r}."
        )
    return value


def _entities(side: str, joint_names, motors) -> list[tuple[str, str | None]]:
    """(name, joint of a single-joint entity or None) for each column of a side."""
    if side == "joint":
        return [(name, name) for name in joint_names]
    return [
        (mo.name, None if mo.coupled else joint_names[mo.joints[0]]) for mo in motors
    ]


def _columns(
    owner: str, field: str, spec: Any, side: str, entities, outside=frozenset()
) -> tuple[str, ...]:
    names = [name for name, _ in entities]
    if isinstance(spec, Mapping):
        unknown = [str(key) for key in spec if key not in names and key not in outside]
        missing = [name for name in names if name not in spec]
        if unknown or missing:
            raise ValueError(
                f"{owner}: {field} must name a column for every {side} "
                f"({listed(names)}); unknown: {listed(unknown) or 'none'}; "
                f"missing: {listed(missing) or 'none'}."
            )
        for name in names:
            if not isinstance(spec[name], str) or not spec[name]:
                raise TypeError(f"{owner}: {field}.{name} must be a column name.")
        return tuple(spec[name] for name in names)
    if not isinstance(spec, str):
        raise TypeError(
            f"{owner}: {field} must be a template string with {{{side}}} or a table "
            f"{{name = column}}; got {spec!r}."
        )
    try:
        fields = {f for _, f, _, _ in string.Formatter().parse(spec) if f is not None}
    except ValueError as error:
        raise ValueError(
            f"{owner}: {field} = {spec!r} is not a template: {error}."
        ) from None
    allowed = {"joint"} if side == "joint" else {"joint", "motor"}
    bad = sorted(fields - allowed)
    if bad or not fields:
        what = "{joint}" if side == "joint" else "{motor} or {joint}"
        raise ValueError(
            f"{owner}: {field} = {spec!r} must use the placeholder {what} "
            f"(the {side} side); got {', '.join('{' + b + '}' for b in bad) or 'none'}."
        )
    out = []
    for name, joint in entities:
        if "joint" in fields and joint is None:
            raise ValueError(
                f"{owner}: {field} = {spec!r} uses {{joint}} but motor {name!r} "
                "drives several joints; use {motor} or a table {name = column}."
            )
        out.append(spec.format(joint=joint, motor=name))
    return tuple(out)


def _offsets(owner, table, side, entities, scales_unit, outside) -> np.ndarray:
    names = [name for name, _ in entities]
    out = np.zeros(len(names))
    if table is None:
        return out
    if not isinstance(table, Mapping):
        raise TypeError(
            f"{owner}: log.position_offset must be a table {{{side} = reading}}; "
            f"got {table!r}."
        )
    for key, value in table.items():
        if key in outside and key not in names:
            continue  # a skipped motor's, a joint's outside --joints
        if key not in names:
            raise ValueError(
                f"{owner}: log.position_offset.{key}: unknown {side} (position_side "
                f"is {side!r}); expected one of {listed(names)}."
            )
        k = names.index(key)
        out[k] = real(owner, f"log.position_offset.{key}", value, scales_unit[k])
    return out


def parse_log(
    owner: str,
    table: Any,
    joint_names: tuple[str, ...],
    prismatic: tuple[bool, ...],
    motors: tuple[Any, ...],
    outside: Collection[str] = frozenset(),
) -> LogFormat:
    """Validates the ``[log]`` table and resolves the column names and scales.

    Args:
        owner: the name used in error messages.
        table: the parsed ``[log]`` table (missing keys take the defaults of the
            plain CSV format: ``t``, ``q_{joint}``, ``tau_{joint}``, SI, joint side).
        joint_names: the identified joints.
        prismatic: (n,) prismatic flags of the joints.
        motors: the resolved motors (``Motor``: ``name``, ``coupled``, ``joints``,
            ``linear``).
        outside: names of skipped motors and of URDF joints outside
            ``joint_names``: ``position_offset`` and column-table entries of
            theirs are ignored (a drive file of the whole robot serves any
            ``--joints``).

    Returns:
        The resolved ``LogFormat``.
    """
    check_table(owner, "log", table, _LOG_KEYS)
    spec = {**_DEFAULTS, **table}
    time = spec["time"]
    if not isinstance(time, str) or not time:
        raise TypeError(f"{owner}: log.time must be a column name; got {time!r}.")
    time_unit = _choice(owner, "log.time_unit", spec["time_unit"], tuple(TIME_UNITS))
    origin = _choice(owner, "log.time_origin", spec["time_origin"], TIME_ORIGINS)
    angle = _choice(owner, "log.angle_unit", spec["angle_unit"], tuple(ANGLE_UNITS))
    length = _choice(owner, "log.length_unit", spec["length_unit"], tuple(LENGTH_UNITS))
    position_side = _choice(owner, "log.position_side", spec["position_side"], SIDES)
    torque_side = _choice(owner, "log.torque_side", spec["torque_side"], SIDES)
    units = (*EFFORT_UNITS, *CURRENT_UNITS)
    torque_unit = _choice(owner, "log.torque_unit", spec["torque_unit"], units)
    if torque_unit in CURRENT_UNITS and torque_side != "motor":
        raise ValueError(
            f"{owner}: log.torque_unit = {torque_unit!r} (currents) needs "
            "torque_side = 'motor' (a current is a motor quantity, τ_m = k_t i); "
            f"got torque_side = {torque_side!r}."
        )
    if position_side == "motor" and len(motors) != len(joint_names):
        raise ValueError(
            f"{owner}: log.position_side = 'motor' needs as many motors as joints "
            f"(q = R⁻¹(q_m - offset)); got {len(motors)} motors for "
            f"{len(joint_names)} joints."
        )
    position_entities = _entities(position_side, joint_names, motors)
    torque_entities = _entities(torque_side, joint_names, motors)
    if position_side == "joint":
        linear = list(prismatic)
    else:
        unsaid = [mo for mo in motors if mo.linear is None]
        if unsaid:
            mo = unsaid[0]
            joint = joint_names[mo.joints[0]]
            raise ValueError(
                f"{owner}: motors.{mo.name} drives prismatic joint {joint!r} with "
                f"gear_ratio {float(mo.row[mo.joints[0]]):g} and the log holds its "
                "motor-side position: say what it is, linear = false (a rotary "
                "motor on a screw, ratio in rad/m, position in angle_unit) or linear "
                "= true (a linear motor, ratio in m/m, position in length_unit)."
            )
        linear = [bool(mo.linear) for mo in motors]
    scale = np.array(
        [LENGTH_UNITS[length] if x else ANGLE_UNITS[angle] for x in linear]
    )
    unit_of = [length if x else angle for x in linear]
    offset = _offsets(
        owner,
        spec.get("position_offset"),
        position_side,
        position_entities,
        unit_of,
        outside,
    )
    positions = _columns(
        owner,
        "log.position",
        spec["position"],
        position_side,
        position_entities,
        outside,
    )
    torques = _columns(
        owner, "log.torque", spec["torque"], torque_side, torque_entities, outside
    )
    every = [time, *positions, *torques]
    duplicated = sorted({name for name in every if every.count(name) > 1})
    if duplicated:
        raise ValueError(
            f"{owner}: the [log] table names column(s) {listed(duplicated)} more "
            "than once (time, position and torque columns must differ)."
        )
    for array in (scale, offset):
        array.setflags(write=False)
    return LogFormat(
        time=time,
        time_unit=time_unit,
        time_scale=TIME_UNITS[time_unit],
        time_origin=origin,
        position_side=position_side,
        position_names=tuple(name for name, _ in position_entities),
        position_columns=positions,
        angle_unit=angle,
        length_unit=length,
        position_scale=scale,
        position_offset=offset,
        torque_side=torque_side,
        torque_names=tuple(name for name, _ in torque_entities),
        torque_columns=torques,
        torque_unit=torque_unit,
        current_scale=CURRENT_UNITS.get(torque_unit),
        joint_position_template=(
            spec["position"]
            if position_side == "joint"
            and isinstance(spec["position"], str)
            and "{joint}" in spec["position"]
            else None
        ),
        time_unit_given="time_unit" in table,
    )
