"""Interpolation of short runs of missing samples on a uniform grid (log repair).

Used by ``drake_dynid.log_repair`` after the grid fit of ``core.timestamps`` (which
re-exports it): dropped samples and short runs of bad cells are filled, cubic for
positions and linear for torques; longer runs stay missing. Pure numpy.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fill_short_runs"]


def fill_short_runs(
    x: np.ndarray,
    max_run: int,
    cubic: bool = False,
    keep: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Interpolates the interior runs of at most ``max_run`` non-finite samples.

    Each column of ``x`` (N, n) on a uniform grid is treated alone. A run of missing
    samples with finite neighbours a (before) and b (after) is filled linearly, or
    with the cubic through a - 1, a, b, b + 1 when ``cubic`` and those are finite.
    Runs at either end, longer runs, and runs holding a sample that ``keep`` (N,)
    marks (a longer gap of a joined file, ``drake_dynid.raw_log``) stay
    non-finite.

    Returns:
        The filled copy of ``x`` and the (N, n) bool mask of the filled entries.
    """
    x = np.array(x, dtype=float, copy=True)
    filled = np.zeros(x.shape, bool)
    if max_run < 1:
        return x, filled
    n = x.shape[0]
    idx = np.arange(n)
    kept = None if keep is None else np.cumsum(np.asarray(keep, dtype=bool))
    for j in range(x.shape[1]):
        col = x[:, j]
        finite = np.isfinite(col)
        if finite.all() or not finite.any():
            continue
        left = np.maximum.accumulate(np.where(finite, idx, -1))
        right = np.minimum.accumulate(np.where(finite, idx, n)[::-1])[::-1]
        p = np.flatnonzero(~finite)
        a, b = left[p], right[p]
        use = (a >= 0) & (b < n) & (b - a - 1 <= max_run)
        p, a, b = p[use], a[use], b[use]
        if kept is not None:  # no kept sample in a + 1 .. b - 1
            free = kept[b - 1] == kept[a]
            p, a, b = p[free], a[free], b[free]
        if p.size == 0:
            continue
        w = (p - a) / (b - a)
        value = (1.0 - w) * col[a] + w * col[b]
        if cubic:
            a0 = np.maximum(a - 1, 0)
            b1 = np.minimum(b + 1, n - 1)
            four = (a - 1 >= 0) & (b + 1 < n) & finite[a0] & finite[b1]
            nodes = [a0[four], a[four], b[four], b1[four]]
            at = p[four]
            cubic_value = np.zeros(at.size)
            for i in range(4):  # Lagrange polynomial through the four nodes
                term = col[nodes[i]]
                for m in range(4):
                    if m != i:
                        term = term * (at - nodes[m]) / (nodes[i] - nodes[m])
                cubic_value += term
            value[four] = cubic_value
        col[p] = value
        filled[p, j] = True
    return x, filled
