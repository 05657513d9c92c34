"""Accuracy of on-line (power, Lagrangian) and off-line (IDIM) identification.

``--robot 2r`` (the paper's arm, below), ``--robot iiwa7`` (a 7-DOF arm on
independent logs: benchmarks/_accuracy_arm7.py) or both (default).

Set-up (paper §V): ``simulate_identification`` on the paper's 2R arm
(``model_path("planar_2r")``, L1 = 1 m), discrete plant at 1 kHz, inverse-dynamics
tracking, SNR 30 dB white noise on every q and τ channel (SNR = 10 log10(var(x)/σ²),
var of the noise-free reference), duration T + 1 = 21 s, window T = 20 s. The
estimate is the one of the last full window (ending at the last sample).

Main trajectory: ``drake_dynid.paper.paper_trajectory()`` (finite Fourier series,
period 40 s, harmonics 4..24, i.e. 0.1-0.6 Hz, coefficients N(0,1)/√l from
default_rng(2014), each joint scaled to max |q̇_j| = 5 rad/s).

Seeds: the controller uses the true state, so the measurement noise never enters the
loop: every scenario is simulated once (``simulate_identification``, seed 0) and seed s
adds ``noise_std · N(0, 1)`` from ``np.random.default_rng(1000 + s)`` to the recorded
noise-free q, τ (also used for the noise-only / bias-only error budget).

On-line estimates: the numerical core of the blocks, batch
(``core.replay.filtered_signals``: matched Jacobi over the whole log;
``core.replay.window_equations``: model rows of the decimated samples of the last
window, trapezoid Fourier integrals; ``core.weighted_lsq.solve_window``, the
identifier's solve: frequency-weighted by default, "OLS" rows without; σ the larger
of the sandwich σ and the jackknife's; rows of the filtered signals by default, "raw
rows" ``rows_from="raw"``, "auto" the rows ``core.raw_rows.rows_from_noise``
chooses on each noisy log). Checked once against
the Drake blocks in the loop (first
table line): same window, the blocks' own noise, relative difference ~1e-12. Off-line:
``drake_dynid.offline.identify_offline`` (IDIM-LS and IDIM-WLS, automatic cutoffs and
decimation). Medians over seeds (40 by default: with 10 the median friction error moves
by a few points from one seed set to the next) of the relative error [%] per
parameter; "inertial" / "friction" are the means of the 4 medians of |error|.

Other scenarios: two more 2R geometries (URDFs generated in a temp dir from
planar_2r.urdf: ``g1`` L1 = 0.7 m, heavy link 2, strong friction; ``g2`` L1 = 1.3 m,
light link 2, weak friction) and ``random_fourier_trajectory`` (H = 5, ω_f = 2π·0.1,
|q̇| ≤ 4 rad/s, default_rng(1|2|3)), plus a wide-band one (H = 4, ω_f = 2π·0.25,
|q̇| ≤ 4, default_rng(5): 0.25-1 Hz). The default settings are the same everywhere:
the ℓ set comes from ``estimate_bandwidth`` of the measured q.

Power model: the library defaults (ℓ set to twice the band, ``core.ell_rule``),
"dynid identify" (rows chosen and σ_q measured on each log, the rows' noise bias
compensated: ``OnlineSettings.position_noise``), "ℓ to B (before)" (the band
alone, as before issue 16); benchmarks/_accuracy_power.py: the rows' bias, the
estimates' bias vs spread and the best linear weighting on the main scenario
(``--power-seeds``, 200).

Uncertainty: |error|/σ over the 8 parameters and the seeds (p90 = 1.64 for a
Gaussian error with an honest σ). Noise-free bias on exact logs: the trajectory
evaluated (no simulation) and Drake's inverse dynamics + Coulomb sign
(``_independent.exact_log``), which separates the identifier's bias from the
simulated plant's time discretisation (the closed loop's noise-free column).

ZZ1R jump (paper Fig. 4) and false alarms of the change detection
(``OnlineSettings.detect_changes``): benchmarks/_change.py; how soon ZZ1R can be
within 2 % at all (Cramér-Rao bound, estimators told the change time, a step test
in place of the CUSUM): benchmarks/_change_floor.py.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path

import _change
import _change_floor
import numpy as np
from _independent import exact_log, honesty, window_solves
from _scenarios import _rf, robots, scenarios
from _timing import quick_or

from drake_dynid import paper
from drake_dynid.core.ell_rule import POWER_BAND_FACTOR
from drake_dynid.core.excitation import (
    estimate_bandwidth,
    position_noise_std,
    torque_noise_std,
)
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.raw_rows import rows_from_noise
from drake_dynid.core.replay import (
    filtered_signals,
    window_covariance_at,
    window_equations,
)
from drake_dynid.logs import RobotLog
from drake_dynid.offline import identify_offline
from drake_dynid.simulation import SimulationSettings, simulate_identification

H = 1e-3
T = 20.0
# The library's per-model defaults (drake_dynid.core.online.MODEL_DEFAULTS).
LAGRANGIAN = dict(model="lagrangian")
POWER = dict(model="power")
PAPER_ONLINE_ERR = 100 * (paper.TABLE2_ONLINE - paper.TRUE_VALUES) / paper.TRUE_VALUES
PAPER_OFFLINE_ERR = 100 * (paper.TABLE2_OFFLINE - paper.TRUE_VALUES) / paper.TRUE_VALUES


def settings_for(
    kind: dict, window: float, bandwidth: float, **extra
) -> OnlineSettings:
    """The library defaults with the measured band.

    The default ℓ set covers the band with integer ℓ, at least 8 of them
    (``band_frequencies``: 2·8 rows per equation: the power model has one equation
    per ℓ for p = 8 parameters; with T = 7 s the band alone gives only 4).
    """
    options = {**kind, **extra}
    return OnlineSettings.for_model(
        options.pop("model"), window=window, bandwidth=bandwidth, **options
    )


# ------------------------------------------------------------------ estimators


def filtered(q, tau, s: OnlineSettings):
    """Matched Jacobi (orders 0, 1) over the whole log, as the differentiator block."""
    return filtered_signals(q, tau, s, H)


def online(rows, s: OnlineSettings, signals, end: int, q=None, tau=None):
    """θ̂ of the core's solve of one window (:func:`online_full`)."""
    return online_full(rows, s, signals, end, q, tau)[0]


def online_full(rows, s: OnlineSettings, signals, end: int, q=None, tau=None):
    """``(θ̂, σ, σ_Gautier, σ_sandwich)`` of the core's solve of the window at ``end``.

    Filtered rows: the differentiator's outputs ``signals`` (computed from ``q``,
    ``tau`` when None); raw rows: the rows of ``q``, ``tau`` (``core.raw_rows``).
    σ is the settings' (by default the larger of the sandwich σ and the
    jackknife's; ``_independent.window_solves``).
    """
    s = s.for_robot(H, int(rows.num_joints), int(rows.num_parameters))
    a, b = window_equations(rows, s, q, tau, end, H, signals=signals)
    m = s.num_equations(int(rows.num_joints))
    covariance = window_covariance_at(rows, s, q, tau, end, H, signals=signals)
    theta, (std, gautier, sandwich) = window_solves(
        a, b, s, m, rows.names, covariance=covariance
    )
    return theta, std, gautier, sandwich


def auto_rows(s: OnlineSettings, q) -> str:
    """``rows_from`` chosen on the log (``core.raw_rows.rows_from_noise``)."""
    grid = s.on_grid(H)
    return rows_from_noise(
        q,
        H,
        raw_window=grid.resolved("raw_window"),
        jacobi_window=grid.jacobi_window,
        bandwidth=grid.bandwidth,
    )[0]


#: The method whose final σ also gets ``dynid identify``'s parametric bootstrap.
BOOTSTRAPPED = "on-line Lagrangian, rows from the log (auto)"


def bootstrap(rows, s: OnlineSettings, q, tau, end: int) -> np.ndarray:
    """σ_B of the window at ``end``, as ``dynid identify``'s final σ.

    ``core.bootstrap.bootstrap_std`` with its defaults (16 replicates, seed 0) and
    the noise measured on the log (NaN when it is not valid).
    """
    from drake_dynid.core.bootstrap import bootstrap_std

    noise = (position_noise_std(q, H), torque_noise_std(tau, H))
    return bootstrap_std(rows, s, q, tau, end, H, noise).std


def measured_noise(q) -> tuple[float, ...]:
    """σ_q per joint measured on the log, as ``dynid identify``."""
    return tuple(position_noise_std(q, H).tolist())


def measured_torque_noise(tau) -> tuple[float, ...]:
    """σ_τ per joint measured on the log, as ``dynid identify``."""
    return tuple(torque_noise_std(tau, H).tolist())


def as_run(name: str, s: OnlineSettings, q, tau) -> OnlineSettings:
    """The settings of method ``name`` on one noisy log, as ``dynid identify``.

    "covariance": the covariance weighting with σ_q, σ_τ measured on the log and
    the filtered rows (the power model's ``dynid identify`` default); "(auto)" or
    "dynid identify": the rows chosen on the log, and for the power model σ_q
    measured (the noise-bias compensation).
    """
    if "covariance" in name:
        return dataclasses.replace(
            s,
            weighting="covariance",
            rows_from="filtered",
            position_noise=measured_noise(q),
            torque_noise=measured_torque_noise(tau),
        )
    if name.endswith("(auto)") or "dynid identify" in name:
        s = dataclasses.replace(s, rows_from=auto_rows(s, q))
        if s.model == "power":
            s = dataclasses.replace(s, position_noise=measured_noise(q))
    return s


def offline(robot, q, tau, weighted=False):
    log = RobotLog(H * np.arange(len(q)), q, tau, tuple(robot.joint_names), H)
    res = identify_offline(log, robot, weighted=weighted)
    return res.theta if res.valid else np.full(robot.num_parameters, np.nan)


def noisy(clean_q, clean_tau, std, seed, which="both"):
    e = np.random.default_rng(1000 + seed).standard_normal((len(clean_q), 4)) * std
    q = clean_q + (e[:, :2] if which in ("both", "q") else 0.0)
    tau = clean_tau + (e[:, 2:] if which in ("both", "tau") else 0.0)
    return q, tau


def errors(estimates, truth):
    """Median over seeds of the signed and absolute relative errors [%]."""
    e = 100 * (np.asarray(estimates) - truth) / truth
    med_abs = np.nanmedian(np.abs(e), axis=0)
    return {
        "median_signed": np.nanmedian(e, axis=0).tolist(),
        "median_abs": med_abs.tolist(),
        "inertial": float(med_abs[:4].mean()),
        "friction": float(med_abs[4:].mean()),
        "failed": int(np.isnan(e).any(axis=1).sum()),
    }


# ------------------------------------------------------------------------ runs


def simulate(robot, trajectory, duration=T + 1.0, settings=(), **kw):
    return simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=duration, snr_db=30.0, seed=0),
        list(settings),
        **kw,
    )


def block_check(robot, trajectory, bandwidth):
    """In-loop Drake blocks vs the core replica on the blocks' own noisy signals."""
    chosen = [
        settings_for(LAGRANGIAN, T, bandwidth, update_period=0.5),
        settings_for(POWER, T, bandwidth, update_period=0.5),
    ]
    r = simulate(robot, trajectory, settings=chosen)
    # The recorded measurements are exactly what the in-loop blocks saw.
    q, tau = r.q, r.tau
    out = []
    for s, trace in zip(chosen, r.traces, strict=True):
        # The logger at t_last shows the solve at t_last - update_period + 3h/4,
        # whose window ends with the differentiator output of sample
        # t_last - update_period (docs/CONVENTIONS.md §2).
        end = round((trace.t[-1] - s.update_period) / H)
        core = online(robot.rows_provider(), s, filtered(q, tau, s), end)
        blocks = trace.final()["theta"]
        out.append(float(np.max(np.abs(core - blocks) / np.abs(robot.base_values))))
    return out


def run_scenario(robot, trajectory, seeds, methods, budget=False):
    r = simulate(robot, trajectory)
    bandwidth = estimate_bandwidth(r.q, H)
    rows = robot.rows_provider()
    truth = robot.base_values
    end = len(r.q) - 1
    results = {"bandwidth_hz": bandwidth}
    cases = [("both", m) for m in methods]
    if budget:
        cases += [
            (w, m)
            for w in ("tau", "q", "none")
            for m in methods
            if not m.startswith("off-line")
        ]
    for which, name in cases:
        estimates, stds, gautier, sandwich, chosen = [], [], [], [], set()
        booted = []  # σ of dynid identify's final estimate: with the bootstrap
        for seed in seeds if which != "none" else [0]:
            if which == "none":
                q, tau = r.q_true, r.tau_true
            else:
                q, tau = noisy(r.q_true, r.tau_true, r.noise_std, seed, which)
            if name.startswith("off-line"):
                estimates.append(offline(robot, q, tau, weighted=name.endswith("WLS")))
                stds.append(np.full(len(truth), np.nan))
                gautier.append(np.full(len(truth), np.nan))
                sandwich.append(np.full(len(truth), np.nan))
                continue
            s = as_run(name, methods[name](bandwidth), q, tau)
            chosen.add(s.rows_from)
            theta, std, std_gautier, std_sandwich = online_full(
                rows, s, None, end, q, tau
            )
            estimates.append(theta)
            stds.append(std)
            gautier.append(std_gautier)
            sandwich.append(std_sandwich)
            if name == BOOTSTRAPPED and which == "both":
                booted.append(np.fmax(std, bootstrap(rows, s, q, tau, end)))
        results[(which, name)] = {
            **errors(estimates, truth),
            "honesty_bootstrap": honesty(estimates, booted, truth) if booted else None,
            "honesty": honesty(estimates, stds, truth),
            "honesty_gautier": honesty(estimates, gautier, truth),
            "honesty_sandwich": honesty(estimates, sandwich, truth),
            "rows": sorted(chosen),
        }
    return results


def method_table(bandwidth_note=True):
    return {
        "on-line Lagrangian": lambda b: settings_for(LAGRANGIAN, T, b),
        "on-line Lagrangian, OLS": lambda b: settings_for(
            LAGRANGIAN, T, b, weighting="none"
        ),
        "on-line Lagrangian, raw rows": lambda b: settings_for(
            LAGRANGIAN, T, b, rows_from="raw"
        ),
        "on-line Lagrangian, rows from the log (auto)": lambda b: settings_for(
            LAGRANGIAN, T, b
        ),
        "on-line Lagrangian, covariance weighting": lambda b: settings_for(
            LAGRANGIAN, T, b
        ),
        "on-line power (dynid identify: covariance weighting)": lambda b: settings_for(
            POWER, T, b
        ),
        "on-line power, frequency weighting (dynid identify before)": lambda b: (
            settings_for(POWER, T, b)
        ),
        "on-line power": lambda b: settings_for(POWER, T, b),
        "on-line power, ℓ to B (before)": lambda b: settings_for(
            POWER, T, b / POWER_BAND_FACTOR
        ),
        "on-line power, OLS": lambda b: settings_for(POWER, T, b, weighting="none"),
        "on-line power, paper set": lambda b: OnlineSettings(
            window=T, frequencies="paper", weighting="none", **POWER
        ),
        "off-line IDIM-LS": None,
        "off-line IDIM-WLS": None,
    }


# ---------------------------------------------------------------------- output


def _row(label, values, fmt="{:+.2f}"):
    return f"| {label} | " + " | ".join(fmt.format(x) for x in values) + " |"


def print_2r(all_results, methods, seeds) -> None:
    """The 2R tables: the main case, its error budget and σ, the other scenarios."""
    names = paper.BASE_NAMES
    main_label = next(iter(all_results))
    res = all_results[main_label]
    print(
        f"## {main_label}: median relative error over {len(seeds)} seeds [%] "
        f"(SNR 30 dB, T = 20 s, measured band {res['bandwidth_hz']:.3f} Hz)\n"
    )
    print("| | " + " | ".join(names) + " | inertial | friction |")
    print("|---" * (len(names) + 3) + "|")
    for name in methods:
        e = res[("both", name)]
        print(
            _row(name, e["median_signed"])[:-2]
            + f" | {e['inertial']:.2f} | {e['friction']:.2f} |"
        )
    for label, err in (
        ("paper Table II on-line", PAPER_ONLINE_ERR),
        ("paper Table II off-line", PAPER_OFFLINE_ERR),
    ):
        a = np.abs(err)
        print(_row(label, err)[:-2] + f" | {a[:4].mean():.2f} | {a[4:].mean():.2f} |")
    print("\n(signed medians; inertial/friction: mean of the 4 medians of |error|)\n")
    print("## Error budget (same seeds; mean |error| % inertial / friction)\n")
    print("| method | noise q and τ | noise on τ only | noise on q only | noise-free |")
    print("|---|---|---|---|---|")
    for name in methods:
        if name.startswith("off-line"):
            continue
        cells = [
            f"{res[(w, name)]['inertial']:.2f} / {res[(w, name)]['friction']:.2f}"
            for w in ("both", "tau", "q", "none")
        ]
        print(f"| {name} | " + " | ".join(cells) + " |")
    print(
        "\n## Uncertainty (same seeds, SNR 30 dB): |error|/σ over the 8 parameters "
        "(p90 1.64 for an honest σ), σ the larger of the sandwich σ and the "
        "jackknife's (default), the sandwich σ alone, or Gautier's alone; rows "
        "chosen on the log; dynid identify's final σ: the default or the parametric "
        "bootstrap's (16 replicates), whichever is larger\n"
    )
    print(
        "| scenario | method | rows | err/σ p50 | err/σ p90 | sandwich σ: p90 | "
        "Gautier σ: p90 | with the bootstrap: p90 |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for label, res_s in all_results.items():
        for name in methods:
            if name.startswith("off-line") or (
                "power" in name and "covariance" not in name
            ):
                continue
            h = res_s[("both", name)]["honesty"]
            g = res_s[("both", name)]["honesty_gautier"]
            w = res_s[("both", name)]["honesty_sandwich"]
            rows = "/".join(res_s[("both", name)]["rows"])
            booted = res_s[("both", name)]["honesty_bootstrap"]
            print(
                f"| {label} | {name} | {rows} | {h['p50']:.2f} | {h['p90']:.2f} | "
                f"{w['p90']:.2f} | {g['p90']:.2f} | "
                f"{'' if booted is None else format(booted['p90'], '.2f')} |"
            )
    if len(all_results) > 1:
        print(
            "\n## Other geometries and trajectories "
            "(same defaults; inertial / friction %)\n"
        )
        print("| scenario | band Hz | " + " | ".join(methods) + " |")
        print("|---|---|" + "---|" * len(methods))
        for label, res_s in all_results.items():
            cells = [
                "{inertial:.2f} / {friction:.2f}".format(**res_s[("both", m)])
                for m in methods
            ]
            print(
                f"| {label} | {res_s['bandwidth_hz']:.2f} | " + " | ".join(cells) + " |"
            )


def exact_bias(robot, quick: bool) -> dict:
    """Noise-free bias on exact logs (Drake inverse dynamics, no simulation)."""
    cases = {"paper_trajectory": paper.paper_trajectory()}
    if not quick:
        cases["1 Hz (wide rf seed 5)"] = _rf(5, harmonics=4, f=0.25)
    out = {}
    for label, trajectory in cases.items():
        log, _ = exact_log(robot, trajectory, T + 1.0, H)
        bandwidth = estimate_bandwidth(log.q, H)
        for rows_from in ("filtered", "raw"):
            s = settings_for(LAGRANGIAN, T, bandwidth, rows_from=rows_from)
            theta = online(
                robot.rows_provider(), s, None, log.num_samples - 1, log.q, log.tau
            )
            out[f"{label}|{rows_from}"] = errors([theta], robot.base_values)
    return out


def change_report(models, scen, robot, trajectory, seeds, quick: bool) -> dict:
    """Tracking, false alarms and the floor on the 2R (_change.py, _change_floor.py).

    ``quick``: one seed, noise on q and τ only, the main scenario.
    """
    bandwidth = estimate_bandwidth(simulate(robot, trajectory, duration=10.0).q, H)
    chosen = [0] if quick else list(seeds)[:10]
    report = {
        "jump": _change.jump_tracking(
            robot,
            lambda **kw: simulate(robot, trajectory, **kw),
            bandwidth,
            chosen,
            noises=("both",) if quick else ("both", "tau"),
        ),
        "false_2r": _change.false_alarms_2r(models, scen, simulate, chosen),
    }
    if not quick:
        main = dict(list(scen.items())[:1])
        tau = _change.false_alarms_2r(models, main, simulate, chosen, "tau")
        report["false_2r_tau"] = {f"{k} (q exact)": v for k, v in tau.items()}
    report["floor"] = _change_floor.floor_report(
        models, None if quick else scen, simulate, bandwidth, chosen
    )
    return report


def run_2r(args, seeds, report) -> None:
    start = time.perf_counter()
    methods = method_table()
    with tempfile.TemporaryDirectory() as tmp:
        models = robots(Path(tmp))
        scen = scenarios(args.quick)
        main_robot, main_traj = models["paper"], paper.paper_trajectory()
        bw0 = estimate_bandwidth(simulate(main_robot, main_traj).q, H)
        check = block_check(main_robot, main_traj, bw0)
        print(
            f"Core replica vs Drake blocks in the loop (seed 0, same window): max rel. "
            f"difference Lagrangian {check[0]:.1e}, power {check[1]:.1e}\n"
        )
        report["block_check"] = check
        all_results = {}
        for label, (rname, traj) in scen.items():
            all_results[label] = run_scenario(
                models[rname], traj, seeds, methods, budget=not all_results
            )
        print_2r(all_results, methods, seeds)
        import _accuracy_power as _power

        r0 = simulate(main_robot, main_traj)
        power = _power.run(
            main_robot, r0.q_true, r0.tau_true, r0.noise_std, range(args.power_seeds)
        )
        _power.print_report(power, paper.BASE_NAMES)
        report["power"] = power
        bias = exact_bias(main_robot, args.quick)
        print(
            "\n## Noise-free bias on exact logs (trajectory evaluated, Drake inverse "
            "dynamics + Coulomb sign; no simulation): inertial / friction %\n"
        )
        print("| trajectory | filtered rows | raw rows |")
        print("|---|---|---|")
        for label in dict.fromkeys(k.split("|")[0] for k in bias):
            cells = [
                "{inertial:.3f} / {friction:.3f}".format(**bias[f"{label}|{r}"])
                for r in ("filtered", "raw")
            ]
            print(f"| {label} | " + " | ".join(cells) + " |")
        tracking = change_report(models, scen, main_robot, main_traj, seeds, args.quick)
        _change.print_tracking(tracking, seeds)
        _change_floor.print_floor(tracking["floor"])
    report["tracking"] = tracking
    report["exact_bias"] = bias
    report["settings"] = {"lagrangian": LAGRANGIAN, "power": POWER}
    report["results"] = {
        label: {
            (k if isinstance(k, str) else f"{k[0]}|{k[1]}"): v for k, v in r.items()
        }
        for label, r in all_results.items()
    }
    report["wall_2r_s"] = time.perf_counter() - start


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--seeds", type=int, default=None, help="noise seeds (default 40; --quick 3)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="few seeds, main cases only (smoke run)"
    )
    parser.add_argument(
        "--robot",
        choices=("2r", "iiwa7", "payload", "all"),
        default="all",
        help="the paper's 2R (closed loop, SNR 30 dB), the 7-DOF iiwa7 (independent "
        "logs, benchmarks/_accuracy_arm7.py), payload identification "
        "(benchmarks/_accuracy_payload.py) or all (default)",
    )
    parser.add_argument(
        "--seeds7",
        type=int,
        default=None,
        help="noise seeds of the iiwa7 section (default 10; --quick 1)",
    )
    parser.add_argument(
        "--payload-seeds",
        type=int,
        default=None,
        help="noise seeds of the payload section (default 16; --quick 1)",
    )
    parser.add_argument(
        "--power-seeds",
        type=int,
        default=None,
        help="noise seeds of the power model's bias/spread section (default 200; "
        "--quick 20)",
    )
    parser.add_argument("--json", type=str, default=None)
    args = parser.parse_args(argv)
    args.power_seeds = quick_or(args.power_seeds, args.quick, 20, 200)
    seeds = range(quick_or(args.seeds, args.quick, 3, 40))
    start = time.perf_counter()
    report: dict = {"seeds": list(seeds), "snr_db": 30.0, "window": T}
    if args.robot in ("2r", "all"):
        run_2r(args, seeds, report)
    if args.robot in ("iiwa7", "all"):
        import _accuracy_arm7 as _arm7

        seeds7 = quick_or(args.seeds7, args.quick, 1, 10)
        arm = _arm7.run(range(seeds7), quick=args.quick)
        _arm7.print_report(arm)
        report["iiwa7"] = arm
        if not args.quick:  # change detection on a log without a change
            seeds7 = range(min(seeds7, 5))
            alarms = _change.false_alarms_arm7(_arm7.Arm7(), seeds7)
            _change.print_tracking({"false_arm7": alarms}, seeds7)
            report["iiwa7_false_alarms"] = alarms
            payload = _change.payload_tracking(_arm7.Arm7(), seeds7)
            _change.print_payload(payload)
            report["iiwa7_payload"] = payload
    if args.robot in ("payload", "all"):  # issue 16 item 5
        import _accuracy_payload as _payload

        payload = _payload.run(
            range(quick_or(args.payload_seeds, args.quick, 1, 16)), args.quick
        )
        _payload.print_report(payload)
        report["payload"] = payload
    wall = time.perf_counter() - start
    print(f"\nwall time {wall:.0f} s")
    report["wall_s"] = wall
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
