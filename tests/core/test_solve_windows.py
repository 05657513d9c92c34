"""Stacked window solves: the same results as one solve_window per window.

Seeds are stated per test (np.random.default_rng(seed)).
"""

import numpy as np
import pytest

from drake_dynid.core.fourier_bank import fourier_bank
from drake_dynid.core.jackknife import jackknife_std
from drake_dynid.core.row_noise import (
    honest_std,
    noise_model_std,
    row_noise,
    stacked_honest_std,
)
from drake_dynid.core.weighted_lsq import solve_window, solve_windows

M = 3  # equations per sample
P = 6  # parameters


def _design():
    bank = fourier_bank(20.0, 0.02, order=1, ell=np.arange(12.0))
    noise = row_noise(bank, M)
    groups = bank.row_functions(M) // 2  # pairs of functions, as OnlineSettings
    return noise, groups


def _windows(noise, seed):
    """Windows whose A lies in the span of the functions (as modulated rows do),
    B with noise growing like ν; then the ones off the common path."""
    rng = np.random.default_rng(seed)
    r = noise.num_rows
    theta = np.linspace(1.0, 2.0, P)
    windows = []
    for _ in range(9):
        A = np.empty((r, P))
        for j in range(M):
            rows = noise.group == j
            A[rows] = noise.factor @ rng.standard_normal((noise.factor.shape[1], P))
        e = 0.05 * (1.0 + 0.2 * noise.frequency) * rng.standard_normal(r)
        windows.append((A, A @ theta + e))
    good_a, good_b = windows[0]
    nan_a = good_a.copy()
    nan_a[3, 2] = np.nan
    dependent = good_a.copy()
    dependent[:, 4] = 2.0 * dependent[:, 1]
    ill = good_a.copy()  # condition between the bound and 1e4, then above 1e4
    ill[:, 5] = ill[:, 0] + 3e-4 * ill[:, 5]
    worse = good_a.copy()
    worse[:, 5] = worse[:, 0] + 1e-6 * worse[:, 5]
    zero = good_a.copy()
    zero[:, 3] = 0.0
    for A in (nan_a, dependent, ill, worse, zero):
        windows.append((A, good_b))
    windows.append((good_a, np.zeros(r)))  # B = 0: θ = 0, zero residual
    order = rng.permutation(len(windows))
    return [windows[k] for k in order]


def _same(one, many):
    assert one.valid == many.valid
    assert one.reason == many.reason
    assert one.unidentified == many.unidentified
    assert one.rank == many.rank and one.num_rows == many.num_rows
    assert one.names == many.names
    # Round-off: the stacked QR and products sum in another order (cond ≤ 7e3 here).
    for name in (
        "theta",
        "std",
        "relative_std_percent",
        "condition_number",
        "residual_std",
    ):
        np.testing.assert_allclose(
            getattr(many, name), getattr(one, name), rtol=1e-8, atol=1e-300
        )


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("jackknife", [False, True])
def test_stacked_solves_equal_one_solve_per_window(weighted, jackknife):
    noise, groups = _design()
    windows = _windows(noise, seed=11)
    A = np.stack([a for a, _ in windows])
    B = np.stack([b for _, b in windows])
    solve = dict(
        weighting=(noise.frequency, noise.group) if weighted else None,
        noise=noise,
        jackknife=groups if jackknife else None,
        names=[f"c{i}" for i in range(P)],
    )
    many = solve_windows(A, B, **solve)
    assert len(many) == len(windows)
    for (a, b), result in zip(windows, many, strict=True):
        _same(solve_window(a, b, **solve), result)
    assert sum(result.valid for result in many) >= 9  # the common path was taken
    assert not all(result.valid for result in many)


def test_without_noise_or_with_too_few_rows_each_window_is_solved_alone():
    noise, _ = _design()
    windows = _windows(noise, seed=4)
    A = np.stack([a for a, _ in windows])
    B = np.stack([b for _, b in windows])
    for one, many in zip(
        [solve_window(a, b) for a, b in windows], solve_windows(A, B), strict=True
    ):
        _same(one, many)
    # 8 functions, one equation, 12 parameters: no honest σ in any window.
    bank = fourier_bank(2.0, 0.01, order=1, ell=np.arange(8.0))
    short = row_noise(bank, 1)
    rng = np.random.default_rng(2)
    A = rng.standard_normal((3, short.num_rows, 12))
    B = rng.standard_normal((3, short.num_rows))
    weighting = (short.frequency, short.group)
    results = solve_windows(A, B, weighting, noise=short)
    assert not any(result.valid for result in results)
    for a, b, result in zip(A, B, results, strict=True):
        _same(solve_window(a, b, weighting, noise=short), result)
    assert solve_windows(np.zeros((0, 5, 2)), np.zeros((0, 5)), noise=short) == []


def test_stacked_noise_model_and_sandwich_equal_the_single_ones():
    noise, _ = _design()
    rng = np.random.default_rng(5)
    (A, B), (A2, B2) = _windows(noise, seed=5)[:2]
    stack_a = np.stack([A, A2])
    if not (np.isfinite(stack_a).all()):
        pytest.skip("seed 5 puts an invalid window first")  # pragma: no cover
    residual = rng.standard_normal((2, noise.num_rows))
    both = noise_model_std(residual, noise.frequency, noise.group)
    for k in range(2):
        np.testing.assert_array_equal(
            both[k], noise_model_std(residual[k], noise.frequency, noise.group)
        )
    weights = np.exp(0.1 * rng.standard_normal((2, noise.num_rows)))
    theta = rng.standard_normal((2, P))
    factors = []
    for a, w in zip(stack_a, weights, strict=True):
        aw = a * w[:, None]
        norms = np.linalg.norm(aw, axis=0)
        factors.append((np.linalg.inv(np.linalg.qr(aw / norms, mode="r")), norms))
    std, residual_std, dof = stacked_honest_std(
        stack_a,
        np.stack([B, B2]),
        theta,
        weights,
        np.abs(residual) + 0.1,
        noise,
        np.stack([f[0] for f in factors]),
        np.stack([f[1] for f in factors]),
    )
    for k, (a, b) in enumerate(((A, B), (A2, B2))):
        one = honest_std(
            a,
            b,
            theta[k],
            weights[k],
            np.abs(residual[k]) + 0.1,
            noise,
            factor=factors[k],
        )
        np.testing.assert_allclose(std[k], one.std, rtol=1e-12)
        assert residual_std[k] == pytest.approx(one.residual_std, rel=1e-12)
        assert dof[k] == pytest.approx(one.dof, rel=1e-12)


def test_jackknife_is_nan_where_a_group_alone_determines_a_parameter():
    # Column 2 is non-zero in the rows of group 0 only: deleting group 0 leaves
    # it undetermined (the Cholesky test of the leverage fails, the eigenvalues
    # decide), whatever the other windows are.
    rng = np.random.default_rng(9)
    groups = np.repeat(np.arange(4), 6)
    A = rng.standard_normal((24, 3))
    A[6:, 2] = 0.0
    B = A @ np.array([1.0, 2.0, 3.0]) + 0.01 * rng.standard_normal(24)
    assert np.isnan(jackknife_std(A, B, groups)).all()
    full = rng.standard_normal((24, 3))
    assert np.isfinite(jackknife_std(full, B, groups)).all()


def test_a_singular_window_leaves_the_others_stacked_and_warns_nothing(monkeypatch):
    # One exactly singular R (a zero on its diagonal) and one nearly singular
    # (R⁻¹ ~ 1e170: its first-pass bound overflows, silently) among valid ones:
    # only those two are solved one by one (tests run with warnings as errors).
    from drake_dynid.core import weighted_lsq

    noise, groups = _design()
    valid = [
        (a, b)
        for a, b in _windows(noise, seed=11)
        if solve_window(a, b).condition_number < 100.0
    ][:6]
    A = np.stack([a for a, _ in valid])
    B = np.stack([b for _, b in valid])
    singular = np.zeros_like(A[0])
    singular[:P, :P] = np.eye(P)
    singular[:, P - 1] = singular[:, 0]
    near = singular.copy()
    near[P - 1, P - 1] = 1e-170
    A[1], A[4] = singular, near
    alone = []
    one = weighted_lsq.solve_window
    monkeypatch.setattr(
        weighted_lsq, "solve_window", lambda *a, **k: alone.append(1) or one(*a, **k)
    )
    for weighting in (None, (noise.frequency, noise.group)):
        alone.clear()
        many = weighted_lsq.solve_windows(
            A, B, weighting, noise=noise, jackknife=groups
        )
        assert len(alone) == 2
        assert [r.valid for r in many] == [True, False, True, True, False, True]
        for a, b, result in zip(A, B, many, strict=True):
            _same(one(a, b, weighting, noise=noise, jackknife=groups), result)


def test_stacked_arguments_are_checked_as_the_single_solve_checks_them():
    noise, groups = _design()
    A, B = (np.stack(x) for x in zip(*_windows(noise, seed=3)[:2], strict=True))
    with pytest.raises(ValueError, match=r"jackknife must have shape \(72,\)"):
        solve_windows(A, B, noise=noise, jackknife=groups[:36])
    with pytest.raises(ValueError, match="max_condition must be finite"):
        solve_windows(A, B, noise=noise, max_condition=np.inf)
    with pytest.raises(ValueError, match="names must have 6 entries"):
        solve_windows(A, B, noise=noise, names=["a"])
    with pytest.raises(ValueError, match=r"A must have shape \(K, rows, p\)"):
        solve_windows(A[0], B[0], noise=noise)
    assert noise_model_std(np.zeros(0), np.zeros(0), np.zeros(0, int)).shape == (0,)


def test_stacked_jackknife_equals_the_single_one_within_the_blend(monkeypatch):
    """Windows whose pair (ℓ = 0, 1) alone carries column 5 (as ℓ = 0 the gravity
    columns), the others seeing ε of it: bias-reduced, blended and plain
    deviations in one stacked call, one power per window (seed 12: 0.5, 0.5,
    0.91, 0.82, 1)."""
    from drake_dynid.core import jackknife

    powers, power = [], jackknife.deviation_power

    def recorded(mu, centre=jackknife.MIN_INFORMATION):
        powers.append(power(mu, centre))
        return powers[-1]

    monkeypatch.setattr(jackknife, "deviation_power", recorded)
    noise, groups = _design()
    rng = np.random.default_rng(12)
    theta = np.linspace(1.0, 2.0, P)
    windows = []
    for eps in (1e-5, 1e-3, 3e-3, 5e-3, 3e-2):
        A = np.empty((noise.num_rows, P))
        for j in range(M):
            rows = noise.group == j
            A[rows] = noise.factor @ rng.standard_normal((noise.factor.shape[1], P))
        A[:, 5] *= np.where(groups == 0, 1.0, eps)
        e = 0.05 * (1.0 + 0.2 * noise.frequency) * rng.standard_normal(len(A))
        windows.append((A, A @ theta + e))
    solve = dict(
        weighting=(noise.frequency, noise.group), noise=noise, jackknife=groups
    )
    many = solve_windows(
        np.stack([a for a, _ in windows]), np.stack([b for _, b in windows]), **solve
    )
    stacked = np.concatenate([np.ravel(p) for p in powers])
    assert np.any(stacked == 0.5) and np.any(stacked == 1.0)
    assert np.any((stacked > 0.55) & (stacked < 0.95))
    for (a, b), result in zip(windows, many, strict=True):
        _same(solve_window(a, b, **solve), result)
