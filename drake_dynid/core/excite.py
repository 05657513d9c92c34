"""Optimal exciting trajectories under joint limits (Swevers; Presse & Gautier).

A finite Fourier series per joint (``core.trajectory.FourierTrajectory``, period
P = 1/f0, H harmonics) is chosen to minimise the condition number of the
column-scaled base regressor stacked over one period::

    min_x log10 cond(W(x) S⁻¹),  W = [W(q_k, v_k, v̇_k)]_k (N·n × p),  S = diag ‖W_:,i‖

    x = (q0, a, b) ∈ R^{n(2H+1)},  t_k = (k + ½) P/N,  k = 0..N-1

subject to, for every joint j and sample k (limits with the user's margins)::

    |q_j(t_k) - mid_j| <= ρ (half_range_j - margin_q)        position   [rad or m]
    |v_j(t_k)|         <= ρ (1 - margin_v) v_max,j           velocity   [rad/s]
    |v̇_j(t_k)|         <= ρ (1 - margin_a) a_max,j           acceleration (if given)
    |τ_j(t_k)|         <= (1 - margin_τ) τ_max,j, τ = W θ    effort (URDF model)
    d(q(t_k))          >= margin_d                           self-collision [m]
    v(0) = 0, v̇(0) = 0                                       start (and end) at rest

q, v and v̇ are linear in x, so the first three are linear constraints, and
ρ = 1 - (πH/N)²/2 makes them hold between the samples too (Bernstein: a degree-H
trigonometric polynomial exceeds its maximum on N uniform samples by at most that
factor). The effort and the clearance d (a callable, e.g. Drake's signed distance)
are checked on the samples, and again on a 4× denser grid afterwards.

Gradients without differentiating the dynamics twice: W at sample k depends only on
(q_k, v_k, v̇_k), so one forward difference per joint and kind (3n + 1 batched
regressor evaluations, velocity steps taken away from zero so that sign(v) in the
Coulomb columns never flips, v̇ exact since W is linear in it) gives ∂W_k/∂(q, v, v̇)
for every sample at once; the chain rule through the (linear) Fourier basis and the
derivative of log cond with respect to W (singular vectors of the column-scaled
matrix) give the exact gradient of the cost and the Jacobian of the torques.
Optimiser: SLSQP (``scipy.optimize.minimize``) from the random trajectory of the
seed, keeping the best feasible iterate.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import optimize

from drake_dynid.core import _validate as v
from drake_dynid.core.joint_limits import (
    JointLimits,
    Margins,
    limit_violations,
)
from drake_dynid.core.trajectory import FourierTrajectory, random_fourier_trajectory

__all__ = ["ExcitationDesign", "ExcitationSettings", "design_excitation"]

RowsFunction = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
ClearanceFunction = Callable[[np.ndarray], np.ndarray]

_STEP_Q = 1e-6  # forward-difference steps [rad], [rad/s]; v̇ is exact (linear)
_STEP_V = 1e-6
_STEP_CLEARANCE = 1e-5  # [rad]: signed distances are smooth at this scale
_FEASIBLE = 1e-6  # tolerance on the normalised constraints
_MAX_BATCH = 4096  # samples per regressor call
_DENSE = 4  # verification grid: this many times the optimisation grid
SOFTNESS = 20.0  # r of the smooth condition number (see _soft_log_condition)


@dataclass(frozen=True)
class ExcitationSettings:
    """The trajectory family and the optimiser's budget.

    Attributes:
        duration: experiment length [s], a whole number of periods 1/f0.
        harmonics: H >= 1 (band H·f0).
        base_frequency: f0 [Hz].
        samples_per_period: N, optimisation grid (0: max(64, 16H)); >= 4H.
        iterations: SLSQP iterations.
        seed: seed of the random start (and of the default random trajectory).
        rest_start: impose v(0) = v̇(0) = 0 (the robot starts and ends each period
            at rest, so the trajectory can be started from a standstill).
    """

    duration: float = 60.0
    harmonics: int = 5
    base_frequency: float = 0.1
    samples_per_period: int = 0
    iterations: int = 100
    seed: int = 0
    rest_start: bool = True

    def __post_init__(self) -> None:
        owner = "ExcitationSettings"
        duration = v.positive(owner, "duration", self.duration, "s")
        harmonics = v.integer(owner, "harmonics", self.harmonics, minimum=1)
        f0 = v.positive(owner, "base_frequency", self.base_frequency, "Hz")
        v.integer(owner, "iterations", self.iterations, minimum=1)
        v.integer(owner, "seed", self.seed, minimum=0)
        samples = v.integer(owner, "samples_per_period", self.samples_per_period, 0)
        if 0 < samples < 4 * harmonics:
            v.fail(
                owner,
                f"samples_per_period must be >= 4·harmonics = {4 * harmonics}; got "
                f"{samples}.",
            )
        period = 1.0 / f0
        if duration < period * (1.0 - 1e-9):
            v.fail(
                owner,
                f"duration must be at least one period 1/f0 = {period:g} s [s]; got "
                f"{duration:g} (raise the duration or f0).",
            )
        periods = duration / period
        if abs(periods - round(periods)) > 1e-6 * periods:
            v.fail(
                owner,
                f"duration must be a whole number of periods 1/f0 = {period:g} s [s] "
                f"(the trajectory repeats so that periods can be averaged); got "
                f"{duration:g} ({periods:.3g} periods).",
            )

    @property
    def period(self) -> float:
        """1/f0 [s]."""
        return 1.0 / self.base_frequency

    @property
    def num_samples(self) -> int:
        """N, samples per period of the optimisation grid."""
        return self.samples_per_period or max(64, 16 * self.harmonics)


@dataclass(frozen=True, eq=False)
class ExcitationDesign:
    """Outcome of :func:`design_excitation`.

    Attributes:
        trajectory: the optimised trajectory.
        condition_number: its cond(W S⁻¹) over one period (the optimisation grid).
        baseline: the default random trajectory of the same seed, H, f0 and
            position/velocity/acceleration limits
            (:func:`~drake_dynid.core.trajectory.random_fourier_trajectory`).
        baseline_condition_number: its condition number on the same grid.
        settings: the settings used.
        iterations: SLSQP iterations run.
        evaluations: regressor evaluations (batched calls of rows_fn).
        message: the optimiser's message.
        usage: per kind ("position", "velocity", "acceleration", "effort"), the
            largest fraction of the raw limit used by each joint (n,) on a grid 4×
            denser than the optimisation's (position: |q - mid|/half range).
        clearance: smallest signed distance on that grid [m] (inf without
            collision geometry).
    """

    trajectory: FourierTrajectory
    condition_number: float
    baseline: FourierTrajectory
    baseline_condition_number: float
    settings: ExcitationSettings
    iterations: int
    evaluations: int
    message: str
    usage: dict[str, np.ndarray] = field(default_factory=dict)
    clearance: float = math.inf


def _condition(W: np.ndarray) -> float:
    Wf = W.reshape(-1, W.shape[-1])
    norms = np.linalg.norm(Wf, axis=0)
    if not (np.all(np.isfinite(Wf)) and np.all(norms > 0.0)):
        return math.inf
    s = np.linalg.svd(Wf / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0.0 else math.inf


def _soft_log_condition(s: np.ndarray) -> tuple[float, np.ndarray]:
    """Smooth log10 condition number and its gradient with respect to σ.

    ``log10(‖σ‖_r · ‖1/σ‖_r)`` with r = SOFTNESS: an upper bound of log10 cond that
    tends to it as r grows, and is differentiable where σ_max or σ_min repeat
    (the plain condition number is not, which stalls SLSQP at the optimum, where
    the extreme singular values cluster).
    """
    if not s[-1] > 0.0:
        return 20.0, np.zeros_like(s)
    r = SOFTNESS
    top = (s / s[0]) ** r
    bottom = (s[-1] / s) ** r
    cost = (
        math.log10(s[0] / s[-1])
        + (math.log10(top.sum()) + math.log10(bottom.sum())) / r
    )
    weights = (top / top.sum() - bottom / bottom.sum()) / (s * math.log(10.0))
    return cost, weights


def _rows(rows_fn: RowsFunction, q, qd, qdd) -> np.ndarray:
    """rows_fn over a batch, in chunks of at most _MAX_BATCH samples."""
    parts = [
        np.asarray(
            rows_fn(
                q[i : i + _MAX_BATCH], qd[i : i + _MAX_BATCH], qdd[i : i + _MAX_BATCH]
            ),
            dtype=float,
        )
        for i in range(0, q.shape[0], _MAX_BATCH)
    ]
    return parts[0] if len(parts) == 1 else np.concatenate(parts)


class _Problem:
    """Grid, basis and limit bounds of one design (private, built once)."""

    def __init__(self, rows_fn, theta, limits, settings, margins, clearance_fn):
        self.rows_fn = rows_fn
        self.theta = theta
        self.limits = limits
        self.settings = settings
        self.margins = margins
        self.clearance_fn = clearance_fn
        self.n = n = limits.num_joints
        self.H = H = settings.harmonics
        self.N = N = settings.num_samples
        self.omega = 2.0 * math.pi * settings.base_frequency
        self.t = (np.arange(N) + 0.5) * settings.period / N
        self.basis = self._basis(self.t)
        self.rho = 1.0 - 0.5 * (math.pi * H / N) ** 2
        self.mid = 0.5 * (limits.lower + limits.upper)
        self.half = 0.5 * (limits.upper - limits.lower) - margins.position
        self.vmax = (1.0 - margins.velocity) * limits.velocity
        self.amax = (1.0 - margins.acceleration) * limits.acceleration
        self.emax = (1.0 - margins.effort) * limits.effort
        self.size = n * (2 * H + 1)
        self.evaluations = 0
        self._values: dict[bytes, tuple] = {}
        self._gradients: dict[bytes, tuple] = {}
        self._clearances: dict[bytes, tuple] = {}

    def _basis(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        wl = self.omega * np.arange(1, self.H + 1)
        S, C = np.sin(np.outer(t, wl)), np.cos(np.outer(t, wl))
        return (
            np.hstack([S / wl, -C / wl]),  # q - q0
            np.hstack([C, S]),  # v
            np.hstack([-S * wl, C * wl]),  # v̇
        )

    # --------------------------------------------------------------- parametrisation
    def unpack(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return x[: self.n], x[self.n :].reshape(self.n, 2 * self.H)

    def pack(self, trajectory: FourierTrajectory) -> np.ndarray:
        ab = np.hstack([trajectory.a, trajectory.b])
        return np.concatenate([trajectory.q0, ab.ravel()])

    def trajectory(self, x: np.ndarray) -> FourierTrajectory:
        q0, ab = self.unpack(x)
        return FourierTrajectory(q0, ab[:, : self.H], ab[:, self.H :], self.omega)

    def kinematics(self, x: np.ndarray, basis=None):
        q0, ab = self.unpack(x)
        Bq, Bv, Ba = self.basis if basis is None else basis
        return q0 + Bq @ ab.T, Bv @ ab.T, Ba @ ab.T

    # ------------------------------------------------------------------- cost, torque
    def values(self, x: np.ndarray) -> tuple:
        """(cost, W, τ, svd pieces) at x, cached."""
        key = x.tobytes()
        if key not in self._values:
            q, qd, qdd = self.kinematics(x)
            W = _rows(self.rows_fn, q, qd, qdd)
            self.evaluations += 1
            Wf = W.reshape(-1, W.shape[-1])
            norms = np.linalg.norm(Wf, axis=0)
            if np.all(np.isfinite(Wf)) and np.all(norms > 0.0):
                A = Wf / norms
                U, s, Vt = np.linalg.svd(A, full_matrices=False)
                cost, weights = _soft_log_condition(s)
                svd = (A, norms, U, weights, Vt)
            else:
                cost, svd = 20.0, None
            self._values = {key: (cost, W, W @ self.theta, svd, (q, qd, qdd))}
        return self._values[key]

    def gradients(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(∂cost/∂x (size,), ∂τ/∂x (N, n, size)), cached."""
        key = x.tobytes()
        if key in self._gradients:
            return self._gradients[key]
        _, W, _, svd, (q, qd, qdd) = self.values(x)
        n, N, p = self.n, self.N, W.shape[-1]
        if svd is None:
            G = np.zeros_like(W)
        else:
            A, norms, U, weights, Vt = svd
            GA = (U * weights) @ Vt
            G = ((GA - A * np.sum(A * GA, axis=0)) / norms).reshape(N, n, p)
        eye = np.eye(n)
        step_v = np.where(qd >= 0.0, _STEP_V, -_STEP_V)  # away from zero
        steps = [np.full((N, n), _STEP_Q), step_v, np.ones((N, n))]
        Q = np.concatenate([q + _STEP_Q * eye[j] for j in range(n)] + [q] * 2 * n)
        V = np.concatenate(
            [qd] * n + [qd + step_v * eye[j] for j in range(n)] + [qd] * n
        )
        Ac = np.concatenate([qdd] * 2 * n + [qdd + eye[j] for j in range(n)])
        Wb = _rows(self.rows_fn, Q, V, Ac).reshape(3, n, N, n, p)
        self.evaluations += 1
        g = np.empty((3, N, n))  # ∂cost/∂(q, v, v̇)_kj
        dtau = np.empty((3, n, N, n))  # ∂τ_ki/∂(q, v, v̇)_kj, [kind, j, k, i]
        for kind in range(3):
            for j in range(n):
                dW = (Wb[kind, j] - W) / steps[kind][:, j, None, None]
                g[kind, :, j] = np.einsum("kic,kic->k", G, dW)
                dtau[kind, j] = dW @ self.theta
        Bq, Bv, Ba = self.basis
        grad_ab = g[0].T @ Bq + g[1].T @ Bv + g[2].T @ Ba
        grad = np.concatenate([g[0].sum(axis=0), grad_ab.ravel()])
        J_q0 = np.transpose(dtau[0], (1, 2, 0))  # (N, n_i, n_j)
        J_ab = (
            np.einsum("jki,km->kijm", dtau[0], Bq)
            + np.einsum("jki,km->kijm", dtau[1], Bv)
            + np.einsum("jki,km->kijm", dtau[2], Ba)
        ).reshape(N, n, -1)
        self._gradients = {key: (grad, np.concatenate([J_q0, J_ab], axis=2))}
        return self._gradients[key]

    # ------------------------------------------------------------------ clearance
    def clearance(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(d (N,), ∂d/∂x (N, size)) [m], cached."""
        key = x.tobytes()
        if key not in self._clearances:
            q, _, _ = self.kinematics(x)
            n, N = self.n, self.N
            Q = np.concatenate([q] + [q + _STEP_CLEARANCE * e for e in np.eye(n)])
            d = np.asarray(self.clearance_fn(Q), dtype=float).reshape(n + 1, N)
            dd = (d[1:] - d[0]) / _STEP_CLEARANCE  # (n_j, N)
            J_ab = np.einsum("jk,km->kjm", dd, self.basis[0]).reshape(N, -1)
            self._clearances = {key: (d[0], np.hstack([dd.T, J_ab]))}
        return self._clearances[key]

    # ---------------------------------------------------------------- constraints
    def linear(self) -> tuple[np.ndarray, np.ndarray, list[tuple[str, int, int]]]:
        """(M, h, labels): normalised linear inequalities M x + h >= 0."""
        n, H, N = self.n, self.H, self.N
        rows, offsets, labels = [], [], []
        Bq, Bv, Ba = self.basis
        for kind, B, bound in (
            ("position", Bq, self.half),
            ("velocity", Bv, self.vmax),
            ("acceleration", Ba, self.amax),
        ):
            for j in range(n):
                if not np.isfinite(bound[j]):
                    continue
                # block @ x = (q_j - q0_j) + q0_j for positions, v_j or v̇_j otherwise.
                block = np.zeros((N, self.size))
                block[:, n + j * 2 * H : n + (j + 1) * 2 * H] = B
                centre = 0.0
                if kind == "position":
                    block[:, j] = 1.0
                    centre = self.mid[j]
                # ρ·bound - (value - centre) >= 0 and ρ·bound + (value - centre) >= 0
                for sign in (-1.0, 1.0):
                    rows.append(sign * block / bound[j])
                    offsets.append(np.full(N, self.rho - sign * centre / bound[j]))
                    labels.append((kind, j, int(sign)))
        return np.vstack(rows), np.concatenate(offsets), labels

    def equality(self) -> np.ndarray:
        """Rows E with E x = 0: v_j(0) = Σ a_jl = 0, v̇_j(0) ∝ Σ l b_jl = 0."""
        n, H = self.n, self.H
        E = np.zeros((2 * n, self.size))
        for j in range(n):
            start = n + j * 2 * H
            E[2 * j, start : start + H] = 1.0
            E[2 * j + 1, start + H : start + 2 * H] = np.arange(1, H + 1)
        return E

    def effort(self, x: np.ndarray) -> np.ndarray:
        finite = np.isfinite(self.emax)
        tau = self.values(x)[2][:, finite] / self.emax[finite]
        return np.concatenate([(1.0 - tau).ravel(), (1.0 + tau).ravel()])

    def effort_jacobian(self, x: np.ndarray) -> np.ndarray:
        finite = np.isfinite(self.emax)
        J = self.gradients(x)[1][:, finite] / self.emax[finite][None, :, None]
        J = J.reshape(-1, self.size)
        return np.vstack([-J, J])


def _start(problem: _Problem) -> np.ndarray:
    """The seed's random coefficients, at rest at t = 0, scaled into the limits."""
    n, H = problem.n, problem.H
    rng = np.random.default_rng(problem.settings.seed)
    a = rng.standard_normal((n, H))
    b = rng.standard_normal((n, H))
    if problem.settings.rest_start:
        a -= a.mean(axis=1, keepdims=True)
        ell = np.arange(1, H + 1)
        b -= np.outer(b @ ell, ell) / (ell @ ell)
    x = np.concatenate([problem.mid, np.hstack([a, b]).ravel()])
    q, qd, qdd = problem.kinematics(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.minimum.reduce(
            [
                problem.rho * problem.half / np.abs(q - problem.mid).max(axis=0),
                problem.rho * problem.vmax / np.abs(qd).max(axis=0),
                problem.rho * problem.amax / np.abs(qdd).max(axis=0),
            ]
        )
    ratio = np.where(np.isfinite(ratio), ratio, 0.0)
    _, ab = problem.unpack(x)
    return np.concatenate([problem.mid, (ab * ratio[:, None]).ravel()])


def _baseline(problem: _Problem) -> FourierTrajectory:
    """The default random trajectory: same seed, H, f0 and kinematic limits."""
    finite = np.isfinite(problem.amax)
    return random_fourier_trajectory(
        problem.n,
        harmonics=problem.H,
        base_frequency=problem.omega,
        max_velocity=problem.vmax,
        max_acceleration=np.where(finite, problem.amax, 1e300)
        if finite.any()
        else None,
        max_position=problem.half,
        q0=problem.mid,
        rng=np.random.default_rng(problem.settings.seed),
    )


def _usage(problem: _Problem, trajectory: FourierTrajectory) -> tuple[dict, float]:
    """Fractions of the raw limits used on the dense grid, and the clearance."""
    limits = problem.limits
    N = _DENSE * problem.N
    t = (np.arange(N) + 0.5) * problem.settings.period / N
    q, qd, qdd = trajectory.evaluate(t)
    tau = _rows(problem.rows_fn, q, qd, qdd) @ problem.theta
    with np.errstate(divide="ignore", invalid="ignore"):
        half = 0.5 * (limits.upper - limits.lower)
        usage = {
            "position": np.abs(q - problem.mid).max(axis=0) / half,
            "velocity": np.abs(qd).max(axis=0) / limits.velocity,
            "acceleration": np.abs(qdd).max(axis=0) / limits.acceleration,
            "effort": np.abs(tau).max(axis=0) / limits.effort,
        }
    clearance = math.inf
    if problem.clearance_fn is not None:
        clearance = float(np.min(problem.clearance_fn(q)))
    return usage, clearance


def _most_violated(problem: _Problem, x: np.ndarray) -> str:
    trajectory = problem.trajectory(x)
    q, qd, qdd = trajectory.evaluate(problem.t)
    tau = problem.values(x)[2]
    clearance = problem.clearance(x)[0] if problem.clearance_fn is not None else None
    found = limit_violations(
        problem.t,
        q,
        qd,
        qdd,
        tau,
        problem.limits,
        problem.margins,
        clearance=clearance,
        tolerance=1e-3,
    )
    if not found:
        return "the constraints could not be met together"
    worst = max(
        found,
        key=lambda f: abs(f.value - f.limit) / max(abs(f.limit), 1e-9),
    )
    return str(worst)


def design_excitation(
    rows_fn: RowsFunction,
    theta: Any,
    limits: JointLimits,
    settings: ExcitationSettings | None = None,
    margins: Margins | None = None,
    *,
    clearance_fn: ClearanceFunction | None = None,
    max_condition: float = 1e6,
) -> ExcitationDesign:
    """Optimises a periodic Fourier trajectory for the regressor's condition number.

    See the module docstring for the problem. Deterministic for given inputs.

    Args:
        rows_fn: base-parameter IDIM rows, (N, n) q, v, v̇ -> (N, n, p)
            (``RobotModel.idim_rows``); the torque is ``rows_fn(q, v, v̇) @ theta``.
        theta: (p,) base parameter values of the model (for the torques) [SI].
        limits: joint limits; position, velocity and effort limits must be finite
            (:meth:`JointLimits.missing`), an infinite effort is not constrained.
        settings: duration, H, f0, grid, budget, seed (default
            ``ExcitationSettings()``).
        margins: margins kept from the limits (default ``Margins()``).
        clearance_fn: optional (M, n) q -> (M,) smallest signed distance between
            collision geometries [m] (self-collision constraint).
        max_condition: a result above this condition number is an error (no
            trajectory within the limits excites every base parameter).

    Returns:
        The :class:`ExcitationDesign`.

    Raises:
        ValueError: missing limits, margins that leave no room, or no feasible
            trajectory (the message names the limiting constraint).
    """
    owner = "design_excitation"
    if not callable(rows_fn):
        raise TypeError(f"{owner}: rows_fn must be callable.")
    if not isinstance(limits, JointLimits):
        raise TypeError(f"{owner}: limits must be a JointLimits.")
    theta = v.array(owner, "theta", theta)
    settings = ExcitationSettings() if settings is None else settings
    margins = Margins() if margins is None else margins
    missing = [m for m in limits.missing() if "position" in m or "velocity" in m]
    if missing:
        v.fail(
            owner,
            f"position and velocity limits are needed for every joint; missing for "
            f"{'; '.join(missing)}.",
        )
    problem = _Problem(rows_fn, theta, limits, settings, margins, clearance_fn)
    tight = np.flatnonzero(problem.half <= 0.0)
    if tight.size:
        j = int(tight[0])
        v.fail(
            owner,
            f"joint {limits.joint_names[j]}: the position margin {margins.position:g} "
            f"leaves no room within [{limits.lower[j]:g}, {limits.upper[j]:g}] "
            f"{limits.units(j)[0]}.",
        )
    x0 = _start(problem)
    baseline = _baseline(problem)
    baseline_condition = _condition(_rows(rows_fn, *baseline.evaluate(problem.t)))

    lin_M, lin_h, _ = problem.linear()
    constraints = [
        {"type": "ineq", "fun": lambda x: lin_M @ x + lin_h, "jac": lambda x: lin_M}
    ]
    if settings.rest_start:
        E = problem.equality()
        constraints.append({"type": "eq", "fun": lambda x: E @ x, "jac": lambda x: E})
    if np.any(np.isfinite(problem.emax)):
        constraints.append(
            {"type": "ineq", "fun": problem.effort, "jac": problem.effort_jacobian}
        )
    if clearance_fn is not None:
        scale = 10.0  # per 0.1 m

        def collision(x):
            return scale * (problem.clearance(x)[0] - margins.collision)

        def collision_jacobian(x):
            return scale * problem.clearance(x)[1]

        constraints.append(
            {"type": "ineq", "fun": collision, "jac": collision_jacobian}
        )

    def feasible(x: np.ndarray) -> bool:
        return all(
            np.all(c["fun"](x) >= -_FEASIBLE)
            if c["type"] == "ineq"
            else np.all(np.abs(c["fun"](x)) <= _FEASIBLE)
            for c in constraints
        )

    best = {"x": None, "cost": math.inf}

    def track(x: np.ndarray) -> None:
        x = np.array(x, dtype=float)
        cost = _condition(problem.values(x)[1])
        if cost < best["cost"] and feasible(x):
            best.update(x=x, cost=cost)

    track(x0)
    result = optimize.minimize(
        lambda x: problem.values(x)[0],
        x0,
        jac=lambda x: problem.gradients(x)[0],
        method="SLSQP",
        constraints=constraints,
        callback=track,
        options={"maxiter": settings.iterations, "ftol": 1e-7},
    )
    track(result.x)
    if best["x"] is None:
        v.fail(
            owner,
            f"no trajectory meets the limits (after the margins): "
            f"{_most_violated(problem, result.x)}. Raise the limits, lower the "
            "margins (--margin), or lower f0/harmonics.",
        )
    x = best["x"]
    condition = best["cost"]
    if not condition <= max_condition:
        v.fail(
            owner,
            f"the best trajectory within the limits has condition number "
            f"{condition:.3g} > {max_condition:g}: the limits leave too little "
            "motion to excite every base parameter; widen the limits or margins, or "
            "raise the duration, harmonics or f0.",
        )
    trajectory = problem.trajectory(x)
    usage, clearance = _usage(problem, trajectory)
    return ExcitationDesign(
        trajectory=trajectory,
        condition_number=float(condition),
        baseline=baseline,
        baseline_condition_number=float(baseline_condition),
        settings=settings,
        iterations=int(result.nit),
        evaluations=int(problem.evaluations),
        message=str(result.message),
        usage=usage,
        clearance=clearance,
    )
