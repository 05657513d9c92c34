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

#: Friction kinds in column order, with the column prefix of each.
FRICTION_KINDS = ("viscous", "coulomb", "offset")
FRICTION_PREFIX = MappingProxyType({"viscous": "FV", "coulomb": "FC", "offset": "OFF"})

#: Model kinds of the (D, G, y) contract (docs/CONVENTIONS.md §3).
MODEL_KINDS = ("power", "lagrangian")

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


def check_friction(owner: str, friction: object) -> tuple[str, ...]:
    """Returns ``friction`` as a tuple of kinds in canonical order, or raises.

    Args:
        owner: the name used in error messages.
        friction: an iterable of kinds among ``"viscous"``, ``"coulomb"`` and
            ``"offset"`` (a comma-separated string is accepted too).

    Returns:
        The kinds, without duplicates, in the order viscous, coulomb, offset.
    """
    if isinstance(friction, str):
        friction = [item.strip() for item in friction.split(",") if item.strip()]
    try:
        kinds = list(friction)  # type: ignore[call-overload]
    except TypeError:
        raise TypeError(
            f"{owner}: friction must be a sequence of {FRICTION_KINDS}; got "
            f"{friction!r}."
        ) from None
    unknown = [kind for kind in kinds if kind not in FRICTION_KINDS]
    if unknown:
        raise ValueError(
            f"{owner}: friction kinds must be among {', '.join(FRICTION_KINDS)}; got "
            f"{', '.join(map(str, unknown))}."
        )
    return tuple(kind for kind in FRICTION_KINDS if kind in kinds)


def as_batch(
    owner: str, name: str, value: object, num_joints: int
) -> tuple[np.ndarray, bool]:
    """Returns ``(array of shape (N, num_joints), single)`` from (n,) or (N, n).

    ``single`` is True when one sample of shape ``(n,)`` was given; callers then drop
    the sample axis of their results.
    """
    array = (
        np.asarray(value, dtype=float) if not isinstance(value, np.ndarray) else value
    )
    single = array.ndim == 1
    if single:
        array = array[None, :]
    array = _validate.array(owner, name, array, shape=(None, num_joints))
    return array, single


def as_batches(owner: str, num_joints: int, **arrays: object):
    """Converts several per-joint arrays with :func:`as_batch`; checks equal N.

    Returns:
        The ``(N, num_joints)`` arrays in keyword order, then ``single``.
    """
    out = []
    singles = []
    for name, value in arrays.items():
        array, single = as_batch(owner, name, value, num_joints)
        out.append(array)
        singles.append(single)
    counts = [a.shape[0] for a in out]
    if len(set(counts)) > 1:
        names = ", ".join(arrays)
        raise ValueError(
            f"{owner}: {names} must have the same number of samples; got "
            f"{', '.join(map(str, counts))}."
        )
    return (*out, all(singles))


def friction_idim_columns(v: np.ndarray, friction: tuple[str, ...]) -> np.ndarray:
    """Friction columns of the inverse-dynamics rows, shape ``(N, n, n·len(friction))``.

    Joint i's row has, in joint i's columns: ``v_i`` [rad/s] (viscous), ``sign v_i``
    (Coulomb), ``1`` (offset), so that τ_f,i = FV_i v_i + FC_i sign(v_i) + OFF_i [N·m].
    """
    num_samples, num_joints = v.shape
    width = len(friction)
    out = np.zeros((num_samples, num_joints, num_joints * width))
    for k, kind in enumerate(friction):
        if kind == "viscous":
            value = v
        elif kind == "coulomb":
            value = np.sign(v)
        else:
            value = np.ones_like(v)
        for i in range(num_joints):
            out[:, i, i * width + k] = value[:, i]
    return out


def friction_power_columns(v: np.ndarray, friction: tuple[str, ...]) -> np.ndarray:
    """Friction power columns, shape ``(N, n·len(friction))``.

    Joint j contributes ``v_j²`` (viscous), ``abs(v_j)`` (Coulomb) and ``v_j``
    (offset): the dissipated power is Σ_j FV_j v_j² + FC_j |v_j| + OFF_j v_j [W].
    """
    return np.einsum("ni,nik->nk", v, friction_idim_columns(v, friction))


def model_rows_from_parts(
    kind: str,
    owner: str,
    v: np.ndarray,
    tau: np.ndarray,
    energy: callable,  # type: ignore[valid-type]
    lagrangian: callable,  # type: ignore[valid-type]
    friction_slice: slice,
    friction: tuple[str, ...],
    num_parameters: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Assembles the (D, G, y) rows of docs/CONVENTIONS.md §3 (batch shapes).

    power: ``D = h``, ``G`` = friction power columns, ``y = vᵀτ`` (m = 1).
    lagrangian: ``D = ∂h_E/∂v``, ``G = ∂h_U/∂q - ∂h_E/∂q`` + friction columns,
    ``y = τ`` (m = n). ``energy()`` returns h ``(N, p)``; ``lagrangian()`` returns
    ``(∂h_E/∂v, ∂h_E/∂q, ∂h_U/∂q)``, each ``(N, n, p)``.
    """
    num_samples = v.shape[0]
    if kind == "power":
        d_rows = energy()[:, None, :]
        g_rows = np.zeros((num_samples, 1, num_parameters))
        g_rows[:, 0, friction_slice] = friction_power_columns(v, friction)
        y = np.einsum("ni,ni->n", v, tau)[:, None]
    elif kind == "lagrangian":
        d_rows, dhe_dq, dhu_dq = lagrangian()
        g_rows = dhu_dq - dhe_dq
        g_rows[:, :, friction_slice] += friction_idim_columns(v, friction)
        y = tau.copy()
    else:
        raise ValueError(
            f"{owner}: kind must be one of {', '.join(MODEL_KINDS)}; got {kind!r}."
        )
    return d_rows, g_rows, y


def _friction_value(kind: str, velocity: float) -> float:
    """One friction column of joint i's IDIM row: v_i, sign v_i or 1."""
    if kind == "viscous":
        return velocity
    if kind == "coulomb":
        return float(np.sign(velocity))
    return 1.0


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
    """

    L1: float = 1.0
    friction: tuple[str, ...] = ("viscous", "coulomb")

    def __post_init__(self) -> None:
        object.__setattr__(self, "L1", _validate.positive(_OWNER, "L1", self.L1, "m"))
        object.__setattr__(self, "friction", check_friction(_OWNER, self.friction))

    @property
    def num_joints(self) -> int:
        """Number of joints (2)."""
        return _NUM_JOINTS

    @property
    def names(self) -> tuple[str, ...]:
        """Base-parameter names: ZZ1R, ZZ2, MX2, MY2, then friction per joint."""
        friction = tuple(
            f"{FRICTION_PREFIX[kind]}{j}" for j in (1, 2) for kind in self.friction
        )
        return ("ZZ1R", "ZZ2", "MX2", "MY2", *friction)

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

        See the module docstring for τ1 and τ2; friction columns v_j, sign v_j, 1.
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
        out[:, :, _NUM_INERTIAL:] = friction_idim_columns(v, self.friction)
        return out

    def power_rows(self, q, v, vdot) -> np.ndarray:
        """Power rows vᵀW = [d/dt h, friction power], shape ``(N, p)`` [W per unit].

        Power balance (MATH.md eq. P): d/dt(h)·X + Σ_j FV_j v_j² + FC_j |v_j|
        + OFF_j v_j = vᵀτ.
        """
        q, v, vdot, single = as_batches(_OWNER, _NUM_JOINTS, q=q, v=v, vdot=vdot)
        return _drop(single, np.einsum("ni,nip->np", v, self._idim(q, v, vdot)))

    def packed_rows(self, kind: str, q, v, tau) -> np.ndarray:
        """One sample's model rows, packed as ``modulating.pack_rows(D, G, y)``.

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
        q2 = float(q[1])
        v1, v2 = float(v[0]), float(v[1])
        c2, s2 = math.cos(q2), math.sin(q2)
        L1, p, width = self.L1, self.num_parameters, len(self.friction)
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
                    out[row + k] = _friction_value(kind_f, vi)
            out[4 * p] = float(tau[0])
            out[4 * p + 1] = float(tau[1])
        elif kind == "power":
            out = [0.0] * (2 * p + 1)
            w = v1 * v1 + v1 * v2
            out[0:4] = (0.5 * v1 * v1, 0.5 * (v1 + v2) ** 2, L1 * c2 * w, -L1 * s2 * w)
            for i, vi in enumerate((v1, v2)):
                row = p + _NUM_INERTIAL + i * width
                for k, kind_f in enumerate(self.friction):
                    out[row + k] = vi * _friction_value(kind_f, vi)
            out[2 * p] = v1 * float(tau[0]) + v2 * float(tau[1])
        else:
            raise ValueError(
                f"{_OWNER}: kind must be one of {', '.join(MODEL_KINDS)}; got {kind!r}."
            )
        return np.array(out)

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
        )
        return _drop(single, *out)
