"""Trajectory files: the sampled CSV of ``dynid excite`` and its coefficient JSON.

CSV (one row per sample, header row, column order free)::

    t,q_<joint 1>,...,q_<joint n>,v_<joint 1>,...,v_<joint n>,a_<joint 1>,...

``t`` [s] strictly increasing; ``q_`` [rad or m], ``v_`` [rad/s or m/s], ``a_``
[rad/s² or m/s²] per joint. ``q_`` and ``v_`` are required (a reader interpolates
with cubic Hermite polynomials through q and v); ``a_`` is optional.

JSON: the Fourier coefficients (``FourierTrajectory``: q0, a, b, base frequency)
and what produced them, so that the exact series can be rebuilt.
"""

from __future__ import annotations

import json
import math
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from drake_dynid.core._validate import listed, real, utf8_text
from drake_dynid.core.trajectory import FourierTrajectory
from drake_dynid.files import json_text, write_text_whole, write_whole

__all__ = [
    "SampledTrajectory",
    "read_coefficients",
    "read_trajectory",
    "write_coefficients",
    "write_trajectory",
]


#: Longest ``duration`` of a coefficient JSON [s]: sampled at 100 Hz, the 1e7 samples
#: ``dynid excite`` writes at most (-1 was an IndexError, 1e12 s a 728 TiB array).
MAX_DURATION = 1e5


@dataclass(frozen=True, eq=False)
class SampledTrajectory:
    """Joint trajectory samples.

    Attributes:
        t: (N,) strictly increasing times [s].
        q: (N, n) positions [rad or m].
        v: (N, n) velocities [rad/s or m/s].
        a: (N, n) accelerations [rad/s² or m/s²] (NaN where not given).
        joint_names: the n joints.
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    joint_names: tuple[str, ...]

    @property
    def duration(self) -> float:
        """t[-1] - t[0] [s]."""
        return float(self.t[-1] - self.t[0])

    @classmethod
    def from_fourier(
        cls,
        trajectory: FourierTrajectory,
        joint_names: Sequence[str],
        duration: float,
        rate: float,
    ) -> SampledTrajectory:
        """Samples ``trajectory`` at ``rate`` [Hz] on [0, duration], both ends."""
        count = round(duration * rate)
        t = np.arange(count + 1) / rate
        q, v, a = trajectory.evaluate(t)
        return cls(t, q, v, a, tuple(joint_names))


def write_trajectory(path: str | os.PathLike, trajectory: SampledTrajectory) -> None:
    """Writes the CSV above (17 significant digits)."""
    if not isinstance(trajectory, SampledTrajectory):
        raise TypeError(
            "write_trajectory: trajectory must be a SampledTrajectory; got "
            f"{type(trajectory).__name__}."
        )
    names = trajectory.joint_names
    header = ["t"] + [f"{kind}_{j}" for kind in ("q", "v", "a") for j in names]
    data = np.column_stack([trajectory.t, trajectory.q, trajectory.v, trajectory.a])

    def write(stream):
        stream.write(",".join(header) + "\n")
        np.savetxt(stream, data, delimiter=",", fmt="%.17g")

    write_whole(path, write)  # a full disk leaves no truncated file


def read_trajectory(
    path: str | os.PathLike, joint_names: Sequence[str]
) -> SampledTrajectory:
    """Reads a trajectory CSV (or a coefficient JSON, sampled at 100 Hz).

    Raises:
        ValueError: missing file or column, non-numeric or non-finite values,
            times not strictly increasing, fewer than 2 samples.
    """
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"trajectory {file}: no such file.")
    if file.suffix.lower() == ".json":
        trajectory, names, duration = read_coefficients(file)
        if tuple(names) != tuple(joint_names):
            raise ValueError(
                f"trajectory {file}: its joints {listed(names)} are not the "
                f"robot's {listed(joint_names)}."
            )
        sampled = SampledTrajectory.from_fourier(trajectory, names, duration, 100.0)
        return _within_bounds(file, sampled)
    # UTF-8 with a byte-order mark accepted (as logs); other encodings named.
    lines = utf8_text(file.read_bytes(), f"trajectory {file}").splitlines()
    header = [cell.strip() for cell in lines[0].split(",")] if lines else []
    wanted = ["t", *(f"{k}_{j}" for k in ("q", "v") for j in joint_names)]
    missing = [name for name in wanted if name not in header]
    if missing:
        raise ValueError(
            f"trajectory {file}: missing column(s) {listed(missing)}; the header "
            f"must hold t, q_<joint> and v_<joint> for the joints "
            f"{listed(joint_names)} (a_<joint> optional)."
        )
    try:
        with warnings.catch_warnings():  # "input contained no data": said below
            warnings.simplefilter("ignore", UserWarning)
            data = np.loadtxt(lines[1:], delimiter=",", ndmin=2, dtype=float)
    except ValueError:
        _name_the_bad_cell(file, header, lines)
    if data.shape[0] < 2 or data.shape[1] != len(header):
        raise ValueError(
            f"trajectory {file}: needs at least 2 rows of {len(header)} numbers; "
            + ("got no data rows." if data.size == 0 else f"got shape {data.shape}.")
        )

    def columns(kind: str) -> np.ndarray:
        names = [f"{kind}_{j}" for j in joint_names]
        if kind == "a" and any(name not in header for name in names):
            return np.full((data.shape[0], len(joint_names)), np.nan)
        return data[:, [header.index(name) for name in names]]

    t, q, v = data[:, header.index("t")], columns("q"), columns("v")
    for name, values in (("t", t[:, None]), ("q", q), ("v", v)):
        bad = np.flatnonzero(~np.all(np.isfinite(values), axis=1))
        if bad.size:
            raise ValueError(
                f"trajectory {file}: row {int(bad[0]) + 2} has an empty or "
                f"non-finite {name} value."
            )
    if np.any(np.diff(t) <= 0.0):
        row = int(np.flatnonzero(np.diff(t) <= 0.0)[0]) + 3
        raise ValueError(
            f"trajectory {file}: time is not strictly increasing at row {row}."
        )
    return _within_bounds(
        file, SampledTrajectory(t, q, v, columns("a"), tuple(joint_names))
    )


def _within_bounds(file: Path, trajectory: SampledTrajectory) -> SampledTrajectory:
    """``trajectory`` when its finite |q|, |v|, |a| are <= 1e100, else a ValueError.

    A coefficient file's base_frequency_hz of 1e-300 made q = 7e298 rad (its
    amplitudes a/(l·2π·f0)): simulate wrote that log with exit code 0.
    """
    from drake_dynid.core._validate import MAX_LOG_MAGNITUDE

    for name, values in (("q", trajectory.q), ("v", trajectory.v), ("a", trajectory.a)):
        finite = np.abs(values[np.isfinite(values)])
        if finite.size and float(finite.max()) > MAX_LOG_MAGNITUDE:
            raise ValueError(
                f"trajectory {file}: |{name}| reaches {float(finite.max()):.3g}, above "
                f"{MAX_LOG_MAGNITUDE:g} [SI units]: check its "
                + (
                    "coefficients (base_frequency_hz, a, b)."
                    if file.suffix.lower() == ".json"
                    else "units."
                )
            )
    return trajectory


def _name_the_bad_cell(file: Path, header: list[str], lines: list[str]) -> NoReturn:
    """Raises naming the first row (a line of the file) numpy could not read."""
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != len(header):
            raise ValueError(
                f"trajectory {file}: row {number} has {len(cells)} cells; the header "
                f"has {len(header)}."
            )
        for name, cell in zip(header, cells, strict=True):
            try:
                float(cell)
            except ValueError:
                raise ValueError(
                    f"trajectory {file}: row {number}, column {name!r}: "
                    f"{cell.strip()!r} is not a number."
                ) from None
    raise ValueError(f"trajectory {file}: not a numeric CSV.")


def write_coefficients(
    path: str | os.PathLike,
    trajectory: FourierTrajectory,
    joint_names: Sequence[str],
    duration: float,
    extra: dict[str, Any] | None = None,
) -> None:
    """Writes the Fourier coefficients (and ``extra`` keys) as JSON.

    Keys: ``joints``, ``base_frequency_hz``, ``harmonics``, ``duration``, ``q0``
    (n), ``a`` and ``b`` (n × H) [rad/s], the series of
    ``drake_dynid.core.trajectory.FourierTrajectory``.
    """
    document = {
        "joints": list(joint_names),
        "base_frequency_hz": trajectory.base_frequency / (2.0 * math.pi),
        "harmonics": trajectory.harmonics,
        "duration": float(duration),
        "q0": trajectory.q0.tolist(),
        "a": trajectory.a.tolist(),
        "b": trajectory.b.tolist(),
        "series": (
            "q_j(t) = q0_j + sum_l [a_jl/(l w) sin(l w t) - b_jl/(l w) cos(l w t)], "
            "w = 2 pi base_frequency_hz"
        ),
        **(extra or {}),
    }
    write_text_whole(path, json_text(document))


def read_coefficients(
    path: str | os.PathLike,
) -> tuple[FourierTrajectory, tuple[str, ...], float]:
    """Reads :func:`write_coefficients` JSON: (trajectory, joint names, duration)."""
    file = Path(path)
    try:
        document = json.loads(file.read_text())
        owner = "read_coefficients"
        frequency = real(
            owner, "base_frequency_hz", document["base_frequency_hz"], "Hz"
        )
        duration = real(owner, "duration", document["duration"], "s")
        if not 0.0 < duration <= MAX_DURATION:
            raise ValueError(
                f"{owner}: duration must be in (0, {MAX_DURATION:g}] [s] (at most "
                f"{MAX_DURATION * 100:g} samples at 100 Hz); got {duration:g}"
            )
        trajectory = FourierTrajectory(
            np.asarray(document["q0"], dtype=float),
            np.asarray(document["a"], dtype=float),
            np.asarray(document["b"], dtype=float),
            2.0 * math.pi * frequency,
        )
        joints = document["joints"]
        if not (
            isinstance(joints, list)
            and joints
            and all(isinstance(name, str) and name for name in joints)
        ):
            raise ValueError(
                f"{owner}: joints must be a list of joint names; got {joints!r}"
            )
        harmonics = document.get("harmonics", trajectory.harmonics)
        if harmonics != trajectory.harmonics or isinstance(harmonics, bool):
            raise ValueError(
                f"{owner}: harmonics ({harmonics!r}) must be the columns of a and b "
                f"({trajectory.harmonics})"
            )
        return trajectory, tuple(joints), duration
    except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as error:
        raise ValueError(
            f"trajectory coefficients {file}: unreadable ({error}); expected the "
            "JSON written by dynid excite --json."
        ) from None
