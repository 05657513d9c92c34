"""Causal Jacobi derivative estimator: the filter design (docs/MATH.md §1).

The k-th derivative of a sampled signal x is estimated from the last window ``Tj``
[s] of samples (Mboup, Join & Fliess; Liu, Gibaru & Perruquetti; used by Guo,
Perruquetti & Gautier, AIM 2014)::

    x^(k)(t0 - Tj·ξ)  ≈  (-Tj)^(-k) ∫_0^1 Q(τ) x(t0 - Tj·τ) dτ        (τ = 0: newest)

    Q(τ) = (1-τ)^μ τ^κ Σ_{i=0..q} C_i P_i^{(μ+k, κ+k)}(ξ) P_{k+i}^{(μ, κ)}(τ)
    C_i  = (μ+κ+2k+2i+1) Γ(κ+μ+2k+i+1) Γ(k+i+1) / (Γ(κ+k+i+1) Γ(μ+k+i+1))

with ``P_m^{(a,b)}(τ) = scipy.special.eval_jacobi(m, a, b, 2τ-1)`` (``core.orthopoly``).
The continuous estimate is the k-th derivative at ξ of the weighted least-squares
polynomial of degree k+q fitted to the window: exact for polynomials of degree k+q for
any ξ, and of degree k+q+1 when ξ is a root of ``P_{q+1}^{(μ+k, κ+k)}``.

Discretisation: product integration with x linear between samples (hat functions
φ_j at τ_j = j/N, N = Tj/h)::

    tap_j = (-1)^k Tj^(-k) ∫_0^1 Q(τ) φ_j(τ) dτ,   x̂^(k)(t_n - Tj·ξ) = Σ_j tap_j x_{n-j}

N+1 taps, delay exactly ``Tj·ξ`` [s]; taps[0] multiplies the newest sample. The end
intervals are integrated by Gauss-Jacobi rules that absorb τ^κ and (1-τ)^μ (so κ, μ
in (-1, 0) are exact too), the interior ones by Gauss-Legendre. The discrete filter
is exact for polynomials of degree <= 1 (which the hats interpolate exactly); for
higher degrees its error versus the continuous estimator is O((h/Tj)^2).

Layout, following ``scipy.signal.savgol_coeffs`` / ``lfilter``: this module designs
the filters (:func:`jacobi_filter`, :func:`jacobi_filters`, immutable
:class:`JacobiFilter`) and the tuning helpers (frequency response, bias on a
sinusoid); :mod:`drake_dynid.core.jacobi_stream` applies them (batch, and the
streaming ring of the Drake block).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.orthopoly import gauss_jacobi, jacobi_polynomial, log_gamma

__all__ = [
    "MAX_EXPONENT",
    "MAX_Q",
    "MAX_TAPS",
    "JacobiFilter",
    "jacobi_filter",
    "jacobi_filters",
    "jacobi_frequency_response",
    "jacobi_kernel",
    "jacobi_minimum_delay_xi",
    "jacobi_sinusoid_error",
]


#: Largest q (extra polynomial degree): at q = 10 the velocity filter's noise gain
#: is already 20-100 times that of q = 1, and the design's cost grows like q².
MAX_Q = 10
#: Largest κ and μ (weight exponents): up to it the taps are exact to ~1e-12.
MAX_EXPONENT = 100.0
#: Most taps of one filter (window / time_step + 1): a hard ceiling on the design.
MAX_TAPS = 1 << 17


def _read_only(value: np.ndarray) -> np.ndarray:
    out = np.array(value, dtype=float)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class JacobiFilter:
    """A designed causal Jacobi FIR filter (immutable; see :func:`jacobi_filter`).

    ``x̂^(k)(t_n - delay) = Σ_j taps[j] x_{n-j}``: ``taps[j]`` multiplies the sample
    taken j steps ago (``taps[0]`` is the newest) and has unit [s^-order].

    Attributes:
        order: Derivative order k (0 = smoothed signal).
        window: Window length Tj [s] (= (num_taps - 1)·time_step).
        time_step: Sample period h [s].
        kappa: Weight exponent κ > -1 of the newest end.
        mu: Weight exponent μ > -1 of the oldest end.
        q: Extra polynomial degree q >= 0 (least-squares degree k+q).
        xi: Normalised delay ξ in [0, 1].
        taps: The N+1 read-only FIR coefficients [s^-order].
        delay: Tj·ξ [s]: the estimate refers to t - delay.
        root: True when ξ is a root of P_{q+1}^{(μ+k, κ+k)} (one more exact degree).
    """

    order: int
    window: float
    time_step: float
    kappa: float
    mu: float
    q: int
    xi: float
    taps: np.ndarray
    delay: float
    root: bool

    @property
    def num_taps(self) -> int:
        """N + 1, with N = window / time_step."""
        return int(self.taps.shape[0])

    @property
    def noise_gain(self) -> float:
        """‖taps‖₂ [s^-order]: output noise std per unit std of white input noise."""
        return float(np.linalg.norm(self.taps))

    @property
    def exact_degree(self) -> int:
        """Degree up to which the continuous estimator is exact (k+q, +1 at a root)."""
        return self.order + self.q + (1 if self.root else 0)


# --------------------------------------------------------------------------- design


def _check_integer(owner: str, name: str, value: Any, minimum: int) -> int:
    """Integer check where a non-integral real is a bad *value* (ValueError)."""
    if (
        isinstance(value, (float, np.floating))
        and np.isfinite(value)
        and not float(value).is_integer()
    ):
        raise ValueError(
            f"{owner}: {name} must be an integer >= {minimum}; got {value}."
        )
    return _validate.integer(owner, name, value, minimum=minimum)


def _check_shape(owner: str, kappa: Any, mu: Any, q: Any) -> tuple[float, float, int]:
    kappa = _validate.greater_than(owner, "kappa", kappa, -1.0)
    mu = _validate.greater_than(owner, "mu", mu, -1.0)
    for name, value in (("kappa", kappa), ("mu", mu)):
        if value > MAX_EXPONENT:
            _validate.fail(owner, f"{name} must be <= {MAX_EXPONENT:g}; got {value:g}.")
    q = _check_integer(owner, "q", q, 0)
    if q > MAX_Q:
        _validate.fail(owner, f"q must be an integer in [0, {MAX_Q}]; got {q}.")
    return kappa, mu, q


def _check_grid(owner: str, window: Any, time_step: Any) -> tuple[float, float, int]:
    time_step = _validate.positive(owner, "time_step", time_step, "s")
    window = _validate.positive(owner, "window", window, "s")
    ratio = window / time_step
    if not ratio < MAX_TAPS:
        _validate.fail(
            owner,
            f"window / time_step must be < {MAX_TAPS} (the filter's taps); got "
            f"{window:g} / {time_step:g} = {ratio:.3g}.",
        )
    intervals = _validate.multiple_of(owner, "window", window, "time_step", time_step)
    return window, time_step, intervals


def jacobi_minimum_delay_xi(order: int, *, kappa: float, mu: float, q: int) -> float:
    """Minimum-delay ξ that makes the estimator exact for degree order+q+1.

    ``ξ = (r+1)/2`` with r the smallest root of ``P_{q+1}^{(μ+k, κ+k)}`` on [-1, 1]
    (``scipy.special.roots_jacobi(q+1, μ+k, κ+k)``, ``core.orthopoly``). For q = 0
    this is ``(κ+k+1)/(κ+μ+2k+2)``. Dimensionless.
    """
    owner = "jacobi_minimum_delay_xi"
    order = _check_integer(owner, "order", order, 0)
    kappa, mu, q = _check_shape(owner, kappa, mu, q)
    roots, _ = gauss_jacobi(q + 1, mu + order, kappa + order)
    return float(np.clip((np.min(roots) + 1.0) / 2.0, 0.0, 1.0))


def _coefficients(order: int, kappa: float, mu: float, q: int, xi: float) -> np.ndarray:
    """C_i P_i^{(μ+k, κ+k)}(ξ), i = 0..q, with all Gamma arguments positive."""
    k = order
    out = np.empty(q + 1)
    for i in range(q + 1):
        if i == 0:  # (κ+μ+2k+1)Γ(κ+μ+2k+1) = Γ(κ+μ+2k+2), fine for κ+μ+2k+1 <= 0
            log_c = log_gamma(kappa + mu + 2 * k + 2)
            scale = 1.0
        else:
            log_c = log_gamma(kappa + mu + 2 * k + i + 1)
            scale = kappa + mu + 2 * k + 2 * i + 1
        log_c += (
            log_gamma(k + i + 1)
            - log_gamma(kappa + k + i + 1)
            - log_gamma(mu + k + i + 1)
        )
        jac = jacobi_polynomial(i, mu + k, kappa + k, 2.0 * xi - 1.0)
        out[i] = scale * np.exp(log_c) * jac
    return out


def _polynomial(tau: np.ndarray, order: int, kappa: float, mu: float, coeffs) -> Any:
    """Σ_i c_i P_{k+i}^{(μ, κ)}(τ): Q(τ) without its weight (1-τ)^μ τ^κ."""
    x = 2.0 * np.asarray(tau, dtype=float) - 1.0
    out = np.zeros_like(x)
    for i, c in enumerate(coeffs):
        out = out + c * jacobi_polynomial(order + i, mu, kappa, x)
    return out


def jacobi_kernel(
    tau: Any, order: int, *, kappa: float, mu: float, q: int, xi: float
) -> np.ndarray:
    """The continuous kernel Q(τ) of docs/MATH.md §1 (dimensionless), τ in [0, 1].

    ``Q(τ) = (1-τ)^μ τ^κ Σ_{i=0..q} C_i P_i^{(μ+k, κ+k)}(ξ) P_{k+i}^{(μ, κ)}(τ)``;
    the estimate is ``(-Tj)^(-k) ∫_0^1 Q(τ) x(t0 - Tj·τ) dτ``. Useful as an
    independent check of the taps and for plots.
    """
    owner = "jacobi_kernel"
    order = _check_integer(owner, "order", order, 0)
    kappa, mu, q = _check_shape(owner, kappa, mu, q)
    xi = _validate.in_range(owner, "xi", xi, 0.0, 1.0)
    tau = np.asarray(tau, dtype=float)
    coeffs = _coefficients(order, kappa, mu, q, xi)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.power(1.0 - tau, mu) * np.power(tau, kappa)
    return weight * _polynomial(tau, order, kappa, mu, coeffs)


def _gauss_jacobi_01(points: int, exponent: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes s and weights W with ∫_0^1 s^e f(s) ds ≈ Σ W f(s)."""
    x, w = gauss_jacobi(points, 0.0, exponent)
    return (x + 1.0) / 2.0, w / 2.0 ** (exponent + 1.0)


def _product_integration(
    intervals: int, order: int, kappa: float, mu: float, coeffs: np.ndarray
) -> np.ndarray:
    """∫_0^1 Q(τ) φ_j(τ) dτ for the hats φ_j at τ_j = j/N, j = 0..N."""
    n = intervals
    step = 1.0 / n
    points = 20 + (order + coeffs.size) // 2
    out = np.zeros(n + 1)

    def accumulate(left: np.ndarray, s: np.ndarray, values: np.ndarray) -> None:
        # values[..., p] already include the quadrature weights and the interval
        # length; s in [0, 1] is the position inside interval `left`.
        np.add.at(out, left, np.sum(values * (1.0 - s), axis=-1))
        np.add.at(out, left + 1, np.sum(values * s, axis=-1))

    if n == 1:  # one interval holds both singular ends: one Gauss-Jacobi rule
        x, w = gauss_jacobi(points, mu, kappa)
        s = (x + 1.0) / 2.0
        values = (
            w / 2.0 ** (mu + kappa + 1.0) * _polynomial(s, order, kappa, mu, coeffs)
        )
        accumulate(np.array([0]), s[None, :], values[None, :])
        return out

    # First interval [0, h]: τ = h·s, τ^κ = h^κ s^κ absorbed by the rule.
    s, w = _gauss_jacobi_01(points, kappa)
    tau = step * s
    f = np.power(1.0 - tau, mu) * _polynomial(tau, order, kappa, mu, coeffs)
    accumulate(np.array([0]), s[None, :], (step ** (kappa + 1.0) * w * f)[None, :])

    # Last interval [1-h, 1]: τ = 1 - h·s, (1-τ)^μ = h^μ s^μ absorbed by the rule.
    s, w = _gauss_jacobi_01(points, mu)
    tau = 1.0 - step * s
    f = np.power(tau, kappa) * _polynomial(tau, order, kappa, mu, coeffs)
    # position inside interval n-1 measured from its left end is 1 - s
    accumulate(
        np.array([n - 1]), (1.0 - s)[None, :], (step ** (mu + 1.0) * w * f)[None, :]
    )

    # Interior intervals: Gauss-Legendre on the full (smooth there) integrand.
    if n > 2:
        x, w = gauss_jacobi(points, 0.0, 0.0)
        s = (x + 1.0) / 2.0
        left = np.arange(1, n - 1)
        tau = (left[:, None] + s[None, :]) * step
        weight = np.power(1.0 - tau, mu) * np.power(tau, kappa)
        f = weight * _polynomial(tau, order, kappa, mu, coeffs)
        accumulate(left, np.broadcast_to(s, tau.shape), f * (w * step / 2.0))
    return out


def _design(
    owner: str,
    order: Any,
    window: Any,
    time_step: Any,
    kappa: Any,
    mu: Any,
    q: Any,
    xi: Any,
) -> JacobiFilter:
    order = _check_integer(owner, "order", order, 0)
    window, time_step, intervals = _check_grid(owner, window, time_step)
    kappa, mu, q = _check_shape(owner, kappa, mu, q)
    roots, _ = gauss_jacobi(q + 1, mu + order, kappa + order)
    root_xi = (roots + 1.0) / 2.0
    if xi is None:
        xi = float(np.clip(np.min(root_xi), 0.0, 1.0))
    else:
        xi = _validate.in_range(owner, "xi", xi, 0.0, 1.0)
    is_root = bool(np.any(np.abs(root_xi - xi) <= 1e-12))
    coeffs = _coefficients(order, kappa, mu, q, xi)
    integrals = _product_integration(intervals, order, kappa, mu, coeffs)
    window = intervals * time_step
    taps = (-1.0) ** order * window ** (-order) * integrals
    return JacobiFilter(
        order=order,
        window=window,
        time_step=time_step,
        kappa=kappa,
        mu=mu,
        q=q,
        xi=xi,
        taps=_read_only(taps),
        delay=window * xi,
        root=is_root,
    )


def jacobi_filter(
    order: int,
    window: float,
    time_step: float,
    *,
    kappa: float,
    mu: float,
    q: int,
    xi: float | None = None,
) -> JacobiFilter:
    """Designs the causal Jacobi FIR estimator of the ``order``-th derivative.

    ``x̂^(k)(t_n - Tj·ξ) = Σ_{j=0..N} taps[j] x_{n-j}``, N = Tj/h, with
    ``taps[j] = (-1)^k Tj^(-k) ∫_0^1 Q(τ) φ_j(τ) dτ`` (product integration, module
    docstring). Units: taps in [s^-k] (times the signal's unit), delay in [s].

    Args:
        order: Derivative order k >= 0 (0 = smoothed signal).
        window: Window length Tj [s], a whole multiple of ``time_step``.
        time_step: Sample period h > 0 [s].
        kappa: κ > -1, weight exponent of the newest end (larger: more delay).
        mu: μ > -1, weight exponent of the oldest end.
        q: Integer q >= 0: the fitted polynomial has degree k+q.
        xi: Normalised delay ξ in [0, 1], or None for the minimum-delay root of
            ``P_{q+1}^{(μ+k, κ+k)}`` (exact for one more degree).

    Returns:
        The immutable :class:`JacobiFilter` (taps, delay = window·ξ, parameters).

    Raises:
        ValueError: a parameter is out of range (names the parameter and value).
        TypeError: a parameter has the wrong type.
    """
    return _design("jacobi_filter", order, window, time_step, kappa, mu, q, xi)


def _check_orders(owner: str, orders: Any) -> tuple[int, ...]:
    if isinstance(orders, (str, bytes)) or not isinstance(orders, Sequence):
        raise TypeError(
            f"{owner}: orders must be a sequence of integers; got {orders!r}."
        )
    out = tuple(_check_integer(owner, "orders", k, 0) for k in orders)
    if not out:
        _validate.fail(owner, "orders must hold at least one order; got ().")
    if len(set(out)) != len(out):
        _validate.fail(owner, f"orders must be distinct; got {out}.")
    return out


def _design_bank(
    owner: str,
    orders: Any,
    window: Any,
    time_step: Any,
    kappa: Any,
    mu: Any,
    q: Any,
    xi: Any,
    matched: bool = False,
) -> tuple[JacobiFilter, ...]:
    orders = _check_orders(owner, orders)
    _check_grid(owner, window, time_step)
    kappa, mu, q = _check_shape(owner, kappa, mu, q)
    top = max(orders)
    if xi is None:
        roots, _ = gauss_jacobi(q + 1, mu + top, kappa + top)
        xi = float(np.clip((np.min(roots) + 1.0) / 2.0, 0.0, 1.0))
    # matched: order k uses (κ + K - k, μ + K - k), K the highest order, so that every
    # output is the same low-pass D⁰(κ+K, μ+K, q) applied to x^(k).
    shift = {k: (top - k if matched else 0) for k in orders}
    return tuple(
        _design(owner, k, window, time_step, kappa + shift[k], mu + shift[k], q, xi)
        for k in orders
    )


def jacobi_filters(
    orders: Sequence[int],
    window: float,
    time_step: float,
    *,
    kappa: float,
    mu: float,
    q: int,
    xi: float | None = None,
    matched: bool = False,
) -> tuple[JacobiFilter, ...]:
    """Designs a bank of Jacobi filters that all refer to the same instant t - Tj·ξ.

    Every order uses the same q, Tj and the same ξ, so the estimates
    ``x̂^(k)(t - Tj·ξ)`` are time-aligned. ``xi=None`` takes the minimum-delay root
    of the HIGHEST requested order K (exact for degree K+q+1 for that order).
    Arguments as :func:`jacobi_filter`.

    With ``matched=False`` every order uses the same κ, μ (the lower orders stay
    exact for degree k+q). With ``matched=True`` order k uses κ + K - k and
    μ + K - k. By the Mboup-Join-Fliess identity (the order-k estimate is the
    weighted least-squares projection of x^(k) on degree-q polynomials with weight
    τ^(κ+k)(1-τ)^(μ+k)),

        D^(k)_{κ+K-k, μ+K-k, q}[x] = D^(0)_{κ+K, μ+K, q}[x^(k)]       (continuous time),

    so every output is the SAME low-pass filter F = D^(0)_{κ+K, μ+K, q} applied to
    the k-th derivative: x̂ = F*x, x̂' = F*ẋ, ... Signals processed this way keep
    every linear relation between them (e.g. τ = J q̈ + F_v q̇ holds exactly between
    the filtered signals), which removes a bias of the identification equations
    that the unmatched bank leaves (about 1 % at ωTj ≈ 1). Same ξ for every order.

    Returns:
        One :class:`JacobiFilter` per entry of ``orders``, in the given order.
    """
    return _design_bank(
        "jacobi_filters", orders, window, time_step, kappa, mu, q, xi, matched
    )


# ------------------------------------------------------------------ tuning helpers


def jacobi_frequency_response(filt: JacobiFilter, omega: Any) -> np.ndarray:
    """Exact frequency response of the discrete filter.

    ``H(ω) = Σ_j taps[j] e^{-iωjh}`` for angular frequencies ``omega`` [rad/s];
    the ideal (delayed differentiator) response is ``(iω)^k e^{-iω·delay}``.
    """
    _validate.instance(
        "jacobi_frequency_response", "filt", filt, JacobiFilter, "a JacobiFilter"
    )
    omega = _validate.array("jacobi_frequency_response", "omega", omega)
    lags = np.arange(filt.num_taps) * filt.time_step
    return np.exp(-1j * np.multiply.outer(omega, lags)) @ filt.taps


def jacobi_sinusoid_error(filt: JacobiFilter, omega: Any) -> np.ndarray:
    """Steady-state error amplitude for a unit sinusoid, ``|H(ω) - (iω)^k e^{-iωδ}|``.

    For ``x = A sin(ωt)`` the estimate of ``x^(k)(t - δ)`` (δ = delay [s]) has an
    error of amplitude ``A·jacobi_sinusoid_error(filt, ω)`` [unit·s^-k]: the bias
    part of the error budget (the noise part is ``σ·filt.noise_gain``).
    """
    _validate.instance(
        "jacobi_sinusoid_error", "filt", filt, JacobiFilter, "a JacobiFilter"
    )
    omega = _validate.array("jacobi_sinusoid_error", "omega", omega)
    ideal = (1j * omega) ** filt.order * np.exp(-1j * omega * filt.delay)
    return np.abs(jacobi_frequency_response(filt, omega) - ideal)
