"""Former import path of :mod:`drake_dynid.core._threads` (BLAS/OpenMP pools)."""

from __future__ import annotations

from drake_dynid.core._threads import (
    ENVIRONMENT,
    configure_process,
    loaded_pools,
    pin_environment,
    requested_threads,
    thread_counts,
    thread_limit,
)

__all__ = [
    "ENVIRONMENT",
    "configure_process",
    "loaded_pools",
    "pin_environment",
    "requested_threads",
    "thread_counts",
    "thread_limit",
]
