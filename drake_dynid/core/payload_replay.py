"""Log replay through the payload identifier's numerical core, vectorised.

:func:`replay_payload_core` computes what ``drake_dynid.payload_diagrams.
replay_payload_log`` (the Drake blocks in a Simulator) computes, to round-off,
without a Simulator (``tests/systems/test_payload_block.py`` checks it). The
timing is the on-line identifier's (docs/CONVENTIONS.md §2, ``core.replay``): the bank
updates at t_j + h/2 with the rows of sample j (filtered or raw rows of
``core.payload.PayloadRows``), the solver at t_u + 3h/4 with the bank's window
up to t_u (:func:`core.payload_step.payload_update`), and the trace records, at
t_s, the state after the solves before t_s. As ``core.replay``, the replay ends
with a final solve at the log's last sample t_{N-1} when that is not a solve time
(``core.replay.solve_samples``) and a final row at t_N = N·h
(``core.replay.logged_samples``): the final estimate's window ends with the log's
last bank sample, not up to two solve periods before it.
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
from drake_dynid.core.replay import bank_windows, logged_samples, solve_samples

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
    p = rows.num_parameters  # the payload's, the arm's error and the known columns
    names = rows.payload_names
    weighting = entry.row_weighting(m, bank)
    noise = entry.row_noise(m, bank)
    jackknife = payload_jackknife_groups(entry, m, bank)

    # Solves at t_u + 3h/4, u = 0, U, ... <= count - 1 and the final one at the
    # last sample (solve_samples); logs at t_s, s = 0, U, ... <= count and count.
    log_times = logged_samples(count, solve_every)
    solve_times = solve_samples(count, solve_every)
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
    windows = bank_windows(log, rows, entry, bank, m, p, solve_times)
    solves = iter(solve_times)
    u = next(solves, None)
    for index, s in enumerate(log_times):
        while u is not None and u < s:  # the solves at t_u + 3h/4 < t_s
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
                arm_columns=rows.num_arm_columns,
            )
            u = next(solves, None)
        # Record the state after the solves at t < t_s.
        estimate = state.estimate
        theta[index], std[index] = estimate.theta, estimate.std
        condition[index], valid[index] = estimate.condition_number, estimate.valid
        status[index], unidentified[index] = (
            float(estimate.status),
            estimate.unidentified,
        )
        correlation[index] = state.correlation
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
