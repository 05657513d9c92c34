"""What an exciting trajectory promises: predicted precision and weak directions.

Predicted precision (Gautier's σ for a noise model, before any experiment). With
white torque noise of std σ_j on joint j, sampled at ``rate`` over ``duration``
(M samples), the weighted least squares of τ = W θ has the covariance::

    C_θ = (Σ_k W_kᵀ Σ⁻¹ W_k)⁻¹,   Σ = diag(σ_j²),   σ_j = f · std_t(τ_j)

where f is the noise fraction (0.01: SNR 40 dB on τ) and the sum over the M log
samples is (M/N)× the sum over N samples of one period (the trajectory is periodic
and the duration a whole number of periods). ``%σ_i = 100 σ_i/|θ_i|``; a parameter
with a large %σ is weakly excited (or small). Computed from the R factor of the
column-scaled, noise-weighted regressor, never from a pseudo-inverse. Position noise
(which enters through v̇) is not modelled: the prediction is a lower bound.

Weakest direction: the right singular vector of the smallest singular value of the
column-scaled regressor, i.e. the combination of parameters that the trajectory
excites least, listed by the parameters holding >= 5 % of it.

On-line identification (``core.modulating``): the Lagrangian model's modulated
equations over one window T (noise-free rows at the bank's sample period, direct
quadrature) and the condition number of their column-scaled matrix, for windows
starting at several phases of the period.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v
from drake_dynid.core.modulating import (
    FourierBank,
    assemble_equations,
    direct_fourier_integrals,
    pack_rows,
)

__all__ = ["ExcitationReport", "excitation_report", "modulated_condition_numbers"]

_WEAK_SHARE = 0.05  # a parameter "holds" a direction with >= 5 % of its energy


@dataclass(frozen=True, eq=False)
class ExcitationReport:
    """Predicted identification precision of a trajectory (module docstring).

    Attributes:
        names: (p,) base parameter names.
        values: (p,) their values in the model.
        condition_number: cond of the column-scaled regressor over one period.
        std: (p,) predicted σ of each parameter [its unit].
        relative_std_percent: (p,) 100·σ/|value| (inf for a zero value).
        noise_std: (n,) torque noise assumed per joint [N·m or N].
        weakest: ((name, coefficient), ...) of the weakest direction.
        weak: names with a predicted %σ above the threshold (non-zero values).
        zero: names whose model value is 0 (relative error undefined).
        threshold_percent: the threshold on %σ.
        num_samples: M, the log samples assumed.
    """

    names: tuple[str, ...]
    values: np.ndarray
    condition_number: float
    std: np.ndarray
    relative_std_percent: np.ndarray
    noise_std: np.ndarray
    weakest: tuple[tuple[str, float], ...]
    weak: tuple[str, ...]
    zero: tuple[str, ...]
    threshold_percent: float
    num_samples: int


def excitation_report(
    rows_fn: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    trajectory: Any,
    theta: Any,
    names: Sequence[str],
    *,
    duration: float,
    rate: float = 1000.0,
    noise_fraction: float = 0.01,
    samples_per_period: int = 256,
    threshold_percent: float = 1.0,
) -> ExcitationReport:
    """Predicted σ of the base parameters for a periodic trajectory and noise model.

    ``C_θ = (M/N)⁻¹ (Σ_{k<N} W_kᵀ Σ⁻¹ W_k)⁻¹`` over one period (module docstring).

    Args:
        rows_fn: base IDIM rows (N, n) q, v, v̇ -> (N, n, p).
        trajectory: periodic trajectory with ``period`` [s] and ``evaluate(t)``.
        theta: (p,) model values of the base parameters.
        names: (p,) their names.
        duration: log length [s] (whole periods).
        rate: log sample rate [Hz].
        noise_fraction: torque noise std as a fraction of each joint's torque std.
        samples_per_period: N.
        threshold_percent: %σ above which a parameter is listed as weak.

    Returns:
        The :class:`ExcitationReport`.
    """
    owner = "excitation_report"
    theta = v.array(owner, "theta", theta)
    names = tuple(names)
    if len(names) != theta.size:
        v.fail(owner, f"names must have {theta.size} entries; got {len(names)}.")
    duration = v.positive(owner, "duration", duration, "s")
    rate = v.positive(owner, "rate", rate, "Hz")
    noise_fraction = v.positive(owner, "noise_fraction", noise_fraction)
    samples = v.integer(owner, "samples_per_period", samples_per_period, minimum=8)
    threshold = v.positive(owner, "threshold_percent", threshold_percent, "%")
    t = (np.arange(samples) + 0.5) * trajectory.period / samples
    W = np.asarray(rows_fn(*trajectory.evaluate(t)), dtype=float)  # (N, n, p)
    tau = W @ theta
    noise = noise_fraction * np.std(tau, axis=0)
    noise = np.where(noise > 0.0, noise, noise_fraction)  # a motionless joint
    Wf = W.reshape(-1, theta.size)
    scale = np.linalg.norm(Wf, axis=0)
    if not np.all(scale > 0.0):
        j = int(np.argmin(scale))
        v.fail(owner, f"parameter {names[j]} has a zero regressor column.")
    singular, vt = np.linalg.svd(Wf / scale, full_matrices=False)[1:]
    condition = float(singular[0] / singular[-1])
    weakest = vt[-1]
    order = np.argsort(-np.abs(weakest))
    weakest_terms = tuple(
        (names[i], float(weakest[i])) for i in order if weakest[i] ** 2 >= _WEAK_SHARE
    )
    weighted = (W / noise[None, :, None]).reshape(-1, theta.size)
    norms = np.linalg.norm(weighted, axis=0)
    R = np.linalg.qr(weighted / norms, mode="r")
    inverse = np.linalg.solve(R, np.eye(theta.size))  # R⁻¹ (triangular, p × p)
    num_samples = round(rate * duration)
    std = np.linalg.norm(inverse, axis=1) / norms * math.sqrt(samples / num_samples)
    with np.errstate(divide="ignore"):
        relative = 100.0 * std / np.abs(theta)
    zero = np.abs(theta) <= 1e-12 * max(1.0, float(np.abs(theta).max()))
    relative = np.where(zero, np.inf, relative)
    weak = tuple(
        names[i]
        for i in np.argsort(-relative)
        if not zero[i] and relative[i] > threshold
    )
    return ExcitationReport(
        names=names,
        values=theta.copy(),
        condition_number=condition,
        std=std,
        relative_std_percent=relative,
        noise_std=noise,
        weakest=weakest_terms,
        weak=weak,
        zero=tuple(name for name, flag in zip(names, zero, strict=True) if flag),
        threshold_percent=threshold,
        num_samples=int(num_samples),
    )


def modulated_condition_numbers(
    model_rows_fn: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple],
    rows_fn: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    theta: Any,
    trajectory: Any,
    bank: FourierBank,
    starts: Sequence[float],
) -> np.ndarray:
    """Condition numbers of the on-line modulated equations over windows.

    For each start s, the window [s, s + T] sampled every ``bank.time_step``:
    τ = rows_fn(q, v, v̇)·θ, ``(D, G, y) = model_rows_fn(q, v, τ)``, the sliding
    Fourier integrals by direct quadrature, ``A = assemble_equations(...)`` and
    ``cond(A S⁻¹)`` with S the column norms (inf if a column is zero).

    Args:
        model_rows_fn: (N, n) q, v, τ -> D, G (N, m, p), y (N, m), e.g.
            ``functools.partial(robot.model_rows, "lagrangian")``.
        rows_fn: base IDIM rows for the torques.
        theta: (p,) base values.
        trajectory: with ``evaluate(t) -> (q, v, v̇)``.
        bank: the modulating-function design (``OnlineSettings.bank()``).
        starts: window start times [s].

    Returns:
        (len(starts),) condition numbers.
    """
    theta = v.array("modulated_condition_numbers", "theta", theta)
    out = []
    for start in starts:
        t = float(start) + bank.time_step * np.arange(bank.num_samples)
        q, qd, qdd = trajectory.evaluate(t)
        tau = np.asarray(rows_fn(q, qd, qdd)) @ theta
        D, G, y = model_rows_fn(q, qd, tau)
        m, p = D.shape[1:]
        A, _ = assemble_equations(
            bank, direct_fourier_integrals(bank, pack_rows(D, G, y)), m, p
        )
        norms = np.linalg.norm(A, axis=0)
        if not np.all(norms > 0.0):
            out.append(math.inf)
            continue
        s = np.linalg.svd(A / norms, compute_uv=False)
        out.append(float(s[0] / s[-1]) if s[-1] > 0.0 else math.inf)
    return np.array(out)
