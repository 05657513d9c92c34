"""The command-line frame shared by the examples (not an example itself).

Each example script builds its ``argparse`` parser and hands it to
:func:`run_example` with the function that does the work; the scripts import this
module by name (``python examples/<name>.py`` puts this folder on ``sys.path``).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping, Sequence
from typing import Any


def run_example(
    parser: argparse.ArgumentParser,
    argv: Sequence[str] | None,
    body: Callable[[argparse.Namespace, argparse.ArgumentParser], int],
    quick: Mapping[str, Any] | None = None,
) -> int:
    """Parses ``argv`` and runs ``body(args, parser)``; returns its exit code.

    ``quick``: the presets of ``--quick``, which replace the defaults only: an
    option typed on the command line wins. A ``ValueError`` of a library check
    (its message names the value) becomes ``parser.error``: exit 2, no traceback.
    """
    args = parser.parse_args(argv)
    if quick is not None and args.quick:
        parser.set_defaults(**quick)
        args = parser.parse_args(argv)
    try:
        return body(args, parser)
    except ValueError as error:
        parser.error(str(error))
