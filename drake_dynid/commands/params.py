"""``dynid params``: standard and base parameters of a URDF robot."""

from __future__ import annotations

import argparse
import math
from typing import Any

from drake_dynid.commands._arguments import (
    URDF_HELP,
    absolute,
    add_drive_arguments,
    add_friction_argument,
    add_joint_arguments,
    robot_from_args,
    urdf_argument,
)
from drake_dynid.commands._report import write_json
from drake_dynid.core._validate import listed

HELP = "standard and base parameters of a URDF robot"
DESCRIPTION = (
    "Reads a fixed-base URDF robot (revolute, prismatic and fixed joints), lists its "
    "standard parameters (Khalil-Kleinfinger names: XXj XYj XZj YYj YZj ZZj MXj MYj "
    "MZj Mj about joint j's child-link frame, IAj, FVj FCj OFFj) and computes its base "
    "(identifiable) parameters by numerical QR reduction of inverse-dynamics rows at "
    "random states. Prints the rank decision (how far the kept and the dropped "
    "columns are from the rank tolerance), then each base parameter's name, its "
    "definition as a linear combination of standard parameters (e.g. ZZ1R = ZZ1 + "
    "1.0 M2) and its value from the URDF (FV from <dynamics damping>, FC from "
    "<dynamics friction>). Joints without a <transmission> are treated as actuated; "
    "--joints chooses the identified joints and --lock the positions of the others."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid params`` arguments."""
    parser.add_argument(
        "urdf", metavar="MODEL.urdf", type=urdf_argument, help=URDF_HELP
    )
    add_friction_argument(parser)
    add_joint_arguments(parser)
    add_drive_arguments(parser)
    parser.add_argument(
        "--json",
        metavar="FILE",
        help="also write the parameters as JSON to FILE (-: standard output, alone)",
    )


def _number(value: float) -> str:
    return f"{value:.6g}" if math.isfinite(value) else str(value)


def _short(value: float) -> str:
    return f"{value:.2g}" if math.isfinite(value) else str(value)


def rank_lines(base) -> list[str]:
    """The rank decision of ``base`` (a ``BaseParameters``) in three lines."""
    round_off = ", ".join(base.round_off_columns)
    return [
        f"rank: {base.num_base} of {base.num_standard} columns, "
        f"{'clear' if base.clear else 'NOT CLEAR'}: |R_kk| of unit columns kept >= "
        f"{_short(base.smallest_kept)}, dropped <= {_short(base.largest_dropped)} "
        f"(gap {_short(base.gap)}; tolerance {base.tolerance:g})",
        f"      singular values / largest: kept >= {_short(base.singular_kept)}, "
        f"dropped <= {_short(base.singular_dropped)} (gap "
        f"{_short(base.singular_gap)})",
        f"zero columns (|W_k| <= {base.column_tolerance:g} x largest): "
        f"{len(base.zero_columns)}"
        + (f"; round-off, not exactly zero: {round_off}" if round_off else ""),
    ]


def _rank_json(base) -> dict:
    def finite(value: float):
        return float(value) if math.isfinite(value) else None

    return {
        "tolerance": base.tolerance,
        "column_tolerance": base.column_tolerance,
        "smallest_kept": finite(base.smallest_kept),
        "largest_dropped": finite(base.largest_dropped),
        "gap": finite(base.gap),
        "singular_kept": finite(base.singular_kept),
        "singular_dropped": finite(base.singular_dropped),
        "singular_gap": finite(base.singular_gap),
        "margin_kept": finite(base.margin_kept),
        "margin_dropped": finite(base.margin_dropped),
        "clear": base.clear,
        "zero_columns": list(base.zero_columns),
        "round_off_columns": list(base.round_off_columns),
    }


def params_document(model: Any, urdf: Any, drive: Any = None) -> dict[str, Any]:
    """The ``dynid params --json`` document of a ``RobotModel``.

    Base parameters (name, value, definition), standard parameters, the rank
    decision, joints (identified, locked, mimic), notes, URDF path and settings
    (with the drive file path ``drive`` and, with a drive chain, its summary);
    ``dynid simulate`` writes it as the log's truth.
    """
    base = model.base
    return {
        "parameters": [
            {
                "name": name,
                "value": float(value),
                "std": None,
                "definition": dict(definition),
            }
            for name, value, definition in zip(
                base.names, model.base_values, base.definitions, strict=True
            )
        ],
        "standard_parameters": [
            {"name": name, "value": float(value)}
            for name, value in zip(
                model.standard_names, model.standard_values, strict=True
            )
        ],
        "num_standard": base.num_standard,
        "num_base": base.num_base,
        "rank": _rank_json(base),
        "joints": list(model.joint_names),
        "links": list(model.links),
        "locked": dict(model.locked),
        "mimic": {
            name: {"leader": leader, "multiplier": a, "offset": b}
            for name, (leader, a, b) in model.mimic.items()
        },
        "notes": list(model.notes),
        "urdf": str(urdf),
        "settings": {
            "friction": list(model.friction),
            "coulomb_width": model.coulomb_width,
            "rotor_inertia": model.rotor_inertia,
            "gravity": model.gravity.tolist(),
            "drive": absolute(drive),
        },
        **({"drive_chain": model.drive.summary()} if model.drive is not None else {}),
    }


def drive_lines(chain: Any) -> list[str]:
    """The drive chain in a few lines: motors (rows of R), torque constants, log."""
    lines = [f"drive: {chain.source}; {chain.num_motors} motors (v_m = R v)"]
    names = chain.joint_names
    for k, motor in enumerate(chain.motors):
        row = " + ".join(f"{motor.row[j]:g} {names[j]}" for j in motor.joints)
        extra = []
        if motor.torque_constant is not None:
            extra.append(f"k_t {motor.torque_constant:g}")
        if motor.rotor_inertia is not None:
            extra.append(f"Ia {motor.rotor_inertia:g}")
        kind = "coupled" if motor.coupled else "simple"
        more = f"; {', '.join(extra)}" if extra else ""
        lines.append(f"  m{k + 1} {motor.name} ({kind}, {motor.source}): {row}{more}")
    log = chain.log
    lines.append(
        f"  log: time '{log.time}' [{log.time_unit}], positions {log.position_side} "
        f"side, torques {log.torque_side} side [{log.torque_unit}]"
    )
    return lines


def run(args: argparse.Namespace) -> int:
    """Prints the base-parameter table; writes JSON when asked. Returns 0."""
    from drake_dynid.commands._paths import check_output_paths

    check_output_paths(args)  # --json never overwrites the URDF
    # --json -: the JSON alone on standard output (check_output_paths).
    say = (lambda *a: None) if getattr(args, "quiet", False) else print
    model = robot_from_args(args, "params")
    base = model.base
    values = model.base_values
    friction = ", ".join(model.friction) or "none"
    say(f"robot: {args.urdf}")
    say(f"joints ({model.num_joints}): {listed(model.joint_names)}")
    if model.locked:
        locked = listed(f"{k}={v:g}" for k, v in model.locked.items())
        say(f"locked ({len(model.locked)}): {locked}")
    for k, (name, (leader, a, b)) in enumerate(model.mimic.items()):
        link = model.num_joints + k + 1
        say(f"mimic: {name} = {a:g} x {leader} + {b:g} (link {link})")
    if model.drive is not None:
        for line in drive_lines(model.drive):
            say(line)
    say(
        f"standard parameters: {base.num_standard}; base parameters: "
        f"{base.num_base} (friction: {friction}; rotor inertia: "
        f"{'yes' if model.rotor_inertia else 'no'})"
    )
    for line in rank_lines(base):
        say(line)
    rows = [
        (name, _number(value), base.definition_text(name))
        for name, value in zip(base.names, values, strict=True)
    ]
    headers = ("name", "value", "definition")
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(headers)]
    say()
    say(f"{headers[0]:<{widths[0]}}  {headers[1]:>{widths[1]}}  {headers[2]}")
    say(f"{'-' * widths[0]}  {'-' * widths[1]}  {'-' * widths[2]}")
    for name, value, definition in rows:
        say(f"{name:<{widths[0]}}  {value:>{widths[1]}}  {definition}")
    if args.json:
        document = params_document(model, args.urdf, args.drive)
        write_json(args.json, document)  # whole or not at all
        say(f"\nwrote {args.json}")
    return 0
