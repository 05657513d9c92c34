"""Butterworth low-pass sections and their filtering in numpy (docs/MATH.md §2, §5).

The standstill dead zone (``core.standstill``) measures the velocity noise of the
off-line equations with two zero-phase Butterworth low-passes and the automatic
cutoff (``core.idim_auto``) with a Welch spectrum. ``dynid identify`` measures
the dead zone by default, and ``scipy.signal`` takes 0.4-0.7 s to import on the
2-core machine, more than the rest of a 60 s 7-DOF identification's start-up:
this module gives the same three tools in numpy.

* :func:`butter_lowpass` equals ``scipy.signal.butter(N, f_c, fs=fs,
  output="sos")`` for even N (analogue prototype, pre-warped bilinear transform,
  sections ordered as ``zpk2sos``'s "nearest" pairing: poles nearest the unit
  circle last, the gain in the first section).
* :func:`sosfilt` equals ``scipy.signal.sosfilt(sos, x, axis=0, zi=zi)`` to
  round-off. The cascade is one state-space system (the sections' transposed
  direct-form-II states), filtered P samples at a time: within a block
  ``y = T x + O s`` (T the P×P Toeplitz matrix of the impulse response, O the
  free response of the state), between blocks ``s ← A^P s + E x``: one matrix
  product per block of every column and a loop over blocks instead of samples.
* :func:`sosfilt_zi` equals ``scipy.signal.sosfilt_zi``: the steady state
  ``(I - A)⁻¹ B`` for a unit step.
* :func:`welch` equals ``scipy.signal.welch`` with a periodic Blackman-Harris
  window, half overlap and linear detrending.
* :func:`butter_power` is the squared magnitude of :func:`butter_lowpass`'s
  response in closed form, and :func:`half_circle_mean` the mean over [0, π] of
  a response-weighted density: the noise gains of the dead zone's velocity
  (``core.standstill.velocity_noise_gain``) and of the torque noise's half band
  (``core.excitation.half_band_share``).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check

__all__ = [
    "butter_lowpass",
    "butter_power",
    "half_circle_mean",
    "sosfilt",
    "sosfilt_zi",
    "welch",
]

#: Samples per block of :func:`sosfilt` (the matrix products against the loop).
BLOCK = 64


def butter_lowpass(order: int, cutoff_hz: float, fs: float) -> np.ndarray:
    """Second-order sections (order/2, 6) of the digital Butterworth low-pass.

    Analogue poles ``-exp(iπ(2k - N + 1)/(2N))``, scaled to the pre-warped
    ``4 tan(π f_c/fs)`` (``fs`` normalised to 2) and mapped by the bilinear
    transform, zeros at z = -1, unit gain at DC.

    Args:
        order: N, even, >= 2.
        cutoff_hz: f_c in (0, fs/2) [Hz].
        fs: the sampling rate [Hz].
    """
    owner = "butter_lowpass"
    order = check.integer(owner, "order", order, minimum=2)
    if order % 2:
        check.fail(owner, f"order must be even; got {order}.")
    fs = check.positive(owner, "fs", fs, "Hz")
    cutoff_hz = check.positive(owner, "cutoff_hz", cutoff_hz, "Hz")
    if not cutoff_hz < fs / 2.0:
        check.fail(
            owner, f"cutoff_hz must be < fs/2 = {fs / 2:g} Hz; got {cutoff_hz:g}."
        )
    warped = 4.0 * math.tan(math.pi * cutoff_hz / fs)
    analog = warped * -np.exp(
        1j * np.pi * np.arange(-order + 1, order, 2) / (2 * order)
    )
    poles = (4.0 + analog) / (4.0 - analog)
    gain = float(np.real(warped**order / np.prod(4.0 - analog)))
    upper = poles[poles.imag > 0]  # one of each conjugate pair
    upper = upper[np.argsort(np.abs(1.0 - np.abs(upper)), kind="stable")][::-1]
    sos = np.zeros((order // 2, 6))
    sos[:, :3] = [1.0, 2.0, 1.0]
    sos[:, 3] = 1.0
    sos[:, 4] = -2.0 * upper.real
    sos[:, 5] = np.abs(upper) ** 2
    sos[0, :3] *= gain
    return sos


def butter_power(w: np.ndarray, corner: float, order: int) -> np.ndarray:
    """|H(e^{iω})|² of the bilinear Butterworth low-pass at the angles ``w`` [rad].

    ``1 / (1 + (tan(ω/2) / corner)^(2N))`` with ``corner = tan(π f_c/fs)``: the
    pre-warped analogue Butterworth of :func:`butter_lowpass` at ω_a = tan(ω/2),
    exactly (``w`` in [0, π]).
    """
    return 1.0 / (1.0 + (np.tan(0.5 * w) / corner) ** (2 * order))


def half_circle_mean(f: np.ndarray, top: float) -> float:
    """(1/π) ∫_0^top f(ω) dω by Simpson's rule.

    Args:
        f: the integrand on the uniform grid ``np.linspace(0, top, len(f))``, an
            odd number of points (an even number of intervals).
        top: the grid's end [rad], at most π.
    """
    step = top / (len(f) - 1)
    simpson = f[0] + f[-1] + 4.0 * f[1:-1:2].sum() + 2.0 * f[2:-1:2].sum()
    return float(step / 3.0 * simpson / math.pi)


@functools.lru_cache(maxsize=32)
def _blocks(key: bytes, sections: int) -> tuple[np.ndarray, ...]:
    """(A^P, T, O, E, A, B) of the cascade ``np.frombuffer(key)`` for P = BLOCK."""
    sos = np.frombuffer(key).reshape(sections, 6)
    A = np.zeros((0, 0))
    B = np.zeros(0)
    C = np.zeros(0)
    D = 1.0
    for b0, b1, b2, a0, a1, a2 in sos:
        b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
        Ai = np.array([[-a1, 1.0], [-a2, 0.0]])
        Bi = np.array([b1 - a1 * b0, b2 - a2 * b0])
        Ci = np.array([1.0, 0.0])
        size = A.shape[0]
        A_new = np.zeros((size + 2, size + 2))
        A_new[:size, :size] = A
        A_new[size:, :size] = np.outer(Bi, C)
        A_new[size:, size:] = Ai
        A, B = A_new, np.concatenate([B, Bi * D])
        C, D = np.concatenate([b0 * C, Ci]), b0 * D
    n = A.shape[0]
    free = np.empty((BLOCK, n))  # C A^i
    row = C.copy()
    for i in range(BLOCK):
        free[i] = row
        row = row @ A
    impulse = np.concatenate([[D], free[: BLOCK - 1] @ B])
    lags = np.arange(BLOCK)[:, None] - np.arange(BLOCK)[None, :]
    toeplitz = np.where(lags >= 0, impulse[np.clip(lags, 0, None)], 0.0)
    entry = np.empty((n, BLOCK))  # A^(P-1-j) B
    column = B.copy()
    for j in range(BLOCK - 1, -1, -1):
        entry[:, j] = column
        column = A @ column
    power = np.linalg.matrix_power(A, BLOCK)
    out = (power, toeplitz, free, entry, A, B)
    for array in out:
        array.flags.writeable = False
    return out


def _system(sos: Any) -> tuple[np.ndarray, ...]:
    sos = np.ascontiguousarray(np.atleast_2d(np.asarray(sos, dtype=float)))
    if sos.ndim != 2 or sos.shape[1] != 6:
        check.fail("sosfilt", f"sos must have shape (sections, 6); got {sos.shape}.")
    return _blocks(sos.tobytes(), sos.shape[0])


def sosfilt_zi(sos: Any) -> np.ndarray:
    """(sections, 2) states of the cascade in steady state for a unit step."""
    sos = np.atleast_2d(np.asarray(sos, dtype=float))
    out = np.empty((sos.shape[0], 2))
    scale = 1.0  # the DC gain of the sections before
    for i, (b0, b1, b2, a0, a1, a2) in enumerate(sos):
        b0, b1, b2, a1, a2 = b0 / a0, b1 / a0, b2 / a0, a1 / a0, a2 / a0
        # Steady state of one section: (I - A_i) z = B_i, input ``scale``.
        matrix = np.array([[1.0 + a1, -1.0], [a2, 1.0]])
        out[i] = scale * np.linalg.solve(matrix, [b1 - a1 * b0, b2 - a2 * b0])
        scale *= (b0 + b1 + b2) / (1.0 + a1 + a2)
    return out


def sosfilt(sos: Any, x: Any, zi: Any) -> np.ndarray:
    """``scipy.signal.sosfilt(sos, x, axis=0, zi=zi)[0]`` by blocks (module doc).

    Args:
        sos: (S, 6) second-order sections.
        x: (L, c) signal, filtered along axis 0.
        zi: (S, 2, c) initial states (as ``sosfilt_zi(sos)[:, :, None] * x0``).

    Returns:
        (L, c) the filtered signal.
    """
    power, toeplitz, free, entry, _, _ = _system(sos)
    x = np.asarray(x, dtype=float)
    length, channels = x.shape
    state = np.asarray(zi, dtype=float).reshape(-1, channels)
    count = -(-length // BLOCK)
    blocks = np.zeros((count * BLOCK, channels))
    blocks[:length] = x
    blocks = blocks.reshape(count, BLOCK, channels)
    entering = entry @ blocks  # (count, n, c): each block's zero-state end state
    states = np.empty((count, state.shape[0], channels))
    for k in range(count):
        states[k] = state
        state = power @ state + entering[k]
    y = toeplitz @ blocks + free @ states
    return y.reshape(count * BLOCK, channels)[:length]


def welch(x: Any, fs: float, segment: int) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch density of the columns of ``x`` [unit²/Hz].

    The mean over segments of ``segment`` samples, half overlapping (step
    segment - segment // 2), each linearly detrended and windowed by the periodic
    4-term Blackman-Harris window, scaled by 1/(fs Σ w²) and doubled except at 0
    (and fs/2 for an even segment): ``scipy.signal.welch(x, fs, window=
    "blackmanharris", nperseg=segment, detrend="linear", axis=0)``.

    Returns:
        ``(f, S)``: (F,) frequencies [Hz] and (F, c) densities.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    step = segment - segment // 2
    count = (x.shape[0] - segment) // step + 1
    phase = 2.0 * np.pi * np.arange(segment) / segment
    window = (
        0.35875
        - 0.48829 * np.cos(phase)
        + 0.14128 * np.cos(2.0 * phase)
        - 0.01168 * np.cos(3.0 * phase)
    )
    design = np.ones((segment, 2))
    design[:, 0] = np.arange(segment)
    projector = np.linalg.pinv(design)  # the least-squares line of a segment
    total = np.zeros((segment // 2 + 1, x.shape[1]))
    for k in range(count):
        part = x[k * step : k * step + segment]
        part = part - design @ (projector @ part)
        spectrum = np.fft.rfft(window[:, None] * part, axis=0)
        total += spectrum.real**2 + spectrum.imag**2
    density = total / (count * fs * np.sum(window**2))
    density[1 : None if segment % 2 else -1] *= 2.0
    return np.fft.rfftfreq(segment, 1.0 / fs), density
