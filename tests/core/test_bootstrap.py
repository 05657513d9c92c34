"""core.bootstrap: σ of a window's estimate by parametric bootstrap.

Independent data: the paper's 2R trajectory with Drake's inverse dynamics
(tests/_drake_dynamics.py), white noise of known levels; the replay's estimate and
the Monte-Carlo spread over noise draws are the references.
"""

import dataclasses

import numpy as np
import pytest
from _drake_dynamics import H, exact_paper_2r

from drake_dynid.core.bootstrap import bootstrap_std, window_start
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core, window_estimate
from drake_dynid.logs import RobotLog
from drake_dynid.plants import RobotModel, model_path

NOISE = (np.array([2e-3, 2e-3]), np.array([0.2, 0.05]))  # σ_q [rad], σ_τ [N·m]


@pytest.fixture(scope="module")
def case():
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    t, q, tau = exact_paper_2r(robot, 8001)
    rng = np.random.default_rng(3)
    noisy_q = q + NOISE[0] * rng.standard_normal(q.shape)
    noisy_tau = tau + NOISE[1] * rng.standard_normal(tau.shape)
    settings = OnlineSettings(window=5.0, rows_from="filtered", bandwidth=1.0)
    settings = settings.on_grid(H)
    log = RobotLog(t, noisy_q, noisy_tau, robot.joint_names, H)
    (trace,) = replay_log_core(log, robot.rows_provider(), [settings])
    return robot, settings, q, tau, log, trace


def _final_end(settings, trace):
    """The newest bank sample of the solve logged last (the CLI's rule)."""
    last = int(np.flatnonzero(trace.valid > 0.5)[-1])
    sample = (last - 1) * settings.solve_decimation(H)
    return last, sample - sample % settings.decimation(H)


def test_the_nominal_window_is_the_replays_estimate_and_the_draws_reproducible(case):
    robot, settings, _, _, log, trace = case
    last, end = _final_end(settings, trace)
    rows = robot.rows_provider()
    result = bootstrap_std(rows, settings, log.q, log.tau, end, H, NOISE, replicates=4)
    np.testing.assert_allclose(result.nominal, trace.theta[last], rtol=1e-9)
    assert result.replicates == 4 and np.all(result.std > 0.0)
    again = bootstrap_std(rows, settings, log.q, log.tau, end, H, NOISE, replicates=4)
    np.testing.assert_array_equal(again.std, result.std)
    # No added noise: every replicate is the nominal window.
    zero = (np.zeros(2), np.zeros(2))
    quiet = bootstrap_std(rows, settings, log.q, log.tau, end, H, zero, replicates=3)
    np.testing.assert_array_equal(quiet.std, np.zeros(robot.num_parameters))
    # The window reads no sample before window_start.
    start = window_start(settings.for_robot(H, 2, 8), H, end)
    assert 0 < start < end - round(settings.window / H)
    shifted = log.q.copy()
    shifted[:start] += 1.0
    moved = bootstrap_std(rows, settings, shifted, log.tau, end, H, zero, replicates=2)
    np.testing.assert_array_equal(moved.nominal, quiet.nominal)


def test_the_bootstrap_follows_the_monte_carlo_spread(case):
    """σ_B of one noisy log against the spread over 24 noise draws: their median
    ratio over the parameters within 0.7-1.3, each within 0.4-2.5 (σ_B varies with
    the realisation it perturbs: 0.5-1.4 on ZZ1R over 8 realisations, median 0.9;
    the sample std of 16 draws alone is within ±18 % at 1σ)."""
    robot, settings, q, tau, log, trace = case
    _, end = _final_end(settings, trace)
    rows = robot.rows_provider()
    rng = np.random.default_rng(11)
    estimates = []
    for _ in range(24):
        qk = q + NOISE[0] * rng.standard_normal(q.shape)
        tauk = tau + NOISE[1] * rng.standard_normal(tau.shape)
        estimates.append(window_estimate(rows, settings, qk, tauk, end, H).theta)
    spread = np.std(estimates, axis=0, ddof=1)
    result = bootstrap_std(rows, settings, log.q, log.tau, end, H, NOISE)
    ratio = result.std / spread
    assert 0.7 < np.median(ratio) < 1.3, ratio
    assert np.all((ratio > 0.4) & (ratio < 2.5)), ratio


def test_bad_arguments_are_named(case):
    robot, settings, _, _, log, _ = case
    rows = robot.rows_provider()
    args = (rows, settings, log.q, log.tau, 6000, H)
    for replicates in (1, 2.5, True):
        with pytest.raises(ValueError, match="replicates must be an integer >= 2"):
            bootstrap_std(*args, NOISE, replicates=replicates)
    with pytest.raises(ValueError, match="noise std must be >= 0"):
        bootstrap_std(*args, (-NOISE[0], NOISE[1]))
    with pytest.raises(ValueError, match="position std"):
        bootstrap_std(*args, (np.ones(3), NOISE[1]))
    with pytest.raises(ValueError, match="end must be a sample of the log"):
        bootstrap_std(rows, settings, log.q, log.tau, 10**6, H, NOISE)
    # A window that is not full yet (its oldest bank sample without the filter's
    # history, or before the log): named, never an estimate of a partial window.
    for end in (1000, 4000, 4990):
        with pytest.raises(ValueError, match=f"window ending at sample {end} is not"):
            bootstrap_std(rows, settings, log.q, log.tau, end, H, NOISE)


def test_linearized_replicates_follow_the_exact_re_solves(case):
    """Raw rows: the replicates' first-order rows (core.raw_rows.linearized_channels)
    give the exact re-solves' σ_B within 1 % per parameter (the same draws); the
    nominal is the same window; without ``lagrangian_friction_rows`` or with
    ``linearized=False`` every replicate is solved again from its signals."""
    robot, settings, _, _, log, trace = case
    raw = dataclasses.replace(settings, rows_from="raw")
    _, end = _final_end(settings, trace)
    rows = robot.rows_provider()
    args = (rows, raw, log.q, log.tau, end, H, NOISE)
    fast = bootstrap_std(*args, replicates=8)
    exact = bootstrap_std(*args, replicates=8, linearized=False)
    assert (fast.method, exact.method) == ("linearized", "exact")
    np.testing.assert_allclose(fast.nominal, exact.nominal, rtol=1e-12)
    np.testing.assert_allclose(fast.std, exact.std, rtol=0.01)

    class Plain:  # the row contract only: no friction part apart
        names, num_joints = rows.names, rows.num_joints
        num_parameters = rows.num_parameters
        model_rows = staticmethod(rows.model_rows)

    plain = bootstrap_std(Plain(), *args[1:], replicates=8)
    assert plain.method == "exact"
    np.testing.assert_allclose(plain.std, exact.std, rtol=1e-9)
    # Filtered rows are solved exactly (their rows are at the bank samples only).
    assert bootstrap_std(rows, settings, *args[2:], replicates=2).method == "exact"
