"""Drake block for the causal Jacobi derivative estimator (docs/MATH.md §1)."""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, LeafSystem

from drake_dynid.core import _validate
from drake_dynid.core.jacobi_design import JacobiFilter, _design_bank
from drake_dynid.core.jacobi_stream import (
    jacobi_history,
    jacobi_initial_state,
    jacobi_outputs,
    jacobi_ring,
    jacobi_step,
    jacobi_valid,
)

_OWNER = "CausalJacobiDifferentiator"


class CausalJacobiDifferentiator(LeafSystem):
    """Causal Jacobi estimates of the derivatives of a sampled vector signal.

    .. pydrake_system::

        name: CausalJacobiDifferentiator
        input_ports:
        - u
        output_ports:
        - derivative_<order> (one per requested order, e.g. derivative_0)
        - ...
        - valid
        - history

    Every ``time_step`` h [s] (offset 0) the block samples ``u`` (size m) into a ring
    buffer of the last N+1 samples (N = window/h) held in its discrete state, and
    for each requested order k outputs the FIR estimate (see
    :func:`drake_dynid.core.jacobi.jacobi_filter`)::

        derivative_k = Σ_{j=0..N} taps_k[j] u(t_n - j·h)  ≈  u^(k)(t_n - delay)

    in [unit of u · s^-k], where t_n is the time of the last update and
    ``delay = window·ξ`` [s] is the same for every order (one ξ for the bank: by
    default the minimum-delay root of the highest order, see
    :func:`~drake_dynid.core.jacobi.jacobi_filters`). Order 0 is the smoothed
    signal at the same instant, to align other signals with the derivatives.

    Timing: after the update at t_k the outputs use the samples up to and
    including t_k. Outputs depend on the state only (no direct feedthrough), so a
    logger or a downstream block that samples them at t_k sees the state after the
    update at t_{k-1}: one extra sample of latency, as for every state-output block
    (docs/CONVENTIONS.md §2). ``valid`` is 0 until N+1 samples have been taken
    (before that, missing samples count as zeros), then 1, except while a NaN or
    infinite sample is in the ring (N+1 updates; that signal's estimates are
    then not finite). ``history`` is the ring itself in time order, the last
    N+1 samples oldest first ((N+1)·m, row-major (N+1, m); zeros before the
    first sample): the raw rows of the on-line identifier read it
    (``drake_dynid.core.raw_rows``).

    State (numeric discrete state, in the Context only): one group, the ring of the
    last N+1 samples with its position,
    ``[buffer ((N+1)·m, slot-major) | head | count]``
    (:func:`~drake_dynid.core.jacobi.jacobi_ring`: the core's streaming functions
    step this one vector in place); the FIR is one matrix-vector product with a
    doubled, age-reversed kernel, without rolling the buffer. The block does not
    resample or hold values: ``u`` must be meaningful at the update times. Double
    only: a plain Python ``LeafSystem`` has no AutoDiffXd or symbolic scalar
    conversion (differentiate the plant off-line instead).

    Args:
        num_signals: Size m >= 1 of ``u``.
        time_step: Update period h > 0 [s].
        window: Window length Tj [s], a multiple of ``time_step``.
        kappa: κ > -1 (weight of the newest end).
        mu: μ > -1 (weight of the oldest end).
        q: Integer q >= 0 (the fitted polynomial has degree k+q).
        xi: ξ in [0, 1] shared by all orders, or None (minimum-delay root of the
            highest order).
        orders: Distinct derivative orders, one output port each.
        matched: If True, order k uses κ + K - k and μ + K - k (K the highest
            order) so that every output is the same low-pass filter applied to
            u^(k) (:func:`~drake_dynid.core.jacobi.jacobi_filters`); use it when
            the outputs enter one equation together, as in identification.
    """

    def __init__(
        self,
        num_signals: int,
        time_step: float,
        window: float,
        *,
        kappa: float,
        mu: float,
        q: int,
        xi: float | None = None,
        orders: Sequence[int] = (0, 1),
        matched: bool = False,
    ):
        super().__init__()
        num_signals = _validate.integer(_OWNER, "num_signals", num_signals, minimum=1)
        self._filters = _design_bank(
            _OWNER, orders, window, time_step, kappa, mu, q, xi, matched
        )
        self._ring = jacobi_ring(self._filters, num_signals)
        self._num_signals = num_signals
        self._time_step = self._filters[0].time_step

        self._input = self.DeclareVectorInputPort("u", num_signals)
        initial = jacobi_initial_state(self._ring)
        self._state_index = int(self.DeclareDiscreteState(initial))
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=self._time_step, offset_sec=0.0, update=self._Update
        )
        # The same update on demand (ExecuteForcedEvents), as Drake's
        # DiscreteDerivative: one sample taken in a unit test without a Simulator.
        self.DeclareForcedDiscreteUpdateEvent(self._Update)
        ticket = {self.xd_ticket()}
        for index, filt in enumerate(self._filters):
            self.DeclareVectorOutputPort(
                f"derivative_{filt.order}",
                num_signals,
                partial(self._CalcDerivative, index),
                prerequisites_of_calc=ticket,
            )
        self.DeclareVectorOutputPort(
            "valid", 1, self._CalcValid, prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "history",
            self._ring.num_taps * num_signals,
            self._CalcHistory,
            prerequisites_of_calc=ticket,
        )

    # ------------------------------------------------------------------ properties
    @property
    def delay(self) -> float:
        """window·ξ [s]: every output refers to (time of the last update) - delay."""
        return self._filters[0].delay

    @property
    def xi(self) -> float:
        """The normalised delay ξ shared by all orders."""
        return self._filters[0].xi

    @property
    def filters(self) -> tuple[JacobiFilter, ...]:
        """The designed filters, one per output port, in port order."""
        return self._filters

    @property
    def num_signals(self) -> int:
        """Size of ``u`` and of every derivative port."""
        return self._num_signals

    @property
    def time_step(self) -> float:
        """Update period h [s]."""
        return self._time_step

    def get_input_port_u(self):
        """The input port ``u``."""
        return self._input

    def get_output_port_derivative(self, order: int):
        """The output port ``derivative_<order>``.

        Raises:
            TypeError: ``order`` is not a whole number (1.7 was read as 1).
            ValueError: the block has no such order.
        """
        order = _validate.integer(_OWNER, "order", order)
        orders = tuple(f.order for f in self._filters)
        if order not in orders:
            _validate.fail(
                _OWNER,
                f"order must be one of the block's orders {orders}; got {order}.",
            )
        return self.GetOutputPort(f"derivative_{order}")

    def get_output_port_valid(self):
        """The output port ``valid``."""
        return self.GetOutputPort("valid")

    def get_output_port_history(self):
        """The output port ``history`` (the last N+1 samples, oldest first)."""
        return self.GetOutputPort("history")

    @property
    def history_length(self) -> int:
        """N + 1, the samples of the ``history`` port."""
        return self._ring.num_taps

    # ------------------------------------------------------------------- callbacks
    def _Update(self, context: Context, discrete_state: DiscreteValues) -> None:
        state = discrete_state.get_mutable_value(self._state_index)
        sample = self._input.Eval(context)
        jacobi_step(self._ring, state, sample, out=state)

    def _CalcDerivative(
        self, index: int, context: Context, output: BasicVector
    ) -> None:
        state = context.get_discrete_state(self._state_index).get_value()
        output.SetFromVector(jacobi_outputs(self._ring, state, index))

    def _CalcHistory(self, context: Context, output: BasicVector) -> None:
        state = context.get_discrete_state(self._state_index).get_value()
        output.SetFromVector(jacobi_history(self._ring, state).ravel())

    def _CalcValid(self, context: Context, output: BasicVector) -> None:
        state = context.get_discrete_state(self._state_index).get_value()
        output.SetFromVector(
            np.array([1.0 if jacobi_valid(self._ring, state) else 0.0])
        )
