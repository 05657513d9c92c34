"""Fourier modulating functions and their sliding integrals (docs/MATH.md §3).

A facade over the modules that hold the pieces (import from here or from them):

* :mod:`drake_dynid.core.fourier_bank`: the bank design (:class:`FourierBank`,
  :func:`fourier_bank`) and the ℓ sets (:func:`band_frequencies`,
  :func:`default_frequencies`, :func:`paper_frequencies`);
* :mod:`drake_dynid.core.sliding`: the sliding Fourier integrals of a stream
  (:class:`SlidingState`, ``sliding_*``, :func:`window_valid`);
* :mod:`drake_dynid.core.equations`: the modulated equations of a window
  (:func:`assemble_equations`, :func:`row_frequencies`, the reference quadrature
  :func:`direct_fourier_integrals`, :func:`modulated_integrals`);
* :mod:`drake_dynid.core.rows`: the model-row contract and its packing
  (:func:`pack_rows`, :func:`unpack_rows`, :func:`num_channels`);
* :mod:`drake_dynid.core.bank`: the :class:`ModulatingBank` protocol, the extension
  point for another modulating-function family.

Typical use (one window of model rows ``D``, ``G``, ``y``)::

    bank = fourier_bank(20.0, 1e-3, order=1, ell=paper_frequencies())
    state = sliding_init(bank, num_channels(m, p))
    state = sliding_push(bank, state, pack_rows(D, G, y))  # per sample
    if window_valid(state):
        A, B = assemble_equations(bank, sliding_fourier_integrals(bank, state), m, p)
"""

from __future__ import annotations

from drake_dynid.core.bank import ModulatingBank
from drake_dynid.core.equations import (
    assemble_equations,
    direct_fourier_integrals,
    modulated_integrals,
    row_frequencies,
)
from drake_dynid.core.fourier_bank import (
    MIN_FUNCTIONS,
    FourierBank,
    band_frequencies,
    default_frequencies,
    fourier_bank,
    num_equation_rows,
    paper_frequencies,
)
from drake_dynid.core.rows import num_channels, pack_rows, unpack_rows
from drake_dynid.core.sliding import (
    SlidingState,
    is_full,
    sliding_fourier_integrals,
    sliding_init,
    sliding_push,
    sliding_push_many,
    sliding_resync,
    window_valid,
)

__all__ = [
    "MIN_FUNCTIONS",
    "FourierBank",
    "ModulatingBank",
    "SlidingState",
    "assemble_equations",
    "band_frequencies",
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
