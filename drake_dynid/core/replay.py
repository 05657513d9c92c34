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
  is processed and the loggers publish up to t_N;
* the replay ends with a final solve at the log's last sample t_{N-1} when that
  is not a solve time (without change detection: :func:`solve_samples`) and a
  final row at t_N when that is not a logged time (:func:`logged_samples`):
  the final estimate's window ends with the log's last bank sample
  (``drake_dynid.diagrams.replay_log`` does both after its Simulator run).

Vectorised and streamed: the FIRs are evaluated at the bank samples only
(:func:`filtered_at`: the smoothed q and τ and the velocity of q), or the raw rows
(``core.raw_rows.raw_channels_batch``) there, and their rows (one
``rows.model_rows`` call) a block of :data:`ROWS_CHUNK` bank samples at a time,
when the solves reach them; the bank's ``push_many`` between two solves, and a
solve only at the solve times, those of a stack of windows in one call
(``core.weighted_lsq.solve_windows``, the same results; :data:`STACK_ENTRIES`)
when they do not depend on the identifier's state (no change detection, no
covariance weighting). Cost per log sample: a few µs, independent of the
window T and of the log's length; memory beyond the log and the traces: a few
blocks, and the (M, p) traces go to temporary files beyond 32 MiB each, as a
long log's q and τ do (:class:`_TraceRows`). :func:`filtered_signals` filters a
whole log and :func:`window_estimate` solves one window by direct quadrature (the
references the accuracy benchmark uses; :func:`window_equations` gives its
equations).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core._threads import thread_limit
from drake_dynid.core.change import (
    change_design,
    tracker_init,
    tracker_outputs,
    tracking_update,
)
from drake_dynid.core.equations import assemble_equations, direct_fourier_integrals
from drake_dynid.core.identifier import (
    identifier_apply,
    identifier_init,
    identifier_update,
)
from drake_dynid.core.jacobi_stream import jacobi_batch
from drake_dynid.core.lsq import LeastSquaresResult
from drake_dynid.core.online import SOLVE_OFFSET, OnlineSettings, OnlineTrace
from drake_dynid.core.raw_rows import raw_channels_batch
from drake_dynid.core.rows import check_rows, num_channels, pack_rows
from drake_dynid.core.weighted_lsq import solve_window, solve_windows

__all__ = [
    "bank_channels",
    "bank_windows",
    "channel_equations",
    "filtered_at",
    "filtered_signals",
    "logged_samples",
    "replay_log_core",
    "solve_equations",
    "solve_samples",
    "window_bank_samples",
    "window_covariance",
    "window_covariance_at",
    "window_equations",
    "window_estimate",
    "window_estimate_covariance",
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


#: Samples per ``model_rows`` call of :func:`bank_channels`: the temporaries of a
#: 7-DOF batch stay in the cache, and the cost per sample does not grow with the
#: log (one batch of a 10-minute log was 1.4 times slower per sample).
ROWS_CHUNK = 256


def filtered_at(
    q: np.ndarray,
    tau: np.ndarray,
    settings: OnlineSettings,
    time_step: float,
    index: np.ndarray,
    *,
    by_fft: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`filtered_signals` at the samples ``index`` only (no full-rate array).

    ``(q̂, v̂, τ̂, valid)`` at each index k: ``Σ_j taps[j] x_{k-j}`` over the last
    N + 1 samples (zeros before the first), valid once k + 1 >= N + 1 and no
    non-finite sample is in that window: each window's dot products
    (``len(index)·(N + 1)·2n`` floats). ``by_fft`` (one window's equations,
    :func:`window_equations`), when the windows overlap much: one FFT
    convolution of the span they read instead, whose round-off (1e-16 of the
    span's largest value) reaches every output, also those whose window does
    not hold that value: not for a replay, where one glitch must not touch the
    windows it is not in (tests/test_bad_values.py).
    """
    smooth, velocity = settings.jacobi_filters(time_step)
    taps = smooth.num_taps
    index = np.asarray(index, dtype=int)
    n = q.shape[1]
    if index.size == 0:
        empty = np.zeros((0, n))
        return empty, empty.copy(), empty.copy(), np.zeros(0, dtype=bool)
    # The span of samples the windows read, once (a stored log is read in part).
    low = max(0, int(index.min()) - taps + 1)
    span = np.concatenate(
        (
            np.asarray(q[low : int(index.max()) + 1], dtype=float),
            np.asarray(tau[low : int(index.max()) + 1], dtype=float),
        ),
        axis=1,
    )
    finite = np.isfinite(span).all(axis=1)
    if not finite.all():  # filtered as zeros, the windows that hold them invalid
        span = np.where(np.isfinite(span), span, 0.0)
    rows = index - low  # rows of span
    length = span.shape[0]
    if by_fft and index.size * taps > 8 * length:  # the FIRs over the span
        size = 1 << int(length + taps - 2).bit_length()  # linear, not circular
        spectrum = np.fft.rfft(span, size, axis=0)
        smoothed = np.fft.irfft(
            spectrum * np.fft.rfft(smooth.taps, size)[:, None], size, axis=0
        )[rows].T
        q_dot = np.fft.irfft(
            spectrum[:, :n] * np.fft.rfft(velocity.taps, size)[:, None], size, axis=0
        )[rows].T
    else:  # each window's dot products
        lags = rows[:, None] - np.arange(taps)  # newest first
        window = np.ascontiguousarray(span.T)[:, np.maximum(lags, 0)]  # (2n, B, N+1)
        if low == 0 and (lags < 0).any():
            window[:, lags < 0] = 0.0  # zeros before the first sample
        smoothed = window @ smooth.taps  # (2n, B)
        q_dot = window[:n] @ velocity.taps
    bad_before = np.concatenate(([0], np.cumsum(~finite)))
    first = np.maximum(index - low - taps + 1, 0)
    bad = bad_before[index - low + 1] - bad_before[first] > 0
    valid = (index + 1 >= taps) & ~bad
    smoothed, q_dot = smoothed.T, q_dot.T
    return smoothed[:, :n], q_dot, smoothed[:, n:], valid


def bank_channels(
    rows: Any, model: str, q_hat: Any, v_hat: Any, tau_hat: Any
) -> np.ndarray:
    """Packed model rows ``pack_rows(*rows.model_rows(model, q̂, v̂, τ̂))``: (N, c).

    Evaluated in chunks of :data:`ROWS_CHUNK` samples.
    """
    count = len(q_hat)
    first = pack_rows(
        *rows.model_rows(model, *(a[:ROWS_CHUNK] for a in (q_hat, v_hat, tau_hat)))
    )
    if count <= ROWS_CHUNK:
        return first
    out = np.empty((count, first.shape[1]))
    out[:ROWS_CHUNK] = first
    for start in range(ROWS_CHUNK, count, ROWS_CHUNK):
        part = slice(start, start + ROWS_CHUNK)
        out[part] = pack_rows(
            *rows.model_rows(model, q_hat[part], v_hat[part], tau_hat[part])
        )
    return out


def _channel_blocks(
    log: Any, rows: Any, entry: OnlineSettings, bank_times: np.ndarray
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """(packed rows, valid) of the bank samples, :data:`ROWS_CHUNK` at a time.

    Raw rows (``entry.rows_from == "raw"``) read the differentiator's ring, as in
    the blocks: valid once the ring is full and every sample read is finite.
    """
    raw = entry.rows_from == "raw"
    if raw:
        design = entry.raw_design(log.time_step)
        taps = entry.jacobi_filters(log.time_step)[0].num_taps
        m = entry.num_equations(int(rows.num_joints))
        width = num_channels(m, int(rows.num_parameters))
    for start in range(0, len(bank_times), ROWS_CHUNK):
        index = bank_times[start : start + ROWS_CHUNK]
        if raw:
            full = index + 1 >= taps
            channels = np.zeros((index.size, width))
            if full.any():
                channels[full] = raw_channels_batch(
                    design, rows, entry.model, log.q, log.tau, index[full]
                )
            yield channels, full & np.isfinite(channels).all(axis=1)
            continue
        q_hat, v_hat, tau_hat, valid = filtered_at(
            log.q, log.tau, entry, log.time_step, index
        )
        yield pack_rows(*rows.model_rows(entry.model, q_hat, v_hat, tau_hat)), valid


def bank_windows(
    log: Any,
    rows: Any,
    entry: OnlineSettings,
    bank: Any,
    m: int,
    p: int,
    solve_times: np.ndarray,
) -> Iterator[tuple[bool, Any, Any, Any]]:
    """The bank's window at each solve, the samples pushed as the solves reach them.

    Bank updates run at t_j + h/2, j = 0, D, ... <= N - 1 (D = bank_time_step/h),
    each pushing ẑ_j (filtered rows) or the mean rows of the raw samples
    j - D + 1 .. j (raw rows), computed a block at a time (:func:`_channel_blocks`);
    the solve at t_s + 3h/4 sees the updates at t_j <= t_s. Yields, for each
    ``s`` of ``solve_times`` (signal samples, increasing, <= N - 1), ``(ready, A,
    B, window)``: whether the window is valid, its equations (None when not) and
    the bank's state. The core replays of the identifier and of the payload
    identifier consume it.
    """
    bank_times = np.arange(0, log.num_samples, entry.decimation(log.time_step))
    blocks = _channel_blocks(log, rows, entry, bank_times)
    channels, sample_valid = next(blocks)
    offset = 0  # bank sample of channels[0]
    window = bank.init_state(channels.shape[1])
    pushed = 0
    for s in solve_times:
        upto = int(np.searchsorted(bank_times, s, side="right"))
        while upto > pushed:
            if pushed - offset == len(channels):
                offset += len(channels)
                channels, sample_valid = next(blocks)
            stop = min(upto, offset + len(channels))
            window = bank.push_many(
                window,
                channels[pushed - offset : stop - offset],
                valid=sample_valid[pushed - offset : stop - offset],
            )
            pushed = stop
        ready = bank.window_valid(window)
        a, b = bank.equations(window, m, p) if ready else (None, None)
        yield ready, a, b, window


def window_covariance(
    design: Any, rows: Any, log: Any, entry: OnlineSettings, index: np.ndarray
) -> Any:
    """θ -> Σ of the window whose bank samples are the signal samples ``index``.

    The filtered signals there (:func:`filtered_at`) and
    ``core.row_covariance.row_covariance`` with the (uncompensated) ``rows``.
    """
    from drake_dynid.core.row_covariance import row_covariance

    q_hat, v_hat, tau_hat, _ = filtered_at(log.q, log.tau, entry, log.time_step, index)
    return lambda theta: row_covariance(design, rows, q_hat, v_hat, tau_hat, theta)


def _replay_one(log: Any, rows: Any, entry: OnlineSettings) -> OnlineTrace:
    h = log.time_step
    plain_rows = rows
    rows = entry.row_provider(rows, h)  # noise-compensated power rows, if asked
    count = log.num_samples
    solve_every = entry.solve_decimation(h)
    bank = entry.bank()
    m = entry.num_equations(int(rows.num_joints))
    p = int(rows.num_parameters)
    names = tuple(rows.names)
    weighting = entry.row_weighting(m, bank)
    noise = entry.row_noise(m, bank)
    jackknife = entry.jackknife_groups(m, bank)
    covariance = entry.covariance_design(h, int(rows.num_joints))
    bank_times = np.arange(0, count, entry.decimation(h))

    # Solves at t_u + 3h/4, u = 0, U, ... <= count - 1 and the final one at the
    # last sample (solve_samples); logs at t_s, s = 0, U, ... <= count and count.
    log_times = logged_samples(count, solve_every)
    num_logs = len(log_times)
    # The (M, p) traces in a temporary file when large (_TraceRows); the
    # (M,) ones in memory.
    theta, std, unidentified = (_TraceRows(num_logs, p) for _ in range(3))
    condition = np.full(num_logs, np.inf)
    valid = np.zeros(num_logs)
    status = np.zeros(num_logs)
    state = identifier_init(p)
    # Change detection keeps its period (its test reads whole update periods).
    design = change_design(entry, h, m, p)
    solve_times = solve_samples(count, solve_every, final=design is None)
    windows = bank_windows(log, rows, entry, bank, m, p, solve_times)
    solve = dict(
        weighting=weighting,
        max_condition=entry.max_condition,
        names=names,
        noise=noise,
        jackknife=jackknife,
    )
    # Change detection (core.change): the tracker's outputs per logged solve.
    tracker = None if design is None else tracker_init(design)
    change = np.zeros((num_logs if design else 0, 3))
    changed = _TraceRows(num_logs if design else 0, p)
    # Without change detection or covariance weighting the windows' solves do not
    # depend on the state: solved a stack at a time (solve_windows, STACK_ENTRIES).
    stacked = (
        _stacked_results(windows, solve)
        if design is None and covariance is None
        else None
    )
    solves = iter(solve_times)
    u = next(solves, None)
    for index, s in enumerate(log_times):
        while u is not None and u < s:  # the solves at t_u + 3h/4 < t_s
            if stacked is not None:
                state = identifier_apply(state, *next(stacked))
                u = next(solves, None)
                continue
            # Solve at t_u + 3h/4: after the bank updates at t_j + h/2, t_j <= t_u.
            ready, a, b, window = next(windows)
            call = dict(solve)
            if covariance is not None and ready:  # the window's K bank samples
                upto = int(np.searchsorted(bank_times, u, side="right"))
                samples = bank_times[upto - covariance.num_samples : upto]
                call["covariance"] = window_covariance(
                    covariance, plain_rows, log, entry, samples
                )
            if design is None or tracker is None:
                state = identifier_update(state, ready, a, b, **call)
            else:
                tracker, state = tracking_update(
                    tracker, state, design, ready, a, b, window, **call
                )
            u = next(solves, None)
        # Record the state after the solves at t < t_s.
        theta.add(state.theta)
        std.add(state.std)
        unidentified.add(state.unidentified)
        condition[index], valid[index] = state.condition_number, float(state.valid)
        status[index] = float(state.status)
        if design is not None and tracker is not None:
            outputs = tracker_outputs(tracker, design)
            change[index] = outputs[:3]
            changed.add(outputs[3:])
    return OnlineTrace(
        settings=entry,
        names=names,
        t=log_times * h,
        theta=theta.finish(),
        std=std.finish(),
        condition_number=condition,
        valid=valid,
        delay=entry.delay(h) + SOLVE_OFFSET * h,
        status=status,
        unidentified=unidentified.finish(),
        change=change[:, 0],
        change_time=change[:, 1],
        tracking=change[:, 2],
        changed=changed.finish(),
    )


def logged_samples(count: int, solve_every: int) -> np.ndarray:
    """The samples s = 0, U, 2U, ... <= N, and N, at which a replay logs its state.

    ``count`` = N samples, U = ``solve_every`` (the solve period in samples);
    the state logged at s is the one after the solves at t < t_s (module
    docstring): the trace's rows, its last one (at t_N, one period h after the
    last sample) the final solve's estimate (:func:`solve_samples`).
    """
    count, every = int(count), int(solve_every)
    times = np.arange(0, count + 1, every)
    return times if times[-1] == count else np.append(times, count)


def solve_samples(count: int, solve_every: int, final: bool = True) -> np.ndarray:
    """The samples u whose solve runs at t_u + 3h/4: 0, U, 2U, ... <= N - 1.

    With ``final`` (the identifier without change detection) also N - 1, the
    log's last sample, when it is not one of them: the final estimate's window
    ends with the last bank sample of the log, not up to a solve period before
    (a final 0.1 s, 1 s with the covariance weighting, left out before). Change
    detection keeps the period: its test reads whole periods.
    """
    count, every = int(count), int(solve_every)
    times = np.arange(0, count, every)
    if final and count > 0 and times[-1] != count - 1:
        times = np.append(times, count - 1)
    return times


class _TraceRows:
    """(M, p) rows of a trace added one at a time, kept by a ``RowSink``.

    ``drake_dynid.log_store.RowSink``: an array up to ``SPILL_BYTES`` (32 MiB:
    about 70 000 solves of 57 parameters, two hours of a 7-DOF arm at 10 solves
    per second), beyond a ``StoredArray`` in a temporary file, as a long log's q
    and τ: the replay's memory does not grow with the log (a 10-hour log's three
    (M, p) traces would take 600 MB). Rows are buffered :data:`TRACE_CHUNK` at a
    time.
    """

    def __init__(self, count: int, width: int):
        from drake_dynid import log_store

        self.count, self.width = int(count), int(width)
        self.sink = log_store.RowSink(self.width, limit=log_store.SPILL_BYTES)
        self.buffer = np.empty((min(TRACE_CHUNK, self.count), self.width))
        self.used = 0

    def add(self, row: Any) -> None:
        """Appends one (p,) row."""
        if self.used == len(self.buffer):
            self.sink.append(self.buffer)
            self.used = 0
        self.buffer[self.used] = row
        self.used += 1

    def finish(self) -> Any:
        """The (M, p) rows: an array, or a ``StoredArray`` beyond SPILL_BYTES."""
        self.sink.append(self.buffer[: self.used])
        self.used = 0
        if self.sink.rows != self.count:  # every logged time records a row
            raise AssertionError(f"{self.sink.rows} trace rows for {self.count}")
        return self.sink.finish()


STACK_ENTRIES = 1 << 18
"""Entries of A (2 MB) of the windows the core replay solves in one stacked call
(larger stacks leave the cache: 1.5x the cost per window at 8 MB)."""

TRACE_CHUNK = 4096
"""Rows of a (M, p) trace gathered before they go to its ``RowSink``."""


def _stacked_results(
    windows: Iterator[tuple[bool, Any, Any, Any]],
    solve: dict[str, Any],
) -> Iterator[tuple[bool, LeastSquaresResult | None]]:
    """(ready, result) of every window of ``windows``, solved a stack at a time.

    ``core.weighted_lsq.solve_windows`` of the ready windows among the next
    ``STACK_ENTRIES / (r·p)`` (the same results as one ``solve_window`` each;
    one window at a time until the first ready one gives r × p).
    """
    size = 1
    while True:
        batch = [(ready, a, b) for ready, a, b, _ in itertools.islice(windows, size)]
        if not batch:
            return
        ready = [k for k, (valid, _, _) in enumerate(batch) if valid]
        results: list[LeastSquaresResult | None] = [None] * len(batch)
        if ready:
            solved = solve_windows(
                np.stack([batch[k][1] for k in ready]),
                np.stack([batch[k][2] for k in ready]),
                **solve,
            )
            for k, one in zip(ready, solved, strict=True):
                results[k] = one
            size = max(1, STACK_ENTRIES // batch[ready[0]][1].size)
        for (valid, _, _), outcome in zip(batch, results, strict=True):
            yield valid, outcome


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
    replay takes a fraction of a second per minute of log). Runs with BLAS/OpenMP
    pools of one thread (``DYNID_THREADS`` changes it; ``core._threads``).

    Args:
        log: a ``drake_dynid.logs.RobotLog`` (``q``, ``tau`` (N, n),
            ``time_step``, ``num_samples``).
        rows: row provider (``RobotModel.rows_provider()``): ``num_joints``,
            ``num_parameters``, ``names``, batch ``model_rows(kind, q, v, tau)``.
        settings: one entry per identifier, put on the log's grid
            (:meth:`OnlineSettings.on_grid`).
        progress: ignored.

    Returns:
        One :class:`~drake_dynid.core.online.OnlineTrace` per settings entry, with
        times relative to the first sample of the log.
    """
    del progress
    check.having(
        "replay_log_core",
        "log",
        log,
        ("q", "tau", "time_step", "num_samples"),
        "a RobotLog",
    )
    check.log_magnitudes("replay_log_core", log.q, log.tau)
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
    with thread_limit():  # BLAS/OpenMP pools of one thread (core._threads)
        p = int(rows.num_parameters)
        return [
            _replay_one(log, rows, raw.for_robot(log.time_step, n, p))
            for raw in settings
        ]


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
    s = settings.for_robot(time_step, int(rows.num_joints), int(rows.num_parameters))
    rows = s.row_provider(rows, time_step)
    index = window_bank_samples(s, time_step, end)
    if s.rows_from == "raw":
        channels = raw_channels_batch(
            s.raw_design(time_step), rows, s.model, q, tau, index
        )
    else:
        if signals is None:  # the filters' outputs at the bank samples only
            q_hat, v_hat, tau_hat, _ = filtered_at(
                q, tau, s, time_step, index, by_fft=True
            )
        else:
            q_hat, v_hat, tau_hat = (np.asarray(x)[index] for x in signals[:3])
        channels = bank_channels(rows, s.model, q_hat, v_hat, tau_hat)
    return channel_equations(rows, s, channels)


def window_bank_samples(
    settings: OnlineSettings, time_step: float, end: int
) -> np.ndarray:
    """The signal samples ``end - j·D``, j = N_bank .. 0, of one window's bank samples.

    Oldest first; ``settings`` put on the grid of ``time_step`` (D =
    bank_time_step/h).
    """
    count = settings.bank().num_intervals
    return end - settings.decimation(time_step) * np.arange(count, -1, -1)


def channel_equations(
    rows: Any, settings: OnlineSettings, channels: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``A θ = B`` of one window from its bank channels (direct quadrature).

    ``core.equations.direct_fourier_integrals`` of the (N_bank + 1, c) channels,
    oldest first, then ``assemble_equations``; ``settings`` resolved for the
    robot (:meth:`OnlineSettings.for_robot`).
    """
    bank = settings.bank()
    m = settings.num_equations(int(rows.num_joints))
    p = int(rows.num_parameters)
    return assemble_equations(bank, direct_fourier_integrals(bank, channels), m, p)


def solve_equations(
    rows: Any,
    settings: OnlineSettings,
    a: np.ndarray,
    b: np.ndarray,
    covariance=None,
    *,
    full: bool = False,
) -> Any:
    """The identifier's solve of one window's ``A θ = B``.

    ``core.lsq.solve_window`` with the weighting, ``max_condition``, row noise and
    jackknife groups of ``settings`` (resolved for the robot); ``covariance``:
    :func:`window_covariance_at`'s θ -> Σ, or None. ``full``: its
    ``core.weighted_lsq.window_covariance`` instead (the same solve and the
    estimator's full covariance).
    """
    from drake_dynid.core.weighted_lsq import window_covariance

    m = settings.num_equations(int(rows.num_joints))
    return (window_covariance if full else solve_window)(
        a,
        b,
        settings.row_weighting(m),
        max_condition=settings.max_condition,
        names=rows.names,
        noise=settings.row_noise(m),
        jackknife=settings.jackknife_groups(m),
        covariance=covariance,
    )


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
    s = settings.for_robot(time_step, int(rows.num_joints), int(rows.num_parameters))
    a, b = window_equations(rows, s, q, tau, end, time_step, signals=signals)
    covariance = window_covariance_at(rows, s, q, tau, end, time_step, signals=signals)
    return solve_equations(rows, s, a, b, covariance)


def window_estimate_covariance(
    rows: Any,
    settings: OnlineSettings,
    q: np.ndarray,
    tau: np.ndarray,
    end: int,
    time_step: float,
    *,
    channels: np.ndarray | None = None,
) -> Any:
    """:func:`window_estimate` with the estimator's full (p, p) covariance.

    ``core.weighted_lsq.window_covariance`` of the window's equations (direct
    quadrature) with the identifier's settings: its ``result`` is
    :func:`window_estimate`'s. Arguments as :func:`window_equations`;
    ``channels``: the window's (N_bank + 1, c) bank channels when already
    computed (raw rows: ``core.bootstrap.BootstrapStd.channels``, the same
    numbers as ``core.raw_rows.raw_channels_batch`` here), used instead of
    evaluating the rows again (:func:`channel_equations`).
    """
    s = settings.for_robot(time_step, int(rows.num_joints), int(rows.num_parameters))
    if channels is not None and s.rows_from == "raw":
        a, b = channel_equations(s.row_provider(rows, time_step), s, channels)
    else:
        a, b = window_equations(rows, s, q, tau, end, time_step)
    covariance = window_covariance_at(rows, s, q, tau, end, time_step)
    return solve_equations(rows, s, a, b, covariance, full=True)


def window_covariance_at(
    rows: Any,
    settings: OnlineSettings,
    q: np.ndarray,
    tau: np.ndarray,
    end: int,
    time_step: float,
    *,
    signals: Sequence[Any] | None = None,
) -> Any:
    """θ -> Σ of the window of :func:`window_equations` (covariance weighting).

    None unless ``settings.weighting`` is ``"covariance"``. Arguments as
    :func:`window_equations`; ``rows`` uncompensated (the derivatives of the
    rows, ``core.row_covariance``).
    """
    s = settings.for_robot(time_step, int(rows.num_joints), int(rows.num_parameters))
    design = s.covariance_design(time_step, int(rows.num_joints))
    if design is None:
        return None
    from drake_dynid.core.row_covariance import row_covariance

    index = end - s.decimation(time_step) * np.arange(design.num_samples - 1, -1, -1)
    if signals is None:
        q_hat, v_hat, tau_hat, _ = filtered_at(q, tau, s, time_step, index)
    else:
        q_hat, v_hat, tau_hat = (np.asarray(x)[index] for x in signals[:3])
    return lambda theta: row_covariance(design, rows, q_hat, v_hat, tau_hat, theta)
