"""``dynid identify --position-noise``: the power rows' noise compensation option.

The power model's rows are quadratic in the estimated velocity; white position
noise of std σ_q biases them by a known amount (``drake_dynid.core.noise_bias``,
docs/MATH.md §3). ``--position-noise auto`` (the default) measures σ_q per joint
on the log (``core.excitation.position_noise_std``), ``none`` turns the
compensation off, numbers give it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "add_position_noise_argument",
    "measured_position_noise",
    "position_noise_line",
    "position_noise_option",
]


def position_noise_option(text: str | None) -> Any:
    """``auto`` | ``none`` | ``S[,S...]``: ``"auto"``, None, a float or floats."""
    text = "auto" if text is None else text.strip()
    if text in ("auto", "none"):
        return None if text == "none" else "auto"
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if not values or any(not math.isfinite(x) or x < 0.0 for x in values):
        raise ValueError(
            "--position-noise must be 'auto', 'none' or stds >= 0 [rad or m] (one, "
            f"or one per joint, comma-separated); got {text!r}."
        )
    return values[0] if len(values) == 1 else values


def measured_position_noise(log: Any) -> np.ndarray:
    """σ_q per joint [rad or m] for ``--position-noise auto`` (power model).

    ``core.excitation.position_noise_std`` (the white floor of the position
    spectrum above f_s/4) on the longest run of finite samples.
    """
    from drake_dynid.core.excitation import position_noise_std

    start, stop = max(log.good_segments(), key=lambda s: s[1] - s[0], default=(0, 0))
    if stop - start < 64:
        raise ValueError(
            "cannot measure the position noise: no run of 64 finite samples in the "
            "log; give --position-noise none or S."
        )
    return position_noise_std(log.q[start:stop], log.time_step)


def add_position_noise_argument(group: Any) -> None:
    """Adds ``--position-noise`` to an argument group."""
    group.add_argument(
        "--position-noise",
        metavar="auto|none|S[,S...]",
        help="power model: std of the white position noise whose bias is removed "
        "from the rows (the quadratic velocity terms of the energy and the "
        "friction power) [rad or m], one or one per joint; 'auto' (default): "
        "measured on the log (the floor of the position spectrum above fs/4; "
        "none with --drive, whose motor columns it does not cover); 'none': no "
        "compensation",
    )


def position_noise_line(settings: Any, measured: bool) -> str:
    """The printed line of the compensation ("" when there is none)."""
    if settings.position_noise is None:
        return ""
    sigma = np.atleast_1d(settings.position_noise)
    where = (
        " (measured on the log: the floor of the position spectrum; "
        "--position-noise to override)"
        if measured
        else " (--position-noise)"
    )
    return (
        "position noise: "
        + ", ".join(f"{x:.3g}" for x in sigma)
        + where
        + "; its bias is removed from the power rows"
    )
