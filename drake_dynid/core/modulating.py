r"""Fourier modulating functions and their sliding integrals (MATH.md §3).

Modulating functions turn a differential equation into algebraic equations without
differentiating the signals. Over the sliding window ``[t - T, t]`` with the
window-relative time ``s = v - (t - T) ∈ [0, T]`` and ``ω0 = 2π/T`` [rad/s], the
Fourier modulating function of order ``k`` and (real) index ``ℓ`` is::

    g_ℓ(s) = (1/T) e^{-jℓω0 s} (e^{-jω0 s} - 1)^k
           = (1/T) Σ_{i=0..k} binom(k, i) (-1)^{k-i} e^{-j(ℓ+i)ω0 s}          [1/s]

It satisfies ``g^{(r)}(0) = g^{(r)}(T) = 0`` for ``r < k`` (for any real ``ℓ``), so
integrating by parts moves up to ``k`` time derivatives from the signal onto ``g``.
Its derivatives are the same combination of exponentials::

    g_ℓ^{(r)}(s) = (1/T) Σ_i binom(k, i) (-1)^{k-i} (-j(ℓ+i)ω0)^r e^{-j(ℓ+i)ω0 s}

so every modulated integral ``M_{g^(r)}(f) = ∫_{t-T}^{t} g^{(r)}(s) f(v) dv`` is a
fixed combination of the **sliding Fourier integrals**::

    F_ν(f)(t) = ∫_{t-T}^{t} e^{-jνω0 s} f(v) dv,      ν ∈ {ℓ + i},             [f·s]

computed once per unique ``ν`` for all channels. Quadrature everywhere: the
trapezoid rule on the samples ``f_0 … f_N`` of the window (``N = T/h``, sample ``i``
at ``s = i·h``), both in the direct reference and in the sliding update.

Sliding update (cost O(K × c) per sample, independent of T). With the absolute
sample index ``n`` (sample ``n`` at ``t_n = n·h``) and the absolute phase
``w_ν(n) = e^{-j2πνn/N}`` the state keeps the plain sums
``P_ν = Σ_{i in window} w_ν(i) f_i`` (add the newest sample, subtract the one leaving
the window; exact for any real ``ν``), and the window-relative trapezoid integral
is one rotation away::

    F_ν = h [ conj(w_ν(n-N)) P_ν - ½ f_{n-N} - ½ e^{-j2πν} f_n ]

The phase is computed from the integer index as ``νa + νb/N (mod 1)`` with
``n = aN + b``, so it does not drift over hours. Round-off in the running sums is
removed by a periodic resynchronisation (recomputing ``P`` from the stored window).

Choice of ``ℓ``: only integer ``ν`` are mutually orthogonal over the window; the
paper's fine grid ``ℓ = 0:0.05:10`` (:func:`paper_frequencies`) adds many nearly
dependent rows (harmless for least squares, but not new information). An integer
set up to the excitation bandwidth (:func:`default_frequencies`) gives independent
rows at ``ν/T`` Hz; the highest frequency seen is ``(ℓ_max + k)/T`` Hz.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.ring import ChunkRing

__all__ = [
    "FourierBank",
    "SlidingState",
    "assemble_equations",
    "default_frequencies",
    "direct_fourier_integrals",
    "fourier_bank",
    "is_full",
    "modulated_integrals",
    "num_channels",
    "num_equation_rows",
    "pack_rows",
    "paper_frequencies",
    "row_frequencies",
    "sliding_fourier_integrals",
    "sliding_init",
    "sliding_push",
    "sliding_push_many",
    "sliding_resync",
    "unpack_rows",
    "window_valid",
]

_DECIMALS = 12  # ℓ and ν are rounded to 1e-12 so that ℓ + i matches a listed ℓ'
_BLOCK = 2048  # samples per block in the direct sums (bounds memory to K × _BLOCK)
_TABLE = 256  # columns of FourierBank.phase_table


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class FourierBank:
    """Immutable design of a Fourier modulating-function bank (see fourier_bank).

    Attributes:
        window: sliding window length T [s].
        time_step: period h [s] of the samples entering the bank (may be a decimated
            rate of the robot signals).
        order: modulating order k (>= 1).
        ell: (L,) indices ℓ of the modulating functions g_ℓ (any reals, rounded to
            1e-12).
        nu: (K,) sorted unique frequencies ν = ℓ + i, i = 0..k, in units of ω0.
        num_samples: samples in a full window, N + 1 = T/h + 1.
        index: (L, k+1) position in ``nu`` of ν = ℓ + i.
        weights: (k+1, L, k+1) complex; ``M_{g^(r)}[ℓ] = Σ_i weights[r, ℓ, i] ·
            F[index[ℓ, i]]`` [1/s^(r+1)], i.e.
            ``(1/T) binom(k, i) (-1)^{k-i} (-j ν ω0)^r``.
        row_mask: (L, 2) bool, whether the real (column 0) and imaginary (column 1)
            parts of g_ℓ are not identically zero. Only ℓ = -k/2 has an identically
            zero part (the real part for odd k, the imaginary part for even k).
        phase_step: (K,) complex ``e^{-j2πν/N}``, one sample of absolute phase.
        phase_leave: (K,) complex ``e^{+j2πν(N+1)/N}``: ``w_ν(n-N-1) = w_ν(n) ·
            phase_leave``.
        phase_end: (K,) complex ``e^{-j2πν}``, the window-relative phase at s = T.
        phase_table: (K, 256) complex ``e^{-j2πνk/N}``, k = 0..255: the phases of a
            run of consecutive samples are ``w_ν(first) · phase_table`` (one
            complex product per entry instead of an exponential).
    """

    window: float
    time_step: float
    order: int
    ell: np.ndarray
    nu: np.ndarray
    num_samples: int
    index: np.ndarray
    weights: np.ndarray
    row_mask: np.ndarray
    phase_step: np.ndarray
    phase_leave: np.ndarray
    phase_end: np.ndarray
    phase_table: np.ndarray

    @property
    def num_intervals(self) -> int:
        """N = T/h, the number of sample intervals in the window."""
        return self.num_samples - 1

    @property
    def omega0(self) -> float:
        """Fundamental ω0 = 2π/T [rad/s]."""
        return 2.0 * math.pi / self.window

    @property
    def num_functions(self) -> int:
        """L, the number of modulating functions."""
        return len(self.ell)

    @property
    def num_frequencies(self) -> int:
        """K, the number of sliding Fourier integrals."""
        return len(self.nu)

    def num_rows(self, m: int) -> int:
        """Rows of :func:`assemble_equations` for ``m`` equations per sample."""
        return int(np.count_nonzero(self.row_mask)) * m

    def coefficient_matrix(self, derivative: int = 0) -> np.ndarray:
        """Dense (L, K) complex matrix C_r with ``M_{g^(r)} = C_r @ F``."""
        derivative = _derivative(self, derivative)
        out = np.zeros((self.num_functions, self.num_frequencies), dtype=complex)
        rows = np.repeat(np.arange(self.num_functions), self.order + 1)
        np.add.at(out, (rows, self.index.ravel()), self.weights[derivative].ravel())
        return out


def num_equation_rows(bank: FourierBank, m: int) -> int:
    """Rows of :func:`assemble_equations`: ``2·L·m`` minus identically zero rows."""
    return bank.num_rows(v.integer("num_equation_rows", "m", m, minimum=1))


def fourier_bank(
    window: float, time_step: float, *, order: int = 1, ell: Any
) -> FourierBank:
    """Designs a bank of Fourier modulating functions g_ℓ, ℓ ∈ ``ell`` (MATH.md §3).

    ``g_ℓ(s) = (1/T) Σ_{i=0..k} binom(k,i) (-1)^{k-i} e^{-j(ℓ+i)ω0 s}``, ω0 = 2π/T.

    Args:
        window: sliding window T [s], a multiple of ``time_step``.
        time_step: sample period h [s] of the samples fed to the bank.
        order: modulating order k >= 1 (derivatives up to k are available).
        ell: 1-D sequence of distinct real indices ℓ (see :func:`default_frequencies`
            and :func:`paper_frequencies`).

    Returns:
        The immutable :class:`FourierBank`.
    """
    owner = "fourier_bank"
    window = v.positive(owner, "window", window, "s")
    time_step = v.positive(owner, "time_step", time_step, "s")
    intervals = v.multiple_of(owner, "window", window, "time_step", time_step)
    order = v.integer(owner, "order", order, minimum=1)
    ell_in = v.array(owner, "ell", ell)
    if ell_in.ndim != 1 or ell_in.size == 0:
        v.fail(owner, f"ell must be a non-empty 1-D array; got shape {ell_in.shape}.")
    ell_r = np.round(ell_in, _DECIMALS)
    if np.unique(ell_r).size != ell_r.size:
        v.fail(owner, "ell must not repeat a value (after rounding to 1e-12).")
    nu_all = np.round(ell_r[:, None] + np.arange(order + 1), _DECIMALS)
    nu, index = np.unique(nu_all, return_inverse=True)
    index = index.reshape(nu_all.shape)
    binomial = np.array(
        [math.comb(order, i) * (-1) ** (order - i) for i in range(order + 1)],
        dtype=float,
    )
    omega0 = 2.0 * math.pi / window
    weights = np.stack(
        [binomial / window * (-1j * nu[index] * omega0) ** r for r in range(order + 1)]
    )
    # g_ℓ = (1/T) e^{-j(ℓ+k/2)ω0 s} (-2j sin(ω0 s/2))^k: one part vanishes only
    # at ℓ = -k/2 (then g is real for even k, imaginary for odd k).
    row_mask = np.ones((len(ell_r), 2), dtype=bool)
    centre = np.abs(ell_r + order / 2.0) < 10.0**-_DECIMALS
    row_mask[centre, 0 if order % 2 else 1] = False
    return FourierBank(
        window=window,
        time_step=time_step,
        order=order,
        ell=_frozen(ell_r),
        nu=_frozen(nu),
        num_samples=intervals + 1,
        index=_frozen(index),
        weights=_frozen(weights),
        row_mask=_frozen(row_mask),
        phase_step=_frozen(np.exp(-2j * np.pi * nu / intervals)),
        phase_leave=_frozen(np.exp(2j * np.pi * (np.mod(nu, 1.0) + nu / intervals))),
        phase_end=_frozen(np.exp(-2j * np.pi * np.mod(nu, 1.0))),
        phase_table=_frozen(
            np.exp(-2j * np.pi * np.multiply.outer(nu, np.arange(_TABLE) / intervals))
        ),
    )


def paper_frequencies() -> np.ndarray:
    """The paper's set ℓ = 0:0.05:10 (Fig. 3), 201 values (K = 221 for k = 1)."""
    return np.round(0.05 * np.arange(201), _DECIMALS)


def default_frequencies(
    window: float, bandwidth_hz: float, *, order: int = 1, spacing: float = 1.0
) -> np.ndarray:
    """Indices ℓ = 0, spacing, 2·spacing, ... covering an excitation bandwidth.

    The bank sees the frequencies ν/T [Hz], ν = ℓ + i (i = 0..k). This returns every
    ℓ = j·spacing >= 0 with ``(ℓ + k)/T <= bandwidth_hz``. ``spacing = 1`` gives the
    integer set, whose exponentials are orthogonal over the window (independent
    rows); a smaller spacing (the paper: 0.05) adds nearly dependent rows.

    Args:
        window: window T [s].
        bandwidth_hz: highest frequency [Hz] carrying excitation energy.
        order: modulating order k.
        spacing: step of ℓ (> 0).
    """
    owner = "default_frequencies"
    window = v.positive(owner, "window", window, "s")
    bandwidth_hz = v.positive(owner, "bandwidth_hz", bandwidth_hz, "Hz")
    order = v.integer(owner, "order", order, minimum=1)
    spacing = v.positive(owner, "spacing", spacing)
    top = bandwidth_hz * window - order
    if top < 0:
        v.fail(
            owner,
            f"bandwidth_hz must be >= order/window = {order / window:g} [Hz]; "
            f"got {bandwidth_hz:g}.",
        )
    count = math.floor(top / spacing + 1e-9) + 1
    return np.round(spacing * np.arange(count), _DECIMALS)


def _derivative(bank: FourierBank, derivative: Any) -> int:
    derivative = v.integer("modulated_integrals", "derivative", derivative, minimum=0)
    if derivative > bank.order:
        v.fail(
            "modulated_integrals",
            f"derivative must be <= order {bank.order}; got {derivative}.",
        )
    return derivative


def _integrals(owner: str, bank: FourierBank, F: Any) -> np.ndarray:
    F = np.asarray(F)
    if F.ndim not in (1, 2) or F.shape[0] != bank.num_frequencies:
        v.fail(
            owner,
            f"F must have shape ({bank.num_frequencies}, channels); got {F.shape}.",
        )
    return F


def _samples(
    owner: str, bank: FourierBank, samples: Any, rows: int | None, finite: bool = True
) -> Any:
    out = v.array(owner, "samples", samples, finite=finite)
    if out.ndim == 1:
        out = out[:, None]
    if out.ndim != 2 or (rows is not None and out.shape[0] != rows):
        want = "any" if rows is None else str(rows)
        v.fail(owner, f"samples must have shape ({want}, channels); got {out.shape}.")
    return out


def direct_fourier_integrals(bank: FourierBank, samples: Any) -> np.ndarray:
    """Reference sliding Fourier integrals of one full window, by trapezoid quadrature.

    ``F_ν = h Σ_{i=0..N} c_i e^{-j2πνi/N} f_i`` with ``c_0 = c_N = ½``, else 1,
    i.e. ``∫_0^T e^{-jνω0 s} f ds`` with the window-relative phase.

    Args:
        bank: the design.
        samples: (N+1, c) or (N+1,) window samples [unit of f], oldest first.

    Returns:
        (K, c) complex [unit of f · s].
    """
    x = _samples("direct_fourier_integrals", bank, samples, bank.num_samples)
    intervals = bank.num_intervals
    weights = np.ones(bank.num_samples)
    weights[[0, -1]] = 0.5
    out = np.zeros((bank.num_frequencies, x.shape[1]), dtype=complex)
    for start in range(0, bank.num_samples, _BLOCK):
        i = np.arange(start, min(start + _BLOCK, bank.num_samples))
        phase = np.exp(-2j * np.pi * np.multiply.outer(bank.nu, i / intervals))
        out += phase @ (weights[i, None] * x[i])
    return out * bank.time_step


def modulated_integrals(bank: FourierBank, F: Any, derivative: int = 0) -> np.ndarray:
    """Modulated integrals ``M_{g^(r)}(f) = ∫_{t-T}^{t} g_ℓ^{(r)}(s) f(v) dv``, all ℓ.

    ``M_{g^(r)}[ℓ] = (1/T) Σ_i binom(k,i) (-1)^{k-i} (-j(ℓ+i)ω0)^r F_{ℓ+i}``.

    Args:
        bank: the design.
        F: (K, c) or (K,) sliding Fourier integrals [unit of f · s].
        derivative: r in 0..k.

    Returns:
        (L, c) or (L,) complex [unit of f · s^-r].
    """
    derivative = _derivative(bank, derivative)
    F = _integrals("modulated_integrals", bank, F)
    weights = bank.weights[derivative]
    if F.ndim == 2:
        weights = weights[:, :, None]
    out = weights[:, 0] * F[bank.index[:, 0]]
    for i in range(1, bank.order + 1):
        out += weights[:, i] * F[bank.index[:, i]]
    return out


# -- equations of the model-row contract (docs/CONVENTIONS.md §3) ----------------------


def num_channels(m: int, p: int) -> int:
    """Channels per sample of :func:`pack_rows`: ``2·m·p + m``."""
    return 2 * m * p + m


def pack_rows(D: Any, G: Any, y: Any) -> np.ndarray:
    """Flattens the model rows of one sample (or a batch) into one channel vector.

    Channel layout (length ``2·m·p + m``): ``[D[0,:], …, D[m-1,:], G[0,:], …,
    G[m-1,:], y[0], …, y[m-1]]``, i.e. ``D`` row-major, then ``G`` row-major, then
    ``y``. Leading batch axes are kept: D, G (..., m, p) and y (..., m) give
    (..., 2mp + m).
    """
    owner = "pack_rows"
    D = v.array(owner, "D", D, finite=False)
    G = v.array(owner, "G", G, finite=False)
    y = v.array(owner, "y", y, finite=False)
    if D.ndim < 2 or G.shape != D.shape or y.shape != D.shape[:-1]:
        v.fail(
            owner,
            f"D and G must have shape (..., m, p) and y (..., m); got D {D.shape}, "
            f"G {G.shape}, y {y.shape}.",
        )
    lead = D.shape[:-2]
    return np.concatenate(
        [D.reshape(*lead, -1), G.reshape(*lead, -1), y.reshape(*lead, -1)], axis=-1
    )


def unpack_rows(x: Any, m: int, p: int) -> tuple[Any, Any, Any]:
    """Inverse of :func:`pack_rows`: (..., 2mp + m) -> D (..., m, p), G, y (..., m)."""
    x = np.asarray(x)
    mp = m * p
    if x.shape[-1] != num_channels(m, p):
        v.fail(
            "unpack_rows", f"x must have {num_channels(m, p)} channels; got {x.shape}."
        )
    lead = x.shape[:-1]
    return (
        x[..., :mp].reshape(*lead, m, p),
        x[..., mp : 2 * mp].reshape(*lead, m, p),
        x[..., 2 * mp :],
    )


def assemble_equations(
    bank: FourierBank, F: Any, m: int, p: int
) -> tuple[np.ndarray, np.ndarray]:
    """Stacks the modulated model equations into a real system A θ = B.

    For every ℓ and every equation j < m of the model-row contract
    (``docs/CONVENTIONS.md`` §3)::

        -M_ġ(D_j)·θ + M_g(G_j)·θ = M_g(y_j)

    whose real and imaginary parts give two real rows.

    Row order: ℓ-major, then the part (real, imaginary), then the equation j, i.e.
    the row ``(ℓ·2 + part)·m + j`` of the full ``2·L·m`` stack; rows of identically
    zero parts (``bank.row_mask``, only at ℓ = -k/2) are dropped, so A has
    ``bank.num_rows(m)`` rows (a constant of the design).

    Args:
        bank: the design.
        F: (K, 2mp + m) sliding Fourier integrals of :func:`pack_rows` channels.
        m: equations per sample.
        p: parameters.

    Returns:
        A (rows, p) and B (rows,), real, in [unit of y · s].
    """
    owner = "assemble_equations"
    m = v.integer(owner, "m", m, minimum=1)
    p = v.integer(owner, "p", p, minimum=1)
    F = _integrals(owner, bank, F)
    if F.ndim != 2 or F.shape[1] != num_channels(m, p):
        v.fail(
            owner,
            f"F must have shape ({bank.num_frequencies}, {num_channels(m, p)}) "
            f"for m={m}, p={p}; got {F.shape}.",
        )
    mp = m * p
    L = bank.num_functions
    d_part = modulated_integrals(bank, F[:, :mp], derivative=1).reshape(L, m, p)
    g_part = modulated_integrals(bank, F[:, mp:], derivative=0)
    lhs = g_part[:, :mp].reshape(L, m, p) - d_part
    rhs = g_part[:, mp:]
    A = np.stack([lhs.real, lhs.imag], axis=1).reshape(2 * L * m, p)
    B = np.stack([rhs.real, rhs.imag], axis=1).reshape(2 * L * m)
    if bank.row_mask.all():
        return A, B
    keep = np.repeat(bank.row_mask.ravel(), m)
    return A[keep], B[keep]


def row_frequencies(bank: FourierBank, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Frequency index ν and equation j of every row of :func:`assemble_equations`.

    ``ν = |ℓ + (k + 1)/2|`` for both parts of g_ℓ (its lines are at ℓ + i, i = 0..k,
    centred on ℓ + k/2; the half-step up was the measured best on the 2R benchmark):
    the derivative ġ_ℓ, which multiplies the velocity estimate in every row, has a
    magnitude ∝ ν/T. Used by the frequency-weighted solve
    (:func:`drake_dynid.core.lsq.solve_frequency_weighted_least_squares`), one
    noise group per equation j.

    Returns:
        ``(frequency, group)``, each (``bank.num_rows(m)``,): float ν and int j.
    """
    m = v.integer("row_frequencies", "m", m, minimum=1)
    L = bank.num_functions
    frequency = np.repeat(np.abs(bank.ell + (bank.order + 1) / 2.0), 2 * m)
    group = np.tile(np.arange(m), 2 * L)
    keep = np.repeat(bank.row_mask.ravel(), m)
    return frequency[keep], group[keep]


# -- sliding state ---------------------------------------------------------------------

_PHASE_REFRESH = 1024  # recompute the absolute phase from the index every this many


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

    @property
    def num_channels(self) -> int:
        """c, the channels per sample."""
        return self.ring.channels

    def __deepcopy__(self, memo: dict[int, Any]) -> SlidingState:
        out = SlidingState(
            ring=copy.deepcopy(self.ring, memo),
            sums=self.sums,
            phase=self.phase,
            count=self.count,
            last_invalid=self.last_invalid,
            since_resync=self.since_resync,
            resync_every=self.resync_every,
        )
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
        stop = min(start + _TABLE, count)
        np.multiply(
            origins[:, run, None],
            bank.phase_table[:, : stop - start],
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
    )


def is_full(state: SlidingState) -> bool:
    """True once the window holds N + 1 samples."""
    return state.ring.is_full


def window_valid(state: SlidingState) -> bool:
    """True when the window is full and holds no invalid sample.

    An invalid sample (pushed with ``valid=False`` or with a non-finite channel) is
    stored as zeros and keeps the window invalid until it has left it, N + 1
    pushes later.
    """
    return state.ring.is_full and state.last_invalid < state.count - len(state.ring)


def sliding_resync(bank: FourierBank, state: SlidingState) -> SlidingState:
    """Recomputes the running sums and the phase from the stored window.

    Removes accumulated round-off; costs K·(N+1)·c complex multiply-adds.
    """
    window = state.ring.window()
    sums = _absolute_sums(bank, window, state.count - len(window))
    return SlidingState(
        ring=state.ring,
        sums=_frozen(sums),
        phase=_frozen(_phases(bank, state.count)),
        count=state.count,
        last_invalid=state.last_invalid,
        since_resync=0,
        resync_every=state.resync_every,
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
    new = SlidingState(
        ring=ring.push(x),
        sums=_frozen(sums),
        phase=_frozen(next_phase),
        count=n + 1,
        last_invalid=last_invalid,
        since_resync=state.since_resync + 1,
        resync_every=state.resync_every,
    )
    if state.resync_every and new.since_resync >= state.resync_every:
        return sliding_resync(bank, new)
    return new


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
    x = _samples(owner, bank, samples, None, finite=False)
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
    if count >= bank.num_samples or (
        state.resync_every and since >= state.resync_every
    ):
        new = SlidingState(
            ring,
            state.sums,
            state.phase,
            new_count,
            last_invalid,
            since,
            state.resync_every,
        )
        return sliding_resync(bank, new)
    sums = _absolute_sums(bank, x, state.count)
    leaving = max(0, state.ring.size + count - bank.num_samples)
    if leaving:
        first = state.count - state.ring.size
        sums -= _absolute_sums(bank, state.ring.head(leaving), first)
    sums += state.sums
    return SlidingState(
        ring=ring,
        sums=_frozen(sums),
        phase=_frozen(_phases(bank, new_count)),
        count=new_count,
        last_invalid=last_invalid,
        since_resync=since,
        resync_every=state.resync_every,
    )


def sliding_fourier_integrals(bank: FourierBank, state: SlidingState) -> np.ndarray:
    """Window-relative sliding Fourier integrals F (K, c) of the current window.

    ``F_ν = h [conj(w_ν(n-N)) P_ν - ½ f_{n-N} - ½ e^{-j2πν} f_n]`` with n the newest
    index: equal to :func:`direct_fourier_integrals` on the window. Before the
    window is full the missing older samples count as zeros.
    """
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
