"""The 7-DOF section of the accuracy benchmark (``bench_accuracy.py --robot iiwa7``).

Arm: ``models/iiwa7.urdf`` (57 base parameters: 43 inertial + FV, FC per joint;
gravity). Log: 60 s at 1 kHz of ``random_fourier_trajectory`` (7 joints, 5
harmonics of 0.1 Hz, |q̇| <= 1 rad/s, |q - q0| <= 1 rad, default_rng(0)), torques
from Drake's ``CalcInverseDynamics`` + the URDF's Coulomb friction
(``_independent.exact_log``; sign(v), or tanh(v/0.05) for the smooth-friction case).
Validation: another trajectory (default_rng(1), 20 s), torques the same way.

Estimates: the on-line identifier's last window (T = 20 s, ending at the last
sample; ``core.replay.window_equations``, the core's equations by direct
quadrature), library defaults with the band measured on the log (0.52 Hz), rows
"filtered" or "raw" (``OnlineSettings.rows_from``; "auto" is
``core.raw_rows.rows_from_noise`` on the log); off-line IDIM-LS
(``identify_offline``). Metrics, medians over noise seeds: the median and the
largest relative error over the well-identified parameters; the torque
prediction error per joint on the validation trajectory, RMS(W θ̂ - τ)/RMS(τ);
err/σ over all 57 parameters (``_independent.honesty``).
The well-identified set is chosen once, independently of the on-line method:
Gautier's σ of an IDIM-LS on the exact states every 10 ms with SNR 30 dB torque
noise (default_rng(0)) at most 5 % of the true value (8 inertial + 14 friction).

Noise: none; "encoder" σ_q = 1e-4 rad with SNR 40 dB on τ (1 % of its std); "high"
σ_q = 1e-3 rad with SNR 30 dB on τ.

The power model ("on-line power auto"): as ``dynid identify --model power``
(rows chosen on the log, σ_q measured and its bias compensated, the default ℓ
set: 61 functions for p = 57, ``core.ell_rule``), solved with max_condition 1e8
(:data:`POWER_MAX_CONDITION`; its windows have condition numbers of 1e5-1e6, so
the default 1e4 rejects every one). "on-line power covariance": as
``dynid identify --model power`` today (the covariance-weighted solve, filtered
rows, σ_q and σ_τ measured on the log, every integer ℓ in the pass band: 116
functions), with the default max_condition (its solve checks the whitened A;
"condition" is the column-scaled A's for every method).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from _independent import drake_torques, exact_log, honesty, window_solves, with_noise

from drake_dynid.core.excitation import (
    estimate_bandwidth,
    position_noise_std,
    torque_noise_std,
)
from drake_dynid.core.lsq import solve_least_squares
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.raw_rows import rows_from_noise
from drake_dynid.core.replay import window_covariance_at, window_equations
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.offline import identify_offline
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path

H = 1e-3
T = 20.0
DURATION = 60.0
WIDTH = 0.05  # [rad/s] of the smooth-friction case
NOISE = {"none": (0.0, None), "encoder": (1e-4, 40.0), "high": (1e-3, 30.0)}
#: The power model's windows on this arm have condition numbers of 1e5-1e6 even on
#: exact data (the default limit 1e4 rejects them all): it is solved at the ceiling.
POWER_MAX_CONDITION = 1e8


def trajectory(seed: int):
    return random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        max_position=1.0,
        rng=np.random.default_rng(seed),
    )


class Arm7:
    """The arm, its logs, the validation set and the well-identified parameters."""

    def __init__(self, duration: float = DURATION):
        self.robot = RobotModel.from_urdf(model_path("iiwa7"))
        self.smooth = RobotModel.from_urdf(model_path("iiwa7"), coulomb_width=WIDTH)
        self.truth = self.robot.base_values
        self.log, _ = exact_log(self.robot, trajectory(0), duration, H)
        self.tanh_log, _ = exact_log(self.robot, trajectory(0), duration, H, WIDTH)
        self.bandwidth = estimate_bandwidth(self.log.q, H)
        q, v, vdot = trajectory(1).evaluate(np.arange(0.0, 20.0, 0.01))
        self.check_rows = self.robot.idim_rows(q, v, vdot)
        self.check_rows_tanh = self.smooth.idim_rows(q, v, vdot)
        self.check_tau = drake_torques(self.robot, q, v, vdot)
        self.check_tau_tanh = drake_torques(self.robot, q, v, vdot, WIDTH)
        # The well-identified set: Gautier σ of IDIM-LS on the exact states every
        # 10 ms with SNR 30 dB torque noise (default_rng(0)) <= 5 % of the value.
        q, v, vdot = trajectory(0).evaluate(self.log.t[::10])
        noise = np.random.default_rng(0).standard_normal(q.shape)
        tau = self.log.tau[::10] + noise * self.log.tau.std(axis=0) * 10**-1.5
        rows = self.robot.idim_rows(q, v, vdot).reshape(-1, len(self.truth))
        reference = solve_least_squares(rows, tau.ravel())
        self.well = reference.std <= 0.05 * np.abs(self.truth)

    def settings(self, rows_from: str, model: str = "lagrangian") -> OnlineSettings:
        extra = {"max_condition": POWER_MAX_CONDITION} if model == "power" else {}
        return OnlineSettings.for_model(
            model, window=T, bandwidth=self.bandwidth, rows_from=rows_from, **extra
        )

    def noisy(self, level: str, seed: int, smooth: bool = False):
        q_std, snr = NOISE[level]
        log = self.tanh_log if smooth else self.log
        if snr is None:
            return log
        return with_noise(log, q_std, log.tau.std(axis=0) * 10 ** (-snr / 20), seed)

    def estimate(self, method: str, log, model=None):
        """``(θ̂, [σ, σ_Gautier], rows)`` of one method on one log."""
        model = self.robot if model is None else model
        self.condition = float("nan")
        if method == "off-line IDIM-LS":
            result = identify_offline(log, model)
            return result.theta, [result.std] * 3, "-"
        rows_from = method.split()[-1]
        kind = "power" if method.startswith("on-line power") else "lagrangian"
        if rows_from == "covariance":
            return self._covariance_estimate(log, model)
        if rows_from == "auto":
            rows_from = rows_from_noise(
                log.q,
                H,
                raw_window=self.settings("raw").on_grid(H).resolved("raw_window"),
                jacobi_window=self.settings("raw", kind).jacobi_window,
                bandwidth=self.bandwidth,
            )[0]
        settings = self.settings(rows_from, kind)
        if kind == "power":  # as dynid identify: σ_q measured, bias compensated
            noise = tuple(position_noise_std(log.q, H).tolist())
            settings = dataclasses.replace(settings, position_noise=noise)
        settings = settings.for_robot(H, 7, len(self.truth))
        a, b = window_equations(model, settings, log.q, log.tau, log.num_samples - 1, H)
        m = settings.num_equations(7)
        theta, stds = window_solves(a, b, settings, m, model.names)
        self.condition = float(np.linalg.cond(a / np.linalg.norm(a, axis=0)))
        return theta, stds, rows_from

    def _covariance_estimate(self, log, model):
        """The power model as ``dynid identify`` runs it (covariance weighting)."""
        settings = OnlineSettings.for_model(
            "power",
            window=T,
            bandwidth=self.bandwidth,
            rows_from="filtered",
            weighting="covariance",
            position_noise=tuple(position_noise_std(log.q, H).tolist()),
            torque_noise=tuple(torque_noise_std(log.tau, H).tolist()),
        ).for_robot(H, 7, len(self.truth))
        end = log.num_samples - 1
        a, b = window_equations(model, settings, log.q, log.tau, end, H)
        covariance = window_covariance_at(model, settings, log.q, log.tau, end, H)
        m = settings.num_equations(7)
        theta, stds = window_solves(
            a, b, settings, m, model.names, covariance=covariance
        )
        self.condition = float(np.linalg.cond(a / np.linalg.norm(a, axis=0)))
        return theta, stds, "filtered"

    def metrics(self, theta, smooth: bool = False) -> dict:
        """Errors over the well-identified set and the torque prediction [%]."""
        well = self.well
        error = 100 * np.abs(theta - self.truth)[well] / np.abs(self.truth[well])
        tau = self.check_tau_tanh if smooth else self.check_tau
        rows = self.check_rows_tanh if smooth else self.check_rows
        prediction = np.sqrt(((rows @ theta - tau) ** 2).mean(0) / (tau**2).mean(0))
        return {
            "median": float(np.median(error)),
            "max": float(np.max(error)),
            "torque": (100 * prediction).tolist(),
        }


def run(seeds, quick: bool = False) -> dict:
    """Every case of the section; returns the report (see the module docstring)."""
    arm = Arm7(duration=DURATION)
    methods = ["on-line filtered", "on-line raw"] + ([] if quick else ["on-line auto"])
    methods += ["on-line power auto", "on-line power covariance"]
    out: dict = {
        "well_identified": [
            n for n, w in zip(arm.robot.names, arm.well, strict=True) if w
        ],
        "bandwidth_hz": arm.bandwidth,
        "seeds": list(seeds),
        "cases": {},
    }
    levels = ["none", "encoder"] if quick else list(NOISE)
    for level in levels:
        for method in methods + ([] if quick else ["off-line IDIM-LS"]):
            runs = seeds if level != "none" else [0]
            if method.startswith("off-line") and level != "none":
                runs = list(seeds)[:3]  # 5 s per off-line run
            thetas, stds, gautier, sandwich, chosen, cond = [], [], [], [], [], []
            for seed in runs:
                theta, std, rows_from = arm.estimate(method, arm.noisy(level, seed))
                cond.append(arm.condition)
                thetas.append(theta)
                stds.append(std[0])
                gautier.append(std[1])
                sandwich.append(std[2])
                chosen.append(rows_from)
            per_run = [arm.metrics(theta) for theta in thetas]
            out["cases"][f"{level}|{method}"] = {
                "median": float(np.median([m["median"] for m in per_run])),
                "max": float(np.median([m["max"] for m in per_run])),
                "torque": np.median([m["torque"] for m in per_run], axis=0).tolist(),
                "honesty": honesty(thetas, stds, arm.truth),
                "honesty_gautier": honesty(thetas, gautier, arm.truth),
                "honesty_sandwich": honesty(thetas, sandwich, arm.truth),
                "rows": sorted(set(chosen)),
                "runs": len(runs),
                "condition": float(np.median(cond)),
            }
    # Smooth (tanh) friction, noise-free: the sign model against the tanh model.
    for label, model in (("sign model", arm.robot), ("tanh model", arm.smooth)):
        theta, _, _ = arm.estimate("on-line raw", arm.tanh_log, model)
        out["cases"][f"tanh friction|on-line raw, {label}"] = arm.metrics(
            theta, smooth=True
        )
    return out


def print_report(report: dict) -> None:
    cases = report["cases"]
    print(
        "\n## iiwa7 (7-DOF, Drake inverse dynamics, 60 s at 1 kHz, T = 20 s, band "
        f"{report['bandwidth_hz']:.2f} Hz): medians over seeds {report['seeds']}\n"
    )
    print(
        f"well identified ({len(report['well_identified'])}): "
        + ", ".join(report["well_identified"])
        + "\n"
    )
    print(
        "| noise | method | rows | median err % | max err % | torque prediction "
        "err % per joint | err/σ p90 | identified but > 30 % off per run | "
        "sandwich σ: err/σ p90 | Gautier σ: err/σ p90 | condition |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for key, c in cases.items():
        level, method = key.split("|")
        if level == "tanh friction":
            continue
        torque = " ".join(f"{x:.2f}" for x in c["torque"])
        print(
            f"| {level} | {method} | {'/'.join(c['rows'])} | {c['median']:.3f} | "
            f"{c['max']:.2f} | {torque} | {c['honesty']['p90']:.2f} | "
            f"{c['honesty']['false_per_run']:.1f} | "
            f"{c['honesty_sandwich']['p90']:.2f} | "
            f"{c['honesty_gautier']['p90']:.2f} | {c['condition']:.3g} |"
        )
    print("\nSmooth friction tanh(v/0.05), noise-free, raw rows:\n")
    print("| model | median err % | max err % | torque prediction err % per joint |")
    print("|---|---|---|---|")
    for key, c in cases.items():
        if key.startswith("tanh friction"):
            torque = " ".join(f"{x:.2f}" for x in c["torque"])
            print(
                f"| {key.split(', ')[-1]} | {c['median']:.3f} | {c['max']:.2f} | "
                f"{torque} |"
            )
