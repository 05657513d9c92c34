"""Causal Jacobi core (docs/MATH.md §1): design, exactness, oracles, streaming.

Seeds: every random draw uses ``np.random.default_rng(SEED)`` with SEED = 20140701
(or hypothesis' own reproducible search).
"""

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import integrate, special

from drake_dynid.core.jacobi import (
    jacobi_apply,
    jacobi_batch,
    jacobi_filter,
    jacobi_filters,
    jacobi_frequency_response,
    jacobi_initial_state,
    jacobi_kernel,
    jacobi_minimum_delay_xi,
    jacobi_outputs,
    jacobi_ring,
    jacobi_sinusoid_error,
    jacobi_step,
    jacobi_valid,
)

SEED = 20140701
H = 1e-3


def exact_derivative(degree, order, at):
    """d^order/ds^order of s^degree at s = at."""
    if degree < order:
        return 0.0
    return (
        math.factorial(degree) / math.factorial(degree - order) * at ** (degree - order)
    )


# ----------------------------------------------------------------- pinned values


def test_pinned_values_q1_kappa1_mu1():
    f = jacobi_filter(1, 0.3, H, kappa=1, mu=1, q=1)
    assert f.num_taps == 301
    assert f.delay == pytest.approx(93.305329e-3, rel=1e-8)
    assert f.taps[0] == pytest.approx(0.001338662429, rel=1e-9)
    assert f.taps[300] == pytest.approx(0.0006016204537, rel=1e-9)
    assert f.noise_gain == pytest.approx(1.45468485, rel=1e-8)
    assert f.root and f.exact_degree == 3


def test_pinned_values_q0_kappa0_mu0():
    f = jacobi_filter(1, 0.1, H, kappa=0, mu=0, q=0)
    assert f.num_taps == 101
    assert f.delay == pytest.approx(0.05, rel=1e-12)
    assert f.taps[0] == pytest.approx(0.298, rel=1e-9)
    assert f.taps[100] == pytest.approx(-0.298, rel=1e-9)
    assert f.noise_gain == pytest.approx(3.43802385, rel=1e-8)


def test_sanity_kernel_k1_q0_is_6_2tau_minus_1():
    tau = np.linspace(0, 1, 11)
    q_tau = jacobi_kernel(tau, 1, kappa=0, mu=0, q=0, xi=0.5)
    np.testing.assert_allclose(q_tau, 6 * (2 * tau - 1), atol=1e-13)


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("kappa,mu", [(0, 0), (1.5, -0.5), (-0.7, 2)])
def test_q0_minimum_delay_closed_form(order, kappa, mu):
    xi = jacobi_minimum_delay_xi(order, kappa=kappa, mu=mu, q=0)
    assert xi == pytest.approx((kappa + order + 1) / (kappa + mu + 2 * order + 2))
    f = jacobi_filter(order, 0.05, H, kappa=kappa, mu=mu, q=0)
    assert f.xi == pytest.approx(xi, abs=1e-15)
    assert f.delay == pytest.approx(0.05 * xi, rel=1e-14)


def test_filter_is_immutable_with_read_only_taps():
    f = jacobi_filter(1, 0.02, H, kappa=1, mu=1, q=1, xi=0.3)
    with pytest.raises(ValueError, match="read-only"):
        f.taps[0] = 1.0
    with pytest.raises(AttributeError):
        f.xi = 0.5
    assert (f.order, f.kappa, f.mu, f.q, f.xi, f.time_step) == (1, 1.0, 1.0, 1, 0.3, H)
    assert f.window == pytest.approx(0.02) and f.delay == pytest.approx(0.006)
    assert not f.root and f.exact_degree == 2


def test_single_interval_window():
    # N = 1: both singular ends in one interval; the 2 taps are still exact on lines.
    f = jacobi_filter(1, H, H, kappa=-0.5, mu=-0.5, q=0)
    np.testing.assert_allclose(f.taps, [1 / H, -1 / H], rtol=1e-12)


# ------------------------------------------------------------------ exactness

SHAPES = [(0.0, 0.0), (1.0, 1.0), (-0.5, 2.0), (3.0, -0.8), (-0.9, -0.9), (4.5, 0.3)]


def continuous_estimate(order, kappa, mu, q, xi, degree):
    """(-1)^-k ∫_0^1 Q(τ) (-τ)^degree dτ by a Gauss-Jacobi rule exact here."""
    x, w = special.roots_jacobi(order + q + degree + 4, mu, kappa)
    tau = (x + 1) / 2
    # Q(τ) = weight(τ) p(τ): recover p at the (interior) nodes from the kernel.
    with np.errstate(divide="ignore", invalid="ignore"):
        p = jacobi_kernel(tau, order, kappa=kappa, mu=mu, q=q, xi=xi) / (
            (1 - tau) ** mu * tau**kappa
        )
    integral = np.sum(w * p * (-tau) ** degree) / 2 ** (mu + kappa + 1)
    return (-1) ** order * integral


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("kappa,mu", SHAPES)
@pytest.mark.parametrize("q", [0, 1, 2])
def test_continuous_kernel_exact_degree(order, kappa, mu, q):
    root = jacobi_minimum_delay_xi(order, kappa=kappa, mu=mu, q=q)
    for xi, top in ((0.37, order + q), (root, order + q + 1)):
        for degree in range(top + 1):
            est = continuous_estimate(order, kappa, mu, q, xi, degree)
            assert est == pytest.approx(
                exact_derivative(degree, order, -xi), abs=1e-9
            ), (xi, degree)
    # and the next degree is NOT reproduced (the test can fail)
    degree = order + q + 2
    est = continuous_estimate(order, kappa, mu, q, root, degree)
    assert abs(est - exact_derivative(degree, order, -root)) > 1e-6


def discrete_error(f, degree):
    """|estimate - truth| in window units for x(t) = (t/Tj)^degree, newest at t=0."""
    n = f.num_taps - 1
    s = -np.arange(n + 1) / n
    est = (f.taps @ s**degree) * f.window**f.order
    return abs(est - exact_derivative(degree, f.order, -f.xi))


@pytest.mark.parametrize("order", [0, 1, 2])
@pytest.mark.parametrize("kappa,mu", SHAPES)
@pytest.mark.parametrize("q", [0, 1, 2])
def test_discrete_taps_exact_up_to_discretisation(order, kappa, mu, q):
    # Product integration interpolates x linearly between samples: exact for
    # degree <= 1, O((h/Tj)^2) for the higher degrees the continuous estimator
    # reproduces exactly (any xi: k+q; the root: k+q+1).
    n = 500
    for xi in (0.37, None):
        f = jacobi_filter(order, n * H, H, kappa=kappa, mu=mu, q=q, xi=xi)
        for degree in range(f.exact_degree + 1):
            tol = 1e-10 if degree <= 1 else 100 / n**2
            assert discrete_error(f, degree) < tol, (xi, degree)
    # one degree more is wrong by far more than the discretisation error
    f = jacobi_filter(order, n * H, H, kappa=kappa, mu=mu, q=q)
    assert discrete_error(f, f.exact_degree + 1) > 1e-5


def test_discretisation_error_is_second_order():
    errors = [
        discrete_error(jacobi_filter(1, n * H, H, kappa=2, mu=0.5, q=1), 3)
        for n in (100, 200, 400)
    ]
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.05)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    order=st.integers(0, 2),
    kappa=st.floats(-0.95, 5.0),
    mu=st.floats(-0.95, 5.0),
    q=st.integers(0, 3),
    n=st.integers(100, 800),
    xi=st.one_of(st.none(), st.floats(0.0, 1.0)),
)
def test_property_polynomial_exactness(order, kappa, mu, q, n, xi):
    f = jacobi_filter(order, n * H, H, kappa=kappa, mu=mu, q=q, xi=xi)
    assert f.num_taps == n + 1
    assert f.delay == pytest.approx(n * H * f.xi, rel=1e-12)
    for degree in range(f.exact_degree + 1):
        est = continuous_estimate(order, kappa, mu, q, f.xi, degree)
        assert est == pytest.approx(exact_derivative(degree, order, -f.xi), abs=1e-8)
        tol = 1e-9 if degree <= 1 else 200 / n**2
        assert discrete_error(f, degree) < tol


# ---------------------------------------------------- independent computations


def independent_kernel(tau, order, kappa, mu, q, xi):
    """Q(τ) straight from docs/MATH.md: binomial-sum Jacobi polynomials, plain Gamma."""

    def jacobi(m, a, b, t):
        return sum(
            special.binom(m + a, j)
            * special.binom(m + b, m - j)
            * (t - 1) ** (m - j)
            * t**j
            for j in range(m + 1)
        )

    g = special.gamma
    k = order
    total = 0.0
    for i in range(q + 1):
        c = (
            (mu + kappa + 2 * k + 2 * i + 1)
            * g(kappa + mu + 2 * k + i + 1)
            * g(k + i + 1)
            / (g(kappa + k + i + 1) * g(mu + k + i + 1))
        )
        total = total + c * jacobi(i, mu + k, kappa + k, xi) * jacobi(
            k + i, mu, kappa, tau
        )
    return total  # without the weight (1-τ)^μ τ^κ (quad's weight='alg' applies it)


def quad_taps(order, n, kappa, mu, q, xi):
    """tap_j = (-1)^k Tj^-k ∫ Q φ_j by QUADPACK with algebraic end weights."""
    window = n * H
    taps = np.zeros(n + 1)
    for j in range(n):
        a, b = j / n, (j + 1) / n
        hats = ((lambda t, b=b: (b - t) * n, j), (lambda t, a=a: (t - a) * n, j + 1))
        for hat, target in hats:

            def integrand(t, hat=hat, j=j):
                p = independent_kernel(t, order, kappa, mu, q, xi) * hat(t)
                w = 1.0
                if j != 0:
                    w *= t**kappa
                if j != n - 1:
                    w *= (1 - t) ** mu
                return p * w

            wvar = (kappa if j == 0 else 0.0, mu if j == n - 1 else 0.0)
            value, _ = integrate.quad(
                integrand, a, b, weight="alg", wvar=wvar, epsabs=1e-15, epsrel=1e-12
            )
            taps[target] += value
    return (-1) ** order * window ** (-order) * taps


@pytest.mark.parametrize(
    "order,kappa,mu,q,xi",
    [
        (0, -0.5, 2.0, 1, None),
        (1, 0.0, 0.0, 0, None),
        (1, 1.0, 1.0, 1, 0.2),
        (1, -0.9, 5.0, 2, None),
        (2, 3.5, -0.6, 1, None),
        (2, 5.0, 5.0, 0, 1.0),
        (0, 0.3, -0.95, 2, 0.0),
    ],
)
def test_taps_match_scipy_quad(order, kappa, mu, q, xi):
    n = 12
    f = jacobi_filter(order, n * H, H, kappa=kappa, mu=mu, q=q, xi=xi)
    expected = quad_taps(order, n, kappa, mu, q, f.xi)
    np.testing.assert_allclose(
        f.taps, expected, rtol=1e-6, atol=1e-9 * np.abs(expected).max()
    )


def algdiff_taps(order, n, kappa, mu, q, xi):
    """Taps and discrete delay from AlgDiff with the docs/MATH.md mapping."""
    algdiff = pytest.importorskip("AlgDiff")

    class Patched(algdiff.AlgebraicDifferentiator):
        # AlgDiff 2.4 stores 1-element arrays into a float array, an error on
        # NumPy >= 2.4: return plain floats.
        def get_integralKernel(self, t, nested=1):
            return float(np.squeeze(super().get_integralKernel(t, nested)))

        def evalKernelDer(self, t, k):
            return float(np.squeeze(super().evalKernelDer(t, k)))

    with warnings.catch_warnings():
        # AlgDiff warns about aliasing for short windows; irrelevant to the taps.
        warnings.simplefilter("ignore")
        diff = Patched(
            ts=H,
            alpha=kappa + order,
            beta=mu + order,
            N=q,
            T=n * H,
            display=False,
            corr=False,
        )
        diff.set_theta(1 - 2 * xi, False)
        method = "analytic trapezoidal"
        taps = diff.discretize(order, method=method)[order][method]
        delay = diff.get_delayDiscrete()[method]
    return np.asarray(taps, dtype=float), float(delay)


@pytest.mark.parametrize(
    "order,kappa,mu,q,xi",
    [
        (1, 1.0, 1.0, 1, None),
        (1, 0.0, 0.0, 0, None),
        (0, 2.0, 0.5, 2, None),
        (2, 1.5, 2.0, 1, 0.4),
        (1, -0.5, 0.5, 1, None),
    ],
)
def test_taps_match_algdiff(order, kappa, mu, q, xi):
    n = 150
    f = jacobi_filter(order, n * H, H, kappa=kappa, mu=mu, q=q, xi=xi)
    taps, delay = algdiff_taps(order, n, kappa, mu, q, f.xi)
    np.testing.assert_allclose(f.taps, taps, rtol=1e-7, atol=1e-9 * np.abs(taps).max())
    # AlgDiff reports the discrete delay h/2 short of the product-integration one.
    assert delay + H / 2 == pytest.approx(f.delay, abs=1e-12)


# ------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "kwargs,error,match",
    [
        (dict(window=0.0105), ValueError, "window must be a multiple of time_step"),
        (dict(window=0.0005), ValueError, "window must be a multiple of time_step"),
        (dict(window=-0.1), ValueError, "window must be > 0"),
        (dict(time_step=0.0), ValueError, "time_step must be > 0"),
        (dict(time_step=-1e-3), ValueError, "time_step must be > 0"),
        (dict(time_step=float("nan")), ValueError, "time_step must be finite"),
        (dict(kappa=-1.0), ValueError, "kappa must be > -1"),
        (dict(kappa=-3), ValueError, "kappa must be > -1"),
        (dict(mu=-1.5), ValueError, "mu must be > -1"),
        (dict(mu=float("inf")), ValueError, "mu must be finite"),
        (dict(q=-1), ValueError, "q must be >= 0"),
        (dict(q=1.5), ValueError, "q must be an integer"),
        (dict(q="1"), TypeError, "q must be an integer"),
        (dict(order=-1), ValueError, "order must be >= 0"),
        (dict(order=0.5), ValueError, "order must be an integer"),
        (dict(xi=1.2), ValueError, r"xi must be in \[0.0, 1.0\]"),
        (dict(xi=-0.1), ValueError, r"xi must be in \[0.0, 1.0\]"),
        (dict(kappa="a"), TypeError, "kappa must be a real number"),
    ],
)
def test_invalid_arguments(kwargs, error, match):
    args = dict(order=1, window=0.01, time_step=H, kappa=1.0, mu=1.0, q=1, xi=None)
    args.update(kwargs)
    with pytest.raises(error, match="jacobi_filter: " + match):
        jacobi_filter(
            args["order"],
            args["window"],
            args["time_step"],
            kappa=args["kappa"],
            mu=args["mu"],
            q=args["q"],
            xi=args["xi"],
        )


def test_window_error_message_is_the_house_format():
    with pytest.raises(ValueError) as info:
        jacobi_filter(1, 0.0105, 0.001, kappa=1, mu=1, q=1)
    assert str(info.value) == (
        "jacobi_filter: window must be a multiple of time_step [s]; "
        "got 0.0105 with time_step 0.001."
    )


@pytest.mark.parametrize(
    "orders,error,match",
    [
        ((), ValueError, "orders must hold at least one order"),
        ((1, 1), ValueError, "orders must be distinct"),
        ((0, -1), ValueError, "orders must be >= 0"),
        (1, TypeError, "orders must be a sequence"),
        ((0, 1.5), ValueError, "orders must be an integer"),
    ],
)
def test_invalid_orders(orders, error, match):
    with pytest.raises(error, match="jacobi_filters: " + match):
        jacobi_filters(orders, 0.01, H, kappa=1, mu=1, q=0)


def test_other_validation_messages():
    f = jacobi_filter(1, 0.01, H, kappa=1, mu=1, q=0)
    with pytest.raises(ValueError, match="num_signals must be >= 1"):
        jacobi_ring(f, 0)
    g = jacobi_filter(1, 0.02, H, kappa=1, mu=1, q=0)
    with pytest.raises(ValueError, match="share one window and time_step"):
        jacobi_ring([f, g], 1)
    with pytest.raises(TypeError, match="filters must be JacobiFilter"):
        jacobi_ring([f.taps], 1)
    with pytest.raises(ValueError, match="newest_first must have 11 rows"):
        jacobi_apply(f.taps, np.zeros(10))
    with pytest.raises(ValueError, match="samples must be finite"):
        jacobi_batch(f, [0.0, np.nan])
    with pytest.raises(ValueError, match="xi must be in"):
        jacobi_kernel(0.5, 1, kappa=0, mu=0, q=0, xi=2.0)


# --------------------------------------------------------------------------- bank


def test_bank_shares_xi_of_highest_order():
    bank = jacobi_filters((0, 1, 2), 0.1, H, kappa=1, mu=0.5, q=1)
    root = jacobi_minimum_delay_xi(2, kappa=1, mu=0.5, q=1)
    assert [f.order for f in bank] == [0, 1, 2]
    assert all(f.xi == root for f in bank)
    assert all(f.delay == bank[0].delay for f in bank)
    assert bank[2].root and bank[2].exact_degree == 4
    # lower orders stay exact for k+q (here the xi is not their root)
    assert not bank[0].root and bank[0].exact_degree == 1
    for f in bank:
        single = jacobi_filter(f.order, 0.1, H, kappa=1, mu=0.5, q=1, xi=root)
        np.testing.assert_array_equal(f.taps, single.taps)
    given_xi = jacobi_filters([2, 0], 0.1, H, kappa=1, mu=0.5, q=1, xi=0.25)
    assert [f.order for f in given_xi] == [2, 0] and given_xi[1].xi == 0.25


def test_bank_orders_refer_to_the_same_instant():
    # x = sin: derivatives of every order at t - delay from one bank.
    bank = jacobi_filters((0, 1, 2), 0.2, H, kappa=2, mu=2, q=1)
    t = np.arange(2000) * H
    omega = 3.0
    x = np.sin(omega * t)
    instant = t[-1] - bank[0].delay
    truths = [
        np.sin(omega * instant),
        omega * np.cos(omega * instant),
        -(omega**2) * np.sin(omega * instant),
    ]
    for f, truth in zip(bank, truths, strict=True):
        assert jacobi_batch(f, x)[-1] == pytest.approx(truth, abs=2e-3 * omega**f.order)


# ---------------------------------------------------------------------- streaming


def test_streaming_equals_batch_and_direct_application():
    rng = np.random.default_rng(SEED)
    bank = jacobi_filters((0, 1, 2), 0.02, H, kappa=0.5, mu=-0.3, q=1)
    ring = jacobi_ring(bank, 3)
    samples = rng.normal(size=(70, 3))
    state = jacobi_initial_state(ring)
    streamed = []
    valid = []
    for sample in samples:
        before = state.copy()
        new = jacobi_step(ring, state, sample)
        np.testing.assert_array_equal(state, before)  # functional: input untouched
        state = new
        streamed.append(jacobi_outputs(ring, state))
        valid.append(jacobi_valid(ring, state))
    streamed = np.array(streamed)  # (T, K, m)
    n = ring.num_taps
    assert valid == [False] * (n - 1) + [True] * (70 - n + 1)
    for index, f in enumerate(bank):
        batch = jacobi_batch(f, samples)
        scale = np.abs(batch).max()
        np.testing.assert_allclose(
            streamed[:, index], batch, rtol=0, atol=1e-13 * scale
        )
        np.testing.assert_allclose(
            jacobi_outputs(ring, state, index), streamed[-1, index], rtol=1e-13
        )
        direct = jacobi_apply(f.taps, samples[::-1][:n])
        np.testing.assert_allclose(direct, batch[-1], rtol=0, atol=1e-13 * scale)
    stacked = jacobi_apply(np.stack([f.taps for f in bank]), samples[::-1][:n])
    np.testing.assert_allclose(stacked, streamed[-1], rtol=1e-12)


def test_step_in_place_and_one_dimensional_batch():
    f = jacobi_filter(1, 0.005, H, kappa=1, mu=1, q=0)
    ring = jacobi_ring(f, 1)
    state = jacobi_initial_state(ring)
    x = np.arange(20.0) * H * 2.0  # slope 2
    for value in x:
        out = jacobi_step(ring, state, [value], out=state)
        assert out is state
    assert jacobi_outputs(ring, state)[0, 0] == pytest.approx(2.0, rel=1e-12)
    assert jacobi_batch(f, x).shape == (20,)
    assert jacobi_batch(f, x)[-1] == pytest.approx(2.0, rel=1e-12)


# ------------------------------------------------------------------ tuning helpers


def test_frequency_response_and_sinusoid_error_predict_the_filter():
    f = jacobi_filter(1, 0.1, H, kappa=1, mu=1, q=1)
    omega = 20.0
    t = np.arange(400) * H
    y = jacobi_batch(f, np.sin(omega * t))[-1]
    truth = omega * np.cos(omega * (t[-1] - f.delay))
    response = jacobi_frequency_response(f, [omega])[0]
    assert y == pytest.approx(np.imag(response * np.exp(1j * omega * t[-1])), abs=1e-12)
    err = jacobi_sinusoid_error(f, [omega])[0]
    assert abs(y - truth) <= err + 1e-12
    assert err > 1e-3  # not trivially zero at 20 rad/s
    assert jacobi_sinusoid_error(f, [0.1])[0] < 1e-6
    g = jacobi_filter(0, 0.1, H, kappa=1, mu=1, q=1)
    assert jacobi_frequency_response(g, [0.0])[0] == pytest.approx(1.0, abs=1e-12)


def test_noise_gain_is_the_output_noise_std():
    rng = np.random.default_rng(SEED)
    f = jacobi_filter(1, 0.1, H, kappa=1, mu=1, q=1)
    sigma = 0.01
    y = jacobi_batch(f, sigma * rng.normal(size=200_000))[f.num_taps :]
    assert np.std(y) == pytest.approx(sigma * f.noise_gain, rel=0.03)


@pytest.mark.parametrize(
    ("kappa", "mu", "q"), [(1.0, 1.0, 1), (0.0, 0.5, 0), (-0.5, 2.0, 2)]
)
def test_matched_bank_is_one_low_pass_on_every_derivative(kappa, mu, q):
    # D^(1)_{κ,μ,q}[x] == D^(0)_{κ+1,μ+1,q}[ẋ]: with matched=True the order-1 output
    # on samples of x equals the order-0 output on samples of ẋ, up to the O(h²)
    # discretisation of product integration.
    from drake_dynid.core.jacobi import jacobi_batch, jacobi_filters

    h = 1e-3
    f0, f1 = jacobi_filters((0, 1), 0.2, h, kappa=kappa, mu=mu, q=q, matched=True)
    assert f0.xi == f1.xi
    assert (f0.kappa, f0.mu) == (kappa + 1, mu + 1)
    assert (f1.kappa, f1.mu) == (kappa, mu)
    t = h * np.arange(2000)
    x = np.sin(9.0 * t) + 0.3 * np.cos(23.0 * t)
    xdot = 9.0 * np.cos(9.0 * t) - 6.9 * np.sin(23.0 * t)
    derivative = jacobi_batch(f1, x)[400:]
    filtered_velocity = jacobi_batch(f0, xdot)[400:]
    np.testing.assert_allclose(derivative, filtered_velocity, atol=2e-4)
    # The unmatched order-0 filter does not have this property.
    g0 = jacobi_filters((0, 1), 0.2, h, kappa=kappa, mu=mu, q=q)[0]
    assert np.max(np.abs(jacobi_batch(g0, xdot)[400:] - derivative)) > 1e-2


def test_a_non_finite_sample_is_not_valid_while_it_is_in_the_ring():
    """Found by a review: ``valid`` counted samples only, so the block alone said
    1 while its outputs were NaN for the N+1 samples after a NaN input."""
    ring = jacobi_ring([jacobi_filter(1, 0.02, 1e-3, kappa=1.0, mu=1.0, q=1)], 2)
    state = jacobi_initial_state(ring)
    for k in range(ring.num_taps):
        state = jacobi_step(ring, state, [k * 1e-3, 1.0])
    assert jacobi_valid(ring, state)
    state = jacobi_step(ring, state, [np.nan, 1.0])
    for _ in range(ring.num_taps - 1):
        assert not jacobi_valid(ring, state)
        assert not np.isfinite(jacobi_outputs(ring, state)).all()
        state = jacobi_step(ring, state, [0.0, 1.0])
    state = jacobi_step(ring, state, [0.0, 1.0])  # the NaN has left the ring
    assert jacobi_valid(ring, state) and np.isfinite(jacobi_outputs(ring, state)).all()
