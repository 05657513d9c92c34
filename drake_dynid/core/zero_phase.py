"""Zero-phase IIR filtering of a span of a longer signal (the streamed chains' blocks).

A zero-phase Butterworth (``scipy.signal.sosfiltfilt``, here with the numpy
filters of ``core.iir``) applied to a block of a long
signal with margins on each side gives the whole-signal result inside the block
once the filter's start-up transients have decayed in the margins
(:func:`settle_samples`); at the signal's true ends the padding of the
whole-signal filter is reproduced (:func:`zero_phase_span`). Used by
``core.idim_stream`` (off-line rows) and ``core.standstill`` (dead-zone widths).
"""

from __future__ import annotations

import math

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.iir import sosfilt, sosfilt_zi

__all__ = ["SETTLE_TOLERANCE", "settle_samples", "zero_phase_span"]

SETTLE_TOLERANCE = 1e-12
"""Block margins: IIR start-up transients decay below this fraction."""


def settle_samples(sos: np.ndarray, tolerance: float = SETTLE_TOLERANCE) -> int:
    """Samples after which the IIR filter ``sos``'s transients fall below tolerance.

    ``ceil(ln(tolerance) / ln ρ)`` with ρ < 1 the largest pole modulus of the
    second-order sections (the slowest mode decays as ρ^k).
    """
    poles = np.concatenate([np.roots(section[3:]) for section in np.atleast_2d(sos)])
    rho = float(np.max(np.abs(poles)))
    if not rho < 1.0:
        check.fail("settle_samples", f"the filter must be stable; got |pole| {rho}.")
    return math.ceil(math.log(tolerance) / math.log(rho))


def zero_phase_span(
    sos: np.ndarray, x: np.ndarray, *, pad_left: int, pad_right: int, padtype: str
) -> np.ndarray:
    """``sosfiltfilt`` of a span of a longer signal, padded only at its true ends.

    ``pad_left`` (``pad_right``) samples of the odd (``2 x_0 - x_k``) or even
    (``x_k``) reflection are added at the start (end) of ``x``; 0 means that side is
    interior (its transient must die in a margin the caller drops). With both pads
    this is exactly ``scipy.signal.sosfiltfilt(sos, x, axis=0, padtype=padtype,
    padlen=pad)``.

    Args:
        sos: second-order sections.
        x: (L, c) span, L > max(pad_left, pad_right).
        pad_left: reflection samples at the start (0: none).
        pad_right: reflection samples at the end (0: none).
        padtype: ``"odd"`` or ``"even"``.

    Returns:
        (L, c) the filtered span.
    """
    parts = []
    if pad_left:
        head = x[pad_left:0:-1]
        parts.append(2.0 * x[:1] - head if padtype == "odd" else head)
    parts.append(x)
    if pad_right:
        tail = x[-2 : -(pad_right + 2) : -1]
        parts.append(2.0 * x[-1:] - tail if padtype == "odd" else tail)
    ext = np.concatenate(parts) if len(parts) > 1 else x
    zi = sosfilt_zi(sos)[:, :, None]
    y = sosfilt(sos, ext, zi * ext[:1])
    y = sosfilt(sos, y[::-1], zi * y[-1:])
    return y[::-1][pad_left : ext.shape[0] - pad_right]
