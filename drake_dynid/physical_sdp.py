"""Building blocks of the physical-consistency programs (``drake_dynid.physical``).

The pseudo-inertia of a link as a linear matrix inequality in its standard
parameters, the per-parameter scales taken from the URDF, and the chain of conic
solvers (Clarabel, then SCS) through Drake's ``MathematicalProgram``. For link j with
θ_j = [XX XY XZ YY YZ ZZ MX MY MZ M] (inertia Ī about the link origin in the link
frame, first moment h = m·c, mass m)::

    J(θ_j) = [[½ tr(Ī)·1 − Ī, h], [hᵀ, m]] = Σ_i θ_j,i F_i      [kg·m², kg·m, kg]

The programs work on scaled variables x = θ_std / scales and on the congruent
T_j J_j T_j, T_j = diag(1/L_j, 1/L_j, 1/L_j, 1)/√m_j, whose entries are of order 1
(positive semidefiniteness is invariant under congruence).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import re
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check

__all__ = [
    "INERTIAL",
    "PRIOR_FLOOR",
    "Layout",
    "SdpProblem",
    "link_names",
    "parameter_scales",
    "pseudo_inertia",
    "solve_program",
    "standard_layout",
]

INERTIAL = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")

PRIOR_FLOOR = 1e-3
"""Smallest eigenvalue of a URDF link's scaled pseudo-inertia T_j J_j,0 T_j in the
entropic regulariser (dimensionless; m_j and L_j make its mass entry 1 and its
trace about 2; the smallest of the 2R, iiwa7 and UR5 URDFs is 0.005)."""


# Pseudo-inertia J = Σ_i θ_i F_i for θ = [XX XY XZ YY YZ ZZ MX MY MZ M].
_F = np.zeros((10, 4, 4))
_F[0, :3, :3] = np.diag([-0.5, 0.5, 0.5])  # XX
_F[3, :3, :3] = np.diag([0.5, -0.5, 0.5])  # YY
_F[5, :3, :3] = np.diag([0.5, 0.5, -0.5])  # ZZ
for _k, (_a, _b) in ((1, (0, 1)), (2, (0, 2)), (4, (1, 2))):  # XY XZ YZ: Σ = -Ī
    _F[_k, _a, _b] = _F[_k, _b, _a] = -1.0
for _k, _a in ((6, 0), (7, 1), (8, 2)):  # MX MY MZ: h
    _F[_k, _a, 3] = _F[_k, 3, _a] = 1.0
_F[9, 3, 3] = 1.0  # M
_F.setflags(write=False)
# Powers of the length scale of XX XY XZ YY YZ ZZ MX MY MZ M.
_LENGTH_POWER = np.array([2, 2, 2, 2, 2, 2, 1, 1, 1, 0])


def pseudo_inertia(link_parameters: Any) -> np.ndarray:
    """The 4×4 pseudo-inertia J = [[½tr(Ī)·1 − Ī, h], [hᵀ, m]] of one link.

    Args:
        link_parameters: ``[XX XY XZ YY YZ ZZ MX MY MZ M]`` (inertia about the link
            origin in the link frame [kg·m²], first moment m·c [kg·m], mass [kg]).

    Returns:
        J ``(4, 4)``; the link is physically consistent iff J ⪰ 0.
    """
    theta = check.array("pseudo_inertia", "link_parameters", link_parameters)
    if theta.shape != (10,):
        check.fail(
            "pseudo_inertia",
            f"link_parameters must have shape (10,) [XX..M]; got {theta.shape}.",
        )
    return np.tensordot(theta, _F, axes=1)


def link_names(robot: Any) -> tuple[str, ...]:
    """The URDF link of each joint's standard parameters (the joint's child link)."""
    plant = robot.plant
    return tuple(
        plant.GetJointByName(name).child_body().name() for name in robot.joint_names
    )


@dataclass(frozen=True)
class Layout:
    """Indices of the standard parameters by role (layout-agnostic, by name)."""

    links: tuple[tuple[int, ...], ...]  # (n, 10) indices of XXj..Mj
    rotor: tuple[int, ...]  # index of IAj per joint, -1 when absent
    nonnegative: tuple[int, ...]  # FV, FC, IA
    friction: tuple[int, ...]  # FV, FC (sign-checked as base parameters)


def standard_layout(robot: Any) -> Layout:
    """Indices of each link's inertial parameters, of IAj, and of the signed ones."""
    index = {name: k for k, name in enumerate(robot.standard_names)}
    n = robot.num_joints
    links = tuple(tuple(index[f"{name}{j + 1}"] for name in INERTIAL) for j in range(n))
    rotor = tuple(index.get(f"IA{j + 1}", -1) for j in range(n))
    friction = tuple(k for name, k in index.items() if name.startswith(("FV", "FC")))
    # Coupled motors' rotor inertias IAmk (docs/DRIVE.md §3) store energy too.
    motors = tuple(k for name, k in index.items() if name.startswith("IAm"))
    nonnegative = tuple(sorted((*friction, *(k for k in rotor if k >= 0), *motors)))
    return Layout(links, rotor, nonnegative, friction)


def parameter_scales(robot: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-parameter scales from the URDF values, and the link scales (m_j, L_j).

    m_j is the URDF mass of link j (the mean of the positive masses where it is 0,
    1 kg if none), L_j = √(tr Σ_j / m_j) its radius of gyration about the link
    origin (the median of the others where it is 0, 0.1 m if none). Inertias and
    rotor inertias scale with m_j·L_j², first moments with m_j·L_j, masses with
    m_j, friction with max(|URDF value|, mean of the non-zero |URDF friction|) (1
    if all are 0).

    Returns:
        ``(scales (p_std,), mass (n,) [kg], length (n,) [m])``.
    """
    parts = standard_layout(robot)
    values = np.asarray(robot.standard_values, dtype=float)
    masses = np.array([values[idx[9]] for idx in parts.links])
    positive = masses[masses > 0]
    mass = np.where(masses > 0, masses, positive.mean() if positive.size else 1.0)
    second = np.array(
        [np.trace(pseudo_inertia(values[list(idx)])[:3, :3]) for idx in parts.links]
    )
    gyration = np.sqrt(np.clip(second, 0.0, None) / mass)
    known = gyration[gyration > 0]
    length = np.where(gyration > 0, gyration, np.median(known) if known.size else 0.1)
    scales = np.ones(values.size)
    for j, idx in enumerate(parts.links):
        scales[list(idx)] = mass[j] * length[j] ** _LENGTH_POWER
        if parts.rotor[j] >= 0:
            scales[parts.rotor[j]] = mass[j] * length[j] ** 2
    friction = [
        k
        for k, name in enumerate(robot.standard_names)
        if name.startswith(("FV", "FC", "OFF"))
    ]
    if friction:
        magnitude = np.abs(values[friction])
        nonzero = magnitude[magnitude > 0]
        scales[friction] = np.maximum(
            magnitude, nonzero.mean() if nonzero.size else 1.0
        )
    _motor_scales(robot, scales, mass * length**2)
    return scales, mass, length


def _motor_scales(robot: Any, scales: np.ndarray, link_inertia: np.ndarray) -> None:
    """Scales of coupled-motor columns (motor side), in place.

    ``IAmk`` and ``FVmk`` act through ρ_k² (ρ_k = max_j |R_kj|), ``FCmk`` and
    ``OFFmk`` through ρ_k (docs/DRIVE.md §3): their scales are the joint-side ones
    (the mean m_j·L_j² of the joints motor k drives, the friction scale computed
    above) divided by ρ_k² or ρ_k.
    """
    chain = getattr(robot, "drive", None)
    if chain is None:
        return
    coupling = np.asarray(chain.coupling, dtype=float)
    for k, name in enumerate(robot.standard_names):
        match = re.fullmatch(r"(IA|FV|FC|OFF)m(\d+)", name)
        if match is None:
            continue
        row = coupling[int(match.group(2)) - 1]
        rho = float(np.max(np.abs(row)))
        if match.group(1) == "IA":
            driven = np.flatnonzero(row)
            scales[k] = float(np.mean(link_inertia[driven])) / rho**2
        else:
            scales[k] /= rho ** (2 if match.group(1) == "FV" else 1)


# ----------------------------------------------------------------------------------
# The conic programs.


@dataclass(frozen=True, eq=False)
class SdpProblem:
    """What every program shares: layout, scales and the scaled LMI matrices."""

    robot: Any
    layout: Layout
    scales: np.ndarray  # θ_std = scales · x
    prior: np.ndarray  # x₀ = θ_URDF / scales
    lmis: tuple[np.ndarray, ...]  # per link (10, 4, 4): T F_i T · scale_i

    @classmethod
    def of(cls, robot: Any) -> SdpProblem:
        """The layout, scales and scaled LMI matrices of ``robot``."""
        parts = standard_layout(robot)
        scales, mass, length = parameter_scales(robot)
        lmis = []
        for j, idx in enumerate(parts.links):
            congruence = np.array([1, 1, 1, length[j]]) / (
                length[j] * math.sqrt(mass[j])
            )
            f = _F * np.outer(congruence, congruence)[None]
            lmis.append(f * scales[list(idx)][:, None, None])
        prior = np.asarray(robot.standard_values, dtype=float) / scales
        return cls(robot, parts, scales, prior, tuple(lmis))

    def link_min_eigenvalues(self, standard_values: np.ndarray) -> np.ndarray:
        """Smallest eigenvalue of each scaled T_j J_j T_j."""
        x = standard_values / self.scales
        return np.array(
            [
                np.linalg.eigvalsh(np.tensordot(x[list(idx)], f, axes=1))[0]
                for idx, f in zip(self.layout.links, self.lmis, strict=True)
            ]
        )

    def program(self):
        """A new ``MathematicalProgram`` and its p_std scaled variables x."""
        from pydrake.solvers import MathematicalProgram

        prog = MathematicalProgram()
        x = prog.NewContinuousVariables(self.scales.size, "x")
        return prog, x

    def add_lmis(self, prog, x, slack=None, margin: float = 0.0) -> None:
        """T_j J_j T_j (+ s_j·1) ⪰ margin·1 for every link."""
        for j, (idx, f) in enumerate(zip(self.layout.links, self.lmis, strict=True)):
            matrices = [-margin * np.eye(4), *f]
            variables = list(x[list(idx)])
            if slack is not None:
                matrices.append(np.eye(4))
                variables.append(slack[j])
            prog.AddLinearMatrixInequalityConstraint(matrices, variables)

    def add_norm_cost(
        self, prog, x, G: np.ndarray, g: np.ndarray, weight: float = 1.0
    ) -> Any:
        """Adds the cost weight·t with t ≥ ‖G x − g‖ (a Lorentz cone); returns t."""
        t = prog.NewContinuousVariables(1, "t")
        rows, cols = G.shape
        A = np.zeros((rows + 1, cols + 1))
        A[0, 0] = 1.0
        A[1:, 1:] = G
        prog.AddLorentzConeConstraint(A, np.concatenate([[0.0], -g]), [t[0], *x])
        prog.AddLinearCost([weight], 0.0, t)
        return t

    def other_columns(self) -> np.ndarray:
        """Indices of the standard parameters outside every link's ten (IA, FV, ...)."""
        inside = {k for idx in self.layout.links for k in idx}
        return np.array([k for k in range(self.scales.size) if k not in inside], int)

    def prior_pseudo_inertias(self) -> tuple[np.ndarray, ...]:
        """The URDF's scaled T_j J_j,0 T_j, eigenvalues floored at PRIOR_FLOOR.

        A URDF link that is a point mass, or massless, or inconsistent has a
        singular (or indefinite) prior; the floor makes it a body of that shape
        with a little spread, so that the entropic divergence is finite.
        """
        out = []
        for idx, f in zip(self.layout.links, self.lmis, strict=True):
            values, vectors = np.linalg.eigh(np.tensordot(self.prior[list(idx)], f, 1))
            floored = np.maximum(values, PRIOR_FLOOR)
            out.append((vectors * floored) @ vectors.T)
        return tuple(out)

    def entropic_divergence(self, x: np.ndarray) -> float:
        """Σ_j d(K_j, P_j) at scaled values x (numpy; inf when a K_j is not ≻ 0)."""
        total = 0.0
        for idx, f, prior in zip(
            self.layout.links, self.lmis, self.prior_pseudo_inertias(), strict=True
        ):
            matrix = np.tensordot(x[list(idx)], f, axes=1)
            sign, logdet = np.linalg.slogdet(matrix)
            if sign <= 0.0 or not math.isfinite(logdet):
                return math.inf
            total += (
                -logdet
                + np.linalg.slogdet(prior)[1]
                + np.trace(np.linalg.solve(prior, matrix))
                - 4.0
            )
        return float(total)

    def add_squared_norm_cost(self, prog, x, G: np.ndarray, g: np.ndarray) -> Any:
        """Adds the cost t with t ≥ ‖G x − g‖² (a rotated Lorentz cone); returns t."""
        t = prog.NewContinuousVariables(1, "t")
        rows, cols = G.shape
        A = np.zeros((rows + 2, cols + 1))
        A[0, 0] = 1.0
        A[2:, 1:] = G
        b = np.concatenate([[0.0, 1.0], -g])
        prog.AddRotatedLorentzConeConstraint(A, b, [t[0], *x])
        prog.AddLinearCost([1.0], 0.0, t)
        return t

    def add_entropic_cost(self, prog, x, weight: float) -> None:
        """Adds weight·Σ_j [tr(P_j⁻¹ K_j) − log det K_j], K_j = T_j J_j T_j.

        P_j = :meth:`prior_pseudo_inertias`. Up to the constant
        weight·Σ_j (log det P_j − 4) this is weight·Σ_j d(K_j, P_j), the log-det
        (Bregman) divergence of Lee, Wensing & Park (IEEE T-RO 36(2), 2020), which
        is invariant under the congruence T_j (so it is the divergence of J_j from
        the URDF's J_j,0) and infinite at a singular K_j. −log det is Drake's
        ``AddMaximizeLogDeterminantCost`` (a PSD block and one exponential cone per
        diagonal entry), weighted here, of the whitened P_j^(-1/2) K_j P_j^(-1/2)
        (the same divergence: d is invariant under congruence; the prior becomes
        the identity, which Clarabel resolves where K_j itself, with eigenvalues
        down to 0.005, left it "almost solved" 8e-5 outside the cone).
        """
        for idx, f, prior in zip(
            self.layout.links, self.lmis, self.prior_pseudo_inertias(), strict=True
        ):
            variables = x[list(idx)]
            values, vectors = np.linalg.eigh(prior)
            root = (vectors / np.sqrt(values)) @ vectors.T  # P^(-1/2)
            whitened = np.einsum("ab,kbc,cd->kad", root, f, root)
            matrix = _symbolic_sum(variables, whitened)
            cost, _, _ = prog.AddMaximizeLogDeterminantCost(matrix)
            count = cost.evaluator().a().size
            cost.evaluator().UpdateCoefficients(-weight * np.ones(count))
            trace = np.einsum("kaa->k", whitened)
            prog.AddLinearCost(weight * trace, 0.0, variables)


def _symbolic_sum(variables, matrices: np.ndarray) -> np.ndarray:
    """Σ_k variables[k]·matrices[k] as a matrix of Drake expressions.

    Built entry by entry in Python: numpy's object ``tensordot`` reports the
    floating-point flags a previous solve left raised as its own "invalid value"
    warning.
    """
    rows, cols = matrices.shape[1:]
    out = np.empty((rows, cols), dtype=object)
    for a in range(rows):
        for b in range(cols):
            terms = [
                float(matrices[k, a, b]) * variables[k]
                for k in range(len(variables))
                if matrices[k, a, b] != 0.0
            ]
            out[a, b] = sum(terms[1:], terms[0]) if terms else 0.0 * variables[0]
    return out


class _Hold(logging.Filter):
    """Drops every record of Drake's logger (a solver's own log lines)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return False


@contextlib.contextmanager
def _quiet_solver() -> Iterator[None]:
    """A solve's own output kept off the user's terminal.

    Drake's logger lines (``SCS returns code -2 ...``) are dropped, and what the
    solvers' C code prints on file descriptor 1 (``WARNING - large complementary
    slackness residual``) goes to ``os.devnull``: a failed solve is said once, in
    :func:`solve_program`'s error.
    """
    drake_logger = logging.getLogger("drake")
    hold = _Hold()
    drake_logger.addFilter(hold)
    saved = None
    try:
        with contextlib.suppress(AttributeError, OSError, ValueError):
            if sys.stdout is not None:
                sys.stdout.flush()
        with contextlib.suppress(OSError):
            saved = os.dup(1)
            with open(os.devnull, "wb") as sink:
                os.dup2(sink.fileno(), 1)
        yield
    finally:
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)
        drake_logger.removeFilter(hold)


def solve_program(
    owner: str, prog, accept, fallback: bool = True
) -> tuple[Any, str, float]:
    """Clarabel, then SCS; ValueError when neither gives an acceptable solution.

    ``accept(result)`` returns None for a usable solution, else why not (a solver
    may report success with an inaccurate point, e.g. SCS "solved inaccurate").
    ``fallback=False``: Clarabel alone.
    """
    from pydrake.solvers import ClarabelSolver, ScsSolver

    failures = []
    start = time.perf_counter()
    solvers = (ClarabelSolver(), ScsSolver()) if fallback else (ClarabelSolver(),)
    for solver in solvers:
        name = solver.solver_id().name()
        if not (solver.available() and solver.enabled()):
            failures.append(f"{name}: not available")
            continue
        with _quiet_solver():
            result = solver.Solve(prog)
        if not result.is_success():
            failures.append(f"{name}: {result.get_solution_result().name}")
            continue
        problem = accept(result)
        if problem is None:
            return result, name, time.perf_counter() - start
        failures.append(f"{name}: {problem}")
    check.fail(
        owner,
        "the semidefinite program could not be solved ("
        + "; ".join(failures)
        + "); check that the rows and torques are finite and excite the robot.",
    )
    raise AssertionError  # unreachable (check.fail raises)
