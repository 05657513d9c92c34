"""Diagram builders: the paper's simulated set-up and the replay of a recorded log.

Both feed the same on-line identification chain (docs/CONVENTIONS.md §2-§3)::

    [q; τ] measured ──► CausalJacobiDifferentiator (matched orders 0, 1)
        ──► (q̂, v̂, τ̂) at t - delay ──► ModelRows ──► ModulatingIntegralBank
        ──► SlidingQRIdentifier ──► θ̂, σ(θ̂), cond, valid

Every signal of an equation goes through the same differentiator, so q̂, v̂ and τ̂
refer to the same instant; with ``matched`` orders they are the same low-pass
applied to q, q̇ and τ, which keeps the linear terms of the dynamics exact.

The simulated set-up (paper §V): a discrete ``MultibodyPlant`` from URDF at 1 kHz,
Coulomb friction as an applied generalized force (viscous friction through the URDF
damping, implicit in the plant), a finite-Fourier-series reference tracked by
Drake's ``InverseDynamicsController`` (which does not compensate Coulomb friction),
seeded white measurement noise on q and τ at a given SNR, and loggers. The torque
fed to identification is the controller's command at t_k (never ``net_actuation``,
which lags one sample).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core import modulating

__all__ = [
    "OnlineSettings",
    "OnlineTrace",
    "SimulationResult",
    "SimulationSettings",
    "add_online_identifier",
    "log_source",
    "replay_log",
    "simulate_identification",
]


@dataclass(frozen=True)
class OnlineSettings:
    """Settings of one on-line identifier (all echoed in the JSON results).

    Attributes:
        model: ``"lagrangian"`` (n equations per sample, the default) or ``"power"``
            (the paper's scalar power model).
        window: sliding window T of the modulating functions [s].
        order: modulating order k (>= 1).
        frequencies: indices ℓ of the modulating functions; None uses the integer
            set ``default_frequencies(window, bandwidth)``, ``"paper"`` the paper's
            ℓ = 0:0.05:10.
        bandwidth: highest excitation frequency the default ℓ set covers [Hz].
        jacobi_window: window Tj of the causal Jacobi differentiator [s].
        kappa, mu, jacobi_q: Jacobi parameters κ, μ, q of the velocity estimate
            (q̂, τ̂ use κ+1, μ+1: the matched bank).
        bank_time_step: sample period of the bank [s] (a multiple of the signal
            period: the bank decimates after the differentiator's low-pass). 20 ms
            costs no accuracy against 5 ms on the paper's 2R at 30 dB (0.93 / 2.76 %
            vs 0.97 / 2.71 % inertial / friction, 8 seeds) and makes the closed loop
            about 1.5 times faster. At most jacobi_window/10.
        update_period: period of the least-squares solve [s].
        max_condition: largest accepted condition number of the column-scaled A.
        weighting: ``"frequency"`` (default): two-step weighted least squares
            whose row weights follow a fitted noise model σ_j²(ν) = a_j + b_j ν²
            per equation j (high-ℓ rows carry more velocity-estimate noise;
            ``lsq.solve_frequency_weighted_least_squares``); ``"none"``: ordinary
            least squares, as in the paper. On the 2R benchmark at 30 dB the
            weighting halves the inertial error (benchmarks/bench_accuracy.py).
    """

    model: str = "lagrangian"
    window: float = 20.0
    order: int = 1
    frequencies: Any = None
    bandwidth: float = 0.6
    jacobi_window: float = 0.4
    kappa: float = 1.0
    mu: float = 1.0
    jacobi_q: int = 1
    bank_time_step: float = 0.02
    update_period: float = 0.1
    max_condition: float = 1e4
    weighting: str = "frequency"

    def __post_init__(self):
        owner = "OnlineSettings"
        if self.model not in ("power", "lagrangian"):
            check.fail(
                owner, f"model must be 'power' or 'lagrangian'; got {self.model!r}."
            )
        check.positive(owner, "window", self.window, "s")
        check.positive(owner, "jacobi_window", self.jacobi_window, "s")
        check.positive(owner, "bank_time_step", self.bank_time_step, "s")
        check.positive(owner, "update_period", self.update_period, "s")
        check.positive(owner, "bandwidth", self.bandwidth, "Hz")
        check.greater_than(owner, "max_condition", self.max_condition, 1.0)
        if self.weighting not in WEIGHTINGS:
            check.fail(
                owner,
                f"weighting must be one of {', '.join(map(repr, WEIGHTINGS))}; got "
                f"{self.weighting!r}.",
            )
        if (
            self.bank_time_step
            > self.jacobi_window / MIN_BANK_SAMPLES_PER_JACOBI_WINDOW
        ):
            check.fail(
                owner,
                "bank_time_step must be <= jacobi_window/"
                f"{MIN_BANK_SAMPLES_PER_JACOBI_WINDOW} [s] (the bank samples the "
                "differentiator's low-passed output; a coarser step aliases it); got "
                f"{self.bank_time_step:g} with jacobi_window {self.jacobi_window:g}.",
            )
        if isinstance(self.frequencies, str) and self.frequencies != "paper":
            check.fail(
                owner,
                f"frequencies must be None, 'paper' or a list of reals; got "
                f"{self.frequencies!r}.",
            )

    @classmethod
    def for_model(cls, model: str, **overrides: Any) -> OnlineSettings:
        """Default settings of ``model`` (:data:`MODEL_DEFAULTS`), with overrides."""
        if model not in MODEL_DEFAULTS:
            check.fail(
                "OnlineSettings",
                f"model must be 'power' or 'lagrangian'; got {model!r}.",
            )
        return cls(**{"model": model, **MODEL_DEFAULTS[model], **overrides})

    def row_weighting(
        self, m: int, bank: modulating.FourierBank | None = None
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The solver's ``weighting`` argument (``lsq.solve_window``).

        None for ordinary least squares, else ``(row_frequency, row_group)`` of
        the bank's rows (``modulating.row_frequencies``).

        Args:
            m: equations per sample of the model rows.
            bank: this configuration's bank when already built (default: builds
                ``self.bank()``).
        """
        if self.weighting == "none":
            return None
        return modulating.row_frequencies(self.bank() if bank is None else bank, m)

    def ell(self) -> np.ndarray:
        """The modulating indices ℓ of this configuration.

        ``frequencies=None``: the integer set ℓ = 0, 1, ... with (ℓ + k)/T up to
        ``bandwidth`` (orthogonal rows). When the window is too short for that set to
        hold :data:`MIN_FUNCTIONS` functions, the same band is divided into
        :data:`MIN_FUNCTIONS` evenly spaced ℓ instead (nearly dependent rows, but a
        well-posed least-squares problem).
        """
        if self.frequencies is None:
            ell = modulating.default_frequencies(
                self.window,
                max(self.bandwidth, self.order / self.window),
                order=self.order,
            )
            if ell.size >= MIN_FUNCTIONS:
                return ell
            top = max(self.bandwidth * self.window - self.order, 1.0)
            return np.round(np.linspace(0.0, top, MIN_FUNCTIONS), 12)
        if isinstance(self.frequencies, str):
            return modulating.paper_frequencies()
        return np.asarray(self.frequencies, dtype=float)

    def bank(self) -> modulating.FourierBank:
        """The modulating-function design."""
        return modulating.fourier_bank(
            self.window, self.bank_time_step, order=self.order, ell=self.ell()
        )

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly dict of the settings (ℓ as a list)."""
        out = asdict(self)
        out["frequencies"] = self.ell().tolist()
        return out


#: Offsets of the bank's and the solver's periodic events, in signal periods h.
BANK_OFFSET = 0.5
SOLVE_OFFSET = 0.75

#: The bank samples the differentiator's output at least this many times per Jacobi
#: window (its low-pass has a cut-off of a few 1/jacobi_window).
MIN_BANK_SAMPLES_PER_JACOBI_WINDOW = 10

#: Fewest modulating functions of the default ℓ set (see OnlineSettings.ell).
MIN_FUNCTIONS = 12

#: Least-squares weightings of OnlineSettings.weighting.
WEIGHTINGS = ("frequency", "none")

#: Per-model defaults (benchmarks/bench_accuracy.py, 2R at SNR 30 dB over noise seeds,
#: geometries and trajectories): κ = μ = q = 1 for both; the Lagrangian model, whose
#: linear terms the matched differentiator keeps exact, gains from a longer Jacobi
#: window than the power model, quadratic in the filtered signals. ``bandwidth`` is the
#: excitation band the default ℓ set covers: measure it on your data with
#: ``drake_dynid.core.excitation.estimate_bandwidth`` (``dynid identify`` does).
MODEL_DEFAULTS: dict[str, dict[str, Any]] = {
    "lagrangian": {"jacobi_window": 0.4, "kappa": 1.0, "mu": 1.0, "bandwidth": 0.6},
    "power": {"jacobi_window": 0.3, "kappa": 1.0, "mu": 1.0, "bandwidth": 0.6},
}


@dataclass
class OnlineTrace:
    """Estimates of one on-line identifier over time (one row per solve).

    Attributes:
        settings: the identifier's settings.
        names: base parameter names (p).
        t: (M,) times of the solves [s].
        theta: (M, p) estimates (the last valid one is held while ``valid`` = 0).
        std: (M, p) Gautier standard deviations (inf before the first valid solve).
        condition_number: (M,) condition number of the column-scaled A.
        valid: (M,) 1 when the solve at that time was accepted.
        status: (M,) the identifier's status code (0 ok, 1 window not ready or holding
            a bad sample, 2 not identifiable).
        unidentified: (M, p) 1 for the parameters found not excited by that solve.
        delay: latency of the estimate [s]: the differentiator delay plus one sample
            per block (the window ends at t - delay).
    """

    settings: OnlineSettings
    names: tuple[str, ...]
    t: np.ndarray
    theta: np.ndarray
    std: np.ndarray
    condition_number: np.ndarray
    valid: np.ndarray
    delay: float
    status: np.ndarray = field(default_factory=lambda: np.zeros(0))
    unidentified: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def final(self) -> dict[str, Any]:
        """The estimate at the end of the run (last valid estimate held)."""
        theta = self.theta[-1] if len(self.t) else np.full(len(self.names), np.nan)
        std = self.std[-1] if len(self.t) else np.full(len(self.names), np.inf)
        return {
            "theta": theta,
            "std": std,
            "condition_number": float(self.condition_number[-1])
            if len(self.t)
            else math.inf,
            "valid": bool(self.valid[-1]) if len(self.t) else False,
            "status": int(self.status[-1]) if len(self.status) else None,
            "unidentified": tuple(
                name
                for name, flag in zip(
                    self.names,
                    self.unidentified[-1] if len(self.unidentified) else (),
                    strict=False,
                )
                if flag > 0.5
            ),
        }


@dataclass
class _Chain:
    settings: OnlineSettings
    names: tuple[str, ...]
    differentiator: Any
    rows: Any
    bank: Any
    identifier: Any
    logs: dict[str, Any] = field(default_factory=dict)


def _check_rows(owner: str, rows: Any) -> int:
    """Checks a row provider's interface; returns its number of joints."""
    missing = [
        name
        for name in ("num_joints", "num_parameters", "names", "model_rows")
        if not hasattr(rows, name)
    ]
    if missing:
        raise TypeError(
            f"{owner}: rows must be a row provider (RobotModel or its "
            f"rows_provider()); {type(rows).__name__} has no {', '.join(missing)}."
        )
    return int(rows.num_joints)


def add_online_identifier(
    builder: Any,
    rows: Any,
    measurement: Any,
    time_step: float,
    settings: OnlineSettings,
    *,
    differentiator: Any = None,
    log: bool = True,
) -> _Chain:
    """Adds the on-line identification chain fed by a measurement port [q; τ].

    Args:
        builder: the ``DiagramBuilder``.
        rows: row provider (``RobotModel`` or its ``rows_provider()``): has
            ``num_joints``, ``num_parameters``, ``names`` and ``model_rows``.
        measurement: output port of size 2n carrying [q; τ] sampled at ``time_step``.
        time_step: sample period h of the measurement [s].
        settings: identifier settings.
        differentiator: reuse an existing differentiator (a chain returned earlier
            with the same Jacobi settings) instead of adding a new one.
        log: add loggers of θ̂, σ, cond and valid at the solve period.

    Returns:
        Handles to the blocks and loggers.
    """
    from pydrake.systems.primitives import LogVectorOutput, MatrixGain

    from drake_dynid.systems.identification import (
        ModelRows,
        ModulatingIntegralBank,
        SlidingQRIdentifier,
    )
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    n = _check_rows("add_online_identifier", rows)
    if not isinstance(settings, OnlineSettings):
        raise TypeError(
            "add_online_identifier: settings must be an OnlineSettings; got "
            f"{type(settings).__name__}."
        )
    if measurement.size() != 2 * n:
        check.fail(
            "add_online_identifier",
            f"measurement must have size 2n = {2 * n} ([q; tau]); got "
            f"{measurement.size()}.",
        )
    check.multiple_of(
        "add_online_identifier",
        "bank_time_step",
        settings.bank_time_step,
        "time_step",
        time_step,
    )
    if differentiator is None:
        differentiator = builder.AddSystem(
            CausalJacobiDifferentiator(
                2 * n,
                time_step,
                settings.jacobi_window,
                kappa=settings.kappa,
                mu=settings.mu,
                q=settings.jacobi_q,
                orders=(0, 1),
                matched=True,
            )
        )
        builder.Connect(measurement, differentiator.get_input_port(0))
    eye = np.eye(n)
    zero = np.zeros((n, n))
    pick_first = builder.AddSystem(MatrixGain(np.hstack([eye, zero])))
    pick_second = builder.AddSystem(MatrixGain(np.hstack([zero, eye])))
    pick_velocity = builder.AddSystem(MatrixGain(np.hstack([eye, zero])))
    builder.Connect(
        differentiator.GetOutputPort("derivative_0"), pick_first.get_input_port()
    )
    builder.Connect(
        differentiator.GetOutputPort("derivative_0"), pick_second.get_input_port()
    )
    builder.Connect(
        differentiator.GetOutputPort("derivative_1"), pick_velocity.get_input_port()
    )
    model_rows = builder.AddSystem(ModelRows(rows, settings.model))
    builder.Connect(pick_first.get_output_port(), model_rows.GetInputPort("q"))
    builder.Connect(pick_velocity.get_output_port(), model_rows.GetInputPort("v"))
    builder.Connect(pick_second.get_output_port(), model_rows.GetInputPort("tau"))
    # Multi-rate timing without ties: the differentiator updates at k·h, the bank at
    # j·D·h + h/2 (it reads the differentiator's state after its update at j·D·h) and
    # the solver at u·U·h + 3h/4 (after the bank updates up to u·U·h). Event times of
    # different periods computed in floating point can differ by an ulp; the offsets
    # make every read unambiguous (docs/CONVENTIONS.md §2).
    design = settings.bank()
    bank = builder.AddSystem(
        ModulatingIntegralBank(
            design,
            model_rows.num_equations,
            model_rows.num_parameters,
            offset=BANK_OFFSET * time_step,
        )
    )
    builder.Connect(model_rows.get_output_port(), bank.GetInputPort("channels"))
    builder.Connect(
        differentiator.GetOutputPort("valid"), bank.GetInputPort("sample_valid")
    )
    names = tuple(rows.names)
    identifier = builder.AddSystem(
        SlidingQRIdentifier(
            model_rows.num_parameters,
            bank.num_rows,
            settings.update_period,
            max_condition=settings.max_condition,
            names=names,
            offset=SOLVE_OFFSET * time_step,
            row_weighting=settings.row_weighting(model_rows.num_equations, design),
        )
    )
    for port in ("A", "B"):
        builder.Connect(bank.GetOutputPort(port), identifier.GetInputPort(port))
    builder.Connect(
        bank.GetOutputPort("valid"), identifier.GetInputPort("window_valid")
    )
    chain = _Chain(settings, names, differentiator, model_rows, bank, identifier)
    if log:
        for port in (
            "theta",
            "theta_std",
            "condition_number",
            "valid",
            "status",
            "unidentified",
        ):
            chain.logs[port] = LogVectorOutput(
                identifier.GetOutputPort(port), builder, settings.update_period
            )
    return chain


def _trace(chain: _Chain, context: Any, time_step: float) -> OnlineTrace:
    logs = {name: sink.FindLog(context) for name, sink in chain.logs.items()}
    # Latency: a solve at u·U·h + 3h/4 uses the samples up to u·U·h, whose estimates
    # refer to u·U·h - (differentiator delay).
    delay = chain.differentiator.delay + SOLVE_OFFSET * time_step
    return OnlineTrace(
        settings=chain.settings,
        names=chain.names,
        t=logs["theta"].sample_times().copy(),
        theta=logs["theta"].data().T.copy(),
        std=logs["theta_std"].data().T.copy(),
        condition_number=logs["condition_number"].data()[0].copy(),
        valid=logs["valid"].data()[0].copy(),
        delay=delay,
        status=logs["status"].data()[0].copy(),
        unidentified=logs["unidentified"].data().T.copy(),
    )


def _advance(simulator: Any, t_end: float, progress: bool, label: str) -> None:
    """AdvanceTo in chunks, printing progress on stderr when asked."""
    if not progress:
        simulator.AdvanceTo(t_end)
        return
    chunks = max(1, math.ceil(t_end))
    for i in range(1, chunks + 1):
        simulator.AdvanceTo(min(t_end, t_end * i / chunks))
        print(f"\r{label}: {100.0 * i / chunks:5.1f} %", end="", file=sys.stderr)
    print(file=sys.stderr)


# ----------------------------------------------------------------------------- replay


def log_source(log: Any) -> Any:
    """A ``TrajectorySource`` playing a log's [q; τ] (size 2n) from t = 0.

    Sample k is held over [t_k - h/2, t_k + h/2), t_k = k·h, so a block updating
    at t_k reads sample k whatever the floating-point rounding of the event times
    (docs/CONVENTIONS.md §2). The last sample is held afterwards.

    Args:
        log: a ``drake_dynid.logs.RobotLog``.
    """
    from pydrake.systems.primitives import TrajectorySource
    from pydrake.trajectories import PiecewisePolynomial

    values = np.hstack([log.q, log.tau]).T
    return TrajectorySource(
        PiecewisePolynomial.ZeroOrderHold(
            log.time_step * (np.arange(log.num_samples + 1) - 0.5),
            np.hstack([values, values[:, -1:]]),
        )
    )


def replay_log(
    log: Any,
    rows: Any,
    settings: Sequence[OnlineSettings],
    *,
    progress: bool = False,
) -> list[OnlineTrace]:
    """Runs the on-line identification blocks over a recorded log in a Simulator.

    :func:`log_source` holds row k of the log ([q_k; τ_k]) over
    [t_k - h/2, t_k + h/2), so the blocks read sample k at their update at t_k,
    exactly as in the closed-loop set-up; the Simulator runs to t_N = N·h so that
    every sample is processed.

    Args:
        log: a ``drake_dynid.logs.RobotLog``.
        rows: row provider of the robot (``RobotModel.rows_provider()``).
        settings: one entry per identifier; identifiers with the same Jacobi
            settings share one differentiator.
        progress: print the progress on stderr.

    Returns:
        One :class:`OnlineTrace` per settings entry, with times relative to the
        first sample of the log.
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    n = _check_rows("replay_log", rows)
    if log.q.shape[1] != n or log.tau.shape[1] != n:
        check.fail(
            "replay_log",
            f"the log has {log.q.shape[1]} joints; the robot has {n}.",
        )
    h = log.time_step
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    chains = _add_chains(builder, rows, source.get_output_port(), h, settings)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.Initialize()
    # Run to t_N = N·h: the updates at times < N·h process every sample (the bank's
    # and the solver's offset events included), the loggers publish up to N·h.
    _advance(simulator, float(h * log.num_samples), progress, "dynid identify")
    context = simulator.get_context()
    return [_trace(chain, context, h) for chain in chains]


def _add_chains(builder, rows, measurement, h, settings) -> list[_Chain]:
    chains: list[_Chain] = []
    shared: dict[tuple, Any] = {}
    for entry in settings:
        key = (entry.jacobi_window, entry.kappa, entry.mu, entry.jacobi_q)
        chain = add_online_identifier(
            builder, rows, measurement, h, entry, differentiator=shared.get(key)
        )
        shared[key] = chain.differentiator
        chains.append(chain)
    return chains


# -------------------------------------------------------------------------- simulation


@dataclass(frozen=True)
class SimulationSettings:
    """Settings of the simulated set-up (paper §V).

    Attributes:
        duration: simulated time [s].
        time_step: plant and sampling period h [s].
        snr_db: SNR of the white Gaussian noise added to every q and τ channel,
            SNR = 10 log10(var(x)/σ²) with var(x) of the noise-free reference signal
            (q of the reference trajectory, τ of its inverse dynamics); None: no
            noise.
        seed: seed of the noise (``numpy.random.default_rng(seed)``, one standard
            normal draw per sample and channel, scaled by σ).
        kp, kd: position and velocity gains of the inverse-dynamics controller
            [1/s², 1/s].
        coulomb_smoothing: ε of tanh(v/ε) in the simulated Coulomb friction [rad/s]
            (a discrete plant chatters with an exact sign()).
    """

    duration: float = 25.0
    time_step: float = 1e-3
    snr_db: float | None = 30.0
    seed: int = 0
    kp: float = 400.0
    kd: float = 40.0
    coulomb_smoothing: float = 1e-2

    def __post_init__(self):
        owner = "SimulationSettings"
        check.positive(owner, "duration", self.duration, "s")
        check.positive(owner, "time_step", self.time_step, "s")
        if self.snr_db is not None:
            check.real(owner, "snr_db", self.snr_db, "dB")
        check.integer(owner, "seed", self.seed, 0)
        check.positive(owner, "kp", self.kp, "1/s²")
        check.positive(owner, "kd", self.kd, "1/s")
        check.real(owner, "coulomb_smoothing", self.coulomb_smoothing, "rad/s")
        if self.coulomb_smoothing < 0:
            check.fail(
                owner,
                "coulomb_smoothing must be >= 0 [rad/s]; got "
                f"{self.coulomb_smoothing}.",
            )


@dataclass
class SimulationResult:
    """Logs of a simulated identification run.

    Attributes:
        t: (N,) sample times [s].
        q: (N, n) measured (noisy) joint positions, the log the identifiers saw.
        tau: (N, n) measured (noisy) joint torques (commands at t_k plus noise).
        q_true: (N, n) noise-free joint positions.
        tau_true: (N, n) noise-free torque commands.
        noise_std: (2n,) standard deviations of the noise on [q; τ].
        traces: one :class:`OnlineTrace` per identifier.
        joint_names: the joints.
        simulator: the Simulator at the end of the run (for inspection).
        chains: handles to the blocks of each identifier.
    """

    t: np.ndarray
    q: np.ndarray
    tau: np.ndarray
    q_true: np.ndarray
    tau_true: np.ndarray
    noise_std: np.ndarray
    traces: list[OnlineTrace]
    joint_names: tuple[str, ...]
    simulator: Any = None
    chains: list[Any] = field(default_factory=list)


def reference_noise_std(
    robot: Any, trajectory: Any, duration: float, snr_db: float | None, time_step: float
) -> np.ndarray:
    """σ of the noise on [q; τ] for an SNR on the noise-free reference signals.

    σ_i = std(x_i)/10^(SNR/20) with x = q of the reference and τ = its inverse
    dynamics (inertial + friction with the robot's base values).
    """
    n = robot.num_joints
    if snr_db is None:
        return np.zeros(2 * n)
    t = np.arange(0.0, duration, time_step)
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    scale = 10.0 ** (-snr_db / 20.0)
    return np.concatenate([q.std(axis=0), tau.std(axis=0)]) * scale


def simulate_identification(
    robot: Any,
    trajectory: Any,
    simulation: SimulationSettings,
    settings: Sequence[OnlineSettings],
    *,
    rows: Any = None,
    events: Sequence[tuple[float, Callable[[Any, Any], None]]] = (),
    progress: bool = False,
) -> SimulationResult:
    """Simulates the paper's set-up and runs on-line identifiers in the loop.

    Args:
        robot: ``RobotModel`` of the simulated robot (its URDF is loaded again as a
            discrete plant, and as the controller's model).
        trajectory: reference with ``evaluate(t) -> (q, v, vdot)`` (e.g. a
            ``FourierTrajectory``); the plant starts on it.
        simulation: set-up settings.
        settings: one entry per on-line identifier.
        rows: row provider for identification (default ``robot.rows_provider()``).
        events: (time, callback(plant, plant_context)) pairs applied when the
            simulation reaches that time, e.g. a change of an inertial parameter.
        progress: print the progress on stderr.

    Returns:
        The logs and one estimate trace per identifier.
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.controllers import InverseDynamicsController
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import (
        Adder,
        LogVectorOutput,
        MatrixGain,
        Multiplexer,
        TrajectorySource,
    )
    from pydrake.trajectories import PiecewisePolynomial

    from drake_dynid.systems.friction import JointFriction
    from drake_dynid.urdf import load_plant, read_urdf_friction

    h = simulation.time_step
    n = robot.num_joints
    if getattr(trajectory, "num_joints", n) != n:
        check.fail(
            "simulate_identification",
            f"trajectory has {trajectory.num_joints} joints; the robot has {n}.",
        )
    rows = robot.rows_provider() if rows is None else rows
    builder = DiagramBuilder()
    plant = builder.AddSystem(load_plant(robot.path, h, gravity=robot.gravity))
    plant.set_name("plant")
    controller_plant = load_plant(robot.path, h, gravity=robot.gravity)

    # Coulomb friction as an applied generalized force (viscous: URDF damping).
    coulomb = read_urdf_friction(robot.path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    friction = builder.AddSystem(
        JointFriction(
            viscous=np.zeros(n),
            coulomb=fc,
            offset=np.zeros(n),
            smoothing=simulation.coulomb_smoothing,
        )
    )
    builder.Connect(plant.get_state_output_port(), friction.get_input_port())
    builder.Connect(
        friction.get_output_port(), plant.get_applied_generalized_force_input_port()
    )

    # Reference: cubic Hermite through the exact trajectory every 10 ms.
    knots = np.arange(0.0, simulation.duration + 0.02, 0.01)
    q_ref, v_ref, _ = trajectory.evaluate(knots)
    reference = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.CubicHermite(knots, q_ref.T, v_ref.T),
            output_derivative_order=2,
        )
    )
    eye = np.eye(n)
    zero = np.zeros((n, n))
    desired_state = builder.AddSystem(
        MatrixGain(np.block([[eye, zero, zero], [zero, eye, zero]]))
    )
    desired_acceleration = builder.AddSystem(MatrixGain(np.hstack([zero, zero, eye])))
    builder.Connect(reference.get_output_port(), desired_state.get_input_port())
    builder.Connect(reference.get_output_port(), desired_acceleration.get_input_port())
    controller = builder.AddSystem(
        InverseDynamicsController(
            controller_plant,
            kp=np.full(n, simulation.kp),
            ki=np.zeros(n),
            kd=np.full(n, simulation.kd),
            has_reference_acceleration=True,
        )
    )
    builder.Connect(
        plant.get_state_output_port(), controller.get_input_port_estimated_state()
    )
    builder.Connect(
        desired_state.get_output_port(), controller.get_input_port_desired_state()
    )
    builder.Connect(
        desired_acceleration.get_output_port(),
        controller.get_input_port_desired_acceleration(),
    )
    builder.Connect(
        controller.get_output_port_control(), plant.get_actuation_input_port()
    )

    # Measurement [q; τ] (τ: the command at t_k) plus seeded white noise.
    positions = builder.AddSystem(MatrixGain(np.hstack([eye, zero])))
    builder.Connect(plant.get_state_output_port(), positions.get_input_port())
    clean = builder.AddSystem(Multiplexer([n, n]))
    builder.Connect(positions.get_output_port(), clean.get_input_port(0))
    builder.Connect(controller.get_output_port_control(), clean.get_input_port(1))
    noise_std = reference_noise_std(
        robot, trajectory, simulation.duration, simulation.snr_db, h
    )
    # White noise: sample k drawn from numpy.random.default_rng(seed) and held over
    # [t_k - h/2, t_k + h/2), so every block reading it at t_k and the logger see
    # the same value (Drake's RandomSource updates before discrete updates, which
    # would make the log one sample off what the blocks saw).
    steps = round(simulation.duration / h) + 2
    draws = np.random.default_rng(int(simulation.seed)).standard_normal((steps, 2 * n))
    noise = builder.AddSystem(
        TrajectorySource(
            PiecewisePolynomial.ZeroOrderHold(
                h * (np.arange(steps + 1) - 0.5),
                np.vstack([draws, draws[-1:]]).T * noise_std[:, None],
            )
        )
    )
    measured = builder.AddSystem(Adder(2, 2 * n))
    builder.Connect(clean.get_output_port(), measured.get_input_port(0))
    builder.Connect(noise.get_output_port(), measured.get_input_port(1))
    measurement = measured.get_output_port()

    chains = _add_chains(builder, rows, measurement, h, settings)
    measured_log = LogVectorOutput(measurement, builder, h)
    clean_log = LogVectorOutput(clean.get_output_port(), builder, h)

    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    plant.SetPositions(plant_context, q_ref[0])
    plant.SetVelocities(plant_context, v_ref[0])
    simulator.Initialize()
    t_end = float(simulation.duration)
    for when, callback in sorted(events, key=lambda e: e[0]):
        if when < t_end:
            _advance(simulator, when, progress, "simulating")
            callback(plant, plant.GetMyMutableContextFromRoot(context))
    _advance(simulator, t_end, progress, "simulating")

    measured_data = measured_log.FindLog(context)
    clean_data = clean_log.FindLog(context).data().T
    data = measured_data.data().T
    return SimulationResult(
        t=measured_data.sample_times().copy(),
        q=data[:, :n].copy(),
        tau=data[:, n:].copy(),
        q_true=clean_data[:, :n].copy(),
        tau_true=clean_data[:, n:].copy(),
        noise_std=noise_std,
        traces=[_trace(chain, context, h) for chain in chains],
        joint_names=tuple(robot.joint_names),
        simulator=simulator,
        chains=chains,
    )
