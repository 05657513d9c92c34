"""``dynid fleet identify|offline``: one command over many logs, in parallel."""

from __future__ import annotations

import argparse
import importlib
import sys
from typing import Any

HELP = "run identify or offline over many logs (local processes or a Dask cluster)"
DESCRIPTION = (
    "Runs dynid identify or dynid offline on each of many logs (a fleet of robots, "
    "a parameter study, a series of recordings), each log one recording, with the "
    "same options, and writes one JSON per log in --out-dir (<log name>.json, as the "
    "command's --json) plus summary.json, and prints a summary table. By default the "
    "logs run in parallel local processes (--jobs, default the CPUs it may use); with "
    "--scheduler ADDRESS they run on that Dask distributed cluster (pip install "
    "'drake-dynid[fleet]'). The command's options follow the logs, as for the "
    "command itself. Exit code 2 when a log fails (the others are still done); "
    "its JSON from an earlier run, if any, is moved aside to <log name>.stale.json."
)

_PER_LOG_OUTPUTS = (
    ("--json", "json"),
    ("--out", "out"),
    ("--plot", "plot"),
    ("--urdf-out", "urdf_out"),
)
_FLEET_OWNED = ("--quiet",)


class _FleetParser(argparse.ArgumentParser):
    """The command's own options, with LOGS (one recording each) for its LOG.

    The command's ``add_arguments`` declares its ``log`` positional and its
    ``--json``/``--quiet`` through this class: the positional becomes the fleet's
    LOGS, and the fleet owns the outputs (the per-log outputs ``--json``,
    ``--out``, ``--plot``, ``--urdf-out`` are still read, unlisted in the help,
    so that they are refused by name, not as an "unrecognized argument").
    """

    def add_argument(self, *names: Any, **kwargs: Any) -> Any:
        if names == ("log",):
            return super().add_argument(
                "logs",
                nargs="+",
                metavar="LOG.csv",
                help="the logs, one recording each (CSV files or ROS bags, as for "
                "the command)",
            )
        if names and names[0] in _FLEET_OWNED:
            return None
        if names == ("--json",):  # read, to be refused by name (run)
            kwargs["help"] = argparse.SUPPRESS
        return super().add_argument(*names, **kwargs)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Adds ``identify`` and ``offline`` with their own options and the fleet's."""
    from drake_dynid.fleet import FLEET_COMMANDS

    commands = parser.add_subparsers(
        dest="fleet_command", metavar="COMMAND", parser_class=_FleetParser
    )
    for name in FLEET_COMMANDS:
        module = importlib.import_module(f"drake_dynid.commands.{name}")
        sub = commands.add_parser(
            name,
            help=f"dynid {name} over many logs",
            description=f"dynid {name} over many logs: {module.HELP}.",
        )
        module.add_arguments(sub)
        for action in sub._actions:  # in argument groups too
            if set(action.option_strings) & set(dict(_PER_LOG_OUTPUTS)):
                # Read, to be refused by name (run), not offered in the help (it
                # described '--out FILE.csv ... -: standard output').
                action.help = argparse.SUPPRESS
        fleet = sub.add_argument_group("fleet")
        fleet.add_argument(
            "--out-dir",
            required=True,
            metavar="DIR",
            help="folder of the results: <log name>.json per log and summary.json",
        )
        fleet.add_argument(
            "--jobs",
            type=int,
            metavar="N",
            help="local worker processes (default: the CPUs this process may run "
            "on); 1 runs the logs one after the other in this process",
        )
        fleet.add_argument(
            "--scheduler",
            metavar="ADDRESS",
            help="run on this Dask distributed scheduler (e.g. tcp://host:8786) "
            "instead of local processes",
        )
        fleet.add_argument(
            "--quiet", action="store_true", help="print nothing on stdout"
        )


def _options(args: argparse.Namespace) -> dict[str, Any]:
    """The command's options: everything but the fleet's own and the dispatch."""
    skip = {
        "command",
        "fleet_command",
        "logs",
        "out_dir",
        "jobs",
        "scheduler",
        "quiet",
        "threads",
        "_run",
    }
    return {k: v for k, v in vars(args).items() if k not in skip}


def summary_table(items: list[dict[str, Any]]) -> list[str]:
    """The markdown summary: log, status, valid, condition number, time, JSON."""
    lines = [
        "| log | status | valid | condition | time [s] | result |",
        "|---|---|---|---:|---:|---|",
    ]
    for item in items:
        condition = item.get("condition_number")
        cond = f"{condition:.3g}" if isinstance(condition, int | float) else ""
        valid = "" if item.get("valid") is None else str(bool(item["valid"])).lower()
        result = item["json"] if item["status"] == "ok" else item["message"]
        result = result.strip().splitlines()[-1] if result.strip() else ""
        if item.get("stale_json_error"):
            result += (
                f" ({item['stale_json']} is from an earlier run, not this one's "
                "result; it could not be moved aside)"
            )
        elif item.get("stale_json"):
            result += (
                f" (an earlier run's JSON, not this one's result, moved to "
                f"{item['stale_json']})"
            )
        lines.append(
            f"| {item['log']} | {item['status']} | {valid} | {cond} | "
            f"{item['seconds']:.2f} | {result} |"
        )
    return lines


def _check_out_dir(args: argparse.Namespace) -> None:
    """``--out-dir`` is a folder (or can be made one) whose files are no input.

    Its per-log JSON files and summary.json are checked like any output
    (``commands._paths``: never an input, never two at one path).
    """
    from pathlib import Path

    from drake_dynid.commands._paths import INPUTS, check_outputs
    from drake_dynid.fleet import output_paths

    folder = Path(args.out_dir)
    if args.out_dir == "-":
        raise ValueError(
            "--out-dir -: a fleet writes a folder of files, not standard output "
            "('-'); give a folder."
        )
    if folder.exists() and not folder.is_dir():
        raise ValueError(f"--out-dir {folder} is a file; give a folder.")
    if not folder.exists():
        return  # created by the run: none of its files can be an input
    outputs = {
        f"--out-dir's {Path(path).name} (log {log})": path
        for log, path in zip(args.logs, output_paths(args.logs, folder), strict=True)
    }
    outputs["--out-dir's summary.json"] = str(folder / "summary.json")
    inputs = {"a log": args.logs}
    for attribute, description in INPUTS.items():
        if attribute not in ("log", "logs"):
            inputs[description] = getattr(args, attribute, None)
    check_outputs(outputs, inputs)


def _check_joint_options(args: argparse.Namespace) -> None:
    """``--joints`` and ``--lock`` as every log's command will read them.

    Found by a review: ``--joints ""`` (an unset shell variable) failed each log
    on its own, with the same message in every row of the table.
    """
    from drake_dynid.commands._arguments import parse_joints, parse_locked

    parse_joints(getattr(args, "joints", None))
    parse_locked(getattr(args, "lock", None))


def _check_topic(args: argparse.Namespace) -> None:
    """``--topic`` needs a ROS bag among the logs (``--validate``'s included).

    Each log's run then reads it for a bag only (``fleet.run_one``), so that a
    fleet of bags and CSV files reads the bags' topic.
    """
    from drake_dynid.commands._arguments import check_topic, log_files

    check_topic(args, [*args.logs, *log_files(args, "validate")])


def _check_shared_inputs(args: argparse.Namespace) -> None:
    """The URDF, drive file and --validate logs every log uses exist (local runs).

    Found by a review: a mistyped --urdf failed each log on its own, after a
    worker process had started for it (1 s each), with the same message in every
    row of the table. Not checked with --scheduler: the cluster's workers read
    the files, and this machine may not hold them.
    """
    from pathlib import Path

    from drake_dynid.urdf import packaged_names

    for attribute, option in (("urdf", "--urdf"), ("drive", "--drive")):
        value = getattr(args, attribute, None)
        if value is not None and not Path(value).is_file():
            suffix, kind = {
                "urdf": (".urdf", "model"),
                "drive": (".toml", "drive file"),
            }[attribute]
            hint = f" (or the name of a packaged {kind}: {packaged_names(suffix)})"
            raise ValueError(
                f"{option} {value}: no such file{hint}; every log would fail on it."
            )
    validate = getattr(args, "validate", None) or ()
    for value in [validate] if isinstance(validate, str) else validate:
        if not Path(value).is_file():
            raise ValueError(
                f"--validate {value}: no such file; every log would fail on it."
            )


def run(args: argparse.Namespace) -> int:
    """Runs the command over the logs; prints the summary.

    Exit 1 if a log met an internal error (a bug), else 2 if a log failed.
    """
    from pathlib import Path

    from drake_dynid.fleet import run_fleet

    if args.fleet_command is None:
        raise ValueError("choose the command: dynid fleet identify|offline LOGS ...")
    given = [
        opt for opt, name in _PER_LOG_OUTPUTS if getattr(args, name, None) is not None
    ]
    if given:
        raise ValueError(
            f"{', '.join(given)} would write one file for every log; a fleet writes "
            "each log's results in --out-dir (its JSON)."
        )
    if args.jobs is not None and args.jobs < 1:  # in its option's name
        raise ValueError(f"--jobs must be >= 1; got {args.jobs}.")
    _check_out_dir(args)
    _check_joint_options(args)
    _check_topic(args)
    if args.scheduler is None:
        _check_shared_inputs(args)
    quiet = bool(args.quiet)

    def progress(item: dict[str, Any], done: int, total: int) -> None:
        if not quiet:
            print(
                f"[{done}/{total}] {item['log']}: {item['status']} "
                f"({item['seconds']:.1f} s)",
                flush=True,
            )
        # The log's notes and warnings, captured by its worker: together, named.
        for line in item.get("stderr") or ():
            print(f"{item['log']}: {line}", file=sys.stderr)
        if item["status"] == "internal error":
            print(item["message"], file=sys.stderr)
        sys.stderr.flush()

    items = run_fleet(
        args.fleet_command,
        _options(args),
        args.logs,
        args.out_dir,
        jobs=args.jobs,
        scheduler=args.scheduler,
        progress=progress,
    )
    from drake_dynid.files import json_text, write_text_whole

    summary = Path(args.out_dir) / "summary.json"
    write_text_whole(summary, json_text(items, allow_nan=True))
    if not quiet:
        print()
        for line in summary_table(items):
            print(line)
        print(f"wrote {summary}")
    failed = [item for item in items if item["status"] != "ok"]
    moved = [
        item["stale_json"]
        for item in failed
        if item.get("stale_json") and not item.get("stale_json_error")
    ]
    if moved:
        print(
            f"dynid fleet: note: {len(moved)} failed log(s) had a JSON in "
            f"{args.out_dir} from an earlier run, not this run's result: moved "
            f"aside to <name>.stale.json (first: {moved[0]}; summary.json: "
            "stale_json).",
            file=sys.stderr,
        )
    kept = [item for item in failed if item.get("stale_json_error")]
    if kept:
        print(
            f"dynid fleet: warning: the JSON of {len(kept)} failed log(s) in "
            f"{args.out_dir} is from an earlier run, not this run's result, and "
            f"could not be moved aside (first: {kept[0]['stale_json']}: "
            f"{kept[0]['stale_json_error']}).",
            file=sys.stderr,
        )
    bugs = [item for item in items if item["status"] == "internal error"]
    if bugs:  # a bug exits 1 (docs/CONVENTIONS.md), its traceback printed above
        print(
            f"dynid fleet: error: {len(bugs)} of {len(items)} logs met an internal "
            f"error (first: {bugs[0]['log']}; its traceback is above); "
            f"{len(failed) - len(bugs)} failed on their input; see {summary}.",
            file=sys.stderr,
        )
        return 1
    if failed:
        raise ValueError(
            f"{len(failed)} of {len(items)} logs failed (first: {failed[0]['log']}: "
            f"{failed[0]['message'].strip().splitlines()[-1]}); see {summary}."
        )
    return 0
