"""Streamed off-line IDIM (core/idim_stream.py): same estimates, bounded memory.

Logs: random Fourier motions (numpy default_rng(1) for the 2R arm, default_rng(5)
for the iiwa7, one period tiled), τ from the inverse-dynamics rows with the URDF's
base values, white noise on q and τ (default_rng(0)).

Tolerance of the equality: the streamed chain (rigid-body columns every D1-th
sample after a stage-1 anti-alias FIR, order-8 Butterworth at f_d) and the
one-stage chain (regressor_decimation=1: every sample, one Butterworth at f_d),
with the same f_c, f_d and D, low-pass the same linear equation τ = W X; they
differ only in the transition band of the stage-1 filter, where the data hold
noise only. The estimates therefore differ by a fraction of their noise-induced
standard deviation σ: at most 0.5 σ, median at most 0.15 σ (measured: 0.25 σ and
0.04 σ on a 60 s iiwa7 log, 0.27 σ and 0.11 σ here with IDIM-WLS).
"""

import tracemalloc

import numpy as np
import pytest

from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.logs import RobotLog
from drake_dynid.offline import identify_offline
from drake_dynid.plants import RobotModel, model_path

H = 1e-3


def _log(robot, seed, period, duration, velocity):
    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi / period,
        max_velocity=velocity,
        rng=np.random.default_rng(seed),
    )
    q, v, vdot = trajectory.evaluate(H * np.arange(round(period / H)))
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    repeats = round(duration / period)
    rng = np.random.default_rng(0)
    q = np.tile(q, (repeats, 1)) + 1e-4 * rng.normal(
        size=(len(q) * repeats, q.shape[1])
    )
    noise = 0.01 * tau.std(axis=0)
    tau = np.tile(tau, (repeats, 1)) + noise * rng.normal(size=q.shape)
    return RobotLog(H * np.arange(len(q)), q, tau, robot.joint_names, H)


@pytest.mark.parametrize("weighted", [False, True])
def test_streamed_estimates_equal_the_one_stage_path(weighted):
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    log = _log(robot, seed=1, period=10.0, duration=60.0, velocity=5.0)
    streamed = identify_offline(log, robot, weighted=weighted)
    settings = streamed.settings
    assert settings["regressor_decimation"] > 4  # the streamed path is exercised
    one_stage = identify_offline(
        log,
        robot,
        weighted=weighted,
        decimation=settings["decimation"],
        decimation_cutoff_hz=settings["decimation_cutoff_hz"],
        regressor_decimation=1,
    )
    assert streamed.valid and one_stage.valid
    assert one_stage.settings["cutoff_hz"] == settings["cutoff_hz"]
    gap = np.abs(streamed.theta - one_stage.theta) / one_stage.std
    assert gap.max() <= 0.5 and np.median(gap) <= 0.15
    np.testing.assert_allclose(streamed.std, one_stage.std, rtol=0.1)


def test_memory_beyond_the_rows_does_not_grow_with_the_log():
    # 300 s and 600 s iiwa7 logs (longer than every block and spectrum piece):
    # the peak grows by the decimated rows (K·n·p floats, a few copies), not by
    # the log (120 bytes per sample here: 36 MB more).
    robot = RobotModel.from_urdf(model_path("iiwa7"))
    peaks, rows = [], []
    for duration in (300.0, 600.0):
        log = _log(robot, seed=5, period=10.0, duration=duration, velocity=1.5)
        tracemalloc.start()
        result = identify_offline(log, robot)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        assert result.valid
        rows.append(result.num_rows * robot.num_parameters * 8)
    assert peaks[1] - peaks[0] <= 2 * (rows[1] - rows[0]) + 1e6
    assert peaks[1] < 100e6


class _RowsWithoutLaw:
    """A robot's rows and names, without its ``sign``: today's one-stage path.

    ``friction_layout`` cannot tell the dead zone from the exact sign, so every
    column, the Coulomb ones included, comes from the model's own rows at every
    sample (regressor_decimation 1).
    """

    def __init__(self, robot):
        self.names = robot.names
        self.joint_names = robot.joint_names
        self.idim_rows = robot.idim_rows


def test_a_dead_zone_keeps_the_streamed_path_with_each_joints_width():
    from drake_dynid.core.friction import DeadZoneSign

    plain = RobotModel.from_urdf(model_path("planar_2r"))
    log = _log(plain, seed=1, period=10.0, duration=60.0, velocity=5.0)
    # Widths that put a good share of each joint's samples in its zone, and
    # differ: a law applied with the other joint's width would move the fit.
    robot = plain.with_sign(DeadZoneSign((0.4, 1.5)))
    v = np.diff(log.q, axis=0) / H
    assert 0.03 < np.mean(np.abs(v[:, 0]) <= 0.4) < 0.5
    assert 0.03 < np.mean(np.abs(v[:, 1]) <= 1.5) < 0.5
    streamed = identify_offline(log, robot)
    settings = streamed.settings
    assert settings["regressor_decimation"] > 4  # the fast path with a dead zone
    same = {
        "cutoff_hz": settings["cutoff_hz"],
        "decimation": settings["decimation"],
        "decimation_cutoff_hz": settings["decimation_cutoff_hz"],
    }
    reference = identify_offline(log, _RowsWithoutLaw(robot), **same)
    assert reference.settings["regressor_decimation"] == 1  # every column from rows
    one_stage = identify_offline(log, robot, regressor_decimation=1, **same)
    assert streamed.valid and reference.valid and one_stage.valid
    # The friction columns computed by the stream (s applied per joint) equal the
    # model's own: the same one-stage chain gives the same estimates to round-off.
    # (The stream also restores short reversals through the zone, which the rows
    # cannot: none here, these wide zones are crossed in more than L samples;
    # the reversals are tested in test_offline.py and tests/core/test_standstill.)
    np.testing.assert_allclose(one_stage.theta, reference.theta, rtol=1e-9, atol=0)
    # Two stages against one: a fraction of σ (module docstring).
    gap = np.abs(streamed.theta - reference.theta) / reference.std
    assert gap.max() <= 0.5 and np.median(gap) <= 0.15
    # The dead zone matters here: the exact sign gives other estimates.
    exact = identify_offline(log, plain, **same)
    assert np.max(np.abs(exact.theta - reference.theta) / reference.std) > 3.0


@pytest.mark.parametrize("factor", [1, 5])
def test_a_dead_zones_reversals_are_the_whole_segments_whatever_the_blocks(factor):
    """Review of the reversal rule's context (core.idim_stream._stage_one_block):
    each block reads 2L + 1 velocities either side, so the stream's Coulomb
    columns are those of core.standstill.reversal_signs on the whole segment's
    velocity, for blocks of 7 samples (< 2L + 1 = 25) to one block, D1 = 1 or 5,
    and the first and last blocks of a segment (measured: 3e-12 on the friction
    columns, 1.3e-10 of the largest raw v̇). The same for a coupled motor's
    channel x = (R·v)/ρ with its own zone (core.idim_friction.MotorChannels)."""
    from drake_dynid.core import idim_stream
    from drake_dynid.core.friction import DeadZoneSign
    from drake_dynid.core.idim import default_padding, default_trim
    from drake_dynid.core.idim_friction import MotorChannels
    from drake_dynid.core.standstill import reversal_signs
    from drake_dynid.core.zero_phase import zero_phase_span

    h, fc, N = 1e-3, 10.0, 3000
    rng = np.random.default_rng(1)
    t = h * np.arange(N)
    # Joint 0 reverses fast through its zone (about 5 samples each time); joint
    # 1 is at rest (noise only).
    q = np.stack([0.05 * np.sin(2 * np.pi * 3 * t + 0.3), 1e-4 * rng.normal(size=N)], 1)
    tau = rng.normal(size=(N, 2))
    sign = DeadZoneSign((0.05, 0.002))
    # A motor turning with 40 (q0 + 0.5 q1): x = v0 + 0.5 v1, its zone 0.04.
    channels = MotorChannels(np.array([[40.0, 20.0]]), DeadZoneSign((0.04,)))
    friction = [("coulomb", 0), ("coulomb", 1), ("viscous", 0), ("coulomb", 2)]
    trim, pad = default_trim(h, fc), default_padding(h, fc)

    def rows(q_f, v, vdot):
        return np.stack([q_f, vdot], -1)

    columns = {}
    for block in (1 << 16, 500, 7):
        plan = idim_stream.stream_plan(
            h,
            cutoff_hz=fc,
            filter_order=4,
            trim=trim,
            padding=pad,
            decimation=1 if factor == 1 else 2 * factor,
            decimation_cutoff_hz=4.0,
            factor=factor,
            block=block,
        )
        chunks = idim_stream.decimated_chunks(
            q, tau, plan, rows, friction, sign, raw=True, channels=channels
        )
        columns[block] = [np.concatenate(part) for part in zip(*chunks, strict=True)]
    for block in (500, 7):
        for got, whole in zip(columns[block], columns[1 << 16], strict=True):
            scale = np.max(np.abs(whole))  # the position filter's block margins
            np.testing.assert_allclose(got, whole, rtol=0, atol=1e-9 * scale)
    if factor == 1:  # the raw friction columns at every sample trim … N - trim - 1
        q_f = zero_phase_span(
            plan.position_sos, q, pad_left=pad, pad_right=pad, padtype="odd"
        )
        v = (q_f[2:] - q_f[:-2]) / (2 * h)  # samples 1 … N - 2
        expected = reversal_signs(v, sign.width, plan.reversal)[trim - 1 : N - trim - 1]
        np.testing.assert_array_equal(columns[7][4][:, :2], expected)
        restored = expected != sign(v)[trim - 1 : N - trim - 1]
        assert restored[:, 0].sum() > 50 and not restored[:, 1].any()
        x = v[:, 0] + 0.5 * v[:, 1]
        motor = reversal_signs(x, 0.04, plan.reversal)[trim - 1 : N - trim - 1]
        np.testing.assert_array_equal(columns[7][4][:, 3], motor)
        assert (
            np.sum(motor != channels.sign(x[trim - 1 : N - trim - 1, None])[:, 0]) > 50
        )
