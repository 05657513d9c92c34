"""Off-line IDIM-LS/WLS on a RobotLog: accuracy, automatic cutoff, NaN segments."""

import math

import numpy as np
import pytest

from drake_dynid.core.idim import default_trim, idim_least_squares
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import SimulationSettings, simulate_identification
from drake_dynid.logs import RobotLog
from drake_dynid.offline import (
    MAX_AUTO_CUTOFF_HZ,
    auto_cutoff,
    auto_decimation,
    auto_decimation_cutoff,
    identify_offline,
    offline_rows,
)
from drake_dynid.plants import RobotModel, model_path

H = 1e-3


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def trajectory():
    # Seed 1: period 10 s, 5 harmonics (top line 0.5 Hz), |v| <= 5 rad/s (paper Fig. 3).
    return random_fourier_trajectory(
        2,
        harmonics=5,
        base_frequency=2 * np.pi / 10.0,
        max_velocity=5.0,
        rng=np.random.default_rng(1),
    )


def _log(result):
    return RobotLog(result.t, result.q, result.tau, result.joint_names, H)


@pytest.fixture(scope="module")
def clean_log(robot, trajectory):
    result = simulate_identification(
        robot, trajectory, SimulationSettings(duration=10.0, snr_db=None), []
    )
    return _log(result)


@pytest.fixture(scope="module")
def noisy_log(robot, trajectory):
    # Paper §V: SNR 30 dB on q and τ (noise seed 7), 20 s.
    result = simulate_identification(
        robot, trajectory, SimulationSettings(duration=20.0, snr_db=30.0, seed=7), []
    )
    return _log(result)


def _relative_error(result, robot):
    return (result.theta - robot.base_values) / robot.base_values


@pytest.mark.parametrize("weighted", [False, True])
def test_noise_free_log_recovers_the_base_parameters(robot, clean_log, weighted):
    result = identify_offline(clean_log, robot, weighted=weighted)
    assert result.valid and result.reason == ""
    assert result.names == robot.base.names
    assert result.model == ("idim-wls" if weighted else "idim-ls")
    # A clean log: the spectrum meets the (numerical) floor far above the 0.5 Hz
    # excitation: the cutoff sits near the 40 Hz cap.
    cutoff = result.settings["cutoff_hz"]
    assert 20.0 <= cutoff <= MAX_AUTO_CUTOFF_HZ
    assert result.settings["cutoff_rule"] == "auto"
    # The decimation low-pass sits at 1.5 times the 0.5 Hz velocity band.
    band_cut = result.settings["decimation_cutoff_hz"]
    assert result.settings["decimation_cutoff_rule"] == "auto"
    assert 0.6 <= band_cut <= 1.0
    # D = floor(0.25·fs/f_d) rounded down to a multiple of the intermediate
    # decimation D1 of the rigid-body columns (f_s/D1 >= 4·f_c: a handful here).
    decimation = result.settings["decimation"]
    factor = result.settings["regressor_decimation"]
    assert result.settings["regressor_decimation_rule"] == "auto"
    assert 2 <= factor <= 1.0 / (H * 4.0 * cutoff)
    assert decimation % factor == 0
    assert (
        auto_decimation(H, band_cut) - factor
        < decimation
        <= auto_decimation(H, band_cut)
    )
    trim = default_trim(H, cutoff)
    assert result.settings["trim"] == trim
    assert result.num_samples == clean_log.num_samples
    assert result.num_samples_used == clean_log.num_samples - 2 * trim
    assert result.num_segments == result.num_segments_used == 1
    error = np.abs(_relative_error(result, robot))
    assert np.all(error < 0.01), error
    # Gautier's σ × the decimated rows' correlation factor (core.idim_auto).
    factor = result.settings["sigma_correlation_factor"]
    assert 1.0 < factor < 3.0
    assert np.all(result.relative_std_percent < 1.0 * factor)
    assert 1.0 < result.condition_number < 20.0


def test_the_rows_are_reduced_as_they_come_unless_kept(robot, noisy_log):
    # Memory independent of the log's length: no decimated rows held by default;
    # kept ones (for the physical solve) give the same fit by the one-shot path.
    rows = offline_rows(noisy_log, robot)
    assert rows.W is None and rows.tau is None
    p = robot.num_parameters
    assert rows.reduced.R.shape == (2, p + 1, p + 1)
    kept = identify_offline(noisy_log, robot, weighted=True, keep_rows=True)
    assert kept.rows.shape[0] == rows.reduced.num_samples
    direct = idim_least_squares(kept.rows, kept.torques, weighted=True)
    np.testing.assert_allclose(kept.theta, direct.theta, rtol=1e-9)
    factor = kept.settings["sigma_correlation_factor"]  # Gautier's σ × factor
    np.testing.assert_allclose(kept.std, factor * direct.std, rtol=1e-9)
    plain = identify_offline(noisy_log, robot, weighted=True)
    assert plain.rows is None
    np.testing.assert_allclose(plain.theta, kept.theta, rtol=1e-12)


def test_snr_30db_log_is_identified_with_an_automatic_cutoff(robot, noisy_log):
    result = identify_offline(noisy_log, robot)
    assert result.valid
    # The noise floor sets the cutoff a few times above the 0.5 Hz excitation.
    cutoff = result.settings["cutoff_hz"]
    assert 0.75 <= cutoff <= 4.0
    error = _relative_error(result, robot)
    # Paper Table II (off-line IDIM at 30 dB): inertial within 1.3 %, friction 11 %.
    assert np.all(np.abs(error[:4]) < 0.05), error
    # Friction is less well determined at 30 dB (%σ of a few %, not the inertial
    # parameters' fraction of a percent); σ says so.
    assert np.max(result.relative_std_percent[4:]) > 2.0
    assert np.max(result.relative_std_percent[4:]) > np.max(
        result.relative_std_percent[:4]
    )
    assert np.all(np.abs(error[4:]) < 0.25), error
    # Gautier's σ is honest: every error within 3 σ.
    assert np.all(np.abs(result.theta - robot.base_values) < 3.0 * result.std)
    # The automatic cutoff matters: 20 Hz passes so much noise into v̇ that the
    # errors-in-variables bias would shrink the inertial parameters by more than
    # 10 %, far beyond σ: such a given cutoff is refused (the highest allowed keeps
    # the noise within 10 % of the velocity's power, core.idim_auto).
    with pytest.raises(
        ValueError, match=r"cutoff_hz must be <= 1\d\.\d Hz .*errors in"
    ):
        identify_offline(noisy_log, robot, cutoff_hz=20.0)
    limit = identify_offline(noisy_log, robot, cutoff_hz=15.0)
    assert limit.settings["cutoff_rule"] == "given" and limit.valid


def test_weighted_least_squares_weights_each_joint(robot, clean_log):
    # Joint 2's torque is 50x noisier than joint 1's (seed 3).
    rng = np.random.default_rng(3)
    tau = clean_log.tau.copy()
    tau[:, 0] += rng.normal(0.0, 0.02 * tau[:, 0].std(), tau.shape[0])
    tau[:, 1] += rng.normal(0.0, 1.0 * tau[:, 1].std(), tau.shape[0])
    log = RobotLog(clean_log.t, clean_log.q, tau, clean_log.joint_names, H)
    ls = identify_offline(log, robot, cutoff_hz=10.0)
    wls = identify_offline(log, robot, cutoff_hz=10.0, weighted=True)
    assert ls.valid and wls.valid
    assert ls.settings["weighted"] is False and wls.settings["weighted"] is True
    # WLS residual is weighted by 1/σ_j: about 1.
    assert 0.9 < wls.residual_std < 1.1
    # LS residual in N·m: the (decimation-filtered) noise, far above a clean log's.
    clean = identify_offline(clean_log, robot, cutoff_hz=10.0)
    assert ls.residual_std > 10.0 * clean.residual_std
    # Joint 1's own parameters (ZZ1R, FV1, FC1) are no longer drowned in joint 2's
    # noise: their σ drops by more than 2x.
    own = [robot.base.names.index(name) for name in ("ZZ1R", "FV1", "FC1")]
    assert np.all(wls.std[own] < 0.5 * ls.std[own])
    assert np.all(np.abs(_relative_error(wls, robot)[:4]) < 0.03)


def test_nan_samples_split_the_log_into_segments(robot, clean_log):
    q = clean_log.q.copy()
    tau = clean_log.tau.copy()
    q[4000:4200] = np.nan  # a 0.2 s dropout
    tau[7000, 1] = np.inf  # one bad torque cell
    q[7100, 0] = np.nan  # a 99-sample segment between them: too short
    log = RobotLog(clean_log.t, q, tau, clean_log.joint_names, H)
    result = identify_offline(log, robot, cutoff_hz=20.0)
    assert result.valid
    assert np.all(np.isfinite(result.theta)) and np.all(np.isfinite(result.std))
    assert result.num_segments == 4 and result.num_segments_used == 3
    trim = default_trim(H, 20.0)
    lengths = [4000, 7000 - 4200, 10001 - 7101]
    assert result.num_samples_used == sum(n - 2 * trim for n in lengths)
    assert np.all(np.abs(_relative_error(result, robot)) < 0.01)


def test_logs_without_a_long_enough_segment_are_rejected(robot, clean_log):
    q = np.full_like(clean_log.q, np.nan)
    log = RobotLog(clean_log.t, q, clean_log.tau, clean_log.joint_names, H)
    with pytest.raises(ValueError, match="no finite sample"):
        identify_offline(log, robot)
    short = RobotLog(
        clean_log.t[:500], clean_log.q[:500], clean_log.tau[:500], log.joint_names, H
    )
    with pytest.raises(ValueError, match=r"cutoff_hz must be >= 8.05 Hz on this log"):
        identify_offline(short, robot, cutoff_hz=2.0)


def test_argument_validation(robot, clean_log):
    for cutoff in (0.0, 600.0, np.nan):
        with pytest.raises(ValueError, match=r"cutoff_hz must be in \(0, 500\)"):
            identify_offline(clean_log, robot, cutoff_hz=cutoff)
    with pytest.raises(ValueError, match="decimation must be >= 1"):
        identify_offline(clean_log, robot, decimation=0)
    with pytest.raises(TypeError, match="decimation must be an integer"):
        identify_offline(clean_log, robot, decimation=2.5)
    with pytest.raises(ValueError, match="filter_order must be >= 1"):
        identify_offline(clean_log, robot, filter_order=0)
    with pytest.raises(TypeError, match="weighted must be a bool"):
        identify_offline(clean_log, robot, weighted="yes")
    with pytest.raises(TypeError, match="log must be a RobotLog"):
        identify_offline(clean_log.q, robot)
    swapped = RobotLog(clean_log.t, clean_log.q, clean_log.tau, ("joint2", "joint1"), H)
    with pytest.raises(ValueError, match="log joints must be the robot's"):
        identify_offline(swapped, robot)


def test_auto_cutoff_follows_the_noise_floor():
    rng = np.random.default_rng(5)  # seed 5
    t = np.arange(20000) * H
    q = np.stack([np.sin(2 * np.pi * 0.5 * t), 0.5 * np.cos(2 * np.pi * 0.3 * t)], 1)
    # No noise: only rounding and the window's -92 dB side lobes, far above the
    # excitation; never above the caps (40 Hz, fs/5 = 20 Hz at 100 Hz).
    assert 20.0 <= auto_cutoff(q, H) <= MAX_AUTO_CUTOFF_HZ
    assert auto_cutoff(q[::10], 0.01) <= 20.0
    noisy = q + rng.normal(0.0, 1e-2, q.shape)
    cutoff = auto_cutoff(noisy, H)
    # At least twice the 0.5 Hz line, far below the 40 Hz cap.
    assert 1.0 <= cutoff <= 3.0
    # More noise never raises the cutoff.
    assert auto_cutoff(q + rng.normal(0.0, 1e-1, q.shape), H) <= cutoff


def _band_limited(noise_std):
    """A 20 s excite-like design at 1 kHz (``_motions.band_limited``: 5 harmonics
    of 0.2 Hz, top 1 Hz), plus white noise of ``noise_std`` [rad]."""
    from _motions import band_limited

    return band_limited(1.0 / H, 0.0, noise_std, t=np.arange(20000) * H)[1]


def test_auto_cutoff_leaves_a_low_noise_band_limited_log_unbiased():
    """Found on the xArm7 (README, "Real robot descriptions"): on an excite design
    the spectrum meets its floor at the top harmonic whatever the noise, and the
    former rule's 2·f_99 (2 Hz there for a 1 Hz top harmonic, |H|² = 0.9961 at
    1 Hz) put XX3R 13.7 % high even without noise, 1-6σ on every seed. The cutoff
    now minimises the expected acceleration error, the filter's droop against the
    noise it passes: at least 3 times the top harmonic on a low-noise log (the
    former rule: 2.75 Hz at 1e-5 rad, 1.75 Hz at simulate's default 1e-4 rad),
    and near twice the band at SNR 30 dB (1e-2 rad: 1.92 Hz; former 1.5 Hz).
    """
    assert auto_cutoff(_band_limited(1e-5), H) >= 3.0  # 3.94 Hz
    assert auto_cutoff(_band_limited(1e-4), H) >= 3.0  # 3.13 Hz
    assert 1.5 <= auto_cutoff(_band_limited(1e-2), H) <= 2.5
    cutoffs = [auto_cutoff(_band_limited(s), H) for s in (1e-5, 1e-4, 1e-3, 1e-2)]
    assert cutoffs == sorted(cutoffs, reverse=True)  # more noise, lower cutoff


@pytest.mark.parametrize("value", [0.3, 0.1, 1.2345678, 2 * np.pi / 4096 * 195])
def test_a_joint_held_still_does_not_move_the_automatic_cutoff(value):
    """Found reviewing the new automatic cutoff: a joint held still in the log (a
    locked torso, a gripper; an encoder at one count) read 0.3 rad in every
    sample, and the segments' linear detrending left a rounding residue (~1e-17
    rad) whose smooth spectrum stood 100 times above its own floor (~1e-45): a
    joint moving without noise, so the max over joints took its 35.8-40 Hz
    instead of the moving joints' 2.37 Hz (100 Hz log: 4.09 instead of 2.12).
    Each joint is now measured from its first sample: a still joint is exactly
    0 and does not count (the noise-limited cutoff likewise)."""
    from drake_dynid.core.idim_auto import noise_limited_cutoff

    q = _band_limited(1e-3)
    still = np.column_stack([q, np.full(q.shape[0], value)])
    assert auto_cutoff(still, H) == auto_cutoff(q, H)
    assert auto_cutoff(still[::10], 10 * H) == auto_cutoff(q[::10], 10 * H)
    assert noise_limited_cutoff(still, H) == noise_limited_cutoff(q, H)
    assert auto_cutoff(still[:, 2:], H) == auto_cutoff(np.zeros((q.shape[0], 1)), H)


@pytest.mark.parametrize("scale", [2 * np.pi / 4096, 1.0])
def test_an_encoder_joint_moving_over_few_counts_does_not_move_the_cutoff(scale):
    """Found reviewing the new automatic cutoff: a joint of a 12-bit encoder
    (2π/4096 rad a count, or the counts themselves) moving slowly over 3-130
    counts at 1 kHz changes count far less often than 1000 times a second, so its
    quantization error is a staircase with little power in [fs/4, fs/2]: read
    there alone, the floor left the steps as noise-free motion up to tens of Hz
    and the max over joints took 35.8-40 Hz instead of the other joints' 2.37
    Hz. The floor is now at least the quantization noise's, Δ²/(6·fs)."""
    q = _band_limited(1e-4)
    reference = auto_cutoff(q, H)
    t = np.arange(q.shape[0]) * H
    for amplitude in (0.002, 0.1):  # 2.6 and 130 counts peak to peak
        counts = np.round((0.3 + amplitude * q[:, 0] / 1.2) / (2 * np.pi / 4096))
        slow = np.round((0.3 + amplitude * np.sin(0.1 * np.pi * t)) * 2048 / np.pi)
        for joint in (counts, slow):
            both = np.column_stack([q, joint * scale])
            assert auto_cutoff(both, H) <= 1.3 * reference


def _design(fs, duration, noise_std, seed=3, t=None):
    """``_band_limited``'s design at ``fs`` [Hz] for ``duration`` [s] (or at the
    times ``t`` [s]): (q + noise, the noise-free acceleration)."""
    from _motions import band_limited

    return band_limited(fs, duration, noise_std, seed, t)[1:]


def _best_cutoff(q, acceleration, h):
    """The truth: the cutoff whose filtered acceleration (``offline_derivatives``,
    order 4, default trim) is nearest the noise-free one (a 2 % grid)."""
    from drake_dynid.core.idim import offline_derivatives

    errors = []
    for cutoff in np.geomspace(0.2, min(40.0, 0.2 / h), 220):
        trim = default_trim(h, cutoff)
        if q.shape[0] >= 2 * trim + 1:
            *_, vdot = offline_derivatives(q, h, cutoff_hz=cutoff)
            error = np.mean((vdot - acceleration[trim : q.shape[0] - trim]) ** 2)
            errors.append((error, cutoff))
    return min(errors)[1]


def test_resampled_positions_keep_their_own_cutoff():
    """Found by a review: 100 Hz positions interpolated linearly onto 1 kHz (a
    multi-file join with the 1 kHz file first; a CSV resampled upstream) hold
    only the interpolation's faded images of their noise above 50 Hz, where the
    floor was read (above fs/4): 39.98 Hz instead of 1.67 Hz, the acceleration
    error 5e2 times its least. The joint's own rate is now recognized (second
    differences zero between knots every L samples; repeats for a hold) and its
    noise, of shape sinc(f/f_e)^(2k), read below its own Nyquist frequency:
    1.69 Hz (held: 1.71 Hz; the 100 Hz log itself 1.71 Hz, the truth 1.39 Hz).
    The noise-limited cutoff (the bound on a given one) read it alike."""
    from drake_dynid.core.idim_auto import (
        noise_limited_cutoff,
        resampled_joints,
        resampled_note,
    )

    q, _ = _design(100.0, 20.0, 1e-2)
    native = auto_cutoff(q, 0.01)
    t = np.arange(q.shape[0]) * 0.01
    for offset in (0.0, 3.7e-4):  # knots on the 1 kHz stamps, or between them
        fine = np.arange(offset, t[-1], H)
        linear = np.column_stack([np.interp(fine, t, q[:, j]) for j in range(2)])
        assert auto_cutoff(linear, H) == pytest.approx(native, rel=0.05)
        # The limit of a given cutoff likewise: 10.25 Hz (10.5 Hz at 100 Hz),
        # not the Nyquist frequency's 500 Hz.
        limit = noise_limited_cutoff(linear, H)
        assert limit == pytest.approx(noise_limited_cutoff(q, 0.01), rel=0.1)
    held = np.repeat(q, 10, axis=0)
    assert auto_cutoff(held, H) == pytest.approx(native, rel=0.05)
    truth = _best_cutoff(linear, _design(0.0, 0.0, 0.0, t=fine)[1], H)
    assert truth <= auto_cutoff(linear, H) <= 1.5 * truth  # 1.69 Hz for 1.39 Hz
    # 30 Hz onto 1 kHz: 33.3 samples a knot.
    slow = np.arange(0.0, 20.0, 1 / 30)
    q30 = _design(30.0, 20.0, 1e-3)[0][: slow.size]
    fine = np.arange(0.0, slow[-1], H)
    onto = np.column_stack([np.interp(fine, slow, q30[:, j]) for j in range(2)])
    assert auto_cutoff(onto, H) == pytest.approx(auto_cutoff(q30, 1 / 30), rel=0.1)
    # One joint resampled, one measured at 1 kHz: each its own.
    both = np.column_stack([linear[:, 0], _design(1000.0, 19.99, 1e-2)[0][:, 1]])
    found = resampled_joints(both, H)
    assert [(j, kind) for j, _, kind in found] == [(0, 2)]
    assert found[0][1] == pytest.approx(100.0, rel=1e-3)
    note = resampled_note(found, ("arm", "torso"), H)
    assert "arm (linearly interpolated from about 100 Hz) look" in note, note
    assert "torso" not in note
    assert resampled_joints(q, 0.01) == [] and resampled_note([], ("a",), H) == ""


def test_a_short_run_gets_the_lowest_cutoff_it_can_take():
    """Found by a review: a run shorter than one 4 s Welch segment is one
    segment; its least-error cutoff (1.56 Hz on 1 s at 100 Hz) fell below the
    lowest whose trimmed ends leave a sample (4.17 Hz), and the off-line
    identification failed, while the truth is that lowest one (4.34 Hz on the
    truth's 2 % grid); 16 samples (9 bins 6.25 Hz apart) gave 12.5 Hz, the
    resolution's, not the log's. At least 64 samples are now needed."""
    from drake_dynid.core.idim_auto import lowest_cutoff

    q, acceleration = _design(100.0, 20.0, 1e-2)
    for samples in (64, 100, 200):
        cutoff = auto_cutoff(q[:samples], 0.01)
        assert cutoff >= lowest_cutoff(samples, 0.01)
        assert 2 * default_trim(0.01, cutoff) + 1 <= samples
        truth = _best_cutoff(q[:samples], acceleration[:samples], 0.01)
        assert cutoff == pytest.approx(truth, rel=0.05), (samples, truth)
    assert lowest_cutoff(100, 0.01) == pytest.approx(2.0 / 0.48)
    # Never above the 40 Hz cap (the identification then names the length).
    assert auto_cutoff(_design(1000.0, 0.064, 1e-4)[0], H) == MAX_AUTO_CUTOFF_HZ
    with pytest.raises(ValueError, match="q has 63 samples; at least 64 are needed"):
        auto_cutoff(q[:63], 0.01)


def test_a_slow_encoder_joint_does_not_raise_the_cutoff():
    """Found by a review: a 12-bit joint (2π/4096 rad a count) on a sine of 6.5
    counts at 0.1 Hz changes count 2.6 times a second; its rounding error is a
    staircase whose harmonics fall like 1/f², far above the white Δ²/(6·fs) at
    a few Hz, and stood as motion there: the joint alone gave 5.05 Hz (its
    truth, the least acceleration error, 0.24 Hz) and raised the log's cutoff
    from 3.13 Hz to 5.05 Hz (5.20 and 8.14 Hz on the other two). Its noise is
    now at least the staircase's, Δ²·r/(24·max(f, r)²)."""
    q, _ = _design(1000.0, 20.0, 1e-4)
    reference = auto_cutoff(q, H)
    t = np.arange(q.shape[0]) * H
    count = 2 * np.pi / 4096
    for amplitude, frequency in ((0.01, 0.1), (0.1, 0.01), (0.003, 0.5)):
        w = 2 * np.pi * frequency
        true = 0.3 + amplitude * np.sin(w * t)
        joint = np.round(true / count) * count
        assert auto_cutoff(np.column_stack([q, joint]), H) <= 1.05 * reference
        truth = _best_cutoff(joint[:, None], -(w**2) * (true - 0.3)[:, None], H)
        # 0.38, 0.5 and 1.04 Hz (truth 0.24, 0.23, 0.90 Hz; 0.25 Hz: the 4 s
        # segments' resolution, whose leakage of a 0.1 Hz line reaches 0.75 Hz)
        assert auto_cutoff(joint, H) <= 2.5 * max(truth, 0.25)


def test_one_odd_piece_does_not_lose_an_encoder_joints_quantum():
    """Found by a review: the cutoff's Welch pieces (2^17 samples) merged their
    quanta, and one piece not whole counts cost the whole joint its quantum: a
    12-bit joint on a 0.1 Hz sine of 6.5 counts (393 s at 1 kHz) with one sample
    0.3 count off in its second piece went from 0.376 Hz to the 40 Hz cap (65
    counts: 1.157 -> 40 Hz), and a log joined from a 12-bit and a 5000-count
    encoder (steps not whole numbers of each other) too. Each piece is now
    judged alone, compatible steps merged: 0.383 and 1.181 Hz; the two encoders
    0.387 and 1.204 Hz (each alone 0.376-0.387, 1.157-1.192 Hz)."""
    samples = 3 * (1 << 17)
    t = np.arange(samples) * H
    fine, coarse = 2 * np.pi / 5000, 2 * np.pi / 4096
    for amplitude in (0.01, 0.1):
        true = 0.3 + amplitude * np.sin(2 * np.pi * 0.1 * t)
        joint = np.round(true / coarse) * coarse
        clean = auto_cutoff(joint, H)
        joint[samples // 2] += 0.3 * coarse  # a glitch in the second piece
        assert auto_cutoff(joint, H) == pytest.approx(clean, rel=0.05)
        half = samples // 2
        joined = np.r_[joint[:half], np.round(true[half:] / fine) * fine]
        assert auto_cutoff(joined, H) <= 1.05 * max(
            clean, auto_cutoff(np.round(true / fine) * fine, H)
        )
    from drake_dynid.core.excitation import piece_quanta

    steps = piece_quanta([coarse, math.nan, 0.0, 2 * coarse, fine, 3 * fine])
    np.testing.assert_allclose(steps, [coarse, math.nan, 0.0, coarse, fine, fine])


def test_one_glitched_sample_does_not_lose_an_encoder_joints_quantum():
    """Found by a review: one sample 0.3 count off in a 20 s 12-bit joint (6.5
    and 65 counts at 0.1 Hz) made it "not counts" (every change had to be whole),
    and its automatic cutoff went from 0.38 / 1.17 Hz to the 40 Hz cap. Up to
    two changes off the counts (one odd sample) are now allowed, Δ fitted
    without them: 0.38 / 1.17 Hz; two odd samples still are not counts."""
    from drake_dynid.core.excitation import quantum

    t = np.arange(20000) * H
    count = 2 * np.pi / 4096
    for amplitude in (0.01, 0.1):
        joint = np.round((0.3 + amplitude * np.sin(0.2 * np.pi * t)) / count) * count
        clean = auto_cutoff(joint, H)
        joint[10000] += 0.3 * count
        assert auto_cutoff(joint, H) == pytest.approx(clean, rel=1e-6)
        assert quantum(joint) == pytest.approx(count, rel=1e-9)
        joint[15000] += 0.4 * count
        assert quantum(joint) == 0.0


def test_resampled_positions_are_read_where_their_spectrum_is():
    """Found by a review: whether a joint's positions were resampled was read on
    the first 2^17 samples alone: a joint at rest for 150 s, then moving with
    100 Hz positions (noise 1e-3 rad) interpolated onto 1 kHz for 250 s, was
    judged not resampled and its automatic cutoff went to 39.98 Hz (the 100 Hz
    positions: 2.10 Hz); dynid offline's note said nothing. The Welch pieces
    now vote by their segments (pieces at rest abstain): 2.12 Hz, and the note
    names the joint."""
    from _motions import band_limited

    from drake_dynid.core.idim_auto import resampled_joints

    moving = 250000
    q = band_limited(1000.0, moving * H, 0.0, 3)[1][:moving, 0]
    t = np.arange(moving) * H
    native = q[::10] + np.random.default_rng(1).normal(0.0, 1e-3, t[::10].shape)
    linear = np.interp(t, t[::10], native)
    log = np.r_[np.full(150000, linear[0]), linear]
    expected = auto_cutoff(native, 10 * H)  # 2.10 Hz
    assert auto_cutoff(log, H) == pytest.approx(expected, rel=0.05)
    found = resampled_joints(log, H)
    assert [(j, kind) for j, _, kind in found] == [(0, 2)]
    assert found[0][1] == pytest.approx(100.0, rel=1e-3)


def test_a_single_segment_reads_its_white_floor_without_bias():
    """Found by a review: a run of up to 6 s is one Welch segment, a periodogram,
    whose white-noise bins are exponential: their median is ln 2 of the density,
    and the cutoff's floor read 0.69 of it (σ 1e-4 rad, 1 and 2 s at 1 kHz, 20
    seeds); now 0.97 and 0.98. The cutoff of 1-2 s runs of the band-limited
    design (σ 1e-4 rad) moves by 1-2 % towards the least error (6.43 -> 6.36 Hz
    for 4.02 Hz; 4.33 -> 4.25 Hz for 3.23 Hz); averaged segments keep their
    median (the paper's 21 s logs unchanged)."""
    from drake_dynid.core.idim_auto import _spectra_and_floors

    for samples in (1000, 2000):
        ratios = []
        for seed in range(20):
            x = np.random.default_rng(seed).normal(0.0, 1e-4, (samples, 1))
            noise = _spectra_and_floors("test", x, H)[3]
            ratios.append(noise[5, 0] / (2e-8 * H))
        assert 0.9 < np.mean(ratios) < 1.1, np.mean(ratios)


def test_the_automatic_cutoff_is_chosen_for_the_filters_order(robot, noisy_log):
    """``auto_cutoff`` weighs the zero-phase Butterworth's droop, G = 1/(1 +
    (f/f_c)^(2N)): identify_offline and the validation chose it for N = 4 whatever
    their ``filter_order`` (a gentler order-2 filter needs a higher cutoff for the
    same droop: 1.62 Hz for N = 4, 2.04 Hz for N = 2 on this SNR 30 dB log)."""
    from drake_dynid.validation import validate_torques

    q, h = np.asarray(noisy_log.q), noisy_log.time_step
    fourth, second = auto_cutoff(q, h), auto_cutoff(q, h, order=2)
    assert second > 1.2 * fourth
    fit = identify_offline(noisy_log, robot, filter_order=2)
    assert fit.settings["cutoff_hz"] == second
    assert identify_offline(noisy_log, robot).settings["cutoff_hz"] == fourth
    check = validate_torques(noisy_log, robot, fit.theta, filter_order=2)
    assert check.settings["cutoff_hz"] == second
    with pytest.raises(ValueError, match="order"):
        auto_cutoff(q, h, order=0)


def test_auto_decimation_and_its_cutoff(clean_log):
    assert auto_decimation(H, 1.0) == 250  # decimated Nyquist 2 Hz = 2·f_d
    assert auto_decimation(H, 40.0) == 6
    assert auto_decimation(H, 400.0) == 1
    # f_d = min(f_c, 1.5·B) with B the velocity band (0.5 Hz trajectory).
    f_d = auto_decimation_cutoff(clean_log.q, H, 40.0)
    assert 0.6 <= f_d <= 1.0
    assert auto_decimation_cutoff(clean_log.q, H, 0.3) == 0.3
    # No motion: the band cannot be measured; f_d falls back to f_c.
    assert auto_decimation_cutoff(np.zeros((1000, 2)), H, 5.0) == 5.0


def test_the_measured_dead_zone_leaves_a_noise_free_log_exact():
    """Found by a review: the dead-zone width measured the velocity above the
    decimation's band f_d, where the order-8 edge passed the motion itself: a
    noise-free log got ~1e-3 rad/s of "noise" and a dead zone that biased every
    estimate. Measured above 2 f_d (and by the white floor) it is ~1e-8 rad/s,
    and the estimate equals the exact sign's (Drake's inverse dynamics, the
    URDF's Coulomb friction).
    """
    from _drake_dynamics import exact_paper_2r

    from drake_dynid.core.friction import DeadZoneSign
    from drake_dynid.offline import standstill_widths

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = exact_paper_2r(robot)
    log = RobotLog(t, q, tau, robot.joint_names, H)
    widths = standstill_widths(log)
    assert np.all(widths < 1e-6), widths
    exact = identify_offline(log, robot)
    zoned = identify_offline(log, robot.with_sign(DeadZoneSign(tuple(widths))))
    truth = robot.base_values
    assert np.max(np.abs(exact.theta - truth) / np.abs(truth)) < 1e-3
    np.testing.assert_allclose(zoned.theta, exact.theta, rtol=1e-9)


def test_a_dead_zone_keeps_the_sign_of_a_moving_joints_reversals(monkeypatch):
    """Found by benchmarks/bench_dead_zone.py: the zone's 0 at the samples where a
    moving joint reverses through it is a model error the exact-sign friction of
    a log does not have (UR5 at 125 Hz: 5.5 σ of bias). On the noise-free 2R log
    (Drake's inverse dynamics, sign(v) friction) a 3 mrad/s zone left the
    estimates 1e-4 (2.5 σ) off the exact sign's; the off-line stream now gives a
    reversal's samples the sign of the motion either side (core.standstill.
    reversal_signs) and the estimates are the exact sign's, whatever the blocks
    the stream cuts the log into (each reads 2L + 1 velocities of context).
    """
    from _drake_dynamics import exact_paper_2r

    from drake_dynid.core.friction import DeadZoneSign

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = exact_paper_2r(robot)
    log = RobotLog(t, q, tau, robot.joint_names, H)
    # A 3 mrad/s zone is a noisy log's, filtered well below 30 Hz: the cutoff is
    # given (28.25 Hz, the automatic one before it weighed droop against noise;
    # this noise-free log now gets 34.8 Hz, where a reversal may take at most
    # L = 0.125/(f_c h) = 3 samples, fewer than this log's slowest reversal spends
    # in 3 mrad/s: read as rest by design, core.standstill.reversal_run).
    exact = identify_offline(log, robot, cutoff_hz=28.25)
    zoned = robot.with_sign(DeadZoneSign((0.003, 0.003)))
    result = identify_offline(log, zoned, cutoff_hz=28.25)
    np.testing.assert_allclose(result.theta, exact.theta, rtol=1e-9)
    # Blocks of 1500 samples (the default holds this log in one).
    import functools

    from drake_dynid.core import idim_stream

    plan = functools.partial(idim_stream.stream_plan, block=1500)
    monkeypatch.setattr(idim_stream, "stream_plan", plan)
    np.testing.assert_allclose(
        identify_offline(log, zoned, cutoff_hz=28.25).theta, exact.theta, rtol=1e-8
    )  # the position filter's block margins: 1e-9


def test_dynid_offline_notes_resampled_positions(tmp_path, capsys):
    """The reviewer's case end to end: a 2R log whose positions (noise 1e-3 rad)
    were sampled at 100 Hz and interpolated linearly onto its 1 kHz stamps.
    ``dynid offline`` says which joints look resampled and from what rate (so do
    ``dynid validate`` and ``dynid identify``, which said nothing); its
    automatic cutoff is the 100 Hz positions' (2.10 Hz; it was 39.98 Hz)."""
    import json

    from _drake_dynamics import exact_paper_2r

    from drake_dynid import cli
    from drake_dynid.logs import write_log

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = exact_paper_2r(robot)
    noisy = q[::10] + np.random.default_rng(2).normal(0.0, 1e-3, q[::10].shape)
    native = auto_cutoff(noisy, 10 * (t[1] - t[0]))
    linear = np.column_stack([np.interp(t, t[::10], noisy[:, j]) for j in range(2)])
    for name, positions, said in (("resampled", linear, True), ("raw", q, False)):
        path, out = tmp_path / f"{name}.csv", tmp_path / f"{name}.json"
        write_log(path, t, positions, tau, robot.joint_names)
        argv = ["offline", str(path), "--urdf", "planar_2r", "--quiet"]
        assert cli.main([*argv, "--json", str(out)]) == 0
        err = capsys.readouterr().err
        assert ("look resampled" in err) is said, err
        cutoff = json.loads(out.read_text())["settings"]["cutoff_hz"]
        if said:
            assert "joint1 (linearly interpolated from about 100 Hz)" in err, err
            assert "joint2 (linearly" in err and cutoff == pytest.approx(native, 0.1)
        # dynid validate and dynid identify read the same spectra: the same note.
        argv = ["validate", str(path), "--urdf", "planar_2r", "--params", str(out)]
        argv.append("--quiet")
        assert cli.main(argv) == 0
        err = capsys.readouterr().err
        assert ("validate: note: the positions of joint1 (linearly" in err) is said
        argv = ["identify", str(path), "--urdf", "planar_2r", "--quiet"]
        assert cli.main([*argv, "--bootstrap", "0"]) == 0
        err = capsys.readouterr().err
        assert ("identify: note: the positions of joint1 (linearly" in err) is said
        # The note names what identify measured (a review: it said 'the measured
        # position noise and excitation band' when it measured only the rows).
        assert ("the measured excitation band and the rows' choice read" in err) is said
        assert cli.main([*argv, "--bootstrap", "0", "--bandwidth", "2"]) == 0
        err = capsys.readouterr().err
        assert ("identify: note: the positions of joint1 (linearly" in err) is said
        assert ("the rows' choice read their noise" in err) is said
        assert "excitation band" not in err.split("positions of")[-1]


def test_a_sensor_slower_than_the_log_clock_keeps_its_cutoff():
    """Found by a review: a 980 Hz sensor read by a 1 kHz log (σ 1e-4 rad)
    repeats one sample in 50; each repeat is a position error of v·h, whose
    lines every 20 Hz stood 20 dB above the white floor up to 40 Hz, and the
    automatic cutoff went to the 40 Hz cap (the least acceleration error: 2.54
    Hz; 3.13 Hz for the same motion read without repeats). The joint's distinct
    samples are now read at the sensor's rate: 3.13 Hz; ``dynid offline`` names
    the joint, its repeat and the sensor's rate."""
    from drake_dynid.core.idim_auto import resampled_joints, resampled_note

    sensor = np.arange(19602) / 980.0
    direct, _ = _design(1000.0, 20.0, 1e-4)
    clean, _ = _design(980.0, 0.0, 0.0, t=sensor)
    read = clean + np.random.default_rng(7).normal(0.0, 1e-4, clean.shape)
    logged = read[np.floor(np.arange(20000) * 0.98 + 1e-9).astype(int)]
    assert auto_cutoff(logged, H) == pytest.approx(auto_cutoff(direct, H), rel=0.05)
    from drake_dynid.core.excitation import repeats

    assert repeats(logged[:, 0]).size == 399
    found = resampled_joints(logged, H)
    assert [(j, kind) for j, _, kind in found] == [(0, 0), (1, 0)]
    assert found[0][1] == pytest.approx(980.0, abs=0.5)
    note = resampled_note(found, ("arm", "torso"), H)
    assert "arm (one in about 50: a sensor at 980 Hz)" in note, note
    assert "look resampled" not in note
    # No repeats read in noise written with 6 decimals, counts, a held channel.
    noisy = np.round(direct[:, 0] + 0.3, 6)
    assert repeats(noisy).size == 0 and repeats(direct[:, 0]).size == 0
    count = 2 * np.pi / 4096
    assert repeats(np.round(direct[:, 0] / count) * count).size == 0
    assert repeats(np.repeat(direct[::10, 0], 10)).size == 0
