"""The payload estimate in physical terms: mass, centre of mass, inertia, with σ.

The identifier estimates the payload's base parameters (``core.payload``): the
standard parameters of F that the joints see, some of them regrouped. This module
states what follows about the physical quantities (docs/PAYLOAD.md §4):

* **mass** m = M, **first moments** h = m·c (MX, MY, MZ) and the **inertia about
  F's origin** (XX ... ZZ): each with its σ when it is a base parameter on its own
  (definition ``{name: 1}``), else "not identifiable" (regrouped or never seen
  by the joints);
* **centre of mass** c = h/m [m] when M, MX, MY and MZ all are, with σ by
  first-order propagation using the errors' correlation ρ of the solve::

      σ_ci² = (σ_hi² + c_i² σ_m² - 2 c_i ρ(h_i, m) σ_hi σ_m) / m²

Every quantity is "identified" when its relative σ is at most
:data:`NOT_IDENTIFIED_PERCENT` (%σ ≤ 30, the library's rule), as the identifier's
tables flag parameters.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from drake_dynid.core.lsq import NOT_IDENTIFIED_PERCENT, relative_std_percent
from drake_dynid.core.payload import PAYLOAD_NAMES

__all__ = ["NOT_IDENTIFIED_PERCENT", "estimate_entry", "payload_summary"]


def estimate_entry(value: float, sigma: float) -> dict[str, Any]:
    """``{"value", "std", "relative_std_percent", "identified"}`` of one estimate.

    %σ = 100 σ/|value| (inf for a zero value or a non-finite one); identified when
    %σ <= :data:`NOT_IDENTIFIED_PERCENT`.
    """
    value, sigma = float(value), float(sigma)
    percent = relative_std_percent(value, sigma)
    return {
        "value": value,
        "std": sigma,
        "relative_std_percent": percent,
        "identified": bool(percent <= NOT_IDENTIFIED_PERCENT),
    }


def payload_summary(
    rows: Any, theta: Any, std: Any, correlation: Any = None
) -> dict[str, Any]:
    """The physical quantities of a payload estimate (module docstring).

    Args:
        rows: the payload's rows (``core.payload.PayloadRows``: ``base``).
        theta: (p,) the payload's base parameters.
        std: (p,) their σ.
        correlation: (p, p) the errors' correlation (default: none, ρ = 0).

    Returns:
        ``{"standard": {name: entry or None}, "mass": entry or None, "com":
        {"x"|"y"|"z": entry} or None, "not_identifiable": [names]}``, an entry
        being ``{"value", "std", "relative_std_percent", "identified"}`` (SI
        units: kg, kg·m, kg·m², m); None where the base parameters do not
        determine the quantity.
    """
    theta = np.asarray(theta, dtype=float)
    std = np.asarray(std, dtype=float)
    p = theta.shape[0]
    rho = np.eye(p) if correlation is None else np.asarray(correlation, dtype=float)
    plain: dict[str, int] = {}
    for k, definition in enumerate(rows.base.definitions):
        if len(definition) == 1:
            plain[next(iter(definition))] = k
    standard: dict[str, Any] = {}
    for name in PAYLOAD_NAMES:
        found = plain.get(name)
        standard[name] = (
            None if found is None else estimate_entry(theta[found], std[found])
        )
    mass = standard["M"]
    com = None
    if all(name in plain for name in ("M", "MX", "MY", "MZ")):
        k_m = plain["M"]
        m, s_m = float(theta[k_m]), float(std[k_m])
        com = {}
        for axis, name in zip("xyz", ("MX", "MY", "MZ"), strict=True):
            k = plain[name]
            h, s_h = float(theta[k]), float(std[k])
            if m == 0.0 or not math.isfinite(m):
                com[axis] = estimate_entry(math.nan, math.inf)
                continue
            c = h / m
            if not (math.isfinite(s_h) and math.isfinite(s_m)):
                com[axis] = estimate_entry(c, math.inf)
                continue
            variance = s_h**2 + c**2 * s_m**2 - 2.0 * c * rho[k, k_m] * s_h * s_m
            com[axis] = estimate_entry(c, math.sqrt(max(variance, 0.0)) / abs(m))
    return {
        "standard": standard,
        "mass": mass,
        "com": com,
        "not_identifiable": [n for n in PAYLOAD_NAMES if standard[n] is None],
    }
