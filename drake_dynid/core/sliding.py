"""Sliding Fourier integrals of a stream of samples (docs/MATH.md §3).

For a :class:`~drake_dynid.core.fourier_bank.FourierBank` (window T = N·h, sample
period h, frequencies ν) the window-relative sliding Fourier integral of a channel
``f`` is, by the trapezoid rule on the samples ``f_0 … f_N`` of the window (sample
``i`` at ``s = i·h``)::

    F_ν(f)(t) = ∫_{t-T}^{t} e^{-jνω0 s} f(v) dv,      ω0 = 2π/T             [f·s]

Sliding update (cost O(K × c) per sample, independent of T). With the absolute
sample index ``n`` (sample ``n`` at ``t_n = n·h``) and the absolute phase
``w_ν(n) = e^{-j2πνn/N}`` the state keeps the plain sums
``P_ν = Σ_{i in window} w_ν(i) f_i`` (add the newest sample, subtract the one leaving
the window; exact for any real ``ν``), and the window-relative trapezoid integral
is one rotation away::

    F_ν = h [ conj(w_ν(n-N)) P_ν - ½ f_{n-N} - ½ e^{-j2πν} f_n ]

The phase is computed from the integer index as ``νa + νb/N (mod 1)`` with
``n = aN + b``, so it does not drift over hours. Round-off in the running sums is
removed by a periodic resynchronisation (recomputing ``P`` from the stored window),
and at once when a sample much larger than the rest of the window leaves it: a
finite glitch (τ = 1e20 at one sample) would otherwise leave ~1e20·1e-16 of
cancellation error in ``P`` after it has gone. The state tracks, per channel, the
largest magnitude since the last check and the index of its sample; when that
sample leaves the window and exceeds :data:`RESYNC_RATIO` times the window's
largest remaining magnitude, the sums are recomputed from the window (exact: the
glitch is no longer in it). The state is immutable and cheap to deep-copy (a
persistent chunked ring).
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.fourier_bank import _TABLE, FourierBank, _frozen, check_samples
from drake_dynid.core.ring import ChunkRing

__all__ = [
    "RESYNC_RATIO",
    "SlidingState",
    "is_full",
    "sliding_fourier_integrals",
    "sliding_init",
    "sliding_push",
    "sliding_push_many",
    "sliding_resync",
    "window_valid",
]

_BLOCK = 2048  # samples per block of the phase sums (bounds memory to K × _BLOCK)
_PHASE_REFRESH = 1024  # recompute the absolute phase from the index every this many

#: A sample leaving the window with a magnitude above this many times the largest
#: one left in its channel triggers a resynchronisation of the running sums (the
#: cancellation error it leaves is ~1e-16 of its magnitude).
RESYNC_RATIO = 100.0


@dataclass(frozen=True, eq=False)
class SlidingState:
    """State of the sliding Fourier integrals (immutable; cheap to deep-copy).

    Attributes:
        ring: the last N + 1 samples (:class:`~drake_dynid.core.ring.ChunkRing`).
        sums: (K, c) complex, read-only: ``P_ν = Σ_{i in window} w_ν(i) f_i`` over
            the absolute sample indices i in the window, ``w_ν(i) = e^{-j2πνi/N}``.
        phase: (K,) complex, read-only: ``w_ν(count)``, the phase of the next sample.
        count: samples pushed so far (the newest has absolute index count - 1).
        last_invalid: absolute index of the newest invalid sample (-1: none).
        since_resync: pushes since ``sums`` was last recomputed from the window.
        resync_every: recompute ``sums`` from the window every this many pushes
            (0: never).
        peak: (c,) read-only, the largest |sample| per channel since the last
            check (a glitch leaving the window triggers a resynchronisation).
        peak_index: (c,) read-only, the absolute index of the newest sample with
            that magnitude.

    ``copy.deepcopy`` shares ``sums`` and ``phase`` (read-only: every push makes new
    arrays) and the frozen chunks of the ring, and copies only the ring's partially
    filled chunk.
    """

    ring: ChunkRing
    sums: np.ndarray
    phase: np.ndarray
    count: int
    last_invalid: int
    since_resync: int
    resync_every: int
    peak: np.ndarray
    peak_index: np.ndarray

    @property
    def num_channels(self) -> int:
        """c, the channels per sample."""
        return self.ring.channels

    def __deepcopy__(self, memo: dict[int, Any]) -> SlidingState:
        out = dataclasses.replace(self, ring=copy.deepcopy(self.ring, memo))
        memo[id(self)] = out
        return out


def _phases(bank: FourierBank, index: Any) -> np.ndarray:
    """Absolute phases ``w_ν(index) = e^{-j2πν·index/N}``, (K,) or (K, M), no drift.

    ``index = aN + b`` (b in [0, N)) gives the phase ``νa mod 1 + νb/N`` cycles,
    whose round-off does not grow with the run length.
    """
    a, b = np.divmod(index, bank.num_intervals)
    cycles = np.mod(np.multiply.outer(bank.nu, a), 1.0) + np.multiply.outer(
        bank.nu, b / bank.num_intervals
    )
    return np.exp(-2j * np.pi * cycles)


def _run_phases(bank: FourierBank, first: int, count: int) -> np.ndarray:
    """``w_ν(first + k)`` for k = 0..count-1: (K, count) complex.

    Each run of 256 starts from an exact :func:`_phases` and multiplies the
    precomputed ``phase_table`` (error: a few ulps, no accumulation).
    """
    out = np.empty((bank.num_frequencies, count), dtype=complex)
    starts = np.arange(0, count, _TABLE)
    origins = _phases(bank, first + starts)  # (K, runs)
    for run, start in enumerate(starts):
        stop = min(int(start) + _TABLE, count)
        np.multiply(
            origins[:, run, None],
            bank.phase_table[:, : stop - int(start)],
            out=out[:, start:stop],
        )
    return out


def _absolute_sums(bank: FourierBank, samples: np.ndarray, first: int) -> np.ndarray:
    """``Σ_i w_ν(first + i) samples[i]`` by blocks: (K, c) complex."""
    out = np.zeros((bank.num_frequencies, samples.shape[1]), dtype=complex)
    for start in range(0, len(samples), _BLOCK):
        stop = min(start + _BLOCK, len(samples))
        out += _run_phases(bank, first + start, stop - start) @ samples[start:stop]
    return out


def sliding_init(
    bank: FourierBank,
    num_channels: int,
    *,
    resync_every: int | None = None,
    chunk_size: int | None = None,
) -> SlidingState:
    """Empty sliding state for ``num_channels`` channels.

    Args:
        bank: the design.
        num_channels: c, floats per sample.
        resync_every: pushes between resynchronisations of the running sums from the
            stored window (each costs K·(N+1)·c complex multiply-adds at once).
            Default ``100·(N+1)`` (every 100 windows; without any
            resynchronisation the measured drift after 3.6e6 samples, 1 h at
            1 kHz, is ~5e-12 relative). One resynchronisation takes ~0.1 s for
            K = 221, c = 34, T = 20 s at 1 kHz (a one-off spike). 0 disables.
        chunk_size: rows per frozen block of the ring (default: see ChunkRing).
    """
    owner = "sliding_init"
    v.instance(owner, "bank", bank, FourierBank, "a FourierBank (fourier_bank)")
    num_channels = v.integer(owner, "num_channels", num_channels, minimum=1)
    if resync_every is None:
        resync_every = 100 * bank.num_samples
    resync_every = v.integer(owner, "resync_every", resync_every, minimum=0)
    sums = np.zeros((bank.num_frequencies, num_channels), dtype=complex)
    return SlidingState(
        ring=ChunkRing(bank.num_samples, num_channels, chunk_size=chunk_size),
        sums=_frozen(sums),
        phase=_frozen(np.ones(bank.num_frequencies, dtype=complex)),
        count=0,
        last_invalid=-1,
        since_resync=0,
        resync_every=resync_every,
        peak=_frozen(np.zeros(num_channels)),
        peak_index=_frozen(np.full(num_channels, -1, dtype=np.int64)),
    )


def is_full(state: SlidingState) -> bool:
    """True once the window holds N + 1 samples."""
    _check("is_full", None, state)
    return state.ring.is_full


def window_valid(state: SlidingState) -> bool:
    """True when the window is full and holds no invalid sample.

    An invalid sample (pushed with ``valid=False`` or with a non-finite channel) is
    stored as zeros and keeps the window invalid until it has left it, N + 1
    pushes later.
    """
    _check("window_valid", None, state)
    return state.ring.is_full and state.last_invalid < state.count - len(state.ring)


def sliding_resync(bank: FourierBank, state: SlidingState) -> SlidingState:
    """Recomputes the running sums and the phase from the stored window.

    Removes accumulated round-off; costs K·(N+1)·c complex multiply-adds.
    """
    _check("sliding_resync", bank, state)
    window = state.ring.window()
    first = state.count - len(window)
    sums = _absolute_sums(bank, window, first)
    peak, peak_index = _window_peaks(window, first)
    return dataclasses.replace(
        state,
        sums=_frozen(sums),
        phase=_frozen(_phases(bank, state.count)),
        since_resync=0,
        peak=peak,
        peak_index=peak_index,
    )


def _check(owner: str, bank: Any, state: Any = None) -> None:
    """TypeError/ValueError unless ``bank`` is a FourierBank and ``state`` its state.

    ``bank`` None: only the state is checked; ``state`` None: only the bank.
    """
    if bank is not None:
        v.instance(owner, "bank", bank, FourierBank, "a FourierBank (fourier_bank)")
    if state is None:
        return
    v.instance(owner, "state", state, SlidingState, "a SlidingState (sliding_init)")
    if bank is not None and state.ring.capacity != bank.num_samples:
        v.fail(
            owner,
            f"state must belong to this bank ({bank.num_samples} samples per "
            f"window); got a state of {state.ring.capacity}.",
        )


def _window_peaks(window: np.ndarray, first: int) -> tuple[np.ndarray, np.ndarray]:
    """Per channel, the largest |sample| of ``window`` and where it is.

    Returns the magnitudes (c,) and the absolute index of the newest sample with
    each (``first``: the index of the window's first row).
    """
    if len(window) == 0:
        c = window.shape[1]
        return _frozen(np.zeros(c)), _frozen(np.full(c, -1, dtype=np.int64))
    magnitude = np.abs(window)
    newest = len(window) - 1 - np.argmax(magnitude[::-1], axis=0)
    peak = magnitude[newest, np.arange(window.shape[1])]
    return _frozen(peak), _frozen(first + newest.astype(np.int64))


def _track(
    state: SlidingState, x: np.ndarray, first: int
) -> tuple[np.ndarray, np.ndarray]:
    """``state``'s peaks updated with the block ``x`` (b, c) of indices first..."""
    block_peak, block_index = _window_peaks(x, first)
    newer = block_peak >= state.peak
    if not newer.any():
        return state.peak, state.peak_index
    return (
        _frozen(np.where(newer, block_peak, state.peak)),
        _frozen(np.where(newer, block_index, state.peak_index)),
    )


def _check_departures(bank: FourierBank, state: SlidingState) -> SlidingState:
    """Resynchronises when a channel's peak has left the window and was large.

    Otherwise, the peaks of the channels whose peak left are re-read from the
    window (O(N·k) for the k channels that left, once per departure).
    """
    oldest = state.count - len(state.ring)
    gone = np.flatnonzero((state.peak_index >= 0) & (state.peak_index < oldest))
    if gone.size == 0:
        return state
    # Only the departed channels are re-read (a few of the c per push).
    peak, peak_index = _window_peaks(state.ring.window_columns(gone), oldest)
    if np.any(state.peak[gone] > RESYNC_RATIO * peak):
        return sliding_resync(bank, state)
    new_peak = state.peak.copy()
    new_index = state.peak_index.copy()
    new_peak[gone] = peak
    new_index[gone] = peak_index
    return dataclasses.replace(
        state, peak=_frozen(new_peak), peak_index=_frozen(new_index)
    )


def sliding_push(
    bank: FourierBank, state: SlidingState, sample: Any, *, valid: bool = True
) -> SlidingState:
    """Pushes one sample: ``P_ν += w_ν(n) f_n - w_ν(n-N-1) f_{n-N-1}``.

    The phase of the next sample is ``w_ν(n+1) = w_ν(n) e^{-j2πν/N}``, recomputed
    exactly from the integer index every 1024 samples, so its error stays below
    ~1e-13 for any run length.

    Args:
        bank: the design.
        state: the current state (unchanged).
        sample: (c,) newest sample f_n.
        valid: False marks the sample invalid (e.g. the differentiator has not
            filled yet): it is stored as zeros and :func:`window_valid` is False
            until it has left the window. A non-finite sample is invalid too.

    Returns:
        The new state (O(K·c) work, plus a resynchronisation every
        ``resync_every`` pushes).
    """
    _check("sliding_push", bank, state)
    x = np.asarray(sample, dtype=float)
    if x.shape != (state.num_channels,):
        v.fail(
            "sliding_push",
            f"sample must have shape ({state.num_channels},); got {x.shape}.",
        )
    n = state.count
    last_invalid = state.last_invalid
    if not (valid and np.isfinite(x).all()):
        x = np.zeros_like(x)
        last_invalid = n
    ring = state.ring
    phase = state.phase
    if ring.is_full:
        phases = np.empty((phase.size, 2), dtype=complex)
        phases[:, 0] = phase
        np.multiply(phase, bank.phase_leave, out=phases[:, 1])
        terms = np.empty((2, x.size))
        terms[0] = x
        np.negative(ring.oldest, out=terms[1])
        sums = phases @ terms
    else:
        sums = np.multiply.outer(phase, x)
    sums += state.sums
    if (n + 1) % _PHASE_REFRESH:
        next_phase = phase * bank.phase_step
    else:
        next_phase = _phases(bank, n + 1)
    peak, peak_index = _track(state, x[None, :], n)
    new = SlidingState(
        ring=ring.push(x),
        sums=_frozen(sums),
        phase=_frozen(next_phase),
        count=n + 1,
        last_invalid=last_invalid,
        since_resync=state.since_resync + 1,
        resync_every=state.resync_every,
        peak=peak,
        peak_index=peak_index,
    )
    if state.resync_every and new.since_resync >= state.resync_every:
        return sliding_resync(bank, new)
    return _check_departures(bank, new)


def sliding_push_many(
    bank: FourierBank, state: SlidingState, samples: Any, *, valid: Any = None
) -> SlidingState:
    """Pushes a block of samples (b, c), oldest first, vectorised (log replay).

    Gives the same integrals as ``b`` calls of :func:`sliding_push` (to round-off):
    one (K × b) @ (b × c) product for the samples entering and one for those
    leaving, with phases computed from the integer indices. A block at least as
    long as the window, or one that reaches ``resync_every``, ends with a
    resynchronisation.

    Args:
        bank: the design.
        state: the current state (unchanged).
        samples: (b, c) samples, oldest first.
        valid: optional (b,) booleans; invalid or non-finite rows are stored as
            zeros (see :func:`sliding_push`).
    """
    owner = "sliding_push_many"
    _check(owner, bank, state)
    x = check_samples(owner, samples, None, finite=False)
    if x.shape[1] != state.num_channels:
        v.fail(
            owner, f"samples must have {state.num_channels} channels; got {x.shape}."
        )
    count = len(x)
    ok = np.isfinite(x).all(axis=1)
    if valid is not None:
        mask = np.asarray(valid)
        if mask.shape != (count,):
            v.fail(owner, f"valid must have shape ({count},); got {mask.shape}.")
        ok &= mask.astype(bool)
    last_invalid = state.last_invalid
    if not ok.all():
        x = np.where(ok[:, None], x, 0.0)
        last_invalid = state.count + int(np.flatnonzero(~ok)[-1])
    ring = state.ring.extend(x)
    new_count = state.count + count
    since = state.since_resync + count
    peak, peak_index = _track(state, x, state.count)
    if count >= bank.num_samples or (
        state.resync_every and since >= state.resync_every
    ):
        new = dataclasses.replace(
            state,
            ring=ring,
            count=new_count,
            last_invalid=last_invalid,
            since_resync=since,
            peak=peak,
            peak_index=peak_index,
        )
        return sliding_resync(bank, new)
    sums = _absolute_sums(bank, x, state.count)
    leaving = max(0, state.ring.size + count - bank.num_samples)
    if leaving:
        first = state.count - state.ring.size
        sums -= _absolute_sums(bank, state.ring.head(leaving), first)
    sums += state.sums
    new = SlidingState(
        ring=ring,
        sums=_frozen(sums),
        phase=_frozen(_phases(bank, new_count)),
        count=new_count,
        last_invalid=last_invalid,
        since_resync=since,
        resync_every=state.resync_every,
        peak=peak,
        peak_index=peak_index,
    )
    return _check_departures(bank, new)


def sliding_fourier_integrals(bank: FourierBank, state: SlidingState) -> np.ndarray:
    """Window-relative sliding Fourier integrals F (K, c) of the current window.

    ``F_ν = h [conj(w_ν(n-N)) P_ν - ½ f_{n-N} - ½ e^{-j2πν} f_n]`` with n the newest
    index: equal to :func:`direct_fourier_integrals` on the window. Before the
    window is full the missing older samples count as zeros.
    """
    _check("sliding_fourier_integrals", bank, state)
    ring = state.ring
    if ring.size == 0:
        return np.zeros((bank.num_frequencies, state.num_channels), dtype=complex)
    # w(n - N) = w(count - 1 - N) = w(count) · e^{+j2πν(N+1)/N}.
    h = bank.time_step
    rotation = np.conj(state.phase * bank.phase_leave) * h
    out = rotation[:, None] * state.sums
    out -= np.multiply.outer((0.5 * h) * bank.phase_end, ring.newest)
    if ring.is_full:
        out -= (0.5 * h) * ring.oldest
    return out
