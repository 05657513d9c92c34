"""Is the on-line identifier's σ honest, whatever the options (issue 14)?

For several option sets, the final window of a log is solved for many noise seeds;
for every window the identifier reports valid, its σ is compared with the
Monte-Carlo spread of the estimates over the seeds (std over seeds, per
parameter): ``ratio = median σ / spread``, honest within a factor 2. The default
σ (the larger of the sandwich σ and the jackknife's), Gautier's σ (independent
rows of equal noise, ``core.weighted_lsq.solve_window`` without the rows' noise
model) and the sandwich σ alone (``uncertainty="sandwich"``, without the
jackknife) are measured side by side on the same windows.

Logs, at 1 kHz on the paper's 2R arm (``drake_dynid.paper``):

* clean: the Drake closed-loop simulation of ``paper_trajectory()`` (noise-free,
  ``simulate_identification``) plus white noise at SNR 30 dB on q and τ, one
  draw per seed (``np.random.default_rng(seed)``);
* pure noise: white noise of the same std on q and τ, nothing else.

Every option set first goes through the checks ``dynid identify`` applies
(``OnlineSettings.for_log`` with the robot): a refused set is listed with the
reason. The window's A, B are the identifier's (the same filters, rows, bank and
solve as ``core.replay``; the final window by direct quadrature, equal to the
sliding sums to ~1e-13).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
from _timing import quick_or

from drake_dynid import paper
from drake_dynid.core.equations import assemble_equations, direct_fourier_integrals
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import bank_channels, filtered_signals
from drake_dynid.core.weighted_lsq import solve_window
from drake_dynid.diagrams import SimulationSettings, simulate_identification
from drake_dynid.plants import RobotModel, model_path
from drake_dynid.simulation import reference_noise_std

H = 1e-3
SNR_DB = 30.0

#: name -> OnlineSettings keyword arguments (model defaults otherwise).
OPTION_SETS: dict[str, dict] = {
    "defaults (T 20 s)": {},
    "T 10 s": {"window": 10.0},
    "T 5 s": {"window": 5.0},
    "T 2 s, Tj 0.1 s": {"window": 2.0, "jacobi_window": 0.1},
    "band 1.5 Hz": {"bandwidth": 1.5},
    "paper ℓ 0:0.05:10": {"frequencies": "paper"},
    "T 5 s, paper ℓ": {"window": 5.0, "frequencies": "paper"},
    "OLS (weighting none)": {"weighting": "none"},
    "paper ℓ, OLS": {"frequencies": "paper", "weighting": "none"},
    "κ = μ = 3, q = 2": {"kappa": 3.0, "mu": 3.0, "jacobi_q": 2},
    "power model": {"model": "power"},
    "power, paper ℓ, OLS": {
        "model": "power",
        "frequencies": "paper",
        "weighting": "none",
    },
    "refused: T 2 s, Tj 0.4 s": {"window": 2.0},
    "refused: band 100 Hz": {"bandwidth": 100.0},
}
QUICK_SETS = ("defaults (T 20 s)", "paper ℓ 0:0.05:10", "refused: T 2 s, Tj 0.4 s")


def _settings(options: dict) -> OnlineSettings:
    kwargs = dict(options)
    return OnlineSettings.for_model(kwargs.pop("model", "lagrangian"), **kwargs)


def _final_window(settings, rows, q, tau):
    """(default, sandwich-only, Gautier) results of the log's last window."""
    signals = filtered_signals(q, tau, settings, H)
    bank = settings.bank()
    end = q.shape[0] - 1
    index = end - settings.decimation(H) * np.arange(bank.num_intervals, -1, -1)
    q_hat, v_hat, tau_hat = (signal[index] for signal in signals[:3])
    channels = bank_channels(rows, settings.model, q_hat, v_hat, tau_hat)
    m = settings.num_equations(int(rows.num_joints))
    p = int(rows.num_parameters)
    A, B = assemble_equations(bank, direct_fourier_integrals(bank, channels), m, p)
    weighting = settings.row_weighting(m, bank)
    common = {"max_condition": settings.max_condition, "names": rows.names}
    noise = settings.row_noise(m, bank)
    groups = settings.jackknife_groups(m, bank)
    honest = solve_window(A, B, weighting, noise=noise, jackknife=groups, **common)
    sandwich = solve_window(A, B, weighting, noise=noise, **common)
    gautier = solve_window(A, B, weighting, **common)
    return honest, sandwich, gautier


def _ratios(estimates, sigmas) -> tuple[float, float, np.ndarray]:
    spread = np.std(estimates, axis=0, ddof=1)
    ratio = np.median(sigmas, axis=0) / spread
    return float(np.min(ratio)), float(np.max(ratio)), ratio


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=None, help="noise seeds (48)")
    parser.add_argument("--duration", type=float, default=None, help="log [s] (30)")
    parser.add_argument("--quick", action="store_true", help="tiny run (smoke test)")
    parser.add_argument("--json", metavar="FILE", help="write the results as JSON")
    args = parser.parse_args(argv)
    seeds = quick_or(args.seeds, args.quick, 4, 48)
    duration = quick_or(args.duration, args.quick, 24.0, 30.0)
    names = list(QUICK_SETS) if args.quick else list(OPTION_SETS)
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    rows = robot.rows_provider()
    trajectory = paper.paper_trajectory()
    clean = simulate_identification(
        robot, trajectory, SimulationSettings(duration=duration, snr_db=None), []
    )
    std = reference_noise_std(robot, trajectory, duration, SNR_DB, H)
    n = robot.num_joints
    count = clean.t.shape[0]

    table = []
    for name in names:
        try:
            settings = _settings(OPTION_SETS[name]).for_log(
                H, duration, num_joints=n, num_parameters=robot.num_parameters
            )
        except ValueError as error:
            table.append({"options": name, "refused": str(error)})
            continue
        for kind in ("clean", "pure noise"):
            theta, sigma, old, middle, valid = [], [], [], [], 0
            identified = []
            for seed in range(seeds):
                rng = np.random.default_rng(seed)
                noise_q = rng.normal(0.0, std[:n], (count, n))
                noise_tau = rng.normal(0.0, std[n:], (count, n))
                if kind == "clean":
                    q, tau = clean.q_true + noise_q, clean.tau_true + noise_tau
                else:
                    q, tau = noise_q, noise_tau
                honest, sandwich, gautier = _final_window(settings, rows, q, tau)
                if not honest.valid:
                    continue
                valid += 1
                theta.append(honest.theta)
                sigma.append(honest.std)
                old.append(gautier.std)
                middle.append(sandwich.std)
                identified.append(int(np.sum(honest.relative_std_percent <= 30.0)))
            row = {"options": name, "log": kind, "valid": valid, "seeds": seeds}
            if valid >= 3:
                low, high, ratio = _ratios(np.array(theta), np.array(sigma))
                old_low, old_high, _ = _ratios(np.array(theta), np.array(old))
                mid_low, mid_high, _ = _ratios(np.array(theta), np.array(middle))
                row.update(
                    {
                        "ratio_min": low,
                        "ratio_max": high,
                        "ratios": ratio.tolist(),
                        "gautier_min": old_low,
                        "gautier_max": old_high,
                        "sandwich_min": mid_low,
                        "sandwich_max": mid_high,
                        "identified": float(np.median(identified)),
                    }
                )
                if kind == "clean":
                    error = np.array(theta) - paper.TRUE_VALUES
                    rms = np.sqrt(np.mean(error**2, axis=0))
                    row["sigma_over_rms_error_max"] = float(
                        np.max(np.median(np.array(sigma), axis=0) / rms)
                    )
            table.append(row)

    print(
        f"σ honesty: final window of {duration:g} s logs, 2R arm at 1 kHz, SNR "
        f"{SNR_DB:g} dB noise, {seeds} seeds; ratio = median σ / spread of the "
        "estimates over the seeds (per parameter: min-max over the 8); honest "
        "within [0.5, 2]\n"
    )
    print(
        "| options | log | valid windows | σ/spread (default: max of sandwich and "
        "jackknife) | σ/spread (sandwich alone) | σ/spread (Gautier) | identified "
        "(%σ ≤ 30) |"
    )
    print("|---|---|---|---|---|---|---|")
    for row in table:
        if "refused" in row:
            reason = row["refused"].split(": ", 1)[-1]
            print(f"| {row['options']} | — | refused: {reason[:90]}… | | | | |")
            continue
        if "ratio_min" not in row:
            print(
                f"| {row['options']} | {row['log']} | {row['valid']}/{row['seeds']} "
                "| — | — | — | — |"
            )
            continue
        honest = 0.5 <= row["ratio_min"] and row["ratio_max"] <= 2.0
        print(
            f"| {row['options']} | {row['log']} | {row['valid']}/{row['seeds']} | "
            f"{row['ratio_min']:.2f}-{row['ratio_max']:.2f}"
            f"{'' if honest else ' (!)'} | "
            f"{row['sandwich_min']:.2f}-{row['sandwich_max']:.2f} | "
            f"{row['gautier_min']:.2f}-{row['gautier_max']:.2f} | "
            f"{row['identified']:g} of {robot.num_parameters} |"
        )
    finite = [r for r in table if "ratio_min" in r]
    worst = min(
        (min(r["ratio_min"], 1.0 / r["ratio_max"]) for r in finite), default=math.nan
    )
    print(f"\nworst factor over the accepted sets: {1.0 / worst:.2f}")
    if args.json:
        with open(args.json, "w") as stream:
            json.dump({"seeds": seeds, "duration": duration, "rows": table}, stream)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
