"""Change tracking for the accuracy benchmark (``bench_accuracy.py``; not a script).

Fig. 4 (paper §V): the paper's 2R arm in closed loop (Drake, 1 kHz), ZZ1R 3.9 -> 4.5
at 9.4 s (``paper.zz1_jump``), 25 s, simulated once; seed s adds white noise
(``default_rng(1000 + s)``, SNR 30 dB on every q and τ, or on τ only) to the
recorded noise-free q, τ, and the core replay (equal to the blocks:
tests/test_change.py) runs T = 7 s identifiers (solve every 50 ms) with and
without ``detect_changes`` (``core.change``, its defaults) and the paper's power
model with its ℓ set. Time to within 2 %: after the jump until ZZ1R stays within
2 % of 4.5 to the end of the run (NaN: not within 2 % at the end).

False alarms: logs without a change, simulated for 40 s on every 2R scenario of
the benchmark (``_scenarios``) with the same noise; T = 7 s, defaults; the test
is armed from the first valid window + its warm-up, except while a segment since a
detection grows. "confirmed": detections whose segment found a changed parameter
(the others are withdrawn after ``confirm`` s and cost nothing). The accuracy
cost: the median over the armed solves of the mean |error| (inertial, friction)
with and without detection, same logs. The iiwa7: the independent 60 s log of
``_accuracy_arm7`` (Drake's inverse dynamics), T = 20 s, rows chosen on the log.

Payload on the iiwa7: the same log, but from 35 s the torques are Drake's inverse
dynamics of the arm carrying 1 kg at (0.02, 0, 0.08) m in link 7's frame (a URDF
written with the compound inertia of link 7: 13 base parameters change).
Metric: the torque prediction error of the estimate on the validation trajectory
of ``_accuracy_arm7`` against the loaded arm's torques (largest joint, RMS
relative %): time after the change until it stays within 2 % (and 5 %), and its
median over the T = 20 s after the change.
"""

from __future__ import annotations

import dataclasses
import re
import tempfile
from pathlib import Path

import numpy as np

from drake_dynid import paper
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.logs import RobotLog

H = 1e-3
JUMP = 9.4
WINDOW = 7.0


def _noisy(result, seed: int, which: str) -> RobotLog:
    """The recorded noise-free log plus white noise (q and τ, or τ only)."""
    n = result.q_true.shape[1]
    e = np.random.default_rng(1000 + seed).standard_normal((len(result.t), 2 * n))
    e = e * result.noise_std
    q = result.q_true + (e[:, :n] if which == "both" else 0.0)
    tau = result.tau_true + e[:, n:]
    return RobotLog(result.t, q, tau, result.joint_names, H)


def settle_time(trace, target: float = 4.5, after: float = JUMP) -> float:
    """Seconds after ``after`` until ZZ1R stays within 2 % (NaN: not at the end)."""
    z = trace.theta[:, 0]
    bad = np.flatnonzero((trace.t >= after) & (np.abs(z - target) > 0.02 * target))
    if not len(bad):
        return 0.0
    if bad[-1] + 1 >= len(trace.t):
        return float("nan")
    return float(trace.t[bad[-1] + 1] - after)


def tracking_settings(bandwidth: float) -> dict[str, OnlineSettings]:
    plain = OnlineSettings.for_model(
        "lagrangian", window=WINDOW, bandwidth=bandwidth, update_period=0.05
    )
    return {
        "Lagrangian, sliding window": plain,
        "Lagrangian, change detection": dataclasses.replace(plain, detect_changes=True),
        "power, paper ℓ set (the paper's method)": OnlineSettings.for_model(
            "power", window=WINDOW, frequencies="paper", update_period=0.05
        ),
    }


def jump_tracking(
    robot, simulate, bandwidth: float, seeds, noises=("both", "tau")
) -> dict:
    """The Fig. 4 table: per noise case and method, times over the seeds."""
    result = simulate(duration=25.0, events=[(JUMP, paper.zz1_jump(0.6))])
    chosen = tracking_settings(bandwidth)
    rows = robot.rows_provider()
    out: dict = {}
    for which in noises:
        per = {name: [] for name in chosen}
        detections = []
        for seed in seeds:
            traces = replay_log_core(
                _noisy(result, seed, which), rows, list(chosen.values())
            )
            for name, trace in zip(chosen, traces, strict=True):
                per[name].append(settle_time(trace))
            found = traces[1].detections()
            after = [d for d in found if d["t"] >= JUMP]
            detections.append(
                {
                    "delay": after[0]["t"] - JUMP if after else float("nan"),
                    "dating_error": after[0]["change_time"] - JUMP
                    if after
                    else float("nan"),
                    "changed": after[0]["changed"] if after else None,
                    "before_jump": len(found) - len(after),
                }
            )
        out[which] = {
            "settle": {
                name: {
                    "median": float(np.median(times)),
                    "max": float(np.max(times)),
                    "runs": [float(x) for x in times],
                }
                for name, times in per.items()
            },
            "detections": detections,
        }
    return out


def _armed(trace, warmup: float) -> np.ndarray:
    """The solves at which the test is armed (module docstring)."""
    valid = np.flatnonzero(trace.valid > 0.5)
    if not valid.size:
        return np.zeros(len(trace.t), dtype=bool)
    start = trace.t[valid[0]] + warmup
    return (trace.t >= start) & (trace.tracking < 0.5)


def _errors(theta, truth) -> np.ndarray:
    e = 100 * np.abs(theta - truth) / np.abs(truth)
    return np.column_stack((e[:, :4].mean(axis=1), e[:, 4:].mean(axis=1)))


def false_alarms_2r(models, scenarios, simulate, seeds, which="both") -> dict:
    """Detections on 2R logs without a change (40 s), per scenario.

    ``which``: SNR 30 dB noise on q and τ ("both") or on τ only ("tau").
    """
    out = {}
    for label, (name, trajectory) in scenarios.items():
        robot = models[name]
        result = simulate(robot=robot, trajectory=trajectory, duration=40.0)
        plain = OnlineSettings.for_model(
            "lagrangian", window=WINDOW, update_period=0.05
        )
        tracked = dataclasses.replace(plain, detect_changes=True)
        alarms = confirmed = 0
        armed = 0.0
        cost = {"without": [], "with": []}
        for seed in seeds:
            log = _noisy(result, seed, which)
            base, trace = replay_log_core(log, robot.rows_provider(), [plain, tracked])
            found = trace.detections()
            alarms += len(found)
            confirmed += sum(bool(d["changed"]) for d in found)
            mask = _armed(trace, 2.0)
            armed += mask.sum() * 0.05
            window = trace.t >= trace.t[np.flatnonzero(trace.valid > 0.5)[0]] + 2.0
            cost["without"].append(_errors(base.theta[window], robot.base_values))
            cost["with"].append(_errors(trace.theta[window], robot.base_values))
        out[label] = {
            "noise": "SNR 30 dB" if which == "both" else "SNR 30 dB on τ only",
            "alarms": alarms,
            "confirmed": confirmed,
            "armed_s": armed,
            "per_minute": 60.0 * alarms / armed if armed else float("nan"),
            "cost": {
                key: np.median(np.vstack(value), axis=0).tolist()
                for key, value in cost.items()
            },
        }
    return out


def _arm_rows(arm, log) -> str:
    """``rows_from`` chosen on the log (``core.raw_rows.rows_from_noise``)."""
    from drake_dynid.core.raw_rows import rows_from_noise

    grid = arm.settings("raw").on_grid(H)
    return rows_from_noise(
        log.q,
        H,
        raw_window=grid.resolved("raw_window"),
        jacobi_window=grid.jacobi_window,
        bandwidth=arm.bandwidth,
    )[0]


def false_alarms_arm7(arm, seeds, levels=("encoder", "high")) -> dict:
    """Detections on the iiwa7's independent 60 s log, T = 20 s, rows chosen."""
    out = {}
    for level in levels:
        alarms = confirmed = 0
        armed = 0.0
        chosen = set()
        for seed in seeds:
            log = arm.noisy(level, seed)
            rows_from = _arm_rows(arm, log)
            chosen.add(rows_from)
            settings = dataclasses.replace(arm.settings(rows_from), detect_changes=True)
            (trace,) = replay_log_core(log, arm.robot.rows_provider(), [settings])
            found = trace.detections()
            alarms += len(found)
            confirmed += sum(bool(d["changed"]) for d in found)
            period = settings.on_grid(H).resolved("update_period")
            armed += _armed(trace, 2.0).sum() * period
        out[level] = {
            "alarms": alarms,
            "confirmed": confirmed,
            "armed_s": armed,
            "per_minute": 60.0 * alarms / armed if armed else float("nan"),
            "rows": sorted(chosen),
        }
    return out


def print_tracking(report: dict, seeds) -> None:
    """The tables of ``report`` (keys ``jump``, ``false_2r``, ``false_arm7``)."""
    if report.get("jump"):
        _print_jump(report["jump"], seeds)
    false_2r = {**report.get("false_2r", {}), **report.get("false_2r_tau", {})}
    _print_false_alarms(false_2r, report.get("false_arm7", {}))


def _print_jump(jump: dict, seeds) -> None:
    print(
        f"\n## Tracking a change: ZZ1R 3.9 -> 4.5 at {JUMP} s (paper Fig. 4, T = 7 s), "
        f"time until it stays within 2 % [s], median (worst) over {len(seeds)} "
        "noise seeds\n"
    )
    titles = {"both": "SNR 30 dB on q and τ", "tau": "SNR 30 dB on τ only"}
    print("| method | " + " | ".join(titles[w] for w in jump) + " |")
    print("|---" * (len(jump) + 1) + "|")
    for name in jump["both"]["settle"]:
        cells = [
            "{median:.2f} ({max:.2f})".format(**jump[w]["settle"][name]) for w in jump
        ]
        print(f"| {name} | " + " | ".join(cells) + " |")
    paper_row = "| paper Fig. 4 (power model, one run) | about 5 |"
    print(paper_row + " - |" * (len(jump) - 1))
    for which in jump:
        d = jump[which]["detections"]
        delay = np.array([x["delay"] for x in d])
        dating = np.array([x["dating_error"] for x in d])
        changed = [",".join(x["changed"] or ["-"]) for x in d]
        print(
            f"\n{which}: detection {np.nanmedian(delay):.2f} s after the jump "
            f"(median; {np.nanmin(delay):.2f}-{np.nanmax(delay):.2f}), dated "
            f"{np.nanmedian(dating):+.2f} s (median error), parameters found changed: "
            f"{', '.join(sorted(set(changed)))}"
        )


def _print_false_alarms(false_2r: dict, false_arm7: dict) -> None:
    print(
        "\n## False alarms without a change (T = 7 s on the 2R, 40 s logs; "
        "T = 20 s on the iiwa7, 60 s)\n"
    )
    print(
        "| log | noise | alarms (confirmed) | armed time [s] | per minute | "
        "inertial / friction error % without → with detection |"
    )
    print("|---|---|---|---|---|---|")
    for label, r in false_2r.items():
        w, d = r["cost"]["without"], r["cost"]["with"]
        print(
            f"| 2R {label} | {r['noise']} | {r['alarms']} ({r['confirmed']}) | "
            f"{r['armed_s']:.0f} | {r['per_minute']:.2f} | {w[0]:.2f} / {w[1]:.2f} "
            f"→ {d[0]:.2f} / {d[1]:.2f} |"
        )
    for level, r in false_arm7.items():
        print(
            f"| iiwa7 ({'/'.join(r['rows'])} rows) | {level} | {r['alarms']} "
            f"({r['confirmed']}) | {r['armed_s']:.0f} | {r['per_minute']:.2f} | - |"
        )


def payload_arm(directory, mass=1.0, at=(0.02, 0.0, 0.08), inertia=5e-4):
    """The iiwa7 with a point-like payload in link 7 (compound inertia), a URDF."""
    from drake_dynid.robot import RobotModel
    from drake_dynid.urdf import model_path

    text = Path(model_path("iiwa7")).read_text()
    m0, c0, i0 = 0.3, np.array([0.0, 0.0, 0.02]), np.eye(3) * 1e-3  # the URDF's
    c1, i1 = np.array(at), np.eye(3) * inertia
    m = m0 + mass
    c = (m0 * c0 + mass * c1) / m

    def shifted(inertia_c, mass_c, com):
        d = com - c
        return inertia_c + mass_c * (d @ d * np.eye(3) - np.outer(d, d))

    total = shifted(i0, m0, c0) + shifted(i1, mass, c1)
    inertial = (
        f'<inertial><origin xyz="{c[0]} {c[1]} {c[2]}" rpy="0 0 0"/>'
        f'<mass value="{m}"/><inertia ixx="{total[0, 0]}" ixy="{total[0, 1]}" '
        f'ixz="{total[0, 2]}" iyy="{total[1, 1]}" iyz="{total[1, 2]}" '
        f'izz="{total[2, 2]}"/></inertial>'
    )
    text = re.sub(
        r'(<link name="iiwa_link_7">\s*)<inertial>.*?</inertial>',
        lambda match: match.group(1) + inertial,
        text,
        flags=re.S,
    )
    path = Path(directory) / "iiwa7_payload.urdf"
    path.write_text(text)
    return RobotModel.from_urdf(path)


def _settle(t, error, after, limit):
    bad = np.flatnonzero((t >= after) & (error > limit))
    if not len(bad):
        return 0.0
    return float("nan") if bad[-1] + 1 >= len(t) else float(t[bad[-1] + 1] - after)


def payload_tracking(arm, seeds, levels=("encoder", "high"), when=35.0) -> dict:
    """The iiwa7 picking up 1 kg at ``when`` (module docstring)."""
    import _accuracy_arm7 as arm7
    from _independent import drake_torques, with_noise

    with tempfile.TemporaryDirectory() as tmp:
        heavy = payload_arm(tmp)
        log = arm.log
        start = round(when / H)
        q, v, vdot = arm7.trajectory(0).evaluate(log.t[start:])
        tau = log.tau.copy()
        tau[start:] = drake_torques(heavy, q, v, vdot)
        q, v, vdot = arm7.trajectory(1).evaluate(np.arange(0.0, 20.0, 0.01))
        check = drake_torques(heavy, q, v, vdot)
    changed = np.abs(heavy.base_values - arm.truth) > 1e-9
    loaded = RobotLog(log.t, log.q, tau, log.joint_names, H)
    scale = (check**2).mean(axis=0)

    def prediction(theta):  # (M, p) -> (M,) largest joint's RMS error [%]
        out = np.empty(len(theta))
        for index, row in enumerate(theta):
            error = arm.check_rows @ row - check
            out[index] = 100 * np.sqrt((error**2).mean(axis=0) / scale).max()
        return out

    out: dict = {"changed": int(changed.sum())}
    for level in levels:
        runs = []
        for seed in seeds:
            q_std, snr = arm7.NOISE[level]
            noisy = with_noise(
                loaded, q_std, loaded.tau.std(axis=0) * 10 ** (-snr / 20), seed
            )
            plain = arm.settings(_arm_rows(arm, noisy))
            tracked = dataclasses.replace(plain, detect_changes=True)
            traces = replay_log_core(noisy, arm.robot.rows_provider(), [plain, tracked])
            run = {}
            for name, trace in zip(("plain", "tracked"), traces, strict=True):
                error = prediction(trace.theta)
                after = (trace.t >= when) & (trace.t <= when + 20.0)
                run[name] = {
                    "settle_2": _settle(trace.t, error, when, 2.0),
                    "settle_5": _settle(trace.t, error, when, 5.0),
                    "median": float(np.median(error[after])),
                    "final": float(error[-1]),
                }
            found = [d for d in traces[1].detections() if d["t"] >= when]
            names = set(found[0]["changed"]) if found else set()
            true = {n for n, c in zip(arm.robot.names, changed, strict=True) if c}
            run["delay"] = found[0]["t"] - when if found else float("nan")
            run["found"] = len(names & true)
            run["spurious"] = len(names - true)
            runs.append(run)
        out[level] = runs
    return out


def print_payload(report: dict) -> None:
    print(
        "\n## iiwa7 picking up 1 kg at 35 s (T = 20 s, rows chosen on the log; "
        f"{report['changed']} base parameters change): torque prediction error of the "
        "estimate on the validation trajectory against the loaded arm, largest "
        "joint, median (worst) over seeds (never: not within the limit at the end "
        "of the log)\n"
    )
    print(
        "| noise | method | time to stay within 2 % [s] | within 5 % [s] | median % "
        "over the 20 s after | final % |"
    )
    print("|---|---|---|---|---|---|")
    for level, runs in report.items():
        if level == "changed":
            continue
        for name in ("plain", "tracked"):

            def cell(key, runs=runs, name=name):
                values = np.array([r[name][key] for r in runs])
                values = np.where(np.isnan(values), np.inf, values)  # never
                median, worst = np.median(values), np.max(values)
                text = "never" if np.isinf(median) else f"{median:.2f}"
                return text + (" (never)" if np.isinf(worst) else f" ({worst:.2f})")

            print(
                f"| {level} | {name} | {cell('settle_2')} | {cell('settle_5')} | "
                f"{cell('median')} | {cell('final')} |"
            )
        delay = np.array([r["delay"] for r in runs])
        print(
            f"\n{level}: detected {np.nanmedian(delay):.2f} s after the change "
            f"(median); parameters found changed: "
            f"{np.median([r['found'] for r in runs]):.0f} of {report['changed']} "
            f"(+ {np.median([r['spurious'] for r in runs]):.0f} not changed), median\n"
        )
