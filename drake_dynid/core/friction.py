"""Joint friction: kinds, parameter names, regressor columns and the applied force.

The one place that spells out the friction law (docs/MATH.md §2). Per joint j::

    τ_f,j = FV_j v_j + FC_j s(v_j) + OFF_j                         [N·m or N]

with ``s`` the Coulomb sign function, a pluggable :class:`SignLaw`:

* :class:`ExactSign`, ``s(v) = sign(v)``: the identification models (the paper's);
* :class:`TanhSign`, ``s(v) = tanh(v/width)``: the simulated friction (a discrete
  plant chatters around v = 0 with an exact sign);
* :class:`DeadZoneSign`, ``s(v) = 0`` for ``|v| <= width``, else ``sign(v)``: the
  standstill treatment of real logs (docs/MATH.md §2: the width follows from the
  velocity noise measured on the log, ``drake_dynid.core.standstill``).

Every consumer reads the law from here: the inverse-dynamics (IDIM) and Lagrangian
rows take the columns ``[v_j, s(v_j), 1]`` (:func:`friction_idim_columns`), the power
model the dissipated power ``[v_j², v_j s(v_j), v_j]`` (:func:`friction_power_columns`;
``v s(v) = |v|`` for the exact sign), the single-sample fast path of the 2R rows
:func:`friction_value`, and the simulated ``JointFriction`` block
:func:`friction_force` / :func:`friction_force_scalar`.

Adding a friction law: a new Coulomb shape (e.g. a standstill dead zone, s(v) = 0
for |v| < v0) is a new :class:`SignLaw` (a vectorised ``__call__`` and a ``scalar``
method) passed as ``sign=``; a new column kind is one entry in
:data:`FRICTION_KINDS`, :data:`FRICTION_PREFIX` and :func:`friction_column`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from drake_dynid.core import _validate

__all__ = [
    "DEFAULT_FRICTION",
    "EXACT_SIGN",
    "FRICTION_KINDS",
    "FRICTION_PREFIX",
    "DeadZoneSign",
    "ExactSign",
    "SignLaw",
    "TanhSign",
    "check_coulomb_width",
    "check_friction",
    "friction_coefficients",
    "friction_column",
    "friction_force",
    "friction_force_scalar",
    "friction_idim_columns",
    "friction_names",
    "friction_power_columns",
    "friction_value",
    "sign_law",
]

#: Friction kinds in column order, with the column prefix of each.
FRICTION_KINDS = ("viscous", "coulomb", "offset")
FRICTION_PREFIX = MappingProxyType({"viscous": "FV", "coulomb": "FC", "offset": "OFF"})

#: The paper's friction columns (viscous + Coulomb per joint).
DEFAULT_FRICTION = ("viscous", "coulomb")


@runtime_checkable
class SignLaw(Protocol):
    """The Coulomb sign function s(v) of the friction law (dimensionless).

    ``__call__`` is vectorised over arrays; ``scalar`` evaluates one float (the
    per-step fast paths of the blocks). Both must give the same numbers.
    """

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """s(v) elementwise."""
        ...

    def scalar(self, v: float) -> float:
        """s(v) of one velocity."""
        ...


@dataclass(frozen=True)
class ExactSign:
    """``s(v) = sign(v)`` (0 at v = 0, NaN for NaN): the identification models."""

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """sign(v) elementwise."""
        return np.sign(v)

    def scalar(self, v: float) -> float:
        """sign(v) of one velocity, without numpy's per-call overhead."""
        if v > 0.0:
            return 1.0
        if v < 0.0:
            return -1.0
        return 0.0 if v == 0.0 else math.nan


@dataclass(frozen=True)
class TanhSign:
    """``s(v) = tanh(v / width)``, width > 0 [rad/s or m/s]: a smooth Coulomb law.

    Used by the simulated friction: with a discrete plant an exact sign makes the
    velocity chatter around zero; the difference to sign(v) is confined to
    |v| ≲ 3·width.
    """

    width: float

    def __post_init__(self) -> None:
        _validate.positive("TanhSign", "width", self.width, "rad/s or m/s")

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """tanh(v/width) elementwise."""
        return np.tanh(v / self.width)

    def scalar(self, v: float) -> float:
        """tanh(v/width) of one velocity."""
        return math.tanh(v / self.width)


@dataclass(frozen=True)
class DeadZoneSign:
    """``s(v) = 0`` for ``|v| <= width``, else ``sign(v)`` (NaN for NaN).

    The standstill treatment of the Coulomb columns (docs/MATH.md §2): at rest the
    estimated velocity is noise and ``sign`` of it is ±1 noise; inside the dead
    zone the Coulomb column is 0 (static friction is not modelled).

    Attributes:
        width: the half-width [rad/s or m/s], >= 0: one number for every joint, or
            a tuple with one width per column of the velocities it is applied to
            (broadcast on the last axis). Only a scalar width has a ``scalar``
            form.
    """

    width: float | tuple[float, ...]

    def __post_init__(self) -> None:
        width = np.asarray(self.width, dtype=float)
        if width.ndim > 1 or not np.all(np.isfinite(width)) or np.any(width < 0.0):
            raise ValueError(
                "DeadZoneSign: width must be a finite number >= 0 [rad/s or m/s] or "
                f"a 1-D sequence of them; got {self.width!r}."
            )
        value = float(width) if width.ndim == 0 else tuple(width.tolist())
        object.__setattr__(self, "width", value)

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """0 inside the zone, sign(v) outside, elementwise."""
        v = np.asarray(v, dtype=float)
        return np.where(np.abs(v) <= np.asarray(self.width), 0.0, np.sign(v))

    def scalar(self, v: float) -> float:
        """s(v) of one velocity (scalar width only)."""
        if not isinstance(self.width, float):
            raise TypeError(
                "DeadZoneSign: a per-joint width has no scalar form; call it on "
                "an array of velocities."
            )
        if abs(v) <= self.width:
            return 0.0
        return EXACT_SIGN.scalar(v)


#: The exact sign shared by the identification models.
EXACT_SIGN = ExactSign()


def sign_law(smoothing: float) -> SignLaw:
    """:class:`TanhSign` of width ``smoothing`` when > 0, else :data:`EXACT_SIGN`."""
    return TanhSign(smoothing) if smoothing > 0.0 else EXACT_SIGN


def check_coulomb_width(owner: str, width: Any) -> float:
    """A Coulomb width ε >= 0 [rad/s or m/s] as a float, or raises.

    ε is the width of the smooth Coulomb law ``s(v) = tanh(v/ε)`` of a model's
    friction columns; 0 means the exact sign (:func:`sign_law`).
    """
    width = _validate.real(owner, "coulomb_width", width, "rad/s or m/s")
    if not width >= 0.0:
        raise ValueError(
            f"{owner}: coulomb_width must be >= 0 [rad/s or m/s] (0: exact sign); "
            f"got {width:g}."
        )
    return float(width)


def check_friction(owner: str, friction: object) -> tuple[str, ...]:
    """Returns ``friction`` as a tuple of kinds in canonical order, or raises.

    Args:
        owner: the name used in error messages.
        friction: an iterable of kinds among ``"viscous"``, ``"coulomb"`` and
            ``"offset"`` (a comma-separated string is accepted too).

    Returns:
        The kinds, without duplicates, in the order viscous, coulomb, offset.
    """
    if isinstance(friction, str):
        friction = [item.strip() for item in friction.split(",") if item.strip()]
    try:
        kinds = list(friction)  # type: ignore[call-overload]
    except TypeError:
        raise TypeError(
            f"{owner}: friction must be a sequence of {FRICTION_KINDS}; got "
            f"{friction!r}."
        ) from None
    unknown = [kind for kind in kinds if kind not in FRICTION_KINDS]
    if unknown:
        raise ValueError(
            f"{owner}: friction kinds must be among {', '.join(FRICTION_KINDS)}; got "
            f"{', '.join(map(str, unknown))}."
        )
    return tuple(kind for kind in FRICTION_KINDS if kind in kinds)


def friction_names(friction: Sequence[str], num_joints: int) -> tuple[str, ...]:
    """Parameter names of the friction columns, joint-major: ``FV1 FC1 FV2 FC2 ...``.

    Joints are numbered from 1 along the chain (docs/CONVENTIONS.md §4).
    """
    return tuple(
        f"{FRICTION_PREFIX[kind]}{j}"
        for j in range(1, num_joints + 1)
        for kind in friction
    )


def friction_column(kind: str, v: np.ndarray, sign: SignLaw = EXACT_SIGN) -> Any:
    """One kind's IDIM column: ``v`` (viscous), ``s(v)`` (Coulomb) or 1 (offset)."""
    if kind == "viscous":
        return v
    if kind == "coulomb":
        return sign(v)
    if kind == "offset":
        return np.ones_like(v)
    raise ValueError(
        f"friction_column: kind must be one of {', '.join(FRICTION_KINDS)}; got "
        f"{kind!r}."
    )


def friction_value(kind: str, velocity: float, sign: SignLaw = EXACT_SIGN) -> float:
    """:func:`friction_column` of one velocity, with plain floats (fast path)."""
    if kind == "viscous":
        return velocity
    if kind == "coulomb":
        return sign.scalar(velocity)
    return 1.0


def friction_idim_columns(
    v: np.ndarray, friction: Sequence[str], sign: SignLaw = EXACT_SIGN, block: int = 1
) -> np.ndarray:
    """Friction columns of the inverse-dynamics rows, shape ``(N, n, n·len(friction))``.

    Joint i's row has, in joint i's columns: ``v_i`` [rad/s] (viscous), ``s(v_i)``
    (Coulomb), ``1`` (offset), so that τ_f,i = FV_i v_i + FC_i s(v_i) + OFF_i
    [N·m]. The Lagrangian model uses the same columns. ``block`` > 1: their means
    over consecutive blocks of that many samples, shape ``(N/block, n, ...)``
    (each column averaged before it is placed: no (N, n, n·len) array).
    """
    num_samples, num_joints = v.shape
    count = num_samples // block
    width = len(friction)
    out = np.zeros((count, num_joints, num_joints * width))
    joints = np.arange(num_joints)
    for k, kind in enumerate(friction):
        value = friction_column(kind, v[: count * block], sign)
        if block > 1:
            value = value.reshape(count, block, num_joints).mean(axis=1)
        out[:, joints, joints * width + k] = value
    return out


def friction_power_columns(
    v: np.ndarray, friction: Sequence[str], sign: SignLaw = EXACT_SIGN
) -> np.ndarray:
    """Friction power columns, shape ``(N, n·len(friction))``.

    Joint j contributes ``v_j²`` (viscous), ``v_j s(v_j) = |v_j|`` (Coulomb) and
    ``v_j`` (offset): the dissipated power is Σ_j FV_j v_j² + FC_j |v_j| + OFF_j v_j
    [W] (docs/MATH.md §2, eq. P).
    """
    return np.einsum("ni,nik->nk", v, friction_idim_columns(v, friction, sign))


def friction_coefficients(
    owner: str, viscous: Any, coulomb: Any, offset: Any = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked friction coefficients per joint: ``(FV, FC, OFF)``, each (n,).

    Args:
        owner: the name used in error messages.
        viscous: FV per joint [N·m·s/rad or N·s/m].
        coulomb: FC per joint [N·m or N], >= 0; its length sets n >= 1.
        offset: OFF per joint [N·m or N]; default zeros.
    """
    coulomb = _validate.array(owner, "coulomb", coulomb, shape=(None,))
    n = coulomb.size
    if n == 0:
        raise ValueError(f"{owner}: coulomb must have at least one joint; got 0.")
    viscous = _validate.array(owner, "viscous", viscous, shape=(n,))
    offset = np.zeros(n) if offset is None else offset
    offset = _validate.array(owner, "offset", offset, shape=(n,))
    if np.any(coulomb < 0.0):
        raise ValueError(
            f"{owner}: coulomb must be >= 0 [N·m or N]; got {coulomb.tolist()}."
        )
    return viscous, coulomb, offset


def friction_force(
    v: np.ndarray,
    viscous: np.ndarray,
    coulomb: np.ndarray,
    offset: np.ndarray,
    sign: SignLaw = EXACT_SIGN,
) -> np.ndarray:
    """Friction torque ``τ_f = FV·v + FC·s(v) + OFF`` per joint [N·m or N].

    The force to apply to a plant is -τ_f (friction opposes the motion).
    """
    return viscous * v + coulomb * sign(v) + offset


def friction_force_scalar(
    v: float, viscous: float, coulomb: float, offset: float, sign: SignLaw
) -> float:
    """:func:`friction_force` of one joint with plain floats (per-step fast path)."""
    return viscous * v + coulomb * sign.scalar(v) + offset
