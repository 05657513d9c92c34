"""Shared pytest configuration.

The process is set up as the ``dynid`` command sets itself up (below); figures are
written with matplotlib's non-interactive Agg backend; hypothesis runs
deterministically (see below).
"""

import os

from drake_dynid.core._threads import configure_process

# As the dynid command does, before numpy is imported: BLAS/OpenMP pools of one
# thread (a busy 2-core machine runs the suite far slower with OpenBLAS's own
# pool), and so no pool thread in the process: commands._background forks only
# from a process with one thread (the forked bootstrap is tested, not skipped).
configure_process()

from hypothesis import settings  # noqa: E402

os.environ.setdefault("MPLBACKEND", "Agg")

# Property-based tests draw their examples deterministically (fixed seeds): a failure
# reproduces, and CI does not depend on the luck of the draw. Run with
# HYPOTHESIS_PROFILE=explore to search new examples.
settings.register_profile("deterministic", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "deterministic"))
