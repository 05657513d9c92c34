"""Drive chains: motors, gears, currents and coupled joints (docs/DRIVE.md).

n identified joints (URDF names, in the given order) are driven by m motors through a
constant coupling matrix R (m × n) [motor rad (or m) per joint rad (or m)]::

    q_m = R q + c,      v_m = R v,      τ = Rᵀ τ_m,      τ_m = k_t i

R = diag(gear ratios) for simple transmissions (negative ratios flip the direction);
a coupled motor's row has several non-zeros (Stäubli TX40 wrist: motor 6 turns with
q5 + q6, row N6·[e5 + e6], so τ5 = N5 τ_m5 + N6 τ_m6). τ = Rᵀ τ_m is the power balance
τ_mᵀ v_m = τᵀ v. A motor-side encoder gives q = R⁻¹(q_m - offset) (m = n, R
invertible); a current i [A] gives τ_m = k_t i with the motor's torque constant
k_t [N·m/A] (negative allowed).

``DriveChain.from_dict`` builds the chain from a parsed TOML drive file (format in
docs/DRIVE.md), validating every field against the joint names; ``read_drive`` reads
the file. Joints without a motor get an implicit direct drive (ratio 1, named after
the joint). Motors are numbered by the joints they drive (their sorted joint indices,
compared lexicographically, so a simple motor of joint 5 comes before a motor of
joints 5 and 6; ties: URDF transmissions, then ``[motors.NAME]`` tables in file
order, then ``[coupling].motors``), so that the k of the coupled-motor columns
``IAmk`` is the usual motor number. ``DriveChain.convert`` maps raw named log
columns to joint space; the motor regressor columns are in
``drake_dynid.core.drive_columns``. Pure numpy and the standard library (tomllib).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core._validate import listed
from drake_dynid.core.drive_log import LogFormat, check_table, parse_log
from drake_dynid.core.drive_motors import Motor, resolve_motors

__all__ = ["DriveChain", "JointSignals", "Motor", "read_drive"]

_TOP_KEYS = ("log", "motors", "coupling")


class JointSignals(NamedTuple):
    """Joint-space signals converted from a log.

    Attributes:
        t: (N,) time stamps [s].
        q: (N, n) joint positions [rad or m].
        tau: (N, n) joint torques [N·m or N].
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray


@dataclass(frozen=True, eq=False)
class DriveChain:
    """The drive chain of a robot: motors, coupling matrix R and the log format.

    Build it with :meth:`from_dict` or :func:`read_drive`. Everything is SI inside;
    the log format converts raw columns (:meth:`convert`).

    Attributes:
        joint_names: the n identified joints, in the order of q and τ.
        prismatic: (n,) True for a prismatic joint (length units), else revolute.
        motors: the m motors, numbered by the joints they drive (module docstring).
        log: the log format (columns, units, sides, position offsets).
        source: the owner named in error messages (e.g. ``drive file robot.toml``).
        notes: what the resolution decided that a user should know, one sentence
            each (URDF motors replaced by the drive file, URDF warnings).
    """

    joint_names: tuple[str, ...]
    prismatic: tuple[bool, ...]
    motors: tuple[Motor, ...]
    log: LogFormat
    source: str = "DriveChain"
    notes: tuple[str, ...] = ()

    # ---------------------------------------------------------------- building
    @classmethod
    def from_dict(
        cls,
        data: Mapping[str, Any],
        joint_names: Sequence[str],
        *,
        prismatic_joints: Collection[str] = (),
        urdf: Mapping[str, Any] | None = None,
        source: str = "DriveChain",
    ) -> DriveChain:
        """Validates a parsed drive file and resolves it against the joints.

        Args:
            data: the parsed TOML (tables ``log``, ``motors``, ``coupling``; all
                optional: ``{}`` is the identity drive of today's CSV format).
            joint_names: the identified joints (URDF names), in the order wanted for
                q and τ.
            prismatic_joints: the names of the prismatic ones (length units).
            urdf: transmissions read from the URDF, ``{"motors": {name: {"joints":
                {joint: ratio}, "rotor_inertia": Ia}}}`` (``drive_urdf``). The drive
                file overrides them: a ``[motors.NAME]`` table of the same name
                overrides field by field (a new joint/joints/gear_ratio replaces the
                row), and a URDF motor driving a joint that the drive file's rows
                mention is dropped. With ``"joints"`` (every joint of the URDF), a
                drive-file motor of joints outside ``joint_names`` only is
                skipped: a drive file of the whole robot serves any ``--joints``.
            source: the owner named in error messages.

        Raises:
            ValueError: unknown key, joint or unit, zero ratio, rank-deficient R,
                missing torque constant with currents, ... (the message names the
                field). TypeError: a value of the wrong type.
        """
        names = tuple(joint_names)
        if not names or not all(isinstance(x, str) for x in names):
            raise TypeError(f"{source}: joint_names must be a non-empty list of names.")
        if len(set(names)) != len(names):
            duplicated = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(
                f"{source}: joint_names has duplicates: {listed(duplicated)}."
            )
        unknown = sorted(set(prismatic_joints) - set(names))
        if unknown:
            raise ValueError(
                f"{source}: prismatic_joints: unknown joint(s) {listed(unknown)}."
            )
        check_table(source, "the drive file", data, _TOP_KEYS)
        prismatic = tuple(name in set(prismatic_joints) for name in names)
        motors, notes, outside = resolve_motors(source, data, names, prismatic, urdf)
        log = parse_log(source, data.get("log", {}), names, prismatic, motors, outside)
        chain = cls(names, prismatic, motors, log, source, notes)
        chain._check_log()
        return chain

    def _check_log(self) -> None:
        log, owner = self.log, self.source
        if log.current_scale is not None:
            missing = [mo.name for mo in self.motors if mo.torque_constant is None]
            if missing:
                implicit = [mo.name for mo in self.motors if mo.source == "implicit"]
                urdf = [mo.name for mo in self.motors if mo.source == "URDF"]
                hint = (
                    f" ({listed(implicit)}: implicit direct drive(s) of joints "
                    "without a motor; add a [motors.NAME] table)"
                    if implicit
                    else ""
                )
                if urdf:
                    joints = sorted(
                        {
                            self.joint_names[j]
                            for mo in self.motors
                            if mo.name in urdf
                            for j in np.flatnonzero(mo.row)
                        }
                    )
                    which = (
                        "these are" if len(urdf) == len(missing) else f"{listed(urdf)}:"
                    )
                    hint += (
                        f" ({which} the URDF's transmissions, which the drive file "
                        "does not describe: give them a torque_constant, or "
                        f"identify without {listed(joints)} (dynid --joints))"
                    )
                raise ValueError(
                    f"{owner}: log.torque_unit = {log.torque_unit!r} (motor "
                    "currents) needs torque_constant [N·m/A] for every motor; "
                    f"missing for {listed(missing)}{hint}."
                )

    # -------------------------------------------------------------- properties
    @property
    def num_joints(self) -> int:
        """Number of identified joints n."""
        return len(self.joint_names)

    @property
    def num_motors(self) -> int:
        """Number of motors m."""
        return len(self.motors)

    @property
    def motor_names(self) -> tuple[str, ...]:
        """Motor names, in motor order (1-based motor number k = index + 1)."""
        return tuple(motor.name for motor in self.motors)

    @property
    def coupling(self) -> np.ndarray:
        """The coupling matrix R, (m, n): v_m = R v, τ = Rᵀ τ_m."""
        out = np.array([motor.row for motor in self.motors])
        out.setflags(write=False)
        return out

    @property
    def coupled_motors(self) -> tuple[int, ...]:
        """0-based indices of the motors that drive several joints."""
        return tuple(k for k, motor in enumerate(self.motors) if motor.coupled)

    @property
    def identity(self) -> bool:
        """True when :meth:`convert` changes no number (only picks columns).

        R = I, joint-side positions and torques in SI units, no position offsets,
        time in seconds kept as logged.
        """
        log = self.log
        return (
            self.num_motors == self.num_joints
            and np.array_equal(self.coupling, np.eye(self.num_joints))
            and log.position_side == log.torque_side == "joint"
            and log.current_scale is None
            and log.time_scale == 1.0
            and log.time_origin == "log"
            and bool(np.all(log.position_scale == 1.0))
            and not np.any(log.position_offset)
        )

    def summary(self) -> dict[str, Any]:
        """A JSON-ready description (for result files and ``--json`` settings)."""
        log = self.log
        motors = []
        names = self.joint_names
        for k, motor in enumerate(self.motors):
            entry: dict[str, Any] = {
                "number": k + 1,
                "name": motor.name,
                "joints": {names[j]: float(motor.row[j]) for j in motor.joints},
                "source": motor.source,
            }
            for key in (
                "torque_constant",
                "rotor_inertia",
                "viscous",
                "coulomb",
                "offset",
            ):
                value = getattr(motor, key)
                if value is not None:
                    entry[key] = value
            motors.append(entry)
        return {
            "source": self.source,
            "joints": list(self.joint_names),
            "motors": motors,
            "log": {
                "time": log.time,
                "time_unit": log.time_unit,
                "position_side": log.position_side,
                "angle_unit": log.angle_unit,
                "length_unit": log.length_unit,
                "torque_side": log.torque_side,
                "torque_unit": log.torque_unit,
            },
            "notes": list(self.notes),
        }

    # ------------------------------------------------------- a-priori values
    def reflected_inertia(self) -> np.ndarray:
        """A-priori IAj [kg·m² or kg], (n,): Σ_k R_kj² Ia_k over simple motors.

        A motor that drives one joint j contributes its rotor inertia reflected to
        the joint (IAj = N² Ia); coupled motors have their own columns
        (``drive_columns``). Unknown rotor inertias count as 0.
        """
        out = np.zeros(self.num_joints)
        for motor in self.motors:
            if not motor.coupled and motor.rotor_inertia is not None:
                out += motor.row**2 * motor.rotor_inertia
        return out

    def reflected_friction(self) -> dict[str, np.ndarray]:
        """A-priori joint friction from the simple motors, per kind, each (n,).

        A motor driving joint j alone with ratio N adds to joint j's columns
        (Rᵀ of its friction torque): ``viscous`` N² fv, ``coulomb`` |N| fc,
        ``offset`` N off. Add these to the joint-side values (URDF damping,
        friction). Unknown values count as 0.
        """
        out = {kind: np.zeros(self.num_joints) for kind in ("viscous", "coulomb")}
        out["offset"] = np.zeros(self.num_joints)
        for motor in self.motors:
            if motor.coupled:
                continue
            row = motor.row
            out["viscous"] += row**2 * (motor.viscous or 0.0)
            out["coulomb"] += np.abs(row) * (motor.coulomb or 0.0)
            out["offset"] += row * (motor.offset or 0.0)
        return out

    # ------------------------------------------------------------ conversion
    def positions_only(self) -> DriveChain:
        """This chain without its torque columns: :meth:`convert` gives τ = 0.

        For what needs the motion only (``dynid replay``): a log without effort
        columns is read, and its torques are not made up (zeros, never used).
        """
        log = dataclasses.replace(self.log, torque_names=(), torque_columns=())
        return dataclasses.replace(self, log=log)

    def required_columns(self) -> tuple[str, ...]:
        """The log columns :meth:`convert` needs: time, positions, torques."""
        log = self.log
        return (log.time, *log.position_columns, *log.torque_columns)

    def convert(
        self, columns: Mapping[str, Any], *, first_stamp: float | None = None
    ) -> JointSignals:
        """Converts raw named log columns to joint space.

        t = s_t (t_raw - t_raw[0]·[origin = first]);  position side ``joint``:
        q = s (p - offset); side ``motor``: q = R⁻¹ s (p_m - offset); torque side
        ``joint``: τ = τ_raw; side ``motor``: τ = Rᵀ τ_m with τ_m = τ_raw (SI) or
        τ_m = k_t s_i i (currents). s are the unit scales (deg -> rad, ...). NaN
        cells stay NaN (a motor-side NaN spreads to the joints it drives).

        Args:
            columns: ``{column name: (N,) array}``, at least
                :meth:`required_columns` (extra columns are not looked at).
            first_stamp: the raw first stamp of the whole log, when ``columns``
                are a block of it (the time origin ``first``; default: the
                block's own first stamp).

        Returns:
            ``JointSignals(t, q, tau)``: (N,) [s], (N, n) [rad or m], (N, n) [N·m
            or N], in ``joint_names`` order.
        """
        owner, log = self.source, self.log
        missing = [name for name in self.required_columns() if name not in columns]
        if missing:
            raise ValueError(
                f"{owner}: the log has no column(s) {listed(map(repr, missing))}; "
                "fix the log or the [log] table of the drive file."
            )
        data = {}
        for name in self.required_columns():
            array = np.asarray(columns[name], dtype=float)
            if array.ndim != 1:
                raise ValueError(
                    f"{owner}: log column {name!r} must be 1-D; got shape "
                    f"{array.shape}."
                )
            data[name] = array
        lengths = {array.shape[0] for array in data.values()}
        if len(lengths) > 1:
            raise ValueError(
                f"{owner}: log columns must have the same length; got "
                f"{sorted(lengths)}."
            )
        t = data[log.time]
        if log.time_origin == "first" and t.size:
            t = t - (t[0] if first_stamp is None else float(first_stamp))
        t = t * log.time_scale
        raw_q = np.column_stack([data[c] for c in log.position_columns])
        position = (raw_q - log.position_offset) * log.position_scale
        if log.position_side == "motor":
            position = np.linalg.solve(self.coupling, position.T).T
        if not log.torque_columns:  # positions_only
            return JointSignals(t, position, np.zeros(position.shape))
        raw_tau = np.column_stack([data[c] for c in log.torque_columns])
        if log.torque_side == "joint":
            tau = raw_tau
        else:
            tau_m = raw_tau
            if log.current_scale is not None:
                constants = np.array([mo.torque_constant for mo in self.motors])
                tau_m = raw_tau * (log.current_scale * constants)
            tau = tau_m @ self.coupling
        return JointSignals(t, position, tau)

    def to_columns(self, t, q, tau) -> dict[str, np.ndarray]:
        """The inverse of :meth:`convert`: joint signals -> raw named log columns.

        With more motors than joints the motor torques are the minimum-norm
        solution of τ = Rᵀ τ_m. Used to write motor-side logs and in tests.
        """
        log = self.log
        t = np.asarray(t, dtype=float) / log.time_scale
        q = np.atleast_2d(np.asarray(q, dtype=float))
        tau = np.atleast_2d(np.asarray(tau, dtype=float))
        if log.position_side == "motor":
            q = q @ self.coupling.T
        position = q / log.position_scale + log.position_offset
        if log.torque_side == "motor":
            tau = np.linalg.lstsq(self.coupling.T, tau.T, rcond=None)[0].T
            if log.current_scale is not None:
                constants = np.array([mo.torque_constant for mo in self.motors])
                tau = tau / (log.current_scale * constants)
        out = {log.time: t}
        out.update(zip(log.position_columns, position.T, strict=True))
        out.update(zip(log.torque_columns, tau.T, strict=True))
        return out


def read_drive(
    path: str | os.PathLike,
    joint_names: Sequence[str],
    *,
    prismatic_joints: Collection[str] = (),
    urdf: Mapping[str, Any] | None = None,
) -> DriveChain:
    """Reads a TOML drive file (docs/DRIVE.md) and resolves it (see from_dict).

    Raises:
        FileNotFoundError: no such file (IsADirectoryError: a folder).
        ValueError: not UTF-8, not TOML, or an invalid field or field type (the
            message starts with ``drive file <path>:`` and names the field).
    """
    import tomllib  # standard library since Python 3.11

    path = os.fspath(path)
    if os.path.isdir(path):
        raise IsADirectoryError(f"drive file {path}: is a directory, expected a file.")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"drive file {path}: no such file.")
    with open(path, "rb") as stream:
        raw = stream.read()
    text = _validate.utf8_text(raw, f"drive file {path}")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"drive file {path}: not valid TOML: {error}.") from None
    try:
        return DriveChain.from_dict(
            data,
            joint_names,
            prismatic_joints=prismatic_joints,
            urdf=urdf,
            source=f"drive file {path}",
        )
    except TypeError as error:  # a field of the wrong type: bad input, named
        raise ValueError(str(error)) from None
