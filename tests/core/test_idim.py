"""Off-line IDIM: zero-phase derivatives, parallel decimation, IDIM-LS/WLS."""

import numpy as np
import pytest

from drake_dynid.core.idim import (
    ReducedRows,
    default_trim,
    idim_least_squares,
    idim_solve,
    joint_noise_std,
    offline_derivatives,
    parallel_decimation,
    reduce_rows,
)
from drake_dynid.core.noise import add_noise

H = 1e-3


def _signal(t):
    w1, w2 = 2 * np.pi * 0.5, 2 * np.pi * 1.3
    q = np.stack([np.sin(w1 * t), 0.3 * np.sin(w2 * t) + 0.2 * np.cos(w1 * t)], 1)
    v = np.stack(
        [w1 * np.cos(w1 * t), 0.3 * w2 * np.cos(w2 * t) - 0.2 * w1 * np.sin(w1 * t)], 1
    )
    a = np.stack(
        [
            -(w1**2) * np.sin(w1 * t),
            -0.3 * w2**2 * np.sin(w2 * t) - 0.2 * w1**2 * np.cos(w1 * t),
        ],
        1,
    )
    return q, v, a


def test_offline_derivatives_match_the_analytic_derivatives_away_from_the_edges():
    t = np.arange(6000) * H
    q, v, a = _signal(t)
    trim = default_trim(H, 10.0)
    assert trim == 201
    q_f, v_f, a_f = offline_derivatives(q, H, cutoff_hz=10.0)
    keep = slice(trim, len(t) - trim)
    assert q_f.shape == v_f.shape == a_f.shape == (len(t) - 2 * trim, 2)
    # Amplitudes: q ≈ 1 rad, v ≈ 3 rad/s, v̇ ≈ 20 rad/s². Two cutoff periods from
    # the ends the edge transient is below 0.3 % of the amplitude; four periods
    # in, the filter's pass-band error only.
    np.testing.assert_allclose(q_f, q[keep], atol=1e-4)
    np.testing.assert_allclose(v_f, v[keep], atol=1.5e-3)
    np.testing.assert_allclose(a_f, a[keep], atol=6e-2)
    inner = slice(2 * trim, len(t) - 2 * trim)
    np.testing.assert_allclose(v_f[trim:-trim], v[inner], atol=3e-4)
    np.testing.assert_allclose(a_f[trim:-trim], a[inner], atol=1e-2)
    # 1-D input and an explicit trim.
    q1, v1, _ = offline_derivatives(q[:, 0], H, cutoff_hz=10.0, trim=1)
    assert q1.shape == (len(t) - 2,)
    np.testing.assert_allclose(
        v1[trim - 1 : -(trim - 1)], v_f[:, 0], rtol=0, atol=1e-12
    )


def test_offline_derivatives_reject_noise():
    rng = np.random.default_rng(21)  # seed 21
    t = np.arange(8000) * H
    q, v, a = _signal(t)
    noisy = add_noise(q, 40.0, rng)
    _, v_f, a_f = offline_derivatives(noisy, H, cutoff_hz=5.0)
    trim = default_trim(H, 5.0)
    keep = slice(trim, len(t) - trim)
    # Raw central differences of the noisy q would have errors ~ σ/h ≈ 5 rad/s.
    assert np.sqrt(np.mean((v_f - v[keep]) ** 2)) < 0.05
    assert np.sqrt(np.mean((a_f - a[keep]) ** 2)) < 1.0


def test_parallel_decimation_keeps_the_linear_relation():
    rng = np.random.default_rng(22)  # seed 22
    t = np.arange(3001) * H
    _, v, a = _signal(t)
    clean = np.stack([a, v, np.sin(3 * t)[:, None] * np.ones(2)], axis=-1)  # (N, 2, 3)
    W = clean + 0.01 * rng.standard_normal(clean.shape)  # broadband content
    X = np.array([2.0, -0.5, 0.3])
    tau = W @ X
    W_d, tau_d = parallel_decimation(W, tau, 10)
    assert W_d.shape == (301, 2, 3) and tau_d.shape == (301, 2)
    np.testing.assert_allclose(tau_d, W_d @ X, atol=1e-10)
    # The noise above the low-pass (0.025 cycles/sample by default) is filtered
    # out before down-sampling: about sqrt(2·0.025) ≈ 0.22 of the white noise std
    # remains.
    clean_d, _ = parallel_decimation(clean, tau, 10)
    assert np.std(W_d - clean_d) < 0.3 * 0.01
    # An explicit cutoff: the noise std scales like sqrt(2·cutoff).
    W_c, tau_c = parallel_decimation(W, tau, 10, cutoff=0.01)
    np.testing.assert_allclose(tau_c, W_c @ X, atol=1e-10)
    clean_c, _ = parallel_decimation(clean, tau, 10, cutoff=0.01)
    assert np.std(W_c - clean_c) < 0.75 * np.std(W_d - clean_d)
    W1, _ = parallel_decimation(W, tau, 1)
    np.testing.assert_array_equal(W1, W)
    assert W1 is not W
    W2, tau2 = parallel_decimation(W[:, 0, :], tau[:, 0], 5)
    assert W2.shape == (601, 3) and tau2.shape == (601,)


def _two_joint_problem(seed, samples=2000, sigma=(0.01, 1.0)):
    # Joint 2 does not see parameters 0 and 1 (like the 2R arm's IDIM rows).
    rng = np.random.default_rng(seed)
    W = rng.standard_normal((samples, 2, 4)) * [3.0, 1.0, 0.5, 2.0]
    W[:, 1, :2] = 0.0
    X = np.array([3.9, 0.3, 0.25, 0.15])
    tau = W @ X + np.asarray(sigma) * rng.standard_normal((samples, 2))
    return W, X, tau


def test_joint_noise_std_recovers_each_joint_noise():
    W, _, tau = _two_joint_problem(seed=23)  # seed 23
    np.testing.assert_allclose(joint_noise_std(W, tau), [0.01, 1.0], rtol=0.06)


def test_idim_ls_and_wls_recover_the_parameters():
    W, X, tau = _two_joint_problem(seed=24)  # seed 24
    names = ("ZZ1R", "FV1", "ZZ2", "FV2")
    ordinary = idim_least_squares(W, tau, names=names)
    weighted = idim_least_squares(W, tau, weighted=True, names=names)
    for result in (ordinary, weighted):
        assert result.valid and result.names == names
        assert result.num_rows == 4000
        assert np.all(np.abs(result.theta - X) < 4 * result.std)
    # The precise joint 1 dominates the weighted fit: much smaller σ.
    assert np.all(weighted.std < ordinary.std)
    assert weighted.std[0] < ordinary.std[0] / 10
    assert weighted.residual_std == pytest.approx(1.0, abs=0.1)
    # Row order: sample-major, joint-minor, same as reshaping W and τ.
    flat = idim_least_squares(W.reshape(-1, 4), tau.reshape(-1), names=names)
    np.testing.assert_allclose(flat.theta, ordinary.theta, rtol=1e-12)


def test_idim_wls_on_exact_data_and_unexcited_parameter():
    W, X, _ = _two_joint_problem(seed=25)
    result = idim_least_squares(W, W @ X, weighted=True)
    np.testing.assert_allclose(result.theta, X, rtol=1e-9)
    W[:, :, 3] = 0.0
    result = idim_least_squares(W, W @ X, weighted=True, names=list("abcd"))
    assert not result.valid and result.unidentified == ("d",)


def test_rows_reduced_a_block_at_a_time_give_the_same_solve():
    # Seed 27; joint 2 does not see parameters 0 and 1: its own least squares
    # has rank 2, the reduction keeps that (the oracle: lstsq on W_j itself).
    W, _, tau = _two_joint_problem(seed=27, samples=3000)
    reduced = None
    for start in range(0, 3000, 700):  # 5 blocks, the last one short
        reduced = reduce_rows(W[start : start + 700], tau[start : start + 700], reduced)
    assert reduced.num_samples == 3000 and reduced.R.shape == (2, 5, 5)
    whole = reduce_rows(W, tau)
    for weighted in (False, True):
        blocks = idim_solve(reduced, weighted=weighted)
        direct = idim_least_squares(W, tau, weighted=weighted)
        assert blocks.valid and blocks.num_rows == direct.num_rows == 6000
        np.testing.assert_allclose(blocks.theta, direct.theta, rtol=1e-10)
        np.testing.assert_allclose(blocks.std, direct.std, rtol=1e-10)
        assert blocks.condition_number == pytest.approx(direct.condition_number)
        assert blocks.residual_std == pytest.approx(direct.residual_std, rel=1e-10)
        np.testing.assert_allclose(
            idim_solve(whole, weighted=weighted).theta, direct.theta, rtol=1e-10
        )
    oracle = []
    for j in range(2):
        fit, _, rank, _ = np.linalg.lstsq(W[:, j], tau[:, j], rcond=None)
        residual = tau[:, j] - W[:, j] @ fit
        oracle.append(np.sqrt(residual @ residual / (3000 - rank)))
    np.testing.assert_allclose(joint_noise_std(W, tau), oracle, rtol=1e-9)
    # Values near 1e155 (squares beyond the largest float): the same weighted fit.
    huge = idim_least_squares(W * 1e155, tau * 1e155, weighted=True)
    plain = idim_least_squares(W, tau, weighted=True)
    assert huge.valid
    np.testing.assert_allclose(huge.theta, plain.theta, rtol=1e-9)
    np.testing.assert_allclose(
        joint_noise_std(W * 1e155, tau * 1e155), np.multiply(oracle, 1e155)
    )
    # Fewer samples than p + 1: zero rows below; no sample at all: too few rows.
    few = reduce_rows(W[:3], tau[:3])
    np.testing.assert_array_equal(few.R[:, 3:], 0.0)
    empty = ReducedRows(R=np.zeros((2, 5, 5)), num_samples=0)
    result = idim_solve(empty)
    assert not result.valid and "0 rows" in result.reason
    with pytest.raises(ValueError, match="previous must reduce 2 joints and 3"):
        reduce_rows(W[:, :, :3], tau, reduced)


def test_one_joint_pipeline_from_noisy_positions():
    # ZZ q̈ + Fv q̇ + Fc sign(q̇) = τ; q and τ noisy at 40 dB (seed 26).
    rng = np.random.default_rng(26)
    t = np.arange(20000) * H
    q, v, a = _signal(t)
    q, v, a = q[:, 0], v[:, 0], a[:, 0]
    tau = 3.0 * a + 0.4 * v + 0.5 * np.sign(v)
    q_n, tau_n = add_noise(q, 40.0, rng), add_noise(tau, 40.0, rng)
    trim = default_trim(H, 5.0)
    _, v_f, a_f = offline_derivatives(q_n, H, cutoff_hz=5.0, trim=trim)
    W = np.stack([a_f, v_f, np.sign(v_f)], axis=-1)
    W_d, tau_d = parallel_decimation(W, tau_n[trim:-trim], 10)
    result = idim_least_squares(W_d, tau_d, names=("ZZ", "FV", "FC"))
    assert result.valid
    np.testing.assert_allclose(result.theta, [3.0, 0.4, 0.5], rtol=0.05)


def test_validation():
    with pytest.raises(
        ValueError, match=r"cutoff_hz must be < the Nyquist frequency 500"
    ):
        offline_derivatives(np.zeros(100), H, cutoff_hz=600.0)
    with pytest.raises(ValueError, match="q must have at least 403 samples"):
        offline_derivatives(np.zeros(100), H, cutoff_hz=10.0)
    with pytest.raises(ValueError, match="trim must be >= 1"):
        offline_derivatives(np.zeros(100), H, cutoff_hz=10.0, trim=0)
    with pytest.raises(ValueError, match="q must have shape"):
        offline_derivatives(np.zeros((100, 2, 2)), H, cutoff_hz=10.0, trim=1)
    with pytest.raises(ValueError, match="q must be finite"):
        offline_derivatives(np.full(100, np.nan), H, cutoff_hz=10.0, trim=1)
    with pytest.raises(ValueError, match="factor must be >= 1"):
        parallel_decimation(np.zeros((50, 2, 3)), np.zeros((50, 2)), 0)
    with pytest.raises(ValueError, match="W must have shape"):
        parallel_decimation(np.zeros((50, 2, 3)), np.zeros((50, 3)), 2)
    with pytest.raises(ValueError, match="W must have at least one sample"):
        parallel_decimation(np.zeros((0, 2, 3)), np.zeros((0, 2)), 2)
    with pytest.raises(ValueError, match=r"cutoff must be < 0\.5 cycles/sample"):
        parallel_decimation(np.zeros((50, 2, 3)), np.zeros((50, 2)), 2, cutoff=0.5)
    with pytest.raises(ValueError, match="padding must be >= 0"):
        parallel_decimation(np.zeros((50, 2, 3)), np.zeros((50, 2)), 2, padding=-1)
    with pytest.raises(ValueError, match="padding must be >= 0"):
        offline_derivatives(np.zeros(100), H, cutoff_hz=10.0, trim=1, padding=-1)
    with pytest.raises(ValueError, match="W must have shape"):
        idim_least_squares(np.zeros((50, 2, 3)), np.zeros((50, 3)))


@pytest.mark.parametrize("order", [2, 4, 8])
def test_the_noise_bandwidth_of_the_zero_phase_filter(order):
    # The closed form against quadrature of |H|^4 = (1 + x^(2N))^-2, and against
    # the filter itself: white noise through the zero-phase sosfiltfilt keeps the
    # share B_n/(fs/2) of its variance (seeded, 2^18 samples).
    import math

    from scipy import integrate, signal

    from drake_dynid.core.idim_auto import decimated_noise_factor, noise_bandwidth

    area = integrate.quad(lambda x: (1.0 + x ** (2 * order)) ** -2, 0.0, math.inf)
    assert noise_bandwidth(order) == pytest.approx(area[0], rel=1e-9)
    fs, cutoff = 1000.0, 20.0
    sos = signal.butter(order, cutoff / (fs / 2), output="sos")
    noise = np.random.default_rng(4).standard_normal(1 << 18)
    kept = signal.sosfiltfilt(sos, noise).var() / noise.var()
    assert kept == pytest.approx(noise_bandwidth(order) * cutoff / (fs / 2), rel=0.03)
    # The factor: sqrt(f_r / (2 B_n)), and 1 for rows no denser than 2 B_n.
    factor = decimated_noise_factor(1e-3, 10, cutoff)
    assert factor == pytest.approx(math.sqrt(100.0 / (2 * 0.9435511 * cutoff)))
    assert decimated_noise_factor(1e-3, 30, cutoff) == 1.0
