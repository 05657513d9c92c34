"""ROS bags as robot logs: ``sensor_msgs/JointState`` messages read as a CSV log.

A real arm's recording is a ROS bag of ``sensor_msgs/JointState`` messages
(``/joint_states``: ``header.stamp``, ``name[]``, ``position[]``, ``velocity[]``,
``effort[]``). A bag is read with the ``rosbags`` package (pure Python, no ROS
installation; an optional dependency, imported only here: ``pip install
'drake_dynid[ros]'``): a ROS 1 ``.bag`` file, or a ROS 2 bag (its folder holding
``metadata.yaml``, or one of its ``.db3`` / ``.mcap`` storage files).

What is read (README "Logs from ROS bags"):

* the topic: ``topic``, else the bag's one topic of type ``sensor_msgs/msg/JointState``
  (several or none: an error listing them);
* the time of message k: ``header.stamp`` [ns]; when every stamp is 0 (a publisher
  that leaves the header empty), the bag's receive time, with a note;
* the needed joints by name, in each message's own order (it may differ between
  messages); a message without one of them (another publisher on the topic, e.g. a
  gripper's) is skipped and counted in a note; none with all of them is an error
  naming the joints the topic's messages have. ``position`` is q [rad or m],
  ``effort`` τ [N·m or N] (or a drive's raw reading, docs/DRIVE.md); an empty
  ``effort[]`` gives empty (NaN) torque cells; ``velocity[]`` is not read
  (the positions are differentiated).

The messages then become the rows of a CSV log (:func:`export_columns`,
:func:`write_export`; ``dynid bag2csv`` writes that file): one row per message kept,
in the bag's order, row 2 the first one. The commands read that export with the
CSV readers (``drake_dynid.logs``, ``drake_dynid.raw_log``), so a bag's time stamps,
gaps and NaN cells are repaired exactly as a CSV log's, and its messages name the
export's rows. Column names (:func:`column_field`): ``t``, ``q_<joint>``,
``tau_<joint>`` (the plain format), and the names a drive file's ``[log]`` table can
give a JointState field, ``<joint>_position`` / ``- <joint>_position`` and
``<joint>_effort`` / ``- <joint>_effort`` (the ``rostopic echo -p`` style export
that the packaged ``tiago.toml`` names).
"""

from __future__ import annotations

import io
import math
import os
import re
from array import array
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_dynid.files import write_whole

__all__ = [
    "JOINT_STATE",
    "JointStates",
    "column_field",
    "export_columns",
    "is_bag",
    "read_joint_states",
    "write_export",
]

#: The message type read (rosbags' name of ROS 1 and ROS 2 sensor_msgs/JointState).
JOINT_STATE = "sensor_msgs/msg/JointState"

#: The error without the optional dependency.
MISSING = "reading a ROS bag needs the rosbags package: pip install 'drake_dynid[ros]'"

#: File name endings of a bag: ROS 1, and a ROS 2 bag's storage files.
BAG_SUFFIXES = (".bag", ".db3", ".mcap")

#: Stamps from this many nanoseconds on are epoch times: written as integer
#: nanoseconds (exact; ``drake_dynid.logs`` reads integers >= 1e17 so).
_EPOCH_NS = 10**17

_FIELD = re.compile(r"^(?:- )?(?P<joint>.+)_(?P<field>position|effort)$")


def is_bag(path: str | os.PathLike) -> bool:
    """Whether ``path`` names a ROS bag (by its name, or a folder's metadata.yaml)."""
    text = os.fspath(path)
    if os.path.isdir(text):
        return os.path.isfile(os.path.join(text, "metadata.yaml"))
    return text.lower().endswith(BAG_SUFFIXES)


def column_field(column: str) -> tuple[str, str] | None:
    """``(joint, "position" | "effort")`` that a log column name means, or None.

    ``q_<joint>`` and ``<joint>_position`` / ``- <joint>_position``: position;
    ``tau_<joint>`` and ``<joint>_effort`` / ``- <joint>_effort``: effort.
    """
    if column.startswith("q_") and len(column) > 2:
        return column[2:], "position"
    if column.startswith("tau_") and len(column) > 4:
        return column[4:], "effort"
    match = _FIELD.match(column)
    if match is None:
        return None
    return match["joint"], match["field"]


@dataclass(frozen=True)
class JointStates:
    """The kept messages of a bag's JointState topic.

    Attributes:
        path: the bag as given.
        topic: the topic read.
        stamps: (N,) int64 time of each message [ns] (header.stamp, or the receive
            time when every header stamp is 0).
        joint_names: the n joints read.
        position: (N, n) position[] of those joints [rad or m].
        effort: (N, n) effort[] (NaN where a message's effort[] is empty), or None
            when no kept message has efforts.
        notes: what was skipped or substituted, one sentence each.
        optional: ``{joint: (N,) position}`` of the optional joints read (NaN in a
            message without the joint); only joints some kept message holds.
    """

    path: str
    topic: str
    stamps: np.ndarray
    joint_names: tuple[str, ...]
    position: np.ndarray
    effort: np.ndarray | None
    notes: tuple[str, ...]
    optional: dict[str, np.ndarray] = field(default_factory=dict)


def _storage(path: str) -> Any:
    """The ``pathlib.Path`` rosbags opens: a ROS 1 file or a ROS 2 bag folder."""
    from pathlib import Path

    if not os.path.exists(path):
        raise FileNotFoundError(f"ROS bag {path}: no such file or folder.")
    if os.path.isdir(path):
        if not os.path.isfile(os.path.join(path, "metadata.yaml")):
            raise ValueError(
                f"ROS bag {path}: a folder without metadata.yaml is no ROS 2 bag."
            )
        return Path(path)
    if path.lower().endswith(".bag"):
        return Path(path)
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isfile(os.path.join(folder, "metadata.yaml")):
        raise ValueError(
            f"ROS bag {path}: a ROS 2 storage file is read with its bag folder's "
            f"metadata.yaml, and {folder} has none; give the bag folder."
        )
    return Path(folder)


def _rosbags() -> Any:
    """``rosbags.highlevel`` (ValueError naming the extra without it)."""
    try:
        from rosbags import highlevel
    except ImportError:
        raise ValueError(MISSING) from None
    return highlevel


def _topic(path: str, reader: Any, topic: str | None) -> Any:
    """The connections of the JointState topic read (module docstring)."""
    types = {c.topic: c.msgtype for c in reader.connections}
    states = sorted(name for name, kind in types.items() if kind == JOINT_STATE)
    if topic is not None:
        if types.get(topic) != JOINT_STATE:
            found = (
                f"it is of type {types[topic]}" if topic in types else "no such topic"
            )
            listed = ", ".join(states) or "none"
            raise ValueError(
                f"ROS bag {path}: --topic {topic}: {found}; the bag's "
                f"{JOINT_STATE} topics: {listed}."
            )
    elif len(states) == 1:
        topic = states[0]
    elif states:
        raise ValueError(
            f"ROS bag {path}: {len(states)} topics of type {JOINT_STATE} "
            f"({', '.join(states)}): name the one to read with --topic."
        )
    else:
        listed = ", ".join(f"{name} ({kind})" for name, kind in sorted(types.items()))
        raise ValueError(
            f"ROS bag {path}: no topic of type {JOINT_STATE}; its topics: "
            f"{listed or 'none'}."
        )
    return topic, [c for c in reader.connections if c.topic == topic]


def read_joint_states(
    path: str | os.PathLike,
    joints: Sequence[str] | None = None,
    *,
    topic: str | None = None,
    optional: Sequence[str] = (),
) -> JointStates:
    """Reads a bag's JointState messages (module docstring).

    Args:
        path: a ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
        joints: the joints needed; None: those of the topic's most frequent set of
            names, in its order.
        topic: the topic; None: the bag's one JointState topic.
        optional: joints whose positions are read where a kept message holds
            them (``JointStates.optional``; the locked and mimic joints, whose
            motion ``commands._arguments.locked_motion`` checks).

    Raises:
        ValueError: rosbags missing, a bag that cannot be read (named), no or
            several JointState topics, no message with every needed joint.
        FileNotFoundError: no such file.
    """
    path = os.fspath(path)
    storage = _storage(path)
    highlevel = _rosbags()
    wanted = None if joints is None else tuple(joints)
    try:
        with highlevel.AnyReader([storage]) as reader:
            topic, connections = _topic(path, reader, topic)
            messages = (
                (reader.deserialize(data, c.msgtype), received)
                for c, received, data in reader.messages(connections=connections)
            )
            return _kept(path, topic, messages, wanted, tuple(optional))
    except (ValueError, OSError):
        raise
    except Exception as error:  # rosbags' own errors, struct.error, KeyError, ...
        raise ValueError(
            f"ROS bag {path}: cannot be read ({type(error).__name__}: {error}); "
            "is it a complete ROS 1 .bag or ROS 2 bag? (a ROS 1 "
            "recording that was killed needs rosbag reindex)"
        ) from None


class _Rows:
    """The kept messages of one set of joints, as flat arrays.

    Streamed: a long bag holds 8 bytes a value here, not its decoded messages.
    """

    def __init__(self, wanted: tuple[str, ...], optional: tuple[str, ...] = ()):
        self.wanted = wanted
        self.optional = {name: array("d") for name in optional if name not in wanted}
        self.stamps = array("q")
        self.received = array("q")
        self.position = array("d")
        self.effort = array("d")
        self.empty_effort = 0  # kept messages with an empty effort[]
        self.malformed = 0

    def add(self, message: Any, received: int, index: dict[str, int]) -> None:
        """Keeps ``message`` (holding every wanted joint), unless malformed."""
        p = np.asarray(message.position, dtype=float)
        e = np.asarray(message.effort, dtype=float)
        if p.size != len(index) or e.size not in (0, len(index)):
            self.malformed += 1  # not one value per name[]
            return
        at = [index[name] for name in self.wanted]
        stamp = message.header.stamp
        self.stamps.append(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec))
        self.received.append(int(received))
        for name, values in self.optional.items():
            values.append(float(p[index[name]]) if name in index else math.nan)
        self.position.extend(p[at].tolist())
        if e.size:
            self.effort.extend(e[at].tolist())
        else:
            self.empty_effort += 1
            self.effort.extend([math.nan] * len(at))


def _kept(
    path: str,
    topic: str,
    messages: Any,
    wanted: tuple[str, ...] | None,
    optional: tuple[str, ...] = (),
) -> JointStates:
    """The messages holding every wanted joint, their fields in that order.

    ``wanted`` None: the most frequent set of names (its first message's order).
    """
    sets: Counter[frozenset[str]] = Counter()
    groups: dict[Any, _Rows] = {}
    total = 0
    for message, received in messages:
        total += 1
        names = list(message.name)
        index = {name: k for k, name in enumerate(names)}
        key = frozenset(index)
        sets[key] += 1
        if wanted is None:
            rows = groups.get(key) or groups.setdefault(key, _Rows(tuple(names)))
        elif all(name in index for name in wanted):
            rows = groups.get(None) or groups.setdefault(None, _Rows(wanted, optional))
        else:
            continue
        rows.add(message, received, index)
    if not total:
        raise ValueError(f"ROS bag {path}: topic {topic} holds no message.")
    if wanted is None:
        chosen = max(groups.values(), key=lambda g: len(g.stamps) + g.malformed)
        if not chosen.wanted:
            raise ValueError(f"ROS bag {path}: topic {topic}'s messages name no joint.")
    else:
        chosen = groups.get(None) or _Rows(wanted)
    wanted = chosen.wanted
    kept, n = len(chosen.stamps), len(wanted)
    notes = []
    lacking = total - kept - chosen.malformed
    if lacking:
        others = sorted({name for s in sets for name in s} - set(wanted))
        extra = f" (their joints: {', '.join(others)})" if others else ""
        notes.append(
            f"skipped {lacking} of {total} message(s) on {topic} that lack "
            f"joint(s) of {', '.join(wanted)}{extra}: another publisher on the topic."
        )
    if chosen.malformed:
        notes.append(
            f"skipped {chosen.malformed} message(s) on {topic} whose position[] or "
            "effort[] does not have one value per name[]."
        )
    if not kept:
        held = "; ".join(f"[{', '.join(sorted(s))}]" for s in sets)
        raise ValueError(
            f"ROS bag {path}: no message on {topic} holds every joint needed "
            f"({', '.join(wanted)}); its messages name: {held}."
        )
    times = np.frombuffer(chosen.stamps, dtype=np.int64).copy()
    if not times.any():
        times = np.frombuffer(chosen.received, dtype=np.int64).copy()
        notes.append(
            f"every header.stamp on {topic} is 0: the bag's receive times are used."
        )
    efforts = kept - chosen.empty_effort
    if efforts and chosen.empty_effort:
        notes.append(
            f"{chosen.empty_effort} message(s) on {topic} have an empty effort[]: "
            "their torques are empty cells."
        )
    position = np.frombuffer(chosen.position, dtype=float).reshape(kept, n)
    found = {name: np.array(values) for name, values in chosen.optional.items()}
    effort = np.frombuffer(chosen.effort, dtype=float).reshape(kept, n)
    return JointStates(
        path,
        topic,
        times,
        tuple(wanted),
        position.copy(),
        effort.copy() if efforts else None,
        tuple(notes),
        {name: values for name, values in found.items() if np.isfinite(values).any()},
    )


def needed_joints(columns: Sequence[str]) -> tuple[str, ...]:
    """The joints that the (non-time) ``columns`` name, in first-named order.

    Raises:
        ValueError: a column that no JointState field gives (the names listed).
    """
    out: dict[str, None] = {}
    for column in columns:
        meant = column_field(column)
        if meant is None:
            raise ValueError(
                f"column {column!r}: a ROS bag gives the columns q_<joint>, "
                "tau_<joint>, <joint>_position, <joint>_effort, - <joint>_position "
                "and - <joint>_effort (docs/DRIVE.md, 'ROS bags'); fix the drive "
                "file's [log] table."
            )
        out.setdefault(meant[0], None)
    return tuple(out)


def export_columns(
    states: JointStates, columns: Sequence[str]
) -> dict[str, np.ndarray]:
    """The named (non-time) log columns from the messages (:func:`column_field`).

    Raises:
        ValueError: an effort column when no message has efforts (named).
    """
    at = {name: k for k, name in enumerate(states.joint_names)}
    out = {}
    for column in columns:
        meant = column_field(column)
        if meant is None or meant[0] not in at:
            raise ValueError(f"ROS bag {states.path}: no column {column!r}.")
        joint, kind = meant
        if kind == "effort" and states.effort is None:
            raise ValueError(
                f"ROS bag {states.path}: the messages on {states.topic} carry no "
                f"effort[] (torques), needed for column {column!r}."
            )
        source = states.position if kind == "position" else states.effort
        assert source is not None
        out[column] = source[:, at[joint]]
    return out


def time_scale(stamps: np.ndarray, unit: str | None = None) -> float | None:
    """How the time column is written: None as integer ns, else ns times this scale.

    ``unit`` None (the plain format, ``drake_dynid.logs``): epoch stamps (>= 1e17
    ns) as integer nanoseconds, exact (the CSV reader's epoch rule), others in
    seconds. A drive file's unit (``core.drive_log.TIME_UNITS``; ``drake_dynid.
    raw_log`` reads its time column in that unit): ns as integers, the others
    with 17 digits.
    """
    from drake_dynid.core.drive_log import TIME_UNITS

    stamps = np.asarray(stamps, dtype=np.int64)
    epoch = unit is None and stamps.size and stamps.min() >= _EPOCH_NS
    if unit == "ns" or epoch:
        return None
    return 1e-9 / TIME_UNITS[unit or "s"]


def time_text(stamps: np.ndarray, scale: float | None) -> list[str]:
    """The time column's cells of ``stamps`` [ns] (``scale``: :func:`time_scale`)."""
    stamps = np.asarray(stamps, dtype=np.int64)
    if scale is None:
        return [str(int(x)) for x in stamps]
    return [f"{x:.17g}" for x in stamps * scale]


#: Messages written at a time by :func:`write_export` (its memory: a block's text).
EXPORT_ROWS = 1 << 16


def write_export(
    path: str | os.PathLike,
    states: JointStates,
    columns: Sequence[str],
    *,
    time: str = "t",
    time_unit: str | None = None,
) -> None:
    """Writes the messages as a CSV log: ``time`` then ``columns`` (17 digits).

    One row per kept message (row 2: the first), :data:`EXPORT_ROWS` rows at a
    time. ``time_unit``: the time column's unit, None for the plain format
    (:func:`time_scale`).
    """
    values = export_columns(states, columns)
    data = np.column_stack([values[c] for c in columns]) if columns else None
    write_rows(path, [time, *columns], states.stamps, data, time_unit)


def write_rows(
    path: str | os.PathLike,
    header: Sequence[str],
    stamps: np.ndarray,
    data: np.ndarray | None,
    time_unit: str | None = None,
) -> None:
    """A CSV file: ``header``, then each stamp [ns] (:func:`time_scale`) and row."""
    import csv

    scale = time_scale(stamps, time_unit)

    def write(stream: Any) -> None:
        csv.writer(stream, lineterminator="\n").writerow(header)
        for start in range(0, stamps.size, EXPORT_ROWS):
            rows = slice(start, start + EXPORT_ROWS)
            cells = time_text(stamps[rows], scale)
            if data is None:
                stream.write("".join(f"{s}\n" for s in cells))
                continue
            body = io.StringIO()
            np.savetxt(body, data[rows], delimiter=",", fmt="%.17g")
            lines = body.getvalue().splitlines()
            stream.write(
                "".join(f"{s},{line}\n" for s, line in zip(cells, lines, strict=True))
            )

    write_whole(path, write)
