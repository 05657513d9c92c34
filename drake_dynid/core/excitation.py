"""Excitation bandwidth of a recorded motion, and the modulating set that covers it.

The on-line identifiers only see the window's Fourier bins ν/T [Hz]
(``core.fourier_bank``): bins above the excitation carry noise only, bins below it miss
information. The rule measured in ``benchmarks/bench_accuracy.py`` is to cover the
velocity band and no more::

    B = estimate_bandwidth(q, h)   # f below which 99 % of the velocity power lies
    ℓ = frequencies_for(T, B)      # ℓ = 0, 1, ..., with (ℓ + k)/T <= B, at least 8

Bandwidth estimate (noise-robust, no tuning):

1. one Hann-windowed periodogram S_j(f) of each detrended position channel q_j over the
   whole record (resolution 1/duration, no segment averaging needed; numpy's FFT,
   :func:`periodogram`, equal to ``scipy.signal.periodogram``);
2. the white-noise floor N_j = median of S_j over the upper half of the spectrum
   (f > f_s/4, where a robot's motion carries no power at kHz sampling) divided by ln 2
   (the median of an exponential variable is ln 2 times its mean); for a channel
   resampled from a rate f_e below f_s (:func:`resampling`: held or linearly
   interpolated), over (f_e/4, f_e/2] of S_j/K_j, times K_j(f) = sinc(f/f_e)^(2k)
   (above f_e/2 lie only images of its noise);
3. only the bins with S_j > ``threshold``·N_j are kept (false-alarm probability
   e^{-threshold} per bin for Gaussian noise), minus the floor;
4. velocity power P_j(f) = (2πf)² (S_j - N_j) on those bins; the bandwidth of joint j is
   the smallest f with Σ_{f' <= f} P_j >= ``energy``·Σ P_j; the result is the largest
   over the joints [Hz].

At SNR 30 dB the noise floor is 10⁵-10⁶ times below the lines of a typical exciting
trajectory, so thresholding at 20× the floor removes the noise that would otherwise
dominate the f²-weighted velocity spectrum (about 10 % of the velocity power up to
20 Hz at SNR 30 dB without it). The Hann main lobe (±2 bins) can add up to
2/duration Hz to the estimate.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.fourier_bank import band_frequencies

__all__ = [
    "MIN_SPECTRUM_SAMPLES",
    "SPECTRUM_PIECE",
    "decimal_step",
    "detrend_linear",
    "estimate_bandwidth",
    "frequencies_for",
    "motion_and_noise",
    "motion_noise_band",
    "periodogram",
    "piece_quanta",
    "piece_quantum",
    "position_noise_std",
    "quantization_density",
    "quantum",
    "record_pieces",
    "repeats",
    "repeats_with",
    "resampling",
    "resampling_kernel",
    "resampling_with",
    "torque_noise_std",
    "velocity_rms",
    "velocity_spectrum",
]

_OWNER = "estimate_bandwidth"

#: Shortest record whose spectrum the measures here take.
MIN_SPECTRUM_SAMPLES = 64
_MAD_TO_STD = 1.4826  # 1/Φ⁻¹(3/4): the MAD of a Gaussian variable times this is σ

SPECTRUM_PIECE = 1 << 18
"""Longest record (samples) whose statistics are one periodogram: longer records are
cut into equal pieces of at most this many samples, one joint at a time (memory of
one piece's spectrum, whatever the log's length)."""


def detrend_linear(x: np.ndarray) -> np.ndarray:
    """``x`` minus its least-squares line along axis 0 (as ``scipy.signal.detrend``).

    ``x_k - (a·(k+1)/N + b)`` per column, with (a, b) the least-squares fit; numpy
    only (no ``scipy.signal`` import on the ``dynid identify`` path).
    """
    count = x.shape[0]
    design = np.ones((count, 2))
    design[:, 0] = np.arange(1, count + 1) / count
    coefficients, *_ = np.linalg.lstsq(design, x, rcond=None)
    return x - design @ coefficients


def periodogram(x: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Hann-windowed periodogram of the detrended columns of ``x``.

    ``S(f_k) = c |Σ_j w_j x̃_j e^{-2πi jk/N}|² / (fs Σ w²)`` with the periodic
    Hann window w_j = ½ - ½ cos(2πj/N), x̃ = :func:`detrend_linear` (x) and c = 2
    except at f = 0 (and at fs/2 for even N): ``scipy.signal.periodogram(x, fs,
    window="hann", detrend="linear", axis=0)`` with numpy's FFT [unit²/Hz].

    Returns:
        ``(f, S)``: frequencies (F,) [Hz] and densities (F, n).
    """
    count = x.shape[0]
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(count) / count)
    spectrum = np.fft.rfft(window[:, None] * detrend_linear(x), axis=0)
    density = (spectrum.real**2 + spectrum.imag**2) / (fs * np.sum(window**2))
    density[1 : None if count % 2 else -1] *= 2.0
    return np.fft.rfftfreq(count, 1.0 / fs), density


def _record(
    owner: str, name: str, values: Any, time_step: float
) -> tuple[float, np.ndarray]:
    """``(h, x)``: a checked sample period and (N, n) record, N >= 64."""
    h = v.positive(owner, "time_step", time_step, "s")
    if not 1e-9 <= h <= 1e5:  # (2πf)² of the spectrum stays finite
        v.fail(owner, f"time_step must be in [1e-09, 1e+05] [s]; got {h:g}.")
    x = v.array(owner, name, values)
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2 or x.shape[0] < MIN_SPECTRUM_SAMPLES or x.shape[1] < 1:
        v.fail(
            owner,
            f"{name} must have shape (N,) or (N, n) with N >= "
            f"{MIN_SPECTRUM_SAMPLES} samples; got {np.shape(values)}.",
        )
    return h, x


def _periodogram(
    q: Any, time_step: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``(f, S, x, h)``: the Hann periodogram of the detrended channels, (F, n).

    Of each channel from its first sample: a constant one is then exactly 0 (its
    detrending left a rounding residue of its value, σ ~ 1e-18 rad for 0.3 rad).
    """
    h, x = _record(_OWNER, "q", q, time_step)
    f, s = periodogram(x - x[:1], 1.0 / h)
    return f, s, x, h


def _traits(x: np.ndarray) -> list[tuple[float, int, float]]:
    """``(L, k, Δ)`` of each channel of x (N, n): :func:`resampling`, :func:`quantum`.

    Computed once per periodogram for the floor, the σ and the staircase (each
    had its own, three or four passes of :func:`quantum` per channel).
    """
    out = []
    for j in range(x.shape[1]):
        step = quantum(x[:, j])
        out.append((*_resampling(x[:, j], step), step))
    return out


def _noise_floor(
    f: np.ndarray, s: np.ndarray, h: float, traits: list[tuple[float, int, float]]
) -> np.ndarray:
    """N_j(f), (F, n): each channel's white-noise density [unit²/Hz] (module docstring).

    N_0,j·K_j(f), N_0,j the median of S_j/K_j over [f_e/4, f_e/2] over ln 2, at the
    channel's own rate f_e = f_s/L_j: K_j = 1 and L_j = 1, or for a channel
    resampled from a rate L_j times lower (:func:`resampling`: held or linearly
    interpolated) its noise's shape K_j = sinc(f/f_e)^(2k); above f_e/2 lie only
    images (100 Hz positions interpolated onto 1 kHz read 1.5 % of their noise's
    σ above f_s/4), where the floor is infinite: no motion is seen there (the
    images of the motion's lines near the kernel's zeros at multiples of f_e
    stood 20 times above its floor, and the velocity band of such positions
    came out at 252-454 Hz instead of 0.95 Hz). ``traits``: :func:`_traits`.
    """
    fs = 1.0 / h
    floor = np.zeros_like(s)
    for j in range(s.shape[1]):
        ratio, order, _ = traits[j]
        kernel = resampling_kernel(f, fs, ratio, order)
        band = (f > 0.25 * fs / ratio) & (f <= 0.5 * fs / ratio)
        white = float(np.median(s[band, j] / kernel[band])) if band.any() else 0.0
        floor[:, j] = white / math.log(2.0) * kernel
        floor[f > 0.5 * fs / ratio, j] = math.inf  # images: no motion is seen there
    return floor


def _noise_std(
    floor: np.ndarray,
    h: float,
    traits: list[tuple[float, int, float]],
    x: np.ndarray,
) -> np.ndarray:
    """σ_j = √(N_0,j·f_e/2) [unit], at least Δ_j/√12 for a quantized channel.

    N_0,j = N_j(0) (:func:`_noise_floor`), f_e the channel's own rate. A channel
    quantized by Δ_j (every change a whole number of the smallest: encoder
    counts) carries its rounding error, uniform of variance Δ²/12, whatever its
    spectrum: a slow or periodic staircase puts it on few lines at low
    frequency, and the floor above f_s/4 read 0.09-0.27 Δ/√12 (1e-11 rad for
    a 12-bit joint on a 1 rad sine of 0.5 Hz, ten whole periods); a channel
    not quantized as a whole (x (N, n), its samples) at least its pieces'
    (:func:`_pieces_rounding_std`). A constant channel gives 0. ``traits``:
    :func:`_traits`.
    """
    sigma = np.empty(len(traits))
    for j, (ratio, _, step) in enumerate(traits):
        sigma[j] = math.sqrt(max(float(floor[0, j]), 0.0) * 0.5 / (h * ratio))
        rounding = (
            step / math.sqrt(12.0) if step > 0.0 else _pieces_rounding_std(x[:, j])
        )
        sigma[j] = max(sigma[j], rounding)
    return sigma


#: Samples of the pieces whose quanta bound the noise of a channel that is not
#: quantized as a whole (:func:`_pieces_rounding_std`).
_ROUNDING_PIECE = 1 << 13


def _pieces_rounding_std(x: np.ndarray) -> float:
    """√(Σ_k w_k Δ_k²/12) [unit] over the pieces of x (N,) that change, or 0.

    Pieces of :data:`_ROUNDING_PIECE` samples, each with its own quantum Δ_k
    (:func:`piece_quantum`, merged by :func:`piece_quanta`; 0 for a piece not
    quantized), w_k its share of the changing pieces' samples (16 changes or
    more: a piece at rest but for a flicker shows no counts): a log joined
    from two encoders (a 12-bit and a 5000-count one, steps not whole numbers of
    each other) was not counts as a whole, and its σ read its staircases' floor,
    5.6e-5 rad where its counts' rounding is 4.2e-4 rad (now 4.17e-4). 0 for a
    channel of one piece (:func:`quantum` judged it whole).
    """
    if x.shape[0] <= _ROUNDING_PIECE:
        return 0.0
    sizes, steps = [], []
    for first in range(0, x.shape[0], _ROUNDING_PIECE):
        piece = x[first : first + _ROUNDING_PIECE + 1]  # its changes, joined
        if np.count_nonzero(np.diff(piece)) < _MIN_COUNTED_MOVES:
            continue  # at rest, or a few flickers: no evidence of counts
        step = piece_quantum(piece)
        if step != 0.0:  # a piece that changes (NaN: not counts)
            sizes.append(piece.shape[0] - 1)
            steps.append(step)
    if not sizes:
        return 0.0
    merged = np.nan_to_num(np.array(piece_quanta(steps)), nan=0.0)
    return math.sqrt(float(np.dot(sizes, merged**2)) / (12.0 * sum(sizes)))


def position_noise_std(q: Any, time_step: float) -> np.ndarray:
    """Std of the white measurement noise of each position channel [rad or m].

    ``σ_j = √(N_j·f_e/2)``, N_j the white-noise floor of the one-sided periodogram
    (module docstring, step 2): the flat part of the spectrum above f_s/4, where a
    robot's motion carries no power at kHz sampling; for a channel resampled from
    a rate f_e below f_s, below f_e/2 (:func:`_noise_floor`). At least Δ/√12 for
    a channel quantized by Δ (piece by piece for one that is not as a whole),
    0 for a constant one (:func:`_noise_std`). A
    noise-free (simulated) record gives the leakage of its motion there, orders
    of magnitude below any sensor's noise.

    Args:
        q: (N,) or (N, n) measured positions [rad or m], N >= 64.
        time_step: sample period h [s].

    Returns:
        (n,) σ per channel (records longer than :data:`SPECTRUM_PIECE`: by
        pieces, :func:`motion_and_noise`).
    """
    if len(np.shape(q)) == 2 and np.shape(q)[0] > SPECTRUM_PIECE:
        return motion_and_noise(q, time_step)[1]
    f, s, x, h = _periodogram(q, time_step)
    traits = _traits(x)
    return _noise_std(_noise_floor(f, s, h, traits), h, traits, x)


#: Fewest knots, largest share of irregular gaps, and the widest ratio
#: :func:`resampling` calls a resampled channel.
_MIN_KNOTS = 8
_REGULAR_SHARE = 0.9
_MAX_RESAMPLING = 100.0
_QUANTUM_TOLERANCE = 1e-3  # a change within this many steps of whole ones
#: Coarsest decimal rounding of a log's values (a CSV's ``%.6f``) a quantum allows
#: for, in steps: a 16-bit joint (Δ 9.6e-5 rad) written to 1e-6 rad is 0.0104.
_MAX_DECIMAL_SHARE = 0.05
_COUNT_REFINE = 8  # counts of the first least-squares refinement of Δ
_QUANTUM_OUTLIERS = 2  # changes off the counts a quantized channel may have
#: Fewest changes on the counts that let :data:`_QUANTUM_OUTLIERS` be off them: a
#: float channel at rest but for 2 or 3 flickers of unrelated sizes (4-6 changes)
#: was given the largest as its Δ, σ 3.75e-5 for 2e-6.
_MIN_COUNTED_MOVES = 16


def decimal_step(x: Any) -> float:
    """The coarsest 10^-k (k = 0, ..., 9) every value is a multiple of, or 0 [unit].

    To round-off (64 ulp of the largest value, at least 1): values written with
    ``%.6f`` give 1e-6, integer counts 1, full-precision floats 0.
    """
    x = np.asarray(x, dtype=float).ravel()
    if x.size == 0 or not np.all(np.isfinite(x)):
        return 0.0
    slack = 64.0 * np.finfo(float).eps * max(1.0, float(np.abs(x).max()))
    for k in range(10):
        d = 10.0**-k
        if d <= 16.0 * slack:
            break
        # The first 256 values first: most channels fail there at once.
        if all(np.all(np.abs(y - d * np.round(y / d)) <= slack) for y in (x[:256], x)):
            return d
    return 0.0


def _quantum(x: np.ndarray) -> float:
    """Δ of :func:`quantum`; 0 for a channel that never changes, NaN if not counts."""
    signed = np.diff(x)
    changes = np.abs(signed)
    moves = changes[changes > 0.0]
    if moves.size == 0:
        return 0.0
    if not np.all(np.isfinite(moves)):
        return math.nan
    decimal = decimal_step(x)
    step, bad = _whole_counts(moves, float(moves.min()), decimal)
    if bad.any() and moves.size >= _QUANTUM_OUTLIERS + _MIN_COUNTED_MOVES:
        # One odd sample (a glitch, a filled gap's end) moves off the counts
        # twice: tried without the smallest two moves, first on 256 changes
        # (a noisy channel fails there at once), when at least 16 others are
        # left to show the counts (2 equal flickers are no encoder).
        k = _QUANTUM_OUTLIERS
        head = moves[:256]
        start = float(np.partition(head, min(k, head.size - 1))[min(k, head.size - 1)])
        if np.count_nonzero(_whole_counts(head, start, decimal)[1]) <= k:
            start = float(np.partition(moves, k)[k])
            step, bad = _whole_counts(moves, start, decimal)
            if np.count_nonzero(bad) <= k:
                step, bad = _whole_counts(moves[~bad], step, decimal)
    if bad.any():
        return math.nan
    signed_counts = np.round(signed / step)
    if np.all(signed_counts == signed_counts[0]):
        return math.nan  # the same change at every sample: exactly linear, a ramp
    return step


def _whole_counts(
    moves: np.ndarray, step: float, decimal: float
) -> tuple[float, np.ndarray]:
    """``(Δ, off)``: Δ fitted from ``step`` over the moves' counts, the moves off.

    Least squares over the whole counts, the small ones first (the smallest
    change alone is off by up to the decimal rounding, 1 % of a 16-bit count);
    a move is off when its count is below 1 or it is more than 1e-3 Δ (plus the
    decimal step when at most 0.05 Δ) from its count.
    """
    for limit in (_COUNT_REFINE, math.inf):
        counts = np.round(moves / step)
        use = (counts <= limit) & (counts >= 1.0)
        if not use.any():
            return step, np.ones(moves.shape, dtype=bool)
        step = float(counts[use] @ moves[use] / (counts[use] @ counts[use]))
    slack = _QUANTUM_TOLERANCE * step
    if decimal <= _MAX_DECIMAL_SHARE * step:
        slack += decimal  # each change is off by up to one decimal step
    counts = np.round(moves / step)
    return step, (counts < 1.0) | (np.abs(moves - counts * step) > slack)


def quantum(x: Any) -> float:
    """A channel's quantization step Δ, or 0 [unit].

    Δ such that every change between consecutive samples is a whole number of it
    (within 1e-3 Δ, plus the values' decimal rounding :func:`decimal_step` when it
    is at most 0.05 Δ: encoder counts written to a CSV with ``%.6f``), fitted by
    least squares over the changes' counts; encoder counts, scaled or not. Up to
    two changes may be off the counts among 16 or more on them (one odd sample:
    a glitch, a filled gap's end; Δ fitted without them; not a channel at rest
    but for a few flickers): one sample 0.3 count off a 12-bit joint made
    it not counts, and its automatic cutoff 40 Hz instead of 0.38 Hz. 0 when
    the channel never changes or its changes are not so, or are all the same
    count of the same sign (an exact ramp, v·h at every sample: no rounding).
    """
    step = _quantum(np.asarray(x, dtype=float).ravel())
    return 0.0 if math.isnan(step) else step


def piece_quantum(x: Any) -> float:
    """:func:`quantum`'s Δ of one piece of a channel [unit].

    0 when it never changes, NaN when its changes are not whole counts (or an
    exact ramp); :func:`piece_quanta` merges the pieces'.
    """
    return _quantum(np.asarray(x, dtype=float).ravel())


def piece_quanta(steps: list[float]) -> list[float]:
    """Each piece's quantum once the pieces' steps are merged (``piece_quantum``).

    Pieces whose steps are whole numbers of each other (within 1 %) share the
    smallest (a piece moving by 2 counts at a time has the others' Δ); a piece
    not quantized (NaN: a glitch, a ramp, another source) or never changing (0)
    keeps its own, and does not cost the others theirs (the whole channel was
    judged not quantized, and one glitched sample in 2^17 put a 12-bit joint's
    automatic cutoff at 40 Hz instead of 0.38 Hz). Steps that are not whole
    numbers of each other (a log joined from two encoders) stay apart.
    """
    classes: list[float] = []
    member: list[int] = []
    for step in steps:
        k = len(classes)
        if step > 0.0:
            k = next((i for i, c in enumerate(classes) if _whole(step, c)), k)
            if k == len(classes):
                classes.append(step)
            classes[k] = min(classes[k], step)
        member.append(k)
    return [
        classes[k] if step > 0.0 else step
        for k, step in zip(member, steps, strict=True)
    ]


def _whole(a: float, b: float) -> bool:
    """The larger of two steps a whole number of the smaller (within 1 %)."""
    ratio = max(a, b) / min(a, b)
    return abs(ratio - round(ratio)) <= 0.01


def resampling(x: Any) -> tuple[float, int]:
    """``(L, k)``: a channel resampled from a rate L times lower, or ``(1.0, 0)``.

    k = 1: held between its own samples (zero-order hold: repeats); k = 2:
    linearly interpolated between them (what a multi-file join or an upstream
    resampling does). The k-th differences of such a channel vanish (within
    1e-9 of their largest: round-off) except at its knots, which come every L
    samples, L the mean gap between knots (a consecutive run of nonzero
    differences one knot): at least 8 knots, 2 <= L <= 100, 90 % of the
    gaps between knots within 1.5 samples of L (a non-integer ratio, unaligned
    stamps, jitter), and 90 % of the knots at most k samples long (a sensor 2 %
    slower than the log's clock repeats one sample in 50 and moves on the 49
    others: not held).
    Below the true Nyquist frequency f_s/(2L) such a channel's white noise of
    one-sided density N_0 reads N_0·sinc(f·L/f_s)^(2k) (the hold's or the
    triangle's kernel); above it, only images. A quantized channel (every change
    a whole number of the smallest: encoder counts) is not judged (its steps
    repeat whatever the rate), nor a constant or exactly linear one.

    Args:
        x: (N,) one channel's samples.

    Returns:
        ``(L, k)``; ``(1.0, 0)`` when the channel does not look resampled.
    """
    x = np.asarray(x, dtype=float).ravel()
    return _resampling(x, quantum(x))


def resampling_with(x: Any, step: float) -> tuple[float, int]:
    """:func:`resampling` of x (N,) whose :func:`quantum` is ``step`` (known)."""
    return _resampling(np.asarray(x, dtype=float).ravel(), step)


def _resampling(x: np.ndarray, step: float) -> tuple[float, int]:
    """:func:`resampling` of x (N,) whose :func:`quantum` is ``step``."""
    if step > 0.0 or np.all(x == x[0]):
        return 1.0, 0  # encoder counts repeat at any rate; constant
    for order in (1, 2):
        difference = np.abs(np.diff(x, order))
        top = float(difference.max()) if difference.size else 0.0
        if not top > 0.0:
            return 1.0, 0
        moving = np.flatnonzero(difference > 1e-9 * top)
        first = np.r_[True, np.diff(moving) > 1]
        starts = moving[first]
        if starts.size < _MIN_KNOTS:
            continue
        # A knot moves the k-th differences on at most k samples (held: one;
        # interpolated: the kink's two when it falls between samples); a sensor
        # slower than the log's clock repeats one sample in L and moves on L - 1.
        runs = np.diff(np.r_[np.flatnonzero(first), moving.size])
        if np.mean(runs <= order) < _REGULAR_SHARE:
            continue
        ratio = float(starts[-1] - starts[0]) / (starts.size - 1)  # mean gap
        if not 2.0 <= ratio <= _MAX_RESAMPLING:
            continue
        gaps = np.diff(starts)
        if np.mean(np.abs(gaps - ratio) < 1.5) >= _REGULAR_SHARE:
            return float(ratio), order
    return 1.0, 0


_MIN_REPEATS = 8  # fewest isolated repeats :func:`repeats` reads as a sensor's


def repeats(x: Any) -> np.ndarray:
    """Indices i of a moving channel's isolated repeats x_i = x_(i-1), or none.

    A sensor slower than the log's clock (980 Hz read at 1 kHz) repeats one
    sample in L (50) and moves on the others: each repeat is a position error of
    v·h whose lines (every f_s/L) stood 20 dB above the white floor up to f_s/2,
    and the automatic cutoff went to 40 Hz instead of 2.54 Hz (the least
    acceleration error; 2.81 Hz without repeats). Noise never repeats a sample
    exactly, so such repeats are the sensor's: at least 8, 90 % of all repeats
    isolated (the samples either side differ), in a channel neither quantized
    (:func:`quantum`: counts repeat at any rate) nor resampled
    (:func:`resampling`: held runs); of values rounded to a decimal step d
    (:func:`decimal_step`), more than twice the changes of 0 < |Δx| <= 1.5 d
    (what the rounding alone gives, about twice its zeros). The first and last
    two samples are not judged.
    """
    return _repeats(np.asarray(x, dtype=float).ravel(), None)


def repeats_with(x: Any, step: float, kind: int) -> np.ndarray:
    """:func:`repeats` of x (N,) whose quantum and resampling kind are known.

    ``step``: its :func:`quantum` (NaN or 0: not counts); ``kind``: its
    :func:`resampling`'s k (the automatic cutoff's pieces have both).
    """
    return _repeats(np.asarray(x, dtype=float).ravel(), (step, kind))


def _repeats(x: np.ndarray, known: tuple[float, int] | None) -> np.ndarray:
    """:func:`repeats` of x (N,); ``known``: its (Δ, k) when already read."""
    none = np.empty(0, dtype=int)
    if x.size < 4 or not np.all(np.isfinite(x)):
        return none
    change = np.diff(x)
    same = np.flatnonzero(change == 0.0) + 1  # x[i] == x[i - 1]
    if same.size < _MIN_REPEATS:
        return none
    if known is None:  # read here, the resampling after the quantum (lazily)
        step = quantum(x)
        if step > 0.0 or _resampling(x, step)[1]:
            return none
    elif known[0] > 0.0 or known[1]:
        return none
    inner = same[(same >= 2) & (same <= x.size - 2)]
    isolated = inner[(x[inner + 1] != x[inner]) & (x[inner - 1] != x[inner - 2])]
    if isolated.size < max(_MIN_REPEATS, _REGULAR_SHARE * same.size):
        return none
    decimal = decimal_step(x)
    if decimal > 0.0:
        near = np.count_nonzero((change != 0.0) & (np.abs(change) <= 1.5 * decimal))
        if same.size <= 2 * near:
            return none  # as many zeros as the rounding gives
    return isolated


def resampling_kernel(f: np.ndarray, fs: float, ratio: float, order: int) -> np.ndarray:
    """``sinc(f·L/f_s)^(2k)``: a resampled channel's noise shape (:func:`resampling`).

    1 for k = 0 (not resampled); f [Hz], f_s [Hz] the log's rate.
    """
    if order == 0:
        return np.ones_like(f)
    return np.sinc(f * ratio / fs) ** (2 * order)


#: Order of the half-band low-pass whose complement holds :func:`torque_noise_std`.
HALF_BAND_ORDER = 8
#: Samples dropped at each end of :func:`torque_noise_std`'s residual (its
#: zero-phase filter's edge transients), when the record keeps 64 between.
_HALF_BAND_EDGE = 60


@functools.lru_cache(maxsize=8)
def half_band_share(order: int = HALF_BAND_ORDER) -> float:
    """White noise's variance share c left by the half-band low-pass's complement.

    c = (1/π) ∫_0^π (1 - |L(e^{iω})|²)² dω, L the zero-phase Butterworth low-pass
    of ``order`` at f_s/4. The bilinear Butterworth at f_s/4 has
    |L|² = 1/(1 + tan(ω/2)^(2N)) exactly (``core.iir.butter_power``, corner
    tan(π/4) = 1); Simpson's rule on 8192 intervals (c = 0.4802 for N = 8, just
    under the ideal 1/2). Computed once per order.
    """
    from drake_dynid.core.iir import butter_power, half_circle_mean

    order = v.integer("half_band_share", "order", order, minimum=1)
    w = np.linspace(0.0, math.pi, 8193)
    return half_circle_mean((1.0 - butter_power(w, 1.0, order)) ** 2, math.pi)


def torque_noise_std(tau: Any, time_step: float) -> np.ndarray:
    """Std of the white measurement noise of each torque channel [N·m or N].

    ``σ_j = 1.4826 · MAD(r_j) / √c``: r_j the torque minus its zero-phase
    Butterworth low-pass (order 8) at f_s/4, where a robot's motion carries no
    power (module docstring, step 2), and c its share of white noise
    (:func:`half_band_share`). Measured in time rather than as the periodogram's
    floor (:func:`position_noise_std`): a Coulomb reversal is a step of the
    torque, whose power spreads over the whole spectrum (the floor above f_s/4
    measured 1.0-1.6 times the true noise on 1 kHz logs of exact sign(v) friction,
    1.0-2.3 times at 100 Hz), while its ringing in r lasts a few samples, which
    the median ignores (1.00-1.03 times; 1.0-1.27 times at 100 Hz).

    Args:
        tau: (N,) or (N, n) measured torques [N·m or N], N >= 64.
        time_step: sample period h [s].

    Returns:
        (n,) σ per channel (records longer than :data:`SPECTRUM_PIECE`: the mean
        of the pieces' σ², one joint at a time: bounded memory).
    """
    from drake_dynid.core.iir import butter_lowpass
    from drake_dynid.core.zero_phase import zero_phase_span

    owner = "torque_noise_std"
    shape = np.shape(tau)  # tau may be a stored log (read a piece at a time)
    if len(shape) == 2 and shape[0] > SPECTRUM_PIECE:
        squares = np.zeros(shape[1])
        count = 0
        for piece in record_pieces(tau):
            count += 1
            for j in range(shape[1]):
                squares[j] += torque_noise_std(piece[:, j], time_step)[0] ** 2
        return np.sqrt(squares / count)
    h, x = _record(owner, "tau", tau, time_step)
    # Centred first: the filter's round-off on a constant channel (~1e-16 of its
    # level) is not noise; an exactly constant torque measures exactly 0.
    x = x - np.median(x, axis=0)
    sos = butter_lowpass(HALF_BAND_ORDER, 0.25 / h, 1.0 / h)
    pad = min(x.shape[0] - 1, 3 * (2 * sos.shape[0] + 1))
    r = x - zero_phase_span(sos, x, pad_left=pad, pad_right=pad, padtype="odd")
    if r.shape[0] - 2 * _HALF_BAND_EDGE >= MIN_SPECTRUM_SAMPLES:
        r = r[_HALF_BAND_EDGE:-_HALF_BAND_EDGE]
    r -= np.median(r, axis=0)
    mad = np.median(np.abs(r), axis=0)
    return _MAD_TO_STD * mad / math.sqrt(half_band_share())


def velocity_rms(q: Any, time_step: float, *, threshold: float = 20.0) -> np.ndarray:
    """RMS of each channel's velocity from :func:`velocity_spectrum` [rad/s or m/s].

    ``√(Σ_f P_j(f)·Δf)``: the motion above the noise floor only.
    """
    f, power = velocity_spectrum(q, time_step, threshold=threshold)
    return np.sqrt(power.sum(axis=0) * (f[1] - f[0]))


def record_pieces(q: Any) -> Iterator[np.ndarray]:
    """The equal pieces of at most :data:`SPECTRUM_PIECE` rows of a record.

    ``N // count`` rows each (count = ⌈N / SPECTRUM_PIECE⌉; the last ``N mod
    count`` rows are left out), as float arrays read one at a time (``q`` may be
    a stored log); one piece, the whole record, up to SPECTRUM_PIECE rows.
    """
    total = int(np.shape(q)[0])
    count = max(1, -(-total // SPECTRUM_PIECE))
    length = total // count
    for k in range(count):
        yield np.asarray(q[k * length : (k + 1) * length], dtype=float)


def motion_and_noise(
    q: Any, time_step: float, *, threshold: float = 20.0
) -> tuple[np.ndarray, np.ndarray]:
    """``(velocity_rms(q, h), position_noise_std(q, h))`` from one periodogram.

    Up to :data:`SPECTRUM_PIECE` samples, exactly those two functions' values.
    Beyond, the mean squares over equal pieces of at most that many samples, one
    joint at a time (``v_rms² = mean of the pieces' v_rms²``, the same for σ²):
    bounded memory on hour-long logs. The first two values of
    :func:`motion_noise_band`.

    Args:
        q: (N,) or (N, n) positions [rad or m], N >= 64.
        time_step: h [s].
        threshold: the motion's detection threshold (:func:`velocity_spectrum`).

    Returns:
        (n,) RMS velocities [rad/s or m/s] and (n,) position noise std [rad or m].
    """
    rms, noise, _ = motion_noise_band(q, time_step, threshold=threshold)
    return rms, noise


def motion_noise_band(
    q: Any, time_step: float, *, threshold: float = 20.0
) -> tuple[np.ndarray, np.ndarray, float | None]:
    """``(v_rms, σ_q, B)``: :func:`motion_and_noise` and the band, one periodogram.

    B [Hz] is :func:`estimate_bandwidth` at its default energy (99 % of the
    velocity power), None when no joint moves above the noise (where
    :func:`estimate_bandwidth` raises). Up to :data:`SPECTRUM_PIECE` samples one
    periodogram of all channels; beyond, one per piece and joint
    (:func:`record_pieces`): v_rms and σ_q by mean squares over the pieces
    (:func:`motion_and_noise`), B from the sum of the pieces' velocity spectra
    (``core.idim_auto.velocity_bandwidth``). A log's dead zone, rows' choice
    and excitation band share it (``RobotLog.on_longest_run``: each computed the
    same periodogram for its own measure).

    Args:
        q: (N,) or (N, n) positions [rad or m], N >= 64 (may be a stored log).
        time_step: h [s].
        threshold: the motion's detection threshold (:func:`velocity_spectrum`).

    Returns:
        (n,) RMS velocities [rad/s or m/s], (n,) position noise std [rad or m]
        and the band [Hz] or None.
    """
    shape = np.shape(q)  # q may be a stored log (read a piece at a time)
    if len(shape) == 2 and shape[0] > SPECTRUM_PIECE:
        squares = np.zeros((2, shape[1]))
        power = np.empty(0)
        f = np.empty(0)
        count = 0
        for k, piece in enumerate(record_pieces(q)):
            count += 1
            for j in range(shape[1]):
                f, part, noise = _motion_spectrum(piece[:, j], time_step, threshold)
                if k == 0 and j == 0:
                    power = np.zeros((len(f), shape[1]))
                power[:, j] += part[:, 0]
                rms = np.sqrt(part.sum(axis=0) * (f[1] - f[0]))
                squares[:, j] += (rms[0] ** 2, noise[0] ** 2)
        rms, noise = np.sqrt(squares / count)
        return rms, noise, _power_band(f, power, 0.99)
    f, power, noise = _motion_spectrum(q, time_step, threshold)
    rms = np.sqrt(power.sum(axis=0) * (f[1] - f[0]))
    return rms, noise, _power_band(f, power, 0.99)


def _motion_spectrum(
    q: Any, time_step: float, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(f, P, σ)``: :func:`velocity_spectrum`, :func:`position_noise_std` at once."""
    threshold = v.greater_than(_OWNER, "threshold", threshold, 1.0)
    f, s, x, h = _periodogram(q, time_step)
    traits = _traits(x)
    floor = _noise_floor(f, s, h, traits)
    noise = _noise_std(floor, h, traits, x)
    return f, _velocity_power(f, s, x, floor, threshold, h, traits), noise


def _power_band(f: np.ndarray, power: np.ndarray, energy: float) -> float | None:
    """``max_j min{f : Σ_{f' <= f} P_j(f') >= energy·Σ P_j}`` [Hz]; None: no P_j > 0.

    Over the joints whose velocity power P (F, n) [(unit/s)²/Hz] is not 0.
    """
    total = power.sum(axis=0)
    moving = np.flatnonzero(total > 0.0)
    if moving.size == 0:
        return None
    return float(
        max(
            f[int(np.searchsorted(np.cumsum(power[:, j]) / total[j], energy - 1e-12))]
            for j in moving
        )
    )


def velocity_spectrum(
    q: Any, time_step: float, *, threshold: float = 20.0
) -> tuple[np.ndarray, np.ndarray]:
    """Noise-floor-cleaned velocity power spectrum of each position channel.

    ``P_j(f) = (2πf)² (S_j(f) - N_j)`` where ``S_j > threshold·N_j``, else 0, with
    ``S_j`` the Hann-windowed periodogram of the linearly detrended ``q_j``
    [unit²/Hz] and ``N_j`` its white-noise floor (module docstring).

    Args:
        q: (N,) or (N, n) positions sampled every ``time_step`` [rad or m], N >= 64.
        time_step: sample period h [s].
        threshold: detection threshold in multiples of the noise floor (> 1).

    Returns:
        ``(f, P)``: frequencies (F,) [Hz] and the velocity power (F, n)
        [(unit/s)²/Hz].
    """
    threshold = v.greater_than(_OWNER, "threshold", threshold, 1.0)
    f, s, x, h = _periodogram(q, time_step)
    traits = _traits(x)
    floor = _noise_floor(f, s, h, traits)
    return f, _velocity_power(f, s, x, floor, threshold, h, traits)


def quantization_density(
    f: np.ndarray, fs: float, step: float, rate: float
) -> np.ndarray:
    """A channel quantized by Δ = ``step``: its rounding error's density [unit²/Hz].

    ``max(Δ²/(6·fs), Δ²·r/(24·max(f, r)²))`` at the frequencies f [Hz]: white
    (variance Δ²/12 over [0, fs/2]) when the count changes at every sample, and
    a staircase changing count r times a second [1/s], a sawtooth of
    fundamental ~r whose harmonics fall like 1/f² (Δ²/12 in all). The one
    formula of the automatic cutoff's floor (``core.idim_auto``) and the
    velocity band's (:func:`_staircase_floor`).
    """
    stairs = step**2 * rate / (24.0 * np.maximum(f, rate) ** 2)
    return np.maximum(step**2 / (6.0 * fs), stairs)


def _staircase_floor(
    f: np.ndarray,
    floor: np.ndarray,
    x: np.ndarray,
    h: float,
    traits: list[tuple[float, int, float]],
) -> np.ndarray:
    """The floor raised to a quantized channel's rounding error [unit²/Hz].

    For a channel quantized by Δ_j (:func:`quantum`) changing count r_j times a
    second, at least ``Δ²/(6 f_s)`` (white, variance Δ²/12) and
    ``Δ²·r/(24·max(f, r)²)`` (a staircase, a sawtooth of fundamental ~r whose
    harmonics fall like 1/f², Δ²/12 in all; the automatic cutoff's floor,
    ``core.idim_auto``), and Δ²·T/18, all of Δ²/12 on one line (a periodic
    motion's staircase is periodic; T the record's duration); not when the
    white floor is at least Δ²/(8 f_s) (noise of σ >= Δ/4 dithers the
    rounding: the TIAGo's joints, σ 0.39 Δ to 29 Δ, keep their band). Read
    against the white floor above f_s/4 alone, a 12-bit joint's staircase put
    the velocity band at 482 Hz for a 1 rad sine of 0.5 Hz (a review). Not for
    the noise's σ (:func:`_noise_std`: Δ/√12).
    """
    raised = floor.copy()
    fs = 1.0 / h
    for j in range(x.shape[1]):
        step = traits[j][2]
        # Noise of σ >= Δ/4 (floor >= Δ²/(8 f_s)) dithers the rounding: white.
        if step > 0.0 and floor[0, j] < step**2 / (8.0 * fs):
            rate = np.count_nonzero(np.diff(x[:, j])) * fs / x.shape[0]
            raised[:, j] = np.maximum(
                raised[:, j], quantization_density(f, fs, step, rate)
            )
            # All of Δ²/12 on one line (a periodic motion's staircase is
            # periodic): a line of power P reads P·T/1.5 on the Hann periodogram.
            line = step**2 / 12.0 * x.shape[0] * h / 1.5
            raised[:, j] = np.maximum(raised[:, j], line)
    return raised


def _velocity_power(
    f: np.ndarray,
    s: np.ndarray,
    x: np.ndarray,
    floor: np.ndarray,
    threshold: float,
    h: float,
    traits: list[tuple[float, int, float]],
) -> np.ndarray:
    """P_j(f) of :func:`velocity_spectrum` from the periodogram and its floor.

    ``floor`` the white one (:func:`_noise_floor`), raised here for a quantized
    channel (:func:`_staircase_floor`).
    """
    floor = _staircase_floor(f, floor, x, h, traits)
    keep = s > threshold * floor
    # A constant (or exactly linear) channel only leaves round-off: no motion.
    residual = detrend_linear(x)
    scale = np.maximum(1.0, np.abs(x).max(axis=0))
    keep &= np.ptp(residual, axis=0) > 1e-9 * scale
    clean = np.where(keep, s - floor, 0.0)
    clean[0] = 0.0
    return (2.0 * math.pi * f[:, None]) ** 2 * clean


def estimate_bandwidth(
    q: Any,
    time_step: float,
    *,
    energy: float = 0.99,
    threshold: float = 20.0,
) -> float:
    """Frequency below which ``energy`` of the velocity power lies [Hz].

    ``B = max_j min{f : Σ_{f' <= f} P_j(f') >= energy · Σ P_j}`` with ``P_j`` from
    :func:`velocity_spectrum` (periodogram of q_j, white-noise floor removed, bins
    below ``threshold`` times the floor dropped, weighted by (2πf)²).

    Args:
        q: (N,) or (N, n) measured positions [rad or m] (noise allowed), N >= 64.
        time_step: sample period h [s].
        energy: fraction of the velocity power to cover, in (0, 1].
        threshold: detection threshold in multiples of the noise floor (> 1).

    Returns:
        The bandwidth [Hz], the largest over the joints.

    Raises:
        ValueError: bad arguments, or no joint shows any motion above the noise.
    """
    energy = v.real(_OWNER, "energy", energy)
    if not 0.0 < energy <= 1.0:
        v.fail(_OWNER, f"energy must be in (0, 1]; got {energy}.")
    band = _power_band(*velocity_spectrum(q, time_step, threshold=threshold), energy)
    if band is None:
        v.fail(
            _OWNER,
            "q shows no motion above the noise floor (constant or pure noise); "
            "an exciting trajectory is needed.",
        )
    return float(band)  # type: ignore[arg-type]  # fail() raised when None


#: The default ℓ set covering a band (the library's one rule, defined with the bank
#: design): ``frequencies_for(T, B)`` equals ``OnlineSettings(window=T,
#: bandwidth=B).ell()``.
frequencies_for = band_frequencies
