"""Model rows of one sample, fused and precomputed (the blocks' per-sample path).

The ``ModelRows`` block evaluates the rows (D, G, y) of docs/CONVENTIONS.md §3 one
sample at a time, where numpy's per-call overhead, not arithmetic, sets the cost.
This module evaluates them with a fixed, short sequence of whole-tree array
operations (no loop over link pairs), straight into base-parameter columns
(docs/MATH.md §2; constants from :mod:`drake_dynid.core.tree_plan`):

1. link transforms ``X_b = Ad(X_WB⁻¹) = Ad(A_b(q_b)⁻¹) X_parent(b)`` (a chain of
   6×6 products, each factor affine in cos q, sin q, q) and world screws
   ``S_j = P X_jᵀ P s_j``;
2. world twists ``V_b^W = Σ_{i anc b} S_i v_i``, screw rates ``Ṡ_i = ad(V^W_parent(i))
   S_i``, body twists ``V_b = X_b V_b^W`` and gravity ``Rᵀg``;
3. per link, the body-frame blocks ``[K(V_b) | -K([0; Rᵀg])]`` moved to the world,
   ``X_bᵀ [...]`` (6 × 20);
4. one product ``[S; Ṡ] · [world blocks of every link]`` gives, for every joint i
   and link b, ``∂h_E/∂v_i`` (S_iᵀ X_bᵀ K(V_b)), ``∂h_E/∂q_i`` (Ṡ_iᵀ X_bᵀ K(V_b))
   and ``∂h_U/∂q_i`` (-S_iᵀ X_bᵀ K([0; Rᵀg])), in one flat buffer;
5. D and G are gathers of that buffer by precomputed indices (base columns; a
   pair where joint i does not move link b reads a zero), plus the rotor
   (``IAj``: momentum v_j) and friction columns (``core.friction``'s law).

The power model uses steps 1-2 and the energy row h = ½ V_bᵀ K(V_b) + U_b. The
results equal the batch rows (``RobotModel.model_rows``) to round-off
(tests/test_sample_rows.py); on a 7-DOF arm one sample costs a few tens of µs.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core.friction import EXACT_SIGN, SignLaw, friction_column
from drake_dynid.core.tree_plan import SWAP, TreePlan

__all__ = ["SampleRowsPlan", "packed_sample_rows", "sample_rows_plan"]


@dataclass(frozen=True, eq=False)
class SampleRowsPlan:
    """Precomputed indices and constants of :func:`packed_sample_rows`.

    The packed channels of a kind are ``buffer[first] + buffer[second]`` of that
    kind's buffer (see :func:`packed_sample_rows`), then the rotor and friction
    channels.

    Attributes:
        tree: the tree's :class:`~drake_dynid.core.tree_plan.TreePlan` (n links).
        num_joints: n, joints (length of q, v, τ).
        num_parameters: p, base parameters (columns of D and G).
        gravity: (3,) gravity in the world [m/s²].
        blocks: (9, 120) maps ``[V_b, Rᵀg]`` to ``[K(V_b) | -K([0; Rᵀg])]``
            (row-major 6 × 20).
        lagrangian: (2, 2np + n) buffer indices of the Lagrangian channels.
        power: (2, 2p + 1) buffer indices of the power channels.
        rotor: (3, r) joint, Lagrangian channel and power channel of each ``IAj``.
        friction_kinds: the friction kinds, in column order.
        friction: (2, n·len(kinds)) Lagrangian and power channel of each friction
            column, kind-major (all joints of the first kind, then the next).
    """

    tree: TreePlan
    num_joints: int
    num_parameters: int
    gravity: np.ndarray
    blocks: np.ndarray
    lagrangian: np.ndarray
    power: np.ndarray
    rotor: np.ndarray
    friction_kinds: tuple[str, ...]
    friction: np.ndarray


def sample_rows_plan(
    tree: TreePlan,
    gravity: Any,
    base_columns: Sequence[int],
    inertial_columns: Any,
    rotor_columns: Any,
    friction_kinds: Sequence[str],
    friction_columns: Any,
) -> SampleRowsPlan:
    """Builds the plan of a robot's single-sample rows (no mimic joints).

    Args:
        tree: the tree's plan; its n links are the n identified joints' links.
        gravity: (3,) gravity in the world [m/s²].
        base_columns: the standard column of each base parameter (the
            independent columns, W_base = W_std[:, base_columns]).
        inertial_columns: (n, 10) standard column of each link's inertial
            parameter [XX … M].
        rotor_columns: (n,) standard column of each joint's ``IAj`` (-1: none).
        friction_kinds: friction kinds (``core.friction``), column order.
        friction_columns: (n, len(friction_kinds)) standard column of each
            joint's friction parameter.

    Raises:
        ValueError: a friction column that is not a base column (the rows could
            not hold the friction law).
    """
    n = tree.num_links
    base = [int(c) for c in base_columns]
    position = {standard: column for column, standard in enumerate(base)}
    p = len(base)
    inertial = np.asarray(inertial_columns, dtype=int).reshape(n, 10)
    rotor = np.asarray(rotor_columns, dtype=int).reshape(n)
    kinds = tuple(friction_kinds)
    friction = np.asarray(friction_columns, dtype=int).reshape(n, len(kinds))
    # Lagrangian buffer: Y[b, r, k] = ([S | Ṡ] of joint r)ᵀ X_bᵀ [K(V_b) | -K(g_b)]
    # (b, r < 2n, k < 20) flattened, then τ (n), then a zero.
    stride = 2 * n * 20
    tau_at = n * stride
    zero = tau_at + n
    lagrangian = np.full((2, 2 * n * p + n), zero)
    # Power buffer: kinetic (n·10), -Rᵀg (n·3), -p·g (n), vᵀτ, zero.
    power_zero = 14 * n + 1
    power = np.full((2, 2 * p + 1), power_zero)
    for b in range(n):
        for k in range(10):
            column = position.get(int(inertial[b, k]))
            if column is None:
                continue
            power[0, column] = b * 10 + k
            if 6 <= k < 9:
                power[1, column] = 10 * n + 3 * b + k - 6
            elif k == 9:
                power[1, column] = 13 * n + b
            for i in np.flatnonzero(tree.ancestors[b]):
                at = b * stride + i * 20 + k
                lagrangian[0, i * p + column] = at  # ∂h_E/∂v_i
                lagrangian[0, n * p + i * p + column] = at + 10  # ∂h_U/∂q_i
                lagrangian[1, n * p + i * p + column] = at + n * 20  # -∂h_E/∂q_i
    lagrangian[0, 2 * n * p :] = tau_at + np.arange(n)
    power[0, 2 * p] = 14 * n
    rotor_rows = [
        (j, j * p + position[int(rotor[j])], position[int(rotor[j])])
        for j in range(n)
        if int(rotor[j]) in position
    ]
    friction_rows = []
    for k in range(len(kinds)):
        for j in range(n):
            column = position.get(int(friction[j, k]))
            if column is None:
                raise ValueError(
                    "sample_rows_plan: every friction column must be a base "
                    f"parameter; standard column {int(friction[j, k])} is not."
                )
            friction_rows.append((n * p + j * p + column, p + column))
    # [V_b, Rᵀg] (9) -> [K(V_b) | -K([0; Rᵀg])] row-major (6, 20).
    basis = tree.momentum.reshape(6, 6, 10)
    blocks = np.zeros((9, 6, 20))
    blocks[:6, :, :10] = basis
    blocks[6:, :, 10:] = -basis[3:]
    arrays: dict[str, np.ndarray] = {
        "gravity": np.array(gravity, dtype=float).reshape(3),
        "blocks": blocks.reshape(9, 120),
        "lagrangian": lagrangian,
        "power": power,
        "rotor": np.array(rotor_rows, dtype=int).reshape(-1, 3).T.copy(),
        "friction": np.array(friction_rows, dtype=int).reshape(-1, 2).T.copy(),
    }
    for array in arrays.values():
        array.setflags(write=False)
    return SampleRowsPlan(
        tree=tree,
        num_joints=n,
        num_parameters=p,
        friction_kinds=kinds,
        **arrays,
    )


def _frames(tree: TreePlan, q: np.ndarray) -> np.ndarray:
    """X_b = Ad(X_WB⁻¹) of every link, (n, 6, 6)."""
    terms = tree.frame_terms
    local = terms[0] + np.cos(q)[:, None] * terms[1]
    local += np.sin(q)[:, None] * terms[2]
    if tree.has_prismatic:
        local += q[:, None] * terms[3]
    local = local.reshape(-1, 6, 6)
    frames = np.empty_like(local)
    for j in tree.roots:
        frames[j] = local[j]
    for j, parent in tree.chain:
        np.dot(local[j], frames[parent], out=frames[j])
    return frames


def packed_sample_rows(
    plan: SampleRowsPlan,
    kind: str,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    sign: SignLaw = EXACT_SIGN,
) -> np.ndarray:
    """The rows (D, G, y) of one sample, packed as ``core.rows.pack_rows``.

    ``"lagrangian"``: D = ∂h_E/∂v, G = ∂h_U/∂q - ∂h_E/∂q + friction ``[v_i, s(v_i),
    1]``, y = τ (m = n); ``"power"``: D = h, G = friction power ``[v_j², v_j s(v_j),
    v_j]``, y = vᵀτ (m = 1). Units as ``RobotModel.model_rows``.

    Args:
        plan: from :func:`sample_rows_plan`.
        kind: ``"power"`` or ``"lagrangian"``.
        q: (n,) joint positions [rad, m].
        v: (n,) joint velocities [rad/s, m/s].
        tau: (n,) joint torques [N·m, N].
        sign: the Coulomb law s(v) of the friction columns.

    Returns:
        ``2·m·p + m`` channels: D row-major, G row-major, y.
    """
    tree = plan.tree
    n = tree.num_links
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    frames = _frames(tree, q)
    screws = (tree.screw_swapped[:, None, :] @ frames)[:, 0, SWAP]
    gravity = frames[:, :3, :3] @ plan.gravity
    moving = tree.ancestors * v
    if kind == "lagrangian":
        parent = (tree.strict_ancestors * v) @ screws
        rates = ((parent @ tree.ad).reshape(n, 6, 6) @ screws[:, :, None])[..., 0]
        pairs = frames @ np.concatenate((screws, rates)).T  # (b, 6, 2n)
        twist = (pairs[:, :, :n] @ moving[:, :, None])[:, :, 0]
        blocks = np.concatenate((twist, gravity), axis=1) @ plan.blocks
        buffer = np.empty(2 * n * n * 20 + n + 1)
        np.matmul(
            pairs.transpose(0, 2, 1),
            blocks.reshape(n, 6, 20),
            out=buffer[: 2 * n * n * 20].reshape(n, 2 * n, 20),
        )
        buffer[-n - 1 : -1] = tau
        buffer[-1] = 0.0
        out = buffer[plan.lagrangian[0]]
        out -= buffer[plan.lagrangian[1]]
        if plan.rotor.size:
            out[plan.rotor[1]] = v[plan.rotor[0]]
        if plan.friction_kinds:
            values = [friction_column(k, v, sign) for k in plan.friction_kinds]
            out[plan.friction[0]] += np.concatenate(values)
        return out
    if kind != "power":
        raise ValueError(
            f"packed_sample_rows: kind must be one of power, lagrangian; got {kind!r}."
        )
    twist = (frames @ (moving @ screws)[:, :, None])[:, :, 0]
    momentum = (twist @ tree.momentum).reshape(n, 6, 10)
    kinetic = 0.5 * (twist[:, None, :] @ momentum)
    # -p·g = u·(Rᵀg) with u = -Rᵀp: [u]× = X_21 X_11ᵀ (X_21 = -Rᵀ[p]×, X_11 = Rᵀ).
    moment = frames[:, 3:, :3] @ frames[:, :3, :3].transpose(0, 2, 1)
    height = np.einsum("bi,bi->b", moment.reshape(n, 9)[:, [7, 2, 3]], gravity)
    buffer = np.concatenate((kinetic.ravel(), -gravity.ravel(), height, [v @ tau, 0.0]))
    out = buffer[plan.power[0]]
    out += buffer[plan.power[1]]
    if plan.rotor.size:
        out[plan.rotor[2]] += 0.5 * v[plan.rotor[0]] ** 2
    if plan.friction_kinds:
        values = [friction_column(k, v, sign) for k in plan.friction_kinds]
        out[plan.friction[1]] = np.tile(v, len(values)) * np.concatenate(values)
    return out
