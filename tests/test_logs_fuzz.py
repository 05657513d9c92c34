"""Fuzz: whatever the file holds, read_log returns a valid log or raises ValueError.

Never another exception type, and never a grid longer than twice the rows read (the
only allocations proportional to the log). Bounded: a few seconds in all
(DYNID_FUZZ_EXAMPLES=3000 for a longer hunt).
"""

import math
import os
import pathlib
import tempfile

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_dynid.logs import RobotLog, read_log, write_log

JOINTS = ("a", "b")
HEADER = b"t,q_a,q_b,tau_a,tau_b\n"
FAST = settings(
    max_examples=int(os.environ.get("DYNID_FUZZ_EXAMPLES", 120)), deadline=None
)
DIRECTORY = tempfile.TemporaryDirectory(prefix="dynid_fuzz_")
PATH = pathlib.Path(DIRECTORY.name) / "log.csv"


def valid_or_value_error(read, rows):
    """Calls ``read``; a log must be uniform, finite in time, and small."""
    try:
        log = read()
    except ValueError as error:
        assert str(error)  # a message, never empty
        return None
    n = log.num_samples
    assert 2 <= n <= 2 * max(rows, 1)
    assert log.q.shape == log.tau.shape == (n, len(log.joint_names))
    assert log.filled.shape == (n,) and log.filled.dtype == bool
    assert math.isfinite(log.time_step) and log.time_step > 0
    assert math.isfinite(log.time_offset)
    np.testing.assert_allclose(log.t, log.time_step * np.arange(n), rtol=1e-12)
    assert all(isinstance(w, str) and w for w in log.warnings)
    return log


def read_bytes(data: bytes):
    PATH.write_bytes(data)
    return valid_or_value_error(lambda: read_log(PATH, JOINTS), data.count(b"\n") + 1)


@FAST
@given(st.one_of(st.binary(max_size=400), st.binary(max_size=400).map(HEADER.__add__)))
def test_random_bytes(data):
    read_bytes(data)


CELL = st.one_of(
    st.floats(width=64).map(repr),
    st.integers(-(10**20), 10**20).map(str),
    st.text(alphabet=' ,"\r\n0123456789.eE+-nafi_#\t', max_size=8),
    st.just(""),
)


@FAST
@given(
    st.lists(st.lists(CELL, min_size=3, max_size=6), max_size=30),
    st.sampled_from(["\n", "\r\n", "\r"]),
)
def test_garbled_rows(rows, newline):
    body = newline.join(",".join(row) for row in rows)
    read_bytes(HEADER + body.encode())


GRIDS = [(0.0, 1e-3)] * 4 + [
    (-3.0, 0.008),
    (0.0, 2e-5),  # 50 kHz: steps under 1e-5 s are refused (log_repair.FAST_STEP)
    (1.7e9, 1e-3),
    (1.7e18, 1e6),  # nanoseconds since the epoch
    (1e300, 1e290),
]


@st.composite
def stamps(draw):
    """A jittered grid with gaps and corruptions: outliers, swaps, NaN, epochs."""
    n = draw(st.integers(2, 300))
    origin, h = draw(st.sampled_from(GRIDS))
    jitter = draw(st.sampled_from([0.0, 0.01, 0.2, 0.3, 0.45]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    k = np.sort(rng.choice(n + draw(st.sampled_from([0, 3, n, 2 * n])), n, False))
    t = origin + h * (k + rng.uniform(-jitter, jitter, n))
    for _ in range(draw(st.sampled_from([0, 0, 1, 3]))):
        i = draw(st.integers(0, n - 1))
        t[i] = draw(
            st.one_of(
                st.floats(width=64),
                st.floats(-10.0, 10.0).map(lambda x, i=i: t[i] + x * h),
                st.just(t[(i + 1) % n]),
            )
        )
    return t


@FAST
@given(stamps(), st.sampled_from([0.0, 0.0, 0.01, 0.1]))
def test_random_time_stamps(t, nan_fraction):
    rng = np.random.default_rng(t.size)
    q = rng.normal(size=(t.size, 2))
    q[rng.uniform(size=t.size) < nan_fraction] = np.nan
    write_log(PATH, t, q, -q, JOINTS)
    log = valid_or_value_error(lambda: read_log(PATH, JOINTS), t.size)
    resampled = valid_or_value_error(
        lambda: read_log(PATH, JOINTS, resample=True), t.size
    )
    if log is not None and resampled is not None:
        assert resampled.num_samples <= 2 * t.size


@FAST
@given(
    stamps(),
    st.integers(0, 3).map(lambda n: ("a", "b", "c")[:n] or ("x",)),
    st.sampled_from([(0,), (1,), (2,), (1, 1), (0, 2)]),
)
def test_from_arrays(t, names, shape_delta):
    n = len(names)
    shape = (t.size + shape_delta[0], n + shape_delta[-1] - 1)
    q = np.zeros(shape) if shape_delta != (1,) else np.zeros((t.size, n))
    valid_or_value_error(lambda: RobotLog.from_arrays(t, q, q, names), t.size)
