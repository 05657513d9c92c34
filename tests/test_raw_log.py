"""drake_dynid.raw_log: several raw CSV files joined on time, read through a drive."""

import gzip
import re

import numpy as np
import pytest

from drake_dynid.core.drive import DriveChain
from drake_dynid.raw_log import read_raw_log, read_raw_table

JOINTS = ("a", "b")
DRIVE = {
    "log": {
        "time": "stamp",
        "time_unit": "ms",
        "position": "- {joint}_position",
        "angle_unit": "deg",
        "torque": "- {joint}_effort",
        "torque_side": "motor",
        "torque_unit": "A",
    },
    "motors": {
        "ma": {"joint": "a", "gear_ratio": 10.0, "torque_constant": 0.5},
        "mb": {"joint": "b", "gear_ratio": -20.0, "torque_constant": 0.1},
    },
}


def _write(path, header, rows, bom=False):
    text = ",".join(header) + "\n"
    text += "".join(",".join(str(x) for x in row) + "\n" for row in rows)
    path.write_text(("\ufeff" if bom else "") + text, encoding="utf-8")
    return path


@pytest.fixture
def chain():
    return DriveChain.from_dict(DRIVE, JOINTS, source="drive file test.toml")


def _two_files(tmp_path, t, q, effort_t, effort):
    """pos.csv (ms stamps, degrees) and eff.csv (ms stamps) of the drive's columns."""
    positions = _write(
        tmp_path / "pos.csv",
        ["stamp", "- a_position", "- b_position"],
        [(1000 * s, *np.rad2deg(x)) for s, x in zip(t, q, strict=True)],
    )
    efforts = _write(
        tmp_path / "eff.csv",
        ["stamp", "- a_effort", "- b_effort"],
        [(1000 * s, *x) for s, x in zip(effort_t, effort, strict=True)],
    )
    return positions, efforts


def _signals(t):
    return np.column_stack([np.sin(t), np.cos(2 * t)]), np.column_stack(
        [0.3 + t, -0.2 * t]
    )


def test_two_files_with_the_same_stamps_join_exactly(tmp_path, chain):
    t = 0.01 * np.arange(50)
    q, current = _signals(t)
    stamp = 1000.0 * t + 5e5  # ms, not starting at 0
    positions = _write(
        tmp_path / "pos.csv",
        ["stamp", "- a_position", "- b_position", "- a_velocity"],
        [(s, *np.rad2deg(x), 0.0) for s, x in zip(stamp, q, strict=True)],
        bom=True,
    )
    efforts = _write(
        tmp_path / "eff.csv",
        ["stamp", "- a_effort", "- b_effort"],
        [(s, *x) for s, x in zip(stamp, current, strict=True)],
    )
    log = read_raw_log([positions, efforts], chain)
    assert log.joint_names == JOINTS and log.num_samples == 50
    # Time re-based to 0; the first stamp is kept as time_offset [s].
    np.testing.assert_allclose(log.t, t, atol=1e-9)
    assert log.time_offset == pytest.approx(500.0)
    np.testing.assert_allclose(log.q, q, atol=1e-12)
    # τ = Rᵀ k_t i: gear ratio times torque constant times current.
    np.testing.assert_allclose(log.tau, current * [10 * 0.5, -20 * 0.1], atol=1e-12)
    assert any("not used by the drive chain: - a_velocity" in w for w in log.warnings)
    assert not any("interpolated" in w for w in log.warnings)


def test_other_stamps_are_interpolated_over_the_common_span(tmp_path, chain):
    t = 0.01 * np.arange(100)
    q, _ = _signals(t)
    shifted = t[::2] + 0.003  # efforts at 50 Hz, 3 ms late
    effort = np.column_stack([2 * shifted, 1 - shifted])  # linear: exact interp
    positions, efforts = _two_files(tmp_path, t, q, shifted, effort)
    table = read_raw_table([positions, efforts], chain.required_columns(), "stamp")
    kept = (t >= shifted[0] - 1e-12) & (t <= shifted[-1] + 1e-12)
    np.testing.assert_allclose(table.columns["stamp"], 1000 * t[kept])
    np.testing.assert_allclose(table.columns["- a_effort"], 2 * t[kept], atol=1e-12)
    text = " ".join(table.warnings)
    assert f"file {efforts}: 2 column(s) interpolated linearly" in text
    assert f"{int((~kept).sum())} row(s) of {positions} outside the common" in text
    log = read_raw_log([positions, efforts], chain)
    assert log.num_samples == int(kept.sum())


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("missing", r"no column\(s\) '- b_effort' \(found: "),
        ("twice", "column '- a_effort' is in several files"),
        ("no_time", "no time column 'stamp'; every file of a multi-file log"),
        ("cell", r"row 3, column '- a_effort': 'x' is not a number"),
        ("unsorted", r"time stamps \('stamp'\) are not increasing at row 4"),
        ("apart", "the files have no common time span"),
        ("empty", "the file is empty"),
        ("same", "a file is given twice"),
        # Found by a review: "'utf-8' codec can't decode byte 0x8b in position 1"
        # naming no file (a header read with open(encoding="utf-8")).
        ("gzip", r"log .*e\.csv: the file is gzip-compressed"),
        ("latin1", r"log .*e\.csv: not UTF-8 text: byte 10 \(line 1, column 11\)"),
        # Found by a review: a tab-separated file was only "no column(s) ..." with a
        # drive file (the plain reader names the separator).
        ("tabs", r"the header of .*e\.csv looks separated by another character"),
    ],
)
def test_bad_raw_logs_name_the_file_and_the_column(tmp_path, chain, case, message):
    positions = _write(
        tmp_path / "pos.csv",
        ["stamp", "- a_position", "- b_position"],
        [(k, 0.1 * k, 0.2) for k in range(6)],
    )
    rows = [(k, 0.5, 0.25) for k in range(6)]
    header = ["stamp", "- a_effort", "- b_effort"]
    files = [positions]
    if case == "missing":
        files.append(_write(tmp_path / "e.csv", header[:2], [r[:2] for r in rows]))
    elif case == "twice":
        files.append(_write(tmp_path / "e.csv", header, rows))
        files.append(_write(tmp_path / "f.csv", header[:2], [r[:2] for r in rows]))
    elif case == "no_time":
        files.append(_write(tmp_path / "e.csv", header[1:], [r[1:] for r in rows]))
    elif case == "cell":
        rows[1] = (1, "x", 0.25)
        files.append(_write(tmp_path / "e.csv", header, rows))
    elif case == "unsorted":
        rows[2], rows[1] = rows[1], rows[2]
        files.append(_write(tmp_path / "e.csv", header, rows))
    elif case == "apart":
        files.append(
            _write(tmp_path / "e.csv", header, [(k + 100, 1, 1) for k in range(6)])
        )
    elif case == "empty":
        empty = tmp_path / "e.csv"
        empty.write_text("\n")
        files.append(empty)
    elif case == "gzip":
        (tmp_path / "e.csv").write_bytes(gzip.compress(b"stamp,- a_effort\n0,1\n"))
        files.append(tmp_path / "e.csv")
    elif case == "tabs":
        (tmp_path / "e.csv").write_text("\t".join(header) + "\n0\t1\t2\n")
        files.append(tmp_path / "e.csv")
    elif case == "latin1":
        (tmp_path / "e.csv").write_bytes("stamp,- a_°,- b_effort\n".encode("latin-1"))
        files.append(tmp_path / "e.csv")
    else:
        files.append(positions)
    with pytest.raises(ValueError, match=message):
        read_raw_log(files, chain)


def test_a_missing_file_is_an_os_error(tmp_path, chain):
    with pytest.raises(FileNotFoundError, match=r"no_such\.csv: no such file"):
        read_raw_log([tmp_path / "no_such.csv"], chain)


def test_jittered_stamps_go_through_the_log_checks(tmp_path, chain):
    # ROS-like stamps (±20 % jitter): snapped to the fitted grid with a warning
    # by default; refused with a tighter tolerance (naming --resample); or
    # resampled with a warning (drake_dynid.logs).
    rng = np.random.default_rng(1)
    t = 0.01 * np.arange(200) + 0.002 * rng.uniform(-1, 1, 200)
    q, current = _signals(t)
    rows = [
        (1000 * s, *np.rad2deg(x), *c) for s, x, c in zip(t, q, current, strict=True)
    ]
    path = _write(
        tmp_path / "one.csv",
        ["stamp", "- a_position", "- b_position", "- a_effort", "- b_effort"],
        rows,
    )
    snapped = read_raw_log(path, chain)
    assert snapped.num_samples == 200 and snapped.time_step == pytest.approx(0.01)
    assert any("jitter" in w for w in snapped.warnings), snapped.warnings
    with pytest.raises(ValueError, match=r"non-uniform sampling.*--resample"):
        read_raw_log(path, chain, jitter_tolerance=0.1)
    log = read_raw_log(path, chain, resample=True)
    assert any("resampled by linear interpolation" in w for w in log.warnings)


def _drive_files(folder, count, seed, layout):
    """A jittered drive log (ms stamps from 5e5, degrees, amperes) with an unused
    column and two empty current cells: one file (``"one"``), or positions and
    currents apart with the same stamps (``"same"``) or the currents at their own
    stamps, from 1 ms later to the end (``"other"``)."""
    rng = np.random.default_rng(seed)
    t = 0.002 * np.arange(count) + 0.0003 * rng.uniform(-1, 1, count)
    q, current = _signals(t)
    stamps = [repr(float(1000 * s + 5e5)) for s in t]
    position = [[*map(repr, map(float, np.rad2deg(x))), "0"] for x in q]
    effort = [list(map(repr, map(float, c))) for c in current]
    effort[40][0] = ""
    effort[41][1] = ""
    names_q = ["- a_position", "- b_position", "- a_velocity"]
    names_e = ["- a_effort", "- b_effort"]
    if layout == "one":
        rows = [[s, *p, *e] for s, p, e in zip(stamps, position, effort, strict=True)]
        return [_write(folder / "one.csv", ["stamp", *names_q, *names_e], rows)]
    if layout == "other":
        t_e = t[::3] + 0.001
        stamps_e = [repr(float(1000 * s + 5e5)) for s in t_e]
        effort = [list(map(repr, map(float, c))) for c in _signals(t_e)[1]]
        effort[20][1] = ""
    else:
        stamps_e = stamps
    return [
        _write(
            folder / "pos.csv",
            ["stamp", *names_q],
            [[s, *p] for s, p in zip(stamps, position, strict=True)],
        ),
        _write(
            folder / "eff.csv",
            ["stamp", *names_e],
            [[s, *e] for s, e in zip(stamps_e, effort, strict=True)],
        ),
    ]


def _in_memory(paths, chain):
    """The whole-file path: every column in memory, joined and converted at once."""
    from drake_dynid.logs import RobotLog

    table = read_raw_table(paths, chain.required_columns(), chain.log.time)
    t, q, tau = chain.convert(table.columns)
    return RobotLog.from_arrays(t, q, tau, JOINTS)


@pytest.mark.parametrize("layout", ["one", "same", "other"])
def test_raw_files_are_read_by_blocks_with_the_same_numbers(
    tmp_path, chain, monkeypatch, layout
):
    """Raw files are streamed (the plain reader's block parser, the join and the
    conversion block by block, stored arrays): the numbers of the whole-file join
    and conversion (``read_raw_table``), bit for bit (a diagonal drive); the
    warnings name the first file's rows."""
    from drake_dynid import log_store, log_table
    from drake_dynid.core import blocks
    from drake_dynid.core.blocks import is_stored

    paths = _drive_files(tmp_path, 3000, 4, layout)
    reference = _in_memory(paths, chain)
    monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
    monkeypatch.setattr(log_table, "BLOCK_BYTES", 700)
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 97)
    log = read_raw_log(paths, chain)
    assert is_stored(log.q) and is_stored(log.tau)
    assert log.num_samples == reference.num_samples
    assert log.time_step == reference.time_step
    assert log.time_offset == reference.time_offset
    for mine, theirs in (
        (log.t, reference.t),
        (log.q, reference.q),
        (log.tau, reference.tau),
    ):
        np.testing.assert_array_equal(np.asarray(mine), np.asarray(theirs))
    text = " ".join(log.warnings)
    assert "1 column(s) not used by the drive chain: - a_velocity" in text
    if layout == "other":  # interpolated: the NaN spreads to its neighbours
        assert "interpolated linearly onto the time stamps of" in text
        assert "row(s) of" in text and "outside the common time span" in text
    else:
        assert "(rows 42, 43)" in text, log.warnings  # the file's rows, not samples
    if layout == "same":
        assert "interpolated" not in text


def test_joined_file_stamps_are_checked_across_blocks(tmp_path, chain, monkeypatch):
    """A joined file's stamps (interpolated over) must be increasing, checked a
    block at a time; the time base's go to the log checks (the plain reader's:
    two swapped rows refused, an empty stamp dropped with a warning)."""
    from drake_dynid.core import blocks

    monkeypatch.setattr(blocks, "BLOCK_ROWS", 10)
    header = ["stamp", "- a_position", "- b_position", "- a_effort", "- b_effort"]
    rows = [(k, 0.1 * k, 0.2, 0.5, 0.25) for k in range(40)]
    rows[20], rows[19] = rows[19], rows[20]  # data row 20 opens a block
    path = _write(tmp_path / "u.csv", header, rows)
    with pytest.raises(
        ValueError,
        match=r"u\.csv: time stamps are not increasing at row 22 \(t = 0\.019\) "
        r"after row 21 \(t = 0\.02\): the two are in the wrong order",
    ):
        read_raw_log(path, chain)
    clock = _write(tmp_path / "c.csv", ["stamp"], [(k,) for k in range(40)])
    with pytest.raises(
        ValueError,
        match=r"u\.csv: time stamps \('stamp'\) are not increasing at row 22",
    ):
        read_raw_log([clock, path], chain)
    rows = [(k, 0.1 * k, 0.2, 0.5, 0.25) for k in range(40)]
    rows[30] = ("", 0.1, 0.2, 0.5, 0.25)
    text = (
        ",".join(header) + "\n\n" + "".join(",".join(map(str, r)) + "\n" for r in rows)
    )
    (tmp_path / "b.csv").write_text(text)  # a blank line after the header
    # A joined file's empty stamp is dropped, naming the file's row, as the plain
    # reader drops one; more than 3 + N/1000 of them are an error naming the first.
    log = read_raw_log([clock, tmp_path / "b.csv"], chain)
    assert any("b.csv: dropped row 33: time stamp ('stamp')" in w for w in log.warnings)
    log = read_raw_log(tmp_path / "b.csv", chain)
    assert log.num_samples == 40 and log.filled.tolist() == [k == 30 for k in range(40)]
    assert any("dropped row 33: time stamp empty" in w for w in log.warnings)
    for k in (10, 12, 14):
        rows[k] = ("", 0.1, 0.2, 0.5, 0.25)
    text = (
        ",".join(header) + "\n\n" + "".join(",".join(map(str, r)) + "\n" for r in rows)
    )
    (tmp_path / "b.csv").write_text(text)
    with pytest.raises(
        ValueError,
        match=r"time stamp \('stamp'\) of row 13 is empty or not finite \(4 such",
    ):
        read_raw_log([clock, tmp_path / "b.csv"], chain)


def test_a_first_file_of_stamps_only_is_the_time_base(tmp_path, chain):
    """The first file may hold the time column alone (e.g. a controller's clock):
    its stamps are the base, as in read_raw_table."""
    header_q = ["stamp", "- a_position", "- b_position"]
    header_e = ["stamp", "- a_effort", "- b_effort"]
    clock = _write(
        tmp_path / "clock.csv", ["stamp", "x"], [(k, 0) for k in range(5, 30)]
    )
    positions = _write(
        tmp_path / "p.csv", header_q, [(k, 0.1 * k, 0.2) for k in range(40)]
    )
    efforts = _write(tmp_path / "e.csv", header_e, [(k, 0.5, 0.25) for k in range(40)])
    files = [clock, positions, efforts]
    log = read_raw_log(files, chain)
    reference = _in_memory(files, chain)
    assert log.num_samples == reference.num_samples == 25
    np.testing.assert_array_equal(np.asarray(log.q), np.asarray(reference.q))


def test_trailing_commas_are_read_and_a_longer_row_is_named(
    tmp_path, chain, monkeypatch
):
    """A logger's trailing comma on every row (an empty extra cell) is accepted by
    both readers, fast path or not; a row with an extra non-empty cell is an error
    naming it (it would shift the columns)."""
    from drake_dynid.logs import read_log

    header = ["stamp", "- a_position", "- b_position", "- a_effort", "- b_effort"]
    rows = [(k, 0.1 * k, 0.2, 0.5, 0.25) for k in range(60)]
    text = (
        ",".join(header) + "\n" + "".join(",".join(map(str, r)) + ",\n" for r in rows)
    )
    (tmp_path / "t.csv").write_text(text)
    plain = _write(tmp_path / "clean.csv", header, rows)
    from drake_dynid import log_table

    with monkeypatch.context() as patch:  # numpy's C parser, not cell by cell
        patch.setattr(log_table, "_slow", None)
        np.testing.assert_array_equal(
            np.asarray(read_raw_log(tmp_path / "t.csv", chain).q),
            np.asarray(read_raw_log(plain, chain).q),
        )
    quoted = text.replace("\n0,", '\n"0",', 1)  # the cell-by-cell reader
    (tmp_path / "q.csv").write_text(quoted)
    assert read_raw_log(tmp_path / "q.csv", chain).num_samples == 60
    t = 0.01 * np.arange(60)
    lines = "t,q_a,q_b,tau_a,tau_b\n" + "".join(
        f"{float(x)!r},0.1,0.2,0.3,0.4,\n" for x in t
    )
    (tmp_path / "p.csv").write_text(lines)
    assert read_log(tmp_path / "p.csv", JOINTS).num_samples == 60
    longer = text.replace("\n30,3.0,0.2,0.5,0.25,\n", "\n30,3.0,0.2,0.5,0.25,7\n")
    assert longer != text
    (tmp_path / "l.csv").write_text(longer)
    with pytest.raises(
        ValueError, match=r"l\.csv: row 32 has 6 cells; the header has 5"
    ):
        read_raw_log(tmp_path / "l.csv", chain)


def test_a_gap_of_a_joined_file_is_missing_samples_not_a_line(
    tmp_path, chain, monkeypatch
):
    """Found by a review: 2 s of the TIAGo's effort file missing (rows cut) were
    bridged by the join's linear interpolation, 200 made-up torques without a
    word, where the same gap in one file is 200 bad samples. The efforts (3 ms
    after the positions) miss 2 samples (filled and flagged, as in one file) and
    20 (bad samples); the streamed join equals the whole-column one."""
    from drake_dynid.core import blocks

    t = 0.01 * np.arange(300)
    q, _ = _signals(t)
    shifted = t + 0.003
    current = np.column_stack([0.3 + shifted, -0.2 * shifted])
    kept = np.ones(t.size, dtype=bool)
    kept[[50, 51]] = False
    kept[150:170] = False
    positions, efforts = _two_files(tmp_path, t, q, shifted[kept], current[kept])
    files = [positions, efforts]
    table = read_raw_table(files, chain.required_columns(), "stamp")
    gaps = np.flatnonzero(np.isnan(table.columns["- a_effort"]))
    # Row k of the table is position k + 1 (position 0 is before the efforts):
    # positions 50..52 lie in the 2-sample gap (filled), 150..170 between effort
    # stamps 210 ms apart (20 samples: no value).
    np.testing.assert_array_equal(gaps, list(range(149, 170)))
    np.testing.assert_array_equal(np.flatnonzero(table.gap_filled), [49, 50, 51])
    np.testing.assert_array_equal(np.flatnonzero(table.gap_bad), range(149, 170))
    text = " ".join(table.warnings)
    assert "2 gap(s) of its time stamps (22 of its samples missing" in text
    assert "3 time stamp(s) of the first file in gaps of up to 5" in text
    assert "21 in longer gaps without a value" in text
    monkeypatch.setattr(blocks, "BLOCK_ROWS", 64)  # gaps across block borders
    log = read_raw_log(files, chain)
    tau = np.asarray(log.tau)
    assert np.flatnonzero(np.isnan(tau[:, 0])).tolist() == list(range(149, 170))
    assert np.flatnonzero(log.filled).tolist() == [49, 50, 51]
    line = np.column_stack([0.3 + t[50:53], -0.2 * t[50:53]]) * [10 * 0.5, -20 * 0.1]
    np.testing.assert_allclose(tau[49:52], line, atol=1e-9)  # linear: exact
    assert np.isfinite(np.asarray(log.q)).all()
    assert any("3 time stamp(s) of the first file" in w for w in log.warnings)


def _rate_files(folder, t_positions, t_efforts):
    """A plain log split in two: positions and efforts on their own stamps [s]."""
    positions = _write(
        folder / "pos.csv",
        ["t", "q_a", "q_b"],
        [(f"{s:.17g}", f"{np.sin(s):.17g}", f"{np.cos(s):.17g}") for s in t_positions],
    )
    efforts = _write(
        folder / "eff.csv",
        ["t", "tau_a", "tau_b"],
        [(f"{s:.17g}", f"{2 * s:.17g}", f"{-s:.17g}") for s in t_efforts],
    )
    return [positions, efforts]


@pytest.fixture
def plain_chain():
    drive = {"log": {"time": "t", "position": "q_{joint}", "torque": "tau_{joint}"}}
    return DriveChain.from_dict(drive, JOINTS, source="drive file plain.toml")


def test_a_gap_of_a_joined_file_is_counted_in_its_own_samples(
    tmp_path, plain_chain, monkeypatch
):
    """Found by a review: one dropped 100 Hz effort joined onto 1 kHz positions
    left 20 bad samples that --fill-gaps 5 never filled (the gap was counted in
    the positions' samples). A gap is counted in the samples of the file that
    misses them: one effort is filled (its 20 position stamps flagged), six are
    bad samples, and so is a 30-sample gap of 1 kHz efforts under 100 Hz
    positions although only 4 position stamps fall in it."""
    from drake_dynid.core import blocks

    monkeypatch.setattr(blocks, "BLOCK_ROWS", 300)  # gaps across block borders
    t = 0.001 * np.arange(3000)
    efforts = 0.01 * np.arange(300) + 0.0003
    kept = np.ones(efforts.size, bool)
    kept[100] = False  # 1 missing: 0.9903 .. 1.0103
    kept[200:206] = False  # 6 missing: 1.9903 .. 2.0603
    files = _rate_files(tmp_path, t, efforts[kept])
    log = read_raw_log(files, plain_chain, fill_gaps=5)
    tau = np.asarray(log.tau)
    t0 = 0.001  # the first position stamp inside the efforts' span
    filled = np.flatnonzero(log.filled)
    np.testing.assert_allclose(log.t[filled] + t0, 0.001 * np.arange(991, 1011))
    np.testing.assert_allclose(tau[filled, 0], 2 * (log.t[filled] + t0), atol=1e-12)
    bad = np.flatnonzero(np.isnan(tau[:, 0]))
    np.testing.assert_allclose(log.t[bad] + t0, 0.001 * np.arange(1991, 2061))
    text = " ".join(log.warnings)
    assert "2 gap(s) of its time stamps (7 of its samples missing" in text
    assert "20 time stamp(s) of the first file in gaps of up to 5" in text
    # --fill-gaps 0: no gap filled, every stamp in one is a bad sample.
    none = read_raw_log(files, plain_chain, fill_gaps=0)
    assert not none.filled.any() and none.bad_samples.sum() == 20 + 70
    # The first file slower: 30 efforts missing, 4 position stamps in the gap.
    fast = 0.001 * np.arange(3000) + 0.0003
    kept = np.ones(fast.size, bool)
    kept[1000:1030] = False
    files = _rate_files(tmp_path, 0.01 * np.arange(300), fast[kept])
    log = read_raw_log(files, plain_chain, fill_gaps=5)
    assert not log.filled.any()
    np.testing.assert_allclose(log.t[log.bad_samples] + 0.01, [1.0, 1.01, 1.02, 1.03])
    for resample in (False, True):  # --resample keeps them bad as well
        jittered = 0.01 * np.arange(300)
        jittered[1::2] += 0.0015 if resample else 0.0
        files = _rate_files(tmp_path, jittered, fast[kept])
        log = read_raw_log(files, plain_chain, fill_gaps=5, resample=resample)
        assert log.bad_samples.sum() == 4 and not log.filled.any(), log.warnings


def test_bursty_stamps_of_a_joined_file_are_not_gaps(tmp_path, plain_chain):
    """Complete but bursty efforts (every 4th message 7.5 ms late, then the next
    2.5 ms after it; or in pairs 1 ms apart) are no gap: before, 850 of 1990
    position stamps were bad samples. A dropped message among them still is."""
    t = 0.001 * np.arange(2000)
    regular = 0.01 * np.arange(200) + 0.0003
    late = regular + np.where(np.arange(200) % 4 == 1, 0.0075, 0.0)
    pairs = regular + np.where(np.arange(200) % 2 == 0, 0.009, 0.0)
    for efforts in (late, pairs):
        log = read_raw_log(_rate_files(tmp_path, t, efforts), plain_chain)
        assert not log.filled.any() and not log.bad_samples.any()
        assert not any("gap" in w for w in log.warnings), log.warnings
    kept = np.ones(200, bool)
    kept[104] = False  # 1 missing: 1.0303 .. 1.0578 (late)
    log = read_raw_log(_rate_files(tmp_path, t, late[kept]), plain_chain)
    # Found, filled and said, once (one interval of the efforts: 10 to 30
    # position stamps, where the late stamps leave the drop).
    assert not log.bad_samples.any()
    assert 10 <= log.filled.sum() <= 30, log.warnings
    assert any(
        "1 gap(s) of its time stamps (1 of its samples" in w for w in log.warnings
    )


@pytest.mark.parametrize("pattern", ["late", "pairs"])
def test_one_drop_among_bursty_stamps_is_one_gap(tmp_path, plain_chain, pattern):
    """Found by a review: one dropped message among bursty efforts (every 4th
    7.5 ms late and the next one catching up; or pairs 1 ms apart) was reported
    as 2 or 3 gaps, 2 or 3 samples missing, wherever it was dropped (400 of 400
    positions): the intervals beside the late stamps shared the drop's spans.
    Now one drop (or three in a row) is one gap of as many samples; two drops
    8 messages apart stay two gaps."""
    from drake_dynid.raw_log import _missing

    k = np.arange(400)
    late = np.where(k % 4 == 1, 0.0075, 0.0) if pattern == "late" else 0.0
    pairs = np.where(k % 2 == 0, 0.009, 0.0) if pattern == "pairs" else 0.0
    stamps = 0.01 * k + 0.0003 + late + pairs
    assert not _missing(stamps)[0].any()
    for drop in range(20, 380):
        for dropped in ([drop], [drop, drop + 1, drop + 2], [drop, drop + 8]):
            kept = np.ones(k.size, bool)
            kept[dropped] = False
            missing = _missing(stamps[kept])[0]
            gaps = 2 if len(dropped) == 2 else 1
            assert missing.sum() == len(dropped), (drop, dropped)
            assert np.count_nonzero(missing) == gaps, (drop, dropped)
    t = 0.001 * np.arange(4000)
    kept = np.ones(k.size, bool)
    kept[[101, 250]] = False
    log = read_raw_log(_rate_files(tmp_path, t, stamps[kept]), plain_chain)
    assert any(
        "2 gap(s) of its time stamps (2 of its samples" in w for w in log.warnings
    )


def _late_runs(count, seed):
    """Stamp offsets [steps] of runs of 3 or 4 stamps 0.2 to 0.8 step late, later
    and later, each followed by 1 to 3 on time (a logger's queue catching up)."""
    rng = np.random.default_rng(seed)
    late = np.zeros(count)
    k = 0
    while k < count:
        run = int(rng.integers(3, 5))
        late[k : k + run] = np.sort(rng.uniform(0.2, 0.8, run))[: count - k]
        k += run + int(rng.integers(1, 4))
    return late


@pytest.mark.parametrize(
    "pattern", ["0 .2 .5 .8", "0 .2 .4 .6 .8", "runs", "runs 2", "jitter 45 %"]
)
def test_a_drop_beside_late_stamps_is_seen_and_counted_once(
    tmp_path, plain_chain, pattern
):
    """Found by a review: with 3 or 4 stamps 0.2 to 0.8 step late and then one on
    time, a sample dropped right after the latest stamp left an interval of 1.2
    steps, below the 1.5 steps (GAP_STEPS) that made an interval a gap
    candidate. Every sample of 200 dropped in turn: unseen at 70 positions (0,
    .2, .5, .8 step late), 80 (0, .2, .4, .6, .8), 55 and 44 (random runs), 9
    (±45 % jitter); two drops a sample apart were miscounted at 141, 200, 133,
    109 and 70 positions (two in a row: 0, 0, 60, 42, 15). Now each drop is
    counted once, in its interval, and the stamps without a drop have no gap."""
    from drake_dynid.raw_log import _missing

    k = np.arange(400)
    if pattern == "runs" or pattern == "runs 2":
        late = _late_runs(k.size, seed=len(pattern))
    elif pattern == "jitter 45 %":
        late = np.random.default_rng(3).uniform(-0.45, 0.45, k.size)
    else:
        cycle = np.array([float(x) for x in pattern.split()])
        late = cycle[k % cycle.size]
    stamps = 0.01 * (k + late) + 0.0003
    assert not _missing(stamps)[0].any()
    for drop in range(100, 300):
        for dropped in ([drop], [drop, drop + 1], [drop, drop + 2]):
            kept = np.ones(k.size, bool)
            kept[dropped] = False
            expected = np.diff(np.flatnonzero(kept)) - 1
            np.testing.assert_array_equal(_missing(stamps[kept])[0], expected, dropped)
    if pattern == "0 .2 .4 .6 .8":  # through the reader: found, filled, said
        kept = np.ones(k.size, bool)
        kept[200] = False  # right after a stamp 0.8 step late: 1.2 steps
        t = 0.001 * np.arange(4000)
        log = read_raw_log(_rate_files(tmp_path, t, stamps[kept]), plain_chain)
        assert 10 <= log.filled.sum() <= 20 and not log.bad_samples.any()
        assert any(
            "1 gap(s) of its time stamps (1 of its samples" in w for w in log.warnings
        ), log.warnings


@pytest.mark.parametrize(
    ("row", "stamp"),
    [(1500, 1e6), (1500, 0.5), (1500, np.nan), (0, 1e6), (2999, -5.0)],
)
@pytest.mark.parametrize("layout", ["one", "joined"])
def test_one_corrupted_stamp_is_dropped_as_the_plain_reader_does(
    tmp_path, plain_chain, row, stamp, layout
):
    """Found by a review: the drive reader refused one corrupted stamp of the
    time base ("not increasing ... sort the file by time", or "empty or not
    finite") that the plain reader drops with a warning naming its row and
    refills. Both drop it now, with the same warning and the same samples; a
    joined file is interpolated onto the other stamps."""
    from drake_dynid.logs import read_log, write_log

    n = 3000
    t = 1e-3 * np.arange(n)
    q = np.column_stack([np.sin(t), np.cos(t)])
    tau = np.column_stack([2 * t, -t])
    t[row] = stamp
    write_log(tmp_path / "s.csv", t, q, tau, JOINTS)
    plain = read_log(tmp_path / "s.csv", JOINTS)
    if layout == "one":
        files = [tmp_path / "s.csv"]
    else:  # positions on the corrupted stamps, efforts on their own clean ones
        clean = 1e-3 * np.arange(-5, n + 5)
        files = _rate_files(tmp_path, t, clean)
        files[0] = _write(
            files[0],
            ["t", "q_a", "q_b"],
            [
                (f"{s:.17g}", *(f"{x:.17g}" for x in v))
                for s, v in zip(t, q, strict=True)
            ],
        )
    log = read_raw_log(files, plain_chain)
    dropped = [w for w in log.warnings if w.startswith("dropped row")]
    assert dropped == [w for w in plain.warnings if w.startswith("dropped row")]
    assert f"dropped row {row + 2}" in dropped[0]
    assert log.num_samples == plain.num_samples
    np.testing.assert_array_equal(log.filled, plain.filled)
    np.testing.assert_allclose(np.asarray(log.q), np.asarray(plain.q), atol=1e-12)
    if layout == "one":
        np.testing.assert_allclose(np.asarray(log.tau), np.asarray(plain.tau))
    else:  # tau = (2 t, -t) of the efforts' own stamps, interpolated: a line
        kept = np.delete(np.arange(n), row) if row in (0, n - 1) else np.arange(n)
        reference = 1e-3 * kept[~np.asarray(log.filled)]
        good = np.asarray(log.tau)[~np.asarray(log.filled)]
        np.testing.assert_allclose(good[:, 0], 2 * reference, atol=1e-12)


def test_a_corrupted_stamp_shared_by_two_files_is_dropped_once(tmp_path, plain_chain):
    """Two files of one logger (the same stamps, one corrupted in both) are
    taken as they are, the stamp dropped as in one file; a joined file's own
    corrupted stamp is still an error naming its row (it is interpolated over)."""
    from drake_dynid.logs import read_log, write_log

    n = 2000
    t = 1e-3 * np.arange(n)
    t[700] = 1e6
    q = np.column_stack([np.sin(t), np.cos(t)])
    tau = np.column_stack([np.cos(t), np.sin(t)])
    write_log(tmp_path / "one.csv", t, q, tau, JOINTS)
    plain = read_log(tmp_path / "one.csv", JOINTS)
    cells = [f"{s:.17g}" for s in t]
    files = [
        _write(tmp_path / "q.csv", ["t", "q_a", "q_b"], zip(cells, *q.T, strict=True)),
        _write(
            tmp_path / "e.csv", ["t", "tau_a", "tau_b"], zip(cells, *tau.T, strict=True)
        ),
    ]
    log = read_raw_log(files, plain_chain)
    assert log.num_samples == plain.num_samples == n
    assert not any("interpolated linearly" in w for w in log.warnings), log.warnings
    assert any(w.startswith("dropped row 702 (t = 1000000)") for w in log.warnings)
    np.testing.assert_array_equal(log.filled, plain.filled)
    np.testing.assert_allclose(np.asarray(log.tau), np.asarray(plain.tau), atol=1e-12)
    clean = [f"{s:.17g}" for s in 1e-3 * np.arange(n)]
    _write(tmp_path / "q.csv", ["t", "q_a", "q_b"], zip(clean, *q.T, strict=True))
    with pytest.raises(
        ValueError, match=r"e\.csv: time stamps \('t'\) are not increasing at row 703"
    ):
        read_raw_log(files, plain_chain)


@pytest.mark.parametrize("stored", [False, True])
def test_an_empty_or_nan_stamp_is_dropped_in_either_file(
    tmp_path, chain, monkeypatch, stored
):
    """Found by a review: the README's bad-data table says one corrupted stamp is
    dropped with a warning; through --drive, or with several files, an empty or
    NaN stamp was an error ("time stamp ('t') of row 501 is empty or not
    finite"). The row is dropped: in the first file its slot is a dropped sample
    (filled), in another file a gap of its own samples (interpolated over)."""
    from drake_dynid import log_store, log_table

    if stored:  # the values in temporary files, read a slice at a time
        monkeypatch.setattr(log_store, "SPILL_BYTES", 512)
        monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
        monkeypatch.setattr(log_table, "BLOCK_BYTES", 700)
    t = 0.01 * np.arange(200)
    q, current = _signals(t)  # currents linear in t: interpolated exactly
    clean = tmp_path / "clean"
    clean.mkdir()
    reference = read_raw_log(_two_files(clean, t, q, t, current), chain)
    positions, efforts = _two_files(tmp_path, t, q, t, current)
    for path, row, cell in ((positions, 51, "nan"), (efforts, 122, "")):
        lines = path.read_text().splitlines()
        lines[row - 1] = ",".join([cell, *lines[row - 1].split(",")[1:]])
        path.write_text("\n".join(lines) + "\n")
    log = read_raw_log([positions, efforts], chain)
    text = " ".join(log.warnings)
    assert "dropped row 51: time stamp empty or not finite" in text  # the plain's
    assert "eff.csv: dropped row 122: time stamp ('stamp')" in text
    assert log.num_samples == reference.num_samples == 200
    filled = np.flatnonzero(np.asarray(log.filled))  # the efforts' gap too
    np.testing.assert_array_equal(filled, [49, 120])
    np.testing.assert_allclose(np.asarray(log.tau), reference.tau, atol=1e-9)
    others = np.arange(200) != 49
    np.testing.assert_array_equal(np.asarray(log.q)[others], reference.q[others])
    np.testing.assert_allclose(np.asarray(log.q)[49], reference.q[49], atol=1e-6)


def test_stamps_sharing_slots_cancel_as_the_nearest_first_loop():
    """raw_log._cancel_shared skips, without a Python loop, the intervals of two
    stamps in one slot that have no sample missing within SLOT_CONTEXT (a rate
    halving mid-file: 900 000 of 3.6 M stamps; 16.3 -> 11.2 s CPU, peak 186 ->
    159 MB): the counts of the loop over all of them, on random counts."""
    from drake_dynid.raw_log import SLOT_CONTEXT, _cancel_shared

    def reference(missing):
        nearest = [0] + [d * s for d in range(1, SLOT_CONTEXT + 1) for s in (-1, 1)]
        for i in np.flatnonzero(missing < 0).tolist():
            excess, missing[i] = int(-missing[i]), 0
            for j in (i + d for d in nearest):
                if excess > 0 and 0 <= j < missing.size and missing[j] > 0:
                    taken = min(excess, int(missing[j]))
                    missing[j] -= taken
                    excess -= taken

    rng = np.random.default_rng(0)
    for _ in range(500):
        counts = rng.choice([-2, -1, 0, 0, 0, 0, 0, 1, 2, 5], int(rng.integers(1, 200)))
        counts[rng.random(counts.size) < rng.random()] = 0  # sparse and dense
        got, expected = counts.copy(), counts.copy()
        _cancel_shared(got)
        reference(expected)
        np.testing.assert_array_equal(got, expected, str(counts.tolist()))


def test_a_gap_of_epoch_stamps_is_named_by_stamps_that_differ(tmp_path, plain_chain):
    """Found by a review: the gap warning gave the stamps around the longest gap
    to 9 digits: Unix-epoch seconds (a ROS export read in seconds) 1.7e9 + ...
    were both '1.70000001e+09' ('between 1.70000001e+09 and 1.70000001e+09').
    Now to 16 digits, as the reader's other notes on stamps."""
    t = 1.7e9 + 0.001 * np.arange(4000)
    k = np.delete(np.arange(400), 250)  # 2.5 s in: one effort dropped
    log = read_raw_log(_rate_files(tmp_path, t, 1.7e9 + 0.0003 + 0.01 * k), plain_chain)
    (said,) = [w for w in log.warnings if "gap(s) of its time stamps" in w]
    assert "between 1700000002.4903 and 1700000002.5103)" in said, said
    # The interpolation note's common span too (it read '1.7e+09 .. 1.7e+09').
    spans = [w for w in log.warnings if "column(s) interpolated linearly" in w]
    assert spans and all("span 1700000000.001 .. 1700000003.99 (" in w for w in spans)


def test_stamps_beyond_the_gap_counting_bound_are_named(tmp_path, plain_chain):
    """Found by two reviews: beyond the bound of `_missing` a dropped sample can
    go unseen, without a word; the joined file is now named with how many of its
    stamps share a slot of its grid (0 within the bound: no note there). Bursts
    of 4 stamps then a 4-step hole (a buffered publisher), named so before, are
    now counted by burst, and named as such; ±70 % jitter is beyond the bound.
    """
    t = 0.001 * np.arange(4000)
    base = 0.01 * np.arange(400)
    rng = np.random.default_rng(3)
    bursts = base - 0.01 * (np.arange(400) % 4) + 0.0002 * (np.arange(400) % 4)
    jitter = base + 0.004 * rng.uniform(-1, 1, 400)
    wide = np.sort(base + 0.007 * rng.uniform(-1, 1, 400))
    for efforts, named, burst in (
        (np.sort(bursts) + 0.03, False, True),
        (jitter + 0.0003, False, False),
        (wide + 0.03, True, False),
    ):
        files = _rate_files(tmp_path, t, efforts)
        columns = plain_chain.required_columns()
        for notes in (
            read_raw_log(files, plain_chain).warnings,
            read_raw_table(files, columns, plain_chain.log.time).warnings,
        ):
            said = [w for w in notes if "fall in the slot of the stamp before" in w]
            assert bool(said) is named, notes
            if named:
                assert "eff.csv: 76 of its 400 time stamps" in said[0], said
            said = [w for w in notes if "its stamps come in bursts" in w]
            assert bool(said) is burst, notes
            if burst:
                assert "eff.csv: its stamps come in bursts (100 bursts, 4 " in said[0]


def _bursty(b, n, drops, jitter, rng):
    """(stamps [s], missing): n samples of a 100 Hz buffered publisher, sent b at
    a time (stamps 0.02 step apart, each burst jittered by up to ``jitter`` of a
    step), ``drops`` of them (not the first or last 2 b + 2) dropped."""
    k = np.arange(n)
    burst = k // b
    offset = rng.uniform(-jitter, jitter, burst[-1] + 1)
    stamps = 0.01 * (b * burst + 0.02 * (k % b) + offset[burst]) + 0.0003
    kept = np.ones(n, bool)
    where = np.arange(2 * b + 2, n - 2 * b - 2)
    kept[rng.choice(where, drops, replace=False)] = False
    return stamps[kept], np.diff(np.flatnonzero(kept)) - 1


@pytest.mark.parametrize("b", [2, 3, 4])
def test_drops_among_bursts_are_counted(tmp_path, plain_chain, b):
    """Found by two reviews: a buffered publisher's stamps (bursts of b = 3 or 4
    stamps, then a hole of b steps) lost their drops: of 30 files of 399 to 401
    stamps with 1 drop, 0 (b = 4), 6 to 19 (b = 3) were counted right, with
    false gaps in complete ones (2 % jitter on bursts of 2: 5 samples in 30
    files). A bursty file is counted by burst: no gap in a complete file, each
    drop one sample missing in the hole beside its burst; the note names the
    bursts (and no longer says its stamps share slots)."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(b)
    for n in (399, 400, 401):
        for jitter in (0.0, 0.02, 0.2):
            for drops in (0, 1, 3):
                stamps, expected = _bursty(b, n, drops, jitter, rng)
                missing, shared, found = _missing(stamps)
                case = (n, jitter, drops, np.flatnonzero(expected).tolist())
                assert missing.sum() == drops and not shared, case
                for i in np.flatnonzero(expected):  # in its burst's hole
                    assert missing[max(0, i - b) : i + b + 1].sum() >= 1, case
                assert "its stamps come in bursts" in found[0], found
    stamps, expected = _bursty(b, 400, 2, 0.2, rng)
    log = read_raw_log(
        _rate_files(tmp_path, 0.001 * np.arange(4000), stamps), plain_chain
    )
    assert any(
        "2 gap(s) of its time stamps (2 of its samples" in w for w in log.warnings
    )
    assert not any("fall in the slot" in w for w in log.warnings), log.warnings


def test_drops_in_stamps_without_jitter_are_counted():
    """Found by the test matrix of the bursts: stamps exactly on a 100 Hz grid
    (a simulated log) with 3 drops in 400 were counted on a grid 3 steps
    coarser, its phase drifting over the drops: 11 of 30 files counted 0 (33
    samples unseen), 4 of 30 with 10 drops; 3 of 30 at 2 % jitter. A grid the
    stamps fit within 15 % of a step (RMS), none two in one slot, is now chosen
    over a coarser one."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    for jitter in (0.0, 0.02):
        for drops in (3, 10):
            for n in range(398, 402):
                stamps, expected = _bursty(1, n, drops, jitter, rng)
                missing = _missing(stamps)[0]
                np.testing.assert_array_equal(missing, expected, (n, jitter, drops))


def _two_rates(n1, n2, h1, h2, jitter, drops, rng):
    """(stamps [s], missing): n1 stamps h1 apart then n2 h2 apart, jittered by a
    share of their step, ``drops`` of them dropped."""
    t = np.concatenate([h1 * np.arange(n1), h1 * (n1 - 1) + h2 * np.arange(1, n2 + 1)])
    step = np.concatenate([np.full(n1, h1), np.full(n2, h2)])
    t += jitter * step * rng.uniform(-1, 1, t.size) + 0.0003
    kept = np.ones(t.size, bool)
    kept[rng.choice(np.arange(5, t.size - 5), drops, replace=False)] = False
    return t[kept], np.diff(np.flatnonzero(kept)) - 1


def test_a_rate_change_mid_file_is_counted_at_each_rate(tmp_path, plain_chain):
    """Found by a review: a joined file at 100 Hz then 50 Hz was counted on one
    grid, a step between the two: 221 false samples missing on 2000 stamps (and
    9.7 s CPU on 3.6 M). The stamps are split where their local step changes
    by more than 5 %, each part counted on its own grid: no false gap, each drop
    counted; the note names the rates and where the rate changes."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(1)
    for n1, n2, h1, h2 in (
        (1000, 1000, 0.01, 0.02),
        (1000, 1000, 0.02, 0.01),
        (300, 300, 0.01, 0.02),
        (1000, 1000, 0.01, 0.013),
        (500, 2000, 0.001, 0.01),
    ):
        for jitter in (0.0, 0.2):
            for drops in (0, 5):
                stamps, expected = _two_rates(n1, n2, h1, h2, jitter, drops, rng)
                missing, shared, found = _missing(stamps)
                case = (n1, n2, h1, h2, jitter, drops)
                assert missing.sum() == drops and not shared, case
                assert np.count_nonzero(missing != expected) <= 1, case
                said = re.match(
                    r"its rate changes \(steps ([\d.]+) then ([\d.]+) in its time "
                    "unit, at ",
                    found[0],
                )
                assert said, found
                steps = [float(x) for x in said.groups()]
                np.testing.assert_allclose(steps, [h1, h2], rtol=1e-3)
    stamps, _ = _two_rates(1000, 1000, 0.01, 0.02, 0.1, 0, rng)
    log = read_raw_log(
        _rate_files(tmp_path, 0.001 * np.arange(20000), stamps), plain_chain
    )
    assert not log.bad_samples.any() and not log.filled.any(), log.warnings
    (said,) = [w for w in log.warnings if "its rate changes" in w]
    assert (
        "eff.csv: its rate changes (steps 0.01 then 0.02 in its time unit, at 9.98"
        in said
    ), said
    assert "counted on its own grid." in said, said


def test_positions_interpolated_onto_denser_stamps_are_named(tmp_path, plain_chain):
    """Found by a review: 100 Hz positions joined onto a 1 kHz effort file (the
    efforts listed first) are interpolated onto the 1 kHz stamps; above 50 Hz
    they hold only the interpolation, whose images, not the noise, fill the band
    above fs/4 where the automatic off-line cutoff read its noise floor (40 Hz,
    the cap, instead of 1.67 Hz). The join's note now says so and what to do;
    the usual order (positions first, sparser efforts) has no such clause. (The
    cutoff now reads such positions' noise below their own Nyquist frequency:
    tests/test_offline.py.)"""
    fast = 0.001 * np.arange(4000)
    slow = 0.01 * np.arange(400) + 0.0003
    positions, efforts = _rate_files(tmp_path, slow, fast)  # q at 100 Hz
    log = read_raw_log([efforts, positions], plain_chain)
    (said,) = [w for w in log.warnings if "column(s) interpolated linearly" in w]
    assert "Its samples (100 Hz) are 10× sparser than" in said, said
    assert f"list {positions} first to keep them as measured." in said, said
    usual = read_raw_log(_rate_files(tmp_path, fast, slow), plain_chain)
    assert not any("sparser" in w for w in usual.warnings), usual.warnings


def test_the_sparser_positions_note_names_rates_in_hz_with_ms_stamps(tmp_path, chain):
    """Found by a review: the note on sparser positions named rates computed
    from the raw stamps: with a drive file's ``[log] time_unit = "ms"``, 100 Hz
    positions under 1 kHz efforts were "0.1 Hz ... 1 Hz", "above 0.05 Hz" (1e3
    too low; 1e9 with ns). The rates are now read in seconds."""
    fast = 0.001 * np.arange(4000)
    slow = 0.01 * np.arange(400) + 0.0003
    q, _ = _signals(slow)
    _, tau = _signals(fast)
    positions, efforts = _two_files(tmp_path, slow, q, fast, tau)
    log = read_raw_log([efforts, positions], chain)
    (said,) = [w for w in log.warnings if "column(s) interpolated linearly" in w]
    assert "Its samples (100 Hz) are 10× sparser than" in said, said
    assert "'s (1000 Hz): above 50 Hz its positions" in said, said


def test_the_chosen_grid_is_read_once(monkeypatch):
    """Found by a review: `_missing` read the chosen grid's slots (a `_cuts`
    pass over every block) once more after the search. When every guess
    refits to one grid its slots are reused: 3000 stamps without jitter, 2
    passes -> 1 (3.6 M with ±20 % jitter: 1.6 -> 1.3 s CPU; at two rates 1.2
    -> 0.7 s), the same counts."""
    from drake_dynid import raw_log

    calls = []
    cuts = raw_log._cuts
    monkeypatch.setattr(raw_log, "_cuts", lambda *a: calls.append(1) or cuts(*a))
    k = np.delete(np.arange(3000), [700, 1500, 1501])
    missing = raw_log._missing(0.01 * k + 0.0003)[0]
    np.testing.assert_array_equal(np.flatnonzero(missing), [699, 1498])
    np.testing.assert_array_equal(missing[[699, 1498]], [1, 2])
    assert len(calls) == 1


def test_a_pause_is_a_gap_not_a_rate_change():
    """Found by a review: a 1 kHz file whose recording paused for a minute and
    resumed at the same rate was split as a rate change (steps 0.001 then
    0.5047 then 0.001: the block holding the pause had a 0.5 ms mean step), the
    part holding it counted on that grid: 86 samples missing for 60 000, 127 of
    its stamps sharing a slot, two drops beside it lost. A block's step now
    leaves out its intervals over 4 times its 4th longest."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    t = 0.001 * (np.arange(3000) + rng.uniform(-0.1, 0.1, 3000))
    t[1500:] += 60.0
    missing, shared, found = _missing(np.delete(t, [1490, 1510]))
    assert not shared and not found, found
    np.testing.assert_array_equal(np.flatnonzero(missing), [1489, 1498, 1508])
    assert missing[1489] == missing[1508] == 1
    assert abs(missing[1498] - 60000) <= 3, missing[1498]


def test_a_pause_in_a_short_file_is_counted_on_its_own_grid():
    """Found by a review: 300 stamps at 1 kHz with a minute's pause in the
    middle were counted on a 0.5 s grid (most of its 8-120 interval steps hold
    the pause), its stamps all sharing slots, cheaper than the file's own
    grid, which inserts 60 000 slots: 82 samples missing, 298 stamps sharing
    a slot, the 2 drops lost. A gap now counts as at most 64 slots inserted in
    a grid's cost."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    t = 0.001 * (np.arange(300) + rng.uniform(-0.1, 0.1, 300))
    t[150:] += 60.0
    missing, shared, _ = _missing(np.delete(t, [100, 200]))
    assert not shared
    np.testing.assert_array_equal(np.flatnonzero(missing), [99, 148, 198])
    assert missing[99] == missing[198] == 1
    assert abs(missing[148] - 60000) <= 150, missing[148]


def test_a_short_file_whose_last_tenth_is_at_half_the_rate():
    """Found by a review: 500 stamps at 100 Hz whose last 50 were recorded at
    50 Hz: the slower end spans under 2 blocks of 64 intervals (and the last
    (n - 1) % 64 intervals were in none), no rate change: 50 false samples
    missing, 1 each interval. A file under 4096 intervals, not bursty, is now
    read in blocks of 16 (a cut kept if the sides' median steps differ too)."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    step = np.where(np.arange(499) < 449, 0.01, 0.02)
    t = np.concatenate([[0.0], np.cumsum(step)]) + 0.001 * rng.uniform(-1, 1, 500)
    missing, shared, found = _missing(t)
    assert not missing.any() and not shared
    assert found[0].startswith("its rate changes (steps 0.01 then 0.02 in its "), found
    missing, shared, found = _missing(np.delete(t, [100, 480]))
    np.testing.assert_array_equal(np.flatnonzero(missing), [99, 478])


@pytest.mark.parametrize("b", [2, 4, 8])
def test_a_rate_change_in_a_bursty_file_is_cut_between_bursts(b):
    """Found by a review: a file in bursts of b at 1 kHz then 0.5 or 0.1 kHz
    was cut where the stamps' intervals (0 or a hole: each costing 1 at either
    step) told nothing, up to 2 blocks off: bursts of 4 at 0.5 kHz 127 false
    samples missing, of 8 6, of 2 64-67 stamps sharing a slot (a beyond-bound
    note); bursts of 4 or 8 at 0.1 kHz a ValueError (min() of an empty
    sequence: the spread stamps went back). The cut now compares the bursts'
    steps (the interval between their last stamps over the later one's
    stamps), at a burst's last stamp: none missing, the drops counted."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(b)
    k = np.arange(4000.0)
    t = (k // b) * b + b - 1 + (k % b) * 0.01
    for ratio in (2.0, 10.0):
        slow = np.where(k < 2000, t, 2000 + ratio * (t - 2000)) * 1e-3
        missing, shared, found = _missing(slow)
        assert not missing.any() and not shared, (missing.sum(), shared)
        assert found[0].startswith("its rate changes"), found
        # each part's burst clause says which part (a review: one note
        # repeated it for each part without saying which)
        assert found[1].startswith(f"from {slow[0]:.16g} on, its stamps come in")
        assert found[2].startswith("from ") and found[2] != found[1], found
        dropped = rng.choice(np.arange(50, 3950), 3, replace=False)
        assert _missing(np.delete(slow, dropped))[0].sum() == 3


@pytest.mark.parametrize("b", [2, 4, 8])
def test_a_short_bursty_file_changing_rate_has_no_false_drops(b):
    """Found by a review: a file of 160-240 stamps in bursts of b, flushed at
    each burst's last sample (stamps 1 us apart, 0-0.2 ms late), at 1 then
    0.5 kHz, was read in blocks of 64 intervals (a short file's 16 only when
    not bursty): under 4 blocks, no rate change, 20-33 false samples missing
    on a complete file (0-6 before the bursts were counted by deficit). A
    short bursty file's blocks now hold 8 of its longest bursts (at least
    16 intervals): none; the drops counted. A later review: of 120 stamps in
    bursts of 4, or 120-240 in bursts of 8, that is under 4 blocks still
    (13-33 false samples); such a file is read in blocks of whole bursts."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(b)
    for n in (120, 160, 200, 240):
        half = n // 2
        slow = half - 1 + 2.0 * np.arange(1, n - half + 1)
        g = np.concatenate([np.arange(half), slow])
        t = g.copy()
        for a in range(0, n, b):
            z = min(a + b, n)
            t[a:z] = g[z - 1] + 1e-3 * np.arange(z - a) + rng.uniform(0.0, 0.2)
        t *= 1e-3
        missing, shared, found = _missing(t)
        assert not missing.any() and not shared, (n, missing.sum(), shared)
        assert found[0].startswith("its rate changes"), found
        dropped = [40 + b // 2, n - 40 - b // 2]  # inside bursts, not the first/last
        assert _missing(np.delete(t, dropped))[0].sum() == 2, n


def test_stamps_going_back_have_a_grid():
    """Found by a review: the grids about as good as the best were those
    within least·(1 + 5 %) + 2 of its cost, none when that cost fell under
    -40 (stamps going back, as a bursty part's spread stamps did where a rate
    change was misplaced: bursts of 4 at 1 then 0.1 kHz): ValueError (min()
    of an empty sequence). The slack is now 5 % of its size."""
    from drake_dynid.raw_log import _grid_missing

    burst, r = 4.0 * np.arange(200), np.arange(4)
    stamps = (burst[:, None] - 10 * (3 - r)).ravel() * 1e-3  # 30 ms back each
    missing, shared, step = _grid_missing(stamps)
    assert shared > 0 and step > 0.0 and missing.size == stamps.size - 1


def _random_file(rng, shape):
    """(stamps, missing, change): a random complete joined file of a shape,
    with 0-5 drops (none in the first or last 10 stamps: a first or last
    burst short of stamps is read as cut by the log); ``change``: the stamp
    where its rate changes (shape "rates"; else -1)."""
    n = int(rng.integers(300, 3000))
    h = float(rng.choice([1e-3, 2e-3, 5e-3, 1e-2]))
    k = np.arange(n).astype(float)
    change = -1
    if shape == "jitter":  # ROS stamps: up to ±20 %
        t = k + rng.uniform(-1, 1, n) * rng.uniform(0.0, 0.2)
    elif shape == "bursts":  # a driver batching 2-8 messages
        b = int(rng.integers(2, 9))
        t = (k // b) * b + b - 1 + (k % b) * 0.01
        t += np.repeat(rng.uniform(0, 0.2, n // b + 1), b)[:n]
    elif shape == "unequal":  # flushed every p steps, p - q then p + q messages
        p = int(rng.integers(3, 9))
        q = int(rng.integers(1, p))
        ends = np.cumsum(np.tile([p - q, p + q], n // (2 * p) + 2))
        b = np.searchsorted(ends, k, side="right")  # each message's burst
        t = p * (b + 1) + rng.uniform(0, 0.1, b[-1] + 1)[b]
        t += 1e-3 * (k - np.concatenate([[0], ends])[b])
    elif shape == "stretch":  # 10-50 % of it in bursts of 2-8
        b = int(rng.integers(2, 9))
        a = int(rng.integers(10, n // 2))
        z = a + int(rng.uniform(0.1, 0.5) * n) // b * b
        t = k + rng.uniform(-0.1, 0.1, n)
        inside = (k >= a) & (k < z)
        t[inside] = a + (k[inside] - a) // b * b + b - 1 + (k[inside] - a) % b * 0.01
        burst = np.where(inside, (k - a) // b + n, k + 2 * n * (k >= z))
    elif shape == "glitch":  # a few stamps near-coincident once
        t = k + rng.uniform(-0.05, 0.05, n)
        g, c = int(rng.integers(20, n - 20)), int(rng.integers(2, 4))
        t[g : g + c] = t[g] + 0.01 * np.arange(c)
    elif shape == "rates":  # its first or last 10 % at half or twice the rate
        step = np.ones(n)
        change = n // 10 if rng.random() < 0.5 else n - n // 10
        if change < n // 2:
            step[:change] = float(rng.choice([0.5, 2.0]))
        else:
            step[change:] = float(rng.choice([0.5, 2.0]))
        t = np.concatenate([[0.0], np.cumsum(step[:-1])])
        t += rng.uniform(-1, 1, n) * rng.uniform(0.0, 0.2) * step
    else:  # a pause of a minute, resumed at the same rate
        t = k + rng.uniform(-0.1, 0.1, n)
        k[int(rng.integers(n // 4, 3 * n // 4)) :] += round(60.0 / h)
        t += k - np.arange(n)
    kept = np.ones(n, bool)
    end = 4 * p + 10 if shape == "unequal" else 10  # its last 2 bursts of each size
    where = np.arange(10, n - end)
    if shape == "stretch":  # not in its first or last burst (unseen: noted)
        where = where[(np.abs(where - a) > b) & (np.abs(where - z) > b)]
    kept[rng.choice(where, int(rng.integers(0, 6)), False)] = False
    expected = np.diff(k[kept]).astype(np.int64) - 1
    if shape in ("bursts", "unequal", "stretch"):  # in the hole before its burst
        if shape != "stretch":  # each stamp outside a stretch: its own burst
            burst = k // b if shape == "bursts" else b
        expected[:] = 0
        before = np.searchsorted(burst[kept], burst[~kept]) - 1
        np.add.at(expected, before, 1)
    if change >= 0:
        change = int(np.searchsorted(np.flatnonzero(kept), change))
    scale = float(rng.choice([1.0, 1e3, 1e9]))  # s, ms, ns
    return t[kept] * h * scale, expected, change


SHAPES = ["jitter", "bursts", "glitch", "pause", "rates", "unequal", "stretch"]


@pytest.mark.parametrize("shape", SHAPES)
def test_random_files_count_their_drops_exactly(shape):
    """A property of the count (a review; 1000 files a shape, seeded, gave
    the same): a file without drops counts 0 missing and one with k drops
    counts k, each in its interval, whatever its rate, time unit (s, ms, ns)
    and shape: ±20 % jitter; bursts of 2-8 messages (a drop counted in the
    hole before its burst; 1 file in 1000 a burst off); 2-3 stamps
    near-coincident once (they share a slot: a note says so, and a drop beside
    them may be placed up to 2 intervals off: 9 files in 1000); a pause of a
    minute (its count within 0.25 % of its length, the step across it read
    from the stamps: 132 of 60 000 off at worst); its first or last 10 % at
    half or twice the rate (a drop beside the change may read as the other
    rate's step: 15 files in 1000 one sample off there, none complete); a
    publisher flushing every p steps p - q then p + q messages (a drop within
    a burst of the hole before its burst; 1 file in 300 one drop unseen, none
    false; 76 of 100 files' counts wrong before the deficit count); 10-50 %
    of it in bursts of 2-8 (none in its first or last burst, unseen as the
    note says; before each stretch was counted on its own: 1-3 false samples
    at the switch). Before
    the pause's two fixes a file of 300-600 stamps counted such a pause on a
    0.5 s grid (82 samples missing for 60 000, its drops lost: 19 files in
    1000); before short files' blocks of 16, a 10 % end at half the rate under
    128 intervals was no rate change (its intervals a sample missing each: 21
    of 200 files of 300-3000 stamps)."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(SHAPES.index(shape))
    for _ in range(50 if shape == "rates" else 100):  # rates: 2 parts each
        stamps, expected, change = _random_file(rng, shape)
        missing, shared, _ = _missing(stamps)
        pause = expected > 1000
        off = np.abs(missing[pause] - expected[pause])
        assert (off <= 2.5e-3 * expected[pause]).all(), (missing, expected)
        missing, expected = missing[~pause], expected[~pause]
        wrong = np.flatnonzero(missing != expected)
        if shape == "rates" and expected.any():  # beside the change: ±1
            assert abs(missing.sum() - expected.sum()) <= 2
            assert (np.abs(wrong - change) <= 2).all(), (wrong, change)
            continue
        if shape == "unequal":  # each drop within a burst of its own
            assert missing.sum() == expected.sum(), (missing.sum(), expected.sum())
            at = np.repeat(np.arange(missing.size), missing)
            due = np.repeat(np.arange(expected.size), expected)
            assert (np.abs(at - due) <= 15).all(), (at, due)
            continue
        assert missing.sum() == expected.sum()
        if shape in ("glitch", "bursts") and wrong.size == 2:  # placed near it
            assert wrong[1] - wrong[0] <= (2 if shape == "glitch" else 8), wrong
        else:
            np.testing.assert_array_equal(missing, expected)
        # a glitch's 2-3 stamps share a slot (a note says so); so may a last
        # burst cut by the log's end (8 files in 1000, their counts right)
        assert shared <= {"glitch": 2, "bursts": 1}.get(shape, 0), shared


def test_bursts_of_unequal_sizes_are_counted_by_their_deficit():
    """Found by a review: a 1 kHz stream flushed every 4 ms as 3 then 5 messages
    (1600 stamps, complete) counted 398 false samples missing: the step was the
    median per-burst ratio (1.07 ms). The samples received are now compared
    with the time elapsed (the deficit's floor, a step fitted on the bursts
    that emptied the buffer): none missing, a drop counted once in the hole
    before its burst or the one before (a sample left in the buffer at that
    flush)."""
    from drake_dynid.raw_log import _missing

    k = np.arange(1600)
    ends = np.cumsum(np.tile([3, 5], 200))
    burst = np.searchsorted(ends, k, side="right")
    t = 4e-3 * (burst + 1) + 1e-6 * (k - np.concatenate([[0], ends])[burst])
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and not shared
    assert "a step of 0.001 in its time unit" in found[0], found
    kept = np.ones(k.size, bool)
    kept[[500, 901]] = False  # in a 5-burst and a 3-burst
    missing = _missing(t[kept])[0]
    assert missing.sum() == 2, np.flatnonzero(missing)
    at = np.flatnonzero(missing)
    assert np.abs(at - np.array([499, 898])).max() <= 8, at


def test_a_stretch_of_bursts_is_counted_by_burst():
    """Found by a review: a file with 10-50 % of it in bursts of 2-8 (not
    bursty as a whole) was counted on one grid: 1-3 false samples missing at
    the switch and a beyond-the-bound note (stamps sharing a slot) on a
    complete file. Each stretch of bursts is now counted by burst, the rest on
    its grid: none missing, no shared slot, a note naming the stretch; a drop
    inside it is one sample missing in the hole before its burst."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(3)
    k = np.arange(1000)
    t = k + rng.uniform(-0.1, 0.1, k.size)
    inside = (k >= 300) & (k < 600)
    t[inside] = 300 + (k[inside] - 300) // 4 * 4 + 3 + (k[inside] - 300) % 4 * 0.01
    t *= 0.01
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and shared == 0, (np.flatnonzero(missing), shared)
    assert found[0].startswith("its stamps come in bursts from "), found
    kept = np.ones(k.size, bool)
    kept[450] = False  # in the burst of 448-451: the hole before it, 447
    missing = _missing(t[kept])[0]
    assert np.flatnonzero(missing).tolist() == [447], np.flatnonzero(missing)


def test_receive_stamps_with_latency_bursts_are_counted_by_burst():
    """Found by a review: receive stamps (1 in 8 messages 2-8 steps late, the
    ones behind it held until it arrives, the rest on time) under the 40 % of
    short intervals of a bursty file: counted in their stretches of bursts
    and the grid between them, 11 of these 20 files of 300-3000 stamps were
    counted wrong (230 false samples missing). A file with 4 stretches of bursts or
    more is counted by burst as a whole: the drops' count exact, none false."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(11)
    for _ in range(20):
        n = int(rng.integers(300, 3000))
        lat = rng.uniform(0, 0.02, n)
        late = rng.random(n) < 0.12
        lat[late] = rng.uniform(2, 8, late.sum())
        t = np.maximum.accumulate(np.arange(n) + lat) + 1e-4 * np.arange(n)
        kept = np.ones(n, bool)
        kept[rng.choice(np.arange(10, n - 30), int(rng.integers(0, 4)), False)] = False
        missing = _missing(t[kept] * 0.01)[0]
        assert missing.sum() == n - kept.sum(), (n, missing.sum(), n - kept.sum())


def _received(n, h, rng, stall_p, lat=1e-3, most=5e-3, stall=(0.02, 0.05)):
    """Receive stamps of a topic published every ``h`` s (a review's shape):
    each message late by an exponential latency (mean ``lat``, at most
    ``most``), the subscriber stalled with probability ``stall_p`` a message
    (for 20-50 ms: the messages published meanwhile received at its end, 2 us
    apart); the stamps up to the ``n``-th message's."""
    m = n + 100
    sent = h * np.arange(m)
    t = sent + np.minimum(rng.exponential(lat, m), most)
    i = 0
    while i < m:
        if rng.random() < stall_p:
            end = sent[i] + rng.uniform(*stall)
            j = i
            while j < m and sent[j] < end:
                t[j] = max(t[j], end)
                j += 1
            i = j
        else:
            i += 1
    for k in range(1, m):
        t[k] = max(t[k], t[k - 1] + 2e-6)
    return t[t <= t[n - 1] + 0.3 * h]


@pytest.mark.parametrize("seed", [5, 7, 32])
def test_latency_in_the_last_bursts_is_no_drop(seed):
    """Found by a review: receive stamps of a 500 Hz topic (latency up to 2.5
    steps, 5 % stalls: bursts of 1 at the median, counted by burst) lie above
    the deficit's floor up to 5-11 bursts in a row; in 3 of 40 complete files
    of 1000 stamps (these seeds) the last 3-4 bursts all did, read as the
    floor rising: 1 false sample missing, the note naming only the last 2
    bursts. The last bursts now span one more than the longest such run
    before them: none missing, the note names them; a drop before them is
    counted."""
    from drake_dynid.raw_log import _missing

    t = _received(1000, 0.002, np.random.default_rng(seed), 0.05)
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and not shared, (np.flatnonzero(missing), shared)
    before = int(found[0].split("one in the ")[1].split()[0])
    assert 5 <= before <= 12, found
    assert _missing(np.delete(t, [300, 600]))[0].sum() == 2


def test_a_lone_stall_is_named_and_counted_by_the_time_elapsed():
    """Found by a review: an EtherCAT master stalled for 10 ms once a second
    (1 kHz, stamps within 2 us of their slots; the messages of the stall
    received at its end, 1 us apart) was named 'its stamps come in bursts'
    and each stall counted on a grid of its own, 9 stamps sharing a slot (a
    beyond-bound note on a complete file; a drop in it counted 0). A stretch
    that is one burst is now named a stall with its catch-up, its samples
    counted against the time elapsed to the next stamp: none missing, a drop
    in a stall or beside it counted once."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    slots = np.arange(3000)
    t = slots * 1e-3 + rng.uniform(-2e-6, 2e-6, slots.size)
    for s in (13, 1013, 2013):  # stalled from slot s to s + 10
        held = (slots >= s) & (slots < s + 10)
        t[held] = (s + 10) * 1e-3 + 1e-6 * np.arange(10) - 0.33e-3
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and shared == 0, (np.flatnonzero(missing), shared)
    assert found[0].startswith("it stalls, then catches up in one burst, from "), found
    assert "(10 stamps)" in found[0] and "bursts" not in found[0], found
    missing = _missing(np.delete(t, [17, 1023, 1500]))[0]
    assert missing.sum() == 3, np.flatnonzero(missing)


@pytest.mark.parametrize("seed", [60, 112, 150, 186])
def test_stalls_caught_up_are_no_rate_change(seed):
    """Found by a review: receive stamps of a 500 Hz topic with stalls (20-50
    ms, each caught up by one burst; here 10 % a message, 1000 stamps) were
    read in blocks of 64 intervals whose stall holes were left out as pauses
    and catch-ups kept: blocks with stalls read 6-26 % faster, a rate change
    (4 of 200 complete files, these seeds: 4-16 false samples missing, the
    note naming the false rates). A short bursty file is now read in blocks
    of whole bursts: no rate change, none missing; drops counted."""
    from drake_dynid.raw_log import _missing

    t = _received(1000, 0.002, np.random.default_rng(seed), 0.1)
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and not shared, (np.flatnonzero(missing), shared)
    assert not any("rate changes" in c for c in found), found
    assert _missing(np.delete(t, [300, 600]))[0].sum() == 2


@pytest.mark.parametrize(("n", "stall_p", "seed"), [(100, 0.05, 22), (1000, 0.1, 38)])
def test_a_count_blurred_by_latency_says_it_is_uncertain(n, stall_p, seed):
    """Found by a review: receive stamps with latency (0-2.5 steps) and stalls
    blur the bursts' floor; of the steps about as close to it the one fitted
    was 0.75-1.5 % short, 1 and 7 false samples missing on these complete
    files with no word of doubt. Taking the fewest of the steps within twice
    the least spread would hide most drops (34 of 40 files with 1-5 counted
    wrong), so the count stays, and the note says a step nearly as close
    counts fewer: uncertain."""
    from drake_dynid.raw_log import _missing

    t = _received(n, 0.002, np.random.default_rng(seed), stall_p)
    missing, shared, found = _missing(t)
    assert missing.sum() > 0 and not shared
    assert "counts" in found[-1] and "the count is uncertain" in found[-1], found


def test_a_stall_two_stamps_before_the_end_is_no_drop():
    """Found by a review: a 1 kHz file's stall (10 samples held, received at
    its end 1 us apart) 2 stamps before the file's end left a part of 3 stamps
    after it, from the catch-up's last stamp (0.33 step to the next): its grid
    read a short step, 1 false sample missing on a complete file (40 of 40
    seeds). The stall is counted up to the stamp after its burst, the next
    part from there: none; a drop after a stall counted once."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    slots = np.arange(3000)
    t = slots * 1e-3 + rng.uniform(-2e-6, 2e-6, slots.size)
    for s in (1500, 2988):  # stalled from slot s to s + 10
        held = (slots >= s) & (slots < s + 10)
        t[held] = (s + 10) * 1e-3 + 1e-6 * np.arange(10) - 0.33e-3
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and shared == 0, (np.flatnonzero(missing), shared)
    assert found[0].startswith("it stalls, then catches up in one burst"), found
    assert _missing(np.delete(t, [1511]))[0].sum() == 1


def test_a_stall_after_a_rate_change_is_counted_at_its_own_step():
    """Found by a review: a file at 1 kHz then 500 Hz (1500 samples each) with
    a stall in the 500 Hz half (10 samples held, received at once before the
    next) counted the stall at the file's mean step: 4 false samples missing
    on a complete file, no note of doubt (40 of 40 seeds). A stall is counted
    at the step around it where that differs from the file's by over 5 %:
    none; a drop beside it counted once."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    g = np.concatenate([np.arange(1500) * 1e-3, 1.499 + 2e-3 * np.arange(1, 1501)])
    t = g + rng.uniform(-2e-6, 2e-6, g.size)
    t[2500:2510] = t[2510] - 0.33 * (t[2510] - t[2509]) - 1e-6 * np.arange(10)[::-1]
    missing, shared, found = _missing(t)
    assert missing.sum() == 0 and shared == 0, (np.flatnonzero(missing), shared)
    assert any("it stalls" in c for c in found), found
    assert _missing(np.delete(t, [2512]))[0].sum() == 1


@pytest.mark.parametrize("pause", [200.0, 60000.0])
def test_a_pause_in_a_bursty_file_is_counted(pause):
    """Found by a review: 400 stamps of a 1 kHz publisher flushing bursts of 4
    (each burst 0-0.1 step late) with a pause of 200 ms or a minute read one
    step over the whole file (0.3 s for the minute): the pause counted 0
    samples missing, drops unseen (40 of 40 seeds). A burst whose step is
    over BURST_PAUSE times the 90th percentile follows a pause: the stretches
    on either side counted on their own, the pause against the time elapsed
    (200 ms: exactly; a minute: within 0.25 %, as a grid's)."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    last = np.arange(400) // 4 * 4 + 3
    t = last + 0.02 * (np.arange(400) - last) + rng.uniform(0, 0.1, 400)[last]
    t = np.maximum.accumulate(t + 1e-6 * np.arange(400))
    t[200:] += pause
    missing, shared, found = _missing(t * 1e-3)
    assert abs(missing.sum() - pause) <= 2.5e-3 * pause and not shared, missing.sum()
    assert found[0].startswith("its bursts pause from "), found
    if pause < 1000:
        assert missing.sum() == pause
        assert _missing(np.delete(t, [50, 301]) * 1e-3)[0].sum() == pause + 2


def test_a_long_pause_is_cut_before_bursts_and_rate_changes():
    """Found by a review: 200 stamps of a 1 kHz publisher flushing bursts of
    4, at 500 Hz from stamp 100, with a minute's pause at stamp 60, read a
    step of 0.6 s over the spans holding the pause: 66 samples missing for
    60 000, 99 stamps sharing a slot, a false rate note (0.6066 then 0.002).
    A pause over LONG_PAUSE steps is cut out first, each side counted on its
    own, the pause by its length: within 0.25 %, no stamp sharing a slot."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    g = np.arange(200.0)
    g[100:] = 100 + 2.0 * np.arange(100)
    last = np.arange(200) // 4 * 4 + 3
    t = g[last] + 0.02 * (np.arange(200) - last) + rng.uniform(0, 0.1, 200)[last]
    t = np.maximum.accumulate(t + 1e-6 * np.arange(200))
    t[60:] += 60000.0
    missing, shared, found = _missing(t * 1e-3)
    assert abs(missing.sum() - 60000) <= 150 and shared == 0, (missing.sum(), shared)
    assert missing[59] == missing.sum(), np.flatnonzero(missing)
    assert found[0].startswith("its bursts pause from "), found


def test_a_short_pause_among_bursts_is_counted():
    """Found by a review: a 50 ms pause among 400 stamps of a 1 kHz publisher
    flushing bursts of 4 (0-0.1 step late) was unseen, 0 counted, the step
    read 1.25 ms and drops lost (40 of 40 seeds): its burst's step, 13.5 times
    the 90th percentile, is under BURST_PAUSE (receive stamps' latency reads
    up to 8.8). A burst whose step is over PAUSE times it follows a pause
    too where the deficit's floor stays PAUSE_RISE samples higher after it
    (a late burst or a stall is caught up): 50, drops counted."""
    from drake_dynid.raw_log import _missing

    rng = np.random.default_rng(0)
    last = np.arange(400) // 4 * 4 + 3
    t = last + 0.02 * (np.arange(400) - last) + rng.uniform(0, 0.1, 400)[last]
    t = np.maximum.accumulate(t + 1e-6 * np.arange(400))
    t[200:] += 50.0
    missing, shared, found = _missing(t * 1e-3)
    assert missing.sum() == 50 and not shared, missing.sum()
    assert found[0].startswith("its bursts pause from "), found
    assert _missing(np.delete(t, [50, 301]) * 1e-3)[0].sum() == 52
