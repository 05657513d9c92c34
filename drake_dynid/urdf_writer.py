"""Write an identified URDF: a copy of the input URDF with the identified parameters.

From consistent standard parameters (``drake_dynid.physical``; every link's
pseudo-inertia ⪰ 0, friction and rotor inertia ≥ 0), for each moving joint j and
its child link (the link that carries the standard parameters ``XXj … Mj``):

* the link's ``<inertial>``: ``mass`` m = Mj, ``origin xyz`` = the centre of mass
  c = (MXj, MYj, MZj)/m in the link frame (``rpy="0 0 0"``), and the inertia about
  the centre of mass in the link frame (parallel-axis theorem, tensor entries as
  URDF's ``ixx … izz``)::

      I_c = Ī − m (|c|²·1 − c cᵀ),      Ī = [[XX XY XZ] [XY YY YZ] [XZ YZ ZZ]]

* links welded to it (a flange, a tool), whose inertia drake_dynid lumps into the
  link's standard parameters: their ``<inertial>`` becomes mass 0 with zero
  inertia (an XML comment says into which link they were lumped). The identified
  parameters describe the welded assembly; splitting them again between the
  bodies is not identifiable. Bodies welded to the world are left unchanged;
* the joint's ``<dynamics damping="FVj" friction="FCj">`` (friction kinds that
  were not identified keep the input's values; ``OFFj`` has no URDF field and is
  listed in ``UrdfExport.skipped``);
* with rotor inertia, ``<drake:rotor_inertia value="IAj/g²">`` in the joint's
  ``<transmission><actuator>`` (Drake's tag; g = the actuator's
  ``drake:gear_ratio``, written as 1 when absent), so that Drake's reflected
  inertia is IAj.

Everything else (comments, geometry, limits) is copied; relative mesh file names
are made absolute when the output goes to another directory; values below 1e-12
of the link's largest (solver round-off) are written as 0. Drake ignores the
``friction`` attribute (drake_dynid reads it, ``read_urdf_friction``); Drake's
``CalcInverseDynamics`` of the written file plus Coulomb friction FCj·sign(vj)
reproduces the identified model's W·θ (tested on the 2R arm and the iiwa7).
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check

__all__ = ["UrdfExport", "write_identified_urdf"]

DRAKE_NAMESPACE = "http://drake.mit.edu"
_OWNER = "write_identified_urdf"
_INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
_TOLERANCE = 1e-9  # relative: smallest accepted pseudo-inertia eigenvalue
_ROUND_OFF = 1e-12  # relative: smaller centre-of-mass or inertia entries are 0
_PROLOG = re.compile(r"\A\s*(?:<\?xml[^>]*\?>\s*)?((?:<!--.*?-->\s*)*)", re.S)


@dataclass(frozen=True)
class UrdfExport:
    """What :func:`write_identified_urdf` wrote.

    Attributes:
        path: the written file.
        links: the links whose ``<inertial>`` holds identified values.
        lumped: welded links set to mass 0 (lumped into an identified link).
        skipped: identified parameters with no URDF field (``OFFj``, the coupled
            motors' ``IAmk``, ``FVmk``, ``FCmk``, ``OFFmk``).
    """

    path: str
    links: tuple[str, ...]
    lumped: tuple[str, ...]
    skipped: tuple[str, ...]


def _number(value: float) -> str:
    return repr(float(value) + 0.0)  # + 0.0: no "-0.0"


def _link_groups(plant: Any, joint_names: tuple[str, ...]) -> dict[str, int]:
    """Body name -> index of the joint whose link it is lumped into (-1: world)."""
    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
    group = {plant.world_body().name(): -1}
    for k, name in enumerate(joint_names):
        group[plant.GetJointByName(name).child_body().name()] = k
    changed = True
    while changed:
        changed = False
        for joint in joints:
            parent, child = joint.parent_body().name(), joint.child_body().name()
            if joint.type_name() == "weld" and parent in group and child not in group:
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
    for element in root.iter():
        name = element.attrib.get("filename")
        if name and "://" not in name and not os.path.isabs(name):
            element.set("filename", str((source.parent / name).resolve()))


def _dynamics(joint: Any) -> Any:
    dynamics = joint.find("dynamics")
    if dynamics is None:
        dynamics = ElementTree.SubElement(joint, "dynamics")
    return dynamics


def _set_rotor_inertia(root: Any, joint: str, value: float) -> None:
    drake = f"{{{DRAKE_NAMESPACE}}}"
    for transmission in root.findall("transmission"):
        names = [j.attrib.get("name") for j in transmission.iter("joint")]
        actuator = transmission.find("actuator")
        if joint not in names or actuator is None:
            continue
        ratio_element = actuator.find(f"{drake}gear_ratio")
        if ratio_element is None:
            ratio_element = ElementTree.SubElement(actuator, f"{drake}gear_ratio")
            ratio_element.set("value", "1")
        ratio = float(ratio_element.attrib.get("value", "1"))
        rotor = actuator.find(f"{drake}rotor_inertia")
        if rotor is None:
            rotor = ElementTree.SubElement(actuator, f"{drake}rotor_inertia")
        rotor.set("value", _number(value / ratio**2))
        return
    check.fail(
        _OWNER,
        f"joint {joint!r} has no <transmission> with an <actuator> in the URDF; the "
        "rotor inertia has nowhere to go (Drake reads drake:rotor_inertia there).",
    )


def write_identified_urdf(
    robot: Any, standard_values: Any, path: str | os.PathLike
) -> UrdfExport:
    """Writes a copy of ``robot``'s URDF with the given standard parameters.

    See the module docstring for what is written where.

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel` the parameters belong to
            (built from a URDF file: ``robot.path``).
        standard_values: (p_std,) physically consistent standard values in
            ``robot.standard_names`` order (e.g. ``PhysicalResult.standard_values``).
        path: the output file; never the input URDF.

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
    parser = ElementTree.XMLParser(target=ElementTree.TreeBuilder(insert_comments=True))
    try:
        tree = ElementTree.parse(source, parser=parser)
    except ElementTree.ParseError as error:
        check.fail(_OWNER, f"{source} is not well-formed XML: {error}.")
    root = tree.getroot()
    links_by_name = {link.attrib.get("name"): link for link in root.findall("link")}
    joints_by_name = {j.attrib.get("name"): j for j in root.findall("joint")}
    groups = _link_groups(robot.plant, tuple(robot.joint_names))
    written, lumped, skipped = [], [], []
    for k, joint_name in enumerate(robot.joint_names):
        j = k + 1
        link_name = robot.plant.GetJointByName(joint_name).child_body().name()
        parameters = np.array([values[f"{p}{j}"] for p in _INERTIAL])
        _replace_inertial(
            links_by_name[link_name], _link_inertial(link_name, joint_name, parameters)
        )
        written.append(link_name)
        joint = joints_by_name[joint_name]
        if f"FV{j}" in values:
            _dynamics(joint).set("damping", _number(values[f"FV{j}"]))
        if f"FC{j}" in values:
            _dynamics(joint).set("friction", _number(values[f"FC{j}"]))
        if f"OFF{j}" in values:
            skipped.append(f"OFF{j}")
        if f"IA{j}" in values:
            _set_rotor_inertia(root, joint_name, values[f"IA{j}"])
    # Coupled motors' parameters (IAmk, FVmk, FCmk, OFFmk) have no URDF field.
    skipped += [name for name in names if re.fullmatch(r"(IA|FV|FC|OFF)m\d+", name)]
    for body, k in groups.items():
        if k < 0 or body in written or body not in links_by_name:
            continue
        link = links_by_name[body]
        _replace_inertial(link, _inertial_element(0.0, np.zeros(3), np.zeros((3, 3))))
        link.insert(
            0,
            ElementTree.Comment(
                f" drake_dynid: inertia lumped into the identified link {written[k]!r} "
            ),
        )
        lumped.append(body)
    root.insert(
        0,
        ElementTree.Comment(
            f" Identified by drake_dynid from {source.name}: <inertial> of "
            f"{', '.join(written)}; joint damping/friction"
            + ("; drake:rotor_inertia" if robot.rotor_inertia else "")
            + ". "
        ),
    )
    _absolute_filenames(root, source, output)
    ElementTree.indent(tree, space="  ")
    # ElementTree drops the comments before the root element: copy them.
    prolog = _PROLOG.match(source.read_text(encoding="utf-8"))
    comments = prolog.group(1).strip() if prolog else ""
    body = ElementTree.tostring(root, encoding="unicode")
    output.write_text(
        '<?xml version="1.0" encoding="utf-8"?>\n'
        + (comments + "\n" if comments else "")
        + body
        + "\n",
        encoding="utf-8",
    )
    return UrdfExport(str(output), tuple(written), tuple(lumped), tuple(skipped))
