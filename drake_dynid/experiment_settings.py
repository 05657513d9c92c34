"""Settings and result of a simulated experiment (``dynid simulate``).

:class:`ExperimentSettings` checks every value on its own (noise, rate, time step,
friction kinds); ``drake_dynid.experiment.simulate_experiment`` checks them
against the trajectory and runs the simulation, returning an
:class:`ExperimentLog`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drake_dynid.core import _validate as check

__all__ = [
    "FRICTION_KINDS",
    "MAX_STEPS",
    "MIN_LOG_SAMPLES",
    "ExperimentLog",
    "ExperimentSettings",
]

FRICTION_KINDS = ("viscous", "coulomb", "offset")


#: Most plant steps of one simulated experiment (duration / time_step).
MAX_STEPS = 1e7

#: Fewest log samples of a simulated experiment: the off-line fit's automatic
#: cutoff needs 16 samples (``drake_dynid.offline``), and every identification
#: needs more (filter edges, windows); a shorter log could only be refused later.
MIN_LOG_SAMPLES = 16


@dataclass(frozen=True)
class ExperimentSettings:
    """Settings of a simulated experiment.

    Attributes:
        friction: friction simulated, among "viscous" (URDF damping, else set to 0)
            and "coulomb" (URDF ``friction``, else none), "offset" (0 in a URDF;
            a drive file's motor offsets), with a drive file's motor friction.
        noise_q: std of the white noise on q [rad or m] (ignored with snr_db); it
            must be below the std of the most moving joint's reference position
            (checked by :func:`simulate_experiment`).
        noise_tau: std of the noise on τ_j as a fraction of std(τ_j), in [0, 1]
            (ignored with snr_db).
        snr_db: SNR on every q and τ channel, SNR = 10 log10(var(x)/σ²), in
            [0, 400] dB (None: use noise_q and noise_tau). Noise above the signal
            (noise_tau > 1, SNR < 0 dB) is refused: no identification reads it.
        rate: log rate [Hz]; 1/(rate·time_step) must be an integer.
        seed: seed of the noise (``numpy.random.default_rng(seed)``).
        duration: simulated time [s] (None: the trajectory's).
        time_step: plant period h [s], with h·kd <= 1 (the discrete tracking
            controller's velocity loop; 0.01 s with the default kd).
        min_samples: fewest log samples (duration·rate + 1) accepted, at least
            :data:`MIN_LOG_SAMPLES`.
        kp, kd: controller gains [1/s², 1/s] (ω = 50 rad/s, critically damped:
            stiff enough for light wrists whose damping time constant J/d is
            below the 1 ms step).
        coulomb_smoothing: ε of tanh(v/ε) [rad/s].
        max_tracking_error: largest |q - q_ref| before the run is stopped [rad or m].
        effort_factor: a command beyond this times the effort limit is a divergence.
    """

    friction: tuple[str, ...] = ("viscous", "coulomb")
    noise_q: float = 1e-4
    noise_tau: float = 0.01
    snr_db: float | None = None
    rate: float = 1000.0
    seed: int = 0
    duration: float | None = None
    time_step: float = 1e-3
    min_samples: int = MIN_LOG_SAMPLES
    kp: float = 2500.0
    kd: float = 100.0
    coulomb_smoothing: float = 1e-2
    max_tracking_error: float = 0.1
    effort_factor: float = 10.0

    def __post_init__(self) -> None:
        owner = "ExperimentSettings"
        unknown = [kind for kind in self.friction if kind not in FRICTION_KINDS]
        if unknown:
            check.fail(
                owner,
                f"friction kinds must be among {', '.join(FRICTION_KINDS)}; got "
                f"{', '.join(unknown)}.",
            )
        if check.real(owner, "noise_q", self.noise_q, "rad or m") < 0.0:
            check.fail(owner, f"noise_q must be >= 0 [rad or m]; got {self.noise_q}.")
        if not 0.0 <= check.real(owner, "noise_tau", self.noise_tau) <= 1.0:
            check.fail(
                owner,
                "noise_tau must be in [0, 1] (a fraction of each joint's torque std; "
                f"above 1 the noise exceeds the torque); got {self.noise_tau}.",
            )
        if self.snr_db is not None:
            snr = check.real(owner, "snr_db", self.snr_db, "dB")
            if not 0.0 <= snr <= 400.0:
                check.fail(
                    owner,
                    "snr_db must be in [0, 400] [dB] (below 0 dB the noise exceeds "
                    f"every signal); got {snr:g}.",
                )
        check.positive(owner, "rate", self.rate, "Hz")
        check.integer(owner, "seed", self.seed, minimum=0)
        if self.duration is not None:
            check.positive(owner, "duration", self.duration, "s")
        h = check.positive(owner, "time_step", self.time_step, "s")
        check.integer(owner, "min_samples", self.min_samples, minimum=MIN_LOG_SAMPLES)
        check.positive(owner, "kp", self.kp, "1/s²")
        check.positive(owner, "kd", self.kd, "1/s")
        # The step's own bound before its relation to the rate: '--time-step 0.02'
        # with the default rate names the step, not a rate the user did not give.
        if h * self.kd > 1.0:
            check.fail(
                owner,
                f"time_step must be <= 1/kd = {1.0 / self.kd:g} s [s] (the tracking "
                f"controller's velocity gain kd = {self.kd:g}/s needs time_step·kd "
                f"<= 1 to stay stable); got {h:g}.",
            )
        ratio = 1.0 / (self.rate * h)
        if ratio < 1.0 - 1e-9 or abs(ratio - round(ratio)) > 1e-9 * ratio:
            check.fail(
                owner,
                f"rate must divide 1/time_step = {1.0 / h:g} Hz [Hz] (the log is "
                f"decimated from the simulation); got {self.rate:g}.",
            )
        check.positive(owner, "coulomb_smoothing", self.coulomb_smoothing, "rad/s")
        check.positive(owner, "max_tracking_error", self.max_tracking_error, "rad")
        check.greater_than(owner, "effort_factor", self.effort_factor, 1.0)

    @property
    def decimation(self) -> int:
        """Simulation steps per log sample."""
        return round(1.0 / (self.rate * self.time_step))


@dataclass(frozen=True, eq=False)
class ExperimentLog:
    """A simulated robot log.

    Attributes:
        t: (N,) sample times [s] from 0.
        q, tau: (N, n) measured (noisy) positions and torques.
        q_true, tau_true: (N, n) noise-free ones (τ: the applied torque).
        noise_std: (2n,) std of the noise added to [q; τ].
        joint_names: the n joints.
        max_tracking_error: (n,) largest |q - q_ref| per joint [rad or m].
        saturated: samples whose command exceeded the URDF effort limit (clipped).
        notes: warnings on the run (none at present).
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    q_true: np.ndarray
    tau_true: np.ndarray
    noise_std: np.ndarray
    joint_names: tuple[str, ...]
    max_tracking_error: np.ndarray
    saturated: int
    notes: tuple[str, ...] = ()
