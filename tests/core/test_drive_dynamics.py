"""core.drive_dynamics: the drive's share of a simulated plant (no pydrake).

The midpoint step in a Drake plant is tested in tests/test_simulate.py and
tests/test_simulate_drive.py; here the algebra and the checks.
"""

import numpy as np
import pytest

from drake_dynid.core.drive_columns import MotorColumns
from drake_dynid.core.drive_dynamics import (
    SimulatedDrive,
    midpoint_step_force,
    simulated_drive,
)
from drake_dynid.core.friction import TanhSign

SIGN = TanhSign(0.01)
ROW = np.array([[0.0, 0.0, 32.0, 32.0]])  # a TX40-style coupled motor (m4)


def _motors(values=(3e-5, 1.5e-4, 6e-3, 0.02)):
    return MotorColumns(
        rows=ROW,
        numbers=(4,),
        friction=("viscous", "coulomb", "offset"),
        values=np.array(values),
        sign=SIGN,
    )


def _drive(**changes):
    fields = {
        "joint_names": ("j1", "j2", "j3", "j4"),
        "rotor_inertia": np.array([0.2, 0.3, 0.06, 0.0]),
        "viscous": np.array([1.5, 1.5, 0.6, 0.2]),
        "coulomb": np.array([2.1, 2.2, 0.9, 0.4]),
        "offset": np.array([0.1, 0.0, 0.0, -0.1]),
        "motors": _motors(),
        "sign": SIGN,
    }
    fields.update(changes)
    return SimulatedDrive(**fields)


def test_coupled_matrices_and_friction():
    drive = _drive()
    outer = np.outer(ROW[0], ROW[0])
    np.testing.assert_allclose(drive.coupled_inertia, 3e-5 * outer)
    np.testing.assert_allclose(drive.coupled_damping, 1.5e-4 * outer)
    assert drive.needs_plant_step
    v = np.array([0.3, -0.2, 0.5, -0.1])
    u = 32.0 * (v[2] + v[3])
    expected = np.array([2.1, 2.2, 0.9, 0.4]) * np.tanh(v / 0.01)
    expected += np.array([0.1, 0.0, 0.0, -0.1])
    # The motor's Coulomb law on u/ρ (joint units), its offset; no viscous term.
    expected += ROW[0] * (6e-3 * np.tanh(u / 32.0 / 0.01) + 0.02)
    np.testing.assert_allclose(drive.applied_friction(v), expected, rtol=1e-14)


@pytest.mark.parametrize("coupled", [True, False])
def test_the_friction_law_of_the_step_is_the_drives(coupled):
    """The midpoint step's analytic tanh law and Jacobian = ``applied_friction``
    and its central differences."""
    from drake_dynid.core.drive_dynamics import _friction_law

    drive = _drive(motors=_motors() if coupled else None)
    law = _friction_law(drive)
    rng = np.random.default_rng(1)
    for v in (rng.normal(size=4), 0.01 * rng.normal(size=4)):
        force, jacobian = law(v)
        np.testing.assert_allclose(force, drive.applied_friction(v), rtol=1e-13)
        step = 1e-7
        numeric = np.column_stack(
            [
                (
                    drive.applied_friction(v + step * e)
                    - drive.applied_friction(v - step * e)
                )
                / (2 * step)
                for e in np.eye(4)
            ]
        )
        np.testing.assert_allclose(jacobian, numeric, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("coupled", [True, False])
@pytest.mark.parametrize("coulomb", [1.0, 1e4])  # 1e4: h·FC/(ε·inertia) ~ 1e3
def test_the_force_makes_the_plants_step_the_midpoint_step(coupled, coulomb):
    """The plant's step (M + h D) a = u + f - c(v) - D v with f takes the a of
    (M + K) a + c(v̄) + (D + B) v̄ + F(v̄) = u, v̄ = v + (h/2) a, c quadratic in
    the velocity (a Coriolis term) plus gravity; a stiff Coulomb law included."""
    rng = np.random.default_rng(0)
    drive = _drive(
        motors=_motors() if coupled else None,
        coulomb=coulomb * np.array([2.1, 2.2, 0.9, 0.4]),
    )
    a = rng.normal(size=(4, 4))
    mass = a @ a.T + 4 * np.eye(4)
    damping, h = np.array([1.5, 1.5, 0.6, 0.2]), 1e-3
    tensor, gravity = rng.normal(size=(4, 4, 4)), rng.normal(size=4)

    def bias(velocity):
        return np.einsum("ijk,j,k->i", tensor, velocity, velocity) - gravity

    for v in (rng.normal(size=4), 1e-3 * rng.normal(size=4)):  # 1e-3: reversals
        u = 10.0 * rng.normal(size=4)
        f = midpoint_step_force(drive, mass, damping, h, bias, v, u)
        # The plant's step with f ...
        accel = np.linalg.solve(
            mass + h * np.diag(damping), u + f - bias(v) - damping * v
        )
        # ... solves the midpoint equation.
        middle = v + 0.5 * h * accel
        residual = (
            (mass + drive.coupled_inertia) @ accel
            + bias(middle)
            + (np.diag(damping) + drive.coupled_damping) @ middle
            + drive.applied_friction(middle)
            - u
        )
        assert np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(u)), residual


def test_from_a_standard_table():
    names = ("ZZ1", "IA1", "IA2", "FV1", "FC2", "IAm2", "FVm2", "FCm2")
    values = np.array([1.0, 0.5, 0.25, 0.7, 0.3, 2e-5, 1e-4, 5e-3])
    motors = MotorColumns(rows=np.array([[10.0, 10.0]]), numbers=(2,))
    drive = simulated_drive(names, values, ("a", "b"), motors, SIGN)
    np.testing.assert_array_equal(drive.rotor_inertia, [0.5, 0.25])
    np.testing.assert_array_equal(drive.viscous, [0.7, 0.0])
    np.testing.assert_array_equal(drive.coulomb, [0.0, 0.3])
    np.testing.assert_array_equal(drive.motors.values, [2e-5, 1e-4, 5e-3])
    assert drive.motors.sign is SIGN
    plain = simulated_drive(("FV1",), np.array([0.2]), ("a",), None, SIGN)
    assert plain.rotor_inertia is None and not plain.needs_plant_step


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"rotor_inertia": np.array([0.1, -1.0, 0.0, 0.0])}, "rotor_inertia must be"),
        ({"coulomb": np.array([1.0, -1.0, 0.0, 0.0])}, "must be >= 0"),
        ({"viscous": np.zeros(3)}, "viscous"),
        ({"joint_names": ()}, "at least one joint"),
        ({"motors": _motors().__class__(rows=ROW, numbers=(4,))}, "motors.sign"),
    ],
)
def test_bad_drives_are_refused(changes, message):
    with pytest.raises(ValueError, match=message):
        _drive(**changes)


def test_a_step_that_does_not_converge_is_refused_not_logged():
    """Found by a review: after its iterations the midpoint step returned its last
    iterate unchecked. A velocity term far too stiff for the step (c = k·v̄ with
    (h/2)·k/M = 50, whose Jacobian the iteration leaves out) now raises."""
    drive = _drive(motors=None, coulomb=np.zeros(4))
    mass, damping, h = np.eye(4), np.zeros(4), 1e-3
    u = np.array([1.0, -2.0, 0.5, 3.0])
    with pytest.raises(ValueError, match="the midpoint step did not converge"):
        midpoint_step_force(drive, mass, damping, h, lambda w: 1e5 * w, np.ones(4), u)
    # A mild one converges as before.
    f = midpoint_step_force(drive, mass, damping, h, lambda w: 10.0 * w, np.ones(4), u)
    assert np.all(np.isfinite(f))
