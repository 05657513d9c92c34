"""Kinematics of a fixed-base tree of revolute and prismatic joints, pure numpy.

Twists are ``[ω; v]`` (angular first, as Drake's ``SpatialVelocity``); poses are 4×4
homogeneous matrices. Joint j (generalized-velocity order) moves link j; the world
twist of its screw is revolute ``S = [a; p × a]`` or prismatic ``S = [0; a]`` with
the axis a and a point p of the joint in the world. Everything is vectorised over a
leading sample axis. Used by :mod:`drake_dynid.core.rigid_body` (the regressor rows)
and built from a ``MultibodyPlant`` by :mod:`drake_dynid.plant_tree`.

Identities (docs/MATH.md §2): the Lie bracket
``ad(x) y = [ωx × ωy; ωx × vy + vx × ωy]``, ``Ad(X_WB⁻¹)`` maps world twists to the
body frame, and the momentum map K(V) gives the spatial momentum of a body with
standard parameters θ_b = [XX XY XZ YY YZ ZZ MX MY MZ M] as M(θ_b)·V = K(V)·θ_b.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from drake_dynid.core.tree_plan import TreePlan

__all__ = [
    "KinematicTree",
    "ad",
    "ad_inverse",
    "ad_transpose_momentum",
    "cross",
    "momentum_matrix",
    "rotation_about",
]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product along the last axis (faster than np.cross for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack((a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0), -1)


def ad(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Returns the Lie bracket of twists [ω; v], [ωx × ωy; ωx × vy + vx × ωy]."""
    wx, vx = x[..., :3], x[..., 3:]
    wy, vy = y[..., :3], y[..., 3:]
    return np.concatenate((cross(wx, wy), cross(wx, vy) + cross(vx, wy)), -1)


def ad_inverse(rotation: np.ndarray, position: np.ndarray, twist: np.ndarray):
    """Ad(X_WB⁻¹) of world twists [ω; v_O]: [Rᵀω; Rᵀ(v_O + ω × p)] (body frame)."""
    w, v = twist[..., :3], twist[..., 3:]
    rt = np.swapaxes(rotation, -1, -2)
    wb = np.einsum("...ij,...j->...i", rt, w)
    vb = np.einsum("...ij,...j->...i", rt, v + cross(w, position))
    return np.concatenate((wb, vb), -1)


def momentum_matrix(twist: np.ndarray) -> np.ndarray:
    """K(V), shape (..., 6, 10): spatial momentum M(θ_b)·V = K(V)·θ_b.

    θ_b = [XX XY XZ YY YZ ZZ MX MY MZ M], V = [ω; v_o] (body frame):
    angular = I_o ω + (m c) × v_o, linear = m v_o + ω × (m c).
    """
    w0, w1, w2 = twist[..., 0], twist[..., 1], twist[..., 2]
    u0, u1, u2 = twist[..., 3], twist[..., 4], twist[..., 5]
    out = np.zeros((*twist.shape[:-1], 6, 10))
    out[..., 0, 0] = w0
    out[..., 0, 1] = w1
    out[..., 1, 1] = w0
    out[..., 0, 2] = w2
    out[..., 2, 2] = w0
    out[..., 1, 3] = w1
    out[..., 1, 4] = w2
    out[..., 2, 4] = w1
    out[..., 2, 5] = w2
    # (m c) × v_o in the angular rows; ω × (m c) in the linear rows.
    out[..., 1, 6], out[..., 2, 6] = -u2, u1
    out[..., 4, 6], out[..., 5, 6] = w2, -w1
    out[..., 0, 7], out[..., 2, 7] = u2, -u0
    out[..., 3, 7], out[..., 5, 7] = -w2, w0
    out[..., 0, 8], out[..., 1, 8] = -u1, u0
    out[..., 3, 8], out[..., 4, 8] = w1, -w0
    out[..., 3, 9] = u0
    out[..., 4, 9] = u1
    out[..., 5, 9] = u2
    return out


def ad_transpose_momentum(twist: np.ndarray, k: np.ndarray) -> np.ndarray:
    """-ad(V)ᵀ applied to each column [n; f] of k: [ω × n + v × f; ω × f]."""
    w = twist[..., None, :3]
    v = twist[..., None, 3:]
    n = np.swapaxes(k[..., :3, :], -1, -2)
    f = np.swapaxes(k[..., 3:, :], -1, -2)
    out = np.concatenate((cross(w, n) + cross(v, f), cross(w, f)), -1)
    return np.swapaxes(out, -1, -2)


def rotation_about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: R = I + sin(θ)[a]× + (1 - cos θ)[a]×², shape (N, 3, 3)."""
    skew = np.array(
        [[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]]
    )
    s = np.sin(angle)[:, None, None]
    c = np.cos(angle)[:, None, None]
    return np.eye(3) + s * skew + (1.0 - c) * (skew @ skew)


@dataclass(frozen=True, eq=False)
class KinematicTree:
    """Numeric joint geometry of a fixed-base tree (one link per moving joint).

    Joint j (velocity order) connects parent link ``parent[j]`` (-1: the world
    group) to link j. ``X_parent_F[j]``: pose of the joint frame F in the parent
    link frame (or in the world); ``X_M_B[j]``: pose of link j's frame in the
    joint's child frame M; ``axis[j]`` in F (= in M); ``prismatic[j]``.
    ``ancestors[b, i]``: joint i is on the path from the world to link b (b
    included).
    """

    parent: np.ndarray
    X_parent_F: np.ndarray
    X_M_B: np.ndarray
    axis: np.ndarray
    prismatic: np.ndarray
    ancestors: np.ndarray
    order: tuple[int, ...]

    @cached_property
    def plan(self) -> TreePlan:
        """The tree's precomputed constants (:mod:`drake_dynid.core.tree_plan`)."""
        from drake_dynid.core.tree_plan import tree_plan

        return tree_plan(self)

    def forward(self, q: np.ndarray):
        """Link poses and world joint screws: R (N,n,3,3), p (N,n,3), S (N,n,6).

        X_WB,b = X_WB,parent(b) · A_b(q_b), with each joint's pose A_j affine in
        (cos q_j, sin q_j, q_j) (``plan.pose_terms``); S_j = Ad(X_WB,j) s_j with s_j
        the joint's constant screw in its child link's frame.
        """
        plan = self.plan
        num_samples, n = q.shape
        terms = plan.pose_terms
        pose = terms[0] + np.cos(q)[..., None] * terms[1]
        pose += np.sin(q)[..., None] * terms[2]
        if plan.has_prismatic:
            pose += q[..., None] * terms[3]
        local = pose.reshape(num_samples, n, 4, 4)
        world = np.empty_like(local)
        roots = list(plan.roots)
        world[:, roots] = local[:, roots]
        for j, parent in plan.chain:
            np.matmul(world[:, parent], local[:, j], out=world[:, j])
        rotation = world[..., :3, :3]
        position = world[..., :3, 3]
        # [R s_ω, R s_v] for every link: one product (einsum's BLAS path pays off
        # on batches, a stacked matmul on a few samples).
        if num_samples >= 32:
            rotated = np.einsum(
                "nbij,bjk->nbik", rotation, plan.screw_pairs, optimize=True
            )
        else:
            rotated = rotation @ plan.screw_pairs
        angular = rotated[..., 0]
        linear = rotated[..., 1] + cross(position, angular)
        return rotation, position, np.concatenate((angular, linear), -1)
