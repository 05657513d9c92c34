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
4. parallel decimation of W and τ: the same zero-phase low-pass at f_d on every
   column, then one sample in D; it removes the equation noise above the dynamics
   band and keeps ``τ = W X``;
5. stack all segments and solve ``min ‖τ - W X‖`` by QR (IDIM-LS), or with one
   weight 1/σ_j per joint (IDIM-WLS), with Gautier's σ (docs/MATH.md §4) times
   the decimated rows' correlation factor √(f_s/(2·D·B_n))
   (``core.idim_auto.decimated_noise_factor``, docs/MATH.md §5).

Steps 2-4 are streamed (:mod:`drake_dynid.core.idim_stream`): the friction
columns and τ are decimated at the full rate, while the rigid-body columns, the
expensive ones, are evaluated only every D1-th sample, D = D1·D2, with the
decimation in two stages (an anti-alias FIR to f_s/D1 on τ and friction, then
the order-8 Butterworth at f_d on every column at f_s/D1). Memory does not grow
with the log length: a long log read from a file stays on disk and is read a
block at a time, and each block of decimated rows is reduced by QR per joint into
the equations so far (:func:`offline_rows`, ``core.idim.reduce_rows``), which
step 5 solves (``core.idim.idim_solve``; the physically consistent solve too,
``drake_dynid.physical.solve_physical_reduced``); only ``keep_rows`` keeps the K
decimated rows. On a 7-DOF arm the regressor runs on about one sample in 40
instead of all of them.
``regressor_decimation=1`` evaluates every sample: the one-stage parallel
decimation (:func:`drake_dynid.core.idim.parallel_decimation`) to round-off.
The estimates of the two agree to a small fraction of their σ (tests/test_offline.py).

Two cutoffs, two jobs. f_c (position filter) must leave the motion undistorted:
W is nonlinear in q, so a distorted q would bias W; f_c sits well above the
excitation band. f_d (decimation filter) acts on a *linear* equation, so it may
cut into the band without bias: it is set just above the band, ``f_d = min(f_c,
1.5·B)`` with B the velocity bandwidth of the log
(:func:`drake_dynid.core.excitation.estimate_bandwidth`, 99 % of the velocity
power). Between B and f_c the log holds almost no motion but most of the noise
of v̇ (which grows like f² times the position noise): on the paper's 2R at SNR
30 dB (automatic f_c 1.61 Hz), f_d = f_c gave 1.28 / 6.73 % mean inertial /
friction error with IDIM-LS, f_d = 1.5·B (0.93 Hz) 0.83 / 4.50 % (40 seeds, the
main scenario of benchmarks/bench_accuracy.py).

The automatic settings (``cutoff_hz``, ``decimation_cutoff_hz``, ``decimation``
None) are those of :mod:`drake_dynid.core.idim_auto`: f_c minimising the expected
error of v̇ (the filter's droop on the measured motion against the noise it
passes), f_d = min(f_c, 1.5·B), D = floor(0.25·fs/f_d)
rounded down to a multiple of D1.

The work runs with one BLAS thread (:func:`drake_dynid.core._threads.thread_limit`;
``DYNID_THREADS`` changes it).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core import idim_stream
from drake_dynid.core._threads import release_heap, thread_limit
from drake_dynid.core.blocks import is_stored, segment
from drake_dynid.core.friction import EXACT_SIGN
from drake_dynid.core.idim import (
    ReducedRows,
    default_padding,
    default_trim,
    idim_solve,
    reduce_rows,
)
from drake_dynid.core.idim_auto import (
    DECIMATION_BAND_FACTOR,
    MAX_AUTO_CUTOFF_HZ,
    auto_cutoff,
    auto_cutoff_rule,
    auto_decimation,
    auto_decimation_cutoff,
    check_cutoff_run,
    decimated_noise_factor,
    decimation_cutoff,
)
from drake_dynid.core.idim_checks import check_offline_settings
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION

__all__ = [
    "DECIMATION_BAND_FACTOR",
    "MAX_AUTO_CUTOFF_HZ",
    "OfflineResult",
    "OfflineRows",
    "auto_cutoff",
    "auto_decimation",
    "auto_decimation_cutoff",
    "identify_offline",
    "log_decimation_cutoff",
    "log_velocity_band",
    "offline_rows",
    "standstill_widths",
]


@dataclass(frozen=True, eq=False)
class OfflineResult:
    """Outcome of :func:`identify_offline`.

    Attributes:
        names: (p,) base parameter names.
        theta: (p,) estimate X̂ (NaN when not valid) [units of the parameters].
        std: (p,) standard deviations σ_X: Gautier's times
            ``settings["sigma_correlation_factor"]`` (NaN when not valid).
        relative_std_percent: (p,) 100·σ_X/|X̂| (> 30 %: not identified).
        condition_number: condition number of the column-scaled stacked W.
        num_rows: rows of the least squares (decimated samples × joints).
        residual_std: σ_ρ = ‖τ - W X̂‖/√(r - p) [N·m or N] (≈ 1 for WLS, whose
            residual is weighted).
        valid: True when X̂ and σ are meaningful.
        reason: empty when valid; otherwise what is wrong.
        settings: the settings used: ``cutoff_hz``, ``cutoff_rule`` ("auto" or
            "given"), ``decimation``, ``decimation_rule``, ``decimation_cutoff_hz``,
            ``decimation_cutoff_rule``, ``regressor_decimation`` (D1: the
            rigid-body columns are evaluated every D1-th sample),
            ``regressor_decimation_rule``, ``weighted``, ``filter_order``,
            ``trim`` and ``padding`` [samples per segment end],
            ``max_condition``, ``time_step``.
        num_samples: samples in the log (N).
        num_samples_used: samples whose rows entered the least squares, before
            decimation (finite segments minus the trimmed ends).
        num_segments: finite segments in the log.
        num_segments_used: segments long enough to give rows.
        unidentified: names of the parameters that the data does not excite.
        rows: with ``keep_rows=True``, a copy of the stacked decimated rows W
            (M, n, p) whose reduction (``reduced``) the least squares solved
            (unweighted); else None.
        torques: with ``keep_rows=True``, the matching torques τ (M, n).
        reduced: those equations reduced by QR per joint
            (``core.idim.reduce_rows``, n (p + 1)² numbers whatever the log's
            length), e.g. for ``drake_dynid.physical.solve_physical_reduced``.
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
    reduced: ReducedRows | None = None

    @property
    def model(self) -> str:
        """``"idim-wls"`` or ``"idim-ls"``."""
        return "idim-wls" if self.settings.get("weighted") else "idim-ls"


def _provider(robot: Any) -> Any:
    """The fastest object with ``idim_rows`` and ``names`` for this robot."""
    fast = robot.rows_provider() if hasattr(robot, "rows_provider") else robot
    return fast if hasattr(fast, "idim_rows") else robot


@dataclass(frozen=True, eq=False)
class OfflineRows:
    """The decimated equations ``tau = W X`` of a log (:func:`offline_rows`).

    Attributes:
        names: (p,) column names (base parameters).
        reduced: the K decimated equations of all segments, reduced by QR per
            joint as they were computed (``core.idim.reduce_rows``; solved by
            ``core.idim.idim_solve``).
        W: with ``keep_rows``, (K, n, p) the decimated rows, all segments stacked
            [N·m or N per unit]; else None.
        tau: with ``keep_rows``, (K, n) the decimated torques [N·m or N]; else None.
        settings: the filter settings (see :class:`OfflineResult`).
        num_samples: samples in the log.
        num_samples_used: samples of the finite segments minus the trimmed ends.
        num_segments: finite segments in the log.
        num_segments_used: segments long enough to give rows.
    """

    names: tuple[str, ...]
    reduced: ReducedRows
    W: np.ndarray | None
    tau: np.ndarray | None
    settings: dict[str, Any]
    num_samples: int
    num_samples_used: int
    num_segments: int
    num_segments_used: int


def _check_log(owner: str, log: Any, robot: Any, rows: Any) -> float:
    for attribute in ("t", "q", "tau", "time_step", "joint_names"):
        if not hasattr(log, attribute):
            raise TypeError(
                f"{owner}: log must be a RobotLog; got {type(log).__name__}."
            )
    expected = getattr(robot, "joint_names", log.joint_names)
    check.log_joints(owner, expected, log.joint_names)
    return check.positive(owner, "time_step", log.time_step, "s")


def offline_rows(
    log: Any,
    robot: Any,
    *,
    cutoff_hz: float | None = None,
    decimation: int | None = None,
    decimation_cutoff_hz: float | None = None,
    filter_order: int = 4,
    regressor_decimation: int | None = None,
    keep_rows: bool = False,
) -> OfflineRows:
    """Steps 1-4 of the chain: the decimated rows and torques of every segment.

    Arguments as :func:`identify_offline`. Each block of decimated rows is
    reduced by QR into the equations so far (``core.idim.reduce_rows``) as it
    comes. Memory: a few blocks and n (p + 1)² floats, whatever the log length;
    with ``keep_rows``, the decimated rows too (K·n·p floats, K ≈ N/D).
    """
    owner = "identify_offline"
    rows = _provider(robot)
    h = _check_log(owner, log, robot, rows)
    names = tuple(rows.names)
    filter_order = check.integer(owner, "filter_order", filter_order, minimum=1)
    # A long log read from a file stays on disk, read a block at a time.
    q = log.q if is_stored(log.q) else np.asarray(log.q, dtype=float)
    tau = log.tau if is_stored(log.tau) else np.asarray(log.tau, dtype=float)
    check.log_magnitudes(owner, q, tau)
    n = q.shape[1]
    segments = log.good_segments()
    if not segments:
        check.fail(owner, "the log has no finite sample (every row has a NaN).")
    # The given settings against the log, before any filter or row (hard limits).
    check_offline_settings(
        q,
        h,
        segments,
        cutoff_hz=cutoff_hz,
        decimation=decimation,
        decimation_cutoff_hz=decimation_cutoff_hz,
        num_joints=n,
        num_parameters=len(names),
        owner=owner,
    )
    longest = max(segments, key=lambda s: s[1] - s[0])
    cutoff_rule = "given" if cutoff_hz is not None else "auto"
    if cutoff_hz is None:
        check_cutoff_run(
            owner, longest[1] - longest[0], "the longest finite segment has"
        )
        cutoff_hz = log.on_longest_run(auto_cutoff_rule(filter_order, auto_cutoff))
    cutoff_hz = check.below_nyquist(owner, "cutoff_hz", cutoff_hz, h)
    decimation_rule = "given" if decimation is not None else "auto"
    if decimation is not None:
        decimation = check.integer(owner, "decimation", decimation, minimum=1)
    decimation_cutoff_rule = "given" if decimation_cutoff_hz is not None else "auto"
    if decimation_cutoff_hz is None:
        decimation_cutoff_hz = log_decimation_cutoff(log, cutoff_hz)
        if decimation is not None:
            decimation_cutoff_hz = min(decimation_cutoff_hz, 0.4 / (decimation * h))
    decimation_cutoff_hz = check.below_nyquist(
        owner, "decimation_cutoff_hz", decimation_cutoff_hz, h
    )
    trim = default_trim(h, cutoff_hz)
    padding = default_padding(h, cutoff_hz)
    minimum = 2 * trim + 1

    # Friction columns go through the decimation at the full rate, with the
    # provider's Coulomb law (a RobotModel's ``sign``: a dead zone by default in
    # dynid; a coupled motor's Coulomb column with its own, ``motor_columns``);
    # the others (rigid body) are evaluated every D1-th sample.
    sign = getattr(rows, "sign", EXACT_SIGN)
    layout = idim_stream.friction_layout(
        names, rows.idim_rows, n, sign, getattr(rows, "motor_columns", None)
    )
    factor_rule = "given" if regressor_decimation is not None else "auto"
    if regressor_decimation is not None:
        regressor_decimation = check.integer(
            owner, "regressor_decimation", regressor_decimation, minimum=1
        )
        if layout is None and regressor_decimation > 1:
            check.fail(
                owner,
                "regressor_decimation must be 1 for this row provider: its columns "
                "named FVj/FCj/OFFj (or FCmk) are not the friction columns v_j, "
                "s(v_j), 1 (or a coupled motor's R_kᵀ s(x_k)).",
            )
    if layout is None:  # every column from the rows, at every sample
        regressor_decimation = 1
        layout = idim_stream.FrictionLayout.rows_only(len(names), n)
    if decimation is None:
        decimation = auto_decimation(h, decimation_cutoff_hz)
        factor = regressor_decimation or idim_stream.regressor_decimation(
            h, cutoff_hz, decimation, decimation_cutoff_hz, trim, divides=False
        )
        if factor > decimation:
            check.fail(
                owner,
                f"regressor_decimation must be <= the decimation {decimation}; got "
                f"{factor}.",
            )
        decimation = factor * (decimation // factor)
    plan = idim_stream.stream_plan(
        h,
        cutoff_hz=cutoff_hz,
        filter_order=filter_order,
        trim=trim,
        padding=padding,
        decimation=decimation,
        decimation_cutoff_hz=decimation_cutoff_hz,
        factor=regressor_decimation,
    )
    friction, rigid_index = layout.friction, list(layout.rigid)

    def rigid(q_f: np.ndarray, v: np.ndarray, vdot: np.ndarray) -> np.ndarray:
        return np.asarray(rows.idim_rows(q_f, v, vdot), dtype=float)[..., rigid_index]

    release_heap()  # the automatic settings' spectra: not under the rows' peak
    used = [(start, stop) for start, stop in segments if stop - start >= minimum]
    # Rows of each segment: ceil((N - 2·trim)/D); W allocated once (no copies)
    # when kept, else each block reduced into the equations so far.
    counts = [-(-(stop - start - 2 * trim) // decimation) for start, stop in used]
    total = sum(counts) if keep_rows else 0
    W = np.zeros((total, n, len(names)))
    tau_out = np.empty((total, n))
    reduced = ReducedRows(
        R=np.zeros((n, len(names) + 1, len(names) + 1)), num_samples=0
    )
    row = 0
    for start, stop in used:
        for W_rigid, F, tau_d in idim_stream.decimated_chunks(
            segment(q, start, stop),
            segment(tau, start, stop),
            plan,
            rigid,
            friction,
            sign,
            channels=layout.channels,
        ):
            count = tau_d.shape[0]
            part = (
                W[row : row + count] if keep_rows else np.zeros((count, *W.shape[1:]))
            )
            part[..., rigid_index] = W_rigid
            part[..., list(layout.columns)] = layout.place(F)
            reduced = reduce_rows(part, tau_d, reduced)
            if keep_rows:
                tau_out[row : row + count] = tau_d
            row += count
    assert row == sum(counts)
    used_samples = sum(stop - start - 2 * trim for start, stop in used)
    if not used:
        check.fail(
            owner,
            f"no finite segment of the log is long enough: the longest has "
            f"{longest[1] - longest[0]} samples ({(longest[1] - longest[0]) * h:g} s) "
            f"and the cutoff {cutoff_hz:.3g} Hz needs at least {minimum} "
            f"({minimum * h:g} s: {trim} samples are dropped at each end); record a "
            "longer log or raise the cutoff.",
        )
    settings = {
        "cutoff_hz": float(cutoff_hz),
        "cutoff_rule": cutoff_rule,
        "decimation": int(decimation),
        "decimation_rule": decimation_rule,
        "decimation_cutoff_hz": float(decimation_cutoff_hz),
        "decimation_cutoff_rule": decimation_cutoff_rule,
        "regressor_decimation": int(plan.factor),
        "regressor_decimation_rule": factor_rule,
        "padding": int(padding),
        "filter_order": int(filter_order),
        "trim": int(trim),
        "time_step": float(h),
    }
    return OfflineRows(
        names=names,
        reduced=reduced,
        W=W if keep_rows else None,
        tau=tau_out if keep_rows else None,
        settings=settings,
        num_samples=int(q.shape[0]),
        num_samples_used=int(used_samples),
        num_segments=len(segments),
        num_segments_used=len(used),
    )


def log_decimation_cutoff(log: Any, cutoff_hz: float) -> float:
    """:func:`auto_decimation_cutoff` on the log's longest run of good samples.

    ``min(f_c, 1.5·B)`` [Hz] with the velocity band B measured once per log
    (``RobotLog.on_longest_run``): the dead zone, the off-line chain and the
    validation of one log share it.
    """
    return decimation_cutoff(log_velocity_band(log), cutoff_hz)


def log_velocity_band(log: Any) -> float | None:
    """``measured_velocity_band`` of the log's longest run of good samples [Hz].

    Its value, from the periodogram that the position noise and RMS velocity
    share (``core.excitation.motion_noise_band``, computed once per log:
    ``RobotLog.on_longest_run``; the dead zone, the rows' choice and the
    excitation band each took it apart). None when it cannot be measured (no
    joint moves above the noise, fewer than 64 samples).

    Raises:
        ValueError: the log has no good sample.
    """
    from drake_dynid.core.excitation import motion_noise_band

    if not log.good_segments():
        log.on_longest_run(motion_noise_band)  # raises: no good sample
    try:
        return log.on_longest_run(motion_noise_band)[2]  # type: ignore[no-any-return]
    except ValueError:  # as measured_velocity_band: too few samples
        return None


def standstill_widths(
    log: Any,
    *,
    cutoff_hz: float | None = None,
    decimation_cutoff_hz: float | None = None,
) -> np.ndarray | None:
    """Coulomb dead-zone half-widths per joint measured on a log [rad/s or m/s].

    ``w_j = 3 max(σ_r,j, G σ_q,j)`` (``drake_dynid.core.standstill``, docs/MATH.md
    §2): σ_r,j the MAD of the part of the off-line velocity above twice the
    parallel decimation's band, σ_q,j the white position noise (the floor of the
    spectrum above f_s/4, ``core.excitation.motion_noise_band``, on the longest
    run of good samples) and G its gain through the off-line velocity. The
    cutoffs default to the automatic rules (``drake_dynid.core.idim_auto``) on the
    longest finite segment.

    Args:
        log: a :class:`~drake_dynid.logs.RobotLog`.
        cutoff_hz: position cutoff f_c [Hz]; None: :func:`auto_cutoff`.
        decimation_cutoff_hz: f_d [Hz]; None: :func:`auto_decimation_cutoff`.

    Returns:
        (n,) widths, in the log's joint order; None when no finite segment is
        long enough to measure the noise (2·trim + 32 samples, and 64); 3 G σ_q
        alone when none holds an interior clear of the filters' edge transients
        (``core.standstill.shortest_run``).

    Raises:
        ValueError: a cutoff that is not in (0, Nyquist).
    """
    from drake_dynid.core.excitation import MIN_SPECTRUM_SAMPLES, motion_noise_band
    from drake_dynid.core.standstill import (
        MIN_RUN,
        NOISE_BAND_FACTOR,
        dead_zone_widths,
    )

    owner = "standstill_widths"
    h = log.time_step
    good = log.good_segments()
    check_offline_settings(
        log.q,
        h,
        good,
        cutoff_hz=cutoff_hz,
        decimation=None,
        decimation_cutoff_hz=decimation_cutoff_hz,
        num_joints=log.q.shape[1],
        num_parameters=0,
        owner=owner,
    )
    if cutoff_hz is not None:
        cutoff_hz = check.below_nyquist(owner, "cutoff_hz", cutoff_hz, h)
    if decimation_cutoff_hz is not None:
        decimation_cutoff_hz = check.below_nyquist(
            owner, "decimation_cutoff_hz", decimation_cutoff_hz, h
        )
    segments = [segment(log.q, a, b) for a, b in good]
    if not segments or max(len(s) for s in segments) < MIN_SPECTRUM_SAMPLES:
        return None
    longest = max(segments, key=len)
    fc = log.on_longest_run(auto_cutoff) if cutoff_hz is None else cutoff_hz
    if len(longest) < 2 * default_trim(h, fc) + MIN_RUN:
        return None
    if decimation_cutoff_hz is None:
        decimation_cutoff_hz = log_decimation_cutoff(log, fc)
    band = min(fc, NOISE_BAND_FACTOR * decimation_cutoff_hz)
    widths = dead_zone_widths(
        segments,
        h,
        cutoff_hz=fc,
        band_cutoff_hz=band,
        position_noise=log.on_longest_run(motion_noise_band)[1],
    )
    release_heap()  # the residuals: not under the next phase's peak
    return widths


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
    regressor_decimation: int | None = None,
) -> OfflineResult:
    """Off-line IDIM-LS / IDIM-WLS of the base parameters from a robot log.

    Solves ``τ = W(q_f, v, v̇) X`` stacked over every finite segment of the log
    (see the module docstring for the chain)::

        q_f = zero-phase Butterworth(q)                      [rad or m]
        v_k = (q_f[k+1] - q_f[k-1]) / (2h),  v̇_k = (q_f[k+1] - 2q_f[k] + q_f[k-1]) / h²
        X̂ = argmin ‖D(τ) - D(W) X‖ (optionally weighted 1/σ_j per joint)

    with D the parallel decimation (zero-phase low-pass at f_d, one sample in D);
    Gautier's σ_X times the decimated rows' correlation factor (docs/MATH.md §5)
    and the column-scaled condition number (docs/MATH.md §4).

    Args:
        log: a :class:`~drake_dynid.logs.RobotLog` whose joints are the robot's.
        robot: a :class:`~drake_dynid.robot.RobotModel` (its ``rows_provider()``
            is used when it has ``idim_rows``: the analytic 2R rows are much
            faster), or any object with ``names`` and ``idim_rows(q, v, vdot)``
            whose columns other than ``FVj``/``FCj``/``OFFj`` are smooth in
            (q, v, v̇).
        cutoff_hz: Butterworth cutoff f_c [Hz]; None: :func:`auto_cutoff` on the
            longest finite segment, for ``filter_order``.
        decimation: parallel decimation factor D (>= 1); None:
            :func:`auto_decimation` of f_d, rounded down to a multiple of D1.
        decimation_cutoff_hz: low-pass f_d of the parallel decimation [Hz]; None:
            :func:`auto_decimation_cutoff` (``min(f_c, 1.5·B)``), lowered to
            0.4·fs/D when D is given.
        weighted: IDIM-WLS (one weight per joint) instead of IDIM-LS.
        filter_order: Butterworth order (>= 1; zero phase doubles it).
        max_condition: largest accepted condition number of the column-scaled W.
        keep_rows: keep the stacked decimated rows and torques in the result
            (``rows``, ``torques``), e.g. for ``drake_dynid.physical``.
        regressor_decimation: D1, the rigid-body columns are evaluated every
            D1-th sample (a divisor of D); 1: every sample (the one-stage parallel
            decimation); None: the largest allowed
            (:func:`~drake_dynid.core.idim_stream.regressor_decimation`).

    Returns:
        An :class:`OfflineResult` (check ``valid``).

    Raises:
        ValueError: bad arguments, joints that differ from the robot's, or a log
            without any finite segment long enough for the filter.
    """
    owner = "identify_offline"
    max_condition = check.greater_than(owner, "max_condition", max_condition, 1.0)
    if not isinstance(weighted, bool | np.bool_):
        raise TypeError(
            f"{owner}: weighted must be a bool; got {type(weighted).__name__}."
        )
    with thread_limit():
        rows = offline_rows(
            log,
            robot,
            cutoff_hz=cutoff_hz,
            decimation=decimation,
            decimation_cutoff_hz=decimation_cutoff_hz,
            filter_order=filter_order,
            regressor_decimation=regressor_decimation,
            keep_rows=keep_rows,
        )
        fit = idim_solve(
            rows.reduced,
            weighted=weighted,
            names=rows.names,
            max_condition=max_condition,
        )
    # The decimated rows' noise is correlated (core.idim_auto.decimated_noise_factor).
    correlation = decimated_noise_factor(
        rows.settings["time_step"],
        rows.settings["decimation"],
        rows.settings["decimation_cutoff_hz"],
    )
    settings = {
        **rows.settings,
        "weighted": bool(weighted),
        "max_condition": float(max_condition),
        "sigma_correlation_factor": float(correlation),
    }
    return OfflineResult(
        names=rows.names,
        theta=fit.theta,
        std=fit.std * correlation,
        relative_std_percent=fit.relative_std_percent * correlation,
        condition_number=float(fit.condition_number),
        num_rows=int(fit.num_rows),
        residual_std=float(fit.residual_std),
        valid=bool(fit.valid),
        reason=fit.reason,
        settings=settings,
        num_samples=rows.num_samples,
        num_samples_used=rows.num_samples_used,
        num_segments=rows.num_segments,
        num_segments_used=rows.num_segments_used,
        unidentified=tuple(fit.unidentified),
        rows=rows.W,
        torques=rows.tau,
        reduced=rows.reduced,
    )
