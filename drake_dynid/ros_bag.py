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
  that leaves the header empty), the bag's receive time, with a note (or when
  asked: ``stamps="receive"``); messages recorded out of stamp order are put in
  it, but :data:`CLOCK_STEP_RUN` late in a row that the recording goes on from
  are a clock set back, an error
  (:class:`_Steps`) giving the ``dynid bag2csv --from / --to`` commands that
  export each side of it (``span``: a bag time range, the only messages read);
* the needed joints by name, in each message's own order (it may differ between
  messages); a message without one of them (another publisher on the topic, e.g. a
  gripper's) is skipped and counted in a note; none with all of them is an error
  naming the joints the topic's messages have. A message whose ``position[]`` or
  ``effort[]`` has not one value per name is skipped and counted (every one: an
  error saying so); without ``joints``, the joints are the most frequent set of
  names among the well-formed messages. ``position`` is q [rad or m],
  ``effort`` τ [N·m or N] (or a drive's raw reading, docs/DRIVE.md); an empty
  ``effort[]`` gives empty (NaN) torque cells; ``velocity[]`` is not read
  (the positions are differentiated).

The messages then become the rows of a CSV log (:func:`export_bag`, which streams
them into it a block at a time in bounded memory; ``dynid bag2csv`` writes that
file; :func:`read_joint_states` with :func:`write_export` write the same bytes from
arrays of every message): one row per message kept, in stamp order (the bag's
order for a recording in order; a message recorded twice, the same stamp and
values, once), row 2 the first one. The commands read that export with the
CSV readers (``drake_dynid.logs``, ``drake_dynid.raw_log``), so a bag's time stamps,
gaps and NaN cells are repaired exactly as a CSV log's, and its messages name the
export's rows. Column names (:func:`column_field`): ``t``, ``q_<joint>``,
``tau_<joint>`` (the plain format), and the names a drive file's ``[log]`` table can
give a JointState field, ``<joint>_position`` / ``- <joint>_position`` and
``<joint>_effort`` / ``- <joint>_effort`` (the ``rostopic echo -p`` style export
that the packaged ``tiago.toml`` names).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import os
import re
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_dynid.core._validate import listed
from drake_dynid.files import INCOMPLETE, is_stdout, write_whole

__all__ = [
    "JOINT_STATE",
    "BagExport",
    "JointStates",
    "column_field",
    "export_bag",
    "export_columns",
    "is_bag",
    "read_joint_states",
    "write_export",
]

#: The message type read (rosbags' name of ROS 1 and ROS 2 sensor_msgs/JointState).
JOINT_STATE = "sensor_msgs/msg/JointState"

#: The error without the optional dependency.
MISSING = "reading a ROS bag needs the rosbags package: pip install 'drake_dynid[ros]'"

#: The times a message can be read at (:func:`read_joint_states`' ``stamps``).
STAMPS = ("header", "receive")

#: File name endings of a bag: ROS 1, and a ROS 2 bag's storage files.
BAG_SUFFIXES = (".bag", ".db3", ".mcap")

#: Stamps from this many nanoseconds on are epoch times: written as integer
#: nanoseconds (exact; ``drake_dynid.logs`` reads integers >= 1e17 so).
_EPOCH_NS = 10**17

#: Sets of joint names an error lists (each :func:`core._validate.listed`).
LISTED_SETS = 4

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
            time when every header stamp is 0), nondecreasing (stamp order).
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
    if not path.lower().endswith(BAG_SUFFIXES):
        raise ValueError(
            f"ROS bag {path}: not a ROS bag by its name (a ROS 1 .bag file, a ROS 2 "
            "bag folder holding metadata.yaml, or its .db3 / .mcap file)."
        )
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
            raise ValueError(
                f"ROS bag {path}: --topic {topic}: {found}; the bag's "
                f"{JOINT_STATE} topics: {listed(states) or 'none'}."
            )
    elif len(states) == 1:
        topic = states[0]
    elif states:
        raise ValueError(
            f"ROS bag {path}: {len(states)} topics of type {JOINT_STATE} "
            f"({listed(states)}): name the one to read with --topic."
        )
    else:
        topics = listed(f"{name} ({kind})" for name, kind in sorted(types.items()))
        raise ValueError(
            f"ROS bag {path}: no topic of type {JOINT_STATE}; its topics: "
            f"{topics or 'none'}."
        )
    return topic, [c for c in reader.connections if c.topic == topic]


def read_joint_states(
    path: str | os.PathLike,
    joints: Sequence[str] | None = None,
    *,
    topic: str | None = None,
    optional: Sequence[str] = (),
    stamps: str = "header",
    span: tuple[float | None, float | None] = (None, None),
) -> JointStates:
    """Reads a bag's JointState messages into arrays (module docstring).

    The commands stream the messages into their CSV export instead
    (:func:`export_bag`, same rows); this holds them all, and puts them in
    stamp order as the export does (a stable sort), a message repeating the
    one before it (the same stamp, positions and efforts) dropped, with the
    export's notes (without its merge's count: nothing is merged here).

    Args:
        path: a ROS 1 ``.bag``, a ROS 2 bag folder, or its ``.db3`` / ``.mcap`` file.
        joints: the joints needed; None: those of the topic's most frequent set of
            names, in its order.
        topic: the topic; None: the bag's one JointState topic.
        optional: joints whose positions are read where a kept message holds
            them (``JointStates.optional``; the locked and mimic joints, whose
            motion ``commands._arguments.locked_motion`` checks).
        stamps: ``"header"``, the time of a message is its header.stamp (the
            receive time when every one is 0); ``"receive"``: the bag's receive
            time (a header clock set back, :class:`_Steps`).
        span: ``(from, to)`` [s] after the bag's first message (any topic), in
            bag (receive) time: only the messages received at or after
            ``from`` and before ``to`` are read (None: the bag's start, end;
            ``to`` the bag's length: to its end, the last message too);
            the others are not read at all (a clock step outside the range is
            not seen). ``0 <= from < to``, both within the bag (:func:`_window`).

    Raises:
        ValueError: rosbags missing, a bag that cannot be read (named), no or
            several JointState topics, no message with every needed joint, a
            clock set back (:class:`_Steps`; when and by how much).
        FileNotFoundError: no such file.
    """
    sink = _Collect()
    done, _ = _scan(path, joints, topic, optional, sink, stamps=stamps, span=span)
    blocks = sink.blocks
    n, m = len(done.joint_names), len(sink.held)

    def joined(field: str, width: int, dtype: Any = float) -> np.ndarray:
        parts = [getattr(b, field) for b in blocks]
        if not parts:
            return np.empty((0, width) if width >= 0 else 0, dtype=dtype)
        return np.concatenate(parts)

    times = joined("received" if sink.plan.received else "stamps", -1, np.int64)
    position, effort, held = (
        joined("position", n),
        joined("effort", n),
        joined("held", m),
    )
    # The export's order (export_bag): by stamp (stable), a message repeating
    # the one before it (the same stamp and values) dropped.
    late = np.zeros(times.size, dtype=bool)  # recorded after a later-stamped one
    late[1:] = times[1:] < np.maximum.accumulate(times)[:-1]
    order = np.argsort(times, kind="stable")
    times, position, effort, held = (a[order] for a in (times, position, effort, held))
    repeated = _repeating(times, position, effort)
    kept = np.concatenate([[True], ~repeated])
    reordered = int(np.count_nonzero(late[order[kept]]))
    times, position, effort, held = (a[kept] for a in (times, position, effort, held))
    notes = _order_notes(done.topic, reordered, int(np.count_nonzero(repeated)))
    return JointStates(
        done.path,
        done.topic,
        times,
        done.joint_names,
        position,
        effort if done.efforts else None,
        (*done.notes, *notes),
        {
            name: held[:, j].copy()
            for j, name in enumerate(sink.held)
            if name in done.held
        },
    )


@dataclass(frozen=True)
class BagExport:
    """What :func:`export_bag` wrote from a bag's JointState topic.

    Attributes:
        path: the bag as given.
        topic: the topic read.
        joint_names: the joints read.
        rows: the messages kept (the export's rows after its header).
        efforts: whether a kept message has an effort[] (else the effort columns
            are empty (NaN) cells).
        notes: what was skipped or substituted, one sentence each.
        held: the optional joints that a kept message holds.
        held_path: the file of their positions, or None (none held, or no
            ``held_out``).
        passes: the passes over the bag (2 when its first block of messages
            misjudged a whole-bag property; see :func:`export_bag`).
    """

    path: str
    topic: str
    joint_names: tuple[str, ...]
    rows: int
    efforts: bool
    notes: tuple[str, ...]
    held: tuple[str, ...]
    held_path: str | None
    passes: int


def export_bag(
    path: str | os.PathLike,
    out: str | os.PathLike,
    joints: Sequence[str] | None,
    columns: Any,
    *,
    topic: str | None = None,
    optional: Sequence[str] = (),
    time: str = "t",
    time_unit: str | None = None,
    held_out: str | os.PathLike | None = None,
    held_column: str = "q_{joint}",
    stamps: str = "header",
    span: tuple[float | None, float | None] = (None, None),
    options: Sequence[str] | None = None,
) -> BagExport:
    """Streams a bag's JointState messages into a CSV log at ``out``.

    The rows of :func:`write_export` on :func:`read_joint_states`'s arrays, bit
    for bit (both in stamp order, a message repeating the one before dropped;
    the export holds back :data:`REORDER_ROWS` messages for that, later ones
    merged in at the end, :class:`_Late`), in bounded memory: the messages are decoded
    and written :data:`EXPORT_ROWS` at a time, nothing else grows with the bag
    (a ROS 1 bag is read a chunk at a time, :class:`_Ros1Chunks`; where rosbags'
    reader reads it, its index of every message, about 350 bytes each). A
    message to merge in is refused on an output that cannot be read back
    (standard output, a pipe; ValueError naming their count and lateness),
    found by the pass that only reads before such an output is written (no
    row written); should the export to it stop on an error once written, its
    last line is :data:`_INCOMPLETE` and the error, a row the CSV readers
    refuse, so that the rows written are never read as the whole bag.

    What the header and the time column need of the whole bag (the joints when
    ``joints`` is None: the most frequent set of names; whether every stamp is
    0; whether every stamp is an epoch time (:func:`time_scale`); whether a
    message has efforts; which optional joints occur) is judged from the first
    block and checked at the end: where the bag proves it wrong, the file is
    written again in a second pass over the bag (time, not memory). An output
    that cannot be read back (a pipe; ``out`` ``-``, standard output, always)
    is written after a pass that only reads (the plan, the messages to merge
    in counted: a dry run of :class:`_Export`).

    Args:
        path: the bag (:func:`read_joint_states`).
        out: the CSV file written (whole or not at all: ``files.write_whole``).
        joints: the joints read; None: the most frequent set of names.
        topic: the topic; None: the bag's one JointState topic.
        optional: joints whose positions are written to ``held_out``.
        columns: ``columns(joint_names, efforts) -> [column, ...]``: the log
            columns after ``time`` (:func:`column_field`; an effort column of
            messages without efforts is NaN cells).
        time: the time column's name.
        time_unit: its unit (:func:`time_scale`).
        held_out: where to write the optional joints' positions (``t``, the
            held joints, then the joints read; :func:`time_scale`'s plain
            format), when a kept message holds one.
        held_column: their column names (``{joint}``).
        stamps: the messages' time (:func:`read_joint_states`).
        span: the bag time range read (:func:`read_joint_states`).
        options: the command's options that the error of a clock set back
            repeats in the ``dynid bag2csv`` commands it gives (``dynid
            bag2csv``'s --joints, --drive, --urdf, --lock; None: not known).

    Raises:
        ValueError, FileNotFoundError: as :func:`read_joint_states`.
    """
    holder: list[BagExport] = []

    def write(stream: Any) -> None:
        rewinds = not is_stdout(out) and _rewinds(stream)
        readable = rewinds and _readable(stream)
        sink = _Export(stream, columns, time, time_unit, held_out, held_column)
        sink.rereads, sink.label = readable, f"ROS bag {os.fspath(path)}"
        try:
            plan = None
            if not readable:
                # A pass that only reads: the plan, and the messages to merge
                # in, refused before a row is written (_Export's dry run).
                dry = _Export(None, columns, time, time_unit, None, held_column)
                try:
                    plan = _scan(
                        path,
                        joints,
                        topic,
                        optional,
                        dry,
                        stamps=stamps,
                        span=span,
                        options=options,
                    )[1]
                finally:
                    dry.close()
                if dry.late.count:
                    raise ValueError(_unmerged(sink.label, dry.late))
            try:
                done, _ = _scan(
                    path,
                    joints,
                    topic,
                    optional,
                    sink,
                    plan,
                    stamps=stamps,
                    span=span,
                    options=options,
                )
            except BaseException as error:  # Ctrl-C too
                if sink.started and not rewinds:
                    # Rows written that cannot be taken back: a last line that
                    # the CSV readers refuse, so a cut export is never read
                    # as a whole one.
                    with contextlib.suppress(Exception):
                        said = str(error) or type(error).__name__
                        said = " ".join(said.replace(",", ";").split())
                        # A signal during a write may have cut a row: the
                        # line on a line of its own.
                        lead = "\n" if sink.writing else ""
                        sink.stream.write(f"{lead}{_INCOMPLETE}{said}\n")
                raise
            merged = ""
            if sink.late.count:
                merged = (
                    f" ({sink.late.count} of them more than {REORDER_ROWS} "
                    f"messages late, up to {sink.late.lateness * 1e-9:.6g} s: "
                    "placed by a merge of the export at its end)"
                )
            notes = _order_notes(done.topic, sink.reordered, sink.repeated, merged)
            if notes:
                done = dataclasses.replace(
                    done,
                    rows=done.rows - sink.repeated,
                    notes=(*done.notes, *notes),
                )
            holder.append(done)
        finally:
            sink.close()

    write_whole(out, write)
    if is_stdout(out):
        import sys

        _reader_gone(sys.stdout)  # gone while its last rows were flushed
    return holder[0]


def _order_notes(
    topic: str, reordered: int, repeated: int, merged: str = ""
) -> list[str]:
    """The notes of messages put in stamp order and of repeats dropped."""
    notes = []
    if reordered:
        notes.append(
            f"{reordered} message(s) on {topic} were recorded after one with a "
            f"later header.stamp: written in stamp order{merged}."
        )
    if repeated:
        notes.append(
            f"dropped {repeated} message(s) on {topic} repeating the one before "
            "(the same header.stamp and values)."
        )
    return notes


def _readable(stream: Any) -> bool:
    """Whether ``stream`` can be read back (``files.write_whole``'s new file)."""
    try:
        return bool(stream.readable())
    except (AttributeError, ValueError, OSError):
        return False


def _rewinds(stream: Any) -> bool:
    """Whether ``stream`` can be rewound and cut (a regular file)."""
    try:
        return bool(stream.seekable())
    except (AttributeError, ValueError, OSError):
        return False


@dataclass(frozen=True)
class _Plan:
    """What the export's header and time column need of the whole bag."""

    wanted: tuple[str, ...]  # the joints read
    exact: frozenset[str] | None  # joints None: the message's set of names kept
    received: bool  # every header stamp 0: the receive times
    epoch: bool  # every time stamp >= 1e17 ns
    efforts: bool  # a kept message has efforts
    held: tuple[str, ...]  # the optional joints some kept message holds


@dataclass
class _Block:
    """Kept messages, decoded: (B,) int64 stamps [ns], (B, n) and (B, m) floats."""

    stamps: np.ndarray
    received: np.ndarray
    position: np.ndarray
    effort: np.ndarray
    held: np.ndarray
    empty: int  # messages with an empty effort[] (NaN rows in effort)


@dataclass
class _Tally:
    """A pass's counts (for the notes and the final plan)."""

    total: int = 0
    sets: dict[frozenset[str], list[Any]] = field(default_factory=dict)
    kept: int = 0
    malformed: int = 0
    empty_effort: int = 0
    stamped: bool = False  # a nonzero header stamp
    low_stamp: bool = False  # a header stamp < 1e17
    low_received: bool = False  # a receive time < 1e17
    present: set[str] = field(default_factory=set)
    steps: _Steps = field(default_factory=lambda: _Steps())
    receive: bool = False  # the receive times asked for (stamps "receive")

    def add(self, block: _Block, held: tuple[str, ...]) -> None:
        """Counts a block of kept messages."""
        self.kept += block.stamps.size
        self.empty_effort += block.empty
        if block.stamps.size:
            self.stamped = self.stamped or bool(block.stamps.any())
            self.low_stamp = self.low_stamp or bool(block.stamps.min() < _EPOCH_NS)
            self.low_received = self.low_received or bool(
                block.received.min() < _EPOCH_NS
            )
        found = np.isfinite(block.held).any(axis=0)
        self.present.update(name for name, f in zip(held, found, strict=True) if f)

    def plan(
        self,
        wanted: tuple[str, ...],
        exact: frozenset[str] | None,
        optional: tuple[str, ...],
    ) -> _Plan:
        """The plan these counts imply, for the joints ``wanted``."""
        received = self.receive or not self.stamped
        low = self.low_received if received else self.low_stamp
        return _Plan(
            wanted,
            exact,
            received,
            bool(self.kept) and not low,
            self.kept > self.empty_effort,
            tuple(name for name in optional if name in self.present),
        )


#: Kept messages in a row, in the bag's order, each older than the newest one
#: recorded before them, that may be a clock set back (:class:`_Steps`, which
#: looks at the messages after them, :class:`_Candidate`). A
#: transport's reordering delays a message past a few newer ones: it is late
#: alone (those after it are newer than the newest before it), and a message
#: recorded twice by two paths alternates with newer ones. A clock set back by
#: d makes every message late until its stamps pass the newest: d / h in a
#: row (ntpd steps a clock off by more than 0.128 s and slews a smaller
#: offset: 12 messages at 100 Hz, 128 at 1 kHz).
CLOCK_STEP_RUN = 10

#: Late messages in a row, each stamped where no message was missing among
#: those recorded before it, that may be a clock set back although fewer
#: than :data:`CLOCK_STEP_RUN` (:meth:`_Steps._interleaving`): a transport's
#: reordering fills a gap that the late message left; a clock set back by a
#: few periods (5.5 ms at 1 kHz: 5 late) stamps its messages between, or on,
#: the stamps of messages recorded before.
SHORT_STEP_RUN = 3

#: A gap between two stamps up to this many times the median step of the
#: on-time messages recorded before it is no gap (no message missing there).
_NO_GAP = 1.5


#: A late run names a clock set back only if, after the newest time recorded
#: before it, the messages come less densely than in the stretch of time the
#: run's messages fill, by this factor (:class:`_Candidate`): that stretch
#: holds the recording before a clock set back and after it (twice one
#: recording's density), the time after the newest one the recording after it
#: alone; a second publisher's late batch fills its stretch as both
#: publishers fill the time after (the same density). sqrt(1/2): halfway, in
#: ratio, between the two.
_STEP_DENSITY = 0.5**0.5

#: The time after the newest one recorded before a late run in which the
#: messages are counted (:class:`_Candidate`), in median steps of the times
#: recorded before the run.
_AFTER_STEPS = 32

#: The times recorded last before a late run whose median step is that step.
_SPACING_ROWS = 256


@dataclass
class _Candidate:
    """A late run that may be a clock set back (:class:`_Steps`).

    A clock set back by d makes every later message late by d: the recording
    goes on from the run's times, and after ``newest`` (the newest time
    recorded before the run) the messages come as densely as one recording,
    half as densely as in the stretches of time that the recording before
    and after the step both fill. A second publisher received in late
    batches, or a burst received late after the messages following it (it
    fills the gap it left), returns to the original sequence: the time after
    ``newest`` is filled as densely as those stretches. ``stretches``: ``[low,
    high, count]`` [ns, ns, messages]: the time from the run's first
    message's to ``newest`` (a step's), and the span of the run's messages
    up to the one that made it a candidate (a clock set back a few periods,
    then forward); ``count``: the messages fed, before the run and after it,
    whose time lies in ``[low, high]``, density ``(count - 1) / (high -
    low)``. ``after``: those in ``(newest, newest + width]``. A step when
    ``after / width < _STEP_DENSITY`` times the larger density, judged once a
    time past ``newest + width + wait`` is fed (the messages late in a batch
    counted), or at the bag's end.
    """

    first: tuple[int, int, int, int]  # the run's first message (_Steps.step)
    length: int  # the run's messages so far
    open: bool  # the run goes on at the end of what was fed
    newest: int  # the newest time recorded before the run [ns]
    stretches: list[list[int]]  # [low, high, count]: [ns, ns, messages]
    width: int  # [ns]; 0: the stretch is older than the times kept (a step)
    wait: int  # [ns]
    after: int = 0

    def count(self, times: np.ndarray) -> None:
        """Counts the times [ns] fed in the stretches and after ``newest``."""
        for stretch in self.stretches:
            low, high, _ = stretch
            stretch[2] += int(np.count_nonzero((times >= low) & (times <= high)))
        top = self.newest + self.width
        self.after += int(np.count_nonzero((times > self.newest) & (times <= top)))

    def sparse(self, width: int) -> bool:
        """Whether fewer came after ``newest`` over ``width`` [ns] than a step's.

        Less densely than in the densest stretch by :data:`_STEP_DENSITY`.
        """
        density = max(
            (count - 1) / (high - low)
            for low, high, count in self.stretches
            if high > low
        )
        return self.after < _STEP_DENSITY * density * width


class _Steps:
    """A clock set back: a run of :data:`CLOCK_STEP_RUN` late messages or more.

    Or of :data:`SHORT_STEP_RUN` late messages or more, each stamped where no
    message was missing (:meth:`_interleaving`); either only when the messages
    after it show the recording going on from the run's stamps, alone
    (:class:`_Candidate`: a second publisher's late batches and a delayed
    burst return to the original sequence).

    Fed each block's times in the bag's order (the header stamps, or the
    receive times when those are read), then :meth:`finish`; a message is
    late when older than the newest recorded before it, unless it repeats one
    of the :data:`REORDER_ROWS` recorded before it (the same time and values
    (:func:`_same_rows`): a message re-sent, which the export drops, not a
    clock's new stamp; a burst of them was named a clock step). ``step``: the
    first step's first message ``(index among the kept messages, its time,
    its receive time, the newest time before it)`` [ns], or None; ``length``:
    the messages of its run.
    Put in stamp order, the messages after such a step interleave with
    those before it: two stretches of a recording on one time line, which
    the readers then refuse for another cause (the samples would be
    interpolated, or duplicated time stamps).
    """

    def __init__(self) -> None:
        self.newest: int | None = None  # the newest time recorded
        self.seen = 0  # messages fed
        self.first_received: int | None = None
        self.run = 0  # late messages in a row at the end of what was fed
        self.start: tuple[int, int, int, int] | None = None  # that run's first
        self.step: tuple[int, int, int, int] | None = None
        self.length = 0  # the step's run's messages
        self.recent: tuple[np.ndarray, np.ndarray] | None = None  # times, values
        self.ontime = np.empty(0, dtype=np.int64)  # the recent times not late
        self.every = np.empty(0, dtype=np.int64)  # the recent times, late ones too
        self.odd = 0  # late messages in a row on no gap (_interleaving), at the end
        self.pending: list[_Candidate] = []  # runs not judged yet
        self.steps: list[_Candidate] = []  # runs judged a step
        self.judged = -1  # the last run made a candidate (its first index)
        self.batches = False  # a run judged not a step by the messages after it

    def add(self, times: np.ndarray, block: _Block) -> None:
        """Feeds a block's times [ns] (``block``: its receive times)."""
        n = times.size
        if not n:
            return
        if self.first_received is None:
            self.first_received = int(block.received[0])
        floor = np.iinfo(np.int64).min if self.newest is None else self.newest
        before = np.maximum.accumulate(np.concatenate([[floor], times]))[:-1]
        late = times < before
        self._repeats(times, block, late)
        index = np.arange(n)
        fresh = np.maximum.accumulate(np.where(late, -1, index))
        # The run of late messages ending at each message (0: not late).
        length = np.where(fresh >= 0, index - fresh, index + 1 + self.run)
        recorded = self.every  # before this block (_interleaving moves it on)
        odd = self._interleaving(times, late, length)
        fresh = np.maximum.accumulate(np.where(odd, -1, index))
        # The run of late messages on no gap ending at each (a short step).
        short = np.where(fresh >= 0, index - fresh, index + 1 + self.odd)
        self.odd = int(short[-1])
        for candidate in self.pending:  # the runs going on, and the stretch after
            if candidate.open:
                stop = np.flatnonzero(~late)
                candidate.length += int(stop[0]) if stop.size else n
                candidate.open = not stop.size
            candidate.count(times)
        hits = np.flatnonzero((length >= CLOCK_STEP_RUN) | (short >= SHORT_STEP_RUN))
        pool = np.concatenate([recorded, times])  # in the bag's order
        base = self.seen - recorded.size  # the index of pool[0]
        for k in hits.tolist():
            first = k - int(length[k]) + 1
            if self.seen + first == self.judged:
                continue  # that run's candidate is made
            self.judged = self.seen + first
            if self.steps and self.steps[0].first[0] < self.judged:
                break  # a step before it: the first is known
            start = (
                self._first(first, times, block, before) if first >= 0 else self.start
            )
            assert start is not None
            stop = np.flatnonzero(~late[k:])
            self._candidate(
                start,
                int(length[k + stop[0] - 1 if stop.size else n - 1]),
                not stop.size,
                pool[self.judged - base :],
                pool[self.judged - base : self.seen + k + 1 - base],
                pool[max(0, self.judged - base - REORDER_ROWS) : self.judged - base],
            )
        if late[-1]:
            last = n - int(length[-1])
            if last >= 0:
                self.start = self._first(last, times, block, before)
        else:
            self.start = None
        self.run = int(length[-1])
        self.newest = int(max(before[-1], times[-1]))
        self.seen += n
        self._judge(False)

    def _repeats(self, times: np.ndarray, block: _Block, late: np.ndarray) -> None:
        """Clears ``late`` of a message repeating one of the recent ones.

        The same time and positions and efforts (NaN equal to NaN) as one of
        the :data:`REORDER_ROWS` messages fed before it.
        """
        values = np.hstack([block.position, block.effort])
        if self.recent is None:
            self.recent = (times[:0], values[:0])
        pool = np.concatenate([self.recent[0], times])
        rows = np.concatenate([self.recent[1], values])
        offset = self.recent[0].size
        self.recent = (pool[-REORDER_ROWS:], rows[-REORDER_ROWS:])
        candidates = np.flatnonzero(late)
        if not candidates.size:
            return
        order = np.argsort(pool, kind="stable")
        ordered = pool[order]
        low = np.searchsorted(ordered, times[candidates], side="left")
        high = np.searchsorted(ordered, times[candidates], side="right")
        shared = high - low > 1  # another message of that time (else itself)
        for k, a, b in zip(candidates[shared], low[shared], high[shared], strict=True):
            own = offset + k
            for j in order[a:b]:
                if j < own and _same_rows(rows[[j, own]])[0]:
                    late[k] = False
                    break

    def _interleaving(
        self, times: np.ndarray, late: np.ndarray, length: np.ndarray
    ) -> np.ndarray:
        """(n,) whether each late message is stamped where no message was missing.

        Among the on-time messages (not late) of the :data:`REORDER_ROWS`
        recorded before it: its stamp t lies between two, lo <= t < hi, no
        more than :data:`_NO_GAP` median steps apart (no gap: a transport's
        reordering puts a message back in the gap it left, two steps or
        more), and nearer to one of them than the smallest step of every time
        recorded before the run, late ones too (a spacing the recording never
        has: a second publisher always received late has its own there; on
        lo: another message of that stamp, with other values: a repeat is not
        late). A clock set back by d stamps its next d / h messages so
        (between, or on, stamps h apart); two publishers interleaved make
        spacings the recording has. Only the
        first :data:`CLOCK_STEP_RUN` of a run of :data:`SHORT_STEP_RUN` late
        messages or more are looked at (a message or two late: a reordering).
        """
        n = times.size
        odd = np.zeros(n, dtype=bool)
        ontime = np.concatenate([self.ontime, times[~late]])
        every = np.concatenate([self.every, times])
        before = np.concatenate([[0], np.cumsum(~late)])  # on-time ones before k
        if late.any():
            runs = np.cumsum(~late)  # the run of each late message
            total = np.bincount(runs, weights=late).astype(int)[runs]
            total[runs == 0] += self.run  # the run going on from before
            looked = late & (total >= SHORT_STEP_RUN) & (length <= CLOCK_STEP_RUN)
            for k in np.flatnonzero(looked):
                end = self.ontime.size + int(before[k])
                pool = np.sort(ontime[max(0, end - REORDER_ROWS) : end])
                steps = np.diff(pool)
                steps = steps[steps > 0]
                t = int(times[k])
                at = int(np.searchsorted(pool, t, side="right"))
                if steps.size < 8 or at == 0 or at == pool.size:
                    continue
                lo, hi = int(pool[at - 1]), int(pool[at])
                # The smallest step of every time recorded before the run, late
                # ones too: a second publisher always received late (in bursts)
                # has its spacing there, not among the on-time ones.
                first = self.every.size + k - int(length[k]) + 1
                seen = np.diff(np.sort(every[max(0, first - REORDER_ROWS) : first]))
                seen = seen[seen > 0]
                smallest = int(min(steps.min(), seen.min(initial=steps.min())))
                odd[k] = (
                    hi - lo <= _NO_GAP * float(np.median(steps))
                    and min(t - lo, hi - t) < smallest
                )
        self.ontime = ontime[-REORDER_ROWS:]
        self.every = every[-REORDER_ROWS:]
        return odd

    def _first(
        self, k: int, times: np.ndarray, block: _Block, before: np.ndarray
    ) -> tuple[int, int, int, int]:
        return self.seen + k, int(times[k]), int(block.received[k]), int(before[k])

    def _candidate(
        self,
        first: tuple[int, int, int, int],
        length: int,
        going: bool,
        since: np.ndarray,
        run: np.ndarray,
        recorded: np.ndarray,
    ) -> None:
        """Makes the :class:`_Candidate` of a late run.

        ``since``: the times from the run's first message on (this block);
        ``run``: the run's first ones, up to the message that made it one;
        ``recorded``: the recent times before it (bag order).
        """
        newest = first[3]
        low, high = int(run.min()), int(run.max())
        stretches = [[first[1], newest, 0], [low, high, 0]]
        spacing = np.diff(np.unique(recorded[-_SPACING_ROWS:]))
        width = wait = 0
        if spacing.size and recorded.min() <= low:
            width = max(1, int(_AFTER_STEPS * float(np.median(spacing))))
            wait = 2 * (newest - low) + width
        candidate = _Candidate(first, length, going, newest, stretches, width, wait)
        candidate.count(recorded)
        candidate.count(since)
        self.pending.append(candidate)

    def _judge(self, end: bool) -> None:
        """Judges the candidates whose time after is counted (``end``: all)."""
        assert self.newest is not None
        waiting = []
        for c in self.pending:
            if not c.width:
                # Older than the times kept (or the bag's first): the stretch
                # is not known; a run of that many late messages, a step.
                self.steps.append(c)
            elif self.newest > c.newest + c.width + c.wait:
                if c.sparse(c.width):
                    self.steps.append(c)
                else:
                    self.batches = True  # the original sequence goes on
            elif end:
                # The bag ends before the time after it is counted: judged on
                # what there is (nothing after its newest: a step), unless a
                # run before it was shown a second publisher's batch.
                part = min(c.width, self.newest - c.newest)
                if not self.batches and (part <= 0 or c.sparse(part)):
                    self.steps.append(c)
            else:
                waiting.append(c)
        self.pending = waiting
        if self.steps:
            self.steps.sort(key=lambda c: c.first[0])
            # The first step is the one named: candidates after it not needed.
            self.pending = [c for c in waiting if c.first[0] < self.steps[0].first[0]]

    def finish(self) -> None:
        """Judges the runs left (the bag's end): ``step`` and ``length``."""
        if self.newest is not None:
            self._judge(True)
        if self.steps:
            self.step, self.length = self.steps[0].first, self.steps[0].length


def _seconds(ns: int) -> str:
    """``ns`` nanoseconds as seconds, every digit (an epoch time's too)."""
    sign = "-" if ns < 0 else ""
    whole, part = divmod(abs(ns), 10**9)
    return f"{sign}{whole}.{part:09d}".rstrip("0").rstrip(".")


def _clock_step(
    path: str,
    topic: str,
    steps: _Steps,
    plan: _Plan,
    window: _Window,
    asked: str | None = None,
    receive: bool = False,
    options: Sequence[str] | None = None,
) -> str:
    """The error of a clock set back (:class:`_Steps`), what to do.

    The commands that export each side of the step, with their values (the
    step's bag time, :class:`_Window`'s origin), and ``--stamps receive``
    when the header stamps were read. ``asked``: the ``--topic`` given;
    ``receive``: ``--stamps receive`` given (the sides are read so too);
    ``options``: the command's other options, repeated in the commands (None:
    not known, the advice asks for the command's --drive, --urdf, --joints
    and --lock).
    """
    import shlex

    assert steps.step is not None
    k, time, received, newest = steps.step
    clock = "the bag's receive times" if plan.received else "header.stamp"
    into = _seconds(received - window.origin)
    command = f"dynid bag2csv {shlex.quote(path)}"
    short = ""
    if steps.length < CLOCK_STEP_RUN:
        short = (
            f" (fewer than {CLOCK_STEP_RUN}, but each stamped between or on the "
            "stamps of messages recorded before it where none was missing: no gap "
            "that a transport's reordering left)"
        )
    if asked is not None:
        command += f" --topic {shlex.quote(asked)}"
    same, with_ = (
        "; the same options",
        ("; with the command's --drive, --urdf, --joints and --lock when it has them"),
    )
    if options is not None:
        command += "".join(f" {shlex.quote(o)}" for o in options)
        same = with_ = ""
    since = "" if window.start is None else f" --from {window.seconds(window.start)}"
    until = "" if window.stop is None else f" --to {window.seconds(window.stop)}"
    stamps = " --stamps receive" if receive else ""
    sides = (
        f"'{command} --out before.csv{since} --to {into}{stamps}' and "
        f"'{command} --out after.csv --from {into}{until}{stamps}'"
    )
    advice = (
        f"Export each side of the step: {sides} (the messages received before and "
        f"from bag time {into} s{with_}), and give one."
    )
    if not plan.received:
        advice = (
            "Export the bag with its receive times, "
            f"'{command} --out LOG.csv{since}{until} --stamps receive'"
            + (f" ({with_[2:]})" if with_ else "")
            + f", and give LOG.csv; or export each side of the step: {sides} (the "
            f"messages received before and from bag time {into} s{same}), and give "
            "one."
        )
    return (
        f"ROS bag {path}: {clock} on {topic} steps back {_seconds(newest - time)} s "
        f"at message {k + 1}{window.label} (bag time {_seconds(received)} s, {into} "
        f"s after the bag's first message): from {_seconds(newest)} s to "
        f"{_seconds(time)} s, "
        f"{steps.length} message(s) in a row older than one recorded before them"
        f"{short}, a clock set back (a robot's clock re-synchronised, e.g. by "
        "NTP), not a transport's reordering; put in stamp order they would "
        f"interleave the recording before and after the step. {advice}"
    )


@dataclass(frozen=True)
class _Window:
    """The bag time range read (:func:`read_joint_states`' ``span``).

    ``origin``: the bag's first message's receive time [ns] (any topic: the
    reader's start time); ``start``, ``stop``: the receive times read, at or
    after ``start`` and before ``stop`` [ns] (None: no bound), the readers'
    own filter (rosbags' ``messages(start=, stop=)``, :class:`_Ros1Chunks`);
    ``stop`` at the bag's last message (``--to`` its length) reads to its
    end, that message too (:attr:`until`).
    """

    origin: int
    start: int | None = None
    stop: int | None = None
    last: int | None = None  # the bag's last receive time [ns]

    @property
    def until(self) -> int | None:
        """The readers' ``stop``: ``stop``, or past the last message at it."""
        return None if self.stop is None or self.stop == self.last else self.stop

    def seconds(self, ns: int) -> str:
        """A receive time [ns] as seconds after the origin (every digit)."""
        return _seconds(ns - self.origin)

    @property
    def label(self) -> str:
        """`` in the bag time range read (A s to B s)``, or ``""`` (no range)."""
        if self.start is None and self.stop is None:
            return ""
        since = "the start" if self.start is None else f"{self.seconds(self.start)} s"
        until = "the end" if self.stop is None else f"{self.seconds(self.stop)} s"
        return f" in the bag time range read ({since} to {until})"


def _window(
    path: str,
    span: tuple[float | None, float | None],
    origin: int,
    end: int,
) -> _Window:
    """The :class:`_Window` of ``span`` = (from, to) [s] after ``origin`` [ns].

    ``origin``, ``end``: the bag's first and last receive times [ns]
    (rosbags' ``start_time``; ``end_time``, less 1 ns in a ROS 2 bag).

    ``--to`` the bag's length reads to its end (the last message received
    at it too: it was left out).

    Raises:
        ValueError: a bound not finite, negative, beyond the bag's length, or
            ``from >= to`` (named as the options ``--from`` and ``--to``).
    """
    first, last = span
    if first is None and last is None:
        return _Window(origin)
    length = max(0, end - origin)
    bounds: list[int | None] = []
    for option, value in (("--from", first), ("--to", last)):
        if value is None:
            bounds.append(None)
            continue
        value = float(value)
        if not np.isfinite(value) or value < 0:
            raise ValueError(
                f"ROS bag {path}: {option} {value}: the bag time range is in "
                "seconds after the bag's first message, a finite number >= 0."
            )
        ns = round(value * 1e9)
        if ns > length:
            raise ValueError(
                f"ROS bag {path}: {option} {value}: beyond the bag, whose messages "
                f"span {_seconds(length)} s of bag time (from its first message)."
            )
        bounds.append(origin + ns)
    start, stop = bounds
    if start is not None and stop is not None and start >= stop:
        raise ValueError(
            f"ROS bag {path}: --from {first} is not before --to {last}: the range "
            "is the messages received at or after --from and before --to."
        )
    return _Window(origin, start, stop, origin + length)


class _Collect:
    """A sink that keeps every block (:func:`read_joint_states`)."""

    def __init__(self) -> None:
        self.blocks: list[_Block] = []
        self.held: tuple[str, ...] = ()
        self.plan: Any = None

    def begin(self, plan: _Plan, held: tuple[str, ...]) -> None:
        self.blocks, self.held, self.plan = [], held, plan

    def rows(self, block: _Block) -> None:
        self.blocks.append(block)

    def end(self) -> None:
        pass

    def close(self) -> None:
        pass


class _Export:
    """A sink that writes each block as CSV rows (:func:`export_bag`).

    ``stream`` None: a dry run that writes nothing and keeps no late row, only
    counts the messages to merge in (``late.count``, ``late.lateness``): the
    pass before an output that cannot be read back.
    """

    def __init__(
        self,
        stream: Any,
        columns: Any,
        time: str,
        time_unit: str | None,
        held_out: Any,
        held_column: str,
    ) -> None:
        self.stream, self.columns, self.time, self.unit = (
            stream,
            columns,
            time,
            time_unit,
        )
        self.held_out, self.held_column = held_out, held_column
        self.held_stream: Any = None
        self.started = False
        self.writing = False  # inside a write of rows (a signal may cut one)
        self.carry: _Block | None = None  # held back for the order (REORDER_ROWS)
        self.reordered = 0  # messages recorded after a later-stamped one
        self.repeated = 0  # messages recorded twice, dropped
        self.rereads, self.label = True, "ROS bag"  # set by export_bag
        self.last: int | None = None  # the newest stamp written
        self.newest = np.iinfo(np.int64).min  # the newest stamp recorded
        self.late = _Late()  # messages older than it, merged at the end
        self.start = self.held_start = 0  # where the files' rows begin

    def begin(self, plan: _Plan, held: tuple[str, ...]) -> None:
        import csv

        if self.started and self.stream is not None:  # a second pass: again
            self.stream.seek(0)
            self.stream.truncate()
            if self.held_stream is not None:
                self.held_stream.close()
                self.held_stream = None
                os.remove(self.held_out)
        self.started = True
        self.carry, self.reordered, self.repeated = None, 0, 0
        self.last, self.newest = None, np.iinfo(np.int64).min
        self.late.close()
        self.late = _Late()
        self.plan, self.held = plan, held
        self.names = list(self.columns(plan.wanted, plan.efforts))
        if self.stream is None:  # a dry run (class docstring)
            return
        at = {name: k for k, name in enumerate(plan.wanted)}
        self.picks = []
        for column in self.names:
            meant = column_field(column)
            if meant is None or meant[0] not in at:
                raise ValueError(f"no column {column!r}.")
            self.picks.append((meant[1] == "effort", at[meant[0]]))
        csv.writer(self.stream, lineterminator="\n").writerow([self.time, *self.names])
        self.start = self.stream.tell() if self.rereads else 0
        self.scale = _scale(plan.epoch, self.unit)
        if self.held_out is not None and plan.held:
            self.held_stream = open(self.held_out, "w+", encoding="utf-8", newline="")
            header = [*plan.held, *(n for n in plan.wanted if n not in plan.held)]
            self.held_at = [held.index(name) for name in plan.held]
            self.held_scale = _scale(plan.epoch, None)
            names = [self.held_column.format(joint=name) for name in header]
            csv.writer(self.held_stream, lineterminator="\n").writerow(["t", *names])
            self.held_start = self.held_stream.tell()

    def rows(self, block: _Block) -> None:
        """Writes ``block`` in stamp order, holding back its newest messages.

        With those held back from the block before; the newest
        :data:`REORDER_ROWS` wait for the next block (:meth:`end`: the last).
        """
        held = 0 if self.carry is None else self.carry.stamps.size
        fresh = block.received if self.plan.received else block.stamps
        if fresh.size:  # lateness: the newest stamp recorded before it - its own
            ahead = np.maximum.accumulate(np.concatenate([[self.newest], fresh]))
            if self.last is not None and np.any(fresh <= self.last):
                behind = (ahead[:-1] - fresh)[fresh <= self.last]
                self.late.lateness = max(self.late.lateness, int(behind.max()))
            self.newest = int(ahead[-1])
        if self.carry is not None:
            block = _joined(self.carry, block)
        stamps = block.received if self.plan.received else block.stamps
        # A message is late when an earlier one has a later stamp (the held-back
        # messages hold the newest stamps written so far).
        late = stamps[1:] < np.maximum.accumulate(stamps)[:-1]
        # Those not held back (counted before), counted once a repeat is
        # dropped (a late repeat is dropped, not written in stamp order).
        counted = np.concatenate([[False], late])
        counted[:held] = False
        if late.any():
            order = np.argsort(stamps, kind="stable")
            block, counted = _taken(block, order), counted[order]
            stamps = block.received if self.plan.received else block.stamps
        # A message recorded twice (the same stamp and values) is written once.
        repeated = _repeating(stamps, block.position, block.effort)
        if repeated.any():
            self.repeated += int(np.count_nonzero(repeated))
            kept = np.flatnonzero(np.concatenate([[True], ~repeated]))
            block, counted = _taken(block, kept), counted[kept]
            stamps = block.received if self.plan.received else block.stamps
        self.reordered += int(np.count_nonzero(counted))
        if self.last is not None and stamps.size and stamps[0] <= self.last:
            # Older than a message written: more than REORDER_ROWS late, or a
            # repeat of a message written; kept aside, merged in at the end.
            older = int(np.searchsorted(stamps, self.last, side="right"))
            if self.stream is None:
                self.late.count += older
            else:
                self.late.add(*self._text(_taken(block, np.arange(older))))
            block = _taken(block, np.arange(older, stamps.size))
        keep = max(0, block.stamps.size - REORDER_ROWS)
        self.carry = _taken(block, np.arange(keep, block.stamps.size))
        self._write(_taken(block, np.arange(keep)))

    def end(self) -> None:
        """Writes the messages held back (the pass is complete).

        Then merges in the messages older than one written (:class:`_Late`).
        """
        if self.carry is not None:
            self._write(self.carry)
            self.carry = None
        if not self.late.count or self.stream is None:
            return
        if not self.rereads:
            raise ValueError(_unmerged(self.label, self.late))
        repeats = self.late.merge(self.stream, self.start, 0)
        self.repeated += repeats  # not late: counted as reordered and late
        self.reordered = max(0, self.reordered - repeats)
        self.late.count -= repeats
        if self.held_stream is not None:
            self.late.merge(self.held_stream, self.held_start, 1)

    def _text(self, block: _Block) -> tuple[str, str]:
        """The export's rows of ``block`` and those of the held joints' file."""
        main, held = io.StringIO(), io.StringIO()
        stamps = block.received if self.plan.received else block.stamps
        data = None
        if self.picks:
            data = np.column_stack(
                [(block.effort if e else block.position)[:, k] for e, k in self.picks]
            )
        _write_block(main, time_text(stamps, self.scale), data)
        if self.held_stream is not None:
            data = np.column_stack([block.held[:, self.held_at], block.position])
            _write_block(held, time_text(stamps, self.held_scale), data)
        return main.getvalue(), held.getvalue()

    def _write(self, block: _Block) -> None:
        if not block.stamps.size:
            return
        stamps = block.received if self.plan.received else block.stamps
        self.last = int(stamps[-1])
        if self.stream is None:
            return
        main, held = self._text(block)
        self.writing = True
        self.stream.write(main)
        self.writing = False
        _reader_gone(self.stream)
        if self.held_stream is not None:
            self.held_stream.write(held)

    def close(self) -> None:
        self.late.close()
        if self.held_stream is not None:
            self.held_stream.close()
            self.held_stream = None


#: The last line of an export to an output that cannot be taken back (standard
#: output, a pipe) when it stops on an error, followed by the error (its commas
#: as semicolons): one cell, a row that the CSV readers refuse ("row N has 1
#: cells; the header has ...": the export has 2 columns at least).
_INCOMPLETE = f"{INCOMPLETE}it stopped on an error: "


def _reader_gone(stream: Any) -> None:
    """Raises when ``stream``'s reader has gone away (a closed pipe).

    The command line's standard output drops what is written once its pipe is
    closed (``cli._ClosableStream.closed_pipe``: a printout's rule); the export
    is the data, cut there: an error (the incomplete-export line cannot reach
    the closed pipe). A stream of the standard library raises BrokenPipeError
    itself.

    Raises:
        BrokenPipeError: saying so (no errno: named as it is).
    """
    if getattr(stream, "closed_pipe", False):
        raise BrokenPipeError(
            "standard output was closed before the export's end (its reader "
            "stopped reading, e.g. head): what it read is not the whole bag, and "
            "the line saying so cannot reach it; export to a file (--out LOG.csv) "
            "for the whole log."
        )


def _unmerged(label: str, late: _Late) -> str:
    """The error of messages to merge in on an output that cannot be read back."""
    return (
        f"{label}: {late.count} message(s) were recorded more than "
        f"{REORDER_ROWS} messages after a later-stamped one (up to "
        f"{late.lateness * 1e-9:.6g} s late) or repeat one that many messages "
        "before: placing them rewrites the export, which standard output or a "
        "pipe cannot; write it to a file (--out FILE)."
    )


class _Late:
    """Messages older than one already written, merged into the export at its end.

    A message recorded more than :data:`REORDER_ROWS` messages after one with a
    later stamp (or a repeat of a message written) cannot be put in place as
    the blocks are written: its rows (the export's and the held joints' file's)
    are kept aside, :data:`LATE_RUN` at a time in memory, sorted by stamp into
    a temporary file (a run) when that many, :data:`LATE_FAN_IN` runs of a
    level merged into one of the next (a run of LATE_RUN rows: level 0), so
    that the open files stay few (one a run reached the open-file limit, 1024,
    at some 8 M late messages); :meth:`merge` then copies the
    written rows aside and writes them back merged with the runs in stamp order
    (``heapq.merge``: one row of each run in memory, stable: the runs in the
    order recorded, as the merges of a level keep them), dropping a row equal
    to the one before it (a repeat: the same stamp and values). Memory:
    LATE_RUN rows; disk (``TMPDIR``): the late rows and a copy of the export.
    """

    def __init__(self) -> None:
        self.count = 0  # messages kept aside
        self.lateness = 0  # the largest: newest stamp recorded before - theirs [ns]
        self.rows: tuple[list[str], list[str]] = ([], [])
        self.runs: tuple[list[Any], list[Any]] = ([], [])
        self.levels: tuple[list[int], list[int]] = ([], [])  # each run's

    def add(self, main: str, held: str) -> None:
        """Keeps the rows of some late messages (text, one line each)."""
        lines = main.splitlines(keepends=True)
        self.count += len(lines)
        self.rows[0].extend(lines)
        self.rows[1].extend(held.splitlines(keepends=True))
        if len(self.rows[0]) >= LATE_RUN:
            self._spill()

    def _spill(self) -> None:
        import heapq
        import tempfile

        with self._temporary():
            for rows, runs, levels in zip(
                self.rows, self.runs, self.levels, strict=True
            ):
                if not rows:
                    continue
                run = tempfile.TemporaryFile("w+", encoding="utf-8", newline="")
                runs.append(run)
                levels.append(0)
                run.writelines(sorted(rows, key=_stamp_key))
                rows.clear()
                # The last LATE_FAN_IN runs of one level: merged into one of the
                # next (the levels never increase along the list).
                while len(levels) >= LATE_FAN_IN and (
                    len(set(levels[-LATE_FAN_IN:])) == 1
                ):
                    merged = tempfile.TemporaryFile("w+", encoding="utf-8", newline="")
                    tail = runs[-LATE_FAN_IN:]
                    try:
                        for each in tail:
                            each.seek(0)
                        merged.writelines(heapq.merge(*tail, key=_stamp_key))
                    except BaseException:  # a full TMPDIR: closed (deleted) now
                        with contextlib.suppress(OSError):
                            merged.close()
                        raise
                    for each in tail:
                        each.close()
                    level = levels[-1] + 1
                    del runs[-LATE_FAN_IN:], levels[-LATE_FAN_IN:]
                    runs.append(merged)
                    levels.append(level)

    @contextlib.contextmanager
    def _temporary(self) -> Iterator[None]:
        """An error of the temporary files named as theirs (``TMPDIR``).

        ``files.write_whole`` names its own file in an error with an errno (a
        full ``TMPDIR`` was said as the export's ``No space left on device``):
        raised without one, naming the folder.
        """
        try:
            yield
        except OSError as error:
            if error.errno is None:
                raise
            import tempfile

            raise OSError(
                f"temporary files in {tempfile.gettempdir()} (the {self.count} "
                f"message(s) recorded late, merged into the export at its end): "
                f"{error.strerror or error}; set TMPDIR to a folder with room."
            ) from None

    def merge(self, stream: Any, start: int, which: int) -> int:
        """Rewrites ``stream``'s rows from ``start`` merged with the late ones.

        ``which``: 0 the export, 1 the held joints' file. Returns the repeats
        dropped.
        """
        import heapq
        import shutil
        import tempfile

        self._spill()
        repeats = 0
        with self._temporary():
            body = tempfile.TemporaryFile("w+", encoding="utf-8", newline="")
        with body:
            stream.seek(start)
            with self._temporary():
                shutil.copyfileobj(stream, body)
                body.seek(0)
                runs = self.runs[which]
                for run in runs:
                    run.seek(0)
            stream.seek(start)
            stream.truncate()
            previous, out = None, []
            for line in heapq.merge(body, *runs, key=_stamp_key):
                if _same_line(line, previous):
                    repeats += 1
                    continue
                out.append(line)
                previous = line
                if len(out) >= LATE_RUN:
                    stream.write("".join(out))
                    out.clear()
            stream.write("".join(out))
        return repeats

    def close(self) -> None:
        for runs, levels in zip(self.runs, self.levels, strict=True):
            for run in runs:
                run.close()
            runs.clear()
            levels.clear()


def _scan(
    path: str | os.PathLike,
    joints: Sequence[str] | None,
    topic: str | None,
    optional: Sequence[str],
    sink: Any,
    plan: _Plan | None = None,
    *,
    stamps: str = "header",
    span: tuple[float | None, float | None] = (None, None),
    options: Sequence[str] | None = None,
) -> tuple[BagExport, _Plan]:
    """Passes over the bag until the plan holds (:func:`export_bag`).

    ``sink`` None: read only; ``stamps``, ``span``: :func:`read_joint_states`';
    ``options``: :func:`export_bag`'s.
    Returns what the final pass wrote, and the bag's plan.
    """
    if stamps not in STAMPS:
        raise ValueError(f"stamps {stamps!r}: one of {listed(STAMPS)}.")
    path = os.fspath(path)
    storage = _storage(path)
    highlevel = _rosbags()
    given = None if joints is None else tuple(joints)
    try:
        chunks = None
        if path.lower().endswith(".bag"):
            chunks = _Ros1Chunks.open(path)  # None: rosbags' reader
        with chunks or highlevel.AnyReader([storage]) as reader:
            asked = topic
            topic, connections = _topic(path, reader, topic)
            # rosbags' ROS 2 end_time is the last message's receive time + 1 ns
            # (its ROS 1 one and _Ros1Chunks' the last message's own).
            last = reader.end_time - bool(getattr(reader, "is2", False))
            window = _window(path, span, reader.start_time, last)
            passes = 0
            while True:
                passes += 1
                tally, used, chosen = _pass(
                    reader,
                    connections,
                    given,
                    tuple(optional),
                    plan,
                    sink,
                    receive=stamps == "receive",
                    window=window,
                )
                final = _final_plan(
                    path, topic, tally, given, tuple(optional), window.label
                )
                if not tally.kept and chosen == (final.wanted, final.exact):
                    needed = listed(final.wanted)
                    if tally.malformed:
                        raise ValueError(
                            f"ROS bag {path}: {tally.malformed} message(s) on {topic} "
                            f"hold every joint needed ({needed}), but none has one "
                            "value per name[] in position[] and effort[] (an empty "
                            "effort[] is read as no torques): a publisher that "
                            "fills them for some of its joints only."
                        )
                    held = listed(
                        (
                            f"[{listed(sorted(s))}]"
                            for s in sorted(tally.sets, key=lambda s: -tally.sets[s][0])
                        ),
                        LISTED_SETS,
                        "; ",
                    )
                    raise ValueError(
                        f"ROS bag {path}: no message on {topic} holds every joint "
                        f"needed ({needed}); its messages name: {held}."
                    )
                if used == final:
                    if tally.steps.step is not None:
                        raise ValueError(
                            _clock_step(
                                path,
                                topic,
                                tally.steps,
                                final,
                                window,
                                asked,
                                receive=stamps == "receive",
                                options=options,
                            )
                        )
                    break
                if passes >= 4:  # cannot happen: the plan is the bag's by then
                    raise RuntimeError(f"no consistent plan after {passes} passes")
                plan = final
    except (ValueError, OSError):
        raise
    except Exception as error:  # rosbags' own errors, struct.error, KeyError, ...
        raise ValueError(
            f"ROS bag {path}: cannot be read ({type(error).__name__}: {error}); "
            "is it a complete ROS 1 .bag or ROS 2 bag? (a ROS 1 "
            "recording that was killed needs rosbag reindex)"
        ) from None
    done = BagExport(
        path,
        topic,
        final.wanted,
        tally.kept,
        final.efforts,
        _notes(topic, tally, final),
        final.held,
        getattr(sink, "held_out", None) if final.held else None,
        passes,
    )
    return done, final


@dataclass(frozen=True)
class _Entry:
    """What a message with one tuple of names gives (cached per tuple)."""

    key: frozenset[str]
    keep: bool
    width: int  # distinct names: the values a well-formed field has
    at: np.ndarray  # indices of the wanted joints
    held: tuple[tuple[int, int], ...]  # (optional joint's column, index)


def _pass(
    reader: Any,
    connections: Any,
    given: tuple[str, ...] | None,
    optional: tuple[str, ...],
    plan: _Plan | None,
    sink: Any,
    *,
    receive: bool = False,
    window: _Window | None = None,
) -> tuple[_Tally, _Plan | None, tuple[Any, Any]]:
    """One pass over the topic's messages, a block at a time into ``sink``.

    ``plan`` None: judged from the first block (the joints, when not
    ``given``, from the first message). Returns the counts, the plan used
    (None: no message kept) and the joints kept ``(wanted, exact)``.
    ``receive``: the receive times, whatever the header stamps; ``window``:
    only the messages received in it are read (the reader's own filter).
    """
    tally = _Tally(receive=receive)
    wanted, exact = (plan.wanted, plan.exact) if plan else (given, None)
    held: tuple[str, ...] = ()
    if wanted is not None:
        held = tuple(name for name in optional if name not in wanted)
    cache: dict[tuple[str, ...], _Entry] = {}
    stamps: list[int] = []
    received: list[int] = []
    entries: list[_Entry] = []
    positions: list[np.ndarray] = []
    efforts: list[np.ndarray] = []

    def flush() -> None:
        nonlocal plan
        if not stamps:
            return
        assert wanted is not None
        block = _decoded(stamps, received, entries, positions, efforts, wanted, held)
        tally.add(block, held)
        if plan is None:
            plan = tally.plan(wanted, exact, optional)
        tally.steps.add(block.received if plan.received else block.stamps, block)
        if sink is not None:
            if tally.kept == block.stamps.size:
                sink.begin(plan, held)
            sink.rows(block)
        for buffer in (stamps, received, entries, positions, efforts):
            buffer.clear()

    start, stop = (None, None) if window is None else (window.start, window.until)
    for c, time, data in reader.messages(
        connections=connections, start=start, stop=stop
    ):
        message = reader.deserialize(data, c.msgtype)
        tally.total += 1
        names = tuple(message.name)
        entry = cache.get(names)
        if entry is None:
            if wanted is None:  # the first message's set of names
                wanted, exact = names, frozenset(names)
                held = tuple(name for name in optional if name not in wanted)
            entry = cache[names] = _entry(names, wanted, exact, held)
            counted = tally.sets.setdefault(entry.key, [0, names, 0])
        else:
            counted = tally.sets[entry.key]
        counted[0] += 1
        # One value per name[] (else the message is malformed, skipped).
        formed = len(message.position) == entry.width and len(message.effort) in (
            0,
            entry.width,
        )
        counted[2] += formed
        if not entry.keep:
            continue
        if not formed:
            tally.malformed += 1
            continue
        p = np.asarray(message.position, dtype=float)
        e = np.asarray(message.effort, dtype=float)
        stamp = message.header.stamp
        stamps.append(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec))
        received.append(int(time))
        entries.append(entry)
        positions.append(p)
        efforts.append(e)
        if len(stamps) >= EXPORT_ROWS:
            flush()
    flush()
    tally.steps.finish()
    if sink is not None and tally.kept:
        sink.end()
    return tally, plan, (wanted, exact)


def _entry(
    names: tuple[str, ...],
    wanted: tuple[str, ...],
    exact: frozenset[str] | None,
    held: tuple[str, ...],
) -> _Entry:
    """The :class:`_Entry` of a message naming ``names``."""
    index = {name: k for k, name in enumerate(names)}
    key = frozenset(index)
    keep = key == exact if exact is not None else all(n in index for n in wanted)
    at = np.array([index[n] for n in wanted] if keep else [], dtype=np.intp)
    found = tuple((j, index[n]) for j, n in enumerate(held) if n in index)
    return _Entry(key, keep, len(index), at, found)


def _decoded(
    stamps: list[int],
    received: list[int],
    entries: list[_Entry],
    positions: list[np.ndarray],
    efforts: list[np.ndarray],
    wanted: tuple[str, ...],
    held: tuple[str, ...],
) -> _Block:
    """A block's arrays: the messages of one tuple of names gathered at once."""
    count, n = len(stamps), len(wanted)
    position = np.empty((count, n))
    effort = np.full((count, n), np.nan)
    values = np.full((count, len(held)), np.nan)
    groups: dict[int, list[int]] = {}
    empty = count
    for k, entry in enumerate(entries):
        groups.setdefault(id(entry), []).append(k)
    for rows in groups.values():
        entry = entries[rows[0]]
        p = np.stack([positions[k] for k in rows])
        position[rows] = p[:, entry.at]
        for j, k in entry.held:
            values[rows, j] = p[:, k]
        full = [k for k in rows if efforts[k].size]
        empty -= len(full)
        if full:
            effort[full] = np.stack([efforts[k] for k in full])[:, entry.at]
    return _Block(
        np.array(stamps, dtype=np.int64),
        np.array(received, dtype=np.int64),
        position,
        effort,
        values,
        empty,
    )


def _repeating(
    stamps: np.ndarray, position: np.ndarray, effort: np.ndarray
) -> np.ndarray:
    """(n - 1,): each message after the first repeats the one before it.

    The same time, positions and efforts (:func:`_same_rows`): the message
    recorded twice, which the export (and ``read_joint_states``) writes once.
    """
    return (stamps[1:] == stamps[:-1]) & _same_rows(position) & _same_rows(effort)


#: Values of two messages of one stamp within this relative difference are
#: the same message sent again (:func:`_same_rows`): a driver that recomputes
#: what it re-sends (a unit conversion) differs by a few ulps (1e-16 to 1e-15
#: relative), two readings by a sensor's resolution at least (a 24-bit
#: encoder's 2 pi / 2**24 = 3.7e-7 rad: 3.7e-7 relative to 1 rad, more for a
#: smaller angle), 370 times this; a re-send within it was named a clock set
#: back, or two rows of one stamp.
REPEAT_RTOL = 1e-9


def _same_rows(values: np.ndarray) -> np.ndarray:
    """(B - 1,) whether each row repeats the one before.

    Each value equal to the one before, or within :data:`REPEAT_RTOL` of it
    (``|a - b| <= REPEAT_RTOL * max(|a|, |b|)``), NaN equal to NaN.
    """
    a, b = values[1:], values[:-1]
    with np.errstate(invalid="ignore"):
        near = np.abs(a - b) <= REPEAT_RTOL * np.maximum(np.abs(a), np.abs(b))
    return np.all((a == b) | near | (np.isnan(a) & np.isnan(b)), axis=1)


def _same_line(line: str, previous: str | None) -> bool:
    """Whether an export row repeats the one before (:func:`_same_rows`).

    The same time cell and values; the values are read only when the time
    cells are the same.
    """
    if line == previous:
        return True
    if previous is None:
        return False
    time, _, cells = line.partition(",")
    time_before, _, cells_before = previous.partition(",")
    if time != time_before or cells.count(",") != cells_before.count(","):
        return False
    if not cells.strip():
        return not cells_before.strip()
    rows = np.array(
        [[float(c) for c in text.split(",")] for text in (cells_before, cells)]
    )
    return bool(_same_rows(rows)[0])


def _taken(block: _Block, rows: np.ndarray) -> _Block:
    """The messages ``rows`` of a block (its ``empty`` count is not kept)."""
    return _Block(
        block.stamps[rows],
        block.received[rows],
        block.position[rows],
        block.effort[rows],
        block.held[rows],
        0,
    )


def _joined(first: _Block, second: _Block) -> _Block:
    """Two blocks' messages, in that order."""
    return _Block(
        np.concatenate([first.stamps, second.stamps]),
        np.concatenate([first.received, second.received]),
        np.concatenate([first.position, second.position]),
        np.concatenate([first.effort, second.effort]),
        np.concatenate([first.held, second.held]),
        first.empty + second.empty,
    )


def _final_plan(
    path: str,
    topic: str,
    tally: _Tally,
    given: tuple[str, ...] | None,
    optional: tuple[str, ...],
    label: str = "",
) -> _Plan:
    """The bag's plan from a pass's counts; the errors of an unusable topic.

    ``label``: the bag time range read (:class:`_Window`), named in the error.
    """
    if not tally.total:
        raise ValueError(f"ROS bag {path}: topic {topic} holds no message{label}.")
    if given is None:
        # The most frequent set of well-formed messages (then of any).
        chosen = max(
            tally.sets, key=lambda key: (tally.sets[key][2], tally.sets[key][0])
        )
        wanted, exact = tuple(tally.sets[chosen][1]), chosen
        if not wanted:
            raise ValueError(f"ROS bag {path}: topic {topic}'s messages name no joint.")
    else:
        wanted, exact = given, None
    plan = tally.plan(wanted, exact, optional)
    return plan


def _notes(topic: str, tally: _Tally, plan: _Plan) -> tuple[str, ...]:
    """The notes of the final pass (module docstring)."""
    wanted, kept = plan.wanted, tally.kept
    notes = []
    lacking = tally.total - kept - tally.malformed
    if lacking:
        others = sorted({name for s in tally.sets for name in s} - set(wanted))
        extra = f" (their joints: {listed(others)})" if others else ""
        notes.append(
            f"skipped {lacking} of {tally.total} message(s) on {topic} that lack "
            f"joint(s) of {listed(wanted)}{extra}: another publisher on the topic."
        )
    if tally.malformed:
        notes.append(
            f"skipped {tally.malformed} message(s) on {topic} whose position[] or "
            "effort[] does not have one value per name[]."
        )
    if plan.received and not tally.receive:
        notes.append(
            f"every header.stamp on {topic} is 0: the bag's receive times are used."
        )
    if plan.efforts and tally.empty_effort:
        notes.append(
            f"{tally.empty_effort} message(s) on {topic} have an empty effort[]: "
            "their torques are empty cells."
        )
    return tuple(notes)


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
    stamps = np.asarray(stamps, dtype=np.int64)
    return _scale(bool(stamps.size and stamps.min() >= _EPOCH_NS), unit)


def _scale(epoch: bool, unit: str | None) -> float | None:
    """:func:`time_scale` of stamps that are all epoch times or not."""
    from drake_dynid.core.drive_log import TIME_UNITS

    if unit == "ns" or (unit is None and epoch):
        return None
    return 1e-9 / TIME_UNITS[unit or "s"]


def time_text(stamps: np.ndarray, scale: float | None) -> list[str]:
    """The time column's cells of ``stamps`` [ns] (``scale``: :func:`time_scale`)."""
    stamps = np.asarray(stamps, dtype=np.int64)
    if scale is None:
        return [str(int(x)) for x in stamps]
    return [f"{x:.17g}" for x in stamps * scale]


#: Messages decoded and written at a time (:func:`export_bag`, :func:`write_export`;
#: their memory: a block's decoded arrays and text, some 10 MB).
EXPORT_ROWS = 1 << 14

#: Messages held back by :func:`export_bag` to put messages recorded out of
#: header-stamp order back in order (a transport's reordering spans a few
#: messages); one later than this many is merged in at the end (:class:`_Late`).
REORDER_ROWS = 1 << 12

#: Rows of messages later than that kept in memory before they are sorted
#: into a temporary file (:class:`_Late`).
LATE_RUN = 1 << 14

#: Sorted runs of one level merged into one run of the next (:class:`_Late`):
#: at most ``LATE_FAN_IN - 1`` temporary files a level, each level's runs
#: ``LATE_FAN_IN`` times longer (10^9 late messages: 61 036 runs of LATE_RUN,
#: 4 levels, at most 60 files, as many again for the held joints' file; one a
#: run before, the open-file limit, 1024, at some 8 M), each row copied once a
#: level.
LATE_FAN_IN = 16


def _stamp_key(row: str) -> int | float:
    """The sort key of an export row: its time cell, as a number.

    An integer (nanoseconds, exact) or a float (:func:`time_scale`); Python
    compares the two exactly.
    """
    cell = row.split(",", 1)[0]
    try:
        return int(cell)
    except ValueError:
        return float(cell)


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
            block = None if data is None else data[rows]
            _write_block(stream, time_text(stamps[rows], scale), block)

    write_whole(path, write)


def _write_block(stream: Any, cells: list[str], data: np.ndarray | None) -> None:
    """CSV rows: each time cell, then its row of ``data`` (17 digits)."""
    if data is None:
        stream.write("".join(f"{s}\n" for s in cells))
        return
    body = io.StringIO()
    np.savetxt(body, data, delimiter=",", fmt="%.17g")
    lines = body.getvalue().splitlines()
    stream.write("".join(f"{s},{line}\n" for s, line in zip(cells, lines, strict=True)))


# ------------------------------------------------------------------ ROS 1 chunks
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<II")


@dataclass(frozen=True)
class _Connection:
    """A ROS 1 bag's connection record (as rosbags' ``Connection`` names them)."""

    id: int
    topic: str
    msgtype: str
    msgdef: str
    digest: str


class BagFormatError(Exception):
    """A ROS 1 bag's record that cannot be read (named with the bag by ``_scan``)."""


def _fields(data: Any, pos: int) -> tuple[dict[str, bytes], int]:
    """A record header's ``name=value`` fields at ``pos``, and where it ends."""
    (size,) = _U32.unpack_from(data, pos)
    pos, end = pos + 4, pos + 4 + size
    fields = {}
    while pos < end:
        (length,) = _U32.unpack_from(data, pos)
        name, _, value = bytes(data[pos + 4 : pos + 4 + length]).partition(b"=")
        fields[name.decode("latin-1")] = value  # ASCII names; never fails
        pos += 4 + length
    if pos != end:
        raise BagFormatError("a record header overruns its length")
    return fields, end


def _read_record(stream: Any) -> tuple[dict[str, bytes], bytes]:
    """The file's next record: its header fields and its data."""
    (size,) = _U32.unpack(stream.read(4))
    header = _U32.pack(size) + stream.read(size)
    fields, _ = _fields(header, 0)
    (size,) = _U32.unpack(stream.read(4))
    data = stream.read(size)
    if len(data) != size:
        raise BagFormatError("a record is cut short")
    return fields, data


#: Chunks of a ROS 1 bag whose receive times may overlap at one instant, at most,
#: for :class:`_Ros1Chunks` (held decompressed together; more: rosbags' reader).
ROS1_OVERLAP = 8


class _Ros1Chunks:
    """A ROS 1 bag read a chunk at a time (bounded memory), in rosbags' order.

    rosbags' ROS 1 reader indexes every message when it opens a bag (about
    350 B a message: 486 MB on 1 M messages). This reads the ROS bag 2.0
    format's records itself: the bag
    header, the connection and chunk-info records at its index position, then
    the chunks by start time, each decompressed whole (none, bz2, lz4), their
    messages merged in rosbags' order (receive time, then the connection's
    rank, the chunk's place in the file and the message's in the chunk); a
    chunk is read once the merge reaches its start time, so only the chunks
    whose receive times overlap are held together (a recording's: one or two).
    rosbags' typestore deserializes the messages from the connections'
    definitions (as its ``AnyReader``). :meth:`open` returns None where
    rosbags' reader is to decide (its errors: no index, encryption, a record
    it would refuse, as a chunk-info record that is not of version 1, a
    definition that does not match its md5), or where more
    than :data:`ROS1_OVERLAP` chunks overlap at one instant.
    """

    def __init__(
        self,
        stream: Any,
        connections: list[_Connection],
        chunks: list[tuple[int, int, int, int]],
    ) -> None:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.stream, self.connections = stream, connections
        self.chunks = chunks  # (start time [ns], position, place in the file, end)
        self.typestore = get_typestore(Stores.EMPTY)
        states = [c for c in connections if c.msgtype == JOINT_STATE]
        for c in states:
            self.typestore.register(get_types_from_msg(c.msgdef, c.msgtype))
        for c in states:
            if self.typestore.generate_msgdef(c.msgtype)[1] != c.digest:
                raise ValueError("a message definition does not match its md5")

    @classmethod
    def open(cls, path: str) -> _Ros1Chunks | None:
        """The bag, or None where rosbags' reader is to read it (class docstring)."""
        import contextlib

        stream = open(path, "rb")
        try:
            if stream.readline() != b"#ROSBAG V2.0\n":
                raise ValueError("no ROS bag 2.0")
            fields, _ = _read_record(stream)
            (index,) = struct.unpack("<Q", fields["index_pos"])
            if not index or fields.get("encryptor"):
                raise ValueError("not indexed, or encrypted")
            (count,) = _U32.unpack(fields["conn_count"])
            (chunks,) = _U32.unpack(fields["chunk_count"])
            stream.seek(index)
            connections = []
            for _ in range(count):
                fields, data = _read_record(stream)
                about, _ = _fields(_U32.pack(len(data)) + data, 0)  # fields only
                kind = about["type"].decode()
                topic = fields["topic"].decode()
                connections.append(
                    _Connection(
                        _U32.unpack(fields["conn"])[0],
                        ("/" if topic.startswith("/") else "")
                        + "/".join(x for x in topic.split("/") if x),
                        kind if "/msg/" in kind else kind.replace("/", "/msg/", 1),
                        about["message_definition"].decode(),
                        about["md5sum"].decode(),
                    )
                )
            infos, events = [], []
            for _ in range(chunks):
                fields, _ = _read_record(stream)
                # CHUNK_INFO (op 0x06) version 1, the only one the format has.
                if fields.get("op") != b"\x06" or fields.get("ver") != _U32.pack(1):
                    raise ValueError("not a CHUNK_INFO record of version 1")
                (position,) = struct.unpack("<Q", fields["chunk_pos"])
                start, end = _time(fields["start_time"]), _time(fields["end_time"])
                infos.append((start, position, end))
                events += [(start, 0), (end, 1)]  # at one time: starts first
            depth = held = 0
            for _, kind_ in sorted(events):
                held += 1 if kind_ == 0 else -1
                depth = max(depth, held)
            if depth > ROS1_OVERLAP:
                raise ValueError("too many chunks overlap in time")
            places = {p: k for k, p in enumerate(sorted(p for _, p, _ in infos))}
            ordered = sorted((start, p, places[p], end) for start, p, end in infos)
            return cls(stream, connections, ordered)
        except Exception:  # rosbags' reader reads it, or names the problem
            with contextlib.suppress(OSError):
                stream.close()
            return None

    def __enter__(self) -> _Ros1Chunks:
        return self

    def __exit__(self, *args: object) -> None:
        self.stream.close()

    @property
    def start_time(self) -> int:
        """The first message's receive time [ns] (rosbags' ``start_time``)."""
        return min((c[0] for c in self.chunks), default=2**63 - 1)

    @property
    def end_time(self) -> int:
        """The last message's receive time [ns] (rosbags' ``end_time``)."""
        return max((c[3] for c in self.chunks), default=0)

    def messages(
        self,
        connections: Sequence[_Connection],
        start: int | None = None,
        stop: int | None = None,
    ) -> Any:
        """``(connection, receive time [ns], data)`` in rosbags' order.

        Only those received at or after ``start`` and before ``stop`` [ns]
        (rosbags' ``messages``): a chunk that ends before ``start`` or begins
        at or after ``stop`` is not read.
        """
        import heapq

        rank = {c.id: (k, c) for k, c in enumerate(connections)}
        heap: list[tuple[int, int, int, int, Any, bytes, int]] = []
        chunks = iter(
            c
            for c in self.chunks
            if (start is None or c[3] >= start) and (stop is None or c[0] < stop)
        )
        waiting = next(chunks, None)
        while heap or waiting is not None:
            # Every chunk starting at or before the earliest message held.
            while waiting is not None and (not heap or waiting[0] <= heap[0][0]):
                for item in self._chunk(waiting[1], waiting[2], rank):
                    if start is None or item[0] >= start:
                        heapq.heappush(heap, item)
                waiting = next(chunks, None)
            if heap:
                time, _, _, end, c, data, begin = heapq.heappop(heap)
                if stop is not None and time >= stop:
                    return  # the rest are later still
                yield c, time, data[begin:end]  # the chunk's bytes: held till then

    def _chunk(self, position: int, place: int, rank: dict[int, Any]) -> Any:
        """The messages of the chunk at ``position``, as ``messages``' heap keys."""
        import bz2

        import lz4.frame  # type: ignore[import-untyped]  # rosbags needs it

        self.stream.seek(position)
        fields, data = _read_record(self.stream)
        compression = fields["compression"]
        try:
            if compression == b"bz2":
                data = bz2.decompress(data)
            elif compression == b"lz4":
                data = lz4.frame.decompress(data)
        except Exception as error:  # bz2: OSError, ValueError; lz4: RuntimeError
            raise BagFormatError(
                f"the {compression.decode()} chunk at byte {position} cannot be "
                f"decompressed ({error})"
            ) from None
        if compression not in (b"bz2", b"lz4", b"none"):
            raise BagFormatError(f"compression {compression.decode()!r} unknown")
        pos = 0
        while pos < len(data):
            header, pos = _fields(data, pos)
            (size,) = _U32.unpack_from(data, pos)
            pos += 4 + size
            if header["op"] == b"\x02":
                found = rank.get(_U32.unpack(header["conn"])[0])
                if found is not None:
                    time = _time(header["time"])
                    yield time, found[0], place, pos, found[1], data, pos - size

    def deserialize(self, data: bytes, msgtype: str) -> Any:
        """The message (rosbags' typestore)."""
        return self.typestore.deserialize_ros1(data, msgtype)


def _time(value: bytes) -> int:
    """A ROS 1 time field (two uint32: s, ns) in ns."""
    sec, ns = _TIME.unpack(value)
    return sec * 1_000_000_000 + ns
