"""The ``ModulatingIntegralBank`` block: the modulated equations of a sliding window."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    InputPort,
    LeafSystem,
    OutputPort,
    State,
    ValueProducer,
)

from drake_dynid.core import _validate as check
from drake_dynid.core.bank import ModulatingBank
from drake_dynid.core.rows import num_channels

__all__ = ["ModulatingIntegralBank"]


class ModulatingIntegralBank(LeafSystem):
    r"""Sliding Fourier modulating integrals of the model rows over a window T.

    .. pydrake_system::

        name: ModulatingIntegralBank
        input_ports:
        - channels
        - sample_valid
        output_ports:
        - A
        - B
        - valid
        - window_state

    Every ``bank.time_step`` seconds the block pushes the input sample (the packed
    rows of docs/CONVENTIONS.md §3) into its sliding window of length T and updates
    the Fourier integrals F_ν(f) = ∫_{t-T}^{t} e^{-jνω0 s} f dv, ω0 = 2π/T,
    recursively (cost independent of T; docs/MATH.md §3). The outputs stack, for
    every ℓ of the bank and every equation, the real and imaginary parts of

        -M_ġ(D)·θ + M_g(G)·θ = M_g(y),     g_ℓ(s) = (1/T) e^{-jℓω0 s}(e^{-jω0 s} - 1)^k,

    into ``A`` (flattened row-major, rows × p) and ``B`` (rows).

    ``valid`` is 1 when the window is full and holds no invalid sample: a sample with
    ``sample_valid`` = 0 or any non-finite channel is stored as zeros and makes the
    window invalid until it has left the window (T later).

    State: one abstract state group, the window (the bank's streaming state: for
    a ``FourierBank`` a persistent ring of the window's samples plus running sums,
    cheap to copy), also exposed as the abstract output ``window_state`` (read by
    the change detector, ``systems.change``). Outputs are computed from the state
    only (no direct feedthrough), so after the update at t_k they describe the
    window ending with the sample read at t_k. Any design satisfying
    ``drake_dynid.core.bank.ModulatingBank`` works (the extension point for
    another modulating-function family). Double only: a plain Python
    ``LeafSystem`` has no AutoDiffXd or symbolic scalar conversion.
    """

    def __init__(
        self,
        bank: ModulatingBank,
        num_equations: int,
        num_parameters: int,
        *,
        offset: float = 0.0,
    ):
        """Builds the block.

        Args:
            bank: the modulating-function design (window T, sample period, order,
                ℓ set), e.g. from ``drake_dynid.core.modulating.fourier_bank``.
            num_equations: m, equations per sample (1 power, n Lagrangian).
            num_parameters: p, columns of A.
            offset: time of the first update [s]. Behind a block updating every
                h (the differentiator), give ``core.online.BANK_OFFSET``·h (h/2),
                as ``diagrams.add_bank_front`` does: at offset 0 the float event
                times of the two periods tie only up to an ulp, so a read at
                k·h sees that block's pre- or post-update state depending on
                the round-off (docs/CONVENTIONS.md §2).
        """
        super().__init__()
        owner = "ModulatingIntegralBank"
        if not isinstance(bank, ModulatingBank):
            raise TypeError(
                f"{owner}: bank must be a modulating bank design "
                "(drake_dynid.core.bank.ModulatingBank, e.g. a FourierBank from "
                f"drake_dynid.core.modulating.fourier_bank); got {type(bank).__name__}."
            )
        self._bank = bank
        offset = check.real(owner, "offset", offset, "s")
        if offset < 0.0:
            check.fail(owner, f"offset must be >= 0 [s]; got {offset}.")
        self._m = check.integer(owner, "num_equations", num_equations, 1)
        self._p = check.integer(owner, "num_parameters", num_parameters, 1)
        self._c = num_channels(self._m, self._p)
        self._num_rows = bank.num_rows(self._m)
        self._channels = self.DeclareVectorInputPort("channels", self._c)
        self._sample_valid = self.DeclareVectorInputPort("sample_valid", 1)
        initial = bank.init_state(self._c)
        self._window = self.DeclareAbstractState(AbstractValue.Make(initial))
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            bank.time_step, offset, self._UpdateWindow
        )
        self.DeclareForcedUnrestrictedUpdateEvent(self._UpdateWindow)  # on demand
        ticket = {self.abstract_state_ticket(self._window)}
        self._equations_cache = self.DeclareCacheEntry(
            description="modulated equations (A, B) of the current window",
            value_producer=ValueProducer(
                allocate=lambda: AbstractValue.Make((np.zeros((0, 0)), np.zeros(0))),
                calc=self._CalcEquations,
            ),
            prerequisites_of_calc=ticket,
        )
        self._a = self.DeclareVectorOutputPort(
            "A", self._num_rows * self._p, self._CalcA, prerequisites_of_calc=ticket
        )
        self._b = self.DeclareVectorOutputPort(
            "B", self._num_rows, self._CalcB, prerequisites_of_calc=ticket
        )
        self._valid = self.DeclareVectorOutputPort(
            "valid", 1, self._CalcValid, prerequisites_of_calc=ticket
        )
        self._window_state = self.DeclareAbstractOutputPort(
            "window_state",
            lambda: AbstractValue.Make(initial),
            self._CalcWindowState,
            prerequisites_of_calc=ticket,
        )

    @property
    def bank(self) -> ModulatingBank:
        """The modulating-function design."""
        return self._bank

    @property
    def num_rows(self) -> int:
        """Rows of A and B (2·L·m minus identically zero rows)."""
        return self._num_rows

    def get_input_port_channels(self) -> InputPort:
        """The input port ``channels`` (packed model rows, 2·m·p + m)."""
        return self._channels

    def get_input_port_sample_valid(self) -> InputPort:
        """The input port ``sample_valid`` (1: the sample may enter the window)."""
        return self._sample_valid

    def get_output_port_A(self) -> OutputPort:
        """The output port ``A`` (rows × p, row-major)."""
        return self._a

    def get_output_port_B(self) -> OutputPort:
        """The output port ``B`` (rows)."""
        return self._b

    def get_output_port_valid(self) -> OutputPort:
        """The output port ``valid`` (1: full window without invalid samples)."""
        return self._valid

    def get_output_port_window_state(self) -> OutputPort:
        """The output port ``window_state`` (abstract: the bank's streaming state)."""
        return self._window_state

    def _CalcWindowState(self, context: Context, value: AbstractValue) -> None:
        value.set_value(self._state(context))

    def _state(self, context: Context) -> Any:
        return context.get_abstract_state(int(self._window)).get_value()

    def _CalcEquations(self, context: Context, value: AbstractValue) -> None:
        value.set_value(self._bank.equations(self._state(context), self._m, self._p))

    def _UpdateWindow(self, context: Context, state: State) -> None:
        sample = np.array(self._channels.Eval(context), dtype=float)
        ok = self._sample_valid.Eval(context)[0] > 0.5 and np.all(np.isfinite(sample))
        new = self._bank.push(self._state(context), sample, valid=bool(ok))
        state.get_mutable_abstract_state(int(self._window)).set_value(new)

    def _CalcA(self, context: Context, output: BasicVector) -> None:
        a, _ = self._equations_cache.Eval(context)
        output.SetFromVector(a.ravel())

    def _CalcB(self, context: Context, output: BasicVector) -> None:
        _, b = self._equations_cache.Eval(context)
        output.SetFromVector(b)

    def _CalcValid(self, context: Context, output: BasicVector) -> None:
        valid = self._bank.window_valid(self._state(context))
        output.SetAtIndex(0, 1.0 if valid else 0.0)
