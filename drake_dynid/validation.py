"""Held-out validation: predict a log's joint torques from identified base parameters.

The prediction is the inverse dynamic model with the base regressor,
τ̂ = W(q_f, v, v̇)·θ̂, computed exactly as ``dynid offline`` builds its equations
(:mod:`drake_dynid.offline`), so that a fit and its validation see the same
signals:

1. the log is split into its finite segments (NaN samples cut it);
2. per segment, q is low-passed by the zero-phase Butterworth at the position
   cutoff f_c and differentiated by central differences
   (:func:`drake_dynid.core.idim.offline_derivatives`, same padding and trim);
   f_c is chosen on the validation log by the same automatic rule
   (:func:`drake_dynid.offline.auto_cutoff`) unless given;
3. the predicted and the measured torques both pass through the parallel
   decimation's zero-phase order-8 low-pass at f_d = min(f_c, 1.5·B) (same rule,
   :func:`drake_dynid.offline.auto_decimation_cutoff`), without down-sampling.

Why compare after the low-pass (and not against the raw torque). The fit
minimises exactly this residual (the equation ``τ = W θ`` filtered on both sides,
which is unbiased because the filter is linear and the same on both sides), so
in-sample and held-out numbers measure the same thing. Above f_d the log holds no
motion, only torque-sensor noise and the noise of v̇: no model of the dynamics can
predict it, and counting it would report the sensor's noise as model error (and
make the figures depend on the sample rate). The raw comparison is reported too
(``raw_relative_rms_percent``, τ as logged against the unfiltered prediction at
the same samples): it adds the noise floor, the torque sensor's noise and the
noise of v̇ between the motion band and the position cutoff.

Per joint j, over the compared samples (e = τ_f − τ̂_f)::

    relative RMS error = 100·RMS(e)/RMS(τ_f)            [%]
    R² = 1 − Σ e² / Σ (τ_f − mean τ_f)²
    residual std = std(e)                               [N·m or N]

**While moving.** A joint at rest is held by static friction, whose torque is
anywhere in ±(the breakaway friction) and which no model here predicts (the dead
zone sets the Coulomb column to 0 there, docs/MATH.md §2). The relative RMS error is
therefore also given over the samples where joint j moves,
``moving_relative_rms_percent``: |v̂_j| above its standstill width w_j, the
off-line velocity v̂ of step 2 (unfiltered by step 3) and w_j the robot's dead
zone (the fit's) or, without one, :func:`drake_dynid.offline.standstill_widths`
measured on this log. On the real TIAGo log (held-out 40 %, about 2/5 of it at
rest) the all-joint error is 14.5 % on every sample and 8.9 % while moving.

Steps 2-3 are streamed (:func:`drake_dynid.core.idim_stream.decimated_chunks`
with D = 1): the zero-phase filters run on blocks whose margins let their
transients decay to 1e-12, the metrics are summed a block at a time and the
compared samples of a long log stay in temporary files, so memory does not grow
with the log (hours of a 7-DOF arm: ``benchmarks/bench_long_logs.py``). The
numbers equal the chain on whole segments (scipy's ``sosfiltfilt``) to a few
1e-11 of the torques (the round-off of ``core.iir``'s block filter through the
narrow order-8 low-pass); the predictions, through v̇ (a second difference of
q_f: 1/h²), to about 1e-8 (tests/test_validation.py).

Pure numpy/scipy (the rows come from the robot object).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core import idim_stream
from drake_dynid.core.blocks import is_stored, segment
from drake_dynid.core.friction import EXACT_SIGN, DeadZoneSign
from drake_dynid.core.idim import default_padding, default_trim
from drake_dynid.core.idim_auto import auto_cutoff, auto_cutoff_rule, check_cutoff_run
from drake_dynid.core.idim_checks import check_filter_frequency
from drake_dynid.core.idim_friction import FrictionLayout, friction_layout
from drake_dynid.log_store import RowSink
from drake_dynid.offline import log_decimation_cutoff

__all__ = [
    "TorqueValidation",
    "check_parameters",
    "read_estimates",
    "read_results",
    "split_log",
    "validate_estimates",
    "validate_torques",
]

_DEFINITION_TOLERANCE = 1e-6  # relative, on the regrouping coefficients


@dataclass(frozen=True, eq=False)
class TorqueValidation:
    """Measured against predicted joint torques of one log (:func:`validate_torques`).

    Attributes:
        joint_names: the n joints.
        t: (M,) times of the compared samples [s] (finite segments, trimmed ends
            dropped).
        measured: (M, n) measured torques after the comparison low-pass [N·m, N].
        predicted: (M, n) predicted torques W·θ after the same low-pass.
        raw_measured: (M, n) torques as logged at the same samples.
        raw_predicted: (M, n) W·θ before the low-pass.
        segment: (M,) index of the finite segment each sample comes from.

        On a long log these arrays are ``log_store.StoredArray`` (temporary
        files; they index like arrays and ``np.asarray`` loads them): each one
        beyond ``log_store.SPILL_BYTES``, so the (M, n) ones from about 10
        minutes of a 7-DOF arm at 1 kHz, ``t`` and ``segment`` (then floats)
        from about 70.
        relative_rms_percent: (n,) 100·RMS(residual)/RMS(measured) [%].
        r_squared: (n,) coefficient of determination (NaN for a constant torque).
        residual_std: (n,) standard deviation of the residual [N·m, N].
        rms_measured: (n,) RMS of the measured (low-passed) torque [N·m, N].
        raw_relative_rms_percent: (n,) the relative RMS error against the raw
            torques, unfiltered prediction (adds the noise above the band) [%].
        total_relative_rms_percent: all joints together,
            100·‖residual‖/‖measured‖ [%].
        settings: ``cutoff_hz``, ``cutoff_rule``, ``decimation_cutoff_hz``,
            ``decimation_cutoff_rule``, ``filter_order``, ``trim``, ``padding``,
            ``time_step``.
        num_samples: samples in the log.
        moving_relative_rms_percent: (n,) the relative RMS error over the samples
            where the joint moves (module docstring; NaN when it never does) [%].
        moving_fraction: (n,) the fraction of the compared samples where it moves.
        total_moving_relative_rms_percent: all joints together, each over its
            moving samples [%].
        moving_widths: (n,) the standstill widths w_j used [rad/s or m/s].
        moving_rule: ``"dead zone"`` (the robot's), ``"measured"`` (on this log)
            or ``"none"`` (the log is too short to measure them).
    """

    joint_names: tuple[str, ...]
    t: np.ndarray
    measured: np.ndarray
    predicted: np.ndarray
    raw_measured: np.ndarray
    raw_predicted: np.ndarray
    segment: np.ndarray
    relative_rms_percent: np.ndarray
    r_squared: np.ndarray
    residual_std: np.ndarray
    rms_measured: np.ndarray
    raw_relative_rms_percent: np.ndarray
    total_relative_rms_percent: float
    settings: dict[str, Any] = field(default_factory=dict)
    num_samples: int = 0
    moving_relative_rms_percent: np.ndarray = field(default_factory=lambda: np.zeros(0))
    moving_fraction: np.ndarray = field(default_factory=lambda: np.zeros(0))
    total_moving_relative_rms_percent: float = math.nan
    moving_widths: np.ndarray = field(default_factory=lambda: np.zeros(0))
    moving_rule: str = ""

    @property
    def num_samples_used(self) -> int:
        """Samples compared (M)."""
        return int(self.t.shape[0])


def _merged(
    count: int, mean: np.ndarray, centred: np.ndarray, block: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(mean, Σ (x - mean)²) of ``count`` samples and the ``block``'s rows.

    Chan, Golub & LeVeque's pairwise update: no cancellation from Σx² - N·mean².
    """
    rows = block.shape[0]
    total = count + rows
    block_mean = block.mean(axis=0)
    delta = block_mean - mean
    block_centred = np.sum((block - block_mean) ** 2, axis=0)
    return (
        mean + delta * (rows / total),
        centred + block_centred + delta**2 * (count * rows / total),
    )


class _Moments:
    """Per-column sums of the metrics of k estimates, merged a block at a time.

    The measured torque's sums are kept once, the residuals' per estimate: the
    same numbers as numpy's whole-array ``mean``/``std`` to round-off.
    """

    def __init__(self, n: int, k: int):
        self.count = 0
        self.mean = np.zeros(n)  # of the measured torque
        self.centred = np.zeros(n)  # its Σ (x - mean)²
        self.residual_mean = np.zeros((n, k))
        self.residual_centred = np.zeros((n, k))
        self.squares = np.zeros((2, n))  # Σ measured², raw measured²
        self.residual_squares = np.zeros((2, n, k))  # Σ e², raw e²
        self.moving = np.zeros(n)  # samples where the joint moves
        self.moving_squares = np.zeros(n)  # Σ measured² there
        self.moving_residual_squares = np.zeros((n, k))  # Σ e² there

    def add(self, measured, predicted, raw_measured, raw_predicted, moving) -> None:
        """Adds (c, n) torques, their (c, n, k) predictions and (c, n) motion."""
        if measured.shape[0] == 0:
            return
        at = moving.astype(float)
        self.moving += at.sum(axis=0)
        self.moving_squares += np.einsum("ij,ij->j", at * measured, measured)
        moved = measured[..., None] - predicted
        self.moving_residual_squares += np.einsum(
            "ijk,ijk->jk", at[..., None] * moved, moved
        )
        residual = measured[..., None] - predicted
        raw_residual = raw_measured[..., None] - raw_predicted
        self.mean, self.centred = _merged(self.count, self.mean, self.centred, measured)
        self.residual_mean, self.residual_centred = _merged(
            self.count, self.residual_mean, self.residual_centred, residual
        )
        self.count += measured.shape[0]
        for i, (x, e) in enumerate(
            ((measured, residual), (raw_measured, raw_residual))
        ):
            self.squares[i] += np.einsum("ij,ij->j", x, x)
            self.residual_squares[i] += np.einsum("ijk,ijk->jk", e, e)

    def metrics(self, j: int) -> dict[str, Any]:
        """The metrics of estimate j."""
        measured, raw_measured = self.squares
        residual, raw_residual = self.residual_squares[..., j]
        # A constant torque: the blocks' merge leaves round-off (1e-29) where the
        # centred sum is 0; below 1e-20 of Σ τ² the torque is constant to 1e-10.
        total = np.where(self.centred > 1e-20 * measured, self.centred, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            r_squared = np.where(total > 0, 1.0 - residual / total, np.nan)
            relative = np.where(
                measured > 0, 100.0 * np.sqrt(residual / measured), np.inf
            )
            raw = np.where(
                raw_measured > 0, 100.0 * np.sqrt(raw_residual / raw_measured), np.inf
            )
        norm = float(np.sum(measured))
        moving = self.moving_residual_squares[:, j]
        with np.errstate(divide="ignore", invalid="ignore"):
            moving_relative = np.where(
                self.moving_squares > 0,
                100.0 * np.sqrt(moving / self.moving_squares),
                np.nan,
            )
        moving_norm = float(np.sum(self.moving_squares))
        return {
            "moving_relative_rms_percent": moving_relative,
            "moving_fraction": self.moving / max(1, self.count),
            "total_moving_relative_rms_percent": (
                100.0 * math.sqrt(float(np.sum(moving)) / moving_norm)
                if moving_norm > 0
                else math.nan
            ),
            "relative_rms_percent": relative,
            "r_squared": r_squared,
            "residual_std": np.sqrt(self.residual_centred[:, j] / self.count),
            "rms_measured": np.sqrt(measured / self.count),
            "raw_relative_rms_percent": raw,
            "total_relative_rms_percent": (
                100.0 * math.sqrt(float(np.sum(residual)) / norm)
                if norm > 0
                else math.inf
            ),
        }


def _rows(robot: Any) -> Any:
    fast = robot.rows_provider() if hasattr(robot, "rows_provider") else robot
    return fast if hasattr(fast, "idim_rows") else robot


def validate_torques(
    log: Any,
    robot: Any,
    theta: Any,
    *,
    cutoff_hz: float | None = None,
    decimation_cutoff_hz: float | None = None,
    filter_order: int = 4,
) -> TorqueValidation:
    """Predicts the torques of ``log`` from base parameters θ and compares them.

    See the module docstring for the filtering (the ``dynid offline`` chain
    without the down-sampling) and the metrics; :func:`validate_estimates`
    compares several θ in one pass.

    Args:
        log: a :class:`~drake_dynid.logs.RobotLog` with the robot's joints.
        robot: a :class:`~drake_dynid.plants.RobotModel` (or any object with
            ``names``, ``joint_names`` and ``idim_rows(q, v, vdot)``).
        theta: (p,) base parameter values in ``robot.names`` order.
        cutoff_hz: position low-pass f_c [Hz]; None: ``auto_cutoff`` on the
            longest finite segment of this log, for ``filter_order``.
        decimation_cutoff_hz: comparison low-pass f_d [Hz]; None:
            ``auto_decimation_cutoff`` (min(f_c, 1.5·B)) on this log.
        filter_order: Butterworth order of the position filter.

    Returns:
        A :class:`TorqueValidation`.

    Raises:
        ValueError: joints that differ from the robot's, θ of the wrong size, or
            no finite segment long enough for the filter.
    """
    return _validate(
        "validate_torques",
        log,
        robot,
        {"theta": theta},
        cutoff_hz,
        decimation_cutoff_hz,
        filter_order,
    )["theta"]


def validate_estimates(
    log: Any,
    robot: Any,
    estimates: Mapping[str, Any],
    *,
    cutoff_hz: float | None = None,
    decimation_cutoff_hz: float | None = None,
    filter_order: int = 4,
) -> dict[str, TorqueValidation]:
    """:func:`validate_torques` of several estimates on one log, in one pass.

    The positions are filtered and the rows W(q_f, v, v̇) evaluated once for all
    of them (τ̂ = W·[θ_1 … θ_k]): k estimates cost about one validation
    (``dynid validate --compare-urdf``, identify's and offline's held-out
    checks). The results share their ``t``, ``measured``, ``raw_measured`` and
    ``segment`` arrays; each equals :func:`validate_torques` of its θ.

    Args:
        log: as for :func:`validate_torques`.
        robot: as for :func:`validate_torques`.
        estimates: ``{label: θ}``, each (p,) in ``robot.names`` order.
        cutoff_hz: as for :func:`validate_torques`.
        decimation_cutoff_hz: as for :func:`validate_torques`.
        filter_order: as for :func:`validate_torques`.

    Returns:
        ``{label: TorqueValidation}`` in the order of ``estimates``.
    """
    return _validate(
        "validate_estimates",
        log,
        robot,
        estimates,
        cutoff_hz,
        decimation_cutoff_hz,
        filter_order,
    )


def check_validation_length(log: Any, cutoff_hz: float | None = None) -> None:
    """Raises ValueError when no good run of ``log`` is long enough to validate on.

    The validation drops ``default_trim(h, f_c)`` samples at each end of every
    run (the filters' start-up); a held-out part shorter than that cannot be
    compared. Checked before a fit (``--split 0.999``: 30 samples for 103
    needed), with the same automatic cutoff (kept per log).
    """
    segments = log.good_segments()
    if not segments:
        raise ValueError("the log has no finite sample (every row has a NaN).")
    start, stop = max(segments, key=lambda s: s[1] - s[0])
    if cutoff_hz is None:
        check_cutoff_run(None, stop - start, "the longest finite segment has")
        cutoff_hz = float(log.on_longest_run(auto_cutoff))
    if not 0.0 < cutoff_hz < 0.5 / log.time_step:
        return  # the validation names a cutoff beyond Nyquist itself
    trim = default_trim(log.time_step, cutoff_hz)
    if stop - start < 2 * trim + 1:
        raise ValueError(
            f"no finite segment of the log is long enough: the longest has "
            f"{stop - start} samples and the cutoff {cutoff_hz:.3g} Hz needs at "
            f"least {2 * trim + 1} ({trim} are dropped at each end)."
        )


def _validate(
    owner: str,
    log: Any,
    robot: Any,
    estimates: Mapping[str, Any],
    cutoff_hz: float | None,
    decimation_cutoff_hz: float | None,
    filter_order: int,
) -> dict[str, TorqueValidation]:
    for attribute in ("t", "q", "tau", "time_step", "joint_names"):
        if not hasattr(log, attribute):
            raise TypeError(
                f"{owner}: log must be a RobotLog; got {type(log).__name__}."
            )
    rows = _rows(robot)
    expected = getattr(robot, "joint_names", log.joint_names)
    check.log_joints(owner, expected, log.joint_names)
    p = len(rows.names)
    if not estimates:
        check.fail(owner, "estimates must hold at least one θ.")
    labels = list(estimates)
    thetas = []
    for label, value in estimates.items():
        name = "theta" if label == "theta" else f"theta '{label}'"
        theta = check.array(owner, name, value)
        if theta.shape != (p,):
            check.fail(owner, f"{name} must have shape ({p},); got {theta.shape}.")
        thetas.append(theta)
    theta = np.stack(thetas, axis=1)  # (p, k)
    h = check.positive(owner, "time_step", log.time_step, "s")
    filter_order = check.integer(owner, "filter_order", filter_order, minimum=1)
    # A long log read from a file stays on disk, read a block at a time.
    q = log.q if is_stored(log.q) else np.asarray(log.q, dtype=float)
    tau = log.tau if is_stored(log.tau) else np.asarray(log.tau, dtype=float)
    times = log.t if is_stored(log.t) else np.asarray(log.t, dtype=float)
    segments = log.good_segments()
    if not segments:
        check.fail(owner, "the log has no finite sample (every row has a NaN).")
    longest = max(segments, key=lambda s: s[1] - s[0])
    q_longest = segment(q, *longest)
    # Given cutoffs against the log before any filter (core/idim_checks.py): below
    # Nyquist and long enough for two periods at each end of the longest segment.
    given = (("cutoff_hz", cutoff_hz), ("decimation_cutoff_hz", decimation_cutoff_hz))
    for name, value in given:
        if value is not None:
            check_filter_frequency(
                f"{owner}: ", name, value, h, longest[1] - longest[0]
            )

    cutoff_rule = "given" if cutoff_hz is not None else "auto"
    if cutoff_hz is None:
        check_cutoff_run(owner, q_longest.shape[0], "the longest finite segment has")
        cutoff_hz = log.on_longest_run(auto_cutoff_rule(filter_order, auto_cutoff))
    cutoff_hz = check.below_nyquist(owner, "cutoff_hz", cutoff_hz, h)
    band_rule = "given" if decimation_cutoff_hz is not None else "auto"
    if decimation_cutoff_hz is None:
        decimation_cutoff_hz = log_decimation_cutoff(log, cutoff_hz)
    decimation_cutoff_hz = check.below_nyquist(
        owner, "decimation_cutoff_hz", decimation_cutoff_hz, h
    )
    trim = default_trim(h, cutoff_hz)
    padding = default_padding(h, cutoff_hz)
    # The dynid offline chain without down-sampling (D = 1): the position filter,
    # central differences, τ̂ = W θ at every sample and the order-8 low-pass of
    # τ̂ and τ, streamed (core.idim_stream): memory independent of the log length.
    plan = idim_stream.stream_plan(
        h,
        cutoff_hz=cutoff_hz,
        filter_order=filter_order,
        trim=trim,
        padding=padding,
        decimation=1,
        decimation_cutoff_hz=decimation_cutoff_hz,
        factor=1,
        block=idim_stream.BLOCK_SAMPLES,
    )

    # A dead zone's Coulomb columns (the joints' and the coupled motors') go
    # through the stream as the fit's do, with their reversals
    # (core.standstill.reversal_signs): τ̂ = W_rb θ_rb + F θ_F.
    sign: Any = getattr(robot, "sign", None)
    layout = (
        friction_layout(
            rows.names,
            rows.idim_rows,
            q.shape[1],
            sign,
            getattr(rows, "motor_columns", None),
        )
        if isinstance(sign, DeadZoneSign)
        else None
    ) or FrictionLayout.rows_only(p, q.shape[1])
    rigid_index = list(layout.rigid)
    widths, moving_rule = _moving_widths(log, sign, cutoff_hz, decimation_cutoff_hz)
    # v̂ of every joint rides along as viscous columns (F = v̂), after the fit's.
    motion = [("viscous", j) for j in range(q.shape[1])]
    fitted = len(layout)  # the stream's columns: the fit's friction, then v̂
    theta_rigid = theta[rigid_index]
    # (F, n, k): each friction series' torque per unit, on every joint's row.
    theta_friction = layout.weights[:, :, None] * theta[list(layout.columns)][:, None]

    def predict(q_f: np.ndarray, v: np.ndarray, vdot: np.ndarray) -> np.ndarray:
        W = np.asarray(rows.idim_rows(q_f, v, vdot), dtype=float)
        return W[..., rigid_index] @ theta_rigid if layout else W @ theta

    def with_friction(rigid: np.ndarray, F: np.ndarray) -> np.ndarray:
        """(R, n, k) predictions: the rigid part plus each friction column's."""
        rigid += np.einsum("rc,cnk->rnk", F, theta_friction)
        return rigid

    n, k = q.shape[1], len(labels)
    sinks = {key: RowSink(n) for key in ("m", "rm")}
    sinks["t"], sinks["s"] = RowSink(1), RowSink(1)
    predictions = [(RowSink(n), RowSink(n)) for _ in labels]  # low-passed, raw
    moments = _Moments(n, k)
    for index, (start, stop) in enumerate(segments):
        if stop - start < 2 * trim + 1:
            continue
        row = start + trim
        for (
            smooth,
            smooth_friction,
            smooth_measured,
            raw,
            raw_friction,
            measured,
        ) in idim_stream.decimated_chunks(
            segment(q, start, stop),
            segment(tau, start, stop),
            plan,
            predict,
            [*layout.friction, *motion],
            sign if layout else EXACT_SIGN,
            raw=True,
            channels=layout.channels,
        ):
            smooth = with_friction(smooth, smooth_friction[:, :fitted])
            raw = with_friction(raw, raw_friction[:, :fitted])
            count = measured.shape[0]
            moving = np.abs(raw_friction[:, fitted:]) > widths
            moments.add(smooth_measured, smooth, measured, raw, moving)
            for j in range(k):
                predictions[j][0].append(smooth[..., j])
                predictions[j][1].append(raw[..., j])
            for key, part in (
                ("t", np.asarray(times[row : row + count], dtype=float)),
                ("m", smooth_measured),
                ("rm", measured),
                ("s", np.full(count, float(index))),
            ):
                sinks[key].append(part)
            row += count
    if moments.count == 0:
        check.fail(
            owner,
            f"no finite segment of the log is long enough: the longest has "
            f"{longest[1] - longest[0]} samples and the cutoff {cutoff_hz:.3g} Hz "
            f"needs at least {2 * trim + 1} ({trim} are dropped at each end).",
        )
    joined = {key: sink.finish(vector=key in ("t", "s")) for key, sink in sinks.items()}
    settings = {
        "cutoff_hz": float(cutoff_hz),
        "cutoff_rule": cutoff_rule,
        "decimation_cutoff_hz": float(decimation_cutoff_hz),
        "decimation_cutoff_rule": band_rule,
        "filter_order": int(filter_order),
        "trim": int(trim),
        "padding": int(padding),
        "time_step": float(h),
    }
    segment_index = joined["s"]
    if not is_stored(segment_index):
        segment_index = segment_index.astype(np.int64)
    return {
        label: TorqueValidation(
            joint_names=tuple(log.joint_names),
            t=joined["t"],
            measured=joined["m"],
            predicted=smooth_sink.finish(),
            raw_measured=joined["rm"],
            raw_predicted=raw_sink.finish(),
            segment=segment_index,
            settings=dict(settings),
            num_samples=int(q.shape[0]),
            moving_widths=widths.copy(),
            moving_rule=moving_rule,
            **moments.metrics(j),
        )
        for j, (label, (smooth_sink, raw_sink)) in enumerate(
            zip(labels, predictions, strict=True)
        )
    }


def _moving_widths(
    log: Any, sign: Any, cutoff_hz: float, decimation_cutoff_hz: float
) -> tuple[np.ndarray, str]:
    """``(w, rule)``: the standstill widths of the moving metrics [rad/s or m/s].

    The robot's dead zone (the fit's: ``"dead zone"``), else
    :func:`drake_dynid.offline.standstill_widths` on this log with the
    validation's cutoffs (``"measured"``); when the log is too short to measure
    them, infinite widths (no sample counts as moving: the moving metrics are
    NaN) and ``"none"``, the validation's own checks naming a log too short for
    itself. A joint whose finite positions are all one value never moves
    (infinite width).
    """
    from drake_dynid.core.blocks import constant_columns
    from drake_dynid.offline import standstill_widths

    n = int(log.q.shape[1])
    if isinstance(sign, DeadZoneSign):
        return np.broadcast_to(np.asarray(sign.width, float), (n,)).copy(), "dead zone"
    try:
        widths = standstill_widths(
            log, cutoff_hz=cutoff_hz, decimation_cutoff_hz=decimation_cutoff_hz
        )
    except ValueError:  # a segment too short for its filters
        widths = None
    if widths is None:
        return np.full(n, np.inf), "none"
    widths = np.array(widths, dtype=float)
    # A joint whose position never changes (a frozen encoder) does not move: the
    # width measured on it is round-off, which the round-off velocities of its
    # filtered constant pass (3 % of the samples of a frozen iiwa7 joint).
    for j, _ in constant_columns(log.q):
        widths[j] = np.inf
    return widths, "measured"


def split_log(log: Any, fraction: float) -> tuple[Any, Any]:
    """Splits a log in time: the first ``fraction`` of its samples, and the rest.

    Args:
        log: a :class:`~drake_dynid.logs.RobotLog`.
        fraction: share of the samples in the first part, in (0, 1).

    Returns:
        ``(first, rest)``, two ``RobotLog``s (the warnings stay with the first;
        both keep the time offset and their rows' ``filled`` flags). A long
        log's stored t, q and τ are split into lazy views, not loaded.
    """
    owner = "split_log"
    fraction = check.real(owner, "fraction", fraction)
    if not 0.0 < fraction < 1.0:
        check.fail(owner, f"fraction must be in (0, 1); got {fraction}.")
    k = round(fraction * log.num_samples)
    if k < 2 or log.num_samples - k < 2:
        check.fail(
            owner,
            f"fraction {fraction} of {log.num_samples} samples leaves a part with "
            "fewer than 2 samples.",
        )
    kind = type(log)
    filled = getattr(log, "filled", None)
    offset = getattr(log, "time_offset", 0.0)
    parts = []
    for a, b, warnings in ((0, k, log.warnings), (k, log.num_samples, ())):
        parts.append(
            kind(
                *(segment(x, a, b) for x in (log.t, log.q, log.tau)),
                log.joint_names,
                log.time_step,
                warnings,
                offset,
                None if filled is None else np.asarray(filled)[a:b],
            )
        )
    return parts[0], parts[1]


# ----------------------------------------------------------------------------------
# Results files (the JSON of ``dynid offline/identify --json``).


def read_results(path: str | os.PathLike) -> dict[str, Any]:
    """Reads a results file (``dynid offline/identify --json``) as a dict.

    Raises:
        FileNotFoundError: no such file.
        ValueError: not JSON, or no ``parameters`` list.
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        raise IsADirectoryError(
            f"results file {path}: is a directory, expected a file."
        )
    if not os.path.isfile(path):
        raise FileNotFoundError(f"results file {path}: no such file.")
    with open(path, "rb") as stream:
        text = check.utf8_text(stream.read(), f"results file {path}")
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise ValueError(f"results file {path}: not valid JSON ({error}).") from None
    if not isinstance(document, dict) or not isinstance(
        document.get("parameters"), list
    ):
        raise ValueError(
            f"results file {path}: expected a JSON object with a 'parameters' list "
            "(written by dynid offline, identify or params --json; dynid excite's "
            "--json is a trajectory)."
        )
    return document


def _same_definition(a: Mapping[str, Any], b: Mapping[str, float]) -> bool:
    if set(a) != set(b):
        return False
    return all(
        isinstance(a[k], int | float)
        and abs(float(a[k]) - b[k]) <= _DEFINITION_TOLERANCE * max(1.0, abs(b[k]))
        for k in b
    )


def check_parameters(robot: Any, parameters: Any, source: str) -> np.ndarray:
    """Checks a ``parameters`` list against the robot's base set; returns θ.

    Every entry must have the robot's base parameter name (same order), the same
    definition (regrouping coefficients within 1e-6) and a finite value.

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel`.
        parameters: list of ``{"name", "value", "definition"}`` dicts.
        source: what to call the list in messages (e.g. the file name).

    Raises:
        ValueError: naming the first mismatch.
    """
    base = robot.base
    expected = tuple(base.names)
    if not isinstance(parameters, list) or not all(
        isinstance(p, dict) and "name" in p for p in parameters
    ):
        raise ValueError(
            f"{source}: 'parameters' must be a list of objects with a name."
        )
    names = tuple(str(p["name"]) for p in parameters)
    where = f"{robot.path or 'the URDF'} (friction {','.join(robot.friction) or 'none'}"
    where += ", rotor inertia)" if robot.rotor_inertia else ")"
    if names != expected:
        first = next(
            (
                k
                for k, (a, b) in enumerate(zip(names, expected, strict=False))
                if a != b
            ),
            min(len(names), len(expected)),
        )
        got = names[first] if first < len(names) else "(none)"
        want = expected[first] if first < len(expected) else "(none)"
        counts = (
            f"{source}'s {len(names)} base parameters are not those of {where}"
            if len(names) == len(expected)
            else f"{source} holds {len(names)} base parameters but {where} has "
            f"{len(expected)}"
        )
        raise ValueError(
            f"{counts}; they differ at position {first + 1}: {got!r} in the "
            f"file, {want!r} expected. Were they identified on another robot, on other "
            "joints (--joints, --lock) or with other --friction?"
        )
    theta = np.empty(len(names))
    for k, (entry, definition) in enumerate(
        zip(parameters, base.definitions, strict=True)
    ):
        given = entry.get("definition")
        if given is not None and not (
            isinstance(given, dict) and _same_definition(given, definition)
        ):
            raise ValueError(
                f"{source}: parameter {names[k]} is defined as {given} in the file but "
                f"as {dict(definition)} by {where}: the base parameters belong to "
                "another model (other link geometry or URDF)."
            )
        value = entry.get("value")
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not (math.isfinite(value))
        ):
            raise ValueError(
                f"{source}: parameter {names[k]} has no finite value ({value!r}); the "
                "estimate in the file is not valid."
            )
        theta[k] = float(value)
    return theta


def read_estimates(
    document: Mapping[str, Any], robot: Any, source: str
) -> dict[str, np.ndarray]:
    """The estimates held by a results document, checked against the robot.

    Returns:
        ``{"fit": θ}`` (the ``parameters`` list), plus ``{"physical": θ}`` when
        the file holds a ``physical`` section (``dynid offline --physical``).
    """
    out = {"fit": check_parameters(robot, document.get("parameters"), source)}
    physical = document.get("physical")
    if isinstance(physical, dict) and "parameters" in physical:
        out["physical"] = check_parameters(
            robot, physical["parameters"], f"{source} (physical)"
        )
    return out
