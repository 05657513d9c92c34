"""``dynid identify --position-noise``, ``--torque-noise``: the noise std options.

The power model's rows are quadratic in the estimated velocity; white position
noise of std σ_q biases them by a known amount (``drake_dynid.core.noise_bias``,
docs/MATH.md §3). The covariance weighting (``core.row_covariance``) computes the
rows' covariance from σ_q and the torque noise σ_τ. ``auto`` (the default)
measures them per joint on the log when they are used (σ_q: the white floor of the
position spectrum above f_s/4, ``core.excitation.position_noise_std``; σ_τ: the
MAD of the torque above f_s/4, ``core.excitation.torque_noise_std``, which a
Coulomb reversal's step does not inflate), ``none`` leaves them out, numbers give
them.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "add_noise_arguments",
    "measured_noise",
    "noise_lines",
    "noise_option",
    "position_noise_option",
]

_UNITS = {"position": "rad or m", "torque": "N·m or N"}


def noise_option(text: str | None, signal: str = "position") -> Any:
    """``auto`` | ``none`` | ``S[,S...]``: ``"auto"``, None, a float or floats.

    ``signal``: ``"position"`` (``--position-noise``) or ``"torque"``.
    """
    text = "auto" if text is None else text.strip()
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if not values or any(not math.isfinite(x) or x < 0.0 for x in values):
        raise ValueError(
            f"--{signal}-noise must be 'auto', 'none' or stds >= 0 [{_UNITS[signal]}] "
            f"(one, or one per joint, comma-separated); got {text!r}."
        )
    return values[0] if len(values) == 1 else values


def position_noise_option(text: str | None) -> Any:
    """:func:`noise_option` of ``--position-noise``."""
    return noise_option(text, "position")


def measured_noise(log: Any, signal: str = "position") -> np.ndarray:
    """σ per joint of the log's positions or torques, for ``auto``.

    On the longest run of finite samples [rad or m; N·m or N]: positions,
    ``core.excitation.motion_noise_band`` (the white floor of the spectrum above
    f_s/4; measured once per log, ``RobotLog.on_longest_run``: the dead zone reads
    it too); torques, ``core.excitation.torque_noise_std`` (the MAD of the part
    above f_s/4: Coulomb steps do not inflate it).
    """
    from drake_dynid.core.blocks import segment
    from drake_dynid.core.excitation import motion_noise_band, torque_noise_std

    start, stop = max(log.good_segments(), key=lambda s: s[1] - s[0], default=(0, 0))
    if stop - start < 64:
        raise ValueError(
            f"cannot measure the {signal} noise: no run of 64 finite samples in the "
            f"log; give --{signal}-noise none or S."
        )
    if signal == "position":
        return np.asarray(log.on_longest_run(motion_noise_band)[1])
    # A lazy view of a stored (long) log: measured a piece at a time.
    return torque_noise_std(segment(log.tau, start, stop), log.time_step)


def add_noise_arguments(group: Any) -> None:
    """Adds ``--position-noise`` and ``--torque-noise`` to an argument group."""
    group.add_argument(
        "--position-noise",
        metavar="auto|none|S[,S...]",
        help="std of the white position noise [rad or m], one or one per joint: "
        "the power model removes its bias from the rows (the quadratic velocity "
        "terms of the energy and the friction power), the covariance weighting "
        "uses it; 'auto' (default): measured on the log (the floor of the "
        "position spectrum above fs/4) when used (not with --drive, whose motor "
        "columns the compensation does not cover); 'none': neither",
    )
    group.add_argument(
        "--torque-noise",
        metavar="auto|none|S[,S...]",
        help="std of the white torque noise [N·m or N], one or one per joint, for "
        "--weighting covariance and the bootstrap; 'auto' (default): measured on "
        "the log (the median deviation of the torque above fs/4)",
    )


def noise_lines(settings: Any, position_measured: bool, torque_measured: bool) -> list:
    """The printed lines of the noise stds (none when not used)."""
    lines = []
    for field, measured, signal in (
        ("position_noise", position_measured, "position"),
        ("torque_noise", torque_measured, "torque"),
    ):
        value = getattr(settings, field)
        if value is None:
            continue
        measure = (
            "the floor of the position spectrum"
            if signal == "position"
            else "the torque above fs/4"
        )
        where = (
            f" (measured on the log: {measure}; --{signal}-noise to override)"
            if measured
            else f" (--{signal}-noise)"
        )
        uses = []
        if signal == "position" and settings.model == "power":
            uses.append("its bias is removed from the power rows")
        if settings.weighting == "covariance":
            uses.append("the rows' covariance uses it")
        lines.append(
            f"{signal} noise: "
            + ", ".join(f"{x:.3g}" for x in np.atleast_1d(value))
            + where
            + "; "
            + " and ".join(uses)
        )
    return lines
