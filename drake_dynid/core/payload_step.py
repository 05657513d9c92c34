"""The payload identifier's settings and step function (state in, new state out).

The payload identifier is the on-line identifier of docs/CONVENTIONS.md §2-§3 on
the rows of ``core.payload.PayloadRows`` (the payload's columns and the arm's
known column), with one more step before the solve: the known column moves to the
right-hand side (``core.payload.eliminate_known``), then the solve, the hold and
the status are ``core.identifier.identifier_update``'s. Both drivers call
:func:`payload_update`: the ``PayloadIdentifier`` block and the core replay
(``core.payload_replay``).

Default settings (:data:`PAYLOAD_DEFAULTS`; docs/PAYLOAD.md §3; the numbers are
benchmarks/_accuracy_payload.py's, iiwa7 with a 2 kg payload, 10 noise seeds): a
short window, so that the estimate follows a pick within a second, and what a
short window needs:

* ``window`` 0.75 s: the mass stays within 5 % from 0.75 s after the pick
  (T = 0.5 s: 0.55 s, with a 3 times larger error of the centre of mass;
  T = 1 s: 0.9 s).
* ``frequencies`` ℓ = 0..3: the motion is slow against 1/T; higher modulating
  frequencies carry noise rather than motion (ℓ = 0..7: 1.5 times the mass error).
* ``bank_time_step`` 2 ms: the known column (the whole arm's momentum and
  gravity) is about 1e3 times the payload's contribution, and a trapezoid over
  bank steps h errs by about (2πf·h)²/12 at the modulating frequency f, which the
  arm's column turns into payload errors: noise-free, 10 ms leave a mass error
  of 0.04 % and 6 of 10 parameters identified, 2 ms 0.002 % and 10 of 10.
* ``rows_from`` raw, ``jacobi_window`` 0.1 s: no filter bias on the nonlinear
  terms (noise-free, 10 of 10 parameters identified, median error 0.14 %;
  filtered rows: 8 of 10).
* ``weighting`` frequency and ``uncertainty`` jackknife (the on-line
  identifier's): the weighting halves the mass error against ordinary least
  squares (0.11 % vs 0.21 %, centre of mass 1.2 mm vs 5.2 mm), and the jackknife
  keeps err/σ p90 at 1.2-1.7 where Gautier's σ gives 2.3. It deletes one
  modulating function at a time (:func:`payload_jackknife_groups`: 4 groups),
  not a pair as the long-window identifier does: 2 groups make σ a
  one-degree-of-freedom estimate (σ of the mass between 0.2 % and 5 % on three
  noise seeds of one log).
* ``update_period`` 50 ms.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.identifier import (
    IdentifierState,
    identifier_init,
    identifier_update,
)
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.payload import eliminate_known

__all__ = [
    "PAYLOAD_DEFAULTS",
    "PayloadState",
    "check_payload_weighting",
    "payload_init",
    "payload_jackknife_groups",
    "payload_settings",
    "payload_update",
    "solve_correlation",
]

#: The payload identifier's settings (module docstring); ``payload_settings``
#: applies them under any overrides.
PAYLOAD_DEFAULTS: dict[str, Any] = {
    "model": "lagrangian",
    "window": 0.75,
    "frequencies": (0.0, 1.0, 2.0, 3.0),
    "jacobi_window": 0.1,
    "bank_time_step": 0.002,
    "update_period": 0.05,
    "rows_from": "raw",
    "weighting": "frequency",
    "uncertainty": "jackknife",
}


def payload_settings(**overrides: Any) -> OnlineSettings:
    """``OnlineSettings`` of the payload identifier: :data:`PAYLOAD_DEFAULTS`.

    Any ``OnlineSettings`` field can be overridden (``window=1.0``, ...); the
    values are checked as by ``OnlineSettings`` and :func:`check_payload_weighting`.
    """
    values = {**PAYLOAD_DEFAULTS, **overrides}
    if isinstance(values.get("frequencies"), tuple):
        values["frequencies"] = list(values["frequencies"])
    return check_payload_weighting("payload_settings", OnlineSettings(**values))


def check_payload_weighting(owner: str, settings: OnlineSettings) -> OnlineSettings:
    """``settings``, unless it asks for what the payload solve does not have.

    The covariance weighting (``core.row_covariance``) models the arm's rows; the
    payload's rows carry the arm's known column, so it is refused. So are change
    detection (``detect_changes``: the payload chain has no change test) and
    ``position_noise`` (the power rows' noise compensation is the arm's rows'),
    which the payload chain and its core replay would ignore.
    """
    if settings.weighting == "covariance":
        check.fail(
            owner,
            "settings.weighting must be 'frequency' or 'none' for the payload "
            "identifier (the covariance weighting models the arm's own rows); got "
            "'covariance'.",
        )
    if settings.detect_changes is not False:
        check.fail(
            owner,
            "settings.detect_changes must be False for the payload identifier (it "
            "has no change test; its short window forgets a change within T); got "
            f"{settings.detect_changes!r}.",
        )
    if settings.position_noise is not None:
        check.fail(
            owner,
            "settings.position_noise must be None for the payload identifier (the "
            "noise compensation of the power rows is the arm's rows'); got "
            f"{settings.position_noise!r}.",
        )
    return settings


def payload_jackknife_groups(settings: OnlineSettings, m: int, bank: Any = None):
    """The payload solve's ``jackknife`` argument: one group per modulating function.

    None unless ``settings.uncertainty`` is ``"jackknife"``; else the function of
    every row, ``bank.row_functions(m)`` (module docstring: with few functions,
    pairs leave too few groups).

    Args:
        settings: the identifier's settings.
        m: equations per sample of the model rows.
        bank: the settings' bank when already built (default ``settings.bank()``).
    """
    if settings.uncertainty != "jackknife":
        return None
    return (settings.bank() if bank is None else bank).row_functions(m)


@dataclass(frozen=True, eq=False)
class PayloadState:
    """State of the payload identifier (immutable).

    Attributes:
        estimate: the identifier's state over the payload's base parameters
            (θ̂, σ, condition number, valid, unidentified, status;
            ``core.identifier.IdentifierState``).
        correlation: (p, p) correlation of θ̂'s errors at the last accepted solve,
            from (AᵀA)⁻¹ of the solve's columns (identity before the first).
    """

    estimate: IdentifierState
    correlation: np.ndarray

    @property
    def num_parameters(self) -> int:
        """p, the payload's base parameters."""
        return self.estimate.num_parameters


def _frozen(value: Any) -> np.ndarray:
    out = np.array(value, dtype=float)
    out.flags.writeable = False
    return out


def payload_init(num_parameters: int) -> PayloadState:
    """The state before the first update: θ̂ = 0 (no payload), σ = +inf."""
    estimate = identifier_init(num_parameters)
    return PayloadState(estimate, _frozen(np.eye(estimate.num_parameters)))


def solve_correlation(A: Any) -> np.ndarray:
    """Correlation matrix of the least-squares errors of ``A θ ≈ b``, (p, p).

    C ∝ (AᵀA)⁻¹ from the R of the column-scaled A (A S⁻¹ = Q R: C = S⁻¹ R⁻¹ R⁻ᵀ
    S⁻¹), normalised to a unit diagonal; scaled by the σ of the solve it gives
    the covariance used to propagate σ to derived quantities (the centre of mass
    c = h/m). A must have full column rank (a solve the identifier accepted).
    """
    a = check.array("solve_correlation", "A", A, (None, None))
    norms = np.linalg.norm(a, axis=0)
    r = np.linalg.qr(a / np.where(norms > 0.0, norms, 1.0), mode="r")
    inverse = np.linalg.inv(r)
    covariance = inverse @ inverse.T
    scale = 1.0 / np.sqrt(np.diag(covariance))
    return covariance * scale[:, None] * scale[None, :]


def payload_update(
    state: PayloadState,
    window_valid: bool,
    A: Any,
    B: Any,
    *,
    weighting: tuple[Any, Any] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Any = None,
    noise: Any = None,
    jackknife: Any = None,
) -> PayloadState:
    """One solve of the payload identifier: the new state (the old is unchanged).

    ``A [θ; 1] = B`` (the bank's equations of ``PayloadRows``: p payload columns
    and the known column last) becomes ``A[:, :p] θ = B - A[:, p]``, then
    ``core.identifier.identifier_update`` (same arguments): accepted solves give
    θ̂, σ and the errors' correlation (:func:`solve_correlation`); a window not
    ready, rank deficient or ill-conditioned holds the last estimate.

    Args:
        state: the current state.
        window_valid: whether the window is full and holds no invalid sample
            (``A`` and ``B`` are not read otherwise; they may be None).
        A: (r, p + 1) the window's equations.
        B: (r,) right-hand side.
        weighting: None, or ``(row_frequency, row_group)`` of the rows.
        max_condition: largest accepted scaled condition number.
        names: the p payload names (for the solver's messages).
        noise: the rows' ``core.row_noise.RowNoise`` (honest σ) or None.
        jackknife: None, or the (r,) jackknife group of every row.
    """
    if not window_valid:
        estimate = identifier_update(state.estimate, False, None, None)
        return dataclasses.replace(state, estimate=estimate)
    a, b = eliminate_known(A, B)
    p = state.num_parameters
    if a.shape[1] != p:
        check.fail(
            "payload_update",
            f"A must have {p + 1} columns (the payload's {p} and the known one); "
            f"got {a.shape[1] + 1}.",
        )
    estimate = identifier_update(
        state.estimate,
        True,
        a,
        b,
        weighting=weighting,
        max_condition=max_condition,
        names=names,
        noise=noise,
        jackknife=jackknife,
    )
    correlation = state.correlation
    if estimate.valid:
        correlation = _frozen(solve_correlation(a))
    return PayloadState(estimate, correlation)
