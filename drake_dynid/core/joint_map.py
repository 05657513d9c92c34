"""Identified joints, locked joints and mimic joints: the map to the full robot.

A robot description may have more movable joints than the ones identified (a
gripper, a head, the wheels of a mobile base). The identified coordinates q (n of
them) map to the positions of every movable joint of the description (n_full) by

    q_full = P q + c,   v_full = P v,   v̇_full = P v̇,     P: (n_full, n), c: (n_full,)

* an identified joint i: row e_i of P, c = 0;
* a locked joint: a zero row of P, c = its position [rad or m];
* a mimic joint (URDF ``<mimic joint="L" multiplier="a" offset="b"/>``, q_f = a q_L
  + b): a times the row of its leader L, c = a c_L + b. Chains of mimic joints are
  followed to the first joint that is not a mimic. A mimic joint whose leader is
  locked is locked at a c_L + b.

By virtual work, the joint torques of the identified joints are τ = Pᵀ τ_full, and
every per-joint regressor row reduces the same way (W = Pᵀ W_full). Pure Python and
numpy; :class:`drake_dynid.robot.RobotModel` applies it to a Drake plant.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from drake_dynid.core._validate import listed

__all__ = ["JointMap", "joint_map"]

#: Largest |locked position| [rad or m]: a prismatic joint locked at 1e300 m lumps
#: its links with m·d² = inf (NaN parameters, a simulation that never ends).
MAX_LOCKED = 1e4


@dataclass(frozen=True, eq=False)
class JointMap:
    """Identified coordinates -> all movable joints, q_full = P q + c.

    Attributes:
        names: the n identified joints, in the order of ``movable``.
        movable: the n_full movable joints of the description (plant order).
        matrix: P, ``(n_full, n)`` read-only.
        offset: c, ``(n_full,)`` read-only [rad or m].
        locked: ``{joint: position}`` for every movable joint that does not move
            (locked by the user, by default at 0, or a mimic of a locked joint).
        mimic: ``{joint: (leader, multiplier, offset)}`` for every mimic joint that
            moves with an identified leader (the first non-mimic joint up its
            chain; multiplier and offset composed along the chain).
    """

    names: tuple[str, ...]
    movable: tuple[str, ...]
    matrix: np.ndarray
    offset: np.ndarray
    locked: Mapping[str, float]
    mimic: Mapping[str, tuple[str, float, float]]

    @property
    def moving(self) -> tuple[str, ...]:
        """The joints that move: the identified ones, then the moving mimic ones."""
        return self.names + tuple(self.mimic)

    @property
    def is_identity(self) -> bool:
        """Whether every movable joint is identified (P = I, c = 0)."""
        return self.names == self.movable

    def rows(self, joints: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
        """Returns ``(P, c)`` restricted to ``joints`` (rows in that order)."""
        index = [self.movable.index(name) for name in joints]
        return self.matrix[index], self.offset[index]


def _fail(owner: str, message: str) -> None:
    raise ValueError(f"{owner}: {message}")


def _listing(names: Sequence[str]) -> str:
    return listed(names) if names else "none"


def _resolve_mimic(
    owner: str, movable: tuple[str, ...], mimic: Mapping[str, tuple[str, float, float]]
) -> dict[str, tuple[str, float, float]]:
    """Follows each mimic chain to its first non-mimic joint; composes a and b."""
    resolved: dict[str, tuple[str, float, float]] = {}
    for follower in mimic:
        if follower not in movable:
            continue  # a mimic tag on a fixed joint: nothing moves
        leader, a, b = follower, 1.0, 0.0
        seen = [follower]
        while leader in mimic:
            parent, multiplier, shift = mimic[leader]
            if not (math.isfinite(multiplier) and math.isfinite(shift)):
                _fail(
                    owner,
                    f"mimic joint {leader!r} must have a finite multiplier and offset; "
                    f"got {multiplier} and {shift}.",
                )
            a, b = a * multiplier, a * shift + b
            leader = parent
            if leader in seen:
                _fail(
                    owner,
                    f"mimic joints form a cycle ({' -> '.join([*seen, leader])}); "
                    "a mimic chain must end at a joint that is not a mimic.",
                )
            seen.append(leader)
        if leader not in movable:
            _fail(
                owner,
                f"joint {follower!r} mimics {leader!r}, which is not a movable joint "
                f"(movable joints: {_listing(movable)}).",
            )
        resolved[follower] = (leader, a, b)
    return resolved


def joint_map(
    movable: Sequence[str],
    *,
    joints: Sequence[str] | None = None,
    locked: Mapping[str, float] | None = None,
    mimic: Mapping[str, tuple[str, float, float]] | None = None,
    owner: str = "joint_map",
) -> JointMap:
    """Chooses the identified joints and builds q_full = P q + c.

    Args:
        movable: names of every movable (1-DOF) joint of the description, in the
            plant's order; the identified joints keep this order.
        joints: the identified joints; default every movable joint that is not a
            mimic and not in ``locked``.
        locked: ``{joint: position [rad or m]}``; every movable joint that is neither
            identified nor a mimic is locked, at 0 unless given here.
        mimic: ``{joint: (leader, multiplier, offset)}`` from the URDF's ``<mimic>``
            tags (q_joint = multiplier·q_leader + offset).
        owner: the name used in error messages.

    Raises:
        ValueError: an unknown joint (the message lists the movable ones), a
            duplicate, locking an identified joint, identifying or locking a mimic
            joint (it follows its leader), a non-finite position, a mimic cycle or
            leader that is not movable, or no joint left to identify.
    """
    movable = tuple(str(name) for name in movable)
    if len(set(movable)) != len(movable):
        _fail(owner, "movable joint names must be unique.")
    followers = _resolve_mimic(owner, movable, dict(mimic or {}))
    independent = tuple(name for name in movable if name not in followers)
    locked_in = dict(locked or {})
    for name, value in locked_in.items():
        if name not in movable:
            _fail(
                owner,
                f"locked joint {name!r} is not a movable joint of the robot; "
                f"available: {_listing(independent)}.",
            )
        if name in followers:
            leader = followers[name][0]
            _fail(
                owner,
                f"joint {name!r} is a mimic of {leader!r} and follows it; lock "
                f"{leader!r} instead.",
            )
        try:
            position = float(value)
        except (TypeError, ValueError):
            position = math.nan
        if not math.isfinite(position):
            _fail(
                owner,
                f"locked position of {name!r} must be a finite number [rad or m]; "
                f"got {value!r}.",
            )
        if abs(position) > MAX_LOCKED:
            _fail(
                owner,
                f"locked position of {name!r} must be within ±{MAX_LOCKED:g} [rad or "
                f"m]; got {position:g}.",
            )
        locked_in[name] = position
    if joints is None:
        chosen = [name for name in independent if name not in locked_in]
    else:
        if isinstance(joints, str):
            raise TypeError(f"{owner}: joints must be a sequence of joint names.")
        chosen = [str(name) for name in joints]
        if not chosen:
            _fail(owner, f"joints must name at least one of {_listing(independent)}.")
        for name in chosen:
            if name not in movable:
                _fail(
                    owner,
                    f"joint {name!r} is not a movable joint of the robot; available: "
                    f"{_listing(independent)}.",
                )
            if name in followers:
                leader = followers[name][0]
                _fail(
                    owner,
                    f"joint {name!r} is a mimic of {leader!r} and cannot be "
                    f"identified on its own; identify {leader!r} instead.",
                )
            if name in locked_in:
                _fail(
                    owner,
                    f"joint {name!r} is both identified and locked; a joint is "
                    "either identified (in joints) or locked.",
                )
        duplicates = sorted({name for name in chosen if chosen.count(name) > 1})
        if duplicates:
            _fail(owner, f"joints lists {listed(duplicates)} more than once.")
    if not chosen:
        _fail(
            owner,
            "no joint left to identify: every movable joint is locked "
            f"({_listing(independent)}).",
        )
    names = tuple(name for name in movable if name in set(chosen))
    n_full, n = len(movable), len(names)
    matrix = np.zeros((n_full, n))
    offset = np.zeros(n_full)
    moving_mimic: dict[str, tuple[str, float, float]] = {}
    for row, name in enumerate(movable):
        if name in names:
            matrix[row, names.index(name)] = 1.0
        elif name not in followers:
            offset[row] = locked_in.get(name, 0.0)
    for row, name in enumerate(movable):
        if name not in followers:
            continue
        leader, a, b = followers[name]
        lead = movable.index(leader)
        if leader in names:
            matrix[row, names.index(leader)] = a
            moving_mimic[name] = (leader, a, b)
            offset[row] = b
        else:
            offset[row] = a * offset[lead] + b
    all_locked = {
        name: float(offset[row])
        for row, name in enumerate(movable)
        if name not in names and name not in moving_mimic
    }
    matrix.setflags(write=False)
    offset.setflags(write=False)
    return JointMap(
        names=names,
        movable=movable,
        matrix=matrix,
        offset=offset,
        locked=MappingProxyType(dict(all_locked)),
        mimic=MappingProxyType(moving_mimic),
    )
