"""Joint limits, safety margins, and the check of sampled motion against them.

Limits come from the URDF (``drake_dynid.limits``) or a limits file; ±inf means
"not given". A motion (q, v, v̇, τ sampled at times t) breaks a limit when, for some
sample and joint j::

    q_j < lower_j + m_q,j or   q_j > upper_j - m_q,j        position   [rad or m]
    |v_j| > (1 - m_v) v_max,j                               velocity   [rad/s or m/s]
    |v̇_j| > (1 - m_a) a_max,j                               acceleration
    |τ_j| > (1 - m_τ) τ_max,j                               effort     [N·m or N]
    d < m_d                                                 self-collision [m]

with the margins m of :class:`Margins` (all zero for the raw limits); the position
margin m_q,j is ``Margins.position`` [rad] on a revolute joint and
``Margins.prismatic`` [m] on a prismatic one.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from drake_dynid.core import _validate as v

__all__ = ["JointLimits", "Margins", "Violation", "limit_violations"]

_LIMIT_FIELDS = ("lower", "upper", "velocity", "acceleration", "effort")


def _frozen(value: np.ndarray) -> np.ndarray:
    value = np.array(value, dtype=float)
    value.flags.writeable = False
    return value


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Per-joint limits (immutable); ±inf means "not given".

    Attributes:
        joint_names: the n joints.
        lower, upper: position limits (n,) [rad or m].
        velocity: |v| limits (n,) [rad/s or m/s].
        effort: |τ| limits (n,) [N·m or N].
        acceleration: |v̇| limits (n,) [rad/s² or m/s²] (default: none, inf).
        prismatic: (n,) bool, for the units in messages (default: all revolute).
    """

    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray
    acceleration: np.ndarray | None = None
    prismatic: tuple[bool, ...] = ()

    def __post_init__(self) -> None:
        owner = "JointLimits"
        names = tuple(str(name) for name in self.joint_names)
        n = len(names)
        if n == 0:
            v.fail(owner, "joint_names must not be empty.")
        object.__setattr__(self, "joint_names", names)
        if self.acceleration is None:
            object.__setattr__(self, "acceleration", np.full(n, np.inf))
        for name in _LIMIT_FIELDS:
            value = v.array(owner, name, getattr(self, name), shape=(n,), finite=False)
            if np.any(np.isnan(value)):
                v.fail(owner, f"{name} must not be NaN; got {value.tolist()}.")
            if name != "lower" and name != "upper" and np.any(value <= 0.0):
                j = int(np.argmax(value <= 0.0))
                v.fail(
                    owner,
                    f"{name} limit of joint {names[j]} must be > 0; got {value[j]:g}.",
                )
            object.__setattr__(self, name, _frozen(value))
        bad = np.flatnonzero(~(self.lower < self.upper))
        if bad.size:
            j = int(bad[0])
            v.fail(
                owner,
                f"joint {names[j]}: lower position limit {self.lower[j]:g} must be "
                f"< upper {self.upper[j]:g}.",
            )
        prismatic = tuple(bool(p) for p in self.prismatic) or (False,) * n
        if len(prismatic) != n:
            v.fail(owner, f"prismatic must have {n} entries; got {len(prismatic)}.")
        object.__setattr__(self, "prismatic", prismatic)

    @property
    def num_joints(self) -> int:
        """Number of joints n."""
        return len(self.joint_names)

    def missing(self) -> list[str]:
        """``"joint (position, effort)"`` for every joint lacking a required limit.

        Required: finite position limits, velocity and effort limits.
        """
        out = []
        for j, name in enumerate(self.joint_names):
            kinds = [
                kind
                for kind, ok in (
                    (
                        "position",
                        np.isfinite(self.lower[j]) and np.isfinite(self.upper[j]),
                    ),
                    ("velocity", np.isfinite(self.velocity[j])),
                    ("effort", np.isfinite(self.effort[j])),
                )
                if not ok
            ]
            if kinds:
                out.append(f"{name} ({', '.join(kinds)})")
        return out

    def with_overrides(self, overrides: Mapping[str, Mapping[str, Any]]) -> JointLimits:
        """A copy with some limits replaced: ``{joint: {field: value}}``.

        Fields: ``lower``, ``upper``, ``velocity``, ``acceleration``, ``effort``.
        """
        owner = "JointLimits.with_overrides"
        values: dict[str, Any] = {
            name: np.array(getattr(self, name)) for name in _LIMIT_FIELDS
        }
        for joint, entries in overrides.items():
            if joint not in self.joint_names:
                v.fail(
                    owner,
                    f"unknown joint {joint!r}; the joints are "
                    f"{v.listed(self.joint_names)}.",
                )
            if not isinstance(entries, Mapping):
                v.fail(owner, f"the limits of joint {joint} must be a table/object.")
            j = self.joint_names.index(joint)
            for key, value in entries.items():
                if key not in _LIMIT_FIELDS:
                    v.fail(
                        owner,
                        f"joint {joint}: unknown limit {key!r}; use "
                        f"{', '.join(_LIMIT_FIELDS)}.",
                    )
                values[key][j] = v.real(owner, f"{joint}.{key}", value)
        return replace(self, **values)

    def units(self, j: int) -> tuple[str, str, str, str]:
        """Units of (position, velocity, acceleration, effort) of joint j."""
        if self.prismatic[j]:
            return "m", "m/s", "m/s²", "N"
        return "rad", "rad/s", "rad/s²", "N·m"


@dataclass(frozen=True)
class Margins:
    """Safety margins applied to the limits during the design.

    Attributes:
        position: kept from each position limit of a revolute joint [rad] (>= 0).
        velocity, acceleration, effort: fractions of the limit kept free, in [0, 1).
        collision: smallest signed distance between collision geometries [m].
        prismatic: kept from each position limit of a prismatic joint [m] (>= 0):
            one number in radians and metres alike kept 0.1 m at each end of the
            TIAGo torso's 0.35 m stroke (57 % of it); 0.02 m keeps 89 %.
    """

    position: float = 0.1
    velocity: float = 0.2
    acceleration: float = 0.2
    effort: float = 0.2
    collision: float = 0.01
    prismatic: float = 0.02

    def __post_init__(self) -> None:
        owner = "Margins"
        for name in ("position", "collision", "prismatic"):
            value = v.real(owner, name, getattr(self, name))
            if value < 0.0:
                v.fail(owner, f"{name} margin must be >= 0; got {value:g}.")
        for name in ("velocity", "acceleration", "effort"):
            value = v.real(owner, name, getattr(self, name))
            if not 0.0 <= value < 1.0:
                v.fail(
                    owner,
                    f"{name} margin must be a fraction in [0, 1); got {value:g}.",
                )

    def position_margins(self, prismatic: Any) -> np.ndarray:
        """The position margin of each joint (n,) [rad or m].

        ``prismatic`` [m] where the (n,) flags ``prismatic`` are set, ``position``
        [rad] elsewhere.
        """
        flags = np.asarray(prismatic, dtype=bool)
        return np.where(flags, self.prismatic, self.position)


@dataclass(frozen=True)
class Violation:
    """One limit exceeded by a trajectory.

    Attributes:
        joint: joint name (for a collision: the pair of links, "A-B", or "").
        kind: "position", "velocity", "acceleration", "effort" or "collision".
        time: when [s] (first worst sample).
        value: the value reached (position q, |v|, |v̇|, |τ|, or distance [m]).
        limit: the limit it breaks (with the margin).
        unit: unit of value and limit.
    """

    joint: str
    kind: str
    time: float
    value: float
    limit: float
    unit: str

    def __str__(self) -> str:
        if self.kind == "collision":
            pair = f" between links {self.joint}" if self.joint else ""
            return (
                f"self-collision clearance {self.value:.4g} m{pair} at t = "
                f"{self.time:.3f} s is below the {self.limit:g} m margin"
            )
        return (
            f"joint {self.joint}: {self.kind} {self.value:.4g} {self.unit} at t = "
            f"{self.time:.3f} s exceeds the limit {self.limit:.4g} {self.unit}"
        )


def limit_violations(
    times: np.ndarray,
    q: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    tau: np.ndarray | None,
    limits: JointLimits,
    margins: Margins | None = None,
    *,
    clearance: np.ndarray | None = None,
    tolerance: float = 1e-6,
) -> list[Violation]:
    """The limits (less the margins) that sampled motion breaks, worst first per kind.

    Args:
        times: (N,) sample times [s].
        q: (N, n) positions [rad or m].
        qd: (N, n) velocities [rad/s or m/s].
        qdd: (N, n) accelerations [rad/s² or m/s²].
        tau: (N, n) joint torques [N·m or N] (None: not checked).
        limits: the joint limits.
        margins: the margins to keep (default ``Margins()``;
            ``Margins(0, 0, 0, 0, 0, 0)`` for the raw limits).
        clearance: (N,) smallest signed distance between collision geometries [m].
        tolerance: relative slack before a sample counts as a violation.

    Returns:
        One :class:`Violation` per joint and kind that is broken (its worst sample).
    """
    margins = Margins() if margins is None else margins
    out: list[Violation] = []
    position = margins.position_margins(limits.prismatic)
    low = limits.lower + position
    high = limits.upper - position
    checks: list[tuple[str, np.ndarray, Any, int]] = [
        ("velocity", np.abs(qd), (1 - margins.velocity) * limits.velocity, 1),
        (
            "acceleration",
            np.abs(qdd),
            (1 - margins.acceleration) * np.asarray(limits.acceleration),
            2,
        ),
    ]
    if tau is not None:
        checks.append(("effort", np.abs(tau), (1 - margins.effort) * limits.effort, 3))
    for j, name in enumerate(limits.joint_names):
        unit = limits.units(j)
        span = max(high[j] - low[j], 1e-12) if np.isfinite(high[j] - low[j]) else 1.0
        below = low[j] - q[:, j]
        above = q[:, j] - high[j]
        for excess, limit in ((below, low[j]), (above, high[j])):
            k = int(np.argmax(excess))
            if excess[k] > tolerance * span:
                out.append(
                    Violation(
                        name,
                        "position",
                        float(times[k]),
                        float(q[k, j]),
                        float(limit),
                        unit[0],
                    )
                )
        for kind, value, bound, u in checks:
            k = int(np.argmax(value[:, j]))
            if value[k, j] > bound[j] * (1.0 + tolerance):
                out.append(
                    Violation(
                        name,
                        kind,
                        float(times[k]),
                        float(value[k, j]),
                        float(bound[j]),
                        unit[u],
                    )
                )
    if clearance is not None and clearance.size:
        k = int(np.argmin(clearance))
        if clearance[k] < margins.collision - tolerance:
            out.append(
                Violation(
                    "",
                    "collision",
                    float(times[k]),
                    float(clearance[k]),
                    margins.collision,
                    "m",
                )
            )
    return out
