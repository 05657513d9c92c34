"""Outputs shared by the ``dynid`` subcommands: tables, JSON documents, CSV and plots.

Not a subcommand. ``dynid identify``, ``dynid offline`` and ``dynid params`` print
and write their results with these helpers, so every command shows a parameter the
same way (name, value, σ, %σ, ``*`` when %σ > 30: not identified) and
writes the same JSON keys (the format in the README, "JSON (--json)").
"""

from __future__ import annotations

import argparse
import csv
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from drake_dynid.core.lsq import NOT_IDENTIFIED_PERCENT, relative_std_percent

__all__ = [
    "NOT_IDENTIFIED_PERCENT",
    "PLOT_BUCKETS",
    "bucket_extremes",
    "bucket_times",
    "estimates_table",
    "json_number",
    "log_document",
    "matplotlib_pyplot",
    "parameters_document",
    "resampled_log_note",
    "trace_envelope",
    "write_estimates_csv",
    "write_json",
    "write_plot",
    "write_trace_outputs",
]


_CSV_BLOCK = 4096  # rows of the traces read at a time by write_estimates_csv

#: ``--plot`` draws a trace of more solves than this as the extremes of as many
#: buckets of consecutive solves (a 6-inch panel at 100 dpi is 600 pixels wide).
PLOT_BUCKETS = 2000


def json_number(value: Any) -> float | None:
    """A float for JSON, None for NaN and infinities (JSON has neither)."""
    value = float(value)
    return value if math.isfinite(value) else None


def _text(value: float, digits: int = 6) -> str:
    return f"{value:.{digits}g}" if math.isfinite(value) else str(value)


def not_identified(names: Sequence[str], theta: Any, std: Any) -> list[str]:
    """The names whose %σ exceeds :data:`NOT_IDENTIFIED_PERCENT` (the ``*``)."""
    return [
        name
        for name, value, sigma in zip(names, theta, std, strict=True)
        if not relative_std_percent(value, sigma) <= NOT_IDENTIFIED_PERCENT
    ]


def estimates_table(names: Sequence[str], theta: Any, std: Any) -> list[str]:
    """Lines of the estimates table: name, value, σ, %σ, flag (``*``: %σ > 30).

    ``theta`` and ``std`` are sequences of p reals (arrays or lists).
    """
    rows = []
    for name, raw_value, raw_sigma in zip(names, theta, std, strict=True):
        value, sigma = float(raw_value), float(raw_sigma)
        percent = relative_std_percent(value, sigma)
        if math.isfinite(percent):
            percent_text = f"{percent:.2f}"
        else:
            percent_text = "inf" if math.isfinite(value) else "nan"
        flag = "*" if not percent <= NOT_IDENTIFIED_PERCENT else ""
        rows.append((name, _text(value), _text(sigma, 3), percent_text, flag))
    headers = ("name", "value", "σ", "%σ", "")
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(headers)]
    lines = [
        f"{headers[0]:<{widths[0]}}  {headers[1]:>{widths[1]}}  "
        f"{headers[2]:>{widths[2]}}  {headers[3]:>{widths[3]}}",
        f"{'-' * widths[0]}  {'-' * widths[1]}  {'-' * widths[2]}  {'-' * widths[3]}",
    ]
    for name, value_text, sigma_text, percent_text, flag in rows:
        lines.append(
            f"{name:<{widths[0]}}  {value_text:>{widths[1]}}  "
            f"{sigma_text:>{widths[2]}}  {percent_text:>{widths[3]}}  {flag}".rstrip()
        )
    if any(r[4] for r in rows):
        lines.append(
            f"* %σ > {NOT_IDENTIFIED_PERCENT:g}: not identified (too little "
            "excitation of this parameter, or too much noise)"
        )
    return lines


def parameters_document(
    robot: Any, names: Sequence[str], theta: Any, std: Any
) -> list[dict[str, Any]]:
    """The ``parameters`` list of the JSON format (README.md, "JSON (--json)")."""
    definitions: Mapping[str, Any] = dict(
        zip(robot.base.names, robot.base.definitions, strict=True)
    )
    out = []
    for name, raw_value, raw_sigma in zip(names, theta, std, strict=True):
        value, sigma = float(raw_value), float(raw_sigma)
        percent = relative_std_percent(value, sigma)
        out.append(
            {
                "name": name,
                "value": json_number(value),
                "std": json_number(sigma),
                "relative_std_percent": json_number(percent),
                "identified": bool(percent <= NOT_IDENTIFIED_PERCENT),
                "definition": dict(definitions.get(name, {})),
            }
        )
    return out


def log_document(args: argparse.Namespace, log: Any) -> dict[str, Any]:
    """The ``log`` entry of the JSON format.

    ``time_offset``: the original time of the log's sample 0 [s] (epoch seconds
    of a ROS log): the results' times (``last_valid_time``, ``changes``) are on
    the re-based grid t_k = k·h, the log's own time is t + time_offset.
    """
    return {
        "path": (
            str(args.log)
            if len(getattr(args, "log_files", [0])) == 1
            else list(args.log_files)
        ),
        "samples": int(log.num_samples),
        "bad_samples": int(np.count_nonzero(log.bad_samples)),
        "time_step": float(log.time_step),
        "duration": float(log.duration),
        "time_offset": float(getattr(log, "time_offset", 0.0)),
        "warnings": list(log.warnings),
    }


def write_json(path: str, document: Mapping[str, Any]) -> None:
    """Writes ``document`` as indented JSON (no NaN: invalid JSON).

    Written whole or not at all (``files.write_text_whole``).

    Raises:
        OSError: naming ``path`` (a full disk's error names no file).
    """
    from drake_dynid.files import json_text, write_text_whole

    write_text_whole(path, json_text(document))


def matplotlib_pyplot() -> Any:
    """``matplotlib.pyplot`` with the Agg backend, or a ValueError saying how to fix."""
    try:
        import matplotlib
    except ImportError:
        raise ValueError(
            "--plot needs matplotlib, which is not installed (pip install "
            "matplotlib, or drop --plot)."
        ) from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _invalid_runs(
    t: np.ndarray, valid: np.ndarray, step: float, merge: float = 0.0
) -> Iterator[tuple[float, float]]:
    """(start, stop) time spans where ``valid`` is 0.

    Spans less than ``merge`` seconds apart are drawn as one (a decimated plot:
    thousands of runs narrower than a pixel would each be a patch).
    """
    bad = np.concatenate([[False], valid < 0.5, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(bad))
    span: tuple[float, float] | None = None
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        begin, end = float(t[start]), float(t[stop - 1] + step)
        if span is not None and begin - span[1] < merge:
            span = (span[0], end)
            continue
        if span is not None:
            yield span
        span = (begin, end)
    if span is not None:
        yield span


def bucket_extremes(
    count: int,
    read: Callable[[int, int], Sequence[np.ndarray]],
    buckets: int = PLOT_BUCKETS,
    breaks: Any = (),
) -> tuple[np.ndarray, list[np.ndarray]]:
    """The least and greatest values of runs of rows, read a block at a time.

    Rows 0 … count-1 fall in buckets of s = ⌈count / buckets⌉ consecutive rows,
    a bucket also ending before each row in ``breaks`` (the first row of a new
    segment: no bucket spans two). ``read(a, b)`` returns the arrays of rows
    [a, b), each (b - a, c_k); it is called on about ``_CSV_BLOCK`` rows at a
    time, so that a long replay's ``StoredArray`` traces are never loaded whole.
    NaN values are left out (a bucket with none is NaN).

    Returns:
        (edges, extremes): edges (B + 1,) the first row of each bucket, then
        ``count``; extremes, per array of ``read``, (B, 2, c_k) its least and
        greatest value in each bucket.
    """
    size = max(1, math.ceil(count / buckets))
    inside = [int(b) for b in breaks if 0 < b < count]
    edges = np.union1d(np.arange(0, count, size), inside).astype(np.int64)
    edges = np.append(edges, count)
    limit = max(_CSV_BLOCK, size)
    parts: list[list[np.ndarray]] = []
    i = 0
    while i < edges.size - 1:
        j = max(i + 1, int(np.searchsorted(edges, edges[i] + limit, "right")) - 1)
        a, b = int(edges[i]), int(edges[j])
        starts = edges[i:j] - a
        reduced = [
            np.stack(
                [
                    np.fmin.reduceat(x, starts, axis=0),
                    np.fmax.reduceat(x, starts, axis=0),
                ],
                axis=1,
            )
            for x in read(a, b)
        ]
        parts.append(reduced)
        i = j
    return edges, [np.concatenate(column) for column in zip(*parts, strict=True)]


def bucket_times(t: Any, edges: np.ndarray) -> np.ndarray:
    """(2B,) the first and last time of each bucket of :func:`bucket_extremes` [s].

    A stored ``t`` is read a block of rows at a time (an index array would read
    every row between its extremes at once).
    """
    rows = np.column_stack([edges[:-1], edges[1:] - 1]).ravel()
    if isinstance(t, np.ndarray):
        return np.asarray(t[rows], dtype=float).ravel()
    from drake_dynid.core.blocks import blocks

    out = np.empty(rows.size)
    for start, block in blocks(t):
        values = block.ravel()
        inside = (rows >= start) & (rows < start + values.size)
        out[inside] = values[rows[inside] - start]
    return out


def _band_rows(theta: Any, std: Any, first: int, a: int, b: int) -> list[np.ndarray]:
    """Rows [a, b) of θ, θ - σ and θ + σ as plotted.

    NaN θ before ``first`` (the first valid solve: the identifier holds zeros
    there); no band where σ is not finite.
    """
    estimates = np.array(theta[a:b], dtype=float)
    estimates[: max(0, first - a)] = np.nan
    sigmas = np.asarray(std[a:b], dtype=float)
    sigmas = np.where(np.isfinite(sigmas), sigmas, np.nan)
    return [estimates, estimates - sigmas, estimates + sigmas]


def trace_envelope(
    t: Any, theta: Any, std: Any, first: int, buckets: int = PLOT_BUCKETS
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A long trace reduced to the extremes of ``buckets`` runs of solves.

    Per bucket of :func:`bucket_extremes` and parameter i: θ's least and
    greatest value and the band's extremes min(θ - σ) and max(θ + σ) (NaN θ
    before ``first``, the first valid solve, and non-finite σ are left out).

    Returns:
        (x, line, lower, upper): x (2B,) the first and last time of each bucket
        [s]; line (2B, p) θ's least then greatest value of each bucket (at
        either end: the bucket is narrower than a pixel); lower, upper (2B, p)
        the band, equal at both ends of a bucket.
    """

    def read(a: int, b: int) -> list[np.ndarray]:
        return _band_rows(theta, std, first, a, b)

    edges, (line, low, high) = bucket_extremes(len(t), read, buckets)
    return (
        bucket_times(t, edges),
        line.reshape(-1, line.shape[2]),
        np.repeat(low[:, 0], 2, axis=0),
        np.repeat(high[:, 1], 2, axis=0),
    )


def write_plot(path: str, t: Any, theta: Any, std: Any, valid, names, title) -> None:
    """One subplot per parameter: estimate, ±σ band, invalid periods shaded.

    A trace of more than ``PLOT_BUCKETS`` solves is drawn as its envelope
    (:func:`trace_envelope`): the plot of a replay of hours costs the same time
    and memory as a minute's, and loads none of its stored traces whole.
    """
    plt = matplotlib_pyplot()
    p = len(names)
    columns = 2 if p > 4 else 1
    rows = math.ceil(p / columns)
    figure, axes = plt.subplots(
        rows, columns, sharex=True, figsize=(6.0 * columns, 1.8 * rows + 0.8)
    )
    axes = np.atleast_1d(axes).ravel()
    valid = np.asarray(valid, dtype=float)
    times = np.asarray(t, dtype=float)
    step = float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    # Nothing to show before the first valid solve (the block holds zeros).
    first = int(np.argmax(valid > 0.5))
    merge = 0.0
    if len(times) > PLOT_BUCKETS:
        x, line, lower, upper = trace_envelope(times, theta, std, first)
        merge = (times[-1] - times[0]) / PLOT_BUCKETS
    else:
        x = times
        line, lower, upper = _band_rows(theta, std, first, 0, len(times))
    spans = list(_invalid_runs(times, valid, step, merge))
    for i, name in enumerate(names):
        axis = axes[i]
        axis.plot(x, line[:, i], color="C0", lw=1.0)
        axis.fill_between(x, lower[:, i], upper[:, i], color="C0", alpha=0.25, lw=0.0)
        for start, stop in spans:
            axis.axvspan(start, stop, color="0.85", lw=0.0, zorder=0)
        axis.set_ylabel(name)
        axis.grid(True, alpha=0.3)
    finish_panels(
        figure,
        axes,
        p,
        columns,
        f"{title} (grey: invalid window, estimate held; band: ±σ)",
    )
    figure.savefig(path, dpi=100)
    plt.close(figure)


def finish_panels(figure: Any, axes: Any, count: int, columns: int, title: str) -> None:
    """Time axes and title of a grid of ``count`` panels in ``columns`` columns.

    The unused panels are hidden; the last panel of each column gets "t [s]"
    and its tick labels (sharex hides them above the last row, and with an odd
    count the right column ends a row higher); the title sits 0.1 in below the
    top and the panels below it (at its default y = 0.98 the title of a tall
    figure fell onto the first row). A title wider than the figure is wrapped
    at spaces into at most 4 lines (the fourth ending in "..." when it is
    longer), and the panels make room for them (found by a review: the TIAGo's
    two file names made one line of 1.5 figure widths, cut at both ends).
    """
    import textwrap

    for axis in axes[count:]:
        axis.set_visible(False)
    for axis in axes[max(0, count - columns) : count]:
        axis.set_xlabel("t [s]")
        axis.tick_params(labelbottom=True)
    height = figure.get_figheight()
    text = figure.suptitle(title, y=1.0 - 0.1 / height, va="top")
    renderer = figure.canvas.get_renderer()
    width = text.get_window_extent(renderer).width
    room = 0.96 * figure.get_figwidth() * figure.dpi
    lines = 1
    chars = len(title)
    while width > room and chars > 20:  # characters per line, by the width taken
        chars = max(20, min(chars - 1, int(chars * room / width)))
        wrapped = textwrap.wrap(title, chars)
        if len(wrapped) > 4:  # many log files: the first of them, then "..."
            wrapped = [*wrapped[:3], wrapped[3][: chars - 4].rstrip() + " ..."]
        text.set_text("\n".join(wrapped))
        lines = len(wrapped)
        width = text.get_window_extent(renderer).width
    line_height = text.get_fontsize() * 1.2 / 72.0  # [in]
    top = 0.4 + (lines - 1) * line_height
    figure.tight_layout(rect=(0.0, 0.0, 1.0, 1.0 - top / height))


def write_trace_outputs(
    args: Any, document: Mapping[str, Any] | None, t: np.ndarray, trace: Any, title: str
) -> None:
    """``--json`` (``document``) and ``--plot`` (the estimates of ``trace`` over t).

    Shared by ``dynid identify`` and ``dynid payload``; each file written is
    announced on stdout unless ``--quiet``.
    """
    if args.json and document is not None:
        write_json(args.json, document)
        if not args.quiet:
            print(f"wrote {args.json}")
    if args.plot:
        write_plot(
            args.plot,
            t,
            trace.theta,
            trace.std,
            trace.valid,
            trace.names,
            title,
        )
        if not args.quiet:
            print(f"wrote {args.plot}")


def write_estimates_csv(
    path: str,
    t: Any,
    valid: Any,
    theta: Any,
    names: Sequence[str],
    std: Any = None,
) -> None:
    """Writes ``t,valid,<names>[,std_<names>]``, one row per solve (``--out``).

    Rows before the first valid estimate have empty estimate and σ cells (the
    identifier holds zeros there, which are not estimates).
    """
    is_valid = np.asarray(valid, dtype=float) > 0.5
    first = int(np.argmax(is_valid)) if is_valid.any() else len(is_valid)
    columns = len(names) * (1 if std is None else 2)
    from drake_dynid.files import write_whole

    def write(stream):
        writer = csv.writer(stream)
        stds = [] if std is None else [f"std_{name}" for name in names]
        writer.writerow(["t", "valid", *names, *stds])
        # A block of rows at a time: a long replay's traces are read from their
        # temporary files (core.replay, drake_dynid.log_store).
        for a in range(0, len(t), _CSV_BLOCK):
            b = min(len(t), a + _CSV_BLOCK)
            estimates = np.asarray(theta[a:b])
            sigmas = None if std is None else np.asarray(std[a:b])
            for k in range(a, b):
                values = []
                if k >= first:
                    values = [*estimates[k - a]]
                    values += [] if sigmas is None else [*sigmas[k - a]]
                writer.writerow(
                    [
                        f"{round(float(t[k]), 9) + 0.0:.15g}",  # + 0.0: no "-0"
                        int(is_valid[k]),
                        *(f"{x:.17g}" for x in values),
                        *([""] * (columns - len(values))),
                    ]
                )

    write_whole(path, write)  # a full disk leaves no truncated file


def resampled_log_note(command: str, log: Any, reader: str | None = None) -> None:
    """Prints ``dynid COMMAND: note:`` on the log's resampled or slow-sensor joints.

    ``core.idim_auto.resampled_note`` of the longest run's
    ``core.idim_auto.resampled_joints`` (nothing when there are none): ``dynid
    offline`` and ``dynid validate`` when their cutoff is automatic, ``dynid
    identify`` when it measures the position noise or the excitation band on the
    log (``reader``: what it measured, named instead of the cutoff).
    """
    import sys

    from drake_dynid.core.idim_auto import resampled_joints, resampled_note

    found = log.on_longest_run(resampled_joints)
    note = resampled_note(found, log.joint_names, log.time_step, reader)
    if note:
        print(f"dynid {command}: note: {note}", file=sys.stderr)
