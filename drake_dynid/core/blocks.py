"""Rows of a long log a block at a time: in-memory arrays and stored arrays alike.

A long log read from a file keeps q and τ on disk (``drake_dynid.log_store``): an
array-like whose indexing by a slice reads those rows only, and whose ``rows(a,
b)`` is a lazy view of rows [a, b). The streamed computations (off-line IDIM,
automatic settings, dead-zone widths, core replay) take either kind through the
helpers below and index them a block of rows at a time, so their memory does not
grow with the log. Pure numpy (duck typing: no import of the store).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check

__all__ = [
    "BLOCK_ROWS",
    "blocks",
    "checked_rows",
    "constant_columns",
    "is_stored",
    "segment",
]

BLOCK_ROWS = 1 << 16
"""Rows per block of the loops over a log."""


def is_stored(x: Any) -> bool:
    """True for an array-like read a block at a time (not an ndarray)."""
    return (
        not isinstance(x, np.ndarray)
        and hasattr(x, "rows")
        and hasattr(x, "shape")
        and hasattr(x, "__getitem__")
    )


def segment(x: Any, start: int, stop: int) -> Any:
    """Rows [start, stop) of ``x``: a view of an array, a lazy view of a store."""
    return x.rows(start, stop) if is_stored(x) else x[start:stop]


def blocks(x: Any, rows: int = BLOCK_ROWS) -> Iterator[tuple[int, np.ndarray]]:
    """``(start, rows [start, start + rows) as an array)`` over the rows of ``x``."""
    for start in range(0, len(x), rows):
        yield start, np.asarray(x[start : start + rows], dtype=float)


def checked_rows(owner: str, name: str, x: Any, ndim: int | None = None) -> Any:
    """``_validate.array`` (finite), a block at a time for a store.

    An array-like that is not a store is converted as ``check.array`` does; a
    store is returned as it is, after its dimensions and, block by block, its
    finiteness are checked.
    """
    if not is_stored(x):
        out = check.array(owner, name, x)
        if ndim is not None and out.ndim != ndim:
            check.fail(owner, f"{name} must have {ndim} dimension(s); got {out.shape}.")
        return out
    if ndim is not None and len(x.shape) != ndim:
        check.fail(owner, f"{name} must have {ndim} dimension(s); got {x.shape}.")
    bad = 0
    for _, block in blocks(x):
        bad += int(block.size - np.count_nonzero(np.isfinite(block)))
    if bad:
        check.fail(owner, f"{name} must be finite; got {bad} NaN or infinite value(s).")
    return x


def constant_columns(values: Any) -> list[tuple[int, float]]:
    """(column, value) of the columns whose finite samples are all one value.

    An array is screened on every 64th row first (a reduction along a narrow
    C-order array costs 1.6 ms per 60 000 × 7): only the columns constant there
    are read in full. A stored log's columns are read a block at a time.
    """

    def extremes(block: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        finite = np.isfinite(block)
        return (
            np.min(block, axis=0, where=finite, initial=np.inf),
            np.max(block, axis=0, where=finite, initial=-np.inf),
        )

    columns = list(range(values.shape[1]))
    if not is_stored(values):
        low, high = extremes(np.asarray(values[::64], dtype=float))
        columns = [j for j in columns if low[j] == high[j]]
        if not columns:
            return []
        values = np.asarray(values, dtype=float)[:, columns]
    low = np.full(len(columns), np.inf)
    high = np.full(len(columns), -np.inf)
    for _, block in blocks(values):
        if block.shape[1] != len(columns):
            block = block[:, columns]
        block_low, block_high = extremes(block)
        low, high = np.minimum(low, block_low), np.maximum(high, block_high)
    return [(j, float(low[k])) for k, j in enumerate(columns) if low[k] == high[k]]
