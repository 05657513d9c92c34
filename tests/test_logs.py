"""The log reader's text layer and repairs: format, encoding, cells, API."""

import gzip

import numpy as np
import pytest

from drake_dynid.logs import RobotLog, read_log, write_log

JOINTS = ("shoulder", "elbow")
HEADER = "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n"


def make_log(path, n=50, h=1e-3, seed=0):
    rng = np.random.default_rng(seed)
    t = h * np.arange(n)
    q = rng.normal(size=(n, 2))
    tau = rng.normal(size=(n, 2))
    write_log(path, t, q, tau, JOINTS)
    return t, q, tau


def write_text(path, text):
    path.write_text(text, encoding="utf-8")
    return path


def rows(n, h=1e-3):
    return "".join(f"{k * h!r},{k},{2 * k},{3 * k},{4 * k}\n" for k in range(n))


def test_round_trip_is_lossless(tmp_path):
    t, q, tau = make_log(tmp_path / "a.csv")
    log = read_log(tmp_path / "a.csv", JOINTS)
    np.testing.assert_array_equal(log.q, q)
    np.testing.assert_array_equal(log.tau, tau)
    np.testing.assert_allclose(log.t, t, atol=1e-15)
    assert log.time_step == 1e-3
    assert log.time_offset == 0.0
    assert log.warnings == ()
    assert log.joint_names == JOINTS
    assert not log.filled.any() and log.filled.shape == (50,)


def test_column_order_is_free_and_joint_order_follows_argument(tmp_path):
    path = write_text(
        tmp_path / "b.csv",
        "tau_elbow,q_elbow,t,q_shoulder,tau_shoulder\n4,2,0,1,3\n8,6,0.001,5,7\n",
    )
    log = read_log(path, JOINTS)
    np.testing.assert_array_equal(log.q, [[1, 2], [5, 6]])
    np.testing.assert_array_equal(log.tau, [[3, 4], [7, 8]])


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_log(tmp_path / "none.csv", JOINTS)
    with pytest.raises(IsADirectoryError, match="is a directory"):
        read_log(tmp_path, JOINTS)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "is empty; expected a header row"),
        ("\n \n\t\n", "is empty; expected a header row"),
        (HEADER, "no data rows"),
        (HEADER + "\n\n", "no data rows"),
        ("t,q_shoulder,tau_shoulder,tau_elbow\n0,1,2,3\n", "missing column.*q_elbow"),
        ("t,t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n", "duplicated column.*'t'"),
        (HEADER + "0,1,abc,3,4\n", "row 2, column 'q_elbow': 'abc' is not a number"),
        (HEADER + "0,1,2,3\n", "row 2 has 4 cells; the header has 5"),
        (HEADER + "0,1,2,3,4\n\n\n0.001,1,2,3\n", "row 5 has 4 cells"),
        (HEADER + "0,1,2,3,4\n0,1,2,3,4\n", "duplicated time stamp at row 3"),
        (HEADER + "0.002,1,2,3,4\n0.001,1,2,3,4\n", "not increasing at row 3"),
        (HEADER + "0,1,2,3,4\nnan,1,2,3,4\n", "time stamp of row 3 is empty or not"),
        (HEADER + "0,1,2,3,4\n", "at least 2 samples; got 1"),
        (HEADER + '0,1,"2,3,4\n', "row 2"),
    ],
)
def test_malformed_logs_name_the_problem(tmp_path, text, match):
    path = write_text(tmp_path / "bad.csv", text)
    with pytest.raises(ValueError, match=match):
        read_log(path, JOINTS)


def test_a_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + (HEADER + rows(5)).encode())
    log = read_log(path, JOINTS)
    assert log.num_samples == 5 and log.warnings == ()


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (
            (HEADER + rows(3)).encode() + "0.003,1,2,3,4 # 20°C\n".encode("latin-1"),
            r"not UTF-8 text: byte 102 \(line 5, column 19\) is 0xb0; expected UTF-8",
        ),
        ((HEADER + rows(3)).encode("utf-16"), "UTF-16 or UTF-32.*expected UTF-8"),
        # Found by a review: a gzip log was said to be Latin-1 (iconv -f latin1).
        (
            gzip.compress((HEADER + rows(3)).encode()),
            r"gzip-compressed \(it starts with bytes 1f 8b\), not CSV text: "
            r"decompress \(gunzip\)",
        ),
        (
            (HEADER + rows(3)).encode() + b"\x00\x00",
            r"not a text file: byte 84 \(line 5\) is NUL",
        ),
    ],
)
def test_encoding_errors_name_the_byte_and_the_expected_encoding(tmp_path, data, match):
    path = tmp_path / "enc.csv"
    path.write_bytes(data)
    with pytest.raises(ValueError, match=match) as error:
        read_log(path, JOINTS)
    assert str(path) in str(error.value)


def test_extra_columns_are_ignored_with_a_warning(tmp_path):
    path = write_text(
        tmp_path / "c.csv",
        "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow,temp\n0,1,2,3,4,40\n0.001,1,2,3,4,41\n",
    )
    log = read_log(path, JOINTS)
    assert any("temp" in w for w in log.warnings)


@pytest.mark.parametrize(
    "names",
    [
        ("base, shoulder", 'elbow "2"'),
        ("a,b,c", "d"),
        ("épaule", "coude ω"),
        ('"', ","),
    ],
)
def test_joint_names_with_commas_and_quotes_round_trip(tmp_path, names):
    rng = np.random.default_rng(2)
    q, tau = rng.normal(size=(20, 2)), rng.normal(size=(20, 2))
    write_log(tmp_path / "n.csv", 1e-3 * np.arange(20), q, tau, names)
    log = read_log(tmp_path / "n.csv", names[::-1])
    np.testing.assert_array_equal(log.q, q[:, ::-1])
    np.testing.assert_array_equal(log.tau, tau[:, ::-1])
    assert log.joint_names == names[::-1]


@pytest.mark.parametrize("name", ["a\nb", " a", "a "])
def test_write_log_refuses_names_it_could_not_read_back(tmp_path, name):
    with pytest.raises(ValueError, match="joint name"):
        write_log(
            tmp_path / "x.csv", [0, 1], np.zeros((2, 1)), np.zeros((2, 1)), [name]
        )


def test_write_log_checks_shapes(tmp_path):
    with pytest.raises(ValueError, match="shape"):
        write_log(
            tmp_path / "h.csv", np.zeros(3), np.zeros((3, 1)), np.zeros((3, 2)), JOINTS
        )


def test_a_last_row_cut_short_without_a_line_end_is_dropped(tmp_path):
    path = write_text(tmp_path / "cut.csv", HEADER + rows(10) + "0.01,10,2")
    log = read_log(path, JOINTS)
    assert log.num_samples == 10
    assert any("last row 12 is cut short" in w for w in log.warnings)


@pytest.mark.parametrize(
    "tail", ["0.01,10,20,30,-", "0.01,10,20,30,4e", "0.01,10,20,30,-1"]
)
def test_a_last_row_cut_inside_its_last_cell_is_dropped(tmp_path, tail):
    """Found by a review: cut to '-' or '4e' it was an error, cut to '-1' (from
    '-1.70') it was read as -1 without a word. A last row without a line end may
    be cut anywhere: it is dropped, said."""
    path = write_text(tmp_path / "cut.csv", HEADER + rows(10) + tail)
    log = read_log(path, JOINTS)
    assert log.num_samples == 10
    assert any("last row 12 is without a line end" in w for w in log.warnings)


def test_a_trailing_comma_in_the_header_and_the_rows_is_read_silently(tmp_path):
    """Found by a review: it warned "ignored extra column(s) ." (an empty name)."""
    text = HEADER.replace("\n", ",\n") + rows(10).replace("\n", ",\n")
    log = read_log(write_text(tmp_path / "t.csv", text), JOINTS)
    assert log.num_samples == 10 and log.warnings == ()
    np.testing.assert_array_equal(log.q[:, 0], np.arange(10))


def test_many_extra_columns_are_counted_not_all_listed(tmp_path):
    """Found by a review: 20 000 extra columns (a logger's every topic) gave a
    warning line of 149 kB."""
    extra = [f"x{i}" for i in range(2000)]
    header = HEADER.rstrip("\n") + "," + ",".join(extra) + "\n"
    body = "".join(
        f"{0.001 * k},1,2,3,4," + ",".join(["0"] * 2000) + "\n" for k in range(3)
    )
    log = read_log(write_text(tmp_path / "x.csv", header + body), JOINTS)
    (note,) = log.warnings
    assert note == "ignored 2000 extra column(s): x0, x1, x2, x3, x4, x5 and 1994 more."


def test_blank_lines_keep_the_row_numbers_of_the_file(tmp_path):
    path = write_text(
        tmp_path / "blank.csv", "\n" + HEADER + "0,1,2,3,4\n\n0.001,x,2,3,4\n"
    )
    with pytest.raises(ValueError, match="row 5, column 'q_shoulder'"):
        read_log(path, JOINTS)


def test_fast_and_cell_by_cell_readers_agree(tmp_path, monkeypatch):
    import drake_dynid.log_table as table

    make_log(tmp_path / "a.csv", n=200, seed=3)
    fast = read_log(tmp_path / "a.csv", JOINTS)
    monkeypatch.setattr(table, "_fast", lambda *args: None)
    slow = read_log(tmp_path / "a.csv", JOINTS)
    np.testing.assert_array_equal(fast.q, slow.q)
    np.testing.assert_array_equal(fast.tau, slow.tau)
    np.testing.assert_array_equal(fast.t, slow.t)


def test_short_runs_of_bad_cells_are_filled_and_flagged(tmp_path):
    n = 200
    t = 1e-3 * np.arange(n)
    q = np.column_stack([np.sin(5 * t), np.cos(3 * t)])
    tau = np.column_stack([2 * t, -t])
    bad_q, bad_tau = q.copy(), tau.copy()
    bad_q[10, 0] = np.nan  # one cell
    bad_tau[50:53, 1] = np.inf  # a run of 3
    bad_q[100:110, 1] = np.nan  # 10 > fill_gaps: kept bad
    write_log(tmp_path / "d.csv", t, bad_q, bad_tau, JOINTS)
    log = read_log(tmp_path / "d.csv", JOINTS)
    np.testing.assert_array_equal(np.flatnonzero(log.filled), [10, 50, 51, 52])
    np.testing.assert_array_equal(np.flatnonzero(log.bad_samples), np.arange(100, 110))
    np.testing.assert_allclose(log.q[10], q[10], atol=1e-9)  # cubic on a smooth q
    np.testing.assert_allclose(log.tau[50:53], tau[50:53], atol=1e-12)  # linear tau
    (note,) = [w for w in log.warnings if "NaN or infinite" in w]
    assert "14 sample(s)" in note and "4 filled" in note and "10 kept as bad" in note
    kept = read_log(tmp_path / "d.csv", JOINTS, fill_gaps=0)
    assert kept.bad_samples.sum() == 14 and not kept.filled.any()


def test_every_hundredth_sample_nan_is_named_and_filled(tmp_path):
    """Issue 14: such a log was told "q shows no motion"."""
    n = 30_001
    t = 1e-3 * np.arange(n)
    q = np.column_stack([np.sin(2 * t), np.cos(3 * t)])
    q[50::100, 0] = np.nan
    write_log(tmp_path / "nan.csv", t, q, q, JOINTS)
    log = read_log(tmp_path / "nan.csv", JOINTS)
    (note,) = [w for w in log.warnings if "NaN" in w]
    assert note.startswith("300 sample(s)")
    assert "rows 52 to 29952, every 100" in note and "300 filled" in note
    assert not log.bad_samples.any() and log.filled.sum() == 300


def test_filling_more_than_five_percent_is_an_error(tmp_path):
    t = 1e-3 * np.arange(100)
    q = np.ones((100, 2))
    q[::10, 1] = np.nan
    q[0, 1] = 1.0
    write_log(tmp_path / "many.csv", t, q, q, JOINTS)
    with pytest.raises(ValueError, match=r"9 of 100 samples \(9 %\).*fill_gaps=0"):
        read_log(tmp_path / "many.csv", JOINTS)
    assert read_log(tmp_path / "many.csv", JOINTS, fill_gaps=0).bad_samples.sum() == 9


def test_a_too_short_log_names_its_duration_and_the_minimum(tmp_path):
    make_log(tmp_path / "short.csv", n=101)
    with pytest.raises(ValueError, match=r"lasts 0.1 s \(101 samples.*at least 2.5 s"):
        read_log(tmp_path / "short.csv", JOINTS, min_duration=2.5)
    assert read_log(tmp_path / "short.csv", JOINTS, min_duration=0.1).num_samples == 101


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        (
            {"jitter_tolerance": 0.3},
            ValueError,
            r"jitter_tolerance must be in \(0, 0.25\] \[steps\]; got 0.3",
        ),
        ({"jitter_tolerance": "0.1"}, TypeError, "jitter_tolerance must be a real"),
        ({"fill_gaps": -1}, ValueError, "fill_gaps must be >= 0"),
        ({"fill_gaps": 2.5}, TypeError, "fill_gaps must be an integer"),
        ({"fill_gaps": True}, TypeError, "fill_gaps must be an integer"),
        ({"min_duration": float("nan")}, ValueError, "min_duration must be None or"),
    ],
)
def test_bad_options_are_named(tmp_path, kwargs, error, match):
    make_log(tmp_path / "a.csv")
    with pytest.raises(error, match=match):
        read_log(tmp_path / "a.csv", JOINTS, **kwargs)


@pytest.mark.parametrize(
    ("names", "error", "match"),
    [
        ("shoulder", TypeError, "sequence of joint names"),
        (("shoulder", 3), TypeError, "non-empty str"),
        ((), TypeError, "one or more"),
        (("a", "a"), ValueError, "repeats a"),
    ],
)
def test_bad_joint_names_are_named(tmp_path, names, error, match):
    make_log(tmp_path / "a.csv")
    with pytest.raises(error, match=match):
        read_log(tmp_path / "a.csv", names)


def test_from_arrays_repairs_like_the_reader(tmp_path):
    t = 5.0 + 1e-3 * np.delete(np.arange(100), [40])
    q = np.column_stack([t, 2 * t])
    log = RobotLog.from_arrays(t, q, -q, JOINTS)
    assert log.num_samples == 100 and log.time_step == 1e-3
    assert log.time_offset == pytest.approx(5.0, abs=1e-12)
    np.testing.assert_allclose(log.q[:, 1], 2 * (log.t + 5.0), atol=1e-12)
    assert np.flatnonzero(log.filled).tolist() == [40]
    assert any("sample 39 and sample 40" in w for w in log.warnings)
    single = RobotLog.from_arrays(t, t, t, ["j"])
    assert single.q.shape == (100, 1)


@pytest.mark.parametrize(
    ("t", "q", "match"),
    [
        (np.zeros((3, 1)), np.zeros((3, 2)), "t must be a 1-D array"),
        (np.array(["0", "1"]), np.zeros((2, 2)), "t must be a 1-D array of real"),
        (np.arange(3.0), np.zeros((3, 3)), r"q must be a real array of shape \(N, n\)"),
        (np.arange(3.0), np.zeros(3), r"\(3, 2\) \[rad or m\]; got shape \(3,\)"),
        (np.arange(3.0), np.full((3, 2), "x"), "dtype <U1"),
    ],
)
def test_from_arrays_checks_shapes(t, q, match):
    with pytest.raises(ValueError, match=match):
        RobotLog.from_arrays(t, q, np.zeros((len(t), 2)), JOINTS)
    with pytest.raises(ValueError, match=r"tau must be .*\[N·m or N\]"):
        RobotLog.from_arrays(np.arange(3.0), np.zeros((3, 2)), np.zeros((2, 2)), JOINTS)


def test_good_segments_are_the_runs_of_finite_samples():
    q = np.zeros((10, 2))
    q[[0, 4, 5]] = np.nan
    log = RobotLog(np.arange(10) * 1e-3, q, np.zeros((10, 2)), JOINTS, 1e-3)
    assert log.good_segments() == [(1, 4), (6, 10)]
    assert not log.filled.any() and log.time_offset == 0.0
    empty = RobotLog(np.arange(3) * 1e-3, np.full((3, 2), np.nan), q[:3], JOINTS, 1e-3)
    assert empty.good_segments() == []


@pytest.mark.parametrize("cell", ["0_5", "１７"])
def test_cells_python_reads_but_a_logger_never_writes_are_errors(tmp_path, cell):
    """Found by a review: '0_5' was read as 5 and '１７' as 17 (Python's float)."""
    body = rows(10).replace("\n5,", f"\n{cell},", 1).replace(",5,", f",{cell},", 1)
    path = write_text(tmp_path / "u.csv", HEADER + body)
    with pytest.raises(ValueError, match=f"'{cell}' is not a number"):
        read_log(path, JOINTS)


def test_an_unnamed_last_column_with_data_is_read_around(tmp_path):
    """Found by a review of the trailing-comma fix: a last column without a name
    but with numbers became an error ("row 2 has 6 cells; the header has 5")."""
    text = HEADER.replace("\n", ",\n") + rows(10).replace("\n", ",7\n")
    log = read_log(write_text(tmp_path / "u.csv", text), JOINTS)
    assert log.num_samples == 10 and log.warnings == ()
    body = "".join(line.replace(",", ",7,", 1) + "\n" for line in rows(10).split())
    middle = HEADER.replace("t,", "t,,", 1) + body
    log = read_log(write_text(tmp_path / "m.csv", middle), JOINTS)
    assert any("unnamed column 2" in w for w in log.warnings)


@pytest.mark.parametrize(
    ("header", "hint"),
    [
        ("t;q_shoulder;q_elbow;tau_shoulder;tau_elbow\n", "must be comma-separated"),
        ("time,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n", "named 'time': rename"),
        ("t,q_shoulder,tau_shoulder\n", "holds shoulder only: --joints shoulder"),
        ("t,q_a1,q_a2,tau_a1,tau_a2\n", "holds the joints a1, a2, not the ones asked"),
        ("t,pos1,pos2,eff1,eff2\n", "described in a drive file"),
    ],
)
def test_a_header_without_the_columns_says_what_it_looks_like(tmp_path, header, hint):
    """Found by a review: the missing-columns error never mentioned the separator,
    the time column's name, --joints or drive files."""
    separator = ";" if ";" in header else ","
    cells = header.count(separator) + 1
    body = "".join(separator.join(["0.001"] * cells) + "\n" for _ in range(3))
    path = write_text(tmp_path / "h.csv", header + body)
    with pytest.raises(ValueError, match=hint):
        read_log(path, JOINTS)


def test_a_header_of_many_columns_is_listed_in_one_short_line(tmp_path):
    """A log of 2000 other joints missing the robot's: its header's first 20
    columns named, the rest counted (a 27 kB message before)."""
    header = ["t", *(f"q_other_{k}" for k in range(2000))]
    path = write_text(tmp_path / "wide.csv", ",".join(header) + "\n")
    with pytest.raises(ValueError, match="missing column") as raised:
        read_log(path, JOINTS)
    text = str(raised.value)
    assert "q_other_18 and 1981 more" in text and len(text) < 800, len(text)


def test_the_joints_hint_of_a_partial_log_names_the_locks(tmp_path):
    """Found by a new user's walk-through: `dynid simulate --joints J --lock L`
    logs J only; scoring it without the options, the hint '--joints J identifies
    those alone' said no word of --lock, and the model then holds the others at 0:
    the fit is the same (the lumped link's parameters), but not the URDF's values
    that --compare-urdf, --physical's prior and the truth give (the Kinova's three
    first joints, the wrist at 0.3, 3.0, 0.2 rad: XX3R 0.331, at 0 0.091)."""
    path = write_text(tmp_path / "part.csv", "t,q_shoulder,tau_shoulder\n0,1,2\n")
    with pytest.raises(ValueError, match="missing column") as raised:
        read_log(path, JOINTS)
    text = str(raised.value)
    assert "--joints shoulder identifies those alone" in text, text
    assert "the others locked at 0 or where --lock NAME=VALUE,... held them" in text
