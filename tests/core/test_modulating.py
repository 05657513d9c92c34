"""Fourier modulating bank: design, sliding == direct quadrature, model equations."""

import copy
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_dynid.core.modulating import (
    assemble_equations,
    default_frequencies,
    direct_fourier_integrals,
    fourier_bank,
    is_full,
    modulated_integrals,
    num_channels,
    pack_rows,
    paper_frequencies,
    sliding_fourier_integrals,
    sliding_init,
    sliding_push,
    sliding_push_many,
    sliding_resync,
    unpack_rows,
    window_valid,
)


def _g(bank, ell, s, derivative=0):
    """g_ℓ^(r)(s) from the closed form (1/T) e^{-jℓω0 s}(e^{-jω0 s} - 1)^k."""
    T, k, w0 = bank.window, bank.order, bank.omega0
    if derivative == 0:
        return np.exp(-1j * ell * w0 * s) * (np.exp(-1j * w0 * s) - 1) ** k / T
    # Derivatives of the closed form by the binomial expansion, term by term.
    out = 0
    for i in range(k + 1):
        c = math.comb(k, i) * (-1) ** (k - i) / T
        out = out + c * (-1j * (ell + i) * w0) ** derivative * np.exp(
            -1j * (ell + i) * w0 * s
        )
    return out


def _trapezoid(values, h):
    return h * (values.sum(axis=0) - 0.5 * values[0] - 0.5 * values[-1])


def _relative(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


# -- design -------------------------------------------------------------------------


def test_paper_set_gives_221_frequencies_for_order_1():
    bank = fourier_bank(20.0, 1e-3, order=1, ell=paper_frequencies())
    assert bank.num_functions == 201
    assert bank.num_frequencies == 221
    assert bank.num_samples == 20001
    np.testing.assert_allclose(bank.nu, np.round(0.05 * np.arange(221), 12))
    # Arrays of the design are read-only.
    with pytest.raises(ValueError):
        bank.nu[0] = 1.0


@pytest.mark.parametrize("order", [1, 2, 3])
def test_coefficients_reproduce_g_and_its_derivatives(order):
    ell = np.array([-1.5, -1.0, 0.0, 0.37, 2.0, 4.05])
    bank = fourier_bank(3.0, 0.01, order=order, ell=ell)
    s = np.linspace(0.0, bank.window, 301)
    basis = np.exp(-1j * np.multiply.outer(bank.nu, bank.omega0 * s))  # (K, S)
    g0 = bank.coefficient_matrix(0) @ basis * bank.window
    closed = np.stack([_g(bank, e, s) for e in ell]) * bank.window
    np.testing.assert_allclose(g0, closed, atol=1e-12)
    # The derivative coefficients match a finite difference of g^(r-1).
    ds = 1e-6
    for r in range(1, order + 1):
        gr = bank.coefficient_matrix(r) @ basis
        shifted = np.exp(-1j * np.multiply.outer(bank.nu, bank.omega0 * (s + ds)))
        back = np.exp(-1j * np.multiply.outer(bank.nu, bank.omega0 * (s - ds)))
        fd = bank.coefficient_matrix(r - 1) @ (shifted - back) / (2 * ds)
        np.testing.assert_allclose(gr, fd, rtol=1e-6, atol=1e-6 * np.abs(gr).max())
    # Boundary conditions g^(r)(0) = g^(r)(T) = 0 for r < k, for every real ℓ.
    ends = np.exp(-1j * np.multiply.outer(bank.nu, bank.omega0 * np.array([0, 3.0])))
    for r in range(order):
        np.testing.assert_allclose(bank.coefficient_matrix(r) @ ends, 0, atol=1e-12)


@pytest.mark.parametrize("order", [1, 2, 3, 4])
def test_row_mask_marks_exactly_the_identically_zero_parts(order):
    ell = np.array([-order / 2, -0.25, 0.0, 0.5, 1.0, 2.5])
    bank = fourier_bank(2.0, 0.01, order=order, ell=ell)
    s = np.linspace(0.0, 2.0, 4001)
    for j, e in enumerate(ell):
        g = _g(bank, e, s)
        scale = np.abs(g).max()
        zero = [np.abs(g.real).max() < 1e-12 * scale, np.abs(g.imag).max() < 1e-12]
        assert bank.row_mask[j].tolist() == [not zero[0], not zero[1]]
    assert bank.row_mask.sum() == 2 * len(ell) - 1


def test_frequency_sets():
    np.testing.assert_allclose(default_frequencies(10.0, 1.0), np.arange(10))
    np.testing.assert_allclose(default_frequencies(10.0, 1.0, order=2), np.arange(9))
    half = default_frequencies(4.0, 2.0, spacing=0.5)
    np.testing.assert_allclose(half, 0.5 * np.arange(15))
    assert (half.max() + 1) / 4.0 <= 2.0
    assert paper_frequencies()[-1] == 10.0


def test_modulated_integrals_equal_direct_quadrature_of_g_times_f():
    rng = np.random.default_rng(3)  # seed 3
    bank = fourier_bank(2.0, 0.01, order=2, ell=[0.0, 0.3, 1.0, 2.25])
    x = rng.standard_normal((bank.num_samples, 2))
    F = direct_fourier_integrals(bank, x)
    s = np.arange(bank.num_samples) * bank.time_step
    for r in range(3):
        expected = np.stack(
            [
                _trapezoid(_g(bank, e, s, r)[:, None] * x, bank.time_step)
                for e in bank.ell
            ]
        )
        np.testing.assert_allclose(
            modulated_integrals(bank, F, derivative=r), expected, rtol=1e-12, atol=1e-12
        )
    np.testing.assert_allclose(
        modulated_integrals(bank, F[:, 0]), modulated_integrals(bank, F)[:, 0]
    )


def test_integration_by_parts_moves_the_derivative_onto_g():
    # M_ġ(f) = -M_g(ḟ) and M_g̈(f) = M_g(f̈) for order 2, up to quadrature error.
    bank = fourier_bank(2.0, 1e-4, order=2, ell=[0.0, 0.5, 1.0, 3.0])
    t = 7.3 + np.arange(bank.num_samples) * bank.time_step
    f = 1 + np.sin(2 * t) + 0.5 * np.cos(5 * t)
    fd = 2 * np.cos(2 * t) - 2.5 * np.sin(5 * t)
    fdd = -4 * np.sin(2 * t) - 12.5 * np.cos(5 * t)
    Ff = direct_fourier_integrals(bank, f)
    Fd = direct_fourier_integrals(bank, fd)
    Fdd = direct_fourier_integrals(bank, fdd)
    # The identity is exact; the trapezoid error is O(h²·(νω0)³) (≈4e-8 relative
    # here), far below a wrong sign or factor (an O(1) error).
    pairs = [
        (modulated_integrals(bank, Ff, 1), -modulated_integrals(bank, Fd)),
        (modulated_integrals(bank, Ff, 2), modulated_integrals(bank, Fdd)),
    ]
    for got, want in pairs:
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * np.abs(want).max())


# -- sliding == direct ---------------------------------------------------------------


def test_sliding_equals_direct_over_a_long_run_with_non_integer_nu():
    # 10^5 single pushes, no resynchronisation: the raw drift stays far below 1e-9.
    rng = np.random.default_rng(11)  # seed 11
    bank = fourier_bank(1.0, 1e-3, order=1, ell=[0.0, 0.05, 1 / 3, 1.7, 4.45, 9.95])
    n = 100_000
    t = np.arange(n) * bank.time_step
    x = np.stack([np.sin(3 * t) + 5, 0.1 * rng.standard_normal(n)], axis=1)
    state = sliding_init(bank, 2, resync_every=0)
    for k in range(n):
        state = sliding_push(bank, state, x[k])
    window = x[n - bank.num_samples :]
    np.testing.assert_array_equal(state.ring.window(), window)
    direct = direct_fourier_integrals(bank, window)
    assert _relative(sliding_fourier_integrals(bank, state), direct) < 1e-9
    scale = bank.window * np.abs(window).mean(axis=0)  # ≈ ∫|f| per channel
    error = np.abs(sliding_fourier_integrals(bank, state) - direct)
    assert np.all(error < 1e-9 * scale)


def test_push_many_with_long_blocks_equals_direct():
    # Blocks longer than the 256-sample phase table, shorter and longer than the
    # window, starting at large absolute indices.
    rng = np.random.default_rng(12)  # seed 12
    bank = fourier_bank(0.6, 1e-3, order=2, ell=[0.0, 0.05, 2.5, 7.3])
    x = rng.standard_normal((5000, 3))
    state = sliding_init(bank, 3, resync_every=0)
    start = 0
    for size in (1000, 300, 257, 2000, 599, 844):
        state = sliding_push_many(bank, state, x[start : start + size])
        start += size
        direct = direct_fourier_integrals(bank, x[start - bank.num_samples : start])
        F = sliding_fourier_integrals(bank, state)
        assert _relative(F, direct) < 1e-12


@settings(max_examples=25, deadline=None)
@given(
    intervals=st.integers(1, 60),
    order=st.integers(1, 3),
    ell=st.lists(
        st.floats(-3, 12, allow_nan=False).map(lambda e: round(e, 3)),
        min_size=1,
        max_size=5,
        unique=True,
    ),
    blocks=st.lists(st.integers(1, 90), min_size=1, max_size=8),
    channels=st.integers(1, 3),
    resync_every=st.integers(0, 50),
    seed=st.integers(0, 2**16),
)
def test_sliding_equals_direct_for_random_designs(
    intervals, order, ell, blocks, channels, resync_every, seed
):
    # Every frequency at most the bank's Nyquist (fourier_bank refuses the others).
    intervals = max(intervals, math.ceil(2 * (max(map(abs, ell)) + order)))
    bank = fourier_bank(intervals * 0.05, 0.05, order=order, ell=ell)
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((sum(blocks), channels)) + 1.0
    single = sliding_init(bank, channels, resync_every=resync_every, chunk_size=4)
    many = sliding_init(bank, channels, resync_every=resync_every, chunk_size=4)
    start = 0
    for size in blocks:
        for row in x[start : start + size]:
            single = sliding_push(bank, single, row)
        many = sliding_push_many(bank, many, x[start : start + size])
        start += size
        # Zero-padded window before it is full.
        padded = np.vstack([np.zeros((bank.num_samples, channels)), x[:start]])
        direct = direct_fourier_integrals(bank, padded[-bank.num_samples :])
        for state in (single, many):
            assert is_full(state) == (start >= bank.num_samples)
            F = sliding_fourier_integrals(bank, state)
            np.testing.assert_allclose(F, direct, rtol=0, atol=1e-11)


def test_states_have_value_semantics_and_cheap_deep_copies():
    bank = fourier_bank(0.2, 0.01, order=1, ell=[0.0, 1.5])
    x = np.arange(60.0).reshape(30, 2)
    state = sliding_push_many(bank, sliding_init(bank, 2), x[:25])
    clone = copy.deepcopy(state)
    assert clone.sums is state.sums  # read-only, shared
    with pytest.raises(ValueError):
        state.sums[0, 0] = 1.0
    a = sliding_push(bank, state, x[25])
    b = sliding_push(bank, state, x[26])  # branch from the same state
    c = sliding_push(bank, clone, x[26])
    np.testing.assert_allclose(
        sliding_fourier_integrals(bank, a), direct_fourier_integrals(bank, x[5:26])
    )
    expected_b = direct_fourier_integrals(bank, np.vstack([x[5:25], x[26]]))
    np.testing.assert_allclose(sliding_fourier_integrals(bank, b), expected_b)
    np.testing.assert_allclose(sliding_fourier_integrals(bank, c), expected_b)
    np.testing.assert_allclose(
        sliding_fourier_integrals(bank, state), direct_fourier_integrals(bank, x[4:25])
    )


def test_resync_keeps_the_integrals():
    rng = np.random.default_rng(5)  # seed 5
    bank = fourier_bank(0.5, 0.01, order=2, ell=[0.25, 1.0, 2.75])
    state = sliding_push_many(bank, sliding_init(bank, 3), rng.normal(size=(333, 3)))
    again = sliding_resync(bank, state)
    assert again.since_resync == 0
    np.testing.assert_allclose(
        sliding_fourier_integrals(bank, again),
        sliding_fourier_integrals(bank, state),
        atol=1e-13,
    )
    # The default period is 100 windows and is applied by the pushes.
    state = sliding_init(bank, 3)
    assert state.resync_every == 100 * bank.num_samples
    state = sliding_push_many(bank, state, np.ones((state.resync_every, 3)))
    assert state.since_resync == 0


def test_invalid_samples_are_zeroed_and_invalidate_the_window_until_they_leave():
    bank = fourier_bank(0.05, 0.01, order=1, ell=[0.0, 1.0])  # N + 1 = 6 samples
    x = np.arange(1.0, 21.0).reshape(10, 2)
    flags = np.ones(10, dtype=bool)
    flags[3] = False
    x_nan = x.copy()
    x_nan[4, 1] = np.nan  # non-finite: invalid as well
    state = sliding_init(bank, 2)
    seen = []
    for k in range(10):
        state = sliding_push(bank, state, x_nan[k], valid=bool(flags[k]))
        seen.append(window_valid(state))
    # Full from sample 5 on; samples 3 and 4 leave the window after sample 10.
    assert seen == [False] * 10
    state = sliding_push(bank, state, [1.0, 1.0])
    assert window_valid(state) and is_full(state)
    clean = x.copy()
    clean[3:5] = 0.0
    expected = direct_fourier_integrals(bank, np.vstack([clean[5:], [[1.0, 1.0]]]))
    np.testing.assert_allclose(sliding_fourier_integrals(bank, state), expected)
    many = sliding_push_many(bank, sliding_init(bank, 2), x_nan, valid=flags)
    assert many.last_invalid == 4 and not window_valid(many)
    np.testing.assert_allclose(
        sliding_fourier_integrals(bank, many), direct_fourier_integrals(bank, clean[4:])
    )


# -- model-row contract ---------------------------------------------------------------


def test_pack_rows_layout_and_inverse():
    D = np.arange(6.0).reshape(2, 3)
    G = 10 + np.arange(6.0).reshape(2, 3)
    y = np.array([100.0, 101.0])
    packed = pack_rows(D, G, y)
    assert packed.tolist() == [0, 1, 2, 3, 4, 5, 10, 11, 12, 13, 14, 15, 100, 101]
    assert num_channels(2, 3) == 14
    batch = pack_rows(np.stack([D, D]), np.stack([G, G]), np.stack([y, y]))
    assert batch.shape == (2, 14)
    for got, want in zip(unpack_rows(batch, 2, 3), (D, G, y), strict=True):
        np.testing.assert_array_equal(got[1], want)


def test_assemble_equations_row_order_and_dropped_rows():
    rng = np.random.default_rng(9)  # seed 9
    m, p = 2, 3
    bank = fourier_bank(1.0, 0.01, order=1, ell=[-0.5, 0.0, 1.25])
    F = rng.normal(size=(bank.num_frequencies, num_channels(m, p))) * (1 + 1j)
    A, B = assemble_equations(bank, F, m, p)
    assert A.shape == (bank.num_rows(m), p) == (10, p)
    D_part = modulated_integrals(bank, F[:, : m * p], 1).reshape(3, m, p)
    G_part = modulated_integrals(bank, F[:, m * p : 2 * m * p]).reshape(3, m, p)
    rhs = modulated_integrals(bank, F[:, 2 * m * p :])
    lhs = G_part - D_part
    # ℓ = -1/2 with k = 1: g is purely imaginary, only its imaginary rows remain.
    expected_rows = [lhs[0, 0].imag, lhs[0, 1].imag]
    expected_rhs = [rhs[0, 0].imag, rhs[0, 1].imag]
    for j in (1, 2):
        expected_rows += [
            lhs[j, 0].real,
            lhs[j, 1].real,
            lhs[j, 0].imag,
            lhs[j, 1].imag,
        ]
        expected_rhs += [rhs[j, 0].real, rhs[j, 1].real, rhs[j, 0].imag, rhs[j, 1].imag]
    np.testing.assert_allclose(A, np.array(expected_rows))
    np.testing.assert_allclose(B, np.array(expected_rhs))


# One joint (docs/MATH.md §3): ZZ q̈ + Fv q̇ + Fc sign(q̇) = τ, with an analytic q(t) whose
# velocity zero crossings fall on samples (t = 0.5 + m s), where sign(q̇) = 0: the
# trapezoid rule then stays second order across the Coulomb jumps.
ZZ, FV, FC = 3.0, 0.4, 0.5
_W, _W2 = math.pi, 2.3


def _one_joint(h, duration):
    t = np.arange(round(duration / h)) * h
    amplitude = 1.5 + 0.5 * np.sin(_W2 * t)
    v = np.cos(_W * t) * amplitude
    vdot = -_W * np.sin(_W * t) * amplitude + 0.5 * _W2 * np.cos(_W * t) * np.cos(
        _W2 * t
    )
    q = 1.5 * np.sin(_W * t) / _W - 0.25 * (
        np.cos((_W2 + _W) * t) / (_W2 + _W) + np.cos((_W2 - _W) * t) / (_W2 - _W)
    )
    sign = np.where(np.abs(v) < 1e-9, 0.0, np.sign(v))
    tau = ZZ * vdot + FV * v + FC * sign
    return q, v, sign, tau


@pytest.mark.parametrize("order", [1, 2])
def test_one_joint_contract_form_recovers_the_parameters(order):
    h = 5e-4
    _, v, sign, tau = _one_joint(h, 6.3)
    zero = np.zeros_like(v)
    D = np.stack([v, zero, zero], axis=-1)[:, None, :]  # d/dt(ZZ q̇)
    G = np.stack([zero, v, sign], axis=-1)[:, None, :]
    rows = pack_rows(D, G, tau[:, None])
    bank = fourier_bank(4.0, h, order=order, ell=np.arange(1, 201) / 50)
    state = sliding_push_many(bank, sliding_init(bank, rows.shape[1]), rows)
    A, B = assemble_equations(bank, sliding_fourier_integrals(bank, state), 1, 3)
    assert A.shape == (400, 3)
    theta = np.linalg.lstsq(A, B, rcond=None)[0]
    np.testing.assert_allclose(theta, [ZZ, FV, FC], rtol=2e-6)


def test_one_joint_paper_fig1_form_with_order_2():
    # ZZ M_g̈(q) - Fv M_ġ(q) + Fc M_g(sign q̇) = M_g(τ): positions only.
    h = 5e-4
    q, _, sign, tau = _one_joint(h, 6.3)
    bank = fourier_bank(4.0, h, order=2, ell=np.arange(1, 201) / 50)
    state = sliding_push_many(bank, sliding_init(bank, 3), np.stack([q, sign, tau], 1))
    F = sliding_fourier_integrals(bank, state)
    columns = [
        modulated_integrals(bank, F[:, 0], 2),
        -modulated_integrals(bank, F[:, 0], 1),
        modulated_integrals(bank, F[:, 1]),
    ]
    A = np.stack(columns, axis=1)
    B = modulated_integrals(bank, F[:, 2])
    A, B = np.vstack([A.real, A.imag]), np.concatenate([B.real, B.imag])
    theta = np.linalg.lstsq(A, B, rcond=None)[0]
    np.testing.assert_allclose(theta, [ZZ, FV, FC], rtol=5e-6)


# -- validation ----------------------------------------------------------------------


def test_validation_messages():
    with pytest.raises(ValueError, match="window must be a multiple of time_step"):
        fourier_bank(1.0005, 0.001, ell=[0.0])
    with pytest.raises(ValueError, match="window must be > 0"):
        fourier_bank(0.0, 0.001, ell=[0.0])
    with pytest.raises(ValueError, match="order must be >= 1"):
        fourier_bank(1.0, 0.001, order=0, ell=[0.0])
    with pytest.raises(ValueError, match="ell must be a non-empty 1-D array"):
        fourier_bank(1.0, 0.001, ell=[])
    with pytest.raises(ValueError, match="ell must not repeat"):
        fourier_bank(1.0, 0.001, ell=[1.0, 1.0])
    with pytest.raises(ValueError, match="ell must be finite"):
        fourier_bank(1.0, 0.001, ell=[np.nan])
    bank = fourier_bank(0.1, 0.01, order=1, ell=[0.0, 1.0])
    with pytest.raises(ValueError, match="derivative must be <= order 1"):
        modulated_integrals(bank, np.zeros((3, 1)), derivative=2)
    with pytest.raises(ValueError, match=r"F must have shape \(3, channels\)"):
        modulated_integrals(bank, np.zeros((4, 1)))
    with pytest.raises(ValueError, match=r"samples must have shape \(11, channels\)"):
        direct_fourier_integrals(bank, np.zeros((10, 1)))
    with pytest.raises(ValueError, match=r"F must have shape \(3, 7\) for m=1, p=3"):
        assemble_equations(bank, np.zeros((3, 6)), 1, 3)
    state = sliding_init(bank, 2)
    with pytest.raises(ValueError, match=r"sample must have shape \(2,\)"):
        sliding_push(bank, state, [1.0])
    with pytest.raises(ValueError, match="samples must have 2 channels"):
        sliding_push_many(bank, state, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"valid must have shape \(3,\)"):
        sliding_push_many(bank, state, np.zeros((3, 2)), valid=[True])
    with pytest.raises(ValueError, match="resync_every must be >= 0"):
        sliding_init(bank, 2, resync_every=-1)
    with pytest.raises(ValueError, match="bandwidth_hz must be >= order/window"):
        default_frequencies(10.0, 0.05)
    with pytest.raises(ValueError, match="D and G must have shape"):
        pack_rows(np.zeros((1, 3)), np.zeros((1, 2)), np.zeros(1))
