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

from drake_dynid.core.kinematics import (
    KinematicTree,
    ad,
    ad_inverse,
    ad_transpose_momentum,
    momentum_matrix,
)

__all__ = ["energy_blocks", "idim_blocks", "lagrangian_blocks", "link_terms"]


def link_terms(
    tree: KinematicTree,
    forward: tuple[np.ndarray, np.ndarray, np.ndarray],
    v: np.ndarray,
    gravity: np.ndarray,
    *,
    derivatives: bool = False,
) -> dict[str, Any]:
    """Per-link spatial quantities shared by the rows.

    Args:
        tree: the kinematic tree.
        forward: ``tree.forward(q)``: link rotations (N, n, 3, 3), positions (N, n, 3)
            and world joint screws (N, n, 6).
        v: joint velocities (N, n) [rad/s, m/s].
        gravity: gravity in the world (3,) [m/s²].
        derivatives: also return ``dtwist`` = ∂V_b/∂q_i · (per unit v_i), needed by
            the Lagrangian and inverse-dynamics rows.

    Returns:
        dict with ``rotation``, ``position``, ``jac`` (N, b, i, 6), ``twist``
        (N, b, 6), ``k`` = K(V_b) (N, b, 6, 10), ``gravity_body`` (N, b, 3) and,
        with ``derivatives``, ``dtwist`` (N, b, i, 6).
    """
    rotation, position, screws = forward
    anc = tree.ancestors.astype(float)
    # World twists of the links and of each joint's parent link.
    twist_world = np.einsum("bi,nis,ni->nbs", anc, screws, v)
    parent_twist = np.zeros_like(screws)
    has_parent = tree.parent >= 0
    parent_twist[:, has_parent] = twist_world[:, tree.parent[has_parent]]
    # Body-frame Jacobians J[n, b, i] (zero unless i is an ancestor of b).
    jac = ad_inverse(rotation[:, :, None], position[:, :, None], screws[:, None, :, :])
    jac *= anc[None, :, :, None]
    twist = np.einsum("nbis,ni->nbs", jac, v)
    out: dict[str, Any] = {
        "rotation": rotation,
        "position": position,
        "jac": jac,
        "twist": twist,
        "k": momentum_matrix(twist),
        "gravity_body": np.einsum("nbji,j->nbi", rotation, gravity),
    }
    if derivatives:
        # ∂V_b/∂q_i = Ad(X_WB⁻¹) ad(V_parent(i)) S_i for i ancestor of b.
        dscrew = ad(parent_twist, screws)
        dtwist = ad_inverse(
            rotation[:, :, None], position[:, :, None], dscrew[:, None, :, :]
        )
        dtwist *= anc[None, :, :, None]
        out["dtwist"] = dtwist
    return out


def energy_blocks(
    terms: dict[str, Any], gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Kinetic and potential energy columns ``(h_E, h_U)``, (N, n_links, 10) [J]."""
    kinetic = 0.5 * np.einsum("nbs,nbsk->nbk", terms["twist"], terms["k"])
    potential = np.zeros_like(kinetic)
    potential[..., 6:9] = -terms["gravity_body"]
    potential[..., 9] = -np.einsum("nbi,i->nb", terms["position"], gravity)
    return kinetic, potential


def lagrangian_blocks(
    terms: dict[str, Any],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(∂h_E/∂v, ∂h_E/∂q, ∂h_U/∂q)``, each (N, n, n_links, 10).

    ``terms`` must come from :func:`link_terms` with ``derivatives=True``.
    """
    dhe_dv = np.einsum("nbis,nbsk->nibk", terms["jac"], terms["k"])
    dhe_dq = np.einsum("nbis,nbsk->nibk", terms["dtwist"], terms["k"])
    gravity_twist = np.zeros_like(terms["twist"])
    gravity_twist[..., 3:] = terms["gravity_body"]
    dhu_dq = -np.einsum("nbis,nbsk->nibk", terms["jac"], momentum_matrix(gravity_twist))
    return dhe_dv, dhe_dq, dhu_dq


def idim_blocks(terms: dict[str, Any], v: np.ndarray, vdot: np.ndarray) -> np.ndarray:
    """Inverse-dynamics columns τ_i = Σ_b rows[i, b]·θ_b, (N, n, n_links, 10) [N·m, N].

    ``terms`` must come from :func:`link_terms` with ``derivatives=True``; gravity
    enters as the base acceleration -g.
    """
    acceleration = np.einsum("nbis,ni->nbs", terms["jac"], vdot) + np.einsum(
        "nbis,ni->nbs", terms["dtwist"], v
    )
    acceleration[..., 3:] -= terms["gravity_body"]
    force = momentum_matrix(acceleration) + ad_transpose_momentum(
        terms["twist"], terms["k"]
    )
    return np.einsum("nbis,nbsk->nibk", terms["jac"], force)
