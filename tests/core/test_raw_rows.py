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


def _smooth_log(count: int, seed: int):
    """A 2R motion whose joint 1 velocity crosses zero slowly, and its torques."""
    t = H * np.arange(count)
    rng = np.random.default_rng(seed)
    q = np.stack([0.3 * np.sin(2.1 * t + 0.4), 0.8 * np.cos(1.3 * t)], axis=1)
    q += 0.05 * np.sin(np.outer(t, rng.uniform(3.0, 5.0, 2)))
    tau = np.stack([np.cos(1.7 * t), np.sin(0.9 * t)], axis=1)
    return q, tau


def test_linearized_channels_follow_the_perturbed_rows():
    """The first-order channels against the exact raw rows of q + δq, τ + δτ.

    No perturbation: the exact channels. White noise: the smooth part within 1 %
    of the exact change of the channels, G's friction part (Coulomb sign flips
    where v' crosses zero) and y exact to round-off."""
    from drake_dynid.core.raw_rows import linearized_channels, raw_linearization

    rows = Planar2RRows(L1=0.8, friction=("viscous", "coulomb", "offset"))
    design = raw_rows_design(0.04, H, block=10)
    q, tau = _smooth_log(4000, 1)
    ends = np.arange(100, 4000, 10)
    lin = raw_linearization(design, rows, "lagrangian", q, tau, ends)
    assert lin is not None
    exact = raw_channels_batch(design, rows, "lagrangian", q, tau, ends)
    np.testing.assert_array_equal(lin.channels, exact)
    zero = np.zeros_like(q)
    np.testing.assert_allclose(
        linearized_channels(lin, design, rows, "lagrangian", zero, zero, ends),
        exact,
        rtol=0,
        atol=1e-14,
    )
    rng = np.random.default_rng(5)
    dq, dtau = 1e-4 * rng.standard_normal(q.shape), 0.1 * rng.standard_normal(q.shape)
    moved = linearized_channels(lin, design, rows, "lagrangian", dq, dtau, ends)
    truth = raw_channels_batch(design, rows, "lagrangian", q + dq, tau + dtau, ends)
    p = rows.num_parameters
    friction = lin.positions
    assert friction.size == 2 * 2 * 3  # 2 joint rows x 6 friction columns
    np.testing.assert_allclose(moved[:, friction], truth[:, friction], atol=1e-12)
    np.testing.assert_allclose(moved[:, 4 * p :], truth[:, 4 * p :], atol=1e-12)
    flips = np.abs(truth[:, friction] - exact[:, friction]).max()
    assert flips > 0.05  # the Coulomb sign does flip: a real test of that part
    smooth = np.setdiff1d(np.arange(4 * p), friction)
    change = truth[:, smooth] - exact[:, smooth]
    error = moved[:, smooth] - truth[:, smooth]
    assert np.linalg.norm(error) < 0.01 * np.linalg.norm(change)


def test_linearization_needs_the_friction_part_apart():
    """Power model, a provider without ``lagrangian_friction_rows``, or a
    non-finite sample: None (the caller solves the perturbed rows exactly)."""
    from drake_dynid.core.raw_rows import raw_linearization

    rows = Planar2RRows()
    design = raw_rows_design(0.04, H, block=10)
    q, tau = _smooth_log(1000, 2)
    ends = np.arange(100, 1000, 10)
    assert raw_linearization(design, rows, "power", q, tau, ends) is None

    class Plain:  # the row contract only
        names, num_joints, num_parameters = rows.names, 2, rows.num_parameters
        model_rows = staticmethod(rows.model_rows)

    assert raw_linearization(design, Plain(), "lagrangian", q, tau, ends) is None
    bad = q.copy()
    bad[500, 1] = np.nan
    assert raw_linearization(design, rows, "lagrangian", bad, tau, ends) is None
    assert raw_linearization(design, rows, "lagrangian", q, tau, ends) is not None
