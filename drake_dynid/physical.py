"""Physical consistency of identified parameters (semidefinite programs in Drake).

A set of standard parameters is *physically consistent* when some rigid bodies with
non-negative mass produce it. For link j with the standard inertial parameters
θ_j = [XX XY XZ YY YZ ZZ MX MY MZ M] (inertia Ī about the link origin, in the link
frame, tensor entries; first moment h = m·c; mass m), this holds exactly when the
4×4 **pseudo-inertia** is positive semidefinite (Wensing, Kim & Slotine, RA-L 2017)::

    J(θ_j) = [[Σ, h], [hᵀ, m]] ⪰ 0,    Σ = ½ tr(Ī)·1 − Ī = ∫ r rᵀ dm  [kg·m², kg·m, kg]

(J ⪰ 0 implies m ≥ 0, the triangle inequalities of the inertia about the centre of
mass, and that the mass lies where it can). Friction must not create energy:
FVj ≥ 0 and FCj ≥ 0 (the offset OFFj is free), and a reflected rotor inertia
IAj ≥ 0. J is linear in θ_j, so all these are linear matrix inequalities.

Three uses, each one ``MathematicalProgram`` solved by Clarabel (fallback SCS):

* :func:`check_physical`: can a base vector θ_base be produced by any consistent
  robot? Feasibility of ``matrix·θ_std = θ_base`` with every J_j ⪰ 0, relaxed by one
  slack s_j ≥ 0 per link (T_j J_j T_j + s_j·1 ⪰ 0, IAj ≥ −s_j·scale) and
  minimising Σ s_j: the links with s_j > 0 are those that cannot be made
  consistent, and the base parameters built from them are named.
* :func:`solve_physical`: the identification ``min ‖W θ_base − τ‖²`` under the
  constraints, with θ_base = matrix·θ_std, in the scaled form::

        min_x ‖(R·matrix·S x − c)/σ̂‖² + λ ‖x − x₀‖²
        s.t.  T_j J_j(S x) T_j ⪰ 0,  FV, FC, IA ≥ 0

  where W = Q R (QR of the stacked, optionally per-joint weighted rows), c = Qᵀτ,
  σ̂ the residual std of the unconstrained fit (so the data term counts in
  variances), S = diag(scales) (θ_std = S x; scales from the URDF: m_j, m_j·L_j,
  m_j·L_j² per link with L_j the URDF's radius of gyration about the link origin),
  x₀ = S⁻¹ θ_URDF, and T_j = diag(1/L_j, 1/L_j, 1/L_j, 1)/√m_j. The small
  regularisation λ keeps the standard parameters that the data cannot see (the
  null space of ``matrix``, unexcited directions) at their URDF values; it moves a
  well-identified base parameter by about λ·(σ_θ/scale)² of itself. With
  ``regularizer="entropic"`` λ weighs instead, per link, the log-det (Bregman)
  divergence of the pseudo-inertia from the URDF's (Lee, Wensing & Park,
  *Geometric Robot Dynamic Identification: A Convex Programming Approach*, IEEE
  T-RO 36(2), 2020)::

        d(J, J₀) = −log det J + log det J₀ + tr(J₀⁻¹ J) − 4      [dimensionless]

  (= d(K, P) for K = T J T, P = T J₀ T: invariant under congruence; P's
  eigenvalues floored at ``physical_sdp.PRIOR_FLOOR``), plus λ‖x − x₀‖² over the
  friction and rotor-inertia columns. d is convex, 0 at J₀ and infinite at a
  singular J: emptying a link, which costs the euclidean term at most about λ,
  costs λ·log(1/m) here (32 weakly excited iiwa7 programs: 8 links below 1 % of
  the URDF's mass with the euclidean term, none with this one, README).
* :func:`project_physical`: the on-line window estimate θ̂ with covariance C
  projected onto the consistent set, ``min (θ − θ̂)ᵀ C⁻¹ (θ − θ̂)`` (same program,
  R = L⁻¹ with C = L Lᵀ).

The pseudo-inertia LMIs, the scales and the solver chain live in
:mod:`drake_dynid.physical_sdp`. Never imported by ``drake_dynid.core`` (it needs
pydrake); the inputs are plain arrays and a :class:`~drake_dynid.plants.RobotModel`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.idim import ReducedRows, joint_weighted, reduce_rows
from drake_dynid.physical_sdp import (
    SdpProblem,
    link_names,
    parameter_scales,
    pseudo_inertia,
    solve_program,
)

__all__ = [
    "DEFAULT_REGULARIZATION",
    "REGULARIZERS",
    "PhysicalCheck",
    "PhysicalResult",
    "check_physical",
    "link_names",
    "parameter_scales",
    "project_physical",
    "pseudo_inertia",
    "solve_physical",
    "solve_physical_reduced",
]


DEFAULT_REGULARIZATION = 1e-3
"""λ of :func:`solve_physical`: weight of ‖x − x₀‖² against the data term counted
in residual variances (a one-σ move of a base parameter costs 1)."""

REGULARIZERS = ("euclidean", "entropic")
"""What λ weighs (module docstring): ``"euclidean"`` ‖x − x₀‖² (the default), or
``"entropic"`` Σ_j d(J_j, J_j,URDF), the log-det divergence of each link's
pseudo-inertia from the URDF's (Lee, Wensing & Park 2020), + ‖x − x₀‖² over the
other parameters (friction, rotor inertias)."""

MARGIN = 1e-6
"""The constrained solutions keep T_j J_j T_j ⪰ MARGIN·1 (dimensionless), so that
solver round-off never leaves a link slightly outside the cone (Drake rejects an
inertia that violates the triangle inequality by a few ulps)."""

ACTIVE_TOLERANCE = 1e-5
"""A scaled J_j whose smallest eigenvalue is below this (or a sign-constrained
parameter below this in scale units) is reported as an active constraint."""

_BOX = 1e4  # |x − x₀| bound of the feasibility program [scale units]
_ACCEPT = 1e-6  # largest constraint violation accepted from a solver [scale units]
_OPTIMAL = 1e-6  # relative excess of an entropic objective over its bound accepted

SIGMA_FLOOR = 1e-5
"""σ̂ of :func:`solve_physical` is at least this fraction of RMS(τ): a noise-free
log would otherwise make the data term 10¹⁰ times the regularisation, beyond what
the conic solvers resolve (they then report numerical errors)."""

FEASIBILITY_TOLERANCE = 1e-6
"""Largest link slack s_j (scaled units) still counted as consistent."""


def _theta(owner: str, robot: Any, theta: Any, name: str = "theta") -> np.ndarray:
    check.having(owner, "robot", robot, ("num_parameters", "base"), "a RobotModel")
    out = check.array(owner, name, theta)
    if out.shape != (robot.num_parameters,):
        check.fail(
            owner,
            f"{name} must have shape ({robot.num_parameters},) (the base parameters "
            f"{', '.join(robot.base.names[:3])}, ...); got {out.shape}.",
        )
    return out


def _regularization(owner: str, value: Any) -> float:
    value = check.real(owner, "regularization", value)
    if value < 0.0:
        check.fail(owner, f"regularization must be >= 0; got {value}.")
    return value


def _regularizer(owner: str, value: Any) -> str:
    if not isinstance(value, str) or value not in REGULARIZERS:
        check.fail(
            owner,
            f"regularizer must be one of {', '.join(map(repr, REGULARIZERS))}; got "
            f"{value!r}.",
        )
    return str(value)


# ----------------------------------------------------------------------------------
# (a) Which estimates are physically impossible.


@dataclass(frozen=True, eq=False)
class PhysicalCheck:
    """Outcome of :func:`check_physical`.

    Attributes:
        consistent: True when some physically consistent robot has these base
            parameters (no negative friction or rotor inertia, SDP feasible).
        negative: base parameters that are a friction (FVj, FCj) or a rotor
            inertia (IAj) on their own and are < 0.
        feasible: the inertial part is feasible: some θ_std with
            ``matrix·θ_std = θ_base`` has every J_j ⪰ 0 (and every regrouped
            IAj ≥ 0).
        infeasible_links: URDF links whose pseudo-inertia cannot be made ⪰ 0.
        involved: base parameters whose definition holds a parameter of those
            links.
        link_slack: (n,) the smallest s_j with T_j J_j T_j + s_j·1 ⪰ 0 (0 for a
            consistent link; dimensionless, the link's own scale).
        solver: the solver that answered.
    """

    consistent: bool
    negative: tuple[str, ...]
    feasible: bool
    infeasible_links: tuple[str, ...]
    involved: tuple[str, ...]
    link_slack: np.ndarray
    solver: str

    def summary(self) -> str:
        """One sentence: consistent, or what is impossible."""
        if self.consistent:
            return "physically consistent (every link's pseudo-inertia can be ⪰ 0)."
        parts = []
        if self.negative:
            parts.append(
                f"negative friction or rotor inertia: {check.listed(self.negative)}"
            )
        if not self.feasible:
            parts.append(
                "no positive-semidefinite pseudo-inertia for link(s) "
                f"{check.listed(self.infeasible_links)} (base parameters involved: "
                f"{check.listed(self.involved)})"
            )
        return "physically impossible: " + "; ".join(parts) + "."


#: A median |θ / θ_URDF| from which the estimate is taken to be in another unit.
_UNIT_SCALE = 100.0


def _unit_scale(robot: Any, theta: np.ndarray) -> float:
    """The feasibility box's factor: median |θ_i / θ_URDF,i| when >= 100, else 1.

    Torques logged in another unit (mN·m: θ 1e3-1e4 times the URDF's) scale every
    parameter alike; the box grows with them (its ±1e4 scale units around the
    URDF made the program infeasible). Not for smaller factors: the verdict of a
    link whose data barely decide it depends on the box (the TIAGo's arm_6_link,
    median 6.8, would pass through a decomposition 4e4 scale units away), and not
    the largest ratio: one poorly determined parameter must not widen it.
    """
    reference = np.abs(np.asarray(robot.base_values, dtype=float))
    used = reference > 1e-9 * float(np.max(reference, initial=0.0))
    if not used.any():
        return 1.0
    ratio = np.abs(np.asarray(theta, dtype=float)[used]) / reference[used]
    scale = float(np.median(ratio))
    return scale if scale >= _UNIT_SCALE else 1.0


def check_physical(
    robot: Any, theta: Any, *, tolerance: float = FEASIBILITY_TOLERANCE
) -> PhysicalCheck:
    """Says whether base parameters can come from a physically consistent robot.

    Friction and rotor inertias that are base parameters on their own are checked
    by sign. The rest is the feasibility SDP (module docstring): find θ_std with
    ``matrix·θ_std = θ_base``, ``T_j J_j(θ_std) T_j + s_j·1 ⪰ 0``, regrouped
    ``IAj ≥ −s_j·scale``, s_j ≥ 0, |x − x₀| ≤ 1e4 (scale units; times the
    estimate's unit factor when it is >= 100: :func:`_unit_scale`), minimising Σ s_j.
    Links with s_j > ``tolerance`` are infeasible. Which links carry the slack is
    not unique when base parameters regroup several links: the L1 cost puts it on
    few links, and ``involved`` names every base parameter those links enter.

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel` the base parameters
            belong to.
        theta: (p,) base parameter values in ``robot.base.names`` order.
        tolerance: largest slack still counted as feasible (scaled units).

    Returns:
        A :class:`PhysicalCheck`.
    """
    from pydrake.solvers import LinearEqualityConstraint

    owner = "check_physical"
    theta = _theta(owner, robot, theta)
    tolerance = check.positive(owner, "tolerance", tolerance)
    problem = SdpProblem.of(robot)
    base = robot.base
    standalone = {
        i: base.independent[i]
        for i, definition in enumerate(base.definitions)
        if len(definition) == 1
    }
    signed = set(problem.layout.nonnegative)
    negative = tuple(
        base.names[i] for i, k in standalone.items() if k in signed and theta[i] < 0.0
    )
    prog, x = problem.program()
    slack = prog.NewContinuousVariables(robot.num_joints, "s")
    prog.AddBoundingBoxConstraint(0.0, np.inf, slack)
    matrix = np.asarray(base.matrix) * problem.scales[None, :]
    keep = [i for i in range(base.num_base) if base.names[i] not in negative]
    rows = matrix[keep]
    norms = np.linalg.norm(rows, axis=1)
    # A constraint object: the (A, b, vars) overloads make pydrake import
    # scipy.sparse (0.1 s of every dynid identify) to test for a sparse A.
    prog.AddConstraint(
        LinearEqualityConstraint(rows / norms[:, None], theta[keep] / norms), x
    )
    problem.add_lmis(prog, x, slack)
    standalone_columns = {k for i, k in standalone.items()}
    for j, k in enumerate(problem.layout.rotor):
        if k >= 0 and k not in standalone_columns:
            prog.AddLinearConstraint(x[k] + slack[j] >= 0.0)
    prog.AddLinearCost(np.ones(robot.num_joints), 0.0, slack)
    # Keep the free directions bounded (no cost on them: a cost would trade slack
    # for distance where the feasible set is thin).
    box = _BOX * _unit_scale(robot, theta)
    prog.AddBoundingBoxConstraint(problem.prior - box, problem.prior + box, x)

    def accept(result) -> str | None:
        xs = np.asarray(result.GetSolution(x), dtype=float)
        equality = rows @ xs - theta[keep]
        if not np.all(np.isfinite(xs)):
            return "non-finite solution"
        if np.max(np.abs(equality) / norms) > _ACCEPT * max(1.0, np.abs(xs).max()):
            return "inaccurate solution (equality constraints violated)"
        return None

    result, solver, _ = solve_program(owner, prog, accept)
    s = np.maximum(np.asarray(result.GetSolution(slack), dtype=float), 0.0)
    bad = np.flatnonzero(s > tolerance)
    names = link_names(robot)
    bad_columns: set[int] = set()
    for j in bad.tolist():
        bad_columns.update(problem.layout.links[j])
        if problem.layout.rotor[j] >= 0:
            bad_columns.add(problem.layout.rotor[j])
    involved = tuple(
        name
        for name, row in zip(base.names, base.matrix, strict=True)
        if any(row[k] != 0.0 for k in bad_columns)
    )
    feasible = bad.size == 0
    return PhysicalCheck(
        consistent=feasible and not negative,
        negative=negative,
        feasible=feasible,
        infeasible_links=tuple(names[j] for j in bad),
        involved=involved,
        link_slack=s,
        solver=solver,
    )


# ----------------------------------------------------------------------------------
# (b) The constrained identification and (c) the projection.


@dataclass(frozen=True, eq=False)
class PhysicalResult:
    """A physically consistent estimate (``solve_physical``, ``project_physical``).

    Attributes:
        names: (p,) base parameter names.
        theta: (p,) consistent base values, ``matrix @ standard_values``.
        standard_names: (p_std,) standard parameter names.
        standard_values: (p_std,) consistent standard values (every J_j ⪰ 0,
            FV, FC, IA ≥ 0); the directions the data do not see are at the URDF
            values (regularisation).
        active: the constraints that hold with equality, e.g.
            ``"J(iiwa_link_7) ⪰ 0"`` or ``"FC2 >= 0"``.
        link_min_eigenvalues: (n,) smallest eigenvalue of each scaled pseudo-inertia
            T_j J_j T_j (≈ 0: on the boundary, a degenerate body).
        data_cost: the data term at the solution above the unconstrained optimum:
            ``(‖Wθ − τ‖² − ‖Wθ̂ − τ‖²)/σ̂²`` (:func:`solve_physical`) or the
            Mahalanobis distance² (θ − θ̂)ᵀC⁻¹(θ − θ̂) (:func:`project_physical`).
        regularization: λ.
        regularizer: what λ weighs, ``"euclidean"`` or ``"entropic"`` (with λ = 0
            the two are one program: ``"euclidean"``).
        solver: ``"Clarabel"`` or ``"SCS"``.
        solve_time: wall time of the solver call [s].
    """

    names: tuple[str, ...]
    theta: np.ndarray
    standard_names: tuple[str, ...]
    standard_values: np.ndarray
    active: tuple[str, ...]
    link_min_eigenvalues: np.ndarray
    data_cost: float
    regularization: float
    regularizer: str
    solver: str
    solve_time: float

    def standard_parameters(self) -> dict[str, float]:
        """``{standard name: consistent value}``."""
        return dict(
            zip(self.standard_names, self.standard_values.tolist(), strict=True)
        )


def _constrained(
    owner: str,
    robot: Any,
    R: np.ndarray,
    c: np.ndarray,
    regularization: float,
    regularizer: str,
) -> PhysicalResult:
    """Solves min ‖R θ_base − c‖² + λ·D(x, x₀) s.t. the constraints (θ_std = S x).

    D: ‖x − x₀‖² (euclidean), or Σ_j d(K_j, P_j) + ‖x − x₀‖² over the columns
    outside the links (entropic; module docstring). The euclidean program
    minimises the norm (one Lorentz cone, the same minimiser); the entropic one
    needs the square (a rotated cone) beside the log-det terms. Its solution is
    accepted only if its objective is no larger than at the euclidean program's
    solution (a feasible point, solved first): SCS, the fallback, returned
    points twice the optimum's cost that satisfied every constraint.
    """
    entropic = regularizer == "entropic" and regularization > 0.0
    reference = (
        _constrained(owner, robot, R, c, regularization, "euclidean")
        if entropic
        else None
    )
    problem = SdpProblem.of(robot)
    prog, x = problem.program()
    G_data = R @ (np.asarray(robot.base.matrix) * problem.scales[None, :])
    root = math.sqrt(regularization)
    if entropic:
        others = problem.other_columns()
        G = np.vstack([G_data, root * np.eye(x.size)[others]])
        g = np.concatenate([c, root * problem.prior[others]])
        problem.add_squared_norm_cost(prog, x, G, g)
        problem.add_entropic_cost(prog, x, regularization)
    else:
        G = np.vstack([G_data, root * np.eye(x.size)])
        g = np.concatenate([c, root * problem.prior])
        problem.add_norm_cost(prog, x, G, g)
    problem.add_lmis(prog, x, margin=MARGIN)
    signed = list(problem.layout.nonnegative)
    if signed:
        prog.AddBoundingBoxConstraint(0.0, np.inf, x[signed])

    def accept(result) -> str | None:
        xs = np.asarray(result.GetSolution(x), dtype=float)
        if not np.all(np.isfinite(xs)):
            return "non-finite solution"
        smallest = problem.link_min_eigenvalues(xs * problem.scales).min()
        lowest = xs[signed].min() if signed else 0.0
        violation = -min(smallest, lowest)
        if violation > _ACCEPT:
            return f"inaccurate solution (a constraint violated by {violation:.2g})"
        if bound is not None and objective(xs) > bound * (1.0 + _OPTIMAL) + 1e-4:
            return (
                f"inaccurate solution (objective {objective(xs):.6g} above the "
                f"{bound:.6g} of the euclidean program's solution)"
            )
        return None

    def objective(xs: np.ndarray) -> float:
        residual = G @ xs - g
        divergence = problem.entropic_divergence(xs)
        return float(residual @ residual) + regularization * divergence

    bound = None
    if reference is not None:
        bound = objective(reference.standard_values / problem.scales)
    if reference is None:
        result, solver, seconds = solve_program(owner, prog, accept)
    else:
        try:
            result, solver, seconds = solve_program(owner, prog, accept, False)
        except ValueError as error:
            raise ValueError(
                f"{error} The euclidean regularizer solves it (data cost "
                f"+{reference.data_cost:.4g} residual variances): with data this "
                "far from any consistent robot the log-det terms are below the "
                "solvers' accuracy."
            ) from None
        seconds += reference.solve_time
    xs = np.asarray(result.GetSolution(x), dtype=float)
    if signed:
        xs[signed] = np.maximum(xs[signed], 0.0)  # solver round-off below 0
    standard = xs * problem.scales
    theta = robot.base.values(standard)
    eigenvalues = problem.link_min_eigenvalues(standard)
    links = link_names(robot)
    active = [
        f"J({links[j]}) ⪰ 0" for j in np.flatnonzero(eigenvalues < ACTIVE_TOLERANCE)
    ]
    active += [
        f"{robot.standard_names[k]} >= 0" for k in signed if xs[k] < ACTIVE_TOLERANCE
    ]
    residual = R @ theta - c
    standard.setflags(write=False)
    theta.setflags(write=False)
    return PhysicalResult(
        names=tuple(robot.base.names),
        theta=theta,
        standard_names=tuple(robot.standard_names),
        standard_values=standard,
        active=tuple(active),
        link_min_eigenvalues=eigenvalues,
        data_cost=float(residual @ residual),
        regularization=regularization,
        # λ = 0: one program either way, the euclidean one (said so, not "entropic").
        regularizer="entropic" if entropic else "euclidean",
        solver=solver,
        solve_time=seconds,
    )


def solve_physical(
    robot: Any,
    W: Any,
    tau: Any,
    *,
    weighted: bool = False,
    regularization: float = DEFAULT_REGULARIZATION,
    regularizer: str = "euclidean",
) -> PhysicalResult:
    """Physically consistent least squares ``min ‖W θ_base − τ‖²`` (module docstring).

    The stacked rows are reduced once by QR (W = Q R, c = Qᵀτ, so
    ‖Wθ − τ‖² = ‖Rθ − c‖² + ρ²) and divided by the unconstrained residual std
    σ̂ = ρ/√(r − p); the program then has p + p_std cone entries whatever the log
    length. :func:`solve_physical_reduced` with ``core.idim.reduce_rows(W, tau)``.

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel` (base parameters, URDF
            values used as the prior, link names).
        W: (N, n, p) base-parameter rows [N·m per unit], e.g. the decimated rows
            of :func:`drake_dynid.offline.identify_offline` (``keep_rows=True``).
        tau: (N, n) torques [N·m or N] of the same samples.
        weighted: weight joint j's equations by 1/σ_j (σ_j from a per-joint
            least squares, as IDIM-WLS).
        regularization: λ ≥ 0 (see :data:`DEFAULT_REGULARIZATION`).
        regularizer: what λ weighs, one of :data:`REGULARIZERS`: ``"euclidean"``
            (‖x − x₀‖²) or ``"entropic"`` (the log-det divergence of each link's
            pseudo-inertia from the URDF's: no link mass reaches 0).

    Returns:
        A :class:`PhysicalResult`.

    Raises:
        ValueError: shapes or values that do not fit the robot, or a solver
            failure.
    """
    owner = "solve_physical"
    check.having(owner, "robot", robot, ("num_parameters", "base"), "a RobotModel")
    W = check.array(owner, "W", W)
    tau = check.array(owner, "tau", tau)
    p = robot.num_parameters
    if W.ndim != 3 or W.shape[2] != p or tau.shape != W.shape[:2]:
        check.fail(
            owner,
            f"W must have shape (N, n, {p}) and tau (N, n); got W {W.shape} and tau "
            f"{tau.shape}.",
        )
    return _physical_of_reduced(
        owner, robot, reduce_rows(W, tau), weighted, regularization, regularizer
    )


def solve_physical_reduced(
    robot: Any,
    reduced: ReducedRows,
    *,
    weighted: bool = False,
    regularization: float = DEFAULT_REGULARIZATION,
    regularizer: str = "euclidean",
) -> PhysicalResult:
    """:func:`solve_physical` of equations already reduced by QR per joint.

    ``reduced``: ``core.idim.reduce_rows`` of the rows, e.g. ``OfflineResult.reduced``
    of :func:`drake_dynid.offline.identify_offline` (kept whatever the log's
    length: n (p + 1)² numbers). With ``weighted``, each joint's R_j is divided
    by its σ_j (IDIM-WLS); then ``[R | c]`` of the stacked R_j, ρ its last
    diagonal entry, σ̂ = ρ/√(K·n − p).

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel`.
        reduced: the reduced equations (n joints, the robot's p parameters).
        weighted: weight joint j's equations by 1/σ_j.
        regularization: λ ≥ 0 (see :data:`DEFAULT_REGULARIZATION`).
        regularizer: ``"euclidean"`` or ``"entropic"`` (:func:`solve_physical`).
    """
    owner = "solve_physical_reduced"
    check.having(owner, "robot", robot, ("num_parameters", "base"), "a RobotModel")
    if not isinstance(reduced, ReducedRows):
        raise TypeError(
            f"{owner}: reduced must be a ReducedRows (core.idim.reduce_rows); got "
            f"{type(reduced).__name__}."
        )
    if reduced.num_parameters != robot.num_parameters:
        check.fail(
            owner,
            f"reduced must have the robot's {robot.num_parameters} parameters; got "
            f"{reduced.num_parameters}.",
        )
    return _physical_of_reduced(
        owner, robot, reduced, weighted, regularization, regularizer
    )


def _physical_of_reduced(
    owner: str,
    robot: Any,
    reduced: ReducedRows,
    weighted: bool,
    regularization: float,
    regularizer: str,
) -> PhysicalResult:
    p = robot.num_parameters
    rows = reduced.num_samples * reduced.R.shape[0]
    if rows <= p:
        check.fail(
            owner, f"the rows must be more than {p} equations (N·n); got {rows}."
        )
    if not np.isfinite(reduced.R).all():
        check.fail(owner, "the reduced rows must be finite (the rows held a NaN).")
    regularization = _regularization(owner, regularization)
    regularizer = _regularizer(owner, regularizer)
    R_joints = joint_weighted(reduced) if weighted else reduced.R
    stack = R_joints.reshape(-1, p + 1)
    R_aug = np.asarray(np.linalg.qr(stack, mode="r"))
    R, c = R_aug[:p, :p], R_aug[:p, p]
    # ρ = |R[p, p]|, ‖τ‖ (weighted) = ‖[c; ρ]‖ by hypot (no square overflows).
    rho = abs(float(R_aug[p, p])) if R_aug.shape[0] > p else 0.0
    total = float(np.hypot.reduce(R_aug[:, p]))
    sigma_hat = rho / math.sqrt(rows - p)
    sigma_hat = max(sigma_hat, SIGMA_FLOOR * total / math.sqrt(rows), 1e-300)
    return _constrained(
        owner, robot, R / sigma_hat, c / sigma_hat, regularization, regularizer
    )


def project_physical(
    robot: Any,
    theta: Any,
    covariance: Any,
    *,
    regularization: float = DEFAULT_REGULARIZATION,
    regularizer: str = "euclidean",
) -> PhysicalResult:
    """Projects a window estimate θ̂ onto the consistent set in the metric C⁻¹.

    ``min (θ − θ̂)ᵀ C⁻¹ (θ − θ̂)`` over consistent base vectors θ (module docstring),
    for the on-line identifier's estimate and its covariance (Gautier's
    C = σ_ρ²(AᵀA)⁻¹). A consistent θ̂ comes back unchanged (up to the
    regularisation); otherwise the parameters that the window knows least move
    most. C's eigenvalues are floored at 1e-12 of the largest.

    Args:
        robot: the :class:`~drake_dynid.plants.RobotModel`.
        theta: (p,) base estimate θ̂.
        covariance: (p, p) symmetric positive (semi)definite covariance of θ̂.
        regularization: λ ≥ 0 (keeps the unseen standard directions at the URDF).
        regularizer: ``"euclidean"`` or ``"entropic"`` (:func:`solve_physical`).

    Returns:
        A :class:`PhysicalResult` (``data_cost`` = the Mahalanobis distance²).
    """
    owner = "project_physical"
    theta = _theta(owner, robot, theta)
    p = theta.size
    covariance = check.array(owner, "covariance", covariance, shape=(p, p))
    if not np.allclose(covariance, covariance.T, rtol=1e-9, atol=0.0):
        check.fail(owner, "covariance must be symmetric.")
    values, vectors = np.linalg.eigh(covariance)
    if values[-1] <= 0.0 or values[0] < -1e-9 * values[-1]:
        check.fail(
            owner,
            f"covariance must be positive semidefinite and non-zero; got eigenvalues "
            f"in [{values[0]:.3g}, {values[-1]:.3g}].",
        )
    values = np.maximum(values, 1e-12 * values[-1])
    R = vectors.T / np.sqrt(values)[:, None]  # Rᵀ R = C⁻¹
    regularization = _regularization(owner, regularization)
    regularizer = _regularizer(owner, regularizer)
    return _constrained(owner, robot, R, R @ theta, regularization, regularizer)
