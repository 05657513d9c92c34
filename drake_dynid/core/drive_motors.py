"""The ``[motors]`` and ``[coupling]`` tables of a drive file (docs/DRIVE.md).

Each motor k has a row R_k of the coupling matrix R (m × n), v_m = R v. A table
``[motors.NAME]`` gives either ``joint = "j"`` and ``gear_ratio = N`` (a simple drive,
row N·e_j) or ``joints = {a = Na, b = Nb}`` (a coupled motor); ``[coupling]`` gives
whole rows as a matrix. Motors read from URDF transmissions (``drake_dynid.drive_urdf``)
are the base that the drive file overrides: a table of the same name overrides field
by field, and a URDF motor driving a joint that a drive-file row mentions is dropped.
Joints without any motor get an implicit direct drive (row e_j, named after the
joint). ``resolve_motors`` validates all this (messages name the field) and returns
the motors numbered by the first joint they drive. Pure numpy.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, NoReturn

import numpy as np

from drake_dynid.core._validate import listed
from drake_dynid.core.drive_log import check_table, real

__all__ = ["Motor", "resolve_motors"]

_MOTOR_KEYS = (
    "joint",
    "gear_ratio",
    "joints",
    "torque_constant",
    "rotor_inertia",
    "viscous",
    "coulomb",
    "offset",
    "linear",
)
#: Motor properties and their units (rotary motor; a linear motor uses N and m).
_MOTOR_PROPERTIES = MappingProxyType(
    {
        "torque_constant": ("N*m/A", "nonzero"),
        "rotor_inertia": ("kg*m^2", "nonnegative"),
        "viscous": ("N*m*s/rad", "nonnegative"),
        "coulomb": ("N*m", "nonnegative"),
        "offset": ("N*m", None),
    }
)
_URDF_MOTOR_KEYS = ("joints", "rotor_inertia")
_COUPLING_KEYS = ("motors", "joints", "matrix")
#: Relative singular-value tolerance of the rank test on R.
_RANK_TOLERANCE = 1e-9


@dataclass(frozen=True, eq=False)
class Motor:
    """One motor of a drive chain (motor-side values, SI units).

    Attributes:
        name: the motor name (an implicit direct drive is named after its joint).
        row: (n,) read-only row of R: motor position per joint position.
        torque_constant: k_t [N·m/A] (N/A for a linear motor), or None.
        rotor_inertia: Ia [kg·m²] (kg for a linear motor), or None.
        viscous: motor-side viscous friction [N·m·s/rad], or None.
        coulomb: motor-side Coulomb friction [N·m], or None.
        offset: motor-side torque offset [N·m], or None.
        linear: a linear motor (positions in the length unit), else rotary; None:
            not said, for a motor of a prismatic joint with a ratio other than
            ±1 (a screw in rad/m or a lever in m/m): motor-side positions then
            need it said (``core.drive_log``).
        source: where it was described ("drive", "URDF", "URDF + drive",
            "implicit").
    """

    name: str
    row: np.ndarray
    torque_constant: float | None = None
    rotor_inertia: float | None = None
    viscous: float | None = None
    coulomb: float | None = None
    offset: float | None = None
    linear: bool | None = False
    source: str = "drive"

    @property
    def joints(self) -> tuple[int, ...]:
        """0-based indices of the joints this motor drives (non-zeros of its row)."""
        return tuple(int(j) for j in np.flatnonzero(self.row))

    @property
    def coupled(self) -> bool:
        """True when the motor drives several joints (a row with several non-zeros)."""
        return len(self.joints) > 1


def _row_text(row: Mapping[str, float]) -> str:
    return "{" + ", ".join(f"{j} = {r:g}" for j, r in row.items()) + "}"


#: Magnitudes accepted for a gear ratio [motor rad per joint rad, or per m]: real
#: rotary drives lie within 1e-3 … 1e4, screws up to about 1e6 rad/m (a 1 mm lead
#: behind a 160:1 gear); 1e300 made the coupling matrix lose its rank to
#: round-off ("singular coupling"), so the message names the ratio instead.
RATIO_RANGE = (1e-9, 1e9)


#: Magnitudes accepted for a torque constant [N·m/A, or N/A]: real motors lie within
#: 1e-3 … 1e3; 1e-320 made every simulated current inf (i = τ_m / k_t), written
#: to the log with exit code 0.
TORQUE_CONSTANT_RANGE = (1e-9, 1e9)


class _Builder:
    """Validates the drive dict and resolves the motors (see DriveChain.from_dict)."""

    def __init__(self, owner: str, joint_names: tuple[str, ...]) -> None:
        self.owner = owner
        self.joint_names = joint_names
        self.index = {name: j for j, name in enumerate(joint_names)}
        self.notes: list[str] = []
        self.locked: set[str] = set()
        self.urdf_joints: set[str] = set()  # every joint of the URDF, when known
        self.skipped: list[str] = []  # motors of joints outside --joints only

    def fail(self, message: str) -> NoReturn:
        raise ValueError(f"{self.owner}: {message}")

    def joint(self, field: str, name: Any) -> int:
        if not isinstance(name, str):
            raise TypeError(f"{self.owner}: {field} must be a joint name (a string).")
        if name not in self.index:
            if name in self.urdf_joints:
                self.fail(
                    f"{field}: joint {name!r} is not identified (--joints) but this "
                    "motor also drives identified joints; identify it too, or "
                    f"describe the motor without it. Identified: "
                    f"{listed(self.joint_names)}."
                )
            self.fail(
                f"{field}: unknown joint {name!r}; the identified joints are "
                f"{listed(self.joint_names)}."
            )
        return self.index[name]

    def ratio(self, field: str, value: Any) -> float:
        out = real(self.owner, field, value)
        if out == 0.0:
            self.fail(f"{field} must be non-zero [motor rad per joint rad]; got 0.")
        if not RATIO_RANGE[0] <= abs(out) <= RATIO_RANGE[1]:
            self.fail(
                f"{field} must be within ±{RATIO_RANGE[0]:g} … ±{RATIO_RANGE[1]:g} "
                "[motor rad per joint rad, or per m for a prismatic joint] (a gear "
                f"ratio); got {out:g}."
            )
        return out

    def row_from_table(self, field: str, table: Any) -> dict[str, float]:
        if not isinstance(table, Mapping) or not table:
            self.fail(
                f"{field} must be a non-empty table {{joint = ratio, ...}}; "
                f"got {table!r}."
            )
        row = {}
        for name, value in table.items():
            self.joint(f"{field}.{name}", name)
            row[name] = self.ratio(f"{field}.{name}", value)
        return row

    def coupling(self, table: Any) -> dict[str, dict[str, float]]:
        check_table(self.owner, "coupling", table, _COUPLING_KEYS, required=True)
        motors, joints = table["motors"], table["joints"]
        for field, names in (("coupling.motors", motors), ("coupling.joints", joints)):
            if (
                not isinstance(names, list)
                or not names
                or not all(isinstance(x, str) for x in names)
            ):
                self.fail(f"{field} must be a non-empty list of names; got {names!r}.")
            if len(set(names)) != len(names):
                self.fail(f"{field} has duplicated names: {names!r}.")
        for k, name in enumerate(joints):
            if name not in self.urdf_joints:  # a URDF joint outside --joints: by row
                self.joint(f"coupling.joints[{k}]", name)
        try:
            matrix = np.array(table["matrix"], dtype=float)
        except (TypeError, ValueError):
            raise TypeError(
                f"{self.owner}: coupling.matrix must be a list of rows of numbers."
            ) from None
        shape = (len(motors), len(joints))
        if matrix.shape != shape:
            self.fail(
                f"coupling.matrix must have shape (len(motors), len(joints)) = "
                f"{shape}; got {matrix.shape}."
            )
        if not np.all(np.isfinite(matrix)):
            self.fail("coupling.matrix must be finite.")
        out = {}
        for k, motor in enumerate(motors):
            # Each entry as a gear ratio: a number (numpy reads "40" and true as
            # numbers), 0 or within RATIO_RANGE.
            row = {
                j: self.ratio(f"coupling.matrix[{k}][{i}] ({motor!r}, {j!r})", r)
                for i, (j, r) in enumerate(zip(joints, table["matrix"][k], strict=True))
                if isinstance(r, (str, bool)) or r
            }
            if not row:
                self.fail(f"coupling.matrix row {k} (motor {motor!r}) is all zeros.")
            outside = [j for j in row if j not in self.index]
            if len(outside) == len(row):  # as a [motors] table's (not_identified)
                self.notes.append(
                    f"coupling.motors[{k}] ({motor!r}) drives {listed(outside)}, "
                    "not identified (--joints): skipped."
                )
                self.skipped.append(str(motor))
                continue
            for j in outside:  # a row mixing identified and other joints
                self.joint(f"coupling.matrix[{k}] ({motor!r}, {j!r})", j)
            out[motor] = row
        return out

    def properties(self, field: str, table: Mapping[str, Any]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for key, (unit, constraint) in _MOTOR_PROPERTIES.items():
            if key not in table:
                continue
            value = real(self.owner, f"{field}.{key}", table[key], unit)
            if constraint == "nonzero" and value == 0.0:
                self.fail(f"{field}.{key} must be non-zero [{unit}]; got 0.")
            low, high = TORQUE_CONSTANT_RANGE
            if key == "torque_constant" and not low <= abs(value) <= high:
                self.fail(
                    f"{field}.{key} must be within ±{low:g} … ±{high:g} [{unit}, or "
                    f"N/A for a linear motor]; got {value:g}."
                )
            if constraint == "nonnegative" and value < 0.0:
                self.fail(f"{field}.{key} must be >= 0 [{unit}]; got {value}.")
            out[key] = value
        if "linear" in table:
            if not isinstance(table["linear"], bool):
                raise TypeError(
                    f"{self.owner}: {field}.linear must be true or false; got "
                    f"{table['linear']!r}."
                )
            out["linear"] = table["linear"]
        return out

    def urdf_motors(
        self, urdf: Mapping[str, Any], rewritten: Collection[str] = ()
    ) -> dict[str, dict[str, Any]]:
        """URDF motors touching identified joints: name -> {row, rotor_inertia}.

        ``rewritten``: the motors whose row the drive file gives anew (``joint``
        or ``joints``): a URDF row that mixes identified and non-identified
        joints is then not an error (the TIAGo's differential wrist, identified
        up to arm_6 with the drive file's simple rows).
        """
        check_table(self.owner, "urdf", urdf, ("motors", "joints"))
        out = {}
        for name, table in dict(urdf.get("motors", {})).items():
            field = f"URDF actuator {name}"
            check_table(self.owner, field, table, _URDF_MOTOR_KEYS)
            row = {str(j): float(r) for j, r in dict(table["joints"]).items() if r}
            inside = [j for j in row if j in self.index]
            if not inside:
                self.locked.add(name)  # drives only non-identified (locked) joints
                continue
            if len(inside) != len(row) and name in rewritten:
                outside = sorted(set(row) - set(inside))
                self.notes.append(
                    f"URDF actuator {name} {_row_text(row)} (it also drives "
                    f"{listed(outside)}, not identified) gets the drive file's row."
                )
                continue  # the drive file's own row replaces it
            if len(inside) != len(row):
                outside = sorted(set(row) - set(inside))
                self.fail(
                    f"{field} drives identified joints {listed(inside)} and "
                    f"non-identified ones {listed(outside)}; identify all of them "
                    "or describe this motor in the drive file."
                )
            entry: dict[str, Any] = {"row": row, "source": "URDF"}
            entry.update(self.properties(field, table))
            out[name] = entry
        return out

    def not_identified(self, table: Mapping[str, Any], urdf: Any) -> list[str] | None:
        """The joints of a motor that drives only URDF joints outside ``--joints``.

        Such a motor is skipped (a drive file of the whole robot serves a subset of
        its joints). None when the motor drives an identified joint, or a name the
        URDF does not have (a typo: :meth:`joint` names it).
        """
        if not self.urdf_joints:
            return None
        if "joint" in table:
            named = [table["joint"]]
        elif isinstance(table.get("joints"), Mapping):
            named = list(table["joints"])
        else:
            return None
        if named and all(
            isinstance(j, str) and j in self.urdf_joints and j not in self.index
            for j in named
        ):
            return [str(j) for j in named]
        return None

    def motors(self, data: Mapping[str, Any], urdf: Mapping[str, Any] | None):
        tables = data.get("motors", {})
        rewritten = (
            [
                name
                for name, table in tables.items()
                if isinstance(table, Mapping)
                and ("joint" in table or "joints" in table)
            ]
            if isinstance(tables, Mapping)
            else []
        )
        urdf_motors = self.urdf_motors(urdf, rewritten) if urdf is not None else {}
        if urdf is not None:
            self.urdf_joints = {str(j) for j in urdf.get("joints", ())}
        tables = data.get("motors", {})
        if not isinstance(tables, Mapping):
            self.fail(
                f"motors must be a table of [motors.NAME] tables; got {tables!r}."
            )
        coupled = self.coupling(data["coupling"]) if "coupling" in data else {}
        drive: dict[str, dict[str, Any]] = {}
        for name, table in tables.items():
            field = f"motors.{name}"
            check_table(self.owner, field, table, _MOTOR_KEYS)
            ways = [k for k in ("joint", "joints") if k in table]
            ways += ["coupling"] if name in coupled or name in self.skipped else []
            if len(ways) > 1:
                self.fail(
                    f"{field}: give its joints one way only; got {' and '.join(ways)}."
                )
            if name in self.skipped:  # a skipped [coupling] motor's properties
                continue
            outside = self.not_identified(table, urdf)
            if outside is not None:
                self.notes.append(
                    f"{field} drives {listed(outside)}, not identified (--joints): "
                    "skipped."
                )
                self.skipped.append(str(name))
                continue
            if "gear_ratio" in table and "joint" not in table:
                base = urdf_motors.get(name, {}).get("row", {})
                if len(base) != 1:
                    self.fail(
                        f"{field}.gear_ratio needs joint = NAME (a simple drive); a "
                        "coupled motor gives its ratios in joints = {a = Na, b = Nb}."
                    )
                table = {**table, "joint": next(iter(base))}
            entry = self.properties(field, table)
            if "joint" in table:
                self.joint(f"{field}.joint", table["joint"])
                ratio = self.ratio(f"{field}.gear_ratio", table.get("gear_ratio", 1.0))
                entry["row"] = {table["joint"]: ratio}
            elif "joints" in table:
                entry["row"] = self.row_from_table(f"{field}.joints", table["joints"])
            elif name in coupled:
                entry["row"] = coupled[name]
            elif name not in urdf_motors:
                why = (
                    "the URDF actuator of that name drives only joints that are not "
                    "identified"
                    if name in self.locked
                    else "no URDF transmission has an actuator of that name"
                )
                self.fail(
                    f"{field} must give joint = NAME (and gear_ratio), joints = "
                    f"{{a = Na, ...}}, or appear in [coupling].motors ({why})."
                )
            drive[name] = entry
        for name, row in coupled.items():
            drive.setdefault(name, {"row": row})
        return self._merge(urdf_motors, drive)

    def _merge(self, urdf_motors, drive):
        """URDF motors, overridden by name and by the joints the drive file takes."""
        taken = {j for entry in drive.values() if "row" in entry for j in entry["row"]}
        sequence: list[tuple[str, dict[str, Any]]] = []
        for name, entry in urdf_motors.items():
            if name in drive:
                merged = {**entry, **drive.pop(name), "source": "URDF + drive"}
                if merged["row"] != entry["row"]:
                    self.notes.append(
                        f"URDF actuator {name} {_row_text(entry['row'])} gets the "
                        f"drive file's row {_row_text(merged['row'])}."
                    )
                sequence.append((name, merged))
            elif not taken & set(entry["row"]):
                sequence.append((name, entry))
            else:
                self.notes.append(
                    f"URDF actuator {name} {_row_text(entry['row'])} is replaced by "
                    f"the drive file, which describes joint(s) "
                    f"{listed(sorted(taken & set(entry['row'])))}."
                )
        sequence += [
            (name, {**entry, "source": "drive"}) for name, entry in drive.items()
        ]
        covered = {j for _, entry in sequence for j in entry["row"]}
        for name in self.joint_names:
            if name not in covered:
                sequence.append((name, {"row": {name: 1.0}, "source": "implicit"}))
        names = [name for name, _ in sequence]
        duplicated = sorted({name for name in names if names.count(name) > 1})
        if duplicated:
            self.fail(
                f"motor name(s) {listed(duplicated)} also name an implicit direct "
                "drive of a joint without a motor; rename the motor(s)."
            )
        driven = [sorted(self.index[j] for j in entry["row"]) for _, entry in sequence]
        order = sorted(range(len(sequence)), key=lambda k: driven[k])
        return [sequence[k] for k in order]


def _check_rank(builder: _Builder, coupling: np.ndarray, motors: list[Motor]) -> None:
    singular = np.linalg.svd(coupling, compute_uv=False)
    rank = int(np.sum(singular > _RANK_TOLERANCE * singular[0]))
    n = coupling.shape[1]
    if rank < n:
        rows = "; ".join(
            f"{mo.name}: "
            + _row_text({builder.joint_names[j]: mo.row[j] for j in mo.joints})
            for mo in motors
            if mo.coupled
        )
        alone = {mo.joints[0] for mo in motors if not mo.coupled}
        shared = [builder.joint_names[j] for j in range(n) if j not in alone]
        builder.fail(
            f"the coupling matrix R ({coupling.shape[0]} × {n}) must have rank {n} "
            f"(τ = Rᵀ τ_m must reach every joint); got rank {rank}, a singular "
            f"coupling. Coupled rows: {rows or 'none'}; joints without a motor of "
            f"their own: {listed(shared) or 'none'} (describe their motors)."
        )


def resolve_motors(
    owner: str,
    data: Mapping[str, Any],
    joint_names: tuple[str, ...],
    prismatic: tuple[bool, ...],
    urdf: Mapping[str, Any] | None = None,
) -> tuple[tuple[Motor, ...], tuple[str, ...], frozenset[str]]:
    """Validates ``[motors]``/``[coupling]`` (and the URDF motors) and resolves them.

    Args:
        owner: the name used in error messages.
        data: the parsed drive file (only ``motors`` and ``coupling`` are read).
        joint_names: the identified joints.
        prismatic: (n,) prismatic flags (an implicit drive of a prismatic joint, or
            a simple drive of ratio ±1 without ``linear``, is linear; another
            simple drive of a prismatic joint without ``linear`` has ``linear``
            None).
        urdf: ``{"motors": {name: {"joints": {joint: ratio}, "rotor_inertia":
            Ia}}, "joints": [every joint of the URDF]}`` from the URDF, or None. A
            drive-file motor that drives only URDF joints outside ``joint_names``
            is skipped (a note).

    Returns:
        ``(motors, notes, outside)``: the m motors, sorted by their sorted joint
        indices (lexicographically; ties: URDF, then ``[motors]`` tables in file
        order, then ``[coupling].motors``), R of rank n; one sentence per URDF
        motor whose row the drive file replaced; the names of the skipped motors
        and of the URDF joints outside ``joint_names`` (the ``[log]`` table's
        offsets and column tables may name them: ignored, as they are).
    """
    builder = _Builder(owner, joint_names)
    motors = []
    keys = ("torque_constant", "rotor_inertia", "viscous", "coulomb", "offset")
    for name, entry in builder.motors(data, urdf):
        row = np.zeros(len(joint_names))
        for joint, ratio in entry["row"].items():
            row[builder.index[joint]] = ratio
        row.setflags(write=False)
        single = [builder.index[j] for j in entry["row"]]
        # Without ``linear``: the direct drive (ratio ±1) of a prismatic joint is
        # a linear motor; another motor of a prismatic joint is ambiguous (None: a
        # rotary motor on a screw, rad/m, or a linear one through a lever, m/m),
        # which matters only for motor-side positions (core.drive_log asks).
        # Reviews found a 1256.6 rad/m screw's degrees read as millimetres, and a
        # 2 m/m linear drive's millimetres read as degrees.
        prismatic_single = len(single) == 1 and prismatic[single[0]]
        ratio = abs(next(iter(entry["row"].values())))
        default = (
            (True if abs(ratio - 1.0) <= 1e-12 else None) if prismatic_single else False
        )
        linear = entry.get("linear", default)
        motors.append(
            Motor(
                name=name,
                row=row,
                linear=None if linear is None else bool(linear),
                source=entry["source"],
                **{key: entry.get(key) for key in keys},
            )
        )
    _check_rank(builder, np.array([motor.row for motor in motors]), motors)
    outside = {*builder.skipped, *(builder.urdf_joints - set(joint_names))}
    return tuple(motors), tuple(builder.notes), frozenset(outside)
