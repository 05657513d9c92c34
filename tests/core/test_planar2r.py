"""Analytic 2R rows: independent energy, finite differences, model identities.

Seeds: numpy default_rng(20140) and (7). Identities hold to 1e-9.
"""

import numpy as np
import pytest

from drake_dynid.core.planar2r import PAPER_BASE_VALUES, Planar2RRows

ROWS = Planar2RRows(L1=0.8, friction=("viscous", "coulomb", "offset"))
THETA = np.array([3.9, 0.25, 0.45, 0.1, 0.3, 0.4, 0.05, 0.15, 0.25, -0.02])


def _states(seed=20140, n=16):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-np.pi, np.pi, (n, 2)),
        rng.normal(scale=2.0, size=(n, 2)),
        rng.normal(scale=3.0, size=(n, 2)),
    )


def _trajectory(t):
    """q(t) with exact v, vdot (a two-harmonic Fourier series per joint)."""
    w = np.array([1.3, 2.1])
    q = np.stack(
        [
            0.3 + np.sin(w[0] * t) + 0.4 * np.cos(w[1] * t),
            -0.5 + 0.8 * np.sin(w[1] * t),
        ],
        -1,
    )
    v = np.stack(
        [
            w[0] * np.cos(w[0] * t) - 0.4 * w[1] * np.sin(w[1] * t),
            0.8 * w[1] * np.cos(w[1] * t),
        ],
        -1,
    )
    a = np.stack(
        [
            -(w[0] ** 2) * np.sin(w[0] * t) - 0.4 * w[1] ** 2 * np.cos(w[1] * t),
            -0.8 * w[1] ** 2 * np.sin(w[1] * t),
        ],
        -1,
    )
    return q, v, a


def _derivative(f, x, step=1e-3):
    """Fourth-order central difference of f at x (scalar step)."""
    return (-f(x + 2 * step) + 8 * f(x + step) - 8 * f(x - step) + f(x - 2 * step)) / (
        12 * step
    )


def test_names_and_paper_values():
    rows = Planar2RRows()
    assert rows.names == ("ZZ1R", "ZZ2", "MX2", "MY2", "FV1", "FC1", "FV2", "FC2")
    assert tuple(PAPER_BASE_VALUES) == rows.names
    assert ROWS.names[4:] == ("FV1", "FC1", "OFF1", "FV2", "FC2", "OFF2")
    assert ROWS.num_parameters == 10


def test_energy_equals_independent_point_mass_computation():
    # Link 1: ZZ1 about joint 1; link 2: mass M2 with centre of mass c = (cx, cy)
    # in its frame and central inertia Izz; energy from the COM velocity.
    L1, M2, cx, cy, izz = 0.8, 1.3, 0.3, -0.1, 0.02
    zz1 = 2.0
    q, v, _ = _states()
    c1, s1 = np.cos(q[:, 0]), np.sin(q[:, 0])
    c12, s12 = np.cos(q.sum(1)), np.sin(q.sum(1))
    w1, w12 = v[:, 0], v.sum(1)
    vx = -L1 * s1 * w1 + (-s12 * cx - c12 * cy) * w12
    vy = L1 * c1 * w1 + (c12 * cx - s12 * cy) * w12
    energy = 0.5 * zz1 * w1**2 + 0.5 * M2 * (vx**2 + vy**2) + 0.5 * izz * w12**2
    base = np.array([zz1 + M2 * L1**2, izz + M2 * (cx**2 + cy**2), M2 * cx, M2 * cy])
    h = ROWS.energy_rows(q, v)
    np.testing.assert_allclose(h[:, :4] @ base, energy, rtol=0, atol=1e-12)
    assert np.all(h[:, 4:] == 0)


def test_momentum_and_position_rows_are_the_gradients_of_h():
    q, v, _ = _states()
    dv, dq, du = ROWS.lagrangian_rows(q, v)
    assert np.all(du == 0)
    for i, e in enumerate(np.eye(2)):
        fd_v = _derivative(lambda s, e=e: ROWS.energy_rows(q, v + s * e), 0.0)
        fd_q = _derivative(lambda s, e=e: ROWS.energy_rows(q + s * e, v), 0.0)
        np.testing.assert_allclose(dv[:, i], fd_v, rtol=0, atol=1e-9)
        np.testing.assert_allclose(dq[:, i], fd_q, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(ROWS.momentum_rows(q, v), dv)


def test_idim_is_lagrange_and_power_is_its_projection():
    t = np.linspace(0.0, 5.0, 11)
    q, v, a = _trajectory(t)
    w = ROWS.idim_rows(q, v, a)
    _, dq, du = ROWS.lagrangian_rows(q, v)
    ddt_dv = _derivative(lambda s: ROWS.momentum_rows(*_trajectory(t + s)[:2]), 0.0)
    friction = w[:, :, 4:]
    np.testing.assert_allclose(w[:, :, :4], (ddt_dv - dq + du)[:, :, :4], atol=1e-9)
    np.testing.assert_allclose(
        friction[:, 0],
        np.stack([v[:, 0], np.sign(v[:, 0]), np.ones(11), 0 * t, 0 * t, 0 * t], 1),
    )
    power = ROWS.power_rows(q, v, a)
    np.testing.assert_allclose(power, np.einsum("ni,nip->np", v, w), atol=1e-12)
    ddt_h = _derivative(lambda s: ROWS.energy_rows(*_trajectory(t + s)[:2]), 0.0)
    np.testing.assert_allclose(power[:, :4], ddt_h[:, :4], atol=1e-9)


@pytest.mark.parametrize("kind", ["power", "lagrangian"])
def test_model_rows_satisfy_the_model_identity(kind):
    # d/dt(D·θ) + G·θ = y along a trajectory with tau from the IDIM rows.
    t = np.linspace(0.0, 5.0, 9)
    q, v, a = _trajectory(t)
    tau = ROWS.idim_rows(q, v, a) @ THETA
    d, g, y = ROWS.model_rows(kind, q, v, tau)
    m = 1 if kind == "power" else 2
    assert d.shape == g.shape == (9, m, 10) and y.shape == (9, m)

    def d_theta(s):
        qs, vs, as_ = _trajectory(t + s)
        return (
            ROWS.model_rows(kind, qs, vs, ROWS.idim_rows(qs, vs, as_) @ THETA)[0]
            @ THETA
        )

    lhs = _derivative(d_theta, 0.0) + g @ THETA
    np.testing.assert_allclose(lhs, y, rtol=0, atol=1e-9)


def test_single_sample_drops_the_sample_axis():
    q, v, a = (x[0] for x in _states())
    assert ROWS.energy_rows(q, v).shape == (10,)
    assert ROWS.idim_rows(q, v, a).shape == (2, 10)
    d, g, y = ROWS.model_rows("lagrangian", q, v, v)
    assert d.shape == g.shape == (2, 10) and y.shape == (2,)


def test_errors_name_the_parameter():
    with pytest.raises(ValueError, match="L1 must be > 0"):
        Planar2RRows(L1=0.0)
    with pytest.raises(ValueError, match="friction kinds must be among"):
        Planar2RRows(friction=("dry",))
    with pytest.raises(ValueError, match="kind must be one of"):
        ROWS.model_rows("energy", np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(ValueError, match="same number of samples"):
        ROWS.energy_rows(np.zeros((3, 2)), np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"q must have shape \(any, 2\)"):
        ROWS.energy_rows(np.zeros((3, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="must be finite"):
        ROWS.energy_rows([np.nan, 0.0], [0.0, 0.0])
