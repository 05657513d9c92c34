"""Settings, timing and results of the on-line identifier (pure configuration).

One on-line identifier is the chain (docs/CONVENTIONS.md §2-§3)::

    [q; τ] every h ──► matched causal Jacobi filters (orders 0, 1)
        ──► (q̂, v̂, τ̂) at t - delay ──► model rows (D, G, y) ──► modulating bank
        (every bank_time_step, window T) ──► sliding least squares (every
        update_period) ──► θ̂, σ(θ̂), cond, valid, status

Two drivers run it on the same numerics: the Drake blocks
(``drake_dynid.diagrams.add_online_identifier``) and the vectorised core replay
(:mod:`drake_dynid.core.replay`). This module holds what both read:
:class:`OnlineSettings` (with the one ℓ rule and the one construction of the Jacobi
filters and of the bank), the event offsets :data:`BANK_OFFSET` and
:data:`SOLVE_OFFSET`, and :class:`OnlineTrace` (defined in ``core.trace``), the
estimates over time.

Periods on the signal grid (:meth:`OnlineSettings.on_grid`, docs/CONVENTIONS.md
§2): every event period and window must be a whole number of its sample period.
``bank_time_step`` and ``update_period`` left at None become the multiples of the
signal period h closest to their nominal values (:data:`NOMINAL_BANK_TIME_STEP`,
:data:`NOMINAL_UPDATE_PERIOD`; ties go to the smaller one), the bank step at most
``jacobi_window``/10; the Jacobi window and the modulating window become the
nearest multiples of h and of the bank step when they are not already. At
h = 1 ms nothing moves; a 125 Hz log (h = 8 ms) gets a 16 ms bank and a 96 ms
solve period.

Checks before any allocation (``core.online_checks``): the constructor checks every
value and its hard ceiling; :meth:`OnlineSettings.for_log` puts the settings on a
log's grid and checks them against the log and the robot (length, Nyquist, the
differentiator's pass band, window memory, enough independent equations for an
honest σ), with the messages in the caller's names (``dynid identify`` shows its
options).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core.ell_rule import model_band
from drake_dynid.core.fourier_bank import (
    MIN_FUNCTIONS,
    FourierBank,
    band_frequencies,
    fourier_bank,
    paper_frequencies,
)
from drake_dynid.core.jacobi_design import JacobiFilter, jacobi_filters
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION
from drake_dynid.core.online_checks import WEIGHTING_NAMES, check_log, check_values
from drake_dynid.core.raw_rows import RawRowsDesign, raw_rows_design
from drake_dynid.core.rows import check_model_kind, num_equations
from drake_dynid.core.trace import OnlineTrace

__all__ = [
    "BANK_OFFSET",
    "JACKKNIFE_FUNCTIONS",
    "MIN_BANK_SAMPLES_PER_JACOBI_WINDOW",
    "MIN_FUNCTIONS",
    "MIN_JACKKNIFE_GROUPS",
    "MODEL_DEFAULTS",
    "NOMINAL_BANK_TIME_STEP",
    "NOMINAL_COVARIANCE_UPDATE_PERIOD",
    "NOMINAL_RAW_WINDOW",
    "NOMINAL_UPDATE_PERIOD",
    "ROWS_FROM",
    "SOLVE_OFFSET",
    "UNCERTAINTIES",
    "WEIGHTINGS",
    "OnlineSettings",
    "OnlineTrace",
    "nearest_multiple",
    "nearest_on_grid",
]

#: Offsets of the bank's and the solver's periodic events, in signal periods h:
#: the bank updates at t_j + h/2, the solver at t_u + 3h/4 (docs/CONVENTIONS.md §2).
BANK_OFFSET = 0.5
SOLVE_OFFSET = 0.75

#: Nominal bank sample period [s]: 20 ms costs no accuracy against 5 ms on the
#: paper's 2R at 30 dB (0.93 / 2.76 % vs 0.97 / 2.71 % inertial / friction, 8 seeds)
#: and makes the closed loop about 1.5 times faster.
NOMINAL_BANK_TIME_STEP = 0.02

#: Nominal period of the least-squares solve [s].
NOMINAL_UPDATE_PERIOD = 0.1

#: Nominal period of the solve with ``weighting="covariance"`` [s]: each of its
#: solves builds the rows' covariance (0.05 s on the 2R, 0.4 s on a 7-DOF arm,
#: 116 functions), so it solves every second unless told otherwise.
NOMINAL_COVARIANCE_UPDATE_PERIOD = 1.0

#: The bank samples the differentiator's output at least this many times per Jacobi
#: window (its low-pass has a cut-off of a few 1/jacobi_window).
MIN_BANK_SAMPLES_PER_JACOBI_WINDOW = 10

#: Nominal window of the raw rows' central velocity estimate [s] (benchmarks: on the
#: iiwa7 without noise 0.1-0.3 s leave < 0.03 % of bias; longer windows filter more
#: of the position noise).
NOMINAL_RAW_WINDOW = 0.2

#: Least-squares weightings of OnlineSettings.weighting.
WEIGHTINGS = WEIGHTING_NAMES

#: Standard deviations of OnlineSettings.uncertainty.
UNCERTAINTIES = ("jackknife", "sandwich", "gautier")

#: Adjacent modulating functions per jackknife group (OnlineSettings.jackknife_groups).
JACKKNIFE_FUNCTIONS = 2

#: Fewest jackknife groups for the jackknife σ: with G groups its variance has G - 1
#: degrees of freedom, and with the 4 groups of a short window (8 functions) it
#: overstated σ up to 15 times on the 2R (benchmarks/bench_sigma.py, T = 2-5 s);
#: fewer groups keep the sandwich σ alone. The iiwa7 benchmark's default window
#: (10 functions, 5 groups) keeps it.
MIN_JACKKNIFE_GROUPS = 5

#: Signals of the model rows (OnlineSettings.rows_from): the matched-filtered
#: signals, or the raw signals with the rows averaged over each bank step
#: (``core.raw_rows``).
ROWS_FROM = ("filtered", "raw")

#: Per-model defaults (benchmarks/bench_accuracy.py, 2R at SNR 30 dB over noise seeds,
#: geometries and trajectories): κ = μ = q = 1 for both; the Lagrangian model, whose
#: linear terms the matched differentiator keeps exact, gains from a longer Jacobi
#: window than the power model, quadratic in the filtered signals. The power model's
#: 0.2 s passes up to 5.8 Hz, which the covariance weighting's ℓ set covers (0.3 s:
#: 3.9 Hz, friction error 10.4 % instead of 9.4 % over 100 seeds); the frequency
#: weighting gives about the same with both (21.9 and 22.4 %). ``bandwidth`` is the
#: excitation band the default ℓ set covers: measure it on your data with
#: ``drake_dynid.core.excitation.estimate_bandwidth`` (``dynid identify`` does).
MODEL_DEFAULTS: dict[str, dict[str, Any]] = {
    "lagrangian": {"jacobi_window": 0.4, "kappa": 1.0, "mu": 1.0, "bandwidth": 0.6},
    "power": {"jacobi_window": 0.2, "kappa": 1.0, "mu": 1.0, "bandwidth": 0.6},
}

_OWNER = "OnlineSettings"
_GRID_RTOL = 1e-9  # a value within this relative distance of a multiple is one


def nearest_multiple(value: float, step: float, *, at_most: int | None = None) -> int:
    """The count c >= 1 whose multiple c·step is closest to ``value``.

    Ties go to the smaller count; ``at_most`` caps the count (still >= 1).
    """
    value = check.real("nearest_multiple", "value", value)
    step = check.positive("nearest_multiple", "step", step)
    ratio = value / step
    if not np.isfinite(ratio):
        check.fail(
            "nearest_multiple",
            f"value / step must be finite; got {value:g} / {step:g}.",
        )
    count = max(1, math.floor(ratio + 0.5 - _GRID_RTOL))
    if at_most is not None:
        count = max(1, min(count, at_most))
    return count


def _is_multiple(value: float, step: float) -> bool:
    ratio = value / step
    if not math.isfinite(ratio):
        return False
    count = round(ratio)
    return count >= 1 and abs(ratio - count) <= _GRID_RTOL * max(1.0, abs(ratio))


def nearest_on_grid(value: float, step: float) -> float:
    """``value`` if it is a multiple of ``step``, else the nearest multiple (>= 1)."""
    return value if _is_multiple(value, step) else nearest_multiple(value, step) * step


@dataclass(frozen=True)
class OnlineSettings:
    """Settings of one on-line identifier (all echoed in the JSON results).

    Attributes:
        model: ``"lagrangian"`` (n equations per sample, the default) or ``"power"``
            (the paper's scalar power model).
        window: sliding window T of the modulating functions [s].
        order: modulating order k (>= 1).
        frequencies: indices ℓ of the modulating functions; None uses the default
            set (:meth:`ell`: the band's integer bins, at least
            :data:`MIN_FUNCTIONS`), ``"paper"`` the paper's ℓ = 0:0.05:10.
        bandwidth: highest excitation frequency the default ℓ set covers [Hz].
        jacobi_window: window Tj of the causal Jacobi differentiator [s].
        kappa, mu, jacobi_q: Jacobi parameters κ, μ, q of the velocity estimate
            (q̂, τ̂ use κ+1, μ+1: the matched bank).
        bank_time_step: sample period of the bank [s], a multiple of the signal
            period h (the bank decimates after the differentiator's low-pass), at
            most jacobi_window/10. None (default): the multiple of h closest to
            :data:`NOMINAL_BANK_TIME_STEP` (20 ms), see :meth:`on_grid`.
        update_period: period of the least-squares solve [s], a multiple of h.
            None (default): the multiple of h closest to
            :data:`NOMINAL_UPDATE_PERIOD` (0.1 s), or
            :data:`NOMINAL_COVARIANCE_UPDATE_PERIOD` (1 s) with
            ``weighting="covariance"``.
        max_condition: largest accepted condition number of the column-scaled A
            (default ``core.lsq.DEFAULT_MAX_CONDITION``).
        weighting: ``"frequency"`` (default): two-step weighted least squares
            whose row weights follow a fitted noise model σ_j²(ν) = a_j + b_j ν²
            per equation j (high-ℓ rows carry more velocity-estimate noise;
            ``weighted_lsq.solve_frequency_weighted_least_squares``);
            ``"none"``: ordinary least squares, as in the paper. On the 2R
            benchmark at 30 dB the weighting halves the inertial error
            (benchmarks/bench_accuracy.py). ``"covariance"``: generalised least
            squares with the rows' noise covariance computed from the window's
            samples, the filters and ``position_noise``, ``torque_noise``
            (``core.row_covariance``: the rows of different ℓ share the velocity
            estimate's noise, which no weighting per row can use); it needs both
            stds and the filtered rows, its default ℓ set covers the
            differentiator's pass band (``core.ell_rule``), and σ is the
            generalised least squares', with ``uncertainty`` ``"jackknife"`` the
            larger of it and a jackknife over the whitened rows (docs/MATH.md
            §4). On the
            paper's 2R at SNR 30 dB it halves the power model's friction and
            inertial errors (README, Accuracy).
        rows_from: ``"filtered"`` (default): the model rows of the matched-filtered
            signals (q̂, v̂, τ̂), the least noisy, but the filter does not commute
            with the nonlinear terms (sign(v̂), velocity products): a bias of
            about 2 % on a 7-DOF arm, 0.3 % of friction on the paper's 2R.
            ``"raw"``: the rows of the raw positions and torques (delayed) and a
            central velocity estimate over ``raw_window``, averaged over each
            bank step (``core.raw_rows``): no filter bias, more velocity noise
            in the nonlinear terms; for logs with a low position noise
            (``core.raw_rows.rows_from_noise`` decides from the log;
            ``dynid identify --rows-from auto``).
        uncertainty: ``"jackknife"`` (default): σ is, per parameter, the larger
            of the honest sandwich σ (``core.row_noise``: correlated rows, noise
            growing with the frequency) and the jackknife's deleting one pair of
            adjacent modulating functions at a time (``core.jackknife``: also
            covers the noise in the regressor and a filter bias that changes with
            the modulating frequency); ``"sandwich"``: the sandwich σ alone;
            ``"gautier"``: Gautier's σ alone (independent rows of equal variance,
            the paper's; no check of the residual's degrees of freedom).
        min_functions: fewest functions of the default ℓ set; None: at least
            :data:`MIN_FUNCTIONS`, raised by :meth:`for_robot` to the count rule
            of ``core.ell_rule`` (twice the rows the robot needs).
        position_noise: white position noise σ_q [rad or m], one or one per
            joint; given, the power model's rows have its known bias removed
            (``core.noise_bias``) and the covariance weighting uses it; None
            (default): no compensation.
        torque_noise: white torque noise σ_τ [N·m or N], one or one per joint,
            for the covariance weighting only (None otherwise, the default).
        raw_window: window 2m·h of the central velocity estimate of the raw rows
            [s] (an even multiple of h; the rows refer to m·h earlier). With
            bank_time_step it must fit in the differentiator's ring:
            raw_window + bank_time_step <= jacobi_window + h. None (default):
            the longest even multiple of h that fits, at most
            :data:`NOMINAL_RAW_WINDOW` (0.2 s), see :meth:`on_grid`.
        detect_changes: False (default): the sliding window alone, which
            forgets an abrupt change of the parameters in about T. True (the
            default ``core.change.ChangeDetection``) or a ``ChangeDetection``:
            a CUSUM test on the equation error of the last second against the
            estimate detects a change and restarts the estimation from it
            (``core.change``, docs/MATH.md §4, change detection; the traces'
            ``change`` fields).
    """

    model: str = "lagrangian"
    window: float = 20.0
    order: int = 1
    frequencies: Any = None
    bandwidth: float = 0.6
    jacobi_window: float = 0.4
    kappa: float = 1.0
    mu: float = 1.0
    jacobi_q: int = 1
    bank_time_step: float | None = None
    update_period: float | None = None
    max_condition: float = DEFAULT_MAX_CONDITION
    weighting: str = "frequency"
    rows_from: str = "filtered"
    uncertainty: str = "jackknife"
    raw_window: float | None = None
    min_functions: int | None = None
    position_noise: float | tuple[float, ...] | None = None
    detect_changes: Any = False
    torque_noise: float | tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        # Types, ranges and the hard ceilings on the work per value
        # (core.online_checks), before anything is allocated.
        check_values({f.name: getattr(self, f.name) for f in dataclasses.fields(self)})
        for field in ("position_noise", "torque_noise"):
            noise: Any = getattr(self, field)
            if noise is not None:  # hashable and JSON-friendly: a float or a tuple
                array = np.asarray(noise, dtype=float)
                value = float(array) if array.ndim == 0 else tuple(array.tolist())
                object.__setattr__(self, field, value)
        if self.min_functions is not None:
            object.__setattr__(self, "min_functions", int(self.min_functions))

    @classmethod
    def for_model(cls, model: str, **overrides: Any) -> OnlineSettings:
        """Default settings of ``model`` (:data:`MODEL_DEFAULTS`), with overrides."""
        check_model_kind(_OWNER, model, "model")
        return cls(**{"model": model, **MODEL_DEFAULTS[model], **overrides})

    # ----------------------------------------------------------- the signal grid
    @property
    def on_signal_grid(self) -> bool:
        """True once :meth:`on_grid` has fixed the periods and the raw window."""
        return (
            self.bank_time_step is not None
            and self.update_period is not None
            and self.raw_window is not None
        )

    def on_grid(self, time_step: float) -> OnlineSettings:
        """These settings for signals sampled every ``time_step`` h [s].

        * ``bank_time_step`` None: the multiple of h closest to
          min(:data:`NOMINAL_BANK_TIME_STEP`, jacobi_window/10), at most
          jacobi_window/10; given: it must be a multiple of h.
        * ``update_period`` None: the multiple of h closest to
          :data:`NOMINAL_UPDATE_PERIOD` (:data:`NOMINAL_COVARIANCE_UPDATE_PERIOD`
          with the covariance weighting); given: it must be a multiple of h.
        * ``jacobi_window``: the nearest multiple of h when it is not one;
          ``window``: the nearest multiple of the bank step when it is not one;
          ``raw_window`` None: the longest even multiple of h up to
          :data:`NOMINAL_RAW_WINDOW` that fits in the differentiator's ring with
          one bank step; given: the nearest even multiple (>= 2) of h.

        Ties go to the smaller multiple; a value already on the grid is kept
        exactly. Idempotent.

        Raises:
            ValueError: a given ``bank_time_step`` or ``update_period`` is not a
                multiple of h, ``jacobi_window`` is shorter than 10 h, or (raw
                rows) raw_window + bank_time_step > jacobi_window + h.
        """
        h = check.positive(_OWNER, "time_step", time_step, "s")
        jacobi_window = nearest_on_grid(self.jacobi_window, h)
        limit = jacobi_window / MIN_BANK_SAMPLES_PER_JACOBI_WINDOW
        if limit < h * (1.0 - _GRID_RTOL):
            check.fail(
                _OWNER,
                f"jacobi_window must be >= {MIN_BANK_SAMPLES_PER_JACOBI_WINDOW} signal "
                f"periods ({MIN_BANK_SAMPLES_PER_JACOBI_WINDOW * h:g} s) so that the "
                f"bank samples its output often enough; got {self.jacobi_window:g} "
                f"with h {h:g}.",
            )
        if self.bank_time_step is None:
            nominal = min(NOMINAL_BANK_TIME_STEP, limit)  # as in bank()
            if _is_multiple(nominal, h):
                bank_time_step = nominal
            else:
                top = max(1, math.floor(limit / h + _GRID_RTOL))
                bank_time_step = nearest_multiple(nominal, h, at_most=top) * h
        else:
            bank_time_step = self._given_multiple("bank_time_step", h)
        if self.update_period is None:
            nominal_period = (
                NOMINAL_COVARIANCE_UPDATE_PERIOD
                if self.weighting == "covariance"
                else NOMINAL_UPDATE_PERIOD
            )
            update_period = nearest_on_grid(nominal_period, h)
        else:
            update_period = self._given_multiple("update_period", h)
        ring = round(jacobi_window / h) + 1  # samples the raw rows may read
        room = ring - round(bank_time_step / h)
        if self.raw_window is None:
            fits = max(1, room // 2)
            raw_window = (
                2.0 * h * min(nearest_multiple(NOMINAL_RAW_WINDOW, 2 * h), fits)
            )
        elif _is_multiple(self.raw_window, 2.0 * h):
            raw_window = float(self.raw_window)
        else:
            raw_window = 2.0 * h * nearest_multiple(self.raw_window, 2.0 * h)
        if self.rows_from == "raw":
            if round(raw_window / h) > room:
                check.fail(
                    _OWNER,
                    "raw rows read raw_window + bank_time_step of signal from the "
                    "differentiator's ring: raw_window + bank_time_step must be <= "
                    f"jacobi_window + h [s]; got {raw_window:g} + {bank_time_step:g} "
                    f"with jacobi_window {jacobi_window:g} and h {h:g}.",
                )
        return dataclasses.replace(
            self,
            window=nearest_on_grid(self.window, bank_time_step),
            jacobi_window=jacobi_window,
            bank_time_step=bank_time_step,
            update_period=update_period,
            raw_window=raw_window,
        )

    def for_log(
        self,
        time_step: float,
        duration: float,
        *,
        num_joints: int | None = None,
        num_parameters: int | None = None,
        owner: str | None = _OWNER,
        names: dict[str, str] | None = None,
    ) -> OnlineSettings:
        """These settings on a log's grid, checked against the log first.

        :meth:`on_grid` plus the checks of ``core.online_checks.check_log``, all
        before anything is allocated: the log is longer than window +
        jacobi_window and lasts until the first full window's estimate is
        recorded (``core.online_checks.first_estimate``), every modulating
        frequency is below the bank's Nyquist frequency and inside the
        differentiator's pass band, the differentiator and (with the robot's n
        and p) the window's samples stay within their ceilings, and the ℓ set
        gives enough independent equations for an honest σ. ``owner`` and
        ``names`` (field -> name shown) set the messages' words
        (the ``dynid identify`` command shows its option names).

        Args:
            time_step: the log's sample period h [s].
            duration: the log's duration [s].
            num_joints: n (optional, with ``num_parameters``).
            num_parameters: p, the base parameters (optional).
            owner: message prefix (None: none).
            names: field -> name shown in the messages.
        """
        return check_log(
            self,
            time_step,
            duration,
            num_joints=num_joints,
            num_parameters=num_parameters,
            owner=owner,
            names=names,
        )

    def for_robot(
        self, time_step: float, num_joints: int, num_parameters: int
    ) -> OnlineSettings:
        """:meth:`on_grid`, then the ℓ count rule and the row count for a robot.

        ``core.ell_rule.for_robot``: ``min_functions`` None becomes the count
        rule's (within the pass band and Nyquist); an ℓ set giving fewer
        independent rows than p raises, saying what to change. Both drivers
        call it; idempotent.
        """
        from drake_dynid.core.ell_rule import for_robot

        return for_robot(self, time_step, num_joints, num_parameters)

    def row_provider(self, rows: Any, time_step: float) -> Any:
        """The row provider the drivers use: ``rows``, or the noise-compensated one.

        With ``position_noise`` (power model): ``rows`` with the known noise bias
        of the rows removed (``core.noise_bias.rows_for_settings``); else ``rows``.
        """
        if self.position_noise is None or self.model != "power":
            return rows
        from drake_dynid.core.noise_bias import rows_for_settings

        return rows_for_settings(self, rows, time_step)

    def covariance_design(self, time_step: float, num_joints: int) -> Any:
        """The covariance weighting's fixed part (``core.row_covariance``).

        The bank, the matched filters' taps, the decimation and the noise stds of
        these settings on the grid of ``time_step`` (after :meth:`on_grid`);
        None unless ``weighting`` is ``"covariance"``.
        """
        if self.weighting != "covariance":
            return None
        from drake_dynid.core.row_covariance import covariance_design

        smooth, velocity = self.jacobi_filters(time_step)
        return covariance_design(
            self.bank(),
            self.num_equations(num_joints),
            smooth.taps,
            velocity.taps,
            self.decimation(time_step),
            self.position_noise,
            self.torque_noise,
            model=self.model,
            num_joints=num_joints,
        )

    def _given_multiple(self, name: str, h: float) -> float:
        value = getattr(self, name)
        if not _is_multiple(value, h):
            check.fail(
                _OWNER,
                f"{name} must be a multiple of the signal period h [s]; got "
                f"{value:g} with h {h:g} (leave it unset for the multiple of h "
                "closest to the nominal value).",
            )
        return float(value)

    def decimation(self, time_step: float) -> int:
        """Signal samples per bank sample, bank_time_step/h (after :meth:`on_grid`)."""
        h = check.positive(_OWNER, "time_step", time_step, "s")
        return round(self.resolved("bank_time_step") / h)

    def solve_decimation(self, time_step: float) -> int:
        """Signal samples per solve, update_period/h (after :meth:`on_grid`)."""
        h = check.positive(_OWNER, "time_step", time_step, "s")
        return round(self.resolved("update_period") / h)

    def resolved(self, name: str) -> float:
        """``name`` (``"bank_time_step"``, ``"update_period"``, ``"raw_window"``) [s].

        Raises:
            ValueError: it is None (not set and not yet put on a grid).
        """
        value = getattr(self, name)
        if value is None:
            check.fail(
                _OWNER,
                f"{name} is not set; call on_grid(time_step) with the signal period "
                "first (or give it).",
            )
        return float(value)

    # --------------------------------------------------------------- the designs
    def num_equations(self, num_joints: int) -> int:
        """m, equations per sample: 1 (power) or n (Lagrangian)."""
        return num_equations(self.model, num_joints)

    def ell(self) -> np.ndarray:
        """The modulating indices ℓ of this configuration.

        ``frequencies=None``: the default set, the integers ℓ = 0, 1, ... with
        (ℓ + k)/T up to the model's band (``bandwidth``; the power model
        ``core.ell_rule.POWER_BAND_FACTOR`` times it: its rows are products of
        velocities and torques), extended with the next integers to at least
        ``min_functions`` (default :data:`MIN_FUNCTIONS`; :meth:`for_robot`
        raises it for the robot) when the band holds fewer
        (``core.fourier_bank.band_frequencies``, the library's one ℓ rule).
        """
        if self.frequencies is None:
            return band_frequencies(
                self.window,
                model_band(self.model, self.bandwidth),
                order=self.order,
                min_count=self.min_functions or MIN_FUNCTIONS,
            )
        if isinstance(self.frequencies, str):
            return paper_frequencies()
        return np.asarray(self.frequencies, dtype=float)

    def bank(self) -> FourierBank:
        """The modulating-function design.

        Its sample period is ``bank_time_step``; while that is None (before
        :meth:`on_grid`), the nominal min(:data:`NOMINAL_BANK_TIME_STEP`,
        jacobi_window/10), for signals whose period divides it.
        """
        step = self.bank_time_step
        if step is None:
            step = min(
                NOMINAL_BANK_TIME_STEP,
                self.jacobi_window / MIN_BANK_SAMPLES_PER_JACOBI_WINDOW,
            )
        return fourier_bank(self.window, step, order=self.order, ell=self.ell())

    def row_weighting(
        self, m: int, bank: Any = None
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The solver's ``weighting`` argument (``weighted_lsq.solve_window``).

        None for ordinary least squares, else ``(row_frequency, row_group)`` of
        the bank's rows (``bank.row_frequencies``).

        Args:
            m: equations per sample of the model rows.
            bank: this configuration's bank when already built (default: builds
                ``self.bank()``); any ``core.bank.ModulatingBank``.
        """
        if self.weighting == "none":
            return None
        return (self.bank() if bank is None else bank).row_frequencies(m)

    def row_noise(self, m: int, bank: Any = None) -> Any:
        """The rows' noise structure for the honest σ (``core.row_noise``).

        ``core.row_noise.row_noise(bank, m)``: row frequencies, noise groups and
        the correlation of one equation's rows (docs/MATH.md §4); None with
        ``uncertainty="gautier"``. Both drivers pass it to the identifier step,
        whatever the weighting.
        """
        if self.uncertainty == "gautier":
            return None
        from drake_dynid.core.row_noise import row_noise

        return row_noise(self.bank() if bank is None else bank, m)

    def jackknife_groups(self, m: int, bank: Any = None) -> np.ndarray | None:
        """The solver's ``jackknife`` argument (``weighted_lsq.solve_window``).

        None unless ``uncertainty="jackknife"``, else the group of every row: the
        pairs of adjacent modulating functions, ``bank.row_functions(m) //``
        :data:`JACKKNIFE_FUNCTIONS` (adjacent functions share a Fourier line; on
        the 2R benchmark pairs give err/σ p90 1.8-2.4 where single functions
        give 1.9-3.3). None too when that makes fewer than
        :data:`MIN_JACKKNIFE_GROUPS` groups (a short window: the sandwich σ alone).

        Args:
            m: equations per sample of the model rows.
            bank: this configuration's bank when already built (default: builds
                ``self.bank()``).
        """
        if self.uncertainty != "jackknife":
            return None
        functions = (self.bank() if bank is None else bank).row_functions(m)
        groups = functions // JACKKNIFE_FUNCTIONS
        if np.unique(groups).size < MIN_JACKKNIFE_GROUPS:
            return None
        return groups

    def raw_design(self, time_step: float) -> RawRowsDesign:
        """The raw-rows design (``core.raw_rows``) on the grid of ``time_step`` h.

        Velocity window ``raw_window``, D = bank_time_step/h samples per bank
        sample (after :meth:`on_grid`).
        """
        window = self.resolved("raw_window")
        return raw_rows_design(window, time_step, self.decimation(time_step))

    def delay(self, time_step: float) -> float:
        """The latency of the bank's samples behind the newest signal sample [s].

        Filtered rows: the Jacobi filters' delay; raw rows: the raw design's
        (m + (D - 1)/2)·h. The estimate's latency adds the solve offset
        (:data:`SOLVE_OFFSET` h).
        """
        if self.rows_from == "raw":
            return self.raw_design(time_step).delay
        return self.jacobi_filters(time_step)[0].delay

    def jacobi_parameters(self) -> dict[str, Any]:
        """Arguments of the matched differentiator (orders 0 and 1) but the period.

        ``window``, ``kappa``, ``mu``, ``q``, ``orders``, ``matched``: the same for
        ``core.jacobi.jacobi_filters`` and the ``CausalJacobiDifferentiator``
        block. Identifiers with equal parameters can share one differentiator.
        """
        return {
            "window": self.jacobi_window,
            "kappa": self.kappa,
            "mu": self.mu,
            "q": self.jacobi_q,
            "orders": (0, 1),
            "matched": True,
        }

    def jacobi_filters(self, time_step: float) -> tuple[JacobiFilter, ...]:
        """The matched Jacobi filters ``(smooth, velocity)`` at period ``time_step``.

        Order 0 smooths q and τ, order 1 estimates q̇; both are the same low-pass
        D⁰(κ+1, μ+1, q) and refer to the same instant t - delay (docs/MATH.md §1).
        """
        parameters = self.jacobi_parameters()
        return jacobi_filters(
            parameters.pop("orders"), time_step=time_step, **parameters
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly dict of the settings (ℓ as a list)."""
        out = asdict(self)
        out["frequencies"] = self.ell().tolist()
        return out
