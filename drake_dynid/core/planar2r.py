"""Analytic regressors of the paper's 2R arm (Guo, Perruquetti & Gautier 2014, §V).

Two revolute joints about parallel vertical axes (horizontal plane: gravity has no
effect), link-1 length ``L1`` [m]. Base parameters, in this order (SI units)::

    X = [ZZ1R, ZZ2, MX2, MY2, (FV1, FC1, OFF1), (FV2, FC2, OFF2)]
    ZZ1R = ZZ1 + M2·L1²   [kg·m²],  ZZ2 [kg·m²],  MX2, MY2 [kg·m]
    FVj [N·m·s/rad],  FCj [N·m],  OFFj [N·m]     (the friction subset is selectable)

With c2 = cos q2, s2 = sin q2 and the total energy H = h(q, v)·X (friction columns of
h are zero)::

    h = [½v1², ½(v1+v2)², L1 c2 (v1² + v1 v2), -L1 s2 (v1² + v1 v2)]

    τ1 = [v̇1, v̇1+v̇2, L1(c2(2v̇1+v̇2) - s2(2v1v2+v2²)), -L1(s2(2v̇1+v̇2) + c2(2v1v2+v2²)),
          v1, sign v1, 1, 0, 0, 0]·X
    τ2 = [0, v̇1+v̇2, L1(c2 v̇1 + s2 v1²), L1(-s2 v̇1 + c2 v1²), 0, 0, 0, v2, sign v2, 1]·X

Everything is vectorised over a leading sample axis: ``q``, ``v``, ``vdot``, ``tau``
are ``(N, 2)`` (or ``(2,)`` for one sample, which drops the sample axis of the
results). Pure numpy: this is the fast path of the on-line blocks for the 2R arm and
an independent check of the generic Drake-based regressor in ``drake_dynid.robot``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from drake_dynid.core import _validate

# Friction and the row contract live in their own modules; these names stay
# importable from here for the modules that imported them before the split.
from drake_dynid.core.friction import (
    FRICTION_KINDS,
    FRICTION_PREFIX,
    SignLaw,
    check_coulomb_width,
    check_friction,
    friction_idim_columns,
    friction_names,
    friction_power_columns,
    friction_value,
    sign_law,
)
from drake_dynid.core.rows import (
    MODEL_KINDS,
    as_batch,
    as_batches,
    check_model_kind,
    lagrangian_friction_part,
    model_rows_from_parts,
)

__all__ = [
    "FRICTION_KINDS",
    "FRICTION_PREFIX",
    "MODEL_KINDS",
    "PAPER_BASE_VALUES",
    "Planar2RRows",
    "as_batch",
    "as_batches",
    "check_friction",
    "friction_idim_columns",
    "friction_power_columns",
    "model_rows_from_parts",
]

#: The paper's true base-parameter values (Table II), friction viscous + Coulomb.
PAPER_BASE_VALUES = MappingProxyType(
    {
        "ZZ1R": 3.9,
        "ZZ2": 0.25,
        "MX2": 0.45,
        "MY2": 0.1,
        "FV1": 0.3,
        "FC1": 0.4,
        "FV2": 0.15,
        "FC2": 0.25,
    }
)

_OWNER = "Planar2RRows"
_NUM_JOINTS = 2
_NUM_INERTIAL = 4


def _drop(single: bool, *arrays: np.ndarray):
    if single:
        arrays = tuple(a[0] for a in arrays)
    return arrays[0] if len(arrays) == 1 else arrays


@dataclass(frozen=True)
class Planar2RRows:
    """Analytic rows of the paper's 2R arm in base-parameter columns.

    The same interface as ``drake_dynid.robot.RobotModel`` (``names``,
    ``energy_rows``, ``momentum_rows``, ``lagrangian_rows``, ``idim_rows``,
    ``power_rows``, ``model_rows``), pure numpy and vectorised. See the module
    docstring for the equations.

    Attributes:
        L1: link-1 length (distance between the two joint axes) [m], > 0.
        friction: friction columns per joint, a subset of ``("viscous", "coulomb",
            "offset")`` in that order; default viscous + Coulomb (the paper's 8
            parameters).
        coulomb_width: width ε of a smooth Coulomb law s(v) = tanh(v/ε) [rad/s];
            0 (default): s(v) = sign(v) (``core.friction.sign_law``).
    """

    L1: float = 1.0
    friction: tuple[str, ...] = ("viscous", "coulomb")
    coulomb_width: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "L1", _validate.positive(_OWNER, "L1", self.L1, "m"))
        object.__setattr__(self, "friction", check_friction(_OWNER, self.friction))
        object.__setattr__(
            self, "coulomb_width", check_coulomb_width(_OWNER, self.coulomb_width)
        )

    @property
    def sign(self) -> SignLaw:
        """The Coulomb law s(v) of the friction columns (sign or tanh(v/ε))."""
        return sign_law(self.coulomb_width)

    @property
    def num_joints(self) -> int:
        """Number of joints (2)."""
        return _NUM_JOINTS

    @property
    def names(self) -> tuple[str, ...]:
        """Base-parameter names: ZZ1R, ZZ2, MX2, MY2, then friction per joint."""
        return ("ZZ1R", "ZZ2", "MX2", "MY2", *friction_names(self.friction, 2))

    @property
    def num_parameters(self) -> int:
        """Number of base parameters p."""
        return _NUM_INERTIAL + _NUM_JOINTS * len(self.friction)

    def _zeros(self, *shape: int) -> np.ndarray:
        return np.zeros((*shape, self.num_parameters))

    def energy_rows(self, q, v) -> np.ndarray:
        """Energy rows h(q, v), shape ``(N, p)``: total energy H = h·X [J].

        h = [½v1², ½(v1+v2)², L1 c2 (v1² + v1 v2), -L1 s2 (v1² + v1 v2), 0...].
        """
        q, v, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v)
        return _drop(single, self._energy(q, v))

    def _energy(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        v1, v2 = v[:, 0], v[:, 1]
        c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
        w = v1 * v1 + v1 * v2
        out = self._zeros(q.shape[0])
        out[:, 0] = 0.5 * v1 * v1
        out[:, 1] = 0.5 * (v1 + v2) ** 2
        out[:, 2] = self.L1 * c2 * w
        out[:, 3] = -self.L1 * s2 * w
        return out

    def momentum_rows(self, q, v) -> np.ndarray:
        """Generalized-momentum rows ∂h_E/∂v, shape ``(N, 2, p)`` [kg·m²/s per unit].

        ∂h/∂v1 = [v1, v1+v2, L1 c2 (2v1+v2), -L1 s2 (2v1+v2)],
        ∂h/∂v2 = [0, v1+v2, L1 c2 v1, -L1 s2 v1].
        """
        q, v, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v)
        return _drop(single, self._momentum(q, v))

    def _momentum(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        v1, v2 = v[:, 0], v[:, 1]
        c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
        out = self._zeros(q.shape[0], 2)
        out[:, 0, 0] = v1
        out[:, 0, 1] = v1 + v2
        out[:, 0, 2] = self.L1 * c2 * (2 * v1 + v2)
        out[:, 0, 3] = -self.L1 * s2 * (2 * v1 + v2)
        out[:, 1, 1] = v1 + v2
        out[:, 1, 2] = self.L1 * c2 * v1
        out[:, 1, 3] = -self.L1 * s2 * v1
        return out

    def _position(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        v1, v2 = v[:, 0], v[:, 1]
        c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
        w = v1 * v1 + v1 * v2
        out = self._zeros(q.shape[0], 2)
        out[:, 1, 2] = -self.L1 * s2 * w
        out[:, 1, 3] = -self.L1 * c2 * w
        return out

    def lagrangian_rows(self, q, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Returns ``(∂h_E/∂v, ∂h_E/∂q, ∂h_U/∂q)``, each ``(N, 2, p)``.

        ∂h_E/∂q1 = 0, ∂h_E/∂q2 = [0, 0, -L1 s2 (v1²+v1v2), -L1 c2 (v1²+v1v2)];
        ∂h_U/∂q = 0 (horizontal plane). Lagrange's equations read
        d/dt(∂h_E/∂v)·X - ∂h_E/∂q·X + ∂h_U/∂q·X + τ_f = τ.
        """
        q, v, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v)
        out = self._lagrangian(q, v)
        return _drop(single, *out)

    def _lagrangian(self, q, v):
        return (
            self._momentum(q, v),
            self._position(q, v),
            self._zeros(q.shape[0], 2),
        )

    def idim_rows(self, q, v, vdot) -> np.ndarray:
        """Inverse-dynamics rows W(q, v, v̇), shape ``(N, 2, p)``: τ = W·X [N·m].

        See the module docstring for τ1 and τ2; friction columns v_j, s(v_j), 1
        (s = sign, or tanh(v/ε) with ``coulomb_width`` ε).
        """
        q, v, vdot, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v, vdot=vdot)
        return _drop(single, self._idim(q, v, vdot))

    def _idim(self, q, v, vdot):
        v1, v2 = v[:, 0], v[:, 1]
        a1, a2 = vdot[:, 0], vdot[:, 1]
        c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
        L1 = self.L1
        out = self._zeros(q.shape[0], 2)
        out[:, 0, 0] = a1
        out[:, 0, 1] = a1 + a2
        out[:, 0, 2] = L1 * (c2 * (2 * a1 + a2) - s2 * (2 * v1 * v2 + v2 * v2))
        out[:, 0, 3] = -L1 * (s2 * (2 * a1 + a2) + c2 * (2 * v1 * v2 + v2 * v2))
        out[:, 1, 1] = a1 + a2
        out[:, 1, 2] = L1 * (c2 * a1 + s2 * v1 * v1)
        out[:, 1, 3] = L1 * (-s2 * a1 + c2 * v1 * v1)
        out[:, :, _NUM_INERTIAL:] = friction_idim_columns(v, self.friction, self.sign)
        return out

    def power_rows(self, q, v, vdot) -> np.ndarray:
        """Power rows vᵀW = [d/dt h, friction power], shape ``(N, p)`` [W per unit].

        Power balance (docs/MATH.md §2, eq. P): d/dt(h)·X + Σ_j FV_j v_j² + FC_j |v_j|
        + OFF_j v_j = vᵀτ.
        """
        q, v, vdot, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v, vdot=vdot)
        return _drop(single, np.einsum("ni,nip->np", v, self._idim(q, v, vdot)))

    def packed_rows(self, kind: str, q, v, tau) -> np.ndarray:
        """One sample's model rows, packed as ``core.rows.pack_rows(D, G, y)``.

        The single-sample fast path of :meth:`model_rows` for the on-line blocks
        (``ModelRows`` evaluates one sample per bank update): the same equations
        with plain floats, about 10x cheaper than numpy on (1, 2) arrays. No
        validation beyond the kind; non-finite inputs give non-finite channels.

        Args:
            kind: ``"power"`` or ``"lagrangian"``.
            q: (2,) joint positions [rad].
            v: (2,) joint velocities [rad/s].
            tau: (2,) joint torques [N·m].

        Returns:
            ``[D row-major, G row-major, y]``, length ``2·m·p + m``.
        """
        kind = check_model_kind(_OWNER, kind)
        q2 = float(q[1])
        v1, v2 = float(v[0]), float(v[1])
        c2, s2 = math.cos(q2), math.sin(q2)
        L1, p, width = self.L1, self.num_parameters, len(self.friction)
        sign = self.sign
        if kind == "lagrangian":
            # D: 2 rows (momentum), G: 2 rows (-∂h_E/∂q + friction), y = τ.
            out = [0.0] * (4 * p + 2)
            a, b = L1 * c2, L1 * s2
            out[0:4] = (v1, v1 + v2, a * (2 * v1 + v2), -b * (2 * v1 + v2))
            out[p + 1 : p + 4] = (v1 + v2, a * v1, -b * v1)
            w = v1 * v1 + v1 * v2
            out[3 * p + 2 : 3 * p + 4] = (b * w, a * w)
            for i, vi in enumerate((v1, v2)):
                row = 2 * p + i * p + _NUM_INERTIAL + i * width
                for k, kind_f in enumerate(self.friction):
                    out[row + k] = friction_value(kind_f, vi, sign)
            out[4 * p] = float(tau[0])
            out[4 * p + 1] = float(tau[1])
        else:  # power
            out = [0.0] * (2 * p + 1)
            w = v1 * v1 + v1 * v2
            out[0:4] = (0.5 * v1 * v1, 0.5 * (v1 + v2) ** 2, L1 * c2 * w, -L1 * s2 * w)
            for i, vi in enumerate((v1, v2)):
                row = p + _NUM_INERTIAL + i * width
                for k, kind_f in enumerate(self.friction):
                    out[row + k] = vi * friction_value(kind_f, vi, sign)
            out[2 * p] = v1 * float(tau[0]) + v2 * float(tau[1])
        return np.array(out)

    def lagrangian_friction_rows(
        self, v, block: int = 1
    ) -> tuple[np.ndarray, np.ndarray]:
        """G's friction part of the Lagrangian rows: ``(columns, values)``.

        ``core.rows.lagrangian_friction_part``: v (N, 2) [rad/s] -> the friction
        columns (k,) and the means of their values in G over consecutive blocks
        of ``block`` samples, (N/block, 2, k).
        """
        v = np.asarray(v, dtype=float)
        return lagrangian_friction_part(
            v,
            slice(_NUM_INERTIAL, None),
            self.friction,
            self.num_parameters,
            self.sign,
            block,
        )

    def model_rows(
        self, kind: str, q, v, tau
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Model rows (D, G, y) of docs/CONVENTIONS.md §3, in base columns.

        Modulated equation: -M_ġ(D)·X + M_g(G)·X = M_g(y), i.e. d/dt(D·X) + G·X = y.

        Args:
            kind: ``"power"`` (m = 1: D = h, G = friction power, y = vᵀτ [W]) or
                ``"lagrangian"`` (m = 2: D = ∂h_E/∂v, G = ∂h_U/∂q - ∂h_E/∂q +
                friction, y = τ [N·m]).
            q: joint positions [rad], ``(N, 2)`` or ``(2,)``.
            v: joint velocities [rad/s], same shape.
            tau: joint torques [N·m], same shape.

        Returns:
            ``D`` and ``G`` of shape ``(N, m, p)`` and ``y`` of shape ``(N, m)``
            (without the sample axis for a single sample).
        """
        q, v, tau, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v, tau=tau)
        out = model_rows_from_parts(
            kind,
            _OWNER,
            v,
            tau,
            lambda: self._energy(q, v),
            lambda: self._lagrangian(q, v),
            slice(_NUM_INERTIAL, None),
            self.friction,
            self.num_parameters,
            self.sign,
        )
        return _drop(single, *out)
