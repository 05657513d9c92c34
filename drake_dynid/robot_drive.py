"""The drive chain inside a :class:`drake_dynid.robot.RobotModel` (docs/DRIVE.md §3).

A ``RobotModel`` built with a drive chain (``drive=``, a ``DriveChain`` or a TOML
drive file, ``drake_dynid.core.drive``) adds to the rigid-body model, through the
coupling matrix R (v_m = R v, τ = Rᵀ τ_m)::

    τ = τ_rigid(q, v, v̇) + Σ_k R_kᵀ [Ia_k R_k v̇ + Fv_k R_k v + Fc_k s(R_k v/ρ_k)]

Khalil's naming: a motor that drives one joint j is folded into joint j's columns
(``IAj`` = N² Ia with rotor inertia, its friction in ``FVj``/``FCj``/``OFFj``); a
coupled motor k gets the motor-side columns ``IAmk`` (with rotor inertia) and
``FVmk``/``FCmk``/``OFFmk`` (the friction kinds of the model), computed by
``drake_dynid.core.drive_columns``. Standard-column order: link blocks (with
``IAj``), mimic links, ``IAmk``, joint friction, motor friction.

This module builds that table (:func:`drive_table`): names, a-priori values (the
drive file's motor values; IAj from the simple motors' rotor inertia where given,
else the URDF's actuators; the simple motors' friction added to the URDF's joint
friction) and the column scales used by the base-parameter reduction. Motor
columns are in motor-side units, N² (or |N|) times a joint column, which with N =
336 would put the joint columns 1e5 below the largest and under the zero-column
tolerance; the reduction therefore runs on columns divided by these scales
(ρ_k² for IAmk and FVmk, ρ_k for FCmk and OFFmk) and :func:`rescale_base` maps
the result back (θ'_c = s_c θ_c).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core._validate import listed
from drake_dynid.core.base_parameters import BaseParameters
from drake_dynid.core.drive import DriveChain
from drake_dynid.core.drive_columns import MotorColumns, motor_columns
from drake_dynid.core.friction import DeadZoneSign, ExactSign, SignLaw
from drake_dynid.core.standstill import combined_widths

__all__ = ["DriveTable", "drive_table", "motor_sign", "rescale_base", "resolve_drive"]

_DECIMALS = 10  # significant digits of the regrouping coefficients (base_parameters)


@dataclass(frozen=True, eq=False)
class DriveTable:
    """The standard-parameter table of a model with a drive chain.

    Attributes:
        names: the standard names with the motor columns inserted.
        values: (p_std,) read-only a-priori values.
        columns: the coupled motors' columns (exact sign), or None without any.
        scales: (p_std,) column scales for the reduction (1 except motor columns).
        notes: remarks for ``RobotModel.notes``.
    """

    names: tuple[str, ...]
    values: np.ndarray
    columns: MotorColumns | None
    scales: np.ndarray
    notes: tuple[str, ...] = ()


def resolve_drive(
    drive: Any,
    urdf_path: str,
    joint_names: Sequence[str],
    prismatic: Sequence[bool],
) -> DriveChain | None:
    """The ``DriveChain`` of ``drive`` for these joints (None for None).

    Args:
        drive: None, a ``DriveChain`` (its joints must be ``joint_names`` in this
            order), or the path of a TOML drive file (resolved against the URDF's
            transmissions, ``drake_dynid.drive_urdf.load_drive``).
        urdf_path: the URDF ("" when the model was built from a plant).
        joint_names: the identified joints, in the model's order.
        prismatic: (n,) True for the prismatic ones.

    Raises:
        ValueError: a chain for other joints or joint types; a drive file without
            a URDF. TypeError: another type.
    """
    if drive is None:
        return None
    names = tuple(joint_names)
    if isinstance(drive, DriveChain):
        if drive.joint_names != names:
            raise ValueError(
                f"RobotModel: drive: the drive chain's joints "
                f"({listed(drive.joint_names)}) must be the identified joints in "
                f"the model's order ({listed(names)})."
            )
        if tuple(drive.prismatic) != tuple(bool(p) for p in prismatic):
            wrong = [
                n
                for n, a, b in zip(names, drive.prismatic, prismatic, strict=True)
                if a != bool(b)
            ]
            raise ValueError(
                f"RobotModel: drive: the drive chain's prismatic joints differ from "
                f"the model's for {listed(wrong)}."
            )
        return drive
    if isinstance(drive, (str, os.PathLike)):
        if not urdf_path:
            raise ValueError(
                "RobotModel: drive: a drive file needs the URDF (from_urdf); pass a "
                "DriveChain to from_plant."
            )
        from drake_dynid.drive_urdf import load_drive

        return load_drive(urdf_path, names, drive)
    raise TypeError(
        "RobotModel: drive must be None, a DriveChain or the path of a drive file; "
        f"got {type(drive).__name__}."
    )


def drive_table(
    chain: DriveChain,
    names: Sequence[str],
    values: Any,
    *,
    num_joints: int,
    rotor_inertia: bool,
    friction: tuple[str, ...],
    totals: Collection[str] = (),
    unwritten: Collection[str] = (),
) -> DriveTable:
    """Inserts the motor columns into a standard table (module docstring).

    Args:
        chain: the drive chain of the n identified joints.
        names: the standard names without motors: link blocks (``IAj`` inside with
            rotor inertia), mimic links, then n·len(friction) joint friction columns.
        values: their a-priori values.
        num_joints: n.
        rotor_inertia: whether the ``IAj`` (and ``IAmk``) columns are modelled.
        friction: the friction kinds.
        totals: the kinds among ``"viscous"``, ``"coulomb"``, ``"inertia"``
            (IAj) whose ``values`` already hold the joint-side totals, as in a
            file that ``dynid --urdf-out`` wrote with a drive file
            (``urdf_writer.drive_totals``): the simple motors' friction of those
            kinds is then not added to them, their rotor inertia does not
            replace the IAj; the other kinds (``offset`` always) get the
            motors' values as for any URDF.
        unwritten: the standard names such a file does not hold
            (``urdf_writer.unwritten``): an ``IAj`` among them is no total, the
            motor's rotor inertia replaces it.
    """
    names = list(names)
    values = np.array(values, dtype=float)
    n = num_joints
    start = len(names) - n * len(friction)
    notes: list[str] = []
    reflected = chain.reflected_inertia()
    known = np.zeros(n, dtype=bool)
    for motor in chain.motors:
        if not motor.coupled and motor.rotor_inertia is not None:
            known[motor.joints[0]] = True
    if rotor_inertia:
        for j in np.flatnonzero(known):
            if "inertia" not in totals or f"IA{j + 1}" in unwritten:
                values[names.index(f"IA{j + 1}")] = reflected[j]
    else:
        given = [mo.name for mo in chain.motors if mo.rotor_inertia is not None]
        if given:
            notes.append(
                f"the drive's rotor inertia of {listed(given)} is not modelled "
                "without rotor inertia columns (--rotor-inertia)"
            )
    extra = chain.reflected_friction()
    for index, kind in enumerate(friction):
        if kind in totals:
            continue
        for joint in range(n):
            values[start + joint * len(friction) + index] += extra[kind][joint]
    columns = None
    if chain.coupled_motors:
        columns = motor_columns(chain, inertia=rotor_inertia, friction=friction)
        coupled = listed(chain.motor_names[k] for k in chain.coupled_motors)
        if not rotor_inertia:
            notes.append(
                f"coupled motor(s) {coupled}: friction columns "
                f"{listed(columns.friction_names) or 'none'}; their rotor inertia "
                "(IAm columns) needs --rotor-inertia"
            )
    scales = np.ones(len(names))
    if columns is not None:
        rho = np.max(np.abs(columns.rows), axis=1)
        c_inertia = len(columns.inertia_names)
        motor_values = np.asarray(columns.values, dtype=float)
        inertia_values = motor_values[:c_inertia]
        friction_values = motor_values[c_inertia:]
        friction_scales = [
            rho[i] ** 2 if kind == "viscous" else rho[i]
            for i in range(len(rho))
            for kind in friction
        ]
        names = (
            names[:start]
            + list(columns.inertia_names)
            + names[start:]
            + list(columns.friction_names)
        )
        values = np.concatenate(
            [values[:start], inertia_values, values[start:], friction_values]
        )
        scales = np.concatenate(
            [
                scales[:start],
                rho[:c_inertia] ** 2 if c_inertia else np.zeros(0),
                scales[start:],
                np.array(friction_scales),
            ]
        )
    values.setflags(write=False)
    scales.setflags(write=False)
    return DriveTable(tuple(names), values, columns, scales, tuple(notes))


def motor_sign(sign: SignLaw, columns: MotorColumns) -> Any:
    """The Coulomb sign of the motor columns from the joints' law.

    The motor sign is evaluated on u_k/ρ_k in joint units: an exact sign stays
    exact (None: ``np.sign``), a scalar width (dead zone or tanh) applies
    unchanged, per-joint dead-zone widths combine per motor
    (``core.standstill.combined_widths``).
    """
    if isinstance(sign, ExactSign):
        return None
    if isinstance(sign, DeadZoneSign) and not isinstance(sign.width, float):
        return DeadZoneSign(tuple(combined_widths(sign.width, columns.rows)))
    return sign


def rescale_base(base: BaseParameters, scales: Any) -> BaseParameters:
    """Maps a reduction on scaled columns W' = W / s back to the unscaled ones.

    With θ'_c = s_c θ_c: θ_base,i = θ'_base,i / s_lead(i), so the regrouping
    coefficient of a dependent column D in base parameter i becomes
    β' s_D / s_lead(i) (rounded to 10 significant digits, as the reduction does);
    the independent columns and names are unchanged.
    """
    scales = np.asarray(scales, dtype=float)
    if np.all(scales == 1.0):
        return base
    lead = scales[list(base.independent)]
    matrix = base.matrix * scales[None, :] / lead[:, None]
    names = base.standard_names
    definitions = []
    for i, column in enumerate(base.independent):
        definition = {names[column]: 1.0}
        for k in np.flatnonzero(matrix[i]):
            if k != column:
                value = float(f"{matrix[i, k]:.{_DECIMALS}g}")
                matrix[i, k] = value
                definition[names[k]] = value
        definitions.append(definition)
    matrix[np.arange(len(lead)), list(base.independent)] = 1.0
    return dataclasses.replace(base, matrix=matrix, definitions=tuple(definitions))
