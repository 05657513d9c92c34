"""Messages in the command's words (not a subcommand).

The library's checks name their owner and arguments (``identify_offline:
cutoff_hz must be ...``); a command reports the same check with the option the
user typed (``--cutoff must be ...``).
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

#: Off-line filter arguments -> the options of dynid offline and dynid validate.
FILTER_OPTIONS = {
    "decimation_cutoff_hz": "--decimation-cutoff",
    "cutoff_hz": "--cutoff",
    "decimation": "--decimation",
}


def option_message(
    message: str, names: Mapping[str, str], owners: Iterable[str] = ()
) -> str:
    """``message`` in a command's words.

    A leading ``OWNER: `` of ``owners`` is dropped and each argument name of
    ``names`` (whole words) is replaced by its option.
    """
    for owner in owners:
        if message.startswith(f"{owner}: "):
            message = message[len(owner) + 2 :]
            break
    if not names:
        return message
    keys = sorted(names, key=len, reverse=True)
    pattern = re.compile(r"\b(" + "|".join(map(re.escape, keys)) + r")\b")
    return pattern.sub(lambda match: names[match.group(1)], message)
