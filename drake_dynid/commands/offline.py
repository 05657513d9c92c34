"""``dynid offline``: off-line IDIM-LS / IDIM-WLS on a recorded robot log."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from drake_dynid.commands._arguments import (
    add_common_arguments,
    apply_dead_zone,
    check_topic,
    dead_zone_cover,
    dead_zone_line,
    load_robot_and_log,
    model_settings,
)
from drake_dynid.commands._model import (
    add_model_arguments,
    check_regularization,
    finish_offline,
    raise_urdf_error,
)
from drake_dynid.commands._options import FILTER_OPTIONS, option_message
from drake_dynid.commands._report import (
    estimates_table,
    json_number,
    log_document,
    matplotlib_pyplot,
    parameters_document,
    resampled_log_note,
    write_json,
)
from drake_dynid.commands.validate import (
    check_output_paths,
    log_line,
    validation_split,
)
from drake_dynid.core._validate import listed

HELP = "off-line IDIM-LS/WLS (zero-phase filtering, parallel decimation) on a log"
DESCRIPTION = (
    "Off-line inverse-dynamics identification of the base parameters from a "
    "recorded robot log (CSV: t, q_<joint>, tau_<joint>), Gautier's practice: "
    "zero-phase Butterworth low-pass of q with central differences for v and v̇, "
    "parallel decimation of the regressor W and the torques, then least squares "
    "τ = W·θ by QR (IDIM-LS) or weighted per joint (IDIM-WLS, --weighted). By "
    "default the cutoff minimises the expected error of v̇, the filter's droop on "
    "the measured motion against the noise it passes (at most 40 Hz and fs/5); the "
    "parallel decimation "
    "low-pass sits at 1.5 times the velocity bandwidth of the log (the equation is "
    "linear, so it may cut into the band without bias, and it removes the noise of "
    "v̇ above the motion). NaN samples split the log into segments, "
    "each filtered on its own. Prints the estimates with their standard "
    "deviations (Gautier's, times sqrt(f_s/(2 D B_n)) for the correlation the "
    "decimation low-pass leaves between rows; %σ > 30 flagged '*' = not "
    "identified) and the condition number."
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds the ``dynid offline`` arguments."""
    add_common_arguments(parser)
    parser.add_argument(
        "--cutoff",
        type=float,
        metavar="HZ",
        help="Butterworth cutoff of the position filter [Hz] (default: automatic)",
    )
    parser.add_argument(
        "--decimation",
        type=int,
        metavar="D",
        help="parallel decimation factor (default: automatic)",
    )
    parser.add_argument(
        "--decimation-cutoff",
        type=float,
        metavar="HZ",
        help="low-pass of the parallel decimation [Hz] (default: 1.5 x the "
        "measured velocity bandwidth, at most the --cutoff)",
    )
    parser.add_argument(
        "--weighted",
        action="store_true",
        help="IDIM-WLS: weight each joint's equations by 1/σ_j",
    )
    add_model_arguments(parser)


def _fitted(args: argparse.Namespace) -> str:
    """The fitted log in a message: with ``--split``, its first part, so named."""
    split = getattr(args, "split", None)
    if split is None:
        return f"log {args.log}"
    return f"log {args.log}, its first {100 * split:g} % (--split {split:g})"


def run(args: argparse.Namespace) -> int:
    """Runs IDIM-LS/WLS on the log; prints the table; writes JSON when asked."""
    from drake_dynid.offline import identify_offline

    check_output_paths(args)
    check_topic(args)
    check_regularization(args)
    if args.plot:
        matplotlib_pyplot()  # fail before the fit
    robot, log = load_robot_and_log(args, "offline")
    total_samples = log.num_samples
    log, held, held_description = validation_split(args, log, robot)
    robot = apply_dead_zone(args, robot, log)  # measured on the fitted part only
    try:
        result = identify_offline(
            log,
            robot,
            cutoff_hz=args.cutoff,
            decimation=args.decimation,
            decimation_cutoff_hz=args.decimation_cutoff,
            weighted=args.weighted,
        )
    except ValueError as error:
        message = option_message(str(error), FILTER_OPTIONS, ("identify_offline",))
        raise ValueError(f"{_fitted(args)}: {message}") from None
    settings = result.settings
    if not result.valid:
        raise ValueError(
            f"the least squares on {_fitted(args)} failed: "
            f"{result.reason.rstrip('.')}. Use a log "
            "with more excitation (every joint moving, velocity reversals), fewer "
            "friction columns (--friction), or another --cutoff."
            + dead_zone_cover(robot, log)
        )
    if not args.quiet:
        print(log_line(args, log, total_samples))
        line = dead_zone_line(robot, args, reversals=True)
        if line:
            print(line)
        print(
            f"model: {result.model}; cutoff {settings['cutoff_hz']:.4g} Hz "
            f"({settings['cutoff_rule']}); decimation {settings['decimation']} "
            f"({settings['decimation_rule']}) after a "
            f"{settings['decimation_cutoff_hz']:.4g} Hz low-pass "
            f"({settings['decimation_cutoff_rule']}); samples used "
            f"{result.num_samples_used} of {result.num_samples} in "
            f"{result.num_segments_used} of {result.num_segments} segment(s); "
            f"{result.num_rows} equations"
        )
        if robot.coulomb_width > 0.0:
            print(f"Coulomb friction: tanh(v/{robot.coulomb_width:g}), --coulomb-width")
        print()
        for line in estimates_table(result.names, result.theta, result.std):
            print(line)
        print()
        print(f"condition number: {result.condition_number:.4g}")
        print(
            f"residual σ: {result.residual_std:.4g}"
            + (" (weighted: in units of each joint's σ_j)" if args.weighted else "")
        )
        if args.split is not None:
            print(f"fitted on the first {100 * args.split:g} % of {args.log}")
    joint_sigma, joint_rank = _joint_noise(result)
    spread = _unequal_noise(robot, joint_sigma, joint_rank, result)
    if spread:
        print(f"dynid offline: note: {spread}", file=sys.stderr)
    shaky = _shaky_weights(robot, joint_rank, result)
    if shaky:
        print(f"dynid offline: note: {shaky}", file=sys.stderr)
    if settings["cutoff_rule"] == "auto":
        resampled_log_note("offline", log)
    extra = finish_offline(args, robot, log, held, held_description, result)
    if args.json:
        document = {
            "parameters": parameters_document(
                robot, result.names, result.theta, result.std
            ),
            "covariance": _covariance(result),
            "condition_number": json_number(result.condition_number),
            "window": float(log.duration),
            "model": result.model,
            "valid": bool(result.valid),
            "reason": result.reason,
            "residual_std": json_number(result.residual_std),
            "joint_noise_std": None
            if joint_sigma is None
            else {
                name: json_number(value)
                for name, value in zip(robot.joint_names, joint_sigma, strict=True)
            },
            "num_rows": int(result.num_rows),
            "samples_used": int(result.num_samples_used),
            "segments": int(result.num_segments),
            "segments_used": int(result.num_segments_used),
            "settings": {
                **settings,
                "friction": list(robot.friction),
                "coulomb_width": robot.coulomb_width,
                "resample": bool(args.resample),
                "fill_gaps": int(args.fill_gaps),
                **model_settings(args, robot),
            },
            "urdf": str(args.urdf),
            "log": log_document(args, log),
            **extra,
        }
        write_json(args.json, document)
        if not args.quiet:
            print(f"wrote {args.json}")
    raise_urdf_error(args)
    return 0


def _covariance(result: Any) -> list[list[float]] | None:
    """The fit's (p, p) covariance as JSON rows (None when not computable).

    ``core.idim.idim_covariance``: σ's diagonal, the solve's correlation; in the
    order of ``parameters`` [their units, squared]. ``dynid payload --params``
    propagates it to the payload's σ (docs/PAYLOAD.md §4).
    """
    import numpy as np

    from drake_dynid.core.idim import idim_covariance

    if result.reduced is None or not result.valid:
        return None
    try:
        covariance = idim_covariance(
            result.reduced, result.std, weighted=result.model == "idim-wls"
        )
    except ValueError:
        return None
    return [[float(x) for x in row] for row in np.asarray(covariance)]


#: Joints' equation-error σ differing by more than this factor: IDIM-LS is told
#: to consider --weighted.
UNEQUAL_NOISE = 10.0


def _joint_noise(result: Any) -> tuple[Any, Any]:
    """Each joint's equation-error σ_j [N·m or N] and fitted rank (None, None).

    None, None when not computable. Gautier's (``core.idim.joint_noise_fits``):
    the OLS of that joint's equations alone, the weights IDIM-WLS would use.
    """
    import numpy as np

    from drake_dynid.core.idim import joint_noise_fits

    reduced = result.reduced
    if reduced is None or not np.isfinite(reduced.R).all():
        return None, None
    try:
        return joint_noise_fits(reduced)
    except ValueError:  # fewer samples than a joint's rank
        return None, None


def _shaky_weights(robot: Any, rank: Any, result: Any) -> str:
    """IDIM-WLS's note on weights σ_j resting on few degrees of freedom ('' if none).

    A joint whose own fit leaves fewer residual degrees of freedom than it has
    parameters (K − rank_j < rank_j) gets a σ_j that comes out low
    (``core.idim.joint_noise_fits``), hence too large a weight: a review's 20 s
    iiwa7 logs with equal noise on every joint gave IDIM-WLS errors 1.2 times
    IDIM-LS's (up to 1.85).
    """
    if rank is None or result.model != "idim-wls":
        return ""
    rows = result.reduced.num_samples
    few = [
        (name, rows - int(r), int(r))
        for name, r in zip(robot.joint_names, rank, strict=True)
        if rows - r < r
    ]
    if not few:
        return ""
    names, left, fitted = zip(*few, strict=True)
    return (
        "IDIM-WLS weights each joint by its σ_j, fitted on that joint's equations "
        f"alone; {listed(names)} leave fewer residual degrees of freedom than "
        f"parameters ({', '.join(map(str, left))} for "
        f"{', '.join(map(str, fitted))}), so their σ_j come out low and their "
        "weights too high: a longer log (more equations per joint) or IDIM-LS may "
        "do better"
    )


def _unequal_noise(robot: Any, sigma: Any, rank: Any, result: Any) -> str:
    """The note for IDIM-LS when the joints' σ_j differ by > UNEQUAL_NOISE ('' if not).

    IDIM-LS minimises Σ_j ‖τ_j − W_j X‖²: a joint with a thousand times less noise
    (a wrist beside a shoulder) counts as much as the shoulder's noise allows, and
    the pooled σ = ‖ρ‖/√(r − p) misstates both (docs/MATH.md §5). IDIM-WLS divides
    each joint's equations by σ_j. Only the joints whose own fit leaves at least as
    many residual degrees of freedom as it has parameters (K − rank_j >= rank_j)
    are compared: with fewer, σ_j comes out low (``core.idim.joint_noise_fits``;
    a review: equal noise on every joint, 20 s iiwa7 logs, σ_j 12.6× apart and
    --weighted 1.2× worse than IDIM-LS).
    """
    import numpy as np

    if sigma is None or result.model != "idim-ls" or sigma.size < 2:
        return ""
    rows = result.reduced.num_samples
    sigma = np.where((sigma > 0.0) & (rows - rank >= rank), sigma, np.nan)
    positive = sigma[np.isfinite(sigma)]
    if positive.size < 2 or positive.max() <= UNEQUAL_NOISE * positive.min():
        return ""
    big, small = int(np.nanargmax(sigma)), int(np.nanargmin(sigma))
    names = robot.joint_names
    return (
        f"the joints' equation errors differ by {sigma[big] / sigma[small]:.3g}× "
        f"(σ {names[big]} {sigma[big]:.3g}, {names[small]} {sigma[small]:.3g}): "
        "IDIM-LS weighs every joint's equations alike, so the small joints' "
        "parameters are fitted to the large joints' noise and the pooled σ misstates "
        "them; --weighted (IDIM-WLS) divides each joint's equations by its σ"
    )
