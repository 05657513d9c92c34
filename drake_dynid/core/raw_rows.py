"""Model rows of the raw signals, averaged over each bank step (docs/MATH.md §3).

The filtered rows (``OnlineSettings.rows_from = "filtered"``) evaluate the model
rows at the matched-filtered signals, ``D(F∗q, F∗q̇)``; the filter F does not
commute with the nonlinear terms (``sign(F∗q̇) ≠ F∗sign(q̇)``, products of
velocities, cos q), which leaves a bias of about 2 % on a 7-DOF arm even without
noise. The raw rows (``rows_from = "raw"``) apply the low-pass to the rows
instead: for every signal sample k

    q_k' = q_{k-m},   v_k' = Σ_{j=0..2m} c_j q_{k-j} ≈ q̇(t_{k-m}),   τ_k' = τ_{k-m}

(``c`` the central Jacobi velocity estimator of window 2m·h, κ = μ = 1, q = 2,
ξ = 1/2: exact for polynomials of degree 4, delay m·h), the rows
``(D, G, y)(q_k', v_k', τ_k')`` are packed and averaged over the D samples of one
bank step (a boxcar, the same linear filter on every channel, so
``d/dt(D̄·θ) + Ḡ·θ = ȳ`` holds exactly for the averages; its nulls at the
multiples of 1/bank_time_step suppress the aliases of the decimation). The
Coulomb column is then the average of s(v'), the filtered nonlinearity. Bias:
only the velocity estimator's (degree 5 and up); noise: the velocity estimate is
noisier than F∗q̇ (``noise_gain`` of ``velocity``), which the sign of a slowly
crossing velocity turns into errors: use the raw rows when the position noise is
low (``core.excitation.choose_rows_from``).

The bank sample pushed at signal sample k_j averages the rows of the samples
k_j - D + 1 .. k_j, which read q and τ from k_j - D + 1 - 2m .. k_j
(:attr:`RawRowsDesign.history` samples); the averages refer to the instant
t_{k_j} - :attr:`RawRowsDesign.delay`. :func:`raw_channels` computes one bank sample
from the newest samples of the differentiator's ring (the ``RawModelRows`` block),
:func:`raw_channels_batch` every bank sample of a log at once (the core replay).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.jacobi_design import JacobiFilter, jacobi_filter
from drake_dynid.core.rows import num_channels, num_equations, pack_rows

__all__ = [
    "RAW_KAPPA",
    "RAW_NOISE_COEFFICIENT",
    "RAW_Q",
    "RawLinearization",
    "RawRowsDesign",
    "linearized_channels",
    "raw_channels",
    "raw_channels_batch",
    "raw_linearization",
    "raw_noise_threshold",
    "raw_rows_design",
    "raw_signals",
    "rows_from_noise",
]

#: Shape of the central velocity estimator: κ = μ = 1, q = 2, ξ = 1/2 (exact for
#: degree 4; on the 7-DOF benchmark q = 0 leaves 0.4 % of bias at a 0.1 s window).
RAW_KAPPA = 1.0
RAW_Q = 2

#: The raw rows are chosen (:func:`rows_from_noise`) when the noise of their velocity
#: estimate, relative to the RMS velocity, is at most
#: ``RAW_NOISE_COEFFICIENT·(2π·B·Tj)²`` (B the excitation band, Tj the Jacobi window:
#: the filtered rows' bias grows like the square of the filter's width against the
#: motion). Calibrated on benchmarks/bench_accuracy.py (final estimates, 3-8 noise
#: seeds; crossover ratio / (2π·B·Tj)²): iiwa7 (B = 0.52 Hz) raw wins at 0.005 and
#: loses at 0.015; 2R paper trajectory (0.62 Hz) ties at 0.005 and loses at 0.015;
#: 2R 1 Hz trajectory wins at 0.007.
RAW_NOISE_COEFFICIENT = 0.008

#: Samples per batch call of the rows in raw_channels_batch: small batches stay in
#: cache (7-DOF 60 s identify: 1.98 s and 166 MB at 256, 2.3 s and 319 MB at 4096).
_CHUNK = 256


@dataclass(frozen=True, eq=False)
class RawRowsDesign:
    """How one bank sample of raw rows is formed (immutable).

    Attributes:
        velocity: the central Jacobi velocity estimator (order 1, window 2m·h,
            delay m·h) [taps in 1/s].
        delay_samples: m, the delay of q', v', τ' in signal samples.
        block: D, the signal samples averaged per bank sample.
    """

    velocity: JacobiFilter
    delay_samples: int
    block: int

    @property
    def time_step(self) -> float:
        """h, the signal period [s]."""
        return self.velocity.time_step

    @property
    def history(self) -> int:
        """Signal samples read per bank sample: D + 2m."""
        return self.block + 2 * self.delay_samples

    @property
    def delay(self) -> float:
        """The instant the bank sample refers to, before its newest sample [s].

        (m + (D - 1)/2)·h: the centre of the averaged samples, each delayed by m.
        """
        return (self.delay_samples + 0.5 * (self.block - 1)) * self.time_step


def raw_rows_design(window: float, time_step: float, block: int) -> RawRowsDesign:
    """The raw-rows design for a velocity window [s], signal period h and D samples.

    Args:
        window: 2m·h, the central velocity estimator's window [s], an even
            multiple of ``time_step`` (>= 2h).
        time_step: h > 0 [s].
        block: D >= 1, signal samples per bank sample.
    """
    owner = "raw_rows_design"
    h = _validate.positive(owner, "time_step", time_step, "s")
    window = _validate.positive(owner, "window", window, "s")
    block = _validate.integer(owner, "block", block, minimum=1)
    half = round(window / (2.0 * h))
    if half < 1 or abs(window - 2 * half * h) > 1e-9 * window:
        _validate.fail(
            owner,
            f"window must be an even multiple (>= 2) of time_step [s]; got {window:g} "
            f"with time_step {h:g}.",
        )
    velocity = jacobi_filter(
        1, 2 * half * h, h, kappa=RAW_KAPPA, mu=RAW_KAPPA, q=RAW_Q, xi=0.5
    )
    return RawRowsDesign(velocity=velocity, delay_samples=half, block=block)


def raw_signals(
    design: RawRowsDesign, history: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q', v', τ')`` of the newest D samples, each (D, n), oldest first.

    Args:
        design: the raw-rows design.
        history: (H, 2n) samples [q; τ], oldest first, H >= ``design.history``.
    """
    history = np.asarray(history, dtype=float)
    count, width = history.shape
    if count < design.history or width % 2:
        _validate.fail(
            "raw_signals",
            f"history must have shape (>= {design.history}, 2n); got {history.shape}.",
        )
    n = width // 2
    m, block = design.delay_samples, design.block
    newest = np.arange(count - block, count)  # the D samples k, oldest first
    lags = np.arange(2 * m + 1)  # taps[j] multiplies q_{k - j}
    windows = history[newest[:, None] - lags[None, :], :n]  # (D, 2m + 1, n)
    v = np.einsum("j,kjn->kn", design.velocity.taps, windows)
    delayed = history[newest - m]
    return delayed[:, :n], v, delayed[:, n:]


def raw_channels(design: RawRowsDesign, rows: Any, kind: str, history: Any) -> Any:
    """One bank sample: the mean over D samples of ``pack_rows(*rows.model_rows)``.

    Args:
        design: the raw-rows design.
        rows: a row provider (``core.rows.RowProvider``).
        kind: ``"power"`` or ``"lagrangian"``.
        history: (H, 2n) samples [q; τ], oldest first (:func:`raw_signals`).

    Returns:
        (2mp + m,) the averaged packed rows (NaN when a sample read is not finite).
    """
    q, v, tau = raw_signals(design, history)
    return _mean_rows(rows, kind, q, v, tau, 1)[0]


def _mean_rows(rows: Any, kind: str, q, v, tau, count: int) -> np.ndarray:
    """(count, c) means of the packed rows of ``count`` consecutive blocks.

    Blocks holding a non-finite input are NaN (the providers reject them).
    """
    width = num_channels(num_equations(kind, q.shape[1]), int(rows.num_parameters))
    finite = np.isfinite(q).all(axis=1) & np.isfinite(v).all(axis=1)
    finite &= np.isfinite(tau).all(axis=1)
    ok = finite.reshape(count, -1).all(axis=1)
    out = np.full((count, width), np.nan)
    if ok.any():
        block = q.shape[0] // count
        keep = np.repeat(ok, block)
        if hasattr(rows, "mean_packed_rows"):  # averaged before the column gather
            out[ok] = rows.mean_packed_rows(kind, q[keep], v[keep], tau[keep], block)
        else:
            packed = pack_rows(*rows.model_rows(kind, q[keep], v[keep], tau[keep]))
            out[ok] = packed.reshape(int(ok.sum()), -1, width).mean(axis=1)
    return out


def raw_channels_batch(
    design: RawRowsDesign,
    rows: Any,
    kind: str,
    q: Any,
    tau: Any,
    ends: Sequence[int] | np.ndarray,
) -> np.ndarray:
    """:func:`raw_channels` of every bank sample of a log, vectorised.

    Bank sample i averages the samples ``ends[i] - D + 1 .. ends[i]``; samples
    before the first are zeros (as in the differentiator's ring). Non-finite
    samples give non-finite channels, as in the block.

    Args:
        design: the raw-rows design.
        rows: a row provider.
        kind: ``"power"`` or ``"lagrangian"``.
        q: (N, n) positions, one row per signal sample: an array or a stored
            log (``drake_dynid.log_store``), of which only the rows these bank
            samples read are loaded.
        tau: (N, n) torques, likewise.
        ends: indices of the newest sample of each bank sample (increasing).

    Returns:
        (len(ends), 2mp + m) the averaged packed rows (NaN for a bank sample
        that reads a non-finite sample).
    """
    ends = np.asarray(ends, dtype=int)  # q, τ: arrays or stored logs, read in part
    return _channels(design, rows, kind, *_padded_signals(design, q, tau, ends))


def _channels(
    design: RawRowsDesign,
    rows: Any,
    kind: str,
    q_pad: np.ndarray,
    velocity: np.ndarray,
    tau_pad: np.ndarray,
    samples: np.ndarray,
) -> np.ndarray:
    """The bank samples' mean rows from :func:`_padded_signals`, a chunk at a time."""
    m, block = design.delay_samples, design.block
    width = num_channels(num_equations(kind, q_pad.shape[1]), int(rows.num_parameters))
    out = [np.zeros((0, width))]
    chunk = max(1, _CHUNK // block) * block  # whole bank samples per call
    for start in range(0, samples.size, chunk):
        k = samples[start : start + chunk]
        out.append(
            _mean_rows(
                rows, kind, q_pad[k - m], velocity[k], tau_pad[k - m], k.size // block
            )
        )
    return np.concatenate(out, axis=0)


def _padded_signals(
    design: RawRowsDesign, q: Any, tau: Any, ends: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(q_pad, v', τ_pad, samples)``: the samples the bank samples ``ends`` read.

    Rows r of ``q_pad``/``τ_pad`` are padded sample ``origin + r`` (``history``
    zeros before the log), ``v'[r]`` the velocity estimate there (zero until the
    taps are filled); ``samples`` (len(ends)·D,) the averaged rows, bank sample by
    bank sample: sample k reads ``q_pad[k - m]``, ``v'[k]``, ``τ_pad[k - m]``.
    """
    m, block = design.delay_samples, design.block
    pad = design.history
    taps = design.velocity.taps
    # Only the samples these bank samples read: padded samples first .. last.
    first = int(ends[0]) + pad - block + 1 if ends.size else pad
    last = int(ends[-1]) + pad + 1 if ends.size else pad
    origin = max(0, first - m - taps.size + 1)  # taps[j] multiplies q_{k-j}
    q_pad = _padded(q, pad, origin, last)  # row r: padded sample origin + r
    tau_pad = _padded(tau, pad, origin, last)
    # v'_k for the padded samples k >= start + taps - 1 (np.convolve's 'valid').
    velocity = np.zeros_like(q_pad)
    for i in range(q.shape[1]):
        velocity[taps.size - 1 :, i] = np.convolve(q_pad[:, i], taps, mode="valid")
    samples = (ends[:, None] + pad - block + 1 + np.arange(block)[None, :]).ravel()
    return q_pad, velocity, tau_pad, samples - origin


@dataclass(frozen=True, eq=False)
class RawLinearization:
    """One window's raw rows and what their perturbation to first order needs.

    Built by :func:`raw_linearization`, used by :func:`linearized_channels`.

    Attributes:
        channels: (B, c) the exact channels (:func:`raw_channels_batch`).
        centre: (B, c) the packed rows at the block means (q̄', v̄', τ̄').
        means: (q̄', v̄', τ̄'), each (B, n): the means of the D averaged samples.
        velocity: (B·D, n) v' of every averaged sample.
        friction: (B, n·k) the block means of G's friction part.
        positions: (n·k,) the channels of G's friction part.
    """

    channels: np.ndarray
    centre: np.ndarray
    means: tuple[np.ndarray, np.ndarray, np.ndarray]
    velocity: np.ndarray
    friction: np.ndarray
    positions: np.ndarray


def raw_linearization(
    design: RawRowsDesign,
    rows: Any,
    kind: str,
    q: Any,
    tau: Any,
    ends: Sequence[int] | np.ndarray,
) -> RawLinearization | None:
    """The raw rows of the bank samples ``ends``, ready for :func:`linearized_channels`.

    None (use :func:`raw_channels_batch` on each perturbed signal instead) unless
    the model is Lagrangian, the provider gives G's friction part apart
    (``lagrangian_friction_rows(v, block)``: the block means of that part, e.g.
    ``core.rows.lagrangian_friction_part``)
    and every sample read is finite. Arguments as :func:`raw_channels_batch`.
    """
    ends = np.asarray(ends, dtype=int)
    part = getattr(rows, "lagrangian_friction_rows", None)
    n = int(np.shape(q)[1])
    if kind != "lagrangian" or part is None or part(np.zeros((1, n))) is None:
        return None
    m, block = design.delay_samples, design.block
    padded = _padded_signals(design, q, tau, ends)
    q_pad, velocity, tau_pad, samples = padded
    signals = q_pad[samples - m], velocity[samples], tau_pad[samples - m]
    if not all(np.isfinite(x).all() for x in signals):
        return None
    count = ends.size
    q_mean, v_mean, tau_mean = (_block_means(x, count, block) for x in signals)
    columns, values = part(signals[1], block)
    p = int(rows.num_parameters)
    return RawLinearization(
        channels=_channels(design, rows, kind, *padded),
        centre=_mean_rows(rows, kind, q_mean, v_mean, tau_mean, count),
        means=(q_mean, v_mean, tau_mean),
        velocity=signals[1],
        friction=values.reshape(count, -1),
        positions=(n * p + p * np.arange(n)[:, None] + columns[None, :]).ravel(),
    )


def linearized_channels(
    linearization: RawLinearization,
    design: RawRowsDesign,
    rows: Any,
    kind: str,
    dq: np.ndarray,
    dtau: np.ndarray,
    ends: Sequence[int] | np.ndarray,
) -> np.ndarray:
    """The channels of the signals q + δq, τ + δτ, the smooth rows to first order.

    With R the packed rows, x̄ = (q̄', v̄', τ̄') the means of one bank sample's
    D samples and δx̄ those of the perturbation (δv' its velocity estimate)::

        C(x + δx) ≈ C(x) + R(x̄ + δx̄) - R(x̄)

    (mean_k R(x_k + δx_k) - mean_k R(x_k) to first order in δx when R's
    Jacobian barely changes over the D samples; exact for y = τ'). G's friction
    part, whose s(v) is not smooth, is averaged exactly:
    mean_k F(v'_k + δv'_k). The parametric bootstrap's replicates
    (``core.bootstrap``): one row evaluation per bank sample instead of D;
    their σ_B is within 3.3 % of the exact re-solves' on the seven 2R scenarios
    (SNR 30 dB, raw rows forced) and equal to three digits on the 7-DOF arm
    (benchmarks/bench_bootstrap.py).

    Args:
        linearization: :func:`raw_linearization` of the same bank samples.
        design: the raw-rows design, as there.
        rows: the row provider, as there.
        kind: ``"lagrangian"``.
        ends: the bank samples, as there.
        dq: (N, n) the perturbation of the positions [rad or m], on the same
            samples as the q given to :func:`raw_linearization`.
        dtau: (N, n) that of the torques [N·m or N].

    Returns:
        (len(ends), 2mp + m) the channels.
    """
    ends = np.asarray(ends, dtype=int)
    lin = linearization
    m, block = design.delay_samples, design.block
    dq_pad, dv, dtau_pad, samples = _padded_signals(design, dq, dtau, ends)
    count = ends.size
    deltas = dq_pad[samples - m], dv[samples], dtau_pad[samples - m]
    q_mean, v_mean, tau_mean = (
        x + _block_means(d, count, block)
        for x, d in zip(lin.means, deltas, strict=True)
    )
    moved = _mean_rows(rows, kind, q_mean, v_mean, tau_mean, count)
    out = lin.channels + (moved - lin.centre)
    _, values = rows.lagrangian_friction_rows(lin.velocity + deltas[1], block)
    friction = values.reshape(count, -1)
    out[:, lin.positions] = lin.channels[:, lin.positions] + (friction - lin.friction)
    return out


def _block_means(x: np.ndarray, count: int, block: int) -> np.ndarray:
    """(count, n) means of ``count`` consecutive blocks of ``block`` rows of x."""
    return x.reshape(count, block, -1).mean(axis=1)


def _padded(x: Any, pad: int, start: int, stop: int) -> np.ndarray:
    """Rows ``start .. stop - 1`` of ``x`` after ``pad`` rows of zeros.

    Reads only those rows of ``x`` (an array, or a stored log read in part).
    """
    out = np.zeros((max(0, stop - start), x.shape[1]))
    low = max(start, pad)
    if stop > low:
        out[low - start :] = np.asarray(x[low - pad : stop - pad], dtype=float)
    return out


def raw_noise_threshold(bandwidth: float, jacobi_window: float) -> float:
    """``RAW_NOISE_COEFFICIENT·(2π·B·Tj)²``: the largest raw velocity noise ratio.

    Args:
        bandwidth: the excitation band B [Hz].
        jacobi_window: the matched filter's window Tj [s].
    """
    owner = "raw_noise_threshold"
    band = _validate.positive(owner, "bandwidth", bandwidth, "Hz")
    window = _validate.positive(owner, "jacobi_window", jacobi_window, "s")
    return RAW_NOISE_COEFFICIENT * (2.0 * math.pi * band * window) ** 2


def rows_from_noise(
    q: Any,
    time_step: float,
    *,
    raw_window: float,
    jacobi_window: float,
    bandwidth: float,
    measures: tuple[Any, Any] | None = None,
) -> tuple[str, float, float]:
    """``(rows_from, ratio, threshold)``: the rows a log's position noise calls for.

    ``ratio = max_j σ_j·‖c‖₂ / v_rms,j``: σ_j the white position noise of joint j,
    ‖c‖₂ the noise gain of the raw rows' central velocity estimator of window
    ``raw_window`` [1/s], v_rms,j the RMS velocity of the motion (both from one
    periodogram, ``core.excitation.motion_and_noise``); joints that do
    not move are ignored. ``"raw"`` (no filter bias, more velocity noise) when
    ``ratio <= threshold = raw_noise_threshold(bandwidth, jacobi_window)`` (the
    filtered rows' bias grows like (2π·B·Tj)²), else ``"filtered"``.

    Args:
        q: (N, n) positions [rad or m], N >= 64 (noise allowed).
        time_step: h [s].
        raw_window: the raw rows' velocity window [s] (rounded to an even
            multiple of h, at least 2h).
        jacobi_window: the matched filter's window Tj [s].
        bandwidth: the excitation band B [Hz].
        measures: ``motion_and_noise(q, time_step)`` when already measured (a
            log measures it once: ``RobotLog.on_longest_run``); None: measured here.
    """
    from drake_dynid.core.excitation import motion_and_noise

    h = _validate.positive("rows_from_noise", "time_step", time_step, "s")
    threshold = raw_noise_threshold(bandwidth, jacobi_window)
    window = 2 * h * max(1, round(raw_window / (2 * h)))
    gain = raw_rows_design(window, h, 1).velocity.noise_gain
    # By pieces on long logs: bounded memory.
    rms, noise = motion_and_noise(q, h) if measures is None else measures
    moving = rms > 0.0
    if not moving.any():
        return "filtered", math.inf, threshold
    ratio = float(np.max(noise[moving] * gain / rms[moving]))
    return ("raw" if ratio <= threshold else "filtered"), ratio, threshold
