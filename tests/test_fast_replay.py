"""replay_log_core (numerical core, vectorised) == replay_log (Drake blocks).

Log: the closed-loop simulation of the 2R arm with noise (SNR 30 dB, seed 7) and a
random Fourier reference (numpy default_rng(4)); a copy with a burst of NaN samples
checks the invalid-window bookkeeping.
"""

import dataclasses

import numpy as np
import pytest

from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import (
    OnlineSettings,
    SimulationSettings,
    replay_log,
    simulate_identification,
)
from drake_dynid.fast_replay import replay_log_core
from drake_dynid.logs import RobotLog
from drake_dynid.plants import RobotModel, model_path

SETTINGS = [
    OnlineSettings(
        model="lagrangian",
        window=1.0,
        frequencies=np.arange(5.0),
        jacobi_window=0.05,
        bank_time_step=0.005,
        update_period=0.05,
    ),
    OnlineSettings(
        model="power",
        window=1.0,
        frequencies=np.arange(0, 9.01, 0.5),
        jacobi_window=0.05,
        bank_time_step=0.002,
        update_period=0.02,
    ),
]
# Ordinary least squares (the paper's solve) through both engines too; its honest σ
# (unequal row noise, docs/MATH.md §4) needs one more function than the weighted
# solve to keep enough residual degrees of freedom in a 1 s window.
SETTINGS.append(
    dataclasses.replace(SETTINGS[0], weighting="none", frequencies=np.arange(6.0))
)
# Raw rows (read from the differentiator's ring, averaged over each bank step).
SETTINGS.append(dataclasses.replace(SETTINGS[0], rows_from="raw", raw_window=0.04))
SETTINGS.append(dataclasses.replace(SETTINGS[1], rows_from="raw", raw_window=0.02))
# The power rows with their noise bias removed (core.noise_bias), filtered and raw.
SETTINGS.append(dataclasses.replace(SETTINGS[1], position_noise=0.02))
SETTINGS.append(dataclasses.replace(SETTINGS[4], position_noise=(0.02, 0.01)))
# The covariance weighting (core.row_covariance: the blocks keep the window's
# filtered signals in a SignalWindow), both models, its default ℓ set.
SETTINGS.extend(
    dataclasses.replace(
        SETTINGS[k],
        weighting="covariance",
        position_noise=0.02,
        torque_noise=(0.5, 0.1),
        frequencies=None,
    )
    for k in (0, 1)
)


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def log(robot):
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )
    result = simulate_identification(
        robot, trajectory, SimulationSettings(duration=2.2, seed=7), []
    )
    return RobotLog(result.t, result.q, result.tau, result.joint_names, 1e-3)


def _compare(fast, reference):
    assert len(fast) == len(reference)
    for got, want in zip(fast, reference, strict=True):
        assert got.names == want.names
        np.testing.assert_allclose(got.t, want.t, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(got.valid, want.valid)
        np.testing.assert_array_equal(got.status, want.status)
        np.testing.assert_array_equal(got.unidentified, want.unidentified)
        np.testing.assert_allclose(got.theta, want.theta, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(got.std, want.std, rtol=1e-7, atol=1e-12)
        finite = np.isfinite(want.condition_number)
        np.testing.assert_array_equal(np.isfinite(got.condition_number), finite)
        np.testing.assert_allclose(
            got.condition_number[finite], want.condition_number[finite], rtol=1e-7
        )
        assert got.delay == pytest.approx(want.delay)


def test_core_replay_equals_the_drake_blocks(robot, log):
    rows = robot.rows_provider()
    fast = replay_log_core(log, rows, SETTINGS)
    _compare(fast, replay_log(log, rows, SETTINGS))
    # The window fills within the log: some solves are valid, the first are not.
    for trace in fast:
        assert trace.valid[0] == 0.0 and trace.valid[-1] == 1.0


def test_core_replay_with_change_detection_equals_the_blocks(robot, log):
    """detect_changes: a test sensitive enough to alarm on this log without a change
    (short windows, low drift), so the restart path runs in both engines."""
    from drake_dynid.core.change import ChangeDetection

    eager = ChangeDetection(
        window=0.3,
        functions=3,
        warmup=0.2,
        drift=1.0,
        onset_drift=0.8,
        threshold=0.1,
        confirm=0.6,
    )
    chosen = [
        dataclasses.replace(SETTINGS[0], detect_changes=eager),
        dataclasses.replace(SETTINGS[4], detect_changes=eager),  # power, raw rows
    ]
    rows = robot.rows_provider()
    fast = replay_log_core(log, rows, chosen)
    reference = replay_log(log, rows, chosen)
    _compare(fast, reference)
    for got, want in zip(fast, reference, strict=True):
        assert got.change.sum() >= 1 and got.tracking.sum() >= 3
        for name in ("change", "tracking", "changed"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
        np.testing.assert_array_equal(got.change_time, want.change_time)


def test_core_replay_handles_bad_samples_like_the_blocks(robot, log):
    q = log.q.copy()
    q[1500:1503, 1] = np.nan
    bad = RobotLog(log.t, q, log.tau, log.joint_names, log.time_step)
    rows = robot.rows_provider()
    chosen = [SETTINGS[0], SETTINGS[3]]  # filtered and raw rows
    fast = replay_log_core(bad, rows, chosen)
    _compare(fast, replay_log(bad, rows, chosen))
    for trace in fast:
        assert 0.0 in trace.valid[-10:]


def test_core_replay_argument_checks(robot, log):
    from drake_dynid.diagrams import OnlineSettings
    from drake_dynid.fast_replay import replay_log_core

    with pytest.raises(TypeError, match="rows must be a row provider"):
        replay_log_core(log, object(), [OnlineSettings()])
    with pytest.raises(TypeError, match="settings must be OnlineSettings"):
        replay_log_core(log, robot.rows_provider(), [{"window": 2.0}])


def test_filters_at_the_bank_samples_equal_the_whole_log_filters():
    """core.replay.filtered_at (the FIRs at some samples) against filtered_signals
    (the whole log): values to round-off, and validity: not before the taps are
    filled, nor while a non-finite sample is in the window."""
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.core.replay import filtered_at, filtered_signals

    settings = OnlineSettings(window=2.0, bandwidth=1.0).on_grid(1e-3)
    rng = np.random.default_rng(8)
    q, tau = np.cumsum(rng.normal(size=(2, 3000, 3)), axis=1) * 1e-2
    q[1500, 2] = np.nan
    tau[2200, 0] = np.inf
    whole = filtered_signals(q, tau, settings, 1e-3)
    taps = settings.jacobi_filters(1e-3)[0].num_taps
    for index in (
        np.arange(0, 3000, 20),
        np.array([taps - 2, taps - 1, 1499, 1500, 1500 + taps - 1, 1500 + taps]),
        np.array([2999]),
    ):
        for by_fft in (False, True):
            at = filtered_at(q, tau, settings, 1e-3, index, by_fft=by_fft)
            np.testing.assert_array_equal(at[3], whole[3][index])
            for mine, reference in zip(at[:3], whole[:3], strict=True):
                np.testing.assert_allclose(
                    mine, reference[index], rtol=1e-12, atol=1e-12
                )
    assert not filtered_at(q, tau, settings, 1e-3, np.array([1500 + taps - 1]))[3][0]
    assert filtered_at(q, tau, settings, 1e-3, np.array([1500 + taps]))[3][0]


@pytest.mark.parametrize("count", [2200, 2187])
def test_the_final_estimate_uses_the_log_up_to_its_last_sample(robot, log, count):
    """Found by a review: the trace ended with the solve a period (up to 1 s with
    the covariance weighting) before the log's end, whose last samples were never
    used (3e-4 relative on the estimate). The final row, at t_N, is now the solve
    at the last sample, in both engines: N a multiple of the solve period (the
    loggers' row at t_N replaced) or not (a row appended)."""
    from drake_dynid.core.replay import window_estimate

    short = RobotLog(
        log.t[:count], log.q[:count], log.tau[:count], log.joint_names, 1e-3
    )
    rows = robot.rows_provider()
    chosen = [SETTINGS[0], SETTINGS[-1]]  # Lagrangian; power, covariance weighting
    fast = replay_log_core(short, rows, chosen)
    # The blocks: the Lagrangian entry (the covariance one is slower; the test
    # above compares it, with its final solve off the 1 s period).
    _compare(fast[:1], replay_log(short, rows, chosen[:1]))
    for trace, settings in zip(fast, chosen, strict=True):
        assert trace.t[-1] == pytest.approx(count * 1e-3, abs=1e-12)
        step = round(settings.on_grid(1e-3).bank_time_step / 1e-3)
        last = (count - 1) - (count - 1) % step  # the log's last bank sample
        want = window_estimate(rows, settings, short.q, short.tau, last, 1e-3)
        assert trace.valid[-1] == 1.0 and want.valid
        np.testing.assert_allclose(trace.theta[-1], want.theta, rtol=1e-8)
