"""The set-up of Guo, Perruquetti & Gautier (AIM 2014, §V) for examples and benchmarks.

* The 2R arm: ``model_path("planar_2r")`` (horizontal plane, L1 = 1 m), base parameters
  :data:`BASE_NAMES` with true values :data:`TRUE_VALUES` (SI units).
* The paper's Table II: :data:`TABLE2_OFFLINE` (off-line IDIM) and :data:`TABLE2_ONLINE`
  (on-line power model + modulating functions, T = 20 s, SNR 30 dB). These are single
  runs of an unspecified trajectory: compare them with medians over noise seeds.
* :func:`paper_trajectory`: the documented exciting trajectory used by the examples and
  the accuracy benchmark (the paper's is "random", not given).
* :func:`zz1_jump`: the Fig. 4 event (ZZ1R jumps from 3.9 to 4.5 at t = 9.4 s).

Pure numpy (no pydrake import at module level).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from drake_dynid.core.trajectory import FourierTrajectory

__all__ = [
    "BASE_NAMES",
    "TABLE2_OFFLINE",
    "TABLE2_ONLINE",
    "TRUE_VALUES",
    "paper_trajectory",
    "zz1_jump",
]

#: Base parameters of the paper's 2R arm (paper §V).
BASE_NAMES = ("ZZ1R", "ZZ2", "MX2", "MY2", "FV1", "FC1", "FV2", "FC2")
#: True values [kg·m², kg·m², kg·m, kg·m, N·m·s/rad, N·m, N·m·s/rad, N·m].
TRUE_VALUES = np.array([3.9, 0.25, 0.45, 0.1, 0.3, 0.4, 0.15, 0.25])
#: Paper Table II, off-line IDIM column.
TABLE2_OFFLINE = np.array(
    [3.8959, 0.2528, 0.4441, 0.0967, 0.2840, 0.4436, 0.1484, 0.2645]
)
#: Paper Table II, on-line column (power model, modulating functions, T = 20 s).
TABLE2_ONLINE = np.array(
    [3.8855, 0.2499, 0.4524, 0.0961, 0.2917, 0.4382, 0.1472, 0.2623]
)


def paper_trajectory(
    seed: int = 2014,
    *,
    max_velocity: float = 5.0,
    period: float = 40.0,
    lowest_harmonic: int = 4,
    highest_harmonic: int = 24,
) -> FourierTrajectory:
    """The documented exciting trajectory of the examples and benchmarks.

    A finite Fourier series per joint (docs/MATH.md §7),
    q_j(t) = Σ_l [a_jl/(lω_f) sin(lω_f t) - b_jl/(lω_f) cos(lω_f t)], ω_f = 2π/period,
    with only the harmonics
    ``lowest_harmonic..highest_harmonic`` (0.1-0.6 Hz by default: every 20 s window
    sees energy at the modulating frequencies of the bank) and random coefficients
    a_jl, b_jl ~ N(0, 1)/√l drawn from ``numpy.random.default_rng(seed)`` (a first,
    then b), each joint scaled so that max_t |q̇_j| = ``max_velocity`` [rad/s]
    (the paper: velocities up to about ±5 rad/s).

    With the defaults: |v| ≤ 5 rad/s, rms velocity ≈ 1.9 rad/s, |v̇| ≤ 10 rad/s²,
    std(q) ≈ 1.4 rad, 11 and 17 velocity sign changes per 20 s.

    Args:
        seed: seed of the coefficients.
        max_velocity: largest joint speed [rad/s].
        period: period of the series [s].
        lowest_harmonic: first non-zero harmonic (>= 1).
        highest_harmonic: last harmonic.

    Returns:
        The trajectory (n = 2 joints, q(0) offsets 0).
    """
    if not 1 <= lowest_harmonic <= highest_harmonic:
        raise ValueError(
            "paper_trajectory: need 1 <= lowest_harmonic <= highest_harmonic; got "
            f"{lowest_harmonic} and {highest_harmonic}."
        )
    rng = np.random.default_rng(seed)
    harmonics = np.arange(1, highest_harmonic + 1)
    weight = (harmonics >= lowest_harmonic) / np.sqrt(harmonics)
    a = rng.normal(size=(2, highest_harmonic)) * weight
    b = rng.normal(size=(2, highest_harmonic)) * weight
    omega = 2.0 * math.pi / period
    unit = FourierTrajectory(np.zeros(2), a, b, omega)
    _, velocity, _ = unit.evaluate(np.arange(0.0, period, 1e-3))
    scale = max_velocity / np.max(np.abs(velocity), axis=0)
    return FourierTrajectory(np.zeros(2), a * scale[:, None], b * scale[:, None], omega)


def zz1_jump(delta: float = 0.6) -> Callable[[Any, Any], None]:
    """Event callback of Fig. 4: adds ``delta`` [kg·m²] to ZZ1 (hence to ZZ1R).

    Returns ``callback(plant, plant_context)`` for the ``events`` argument of
    :func:`drake_dynid.diagrams.simulate_identification`. It raises link 1's central
    inertia about z by ``delta`` (and about y, to keep the inertia physically valid;
    the planar motion does not see XX1, YY1).
    """

    def callback(plant: Any, context: Any) -> None:
        from pydrake.multibody.tree import RotationalInertia, SpatialInertia

        body = plant.GetBodyByName("link1")
        current = body.CalcSpatialInertiaInBodyFrame(context)
        mass = current.get_mass()
        com = current.get_com()
        central = current.Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
        central = central + np.diag([0.0, delta, delta])
        updated = SpatialInertia.MakeFromCentralInertia(
            mass, com, RotationalInertia(*np.diag(central), 0.0, 0.0, 0.0)
        )
        body.SetSpatialInertiaInBodyFrame(context, updated)

    return callback
