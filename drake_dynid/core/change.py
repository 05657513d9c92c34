r"""Change detection for the on-line identifier: a CUSUM test and a restart.

A sliding window T forgets an abrupt change of the parameters only as the old
data leave it: after ZZ1R of the paper's 2R arm jumps 3.9 → 4.5 (Fig. 4, T = 7 s)
the estimate is within 2 % only 3-4 s later. With ``OnlineSettings.detect_changes``
the identifier runs, at every solve after the window's estimate (docs/MATH.md
§4b):

1. **Residual test.** The equations ``A_d θ = B_d`` of the last T_d of bank
   samples (``core.segment``: M_d polynomial modulating functions; T_d = 1 s)
   with the estimate held before this solve, θ̂:
   ``r = B_d - A_d θ̂`` (M_d·m components [unit of y]). In control each component
   has a mean square v_i (the velocity noise in the regressor, the filter's
   bias), learned over a warm-up and then by an exponential average of time
   constant ``memory`` while the test is quiet; the statistic
   ``z = mean_i(r_i² / v_i)`` is about 1. A CUSUM accumulates its excess in
   units of detection windows (overlapping windows repeat the same evidence)::

       S ← max(0, S + (z - κ) Δt / T_d)        (Δt the solve period)

   and a change is detected when S > h. The change is placed T_d/2 before the
   solve at which S last left 0 (the test weighs the middle of its window most).
2. **Restart.** From that estimate plus the bank samples' delay (the filtered
   rows of the first samples after a change mix both parameter values), a
   segment grows at every solve. Its equations (``core.segment``, M_d/T_d
   functions per second) are too few to determine all parameters; forward
   selection (``core.isolation``) finds the parameters that moved and
   re-estimates them, the others keeping their value before the change.
3. **Refilled.** Once the sliding window holds no sample before the segment's
   start, the identifier reports the window's estimate again and the test is
   re-armed (the mean squares v are kept). While a segment grows the test is
   off: a second change within T of the first is seen only after that.

Without a detection the identifier's outputs are those of the plain sliding
window, bit for bit. :func:`tracking_update` is the step both drivers call (the
``ChangeTrackingIdentifier`` block and ``core.replay``); the state is plain
numbers (:func:`tracker_vector` packs it into one vector for a Drake Context).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.identifier import (
    IdentifierState,
    Status,
    identifier_init,
    identifier_update,
)
from drake_dynid.core.isolation import MIN_DOF, isolate_change
from drake_dynid.core.segment import MAX_SEGMENT_FUNCTIONS, segment_equations

__all__ = [
    "ChangeDesign",
    "ChangeDetection",
    "TrackerState",
    "change_design",
    "tracker_from_vector",
    "tracker_init",
    "tracker_outputs",
    "tracker_vector",
    "tracking_update",
]

_OWNER = "ChangeDetection"


@dataclass(frozen=True)
class ChangeDetection:
    """Settings of the residual test and of the restart (docs/MATH.md §4b).

    The defaults are the measured trade-off on the paper's 2R arm at SNR 30 dB
    (benchmarks/bench_accuracy.py: detection about 1 s after the Fig. 4 jump, few
    false alarms on logs without a change; README "Tracking a change").

    Attributes:
        window: T_d, the residual test's window [s].
        functions: M_d, polynomial modulating functions of the test's window
            (the segment since a change gets M_d/T_d per second, at least M_d).
        drift: κ, the allowance of the CUSUM per window (z ≈ 1 in control).
        onset_drift: κ_o < κ, the allowance of the second sum that dates the
            change (it leaves 0 when z first exceeds κ_o).
        threshold: h, the CUSUM's alarm level [detection windows].
        warmup: valid solves [s] over which the in-control mean squares are
            learned before the test is armed.
        memory: time constant of their exponential average [s] (None: the
            sliding window T).
        alpha: level of the isolation's F-tests (``core.isolation``).
        lookback: the change is placed ``lookback``·T_d before the solve at which
            the onset sum last left 0 (the test's window responds a little after
            the change enters it).
        confirm: a detection whose segment, this long [s], has shown no changed
            parameter is withdrawn: the window's estimate is reported again and
            the test re-armed (a false alarm then costs about nothing).
    """

    window: float = 1.0
    functions: int = 4
    drift: float = 5.0
    onset_drift: float = 2.0
    threshold: float = 0.5
    warmup: float = 2.0
    memory: float | None = None
    alpha: float = 1e-3
    lookback: float = 0.2
    confirm: float = 2.0

    def __post_init__(self) -> None:
        v.positive(_OWNER, "window", self.window, "s")
        count = v.integer(_OWNER, "functions", self.functions, minimum=1)
        if count > MAX_SEGMENT_FUNCTIONS:
            v.fail(
                _OWNER,
                f"functions must be <= {MAX_SEGMENT_FUNCTIONS}; got {count}.",
            )
        drift = v.positive(_OWNER, "drift", self.drift)
        onset = v.positive(_OWNER, "onset_drift", self.onset_drift)
        if not onset <= drift:
            v.fail(_OWNER, f"onset_drift must be <= drift {drift:g}; got {onset:g}.")
        v.positive(_OWNER, "threshold", self.threshold)
        v.positive(_OWNER, "warmup", self.warmup, "s")
        if self.memory is not None:
            v.positive(_OWNER, "memory", self.memory, "s")
        v.positive(_OWNER, "confirm", self.confirm, "s")
        lookback = v.real(_OWNER, "lookback", self.lookback)
        if not 0.0 <= lookback <= 1.0:
            v.fail(_OWNER, f"lookback must be in [0, 1]; got {lookback:g}.")
        alpha = v.positive(_OWNER, "alpha", self.alpha)
        if alpha >= 1.0:
            v.fail(_OWNER, f"alpha must be in (0, 1); got {alpha:g}.")
        for name in ("window", "warmup", "memory", "confirm"):
            value = getattr(self, name)
            if value is not None and not math.isfinite(value):
                v.fail(_OWNER, f"{name} must be finite [s]; got {value}.")


@dataclass(frozen=True)
class ChangeDesign:
    """The test and the restart on one identifier's grid (:func:`change_design`).

    Attributes:
        detection: the settings.
        m: equations per sample; p: parameters.
        bank_time_step: h_b, spacing of the bank samples [s].
        update_period: Δt, period of the solves [s].
        window_samples: bank samples of the sliding window (N + 1).
        detect_samples: bank samples of the test's window (T_d/h_b + 1).
        margin: bank samples skipped after the change estimate (the delay).
        delay: latency of the bank samples [s] (change times refer to the signal).
        memory: time constant of the mean squares [s].
        history: past estimates kept (lookback·T_d/Δt + 1): the reference of a
            change is the estimate from before it, not the one at the detection
            (the sliding window has already mixed some data after the change).
    """

    detection: ChangeDetection
    m: int
    p: int
    bank_time_step: float
    update_period: float
    window_samples: int
    detect_samples: int
    margin: int
    delay: float
    memory: float
    history: int

    @property
    def num_residuals(self) -> int:
        """The components of the test's residual, d = M_d·m."""
        return self.detection.functions * self.m

    def segment_functions(self, count: int) -> int:
        """Polynomial functions of a segment of ``count`` bank samples."""
        length = (count - 1) * self.bank_time_step
        density = self.detection.functions / self.detection.window
        wanted = max(self.detection.functions, round(density * length))
        return int(min(wanted, MAX_SEGMENT_FUNCTIONS))


def change_design(
    settings: Any, time_step: float, m: int, p: int
) -> ChangeDesign | None:
    """The design of ``settings.detect_changes`` on the signal grid, or None.

    Args:
        settings: ``OnlineSettings`` (put on the grid of ``time_step`` here).
        time_step: signal period h [s].
        m: equations per sample.
        p: parameters.

    Raises:
        ValueError: the test's window is not shorter than the sliding window or
            holds fewer than 2·M_d bank samples.
    """
    chosen = settings.detect_changes
    if chosen is False or chosen is None:
        return None
    detection = ChangeDetection() if chosen is True else chosen
    grid = settings.on_grid(time_step)
    step = grid.resolved("bank_time_step")
    count = round(detection.window / step) + 1
    if not detection.window < grid.window or count < 2 * detection.functions:
        v.fail(
            _OWNER,
            f"window must be shorter than the sliding window ({grid.window:g} s) "
            f"and hold at least 2·functions = {2 * detection.functions} bank samples "
            f"({step:g} s apart) [s]; got {detection.window:g}.",
        )
    delay = grid.delay(time_step)
    return ChangeDesign(
        detection=detection,
        m=int(m),
        p=int(p),
        bank_time_step=step,
        update_period=grid.resolved("update_period"),
        window_samples=round(grid.window / step) + 1,
        detect_samples=count,
        margin=math.ceil(delay / step - 1e-9),
        delay=delay,
        memory=grid.window if detection.memory is None else detection.memory,
        history=math.ceil(
            detection.lookback * detection.window / grid.resolved("update_period")
            - 1e-9
        )
        + 1,
    )


@dataclass(frozen=True, eq=False)
class TrackerState:
    """State of the change tracker (plain numbers; see the module docstring).

    Attributes:
        long: the sliding window's own identifier state.
        scale: (d,) in-control mean squares v of the test's residual.
        learned: solves that contributed to ``scale``.
        cusum: S [detection windows].
        onset_cusum: S_o, the same sum with the smaller drift κ_o (the onset).
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


def _recent(window: Any, first: int) -> np.ndarray | None:
    """Bank samples ``first`` .. newest of the sliding state, or None.

    None when some are no longer stored, or one of them is invalid.
    """
    newest = window.count - 1
    count = newest - first + 1
    if count < 2 or count > len(window.ring) or window.last_invalid >= first:
        return None
    return window.ring.tail(count)


def _segment_estimate(
    tracker: TrackerState,
    reported: IdentifierState,
    design: ChangeDesign,
    window: Any,
    max_condition: float,
) -> tuple[IdentifierState, np.ndarray | None]:
    """``(estimate, re-estimated flags)`` of the segment since the change.

    The held estimate (not valid) and None when the segment is too short or
    holds an invalid sample, or its chosen columns cannot be solved.
    """
    samples = _recent(window, tracker.restart)
    functions = 0 if samples is None else design.segment_functions(len(samples))
    if samples is None or functions * design.m < 1 + MIN_DOF:
        held = dataclasses.replace(
            reported, valid=False, status=Status.WINDOW_NOT_READY
        )
        return held, None
    A, B = segment_equations(
        samples, design.bank_time_step, functions, design.m, design.p
    )
    found = isolate_change(
        A,
        B,
        tracker.reference,
        tracker.reference_std,
        alpha=design.detection.alpha,
        max_condition=max_condition,
    )
    if not found.valid:
        held = dataclasses.replace(
            reported,
            condition_number=found.condition_number,
            valid=False,
            status=Status.NOT_IDENTIFIABLE,
        )
        return held, None
    estimate = IdentifierState(
        theta=_frozen(found.theta),
        std=_frozen(found.std),
        condition_number=found.condition_number,
        valid=True,
        unidentified=_frozen(np.zeros(design.p)),
        status=Status.OK,
    )
    return estimate, found.selected


def tracking_update(
    tracker: TrackerState,
    reported: IdentifierState,
    design: ChangeDesign,
    window_valid: bool,
    A: Any,
    B: Any,
    window: Any,
    **solve: Any,
) -> tuple[TrackerState, IdentifierState]:
    """One solve with change detection: ``(new tracker, reported estimate)``.

    Args:
        tracker: the tracker's state.
        reported: the estimate reported after the previous solve.
        design: :func:`change_design`.
        window_valid: whether the sliding window is full and holds no invalid
            sample (``A``, ``B`` are then not read).
        A: (r, p) the sliding window's equations
            (``core.identifier.identifier_update``).
        B: (r,) their right-hand side.
        window: the bank's sliding state (``core.sliding.SlidingState``: its
            ring of bank samples, ``count`` and ``last_invalid``).
        **solve: the keyword arguments of ``identifier_update`` (weighting,
            max_condition, names, noise, jackknife).

    Returns:
        The new tracker and the estimate to report: the sliding window's
        (``tracker.long``) unless a segment since a change is growing.
    """
    long = identifier_update(tracker.long, window_valid, A, B, **solve)
    tracker = dataclasses.replace(tracker, long=long, detected=False)
    oldest = window.count - len(window.ring)
    max_condition = float(solve.get("max_condition", 1e4))
    if tracker.tracking:
        if oldest >= tracker.restart and long.valid:  # refilled
            return _rearmed(tracker), long
        return _with_segment(tracker, reported, design, window, max_condition)
    detected, tracker = _test(tracker, reported, design, window)
    if not detected:
        return tracker, long
    return _with_segment(tracker, reported, design, window, max_condition)


def _rearmed(tracker: TrackerState) -> TrackerState:
    """The test armed again after a segment (the held estimates start afresh)."""
    return dataclasses.replace(
        tracker,
        restart=-1,
        cusum=0.0,
        onset_cusum=0.0,
        onset=-1,
        changed=_frozen(np.zeros_like(tracker.changed)),
        history=_frozen(np.full_like(tracker.history, np.nan)),
    )


def _with_segment(
    tracker: TrackerState,
    reported: IdentifierState,
    design: ChangeDesign,
    window: Any,
    max_condition: float,
) -> tuple[TrackerState, IdentifierState]:
    estimate, selected = _segment_estimate(
        tracker, reported, design, window, max_condition
    )
    if selected is None:
        return tracker, estimate
    length = (window.count - 1 - tracker.restart) * design.bank_time_step
    if not selected.any() and length >= design.detection.confirm:
        return _rearmed(tracker), tracker.long  # withdrawn: nothing changed
    return dataclasses.replace(tracker, changed=_frozen(selected)), estimate


def _test(
    tracker: TrackerState,
    reported: IdentifierState,
    design: ChangeDesign,
    window: Any,
) -> tuple[bool, TrackerState]:
    """The CUSUM step; ``(detected, tracker)`` (a detection starts a segment)."""
    newest = window.count - 1
    samples = _recent(window, newest - design.detect_samples + 1)
    if samples is None or not (reported.valid and tracker.long.valid):
        return False, tracker
    detection = design.detection
    A, B = segment_equations(
        samples, design.bank_time_step, detection.functions, design.m, design.p
    )
    squared = (B - A @ reported.theta) ** 2
    held = np.concatenate((reported.theta, reported.std))
    history = np.vstack((tracker.history[1:], held[None, :]))
    tracker = dataclasses.replace(tracker, history=_frozen(history))
    step = design.update_period
    if tracker.learned * step < detection.warmup:  # the warm-up's running mean
        weight = 1.0 / (tracker.learned + 1)
        scale = tracker.scale + weight * (squared - tracker.scale)
        return False, dataclasses.replace(
            tracker, scale=_frozen(scale), learned=tracker.learned + 1
        )
    floor = np.finfo(float).tiny
    z = float(np.mean(squared / np.maximum(tracker.scale, floor)))
    scale_step = step / detection.window  # S counts detection windows
    cusum = max(0.0, tracker.cusum + (z - detection.drift) * scale_step)
    onset_cusum = max(
        0.0, tracker.onset_cusum + (z - detection.onset_drift) * scale_step
    )
    if tracker.onset_cusum == 0.0 and onset_cusum > 0.0:
        # S_o leaves 0: the change, if one follows, is about lookback·T_d earlier;
        # keep the estimate held then (the oldest one kept) as its reference.
        oldest = history[np.flatnonzero(np.isfinite(history[:, 0]))[0]]
        tracker = dataclasses.replace(
            tracker,
            onset=newest,
            reference=_frozen(oldest[: design.p]),
            reference_std=_frozen(oldest[design.p :]),
        )
    tracker = dataclasses.replace(tracker, onset_cusum=onset_cusum)
    if cusum > detection.threshold:
        back = round(detection.lookback * detection.window / design.bank_time_step)
        change = max(tracker.onset - back, window.count - len(window.ring))
        return True, dataclasses.replace(
            tracker,
            cusum=0.0,
            onset_cusum=0.0,
            onset=-1,
            restart=change + design.margin,
            changes=tracker.changes + 1,
            detected=True,
            change_index=change,
        )
    if cusum == 0.0:  # in control: the mean squares follow the motion slowly
        weight = min(1.0, step / design.memory)
        scale = tracker.scale + weight * (squared - tracker.scale)
        return False, dataclasses.replace(
            tracker, scale=_frozen(scale), cusum=cusum, learned=tracker.learned + 1
        )
    return False, dataclasses.replace(tracker, cusum=cusum)
