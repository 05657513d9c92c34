"""The off-line automatic position cutoff: the former rule against the current one.

``core.idim_auto.auto_cutoff`` chooses f_c minimising each joint's expected
squared acceleration error, the filter's droop on the measured motion plus the
noise it passes (docs/MATH.md §5). The former rule, ``min(max(f_x, 2·f_99), 40 Hz,
fs/5)`` (f_x: 20 dB above the noise floor; f_99: 99 % of the floor-corrected
power), is :func:`former_cutoff` here. Side by side:

* ``paper``: the 2R scenarios of ``bench_accuracy.py`` at SNR 30 dB (the paper's
  arm and trajectory first; 21 s in closed loop), its off-line rows
  (``identify_offline`` IDIM-LS and IDIM-WLS, each seed's noise): the mean over
  the inertial and over the friction parameters of the median |relative error|
  over seeds [%], with the bootstrap spread of that median (200 resamplings of
  the seeds), the cutoffs chosen, and IDIM-LS on the noise-free closed-loop log;
* ``logs``: simulated logs with their truth (``dynid simulate``'s LOG.truth.json):
  ``dynid offline`` run once with ``--cutoff`` at the former rule's value and once
  automatic; χ² = eᵀC⁻¹e of the errors against the reported covariance, the
  largest |error|/σ (its name) and, with ``--show NAME``, that parameter's error;
* ``held-out``: ``dynid offline ... --split F`` (a real recording, the README's
  TIAGo): the held-out "all joints" torque error (every sample, and while moving)
  for each estimate (cutoff), under both rules' validation filters.

Run (from the repository root; each part well under 3 min on one core):
``python benchmarks/bench_cutoff.py paper [--seeds 40]``;
``python benchmarks/bench_cutoff.py logs LOG.csv ... --truth T.json -- OFFLINE_ARGS``
(``--truth`` defaults to each LOG's own ``.truth.json``);
``python benchmarks/bench_cutoff.py held-out LOG.csv [EFFORTS.csv] -- OFFLINE_ARGS``.
``--quick`` runs ``paper`` on 4 seeds, the paper's scenario only; ``--json F``
writes what it prints.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from drake_dynid.core import idim_auto

FORMER_POWER_SHARE = 0.99


def former_cutoff(q: Any, time_step: float) -> float:
    """The former rule: ``min(max(f_x, 2·f_99), 40 Hz, fs/5)`` [Hz] (Welch spectra)."""
    fs, f, power = idim_auto._position_spectra("former_cutoff", q, time_step)
    resolution = float(f[1])
    crossover = bandwidth = resolution
    for j in range(power.shape[1]):
        spectrum = power[:, j]
        floor = float(np.median(spectrum[f >= 0.25 * fs]))
        above = np.flatnonzero(spectrum > 100.0 * floor)
        if above.size == 0:
            continue
        top = int(above[-1])
        crossover = max(crossover, float(f[top]))
        excess = np.clip(spectrum[: top + 1] - floor, 0.0, None)
        if excess.sum() > 0.0:
            share = np.cumsum(excess) / excess.sum()
            bandwidth = max(bandwidth, float(f[np.argmax(share >= FORMER_POWER_SHARE)]))
    cutoff = min(
        max(crossover, 2.0 * bandwidth), idim_auto.MAX_AUTO_CUTOFF_HZ, 0.2 * fs
    )
    return float(max(cutoff, resolution))


RULES = {"former": former_cutoff, "current": idim_auto.auto_cutoff}


# ------------------------------------------------------------------- paper 2R


def paper(seeds: int, quick: bool) -> dict:
    import bench_accuracy as acc
    from _scenarios import scenarios

    report: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        models = acc.robots(Path(tmp))
        print(
            f"## 2R scenarios of bench_accuracy.py, SNR 30 dB, {seeds} seeds: median "
            "|error| % (± bootstrap spread of the median); last column noise-free\n"
        )
        print(
            "| scenario | rule | cutoff [Hz] | IDIM-LS inertial / friction "
            "| IDIM-WLS inertial / friction | noise-free IDIM-LS |"
        )
        print("|---|---|---|---|---|---|")
        for label, (name, trajectory) in scenarios(quick).items():
            robot = models[name]
            run = acc.simulate(robot, trajectory)
            for rule, function in RULES.items():
                row = _scenario(acc, robot, run, function, seeds)
                report[f"{label}|{rule}"] = row
                low, high = row["cutoffs"]
                band = f"{low:.3g}" if low == high else f"{low:.3g}-{high:.3g}"
                cells = [
                    "{0[0]:.2f} ± {0[1]:.2f} / {1[0]:.2f} ± {1[1]:.2f}".format(
                        row[f"{kind}_inertial"], row[f"{kind}_friction"]
                    )
                    for kind in ("ls", "wls")
                ]
                clean = "{:.3f} / {:.3f} ({:.3g} Hz)".format(*row["noise_free"])
                print(
                    f"| {label} | {rule} | {band} | "
                    + " | ".join(cells)
                    + f" | {clean} |"
                )
    return report


def _scenario(acc: Any, robot: Any, run: Any, rule: Any, seeds: int) -> dict:
    """One scenario's off-line rows (``bench_accuracy.offline``) with ``rule``."""
    from drake_dynid.logs import RobotLog
    from drake_dynid.offline import identify_offline

    truth = np.asarray(robot.base_values)

    def fit(q: np.ndarray, tau: np.ndarray, weighted: bool, fc: float) -> np.ndarray:
        log = RobotLog(
            acc.H * np.arange(len(q)), q, tau, tuple(robot.joint_names), acc.H
        )
        res = identify_offline(log, robot, weighted=weighted, cutoff_hz=fc)
        return res.theta if res.valid else np.full(truth.size, np.nan)

    row: dict = {}
    cutoffs = []
    estimates: dict[bool, list] = {False: [], True: []}
    for seed in range(seeds):
        q, tau = acc.noisy(run.q_true, run.tau_true, run.noise_std, seed)
        fc = rule(q, acc.H)
        cutoffs.append(fc)
        for weighted in (False, True):
            estimates[weighted].append(fit(q, tau, weighted, fc))
    for weighted in (False, True):
        err = np.abs(100 * (np.asarray(estimates[weighted]) - truth) / truth)
        kind = "wls" if weighted else "ls"
        row[f"{kind}_inertial"] = _median_and_spread(err[:, :4])
        row[f"{kind}_friction"] = _median_and_spread(err[:, 4:])
    row["cutoffs"] = (min(cutoffs), max(cutoffs))
    fc = rule(run.q_true, acc.H)
    clean = np.abs(100 * (fit(run.q_true, run.tau_true, False, fc) - truth) / truth)
    row["noise_free"] = (float(clean[:4].mean()), float(clean[4:].mean()), fc)
    return row


def _median_and_spread(err: np.ndarray) -> tuple[float, float]:
    """Mean over the columns of the median over seeds, and its bootstrap std."""
    rng = np.random.default_rng(0)
    value = float(np.nanmedian(err, axis=0).mean())
    boot = [
        float(np.nanmedian(err[rng.integers(0, len(err), len(err))], axis=0).mean())
        for _ in range(200)
    ]
    return value, float(np.std(boot))


# ---------------------------------------------------------------- simulated logs


def _offline(argv: list[str]) -> str:
    from drake_dynid import cli

    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = cli.main(argv)
    if code != 0:
        raise SystemExit(f"dynid {' '.join(argv)} failed ({code})")
    return out.getvalue()


def _read(path: str) -> Any:
    from drake_dynid.logs import header_joints, read_log

    return read_log(path, header_joints(path))


def logs(
    paths: list[str], truth: str | None, extra: list[str], show: str | None
) -> dict:
    report: dict = {}
    print(
        "| log | rule | cutoff [Hz] | χ² (of p) | max |err|/σ (name) |"
        + (f" {show} err / σ |" if show else "")
    )
    print("|---|---|---|---|---|" + ("---|" if show else ""))
    with tempfile.TemporaryDirectory() as tmp:
        for path in paths:
            fc_former = former_cutoff(_read(path).q, _read(path).time_step)
            truth_path = truth or str(Path(path).with_suffix("")) + ".truth.json"
            true = {
                p["name"]: p["value"]
                for p in json.loads(Path(truth_path).read_text())["parameters"]
            }
            for name, given in (
                ("former", ["--cutoff", repr(fc_former)]),
                ("current", []),
            ):
                out = Path(tmp) / "fit.json"
                _offline(["offline", path, *extra, *given, "--json", str(out)])
                fit = json.loads(out.read_text())
                names = [p["name"] for p in fit["parameters"]]
                err = np.array(
                    [
                        p["value"] - true[n]
                        for p, n in zip(fit["parameters"], names, strict=True)
                    ]
                )
                cov = np.asarray(fit["covariance"])
                std = np.sqrt(np.diag(cov))
                chi2 = float(err @ np.linalg.solve(cov, err))
                ident = np.array(
                    [bool(p.get("identified", True)) for p in fit["parameters"]]
                )
                z = np.where(ident, np.abs(err) / std, 0.0)
                k = int(np.argmax(z))
                cell = ""
                if show:
                    i = names.index(show)
                    rel, z_i = 100 * err[i] / true[show], err[i] / std[i]
                    cell = f" {rel:+.2f} % / {z_i:+.2f} |"
                fc = fit["settings"]["cutoff_hz"]
                print(
                    f"| {Path(path).name} | {name} | {fc:.3g} | {chi2:.0f} "
                    f"({len(err)}) | {z[k]:.2f} ({names[k]}) |{cell}"
                )
                report[f"{path}|{name}"] = {
                    "cutoff_hz": fc,
                    "chi2": chi2,
                    "max_z": float(z[k]),
                    "max_z_name": names[k],
                }
    return report


# --------------------------------------------------------------- held-out torques


def held_out(paths: list[str], extra: list[str]) -> dict:
    """Held-out errors, each rule for the fit crossed with each for the check.

    A given ``--cutoff`` would set both filters: the rules are swapped in instead.
    """
    import drake_dynid.offline as offline
    import drake_dynid.validation as validation

    report: dict = {}
    print(
        "| fit's rule (cutoff) | validation's rule (cutoff) | held-out error % "
        "| moving % |"
    )
    print("|---|---|---|---|")
    for fit_rule, fit_function in RULES.items():
        for check_rule, check_function in RULES.items():
            offline.auto_cutoff = fit_function
            validation.auto_cutoff = check_function
            try:
                text = _offline(["offline", *paths, *extra])
            finally:
                offline.auto_cutoff = validation.auto_cutoff = idim_auto.auto_cutoff
            fc = float(text.split("; cutoff ", 1)[1].split(" Hz", 1)[0])
            fv = float(text.split("positions filtered at ", 1)[1].split(" Hz", 1)[0])
            line = next(x for x in text.splitlines() if x.startswith("all joints"))
            total, moving = (float(x) for x in line.split()[2:4])
            print(
                f"| {fit_rule} ({fc:.4g} Hz) | {check_rule} ({fv:.4g} Hz) "
                f"| {total} | {moving} |"
            )
            report[f"{fit_rule}|{check_rule}"] = [fc, fv, total, moving]
    return report


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    extra: list[str] = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1 :]
        argv = argv[: argv.index("--")]
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "part", nargs="?", default="paper", choices=["paper", "logs", "held-out"]
    )
    parser.add_argument("paths", nargs="*")
    parser.add_argument("--seeds", type=int, default=None)
    parser.add_argument("--truth", default=None)
    parser.add_argument("--show", default=None)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    if args.part == "paper":
        seeds = args.seeds if args.seeds is not None else (4 if args.quick else 40)
        report = paper(seeds, args.quick)
    elif args.part == "logs":
        report = logs(args.paths, args.truth, extra, args.show)
    else:
        report = held_out(args.paths, extra)
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
