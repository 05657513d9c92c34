"""Parametric bootstrap σ of one window's estimate (docs/MATH.md §4).

The window solve's σ (the sandwich and the jackknife of ``core.lsq.solve_window``)
are statistics of the window's own rows. Noise that lies in the column space of
the rows moves θ̂ exactly as a change of θ would, and no statistic of one window's
residuals can see it: the velocity estimate's noise inside the regressor, above
all the Coulomb sign s(v̂) flipping where a joint's velocity crosses zero slowly
(benchmarks/bench_sigma_diagnosis.py: 45 % of the weighted noise lies there on the
2R scenario ``g1 / rf seed 3``, 18 % for noise without structure; err/σ p90 2.87).

The bootstrap measures that sensitivity instead. K replicates of the window, each
with white noise of the levels measured on the log added to the positions and the
torques (σ_q,j, σ_τ,j: the white floor of each signal's spectrum,
``core.excitation.position_noise_std``), are solved exactly as the identifier
solves the window (:func:`drake_dynid.core.replay.window_estimate`: the same
filters or raw rows, bank, weighting and checks)::

    σ_B,i = std_k(θ̂_i^(k)),   k = 1..K   (sample std, ddof = 1)

The replicates perturb the measured signals, whose own noise is already there:
σ_B is the estimate's sensitivity to noise at the measured operating point, the
parametric bootstrap's usual approximation. ``dynid identify`` reports
max(σ, σ_B) per parameter for its final estimate; the accuracy benchmark
(benchmarks/bench_accuracy.py, Uncertainty) measures it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = [
    "DEFAULT_REPLICATES",
    "MAX_REPLICATES",
    "BootstrapStd",
    "bootstrap_std",
    "window_start",
]

#: Replicates of the default bootstrap: the sample std of K normal draws is within
#: ±18 % (one σ of its sampling spread, 1/√(2(K-1))) at K = 16.
DEFAULT_REPLICATES = 16

#: The most replicates ``dynid identify --bootstrap`` takes (a ceiling on the work
#: per option value: about 35 s on a 7-DOF window; σ then within 2 %).
MAX_REPLICATES = 1000


@dataclass(frozen=True)
class BootstrapStd:
    """Outcome of :func:`bootstrap_std`.

    Attributes:
        std: (p,) σ_B [units of θ]; NaN when fewer than 2 replicates were valid.
        nominal: (p,) θ̂ of the unperturbed window (its direct quadrature: the
            identifier's estimate to round-off); NaN when that window is not valid.
        replicates: the replicates whose window was valid.
        method: ``"linearized"`` (the raw rows' replicates to first order,
            ``core.raw_rows.linearized_channels``) or ``"exact"`` (each
            replicate's window solved again from its signals).
        channels: the unperturbed window's (N_bank + 1, c) bank channels
            (``core.raw_rows.raw_channels_batch``'s, computed by the linearised
            method; None for ``"exact"``): ``core.replay.window_estimate_covariance``
            of the same window takes them instead of evaluating its rows again.
    """

    std: np.ndarray
    nominal: np.ndarray
    replicates: int
    method: str = "exact"
    channels: np.ndarray | None = None


def window_start(settings: Any, time_step: float, end: int) -> int:
    """The first signal sample the window ending at ``end`` reads (>= 0).

    The oldest bank sample ``end - D·N_bank``, the raw rows' D-sample average
    before it and the longest filter or raw-velocity history (``settings`` put on
    the grid and resolved for the robot, :meth:`OnlineSettings.for_robot`).
    """
    decimation = settings.decimation(time_step)
    history = settings.jacobi_filters(time_step)[0].num_taps
    if settings.rows_from == "raw":
        history = max(history, settings.raw_design(time_step).history)
    first = _oldest_bank_sample(settings, time_step, end) - decimation - history
    return max(0, first - decimation)


def _oldest_bank_sample(settings: Any, time_step: float, end: int) -> int:
    """``end - D·N_bank``: the oldest bank sample of the window ending at ``end``."""
    return int(end) - settings.decimation(time_step) * settings.bank().num_intervals


def bootstrap_std(
    rows: Any,
    settings: Any,
    q: Any,
    tau: Any,
    end: int,
    time_step: float,
    noise_std: tuple[Any, Any],
    *,
    replicates: int = DEFAULT_REPLICATES,
    seed: int = 0,
    linearized: bool = True,
) -> BootstrapStd:
    """σ of the estimate of the window ending at ``end``, by parametric bootstrap.

    Args:
        rows: the row provider the identifier used.
        settings: its :class:`~drake_dynid.core.online.OnlineSettings` (put on
            the log's grid).
        q: (N, n) positions of the log [rad or m] (an array or a stored log: only
            the window's samples are read).
        tau: (N, n) torques [N·m or N].
        end: the window's newest bank sample (signal sample index); the window
            must be full (ValueError otherwise).
        time_step: h [s].
        noise_std: ``(σ_q, σ_τ)``, each (n,) >= 0: the white noise added to the
            positions [rad or m] and the torques [N·m or N].
        replicates: K >= 2.
        seed: seed of ``numpy.random.default_rng`` (the result is reproducible).
        linearized: with raw rows of a Lagrangian model whose provider gives its
            friction part apart, solve the replicates from the window's rows
            perturbed to first order (``core.raw_rows.linearized_channels``: one
            row evaluation per bank sample instead of D; the same draws); False:
            solve each replicate's window again from its signals.

    Returns:
        :class:`BootstrapStd`.
    """
    owner = "bootstrap_std"
    n = int(rows.num_joints)
    p = int(rows.num_parameters)
    if isinstance(replicates, bool) or not isinstance(replicates, (int, np.integer)):
        v.fail(owner, f"replicates must be an integer >= 2; got {replicates!r}.")
    if replicates < 2:
        v.fail(owner, f"replicates must be an integer >= 2; got {replicates}.")
    if len(noise_std) != 2:
        v.fail(owner, "noise_std must be (position std, torque std).")
    sigma_q, sigma_tau = (
        v.array(owner, name, x, shape=(n,))
        for name, x in zip(("position std", "torque std"), noise_std, strict=True)
    )
    if np.any(sigma_q < 0.0) or np.any(sigma_tau < 0.0):
        v.fail(owner, "the noise std must be >= 0.")
    h = v.positive(owner, "time_step", time_step, "s")
    s = settings.for_robot(h, n, p)
    count = int(np.shape(q)[0])
    if not 0 <= int(end) < count:
        v.fail(owner, f"end must be a sample of the log (0..{count - 1}); got {end}.")
    # A full window: its oldest bank sample has the differentiator's taps behind it
    # (as the replay's validity, core.replay).
    taps = s.jacobi_filters(h)[0].num_taps
    first = _oldest_bank_sample(s, h, end)
    if first + 1 < taps:
        v.fail(
            owner,
            f"the window ending at sample {end} is not full: its oldest bank sample "
            f"{first} needs {taps - 1} samples before it (end >= "
            f"{int(end) - first + taps - 1}).",
        )
    start = window_start(s, h, int(end))
    q_window = np.asarray(q[start : end + 1], dtype=float)
    tau_window = np.asarray(tau[start : end + 1], dtype=float)
    last = int(end) - start
    rng = np.random.default_rng(seed)
    noise = (
        (
            sigma_q * rng.standard_normal(q_window.shape),
            sigma_tau * rng.standard_normal(tau_window.shape),
        )
        for _ in range(replicates)
    )
    linear = (
        _linearized_solver(rows, s, q_window, tau_window, last, h)
        if linearized
        else None
    )
    method = "exact" if linear is None else "linearized"
    channels = None
    if linear is None:
        solve = _exact_solver(rows, s, q_window, tau_window, last, h)
    else:
        solve, channels = linear
    nominal = solve(None, None)
    draws = [theta for dq, dtau in noise if (theta := solve(dq, dtau)) is not None]
    std = np.full(p, np.nan)
    if len(draws) >= 2:  # about the first draw: equal draws give 0 exactly
        std = np.std(np.asarray(draws) - draws[0], axis=0, ddof=1)
    return BootstrapStd(
        std=std,
        nominal=np.full(p, np.nan) if nominal is None else nominal,
        replicates=len(draws),
        method=method,
        channels=channels,
    )


Solver = Callable[[np.ndarray | None, np.ndarray | None], np.ndarray | None]


def _exact_solver(
    rows: Any, s: Any, q: np.ndarray, tau: np.ndarray, end: int, h: float
) -> Solver:
    """(δq, δτ) -> θ̂ of the window of q + δq, τ + δτ ending at ``end``, or None.

    ``core.replay.window_estimate`` (the unperturbed window for None).
    """
    from drake_dynid.core.replay import window_estimate

    def solve(dq: np.ndarray | None, dtau: np.ndarray | None) -> np.ndarray | None:
        if dq is None or dtau is None:
            result = window_estimate(rows, s, q, tau, end, h)
        else:
            result = window_estimate(rows, s, q + dq, tau + dtau, end, h)
        return np.asarray(result.theta) if result.valid else None

    return solve


def _linearized_solver(
    rows: Any, s: Any, q: np.ndarray, tau: np.ndarray, end: int, h: float
) -> tuple[Solver, np.ndarray] | None:
    """(δq, δτ) -> θ̂ of the window ending at ``end`` with linearised raw rows.

    ``core.raw_rows.linearized_channels`` (None for the unperturbed window, the
    exact channels), with those exact channels; None when it does not apply:
    rows not raw, a covariance weighting (its Σ would need the perturbed
    signals), or no ``core.raw_rows.raw_linearization``.
    """
    from drake_dynid.core.raw_rows import linearized_channels, raw_linearization
    from drake_dynid.core.replay import (
        channel_equations,
        solve_equations,
        window_bank_samples,
    )

    if s.rows_from != "raw" or s.weighting == "covariance":
        return None
    provider = s.row_provider(rows, h)
    design = s.raw_design(h)
    index = window_bank_samples(s, h, end)
    lin = raw_linearization(design, provider, s.model, q, tau, index)
    if lin is None:
        return None

    def solve(dq: np.ndarray | None, dtau: np.ndarray | None) -> np.ndarray | None:
        if dq is None or dtau is None:
            channels = lin.channels
        else:
            channels = linearized_channels(
                lin, design, provider, s.model, dq, dtau, index
            )
        result = solve_equations(provider, s, *channel_equations(provider, s, channels))
        return np.asarray(result.theta) if result.valid else None

    return solve, lin.channels
