"""The modulating-bank protocol: what the on-line pipeline needs from a bank design.

The ``ModulatingIntegralBank`` block, the core replay (``core.replay``) and the
solver's row weighting (``OnlineSettings.row_weighting``) use a bank design only
through this protocol. :class:`~drake_dynid.core.fourier_bank.FourierBank` (Fourier
modulating functions, sliding Fourier integrals) satisfies it.

Adding another modulating-function family (e.g. polynomial or spline modulating
functions, docs/MATH.md §3): write an immutable design class with the members below
(a streaming state of the window and the assembly of the stacked real equations
``A θ = B`` of the model-row contract, docs/CONVENTIONS.md §3), and pass it to the
block or the replay in place of a ``FourierBank``. Nothing else changes: the rows,
the solver and the timing are independent of the family. ``OnlineSettings.bank()``
builds the Fourier design; another family is built by the caller.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["ModulatingBank"]


@runtime_checkable
class ModulatingBank(Protocol):
    """A modulating-function bank over a sliding window (immutable design).

    Attributes:
        window: sliding window T [s].
        time_step: period of the samples entering the bank [s] (a multiple of
            the signal period: the bank may decimate).
        num_samples: samples in a full window.
    """

    @property
    def window(self) -> float:
        """Sliding window T [s]."""
        ...

    @property
    def time_step(self) -> float:
        """Period of the samples entering the bank [s]."""
        ...

    @property
    def num_samples(self) -> int:
        """Samples in a full window."""
        ...

    def num_rows(self, m: int) -> int:
        """Rows of the stacked equations for ``m`` equations per sample."""
        ...

    def row_frequencies(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        """``(frequency, group)`` of every row.

        The frequency index ν (the rows' noise grows with it) and the equation j
        (the noise group), as ``core.equations.row_frequencies``.
        """
        ...

    def row_functions(self, m: int) -> np.ndarray:
        """The modulating function (0 .. L-1) of every row.

        The jackknife's groups, as ``core.equations.row_functions``.
        """
        ...

    def init_state(self, num_channels: int) -> Any:
        """Empty streaming state for samples of ``num_channels`` floats."""
        ...

    def push(self, state: Any, sample: Any, *, valid: bool = True) -> Any:
        """New state after one sample (c,).

        Invalid or non-finite samples are stored as zeros and keep the window
        invalid until they have left it.
        """
        ...

    def push_many(self, state: Any, samples: Any, *, valid: Any = None) -> Any:
        """New state after a block of samples (b, c), oldest first."""
        ...

    def window_valid(self, state: Any) -> bool:
        """True when the window is full and holds no invalid sample."""
        ...

    def equations(self, state: Any, m: int, p: int) -> tuple[np.ndarray, np.ndarray]:
        """The window's stacked real equations ``A`` (rows, p) and ``B`` (rows,)."""
        ...
