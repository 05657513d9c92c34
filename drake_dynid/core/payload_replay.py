"""Log replay through the payload identifier's numerical core, vectorised.

:func:`replay_payload_core` computes what ``drake_dynid.payload_diagrams.
replay_payload_log`` (the Drake blocks in a Simulator) computes, to round-off,
without a Simulator (``tests/systems/test_payload_block.py`` checks it). The
timing is the on-line identifier's (docs/CONVENTIONS.md §2, ``core.replay``): the bank
updates at t_j + h/2 with the rows of sample j (filtered or raw rows of
``core.payload.PayloadRows``), the solver at t_u + 3h/4 with the bank's window
up to t_u (:func:`core.payload_step.payload_update`), and the trace records, at
t_s, the state after the solves before t_s.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core._threads import thread_limit
from drake_dynid.core.online import SOLVE_OFFSET, OnlineSettings, OnlineTrace
from drake_dynid.core.payload import PayloadRows
from drake_dynid.core.payload_step import (
    check_payload_weighting,
    payload_init,
    payload_jackknife_groups,
    payload_update,
)
from drake_dynid.core.replay import bank_windows

__all__ = ["PayloadTrace", "replay_payload_core"]


@dataclass
class PayloadTrace(OnlineTrace):
    """The payload estimates over time, with the correlation of their errors.

    An ``OnlineTrace`` of the payload's base parameters (``names``).

    Attributes:
        correlation: (M, p, p) the errors' correlation at the last accepted solve
            (``core.payload_step.solve_correlation``; identity before it).
    """

    correlation: np.ndarray = field(default_factory=lambda: np.zeros((0, 0, 0)))


def _replay(log: Any, rows: PayloadRows, entry: OnlineSettings) -> PayloadTrace:
    h = log.time_step
    count = log.num_samples
    solve_every = entry.solve_decimation(h)
    bank = entry.bank()
    m = entry.num_equations(rows.num_joints)
    p = rows.num_parameters  # the payload's columns and the known one
    names = rows.payload_names
    weighting = entry.row_weighting(m, bank)
    noise = entry.row_noise(m, bank)
    jackknife = payload_jackknife_groups(entry, m, bank)

    log_times = np.arange(0, count + 1, solve_every)
    num_logs = len(log_times)
    size = len(names)
    theta = np.zeros((num_logs, size))
    std = np.full((num_logs, size), np.inf)
    condition = np.full(num_logs, np.inf)
    valid = np.zeros(num_logs)
    status = np.zeros(num_logs)
    unidentified = np.zeros((num_logs, size))
    correlation = np.zeros((num_logs, size, size))
    state = payload_init(size)
    windows = bank_windows(log, rows, entry, bank, m, p, log_times)
    for index, s in enumerate(log_times):
        estimate = state.estimate
        theta[index], std[index] = estimate.theta, estimate.std
        condition[index], valid[index] = estimate.condition_number, estimate.valid
        status[index], unidentified[index] = (
            float(estimate.status),
            estimate.unidentified,
        )
        correlation[index] = state.correlation
        if s > count - 1:
            break
        ready, a, b, _ = next(windows)
        state = payload_update(
            state,
            ready,
            a,
            b,
            weighting=weighting,
            max_condition=entry.max_condition,
            names=names,
            noise=noise,
            jackknife=jackknife,
        )
    return PayloadTrace(
        settings=entry,
        names=names,
        t=log_times * h,
        theta=theta,
        std=std,
        condition_number=condition,
        valid=valid,
        delay=entry.delay(h) + SOLVE_OFFSET * h,
        status=status,
        unidentified=unidentified,
        correlation=correlation,
    )


def replay_payload_core(
    log: Any, rows: PayloadRows, settings: OnlineSettings
) -> PayloadTrace:
    """Replays a log through the payload identifier's core, without a Simulator.

    Args:
        log: a ``drake_dynid.logs.RobotLog`` of the arm (``q``, ``tau`` (N, n),
            ``time_step``, ``num_samples``).
        rows: the payload's rows (``core.payload.payload_rows``).
        settings: the identifier's settings (``core.payload_step.
            payload_settings``), put on the log's grid (``OnlineSettings.on_grid``).

    Returns:
        The :class:`PayloadTrace`, times relative to the log's first sample.
    """
    owner = "replay_payload_core"
    check.having(
        owner, "log", log, ("q", "tau", "time_step", "num_samples"), "a RobotLog"
    )
    check.instance(owner, "rows", rows, PayloadRows, "a PayloadRows (payload_rows)")
    check.instance(owner, "settings", settings, OnlineSettings, "an OnlineSettings")
    check_payload_weighting(owner, settings)
    check.log_magnitudes(owner, log.q, log.tau)
    n = rows.num_joints
    if log.q.shape[1] != n or log.tau.shape[1] != n:
        check.fail(owner, f"the log has {log.q.shape[1]} joints; the robot has {n}.")
    with thread_limit():
        return _replay(log, rows, settings.on_grid(log.time_step))
