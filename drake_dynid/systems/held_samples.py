"""The ``HeldSamples`` block: sample tables played back, each row held over its step."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem, OutputPort

from drake_dynid.core import _validate as check

__all__ = ["HeldSamples", "held_index"]

#: Rows read from the arrays at a time (a stored log's rows come from its file).
BLOCK_ROWS = 4096

# A time this close below t_k - h/2 (relative to h) already reads sample k: the
# boundary does not depend on the last bit of an event time computed as a sum.
_EDGE = 1e-9

#: The dtypes a table may hold (read as floats).
_REAL_KINDS = (np.floating, np.integer, np.bool_)


def held_index(t: float, start: float, time_step: float, count: int) -> int:
    """k(t) = clip(⌊(t - t_0)/h + 1/2⌋, 0, N - 1): the sample held at time t.

    Sample k is held over [t_0 + (k - 1/2)·h, t_0 + (k + 1/2)·h); the first one
    before, the last one after (t = ±∞ included). A time within 1e-9·h below a
    boundary counts as past it.

    Raises:
        ValueError: a NaN time.
    """
    x = (t - start) / time_step + 0.5 + _EDGE
    if x != x:
        raise ValueError(f"HeldSamples: the time must be a number; got {t}.")
    if x >= count:
        return count - 1
    return max(math.floor(x), 0) if x >= 0 else 0


class HeldSamples(LeafSystem):
    r"""Rows of sample tables played back in time, row k held over its step.

    .. pydrake_system::

        name: HeldSamples
        output_ports:
        - y

    ``y(t) = [c_1[k]; c_2[k]; …]``, k = :func:`held_index` (t, t_0, h, N): row k
    of each table c_i (N, m_i), side by side, held over [t_k - h/2, t_k + h/2),
    t_k = t_0 + k·h, so that a block updating at t_k reads sample k whatever the
    rounding of the event times (docs/CONVENTIONS.md §2); the first row before,
    the last after (or NaN after it with ``after_end="nan"``). It replaces
    ``TrajectorySource(PiecewisePolynomial.ZeroOrderHold(t_0 + h·(k - 1/2),
    rows))``, without its N·Σm_i ``Polynomial``
    objects, which took about 2 KB per sample of a 7-DOF log ([q; τ]): 1.8 GB
    for a 10-minute log at 1 kHz. The same output at the sample times and away
    from the boundaries (tests/systems/test_held_samples.py); at a boundary
    t_k + h/2 itself, this block gives sample k + 1 (the convention) where the
    zero-order hold gave k or k + 1 with the rounding of t_k + h/2 against its
    breaks (k from 500 on at 1 kHz). The identification blocks read it at t_k.

    No state: the output is a function of the time. The tables may be arrays or
    a long log's ``StoredArray`` columns; they are read ``BLOCK_ROWS`` rows at a
    time into a read cache (the rows last read, replaced as one tuple: it does
    not change the output, so any number of Contexts may share the block).
    Double only (a Python system: no AutoDiffXd/Expression scalar conversion).
    """

    def __init__(
        self,
        tables: Sequence[Any],
        time_step: float,
        start_time: float = 0.0,
        *,
        after_end: str = "hold",
    ):
        """Builds the block.

        Args:
            tables: (N, m_i) sample tables (arrays, or array-likes that slice by
                rows such as ``log_store.StoredArray``), the same N >= 1.
            time_step: the sample period h [s].
            start_time: t_0, the time of row 0 [s].
            after_end: from t_{N-1} + h/2 on, ``"hold"`` the last row (a
                trajectory that stays where it ends) or ``"nan"`` (a recording
                that has ended: no sample to read, see ``diagrams.log_source``).
        """
        super().__init__()
        owner = "HeldSamples"
        self._h = check.positive(owner, "time_step", time_step, "s")
        self._t0 = check.real(owner, "start_time", start_time, "s")
        if after_end not in ("hold", "nan"):
            check.fail(owner, f"after_end must be 'hold' or 'nan'; got {after_end!r}.")
        self._nan_after = after_end == "nan"
        if isinstance(tables, np.ndarray) and tables.ndim == 2:
            # Its rows were taken for N tables: "got [(2,), (2,), (2,)]".
            raise TypeError(
                f"{owner}: tables must be a sequence of (N, m_i) tables; got one "
                f"{tables.shape} array: pass [table]."
            )
        self._tables = list(tables)
        if not self._tables:
            check.fail(owner, "tables must hold at least one (N, m) table.")
        for index, table in enumerate(self._tables):
            # Read at run time a block at a time: a table of strings failed at the
            # first Eval, inside a Simulator; complex values lost their imaginary
            # part silently.
            dtype = getattr(table, "dtype", None)
            if dtype is None:
                dtype = np.asarray(table).dtype
            if not any(np.issubdtype(dtype, kind) for kind in _REAL_KINDS):
                raise TypeError(
                    f"{owner}: tables[{index}] must hold real numbers; got dtype "
                    f"{dtype}."
                )
        shapes = [tuple(getattr(c, "shape", np.shape(c))) for c in self._tables]
        if any(len(s) != 2 for s in shapes) or len({s[0] for s in shapes}) != 1:
            check.fail(owner, f"tables must be (N, m_i) with the same N; got {shapes}.")
        self._count = int(shapes[0][0])
        if self._count < 1:
            check.fail(owner, "tables must hold at least one row.")
        width = sum(s[1] for s in shapes)
        self._cache: tuple[int, np.ndarray] = (0, np.zeros((0, width)))
        self._y = self.DeclareVectorOutputPort(
            "y",
            width,
            self._CalcY,
            prerequisites_of_calc={self.time_ticket()},
        )

    def get_output_port_y(self) -> OutputPort:
        """The output port ``y`` (Σ m_i)."""
        return self._y

    def _row(self, k: int) -> np.ndarray:
        first, rows = self._cache
        if not first <= k < first + rows.shape[0]:
            first = k - k % BLOCK_ROWS
            b = min(self._count, first + BLOCK_ROWS)
            rows = np.hstack(
                [np.asarray(c[first:b], dtype=float) for c in self._tables]
            )
            self._cache = (first, rows)
        return rows[k - first]

    def _CalcY(self, context: Context, output: BasicVector) -> None:
        t = context.get_time()
        if self._nan_after and (t - self._t0) / self._h + 0.5 + _EDGE >= self._count:
            output.SetFromVector(np.full(output.size(), np.nan))  # the log has ended
            return
        output.SetFromVector(self._row(held_index(t, self._t0, self._h, self._count)))
