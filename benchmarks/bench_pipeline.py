"""Real-time factors of the on-line identification pipeline (issue 5).

Tables (medians over ``--repeats``; ratios measured side by side in one run):

1. Replay of a 1 kHz 2R log (Lagrangian model, T = 20 s): the core path
   (``drake_dynid.fast_replay.replay_log_core``) end to end in a fresh process (start,
   imports, URDF, CSV read, replay: what ``dynid identify`` does), its in-process
   time, and the Drake blocks (``diagrams.replay_log``) on a shorter log.
2. Closed loop (``diagrams.simulate_identification``, one Lagrangian identifier):
   µs per simulated step in the steady state (window full), T = 5 s and T = 40 s,
   and the plant/controller/noise floor without identifier.
3. Window independence: per-step cost at T = 40 s / T = 5 s, closed loop and
   replay.
4. 7-DOF arm (``models/iiwa7.urdf``, gravity + friction, Lagrangian model, bank
   decimated to 20 ms after the differentiator's low-pass): the Drake blocks on a
   1 kHz log, real-time factor.
5. Per block: µs per 1 kHz step and state size; the sliding integrals against a
   direct quadrature of the whole window at every bank step.
6. 7-DOF iiwa7 logs (60 s and 600 s, 1 kHz; benchmarks/_arm7.py): ``dynid offline``
   and ``dynid identify`` end to end (at 60 s also with ``--rows-from filtered``,
   with ``--bootstrap 0``, without the final σ's bootstrap, and with ``--parallel
   off``: the log read and the bootstrap in the same process instead of forked
   children beside the URDF's load and the replay), each run in a fresh process
   (start, imports, URDF, CSV, compute, JSON) with its wall and CPU time (the
   children's included) and its own peak memory, beside a Pinocchio + scipy
   off-line reference of the same algorithm (60 s); both commands on a 1-hour CSV
   log (1.08 GB, written to a temporary file; not with ``--quick``); the off-line
   API on a 1-hour log built in memory (peak memory with and without the log's own
   arrays). ``--arm-only`` runs this section alone (minutes).
7. Regressor rows of the iiwa7: one sample (the blocks' path), batches (the
   replay and off-line paths) and Pinocchio's regressor side by side (alternating
   rounds, median of the rounds' ratios), µs of CPU time per sample;
   ``--rows-only`` runs this section alone (about 15 s).
8. Window solves of the iiwa7 (``dynid identify``'s default solve: weighted,
   honest σ, jackknife; 32 consecutive windows of the 60 s log's raw rows, T = 20
   s): one ``solve_window`` per window against ``solve_windows`` of the 32
   stacked, side by side (CPU time, alternating rounds, median of the rounds'
   ratios); ``--solves-only`` runs this section alone.

The process runs with ``dynid``'s settings (``configure_process``: BLAS pools of
one thread, glibc's allocator tuned), as the ``dynid`` command does.

Logs are synthetic: a random Fourier trajectory (numpy default_rng(4), 2R; rng(5),
7-DOF) and τ from the inverse-dynamics rows with the URDF's base values, plus
white noise (default_rng(0)). Timings on a shared 2-core machine move by ±30 %.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from _arm7 import arm_log, run_case
from _timing import median_ratio, quick_or, time_call, time_side_by_side

from drake_dynid.core import modulating
from drake_dynid.core._threads import configure_process
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import (
    OnlineSettings,
    SimulationSettings,
    replay_log,
    simulate_identification,
)
from drake_dynid.fast_replay import replay_log_core
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.plants import RobotModel, model_path

_CLI_PROXY = """
import sys
from drake_dynid.diagrams import OnlineSettings
from drake_dynid.fast_replay import replay_log_core
from drake_dynid.logs import read_log
from drake_dynid.plants import RobotModel, model_path
robot = RobotModel.from_urdf(model_path("planar_2r"))
log = read_log(sys.argv[1], robot.joint_names)
traces = replay_log_core(
    log, robot.rows_provider(), [OnlineSettings(window=float(sys.argv[2]))]
)
print(traces[0].final()["valid"])
"""


def _median_time(function, repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def _synthetic_log(robot, duration: float, seed: int, velocity: float) -> RobotLog:
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=3,
        base_frequency=2 * np.pi * 0.2,
        max_velocity=velocity,
        rng=np.random.default_rng(seed),
    )
    h = 1e-3
    t = h * np.arange(round(duration / h) + 1)
    q, v, vdot = trajectory.evaluate(t)
    tau = np.einsum("nip,p->ni", robot.idim_rows(q, v, vdot), robot.base_values)
    rng = np.random.default_rng(0)
    q = q + 1e-4 * rng.normal(size=q.shape)
    tau = tau + 0.01 * tau.std(axis=0) * rng.normal(size=tau.shape)
    return RobotLog(t, q, tau, tuple(robot.joint_names), h)


def _closed_loop_step_us(robot, trajectory, settings, measure: float) -> float:
    """µs per simulated 1 ms step between t0 and t0 + measure (after the window)."""
    stamps = {}
    start = (settings[0].window + 0.3) if settings else 0.3
    events = [
        (start, lambda plant, context: stamps.__setitem__(0, time.perf_counter())),
        (
            start + measure,
            lambda plant, context: stamps.__setitem__(1, time.perf_counter()),
        ),
    ]
    simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=start + measure + 0.01),
        settings,
        events=events,
    )
    return 1e6 * (stamps[1] - stamps[0]) / (measure * 1000)


def _table(title: str, header: tuple[str, ...], rows: list[tuple]) -> str:
    lines = [f"\n### {title}\n", "| " + " | ".join(header) + " |"]
    lines.append(
        "|" + "|".join("---:" if i else "---" for i in range(len(header))) + "|"
    )
    for row in rows:
        cells = [f"{c:.3g}" if isinstance(c, float) else str(c) for c in row]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=None, help="default 3")
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    parser.add_argument(
        "--rows-only", action="store_true", help="only section 7 (a few seconds)"
    )
    parser.add_argument(
        "--solves-only", action="store_true", help="only section 8 (a few seconds)"
    )
    parser.add_argument(
        "--arm-only",
        action="store_true",
        help="only section 6 (the 7-DOF commands end to end; minutes)",
    )
    args = parser.parse_args(argv)
    configure_process()
    quick = args.quick
    repeats = quick_or(args.repeats, quick, 1, 3)
    only = {
        "arm_only": lambda r, arm: _arm_table(r, arm, repeats, quick),
        "solves_only": lambda r, arm: _solves_table(r, arm, quick),
        "rows_only": lambda r, arm: _rows_table(r, arm, repeats, quick),
    }
    for flag, section in only.items():
        if getattr(args, flag):  # one 7-DOF section alone
            results_one: dict[str, dict] = {}
            print(section(results_one, RobotModel.from_urdf(model_path("iiwa7"))))
            if args.json:
                with open(args.json, "w", encoding="utf-8") as handle:
                    json.dump(results_one, handle, indent=2)
            return 0
    window = 2.0 if quick else 20.0
    log_duration = 4.0 if quick else 60.0
    results: dict[str, dict] = {}
    out: list[str] = []

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    rows = robot.rows_provider()
    log = _synthetic_log(robot, log_duration, 4, 3.0)
    settings = [OnlineSettings(window=window)]

    # 1. Replay.
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "log.csv")
        write_log(path, log.t, log.q, log.tau, log.joint_names)
        command = [sys.executable, "-c", _CLI_PROXY, path, str(window)]
        end_to_end = _median_time(
            lambda: subprocess.run(command, check=True, capture_output=True), repeats
        )
    in_process = _median_time(lambda: replay_log_core(log, rows, settings), repeats)
    short = log_duration if quick else window + 5.0
    short_log = RobotLog(
        log.t[: round(short / 1e-3) + 1],
        log.q[: round(short / 1e-3) + 1],
        log.tau[: round(short / 1e-3) + 1],
        log.joint_names,
        1e-3,
    )
    blocks = _median_time(lambda: replay_log(short_log, rows, settings), 1)
    core_short = _median_time(
        lambda: replay_log_core(short_log, rows, settings), repeats
    )
    results["replay"] = {
        "log_s": log_duration,
        "end_to_end_s": end_to_end,
        "end_to_end_rtf": log_duration / end_to_end,
        "core_in_process_s": in_process,
        "core_rtf": log_duration / in_process,
        "blocks_rtf": short / blocks,
        "core_over_blocks_speedup": blocks / core_short,
    }
    r = results["replay"]
    out.append(
        _table(
            f"Replay, 2R, Lagrangian, T = {window:g} s, {log_duration:g} s log, 1 kHz",
            ("path", "wall [s]", "× real time"),
            [
                (
                    "core, fresh process (dynid identify proxy)",
                    end_to_end,
                    r["end_to_end_rtf"],
                ),
                ("core, in process", in_process, r["core_rtf"]),
                (f"Drake blocks ({short:g} s log)", blocks, r["blocks_rtf"]),
                (
                    "speed-up core / blocks (same log)",
                    "",
                    r["core_over_blocks_speedup"],
                ),
            ],
        )
    )

    # 2-3. Closed loop and window independence.
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )
    measure = 0.5 if quick else 8.0
    windows = (0.5, 1.0) if quick else (5.0, 40.0)
    # The same 12 modulating functions for both windows: the comparison isolates
    # the window length (with the band rule, a longer window also holds more ℓ).
    ell = np.arange(12.0)
    floor, per_window = [], {w: [] for w in windows}
    for _ in range(repeats):
        floor.append(_closed_loop_step_us(robot, trajectory, [], measure))
        for w in windows:
            per_window[w].append(
                _closed_loop_step_us(
                    robot,
                    trajectory,
                    [OnlineSettings(window=w, frequencies=ell)],
                    measure,
                )
            )
    floor_us = statistics.median(floor)
    loop = {w: statistics.median(v) for w, v in per_window.items()}
    ratio = statistics.median(
        b / a
        for a, b in zip(per_window[windows[0]], per_window[windows[1]], strict=True)
    )
    replay_cost = {}
    for w in windows:
        length = w + (1.0 if quick else 5.0)
        cut = round(length / 1e-3) + 1
        part = RobotLog(log.t[:cut], log.q[:cut], log.tau[:cut], log.joint_names, 1e-3)
        each = [OnlineSettings(window=w)]
        replay_cost[w] = (
            _median_time(lambda p=part, e=each: replay_log(p, rows, e), 1) / cut * 1e6,
            _median_time(lambda p=part, e=each: replay_log_core(p, rows, e), repeats)
            / cut
            * 1e6,
        )
    results["closed_loop"] = {
        "floor_us_per_step": floor_us,
        "us_per_step": {str(w): v for w, v in loop.items()},
        "rtf": {str(w): 1000.0 / v for w, v in loop.items()},
        "window_ratio": ratio,
        "replay_us_per_sample": {str(w): v for w, v in replay_cost.items()},
    }
    out.append(
        _table(
            "Closed loop (2R plant + IDC + friction + noise + 1 Lagrangian identifier)",
            ("case", "µs per 1 ms step", "× real time"),
            [("no identifier (floor)", floor_us, 1000.0 / floor_us)]
            + [(f"T = {w:g} s", loop[w], 1000.0 / loop[w]) for w in windows],
        )
    )
    out.append(
        _table(
            "Window independence (per step)",
            ("path", f"T = {windows[0]:g} s", f"T = {windows[1]:g} s", "ratio"),
            [
                ("closed loop [µs/step]", loop[windows[0]], loop[windows[1]], ratio),
                (
                    "replay, Drake blocks [µs/sample]",
                    replay_cost[windows[0]][0],
                    replay_cost[windows[1]][0],
                    replay_cost[windows[1]][0] / replay_cost[windows[0]][0],
                ),
                (
                    "replay, core [µs/sample]",
                    replay_cost[windows[0]][1],
                    replay_cost[windows[1]][1],
                    replay_cost[windows[1]][1] / replay_cost[windows[0]][1],
                ),
            ],
        )
    )

    # 4. 7-DOF arm through the Drake blocks.
    arm = RobotModel.from_urdf(model_path("iiwa7"))
    arm_window = 1.0 if quick else 5.0
    arm_duration = arm_window + (0.5 if quick else 3.0)
    arm_log = _synthetic_log(arm, arm_duration, 5, 1.0)
    arm_settings = [
        OnlineSettings(window=arm_window, bank_time_step=0.02, update_period=0.1)
    ]
    arm_wall = _median_time(lambda: replay_log(arm_log, arm, arm_settings), 1)
    arm_core = _median_time(
        lambda: replay_log_core(arm_log, arm, arm_settings), repeats
    )
    results["arm7"] = {
        "standard": len(arm.standard_names),
        "base": arm.num_parameters,
        "blocks_rtf": arm_duration / arm_wall,
        "core_rtf": arm_duration / arm_core,
    }
    out.append(
        _table(
            f"7-DOF iiwa7 (gravity + friction), Lagrangian, T = {arm_window:g} s, "
            "bank at 20 ms",
            ("path", "standard / base", "× real time"),
            [
                (
                    "Drake blocks",
                    f"{len(arm.standard_names)} / {arm.num_parameters}",
                    results["arm7"]["blocks_rtf"],
                ),
                ("core replay", "", results["arm7"]["core_rtf"]),
            ],
        )
    )

    # 5. Per block and sliding vs direct quadrature.
    out.append(_block_table(results, window, repeats, quick))
    # 6-7. 7-DOF logs end to end, the Pinocchio + scipy reference, rows.
    out.append(_arm_table(results, arm, repeats, quick))
    out.append(_rows_table(results, arm, repeats, quick))
    # 8. Window solves, one by one and stacked.
    out.append(_solves_table(results, arm, quick))
    text = "\n".join(out)
    print(text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as handle:
            json.dump(results, handle, indent=2)
    return 0


def _block_table(results: dict, window: float, repeats: int, quick: bool) -> str:
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    settings = OnlineSettings(window=window)
    rows_out = []
    # Jacobi block alone at 1 kHz (4 signals).
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource(np.ones(4)))
    jacobi = builder.AddSystem(
        CausalJacobiDifferentiator(
            4, 1e-3, settings.jacobi_window, kappa=1, mu=1, q=1, matched=True
        )
    )
    builder.Connect(source.get_output_port(), jacobi.get_input_port(0))
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    steps = 200 if quick else 3000

    def advance():
        simulator.AdvanceTo(simulator.get_context().get_time() + steps * 1e-3)

    jacobi_us = _median_time(advance, repeats) / steps * 1e6
    rows_out.append(
        (
            "CausalJacobiDifferentiator (4 signals)",
            jacobi_us,
            "1 ms",
            jacobi.num_signals * jacobi.filters[0].num_taps + 2,
        )
    )
    # Bank core: push, outputs, deep copy, vs direct quadrature per bank step.
    bank = settings.bank()
    channels = modulating.num_channels(2, 8)
    rng = np.random.default_rng(0)
    state = modulating.sliding_init(bank, channels)
    window_samples = rng.normal(size=(bank.num_samples, channels))
    state = modulating.sliding_push_many(bank, state, window_samples)
    sample = rng.normal(size=channels)
    count = 200 if quick else 2000
    push = (
        _median_time(
            lambda: [
                modulating.sliding_push(bank, state, sample) for _ in range(count)
            ],
            repeats,
        )
        / count
        * 1e6
    )
    deep = (
        _median_time(lambda: [copy.deepcopy(state) for _ in range(count)], repeats)
        / count
        * 1e6
    )
    integrals = (
        _median_time(lambda: modulating.sliding_fourier_integrals(bank, state), repeats)
        * 1e6
    )
    direct = (
        _median_time(
            lambda: modulating.direct_fourier_integrals(bank, window_samples), repeats
        )
        * 1e6
    )
    per_ms = bank.time_step / 1e-3
    rows_out.append(
        (
            "bank: sliding_push + 2 deep copies",
            push + 2 * deep,
            f"{bank.time_step * 1e3:g} ms",
            f"ring {bank.num_samples}×{channels} (shared chunks)",
        )
    )
    rows_out.append(
        (
            "bank: F from running sums",
            integrals,
            "per solve",
            f"K = {bank.num_frequencies}",
        )
    )
    rows_out.append(
        ("bank: F by direct quadrature of the window", direct, "per solve", "")
    )
    results["blocks"] = {
        "jacobi_us_per_step": jacobi_us,
        "bank_push_us": push,
        "bank_deepcopy_us": deep,
        "bank_us_per_ms": (push + 2 * deep) / per_ms,
        "sliding_integrals_us": integrals,
        "direct_quadrature_us": direct,
        "sliding_speedup_per_step": (direct) / (push + 2 * deep),
    }
    rows_out.append(
        (
            "speed-up sliding (push per bank step) vs direct quadrature per bank step",
            results["blocks"]["sliding_speedup_per_step"],
            "",
            "",
        )
    )
    return _table(
        f"Per block (T = {window:g} s, 2R Lagrangian, c = {channels} channels)",
        ("block", "µs per call", "period", "state"),
        rows_out,
    )


def _arm_table(results: dict, arm, repeats: int, quick: bool) -> str:
    """Section 6: dynid offline/identify on 7-DOF logs, the reference, 1 hour."""
    urdf = str(model_path("iiwa7"))
    durations = (25.0,) if quick else (60.0, 600.0)
    window = ["--window", "5"] if quick else []
    cases: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as folder:
        for duration in durations:
            log = os.path.join(folder, f"arm{duration:g}.csv")
            arm_log(arm, duration, log)
            count = repeats if duration <= 60.0 else 1
            variants = [("offline", []), ("identify", [])]
            if duration == durations[0]:  # the rows chosen on the log are raw here
                variants.append(("identify", ["--rows-from", "filtered"]))
                variants.append(("identify", ["--bootstrap", "0"]))
                variants.append(("identify", ["--parallel", "off"]))
            for command, extra in variants:
                json_path = os.path.join(folder, f"{command}{duration:g}.json")
                argv = [command, log, "--urdf", urdf, "--json", json_path, "--quiet"]
                argv += (window if command == "identify" else []) + extra
                if duration == durations[0]:
                    run_case({"kind": "cli", "argv": argv})  # warm-up: bytecode, cache
                runs = [run_case({"kind": "cli", "argv": argv}) for _ in range(count)]
                with open(json_path, encoding="utf-8") as stream:
                    document = json.load(stream)
                label = command + {
                    "--rows-from": " filtered rows",
                    "--bootstrap": " --bootstrap 0",
                    "--parallel": " --parallel off",
                }.get(extra[0] if extra else "", "")
                cases[f"{label} {duration:g} s"] = {
                    "duration": duration,
                    "wall": statistics.median(r["wall"] for r in runs),
                    "seconds": statistics.median(r["seconds"] for r in runs),
                    "cpu": statistics.median(r["cpu"] for r in runs),
                    "peak_mb": max(r["peak_mb"] for r in runs),
                    "children_peak_mb": max(r["children_peak_mb"] for r in runs),
                    "valid": bool(document["valid"]),
                }
                if command == "offline" and duration == durations[0]:
                    settings = document["settings"]
                    reference = {
                        "path": log,
                        "urdf": urdf,
                        **{
                            key: settings[key]
                            for key in (
                                "cutoff_hz",
                                "decimation_cutoff_hz",
                                "decimation",
                                "trim",
                            )
                        },
                    }
                    offline_residual = document["residual_std"]
            runs = []
            if duration == durations[0]:
                runs = [
                    run_case({"kind": "reference", "args": reference})
                    for _ in range(count)
                ]
                cases[f"reference {duration:g} s"] = {
                    "duration": duration,
                    "wall": statistics.median(r["wall"] for r in runs),
                    "seconds": statistics.median(r["seconds"] for r in runs),
                    "cpu": statistics.median(r["cpu"] for r in runs),
                    "peak_mb": max(r["peak_mb"] for r in runs),
                    "children_peak_mb": max(r["children_peak_mb"] for r in runs),
                    "rows_seconds": statistics.median(r["rows_seconds"] for r in runs),
                    "residual_std": runs[0]["residual_std"],
                    "offline_residual_std": offline_residual,
                }
        if not quick:
            cases.update(_hour_csv_cases(arm, urdf, folder))
    hour = None
    if not quick:
        hour = {
            step: run_case({"kind": "api", "duration": 3600.0, "step": step})
            for step in ("offline", "identify")
        }
    first, last = durations[0], durations[-1]
    ratios = {
        "offline_over_reference": cases[f"offline {first:g} s"]["wall"]
        / cases[f"reference {first:g} s"]["wall"],
    }
    for command in ("offline", "identify"):
        for key in ("wall", "seconds"):
            ratios[f"{command}_cost_ratio_{key}"] = (
                cases[f"{command} {last:g} s"][key]
                / cases[f"{command} {first:g} s"][key]
            )
    results["arm7_pipeline"] = {"cases": cases, "ratios": ratios, "hour": hour}
    rows = [
        (
            name,
            case["wall"],
            case["duration"] / case["wall"],
            case["seconds"],
            case["cpu"],
            case["peak_mb"],
            case["children_peak_mb"] if case["children_peak_mb"] > 0 else "",
        )
        for name, case in cases.items()
    ]
    text = _table(
        "7-DOF iiwa7 logs, 1 kHz, end to end in a fresh process (median of "
        f"{repeats} at {first:g} s; CPU: the process and its forked children, "
        "the log read and the bootstrap)",
        (
            "case",
            "wall [s]",
            "× real time",
            "in process [s]",
            "CPU [s]",
            "peak memory [MB]",
            "child's peak [MB]",
        ),
        rows,
    )
    lines = [
        text,
        "",
        f"- offline / Pinocchio + scipy reference ({first:g} s, wall): "
        f"{ratios['offline_over_reference']:.3g}",
        f"- cost({last:g} s)/cost({first:g} s): offline "
        f"{ratios['offline_cost_ratio_wall']:.3g} wall, "
        f"{ratios['offline_cost_ratio_seconds']:.3g} in process; identify "
        f"{ratios['identify_cost_ratio_wall']:.3g} wall, "
        f"{ratios['identify_cost_ratio_seconds']:.3g} in process",
    ]
    if hour is not None:
        for step, case in hour.items():
            lines.append(
                f"- {step}, 1-hour log in memory ({case['log_mb']:.0f} MB of arrays), "
                f"API: {case['step_seconds']:.3g} s "
                f"({3600.0 / case['step_seconds']:.0f}× real time); peak "
                f"{case.get('step_peak_mb', float('nan')):.0f} MB resident, "
                f"{case.get('working_mb', float('nan')):.0f} MB above the process "
                "holding its log"
            )
    return "\n".join(lines)


def _hour_csv_cases(arm, urdf: str, folder: str) -> dict[str, dict]:
    """``dynid offline`` and ``identify`` on a 1-hour 7-DOF CSV log (1.08 GB).

    The log (3.6 M samples, ``_arm7.arm_log``) is written to the temporary
    folder; each command runs once in a fresh process, its peak memory the
    process's high-water mark (``_arm7.run_case``). The reader keeps the log's
    arrays in temporary files (``drake_dynid.log_store``), so the peak does not
    hold the log.
    """
    path = os.path.join(folder, "arm3600.csv")
    start = time.perf_counter()
    arm_log(arm, 3600.0, path)
    written = time.perf_counter() - start
    size = os.path.getsize(path) / 1e6
    cases = {}
    for command in ("offline", "identify"):
        json_path = os.path.join(folder, f"{command}3600.json")
        argv = [command, path, "--urdf", urdf, "--json", json_path, "--quiet"]
        run = run_case({"kind": "cli", "argv": argv})
        with open(json_path, encoding="utf-8") as stream:
            valid = bool(json.load(stream)["valid"])
        cases[f"{command} 3600 s (CSV, {size:.0f} MB)"] = {
            "duration": 3600.0,
            "wall": run["wall"],
            "seconds": run["seconds"],
            "cpu": run["cpu"],
            "peak_mb": run["peak_mb"],
            "children_peak_mb": run["children_peak_mb"],
            "valid": valid,
            "csv_mb": size,
            "csv_write_seconds": written,
        }
    os.remove(path)
    return cases


def _rows_table(results: dict, arm, repeats: int, quick: bool) -> str:
    """Section 7: µs per sample of the iiwa7 rows, one sample and batches.

    Times are the process's CPU time (BLAS pinned to one thread, so CPU time is the
    compute time, without the waits for a core of a shared machine). The batch
    inverse-dynamics rows and Pinocchio's regressor (a Python loop over the
    samples, as a user would call it) run side by side: alternating, in rounds of
    at least 20 ms each, the ratio being the median of the rounds' ratios
    (``_timing.time_side_by_side``).
    """
    from drake_dynid.core.rows import pack_rows

    rng = np.random.default_rng(3)
    n = arm.num_joints
    q, v, tau = rng.normal(size=(3, n))
    batch = 256
    Q, V, A = rng.normal(size=(3, batch, n))
    minimum = 0.05 if quick else 0.5
    cpu = time.process_time
    rows = {
        "one sample, Lagrangian (ModelRows: packed_rows)": time_call(
            lambda: arm.packed_rows("lagrangian", q, v, tau), repeats, minimum, cpu
        ),
        "one sample, power (ModelRows: packed_rows)": time_call(
            lambda: arm.packed_rows("power", q, v, tau), repeats, minimum, cpu
        ),
        "one sample, batch code with N = 1 (model_rows)": time_call(
            lambda: pack_rows(*arm.model_rows("lagrangian", q, v, tau)),
            repeats,
            minimum,
            cpu,
        ),
        f"batch of {batch}, Lagrangian model_rows, per sample": time_call(
            lambda: arm.model_rows("lagrangian", Q, V, A), repeats, minimum, cpu
        )
        / batch,
    }
    try:
        import pinocchio as pin
    except ImportError:  # a test-only oracle
        pin = None
    ratios = {}
    rounds, each = (1, 0.0) if quick else (max(repeats, 21), 0.02)
    for size in (batch, 1000):
        Qs, Vs, As = rng.normal(size=(3, size, n))
        functions = {"ours": lambda Q=Qs, V=Vs, A=As: arm.idim_rows(Q, V, A)}
        if pin is not None:
            model = pin.buildModelFromUrdf(str(model_path("iiwa7")))
            data = model.createData()

            def pinocchio_rows(Q=Qs, V=Vs, A=As, size=size, model=model, data=data):
                for k in range(size):
                    pin.computeJointTorqueRegressor(model, data, Q[k], V[k], A[k])

            functions["pinocchio"] = pinocchio_rows
        samples = time_side_by_side(functions, rounds, each, cpu)
        rows[f"batch of {size}, inverse-dynamics idim_rows, per sample"] = (
            statistics.median(samples["ours"]) / size
        )
        if pin is not None:
            rows[
                f"batch of {size}: Pinocchio computeJointTorqueRegressor, per sample "
                "(Python loop), side by side"
            ] = statistics.median(samples["pinocchio"]) / size
            ratios[size] = median_ratio(samples, "ours", "pinocchio")
    table = [(name, 1e6 * value) for name, value in rows.items()]
    results["rows"] = {name: 1e6 * value for name, value in rows.items()}
    for size, ratio in ratios.items():
        key = "idim_batch_over_pinocchio" + ("" if size == batch else f"_{size}")
        results["rows"][key] = ratio
        label = f"batch idim_rows / Pinocchio, batches of {size} (median of rounds)"
        table.append((label, ratio))
    return _table(
        f"Regressor rows, iiwa7 ({arm.num_parameters} base parameters)",
        ("rows", "µs per sample (CPU time)"),
        table,
    )


def _solves_table(results: dict, arm, quick: bool) -> str:
    """Section 8: µs of CPU time per window solve, one by one and stacked."""
    from _arm7 import arm_samples

    from drake_dynid.core.replay import window_bank_samples, window_equations
    from drake_dynid.core.weighted_lsq import solve_window, solve_windows

    duration, window, count = (12.0, 4.0, 8) if quick else (60.0, 20.0, 32)
    t, q, tau = arm_samples(arm, duration)
    h = float(t[1] - t[0])
    rows = arm.rows_provider()
    n, p = arm.num_joints, arm.num_parameters
    settings = OnlineSettings(window=window, rows_from="raw").for_robot(h, n, p)
    m = settings.num_equations(n)
    solve = dict(
        weighting=settings.row_weighting(m),
        max_condition=settings.max_condition,
        names=rows.names,
        noise=settings.row_noise(m),
        jackknife=settings.jackknife_groups(m),
    )
    last = t.size - 1
    last -= last % settings.decimation(h)
    step = settings.solve_decimation(h)
    ends = [last - k * step for k in range(count)][::-1]
    first = window_bank_samples(settings, h, ends[0])[0]
    assert first > settings.raw_design(h).history, "the windows must be full"
    systems = [window_equations(rows, settings, q, tau, end, h) for end in ends]
    A = np.stack([a for a, _ in systems])
    B = np.stack([b for _, b in systems])
    assert all(r.valid for r in solve_windows(A, B, **solve))
    samples = time_side_by_side(
        {
            "one by one": lambda: [solve_window(a, b, **solve) for a, b in systems],
            "stacked": lambda: solve_windows(A, B, **solve),
        },
        rounds=3 if quick else 11,
        min_time=0.05 if quick else 0.3,
        clock=time.process_time,
    )
    per_window = {
        name: 1e6 * statistics.median(values) / count
        for name, values in samples.items()
    }
    ratio = median_ratio(samples, "one by one", "stacked")
    results["solves"] = {
        "windows": count,
        "rows": int(A.shape[1]),
        "parameters": int(A.shape[2]),
        "one_by_one_us": per_window["one by one"],
        "stacked_us": per_window["stacked"],
        "speed_up": ratio,
    }
    return _table(
        f"Window solves, iiwa7 ({A.shape[1]} rows × {A.shape[2]} parameters, "
        f"{count} windows, CPU time)",
        ("solve", "µs per window"),
        [
            ("solve_window, one per window", per_window["one by one"]),
            ("solve_windows, stacked", per_window["stacked"]),
            ("speed-up (median of the rounds' ratios)", ratio),
        ],
    )


if __name__ == "__main__":
    raise SystemExit(main())
