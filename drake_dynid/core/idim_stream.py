"""Streamed off-line IDIM rows: two-stage parallel decimation in bounded memory.

The off-line chain of ``drake_dynid.offline`` on one finite segment of a log is
(README "Off-line identification"; :mod:`drake_dynid.core.idim`)::

    q_f = zero-phase Butterworth(q) at f_c,  v, v̇ central differences of q_f
    W_k = W(q_f,k, v_k, v̇_k)                      (N, n, p)  [N·m per unit]
    D(x) = (zero-phase order-8 Butterworth at f_d)(x), one sample in D
    solve D(τ) = D(W) X

Evaluated directly, W costs a regressor call and n·p floats per sample: 3.2 KB per
sample on a 7-DOF arm, 1.2 GB for one minute at 1 kHz. This module computes the
same equation at a fraction of the cost, in memory independent of the log length.

**Which columns are evaluated where.** The columns of W are of two kinds:

* friction columns ``v_j``, ``s(v_j)``, ``1`` (joint j's row only; s the model's
  Coulomb law: the exact sign or a standstill dead zone, whose moving joints'
  reversals are restored, ``core.standstill.reversal_signs``, each block reading
  2L + 1 velocities of context either side), and a coupled motor's Coulomb
  column, one series s_m(x_k) of its velocity x_k = (R_k·v)/ρ_k with its own
  zone and reversals, which the caller spreads over the rows by R_kᵀ
  (``core.idim_friction``): cheap, and ``s(v)`` is discontinuous (broadband);
  they go through the decimation at the full rate, like τ;
* rigid-body columns (everything else): expensive, but smooth functions of the
  filtered q_f, v, v̇, whose spectrum the position filter limits to a few f_c.

**Two stages, the same on both sides.** The decimation D = D1·D2 runs in two
stages:

1. anti-alias to the intermediate rate f_s/D1: a symmetric Kaiser FIR ``a`` (120 dB,
   flat to 1e-6 up to 2·f_d, stop band from f_s/D1 - 2·f_d), evaluated only at
   every D1-th sample: ``x_A[r] = Σ_m a_m x[trim + r·D1 + m]``, on τ and on the
   friction columns. Its support (K samples each side) lies inside the trimmed
   ends of the segment, so it needs no padding and has no edge transient.
   The rigid-body columns are *not* filtered: they are evaluated at the same
   D1-th samples, W_rb[r] = W_rb(q_f, v, v̇)[trim + r·D1];
2. on every column at the intermediate rate: the zero-phase order-8 Butterworth
   at f_d (even padding of four cutoff periods, as
   :func:`~drake_dynid.core.idim.parallel_decimation`), then one sample in D2.

Stage 1 leaves τ = W X intact to first order: ``a`` is flat (1 ± 1e-6) where
stage 2 passes anything (|H|² < 1.5e-5 above 2·f_d), and the only content of
W_rb that stage 1 would have removed *and* that stage 2 would keep is what
aliases from around multiples of f_s/D1 into [0, 2·f_d]; the rule
f_s/D1 >= 4·f_c (:func:`regressor_decimation`) puts that beyond four times the
position filter's cutoff (|H_c| < 1.5e-5 there). Stage 2 is applied to both sides
identically. The decimated equation therefore differs from the one-stage parallel
decimation only by the filter that shapes the noise (the two-stage filter instead
of the one-stage one), not by a model error. Measured on simulated 2R and 7-DOF
logs (tests/test_offline_stream.py), the estimates agree with the one-stage path
to a small fraction of their σ.

**Bounded memory.** Both zero-phase IIR filters are applied to blocks with
margins long enough for their start-up transients to decay to 1e-12
(:func:`settle_samples`); at the true ends of the segment the padding of the
whole-segment filter is reproduced exactly, so a segment that fits in one block
gives :func:`zero_phase_span` of the whole segment bit for bit, and longer ones
agree to the margins' 1e-12. Against ``scipy.signal.sosfiltfilt`` both differ by
the round-off of ``core.iir``'s block filter, about 1e-12 of the positions
(measured on a 4th-order 6 Hz filter at 1 kHz), which the second difference v̇
(1/h²) turns into about 1e-8 of the accelerations.
Working memory is a few blocks of n + friction + rigid-body columns, independent of
the log length; only the decimated rows (N/D of them) are kept.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Literal, overload

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.blocks import checked_rows
from drake_dynid.core.friction import EXACT_SIGN, DeadZoneSign, SignLaw
from drake_dynid.core.idim import DECIMATION_FILTER_ORDER, default_padding
from drake_dynid.core.idim_friction import (
    FRICTION_KINDS,
    FrictionLayout,
    MotorChannels,
    channel_velocities,
    friction_layout,
    friction_series,
    signs_of,
)
from drake_dynid.core.standstill import reversal_run, reversal_signs
from drake_dynid.core.zero_phase import (
    SETTLE_TOLERANCE,
    settle_samples,
    zero_phase_span,
)

__all__ = [
    "ALIAS_FACTOR",
    "ANTI_ALIAS_DB",
    "BAND_FACTOR",
    "FRICTION_KINDS",
    "SETTLE_TOLERANCE",
    "FrictionLayout",
    "StreamPlan",
    "anti_alias_taps",
    "decimated_chunks",
    "decimated_segment",
    "friction_layout",
    "regressor_decimation",
    "settle_samples",
    "stream_plan",
    "zero_phase_span",
]

ALIAS_FACTOR = 4.0
"""The intermediate rate f_s/D1 is at least 4·f_c (rigid-body columns, stage 1)."""

BAND_FACTOR = 16.0
"""The intermediate rate f_s/D1 is at least 16·f_d (stage 2 close to one stage)."""

ANTI_ALIAS_DB = 120.0
"""Kaiser FIR of stage 1: pass-band ripple and stop-band attenuation 1e-6."""

BLOCK_SAMPLES = 1 << 16
"""Full-rate samples per block of the position filter and stage 1."""

ROWS_CHUNK = 256
"""Largest batch of one rigid-body rows call (larger batches leave the cache)."""

_GROUP_COLUMNS = 32  # stage 2 filters at most this many columns at once

RigidRows = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def anti_alias_taps(factor: int, passband: float) -> np.ndarray:
    """Stage-1 FIR: symmetric Kaiser low-pass for one sample in ``factor``.

    Cutoff at the intermediate Nyquist frequency 1/(2·factor), transition band
    [passband, 1/factor - passband] (cycles per sample), ripple and attenuation
    :data:`ANTI_ALIAS_DB`. ``factor = 1`` gives the identity ``[1.0]``.

    Args:
        factor: the intermediate decimation D1 (>= 1).
        passband: the highest frequency passed flat [cycles/sample], < 1/(2·factor).

    Returns:
        The odd number 2K + 1 of taps, DC gain 1.
    """
    if factor == 1:
        return np.ones(1)
    width = 2.0 * (1.0 / factor - 2.0 * passband)  # Nyquist = 1
    if width <= 0.0:
        check.fail(
            "anti_alias_taps",
            f"passband must be < 1/(2·factor) = {0.5 / factor:g} cycles/sample; got "
            f"{passband:g}.",
        )
    from scipy import signal  # lazily: not on dynid identify's path

    numtaps, beta = signal.kaiserord(ANTI_ALIAS_DB, min(width, 1.0))
    numtaps += 1 - numtaps % 2  # odd: symmetric about a sample
    return signal.firwin(numtaps, 1.0 / factor, window=("kaiser", beta))


def regressor_decimation(
    time_step: float,
    cutoff_hz: float,
    decimation: int,
    decimation_cutoff_hz: float,
    trim: int,
    *,
    divides: bool = True,
) -> int:
    """Largest intermediate decimation D1 for the rigid-body columns (1: none).

    The intermediate rate f_s/D1 is at least ``max(4·f_c, 16·f_d)``: the
    rigid-body columns have nothing left to alias there, and stage 2 (the order-8
    Butterworth at f_d designed at the intermediate rate) stays close to the
    one-stage filter: on a simulated 7-DOF log at 1 kHz, f_s/D1 = 28·f_d moved the
    estimates by at most 0.11 σ from the one-stage parallel decimation, 8·f_d by
    0.42 σ (the bilinear transform's frequency warping grows like (f_d·D1·h)²).
    Also the FIR's half length K is shorter than the ``trim`` samples dropped at
    each segment end, D1 <= D and, with ``divides``, D1 divides D.

    Args:
        time_step: sample period h [s].
        cutoff_hz: position filter cutoff f_c [Hz].
        decimation: the total decimation D.
        decimation_cutoff_hz: the decimation low-pass f_d [Hz].
        trim: samples dropped at each end of a segment.
        divides: only divisors of D (False: any D1 <= D, to choose D itself).
    """
    rate = 1.0 / time_step
    bound = rate / max(ALIAS_FACTOR * cutoff_hz, BAND_FACTOR * decimation_cutoff_hz)
    for factor in range(min(decimation, math.floor(bound)), 1, -1):
        if divides and decimation % factor:
            continue
        taps = anti_alias_taps(factor, 2.0 * decimation_cutoff_hz * time_step)
        if (taps.size - 1) // 2 <= trim - 1:
            return factor
    return 1


@dataclass(frozen=True)
class StreamPlan:
    """Filters and sizes of the streamed chain of one log (see the module docstring).

    Attributes:
        time_step: sample period h [s].
        trim: samples dropped at each segment end (>= K + 1).
        padding: odd-reflection samples of the position filter.
        decimation: D = D1·D2.
        factor: D1, the intermediate decimation of the rigid-body columns.
        position_sos: the position filter (order ``filter_order`` at f_c).
        position_margin: its settling length [full-rate samples].
        taps: the stage-1 FIR (2K + 1 taps).
        decimation_sos: stage 2 at the intermediate rate (order 8 at f_d).
        decimation_margin: its settling length [intermediate samples].
        decimation_padding: its even-reflection padding [intermediate samples].
        block: full-rate samples per stage-1 block.
        reversal: L of a dead zone's reversals (``core.standstill.reversal_run``
            at f_c) [full-rate samples].
    """

    time_step: float
    trim: int
    padding: int
    decimation: int
    factor: int
    position_sos: np.ndarray
    position_margin: int
    taps: np.ndarray
    decimation_sos: np.ndarray
    decimation_margin: int
    decimation_padding: int
    block: int
    reversal: int


def stream_plan(
    time_step: float,
    *,
    cutoff_hz: float,
    filter_order: int,
    trim: int,
    padding: int,
    decimation: int,
    decimation_cutoff_hz: float,
    factor: int | None = None,
    block: int = BLOCK_SAMPLES,
) -> StreamPlan:
    """The :class:`StreamPlan` of these settings (``factor`` None: automatic D1).

    Args:
        time_step: sample period h [s].
        cutoff_hz: position filter cutoff f_c [Hz].
        filter_order: its Butterworth order.
        trim: samples dropped at each segment end (>= 1).
        padding: odd-reflection padding of the position filter [samples].
        decimation: total decimation D (>= 1).
        decimation_cutoff_hz: the decimation low-pass f_d [Hz].
        factor: intermediate decimation D1, a divisor of D (1: every sample is
            evaluated, the one-stage parallel decimation); None:
            :func:`regressor_decimation`.
        block: full-rate samples per block (>= 1).
    """
    owner = "stream_plan"
    fd = decimation_cutoff_hz * time_step  # cycles per full-rate sample
    if factor is None:
        factor = regressor_decimation(
            time_step, cutoff_hz, decimation, decimation_cutoff_hz, trim
        )
    factor = check.integer(owner, "factor", factor, minimum=1)
    if decimation % factor:
        check.fail(
            owner, f"factor must divide the decimation {decimation}; got {factor}."
        )
    if factor > 1 and 2.0 * fd * factor >= 0.5:
        check.fail(
            owner,
            f"factor {factor} leaves no room for the decimation low-pass "
            f"{decimation_cutoff_hz:g} Hz: the intermediate rate must exceed 4·f_d.",
        )
    taps = anti_alias_taps(factor, 2.0 * fd)
    if (taps.size - 1) // 2 > trim - 1:
        check.fail(
            owner,
            f"factor {factor} needs an anti-alias filter of {taps.size} taps, longer "
            f"than the {trim} samples trimmed at each segment end; use a smaller "
            "factor.",
        )
    from scipy import signal  # lazily: not on dynid identify's path

    position_sos = signal.butter(
        filter_order, cutoff_hz, fs=1.0 / time_step, output="sos"
    )
    decimation_sos = signal.butter(
        DECIMATION_FILTER_ORDER, 2.0 * fd * factor, output="sos"
    )
    reduced_padding = default_padding(1.0, fd * factor)
    return StreamPlan(
        time_step=float(time_step),
        trim=int(trim),
        padding=int(padding),
        decimation=int(decimation),
        factor=int(factor),
        position_sos=position_sos,
        position_margin=max(settle_samples(position_sos), padding + 2),
        taps=taps,
        decimation_sos=decimation_sos,
        decimation_margin=max(settle_samples(decimation_sos), reduced_padding + 2),
        decimation_padding=reduced_padding,
        block=check.integer(owner, "block", block, minimum=1),
        reversal=reversal_run(time_step, cutoff_hz),
    )


def _rigid(rows: RigidRows, q, v, vdot) -> np.ndarray:
    parts = []
    for a in range(0, q.shape[0], ROWS_CHUNK):
        b = a + ROWS_CHUNK
        parts.append(np.asarray(rows(q[a:b], v[a:b], vdot[a:b]), dtype=float))
    out = np.concatenate(parts) if len(parts) > 1 else parts[0]
    return out.reshape(out.shape[0], -1)


def _stage_one(
    q: np.ndarray,
    tau: np.ndarray,
    plan: StreamPlan,
    rows: RigidRows,
    friction: Sequence[tuple[str, int]],
    laws: tuple[SignLaw, MotorChannels | None],
) -> Iterator[np.ndarray]:
    """Intermediate-rate columns [τ_A, friction_A, W_rb] in consecutive chunks."""
    count = -(-(q.shape[0] - 2 * plan.trim) // plan.factor)
    chunk = max(1, plan.block // plan.factor)
    for ra in range(0, count, chunk):
        # One block per call: its full-rate arrays are freed before the yield.
        yield _stage_one_block(
            q, tau, plan, rows, friction, laws, ra, min(count, ra + chunk)
        )


def _restored_signs(
    v: np.ndarray, sign: SignLaw, channels: MotorChannels | None, longest: int
) -> np.ndarray:
    """Signs s of every channel of v (n joints, then c motors), reversals restored.

    A dead zone (the joints' ``sign``, the motors' ``channels.sign``) gives
    ``core.standstill.reversal_signs`` with its widths; any other law its values
    sample by sample.
    """
    n = v.shape[1] - (0 if channels is None else channels.rows.shape[0])
    groups = [(slice(0, n), sign)]
    if channels is not None:
        groups.append((slice(n, None), channels.sign))
    out = np.empty_like(v)
    for part, law in groups:
        out[:, part] = (
            reversal_signs(v[:, part], law.width, longest)
            if isinstance(law, DeadZoneSign)
            else law(v[:, part])
        )
    return out


def _stage_one_block(q, tau, plan, rows, friction, laws, ra, rb) -> np.ndarray:
    """Intermediate samples [ra, rb) of :func:`_stage_one`."""
    sign, channels = laws
    h, trim, D1 = plan.time_step, plan.trim, plan.factor
    N = q.shape[0]
    K = (plan.taps.size - 1) // 2
    lead = (-2 * K) % D1  # zeros ahead of the data: output `first` is sample trim
    first = (2 * K + lead) // D1
    pad = min(plan.padding, N - 1)
    margin = plan.position_margin
    lo = trim + ra * D1 - K  # full-rate range [lo, hi) of stage 1's support
    hi = trim + (rb - 1) * D1 + K + 1
    # A dead zone's reversals (the joints' or the motors') need 2L + 1 velocities
    # of context on either side (core.standstill.reversal_signs): the block's
    # signs are then the whole segment's.
    zone = any(
        isinstance(law, DeadZoneSign)
        for law in (sign, None if channels is None else channels.sign)
    ) and any(kind == "coulomb" for kind, _ in friction)
    context = 2 * plan.reversal + 1 if zone else 0
    lo_c, hi_c = max(1, lo - context), min(N - 1, hi + context)
    a, b = max(0, lo_c - 1 - margin), min(N, hi_c + 1 + margin)
    q_c = zero_phase_span(
        plan.position_sos,
        q[a:b],
        pad_left=pad if a == 0 else 0,
        pad_right=pad if b == N else 0,
        padtype="odd",
    )[lo_c - 1 - a : hi_c + 1 - a]
    v_c = (q_c[2:] - q_c[:-2]) / (2.0 * h)  # samples [lo_c, hi_c)
    q_f = q_c[lo - lo_c : hi - lo_c + 2]
    v = v_c[lo - lo_c : hi - lo_c]
    x_c = channel_velocities(v_c, channels)  # the joints', then the motors'
    x = x_c[lo - lo_c : hi - lo_c]
    grid = slice(K, K + (rb - ra - 1) * D1 + 1, D1)
    ahead, here, behind = q_f[2:][grid], q_f[1:-1][grid], q_f[:-2][grid]
    vdot = (ahead - 2.0 * here + behind) / h**2  # at the grid only
    rigid = _rigid(rows, here, v[grid], vdot)
    # [τ, friction] at the full rate after `lead` zeros, through the FIR a group
    # of n columns at a time (each column on its own: the same numbers).
    n = tau.shape[1]
    series = np.asarray(tau[lo:hi], dtype=float)
    signs = (
        _restored_signs(x_c, sign, channels, plan.reversal)[lo - lo_c : hi - lo_c]
        if zone
        else signs_of(x, friction, sign, channels)
    )
    out = np.empty((rb - ra, n + len(friction) + rigid.shape[1]))
    out[:, n + len(friction) :] = rigid
    from scipy import signal  # lazily: not on dynid identify's path

    for c in range(0, n + len(friction), n):
        if c:
            series = friction_series(x, friction[c - n : c], sign, signs=signs)
        if D1 == 1:
            out[:, c : c + series.shape[1]] = series
            continue
        full = np.zeros((lead + series.shape[0], series.shape[1]))
        full[lead:] = series
        filtered = signal.upfirdn(plan.taps, full, down=D1, axis=0)
        out[:, c : c + series.shape[1]] = filtered[first : first + rb - ra]
    return out


def _stage_two(
    chunks: Iterator[np.ndarray], count: int, plan: StreamPlan, raw: bool = False
) -> Iterator[np.ndarray]:
    """Zero-phase order-8 low-pass at f_d and one sample in D2, block by block.

    ``raw``: the same samples before the low-pass follow as many more columns.
    """
    D2 = plan.decimation // plan.factor
    margin = plan.decimation_margin
    pad = min(plan.decimation_padding, count - 1)
    step = D2 * max(1, -(-2 * margin // D2))  # outputs per block: a multiple of D2
    buffer = np.empty((0, 0))
    start = 0  # intermediate index of buffer[0]
    done = 0  # next intermediate index to output
    for chunk in chunks:
        buffer = chunk if buffer.size == 0 else np.concatenate([buffer, chunk])
        end = start + buffer.shape[0]
        while done < count and (end == count or end >= done + step + margin):
            r1 = min(count, done + step)
            u0, u1 = max(0, done - margin), min(count, r1 + margin)
            span = buffer[u0 - start : u1 - start]
            parts = []
            for c in range(0, span.shape[1], _GROUP_COLUMNS):
                y = zero_phase_span(
                    plan.decimation_sos,
                    span[:, c : c + _GROUP_COLUMNS],
                    pad_left=pad if u0 == 0 else 0,
                    pad_right=pad if u1 == count else 0,
                    padtype="even",
                )
                parts.append(y[done - u0 : r1 - u0 : D2].copy())  # y freed
            if raw:
                parts.append(span[done - u0 : r1 - u0 : D2].copy())
            yield np.concatenate(parts, axis=1)
            done = r1
            keep = max(0, done - margin) - start
            buffer = buffer[keep:].copy()
            start += keep


_Chunk = tuple[np.ndarray, np.ndarray, np.ndarray]


@overload
def decimated_chunks(
    q: np.ndarray,
    tau: np.ndarray,
    plan: StreamPlan,
    rows: RigidRows,
    friction: Sequence[tuple[str, int]] = (),
    sign: SignLaw = EXACT_SIGN,
    raw: Literal[False] = False,
    channels: MotorChannels | None = None,
) -> Iterator[_Chunk]: ...


@overload
def decimated_chunks(
    q: np.ndarray,
    tau: np.ndarray,
    plan: StreamPlan,
    rows: RigidRows,
    friction: Sequence[tuple[str, int]] = (),
    sign: SignLaw = EXACT_SIGN,
    *,
    raw: Literal[True],
    channels: MotorChannels | None = None,
) -> Iterator[
    tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
]: ...


def decimated_chunks(
    q: np.ndarray,
    tau: np.ndarray,
    plan: StreamPlan,
    rows: RigidRows,
    friction: Sequence[tuple[str, int]] = (),
    sign: SignLaw = EXACT_SIGN,
    raw: bool = False,
    channels: MotorChannels | None = None,
) -> Iterator[tuple[np.ndarray, ...]]:
    """Decimated rigid-body rows, friction columns and torques of one finite segment.

    Row i refers to sample ``trim + i·D`` of the segment (as
    ``parallel_decimation(W, tau[trim:N - trim], D)``); yielded a block of rows
    at a time, in order (memory: a few blocks, not the K rows).

    Args:
        q: (N, n) finite positions [rad or m], N >= 2·trim + 1 (an array, or a
            stored log read a block at a time: ``drake_dynid.core.blocks``).
        tau: (N, n) finite torques [N·m or N], likewise.
        plan: the :class:`StreamPlan`.
        rows: ``rows(q_f, v, v̇) -> (R, n, p_rb)`` rigid-body columns.
        friction: (kind, channel) per friction column, kind in
            :data:`FRICTION_KINDS`, channel 0-based: joint j < n, or n + i for
            motor i of ``channels``.
        sign: the Coulomb sign law s of the joints' ``coulomb`` columns (applied
            to the (N, n) velocity; default the exact sign). A ``DeadZoneSign``
            is applied with the segment's reversals restored
            (``core.standstill.reversal_signs`` at L = ``plan.reversal``), any
            other law sample by sample; so is the motors' law ``channels.sign``
            on their (N, c) velocities.
        raw: also yield the same rows before stage 2's low-pass (with D = 1,
            e.g. ``drake_dynid.validation``: the unfiltered samples).
        channels: the coupled motors' channels x_i = (R_i·v)/ρ_i
            (``core.idim_friction.MotorChannels``), or None.

    Yields:
        ``(W_rb, F, tau_d)`` chunks of (k, n, p_rb) rigid-body rows, (k,
        len(friction)) friction series (column c belongs to joint j's row for
        channel j < n; the caller spreads a motor's by R_iᵀ,
        ``FrictionLayout.place``) and (k, n) torques; K = ceil((N - 2·trim)/D) rows in
        all. With ``raw``, followed by ``(W_rb, F, tau)`` before the low-pass.
    """
    owner = "decimated_chunks"
    q = checked_rows(owner, "q", q)  # a stored log: read a block at a time
    tau = checked_rows(owner, "tau", tau)
    if q.ndim != 2 or tau.shape != q.shape:
        check.fail(owner, f"q and tau must be (N, n); got {q.shape} and {tau.shape}.")
    if q.shape[0] < 2 * plan.trim + 1:
        check.fail(
            owner,
            f"q must have at least {2 * plan.trim + 1} samples for trim {plan.trim}; "
            f"got {q.shape[0]}.",
        )
    if channels is not None and (
        channels.rows.ndim != 2 or channels.rows.shape[1] != q.shape[1]
    ):
        check.fail(
            owner,
            f"channels.rows must be (c, {q.shape[1]}); got {channels.rows.shape}.",
        )
    n, width = q.shape[1], len(friction)
    total = n + (0 if channels is None else channels.rows.shape[0])
    for kind, channel in friction:
        if kind not in FRICTION_KINDS or not 0 <= channel < total:
            check.fail(owner, f"bad friction column ({kind!r}, {channel}).")
    count = -(-(q.shape[0] - 2 * plan.trim) // plan.factor)
    chunks = _stage_one(q, tau, plan, rows, friction, (sign, channels))
    for data in _stage_two(chunks, count, plan, raw):
        out: tuple[np.ndarray, ...] = ()
        for part in np.split(data, 2, axis=1) if raw else (data,):
            rigid = part[:, n + width :]
            out += (
                rigid.reshape(rigid.shape[0], n, -1),
                part[:, n : n + width],
                part[:, :n],
            )
        yield out


def decimated_segment(
    q: np.ndarray,
    tau: np.ndarray,
    plan: StreamPlan,
    rows: RigidRows,
    friction: Sequence[tuple[str, int]] = (),
    sign: SignLaw = EXACT_SIGN,
    channels: MotorChannels | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`decimated_chunks` of one segment, stacked.

    Arguments and chunks as there: ``(W_rb, F, tau_d)`` with K = ceil((N -
    2·trim)/D) rows.
    """
    parts = list(
        decimated_chunks(q, tau, plan, rows, friction, sign, channels=channels)
    )
    W_rb, F, tau_d = (np.concatenate([part[i] for part in parts]) for i in range(3))
    return W_rb, F, tau_d
