"""Replay a motion (a log or a trajectory) in Drake's Meshcat viewer.

:func:`replay_in_meshcat` loads the URDF with its geometry into a plant and a
``SceneGraph``, adds Drake's Meshcat visualization (``ApplyVisualizationConfig``
with an in-memory LCM, so nothing goes to the network but Meshcat's own web
server on localhost), and records the motion as a Meshcat animation: for each
frame (``frames_per_second``, positions interpolated linearly between samples)
the plant's positions are set and the diagram is published;
``Meshcat.StartRecording`` / ``StopRecording`` / ``PublishRecording`` turn the
frames into the animation the browser plays (its controls: play, speed, scrub).

The live page (``Replay.url``) lives as long as the process holds the Meshcat
server; ``Replay.html`` is a standalone copy (``Meshcat.StaticHtml``: scene and
animation in one file, no server needed). A URDF without ``<visual>`` elements
(the shipped iiwa7, UR5, 2R) is shown by its links' equivalent inertia
ellipsoids (Drake's inertia layer, made visible); a URDF whose meshes cannot be
found is loaded without geometry, with a note. A server it starts itself starts
quietly: Drake's INFO line "Meshcat listening for connections at URL" (its
``drake`` logger) is held back, the URL being ``Replay.url``, which the commands
print in their own words.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check

__all__ = ["Replay", "replay_in_meshcat"]

#: Most animation frames of one replay (an hour at 32 frames per second, both
#: ends included).
MAX_FRAMES = 115_201


@contextlib.contextmanager
def _drake_quiet() -> Any:
    """Drake's ``drake`` logger at WARNING at least (its INFO lines held back).

    pydrake routes Drake's C++ log into Python's ``logging`` and keeps the C++
    level in step with this logger's level; the previous level is restored.
    """
    logger = logging.getLogger("drake")
    saved = logger.level
    if logger.getEffectiveLevel() < logging.WARNING:
        logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(saved)


@dataclass(frozen=True)
class Replay:
    """A published replay.

    Attributes:
        url: the live page (valid while ``meshcat`` is alive).
        html: the standalone page written, or None.
        frames: animation frames recorded.
        notes: remarks (geometry not found, shown by inertia ellipsoids).
        meshcat: the ``pydrake.geometry.Meshcat`` (keep it to keep the page live).
    """

    url: str
    html: str | None
    frames: int
    notes: tuple[str, ...]
    meshcat: Any


def _load(urdf: str) -> tuple[Any, Any, list[str]]:
    """A builder with the plant and its geometry, else without (a note says why)."""
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.urdf import load_urdf

    builder = DiagramBuilder()
    try:
        return builder, load_urdf(urdf, 0.0, builder=builder, geometry=True).plant, []
    except ValueError as error:
        builder = DiagramBuilder()
        plant = load_urdf(urdf, 0.0, builder=builder, geometry=False).plant
        text = str(error).splitlines()[0]
        match = re.search(r"error: (.+?)\. Fix the URDF", text)
        reason = (match.group(1) if match else text).rstrip(".")
        # The URDF may well have <visual> elements: none is loaded (its
        # collision meshes failed, e.g. .dae ones, which Drake cannot hull).
        note = f"shown without its geometry ({reason}): the links are shown by "
        return builder, plant, [note + "their inertia"]


def replay_in_meshcat(
    urdf: str,
    t: Any,
    q: Any,
    joint_names: Sequence[str],
    *,
    html: str | os.PathLike | None = None,
    frames_per_second: float = 32.0,
    meshcat: Any = None,
    locked: Mapping[str, float] | None = None,
) -> Replay:
    """Records the motion q(t) of the URDF's joints as a Meshcat animation.

    Args:
        urdf: the robot's URDF.
        t: (N,) sample times [s], increasing.
        q: (N, n) positions [rad or m] of ``joint_names`` (other joints stay at 0,
            or at their ``locked`` position).
        joint_names: the n joints of q (URDF names).
        html: write the standalone page here (None: do not).
        frames_per_second: animation frames per second of motion [Hz].
        meshcat: a ``Meshcat`` to use (default: ``StartMeshcat()``, a new server
            on the first free port from 7000, started without Drake's INFO line:
            its URL is ``Replay.url``).
        locked: ``{joint: position [rad or m]}`` of joints outside ``joint_names``
            (``RobotModel.locked``); a URDF mimic joint follows its leader.

    Raises:
        ValueError: bad arrays, an unknown joint, too many frames.
    """
    from pydrake.geometry import StartMeshcat
    from pydrake.lcm import DrakeLcm
    from pydrake.multibody.tree import BodyIndex
    from pydrake.visualization import ApplyVisualizationConfig, VisualizationConfig

    from drake_dynid.urdf import joint_embedding, read_urdf_mimic

    owner = "replay_in_meshcat"
    t = check.array(owner, "t", t, shape=(None,))
    names = tuple(joint_names)
    q = check.array(owner, "q", q, shape=(t.size, len(names)))
    if t.size < 2 or np.any(np.diff(t) <= 0.0):
        check.fail(owner, "t must have at least 2 increasing samples [s].")
    fps = check.positive(owner, "frames_per_second", frames_per_second, "Hz")
    frames = int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    if frames > MAX_FRAMES:
        # The largest rate that fits, rounded down to 3 significant digits.
        fitting = (MAX_FRAMES - 1) / (t[-1] - t[0])
        digits = 2 - math.floor(math.log10(fitting))
        fitting = math.floor(fitting * 10.0**digits) / 10.0**digits
        check.fail(
            owner,
            f"the replay must have at most {MAX_FRAMES} frames; got {frames} "
            f"({t[-1] - t[0]:g} s at frames_per_second {fps:g} Hz): lower "
            f"frames_per_second to {fitting:g} Hz or less, or replay part of the "
            "log.",
        )
    builder, plant, notes = _load(urdf)
    for name in names:
        if not plant.HasJointNamed(name):
            check.fail(owner, f"joint {name!r} is not a joint of {urdf}.")
    locked = dict(locked or {})
    for name in locked:
        if not plant.HasJointNamed(name):
            check.fail(owner, f"locked joint {name!r} is not a joint of {urdf}.")
    mimic = read_urdf_mimic(urdf) if str(urdf).lower().endswith(".urdf") else {}
    followed = {
        name: relation
        for name, relation in mimic.items()
        if plant.HasJointNamed(name) and plant.HasJointNamed(relation[0])
    }
    bodies = [plant.get_body(BodyIndex(i)) for i in range(plant.num_bodies())]
    if not notes and not any(plant.GetVisualGeometriesForBody(body) for body in bodies):
        notes.append("no <visual> geometry: the links are shown by their inertia")
    if meshcat is None:
        with _drake_quiet():  # the URL is Replay.url (module docstring)
            meshcat = StartMeshcat()
    config = VisualizationConfig(
        publish_contacts=False, publish_proximity=False, enable_alpha_sliders=False
    )
    lcm = DrakeLcm("memq://")  # in memory; referenced by the diagram: keep it alive
    ApplyVisualizationConfig(config, builder, meshcat=meshcat, lcm=lcm)
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    diagram.ForcedPublish(context)  # the scene, before the animation
    if notes and notes[-1].startswith("no <visual>"):
        meshcat.SetProperty("/drake/inertia", "visible", True)
    times = t[0] + np.arange(frames) / fps
    path = np.column_stack([np.interp(times, t, q[:, j]) for j in range(len(names))])
    embedding = joint_embedding(
        plant, names, locked, followed, base=plant.GetPositions(plant_context)
    )
    meshcat.StartRecording(
        frames_per_second=fps, set_visualizations_while_recording=False
    )
    for k, time in enumerate(times):
        context.SetTime(float(time - t[0]))
        plant.SetPositions(plant_context, embedding.place(path[k]))
        diagram.ForcedPublish(context)
    meshcat.StopRecording()
    meshcat.PublishRecording()
    written = None
    if html is not None:
        written = os.fspath(html)
        from drake_dynid.files import write_text_whole

        write_text_whole(written, meshcat.StaticHtml())  # no truncated page
    return Replay(meshcat.web_url(), written, frames, tuple(notes), meshcat)
