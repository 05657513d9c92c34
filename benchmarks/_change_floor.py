"""The floor of the Fig. 4 tracking: ZZ1R within 2 % how soon after the jump?

Not a script. The change detection (``core.change``) tracks the paper's Fig. 4
jump (ZZ1R 3.9 -> 4.5 at 9.4 s, SNR 30 dB on q and τ) within 2 % about 1.4 s
after it; issue 16 asked for 1 s. Two floors that need no detection, on the
recorded noise-free log of ``_change.jump_tracking`` (Drake, closed loop):

1. **Cramér-Rao bound** of ZZ1R after the change, the change time and every
   other parameter known: white noise of the benchmark's σ on every q and τ
   sample (1 kHz) from ``before`` seconds ahead of the change to ``age`` after
   it; each joint's path a Legendre polynomial of degree ``degree`` over that
   span plus (t - t_c)₊² … (t - t_c)₊⁴ (the acceleration may jump at the
   change), nuisance parameters. τ = W(q, q̇, q̈) θ with W the 2R's inverse
   dynamics rows (``rows.idim_rows``, equal to Drake's inverse dynamics:
   tests/test_plants.py), ZZ1R's column q̈₁ in joint 1 after t_c. The bound
   is what any unbiased estimator can reach; the ±2 % band needs σ ≲ 1 %.
2. **Oracle estimators**: the change time known, no detection; the core's bank
   samples (the matched Jacobi filters, T = 7 s settings) of noise seed s
   (``_change._noisy``). At every 50 ms after the change, ZZ1R from the data up
   to then; "settle": the time after the jump from which it stays within 2 %
   (to 3 s after the jump). The estimators, all on the polynomial segments of
   ``core.segment`` (M = max(4, 4/s) functions):

   * *since the change*: the restart of ``core.change``: the segment from the
     change + the bank samples' delay, ZZ1R alone re-estimated;
   * *step, whitened*: 1 s before the change is added to the segment and ZZ1R
     enters as a step at t_c (the segment's functions on the data after t_c and
     the jump of the momentum); the equations of each function are whitened by
     the covariance across equations of the residual before the change (the
     same position noise enters both equations: it halves the σ of ZZ1R at
     0.5 s). With the other parameters at their true values, or at the sliding
     window's estimate at t_c (the realistic case);
   * *step, all free*: the whole stored window (7 s), every parameter free plus
     ZZ1R's step, whitened.

3. **A step test instead of the CUSUM** (not kept in the library: no faster at
   the same false alarms): at every solve (50 ms) the residual of the last
   T_d = 1.5 s (6 functions) against the sliding window's estimate, whitened per
   function by the learned mean squares and the correlation across equations
   (warm-up 2 s, then an exponential average of 7 s), and for every parameter
   and every candidate change 0.2 … 0.8 s back (every 40 ms) the generalised
   likelihood ratio of a step, z = (aᵀr)²/(aᵀa) on the whitened rows (a the
   step column above). Alarms at level h: episodes of z > h more than 2 s apart
   (a detection's segment lasts at least that long) on the logs without a
   change of ``_change.false_alarms_2r``, same seeds; the delay: the first
   solve after the Fig. 4 jump with z > h.
"""

from __future__ import annotations

import dataclasses

import _change
import numpy as np
from numpy.polynomial import legendre

from drake_dynid import paper
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import bank_channels, filtered_signals, replay_log_core
from drake_dynid.core.segment import segment_equations, segment_functions

H = 1e-3
JUMP = _change.JUMP
TOLERANCE = 0.02
AGES = np.round(np.arange(0.3, 3.0001, 0.05), 3)


# ---------------------------------------------------------------- Cramér-Rao


def crlb(
    result,
    rows,
    truth,
    ages=(0.2, 0.3, 0.5, 0.7, 1.0),
    before=1.0,
    degree=12,
    exact_positions=False,
):
    """σ of ZZ1R after the change [% of 4.5] per age (module docstring, 1).

    ``exact_positions``: the noise on τ only (σ_q = 1e-7 rad).
    """
    theta_before = np.asarray(truth, dtype=float)
    theta_after = theta_before.copy()
    theta_after[0] += 0.6
    sigma = np.array(result.noise_std, dtype=float)  # q1, q2, τ1, τ2
    if exact_positions:
        sigma[:2] = 1e-7
    t = result.t
    q = result.q_true
    v = np.gradient(q, H, axis=0)
    a = np.gradient(v, H, axis=0)

    def torques(qq, vv, aa, after):
        W = rows.idim_rows(qq, vv, aa)  # (N, 2, p)
        th = np.where(after[:, None], theta_after, theta_before)
        return np.einsum("nmp,np->nm", W, th), W

    out = []
    for age in ages:
        span = (t >= JUMP - before) & (t <= JUMP + age)
        tt, qq, vv, aa = t[span], q[span], v[span], a[span]
        after = tt >= JUMP
        width = tt[-1] - tt[0]
        x = 2.0 * (tt - tt[0]) / width - 1.0
        eye = np.eye(degree + 1)
        basis = [legendre.legval(x, eye)]
        basis.append(legendre.legval(x, legendre.legder(eye)) * 2 / width)
        basis.append(legendre.legval(x, legendre.legder(eye, 2)) * (2 / width) ** 2)
        s = np.maximum(tt - JUMP, 0.0)
        extra = [
            [s**e for e in (2, 3, 4)],
            [e * s ** (e - 1) for e in (2, 3, 4)],
            [e * (e - 1) * s ** (e - 2) for e in (2, 3, 4)],
        ]
        B, dB, ddB = (
            np.vstack((b, np.array(x_))) for b, x_ in zip(basis, extra, strict=True)
        )
        tau, W = torques(qq, vv, aa, after)
        columns = []
        zz = np.zeros((len(tt), 4))
        zz[:, 2:] = np.where(after[:, None], W[:, :, 0], 0.0)
        columns.append(zz)
        step = 1e-6
        for joint in range(2):
            for i in range(len(B)):
                dq = np.zeros_like(qq)
                dv = np.zeros_like(qq)
                da = np.zeros_like(qq)
                dq[:, joint], dv[:, joint], da[:, joint] = B[i], dB[i], ddB[i]
                moved, _ = torques(
                    qq + step * dq, vv + step * dv, aa + step * da, after
                )
                column = np.zeros((len(tt), 4))
                column[:, joint] = B[i]
                column[:, 2:] = (moved - tau) / step
                columns.append(column)
        J = (
            np.stack([c.ravel() for c in columns], axis=1)
            / np.tile(sigma, len(tt))[:, None]
        )
        R = np.linalg.qr(J, mode="r")
        covariance = np.linalg.inv(R) @ np.linalg.inv(R).T
        out.append(100.0 * np.sqrt(covariance[0, 0]) / 4.5)
    return out


# ------------------------------------------------------------------- oracles


def _step_columns(x, step, functions, m, p, starts):
    """(K, M·m, p): a step of every parameter at each sample of ``starts``.

    The segment's functions (``core.segment``) on the data from the step on
    (trapezoid rule, half weight at the step) and the jump of the momentum,
    ``-g(t_g) D(t_g)``.
    """
    count = len(x)
    index = np.atleast_1d(np.asarray(starts, dtype=int))
    length = (count - 1) * step
    phi, dphi = segment_functions(count, functions)
    g, gdot = phi / length, dphi / length**2
    mp = m * p
    D, G = x[:, :mp], x[:, mp : 2 * mp]
    term = g[:, :, None] * G[None] - gdot[:, :, None] * D[None]  # (M, count, mp)
    weights = np.full(count, step)
    weights[-1] *= 0.5
    tail = np.cumsum((term * weights[None, :, None])[:, ::-1], axis=1)[:, ::-1]
    out = (
        tail[:, index]
        - 0.5 * step * term[:, index]
        - g[:, index, None] * D[None, index]
    )
    return out.transpose(1, 0, 2).reshape(len(index), functions * m, p)


def _whiten(factor, rows, m):
    shaped = rows.reshape(-1, m, *rows.shape[1:])
    return np.einsum("ef,if...->ie...", factor, shaped).reshape(rows.shape)


class _Oracle:
    """One noisy log: bank samples, the equations' whitener, the references."""

    def __init__(self, log, rows, settings, truth):
        grid = settings.on_grid(H)
        self.step = grid.resolved("bank_time_step")
        decimation = round(self.step / H)
        q_hat, v_hat, tau_hat, _, _ = filtered_signals(log.q, log.tau, grid, H)
        index = np.arange(0, log.num_samples, decimation)
        self.x = bank_channels(
            rows, "lagrangian", q_hat[index], v_hat[index], tau_hat[index]
        )
        self.m, self.p = 2, len(truth)
        self.change = round((JUMP + grid.delay(H)) / self.step)  # first sample after
        self.margin = int(np.ceil(grid.delay(H) / self.step - 1e-9))
        self.truth = np.asarray(truth, dtype=float)
        (plain,) = replay_log_core(log, rows, [settings])
        self.window = plain.theta[np.searchsorted(plain.t, JUMP)]
        # Covariance across the equations of the residual before the change
        # (windows of 1.5 s, 6 functions, every 60 ms from 7.5 s on).
        cross = np.zeros((2, 2))
        count = round(1.5 / self.step) + 1
        for end in range(round(7.5 / self.step), round(JUMP / self.step), 3):
            A, B = segment_equations(
                self.x[end - count + 1 : end + 1], self.step, 6, self.m, self.p
            )
            blocks = (B - A @ self.window).reshape(6, self.m)
            cross += blocks.T @ blocks
        self.whitener = np.linalg.inv(np.linalg.cholesky(cross))

    def functions(self, count):
        return int(min(32, max(4, round(4 * (count - 1) * self.step))))

    def zz1r(self, kind, reference, age):
        """ZZ1R from the data up to JUMP + age (module docstring)."""
        newest = round((JUMP + age) / self.step)
        if kind == "since":
            first = self.change + self.margin
        elif kind == "step":
            first = self.change - round(1.0 / self.step)
        else:  # "free": the stored 7 s
            first = newest - round(7.0 / self.step)
        x = self.x[first : newest + 1]
        if newest - self.change < 2 or len(x) < 3:
            return np.nan
        functions = self.functions(len(x))
        A, B = segment_equations(x, self.step, functions, self.m, self.p)
        if kind == "since":
            residual = B - A[:, 1:] @ reference[1:]
            return float(A[:, 0] @ residual / (A[:, 0] @ A[:, 0]))
        S = _step_columns(x, self.step, functions, self.m, self.p, self.change - first)[
            0
        ]
        A, B, S = (_whiten(self.whitener, y, self.m) for y in (A, B, S))
        if kind == "step":
            residual = B - A @ reference
            return float(reference[0] + S[:, 0] @ residual / (S[:, 0] @ S[:, 0]))
        regressor = np.column_stack((A, S[:, 0]))
        solution = np.linalg.lstsq(regressor, B, rcond=None)[0]
        return float(solution[0] + solution[-1])


def _settle(estimates) -> float:
    error = np.abs(np.asarray(estimates) - 4.5) > TOLERANCE * 4.5
    error |= ~np.isfinite(estimates)
    bad = np.flatnonzero(error)
    if not len(bad):
        return float(AGES[0])
    return float(AGES[bad[-1] + 1]) if bad[-1] + 1 < len(AGES) else float("nan")


VARIANTS = {
    "since the change (the restart), others true": ("since", "truth"),
    "since the change (the restart), others the window's": ("since", "window"),
    "step, whitened, others true": ("step", "truth"),
    "step, whitened, others the window's": ("step", "window"),
    "step, all free (7 s), whitened": ("free", "window"),
}


def oracle_floor(result, robot, bandwidth: float, seeds, which="both") -> dict:
    """Settle times of the oracle estimators (module docstring, 2) per seed."""
    settings = OnlineSettings.for_model(
        "lagrangian", window=_change.WINDOW, bandwidth=bandwidth, update_period=0.05
    )
    rows = robot.rows_provider()
    runs = {name: [] for name in VARIANTS}
    for seed in seeds:
        oracle = _Oracle(
            _change._noisy(result, seed, which), rows, settings, robot.base_values
        )
        for name, (kind, base) in VARIANTS.items():
            reference = oracle.truth if base == "truth" else oracle.window
            runs[name].append(
                _settle([oracle.zz1r(kind, reference, age) for age in AGES])
            )
    return {
        name: {
            "median": float(np.nanmedian(times)),
            "max": float(np.nanmax(times)),
            "runs": times,
        }
        for name, times in runs.items()
    }


def floor_report(models, scenarios, simulate, bandwidth: float, seeds) -> dict:
    """The floors on the Fig. 4 log (module docstring); ``scenarios`` None: no 3.

    ``simulate(robot=, trajectory=, duration=, events=)`` as ``bench_accuracy``'s;
    ``models["paper"]`` and ``paper.paper_trajectory()`` make the Fig. 4 log.
    """
    robot = models["paper"]
    result = simulate(
        robot=robot,
        trajectory=paper.paper_trajectory(),
        duration=25.0,
        events=[(JUMP, paper.zz1_jump(0.6))],
    )
    ages = (0.2, 0.3, 0.5, 0.7, 1.0)
    rows = robot.rows_provider()
    bound = crlb(result, rows, robot.base_values, ages)
    exact = crlb(result, rows, robot.base_values, ages, exact_positions=True)
    report = {
        "crlb": dict(zip(ages, bound, strict=True)),
        "crlb_exact_positions": dict(zip(ages, exact, strict=True)),
        "oracle": oracle_floor(result, robot, bandwidth, seeds),
        "oracle_exact_positions": oracle_floor(
            result, robot, bandwidth, seeds, which="tau"
        ),
        "seeds": len(list(seeds)),
    }
    if scenarios is not None:
        report["step_test"] = step_test(
            models, scenarios, simulate, result, bandwidth, seeds
        )
    return report


def print_floor(report: dict) -> None:
    print(
        "\n## The floor of the Fig. 4 tracking: the change time known, no "
        "detection (benchmarks/_change_floor.py)\n"
    )
    cells = " | ".join(f"{age:g} s after" for age in report["crlb"])
    print(f"| Cramér-Rao σ of ZZ1R [% of 4.5], other parameters known | {cells} |")
    print("|---" * (len(report["crlb"]) + 1) + "|")
    for key, label in (
        ("crlb", "SNR 30 dB on q and τ"),
        ("crlb_exact_positions", "SNR 30 dB on τ only"),
    ):
        values = " | ".join(f"{value:.2f}" for value in report[key].values())
        print(f"| {label} | {values} |")
    print(
        f"\n| oracle estimator | time to stay within 2 % [s], median (worst) over "
        f"{report['seeds']} seeds: SNR 30 dB on q and τ | on τ only |"
    )
    print("|---|---|---|")
    for name, row in report["oracle"].items():
        exact = report["oracle_exact_positions"][name]
        print(
            f"| {name} | {row['median']:.2f} ({row['max']:.2f}) | "
            f"{exact['median']:.2f} ({exact['max']:.2f}) |"
        )
    if "step_test" in report:
        print(
            "\n| step test, level h | alarms without a change (armed s) | "
            "delay after the jump [s], median (worst) |"
        )
        print("|---|---|---|")
        for h, row in report["step_test"].items():
            worst = row["delay_max"]
            print(
                f"| {h:g} | {row['alarms']} ({row['armed_s']:.0f}) | "
                f"{row['delay_median']:.2f} "
                f"({'never' if np.isinf(worst) else f'{worst:.2f}'}) |"
            )


# --------------------------------------------------------- the step test (3)


class _StepTest:
    """z per solve of one log (module docstring, 3)."""

    def __init__(self, settings, m, p):
        grid = settings.on_grid(H)
        self.step = grid.resolved("bank_time_step")
        self.delay = grid.delay(H)
        self.count = round(1.5 / self.step) + 1
        self.functions, self.m, self.p = 6, m, p
        newest = self.count - 1
        ages = np.arange(0.2, 0.8 + 1e-9, 0.04)
        self.starts = sorted(
            {newest - round((age - self.delay) / self.step) for age in ages}
        )

    def series(self, x, times, estimates):
        """(times, z) of the armed solves; ``estimates`` held at each solve."""
        d = self.functions * self.m
        scale, cross, learned = np.zeros(d), np.zeros((self.m, self.m)), 0
        out_t, out_z = [], []
        for t, theta in zip(times, estimates, strict=True):
            newest = int(np.floor(t / self.step + 1e-9))
            first = newest - self.count + 1
            if first < 0 or not np.isfinite(theta).all() or not theta.any():
                continue
            samples = x[first : newest + 1]
            A, B = segment_equations(samples, self.step, self.functions, self.m, self.p)
            r = B - A @ theta
            blocks = r.reshape(self.functions, self.m)
            warm = learned * 0.05 < 2.0
            if not warm:
                out_t.append(t)
                out_z.append(self._z(samples, r, scale, cross))
            weight = 1.0 / (learned + 1) if warm else 0.05 / _change.WINDOW
            scale = scale + weight * (r**2 - scale)
            cross = cross + weight * (blocks.T @ blocks / self.functions - cross)
            learned += 1
        return np.array(out_t), np.array(out_z)

    def _z(self, samples, r, scale, cross):
        tiny = np.finfo(float).tiny
        spread = np.sqrt(np.maximum(np.diag(cross), tiny))
        correlation = cross / np.outer(spread, spread) + 1e-9 * np.eye(self.m)
        root = np.sqrt(np.maximum(scale, tiny)).reshape(self.functions, self.m)
        whiteners = np.linalg.inv(
            np.linalg.cholesky(root[:, :, None] * correlation * root[:, None, :])
        )
        target = np.einsum("ief,if->ie", whiteners, r.reshape(self.functions, self.m))
        columns = _step_columns(
            samples, self.step, self.functions, self.m, self.p, self.starts
        ).reshape(len(self.starts), self.functions, self.m, self.p)
        a = np.einsum("ief,kifp->kiep", whiteners, columns).reshape(
            len(self.starts), -1, self.p
        )
        information = np.einsum("kdp,kdp->kp", a, a)
        usable = information > 1e-12 * information.max()
        score = np.einsum("kdp,d->kp", a, target.ravel())
        z = score**2 / np.where(usable, information, 1.0)
        return float(np.where(usable, z, 0.0).max())


def _step_series(result, robot, settings, seed, which="both"):
    log = _change._noisy(result, seed, which)
    rows = robot.rows_provider()
    grid = settings.on_grid(H)
    decimation = round(grid.resolved("bank_time_step") / H)
    q_hat, v_hat, tau_hat, _, _ = filtered_signals(log.q, log.tau, grid, H)
    index = np.arange(0, log.num_samples, decimation)
    x = bank_channels(rows, "lagrangian", q_hat[index], v_hat[index], tau_hat[index])
    (plain,) = replay_log_core(log, rows, [settings])
    valid = plain.valid > 0.5
    test = _StepTest(settings, 2, int(rows.num_parameters))
    return test.series(x, plain.t[valid], plain.theta[valid])


def _episodes(z, h, gap):
    count, last = 0, -np.inf
    for i in np.flatnonzero(z > h):
        if i - last > gap:
            count += 1
        last = i
    return count


def step_test(
    models,
    scenarios,
    simulate,
    jump_result,
    bandwidth,
    seeds,
    thresholds=(40.0, 60.0, 80.0, 100.0),
) -> dict:
    """Alarms on the logs without a change and delay on the jump (docstring, 3)."""
    plain = OnlineSettings.for_model(
        "lagrangian", window=_change.WINDOW, update_period=0.05
    )
    null = []
    for name, trajectory in scenarios.values():
        result = simulate(robot=models[name], trajectory=trajectory, duration=40.0)
        null += [_step_series(result, models[name], plain, seed)[1] for seed in seeds]
    tuned = dataclasses.replace(plain, bandwidth=bandwidth)
    jumps = [_step_series(jump_result, models["paper"], tuned, seed) for seed in seeds]
    out = {}
    for h in thresholds:
        delays = []
        for times, z in jumps:
            after = np.flatnonzero((times >= JUMP) & (z > h))
            delays.append(times[after[0]] - JUMP if len(after) else np.inf)
        out[h] = {
            "alarms": sum(_episodes(z, h, round(2.0 / 0.05)) for z in null),
            "armed_s": 0.05 * sum(len(z) for z in null),
            "delay_median": float(np.median(delays)),
            "delay_max": float(np.max(delays)),
        }
    return out
