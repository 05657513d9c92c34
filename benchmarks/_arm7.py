"""7-DOF pipeline cases of bench_pipeline.py (a helper, not a benchmark itself).

* :func:`arm_log`: a periodic random Fourier motion of the iiwa7 (numpy
  default_rng(5), 5 harmonics of 0.1 Hz, |v| <= 1.5 rad/s: every base parameter
  excited within a 20 s window), τ from the inverse-dynamics rows with the URDF's
  base values, one 10 s period tiled, white noise on q (1e-4 rad) and τ (1 % of
  its std) from default_rng(0).
* :func:`run_case`: one case in a fresh Python process, with its own peak memory:
  the process's resident high-water mark (``VmHWM`` of /proc/self/status on
  Linux, where ``resource.getrusage(RUSAGE_SELF).ru_maxrss`` keeps the parent's
  peak across fork and exec; ``ru_maxrss`` elsewhere): ``dynid offline``/
  ``identify`` on a CSV log, the Pinocchio + scipy reference, or the off-line API
  on a long log built in memory.
* :data:`REFERENCE`: the off-line IDIM of drake_dynid written straightforwardly
  with Pinocchio and scipy (the comparison of issue 15): np.loadtxt, zero-phase
  Butterworth of q (``sosfiltfilt``, order 4, the same cutoff), central
  differences, ``pin.computeJointTorqueRegressor`` at every sample, friction
  columns [v, sign v], the same parallel decimation (order-8 zero-phase
  Butterworth at the same f_d, one sample in D, same trim), base columns by a
  pivoted QR of regressor rows at random states, ``scipy.linalg.lstsq``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np

from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import write_log

PERIOD = 10.0
H = 1e-3

# Runs one case; prints {"seconds": in-process wall, "peak_mb": ru_maxrss, ...}.
_RUNNER = r"""
import json, os, resource, sys, time
start = time.perf_counter()
from drake_dynid.core._threads import configure_process
configure_process()  # dynid's settings for every case, the reference included
case = json.loads(sys.argv[1])
out = {}
if case["kind"] == "cli":
    from drake_dynid.cli import main
    code = main(case["argv"])
    assert code == 0, code
elif case["kind"] == "reference":
    sys.path.insert(0, case["benchmarks"])
    from _arm7 import reference_offline
    out = reference_offline(**case["args"])
elif case["kind"] == "api":
    sys.path.insert(0, case["benchmarks"])
    from _arm7 import api_offline
    out = api_offline(case["duration"], case["step"])
out["seconds"] = time.perf_counter() - start
# CPU time of the process and its children (identify's forked log read, bootstrap).
times = os.times()
out["cpu"] = times.user + times.system + times.children_user + times.children_system
children = resource.getrusage(resource.RUSAGE_CHILDREN)
out["children_peak_mb"] = children.ru_maxrss / 1024.0
out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
try:  # Linux keeps the parent's high-water mark in ru_maxrss across exec
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmHWM:"):
                out["peak_mb"] = float(line.split()[1]) / 1024.0
except OSError:
    pass
print(json.dumps(out))
"""


def arm_samples(robot, duration: float):
    """(t, q, tau) of :func:`arm_log`, without writing it."""
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi / PERIOD,
        max_velocity=1.5,
        rng=np.random.default_rng(5),
    )
    q1, v1, a1 = trajectory.evaluate(H * np.arange(round(PERIOD / H)))
    tau1 = robot.idim_rows(q1, v1, a1) @ robot.base_values
    count = round(duration / H) + 1
    repeats = -(-count // len(q1))
    rng = np.random.default_rng(0)
    q = np.tile(q1, (repeats, 1))[:count]
    q += 1e-4 * rng.normal(size=q.shape)
    tau = np.tile(tau1, (repeats, 1))[:count]
    tau += 0.01 * tau1.std(axis=0) * rng.normal(size=tau.shape)
    return H * np.arange(count), q, tau


def arm_log(robot, duration: float, path: str) -> None:
    """Writes the 7-DOF benchmark log of ``duration`` seconds to ``path``."""
    t, q, tau = arm_samples(robot, duration)
    write_log(path, t, q, tau, robot.joint_names)


def run_case(case: dict) -> dict:
    """Runs ``case`` in a fresh process; adds ``wall`` (end to end, start included)."""
    case = {**case, "benchmarks": str(__import__("pathlib").Path(__file__).parent)}
    # As installed: modules load from cached bytecode (an environment that sets
    # PYTHONDONTWRITEBYTECODE would compile every module of every run).
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", _RUNNER, json.dumps(case)],
        check=True,
        capture_output=True,
        text=True,
        env=env,
    )
    wall = time.perf_counter() - start
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["wall"] = wall
    return out


def _memory(field: str) -> float:
    """``VmRSS``/``VmHWM`` of this process [MB] (NaN where /proc is missing)."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith(field + ":"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def _reset_peak() -> bool:
    """Resets VmHWM to the current RSS (Linux >= 4.0: clear_refs 5)."""
    try:
        with open("/proc/self/clear_refs", "w") as handle:
            handle.write("5")
        return True
    except OSError:
        return False


def api_offline(duration: float, step: str) -> dict:
    """identify_offline or the core replay on a long log built in memory.

    The peak of the step is the resident high-water mark after a reset, with the
    log's arrays resident; ``working_mb`` is that peak minus the resident size
    before the step (what the step itself adds).
    """
    import gc

    from drake_dynid.commands.identify import measured_bandwidth
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.core.replay import replay_log_core
    from drake_dynid.logs import RobotLog
    from drake_dynid.offline import identify_offline
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(model_path("iiwa7"))
    t, q, tau = arm_samples(robot, duration)
    log = RobotLog(t, q, tau, robot.joint_names, H)
    out: dict = {"log_mb": (t.nbytes + q.nbytes + tau.nbytes) / 1e6}
    gc.collect()
    before = _memory("VmRSS")
    reset = _reset_peak()
    start = time.perf_counter()
    if step == "offline":
        valid = identify_offline(log, robot).valid
    else:
        settings = OnlineSettings.for_model(
            "lagrangian", bandwidth=measured_bandwidth(log, 20.0)
        )
        (trace,) = replay_log_core(log, robot, [settings])
        valid = bool(trace.valid[-1] > 0.5)
    out["step_seconds"] = time.perf_counter() - start
    out["valid"] = bool(valid)
    out["rss_before_mb"] = before
    if reset:
        out["step_peak_mb"] = _memory("VmHWM")
        out["working_mb"] = out["step_peak_mb"] - before
    return out


def reference_offline(
    path: str,
    urdf: str,
    cutoff_hz: float,
    decimation_cutoff_hz: float,
    decimation: int,
    trim: int,
) -> dict:
    """The Pinocchio + scipy off-line IDIM (module docstring); returns its timings."""
    import pinocchio as pin
    from scipy import linalg, signal

    start = time.perf_counter()
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    model = pin.buildModelFromUrdf(urdf)
    pdata = model.createData()
    n = model.nv
    q, tau = data[:, 1 : 1 + n], data[:, 1 + n : 1 + 2 * n]
    h = float(np.median(np.diff(data[:, 0])))
    sos = signal.butter(4, cutoff_hz, fs=1.0 / h, output="sos")
    q_f = signal.sosfiltfilt(sos, q, axis=0)
    v = (q_f[2:] - q_f[:-2]) / (2 * h)
    a = (q_f[2:] - 2 * q_f[1:-1] + q_f[:-2]) / h**2
    q_f, tau = q_f[1:-1], tau[1:-1]
    load = time.perf_counter()
    W = np.empty((len(q_f), n, 10 * n + 2 * n))
    for k in range(len(q_f)):
        W[k, :, : 10 * n] = pin.computeJointTorqueRegressor(
            model, pdata, q_f[k], v[k], a[k]
        )
    W[:, :, 10 * n :] = 0.0
    for j in range(n):
        W[:, j, 10 * n + 2 * j] = v[:, j]
        W[:, j, 10 * n + 2 * j + 1] = np.sign(v[:, j])
    rows = time.perf_counter()
    sos = signal.butter(8, 2.0 * decimation_cutoff_hz * h, output="sos")
    columns = np.concatenate([W.reshape(len(W), -1), tau], axis=1)
    filtered = signal.sosfiltfilt(sos, columns, axis=0)[trim:-trim:decimation]
    W_d = filtered[:, : W[0].size].reshape(-1, n, W.shape[2])
    tau_d = filtered[:, W[0].size :]
    rng = np.random.default_rng(0)
    probe = []
    for _ in range(40):
        qs, vs, as_ = rng.uniform(-np.pi, np.pi, n), *rng.normal(size=(2, n))
        block = np.zeros((n, W.shape[2]))
        block[:, : 10 * n] = pin.computeJointTorqueRegressor(model, pdata, qs, vs, as_)
        block[:, 10 * n :] = np.kron(np.eye(n), [1.0, 1.0])
        probe.append(block)
    probe = np.vstack(probe)
    probe /= np.maximum(np.linalg.norm(probe, axis=0), 1e-300)
    _, r_factor, order = linalg.qr(probe, pivoting=True, mode="economic")
    diagonal = np.abs(np.diag(r_factor))
    base = np.sort(order[diagonal > 1e-8 * diagonal[0]])
    A = W_d[:, :, base].reshape(-1, base.size)
    theta, *_ = linalg.lstsq(A, tau_d.reshape(-1))
    residual = tau_d.reshape(-1) - A @ theta
    end = time.perf_counter()
    return {
        "load_filter_seconds": load - start,
        "rows_seconds": rows - load,
        "solve_seconds": end - rows,
        "num_base": int(base.size),
        "residual_std": float(np.sqrt(residual @ residual / (len(A) - base.size))),
    }
