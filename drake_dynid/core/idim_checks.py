"""Checks of the off-line IDIM's given settings against the log, before any work.

``drake_dynid.offline.offline_rows`` calls :func:`check_offline_settings` with the
values the user gave (None: automatic, chosen by ``core.idim_auto``), before any
filter is designed or any row computed (docs/CONVENTIONS.md §5):

* ``cutoff_hz`` and ``decimation_cutoff_hz``: finite, below the Nyquist frequency,
  and high enough that their filters fit in the log (the position filter drops
  ``1 + ceil(2/(f_c·h))`` samples at each end of a segment: f_c >=
  4/((L - 3)·h) for the longest finite segment of L samples; the decimation
  low-pass needs as many periods);
* ``cutoff_hz``: at most ``core.idim_auto.noise_limited_cutoff`` (above it the
  position noise in v biases the estimates, errors in variables, far beyond σ:
  on the paper's 2R at SNR 30 dB a cutoff of 499.9 Hz put MY2 228σ off);
* ``decimation``: an integer that leaves more equations than parameters.

Messages name the settings through ``names`` (``dynid offline`` shows its
options: ``--cutoff``, ``--decimation``, ``--decimation-cutoff``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.blocks import segment
from drake_dynid.core.idim_auto import MAX_VELOCITY_NOISE_SHARE, noise_limited_cutoff

__all__ = ["check_filter_frequency", "check_offline_settings"]


def check_filter_frequency(
    prefix: str, name: str, value: Any, time_step: float, longest: int
) -> float:
    """A filter cutoff [Hz] in (0, Nyquist) that fits in the log.

    Two periods at each end of a segment of ``longest`` samples: >= 4/((longest -
    3)·h). ``prefix`` starts the messages.
    """
    numeric = (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, numeric):
        raise TypeError(
            f"{prefix}{name} must be a real number [Hz]; got {value!r} of type "
            f"{type(value).__name__}."
        )
    value = float(value)
    nyquist = 0.5 / time_step
    if not (math.isfinite(value) and 0.0 < value < nyquist):
        raise ValueError(
            f"{prefix}{name} must be in (0, {nyquist:g}) [Hz] (below the Nyquist "
            f"frequency of the log); got {value:g}."
        )
    lowest = 4.0 / (max(longest - 3, 1) * time_step)
    if value < lowest:
        raise ValueError(
            f"{prefix}{name} must be >= {lowest:.3g} Hz on this log: its filter "
            f"needs two periods of the cutoff at each end of a segment and the "
            f"longest finite segment lasts {longest * time_step:g} s; got {value:g}."
        )
    return value


def check_offline_settings(
    q: Any,
    time_step: float,
    segments: Sequence[tuple[int, int]],
    *,
    cutoff_hz: Any,
    decimation: Any,
    decimation_cutoff_hz: Any,
    num_joints: int,
    num_parameters: int,
    owner: str | None = "identify_offline",
    names: Mapping[str, str] | None = None,
) -> None:
    """Checks the given off-line settings against the log (module docstring).

    Args:
        q: (N, n) positions of the log [rad or m].
        time_step: the log's sample period h [s].
        segments: its finite segments ``[start, stop)``.
        cutoff_hz: the given position cutoff [Hz], or None (automatic).
        decimation: the given decimation factor, or None.
        decimation_cutoff_hz: the given decimation low-pass [Hz], or None.
        num_joints: n.
        num_parameters: p.
        owner: message prefix (None: none).
        names: setting -> name shown in the messages.

    Raises:
        ValueError: a value the log cannot honour. TypeError: a bad type.
    """
    prefix = f"{owner}: " if owner else ""

    def say(name: str) -> str:
        return (names or {}).get(name, name)

    if not segments:
        return
    longest = max(segments, key=lambda s: s[1] - s[0])
    length = longest[1] - longest[0]
    total = sum(stop - start for start, stop in segments)
    if cutoff_hz is not None:
        cutoff = check_filter_frequency(
            prefix, say("cutoff_hz"), cutoff_hz, time_step, length
        )
        if length >= 16:
            limit = noise_limited_cutoff(segment(q, *longest), time_step)
            if cutoff > limit:
                raise ValueError(
                    f"{prefix}{say('cutoff_hz')} must be <= {limit:.3g} Hz on this "
                    f"log: above it the position noise makes more than "
                    f"{MAX_VELOCITY_NOISE_SHARE:g} of the velocity's power on some "
                    "joint, which biases the estimates (errors in variables) far "
                    f"beyond their σ; got {cutoff:g} Hz (leave it out for the "
                    "automatic cutoff)."
                )
    if decimation_cutoff_hz is not None:
        check_filter_frequency(
            prefix, say("decimation_cutoff_hz"), decimation_cutoff_hz, time_step, length
        )
    if decimation is not None:
        factor = check.integer(
            owner or "identify_offline", say("decimation"), decimation, minimum=1
        )
        rows = (total // factor) * num_joints
        if rows <= num_parameters:
            raise ValueError(
                f"{prefix}{say('decimation')} must leave more equations than the "
                f"{num_parameters} parameters: {total} finite samples / {factor} x "
                f"{num_joints} joints = {rows} equations; got {factor}."
            )
