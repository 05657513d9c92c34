"""Diagram builders: the on-line identification chain and the replay of a log.

The chain (docs/CONVENTIONS.md §2-§3)::

    [q; τ] measured ──► CausalJacobiDifferentiator (matched orders 0, 1)
        ──► (q̂, v̂, τ̂) at t - delay ──► ModelRows ──► ModulatingIntegralBank
        ──► SlidingQRIdentifier ──► θ̂, σ(θ̂), cond, valid

Every signal of an equation goes through the same differentiator, so q̂, v̂ and τ̂
refer to the same instant; with ``matched`` orders they are the same low-pass
applied to q, q̇ and τ, which keeps the linear terms of the dynamics exact.

The settings (:class:`~drake_dynid.core.online.OnlineSettings`), the event offsets
and the result type (:class:`~drake_dynid.core.online.OnlineTrace`) are pure
configuration in :mod:`drake_dynid.core.online`, shared with the core replay
(:mod:`drake_dynid.core.replay`); they stay importable from here. The paper's
simulated set-up is :mod:`drake_dynid.simulation` (its names are importable from
here too).
"""

from __future__ import annotations

import importlib
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from drake_dynid.core import _validate as check
from drake_dynid.core._threads import thread_limit
from drake_dynid.core.change import change_design
from drake_dynid.core.online import (
    BANK_OFFSET,
    MIN_BANK_SAMPLES_PER_JACOBI_WINDOW,
    MIN_FUNCTIONS,
    MODEL_DEFAULTS,
    SOLVE_OFFSET,
    WEIGHTINGS,
    OnlineSettings,
    OnlineTrace,
)
from drake_dynid.core.rows import check_rows

if TYPE_CHECKING:  # loaded on first use by __getattr__ below
    from drake_dynid.simulation import (
        SimulationResult,
        SimulationSettings,
        reference_noise_std,
        simulate_identification,
    )

__all__ = [
    "BANK_OFFSET",
    "MIN_BANK_SAMPLES_PER_JACOBI_WINDOW",
    "MIN_FUNCTIONS",
    "MODEL_DEFAULTS",
    "SOLVE_OFFSET",
    "WEIGHTINGS",
    "IdentifierChain",
    "OnlineSettings",
    "OnlineTrace",
    "SimulationResult",
    "SimulationSettings",
    "add_bank_front",
    "add_online_identifier",
    "add_online_identifiers",
    "advance",
    "chain_trace",
    "check_measurement",
    "final_row",
    "log_source",
    "reference_noise_std",
    "replay_log",
    "simulate_identification",
]

# Names of the simulated set-up, loaded on first use (drake_dynid.simulation builds
# on this module).
_SIMULATION = (
    "SimulationResult",
    "SimulationSettings",
    "reference_noise_std",
    "simulate_identification",
)


def __getattr__(name: str) -> Any:
    if name in _SIMULATION:
        return getattr(importlib.import_module("drake_dynid.simulation"), name)
    raise AttributeError(f"module 'drake_dynid.diagrams' has no attribute {name!r}")


#: The ports of the identifier that the chain logs at the solve period.
_LOGGED = ("theta", "theta_std", "condition_number", "valid", "status", "unidentified")
#: Also logged with change detection (``systems.change.ChangeTrackingIdentifier``).
_CHANGE_LOGGED = ("change", "changed")


@dataclass
class IdentifierChain:
    """Handles to the blocks and loggers of one on-line identifier.

    Attributes:
        settings: the identifier's settings, on the measurement's grid.
        names: the base-parameter names.
        differentiator: the ``CausalJacobiDifferentiator`` (may be shared).
        rows: the ``ModelRows`` block.
        bank: the ``ModulatingIntegralBank`` block.
        identifier: the ``SlidingQRIdentifier`` block.
        logs: port name -> ``VectorLogSink`` of the identifier's outputs.
    """

    settings: OnlineSettings
    names: tuple[str, ...]
    differentiator: Any
    rows: Any
    bank: Any
    identifier: Any
    logs: dict[str, Any] = field(default_factory=dict)


_Chain = IdentifierChain  # the former private name


def add_bank_front(
    builder: Any,
    rows: Any,
    settings: OnlineSettings,
    measurement: Any,
    time_step: float,
    differentiator: Any = None,
    *,
    owner: str = "add_bank_front",
) -> tuple[Any, Any, Any, Any]:
    """Differentiator → model rows → modulating bank, wired in ``builder``.

    The front end every on-line identifier block shares (the sliding identifier of
    :func:`add_online_identifier`, ``payload_diagrams.add_payload_identifier``):
    a ``CausalJacobiDifferentiator`` of ``measurement`` = [q; τ] (or the one
    given), the ``ModelRows`` of its outputs or the ``RawModelRows`` of its ring
    (``settings.rows_from``), and a ``ModulatingIntegralBank`` of their channels.
    ``settings`` must already be on the grid of ``time_step`` [s]
    (``settings.on_grid(time_step)``, or ``for_robot``; else ValueError: a bank
    step of 6.67 samples read a 3 ms differentiator at lags varying by up to
    3 ms). A given differentiator must sample every ``time_step``, take the 2n
    signals and have ``settings.jacobi_filters(time_step)`` (else ValueError, in
    ``owner``'s name).

    Returns:
        ``(differentiator, model_rows, bank, design)``: the blocks and the bank's
        design (``settings.bank()``).
    """
    from pydrake.systems.primitives import Demultiplexer

    from drake_dynid.systems.identification import (
        ModelRows,
        ModulatingIntegralBank,
        RawModelRows,
    )
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    n = int(rows.num_joints)
    check_measurement(owner, measurement, n)
    _check_on_grid(owner, settings, time_step)
    _warn_sampled_plant(owner, builder, measurement)
    if differentiator is None:
        differentiator = builder.AddSystem(
            CausalJacobiDifferentiator(2 * n, time_step, **settings.jacobi_parameters())
        )
        builder.Connect(measurement, differentiator.get_input_port_u())
    else:
        _check_shared_differentiator(owner, differentiator, settings, time_step, n)
    if settings.rows_from == "raw":
        # The mean rows of the raw samples of each bank step, read from the ring.
        model_rows = builder.AddSystem(
            RawModelRows(
                rows,
                settings.model,
                settings.raw_design(time_step),
                differentiator.history_length,
                time_step=differentiator.time_step,
            )
        )
        builder.Connect(
            differentiator.get_output_port_history(),
            model_rows.get_input_port_history(),
        )
    else:
        # derivative_0 = [q̂; τ̂] and derivative_1 = [v̂; τ̂']: split them per joint.
        smoothed = builder.AddSystem(Demultiplexer([n, n]))
        rates = builder.AddSystem(Demultiplexer([n, n]))
        builder.Connect(
            differentiator.get_output_port_derivative(0), smoothed.get_input_port()
        )
        builder.Connect(
            differentiator.get_output_port_derivative(1), rates.get_input_port()
        )
        model_rows = builder.AddSystem(ModelRows(rows, settings.model))
        builder.Connect(smoothed.get_output_port(0), model_rows.get_input_port_q())
        builder.Connect(rates.get_output_port(0), model_rows.get_input_port_v())
        builder.Connect(smoothed.get_output_port(1), model_rows.get_input_port_tau())
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
    builder.Connect(
        model_rows.get_output_port_channels(), bank.get_input_port_channels()
    )
    builder.Connect(
        differentiator.get_output_port_valid(), bank.get_input_port_sample_valid()
    )
    return differentiator, model_rows, bank, design


def check_measurement(owner: str, measurement: Any, n: int) -> None:
    """The measurement must be a vector output port of size 2n carrying [q; τ].

    A ``MultibodyPlant``'s state port ([q; v], also of size 2n for a chain of
    revolute joints) is refused: a review wired the 2R plant's
    ``get_state_output_port()`` into the chain, which took v for τ and reported
    FV1 = FV2 = 1.000 ± 0.0005, every other parameter 0, "valid".

    Raises:
        TypeError: ``measurement`` is not an ``OutputPort`` with a vector value
            (a system, an input port, an abstract port).
        ValueError: its size is not 2n, or it is a ``MultibodyPlant``'s state.
    """
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import ModelInstanceIndex
    from pydrake.systems.framework import OutputPort, PortDataType

    vector = isinstance(measurement, OutputPort) and (
        measurement.get_data_type() == PortDataType.kVectorValued
    )
    if not vector:
        what = type(measurement).__name__
        if isinstance(measurement, OutputPort):
            what = f"the abstract-valued port {measurement.get_name()!r}"
        raise TypeError(
            f"{owner}: measurement must be the vector OutputPort carrying [q; tau] "
            f"(e.g. source.get_output_port()); got {what}."
        )
    if measurement.size() != 2 * n:
        check.fail(
            owner,
            f"measurement must have size 2n = {2 * n} ([q; tau]); got "
            f"{measurement.size()}.",
        )
    plant = measurement.get_system()
    if isinstance(plant, MultibodyPlant) and plant.is_finalized():
        states = [plant.get_state_output_port()] + [
            plant.get_state_output_port(ModelInstanceIndex(index))
            for index in range(plant.num_model_instances())
        ]
        if measurement.get_index() in {port.get_index() for port in states}:
            check.fail(
                owner,
                f"measurement is the MultibodyPlant's state port "
                f"{measurement.get_name()!r}, [q; v]: the chain needs [q; tau] (a "
                "Multiplexer of the plant's positions and the torque it applies).",
            )


def _check_on_grid(owner: str, settings: OnlineSettings, time_step: float) -> None:
    """ValueError unless ``settings.on_grid(time_step)`` would keep ``settings``.

    The bank's step must be a whole number of signal samples (the raw rows
    average that many, the core replay decimates by it); a given period off the
    grid raises in ``on_grid`` itself.
    """
    gridded = settings.on_grid(time_step)
    moved = [
        f"{name} {getattr(settings, name)} -> {getattr(gridded, name):g}"
        for name in ("jacobi_window", "bank_time_step", "window", "raw_window")
        if getattr(gridded, name) != getattr(settings, name)
    ]
    if moved:
        check.fail(
            owner,
            f"settings must be on the grid of time_step {time_step:g} s; call "
            f"settings.on_grid(time_step) first ({'; '.join(moved)}).",
        )


def _warn_sampled_plant(owner: str, builder: Any, measurement: Any) -> None:
    """A warning when a discrete plant with sampled output ports feeds the chain.

    Drake's discrete ``MultibodyPlant`` samples its output ports by default; the
    q it reports is then one step off the τ commanded at t_k
    (docs/CONVENTIONS.md §2). A review built the paper's 2R closed loop around
    such a plant: FV1 = -1.41 for 0.3, FC1 -98 %, ZZ1R -4.2 %, all "valid"
    (live ports: within 0.6 %). Looks upstream of ``measurement`` through the
    builder's connections (and inside sub-diagrams) for such a plant.
    """
    import warnings

    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.systems.framework import Diagram

    upstream: dict[Any, list[Any]] = {}
    for (system, _), (source, _) in builder.connection_map().items():
        upstream.setdefault(system, []).append(source)
    seen: set[int] = set()
    todo = [measurement.get_system()]
    while todo:
        system = todo.pop()
        if id(system) in seen:
            continue
        seen.add(id(system))
        if isinstance(system, Diagram):
            todo.extend(system.GetSystems())
        sampled = (
            isinstance(system, MultibodyPlant)
            and system.is_finalized()
            and system.time_step() > 0.0
            and system.has_sampled_output_ports()
        )
        if sampled:
            warnings.warn(
                f"{owner}: the measurement comes from a discrete MultibodyPlant "
                f"({system.get_name() or 'unnamed'}) with sampled output ports, "
                "Drake's default: its q is one step off the τ commanded at t_k, "
                "which biases the estimates (the paper's 2R: FV1 -1.41 for 0.3). "
                "Call plant.SetUseSampledOutputPorts(False) before Finalize() "
                "(drake_dynid.load_plant does), unless the measurement already "
                "aligns q and τ.",
                UserWarning,
                stacklevel=4,  # the caller of add_online_identifier
            )
            return
        todo.extend(upstream.get(system, ()))


def _check_shared_differentiator(
    owner: str, differentiator: Any, settings: OnlineSettings, time_step: float, n: int
) -> None:
    """A reused differentiator must be the one the chain would add.

    Its period is the chain's ``time_step`` (the raw rows' velocity and the bank's
    samples assume it), it differentiates the 2n signals [q; τ] and its filters
    are ``settings.jacobi_filters(time_step)`` (the trace's delay is theirs).
    """
    from drake_dynid.systems.jacobi import CausalJacobiDifferentiator

    check.instance(
        owner,
        "differentiator",
        differentiator,
        CausalJacobiDifferentiator,
        "a CausalJacobiDifferentiator (the one of an earlier chain)",
    )
    if not math.isclose(differentiator.time_step, time_step, rel_tol=1e-9):
        check.fail(
            owner,
            f"differentiator must sample every {time_step:g} s (the measurement's "
            f"time_step); got {differentiator.time_step:g} s.",
        )
    if differentiator.num_signals != 2 * n:
        check.fail(
            owner,
            f"differentiator must differentiate {2 * n} signals ([q; tau]); got "
            f"{differentiator.num_signals}.",
        )
    wanted = settings.jacobi_filters(time_step)
    same = len(wanted) == len(differentiator.filters) and all(
        a.order == b.order and np.array_equal(a.taps, b.taps)
        for a, b in zip(wanted, differentiator.filters, strict=True)
    )
    if not same:
        check.fail(
            owner,
            "differentiator must have the settings' Jacobi filters "
            f"(settings.jacobi_parameters(): {settings.jacobi_parameters()}); got "
            f"window {differentiator.filters[0].window:g} s, orders "
            f"{tuple(f.order for f in differentiator.filters)}.",
        )


def add_online_identifier(
    builder: Any,
    rows: Any,
    measurement: Any,
    time_step: float,
    settings: OnlineSettings,
    *,
    differentiator: Any = None,
    log: bool = True,
) -> IdentifierChain:
    """Adds the on-line identification chain fed by a measurement port [q; τ].

    The settings are put on the measurement's grid first
    (:meth:`OnlineSettings.on_grid`: unset bank and solve periods become the
    multiples of ``time_step`` closest to their nominal values).

    Args:
        builder: the ``DiagramBuilder``.
        rows: row provider (``RobotModel`` or its ``rows_provider()``): has
            ``num_joints``, ``num_parameters``, ``names`` and ``model_rows``.
        measurement: output port of size 2n carrying [q; τ] sampled at ``time_step``.
        time_step: sample period h of the measurement [s].
        settings: identifier settings.
        differentiator: reuse an existing differentiator (a chain returned earlier
            with the same Jacobi settings) instead of adding a new one; its
            period, size and filters are checked (ValueError).
        log: add loggers of θ̂, σ, cond, valid, status and unidentified at the
            solve period.

    Returns:
        Handles to the blocks and loggers.
    """
    from pydrake.systems.primitives import LogVectorOutput

    from drake_dynid.systems.identification import SlidingQRIdentifier

    owner = "add_online_identifier"
    n = check_rows(owner, rows)
    if not isinstance(settings, OnlineSettings):
        raise TypeError(
            f"{owner}: settings must be an OnlineSettings; got "
            f"{type(settings).__name__}."
        )
    check_measurement(owner, measurement, n)
    settings = settings.for_robot(time_step, n, int(rows.num_parameters))
    plain_rows = rows
    rows = settings.row_provider(rows, time_step)  # noise-compensated power rows
    differentiator, model_rows, bank, design = add_bank_front(
        builder, rows, settings, measurement, time_step, differentiator, owner=owner
    )
    names = tuple(rows.names)
    covariance = settings.covariance_design(time_step, n)
    solver = dict(
        max_condition=settings.max_condition,
        names=names,
        offset=SOLVE_OFFSET * time_step,
        row_weighting=settings.row_weighting(model_rows.num_equations, design),
        row_noise=settings.row_noise(model_rows.num_equations, design),
        jackknife_groups=settings.jackknife_groups(model_rows.num_equations, design),
        covariance=None if covariance is None else (covariance, plain_rows),
    )
    period = settings.resolved("update_period")
    tracking = change_design(
        settings, time_step, model_rows.num_equations, model_rows.num_parameters
    )
    if tracking is None:
        identifier = builder.AddSystem(
            SlidingQRIdentifier(
                model_rows.num_parameters, bank.num_rows, period, **solver
            )
        )
    else:  # change detection (core.change): it reads the bank's stored samples
        from drake_dynid.systems.change import ChangeTrackingIdentifier

        identifier = builder.AddSystem(
            ChangeTrackingIdentifier(
                model_rows.num_parameters, bank.num_rows, period, tracking, **solver
            )
        )
        builder.Connect(
            bank.get_output_port_window_state(),
            identifier.get_input_port_window_state(),
        )
    if covariance is not None:  # the window's filtered signals (core.row_covariance)
        from drake_dynid.systems.signal_window import SignalWindow

        window = builder.AddSystem(
            SignalWindow(
                n,
                covariance.num_samples,
                settings.resolved("bank_time_step"),
                offset=BANK_OFFSET * time_step,
            )
        )
        for order, port in (
            (0, window.get_input_port_smoothed()),
            (1, window.get_input_port_rates()),
        ):
            builder.Connect(differentiator.get_output_port_derivative(order), port)
        builder.Connect(
            window.get_output_port_window(), identifier.get_input_port_window_signals()
        )
    builder.Connect(bank.get_output_port_A(), identifier.get_input_port_A())
    builder.Connect(bank.get_output_port_B(), identifier.get_input_port_B())
    builder.Connect(
        bank.get_output_port_valid(), identifier.get_input_port_window_valid()
    )
    chain = IdentifierChain(
        settings, names, differentiator, model_rows, bank, identifier
    )
    if log:
        for port in _LOGGED + (_CHANGE_LOGGED if tracking is not None else ()):
            chain.logs[port] = LogVectorOutput(
                identifier.GetOutputPort(port),
                builder,
                settings.resolved("update_period"),
            )
    return chain


def add_online_identifiers(
    builder: Any,
    rows: Any,
    measurement: Any,
    time_step: float,
    settings: Sequence[OnlineSettings],
) -> list[IdentifierChain]:
    """One :func:`add_online_identifier` per settings entry on one measurement.

    Entries with the same Jacobi settings share one differentiator.
    """
    if isinstance(settings, OnlineSettings):
        raise TypeError(
            "add_online_identifiers: settings must be a sequence of OnlineSettings "
            "(one per identifier); got one OnlineSettings: pass [settings] (or "
            "call add_online_identifier)."
        )
    chains: list[IdentifierChain] = []
    shared: dict[tuple, Any] = {}
    for index, entry in enumerate(settings):
        check.instance(
            "add_online_identifiers",
            f"settings[{index}]",
            entry,
            OnlineSettings,
            "an OnlineSettings",
        )
        key = tuple(entry.on_grid(time_step).jacobi_parameters().values())
        chain = add_online_identifier(
            builder, rows, measurement, time_step, entry, differentiator=shared.get(key)
        )
        shared[key] = chain.differentiator
        chains.append(chain)
    return chains


def chain_trace(chain: IdentifierChain, context: Any, time_step: float) -> OnlineTrace:
    """The estimates a chain's loggers recorded, as an :class:`OnlineTrace`.

    Raises:
        ValueError: the chain has no loggers (built with ``log=False``), or
            ``time_step`` is not its signal period.
    """
    logs = chain_logs("chain_trace", chain, context, time_step, _LOGGED)
    # Latency: a solve at u·U·h + 3h/4 uses the samples up to u·U·h, whose estimates
    # refer to u·U·h - (differentiator delay, or the raw rows' delay).
    delay = chain.settings.delay(time_step) + SOLVE_OFFSET * time_step
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
        **_change_fields(logs),
    )


def chain_logs(
    owner: str,
    chain: IdentifierChain,
    context: Any,
    time_step: float,
    ports: Sequence[str],
) -> dict[str, Any]:
    """The ``VectorLog`` of every logger of ``chain`` in ``context``.

    ``time_step`` is the caller's signal period [s], checked against the
    chain's (a trace's delay computed at another period was silently off:
    0.1259 s for 0.1252 s at 2 ms instead of 1 ms).

    Raises:
        ValueError: a port of ``ports`` has no logger (the chain was built with
            ``log=False``: read its identifier's output ports instead), or
            ``time_step`` is not the chain's signal period.
    """
    period = chain.differentiator.time_step
    if not math.isclose(time_step, period, rel_tol=1e-9):
        check.fail(
            owner,
            f"time_step must be the chain's signal period {period:g} [s] (its "
            f"differentiator's; the trace's delay depends on it); got {time_step:g}.",
        )
    missing = [port for port in ports if port not in chain.logs]
    if missing:
        check.fail(
            owner,
            f"the chain has no logger of {', '.join(missing)} (built with "
            "log=False?); read chain.identifier's output ports instead, or build "
            "it with log=True.",
        )
    return {name: sink.FindLog(context) for name, sink in chain.logs.items()}


def _change_fields(logs: dict[str, Any]) -> dict[str, np.ndarray]:
    """The trace's change-detection fields from the logs (none without)."""
    if "change" not in logs:
        return {}
    change = logs["change"].data()
    return {
        "change": change[0].copy(),
        "change_time": change[1].copy(),
        "tracking": change[2].copy(),
        "changed": logs["changed"].data().T.copy(),
    }


def advance(simulator: Any, t_end: float, progress: bool, label: str) -> None:
    """``simulator.AdvanceTo(t_end)`` in chunks; progress on stderr when asked.

    The chunks start at the simulator's time (a review: with ``progress`` the
    first chunk of a second call, e.g. after an event of
    ``simulate_identification``, went back to t_end/chunks, and Drake's
    Simulator aborted the Python process on the C++ assertion
    ``boundary_time >= context_->get_time()``).

    Raises:
        ValueError: ``t_end`` is not finite or before the simulator's time.
    """
    now = simulator.get_context().get_time()
    t_end = check.real("advance", "t_end", t_end, "s")
    if t_end < now:
        check.fail(
            "advance",
            f"t_end must be >= the simulator's time {now:g} [s] (a Simulator "
            f"cannot go back); got {t_end:g}.",
        )
    if not progress:
        simulator.AdvanceTo(t_end)
        return
    chunks = max(1, math.ceil(t_end - now))
    for i in range(1, chunks + 1):
        simulator.AdvanceTo(min(t_end, now + (t_end - now) * i / chunks))
        done = 100.0 * simulator.get_context().get_time() / t_end if t_end else 100.0
        print(f"\r{label}: {done:5.1f} %", end="", file=sys.stderr)
    print(file=sys.stderr)


# ----------------------------------------------------------------------------- replay


def log_source(log: Any) -> Any:
    """A ``HeldSamples`` block playing a log's [q; τ] (size 2n) from t = 0.

    Sample k is held over [t_k - h/2, t_k + h/2), t_k = k·h, so a block updating
    at t_k reads sample k whatever the floating-point rounding of the event times
    (docs/CONVENTIONS.md §2). After the last sample (from t_{N-1} + h/2) the
    output is NaN: the log has ended, so the windows that would hold samples past
    it are invalid and the identifiers keep their last valid estimate (a review
    found a Simulator run past the end giving "valid" estimates from the last
    sample repeated: FV1 -78 ± 34 for 0.3). A long log's
    stored q and τ are read a block of rows at a time
    (``drake_dynid.systems.held_samples``: memory independent of the log's
    length; a ``TrajectorySource`` of a zero-order hold took 1.8 GB per 10
    minutes of a 7-DOF log).

    Args:
        log: a ``drake_dynid.logs.RobotLog``.
    """
    from drake_dynid.systems.held_samples import HeldSamples

    check.having(
        "log_source", "log", log, ("q", "tau", "time_step", "num_samples"), "a RobotLog"
    )
    return HeldSamples([log.q, log.tau], log.time_step, after_end="nan")


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
    every sample is processed. ``drake_dynid.core.replay.replay_log_core`` gives
    the same traces without a Simulator.

    Args:
        log: a ``drake_dynid.logs.RobotLog``.
        rows: row provider of the robot (``RobotModel.rows_provider()``).
        settings: one entry per identifier; identifiers with the same Jacobi
            settings share one differentiator.
        progress: print the progress on stderr.

    Returns:
        One :class:`OnlineTrace` per settings entry, with times relative to the
        first sample of the log.

    The Simulator runs with BLAS/OpenMP pools of one thread (``DYNID_THREADS``
    changes it; ``drake_dynid.core._threads``).
    """
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    check.having(
        "replay_log", "log", log, ("q", "tau", "time_step", "num_samples"), "a RobotLog"
    )
    n = check_rows("replay_log", rows)
    if log.q.shape[1] != n or log.tau.shape[1] != n:
        check.fail(
            "replay_log",
            f"the log has {log.q.shape[1]} joints; the robot has {n}.",
        )
    h = log.time_step
    builder = DiagramBuilder()
    source = builder.AddSystem(log_source(log))
    chains = add_online_identifiers(
        builder, rows, source.get_output_port(), h, settings
    )
    simulator = Simulator(builder.Build())
    with thread_limit():  # BLAS/OpenMP pools of one thread (core._threads)
        simulator.Initialize()
        # Run to t_N = N·h: the updates at times < N·h process every sample (the
        # bank's and the solver's offset events included), the loggers publish up
        # to N·h.
        advance(simulator, float(h * log.num_samples), progress, "dynid identify")
        context = simulator.get_mutable_context()
        return [_final_trace(chain, context, log.num_samples, h) for chain in chains]


def _final_trace(
    chain: IdentifierChain, context: Any, count: int, time_step: float
) -> OnlineTrace:
    """The chain's trace with the log's final solve and row (``core.replay``).

    :func:`final_row`, in place of the loggers' row at t_N or appended.
    """
    trace = chain_trace(chain, context, time_step)
    keep, row = final_row(chain, context, count, time_step)
    extra = {}
    if "change" in row:
        extra = {
            "change": row["change"][0],
            "change_time": row["change"][1],
            "tracking": row["change"][2],
            "changed": row["changed"],
        }
    return with_final_row(trace, keep, row, count * time_step, extra)


def with_final_row(
    trace: Any, keep: int, row: dict[str, np.ndarray], end: float, extra: Any = None
) -> Any:
    """``trace``'s first ``keep`` rows and the final ``row`` of :func:`final_row`.

    The row is recorded at ``end`` = t_N [s]; ``extra`` maps more of the trace's
    fields to their final values (the change detection's, the payload's
    correlation).
    """

    def ended(values: Any, last: Any) -> np.ndarray:
        return np.concatenate([np.asarray(values)[:keep], np.asarray(last)[None]])

    fields = {
        "t": ended(trace.t, end),
        "theta": ended(trace.theta, row["theta"]),
        "std": ended(trace.std, row["theta_std"]),
        "condition_number": ended(trace.condition_number, row["condition_number"][0]),
        "valid": ended(trace.valid, row["valid"][0]),
        "status": ended(trace.status, row["status"][0]),
        "unidentified": ended(trace.unidentified, row["unidentified"]),
    }
    for name, last in (extra or {}).items():
        fields[name] = ended(getattr(trace, name), last)
    return replace(trace, **fields)


def final_row(
    chain: IdentifierChain, context: Any, count: int, time_step: float
) -> tuple[int, dict[str, np.ndarray]]:
    """The log's final solve and row, after a Simulator run to t_N = N·h.

    Runs the final solve at the last sample t_{N-1} when it is not a solve time
    (``core.replay.solve_samples``; the identifier's periodic update evaluated at
    t_N, whose inputs then hold every bank update of the log) in ``context``, and
    returns ``(keep, row)``: the number of the loggers' rows before t_N
    (``core.replay.logged_samples``; a logged row at t_N is replaced) and the
    identifier's outputs, by logged port name, as the row at t_N. The on-line
    identifier's replay (:func:`replay_log`) and the payload identifier's
    (``payload_diagrams.replay_payload_log``) end their traces with it.
    """
    from drake_dynid.core.replay import logged_samples, solve_samples

    every = chain.settings.solve_decimation(time_step)
    tracking = chain.settings.detect_changes is not False
    final = solve_samples(count, every, final=not tracking)[-1]
    identifier = chain.identifier
    own = identifier.GetMyMutableContextFromRoot(context)
    if final % every:  # not a periodic solve: run it now
        own.SetDiscreteState(identifier.EvalUniquePeriodicDiscreteUpdate(own))
    keep = len(logged_samples(count, every)) - 1  # the loggers' rows before t_N
    row = {port: identifier.GetOutputPort(port).Eval(own) for port in chain.logs}
    return keep, row
