"""Output-path checks shared by subcommands (not a subcommand itself)."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path


def _same(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    first, second = Path(a), Path(b)
    if first.exists() and second.exists():
        return os.path.samefile(first, second)
    return first.resolve() == second.resolve()


def check_outputs(
    outputs: Mapping[str, str | os.PathLike | None],
    inputs: Sequence[str | os.PathLike | None],
) -> None:
    """Raises ValueError if an output would overwrite an input or another output.

    Args:
        outputs: option name (e.g. ``"--out"``) -> path (None: not written).
        inputs: the paths read by the command (None entries ignored).
    """
    given = [(name, path) for name, path in outputs.items() if path is not None]
    for name, path in given:
        for source in inputs:
            if source is not None and _same(path, source):
                raise ValueError(
                    f"{name} {path} is an input of this command; choose another "
                    "output path (inputs are never overwritten)."
                )
        if Path(path).is_dir():
            raise ValueError(f"{name} {path} is a directory; give a file path.")
    for i, (name, path) in enumerate(given):
        for other, other_path in given[i + 1 :]:
            if _same(path, other_path):
                raise ValueError(f"{name} and {other} are the same file {path}.")
