"""The text layer of the log reader: bytes → header, numbers and row numbers.

Used by :func:`drake_dynid.logs.read_log`; every failure is a ``ValueError`` whose
message names the file and the row (the line number in the file, header = row 1 when
the file starts with it).
"""

from __future__ import annotations

import csv
import io
import re
import warnings as warnings_module
from dataclasses import dataclass

import numpy as np

_BLANK_LINE = re.compile(r"(?:^|\n)[ \t]*(?:\n|$)")
_LEADING_BLANK = re.compile(r"(?:[ \t]*\n)*")


@dataclass
class Table:
    """Header and numbers of a CSV log.

    Attributes:
        header: the column names, stripped.
        data: (R, len(wanted)) numbers of the wanted columns, NaN for empty cells.
        rows: (R,) line number in the file of each data row.
        notes: what was repaired while reading (a truncated last row).
        body: the text below the header (for an exact re-read of a column).
        body_line: line number of the first line of ``body``.
    """

    header: list[str]
    data: np.ndarray
    rows: np.ndarray
    notes: list[str]
    body: str
    body_line: int


def decode(path: str, raw: bytes) -> str:
    """UTF-8 text of the file (a byte-order mark is dropped), or a clear error."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise ValueError(
            f"log {path}: the file is UTF-16 or UTF-32 text (byte-order mark "
            f"{raw[:2].hex(' ')}); expected UTF-8: save the log as UTF-8 CSV."
        )
    nul = raw.find(b"\x00")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        start = error.start
        line = raw.count(b"\n", 0, start) + 1
        column = start - (raw.rfind(b"\n", 0, start) + 1) + 1
        raise ValueError(
            f"log {path}: not UTF-8 text: byte {start} (line {line}, column {column}) "
            f"is 0x{raw[start]:02x}; expected UTF-8 (or ASCII): save the log as UTF-8 "
            "CSV (e.g. iconv -f latin1 -t utf-8)."
        ) from None
    if nul >= 0:
        line = raw.count(b"\n", 0, nul) + 1
        raise ValueError(
            f"log {path}: not a text file: byte {nul} (line {line}) is NUL; expected "
            "a UTF-8 CSV file."
        )
    if "\r" in text:  # Windows and old Mac line ends
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    return text


def _split_header(path: str, text: str) -> tuple[list[str], str, int]:
    """Header cells, body text and the line number of the body's first line."""
    lead = _LEADING_BLANK.match(text)
    start = lead.end() if lead else 0
    if start >= len(text) or not text[start:].strip():
        raise ValueError(f"log {path}: the file is empty; expected a header row.")
    header_line = text.count("\n", 0, start) + 1
    end = text.find("\n", start)
    end = len(text) if end < 0 else end
    try:
        header = next(csv.reader([text[start:end]]))
    except (csv.Error, StopIteration) as error:
        raise ValueError(
            f"log {path}: row {header_line}: the header is not valid CSV ({error})."
        ) from None
    return [cell.strip() for cell in header], text[end + 1 :], header_line + 1


def _fast(body: str, width: int, index: list[int]) -> np.ndarray | None:
    """Numbers of a clean body with numpy's C parser, else None."""
    if '"' in body or _BLANK_LINE.search(body.rstrip("\n \t")):
        return None
    try:
        with warnings_module.catch_warnings():
            warnings_module.simplefilter("error")  # "input contained no data"
            numbers = np.loadtxt(
                io.StringIO(body), delimiter=",", ndmin=2, dtype=float, comments=None
            )
    except Exception:  # any parse failure: the cell-by-cell reader names it
        return None
    if numbers.shape[1] != width:
        return None
    return numbers[:, index]


def _cell(path: str, text: str, row: int, column: str) -> float:
    text = text.strip()
    if text == "":
        return float("nan")
    try:
        return float(text)
    except ValueError:
        shown = text if len(text) <= 40 else text[:40] + "..."
        raise ValueError(
            f"log {path}: row {row}, column '{column}': '{shown}' is not a number."
        ) from None


def _slow(path, body, first_line, header, index, wanted, notes):
    """Cell by cell, with messages naming the row and the column."""
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
    truncated = not body.endswith("\n")  # no line end after the last row
    if truncated and len(records) >= 3 and len(records[-1][1]) < len(header):
        row, record = records.pop()
        notes.append(
            f"the last row {row} is cut short ({len(record)} of {len(header)} "
            "cells, no line end: was the logger interrupted?): dropped."
        )
    data = np.empty((len(records), len(index)))
    for r, (row, record) in enumerate(records):
        if len(record) != len(header):
            raise ValueError(
                f"log {path}: row {row} has {len(record)} cells; the header has "
                f"{len(header)}."
            )
        for c, i in enumerate(index):
            data[r, c] = _cell(path, record[i], row, wanted[c])
    rows = np.array([row for row, _ in records], dtype=np.int64)
    return data, rows


def read_table(path: str, raw: bytes, wanted: list[str]) -> Table:
    """Decodes and parses a log; checks the header against the ``wanted`` columns."""
    text = decode(path, raw)
    header, body, body_line = _split_header(path, text)
    duplicated = sorted({name for name in header if header.count(name) > 1})
    if duplicated:
        names = ", ".join(f"'{name}'" for name in duplicated)
        raise ValueError(f"log {path}: duplicated column(s) {names}.")
    missing = [name for name in wanted if name not in header]
    if missing:
        raise ValueError(
            f"log {path}: missing column(s) {', '.join(missing)}; the header must hold "
            "t, q_<joint> and tau_<joint> for every joint "
            f"(found: {', '.join(header)})."
        )
    index = [header.index(name) for name in wanted]
    notes: list[str] = []
    data = _fast(body, len(header), index)
    if data is not None:
        rows = body_line + np.arange(data.shape[0], dtype=np.int64)
    else:
        data, rows = _slow(path, body, body_line, header, index, wanted, notes)
    if data.shape[0] == 0:
        raise ValueError(f"log {path}: the header has no data rows below it.")
    return Table(header, data, rows, notes, body, body_line)


def column_text(table: Table, column: int) -> list[str]:
    """The cells of one column, as written, for the rows of ``table.data``."""
    wanted = set(table.rows.tolist())
    cells = []
    reader = csv.reader(io.StringIO(table.body))
    line = table.body_line
    for record in reader:
        if line in wanted and column < len(record):
            cells.append(record[column].strip())
        line = table.body_line + reader.line_num
    return cells
