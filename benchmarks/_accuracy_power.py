"""The power model's limits on the paper's 2R (a section of bench_accuracy.py).

On the main scenario (paper 2R, paper trajectory, SNR 30 dB on q and τ, T = 20 s),
over ``seeds`` noise draws (default_rng(1000 + s), as the other tables):

* **the rows' bias**: the mean over seeds of the window's regressor A against the
  noise-free log's, per column in units of its Monte-Carlo error (χ²/rows: 1 when
  unbiased), with the frequency weighting's rows as they are and with their noise
  bias compensated (``OnlineSettings.position_noise`` = the σ_q measured on each
  log, ``core.noise_bias``);
* **bias vs spread**: the mean over seeds of the relative error of each parameter
  (the bias), its standard deviation (the spread) and the median |error| of one
  run (the metric of the other tables), for the frequency weighting with the
  compensation (``dynid identify`` before the covariance weighting) and for the
  covariance weighting (``core.row_covariance``, σ_q and σ_τ measured on each log:
  ``dynid identify``'s default);
* **the floor of the power rows**: the best linear unbiased use of a window's
  power rows, generalised least squares with their exact first-order covariance
  Σ (``core.row_covariance`` at the true θ on the noise-free log, with the true
  noise stds): σ_θ = √diag((AᵀΣ⁻¹A)⁻¹), reported as the median |error| of one run
  it implies (0.674 σ_θ for a Gaussian error), for the frequency weighting's ℓ set
  (ℓ to 2B) and for every ℓ within the differentiator's pass band (the covariance
  weighting's set). No weighting of these rows can do better to first order in
  the noise; more information needs a longer window or a lower noise.
* **the covariance weighting without noise** (the filters' and the closed loop's
  bias): its estimate on the noise-free log with Σ from the true stds.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from drake_dynid.core.excitation import (
    estimate_bandwidth,
    position_noise_std,
    torque_noise_std,
)
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import (
    filtered_signals,
    window_covariance_at,
    window_equations,
)
from drake_dynid.core.weighted_lsq import solve_window

H = 1e-3
T = 20.0
#: The median |error| of a zero-mean Gaussian of std σ is 0.674 σ.
MEDIAN_OF_GAUSSIAN = 0.6745


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


def _solve(rows, settings, q, tau, end):
    """θ̂ of the window at ``end`` (NaN when not valid) and its regressor."""
    a, b = window_equations(rows, settings, q, tau, end, H)
    res = solve_window(
        a,
        b,
        settings.row_weighting(1),
        max_condition=settings.max_condition,
        names=rows.names,
        covariance=window_covariance_at(rows, settings, q, tau, end, H),
    )
    return (res.theta if res.valid else np.full(a.shape[1], np.nan)), a


def floor(rows, settings, clean_q, clean_tau, truth) -> dict:
    """σ_θ of generalised least squares with the rows' exact covariance (docstring)."""
    end = len(clean_q) - 1
    s = settings.for_robot(H, int(rows.num_joints), int(rows.num_parameters))
    signals = filtered_signals(clean_q, clean_tau, s, H)
    a = window_equations(rows, s, clean_q, clean_tau, end, H, signals=signals)[0]
    cov = window_covariance_at(rows, s, clean_q, clean_tau, end, H, signals=signals)
    information = a.T @ np.linalg.solve(cov(truth), a)
    std = 100 * np.sqrt(np.diag(np.linalg.inv(information))) / np.abs(truth)
    median = MEDIAN_OF_GAUSSIAN * std
    return {
        "functions": len(s.ell()),
        "std": std.tolist(),
        "median_abs": median.tolist(),
        "inertial": float(median[:4].mean()),
        "friction": float(median[4:].mean()),
    }


def run(robot, clean_q, clean_tau, noise_std, seeds) -> dict:
    """Every number of the section (module docstring) on one noise-free log."""
    rows = robot.rows_provider()
    truth = robot.base_values
    n = robot.num_joints
    base = OnlineSettings.for_model(
        "power", window=T, bandwidth=estimate_bandwidth(clean_q, H)
    )
    end = len(clean_q) - 1
    sigma_q, sigma_tau = tuple(noise_std[:n]), tuple(noise_std[n:])
    weighted = dataclasses.replace(
        base, weighting="covariance", position_noise=sigma_q, torque_noise=sigma_tau
    )
    found = {"plain": [], "compensated": [], "covariance": []}
    regressors = {"plain": [], "compensated": []}
    for seed in seeds:
        q, tau = _noisy(clean_q, clean_tau, noise_std, seed)
        measured_q = tuple(position_noise_std(q, H).tolist())
        measured_tau = tuple(torque_noise_std(tau, H).tolist())
        for key, settings in (
            ("plain", base),
            ("compensated", dataclasses.replace(base, position_noise=measured_q)),
            (
                "covariance",
                dataclasses.replace(
                    weighted, position_noise=measured_q, torque_noise=measured_tau
                ),
            ),
        ):
            theta, a = _solve(rows, settings, q, tau, end)
            found[key].append(theta)
            if key in regressors:
                regressors[key].append(a)
    clean = window_equations(rows, base, clean_q, clean_tau, end, H)[0]
    chi2 = {}
    for key, values in regressors.items():
        values = np.array(values)
        error = values.std(axis=0) / np.sqrt(len(values))
        chi2[key] = (((values.mean(axis=0) - clean) / error) ** 2).mean(axis=0).tolist()
    # Without noise there is no noise bias to remove: the covariance set's rows
    # uncompensated, Σ from the true stds.
    grid = weighted.for_robot(H, n, len(truth))
    plain = dataclasses.replace(
        grid,
        weighting="frequency",
        position_noise=None,
        torque_noise=None,
        frequencies=grid.ell(),
    )
    a, b = window_equations(rows, plain, clean_q, clean_tau, end, H)
    noise_free = solve_window(
        a, b, covariance=window_covariance_at(rows, grid, clean_q, clean_tau, end, H)
    ).theta
    return {
        "regressor_chi2": chi2,
        "seeds": len(list(seeds)),
        "functions": {
            "frequency": len(base.for_robot(H, n, len(truth)).ell()),
            "covariance": len(weighted.for_robot(H, n, len(truth)).ell()),
        },
        "compensated": _summary(_percent(found["compensated"], truth)),
        "covariance": _summary(_percent(found["covariance"], truth)),
        "plain": _summary(_percent(found["plain"], truth)),
        "floor_frequency_set": floor(
            rows,
            dataclasses.replace(
                weighted, frequencies=base.for_robot(H, n, len(truth)).ell()
            ),
            clean_q,
            clean_tau,
            truth,
        ),
        "floor": floor(rows, weighted, clean_q, clean_tau, truth),
        "covariance_noise_free": _percent(noise_free, truth).tolist(),
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
    functions = report["functions"]
    print(
        f"\n## Power model on the 2R (paper trajectory, SNR 30 dB, {report['seeds']} "
        f"seeds): bias (mean error) vs spread (std), %; frequency weighting with "
        f"{functions['frequency']} functions (ℓ to 2B), covariance weighting with "
        f"{functions['covariance']} (ℓ to the pass band)\n"
    )
    print("| | " + " | ".join(names) + " | inertial | friction |")
    print("|---" * (len(names) + 3) + "|")
    methods = (
        ("frequency weighting, compensated", "compensated"),
        ("covariance weighting", "covariance"),
    )
    for label, key in methods:
        r = report[key]
        cells = " | ".join(f"{x:+.2f}" for x in r["mean"])
        print(
            f"| mean error, {label} | {cells} | | {r['friction_bias']:.2f} (mean abs) |"
        )
    for label, key in methods:
        cells = " | ".join(f"{x:.2f}" for x in report[key]["std"])
        print(f"| std over seeds, {label} | {cells} | | |")
    rows = [(f"median abs, {label}", report[key]) for label, key in methods]
    rows += [
        (
            f"floor: exact-covariance GLS, {report[key]['functions']} functions "
            "(0.674 σ_θ)",
            report[key],
        )
        for key in ("floor_frequency_set", "floor")
    ]
    for label, r in rows:
        cells = " | ".join(f"{x:.2f}" for x in r["median_abs"])
        print(f"| {label} | {cells} | {r['inertial']:.2f} | {r['friction']:.2f} |")
    bias = np.abs(report["covariance_noise_free"])
    cells = " | ".join(f"{x:+.2f}" for x in report["covariance_noise_free"])
    print(
        f"| covariance weighting, noise-free log | {cells} | {bias[:4].mean():.2f} | "
        f"{bias[4:].mean():.2f} |"
    )
