"""``dynid params``: standard and base parameters of a URDF robot."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from drake_dynid.commands._arguments import add_friction_argument, parse_friction

HELP = "standard and base parameters of a URDF robot"
DESCRIPTION = (
    "Reads a fixed-base URDF robot (revolute, prismatic and fixed joints), lists its "
    "standard parameters (Khalil-Kleinfinger names: XXj XYj XZj YYj YZj ZZj MXj MYj "
    "MZj Mj about joint j's child-link frame, IAj, FVj FCj OFFj) and computes its base "
    "(identifiable) parameters by numerical QR reduction of inverse-dynamics rows at "
    "random states. Prints each base parameter's name, its definition as a linear "
    "combination of standard parameters (e.g. ZZ1R = ZZ1 + 1.0 M2) and its value from "
    "the URDF (FV from <dynamics damping>, FC from <dynamics friction>)."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid params`` arguments."""
    parser.add_argument("urdf", metavar="MODEL.urdf", help="the robot's URDF file")
    add_friction_argument(parser)
    parser.add_argument(
        "--rotor-inertia",
        action="store_true",
        help="add the rotor inertia columns IAj (values from the URDF's actuators)",
    )
    parser.add_argument(
        "--json", metavar="FILE", help="also write the parameters as JSON to FILE"
    )


def _number(value: float) -> str:
    return f"{value:.6g}" if math.isfinite(value) else str(value)


def params_document(model, urdf) -> dict:
    """The ``dynid params --json`` document of a ``RobotModel``.

    Base parameters (name, value, definition), standard parameters, joints, URDF
    path and settings; ``dynid simulate`` writes it as the log's truth.
    """
    return {
        "parameters": [
            {
                "name": name,
                "value": float(value),
                "std": None,
                "definition": dict(definition),
            }
            for name, value, definition in zip(
                model.base.names, model.base_values, model.base.definitions, strict=True
            )
        ],
        "standard_parameters": [
            {"name": name, "value": float(value)}
            for name, value in zip(
                model.standard_names, model.standard_values, strict=True
            )
        ],
        "num_standard": model.base.num_standard,
        "num_base": model.base.num_base,
        "joints": list(model.joint_names),
        "urdf": str(urdf),
        "settings": {
            "friction": list(model.friction),
            "rotor_inertia": model.rotor_inertia,
            "gravity": model.gravity.tolist(),
        },
    }


def run(args: argparse.Namespace) -> int:
    """Prints the base-parameter table; writes JSON when asked. Returns 0."""
    from drake_dynid.robot import RobotModel

    model = RobotModel.from_urdf(
        args.urdf,
        friction=parse_friction(args.friction),
        rotor_inertia=args.rotor_inertia,
    )
    base = model.base
    values = model.base_values
    friction = ", ".join(model.friction) or "none"
    print(f"robot: {args.urdf}")
    print(f"joints ({model.num_joints}): {', '.join(model.joint_names)}")
    print(
        f"standard parameters: {base.num_standard}; base parameters: "
        f"{base.num_base} (friction: {friction}; rotor inertia: "
        f"{'yes' if model.rotor_inertia else 'no'})"
    )
    rows = [
        (name, _number(value), base.definition_text(name))
        for name, value in zip(base.names, values, strict=True)
    ]
    headers = ("name", "value", "definition")
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(headers)]
    print()
    print(f"{headers[0]:<{widths[0]}}  {headers[1]:>{widths[1]}}  {headers[2]}")
    print(f"{'-' * widths[0]}  {'-' * widths[1]}  {'-' * widths[2]}")
    for name, value, definition in rows:
        print(f"{name:<{widths[0]}}  {value:>{widths[1]}}  {definition}")
    if args.json:
        document = params_document(model, args.urdf)
        Path(args.json).write_text(json.dumps(document, indent=2) + "\n")
        print(f"\nwrote {args.json}")
    return 0
