"""The ``SlidingQRIdentifier`` block: least squares on the bank's sliding window."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    Context,
    DiscreteValues,
    InputPort,
    LeafSystem,
)

from drake_dynid.core import _validate as check
from drake_dynid.core.identifier import (
    IdentifierState,
    Status,
    identifier_init,
    identifier_update,
)
from drake_dynid.core.lsq import DEFAULT_MAX_CONDITION
from drake_dynid.core.rows import check_rows
from drake_dynid.systems._solver_block import (
    ESTIMATE_GROUPS,
    SolverBlock,
    estimate_vectors,
)

__all__ = ["SlidingQRIdentifier"]

# The state groups of the block, in declaration order (p: the parameters); each is
# also an output port of the same name.
_GROUPS = ESTIMATE_GROUPS


def _covariance_pair(owner: str, covariance: Any) -> tuple[Any, Any]:
    """``(design, rows)`` checked: a ``CovarianceDesign`` and a row provider."""
    from drake_dynid.core.row_covariance import CovarianceDesign

    if not (isinstance(covariance, tuple) and len(covariance) == 2):
        raise TypeError(
            f"{owner}: covariance must be a pair (CovarianceDesign, rows) "
            f"(OnlineSettings.covariance_design, the row provider); got "
            f"{type(covariance).__name__}."
        )
    design, rows = covariance
    check.instance(
        owner,
        "covariance design",
        design,
        CovarianceDesign,
        "a core.row_covariance.CovarianceDesign (OnlineSettings.covariance_design)",
    )
    check_rows(owner, rows)
    return design, rows


class SlidingQRIdentifier(SolverBlock, LeafSystem):
    r"""Least squares on the bank's sliding equations, with their uncertainty.

    .. pydrake_system::

        name: SlidingQRIdentifier
        input_ports:
        - A
        - B
        - window_valid
        - window_signals (with covariance)
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
    ``theta_std`` = √diag(C) (in the units of θ; with ``jackknife_groups``, the
    larger of it and the delete-one-group jackknife's σ), and ``condition_number``
    of A after scaling its columns to unit norm (docs/MATH.md §4). When the window
    is not ready, or the system is rank deficient or more ill-conditioned than
    ``max_condition``, the block **holds the last valid estimate** and its σ, sets
    ``valid`` = 0, and marks in ``unidentified`` (p, 0/1) the parameters found not
    excited; ``status`` is ``Status.OK`` (0), ``Status.WINDOW_NOT_READY`` (1: window
    not full or holding an invalid sample) or ``Status.NOT_IDENTIFIABLE`` (2: rank
    deficient or ill-conditioned). Before the first valid update ``theta`` is
    ``initial_theta`` (default zeros) and ``theta_std`` is +inf. The step is
    ``drake_dynid.core.identifier.identifier_update``, shared with the core replay.
    With ``covariance`` the solve is the covariance-weighted one
    (``core.row_covariance``), from the window's filtered signals read on the
    abstract input ``window_signals`` (a ``SignalWindow`` block's ``window``).

    State: one discrete state group per quantity (theta, theta_std,
    condition_number, valid, unidentified, status), each exposed by a state output
    port of the same name (no direct feedthrough). Double only: a plain Python
    ``LeafSystem`` has no AutoDiffXd or symbolic scalar conversion.
    """

    def __init__(
        self,
        num_parameters: int,
        num_rows: int,
        update_period: float,
        *,
        max_condition: float = DEFAULT_MAX_CONDITION,
        names: Sequence[str] | None = None,
        initial_theta: Sequence[float] | None = None,
        offset: float = 0.0,
        row_weighting: tuple[Any, Any] | None = None,
        row_noise: Any = None,
        jackknife_groups: Any = None,
        covariance: tuple[Any, Any] | None = None,
    ):
        """Builds the block.

        Args:
            num_parameters: p, unknowns.
            num_rows: r, rows of A and B (``ModulatingIntegralBank.num_rows``).
            update_period: seconds between two solves [s].
            max_condition: largest accepted condition number of the column-scaled A.
            names: parameter names (for messages), length p.
            initial_theta: estimate held before the first valid solve (default 0).
            offset: time of the first update [s]. Behind a bank fed every h,
                give ``core.online.SOLVE_OFFSET``·h (3h/4), as
                ``diagrams.add_online_identifier`` does: at offset 0, solves
                every 0.1 s behind a bank updating every 20 ms (offset 0) read
                its post-update window on 17 % of the solves (round-off of the
                event times; the others the pre-update one, 20 ms older), so
                the estimates do not follow docs/CONVENTIONS.md §2.
            row_weighting: ``(row_frequency, row_group)``, each (r,): the frequency
                index ν and noise group (model equation j) of each row
                (``bank.row_frequencies``). Given, every solve is the two-step
                frequency-weighted one
                (``weighted_lsq.solve_frequency_weighted_least_squares``: OLS, fit
                σ_j²(ν) = a_j + b_j ν² to its residuals, re-solve with 1/σ);
                None: ordinary least squares.
            row_noise: the rows' ``core.row_noise.RowNoise``
                (``OnlineSettings.row_noise``): σ is the honest sandwich σ
                (correlated rows, noise growing with frequency, docs/MATH.md §4)
                and windows with too few effective degrees of freedom are not
                valid; None: Gautier's σ.
            jackknife_groups: (r,) the jackknife group of each row
                (``OnlineSettings.jackknife_groups``): σ is then, per parameter,
                the larger of the σ above and the delete-one-group jackknife's
                (``core.jackknife``); None: no jackknife.
            covariance: ``(design, rows)``: the covariance weighting's
                ``core.row_covariance.CovarianceDesign``
                (``OnlineSettings.covariance_design``) and the uncompensated row
                provider; adds the input ``window_signals``. None: the solve of
                ``row_weighting``.
        """
        super().__init__()
        owner = "SlidingQRIdentifier"
        offset = self._configure(
            owner,
            num_parameters,
            num_rows,
            update_period,
            offset,
            max_condition,
            names,
            row_weighting,
            row_noise,
            jackknife_groups,
        )
        if initial_theta is not None:
            check.array(owner, "initial_theta", initial_theta, (self._p,))
        initial = identifier_init(self._p, initial_theta)
        self._declare(self._p, _GROUPS, self._as_vectors(initial), offset, self._Solve)
        self._covariance = covariance
        self._window_signals = None
        if covariance is not None:
            design, _ = _covariance_pair(owner, covariance)
            if design.num_rows != self._r:
                check.fail(
                    owner,
                    f"covariance must describe {self._r} rows; its design has "
                    f"{design.num_rows}.",
                )
            self._window_signals = self.DeclareAbstractInputPort(
                "window_signals", AbstractValue.Make(object())
            )

    def get_input_port_window_signals(self) -> InputPort:
        """The input port ``window_signals`` (with ``covariance`` only)."""
        if self._window_signals is None:
            raise RuntimeError(
                "SlidingQRIdentifier: window_signals exists with covariance only."
            )
        return self._window_signals

    def _row_covariance(self, context: Context, ready: bool) -> Any:
        """θ -> Σ of the window's rows (covariance weighting), else None."""
        if self._covariance is None or not ready:
            return None
        from drake_dynid.core.row_covariance import row_covariance

        port = self._window_signals
        assert port is not None  # built with the covariance weighting
        window = port.Eval(context)
        if window is None:
            raise RuntimeError(
                "SlidingQRIdentifier: window_signals holds fewer samples than the "
                "bank's window; connect the SignalWindow of the same bank."
            )
        if not (isinstance(window, tuple) and len(window) == 3):
            raise TypeError(
                "SlidingQRIdentifier: window_signals must be a SignalWindow's "
                "window, (q_hat, v_hat, tau_hat) or None; got "
                f"{type(window).__name__}."
            )
        design, rows = self._covariance
        q_hat, v_hat, tau_hat = window
        return lambda theta: row_covariance(design, rows, q_hat, v_hat, tau_hat, theta)

    def status(self, context: Context) -> Status:
        """The status of the last update."""
        return Status(int(self._value(context, "status")[0]))

    def state(self, context: Context) -> IdentifierState:
        """The identifier's state in ``context`` (``core.identifier``)."""
        return self._estimate(context)

    @staticmethod
    def _as_vectors(state: IdentifierState) -> tuple[np.ndarray, ...]:
        return estimate_vectors(state)

    def _Solve(self, context: Context, discrete_state: DiscreteValues) -> None:
        ready = self._window_valid.Eval(context)[0] > 0.5
        a = self._a.Eval(context).reshape(self._r, self._p) if ready else None
        b = self._b.Eval(context) if ready else None
        new = identifier_update(
            self.state(context),
            ready,
            a,
            b,
            weighting=self._weighting,
            max_condition=self._max_condition,
            names=self._names,
            noise=self._noise,
            jackknife=self._jackknife,
            covariance=self._row_covariance(context, ready),
        )
        for name, value in zip(_GROUPS, self._as_vectors(new), strict=True):
            discrete_state.set_value(int(self._groups[name]), value)
