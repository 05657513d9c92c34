"""On-line identification blocks: model rows, modulating-integral bank, sliding QR.

The three blocks of the on-line identifier (MATH.md §3-§4, CONVENTIONS.md §3)::

    (q̂, v̂, τ̂) ──► ModelRows ──channels──► ModulatingIntegralBank ──A, B──►
    SlidingQRIdentifier ──► θ̂, σ(θ̂), cond, valid

Each block is a thin wrapper over ``drake_dynid.core``; all state lives in the Context.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State

from drake_dynid.core import _validate as check
from drake_dynid.core import lsq, modulating

__all__ = ["ModelRows", "ModulatingIntegralBank", "SlidingQRIdentifier"]

_KINDS = ("power", "lagrangian")


class ModelRows(LeafSystem):
    r"""Per-sample rows (D, G, y) of the power or Lagrangian model, packed.

    .. pydrake_system::

        name: ModelRows
        input_ports:
        - q
        - v
        - tau
        output_ports:
        - channels

    For the signals of one instant (already aligned by the differentiator), the
    output packs the arrays of the modulated equation (CONVENTIONS.md §3)

        -M_ġ(D(q, v))·θ + M_g(G(q, v))·θ = M_g(y(q, v, τ))

    as ``drake_dynid.core.modulating.pack_rows(D, G, y)``: ``D``, ``G`` are
    ``m × p`` and ``y`` is ``m`` (m = 1 for the power model, n for the Lagrangian
    model; p base parameters). Units follow the base parameters: D·θ is an energy [J]
    (power model) or a momentum [N·m·s] (Lagrangian model).

    The output is computed from the inputs (direct feedthrough, no state); it is
    evaluated only when a downstream block reads it, e.g. at the bank's
    (decimated) update rate.
    """

    def __init__(self, rows: Any, kind: str = "lagrangian"):
        """Builds the block.

        Args:
            rows: a row provider with ``num_joints``, ``num_parameters`` and
                ``model_rows(kind, q, v, tau) -> (D, G, y)`` on batches (N, n),
                e.g. a ``drake_dynid.RobotModel``.
            kind: ``"power"`` (the paper's model, m = 1) or ``"lagrangian"`` (m = n).
        """
        super().__init__()
        if kind not in _KINDS:
            check.fail("ModelRows", f"kind must be one of {_KINDS}; got {kind!r}.")
        self._rows = rows
        self._kind = kind
        n = int(rows.num_joints)
        p = int(rows.num_parameters)
        self._m = 1 if kind == "power" else n
        self._p = p
        self._num_channels = modulating.num_channels(self._m, p)
        # Providers with ``packed_rows(kind, q, v, tau)`` (one sample, packed as
        # ``pack_rows``) skip numpy's per-call overhead on (1, n) batches.
        self._packed = getattr(rows, "packed_rows", None)
        self._q = self.DeclareVectorInputPort("q", n)
        self._v = self.DeclareVectorInputPort("v", n)
        self._tau = self.DeclareVectorInputPort("tau", n)
        self.DeclareVectorOutputPort("channels", self._num_channels, self._CalcChannels)

    @property
    def kind(self) -> str:
        """The model kind, ``"power"`` or ``"lagrangian"``."""
        return self._kind

    @property
    def num_equations(self) -> int:
        """m, equations per sample."""
        return self._m

    @property
    def num_parameters(self) -> int:
        """p, base parameters."""
        return self._p

    def _CalcChannels(self, context: Context, output: BasicVector) -> None:
        q = self._q.Eval(context)
        v = self._v.Eval(context)
        tau = self._tau.Eval(context)
        if self._packed is not None:  # single-sample fast path (Planar2RRows)
            output.SetFromVector(self._packed(self._kind, q, v, tau))
            return
        d, g, y = self._rows.model_rows(self._kind, q[None, :], v[None, :], tau[None])
        output.SetFromVector(np.concatenate([d[0].ravel(), g[0].ravel(), y[0]]))


class ModulatingIntegralBank(LeafSystem):
    r"""Sliding Fourier modulating integrals of the model rows over a window T.

    .. pydrake_system::

        name: ModulatingIntegralBank
        input_ports:
        - channels
        - sample_valid
        output_ports:
        - A
        - B
        - valid

    Every ``bank.time_step`` seconds the block pushes the input sample (the packed
    rows of CONVENTIONS.md §3) into its sliding window of length T and updates the
    Fourier integrals F_ν(f) = ∫_{t-T}^{t} e^{-jνω0 s} f dv, ω0 = 2π/T, recursively
    (cost independent of T). The outputs stack, for every ℓ of the bank and every
    equation, the real and imaginary parts of

        -M_ġ(D)·θ + M_g(G)·θ = M_g(y),     g_ℓ(s) = (1/T) e^{-jℓω0 s}(e^{-jω0 s} - 1)^k,

    into ``A`` (flattened row-major, rows × p) and ``B`` (rows).

    ``valid`` is 1 when the window is full and holds no invalid sample: a sample with
    ``sample_valid`` = 0 or any non-finite channel is stored as zeros and makes the
    window invalid until it has left the window (T later).

    State: one abstract slot holding the core's sliding state (a persistent ring of
    the window's samples plus running sums; cheap to copy). Outputs are computed
    from the state only (no direct feedthrough), so after the update at t_k they
    describe the window ending with the sample read at t_k.
    """

    def __init__(
        self,
        bank: modulating.FourierBank,
        num_equations: int,
        num_parameters: int,
        *,
        offset: float = 0.0,
    ):
        """Builds the block.

        Args:
            bank: the modulating-function design (window T, sample period, order,
                ℓ set), from ``drake_dynid.core.modulating.fourier_bank``.
            num_equations: m, equations per sample (1 power, n Lagrangian).
            num_parameters: p, columns of A.
            offset: time of the first update [s].
        """
        super().__init__()
        if not isinstance(bank, modulating.FourierBank):
            raise TypeError(
                "ModulatingIntegralBank: bank must be a FourierBank (from "
                f"drake_dynid.core.modulating.fourier_bank); got {type(bank).__name__}."
            )
        self._bank = bank
        self._m = check.integer(
            "ModulatingIntegralBank", "num_equations", num_equations, 1
        )
        self._p = check.integer(
            "ModulatingIntegralBank", "num_parameters", num_parameters, 1
        )
        self._c = modulating.num_channels(self._m, self._p)
        self._num_rows = modulating.num_equation_rows(bank, self._m)
        self.DeclareVectorInputPort("channels", self._c)
        self.DeclareVectorInputPort("sample_valid", 1)
        initial = modulating.sliding_init(bank, self._c)
        self._state_index = self.DeclareAbstractState(AbstractValue.Make(initial))
        self.DeclarePeriodicUnrestrictedUpdateEvent(
            bank.time_step, offset, self._UpdateWindow
        )
        ticket = {self.abstract_state_ticket(self._state_index)}
        self._equations_cache = self.DeclareCacheEntry(
            description="modulated equations (A, B) of the current window",
            value_producer=self._MakeEquationsProducer(),
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort(
            "A", self._num_rows * self._p, self._CalcA, prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "B", self._num_rows, self._CalcB, prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "valid", 1, self._CalcValid, prerequisites_of_calc=ticket
        )

    def _MakeEquationsProducer(self):
        from pydrake.systems.framework import ValueProducer

        def allocate():
            return AbstractValue.Make((np.zeros((0, 0)), np.zeros(0)))

        def calc(context, value):
            state = context.get_abstract_state(self._state_index).get_value()
            value.set_value(self._Equations(state))

        return ValueProducer(allocate=allocate, calc=calc)

    @property
    def bank(self) -> modulating.FourierBank:
        """The modulating-function design."""
        return self._bank

    @property
    def num_rows(self) -> int:
        """Rows of A and B (2·L·m minus identically zero rows)."""
        return self._num_rows

    def _Equations(self, state) -> tuple[np.ndarray, np.ndarray]:
        integrals = modulating.sliding_fourier_integrals(self._bank, state)
        return modulating.assemble_equations(self._bank, integrals, self._m, self._p)

    def _UpdateWindow(self, context: Context, state: State) -> None:
        sample = np.array(self.get_input_port(0).Eval(context), dtype=float)
        ok = self.get_input_port(1).Eval(context)[0] > 0.5 and np.all(
            np.isfinite(sample)
        )
        current = context.get_abstract_state(self._state_index).get_value()
        new = modulating.sliding_push(self._bank, current, sample, valid=bool(ok))
        state.get_mutable_abstract_state(self._state_index).set_value(new)

    def _CalcA(self, context: Context, output: BasicVector) -> None:
        a, _ = self._equations_cache.Eval(context)
        output.SetFromVector(a.ravel())

    def _CalcB(self, context: Context, output: BasicVector) -> None:
        _, b = self._equations_cache.Eval(context)
        output.SetFromVector(b)

    def _CalcValid(self, context: Context, output: BasicVector) -> None:
        state = context.get_abstract_state(self._state_index).get_value()
        output.SetAtIndex(0, 1.0 if modulating.window_valid(state) else 0.0)


# Status codes of SlidingQRIdentifier (output ``status``), defined in the core.
STATUS_OK = lsq.STATUS_OK
STATUS_WINDOW_NOT_READY = lsq.STATUS_WINDOW_NOT_READY
STATUS_NOT_IDENTIFIABLE = lsq.STATUS_NOT_IDENTIFIABLE


class SlidingQRIdentifier(LeafSystem):
    r"""Least squares on the bank's sliding equations, with Gautier's uncertainty.

    .. pydrake_system::

        name: SlidingQRIdentifier
        input_ports:
        - A
        - B
        - window_valid
        output_ports:
        - theta
        - theta_std
        - condition_number
        - valid
        - unidentified
        - status

    Every ``update_period`` seconds, if ``window_valid`` is 1, the block solves

        θ̂ = argmin ‖A θ - B‖₂      by QR (numpy), A: r × p,

    with σ_ρ² = ‖B - Aθ̂‖²/(r - p), C = σ_ρ² (AᵀA)⁻¹ (from R, never a pseudo-inverse),
    ``theta_std`` = √diag(C) (in the units of θ), and ``condition_number`` of A after
    scaling its columns to unit norm. When the window is not ready, or the system
    is rank deficient or more ill-conditioned than ``max_condition``, the block
    **holds the last valid estimate** and its σ, sets ``valid`` = 0, and marks in
    ``unidentified`` (p, 0/1) the parameters found not excited; ``status`` is
    ``STATUS_OK`` (0), ``STATUS_WINDOW_NOT_READY`` (1: window not full or holding an
    invalid sample) or ``STATUS_NOT_IDENTIFIABLE`` (2: rank deficient or
    ill-conditioned). Before the first
    valid update ``theta`` is ``initial_theta`` (default zeros) and ``theta_std``
    is +inf.

    State: numeric, [θ (p) | σ (p) | cond | valid | unidentified (p) | status]. All
    outputs are computed from the state only (no direct feedthrough).
    """

    def __init__(
        self,
        num_parameters: int,
        num_rows: int,
        update_period: float,
        *,
        max_condition: float = 1e4,
        names: Sequence[str] | None = None,
        initial_theta: Sequence[float] | None = None,
        offset: float = 0.0,
        row_weighting: tuple[Sequence[float], Sequence[int]] | None = None,
    ):
        """Builds the block.

        Args:
            num_parameters: p, unknowns.
            num_rows: r, rows of A and B (``ModulatingIntegralBank.num_rows``).
            update_period: seconds between two solves [s].
            max_condition: largest accepted condition number of the column-scaled A.
            names: parameter names (for messages), length p.
            initial_theta: estimate held before the first valid solve (default 0).
            offset: time of the first update [s].
            row_weighting: ``(row_frequency, row_group)``, each (r,): the frequency
                index ν and noise group (model equation j) of each row
                (``modulating.row_frequencies``). Given, every solve is the
                two-step frequency-weighted one
                (``lsq.solve_frequency_weighted_least_squares``: OLS, fit
                σ_j²(ν) = a_j + b_j ν² to its residuals, re-solve with 1/σ);
                None: ordinary least squares.
        """
        super().__init__()
        owner = "SlidingQRIdentifier"
        p = check.integer(owner, "num_parameters", num_parameters, 1)
        r = check.integer(owner, "num_rows", num_rows, 1)
        self._period = check.positive(owner, "update_period", update_period, "s")
        self._max_condition = check.greater_than(
            owner, "max_condition", max_condition, 1.0
        )
        if names is not None and len(names) != p:
            check.fail(owner, f"names must have {p} entries; got {len(names)}.")
        self._names = tuple(names) if names is not None else None
        theta0 = (
            np.zeros(p)
            if initial_theta is None
            else check.array(owner, "initial_theta", initial_theta, (p,))
        )
        self._p, self._r = p, r
        self._weighting = None
        if row_weighting is not None:
            frequency, group = row_weighting
            self._weighting = (
                check.array(owner, "row_frequency", frequency, (r,)),
                check.array(owner, "row_group", group, (r,)).astype(int),
            )
        self.DeclareVectorInputPort("A", r * p)
        self.DeclareVectorInputPort("B", r)
        self.DeclareVectorInputPort("window_valid", 1)
        initial = np.concatenate(
            [
                theta0,
                np.full(p, np.inf),
                [np.inf, 0.0],
                np.zeros(p),
                [STATUS_WINDOW_NOT_READY],
            ]
        )
        self._xd = self.DeclareDiscreteState(initial)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, offset, self._Solve)
        ticket = {self.discrete_state_ticket(self._xd)}
        self.DeclareVectorOutputPort(
            "theta", p, self._Slice(0, p), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "theta_std", p, self._Slice(p, 2 * p), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "condition_number",
            1,
            self._Slice(2 * p, 2 * p + 1),
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort(
            "valid", 1, self._Slice(2 * p + 1, 2 * p + 2), prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort(
            "unidentified",
            p,
            self._Slice(2 * p + 2, 3 * p + 2),
            prerequisites_of_calc=ticket,
        )
        self.DeclareVectorOutputPort(
            "status", 1, self._Slice(3 * p + 2, 3 * p + 3), prerequisites_of_calc=ticket
        )

    @property
    def update_period(self) -> float:
        """Seconds between two solves."""
        return self._period

    def _Slice(self, start: int, stop: int):
        def calc(context: Context, output: BasicVector) -> None:
            x = context.get_discrete_state(self._xd).get_value()
            output.SetFromVector(x[start:stop])

        return calc

    def status(self, context: Context) -> int:
        """The status code of the last update (``STATUS_*``)."""
        return int(context.get_discrete_state(self._xd).get_value()[-1])

    def _Solve(self, context: Context, discrete_state) -> None:
        p = self._p
        x = discrete_state.get_mutable_value(self._xd)
        if self.get_input_port(2).Eval(context)[0] < 0.5:
            x[2 * p + 1] = 0.0
            x[-1] = STATUS_WINDOW_NOT_READY
            return
        a = self.get_input_port(0).Eval(context).reshape(self._r, p)
        b = self.get_input_port(1).Eval(context)
        result = lsq.solve_window(
            a,
            b,
            self._weighting,
            max_condition=self._max_condition,
            names=self._names,
        )
        x[2 * p] = result.condition_number
        x[2 * p + 2 : 3 * p + 2] = 0.0
        if result.valid:
            x[:p] = result.theta
            x[p : 2 * p] = result.std
            x[2 * p + 1] = 1.0
            x[-1] = STATUS_OK
        else:
            x[2 * p + 1] = 0.0
            x[2 * p + 2 + np.asarray(result.unidentified_indices, dtype=int)] = 1.0
            x[-1] = STATUS_NOT_IDENTIFIABLE
