"""Diagram builders of the payload identifier: its chain and the replay of a log.

The chain is the on-line identifier's (``drake_dynid.diagrams``), on the rows of
a payload (``drake_dynid.core.payload.PayloadRows``: the payload's columns and the
arm's known column) and ending in the ``PayloadIdentifier`` block::

    [q; τ] ──► CausalJacobiDifferentiator ──► ModelRows (or RawModelRows, from
    the ring) ──► ModulatingIntegralBank ──A, B──► PayloadIdentifier
    ──► θ̂ (payload), σ, cond, valid, status, correlation

with the same event offsets (docs/CONVENTIONS.md §2) and the same settings
(``core.payload_step.payload_settings``). :func:`replay_payload_log` runs it over
a recorded log in a Simulator; ``core.payload_replay.replay_payload_core`` gives
the same trace without one (``tests/systems/test_payload_block.py``), both ending
with the final solve at the log's last sample, recorded at t_N = N·h
(``core.replay.solve_samples``, ``drake_dynid.diagrams.final_row``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core._threads import thread_limit
from drake_dynid.core.online import (
    SOLVE_OFFSET,
    OnlineSettings,
)
from drake_dynid.core.payload import PayloadRows
from drake_dynid.core.payload_replay import PayloadTrace
from drake_dynid.core.payload_step import (
    check_payload_weighting,
    payload_jackknife_groups,
)
from drake_dynid.diagrams import (
    IdentifierChain,
    add_bank_front,
    advance,
    chain_logs,
    check_measurement,
    final_row,
    log_source,
    with_final_row,
)

__all__ = ["add_payload_identifier", "payload_chain_trace", "replay_payload_log"]

#: The identifier's ports the chain logs at the solve period.
_LOGGED = (
    "theta",
    "theta_std",
    "condition_number",
    "valid",
    "status",
    "unidentified",
    "correlation",
)


def add_payload_identifier(
    builder: Any,
    rows: PayloadRows,
    measurement: Any,
    time_step: float,
    settings: OnlineSettings,
    *,
    differentiator: Any = None,
    log: bool = True,
) -> IdentifierChain:
    """Adds the payload identifier fed by a measurement port [q; τ] of the arm.

    As ``drake_dynid.diagrams.add_online_identifier`` (settings put on the
    measurement's grid first; the same differentiator, rows and bank blocks),
    with a ``PayloadIdentifier`` at the end.

    Args:
        builder: the ``DiagramBuilder``.
        rows: the payload's rows (``core.payload.payload_rows``).
        measurement: output port of size 2n carrying [q; τ] sampled at
            ``time_step``.
        time_step: sample period h of the measurement [s].
        settings: identifier settings (``core.payload_step.payload_settings``).
        differentiator: reuse an existing ``CausalJacobiDifferentiator`` with the
            same Jacobi settings (period, size and filters checked: ValueError).
        log: add loggers of every output of the identifier at the solve period.

    Returns:
        Handles to the blocks and loggers (``identifier`` is the
        ``PayloadIdentifier``; ``names`` the payload's base parameters).
    """
    from pydrake.systems.primitives import LogVectorOutput

    from drake_dynid.systems.payload import PayloadIdentifier

    owner = "add_payload_identifier"
    check.instance(owner, "rows", rows, PayloadRows, "a PayloadRows (payload_rows)")
    check.instance(owner, "settings", settings, OnlineSettings, "an OnlineSettings")
    check_payload_weighting(owner, settings)
    n = rows.num_joints
    check_measurement(owner, measurement, n)
    settings = settings.on_grid(time_step)
    differentiator, model_rows, bank, design = add_bank_front(
        builder, rows, settings, measurement, time_step, differentiator, owner=owner
    )
    m = model_rows.num_equations
    names = rows.payload_names
    identifier = builder.AddSystem(
        PayloadIdentifier(
            rows.num_payload,
            bank.num_rows,
            settings.resolved("update_period"),
            max_condition=settings.max_condition,
            names=names,
            offset=SOLVE_OFFSET * time_step,
            row_weighting=settings.row_weighting(m, design),
            row_noise=settings.row_noise(m, design),
            jackknife_groups=payload_jackknife_groups(settings, m, design),
            arm_columns=rows.num_arm_columns,
        )
    )
    builder.Connect(bank.get_output_port_A(), identifier.get_input_port_A())
    builder.Connect(bank.get_output_port_B(), identifier.get_input_port_B())
    builder.Connect(
        bank.get_output_port_valid(), identifier.get_input_port_window_valid()
    )
    chain = IdentifierChain(
        settings, names, differentiator, model_rows, bank, identifier
    )
    if log:
        for port in _LOGGED:
            chain.logs[port] = LogVectorOutput(
                identifier.GetOutputPort(port),
                builder,
                settings.resolved("update_period"),
            )
    return chain


def payload_chain_trace(
    chain: IdentifierChain, context: Any, time_step: float
) -> PayloadTrace:
    """The estimates a payload chain's loggers recorded, as a ``PayloadTrace``.

    Raises:
        ValueError: the chain has no loggers (built with ``log=False``), or
            ``time_step`` is not its signal period.
    """
    logs = chain_logs("payload_chain_trace", chain, context, time_step, _LOGGED)
    p = len(chain.names)
    correlation = logs["correlation"].data().T.reshape(-1, p, p).copy()
    return PayloadTrace(
        settings=chain.settings,
        names=chain.names,
        t=logs["theta"].sample_times().copy(),
        theta=logs["theta"].data().T.copy(),
        std=logs["theta_std"].data().T.copy(),
        condition_number=logs["condition_number"].data()[0].copy(),
        valid=logs["valid"].data()[0].copy(),
        delay=chain.settings.delay(time_step) + SOLVE_OFFSET * time_step,
        status=logs["status"].data()[0].copy(),
        unidentified=logs["unidentified"].data().T.copy(),
        correlation=correlation,
    )


def replay_payload_log(
    log: Any, rows: PayloadRows, settings: OnlineSettings, *, progress: bool = False
) -> PayloadTrace:
    """Runs the payload identifier's blocks over a recorded log in a Simulator.

    The log is played by ``drake_dynid.diagrams.log_source`` (sample k held over
    [t_k - h/2, t_k + h/2)) and the Simulator runs to t_N = N·h, as
    ``drake_dynid.diagrams.replay_log``; the trace ends, as that one's, with the
    final solve at the last sample t_{N-1}, recorded at t_N
    (``drake_dynid.diagrams.final_row``).

    Args:
        log: a ``drake_dynid.logs.RobotLog`` of the arm.
        rows: the payload's rows.
        settings: the identifier's settings.
        progress: print the progress on stderr.
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    owner = "replay_payload_log"
    check.having(
        owner, "log", log, ("q", "tau", "time_step", "num_samples"), "a RobotLog"
    )
    check.instance(owner, "rows", rows, PayloadRows, "a PayloadRows (payload_rows)")
    n = rows.num_joints
    if log.q.shape[1] != n or log.tau.shape[1] != n:
        check.fail(owner, f"the log has {log.q.shape[1]} joints; the robot has {n}.")
    h = log.time_step
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    chain = add_payload_identifier(builder, rows, source.get_output_port(), h, settings)
    simulator = Simulator(builder.Build())
    with thread_limit():
        simulator.Initialize()
        advance(simulator, float(h * log.num_samples), progress, "dynid payload")
        context = simulator.get_mutable_context()
        trace = payload_chain_trace(chain, context, h)
        keep, row = final_row(chain, context, log.num_samples, h)
    p = len(chain.names)
    correlation = np.reshape(row["correlation"], (p, p))
    return with_final_row(
        trace, keep, row, log.num_samples * h, {"correlation": correlation}
    )
