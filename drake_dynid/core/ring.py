"""Persistent chunked ring buffer: a fixed-length sliding window of samples.

The window holds the last ``capacity`` samples of ``channels`` floats each, oldest
first. It has **value semantics**: :meth:`ChunkRing.push` and :meth:`ChunkRing.extend`
return a new ring and never change the one they are called on, so every version
of the window stays valid. That is what a Drake abstract-state slot needs: the
Simulator deep-copies abstract state twice per step (docs/CONVENTIONS.md §7),
and copying a 20 000 × 34 numpy window twice per 1 ms step would cost more than the
identification itself.

Layout: the samples live in blocks of ``chunk_size`` rows. Full blocks are
**frozen** (read-only numpy arrays) and shared, in a tuple, by every ring version
that contains them; only the block being filled (the *tail*) is private.

* ``push`` writes one row into the tail in place when this ring version is the
  last one that wrote to it (the common, linear use), and copies the tail first
  otherwise (a branch: an older version pushed again). Rows a version can see
  are therefore never overwritten. Cost O(channels) amortised.
* ``copy.deepcopy`` copies only the tail (``chunk_size × channels`` floats); the
  tuple of frozen blocks is shared. The copy owns its tail.
* Not thread-safe: two threads must not push the *same* ring version at once.

Access: :attr:`ChunkRing.oldest` (the sample that leaves the window at the next
push once the window is full), :attr:`ChunkRing.newest`, :meth:`ChunkRing.head`
(the ``k`` oldest samples), :meth:`ChunkRing.tail` (the ``k`` newest) and
:meth:`ChunkRing.window` (all samples, oldest first,
for resynchronisation).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

_OWNER = "ChunkRing"


class _Claim:
    """Number of rows written so far into one tail buffer (shared by versions)."""

    __slots__ = ("rows",)

    def __init__(self, rows: int) -> None:
        self.rows = rows


class ChunkRing:
    """Fixed-capacity sliding window of float samples with value semantics.

    Args:
        capacity: number of samples kept (the window length), >= 1.
        channels: floats per sample, >= 1.
        chunk_size: rows per frozen block, >= 1. Default: about
            ``sqrt(capacity)`` clipped to [16, 256], which balances the tuple of
            blocks against the size of the copied tail.

    The window after pushes ``x_0 … x_{n-1}`` is ``x_{max(0, n-capacity)} …
    x_{n-1}`` (oldest first), exactly like ``collections.deque(maxlen=capacity)``.
    """

    __slots__ = (
        "_capacity",
        "_channels",
        "_chunk_size",
        "_chunks",
        "_claim",
        "_size",
        "_start",
        "_tail",
        "_tail_rows",
    )

    def __init__(
        self, capacity: int, channels: int, *, chunk_size: int | None = None
    ) -> None:
        capacity = v.integer(_OWNER, "capacity", capacity, minimum=1)
        channels = v.integer(_OWNER, "channels", channels, minimum=1)
        if chunk_size is None:
            chunk_size = int(min(256, max(16, round(np.sqrt(capacity)))))
        chunk_size = v.integer(_OWNER, "chunk_size", chunk_size, minimum=1)
        self._capacity = capacity
        self._channels = channels
        self._chunk_size = chunk_size
        self._chunks: tuple[np.ndarray, ...] = ()
        self._tail = np.empty((chunk_size, channels))
        self._tail_rows = 0
        self._claim = _Claim(0)
        self._start = 0  # offset of the oldest sample in the first block
        self._size = 0

    # -- read access ---------------------------------------------------------------

    @property
    def capacity(self) -> int:
        """Maximum number of samples in the window."""
        return self._capacity

    @property
    def channels(self) -> int:
        """Floats per sample."""
        return self._channels

    @property
    def chunk_size(self) -> int:
        """Rows per frozen block."""
        return self._chunk_size

    @property
    def size(self) -> int:
        """Number of samples currently in the window (<= capacity)."""
        return self._size

    def __len__(self) -> int:
        return self._size

    @property
    def is_full(self) -> bool:
        """True once ``capacity`` samples have been pushed."""
        return self._size == self._capacity

    def _row(self, index: int) -> np.ndarray:
        """Read-only view of sample ``index`` of the window (0 = oldest)."""
        position = self._start + index
        block, row = divmod(position, self._chunk_size)
        if block < len(self._chunks):
            out = self._chunks[block][row]
        else:
            out = self._tail[row]
            out = out.view()
            out.flags.writeable = False
        return out

    @property
    def oldest(self) -> np.ndarray:
        """The oldest sample (channels,): the one the next push evicts when full."""
        if self._size == 0:
            raise IndexError(f"{_OWNER}: the window is empty.")
        return self._row(0)

    @property
    def newest(self) -> np.ndarray:
        """The most recently pushed sample (channels,)."""
        if self._size == 0:
            raise IndexError(f"{_OWNER}: the window is empty.")
        return self._row(self._size - 1)

    def _blocks(self) -> list[np.ndarray]:
        blocks = list(self._chunks)
        if self._tail_rows:
            blocks.append(self._tail[: self._tail_rows])
        if blocks:
            blocks[0] = blocks[0][self._start :]
        return blocks

    def head(self, count: int) -> np.ndarray:
        """The ``count`` oldest samples, oldest first, as a new (count, c) array."""
        count = v.integer(_OWNER, "count", count, minimum=0)
        if count > self._size:
            v.fail(_OWNER, f"count must be <= size {self._size}; got {count}.")
        out = np.empty((count, self._channels))
        filled = 0
        for block in self._blocks():
            if filled == count:
                break
            take = min(count - filled, len(block))
            out[filled : filled + take] = block[:take]
            filled += take
        return out

    def tail(self, count: int) -> np.ndarray:
        """The ``count`` newest samples, oldest first, as a new (count, c) array."""
        count = v.integer(_OWNER, "count", count, minimum=0)
        if count > self._size:
            v.fail(_OWNER, f"count must be <= size {self._size}; got {count}.")
        out = np.empty((count, self._channels))
        filled = count
        for block in reversed(self._blocks()):
            if filled == 0:
                break
            take = min(filled, len(block))
            out[filled - take : filled] = block[len(block) - take :]
            filled -= take
        return out

    def window(self) -> np.ndarray:
        """All samples in the window, oldest first, as a new (size, channels) array."""
        blocks = self._blocks()
        if not blocks:
            return np.empty((0, self._channels))
        return np.concatenate(blocks, axis=0)

    def window_columns(self, columns: Any) -> np.ndarray:
        """The window's samples of the channels ``columns`` only, (size, k), a copy.

        ``window()[:, columns]`` without copying the other channels.
        """
        blocks = self._blocks()
        columns = np.asarray(columns, dtype=np.intp)
        if not blocks:
            return np.empty((0, columns.size))
        return np.concatenate([block[:, columns] for block in blocks], axis=0)

    # -- value-semantics updates ---------------------------------------------------

    def _derive(self) -> ChunkRing:
        out = object.__new__(ChunkRing)
        out._capacity = self._capacity
        out._channels = self._channels
        out._chunk_size = self._chunk_size
        out._chunks = self._chunks
        out._tail = self._tail
        out._tail_rows = self._tail_rows
        out._claim = self._claim
        out._start = self._start
        out._size = self._size
        return out

    def _own_tail(self) -> None:
        """Makes the tail writable beyond ``_tail_rows`` for this (new) version."""
        if self._claim.rows != self._tail_rows:
            tail = np.empty((self._chunk_size, self._channels))
            tail[: self._tail_rows] = self._tail[: self._tail_rows]
            self._tail = tail
            self._claim = _Claim(self._tail_rows)

    def _evict(self) -> None:
        """Drops samples beyond the capacity from the old end."""
        excess = self._size - self._capacity
        if excess <= 0:
            return
        self._size = self._capacity
        self._start += excess
        drop = min(self._start // self._chunk_size, len(self._chunks))
        if drop:
            self._chunks = self._chunks[drop:]
            self._start -= drop * self._chunk_size

    def push(self, sample: Any) -> ChunkRing:
        """Returns a new ring with ``sample`` (channels,) appended as the newest.

        When the window is full the oldest sample (``self.oldest``) leaves it.
        ``self`` is unchanged.
        """
        row = np.asarray(sample, dtype=float)
        if row.shape != (self._channels,):
            v.fail(
                _OWNER,
                f"sample must have shape ({self._channels},); got {row.shape}.",
            )
        out = self._derive()
        out._own_tail()
        out._tail[out._tail_rows] = row
        out._tail_rows += 1
        out._claim.rows = out._tail_rows
        out._size += 1
        if out._tail_rows == out._chunk_size:
            out._freeze_tail()
        out._evict()
        return out

    def _freeze_tail(self) -> None:
        self._tail.flags.writeable = False
        self._chunks = (*self._chunks, self._tail)
        self._tail = np.empty((self._chunk_size, self._channels))
        self._tail_rows = 0
        self._claim = _Claim(0)

    def extend(self, samples: Any) -> ChunkRing:
        """Returns a new ring with ``samples`` (count, channels) appended in order.

        Equivalent to pushing the rows one by one, in O(count × channels).
        """
        block = np.asarray(samples, dtype=float)
        if block.ndim != 2 or block.shape[1] != self._channels:
            v.fail(
                _OWNER,
                f"samples must have shape (any, {self._channels}); got {block.shape}.",
            )
        if len(block) >= self._capacity:
            # Everything older than this block leaves the window: start afresh.
            out = ChunkRing(self._capacity, self._channels, chunk_size=self._chunk_size)
            block = block[len(block) - self._capacity :]
        else:
            out = self._derive()
            out._own_tail()
        out._append(block)
        out._evict()
        return out

    def _append(self, block: np.ndarray) -> None:
        """Appends rows to a ring version that owns its tail (no eviction)."""
        chunks = list(self._chunks)
        position = 0
        while position < len(block):
            take = min(self._chunk_size - self._tail_rows, len(block) - position)
            rows = slice(self._tail_rows, self._tail_rows + take)
            self._tail[rows] = block[position : position + take]
            self._tail_rows += take
            self._claim.rows = self._tail_rows
            position += take
            if self._tail_rows == self._chunk_size:
                self._tail.flags.writeable = False
                chunks.append(self._tail)
                self._tail = np.empty((self._chunk_size, self._channels))
                self._tail_rows = 0
                self._claim = _Claim(0)
        self._chunks = tuple(chunks)
        self._size += len(block)

    def __deepcopy__(self, memo: dict[int, Any]) -> ChunkRing:
        out = self._derive()
        tail = np.empty((self._chunk_size, self._channels))
        tail[: self._tail_rows] = self._tail[: self._tail_rows]
        out._tail = tail
        out._claim = _Claim(self._tail_rows)
        memo[id(self)] = out
        return out

    def __copy__(self) -> ChunkRing:
        return self._derive()

    def __repr__(self) -> str:
        return (
            f"ChunkRing(capacity={self._capacity}, channels={self._channels}, "
            f"size={self._size}, chunk_size={self._chunk_size})"
        )
