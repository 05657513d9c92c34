"""The power model's limits on the paper's 2R (a section of bench_accuracy.py).

On the main scenario (paper 2R, paper trajectory, SNR 30 dB on q and τ, T = 20 s,
the power model's defaults with the rows ``dynid identify`` chooses), over
``seeds`` noise draws (default_rng(1000 + s), as the other tables):

* **bias vs spread**: the mean over seeds of the relative error of each parameter
  (the bias) and its standard deviation (the spread), with the rows as they are
  and with their noise bias compensated (``OnlineSettings.position_noise`` = the
  σ_q measured on each log, ``core.noise_bias``); plus the median |error| of one
  run, the metric of the other tables;
* **the rows' bias**: the mean over seeds of the window's regressor A against the
  noise-free log's, per column in units of its Monte-Carlo error (χ²/rows: 1 when
  unbiased), as they are and compensated;
* **the best linear weighting** (an oracle bound): the window's rows A θ = B of
  every seed, their residual at the true θ, r = B - A θ, and its covariance Σ
  over the first half of the seeds (the Monte-Carlo truth of the rows' noise,
  which no estimator knows; shrunk towards its diagonal by r/(r + N/2) for r
  rows and N seeds, so that it stays invertible); generalised least squares with
  Σ⁻¹ on the other half: about what the best (linear, generalised least
  squares) weighting of these rows could reach if it knew their noise, i.e. how
  far the power model's rows can go at this noise level.

Frequency-weighted solves (the default) unless stated.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from drake_dynid.core.excitation import estimate_bandwidth, position_noise_std
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.raw_rows import rows_from_noise
from drake_dynid.core.replay import window_equations
from drake_dynid.core.weighted_lsq import solve_window

H = 1e-3
T = 20.0


def _noisy(q, tau, std, seed):
    e = np.random.default_rng(1000 + seed).standard_normal((len(q), 4)) * std
    return q + e[:, :2], tau + e[:, 2:]


def _percent(estimates, truth) -> np.ndarray:
    return 100 * (np.asarray(estimates) - truth) / truth


def _summary(errors: np.ndarray) -> dict:
    med = np.nanmedian(np.abs(errors), axis=0)
    return {
        "mean": np.nanmean(errors, axis=0).tolist(),
        "std": np.nanstd(errors, axis=0).tolist(),
        "median_abs": med.tolist(),
        "inertial": float(med[:4].mean()),
        "friction": float(med[4:].mean()),
        "friction_bias": float(np.abs(np.nanmean(errors, axis=0))[4:].mean()),
    }


def run(robot, clean_q, clean_tau, noise_std, seeds) -> dict:
    """Every number of the section (module docstring) on one noise-free log."""
    rows = robot.rows_provider()
    truth = robot.base_values
    n, p = robot.num_joints, robot.num_parameters
    base = OnlineSettings.for_model(
        "power", window=T, bandwidth=estimate_bandwidth(clean_q, H)
    )
    end = len(clean_q) - 1
    plain, compensated, systems, regressors = [], [], [], []
    for seed in seeds:
        q, tau = _noisy(clean_q, clean_tau, noise_std, seed)
        grid = base.on_grid(H)
        chosen = rows_from_noise(
            q,
            H,
            raw_window=grid.resolved("raw_window"),
            jacobi_window=grid.jacobi_window,
            bandwidth=grid.bandwidth,
        )[0]
        s = dataclasses.replace(base, rows_from=chosen).for_robot(H, n, p)
        sigma = tuple(position_noise_std(q, H).tolist())
        for settings, out in (
            (s, plain),
            (dataclasses.replace(s, position_noise=sigma), compensated),
        ):
            a, b = window_equations(rows, settings, q, tau, end, H)
            res = solve_window(
                a,
                b,
                settings.row_weighting(1),
                max_condition=settings.max_condition,
                names=rows.names,
            )
            out.append(res.theta if res.valid else np.full(p, np.nan))
            regressors.append(a)
            if out is plain:
                systems.append((a, b))
    half = len(systems) // 2
    residual = np.array([b - a @ truth for a, b in systems[:half]])
    cov = np.cov(residual.T)
    shrink = min(1.0, cov.shape[0] / (cov.shape[0] + half))  # towards the diagonal
    cov = (1.0 - shrink) * cov + shrink * np.diag(np.diag(cov))
    whiten = np.linalg.cholesky(np.linalg.inv(cov)).T
    oracle = [
        np.linalg.lstsq(whiten @ a, whiten @ b, rcond=None)[0]
        for a, b in systems[half:]
    ]
    clean = window_equations(rows, s, clean_q, clean_tau, end, H)[0]
    chi2 = {}
    for key, found in (("plain", regressors[0::2]), ("compensated", regressors[1::2])):
        found = np.array(found)
        error = found.std(axis=0) / np.sqrt(len(found))
        chi2[key] = (((found.mean(axis=0) - clean) / error) ** 2).mean(axis=0).tolist()
    return {
        "regressor_chi2": chi2,
        "seeds": len(list(seeds)),
        "rows": int(systems[0][0].shape[0]),
        "rows_from": s.rows_from,
        "plain": _summary(_percent(plain, truth)),
        "compensated": _summary(_percent(compensated, truth)),
        "oracle": _summary(_percent(oracle, truth)),
    }


def print_report(report: dict, names) -> None:
    print(
        "\n## Power rows' bias: mean over seeds of the window's regressor A minus the "
        "noise-free A, in units of its Monte-Carlo error, squared and averaged over "
        "the rows (1 for an unbiased column)\n"
    )
    print("| rows | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 1) + "|")
    for label, key in (("as they are", "plain"), ("compensated", "compensated")):
        cells = " | ".join(f"{x:.2f}" for x in report["regressor_chi2"][key])
        print(f"| {label} | {cells} |")
    print(
        f"\n## Power model on the 2R (paper trajectory, SNR 30 dB, {report['seeds']} "
        f"seeds, {report['rows']} rows, {report['rows_from']} rows): bias (mean "
        "error) vs spread (std), %\n"
    )
    print("| | " + " | ".join(names) + " | inertial | friction |")
    print("|---" * (len(names) + 3) + "|")
    for label, key in (
        ("mean error, rows as they are", "plain"),
        ("mean error, noise bias compensated", "compensated"),
    ):
        r = report[key]
        cells = " | ".join(f"{x:+.2f}" for x in r["mean"])
        print(f"| {label} | {cells} | | {r['friction_bias']:.2f} (mean abs) |")
    for label, key in (
        ("std over seeds, rows as they are", "plain"),
        ("std over seeds, compensated", "compensated"),
    ):
        cells = " | ".join(f"{x:.2f}" for x in report[key]["std"])
        print(f"| {label} | {cells} | | |")
    for label, key in (
        ("median abs, rows as they are", "plain"),
        ("median abs, compensated", "compensated"),
        ("median abs, best linear weighting (oracle, other half)", "oracle"),
    ):
        r = report[key]
        cells = " | ".join(f"{x:.2f}" for x in r["median_abs"])
        print(f"| {label} | {cells} | {r['inertial']:.2f} | {r['friction']:.2f} |")
