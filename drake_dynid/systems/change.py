"""The ``ChangeTrackingIdentifier`` block: the sliding identifier with a change test."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiscreteValues, InputPort, OutputPort

from drake_dynid.core import _validate as check
from drake_dynid.core.change import (
    ChangeDesign,
    tracker_from_vector,
    tracker_init,
    tracker_outputs,
    tracker_vector,
    tracking_update,
)
from drake_dynid.systems.identifier import _GROUPS, SlidingQRIdentifier

__all__ = ["ChangeTrackingIdentifier"]


class ChangeTrackingIdentifier(SlidingQRIdentifier):
    r"""``SlidingQRIdentifier`` with change detection and restart (``core.change``).

    .. pydrake_system::

        name: ChangeTrackingIdentifier
        input_ports:
        - A
        - B
        - window_valid
        - window_signals (with covariance)
        - window_state
        output_ports:
        - theta
        - theta_std
        - condition_number
        - valid
        - unidentified
        - status
        - change
        - changed

    Every ``update_period`` the block solves the sliding window as its parent
    does, then runs ``core.change.tracking_update``: a CUSUM test on the equation
    error of the last second of bank samples (read from ``window_state``, the
    ``ModulatingIntegralBank``'s streaming state) against the estimate held; after
    a detection, the estimate of the segment since the change (the parameters
    found changed re-estimated, docs/MATH.md §4, change detection) until the
    window holds no older sample. Without a detection the outputs equal the parent's.

    Extra outputs: ``change`` = [1 at the solve that detected a change else 0,
    estimated time of the last change [s] (NaN before the first), 1 while the
    estimate comes from the segment since the change]; ``changed`` (p): 1 for the
    parameters re-estimated on that segment.

    State: the parent's groups (the reported estimate), ``change``, ``changed``,
    and ``tracker``, the tracker's numbers (``core.change.tracker_vector``: the
    window's own estimate, the CUSUM, the in-control mean squares, the segment's
    start). Double only.
    """

    def __init__(
        self,
        num_parameters: int,
        num_rows: int,
        update_period: float,
        design: ChangeDesign,
        **options: Any,
    ):
        """Builds the block.

        Args:
            num_parameters: p, unknowns.
            num_rows: r, rows of A and B.
            update_period: seconds between two solves [s].
            design: the test's design (``core.change.change_design``) for these
                p parameters.
            **options: the other ``SlidingQRIdentifier`` arguments.
        """
        owner = "ChangeTrackingIdentifier"
        if not isinstance(design, ChangeDesign):
            raise TypeError(
                f"{owner}: design must be a ChangeDesign (core.change.change_design); "
                f"got {type(design).__name__}."
            )
        if design.p != num_parameters:
            check.fail(
                owner,
                f"design must be for {num_parameters} parameters; got {design.p}.",
            )
        super().__init__(num_parameters, num_rows, update_period, **options)
        self._design = design
        tracker = tracker_init(design, options.get("initial_theta"))
        self._window_state = self.DeclareAbstractInputPort(
            "window_state", AbstractValue.Make(object())
        )
        self._tracker = self.DeclareDiscreteState(tracker_vector(tracker, design))
        flags = tracker_outputs(tracker, design)
        self._change = self.DeclareDiscreteState(flags[:3])
        self._changed = self.DeclareDiscreteState(flags[3:])
        self._change_ports = {
            "change": self.DeclareStateOutputPort("change", self._change),
            "changed": self.DeclareStateOutputPort("changed", self._changed),
        }

    @property
    def design(self) -> ChangeDesign:
        """The change test's design."""
        return self._design

    def get_input_port_window_state(self) -> InputPort:
        """The input port ``window_state`` (the bank's streaming state)."""
        return self._window_state

    def get_output_port_change(self) -> OutputPort:
        """The output port ``change`` (3: detected, change time [s], tracking)."""
        return self._change_ports["change"]

    def get_output_port_changed(self) -> OutputPort:
        """The output port ``changed`` (p: 1 for the re-estimated parameters)."""
        return self._change_ports["changed"]

    def _Solve(self, context: Context, discrete_state: DiscreteValues) -> None:
        ready = self._window_valid.Eval(context)[0] > 0.5
        a = self._a.Eval(context).reshape(self._r, self._p) if ready else None
        b = self._b.Eval(context) if ready else None
        vector = context.get_discrete_state(int(self._tracker)).get_value()
        window = check.having(
            "ChangeTrackingIdentifier",
            "window_state",
            self._window_state.Eval(context),
            ("count", "ring", "last_invalid"),
            "the bank's streaming state (connect the ModulatingIntegralBank's "
            "get_output_port_window_state())",
        )
        tracker, reported = tracking_update(
            tracker_from_vector(vector, self._design),
            self.state(context),
            self._design,
            ready,
            a,
            b,
            window,
            weighting=self._weighting,
            max_condition=self._max_condition,
            names=self._names,
            noise=self._noise,
            jackknife=self._jackknife,
            covariance=self._row_covariance(context, ready),
        )
        for name, value in zip(_GROUPS, self._as_vectors(reported), strict=True):
            discrete_state.set_value(int(self._groups[name]), value)
        discrete_state.set_value(
            int(self._tracker), tracker_vector(tracker, self._design)
        )
        flags = tracker_outputs(tracker, self._design)
        discrete_state.set_value(int(self._change), flags[:3])
        discrete_state.set_value(int(self._changed), np.asarray(flags[3:]))
