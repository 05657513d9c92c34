"""Payload section of the accuracy benchmark (``bench_accuracy.py --robot payload``).

A payload is picked at t = 3 s of a 5 s log; the arm's parameters are the URDF's
(known); the payload identifier (``drake_dynid.core.payload_replay``, the core of
the blocks) runs over the log. Truth: the payload given to Drake, never the
library's regressor.

* **iiwa7, exact**: ``random_fourier_trajectory`` (7 joints, 5 harmonics of
  0.1 Hz, |q̇| <= 1 rad/s, default_rng(5)) evaluated at 1 kHz, torques from
  Drake's ``CalcInverseDynamics`` + the URDF's Coulomb·sign(v), the payload added
  to ``iiwa_link_7``'s spatial inertia in the Context from the pick on: 2 kg,
  centre of mass (0.01, -0.02, 0.1) m, central inertia diag(0.01, 0.012, 0.008)
  kg·m² (the flange frame). "slow": the same with |q̇| <= 0.3 rad/s.
* **iiwa7, closed loop**: Drake simulates the arm (discrete plant, inverse-
  dynamics tracking that ignores the payload, Coulomb tanh(v/0.01), the arm's
  model with the same law) and the payload is added in the plant's Context at the
  pick (``simulate_identification`` events, as examples/payload_pick.py).
* **README example**: the same closed loop with examples/payload_pick.py's
  defaults: the pick at 4 s, σ_τ = 0.05 N·m on every joint (its
  ``--tau-noise``), estimated 1.5 s after the pick (the end of its log).
* **2R, exact**: the paper's arm (horizontal plane: only ZZ, MX, MY and M of the
  payload act), |q̇| <= 3 rad/s (5 harmonics of 0.2 Hz), 0.5 kg at
  (0.05, 0.02, 0) m on link 2.
* **UR5, Pinocchio** (when pinocchio and example-robot-data are installed):
  example-robot-data's ur5_robot.urdf, ``random_fourier_trajectory`` (6 joints, 5
  harmonics of 0.1 Hz, |q̇| <= 1 rad/s, default_rng(3)), torques from
  Pinocchio's RNEA, 1.5 kg at (0, 0.03, 0.05) m, central inertia
  diag(0.004, 0.005, 0.003) kg·m², on wrist_3_link.

Noise (seeded, default_rng(1000 + seed)): σ_q = 1e-4 rad and τ white with 1 % of
each joint's torque std (the 7-DOF benchmark's "encoder" level); "noise-free"
rows have none.

Metrics, medians over seeds: the time after the pick until the mass stays within
5 %; at the end of the log (the window 2 s after the pick), the mass error, the
centre-of-mass error |ĉ - c| [mm], the parameters flagged identified (%σ <= 30)
per run, the median relative error over them, err/σ p90 over them and the
identified parameters more than 30 % off per run (``_independent.honesty``'s
rule). Whether σ is honest, over **all** parameters (also those with %σ > 30),
per group (mass M; first moments MX, MY, MZ; inertia, the others): the RMS
error over seeds, median σ / RMS error, err/σ p90, and the σ spread across
seeds (largest σ / smallest, the worst parameter of the group). Methods: the
payload identifier's defaults (``payload_settings()``) and one change at a time, to
show what each default buys.
"""

from __future__ import annotations

import time

import numpy as np
from _independent import drake_torques

from drake_dynid.core.payload import payload_parameters, payload_rows
from drake_dynid.core.payload_replay import replay_payload_core
from drake_dynid.core.payload_step import payload_settings
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog
from drake_dynid.robot import RobotModel
from drake_dynid.urdf import model_path

H = 1e-3
PICK = 3.0
DURATION = 5.0
IIWA_PAYLOAD = (2.0, [0.01, -0.02, 0.1], np.diag([0.01, 0.012, 0.008]))
PLANAR_PAYLOAD = (0.5, [0.05, 0.02, 0.0], np.diag([0.001, 0.001, 0.002]))
#: examples/payload_pick.py's default --tau-noise [N·m] (the README's example).
README_TAU_NOISE = 0.05

METHODS = {
    "payload defaults": {},
    "window 0.5 s": {"window": 0.5},
    "window 1.0 s": {"window": 1.0},
    "filtered rows": {"rows_from": "filtered"},
    "bank step 10 ms": {"bank_time_step": 0.01},
    "ℓ = 0..7": {"frequencies": list(range(8))},
    "OLS + Gautier σ": {"weighting": "none", "uncertainty": "gautier"},
}


def _spatial(theta):
    from pydrake.multibody.tree import SpatialInertia, UnitInertia

    m = theta[9]
    g = theta[:6] / m
    return SpatialInertia(
        m, theta[6:9] / m, UnitInertia(g[0], g[3], g[5], g[1], g[2], g[4])
    )


def _torques_with(robot, q, v, vdot, body, theta):
    from pydrake.multibody.tree import MultibodyForces

    from drake_dynid.urdf import read_urdf_friction

    coulomb = read_urdf_friction(robot.path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    plant = robot.plant
    context = plant.CreateDefaultContext()
    target = plant.GetBodyByName(body)
    total = target.CalcSpatialInertiaInBodyFrame(context)
    total += _spatial(theta)
    target.SetSpatialInertiaInBodyFrame(context, total)
    out = np.empty_like(q)
    for k in range(len(q)):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        out[k] = plant.CalcInverseDynamics(context, vdot[k], forces)
    return out + fc * np.sign(v)


class Case:
    """One scenario: the robot, the payload's rows and truth, the noise-free log.

    ``pick``: the pick time [s]; ``tau_noise``: σ of the torque noise [N·m] on
    every joint (None: 1 % of each joint's torque std before the pick).
    """

    def __init__(self, label, robot, truth, q, tau, pick=PICK, tau_noise=None):
        self.label = label
        self.robot = robot
        self.rows = payload_rows(robot)
        self.truth = truth  # the payload's 10 standard parameters
        self.expected = self.rows.base.matrix @ truth
        self.q, self.tau = q, tau
        self.pick = pick
        before = tau[: round(pick / H)]
        self.tau_noise = 0.01 * before.std(axis=0) if tau_noise is None else tau_noise

    def log(self, seed: int | None) -> RobotLog:
        t = H * np.arange(len(self.q))
        q, tau = self.q, self.tau
        if seed is not None:
            noise = np.random.default_rng(1000 + seed).standard_normal((2, *q.shape))
            q = q + 1e-4 * noise[0]
            tau = tau + self.tau_noise * noise[1]
        return RobotLog(t, q, tau, self.robot.joint_names, H)


def exact_case(label, urdf, truth_args, body, harmonics_hz, max_velocity):
    robot = RobotModel.from_urdf(model_path(urdf))
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi * harmonics_hz,
        max_velocity=max_velocity,
        rng=np.random.default_rng(5),
    )
    t = H * np.arange(round(DURATION / H) + 1)
    q, v, vdot = trajectory.evaluate(t)
    truth = payload_parameters(*truth_args)
    pick = round(PICK / H)
    tau = np.vstack(
        [
            drake_torques(robot, q[:pick], v[:pick], vdot[:pick]),
            _torques_with(robot, q[pick:], v[pick:], vdot[pick:], body, truth),
        ]
    )
    return Case(label, robot, truth, q, tau)


def _example():
    """examples/payload_pick.py as a module (its payload event and constants)."""
    import importlib.util
    import pathlib

    path = pathlib.Path(__file__).parents[1] / "examples" / "payload_pick.py"
    spec = importlib.util.spec_from_file_location("payload_pick", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    return example


def closed_loop_case(
    label="iiwa7, closed loop", pick=PICK, duration=DURATION, tau_noise=None
):
    """The closed loop (module docstring).

    Also the README example, with its pick, end and absolute torque noise
    (``readme_example_case``).
    """
    from drake_dynid.simulation import SimulationSettings, simulate_identification

    example = _example()
    robot = RobotModel.from_urdf(model_path("iiwa7"), coulomb_width=0.01)
    truth = payload_parameters(*IIWA_PAYLOAD)
    trajectory = random_fourier_trajectory(
        7,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        rng=np.random.default_rng(5),
    )
    result = simulate_identification(
        robot,
        trajectory,
        SimulationSettings(duration=duration, snr_db=None, coulomb_smoothing=0.01),
        [],
        events=[(pick, example.payload_event("iiwa_link_7", truth))],
    )
    return Case(label, robot, truth, result.q_true, result.tau_true, pick, tau_noise)


def readme_example_case():
    """examples/payload_pick.py's defaults (the README's example).

    The closed loop with the pick at 4 s, σ_τ = 0.05 N·m on every joint (its
    ``--tau-noise``), estimated 1.5 s after the pick (the log ends there; the
    example's place at 7 s is not simulated).
    """
    pick = 4.0
    return closed_loop_case(
        "README example, 1.5 s after the pick", pick, pick + 1.5, README_TAU_NOISE
    )


UR5_URDF = "robots/ur_description/urdf/ur5_robot.urdf"
UR5_PAYLOAD = (1.5, [0.0, 0.03, 0.05], np.diag([0.004, 0.005, 0.003]))


def ur5_case():
    """The UR5 scenario (module docstring), or None without Pinocchio."""
    import pathlib

    try:
        import pinocchio as pin
    except ImportError:
        return None
    # The cmeel wheel of example-robot-data installs under pinocchio's prefix.
    prefix = pathlib.Path(pin.__file__).resolve().parents[4]
    path = prefix / "share" / "example-robot-data" / UR5_URDF
    if not path.exists():
        return None
    robot = RobotModel.from_urdf(str(path))
    names = robot.joint_names
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array([0.0, 0.0, -9.81])
    loaded = model.copy()
    joint = model.getJointId(names[-1])
    mass, com, inertia = UR5_PAYLOAD
    loaded.inertias[joint] = loaded.inertias[joint] + pin.Inertia(
        mass, np.array(com), inertia
    )
    index = [model.getJointId(name) - 1 for name in names]
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi * 0.1,
        max_velocity=1.0,
        rng=np.random.default_rng(3),
    )
    t = H * np.arange(round(DURATION / H) + 1)
    q, v, vdot = trajectory.evaluate(t)
    pick = round(PICK / H)
    tau = np.empty_like(q)
    data, data_loaded = model.createData(), loaded.createData()
    full = np.zeros((3, model.nq))
    for k in range(len(t)):
        full[:, index] = q[k], v[k], vdot[k]
        which, store = (loaded, data_loaded) if k >= pick else (model, data)
        tau[k] = pin.rnea(which, store, full[0], full[1], full[2])[index]
    return Case("UR5, Pinocchio", robot, payload_parameters(*UR5_PAYLOAD), q, tau)


def evaluate(case: Case, settings, seeds) -> dict:
    """The metrics of the module docstring over ``seeds`` (None: noise-free)."""
    names = case.rows.payload_names
    m_index = names.index("M")
    settle, mass_error, com_error, counts, errors, z, false = ([] for _ in range(7))
    final_theta, final_std = [], []
    for seed in seeds:
        trace = replay_payload_core(case.log(seed), case.rows, settings)
        mass = trace.theta[:, m_index]
        outside = np.flatnonzero(
            (trace.t >= case.pick) & (np.abs(mass / case.truth[9] - 1) > 0.05)
        )
        if outside.size and outside[-1] + 1 >= len(trace.t):
            settle.append(np.inf)
        else:
            settle.append(
                float(trace.t[outside[-1] + 1] - case.pick) if outside.size else 0.0
            )
        theta, std = trace.theta[-1], trace.std[-1]
        final_theta.append(theta)
        final_std.append(std)
        mass_error.append(100 * (theta[m_index] - case.truth[9]) / case.truth[9])
        if all(n in names for n in ("MX", "MY", "MZ")):
            h = np.array([theta[names.index(n)] for n in ("MX", "MY", "MZ")])
            com_error.append(
                1e3
                * np.linalg.norm(h / theta[m_index] - case.truth[6:9] / case.truth[9])
            )
        identified = std <= 0.3 * np.abs(theta)
        error = np.abs(theta - case.expected)
        counts.append(int(identified.sum()))
        errors.append(
            float(
                np.median(100 * error[identified] / np.abs(case.expected[identified]))
            )
            if identified.any()
            else np.nan
        )
        z.extend((error / std)[identified])
        false.append(int((identified & (error > 0.3 * np.abs(case.expected))).sum()))
    return {
        "settle_s": float(np.median(settle)),
        "settle_max_s": float(np.max(settle)),
        "mass_error_percent": float(np.median(np.abs(mass_error))),
        "com_error_mm": float(np.median(com_error)) if com_error else None,
        "identified_per_run": float(np.mean(counts)),
        "identified_error_percent": float(np.nanmedian(errors)),
        "err_sigma_p90": float(np.percentile(z, 90)) if z else float("nan"),
        "false_per_run": float(np.mean(false)),
        "names": list(names),
        **honesty_all(names, case.expected, np.array(final_theta), np.array(final_std)),
    }


def groups(names) -> dict[str, list[int]]:
    """Indices of the mass, the first moments and the inertia parameters."""
    out: dict[str, list[int]] = {}
    for i, name in enumerate(names):
        key = "mass" if name == "M" else "moments" if name[0] == "M" else "inertia"
        out.setdefault(key, []).append(i)
    return out


def honesty_all(names, expected, theta, std) -> dict:
    """σ against the seeds' errors over all parameters (module docstring)."""
    error = theta - expected
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.abs(error) / std
    rms = np.sqrt(np.mean(error**2, axis=0))
    out = {"err_sigma_p90_all": float(np.percentile(z, 90)), "groups": {}}
    if len(theta) < 2:
        return out
    for key, index in groups(names).items():
        out["groups"][key] = {
            "rms": float(np.median(rms[index])),
            "sigma_over_rms": float(
                np.median(np.median(std[:, index], 0) / rms[index])
            ),
            "err_sigma_p90": float(np.percentile(z[:, index], 90)),
            "sigma_spread": float(np.max(std[:, index].max(0) / std[:, index].min(0))),
        }
    return out


def run(seeds, quick: bool = False) -> dict:
    start = time.perf_counter()
    cases = [
        exact_case("iiwa7, exact", "iiwa7", IIWA_PAYLOAD, "iiwa_link_7", 0.1, 1.0),
    ]
    if not quick:
        cases += [
            exact_case(
                "iiwa7, exact, slow", "iiwa7", IIWA_PAYLOAD, "iiwa_link_7", 0.1, 0.3
            ),
            closed_loop_case(),
            readme_example_case(),
            exact_case("2R, exact", "planar_2r", PLANAR_PAYLOAD, "link2", 0.2, 3.0),
        ]
        ur5 = ur5_case()
        if ur5 is not None:
            cases.append(ur5)
    results: dict = {}
    methods = METHODS if not quick else {"payload defaults": {}}
    for case in cases:
        chosen = methods if case.label == "iiwa7, exact" else {"payload defaults": {}}
        for name, overrides in chosen.items():
            settings = payload_settings(**overrides)
            results[f"{case.label}|{name}"] = evaluate(case, settings, list(seeds))
        results[f"{case.label}|payload defaults, noise-free"] = evaluate(
            case, payload_settings(), [None]
        )
        if case.label == "iiwa7, exact" and not quick:
            for name in ("filtered rows", "bank step 10 ms"):
                results[f"{case.label}|{name}, noise-free"] = evaluate(
                    case, payload_settings(**METHODS[name]), [None]
                )
    return {
        "seeds": list(seeds),
        "pick_s": PICK,
        "duration_s": DURATION,
        "cases": results,
        "wall_s": time.perf_counter() - start,
    }


def print_report(report: dict) -> None:
    print(
        f"\n## Payload identification (pick at {PICK:g} s, estimate at {DURATION:g} s "
        "unless the scenario says otherwise; "
        f"medians over seeds {report['seeds']}; noise σ_q = 1e-4 rad, 1 % of τ std)\n"
    )
    print(
        "| scenario | method | time to 5 % of the mass [s] (max) | mass err % | "
        "c err [mm] | identified / run | err % of identified | err/σ p90 | "
        "identified but > 30 % off / run |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for key, c in report["cases"].items():
        label, method = key.split("|")
        com = "-" if c["com_error_mm"] is None else f"{c['com_error_mm']:.2f}"
        print(
            f"| {label} | {method} | {c['settle_s']:.2f} ({c['settle_max_s']:.2f}) | "
            f"{c['mass_error_percent']:.3f} | {com} | {c['identified_per_run']:.1f} of "
            f"{len(c['names'])} | {c['identified_error_percent']:.2f} | "
            f"{c['err_sigma_p90']:.2f} | {c['false_per_run']:.2f} |"
        )
    print(
        "\nσ over all parameters (also %σ > 30), payload defaults, at the end of the "
        "log: per group the RMS error over seeds, median σ / RMS error, err/σ p90 and "
        "the σ spread across seeds (max σ / min σ, worst parameter of the group)\n"
    )
    print(
        "| scenario | err/σ p90, all | mass: RMS, σ/RMS, p90, spread | first moments | "
        "inertia |"
    )
    print("|---|---|---|---|---|")
    for key, c in report["cases"].items():
        label, method = key.split("|")
        if method != "payload defaults" or not c.get("groups"):
            continue
        cells = []
        for group in ("mass", "moments", "inertia"):
            g = c["groups"].get(group)
            cells.append(
                "-"
                if g is None
                else f"{g['rms']:.2g}, {g['sigma_over_rms']:.2f}, "
                f"{g['err_sigma_p90']:.2f}, {g['sigma_spread']:.1f}"
            )
        print(f"| {label} | {c['err_sigma_p90_all']:.2f} | " + " | ".join(cells) + " |")
    print(f"\n(payload section: {report['wall_s']:.0f} s)")
