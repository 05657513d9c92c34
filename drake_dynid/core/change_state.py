"""The state of the change tracker (``core.change``) and its packing.

:class:`TrackerState` is plain numbers; :func:`tracker_vector` and
:func:`tracker_from_vector` pack it into one float vector (the
``ChangeTrackingIdentifier`` block keeps it in a discrete state of the Context),
:func:`tracker_outputs` gives the block's and the trace's change outputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.change_design import ChangeDesign
from drake_dynid.core.identifier import IdentifierState, Status, identifier_init

__all__ = [
    "TrackerState",
    "tracker_from_vector",
    "tracker_init",
    "tracker_outputs",
    "tracker_vector",
]


@dataclass(frozen=True, eq=False)
class TrackerState:
    """State of the change tracker (plain numbers; see the module docstring).

    Attributes:
        long: the sliding window's own identifier state.
        scale: (d,) in-control mean squares v of the test's residual.
        learned: solves that contributed to ``scale``.
        cusum: S [detection windows].
        onset_cusum: S_o, the same sum with the smaller drift κ_o (the onset).
        quiet: absolute bank index of the newest sample of the last window whose
            statistic z was <= 1 (-1).
        onset: absolute bank index of the newest sample when S_o last left 0
            (-1).
        restart: absolute bank index of the first sample of the segment since
            the last change (-1: no segment, the window's estimate is reported).
        reference: (p,) the estimate before the last change (the one held
            ``lookback``·T_d before the CUSUM last left 0); reference_std its σ.
        history: (K, 2p) the last K estimates held and their σ, oldest first
            (NaN rows before they are filled).
        changes: changes detected so far.
        detected: True when this solve detected a change.
        change_index: absolute bank index of the last change's estimate (-1).
        changed: (p,) 1.0 for the parameters re-estimated on the segment.
    """

    long: IdentifierState
    scale: np.ndarray
    learned: int
    cusum: float
    onset_cusum: float
    quiet: int
    onset: int
    restart: int
    reference: np.ndarray
    reference_std: np.ndarray
    history: np.ndarray
    changes: int
    detected: bool
    change_index: int
    changed: np.ndarray

    @property
    def tracking(self) -> bool:
        """True while the estimate comes from the segment since a change."""
        return self.restart >= 0


def _frozen(value: Any) -> np.ndarray:
    out = np.array(value, dtype=float)
    out.flags.writeable = False
    return out


def tracker_init(design: ChangeDesign, initial_theta: Any = None) -> TrackerState:
    """The tracker before the first solve."""
    p = design.p
    return TrackerState(
        long=identifier_init(p, initial_theta),
        scale=_frozen(np.zeros(design.num_residuals)),
        learned=0,
        cusum=0.0,
        onset_cusum=0.0,
        quiet=-1,
        onset=-1,
        restart=-1,
        reference=_frozen(np.zeros(p)),
        reference_std=_frozen(np.full(p, np.inf)),
        history=_frozen(np.full((design.history, 2 * p), np.nan)),
        changes=0,
        detected=False,
        change_index=-1,
        changed=_frozen(np.zeros(p)),
    )


def _vector_layout(design: ChangeDesign) -> list[tuple[str, int]]:
    p, d = design.p, design.num_residuals
    return [
        ("theta", p),
        ("std", p),
        ("condition_number", 1),
        ("valid", 1),
        ("unidentified", p),
        ("status", 1),
        ("scale", d),
        ("learned", 1),
        ("cusum", 1),
        ("onset_cusum", 1),
        ("quiet", 1),
        ("onset", 1),
        ("restart", 1),
        ("reference", p),
        ("reference_std", p),
        ("history", design.history * 2 * p),
        ("changes", 1),
        ("detected", 1),
        ("change_index", 1),
        ("changed", p),
    ]


def tracker_vector(state: TrackerState, design: ChangeDesign) -> np.ndarray:
    """The state as one float vector (integers are exact up to 2⁵³)."""
    long = state.long
    values = {
        "theta": long.theta,
        "std": long.std,
        "condition_number": long.condition_number,
        "valid": float(long.valid),
        "unidentified": long.unidentified,
        "status": float(long.status),
        "scale": state.scale,
        "learned": state.learned,
        "cusum": state.cusum,
        "onset_cusum": state.onset_cusum,
        "quiet": state.quiet,
        "onset": state.onset,
        "restart": state.restart,
        "reference": state.reference,
        "reference_std": state.reference_std,
        "history": state.history.ravel(),
        "changes": state.changes,
        "detected": float(state.detected),
        "change_index": state.change_index,
        "changed": state.changed,
    }
    return np.concatenate(
        [
            np.atleast_1d(np.asarray(values[name], dtype=float))
            for name, _ in _vector_layout(design)
        ]
    )


def tracker_from_vector(vector: Any, design: ChangeDesign) -> TrackerState:
    """Inverse of :func:`tracker_vector`."""
    x = np.asarray(vector, dtype=float)
    parts: dict[str, np.ndarray] = {}
    start = 0
    for name, size in _vector_layout(design):
        parts[name] = x[start : start + size]
        start += size
    if start != x.size:
        v.fail(
            "tracker_from_vector",
            f"vector must have {start} entries for this design; got {x.size}.",
        )
    one = {name: float(value[0]) for name, value in parts.items() if value.size == 1}
    return TrackerState(
        long=IdentifierState(
            theta=_frozen(parts["theta"]),
            std=_frozen(parts["std"]),
            condition_number=one["condition_number"],
            valid=one["valid"] > 0.5,
            unidentified=_frozen(parts["unidentified"]),
            status=Status(int(one["status"])),
        ),
        scale=_frozen(parts["scale"]),
        learned=int(one["learned"]),
        cusum=one["cusum"],
        onset_cusum=one["onset_cusum"],
        quiet=int(one["quiet"]),
        onset=int(one["onset"]),
        restart=int(one["restart"]),
        reference=_frozen(parts["reference"]),
        reference_std=_frozen(parts["reference_std"]),
        history=_frozen(parts["history"].reshape(design.history, 2 * design.p)),
        changes=int(one["changes"]),
        detected=one["detected"] > 0.5,
        change_index=int(one["change_index"]),
        changed=_frozen(parts["changed"]),
    )


def tracker_outputs(state: TrackerState, design: ChangeDesign) -> np.ndarray:
    """The tracker's outputs ``[detected, change_time, tracking, changed (p)]``.

    ``change_time`` [s]: the bank sample of the change estimate, j·h_b, minus the
    bank samples' delay (NaN before the first change).
    """
    time = (
        state.change_index * design.bank_time_step - design.delay
        if state.change_index >= 0
        else math.nan
    )
    head = [float(state.detected), time, float(state.tracking)]
    return np.concatenate((head, state.changed))
