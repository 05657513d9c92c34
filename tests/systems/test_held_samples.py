"""``HeldSamples``: a log played back as Drake's zero-order hold, in bounded memory."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_dynid import log_store
from drake_dynid.log_store import RowSink
from drake_dynid.systems import held_samples
from drake_dynid.systems.held_samples import HeldSamples, held_index

H = 1e-3


def _output(system, t):
    context = system.CreateDefaultContext()
    context.SetTime(t)
    return system.get_output_port(0).Eval(context)


def test_it_holds_each_row_as_the_zero_order_hold_does(monkeypatch):
    monkeypatch.setattr(held_samples, "BLOCK_ROWS", 7)  # many cache refills
    rng = np.random.default_rng(0)
    q, tau = rng.standard_normal((50, 2)), rng.standard_normal((50, 3))
    values = np.hstack([q, tau]).T
    reference = TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(
            H * (np.arange(51) - 0.5), np.hstack([values, values[:, -1:]])
        )
    )
    held = HeldSamples([q, tau], H)
    k = np.arange(-3, 55)
    # Sample times and the solves' (+3h/4) and others away from the boundaries,
    # out of order: the read cache must not matter.
    times = np.concatenate([k * H, k * H + 0.75 * H, 0.25 * H + k * H])
    for t in rng.permutation(times):
        np.testing.assert_array_equal(_output(held, t), _output(reference, t))
    # At a boundary t_k + h/2 (the bank's times) the later sample, whatever the
    # rounding of the sum (the zero-order hold's depended on it from k = 500).
    for j in (9, 499, 500, 12345, 3_599_999):
        assert held_index(j * H + 0.5 * H, 0.0, H, 4_000_000) == j + 1
        assert held_index((j + 0.5) * H, 0.0, H, 4_000_000) == j + 1
    assert held_index(-1.0, 0.0, H, 50) == 0 and held_index(1.0, 0.0, H, 50) == 49
    assert held_index(np.inf, 0.0, H, 50) == 49 and held_index(-np.inf, 0.0, H, 50) == 0
    with pytest.raises(ValueError, match="must be a number"):
        held_index(np.nan, 0.0, H, 50)


def test_a_stored_log_is_read_a_block_at_a_time(monkeypatch):
    monkeypatch.setattr(log_store, "BUFFER_BYTES", 256)
    rng = np.random.default_rng(1)
    rows = rng.standard_normal((9000, 4))
    sink = RowSink(4, limit=0)
    for a in range(0, 9000, 1000):
        sink.append(rows[a : a + 1000])
    stored = sink.finish()
    assert isinstance(stored, log_store.StoredArray)
    held = HeldSamples([stored], H, start_time=2.0)
    for k in (0, 4095, 4096, 8999, 17, 6000):
        np.testing.assert_array_equal(_output(held, 2.0 + k * H), rows[k])
    assert held._cache[1].shape[0] <= held_samples.BLOCK_ROWS  # one block in memory


@pytest.mark.parametrize(
    "tables,step,message",
    [
        ([], H, "at least one"),
        ([np.zeros((4, 2)), np.zeros((5, 2))], H, "same N"),
        ([np.zeros(4)], H, r"\(N, m_i\)"),
        ([np.zeros((0, 2))], H, "at least one row"),
        ([np.zeros((4, 2))], 0.0, "time_step"),
    ],
)
def test_bad_tables_are_refused(tables, step, message):
    with pytest.raises(ValueError, match=message):
        HeldSamples(tables, step)


def test_one_table_not_in_a_list_is_named():
    """Found by a review: ``HeldSamples(table, h)`` took the table's rows for
    tables ("tables must be (N, m_i) with the same N; got [(2,), (2,), (2,)]")."""
    with pytest.raises(TypeError, match=r"got one \(3, 2\) array: pass \[table\]"):
        HeldSamples(np.zeros((3, 2)), H)
    assert HeldSamples(np.zeros((1, 3, 2)), H).get_output_port_y().size() == 2


def test_after_end_nan_says_the_recording_has_ended():
    rows = np.arange(8.0).reshape(4, 2)
    h = 1e-3
    system = HeldSamples([rows], h, after_end="nan")
    context = system.CreateDefaultContext()

    def y(t):
        context.SetTime(t)
        return system.get_output_port_y().Eval(context)

    np.testing.assert_array_equal(y(3 * h), rows[3])
    np.testing.assert_array_equal(y(3.49 * h), rows[3])
    assert np.isnan(y(3.5 * h)).all() and np.isnan(y(10.0)).all()
    held = HeldSamples([rows], h)  # "hold": a trajectory stays where it ends
    hold_context = held.CreateDefaultContext()
    hold_context.SetTime(10.0)
    np.testing.assert_array_equal(held.get_output_port_y().Eval(hold_context), rows[3])
    with pytest.raises(ValueError, match="after_end must be 'hold' or 'nan'"):
        HeldSamples([rows], h, after_end="zero")


@pytest.mark.parametrize(
    "table", [np.array([["a", "b"]] * 3), np.ones((3, 2)) * (1 + 2j)]
)
def test_tables_that_are_not_real_numbers_are_refused_when_built(table):
    """Found by a review: a table of strings built and failed at the first
    Eval, inside a Simulator; complex values played their real part silently."""
    with pytest.raises(TypeError, match=r"tables\[1\] must hold real numbers"):
        HeldSamples([np.zeros((3, 1)), table], H)
    held = HeldSamples([np.zeros((3, 1), dtype=int), np.ones((3, 1), dtype=bool)], H)
    np.testing.assert_array_equal(_output(held, 0.0), [0.0, 1.0])
