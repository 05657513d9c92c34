"""``dynid identify``: on-line identification blocks replayed over a recorded log."""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import numpy as np

from drake_dynid.commands._arguments import (
    add_common_arguments,
    apply_dead_zone,
    check_topic,
    dead_zone_cover,
    dead_zone_line,
    load_robot_and_log,
    model_settings,
)
from drake_dynid.commands._background import Background
from drake_dynid.commands._noise import (
    add_noise_arguments,
    measured_noise,
    noise_lines,
    noise_option,
)
from drake_dynid.commands._report import (
    estimates_table,
    json_number,
    log_document,
    matplotlib_pyplot,
    parameters_document,
    resampled_log_note,
    write_estimates_csv,
    write_trace_outputs,
)
from drake_dynid.core._validate import listed
from drake_dynid.core.bootstrap import (
    DEFAULT_REPLICATES,
    MAX_REPLICATES,
    bootstrap_std,
)
from drake_dynid.core.rows import MODEL_KINDS

HELP = "on-line identification (modulating functions + sliding QR) over a robot log"
DESCRIPTION = (
    "Replays a recorded robot log (CSV: t, q_<joint>, tau_<joint> for every URDF "
    "joint) through drake_dynid's on-line identifier: causal Jacobi differentiator "
    "-> model rows (power or Lagrangian) -> modulating-integral bank over a sliding "
    "window -> sliding QR identifier. The default engine (--engine core) runs the "
    "vectorised numerical core, without a Simulator; --engine blocks steps the Drake "
    "LeafSystems in a Drake Simulator (the reference: both give the same "
    "estimates). Prints the final base-parameter estimates with their standard "
    "deviations (a parameter with %σ > 30 is flagged '*' = not identified), the "
    "condition number and the validity of the last window; optionally writes the "
    "estimates over time (--out CSV, --plot PNG) and a JSON summary (--json). Options "
    "left "
    "out take the OnlineSettings defaults; the bank and solve periods default to "
    "the multiples of the log's time step closest to 20 ms and 0.1 s."
)

# Option name -> OnlineSettings field; None values keep the OnlineSettings default.
_SETTING_OPTIONS = {
    "model": "model",
    "window": "window",
    "bandwidth": "bandwidth",
    "jacobi_window": "jacobi_window",
    "kappa": "kappa",
    "mu": "mu",
    "jacobi_q": "jacobi_q",
    "bank_time_step": "bank_time_step",
    "update_period": "update_period",
    "max_condition": "max_condition",
    "weighting": "weighting",
    "raw_window": "raw_window",
    "uncertainty": "uncertainty",
    "detect_changes": "detect_changes",
}


#: OnlineSettings field -> the option that sets it (the names the messages show).
OPTION_NAMES = {
    field: f"--{option.replace('_', '-')}" for option, field in _SETTING_OPTIONS.items()
}
OPTION_NAMES["frequencies"] = "--frequencies"
OPTION_NAMES["position_noise"] = "--position-noise"
OPTION_NAMES["torque_noise"] = "--torque-noise"


# --------------------------------------------------------------------- identify
def _frequencies(text: str | None) -> Any:
    """``paper`` | ``auto`` | ``LIST`` (comma-separated ℓ, or ``start:step:stop``).

    The count of a ``start:step:stop`` range is checked (at most
    ``core.fourier_bank.MAX_FUNCTIONS``) before the list is built.
    """
    from drake_dynid.core.fourier_bank import MAX_FUNCTIONS
    from drake_dynid.core.online_checks import MAX_INDEX

    if text is None:
        return "default"
    text = text.strip()
    if text == "paper":
        return "paper"
    if text == "auto":
        return None
    syntax = (
        "--frequencies must be 'paper', 'auto', a comma-separated list of indices "
        f"ℓ >= 0 or start:step:stop; got {text!r}."
    )
    if ":" in text and "," not in text:
        parts = text.split(":")
        try:
            start, step, stop = (float(x) for x in parts)
        except ValueError:
            raise ValueError(syntax) from None
        if not (
            all(map(math.isfinite, (start, step, stop)))
            and start >= 0.0
            and step > 0.0
            and stop >= start
        ):
            raise ValueError(
                "--frequencies start:step:stop must have finite start >= 0, step > 0 "
                f"and stop >= start; got {text!r}."
            )
        if stop > MAX_INDEX:
            raise ValueError(
                f"--frequencies must hold indices ℓ <= {MAX_INDEX:g}; got {text!r}."
            )
        count = (stop - start) / step + 1.0
        if not count <= MAX_FUNCTIONS:
            raise ValueError(
                f"--frequencies must give at most {MAX_FUNCTIONS} indices ℓ; got "
                f"{text!r} ({count:.3g} indices)."
            )
        count = math.floor((stop - start) / step + 1e-9) + 1
        return np.round(start + step * np.arange(count), 9).tolist()
    items = [x.strip() for x in text.split(",")]
    if not all(items):  # "1,,2" or "1,": an item left out, not silently dropped
        raise ValueError(f"{syntax[:-1]} (an empty item).")
    try:
        values = [float(x) for x in items]
    except ValueError:
        raise ValueError(syntax) from None
    if not values or any(not math.isfinite(x) or x < 0.0 for x in values):
        raise ValueError(
            f"--frequencies must hold finite indices ℓ >= 0; got {text!r}."
        )
    return values


def _setting_values(args: argparse.Namespace, bandwidth: float | None) -> dict:
    """The OnlineSettings keyword arguments of the options (unset ones left out)."""
    kwargs: dict[str, Any] = {}
    for option, name in _SETTING_OPTIONS.items():
        value = getattr(args, option, None)
        if value is not None:
            kwargs[name] = value
    frequencies = _frequencies(args.frequencies)
    if not (isinstance(frequencies, str) and frequencies == "default"):
        kwargs["frequencies"] = frequencies
    if bandwidth is not None and "bandwidth" not in kwargs:
        kwargs["bandwidth"] = bandwidth
    if getattr(args, "rows_from", "auto") != "auto":
        kwargs["rows_from"] = args.rows_from
    for signal in ("position", "torque"):
        noise = noise_option(getattr(args, f"{signal}_noise", None), signal)
        if noise != "auto" and noise is not None:
            kwargs[f"{signal}_noise"] = noise
    return kwargs


def default_weighting(args: argparse.Namespace, robot: Any = None) -> str | None:
    """``--weighting``, or the power model's default: ``covariance``.

    The covariance weighting (``core.row_covariance``) for ``--model power`` unless
    the rows are raw (``--rows-from raw``), a noise std is turned off (``none``) or
    the robot has a drive (whose motor columns the power rows' noise compensation
    does not cover); None otherwise (the library default, ``frequency``).
    """
    if args.weighting is not None:
        return args.weighting
    off = any(
        noise_option(getattr(args, f"{signal}_noise", None), signal) is None
        for signal in ("position", "torque")
    )
    if (
        args.model == "power"
        and getattr(args, "rows_from", "auto") != "raw"
        and not off
        and getattr(robot, "drive", None) is None
    ):
        return "covariance"
    return None


def online_settings(
    args: argparse.Namespace,
    bandwidth: float | None = None,
    time_step: float | None = None,
    duration: float | None = None,
    robot: Any = None,
    rows_from: str | None = None,
    position_noise: Any = None,
    torque_noise: Any = None,
    weighting: str | None = None,
) -> Any:
    """The ``OnlineSettings`` of the options; unset options keep the model's defaults.

    Every value is checked first, with the option names in the messages
    (``core.online_checks.check_values``), before anything is allocated.
    ``bandwidth`` [Hz] (measured on the log) replaces the default band when neither
    ``--bandwidth`` nor ``--frequencies`` is given; ``rows_from`` (chosen on the
    log) is used when ``--rows-from`` is ``auto``, ``position_noise`` [rad or m]
    and ``torque_noise`` [N·m or N] (measured on the log) when their options are
    ``auto``, ``weighting`` (:func:`default_weighting`) when ``--weighting`` is
    not given. The covariance weighting waiting for noise stds still to be
    measured is checked as the frequency weighting. With the log's ``time_step``
    [s] and ``duration`` [s] (and the ``robot``: its joints and base parameters)
    the settings are put on the log's grid and checked against it
    (``OnlineSettings.for_log``: Nyquist, the differentiator's pass band, the
    log's length, an honest σ), still before any allocation.
    """
    from drake_dynid.core.online import MODEL_DEFAULTS, OnlineSettings
    from drake_dynid.core.online_checks import check_values

    kwargs = _setting_values(args, bandwidth)
    if weighting is None:  # the model's default (power: covariance) from the start
        weighting = default_weighting(args, robot)
    if rows_from is not None and "rows_from" not in kwargs:
        kwargs["rows_from"] = rows_from
    noises = (("position_noise", position_noise), ("torque_noise", torque_noise))
    for field, value in noises:
        if value is not None and field not in kwargs:
            kwargs[field] = value
    if weighting is not None and "weighting" not in kwargs:
        kwargs["weighting"] = weighting
    waiting = [  # stds that --*-noise auto will measure on the log
        field
        for field in ("position_noise", "torque_noise")
        if field not in kwargs
        and noise_option(getattr(args, field, None), field.split("_")[0]) == "auto"
    ]
    if kwargs.get("weighting") == "covariance" and waiting:
        kwargs["weighting"] = "frequency"
        if kwargs.get("model") != "power":
            kwargs.pop("position_noise", None)
        kwargs.pop("torque_noise", None)
    model = kwargs.pop("model", "lagrangian")
    if model in MODEL_DEFAULTS:
        values = {"model": model, **MODEL_DEFAULTS[model], **kwargs}
        check_values(values, owner=None, names=OPTION_NAMES)
    settings = OnlineSettings.for_model(model, **kwargs)
    if time_step is not None:
        settings = settings.for_log(
            time_step,
            math.inf if duration is None else duration,
            num_joints=None if robot is None else robot.num_joints,
            num_parameters=None if robot is None else robot.num_parameters,
            owner=None,
            names=OPTION_NAMES,
        )
    _check_drive_noise(settings, robot)
    return settings


def _check_drive_noise(settings: Any, robot: Any) -> None:
    """Refuses a position noise for the power rows of a robot with a drive.

    The noise-bias compensation (``core.noise_bias``) covers the joint friction
    columns, not a drive's motor columns; the library's own message names its
    classes, this one the options.
    """
    if (
        getattr(robot, "drive", None) is None
        or settings.model != "power"
        or settings.position_noise is None
    ):
        return
    if settings.weighting == "covariance":
        raise ValueError(
            "--weighting covariance needs --position-noise, whose noise-bias "
            "compensation of the power rows covers the joints' friction columns, "
            "not the motor columns of --drive: use --weighting frequency (the power "
            "model's default with --drive)."
        )
    raise ValueError(
        "--position-noise compensates the noise bias of the power rows' joint "
        "friction columns, not the motor columns of --drive; got "
        f"{settings.position_noise!r}: use --position-noise none (the default "
        "'auto' skips it with --drive)."
    )


def _longest_run(log: Any, minimum: int, what: str, override: str) -> Any:
    """The positions of the longest run of finite samples (>= ``minimum``).

    A lazy view of a stored (long) log: it stays on disk.
    """
    from drake_dynid.core.blocks import segment

    start, stop = max(log.good_segments(), key=lambda s: s[1] - s[0], default=(0, 0))
    if stop - start < minimum:
        raise ValueError(
            f"cannot measure {what}: no run of {minimum} finite samples in the log; "
            f"give {override}."
        )
    return segment(log.q, start, stop)


def measured_bandwidth(log: Any, window: float, settings: Any = None) -> float:
    """The excitation band of the log's positions [Hz] (99 % of the velocity power).

    Measured on the longest run of finite samples:
    ``core.excitation.estimate_bandwidth``'s value, from the periodogram the dead
    zone's position noise reads (``drake_dynid.offline.log_velocity_band``; in
    bounded memory on long logs); at least 2/window (the default ℓ set is
    never empty). With ``settings`` it is capped at what the identifier can use:
    the differentiator's pass band (``core.online_checks.pass_band``), the bank's
    Nyquist frequency and ``core.fourier_bank.MAX_FUNCTIONS`` functions; a noisy or
    unexcited log measures a wide band that only noise fills.
    """
    from drake_dynid.offline import log_velocity_band

    start, stop = max(log.good_segments(), key=lambda s: s[1] - s[0], default=(0, 0))
    run = stop - start
    if run < 64:
        raise ValueError(
            f"cannot measure the excitation band: no run of 64 finite samples in the "
            f"log (the longest has {run}, {run * log.time_step:g} s); give "
            "--bandwidth or --frequencies."
        )
    # The dead zone measured it on this log already (RobotLog.on_longest_run).
    measured = log_velocity_band(log)
    if measured is None:
        bad = int(np.count_nonzero(log.bad_samples))
        where = (
            f"the longest run of finite samples ({(run - 1) * log.time_step:g} s of "
            f"{log.duration:g} s: {bad} bad samples split the log)"
            if bad
            else "the log"
        )
        raise ValueError(
            "cannot measure the excitation band: the positions show no motion above "
            f"their noise floor on {where}: the robot did not move, or too little to "
            "identify anything (give --bandwidth or --frequencies to try anyway)."
        )
    band = max(measured, 2.0 / window)
    if settings is not None:
        band = min(band, usable_band(settings, log.time_step))
    return band


def check_log_values(args: argparse.Namespace, log: Any, settings: Any) -> None:
    """The log's magnitudes and length, before anything is measured on it."""
    from drake_dynid.core._validate import log_magnitudes

    try:
        log_magnitudes("identify", log.q, log.tau)
    except ValueError as error:
        raise ValueError(f"log {args.log}: {str(error).split(': ', 1)[1]}") from None
    needed = settings.window + settings.jacobi_window
    if log.duration <= needed:
        split = getattr(args, "split", None)  # ``log`` is then the fitted part
        fitted = (
            f"log {args.log} lasts"
            if split is None
            else f"log {args.log}: its first {100 * split:g} % (--split {split:g}) "
            "lasts"
        )
        longer = "record a longer log" + (", raise --split" if split else "")
        raise ValueError(
            f"{fitted} {log.duration:g} s; the on-line identifier needs more than "
            f"--window + --jacobi-window = {needed:g} s before its first estimate: "
            f"{longer} or shorten --window."
        )


def usable_band(settings: Any, time_step: float) -> float:
    """The widest motion band [Hz] the default ℓ set of ``settings`` may cover.

    min(differentiator's pass band, bank Nyquist, MAX_FUNCTIONS functions) [Hz],
    divided by ``core.ell_rule.POWER_BAND_FACTOR`` for the power model (its set
    covers that multiple of the band).
    """
    from drake_dynid.core.ell_rule import model_band
    from drake_dynid.core.fourier_bank import MAX_FUNCTIONS
    from drake_dynid.core.online_checks import on_grid, pass_band

    grid = on_grid(settings, time_step, owner=None, names=OPTION_NAMES)
    usable = min(
        pass_band(grid, time_step),
        0.5 / grid.resolved("bank_time_step"),
        (MAX_FUNCTIONS - 1 + grid.order) / grid.window,
    )
    return usable / model_band(grid.model, 1.0)  # the power set covers 2B


def _top_frequency(settings: Any) -> float:
    """The highest modulating frequency (max ℓ + k)/T of the settings' ℓ set [Hz]."""
    return float((np.max(settings.ell()) + settings.order) / settings.window)


def bootstrap_replicates(args: argparse.Namespace, settings: Any) -> int:
    """K of ``--bootstrap``: as given, else 16, or 0 with the covariance weighting.

    The covariance weighting's σ (generalised least squares and the jackknife on the
    whitened rows) models the regressor's noise from the measured noise levels
    (err/σ p90 1.25-1.62 on the benchmarks, README Accuracy), and each of its
    replicates would rebuild the window's row covariance (2R: 0.18 s each).
    """
    if args.bootstrap is not None:
        return int(args.bootstrap)
    return 0 if settings.weighting == "covariance" else DEFAULT_REPLICATES


def bootstrap_end(settings: Any, time_step: float, last_valid: int, count: int) -> int:
    """The newest bank sample of the solve whose estimate is logged at ``last_valid``.

    The last solve before the logged time (``core.replay``: the trace records at
    t_s the state after the solves at t < t_s; its final row at t_N, that of the
    final solve at the last sample); ``count``: the log's N samples.
    """
    from drake_dynid.core.replay import logged_samples, solve_samples

    every = settings.solve_decimation(time_step)
    logged = logged_samples(count, every)
    solves = solve_samples(count, every, final=settings.detect_changes is False)
    sample = int(solves[max(0, np.searchsorted(solves, logged[last_valid]) - 1)])
    return sample - sample % settings.decimation(time_step)


def final_solve_index(log: Any, settings: Any) -> int:
    """The logged index of the last solve's estimate (``last_valid`` when it is valid).

    The last of ``core.replay.logged_samples``.
    """
    from drake_dynid.core.replay import logged_samples

    every = settings.solve_decimation(log.time_step)
    return len(logged_samples(log.num_samples, every)) - 1


def window_bootstrap(
    replicates: int, log: Any, robot: Any, settings: Any, end: int
) -> dict[str, Any]:
    """``core.bootstrap.bootstrap_std`` of the window ending at ``end`` (K >= 2).

    With the white noise measured on the log (``measured_noise``; the settings'
    ``position_noise``/``torque_noise`` when given). Needs no trace: ``dynid
    identify`` runs it beside the replay (``commands._background``).

    Returns:
        ``{"noise": (σ_q, σ_τ), "result": BootstrapStd or None, "error": the
        reason bootstrap_std refused the window, or None}``.
    """
    n = int(robot.num_joints)
    noise = []
    given = (settings.position_noise, settings.torque_noise)
    for value, kind in zip(given, ("position", "torque"), strict=True):
        if value is None:
            noise.append(measured_noise(log, kind))
        else:  # one value or one per joint
            noise.append(np.broadcast_to(np.asarray(value, dtype=float), (n,)))
    try:
        result = bootstrap_std(
            robot.rows_provider(),
            settings,
            log.q,
            log.tau,
            end,
            log.time_step,
            (noise[0], noise[1]),
            replicates=int(replicates),
        )
    except ValueError as error:  # e.g. a window a detected change left short
        message = str(error).removeprefix("bootstrap_std: ")
        return {"noise": tuple(noise), "result": None, "error": message}
    return {"noise": tuple(noise), "result": result, "error": None}


def final_bootstrap(
    replicates: int,
    log: Any,
    robot: Any,
    settings: Any,
    trace: Any,
    last_valid: int,
    computed: Any = None,
) -> dict[str, Any]:
    """The parametric bootstrap of the final estimate's window (``--bootstrap``).

    ``replicates``: K (0: none; :func:`bootstrap_replicates`).

    :func:`window_bootstrap` on the window of the solve that gave the estimate
    logged at ``last_valid`` (:func:`bootstrap_end`), or ``computed``: its value
    for that window, computed already (beside the replay). Not applied (with the
    reason) when switched off, when fewer than 2 replicates are valid, or when the
    window's direct quadrature does not reproduce the estimate (a change detection
    restarted the window).

    Returns:
        The JSON ``bootstrap`` object (``applied``, ``replicates``,
        ``valid_replicates``, ``method``, ``position_noise``, ``torque_noise``,
        ``std``, ``reason``) and ``line``, the text report's line.
    """
    out: dict[str, Any] = {
        "applied": False,
        "replicates": int(replicates),
        "valid_replicates": 0,
        "method": None,
        "position_noise": None,
        "torque_noise": None,
        "std": None,
        "reason": "",
    }

    def skipped(reason: str) -> dict[str, Any]:
        out["reason"] = reason
        out["line"] = f"σ: the window's (no bootstrap: {reason})"
        return out

    if replicates == 0:
        return skipped(
            "--bootstrap 0"
            if settings.weighting != "covariance"
            else "the covariance weighting's σ models the regressor noise; "
            "--bootstrap K adds it"
        )
    if computed is None:
        end = bootstrap_end(settings, log.time_step, last_valid, log.num_samples)
        computed = window_bootstrap(replicates, log, robot, settings, end)
    noise, result = computed["noise"], computed["result"]
    out["position_noise"] = [json_number(x) for x in noise[0]]
    out["torque_noise"] = [json_number(x) for x in noise[1]]
    if result is None:
        return skipped(computed["error"])
    out["valid_replicates"] = result.replicates
    out["method"] = result.method
    theta = np.asarray(trace.theta[last_valid])
    scale = np.fmax(np.abs(theta), np.asarray(trace.std[last_valid]))
    if not np.all(np.abs(result.nominal - theta) <= 1e-6 * scale):
        return skipped(
            "the final window is not the sliding window of the estimate (a detected "
            "change restarted it)"
        )
    if result.replicates < 2:
        return skipped(f"{result.replicates} of {replicates} replicates valid")
    out["applied"] = True
    out["std"] = [json_number(x) for x in result.std]
    out["line"] = (
        "σ: the larger of the window's and a parametric bootstrap's "
        f"({result.replicates} of {replicates} replicates of the final window "
        "with the white noise measured on the log added; --bootstrap 0 to skip)"
    )
    return out


def _beside_replay(
    replicates: int, log: Any, robot: Any, settings: Any, end: int, covariance: bool
) -> dict[str, Any]:
    """What ``dynid identify`` computes beside the replay on the last solve's window.

    ``{"bootstrap": window_bootstrap(...) or None (K = 0), "covariance": (end,
    window_covariance_at(...)) or None (not wanted)}``: neither needs the trace.
    The covariance takes the bootstrap's raw rows of the window (its unperturbed
    channels) instead of evaluating them again; they are then dropped (not
    carried back from a forked child).
    """
    bootstrap: dict[str, Any] | None = None
    channels = None
    if replicates > 0:
        bootstrap = window_bootstrap(replicates, log, robot, settings, end)
        result = bootstrap["result"]
        if result is not None and result.channels is not None:
            channels = result.channels
            bootstrap["result"] = replace(result, channels=None)
    return {
        "bootstrap": bootstrap,
        "covariance": (
            (end, window_covariance_at(log, robot, settings, end, channels))
            if covariance
            else None
        ),
    }


def _final_bootstrap(
    replicates: int,
    log: Any,
    robot: Any,
    settings: Any,
    trace: Any,
    valid: np.ndarray,
    background: Background[dict[str, Any]],
    last_solve: int,
) -> tuple[dict[str, Any], tuple[int, Any] | None]:
    """:func:`final_bootstrap`, from the window computed beside the replay if it fits.

    ``valid``: the trace's (M,) bool validity. The window computed beside the
    replay (:func:`_beside_replay`) is the last solve's: used when that solve was
    valid. Returns the bootstrap ({} when no solve was valid) and the final
    window's covariance computed beside the replay (None: not computed there).
    """
    if not valid.any():
        background.cancel()
        return {}, None  # no estimate at all: run() says so
    last_valid = int(np.flatnonzero(valid)[-1])
    beside: dict[str, Any] = {}
    if last_valid == last_solve:
        beside = background.result()
    else:  # another window (or none): the child's work is not wanted
        background.cancel()
    return (
        final_bootstrap(
            replicates, log, robot, settings, trace, last_valid, beside.get("bootstrap")
        ),
        beside.get("covariance"),
    )


def measured_rows_from(log: Any, settings: Any) -> tuple[str, float, float]:
    """``(rows_from, ratio, threshold)`` for ``--rows-from auto``.

    ``core.raw_rows.rows_from_noise`` on the longest run of finite samples, with
    the settings' raw window, Jacobi window and band: the raw rows when the
    position noise gives their velocity estimate a noise (relative to the RMS
    velocity) below the filtered rows' expected bias, else the filtered rows.
    """
    from drake_dynid.core.excitation import motion_noise_band
    from drake_dynid.core.raw_rows import rows_from_noise

    q = _longest_run(log, 64, "the position noise", "--rows-from filtered or raw")
    return rows_from_noise(
        q,
        log.time_step,
        raw_window=settings.resolved("raw_window"),
        jacobi_window=settings.jacobi_window,
        bandwidth=settings.bandwidth,
        # The same run as on_longest_run's: the dead zone's measure, reused.
        measures=log.on_longest_run(motion_noise_band)[:2],
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid identify`` arguments."""
    add_common_arguments(parser)
    group = parser.add_argument_group(
        "identifier settings (default: the OnlineSettings defaults)"
    )
    group.add_argument(
        "--model",
        choices=MODEL_KINDS,
        help="power (the paper's scalar power model) or lagrangian (n equations "
        "per sample)",
    )
    group.add_argument("--window", type=float, metavar="S", help="sliding window T [s]")
    group.add_argument(
        "--frequencies",
        metavar="paper|auto|LIST",
        help="modulating indices ℓ: 'paper' (0:0.05:10), 'auto' (integers up to "
        "--bandwidth·T - 1, twice that for the power model, and at least twice the "
        "rows the robot's parameters need), or a list '0,1,2' / 'start:step:stop'",
    )
    group.add_argument(
        "--bandwidth",
        type=float,
        metavar="HZ",
        help="highest excitation frequency covered by the auto ℓ set [Hz]; not "
        "used by --weighting covariance, whose auto set is every integer ℓ within "
        "the differentiator's pass band",
    )
    group.add_argument(
        "--jacobi-window",
        type=float,
        metavar="S",
        help="window of the causal Jacobi differentiator [s]",
    )
    group.add_argument("--kappa", type=float, metavar="K", help="Jacobi κ (> -1)")
    group.add_argument("--mu", type=float, metavar="M", help="Jacobi μ (> -1)")
    group.add_argument(
        "--jacobi-q", type=int, metavar="Q", help="Jacobi truncation order q (>= 0)"
    )
    group.add_argument(
        "--bank-time-step",
        type=float,
        metavar="S",
        help="sample period of the modulating bank [s], a multiple of the log's "
        "(default: the multiple closest to 20 ms, at most --jacobi-window/10)",
    )
    group.add_argument(
        "--update-period",
        type=float,
        metavar="S",
        help="period of the least-squares solve [s], a multiple of the log's "
        "(default: the multiple closest to 0.1 s; 1 s with --weighting covariance)",
    )
    group.add_argument(
        "--max-condition",
        type=float,
        metavar="C",
        help="largest accepted condition number of the column-scaled regressor",
    )
    group.add_argument(
        "--weighting",
        choices=("frequency", "none", "covariance"),
        help="least squares of each window: 'frequency' (the Lagrangian model's "
        "default) re-weights the rows by a noise model fitted to the residuals, "
        "growing with the modulating frequency; 'covariance' (the power model's "
        "default: filtered rows, not with --drive) is the generalised least "
        "squares with the rows' noise covariance computed from the window, the "
        "filters and --position-noise, --torque-noise, and an ℓ set up to the "
        "differentiator's pass band; 'none': ordinary least squares (the paper)",
    )
    group.add_argument(
        "--uncertainty",
        choices=("jackknife", "sandwich", "gautier"),
        help="standard deviations: 'jackknife' (default) the larger of the sandwich σ "
        "and the jackknife's deleting pairs of modulating functions (covers "
        "correlated rows, noise in the regressor and a filter bias); 'sandwich': "
        "Gautier's σ corrected for correlated rows and frequency-dependent noise; "
        "'gautier': Gautier's σ alone (the paper's)",
    )
    group.add_argument(
        "--bootstrap",
        type=int,
        metavar="K",
        help="σ of the final estimate: also a parametric bootstrap of its window, "
        "K replicates with white noise of the levels measured on the log added to "
        "q and tau (sees the noise inside the regressor, e.g. the Coulomb sign "
        "at slow velocity reversals, that no statistic of one window's rows "
        f"sees); the larger σ is reported (default {DEFAULT_REPLICATES}, 0 with the "
        "covariance weighting, whose σ models that noise; 0: the window's σ alone)",
    )
    group.add_argument(
        "--rows-from",
        choices=("auto", "filtered", "raw"),
        default="auto",
        help="signals of the model rows: 'filtered' (the matched-filtered q, v, "
        "tau: least noise, but the filter biases the nonlinear terms, e.g. the "
        "Coulomb sign), 'raw' (rows of the raw q, tau and a central velocity "
        "estimate, averaged over each bank step: no filter bias, for a low "
        "position noise), 'auto' (default): raw when the raw velocity's noise "
        "(measured on the log, relative to the RMS velocity) is below "
        "0.008·(2π·band·jacobi window)², the filtered rows' expected bias",
    )
    group.add_argument(
        "--raw-window",
        type=float,
        metavar="S",
        help="window of the raw rows' central velocity estimate [s] (default 0.2; "
        "raw_window + bank step <= jacobi window)",
    )
    add_noise_arguments(group)
    group.add_argument(
        "--detect-changes",
        action="store_true",
        default=None,
        help="detect abrupt changes of the parameters (a CUSUM test on the equation "
        "error of the last second against the estimate) and restart the estimation "
        "from each change instead of waiting for the window to forget it; the "
        "detections are printed and in the JSON ('changes')",
    )
    group.add_argument(
        "--engine",
        choices=("core", "blocks"),
        default="core",
        help="core: the vectorised numerical core (fast, default); blocks: the Drake "
        "LeafSystems stepped in a Simulator (the reference; the test suite checks "
        "that both give the same estimates)",
    )
    group.add_argument(
        "--parallel",
        choices=("auto", "off"),
        default=None,
        help="auto (default): the log is read in a second process (a fork, on "
        "Linux) while the URDF loads, and the final window's bootstrap runs in "
        "one beside the replay, when 2 or more CPUs are available, with the "
        "same result; off: everything in this process "
        "(dynid fleet sets it when its own workers fill the CPUs)",
    )
    outputs = parser.add_argument_group("outputs")
    outputs.add_argument(
        "--out",
        metavar="FILE.csv",
        help="write the estimates over time: t,valid,<base parameter names>,"
        "std_<names> (empty cells before the first valid estimate; -: standard "
        "output)",
    )
    outputs.add_argument(
        "--plot",
        metavar="FILE.png",
        help="plot the estimates over time (needs matplotlib)",
    )
    from drake_dynid.commands._model import add_physical_arguments
    from drake_dynid.commands.validate import add_validation_arguments

    add_physical_arguments(parser, online=True)
    add_validation_arguments(parser)


#: ``covariance_method`` of the final estimate (``dynid identify --json``): the
#: covariance model its correlation K comes from (``core.weighted_lsq``), or
#: ``"diagonal"`` when the final window's solve cannot be reproduced (K = 1).
COVARIANCE_METHODS = ("sandwich", "gls", "gautier", "diagonal")


def window_covariance_at(
    log: Any, robot: Any, settings: Any, end: int, channels: Any = None
) -> Any:
    """``core.replay.window_estimate_covariance`` of the window ending at ``end``.

    The final window's direct-quadrature solve with its full covariance; needs no
    trace, so ``dynid identify`` computes it beside the replay (with the
    bootstrap, ``commands._background``). The ``ValueError`` or ``LinAlgError``
    of a window whose equations cannot be formed is returned, not raised (a
    forked child's result crosses as a value). ``channels``: the window's raw
    bank channels when computed already (the bootstrap's,
    ``core.bootstrap.BootstrapStd.channels``), or None.
    """
    from drake_dynid.core.bootstrap import window_start
    from drake_dynid.core.replay import window_estimate_covariance

    h = log.time_step
    try:
        s = settings.for_robot(h, int(robot.num_joints), int(robot.num_parameters))
        start = window_start(s, h, end)
        return window_estimate_covariance(
            robot.rows_provider(),
            s,
            np.asarray(log.q[start : end + 1], dtype=float),
            np.asarray(log.tau[start : end + 1], dtype=float),
            end - start,
            h,
            channels=channels,
        )
    except (ValueError, np.linalg.LinAlgError) as error:
        return error


def final_covariance_of(
    log: Any,
    robot: Any,
    settings: Any,
    trace: Any,
    last_valid: int,
    std: np.ndarray,
    computed: tuple[int, Any] | None = None,
) -> dict[str, Any]:
    """The final estimate's covariance C = S K S and how it was obtained.

    The window of the solve that gave the estimate logged at ``last_valid``
    (:func:`bootstrap_end`) solved again by direct quadrature with the
    identifier's settings and its full covariance
    (``core.replay.window_estimate_covariance``): K the correlation of the
    estimator's covariance model (the sandwich of the frequency-weighted solve,
    the generalised least squares' of the covariance weighting, or Gautier's),
    S = diag(``std``), the reported σ (the window's, the jackknife's or the
    bootstrap's, whichever is larger per parameter): the diagonal is σ² exactly.
    When that solve does not reproduce the logged estimate (to 1e-6, as the
    bootstrap's check: a detected change restarted the window, whose segment
    estimate holds parameters at their values before the change) or cannot be
    formed, K = 1 (``"diagonal"``: the correlation is not known).

    ``computed``: ``(end, window_covariance_at(..., end))`` computed already
    (beside the replay), used when ``end`` is that window's.

    Returns:
        ``{"covariance": (p, p), "correlation": (p, p), "method": one of
        COVARIANCE_METHODS, "reason": why "diagonal" (else "")}``; entries of a
        parameter whose σ is not finite are NaN.
    """
    from drake_dynid.core.weighted_lsq import scaled_covariance

    std = np.asarray(std, dtype=float)
    p = std.size
    end = bootstrap_end(settings, log.time_step, last_valid, log.num_samples)
    correlation, method, reason = np.eye(p), "diagonal", ""
    try:
        if computed is None or computed[0] != end:
            computed = (end, window_covariance_at(log, robot, settings, end))
        found = computed[1]
        if isinstance(found, Exception):
            raise found
        theta = np.asarray(trace.theta[last_valid], dtype=float)
        scale = np.fmax(np.abs(theta), np.asarray(trace.std[last_valid]))
        if not found.result.valid:
            reason = f"the final window's solve is not valid: {found.result.reason}"
        elif not np.all(np.abs(found.result.theta - theta) <= 1e-6 * scale):
            reason = (
                "the final estimate is not the sliding window's solve (a detected "
                "change restarted it)"
            )
        elif not np.all(np.isfinite(found.correlation)):
            reason = "the final window's covariance is not finite"
        else:
            correlation, method = found.correlation, found.method
    except (ValueError, np.linalg.LinAlgError) as error:
        reason = f"the final window's equations cannot be formed ({error})"
    finite = np.isfinite(std)
    covariance = scaled_covariance(correlation, np.where(finite, std, 0.0))
    covariance[~finite, :] = np.nan
    covariance[:, ~finite] = np.nan
    return {
        "covariance": covariance,
        "correlation": correlation,
        "method": method,
        "reason": reason,
    }


def projection_covariance(covariance: np.ndarray) -> np.ndarray:
    """The metric of ``--physical``'s projection from the final covariance.

    A parameter whose σ is not finite (NaN row and column; a parameter the window
    does not see) gets 1e3 times the largest finite σ and no correlation, so
    that the projection moves it freely.
    """
    covariance = np.array(covariance, dtype=float)
    diagonal = np.diag(covariance).copy()
    finite = np.isfinite(diagonal) & (diagonal > 0.0)
    largest = float(np.max(diagonal[finite])) if finite.any() else 1.0
    covariance[~finite, :] = 0.0
    covariance[:, ~finite] = 0.0
    diagonal = np.where(finite, diagonal, 1e6 * largest)
    np.fill_diagonal(covariance, diagonal)
    return covariance


def covariance_document(covariance: np.ndarray) -> list[list[float | None]]:
    """The (p, p) covariance as JSON rows: null where not finite."""
    return [[json_number(x) for x in row] for row in np.asarray(covariance)]


#: Under the covariance weighting, a joint whose position and torque noise are
#: both at most this fraction of their largest is taken as nearly noise-free.
NEAR_SILENT = 1e-6


def near_silent_joints(settings: Any, num_joints: int) -> list[int]:
    """Joints (0-based) whose stds are both <= :data:`NEAR_SILENT` of the largest.

    Each channel (position, torque) on its own, against its largest std over the
    joints; a channel that is 0 for every joint counts as quiet.

    With the covariance weighting their rows are taken as nearly noise-free and
    every window is ill-conditioned (h64's review: 0 for both is refused up
    front, ``core.online_checks``; 1e-12 against 1e-4 was not).
    """
    if settings.weighting != "covariance":
        return []
    q = np.broadcast_to(np.asarray(settings.position_noise or 0.0, float), num_joints)
    tau = np.broadcast_to(np.asarray(settings.torque_noise or 0.0, float), num_joints)
    quiet = np.ones(num_joints, dtype=bool)
    for std in (q, tau):
        top = float(np.max(std)) if std.size else 0.0
        if top > 0.0:  # a channel that is 0 everywhere counts as quiet
            quiet &= std <= NEAR_SILENT * top
    return [int(j) for j in np.flatnonzero(quiet)]


def no_valid_window_message(trace: Any, settings: Any, robot: Any, log: Any) -> str:
    """Why no window of the replay gave a valid estimate, and what to change."""
    finite = trace.condition_number[np.isfinite(trace.condition_number)]
    best = f"{finite.min():.3g}" if finite.size else "inf"
    head = (
        f"no window of the log gave a valid estimate (best condition number "
        f"{best}, limit {settings.max_condition:g}; {trace.t.size} solves)"
    )
    quiet = near_silent_joints(settings, robot.num_joints)
    if quiet:
        names = listed(robot.joint_names[j] for j in quiet)
        return (
            f"{head}: with --weighting covariance, {names} have --position-noise "
            f"and --torque-noise near 0 (at most {NEAR_SILENT:g} of the other "
            "joints'), so their rows are taken as nearly noise-free and every "
            "window is ill-conditioned; give each joint its real noise (auto "
            "measures it on the log), or use --weighting frequency."
        )
    power = (
        " (the power model has one equation per ℓ: on a multi-joint arm its "
        "windows are ill-conditioned even on exact data, README Accuracy; "
        "--model lagrangian uses n)"
        if settings.model == "power" and len(finite)
        else ""
    )
    noise_hint = (
        " With --weighting covariance the noise stds weigh the rows: stds near 0 "
        "on some joints (--position-noise, --torque-noise) leave rows nearly "
        "noise-free, which makes every window ill-conditioned as well (compare "
        "--weighting frequency)."
        if settings.weighting == "covariance"
        else ""
    )
    return (
        f"{head}{power}: the {len(trace.names)} base parameters are not all excited. "
        "Use a log "
        "longer than the window with a more exciting trajectory (every joint "
        "moving, velocity reversals), a longer --window, a wider --bandwidth or "
        "--frequencies set, fewer friction columns (--friction), or a larger "
        "--max-condition." + noise_hint + dead_zone_cover(robot, log)
    )


def _change_lines(changes: list[dict[str, Any]]) -> list[str]:
    """The printed lines of ``--detect-changes``."""
    if not changes:
        return ["changes detected: none"]
    lines = [f"changes detected: {len(changes)}"]
    for found in changes:
        changed = ", ".join(found["changed"]) or "none found"
        lines.append(
            f"  at t = {found['t']:.4g} s: change at about {found['change_time']:.4g} "
            f"s; parameters changed: {changed}"
        )
    return lines


def _invalid_reason(trace: Any) -> str:
    final = trace.final()
    settings = trace.settings
    condition = float(final["condition_number"])
    unexcited = listed(final["unidentified"]) or "some parameters"
    if final["status"] == 1:
        return (
            "the last window is not ready: it contains bad (NaN) samples or starts "
            "before the differentiator's output was valid"
        )
    if not math.isfinite(condition):
        return (
            f"the regressor of the last window is rank deficient ({unexcited} not "
            "excited)"
        )
    return (
        f"the last window is ill-conditioned (condition number {condition:.3g} > "
        f"--max-condition {settings.max_condition:g}; weakest: {unexcited})"
    )


def run(args: argparse.Namespace) -> int:
    """Replays the log through the on-line identifier; prints and writes results."""
    from drake_dynid.commands._model import (
        check_regularization,
        finish_identify,
        raise_urdf_error,
    )
    from drake_dynid.commands.validate import (
        check_output_paths,
        log_line,
        validation_split,
    )

    check_output_paths(args)
    check_topic(args)
    check_regularization(args)
    if args.bootstrap is not None and (
        args.bootstrap < 0 or args.bootstrap == 1 or args.bootstrap > MAX_REPLICATES
    ):
        raise ValueError(
            f"--bootstrap must be 0 (no bootstrap) or a number of replicates in 2 … "
            f"{MAX_REPLICATES} (σ from K replicates is within about 1/sqrt(2K) of "
            f"its value: 2 % at {MAX_REPLICATES}); got {args.bootstrap}."
        )
    settings = online_settings(args)  # every value checked, nothing allocated
    if args.plot:
        matplotlib_pyplot()  # fail before the long replay
    robot, log = load_robot_and_log(args, "identify")
    total_samples = log.num_samples
    log, held, held_description = validation_split(args, log, robot)
    robot = apply_dead_zone(args, robot, log)  # measured on the fitted part only
    check_log_values(args, log, settings)
    default_set = args.frequencies is None or args.frequencies.strip() == "auto"
    band_measured = args.bandwidth is None and default_set
    # The covariance weighting's default ℓ set is every integer ℓ the pass band
    # allows (core.ell_rule): --bandwidth does not choose it, and is said so.
    every_ell = default_set and default_weighting(args, robot) == "covariance"
    band_given = args.bandwidth if every_ell else None
    try:
        bandwidth = (
            measured_bandwidth(log, settings.window, settings)
            if band_measured
            else None
        )
        if band_given is not None:  # capped as a measured band, not refused
            bandwidth = min(band_given, usable_band(settings, log.time_step))
            args = argparse.Namespace(**{**vars(args), "bandwidth": None})
        settings = online_settings(args, bandwidth, log.time_step, log.duration, robot)
        weighting = default_weighting(args, robot)
        covariance = weighting == "covariance"  # it models the filtered rows' noise
        rows_measured = args.rows_from == "auto" and not covariance
        noise_ratio = noise_threshold = position_noise = torque_noise = None
        rows_from = "filtered" if covariance and args.rows_from == "auto" else None
        if rows_measured:  # with the raw window resolved on the log's grid
            rows_from, noise_ratio, noise_threshold = measured_rows_from(log, settings)
        noise_measured = noise_option(args.position_noise) == "auto" and (
            covariance  # the compensation: not with a drive (its motor columns)
            or (settings.model == "power" and robot.drive is None)
        )
        torque_measured = (
            covariance and noise_option(args.torque_noise, "torque") == "auto"
        )
        if noise_measured:
            position_noise = tuple(measured_noise(log).tolist())
        if torque_measured:
            torque_noise = tuple(measured_noise(log, "torque").tolist())
        settings = online_settings(
            args,
            bandwidth,
            log.time_step,
            log.duration,
            robot,
            rows_from,
            position_noise,
            torque_noise,
            weighting,
        )
    except ValueError as error:
        raise ValueError(f"log {args.log}: {error}") from None
    if args.engine == "blocks":
        from drake_dynid.diagrams import replay_log as replay
    else:
        from drake_dynid.core.replay import replay_log_core as replay

    progress = bool(sys.stderr.isatty()) and not args.quiet
    replicates = bootstrap_replicates(args, settings)
    # The bootstrap of the last solve's window needs no trace: it runs beside the
    # replay (commands._background), and is used if that solve gave the estimate.
    last_solve = final_solve_index(log, settings)
    end = bootstrap_end(settings, log.time_step, last_solve, log.num_samples)
    # So is the final window's covariance (--json, --physical): beside the replay.
    from drake_dynid.commands._model import wants_physical

    wants_covariance = bool(args.json) or wants_physical(args)
    with Background(
        lambda: _beside_replay(replicates, log, robot, settings, end, wants_covariance),
        enabled=(replicates > 0 or wants_covariance)
        and getattr(args, "parallel", None) != "off",
    ) as background:
        (trace,) = replay(log, robot.rows_provider(), [settings], progress=progress)
        valid = np.asarray(trace.valid) > 0.5
        bootstrap, covariance_beside = _final_bootstrap(
            replicates, log, robot, settings, trace, valid, background, last_solve
        )
    measured = [
        text
        for text, done in (
            ("the measured position noise", noise_measured),
            ("the measured excitation band", band_measured),
            ("the rows' choice", rows_measured),
        )
        if done
    ]
    if measured:
        reader = " and ".join(
            [", ".join(measured[:-1]), measured[-1]] if measured[1:] else measured
        )
        resampled_log_note("identify", log, reader=reader)
    if band_given is not None:
        print(
            f"dynid identify: note: --bandwidth {band_given:g} Hz is not used: the "
            "covariance weighting's ℓ set is every integer ℓ within the "
            f"differentiator's pass band ({len(settings.ell())} functions up to "
            f"{_top_frequency(settings):.3g} Hz); --frequencies chooses another set "
            "(--weighting frequency uses --bandwidth)",
            file=sys.stderr,
        )
    if not valid.any():
        raise ValueError(no_valid_window_message(trace, settings, robot, log))
    t = log.t[0] + np.asarray(trace.t)
    changes = [
        {
            **found,
            "t": log.t[0] + found["t"],
            "change_time": log.t[0] + found["change_time"],
        }
        for found in trace.detections()
    ]
    last_valid = int(np.flatnonzero(valid)[-1])
    final = trace.final()
    theta, std = final["theta"], final["std"]
    if bootstrap["applied"]:
        std = np.fmax(std, np.asarray(bootstrap["std"], dtype=float))
    final_valid = bool(valid[-1])
    reason = "" if final_valid else _invalid_reason(trace)
    condition = float(trace.condition_number[last_valid])
    if not args.quiet:
        print(log_line(args, log, total_samples))
        line = dead_zone_line(robot, args)
        if line:
            print(line)
        print(
            f"model: {settings.model}; window: {settings.window:g} s; "
            f"{len(settings.ell())} modulating functions; latency "
            f"{trace.delay:.4g} s; weighting: {settings.weighting}"
        )
        if robot.coulomb_width > 0.0:
            print(f"Coulomb friction: tanh(v/{robot.coulomb_width:g}), --coulomb-width")
        if band_measured and every_ell:
            print(
                f"excitation band: {settings.bandwidth:.3g} Hz (measured on the log: "
                "99 % of the velocity power); the covariance weighting's ℓ set "
                f"covers the differentiator's pass band, "
                f"{_top_frequency(settings):.3g} Hz, whatever the band"
            )
        elif band_measured:
            print(
                f"excitation band: {settings.bandwidth:.3g} Hz (measured on the log: "
                "99 % of the velocity power; --bandwidth to override)"
            )
        if noise_ratio is not None and noise_threshold is not None:
            print(
                f"rows: {settings.rows_from} (raw velocity noise "
                f"{100 * noise_ratio:.3g} % of the RMS velocity, measured on the "
                f"log; raw up to {100 * noise_threshold:.3g} % at this band and "
                "Jacobi window; --rows-from to override)"
            )
        if covariance and args.rows_from == "auto":
            print(
                "rows: filtered (the covariance weighting models the filtered rows' "
                "noise; --rows-from to override)"
            )
        for line in noise_lines(settings, noise_measured, torque_measured):
            print(line)
        print()
        for line in estimates_table(trace.names, theta, std):
            print(line)
        print()
        print(bootstrap["line"])
        print(f"condition number: {condition:.4g}")
        print(
            f"valid windows: {int(valid.sum())} of {valid.size} solves; final "
            f"window: {'valid' if final_valid else 'INVALID'}"
        )
        if not final_valid:
            print(
                f"  {reason}; the estimates above are the last valid ones "
                f"(t = {t[last_valid]:.4g} s)."
            )
        if settings.detect_changes is not False:
            for line in _change_lines(changes):
                print(line)
    computed: dict[str, Any] = {}

    def covariance_final() -> dict[str, Any]:  # for --json, --physical
        if not computed:
            computed.update(
                final_covariance_of(
                    log, robot, settings, trace, last_valid, std, covariance_beside
                )
            )
        return computed

    extra = finish_identify(
        args,
        robot,
        held,
        held_description,
        {settings.model: theta},
        fit=SimpleNamespace(names=trace.names, theta=theta, std=std),
        covariance=lambda: projection_covariance(covariance_final()["covariance"]),
        urdf_notes=[
            f"From dynid identify's {'final' if final_valid else 'last valid'} "
            f"window ({settings.window:g} s ending at t = {t[last_valid]:.6g} s)"
            + ("" if final_valid else f"; the final window is not valid: {reason}")
            + "."
        ],
    )
    if args.out:
        write_estimates_csv(
            args.out, t, trace.valid, trace.theta, trace.names, trace.std
        )
        if not args.quiet:
            print(f"wrote {args.out}")
    document = None
    if args.json:
        document = {
            "parameters": parameters_document(robot, trace.names, theta, std),
            "condition_number": json_number(condition),
            "window": float(settings.window),
            "model": settings.model,
            "valid": final_valid,
            "reason": reason,
            "last_valid_time": float(t[last_valid]),
            "delay": float(trace.delay),
            "covariance": covariance_document(covariance_final()["covariance"]),
            "covariance_method": covariance_final()["method"],
            "covariance_reason": covariance_final()["reason"],
            "bootstrap": {k: value for k, value in bootstrap.items() if k != "line"},
            "changes": changes if settings.detect_changes is not False else None,
            "settings": {
                **settings.as_dict(),
                "friction": list(robot.friction),
                "coulomb_width": robot.coulomb_width,
                "resample": bool(args.resample),
                "fill_gaps": int(args.fill_gaps),
                **model_settings(args, robot),
                "bandwidth_measured": band_measured,
                "rows_from_measured": rows_measured,
                "position_noise_measured": noise_measured,
                "torque_noise_measured": torque_measured,
                "raw_noise_ratio": None
                if noise_ratio is None
                else json_number(noise_ratio),
                "raw_noise_threshold": None
                if noise_threshold is None
                else json_number(noise_threshold),
                "engine": args.engine,
            },
            "urdf": str(args.urdf),
            "log": log_document(args, log),
            **extra,
        }
    write_trace_outputs(
        args,
        document,
        t,
        trace,
        f"dynid identify: {settings.model} model, window {settings.window:g} s",
    )
    raise_urdf_error(args)
    return 0
