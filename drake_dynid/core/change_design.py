"""Settings and design of the on-line change test (``core.change``).

:class:`ChangeDetection` holds the test's settings (``OnlineSettings.detect_changes``),
:func:`change_design` puts them on one identifier's grid (bank step, solve period,
window, delay): the :class:`ChangeDesign` both drivers pass to
``core.change.tracking_update``. docs/MATH.md §4, change detection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from drake_dynid.core import _validate as v
from drake_dynid.core.segment import MAX_SEGMENT_FUNCTIONS

__all__ = ["ChangeDesign", "ChangeDetection", "change_design"]

_OWNER = "ChangeDetection"


@dataclass(frozen=True)
class ChangeDetection:
    """Settings of the residual test and of the restart.

    docs/MATH.md §4, change detection.

    The defaults are the measured trade-off on the paper's 2R arm at SNR 30 dB
    (benchmarks/bench_accuracy.py: detection about 1.4 s after the Fig. 4 jump,
    0.1-0.4 false alarms per minute on logs without a change; README "Tracking a
    change").

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
        lookback: the change is placed ``lookback``·T_d before the later of the
            solve at which the onset sum last left 0 and the last quiet window
            (z <= 1): the test's window responds a little after the change
            enters it.
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
