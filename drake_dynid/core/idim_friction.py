"""The friction columns of the streamed off-line IDIM (``core.idim_stream``).

The columns ``FVj``, ``FCj``, ``OFFj`` of a row provider are v_j, s(v_j) and 1 in
joint j's row (s the provider's Coulomb law: the exact sign, or the standstill
dead zone of ``core.friction.DeadZoneSign``): cheap and, for s, discontinuous,
they go through the decimation at the full rate. :func:`friction_layout` finds
and checks them; :func:`friction_series` computes them from the velocities.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

import numpy as np

from drake_dynid.core.friction import EXACT_SIGN, SignLaw
from drake_dynid.core.planar2r import FRICTION_PREFIX

__all__ = [
    "FRICTION_KINDS",
    "friction_layout",
    "friction_series",
    "signs_of",
    "split_layout",
]

FRICTION_KINDS = ("viscous", "coulomb", "offset")
"""Friction column kinds: v_j [rad/s or m/s], s(v_j), 1 (joint j's row)."""

RigidRows = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def signs_of(
    v: np.ndarray, friction: Sequence[tuple[str, int]], sign: SignLaw
) -> np.ndarray | None:
    """s(v) of the whole (N, n) velocity when a Coulomb column needs it."""
    if any(kind == "coulomb" for kind, _ in friction):
        return np.asarray(sign(v), dtype=float)
    return None


def friction_series(
    v: np.ndarray,
    friction: Sequence[tuple[str, int]],
    sign: SignLaw,
    signs: np.ndarray | None = None,
) -> np.ndarray:
    """(N, len(friction)) friction columns: v_j, s(v_j) or 1.

    ``sign`` is applied to the whole (N, n) velocity, as the models' rows do
    (``core.friction.friction_idim_columns``): a per-joint law (a dead zone with
    one width per joint, broadcast on the last axis) gives joint j its own width.
    """
    out = np.empty((v.shape[0], len(friction)))
    if signs is None:
        signs = signs_of(v, friction, sign)
    for c, (kind, joint) in enumerate(friction):
        if kind == "viscous":
            out[:, c] = v[:, joint]
        elif kind == "coulomb":
            assert signs is not None
            out[:, c] = signs[:, joint]
        else:
            out[:, c] = 1.0
    return out


def friction_layout(
    names: Sequence[str],
    idim_rows: RigidRows,
    num_joints: int,
    sign: SignLaw = EXACT_SIGN,
) -> tuple[tuple[int, str, int], ...] | None:
    """The friction columns of a row provider: (column, kind, joint) each, checked.

    A column named ``FVj``, ``FCj`` or ``OFFj`` (j = 1..n) is a friction column of
    joint j - 1 (:data:`~drake_dynid.core.planar2r.FRICTION_PREFIX`). The provider's
    rows at seeded random states must hold ``v_j``, ``s(v_j)`` (``sign``, the
    provider's Coulomb law) or 1 in joint j's row and 0 in the others there;
    otherwise None (the columns cannot be split). The states include velocities
    of 1e-9 [rad/s or m/s], so a Coulomb column whose law is not ``sign`` (a dead
    zone or tanh given as the exact sign) is not split: it would be computed with
    the wrong law. A motor friction column (``FVmk``, ``FCmk``, ``OFFmk``: a
    coupled motor's friction, spread over several joints' rows) gives None too:
    nonlinear in v, it must not be evaluated at the intermediate rate.

    Args:
        names: the p column names.
        idim_rows: ``idim_rows(q, v, v̇) -> (N, n, p)``.
        num_joints: n.
        sign: the provider's Coulomb sign law (``RobotModel.sign``).
    """
    kinds = {prefix: kind for kind, prefix in FRICTION_PREFIX.items()}
    if any(re.fullmatch(r"(FV|FC|OFF)m[0-9]+", name) for name in names):
        return None
    layout = []
    for column, name in enumerate(names):
        match = re.fullmatch(r"(FV|FC|OFF)([1-9][0-9]*)", name)
        if match and int(match[2]) <= num_joints:
            layout.append((column, kinds[match[1]], int(match[2]) - 1))
    if not layout:
        return ()
    rng = np.random.default_rng(20150)
    q, v, vdot = rng.normal(size=(3, 4, num_joints))
    v[0] *= 1e-9  # near standstill: tells sign(v) from other sign laws
    rows = np.asarray(idim_rows(q, v, vdot), dtype=float)
    values = friction_series(v, [(kind, joint) for _, kind, joint in layout], sign)
    for c, (column, _, joint) in enumerate(layout):
        expected = np.zeros((4, num_joints))
        expected[:, joint] = values[:, c]
        if not np.allclose(rows[:, :, column], expected, rtol=1e-12, atol=1e-12):
            return None
    return tuple(layout)


def split_layout(
    layout: Sequence[tuple[int, str, int]], num_columns: int
) -> tuple[list[tuple[str, int]], list[int]]:
    """``(friction, rigid)`` of a :func:`friction_layout`: the stream's columns.

    ``friction``: (kind, joint) of each friction column, in the layout's order
    (``core.idim_stream.decimated_chunks``); ``rigid``: the other columns of the
    ``num_columns``, in order (the rigid-body rows the stream evaluates).
    """
    split = {column for column, _, _ in layout}
    return (
        [(kind, joint) for _, kind, joint in layout],
        [c for c in range(num_columns) if c not in split],
    )
