"""Options and inputs shared by several ``dynid`` subcommands (not a subcommand)."""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Mapping, Sequence
from typing import Any

from drake_dynid.core._validate import listed


class LogFiles(argparse.Action):
    """``LOG [LOG ...]``: stores the list in ``<dest>_files`` and a label in ``dest``.

    The label (the file, or the files joined by `` + ``) names the log in messages
    and outputs; the list is what the readers open.
    """

    def __call__(self, parser, namespace, values, option_string=None):
        files = [values] if isinstance(values, str) else list(values)
        setattr(namespace, f"{self.dest}_files", files)
        setattr(namespace, self.dest, " + ".join(files))


def log_files(args: argparse.Namespace, name: str = "log") -> list[str]:
    """The files of the ``LOG`` positional (or of ``--validate`` with ``name``)."""
    files = getattr(args, f"{name}_files", None)
    if files is not None:
        return list(files)
    value = getattr(args, name, None)
    return [value] if value else []


def add_drive_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds ``--drive`` (drive file) and ``--rotor-inertia``."""
    parser.add_argument(
        "--drive",
        metavar=DRIVE_METAVAR,
        type=drive_argument,
        help="drive file (docs/DRIVE.md; or a packaged one's name: tiago): log "
        "column names and units, motor-side "
        "positions, currents and torque constants, zero offsets, gear ratios and "
        "coupled joints; it overrides the URDF's <transmission> elements; coupled "
        "motors get their own friction (and, with --rotor-inertia, inertia) "
        "parameters",
    )
    parser.add_argument(
        "--rotor-inertia",
        action="store_true",
        help="add the rotor inertia columns: IAj per joint (a-priori value: the "
        "drive file's rotor_inertia x gear ratio squared, else the URDF's "
        "actuators) and IAmk per coupled motor",
    )


def add_dead_zone_argument(
    parser: argparse.ArgumentParser, default: Any, default_help: str = ""
) -> None:
    """Adds ``--dead-zone`` (the Coulomb columns at standstill)."""
    if not default_help and default == "auto":
        default_help = " (default: auto)"
    parser.add_argument(
        "--dead-zone",
        default=default,
        metavar="auto|none|W",
        help="Coulomb columns at standstill: s(v) = 0 for |v| <= w, else sign(v). "
        "auto: w_j = 3 x the velocity noise measured on the log, per joint "
        "(docs/MATH.md section 2); none: the exact sign(v) (the paper's model); W: "
        "one width for every joint [rad/s or m/s]" + default_help,
    )


def parse_dead_zone(text: str | None) -> Any:
    """``"auto"`` -> ``"auto"``; ``"none"`` -> None; ``"0.01"`` -> 0.01 [rad/s].

    Raises:
        ValueError: anything else, or a negative or non-finite width.
    """
    if text is None:
        return None
    value = text.strip().lower()
    if value in ("auto", "none"):
        return None if value == "none" else "auto"
    try:
        width = float(value)
    except ValueError:
        width = math.nan
    if not math.isfinite(width) or width < 0.0:
        raise ValueError(
            "--dead-zone must be auto, none or a width >= 0 [rad/s or m/s]; got "
            f"{text!r}."
        )
    return width


def add_friction_argument(
    parser: argparse.ArgumentParser,
    from_results: bool = False,
    simulated: float | None = None,
) -> None:
    """Adds ``--friction`` (the friction columns) and ``--coulomb-width`` (its law).

    ``from_results``: the default is None, the columns of a ``--params`` results
    file (``dynid payload``), else viscous,coulomb. ``simulated``: the default
    width of a simulation's Coulomb law tanh(v/W), which must be > 0 (``dynid
    simulate``); None: a model's law, 0 (sign(v)) by default.
    """
    parser.add_argument(
        "--friction",
        default=None if from_results else "viscous,coulomb",
        help=(
            "comma-separated friction columns per joint among viscous, coulomb, "
            "offset, or 'none' (default: "
            + ("those of --params, else " if from_results else "")
            + "viscous,coulomb)"
        ),
    )
    if simulated is not None:
        parser.add_argument(
            "--coulomb-width",
            type=float,
            default=simulated,
            metavar="W",
            help=(
                "the simulated Coulomb friction FC tanh(v/W), W > 0 in rad/s (or "
                f"m/s) (default {simulated:g}); dynid offline/identify "
                "--coulomb-width W model the same law"
            ),
        )
        return
    parser.add_argument(
        "--coulomb-width",
        type=float,
        default=0.0,
        metavar="W",
        help=(
            "smooth Coulomb friction: the Coulomb column is tanh(v/W) instead of "
            "sign(v), W in rad/s (or m/s); 0 (default): sign(v)"
        ),
    )


def parse_friction(text: str) -> tuple[str, ...]:
    """``"viscous,coulomb"`` -> ``("viscous", "coulomb")``; ``"none"`` -> ``()``.

    Raises:
        ValueError: an empty text or item (``""``, ``",,"``, ``"viscous,"``): a
            typo or an unset shell variable must not silently mean fewer (or the
            default) friction columns; no friction is ``none``.
    """
    if text.strip().lower() == "none":
        return ()
    if not text.strip():
        raise ValueError(
            "--friction must be comma-separated names among viscous, coulomb, "
            "offset, or 'none'; got an empty text (no friction: --friction none)."
        )
    items = tuple(item.strip() for item in text.split(","))
    if not all(items):
        raise ValueError(
            "--friction must be comma-separated names among viscous, coulomb, "
            f"offset, or 'none'; got {text!r} (an empty name)."
        )
    return items


def add_joint_arguments(
    parser: argparse.ArgumentParser,
    verb: str = "identify",
    participle: str = "identified",
) -> None:
    """Adds ``--joints`` (the identified joints) and ``--lock`` (locked positions).

    ``verb``, ``participle``: what the command does with the chosen joints (help).
    """
    parser.add_argument(
        "--joints",
        metavar="A,B,...",
        help=(
            f"comma-separated joints to {verb} (default: every movable joint that "
            "is not a mimic joint); every other movable joint is locked, at 0 "
            "unless --lock gives its position; mimic joints follow their leader"
        ),
    )
    parser.add_argument(
        "--lock",
        metavar="NAME=VALUE,...",
        help=(
            "positions [rad or m] of locked joints, e.g. head_1_joint=0.2,"
            f"head_2_joint=-0.1; without --joints, the joints not locked are "
            f"{participle}"
        ),
    )


def parse_joints(text: str | None) -> tuple[str, ...] | None:
    """``"a, b"`` -> ``("a", "b")``; None (not given) -> None (every joint).

    Raises:
        ValueError: an empty name (``"a,,b"``), or a blank ``--joints`` (``--joints
            "$J"`` with J unset meant every joint, silently).
    """
    if text is None:
        return None
    if not text.strip():
        raise ValueError(
            "--joints is empty (an unset shell variable?): give the joints, "
            "comma-separated, or leave --joints out for every movable joint."
        )
    names = tuple(item.strip() for item in text.split(","))
    if any(not name for name in names):
        where = "a trailing comma" if not names[-1] else "two commas in a row"
        if not names[0]:
            where = "a leading comma"
        raise ValueError(
            f"--joints must be comma-separated joint names; got {text!r}, with an "
            f"empty name ({where})."
        )
    return names


def parse_locked(text: str | None) -> dict[str, float]:
    """``"a=0.2,b=-1"`` -> ``{"a": 0.2, "b": -1.0}`` [rad or m]; None -> ``{}``.

    Raises:
        ValueError: a blank ``--lock`` (``--lock "$L"`` with L unset locked every
            joint at 0, silently), an item without ``=``, an empty name, a value
            that is not a finite number, or a joint given twice.
    """
    out: dict[str, float] = {}
    if text is None:
        return out
    if not text.strip():
        raise ValueError(
            "--lock is empty (an unset shell variable?): give NAME=VALUE pairs, or "
            "leave --lock out to lock the joints not chosen at 0."
        )
    for item in text.split(","):
        name, sep, value = item.partition("=")
        name = name.strip()
        try:
            position = float(value)
        except ValueError:
            position = math.nan
        if not sep or not name or not math.isfinite(position):
            raise ValueError(
                "--lock must be NAME=VALUE pairs with finite values [rad or m] "
                f"separated by commas; got {item.strip()!r}."
            )
        if name in out:
            raise ValueError(f"--lock gives joint {name!r} twice.")
        out[name] = position
    return out


def robot_from_args(args: argparse.Namespace, command: str, **kwargs: Any) -> Any:
    """Builds the ``RobotModel`` of ``args`` and prints its notes on stderr.

    Reads ``args.urdf``, ``args.friction``, ``args.coulomb_width``, ``args.joints``
    and ``args.lock`` (each optional on ``args``; see :func:`add_friction_argument` and
    :func:`add_joint_arguments`) and ``args.rotor_inertia`` when present. Each note
    of the load (joints treated as actuated, Drake's parser warnings summarised,
    an unclear rank decision) is one line ``dynid COMMAND: note: ...`` on stderr.

    Args:
        args: the parsed arguments.
        command: the subcommand name, for the notes.
        **kwargs: further ``RobotModel.from_urdf`` arguments (they win over
            ``args``).

    Raises:
        ValueError: bad ``--joints``/``--lock`` syntax, or the model's errors (an
            unknown joint names the available ones).
    """
    from drake_dynid.robot import RobotModel

    options: dict[str, Any] = {
        "friction": parse_friction(
            "viscous,coulomb"
            if getattr(args, "friction", None) is None
            else args.friction
        ),
        "joints": parse_joints(getattr(args, "joints", None)),
        "locked": parse_locked(getattr(args, "lock", None)),
        "coulomb_width": getattr(args, "coulomb_width", 0.0),
    }
    if hasattr(args, "rotor_inertia"):
        options["rotor_inertia"] = bool(args.rotor_inertia)
    if getattr(args, "drive", None):
        options["drive"] = args.drive
    options.update(kwargs)
    try:
        robot = RobotModel.from_urdf(args.urdf, **options)
    except ValueError as error:  # the model's checks, in the command's options
        from drake_dynid.commands._options import option_message

        names = {"coulomb_width": "--coulomb-width"}
        message = option_message(str(error), names, ("RobotModel",))
        raise ValueError(message + _fixed_hint(args.urdf, message)) from None
    for note in robot.notes:
        print(f"dynid {command}: note: {note}", file=sys.stderr)
    for line in _locks_beyond_limits(robot, options.get("locked") or {}):
        print(f"dynid {command}: warning: {line}", file=sys.stderr)
    return robot


def _fixed_hint(urdf: Any, message: str) -> str:
    """A hint when a locked joint is fixed in the URDF (one --urdf-out wrote)."""
    import re

    from drake_dynid.urdf import read_urdf_joint_types

    found = re.search(r"locked joint '([^']+)' is not a movable joint", message)
    if not found:
        return ""
    try:
        kind = read_urdf_joint_types(urdf).get(found.group(1))
    except (OSError, ValueError):
        return ""
    if kind != "fixed":
        return ""
    return (
        f" It is a fixed joint of {urdf} (a URDF written by --urdf-out fixes the "
        "joints locked in the fit): leave it out of --lock."
    )


def _locks_beyond_limits(robot: Any, locked: Mapping[str, float]) -> list[str]:
    """A locked position outside its joint's URDF limits (a typo, or degrees)."""
    out = []
    plant = robot.plant
    for name, value in locked.items():
        if not plant.HasJointNamed(name):
            continue
        joint = plant.GetJointByName(name)
        if joint.num_positions() != 1:
            continue
        low = float(joint.position_lower_limits()[0])
        high = float(joint.position_upper_limits()[0])
        if not low <= value <= high:
            unit = "m" if joint.type_name() == "prismatic" else "rad"
            out.append(
                f"--lock {name}={value:g} is outside its URDF limits [{low:g}, "
                f"{high:g}] {unit}: the model holds it there."
            )
    return out


def add_log_argument(parser: argparse.ArgumentParser) -> None:
    """Adds the ``LOG`` positional: one CSV file or several joined on time."""
    parser.add_argument(
        "log",
        nargs="+",
        action=LogFiles,
        metavar="LOG.csv",
        help="the robot log (CSV); several files (e.g. positions and efforts "
        "recorded apart) are joined on their time column: the other files are "
        "interpolated onto the first file's time stamps over the common span. Or "
        "a ROS bag of sensor_msgs/JointState (a ROS 1 .bag; a ROS 2 bag folder, "
        "or its .db3/.mcap file), given alone",
    )
    parser.add_argument(
        "--topic",
        metavar="NAME",
        help="the sensor_msgs/JointState topic of a ROS bag log (default: the "
        "bag's one topic of that type; refused when no log is a bag)",
    )


def check_topic(args: argparse.Namespace, logs: Sequence[str] | None = None) -> None:
    """``--topic`` names a bag's topic: refused when no log of the command is a bag.

    The logs: ``LOG`` and ``--validate``'s files (``logs``: a fleet's). A topic
    given with CSV logs only was ignored, so a bag's fit could be validated on
    a CSV file by mistake, without a word.

    Raises:
        ValueError: naming the option and the logs.
    """
    from drake_dynid.ros_bag import is_bag

    topic = getattr(args, "topic", None)
    if topic is None:
        return
    if logs is None:
        logs = [*log_files(args), *log_files(args, "validate")]
    if not any(is_bag(path) for path in logs):
        raise ValueError(
            f"--topic {topic}: no log is a ROS bag ({listed(logs)}); a CSV log "
            "has no topic: leave the option out, or give the bag."
        )


def urdf_argument(text: str) -> str:
    """A URDF option (argparse type): a file, or the name of a packaged model.

    ``iiwa7``, ``ur5``, ``planar_2r``, ... (``drake_dynid/models``) when no file of
    that name exists, so an installed package's robots need no path.
    """
    return _packaged(text, ".urdf")


def short_packaged(path: Any, suffix: str = ".urdf") -> str:
    """The name a user types for ``path``: a packaged file's bare name, else ``path``.

    ``drake_dynid/models/iiwa7.urdf`` -> ``iiwa7`` when that name, given again,
    still means the packaged file (:func:`_packaged`); for the command lines the
    commands suggest (``dynid simulate``'s "score it with").
    """
    from pathlib import Path

    text = str(path)
    name = Path(text).name
    if not name.lower().endswith(suffix):
        return text
    stem = name[: -len(suffix)]
    if stem and _packaged(stem, suffix) == text:
        return stem
    return text


def _packaged(text: str, suffix: str) -> str:
    """``text``, or ``drake_dynid/models/<text><suffix>`` when that is meant.

    The packaged file when ``text`` is a bare name (no folder, not ending in
    ``suffix``) that names no file here and a packaged file of that name exists.
    A folder of that name is no such file: the packaged one is meant.
    """
    import os

    from drake_dynid.urdf import MODELS_DIR

    if os.sep in text or text.lower().endswith(suffix) or os.path.isfile(text):
        return text
    packaged = MODELS_DIR / f"{text}{suffix}"
    return str(packaged) if packaged.is_file() else text


URDF_HELP = "the robot's URDF file, or the name of a packaged model (iiwa7, ur5, ...)"


def drive_argument(text: str) -> str:
    """A ``--drive`` option (argparse type): a file, or a packaged drive file's name.

    ``tiago`` is ``drake_dynid/models/tiago.toml`` when no file of that name
    exists (as :func:`urdf_argument` for the URDFs), so the shipped TIAGo's drive
    file needs no path from another folder.

    Raises:
        argparse.ArgumentTypeError: a blank text (``--drive "$D"`` with D unset
            meant no drive file, silently; with ``--params`` the results file's).
    """
    if not text.strip():
        raise argparse.ArgumentTypeError(
            "empty (an unset shell variable?): give the drive file or a packaged "
            "one's name, or leave --drive out."
        )
    return _packaged(text, ".toml")


DRIVE_METAVAR = "FILE.toml"


def fill_gaps_count(text: str) -> int:
    """``--fill-gaps N``: an integer >= 0 (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be a whole number of samples >= 0; got {text!r}"
        ) from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0; got {value}")
    return value


def add_fill_gaps_argument(parser: argparse.ArgumentParser) -> None:
    """``--fill-gaps N``: the reader's longest interpolated run (``read_log``)."""
    from drake_dynid.log_repair import FILL_GAPS

    parser.add_argument(
        "--fill-gaps",
        type=fill_gaps_count,
        default=FILL_GAPS,
        metavar="N",
        help="longest run of missing samples or bad cells interpolated "
        f"(default {FILL_GAPS}; a gap of a file joined onto the first one counts "
        "in that file's own samples); longer runs are kept as bad samples, which the "
        "windows holding them skip. 0: never interpolate (a log with more than 5 "
        "%% of its samples to fill is refused unless this is lowered)",
    )


def add_time_unit_argument(parser: argparse.ArgumentParser) -> None:
    """``--time-unit``: the unit of the log's time column (``[log] time_unit``)."""
    from drake_dynid.core.drive_log import TIME_UNITS

    parser.add_argument(
        "--time-unit",
        choices=tuple(TIME_UNITS),
        default=None,
        help="unit of the log's time column (default s, and then integer stamps "
        ">= 1e17 are read as nanoseconds since the epoch); a drive file's [log] "
        "time_unit, when it says one, must agree with this option; given (s "
        "included), a time step >= 0.5 s is read with a warning instead of refused "
        "as stamps in ms, us or ns read as seconds",
    )


def add_common_arguments(
    parser: argparse.ArgumentParser, from_results: bool = False
) -> None:
    """Arguments shared by ``dynid identify``, ``offline`` and ``payload``.

    ``from_results`` (``dynid payload``): ``--friction`` and ``--dead-zone``
    default to None, the ``--params`` results file's columns and widths
    (``_results.results_robot``, ``results_sign``), else viscous,coulomb and auto.
    """
    add_log_argument(parser)
    parser.add_argument(
        "--urdf",
        required=True,
        metavar="MODEL.urdf",
        type=urdf_argument,
        help=URDF_HELP,
    )
    add_friction_argument(parser, from_results)
    add_joint_arguments(parser)
    add_drive_arguments(parser)
    if from_results:
        add_dead_zone_argument(
            parser, None, " (default: the --params file's widths, else auto)"
        )
    else:
        add_dead_zone_argument(parser, "auto")
    parser.add_argument(
        "--resample",
        action="store_true",
        help="interpolate linearly from the time stamps onto the fitted uniform grid "
        "instead of snapping stamps to it (for samples really taken at jittered "
        "times; accepts non-uniform sampling; off by default: it changes the data)",
    )
    add_fill_gaps_argument(parser)
    add_time_unit_argument(parser)
    parser.add_argument(
        "--json",
        metavar="FILE",
        help="write a JSON summary to FILE (-: standard output)",
    )
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="print nothing on stdout (log warnings and errors still go to stderr)",
    )


def read_robot_log(
    files: Sequence[str],
    robot: Any,
    *,
    resample: bool,
    command: str,
    fill_gaps: int | None = None,
    time_unit: str | None = None,
    torques_optional: bool = False,
    topic: str | None = None,
    options: Sequence[str] | None = None,
) -> Any:
    """Reads a log of ``robot``; prints the reader's warnings on stderr.

    One file, no drive chain and no ``time_unit``: the plain CSV format
    (``drake_dynid.logs``). Otherwise the files are joined on time and converted
    by the robot's drive chain (``drake_dynid.raw_log``; an identity chain
    without ``--drive``). ``fill_gaps``: ``--fill-gaps`` (None: the reader's
    default); ``time_unit``: ``--time-unit`` (None: the drive file's, else s).
    ``torques_optional``: files without every torque column are read for their
    positions (τ = 0, not checked; ``dynid replay``). A ROS bag (alone) is read
    as its CSV export (:func:`_read_bag_log`); ``topic``: ``--topic`` (a bag's;
    not used with CSV files: the fitted log may be a bag and ``--validate``'s a
    CSV file; :func:`check_topic` refuses it when no log is a bag);
    ``options``: the command's :func:`bag_options` (a bag's error repeats them).
    """
    from drake_dynid.ros_bag import is_bag

    if any(is_bag(path) for path in files):
        return _read_bag_log(
            files,
            robot,
            resample=resample,
            command=command,
            fill_gaps=fill_gaps,
            time_unit=time_unit,
            torques_optional=torques_optional,
            topic=topic,
            options=options,
        )
    log, torques = _read_files(
        files, robot, resample, fill_gaps, time_unit, torques_optional
    )
    check_log_magnitudes(log, files)
    print_log_warnings(log, files, command, robot, torques=torques)
    return log


def _read_files(
    files: Sequence[str],
    robot: Any,
    resample: bool,
    fill_gaps: int | None,
    time_unit: str | None,
    torques_optional: bool,
    unit_known: bool = False,
) -> tuple[Any, bool]:
    """The read of :func:`read_robot_log` (CSV files); whether τ was read.

    ``unit_known``: the time column's unit is known without ``time_unit`` (a ROS
    bag's export, from ns stamps): a step >= 0.5 s is then a warning, as with
    ``--time-unit``, not the error on stamps in another unit (``log_repair``).
    """
    from drake_dynid.log_repair import FILL_GAPS

    gaps = FILL_GAPS if fill_gaps is None else fill_gaps
    chain = robot.drive
    if time_unit is not None:
        chain = _with_time_unit(chain, robot.joint_names, time_unit)
    elif unit_known and chain is not None:
        chain = dataclasses.replace(
            chain, log=dataclasses.replace(chain.log, time_unit_given=True)
        )
    torques = not torques_optional or _has_torque_columns(files, chain, robot)
    if chain is None and len(files) == 1:
        from drake_dynid.logs import read_log

        log = read_log(
            files[0],
            robot.joint_names,
            resample=resample,
            fill_gaps=gaps,
            torques=torques,
            time_unit="s" if unit_known else None,
        )
    else:
        from drake_dynid.core.drive import DriveChain
        from drake_dynid.raw_log import read_raw_log

        plain = chain is None
        if chain is None:
            chain = DriveChain.from_dict({}, robot.joint_names, source="log format")
        if not torques:
            chain = chain.positions_only()
        try:
            log = read_raw_log(files, chain, resample=resample, fill_gaps=gaps)
        except ValueError as error:
            # As the one-file reader says (log_table): the plain names are not
            # the only ones a log may have.
            if not (plain and ": no column(s) " in str(error)):
                raise
            raise ValueError(
                f"{str(error).rstrip('.')}; other column names are described in a "
                "drive file ([log] time, position and torque templates, "
                "docs/DRIVE.md)."
            ) from None
    return log, torques


#: The start of the CSV reader's warning on integer nanosecond stamps
#: (``log_repair``), not repeated for a ROS bag.
EPOCH_NOTE = "time stamps read as integer nanoseconds since the epoch"


@dataclasses.dataclass(frozen=True)
class BagLayout:
    """The CSV export of a ROS bag that the robot's log reader reads.

    Attributes:
        time: the time column's name (``t``; a drive file's ``[log] time``).
        time_unit: its unit (None: the plain format's; a drive file's unit).
        positions: the position columns (``q_<joint>``; the drive file's).
        torques: the torque columns (``tau_<joint>``; the drive file's).
        joints: the joints the messages must hold for those columns.
        held: the locked and mimic joints, whose positions ``locked_motion``
            checks.
        held_template: their column names (``{joint}``), or None when the
            log format names no joint-side position.
    """

    time: str
    time_unit: str | None
    positions: list[str]
    torques: list[str]
    joints: tuple[str, ...]
    held: list[str]
    held_template: str | None


def bag_layout(robot: Any, bag: str) -> BagLayout:
    """The columns a bag's messages are written to for ``robot``'s log reader.

    The plain format (``t`` in integer ns, ``q_<joint>``, ``tau_<joint>``), or with
    a drive chain its ``[log]`` columns in its time unit: what the commands read
    when given the bag, and what ``dynid bag2csv`` writes with the same options.

    Raises:
        ValueError: a drive file's column that no JointState field gives (named).
    """
    from drake_dynid.ros_bag import needed_joints

    chain = robot.drive
    if chain is None:
        time, unit = "t", None
        positions = [f"q_{name}" for name in robot.joint_names]
        torques = [f"tau_{name}" for name in robot.joint_names]
    else:
        time, unit = chain.log.time, chain.log.time_unit
        positions = list(chain.log.position_columns)
        torques = list(chain.log.torque_columns)
    try:
        joints = needed_joints([*positions, *torques])
    except ValueError as error:
        raise ValueError(f"log {bag}: {chain.source}: {error}") from None
    held = [
        *(getattr(robot, "locked", None) or {}),
        *(getattr(robot, "mimic", None) or {}),
    ]
    # The positions that locked_motion checks (the locked and mimic joints'),
    # named as the log format names a position.
    template = (
        "q_{joint}"
        if chain is None
        else getattr(chain.log, "joint_position_template", None)
    )
    return BagLayout(time, unit, positions, torques, joints, held, template)


def bag_options(args: argparse.Namespace) -> list[str]:
    """The options that choose a bag export's columns, as a command line repeats them.

    ``--joints``, ``--drive``, ``--urdf``, ``--lock`` as given (a packaged file
    by its short name): in the ``dynid bag2csv`` commands that the error of a
    header clock set back gives (``ros_bag.export_bag``'s ``options``), whose
    exports are then the one asked for.
    """
    out: list[str] = []
    for option, name, suffix in (
        ("--joints", "joints", None),
        ("--drive", "drive", ".toml"),
        ("--urdf", "urdf", ".urdf"),
        ("--lock", "lock", None),
    ):
        value = getattr(args, name, None)
        if value is not None:
            out += [option, value if suffix is None else short_packaged(value, suffix)]
    return out


def _read_bag_log(
    files: Sequence[str],
    robot: Any,
    *,
    resample: bool,
    command: str,
    fill_gaps: int | None,
    time_unit: str | None,
    torques_optional: bool,
    topic: str | None,
    options: Sequence[str] | None = None,
) -> Any:
    """A ROS bag's JointState messages read as a CSV log (``drake_dynid.ros_bag``).

    The columns the robot's log format needs (``t``, ``q_<joint>``,
    ``tau_<joint>``; with a drive chain its ``[log]`` columns, in its time unit)
    are written from the messages to a temporary CSV file, one row per message,
    which the CSV readers read (:func:`_read_files`: the same repairs); the
    messages name the bag instead of that file (its rows are those of ``dynid
    bag2csv``'s export). The bag's notes (skipped messages, receive times) come
    first among the log's warnings. ``options``: the command's
    (:func:`bag_options`), which the ``dynid bag2csv`` commands of a clock
    step's error repeat with a drive file (without one, the joints read).
    """
    import os
    import tempfile

    from drake_dynid.ros_bag import export_bag

    if len(files) != 1:
        raise ValueError(
            f"log {' + '.join(files)}: a ROS bag is a whole log: give it alone "
            "(files joined on time are CSV files)."
        )
    if time_unit is not None:
        raise ValueError(
            f"--time-unit {time_unit}: the log {files[0]} is a ROS bag, whose "
            "header stamps are nanoseconds; the option is for CSV logs."
        )
    bag = files[0]
    chain = robot.drive
    layout = bag_layout(robot, bag)
    time, unit, joints = layout.time, layout.time_unit, layout.joints
    positions, torques = layout.positions, layout.torques
    held, template = layout.held, layout.held_template

    def columns(names: tuple[str, ...], efforts: bool) -> list[str]:
        return [*positions, *(torques if efforts or not torques_optional else [])]

    name = os.path.basename(os.path.normpath(bag)) or "bag"
    with tempfile.TemporaryDirectory(prefix="dynid-bag-") as folder:
        export = os.path.join(folder, f"{name}.csv")
        try:
            done = export_bag(
                bag,
                export,
                joints,
                columns,
                topic=topic,
                optional=held if template is not None else (),
                time=time,
                time_unit=unit,
                held_out=os.path.join(folder, "held.csv"),
                held_column=template or "q_{joint}",
                # The plain export of the joints read; with a drive file, its
                # columns: the command's options (bag2csv refuses --urdf and
                # --lock without --drive).
                options=["--joints", ",".join(joints)] if chain is None else options,
            )
        except OSError as error:
            # A write to the temporary folder (a full disk): the files named
            # are gone with the folder; say where the export went instead.
            if not str(error.filename or "").startswith(folder):
                raise
            raise OSError(
                f"ROS bag {bag}: writing its CSV export in "
                f"{os.path.dirname(folder)} failed ({error.strerror or error}); "
                "set TMPDIR to a folder with room, or export it once with dynid "
                "bag2csv BAG --out LOG.csv"
                + (
                    ""
                    if chain is None
                    else " (with this command's --urdf, --joints, --lock and "
                    "--drive: the drive file's columns)"
                )
                + " and give that file."
            ) from None
        if not done.efforts and not torques_optional:
            raise ValueError(
                f"ROS bag {bag}: the messages on {done.topic} carry no effort[] "
                f"(torques), needed for column {torques[0]!r}."
            )

        def named(text: str) -> str:
            return text.replace(export, bag)

        try:
            log, read = _read_files(
                [export],
                robot,
                resample,
                fill_gaps,
                None,
                torques_optional,
                unit_known=True,
            )
        except (ValueError, OSError) as error:
            raise _renamed(error, named(str(error))) from None
        # A bag's stamps are nanoseconds: the CSV reader's note that it read
        # integers as such says nothing here.
        said = tuple(w for w in log.warnings if not w.startswith(EPOCH_NOTE))
        warnings = (*done.notes, *(named(w) for w in said))
        log = dataclasses.replace(log, warnings=warnings)
        check_log_magnitudes(log, [bag])
        print_log_warnings(
            log, [done.held_path or export], command, robot, torques=read, label=bag
        )
    return log


def _renamed(error: Exception, text: str) -> Exception:
    """``error`` with the message ``text``, of its own type where that can be.

    Where its type takes more than the message (``NonUniformSampling``: the
    rows kept and the step; a TypeError was raised instead), a ValueError (an
    OSError).
    """
    try:
        return type(error)(text)
    except TypeError:
        return (OSError if isinstance(error, OSError) else ValueError)(text)


def _has_torque_columns(files: Sequence[str], chain: Any, robot: Any) -> bool:
    """Every torque column of ``chain`` (None: ``tau_<joint>``) is in a file's header.

    A header that cannot be read counts as having them: the reader names the
    problem.
    """
    from drake_dynid.log_table import read_header

    names = (
        [f"tau_{name}" for name in robot.joint_names]
        if chain is None
        else list(chain.log.torque_columns)
    )
    found: set[str] = set()
    for path in files:
        try:
            with open(path, "rb") as stream:
                found.update(read_header(path, stream))
        except (OSError, ValueError):
            return True
    return all(name in found for name in names)


def check_log_magnitudes(log: Any, files: Sequence[str]) -> None:
    """|q|, |τ| <= 1e100 (``core._validate.log_magnitudes``), in the log's name.

    Checked when the log is read, before anything is measured on it (the dead
    zone, the cutoff, a validation's torques): beyond, squares overflow.
    """
    from drake_dynid.core._validate import log_magnitudes

    try:
        log_magnitudes("log", log.q, log.tau)
    except ValueError as error:
        message = str(error).split(": ", 1)[1]
        raise ValueError(f"log {' + '.join(files)}: {message}") from None


def _with_time_unit(chain: Any, joint_names: Sequence[str], unit: str) -> Any:
    """``chain`` (None: the plain format's identity chain) reading time in ``unit``.

    Raises:
        ValueError: the drive file says ``[log] time_unit`` and it is not ``unit``.
    """
    import dataclasses

    from drake_dynid.core.drive import DriveChain
    from drake_dynid.core.drive_log import TIME_UNITS

    if chain is None:
        return DriveChain.from_dict(
            {"log": {"time_unit": unit}}, joint_names, source="--time-unit"
        )
    given = chain.log.time_unit
    if chain.log.time_unit_given and given != unit:
        raise ValueError(
            f"--time-unit {unit} contradicts the drive file's [log] time_unit = "
            f"{given!r}: give one of them."
        )
    log = dataclasses.replace(
        chain.log, time_unit=unit, time_scale=TIME_UNITS[unit], time_unit_given=True
    )
    return dataclasses.replace(chain, log=log)


#: A joint that is not identified is said to move in the log when its recorded
#: position leaves its locked value by more than this [rad or m].
LOCKED_TOLERANCE = 1e-3

#: Chunks of the file read by :func:`locked_motion` and their size [bytes].
_CHUNKS, _CHUNK_BYTES = 16, 1 << 16


def _motion_checks(files: Sequence[str], robot: Any) -> list[tuple[Any, ...]]:
    """What :func:`locked_motion` reads: ``(file, body offset, checks)`` per file.

    The body offset is the first byte after the header. Each check is
    ``(joint, column, leader column or -1, multiplier, offset, scale)``.

    Plain logs: ``q_<joint>`` of the locked and the mimic joints. Drive-file logs
    with a joint-side ``{joint}`` position template: the locked joints' columns
    (their reading times the angle or length unit's scale, in rad or m).
    """
    from drake_dynid.core.drive_log import ANGLE_UNITS, LENGTH_UNITS
    from drake_dynid.log_table import read_header

    locked = dict(getattr(robot, "locked", None) or {})
    mimic = dict(getattr(robot, "mimic", None) or {})
    if robot.drive is None:
        if len(files) != 1:
            return []
        column = "q_{joint}"
        scale = length = 1.0  # a plain log is in rad and m
    else:
        template = getattr(robot.drive.log, "joint_position_template", None)
        if template is None:
            return []
        column, mimic = template, {}
        scale = float(ANGLE_UNITS[robot.drive.log.angle_unit])
        length = float(LENGTH_UNITS[robot.drive.log.length_unit])
    out = []
    for path in files:
        with open(path, "rb") as stream:
            header = read_header(path, stream)
            start = stream.tell()
        checks = [
            (
                name,
                header.index(column.format(joint=name)),
                -1,
                0.0,
                value,
                length if _prismatic(robot, name) else scale,
            )
            for name, value in locked.items()
            if column.format(joint=name) in header
        ]
        for name, (leader, multiplier, offset) in mimic.items():
            mine, theirs = column.format(joint=name), column.format(joint=leader)
            if mine in header and theirs in header:
                at, lead = header.index(mine), header.index(theirs)
                checks.append((name, at, lead, float(multiplier), float(offset), 1.0))
        if checks:
            out.append((path, start, checks))
    return out


def _prismatic(robot: Any, name: str) -> bool:
    """Whether ``name`` is a prismatic joint of the robot's plant."""
    try:
        return robot.plant.GetJointByName(name).type_name() == "prismatic"
    except (AttributeError, RuntimeError):
        return False


def locked_motion(files: str | Sequence[str], robot: Any) -> str | None:
    """A warning when the log records joints moving otherwise than the model.

    The joints outside ``--joints`` are welded at their ``locked`` positions (0
    unless ``--lock``), and a mimic joint follows its leader (q = k·q_leader +
    offset, from the URDF). A log whose column of such a joint moves otherwise
    gives torques that model cannot predict (a review found the held-out error
    10 times larger, with only "ignored extra column" said). Reads 16 chunks of
    64 KiB spread over each file (start, end and between; not the whole file).
    Plain logs (``q_<joint>``) and drive-file logs whose positions are a
    joint-side ``{joint}`` template (the TIAGo's ``- {joint}_position``).
    """
    import os

    files = [files] if isinstance(files, str) else list(files)
    locked = dict(getattr(robot, "locked", None) or {})
    mimic = dict(getattr(robot, "mimic", None) or {})
    if not (locked or mimic):
        return None
    low: dict[str, float] = {}
    high: dict[str, float] = {}
    worst: dict[str, float] = {}
    try:
        for path, start, checks in _motion_checks(files, robot):
            with open(path, "rb") as stream:
                size = os.fstat(stream.fileno()).st_size
                span = max(0, size - start - _CHUNK_BYTES)
                for k in range(_CHUNKS):
                    offset = start + span * k // max(1, _CHUNKS - 1)
                    stream.seek(offset)
                    lines = stream.read(_CHUNK_BYTES).split(b"\n")
                    for line in lines[(1 if offset > start else 0) : -1]:
                        _sample_line(line.split(b","), checks, low, high, worst)
    except (OSError, ValueError):
        return None  # the read names the problem
    # A column with no finite value read says nothing (all NaN, or unparsed).
    off = [
        name
        for name in worst
        if low[name] <= high[name] and worst[name] > LOCKED_TOLERANCE
    ]
    moving = [
        f"{name} from {low[name]:.4g} to {high[name]:.4g}"
        for name in off
        if name in locked
    ]
    astray = [
        f"{name} departs from {mimic[name][1]:g}·{mimic[name][0]} + "
        f"{mimic[name][2]:g} by up to {worst[name]:.3g}"
        for name in off
        if name not in locked
    ]
    parts = []
    if moving:
        held = listed(f"{name} = {locked[name]:g}" for name in off if name in locked)
        parts.append(
            f"joint(s) not identified move in the log ({listed(moving, sep='; ')}) "
            f"while the model holds them fixed ({held}): add them to --joints, or "
            "--lock them at the position they keep"
        )
    if astray:
        parts.append(
            f"mimic joint(s) do not follow their URDF relation in the log "
            f"({listed(astray, sep='; ')}): fix the URDF's <mimic>, or identify the "
            "joint on its own"
        )
    if not parts:
        return None
    return "; ".join(parts) + ". The torques they cause are not modelled."


def _sample_line(cells, checks, low, high, worst) -> None:
    """One sampled row into the running range and departure of each check."""
    for name, at, lead, multiplier, shift, scale in checks:
        try:
            value = scale * float(cells[at].strip(b' "'))
            expected = shift
            if lead >= 0:
                expected += multiplier * float(cells[lead].strip(b' "'))
        except (IndexError, ValueError):
            continue
        if math.isfinite(value) and math.isfinite(expected):
            low[name] = min(low.get(name, math.inf), value)
            high[name] = max(high.get(name, -math.inf), value)
            worst[name] = max(worst.get(name, 0.0), abs(value - expected))


def constant_channels(log: Any, *, torques: bool = True) -> str | None:
    """A warning naming the q and τ columns that never change (None if none).

    A joint whose position never changes does not move (a frozen encoder, or a
    joint to ``--lock``): its parameters cannot be identified. A torque that never
    changes (all zeros: not recorded) makes every estimate fit that constant.
    Finite samples only; q only without ``torques`` (a log read for its motion).
    """
    from drake_dynid.core.blocks import constant_columns

    names = log.joint_names
    channels = (("q", log.q), ("tau", log.tau)) if torques else (("q", log.q),)
    found = {
        label: [f"{label}_{names[j]} = {value:g}" for j, value in constant_columns(x)]
        for label, x in channels
    }
    found.setdefault("tau", [])
    reasons = []
    if found["q"]:
        reasons.append(
            f"{listed(found['q'])} never change: a joint that does not move (a "
            "frozen encoder? --lock it at that position)"
        )
    if found["tau"]:
        reasons.append(
            f"{listed(found['tau'])} never change: a torque that was not recorded"
        )
    if not reasons:
        return None
    return (
        "; ".join(reasons) + ". The parameters they enter cannot be identified from "
        "this log."
    )


#: A position beyond a joint's URDF limits by more than this fraction of its range
#: is named by :func:`outside_limits`.
LIMIT_MARGIN = 0.1


def outside_limits(log: Any, robot: Any) -> str | None:
    """A warning naming the joints whose logged positions leave their URDF limits.

    A joint is named when its finite positions go beyond ``[lower, upper]`` by
    more than ``LIMIT_MARGIN`` × (upper - lower) (joints without finite limits
    are not checked): positions in another unit than the one read (degrees read
    as radians, millimetres as metres: a drive file's ``angle_unit``,
    ``length_unit``) or a wrong zero offset, which nothing else notices (the
    model's gravity and inertia torques are then evaluated at positions the
    robot was never in). A stored log is read a block at a time.
    """
    import numpy as np

    from drake_dynid.core.blocks import blocks

    plant = getattr(robot, "plant", None)
    if plant is None:
        return None
    low = np.full(len(log.joint_names), np.inf)
    high = np.full(len(log.joint_names), -np.inf)
    for _, block in blocks(log.q):
        finite = np.isfinite(block)
        low = np.minimum(low, np.min(block, axis=0, where=finite, initial=np.inf))
        high = np.maximum(high, np.max(block, axis=0, where=finite, initial=-np.inf))
    found = []
    for j, name in enumerate(log.joint_names):
        joint = plant.GetJointByName(name)
        lower = float(joint.position_lower_limits()[0])
        upper = float(joint.position_upper_limits()[0])
        if not (np.isfinite(lower) and np.isfinite(upper) and upper > lower):
            continue
        margin = LIMIT_MARGIN * (upper - lower)
        if low[j] < lower - margin or high[j] > upper + margin:
            unit = "m" if joint.type_name() == "prismatic" else "rad"
            found.append(
                f"{name} from {low[j]:.4g} to {high[j]:.4g} {unit} (limits "
                f"{lower:.4g} .. {upper:.4g})"
            )
    if not found:
        return None
    return (
        f"position(s) beyond the URDF's joint limits: {listed(found, sep='; ')}. "
        "Positions in another unit (degrees read as radians, millimetres as "
        "metres: a drive file's angle_unit, length_unit) or a wrong zero offset "
        "(position_offset)? The model is evaluated at the positions as read."
    )


def print_log_warnings(
    log: Any,
    files: Sequence[str],
    command: str,
    robot: Any = None,
    *,
    torques: bool = True,
    label: str | None = None,
) -> None:
    """Each of the reader's warnings as one line on stderr, naming the log.

    Also :func:`constant_channels`'s (of q only without ``torques``: τ = 0 was
    not read), and with ``robot`` :func:`locked_motion`'s and
    :func:`outside_limits`'s. ``label``: the log's name in the lines (default:
    the files).
    """
    label = label or " + ".join(files)
    extra = [constant_channels(log, torques=torques)]
    if robot is not None:
        extra.append(locked_motion(files, robot))
        extra.append(outside_limits(log, robot))
    for warning in (*log.warnings, *(w for w in extra if w)):
        print(f"dynid {command}: warning: log {label}: {warning}", file=sys.stderr)


def apply_dead_zone(args: argparse.Namespace, robot: Any, log: Any) -> Any:
    """``robot`` with the Coulomb sign of ``--dead-zone`` (measured on ``log``).

    ``auto`` measures one width per joint (``drake_dynid.offline.
    standstill_widths``, with ``--cutoff``/``--decimation-cutoff`` when given);
    ``none`` keeps the exact sign; a number is one width for every joint. A model
    without Coulomb columns, or with a smooth Coulomb law (``--coulomb-width``:
    tanh(v/W) is already continuous at standstill), is returned unchanged.
    """
    from drake_dynid.core.friction import DeadZoneSign

    choice = parse_dead_zone(getattr(args, "dead_zone", None))
    if isinstance(choice, float) and robot.coulomb_width > 0:
        # A width is always the user's: not dropped without a word (found by a
        # review: --coulomb-width 0.01 --dead-zone 0.05 fitted tanh(v/0.01)).
        raise ValueError(
            f"--dead-zone {args.dead_zone}: the Coulomb law is already smooth, "
            f"tanh(v/{robot.coulomb_width:g}) (--coulomb-width, or the results "
            "file's), which replaces the dead zone; give one of the two."
        )
    if choice is None or "coulomb" not in robot.friction or robot.coulomb_width > 0:
        return robot
    if choice == "auto":
        from drake_dynid.commands._options import FILTER_OPTIONS, option_message
        from drake_dynid.offline import standstill_widths

        try:
            widths = standstill_widths(
                log,
                cutoff_hz=getattr(args, "cutoff", None),
                decimation_cutoff_hz=getattr(args, "decimation_cutoff", None),
            )
        except ValueError as error:
            message = option_message(str(error), FILTER_OPTIONS, ("standstill_widths",))
            raise ValueError(f"log {args.log}: {message}") from None
        if widths is None:
            # Too short for the noise measurement (the fit says so in its own
            # terms when it cannot run either); dead_zone_line reports it.
            args.dead_zone_note = (
                "exact sign(v): no finite run of the log is long enough to measure "
                "the velocity noise (--dead-zone auto)"
            )
            return robot
        return robot.with_sign(DeadZoneSign(tuple(float(w) for w in widths)))
    return robot.with_sign(DeadZoneSign((float(choice),) * robot.num_joints))


def dead_zone_widths(robot: Any) -> dict[str, float] | None:
    """``{joint: width}`` of the robot's dead zone, or None (exact sign)."""
    from drake_dynid.core.friction import DeadZoneSign

    sign = getattr(robot, "sign", None)
    if not isinstance(sign, DeadZoneSign):
        return None
    widths = sign.width
    if isinstance(widths, float):
        widths = (widths,) * robot.num_joints
    return dict(zip(robot.joint_names, map(float, widths), strict=True))


def _top_speeds(q: Any, h: float, rows: Any) -> Any:
    """(c,) largest |R_k (q[k+1] - q[k-1])|/(2h ρ_k) of a run, ρ_k = max_j |R_kj|.

    The identity's rows give the joints' speeds; a coupled motor's its sign's
    argument u_k/ρ_k in joint units (``core.drive_columns``). inf when the run is
    shorter than 3.
    """
    import numpy as np

    rows = np.asarray(rows, dtype=float)
    if q.shape[0] < 3:
        return np.full(rows.shape[0], np.inf)
    scale = np.max(np.abs(rows), axis=1)
    return np.max(np.abs((q[2:] - q[:-2]) @ rows.T), axis=0) / (2.0 * h * scale)


def dead_zone_cover(robot: Any, log: Any) -> str:
    """A sentence for a failed fit whose dead zone covers a joint's every velocity.

    Empty unless the robot has a dead zone and a joint's largest central-difference
    speed on the longest good run, |q[k+1] - q[k-1]|/(2h), is within its width:
    that joint's Coulomb column is then all zero (``--dead-zone 1e300`` made the
    fit name an unexcited FCj, not the option). With a drive chain, a coupled
    motor k's too (its sign reads u_k/ρ_k = R_k v/ρ_k, within the combined width:
    its FCmk column is all zero).
    """
    import numpy as np

    from drake_dynid.core.friction import DeadZoneSign

    widths = dead_zone_widths(robot)
    if widths is None:
        return ""
    try:  # read once (a stored segment on a long log): joints and motors
        q = np.asarray(_longest_positions(log), dtype=float)
    except ValueError:
        return ""
    speeds = _top_speeds(q, log.time_step, np.eye(q.shape[1]))
    covered = [
        f"{name} (width {w:.3g}; largest raw |q[k+1] - q[k-1]|/2h {speed:.3g})"
        for (name, w), speed in zip(widths.items(), speeds, strict=True)
        if speed <= w
    ]
    motors = getattr(robot, "motor_columns", None)
    sign = getattr(motors, "sign", None)
    if motors is not None and isinstance(sign, DeadZoneSign):
        width = sign.width
        count = motors.rows.shape[0]
        motor_widths = (width,) * count if isinstance(width, float) else width
        motor_speeds = _top_speeds(q, log.time_step, motors.rows)
        covered += [
            f"motor {name} (width {w:.3g}; largest raw |R (q[k+1] - q[k-1])|/2hρ "
            f"{speed:.3g})"
            for name, w, speed in zip(
                coupled_motor_names(robot, motors),
                motor_widths,
                motor_speeds,
                strict=True,
            )
            if speed <= w
        ]
    if not covered:
        return ""
    return (
        " The Coulomb dead zone is wider than every speed of "
        + listed(covered)
        + ": their Coulomb columns are all zero; give a smaller --dead-zone, "
        "or none."
    )


def _longest_positions(log: Any) -> Any:
    """The positions of the log's longest good run (a stored segment on a long log)."""
    from drake_dynid.core.blocks import segment

    start, stop = max(log.good_segments(), key=lambda run: run[1] - run[0])
    return segment(log.q, start, stop)


def coupled_motor_names(robot: Any, motors: Any) -> list[str]:
    """The drive file's names of the coupled motors (``MotorColumns`` order).

    Their columns' numbers (``FCm7``) count the motors of the identified joints'
    chain; the messages name them as the drive file does (``arm_6_motor``).
    """
    chain = getattr(robot, "drive", None)
    if chain is not None and len(chain.coupled_motors) == motors.rows.shape[0]:
        return [str(chain.motor_names[k]) for k in chain.coupled_motors]
    return [f"m{k}" for k in motors.numbers]


def motor_dead_zone_widths(robot: Any) -> dict[str, tuple[float, bool]]:
    """``{motor: (width, prismatic)}`` of the coupled motors' dead zone, or {}.

    A coupled motor k's Coulomb sign reads x_k = R_k·v/ρ_k in joint units with
    its own width, the joints' widths combined (``core.standstill.
    combined_widths``); ``prismatic``: the unit of its largest |R_kj|'s joint.
    """
    import numpy as np

    from drake_dynid.core.friction import DeadZoneSign

    motors = getattr(robot, "motor_columns", None)
    sign = getattr(motors, "sign", None)
    if motors is None or not isinstance(sign, DeadZoneSign):
        return {}
    count = motors.rows.shape[0]
    width = sign.width
    widths = (width,) * count if isinstance(width, float) else tuple(width)
    names = coupled_motor_names(robot, motors)
    prismatic = getattr(robot, "prismatic", (False,) * motors.rows.shape[1])
    lead = np.argmax(np.abs(motors.rows), axis=1)
    return {
        name: (float(w), bool(prismatic[j]))
        for name, w, j in zip(names, widths, lead, strict=True)
    }


def dead_zone_line(robot: Any, args: Any = None, reversals: bool = False) -> str | None:
    """One printed line with the dead-zone widths (None with the exact sign).

    When ``--dead-zone auto`` could not measure the noise, the line says so.
    ``reversals``: the off-line equations and the validation, which restore a
    moving joint's reversals through the zone (``core.standstill.reversal_signs``).
    """
    widths = dead_zone_widths(robot)
    if widths is None:
        note = getattr(args, "dead_zone_note", None)
        return f"Coulomb columns: {note}" if note else None
    prismatic = getattr(robot, "prismatic", (False,) * robot.num_joints)
    text = ", ".join(
        f"{name} {w:.2g} {'m' if p else 'rad'}/s"
        for (name, w), p in zip(widths.items(), prismatic, strict=True)
    )
    line = f"Coulomb dead zone (|v| <= w: sign(v) = 0): {text}"
    motors = motor_dead_zone_widths(robot)
    if motors:
        line += "; coupled motors, on R_k·v/ρ_k (the joints' widths combined): " + (
            ", ".join(
                f"{name} {w:.2g} {'m' if p else 'rad'}/s"
                for name, (w, p) in motors.items()
            )
        )
    if reversals:
        line += "; a moving joint's reversal through it keeps its sign"
    return line


def absolute(path: str | None) -> str | None:
    """A path as a results file records it: absolute (None stays None).

    ``dynid validate`` then finds it from any folder.
    """
    import os

    return os.path.abspath(path) if path else None


def model_settings(args: argparse.Namespace, robot: Any) -> dict[str, Any]:
    """The model entries of a results file's ``settings`` (read back by validate).

    Identified and locked joints, rotor inertia, the drive file (its absolute
    path) and its chain, and the Coulomb dead zone (``--dead-zone`` and the widths
    used).
    """
    out: dict[str, Any] = {
        "joints": list(robot.joint_names),
        "locked": dict(robot.locked),
        "rotor_inertia": bool(robot.rotor_inertia),
        "drive": absolute(getattr(args, "drive", None)),
        "dead_zone": getattr(args, "dead_zone", None),
        "coulomb_dead_zone": dead_zone_widths(robot),
    }
    if robot.drive is not None:
        out["drive_chain"] = robot.drive.summary()
    if getattr(args, "time_unit", None):
        out["time_unit"] = args.time_unit
    if getattr(args, "topic", None):
        out["topic"] = args.topic  # a ROS bag log's (for the record)
    return out


PREFETCH_BYTES = 32 << 20
"""Largest log file [bytes] read in a second process while the URDF loads.

The overlap saves the URDF's load (about 0.13 s); on a larger log, sending the
arrays back and the two processes' contention eat it (measured: none left at 53
MB), and it would be a small part of the reading anyway. A file whose numbers
are so short that an array would spill to disk (``log_store.SPILL_BYTES``, sent
back it cannot be) is read here too (:func:`_log_prefetch`).
"""


def load_robot_and_log(args: argparse.Namespace, command: str):
    """Loads the URDF model (with its drive chain) and the log.

    Prints the reader's warnings on stderr. The model keeps the exact Coulomb
    sign: the caller applies ``--dead-zone`` (:func:`apply_dead_zone`) on the
    part of the log it fits, after any ``--split``, so that the held-out part
    tells nothing to the model.

    With ``args.parallel`` present and not ``"off"`` (``dynid identify``), a
    one-file log (a regular file of at most :data:`PREFETCH_BYTES`) is read in a
    forked child process (``commands._background``) while this process loads the
    URDF (mostly importing Drake's library): about 0.1 s of a 7-DOF 60 s run. The
    child reads the joints its header names (``logs.header_joints``); the read is
    used when they are the robot's joints and the robot has no drive chain (checked
    on the header before waiting for it), with its columns put in the robot's order
    (the reader treats every column alike, so the log and its warnings are those of
    the read here, tested). In any other case, or when the child fails, the log is
    read here, and its errors are the usual ones.
    """
    from drake_dynid.commands._background import Background

    files = log_files(args)
    prefetch = _log_prefetch(files, args)
    with Background(prefetch or _no_log, enabled=prefetch is not None) as early:
        robot = robot_from_args(args, command)
        log = None
        if early.forked and _header_has(files[0], robot):  # else not waited for
            log = _in_joint_order(early.result(), robot.joint_names)
    if log is None:
        log = read_robot_log(
            files,
            robot,
            resample=args.resample,
            command=command,
            fill_gaps=getattr(args, "fill_gaps", None),
            time_unit=getattr(args, "time_unit", None),
            topic=getattr(args, "topic", None),
            options=bag_options(args),
        )
    else:
        check_log_magnitudes(log, files)
        print_log_warnings(log, files, command, robot)
    return robot, log


def _log_prefetch(files: Sequence[str], args: argparse.Namespace) -> Any:
    """The child's read of :func:`load_robot_and_log` (None: none is tried)."""
    import os
    import stat

    from drake_dynid.log_store import SPILL_BYTES

    if len(files) != 1 or getattr(args, "parallel", "off") == "off":
        return None
    if getattr(args, "drive", None) or getattr(args, "time_unit", None):
        return None
    path = files[0]
    from drake_dynid.ros_bag import is_bag

    if is_bag(path) or getattr(args, "topic", None):
        return None  # read here (read_robot_log)
    try:
        status = os.stat(path)
        # A regular file only: a pipe or FIFO can be read once (by the child).
        if not stat.S_ISREG(status.st_mode) or status.st_size > PREFETCH_BYTES:
            return None
        with open(path, "rb") as stream:
            sample = stream.read(1 << 16)
    except OSError:
        return None  # the read here names the problem
    # Numbers in the file (commas and line ends counted on its start): q or τ
    # holds less than half of them, 8 bytes each, and must stay in memory.
    numbers = (sample.count(b",") + sample.count(b"\n")) / max(1, len(sample))
    if 4.0 * numbers * status.st_size > SPILL_BYTES:
        return None
    resample = bool(args.resample)
    options: dict[str, Any] = {"resample": resample}
    if getattr(args, "fill_gaps", None) is not None:
        options["fill_gaps"] = int(args.fill_gaps)

    def read() -> Any:
        import warnings

        from drake_dynid.commands._background import Background
        from drake_dynid.core.blocks import is_stored
        from drake_dynid.logs import header_joints, read_log

        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                # Half the file parsed in one more child (2 CPUs: this one and
                # the parent, which loads the URDF meanwhile).
                log = read_log(
                    path, header_joints(path), parse_beside=Background, **options
                )
        except Exception:
            return None  # read here again: its own message
        if caught or any(is_stored(x) for x in (log.t, log.q, log.tau)):
            return None  # warnings are printed by the read here
        return log

    return read


def _header_has(path: str, robot: Any) -> bool:
    """Whether the log's header names exactly the joints of ``robot`` (no drive)."""
    from drake_dynid.logs import header_joints

    if robot.drive is not None:
        return False
    try:
        return sorted(header_joints(path)) == sorted(robot.joint_names)
    except (OSError, ValueError):
        return False  # the read here names the problem


def _no_log() -> None:
    return None


def _in_joint_order(log: Any, names: Sequence[str]) -> Any:
    """``log`` with its columns in the order of ``names``; None: other joints."""
    import dataclasses

    import numpy as np

    if log is None or sorted(log.joint_names) != sorted(names):
        return None
    if tuple(log.joint_names) == tuple(names):
        return log
    order = [log.joint_names.index(name) for name in names]

    def ordered(x: np.ndarray) -> np.ndarray:
        # The reader's memory layout (Fortran order when nothing was repaired),
        # which does not depend on the column order: the read here has it too.
        fortran = x.flags.f_contiguous and not x.flags.c_contiguous
        return (np.asfortranarray if fortran else np.ascontiguousarray)(x[:, order])

    return dataclasses.replace(
        log, q=ordered(log.q), tau=ordered(log.tau), joint_names=tuple(names)
    )
