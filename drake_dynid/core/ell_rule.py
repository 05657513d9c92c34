"""How many modulating functions a model needs: the default ℓ set's two rules.

The default ℓ set (``OnlineSettings.ell``, docs/MATH.md §3) is the integers
ℓ = 0, 1, ... with (ℓ + k)/T up to a band, extended to at least a count of
functions. Both depend on the model:

* **Band** (:func:`model_band`). The Lagrangian rows are linear in the torque and
  carry the motion's band B. The power model's rows are products of two band-B
  signals (the energy ½ vᵀM(q)v, the input power vᵀτ, the friction power v²):
  they carry frequencies up to 2B, and the power model's set covers
  :data:`POWER_BAND_FACTOR`·B. On the paper's 2R at SNR 30 dB (the seven
  geometries and trajectories of benchmarks/bench_accuracy.py, 40 seeds, the
  frequency weighting without noise compensation) this lowers the inertial
  error on every one (mean 5.1 → 3.6 %) and the friction error on average
  (mean 53 → 38 %: the worst two, 111 and 130 %, become 41 and 85 %), but not
  everywhere (two random-Fourier trajectories go from 25 and 29 % to 29 and
  35 %). 3B (the inertia M(q) adds the configuration's band) is about the same
  (inertial 3.9 %, friction 36 %).
* **Count** (:func:`functions_for_rows`). Each integer ℓ gives two independent
  real rows per equation (m = 1 for the power model, n for the Lagrangian): a
  window needs m·2L >= p + ``core.row_noise.MIN_RESIDUAL_DOF`` rows for an honest
  σ, and in practice about twice that (on the iiwa7 benchmark log of
  benchmarks/_arm7.py, T = 20 s, a 7-DOF power model's scaled condition number
  is 4.7e5 with 40 functions, 1.3e5 with 50 and 3.0e4 with 60: its high rows
  carry little of the motion). The rule asks for :data:`ROWS_PER_UNKNOWN` times
  the rows needed, i.e. L >= ⌈ROWS_PER_UNKNOWN·(p + MIN_RESIDUAL_DOF)/(2m)⌉.
  It changes nothing for the Lagrangian model on a 7-DOF arm (9 functions for
  p = 57, n = 7; the band already gives 10 at T = 20 s) nor for the 2R; it gives
  the power model 61 functions on a 7-DOF arm (p = 57).

With the covariance weighting (``OnlineSettings.weighting``, ``core.row_covariance``)
the set is every integer ℓ the limit below allows: the generalised least squares
weighs each row by its modelled noise and correlation, so rows where the noise
dominates cost nothing, and the high rows still carry information (the Coulomb
term's |v| is broadband). On the paper's 2R at SNR 30 dB (the main scenario of
benchmarks/bench_accuracy.py, 100 seeds, the noise stds measured on each log) the
power model's median friction error is 9.4 % with every function up to the 0.2 s
Jacobi window's pass band, 5.8 Hz (116: the defaults), 12.0 % with that set cut
at 3.9 Hz (78) and 10.4 % with a 0.3 s Jacobi window (77, up to its 3.9 Hz pass
band), where the frequency weighting (noise bias compensated) is 22.4 % with its
2B set (24 functions; 21.9 % with the 0.3 s window).

The limit (:func:`functions_that_fit`): every function must stay inside the
differentiator's pass band and below the bank's Nyquist frequency, at most
``core.fourier_bank.MAX_FUNCTIONS``: L <= ⌊f_max·T⌋ - k + 1. When the count rule
asks for more, the set stops there and ``OnlineSettings.for_log`` reports the
shortfall (lengthen the window or shorten the Jacobi window).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from drake_dynid.core.fourier_bank import MAX_FUNCTIONS, MIN_FUNCTIONS

__all__ = [
    "POWER_BAND_FACTOR",
    "ROWS_PER_UNKNOWN",
    "for_robot",
    "functions_for_rows",
    "functions_that_fit",
    "independent_rows",
    "model_band",
    "resolve_functions",
    "rows_count",
    "rows_remedy",
    "usable_frequency",
]

#: The power model's default ℓ set covers this multiple of the motion's band B
#: (its rows are products of velocities, torques and the inertia: module docstring).
POWER_BAND_FACTOR = 2.0

#: The default ℓ set gives at least this many times the rows a window needs
#: (p + MIN_RESIDUAL_DOF) when the band alone gives fewer.
ROWS_PER_UNKNOWN = 2.0


def model_band(model: str, bandwidth: float) -> float:
    """The band [Hz] the default ℓ set of ``model`` covers for a motion band B [Hz].

    ``POWER_BAND_FACTOR·B`` for the power model, B for the Lagrangian model.
    """
    return bandwidth * (POWER_BAND_FACTOR if model == "power" else 1.0)


def functions_for_rows(num_equations: int, num_parameters: int) -> int:
    """The count rule: ⌈ROWS_PER_UNKNOWN·(p + MIN_RESIDUAL_DOF)/(2m)⌉, >= MIN_FUNCTIONS.

    Args:
        num_equations: m, equations per sample (1 power, n Lagrangian).
        num_parameters: p, the base parameters.
    """
    from drake_dynid.core.row_noise import MIN_RESIDUAL_DOF

    needed = ROWS_PER_UNKNOWN * (num_parameters + MIN_RESIDUAL_DOF)
    return max(MIN_FUNCTIONS, math.ceil(needed / (2.0 * num_equations) - 1e-9))


def functions_that_fit(window: float, order: int, top_frequency: float) -> int:
    """The most integer ℓ = 0, 1, ... with (ℓ + k)/T <= ``top_frequency`` [Hz].

    At most ``MAX_FUNCTIONS``; at least 1.

    Args:
        window: T [s].
        order: k.
        top_frequency: the highest usable frequency [Hz] (the differentiator's
            pass band, the bank's Nyquist frequency).
    """
    count = math.floor(top_frequency * window - order + 1e-9) + 1
    return max(1, min(MAX_FUNCTIONS, count))


def independent_rows(settings: Any) -> int:
    """Independent real rows per equation of the settings' ℓ set.

    Integer ℓ: the exact rank of the rows on the Fourier lines, whose real and
    imaginary parts cos(νω0 s), sin(νω0 s) of integer ν are orthogonal over the
    window: two per ℓ >= 0 (fewer where ℓ and -ℓ - k give the same lines). Their
    noise correlation (``FourierBank.row_correlation``) is full rank but not well
    conditioned, as adjacent g_ℓ share lines: its smallest eigenvalue falls like
    L^(-2k) (7e-4 of the largest for 29 functions, k = 1), so a numerical rank
    would count fewer rows than the set has and refuse the very set its message
    asks for. Any other set: the numerical rank of that correlation (eigenvalues
    above 1e-3 of the largest), fewer than two per ℓ for a fine grid such as the
    paper's ℓ = 0:0.05:10, whose neighbours repeat each other.
    """
    bank = settings.bank()
    if np.all(bank.ell == np.round(bank.ell)):
        return int(np.linalg.matrix_rank(_line_coefficients(bank)))
    correlation = bank.row_correlation()
    eigenvalues = np.linalg.eigvalsh(correlation)
    return int(np.count_nonzero(eigenvalues > 1e-3 * eigenvalues.max()))


def _line_coefficients(bank: Any) -> np.ndarray:
    """(rows of one equation, lines): the rows of integer ℓ on cos/sin(|ν|ω0 s).

    Re(w e^{-jνθ}) = Re(w) cos(|ν|θ) + sgn(ν) Im(w) sin(|ν|θ) and
    Im(w e^{-jνθ}) = Im(w) cos(|ν|θ) - sgn(ν) Re(w) sin(|ν|θ), θ = ω0 s.
    """
    weights = bank.coefficient_matrix(0)  # (L, K) on the lines ν of bank.nu
    magnitude = np.abs(np.round(bank.nu)).astype(int)
    sign = np.sign(bank.nu)
    lines = int(magnitude.max()) + 1
    real = np.zeros((bank.num_functions, 2 * lines))
    imaginary = np.zeros_like(real)
    for column, (nu, s) in enumerate(zip(magnitude, sign, strict=True)):
        w = weights[:, column]
        real[:, nu] += w.real
        real[:, lines + nu] += s * w.imag
        imaginary[:, nu] += w.imag
        imaginary[:, lines + nu] -= s * w.real
    rows = np.stack([real, imaginary], axis=1)[bank.row_mask]
    return rows[:, np.r_[0:lines, lines + 1 : 2 * lines]]  # sin(0) is no line


def rows_count(settings: Any, independent: int, m: int) -> str:
    """How ``m·independent`` rows come about, for the row-count messages.

    ``"4 modulating functions x 2 rows x 1 equation of the power model"`` for
    integer ℓ (two real rows per function and equation); for a set whose
    neighbours repeat each other (the paper's ℓ = 0:0.05:10) ``"201 modulating
    functions whose neighbouring ℓ repeat each other: 23 independent rows x 1
    equation of the power model"``. Each factor multiplies to the count.

    Args:
        settings: the settings (its ℓ set and model).
        independent: :func:`independent_rows` of ``settings``.
        m: equations per sample.
    """
    ell = np.asarray(settings.ell())
    functions = len(ell)
    why = (
        "ℓ and -ℓ - k give the same rows"
        if np.all(ell == np.round(ell))
        else "neighbouring ℓ repeat each other"
    )
    parts = (
        f"{functions} modulating functions x 2 rows"
        if independent == 2 * functions
        else f"{functions} modulating functions whose {why}: {independent} "
        "independent rows"
    )
    return f"{parts} x {m} equation{'s' if m > 1 else ''} of the {settings.model} model"


def usable_frequency(settings: Any, time_step: float) -> float:
    """The highest frequency a modulating function may have [Hz].

    min(the differentiator's pass band, the bank's Nyquist frequency) of
    ``settings`` on the grid of ``time_step`` (``core.online_checks.pass_band``).
    """
    from drake_dynid.core.online_checks import pass_band

    return min(
        pass_band(settings, time_step), 0.5 / settings.resolved("bank_time_step")
    )


def rows_remedy(
    settings: Any, time_step: float, needed: float, m: int, say: Any = str
) -> str:
    """What to change so that the ℓ set gives ``needed`` independent rows.

    The integer ℓ = 0..L-1 needed (L = ⌈needed/(2m)⌉) and their top frequency;
    when that is above what the differentiator passes, the window that would
    hold them. ``say`` maps a field to the name shown (``dynid identify``: its
    options).
    """
    count = math.ceil(needed / (2.0 * m) - 1e-9)
    top = (count - 1 + settings.order) / settings.window
    usable = usable_frequency(settings, time_step)
    if top <= usable:
        return (
            f"use at least {count} integer ℓ ({say('frequencies')} 0:1:{count - 1}, "
            f"up to {top:.3g} Hz with {say('window')} {settings.window:g} s; the "
            f"differentiator passes {usable:.3g} Hz)"
        )
    window = (count - 1 + settings.order) / usable
    return (
        f"{count} integer ℓ would reach {top:.3g} Hz with {say('window')} "
        f"{settings.window:g} s, above the {usable:.3g} Hz the differentiator "
        f"passes: lengthen {say('window')} to at least {window:.3g} s or shorten "
        f"{say('jacobi_window')}"
    )


def resolve_functions(grid: Any, time_step: float, n: int, p: int) -> Any:
    """``grid`` with ``min_functions`` None set by the count rule (module docstring).

    min(:func:`functions_for_rows`, :func:`functions_that_fit` below
    :func:`usable_frequency`), at least ``MIN_FUNCTIONS``; with the covariance
    weighting every function that fits (module docstring); unchanged when
    ``frequencies`` or ``min_functions`` is given. ``grid`` is on the grid of
    ``time_step`` (``OnlineSettings.on_grid``).
    """
    if grid.frequencies is not None or grid.min_functions is not None:
        return grid
    top = usable_frequency(grid, time_step)
    fit = functions_that_fit(grid.window, grid.order, top)
    wanted = min(functions_for_rows(grid.num_equations(n), p), fit)
    if grid.weighting == "covariance":
        wanted = fit
    return dataclasses.replace(grid, min_functions=max(MIN_FUNCTIONS, wanted))


def for_robot(settings: Any, time_step: float, n: int, p: int) -> Any:
    """``OnlineSettings.for_robot``: the grid, the count rule, the row count."""
    from drake_dynid.core import _validate

    owner = "OnlineSettings"
    n = _validate.integer(owner, "num_joints", n, minimum=1)
    p = _validate.integer(owner, "num_parameters", p, minimum=1)
    grid = settings.on_grid(time_step)
    for field, unit in (("position_noise", "rad or m"), ("torque_noise", "N·m or N")):
        noise = getattr(grid, field)
        if noise is not None and np.ndim(noise) == 1 and len(noise) != n:
            _validate.fail(
                owner,
                f"{field} must hold one std per joint ({n}) or one for all [{unit}]; "
                f"got {len(noise)} values.",
            )
    grid = resolve_functions(grid, time_step, n, p)
    m = grid.num_equations(n)
    independent = independent_rows(grid)
    rows = m * independent
    if rows < p:
        _validate.fail(
            owner,
            f"the ℓ set gives {rows} independent rows "
            f"({rows_count(grid, independent, m)}) for {p} parameters: no window "
            "can identify them; "
            + rows_remedy(grid, time_step, float(p), m)
            + (", or use the lagrangian model." if grid.model == "power" else "."),
        )
    return grid
