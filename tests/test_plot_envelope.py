"""``--plot`` of a long trace: its envelope, read a block at a time.

A replay of hours has hundreds of thousands of solves, kept in temporary files
(``log_store.StoredArray``). ``commands._report.write_plot`` draws such a trace
as the extremes of ``PLOT_BUCKETS`` buckets of solves (``trace_envelope``) and
never loads it whole; a short trace is drawn solve by solve, as before.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from drake_dynid import log_store
from drake_dynid.commands import _report
from drake_dynid.commands._report import _invalid_runs, trace_envelope, write_plot
from drake_dynid.log_store import RowSink


def _trace(count: int, p: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = 0.05 * np.arange(count)
    theta = np.cumsum(rng.standard_normal((count, p)), axis=0)
    std = np.abs(rng.standard_normal((count, p)))
    std[rng.random((count, p)) < 0.05] = np.inf  # unidentified: no band
    return t, theta, std


def _stored(rows: np.ndarray):
    sink = RowSink(rows.shape[1], limit=0)
    for a in range(0, len(rows), 100):
        sink.append(rows[a : a + 100])
    return sink.finish()


class _NoWholeLoad:
    """Rows that may be sliced by at most ``limit`` rows, never loaded whole."""

    def __init__(self, rows: np.ndarray, limit: int):
        self._rows, self._limit = rows, limit

    def __len__(self) -> int:
        return len(self._rows)

    def __getitem__(self, index):
        assert isinstance(index, slice), index
        assert len(range(*index.indices(len(self._rows)))) <= self._limit, index
        return self._rows[index]

    def __array__(self, *args, **kwargs):
        raise AssertionError("the whole trace was loaded")


@pytest.mark.parametrize("count,buckets", [(10_000, 300), (997, 50), (40, 40)])
def test_envelope_is_each_buckets_extremes(count, buckets):
    t, theta, std = _trace(count, 3)
    first = count // 7  # estimates before the first valid solve are not drawn
    x, line, lower, upper = trace_envelope(t, theta, std, first, buckets)
    size = -(-count // buckets)
    shown = theta.copy()
    shown[:first] = np.nan
    sigma = np.where(np.isfinite(std), std, np.nan)
    starts = list(range(0, count, size))
    assert x.shape == (2 * len(starts),) and line.shape == (2 * len(starts), 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN buckets
        for b, a in enumerate(starts):
            rows = slice(a, min(a + size, count))
            assert x[2 * b] == t[rows][0] and x[2 * b + 1] == t[rows][-1]
            np.testing.assert_array_equal(line[2 * b], np.nanmin(shown[rows], axis=0))
            np.testing.assert_array_equal(
                line[2 * b + 1], np.nanmax(shown[rows], axis=0)
            )
            band_low = np.nanmin(shown[rows] - sigma[rows], axis=0)
            band_high = np.nanmax(shown[rows] + sigma[rows], axis=0)
            for end in (2 * b, 2 * b + 1):
                np.testing.assert_array_equal(lower[end], band_low)
                np.testing.assert_array_equal(upper[end], band_high)
    assert np.isnan(line[0]).all() == (first >= size)  # all before the first valid


def test_envelope_reads_a_block_at_a_time():
    t, theta, std = _trace(20_000, 4)
    expected = trace_envelope(t, theta, std, 5, 1000)
    limit = _report._CSV_BLOCK
    got = trace_envelope(
        t, _NoWholeLoad(theta, limit), _NoWholeLoad(std, limit), 5, 1000
    )
    for a, b in zip(expected, got, strict=True):
        np.testing.assert_array_equal(a, b)


def test_invalid_runs_merge_only_when_asked():
    t = np.arange(12.0)
    valid = np.array([1, 0, 1, 0, 0, 1, 1, 1, 1, 0, 1, 1], dtype=float)
    assert list(_invalid_runs(t, valid, 1.0)) == [(1.0, 2.0), (3.0, 5.0), (9.0, 10.0)]
    assert list(_invalid_runs(t, valid, 1.0, merge=1.5)) == [(1.0, 5.0), (9.0, 10.0)]
    assert list(_invalid_runs(t, np.ones(12), 1.0, merge=5.0)) == []


def test_long_stored_trace_is_plotted_as_its_envelope(tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 1024)
    count = 3 * _report.PLOT_BUCKETS + 17
    t, theta, std = _trace(count, 3)
    valid = np.ones(count)
    valid[:40] = 0.0
    valid[count // 2 : count // 2 + 9] = 0.0
    stored_theta, stored_std = _stored(theta), _stored(std)
    assert isinstance(stored_theta, log_store.StoredArray)

    drawn = []
    plt = _report.matplotlib_pyplot()
    original = plt.Axes.plot

    def plot(self, *args, **kwargs):
        drawn.append(len(args[0]))
        return original(self, *args, **kwargs)

    monkeypatch.setattr(plt.Axes, "plot", plot)
    path = tmp_path / "trace.png"
    write_plot(str(path), t, stored_theta, stored_std, valid, ["a", "b", "c"], "x")
    assert path.stat().st_size > 1000
    buckets = -(-count // -(-count // _report.PLOT_BUCKETS))
    assert drawn == [2 * buckets] * 3

    drawn.clear()
    short = tmp_path / "short.png"
    write_plot(
        str(short), t[:500], theta[:500], std[:500], valid[:500], ["a", "b", "c"], "x"
    )
    assert drawn == [500] * 3  # a short trace: every solve


def test_a_long_validation_is_plotted_as_envelopes_broken_between_segments(
    tmp_path, monkeypatch
):
    from types import SimpleNamespace

    from drake_dynid.commands import validate

    monkeypatch.setattr(log_store, "BUFFER_BYTES", 1024)
    count, n = 5 * _report.PLOT_BUCKETS + 3, 2
    rng = np.random.default_rng(1)
    t = 1e-3 * np.arange(count)
    segment = np.zeros(count)
    segment[3001:] = 1.0  # a NaN gap of the log between rows 3000 and 3001
    t[3001:] += 0.5
    measured = rng.standard_normal((count, n))
    predicted = measured + 0.1 * rng.standard_normal((count, n))
    stored = SimpleNamespace(
        joint_names=("a", "b"),
        t=_stored(t[:, None]),
        segment=_stored(segment[:, None]),
        measured=_stored(measured),
        predicted=_stored(predicted),
        num_samples_used=count,
        relative_rms_percent=np.ones(n),
        moving_relative_rms_percent=np.ones(n),
    )
    np.testing.assert_array_equal(validate._segment_breaks(stored.segment), [3001])
    x, series = validate._torque_series({"fit": stored})
    gap = np.flatnonzero(np.isnan(x))
    assert gap.size == 1 and x[gap[0] - 1] < t[3001] <= x[gap[0] + 1]
    assert len(x) < 2 * _report.PLOT_BUCKETS + 8  # bounded, whatever the count
    for values, full in zip(
        series, (measured, predicted, measured - predicted), strict=True
    ):
        assert np.isnan(values[gap]).all()
        kept = np.delete(values, gap, axis=0)
        assert kept.min() == full.min() and kept.max() == full.max()
        assert np.nanmin(values[: gap[0]]) == full[:3001].min()
    path = tmp_path / "torques.png"
    validate.write_torque_plot(str(path), {"fit": stored}, "x")
    assert path.stat().st_size > 1000


def test_bucket_times_read_a_stored_time_a_block_at_a_time():
    from drake_dynid.commands._report import bucket_times
    from drake_dynid.core.blocks import BLOCK_ROWS

    count = 3 * BLOCK_ROWS + 11
    t = 0.01 * np.arange(count)
    edges = np.array([0, 5, BLOCK_ROWS - 1, BLOCK_ROWS, 2 * BLOCK_ROWS + 3, count])
    expected = bucket_times(t, edges)
    np.testing.assert_array_equal(
        expected,
        t[
            [
                0,
                4,
                5,
                BLOCK_ROWS - 2,
                BLOCK_ROWS - 1,
                BLOCK_ROWS - 1,
                BLOCK_ROWS,
                2 * BLOCK_ROWS + 2,
                2 * BLOCK_ROWS + 3,
                count - 1,
            ]
        ],
    )
    sliced = _NoWholeLoad(t, BLOCK_ROWS)  # slices of a block at most, no arrays
    np.testing.assert_array_equal(bucket_times(sliced, edges), expected)


@pytest.mark.parametrize("count", [5, 6, 7])
def test_the_last_panel_of_each_column_shows_its_time_axis(
    tmp_path, monkeypatch, count
):
    # With an odd number of parameters the right column ends a row above the
    # bottom: its last panel had the "t [s]" label but no tick labels (sharex
    # hides them above the last row; a review, 15 parameters).
    pytest.importorskip("matplotlib")
    plt = _report.matplotlib_pyplot()
    saved = []
    monkeypatch.setattr(plt.Figure, "savefig", lambda self, *a, **k: saved.append(self))
    t, theta, std = _trace(50, count)
    names = [f"p{i}" for i in range(count)]
    write_plot(str(tmp_path / "p.png"), t, theta, std, np.ones(50), names, "x")
    (figure,) = saved
    shown = [axis for axis in figure.axes if axis.get_visible()]
    labelled = [axis for axis in shown if axis.get_xlabel()]
    assert len(labelled) == 2
    for axis in labelled:
        ticks = axis.xaxis.get_major_ticks()
        assert ticks and all(tick.label1.get_visible() for tick in ticks)


@pytest.mark.parametrize("count", [2, 15, 24, 48])
def test_the_title_stays_above_the_panels(tmp_path, monkeypatch, count):
    # At its default height (98 % of the figure) the title of a 48-parameter plot
    # (a 6-joint arm: 24 rows, 44 in tall) fell onto the first row (a review).
    pytest.importorskip("matplotlib")
    plt = _report.matplotlib_pyplot()
    saved = []
    original = plt.Figure.savefig

    def savefig(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        renderer = self.canvas.get_renderer()  # the figure as drawn to the file
        title = self._suptitle
        panels = [a.get_tightbbox(renderer) for a in self.axes if a.get_visible()]
        saved.append((title.get_text(), title.get_window_extent(renderer), panels))
        return result

    monkeypatch.setattr(plt.Figure, "savefig", savefig)
    t, theta, std = _trace(50, count)
    names = [f"p{i}" for i in range(count)]
    write_plot(str(tmp_path / "p.png"), t, theta, std, np.ones(50), names, "x")
    ((text, title, panels),) = saved
    assert text and title.y0 >= max(panel.y1 for panel in panels)


def test_the_torque_plot_gives_a_prismatic_joint_its_force_unit(tmp_path, monkeypatch):
    """A prismatic joint's effort is a force: its panel reads [N], not [N·m]."""
    from types import SimpleNamespace

    import matplotlib.pyplot as plt

    from drake_dynid.commands import validate

    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    count = 50
    t = 0.01 * np.arange(count)
    values = np.column_stack([np.sin(t), np.cos(t)])
    result = SimpleNamespace(
        joint_names=("torso_lift_joint", "arm_1_joint"),
        t=t,
        segment=np.zeros(count),
        measured=values,
        predicted=values,
        num_samples_used=count,
        relative_rms_percent=np.zeros(2),
        moving_relative_rms_percent=np.array([np.nan, 0.0]),
    )
    path = str(tmp_path / "torques.png")
    validate.write_torque_plot(path, {"fit": result}, "x", (True, False))
    labels = [axis.get_ylabel() for axis in figures[0].axes if axis.get_ylabel()]
    assert labels == ["torso_lift_joint\n[N]", "arm_1_joint\n[N·m]"]
    # The legend's moving error (2620346); a joint that never moves says so
    # (it read 'moving nan %').
    legends = [
        [text.get_text() for text in axis.get_legend().get_texts()]
        for axis in figures[0].axes
        if axis.get_legend() is not None
    ]
    assert legends == [
        ["measured", "fit (0.00 %; never moving)"],
        ["measured", "fit (0.00 %; moving 0.00 %)"],
    ]


@pytest.mark.parametrize("words", [3, 12, 90])
def test_a_long_title_is_wrapped_inside_the_figure_above_the_panels(words):
    """Found by a review: the TIAGo's validation plot titled with its two file
    names ("dynid offline: held-out torques (examples/data/tiago/tiago_position.csv
    + ...)") was one line 1.5 times the figure's width, cut at both ends."""
    from drake_dynid.commands._report import finish_panels

    plt = _report.matplotlib_pyplot()
    figure, axes = plt.subplots(4, 2, sharex=True, figsize=(12.0, 8.0))
    title = " ".join(f"examples/data/tiago/file{k}.csv" for k in range(words))
    finish_panels(figure, axes.ravel(), 8, 2, title)
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    box = figure._suptitle.get_window_extent(renderer)
    assert 0.0 <= box.x0 and box.x1 <= figure.bbox.width
    assert box.y1 <= figure.bbox.height
    top = max(axis.get_tightbbox(renderer).y1 for axis in axes.ravel())
    assert top <= box.y0
    shown = figure._suptitle.get_text()
    if words < 90:
        assert shown.replace("\n", " ") == title
    else:  # at most 4 lines, the rest cut
        assert shown.count("\n") == 3 and shown.endswith(" ...")
    plt.close(figure)
