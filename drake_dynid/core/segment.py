r"""Modulated equations of a stored segment: polynomial modulating functions.

The sliding Fourier bank (``core.fourier_bank``, ``core.sliding``) gives the
equations of one fixed window T. The change detector (``core.change``) needs the
equations of *any* stretch of the stored bank samples: the last second (the
residual test) and the segment since a detected change, which grows at every
solve. On a segment ``[t_0, t_0 + L]`` of length L [s] it uses the polynomial
modulating functions (docs/MATH.md §3, segments), with s = (v - t_0)/L ∈ [0, 1]::

    φ_i(s) = s (1 - s) P_i(2s - 1),      i = 0 .. M - 1
    g_i(v) = φ_i(s) / L  [1/s],          ġ_i(v) = φ_i'(s) / L²  [1/s²]

(P_i the Legendre polynomials). Every φ_i vanishes at both ends (order k = 1),
so one integration by parts moves the time derivative of the model-row contract
``d/dt(D·θ) + G·θ = y`` (docs/CONVENTIONS.md §3) onto g::

    -∫ ġ_i D_j dv · θ + ∫ g_i G_j dv · θ = ∫ g_i y_j dv        [unit of y]

for every function i and equation j (trapezoid rule on the segment's samples).
With the 1/L normalisation a row has the magnitude of a torque whatever L, like
the Fourier rows. Degree M + 1 over L resolves about (M + 1)/(2L) Hz: a few
functions per second stay inside the differentiator's pass band.

Pure numpy; the rows are function-major: row ``i·m + j``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.polynomial import legendre

from drake_dynid.core import _validate as v
from drake_dynid.core.rows import num_channels

__all__ = ["MAX_SEGMENT_FUNCTIONS", "segment_equations", "segment_functions"]

#: Most polynomial functions of one segment (a ceiling on the work per solve).
MAX_SEGMENT_FUNCTIONS = 32


def segment_functions(count: int, num_functions: int) -> tuple[np.ndarray, np.ndarray]:
    """``(φ, φ')``: the M functions and their s-derivatives at ``count`` samples.

    Samples at s_k = k/(count - 1), k = 0 .. count - 1; each array (M, count),
    dimensionless (the 1/L, 1/L² factors are the caller's).
    """
    owner = "segment_functions"
    count = v.integer(owner, "count", count, minimum=2)
    num_functions = v.integer(owner, "num_functions", num_functions, minimum=1)
    if num_functions > MAX_SEGMENT_FUNCTIONS:
        v.fail(
            owner,
            f"num_functions must be <= {MAX_SEGMENT_FUNCTIONS}; got {num_functions}.",
        )
    s = np.linspace(0.0, 1.0, count)
    x = 2.0 * s - 1.0
    eye = np.eye(num_functions)
    p = legendre.legval(x, eye)  # (M, count)
    dp = 2.0 * legendre.legval(x, legendre.legder(eye)) if num_functions > 1 else 0.0
    base = s * (1.0 - s)
    return base * p, (1.0 - 2.0 * s) * p + base * dp


def segment_equations(
    samples: Any, time_step: float, num_functions: int, m: int, p: int
) -> tuple[np.ndarray, np.ndarray]:
    """The modulated equations ``A θ = B`` of a segment of packed bank samples.

    Args:
        samples: (count, 2mp + m) packed model rows (``core.rows.pack_rows``) at
            the bank samples of the segment, oldest first, ``time_step`` apart
            (count >= 2).
        time_step: spacing of the samples h_b [s].
        num_functions: M, the polynomial functions (module docstring).
        m: equations per sample.
        p: parameters.

    Returns:
        A (M·m, p) and B (M·m,) [unit of y]; row ``i·m + j`` is function i,
        equation j.
    """
    owner = "segment_equations"
    x = np.asarray(samples, dtype=float)
    if x.ndim != 2 or x.shape[1] != num_channels(m, p) or len(x) < 2:
        v.fail(
            owner,
            f"samples must have shape (>= 2, {num_channels(m, p)}); got {x.shape}.",
        )
    h = v.positive(owner, "time_step", time_step, "s")
    length = (len(x) - 1) * h
    phi, dphi = segment_functions(len(x), num_functions)
    weights = np.full(len(x), h)
    weights[[0, -1]] = 0.5 * h
    g = phi * (weights / length)  # quadrature weights of g_i [1]
    gdot = dphi * (weights / length**2)  # of ġ_i [1/s]
    mp = m * p
    lhs = g @ x[:, mp : 2 * mp] - gdot @ x[:, :mp]
    rhs = g @ x[:, 2 * mp :]
    return lhs.reshape(num_functions * m, p), rhs.reshape(num_functions * m)
