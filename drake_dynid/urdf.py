"""URDF robots: files shipped with drake_dynid and loading them into Drake.

``load_plant`` turns a URDF into a finalized ``MultibodyPlant`` and checks that
drake_dynid can handle it (fixed base; revolute, continuous, prismatic and fixed
joints). Any such description loads:

* identification needs no geometry, so ``<visual>`` and ``<collision>`` are stripped
  before parsing: missing ``package://`` meshes never fail the load;
* a movable joint without a ``<transmission>`` (or with one Drake ignores) is
  treated as actuated: it gets an actuator without effort limit (one note says
  which); mimic joints do not;
* Drake's parser warnings are summarised in one note (counted by kind; each one at
  DEBUG on the ``drake_dynid`` logger) instead of a flood.

``read_urdf_friction`` reads the Coulomb friction that Drake ignores and
``read_urdf_mimic`` the ``<mimic>`` tags.
"""

from __future__ import annotations

import logging
import math
import os
import re
import xml.etree.ElementTree as ElementTree
from collections import Counter
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drake_dynid.core import _validate
from drake_dynid.drive_urdf import parse_urdf_xml
from drake_dynid.urdf_meshes import add_ancestor_packages, stl_collisions_as_obj

__all__ = [
    "MODELS_DIR",
    "JointEmbedding",
    "LoadedUrdf",
    "MissingFileError",
    "joint_embedding",
    "load_plant",
    "load_urdf",
    "model_path",
    "read_urdf_friction",
    "read_urdf_joint_types",
    "read_urdf_mimic",
]

#: Directory of the URDF robots shipped with drake_dynid.
MODELS_DIR = Path(__file__).resolve().parent / "models"

_SUPPORTED_JOINTS = ("revolute", "prismatic", "weld")
_FRICTION_WARNING = "does not currently support non-zero joint friction"
_LOGGER = logging.getLogger("drake_dynid")


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
        available = packaged_names(".urdf")
        raise ValueError(
            f"model_path: name must be one of the packaged models ({available}); "
            f"got {name!r}."
        )
    return str(path)


def packaged_names(suffix: str) -> str:
    """The packaged files ending in ``suffix`` (``drake_dynid/models``), by stem.

    Comma-separated and sorted, for the messages that offer them (``".urdf"``:
    the models; ``".toml"``: the drive files).
    """
    return ", ".join(sorted(p.stem for p in MODELS_DIR.glob(f"*{suffix}")))


def _check_file(owner: str, path: Any) -> Path:
    if not isinstance(path, (str, Path)):
        raise TypeError(f"{owner}: path must be a str or Path; got {type(path)}.")
    file = Path(path)
    if file.is_dir():
        raise ValueError(f"{owner}: URDF {file} is a directory, expected a file.")
    if not file.is_file():
        available = packaged_names(".urdf")
        raise ValueError(
            f"{owner}: URDF file not found: {file} (the dynid command also takes "
            f"the name of a packaged model: {available})."
        )
    return file


def _read_urdf(owner: str, file: Path) -> Any:
    try:
        return parse_urdf_xml(file)
    except ElementTree.ParseError as error:
        raise ValueError(f"{owner}: {file} is not well-formed XML: {error}.") from None


_URDF_JOINTS = ("revolute", "continuous", "prismatic", "fixed")


def read_urdf_joint_types(path: str | Path) -> dict[str, str]:
    """``{joint: type}`` of the URDF's ``<joint>`` elements (not a transmission's).

    Raises:
        ValueError: the file is missing or is not XML.
    """
    owner = "read_urdf_joint_types"
    return _joint_types(_read_urdf(owner, _check_file(owner, path)))


def _joint_types(root: Any) -> dict[str, str]:
    return {
        joint.attrib.get("name", ""): joint.attrib.get("type", "")
        for joint in root.findall("joint")
    }


def read_urdf_joints(
    path: str | Path,
) -> tuple[dict[str, str], dict[str, tuple[str, float, float]] | None]:
    """:func:`read_urdf_joint_types` and :func:`read_urdf_mimic` of one parse.

    The mimic table is None when a ``<mimic>`` is malformed (the types are read).

    Raises:
        ValueError: the file is missing or is not XML.
    """
    owner = "read_urdf_joints"
    file = _check_file(owner, path)
    root = _read_urdf(owner, file)
    try:
        mimic: dict[str, tuple[str, float, float]] | None = _mimic(owner, file, root)
    except ValueError:
        mimic = None
    return _joint_types(root), mimic


def read_urdf_friction(path: str | Path) -> dict[str, float]:
    """Returns ``{joint name: Coulomb friction [N·m or N]}`` from URDF ``<dynamics>``.

    Drake ignores the ``friction`` attribute of ``<dynamics>`` (it warns), so it is
    read here. Joints without it are absent from the result.

    Raises:
        ValueError: the file is missing, is not XML, or has a non-numeric,
            negative or infinite value.
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
            value = float(text)
        except ValueError:
            raise ValueError(
                f"read_urdf_friction: joint {joint.attrib.get('name')!r} in {file} "
                f"has a non-numeric friction {text!r}."
            ) from None
        if not 0.0 <= value < math.inf:  # Drake refuses a negative damping alike
            raise ValueError(
                f"read_urdf_friction: joint {joint.attrib.get('name')!r} in {file} "
                f'has <dynamics friction="{text}">; the Coulomb friction must be '
                "a finite number >= 0 [N·m or N]: fix the URDF."
            )
        out[joint.attrib.get("name", "")] = value
    return out


def read_urdf_mimic(path: str | Path) -> dict[str, tuple[str, float, float]]:
    """Returns ``{joint: (leader, multiplier, offset)}`` from URDF ``<mimic>`` tags.

    q_joint = multiplier·q_leader + offset [rad or m]; multiplier defaults to 1 and
    offset to 0, as in the URDF specification.

    Raises:
        ValueError: the file is missing, is not XML, a ``<mimic>`` has no
            ``joint`` attribute or a non-numeric multiplier or offset.
    """
    owner = "read_urdf_mimic"
    file = _check_file(owner, path)
    return _mimic(owner, file, _read_urdf(owner, file))


def _mimic(owner: str, file: Path, root: Any) -> dict[str, tuple[str, float, float]]:
    """:func:`read_urdf_mimic` of a parsed URDF."""
    out: dict[str, tuple[str, float, float]] = {}
    for joint in root.iter("joint"):
        mimic = joint.find("mimic")
        if (
            mimic is None
            or joint.find("parent") is None
            or joint.attrib.get("type") == "fixed"  # follows nothing (load_urdf)
        ):
            continue
        name = joint.attrib.get("name", "")
        leader = mimic.attrib.get("joint", "")
        if not leader:
            raise ValueError(
                f"{owner}: the <mimic> of joint {name!r} in {file} has no 'joint' "
                "attribute (the leader)."
            )
        numbers = []
        for key, default in (("multiplier", 1.0), ("offset", 0.0)):
            text = mimic.attrib.get(key, str(default))
            try:
                numbers.append(float(text))
            except ValueError:
                raise ValueError(
                    f"{owner}: the <mimic> of joint {name!r} in {file} has a "
                    f"non-numeric {key} {text!r}."
                ) from None
        out[name] = (leader, numbers[0], numbers[1])
    return out


# Geometry is not needed for identification: comments (which may hold unbalanced
# tags), then <visual> and <collision> elements, are removed from the text, so that
# the rest of the file (namespaces, drake: tags) reaches Drake unchanged.
_COMMENT = re.compile(r"<!--.*?-->", re.S)
_GEOMETRY = re.compile(r"<(visual|collision)\b(?:[^>]*/>|.*?</\1\s*>)", re.S)
_VISUAL = re.compile(r"<(visual)\b(?:[^>]*/>|.*?</\1\s*>)", re.S)
_FIXED_JOINT = re.compile(
    r"""<joint\b[^>]*\btype\s*=\s*(["'])fixed\1[^>]*>.*?</joint\s*>""", re.S
)
_MIMIC = re.compile(r"<mimic\b[^>]*/>|<mimic\b.*?</mimic\s*>", re.S)
_STL = re.compile(r"""\bfilename\s*=\s*["'][^"']*\.stl["']""", re.I)
# A filename that is not a URI: relative, or a bare absolute path (both made
# file:// URIs by _strip_geometry).
_RELATIVE_FILE = re.compile(
    r"""(\bfilename\s*=\s*)(["'])(?![a-zA-Z][\w+.-]*://)([^"']+)\2"""
)


def _orphan_transmissions(root: Any) -> dict[str, str]:
    """``{transmission: joint}`` of the transmissions naming a joint not in the file.

    Drake refuses such a file ("Transmission specifies joint ... which does not
    exist"): the arm-only Talos descriptions keep their torso joint's.
    """
    if root is None:
        return {}
    joints = {
        joint.attrib.get("name")
        for joint in root.iter("joint")
        if joint.find("parent") is not None
    }
    out: dict[str, str] = {}
    for transmission in root.iter("transmission"):
        for joint in transmission.iter("joint"):
            name = joint.attrib.get("name")
            if name not in joints and transmission.attrib.get("name"):
                out[transmission.attrib["name"]] = str(name)
    return out


def _fixed_mimic(text: str) -> bool:
    """Whether a fixed joint of the URDF text carries a ``<mimic>``."""
    return any(_MIMIC.search(m.group(0)) for m in _FIXED_JOINT.finditer(text))


def _strip_geometry(
    text: str, directory: Path, keep_collision: bool | None = False
) -> str:
    """URDF text without comments, ``<visual>`` and ``<collision>``.

    ``keep_collision``: only the ``<visual>`` elements are removed (a collision
    check needs no visual mesh, and a missing one must not stop it); None: the
    geometry is kept. A ``<mimic>`` of a fixed joint is removed too.

    Each removed element leaves its newlines, so Drake's messages keep the file's
    line numbers. Any other ``filename`` that is not a URI is made an absolute
    ``file://`` URI (a relative one relative to the file's directory, a bare
    absolute path as it is), since the text is parsed from a string.
    """

    def blank(match: re.Match) -> str:
        return "\n" * match.group(0).count("\n")

    text = _COMMENT.sub(blank, text)
    if keep_collision is not None:
        text = (_VISUAL if keep_collision else _GEOMETRY).sub(blank, text)
    # A fixed joint cannot follow another (Drake refuses the file: the Talos
    # grippers' fixed joints carry <mimic>); its <mimic> means nothing.
    text = _FIXED_JOINT.sub(lambda m: _MIMIC.sub(blank, m.group(0)), text)
    # Drake takes only URIs in a string (a bare absolute path is "invalid when
    # parsing a string"): file:// and the absolute path, not percent-encoded.
    return _RELATIVE_FILE.sub(
        lambda m: (
            f"{m.group(1)}{m.group(2)}file://{(directory / m.group(3)).as_posix()}"
            f"{m.group(2)}"
        ),
        text,
    )


_WARNING_KINDS = (
    (re.compile(r"The tag '([^']+)' found as a child of '([^']+)'"), "ignored <{0}>"),
    (re.compile(r"While parsing inertia matrix"), "non-physical inertia"),
    (re.compile(r"<transmission> has a type"), "ignored transmission type"),
    (re.compile(r"mechanicalReduction"), "ignored mechanical reduction"),
    (re.compile(r"Skipping transmission"), "transmission on a fixed joint"),
    (re.compile(r"[Mm]imic"), "mimic element"),
)


class _ParserLog(logging.Filter):
    """Holds back Drake's parser messages (they are summarised in one note).

    The warning that URDF joint friction is ignored is dropped: drake_dynid reads
    that friction itself (:func:`read_urdf_friction`).
    """

    def __init__(self) -> None:
        super().__init__()
        self.messages: list[str] = []

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if _FRICTION_WARNING not in message and record.levelno >= logging.WARNING:
            self.messages.append(message)
        return False

    def summary(self, file: Path) -> str | None:
        """One line: how many warnings of each kind, or None without warnings."""
        if not self.messages:
            return None
        kinds: Counter[str] = Counter()
        for message in self.messages:
            message = message.replace("<literal-string>.urdf", file.name)
            _LOGGER.debug("Drake's parser: %s", message)
            text = message.split("warning: ", 1)[-1]
            for pattern, label in _WARNING_KINDS:
                match = pattern.search(text)
                if match:
                    kinds[label.format(*match.groups())] += 1
                    break
            else:
                kinds[re.sub(r"\d+(\.\d+)?", "#", text.splitlines()[0])[:60]] += 1
        listing = ", ".join(f"{count} {kind}" for kind, count in kinds.most_common())
        count = len(self.messages)
        return (
            f"Drake's parser: {count} warning{'s' if count > 1 else ''} on "
            f"{file.name} ({listing}); each one at DEBUG on the 'drake_dynid' logger"
        )


@dataclass(frozen=True)
class LoadedUrdf:
    """A loaded robot: the finalized plant and the one-line notes of the load.

    ``untransmitted``: the joints actuated without a (simple) ``<transmission>``
    (one note says so, :func:`untransmitted_note`); ``untransmitted_limited``: those
    of them whose URDF ``<limit>`` gives an effort.
    """

    plant: Any
    notes: tuple[str, ...]
    untransmitted: tuple[str, ...] = ()
    untransmitted_limited: frozenset[str] = frozenset()


def load_plant(
    path: str | Path,
    time_step: float = 0.0,
    *,
    builder: Any = None,
    gravity: Sequence[float] | None = None,
    weld_root: bool = True,
    sampled_output_ports: bool = False,
    geometry: bool | str = False,
    locked: Mapping[str, float] | None = None,
) -> Any:
    """Loads a URDF robot into a finalized ``MultibodyPlant``.

    Returns ``load_urdf(...).plant``; the notes of the load (joints treated as
    actuated, Drake's parser warnings) go to the ``drake_dynid`` logger at INFO.
    See :func:`load_urdf` for the arguments.
    """
    loaded = load_urdf(
        path,
        time_step,
        builder=builder,
        gravity=gravity,
        weld_root=weld_root,
        sampled_output_ports=sampled_output_ports,
        geometry=geometry,
        locked=locked,
    )
    for note in loaded.notes:
        _LOGGER.info("load_plant: %s.", note)
    return loaded.plant


def _drop_placeholder_limits(plant: Any) -> str | None:
    """Reads a movable joint's ``<limit>`` left at 0 as no limit; returns a note.

    A revolute or prismatic joint whose ``lower == upper`` or whose ``velocity``
    is 0 could not move: these are placeholders (the double pendulum of
    example-robot-data writes ``lower="0" upper="0" effort="0" velocity="0"``).
    Drake's discrete plant enforces position limits, so a [0, 0] range pinned the
    simulated joint (a 3341 N·m command at t = 0 and exit 2), and ``dynid
    excite`` refused a velocity limit of 0 without saying where it came from.
    They become ±inf (not given: ``dynid excite`` then asks for ``--limits``);
    an effort of 0 already reads as no effort limit.
    """
    found = []
    for index in plant.GetJointIndices():
        joint = plant.get_joint(index)
        if joint.num_velocities() != 1:
            continue
        kinds = []
        lower, upper = joint.position_lower_limits(), joint.position_upper_limits()
        if lower[0] == upper[0]:
            kinds.append(f"position {lower[0]:g} .. {upper[0]:g}")
            joint.set_position_limits([-math.inf], [math.inf])
        if joint.velocity_upper_limits()[0] == 0.0:
            kinds.append("velocity 0")
            joint.set_velocity_limits([-math.inf], [math.inf])
        if kinds:
            found.append(f"{joint.name()} ({', '.join(kinds)})")
    if not found:
        return None
    return (
        f"{len(found)} joint(s) whose <limit> gives a range or velocity of 0, a "
        f"placeholder (the joint moves), read as no limit: {_validate.listed(found)}"
    )


def _check_limit(owner: str, file: Path, joint: Any) -> None:
    """A ``<limit>`` Drake asserts on (a crash, exit 1): lower > upper, velocity < 0.

    Values that are not numbers are left to Drake's parser, which names them.
    """
    limit = joint.find("limit")
    if limit is None or joint.attrib.get("type") not in ("revolute", "prismatic"):
        return

    def value(key: str, default: float) -> float:
        try:
            return float(limit.attrib.get(key, default))
        except ValueError:
            return default

    where = f"{owner}: joint {joint.attrib.get('name')!r} of {file}: <limit>"
    lower, upper = value("lower", -math.inf), value("upper", math.inf)
    if lower > upper:
        raise ValueError(
            f"{where} lower = {lower:g} > upper = {upper:g}; fix the URDF (lower <= "
            "upper)."
        )
    velocity = value("velocity", 0.0)
    if velocity < 0.0:
        raise ValueError(
            f"{where} velocity = {velocity:g} must be >= 0 [rad/s or m/s]; fix the "
            "URDF."
        )


def _parse(
    owner: str,
    plant: Any,
    file: Path,
    geometry: bool | str,
    orphans: Sequence[str] = (),
) -> tuple[list[Any], str | None]:
    """Adds the models of ``file`` to ``plant``; returns them and the summary.

    ``orphans``: names of ``<transmission>`` elements to drop (they name a joint
    the file does not have, which Drake refuses).
    """
    from pydrake.multibody.parsing import Parser

    drake_logger = logging.getLogger("drake")
    log = _ParserLog()
    drake_logger.addFilter(log)
    try:
        parser = Parser(plant)
        # package:// URIs resolve through ROS_PACKAGE_PATH too (a ROS workspace,
        # example-robot-data's share folder), as in ROS tools.
        if os.environ.get("ROS_PACKAGE_PATH"):
            parser.package_map().PopulateFromRosPackagePath()
        source = (
            _validate.utf8_text(file.read_bytes(), f"{owner}: URDF {file}")
            if file.suffix.lower() == ".urdf"
            else None
        )
        if source is not None:  # package://NAME of an ancestor folder NAME
            add_ancestor_packages(parser.package_map(), file, source)
        stl = geometry is not False and source is not None and _STL.search(source)
        # With its geometry kept, the file is parsed as is (the same package map:
        # Drake finds no package.xml beside it by itself) unless a fixed joint
        # carries a <mimic> or a collision mesh is an STL (Drake hulls .obj, .vtk
        # and .gltf only).
        if source is not None and (
            geometry in (False, "collision") or _fixed_mimic(source) or orphans or stl
        ):
            keep = None if geometry is True else geometry == "collision"
            text = _strip_geometry(source, file.resolve().parent, keep_collision=keep)
            if stl:
                try:
                    text = stl_collisions_as_obj(
                        text, parser.package_map(), visual=geometry is True
                    )
                except ValueError as error:
                    raise MissingFileError(
                        f"{owner}: {file}: {error}", str(error).rstrip(".")
                    ) from None
            for name in orphans:
                text = re.sub(
                    rf"""<transmission\b[^>]*\bname\s*=\s*(["']){re.escape(name)}"""
                    r"""\1.*?</transmission\s*>""",
                    lambda m: "\n" * m.group(0).count("\n"),
                    text,
                    flags=re.S,
                )
            instances = parser.AddModelsFromString(text, "urdf")
        else:
            instances = parser.AddModels(str(file))
    except (RuntimeError, ValueError) as error:
        if str(error).startswith(f"{owner}: "):
            raise  # ours (the text's encoding, an STL mesh), not Drake's
        message = str(error).strip().splitlines()[0] if str(error).strip() else ""
        message = message.replace("<literal-string>.urdf", file.name)
        # A file (a mesh) the URDF names: "URI 'x' resolved to 'y' which does
        # not exist" or "refers to unknown package"; a joint a <transmission>
        # names "does not exist" too (the Talos arms of example-robot-data).
        missing = (
            "URI " in message
            and ("does not exist" in message or "unknown package" in message)
        ) or "MakeConvexHull only applies" in message  # a .dae collision mesh
        hint = (
            "a collision mesh must be .obj, .vtk, .gltf or .stl for Drake's hull"
            if "MakeConvexHull only applies" in message
            else "a file it names is missing"
            if missing
            else "a joint's <limit effort> must be >= 0"
            if "negative effort limit" in message
            else "every joint a <transmission> names must be a joint of the file"
            if "Transmission" in message
            else "each link's <inertial>: a mass and an inertia of a real body, at "
            "coordinates of a robot's size"
            if "IsPhysicallyValid" in message
            else "valid XML, every joint's parent and child links defined"
        )
        text = (
            f"{owner}: could not parse {file}: {message.rstrip('.')}. Fix the URDF "
            f"({hint})."
        )
        if missing:
            detail = message.split("error: ", 1)[-1].rstrip(".")
            raise MissingFileError(text, detail) from None
        raise ValueError(text) from None
    finally:
        drake_logger.removeFilter(log)
    summary = log.summary(file)
    if summary:
        summary = summary.replace("<literal-string>.urdf", file.name)
    return instances, summary


@dataclass(frozen=True)
class JointEmbedding:
    """Some joints' positions placed in a whole plant's position vector.

    Attributes:
        base: (plant positions,) the other joints' values (locked ones at theirs).
        index: the chosen joints' position indices.
        mimic: (mimic index, leader index, multiplier, offset) of each mimic joint
            placed after them: q_mimic = multiplier·q_leader + offset.
    """

    base: Any
    index: Any
    mimic: tuple[tuple[int, int, float, float], ...]

    def place(self, q: Any) -> Any:
        """The plant's positions with ``q`` for the chosen joints."""
        full = self.base.copy()
        full[self.index] = q
        for at, leader, multiplier, offset in self.mimic:
            full[at] = multiplier * full[leader] + offset
        return full


def joint_embedding(
    plant: Any,
    joint_names: Sequence[str],
    locked: Mapping[str, float],
    mimic: Mapping[str, tuple[str, float, float]],
    base: Any = None,
) -> JointEmbedding:
    """:class:`JointEmbedding` of ``joint_names`` in ``plant`` (names it has).

    ``locked``: ``{joint: position}`` held; ``mimic``: ``{joint: (leader,
    multiplier, offset)}`` followed; ``base``: the other positions (default 0).
    """
    import numpy as np

    full = np.zeros(plant.num_positions()) if base is None else np.array(base)
    for name, value in locked.items():
        full[plant.GetJointByName(name).position_start()] = float(value)
    index = np.array(
        [plant.GetJointByName(name).position_start() for name in joint_names],
        dtype=int,
    )
    followers = tuple(
        (
            plant.GetJointByName(name).position_start(),
            plant.GetJointByName(leader).position_start(),
            float(multiplier),
            float(offset),
        )
        for name, (leader, multiplier, offset) in mimic.items()
    )
    return JointEmbedding(full, index, followers)


class MissingFileError(ValueError):
    """A URDF names a file (a mesh) that cannot be found or used: ``detail`` says which.

    Used: a collision mesh in a format Drake cannot hull (.dae).

    ``dynid excite`` skips its self-collision check on it, with the reason; every
    other caller treats it as any URDF error.
    """

    def __init__(self, message: str, detail: str) -> None:
        super().__init__(message)
        self.detail = detail


def _lock_joints(
    owner: str,
    plant: Any,
    file: Path,
    locked: Mapping[str, float],
    mimic: dict[str, Any],
) -> None:
    """Replaces each joint of ``locked`` by a weld at its position (X_FM(q)).

    A revolute joint at θ: X_FM = R(axis, θ); a prismatic one at d: a translation
    d·axis [m] (``plant_tree.locked_pose``, the pose it lumps the bodies beyond
    it with). Its actuator (from a ``<transmission>``) goes first, as Drake
    requires.
    """
    from pydrake.math import RigidTransform

    from drake_dynid.plant_tree import locked_pose

    positions = {str(name): float(value) for name, value in locked.items()}
    for name, (leader, multiplier, offset) in mimic.items():
        if leader in positions and name not in positions:
            positions[name] = multiplier * positions[leader] + offset
    # Drake removes a joint only from a plant without constraints: the couplers
    # its parser made of <mimic> (q_mimic = multiplier·q_leader + offset) go, and
    # those of joints that stay come back after.
    couplers = [
        (name, leader, multiplier, offset)
        for name, (leader, multiplier, offset) in mimic.items()
        if plant.HasJointNamed(name) and plant.HasJointNamed(leader)
    ]
    if plant.num_constraints() not in (0, len(couplers)):
        raise ValueError(
            f"{owner}: {file} has constraints other than its <mimic> joints; "
            "its joints cannot be locked."
        )
    restore = plant.num_constraints() > 0
    for constraint in plant.GetConstraintIds():
        plant.RemoveConstraint(constraint)
    for name, position in positions.items():
        joint = plant.GetJointByName(name) if plant.HasJointNamed(name) else None
        if joint is None or joint.num_velocities() != 1:
            raise ValueError(
                f"{owner}: locked joint {name!r} is not a movable joint of {file}."
            )
        if not math.isfinite(position):
            raise ValueError(
                f"{owner}: locked joint {name!r} needs a finite position [rad or "
                f"m]; got {position}."
            )
        for index in plant.GetJointActuatorIndices():
            actuator = plant.get_joint_actuator(index)
            if actuator.joint().index() == joint.index():
                plant.RemoveJointActuator(actuator)
        pose = RigidTransform(locked_pose(joint, position))
        parent, child = joint.frame_on_parent(), joint.frame_on_child()
        plant.RemoveJoint(joint)
        plant.WeldFrames(parent, child, pose)
    for name, leader, multiplier, offset in couplers if restore else ():
        if name not in positions and leader not in positions:
            plant.AddCouplerConstraint(
                plant.GetJointByName(name),
                plant.GetJointByName(leader),
                multiplier,
                offset,
            )


def _urdf_efforts(root: Any) -> dict[str, float]:
    """``{joint: effort}`` of the URDF's ``<limit effort=...>`` (> 0 only)."""
    out: dict[str, float] = {}
    if root is None:
        return out
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        if limit is None:
            continue
        try:
            effort = float(limit.attrib.get("effort", "0"))
        except ValueError:
            continue
        if effort > 0.0:
            out[joint.attrib.get("name", "")] = effort
    return out


def _actuate_all(
    plant: Any, mimic: dict[str, Any], efforts: dict[str, float] | None = None
) -> tuple[str, ...]:
    """Adds an actuator to every movable joint without one (not to mimic joints).

    Its effort limit is the joint's URDF ``<limit effort>`` when given (Drake
    reads that value only through a transmission), else none. Returns the names
    of the joints actuated here.
    """
    efforts = efforts or {}
    actuated = {
        plant.get_joint_actuator(i).joint().index()
        for i in plant.GetJointActuatorIndices()
    }
    added = []
    for i in plant.GetJointIndices():
        joint = plant.get_joint(i)
        if (
            joint.num_velocities() == 1
            and joint.index() not in actuated
            and joint.name() not in mimic
        ):
            effort = efforts.get(joint.name(), math.inf)
            plant.AddJointActuator(f"{joint.name()}_dynid_actuator", joint, effort)
            added.append(joint.name())
    return tuple(added)


def untransmitted_note(added: Sequence[str], limited: Collection[str]) -> str | None:
    """The note on joints actuated without a (simple) ``<transmission>``.

    ``added``: those joints; ``limited``: the ones whose URDF ``<limit>`` gives an
    effort (None when ``added`` is empty).
    """
    if not added:
        return None
    shown = _validate.listed(added)
    count = sum(name in limited for name in added)
    which = (
        "effort limit from the URDF's <limit>"
        if count == len(added)
        else "no effort limit"
        if count == 0
        else f"effort limit from the URDF's <limit> for {count} of them"
    )
    return (
        f"{len(added)} joint{'s' if len(added) > 1 else ''} without a (simple) "
        f"<transmission> treated as actuated ({which}): {shown}"
    )


def load_urdf(
    path: str | Path,
    time_step: float = 0.0,
    *,
    builder: Any = None,
    gravity: Sequence[float] | None = None,
    weld_root: bool = True,
    sampled_output_ports: bool = False,
    geometry: bool | str = False,
    locked: Mapping[str, float] | None = None,
) -> LoadedUrdf:
    """Loads a URDF robot into a finalized ``MultibodyPlant``, with the notes.

    Args:
        path: the URDF file (an SDFormat or MJCF file is parsed as is).
        time_step: plant period [s]; 0.0 gives a continuous plant, > 0 a discrete
            one (drake_dynid's simulations use 1e-3).
        builder: optional ``DiagramBuilder``; when given the plant is added with
            ``AddMultibodyPlantSceneGraph`` (so it has a SceneGraph).
        gravity: gravity vector in the world [m/s²]; default Drake's (0, 0, -9.81).
        weld_root: weld a root link that has no joint to the world (a URDF without a
            ``world`` link, e.g. a mobile base) at the world origin, as fixed-base
            arms are described. With False such a link is a floating base, which is
            rejected.
        sampled_output_ports: for a discrete plant, keep Drake's default sampled
            output ports (True) or use live ones (False, drake_dynid's default).
            With sampled ports (pydrake 1.51), a discrete-update handler at t_k that
            reads the plant's state port sees the post-step state x_{k+1}, while a
            logger at t_k sees x_k: the identification blocks would then pair
            q_{k+1} with the torque computed from x_k. Live ports give every block
            x_k at t_k (docs/CONVENTIONS.md §2; tested).
        geometry: keep ``<visual>`` and ``<collision>`` (for a visualisation; every
            mesh must then resolve); ``"collision"``: keep ``<collision>`` only
            (a self-collision check). Identification needs none: by default they
            are stripped.
        locked: ``{joint: position [rad or m]}``: each of these movable joints
            becomes a weld at that position (its actuator removed), as
            ``RobotModel``'s ``locked=`` treats it; a mimic joint whose leader is
            locked is welded at multiplier·position + offset. The plant then has
            the other joints only (``dynid simulate --joints/--lock``). Joint
            indices then have gaps: iterate ``plant.GetJointIndices()``.

    Returns:
        :class:`LoadedUrdf`: the finalized plant (one actuator per movable joint
        that is not a mimic; its joint ``friction`` attributes are ignored by
        Drake: read them with :func:`read_urdf_friction` and apply them with
        ``drake_dynid.systems.friction.JointFriction``) and the notes.

    Raises:
        ValueError: missing or malformed file, a floating base, a joint other than
            revolute, continuous, prismatic or fixed, no movable joint, or a
            ``locked`` name that is not a movable joint of the file.
    """
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant

    owner = "load_plant"
    file = _check_file(owner, path)
    time_step = _validate.real(owner, "time_step", time_step, "s")
    if time_step < 0.0:
        raise ValueError(f"{owner}: time_step must be >= 0 [s]; got {time_step}.")
    mimic: dict[str, Any] = {}
    root = None
    if file.suffix.lower() == ".urdf":
        root = _read_urdf(owner, file)
        for joint in root.iter("joint"):
            kind = joint.attrib.get("type", "")
            if joint.find("parent") is not None and kind not in _URDF_JOINTS:
                raise ValueError(
                    f"{owner}: joint {joint.attrib.get('name')!r} of {file} has type "
                    f"{kind!r}; only revolute, continuous, prismatic and fixed joints "
                    "are supported (no floating, planar or ball joints)."
                )
            _check_limit(owner, file, joint)
        mimic = read_urdf_mimic(file)
    if builder is None:
        plant = MultibodyPlant(time_step)
    else:
        plant, _ = AddMultibodyPlantSceneGraph(builder, time_step)
    if time_step > 0.0:
        plant.SetUseSampledOutputPorts(bool(sampled_output_ports))
    orphans = _orphan_transmissions(root)
    instances, summary = _parse(owner, plant, file, geometry, tuple(orphans))
    if gravity is not None:
        g = _validate.array(owner, "gravity", gravity, shape=(3,))
        plant.mutable_gravity_field().set_gravity_vector(g)

    joints = [plant.get_joint(i) for i in plant.GetJointIndices()]
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
            f"({_validate.listed(b.name() for b in roots)}); a fixed-base robot has "
            "one."
        )
    for body in roots:
        plant.WeldFrames(plant.world_frame(), body.body_frame())
    for joint in joints:
        kind = joint.type_name()
        if kind not in _SUPPORTED_JOINTS:
            raise ValueError(
                f"{owner}: joint {joint.name()!r} of {file} has type {kind!r}; only "
                "revolute (and continuous), prismatic and fixed joints are supported "
                "(no floating, ball or planar joints)."
            )
    if all(joint.type_name() == "weld" for joint in joints):
        raise ValueError(
            f"{owner}: {file} has no movable joint (revolute, continuous or "
            "prismatic); there is nothing to identify."
        )
    if locked:
        _lock_joints(owner, plant, file, locked, mimic)
    placeholders = _drop_placeholder_limits(plant)
    efforts = _urdf_efforts(root)
    untransmitted = _actuate_all(plant, mimic, efforts)
    actuated = untransmitted_note(untransmitted, efforts)
    plant.Finalize()
    inertia = None
    if root is not None:
        from drake_dynid.urdf_inertia import inertia_note

        inertia = inertia_note(root, plant, file.name)
    orphaned = (
        f"{len(orphans)} <transmission> element(s) naming a joint the file does not "
        "have ignored: "
        + _validate.listed(f"{name} ({joint})" for name, joint in orphans.items())
        if orphans
        else None
    )
    notes = tuple(
        note for note in (actuated, placeholders, summary, inertia, orphaned) if note
    )
    return LoadedUrdf(
        plant=plant,
        notes=notes,
        untransmitted=untransmitted,
        untransmitted_limited=frozenset(
            name for name in untransmitted if name in efforts
        ),
    )
