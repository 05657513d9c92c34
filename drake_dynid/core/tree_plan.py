"""Precomputed constants of a kinematic tree for the fused regressor rows (numpy).

The rows of :mod:`drake_dynid.core.rigid_body` need, per sample, the body-frame
Jacobians ``J_b,i = Ad(X_WB⁻¹) S_i`` of every (link, joint) pair and the momentum
maps ``K(V_b)``. Evaluated pair by pair (or with ``einsum``), the numpy call
overhead dominates for one sample and the einsum paths for batches. This module
turns the tree into constant arrays so that each quantity is one matrix product
over all links (docs/MATH.md §2):

* link frame transforms by the chain of spatial (6×6) transforms, each affine in
  (cos q_j, sin q_j, q_j)::

      X_b = Ad(X_WB⁻¹) = Ad(A_b(q_b)⁻¹) · X_parent(b),
      Ad(A_j(q)⁻¹) = F0_j + cos q·F1_j + sin q·F2_j + q·F3_j

  with A_j(q) = X_parent_F · H_j(q) · X_M_B the joint's pose in its parent link
  (a revolute H_j rotates about the axis: Rot = (I + [a]×²) + sin q [a]× - cos q
  [a]×²; a prismatic one translates along it);
* world screws ``S_j = Ad(X_WB,j) s_j`` from the constant screw s_j of joint j in
  its child link's frame, with ``Ad(X) = P X⁻ᵀ P`` (P swaps the angular and linear
  halves), i.e. ``S_j = P X_jᵀ (P s_j)``;
* the bilinear maps as matrices: ``K(V) = V · K_basis`` (6 → 6×10) and
  ``ad(x) = x · ad_basis`` (6 → 6×6).

All arrays are read-only; :func:`tree_plan` builds them once per tree
(``KinematicTree.plan``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from drake_dynid.core.kinematics import momentum_matrix

if TYPE_CHECKING:
    from drake_dynid.core.kinematics import KinematicTree

__all__ = ["SWAP", "TreePlan", "ad_basis", "momentum_basis", "skew", "tree_plan"]

#: Index that swaps the angular and linear halves of a 6-vector (P above).
SWAP = np.array([3, 4, 5, 0, 1, 2])
SWAP.setflags(write=False)


def skew(a: np.ndarray) -> np.ndarray:
    """[a]×, the 3×3 cross-product matrix of a 3-vector: [a]× b = a × b."""
    return np.array(
        [[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]], dtype=float
    )


def momentum_basis() -> np.ndarray:
    """(6, 60): K(V) = (V · basis).reshape(6, 10), K the momentum map."""
    return np.stack([momentum_matrix(e).ravel() for e in np.eye(6)])


def ad_basis() -> np.ndarray:
    """(6, 36): ad(x) = (x · basis).reshape(6, 6) = [[ω×, 0], [v×, ω×]]."""
    out = np.zeros((6, 6, 6))
    for k, e in enumerate(np.eye(3)):
        out[k, :3, :3] = out[k, 3:, 3:] = skew(e)
        out[3 + k, 3:, :3] = skew(e)
    return out.reshape(6, 36)


def _ad_matrix(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Ad(X) = [[R, 0], [[p]× R, R]] of a pose X = (R, p): body twist -> world."""
    out = np.zeros((6, 6))
    out[:3, :3] = out[3:, 3:] = rotation
    out[3:, :3] = skew(position) @ rotation
    return out


def _ad_inverse(pose: np.ndarray) -> np.ndarray:
    """Ad(X⁻¹) of a 4×4 pose."""
    rotation, position = pose[:3, :3], pose[:3, 3]
    return _ad_matrix(rotation.T, -rotation.T @ position)


@dataclass(frozen=True, eq=False)
class TreePlan:
    """Constant arrays of a :class:`~drake_dynid.core.kinematics.KinematicTree`.

    Attributes:
        num_links: n, links (= joints) of the tree.
        chain: ``(link, parent)`` pairs in evaluation order, parent >= 0.
        roots: links whose parent is the world group.
        frame_terms: (4, n, 36): Ad(A_j(q)⁻¹) = Σ_k c_k frame_terms[k, j] with
            c = (1, cos q, sin q, q) (cos/sin terms zero for prismatic joints, the
            q term zero for revolute ones).
        pose_terms: (4, n, 16): A_j(q) (4×4, row-major) with the same c.
        has_prismatic: whether some joint is prismatic (the q terms are used).
        screw: (n, 6) s_j, the screw of joint j in its child link's frame.
        screw_pairs: (n, 3, 2) its angular and linear halves as columns.
        screw_swapped: (n, 6) P s_j.
        ancestors: (n, n) 1.0 where joint i is on the path to link b (b
            included): ``ancestors[b, i]``.
        strict_ancestors: (n, n) the same without b itself (``[i, k]``: joint k
            moves joint i's parent link).
        pair_mask: (n, 1, 2n) ``[ancestors, ancestors]`` for the stacked
            Jacobians ``[J | ∂J]``.
        momentum: (6, 60) :func:`momentum_basis`.
        ad: (6, 36) :func:`ad_basis`.
    """

    num_links: int
    chain: tuple[tuple[int, int], ...]
    roots: tuple[int, ...]
    frame_terms: np.ndarray
    pose_terms: np.ndarray
    has_prismatic: bool
    screw: np.ndarray
    screw_pairs: np.ndarray
    screw_swapped: np.ndarray
    ancestors: np.ndarray
    strict_ancestors: np.ndarray
    pair_mask: np.ndarray
    momentum: np.ndarray
    ad: np.ndarray


def tree_plan(tree: KinematicTree) -> TreePlan:
    """Builds the :class:`TreePlan` of a tree (see the module docstring)."""
    n = len(tree.parent)
    frame_terms = np.zeros((4, n, 6, 6))
    pose_terms = np.zeros((4, n, 4, 4))
    screws = np.zeros((n, 6))
    for j in range(n):
        axis = np.asarray(tree.axis[j], dtype=float)
        x_pf = np.asarray(tree.X_parent_F[j], dtype=float)
        x_mb = np.asarray(tree.X_M_B[j], dtype=float)
        ad_mb_inv = _ad_inverse(x_mb)
        ad_pf_inv = _ad_inverse(x_pf)
        k = skew(axis)
        rotation_mb = x_mb[:3, :3]
        direction = rotation_mb.T @ axis  # the axis in the child link's frame
        if tree.prismatic[j]:
            # H(x) = translation a·x: Ad(H⁻¹) = [[I, 0], [-x [a]×, I]].
            shift = np.zeros((6, 6))
            shift[3:, :3] = -k
            frame_terms[0, j] = ad_mb_inv @ ad_pf_inv
            frame_terms[3, j] = ad_mb_inv @ shift @ ad_pf_inv
            move = np.zeros((4, 4))
            move[:3, 3] = axis
            pose_terms[0, j] = x_pf @ x_mb
            pose_terms[3, j] = x_pf @ move @ x_mb
            screws[j, 3:] = direction
        else:
            # Rot(q) = (I + K²) + sin q K - cos q K²; Ad(H⁻¹) = diag(Rotᵀ, Rotᵀ).
            parts = (np.eye(3) + k @ k, -(k @ k), k)
            for term, rotation in zip((0, 1, 2), parts, strict=True):
                block = np.zeros((6, 6))
                block[:3, :3] = block[3:, 3:] = rotation.T
                frame_terms[term, j] = ad_mb_inv @ block @ ad_pf_inv
                homogeneous = np.zeros((4, 4))
                homogeneous[:3, :3] = rotation
                homogeneous[3, 3] = 1.0 if term == 0 else 0.0
                pose_terms[term, j] = x_pf @ homogeneous @ x_mb
            # The joint passes through the origin of M: -R_MBᵀ t_MB in link frame.
            point = -rotation_mb.T @ x_mb[:3, 3]
            screws[j, :3] = direction
            screws[j, 3:] = np.cross(point, direction)
    ancestors = np.asarray(tree.ancestors, dtype=float)
    strict = ancestors - np.eye(n)
    parent = [int(p) for p in tree.parent]
    arrays = {
        "frame_terms": frame_terms.reshape(4, n, 36),
        "pose_terms": pose_terms.reshape(4, n, 16),
        "screw": screws,
        "screw_pairs": np.stack((screws[:, :3], screws[:, 3:]), axis=-1),
        "screw_swapped": screws[:, SWAP],
        "ancestors": ancestors,
        "strict_ancestors": strict,
        "pair_mask": np.concatenate([ancestors, ancestors], axis=1)[:, None, :],
        "momentum": momentum_basis(),
        "ad": ad_basis(),
    }
    for array in arrays.values():
        array.setflags(write=False)
    return TreePlan(
        num_links=n,
        chain=tuple((j, parent[j]) for j in tree.order if parent[j] >= 0),
        roots=tuple(j for j in tree.order if parent[j] < 0),
        has_prismatic=bool(np.any(tree.prismatic)),
        **arrays,
    )
