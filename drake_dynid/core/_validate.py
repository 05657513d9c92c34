"""Argument checks shared by the core and the blocks.

Every message names the owner, the parameter, the constraint, the unit and the
value, in the house format::

    CausalJacobiDifferentiator: window must be a multiple of time_step [s]; got 0.0105
    with time_step 0.001.

All checks raise ``ValueError`` (bad value) or ``TypeError`` (bad type).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np


def utf8_text(raw: bytes, what: str) -> str:
    """``raw`` decoded as UTF-8 (a byte-order mark accepted, as in logs).

    Raises:
        ValueError: ``"<what>: not UTF-8 text (byte k); save it as UTF-8."``
    """
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise ValueError(
            f"{what}: not UTF-8 text (byte {error.start}); save it as UTF-8."
        ) from None


#: Names a message lists before it counts the rest (:func:`listed`).
LISTED_NAMES = 20


def listed(names: Iterable[str], limit: int = LISTED_NAMES, sep: str = ", ") -> str:
    """``"a, b, c"``; of more than ``limit`` names, the first ones "and N more".

    The one list of names a message prints (a log's or a URDF's joints, a
    bag's topics, a log's columns), so that it stays one readable line: a ROS
    bag of 2000 joints made 16 kB lines. ``sep``: the separator.
    """
    names = list(names)
    shown = sep.join(names[:limit])
    left = len(names) - limit
    return f"{shown} and {left} more" if left > 0 else shown


def choices(names: Iterable[str], given: str, limit: int = LISTED_NAMES) -> str:
    """:func:`listed` ``names`` for a message refusing ``given``, with its closest.

    Of more than ``limit`` names the list is cut; the valid names closest to
    the one given (``difflib``, up to 5) are then named after it, wherever they
    stand in the list: a mistyped flange name among a humanoid's 40 links.
    """
    import difflib

    names = list(names)
    shown = listed(names, limit)
    if len(names) <= limit:
        return shown
    close = difflib.get_close_matches(str(given), names, n=5, cutoff=0.5)
    return f"{shown}; the closest to {given!r}: {', '.join(close)}" if close else shown


def first_difference(expected: Sequence[str], got: Sequence[str]) -> str:
    """Where two lists of names first differ, in words ("" where they do not).

    For a message that lists both (:func:`listed`): beyond the first
    :data:`LISTED_NAMES` names the two shown lists can be the same words.
    """
    expected, got = list(expected), list(got)
    for k in range(max(len(expected), len(got))):
        want = expected[k] if k < len(expected) else None
        have = got[k] if k < len(got) else None
        if want != have:
            return (
                f" (name {k + 1} of {len(expected)}: "
                f"{'none' if want is None else repr(want)} expected, "
                f"{'none' if have is None else repr(have)} given)"
            )
    return ""


def log_joints(owner: str, expected: Sequence[str], got: Sequence[str]) -> None:
    """Checks a log's joints are the robot's ``expected`` joints, in that order.

    Raises:
        ValueError: naming both lists (:func:`listed`) and where they first
            differ (:func:`first_difference`).
    """
    if tuple(got) != tuple(expected):
        fail(
            owner,
            f"log joints must be the robot's {listed(expected)} in that order; "
            f"got {listed(got)}{first_difference(expected, got)}.",
        )


def _unit(unit: str | None) -> str:
    return f" [{unit}]" if unit else ""


def fail(owner: str, message: str) -> None:
    """Raises ``ValueError(f"{owner}: {message}")``."""
    raise ValueError(f"{owner}: {message}")


def real(owner: str, name: str, value: Any, unit: str | None = None) -> float:
    """Returns ``value`` as a finite float, or raises naming ``name``."""
    numeric = (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, numeric):
        raise TypeError(
            f"{owner}: {name} must be a real number{_unit(unit)}; got {value!r} "
            f"of type {type(value).__name__}."
        )
    out = float(value)
    if not math.isfinite(out):
        raise ValueError(f"{owner}: {name} must be finite{_unit(unit)}; got {out}.")
    return out


def positive(owner: str, name: str, value: Any, unit: str | None = None) -> float:
    """Returns ``value`` as a float > 0, or raises naming ``name``."""
    out = real(owner, name, value, unit)
    if out <= 0.0:
        raise ValueError(f"{owner}: {name} must be > 0{_unit(unit)}; got {out}.")
    return out


def below_nyquist(owner: str, name: str, value: Any, time_step: float) -> float:
    """A frequency [Hz] in (0, 1/(2h)), or a ValueError naming it."""
    value = positive(owner, name, value, "Hz")
    if value >= 0.5 / time_step:
        fail(
            owner,
            f"{name} must be < the Nyquist frequency {0.5 / time_step:g} [Hz]; got "
            f"{value:g}.",
        )
    return value


def greater_than(
    owner: str, name: str, value: Any, bound: float, unit: str | None = None
) -> float:
    """Returns ``value`` as a float > ``bound``, or raises naming ``name``."""
    out = real(owner, name, value, unit)
    if not out > bound:
        raise ValueError(f"{owner}: {name} must be > {bound}{_unit(unit)}; got {out}.")
    return out


def in_range(
    owner: str,
    name: str,
    value: Any,
    low: float,
    high: float,
    unit: str | None = None,
) -> float:
    """Returns ``value`` as a float in the closed interval [low, high]."""
    out = real(owner, name, value, unit)
    if not low <= out <= high:
        raise ValueError(
            f"{owner}: {name} must be in [{low}, {high}]{_unit(unit)}; got {out}."
        )
    return out


def integer(owner: str, name: str, value: Any, minimum: int | None = None) -> int:
    """Returns ``value`` as an int (>= ``minimum`` when given), or raises."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            value = int(value)
        else:
            raise TypeError(
                f"{owner}: {name} must be an integer; got {value!r} "
                f"of type {type(value).__name__}."
            )
    out = int(value)
    if minimum is not None and out < minimum:
        raise ValueError(f"{owner}: {name} must be >= {minimum}; got {out}.")
    return out


def multiple_of(
    owner: str,
    name: str,
    value: float,
    step_name: str,
    step: float,
    unit: str | None = "s",
    rtol: float = 1e-9,
) -> int:
    """Returns the integer ``value / step``; raises unless it is a whole number >= 1."""
    ratio = value / step
    count = round(ratio)
    if count < 1 or abs(ratio - count) > rtol * max(1.0, abs(ratio)):
        raise ValueError(
            f"{owner}: {name} must be a multiple of {step_name}{_unit(unit)}; "
            f"got {value:g} with {step_name} {step:g}."
        )
    return int(count)


def array(
    owner: str,
    name: str,
    value: Any,
    shape: Sequence[int | None] | None = None,
    finite: bool = True,
) -> np.ndarray:
    """Returns ``value`` as a float64 array, checking its shape and finiteness.

    ``shape`` entries of ``None`` accept any size along that axis.
    """
    try:
        out = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{owner}: {name} must be an array of real numbers.") from None
    if shape is not None:
        ok = out.ndim == len(shape) and all(
            want is None or got == want
            for got, want in zip(out.shape, shape, strict=True)
        )
        if not ok:
            sizes = ", ".join("any" if s is None else str(s) for s in shape)
            want_text = f"({sizes})"
            if tuple(shape) == (None,):
                want_text = "(N,), a 1-D array of any length"
            got = f"{out.shape}" + (" (a single number)" if out.ndim == 0 else "")
            raise ValueError(f"{owner}: {name} must have shape {want_text}; got {got}.")
    if finite and not np.all(np.isfinite(out)):
        bad = int(np.size(out) - np.count_nonzero(np.isfinite(out)))
        raise ValueError(
            f"{owner}: {name} must be finite; got {bad} NaN or infinite value(s)."
        )
    return out


def instance(owner: str, name: str, value: Any, types: Any, what: str) -> Any:
    """Returns ``value`` if it is an instance of ``types``, else raises TypeError.

    ``what`` describes the expected object (e.g. ``"a FourierBank (fourier_bank)"``).
    """
    if not isinstance(value, types):
        raise TypeError(
            f"{owner}: {name} must be {what}; got {value!r:.60} of type "
            f"{type(value).__name__}."
        )
    return value


def having(
    owner: str, name: str, value: Any, attributes: Sequence[str], what: str
) -> Any:
    """Returns ``value`` if it has every attribute of ``attributes``, else TypeError.

    For duck-typed arguments (a robot model, a log): ``what`` names the expected
    object (e.g. ``"a RobotModel"``).
    """
    missing = [attribute for attribute in attributes if not hasattr(value, attribute)]
    if missing:
        raise TypeError(
            f"{owner}: {name} must be {what}; got {value!r:.60} of type "
            f"{type(value).__name__} (no {missing[0]})."
        )
    return value


#: Largest |q| or |τ| of a log (any unit): the identification squares and
#: multiplies samples (v², v·τ, products with 1/h² in v̇), which overflows float64
#: beyond ~1e154; 1e100 is far beyond any physical value in SI units.
MAX_LOG_MAGNITUDE = 1e100


def log_magnitudes(owner: str, q: Any, tau: Any) -> None:
    """Raises ValueError when a finite |q| or |τ| of a log exceeds 1e100.

    Non-finite samples are not checked here (they are bad samples).
    """
    for name, values, unit in (("q", q, "rad or m"), ("tau", tau, "N·m or N")):
        stored = hasattr(values, "rows") and not isinstance(values, np.ndarray)
        array = values if stored else np.asarray(values, dtype=float)  # core.blocks
        top = 0.0
        for start in range(0, array.shape[0] if array.ndim else 1, 1 << 16):
            # In blocks of rows: memory independent of the log's length.
            block = np.abs(np.asarray(array[start : start + (1 << 16)], dtype=float))
            block[~np.isfinite(block)] = 0.0
            if block.size:
                top = max(top, float(block.max()))
        if top > MAX_LOG_MAGNITUDE:
            raise ValueError(
                f"{owner}: |{name}| must be <= {MAX_LOG_MAGNITUDE:g} [{unit}] (the "
                "identification squares and multiplies the samples, which overflows "
                f"beyond about 1e154); got {top:.3g}: check the log's units."
            )
