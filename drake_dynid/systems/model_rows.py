"""The ``ModelRows`` block: per-sample power or Lagrangian rows, packed."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydrake.systems.framework import (
    BasicVector,
    Context,
    InputPort,
    LeafSystem,
    OutputPort,
)

from drake_dynid.core import _validate
from drake_dynid.core.raw_rows import RawRowsDesign, raw_channels
from drake_dynid.core.rows import (
    check_model_kind,
    check_rows,
    num_channels,
    num_equations,
    pack_rows,
)

__all__ = ["ModelRows", "RawModelRows"]


class ModelRows(LeafSystem):
    r"""Per-sample rows (D, G, y) of the power or Lagrangian model, packed.

    .. pydrake_system::

        name: ModelRows
        input_ports:
        - q
        - v
        - tau
        output_ports:
        - channels

    For the signals of one instant (already aligned by the differentiator), the
    output packs the arrays of the modulated equation (docs/CONVENTIONS.md §3)

        -M_ġ(D(q, v))·θ + M_g(G(q, v))·θ = M_g(y(q, v, τ))

    as ``drake_dynid.core.rows.pack_rows(D, G, y)``: ``D``, ``G`` are ``m × p`` and
    ``y`` is ``m`` (m = 1 for the power model, n for the Lagrangian model; p base
    parameters). Units follow the base parameters: D·θ is an energy [J] (power
    model) or a momentum [N·m·s] (Lagrangian model).

    The output is computed from the inputs (direct feedthrough, no state); it is
    evaluated only when a downstream block reads it, e.g. at the bank's
    (decimated) update rate. A non-finite input gives NaN channels (the
    provider is not called), which the bank stores as an invalid sample. Double
    only: a plain Python ``LeafSystem`` has no AutoDiffXd or symbolic scalar
    conversion.
    """

    def __init__(self, rows: Any, kind: str = "lagrangian"):
        """Builds the block.

        Args:
            rows: a row provider (``drake_dynid.core.rows.RowProvider``, e.g. a
                ``drake_dynid.RobotModel``): ``num_joints``, ``num_parameters``,
                ``names`` and ``model_rows(kind, q, v, tau) -> (D, G, y)`` on
                batches (N, n).
            kind: ``"power"`` (the paper's model, m = 1) or ``"lagrangian"`` (m = n).
        """
        super().__init__()
        self._kind = check_model_kind("ModelRows", kind)
        n = check_rows("ModelRows", rows)
        self._rows = rows
        self._m = num_equations(kind, n)
        self._p = int(rows.num_parameters)
        self._num_channels = num_channels(self._m, self._p)
        # Providers with ``packed_rows(kind, q, v, tau)`` (one sample, packed as
        # ``pack_rows``) skip numpy's per-call overhead on (1, n) batches.
        self._packed = getattr(rows, "packed_rows", None)
        self._q = self.DeclareVectorInputPort("q", n)
        self._v = self.DeclareVectorInputPort("v", n)
        self._tau = self.DeclareVectorInputPort("tau", n)
        self._channels = self.DeclareVectorOutputPort(
            "channels", self._num_channels, self._CalcChannels
        )

    @property
    def kind(self) -> str:
        """The model kind, ``"power"`` or ``"lagrangian"``."""
        return self._kind

    @property
    def num_equations(self) -> int:
        """m, equations per sample."""
        return self._m

    @property
    def num_parameters(self) -> int:
        """p, base parameters."""
        return self._p

    def get_input_port_q(self) -> InputPort:
        """The input port ``q`` (n joint positions)."""
        return self._q

    def get_input_port_v(self) -> InputPort:
        """The input port ``v`` (n joint velocities)."""
        return self._v

    def get_input_port_tau(self) -> InputPort:
        """The input port ``tau`` (n joint torques)."""
        return self._tau

    def get_output_port_channels(self) -> OutputPort:
        """The output port ``channels`` (2·m·p + m packed rows)."""
        return self._channels

    def _CalcChannels(self, context: Context, output: BasicVector) -> None:
        q = self._q.Eval(context)
        v = self._v.Eval(context)
        tau = self._tau.Eval(context)
        if not (
            np.isfinite(q).all() and np.isfinite(v).all() and np.isfinite(tau).all()
        ):
            # No sample (a log's end, a dropout): NaN channels, which the bank
            # stores as an invalid sample; providers may reject non-finite input.
            output.SetFromVector(np.full(self._num_channels, np.nan))
            return
        if self._packed is not None:  # single-sample fast path (Planar2RRows)
            output.SetFromVector(self._packed(self._kind, q, v, tau))
            return
        d, g, y = self._rows.model_rows(self._kind, q[None, :], v[None, :], tau[None])
        output.SetFromVector(pack_rows(d[0], g[0], y[0]))


class RawModelRows(LeafSystem):
    r"""Model rows of the raw signals, averaged over one bank step, packed.

    .. pydrake_system::

        name: RawModelRows
        input_ports:
        - history
        output_ports:
        - channels

    The raw-rows counterpart of :class:`ModelRows` (``OnlineSettings.rows_from =
    "raw"``, ``drake_dynid.core.raw_rows``): from the differentiator's ``history``
    port (its ring of the last H samples of [q; τ], oldest first), the output is
    the mean over the newest D samples k of ``pack_rows(D, G, y)`` at
    ``(q_{k-m}, v_k', τ_{k-m})``, v' the central velocity estimate of the design,
    i.e. ``core.raw_rows.raw_channels``. Same units and layout as ``ModelRows``.

    Direct feedthrough from ``history``, no state; evaluated when the bank reads
    it (once per bank step: one batch of D rows). Double only.

    The ``history`` port carries no time: its samples must be ``design.time_step``
    apart, so the block is told the period of the differentiator that feeds it
    (``time_step``) and refuses another one (the velocity taps are in 1/s: a
    differentiator sampling every 0.5 ms read with a 1 ms design halved v'). The
    bank reading ``channels`` must update every ``design.block`` samples (its
    ``time_step`` is D·h), as ``diagrams.add_bank_front`` wires it.
    """

    def __init__(
        self,
        rows: Any,
        kind: str,
        design: RawRowsDesign,
        history_length: int,
        *,
        time_step: float,
    ):
        """Builds the block.

        Args:
            rows: a row provider (``drake_dynid.core.rows.RowProvider``).
            kind: ``"power"`` or ``"lagrangian"``.
            design: the raw-rows design (``OnlineSettings.raw_design``).
            history_length: H, samples of the ``history`` input (the
                differentiator's ``history_length``), >= ``design.history``.
            time_step: h, the period of the ``history``'s samples [s] (the
                differentiator's ``time_step``); must be ``design.time_step``.
        """
        super().__init__()
        owner = "RawModelRows"
        self._kind = check_model_kind(owner, kind)
        n = check_rows(owner, rows)
        if not isinstance(design, RawRowsDesign):
            raise TypeError(
                f"{owner}: design must be a core.raw_rows.RawRowsDesign; got "
                f"{type(design).__name__}."
            )
        h = _validate.positive(owner, "time_step", time_step, "s")
        if not math.isclose(h, design.time_step, rel_tol=1e-9):
            _validate.fail(
                owner,
                f"time_step must be the design's signal period {design.time_step:g} "
                f"s (the history's samples are the differentiator's); got {h:g} s: "
                "build the design on the differentiator's grid "
                "(settings.raw_design(differentiator.time_step)).",
            )
        length = _validate.integer(owner, "history_length", history_length, 1)
        if length < design.history:
            _validate.fail(
                owner,
                f"history_length must be >= {design.history} samples (raw window "
                f"+ bank step); got {length}.",
            )
        self._rows = rows
        self._design = design
        self._shape = (length, 2 * n)
        self._m = num_equations(kind, n)
        self._p = int(rows.num_parameters)
        self._history = self.DeclareVectorInputPort("history", length * 2 * n)
        self._channels = self.DeclareVectorOutputPort(
            "channels", num_channels(self._m, self._p), self._CalcChannels
        )

    @property
    def kind(self) -> str:
        """The model kind, ``"power"`` or ``"lagrangian"``."""
        return self._kind

    @property
    def num_equations(self) -> int:
        """m, equations per sample."""
        return self._m

    @property
    def num_parameters(self) -> int:
        """p, base parameters."""
        return self._p

    @property
    def time_step(self) -> float:
        """h, the period of the ``history``'s samples [s] (the design's)."""
        return self._design.time_step

    @property
    def design(self) -> RawRowsDesign:
        """The raw-rows design."""
        return self._design

    def get_input_port_history(self) -> InputPort:
        """The input port ``history`` (H samples of [q; τ], oldest first)."""
        return self._history

    def get_output_port_channels(self) -> OutputPort:
        """The output port ``channels`` (2·m·p + m averaged packed rows)."""
        return self._channels

    def _CalcChannels(self, context: Context, output: BasicVector) -> None:
        history = self._history.Eval(context).reshape(self._shape)
        output.SetFromVector(
            raw_channels(self._design, self._rows, self._kind, history)
        )
