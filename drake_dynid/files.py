"""File helpers of the outputs and inputs: one file by any name, whole writes.

* :func:`same_file`, :func:`repeated_file`: two paths name one file (hard and
  symbolic links and spellings included), the test behind "an output never
  overwrites an input" (``commands._paths``) and "a file given twice"
  (``raw_log``, ``fleet``).
* :func:`write_text_whole`: a text file written whole or not at all (a full disk
  leaves the previous file, or none, never a truncated one); :func:`write_whole`
  the same for a file written piece by piece (the CSV outputs: logs, estimates,
  trajectories), so that a long one is never held in memory as one string.
* :func:`json_text`: a JSON document indented, its lists of numbers on one line
  each (a covariance matrix one row per line, not one number).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import secrets
import stat
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, TextIO

__all__ = [
    "STDOUT",
    "file_key",
    "is_stdout",
    "json_text",
    "repeated_file",
    "same_file",
    "write_text_whole",
    "write_whole",
]


#: The first words of the last line of a ROS bag's export to an output that
#: cannot be taken back when it stops on an error (``ros_bag.export_bag``):
#: the CSV readers refuse a row that begins so (:func:`incomplete_export`).
INCOMPLETE = "# dynid: this export is incomplete; "


def incomplete_export(path: str, row: int | None, cell: str) -> str | None:
    """The error of a row of a CSV log that is :data:`INCOMPLETE`'s line.

    ``row``: its number (None: the last line); ``cell``: its first cell.
    None when it is another row.
    """
    if not cell.startswith(INCOMPLETE):
        return None
    said = cell[len("# dynid: ") :].strip()
    where = "its last line" if row is None else f"row {row}"
    return (
        f"log {path}: {where} says '{said}': the ROS bag's export to a pipe was "
        "cut short there, its rows are not the whole bag; export it again to a "
        "file (dynid bag2csv BAG --out LOG.csv)."
    )


def refuse_incomplete(path: str | os.PathLike) -> None:
    """Raises ValueError when the last line of ``path`` is :data:`INCOMPLETE`'s.

    For a reader that skips ``#`` lines (``np.loadtxt``); reads the last 64 KB.
    """
    with open(path, "rb") as stream:
        size = stream.seek(0, os.SEEK_END)
        stream.seek(max(0, size - (1 << 16)))
        tail = stream.read().decode("utf-8", errors="replace")
    lines = [line for line in tail.splitlines() if line.strip()]
    said = lines and incomplete_export(os.fspath(path), None, lines[-1])
    if said:
        raise ValueError(said)


#: The output path that means standard output (the commands' JSON and CSV
#: outputs: ``--json -``, ``--out -``; README "Bad options and outputs").
STDOUT = "-"


def is_stdout(path: str | os.PathLike | None) -> bool:
    """Whether ``path`` is :data:`STDOUT` (standard output, not a file)."""
    return path is not None and os.fspath(path) == STDOUT


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """True when ``a`` and ``b`` name one file (:func:`repeated_file`'s rule).

    The same device and inode where both exist (hard links, symbolic links,
    ``./x`` and ``x``); else the same resolved absolute path.
    """
    return repeated_file([a, b]) is not None


def repeated_file(
    paths: Sequence[str | os.PathLike],
) -> tuple[str, str] | None:
    """The first two of ``paths`` that name one file (:func:`same_file`), or None.

    One key per path (its device and inode where it exists, else its resolved
    absolute path), so a fleet of thousands of logs costs one ``stat`` each, not
    one :func:`same_file` per pair.
    """
    seen: dict[tuple[Any, ...], str] = {}
    for path in paths:
        name = os.fspath(path)
        key = file_key(name)
        if key in seen:
            return seen[key], name
        seen[key] = name
    return None


def file_key(path: str | os.PathLike) -> tuple[Any, ...]:
    """The key of :func:`same_file`: two paths name one file iff their keys are equal.

    Its device and inode where it exists, else its resolved absolute path (one
    ``stat``): a dictionary of keys finds the same file among many in linear time.
    """
    name = os.fspath(path)
    try:
        found = os.stat(name)
        return ("file", found.st_dev, found.st_ino)
    except OSError:  # realpath, not Path.resolve: a link loop is a path
        return ("path", os.path.realpath(name))


# An indented list of numbers, booleans or nulls: ``[`` then a newline (never
# inside a JSON string, which escapes it), items separated by a comma and a
# newline.
_NUMBER = r"(?:-?[0-9][0-9.eE+-]*|null|true|false|NaN|-?Infinity)"
_NUMBER_LIST = re.compile(rf"\[\n\s*({_NUMBER}(?:,\n\s*{_NUMBER})*)\n\s*\]")


def json_text(document: Any, *, allow_nan: bool = False) -> str:
    """``document`` as JSON indented by 2, each list of numbers on one line.

    ``json.dumps(document, indent=2, allow_nan=allow_nan)`` (by default a
    ValueError on NaN or infinity: invalid JSON) with every list holding only
    numbers, booleans or nulls joined onto one line: the same values
    (``json.loads`` returns the same document), a (p, p) covariance in p lines
    instead of p².
    """
    text = json.dumps(document, indent=2, allow_nan=allow_nan)
    return (
        _NUMBER_LIST.sub(
            lambda m: "[" + ", ".join(re.split(r",\n\s*", m.group(1))) + "]", text
        )
        + "\n"
    )


def write_text_whole(path: str | os.PathLike, text: str) -> None:
    """Writes ``text`` (UTF-8) to ``path`` whole or not at all (:func:`write_whole`)."""
    write_whole(path, lambda stream: stream.write(text), newline=None)


def write_whole(
    path: str | os.PathLike,
    write: Callable[[TextIO], object],
    *,
    newline: str | None = "",
) -> None:
    """Writes a text file (UTF-8) whole or not at all: ``write(stream)`` fills it.

    ``newline``: as ``open``'s (``""``: the lines as ``write`` ends them). A
    regular file (or a new one) is written to a temporary file beside it, which
    then replaces it (``os.replace``, atomic on one file system); a
    symbolic link is followed (its target is replaced, the link kept). The
    file keeps its permissions (a new one gets the umask's). Anything else
    (``/dev/null``, a named pipe), a file in a folder where no other file can
    be made, or a file that cannot be replaced (a bind mount of one file:
    ``EBUSY``), is written in place. ``stream`` is open read-write on a
    regular file (the temporary one, or one written in place), so that
    ``write`` may read back what it wrote (``ros_bag``'s merge of messages
    recorded late); write-only on anything else. ``path`` :data:`STDOUT`
    (``-``): written to ``sys.stdout`` in UTF-8 (as the file, whatever the
    locale's encoding), then flushed (as a pipe, not whole or not at all).

    Raises:
        OSError: naming ``path`` (a full disk's error names no file; an
            error without errno, a message of ``write``'s, as it is); the
            temporary file is removed and ``path`` is unchanged. Any error of
            ``write`` likewise leaves ``path`` unchanged and is raised as it is.
    """

    def in_place(name: str | os.PathLike, *, regular: bool = True) -> None:
        # A regular file read-write, as the temporary file (a writer may read
        # back what it wrote); a pipe or a device write-only.
        stream = None
        if regular:
            with contextlib.suppress(PermissionError):  # a write-only file: "w"
                stream = open(name, "w+", encoding="utf-8", newline=newline)
        if stream is None:
            stream = open(name, "w", encoding="utf-8", newline=newline)
        with stream:
            write(stream)

    if is_stdout(path):
        try:
            _write_stdout(write)
        except OSError as error:
            if error.errno is None:  # a message of ``write``'s own
                raise
            # A full disk behind '>' named no file.
            raise OSError(error.errno, error.strerror, "standard output") from None
        return

    try:
        try:
            # The path's own stat (links followed): ``/dev/stdout`` of a pipe
            # resolves to '/proc/<pid>/fd/pipe:[...]', no file, but is a pipe.
            mode: int | None = os.stat(path).st_mode
        except FileNotFoundError:
            mode = None
        target = Path(os.path.realpath(path))
        if mode is not None and not stat.S_ISREG(mode):
            in_place(path, regular=False)
            return
        try:
            descriptor, temporary = _open_temporary(target, new=mode is None)
        except PermissionError:
            if mode is None:
                raise
            # A file one may write in a folder one may not: written in place.
            in_place(target)
            return
        try:
            with os.fdopen(
                descriptor, "w+", encoding="utf-8", newline=newline
            ) as stream:
                write(stream)
            if mode is not None:
                os.chmod(temporary, stat.S_IMODE(mode))
            try:
                os.replace(temporary, target)
                return
            except OSError as error:
                if error.errno != errno.EBUSY or mode is None:
                    raise
        except BaseException:
            with contextlib.suppress(OSError):
                os.unlink(temporary)
            raise
        # A file mounted on its own (a container's bind mount of one file) cannot
        # be replaced (EBUSY): written in place, as a plain write did.
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        in_place(target)
    except OSError as error:
        if error.errno is None:  # a message of ``write``'s own (a missing input)
            raise
        raise OSError(error.errno, error.strerror, str(path)) from None


def _write_stdout(write: Callable[[TextIO], object]) -> None:
    """``write(sys.stdout)`` in UTF-8, flushed (:func:`write_whole`'s ``-``).

    The file's UTF-8 bytes whatever the locale's encoding (a joint named
    '関節1' under an ASCII locale failed); the encoding restored after.
    """
    import codecs
    import sys

    stream = sys.stdout
    encoding = getattr(stream, "encoding", None) or "utf-8"
    reconfigure = getattr(stream, "reconfigure", None)
    if reconfigure is None or codecs.lookup(encoding).name == "utf-8":
        write(stream)
        stream.flush()
        return
    stream.flush()
    reconfigure(encoding="utf-8")
    try:
        write(stream)
        stream.flush()
    finally:
        reconfigure(encoding=encoding)


def _open_temporary(target: Path, *, new: bool) -> tuple[int, str]:
    """A new file beside ``target``, open for writing: (descriptor, path).

    Created with mode 0o666 for a new output, so that the umask applies as to
    any new file (reading the umask sets it: two threads writing at once, a
    Dask worker's tasks, could leave the process's umask at 0), 0o600 for an
    existing one (its own mode is set before the replace). Its name keeps at
    most 40 characters of ``target``'s, so that a name near the file system's
    limit (255 bytes) still has a temporary file.
    """
    # Read and write: a writer may read back what it wrote (ros_bag's merge).
    flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        temporary = target.parent / f".{target.name[:40]}.{secrets.token_hex(4)}.tmp"
        try:
            return os.open(temporary, flags, 0o666 if new else 0o600), str(temporary)
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "no free temporary file name", str(target))
