"""The model-row contract shared by the bank, the identifier and the row providers.

For a robot with ``n`` joints and ``p`` base parameters θ, a row provider gives, per
sample, the arrays of docs/CONVENTIONS.md §3 built from ``(q, v, τ)`` at one
instant::

    d/dt(D·θ) + G·θ = y     →  modulated:  -M_ġ(D)·θ + M_g(G)·θ = M_g(y)

with ``D``, ``G`` of shape ``(m, p)`` and ``y`` of shape ``(m,)`` (m = 1 for the
power model, n for the Lagrangian model; docs/MATH.md §3). This module holds the
contract: the :class:`RowProvider` protocol, the model kinds, the one check of a
kind and of a provider, the packing of one sample's rows into the bank's channel
vector and the assembly of the rows from a provider's energy and Lagrangian parts.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from drake_dynid.core import _validate
from drake_dynid.core.friction import (
    EXACT_SIGN,
    SignLaw,
    friction_idim_columns,
    friction_power_columns,
)

__all__ = [
    "MODEL_KINDS",
    "RowProvider",
    "as_batch",
    "as_batches",
    "check_model_kind",
    "check_rows",
    "lagrangian_friction_part",
    "model_rows_from_parts",
    "num_channels",
    "num_equations",
    "pack_rows",
    "unpack_rows",
]

#: Model kinds of the (D, G, y) contract: the paper's scalar power model and the
#: Lagrangian (one equation per joint) model.
MODEL_KINDS = ("power", "lagrangian")

Rows = tuple[np.ndarray, np.ndarray, np.ndarray]


@runtime_checkable
class RowProvider(Protocol):
    """What the on-line identifier needs from a robot description.

    ``drake_dynid.RobotModel`` and ``drake_dynid.core.planar2r.Planar2RRows``
    satisfy it. A provider may also offer ``packed_rows(kind, q, v, tau)``, one
    sample already packed by :func:`pack_rows` (a fast path the ``ModelRows`` block
    uses when present).

    Attributes:
        num_joints: n.
        num_parameters: p, the base parameters (columns of D and G).
        names: the p parameter names.
    """

    @property
    def num_joints(self) -> int:
        """n, the joints."""
        ...

    @property
    def num_parameters(self) -> int:
        """p, the base parameters."""
        ...

    @property
    def names(self) -> tuple[str, ...]:
        """The p base-parameter names."""
        ...

    def model_rows(self, kind: str, q: Any, v: Any, tau: Any) -> Rows:
        """``(D, G, y)`` of (N, n) batches: (N, m, p), (N, m, p), (N, m)."""
        ...


def check_model_kind(owner: str, kind: Any, name: str = "kind") -> str:
    """Returns ``kind`` if it is one of :data:`MODEL_KINDS`, else raises ValueError.

    The one check of a model kind; ``name`` is the argument's name in the message.
    """
    if kind not in MODEL_KINDS:
        _validate.fail(
            owner, f"{name} must be one of {', '.join(MODEL_KINDS)}; got {kind!r}."
        )
    return str(kind)


def num_equations(kind: str, num_joints: int) -> int:
    """m, the equations per sample: 1 for the power model, n for the Lagrangian."""
    return 1 if check_model_kind("num_equations", kind) == "power" else num_joints


def check_rows(owner: str, rows: Any) -> int:
    """Checks a row provider's interface; returns its number of joints n."""
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


def num_channels(m: int, p: int) -> int:
    """Channels per sample of :func:`pack_rows`: ``2·m·p + m``."""
    return 2 * m * p + m


def pack_rows(D: Any, G: Any, y: Any) -> np.ndarray:
    """Flattens the model rows of one sample (or a batch) into one channel vector.

    Channel layout (length ``2·m·p + m``): ``[D[0,:], …, D[m-1,:], G[0,:], …,
    G[m-1,:], y[0], …, y[m-1]]``, i.e. ``D`` row-major, then ``G`` row-major, then
    ``y``. Leading batch axes are kept: D, G (..., m, p) and y (..., m) give
    (..., 2mp + m).
    """
    owner = "pack_rows"
    D = _validate.array(owner, "D", D, finite=False)
    G = _validate.array(owner, "G", G, finite=False)
    y = _validate.array(owner, "y", y, finite=False)
    if D.ndim < 2 or G.shape != D.shape or y.shape != D.shape[:-1]:
        _validate.fail(
            owner,
            f"D and G must have shape (..., m, p) and y (..., m); got D {D.shape}, "
            f"G {G.shape}, y {y.shape}.",
        )
    lead = D.shape[:-2]
    return np.concatenate(
        [D.reshape(*lead, -1), G.reshape(*lead, -1), y.reshape(*lead, -1)], axis=-1
    )


def unpack_rows(x: Any, m: int, p: int) -> Rows:
    """Inverse of :func:`pack_rows`: (..., 2mp + m) -> D (..., m, p), G, y (..., m)."""
    x = np.asarray(x)
    mp = m * p
    if x.shape[-1] != num_channels(m, p):
        _validate.fail(
            "unpack_rows", f"x must have {num_channels(m, p)} channels; got {x.shape}."
        )
    lead = x.shape[:-1]
    return (
        x[..., :mp].reshape(*lead, m, p),
        x[..., mp : 2 * mp].reshape(*lead, m, p),
        x[..., 2 * mp :],
    )


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


def as_batches(owner: str, num_joints: int, **arrays: object) -> tuple[Any, ...]:
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


def model_rows_from_parts(
    kind: str,
    owner: str,
    v: np.ndarray,
    tau: np.ndarray,
    energy: Callable[[], np.ndarray],
    lagrangian: Callable[[], Sequence[np.ndarray]],
    friction_slice: slice,
    friction: Sequence[str],
    num_parameters: int,
    sign: SignLaw = EXACT_SIGN,
) -> Rows:
    """Assembles the (D, G, y) rows of docs/CONVENTIONS.md §3 (batch shapes).

    power: ``D = h``, ``G`` = friction power columns, ``y = vᵀτ`` (m = 1).
    lagrangian: ``D = ∂h_E/∂v``, ``G = ∂h_U/∂q - ∂h_E/∂q`` + friction columns,
    ``y = τ`` (m = n). ``energy()`` returns h ``(N, p)``; ``lagrangian()`` returns
    ``(∂h_E/∂v, ∂h_E/∂q, ∂h_U/∂q)``, each ``(N, n, p)``. Friction columns from
    ``drake_dynid.core.friction`` with the Coulomb law ``sign``.
    """
    kind = check_model_kind(owner, kind)
    num_samples = v.shape[0]
    if kind == "power":
        d_rows = energy()[:, None, :]
        g_rows = np.zeros((num_samples, 1, num_parameters))
        g_rows[:, 0, friction_slice] = friction_power_columns(v, friction, sign)
        y = np.einsum("ni,ni->n", v, tau)[:, None]
    else:
        d_rows, dhe_dq, dhu_dq = lagrangian()
        g_rows = dhu_dq - dhe_dq
        g_rows[:, :, friction_slice] += friction_idim_columns(v, friction, sign)
        y = tau.copy()
    return d_rows, g_rows, y


def lagrangian_friction_part(
    v: np.ndarray,
    friction_slice: slice,
    friction: Sequence[str],
    num_parameters: int,
    sign: SignLaw = EXACT_SIGN,
    block: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """The friction part of the Lagrangian G rows of :func:`model_rows_from_parts`.

    ``(columns, values)``: the parameter columns ``friction_slice`` (k,) and
    ``values`` (N/block, n, k), the means over consecutive blocks of ``block``
    samples of ``G[:, :, columns]`` (joint i's row holds v_i, s(v_i), 1 in its own
    columns, zeros elsewhere; ``core.friction.friction_idim_columns``; the
    energy has no friction parameter). It depends on v alone and holds G's only
    non-smooth column, s(v) (the linearised bootstrap,
    ``core.raw_rows.linearized_channels``, averages it exactly).
    """
    columns = np.arange(num_parameters)[friction_slice]
    return columns, friction_idim_columns(v, friction, sign, block)
