"""Write an identified URDF: a copy of the input URDF with the identified parameters.

From consistent standard parameters (``drake_dynid.physical``; every link's
pseudo-inertia ⪰ 0, friction and rotor inertia ≥ 0), for each moving link j (the
child link of identified joint j, then of each moving mimic joint: ``robot.links``):

* the link's ``<inertial>``: ``mass`` m = Mj, ``origin xyz`` = the centre of mass
  c = (MXj, MYj, MZj)/m in the link frame (``rpy="0 0 0"``), and the inertia about
  the centre of mass in the link frame (parallel-axis theorem, tensor entries as
  URDF's ``ixx … izz``)::

      I_c = Ī − m (|c|²·1 − c cᵀ),      Ī = [[XX XY XZ] [XY YY YZ] [XZ YZ ZZ]]

* links welded to it (a flange, a tool), and the links beyond a locked joint,
  whose inertia drake_dynid lumps into the link's standard parameters: their
  ``<inertial>`` becomes mass 0 with zero inertia (an XML comment says into which
  link they were lumped). The identified parameters describe the welded
  assembly; splitting them again between the bodies is not identifiable. Bodies
  welded to the world are left unchanged;
* a locked joint (``robot.locked``: outside ``joints=``, at its locked position,
  or a mimic joint of a locked leader) becomes a ``fixed`` joint at that position
  (origin = the joint's origin composed with its motion: the lumped inertia holds
  only there), without its axis, limits, dynamics and transmission;
* an identified joint's ``<dynamics damping="FVj" friction="FCj">``; a friction
  kind that was not identified is written as 0 (the identified model has none);
  ``OFFj`` has no URDF field and is listed in ``UrdfExport.skipped``;
* without rotor inertia (the model has no IAj), the input's
  ``drake:rotor_inertia`` of the joint is written as 0 (Drake would add it to
  an identified model that has none), as a moving mimic joint's always is (no
  model has a column for it);
* with rotor inertia, ``<drake:rotor_inertia value="IAj/g²">`` in the joint's
  ``<transmission><actuator>`` (Drake's tag; g = the actuator's
  ``drake:gear_ratio``, written as the drive chain's ratio of the joint's motor
  with a drive file; when absent, as the actuator's ``<mechanicalReduction>``,
  the ratio drake_dynid's drive chain reads, else 1), so that Drake's reflected
  inertia is IAj. A joint without a ``<transmission>`` gets a
  ``SimpleTransmission`` with one actuator. A joint of a transmission with
  several joints (a differential wrist: Drake reads no such transmission) has no
  field for its IAj: listed in ``skipped``, as the coupled motors' ``IAmk``,
  ``FVmk``, ``FCmk``, ``OFFmk``.

Everything else (comments, geometry, limits) is copied; relative mesh file names
are made absolute when the output goes to another directory; values below 1e-12
of the link's largest (solver round-off) are written as 0. A comment at the top
says what was written, what was not, the fit's Coulomb law and, with a drive
file, that the joint friction (and the rotor inertia, with rotor inertia) are
the joint-side totals (its motors' reflected values included). Drake ignores the
``friction`` attribute (drake_dynid reads it, ``read_urdf_friction``); Drake's
``CalcInverseDynamics`` of the written file plus Coulomb friction FCj·s(vj), s
the fit's law (sign(v), the dead zone or tanh(v/ε): ``robot.sign``; off-line the
dead zone with its reversals restored, ``core.standstill.reversal_signs``),
reproduces the identified model's W·θ (tests/test_urdf_writer.py: the 2R, the iiwa7,
locked, welded and mimic joints).
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ElementTree
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.drive_urdf import DRAKE_NAMESPACE, parse_urdf_xml
from drake_dynid.files import write_text_whole

__all__ = [
    "UrdfExport",
    "doubtful_links",
    "drive_totals",
    "implausible_links",
    "implausible_note",
    "totals_words",
    "unwritten",
    "write_identified_urdf",
]

#: Written in the header comment of a file identified with a drive file (the
#: joint friction and rotor inertia are joint-side totals); ``RobotModel``
#: reads them as they are when such a file is loaded with a drive file again
#: (:func:`drive_totals`).
DRIVE_TOTALS = "are joint-side totals, its motors' reflected values included"
#: Opens the header comment of a written file; :func:`drive_totals` and
#: :func:`implausible_links` read that comment only (not a stale copy of it, nor
#: the same words elsewhere in the file).
HEADER = "Identified by drake_dynid from"
_HEADER = re.compile(r"\s+".join(HEADER.split()))
_UNWRITTEN = re.compile(
    r"Identified,\s+no\s+URDF\s+field\s+\(not\s+written\):\s*([^.]*)\."
)
#: The header's words for the joint fields that hold a drive's totals, and the
#: kinds ``drive_totals`` returns for them.
_TOTAL_KINDS = {"damping": "viscous", "friction": "coulomb", "rotor inertia": "inertia"}
_WORD = r"(?:damping|friction|rotor\s+inertia)"
_TOTALS = re.compile(
    rf"the\s+joint\s+({_WORD}(?:(?:,\s*|\s+and\s+){_WORD})*)\s+"
    + r"\s+".join(map(re.escape, DRIVE_TOTALS.split()))
)
#: Opens the header line naming the links :func:`doubtful_links` found
#: (:func:`implausible_note`; read back by :func:`implausible_links`).
IMPLAUSIBLE = "Consistent but implausible, check before use"
_OWNER = "write_identified_urdf"
_INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
_TOLERANCE = 1e-9  # relative: smallest accepted pseudo-inertia eigenvalue
_ROUND_OFF = 1e-12  # relative: smaller centre-of-mass or inertia entries are 0
_ROUND_OFF_FRICTION = 1e-9  # relative to the largest friction (or 1): smaller is 0
_DOUBTFUL_MASS = (1e-2, 10.0)  # a written mass outside these multiples of the URDF's
_DOUBTFUL_REACH = 10.0  # a centre of mass farther than this many L_j from the origin
_REACH_FLOOR = 0.01  # [m] the least L_j: a URDF's placeholder inertia (1e-6 kg·m²)
_PROLOG = re.compile(r"\A\s*(?:<\?xml[^>]*\?>\s*)?((?:<!--.*?-->\s*)*)", re.S)


@dataclass(frozen=True)
class UrdfExport:
    """What :func:`write_identified_urdf` wrote.

    Attributes:
        path: the written file.
        links: the links whose ``<inertial>`` holds identified values.
        lumped: welded links set to mass 0 (lumped into an identified link).
        skipped: identified parameters with no URDF field (``OFFj``, the coupled
            motors' ``IAmk``, ``FVmk``, ``FCmk``, ``OFFmk``, ``IAj`` of a joint in a
            transmission of several joints).
        locked: the joints written as fixed joints at their locked positions.
    """

    path: str
    links: tuple[str, ...]
    lumped: tuple[str, ...]
    skipped: tuple[str, ...]
    locked: tuple[str, ...] = ()


def _comment(text: str) -> Any:
    """An XML comment of ``text`` ("--" may not appear in one: a name may hold it)."""
    return ElementTree.Comment(" " + text.replace("--", "- -") + " ")


def _number(value: float) -> str:
    return repr(float(value) + 0.0)  # + 0.0: no "-0.0"


def _link_groups(
    plant: Any, joint_names: tuple[str, ...], locked: frozenset[str] = frozenset()
) -> dict[str, int]:
    """Body name -> index of the joint whose link it is lumped into (-1: world).

    A joint of ``locked`` is a weld (``plant_tree.extract_tree``'s lumping).
    """
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    group = {plant.world_body().name(): -1}
    for k, name in enumerate(joint_names):
        group[plant.GetJointByName(name).child_body().name()] = k
    changed = True
    while changed:
        changed = False
        for joint in joints:
            parent, child = joint.parent_body().name(), joint.child_body().name()
            welded = joint.type_name() == "weld" or joint.name() in locked
            if welded and parent in group and child not in group:
                group[child] = group[parent]
                changed = True
    return group


def _inertial_element(mass: float, com: np.ndarray, inertia: np.ndarray) -> Any:
    inertial = ElementTree.Element("inertial")
    ElementTree.SubElement(
        inertial, "origin", xyz=" ".join(_number(x) for x in com), rpy="0 0 0"
    )
    ElementTree.SubElement(inertial, "mass", value=_number(mass))
    entries = {
        "ixx": inertia[0, 0],
        "ixy": inertia[0, 1],
        "ixz": inertia[0, 2],
        "iyy": inertia[1, 1],
        "iyz": inertia[1, 2],
        "izz": inertia[2, 2],
    }
    ElementTree.SubElement(
        inertial, "inertia", {k: _number(v) for k, v in entries.items()}
    )
    return inertial


def _replace_inertial(link: Any, inertial: Any) -> None:
    old = link.find("inertial")
    if old is None:
        link.insert(0, inertial)
    else:
        position = list(link).index(old)
        link.remove(old)
        link.insert(position, inertial)


def _link_inertial(name: str, joint: str, theta: np.ndarray) -> Any:
    """The ``<inertial>`` of standard parameters [XX..M] (checked consistent)."""
    xx, xy, xz, yy, yz, zz, mx, my, mz, mass = theta
    about_origin = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    first = np.array([mx, my, mz])
    sigma = 0.5 * np.trace(about_origin) * np.eye(3) - about_origin
    pseudo = np.block([[sigma, first[:, None]], [first[None, :], np.array([[mass]])]])
    smallest = float(np.linalg.eigvalsh(pseudo)[0])
    size = float(np.abs(pseudo).max())
    if not mass > 0.0 or smallest < -_TOLERANCE * size:
        check.fail(
            _OWNER,
            f"link {name!r} (joint {joint!r}) is not physically consistent: mass "
            f"{mass:.6g} kg, smallest pseudo-inertia eigenvalue {smallest:.3g}; write "
            "the consistent parameters (drake_dynid.physical, dynid offline "
            "--physical).",
        )
    com = first / mass
    inertia = about_origin - mass * (com @ com * np.eye(3) - np.outer(com, com))
    # Round-off of the solver (1e-20 products of inertia) is written as 0.
    com = np.where(np.abs(com) < _ROUND_OFF * np.abs(com).max(), 0.0, com)
    inertia = np.where(
        np.abs(inertia) < _ROUND_OFF * np.abs(inertia).max(), 0.0, inertia
    )
    return _inertial_element(mass, com, inertia)


def _absolute_filenames(root: Any, source: Path, output: Path) -> None:
    if source.parent.resolve() == output.parent.resolve():
        return
    # Only files the URDF names beside it: meshes and textures (a Gazebo
    # <plugin filename="libx.so"> is a library on Gazebo's own search path).
    for element in root.iter():
        name = element.attrib.get("filename")
        if element.tag not in ("mesh", "texture"):
            continue
        if name and "://" not in name and not os.path.isabs(name):
            element.set("filename", str((source.parent / name).resolve()))


def motor_friction(
    drive: Any, kinds: Sequence[str] = ("viscous", "coulomb", "offset")
) -> bool:
    """Whether a drive chain adds motor friction to the joints' a-priori values.

    ``DriveChain.reflected_friction`` (its simple motors' ``viscous``,
    ``coulomb``, ``offset``; ``kinds``: those looked at) not all 0: a file
    written with it holds that friction in its joint friction already
    (:func:`drive_totals`).
    """
    extra = drive.reflected_friction()
    return any(np.any(extra[kind] != 0.0) for kind in kinds)


def _header_comment(text: str) -> str:
    """The text of a written file's header comment (:data:`HEADER`), or ""."""
    found = _HEADER.search(text)
    if found is None:
        return ""
    start = found.start()
    end = text.find("-->", start)
    return text[start : end if end >= 0 else len(text)]


def totals_words(kinds: Collection[str]) -> str:
    """The header's words for ``kinds`` of :func:`drive_totals`, in its order.

    ``{"viscous", "inertia"}`` -> ``"damping and rotor inertia"``.
    """
    words = [word for word, kind in _TOTAL_KINDS.items() if kind in kinds]
    return " and ".join([", ".join(words[:-1]), words[-1]] if len(words) > 1 else words)


def drive_totals(text: str) -> frozenset[str]:
    """Which of a URDF's joint fields hold a drive's joint-side totals.

    ``text``: the file. A file this module wrote with a drive file says so in
    its header comment (:data:`HEADER`, :data:`DRIVE_TOTALS`), naming the
    fields the fit identified: ``damping`` (FVj, kind ``"viscous"``),
    ``friction`` (FCj, ``"coulomb"``), ``rotor inertia`` (the
    ``drake:rotor_inertia`` that reflects to IAj, ``"inertia"``), the motors'
    reflected values included. Loaded with a drive file again, ``RobotModel``
    reads those as they are (``robot_drive.drive_table``): the round trip gives
    the fit's standard values. A field the fit did not identify (written as 0)
    and the ones no URDF field holds (``OFFj``, the motor-side ``IAmk``,
    ``FVmk``, ``FCmk``) get the drive file's a-priori values as for any URDF.

    Returns:
        The kinds among ``"viscous"``, ``"coulomb"``, ``"inertia"`` (none for a
        file without such a header).
    """
    found = _TOTALS.search(_header_comment(text))
    if found is None:
        return frozenset()
    words = re.split(r",\s*|\s+and\s+", found.group(1))
    return frozenset(_TOTAL_KINDS[" ".join(word.split())] for word in words)


def unwritten(text: str) -> frozenset[str]:
    """The identified parameters a written file's header says it does not hold.

    ``text``: the file. Its header's "Identified, no URDF field (not written)"
    line (``OFFj``, the coupled motors' ``IAmk``..., the ``IAj`` of a joint in
    a transmission of several joints): such an ``IAj`` is no total of
    :func:`drive_totals` (the drive file's rotor inertia gives it, as for any
    URDF). None for a file without a header.
    """
    found = _UNWRITTEN.search(_header_comment(text))
    if found is None:
        return frozenset()
    return frozenset(name.strip() for name in found.group(1).split(","))


def _dynamics(joint: Any) -> Any:
    dynamics = joint.find("dynamics")
    if dynamics is None:
        dynamics = ElementTree.SubElement(joint, "dynamics")
    return dynamics


def _set_rotor_inertia(
    root: Any, joint: str, value: float, ratio: float | None = None
) -> bool:
    """Writes IAj in the joint's transmission; False where there is no field.

    A transmission of several joints (a differential) has none. A joint without
    a transmission gets a ``SimpleTransmission`` (Drake reads its actuator's
    ``drake:rotor_inertia``; drake_dynid actuates such a joint anyway).
    ``ratio``: the drive chain's gear ratio of the joint's motor, written as
    ``drake:gear_ratio`` (the drive file's ratio overrides the URDF's when the
    file is loaded with it again: both then reflect IAj).
    """
    drake = f"{{{DRAKE_NAMESPACE}}}"
    found = [
        transmission
        for transmission in root.findall("transmission")
        if joint in [j.attrib.get("name") for j in transmission.iter("joint")]
    ]
    if not found:
        transmission = ElementTree.SubElement(
            root, "transmission", name=f"{joint}_dynid_transmission"
        )
        kind = ElementTree.SubElement(transmission, "type")
        kind.text = "transmission_interface/SimpleTransmission"
        element = ElementTree.SubElement(transmission, "joint", name=joint)
        ElementTree.SubElement(
            element, "hardwareInterface"
        ).text = "EffortJointInterface"
        found = [transmission]
    transmission = found[0]
    joints = {j.attrib.get("name") for j in transmission.iter("joint")}
    actuators = transmission.findall("actuator")
    if len(found) > 1 or len(joints) > 1 or len(actuators) > 1:
        return False
    if not actuators:
        actuators = [
            ElementTree.SubElement(transmission, "actuator", name=f"{joint}_motor")
        ]
    actuator = actuators[0]
    ratio_element = actuator.find(f"{drake}gear_ratio")
    if ratio is not None:
        if ratio_element is None:
            ratio_element = ElementTree.SubElement(actuator, f"{drake}gear_ratio")
        ratio_element.set("value", _number(ratio))
    elif ratio_element is None:
        # The ratio drake_dynid's drive chain reads (drive_urdf: the actuator's,
        # else the transmission's <mechanicalReduction>, else 1): a gear ratio of 1
        # would win over it and change R for a file loaded with a drive file.
        reduction = actuator.findtext("mechanicalReduction")
        if reduction is None:
            reduction = transmission.findtext("mechanicalReduction")
        try:
            ratio = float((reduction or "1").strip())
        except ValueError:
            ratio = 1.0
        ratio_element = ElementTree.SubElement(actuator, f"{drake}gear_ratio")
        ratio_element.set("value", _number(ratio if ratio else 1.0))
    ratio = float(ratio_element.attrib.get("value", "1"))
    rotor = actuator.find(f"{drake}rotor_inertia")
    if rotor is None:
        rotor = ElementTree.SubElement(actuator, f"{drake}rotor_inertia")
    rotor.set("value", _number(value / ratio**2))
    return True


def _zero_rotor_inertia(root: Any, joint: str) -> bool:
    """Sets the joint's ``drake:rotor_inertia`` to 0; True if one was not 0.

    A model without rotor inertia (no ``rotor_inertia``): Drake would add the
    input's N²·Ia to the identified model, which has none (the data's rotor
    inertia is in the link parameters it regroups with). Only the one-joint
    transmissions Drake reads.
    """
    changed = False
    for transmission in root.findall("transmission"):
        joints = {j.attrib.get("name") for j in transmission.iter("joint")}
        if joints != {joint}:
            continue
        for rotor in transmission.iter(f"{{{DRAKE_NAMESPACE}}}rotor_inertia"):
            try:
                value = float(rotor.attrib.get("value", "0"))
            except ValueError:
                value = 1.0  # not a number: replaced all the same
            changed = changed or value != 0.0
            rotor.set("value", "0")
    return changed


def _numbers(text: str | None, default: tuple[float, ...]) -> np.ndarray:
    if text is None or not text.split():
        return np.array(default, dtype=float)
    return np.array([float(x) for x in text.split()], dtype=float)


def _lock_joint(root: Any, joint: Any, position: float) -> None:
    """Makes ``joint`` a fixed joint at ``position`` [rad or m] (module docstring).

    X_PC = X_PJ · X_JC(q): the origin composed with a rotation about the axis
    (revolute, continuous) or a translation along it (prismatic).
    """
    from pydrake.common.eigen_geometry import AngleAxis
    from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix

    name = joint.attrib.get("name", "")
    kind = joint.attrib.get("type", "")
    origin = joint.find("origin")
    xyz = _numbers(None if origin is None else origin.attrib.get("xyz"), (0, 0, 0))
    rpy = _numbers(None if origin is None else origin.attrib.get("rpy"), (0, 0, 0))
    axis_element = joint.find("axis")
    axis = _numbers(
        None if axis_element is None else axis_element.attrib.get("xyz"), (1, 0, 0)
    )
    axis = axis / np.linalg.norm(axis)
    pose = RigidTransform(RollPitchYaw(rpy), xyz)
    if kind == "prismatic":
        motion = RigidTransform(position * axis)
    else:
        motion = RigidTransform(RotationMatrix(AngleAxis(position, axis)), np.zeros(3))
    fixed = pose.multiply(motion)
    for tag in ("axis", "limit", "dynamics", "mimic", "safety_controller"):
        for element in joint.findall(tag):
            joint.remove(element)
    if origin is None:
        origin = ElementTree.SubElement(joint, "origin")
    origin.set("xyz", " ".join(_number(x) for x in fixed.translation()))
    origin.set(
        "rpy", " ".join(_number(x) for x in RollPitchYaw(fixed.rotation()).vector())
    )
    joint.set("type", "fixed")
    joint.insert(
        0,
        _comment(
            f"drake_dynid: {kind} joint locked at {position!r} "
            f"{'m' if kind == 'prismatic' else 'rad'} in the identification (its "
            "child links are lumped into the identified link: valid there only)"
        ),
    )
    for transmission in root.findall("transmission"):
        if name in [j.attrib.get("name") for j in transmission.iter("joint")]:
            root.remove(transmission)


def _law(robot: Any) -> str:
    """The fit's Coulomb law s(v), in words."""
    sign = getattr(robot, "sign", None)
    kind = type(sign).__name__
    width: Any = getattr(sign, "width", 0.0)
    if kind == "TanhSign":
        return f"tanh(v/{float(width)!r}) (the fit's coulomb-width)"
    if kind == "DeadZoneSign":
        widths = (width,) * robot.num_joints if isinstance(width, float) else width
        listed = ", ".join(
            f"{name} {float(w):.3g}"
            for name, w in zip(robot.joint_names, widths, strict=True)
        )
        return (
            f"sign(v), 0 for |v| <= w (dead zone, w: {listed}); off-line (dynid "
            "offline, the validations) a moving joint's reversal through the zone, "
            "a run of at most L = floor(1/(8 f_c h)) samples between L outside of "
            "each sign, keeps the sign of the line through its neighbours "
            "(core.standstill.reversal_signs, docs/MATH.md section 2)"
        )
    return "sign(v)"


def _header(
    robot: Any,
    source: Path,
    written: list[str],
    skipped: list[str],
    locked: dict[str, float],
    zeroed: list[str],
) -> list[str]:
    """The lines of the comment at the top: what the file holds and what not."""
    drive = getattr(robot, "drive", None)
    lines = [
        f"{HEADER} {source.name}: <inertial> of "
        f"{', '.join(written)}; joint damping/friction"
        + ("; drake:rotor_inertia" if robot.rotor_inertia else "")
        + ".",
        f"Coulomb friction of the fit: FCj * {_law(robot)}; Drake ignores the "
        "friction attribute."
        if "coulomb" in tuple(getattr(robot, "friction", ("coulomb",)))
        else "No Coulomb friction in the fit.",
    ]
    if locked:
        lines.append(
            "Locked in the identification, fixed here: "
            + ", ".join(f"{name} = {value!r}" for name, value in locked.items())
            + "."
        )
    if zeroed:
        lines.append(f"Not identified, written as 0: {', '.join(zeroed)}.")
    if skipped:
        lines.append(f"Identified, no URDF field (not written): {', '.join(skipped)}.")
    kinds = tuple(getattr(robot, "friction", ()))
    totals = {*kinds, *(["inertia"] if robot.rotor_inertia else [])}
    words = totals_words(totals)
    if drive is not None and words:
        frictions = [kind for kind in ("viscous", "coulomb") if kind in kinds]
        read_back = (
            "; loaded with a drive file again, drake_dynid reads them as they are "
            "(the drive file's motor friction is not added again)."
            if frictions and motor_friction(drive, frictions)
            else "."
        )
        inertia = (
            " The rotor inertia of a joint with a motor of its own is written for "
            "that motor's gear ratio N (drake:gear_ratio N, drake:rotor_inertia "
            "IAj/N²): Drake and the same drive file reflect it to IAj (the "
            "drive file's own rotor_inertia does not replace it); a joint driven only "
            "by coupled motors keeps its actuator's ratio."
            if robot.rotor_inertia
            else ""
        )
        # Only what the fit identified: a field written as 0 (no rotor inertia
        # columns, no viscous or Coulomb friction in the fit) is no total.
        lines.append(
            f"With the {getattr(drive, 'source', 'drive file')}: the joint "
            f"{words} {DRIVE_TOTALS}{read_back}{inertia}"
        )
    return lines


def doubtful_links(robot: Any, standard_values: Any) -> tuple[str, ...]:
    """The written links whose mass or centre of mass is implausible, described.

    A consistent estimate can still put a link's mass near 0 and its centre of
    mass metres away (m·c small, m·|c|² within the inertia): the data see only the
    base parameters, and a regrouped link's mass and first moment are shared with
    its neighbours, and with λ = 0 nothing holds what the data do not see (the
    README's UR5 log: shoulder_link at 78.8 kg for 3.7). A link is named when its
    mass is below 1 % or above 10 times the URDF's (``robot.standard_values``), or
    its centre of mass is more than 10 L_j from the link origin, L_j =
    max(√(tr Σ_j / m_j), 1 cm) the URDF's radius of gyration about that origin
    [m] (Σ_j the second moment of the pseudo-inertia; the 1 cm floor for URDFs
    whose links hold placeholder inertias, 1e-6 kg·m² on 1 kg: L_j 1.2 mm would
    name a centre of mass 13 mm out).

    Returns:
        One ``"link: mass m kg (URDF m0), centre of mass d m from its origin
        (URDF d0)"`` per such link, in joint order.
    """
    names = tuple(robot.standard_names)
    values = dict(zip(names, np.asarray(standard_values, dtype=float), strict=True))
    prior = dict(
        zip(names, np.asarray(robot.standard_values, dtype=float), strict=True)
    )
    moving = tuple(getattr(robot, "links", ()) or robot.joint_names)
    out = []
    for k, joint_name in enumerate(moving):
        j = k + 1
        link = robot.plant.GetJointByName(joint_name).child_body().name()
        mass, mass0 = values[f"M{j}"], prior[f"M{j}"]
        if not mass0 > 0.0:
            continue
        first = np.array([values[f"M{a}{j}"] for a in "XYZ"])
        first0 = np.array([prior[f"M{a}{j}"] for a in "XYZ"])
        trace0 = sum(prior[f"{a}{j}"] for a in ("XX", "YY", "ZZ"))  # tr Σ = tr Ī / 2
        reach = max(math.sqrt(max(0.5 * trace0, 0.0) / mass0), _REACH_FLOOR)
        distance = float(np.linalg.norm(first) / mass) if mass > 0.0 else math.inf
        low, high = _DOUBTFUL_MASS
        if not low * mass0 <= mass <= high * mass0 or (
            distance > _DOUBTFUL_REACH * reach
        ):
            out.append(
                f"{link}: mass {mass:.3g} kg (URDF {mass0:.3g}), centre of mass "
                f"{distance:.3g} m from its origin (URDF "
                f"{float(np.linalg.norm(first0)) / mass0:.3g})"
            )
    return tuple(out)


def implausible_note(doubtful: Sequence[str]) -> str:
    """The header line naming the links of :func:`doubtful_links` (``notes=``)."""
    return (
        f"{IMPLAUSIBLE} (the base parameters share a link's mass and first moment "
        "with its neighbours, or the data contradict the URDF; a larger "
        "regularization λ pulls towards the URDF's, --regularizer entropic keeps "
        "masses off 0): " + "; ".join(doubtful) + "."
    )


_DOUBTFUL_ENTRY = re.compile(
    r"([^\s;:]+): mass (\S+) kg \(URDF (\S+)\), centre of mass (\S+) m from its "
    r"origin \(URDF (\S+)\)"
)


def implausible_links(
    text: str,
) -> tuple[tuple[str, float, float, float, float], ...]:
    """The links a written file's header names as implausible.

    ``text``: the file. Returns ``(link, mass [kg], centre-of-mass distance from
    the link origin [m], the URDF's mass [kg], the URDF's distance [m])`` per
    link of its :func:`implausible_note` line (none for a file without one).
    """
    header = _header_comment(text)
    start = header.find(IMPLAUSIBLE)
    if start < 0:
        return ()
    end = header.find("\n", start)
    line = header[start : end if end >= 0 else len(header)]
    return tuple(
        (
            m.group(1),
            float(m.group(2)),
            float(m.group(4)),
            float(m.group(3)),
            float(m.group(5)),
        )
        for m in _DOUBTFUL_ENTRY.finditer(line)
    )


def write_identified_urdf(
    robot: Any,
    standard_values: Any,
    path: str | os.PathLike,
    *,
    notes: Sequence[str] = (),
) -> UrdfExport:
    """Writes a copy of ``robot``'s URDF with the given standard parameters.

    See the module docstring for what is written where.

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel` the parameters belong to
            (built from a URDF file: ``robot.path``).
        standard_values: (p_std,) physically consistent standard values in
            ``robot.standard_names`` order (e.g. ``PhysicalResult.standard_values``).
        path: the output file; never the input URDF.
        notes: more lines for the header comment (e.g. the parameters the fit
            flagged as not identified).

    Returns:
        A :class:`UrdfExport`.

    Raises:
        ValueError: the robot has no URDF file, the output is the input, values of
            the wrong size, or a link, friction or rotor inertia that is not
            physically consistent.
    """
    check.having(
        _OWNER,
        "robot",
        robot,
        ("path", "standard_names", "joint_names"),
        "a RobotModel",
    )
    if not robot.path or not Path(robot.path).is_file():
        check.fail(_OWNER, "robot must be built from a URDF file (robot.path).")
    source = Path(robot.path)
    output = Path(os.fspath(path))
    if output.resolve() == source.resolve():
        check.fail(
            _OWNER, f"path must differ from the input URDF {source}; got {output}."
        )
    names = tuple(robot.standard_names)
    theta = check.array(_OWNER, "standard_values", standard_values, shape=(len(names),))
    values = dict(zip(names, theta.tolist(), strict=True))
    for name, value in values.items():
        if name.startswith(("FV", "FC", "IA")) and value < 0.0:
            check.fail(
                _OWNER,
                f"{name} must be >= 0 (friction and rotor inertia dissipate or store "
                f"energy); got {value:.6g}.",
            )
    ElementTree.register_namespace("drake", DRAKE_NAMESPACE)
    try:
        root = parse_urdf_xml(source, comments=True)
    except ElementTree.ParseError as error:
        check.fail(_OWNER, f"{source} is not well-formed XML: {error}.")
    tree = ElementTree.ElementTree(root)
    # The header of a file written before (re-identified from it) described
    # that file's values: the one written here replaces it.
    for element in list(root):
        if element.tag is ElementTree.Comment and (
            element.text or ""
        ).strip().startswith(HEADER):
            root.remove(element)
    links_by_name = {link.attrib.get("name"): link for link in root.findall("link")}
    joints_by_name = {j.attrib.get("name"): j for j in root.findall("joint")}
    moving = tuple(getattr(robot, "links", ()) or robot.joint_names)
    locked = {str(k): float(v) for k, v in dict(getattr(robot, "locked", {})).items()}
    groups = _link_groups(robot.plant, moving, frozenset(locked))
    n = len(robot.joint_names)
    written: list[str] = []
    lumped: list[str] = []
    skipped: list[str] = []
    zeroed: list[str] = []
    folded: list[str] = []  # a moving mimic joint's, in its leader's FVj, FCj
    # The drive chain's ratio of each joint's simple motor (its IAj = N²·Ia).
    drive = getattr(robot, "drive", None)
    ratios = {
        int(motor.joints[0]): float(motor.row[motor.joints[0]])
        for motor in (drive.motors if drive is not None else ())
        if not motor.coupled
    }
    friction_scale = max(
        [1.0, *(abs(v) for name, v in values.items() if name[:2] in ("FV", "FC"))]
    )
    for k, joint_name in enumerate(moving):
        j = k + 1
        link_name = robot.plant.GetJointByName(joint_name).child_body().name()
        parameters = np.array([values[f"{p}{j}"] for p in _INERTIAL])
        _replace_inertial(
            links_by_name[link_name], _link_inertial(link_name, joint_name, parameters)
        )
        written.append(link_name)
        joint = joints_by_name[joint_name]
        for kind, attribute in (("FV", "damping"), ("FC", "friction")):
            # A moving mimic joint (k >= n) has no friction columns.
            if k < n and f"{kind}{j}" in values:
                value = values[f"{kind}{j}"]
                # A friction the consistent solve holds at its bound 0 comes out
                # at 1e-11: written as 0 (Drake's parser warns on any non-zero
                # friction attribute).
                value = 0.0 if value <= _ROUND_OFF_FRICTION * friction_scale else value
                _dynamics(joint).set(attribute, _number(value))
            else:
                dynamics = joint.find("dynamics")
                if dynamics is not None and float(dynamics.get(attribute, 0.0)):
                    (zeroed if k < n else folded).append(f"{attribute} of {joint_name}")
                if dynamics is not None and attribute in dynamics.attrib:
                    dynamics.set(attribute, "0")
        if k >= n:
            # A moving mimic joint has no rotor inertia column in any model.
            if _zero_rotor_inertia(root, joint_name):
                zeroed.append(f"rotor inertia of {joint_name}")
            continue
        if f"OFF{j}" in values:
            skipped.append(f"OFF{j}")
        if f"IA{j}" in values and not _set_rotor_inertia(
            root, joint_name, values[f"IA{j}"], ratios.get(k)
        ):
            skipped.append(f"IA{j}")
        if not robot.rotor_inertia and _zero_rotor_inertia(root, joint_name):
            zeroed.append(f"rotor inertia of {joint_name}")
    for joint_name, position in locked.items():
        if joint_name in joints_by_name:
            _lock_joint(root, joints_by_name[joint_name], position)
    # Coupled motors' parameters (IAmk, FVmk, FCmk, OFFmk) have no URDF field.
    skipped += [name for name in names if re.fullmatch(r"(IA|FV|FC|OFF)m\d+", name)]
    for body, k in groups.items():
        if k < 0 or body in written or body not in links_by_name:
            continue
        link = links_by_name[body]
        _replace_inertial(link, _inertial_element(0.0, np.zeros(3), np.zeros((3, 3))))
        link.insert(
            0,
            _comment(
                f"drake_dynid: inertia lumped into the identified link {written[k]!r}"
            ),
        )
        lumped.append(body)
    lines = _header(robot, source, written, skipped, locked, zeroed)
    if folded:
        lines.append(
            "A moving mimic joint's friction is part of its leader's FVj, FCj in "
            f"drake_dynid's model: written as 0 here: {', '.join(folded)}."
        )
    root.insert(0, _comment("\n     ".join([*lines, *notes])))
    _absolute_filenames(root, source, output)
    ElementTree.indent(tree, space="  ")
    # ElementTree drops the comments before the root element: copy them.
    prolog = _PROLOG.match(source.read_text(encoding="utf-8"))
    comments = prolog.group(1).strip() if prolog else ""
    body = ElementTree.tostring(root, encoding="unicode")
    write_text_whole(  # a full disk leaves no truncated URDF
        output,
        '<?xml version="1.0" encoding="utf-8"?>\n'
        + (comments + "\n" if comments else "")
        + body
        + "\n",
    )
    return UrdfExport(
        str(output), tuple(written), tuple(lumped), tuple(skipped), tuple(locked)
    )
