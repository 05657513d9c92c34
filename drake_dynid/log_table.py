"""The text layer of the log reader: bytes → header, numbers and row numbers.

Used by :func:`drake_dynid.logs.read_log`; every failure is a ``ValueError`` whose
message names the file and the row (the line number in the file, header = row 1 when
the file starts with it).

The file is read a block of about :data:`BLOCK_BYTES` at a time, cut at line ends,
so the text of a long log is never in memory at once: each block is decoded and
checked (UTF-8, NUL bytes), parsed by numpy's C reader when it is clean (no quote,
no blank line), else cell by cell, and its numbers go to a
:class:`~drake_dynid.log_store.RowSink` (in memory, or a temporary file for a long
log). A block never ends inside a quoted cell. Parsing a block is parsing its lines:
the numbers and messages are those of the whole file read at once.
"""

from __future__ import annotations

import csv
import io
import math
import re
import warnings as warnings_module
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core._validate import LISTED_NAMES, listed
from drake_dynid.core.blocks import is_stored
from drake_dynid.files import incomplete_export
from drake_dynid.log_store import RowSink

BLOCK_BYTES = 1 << 21
"""Bytes of text read and parsed at a time."""

NANOSECONDS = 1e17  # integer stamps from here on: nanoseconds since the epoch

_BLANK_START = re.compile(r"[ \t]*(?:\n|\Z)")  # a blank first line
_BLANK_INNER = re.compile(r"\n[ \t]*\n")  # a blank line after a line end
_LEADING_BLANK = re.compile(r"(?:[ \t]*\n)*")


class LineNumbers:
    """Line numbers ``first + i`` of consecutive rows i = 0..count-1 (lazy).

    Indexing by an integer, a boolean mask or an integer array gives what the
    array ``first + np.arange(count)`` would.
    """

    def __init__(self, first: int, count: int):
        self.first = int(first)
        self.count = int(count)

    def __len__(self) -> int:
        return self.count

    @property
    def size(self) -> int:
        """Number of rows."""
        return self.count

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, (int, np.integer)):
            i = int(index) + (self.count if index < 0 else 0)
            if not 0 <= i < self.count:
                raise IndexError(f"row {index} is out of bounds for {self.count}")
            return self.first + i
        array = np.asarray(index)
        if array.dtype == bool:
            return self.first + np.flatnonzero(array)
        array = np.where(array < 0, array + self.count, array).astype(np.int64)
        if array.size and (array.min() < 0 or array.max() >= self.count):
            raise IndexError(f"row index out of bounds for {self.count}")
        return self.first + array

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self.first + np.arange(self.count)
        return out if dtype is None else out.astype(dtype, copy=False)


@dataclass
class Table:
    """Header and numbers of a CSV log.

    Attributes:
        header: the column names, stripped.
        t: (R,) numbers of the first wanted column (the time), NaN when empty;
            a stored array (a temporary file) when ``parts`` are.
        parts: the other wanted columns in consecutive groups (``groups``), each
            (R, width): an array, or a :class:`~drake_dynid.log_store.StoredArray`
            for a long log; NaN for empty cells.
        rows: (R,) line number in the file of each data row (an int64 array or a
            :class:`LineNumbers`).
        bad: (R,) bool, True where a cell of ``parts`` is not finite.
        exact: (R,) int64 time stamps as written (integer nanoseconds; 0 where t
            is not finite) when every finite t is >= 1e17 and written as an
            integer; else None.
        notes: what was repaired while reading (a truncated last row).
    """

    header: list[str]
    t: np.ndarray
    parts: tuple[Any, ...]
    rows: Any
    bad: np.ndarray
    exact: np.ndarray | None
    notes: list[str]


#: (leading bytes, what the file is, the fix) of compressed files given as a log.
_COMPRESSED = (
    (b"\x1f\x8b", "gzip-compressed", "decompress (gunzip)"),
    (b"BZh", "bzip2-compressed", "decompress (bunzip2)"),
    (b"\xfd7zXZ\x00", "xz-compressed", "decompress (unxz)"),
    (b"\x28\xb5\x2f\xfd", "zstd-compressed", "decompress (unzstd)"),
    (b"PK\x03\x04", "a zip archive (or a spreadsheet)", "extract (or export as CSV)"),
)


def decode(path: str, raw: bytes, offset: int = 0, lines: int = 0) -> str:
    """UTF-8 text of a block of the file (a byte-order mark is dropped), or an error.

    Args:
        path: the file, for the messages.
        raw: the bytes of the block, starting at a line start.
        offset: byte offset of the block in the file.
        lines: line ends before the block.
    """
    if offset == 0 and raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ValueError(
            f"log {path}: the file is UTF-16 or UTF-32 text (byte-order mark "
            f"{raw[:2].hex(' ')}); expected UTF-8: save the log as UTF-8 CSV."
        )
    if offset == 0:
        for magic, kind, fix in _COMPRESSED:
            if raw.startswith(magic):
                raise ValueError(
                    f"log {path}: the file is {kind} (it starts with bytes "
                    f"{magic.hex(' ')}), not CSV text: {fix} it first and give the "
                    "CSV file."
                )
    skip = 3 if offset == 0 and raw.startswith(b"\xef\xbb\xbf") else 0
    nul = raw.find(b"\x00")
    try:
        text = raw[skip:].decode("utf-8")
    except UnicodeDecodeError as error:
        start = error.start + skip  # in raw
        line = lines + raw.count(b"\n", 0, start) + 1
        column = start - (raw.rfind(b"\n", 0, start) + 1) + 1
        raise ValueError(
            f"log {path}: not UTF-8 text: byte {offset + start} (line {line}, column "
            f"{column}) is 0x{raw[start]:02x}; expected UTF-8 (or ASCII): save the "
            "log as UTF-8 CSV (e.g. iconv -f latin1 -t utf-8)."
        ) from None
    if nul >= 0:
        line = lines + raw.count(b"\n", 0, nul) + 1
        raise ValueError(
            f"log {path}: not a text file: byte {offset + nul} (line {line}) is NUL; "
            "expected a UTF-8 CSV file."
        )
    if "\r" in text:  # Windows and old Mac line ends
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text


def _texts(path: str, stream: Any) -> Iterator[tuple[str, bool]]:
    """(decoded text, last) blocks of the file, each cut after a line end.

    A block is extended to the next line end, and past a line end inside a
    quoted cell (an odd number of quotes so far), so that no row is split.
    """
    previous = None
    for text in _decoded(path, stream):
        if previous is not None:
            yield previous, False
        previous = text
    if previous is not None:
        yield previous, True


def _decoded(path: str, stream: Any) -> Iterator[str]:
    offset = lines = 0
    pending = b""
    eof = False
    while not eof:
        chunk = stream.read(BLOCK_BYTES)
        eof = not chunk
        data = pending + chunk
        cut = len(data) if eof else data.rfind(b"\n") + 1
        if not eof and (cut == 0 or data.count(b'"', 0, cut) % 2):
            pending = data  # no complete row yet, or inside a quoted cell
            continue
        raw, pending = data[:cut], data[cut:]
        if raw:
            yield decode(path, raw, offset, lines)
            offset += len(raw)
            lines += raw.count(b"\n")


def _split_header(path: str, text: str, first_line: int) -> tuple[list[str], str, int]:
    """Header cells, the text after it and the line number of its first line."""
    lead = _LEADING_BLANK.match(text)
    start = lead.end() if lead else 0
    header_line = first_line + text.count("\n", 0, start)
    end = text.find("\n", start)
    end = len(text) if end < 0 else end
    try:
        header = next(csv.reader([text[start:end]]))
    except (csv.Error, StopIteration) as error:
        raise ValueError(
            f"log {path}: row {header_line}: the header is not valid CSV ({error})."
        ) from None
    return [cell.strip() for cell in header], text[end + 1 :], header_line + 1


#: The most joints whose ``--joints`` value the reader's hint prints to copy
#: (a 100-joint value is a line of about 1.5 kB; a ROS bag's 2000 made 16 kB).
COPIED_JOINTS = 100


def _format_hint(header: Sequence[str], wanted: Sequence[str]) -> str:
    """What the header suggests when wanted columns are missing ('' if nothing)."""
    if len(header) == 1 and any(sep in header[0] for sep in ";\t|"):
        return (
            "; the header looks separated by another character than a comma: "
            "the log must be comma-separated (CSV)"
        )
    joints = [name[2:] for name in wanted if name.startswith("q_")]
    present = [j for j in joints if f"q_{j}" in header and f"tau_{j}" in header]
    if present and len(present) < len(joints):
        # The --joints value to copy, while it is one (the listed names are not):
        # beyond LISTED_NAMES, only that value names them (one list, not two).
        # The other joints' positions are not in the log: where they were held
        # must be said (a log of `dynid simulate --joints J --lock L`).
        locks = " (the others locked at 0 or where --lock NAME=VALUE,... held them)"
        value = ",".join(present)
        if len(present) <= LISTED_NAMES:
            return (
                f"; the log holds {listed(present)} only: --joints {value} "
                f"identifies those alone{locks}"
            )
        if len(present) <= COPIED_JOINTS:
            return (
                f"; the log holds {len(present)} of the {len(joints)} joints only: "
                f"--joints {value} identifies those alone{locks}"
            )
        return (
            f"; the log holds {listed(present)} only: --joints with those names "
            f"identifies them alone{locks}"
        )
    logged = [n[2:] for n in header if n.startswith("q_") and f"tau_{n[2:]}" in header]
    if logged and not present:
        shown = listed(logged)
        return (
            f"; the log holds the joints {shown}, not the ones asked for (check "
            "--urdf and --joints)"
        )
    if "t" not in header and wanted and wanted[0] == "t":
        named = [n for n in header if n.lower() in ("time", "timestamp", "stamp", "ts")]
        if named:
            return (
                f"; a time column named {named[0]!r}: rename it t, or describe the "
                f'log in a drive file ([log] time = "{named[0]}", docs/DRIVE.md)'
            )
    return (
        "; other column names are described in a drive file ([log] time, position "
        "and torque templates, docs/DRIVE.md)"
    )


#: Column names a reader's warning lists before it counts the rest.
LISTED_COLUMNS = 6


def listed_columns(names: Sequence[str]) -> str:
    """``"a, b, c"``; of more than ``LISTED_COLUMNS``, the first ones ``"and N more"``.

    The list of the readers' extra-columns warnings (20 000 extra columns made
    a 149 kB line).
    """
    return listed(names, LISTED_COLUMNS)


def unused_columns(header: Sequence[str], used: Any) -> list[str]:
    """The named columns of ``header`` not in ``used``, for the reader's warning.

    A column without a name is not listed when it is the last one (a logger's
    trailing comma on every row, the header included); elsewhere it is named by
    its position ("unnamed column 3").
    """
    out = []
    for k, name in enumerate(header):
        if name in used:
            continue
        if name:
            out.append(name)
        elif k < len(header) - 1:
            out.append(f"unnamed column {k + 1}")
    return out


def _blank_line(text: str) -> bool:
    """True when a line of ``text`` is empty or only spaces and tabs."""
    if _BLANK_START.match(text) or _BLANK_INNER.search(text):
        return True
    end = text.rfind("\n")
    return end >= 0 and not text[end + 1 :].strip(" \t")


def _lines(body: str) -> list[str]:
    r"""The lines of a block (split at ``\n`` only), without the last line end."""
    lines = body.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    return lines


def _fast(body: str, width: int, index: list[int], last: bool = True):
    """Numbers of a clean block with numpy's C parser, else None."""
    clean = body.rstrip("\n \t") if last else body[:-1]
    if '"' in body or _blank_line(clean):
        return None
    lines = _lines(body)
    columns = None
    if lines and lines[0].rstrip().endswith(","):  # a logger's trailing commas?
        if not all(
            line.count(",") == width and line.rstrip().endswith(",") for line in lines
        ):
            return None
        columns = range(width)  # every row: width cells and one empty one
    try:
        with warnings_module.catch_warnings():
            warnings_module.simplefilter("error")  # "input contained no data"
            numbers = np.loadtxt(
                lines,
                delimiter=",",
                ndmin=2,
                dtype=float,
                comments=None,
                usecols=columns,
            )
    except Exception:  # any parse failure: the cell-by-cell reader names it
        return None
    if numbers.shape[1] != width:
        return None
    return numbers[:, index]


def parse_cell(path: str, text: str, row: int, column: str) -> float:
    """One CSV cell as a number: empty is NaN, anything but a number a ValueError."""
    text = text.strip()
    if text == "":
        return float("nan")
    try:
        # Python's float() also reads '0_5' (as 5) and non-ASCII digits ('１７'):
        # not numbers a logger writes, and not what numpy's parser accepts.
        if "_" in text or not text.isascii():
            raise ValueError(text)
        return float(text)
    except ValueError:
        shown = text if len(text) <= 40 else text[:40] + "..."
        raise ValueError(
            f"log {path}: row {row}, column '{column}': '{shown}' is not a number."
        ) from None


def _records(path: str, body: str, first_line: int) -> list[tuple[int, list[str]]]:
    """(line, cells) of the non-blank CSV records of a block."""
    reader = csv.reader(io.StringIO(body))
    records: list[tuple[int, list[str]]] = []
    line = first_line
    try:
        for record in reader:
            if any(cell.strip() for cell in record):
                records.append((line, record))
            line = first_line + reader.line_num
    except csv.Error as error:
        raise ValueError(f"log {path}: row {line}: not valid CSV ({error}).") from None
    return records


def _slow(path, records, header, index, wanted):
    """Cell by cell, with messages naming the row and the column."""
    data = np.empty((len(records), len(index)))
    for r, (row, record) in enumerate(records):
        if len(record) > len(header) and not any(
            c.strip() for c in record[len(header) :]
        ):
            record = record[: len(header)]  # trailing commas: empty extra cells
        if len(record) != len(header):
            cut = record and incomplete_export(path, row, record[0])
            if cut:
                raise ValueError(cut)
            raise ValueError(
                f"log {path}: row {row} has {len(record)} cells; the header has "
                f"{len(header)}."
            )
        for c, i in enumerate(index):
            data[r, c] = parse_cell(path, record[i], row, wanted[c])
    rows = np.array([row for row, _ in records], dtype=np.int64)
    return data, rows


def _exact_stamps(cells: Sequence[str], t: np.ndarray) -> np.ndarray | None:
    """Integer stamps as written (0 where t is not finite), None when one is not."""
    out = np.zeros(t.size, np.int64)
    if len(cells) != t.size:
        return None
    try:
        for i in np.flatnonzero(np.isfinite(t)).tolist():
            out[i] = int(cells[i])
    except (ValueError, OverflowError):
        return None
    return out


class _Stamps:
    """Collects the time column, and its exact integers while they can be read."""

    def __init__(self) -> None:
        self.t = RowSink(1, limit=math.inf)
        self.exact: list[np.ndarray] | None = []

    def add(self, t: np.ndarray, cells: Any) -> None:
        self.t.append(t)
        if self.exact is None:
            return
        finite = t[np.isfinite(t)]
        if finite.size and finite.min() < NANOSECONDS:
            self.exact = None  # seconds: no exact integers needed
            return
        exact = _exact_stamps(cells(), t) if finite.size else np.zeros(t.size, np.int64)
        self.exact = None if exact is None else [*self.exact, exact]

    def finish(self, stored: bool) -> tuple[Any, np.ndarray | None]:
        """(t, exact): t stays in its file when ``stored`` (a long log)."""
        self.t.limit = 0 if stored else math.inf
        t = self.t.finish(vector=True)
        if self.exact is None:
            return t, None
        exact = np.concatenate(self.exact)
        return (t, exact) if np.isfinite(np.asarray(t)).any() else (t, None)


def _header_block(
    path: str, texts: Iterator[tuple[str, bool]]
) -> tuple[list[str], str, int, bool]:
    """(header cells, rest of the block, its first line number, last block)."""
    line = 1
    text, last = "", True
    for item in texts:  # leading blank lines: until the header
        text, last = item
        if text.strip():
            break
        line += text.count("\n")
    if not text.strip():
        raise ValueError(f"log {path}: the file is empty; expected a header row.")
    header, body, body_line = _split_header(path, text, line)
    return header, body, body_line, last


def read_header(path: str, stream: Any) -> list[str]:
    """The header's cells (the first non-blank row), reading no further.

    Args:
        path: the file, for the messages.
        stream: the file opened in binary mode (read a line at a time).

    Raises:
        ValueError: an empty file, a header that is not CSV, bytes that are not
            UTF-8 up to the header's end (the messages of :func:`read_table`).
    """
    raw = b""
    while True:
        line = stream.readline()
        raw += line
        text = decode(path, raw)
        if text.strip() or not line:
            return _header_block(path, iter([(text, not line)]))[0]


#: ``parse``'s data not computed yet (None: the fast parser declined the block).
_UNPARSED = object()


def read_table(
    path: str,
    stream: Any,
    wanted: list[str],
    groups: Sequence[int],
    *,
    beside: Callable[[Callable[[], Any]], Any] | None = None,
) -> Table:
    """Parses a log; checks the header against the ``wanted`` columns.

    Args:
        path: the file, for the messages.
        stream: the file opened in binary mode.
        wanted: the columns to read, the time first.
        groups: widths of the consecutive groups of ``wanted[1:]`` returned as
            ``Table.parts`` (e.g. n positions, n torques).
        beside: parse the second half of the file's blocks in another process
            while this one parses the first: ``beside(function)`` is a context
            manager whose ``result()`` is ``function()`` (e.g.
            ``commands._background.Background``, a fork). The whole file is then
            held as text (for a log of at most a few tens of MB); the result is
            the same table.
    """
    texts = _texts(path, stream)
    header, body, body_line, last = _header_block(path, texts)
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        names = listed(f"'{name}'" for name in duplicated)
        raise ValueError(f"log {path}: duplicated column(s) {names}.")
    missing = [name for name in wanted if name not in header]
    if missing:
        raise ValueError(
            f"log {path}: missing column(s) {listed(missing)}; the header must hold "
            "t, q_<joint> and tau_<joint> for every joint "
            f"(found: {listed(header)}){_format_hint(header, wanted)}."
        )
    index = [header.index(name) for name in wanted]
    bounds = np.cumsum([1, *groups])
    sinks = [RowSink(width) for width in groups]
    stamps = _Stamps()
    bad: list[np.ndarray] = []
    rows: list[Any] = []  # per block: (first line, count) or a line array
    notes: list[str] = []
    count = 0

    def drop_unended(body: str, first: int) -> str:
        """The block without the file's last row when that row has no line end.

        A logger interrupted mid-row may have cut its last cell ('-1.7012' read
        as '-1'); dropped when at least 2 rows remain.
        """
        cut = body.rfind("\n") + 1
        tail, kept = body[cut:], body[:cut]
        rows_before = count + sum(1 for line in kept.split("\n") if line.strip())
        if not tail.strip() or rows_before < 2:
            return body
        row = first + kept.count("\n")
        cells = next(csv.reader([tail]), [])
        shown = (
            f"cut short ({len(cells)} of {len(header)} cells, no line end"
            if len(cells) < len(header)
            else "without a line end (its last cell may be cut"
        )
        notes.append(
            f"the last row {row} is {shown}: was the logger interrupted?): dropped."
        )
        return kept

    def parse(body: str, first: int, final: bool, data: Any = _UNPARSED) -> None:
        nonlocal count
        if final and body and not body.endswith("\n"):
            body = drop_unended(body, first)
        if data is _UNPARSED:
            data = _fast(body, len(header), index, final)
        lines: Any
        if data is not None:
            lines = (first, data.shape[0])

            def cells() -> list[str]:
                full = (r for r in _lines(body) if r.strip())
                return [r.split(",")[index[0]].strip() for r in full]

        else:
            records = _records(path, body, first)
            data, lines = _slow(path, records, header, index, wanted)

            def cells() -> list[str]:
                return [record[index[0]].strip() for _, record in records]

        if data.shape[0] == 0:
            return
        count += data.shape[0]
        stamps.add(data[:, 0], cells)
        for sink, a, b in zip(sinks, bounds[:-1], bounds[1:], strict=True):
            sink.append(data[:, a:b])
        bad.append(~np.all(np.isfinite(data[:, 1:]), axis=1))
        rows.append(lines)

    blocks = [(body, body_line, last)]
    line = body_line + body.count("\n")
    for text, last in texts:
        if beside is None:
            parse(*blocks.pop())
        blocks.append((text, line, last))
        line += text.count("\n")
    half = len(blocks) // 2
    # The final block is parsed here (its row without a line end is dropped).
    later = [block for block in blocks[half:] if not block[2]]
    if beside is not None and half >= 1 and later:
        width = len(header)
        with beside(lambda: [_fast(b[0], width, index, False) for b in later]) as other:
            for block in blocks[:half]:
                parse(*block)
            parsed = other.result()
        for block, data in zip(later, parsed, strict=True):
            parse(*block, data=data)
        blocks = [block for block in blocks[half:] if block[2]]
    for block in blocks:
        parse(*block)
    if count == 0:
        raise ValueError(f"log {path}: the header has no data rows below it.")
    parts = tuple(sink.finish() for sink in sinks)
    t, exact = stamps.finish(any(is_stored(part) for part in parts))
    return Table(
        header,
        t,
        parts,
        _line_numbers(rows),
        np.concatenate(bad),
        exact,
        notes,
    )


def _line_numbers(rows: list[Any]) -> Any:
    """One :class:`LineNumbers` when the rows are consecutive lines, else an array."""
    first, total, consecutive = None, 0, True
    for part in rows:
        if not isinstance(part, tuple):
            consecutive = False
            break
        start, count = part
        if first is None:
            first = start
        consecutive = consecutive and start == first + total
        total += count
    if consecutive and first is not None:
        return LineNumbers(first, total)
    return np.concatenate(
        [
            part if not isinstance(part, tuple) else part[0] + np.arange(part[1])
            for part in rows
        ]
    ).astype(np.int64)
