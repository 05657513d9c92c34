"""Log replay through the on-line identifier's numerical core, vectorised.

:func:`replay_log_core` computes what ``drake_dynid.diagrams.replay_log`` (the Drake
blocks in a Simulator) computes, the same :class:`~drake_dynid.core.online.OnlineTrace`
per settings entry to round-off, without a Simulator: the blocks stay the
reference and ``tests/test_fast_replay.py`` checks the equality on a log. Both
drivers share the settings, the filters, the bank and the identifier step
(:mod:`drake_dynid.core.online`, :mod:`drake_dynid.core.identifier`).

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

Vectorised: one FIR per filter over the whole log (:func:`filtered_signals`: the
smoothed q and τ and the velocity of q), the rows of every decimated sample in one
batch call of ``rows.model_rows`` (:func:`bank_channels`), the bank's
``push_many`` between two solves, and a solve only at the solve times. Cost per
log sample: a few µs, independent of the window T. :func:`window_estimate` solves
one window by direct quadrature (the reference the accuracy benchmark uses;
:func:`window_equations` gives its equations).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_dynid.core.equations import assemble_equations, direct_fourier_integrals
from drake_dynid.core.identifier import identifier_init, identifier_update
from drake_dynid.core.jacobi_stream import jacobi_batch
from drake_dynid.core.lsq import LeastSquaresResult, solve_window
from drake_dynid.core.online import SOLVE_OFFSET, OnlineSettings, OnlineTrace
from drake_dynid.core.raw_rows import raw_channels_batch
from drake_dynid.core.rows import check_rows, num_channels, pack_rows

__all__ = [
    "bank_channels",
    "filtered_signals",
    "replay_log_core",
    "window_equations",
    "window_estimate",
]

Signals = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]


def filtered_signals(
    q: np.ndarray, tau: np.ndarray, settings: OnlineSettings, time_step: float
) -> Signals:
    """The differentiator's outputs after its update at every sample.

    ``(q̂, v̂, τ̂, valid, delay)``: the matched Jacobi filters of ``settings``
    (:meth:`OnlineSettings.jacobi_filters`) applied causally to the whole log,
    each (N, n); ``valid`` (N,) is True once N + 1 taps are filled and no
    non-finite sample is in the filter's window (such samples are filtered as
    zeros, as the block's outputs are invalid while they are in its ring);
    ``delay`` [s] is the filters' delay.
    """
    smooth, velocity = settings.jacobi_filters(time_step)
    signals = np.hstack([q, tau])
    n = q.shape[1]
    bad = ~np.isfinite(signals).all(axis=1)
    if bad.any():
        signals = np.where(np.isfinite(signals), signals, 0.0)
    smoothed = jacobi_batch(smooth, signals)
    q_dot = jacobi_batch(velocity, signals[:, :n])
    count = signals.shape[0]
    valid = np.arange(count) + 1 >= smooth.num_taps
    if bad.any():
        poisoned = np.convolve(bad.astype(float), np.ones(smooth.num_taps))[:count]
        valid &= poisoned < 0.5
    return smoothed[:, :n], q_dot, smoothed[:, n:], valid, smooth.delay


def bank_channels(
    rows: Any, model: str, q_hat: Any, v_hat: Any, tau_hat: Any
) -> np.ndarray:
    """Packed model rows ``pack_rows(*rows.model_rows(model, q̂, v̂, τ̂))``: (N, c)."""
    return pack_rows(*rows.model_rows(model, q_hat, v_hat, tau_hat))


def _replay_one(
    log: Any, rows: Any, entry: OnlineSettings, signals: Signals
) -> OnlineTrace:
    h = log.time_step
    count = log.num_samples
    q_hat, v_hat, tau_hat, jacobi_ok, jacobi_delay = signals
    decimation = entry.decimation(h)
    solve_every = entry.solve_decimation(h)
    bank = entry.bank()
    m = entry.num_equations(int(rows.num_joints))
    p = int(rows.num_parameters)
    names = tuple(rows.names)
    weighting = entry.row_weighting(m, bank)
    jackknife = entry.jackknife_groups(m, bank)

    # Bank updates run at t_j + h/2, j = 0, D, ... <= count - 1, each pushing ẑ_j
    # (filtered rows) or the mean rows of the raw samples j - D + 1 .. j (raw rows,
    # read from the differentiator's ring: valid once the ring is full, invalid
    # when a sample read is not finite, as in the blocks).
    bank_times = np.arange(0, count, decimation)
    if entry.rows_from == "raw":
        full = bank_times + 1 >= entry.jacobi_filters(h)[0].num_taps
        channels = np.zeros((bank_times.size, num_channels(m, p)))
        if full.any():
            channels[full] = raw_channels_batch(
                entry.raw_design(h), rows, entry.model, log.q, log.tau, bank_times[full]
            )
        sample_valid = full & np.isfinite(channels).all(axis=1)
    else:
        channels = bank_channels(
            rows,
            entry.model,
            q_hat[bank_times],
            v_hat[bank_times],
            tau_hat[bank_times],
        )
        sample_valid = jacobi_ok[bank_times]

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
    state = identifier_init(p)
    window = bank.init_state(channels.shape[1])
    pushed = 0
    for index, s in enumerate(log_times):
        # Record the state after the solves at t < t_s.
        theta[index], std[index] = state.theta, state.std
        condition[index], valid[index] = state.condition_number, float(state.valid)
        status[index], unidentified[index] = float(state.status), state.unidentified
        if s > count - 1:
            break
        # Solve at t_s + 3h/4: after the bank updates at t_j + h/2, t_j <= t_s.
        upto = int(np.searchsorted(bank_times, s, side="right"))
        if upto > pushed:
            window = bank.push_many(
                window, channels[pushed:upto], valid=sample_valid[pushed:upto]
            )
            pushed = upto
        ready = bank.window_valid(window)
        a, b = bank.equations(window, m, p) if ready else (None, None)
        state = identifier_update(
            state,
            ready,
            a,
            b,
            weighting=weighting,
            max_condition=entry.max_condition,
            names=names,
            jackknife=jackknife,
        )
    return OnlineTrace(
        settings=entry,
        names=names,
        t=log_times * h,
        theta=theta,
        std=std,
        condition_number=condition,
        valid=valid,
        delay=(entry.delay(h) if entry.rows_from == "raw" else jacobi_delay)
        + SOLVE_OFFSET * h,
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

    Same arguments and result as ``drake_dynid.diagrams.replay_log`` (the
    reference, equal to round-off: see the module docstring for the timing it
    reproduces); ``progress`` is accepted for the same signature and ignored (the
    replay takes a fraction of a second per minute of log).

    Args:
        log: a ``drake_dynid.logs.RobotLog`` (``q``, ``tau`` (N, n),
            ``time_step``, ``num_samples``).
        rows: row provider (``RobotModel.rows_provider()``): ``num_joints``,
            ``num_parameters``, ``names``, batch ``model_rows(kind, q, v, tau)``.
        settings: one entry per identifier, put on the log's grid
            (:meth:`OnlineSettings.on_grid`); entries with the same Jacobi
            settings share the differentiated signals.
        progress: ignored.

    Returns:
        One :class:`~drake_dynid.core.online.OnlineTrace` per settings entry, with
        times relative to the first sample of the log.
    """
    del progress
    n = check_rows("replay_log_core", rows)
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
    shared: dict[tuple, Signals] = {}
    traces = []
    for raw in settings:
        entry = raw.on_grid(log.time_step)
        key = tuple(entry.jacobi_parameters().values())
        if key not in shared:
            shared[key] = filtered_signals(log.q, log.tau, entry, log.time_step)
        traces.append(_replay_one(log, rows, entry, shared[key]))
    return traces


def window_equations(
    rows: Any,
    settings: OnlineSettings,
    q: np.ndarray,
    tau: np.ndarray,
    end: int,
    time_step: float,
    *,
    signals: Sequence[Any] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The modulated equations ``A θ = B`` of one window, by direct quadrature.

    The window's newest bank sample is the one pushed at signal sample ``end``;
    its samples are ``end - j·D``, j = N_bank .. 0 (D = bank_time_step/h): the
    filtered rows of the differentiator's outputs there, or the raw rows
    (``core.raw_rows.raw_channels_batch``), then
    ``core.equations.direct_fourier_integrals`` instead of the sliding sums.

    Args:
        rows: row provider.
        settings: the identifier's settings (put on the grid of ``time_step``).
        q: (N, n) positions of the log [rad or m].
        tau: (N, n) torques of the log [N·m or N].
        end: index of the window's newest sample.
        time_step: the signal period h [s].
        signals: ``(q̂, v̂, τ̂, ...)`` from :func:`filtered_signals` when already
            computed (filtered rows only).
    """
    s = settings.on_grid(time_step)
    bank = s.bank()
    index = end - s.decimation(time_step) * np.arange(bank.num_intervals, -1, -1)
    if s.rows_from == "raw":
        channels = raw_channels_batch(
            s.raw_design(time_step), rows, s.model, q, tau, index
        )
    else:
        found = filtered_signals(q, tau, s, time_step) if signals is None else signals
        q_hat, v_hat, tau_hat = found[:3]
        channels = bank_channels(
            rows, s.model, q_hat[index], v_hat[index], tau_hat[index]
        )
    m = s.num_equations(int(rows.num_joints))
    p = int(rows.num_parameters)
    return assemble_equations(bank, direct_fourier_integrals(bank, channels), m, p)


def window_estimate(
    rows: Any,
    settings: OnlineSettings,
    q: np.ndarray,
    tau: np.ndarray,
    end: int,
    time_step: float,
    *,
    signals: Sequence[Any] | None = None,
) -> LeastSquaresResult:
    """The solve of one window by direct trapezoid quadrature (a reference).

    :func:`window_equations`, then the identifier's solve
    (``core.lsq.solve_window`` with the settings' weighting and
    ``max_condition``). Arguments as :func:`window_equations`.
    """
    s = settings.on_grid(time_step)
    a, b = window_equations(rows, s, q, tau, end, time_step, signals=signals)
    m = s.num_equations(int(rows.num_joints))
    return solve_window(
        a,
        b,
        s.row_weighting(m),
        max_condition=s.max_condition,
        names=rows.names,
        jackknife=s.jackknife_groups(m),
    )
