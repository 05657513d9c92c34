"""Options shared by several ``dynid`` subcommands (not a subcommand itself)."""

from __future__ import annotations

import argparse


def add_friction_argument(parser: argparse.ArgumentParser) -> None:
    """Adds ``--friction`` (the friction columns per joint)."""
    parser.add_argument(
        "--friction",
        default="viscous,coulomb",
        help=(
            "comma-separated friction columns per joint among viscous, coulomb, "
            "offset, or 'none' (default: viscous,coulomb)"
        ),
    )


def parse_friction(text: str) -> tuple[str, ...]:
    """``"viscous,coulomb"`` -> ``("viscous", "coulomb")``; ``"none"`` -> ``()``."""
    if text.strip().lower() in ("", "none"):
        return ()
    return tuple(item.strip() for item in text.split(",") if item.strip())
