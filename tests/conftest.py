"""Shared pytest configuration.

Figures are written with matplotlib's non-interactive Agg backend; hypothesis runs
deterministically (see below).
"""

import os

from hypothesis import settings

os.environ.setdefault("MPLBACKEND", "Agg")

# Property-based tests draw their examples deterministically (fixed seeds): a failure
# reproduces, and CI does not depend on the luck of the draw. Run with
# HYPOTHESIS_PROFILE=explore to search new examples.
settings.register_profile("deterministic", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))
