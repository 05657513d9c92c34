"""Off-line IDIM-LS / IDIM-WLS on a recorded robot log (Gautier's practice).

The inverse dynamic model (docs/MATH.md §5) is linear in the p base parameters X::

    τ(t_k) = W(q_k, v_k, v̇_k) X + e_k      W: n × p per sample [N·m or N per unit]

:func:`identify_offline` runs the whole off-line chain on a
:class:`~drake_dynid.logs.RobotLog`:

1. split the log into its finite segments (NaN rows, ``RobotLog.bad_samples``, cut
   it; no NaN ever reaches the least squares);
2. per segment, zero-phase Butterworth low-pass of q at f_c and central differences
   for v and v̇ (:func:`drake_dynid.core.idim.offline_derivatives`: odd-reflection
   padding of four cutoff periods, ``trim = 1 + ceil(2/(f_c·h))`` samples dropped
   at each end of the segment, so also next to every gap);
3. rows ``W = robot.idim_rows(q_f, v, v̇)``, torques τ of the same samples;
4. parallel decimation of W and τ (:func:`drake_dynid.core.idim.parallel_decimation`:
   the same zero-phase order-8 Butterworth low-pass at f_d on every column, then
   one sample in D); it removes the equation noise above the dynamics band and
   keeps ``τ = W X``;
5. stack all segments and solve ``min ‖τ - W X‖`` by QR (IDIM-LS), or with one
   weight 1/σ_j per joint (IDIM-WLS), with Gautier's σ (docs/MATH.md §4).

Two cutoffs, two jobs. f_c (position filter) must leave the motion undistorted:
W is nonlinear in q, so a distorted q would bias W; f_c sits well above the
excitation band. f_d (decimation filter) acts on a *linear* equation, so it may
cut into the band without bias: it is set just above the band, ``f_d = min(f_c,
1.5·B)`` with B the velocity bandwidth of the log
(:func:`drake_dynid.core.excitation.estimate_bandwidth`, 99 % of the velocity
power). Between B and f_c the log holds almost no motion but most of the noise
of v̇ (which grows like f² times the position noise): on the paper's 2R at SNR
30 dB, f_d = f_c gave 1.1 / 7.5 % mean inertial / friction error, f_d = 1.5·B
0.9 / 4.1 % (60 seeds; benchmarks/bench_accuracy.py).

Automatic cutoff (:func:`auto_cutoff`, used when ``cutoff_hz`` is None). The
Welch spectrum S_j(f) of every detrended position q_j (Blackman-Harris window,
4 s segments) gives

* its noise floor N_j: the median of S_j over [fs/4, fs/2] (white measurement
  noise is flat; a rigid robot's motion has no power there);
* its noise crossover f_x: the highest frequency where some S_j > 100·N_j (20 dB
  above the floor): beyond it the filter would only pass noise, whose second
  difference grows like f⁵ and biases W (errors in variables);
* its excitation bandwidth f_99: the frequency below which 99 % of the power
  of (S_j - N_j)⁺ up to f_x lies (largest over the joints; above f_x the noise's
  fluctuations would add up);

and ``f_c = min(max(f_x, 2·f_99), 40 Hz, fs/5)``. The factor 2 keeps the
zero-phase Butterworth (|H|² = 1/(1+(f/f_c)^(2·order))) above 0.996 in the
excitation band. 40 Hz is ten times a typical 4 Hz position closed-loop bandwidth
(Gautier's ω_c ≥ 10·ω_dyn), the cap for clean logs. On the paper's 2R arm at
1 kHz this gives about 1.5 Hz at SNR 30 dB and 40 Hz without noise.

Automatic decimation (``decimation`` None): ``D = max(1, floor(0.25·fs/f_d))``,
so that the decimated Nyquist frequency is at least twice f_d (the zero-phase
order-8 Butterworth is below 1.5e-5 there: no aliasing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal

from drake_dynid.core import _validate as check
from drake_dynid.core.excitation import estimate_bandwidth
from drake_dynid.core.idim import (
    default_padding,
    default_trim,
    idim_least_squares,
    offline_derivatives,
    parallel_decimation,
)
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION

__all__ = [
    "OfflineResult",
    "auto_cutoff",
    "auto_decimation",
    "auto_decimation_cutoff",
    "identify_offline",
    "standstill_widths",
]

MAX_AUTO_CUTOFF_HZ = 40.0
"""Cap of the automatic cutoff [Hz] (ten times a 4 Hz position loop bandwidth)."""

_FLOOR_MARGIN = 100.0  # 20 dB above the noise floor
_POWER_SHARE = 0.99  # excitation bandwidth: 99 % of the noise-corrected power
_SPECTRUM_SEGMENT = 4.0  # Welch segment length [s]
DECIMATION_BAND_FACTOR = 1.5
"""Automatic decimation low-pass f_d = min(f_c, 1.5·B), B the velocity bandwidth."""


@dataclass(frozen=True, eq=False)
class OfflineResult:
    """Outcome of :func:`identify_offline`.

    Attributes:
        names: (p,) base parameter names.
        theta: (p,) estimate X̂ (NaN when not valid) [units of the parameters].
        std: (p,) Gautier standard deviations σ_X (NaN when not valid).
        relative_std_percent: (p,) 100·σ_X/|X̂| (> 30 %: not identified).
        condition_number: condition number of the column-scaled stacked W.
        num_rows: rows of the least squares (decimated samples × joints).
        residual_std: σ_ρ = ‖τ - W X̂‖/√(r - p) [N·m or N] (≈ 1 for WLS, whose
            residual is weighted).
        valid: True when X̂ and σ are meaningful.
        reason: empty when valid; otherwise what is wrong.
        settings: the settings used: ``cutoff_hz``, ``cutoff_rule`` ("auto" or
            "given"), ``decimation``, ``decimation_rule``, ``decimation_cutoff_hz``,
            ``decimation_cutoff_rule``, ``weighted``, ``filter_order``, ``trim`` and
            ``padding`` [samples per segment end], ``max_condition``.
        num_samples: samples in the log (N).
        num_samples_used: samples whose rows entered the least squares, before
            decimation (finite segments minus the trimmed ends).
        num_segments: finite segments in the log.
        num_segments_used: segments long enough to give rows.
        unidentified: names of the parameters that the data does not excite.
        rows: with ``keep_rows=True``, the stacked decimated rows W (M, n, p)
            that entered the least squares (unweighted); else None.
        torques: with ``keep_rows=True``, the matching torques τ (M, n).
    """

    names: tuple[str, ...]
    theta: np.ndarray
    std: np.ndarray
    relative_std_percent: np.ndarray
    condition_number: float
    num_rows: int
    residual_std: float
    valid: bool
    reason: str
    settings: dict[str, Any] = field(default_factory=dict)
    num_samples: int = 0
    num_samples_used: int = 0
    num_segments: int = 0
    num_segments_used: int = 0
    unidentified: tuple[str, ...] = ()
    rows: np.ndarray | None = None
    torques: np.ndarray | None = None

    @property
    def model(self) -> str:
        """``"idim-wls"`` or ``"idim-ls"``."""
        return "idim-wls" if self.settings.get("weighted") else "idim-ls"


def auto_cutoff(q: Any, time_step: float) -> float:
    """Automatic Butterworth cutoff f_c [Hz] from the spectrum of the positions.

    ``f_c = min(max(f_x, 2·f_99), 40 Hz, fs/5)`` with f_x the highest frequency
    where a joint's Welch spectrum is 20 dB above its noise floor (median over
    [fs/4, fs/2]) and f_99 the frequency holding 99 % of the floor-corrected power
    (see the module docstring). Both are the largest over the joints.

    Args:
        q: (N, n) finite positions sampled every ``time_step`` [rad or m].
        time_step: sample period h [s].

    Returns:
        The cutoff [Hz], at least the Welch resolution fs/N_seg.
    """
    owner = "auto_cutoff"
    time_step = check.positive(owner, "time_step", time_step, "s")
    q = check.array(owner, "q", q)
    if q.ndim == 1:
        q = q[:, None]
    if q.ndim != 2 or q.shape[0] < 16:
        check.fail(owner, f"q must have shape (N >= 16, n); got {q.shape}.")
    fs = 1.0 / time_step
    segment = min(q.shape[0], max(16, round(_SPECTRUM_SEGMENT * fs)))
    f, power = signal.welch(
        q,
        fs=fs,
        window="blackmanharris",
        nperseg=segment,
        detrend="linear",
        axis=0,
    )
    resolution = f[1]
    high = f >= 0.25 * fs
    crossover = resolution
    bandwidth = resolution
    for j in range(q.shape[1]):
        spectrum = power[:, j]
        floor = float(np.median(spectrum[high]))
        above = np.flatnonzero(spectrum > _FLOOR_MARGIN * floor)
        if above.size == 0:
            continue
        top = int(above[-1])
        crossover = max(crossover, float(f[top]))
        # Excitation bandwidth: only below the crossover, where the spectrum is
        # signal (above it, the noise's fluctuations would add up).
        excess = np.clip(spectrum[: top + 1] - floor, 0.0, None)
        total = float(excess.sum())
        if total > 0.0:
            share = np.cumsum(excess) / total
            bandwidth = max(bandwidth, float(f[np.argmax(share >= _POWER_SHARE)]))
    cutoff = min(max(crossover, 2.0 * bandwidth), MAX_AUTO_CUTOFF_HZ, 0.2 * fs)
    return float(max(cutoff, resolution))


def auto_decimation(time_step: float, cutoff_hz: float) -> int:
    """``max(1, floor(0.25·fs/f_d))``: the decimated Nyquist frequency is >= 2·f_d.

    Args:
        time_step: sample period h [s].
        cutoff_hz: the decimation low-pass f_d [Hz].
    """
    owner = "auto_decimation"
    time_step = check.positive(owner, "time_step", time_step, "s")
    cutoff_hz = check.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    return max(1, math.floor(0.25 / (time_step * cutoff_hz)))


def auto_decimation_cutoff(q: Any, time_step: float, cutoff_hz: float) -> float:
    """The decimation low-pass ``f_d = min(f_c, 1.5·B)`` [Hz].

    B is the velocity bandwidth of the positions
    (:func:`~drake_dynid.core.excitation.estimate_bandwidth`); when it cannot be
    measured (no joint moves above the noise, or fewer than 64 samples), f_d = f_c
    (the least squares then reports the unexcited parameters).

    Args:
        q: (N, n) finite positions [rad or m].
        time_step: sample period h [s].
        cutoff_hz: the position filter's cutoff f_c [Hz].
    """
    try:
        band = estimate_bandwidth(q, time_step)
    except ValueError:
        return float(cutoff_hz)
    return float(min(cutoff_hz, DECIMATION_BAND_FACTOR * band))


def standstill_widths(
    log: Any,
    *,
    cutoff_hz: float | None = None,
    decimation_cutoff_hz: float | None = None,
) -> np.ndarray | None:
    """Coulomb dead-zone half-widths per joint measured on a log [rad/s or m/s].

    ``w_j = 3 σ_v,j`` with σ_v,j the velocity noise of the off-line equations
    (``drake_dynid.core.standstill``, docs/MATH.md §2): the MAD of the part of
    the velocity that the parallel decimation's low-pass removes. The cutoffs
    default to this module's automatic rules on the longest finite segment.

    Args:
        log: a :class:`~drake_dynid.logs.RobotLog`.
        cutoff_hz: position cutoff f_c [Hz]; None: :func:`auto_cutoff`.
        decimation_cutoff_hz: f_d [Hz]; None: :func:`auto_decimation_cutoff`.

    Returns:
        (n,) widths, in the log's joint order; None when no finite segment is
        long enough to measure the noise (2·trim + 32 samples).

    Raises:
        ValueError: a cutoff that is not in (0, Nyquist).
    """
    from drake_dynid.core.standstill import MIN_RUN, dead_zone_widths

    owner = "standstill_widths"
    h = log.time_step
    if cutoff_hz is not None:
        cutoff_hz = _below_nyquist(owner, "cutoff_hz", cutoff_hz, h)
    if decimation_cutoff_hz is not None:
        decimation_cutoff_hz = _below_nyquist(
            owner, "decimation_cutoff_hz", decimation_cutoff_hz, h
        )
    segments = [log.q[a:b] for a, b in log.good_segments()]
    if not segments or max(len(s) for s in segments) < 16:
        return None
    longest = max(segments, key=len)
    fc = auto_cutoff(longest, h) if cutoff_hz is None else cutoff_hz
    if len(longest) < 2 * default_trim(h, fc) + MIN_RUN:
        return None
    if decimation_cutoff_hz is None:
        decimation_cutoff_hz = auto_decimation_cutoff(longest, h, fc)
    return dead_zone_widths(
        segments, h, cutoff_hz=fc, band_cutoff_hz=min(decimation_cutoff_hz, fc)
    )


def _below_nyquist(owner: str, name: str, value: Any, time_step: float) -> float:
    """A frequency [Hz] in (0, 1/(2h)), or a ValueError naming it."""
    value = check.positive(owner, name, value, "Hz")
    if value >= 0.5 / time_step:
        check.fail(
            owner,
            f"{name} must be < the Nyquist frequency {0.5 / time_step:g} [Hz]; got "
            f"{value:g}.",
        )
    return value


def _provider(robot: Any) -> Any:
    """The fastest object with ``idim_rows`` and ``names`` for this robot."""
    fast = robot.rows_provider() if hasattr(robot, "rows_provider") else robot
    return fast if hasattr(fast, "idim_rows") else robot


def identify_offline(
    log: Any,
    robot: Any,
    *,
    cutoff_hz: float | None = None,
    decimation: int | None = None,
    decimation_cutoff_hz: float | None = None,
    weighted: bool = False,
    filter_order: int = 4,
    max_condition: float = DEFAULT_MAX_CONDITION,
    keep_rows: bool = False,
) -> OfflineResult:
    """Off-line IDIM-LS / IDIM-WLS of the base parameters from a robot log.

    Solves ``τ = W(q_f, v, v̇) X`` stacked over every finite segment of the log
    (see the module docstring for the chain)::

        q_f = zero-phase Butterworth(q)                      [rad or m]
        v_k = (q_f[k+1] - q_f[k-1]) / (2h),  v̇_k = (q_f[k+1] - 2q_f[k] + q_f[k-1]) / h²
        X̂ = argmin ‖D(τ) - D(W) X‖ (optionally weighted 1/σ_j per joint)

    with D the parallel decimation (zero-phase low-pass at f_d, one sample in D);
    Gautier's σ_X and the column-scaled condition number (docs/MATH.md §4).

    Args:
        log: a :class:`~drake_dynid.logs.RobotLog` whose joints are the robot's.
        robot: a :class:`~drake_dynid.robot.RobotModel` (its ``rows_provider()``
            is used when it has ``idim_rows``: the analytic 2R rows are much
            faster), or any object with ``names`` and ``idim_rows(q, v, vdot)``.
        cutoff_hz: Butterworth cutoff f_c [Hz]; None: :func:`auto_cutoff` on the
            longest finite segment.
        decimation: parallel decimation factor D (>= 1); None:
            :func:`auto_decimation` of f_d.
        decimation_cutoff_hz: low-pass f_d of the parallel decimation [Hz]; None:
            :func:`auto_decimation_cutoff` (``min(f_c, 1.5·B)``), lowered to
            0.4·fs/D when D is given.
        weighted: IDIM-WLS (one weight per joint) instead of IDIM-LS.
        filter_order: Butterworth order (>= 1; zero phase doubles it).
        max_condition: largest accepted condition number of the column-scaled W.
        keep_rows: keep the stacked decimated rows and torques in the result
            (``rows``, ``torques``), e.g. for ``drake_dynid.physical``.

    Returns:
        An :class:`OfflineResult` (check ``valid``).

    Raises:
        ValueError: bad arguments, joints that differ from the robot's, or a log
            without any finite segment long enough for the filter.
    """
    owner = "identify_offline"
    for attribute in ("t", "q", "tau", "time_step", "joint_names"):
        if not hasattr(log, attribute):
            raise TypeError(
                f"{owner}: log must be a RobotLog; got {type(log).__name__}."
            )
    rows = _provider(robot)
    names = tuple(rows.names)
    robot_joints = tuple(getattr(robot, "joint_names", log.joint_names))
    if tuple(log.joint_names) != robot_joints:
        check.fail(
            owner,
            f"log joints must be the robot's {', '.join(robot_joints)} in that "
            f"order; got {', '.join(log.joint_names)}.",
        )
    h = check.positive(owner, "time_step", log.time_step, "s")
    filter_order = check.integer(owner, "filter_order", filter_order, minimum=1)
    max_condition = check.greater_than(owner, "max_condition", max_condition, 1.0)
    if not isinstance(weighted, bool | np.bool_):
        raise TypeError(
            f"{owner}: weighted must be a bool; got {type(weighted).__name__}."
        )
    q = np.asarray(log.q, dtype=float)
    tau = np.asarray(log.tau, dtype=float)
    segments = log.good_segments()
    if not segments:
        check.fail(owner, "the log has no finite sample (every row has a NaN).")
    longest = max(segments, key=lambda s: s[1] - s[0])
    cutoff_rule = "given" if cutoff_hz is not None else "auto"
    if cutoff_hz is None:
        if longest[1] - longest[0] < 16:
            check.fail(
                owner,
                f"the longest finite segment has {longest[1] - longest[0]} samples; "
                "at least 16 are needed to choose the cutoff.",
            )
        cutoff_hz = auto_cutoff(q[longest[0] : longest[1]], h)
    cutoff_hz = _below_nyquist(owner, "cutoff_hz", cutoff_hz, h)
    decimation_rule = "given" if decimation is not None else "auto"
    if decimation is not None:
        decimation = check.integer(owner, "decimation", decimation, minimum=1)
    decimation_cutoff_rule = "given" if decimation_cutoff_hz is not None else "auto"
    if decimation_cutoff_hz is None:
        decimation_cutoff_hz = auto_decimation_cutoff(
            q[longest[0] : longest[1]], h, cutoff_hz
        )
        if decimation is not None:
            decimation_cutoff_hz = min(decimation_cutoff_hz, 0.4 / (decimation * h))
    decimation_cutoff_hz = _below_nyquist(
        owner, "decimation_cutoff_hz", decimation_cutoff_hz, h
    )
    if decimation is None:
        decimation = auto_decimation(h, decimation_cutoff_hz)
    trim = default_trim(h, cutoff_hz)
    padding = default_padding(h, cutoff_hz)
    minimum = 2 * trim + 1

    W_parts: list[np.ndarray] = []
    tau_parts: list[np.ndarray] = []
    used_samples = 0
    for start, stop in segments:
        if stop - start < minimum:
            continue
        q_f, v, vdot = offline_derivatives(
            q[start:stop],
            h,
            cutoff_hz=cutoff_hz,
            filter_order=filter_order,
            trim=trim,
            padding=padding,
        )
        W = np.asarray(rows.idim_rows(q_f, v, vdot), dtype=float)
        tau_segment = tau[start + trim : stop - trim]
        used_samples += tau_segment.shape[0]
        W, tau_segment = parallel_decimation(
            W, tau_segment, decimation, cutoff=decimation_cutoff_hz * h
        )
        W_parts.append(W)
        tau_parts.append(tau_segment)
    if not W_parts:
        check.fail(
            owner,
            f"no finite segment of the log is long enough: the longest has "
            f"{longest[1] - longest[0]} samples ({(longest[1] - longest[0]) * h:g} s) "
            f"and the cutoff {cutoff_hz:.3g} Hz needs at least {minimum} "
            f"({minimum * h:g} s: {trim} samples are dropped at each end); record a "
            "longer log or raise the cutoff.",
        )
    W_all, tau_all = np.concatenate(W_parts), np.concatenate(tau_parts)
    fit = idim_least_squares(
        W_all,
        tau_all,
        weighted=weighted,
        names=names,
        max_condition=max_condition,
    )
    settings = {
        "cutoff_hz": float(cutoff_hz),
        "cutoff_rule": cutoff_rule,
        "decimation": int(decimation),
        "decimation_rule": decimation_rule,
        "decimation_cutoff_hz": float(decimation_cutoff_hz),
        "decimation_cutoff_rule": decimation_cutoff_rule,
        "padding": int(padding),
        "weighted": bool(weighted),
        "filter_order": int(filter_order),
        "trim": int(trim),
        "max_condition": float(max_condition),
        "time_step": float(h),
    }
    return OfflineResult(
        names=names,
        theta=fit.theta,
        std=fit.std,
        relative_std_percent=fit.relative_std_percent,
        condition_number=float(fit.condition_number),
        num_rows=int(fit.num_rows),
        residual_std=float(fit.residual_std),
        valid=bool(fit.valid),
        reason=fit.reason,
        settings=settings,
        num_samples=int(q.shape[0]),
        num_samples_used=int(used_samples),
        num_segments=len(segments),
        num_segments_used=len(W_parts),
        unidentified=tuple(fit.unidentified),
        rows=W_all if keep_rows else None,
        torques=tau_all if keep_rows else None,
    )
