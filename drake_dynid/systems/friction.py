"""Joint friction (viscous + Coulomb + offset) as an applied generalized force."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from drake_dynid.core import _validate

_OWNER = "JointFriction"


def joint_friction_force(
    v: np.ndarray,
    viscous: np.ndarray,
    coulomb: np.ndarray,
    offset: np.ndarray,
    smoothing: float = 0.0,
) -> np.ndarray:
    """Friction torque τ_f = FV·v + FC·s(v) + OFF per joint [N·m or N].

    s(v) = tanh(v/ε) when ``smoothing`` ε > 0 [rad/s or m/s], sign(v) when ε = 0.
    The force applied to the plant is -τ_f (friction opposes the motion).
    """
    if smoothing > 0.0:
        s = np.tanh(v / smoothing)
    else:
        s = np.sign(v)
    return viscous * v + coulomb * s + offset


class JointFriction(LeafSystem):
    """Joint friction for a ``MultibodyPlant``'s applied generalized force input.

    .. pydrake_system::

        name: JointFriction
        input_ports:
        - state
        output_ports:
        - generalized_force

    Computes, per joint j (MATH.md §2, friction τ_f,j = FV_j v_j + FC_j sign(v_j) +
    OFF_j), the generalized force applied to the plant::

        generalized_force_j = -(FV_j v_j + FC_j s(v_j) + OFF_j)     [N·m or N]
        s(v) = tanh(v / ε)  (smoothing ε > 0, default 1e-2 rad/s),  sign(v) if ε = 0

    Connect ``plant.get_state_output_port()`` ([q; v], size 2n) to ``state`` and
    ``generalized_force`` (size n) to the plant's
    ``get_applied_generalized_force_input_port()``.

    Choices (see notes/drake-facts.md §4):

    * **Smoothing.** Forces through this port are explicit in the plant's step. With a
      discrete plant, exact sign() makes the velocity chatter around zero (a limit
      cycle of about 1e-2 rad/s, sign flip every step). tanh(v/ε) with ε ≈ 1e-2 rad/s
      settles; the explicit-step condition is roughly h·FC/(ε·m_eff) < 1, keep a 2-3×
      margin. Use ε = 0 only with a continuous plant and an error-controlled
      integrator (slow). The identification models use sign(v); the difference is
      confined to |v| ≲ 3ε.
    * **Viscous.** Prefer URDF ``<dynamics damping>``: Drake applies joint damping
      implicitly (stable for any value). This block's viscous term is explicit and
      can go unstable for large FV, so :meth:`from_model` excludes it by default
      (``include_viscous=False``); include it only for a plant without damping.

    Direct feedthrough from ``state`` to ``generalized_force`` is inherent (the force
    is a function of the current velocity); it creates no algebraic loop because a
    plant's state output does not depend on its applied force.

    Args:
        viscous: FV per joint [N·m·s/rad or N·s/m], shape (n,).
        coulomb: FC per joint [N·m or N], shape (n,), >= 0.
        offset: OFF per joint [N·m or N], shape (n,); default zeros.
        smoothing: ε [rad/s or m/s], >= 0; 0 means exact sign().
    """

    def __init__(
        self,
        viscous: Any,
        coulomb: Any,
        offset: Any = None,
        *,
        smoothing: float = 1e-2,
    ) -> None:
        super().__init__()
        coulomb = _validate.array(_OWNER, "coulomb", coulomb, shape=(None,))
        n = coulomb.size
        if n == 0:
            raise ValueError(f"{_OWNER}: coulomb must have at least one joint; got 0.")
        viscous = _validate.array(_OWNER, "viscous", viscous, shape=(n,))
        offset = np.zeros(n) if offset is None else offset
        offset = _validate.array(_OWNER, "offset", offset, shape=(n,))
        if np.any(coulomb < 0.0):
            raise ValueError(
                f"{_OWNER}: coulomb must be >= 0 [N·m or N]; got {coulomb.tolist()}."
            )
        smoothing = _validate.real(_OWNER, "smoothing", smoothing, "rad/s or m/s")
        if smoothing < 0.0:
            raise ValueError(
                f"{_OWNER}: smoothing must be >= 0 [rad/s or m/s]; got {smoothing}."
            )
        self._num_joints = n
        self._viscous = viscous
        self._coulomb = coulomb
        self._offset = offset
        self._smoothing = smoothing
        self._coefficients = tuple(
            (float(a), float(b), float(c))
            for a, b, c in zip(viscous, coulomb, offset, strict=True)
        )
        self.DeclareVectorInputPort("state", 2 * n)
        self.DeclareVectorOutputPort("generalized_force", n, self._CalcForce)

    @classmethod
    def from_model(
        cls,
        model: Any,
        *,
        include_viscous: bool = False,
        smoothing: float = 1e-2,
    ) -> JointFriction:
        """Builds the block from a ``RobotModel``'s standard FV, FC, OFF values.

        Friction kinds absent from the model count as zero. The viscous term is
        excluded by default because the plant already applies the URDF damping.
        """
        values = model.standard_parameters()
        n = model.num_joints

        def column(prefix: str) -> np.ndarray:
            return np.array([values.get(f"{prefix}{j + 1}", 0.0) for j in range(n)])

        viscous = column("FV") if include_viscous else np.zeros(n)
        return cls(viscous, column("FC"), column("OFF"), smoothing=smoothing)

    @property
    def num_joints(self) -> int:
        """Number of joints n."""
        return self._num_joints

    @property
    def smoothing(self) -> float:
        """Smoothing ε [rad/s or m/s] (0: exact sign)."""
        return self._smoothing

    def _CalcForce(self, context: Any, output: BasicVector) -> None:
        # Runs at every plant step: plain floats beat numpy on a few joints (the
        # same equation as joint_friction_force; a test checks they agree).
        state = self.get_input_port(0).Eval(context)
        n, eps = self._num_joints, self._smoothing
        for j, (fv, fc, off) in enumerate(self._coefficients):
            v = float(state[n + j])
            s = math.tanh(v / eps) if eps > 0.0 else (v > 0.0) - (v < 0.0)
            output.SetAtIndex(j, -(fv * v + fc * s + off))
