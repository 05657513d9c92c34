"""Joint friction (viscous + Coulomb + offset) as an applied generalized force.

The friction law itself lives in :mod:`drake_dynid.core.friction`; this block only
reads the plant's velocities and applies it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydrake.systems.framework import BasicVector, InputPort, LeafSystem, OutputPort

from drake_dynid.core import _validate
from drake_dynid.core.friction import (
    friction_coefficients,
    friction_force,
    friction_force_scalar,
    sign_law,
)

__all__ = ["JointFriction", "joint_friction_force"]

_OWNER = "JointFriction"


def joint_friction_force(
    v: np.ndarray,
    viscous: np.ndarray,
    coulomb: np.ndarray,
    offset: np.ndarray,
    smoothing: float = 0.0,
) -> np.ndarray:
    """Friction torque τ_f = FV·v + FC·s(v) + OFF per joint [N·m or N].

    s(v) = tanh(v/ε) when ``smoothing`` ε > 0 [rad/s or m/s], sign(v) when ε = 0
    (``core.friction.friction_force`` with ``core.friction.sign_law(ε)``). The
    force applied to the plant is -τ_f (friction opposes the motion).
    """
    return friction_force(v, viscous, coulomb, offset, sign_law(smoothing))


class JointFriction(LeafSystem):
    """Joint friction for a ``MultibodyPlant``'s applied generalized force input.

    .. pydrake_system::

        name: JointFriction
        input_ports:
        - state
        output_ports:
        - generalized_force

    Computes, per joint j (docs/MATH.md §2, friction τ_f,j = FV_j v_j + FC_j
    sign(v_j) + OFF_j; the law of :mod:`drake_dynid.core.friction`), the
    generalized force applied to the plant::

        generalized_force_j = -(FV_j v_j + FC_j s(v_j) + OFF_j)     [N·m or N]
        s(v) = tanh(v / ε)  (smoothing ε > 0, default 1e-2 rad/s),  sign(v) if ε = 0

    Connect ``plant.get_state_output_port()`` ([q; v], size 2n) to ``state`` and
    ``generalized_force`` (size n) to the plant's
    ``get_applied_generalized_force_input_port()``.

    Choices (docs/CONVENTIONS.md §7):

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
    plant's state output does not depend on its applied force. The block has no
    state. Double only (no AutoDiffXd or symbolic scalar conversion: the blocks of
    this package are plain Python ``LeafSystem`` classes).

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
        viscous, coulomb, offset = friction_coefficients(
            _OWNER, viscous, coulomb, offset
        )
        n = coulomb.size
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
        self._sign = sign_law(smoothing)
        self._coefficients = tuple(
            (float(a), float(b), float(c))
            for a, b, c in zip(viscous, coulomb, offset, strict=True)
        )
        self._state = self.DeclareVectorInputPort("state", 2 * n)
        self._force = self.DeclareVectorOutputPort(
            "generalized_force", n, self._CalcForce
        )

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

    def get_input_port_state(self) -> InputPort:
        """The input port ``state`` ([q; v], size 2n)."""
        return self._state

    def get_output_port_generalized_force(self) -> OutputPort:
        """The output port ``generalized_force`` (size n)."""
        return self._force

    def _CalcForce(self, context: Any, output: BasicVector) -> None:
        # Runs at every plant step: plain floats beat numpy on a few joints (the
        # same law as joint_friction_force; a test checks they agree).
        state = self._state.Eval(context)
        n, sign = self._num_joints, self._sign
        for j, (fv, fc, off) in enumerate(self._coefficients):
            force = friction_force_scalar(float(state[n + j]), fv, fc, off, sign)
            output.SetAtIndex(j, -force)
