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

    Attributes:
        settings: the identifier's settings (on the signal grid).
        names: base parameter names (p).
        t: (M,) times of the solves [s].
        theta: (M, p) estimates (the last valid one is held while ``valid`` = 0).
        std: (M, p) standard deviations (``settings.uncertainty``; inf before the
            first valid solve).
        condition_number: (M,) condition number of the column-scaled A.
        valid: (M,) 1 when the solve at that time was accepted.
        status: (M,) the identifier's status code (``core.identifier.Status``: 0
            ok, 1 window not ready or holding a bad sample, 2 not identifiable).
        unidentified: (M, p) 1 for the parameters found not excited by that solve.
        delay: latency of the estimate [s]: the differentiator delay plus one sample
            per block (the window ends at t - delay).
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
