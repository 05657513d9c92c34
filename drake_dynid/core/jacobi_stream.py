"""Causal Jacobi filters applied to signals: batch and streaming (docs/MATH.md §1).

A designed filter (:mod:`drake_dynid.core.jacobi_design`) estimates
``x̂^(k)(t_n - delay) = Σ_{j=0..N} taps[j] x_{n-j}``. :func:`jacobi_batch` applies it
causally to a whole array (log replay, benchmarks); the streaming functions keep
the last N+1 samples of m channels in a ring (:func:`jacobi_ring` designs it,
:func:`jacobi_initial_state`, :func:`jacobi_step`, :func:`jacobi_outputs`,
:func:`jacobi_valid` take state and return new state: the Drake block's discrete
state) and give the same numbers as the batch, to rounding.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.jacobi_design import JacobiFilter, _read_only

__all__ = [
    "JacobiRing",
    "jacobi_apply",
    "jacobi_batch",
    "jacobi_history",
    "jacobi_initial_state",
    "jacobi_outputs",
    "jacobi_ring",
    "jacobi_step",
    "jacobi_valid",
]


def jacobi_apply(taps: Any, newest_first: Any) -> np.ndarray:
    """Applies taps to a buffer of samples ordered newest first.

    ``y[..., c] = Σ_j taps[..., j] newest_first[j, c]``. ``taps`` is (L,) or
    (K, L); ``newest_first`` is (L,) or (L, m). Returns shape ``taps.shape[:-1] +
    newest_first.shape[1:]``.
    """
    taps = _validate.array("jacobi_apply", "taps", taps)
    samples = _validate.array(
        "jacobi_apply", "newest_first", newest_first, finite=False
    )
    if taps.ndim not in (1, 2) or samples.ndim not in (1, 2):
        _validate.fail(
            "jacobi_apply",
            f"taps must be (L,) or (K, L) and newest_first (L,) or (L, m); got "
            f"shapes {taps.shape} and {samples.shape}.",
        )
    if samples.shape[:1] != taps.shape[-1:]:
        _validate.fail(
            "jacobi_apply",
            f"newest_first must have {taps.shape[-1]} rows (one per tap); "
            f"got shape {samples.shape}.",
        )
    return np.tensordot(taps, samples, axes=([-1], [0]))


def jacobi_batch(filt: JacobiFilter, samples: Any) -> np.ndarray:
    """Applies a filter causally to a whole array (log replay, benchmarks).

    ``y[n] = Σ_{j=0..min(n, N)} taps[j] x[n-j]``: samples before the first are
    zero, which is exactly the transient of :func:`jacobi_step` from
    :func:`jacobi_initial_state` (and of the Drake block). ``y[n]`` estimates
    ``x^(k)(t_n - delay)`` once n >= N. ``samples`` is (T,) or (T, m) along time.
    """
    _validate.instance(
        "jacobi_batch", "filt", filt, JacobiFilter, "a JacobiFilter (jacobi_filter)"
    )
    samples = _validate.array("jacobi_batch", "samples", samples)
    if samples.ndim not in (1, 2):
        _validate.fail(
            "jacobi_batch", f"samples must be 1-D or 2-D (T, m); got {samples.shape}."
        )
    # Direct causal convolution in numpy (the same sums as scipy.signal.lfilter
    # with a = [1], to rounding) without importing scipy.signal (~1.5 s at start-up,
    # most of a command-line replay).
    count = samples.shape[0]
    if samples.ndim == 1:
        return np.convolve(samples, filt.taps)[:count]
    out = np.empty_like(samples)
    for column in range(samples.shape[1]):
        out[:, column] = np.convolve(samples[:, column], filt.taps)[:count]
    return out


@dataclass(frozen=True, eq=False)
class JacobiRing:
    """Design of the streaming ring buffer for a bank of filters (immutable).

    State layout (float64, size ``num_taps·num_signals + 2``)::

        [ buffer (num_taps slots × num_signals, slot-major) | head | count ]

    ``head`` is the slot of the newest sample and ``count`` the number of samples
    pushed (saturating at num_taps). ``kernel`` is the doubled age-reversed kernel
    (K × (2L-1)), ``kernel[:, L-1-head : 2L-1-head] @ buffer`` is the FIR without
    rolling the buffer.

    Attributes:
        filters: The filters, one output row each (same window and time step).
        num_signals: Number of channels m.
        kernel: Read-only doubled kernel (K × (2L-1)).
    """

    filters: tuple[JacobiFilter, ...]
    num_signals: int
    kernel: np.ndarray

    @property
    def num_taps(self) -> int:
        """L = N + 1 slots of the ring."""
        return self.filters[0].num_taps

    @property
    def state_size(self) -> int:
        """Length of the flat state vector."""
        return self.num_taps * self.num_signals + 2


def jacobi_ring(filters: Any, num_signals: int) -> JacobiRing:
    """Designs the ring buffer that streams ``filters`` over ``num_signals`` channels.

    Args:
        filters: A :class:`JacobiFilter` or a sequence of them sharing one window
            and time step (e.g. from :func:`jacobi_filters`).
        num_signals: Number of channels m >= 1.
    """
    owner = "jacobi_ring"
    if isinstance(filters, JacobiFilter):
        filters = (filters,)
    filters = tuple(filters)
    if not filters or not all(isinstance(f, JacobiFilter) for f in filters):
        raise TypeError(
            f"{owner}: filters must be JacobiFilter objects; got {filters!r}."
        )
    num_signals = _validate.integer(owner, "num_signals", num_signals, minimum=1)
    if len({(f.num_taps, f.time_step) for f in filters}) != 1:
        _validate.fail(owner, "filters must share one window and time_step.")
    reversed_taps = np.stack([f.taps[::-1] for f in filters])
    kernel = np.concatenate([reversed_taps, reversed_taps[:, :-1]], axis=1)
    return JacobiRing(
        filters=filters, num_signals=num_signals, kernel=_read_only(kernel)
    )


def jacobi_initial_state(ring: JacobiRing) -> np.ndarray:
    """Empty ring: zero buffer, ``head = L-1`` (first sample to slot 0), count 0."""
    _check_ring("jacobi_initial_state", ring)
    state = np.zeros(ring.state_size)
    state[-2] = ring.num_taps - 1
    return state


def jacobi_step(
    ring: JacobiRing, state: np.ndarray, sample: Any, *, out: np.ndarray | None = None
) -> np.ndarray:
    """Pushes one sample (m,) into the ring; returns the new state.

    ``head ← (head+1) mod L``, ``buffer[head] ← sample``, ``count ← min(count+1, L)``.
    By default ``state`` is left untouched and a new array is returned; pass
    ``out`` (which may be ``state`` itself) to write in place, as the Drake block
    does with its mutable discrete state.
    """
    _check_ring("jacobi_step", ring, state)
    length, m = ring.num_taps, ring.num_signals
    if out is None:
        out = np.array(state, dtype=float)
    elif out is not state:
        out[:] = state
    head = (int(out[-2]) + 1) % length
    out[head * m : (head + 1) * m] = sample
    out[-2] = head
    out[-1] = min(out[-1] + 1.0, float(length))
    return out


def jacobi_outputs(
    ring: JacobiRing, state: np.ndarray, index: int | None = None
) -> np.ndarray:
    """The filters applied to the samples in the ring.

    ``y[f, c] = Σ_j taps_f[j] x_{n-j, c}`` (zeros for samples not yet pushed).
    Returns (K, m), or (m,) for one filter when ``index`` is given. Refers to
    ``t_n - delay`` where ``t_n`` is the time of the newest sample.
    """
    _check_ring("jacobi_outputs", ring, state)
    length, m = ring.num_taps, ring.num_signals
    head = int(state[-2])
    buffer = state[: length * m].reshape(length, m)
    start = length - 1 - head
    if index is None:
        return ring.kernel[:, start : start + length] @ buffer
    return ring.kernel[index, start : start + length] @ buffer


def jacobi_history(ring: JacobiRing, state: np.ndarray) -> np.ndarray:
    """The ring's samples in time order, oldest first: (L, m).

    Row L-1 is the newest sample; samples not yet pushed are zeros (the rows
    before the first sample), as in :func:`jacobi_batch`.
    """
    length, m = ring.num_taps, ring.num_signals
    head = int(state[-2])
    buffer = state[: length * m].reshape(length, m)
    return np.roll(buffer, length - 1 - head, axis=0)


def jacobi_valid(ring: JacobiRing, state: np.ndarray) -> bool:
    """True once the ring holds L = N+1 real samples, all of them finite.

    Until then the transient is not over; a NaN or inf sample makes the outputs
    non-finite for the L samples it stays in the ring (not valid then).
    """
    _check_ring("jacobi_valid", ring, state)
    return bool(state[-1] >= ring.num_taps) and bool(np.isfinite(state[:-2]).all())


def _check_ring(owner: str, ring: Any, state: Any = None) -> None:
    """TypeError/ValueError unless ``ring`` is a JacobiRing and ``state`` its state."""
    _validate.instance(owner, "ring", ring, JacobiRing, "a JacobiRing (jacobi_ring)")
    if state is not None and np.shape(state) != (ring.state_size,):
        _validate.fail(
            owner,
            f"state must have shape ({ring.state_size},) (jacobi_initial_state); "
            f"got {np.shape(state)}.",
        )
