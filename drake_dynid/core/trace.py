"""The estimates of one on-line identifier over time (:class:`OnlineTrace`).

Both drivers return it: the Drake blocks (``drake_dynid.diagrams``) and the core
replay (``drake_dynid.core.replay``); it stays importable from
``drake_dynid.core.online``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from drake_dynid.core.online import OnlineSettings

__all__ = ["OnlineTrace"]


@dataclass
class OnlineTrace:
    """Estimates of one on-line identifier over time (one row per solve).

    The core replay of a long log (``core.replay``) keeps the (M, p) arrays
    (``theta``, ``std``, ``unidentified``, ``changed``) beyond 32 MiB each in
    temporary files, as ``drake_dynid.log_store.StoredArray`` (indexed like an
    array, reading only the rows asked; ``np.asarray`` reads it all).

    Attributes:
        settings: the identifier's settings (on the signal grid).
        names: base parameter names (p).
        t: (M,) times at which the estimates were logged [s], every update
            period U: at t_s the state after the solves at t < t_s (the left
            limit, as Drake's loggers record it), i.e. the estimate of the solve
            at t_s - U + 3h/4 on the samples up to t_s - U. A replayed log's
            trace ends at t_N, one period h after its last sample, with the
            final solve's estimate on the samples up to the last
            (``core.replay.solve_samples``).
        theta: (M, p) estimates (the last valid one is held while ``valid`` = 0).
        std: (M, p) standard deviations (``settings.uncertainty``; inf before the
            first valid solve).
        condition_number: (M,) condition number of the column-scaled A.
        valid: (M,) 1 when the solve at that time was accepted.
        status: (M,) the identifier's status code (``core.identifier.Status``: 0
            ok, 1 window not ready or holding a bad sample, 2 not identifiable).
        unidentified: (M, p) 1 for the parameters found not excited by that solve.
        delay: latency of a solve [s]: the differentiator delay (or the raw
            rows' delay) plus the solve's offset 3h/4. The solve at t_u + 3h/4
            uses the samples up to t_u, which estimate the signals at t_u minus
            the differentiator delay; so the window of the estimate logged at
            t_s ends at t_s - U - (delay - 3h/4). A trace shows an estimate up to
            U - 3h/4 after the solve made it.
        change: (M,) with ``settings.detect_changes`` (else empty): 1 at the solve
            that detected an abrupt change (``core.change``).
        change_time: (M,) estimated time of the last detected change [s] (NaN
            before the first), in the signal's time base (like ``t - delay``).
        tracking: (M,) 1 while the estimate comes from the segment since the
            last change (the sliding window still holds older samples).
        changed: (M, p) 1 for the parameters re-estimated on that segment.
    """

    settings: OnlineSettings
    names: tuple[str, ...]
    t: np.ndarray
    theta: np.ndarray
    std: np.ndarray
    condition_number: np.ndarray
    valid: np.ndarray
    delay: float
    status: np.ndarray = field(default_factory=lambda: np.zeros(0))
    unidentified: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    change: np.ndarray = field(default_factory=lambda: np.zeros(0))
    change_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    tracking: np.ndarray = field(default_factory=lambda: np.zeros(0))
    changed: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def detections(self) -> list[dict[str, Any]]:
        """The detected changes (empty without detection).

        Per change: the solve that detected it ``t`` [s], the estimated time of
        the change [s] and the parameters found changed at the last solve of its
        segment (before the sliding window took over again).
        """
        out = []
        tracking = np.asarray(self.tracking) > 0.5
        for index in np.flatnonzero(np.asarray(self.change) > 0.5):
            last = index  # the segment's last solve: its most informed selection
            while last + 1 < len(tracking) and tracking[last + 1]:
                last += 1
                if self.change[last] > 0.5:
                    last -= 1
                    break
            flags = self.changed[last] if len(self.changed) else ()
            out.append(
                {
                    "t": float(self.t[index]),
                    "change_time": float(self.change_time[index]),
                    "changed": [
                        name
                        for name, flag in zip(self.names, flags, strict=False)
                        if flag > 0.5
                    ],
                }
            )
        return out

    def final(self) -> dict[str, Any]:
        """The estimate at the end of the run (last valid estimate held)."""
        theta = self.theta[-1] if len(self.t) else np.full(len(self.names), np.nan)
        std = self.std[-1] if len(self.t) else np.full(len(self.names), np.inf)
        return {
            "theta": theta,
            "std": std,
            "condition_number": float(self.condition_number[-1])
            if len(self.t)
            else math.inf,
            "valid": bool(self.valid[-1]) if len(self.t) else False,
            "status": int(self.status[-1]) if len(self.status) else None,
            "unidentified": tuple(
                name
                for name, flag in zip(
                    self.names,
                    self.unidentified[-1] if len(self.unidentified) else (),
                    strict=False,
                )
                if flag > 0.5
            ),
        }
