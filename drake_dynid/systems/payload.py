"""The ``PayloadIdentifier`` block: the payload's parameters on the bank's window."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.systems.framework import (
    Context,
    DiscreteValues,
    LeafSystem,
    OutputPort,
)

from drake_dynid.core import _validate as check
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION
from drake_dynid.core.payload_noise import PooledNoise, pooled_noise_init
from drake_dynid.core.payload_step import PayloadState, payload_init, payload_update
from drake_dynid.systems._solver_block import (
    ESTIMATE_GROUPS,
    SolverBlock,
    estimate_vectors,
)

__all__ = ["PayloadIdentifier"]

# State groups in declaration order; each is also an output port of the same name,
# but the pooled row noise (core.payload_noise: P_i; N, count, refused).
_POOL = ("noise_moments", "noise_counts")
_GROUPS = (*ESTIMATE_GROUPS, "correlation", *_POOL)


class PayloadIdentifier(SolverBlock, LeafSystem):
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
    a state output port (no direct feedthrough), and the rows' noise pooled
    across windows (``core.payload_noise.PooledNoise``: noise_moments (r),
    noise_counts (3)), internal. Double only: a plain Python
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
        arm_columns: int = 0,
    ):
        """Builds the block.

        Args:
            num_parameters: p, the payload's base parameters (``A`` has
                p + k + 1 columns).
            num_rows: r, rows of A and B (``ModulatingIntegralBank.num_rows``).
            update_period: seconds between two solves [s].
            max_condition: largest accepted condition number of the column-scaled
                A[:, :p].
            names: the p payload names (for messages).
            offset: time of the first update [s] (>= 0); behind a bank fed
                every h, ``core.online.SOLVE_OFFSET``·h, as for the
                ``SlidingQRIdentifier``.
            row_weighting: ``(row_frequency, row_group)`` of the rows
                (``OnlineSettings.row_weighting``), or None: ordinary least
                squares.
            row_noise: the rows' ``core.row_noise.RowNoise``
                (``OnlineSettings.row_noise``), or None: Gautier's σ.
            jackknife_groups: (r,) the jackknife group of each row
                (``OnlineSettings.jackknife_groups``), or None.
            arm_columns: k, the arm's error columns of ``A``
                (``core.payload.PayloadRows.num_arm_columns``; their image adds
                to σ, ``core.payload_step.payload_update``).
        """
        super().__init__()
        offset = self._configure(
            "PayloadIdentifier",
            num_parameters,
            num_rows,
            update_period,
            offset,
            max_condition,
            names,
            row_weighting,
            row_noise,
            jackknife_groups,
        )
        self._k = check.integer("PayloadIdentifier", "arm_columns", arm_columns, 0)
        self._declare(
            self._p + self._k + 1,
            _GROUPS,
            self._as_vectors(payload_init(self._p)),
            offset,
            self._Solve,
            state_only=_POOL,
        )

    def get_output_port_correlation(self) -> OutputPort:
        """The output port ``correlation`` (p × p, row-major)."""
        return self._outputs["correlation"]

    def state(self, context: Context) -> PayloadState:
        """The identifier's state in ``context`` (``core.payload_step``)."""
        p = self._p
        correlation = self._value(context, "correlation").reshape(p, p).copy()
        weight, count, refused = self._value(context, "noise_counts")
        pool = None
        if count > 0:
            moments = self._value(context, "noise_moments").copy()
            moments.flags.writeable = False
            pool = PooledNoise(moments, float(weight), int(count), int(refused))
        return PayloadState(self._estimate(context), correlation, pool)

    def _as_vectors(self, state: PayloadState) -> tuple[np.ndarray, ...]:
        pool = state.pool if state.pool is not None else pooled_noise_init(self._r)
        return (
            *estimate_vectors(state.estimate),
            state.correlation.reshape(-1),
            pool.moments,
            np.array([pool.weight, pool.count, pool.refused], dtype=float),
        )

    def _Solve(self, context: Context, discrete_state: DiscreteValues) -> None:
        ready = self._window_valid.Eval(context)[0] > 0.5
        columns = self._p + self._k + 1
        a = self._a.Eval(context).reshape(self._r, columns) if ready else None
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
            arm_columns=self._k,
        )
        for name, value in zip(_GROUPS, self._as_vectors(new), strict=True):
            discrete_state.set_value(int(self._groups[name]), value)
