"""The differentiable excitation problem behind ``core.excite`` (private helpers).

One design evaluates, at the N grid times of one period, the base regressor
W(q_k, v_k, v̇_k) (N, n, p) of a Fourier trajectory x = (q0, a, b), its smooth
log condition number, the torques τ = W θ, and their exact gradients with respect
to x: W at sample k depends only on (q_k, v_k, v̇_k), so 3n batched forward
differences (one per joint and kind, all samples at once; velocity steps away from
zero so that sign(v) never flips; v̇ exact since W is linear in it) give
∂W_k/∂(q, v, v̇)_k, and the chain rule through the linear Fourier basis and the
derivative of the cost with respect to W (singular vectors of the column-scaled
matrix: ∂σ_i/∂A = u_i v_iᵀ) gives ∂cost/∂x and ∂τ/∂x.

Columns that vanish at random states (relative norm < 1e-8: a base parameter with
no effect on the dynamics, kept by a numerical reduction by round-off) cannot be
excited by any motion; they are left out of the cost and reported.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from drake_dynid.core.trajectory import FourierTrajectory

RowsFunction = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]

_STEP_Q = 1e-6  # forward-difference steps [rad], [rad/s]; v̇ is exact (linear)
_STEP_V = 1e-6
_STEP_CLEARANCE = 1e-5  # [rad]: signed distances are smooth at this scale
_MAX_BATCH = 4096  # samples per regressor call
_ZERO_COLUMN = 1e-8  # relative column norm of a parameter without any effect
SOFTNESS = 20.0  # r of the smooth condition number (see soft_log_condition)


def condition_number(W: np.ndarray) -> float:
    """Cond of the column-scaled (…, p) rows stacked to (·, p); inf if singular."""
    Wf = W.reshape(-1, W.shape[-1])
    norms = np.linalg.norm(Wf, axis=0)
    if not (np.all(np.isfinite(Wf)) and np.all(norms > 0.0)):
        return math.inf
    s = np.linalg.svd(Wf / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0.0 else math.inf


def soft_log_condition(s: np.ndarray) -> tuple[float, np.ndarray]:
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


def batched_rows(rows_fn: RowsFunction, q, qd, qdd) -> np.ndarray:
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


class ExcitationProblem:
    """Grid, basis, bounds and cached evaluations of one design (built once).

    ``x = [q0 (n), (a_j, b_j) (n × 2H) row-major]``. Attributes: ``t`` the grid,
    ``basis`` (Bq, Bv, Bv̇) (N, 2H) with q = q0 + Bq·(a_j, b_j), v = Bv·…,
    v̇ = Bv̇·…; ``rho`` the Bernstein factor; ``mid``, ``half``, ``vmax``, ``amax``,
    ``emax`` the limits with their margins; ``active`` the columns in the cost.
    """

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
        self.half = 0.5 * (limits.upper - limits.lower) - margins.position_margins(
            limits.prismatic
        )
        self.vmax = (1.0 - margins.velocity) * limits.velocity
        self.amax = (1.0 - margins.acceleration) * limits.acceleration
        self.emax = (1.0 - margins.effort) * limits.effort
        self.size = n * (2 * H + 1)
        self.evaluations = 0
        self._values: dict[bytes, tuple] = {}
        self._gradients: dict[bytes, tuple] = {}
        self._clearances: dict[bytes, tuple] = {}
        self.active = self._excitable(np.random.default_rng(settings.seed))

    def _excitable(self, rng: np.random.Generator) -> np.ndarray:
        """Columns that do not vanish at random states within the limits."""
        count = max(64, 4 * self.theta.size // self.n)
        q = rng.uniform(self.limits.lower, self.limits.upper, (count, self.n))
        W = batched_rows(self.rows_fn, q, *rng.standard_normal((2, count, self.n)))
        norms = np.linalg.norm(W.reshape(-1, W.shape[-1]), axis=0)
        return norms > _ZERO_COLUMN * norms.max()

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
        """(q0 (n,), coefficients (n, 2H)) of x."""
        return x[: self.n], x[self.n :].reshape(self.n, 2 * self.H)

    def pack(self, trajectory: FourierTrajectory) -> np.ndarray:
        """The parameter vector x of a trajectory."""
        ab = np.hstack([trajectory.a, trajectory.b])
        return np.concatenate([trajectory.q0, ab.ravel()])

    def trajectory(self, x: np.ndarray) -> FourierTrajectory:
        """The trajectory of x."""
        q0, ab = self.unpack(x)
        return FourierTrajectory(q0, ab[:, : self.H], ab[:, self.H :], self.omega)

    def kinematics(self, x: np.ndarray, basis=None):
        """(q, v, v̇) (N, n) of x on the grid (or on another ``basis``)."""
        q0, ab = self.unpack(x)
        Bq, Bv, Ba = self.basis if basis is None else basis
        return q0 + Bq @ ab.T, Bv @ ab.T, Ba @ ab.T

    # ------------------------------------------------------------------- cost, torque
    def values(self, x: np.ndarray) -> tuple:
        """(cost, W, τ, svd pieces) at x, cached."""
        key = x.tobytes()
        if key not in self._values:
            q, qd, qdd = self.kinematics(x)
            W = batched_rows(self.rows_fn, q, qd, qdd)
            self.evaluations += 1
            Wf = W[..., self.active].reshape(-1, int(self.active.sum()))
            norms = np.linalg.norm(Wf, axis=0)
            if np.all(np.isfinite(Wf)) and np.all(norms > 0.0):
                A = Wf / norms
                U, s, Vt = np.linalg.svd(A, full_matrices=False)
                cost, weights = soft_log_condition(s)
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
        G = np.zeros_like(W)  # ∂cost/∂W; zero in the inactive columns
        if svd is not None:
            A, norms, U, weights, Vt = svd
            GA = (U * weights) @ Vt
            GA = (GA - A * np.sum(A * GA, axis=0)) / norms
            G[..., self.active] = GA.reshape(N, n, -1)
        eye = np.eye(n)
        step_v = np.where(qd >= 0.0, _STEP_V, -_STEP_V)  # away from zero
        steps = [np.full((N, n), _STEP_Q), step_v, np.ones((N, n))]
        Q = np.concatenate([q + _STEP_Q * eye[j] for j in range(n)] + [q] * 2 * n)
        V = np.concatenate(
            [qd] * n + [qd + step_v * eye[j] for j in range(n)] + [qd] * n
        )
        Ac = np.concatenate([qdd] * 2 * n + [qdd + eye[j] for j in range(n)])
        Wb = batched_rows(self.rows_fn, Q, V, Ac).reshape(3, n, N, n, p)
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

    def effort(self, x: np.ndarray, emax: np.ndarray | None = None) -> np.ndarray:
        """Normalised effort constraints 1 ∓ τ/τ_max >= 0 (finite limits).

        ``emax`` (n,) [N·m or N] replaces the margined limits (tightened where the
        dense check finds τ beyond them between the grid's samples).
        """
        emax = self.emax if emax is None else emax
        finite = np.isfinite(emax)
        tau = self.values(x)[2][:, finite] / emax[finite]
        return np.concatenate([(1.0 - tau).ravel(), (1.0 + tau).ravel()])

    def effort_jacobian(
        self, x: np.ndarray, emax: np.ndarray | None = None
    ) -> np.ndarray:
        """Jacobian of :meth:`effort`."""
        emax = self.emax if emax is None else emax
        finite = np.isfinite(emax)
        J = self.gradients(x)[1][:, finite] / emax[finite][None, :, None]
        J = J.reshape(-1, self.size)
        return np.vstack([-J, J])
