"""The payload identifier's settings and step function (state in, new state out).

The payload identifier is the on-line identifier of docs/CONVENTIONS.md §2-§3 on
the rows of ``core.payload.PayloadRows`` (the payload's columns and the arm's
known column), with one more step before the solve: the known column moves to the
right-hand side (``core.payload.eliminate_known``), then the solve, the hold and
the status are ``core.identifier.identifier_update``'s. Both drivers call
:func:`payload_update`: the ``PayloadIdentifier`` block and the core replay
(``core.payload_replay``).

Default settings (:data:`PAYLOAD_DEFAULTS`; docs/PAYLOAD.md §3; the numbers are
benchmarks/_accuracy_payload.py's, iiwa7 with a 2 kg payload, 16 noise seeds): a
short window, so that the estimate follows a pick within a second, and what a
short window needs:

* ``window`` 0.75 s: the mass stays within 5 % from 0.75 s after the pick
  (T = 0.5 s: 0.55 s, with a 4 times larger error of the centre of mass;
  T = 1 s: 0.9 s).
* ``frequencies`` ℓ = 0..3: the motion is slow against 1/T; higher modulating
  frequencies carry noise rather than motion (ℓ = 0..7: 1.8 times the mass error).
* ``bank_time_step`` 2 ms (at most ``jacobi_window``/10, as an unset bank step
  of ``OnlineSettings.on_grid``: :func:`payload_bank_step`): the known column
  (the whole arm's momentum and gravity) is about 1e3 times the payload's
  contribution, and a trapezoid over bank steps h errs by about (2πf·h)²/12 at
  the modulating frequency f, which the arm's column turns into payload errors:
  noise-free, 10 ms leave a mass error of 0.04 % and 6 of 10 parameters
  identified, 2 ms 0.002 % and 10 of 10.
* ``rows_from`` raw, ``jacobi_window`` 0.1 s: no filter bias on the nonlinear
  terms (noise-free, 10 of 10 parameters identified, median error 0.14 %;
  filtered rows: 8 of 10).
* ``weighting`` frequency and ``uncertainty`` sandwich, with the row noise
  pooled across windows (``core.payload_noise``): the pool's row variances
  and one level per equation from the window weigh the rows and give the
  sandwich σ. A noise model of one window's 8 rows per equation fits the very
  residuals it weighs (σ 0.3-0.8 times too small), and the jackknife that
  covered it, one group per modulating function, has 4 groups (fewer than
  ``core.online.MIN_JACKKNIFE_GROUPS``): it overstated the mass σ up to 40
  times (UR5), 230 times apart between noise seeds. ``uncertainty`` jackknife
  adds the jackknife only with at least 5 functions
  (:func:`payload_jackknife_groups`).
* ``update_period`` 50 ms.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.identifier import (
    IdentifierState,
    identifier_apply,
    identifier_init,
    identifier_update,
)
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION
from drake_dynid.core.online import (
    MIN_BANK_SAMPLES_PER_JACOBI_WINDOW,
    MIN_JACKKNIFE_GROUPS,
    OnlineSettings,
    nearest_multiple,
    nearest_on_grid,
)
from drake_dynid.core.payload import eliminate_known
from drake_dynid.core.payload_noise import (
    PooledNoise,
    pooled_noise_init,
    pooled_solve,
)
from drake_dynid.core.weighted_lsq import with_jackknife

__all__ = [
    "PAYLOAD_DEFAULTS",
    "PayloadState",
    "check_payload_weighting",
    "payload_bank_step",
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
    "uncertainty": "sandwich",
}


def payload_settings(
    time_step: float | None = None, **overrides: Any
) -> OnlineSettings:
    """``OnlineSettings`` of the payload identifier: :data:`PAYLOAD_DEFAULTS`.

    Any ``OnlineSettings`` field can be overridden (``window=1.0``, ...); the
    values are checked as by ``OnlineSettings`` and :func:`check_payload_weighting`.

    Args:
        time_step: the log's sample period h [s], or None. Given, the defaults of
            ``bank_time_step`` (2 ms) and ``update_period`` (50 ms) that are not
            overridden become the multiples of h closest to them (at least h;
            ``core.online.nearest_on_grid``), as ``OnlineSettings.on_grid`` does
            for unset periods: a 100 Hz log gets a 10 ms bank step (2 ms is no
            multiple of it, and ``on_grid`` refuses a given period off the grid).
            The default bank step is at most jacobi_window/10, as identify's
            (:func:`payload_bank_step`: 1 ms under a 10 ms window, with or
            without h); with h above jacobi_window/10 it stays 2 ms: h itself
            is too coarse for the Jacobi window, which ``on_grid`` then says.
        **overrides: ``OnlineSettings`` fields.
    """
    values = {**PAYLOAD_DEFAULTS, **overrides}
    h = None
    if time_step is not None:
        h = check.positive("payload_settings", "time_step", time_step, "s")
        if "update_period" not in overrides:
            values["update_period"] = nearest_on_grid(
                PAYLOAD_DEFAULTS["update_period"], h
            )
    if "bank_time_step" not in overrides:
        values["bank_time_step"] = payload_bank_step(values.get("jacobi_window"), h)
    if isinstance(values.get("frequencies"), tuple):
        values["frequencies"] = list(values["frequencies"])
    return check_payload_weighting("payload_settings", OnlineSettings(**values))


def payload_bank_step(jacobi_window: Any, time_step: float | None = None) -> float:
    """The default bank step [s]: 2 ms, at most the Jacobi window's tenth.

    As ``OnlineSettings.on_grid`` derives an unset bank step (docs/CONVENTIONS.md
    §2) from its nominal 20 ms, with the payload's nominal 2 ms::

        Δ = min(2 ms, Tj/10)                      (no time step given)
        Δ = c·h, c >= 1 the count closest to min(2 ms, Tj/10), c·h <= Tj/10

    Tj the Jacobi window [s] (on h's grid), h the log's step [s]. A window that
    is no positive number, or shorter than 10 h, leaves 2 ms (``OnlineSettings``
    names the window: the log is too coarse for it).

    Args:
        jacobi_window: Tj [s] (as given: checked by ``OnlineSettings``).
        time_step: h [s], or None.

    Returns:
        The bank step Δ [s].
    """
    nominal = float(PAYLOAD_DEFAULTS["bank_time_step"])
    window = jacobi_window
    if isinstance(window, bool) or not isinstance(window, int | float):
        return nominal
    if not (math.isfinite(window) and window > 0.0):
        return nominal
    if time_step is None:
        return min(nominal, float(window) / MIN_BANK_SAMPLES_PER_JACOBI_WINDOW)
    h = time_step
    limit = nearest_on_grid(float(window), h) / MIN_BANK_SAMPLES_PER_JACOBI_WINDOW
    if limit < h * (1.0 - 1e-9):
        return nominal
    wanted = min(nominal, limit)
    if wanted == nominal and math.isclose(
        nominal / h, round(nominal / h), rel_tol=1e-9
    ):
        return nominal  # 2 ms on a 1 kHz (500 Hz) log: the value itself
    top = max(1, math.floor(limit / h + 1e-9))
    return nearest_multiple(wanted, h, at_most=top) * h


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

    None unless ``settings.uncertainty`` is ``"jackknife"`` and the bank has at
    least ``core.online.MIN_JACKKNIFE_GROUPS`` functions (the default ℓ = 0..3
    has 4: the jackknife's σ would be a 3-degree-of-freedom estimate, and
    deleting ℓ = 0 deletes most of the gravity rows); else the function of every
    row, ``bank.row_functions(m)``.

    Args:
        settings: the identifier's settings.
        m: equations per sample of the model rows.
        bank: the settings' bank when already built (default ``settings.bank()``).
    """
    if settings.uncertainty != "jackknife":
        return None
    functions = (settings.bank() if bank is None else bank).row_functions(m)
    if np.unique(functions).size < MIN_JACKKNIFE_GROUPS:
        return None
    return functions


@dataclass(frozen=True, eq=False)
class PayloadState:
    """State of the payload identifier (immutable).

    Attributes:
        estimate: the identifier's state over the payload's base parameters
            (θ̂, σ, condition number, valid, unidentified, status;
            ``core.identifier.IdentifierState``).
        correlation: (p, p) correlation of θ̂'s errors at the last accepted solve,
            from (AᵀA)⁻¹ of the solve's columns (identity before the first).
        pool: the rows' noise pooled across windows (``core.payload_noise``),
            None before the first window (or with Gautier's σ).
    """

    estimate: IdentifierState
    correlation: np.ndarray
    pool: PooledNoise | None = None

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
    arm_columns: int = 0,
) -> PayloadState:
    """One solve of the payload identifier: the new state (the old is unchanged).

    ``A [θ; z; 1] = B`` (the bank's equations of ``PayloadRows``: p payload
    columns, k = ``arm_columns`` arm's error columns K_L with z ~ N(0, 1_k), the
    known column last) becomes ``A[:, :p] θ = B - A[:, -1]``; with the pooled
    noise, the arm's error K_L z adds G K_L K_Lᵀ Gᵀ to θ̂'s covariance
    (``core.payload_noise.pooled_solve``, docs/PAYLOAD.md §4; Gautier's σ
    leaves it out). With
    ``noise`` (the default ``uncertainty``), the solve is
    ``core.payload_noise.pooled_solve``: the rows weighed by the noise pooled
    across windows and one level per equation, the sandwich σ (docs/PAYLOAD.md
    §3); the pool learns from every accepted window, and until it holds
    ``core.payload_noise.MIN_POOLED_WINDOWS`` windows the estimate is not valid
    (status ``WINDOW_NOT_READY``: the noise model has no data yet; θ̂ and σ
    held). Without ``noise``: ``core.identifier.identifier_update`` (Gautier's
    σ). Accepted solves give θ̂, σ and the errors' correlation
    (:func:`solve_correlation`); a window not ready, rank deficient or
    ill-conditioned holds the last estimate.

    Args:
        state: the current state.
        window_valid: whether the window is full and holds no invalid sample
            (``A`` and ``B`` are not read otherwise; they may be None).
        A: (r, p + k + 1) the window's equations.
        B: (r,) right-hand side.
        weighting: None (ordinary least squares), or ``(row_frequency,
            row_group)`` of the rows: weighted (by the pool with ``noise``, else
            ``core.weighted_lsq``'s frequency weights).
        max_condition: largest accepted scaled condition number.
        names: the p payload names (for the solver's messages).
        noise: the rows' ``core.row_noise.RowNoise`` (pooled noise, sandwich σ)
            or None (Gautier's σ).
        jackknife: None, or the (r,) jackknife group of every row
            (:func:`payload_jackknife_groups`): σ is then, per parameter, the
            larger of the sandwich's and the jackknife's.
        arm_columns: k, the arm's error columns of A (``PayloadRows.
            num_arm_columns``).
    """
    if not window_valid:
        estimate = identifier_update(state.estimate, False, None, None)
        return dataclasses.replace(state, estimate=estimate)
    p = state.num_parameters
    k = check.integer("payload_update", "arm_columns", arm_columns, 0)
    full = np.asarray(A, dtype=float)
    if full.ndim != 2 or full.shape[1] != p + k + 1:
        check.fail(
            "payload_update",
            f"A must have {p + k + 1} columns (the payload's {p}, the arm's {k} "
            f"error columns and the known one); got shape {full.shape}.",
        )
    arm = full[:, p : p + k] if k > 0 else None
    a, b = eliminate_known(np.concatenate([full[:, :p], full[:, -1:]], axis=1), B)
    if noise is None:
        estimate = identifier_update(
            state.estimate,
            True,
            a,
            b,
            weighting=weighting,
            max_condition=max_condition,
            names=names,
            noise=None,
            jackknife=jackknife,
        )
        correlation = state.correlation
        if estimate.valid:
            correlation = _frozen(solve_correlation(a))
        return PayloadState(estimate, correlation, state.pool)
    if not (np.isfinite(a).all() and np.isfinite(b).all()) or (
        arm is not None and not np.isfinite(arm).all()
    ):
        estimate = identifier_update(state.estimate, False, None, None)
        return dataclasses.replace(state, estimate=estimate)
    pool = state.pool if state.pool is not None else pooled_noise_init(a.shape[0])
    ready = pool.ready
    solved = pooled_solve(
        a,
        b,
        pool,
        noise,
        weighted=weighting is not None,
        max_condition=max_condition,
        names=names,
        known=full[:, -1],
        arm=arm,
    )
    if not ready:
        # The noise model has fewer than MIN_POOLED_WINDOWS windows: σ would be
        # one window's guess; hold, not valid.
        estimate = identifier_apply(state.estimate, False, None)
        return PayloadState(estimate, state.correlation, solved.pool)
    result = solved.result
    if result.valid and jackknife is not None:
        result = with_jackknife(result, a, b, jackknife, solved.weights)
    estimate = identifier_apply(state.estimate, True, result)
    correlation = state.correlation
    if estimate.valid and solved.correlation is not None:
        correlation = _frozen(solved.correlation)
    return PayloadState(estimate, correlation, solved.pool)
