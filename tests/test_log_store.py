"""Long logs a block at a time (log_store, core.blocks): same numbers, less memory.

A log is "long" beyond ``log_store.SPILL_BYTES``; the tests make every log long by
shrinking that limit (and the reader's text blocks, the sinks' buffers and the
chunks of the grid fit, the filters and the least squares), and compare with the
in-memory path, which is the reader and the off-line chain as before (bit for bit:
the stored arrays hold the float64 values themselves, and the consumers use the
same blocks whatever the storage). Chunked sums (grid fit, column norms, the
blocked QR) and block-wise zero-phase filters differ from their one-piece versions
by round-off only: the tolerances below are round-off (1e-12 relative on the grid,
1e-9 σ on the estimates, 1e-7 relative on the dead-zone widths, whose residual is
1e-4 of the motion and whose differentiation amplifies q's round-off by 1/h).
"""

import pathlib
import tracemalloc

import numpy as np
import pytest

import drake_dynid.core.lsq as lsq
import drake_dynid.core.standstill as standstill
import drake_dynid.core.timestamps as timestamps
import drake_dynid.log_store as log_store
import drake_dynid.log_table as log_table
from drake_dynid.core.blocks import BLOCK_ROWS, is_stored
from drake_dynid.log_store import GridTimes, RowSink
from drake_dynid.logs import RobotLog, read_log, write_log
from drake_dynid.offline import identify_offline, standstill_widths
from drake_dynid.plants import RobotModel, model_path

TIAGO = pathlib.Path(__file__).parent / "data" / "logs"


@pytest.fixture
def long_logs(monkeypatch):
    """Every log read is stored on disk, its text read in small blocks."""
    monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
    monkeypatch.setattr(log_table, "BLOCK_BYTES", 700)


def _stored(sink_rows, width):
    sink = RowSink(width, limit=0)
    for block in sink_rows:
        sink.append(block)
    return sink.finish()


def test_a_stored_array_indexes_like_the_array(monkeypatch):
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 64)
    rng = np.random.default_rng(0)
    x = rng.normal(size=(57, 3))
    stored = _stored(np.array_split(x, 5), 3)
    assert is_stored(stored) and stored.shape == x.shape and len(stored) == 57
    indices = [
        3,
        -1,
        np.int64(7),
        slice(None),
        slice(5, 20),
        slice(50, 90),
        slice(2, 40, 7),
        slice(None, None, -3),
        np.array([4, 0, 56, 4, -2]),
        rng.random(57) < 0.3,
        (slice(1, 9), 2),
        (slice(1, 9), slice(0, 2)),
        (4, 1),
        (np.array([9, 1]), [0, 2]),
    ]
    for index in indices:
        np.testing.assert_array_equal(stored[index], x[index])
    np.testing.assert_array_equal(np.asarray(stored), x)
    view = stored.rows(10, 40)
    assert is_stored(view) and view.shape == (30, 3)
    np.testing.assert_array_equal(view[5:9], x[15:19])
    np.testing.assert_array_equal(np.asarray(view.rows(-5, 100)), x[35:40])
    with pytest.raises(IndexError):
        stored[57]
    vector = RowSink(1, limit=0)
    vector.append(x[:, :1])
    column = vector.finish(vector=True)
    assert column.shape == (57,) and float(column[6]) == x[6, 0]
    np.testing.assert_array_equal(column[np.array([3, 1])], x[[3, 1], 0])


def test_grid_times_equal_step_times_arange():
    times = GridTimes(1e-3, 1000)
    full = 1e-3 * np.arange(1000)
    for index in (0, -1, 777, slice(3, 90, 4), np.array([5, 999])):
        np.testing.assert_array_equal(times[index], full[index])
    np.testing.assert_array_equal(np.asarray(times.rows(100, 200)), full[100:200])
    assert times.rows(100, 200)[0] == full[100]


def _messy_log(path, seed):
    """Jitter, dropped samples, short and long runs of bad cells, an outlier."""
    rng = np.random.default_rng(seed)
    n = 3000
    slots = np.arange(n) + np.cumsum(rng.random(n) < 0.003)
    t = 5.0 + 2e-3 * slots + 2e-4 * rng.uniform(-1, 1, n)
    t[1500] += 2e-3 * 0.45  # off the grid between good neighbours: an outlier
    q = np.column_stack([np.sin(3e-3 * slots), np.cos(2e-3 * slots)])
    tau = rng.normal(size=(n, 2))
    q[100:103, 0] = np.nan  # filled
    tau[900:920, 1] = np.nan  # kept bad
    write_log(path, t, q, tau, ("a", "b"))


@pytest.mark.parametrize("case", ["tiago", "messy", "nanoseconds"])
def test_a_stored_log_reads_the_same_numbers_and_warnings(tmp_path, monkeypatch, case):
    if case == "tiago":
        path, joints = TIAGO / "tiago_arm_excerpt.csv", ("arm_1_joint", "arm_2_joint")
    else:
        path, joints = tmp_path / "log.csv", ("a", "b")
        _messy_log(path, seed=1)
        if case == "nanoseconds":
            text = path.read_text().splitlines()
            rows = [text[0]]
            for k, line in enumerate(text[1:]):
                stamp = 1_700_000_000_000_000_000 + 2_000_000 * k + (k % 7) * 1000
                rows.append(f"{stamp}," + line.split(",", 1)[1])
            path.write_text("\n".join(rows) + "\n")
    memory = read_log(path, joints)
    assert not is_stored(memory.q)
    monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
    monkeypatch.setattr(log_table, "BLOCK_BYTES", 700)
    stored = read_log(path, joints)
    assert is_stored(stored.q) and is_stored(stored.tau) and is_stored(stored.t)
    for name in ("t", "q", "tau", "filled"):
        np.testing.assert_array_equal(
            np.asarray(getattr(stored, name)), np.asarray(getattr(memory, name))
        )
    assert stored.warnings == memory.warnings and memory.warnings
    assert stored.time_step == memory.time_step
    assert stored.time_offset == memory.time_offset
    np.testing.assert_array_equal(stored.bad_samples, memory.bad_samples)
    assert stored.good_segments() == memory.good_segments()


def _arm_log(robot, seconds, seed=5):
    from drake_dynid.core.trajectory import random_fourier_trajectory

    trajectory = random_fourier_trajectory(
        robot.num_joints,
        harmonics=5,
        base_frequency=2 * np.pi / 10.0,
        max_velocity=3.0,
        rng=np.random.default_rng(seed),
    )
    t = 1e-3 * np.arange(round(seconds / 1e-3))
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    rng = np.random.default_rng(0)
    q += 1e-4 * rng.normal(size=q.shape)
    tau += 0.01 * tau.std(axis=0) * rng.normal(size=tau.shape)
    q[20000:20040] = np.nan  # two segments
    return t, q, tau


def test_the_offline_chain_on_a_stored_log_equals_the_in_memory_log(
    tmp_path, long_logs
):
    # A stored log is read a block at a time by the very computations that run
    # on an array: the same numbers, bit for bit.
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = _arm_log(robot, 40.0)
    write_log(tmp_path / "arm.csv", t, q, tau, robot.joint_names)
    stored = read_log(tmp_path / "arm.csv", robot.joint_names)
    assert is_stored(stored.q)
    memory = RobotLog(
        np.asarray(stored.t),
        np.asarray(stored.q),
        np.asarray(stored.tau),
        stored.joint_names,
        stored.time_step,
    )
    widths = standstill_widths(stored)
    np.testing.assert_array_equal(widths, standstill_widths(memory))
    from drake_dynid.core.friction import DeadZoneSign

    model = robot.with_sign(DeadZoneSign(tuple(map(float, widths))))
    for weighted in (False, True):
        a = identify_offline(stored, model, weighted=weighted)
        b = identify_offline(memory, model, weighted=weighted)
        assert a.valid and a.num_segments == 2
        np.testing.assert_array_equal(a.theta, b.theta)
        np.testing.assert_array_equal(a.std, b.std)
        assert a.settings == b.settings


def test_the_grid_fit_in_chunks_equals_one_piece(monkeypatch):
    rng = np.random.default_rng(4)
    n = 5000
    slots = np.arange(n) + np.cumsum(rng.random(n) < 0.01)
    t = 1.7e9 + 1e-3 * slots + 1e-4 * rng.uniform(-1, 1, n)
    t[2222] += 4.5e-4  # an isolated outlier, dropped in the second pass
    whole = timestamps.fit_time_grid(t, edge_gap=5)
    monkeypatch.setattr(timestamps, "_CHUNK", 97)
    chunked = timestamps.fit_time_grid(t, edge_gap=5)
    np.testing.assert_array_equal(chunked.kept, whole.kept)
    np.testing.assert_array_equal(chunked.slots, whole.slots)
    assert not whole.kept[2222] and chunked.step == whole.step == 1e-3
    assert chunked.fitted_step == pytest.approx(whole.fitted_step, rel=1e-12)
    assert chunked.origin == pytest.approx(whole.origin, abs=1e-9)
    assert chunked.jitter == pytest.approx(whole.jitter, abs=1e-9)


def test_the_blocked_least_squares_equals_one_qr(monkeypatch):
    rng = np.random.default_rng(7)
    A = rng.normal(size=(3000, 12)) * np.logspace(-4, 4, 12)
    B = A @ rng.normal(size=12) + rng.normal(size=3000)
    whole = lsq.solve_least_squares(A, B)
    monkeypatch.setattr(lsq, "_BLOCK_ENTRIES", 1000)
    assert lsq._block_rows(12) < 3000 // 10  # many blocks
    blocked = lsq.solve_least_squares(A, B)
    assert whole.valid and blocked.valid
    assert np.max(np.abs(blocked.theta - whole.theta) / whole.std) < 1e-9
    np.testing.assert_allclose(blocked.std, whole.std, rtol=1e-9)
    assert blocked.condition_number == pytest.approx(whole.condition_number, 1e-9)
    assert blocked.residual_std == pytest.approx(whole.residual_std, rel=1e-12)


def test_the_dead_zone_widths_by_blocks_equal_one_block(monkeypatch):
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    _, q, _ = _arm_log(robot, 40.0)
    runs = [q[:20000], q[20040:]]
    whole = standstill.dead_zone_widths(runs, 1e-3, cutoff_hz=8.0, band_cutoff_hz=2.0)
    monkeypatch.setattr(standstill, "BLOCK_ROWS", 3000)
    blocks = standstill.dead_zone_widths(runs, 1e-3, cutoff_hz=8.0, band_cutoff_hz=2.0)
    np.testing.assert_allclose(blocks, whole, rtol=1e-7)


def test_reading_a_long_log_grows_by_a_fraction_of_its_size(tmp_path, monkeypatch):
    # Stored, the reader holds a few text blocks and chunks, the slots of the
    # grid (8 bytes a sample) and some masks (1 byte each), never t, q, tau
    # (8·(1 + 2n) bytes a sample) nor the text: the peak grows by less than
    # half of the log's values per extra sample.
    monkeypatch.setattr(log_store, "SPILL_BYTES", 1 << 14)
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 1 << 14)
    monkeypatch.setattr(log_table, "BLOCK_BYTES", 1 << 16)
    monkeypatch.setattr(timestamps, "_CHUNK", 1 << 13)
    rng = np.random.default_rng(2)
    peaks = []
    for n in (40_000, 160_000):
        t = 1e-3 * np.arange(n) + 1e-5 * rng.uniform(-1, 1, n)
        q, tau = rng.normal(size=(2, n, 2))
        write_log(tmp_path / "l.csv", t, q, tau, ("a", "b"))
        tracemalloc.start()
        log = read_log(tmp_path / "l.csv", ("a", "b"))
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        assert is_stored(log.q) and log.num_samples == n
    per_sample = (peaks[1] - peaks[0]) / 120_000
    assert per_sample < 0.5 * 8 * 5, per_sample


def test_identify_reads_a_long_log_in_part(tmp_path, monkeypatch, long_logs):
    """``dynid identify`` on a stored log never loads it whole (the rows' choice,
    the raw rows, the bandwidth, the dead zone, the noise levels and the bootstrap
    read pieces): a 1-hour 7-DOF log identified in about 200 MB (README
    Performance)."""
    import json
    import traceback

    import drake_dynid.core.excitation as excitation
    from drake_dynid import cli

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = _arm_log(robot, 100.0)  # its longest finite run: > BLOCK_ROWS
    path = tmp_path / "long.csv"
    write_log(path, t, q, tau, robot.joint_names)
    monkeypatch.setattr(excitation, "SPECTRUM_PIECE", 6000)
    loads = []
    read = log_store.StoredArray._read
    # Every other read is a block of at most BLOCK_ROWS (2^16) rows, a spectrum
    # piece (patched to 6000) or the window's samples; the reader and the dead
    # zone read blocks of up to 2^18 rows by design (their own tests), and the
    # note on resampled joints the automatic cutoff's Welch pieces (2^17 rows).
    blocked = {"read_log", "standstill_widths", "resampled_joints"}

    def counted(self, start, stop):
        names = {frame.name for frame in traceback.extract_stack()}
        if not names & blocked:
            loads.append(stop - start)
        return read(self, start, stop)

    monkeypatch.setattr(log_store.StoredArray, "_read", counted)
    out = tmp_path / "out.json"
    argv = ["identify", str(path), "--urdf", model_path("planar_2r"), "--window", "3"]
    assert cli.main([*argv, "--json", str(out), "--quiet"]) == 0
    assert json.loads(out.read_text())["valid"]
    assert loads and max(loads) <= BLOCK_ROWS < 79_000, sorted(loads)[-5:]


def test_resampling_a_long_log_by_chunks_equals_one_piece(
    tmp_path, monkeypatch, long_logs
):
    """``resample=True`` fills the grid a chunk at a time from the samples around
    it (``fill_gaps + 2`` of margin): the same numbers as one piece, bit for bit,
    with short and long runs of bad cells and a gap across chunk edges; a long log
    stays stored."""
    import drake_dynid.log_repair as log_repair

    rng = np.random.default_rng(1)
    n = 5000
    t = 1.7e9 + np.cumsum(rng.uniform(0.5e-3, 1.6e-3, n))  # non-uniform, epoch
    q = np.stack([np.sin(t - t[0]), np.cos(2 * (t - t[0]))], 1)
    tau = rng.normal(size=(n, 2))
    q[200:202, 0] = np.nan  # filled
    q[3000:3030, 1] = np.nan  # kept bad
    tau[4000, 1] = np.nan
    keep = np.ones(n, bool)
    keep[2500:2504] = False  # a gap
    path = tmp_path / "irregular.csv"
    write_log(path, t[keep], q[keep], tau[keep], ("a", "b"))
    whole = read_log(path, ("a", "b"), resample=True)  # one chunk of 2^14 samples
    monkeypatch.setattr(log_repair, "_PLACE_SLOTS", 37)
    chunked = read_log(path, ("a", "b"), resample=True)
    assert is_stored(chunked.q) and is_stored(chunked.tau)
    for name in ("t", "q", "tau"):
        np.testing.assert_array_equal(
            np.asarray(getattr(chunked, name)), np.asarray(getattr(whole, name))
        )
    assert chunked.warnings == whole.warnings
    assert np.isnan(np.asarray(chunked.q)[:, 1]).sum() > 0  # the long run stays bad


@pytest.mark.parametrize("seed", range(12))
def test_resampling_by_chunks_equals_one_piece_on_random_logs(seed, monkeypatch):
    """Random irregular stamps, bad-cell runs of every length around ``fill_gaps``,
    dropped rows and chunk sizes down to 1 sample: the chunked interpolation gives
    the one-piece numbers, bad samples and bridged flags bit for bit."""
    import drake_dynid.log_repair as log_repair

    rng = np.random.default_rng(seed)
    n = int(rng.integers(200, 600))
    t = np.cumsum(1e-3 * (1.0 + 0.35 * rng.uniform(-1.0, 1.0, n)))  # 35 % jitter
    q, tau = rng.normal(size=(2, n, 2))
    for values in (q, tau):
        for _ in range(int(rng.integers(2, 7))):  # runs of 1 to 7 bad cells
            start = int(rng.integers(0, n - 1))
            length = int(rng.integers(1, 8))
            values[start : start + length, int(rng.integers(0, 2))] = np.nan
    keep = rng.uniform(size=n) > 0.01
    keep[[0, 1, -2, -1]] = True
    args = (t[keep], q[keep], tau[keep], ("a", "b"))
    fill_gaps = int(rng.integers(1, 6))

    def read():
        try:
            return RobotLog.from_arrays(*args, resample=True, fill_gaps=fill_gaps)
        except ValueError as error:  # the same refusal either way
            return str(error)

    whole = read()
    monkeypatch.setattr(log_repair, "_PLACE_SLOTS", int(rng.integers(1, 12)))
    chunked = read()
    if isinstance(whole, str):
        assert chunked == whole
        return
    for name in ("t", "q", "tau", "filled"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))
    assert chunked.warnings == whole.warnings
    assert chunked.time_offset == whole.time_offset


def test_a_long_replay_keeps_its_traces_on_disk_with_the_same_numbers(
    tmp_path, monkeypatch
):
    """The core replay's (M, p) traces (θ, σ, unidentified, changed) go to a
    temporary file beyond SPILL_BYTES, as a long log does: the same numbers, and
    ``dynid identify --out`` writes the same CSV from them."""
    import json

    import drake_dynid.core.replay as replay
    from drake_dynid import cli
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.core.replay import replay_log_core

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = _arm_log(robot, 12.0)
    log = RobotLog(t, q, tau, robot.joint_names, 1e-3)
    settings = [
        OnlineSettings(window=3.0, bandwidth=1.0, update_period=0.05),
        OnlineSettings(window=3.0, bandwidth=1.0, detect_changes=True),
    ]
    path = tmp_path / "log.csv"
    write_log(path, t, q, tau, robot.joint_names)
    argv = ["identify", str(path), "--urdf", model_path("planar_2r"), "--window", "3"]
    argv += ["--bootstrap", "0", "--quiet"]
    fields = ("theta", "std", "unidentified", "changed", "valid", "change_time")
    traces, outputs = [], []
    for spilled in (False, True):
        if spilled:  # every trace longer than the limits; rows flushed by 7
            monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
            monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
            monkeypatch.setattr(replay, "TRACE_CHUNK", 7)
        traces.append(replay_log_core(log, robot.rows_provider(), settings))
        csv_path, json_path = tmp_path / f"{spilled}.csv", tmp_path / f"{spilled}.json"
        assert cli.main([*argv, "--out", str(csv_path), "--json", str(json_path)]) == 0
        outputs.append((csv_path.read_text(), json.loads(json_path.read_text())))
    for memory, stored in zip(*traces, strict=True):
        assert not is_stored(memory.theta) and is_stored(stored.theta)
        for name in fields:
            np.testing.assert_array_equal(
                np.asarray(getattr(stored, name)), getattr(memory, name)
            )
        assert stored.final()["unidentified"] == memory.final()["unidentified"]
    assert is_stored(traces[1][1].changed)  # detection on: its (M, p) flags too
    assert outputs[0] == outputs[1]
