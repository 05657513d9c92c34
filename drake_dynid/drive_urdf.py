"""Drive chains from URDF ``<transmission>`` elements (docs/DRIVE.md).

Reads ros_control transmissions and Drake's actuator tags into motor rows of the
coupling matrix R (v_m = R v, τ = Rᵀ τ_m; ``drake_dynid.core.drive``). With ``n``
the ``<mechanicalReduction>`` of an actuator (a) or of a joint (j, default 1)::

    SimpleTransmission          x_a = n (x_j - x_off)        row: {j: n}
    DifferentialTransmission    x_a1 = n_a1 (n_j1 x_j1 + n_j2 x_j2)
                                x_a2 = n_a2 (n_j1 x_j1 - n_j2 x_j2)
    FourBarLinkageTransmission  x_a1 = n_a1 n_j1 x_j1
                                x_a2 = n_a2 (x_j1 + n_j2 x_j2)

(the ros_control position maps, offsets x_off aside; roles ``actuator1/2``,
``joint1/2``). Efforts always follow τ = Rᵀ τ_m, the power-consistent map; for the
four-bar linkage ros_control's own effort map is not (ros2_control issue #1746, fixed
by its pull request #1837), and this module does not reproduce it. A simple
transmission's ratio is ``<drake:gear_ratio value=...>`` when present (Drake
reflects N² Ia with it), else ``<mechanicalReduction>`` (in the actuator, or in the
transmission for the old PR2 format), else 1. ``<drake:rotor_inertia value=...>``
gives the motor's rotor inertia [kg·m²]. Joint ``<offset>`` values are read and
reported but not applied: a ROS joint-side log already includes them.

A drive file overrides the URDF (``DriveChain.from_dict``'s ``urdf`` argument):
``load_drive`` reads both. No pydrake; xml.etree only.
"""

from __future__ import annotations

import dataclasses
import os
import re
import xml.etree.ElementTree as ElementTree
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, NoReturn

from drake_dynid.core._validate import listed
from drake_dynid.core.drive import DriveChain, read_drive

__all__ = ["UrdfDrive", "load_drive", "read_urdf_drive"]

#: Drake's XML namespace of its URDF extensions (``drake:rotor_inertia``, ...).
DRAKE_NAMESPACE = "http://drake.mit.edu"
_DRAKE = f"{{{DRAKE_NAMESPACE}}}"
_KINDS = (
    "SimpleTransmission",
    "DifferentialTransmission",
    "FourBarLinkageTransmission",
)


@dataclass(frozen=True)
class UrdfDrive:
    """What a URDF says about its drives.

    Attributes:
        motors: ``{actuator name: {"joints": {joint: ratio}, ["rotor_inertia":
            Ia]}}``, the ``urdf`` argument of ``DriveChain.from_dict``.
        joint_types: ``{joint name: URDF type}`` for every joint of the URDF.
        joint_offsets: ``{joint name: x_off}`` from transmission ``<offset>``
            elements [rad or m] (reported, not applied).
        warnings: what was ignored or chosen, one sentence each.
    """

    motors: Mapping[str, Mapping[str, Any]]
    joint_types: Mapping[str, str]
    joint_offsets: Mapping[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    @property
    def prismatic_joints(self) -> tuple[str, ...]:
        """Names of the prismatic joints."""
        return tuple(n for n, kind in self.joint_types.items() if kind == "prismatic")

    def as_dict(self) -> dict[str, Any]:
        """``{"motors": ..., "joints": [...]}``: ``DriveChain.from_dict``'s ``urdf``.

        The joints tell a joint that is not identified from a typo in a drive file.
        """
        return {
            "motors": {name: dict(table) for name, table in self.motors.items()},
            "joints": sorted(self.joint_types),
        }


class _Reader:
    def __init__(self, path: str, joints: Mapping[str, str]) -> None:
        self.path = path
        self.joints = joints
        self.motors: dict[str, dict[str, Any]] = {}
        self.offsets: dict[str, float] = {}
        self.warnings: list[str] = []

    def fail(self, where: str, message: str) -> NoReturn:
        raise ValueError(f"read_urdf_drive: {self.path}: {where}: {message}.")

    def number(self, where: str, text: str | None, what: str) -> float:
        try:
            return float((text or "").strip())
        except ValueError:
            self.fail(where, f"{what} {text!r} is not a number")

    def drake_value(self, where: str, element, tag: str) -> float | None:
        found = element.find(_DRAKE + tag)
        if found is None:
            return None
        return self.number(where, found.attrib.get("value"), f"drake:{tag} value")

    def reduction(self, where: str, element) -> float | None:
        found = element.find("mechanicalReduction")
        if found is None:
            return None
        value = self.number(where, found.text, "mechanicalReduction")
        if value == 0.0:
            self.fail(where, "mechanicalReduction must be non-zero; got 0")
        return value

    def required_reduction(self, where: str, element) -> float:
        value = self.reduction(where, element)
        if value is None:
            self.fail(where, "missing <mechanicalReduction>")
        return value

    def by_role(self, where: str, elements, roles: tuple[str, str]):
        if len(elements) != 2:
            self.fail(
                where, f"needs 2 elements with roles {roles}; got {len(elements)}"
            )
        found = {}
        for element in elements:
            role = (element.findtext("role") or "").strip()
            if role not in roles or role in found:
                self.fail(
                    where, f"roles must be {roles[0]} and {roles[1]}; got {role!r}"
                )
            found[role] = element
        return [found[role] for role in roles]

    def transmission(self, index: int, element) -> None:
        name = element.attrib.get("name") or f"#{index}"
        where = f"transmission {name}"
        kind = (element.findtext("type") or element.attrib.get("type") or "").strip()
        short = kind.rsplit("/", 1)[-1]
        joints = element.findall("joint")
        actuators = element.findall("actuator")
        for joint in joints:
            joint_name = joint.attrib.get("name", "")
            if joint_name not in self.joints:
                self.fail(where, f"joint {joint_name!r} is not a joint of the URDF")
            if joint.find("offset") is not None:
                offset = self.number(where, joint.findtext("offset"), "offset")
                self.offsets[joint_name] = offset
                if offset != 0.0:
                    self.warnings.append(
                        f"{where}: joint offset {offset:g} of {joint_name} is not "
                        "applied (a joint-side log includes it; for a motor-side "
                        "log give log.position_offset in the drive file)."
                    )
        if short not in _KINDS:
            names = listed(j.attrib.get("name", "") for j in joints)
            self.warnings.append(
                f"{where}: type {kind!r} is not supported (only {', '.join(_KINDS)}); "
                f"ignored: joint(s) {names} "
                "get an implicit direct drive unless the drive file describes them."
            )
            return
        if short == "SimpleTransmission":
            if len(joints) != 1 or len(actuators) != 1:
                self.fail(
                    where,
                    f"a SimpleTransmission has one joint and one actuator; got "
                    f"{len(joints)} and {len(actuators)}",
                )
            self.simple(where, element, joints[0], actuators[0])
            return
        actuators = self.by_role(where, actuators, ("actuator1", "actuator2"))
        joints = self.by_role(where, joints, ("joint1", "joint2"))
        na = [
            self.required_reduction(f"{where}, actuator {a.attrib.get('name')}", a)
            for a in actuators
        ]
        nj = [self.reduction(where, j) or 1.0 for j in joints]
        j1, j2 = (j.attrib["name"] for j in joints)
        if short == "DifferentialTransmission":
            rows = [
                {j1: na[0] * nj[0], j2: na[0] * nj[1]},
                {j1: na[1] * nj[0], j2: -na[1] * nj[1]},
            ]
        else:  # FourBarLinkageTransmission
            rows = [{j1: na[0] * nj[0]}, {j1: na[1], j2: na[1] * nj[1]}]
        for actuator, row in zip(actuators, rows, strict=True):
            if actuator.find(_DRAKE + "gear_ratio") is not None:
                self.warnings.append(
                    f"{where}: drake:gear_ratio of {actuator.attrib.get('name')} is "
                    f"ignored (Drake ignores {short}); the ratios are the "
                    "mechanicalReduction elements."
                )
            self.add(where, actuator, row)

    def simple(self, where: str, element, joint, actuator) -> None:
        actuator_where = f"{where}, actuator {actuator.attrib.get('name')}"
        gear = self.drake_value(actuator_where, actuator, "gear_ratio")
        reduction = self.reduction(actuator_where, actuator)
        if reduction is None:
            reduction = self.reduction(where, element)  # old PR2 format
        if gear is not None and gear == 0.0:
            self.fail(actuator_where, "drake:gear_ratio must be non-zero; got 0")
        if gear is not None and reduction is not None and gear != reduction:
            self.warnings.append(
                f"{actuator_where}: drake:gear_ratio {gear:g} is used (Drake reflects "
                f"N² Ia with it); mechanicalReduction {reduction:g} is ignored."
            )
        ratio = gear if gear is not None else (reduction or 1.0)
        self.add(where, actuator, {joint.attrib["name"]: ratio})

    def add(self, where: str, actuator, row: dict[str, float]) -> None:
        name = actuator.attrib.get("name", "")
        if not name:
            self.fail(where, "an <actuator> has no name")
        if name in self.motors:
            self.fail(where, f"actuator name {name!r} is used by two transmissions")
        table: dict[str, Any] = {"joints": {j: r for j, r in row.items() if r}}
        inertia = self.drake_value(
            f"{where}, actuator {name}", actuator, "rotor_inertia"
        )
        if inertia is not None:
            if inertia < 0.0:
                self.fail(where, f"drake:rotor_inertia of {name} must be >= 0")
            table["rotor_inertia"] = inertia
        self.motors[name] = table


def read_urdf_drive(path: str | os.PathLike) -> UrdfDrive:
    """Reads the transmissions and joint types of a URDF (see the module docstring).

    Raises:
        FileNotFoundError: no such file. ValueError: not XML, or a malformed
            transmission (the message names it).
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError(f"read_urdf_drive: URDF file not found: {path}.")
    try:
        root = parse_urdf_xml(path)
    except ElementTree.ParseError as error:
        raise ValueError(
            f"read_urdf_drive: {path} is not well-formed XML: {error}."
        ) from None
    joints = {
        joint.attrib.get("name", ""): joint.attrib.get("type", "")
        for joint in root.findall("joint")
    }
    reader = _Reader(path, joints)
    for index, element in enumerate(root.findall("transmission")):
        reader.transmission(index, element)
    return UrdfDrive(
        motors=MappingProxyType(reader.motors),
        joint_types=MappingProxyType(joints),
        joint_offsets=MappingProxyType(reader.offsets),
        warnings=tuple(reader.warnings),
    )


def load_drive(
    urdf_path: str | os.PathLike,
    joint_names: Sequence[str],
    drive_path: str | os.PathLike | None = None,
) -> DriveChain:
    """The drive chain of a robot: URDF transmissions, overridden by a drive file.

    Args:
        urdf_path: the URDF (transmissions, Drake actuator tags, joint types).
        joint_names: the identified joints, in the order wanted for q and τ.
        drive_path: an optional TOML drive file (docs/DRIVE.md); without it the log
            format is the plain CSV one (``t``, ``q_<joint>``, ``tau_<joint>``, SI).

    Returns:
        The ``DriveChain``; its ``notes`` hold the URDF warnings and the URDF motors
        that the drive file replaced.
    """
    urdf = read_urdf_drive(urdf_path)
    unknown = [name for name in joint_names if name not in urdf.joint_types]
    if unknown:
        raise ValueError(
            f"load_drive: joint(s) {listed(unknown)} are not joints of "
            f"{os.fspath(urdf_path)}."
        )
    prismatic = [name for name in joint_names if name in urdf.prismatic_joints]
    if drive_path is None:
        chain = DriveChain.from_dict(
            {},
            joint_names,
            prismatic_joints=prismatic,
            urdf=urdf.as_dict(),
            source=f"URDF {os.fspath(urdf_path)}",
        )
    else:
        if not os.path.exists(drive_path):  # the hint the URDF's message gives
            from drake_dynid.urdf import packaged_names

            raise FileNotFoundError(
                f"drive file {os.fspath(drive_path)}: no such file (the dynid "
                "command also takes the name of a packaged drive file: "
                f"{packaged_names('.toml')})."
            )
        chain = read_drive(
            drive_path, joint_names, prismatic_joints=prismatic, urdf=urdf.as_dict()
        )
    return dataclasses.replace(chain, notes=(*urdf.warnings, *chain.notes))


def parse_urdf_xml(
    path: str | os.PathLike, *, comments: bool = False
) -> ElementTree.Element:
    """The URDF's root XML element; ``drake:`` tags are read without their declaration.

    Drake's parser reads ``<drake:rotor_inertia>`` (and its other extensions)
    whether or not the file declares ``xmlns:drake``; ElementTree refuses an
    undeclared prefix ("unbound prefix"). Such a file is read with
    ``xmlns:drake="http://drake.mit.edu"`` added to its ``<robot>`` tag (a
    review found these URDFs refused). Any other file is parsed as it is.
    ``comments``: keep the comments in the tree.

    Raises:
        OSError: the file cannot be read. ElementTree.ParseError: not XML.
    """

    def parse(data: bytes) -> ElementTree.Element:
        builder = ElementTree.TreeBuilder(insert_comments=comments)
        return ElementTree.fromstring(
            data, parser=ElementTree.XMLParser(target=builder)
        )

    data = Path(path).read_bytes()
    try:
        return parse(data)
    except ElementTree.ParseError as error:
        undeclared = b"drake:" in data and b"xmlns:drake" not in data
        if "unbound prefix" not in str(error) or not undeclared:
            raise
    namespace = b' xmlns:drake="' + DRAKE_NAMESPACE.encode() + b'"'
    # The <robot> tag, not a '<robot' in a comment before it.
    for match in re.finditer(rb"<!--.*?-->|<robot\b", data, re.DOTALL):
        if match.group() == b"<robot":
            return parse(data[: match.end()] + namespace + data[match.end() :])
    return parse(data)  # no <robot> tag: ElementTree's error
