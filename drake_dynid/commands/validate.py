"""``dynid validate``: predict a log's torques from identified parameters.

Also the validation helpers of ``dynid offline`` and ``dynid identify``
(``--validate LOG2``, ``--split FRACTION``).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.commands._arguments import (
    URDF_HELP,
    LogFiles,
    add_dead_zone_argument,
    add_drive_arguments,
    add_fill_gaps_argument,
    add_joint_arguments,
    add_log_argument,
    add_time_unit_argument,
    bag_options,
    check_topic,
    dead_zone_line,
    log_files,
    read_robot_log,
    urdf_argument,
)
from drake_dynid.commands._paths import check_output_paths
from drake_dynid.core._validate import listed

__all__ = [
    "add_validation_arguments",
    "check_output_paths",
    "report_validation",
    "run_validations",
    "validation_split",
]

HELP = "predict a log's joint torques from identified base parameters (validation)"
DESCRIPTION = (
    "Held-out validation: predicts the joint torques of a robot log (CSV: t, "
    "q_<joint>, tau_<joint>) from the base parameters of a results file (the JSON "
    "of dynid offline/identify --json) with the inverse dynamic model τ = W(q, v, "
    "v̇)·θ, built exactly as dynid offline builds its equations: zero-phase "
    "Butterworth q at the automatic position cutoff, central differences for v and "
    "v̇, and the measured and predicted torques both through the parallel "
    "decimation's zero-phase low-pass (1.5 x the velocity bandwidth), which removes "
    "the sensor noise above the motion. Prints per joint the RMS of the measured "
    "torque, the residual std, the relative RMS error 100·RMS(residual)/RMS(τ), "
    "R², and the relative error against the raw (unfiltered) torque. A results "
    "file with a 'physical' section (dynid offline --physical) is validated for "
    "both estimates."
)


# ------------------------------------------------------------------ shared helpers
def add_validation_arguments(parser: argparse.ArgumentParser) -> None:
    """``--validate LOG2`` and ``--split FRACTION`` (offline and identify)."""
    group = parser.add_argument_group("validation")
    group.add_argument(
        "--validate",
        nargs="+",
        action=LogFiles,
        metavar="LOG2.csv",
        help="after the fit, predict the torques of this other log (one file or "
        "several joined on time, read like LOG) and report the errors per joint "
        "(see dynid validate)",
    )
    group.add_argument(
        "--split",
        type=float,
        metavar="FRACTION",
        help="fit on the first FRACTION of the log (0 < FRACTION < 1) and validate "
        "on the rest",
    )
    group.add_argument(
        "--compare-urdf",
        action="store_true",
        help="with --validate or --split: also predict the held-out torques with "
        "the URDF's a-priori parameters (inertias, <dynamics damping friction>, the "
        "drive file's motor values)",
    )


def _check_held_out(
    args: argparse.Namespace, held: Any, description: str, whole: Any = None
) -> None:
    """The held-out log is long enough to validate on, checked before the fit.

    With ``--split`` (``whole``: the log it splits) a smaller fraction is
    suggested only when the whole log is long enough itself (else no split is).
    """
    from drake_dynid.validation import check_validation_length

    cutoff = getattr(args, "cutoff", None)
    try:
        check_validation_length(held, cutoff)
    except ValueError as error:
        text = str(error)
        if whole is not None:
            try:
                check_validation_length(whole, cutoff)
            except ValueError:
                text = f"{text.rstrip('.')}; the whole log is too short for it too."
            else:
                text = f"{text.rstrip('.')}; use a smaller --split."
        raise ValueError(f"validation on {description}: {text}") from None


def log_line(args: argparse.Namespace, fitted: Any, total: int) -> str:
    """``log: FILE (N samples, h = ...)``; with ``--split``, the part fitted too."""
    line = f"log: {args.log} ({total} samples, h = {fitted.time_step:g} s"
    if getattr(args, "split", None) is not None:
        line += f"; fitted on the first {fitted.num_samples} (--split {args.split:g})"
    return line + ")"


def validation_split(
    args: argparse.Namespace, log: Any, robot: Any
) -> tuple[Any, Any, str]:
    """(log to fit, log to validate or None, its description) from the options.

    ``--validate`` files are read like the fitted log (``robot``'s drive chain).
    """
    split = getattr(args, "split", None)
    other = getattr(args, "validate", None)
    if split is not None and other:
        raise ValueError("give --validate LOG2 or --split FRACTION, not both.")
    if getattr(args, "compare_urdf", False) and split is None and not other:
        # Found by a review: it was ignored without a word.
        raise ValueError(
            "--compare-urdf predicts held-out torques with the URDF's parameters: "
            "give it with --validate LOG2 or --split FRACTION."
        )
    if split is not None:
        if not 0.0 < split < 1.0:
            raise ValueError(f"--split must be in (0, 1); got {split}.")
        from drake_dynid.validation import split_log  # scipy.signal: only here

        first, rest = split_log(log, split)
        description = f"{args.log} after the first {100 * split:g} %"
        _check_held_out(args, rest, description, log)
        return first, rest, description
    if other:
        from drake_dynid.files import same_file

        for fitted in log_files(args):
            for given in log_files(args, "validate"):
                if same_file(fitted, given):
                    raise ValueError(
                        f"--validate {given} is the fitted log ({fitted}): a "
                        "validation needs another recording (or --split F, the "
                        "end of this one held out)."
                    )
        held = read_robot_log(
            log_files(args, "validate"),
            robot,
            resample=args.resample,
            command=getattr(args, "command", "dynid"),
            fill_gaps=getattr(args, "fill_gaps", None),
            time_unit=getattr(args, "time_unit", None),
            topic=getattr(args, "topic", None),
            options=bag_options(args),
        )
        _check_held_out(args, held, str(other))
        return log, held, str(other)
    return log, None, ""


def run_validations(
    log: Any,
    robot: Any,
    estimates: Mapping[str, np.ndarray],
    *,
    cutoff_hz: float | None = None,
    decimation_cutoff_hz: float | None = None,
) -> dict[str, Any]:
    """``{label: TorqueValidation}`` of every estimate on ``log``, in one pass."""
    from drake_dynid.validation import validate_estimates

    return validate_estimates(
        log,
        robot,
        estimates,
        cutoff_hz=cutoff_hz,
        decimation_cutoff_hz=decimation_cutoff_hz,
    )


def _cell(value: float, digits: int = 4) -> str:
    return f"{value:.{digits}g}" if math.isfinite(value) else str(value)


def validation_lines(validations: Mapping[str, Any], description: str) -> list[str]:
    """The printed report: settings line, then one table per estimate."""
    first = next(iter(validations.values()))
    settings = first.settings
    lines = [
        f"validation on {description} ({first.num_samples} samples): positions "
        f"filtered at {settings['cutoff_hz']:.4g} Hz ({settings['cutoff_rule']}), "
        f"torques compared after the {settings['decimation_cutoff_hz']:.4g} Hz "
        f"low-pass ({settings['decimation_cutoff_rule']}); "
        f"{first.num_samples_used} samples compared"
    ]
    headers = (
        "joint",
        "RMS τ",
        "residual σ",
        "error %",
        "moving error %",
        "R²",
        "raw error %",
    )
    for label, result in validations.items():
        rows = [
            (
                name,
                _cell(result.rms_measured[j]),
                _cell(result.residual_std[j], 3),
                f"{result.relative_rms_percent[j]:.2f}",
                f"{result.moving_relative_rms_percent[j]:.2f} "
                f"({100 * result.moving_fraction[j]:.0f} %)",
                f"{result.r_squared[j]:.4f}",
                f"{result.raw_relative_rms_percent[j]:.2f}",
            )
            for j, name in enumerate(result.joint_names)
        ]
        rows.append(
            (
                "all joints",
                "",
                "",
                f"{result.total_relative_rms_percent:.2f}",
                f"{result.total_moving_relative_rms_percent:.2f}",
                "",
                "",
            )
        )
        widths = [
            max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(headers)
        ]
        lines += ["", f"estimate: {label}"]
        lines.append(
            "  ".join(
                h.ljust(w) if k == 0 else h.rjust(w)
                for k, (h, w) in enumerate(zip(headers, widths, strict=True))
            )
        )
        lines.append("  ".join("-" * w for w in widths))
        for row in rows:
            lines.append(
                "  ".join(
                    c.ljust(w) if k == 0 else c.rjust(w)
                    for k, (c, w) in enumerate(zip(row, widths, strict=True))
                ).rstrip()
            )
    rule = {
        "dead zone": "its dead zone",
        "measured": "measured on this log",
        "none": "not measured: the log is too short; nan",
    }
    lines += [
        "",
        "moving error %: over the samples where the joint moves (their share in "
        "brackets), |v| above its standstill width ("
        f"{rule.get(first.moving_rule, first.moving_rule)}); at rest static "
        "friction holds any torque within its breakaway level, which the model "
        "does not predict",
    ]
    return lines


def validation_document(
    validations: Mapping[str, Any], description: str, log: Any
) -> dict[str, Any]:
    """The ``validation`` entry of the JSON outputs."""
    from drake_dynid.commands._report import json_number

    first = next(iter(validations.values()))
    estimates = {}
    for label, result in validations.items():
        estimates[label] = {
            "joints": [
                {
                    "name": name,
                    "rms_measured": json_number(result.rms_measured[j]),
                    "residual_std": json_number(result.residual_std[j]),
                    "relative_rms_percent": json_number(result.relative_rms_percent[j]),
                    "r_squared": json_number(result.r_squared[j]),
                    "raw_relative_rms_percent": json_number(
                        result.raw_relative_rms_percent[j]
                    ),
                    "moving_relative_rms_percent": json_number(
                        result.moving_relative_rms_percent[j]
                    ),
                    "moving_fraction": json_number(result.moving_fraction[j]),
                    "moving_width": json_number(result.moving_widths[j]),
                }
                for j, name in enumerate(result.joint_names)
            ],
            "total_relative_rms_percent": json_number(
                result.total_relative_rms_percent
            ),
            "total_moving_relative_rms_percent": json_number(
                result.total_moving_relative_rms_percent
            ),
            "moving_rule": result.moving_rule,
        }
    return {
        "log": {
            "description": description,
            "samples": int(log.num_samples),
            "time_step": float(log.time_step),
            "start": float(log.t[0]),
            "duration": float(log.duration),
        },
        "settings": dict(first.settings),
        "samples_compared": int(first.num_samples_used),
        "estimates": estimates,
    }


def _segment_breaks(segment: Any) -> np.ndarray:
    """Rows where a new finite segment starts (a block at a time: may be stored)."""
    from drake_dynid.core.blocks import blocks

    out, previous = [], None
    for start, block in blocks(segment):
        values = block.ravel()
        if previous is not None and values.size and values[0] != previous:
            out.append(np.array([start]))
        out.append(start + 1 + np.flatnonzero(np.diff(values)))
        previous = values[-1] if values.size else previous
    return np.concatenate(out) if out else np.zeros(0, np.int64)


def _torque_series(validations: Mapping[str, Any]) -> tuple[np.ndarray, list[Any]]:
    """Times and the plotted (·, n) series, NaN rows between segments.

    The series: the measured torque, then per estimate its prediction and its
    residual. More than ``PLOT_BUCKETS`` compared samples are drawn as the
    extremes of as many buckets (``_report.bucket_extremes``), read a block at a
    time: a validation of hours costs the plot what one of a minute does.
    """
    from drake_dynid.commands._report import (
        PLOT_BUCKETS,
        bucket_extremes,
        bucket_times,
    )

    first = next(iter(validations.values()))
    results = list(validations.values())
    breaks = _segment_breaks(first.segment)
    count = first.num_samples_used

    def read(a: int, b: int) -> list[np.ndarray]:
        out = [np.asarray(first.measured[a:b], dtype=float)]
        for result in results:
            predicted = np.asarray(result.predicted[a:b], dtype=float)
            out += [
                predicted,
                np.asarray(result.measured[a:b], dtype=float) - predicted,
            ]
        return out

    if count <= PLOT_BUCKETS:  # every sample

        def gapped(values: Any) -> np.ndarray:
            return np.insert(np.asarray(values, dtype=float), breaks, np.nan, axis=0)

        return gapped(first.t), [gapped(values) for values in read(0, count)]
    edges, extremes = bucket_extremes(count, read, PLOT_BUCKETS, breaks)
    gaps = 2 * np.flatnonzero(np.isin(edges[:-1], breaks))
    t = np.insert(bucket_times(first.t, edges), gaps, np.nan)
    return t, [
        np.insert(e.reshape(-1, e.shape[2]), gaps, np.nan, axis=0) for e in extremes
    ]


def write_torque_plot(
    path: str,
    validations: Mapping[str, Any],
    title: str,
    prismatic: Sequence[bool] = (),
) -> None:
    """One panel per joint: measured (low-passed) torque and each prediction.

    The thin lines on the right axis are the residuals (measured - predicted).
    A long validation is drawn as its envelope (``_torque_series``). The effort
    axis is in N·m, or in N for a joint flagged in ``prismatic`` (the robot's
    ``RobotModel.prismatic``, one flag per joint; empty: all revolute).
    """
    from drake_dynid.commands._report import finish_panels, matplotlib_pyplot

    plt = matplotlib_pyplot()
    first = next(iter(validations.values()))
    n = len(first.joint_names)
    columns = 2 if n > 4 else 1
    rows = math.ceil(n / columns)
    figure, axes = plt.subplots(
        rows, columns, sharex=True, figsize=(6.0 * columns, 1.8 * rows + 0.8)
    )
    axes = np.atleast_1d(axes).ravel()
    t, series = _torque_series(validations)
    for j, name in enumerate(first.joint_names):
        axis = axes[j]
        residuals = axis.twinx()  # right axis: measured - predicted
        axis.plot(t, series[0][:, j], color="k", lw=1.2, label="measured")
        for k, (label, result) in enumerate(validations.items()):
            axis.plot(
                t,
                series[1 + 2 * k][:, j],
                color=f"C{k}",
                lw=0.9,
                ls="--" if k else "-",
                label=f"{label} ({result.relative_rms_percent[j]:.2f} %; "
                f"{_moving_text(result.moving_relative_rms_percent[j])})",
            )
            residuals.plot(t, series[2 + 2 * k][:, j], color=f"C{k}", lw=0.5, alpha=0.5)
        residuals.tick_params(labelsize=7, colors="0.4")
        unit = "N" if j < len(prismatic) and prismatic[j] else "N·m"
        axis.set_ylabel(f"{name}\n[{unit}]")
        axis.grid(True, alpha=0.3)
        axis.legend(fontsize=7, loc="upper right")
    finish_panels(
        figure, axes, n, columns, f"{title}; thin lines: residuals (right axis)"
    )
    figure.savefig(path, dpi=100)
    plt.close(figure)


def _moving_text(percent: float) -> str:
    """The legend's moving error: ``moving 7.37 %``, or ``never moving`` (NaN)."""
    return f"moving {percent:.2f} %" if math.isfinite(percent) else "never moving"


#: The physical estimate is called worse than the fit when its held-out error
#: (over all joints, or a joint's) exceeds the fit's by this factor plus
#: :data:`PHYSICAL_WORSE_POINTS` percentage points.
PHYSICAL_WORSE = 1.25
#: The floor [percentage points] of :data:`PHYSICAL_WORSE`: on a clean log 0.07 %
#: against 0.05 % is no reason to prefer the fit.
PHYSICAL_WORSE_POINTS = 1.0


def physical_worse(
    validations: Mapping[str, Any], what: str = "the held-out torques"
) -> str | None:
    """A note when the physical estimate predicts the held-out torques worse.

    ``what`` names the torques compared (``dynid validate``: a log that may be
    the fitted one, so not called held out).

    The constraints (positive masses, inertias, friction) can pull an estimate
    away from what the data say: a torque the model cannot describe (the TIAGo's
    torso effort leaves gravity out: its physical estimate missed the held-out
    torques by 20.8 % against the fit's 14.5 % off-line, 104 % against 15.2 %
    on-line), or too little excitation of what they move. None when there is no
    physical estimate or it is within :data:`PHYSICAL_WORSE` times the fit's
    error plus :data:`PHYSICAL_WORSE_POINTS` (over all joints; a joint is named
    when its own error is beyond that bound).
    """
    from drake_dynid.commands._model import APRIORI_LABEL

    physical = validations.get("physical")
    fits = [v for k, v in validations.items() if k not in ("physical", APRIORI_LABEL)]
    if physical is None or not fits:
        return None
    fit = fits[0]
    total, reference = (
        physical.total_relative_rms_percent,
        fit.total_relative_rms_percent,
    )
    if not total > PHYSICAL_WORSE * reference + PHYSICAL_WORSE_POINTS:
        return None
    joints = [
        f"{name} {physical.relative_rms_percent[j]:.3g} % against "
        f"{fit.relative_rms_percent[j]:.3g} %"
        for j, name in enumerate(physical.joint_names)
        if physical.relative_rms_percent[j]
        > PHYSICAL_WORSE * fit.relative_rms_percent[j] + PHYSICAL_WORSE_POINTS
    ]
    where = f" ({listed(joints, sep='; ')})" if joints else ""
    return (
        f"the physical estimate predicts {what} worse than the fit: "
        f"{total:.3g} % against {reference:.3g} % over all joints{where}. The "
        "constraints pull it away from what the data say (a torque the model "
        "cannot describe, such as gravity left out of a logged effort, or too "
        "little excitation of what they move): prefer the fit's estimate, or "
        "check the model and the log."
    )


def report_validation(
    args: argparse.Namespace,
    robot: Any,
    log: Any,
    description: str,
    estimates: Mapping[str, np.ndarray],
    *,
    plot_title: str | None = None,
) -> dict[str, Any]:
    """Validates, prints (unless --quiet), plots when --plot; returns the JSON entry.

    The position and comparison cutoffs follow ``--cutoff`` and
    ``--decimation-cutoff`` when the command has them, else the automatic rules
    on ``log``.
    """
    from drake_dynid.commands._options import FILTER_OPTIONS, option_message

    try:
        validations = run_validations(
            log,
            robot,
            estimates,
            cutoff_hz=getattr(args, "cutoff", None),
            decimation_cutoff_hz=getattr(args, "decimation_cutoff", None),
        )
    except ValueError as error:
        owners = ("validate_estimates", "validate_torques")
        message = option_message(str(error), FILTER_OPTIONS, owners)
        raise ValueError(f"validation on {description}: {message}") from None
    if not args.quiet:
        print()
        for line in validation_lines(validations, description):
            print(line)
    command = getattr(args, "command", None) or "validate"
    worse = physical_worse(
        validations,
        "the torques of the validated log"
        if command == "validate"
        else "the held-out torques",
    )
    if worse:
        print(f"dynid {command}: note: {worse}", file=sys.stderr)
    if plot_title is not None and args.plot:
        write_torque_plot(
            args.plot, validations, plot_title, getattr(robot, "prismatic", ())
        )
        if not args.quiet:
            print(f"wrote {args.plot}")
    return validation_document(validations, description, log)


# --------------------------------------------------------------------- validate
def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid validate`` arguments."""
    add_log_argument(parser)
    parser.add_argument(
        "--urdf",
        required=True,
        metavar="MODEL.urdf",
        type=urdf_argument,
        help=URDF_HELP,
    )
    parser.add_argument(
        "--params",
        required=True,
        metavar="RESULT.json",
        help="the identified parameters (dynid offline/identify --json, or dynid "
        "params --json for the URDF's a-priori values)",
    )
    parser.add_argument(
        "--friction",
        default=None,
        help="friction columns per joint (default: those of the results file)",
    )
    add_joint_arguments(parser)
    add_drive_arguments(parser)
    add_dead_zone_argument(parser, None)
    parser.add_argument(
        "--cutoff",
        type=float,
        metavar="HZ",
        help="position filter cutoff [Hz] (default: automatic, as dynid offline)",
    )
    parser.add_argument(
        "--decimation-cutoff",
        type=float,
        metavar="HZ",
        help="low-pass applied to the measured and predicted torques [Hz] "
        "(default: 1.5 x the measured velocity bandwidth, at most the cutoff)",
    )
    parser.add_argument(
        "--resample",
        action="store_true",
        help="accept a non-uniformly sampled log (linear interpolation)",
    )
    add_fill_gaps_argument(parser)
    add_time_unit_argument(parser)
    parser.add_argument(
        "--json", metavar="FILE", help="write the errors as JSON (-: standard output)"
    )
    parser.add_argument(
        "--plot", metavar="FILE.png", help="plot measured and predicted torques"
    )
    parser.add_argument("--quiet", action="store_true", help="print nothing")


def fitted_log_note(
    args: argparse.Namespace, document: Mapping[str, Any], log: Any
) -> str | None:
    """The note when a validated file is the log the results file was fitted on.

    The results file records its log as given (``log.path``, one path or a list),
    relative to the folder the fit ran in: it is looked for from here and from the
    results file's folder. On that log the errors are in-sample (the fit saw those
    samples, all of them or, after ``--split``, the first ones), not a prediction
    of another recording; ``offline --validate`` refuses it, ``validate`` says so.
    """
    from drake_dynid.files import same_file

    recorded = document.get("log")
    if not isinstance(recorded, Mapping):
        return None
    paths = recorded.get("path")
    if isinstance(paths, str):
        paths = [paths]
    if not isinstance(paths, list):
        return None
    beside = Path(args.params).parent
    found = []
    for path in (Path(p) for p in paths if isinstance(p, str) and p):
        options = [path] if path.is_absolute() else [path, beside / path]
        existing = [c for c in options if c.is_file()]
        if len(existing) == 2 and not same_file(*existing):
            # Two files of that name, from here and beside the results file:
            # which folder the fit ran in is not known, so nothing is claimed.
            return None
        found += existing[:1]
    # The fitted samples of that log: all of them, or the first ones (--split).
    fitted, step = recorded.get("samples"), recorded.get("time_step")
    if not (isinstance(fitted, int) and 0 < fitted <= log.num_samples):
        return None
    if isinstance(step, int | float) and not math.isclose(
        step, log.time_step, rel_tol=1e-6
    ):
        return None
    for given in log_files(args):
        if any(same_file(c, given) for c in found):
            part = ""
            if fitted < log.num_samples:
                part = f" (its first {fitted} of {log.num_samples} samples)"
            return (
                f"{given} is the log these parameters were fitted on{part}: the "
                "errors are in-sample there, not a prediction of another recording."
            )
    return None


def run(args: argparse.Namespace) -> int:
    """Validates the results file's estimates on the log."""
    from drake_dynid.commands._model import APRIORI_LABEL
    from drake_dynid.commands._report import resampled_log_note, write_json
    from drake_dynid.commands._results import (
        drive_mismatch,
        results_robot,
        results_sign,
    )
    from drake_dynid.validation import read_estimates, read_results

    check_output_paths(args)
    check_topic(args)
    if args.plot:
        from drake_dynid.commands._report import matplotlib_pyplot

        matplotlib_pyplot()
    document = read_results(args.params)
    robot = results_robot(args, document)
    mismatch = drive_mismatch(document, robot)
    if mismatch:
        print(f"dynid validate: note: {mismatch}.", file=sys.stderr)
    estimates = read_estimates(document, robot, f"results file {args.params}")
    # A `dynid params --json` file (or a simulated log's truth) holds the URDF's
    # values, no "model": they are the a-priori model, not a fit.
    default = APRIORI_LABEL if "standard_parameters" in document else "fit"
    model = str(document.get("model", default))
    labels = {"fit": model, "physical": "physical"}
    estimates = {labels[k]: v for k, v in estimates.items()}
    log = read_robot_log(
        log_files(args),
        robot,
        resample=args.resample,
        command="validate",
        fill_gaps=args.fill_gaps,
        time_unit=getattr(args, "time_unit", None),
        topic=getattr(args, "topic", None),
        options=bag_options(args),
    )
    robot = results_sign(args, document, robot, log)
    in_sample = fitted_log_note(args, document, log)
    if in_sample:
        print(f"dynid validate: note: {in_sample}", file=sys.stderr)
    if args.cutoff is None:  # the automatic cutoff's measure, as dynid offline's
        resampled_log_note("validate", log)
    if not args.quiet:
        print(
            f"parameters: {args.params} ({model}, {robot.num_parameters} base "
            f"parameters{', with a physical estimate' if len(estimates) > 1 else ''})"
        )
        line = dead_zone_line(robot, reversals=True)
        if line:
            print(line)
        if robot.coulomb_width > 0.0:
            print(f"Coulomb friction: tanh(v/{robot.coulomb_width:g})")
    entry = report_validation(
        args,
        robot,
        log,
        str(args.log),
        estimates,
        plot_title=f"dynid validate: {args.log} with {Path(args.params).name}",
    )
    if args.json:
        write_json(
            args.json,
            {
                **entry,
                "settings": {**entry["settings"], "coulomb_width": robot.coulomb_width},
                "params": str(args.params),
                "urdf": str(args.urdf),
            },
        )
        if not args.quiet:
            print(f"wrote {args.json}")
    return 0
