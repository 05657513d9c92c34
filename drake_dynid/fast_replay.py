"""Log replay through the numerical core, vectorised (fast path of dynid identify).

:func:`replay_log_core` computes what :func:`drake_dynid.diagrams.replay_log` computes
(the same :class:`~drake_dynid.diagrams.OnlineTrace` per settings entry, to
round-off) without a Simulator: the Drake blocks stay the reference and
``tests/test_fast_replay.py`` checks the equality on a log.

The blocks' timing (docs/CONVENTIONS.md §2), with h the log period, D =
bank_time_step/h and U = update_period/h samples:

* the differentiator's state after its update at t_k holds samples 0..k; its
  outputs are the causal FIR ``ẑ_k = Σ_j taps[j] [q; τ]_{k-j}`` (zeros before the
  first sample), valid once k + 1 >= N + 1 taps;
* the bank updates at t_j + h/2 (j = 0, D, 2D, ...): it reads ``ẑ_j`` and pushes
  the model rows of that sample;
* the identifier solves at t_u + 3h/4 (u = 0, U, 2U, ...): its window ends with the
  bank sample pushed at t_u + h/2;
* a logger at t_s records the identifier state after the solves before t_s; the
  Simulator runs to t_N = N·h (one period after the last sample), so every sample
  is processed and the loggers publish up to t_N.

Vectorised: one FIR per filter over the whole log (only the columns the model
uses: the smoothed q and τ and the velocity of q), the rows of every decimated
sample in one batch call of ``rows.model_rows``, ``sliding_push_many`` between two
solves, and a least-squares solve only at the solve times. Cost per log sample:
a few µs, independent of the window T.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_dynid.core import lsq, modulating
from drake_dynid.core.jacobi import jacobi_batch, jacobi_filters
from drake_dynid.core.lsq import (
    STATUS_NOT_IDENTIFIABLE,
    STATUS_OK,
    STATUS_WINDOW_NOT_READY,
)
from drake_dynid.diagrams import (
    SOLVE_OFFSET,
    OnlineSettings,
    OnlineTrace,
    _check_rows,
)

__all__ = ["replay_log_core"]


def _steps(period: float, time_step: float, owner: str, name: str) -> int:
    ratio = period / time_step
    count = round(ratio)
    if count < 1 or abs(ratio - count) > 1e-9 * max(1.0, ratio):
        raise ValueError(
            f"{owner}: {name} must be a multiple of time_step [s]; got {period:g} "
            f"with time_step {time_step:g}."
        )
    return int(count)


def _differentiate(log: Any, entry: OnlineSettings):
    """(q̂, v̂, τ̂, valid) after the update at every t_k, and the delay [s]."""
    h = log.time_step
    smooth, velocity = jacobi_filters(
        (0, 1),
        entry.jacobi_window,
        h,
        kappa=entry.kappa,
        mu=entry.mu,
        q=entry.jacobi_q,
        matched=True,
    )
    signals = np.hstack([log.q, log.tau])
    n = log.q.shape[1]
    # A non-finite sample makes the block's outputs non-finite while it is in the
    # ring (N+1 updates), and the bank stores such samples as invalid: filter the
    # finite part and flag every output whose window holds a bad sample.
    bad = ~np.isfinite(signals).all(axis=1)
    if bad.any():
        signals = np.where(np.isfinite(signals), signals, 0.0)
    smoothed = jacobi_batch(smooth, signals)
    q_dot = jacobi_batch(velocity, signals[:, :n])
    count = log.num_samples
    valid = np.arange(count) + 1 >= smooth.num_taps
    if bad.any():
        poisoned = np.convolve(bad.astype(float), np.ones(smooth.num_taps))[:count]
        valid &= poisoned < 0.5
    return smoothed[:, :n], q_dot, smoothed[:, n:], valid, smooth.delay


def _replay_one(log: Any, rows: Any, entry: OnlineSettings, derived) -> OnlineTrace:
    owner = "replay_log_core"
    h = log.time_step
    count = log.num_samples
    q_hat, v_hat, tau_hat, jacobi_ok, jacobi_delay = derived
    decimation = _steps(entry.bank_time_step, h, owner, "bank_time_step")
    solve_every = _steps(entry.update_period, h, owner, "update_period")
    bank = entry.bank()
    m = 1 if entry.model == "power" else int(rows.num_joints)
    p = int(rows.num_parameters)
    names = tuple(rows.names)
    weighting = entry.row_weighting(m, bank)

    # Bank updates run at t_j + h/2, j = 0, D, ... <= count - 1, each pushing ẑ_j.
    bank_times = np.arange(0, count, decimation)
    picked = bank_times
    d_rows, g_rows, y_rows = rows.model_rows(
        entry.model, q_hat[picked], v_hat[picked], tau_hat[picked]
    )
    lead = len(picked)
    channels = np.concatenate(
        [d_rows.reshape(lead, -1), g_rows.reshape(lead, -1), y_rows.reshape(lead, -1)],
        axis=1,
    )
    sample_valid = jacobi_ok[picked]

    # Solves at t_u + 3h/4, u = 0, U, ... <= count - 1; logs at t_s, s = 0, U, ...
    # <= count.
    log_times = np.arange(0, count + 1, solve_every)
    num_logs = len(log_times)
    theta = np.zeros((num_logs, p))
    std = np.full((num_logs, p), np.inf)
    condition = np.full(num_logs, np.inf)
    valid = np.zeros(num_logs)
    status = np.zeros(num_logs)
    unidentified = np.zeros((num_logs, p))
    current_theta, current_std = np.zeros(p), np.full(p, np.inf)
    current_condition, current_valid = math.inf, 0.0
    # As SlidingQRIdentifier: status 1 (window not ready) until a solve; the
    # unidentified flags are those of the last solve.
    current_status, current_unidentified = float(STATUS_WINDOW_NOT_READY), np.zeros(p)
    state = modulating.sliding_init(bank, channels.shape[1])
    pushed = 0
    for index, s in enumerate(log_times):
        # Record the state after the solves at t < t_s.
        theta[index], std[index] = current_theta, current_std
        condition[index], valid[index] = current_condition, current_valid
        status[index], unidentified[index] = current_status, current_unidentified
        if s > count - 1:
            break
        # Solve at t_s + 3h/4: after the bank updates at t_j + h/2, t_j <= t_s.
        upto = int(np.searchsorted(bank_times, s, side="right"))
        if upto > pushed:
            state = modulating.sliding_push_many(
                bank,
                state,
                channels[pushed:upto],
                valid=sample_valid[pushed:upto],
            )
            pushed = upto
        if not modulating.window_valid(state):
            current_valid = 0.0
            current_status = float(STATUS_WINDOW_NOT_READY)
            continue
        integrals = modulating.sliding_fourier_integrals(bank, state)
        a, b = modulating.assemble_equations(bank, integrals, m, p)
        result = lsq.solve_window(
            a, b, weighting, max_condition=entry.max_condition, names=names
        )
        current_condition = result.condition_number
        current_unidentified = np.zeros(p)
        if result.valid:
            current_theta, current_std = result.theta.copy(), result.std.copy()
            current_valid = 1.0
            current_status = float(STATUS_OK)
        else:
            current_valid = 0.0
            current_status = float(STATUS_NOT_IDENTIFIABLE)
            current_unidentified[list(result.unidentified_indices)] = 1.0
    return OnlineTrace(
        settings=entry,
        names=names,
        t=log_times * h,
        theta=theta,
        std=std,
        condition_number=condition,
        valid=valid,
        delay=jacobi_delay + SOLVE_OFFSET * h,
        status=status,
        unidentified=unidentified,
    )


def replay_log_core(
    log: Any,
    rows: Any,
    settings: Sequence[OnlineSettings],
    *,
    progress: bool = False,
) -> list[OnlineTrace]:
    """Replays a log through the on-line identifier's core, without a Simulator.

    Same arguments and result as :func:`drake_dynid.diagrams.replay_log` (the
    reference, equal to round-off: see the module docstring for the timing it
    reproduces); ``progress`` is accepted for the same signature and ignored (the
    replay takes a fraction of a second per minute of log).

    Args:
        log: a ``drake_dynid.logs.RobotLog``.
        rows: row provider (``RobotModel.rows_provider()``): ``num_joints``,
            ``num_parameters``, ``names``, batch ``model_rows(kind, q, v, tau)``.
        settings: one entry per identifier; entries with the same Jacobi
            settings share the differentiated signals.
        progress: ignored.

    Returns:
        One :class:`~drake_dynid.diagrams.OnlineTrace` per settings entry, with
        times relative to the first sample of the log.
    """
    del progress
    n = _check_rows("replay_log_core", rows)
    if log.q.shape[1] != n or log.tau.shape[1] != n:
        raise ValueError(
            f"replay_log_core: the log has {log.q.shape[1]} joints; the robot has {n}."
        )
    for entry in settings:
        if not isinstance(entry, OnlineSettings):
            raise TypeError(
                "replay_log_core: settings must be OnlineSettings; got "
                f"{type(entry).__name__}."
            )
    shared: dict[tuple, Any] = {}
    traces = []
    for entry in settings:
        key = (entry.jacobi_window, entry.kappa, entry.mu, entry.jacobi_q)
        if key not in shared:
            shared[key] = _differentiate(log, entry)
        traces.append(_replay_one(log, rows, entry, shared[key]))
    return traces
