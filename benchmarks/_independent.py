"""Independent logs and uncertainty metrics for the accuracy benchmark (not a script).

An independent log evaluates a trajectory exactly (``FourierTrajectory.evaluate``:
no simulation, no filtering) and computes its torques with Drake's own inverse
dynamics, ``MultibodyPlant.CalcInverseDynamics`` with the plant's force elements
(gravity, the URDF damping = viscous friction), plus the URDF's Coulomb friction
``FC·s(v)`` with s = sign or tanh(v/W): never the library's regressor.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drake_dynid.logs import RobotLog
from drake_dynid.urdf import read_urdf_friction


def drake_torques(robot: Any, q, v, vdot, width: float = 0.0) -> np.ndarray:
    """Drake's inverse dynamics (gravity, damping) + URDF Coulomb·s(v), (N, n).

    ``width`` W > 0: s(v) = tanh(v/W) [rad/s], else sign(v).
    """
    from pydrake.multibody.tree import MultibodyForces

    coulomb = read_urdf_friction(robot.path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    plant = robot.plant
    context = plant.CreateDefaultContext()
    out = np.empty_like(np.asarray(q, dtype=float))
    for k in range(len(q)):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        out[k] = plant.CalcInverseDynamics(context, vdot[k], forces)
    sign = np.tanh(v / width) if width > 0.0 else np.sign(v)
    return out + fc * sign


def exact_log(
    robot: Any, trajectory: Any, duration: float, time_step: float, width: float = 0.0
) -> tuple[RobotLog, np.ndarray]:
    """``(log, v)``: the trajectory sampled every ``time_step`` and its torques."""
    t = time_step * np.arange(round(duration / time_step) + 1)
    q, v, vdot = trajectory.evaluate(t)
    tau = drake_torques(robot, q, v, vdot, width)
    return RobotLog(t, q, tau, robot.joint_names, time_step), v


def with_noise(log: RobotLog, q_std, tau_std, seed: int) -> RobotLog:
    """The log plus white noise N(0, std²) per channel, ``default_rng(1000 + seed)``."""
    rng = np.random.default_rng(1000 + seed)
    noise = rng.standard_normal((2, *log.q.shape))
    return RobotLog(
        log.t,
        log.q + np.asarray(q_std) * noise[0],
        log.tau + np.asarray(tau_std) * noise[1],
        log.joint_names,
        log.time_step,
    )


def z_scores(estimates, stds, truth) -> np.ndarray:
    """|θ̂ - θ|/σ of every parameter of every run (invalid runs dropped)."""
    estimates, stds = np.asarray(estimates), np.asarray(stds)
    ok = np.isfinite(estimates).all(axis=1)
    return np.abs(estimates[ok] - truth) / stds[ok]


def honesty(estimates, stds, truth) -> dict[str, float]:
    """err/σ percentiles over all parameters and runs, and the false claims.

    ``p90``: 90th percentile of |θ̂ - θ|/σ (1.64 for a Gaussian error with an honest
    σ); ``false_per_run``: parameters flagged identified (%σ <= 30) while more than
    30 % (of a non-zero true value) off, per run.
    """
    z = z_scores(estimates, stds, truth)
    estimates, stds = np.asarray(estimates), np.asarray(stds)
    ok = np.isfinite(estimates).all(axis=1)
    estimates, stds = estimates[ok], stds[ok]
    flagged = stds <= 0.3 * np.abs(estimates)
    off = np.abs(estimates - truth) > 0.3 * np.abs(truth)
    false = (flagged & off & (truth != 0)).sum(axis=1)
    return {
        "p50": float(np.percentile(z, 50)) if z.size else float("nan"),
        "p90": float(np.percentile(z, 90)) if z.size else float("nan"),
        "false_per_run": float(np.mean(false)) if false.size else float("nan"),
    }


#: The σ of the identifier's settings (``OnlineSettings.uncertainty``) compared by
#: the benchmark, in the order :func:`window_solves` returns them.
SIGMAS = ("jackknife", "gautier", "sandwich")


def window_solves(
    a, b, settings: Any, m: int, names, bank: Any = None, covariance: Any = None
):
    """``(θ̂, [σ for each of SIGMAS])`` of one window's equations ``a θ = b``.

    The identifier's solve (``core.weighted_lsq.solve_window``, the settings'
    weighting) with each uncertainty: the default (the larger of the sandwich σ and
    the jackknife's), Gautier's alone and the sandwich σ alone; NaN when a solve is
    not valid. θ̂ is the default's. With ``covariance`` (θ -> Σ of the rows, the
    covariance weighting): the default σ is the larger of the generalised least
    squares' and the jackknife's on the whitened rows, the other two the GLS σ.
    """
    import dataclasses

    from drake_dynid.core.weighted_lsq import solve_window

    nan = np.full(len(names), np.nan)
    bank = settings.bank() if bank is None else bank
    if covariance is not None:  # default: with the jackknife; then the GLS σ alone
        stds = []
        for groups in (settings.jackknife_groups(m, bank), None):
            res = solve_window(
                a,
                b,
                max_condition=settings.max_condition,
                names=names,
                covariance=covariance,
                jackknife=groups,
            )
            stds.append(res.std if res.valid else nan)
        theta = res.theta if res.valid else nan
        return theta, [stds[0], stds[1], stds[1]]
    theta, stds = None, []
    for kind in SIGMAS:
        s = dataclasses.replace(settings, uncertainty=kind)
        res = solve_window(
            a,
            b,
            s.row_weighting(m, bank),
            max_condition=s.max_condition,
            names=names,
            noise=s.row_noise(m, bank),
            jackknife=s.jackknife_groups(m, bank),
        )
        nan = np.full(len(names), np.nan)
        if theta is None:
            theta = res.theta if res.valid else nan
        stds.append(res.std if res.valid else nan)
    return theta, stds
