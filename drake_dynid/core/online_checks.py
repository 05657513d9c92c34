"""Checks of the on-line identifier's settings: their values, then against a log.

Two stages, both before anything is allocated (docs/CONVENTIONS.md §5):

* :func:`check_values` (``OnlineSettings.__post_init__``): types, ranges and the
  hard ceilings that do not depend on the log: at most
  ``core.fourier_bank.MAX_FUNCTIONS`` modulating functions (``frequencies``, or
  ``bandwidth``·``window`` for the default set), Jacobi ``jacobi_q`` <=
  :data:`MAX_JACOBI_Q` and ``kappa``, ``mu`` <= :data:`MAX_JACOBI_EXPONENT` (beyond
  them the filter's noise gain exceeds 1e3 and its design loses digits),
  ``max_condition`` <= :data:`MAX_CONDITION` (beyond it the QR's round-off can
  exceed σ), ``jacobi_window`` < ``window``.
* :func:`check_log` (``OnlineSettings.for_log``): the settings put on the log's
  grid (``OnlineSettings.on_grid``) and checked against it: the log is longer than
  ``window`` + ``jacobi_window`` and lasts until the first full window's estimate
  is recorded (:func:`first_estimate`); the differentiator has at most
  :data:`MAX_JACOBI_TAPS` taps; every modulating frequency (|ℓ| + k)/T is below
  the bank's Nyquist frequency 1/(2·bank_time_step) and inside the
  differentiator's pass band (its low-pass gain >= 1/√2 there: above it the
  filtered signals no longer satisfy the model's nonlinear terms and the window
  gives precise wrong values); with the robot's size, the window's samples fit in
  :data:`MAX_WINDOW_BYTES` and the ℓ set gives more independent equations than
  parameters plus ``core.row_noise.MIN_RESIDUAL_DOF`` (else no window can give an
  honest σ).

Every message names the setting through ``names`` (field -> name shown), so the
``dynid identify`` command reports its option names (``--window``) and the API
its field names (``window``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from drake_dynid.core._validate import listed
from drake_dynid.core.ell_rule import model_band
from drake_dynid.core.fourier_bank import MAX_FUNCTIONS, MAX_ORDER, MIN_FUNCTIONS
from drake_dynid.core.jacobi_design import MAX_EXPONENT, MAX_Q, MAX_TAPS
from drake_dynid.core.rows import MODEL_KINDS, num_channels

__all__ = [
    "MAX_CONDITION",
    "MAX_INDEX",
    "MAX_JACOBI_EXPONENT",
    "MAX_JACOBI_Q",
    "MAX_JACOBI_TAPS",
    "MAX_SECONDS",
    "MAX_WINDOW_BYTES",
    "PASS_BAND_GAIN",
    "WEIGHTING_NAMES",
    "check_log",
    "check_values",
    "first_estimate",
    "on_grid",
    "pass_band",
]

#: Largest Jacobi q (``core.jacobi_design.MAX_Q``).
MAX_JACOBI_Q = MAX_Q
#: Largest Jacobi κ and μ (``core.jacobi_design.MAX_EXPONENT``).
MAX_JACOBI_EXPONENT = MAX_EXPONENT
#: Most taps of the differentiator (``core.jacobi_design.MAX_TAPS``).
MAX_JACOBI_TAPS = MAX_TAPS
#: Largest window, Jacobi window, bank step or solve period [s] (about 11 days).
MAX_SECONDS = 1e6
#: Largest |ℓ| of a given ℓ set: ℓ/T Hz is then above the Nyquist frequency of
#: any bank the other ceilings allow.
MAX_INDEX = 1e6
#: Largest accepted max_condition: the QR's relative round-off, about cond·1e-16,
#: stays far below any σ.
MAX_CONDITION = 1e8
#: Largest memory of the bank's window (its samples times channels, float64) [B].
MAX_WINDOW_BYTES = 1 << 30
#: The differentiator's low-pass gain at the highest modulating frequency must be
#: at least this (-3 dB).
PASS_BAND_GAIN = 1.0 / math.sqrt(2.0)
#: The solves of ``OnlineSettings.weighting`` (``core.online.WEIGHTINGS``).
WEIGHTING_NAMES = ("frequency", "none", "covariance")

Say = Callable[[str], str]


def _namer(owner: str | None, names: Mapping[str, str] | None) -> tuple[str, Say]:
    prefix = f"{owner}: " if owner else ""
    return prefix, (lambda field: (names or {}).get(field, field))


def _fail(prefix: str, message: str) -> None:
    raise ValueError(f"{prefix}{message}")


def _real(prefix: str, name: str, value: Any, unit: str | None) -> float:
    numeric = (int, float, np.integer, np.floating)
    unit_text = f" [{unit}]" if unit else ""
    if isinstance(value, bool) or not isinstance(value, numeric):
        raise TypeError(
            f"{prefix}{name} must be a real number{unit_text}; got {value!r} of "
            f"type {type(value).__name__}."
        )
    out = float(value)
    if not math.isfinite(out):
        _fail(prefix, f"{name} must be finite{unit_text}; got {out}.")
    return out


def _positive(prefix: str, name: str, value: Any, unit: str | None) -> float:
    out = _real(prefix, name, value, unit)
    if out <= 0.0:
        _fail(prefix, f"{name} must be > 0{f' [{unit}]' if unit else ''}; got {out}.")
    return out


def _duration(prefix: str, name: str, value: Any) -> float:
    """A time setting in (0, :data:`MAX_SECONDS`] [s]."""
    out = _positive(prefix, name, value, "s")
    if out > MAX_SECONDS:
        _fail(prefix, f"{name} must be <= {MAX_SECONDS:g} [s]; got {out:g}.")
    return out


def _integer(prefix: str, name: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, (float, np.floating)) and float(value).is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(
            f"{prefix}{name} must be an integer in [{low}, {high}]; got {value!r} "
            f"of type {type(value).__name__}."
        )
    if not low <= int(value) <= high:
        _fail(prefix, f"{name} must be an integer in [{low}, {high}]; got {value}.")
    return int(value)


def _frequencies(prefix: str, name: str, value: Any) -> np.ndarray | None:
    """None (default set), the paper's set, or a checked 1-D array of ℓ."""
    if value is None:
        return None
    if isinstance(value, str):
        if value != "paper":
            _fail(
                prefix,
                f"{name} must be None, 'paper' or a list of reals; got {value!r}.",
            )
        return None
    if isinstance(value, bytes) or not hasattr(value, "__len__"):
        raise TypeError(
            f"{prefix}{name} must be None, 'paper' or a list of reals; got "
            f"{value!r} of type {type(value).__name__}."
        )
    if len(value) > MAX_FUNCTIONS:
        _fail(
            prefix,
            f"{name} must hold at most {MAX_FUNCTIONS} modulating indices ℓ; got "
            f"{len(value)}.",
        )
    try:
        ell = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(
            f"{prefix}{name} must be None, 'paper' or a list of reals; got {value!r}."
        ) from None
    if ell.ndim != 1 or ell.size == 0:
        _fail(prefix, f"{name} must be a non-empty list of reals; got {value!r}.")
    if not np.all(np.isfinite(ell)):
        _fail(prefix, f"{name} must hold finite indices ℓ; got {value!r}.")
    if np.max(np.abs(ell)) > MAX_INDEX:  # (beyond any bank's Nyquist frequency)
        _fail(
            prefix,
            f"{name} must hold indices |ℓ| <= {MAX_INDEX:g}; got "
            f"{float(np.max(np.abs(ell))):g}.",
        )
    if np.unique(np.round(ell, 12)).size != ell.size:
        _fail(prefix, f"{name} must not repeat an index ℓ; got {value!r}.")
    return ell


def _detect_changes(prefix: str, name: str, value: Any) -> None:
    """True, False or a ``core.change.ChangeDetection``."""
    from drake_dynid.core.change_design import ChangeDetection

    if value is True or value is False or isinstance(value, ChangeDetection):
        return
    raise TypeError(
        f"{prefix}{name} must be True, False or a ChangeDetection; got {value!r} of "
        f"type {type(value).__name__}."
    )


def check_values(
    values: Mapping[str, Any],
    *,
    owner: str | None = "OnlineSettings",
    names: Mapping[str, str] | None = None,
) -> None:
    """Checks the settings' values (types, ranges, hard ceilings), no log needed.

    Args:
        values: the ``OnlineSettings`` fields (missing ones are not checked).
        owner: the message prefix (None: none, as the CLI's messages).
        names: field -> name shown in the messages (default: the field names).

    Raises:
        ValueError: a bad value. TypeError: a bad type.
    """
    prefix, say = _namer(owner, names)
    get = values.get
    model = get("model", "lagrangian")
    if not isinstance(model, str) or model not in MODEL_KINDS:
        _fail(
            prefix,
            f"{say('model')} must be one of {', '.join(MODEL_KINDS)}; got {model!r}.",
        )
    window = _duration(prefix, say("window"), get("window", 20.0))
    order = _integer(prefix, say("order"), get("order", 1), 1, MAX_ORDER)
    ell = _frequencies(prefix, say("frequencies"), get("frequencies"))
    bandwidth = _positive(prefix, say("bandwidth"), get("bandwidth", 0.6), "Hz")
    if get("frequencies") is None:
        count = model_band(model, bandwidth) * window - order + 1.0
        if not count <= MAX_FUNCTIONS:
            _fail(
                prefix,
                f"{say('window')} x {say('bandwidth')} must give at most "
                f"{MAX_FUNCTIONS} modulating functions (ℓ = 0, 1, ... while "
                f"(ℓ + k)/T <= {say('bandwidth')}); got {window:g} s x "
                f"{bandwidth:g} Hz ({count:.3g} functions).",
            )
    del ell
    jacobi_window = _duration(prefix, say("jacobi_window"), get("jacobi_window", 0.4))
    for field in ("kappa", "mu"):
        value = _real(prefix, say(field), get(field, 1.0), None)
        if not -1.0 < value <= MAX_JACOBI_EXPONENT:
            _fail(
                prefix,
                f"{say(field)} must be in (-1, {MAX_JACOBI_EXPONENT:g}]; got "
                f"{value:g}.",
            )
    _integer(prefix, say("jacobi_q"), get("jacobi_q", 1), 0, MAX_JACOBI_Q)
    for field in ("bank_time_step", "update_period"):
        if get(field) is not None:
            _duration(prefix, say(field), get(field))
    condition = _real(prefix, say("max_condition"), get("max_condition", 1e4), None)
    if not 1.0 < condition <= MAX_CONDITION:
        _fail(
            prefix,
            f"{say('max_condition')} must be in (1, {MAX_CONDITION:g}] (beyond it "
            f"the solve's round-off can exceed σ); got {condition:g}.",
        )
    weighting = get("weighting", "frequency")
    if not isinstance(weighting, str) or weighting not in WEIGHTING_NAMES:
        _fail(
            prefix,
            f"{say('weighting')} must be one of "
            f"{', '.join(map(repr, WEIGHTING_NAMES))}; got {weighting!r}.",
        )
    for field, allowed in (
        ("rows_from", ("filtered", "raw")),
        ("uncertainty", ("jackknife", "sandwich", "gautier")),
    ):
        value = get(field, allowed[0])
        if not isinstance(value, str) or value not in allowed:
            _fail(
                prefix,
                f"{say(field)} must be one of {', '.join(map(repr, allowed))}; got "
                f"{value!r}.",
            )
    if get("raw_window") is not None:
        _duration(prefix, say("raw_window"), get("raw_window"))
    if get("min_functions") is not None:
        _integer(prefix, say("min_functions"), get("min_functions"), 1, MAX_FUNCTIONS)
    _noise_std(prefix, say, "position_noise", get("position_noise"), "rad or m")
    _noise_std(prefix, say, "torque_noise", get("torque_noise"), "N·m or N")
    _noise_use(prefix, say, values, model, weighting)
    _detect_changes(prefix, say("detect_changes"), get("detect_changes", False))
    step = get("bank_time_step")
    if step is not None and step > jacobi_window / 10:
        bank, jacobi = say("bank_time_step"), say("jacobi_window")
        _fail(  # the conflict both ways: either value may be the one given
            prefix,
            f"{bank} must be <= {jacobi}/10 [s] (the bank samples the "
            "differentiator's low-passed output; a coarser step aliases it); got "
            f"{bank} {step:g} with {jacobi} {jacobi_window:g}: lengthen {jacobi} "
            f"to at least {10 * step:g} s or shorten {bank} to at most "
            f"{jacobi_window / 10:g} s.",
        )
    if not jacobi_window < window:
        _fail(
            prefix,
            f"{say('jacobi_window')} must be < {say('window')} [s] (the "
            "differentiator's low-pass would remove the modulating frequencies); got "
            f"{jacobi_window:g} with {say('window')} {window:g}.",
        )


def _noise_std(prefix: str, say: Say, field: str, value: Any, unit: str) -> None:
    """None, or a white-noise std >= 0 [unit] (one, or one per joint)."""
    if value is None:
        return
    name = say(field)
    text = f"{name} must be None, a std >= 0 [{unit}] or one per joint"
    if isinstance(value, (str, bytes, bool)):
        raise TypeError(f"{prefix}{text}; got {value!r}.")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"{prefix}{text}; got {value!r}.") from None
    if array.ndim > 1 or array.size > 100_000 or (array.ndim == 1 and not array.size):
        _fail(prefix, f"{text}; got {value!r}.")
    if not np.all(np.isfinite(array)) or np.any(array < 0.0):
        _fail(prefix, f"{text}, finite; got {value!r}.")


def _own_noise(prefix: str, say: Say, position: Any, torque: Any) -> None:
    """Refuses a Lagrangian equation whose joint has no noise of its own.

    Joint j's equation gets noise from its own q_j and τ_j; with both stds 0 only
    the other joints' noise reaches it, through the coupling terms, and the rows'
    covariance is nearly singular: the whitened solve trusts those rows almost
    without limit and every window is ill-conditioned (a 4-joint UR5 log with
    σ_q = 0, 0, 0, 1e-4 rad and σ_τ = 0: Σ's eigenvalues span 1e-15, the whitened
    condition number 3e4 against 191 unweighted). A floor on Σ does not help:
    its weight still goes to the rows whose noise the stds leave out (a ridge of
    1e-6 of Σ's mean diagonal makes the windows valid with a median relative
    error of 28-55 % of the base parameters, against 5-11 % with every joint's
    noise given).
    """
    position = np.atleast_1d(np.asarray(position, dtype=float))
    torque = np.atleast_1d(np.asarray(torque, dtype=float))
    if position.size > 1 and torque.size > 1 and position.size != torque.size:
        return  # the per-joint length check names it (check_log)
    silent = np.flatnonzero((position == 0) & (torque == 0))
    if silent.size:
        joints = listed(str(j + 1) for j in silent)
        _fail(
            prefix,
            f"{say('weighting')} 'covariance' of the lagrangian model needs a "
            f"noise of every joint's own: joint(s) {joints} have "
            f"{say('position_noise')} 0 and {say('torque_noise')} 0, so their rows "
            "get only the other joints' noise, through the coupling terms: their "
            "covariance is nearly singular and every window ill-conditioned; give "
            f"them a {say('position_noise')} or {say('torque_noise')} > 0, or use "
            f"{say('weighting')} 'frequency'.",
        )


def _noise_use(
    prefix: str, say: Say, values: Mapping[str, Any], model: str, weighting: str
) -> None:
    """What the noise stds are for: the power rows' compensation, the covariance.

    ``position_noise`` compensates the power model's rows and, with the
    covariance weighting, shapes the rows' covariance (either model);
    ``torque_noise`` is for the covariance weighting only, which needs both and
    the filtered rows (``core.row_covariance``).
    """
    position, torque = values.get("position_noise"), values.get("torque_noise")
    if weighting == "covariance":
        missing = [
            say(field)
            for field, value in (("position_noise", position), ("torque_noise", torque))
            if value is None
        ]
        if missing:
            _fail(
                prefix,
                f"{say('weighting')} 'covariance' needs the white noise stds of the "
                f"positions and torques (the rows' covariance is computed from them); "
                f"{' and '.join(missing)} not given.",
            )
        if not (np.any(np.asarray(position) > 0) or np.any(np.asarray(torque) > 0)):
            _fail(
                prefix,
                f"{say('weighting')} 'covariance' needs a noise: "
                f"{say('position_noise')} and {say('torque_noise')} are all 0.",
            )
        silent = np.flatnonzero(np.atleast_1d(np.asarray(torque, dtype=float)) == 0)
        if not np.any(np.asarray(position) > 0) and silent.size:
            # Joint j's rows then carry no noise at all: their covariance is
            # singular, and the whitened solve trusts them without limit (the
            # 4R wrist with σ_τ on joint 1 only: FC1 1.31 ± 2.8e4 for 1.50).
            joints = listed(str(j + 1) for j in silent)
            _fail(
                prefix,
                f"{say('weighting')} 'covariance' needs a noise in every joint's "
                f"rows: with {say('position_noise')} 0, the rows of joint(s) "
                f"{joints} ({say('torque_noise')} 0) have none and their covariance "
                f"is singular; give them a {say('torque_noise')} > 0, a "
                f"{say('position_noise')} > 0, or {say('weighting')} 'frequency'.",
            )
        if model != "power":
            _own_noise(prefix, say, position, torque)
        rows_from = values.get("rows_from", "filtered")
        if rows_from != "filtered":
            _fail(
                prefix,
                f"{say('weighting')} 'covariance' models the noise of the filtered "
                f"rows; got {say('rows_from')} {rows_from!r} (use 'filtered', or "
                f"{say('weighting')} 'frequency').",
            )
        return
    if torque is not None:
        _fail(
            prefix,
            f"{say('torque_noise')} is used by {say('weighting')} 'covariance' "
            f"only; got {torque!r} with {say('weighting')} {weighting!r}.",
        )
    if position is not None and model != "power":
        _fail(
            prefix,
            f"{say('position_noise')} compensates the noise bias of the power "
            f"model's rows (and shapes the rows' covariance with {say('weighting')} "
            f"'covariance'); got {position!r} with {say('model')} {model!r} and "
            f"{say('weighting')} {weighting!r}.",
        )


def pass_band(settings: Any, time_step: float) -> float:
    """Upper edge of the differentiator's pass band [Hz] (gain 1/√2, -3 dB).

    The smoothing filter of ``settings.jacobi_filters(time_step)`` (the same
    low-pass acts on q, q̇ and τ), by bisection on |H(2πf)| below its first dip.
    """
    from drake_dynid.core.jacobi_design import jacobi_frequency_response

    smooth = settings.jacobi_filters(time_step)[0]

    def gain(f: float) -> float:
        return float(np.abs(jacobi_frequency_response(smooth, [2 * math.pi * f])[0]))

    nyquist = 0.5 / time_step
    low, high = 0.0, min(nyquist, 4.0 / smooth.window)
    while gain(high) >= PASS_BAND_GAIN and high < nyquist:
        low, high = high, min(nyquist, 2.0 * high)
    if gain(high) >= PASS_BAND_GAIN:
        return nyquist
    for _ in range(40):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if gain(middle) >= PASS_BAND_GAIN else (low, middle)
    return low


def on_grid(
    settings: Any,
    time_step: float,
    *,
    owner: str | None = "OnlineSettings",
    names: Mapping[str, str] | None = None,
) -> Any:
    """``settings.on_grid(time_step)``, its messages with the names of ``names``."""
    prefix, say = _namer(owner, names)
    taps = settings.jacobi_window / time_step + 1.0
    if not taps < MAX_JACOBI_TAPS:
        _fail(
            prefix,
            f"{say('jacobi_window')} must span fewer than {MAX_JACOBI_TAPS} samples "
            f"of the log ({(MAX_JACOBI_TAPS - 1) * time_step:g} s at h = "
            f"{time_step:g} s); got {settings.jacobi_window:g} s ({taps:.3g} "
            "samples).",
        )
    try:
        return settings.on_grid(time_step)
    except ValueError as error:
        raise ValueError(f"{prefix}{_renamed(str(error), say)}") from None


def first_estimate(settings: Any, time_step: float) -> tuple[float, float]:
    """``(solve, recorded)`` [s]: the first solve of a full window and its record.

    ``settings`` on the grid of h = ``time_step`` (docs/CONVENTIONS.md §2, the
    replay's order in ``core.replay``): the differentiator's outputs are valid from
    sample Tj/h (its Tj/h + 1 taps filled); the bank pushes the samples j = 0, D,
    2D, ... (D = bank_time_step/h) and its window is full with T/(D·h) + 1 valid
    ones; the solve at sample u (u = 0, U, 2U, ..., U = update_period/h) sees the
    pushes j <= u, and the trace records its estimate at the next solve time
    u + U. A log of N samples records the solves at u + U <= N.
    """
    h = float(time_step)
    d = settings.decimation(h)
    u = settings.solve_decimation(h)
    first = -(-round(settings.jacobi_window / h) // d) * d  # first valid push
    full = first + round(settings.window / (d * h)) * d  # its window full
    solve = -(-full // u) * u
    return solve * h, (solve + u) * h


def _highest_frequency(settings: Any) -> float:
    """(max|ℓ| + k)/T [Hz], the highest frequency of the modulating functions."""
    ell = settings.ell()
    return (float(np.max(np.abs(ell))) + settings.order) / settings.window


def check_log(
    settings: Any,
    time_step: float,
    duration: float,
    *,
    num_joints: int | None = None,
    num_parameters: int | None = None,
    owner: str | None = "OnlineSettings",
    names: Mapping[str, str] | None = None,
) -> Any:
    """``settings`` on the log's grid, checked against the log (module docstring).

    Args:
        settings: an ``OnlineSettings``.
        time_step: the log's sample period h [s].
        duration: the log's duration [s].
        num_joints: n, with ``num_parameters``: also check the window's memory and
            that the ℓ set can give an honest σ for this robot.
        num_parameters: p, the base parameters.
        owner: message prefix (None: none).
        names: field -> name shown in the messages.

    Returns:
        ``settings.on_grid(time_step)``.
    """
    prefix, say = _namer(owner, names)
    h = _positive(prefix, "the log's time step", time_step, "s")
    duration = _real(prefix, "the log's duration", duration, "s")
    needed = settings.window + settings.jacobi_window
    if duration <= needed:  # before the grid: the Jacobi design scales with it
        _fail(
            prefix,
            f"the log lasts {duration:g} s; the on-line identifier needs more than "
            f"{say('window')} + {say('jacobi_window')} = {needed:g} s before its "
            f"first estimate: record a longer log or shorten {say('window')}.",
        )
    grid = on_grid(settings, h, owner=owner, names=names)
    for field, unit in (("position_noise", "rad or m"), ("torque_noise", "N·m or N")):
        noise = getattr(grid, field)
        if num_joints is not None and np.ndim(noise) == 1 and len(noise) != num_joints:
            _fail(
                prefix,
                f"{say(field)} must hold one std per joint ({num_joints}) or one for "
                f"all [{unit}]; got {len(noise)} values.",
            )
    if num_joints is not None and num_parameters is not None:
        from drake_dynid.core.ell_rule import resolve_functions

        grid = resolve_functions(grid, h, num_joints, num_parameters)
    needed = grid.window + grid.jacobi_window
    if not duration > needed:
        _fail(
            prefix,
            f"the log lasts {duration:g} s; the on-line identifier needs more than "
            f"{say('window')} + {say('jacobi_window')} = {needed:g} s before its "
            f"first estimate: record a longer log or shorten {say('window')}.",
        )
    period = grid.resolved("update_period")
    solve, recorded = first_estimate(grid, h)
    if math.isfinite(duration) and round(duration / h) < round(recorded / h) - 1:
        _fail(
            prefix,
            f"{say('window')}, {say('jacobi_window')} and {say('update_period')} "
            f"must leave a solve of a full window whose estimate is recorded before "
            f"the end of the log ({duration:g} s): the first window is full for the "
            f"solve at {solve:g} s, recorded at {recorded:g} s (a solve's estimate "
            f"is recorded at the next solve time, a log of at least "
            f"{recorded - h:g} s); got {say('window')} {grid.window:g} s, "
            f"{say('update_period')} {period:g} s: record a longer log or shorten "
            f"{say('window')}.",
        )
    top = _highest_frequency(grid)
    bank_step = grid.resolved("bank_time_step")
    nyquist = 0.5 / bank_step
    which = say("frequencies") if grid.frequencies is not None else say("bandwidth")
    if top > nyquist * (1.0 + 1e-9):
        _fail(
            prefix,
            f"{which} must keep every modulating frequency (|ℓ| + k)/T at most the "
            f"bank's Nyquist frequency 1/(2·{say('bank_time_step')}) = {nyquist:g} "
            f"[Hz]; got {top:g} Hz with {say('window')} {grid.window:g} s.",
        )
    band = pass_band(grid, h)
    if top > band:
        subject, remedy = f"{which} must keep", f"lower {which}, "
        band_of_model = model_band(grid.model, grid.bandwidth)  # power: 2B
        if grid.frequencies is None and top > band_of_model * (1.0 + 1e-9):
            subject = (
                f"the default ℓ set (at least {MIN_FUNCTIONS} functions over "
                f"{say('window')} {grid.window:g} s) must keep"
            )
            remedy = ""
        _fail(
            prefix,
            f"{subject} every modulating frequency (|ℓ| + k)/T inside the "
            f"differentiator's pass band, <= {band:.3g} Hz with "
            f"{say('jacobi_window')} {grid.jacobi_window:g} s (above it the filtered "
            f"signals break the model and the estimates are precise but wrong); got "
            f"{top:.3g} Hz with {say('window')} {grid.window:g} s: {remedy}"
            f"lengthen {say('window')} or shorten {say('jacobi_window')}.",
        )
    if num_joints is not None and num_parameters is not None:
        _check_robot(prefix, say, grid, h, num_joints, num_parameters)
    return grid


def _check_robot(prefix: str, say: Say, grid: Any, h: float, n: int, p: int) -> None:
    from drake_dynid.core.ell_rule import independent_rows, rows_count, rows_remedy
    from drake_dynid.core.row_noise import MIN_RESIDUAL_DOF

    m = grid.num_equations(n)
    samples = grid.window / grid.resolved("bank_time_step") + 1.0
    size = samples * num_channels(m, p) * 8.0
    if size > MAX_WINDOW_BYTES:
        _fail(
            prefix,
            f"{say('window')} / {say('bank_time_step')} must keep the window's "
            f"samples within {MAX_WINDOW_BYTES / 2**30:g} GiB for {p} parameters; "
            f"got {grid.window:g} s / {grid.resolved('bank_time_step'):g} s "
            f"({size / 2**30:.3g} GiB).",
        )
    independent = independent_rows(grid)
    needed = p + MIN_RESIDUAL_DOF
    if m * independent < needed:
        which = say("frequencies") if grid.frequencies is not None else say("window")
        _fail(
            prefix,
            f"{which} gives {m * independent} independent rows "
            f"({rows_count(grid, independent, m)}) for {p} parameters; an honest "
            f"σ needs at least {needed:g}: "
            + rows_remedy(grid, h, needed, m, say)
            + (", or use the lagrangian model." if grid.model == "power" else "."),
        )


def _renamed(message: str, say: Say) -> str:
    """An ``OnlineSettings: ...`` message with the field names shown by ``say``."""
    import re

    owner = "OnlineSettings: "
    text = message[len(owner) :] if message.startswith(owner) else message
    fields = (
        "bank_time_step",
        "update_period",
        "jacobi_window",
        "raw_window",
        "window",
        "time_step",
    )
    pattern = re.compile(r"\b(" + "|".join(fields) + r")\b")
    return pattern.sub(lambda match: say(match.group(1)), text)
