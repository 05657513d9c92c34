"""URDF robots: files shipped with drake_dynid and loading them into Drake.

``load_plant`` turns a URDF into a finalized ``MultibodyPlant`` and checks that
drake_dynid can handle it (fixed base; revolute, prismatic and fixed joints; at least
one actuator). ``read_urdf_friction`` reads the Coulomb friction that Drake ignores.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from drake_dynid.core import _validate

__all__ = ["MODELS_DIR", "load_plant", "model_path", "read_urdf_friction"]

#: Directory of the URDF robots shipped with drake_dynid.
MODELS_DIR = Path(__file__).resolve().parent / "models"

_SUPPORTED_JOINTS = ("revolute", "prismatic", "weld")
_FRICTION_WARNING = "does not currently support non-zero joint friction"


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
        available = ", ".join(sorted(p.stem for p in MODELS_DIR.glob("*.urdf")))
        raise ValueError(
            f"model_path: name must be one of the packaged models ({available}); "
            f"got {name!r}."
        )
    return str(path)


def _check_file(owner: str, path: Any) -> Path:
    if not isinstance(path, (str, Path)):
        raise TypeError(f"{owner}: path must be a str or Path; got {type(path)}.")
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"{owner}: URDF file not found: {file}.")
    return file


def _read_urdf(owner: str, file: Path) -> Any:
    try:
        return ElementTree.parse(file).getroot()
    except ElementTree.ParseError as error:
        raise ValueError(f"{owner}: {file} is not well-formed XML: {error}.") from None


_URDF_JOINTS = ("revolute", "continuous", "prismatic", "fixed")


def read_urdf_friction(path: str | Path) -> dict[str, float]:
    """Returns ``{joint name: Coulomb friction [N·m or N]}`` from URDF ``<dynamics>``.

    Drake ignores the ``friction`` attribute of ``<dynamics>`` (it warns), so it is
    read here. Joints without it are absent from the result.

    Raises:
        ValueError: the file is missing, is not XML, or has a non-numeric value.
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
            out[joint.attrib.get("name", "")] = float(text)
        except ValueError:
            raise ValueError(
                f"read_urdf_friction: joint {joint.attrib.get('name')!r} in {file} "
                f"has a non-numeric friction {text!r}."
            ) from None
    return out


class _DropFrictionWarning(logging.Filter):
    """Drops Drake's warning that URDF joint friction is ignored (we read it)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return _FRICTION_WARNING not in record.getMessage()


def load_plant(
    path: str | Path,
    time_step: float = 0.0,
    *,
    builder: Any = None,
    gravity: Sequence[float] | None = None,
    weld_root: bool = True,
    sampled_output_ports: bool = False,
) -> Any:
    """Loads a URDF robot into a finalized ``MultibodyPlant``.

    Args:
        path: the URDF file.
        time_step: plant period [s]; 0.0 gives a continuous plant, > 0 a discrete
            one (drake_dynid's simulations use 1e-3).
        builder: optional ``DiagramBuilder``; when given the plant is added with
            ``AddMultibodyPlantSceneGraph`` (so it has a SceneGraph).
        gravity: gravity vector in the world [m/s²]; default Drake's (0, 0, -9.81).
        weld_root: weld a root link that has no joint to the world (a URDF without a
            ``world`` link) at the world origin, as fixed-base arms are described.
            With False such a link is a floating base, which is rejected.
        sampled_output_ports: for a discrete plant, keep Drake's default sampled
            output ports (True) or use live ones (False, drake_dynid's default).
            With sampled ports (pydrake 1.51), a discrete-update handler at t_k that
            reads the plant's state port sees the post-step state x_{k+1}, while a
            logger at t_k sees x_k: the identification blocks would then pair
            q_{k+1} with the torque computed from x_k. Live ports give every block
            x_k at t_k (docs/CONVENTIONS.md §2; tested).

    Returns:
        The finalized plant. Its joint ``friction`` attributes are ignored by Drake:
        read them with :func:`read_urdf_friction` and apply them with
        ``drake_dynid.systems.friction.JointFriction``.

    Raises:
        ValueError: missing or malformed file, a floating base, a joint other than
            revolute, prismatic or fixed, or no actuated joint.
    """
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant

    owner = "load_plant"
    file = _check_file(owner, path)
    time_step = _validate.real(owner, "time_step", time_step, "s")
    if time_step < 0.0:
        raise ValueError(f"{owner}: time_step must be >= 0 [s]; got {time_step}.")
    if file.suffix.lower() == ".urdf":
        for joint in _read_urdf(owner, file).iter("joint"):
            kind = joint.attrib.get("type", "")
            if joint.find("parent") is not None and kind not in _URDF_JOINTS:
                raise ValueError(
                    f"{owner}: joint {joint.attrib.get('name')!r} of {file} has type "
                    f"{kind!r}; only revolute, continuous, prismatic and fixed joints "
                    "are supported (no floating, planar or ball joints)."
                )
    if builder is None:
        plant = MultibodyPlant(time_step)
    else:
        plant, _ = AddMultibodyPlantSceneGraph(builder, time_step)
    if time_step > 0.0:
        plant.SetUseSampledOutputPorts(bool(sampled_output_ports))
    drake_logger = logging.getLogger("drake")
    quiet = _DropFrictionWarning()
    drake_logger.addFilter(quiet)
    try:
        instances = Parser(plant).AddModels(str(file))
    except RuntimeError as error:
        message = str(error).strip().splitlines()[0] if str(error).strip() else ""
        raise ValueError(
            f"{owner}: could not parse {file}: {message}. Fix the URDF (valid XML, "
            "every joint's parent and child links defined)."
        ) from None
    finally:
        drake_logger.removeFilter(quiet)
    if gravity is not None:
        g = _validate.array(owner, "gravity", gravity, shape=(3,))
        plant.mutable_gravity_field().set_gravity_vector(g)

    from pydrake.multibody.tree import JointIndex

    joints = [plant.get_joint(JointIndex(i)) for i in range(plant.num_joints())]
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
            f"({', '.join(b.name() for b in roots)}); a fixed-base robot has one."
        )
    for body in roots:
        plant.WeldFrames(plant.world_frame(), body.body_frame())
    plant.Finalize()
    for index in range(plant.num_joints()):
        joint = plant.get_joint(JointIndex(index))
        kind = joint.type_name()
        if kind not in _SUPPORTED_JOINTS:
            raise ValueError(
                f"{owner}: joint {joint.name()!r} of {file} has type {kind!r}; only "
                "revolute (and continuous), prismatic and fixed joints are supported "
                "(no floating, ball or planar joints)."
            )
    if plant.num_actuators() == 0:
        raise ValueError(
            f"{owner}: {file} has no actuated joint; add a <transmission> per joint "
            "(drake_dynid identifies actuated robots)."
        )
    return plant


# ----------------------------------------------------------------------------------
# Numeric kinematic structure and vectorised spatial algebra.
