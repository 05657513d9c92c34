"""Causal Jacobi derivative estimator (docs/MATH.md §1): design and streaming.

A facade over :mod:`drake_dynid.core.jacobi_design` (the filter design and tuning
helpers) and :mod:`drake_dynid.core.jacobi_stream` (applying the filters: batch and
the streaming ring). Import from here or from them.
"""

from __future__ import annotations

from drake_dynid.core.jacobi_design import (
    JacobiFilter,
    jacobi_filter,
    jacobi_filters,
    jacobi_frequency_response,
    jacobi_kernel,
    jacobi_minimum_delay_xi,
    jacobi_sinusoid_error,
)
from drake_dynid.core.jacobi_stream import (
    JacobiRing,
    jacobi_apply,
    jacobi_batch,
    jacobi_initial_state,
    jacobi_outputs,
    jacobi_ring,
    jacobi_step,
    jacobi_valid,
)

__all__ = [
    "JacobiFilter",
    "JacobiRing",
    "jacobi_apply",
    "jacobi_batch",
    "jacobi_filter",
    "jacobi_filters",
    "jacobi_frequency_response",
    "jacobi_initial_state",
    "jacobi_kernel",
    "jacobi_minimum_delay_xi",
    "jacobi_outputs",
    "jacobi_ring",
    "jacobi_sinusoid_error",
    "jacobi_step",
    "jacobi_valid",
]
