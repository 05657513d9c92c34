"""Rigid-body regressor blocks of a fixed-base tree, exact and vectorised (numpy).

For link b with pose X_WB = (R, p), body-frame twist V_b = [ω; v_o] and the 6×10
momentum map K(V) (M(θ_b)·V = K(V)·θ_b, θ_b = [XX XY XZ YY YZ ZZ MX MY MZ M], see
:mod:`drake_dynid.core.kinematics`)::

    E_b = ½ V_bᵀ K(V_b) θ_b = ½ m v_o·v_o + (m c)·(v_o × ω) + ½ ωᵀ I_o ω      [J]
    U_b = -m g·p - g·(R m c)                                                 [J]

With world-frame joint screws S_i, J_b,i = Ad(X_WB⁻¹) S_i for every joint i on the
path of b, and the screw identity ∂S_j/∂q_i = ad(S_i) S_j (i ancestor of j)::

    ∂E_b/∂v_i = J_b,iᵀ K(V_b) θ_b
    ∂E_b/∂q_i = (Ad(X_WB⁻¹) ad(V_parent(i)) S_i)ᵀ K(V_b) θ_b
    ∂U_b/∂q_i = -J_b,iᵀ K([0; Rᵀg]) θ_b
    τ_i = Σ_b J_b,iᵀ [K(V̇_b - [0; Rᵀg]) - ad(V_b)ᵀ K(V_b)] θ_b      (Newton-Euler)

all exact (no finite differences; docs/MATH.md §2). The functions return the 10
inertial columns of every link: arrays ``(N, n_links, 10)`` for energies and
``(N, n, n_links, 10)`` for per-joint rows; :class:`drake_dynid.robot.RobotModel`
assembles them with the rotor and friction columns.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.core.kinematics import KinematicTree, ad

__all__ = ["energy_blocks", "idim_blocks", "lagrangian_blocks", "link_terms"]


def _frames(rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """Ad(X_WB⁻¹) = [[Rᵀ, 0], [-Rᵀ[p]×, Rᵀ]] of every link, (N, b, 6, 6)."""
    rt = np.swapaxes(rotation, -1, -2)
    out = np.zeros((*rotation.shape[:-2], 6, 6))
    out[..., :3, :3] = rt
    out[..., 3:, 3:] = rt
    # Column k of -Rᵀ[p]× is Rᵀ(e_k × p), r_k = Rᵀe_k.
    px, py, pz = position[..., 0, None], position[..., 1, None], position[..., 2, None]
    r0, r1, r2 = rt[..., 0], rt[..., 1], rt[..., 2]
    out[..., 3:, 0] = r2 * py - r1 * pz
    out[..., 3:, 1] = r0 * pz - r2 * px
    out[..., 3:, 2] = r1 * px - r0 * py
    return out


def _rotated_back(gravity: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Rᵀg = Σ_k g_k R[k, :] of every link, (N, b, 3), skipping the zero g_k.

    A stacked vector-matrix product costs a call per link; gravity usually has one
    nonzero component, so this is one or two array operations (the same sums).
    """
    out = None
    for k in np.flatnonzero(gravity):
        term = gravity[k] * rotation[..., k, :]
        out = term if out is None else out + term
    return np.zeros(rotation.shape[:-1]) if out is None else out


def link_terms(
    tree: KinematicTree,
    forward: tuple[np.ndarray, np.ndarray, np.ndarray],
    v: np.ndarray,
    gravity: np.ndarray,
    *,
    derivatives: bool = False,
    vdot: np.ndarray | None = None,
) -> dict[str, Any]:
    """Per-link spatial quantities shared by the rows.

    The rows are formed in the world frame, J_b,iᵀ F = S_iᵀ (Ad(X_WB⁻¹)ᵀ F): one
    product per link moves a link's 6×10 block to the world, one product per
    sample applies every screw to every link (masked by the ancestors).

    Args:
        tree: the kinematic tree.
        forward: ``tree.forward(q)``: link rotations (N, n, 3, 3), positions (N, n, 3)
            and world joint screws (N, n, 6).
        v: joint velocities (N, n) [rad/s, m/s].
        gravity: gravity in the world (3,) [m/s²].
        derivatives: also return ``dscrews`` = ad(V_parent(i)) S_i (world), the
            rate of the screw per unit velocity, needed by the Lagrangian and
            inverse-dynamics rows.
        vdot: joint accelerations (N, n) for the inverse-dynamics rows: also
            return (with ``dscrews``) ``acceleration``, the body-frame spatial
            acceleration of every link without gravity (N, b, 6), and
            ``adjoint`` = ad(V_b) (N, b, 6, 6), computed in the same products as
            the twist and K(V_b).

    Returns:
        dict with ``rotation``, ``position``, ``screws`` (N, i, 6), ``frames`` =
        Ad(X_WB⁻¹) (N, b, 6, 6), ``twist`` (body frame, N, b, 6), ``k`` = K(V_b)
        (N, b, 6, 10), ``gravity_body`` = Rᵀg (N, b, 3), ``plan`` (the tree's
        :class:`~drake_dynid.core.tree_plan.TreePlan`) and, with ``derivatives``,
        ``dscrews`` (N, i, 6).
    """
    rotation, position, screws = forward
    plan = tree.plan
    num_samples, n = v.shape
    frames = _frames(rotation, position)
    out: dict[str, Any] = {
        "rotation": rotation,
        "position": position,
        "screws": screws,
        "frames": frames,
        "gravity_body": _rotated_back(gravity, rotation),
        "plan": plan,
    }
    if not (derivatives or vdot is not None):
        twist_world = (plan.ancestors * v[:, None, :]) @ screws
        out["twist"] = twist = (frames @ twist_world[..., None])[..., 0]
        out["k"] = (twist @ plan.momentum).reshape(num_samples, n, 6, 10)
        return out
    # World twists of every link and of every joint's parent link, one product;
    # ∂S_j/∂q_i = ad(S_i) S_j: d/dt S_i = ad(V_parent(i)) S_i.
    masks = np.concatenate((plan.ancestors, plan.strict_ancestors))
    twists = (masks * v[:, None, :]) @ screws
    twist_world = twists[:, :n]
    out["dscrews"] = dscrews = ad(twists[:, n:], screws)
    if vdot is None:
        out["twist"] = twist = (frames @ twist_world[..., None])[..., 0]
        out["k"] = (twist @ plan.momentum).reshape(num_samples, n, 6, 10)
        return out
    # Body twist and acceleration (Σ_i S_i v̇_i + Ṡ_i v_i) in one product, and
    # K(V_b), ad(V_b) in another.
    rates = screws * vdot[..., None] + dscrews * v[..., None]
    body = frames @ np.stack((twist_world, plan.ancestors @ rates), axis=-1)
    out["twist"] = twist = body[..., 0]
    out["acceleration"] = body[..., 1]
    maps = twist @ np.concatenate((plan.momentum, plan.ad), axis=1)
    out["k"] = maps[..., :60].reshape(num_samples, n, 6, 10)
    out["adjoint"] = maps[..., 60:].reshape(num_samples, n, 6, 6)
    return out


def _joint_rows(terms: dict[str, Any], columns: np.ndarray, blocks: np.ndarray):
    """``rows[n, i, b, :] = columns[n, i]ᵀ Ad(X_WB⁻¹)ᵀ blocks[n, b]`` for i anc b.

    ``columns`` (N, r, 6) are world screws (r a multiple of the joints), ``blocks``
    (N, b, 6, w) body-frame blocks; returns (N, r, b, w), zero where joint i does
    not move link b.
    """
    num_samples, links, _, width = blocks.shape
    world = np.empty((num_samples, 6, links, width))  # Ad(X_WB⁻¹)ᵀ blocks, by row
    np.matmul(
        np.swapaxes(terms["frames"], -1, -2), blocks, out=world.transpose(0, 2, 1, 3)
    )
    rows = columns @ world.reshape(num_samples, 6, links * width)  # (N, r, b·w)
    # [i, (b, k)] = 1 where joint i moves link b: one 2-D mask for every sample.
    mask = np.repeat(terms["plan"].ancestors.T, width, axis=1)
    rows *= np.tile(mask, (columns.shape[1] // links, 1))
    return rows.reshape(num_samples, columns.shape[1], links, width)


def energy_blocks(
    terms: dict[str, Any], gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic and potential energy columns ``(h_E, h_U)``, (N, n_links, 10) [J]."""
    kinetic = 0.5 * np.einsum("nbs,nbsk->nbk", terms["twist"], terms["k"])
    potential = np.zeros_like(kinetic)
    potential[..., 6:9] = -terms["gravity_body"]
    potential[..., 9] = -(terms["position"] @ gravity)
    return kinetic, potential


def lagrangian_blocks(
    terms: dict[str, Any],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(∂h_E/∂v, ∂h_E/∂q, ∂h_U/∂q)``, each (N, n, n_links, 10).

    ``terms`` must come from :func:`link_terms` with ``derivatives=True``. One
    product ``[S | ad(V_parent) S]ᵀ Ad(X_WB⁻¹)ᵀ [K(V_b) | -K([0; Rᵀg])]`` gives
    all three.
    """
    screws = terms["screws"]
    n = screws.shape[1]
    gravity = -terms["gravity_body"] @ terms["plan"].momentum[3:]
    blocks = np.concatenate((terms["k"], gravity.reshape(terms["k"].shape)), axis=-1)
    rows = _joint_rows(
        terms, np.concatenate((screws, terms["dscrews"]), axis=1), blocks
    )
    return rows[:, :n, :, :10], rows[:, n:, :, :10], rows[:, :n, :, 10:]


def idim_blocks(terms: dict[str, Any], v: np.ndarray, vdot: np.ndarray) -> np.ndarray:
    """Inverse-dynamics columns τ_i = Σ_b rows[i, b]·θ_b, (N, n, n_links, 10) [N·m, N].

    ``terms`` must come from :func:`link_terms` with ``derivatives=True`` (or
    with ``vdot``: the accelerations and ad(V) it computed are used); gravity
    enters as the base acceleration -g.
    """
    plan = terms["plan"]
    screws = terms["screws"]
    num_samples, links = terms["twist"].shape[:2]
    if "acceleration" in terms:
        acceleration = terms["acceleration"].copy()
        adjoint = terms["adjoint"]
    else:
        rates = screws * vdot[..., None] + terms["dscrews"] * v[..., None]
        acceleration = (terms["frames"] @ (plan.ancestors @ rates)[..., None])[..., 0]
        adjoint = (terms["twist"] @ plan.ad).reshape(num_samples, links, 6, 6)
    acceleration[..., 3:] -= terms["gravity_body"]
    # K(V̇ - [0; Rᵀg]) - ad(V)ᵀ K(V): the link's Newton-Euler force per parameter.
    force = (acceleration @ plan.momentum).reshape(num_samples, links, 6, 10)
    force -= np.swapaxes(adjoint, -1, -2) @ terms["k"]
    return _joint_rows(terms, screws, force)
