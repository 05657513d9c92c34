r"""The power model's noise bias and its compensation (docs/MATH.md §3).

White position noise of std σ_q,j on joint j reaches the model rows through the
estimated signals: the velocity v̂_j = v_j + e_j with Var e_j = σ_v,j² =
σ_q,j²·‖c₁‖₂² (c₁ the velocity taps: the matched Jacobi filter's, or the raw rows'
central estimator's, ``JacobiFilter.noise_gain`` [1/s]) and the position
q̂_j = q_j + d_j with Var d_j = σ_q̂,j² = σ_q,j²·‖c₀‖₂² (the smoothing taps; raw
rows: c₀ = 1). e_j and d_j are uncorrelated, Σ c₀c₁ ≈ 0: the matched bank's c₁ is
the derivative of c₀'s kernel (c₁∗x = c₀∗ẋ), so Σ c₀c₁ ≈ ½∫ d(c₀²) = 0 (c₀ vanishes
at both ends; the taps are not symmetric, ξ ≠ ½), and the raw rows' c₁ is
antisymmetric about c₀'s one sample. Different joints' noises are independent.

The power model's rows are not linear in these signals, so their expectation is
biased. With the energy h(q, v) = h_U(q) + ½ vᵀM(q)v (in regressor form, per
parameter column) and the friction power columns:

    E[h(q̂, v̂)]       = h(q, v) + Σ_a ½σ_v,a² M_aa(q) + Σ_a ½σ_q̂,a² ∂²h/∂q_a²  + O(σ⁴)
    E[v̂_j²]          = v_j² + σ_v,j²                                   (viscous)
    E[v̂_j s(v̂_j)]    = v_j s(v_j) + b_j(v_j)                            (Coulomb)
    E[v̂_j]           = v_j                                             (offset)
    E[v̂ᵀτ̂]           = vᵀτ                          (τ noise independent of q's)

with b_j(v) = E[x s(x)] - v s(v), x ~ N(v, σ_v,j²): for s = sign (a dead zone of
half-width w: s = 0 for |x| <= w, w = 0 the exact sign), with Φ, φ the standard
normal cdf and pdf and u± = (w ∓ v)/σ,

    E[x s(x)] = v (Φ(-u₊) - Φ(-u₋)) + σ (φ(u₊) + φ(u₋))

(E|x| = v erf(v/(σ√2)) + 2σφ(v/σ) for w = 0), and Gauss-Hermite quadrature for
any other law (tanh). The compensated rows subtract these biases evaluated at the
measured signals (plug-in): the energy terms by symmetric differences of the
provider's own energy rows (exact for the quadratic velocity terms),

    ΔD = Σ_a ( h(q̂, σ_v,a u_a) - h(q̂, 0) )
       + Σ_a ( ½[h(q̂ + σ_q̂,a u_a, v̂) + h(q̂ - σ_q̂,a u_a, v̂)] - h(q̂, v̂) )

(u_a the unit vector of joint a; the kinetic energy has no term linear in v), the
friction columns by the formulas above: 3n + 1 evaluations of the energy rows
per sample (n + 1 when σ_q̂ = 0). The
plug-in leaves O(σ⁴) in the energy and, in the Coulomb column near a velocity
reversal, a residual b - b∗N(0, σ²) whose integral over v is zero: the modulated
integral of a reversal at acceleration a, ∫ g b(v(t)) dt ≈ g(t_c)∫b dv/|a|, is
removed to first order.

What it does and does not do (benchmarks/bench_accuracy.py, the paper's 2R at SNR
30 dB, 200 seeds; README Accuracy, docs/MATH.md §3): it removes most of the noise's
*mean* effect on the power equations (the mean squared bias of the columns, in units
of their Monte-Carlo error, falls from 24-166 to 0.6-2.8), but the median error of
one run is dominated by the noise's *spread* (frequency weighting: std over seeds
11.5-56 % per friction parameter against a mean friction error of 5.2 %), which no
bias correction reduces.

Only the power model's rows are compensated; the Lagrangian rows pass unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.friction import (
    FRICTION_PREFIX,
    DeadZoneSign,
    ExactSign,
    SignLaw,
)

__all__ = [
    "NoiseCompensatedRows",
    "coulomb_power_mean",
    "noise_compensated_rows",
    "rows_for_settings",
]

_OWNER = "NoiseCompensatedRows"
_HERMITE = np.polynomial.hermite_e.hermegauss(40)  # nodes, weights for N(0, 1)


def _normal_cdf(x: np.ndarray) -> np.ndarray:
    from scipy.special import ndtr

    return np.asarray(ndtr(x))


def _normal_pdf(x: np.ndarray) -> np.ndarray:
    return np.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)


def coulomb_power_mean(v: Any, sigma: Any, sign: SignLaw) -> np.ndarray:
    """E[x s(x)] for x ~ N(v, σ²), elementwise [rad/s or m/s].

    Closed form for the exact sign and a dead zone (module docstring), 40-point
    Gauss-Hermite quadrature for any other law. σ = 0 gives v s(v).

    Args:
        v: (N, n) velocities.
        sigma: (n,) noise std per column, >= 0.
        sign: the Coulomb law s.
    """
    v = np.asarray(v, dtype=float)
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), v.shape[-1:])
    exact = v * sign(v)
    if isinstance(sign, (ExactSign, DeadZoneSign)):
        width = 0.0 if isinstance(sign, ExactSign) else np.asarray(sign.width)
        width = np.broadcast_to(width, v.shape[-1:])
        safe = np.where(sigma > 0.0, sigma, 1.0)
        upper, lower = (width - v) / safe, (width + v) / safe
        mean = v * (_normal_cdf(-upper) - _normal_cdf(-lower)) + safe * (
            _normal_pdf(upper) + _normal_pdf(lower)
        )
        return np.where(sigma > 0.0, mean, exact)
    nodes, weights = _HERMITE
    x = v[..., None] + sigma[:, None] * nodes
    mean = (x * sign(x)) @ weights / math.sqrt(2.0 * math.pi)
    return np.where(sigma > 0.0, mean, exact)


@dataclass(frozen=True, eq=False)
class NoiseCompensatedRows:
    """A row provider whose power-model rows have their noise bias removed.

    Wraps a provider (``core.rows.RowProvider``); ``model_rows("power", ...)``
    returns the rows minus the bias of the module docstring, evaluated at the
    given signals; the Lagrangian rows pass unchanged. Build it with
    :func:`noise_compensated_rows`.

    Attributes:
        rows: the wrapped provider (with ``friction``, ``sign`` and the friction
            columns named ``FV<j>``, ``FC<j>``, ``OFF<j>``).
        velocity_std: (n,) σ_v,j of the rows' velocity [rad/s or m/s].
        position_std: (n,) σ_q̂,j of the rows' position [rad or m].
    """

    rows: Any
    velocity_std: np.ndarray
    position_std: np.ndarray
    columns: tuple[tuple[int, int, int], ...]  # (joint, kind index, column)

    @property
    def num_joints(self) -> int:
        """n, the joints."""
        return int(self.rows.num_joints)

    @property
    def num_parameters(self) -> int:
        """p, the base parameters."""
        return int(self.rows.num_parameters)

    @property
    def names(self) -> tuple[str, ...]:
        """The p base-parameter names."""
        return tuple(self.rows.names)

    def model_rows(self, kind: str, q: Any, v: Any, tau: Any) -> Any:
        """``(D, G, y)`` of the wrapped provider, the power rows compensated."""
        d_rows, g_rows, y = self.rows.model_rows(kind, q, v, tau)
        if kind != "power":
            return d_rows, g_rows, y
        q = np.atleast_2d(np.asarray(q, dtype=float))
        v = np.atleast_2d(np.asarray(v, dtype=float))
        tau = np.atleast_2d(np.asarray(tau, dtype=float))
        single = np.ndim(d_rows) == 2
        d_rows = np.array(d_rows, dtype=float).reshape(len(q), 1, -1)
        g_rows = np.array(g_rows, dtype=float).reshape(len(q), 1, -1)
        d_rows[:, 0] -= self._energy_bias(q, v, d_rows[:, 0])
        g_rows[:, 0] -= self._friction_bias(v)
        if single:
            return d_rows[0], g_rows[0], y
        return d_rows, g_rows, y

    def _energy_bias(self, q, v, energy) -> np.ndarray:
        """(N, p) ΔD of the module docstring, one batch call to the provider.

        The kinetic energy has no term linear in v, so the velocity part needs
        h(q̂, σ_v,a u_a) - h(q̂, 0) only (n + 1 evaluations); the position part
        (2n more) is skipped when every σ_q̂ is 0.
        """
        count, n = q.shape
        eye = np.eye(n)
        shifts = [self.velocity_std[:, None] * eye, np.zeros((1, n))]
        blocks_q = [np.broadcast_to(q[:, None, :], (count, n + 1, n))]
        blocks_v = [np.broadcast_to(np.concatenate(shifts)[None], (count, n + 1, n))]
        moved = bool(np.any(self.position_std > 0.0))
        if moved:
            position = self.position_std[:, None] * eye
            blocks_q.append(q[:, None, :] + np.concatenate([position, -position]))
            blocks_v.append(np.broadcast_to(v[:, None, :], (count, 2 * n, n)))
        q_all = np.concatenate(blocks_q, axis=1).reshape(-1, n)
        v_all = np.concatenate(blocks_v, axis=1).reshape(-1, n)
        h = np.asarray(
            self.rows.model_rows("power", q_all, v_all, np.zeros_like(q_all))[0]
        )
        h = h.reshape(count, -1, self.num_parameters)
        bias = h[:, :n].sum(axis=1) - n * h[:, n]  # Σ_a ½σ_v,a² M_aa(q̂)
        if moved:
            bias += 0.5 * h[:, n + 1 :].sum(axis=1) - n * energy
        return bias

    def _friction_bias(self, v) -> np.ndarray:
        """(N, p) the friction power columns' bias at the measured velocities."""
        out = np.zeros((len(v), self.num_parameters))
        sign = self.rows.sign
        coulomb = None
        for joint, kind, column in self.columns:
            sigma = self.velocity_std[joint]
            if kind == 0:  # viscous: E[v̂²] - v̂² = σ²
                out[:, column] = sigma**2
            elif kind == 1:  # Coulomb
                if coulomb is None:
                    coulomb = coulomb_power_mean(v, self.velocity_std, sign) - v * sign(
                        v
                    )
                out[:, column] = coulomb[:, joint]
        return out


_KINDS = {"viscous": 0, "coulomb": 1, "offset": 2}


def noise_compensated_rows(
    rows: Any, velocity_std: Any, position_std: Any
) -> NoiseCompensatedRows:
    """The power rows of ``rows`` with the bias of white position noise removed.

    Args:
        rows: a row provider with ``friction`` (kinds), ``sign`` (the Coulomb
            law) and friction columns named ``FV<j>``, ``FC<j>``, ``OFF<j>``
            (``RobotModel``, ``Planar2RRows``); a drive with motor friction
            columns is not supported.
        velocity_std: σ_v,j of the rows' velocity per joint (or one for all)
            [rad/s or m/s], >= 0.
        position_std: σ_q̂,j of the rows' position per joint [rad or m], >= 0.

    Raises:
        ValueError: bad standard deviations, or a provider whose friction columns
            cannot be located.
    """
    n = int(rows.num_joints)
    stds = []
    for name, value, unit in (
        ("velocity_std", velocity_std, "rad/s or m/s"),
        ("position_std", position_std, "rad or m"),
    ):
        array = np.broadcast_to(np.asarray(value, dtype=float), (n,)).copy()
        if not np.all(np.isfinite(array)) or np.any(array < 0.0):
            _validate.fail(
                _OWNER, f"{name} must be finite and >= 0 [{unit}]; got {value!r}."
            )
        array.flags.writeable = False
        stds.append(array)
    friction = tuple(getattr(rows, "friction", ()))
    if getattr(rows, "drive", None) is not None or not hasattr(rows, "sign"):
        _validate.fail(
            _OWNER,
            "rows must be a provider with joint friction columns and a Coulomb "
            "law (a RobotModel without a drive, or Planar2RRows); got "
            f"{type(rows).__name__}"
            + (" with a drive" if getattr(rows, "drive", None) is not None else "")
            + ".",
        )
    names = {name: k for k, name in enumerate(rows.names)}
    columns = []
    for joint in range(n):
        for kind in friction:
            name = f"{FRICTION_PREFIX[kind]}{joint + 1}"
            if name not in names:
                _validate.fail(
                    _OWNER,
                    f"rows must name the friction column of joint {joint + 1} "
                    f"{kind!r} {name!r}; its friction names are "
                    f"{_validate.listed(_friction_names(rows.names)) or 'none'}.",
                )
            columns.append((joint, _KINDS[kind], names[name]))
    return NoiseCompensatedRows(rows, stds[0], stds[1], tuple(columns))


def _friction_names(names: Any) -> list[str]:
    """The names of ``names`` that are a joint's friction column (FVj, FCj, OFFj)."""
    prefixes = tuple(FRICTION_PREFIX.values())
    return [
        name
        for name in names
        if name.startswith(prefixes) and name.lstrip("FVCO").isdigit()
    ]


def rows_for_settings(settings: Any, rows: Any, time_step: float) -> Any:
    """``rows`` compensated for ``settings.position_noise`` σ_q (power model).

    The rows' velocity noise is σ_q times the noise gain of the velocity estimate
    (the matched Jacobi filter, or the raw rows' central estimator), their
    position noise σ_q times the smoothing filter's gain (1 for the raw rows), on
    the grid of ``time_step`` (``OnlineSettings.row_provider``).
    """
    sigma = settings.position_noise
    if sigma is None or settings.model != "power":
        return rows
    n = int(rows.num_joints)
    sigma = np.asarray(sigma, dtype=float)
    if sigma.ndim == 1 and sigma.size != n:
        _validate.fail(
            "OnlineSettings",
            f"position_noise must hold one std per joint ({n}) or one for all [rad "
            f"or m]; got {sigma.size} values.",
        )
    sigma = np.broadcast_to(sigma, (n,))
    if settings.rows_from == "raw":
        velocity_gain = settings.raw_design(time_step).velocity.noise_gain
        position_gain = 1.0
    else:
        smooth, velocity = settings.jacobi_filters(time_step)
        velocity_gain, position_gain = velocity.noise_gain, smooth.noise_gain
    return noise_compensated_rows(rows, sigma * velocity_gain, sigma * position_gain)
