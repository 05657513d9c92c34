"""The ``PayloadIdentifier`` block: the payload's parameters on the bank's window."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.systems.framework import (
    Context,
    DiscreteValues,
    InputPort,
    LeafSystem,
    OutputPort,
)

from drake_dynid.core import _validate as check
from drake_dynid.core.identifier import IdentifierState, Status
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION
from drake_dynid.core.payload_step import PayloadState, payload_init, payload_update

__all__ = ["PayloadIdentifier"]

# State groups in declaration order; each is also an output port of the same name.
_GROUPS = (
    "theta",
    "theta_std",
    "condition_number",
    "valid",
    "unidentified",
    "status",
    "correlation",
)


class PayloadIdentifier(LeafSystem):
    r"""Least squares of a payload's parameters with the arm's part known.

    .. pydrake_system::

        name: PayloadIdentifier
        input_ports:
        - A
        - B
        - window_valid
        output_ports:
        - theta
        - theta_std
        - condition_number
        - valid
        - unidentified
        - status
        - correlation

    The bank's window of ``drake_dynid.core.payload.PayloadRows`` gives
    ``A [θ; 1] = B`` (r × (p + 1): the payload's p base parameters, then the
    arm's known column with coefficient 1). Every ``update_period`` seconds, if
    ``window_valid`` is 1, the block solves

        θ̂ = argmin ‖A[:, :p] θ - (B - A[:, p])‖₂

    (``drake_dynid.core.payload_step.payload_update``: the on-line identifier's
    solve, σ, condition number and hold; the units of θ are those of
    ``PayloadRows.payload_names``: kg·m², kg·m, kg), and ``correlation``
    (p × p, row-major) is the correlation of θ̂'s errors at the last accepted
    solve. A window not ready, rank deficient or ill-conditioned holds the last
    estimate with ``valid`` = 0 and its ``status`` (``core.identifier.Status``).
    Before the first accepted solve θ̂ = 0 (no payload) and σ = +inf.

    State: one discrete state group per output (theta, theta_std,
    condition_number, valid, unidentified, status, correlation), each exposed by
    a state output port (no direct feedthrough). Double only: a plain Python
    ``LeafSystem`` has no AutoDiffXd or symbolic scalar conversion.
    """

    def __init__(
        self,
        num_parameters: int,
        num_rows: int,
        update_period: float,
        *,
        max_condition: float = DEFAULT_MAX_CONDITION,
        names: Sequence[str] | None = None,
        offset: float = 0.0,
        row_weighting: tuple[Any, Any] | None = None,
        row_noise: Any = None,
        jackknife_groups: Any = None,
    ):
        """Builds the block.

        Args:
            num_parameters: p, the payload's base parameters (``A`` has p + 1
                columns).
            num_rows: r, rows of A and B (``ModulatingIntegralBank.num_rows``).
            update_period: seconds between two solves [s].
            max_condition: largest accepted condition number of the column-scaled
                A[:, :p].
            names: the p payload names (for messages).
            offset: time of the first update [s] (>= 0).
            row_weighting: ``(row_frequency, row_group)`` of the rows
                (``OnlineSettings.row_weighting``), or None: ordinary least
                squares.
            row_noise: the rows' ``core.row_noise.RowNoise``
                (``OnlineSettings.row_noise``), or None: Gautier's σ.
            jackknife_groups: (r,) the jackknife group of each row
                (``OnlineSettings.jackknife_groups``), or None.
        """
        super().__init__()
        owner = "PayloadIdentifier"
        p = check.integer(owner, "num_parameters", num_parameters, 1)
        r = check.integer(owner, "num_rows", num_rows, 1)
        self._period = check.positive(owner, "update_period", update_period, "s")
        offset = check.real(owner, "offset", offset, "s")
        if offset < 0.0:
            check.fail(owner, f"offset must be >= 0 [s]; got {offset}.")
        self._max_condition = check.greater_than(
            owner, "max_condition", max_condition, 1.0
        )
        if names is not None and len(names) != p:
            check.fail(owner, f"names must have {p} entries; got {len(names)}.")
        self._names = tuple(names) if names is not None else None
        self._p, self._r = p, r
        self._weighting = None
        if row_weighting is not None:
            frequency, group = row_weighting
            self._weighting = (
                check.array(owner, "row_frequency", frequency, (r,)),
                check.array(owner, "row_group", group, (r,)).astype(int),
            )
        if row_noise is not None and row_noise.num_rows != r:
            check.fail(
                owner, f"row_noise must describe {r} rows; got {row_noise.num_rows}."
            )
        self._noise = row_noise
        self._jackknife = None
        if jackknife_groups is not None:
            self._jackknife = check.array(
                owner, "jackknife_groups", jackknife_groups, (r,)
            ).astype(int)
        self._a = self.DeclareVectorInputPort("A", r * (p + 1))
        self._b = self.DeclareVectorInputPort("B", r)
        self._window_valid = self.DeclareVectorInputPort("window_valid", 1)
        self._groups = {
            name: self.DeclareDiscreteState(value)
            for name, value in zip(
                _GROUPS, self._as_vectors(payload_init(p)), strict=True
            )
        }
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, offset, self._Solve)
        self._outputs = {
            name: self.DeclareStateOutputPort(name, index)
            for name, index in self._groups.items()
        }

    @property
    def update_period(self) -> float:
        """Seconds between two solves."""
        return self._period

    def get_input_port_A(self) -> InputPort:
        """The input port ``A`` (r × (p + 1), row-major)."""
        return self._a

    def get_input_port_B(self) -> InputPort:
        """The input port ``B`` (r)."""
        return self._b

    def get_input_port_window_valid(self) -> InputPort:
        """The input port ``window_valid`` (1: solve this window)."""
        return self._window_valid

    def get_output_port_theta(self) -> OutputPort:
        """The output port ``theta`` (p, the estimate held)."""
        return self._outputs["theta"]

    def get_output_port_theta_std(self) -> OutputPort:
        """The output port ``theta_std`` (p, σ of the estimate)."""
        return self._outputs["theta_std"]

    def get_output_port_condition_number(self) -> OutputPort:
        """The output port ``condition_number`` (1)."""
        return self._outputs["condition_number"]

    def get_output_port_valid(self) -> OutputPort:
        """The output port ``valid`` (1: the last solve was accepted)."""
        return self._outputs["valid"]

    def get_output_port_unidentified(self) -> OutputPort:
        """The output port ``unidentified`` (p, 1: not excited in the last solve)."""
        return self._outputs["unidentified"]

    def get_output_port_status(self) -> OutputPort:
        """The output port ``status`` (1, a ``core.identifier.Status`` code)."""
        return self._outputs["status"]

    def get_output_port_correlation(self) -> OutputPort:
        """The output port ``correlation`` (p × p, row-major)."""
        return self._outputs["correlation"]

    def state(self, context: Context) -> PayloadState:
        """The identifier's state in ``context`` (``core.payload_step``)."""
        p = self._p
        estimate = IdentifierState(
            theta=self._value(context, "theta").copy(),
            std=self._value(context, "theta_std").copy(),
            condition_number=float(self._value(context, "condition_number")[0]),
            valid=bool(self._value(context, "valid")[0] > 0.5),
            unidentified=self._value(context, "unidentified").copy(),
            status=Status(int(self._value(context, "status")[0])),
        )
        correlation = self._value(context, "correlation").reshape(p, p).copy()
        return PayloadState(estimate, correlation)

    def _value(self, context: Context, name: str) -> np.ndarray:
        return context.get_discrete_state(int(self._groups[name])).get_value()

    @staticmethod
    def _as_vectors(state: PayloadState) -> tuple[np.ndarray, ...]:
        estimate = state.estimate
        return (
            estimate.theta,
            estimate.std,
            np.array([estimate.condition_number]),
            np.array([1.0 if estimate.valid else 0.0]),
            estimate.unidentified,
            np.array([float(estimate.status)]),
            state.correlation.reshape(-1),
        )

    def _Solve(self, context: Context, discrete_state: DiscreteValues) -> None:
        ready = self._window_valid.Eval(context)[0] > 0.5
        a = self._a.Eval(context).reshape(self._r, self._p + 1) if ready else None
        b = self._b.Eval(context) if ready else None
        new = payload_update(
            self.state(context),
            ready,
            a,
            b,
            weighting=self._weighting,
            max_condition=self._max_condition,
            names=self._names,
            noise=self._noise,
            jackknife=self._jackknife,
        )
        for name, value in zip(_GROUPS, self._as_vectors(new), strict=True):
            discrete_state.set_value(int(self._groups[name]), value)
