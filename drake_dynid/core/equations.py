"""The modulated equations of one window (docs/MATH.md §3, docs/CONVENTIONS.md §3).

From the sliding Fourier integrals ``F_ν`` of the packed model rows
(``core.rows.pack_rows``), every modulated integral is a fixed combination::

    M_{g^(r)}[ℓ] = (1/T) Σ_i binom(k,i) (-1)^{k-i} (-j(ℓ+i)ω0)^r F_{ℓ+i}

and for every ℓ and every equation j of the model-row contract::

    -M_ġ(D_j)·θ + M_g(G_j)·θ = M_g(y_j)

whose real and imaginary parts give two real rows of ``A θ = B``
(:func:`assemble_equations`). :func:`direct_fourier_integrals` is the reference
quadrature of one full window (the trapezoid rule on its samples, the same rule as
the sliding update in ``core.sliding``); :func:`row_frequencies` gives each row's
frequency for the frequency-weighted solve (``core.lsq``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.fourier_bank import FourierBank, _derivative, check_samples
from drake_dynid.core.rows import num_channels

__all__ = [
    "assemble_equations",
    "direct_fourier_integrals",
    "modulated_integrals",
    "row_frequencies",
    "row_functions",
]

_BLOCK = 2048  # samples per block in the direct sums (bounds memory to K × _BLOCK)


def _bank(owner: str, bank: Any) -> FourierBank:
    return v.instance(owner, "bank", bank, FourierBank, "a FourierBank (fourier_bank)")


def _integrals(owner: str, bank: FourierBank, F: Any) -> np.ndarray:
    _bank(owner, bank)
    F = np.asarray(F)
    if F.ndim not in (1, 2) or F.shape[0] != bank.num_frequencies:
        v.fail(
            owner,
            f"F must have shape ({bank.num_frequencies}, channels); got {F.shape}.",
        )
    return F


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
    _bank("direct_fourier_integrals", bank)
    x = check_samples("direct_fourier_integrals", samples, bank.num_samples)
    intervals = bank.num_intervals
    weights = np.ones(bank.num_samples)
    weights[[0, -1]] = 0.5
    real = np.zeros((bank.num_frequencies, x.shape[1]))
    imag = np.zeros_like(real)
    for start in range(0, bank.num_samples, _BLOCK):  # real products (c can be 10^3)
        i = np.arange(start, min(start + _BLOCK, bank.num_samples))
        phase = 2.0 * np.pi * np.multiply.outer(bank.nu, i / intervals)
        weighted = weights[i, None] * x[i]
        real += np.cos(phase) @ weighted
        imag -= np.sin(phase) @ weighted
    return (real + 1j * imag) * bank.time_step


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
    _bank("modulated_integrals", bank)
    derivative = _derivative(bank, derivative)
    F = _integrals("modulated_integrals", bank, F)
    weights = bank.weights[derivative]
    if F.ndim == 2:
        weights = weights[:, :, None]
    out = weights[:, 0] * F[bank.index[:, 0]]
    for i in range(1, bank.order + 1):
        out += weights[:, i] * F[bank.index[:, i]]
    return out


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
        F: (K, 2mp + m) sliding Fourier integrals of the packed channels
            (``core.rows.pack_rows``).
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
    (:func:`drake_dynid.core.weighted_lsq.solve_frequency_weighted_least_squares`), one
    noise group per equation j.

    Returns:
        ``(frequency, group)``, each (``bank.num_rows(m)``,): float ν and int j.
    """
    _bank("row_frequencies", bank)
    m = v.integer("row_frequencies", "m", m, minimum=1)
    L = bank.num_functions
    frequency = np.repeat(np.abs(bank.ell + (bank.order + 1) / 2.0), 2 * m)
    group = np.tile(np.arange(m), 2 * L)
    keep = np.repeat(bank.row_mask.ravel(), m)
    return frequency[keep], group[keep]


def row_functions(bank: FourierBank, m: int) -> np.ndarray:
    """Index (0 .. L-1) of the modulating function g_ℓ of every row.

    Rows of :func:`assemble_equations`, in their order (ℓ-major): the groups of
    the jackknife (``OnlineSettings.jackknife_groups``).

    Returns:
        (``bank.num_rows(m)``,) int.
    """
    m = v.integer("row_functions", "m", m, minimum=1)
    index = np.repeat(np.arange(bank.num_functions), 2 * m)
    return index[np.repeat(bank.row_mask.ravel(), m)]
