"""core.identifier: the sliding identifier's step (hold, status, estimate)."""

import numpy as np
import pytest

from drake_dynid.core.identifier import Status, identifier_init, identifier_update
from drake_dynid.core.lsq import solve_least_squares


def test_status_values_are_the_published_codes():
    assert [int(s) for s in Status] == [0, 1, 2]
    assert Status.OK == 0 and Status.WINDOW_NOT_READY == 1
    assert Status.NOT_IDENTIFIABLE == 2


def test_hold_estimate_and_report():
    rng = np.random.default_rng(12)
    a = rng.normal(size=(40, 3))
    b = a @ np.array([1.0, -2.0, 0.5]) + 0.01 * rng.normal(size=40)
    start = identifier_init(3, initial_theta=[1.0, 1.0, 1.0])
    assert start.status is Status.WINDOW_NOT_READY and not start.valid
    np.testing.assert_array_equal(start.theta, 1.0)
    assert np.all(np.isinf(start.std)) and start.condition_number == np.inf
    # Not ready: A and B are not read.
    waiting = identifier_update(start, False, None, None)
    np.testing.assert_array_equal(waiting.theta, start.theta)
    solved = identifier_update(waiting, True, a, b, names=("a", "b", "c"))
    core = solve_least_squares(a, b)
    np.testing.assert_array_equal(solved.theta, core.theta)
    assert solved.valid and solved.status is Status.OK
    assert solved.condition_number == core.condition_number
    # Rank deficient: hold the estimate, flag column c, keep the status apart.
    deficient = a.copy()
    deficient[:, 2] = 0.0
    held = identifier_update(solved, True, deficient, b)
    np.testing.assert_array_equal(held.theta, solved.theta)
    np.testing.assert_array_equal(held.std, solved.std)
    assert not held.valid and held.status is Status.NOT_IDENTIFIABLE
    np.testing.assert_array_equal(held.unidentified, [0.0, 0.0, 1.0])
    # Not ready afterwards: the last solve's condition and flags are kept.
    again = identifier_update(held, False, None, None)
    assert again.status is Status.WINDOW_NOT_READY
    np.testing.assert_array_equal(again.unidentified, held.unidentified)
    assert again.condition_number == held.condition_number
    with pytest.raises(ValueError):
        held.theta[0] = 3.0  # read-only state


def test_init_checks_its_arguments():
    with pytest.raises(ValueError, match="num_parameters must be >= 1"):
        identifier_init(0)
    with pytest.raises(ValueError, match=r"initial_theta must have shape \(2\)"):
        identifier_init(2, [1.0])


@pytest.mark.parametrize("where", ["A", "B"])
def test_a_non_finite_window_is_a_window_holding_a_bad_sample(where):
    """Found by a review: NaN in A was NOT_IDENTIFIABLE, flagging parameter 0 as
    not excited, and inf in B flagged nothing; it is a bad sample (status 1)."""
    rng = np.random.default_rng(12)
    a = rng.normal(size=(40, 3))
    b = a @ np.array([1.0, -2.0, 0.5])
    solved = identifier_update(identifier_init(3), True, a, b)
    if where == "A":
        a[0, 0] = np.nan
    else:
        b[5] = np.inf
    held = identifier_update(solved, True, a, b)
    assert not held.valid and held.status is Status.WINDOW_NOT_READY
    np.testing.assert_array_equal(held.theta, solved.theta)
    np.testing.assert_array_equal(held.unidentified, solved.unidentified)
