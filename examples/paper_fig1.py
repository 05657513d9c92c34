"""Paper Fig. 1: one joint, ZZ q̈ + Fv q̇ + Fc sign(q̇) = τ, modulating functions, T = 4 s.

The paper's introductory example (§II-A): a single revolute joint
(``models/one_joint.urdf``: ZZ = 3 kg·m², Fv = 0.4 N·m·s/rad, Fc = 0.5 N·m) follows an
exciting trajectory in a Drake simulation at 1 kHz; white Gaussian noise at SNR 40 dB is
added to the measured q and τ. Two on-line estimators slide a T = 4 s window:

* the paper's form, order-2 Fourier modulating functions g_ℓ, ℓ = i/50, i = 1..200,
  integrating by parts twice so that only q (and sign q̇) is needed::

      ZZ·M_g̈(q) - Fv·M_ġ(q) + Fc·M_g(sign q̇) = M_g(τ)

  computed with the core's sliding integrals on the recorded log (q, sign q̇ and τ
  from the matched causal Jacobi differentiator, so they refer to one instant);
* the library's blocks in the loop (Lagrangian model, order-1 modulating functions,
  causal Jacobi velocity).

Prints the estimates at the end and writes ``fig1_estimates.png`` (estimates over
time; the paper: meaningless for t < T, then ZZ well estimated, Fv and Fc noisier).
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np
from _example import run_example

from drake_dynid.core import lsq, modulating
from drake_dynid.core.friction import friction_column
from drake_dynid.core.jacobi import jacobi_batch, jacobi_filters
from drake_dynid.core.trajectory import FourierTrajectory
from drake_dynid.diagrams import (
    OnlineSettings,
    SimulationSettings,
    simulate_identification,
)
from drake_dynid.plants import RobotModel, model_path


def one_joint_trajectory(max_velocity: float = 3.0) -> FourierTrajectory:
    """q(t) = Σ_l a_l/(lω) sin(lωt) - b_l/(lω) cos(lωt), ω = 2π/20 s, l = 5..30.

    Coefficients ~ N(0, 1)/√l from ``default_rng(1)``, scaled to max |q̇| =
    ``max_velocity`` [rad/s]: content at 0.25-1.5 Hz, where the bank looks.
    """
    rng = np.random.default_rng(1)
    harmonics = np.arange(1, 31)
    weight = (harmonics >= 5) / np.sqrt(harmonics)
    a = rng.normal(size=(1, 30)) * weight
    b = rng.normal(size=(1, 30)) * weight
    omega = 2 * np.pi / 20.0
    unit = FourierTrajectory(np.zeros(1), a, b, omega)
    _, v, _ = unit.evaluate(np.arange(0.0, 20.0, 1e-3))
    scale = max_velocity / np.abs(v).max()
    return FourierTrajectory(np.zeros(1), a * scale, b * scale, omega)


def paper_form_estimates(t, q, tau, window, update_period, jacobi):
    """Sliding estimates of [ZZ, Fv, Fc] with the paper's k = 2 equation.

    Returns (times, theta (M, 3), valid (M,)).
    """
    h = float(t[1] - t[0])
    f0, f1 = jacobi
    q_hat = jacobi_batch(f0, q[:, 0])
    v_hat = jacobi_batch(f1, q[:, 0])
    tau_hat = jacobi_batch(f0, tau[:, 0])
    coulomb = friction_column("coulomb", v_hat)  # sign(v̂), the identification law
    channels = np.column_stack([q_hat, coulomb, tau_hat])
    ell = np.arange(1, 201) / 50.0
    bank = modulating.fourier_bank(window, h, order=2, ell=ell)
    state = modulating.sliding_init(bank, 3)
    step = round(update_period / h)
    ready = f0.num_taps - 1  # the differentiator has filled
    times, thetas, valids = [], [], []
    for start in range(0, len(t), step):
        block = channels[start : start + step]
        flags = np.arange(start, start + len(block)) >= ready
        state = modulating.sliding_push_many(bank, state, block, valid=flags)
        theta = np.full(3, np.nan)
        valid = False
        if modulating.window_valid(state):
            F = modulating.sliding_fourier_integrals(bank, state)
            g2 = modulating.modulated_integrals(bank, F[:, 0], derivative=2)
            g1 = modulating.modulated_integrals(bank, F[:, 0], derivative=1)
            g0 = modulating.modulated_integrals(bank, F[:, 1:], derivative=0)
            lhs = np.column_stack([g2, -g1, g0[:, 0]])
            A = np.vstack([lhs.real, lhs.imag])
            B = np.concatenate([g0[:, 1].real, g0[:, 1].imag])
            result = lsq.solve_least_squares(A, B, names=("ZZ", "Fv", "Fc"))
            theta, valid = result.theta, result.valid
        times.append(t[min(start + len(block), len(t)) - 1])
        thetas.append(theta)
        valids.append(valid)
    return np.array(times), np.array(thetas), np.array(valids)


#: --quick's presets: defaults that an explicit option overrides.
QUICK = {"duration": 6.0}


def main(argv=None) -> int:
    """Runs the example; returns 0."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seed", type=int, default=1, help="noise seed (default 1)")
    parser.add_argument("--snr", type=float, default=40.0, help="SNR [dB] (40)")
    parser.add_argument("--duration", type=float, default=20.0, help="[s] (20)")
    parser.add_argument("--out", default="out", help="output folder (out/)")
    parser.add_argument(
        "--quick", action="store_true", help="tiny run for tests (--duration 6)"
    )
    return run_example(parser, argv, _run, QUICK)


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The example with parsed arguments; returns 0 (``parser.error`` exits 2)."""
    if not np.isfinite(args.snr):
        parser.error(f"--snr must be a finite SNR [dB]; got {args.snr}")
    if not args.duration > 0:
        parser.error("--duration must be > 0")
    duration = args.duration
    window = 4.0
    try:  # a file of that name (or under one) was a FileExistsError traceback
        os.makedirs(args.out, exist_ok=True)
    except OSError as error:
        parser.error(f"--out {args.out}: not a folder ({error.strerror})")
    robot = RobotModel.from_urdf(model_path("one_joint"))
    settings = OnlineSettings.for_model(
        "lagrangian", window=window, bandwidth=1.5, update_period=0.1
    )
    result = simulate_identification(
        robot,
        one_joint_trajectory(),
        SimulationSettings(duration=duration, snr_db=args.snr, seed=args.seed),
        [settings],
        progress=sys.stderr.isatty(),
    )
    jacobi = jacobi_filters(
        (0, 1),
        settings.jacobi_window,
        1e-3,
        kappa=settings.kappa,
        mu=settings.mu,
        q=settings.jacobi_q,
        matched=True,
    )
    t_paper, theta_paper, valid_paper = paper_form_estimates(
        result.t, result.q, result.tau, window, 0.1, jacobi
    )
    trace = result.traces[0]
    truth = robot.base_values
    print(
        f"one joint, SNR {args.snr:g} dB on q and tau (seed {args.seed}), "
        f"T = {window:g} s"
    )
    print("| | ZZ | Fv | Fc |\n|---|---|---|---|")
    print("| true | " + " | ".join(f"{x:.4g}" for x in truth) + " |")
    print(
        "| paper form (k = 2) | "
        + " | ".join(f"{x:.4g}" for x in theta_paper[-1])
        + " |"
    )
    print(
        "| Lagrangian blocks (k = 1) | "
        + " | ".join(f"{x:.4g}" for x in trace.final()["theta"])
        + " |"
    )

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4))
    shown = np.where(valid_paper[:, None], theta_paper, np.nan)
    blocks = np.where(trace.valid[:, None] > 0, trace.theta, np.nan)
    axes[0].plot(t_paper, shown[:, 0], label="ZZ, paper form (k = 2)")
    axes[0].plot(trace.t, blocks[:, 0], label="ZZ, Lagrangian blocks")
    axes[0].axhline(truth[0], color="k", ls="--", lw=1, label="real ZZ")
    axes[0].set_ylim(2.5, 3.5)
    for index, name in ((1, "Fv"), (2, "Fc")):
        (line,) = axes[1].plot(t_paper, shown[:, index], label=f"{name}, paper form")
        axes[1].plot(
            trace.t,
            blocks[:, index],
            ls=":",
            color=line.get_color(),
            label=f"{name}, blocks",
        )
        axes[1].axhline(truth[index], color=line.get_color(), ls="--", lw=1)
    axes[1].set_ylim(0.2, 0.7)
    for ax in axes:
        ax.set_xlabel("t [s]")
        ax.set_xlim(0.0, duration)
        ax.legend(fontsize=7)
    fig.suptitle(f"Fig. 1: one joint, SNR {args.snr:g} dB, T = {window:g} s")
    fig.tight_layout()
    path = os.path.join(args.out, "fig1_estimates.png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
