"""The log reader's time-stamp model: jitter, epochs, outliers, gaps, resampling."""

import pathlib
import re
import tracemalloc

import numpy as np
import pytest

from drake_dynid.core.timestamps import fill_short_runs, fit_time_grid, nominal_step
from drake_dynid.logs import RobotLog, read_log, write_log

JOINTS = ("a", "b")
DATA = pathlib.Path(__file__).parent / "data" / "logs"


def slot_log(path, t, h=1e-3):
    """A log whose q holds the true slot k of each row: q = (k, -k), tau = (2k, k)."""
    k = np.rint((np.asarray(t) - t[0]) / h) if np.ndim(t) else None
    q = np.column_stack([k, -k])
    write_log(path, t, q, np.column_stack([2 * k, k]), JOINTS)
    return k


@pytest.mark.parametrize(
    ("jitter", "n"),
    [(0.05, 30_001), (0.2, 30_001), (0.2, 1_001), (0.01, 100_001)],
)
def test_jitter_is_snapped_to_the_least_squares_grid(tmp_path, jitter, n):
    """Issue 14: ±5 % was rejected from 1 000 samples, ±1 % from 30 000 (drift)."""
    rng = np.random.default_rng(n)
    k = np.arange(n)
    t = 1e-3 * k + 1e-3 * rng.uniform(-jitter, jitter, n)
    write_log(tmp_path / "j.csv", t, np.column_stack([k, -k]), np.zeros((n, 2)), JOINTS)
    log = read_log(tmp_path / "j.csv", JOINTS)
    assert log.time_step == 1e-3 and log.num_samples == n
    np.testing.assert_array_equal(log.q[:, 0], k)  # every row on its own slot
    np.testing.assert_array_equal(log.t, 1e-3 * k)
    assert abs(log.time_offset) < jitter * 1e-3
    (note,) = log.warnings
    assert "jitter up to" in note and "snapped" in note


def test_jitter_beyond_the_tolerance_is_non_uniform_sampling(tmp_path):
    rng = np.random.default_rng(4)
    t = 1e-3 * np.arange(1000) + rng.uniform(-3e-4, 3e-4, 1000)
    slot_log(tmp_path / "j.csv", t)
    # Most stamps off (±30 % jitter): the spread of the steps, not the worst
    # stamp against a wrongly fitted grid (a review found "11.78 steps off").
    with pytest.raises(
        ValueError,
        match=r"non-uniform sampling: \d+ of 1000 stamps are more than 0.25 step off"
        r" any uniform grid: the steps between stamps range from 0.4\d to 1.5\d",
    ):
        read_log(tmp_path / "j.csv", JOINTS)
    log = read_log(tmp_path / "j.csv", JOINTS, resample=True)
    assert log.time_step == 1e-3 and abs(log.num_samples - 1000) <= 1


def test_a_real_ros_log_with_20_percent_jitter_is_read():
    """TIAGo arm, 100 Hz ROS stamps (tests/data/logs/README.md)."""
    path = DATA / "tiago_arm_excerpt.csv"
    log = read_log(path, ["arm_1_joint", "arm_2_joint"])
    raw = np.loadtxt(path, delimiter=",", skiprows=1)
    assert log.time_step == 0.01 and log.num_samples == raw.shape[0] == 1000
    np.testing.assert_array_equal(log.q, raw[:, 1:3])
    np.testing.assert_array_equal(log.tau, raw[:, 3:5])
    assert log.time_offset == pytest.approx(raw[0, 0], abs=2e-3)
    (note,) = log.warnings
    assert re.search(r"\((19|20)\.\d % of the step 0.01 s\)", note)
    with pytest.raises(ValueError, match="non-uniform sampling"):
        read_log(path, ["arm_1_joint", "arm_2_joint"], jitter_tolerance=0.1)


def test_epoch_time_stamps_are_rebased(tmp_path):
    """Issue 14: 1.7e9 + k·1 ms was rejected after 30 s."""
    k = np.arange(60_001)
    slot_log(tmp_path / "e.csv", 1.7e9 + 1e-3 * k)
    log = read_log(tmp_path / "e.csv", JOINTS)
    assert log.time_step == 1e-3 and log.time_offset == 1.7e9
    np.testing.assert_array_equal(log.q[:, 0], k)
    assert log.t[0] == 0.0 and log.warnings == ()


def test_integer_nanosecond_stamps_are_read_exactly(tmp_path):
    k = np.arange(5000)
    stamps = [1_700_000_000_123_456_789 + 1_000_000 * int(i) for i in k]
    text = "t,q_a,q_b,tau_a,tau_b\n" + "".join(
        f"{s},{i},{-i},0,0\n" for s, i in zip(stamps, k, strict=True)
    )
    (tmp_path / "ns.csv").write_text(text)
    log = read_log(tmp_path / "ns.csv", JOINTS)
    assert log.time_step == 1e-3
    assert log.time_offset == pytest.approx(1_700_000_000.123456789, abs=1e-6)
    np.testing.assert_array_equal(log.q[:, 0], k)
    assert any("nanoseconds since the epoch" in w for w in log.warnings)
    # No round-off jitter from float parsing (256 ns at 1.7e18): nothing snapped.
    assert not any("jitter" in w for w in log.warnings)
    arrays = RobotLog.from_arrays(
        np.array(stamps), np.zeros((5000, 2)), np.zeros((5000, 2)), JOINTS
    )
    assert arrays.time_step == 1e-3


@pytest.mark.parametrize("first", [1.7e12, 1.7e15, -1e12])
def test_stamps_that_cannot_be_seconds_are_refused(tmp_path, first):
    slot_log(tmp_path / "u.csv", first + 1e-3 * np.arange(10) * abs(first) / 1e9)
    with pytest.raises(ValueError, match=r"cannot be seconds.*t must be in seconds"):
        read_log(tmp_path / "u.csv", JOINTS)


@pytest.mark.parametrize(("rate", "step"), [(125, 0.008), (909.0909090909091, 0.0011)])
def test_the_step_is_the_round_number_of_the_logger(tmp_path, rate, step):
    rng = np.random.default_rng(7)
    t = np.arange(20_000) / rate + rng.uniform(-0.03, 0.03, 20_000) / rate
    slot_log(tmp_path / "r.csv", t, 1 / rate)
    log = read_log(tmp_path / "r.csv", JOINTS)
    assert log.time_step == step
    np.testing.assert_array_equal(log.q[:, 0], np.arange(20_000))


N30 = 30_001  # a 30 s log at 1 kHz


@pytest.mark.parametrize(
    ("row", "stamp"),
    [
        (N30 - 1, 1e6),  # issue 14: inserted 1e9 "dropped samples"
        (N30 - 1, 3.0),  # going back
        (0, 1e6),
        (0, -5.0),
        (15_000, 3.0),  # isolated, going back
        (15_000, 1e6),
        (15_000, 15.0004),  # 0.4 step off, between its neighbours
        (15_000, np.nan),
    ],
)
def test_one_corrupted_stamp_is_dropped_with_a_warning_naming_its_row(
    tmp_path, row, stamp
):
    t = 1e-3 * np.arange(N30)
    k = slot_log(tmp_path / "s.csv", t)
    t[row] = stamp
    write_log(
        tmp_path / "s.csv", t, np.column_stack([k, -k]), np.zeros((N30, 2)), JOINTS
    )
    tracemalloc.start()
    log = read_log(tmp_path / "s.csv", JOINTS)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50e6
    middle = 0 < row < N30 - 1
    assert log.num_samples == (N30 if middle else N30 - 1)
    assert log.time_step == 1e-3
    assert any(f"dropped row {row + 2}" in w for w in log.warnings)
    expected = np.arange(N30) if middle else np.delete(np.arange(N30), row)
    np.testing.assert_allclose(log.q[:, 0], expected, atol=1e-9)  # slot refilled
    assert np.flatnonzero(log.filled).tolist() == ([row] if middle else [])


@pytest.mark.parametrize(
    ("stamps", "match"),
    [
        # A gap 30 000 times longer than the log: refused before any allocation.
        (
            np.r_[1e-3 * np.arange(15_000), 1e6 + 1e-3 * np.arange(15_000)],
            r"gap of 999985 s between row 15001 \(t = 14.999\) and row 15002 "
            r"\(t = 1000000\) would insert about 999985000 missing samples.*"
            "more than the 30000 allowed.*split the log there",
        ),
        (
            np.r_[1e-3 * np.arange(1000), 5 + 1e-3 * np.arange(1000)],
            "gap of 4.001 s between row 1001",
        ),
        (
            1e-3 * np.tile(np.arange(500), 2),
            "not increasing at row 502 .*sort the log by time",
        ),
        (1e-3 * np.arange(1000)[::-1], "not increasing at row 3"),
    ],
)
def test_breaks_that_are_not_outliers_are_errors_naming_the_rows(
    tmp_path, stamps, match
):
    slot_log(tmp_path / "g.csv", stamps)
    tracemalloc.start()
    with pytest.raises(ValueError, match=match):
        read_log(tmp_path / "g.csv", JOINTS)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 50e6


def test_the_total_of_the_gaps_is_bounded_by_the_rows_read(tmp_path):
    k = (np.arange(1000)[:, None] * 11 + np.arange(3)).ravel()  # 3 rows, 8 missing
    slot_log(tmp_path / "m.csv", 1e-3 * k)
    with pytest.raises(
        ValueError, match=r"insert \d{4} missing samples, more than the 3000"
    ):
        read_log(tmp_path / "m.csv", JOINTS)


def test_dropped_samples_short_gaps_filled_long_gaps_bad(tmp_path):
    """Issue 14: 13 dropped samples in 30 s left no valid on-line window."""
    n = 30_001
    t = 1e-3 * np.arange(n)
    gone = [100, 2000, 2001, 9000, 9001, 9002, 9003, 9004, *range(20_000, 20_006)]
    keep = np.setdiff1d(np.arange(n), gone)
    q = np.column_stack([np.sin(3 * t), np.cos(2 * t)])
    tau = np.column_stack([t, 2 * t])
    write_log(tmp_path / "d.csv", t[keep], q[keep], tau[keep], JOINTS)
    log = read_log(tmp_path / "d.csv", JOINTS)
    assert log.num_samples == n
    np.testing.assert_array_equal(np.flatnonzero(log.filled), gone[:8])
    np.testing.assert_array_equal(np.flatnonzero(log.bad_samples), gone[8:])
    np.testing.assert_allclose(log.q[gone[:8]], q[gone[:8]], atol=1e-9)
    np.testing.assert_allclose(log.tau[gone[:8]], tau[gone[:8]], atol=1e-12)
    (note,) = [w for w in log.warnings if "dropped" in w]
    assert note.startswith("14 dropped sample(s) (missing time stamps) in 4 gap(s)")
    assert "8 filled by interpolation" in note and "6 inserted as bad" in note
    assert "the longest: 6 samples between row 19993 and row 19994" in note


def test_resample_interpolates_a_non_uniform_log_onto_the_fitted_grid(tmp_path):
    rng = np.random.default_rng(3)
    t = np.cumsum(np.r_[0.0, rng.uniform(1e-3, 2e-3, 999)])
    x = np.column_stack([t, 2 * t])
    write_log(tmp_path / "g.csv", t, x, x, JOINTS)
    with pytest.raises(ValueError, match=r"non-uniform sampling.*--resample"):
        read_log(tmp_path / "g.csv", JOINTS)
    log = read_log(tmp_path / "g.csv", JOINTS, resample=True)
    # Linear signals are reproduced exactly by linear interpolation.
    np.testing.assert_allclose(log.q[:, 1], 2 * (log.t + log.time_offset), atol=1e-12)
    assert log.time_step == pytest.approx((t[-1] - t[0]) / 999, rel=0.05)
    assert any("resampled by linear interpolation" in w for w in log.warnings)


def test_resample_interpolates_jittered_samples_and_marks_long_gaps(tmp_path):
    rng = np.random.default_rng(5)
    k = np.delete(np.arange(2000), np.r_[500, 1000:1020])
    t = 1.7e9 + 1e-3 * k + rng.uniform(-1e-4, 1e-4, k.size)
    x = np.column_stack([t - 1.7e9, 3 * (t - 1.7e9)])
    write_log(tmp_path / "r.csv", t, x, x, JOINTS)
    log = read_log(tmp_path / "r.csv", JOINTS, resample=True)
    assert log.time_step == 1e-3 and log.time_offset == pytest.approx(1.7e9, abs=1e-3)
    good = ~log.bad_samples
    np.testing.assert_allclose(
        log.q[good, 1], 3 * (log.t[good] + log.time_offset - 1.7e9), atol=1e-6
    )
    assert set(np.flatnonzero(log.bad_samples)) <= set(range(995, 1025))
    assert log.bad_samples.sum() >= 19 and log.filled[498:502].any()


@pytest.mark.parametrize(
    ("h", "expected"),
    [
        (0.0010000000012, 0.001),
        (0.00999996, 0.01),
        (0.0011000003, 0.0011),
        (1 / 3000 * (1 + 3e-6), 1 / 3000),
        (0.001003, 0.001003),
        (0.0012345678, 1 / 810),
        (0.0012345, 0.0012345),
        (0.00123, 0.00123),
    ],
)
def test_nominal_step(h, expected):
    assert nominal_step(h) == expected


def test_fit_time_grid_reports_slots_and_outliers():
    t = 1e-3 * np.array([0, 1, 2, 4, 5, 6, 7, 8, 9, 10], float)
    t[5] = 100.0
    grid = fit_time_grid(t)
    assert grid.outliers.tolist() == [5]
    assert grid.slots.tolist() == [0, 1, 2, 4, 5, 7, 8, 9, 10]
    assert grid.num_slots == 11 and grid.step == 1e-3


def test_fill_short_runs_cubic_is_exact_on_cubics_and_leaves_the_rest():
    x = np.arange(30.0)
    col = 0.5 * x**3 - x**2 + 3.0
    data = np.column_stack([col, col])
    data[[0, 10, 11, 12, 20, 29], 0] = np.nan
    data[15:25, 1] = np.nan
    out, mask = fill_short_runs(data, 3, cubic=True)
    np.testing.assert_allclose(out[[10, 11, 12, 20], 0], col[[10, 11, 12, 20]])
    assert np.isnan(out[[0, 29], 0]).all() and np.isnan(out[15:25, 1]).all()
    assert mask[:, 0].sum() == 4 and not mask[:, 1].any()
    linear, _ = fill_short_runs(data, 3)
    assert linear[11, 0] == pytest.approx((col[9] + col[13]) / 2)


@pytest.mark.parametrize(("scale", "unit"), [(1e3, "ms"), (1e9, "ns")])
def test_stamps_in_another_unit_are_said_with_the_fix(tmp_path, scale, unit):
    """Found by a review: ms or relative ns stamps read as seconds (h = 1 s, 1e6 s)
    gave nonsense estimates and option errors without a word about the unit."""
    k = np.arange(2000)
    write_log(
        tmp_path / "u.csv",
        1e-3 * scale * k,
        np.zeros((k.size, 2)),
        np.zeros((k.size, 2)),
        JOINTS,
    )
    # Not said: an error naming the step and the likely unit (a new user's
    # walk-through: the warning alone let ms stamps give confident nonsense).
    with pytest.raises(ValueError, match=f"{unit} gives 1000 Hz.*--time-unit {unit}"):
        read_log(tmp_path / "u.csv", JOINTS)
    # Said (a log truly sampled this slowly): the warning.
    log = read_log(tmp_path / "u.csv", JOINTS, time_unit="s")
    (note,) = log.warnings
    assert f"the time step is {1e-3 * scale:g} s" in note and "time_unit" in note
    with pytest.raises(ValueError, match="time_unit"):  # also in a length error
        read_log(tmp_path / "u.csv", JOINTS, min_duration=1e12, time_unit="s")
    write_log(
        tmp_path / "s.csv",
        0.1 * k,
        np.zeros((k.size, 2)),
        np.zeros((k.size, 2)),
        JOINTS,
    )
    assert read_log(tmp_path / "s.csv", JOINTS).warnings == ()  # 10 Hz: no note


@pytest.mark.parametrize("step", [5e-324, 1e-300, 1e-12, 1e-6])
def test_a_step_too_short_for_a_robot_log_is_refused_naming_the_unit(tmp_path, step):
    """Found by a review: subnormal steps (1/h = inf) were an OverflowError in the
    cutoff choice (exit 1), and --time-unit ms on a log in seconds (h = 1e-6 s)
    asked for a longer log or a higher cutoff instead of naming the unit."""
    k = np.arange(100)
    slot_log(tmp_path / "f.csv", step * k, h=step)
    with pytest.raises(ValueError, match=r"time step is .* s, too short.*time_unit"):
        read_log(tmp_path / "f.csv", JOINTS)
    with pytest.raises(ValueError, match="too short for a robot log"):
        RobotLog.from_arrays(step * k, np.zeros((100, 2)), np.zeros((100, 2)), JOINTS)


def test_the_json_log_entry_keeps_the_original_time(tmp_path):
    """A review: results times (last_valid_time, changes) are on the re-based
    grid and the JSON did not say where it started for an epoch-stamped log."""
    from argparse import Namespace

    from drake_dynid.commands._report import log_document

    slot_log(tmp_path / "e.csv", 1.7e9 + 1e-3 * np.arange(2001))
    log = read_log(tmp_path / "e.csv", JOINTS)
    entry = log_document(Namespace(log=str(tmp_path / "e.csv")), log)
    assert entry["time_offset"] == 1.7e9 and entry["duration"] == 2.0


@pytest.mark.parametrize("where", [1, 101, 998])
def test_two_swapped_rows_are_refused_naming_both_as_the_drive_reader_does(
    tmp_path, monkeypatch, where
):
    """A review: a plain log with two rows swapped (time going back) had one of
    them dropped as an outlier (a real sample thrown away and interpolated),
    while the drive reader refused the same file. Both refuse it now, naming the
    two rows (data rows ``where``, ``where + 1`` are file rows + 1); one corrupted
    stamp amid good ones is still an outlier of the plain reader."""
    from drake_dynid import log_repair
    from drake_dynid.core import blocks
    from drake_dynid.core.drive import DriveChain
    from drake_dynid.raw_log import read_raw_log

    monkeypatch.setattr(blocks, "BLOCK_ROWS", 100)  # a swap across blocks
    monkeypatch.setattr(log_repair, "BLOCK_ROWS", 100)
    t = 1e-3 * np.arange(1000)
    t[[where, where + 1]] = t[[where + 1, where]]
    slot_log(tmp_path / "s.csv", t)
    row = rf"row {where + 3} \(t = {t[where + 1]:g}\) after row {where + 2}"
    with pytest.raises(ValueError, match=rf"not increasing at {row}.*wrong order"):
        read_log(tmp_path / "s.csv", JOINTS)
    chain = DriveChain.from_dict({}, JOINTS, source="identity")
    with pytest.raises(ValueError, match=rf"not increasing at {row}"):
        read_raw_log(tmp_path / "s.csv", chain)
    with pytest.raises(ValueError, match=rf"sample {where + 1} .* after sample"):
        RobotLog.from_arrays(t, np.zeros((1000, 2)), np.zeros((1000, 2)), JOINTS)
    t = 1e-3 * np.arange(1000)
    t[where] = -5.0 if where > 1 else 0.5  # one stamp going back (or far ahead)
    slot_log(tmp_path / "o.csv", t)
    log = read_log(tmp_path / "o.csv", JOINTS)
    assert any("outliers" in w for w in log.warnings), log.warnings


def restarted(n1, n2, gap, jitter=0.0, seed=0):
    """Stamps 1 ms apart with one gap of ``gap`` s after row n1 - 1 (a restart)."""
    t1 = 1e-3 * np.arange(n1)
    t = np.r_[t1, 1e-3 * np.arange(n2) + t1[-1] + gap]
    return t + 1e-3 * np.random.default_rng(seed).uniform(-jitter, jitter, t.size)


def test_a_gap_off_the_grid_splits_the_log_unfilled_each_part_on_its_grid(tmp_path):
    """A 5.5 ms gap (4.5 steps) was filled by cubic interpolation with the later
    part's 30 000 stamps snapped by half a step (jitter 25 %), silently."""
    t = restarted(3000, 3000, 5.5e-3)
    k = np.arange(t.size, dtype=float)  # q = row number: where each row went
    write_log(
        tmp_path / "g.csv", t, np.column_stack([k, -k]), np.ones((t.size, 2)), JOINTS
    )
    log = read_log(tmp_path / "g.csv", JOINTS)
    assert log.time_step == 1e-3 and log.num_samples == 6005
    np.testing.assert_array_equal(log.q[:3000, 0], k[:3000])
    assert np.all(np.isnan(log.q[3000:3005]))  # 5 empty slots, never filled
    np.testing.assert_array_equal(log.q[3005:, 0], k[3000:])
    assert not log.filled.any()
    assert log.good_segments() == [(0, 3000), (3005, 6005)]
    assert not any("jitter" in w for w in log.warnings)
    (note,) = [w for w in log.warnings if "restarted" in w]
    assert (
        "a gap of 5.5 ms, 4.5 steps of 0.001 s, between row 3001 and row 3002" in note
    )
    assert "placed 0.5 ms later" in note and "split" in note


@pytest.mark.parametrize("gap", [5.5e-3, 1.2345])
def test_a_long_log_with_a_restart_is_read_not_refused(tmp_path, gap):
    """50 000 + 10 000 rows, a 5.5 ms gap: refused as non-uniform sampling ('0.28
    steps off') with --resample advised; a 1.2345 s gap: h fitted 0.99999 ms."""
    t = restarted(50_000, 10_000, gap)
    slot_log(tmp_path / "g.csv", t)
    log = read_log(tmp_path / "g.csv", JOINTS)
    assert log.time_step == 1e-3 and len(log.good_segments()) == 2
    assert abs(log.time_offset) == 0.0
    assert not any("jitter" in w for w in log.warnings)


@pytest.mark.parametrize("jitter", [0.05, 0.2])
def test_a_jittered_log_with_a_dropped_sample_is_not_split(tmp_path, jitter):
    """A gap of a whole number of steps (2 steps ± the jitter) stays one log, filled."""
    t = restarted(3000, 3000, 2e-3, jitter, seed=3)
    slot_log(tmp_path / "g.csv", t)
    log = read_log(tmp_path / "g.csv", JOINTS)
    assert log.num_samples == 6001 and log.filled.sum() == 1
    assert len(log.good_segments()) == 1
    assert not any("restarted" in w for w in log.warnings)
