"""Motor regressor columns: hand-derived rows and energy/power/Lagrange consistency."""

import numpy as np
import pytest

from drake_dynid.core.drive import DriveChain
from drake_dynid.core.drive_columns import MotorColumns, motor_columns

TX40 = {
    "motors": {
        **{f"m{k}": {"joint": f"j{k}", "gear_ratio": 30.0 + k} for k in range(1, 6)},
        "m6": {
            "joints": {"j5": 32.0, "j6": 32.0},
            "rotor_inertia": 2e-5,
            "viscous": 1e-3,
            "coulomb": 0.02,
            "offset": 0.001,
        },
    }
}
JOINTS = tuple(f"j{k}" for k in range(1, 7))


def _trajectory(num=2001, duration=2.0, n=2, seed=0):
    """Smooth sinusoids q(t) with exact v and v̇, and the sample times."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, duration, num)
    amplitude = rng.uniform(0.5, 1.5, n)
    omega = rng.uniform(1.0, 3.0, n)
    phase = rng.uniform(0, np.pi, n)
    v = amplitude * omega * np.cos(omega * t[:, None] + phase)
    vdot = -amplitude * omega**2 * np.sin(omega * t[:, None] + phase)
    return t, v, vdot


def test_two_motor_coupling_rows_derived_by_hand():
    # R = [[a, 0], [b, c]] (a four-bar-like pair): τ = Rᵀ (Ia R v̇ + Fv R v + Fc s).
    a, b, c = 3.0, -2.0, 5.0
    ia, fv, fc = (0.2, 0.7), (0.3, 0.1), (0.4, 0.6)
    columns = MotorColumns(
        rows=np.array([[a, 0.0], [b, c]]),
        numbers=(1, 2),
        friction=("viscous", "coulomb"),
        values=np.array([*ia, fv[0], fc[0], fv[1], fc[1]]),
    )
    assert columns.names == ("IAm1", "IAm2", "FVm1", "FCm1", "FVm2", "FCm2")
    rng = np.random.default_rng(1)
    v, vdot = rng.normal(size=(5, 2)), rng.normal(size=(5, 2))
    tau = columns.idim_columns(v, vdot) @ columns.values
    u1, u2 = a * v[:, 0], b * v[:, 0] + c * v[:, 1]
    a1, a2 = a * vdot[:, 0], b * vdot[:, 0] + c * vdot[:, 1]
    f1 = ia[0] * a1 + fv[0] * u1 + fc[0] * np.sign(u1)
    f2 = ia[1] * a2 + fv[1] * u2 + fc[1] * np.sign(u2)
    np.testing.assert_allclose(tau[:, 0], a * f1 + b * f2)
    np.testing.assert_allclose(tau[:, 1], c * f2)


def test_tx40_motor6_columns_from_the_drive_chain():
    chain = DriveChain.from_dict(TX40, JOINTS)
    columns = motor_columns(chain, friction="viscous,coulomb,offset")
    assert columns.names == ("IAm6", "FVm6", "FCm6", "OFFm6")
    np.testing.assert_array_equal(columns.values, [2e-5, 1e-3, 0.02, 0.001])
    rng = np.random.default_rng(2)
    v, vdot = rng.normal(size=(4, 6)), rng.normal(size=(4, 6))
    rows = columns.idim_columns(v, vdot)
    s56 = v[:, 4] + v[:, 5]
    expected = np.zeros((4, 6, 4))
    for j in (4, 5):
        expected[:, j, 0] = 32 * 32 * (vdot[:, 4] + vdot[:, 5])
        expected[:, j, 1] = 32 * 32 * s56
        expected[:, j, 2] = 32 * np.sign(s56)
        expected[:, j, 3] = 32
    np.testing.assert_allclose(rows, expected)
    assert motor_columns(chain, inertia=False, friction=()).num_columns == 0
    plain = motor_columns(DriveChain.from_dict({}, JOINTS))
    assert plain.names == () and plain.idim_columns(v, vdot).shape == (4, 6, 0)


@pytest.mark.parametrize("friction", [("viscous", "coulomb", "offset"), ()])
def test_energy_power_and_lagrange_consistency_along_a_trajectory(friction):
    t, v, vdot = _trajectory()
    columns = MotorColumns(
        rows=np.array([[4.0, -4.0], [1.5, 2.5]]),
        numbers=(3, 4),
        friction=friction,
        sign=lambda x: np.tanh(x / 0.05),
    )
    h = t[1] - t[0]
    idim = columns.idim_columns(v, vdot)
    # Power: vᵀ(IDIM) = d/dt(energy) + friction power (central differences).
    energy = columns.energy_columns(v)
    d_energy = (energy[2:] - energy[:-2]) / (2 * h)
    power = np.einsum("ni,nip->np", v, idim)[1:-1]
    np.testing.assert_allclose(
        power, d_energy + columns.friction_power_columns(v)[1:-1], atol=1e-4
    )
    np.testing.assert_allclose(
        columns.power_columns(v, vdot), np.einsum("ni,nip->np", v, idim)
    )
    # Lagrange: d/dt(∂E/∂v) + friction = IDIM (∂E/∂q = 0).
    momentum = columns.momentum_columns(v)
    d_momentum = (momentum[2:] - momentum[:-2]) / (2 * h)
    np.testing.assert_allclose(
        d_momentum + columns.friction_columns(v)[1:-1], idim[1:-1], atol=1e-4
    )
    # The (D, G) rows of both models.
    d, g = columns.model_columns("power", v)
    np.testing.assert_array_equal(d[:, 0], energy)
    np.testing.assert_array_equal(g[:, 0], columns.friction_power_columns(v))
    d, g = columns.model_columns("lagrangian", v)
    np.testing.assert_array_equal(d, momentum)
    np.testing.assert_array_equal(g, columns.friction_columns(v))


def test_sign_is_evaluated_in_joint_units():
    seen = []

    def sign(x):
        seen.append(np.array(x))
        return np.tanh(x / 0.1)

    columns = MotorColumns(
        rows=np.array([[32.0, 32.0]]),
        numbers=(6,),
        inertia=False,
        friction=("coulomb",),
        sign=sign,
    )
    v = np.array([[0.03, 0.02], [-0.5, 0.1]])
    rows = columns.friction_columns(v)
    np.testing.assert_allclose(seen[0][:, 0], v.sum(axis=1))  # v5 + v6 [rad/s]
    np.testing.assert_allclose(rows[:, 0, 0], 32 * np.tanh(v.sum(axis=1) / 0.1))


def test_single_sample_and_errors():
    columns = MotorColumns(rows=np.array([[2.0, 1.0]]), numbers=(1,))
    assert columns.idim_columns(np.ones(2), np.ones(2)).shape == (2, 3)
    assert columns.energy_columns(np.ones(2)).shape == (3,)
    d, g = columns.model_columns("power", np.ones(2))
    assert d.shape == g.shape == (1, 3)
    with pytest.raises(ValueError, match="kind must be one of power, lagrangian"):
        columns.model_columns("energy", np.ones(2))
    with pytest.raises(ValueError, match=r"v must have shape \(any, 2\)"):
        columns.energy_columns(np.ones(3))
    with pytest.raises(ValueError, match="rows must not be all zeros"):
        MotorColumns(rows=np.zeros((1, 2)), numbers=(1,))
    with pytest.raises(ValueError, match="numbers must have one entry per row"):
        MotorColumns(rows=np.ones((1, 2)), numbers=(1, 2))
    with pytest.raises(ValueError, match=r"values must have shape \(3\)"):
        MotorColumns(rows=np.ones((1, 2)), numbers=(1,), values=np.ones(2))
    with pytest.raises(ValueError, match="friction kinds must be among"):
        MotorColumns(rows=np.ones((1, 2)), numbers=(1,), friction=("stribeck",))
