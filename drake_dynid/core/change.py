r"""Change detection for the on-line identifier: a CUSUM test and a restart.

A sliding window T forgets an abrupt change of the parameters only as the old
data leave it: after ZZ1R of the paper's 2R arm jumps 3.9 → 4.5 (Fig. 4, T = 7 s)
the estimate is within 2 % only 3-4 s later. With ``OnlineSettings.detect_changes``
the identifier runs, at every solve after the window's estimate (docs/MATH.md §4,
change detection):

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

   and a change is detected when S > h. A second sum S_o with a smaller drift
   κ_o dates it: the change is placed ``lookback``·T_d before the later of the
   solve at which S_o last left 0 and the last solve with z <= 1, at most
   1.5·T_d before the detection, and the estimate held then (a short history is
   kept) is the reference, the sliding window having already mixed later data.
2. **Restart.** From that date plus the bank samples' delay (the filtered rows
   of the first samples after a change mix both parameter values), a segment
   grows at every solve. Its equations (``core.segment``, M_d/T_d
   functions per second) are too few to determine all parameters; forward
   selection (``core.isolation``) finds the parameters that moved and
   re-estimates them, the others keeping their value before the change (the
   reference alone while the segment is shorter than T_d/2). A detection whose
   segment shows no changed parameter after ``confirm`` seconds is withdrawn and
   the mean squares v are learned again.
3. **Refilled.** Once the sliding window holds no sample before the segment's
   start, the identifier reports the window's estimate again and the test is
   re-armed (the mean squares v are kept). While a segment grows the test is
   off: a second change within T of the first is seen only after that.

Without a detection the identifier's outputs are those of the plain sliding
window, bit for bit. :func:`tracking_update` is the step both drivers call (the
``ChangeTrackingIdentifier`` block and ``core.replay``); the state is plain
numbers (``core.change_state``: :func:`tracker_vector` packs it into one vector
for a Drake Context); the settings are ``core.change_design``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from drake_dynid.core.change_design import ChangeDesign, ChangeDetection, change_design
from drake_dynid.core.change_state import (
    TrackerState,
    _frozen,
    tracker_from_vector,
    tracker_init,
    tracker_outputs,
    tracker_vector,
)
from drake_dynid.core.identifier import IdentifierState, Status, identifier_update
from drake_dynid.core.isolation import MIN_DOF, isolate_change
from drake_dynid.core.segment import segment_equations

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

    The reference (the estimate before the change) while the segment is shorter
    than T_d/2 (its rows are then too few and too alike for the isolation's
    tests); the held estimate (not valid) and None when the segment holds an
    invalid sample or its chosen columns cannot be solved.
    """
    samples = _recent(window, tracker.restart)
    if samples is None:
        held = dataclasses.replace(
            reported, valid=False, status=Status.WINDOW_NOT_READY
        )
        return held, None
    functions = design.segment_functions(len(samples))
    length = (len(samples) - 1) * design.bank_time_step
    if length < 0.5 * design.detection.window or functions * design.m < 1 + MIN_DOF:
        reference = IdentifierState(
            theta=tracker.reference,
            std=tracker.reference_std,
            condition_number=reported.condition_number,
            valid=True,
            unidentified=_frozen(np.zeros(design.p)),
            status=Status.OK,
        )
        return reference, np.zeros(design.p, dtype=bool)
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
        quiet=-1,
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
        # Withdrawn: nothing changed, the residual's level did. The test re-learns
        # its in-control mean squares (a new warm-up) before it is armed again.
        return dataclasses.replace(_rearmed(tracker), learned=0), tracker.long
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
    if z <= 1.0 or (tracker.onset_cusum == 0.0 and onset_cusum > 0.0):
        # The window is quiet, or S_o leaves 0: a change, if one follows, is
        # about lookback·T_d before the later of the two; keep the estimate held
        # then (the oldest one kept) as its reference.
        oldest = history[np.flatnonzero(np.isfinite(history[:, 0]))[0]]
        tracker = dataclasses.replace(
            tracker,
            reference=_frozen(oldest[: design.p]),
            reference_std=_frozen(oldest[design.p :]),
            **({"quiet": newest} if z <= 1.0 else {"onset": newest}),
        )
    tracker = dataclasses.replace(tracker, onset_cusum=onset_cusum)
    if cusum > detection.threshold:
        # The date: lookback·T_d before the later of the last quiet window and
        # the onset, at most 1.5·T_d before now.
        windows = detection.window / design.bank_time_step
        change = max(
            max(tracker.onset, tracker.quiet) - round(detection.lookback * windows),
            newest - round(1.5 * windows),
            window.count - len(window.ring),
        )
        return True, dataclasses.replace(
            tracker,
            cusum=0.0,
            onset_cusum=0.0,
            onset=-1,
            quiet=-1,
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
