"""Long logs on disk: float64 rows in a temporary file, read a block at a time.

A 1-hour log of a 7-DOF arm at 1 kHz holds 3.6 M samples of 14 values: 403 MB of
float64, more than the whole off-line identification needs at any moment.
:func:`drake_dynid.logs.read_log` therefore keeps q and τ, when each is larger
than :data:`SPILL_BYTES`, in unnamed temporary files (``tempfile.TemporaryFile``, in
``TMPDIR``; the operating system deletes them when the log is garbage-collected or
the process ends) and gives the :class:`~drake_dynid.logs.RobotLog` array-likes:

* :class:`StoredArray`: (N, c) float64, read-only. Indexing with an integer, a
  slice or an array of row indices reads only the rows needed (``os.pread``, never
  a memory map: the rows read are the caller's own memory, freed with it, and do
  not stay resident); ``np.asarray`` reads it all (any numpy function does).
* :class:`GridTimes`: the times ``h·k``, k = 0..N-1, computed when indexed.

Both have ``rows(a, b)``, a lazy view of rows [a, b). The streamed consumers
(the off-line IDIM, the automatic settings, the dead-zone widths, the core
replay) index them a block of rows at a time (``drake_dynid.core.blocks``).
Logs up to :data:`SPILL_BYTES` stay in memory as plain arrays. Numbers are the
same either way: the file holds the float64 values themselves.
"""

from __future__ import annotations

import os
import tempfile
import weakref
from typing import Any, cast

import numpy as np

__all__ = ["BUFFER_BYTES", "SPILL_BYTES", "GridTimes", "RowSink", "StoredArray"]

SPILL_BYTES = 32 << 20
"""q (or τ) beyond this many bytes of float64 is kept on disk (q and τ together:
64 MiB, about 10 minutes of a 7-DOF arm at 1 kHz)."""

_READ_BYTES = 1 << 22  # largest single read (no larger temporary without preadv)


class _RowFile:
    """An unnamed temporary file of float64 rows of ``width`` values."""

    def __init__(self, width: int):
        self.width = int(width)
        self.rows = 0
        self._file = tempfile.TemporaryFile(prefix="dynid-log-")
        self._fd = self._file.fileno()
        # Closed (and so deleted) with the last array that reads it.
        weakref.finalize(self, self._file.close)

    def append(self, block: np.ndarray) -> None:
        data = np.ascontiguousarray(block, dtype=np.float64)
        view = memoryview(cast(Any, data)).cast("B")
        offset = self.rows * self.width * 8
        while view:
            written = os.pwrite(self._fd, view, offset)
            view, offset = view[written:], offset + written
        self.rows += data.shape[0]

    def read(self, start: int, stop: int) -> np.ndarray:
        """Rows [start, stop) as a fresh (stop - start, width) array."""
        count = max(0, stop - start)
        out = np.empty((count, self.width))
        view = memoryview(cast(Any, out)).cast("B")
        offset = start * self.width * 8
        while view:
            part = view[:_READ_BYTES]
            if hasattr(os, "preadv"):  # straight into the array
                done = os.preadv(self._fd, [part], offset)
            else:
                data = os.pread(self._fd, len(part), offset)
                done = len(data)
                part[:done] = data
            if not done:
                raise OSError(
                    f"log store: the temporary file ended at byte {offset}; was it "
                    "truncated?"
                )
            view, offset = view[done:], offset + done
        return out


class StoredArray:
    """(N, c) float64 rows kept in a temporary file (module docstring).

    Supports ``len``, ``shape``, ``ndim``, ``dtype``, ``size``, ``nbytes``,
    indexing by an integer, a slice, an integer array or a boolean mask of the
    rows (optionally followed by a column index), ``rows(a, b)`` (a lazy view)
    and ``np.asarray`` (reads it all). Read-only. ``vector``: one column seen as
    an (N,) array.
    """

    __array_priority__ = 1.0

    def __init__(
        self,
        store: _RowFile,
        start: int = 0,
        stop: int | None = None,
        vector: bool = False,
    ):
        self._file = store
        self._start = int(start)
        self._stop = store.rows if stop is None else int(stop)
        self._vector = bool(vector) and store.width == 1

    @property
    def shape(self) -> tuple[int, ...]:
        """(N, c), or (N,) for a vector."""
        count = self._stop - self._start
        return (count,) if self._vector else (count, self._file.width)

    @property
    def ndim(self) -> int:
        """1 for a vector, else 2."""
        return 1 if self._vector else 2

    @property
    def dtype(self) -> np.dtype:
        """float64."""
        return np.dtype(np.float64)

    @property
    def size(self) -> int:
        """Number of values."""
        return (self._stop - self._start) * self._file.width

    @property
    def nbytes(self) -> int:
        """Bytes of the values (on disk)."""
        return 8 * self.size

    def __len__(self) -> int:
        return self._stop - self._start

    def __repr__(self) -> str:
        return f"StoredArray(shape={self.shape}, in a temporary file)"

    def rows(self, start: int, stop: int) -> StoredArray:
        """A lazy view of rows [start, stop) (clipped as a slice would be)."""
        start, stop, _ = slice(start, stop).indices(len(self))
        first = self._start + start
        last = first + max(0, stop - start)
        return StoredArray(self._file, first, last, self._vector)

    def _read(self, start: int, stop: int) -> np.ndarray:
        out = self._file.read(self._start + start, self._start + stop)
        return out[:, 0] if self._vector else out

    def _span(self, index: Any) -> tuple[int, int, Any]:
        """(low, high, index shifted to rows [low, high)) of a row index."""
        n = len(self)
        if isinstance(index, slice):
            start, stop, step = index.indices(n)
            picked = range(start, stop, step)
            if len(picked) == 0:
                return 0, 0, slice(0, 0)
            low, high = min(picked[0], picked[-1]), max(picked[0], picked[-1]) + 1
            end = stop - low
            return low, high, slice(start - low, end if end >= 0 else None, step)
        if isinstance(index, (int, np.integer)):
            i = int(index) + (n if index < 0 else 0)
            if not 0 <= i < n:
                raise IndexError(f"index {index} is out of bounds for {n} rows")
            return i, i + 1, 0
        array = np.asarray(index)
        if array.dtype == bool:
            if array.shape != (n,):
                raise IndexError(f"boolean index of shape {array.shape} for {n} rows")
            array = np.flatnonzero(array)
        if array.dtype.kind not in "iu":
            raise IndexError(f"rows must be indexed by integers; got {array.dtype}")
        flat = np.where(array < 0, array + n, array).astype(np.int64)
        if flat.size == 0:
            return 0, 0, flat
        low, high = int(flat.min()), int(flat.max()) + 1
        if low < 0 or high > n:
            raise IndexError(f"row index out of bounds for {n} rows")
        return low, high, flat - low

    def __getitem__(self, index: Any) -> Any:
        """Reads only the rows the index needs; numpy's indexing rules on them."""
        if not isinstance(index, tuple):
            index = (index,)
        if len(index) == 0 or index[0] is Ellipsis:
            return np.asarray(self)[index]
        low, high, rows = self._span(index[0])
        return self._read(low, high)[(rows, *index[1:])]

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self._read(0, len(self))
        return out if dtype is None else out.astype(dtype, copy=False)


class GridTimes:
    """The times ``step·k`` [s], k = 0..N-1, computed when indexed (read-only).

    Equal, element by element, to ``step * np.arange(count)``.
    """

    __array_priority__ = 1.0

    def __init__(self, step: float, count: int, start: int = 0):
        self.step = float(step)
        self.count = int(count)
        self.start = int(start)  # k of element 0

    def rows(self, start: int, stop: int) -> GridTimes:
        """A lazy view of elements [start, stop) (clipped as a slice would be)."""
        start, stop, _ = slice(start, stop).indices(self.count)
        return GridTimes(self.step, max(start, stop) - start, self.start + start)

    @property
    def shape(self) -> tuple[int]:
        """(N,)."""
        return (self.count,)

    @property
    def ndim(self) -> int:
        """1."""
        return 1

    @property
    def dtype(self) -> np.dtype:
        """float64."""
        return np.dtype(np.float64)

    @property
    def size(self) -> int:
        """N."""
        return self.count

    @property
    def nbytes(self) -> int:
        """8·N (none held)."""
        return 8 * self.count

    def __len__(self) -> int:
        return self.count

    def __repr__(self) -> str:
        return f"GridTimes(step={self.step!r}, count={self.count}, start={self.start})"

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, tuple) and len(index) == 1:
            index = index[0]
        if isinstance(index, slice):
            k = np.arange(*index.indices(self.count))
        elif isinstance(index, (int, np.integer)):
            i = int(index) + (self.count if index < 0 else 0)
            if not 0 <= i < self.count:
                raise IndexError(f"index {index} is out of bounds for {self.count}")
            return self.step * np.float64(self.start + i)
        else:
            k = np.arange(self.count)[np.asarray(index)]
        return self.step * (k + self.start)

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        out = self.step * np.arange(self.start, self.start + self.count)
        return out if dtype is None else out.astype(dtype, copy=False)


BUFFER_BYTES = 1 << 20
"""A :class:`RowSink` keeps up to this many bytes in memory before its file."""


class RowSink:
    """Collects blocks of (R, c) float64 rows, in memory of a few blocks.

    The first :data:`BUFFER_BYTES` stay in memory; beyond, every block goes to a
    temporary file. :meth:`finish` returns the rows as one array when they take
    at most ``limit`` bytes (read back from the file: no copy of the parts),
    else as a :class:`StoredArray`.
    """

    def __init__(self, width: int, limit: float | None = None):
        self.width = int(width)
        self.limit = SPILL_BYTES if limit is None else limit
        self.rows = 0
        self._parts: list[np.ndarray] = []
        self._file: _RowFile | None = None

    def append(self, block: np.ndarray) -> None:
        """Adds (R, c) rows after the others."""
        block = np.asarray(block, dtype=np.float64).reshape(-1, self.width)
        self.rows += block.shape[0]
        if self._file is None and self.rows * self.width * 8 > BUFFER_BYTES:
            self._file = _RowFile(self.width)
            for part in self._parts:
                self._file.append(part)
            self._parts = []
        if self._file is not None:
            self._file.append(block)
        else:
            self._parts.append(np.array(block, copy=True))

    def finish(self, vector: bool = False) -> Any:
        """The rows: an (R, c) array, or a :class:`StoredArray` beyond ``limit``.

        ``vector`` (one column): (R,) instead of (R, 1).
        """
        if self._file is not None:
            if self.rows * self.width * 8 > self.limit:
                return StoredArray(self._file, vector=vector)
            out = self._file.read(0, self.rows)  # the file closes with the sink
        elif not self._parts:
            out = np.empty((0, self.width))
        else:
            out = np.concatenate(self._parts)
            self._parts = []
        return out[:, 0] if vector and self.width == 1 else out
