"""What the identifier blocks share: settings checks, ports, state groups.

``SlidingQRIdentifier`` (systems/identifier.py) and ``PayloadIdentifier``
(systems/payload.py) both solve the bank's window ``A``, ``B`` every
``update_period`` seconds when ``window_valid`` is 1, with the same solve
settings (weighting, the rows' noise, jackknife groups, condition limit), and keep
one discrete state group per output port (theta, theta_std, condition_number,
valid, unidentified, status, ...). This mixin holds that plumbing; each block
keeps its own step (``core.identifier.identifier_update`` or
``core.payload_step.payload_update``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.systems.framework import Context, InputPort, OutputPort

from drake_dynid.core import _validate as check
from drake_dynid.core.identifier import IdentifierState, Status

__all__ = ["ESTIMATE_GROUPS", "SolverBlock"]

#: The state groups of an estimate, in declaration order (p: the parameters).
ESTIMATE_GROUPS = (
    "theta",
    "theta_std",
    "condition_number",
    "valid",
    "unidentified",
    "status",
)


def estimate_vectors(state: IdentifierState) -> tuple[np.ndarray, ...]:
    """The values of :data:`ESTIMATE_GROUPS` for ``state``."""
    return (
        state.theta,
        state.std,
        np.array([state.condition_number]),
        np.array([1.0 if state.valid else 0.0]),
        state.unidentified,
        np.array([float(state.status)]),
    )


def _indices(owner: str, name: str, value: Any, r: int) -> np.ndarray:
    """(r,) whole numbers (group indices) as ints; 0.7 truncated to 0 before."""
    array = check.array(owner, name, value, (r,))
    if not np.array_equal(array, np.round(array)):
        check.fail(
            owner, f"{name} must hold whole numbers (group indices); got {array}."
        )
    return array.astype(int)


class SolverBlock:
    """Mixin of a ``LeafSystem`` that solves the bank's window (module docstring)."""

    # Set by _configure and _declare (the LeafSystem's own API is inherited).
    _period: float
    _p: int
    _r: int
    _a: InputPort
    _b: InputPort
    _window_valid: InputPort
    _groups: dict[str, Any]
    _outputs: dict[str, OutputPort]

    def _configure(
        self,
        owner: str,
        num_parameters: int,
        num_rows: int,
        update_period: float,
        offset: float,
        max_condition: float,
        names: Sequence[str] | None,
        row_weighting: tuple[Any, Any] | None,
        row_noise: Any,
        jackknife_groups: Any,
    ) -> float:
        """Checks and stores the solve settings; returns the checked offset [s]."""
        p = check.integer(owner, "num_parameters", num_parameters, 1)
        r = check.integer(owner, "num_rows", num_rows, 1)
        if r <= p:
            check.fail(
                owner,
                f"num_rows must exceed num_parameters: {r} rows cannot identify {p} "
                "parameters and their σ (the residual needs degrees of freedom); "
                "give the bank more rows (ModulatingIntegralBank.num_rows).",
            )
        self._period = check.positive(owner, "update_period", update_period, "s")
        offset = check.real(owner, "offset", offset, "s")
        if offset < 0.0:
            check.fail(owner, f"offset must be >= 0 [s]; got {offset}.")
        self._max_condition = check.greater_than(
            owner, "max_condition", max_condition, 1.0
        )
        if isinstance(names, str):  # len("abc") == 3 took each letter as a name
            raise TypeError(
                f"{owner}: names must be a sequence of {p} parameter names; got the "
                f"string {names!r}."
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
                _indices(owner, "row_group", group, r),
            )
        if row_noise is not None and not hasattr(row_noise, "num_rows"):
            raise TypeError(
                f"{owner}: row_noise must be a core.row_noise.RowNoise "
                f"(OnlineSettings.row_noise) or None; got {type(row_noise).__name__}."
            )
        if row_noise is not None and row_noise.num_rows != r:
            check.fail(
                owner, f"row_noise must describe {r} rows; got {row_noise.num_rows}."
            )
        self._noise = row_noise
        self._jackknife = None
        if jackknife_groups is not None:
            self._jackknife = _indices(owner, "jackknife_groups", jackknife_groups, r)
        return offset

    def _declare(
        self,
        columns: int,
        groups: Sequence[str],
        values: Sequence[np.ndarray],
        offset: float,
        solve: Any,
        state_only: Sequence[str] = (),
    ) -> None:
        """Ports ``A`` (r × columns), ``B``, ``window_valid``; state and outputs.

        Every group of ``groups`` is a state output port, but those named in
        ``state_only`` (internal state).
        """
        system: Any = self
        self._a = system.DeclareVectorInputPort("A", self._r * columns)
        self._b = system.DeclareVectorInputPort("B", self._r)
        self._window_valid = system.DeclareVectorInputPort("window_valid", 1)
        self._groups = {
            name: system.DeclareDiscreteState(value)
            for name, value in zip(groups, values, strict=True)
        }
        system.DeclarePeriodicDiscreteUpdateEvent(self._period, offset, solve)
        system.DeclareForcedDiscreteUpdateEvent(solve)  # on demand: one solve
        self._outputs = {
            name: system.DeclareStateOutputPort(name, index)
            for name, index in self._groups.items()
            if name not in state_only
        }

    @property
    def update_period(self) -> float:
        """Seconds between two solves."""
        return self._period

    def get_input_port_A(self) -> InputPort:
        """The input port ``A`` (the window's equations, row-major)."""
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

    def _value(self, context: Context, name: str) -> np.ndarray:
        return context.get_discrete_state(int(self._groups[name])).get_value()

    def _estimate(self, context: Context) -> IdentifierState:
        """The estimate's groups in ``context`` (copies)."""
        return IdentifierState(
            theta=self._value(context, "theta").copy(),
            std=self._value(context, "theta_std").copy(),
            condition_number=float(self._value(context, "condition_number")[0]),
            valid=bool(self._value(context, "valid")[0] > 0.5),
            unidentified=self._value(context, "unidentified").copy(),
            status=Status(int(self._value(context, "status")[0])),
        )
