"""Inverse-dynamics rows of a batch, fused and precomputed (the replay/off-line path).

Batches of regressor rows W(q, v, v̇) (τ = W·θ, docs/MATH.md §2) are a few dozen
whole-batch numpy calls. Their cost is set by the stacked products of small matrices
(numpy calls one BLAS product per sample and link, about 50-100 ns each) and by the
temporaries; this module keeps the stacked products to four and does the rest with
large products against constant matrices (constants from
:mod:`drake_dynid.core.tree_plan`), straight into base-parameter columns:

1. link transforms ``X_b = Ad(X_WB⁻¹)``: the local factors ``Ad(A_b(q_b)⁻¹)`` of
   every link are one product ``[1, cos q, sin q, q] · local_terms``; the chain
   ``X_b = Ad(A_b⁻¹) X_parent(b)`` is one stacked product per link;
2. world screws ``S_j = P X_jᵀ P s_j`` (a few rows of X_j, as P s_j is sparse), world
   twists ``V^W_b = Σ_{i anc b} S_i v_i`` (a cumulative sum on a serial chain),
   screw rates ``Ṡ_i v_i = ad(V^W_i) S_i v_i`` (= ad(V^W_parent(i)) S_i v_i, as
   ad(S_i) S_i = 0) and world accelerations
   ``A^W_b = Σ_{i anc b} S_i v̇_i + Ṡ_i v_i - [0; g]`` (gravity as the base
   acceleration -g, added at the roots);
3. body twist and acceleration ``[V_b, a_b] = X_b [V^W_b, A^W_b]`` (one stacked
   product), and the link's Newton-Euler force per parameter
   ``F_b = K(a_b) - ad(V_b)ᵀ K(V_b)`` (6×10) as one product of
   ``[ω_b ⊗ V_b, a_b]`` (24 features: F_b is bilinear in V_b, with no term in the
   products of the linear velocity, and linear in a_b) with a constant 24×60 matrix;
4. ``X_bᵀ F_b`` moves every link's block to the world (one stacked product), and
   ``S_iᵀ X_bᵀ F_b`` for every joint i and link b is one stacked product per sample
   (n × 6 by 6 × 10n);
5. W in base columns is one gather of ``[S_iᵀ X_bᵀ F_b, v̇, friction columns, 0]``
   by precomputed indices (a pair where joint i does not move link b reads the 0;
   ``IAj``: v̇_j; friction ``[v_i, s(v_i), 1]``, ``core.friction``'s law).

The Lagrangian model rows of the raw-rows path (``core.raw_rows``), averaged over
bank steps, reuse steps 1-2 and the gather (:func:`batch_lagrangian_mean_rows`): the
mean over a bank step of ``[S_i; ad(V^W_i) S_i]ᵀ X_bᵀ [K(V_b) | K([0; -g_b])]`` is one
product per bank step, its samples side by side in the inner dimension.

Large batches are cut into blocks of :data:`BLOCK` samples so that the temporaries
stay in the processor's cache. The rows equal ``core.rigid_body``'s (the general
path, ``RobotModel.idim_rows(columns="standard")``) to round-off and Pinocchio's
joint-torque regressor to 1e-12 (tests/test_idim_base_rows.py).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core.friction import EXACT_SIGN, SignLaw, friction_column
from drake_dynid.core.kinematics import ad, momentum_matrix
from drake_dynid.core.tree_plan import SWAP, TreePlan

__all__ = [
    "BLOCK",
    "BatchRowsPlan",
    "batch_idim_rows",
    "batch_lagrangian_mean_rows",
    "batch_rows_plan",
]

#: Samples per block: the temporaries of one block (a few hundred kB on a 7-DOF arm)
#: stay in the cache; larger blocks are slower per sample, smaller ones pay numpy's
#: per-call overhead more often.
BLOCK = 256


@dataclass(frozen=True, eq=False)
class BatchRowsPlan:
    """Precomputed constants of :func:`batch_idim_rows` (n links = n joints).

    Attributes:
        tree: the tree's :class:`~drake_dynid.core.tree_plan.TreePlan`.
        num_parameters: p, base parameters (columns of W).
        gravity: (3,) gravity in the world [m/s²].
        local_terms: (2n + 1 [+ n], 36n): ``[1, cos q, sin q (, q)] · local_terms``
            is ``Ad(A_j(q_j)⁻¹)`` of every link, row-major (the q terms only with a
            prismatic joint).
        serial: whether the tree is one chain in link order (link j's parent is
            j - 1): sums over ancestors are cumulative sums.
        screw_rows: ``(r, c)`` pairs: ``P S_j = Σ c[j] X_j[r, :]`` (c (n,), the
            nonzero rows r of ``P s_j``).
        force: (24, 60): ``F_b.ravel() = [(ω_b ⊗ V_b).ravel(), a_b] · force``.
        index: (n·p,) buffer index of each entry of W (joint-major).
        friction_kinds: the friction kinds, in buffer order.
    """

    tree: TreePlan
    num_parameters: int
    gravity: np.ndarray
    local_terms: np.ndarray
    serial: bool
    screw_rows: tuple[tuple[int, np.ndarray], ...]
    force: np.ndarray
    index: np.ndarray
    friction_kinds: tuple[str, ...]


def _force_basis() -> np.ndarray:
    """(24, 60): F = K(a) - ad(V)ᵀ K(V) from [ω ⊗ V, a], V = [ω; u]."""
    basis = np.eye(6)
    ad_basis = np.zeros((6, 6, 6))
    for k in range(6):
        for m in range(6):
            ad_basis[k, :, m] = ad(basis[k], basis[m])

    def quadratic(twist: np.ndarray) -> np.ndarray:
        matrix = np.tensordot(twist, ad_basis, axes=1)  # ad(V)
        return -(matrix.T @ momentum_matrix(twist)).ravel()

    out = np.zeros((24, 60))
    for a in range(3):
        for b in range(6):
            if a == b:
                term = quadratic(basis[a])
            else:
                term = quadratic(basis[a] + basis[b])
                term = term - quadratic(basis[a]) - quadratic(basis[b])
                if b < 3:
                    term = 0.5 * term  # ω_a ω_b appears twice in ω ⊗ V
            out[6 * a + b] = term
    out[18:] = momentum_matrix(basis).reshape(6, 60)
    # No term in u_a u_b: the features need not hold the linear velocity's products.
    assert not any(np.any(quadratic(u + w)) for u in basis[3:] for w in basis[3:])
    return out


def batch_rows_plan(
    tree: TreePlan,
    gravity: Any,
    base_columns: Sequence[int],
    inertial_columns: Any,
    rotor_columns: Any,
    friction_kinds: Sequence[str],
    friction_columns: Any,
) -> BatchRowsPlan:
    """Builds the plan of a robot's batch inverse-dynamics rows (no mimic joints).

    Args:
        tree: the tree's plan; its n links are the n identified joints' links.
        gravity: (3,) gravity in the world [m/s²].
        base_columns: the standard column of each base parameter
            (W_base = W_std[:, base_columns]).
        inertial_columns: (n, 10) standard column of each link's inertial
            parameter [XX … M].
        rotor_columns: (n,) standard column of each joint's ``IAj`` (-1: none).
        friction_kinds: friction kinds (``core.friction``), column order.
        friction_columns: (n, len(friction_kinds)) standard column of each
            joint's friction parameter.

    Raises:
        ValueError: a base column that is none of these (e.g. a coupled motor's),
            which the gather could not fill.
    """
    n = tree.num_links
    base = [int(c) for c in base_columns]
    p = len(base)
    kinds = tuple(friction_kinds)
    sources: dict[int, tuple[str, int, int]] = {}
    inertial = np.asarray(inertial_columns, dtype=int).reshape(n, 10)
    for b in range(n):
        for k in range(10):
            sources[int(inertial[b, k])] = ("link", b, k)
    for j, column in enumerate(np.asarray(rotor_columns, dtype=int).reshape(n)):
        if column >= 0:
            sources[int(column)] = ("rotor", j, 0)
    friction = np.asarray(friction_columns, dtype=int).reshape(n, len(kinds))
    for j in range(n):
        for k in range(len(kinds)):
            sources[int(friction[j, k])] = ("friction", j, k)
    # Buffer: [S_iᵀ X_bᵀ F_b (i, b, k: n·n·10) | v̇ (n) | friction (kind, j) | 0].
    links = n * n * 10
    zero = links + n + n * len(kinds)
    index = np.full((n, p), zero)
    for column, standard in enumerate(base):
        if standard not in sources:
            raise ValueError(
                "batch_rows_plan: every base column must be a link, rotor or "
                f"friction column; standard column {standard} is not."
            )
        source, j, k = sources[standard]
        if source == "link":
            for i in np.flatnonzero(tree.ancestors[j]):
                index[i, column] = (i * n + j) * 10 + k
        elif source == "rotor":
            index[j, column] = links + j
        else:
            index[j, column] = links + n + k * n + j
    terms = tree.frame_terms.reshape(4, n, 36)
    used = 4 if tree.has_prismatic else 3
    local = np.zeros((1 + (used - 1) * n, n * 36))
    local[0] = terms[0].ravel()
    for t in range(1, used):
        for j in range(n):
            local[1 + (t - 1) * n + j, j * 36 : (j + 1) * 36] = terms[t, j]
    swapped = tree.screw_swapped
    screw_rows = tuple(
        (r, swapped[:, r].copy()) for r in range(6) if np.any(swapped[:, r])
    )
    for _, coefficients in screw_rows:
        coefficients.setflags(write=False)
    arrays: dict[str, np.ndarray] = {
        "gravity": np.array(gravity, dtype=float).reshape(3),
        "local_terms": local,
        "force": _force_basis(),
        "index": index.ravel(),
    }
    for array in arrays.values():
        array.setflags(write=False)
    serial = tree.roots == (0,) and tree.chain == tuple((j, j - 1) for j in range(1, n))
    return BatchRowsPlan(
        tree=tree,
        num_parameters=p,
        serial=serial,
        screw_rows=screw_rows,
        friction_kinds=kinds,
        **arrays,
    )


def _over_ancestors(plan: BatchRowsPlan, x: np.ndarray, out: np.ndarray) -> None:
    """out[:, b] = Σ_{i anc b} x[:, i] (x, out: (N, n, 6)).

    On a serial chain one addition per link (twice as fast as ``np.cumsum`` along
    the link axis).
    """
    if plan.serial:
        out[:, 0] = x[:, 0]
        for j in range(1, x.shape[1]):
            np.add(out[:, j - 1], x[:, j], out=out[:, j])
    else:
        np.matmul(plan.tree.ancestors, x, out=out)


# ad(x) y = [ωx × ωy; ωx × vy + vx × ωy] as the cross products of the 3 pairs
# ([ωx, ωx, vx], [ωy, vy, ωy]), a × b = a[1,2,0] b[2,0,1] - a[2,0,1] b[1,2,0].
_PAIRS = (np.array([0, 1, 2, 0, 1, 2, 3, 4, 5]), np.array([0, 1, 2, 3, 4, 5, 0, 1, 2]))
_ROLL = (np.array([1, 2, 0]), np.array([2, 0, 1]))
_BRACKET = tuple(
    pair.reshape(3, 3)[:, roll].ravel() for pair in _PAIRS for roll in _ROLL
)  # x's first roll, x's second, y's first, y's second


def _bracket(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """ad(x) y of twists [ω; v] (..., 6), by index gathers.

    The same numbers as ``core.kinematics.ad`` in fewer numpy calls.
    """
    x1, x2, y1, y2 = _BRACKET
    terms = x[..., x1] * y[..., y2]
    terms -= x[..., x2] * y[..., y1]
    out = np.empty(x.shape)
    out[..., :3] = terms[..., :3]
    np.add(terms[..., 3:6], terms[..., 6:], out=out[..., 3:])
    return out


def _frames_and_screws(
    plan: BatchRowsPlan, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-2a: X_b = Ad(X_WB⁻¹) (N, n, 6, 6) and the world screws S_j (N, n, 6)."""
    tree = plan.tree
    num_samples, n = q.shape
    factors = np.empty((num_samples, plan.local_terms.shape[0]))
    factors[:, 0] = 1.0
    np.cos(q, out=factors[:, 1 : n + 1])
    np.sin(q, out=factors[:, n + 1 : 2 * n + 1])
    if tree.has_prismatic:
        factors[:, 2 * n + 1 :] = q
    local = (factors @ plan.local_terms).reshape(num_samples, n, 6, 6)
    frames = np.empty_like(local)
    for j in tree.roots:
        frames[:, j] = local[:, j]
    for j, parent in tree.chain:
        np.matmul(local[:, j], frames[:, parent], out=frames[:, j])
    swapped = None
    for r, coefficients in plan.screw_rows:
        term = frames[:, :, r, :] * coefficients[:, None]
        swapped = term if swapped is None else swapped + term
    screws = np.zeros((num_samples, n, 6)) if swapped is None else swapped[..., SWAP]
    return frames, screws


def _block_rows(
    plan: BatchRowsPlan,
    q: np.ndarray,
    v: np.ndarray,
    vdot: np.ndarray,
    sign: SignLaw,
    out: np.ndarray,
) -> None:
    """W of one block of samples into ``out`` ((N, n·p), C-contiguous)."""
    tree = plan.tree
    num_samples, n = q.shape
    rows = num_samples * n
    # 1. X_b of every link; 2. world screws, twists, screw rates and accelerations.
    frames, screws = _frames_and_screws(plan, q)
    world = np.empty((num_samples, n, 6, 2))  # [A^W_b, V^W_b] as columns
    twist = world[..., 1]
    moving = screws * v[..., None]
    _over_ancestors(plan, moving, twist)
    rates = _bracket(twist, moving)
    rates += screws * vdot[..., None]
    rates[:, list(tree.roots), 3:] -= plan.gravity
    _over_ancestors(plan, rates, world[..., 0])
    # 3. [a_b, V_b] into the features [ω_b ⊗ V_b, a_b, V_b], then F_b.
    features = np.empty((rows, 30))
    body = features.reshape(num_samples, n, 5, 6)[:, :, 3:].transpose(0, 1, 3, 2)
    np.matmul(frames, world, out=body)
    np.multiply(
        features[:, 24:27, None],
        features[:, None, 24:30],
        out=features[:, :18].reshape(rows, 3, 6),
    )
    force = features[:, :24] @ plan.force
    # 4. S_iᵀ X_bᵀ F_b for every joint i and link b.
    moved = np.empty((num_samples, 6, n, 10))
    np.matmul(
        frames.transpose(0, 1, 3, 2),
        force.reshape(num_samples, n, 6, 10),
        out=moved.transpose(0, 2, 1, 3),
    )
    links = n * n * 10
    buffer = np.empty((num_samples, links + n + n * len(plan.friction_kinds) + 1))
    np.matmul(
        screws,
        moved.reshape(num_samples, 6, n * 10),
        out=buffer[:, :links].reshape(num_samples, n, n * 10),
    )
    # 5. Rotor and friction columns, the gather.
    buffer[:, links : links + n] = vdot
    at = links + n
    for kind in plan.friction_kinds:
        buffer[:, at : at + n] = friction_column(kind, v, sign)
        at += n
    buffer[:, -1] = 0.0
    np.take(buffer, plan.index, axis=1, out=out, mode="clip")


def batch_idim_rows(
    plan: BatchRowsPlan,
    q: np.ndarray,
    v: np.ndarray,
    vdot: np.ndarray,
    sign: SignLaw = EXACT_SIGN,
) -> np.ndarray:
    """Inverse-dynamics rows W(q, v, v̇) in base columns, ``(N, n, p)``: τ = W·θ.

    Same rows as ``RobotModel.idim_rows`` (gravity as the base acceleration -g,
    friction ``[v_i, s(v_i), 1]`` in joint i's columns, ``IAj``: v̇_j) [N·m, N per
    parameter unit].

    Args:
        plan: from :func:`batch_rows_plan`.
        q: (N, n) joint positions [rad, m].
        v: (N, n) joint velocities [rad/s, m/s].
        vdot: (N, n) joint accelerations [rad/s², m/s²].
        sign: the Coulomb law s(v) of the friction columns.
    """
    q = np.ascontiguousarray(q, dtype=float)
    v = np.ascontiguousarray(v, dtype=float)
    vdot = np.ascontiguousarray(vdot, dtype=float)
    num_samples, n = q.shape
    p = plan.num_parameters
    out = np.empty((num_samples, n * p))
    for start in range(0, num_samples, BLOCK):
        stop = min(start + BLOCK, num_samples)
        _block_rows(
            plan, q[start:stop], v[start:stop], vdot[start:stop], sign, out[start:stop]
        )
    return out.reshape(num_samples, n, p)


def _energy_basis() -> np.ndarray:
    """(9, 84): ``[K(V_b) | K([0; -g_b])[:, 6:]]`` (6×14, row-major) from [V_b, g_b].

    K([0; u]) has no term in the rotational inertia: its last four columns
    (MX MY MZ M) are all the gravity block needs.
    """
    out = np.zeros((9, 6, 14))
    out[:6, :, :10] = momentum_matrix(np.eye(6))
    unit = np.zeros((3, 6))
    unit[:, 3:] = np.eye(3)
    out[6:, :, 10:] = -momentum_matrix(unit)[..., 6:]
    return out.reshape(9, 84)


_ENERGY = _energy_basis()
_ENERGY.setflags(write=False)


def _lagrangian_block(
    plan: BatchRowsPlan,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    block: int,
    sign: SignLaw,
    out: np.ndarray,
) -> None:
    """The block means of one batch of samples into ``out`` ((N/block, 2np + n))."""
    num_samples, n = q.shape
    count = num_samples // block
    frames, screws = _frames_and_screws(plan, q)
    # World twists V^W_b and [0; g] as columns; X_b moves both to the body.
    world = np.zeros((num_samples, n, 6, 2))
    _over_ancestors(plan, screws * v[..., None], world[..., 0])
    world[..., 3:, 1] = plan.gravity
    body = frames @ world
    features = np.empty((num_samples, n, 9))
    features[..., :6] = body[..., 0]
    features[..., 6:] = body[..., 3:, 1]
    blocks = (features.reshape(num_samples * n, 9) @ _ENERGY).reshape(
        num_samples, n, 6, 14
    )
    moved = np.empty((num_samples, 6, n, 14))  # X_bᵀ [K(V_b) | K([0; -g_b])]
    np.matmul(frames.transpose(0, 1, 3, 2), blocks, out=moved.transpose(0, 2, 1, 3))
    # [S_i; ad(V^W_i) S_i] of the block's samples side by side: the block's mean of
    # their products with ``moved`` is one product over (sample, 6).
    left = np.empty((count, 2 * n, block, 6))
    by_block = left.transpose(0, 2, 1, 3)
    by_block[:, :, :n] = screws.reshape(count, block, n, 6)
    by_block[:, :, n:] = _bracket(world[..., 0], screws).reshape(count, block, n, 6)
    product = left.reshape(count, 2 * n, block * 6) @ moved.reshape(
        count, block * 6, n * 14
    )
    product = product.reshape(count, 2 * n, n, 14)
    product *= 1.0 / block
    # W's columns gathered from the products (plan.index into batch_idim_rows's
    # buffer [links (i, b, k) | v | friction | 0], without forming the buffers):
    # D_i the S_i rows' K(V) part; G_i minus the ad(V) S_i rows' K(V) part, plus
    # the S_i rows' gravity part on k = 6..9 (MX MY MZ M).
    gather = _lagrangian_gather(plan)
    flat = product.reshape(count, 2 * n * n * 14)
    np.negative(product[:, n:], out=product[:, n:])
    p = plan.num_parameters
    d_out, g_out = out[:, : n * p], out[:, n * p : 2 * n * p]
    np.take(flat, gather.d_source, axis=1, out=d_out, mode="clip")
    np.take(flat, gather.g_source, axis=1, out=g_out, mode="clip")
    g_out[:, gather.gravity_columns] += flat[:, gather.gravity_source]
    d_out[:, gather.d_zero] = 0.0
    g_out[:, gather.g_zero] = 0.0
    if gather.rotor_columns.size:
        means = v.reshape(count, block, n).mean(axis=1)
        d_out[:, gather.rotor_columns] = means[:, gather.rotor_joints]
    for kind, columns, joints in zip(
        plan.friction_kinds,
        gather.friction_columns,
        gather.friction_joints,
        strict=True,
    ):
        if columns.size:
            column = np.broadcast_to(friction_column(kind, v, sign), v.shape)
            means = column.reshape(count, block, n).mean(axis=1)
            g_out[:, columns] = means[:, joints]
    out[:, 2 * n * p :] = tau.reshape(count, block, n).mean(axis=1)


@dataclass(frozen=True)
class _LagrangianGather:
    """Where each column of :func:`_lagrangian_block`'s D and G comes from.

    ``d_source``/``g_source``: (n·p,) positions in the block's products (C, 2n, n,
    14) flattened (0 where another rule fills the column); ``gravity_columns``
    (of G) add ``gravity_source``; ``d_zero``/``g_zero`` the columns that are 0;
    rotor and friction columns the joints' block means.
    """

    d_source: np.ndarray
    g_source: np.ndarray
    gravity_columns: np.ndarray
    gravity_source: np.ndarray
    d_zero: np.ndarray
    g_zero: np.ndarray
    rotor_columns: np.ndarray
    rotor_joints: np.ndarray
    friction_columns: tuple[np.ndarray, ...]
    friction_joints: tuple[np.ndarray, ...]


@functools.lru_cache(maxsize=16)
def _lagrangian_gather(plan: BatchRowsPlan) -> _LagrangianGather:
    """:class:`_LagrangianGather` of a plan (its ``index``), once per plan."""
    n = plan.tree.num_links
    links = n * n * 10
    index = plan.index
    is_link = index < links
    pair, k = np.divmod(np.where(is_link, index, 0), 10)  # pair = i·n + b
    d_source = np.where(is_link, pair * 14 + k, 0)
    g_source = np.where(is_link, (n * n + pair) * 14 + k, 0)
    gravity = np.flatnonzero(is_link & (k >= 6))
    rotor = (index >= links) & (index < links + n)
    friction = index - links - n
    kinds = len(plan.friction_kinds)
    in_friction = (friction >= 0) & (friction < n * kinds)
    friction_columns = tuple(
        np.flatnonzero(in_friction & (friction // n == kind)) for kind in range(kinds)
    )
    return _LagrangianGather(
        d_source=d_source,
        g_source=g_source,
        gravity_columns=gravity,
        gravity_source=pair[gravity] * 14 + 10 + (k[gravity] - 6),
        d_zero=np.flatnonzero(~is_link & ~rotor),
        g_zero=np.flatnonzero(~is_link & ~in_friction),
        rotor_columns=np.flatnonzero(rotor),
        rotor_joints=index[rotor] - links,
        friction_columns=friction_columns,
        friction_joints=tuple(friction[c] % n for c in friction_columns),
    )


def batch_lagrangian_mean_rows(
    plan: BatchRowsPlan,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    block: int,
    sign: SignLaw = EXACT_SIGN,
) -> np.ndarray:
    """Lagrangian model rows averaged over consecutive blocks of samples, packed.

    The rows of the modulated Lagrangian model (docs/MATH.md §3), per joint i::

        D_i = ∂h_E/∂v_i = S_iᵀ X_bᵀ K(V_b)                        (per link b)
        G_i = ∂h_U/∂q_i - ∂h_E/∂q_i + friction
            = S_iᵀ X_bᵀ K([0; -R_bᵀg]) - (ad(V^W_i) S_i)ᵀ X_bᵀ K(V_b) + [v_i, s(v_i), 1]

    (``core.rigid_body.lagrangian_blocks``; IAj: D_j += v_j), averaged over samples
    ``k·block .. (k+1)·block - 1`` and returned as ``pack_rows(D, G, τ)`` of the
    means, ``(N/block, 2np + n)``. The mean over a block is one matrix product per
    block, ``[S; ad(V^W) S]`` of its samples side by side times their
    ``X_bᵀ [K(V_b) | K([0; -g_b])]`` stacked: no per-sample rows are formed.
    Equal to ``RobotModel.mean_packed_rows``'s general path to round-off
    (tests/test_idim_base_rows.py).

    Args:
        plan: from :func:`batch_rows_plan`.
        q: (N, n) joint positions [rad, m], N a multiple of ``block``.
        v: (N, n) joint velocities [rad/s, m/s].
        tau: (N, n) joint torques [N·m, N].
        block: samples per mean.
        sign: the Coulomb law s(v) of the friction columns.
    """
    q = np.ascontiguousarray(q, dtype=float)
    v = np.ascontiguousarray(v, dtype=float)
    tau = np.ascontiguousarray(tau, dtype=float)
    num_samples, n = q.shape
    if block < 1 or num_samples % block:
        raise ValueError(
            "batch_lagrangian_mean_rows: the number of samples must be a multiple "
            f"of block >= 1; got {num_samples} samples, block {block}."
        )
    p = plan.num_parameters
    out = np.empty((num_samples // block, 2 * n * p + n))
    step = max(1, BLOCK // block) * block
    for start in range(0, num_samples, step):
        stop = min(start + step, num_samples)
        _lagrangian_block(
            plan,
            q[start:stop],
            v[start:stop],
            tau[start:stop],
            block,
            sign,
            out[start // block : stop // block],
        )
    return out
