"""The filtered signals of a window's bank samples, as a step function.

The covariance weighting (``core.row_covariance``) needs, at every solve, the
filtered signals (q̂, v̂, τ̂) at the K bank samples of the window. The core replay
reads them from the log; the ``SignalWindow`` block (systems/signal_window.py)
keeps them in this ring, pushed at the bank's sample times. Immutable state: a
push returns a new ring (one copy of K × 3n floats).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check

__all__ = ["SignalRing", "ring_init", "ring_push", "ring_window"]


@dataclass(frozen=True, eq=False)
class SignalRing:
    """The last K samples of [q̂; v̂; τ̂] (read-only).

    Attributes:
        samples: (K, 3n), sample ``count - 1`` at row ``(count - 1) % K``.
        count: samples pushed so far.
    """

    samples: np.ndarray
    count: int

    @property
    def num_samples(self) -> int:
        """K, the samples the ring holds when full."""
        return int(self.samples.shape[0])

    @property
    def num_joints(self) -> int:
        """The joints n."""
        return int(self.samples.shape[1] // 3)


def ring_init(num_samples: int, num_joints: int) -> SignalRing:
    """An empty ring of ``num_samples`` K samples of n joints."""
    owner = "ring_init"
    k = check.integer(owner, "num_samples", num_samples, minimum=1)
    n = check.integer(owner, "num_joints", num_joints, minimum=1)
    samples = np.zeros((k, 3 * n))
    samples.flags.writeable = False
    return SignalRing(samples, 0)


def ring_push(ring: SignalRing, q_hat: Any, v_hat: Any, tau_hat: Any) -> SignalRing:
    """``ring`` with the sample (q̂, v̂, τ̂), each (n,), pushed (the oldest dropped)."""
    sample = np.concatenate(
        [np.asarray(x, dtype=float).ravel() for x in (q_hat, v_hat, tau_hat)]
    )
    if sample.size != ring.samples.shape[1]:
        check.fail(
            "ring_push",
            f"q_hat, v_hat and tau_hat must have {ring.num_joints} entries each; got "
            f"{sample.size} in all.",
        )
    samples = ring.samples.copy()
    samples[ring.count % ring.num_samples] = sample
    samples.flags.writeable = False
    return SignalRing(samples, ring.count + 1)


def ring_window(ring: SignalRing) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(q̂, v̂, τ̂)``, each (K, n) oldest first; None until K samples were pushed."""
    k = ring.num_samples
    if ring.count < k:
        return None
    ordered = np.roll(ring.samples, -(ring.count % k), axis=0)
    n = ring.num_joints
    return ordered[:, :n], ordered[:, n : 2 * n], ordered[:, 2 * n :]
