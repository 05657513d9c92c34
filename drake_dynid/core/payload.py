r"""Payload identification on a known arm: the rows of the load's 10 parameters.

A payload rigidly attached to link L (its frame: the child body of L's joint,
docs/CONVENTIONS.md §4) through a frame F adds its 10 standard inertial parameters
to L's. In F (docs/PAYLOAD.md §1)::

    θ_F = [XX XY XZ YY YZ ZZ MX MY MZ M]_F
        (inertia tensor about F's origin in F's axes [kg·m²] (XY = -∫xy dm),
         first moments m·c_F [kg·m], mass m [kg])

and, with F's pose in L (rotation R_LF, origin p = p_LF [m]), the link gains
θ_L = Φ θ_F (:func:`payload_transform`, linear in θ_F)::

    m_L = m
    h_L = R h_F + m p                                           (h = m·c)
    I_L = R I_F Rᵀ + m (|p|² 1 - p pᵀ) + 2 (pᵀ R h_F) 1 - p (R h_F)ᵀ - (R h_F) pᵀ

(the parallel-axis theorem between two points, neither of which is the centre of
mass: for a point mass at r_F it is m(|s|² 1 - s sᵀ) with s = p + R r_F).

Every regressor of the arm is linear in the standard parameters, so the payload's
columns are the link's 10 standard columns times Φ: W_F = W_L Φ. With the arm's
base parameters θ_arm known (a previous identification, or the URDF's values),
the Lagrangian rows of docs/CONVENTIONS.md §3 split into the payload's columns and
one **known column** whose coefficient is 1::

    d/dt(D_F θ_F + D_arm θ_arm) + (G_F θ_F + G_arm θ_arm) = τ

:class:`PayloadRows` is a row provider (``core.rows.RowProvider``) with the
payload's identifiable columns followed by the known column (D_arm θ_arm,
G_arm θ_arm: inertia, gravity and friction of the arm), so the filters, the raw
rows and the modulating bank run unchanged; the identifier moves the known
column to the right-hand side (:func:`eliminate_known`: B' = B - A[:, -1]) and
solves only the payload's parameters (``core.payload_step``).

**The arm's error.** When θ_arm comes with a covariance Σ_arm (a previous
identification's, ``dynid offline/identify --json``), :func:`payload_rows` factors it,
Σ_arm = L Lᵀ (:func:`arm_factor`, L: p_arm × k), and the provider carries k more
columns between the payload's and the known one: D_arm L, G_arm L, the arm's
rows along L's columns. The bank integrates them as any column, so each window
holds K_L, the rows of the known column's error δK = K_L z (z ~ N(0, 1_k)), and
the solve adds its image to the payload's covariance (``core.payload_noise``:
Cov_θ += G K_L K_Lᵀ Gᵀ, G the window's solve operator; docs/PAYLOAD.md §4).

Identifiable parameters: the joints below L see only some combinations of θ_F
(planar motion without gravity: ZZ, MX, MY and, through the joint before, M).
:func:`payload_rows` reduces the 10 columns W_L Φ at seeded random states with the
library's rank decision (``core.base_parameters``): the payload's base parameters
(``names``; e.g. ``XXR = XX - YY`` about a last joint's axis, where only the
difference acts). A payload base parameter that the motion of a window does not
excite gets a large σ (flagged at %σ > 30) or a rank-deficient window.

Pure numpy; the robot is any object with ``num_joints``, ``standard_names``,
``base`` and the row methods of ``drake_dynid.robot.RobotModel``
(``lagrangian_rows``, ``energy_rows``, ``idim_rows`` with ``columns=``, and
``model_rows``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.base_parameters import BaseParameters, base_parameters
from drake_dynid.core.rows import check_model_kind

__all__ = [
    "ARM_COLUMN",
    "KNOWN_COLUMN",
    "PAYLOAD_NAMES",
    "PayloadRows",
    "arm_factor",
    "eliminate_known",
    "payload_parameters",
    "payload_rows",
    "payload_transform",
    "shift_parameters",
]

#: The payload's standard parameters in F, in Khalil's order (docs/CONVENTIONS.md §4).
PAYLOAD_NAMES = ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")

#: Name of the known column (the arm's D θ_arm, G θ_arm; its coefficient is 1).
KNOWN_COLUMN = "arm"

#: Prefix of the names of the arm's error columns (``arm_error0``, ...).
ARM_COLUMN = "arm_error"

_SYMMETRIC = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _tensor(theta: np.ndarray) -> np.ndarray:
    """(..., 10) -> the (..., 3, 3) inertia tensors of the first 6 entries."""
    out = np.empty((*theta.shape[:-1], 3, 3))
    for k, (i, j) in enumerate(_SYMMETRIC):
        out[..., i, j] = out[..., j, i] = theta[..., k]
    return out


def _pose(owner: str, rotation: Any, translation: Any) -> tuple[np.ndarray, ...]:
    r = check.array(owner, "rotation", rotation, (3, 3))
    p = check.array(owner, "translation", translation, (3,))
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-9) or np.linalg.det(r) < 0.0:
        check.fail(
            owner,
            "rotation must be a rotation matrix (R Rᵀ = 1 within 1e-9, det +1); got "
            f"R Rᵀ - 1 up to {np.abs(r @ r.T - np.eye(3)).max():.3g}, det "
            f"{np.linalg.det(r):.3g}.",
        )
    return r, p


def shift_parameters(theta: Any, rotation: Any, translation: Any) -> np.ndarray:
    """The standard parameters of a body expressed in F, re-expressed in L.

    θ_L = Φ θ_F of the module docstring (moving the reference point from F's
    origin to L's and rotating the axes), for ``theta`` of shape (..., 10).

    Args:
        theta: (..., 10) ``PAYLOAD_NAMES`` about F's origin, in F [kg·m², kg·m, kg].
        rotation: R_LF (3, 3), F's axes in L.
        translation: p_LF (3,), F's origin in L [m].
    """
    owner = "shift_parameters"
    r, p = _pose(owner, rotation, translation)
    theta = check.array(owner, "theta", theta)
    if theta.ndim < 1 or theta.shape[-1] != 10:
        check.fail(owner, f"theta must have shape (..., 10); got {theta.shape}.")
    mass = theta[..., 9]
    first = theta[..., 6:9] @ r.T  # R h_F
    inertia = r @ _tensor(theta) @ r.T
    inertia += mass[..., None, None] * (p @ p * np.eye(3) - np.outer(p, p))
    cross = first @ p
    inertia += 2.0 * cross[..., None, None] * np.eye(3)
    inertia -= p[:, None] * first[..., None, :] + first[..., :, None] * p[None, :]
    out = np.empty_like(theta)
    for k, (i, j) in enumerate(_SYMMETRIC):
        out[..., k] = inertia[..., i, j]
    out[..., 6:9] = first + mass[..., None] * p
    out[..., 9] = mass
    return out


def payload_transform(rotation: Any, translation: Any) -> np.ndarray:
    """Φ (10, 10): θ_L = Φ θ_F for a body attached through the frame F.

    Columns: :func:`shift_parameters` of the unit vectors. The payload's regressor
    columns are ``W_L @ Φ`` (W_L: the link's 10 standard columns).
    """
    r, p = _pose("payload_transform", rotation, translation)
    out = shift_parameters(np.eye(10), r, p).T
    out.flags.writeable = False
    return out


def payload_parameters(mass: float, com: Any, inertia: Any) -> np.ndarray:
    """θ_F (10,) of a rigid body from its mass, centre of mass and central inertia.

    Args:
        mass: m > 0 [kg].
        com: c (3,), the centre of mass in F [m].
        inertia: (3, 3) symmetric inertia tensor about the centre of mass, in F's
            axes [kg·m²].

    Returns:
        ``PAYLOAD_NAMES`` about F's origin: I_F = I_c + m(|c|² 1 - c cᵀ), h = m c.
    """
    owner = "payload_parameters"
    m = check.positive(owner, "mass", mass, "kg")
    c = check.array(owner, "com", com, (3,))
    i_c = check.array(owner, "inertia", inertia, (3, 3))
    if not np.allclose(i_c, i_c.T, atol=1e-12 * max(1.0, np.abs(i_c).max())):
        check.fail(owner, "inertia must be symmetric [kg·m²].")
    tensor = i_c + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([*(tensor[i, j] for i, j in _SYMMETRIC), *(m * c), m])


def eliminate_known(A: Any, B: Any) -> tuple[np.ndarray, np.ndarray]:
    """Moves the known column (the last one, coefficient 1) to the right-hand side.

    ``A [θ; 1] = B``  ->  ``A[:, :-1] θ = B - A[:, -1]``; A (r, p + 1), B (r,).
    """
    a = np.asarray(A, dtype=float)
    b = np.asarray(B, dtype=float)
    if a.ndim != 2 or a.shape[1] < 2 or b.shape != (a.shape[0],):
        check.fail(
            "eliminate_known",
            f"A must have shape (r, p + 1) with p >= 1 and B (r,); got A {a.shape}, "
            f"B {b.shape}.",
        )
    return a[:, :-1], b - a[:, -1]


def arm_factor(covariance: Any, num_parameters: int) -> np.ndarray:
    """L (p_arm, k) with L Lᵀ = Σ_arm: the arm's error columns (module docstring).

    From the eigen decomposition Σ = V diag(λ) Vᵀ: L = V_k diag(√λ_k) over the k
    eigenvalues above 1e-12 λ_max (the others carry no variance). Units: those
    of the arm's base parameters.

    Args:
        covariance: Σ_arm (p_arm, p_arm), symmetric positive semi-definite
            (within 1e-9 of its largest entry) [units of θ_arm, squared].
        num_parameters: p_arm.

    Raises:
        ValueError: a wrong shape, a non-finite entry, an asymmetric matrix or a
            negative eigenvalue beyond round-off.
    """
    owner = "arm_factor"
    p = int(num_parameters)
    sigma = check.array(owner, "covariance", covariance, (p, p))
    scale = float(np.abs(sigma).max()) if sigma.size else 0.0
    if not np.allclose(sigma, sigma.T, rtol=0.0, atol=1e-9 * scale):
        check.fail(
            owner,
            "covariance must be symmetric; got entries apart by up to "
            f"{np.abs(sigma - sigma.T).max():.3g} [parameter units²].",
        )
    values, vectors = np.linalg.eigh(0.5 * (sigma + sigma.T))
    top = float(values.max()) if values.size else 0.0
    if values.size and values.min() < -1e-9 * max(top, scale):
        check.fail(
            owner,
            "covariance must be positive semi-definite; got the eigenvalue "
            f"{values.min():.3g} (largest {top:.3g}).",
        )
    keep = values > 1e-12 * top if top > 0.0 else np.zeros(values.shape, bool)
    out = vectors[:, keep] * np.sqrt(values[keep])
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class PayloadRows:
    """Row provider of a payload on a known arm (module docstring).

    Build it with :func:`payload_rows`. ``model_rows(kind, q, v, tau)`` returns
    the (D, G, y) of docs/CONVENTIONS.md §3 with ``num_parameters`` = p_F + k + 1
    columns: the payload's base parameters (``payload_names``), the k arm's
    error columns (``arm_factor``, k = 0 without the arm's covariance), then the
    known column :data:`KNOWN_COLUMN` (coefficient 1).

    Attributes:
        robot: the arm (a ``drake_dynid.RobotModel``).
        link: index of the carrying link (0-based; its standard names end with
            ``link + 1``).
        link_name: the joint that moves the carrying link.
        frame_name: the attachment frame F ("" for the link's own frame).
        columns: (10,) the link's standard columns, in ``PAYLOAD_NAMES`` order.
        transform: Φ (10, 10), θ_L = Φ θ_F.
        rotation: R_LF (3, 3); translation: p_LF (3,) [m].
        arm: (p_arm,) the arm's known base parameters (``robot.base.names``).
        base: the payload's base parameters (reduction of ``W_L Φ``).
        arm_factor: (p_arm, k) L, Σ_arm = L Lᵀ (:func:`arm_factor`), or None: the
            arm taken as exact (k = 0).
    """

    robot: Any
    link: int
    link_name: str
    frame_name: str
    columns: tuple[int, ...]
    transform: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    arm: np.ndarray
    base: BaseParameters
    arm_factor: np.ndarray | None = None

    @property
    def num_joints(self) -> int:
        """n, the arm's identified joints."""
        return int(self.robot.num_joints)

    @property
    def num_payload(self) -> int:
        """p_F, the payload's base parameters."""
        return len(self.base.names)

    @property
    def num_arm_columns(self) -> int:
        """k, the arm's error columns (0 without the arm's covariance)."""
        return 0 if self.arm_factor is None else int(self.arm_factor.shape[1])

    @property
    def num_parameters(self) -> int:
        """p_F + k + 1: the payload's, the arm's error and the known columns."""
        return self.num_payload + self.num_arm_columns + 1

    @property
    def payload_names(self) -> tuple[str, ...]:
        """The payload's base parameter names (``base.names``)."""
        return tuple(self.base.names)

    @property
    def names(self) -> tuple[str, ...]:
        """Column names: ``payload_names``, the arm's error columns, the known one."""
        errors = tuple(f"{ARM_COLUMN}{k}" for k in range(self.num_arm_columns))
        return (*self.base.names, *errors, KNOWN_COLUMN)

    def _payload(self, standard: np.ndarray) -> np.ndarray:
        """Standard-column rows (..., p_std) -> the payload's base columns."""
        rows = standard[..., list(self.columns)] @ self.transform
        return rows[..., list(self.base.independent)]

    def idim_rows(self, q: Any, v: Any, vdot: Any) -> np.ndarray:
        """Inverse-dynamics rows of the payload's base parameters, (N, n, p_F).

        τ = W_arm θ_arm + ``idim_rows`` · θ_F,base [N·m, N] (no friction: the
        payload adds none).
        """
        return self._payload(self.robot.idim_rows(q, v, vdot, columns="standard"))

    def model_rows(
        self, kind: str, q: Any, v: Any, tau: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(D, G, y): the payload's columns, the arm's error columns, the known one.

        Lagrangian: D = [∂h_E/∂v·Φ, (∂h_E/∂v)_arm θ_arm], G = [(∂h_U/∂q -
        ∂h_E/∂q)·Φ, G_arm θ_arm] (G_arm with the arm's friction), y = τ. Power:
        D = [h·Φ, h_arm θ_arm], G = [0, friction power θ_arm], y = vᵀτ. Batch
        shapes of ``RobotModel.model_rows``; (n,) inputs drop the sample axis.
        The arm's error columns are D_arm L and G_arm L (``arm_factor``).
        """
        kind = check_model_kind("PayloadRows", kind)
        d_arm, g_arm, y = self.robot.model_rows(kind, q, v, tau)
        known_d = d_arm @ self.arm
        known_g = g_arm @ self.arm
        if kind == "lagrangian":
            dhe_dv, dhe_dq, dhu_dq = self.robot.lagrangian_rows(
                q, v, columns="standard"
            )
            d_rows = self._payload(dhe_dv)
            g_rows = self._payload(dhu_dq) - self._payload(dhe_dq)
        else:
            d_rows = self._payload(self.robot.energy_rows(q, v, columns="standard"))
            d_rows = d_rows[..., None, :]
            g_rows = np.zeros_like(d_rows)
        factor = (
            self.arm_factor
            if self.arm_factor is not None
            else np.zeros((self.arm.size, 0))
        )
        return (
            np.concatenate([d_rows, d_arm @ factor, known_d[..., None]], axis=-1),
            np.concatenate([g_rows, g_arm @ factor, known_g[..., None]], axis=-1),
            y,
        )


def _link_columns(robot: Any, link: int) -> tuple[int, ...]:
    names = tuple(robot.standard_names)
    wanted = [f"{name}{link + 1}" for name in PAYLOAD_NAMES]
    missing = [name for name in wanted if name not in names]
    if missing:
        check.fail(
            "payload_rows",
            f"link must be a moving link of the robot (0 .. {robot.num_links - 1}); "
            f"got {link} (no standard parameter {missing[0]}).",
        )
    return tuple(names.index(name) for name in wanted)


def payload_rows(
    robot: Any,
    link: int | None = None,
    *,
    rotation: Any = None,
    translation: Any = None,
    arm: Any = None,
    arm_covariance: Any = None,
    frame_name: str = "",
    seed: int = 0,
) -> PayloadRows:
    """The row provider of a payload attached to ``link`` of a known arm.

    The payload's base parameters come from the 10 columns W_L Φ of the
    inverse-dynamics rows (gravity included) at ``max(20, 40/n)`` seeded random
    states (q uniform in ±π rad, q̇ and q̈ standard normal; the robot's own
    reduction uses the same), reduced by ``core.base_parameters``.

    Args:
        robot: the arm (``drake_dynid.RobotModel``).
        link: the carrying link, 0-based (default: the last identified link,
            n - 1).
        rotation: R_LF (3, 3) of the attachment frame F in the link's frame
            (default identity).
        translation: p_LF (3,) [m] (default 0).
        arm: (p_arm,) the arm's base parameters (default ``robot.base_values``,
            the URDF's values).
        arm_covariance: (p_arm, p_arm) the covariance of ``arm`` [units of
            θ_arm, squared], or None: the arm taken as exact. Given, the rows
            carry the arm's error columns (:func:`arm_factor`) and the payload's
            σ holds that error (docs/PAYLOAD.md §4).
        frame_name: a name for F in reports.
        seed: seed of the random states of the reduction.

    Raises:
        ValueError: a link out of range, a non-rotation, an ``arm`` of the wrong
            size or not finite, an ``arm_covariance`` that is no covariance of
            it, or a payload that the joints cannot see at all.
    """
    owner = "payload_rows"
    check.having(
        owner,
        "robot",
        robot,
        ("num_joints", "standard_names", "base", "idim_rows", "model_rows"),
        "a RobotModel",
    )
    n = int(robot.num_joints)
    link = n - 1 if link is None else check.integer(owner, "link", link, 0)
    columns = _link_columns(robot, link)
    r, p = _pose(
        owner,
        np.eye(3) if rotation is None else rotation,
        np.zeros(3) if translation is None else translation,
    )
    p_arm = len(robot.base.names)
    theta_arm = np.array(
        robot.base_values if arm is None else check.array(owner, "arm", arm, (p_arm,)),
        dtype=float,
    )
    factor = None if arm_covariance is None else arm_factor(arm_covariance, p_arm)
    transform = payload_transform(r, p)
    rng = np.random.default_rng(seed)
    count = max(20, -(-40 // n))
    q = rng.uniform(-np.pi, np.pi, (count, n))
    prismatic = getattr(robot, "prismatic", (False,) * n)
    for j in np.flatnonzero(prismatic):
        q[:, j] = rng.uniform(-1.0, 1.0, count)
    v, vdot = rng.normal(size=(2, count, n))
    standard = robot.idim_rows(q, v, vdot, columns="standard")
    rows = (standard[..., list(columns)] @ transform).reshape(-1, 10)
    if not np.any(rows):
        check.fail(
            owner,
            f"the joints do not see a payload on link {link} (every column of its "
            "parameters is zero); choose another link.",
        )
    base = base_parameters(rows, PAYLOAD_NAMES)
    links = tuple(getattr(robot, "links", robot.joint_names))
    theta_arm.flags.writeable = False
    r.flags.writeable = False
    p.flags.writeable = False
    return PayloadRows(
        robot=robot,
        link=link,
        link_name=str(links[link]) if link < len(links) else str(link),
        frame_name=str(frame_name),
        columns=columns,
        transform=transform,
        rotation=r,
        translation=p,
        arm=theta_arm,
        base=base,
        arm_factor=factor,
    )
