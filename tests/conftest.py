"""Shared pytest configuration.

Figures are written with matplotlib's non-interactive Agg backend.
"""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
