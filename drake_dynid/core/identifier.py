"""The sliding least-squares identifier as a step function: hold, status, estimate.

Every solve period the identifier reads the bank's window (``window_valid`` and
the stacked equations ``A θ = B``, docs/MATH.md §3-§4) and updates its state::

    window not ready, or A or B
    not finite (a bad sample)   → hold θ̂, σ; valid = 0; status WINDOW_NOT_READY
    solved, accepted            → θ̂, σ from the solve; valid = 1; status OK
    rank deficient or cond > C  → hold θ̂, σ; valid = 0; status NOT_IDENTIFIABLE,
                                  ``unidentified`` flags the unexcited parameters

The condition number and the ``unidentified`` flags are those of the last solve.
Before the first accepted solve θ̂ is the initial estimate and σ = +inf. The
``SlidingQRIdentifier`` block and the core replay (``core.replay``) both call
:func:`identifier_update`, so they hold and report identically.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION, LeastSquaresResult
from drake_dynid.core.weighted_lsq import solve_window

__all__ = [
    "IdentifierState",
    "Status",
    "identifier_apply",
    "identifier_init",
    "identifier_update",
]


class Status(IntEnum):
    """Status of the identifier after an update (the block's ``status`` output)."""

    OK = 0
    """The window was solved and the estimate accepted."""
    WINDOW_NOT_READY = 1
    """The window is not full, or holds an invalid sample."""
    NOT_IDENTIFIABLE = 2
    """The window's regressor is rank deficient or too ill-conditioned."""


@dataclass(frozen=True, eq=False)
class IdentifierState:
    """State of the sliding identifier (immutable; arrays read-only).

    Attributes:
        theta: (p,) the estimate held [units of the parameters].
        std: (p,) Gautier standard deviations of ``theta`` (+inf before the first
            accepted solve).
        condition_number: condition number of the last solve's column-scaled A
            (+inf before the first solve).
        valid: True when the last update accepted a solve.
        unidentified: (p,) 1.0 for the parameters the last solve found not
            excited, else 0.0.
        status: the :class:`Status` of the last update.
    """

    theta: np.ndarray
    std: np.ndarray
    condition_number: float
    valid: bool
    unidentified: np.ndarray
    status: Status

    @property
    def num_parameters(self) -> int:
        """p, the parameters."""
        return int(self.theta.shape[0])


def _frozen(value: Any) -> np.ndarray:
    out = np.array(value, dtype=float)
    out.flags.writeable = False
    return out


def identifier_init(
    num_parameters: int, initial_theta: Sequence[float] | None = None
) -> IdentifierState:
    """The state before the first update.

    Args:
        num_parameters: p >= 1.
        initial_theta: (p,) estimate held before the first accepted solve
            (default zeros).
    """
    owner = "identifier_init"
    p = check.integer(owner, "num_parameters", num_parameters, 1)
    theta = (
        np.zeros(p)
        if initial_theta is None
        else check.array(owner, "initial_theta", initial_theta, (p,))
    )
    return IdentifierState(
        theta=_frozen(theta),
        std=_frozen(np.full(p, np.inf)),
        condition_number=np.inf,
        valid=False,
        unidentified=_frozen(np.zeros(p)),
        status=Status.WINDOW_NOT_READY,
    )


def identifier_update(
    state: IdentifierState,
    window_valid: bool,
    A: Any,
    B: Any,
    *,
    weighting: tuple[Any, Any] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
    names: Sequence[str] | None = None,
    noise: Any = None,
    jackknife: Any = None,
    covariance: Any = None,
) -> IdentifierState:
    """One solve of the sliding identifier: the new state (the old is unchanged).

    ``θ̂ = argmin ‖A θ - B‖`` (``core.weighted_lsq.solve_window``: ordinary, or
    frequency-weighted when ``weighting`` is given), accepted when A has full rank
    and a condition number (columns scaled to unit norm) <= ``max_condition``;
    otherwise the previous estimate is held (module docstring).

    Args:
        state: the current state.
        window_valid: whether the window is full and holds no invalid sample.
            When False, ``A`` and ``B`` are not read (they may be None).
        A: (r, p) stacked equations of the window.
        B: (r,) right-hand side.
        weighting: None, or ``(row_frequency, row_group)`` of the rows.
        max_condition: largest accepted scaled condition number.
        names: p parameter names (for the solver's messages).
        noise: the rows' ``core.row_noise.RowNoise`` for the honest σ
            (``OnlineSettings.row_noise``; ``core.weighted_lsq.solve_window``); None:
            Gautier's σ.
        jackknife: None, or the (r,) jackknife group of every row
            (``OnlineSettings.jackknife_groups``): σ is then, per parameter, the
            larger of the σ above and the delete-one-group jackknife's.
        covariance: None, or θ -> Σ of the window's rows: the covariance-weighted
            solve (``core.row_covariance``; weighting, noise and jackknife unused).
    """
    if not window_valid or not (np.isfinite(A).all() and np.isfinite(B).all()):
        # A window holding a non-finite entry is a window holding a bad sample.
        return identifier_apply(state, False, None)
    result = solve_window(
        A,
        B,
        weighting,
        max_condition=max_condition,
        names=names,
        noise=noise,
        jackknife=jackknife,
        covariance=covariance,
    )
    return identifier_apply(state, True, result)


def identifier_apply(
    state: IdentifierState, window_valid: bool, result: LeastSquaresResult | None
) -> IdentifierState:
    """The new state from one window's solve (:func:`identifier_update`'s step).

    ``result``: the window's ``core.weighted_lsq.solve_window`` (not read when
    ``window_valid`` is False; the core replay solves windows stacked,
    ``core.weighted_lsq.solve_windows``, then applies them one by one).
    """
    if not window_valid or result is None:
        return dataclasses.replace(state, valid=False, status=Status.WINDOW_NOT_READY)
    unidentified = np.zeros(state.num_parameters)
    if result.valid:
        return IdentifierState(
            theta=result.theta,
            std=result.std,
            condition_number=result.condition_number,
            valid=True,
            unidentified=_frozen(unidentified),
            status=Status.OK,
        )
    unidentified[list(result.unidentified_indices)] = 1.0
    return dataclasses.replace(
        state,
        condition_number=result.condition_number,
        valid=False,
        unidentified=_frozen(unidentified),
        status=Status.NOT_IDENTIFIABLE,
    )
