"""Standstill and Coulomb friction: the dead-zone width from the log (docs/MATH.md §2).

At rest the estimated velocity v̂ is noise, and sign(v̂) of the Coulomb column is ±1
noise: a joint at rest then pulls its FCj towards whatever its torque does there
(gravity compensation, the controller's dither), and the two engines, whose
differentiators differ, disagree. The treatment (Swevers-style dead zone): the
Coulomb column is s(v) = 0 for |v| <= w_j, sign(v) outside
(``drake_dynid.core.friction.DeadZoneSign``), with one width per joint measured on
the log::

    v_j        velocity of the off-line equations (zero-phase Butterworth of q_j at
               the position cutoff f_c, order N = 4, central differences; core.idim)
    r_j        v_j minus its zero-phase low-pass (order 8) at f_n = min(f_c, 2 f_d),
               twice the parallel decimation's band f_d (min(f_c, 1.5 B), B the
               velocity bandwidth): what the dynamics band and its edge do not
               explain (odd padding of four f_n periods; at each end of a run the
               samples where both filters' slowest modes have not decayed to
               EDGE_DECAY = 1e-4 are dropped, at least two f_n periods: a joint
               still moving there leaves the padding's transient; a run without
               such an interior is left out, and with none σ_v = G σ_q)
    σ_r,j      1.4826 · median|r_j - median r_j|   (MAD: robust to the motion's
               own outliers; = the std for Gaussian noise)       [rad/s or m/s]
    σ_q,j      white position noise: the flat floor of q_j's periodogram above
               f_s/4 (``core.excitation.position_noise_std``)          [rad or m]
    G          noise gain of v_j for white position noise [1/s]:
               G² = (1/π) ∫_0^π |H(e^{iω})|⁴ sin²(ω)/h² dω,
               |H(e^{iω})|² = 1 / (1 + (tan(ω/2) / tan(π f_c h))^(2N))
    σ_v,j      max(σ_r,j, G σ_q,j)
    w_j        3 σ_v,j

Each measure is a lower bound of the velocity noise: σ_r sees only the part above
f_n (but whatever its spectrum: the TIAGo recording's, 4-10 times what its white
floor predicts on arm_1..arm_4), G σ_q the whole band of white noise only. The corner
sits at twice the fit's band because the order-8 low-pass's edge lets the motion
through: at f_d itself a noise-free log (a simulation) measured 1e-3 rad/s of
"noise" out of its own motion, a dead zone that biased the off-line estimates by
0.1 % (median) and flagged parameters 30 % off as identified; at 2 f_d, 1e-8 rad/s
(``tests/core/test_standstill.py``).

For Gaussian noise a joint at rest then has s = 0 on 99.7 % of its samples. A
moving joint's reversal is not rest: the off-line equations give a short run inside
the zone between long runs of opposite signs the sign of the motion either side
(:func:`reversal_signs`; the on-line engines, causal, keep the zone sample by
sample). Both engines (on-line replay and blocks, off-line IDIM) use the same
widths, computed once on the log. A coupled motor k (Coulomb sign of
u_k/ρ_k = Σ_j (R_kj/ρ_k) v_j, ``core.drive_columns``) gets the width of that
combination for independent joint noises, w_k = (Σ_j (R_kj/ρ_k)² w_j²)^½
(:func:`combined_widths`).

Measured on the TIAGo recording (README "Identify your own robot"): σ_v ≈ 0.8-3.2e-3
rad/s on the arm (0.5e-3 m/s on the torso), against moving speeds of order 0.1 rad/s;
at rest the velocity is almost 0 most of the time, with encoder-dither spikes up to
7.5e-3 rad/s. Pure numpy/scipy.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.blocks import BLOCK_ROWS, checked_rows, is_stored
from drake_dynid.core.idim import (
    DECIMATION_FILTER_ORDER,
    default_padding,
    default_trim,
)

__all__ = [
    "DEAD_ZONE_FACTOR",
    "MIN_RUN",
    "NOISE_BAND_FACTOR",
    "POSITION_FILTER_ORDER",
    "REVERSAL_FRACTION",
    "combined_widths",
    "dead_zone_widths",
    "reversal_run",
    "reversal_signs",
    "shortest_run",
    "velocity_noise",
    "velocity_noise_gain",
]

#: The dead-zone half-width in multiples of the measured velocity noise σ_v.
DEAD_ZONE_FACTOR = 3.0
#: The longest run inside the zone read as a reversal, in periods of the position
#: cutoff f_c: filtered noise at rest never crossed the zone (6 σ_v) this fast
#: (:func:`reversal_run`).
REVERSAL_FRACTION = 0.125
#: The noise band's corner f_n in multiples of the decimation's band f_d.
NOISE_BAND_FACTOR = 2.0
#: Butterworth order of the off-line position filter (``core.idim``'s default).
POSITION_FILTER_ORDER = 4
#: The gain's integral stops where tan(ω/2)/tan(ω_c/2) reaches this: |H|⁴ is below
#: 1e-17 of its pass band beyond (order 4), nothing the sum can see.
_GAIN_STOP = 12.0
_GAIN_POINTS = 8193
#: Residuals held at once by :func:`velocity_noise` (32 MB): the joints whose
#: residuals fit are filtered together.
GROUP_ENTRIES = 1 << 22
_MAD_TO_STD = 1.4826  # 1/Φ⁻¹(3/4): the MAD of a Gaussian variable times this is σ
_OWNER = "velocity_noise"
#: Velocity samples a run needs beyond the edge trims (the order-8 zero-phase
#: low-pass pads 27 samples).
MIN_RUN = 32
#: The edge transients of a run (the odd padding's extrapolation of a joint still
#: moving there, through both low-passes) must decay to this fraction of the motion
#: before a velocity sample is kept: a joint moving at 1 rad/s at a run's end left
#: 2e-3 rad/s of "noise" two f_n periods in (the order-8 low-pass's slowest mode
#: decays e^{-2π sin(π/16)} = 0.29 a period), ~1e-4 at this decay.
EDGE_DECAY = 1e-4
#: Block margins: the filters' start-up transients decay below this fraction (the
#: residual is ~1e-4 of the motion, and v̇ amplifies q's errors by 1/h: at 1e-16
#: the blocks agree with the whole-run filters to round-off, ~1e-9 of σ_v).
_SETTLE = 1e-16


def velocity_noise(
    segments: Any, time_step: float, *, cutoff_hz: float, band_cutoff_hz: float
) -> np.ndarray:
    """Velocity noise σ_v per joint [rad/s or m/s] (module docstring).

    Args:
        segments: a list of (N_i, n) finite position runs [rad or m] (the finite
            segments of a log), or one (N, n) array. Runs shorter than
            :func:`shortest_run` (the filters' edges and MIN_RUN samples) are
            skipped.
        time_step: sample period h [s].
        cutoff_hz: position cutoff f_c [Hz] (``drake_dynid.offline.auto_cutoff``).
        band_cutoff_hz: the corner f_n [Hz] of the low-pass that keeps the
            motion (``drake_dynid.offline.standstill_widths``: twice the
            decimation's band); at most f_c.

    Returns:
        (n,) σ_v; 0 for a joint whose residual is exactly zero.

    Raises:
        ValueError: no run long enough, or a cutoff not in (0, Nyquist).
    """
    time_step = check.positive(_OWNER, "time_step", time_step, "s")
    cutoff_hz = check.positive(_OWNER, "cutoff_hz", cutoff_hz, "Hz")
    band_cutoff_hz = check.positive(_OWNER, "band_cutoff_hz", band_cutoff_hz, "Hz")
    nyquist = 0.5 / time_step
    if cutoff_hz >= nyquist or band_cutoff_hz >= nyquist:
        check.fail(
            _OWNER,
            f"cutoff_hz and band_cutoff_hz must be < the Nyquist frequency "
            f"{nyquist:g} [Hz]; got {cutoff_hz:g} and {band_cutoff_hz:g}.",
        )
    single = is_stored(segments) or isinstance(segments, np.ndarray)
    runs = [segments] if single else list(segments)
    filters = _Filters(time_step, cutoff_hz, min(band_cutoff_hz, cutoff_hz))
    trim, shortest = filters.trim, filters.shortest
    checked = []
    for run in runs:
        q = checked_rows(_OWNER, "segments", run)
        if q.ndim == 1:
            q = q[:, None]
        if q.shape[0] >= shortest:
            checked.append(q)
    if not checked:
        check.fail(
            _OWNER,
            f"needs a finite run of at least {shortest} samples to measure the "
            "velocity noise; got none.",
        )
    spans = [filters.kept(q.shape[0] - 2 * trim) for q in checked]
    total = sum(b - a for a, b in spans)
    n = checked[0].shape[1]
    sigma = np.empty(n)
    # As many joints at a time as fit in GROUP_ENTRIES residuals (all of them on
    # a minute's log; one at a time on hours): one filter call per group.
    group = max(1, min(n, GROUP_ENTRIES // max(total, 1)))
    for j0 in range(0, n, group):
        joints = slice(j0, min(n, j0 + group))
        r = np.empty((total, joints.stop - j0))
        at = 0
        for q, span in zip(checked, spans, strict=True):
            for part in filters.residual(q, joints, trim, span):
                r[at : at + part.shape[0]] = part
                at += part.shape[0]
        r -= np.median(r, axis=0, overwrite_input=True)
        np.abs(r, out=r)
        sigma[joints] = _MAD_TO_STD * np.median(r, axis=0, overwrite_input=True)
    return sigma


class _Filters:
    """The two zero-phase low-passes of :func:`velocity_noise`, a block at a time.

    Each block of velocities is computed from a span of q with margins where the
    filters' start-up transients decay below 1e-12
    (``core.zero_phase.settle_samples``), padded only at the run's true ends:
    a run that fits in one block gives ``sosfiltfilt`` of the whole run exactly,
    a longer one the same to round-off, in memory of a few blocks.
    """

    def __init__(self, time_step: float, cutoff_hz: float, band: float):
        from drake_dynid.core.iir import butter_lowpass
        from drake_dynid.core.zero_phase import settle_samples

        self.h = time_step
        fs = 1.0 / time_step
        self.position = butter_lowpass(POSITION_FILTER_ORDER, cutoff_hz, fs)
        self.position_padding = default_padding(time_step, cutoff_hz)
        self.position_margin = max(
            settle_samples(self.position, _SETTLE), self.position_padding + 2
        )
        self.low = butter_lowpass(DECIMATION_FILTER_ORDER, band, fs)
        self.low_padding = default_padding(time_step, band)
        self.low_margin = max(settle_samples(self.low, _SETTLE), self.low_padding + 2)
        # The edge transients on the motion are not noise: velocity samples are
        # kept where both filters' slowest modes have decayed to EDGE_DECAY (the
        # position filter's counted from the run's end, trim samples out).
        self.trim = default_trim(time_step, cutoff_hz)
        self.edge = max(
            default_trim(time_step, band) - 1,  # two periods of f_n at least
            settle_samples(self.low, EDGE_DECAY),
            settle_samples(self.position, EDGE_DECAY) - self.trim,
        )
        #: Samples a run needs: the trims, the edges and MIN_RUN between.
        self.shortest = 2 * (self.trim + self.edge) + MIN_RUN

    def kept(self, count: int) -> tuple[int, int]:
        """Velocity samples [a, b) kept of ``count`` (empty: a run too short).

        ``edge`` samples are dropped at each end (the filters' edge transients on
        the motion); a run that keeps fewer than MIN_RUN keeps none.
        """
        if count - 2 * self.edge >= MIN_RUN:
            return self.edge, count - self.edge
        return 0, 0

    def residual(self, q: Any, joints: slice, trim: int, span: tuple[int, int]):
        """The residuals v - low-pass(v) of ``joints`` at velocity samples [a, b).

        Velocity sample k is position sample trim + k (central differences of
        the position filter's output, as ``core.idim.offline_derivatives``).
        """
        from drake_dynid.core.zero_phase import zero_phase_span

        count = q.shape[0]
        velocities = count - 2 * trim
        pad_q = min(self.position_padding, count - 1)
        pad_v = min(self.low_padding, velocities - 1)
        for r0 in range(span[0], span[1], BLOCK_ROWS):
            r1 = min(span[1], r0 + BLOCK_ROWS)
            u0 = max(0, r0 - self.low_margin)
            u1 = min(velocities, r1 + self.low_margin)
            lo, hi = trim + u0 - 1, trim + u1 + 1  # positions behind and ahead
            a = max(0, lo - self.position_margin)
            b = min(count, hi + self.position_margin)
            x = np.asarray(q[a:b], dtype=float)[:, joints]
            q_f = zero_phase_span(
                self.position,
                x,
                pad_left=pad_q if a == 0 else 0,
                pad_right=pad_q if b == count else 0,
                padtype="odd",
            )[lo - a : hi - a]
            v = (q_f[2:] - q_f[:-2]) / (2.0 * self.h)
            low = zero_phase_span(
                self.low,
                v,
                pad_left=pad_v if u0 == 0 else 0,
                pad_right=pad_v if u1 == velocities else 0,
                padtype="odd",
            )
            yield (v - low)[r0 - u0 : r1 - u0]


def shortest_run(time_step: float, cutoff_hz: float, band_cutoff_hz: float) -> int:
    """Samples a finite run needs for :func:`velocity_noise` to measure it.

    The position filter's trims (``core.idim.default_trim``), the edges where the
    filters' transients on the motion have not decayed to :data:`EDGE_DECAY`, at
    each end, and :data:`MIN_RUN` between.
    """
    owner = "shortest_run"
    time_step = check.positive(owner, "time_step", time_step, "s")
    cutoff_hz = check.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    band_cutoff_hz = check.positive(owner, "band_cutoff_hz", band_cutoff_hz, "Hz")
    return _Filters(time_step, cutoff_hz, min(band_cutoff_hz, cutoff_hz)).shortest


def velocity_noise_gain(
    time_step: float, cutoff_hz: float, order: int = POSITION_FILTER_ORDER
) -> float:
    """Noise gain G of the off-line velocity estimator [1/s] (module docstring).

    White position noise of std σ_q leaves the zero-phase Butterworth of ``order``
    at ``cutoff_hz`` followed by central differences (q_f[k+1] - q_f[k-1])/(2h)
    with std G·σ_q. The bilinear Butterworth's magnitude is exact in closed form;
    the integral is Simpson's rule on 8192 intervals up to where |H|⁴ has vanished.

    Args:
        time_step: sample period h [s].
        cutoff_hz: f_c in (0, 1/(2h)) [Hz].
        order: the filter's order N >= 1 (zero phase: |H|² applied twice).
    """
    owner = "velocity_noise_gain"
    h = check.positive(owner, "time_step", time_step, "s")
    cutoff_hz = check.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    order = check.integer(owner, "order", order, minimum=1)
    if not cutoff_hz < 0.5 / h:
        check.fail(
            owner,
            f"cutoff_hz must be < the Nyquist frequency {0.5 / h:g} [Hz]; "
            f"got {cutoff_hz:g}.",
        )
    from drake_dynid.core.iir import butter_power, half_circle_mean

    corner = math.tan(math.pi * cutoff_hz * h)
    top = 2.0 * math.atan(_GAIN_STOP * corner)
    w = np.linspace(0.0, top, _GAIN_POINTS)
    return (
        math.sqrt(
            half_circle_mean((np.sin(w) * butter_power(w, corner, order)) ** 2, top)
        )
        / h
    )


def dead_zone_widths(
    segments: Any,
    time_step: float,
    *,
    cutoff_hz: float,
    band_cutoff_hz: float,
    position_noise: Any = None,
    factor: float = DEAD_ZONE_FACTOR,
) -> np.ndarray:
    """Dead-zone half-widths w_j = factor·max(σ_r,j, G·σ_q,j) [rad/s or m/s], (n,).

    σ_r from :func:`velocity_noise`, G from :func:`velocity_noise_gain`. With
    ``position_noise`` and no run of :func:`shortest_run` samples (σ_r cannot be
    measured clear of the edges' transients), G·σ_q alone.

    Args:
        segments: the position runs of :func:`velocity_noise` [rad or m].
        time_step: sample period h [s].
        cutoff_hz: the position cutoff f_c [Hz].
        band_cutoff_hz: the noise band's corner f_n [Hz] (at most f_c).
        position_noise: (n,) white position noise σ_q,j >= 0 [rad or m]
            (``core.excitation.position_noise_std``); None: σ_r alone.
        factor: > 0 (default 3).
    """
    owner = "dead_zone_widths"
    factor = check.positive(owner, "factor", factor, "")
    single = is_stored(segments) or isinstance(segments, np.ndarray)
    runs = [segments] if single else list(segments)
    shapes: list[tuple[int, ...]] = [tuple(np.shape(run)) for run in runs]
    if (
        position_noise is not None
        and shapes
        and all(len(shape) in (1, 2) for shape in shapes)
        and max(shape[0] for shape in shapes)
        < shortest_run(time_step, cutoff_hz, band_cutoff_hz)
    ):
        first = shapes[0]
        sigma = np.zeros(first[1] if len(first) == 2 else 1)
    else:
        sigma = velocity_noise(
            runs, time_step, cutoff_hz=cutoff_hz, band_cutoff_hz=band_cutoff_hz
        )
    if position_noise is not None:
        white = check.array(owner, "position_noise", position_noise, shape=sigma.shape)
        if np.any(white < 0.0):
            check.fail(owner, "position_noise must be >= 0.")
        sigma = np.fmax(sigma, velocity_noise_gain(time_step, cutoff_hz) * white)
    return factor * sigma


def reversal_run(time_step: float, cutoff_hz: float) -> int:
    """L = max(1, floor(:data:`REVERSAL_FRACTION` / (f_c h))): samples [count].

    The longest run inside the dead zone that :func:`reversal_signs` reads as a
    moving joint's reversal. The off-line velocity's noise is smooth at the scale
    of 1/f_c: in 2e6 samples of filtered white noise per case (125 Hz and 1 kHz at
    f_c = 1.5 Hz, 100 Hz at 2.5 Hz, 1 kHz at 20 Hz; widths 3 σ_v) no run between
    exits of opposite signs was shorter than 1/(8 f_c) (the shortest: 0.22-0.32
    periods of f_c; 0.1 % of the samples lie in such runs shorter than 1/(2 f_c)),
    while a joint reversing at 1 rad/s² through a zone of 2e-4 rad/s spends 0.4 ms
    in it.
    """
    owner = "reversal_run"
    h = check.positive(owner, "time_step", time_step, "s")
    cutoff_hz = check.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    return max(1, int(REVERSAL_FRACTION / (cutoff_hz * h)))


def reversal_signs(v: Any, width: Any, longest: int) -> np.ndarray:
    """The dead zone's Coulomb column of a velocity series, reversals restored.

    s_k = 0 for |v_k| <= w_j, sign(v_k) outside (``core.friction.DeadZoneSign``),
    except on a reversal: a run k = i … e-1 inside the zone of at most ``longest``
    samples whose ``longest`` samples before are all outside with one sign and
    whose ``longest`` samples after all outside with the other. Its samples take
    the sign of the line through the run's neighbours,

        s_k = sign(v_{i-1} + (v_e - v_{i-1}) (k - i + 1)/(e - i + 1)).

    The zone is for joints at rest, where sign(v̂) is noise; at a moving joint's
    reversal the sign is known from the motion on either side, and a 0 there is a
    model error of FC_j per sample that σ does not hold (docs/MATH.md §2: up to
    4.5 σ of bias on the UR5 at 125 Hz, ``benchmarks/bench_dead_zone.py``). A
    dither spike at rest is not a reversal (too short an excursion), nor is a run
    cut by the series' ends. Each sample's value depends on the 2L + 1 samples on
    either side only (L = ``longest``): a block of a longer series with that much
    context gives the whole series' values.

    Args:
        v: (N, n) velocities, rows in time order, or (N,) one joint's [rad/s or
            m/s].
        width: w >= 0, one number or (n,) [rad/s or m/s].
        longest: L >= 1 (:func:`reversal_run`) [samples].

    Returns:
        values in {-1, 0, 1} of v's shape (NaN for a NaN velocity).
    """
    owner = "reversal_signs"
    v = np.asarray(v, dtype=float)
    if v.ndim == 1:
        return reversal_signs(v[:, None], width, longest)[:, 0]
    if v.ndim != 2:
        check.fail(owner, f"v must be (N, n) or (N,) velocities; got shape {v.shape}.")
    w = np.asarray(width, dtype=float)
    if w.shape not in ((), (v.shape[1],)) or not np.all(np.isfinite(w) & (w >= 0.0)):
        check.fail(
            owner,
            f"width must be one finite number >= 0 or {v.shape[1]} of them "
            f"[rad/s or m/s]; got {width!r}.",
        )
    if isinstance(longest, bool) or not isinstance(longest, (int, np.integer)):
        check.fail(owner, f"longest must be an integer >= 1; got {longest!r}.")
    longest = int(longest)
    if longest < 1:
        check.fail(owner, f"longest must be an integer >= 1; got {longest}.")
    width = np.broadcast_to(w, v.shape[-1:])
    with np.errstate(invalid="ignore"):
        out = np.where(np.abs(v) <= width, 0.0, np.sign(v))
    if v.shape[0] < 2 * longest + 1:
        return out
    count = v.shape[0]
    for j in range(v.shape[1]):
        s = out[:, j]
        inside = (s == 0.0).astype(np.int8)
        edges = np.diff(np.concatenate(([0], inside, [0])))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        keep = (ends - starts <= longest) & (starts >= longest)
        keep &= ends + longest <= count
        starts, ends = starts[keep], ends[keep]
        if not starts.size:
            continue
        # Samples of one sign in [a, b): cumulative counts of s = +1 and s = -1.
        plus = np.concatenate(([0], np.cumsum(s == 1.0)))
        minus = np.concatenate(([0], np.cumsum(s == -1.0)))
        before_up = plus[starts] - plus[starts - longest] == longest
        before_down = minus[starts] - minus[starts - longest] == longest
        after_up = plus[ends + longest] - plus[ends] == longest
        after_down = minus[ends + longest] - minus[ends] == longest
        reversal = (before_up & after_down) | (before_down & after_up)
        for i, e in zip(starts[reversal], ends[reversal], strict=True):
            before, after = v[i - 1, j], v[e, j]
            k = np.arange(1, e - i + 1)
            s[i:e] = np.sign(before + (after - before) * k / (e - i + 1))
    return out


def combined_widths(widths: Any, rows: Any) -> np.ndarray:
    """Widths of the motor signs u_k/ρ_k: (Σ_j (R_kj/ρ_k)² w_j²)^½, (c,).

    Args:
        widths: (n,) joint widths w_j [rad/s or m/s].
        rows: (c, n) rows R_k of the motors (ρ_k = max_j |R_kj| > 0).
    """
    widths = check.array("combined_widths", "widths", widths, shape=(None,))
    rows = check.array("combined_widths", "rows", rows, shape=(None, widths.size))
    if rows.shape[0] == 0:
        return np.zeros(0)
    scale = np.max(np.abs(rows), axis=1)
    if np.any(scale == 0.0):
        check.fail("combined_widths", "rows must not be all zeros.")
    unit = rows / scale[:, None]
    top = float(np.max(np.abs(widths), initial=0.0))
    if top == 0.0:
        return np.zeros(rows.shape[0])
    # Scaled by the largest width: no overflow of w² (--dead-zone 1e300).
    return top * np.sqrt((unit**2) @ ((widths / top) ** 2))
