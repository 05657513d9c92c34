"""Output-path checks shared by every subcommand (not a subcommand itself).

An output never overwrites an input (docs/CONVENTIONS.md §5): every ``dynid``
subcommand calls :func:`check_output_paths` first, before it reads or computes
anything. It compares every output option of the command (:data:`OUTPUTS`, plus
derived files such as ``dynid simulate``'s truth file) with every input
(:data:`INPUTS`: logs, URDF, results, trajectory, limits and drive files) by
resolved path, and by ``os.path.samefile`` where both exist (hard links and
symbolic links included), and two outputs with each other. A new input or output
option of any command is one entry in these tables.

An output given as ``-`` is standard output where a pipe can take it, the JSON
and CSV outputs (:data:`STDOUT_OUTPUTS`); the command then prints no report
there (as ``--quiet``). Any other output refuses ``-`` (it wrote a file named
``-``).
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from drake_dynid.files import file_key, is_stdout

__all__ = [
    "INPUTS",
    "OUTPUTS",
    "STDOUT_OUTPUTS",
    "check_output_paths",
    "check_outputs",
]

#: Attribute of the parsed arguments -> how a message names that input. A value
#: may be one path or a list of paths (several raw logs).
INPUTS: dict[str, str] = {
    "log": "the log",
    "logs": "a log",
    "raw": "a raw log",
    "raw_logs": "a raw log",
    "urdf": "the URDF",
    "params": "--params",
    "validate": "--validate",
    "trajectory": "--trajectory",
    "limits": "--limits",
    "drive": "--drive",
}

#: Attribute of the parsed arguments -> its output option.
OUTPUTS: dict[str, str] = {
    "out": "--out",
    "json": "--json",
    "plot": "--plot",
    "urdf_out": "--urdf-out",
    "html": "--html",
}

#: Command -> its outputs that ``-`` writes to standard output: the JSON and CSV
#: files (not a figure, a URDF whose mesh paths are relative to its folder, a
#: page, or a simulated log beside its truth file).
STDOUT_OUTPUTS: dict[str, tuple[str, ...]] = {
    "offline": ("--json", "--out"),
    "identify": ("--json", "--out"),
    "payload": ("--json", "--out"),
    "validate": ("--json",),
    "params": ("--json",),
    "excite": ("--json", "--out"),
    "bag2csv": ("--out",),
}

#: The figure formats ``--plot`` writes (matplotlib's Agg canvas), by extension.
FIGURE_SUFFIXES = frozenset(
    {".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif"}
    | {".tiff", ".webp", ".pgf", ".raw", ".rgba", ".gif", ".avif"}
)


def _paths(value: Any) -> list[str]:
    if value is None or value == "":
        return []
    if isinstance(value, (str, os.PathLike)):
        return [os.fspath(value)]
    if isinstance(value, Iterable):
        return [os.fspath(item) for item in value if item]
    return []


def _with_bag_files(path: str) -> list[str]:
    """``[path]``, and for a ROS 2 bag (its folder or a storage file) the bag's files.

    A ROS 2 bag is read whole (``drake_dynid.ros_bag``): its ``metadata.yaml`` and
    its ``.db3`` / ``.mcap`` files are inputs too.
    """
    folder = path if os.path.isdir(path) else None
    if folder is None and path.lower().endswith((".db3", ".mcap")):
        folder = os.path.dirname(os.path.abspath(path))
    if folder is None or not os.path.isfile(os.path.join(folder, "metadata.yaml")):
        return [path]
    try:
        names = sorted(os.listdir(folder))
    except OSError:
        return [path]
    bag = [
        os.path.join(folder, name)
        for name in names
        if name == "metadata.yaml" or name.lower().endswith((".db3", ".mcap"))
    ]
    return [path, *bag]


def _check_parent(option: str, path: str) -> None:
    """Raises ValueError unless an output can be written where it goes.

    An existing file is written in place: its own permission decides (``--json
    /dev/null`` in a folder a user cannot write). A new file needs its folder to
    exist and be writable. Checked before any work, so a long run does not end on
    a missing folder.
    """
    file, parent = Path(path), Path(path).parent
    if file.exists():  # written in place: the file's own permission decides
        if not os.access(file, os.W_OK):
            raise ValueError(f"{option} {path}: the file cannot be written.")
        return
    if not parent.exists():
        raise ValueError(
            f"{option} {path}: the folder {parent} does not exist; create it first "
            "or choose another path."
        )
    if not parent.is_dir():
        raise ValueError(f"{option} {path}: {parent} is not a folder.")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(
            f"{option} {path}: the folder {parent} cannot be written; choose another "
            "path."
        )


def check_outputs(
    outputs: Mapping[str, str | os.PathLike | None],
    inputs: Sequence[str | os.PathLike | None] | Mapping[str, Any],
    *,
    stdout: Sequence[str] = (),
    command: str = "this command",
) -> None:
    """Raises ValueError if an output would overwrite an input or another output.

    Also if the output's folder is missing or cannot be written, or its path is
    empty (an output asked for must be written), or it is ``-`` (standard
    output) and not one of ``stdout``, or two are ``-``.

    Args:
        outputs: option name (e.g. ``"--out"``) -> path (None: not written).
        inputs: the paths read by the command (None entries ignored), or a mapping
            description -> path(s) (the description names the input in the
            message).
        stdout: the options that may be ``-`` (:data:`STDOUT_OUTPUTS`).
        command: how the messages name the command (``dynid offline``).
    """
    if isinstance(inputs, Mapping):
        named = [
            (name, path) for name, value in inputs.items() for path in _paths(value)
        ]
    else:
        named = [("an input", path) for path in _paths(inputs)]
    for option, path in outputs.items():
        if path is not None and os.fspath(path) == "":
            # --urdf-out "" (an unset shell variable) would silently write nothing.
            raise ValueError(f"{option}: the path is empty; give a file path.")
    piped = [name for name, path in outputs.items() if is_stdout(path)]
    for option in piped:
        if option not in stdout:
            takes = (
                f"{command} writes {' and '.join(stdout)} only there (JSON or CSV text)"
                if stdout
                else f"{command} writes none of its outputs there"
            )
            raise ValueError(
                f"{option} -: '-' is standard output, and {takes}; give {option} "
                "a file name."
            )
    if len(piped) > 1:
        raise ValueError(
            f"{' and '.join(piped)} are both '-' (standard output); give one of "
            "them a file name."
        )
    given = [
        (name, os.fspath(path))
        for name, path in outputs.items()
        if path and not is_stdout(path)
    ]
    # One key a path (files.file_key), so that a fleet of n logs checks its n
    # outputs against its n inputs in linear time, not n² same_file calls.
    sources: dict[tuple[Any, ...], tuple[str, str]] = {}
    for description, source in named:
        for path in _with_bag_files(source):
            sources.setdefault(file_key(path), (description, source))
    seen: dict[tuple[Any, ...], tuple[str, str]] = {}
    for option, path in given:
        key = file_key(path)
        if key in sources:
            description, source = sources[key]
            raise ValueError(
                f"{option} {path} is an input of this command ({description} "
                f"{source}): an output never overwrites an input; choose another "
                "file."
            )
        if key in seen:
            first, first_path = seen[key]
            raise ValueError(
                f"{first} and {option} are the same file {first_path}; give each "
                "output its own file."
            )
        seen[key] = (option, path)
        if Path(path).is_dir():
            raise ValueError(f"{option} {path} is a directory; give a file path.")
        _check_parent(option, path)
        if option == "--html" and Path(path).suffix.lower() not in (".html", ".htm"):
            raise ValueError(
                f"--html {path}: a page file ends in .html; got "
                f"{Path(path).suffix or 'no extension'}."
            )
        if option == "--plot" and Path(path).suffix.lower() not in FIGURE_SUFFIXES:
            raise ValueError(
                f"--plot {path}: a figure file ends in "
                f"{', '.join(sorted(FIGURE_SUFFIXES))} (matplotlib's formats); got "
                f"{Path(path).suffix or 'no extension'}."
            )


def check_output_paths(
    args: argparse.Namespace,
    *,
    outputs: Mapping[str, str | os.PathLike | None] | None = None,
    inputs: Mapping[str, Any] | None = None,
) -> None:
    """No output of the command may be one of its inputs, nor two outputs one file.

    Reads every attribute of ``args`` listed in :data:`INPUTS` and
    :data:`OUTPUTS` (absent or None ones are skipped), plus the extra ``outputs``
    (name shown -> path, e.g. a derived truth file) and ``inputs`` (description
    -> path(s)).

    Raises:
        ValueError: naming the output option, its path and the input it would
            overwrite (or the other output).
    """
    found_outputs = {
        option: getattr(args, attribute, None) for attribute, option in OUTPUTS.items()
    }
    found_outputs.update(outputs or {})
    # A LOG positional of several files stores the list in ``<name>_files``
    # (``commands._arguments.LogFiles``) and a label in ``<name>``.
    found_inputs = {
        description: getattr(args, f"{attribute}_files", None)
        or getattr(args, attribute, None)
        for attribute, description in INPUTS.items()
    }
    found_inputs.update(inputs or {})
    command = getattr(args, "command", None)
    check_outputs(
        found_outputs,
        found_inputs,
        stdout=STDOUT_OUTPUTS.get(command or "", ()),
        command=f"dynid {command}" if command else "this command",
    )
    if any(is_stdout(path) for path in found_outputs.values()):
        args.quiet = True  # standard output holds the file alone
