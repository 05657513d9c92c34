r"""Fourier modulating functions: the bank design and the choice of ℓ (docs/MATH.md §3).

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
fixed combination of the **sliding Fourier integrals** ``F_ν(f)`` at
``ν ∈ {ℓ + i}`` (``core.sliding``, ``core.equations``). :class:`FourierBank` is the
immutable design (the ν set and the combination weights); it satisfies the
:class:`~drake_dynid.core.bank.ModulatingBank` protocol.

Choice of ``ℓ`` (one rule, :func:`band_frequencies`): only integer ``ν`` are
mutually orthogonal over the window; the paper's fine grid ``ℓ = 0:0.05:10``
(:func:`paper_frequencies`) adds many nearly dependent rows (harmless for least
squares, but not new information). The default is the integer set up to the
excitation bandwidth B (:func:`default_frequencies`: rows at ``ν/T`` Hz, the
highest ``(ℓ_max + k)/T <= B``), extended with the next integers to at least
:data:`MIN_FUNCTIONS` functions when the window is too short for the band to hold
that many.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = [
    "MAX_FUNCTIONS",
    "MAX_ORDER",
    "MIN_FUNCTIONS",
    "FourierBank",
    "band_frequencies",
    "default_frequencies",
    "fourier_bank",
    "num_equation_rows",
    "paper_frequencies",
]

_DECIMALS = 12  # ℓ and ν are rounded to 1e-12 so that ℓ + i matches a listed ℓ'
_TABLE = 256  # columns of FourierBank.phase_table

#: Fewest modulating functions of the default ℓ set (:func:`band_frequencies`):
#: 2·8 rows per equation, enough for the power model's single equation with the
#: 2R arm's p = 8 parameters (benchmarks/bench_accuracy.py, T = 7 s).
MIN_FUNCTIONS = 8

#: Most modulating functions of one bank (a hard ceiling on the work per window:
#: the bank's state and every solve grow with it). The paper's set has 201.
MAX_FUNCTIONS = 500

#: Highest modulating order k (a hard ceiling; the paper uses k = 1 and 2).
MAX_ORDER = 8


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

    def row_correlation(self) -> np.ndarray:
        """Correlation of the rows of one equation under white noise (R1, R1).

        Row ``(ℓ, part)`` of an equation is ``part(∫_0^T g_ℓ(s) e(s) ds)`` (real
        or imaginary part, the rows of ``bank.row_mask`` in the order of
        ``core.equations.assemble_equations``). For white noise e the covariance of
        two rows is the inner product of their functions,
        ``Γ_ab = ∫_0^T part_a(g_a) part_b(g_b) ds``; this returns
        ``Γ_ab / √(Γ_aa Γ_bb)`` (dimensionless). Integer ℓ give nearly
        uncorrelated rows; the paper's dense ℓ = 0:0.05:10 gives strongly
        correlated ones (docs/MATH.md §4: the honest σ).
        """
        return _row_correlation(self)

    # -- the ModulatingBank protocol (core.bank): streaming and equations ---------

    def row_frequencies(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        """:func:`drake_dynid.core.equations.row_frequencies` of this bank."""
        from drake_dynid.core.equations import row_frequencies

        return row_frequencies(self, m)

    def row_functions(self, m: int) -> np.ndarray:
        """:func:`drake_dynid.core.equations.row_functions` of this bank."""
        from drake_dynid.core.equations import row_functions

        return row_functions(self, m)

    def init_state(self, num_channels: int) -> Any:
        """:func:`drake_dynid.core.sliding.sliding_init` of this bank."""
        from drake_dynid.core.sliding import sliding_init

        return sliding_init(self, num_channels)

    def push(self, state: Any, sample: Any, *, valid: bool = True) -> Any:
        """:func:`drake_dynid.core.sliding.sliding_push` of this bank."""
        from drake_dynid.core.sliding import sliding_push

        return sliding_push(self, state, sample, valid=valid)

    def push_many(self, state: Any, samples: Any, *, valid: Any = None) -> Any:
        """:func:`drake_dynid.core.sliding.sliding_push_many` of this bank."""
        from drake_dynid.core.sliding import sliding_push_many

        return sliding_push_many(self, state, samples, valid=valid)

    def window_valid(self, state: Any) -> bool:
        """:func:`drake_dynid.core.sliding.window_valid` of the state."""
        from drake_dynid.core.sliding import window_valid

        return window_valid(state)

    def equations(self, state: Any, m: int, p: int) -> tuple[np.ndarray, np.ndarray]:
        """The window's ``A``, ``B``: sliding integrals, then assembly.

        ``assemble_equations(bank, sliding_fourier_integrals(bank, state), m, p)``.
        """
        from drake_dynid.core.equations import assemble_equations
        from drake_dynid.core.sliding import sliding_fourier_integrals

        return assemble_equations(self, sliding_fourier_integrals(self, state), m, p)


def _window_integral(x: np.ndarray, window: float) -> np.ndarray:
    """``∫_0^T e^{-jxω0 s} ds = T (1 - e^{-j2πx})/(j2πx)`` (T at x = 0), ω0 = 2π/T."""
    small = np.abs(x) < 1e-12
    safe = np.where(small, 1.0, x)
    out = window * (1.0 - np.exp(-2j * np.pi * safe)) / (2j * np.pi * safe)
    return np.where(small, window + 0j, out)


def _row_correlation(bank: FourierBank) -> np.ndarray:
    """:meth:`FourierBank.row_correlation`, in closed form.

    With ``g_a = Σ_i w_ai e^{-jν_ai ω0 s}``, ``S = ∫ g_a g_b`` and
    ``H = ∫ g_a conj(g_b)``: Re·Re = (Re S + Re H)/2, Im·Im = (Re H - Re S)/2,
    Re_a·Im_b = (Im S - Im H)/2.
    """
    nu = bank.nu[bank.index]  # (L, k+1)
    w = bank.weights[0]  # (L, k+1)
    count = bank.num_functions
    S = np.zeros((count, count), dtype=complex)
    H = np.zeros((count, count), dtype=complex)
    for i in range(bank.order + 1):
        for k in range(bank.order + 1):
            a, b = nu[:, i, None], nu[None, :, k]
            weight = w[:, i, None] * w[None, :, k]
            S += weight * _window_integral(a + b, bank.window)
            H += (
                w[:, i, None]
                * np.conj(w[None, :, k])
                * _window_integral(a - b, bank.window)
            )
    blocks = np.empty((count, 2, count, 2))
    blocks[:, 0, :, 0] = 0.5 * (S.real + H.real)
    blocks[:, 1, :, 1] = 0.5 * (H.real - S.real)
    blocks[:, 0, :, 1] = 0.5 * (S.imag - H.imag)
    blocks[:, 1, :, 0] = blocks[:, 0, :, 1].T
    keep = bank.row_mask.ravel()
    gram = blocks.reshape(2 * count, 2 * count)[np.ix_(keep, keep)]
    scale = np.sqrt(np.clip(np.diag(gram), np.finfo(float).tiny, None))
    out = gram / np.outer(scale, scale)
    np.fill_diagonal(out, 1.0)
    return _frozen(out)


def num_equation_rows(bank: FourierBank, m: int) -> int:
    """Rows of :func:`assemble_equations`: ``2·L·m`` minus identically zero rows."""
    return bank.num_rows(v.integer("num_equation_rows", "m", m, minimum=1))


def fourier_bank(
    window: float, time_step: float, *, order: int = 1, ell: Any
) -> FourierBank:
    """Designs a bank of Fourier modulating functions g_ℓ, ℓ ∈ ``ell``.

    ``g_ℓ(s) = (1/T) Σ_{i=0..k} binom(k,i) (-1)^{k-i} e^{-j(ℓ+i)ω0 s}``, ω0 = 2π/T
    (docs/MATH.md §3).

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
    if order > MAX_ORDER:
        v.fail(owner, f"order must be <= {MAX_ORDER}; got {order}.")
    ell_in = v.array(owner, "ell", ell)
    if ell_in.ndim != 1 or ell_in.size == 0:
        v.fail(owner, f"ell must be a non-empty 1-D array; got shape {ell_in.shape}.")
    if ell_in.size > MAX_FUNCTIONS:
        v.fail(
            owner,
            f"ell must hold at most {MAX_FUNCTIONS} modulating functions; got "
            f"{ell_in.size}.",
        )
    top = float(np.max(np.abs(ell_in))) + order
    if top > intervals / 2.0:
        v.fail(
            owner,
            f"ell must keep every frequency |ℓ + i|/window (i = 0..order) at most "
            f"the bank's Nyquist frequency 1/(2·time_step) = {0.5 / time_step:g} "
            f"[Hz]; got {top / window:g} Hz (window {window:g} s, time_step "
            f"{time_step:g} s).",
        )
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
    exact = top / spacing + 1e-9
    if not exact < MAX_FUNCTIONS:  # also inf: checked before any allocation
        v.fail(
            owner,
            f"bandwidth_hz·window must give at most {MAX_FUNCTIONS} modulating "
            f"functions (ℓ spacing {spacing:g}); got bandwidth_hz {bandwidth_hz:g} Hz "
            f"with window {window:g} s ({exact:.3g} functions).",
        )
    count = math.floor(exact) + 1
    return np.round(spacing * np.arange(count), _DECIMALS)


def band_frequencies(
    window: float,
    bandwidth_hz: float,
    *,
    order: int = 1,
    spacing: float = 1.0,
    min_count: int = MIN_FUNCTIONS,
) -> np.ndarray:
    """The default ℓ set: the band's integer bins, at least ``min_count`` of them.

    ``ℓ = 0, spacing, 2·spacing, ...`` with ``(ℓ + order)/window <= bandwidth_hz``
    (:func:`default_frequencies`), extended with the next values to ``min_count``
    when the band is narrower than ``(order + spacing·(min_count - 1))/window``
    (a short window on a slow motion still needs a few equations per joint). The
    one rule of the library: ``OnlineSettings.ell()`` and
    ``core.excitation.frequencies_for`` are this function.

    Args:
        window: modulating window T [s].
        bandwidth_hz: excitation bandwidth [Hz]
            (``core.excitation.estimate_bandwidth``).
        order: modulating order k >= 1.
        spacing: step of ℓ (1: orthogonal integer bins, the recommended set).
        min_count: smallest number of ℓ values returned (>= 1).

    Returns:
        (L,) the indices ℓ.
    """
    owner = "band_frequencies"
    window = v.positive(owner, "window", window, "s")
    bandwidth_hz = v.positive(owner, "bandwidth_hz", bandwidth_hz, "Hz")
    order = v.integer(owner, "order", order, minimum=1)
    spacing = v.positive(owner, "spacing", spacing)
    min_count = v.integer(owner, "min_count", min_count, minimum=1)
    floor_band = (order + spacing * (min_count - 1)) / window
    return default_frequencies(
        window, max(bandwidth_hz, floor_band), order=order, spacing=spacing
    )


def _derivative(bank: FourierBank, derivative: Any) -> int:
    derivative = v.integer("modulated_integrals", "derivative", derivative, minimum=0)
    if derivative > bank.order:
        v.fail(
            "modulated_integrals",
            f"derivative must be <= order {bank.order}; got {derivative}.",
        )
    return derivative


def check_samples(
    owner: str, samples: Any, rows: int | None, finite: bool = True
) -> np.ndarray:
    """``samples`` as a float (N, c) array ((N,) becomes (N, 1)); N = ``rows``."""
    out = v.array(owner, "samples", samples, finite=finite)
    if out.ndim == 1:
        out = out[:, None]
    if out.ndim != 2 or (rows is not None and out.shape[0] != rows):
        want = "any" if rows is None else str(rows)
        v.fail(owner, f"samples must have shape ({want}, channels); got {out.shape}.")
    return out
