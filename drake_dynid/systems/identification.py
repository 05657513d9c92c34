"""On-line identification blocks: model rows, modulating-integral bank, sliding QR.

The three blocks of the on-line identifier (docs/MATH.md §3-§4, docs/CONVENTIONS.md
§3)::

    (q̂, v̂, τ̂) ──► ModelRows ──channels──► ModulatingIntegralBank ──A, B──►
    SlidingQRIdentifier ──► θ̂, σ(θ̂), cond, valid

(``RawModelRows`` replaces ``ModelRows`` for the raw rows: it reads the
differentiator's ring, ``drake_dynid.core.raw_rows``.)

Each block is a thin wrapper over ``drake_dynid.core`` with all state in the
Context, in its own module (:mod:`~drake_dynid.systems.model_rows`,
:mod:`~drake_dynid.systems.modulating_bank`, :mod:`~drake_dynid.systems.identifier`);
this module gathers them.
"""

from __future__ import annotations

from drake_dynid.core.identifier import Status
from drake_dynid.systems.identifier import SlidingQRIdentifier
from drake_dynid.systems.model_rows import ModelRows, RawModelRows
from drake_dynid.systems.modulating_bank import ModulatingIntegralBank

__all__ = [
    "STATUS_NOT_IDENTIFIABLE",
    "STATUS_OK",
    "STATUS_WINDOW_NOT_READY",
    "ModelRows",
    "ModulatingIntegralBank",
    "RawModelRows",
    "SlidingQRIdentifier",
    "Status",
]

# Status codes of SlidingQRIdentifier (output ``status``): ``Status`` members.
STATUS_OK = Status.OK
STATUS_WINDOW_NOT_READY = Status.WINDOW_NOT_READY
STATUS_NOT_IDENTIFIABLE = Status.NOT_IDENTIFIABLE
