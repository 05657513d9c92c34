"""``dynid payload``: a payload's inertial parameters on-line, the arm known."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

import numpy as np

from drake_dynid.commands._arguments import (
    add_common_arguments,
    apply_dead_zone,
    bag_options,
    check_topic,
    dead_zone_line,
    log_files,
    model_settings,
    read_robot_log,
    robot_from_args,
)
from drake_dynid.commands._report import (
    estimates_table,
    json_number,
    log_document,
    matplotlib_pyplot,
    write_estimates_csv,
    write_trace_outputs,
)

HELP = "on-line identification of a payload's 10 inertial parameters (arm known)"
DESCRIPTION = (
    "Replays a robot log (CSV: t, q_<joint>, tau_<joint>) through drake_dynid's "
    "payload identifier: the arm's parameters are known (the URDF's values, or a "
    "previous identification with --params), and only the payload rigidly attached "
    "to --frame (default: the last identified link) is estimated on-line: its mass, "
    "first moments m·c and inertia about the attachment frame, in that frame, with "
    "their standard deviations, over a short sliding window (0.75 s by default: the "
    "estimate follows a pick within about a second). Prints the final estimate "
    "(parameters with %σ > 30 flagged '*' = not identified; parameters the joints "
    "cannot see are listed), the mass and the centre of mass; optionally the "
    "estimates every --every seconds, a CSV over time (--out), a plot (--plot) and "
    "a JSON summary (--json)."
)

# Option -> OnlineSettings field of the payload identifier's settings.
_SETTING_OPTIONS = (
    "window",
    "jacobi_window",
    "bank_time_step",
    "update_period",
    "max_condition",
    "weighting",
    "uncertainty",
    "rows_from",
    "raw_window",
)


#: Largest payload offset accepted [m] (a tool is centimetres to a metre away;
#: 1e300 made the rows overflow to NaN).
MAX_OFFSET = 100.0


def _triple_or_six(text: str | None) -> tuple[list[float], list[float]] | None:
    """``--offset X,Y,Z[,ROLL,PITCH,YAW]`` -> (xyz [m], rpy [rad])."""
    if text is None:
        return None
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if (
        len(values) not in (3, 6)
        or not all(map(math.isfinite, values))
        or max(map(abs, values[:3])) > MAX_OFFSET
    ):
        raise ValueError(
            "--offset must be X,Y,Z [m] or X,Y,Z,ROLL,PITCH,YAW [m, rad] (finite "
            f"numbers, |X|, |Y|, |Z| <= {MAX_OFFSET:g} m); got {text!r}."
        )
    return values[:3], (values[3:] or [0.0, 0.0, 0.0])


def payload_settings_of(
    args: argparse.Namespace, time_step: float | None = None
) -> Any:
    """The payload identifier's ``OnlineSettings`` of the options (checked).

    ``time_step``: the log's h, which puts the default bank step and solve
    period on its grid (``core.payload_step.payload_settings``).
    """
    from drake_dynid.commands.identify import OPTION_NAMES, _frequencies
    from drake_dynid.core.online_checks import check_values
    from drake_dynid.core.payload_step import (
        PAYLOAD_DEFAULTS,
        payload_bank_step,
        payload_settings,
    )

    # `is not None`: a 0 given is checked (and refused), not taken for unset.
    values = {
        k: getattr(args, k)
        for k in _SETTING_OPTIONS
        if getattr(args, k, None) is not None
    }
    frequencies = _frequencies(args.frequencies)
    if not (isinstance(frequencies, str) and frequencies == "default"):
        values["frequencies"] = frequencies
    merged = {**PAYLOAD_DEFAULTS, **values}
    if "bank_time_step" not in values:  # the default follows --jacobi-window
        merged["bank_time_step"] = payload_bank_step(merged["jacobi_window"])
    check_values(merged, owner=None, names=OPTION_NAMES)
    return payload_settings(time_step, **values)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid payload`` arguments."""
    add_common_arguments(parser, from_results=True)
    where = parser.add_argument_group("the payload and the arm")
    where.add_argument(
        "--frame",
        metavar="NAME",
        help="body or frame of the URDF the payload is rigidly attached to (default: "
        "the last identified link); the parameters are about its origin, in its axes",
    )
    where.add_argument(
        "--offset",
        metavar="X,Y,Z[,R,P,Y]",
        help="the attachment frame's offset from --frame: translation [m] and "
        "roll, pitch, yaw [rad], as a URDF <origin> (default 0)",
    )
    where.add_argument(
        "--params",
        metavar="ARM.json",
        help="the arm's parameters: a results file of dynid offline/identify "
        "--json (or dynid params --json); default: the URDF's values. The "
        "covariance a dynid offline/identify file holds is propagated to the "
        "payload's σ; of a file with a --physical estimate, the fit's (whose "
        "covariance it is) is used",
    )
    group = parser.add_argument_group(
        "identifier settings (default: the payload identifier's, "
        "drake_dynid.core.payload_step.PAYLOAD_DEFAULTS)"
    )
    group.add_argument("--window", type=float, metavar="S", help="window T [s] (0.75)")
    group.add_argument(
        "--frequencies",
        metavar="LIST",
        help="modulating indices ℓ: '0,1,2,3' (default) or start:step:stop; 'auto': "
        "the integers up to the default band (at least 8)",
    )
    group.add_argument(
        "--jacobi-window", type=float, metavar="S", help="differentiator window [s]"
    )
    group.add_argument(
        "--bank-time-step",
        type=float,
        metavar="S",
        help="bank sample period [s], a multiple of the log's (default: the "
        "multiple closest to 0.002, at least one step, at most --jacobi-window/10 "
        "as in dynid identify: the arm's known part must be integrated finely)",
    )
    group.add_argument(
        "--update-period",
        type=float,
        metavar="S",
        help="solve period [s] (the multiple of the log's step closest to 0.05)",
    )
    group.add_argument(
        "--max-condition", type=float, metavar="C", help="largest condition number"
    )
    group.add_argument(
        "--weighting", choices=("frequency", "none"), help="row weighting (frequency)"
    )
    group.add_argument(
        "--uncertainty",
        choices=("jackknife", "sandwich", "gautier"),
        help="standard deviations (sandwich: the row noise pooled across windows)",
    )
    group.add_argument(
        "--rows-from", choices=("filtered", "raw"), help="model rows' signals (raw)"
    )
    group.add_argument(
        "--raw-window", type=float, metavar="S", help="raw rows' velocity window [s]"
    )
    group.add_argument(
        "--engine",
        choices=("core", "blocks"),
        default="core",
        help="core: the vectorised numerical core (default); blocks: the Drake "
        "LeafSystems in a Simulator (the same estimates)",
    )
    outputs = parser.add_argument_group("outputs")
    outputs.add_argument(
        "--every",
        type=float,
        metavar="S",
        help="also print the mass and centre of mass every S seconds",
    )
    outputs.add_argument(
        "--out",
        metavar="FILE.csv",
        help="write the estimates over time: t,valid,<payload names>,std_<names> "
        "(-: standard output)",
    )
    outputs.add_argument(
        "--plot", metavar="FILE.png", help="plot the estimates over time"
    )


def _arm_covariance(
    document: dict[str, Any], size: int, source: str, names: Any = None
) -> tuple[Any, dict[str, Any]]:
    """Σ_arm of a results file (``covariance``) or None, and what it records.

    ``dynid offline --json`` and ``dynid identify --json`` write it (p × p in
    the order of ``parameters``). Checked as ``core.payload.arm_factor`` checks
    it (a size × size symmetric positive semi-definite matrix), with the file
    named. A parameter whose row and column are all null (``dynid identify``
    writes them so for a σ that is not finite) is taken as exact: its row and
    column are 0, and it is named. ``names``: the arm's parameter names.

    Returns:
        ``(Σ_arm or None, {"method": the file's covariance_method or None,
        "exact": names of the parameters taken as exact})``.
    """
    from drake_dynid.core.payload import arm_factor

    method = document.get("covariance_method")
    info: dict[str, Any] = {
        "method": method if isinstance(method, str) else None,
        "exact": [],
    }
    value = document.get("covariance")
    if value is None:
        return None, info
    try:
        covariance = np.array(
            [[np.nan if x is None else x for x in row] for row in value],
            dtype=float,
        )
    except (TypeError, ValueError):
        covariance = np.zeros(0)
    if covariance.shape == (size, size):
        unknown = np.isnan(covariance).all(axis=1) & np.isnan(covariance).all(axis=0)
        covariance[unknown, :] = 0.0
        covariance[:, unknown] = 0.0
        labels = list(names) if names is not None else [str(i) for i in range(size)]
        info["exact"] = [str(labels[i]) for i in np.flatnonzero(unknown)]
    if covariance.shape != (size, size) or not np.isfinite(covariance).all():
        raise ValueError(
            f"--params {source}: 'covariance' must be a {size} × {size} matrix of "
            "finite numbers, null only in whole rows and columns (the covariance of "
            "its parameters, as dynid offline/identify --json write it); got "
            + (
                f"shape {covariance.shape}."
                if covariance.shape != (size, size)
                else "a null or non-finite entry outside a whole row and column."
            )
        )
    try:
        arm_factor(covariance, size)
    except ValueError as error:
        text = str(error).replace("arm_factor: covariance", "'covariance'")
        raise ValueError(f"--params {source}: {text}") from None
    return covariance, info


def _robot(args: argparse.Namespace) -> tuple[Any, Any, Any, str, Any]:
    """(robot, log, θ_arm, source, Σ_arm or None): the arm, the log, its parameters."""
    from drake_dynid.validation import read_estimates, read_results

    if args.params:
        from drake_dynid.commands._results import results_robot, results_sign

        document = read_results(args.params)
        settings = document.get("settings")
        if args.dead_zone is None and not (
            isinstance(settings, dict)
            and ("dead_zone" in settings or "coulomb_dead_zone" in settings)
        ):
            # A file that records no Coulomb law (dynid params --json, the URDF's
            # a-priori values): the widths are measured on the log, as without it.
            args.dead_zone = "auto"
        robot = results_robot(args, document)
        estimates = read_estimates(document, robot, f"--params {args.params}")
        arm = estimates["fit"]  # the covariance the file records is the fit's
        args.arm_physical_unused = "physical" in estimates
        names = [entry.get("name") for entry in document.get("parameters", [])]
        covariance, args.arm_covariance = _arm_covariance(
            document,
            len(arm),
            str(args.params),
            names if len(names) == len(arm) else None,
        )
        log = read_robot_log(
            log_files(args),
            robot,
            resample=args.resample,
            command="payload",
            fill_gaps=args.fill_gaps,
            time_unit=getattr(args, "time_unit", None),
            topic=getattr(args, "topic", None),
            options=bag_options(args),
        )
        robot = results_sign(args, document, robot, log)
        return robot, log, arm, str(args.params), covariance
    if args.dead_zone is None:  # no --params: measured on the log
        args.dead_zone = "auto"
    robot = robot_from_args(args, "payload")
    log = read_robot_log(
        log_files(args),
        robot,
        resample=args.resample,
        command="payload",
        fill_gaps=args.fill_gaps,
        time_unit=getattr(args, "time_unit", None),
        topic=getattr(args, "topic", None),
        options=bag_options(args),
    )
    return apply_dead_zone(args, robot, log), log, robot.base_values, "urdf", None


def _document_entry(entry: dict[str, Any] | None) -> dict[str, Any] | None:
    if entry is None:
        return None
    return {
        "value": json_number(entry["value"]),
        "std": json_number(entry["std"]),
        "relative_std_percent": json_number(entry["relative_std_percent"]),
        "identified": bool(entry["identified"]),
    }


def _text(entry: dict[str, Any] | None, unit: str) -> str:
    if entry is None:
        return "not identifiable"
    flag = "" if entry["identified"] else " (not identified: %σ > 30)"
    return f"{entry['value']:.5g} ± {entry['std']:.3g} {unit}{flag}"


def run(args: argparse.Namespace) -> int:
    """Replays the log through the payload identifier; prints and writes results."""
    from drake_dynid.commands._paths import check_output_paths
    from drake_dynid.commands.identify import OPTION_NAMES, check_log_values
    from drake_dynid.core.payload_report import estimate_entry, payload_summary
    from drake_dynid.payload import payload_model

    check_output_paths(args)
    check_topic(args)
    if args.every is not None and not (math.isfinite(args.every) and args.every > 0):
        raise ValueError(f"--every must be > 0 [s]; got {args.every:g}.")
    offset = _triple_or_six(args.offset)
    payload_settings_of(args)  # every value checked before the log is read
    if args.plot:
        matplotlib_pyplot()
    robot, log, arm, source, covariance = _robot(args)
    settings = payload_settings_of(args, log.time_step)
    if settings.uncertainty == "gautier":
        # Gautier's σ has no term for it (_arm_line says so when the file has one).
        args.arm_covariance_dropped = covariance is not None
        covariance = None
    xyz, rpy = offset if offset is not None else (None, None)
    try:
        rows = payload_model(
            robot, args.frame, xyz=xyz, rpy=rpy, arm=arm, arm_covariance=covariance
        )
    except ValueError as error:
        raise ValueError(
            str(error).replace("payload_model: frame", "--frame")
        ) from None
    check_log_values(args, log, settings)
    try:
        settings = settings.for_log(
            log.time_step,
            log.duration,
            num_joints=robot.num_joints,
            num_parameters=rows.num_payload,
            owner=None,
            names=OPTION_NAMES,
        )
    except ValueError as error:
        raise ValueError(f"log {args.log}: {error}") from None
    if args.engine == "blocks":
        from drake_dynid.payload_diagrams import replay_payload_log

        progress = bool(sys.stderr.isatty()) and not args.quiet
        trace = replay_payload_log(log, rows, settings, progress=progress)
    else:
        from drake_dynid.core.payload_replay import replay_payload_core

        trace = replay_payload_core(log, rows, settings)
    valid = np.asarray(trace.valid) > 0.5
    if not valid.any():
        raise ValueError(
            f"no window of the log gave a valid payload estimate ({trace.t.size} "
            f"solves): the payload's {rows.num_payload} parameters "
            f"({', '.join(rows.payload_names)}) are not all excited within "
            f"--window {settings.window:g} s with {len(settings.ell())} modulating "
            "function(s). Move the arm more (every joint, changing orientation and "
            "accelerations), lengthen --window, use more modulating functions "
            "(--frequencies, default 0,1,2,3), or raise --max-condition."
        )
    t = log.t[0] + np.asarray(trace.t)
    last = int(np.flatnonzero(valid)[-1])
    final_valid = bool(valid[-1])
    theta, std, correlation = trace.theta[-1], trace.std[-1], trace.correlation[-1]
    summary = payload_summary(rows, theta, std, correlation)
    reason = ""
    if not final_valid:
        reason = (
            "the last window is not ready (bad samples)"
            if int(trace.status[-1]) == 1
            else "the last window does not excite every payload parameter "
            f"(condition number {trace.condition_number[-1]:.3g})"
        )
    if not args.quiet:
        _print(args, robot, log, rows, trace, summary, settings, source, t, reason)
    if args.out:
        write_estimates_csv(
            args.out, t, trace.valid, trace.theta, trace.names, trace.std
        )
        if not args.quiet:
            print(f"wrote {args.out}")
    document = None
    if args.json:
        definitions = rows.base.definitions
        document = {
            "payload": {
                "link": rows.link_name,
                "link_index": rows.link,
                "frame": rows.frame_name,
                "offset": None
                if offset is None
                else {"xyz": offset[0], "rpy": offset[1]},
                "parameters": [
                    {
                        "name": name,
                        **(_document_entry(estimate_entry(value, sigma)) or {}),
                        "definition": dict(definition),
                    }
                    for name, value, sigma, definition in zip(
                        rows.payload_names, theta, std, definitions, strict=True
                    )
                ],
                "mass": _document_entry(summary["mass"]),
                "com": None
                if summary["com"] is None
                else {k: _document_entry(v) for k, v in summary["com"].items()},
                "inertia": {
                    name: _document_entry(summary["standard"][name])
                    for name in ("XX", "XY", "XZ", "YY", "YZ", "ZZ")
                },
                "not_identifiable": summary["not_identifiable"],
            },
            "arm": {
                "source": source,
                "num_parameters": len(arm),
                "covariance_method": _arm_info(args)["method"],
                "taken_as_exact": _arm_info(args)["exact"]
                if rows.arm_factor is not None
                else None,
            },
            "sigma_terms": {
                "rows_noise": True,
                "arm_covariance": rows.arm_factor is not None,
                "arm_model_error": False,
            },
            "valid": final_valid,
            "reason": reason,
            "last_valid_time": float(t[last]),
            "condition_number": json_number(trace.condition_number[last]),
            "delay": float(trace.delay),
            "settings": {
                **settings.as_dict(),
                "friction": list(robot.friction),
                "coulomb_width": robot.coulomb_width,
                **model_settings(args, robot),
                "engine": args.engine,
            },
            "urdf": str(args.urdf),
            "log": log_document(args, log),
        }
    write_trace_outputs(
        args,
        document,
        t,
        trace,
        f"dynid payload: {rows.frame_name}, window {settings.window:g} s",
    )
    return 0


def _print(args, robot, log, rows, trace, summary, settings, source, t, reason) -> None:

    print(f"log: {args.log} ({log.num_samples} samples, h = {log.time_step:g} s)")
    line = dead_zone_line(robot, args)
    if line:
        print(line)
    where = f"frame {rows.frame_name}" + (
        f" + offset {args.offset}" if args.offset else ""
    )
    print(f"payload: on link {rows.link + 1} ({rows.link_name}), {where}")
    print(_arm_line(args, rows, source))
    print(
        f"window: {settings.window:g} s; ℓ = "
        f"{', '.join(f'{x:g}' for x in settings.ell())}; {settings.rows_from} rows; "
        f"latency {trace.delay:.4g} s"
    )
    if args.every:
        print()
        _print_every(args.every, rows, trace, settings, t)
    print()
    last = int(np.flatnonzero(np.asarray(trace.valid) > 0.5)[-1]) if reason else -1
    # The table holds the last valid window's estimate: its time heads it.
    shown = (
        f"last valid estimate (t = {t[last]:.4g} s; the final window, t = "
        f"{t[-1]:.4g} s, is not valid)"
        if reason
        else f"final estimate (t = {t[-1]:.4g} s)"
    )
    print(f"{shown}, about the attachment frame, in its axes:")
    for text in estimates_table(trace.names, trace.theta[-1], trace.std[-1]):
        print(text)
    print()
    print(f"mass: {_text(summary['mass'], 'kg')}")
    com = summary["com"]
    if com is None:
        print("centre of mass: not identifiable (M, MX, MY, MZ not all seen)")
    else:
        for axis in "xyz":
            print(f"centre of mass {axis}: {_text(com[axis], 'm')}")
    if summary["not_identifiable"]:
        print(
            "not identifiable from these joints: "
            f"{', '.join(summary['not_identifiable'])} (regrouped or never seen)"
        )
    if reason:
        print(
            f"final window INVALID: {reason}; the last valid estimate (t = "
            f"{t[last]:.4g} s) is shown"
        )


def _arm_info(args: argparse.Namespace) -> dict[str, Any]:
    """What ``--params``' covariance records (:func:`_arm_covariance`)."""
    info = getattr(args, "arm_covariance", None)
    return info if isinstance(info, dict) else {"method": None, "exact": []}


def _arm_line(args: argparse.Namespace, rows: Any, source: str) -> str:
    """The printout's line on the arm: its source and what σ holds of its error."""
    where = "the URDF" if source == "urdf" else source
    info = _arm_info(args)
    if rows.arm_factor is not None:
        held = "their covariance propagated to σ"
        if info["method"] == "diagonal":
            held += " (the file's is diagonal: their correlation not known)"
        if info["exact"]:
            held += (
                f"; {', '.join(info['exact'])} without a finite σ in the file: "
                "taken as exact"
            )
    elif source == "urdf":
        held = "taken as exact: σ holds no error of the arm"
    elif getattr(args, "arm_covariance_dropped", False):
        held = "their covariance not propagated under --uncertainty gautier"
    else:
        held = "no covariance in the file: taken as exact"
    which = (
        ", the fit's estimate; not the file's physical one"
        if getattr(args, "arm_physical_unused", False)
        else ""
    )
    return f"arm: {where} ({len(rows.arm)} base parameters, known{which}; {held})"


def _print_every(every: float, rows, trace, settings, t) -> None:
    """The estimate every ``every`` seconds: m and c, else the base parameters."""
    from drake_dynid.core.payload_report import estimate_entry, payload_summary

    step = max(1, round(every / settings.resolved("update_period")))
    has_mass = "M" in rows.payload_names
    if has_mass:
        print("t [s]     m [kg]               c [m] (* not identified: %σ > 30)")
    else:
        print("t [s]     " + "  ".join(rows.payload_names) + " (* %σ > 30)")
    for k in range(0, len(t), step):
        if trace.valid[k] < 0.5 and trace.status[k] == 1:
            continue  # the first window is not full yet
        if not has_mass:
            cells = []
            for value, sigma in zip(trace.theta[k], trace.std[k], strict=True):
                flag = "" if estimate_entry(value, sigma)["identified"] else "*"
                cells.append(f"{value:.4g} ± {sigma:.2g}{flag}")
            print(f"{t[k]:<9.4g} " + "  ".join(cells))
            continue
        entry = payload_summary(
            rows, trace.theta[k], trace.std[k], trace.correlation[k]
        )
        mass, com = entry["mass"], entry["com"]
        m = f"{mass['value']:.4g} ± {mass['std']:.2g}"
        m += "" if mass["identified"] else " *"
        c = "-"
        if com is not None and mass["identified"]:
            c = ", ".join(
                f"{com[a]['value']:.4g}" + ("" if com[a]["identified"] else "*")
                for a in "xyz"
            )
            c = f"({c})"
        print(f"{t[k]:<9.4g} {m:<20} {c}")
