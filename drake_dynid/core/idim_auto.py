"""Automatic settings of the off-line IDIM: position cutoff, decimation low-pass.

Used by :func:`drake_dynid.offline.identify_offline` when ``cutoff_hz``,
``decimation_cutoff_hz`` or ``decimation`` is None (pure numpy/scipy).

Automatic cutoff (:func:`auto_cutoff`, used when ``cutoff_hz`` is None). The
Welch spectrum S_j(f) of every detrended position q_j (Blackman-Harris window,
4 s segments) gives

* its noise density N_j(f): the median of S_j over [fs/4, fs/2] (white
  measurement noise is flat; a rigid robot's motion has no power there), over
  ln 2 for a run of one segment (a periodogram: exponential bins); for
  positions resampled from a rate f_e below fs (held or linearly interpolated:
  a multi-file join, an upstream resampling), the median of S_j/K_j over
  [f_e/4, f_e/2] times K_j(f) = sinc(f/f_e)^(2k), their noise's shape; for a
  sensor slower than the log's clock (isolated repeats), its distinct samples'
  spectrum at its own rate (:func:`_joint_welch`); for a
  joint quantized by Δ_j (encoder counts, :func:`~drake_dynid.core.excitation.quantum`)
  at least Δ_j²/(6·fs) and the
  staircase's Δ_j²·r_j/(24·max(f, r_j)²), r_j its count changes a second
  (:func:`_spectra_and_floors`);
* its noise crossover f_x,j: the highest frequency (up to f_e/2) where S_j >
  100·N_j (20 dB above the floor); the motion's spectrum is M_j = (S_j - N_j)⁺
  up to f_x,j (0 above: there the noise's fluctuations would add up).

The zero-phase Butterworth of order N passes G(f) = 1/(1 + (f/f_c)^(2N)) (N = 4,
the off-line default; ``identify_offline``'s and the validations'
``filter_order`` otherwise: on the paper's 2R at SNR 30 dB, 1.62 Hz for N = 4,
2.04 Hz for N = 2), and the accelerations, the positions' second derivative
(weight (2πf)⁴), are the most sensitive to it. Joint j's filtered acceleration
misses (1 - G)·a of the motion (a bias, which survives the parallel decimation:
it is in the band) and carries G·n of the noise, independent of it, so its
expected squared error is

    E_j(f_c) = Σ_f (2πf)⁴ [ (1 - G(f))² M_j(f) + G(f)² N_j(f) ]

(the Welch bins up to fs/2), and ``f_c = min(max_j min(argmin E_j, f_e,j/5),
40 Hz, fs/5)`` over a 1 % geometric grid from the Welch resolution (the joint
that needs the widest band decides, as the crossover did), at least the lowest
cutoff whose trimmed ends leave a sample of the run (:func:`lowest_cutoff`,
within the caps); a run of fewer than 64 samples is refused. The noise term
counts all the noise of v̇ the filter passes, though the decimation low-pass (at
1.5 times the velocity band) later removes most of it from the linear columns:
it errs
towards a lower cutoff, which the noisy paper 2R prefers. As the droop falls
like (f/f_c)^16 and the noise grows like f_c⁵, the optimum moves slowly with
the noise (a factor 10 in N_j: 1.12 in f_c). A joint without noise floor (N_j =
0) takes the cap; a joint held still (the same value in every sample) does not
count (each joint's spectrum is of q_j - q_j[0], exactly 0). Measured
(benchmarks/bench_cutoff.py; README, "Real robot descriptions"): the paper's 2R
arm at SNR 30 dB (21 s, 1 kHz) gets 1.61 Hz (the former rule, max(f_x, 2·f_99)
with f_99 holding 99 % of the motion's power, gave 1.5 Hz), and 40 Hz without
noise (35.5 Hz); an xArm7 excite design (top harmonic 1 Hz, default simulate
noise) 3.6 Hz instead of 2 Hz, where the droop put XX3R 13.7 % high even
without noise. 40 Hz is ten times a typical 4 Hz position closed-loop bandwidth
(Gautier's ω_c ≥ 10·ω_dyn), the cap for clean logs. Against the cutoff of least
acceleration error on logs with a known motion (tests/test_offline.py): 100 Hz
positions interpolated onto 1 kHz 1.69 Hz for 1.39 Hz (39.98 Hz when their
floor was read above fs/4); a 12-bit joint on a 0.1 Hz sine of 6.5 counts 0.38
Hz for 0.24 Hz (5.05 Hz with the white floor alone); 100 samples at 100 Hz
4.17 Hz, the lowest they take (1.56 Hz: no rows).

Automatic decimation (``decimation`` None): ``D_0 = max(1, floor(0.25·fs/f_d))``,
so that the decimated Nyquist frequency is at least twice f_d (the zero-phase
order-8 Butterworth is below 1.5e-5 there: no aliasing), rounded down to a
multiple of the intermediate decimation D1
(:func:`~drake_dynid.core.idim_stream.regressor_decimation`), at least D_0/2.

The spectra behind the automatic choices use bounded memory too: Welch's average
in pieces (the same result), and for a segment longer than 2^18 samples the
velocity bandwidth from the velocity spectra of equal pieces of at most 2^18
samples, averaged (on shorter ones, the periodogram of the whole segment).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core import excitation
from drake_dynid.core.blocks import checked_rows, is_stored
from drake_dynid.core.excitation import estimate_bandwidth

__all__ = [
    "DECIMATION_BAND_FACTOR",
    "MAX_AUTO_CUTOFF_HZ",
    "MAX_VELOCITY_NOISE_SHARE",
    "auto_cutoff",
    "auto_cutoff_rule",
    "auto_decimation",
    "auto_decimation_cutoff",
    "check_cutoff_run",
    "decimated_noise_factor",
    "decimation_cutoff",
    "lowest_cutoff",
    "measured_velocity_band",
    "noise_bandwidth",
    "noise_limited_cutoff",
    "resampled_joints",
    "resampled_note",
    "velocity_bandwidth",
]

MAX_AUTO_CUTOFF_HZ = 40.0
"""Cap of the automatic cutoff [Hz] (ten times a 4 Hz position loop bandwidth)."""

_FLOOR_MARGIN = 100.0  # 20 dB above the noise floor
_CUTOFF_FILTER_ORDER = 4  # the off-line position filter's default order
_SPECTRUM_SEGMENT = 4.0  # Welch segment length [s]
_CUTOFF_BLOCK = 1 << 18  # candidate gains evaluated at a time (2 MB of float64)
DECIMATION_BAND_FACTOR = 1.5
"""Automatic decimation low-pass f_d = min(f_c, 1.5·B), B the velocity bandwidth."""
MAX_VELOCITY_NOISE_SHARE = 0.1
"""Largest share of position noise in the velocity a given cutoff may let through:
noise power / motion power of v on every joint (:func:`noise_limited_cutoff`). On
the paper's 2R at SNR 30 dB (its trajectory, 21 s in closed loop, IDIM-LS with the
reported σ), the limit is 17 Hz (errors within 1.5σ); 0.30 (25 Hz) still gave
errors within 2σ, 2.3 (50 Hz) 3σ and 19 (100 Hz) 16σ: the errors-in-variables
bias of v² and sign(v) terms, which σ does not show."""
_WELCH_PIECE = 1 << 17  # samples per piece of Welch's average
#: A joint's Welch piece: (share, Δ, r, L, k) (:func:`_pieces`, :func:`_piece_traits`).
_Traits = tuple[float, float, float, float, int]


def _position_spectra(
    owner: str, q: Any, time_step: float
) -> tuple[float, np.ndarray, np.ndarray]:
    """``(fs, f, S)``: the checked positions' Welch spectra (4 s segments)."""
    fs, f, power, _, _ = _spectra_and_floors(owner, q, time_step)
    return fs, f, power


def _spectra_and_floors(
    owner: str, q: Any, time_step: float, quantized: bool = True
) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(fs, f, S, N, f_e)``: :func:`_position_spectra`, each joint's noise density.

    N_j(f) [unit²/Hz], (F, n): the white floor N_0,j·K_j(f), and for a joint
    quantized by Δ_j (every change of q_j a whole number of Δ_j: encoder counts)
    at least the quantization's, max(Δ_j²/(6·fs), Δ_j²·r_j/(24·max(f, r_j)²)):

    * N_0,j = median of S_j/K_j over [f_e/4, f_e/2], f_e = fs/L_j the joint's own
      rate: L_j = 1 and K_j = 1, or for positions resampled from a rate L_j times
      lower (:func:`~drake_dynid.core.excitation.resampling`, the kind of most
      of the moving Welch pieces' segments, :func:`_majority_resampling`: held,
      k = 1, or linearly interpolated, k = 2) K_j =
      sinc(f/f_e)^(2k), their noise's shape;
      above f_e/2 lie only its images (100 Hz positions interpolated onto 1 kHz:
      their floor read above fs/4 was 1e-3 of their noise's, and the cutoff 40 Hz
      instead of 1.7 Hz);
    * Δ²/(6·fs): white quantization noise (variance Δ²/12) when counts change
      at every sample; a joint changing count r_j times a second (its count
      changes over the log's duration) carries a staircase instead, a sawtooth
      of fundamental ~r_j whose harmonics fall like 1/f² (Δ²/12 in all): read as
      a white floor alone, the staircase stood as motion up to 5 Hz where its
      acceleration error is least at 0.24 Hz (12-bit joint, 6.5 counts at 0.1 Hz;
      ``quantized`` False: the white floor alone). On a log of several Welch
      pieces, the pieces' quantization densities weighted like their spectra,
      each quantized piece with its own Δ and r
      (:func:`~drake_dynid.core.excitation.piece_quanta`).
    """
    time_step = check.positive(owner, "time_step", time_step, "s")
    q = checked_rows(owner, "q", q)  # a stored log: checked a block at a time
    if q.ndim == 1:
        q = q[:, None]
    if q.ndim != 2 or q.shape[0] < 16:
        check.fail(owner, f"q must have shape (N >= 16, n); got {q.shape}.")
    fs = 1.0 / time_step
    segment = _segment(q.shape[0], fs)
    f, power, staircase, resampled = _welch(q, fs, segment)
    # One segment (a run of up to 6 s): a periodogram, whose bins of white noise
    # are exponential, median ln 2 of their mean (an average of segments is
    # near its mean: its median is kept, the paper's 9 segments unchanged).
    single = math.log(2.0) if q.shape[0] < segment + segment - segment // 2 else 1.0
    noise = np.zeros_like(power)
    for j in range(power.shape[1]):
        ratio, kind = resampled[j]
        kernel = excitation.resampling_kernel(f, fs, ratio, int(kind))
        band = (f >= 0.25 * fs / ratio) & (f <= 0.5 * fs / ratio)
        white = float(np.median(power[band, j] / kernel[band])) if band.any() else 0.0
        noise[:, j] = white / single * kernel
        if quantized:
            noise[:, j] = np.maximum(noise[:, j], staircase[:, j])
    return fs, f, power, noise, fs / resampled[:, 0]


def resampled_note(
    resampled: list[tuple[int, float, int]],
    names: Any,
    time_step: float,
    reader: str | None = None,
) -> str:
    """The note on positions that look resampled (:func:`resampled_joints`), or "".

    Names the joints, their own rate and how they were resampled: above half
    that rate their positions hold no measurement, and the automatic cutoff
    (``reader`` None; else what ``reader`` names, e.g. ``dynid identify``'s
    measured position noise) read their noise below it; and the joints whose sensor is
    slower than the log's clock (k = 0: isolated repeats), their repeat and the
    sensor's rate (the automatic cutoff reads their spectrum at that rate,
    without the repeats).
    """
    fs = 1.0 / time_step
    kinds = {1: "held", 2: "linearly interpolated"}
    held = [
        f"{names[j]} ({kinds[kind]} from about {rate:.4g} Hz)"
        for j, rate, kind in resampled
        if kind
    ]
    slow = [
        f"{names[j]} (one in about {fs / (fs - rate):.0f}: a sensor at {rate:.4g} Hz)"
        for j, rate, kind in resampled
        if not kind
    ]
    notes = []
    if held:
        notes.append(
            f"the positions of {check.listed(held)} look resampled onto the log's "
            f"{fs:.4g} Hz: above half their own rate they hold no measurement, and "
            + ("the automatic cutoff" if reader is None else reader)
            + " read their noise below it."
        )
    if slow:
        notes.append(
            f"the positions of {check.listed(slow)} repeat isolated samples at the "
            f"log's {fs:.4g} Hz: a sensor slower than the log's clock, whose "
            "repeats are errors of v·h"
            + (
                "; the automatic cutoff read their spectrum at the sensor's rate, "
                "without them."
                if reader is None
                else "."
            )
        )
    return " ".join(notes)


def resampled_joints(q: Any, time_step: float) -> list[tuple[int, float, int]]:
    """``[(j, f_e, k)]``: the joints whose positions look resampled, their rate [Hz].

    Read on the automatic cutoff's Welch pieces (:func:`_pieces`, 2^17 samples),
    by the most segments (:func:`_majority_resampling`; it read the first
    piece alone, which may be at rest or from another source):
    :func:`~drake_dynid.core.excitation.resampling`, k = 1 held, k = 2 linearly
    interpolated from samples at f_e; k = 0: isolated repeats
    (:func:`~drake_dynid.core.excitation.repeats`) in most of the moving
    pieces' segments, a sensor at f_e = fs·(N - R)/N, R repeats in their N
    samples, slower than the log.
    """
    time_step = check.positive("resampled_joints", "time_step", time_step, "s")
    q = checked_rows("resampled_joints", "q", q)
    if q.ndim == 1:
        q = q[:, None]
    fs = 1.0 / time_step
    traits: list[list[_Traits]] = [[] for _ in range(q.shape[1])]
    repeated = np.zeros((q.shape[1], 3))  # share, repeats, samples
    for j, x, piece in _joint_pieces(q, _segment(q.shape[0], fs), fs):
        traits[j].append(piece)
        share, step, rate, _, kind = piece
        if rate > 0.0:  # a moving piece
            count = excitation.repeats_with(x, step, kind).size
            if count:
                repeated[j] += (share, count, x.size)
    found = []
    for j, pieces in enumerate(traits):
        ratio, kind = _majority_resampling(pieces)
        if kind:
            found.append((j, 1.0 / (ratio * time_step), kind))
            continue
        moving = sum(share for share, _, rate, *_ in pieces if rate > 0.0)
        if repeated[j, 0] > 0.5 * moving:
            found.append((j, (1.0 - repeated[j, 1] / repeated[j, 2]) * fs, 0))
    return found


def auto_cutoff(q: Any, time_step: float, order: int = _CUTOFF_FILTER_ORDER) -> float:
    """Automatic Butterworth cutoff f_c [Hz]: the least expected acceleration error.

    For each joint j, with its Welch spectrum S_j, noise density N_j(f) (median
    over [fs/4, fs/2]; below its own Nyquist frequency for resampled positions;
    at least the quantization's for a joint quantized by Δ_j:
    :func:`_spectra_and_floors`) and motion M_j = (S_j - N_j)⁺ up to its
    crossover (20 dB above the floor), and G(f) =
    1/(1 + (f/f_c)^(2N)) the zero-phase Butterworth of order N (``order``; 4, the
    off-line default: (f/f_c)⁸)::

        E_j(f_c) = Σ_f (2πf)⁴ [ (1 - G(f))² M_j(f) + G(f)² N_j(f) ]  [(unit/s²)²/Hz]

    the filter's bias on the measured motion's acceleration plus the noise it
    passes; ``f_c = min(max_j min(argmin E_j, f_e,j/5), 40 Hz, fs/5)`` on a 1 %
    geometric grid, f_e,j a resampled joint's own rate (fs otherwise), and at
    least :func:`lowest_cutoff` (within the caps; see the module docstring).

    Args:
        q: (N, n) finite positions sampled every ``time_step`` [rad or m].
        time_step: sample period h [s].
        order: N, the order of the Butterworth applied forwards and backwards
            (the position filter's ``filter_order``, >= 1).

    Returns:
        The cutoff [Hz], at least the Welch resolution fs/N_seg and the lowest
        cutoff the run's trimmed ends allow (:func:`lowest_cutoff`).

    Raises:
        ValueError: fewer than 64 samples (no spectrum to measure), or bad input.
    """
    order = check.integer("auto_cutoff", "order", order, minimum=1)
    shape = q.shape if hasattr(q, "shape") else np.shape(q)  # a store: on disk
    samples = int(shape[0]) if len(shape) else 0
    check_cutoff_run("auto_cutoff", samples, "q has")
    fs, f, power, noise, own_rates = _spectra_and_floors("auto_cutoff", q, time_step)
    cap = min(MAX_AUTO_CUTOFF_HZ, 0.2 * fs)
    lowest = min(lowest_cutoff(samples, 1.0 / fs), cap)
    return max(_least_error_cutoff(f, fs, power, noise, own_rates, order), lowest)


def check_cutoff_run(owner: str | None, samples: int, subject: str) -> None:
    """Raises ValueError when a run of ``samples`` is too short for :func:`auto_cutoff`.

    At least 64 samples (``core.excitation.MIN_SPECTRUM_SAMPLES``): fewer hold no
    spectrum to read a noise floor from (16 samples at 100 Hz: 9 bins, 6.25 Hz
    apart, and the former cutoff of 12.5 Hz was the resolution's, not the log's).
    ``subject``: the message's start ("the longest finite segment has");
    ``owner``: its prefix (None: none).
    """
    if samples < excitation.MIN_SPECTRUM_SAMPLES:
        message = (
            f"{subject} {samples} samples; at least "
            f"{excitation.MIN_SPECTRUM_SAMPLES} are needed to measure its spectrum "
            "and choose the cutoff: record a longer log or give the cutoff."
        )
        raise ValueError(message if owner is None else f"{owner}: {message}")


def lowest_cutoff(samples: int, time_step: float) -> float:
    """The lowest cutoff [Hz] whose trimmed ends leave one of ``samples`` samples.

    ``2 / (m·h)``, m = floor((N - 1)/2) - 1: :func:`~drake_dynid.core.idim.default_trim`
    drops 1 + ceil(2/(f_c·h)) samples at each end, so a run of N samples gives rows
    only at f_c >= 2/(m·h) (a 1 s run at 100 Hz: 4.17 Hz). On runs of 64 to a few
    hundred samples the least-error cutoff fell below it (1.56 Hz on 1 s at 100
    Hz), and the off-line identification failed; their acceleration error is
    then least at the lowest cutoff they can take (the rule's own value minimises
    it on longer runs).
    """
    m = (int(samples) - 1) // 2 - 1
    if m < 1:
        return math.inf
    return 2.0 / (m * float(time_step)) * (1.0 + 1e-12)  # ceil(2/(f_c·h)) = m


def _least_error_cutoff(
    f: np.ndarray,
    fs: float,
    power: np.ndarray,
    noise: np.ndarray,
    own_rates: np.ndarray,
    order: int,
) -> float:
    """:func:`auto_cutoff`'s argmin over the joints, before the short runs' bound."""
    resolution = float(f[1])
    cap = min(MAX_AUTO_CUTOFF_HZ, 0.2 * fs)
    steps = math.floor(math.log(max(cap / resolution, 1.0)) / math.log(1.01))
    grid = resolution * 1.01 ** np.arange(steps + 1)
    weight = (2.0 * np.pi * f) ** 4
    motion = np.zeros_like(power)
    moving = np.zeros(power.shape[1], dtype=bool)
    for j in range(power.shape[1]):
        # Up to the joint's own Nyquist frequency: above, images only.
        own = f <= 0.5 * own_rates[j]
        above = np.flatnonzero(own & (power[:, j] > _FLOOR_MARGIN * noise[:, j]))
        if above.size:
            top = int(above[-1]) + 1
            motion[:top, j] = np.clip(power[:top, j] - noise[:top, j], 0.0, None)
            moving[j] = bool(motion[:, j].any())
    if not moving.any():  # nothing measured: twice the resolution, as before
        return float(max(min(2.0 * resolution, cap), resolution))
    if np.any(noise[:, moving].max(axis=0) <= 0.0):  # noise-free: nothing to trade
        return float(max(min(cap, 0.2 * float(own_rates[moving].min())), resolution))
    errors = np.empty((grid.size, power.shape[1]))
    rows = max(1, _CUTOFF_BLOCK // f.size)  # candidates at a time: memory bounded
    for a in range(0, grid.size, rows):
        gain = 1.0 / (1.0 + (f / grid[a : a + rows, None]) ** (2 * order))
        errors[a : a + rows] = ((1.0 - gain) ** 2 * weight) @ motion + (
            (gain**2 * weight) @ noise
        )
    best = max(
        min(float(grid[int(np.argmin(errors[:, j]))]), 0.2 * float(own_rates[j]))
        for j in np.flatnonzero(moving)
    )
    return float(max(min(best, cap), resolution))


@functools.cache
def _auto_cutoff_of_order(order: int) -> Callable[[Any, float], float]:
    return functools.partial(auto_cutoff, order=order)


def auto_cutoff_rule(
    order: int, default: Callable[[Any, float], float] = auto_cutoff
) -> Callable[[Any, float], float]:
    """``f(q, time_step)``: :func:`auto_cutoff` for a position filter of ``order``.

    The same function object for the same order, a key of ``RobotLog.on_longest_run``
    (a log's measure is computed once per function): ``default`` (the module's
    :func:`auto_cutoff`, as the caller names it) for the default order 4, which the
    dead zone's widths and the validations share.
    """
    order = check.integer("auto_cutoff", "order", order, minimum=1)
    if order == _CUTOFF_FILTER_ORDER:
        return default
    return _auto_cutoff_of_order(order)


def _segment(samples: int, fs: float) -> int:
    """Samples of the cutoff's Welch segments: 4 s, at least 16, at most the run."""
    return min(samples, max(16, round(_SPECTRUM_SEGMENT * fs)))


def _pieces(q: Any, segment: int) -> Any:
    """``(share, piece)``: Welch's consecutive runs of whole segments of q (N, n).

    ``share`` [1]: the piece's segments over all of them (its weight in the
    average); ``piece``: its rows as floats, (M, n), read one at a time (q may
    be a stored log).
    """
    step = segment - segment // 2
    total = (q.shape[0] - segment) // step + 1
    per_piece = max(1, (_WELCH_PIECE - segment) // step + 1)
    for first in range(0, total, per_piece):
        count = min(per_piece, total - first)
        piece = np.asarray(q[first * step : (first + count - 1) * step + segment])
        yield count / total, piece.reshape(piece.shape[0], -1).astype(float)


def _joint_pieces(q: Any, segment: int, fs: float) -> Any:
    """``(j, x, traits)``: each joint's Welch pieces (:func:`_pieces`), one at a time.

    x (M,) the piece of joint j from the joint's first sample, ``traits`` its
    ``(share, Δ, r, L, k)``. The automatic cutoff's spectra and
    :func:`resampled_joints` read the same pieces.
    """
    # Each joint from its first sample: a joint held still (a locked torso, a
    # gripper) is then exactly 0, where the segments' detrending left rounding
    # residue ~1e-17 rad of its value (0.3 rad) whose smooth spectrum stood
    # above its own floor of ~1e-45 as motion with no noise, and the
    # automatic cutoff went to 35.8 Hz instead of the moving joints' 2.37 Hz.
    origin = np.asarray(q[:1], dtype=float).reshape(1, -1)
    for share, piece in _pieces(q, segment):
        piece = piece - origin
        for j in range(piece.shape[1]):
            x = piece[:, j]
            yield j, x, (share, *_piece_traits(x, fs))


def _welch(
    q: np.ndarray, fs: float, segment: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``scipy.signal.welch`` (Blackman-Harris, half overlap), in pieces of segments.

    The average over all segments, computed over consecutive runs of whole
    segments (:func:`_pieces`, 2^17 samples), one joint at a time, so that the
    memory stays bounded on long logs. Also each joint's quantization density
    (F, n) [unit²/Hz] and its resampling (n, 2) ``(L, k)``, both decided piece by
    piece (:func:`_piece_traits`).
    """
    f, power = np.empty(0), np.empty(0)
    traits: list[list[_Traits]] = [[] for _ in range(q.shape[1])]
    for j, x, piece in _joint_pieces(q, segment, fs):  # one joint at a time
        traits[j].append(piece)
        f, part = _joint_welch(x, fs, segment, piece)
        if power.size == 0:
            power = np.zeros((f.size, q.shape[1]))
        power[:, j] = power[:, j] + part * piece[0]
    staircase = np.zeros_like(power)
    resampled = np.tile([1.0, 0.0], (q.shape[1], 1))
    for j, pieces in enumerate(traits):
        steps = excitation.piece_quanta([step for _, step, *_ in pieces])
        for (share, _, rate, *_), step in zip(pieces, steps, strict=True):
            if step > 0.0:  # a quantized piece: its rounding's staircase
                staircase[:, j] += share * excitation.quantization_density(
                    f, fs, step, rate
                )
        resampled[j] = _majority_resampling(pieces)
    return f, power, staircase, resampled


def _piece_traits(x: np.ndarray, fs: float) -> tuple[float, float, float, int]:
    """``(Δ, r, L, k)`` of one piece of a joint.

    Its quantum (NaN: not counts; 0: no change), its count changes a second
    [1/s] and its resampling ``(L, k)`` (a quantized or constant piece: (1, 0)).
    """
    step = excitation.piece_quantum(x)
    rate = np.count_nonzero(np.diff(x)) * fs / max(x.size - 1, 1)
    ratio, kind = excitation.resampling_with(x, step if step > 0.0 else 0.0)
    return step, float(rate), ratio, kind


def _majority_resampling(
    pieces: list[_Traits],
) -> tuple[float, int]:
    """``(L, k)`` of a joint from its pieces' ``(share, Δ, r, L, k)``.

    The kind k (0: not resampled) of the most segments among the pieces that
    change (a joint at rest, then resampled, is resampled), L the median of its
    pieces' (weighted by segments); ``(1, 0)`` when none changes or k = 0 wins.
    A log whose first 2^17 samples came from another source (or held still)
    was judged by them alone.
    """
    votes: dict[int, list[tuple[float, float]]] = {}
    for share, _, rate, ratio, kind in pieces:
        if rate > 0.0:
            votes.setdefault(kind, []).append((share, ratio))
    if not votes:
        return 1.0, 0
    kind = max(votes, key=lambda k: (sum(w for w, _ in votes[k]), -k))
    if kind == 0:
        return 1.0, 0
    shares, ratios = np.array(sorted(votes[kind], key=lambda v: v[1])).T
    middle = int(np.searchsorted(np.cumsum(shares), 0.5 * shares.sum()))
    return float(ratios[min(middle, ratios.size - 1)]), kind


def _joint_welch(
    x: np.ndarray, fs: float, segment: int, traits: _Traits
) -> tuple[np.ndarray, np.ndarray]:
    """``(f, S)``: one joint's Welch spectrum at the log's rate, (F,) each.

    A joint whose sensor is slower than the log's clock (isolated repeats,
    :func:`~drake_dynid.core.excitation.repeats`: 980 Hz read at 1 kHz) is read
    at its own rate: its M distinct samples are the sensor's, evenly spaced at
    f_e = fs·M/N, and their spectrum, interpolated onto the log's bins (held
    above f_e/2, its white floor), replaces the log's, where each repeat put a
    v·h error and their lines every fs/L stood 20 dB above the floor up to 40
    Hz (the cutoff 40 Hz instead of 2.54 Hz, the least acceleration error).
    """
    from drake_dynid.core.iir import welch  # numpy: no scipy.signal at start-up

    _, step, _, _, kind = traits  # its pieces' quantum and resampling, read
    found = excitation.repeats_with(x, step, kind)
    if found.size == 0:
        f, part = welch(x, fs, segment)
        return f, part[:, 0]
    f, _ = welch(x[:segment], fs, segment)  # the log's bins
    kept = np.delete(x, found)
    own = fs * kept.size / x.size
    f_own, part = welch(kept, own, min(segment, kept.size))
    return f, np.interp(f, f_own, part[:, 0])


def noise_bandwidth(order: int) -> float:
    """Equivalent noise bandwidth of the zero-phase Butterworth, in units of f_d.

    The filter applied forwards and backwards passes white noise's power through
    |H|⁴ = (1 + (f/f_d)^(2N))⁻²:  ∫₀^∞ |H|⁴ df / f_d = (1 - 1/(2N)) · π/(2N·sin(π/(2N)))
    (0.944 for N = 8, the decimation filter; tests/core/test_idim.py checks
    it by quadrature).
    """
    n = int(order)
    return (1.0 - 1.0 / (2 * n)) * math.pi / (2 * n * math.sin(math.pi / (2 * n)))


def decimated_noise_factor(
    time_step: float, decimation: int, decimation_cutoff_hz: float
) -> float:
    """The factor Gautier's σ of the decimated rows needs: √max(1, f_r/(2·B_n)).

    Gautier's σ_X = σ_ρ √((WᵀW)⁻¹)_ii counts the K decimated rows as independent.
    Their residual noise went through the anti-alias low-pass at f_d [Hz] and is
    sampled at f_r = 1/(D·h) ≥ 4·f_d (:func:`auto_decimation`): neighbouring rows
    are correlated, and for white measurement noise under regressor columns of
    the motion band the estimate's variance is that of K·2·B_n/f_r independent
    rows, B_n the noise's equivalent bandwidth (:func:`noise_bandwidth` of the
    order-8 zero-phase filter: 0.944·f_d). Hence σ_X × √(f_r/(2·B_n)): 1.46 at
    the automatic decimation (f_r = 4·f_d; 1.459 on the paper's 2R log at SNR
    30 dB, D = 268). Monte-Carlo spread over Gautier's σ (torque noise, IDIM-WLS,
    40 seeds on logs of Pinocchio's inverse dynamics, a review): 1.34 (UR5), 1.43
    (Panda) at D = 320, 2.71 at D = 80; benchmarks/bench_sigma_offline.py measures
    it side by side (20 seeds, Drake's inverse dynamics, torque noise 1 %): 1.48
    (iiwa7), 1.50 (UR5) with IDIM-WLS at D = 322; 2.16, 2.42 with IDIM-LS at
    D = 80 (factor 2.92), but 0.96, 1.11 with IDIM-LS at D = 322, whose reported
    σ is then 1.2-1.6 times the spread.

    Args:
        time_step: h [s] of the log.
        decimation: D, the rows' decimation.
        decimation_cutoff_hz: f_d [Hz], the anti-alias low-pass cutoff.
    """
    from drake_dynid.core.idim import DECIMATION_FILTER_ORDER

    rate = 1.0 / (float(decimation) * float(time_step))
    band = noise_bandwidth(DECIMATION_FILTER_ORDER) * float(decimation_cutoff_hz)
    return math.sqrt(max(1.0, rate / (2.0 * band)))


def auto_decimation(time_step: float, cutoff_hz: float) -> int:
    """``max(1, floor(0.25·fs/f_d))``: the decimated Nyquist frequency is >= 2·f_d.

    Args:
        time_step: sample period h [s].
        cutoff_hz: the decimation low-pass f_d [Hz].
    """
    owner = "auto_decimation"
    time_step = check.positive(owner, "time_step", time_step, "s")
    cutoff_hz = check.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    ratio = 0.25 / time_step / cutoff_hz
    if not math.isfinite(ratio):
        check.fail(
            owner,
            f"0.25/(time_step·cutoff_hz) must be finite; got time_step {time_step:g} "
            f"s and cutoff_hz {cutoff_hz:g} Hz.",
        )
    return max(1, math.floor(ratio))


def auto_decimation_cutoff(q: Any, time_step: float, cutoff_hz: float) -> float:
    """The decimation low-pass ``f_d = min(f_c, 1.5·B)`` [Hz].

    B is the velocity bandwidth of the positions
    (:func:`~drake_dynid.core.excitation.estimate_bandwidth`; beyond 2^18 samples,
    from the average velocity spectrum of equal pieces); when it cannot be
    measured (no joint moves above the noise, or fewer than 64 samples), f_d = f_c
    (the least squares then reports the unexcited parameters).

    Args:
        q: (N, n) finite positions [rad or m].
        time_step: sample period h [s].
        cutoff_hz: the position filter's cutoff f_c [Hz].
    """
    return decimation_cutoff(measured_velocity_band(q, time_step), cutoff_hz)


def decimation_cutoff(band_hz: float | None, cutoff_hz: float) -> float:
    """``min(f_c, 1.5·B)`` [Hz]; f_c when the band B [Hz] is None (not measured)."""
    if band_hz is None:
        return float(cutoff_hz)
    return float(min(cutoff_hz, DECIMATION_BAND_FACTOR * band_hz))


def measured_velocity_band(q: Any, time_step: float) -> float | None:
    """:func:`velocity_bandwidth` [Hz], or None when it cannot be measured.

    None: no joint moves above the noise, or fewer than 64 samples.

    Args:
        q: (N, n) finite positions [rad or m] (a stored log's segment stays on
            disk).
        time_step: sample period h [s].
    """
    try:
        return velocity_bandwidth(
            q if is_stored(q) else np.asarray(q, dtype=float), time_step
        )
    except ValueError:
        return None


def velocity_bandwidth(q: np.ndarray, time_step: float) -> float:
    """``estimate_bandwidth`` (99 % of the velocity power) in bounded memory [Hz].

    Up to 2^18 samples, :func:`~drake_dynid.core.excitation.estimate_bandwidth`
    itself; beyond, from the sum of the velocity spectra of equal pieces of at
    most 2^18 samples, one joint at a time (memory: one piece, whatever the log's
    length; ``q`` may be a stored log, ``drake_dynid.core.blocks``).

    Raises:
        ValueError: no joint moves above the noise (or fewer than 64 samples).
    """
    if q.shape[0] <= excitation.SPECTRUM_PIECE:
        return estimate_bandwidth(np.asarray(q, dtype=float), time_step)
    if len(q.shape) == 1:
        q = np.asarray(q, dtype=float)[:, None]
    # Summed piece by piece, joint by joint: bounded memory.
    band = excitation.motion_noise_band(q, time_step)[2]
    if band is None:
        check.fail("auto_decimation_cutoff", "q shows no motion above the noise.")
    return float(band)  # type: ignore[arg-type]  # fail() raised when None


def noise_limited_cutoff(q: Any, time_step: float) -> float:
    """Highest cutoff [Hz] that keeps position noise out of the velocity.

    With the Welch spectrum S_j of each position (as :func:`auto_cutoff`), its
    white noise density N_j(f) (:func:`auto_cutoff`'s, read below a resampled
    joint's own Nyquist frequency, without the quantization's) and its crossover
    f_x,j, the velocity's motion power is ``Σ_{f <= f_x} (S_j - N_j)⁺ (2πf)²``
    and the noise a cutoff f_c lets through ``Σ_{f <= f_c} N_j (2πf)²``; this
    returns the highest f_c whose ratio stays within
    :data:`MAX_VELOCITY_NOISE_SHARE` on every joint that moves (the Nyquist
    frequency when none is limited). Above it the noise of v biases the
    v² and sign(v) columns (errors in variables) by more than σ shows.

    Args:
        q: (N >= 16, n) finite positions [rad or m].
        time_step: sample period h [s].
    """
    # The white floor alone: a slow encoder joint's staircase would refuse every
    # cutoff above ~1 Hz for the whole log (0.75 Hz for 6.5 counts at 0.1 Hz).
    fs, f, power, noise, own_rates = _spectra_and_floors(
        "noise_limited_cutoff", q, time_step, quantized=False
    )
    weight = (2.0 * np.pi * f) ** 2
    limit = 0.5 * fs
    for j in range(power.shape[1]):
        spectrum, floor = power[:, j], noise[:, j]
        own = f <= 0.5 * own_rates[j]  # above: a resampled joint's images only
        above = np.flatnonzero(own & (spectrum > _FLOOR_MARGIN * floor))
        if above.size == 0 or not np.any(floor > 0.0):
            continue
        top = int(above[-1])
        excess = np.clip(spectrum[: top + 1] - floor[: top + 1], 0.0, None)
        motion = float(np.sum(excess * weight[: top + 1]))
        if motion <= 0.0:
            continue
        share = np.cumsum(floor * weight) / motion
        allowed = np.flatnonzero(share <= MAX_VELOCITY_NOISE_SHARE)
        limit = min(limit, float(f[allowed[-1]]) if allowed.size else float(f[1]))
    return limit
