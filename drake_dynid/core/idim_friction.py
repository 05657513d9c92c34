"""The friction columns of the streamed off-line IDIM (``core.idim_stream``).

The columns ``FVj``, ``FCj``, ``OFFj`` of a row provider are v_j, s(v_j) and 1 in
joint j's row (s the provider's Coulomb law: the exact sign, or the standstill
dead zone of ``core.friction.DeadZoneSign``): cheap and, for s, discontinuous,
they go through the decimation at the full rate. A coupled motor k's Coulomb
column ``FCmk`` (``core.drive_columns``) is R_kᵀ s_m(x_k), one series of the
motor's velocity in joint units

    x_k = (R_k·v)/ρ_k,   ρ_k = max_j |R_kj|                       [rad/s or m/s]

spread over the joints' rows by the fixed weights R_kᵀ (s_m the motor's law, its
own dead-zone width): it goes through the decimation as one series too, and the
filters being linear, W[:, :, FCmk] = R_kᵀ ⊗ (filtered s_m(x_k)). The stream
indexes these series by *channel*: channel j < n is joint j's velocity v_j,
channel n + i motor i's x_i (:class:`MotorChannels`). :func:`friction_layout`
finds and checks the columns; :func:`friction_series` computes them from the
channels' velocities.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core.friction import EXACT_SIGN, SignLaw
from drake_dynid.core.planar2r import FRICTION_PREFIX

__all__ = [
    "FRICTION_KINDS",
    "FrictionLayout",
    "MotorChannels",
    "channel_velocities",
    "friction_layout",
    "friction_series",
    "signs_of",
]

FRICTION_KINDS = ("viscous", "coulomb", "offset")
"""Friction column kinds: v_j [rad/s or m/s], s(v_j), 1 (joint j's row)."""

RigidRows = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True, eq=False)
class MotorChannels:
    """The coupled motors' velocity channels x_i = (R_i·v)/ρ_i and their Coulomb law.

    Attributes:
        rows: (c, n) rows R_i of the coupling matrix (``MotorColumns.rows``).
        sign: their Coulomb law s_m, applied to the (N, c) x (a dead zone with one
            width per motor: ``robot_drive.motor_sign``).
    """

    rows: np.ndarray
    sign: SignLaw

    def velocities(self, v: np.ndarray) -> np.ndarray:
        """(N, c) x = (v @ Rᵀ)/ρ, ρ_i = max_j |R_ij|, as ``MotorColumns``'s sign."""
        return (v @ self.rows.T) / np.max(np.abs(self.rows), axis=1)


def channel_velocities(v: np.ndarray, channels: MotorChannels | None) -> np.ndarray:
    """(N, n + c) velocities of every channel: v, then the motors' x."""
    if channels is None:
        return v
    return np.concatenate([v, channels.velocities(v)], axis=1)


def signs_of(
    v: np.ndarray,
    friction: Sequence[tuple[str, int]],
    sign: SignLaw,
    channels: MotorChannels | None = None,
) -> np.ndarray | None:
    """Signs s of the (N, n [+ c]) channel velocities when a Coulomb column needs it.

    The joints' law ``sign`` on the first n, the motors' (``channels.sign``) on
    the others.
    """
    if not any(kind == "coulomb" for kind, _ in friction):
        return None
    if channels is None:
        return np.asarray(sign(v), dtype=float)
    n = v.shape[1] - channels.rows.shape[0]
    return np.concatenate(
        [
            np.asarray(sign(v[:, :n]), dtype=float),
            np.asarray(channels.sign(v[:, n:]), dtype=float),
        ],
        axis=1,
    )


def friction_series(
    v: np.ndarray,
    friction: Sequence[tuple[str, int]],
    sign: SignLaw,
    signs: np.ndarray | None = None,
) -> np.ndarray:
    """(N, len(friction)) friction columns: v_j, s(v_j) or 1 of each (kind, channel).

    ``v``: the (N, n [+ c]) channel velocities (:func:`channel_velocities`).
    ``sign`` is applied to the whole (N, n) joint velocity, as the models' rows do
    (``core.friction.friction_idim_columns``): a per-joint law (a dead zone with
    one width per joint, broadcast on the last axis) gives joint j its own width;
    ``signs``: s of every channel, computed already (:func:`signs_of`).
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


@dataclass(frozen=True, eq=False)
class FrictionLayout:
    """The friction columns a row provider's stream computes (:func:`friction_layout`).

    Model column ``columns[c]`` is ``weights[c]`` (its rows, (n,)) times the series
    ``friction[c]`` of a channel: e_j for joint j's own columns, R_kᵀ for a coupled
    motor's Coulomb column.

    Attributes:
        columns: the provider's column of each friction column.
        friction: (kind, channel) of each, the stream's columns
            (``core.idim_stream.decimated_chunks``): channel j < n is joint j,
            n + i motor i of ``channels``.
        weights: (F, n) their rows.
        rigid: the provider's other columns, in order (the rigid-body rows).
        channels: the coupled motors' channels; None without a motor column.
    """

    columns: tuple[int, ...]
    friction: tuple[tuple[str, int], ...]
    weights: np.ndarray
    rigid: tuple[int, ...]
    channels: MotorChannels | None = None

    def __len__(self) -> int:
        return len(self.columns)

    @classmethod
    def rows_only(cls, num_columns: int, num_joints: int) -> FrictionLayout:
        """No friction column split out: all ``num_columns`` from the rows."""
        return cls((), (), np.zeros((0, num_joints)), tuple(range(num_columns)))

    def place(self, F: np.ndarray) -> np.ndarray:
        """(R, n, F) model columns of (R, F) stream columns: F[:, c]·weights[c]."""
        return F[:, None, :] * self.weights.T[None, :, :]


def friction_layout(
    names: Sequence[str],
    idim_rows: RigidRows,
    num_joints: int,
    sign: SignLaw = EXACT_SIGN,
    motors: Any = None,
) -> FrictionLayout | None:
    """The friction columns of a row provider, checked (:class:`FrictionLayout`).

    A column named ``FVj``, ``FCj`` or ``OFFj`` (j = 1..n) is a friction column of
    joint j - 1 (:data:`~drake_dynid.core.planar2r.FRICTION_PREFIX`); ``FCmk`` is
    coupled motor k's Coulomb column when ``motors`` has motor k (either with a
    trailing ``R``: regrouped, the column is still that one). The provider's
    rows at seeded random states must hold ``v_j``, ``s(v_j)`` (``sign``, the
    provider's Coulomb law) or 1 in joint j's row and 0 in the others there, and
    R_kᵀ s_m(x_k) for ``FCmk`` (s_m the motors' law ``motors.sign``);
    otherwise None (the columns cannot be split). The states include velocities
    of 1e-9 [rad/s or m/s], so a Coulomb column whose law is not the one given (a
    dead zone or tanh given as the exact sign) is not split: it would be computed
    with the wrong law. So is a motor's Coulomb column without ``motors``: a
    Coulomb column left in the rows would be evaluated at the intermediate rate.
    A motor's viscous and offset columns (R_kᵀ R_k v, R_kᵀ) stay in the rows:
    smooth, as the rigid-body columns.

    Args:
        names: the p column names.
        idim_rows: ``idim_rows(q, v, v̇) -> (N, n, p)``.
        num_joints: n.
        sign: the provider's Coulomb sign law (``RobotModel.sign``).
        motors: the coupled motors' columns (``core.drive_columns.MotorColumns``,
            ``RobotModel.motor_columns``: ``rows``, ``numbers`` and their ``sign``,
            None for ``np.sign``), or None.
    """
    n = num_joints
    kinds = {prefix: kind for kind, prefix in FRICTION_PREFIX.items()}
    numbers = {} if motors is None else {k: i for i, k in enumerate(motors.numbers)}
    channels = None
    if numbers:
        law = EXACT_SIGN if motors.sign is None else motors.sign
        channels = MotorChannels(np.asarray(motors.rows, dtype=float), law)
    columns, friction, weights = [], [], []
    for column, name in enumerate(names):
        # A trailing R: a regrouped base parameter (another column's value added
        # to it, e.g. FCm4R = FCm4 + FCm5 of two motors on the same row, opposite
        # ways); its column is the independent one's, which the check below reads.
        joint = re.fullmatch(r"(FV|FC|OFF)([1-9][0-9]*)R?", name)
        motor = re.fullmatch(r"FCm([1-9][0-9]*)R?", name)
        if joint and int(joint[2]) <= n:
            columns.append(column)
            friction.append((kinds[joint[1]], int(joint[2]) - 1))
            weights.append(np.eye(n)[int(joint[2]) - 1])
        elif motor and int(motor[1]) in numbers:
            i = numbers[int(motor[1])]
            columns.append(column)
            friction.append(("coulomb", n + i))
            assert channels is not None
            weights.append(channels.rows[i])
        elif name.startswith("FCm"):
            return None  # a motor's Coulomb column this cannot compute
    rigid = tuple(c for c in range(len(names)) if c not in set(columns))
    layout = FrictionLayout(
        tuple(columns),
        tuple(friction),
        np.array(weights, dtype=float).reshape(len(columns), n),
        rigid,
        channels if any(c >= n for _, c in friction) else None,
    )
    if not columns:
        return layout
    rng = np.random.default_rng(20150)
    q, v, vdot = rng.normal(size=(3, 4, n))
    v[0] *= 1e-9  # near standstill: tells sign(v) from other sign laws
    rows_at = np.asarray(idim_rows(q, v, vdot), dtype=float)
    x = channel_velocities(v, layout.channels)
    values = friction_series(
        x, friction, sign, signs_of(x, friction, sign, layout.channels)
    )
    expected = layout.place(values)
    if not np.allclose(rows_at[:, :, list(columns)], expected, rtol=1e-12, atol=1e-12):
        return None
    return layout
