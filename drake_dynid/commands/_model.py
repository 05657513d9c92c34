"""Model outputs shared by ``dynid offline`` and ``dynid identify`` (not a subcommand).

``offline``: ``--physical`` (identification under physical-consistency
constraints, ``drake_dynid.physical``), ``--urdf-out`` (identified URDF,
``drake_dynid.urdf_writer``), ``--out`` / ``--plot`` and the validation options;
``identify``: the consistency check and validation of the final estimate.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from drake_dynid.commands.validate import (
    add_validation_arguments,
    report_validation,
    run_validations,
    write_torque_plot,
)
from drake_dynid.core._validate import listed


def add_physical_arguments(
    parser: argparse.ArgumentParser, online: bool = False
) -> Any:
    """``--physical``, ``--regularization``, ``--regularizer``, ``--urdf-out``.

    Returns their group.

    ``online``: ``dynid identify``'s wording (the final estimate is projected in
    its window's covariance metric, ``physical.project_physical``).
    """
    group = parser.add_argument_group("physically consistent model and outputs")
    group.add_argument(
        "--physical",
        action="store_true",
        help=(
            "also project the final estimate onto the physically consistent set "
            "(every link's 4x4 pseudo-inertia positive semidefinite, friction >= "
            "0) in the metric of its window's covariance, a semidefinite program "
            "(Clarabel)"
            if online
            else "also solve the identification under physical consistency (every "
            "link's 4x4 pseudo-inertia positive semidefinite, friction >= 0), a "
            "semidefinite program (Clarabel)"
        ),
    )
    group.add_argument(
        "--regularization",
        type=float,
        default=None,
        metavar="LAMBDA",
        help="weight of the pull towards the URDF values in --physical (default "
        "1e-3; in residual variances per squared parameter scale)",
    )
    group.add_argument(
        "--regularizer",
        choices=("euclidean", "entropic"),
        default=None,
        help="what --regularization weighs in --physical: 'euclidean' (default) "
        "the squared distance of the scaled standard parameters from the URDF's, "
        "which can empty a link the data barely see (mass near 0, centre of mass "
        "metres away); 'entropic' each link's log-det divergence from the URDF's "
        "pseudo-inertia (Lee, Wensing & Park 2020): no mass reaches 0 and the "
        "centre of mass stays inside the body (friction and rotor inertia keep "
        "the squared distance)",
    )
    group.add_argument(
        "--urdf-out",
        metavar="FILE.urdf",
        help="write a copy of the URDF with the consistent identified parameters "
        "(implies --physical)",
    )
    return group


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """The physical options (:func:`add_physical_arguments`), ``--out``, ``--plot``."""
    group = add_physical_arguments(parser)
    group.add_argument(
        "--out",
        metavar="FILE.csv",
        help="write the estimate as dynid identify --out does: t,valid,<names>,"
        "std_<names> (one row, at the end of the fitted log; -: standard output)",
    )
    group.add_argument(
        "--plot",
        metavar="FILE.png",
        help="plot measured and predicted torques per joint (on the validation log "
        "when --validate/--split is given, else on the fitted log)",
    )
    add_validation_arguments(parser)


def wants_physical(args: argparse.Namespace) -> bool:
    """Whether the physically consistent solve runs (--physical, --urdf-out)."""
    return bool(args.physical or args.urdf_out)


def _parameters(robot: Any, names, theta) -> list[dict[str, Any]]:
    definitions = dict(zip(robot.base.names, robot.base.definitions, strict=True))
    return [
        {"name": name, "value": float(value), "definition": dict(definitions[name])}
        for name, value in zip(names, theta, strict=True)
    ]


def consistency(
    robot: Any, theta, quiet: bool, what: str, hint: bool = False
) -> dict[str, Any]:
    """Prints whether θ is physically consistent; returns the JSON entry.

    ``hint``: an impossible θ's line names ``--physical`` (not asked for).
    """
    from drake_dynid.physical import check_physical

    if not np.all(np.isfinite(theta)):
        return {"consistent": None, "summary": "no finite estimate"}
    try:
        check = check_physical(robot, theta)
    except ValueError as error:
        # A check nobody asked for never stops the command: the fit and its
        # files are still written, and the check says why it was not done.
        summary = f"not done ({error})"
        if not quiet:
            print(f"physical check of {what}: {summary}")
        return {"consistent": None, "summary": summary}
    if not quiet:
        fix = (
            " --physical gives the closest consistent estimate (and --urdf-out "
            "writes it)."
            if hint and not check.consistent
            else ""
        )
        print(f"physical check of {what}: {check.summary()}{fix}")
    return {
        "consistent": bool(check.consistent),
        "negative": list(check.negative),
        "infeasible_links": list(check.infeasible_links),
        "involved": list(check.involved),
        "summary": check.summary(),
    }


def _comparison_lines(result: Any, physical: Any) -> list[str]:
    rows = []
    for k, name in enumerate(result.names):
        fit, value, sigma = result.theta[k], physical.theta[k], result.std[k]
        shift = (
            (value - fit) / sigma if sigma > 0 and math.isfinite(sigma) else math.nan
        )
        rows.append((name, f"{fit:.6g}", f"{value:.6g}", f"{shift:+.2f}"))
    headers = ("name", "fit", "physical", "shift/σ")
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(headers)]
    lines = [
        "  ".join(
            h.ljust(w) if k == 0 else h.rjust(w)
            for k, (h, w) in enumerate(zip(headers, widths, strict=True))
        ),
        "  ".join("-" * w for w in widths),
    ]
    for row in rows:
        lines.append(
            "  ".join(
                c.ljust(w) if k == 0 else c.rjust(w)
                for k, (c, w) in enumerate(zip(row, widths, strict=True))
            )
        )
    return lines


def _regularization(args: argparse.Namespace) -> float:
    from drake_dynid.physical import DEFAULT_REGULARIZATION

    value = getattr(args, "regularization", None)
    return DEFAULT_REGULARIZATION if value is None else float(value)


def _regularizer(args: argparse.Namespace) -> str:
    value = getattr(args, "regularizer", None)
    return "euclidean" if value is None else str(value)


def _physical(args: argparse.Namespace, robot: Any, result: Any):
    from drake_dynid.physical import solve_physical_reduced

    physical = solve_physical_reduced(
        robot,
        result.reduced,
        weighted=bool(result.settings.get("weighted")),
        regularization=_regularization(args),
        regularizer=_regularizer(args),
    )
    cost = "data cost +{:.4g} residual variances"
    return physical, physical_report(args, robot, result, physical, cost)


def physical_report(
    args: argparse.Namespace, robot: Any, fit: Any, physical: Any, cost: str
) -> dict[str, Any]:
    """Prints the consistent estimate beside ``fit`` (names, theta, std); its JSON.

    ``cost``: what ``physical.data_cost`` is, a format of its value.
    """
    regularization = _regularization(args)
    if not args.quiet:
        active = ", ".join(physical.active) or "none"
        print()
        print(
            f"physically consistent estimate ({physical.solver}, "
            f"{physical.solve_time:.3g} s; λ = {regularization:g}, "
            f"{physical.regularizer}): "
            f"{cost.format(physical.data_cost)}; active constraints: {active}"
        )
        print()
        for line in _comparison_lines(fit, physical):
            print(line)
    return {
        "parameters": _parameters(robot, physical.names, physical.theta),
        "standard": physical.standard_parameters(),
        "active": list(physical.active),
        "link_min_eigenvalues": [float(x) for x in physical.link_min_eigenvalues],
        "data_cost": float(physical.data_cost),
        "regularization": float(regularization),
        "regularizer": physical.regularizer,
        "solver": physical.solver,
        "solve_time": float(physical.solve_time),
    }


def check_regularization(args: argparse.Namespace) -> None:
    """``--regularization`` in [0, 1e6] and ``--regularizer``, with ``--physical``.

    Checked before the fit. Without ``--physical`` or ``--urdf-out`` (which
    implies it) nothing uses them: refused, not ignored (found by a review:
    ``--regularization`` was dropped without a word). argparse refuses a
    ``--regularizer`` other than its choices.
    """
    value = getattr(args, "regularization", None)
    if value is not None and not 0.0 <= value <= 1e6:
        raise ValueError(
            "--regularization must be in [0, 1e6] (1e6: the URDF's values, almost "
            f"regardless of the data); got {value:g}."
        )
    physical = getattr(args, "physical", False) or getattr(args, "urdf_out", None)
    if value is not None and not physical:
        raise ValueError(
            "--regularization weighs the pull towards the URDF values of the "
            "physically consistent estimate: give it with --physical (or "
            "--urdf-out)."
        )
    if getattr(args, "regularizer", None) is not None and not physical:
        raise ValueError(
            "--regularizer chooses what --regularization weighs in the physically "
            "consistent estimate: give it with --physical (or --urdf-out)."
        )


def finish_offline(
    args: argparse.Namespace,
    robot: Any,
    fit_log: Any,
    held: Any,
    description: str,
    result: Any,
) -> dict[str, Any]:
    """Consistency, --physical, --urdf-out, --out, --plot and validation.

    Prints its sections (unless --quiet) and returns the JSON entries to add.
    """
    from drake_dynid.commands._report import write_estimates_csv

    check_regularization(args)
    document: dict[str, Any] = {}
    if not args.quiet:
        print()
    document["physical_check"] = consistency(
        robot, result.theta, args.quiet, "the estimate", not wants_physical(args)
    )
    estimates: dict[str, np.ndarray] = {result.model: result.theta}
    if wants_physical(args):
        physical, document["physical"] = _physical(args, robot, result)
        estimates["physical"] = physical.theta
        if args.urdf_out:
            _write_urdf(args, robot, physical, document["physical"], result)
    if args.out:
        write_estimates_csv(
            args.out,
            [fit_log.t[-1]],
            [1.0],
            [result.theta],
            result.names,
            [result.std],
        )
        if not args.quiet:
            print(f"wrote {args.out}")
    if held is not None:
        document["validation"] = report_validation(
            args,
            robot,
            held,
            description,
            with_apriori(args, robot, estimates),
            plot_title=f"dynid offline: held-out torques ({description})",
        )
    elif args.plot:
        validations = run_validations(
            fit_log,
            robot,
            estimates,
            cutoff_hz=args.cutoff,
            decimation_cutoff_hz=args.decimation_cutoff,
        )
        write_torque_plot(
            args.plot,
            validations,
            f"dynid offline: fitted torques ({args.log})",
            getattr(robot, "prismatic", ()),
        )
        if not args.quiet:
            print(f"wrote {args.plot}")
    return document


def _write_urdf(
    args: argparse.Namespace,
    robot: Any,
    physical: Any,
    entry: dict[str, Any],
    fit: Any,
    notes: Sequence[str] = (),
) -> None:
    """``--urdf-out``: writes the URDF and records what it holds in ``entry``.

    The base parameters the fit (``names``, ``theta``, ``std``) did not identify
    (%σ > 30) are named in the file's header and in a warning: their written
    values are the projection's, which the data barely constrain. A writer error
    does not lose the fit: it is recorded as ``args.urdf_out_error`` and raised
    once the other outputs are written.
    """
    from drake_dynid.commands._report import not_identified
    from drake_dynid.urdf_writer import (
        doubtful_links,
        implausible_note,
        write_identified_urdf,
    )

    flagged = not_identified(fit.names, fit.theta, fit.std)
    notes = list(notes)
    if flagged:
        notes.append(
            f"Not identified by the fit (%σ > 30), {len(flagged)} of "
            f"{len(fit.names)} base parameters: {', '.join(flagged)}; the values "
            "written for them are the consistent projection's, which the data "
            "barely constrain: treat them as unknown."
        )
        print(
            f"dynid {getattr(args, 'command', None) or 'offline'}: warning: "
            f"--urdf-out: {len(flagged)} of {len(fit.names)} base "
            f"parameters were not identified (%σ > 30): {listed(flagged)}"
            "; the file's header lists them",
            file=sys.stderr,
        )
    entry["urdf_not_identified"] = flagged
    doubtful = doubtful_links(robot, physical.standard_values)
    if doubtful:
        notes.append(implausible_note(doubtful))
        print(
            f"dynid {getattr(args, 'command', None) or 'offline'}: warning: "
            f"--urdf-out: {len(doubtful)} link(s) written with a mass outside 1 % - "
            "10 times the URDF's or a centre of mass beyond 10 of its radii of "
            "gyration "
            "(consistent, but the base parameters share a link's mass and first "
            "moment with its neighbours, or the data contradict the URDF; "
            "--regularization pulls towards the URDF's, --regularizer entropic "
            "keeps masses off 0; the file's header lists them): " + "; ".join(doubtful),
            file=sys.stderr,
        )
    entry["urdf_doubtful_links"] = [text.split(":")[0] for text in doubtful]
    try:
        export = write_identified_urdf(
            robot, physical.standard_values, args.urdf_out, notes=notes
        )
    except (ValueError, OSError) as error:  # OSError: a full disk, a lost folder
        args.urdf_out_error = str(error)
        entry["urdf_error"] = str(error)
        return
    entry["urdf"] = export.path
    entry["urdf_lumped"] = list(export.lumped)
    entry["urdf_skipped"] = list(export.skipped)
    entry["urdf_locked"] = list(export.locked)
    if not args.quiet:
        parts = [f"wrote {export.path}"]
        if export.locked:
            parts.append(f"locked joints written as fixed: {listed(export.locked)}")
        if export.lumped:
            parts.append(f"welded links set to mass 0: {listed(export.lumped)}")
        if export.skipped:
            parts.append(f"not written, no URDF field: {listed(export.skipped)}")
        print("; ".join(parts))


def raise_urdf_error(args: argparse.Namespace) -> None:
    """Raises the ``--urdf-out`` error kept by :func:`finish_offline`, if any."""
    message = getattr(args, "urdf_out_error", None)
    if message:
        raise ValueError(
            f"--urdf-out {args.urdf_out} was not written (the other outputs were): "
            f"{message}"
        )


def finish_identify(
    args: argparse.Namespace,
    robot: Any,
    held: Any,
    description: str,
    estimates: Mapping[str, np.ndarray],
    fit: Any = None,
    covariance: Callable[[], np.ndarray] | None = None,
    urdf_notes: Sequence[str] = (),
) -> dict[str, Any]:
    """Consistency of the final estimate, --physical/--urdf-out, validation.

    ``dynid identify``. ``fit``: the final estimate's ``names``, ``theta``,
    ``std``; ``covariance``: its (p, p) covariance, computed when --physical or
    --urdf-out asks for the projection (``physical.project_physical``);
    ``urdf_notes``: more lines for the written URDF's header.
    """
    document: dict[str, Any] = {}
    theta = next(iter(estimates.values()))
    if not args.quiet:
        print()
    document["physical_check"] = consistency(
        robot, theta, args.quiet, "the final estimate", not wants_physical(args)
    )
    estimates = dict(estimates)
    if wants_physical(args) and fit is not None and covariance is not None:
        from drake_dynid.physical import project_physical

        physical = project_physical(
            robot,
            theta,
            covariance(),
            regularization=_regularization(args),
            regularizer=_regularizer(args),
        )
        cost = "Mahalanobis distance² +{:.4g} from the estimate"
        document["physical"] = physical_report(args, robot, fit, physical, cost)
        estimates["physical"] = physical.theta
        if args.urdf_out:
            _write_urdf(args, robot, physical, document["physical"], fit, urdf_notes)
    if held is not None:
        document["validation"] = report_validation(
            args, robot, held, description, with_apriori(args, robot, estimates)
        )
    return document


#: Label of the a-priori model in the validation tables (``--compare-urdf``).
APRIORI_LABEL = "URDF a-priori"


def with_apriori(
    args: argparse.Namespace, robot: Any, estimates: Mapping[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """``estimates`` plus the URDF's a-priori base values with ``--compare-urdf``.

    The a-priori values are the model's ``base_values``: the URDF's inertial
    parameters, ``<dynamics damping friction>``, the actuators' rotor inertia and
    the drive file's motor values.
    """
    out = dict(estimates)
    if getattr(args, "compare_urdf", False):
        out[APRIORI_LABEL] = np.asarray(robot.base_values, dtype=float)
    return out
