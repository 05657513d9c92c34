"""Optimal exciting trajectories under joint limits (Swevers; Presse & Gautier).

A finite Fourier series per joint (``core.trajectory.FourierTrajectory``, period
P = 1/f0, H harmonics) is chosen to minimise the condition number of the
column-scaled base regressor stacked over one period::

    min_x log10 cond(W(x) S⁻¹),  W = [W(q_k, v_k, v̇_k)]_k (N·n × p),  S = diag ‖W_:,i‖

    x = (q0, a, b) ∈ R^{n(2H+1)},  t_k = (k + ½) P/N,  k = 0..N-1

subject to, for every joint j and sample k (limits with the user's margins)::

    |q_j(t_k) - mid_j| <= ρ (half_range_j - margin_q,j)      position   [rad or m]
    |v_j(t_k)|         <= ρ (1 - margin_v) v_max,j           velocity   [rad/s]
    |v̇_j(t_k)|         <= ρ (1 - margin_a) a_max,j           acceleration (if given)
    |τ_j(t_k)|         <= (1 - margin_τ) τ_max,j, τ = W θ    effort (URDF model)
    d(q(t_k))          >= margin_d                           self-collision [m]
    v(0) = 0, v̇(0) = 0                                       start (and end) at rest

(margin_q,j: ``Margins.position`` [rad] on a revolute joint, ``Margins.prismatic``
[m] on a prismatic one.) q, v and v̇ are linear in x, so the first three are linear
constraints, and ρ = 1 - (πH/N)²/2 makes them hold between the samples too
(Bernstein: a degree-H trigonometric polynomial exceeds its maximum on N uniform
samples by at most that factor). The effort and the clearance d (a callable, e.g.
Drake's signed distance) are constrained on the samples; a check on a 16× denser
grid (each joint's peak refined on a 33-point grid one dense step either side) then
finds their extremes between the samples, and where τ_j or d passes its margined
bound there, the design is solved again from its optimum with that bound tightened
by the excess found (τ_max,j divided by max|τ_j|/bound, margin_d raised by the
shortfall), at most 30 SLSQP iterations, keeping the best iterate that the dense
check passes as well; up to 3 rounds, each tightening by the excess where the last
one ended (the UR5 at 0.3x its datasheet torques, seeds 0-3: up to 100.033 % of the
margined effort between the samples before, at most 100 % after).

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
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import optimize

from drake_dynid.core import _validate as v
from drake_dynid.core.excite_problem import (
    ExcitationProblem,
    RowsFunction,
    batched_rows,
    condition_number,
)
from drake_dynid.core.joint_limits import (
    JointLimits,
    Margins,
    Violation,
    limit_violations,
)
from drake_dynid.core.trajectory import FourierTrajectory, random_fourier_trajectory

__all__ = ["ExcitationDesign", "ExcitationSettings", "design_excitation"]

ClearanceFunction = Callable[[np.ndarray], np.ndarray]

_FEASIBLE = 1e-6  # tolerance on the normalised constraints
#: Hard ceilings on the design's work: harmonics per joint (the optimiser has
#: 2·n·H variables), grid samples per period, and the experiment's length [s].
MAX_HARMONICS = 50
MAX_SAMPLES_PER_PERIOD = 1 << 16
MAX_DURATION = 1e5  # as trajectory_file.MAX_DURATION: its JSON is read back
_DENSE = 16  # verification grid: this many times the optimisation grid
_REFINE = 33  # points of the local grid (± one dense step) around each peak
_ROUNDS = 3  # re-solves with the bounds tightened by the dense check's excess
_TIGHTEN = 1e-3  # relative room kept below a tightened bound
_ROUND_ITERATIONS = 30  # SLSQP iterations of a re-solve (from the optimum)


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
        rest_start: impose v(0) = v̇(0) = 0 (each period starts and ends at rest,
            so the trajectory can be started from a standstill). Off by default:
            all joints then dwell near zero velocity at every period boundary,
            where Coulomb friction is least like sign(v), and the simulated
            friction estimates degrade (benchmarks/bench_excite.py).
    """

    duration: float = 60.0
    harmonics: int = 5
    base_frequency: float = 0.2
    samples_per_period: int = 0
    iterations: int = 100
    seed: int = 0
    rest_start: bool = False

    def __post_init__(self) -> None:
        owner = "ExcitationSettings"
        duration = v.positive(owner, "duration", self.duration, "s")
        harmonics = v.integer(owner, "harmonics", self.harmonics, minimum=1)
        f0 = v.positive(owner, "base_frequency", self.base_frequency, "Hz")
        if duration > MAX_DURATION:
            v.fail(
                owner, f"duration must be <= {MAX_DURATION:g} [s]; got {duration:g}."
            )
        if harmonics > MAX_HARMONICS:
            v.fail(owner, f"harmonics must be <= {MAX_HARMONICS}; got {harmonics}.")
        v.integer(owner, "iterations", self.iterations, minimum=1)
        v.integer(owner, "seed", self.seed, minimum=0)
        samples = v.integer(owner, "samples_per_period", self.samples_per_period, 0)
        if samples > MAX_SAMPLES_PER_PERIOD:
            v.fail(
                owner,
                f"samples_per_period must be <= {MAX_SAMPLES_PER_PERIOD}; got "
                f"{samples}.",
            )
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
            largest fraction of the raw limit used by each joint (n,) on a grid 16×
            denser than the optimisation's, refined around each peak (position:
            |q - mid|/half range).
        clearance: smallest signed distance on that grid [m] (inf without
            collision geometry).
        unexcitable: indices of the base parameters whose regressor column
            vanishes at random states (no motion excites them; left out of the
            condition numbers).
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
    unexcitable: tuple[int, ...] = ()


def _start(problem: ExcitationProblem) -> np.ndarray:
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


def _constraints(
    problem: ExcitationProblem, emax: np.ndarray | None = None
) -> list[dict]:
    """SLSQP constraints: kinematic limits (linear), rest start, effort.

    ``emax`` (n,): the effort bounds (default the margined limits ``problem.emax``).
    """
    emax = problem.emax if emax is None else emax
    lin_M, lin_h, _ = problem.linear()
    out = [{"type": "ineq", "fun": lambda x: lin_M @ x + lin_h, "jac": lambda x: lin_M}]
    if problem.settings.rest_start:
        E = problem.equality()
        out.append({"type": "eq", "fun": lambda x: E @ x, "jac": lambda x: E})
    if np.any(np.isfinite(emax)):
        out.append(
            {
                "type": "ineq",
                "fun": lambda x: problem.effort(x, emax),
                "jac": lambda x: problem.effort_jacobian(x, emax),
            }
        )
    return out


def _collision_constraint(
    problem: ExcitationProblem, margin: float | None = None
) -> dict | None:
    """The clearance constraint 10·(d - margin) >= 0 (per 0.1 m), or None.

    ``margin`` [m]: default the user's ``problem.margins.collision``.
    """
    if problem.clearance_fn is None:
        return None
    margin = problem.margins.collision if margin is None else margin
    return {
        "type": "ineq",
        "fun": lambda x: 10.0 * (problem.clearance(x)[0] - margin),
        "jac": lambda x: 10.0 * problem.clearance(x)[1],
    }


def _shrink(problem: ExcitationProblem, x: np.ndarray, feasible) -> np.ndarray:
    """Scales the motion of x down (about q0) until ``feasible``, if that helps.

    Bisection on the factor s of the Fourier coefficients (the effort and the
    clearance are not monotonic in s, but a start near the feasible set keeps
    SLSQP's first steps small); x itself when feasible or when s = 0 is not.
    """
    n = problem.n

    def scaled(factor: float) -> np.ndarray:
        return np.concatenate([x[:n], factor * x[n:]])

    if feasible(x) or not feasible(scaled(0.0)):
        return x
    low, high = 0.0, 1.0
    for _ in range(12):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if feasible(scaled(middle)) else (low, middle)
    return scaled(low)


def _bounds(problem: ExcitationProblem) -> list[tuple[float, float]]:
    """Box bounds that contain every feasible x (they keep SLSQP's steps physical).

    q0 within the position limits and |a_jl|, |b_jl| <= 2 v_max,j (a Fourier
    coefficient of v_j is at most twice max |v_j|).
    """
    out = [
        (float(lo), float(hi))
        for lo, hi in zip(problem.limits.lower, problem.limits.upper, strict=True)
    ]
    for j in range(problem.n):
        bound = 2.0 * float(problem.vmax[j])
        out += [(-bound, bound)] * (2 * problem.H)
    return out


def _baseline(problem: ExcitationProblem) -> FourierTrajectory:
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


def _usage(
    problem: ExcitationProblem, trajectory: FourierTrajectory
) -> tuple[dict, float]:
    """Fractions of the raw limits used on the dense grid, and the clearance [m].

    The grid is ``_DENSE`` times the optimisation's; each joint's and kind's
    largest sample (and the smallest clearance) is then refined on a local grid
    of ``_REFINE`` points one dense step either side of it.
    """
    limits = problem.limits
    N = _DENSE * problem.N
    step = problem.settings.period / N
    t = (np.arange(N) + 0.5) * step

    def magnitudes(times: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        q, qd, qdd = trajectory.evaluate(times)
        tau = batched_rows(problem.rows_fn, q, qd, qdd) @ problem.theta
        values = {
            "position": np.abs(q - problem.mid),
            "velocity": np.abs(qd),
            "acceleration": np.abs(qdd),
            "effort": np.abs(tau),
        }
        return q, values

    q, values = magnitudes(t)
    local = np.linspace(-step, step, _REFINE)
    peaks = np.concatenate([t[np.argmax(value, axis=0)] for value in values.values()])
    _, near = magnitudes((peaks[:, None] + local).ravel())
    bound = {
        "position": 0.5 * (limits.upper - limits.lower),
        "velocity": limits.velocity,
        "acceleration": limits.acceleration,
        "effort": limits.effort,
    }
    with np.errstate(divide="ignore", invalid="ignore"):
        usage = {
            kind: np.maximum(value.max(axis=0), near[kind].max(axis=0)) / bound[kind]
            for kind, value in values.items()
        }
    clearance = math.inf
    if problem.clearance_fn is not None:
        d = np.asarray(problem.clearance_fn(q), dtype=float)
        nearest = trajectory.evaluate(t[int(np.argmin(d))] + local)[0]
        clearance = float(min(d.min(), np.min(problem.clearance_fn(nearest))))
    return usage, clearance


def _dense_excess(
    problem: ExcitationProblem, usage: dict, clearance: float
) -> tuple[np.ndarray, float]:
    """(ratio (n,) of each dense max|τ_j| to its margined bound, clearance shortfall).

    A ratio above 1 or a shortfall above 0 [m] (the collision margin less the dense
    clearance): the constraints on the grid let the motion pass them between its
    samples. Joints without an effort limit: ratio 0.
    """
    allowed = 1.0 - problem.margins.effort
    finite = np.isfinite(problem.emax)
    ratio = np.where(finite, np.where(finite, usage["effort"], 0.0) / allowed, 0.0)
    margin = problem.margins.collision
    shortfall = margin - clearance if math.isfinite(clearance) else 0.0
    return ratio, shortfall


def _dense_holds(problem: ExcitationProblem, x: np.ndarray) -> bool:
    """Whether x keeps the margined effort and clearance on the dense grid.

    The grid of :func:`_usage`, within the optimiser's tolerance.
    """
    usage, clearance = _usage(problem, problem.trajectory(x))
    ratio, shortfall = _dense_excess(problem, usage, clearance)
    return bool(np.all(ratio <= 1.0 + _FEASIBLE)) and not shortfall > _FEASIBLE


_COLLISION_ADVICE = (
    "if the links cannot meet in the real robot (a convex hull of a coarse "
    "collision mesh covers more than the part), simplify their collision "
    "geometry; otherwise narrow the ranges of the joints that bring them together "
    "(--limits lower/upper), lock one (--lock NAME=VALUE), or lower the collision "
    "margin (--margin collision=M)"
)


def _advice(problem: ExcitationProblem, found: Violation, resting: np.ndarray) -> str:
    """What a user can change about one broken limit (``found``).

    ``resting`` (n,): |τ| [N·m or N] standing still at mid-range; an effort limit
    it already passes is said with the effort limit the model needs.
    """
    kind = found.kind
    if kind == "collision":
        return _COLLISION_ADVICE
    j = problem.limits.joint_names.index(found.joint)
    if kind == "position":
        margin = "prismatic=M" if problem.limits.prismatic[j] else "position=RAD"
        return (
            f"widen its range (--limits FILE, lower/upper) or lower the margin "
            f"(--margin {margin})"
        )
    if kind in ("velocity", "acceleration"):
        return (
            f"raise its {kind} limit (--limits FILE, {kind}), lower the margin "
            f"(--margin {kind}=FRAC), or lower f0/harmonics"
        )
    allowed = 1.0 - problem.margins.effort
    if resting[j] > found.limit * (1.0 + _FEASIBLE):
        need = resting[j] / allowed
        return (
            f"standing still at mid-range it already needs {resting[j]:.3g} "
            f"{found.unit} (the URDF's gravity), more than the {found.limit:.3g} "
            f"{found.unit} allowed ({problem.limits.effort[j]:.4g} less the "
            f"{problem.margins.effort:.0%} effort margin): a design can only move "
            "about a posture where gravity needs less. If the real joint has help "
            "the URDF does not model (a counterbalance spring), give it an effort "
            f"limit above {need:.3g} {found.unit} (--limits FILE, effort) so that "
            "the URDF's torques fit; otherwise lock the joint (--lock "
            f"{found.joint}=VALUE) or narrow its range to where gravity needs less "
            "(--limits lower/upper)"
        )
    return (
        "raise its effort limit (--limits FILE, effort), lower the margin "
        "(--margin effort=FRAC), or lower f0/harmonics"
    )


def _refusal(problem: ExcitationProblem, x: np.ndarray) -> str:
    """Every constraint x breaks, most violated first, each with what to change.

    Most violated: the largest excess relative to the bound, |value - bound| /
    |bound| (a position's relative to its margined half range, :func:`_excess`).
    A clearance shortfall names each pair of links below the margin
    when ``clearance_fn`` has a ``below(q, margin) -> [(d [m], "A-B"[, geometric
    d]), ...]``
    method (``collision.SelfCollision``), else the closest pair at the worst
    sample with a ``closest(q) -> (d [m], "A-B")`` method.
    """
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
        return (
            "the constraints could not be met together. Raise the limits, lower the "
            "margins (--margin), or lower f0/harmonics"
        )
    collisions = [f for f in found if f.kind == "collision"]
    if collisions and clearance is not None:
        found = [f for f in found if f.kind != "collision"]
        found += _pairs(problem, q, clearance, collisions[0])
    found.sort(key=lambda f: -_excess(problem, f))
    zero = np.zeros((1, problem.n))
    resting = np.abs(
        batched_rows(problem.rows_fn, problem.mid[None, :], zero, zero)[0]
        @ problem.theta
    )
    items: list[str] = []
    said: dict[str, int] = {}  # advice -> the item that gave it
    for i, f in enumerate(found, 1):
        advice = _advice(problem, f, resting)
        items.append(
            f"({i}) {f}: " + (f"as ({said[advice]})" if advice in said else advice)
        )
        said.setdefault(advice, i)
    return (
        f"the optimiser's last iterate (none it tried met every constraint) breaks "
        f"{len(found)} limit{'s' if len(found) > 1 else ''}, most violated first: "
        + "; ".join(items)
    )


def _excess(problem: ExcitationProblem, found: Violation) -> float:
    """How much ``found`` breaks its bound, relative to it (the refusal's order).

    |value - bound| / |bound| (a fraction over a velocity, acceleration or effort
    limit; margins short of the collision margin), but a position's excess
    relative to the joint's margined half range [rad or m]: a bound's own value
    says nothing of how far (0.01 rad past a bound at 0 rad came before an
    effort 2.25 times its limit).
    """
    scale = abs(found.limit)
    if found.kind == "position":
        scale = float(problem.half[problem.limits.joint_names.index(found.joint)])
    return abs(found.value - found.limit) / max(scale, 1e-9)


def _pairs(
    problem: ExcitationProblem,
    q: np.ndarray,
    clearance: np.ndarray,
    worst: Violation,
) -> list[Violation]:
    """One collision :class:`Violation` per pair of links below the margin.

    Each pair at its own smallest distance over the grid's samples; ``worst``
    (the smallest clearance, no pair named) when ``clearance_fn`` names none.
    A ``below`` item ``(d, "A-B", geometric d)`` (a pair held no closer than half
    its mid-range distance, ``collision.SelfCollision``) is said at its geometric
    distance against the distance it is held at, not at the offset clearance
    the optimiser sees (base-l2 0.062 m deep read 'clearance 0.0325 m').
    """
    margin = problem.margins.collision
    below = getattr(problem.clearance_fn, "below", None)
    closest = getattr(problem.clearance_fn, "closest", None)
    if callable(below):
        pairs: dict[str, Violation] = {}
        for k in np.flatnonzero(clearance < margin - 1e-3):
            for distance, pair, *geometric in below(q[k], margin - 1e-3):
                real = float(geometric[0]) if geometric else float(distance)
                if pair not in pairs or real < pairs[pair].value:
                    held = " (held at half its mid-range distance)"
                    pairs[pair] = replace(
                        worst,
                        joint=pair + (held if real != distance else ""),
                        time=float(problem.t[k]),
                        value=real,
                        limit=margin - (float(distance) - real),
                    )
        if pairs:
            return list(pairs.values())
    if callable(closest):
        return [replace(worst, joint=str(closest(q[int(np.argmin(clearance))])[1]))]
    return [worst]


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
            collision geometries [m] (self-collision constraint); with a
            ``below(q, margin) -> [(d, "A-B"), ...]`` method (or a
            ``closest(q) -> (d, "A-B")`` one), a refusal on the clearance names
            the pairs of links (or the closest pair).
        max_condition: a result above this condition number is an error (no
            trajectory within the limits excites every base parameter).

    Returns:
        The :class:`ExcitationDesign`.

    Raises:
        ValueError: missing limits, margins that leave no room, or no feasible
            trajectory (the message lists every limit the optimiser's last
            iterate breaks, most violated first, each with what to change).
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
            f"{v.listed(missing, sep='; ')}.",
        )
    problem = ExcitationProblem(rows_fn, theta, limits, settings, margins, clearance_fn)
    tight = np.flatnonzero(problem.half <= 0.0)
    if tight.size:
        j = int(tight[0])
        kind = "prismatic" if limits.prismatic[j] else "position"
        unit = limits.units(j)[0]
        v.fail(
            owner,
            f"joint {limits.joint_names[j]}: the position margin "
            f"{getattr(margins, kind):g} {unit} (margin {kind}) leaves no room within "
            f"[{limits.lower[j]:g}, {limits.upper[j]:g}] {unit}: give a margin below "
            f"half the range (--margin {kind}=V, V < "
            f"{(limits.upper[j] - limits.lower[j]) / 2:g}), or lock the joint "
            "(--lock NAME=VALUE) if it is not to be identified.",
        )
    x0 = _start(problem)
    baseline = _baseline(problem)
    baseline_condition = condition_number(
        batched_rows(rows_fn, *baseline.evaluate(problem.t))
    )

    constraints = _constraints(problem)
    collision = _collision_constraint(problem)

    def feasible(x: np.ndarray, checked: list[dict]) -> bool:
        return all(
            np.all(c["fun"](x) >= -_FEASIBLE)
            if c["type"] == "ineq"
            else np.all(np.abs(c["fun"](x)) <= _FEASIBLE)
            for c in checked
        )

    def solve(
        x_start: np.ndarray,
        checked: list[dict],
        iterations: int = settings.iterations,
        accept: Callable[[np.ndarray], bool] | None = None,
    ) -> dict:
        """SLSQP from x_start; the best iterate feasible for ``checked``.

        With ``accept``: the best iterate that passes it instead.
        """
        best: dict = {"x": None, "cost": math.inf, "last": x_start}

        def track(x: np.ndarray) -> None:
            x = np.array(x, dtype=float)
            cost = condition_number(problem.values(x)[1][..., problem.active])
            if cost < best["cost"] and (
                feasible(x, checked) if accept is None else accept(x)
            ):
                best.update(x=x, cost=cost)

        track(x_start)
        result = optimize.minimize(
            lambda x: problem.values(x)[0],
            x_start,
            jac=lambda x: problem.gradients(x)[0],
            method="SLSQP",
            bounds=_bounds(problem),
            constraints=checked,
            callback=track,
            options={"maxiter": iterations, "ftol": 1e-7},
        )
        track(result.x)
        best.update(last=result.x, nit=int(result.nit), message=str(result.message))
        return best

    # Without self-collision first; if that motion collides, continue from it with
    # the clearance constraint, and from a start shrunk out of collision.
    best = solve(_shrink(problem, x0, lambda x: feasible(x, constraints)), constraints)
    iterations = best["nit"]
    if collision is not None:
        everything = [*constraints, collision]
        if best["x"] is None or not feasible(best["x"], everything):
            runs = [solve(best["x"] if best["x"] is not None else x0, everything)]
            runs.append(
                solve(
                    _shrink(problem, x0, lambda x: feasible(x, everything)), everything
                )
            )
            iterations += sum(run["nit"] for run in runs)
            best = min(runs, key=lambda run: run["cost"])
    if best["x"] is None:
        v.fail(
            owner,
            f"no trajectory meets the limits (after the margins): "
            f"{_refusal(problem, best['last'])}.",
        )
    x = best["x"]
    condition = float(best["cost"])
    if not condition <= max_condition:
        v.fail(
            owner,
            f"the best trajectory within the limits has condition number "
            f"{condition:.3g} > {max_condition:g}: the limits leave too little "
            "motion to excite every base parameter; widen the limits or margins, or "
            "raise the duration, harmonics or f0.",
        )
    # Between the samples: tighten the bounds the dense check finds passed and
    # re-solve, keeping the best iterate that meets the user's bounds on the grid
    # and on the dense check.
    original = constraints if collision is None else [*constraints, collision]

    def holds(y: np.ndarray) -> bool:
        return feasible(y, original) and _dense_holds(problem, y)

    emax = problem.emax.copy()
    margin = margins.collision
    start = x
    usage, clearance = _usage(problem, problem.trajectory(x))
    for _ in range(_ROUNDS):
        ratio, shortfall = _dense_excess(problem, usage, clearance)
        over = ratio > 1.0 + _FEASIBLE
        if not (over.any() or shortfall > _FEASIBLE):
            if start is not x and feasible(start, original):  # where a round ended
                x = start
                condition = condition_number(problem.values(x)[1][..., problem.active])
            break
        emax = np.where(over, emax / np.where(over, ratio, 1.0) * (1 - _TIGHTEN), emax)
        margin += max(shortfall, 0.0) * (1.0 + _TIGHTEN)
        checked = _constraints(problem, emax)
        tightened = _collision_constraint(problem, margin)
        if tightened is not None:  # the re-solve must not move into collision
            checked.append(tightened)
        run = solve(
            start,
            checked,
            min(settings.iterations, _ROUND_ITERATIONS),
            accept=holds,
        )
        iterations += run["nit"]
        if run["x"] is not None:
            x, condition, best["message"] = run["x"], float(run["cost"]), run["message"]
            break
        # No iterate passed: tighten by what the dense check finds where it ended.
        start = run["last"]
        usage, clearance = _usage(problem, problem.trajectory(start))
    usage, clearance = _usage(problem, problem.trajectory(x))
    trajectory = problem.trajectory(x)
    return ExcitationDesign(
        trajectory=trajectory,
        condition_number=float(condition),
        baseline=baseline,
        baseline_condition_number=float(baseline_condition),
        settings=settings,
        iterations=int(iterations),
        evaluations=int(problem.evaluations),
        message=best["message"],
        usage=usage,
        clearance=clearance,
        unexcitable=tuple(int(i) for i in np.flatnonzero(~problem.active)),
    )
