import numpy as np
import pytest

from drake_dynid.logs import read_log, write_log

JOINTS = ("shoulder", "elbow")


def make_log(path, n=50, h=1e-3, seed=0):
    rng = np.random.default_rng(seed)
    t = h * np.arange(n)
    q = rng.normal(size=(n, 2))
    tau = rng.normal(size=(n, 2))
    write_log(path, t, q, tau, JOINTS)
    return t, q, tau


def write_text(path, text):
    path.write_text(text)
    return path


def test_round_trip_is_lossless(tmp_path):
    t, q, tau = make_log(tmp_path / "a.csv")
    log = read_log(tmp_path / "a.csv", JOINTS)
    np.testing.assert_array_equal(log.q, q)
    np.testing.assert_array_equal(log.tau, tau)
    np.testing.assert_allclose(log.t, t, atol=1e-15)
    assert log.time_step == pytest.approx(1e-3)
    assert log.warnings == ()
    assert log.joint_names == JOINTS


def test_column_order_is_free_and_joint_order_follows_argument(tmp_path):
    path = write_text(
        tmp_path / "b.csv",
        "tau_elbow,q_elbow,t,q_shoulder,tau_shoulder\n4,2,0,1,3\n8,6,0.001,5,7\n",
    )
    log = read_log(path, JOINTS)
    np.testing.assert_array_equal(log.q, [[1, 2], [5, 6]])
    np.testing.assert_array_equal(log.tau, [[3, 4], [7, 8]])


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="no such file"):
        read_log(tmp_path / "none.csv", JOINTS)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "is empty"),
        ("t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n", "no data rows"),
        ("t,q_shoulder,tau_shoulder,tau_elbow\n0,1,2,3\n", "missing column.*q_elbow"),
        ("t,t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n", "duplicated column.*t"),
        (
            "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n0,1,abc,3,4\n",
            "row 2, column 'q_elbow': 'abc' is not a number",
        ),
        ("t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n0,1,2,3\n", "row 2 has 4 cells"),
        (
            "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n0,1,2,3,4\n0,1,2,3,4\n",
            "duplicated time stamp",
        ),
        (
            "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n0.002,1,2,3,4\n0.001,1,2,3,4\n",
            "not increasing at row 3",
        ),
        (
            "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n0,1,2,3,4\nnan,1,2,3,4\n",
            "time stamp of row 3",
        ),
        ("t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n0,1,2,3,4\n", "at least 2"),
    ],
)
def test_malformed_logs_name_the_problem(tmp_path, text, match):
    path = write_text(tmp_path / "bad.csv", text)
    with pytest.raises(ValueError, match=match):
        read_log(path, JOINTS)


def test_extra_columns_are_ignored_with_a_warning(tmp_path):
    path = write_text(
        tmp_path / "c.csv",
        "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow,temp\n0,1,2,3,4,40\n0.001,1,2,3,4,41\n",
    )
    log = read_log(path, JOINTS)
    assert any("temp" in w for w in log.warnings)


def test_bad_cells_become_nan_samples(tmp_path):
    path = write_text(
        tmp_path / "d.csv",
        "t,q_shoulder,q_elbow,tau_shoulder,tau_elbow\n"
        "0,1,2,3,4\n0.001,,2,3,4\n0.002,1,2,inf,4\n0.003,1,2,3,4\n",
    )
    log = read_log(path, JOINTS)
    np.testing.assert_array_equal(log.bad_samples, [False, True, True, False])
    assert any("2 sample(s)" in w for w in log.warnings)


def test_jitter_is_snapped_with_a_warning(tmp_path):
    rng = np.random.default_rng(1)
    t = 1e-3 * np.arange(100) + rng.uniform(-5e-5, 5e-5, 100)
    write_log(tmp_path / "e.csv", t, np.zeros((100, 2)), np.zeros((100, 2)), JOINTS)
    log = read_log(tmp_path / "e.csv", JOINTS)
    np.testing.assert_allclose(np.diff(log.t), log.time_step, rtol=1e-9)
    assert any("jitter" in w for w in log.warnings)


def test_dropped_samples_are_inserted_as_bad_samples(tmp_path):
    t = 1e-3 * np.delete(np.arange(100), [10, 11, 50])
    q = np.ones((t.size, 2))
    write_log(tmp_path / "f.csv", t, q, q, JOINTS)
    log = read_log(tmp_path / "f.csv", JOINTS)
    assert log.num_samples == 100
    np.testing.assert_array_equal(np.flatnonzero(log.bad_samples), [10, 11, 50])
    assert any("3 dropped" in w for w in log.warnings)


def test_non_uniform_sampling_needs_resample(tmp_path):
    t = np.cumsum(np.r_[0.0, np.tile([1e-3, 1.5e-3], 50)])
    x = np.column_stack([t, 2 * t])
    write_log(tmp_path / "g.csv", t, x, x, JOINTS)
    with pytest.raises(ValueError, match=r"non-uniform sampling.*--resample"):
        read_log(tmp_path / "g.csv", JOINTS)
    log = read_log(tmp_path / "g.csv", JOINTS, resample=True)
    # Linear signals are reproduced exactly by linear interpolation.
    np.testing.assert_allclose(log.q[:, 1], 2 * log.t, atol=1e-12)
    assert any("resampled" in w for w in log.warnings)


def test_write_log_checks_shapes(tmp_path):
    with pytest.raises(ValueError, match="shape"):
        write_log(
            tmp_path / "h.csv", np.zeros(3), np.zeros((3, 1)), np.zeros((3, 2)), JOINTS
        )


def test_fast_and_cell_by_cell_readers_agree(tmp_path, monkeypatch):
    import drake_dynid.logs as logs

    make_log(tmp_path / "a.csv", n=200, seed=3)
    fast = read_log(tmp_path / "a.csv", JOINTS)
    monkeypatch.setattr(logs, "_fast_table", lambda path: None)
    slow = read_log(tmp_path / "a.csv", JOINTS)
    np.testing.assert_array_equal(fast.q, slow.q)
    np.testing.assert_array_equal(fast.tau, slow.tau)
    np.testing.assert_array_equal(fast.t, slow.t)


def test_good_segments_are_the_runs_of_finite_samples(tmp_path):
    from drake_dynid.logs import RobotLog

    q = np.zeros((10, 2))
    q[[0, 4, 5]] = np.nan
    log = RobotLog(np.arange(10) * 1e-3, q, np.zeros((10, 2)), JOINTS, 1e-3)
    assert log.good_segments() == [(1, 4), (6, 10)]
    empty = RobotLog(np.arange(3) * 1e-3, np.full((3, 2), np.nan), q[:3], JOINTS, 1e-3)
    assert empty.good_segments() == []
