"""Log replay through the numerical core (fast path of ``dynid identify``).

The replay is pure numpy and lives in :mod:`drake_dynid.core.replay`; this module
keeps its former import path: ``drake_dynid.fast_replay.replay_log_core``.
"""

from __future__ import annotations

from drake_dynid.core.replay import replay_log_core

__all__ = ["replay_log_core"]
