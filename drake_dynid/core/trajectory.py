"""Exciting trajectories: finite Fourier series (Swevers 1997; docs/MATH.md §7).

Per joint j, with base frequency ω_f [rad/s] and H harmonics::

    q_j(t)  = q0_j + Σ_{l=1..H} [ a_jl/(lω_f) sin(lω_f t) - b_jl/(lω_f) cos(lω_f t) ]
    v_j(t)  = Σ_l [ a_jl cos(lω_f t) + b_jl sin(lω_f t) ]                    [rad/s]
    v̇_j(t)  = Σ_l lω_f [ -a_jl sin(lω_f t) + b_jl cos(lω_f t) ]             [rad/s²]

periodic with period 2π/ω_f, band-limited to H·ω_f. The coefficients are chosen at
random under a velocity limit (:func:`random_fourier_trajectory`) or optimised for
the condition number of the column-scaled regressor
(:func:`optimize_fourier_trajectory`, Gautier/Presse, Swevers).

Choosing ω_f for the on-line (modulating-function) method. The bank of window
T sees the frequencies ν/T [Hz] (ν = ℓ + i, see ``core.modulating``); every window
must carry excitation there:

* **Period dividing the window** (recommended with the integer ℓ set):
  ``ω_f = 2π·m/T`` for an integer m >= 1, i.e. the period T/m <= T. Every window then
  holds whole periods, so the modulated equations (and their conditioning) are the
  same in every window, and the trajectory's own lines sit exactly on the bins
  ν = m·l, l = 1..H. Cover at least ν <= 2·m·H with ℓ (the regressors are
  nonlinear: products such as v², v₁v₂ and cos q double the bandwidth), e.g.
  ``default_frequencies(T, 2·H·m/T)``.
* **Non-commensurate multi-sine** (period longer than T or not dividing it): the
  energy leaks into every bin, which suits the paper's fine ℓ grid, but the
  excitation, hence the conditioning, changes from window to window; check the
  condition number of the modulated regressor over several windows.

A period longer than T with few harmonics is the case to avoid: a window then sees
only part of a slow swing and the columns become nearly dependent.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize

from drake_dynid.core import _validate as v

__all__ = [
    "FourierTrajectory",
    "optimize_fourier_trajectory",
    "random_fourier_trajectory",
    "regressor_condition_number",
]

RowsFunction = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]

_GRID_PER_HARMONIC = 64  # samples per period and harmonic for the maxima


@dataclass(frozen=True, eq=False)
class FourierTrajectory:
    """Finite Fourier series trajectory (immutable).

    Attributes:
        q0: (n,) position offsets [rad or m].
        a: (n, H) coefficients of cos(lω_f t) in the velocity (of sin in the
            position, divided by lω_f) [rad/s].
        b: (n, H) coefficients of sin(lω_f t) in the velocity (of -cos in the
            position, divided by lω_f) [rad/s].
        base_frequency: ω_f [rad/s] (period 2π/ω_f).
    """

    q0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    base_frequency: float

    def __post_init__(self) -> None:
        owner = "FourierTrajectory"
        q0 = v.array(owner, "q0", self.q0)
        if q0.ndim != 1 or q0.size == 0:
            v.fail(owner, f"q0 must have shape (n,) with n >= 1; got {q0.shape}.")
        a = v.array(owner, "a", self.a)
        if a.ndim != 2 or a.shape[0] != q0.size or a.shape[1] < 1:
            v.fail(owner, f"a must have shape ({q0.size}, H >= 1); got {a.shape}.")
        b = v.array(owner, "b", self.b, shape=a.shape)
        omega = v.positive(owner, "base_frequency", self.base_frequency, "rad/s")
        for name, value in (("q0", q0), ("a", a), ("b", b)):
            value = value.copy()
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "base_frequency", omega)

    @property
    def num_joints(self) -> int:
        """n, the number of joints."""
        return self.q0.size

    @property
    def harmonics(self) -> int:
        """H, the number of harmonics."""
        return self.a.shape[1]

    @property
    def period(self) -> float:
        """2π/ω_f [s]."""
        return 2.0 * math.pi / self.base_frequency

    def evaluate(self, t: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations at times ``t`` [s].

        Args:
            t: a scalar or (N,) times.

        Returns:
            ``(q, v, vdot)``, each (n,) for a scalar t or (N, n).
        """
        times = np.asarray(t, dtype=float)
        if times.ndim > 1:
            v.fail(
                "FourierTrajectory", f"t must be a scalar or 1-D; got {times.shape}."
            )
        omega_l = self.base_frequency * np.arange(1, self.harmonics + 1)  # (H,)
        phase = np.multiply.outer(np.atleast_1d(times), omega_l)  # (N, H)
        sin, cos = np.sin(phase), np.cos(phase)
        q = self.q0 + sin @ (self.a / omega_l).T - cos @ (self.b / omega_l).T
        velocity = cos @ self.a.T + sin @ self.b.T
        acceleration = cos @ (self.b * omega_l).T - sin @ (self.a * omega_l).T
        if times.ndim == 0:
            return q[0], velocity[0], acceleration[0]
        return q, velocity, acceleration

    def extrema(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Guaranteed upper bounds of max |q - q0|, max |v|, max |v̇| per joint.

        The maxima of the samples on a grid of M = 64·H points per period, divided
        by ``1 - (πH/M)²/2`` (Bernstein: between grid points a degree-H
        trigonometric polynomial cannot exceed its sampled maximum by more).
        """
        grid = _GRID_PER_HARMONIC * self.harmonics
        times = self.period * np.arange(grid) / grid
        q, velocity, acceleration = self.evaluate(times)
        margin = 1.0 - 0.5 * (math.pi * self.harmonics / grid) ** 2
        return (
            np.abs(q - self.q0).max(axis=0) / margin,
            np.abs(velocity).max(axis=0) / margin,
            np.abs(acceleration).max(axis=0) / margin,
        )


def _limit(owner: str, name: str, value: Any, n: int) -> np.ndarray | None:
    if value is None:
        return None
    out = v.array(owner, name, value)
    if out.shape not in ((), (n,)):
        v.fail(owner, f"{name} must be a scalar or have shape ({n},); got {out.shape}.")
    if np.any(out <= 0):
        v.fail(owner, f"{name} must be > 0; got minimum {out.min():g}.")
    return np.broadcast_to(out, (n,))


def _velocity_limit(owner: str, value: Any, n: int) -> np.ndarray:
    """The required velocity limit as (n,) [rad/s]; None is a TypeError."""
    out = _limit(owner, "max_velocity", value, n)
    if out is None:
        raise TypeError(
            f"{owner}: max_velocity must be a real number or an ({n},) array [rad/s]; "
            "got None."
        )
    return out


def _scaled(
    trajectory: FourierTrajectory,
    max_velocity: np.ndarray,
    max_acceleration: np.ndarray | None,
    max_position: np.ndarray | None,
) -> FourierTrajectory:
    """Scales each joint's coefficients so that its tightest limit is just met."""
    excursion, velocity, acceleration = trajectory.extrema()
    with np.errstate(divide="ignore"):
        ratio = max_velocity / velocity
        if max_acceleration is not None:
            ratio = np.minimum(ratio, max_acceleration / acceleration)
        if max_position is not None:
            ratio = np.minimum(ratio, max_position / excursion)
    ratio = np.where(np.isfinite(ratio), ratio, 0.0)[:, None]
    return FourierTrajectory(
        trajectory.q0,
        trajectory.a * ratio,
        trajectory.b * ratio,
        trajectory.base_frequency,
    )


def random_fourier_trajectory(
    n: int,
    *,
    harmonics: int,
    base_frequency: float,
    max_velocity: Any,
    rng: np.random.Generator,
    q0: Any = None,
    max_acceleration: Any = None,
    max_position: Any = None,
) -> FourierTrajectory:
    """Random Fourier trajectory scaled to its limits.

    Coefficients a, b ~ N(0, 1) (drawn from ``rng``, a first, then b), then each
    joint is scaled so that its guaranteed bound (:meth:`FourierTrajectory.extrema`)
    on |v_j| equals ``max_velocity`` (or, when tighter, on |v̇_j| the acceleration
    limit or on |q_j - q0_j| the position limit).

    Args:
        n: joints.
        harmonics: H >= 1.
        base_frequency: ω_f [rad/s].
        max_velocity: velocity limit [rad/s], scalar or (n,).
        rng: a seeded numpy Generator.
        q0: (n,) offsets (default zeros) [rad].
        max_acceleration: optional limit [rad/s²], scalar or (n,).
        max_position: optional limit on |q - q0| [rad], scalar or (n,).
    """
    owner = "random_fourier_trajectory"
    n = v.integer(owner, "n", n, minimum=1)
    harmonics = v.integer(owner, "harmonics", harmonics, minimum=1)
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"{owner}: rng must be a numpy.random.Generator; got {type(rng).__name__}."
        )
    q0 = np.zeros(n) if q0 is None else v.array(owner, "q0", q0, shape=(n,))
    velocity = _velocity_limit(owner, max_velocity, n)
    acceleration = _limit(owner, "max_acceleration", max_acceleration, n)
    position = _limit(owner, "max_position", max_position, n)
    a = rng.standard_normal((n, harmonics))
    b = rng.standard_normal((n, harmonics))
    raw = FourierTrajectory(q0, a, b, base_frequency)
    return _scaled(raw, velocity, acceleration, position)


def regressor_condition_number(
    rows_fn: RowsFunction, trajectory: FourierTrajectory, times: Any
) -> float:
    """Condition number of the column-scaled regressor stacked along a trajectory.

    ``W = rows_fn(q, v, v̇)`` at ``times``, reshaped to (N·n, p); each column is
    scaled to unit norm before ``σ_max/σ_min``. A zero column gives inf.
    """
    q, velocity, acceleration = trajectory.evaluate(np.asarray(times, dtype=float))
    W = np.asarray(rows_fn(q, velocity, acceleration), dtype=float)
    W = W.reshape(-1, W.shape[-1])
    norms = np.linalg.norm(W, axis=0)
    if not np.all(norms > 0) or not np.all(np.isfinite(W)):
        return math.inf
    singular = np.linalg.svd(W / norms, compute_uv=False)
    return float(singular[0] / singular[-1]) if singular[-1] > 0 else math.inf


def optimize_fourier_trajectory(
    rows_fn: RowsFunction,
    n: int,
    *,
    harmonics: int,
    base_frequency: float,
    max_velocity: Any,
    max_acceleration: Any = None,
    max_position: Any = None,
    q0: Any = None,
    num_samples: int = 200,
    seed: int = 0,
    iterations: int = 300,
) -> FourierTrajectory:
    """Fourier trajectory minimising the condition number of the scaled regressor.

    Minimises ``log10 cond(W S⁻¹)`` where W stacks ``rows_fn(q, v, v̇)`` (N, n, p)
    at ``num_samples`` instants over one period and S scales the columns to unit
    norm, over the coefficients (a, b). Every candidate is first scaled joint by
    joint to its limits (as in :func:`random_fourier_trajectory`), so the limits
    always hold. Optimiser: Nelder-Mead (``scipy.optimize.minimize``) for
    ``iterations`` iterations from the coefficients of
    ``random_fourier_trajectory(..., rng=np.random.default_rng(seed))``;
    deterministic for a given seed.

    Args:
        rows_fn: regressor rows, (N, n) q, v, v̇ -> (N, n, p) (base parameters).
        n: joints.
        harmonics: H >= 1.
        base_frequency: ω_f [rad/s].
        max_velocity: velocity limit [rad/s], scalar or (n,).
        max_acceleration: optional acceleration limit [rad/s²].
        max_position: optional limit on |q - q0| [rad].
        q0: (n,) offsets (default zeros).
        num_samples: instants per period at which the regressor is evaluated.
        seed: seed of the starting point.
        iterations: Nelder-Mead iterations (small budget).

    Returns:
        The best trajectory found (scaled to its limits).
    """
    owner = "optimize_fourier_trajectory"
    if not callable(rows_fn):
        raise TypeError(
            f"{owner}: rows_fn must be callable; got {type(rows_fn).__name__}."
        )
    num_samples = v.integer(owner, "num_samples", num_samples, minimum=2)
    iterations = v.integer(owner, "iterations", iterations, minimum=1)
    seed = v.integer(owner, "seed", seed, minimum=0)
    start = random_fourier_trajectory(
        n,
        harmonics=harmonics,
        base_frequency=base_frequency,
        max_velocity=max_velocity,
        rng=np.random.default_rng(seed),
        q0=q0,
        max_acceleration=max_acceleration,
        max_position=max_position,
    )
    n = start.num_joints
    velocity = _velocity_limit(owner, max_velocity, n)
    acceleration = _limit(owner, "max_acceleration", max_acceleration, n)
    position = _limit(owner, "max_position", max_position, n)
    times = start.period * np.arange(num_samples) / num_samples
    shape = start.a.shape

    def candidate(x: np.ndarray) -> FourierTrajectory:
        raw = FourierTrajectory(
            start.q0,
            x[: x.size // 2].reshape(shape),
            x[x.size // 2 :].reshape(shape),
            start.base_frequency,
        )
        return _scaled(raw, velocity, acceleration, position)

    def cost(x: np.ndarray) -> float:
        condition = regressor_condition_number(rows_fn, candidate(x), times)
        return math.log10(condition) if math.isfinite(condition) else 20.0

    x0 = np.concatenate([start.a.ravel(), start.b.ravel()])
    result = optimize.minimize(
        cost, x0, method="Nelder-Mead", options={"maxiter": iterations}
    )
    best = result.x if result.fun <= cost(x0) else x0
    return candidate(best)
