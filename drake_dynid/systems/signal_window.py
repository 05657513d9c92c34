"""The ``SignalWindow`` block: the filtered signals of the bank's window."""

from __future__ import annotations

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    Context,
    InputPort,
    LeafSystem,
    OutputPort,
    State,
)

from drake_dynid.core import _validate as check
from drake_dynid.core.signal_ring import ring_init, ring_push, ring_window

__all__ = ["SignalWindow"]


class SignalWindow(LeafSystem):
    r"""The differentiator's outputs at the bank's last K sample times.

    .. pydrake_system::

        name: SignalWindow
        input_ports:
        - smoothed
        - rates
        output_ports:
        - window

    Every ``time_step`` seconds (the bank's step, with the bank's offset, so that
    it reads the same differentiator outputs as the bank) the block pushes
    (q̂, v̂, τ̂) from ``smoothed`` = [q̂; τ̂] and ``rates`` = [v̂; τ̂'] (the
    ``CausalJacobiDifferentiator``'s orders 0 and 1) into a ring of K samples
    (``core.signal_ring``). The abstract output ``window`` is ``(q̂, v̂, τ̂)``, each
    (K, n) oldest first, or None before K samples: the covariance weighting's
    input (``core.row_covariance``, the ``SlidingQRIdentifier``'s
    ``window_signals`` port). State: the ring (abstract); no direct feedthrough.
    Double only.
    """

    def __init__(
        self, num_joints: int, num_samples: int, time_step: float, offset: float = 0.0
    ):
        """Builds the block.

        Args:
            num_joints: n.
            num_samples: K, the bank's samples per window.
            time_step: the bank's sample period [s].
            offset: time of the first update [s] (the bank's).
        """
        super().__init__()
        owner = "SignalWindow"
        self._n = check.integer(owner, "num_joints", num_joints, 1)
        check.integer(owner, "num_samples", num_samples, 1)
        period = check.positive(owner, "time_step", time_step, "s")
        offset = check.real(owner, "offset", offset, "s")
        if offset < 0.0:
            check.fail(owner, f"offset must be >= 0 [s]; got {offset}.")
        initial = ring_init(num_samples, self._n)
        self._smoothed = self.DeclareVectorInputPort("smoothed", 2 * self._n)
        self._rates = self.DeclareVectorInputPort("rates", 2 * self._n)
        self._ring = self.DeclareAbstractState(AbstractValue.Make(initial))
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, offset, self._Push)
        self.DeclareForcedUnrestrictedUpdateEvent(self._Push)  # on demand
        self._window = self.DeclareAbstractOutputPort(
            "window",
            lambda: AbstractValue.Make(ring_window(initial)),
            self._CalcWindow,
            prerequisites_of_calc={self.abstract_state_ticket(self._ring)},
        )

    def get_input_port_smoothed(self) -> InputPort:
        """The input port ``smoothed`` ([q̂; τ̂], 2n)."""
        return self._smoothed

    def get_input_port_rates(self) -> InputPort:
        """The input port ``rates`` ([v̂; τ̂'], 2n)."""
        return self._rates

    def get_output_port_window(self) -> OutputPort:
        """The output port ``window`` (abstract: (q̂, v̂, τ̂) or None)."""
        return self._window

    def _Push(self, context: Context, state: State) -> None:
        n = self._n
        smoothed = self._smoothed.Eval(context)
        rates = self._rates.Eval(context)
        ring = context.get_abstract_state(int(self._ring)).get_value()
        new = ring_push(ring, smoothed[:n], rates[:n], smoothed[n:])
        state.get_mutable_abstract_state(int(self._ring)).set_value(new)

    def _CalcWindow(self, context: Context, value: AbstractValue) -> None:
        ring = context.get_abstract_state(int(self._ring)).get_value()
        value.set_value(ring_window(ring))
