"""core.raw_rows: the raw rows of one bank step, single and batch forms, settings."""

import dataclasses

import numpy as np
import pytest

from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.core.raw_rows import (
    raw_channels,
    raw_channels_batch,
    raw_rows_design,
    raw_signals,
)
from drake_dynid.core.rows import pack_rows

H = 1e-3


def test_central_velocity_is_exact_for_quartics_and_delays_by_m():
    """Exact to the product integration's O((h/window)²); a one-sample shift of the
    delay would be off by |q̈|·h ≈ 1e-3."""
    design = raw_rows_design(0.02, H, block=5)  # m = 10 samples
    assert design.delay_samples == 10 and design.history == 25
    assert design.velocity.delay == pytest.approx(0.01, abs=1e-15)
    assert design.delay == pytest.approx((10 + 2) * H)
    t = H * np.arange(40)
    coefficients = np.random.default_rng(2).normal(size=(2, 5))  # degree 4
    q = np.stack([np.polyval(c, t) for c in coefficients], axis=1)
    q_dot = np.stack([np.polyval(np.polyder(c), t) for c in coefficients], axis=1)
    tau = np.sin(3 * t)[:, None] * np.ones(2)
    q_d, v, tau_d = raw_signals(design, np.hstack([q, tau]))
    newest = np.arange(35, 40)
    np.testing.assert_allclose(q_d, q[newest - 10], rtol=0, atol=0)
    np.testing.assert_allclose(tau_d, tau[newest - 10], rtol=0, atol=0)
    np.testing.assert_allclose(v, q_dot[newest - 10], rtol=0, atol=1e-6)


def test_channels_are_the_mean_rows_and_the_batch_form_agrees():
    rows = Planar2RRows(L1=0.8, friction=("viscous", "coulomb", "offset"))
    design = raw_rows_design(0.01, H, block=4)
    rng = np.random.default_rng(3)
    q = np.cumsum(rng.normal(scale=1e-3, size=(60, 2)), axis=0)
    tau = rng.normal(size=(60, 2))
    history = np.hstack([q, tau])
    for kind in ("lagrangian", "power"):
        expected = pack_rows(
            *rows.model_rows(kind, *raw_signals(design, history[:40]))
        ).mean(axis=0)
        np.testing.assert_allclose(
            raw_channels(design, rows, kind, history[:40]), expected, rtol=1e-14
        )
        ends = np.array([13, 39, 59])
        batch = raw_channels_batch(design, rows, kind, q, tau, ends)
        for i, end in enumerate(ends):
            window = history[end - design.history + 1 : end + 1]
            np.testing.assert_allclose(
                batch[i], raw_channels(design, rows, kind, window), rtol=1e-12
            )
    # A non-finite sample poisons exactly the bank samples that read it.
    q_bad = q.copy()
    q_bad[30, 0] = np.nan
    batch = raw_channels_batch(design, rows, "lagrangian", q_bad, tau, [29, 33, 59])
    assert np.isfinite(batch[0]).all()  # reads samples up to 29
    assert np.isnan(batch[1]).all()  # its velocity window holds sample 30
    assert np.isfinite(batch[2]).all()  # reads samples 44..59 only


def test_designs_and_settings_reject_bad_windows():
    with pytest.raises(ValueError, match="even multiple"):
        raw_rows_design(0.003, H, block=2)
    with pytest.raises(ValueError, match="rows_from must be one of"):
        OnlineSettings(rows_from="smoothed")
    with pytest.raises(ValueError, match="raw_window must be > 0"):
        OnlineSettings(raw_window=0.0)
    settings = OnlineSettings(rows_from="raw", raw_window=0.0305).on_grid(H)
    assert settings.raw_window == pytest.approx(0.030)  # an even multiple of h
    assert settings.raw_design(H).block == 20
    too_long = dataclasses.replace(settings, raw_window=0.39)
    with pytest.raises(ValueError, match=r"raw_window \+ bank_time_step must be <="):
        too_long.on_grid(H)
    # The filtered rows do not read the ring: any raw window is accepted.
    dataclasses.replace(too_long, rows_from="filtered").on_grid(H)


def test_latency_follows_the_rows():
    filtered = OnlineSettings().on_grid(H)
    raw = dataclasses.replace(filtered, rows_from="raw")
    assert filtered.delay(H) == pytest.approx(filtered.jacobi_filters(H)[0].delay)
    assert raw.delay(H) == pytest.approx((100 + 9.5) * H)  # m = 100, D = 20


class _Stored:
    """A stored log's interface (shape, row slices); loading it whole fails."""

    def __init__(self, values):
        self.values = values
        self.shape = values.shape
        self.largest_read = 0

    def rows(self, start, stop):  # pragma: no cover - not used here
        raise AssertionError("no lazy view expected")

    def __getitem__(self, index):
        part = self.values[index]
        self.largest_read = max(self.largest_read, len(part))
        return part

    def __array__(self, dtype=None, copy=None):
        raise AssertionError("the whole log was loaded")


def test_batch_reads_only_the_rows_its_bank_samples_need():
    """A long (stored) log is read in part: the channels equal the array's."""
    design = raw_rows_design(0.02, H, block=5)
    rows = Planar2RRows()
    rng = np.random.default_rng(4)
    q, tau = rng.normal(size=(2, 5000, 2))
    ends = np.arange(3000, 3100, 5)
    stored_q, stored_tau = _Stored(q), _Stored(tau)
    for kind in ("lagrangian", "power"):
        np.testing.assert_array_equal(
            raw_channels_batch(design, rows, kind, stored_q, stored_tau, ends),
            raw_channels_batch(design, rows, kind, q, tau, ends),
        )
    assert stored_q.largest_read <= 100 + design.history + design.velocity.taps.size
