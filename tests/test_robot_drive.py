"""RobotModel with a drive chain and a Coulomb sign law.

See docs/DRIVE.md §3 (motor columns) and docs/MATH.md §2 (the dead zone).

Truths: Drake's inverse dynamics and energies of the URDF (rigid bodies, gravity)
plus the motors written out in numpy through R (Ia ⊙ R v̇, Fv ⊙ R v, Fc ⊙ sign R v),
never the library's columns; and the Drake blocks for the on-line core replay.
"""

import pathlib
import re

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import MultibodyForces

from drake_dynid.core.drive import DriveChain
from drake_dynid.core.friction import DeadZoneSign
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import OnlineSettings, replay_log
from drake_dynid.fast_replay import replay_log_core
from drake_dynid.logs import RobotLog
from drake_dynid.plants import model_path
from drake_dynid.robot import RobotModel

URDF = (pathlib.Path(__file__).parent / "data" / "wrist4.urdf").read_text()

JOINTS = ("j1", "j2", "j3", "j4")
R = np.diag([50.0, 60.0, 30.0, 25.0])
R[3, 2] = 25.0  # motor 4 turns with q3 + q4
IA = np.array([1e-4, 8e-5, 6e-5, 5e-5])
FV = np.array([1e-3, 2e-3, 1.5e-3, 1e-3])
FC = np.array([0.02, 0.03, 0.01, 0.015])
DRIVE = {
    "motors": {
        **{
            f"m{k + 1}": {
                "joint": f"j{k + 1}",
                "gear_ratio": float(R[k, k]),
                "rotor_inertia": float(IA[k]),
                "viscous": float(FV[k]),
                "coulomb": float(FC[k]),
            }
            for k in range(3)
        },
        "m4": {
            "joints": {"j3": 25.0, "j4": 25.0},
            "rotor_inertia": float(IA[3]),
            "viscous": float(FV[3]),
            "coulomb": float(FC[3]),
        },
    }
}


@pytest.fixture(scope="module")
def urdf(tmp_path_factory):
    path = tmp_path_factory.mktemp("drive") / "wrist4.urdf"
    path.write_text(URDF)
    return path


@pytest.fixture(scope="module")
def chain():
    return DriveChain.from_dict(DRIVE, JOINTS, source="test drive")


@pytest.fixture(scope="module")
def robot(urdf, chain):
    return RobotModel.from_urdf(urdf, drive=chain, rotor_inertia=True)


def _drake(q, v, vdot):
    """(τ_rigid, kinetic energy, potential energy) of the URDF without friction."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(re.sub(r"<dynamics[^>]*/>", "", URDF), "urdf")
    plant.Finalize()
    context = plant.CreateDefaultContext()
    forces = MultibodyForces(plant)
    tau, kinetic, potential = [], [], []
    for k in range(q.shape[0]):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces.SetZero()
        plant.CalcForceElementsContribution(context, forces)
        tau.append(plant.CalcInverseDynamics(context, vdot[k], forces))
        kinetic.append(plant.CalcKineticEnergy(context))
        potential.append(plant.CalcPotentialEnergy(context))
    return np.array(tau), np.array(kinetic), np.array(potential)


def _truth(q, v, vdot, sign=np.sign):
    rigid, kinetic, potential = _drake(q, v, vdot)
    damping = np.array([0.8, 0.6, 0.3, 0.2])
    dry = np.array([1.5, 1.2, 0.6, 0.4])
    v_m, a_m = v @ R.T, vdot @ R.T
    scale = np.max(np.abs(R), axis=1)
    motor = IA * a_m + FV * v_m + FC * sign(v_m / scale)
    tau = rigid + damping * v + dry * sign(v) + motor @ R
    energy = kinetic + 0.5 * np.sum(IA * v_m**2, axis=1)
    return tau, energy, potential


def _states(seed=0, count=6):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(-2, 2, (count, 4)),
        rng.normal(size=(count, 4)),
        rng.normal(size=(count, 4)),
    )


def test_rows_times_the_a_priori_values_are_drake_plus_the_motors(robot):
    q, v, vdot = _states()
    tau, energy, potential = _truth(q, v, vdot)
    theta = robot.standard_values
    np.testing.assert_allclose(
        robot.idim_rows(q, v, vdot, columns="standard") @ theta, tau, atol=1e-9
    )
    np.testing.assert_allclose(
        robot.idim_rows(q, v, vdot) @ robot.base_values, tau, atol=1e-9
    )
    kinetic, potential_rows = robot.kinetic_potential_rows(q, v, columns="standard")
    np.testing.assert_allclose(kinetic @ theta, energy, rtol=1e-12, atol=1e-12)
    # The potential energy is Drake's up to a constant.
    difference = potential_rows @ theta - potential
    np.testing.assert_allclose(difference, difference[0], atol=1e-9)
    # Momentum rows: ∂E/∂v = (M + Rᵀ diag(Ia) R) v.
    momentum = robot.momentum_rows(q, v, columns="standard") @ theta
    step = 1e-6
    for j in range(4):
        dv = np.zeros(4)
        dv[j] = step
        plus = _truth(q, v + dv, vdot)[1]
        minus = _truth(q, v - dv, vdot)[1]
        np.testing.assert_allclose(
            momentum[:, j], (plus - minus) / (2 * step), rtol=1e-6, atol=1e-8
        )


def test_model_rows_satisfy_the_balance_along_a_trajectory(robot):
    trajectory = random_fourier_trajectory(
        4,
        harmonics=3,
        base_frequency=2.0,
        max_velocity=1.0,
        rng=np.random.default_rng(2),
    )
    h = 1e-4
    t = np.arange(0.3, 0.3 + 40 * h, h)
    q, v, vdot = trajectory.evaluate(t)
    tau = _truth(q, v, vdot)[0]
    theta = robot.base_values
    for kind in ("power", "lagrangian"):
        D, G, y = robot.model_rows(kind, q, v, tau)
        # d/dt(D θ) + G θ = y (central differences of D θ).
        momentum = D @ theta
        rate = (momentum[2:] - momentum[:-2]) / (2 * h)
        np.testing.assert_allclose(
            rate + (G @ theta)[1:-1], y[1:-1], rtol=1e-5, atol=1e-4 * np.abs(y).max()
        )


def test_motor_columns_names_and_scaled_rank_decision(robot):
    assert robot.drive.coupled_motors == (3,)
    names = robot.standard_names
    assert names.index("IAm4") < names.index("FV1") < names.index("FVm4")
    assert names[-2:] == ("FVm4", "FCm4")
    assert {"IAm4", "FVm4", "FCm4"} <= set(robot.base.names)
    assert robot.base.clear
    values = robot.standard_parameters()
    assert values["IA1"] == pytest.approx(50.0**2 * 1e-4)  # N² Ia
    assert values["FV2"] == pytest.approx(0.6 + 60.0**2 * 2e-3)
    assert values["FC3"] == pytest.approx(0.6 + 30.0 * 0.01)
    assert values["IAm4"] == 5e-5 and values["FCm4"] == 0.015


def test_a_differential_regroups_and_the_base_map_stays_exact():
    # TIAGo's wrist: URDF DifferentialTransmission, R = [[-1, 1], [1, 1]]: both
    # motors' friction and inertia regroup with the joint columns.
    from drake_dynid.drive_urdf import load_drive

    path = model_path("tiago_no_hand")
    joints = ["arm_5_joint", "arm_6_joint", "arm_7_joint"]
    robot = RobotModel.from_urdf(path, joints=joints, rotor_inertia=True)
    chain = load_drive(path, robot.joint_names)
    assert chain.coupled_motors == (1, 2)
    coupled = RobotModel.from_urdf(path, joints=joints, rotor_inertia=True, drive=chain)
    definitions = dict(zip(coupled.base.names, coupled.base.definitions, strict=True))
    assert definitions["IAm2R"] == {"IAm2": 1.0, "IAm3": -1.0}
    assert definitions["FV2R"] == {"FV2": 1.0, "FVm3": 2.0}
    rng = np.random.default_rng(5)
    q, v, vdot = (rng.normal(size=(5, 3)) for _ in range(3))
    theta = rng.normal(size=len(coupled.standard_names))
    np.testing.assert_allclose(
        coupled.idim_rows(q, v, vdot) @ coupled.base.values(theta),
        coupled.idim_rows(q, v, vdot, columns="standard") @ theta,
        atol=1e-10,
    )
    for kind in ("power", "lagrangian"):
        _, G, _ = coupled.model_rows(kind, q, v, np.zeros((5, 3)))
        assert G.shape[-1] == coupled.num_parameters
    # The same differential with ratios ±30: the rank decision runs on columns
    # scaled by 1/ρ² and the coefficients come back in motor-side units (2·30²).
    scaled = DriveChain.from_dict(
        {
            "coupling": {
                "motors": ["a", "b"],
                "joints": ["arm_6_joint", "arm_7_joint"],
                "matrix": [[-30.0, 30.0], [30.0, 30.0]],
            }
        },
        robot.joint_names,
    )
    geared = RobotModel.from_urdf(path, joints=joints, rotor_inertia=True, drive=scaled)
    definitions = dict(zip(geared.base.names, geared.base.definitions, strict=True))
    assert definitions["IA3R"] == {"IA3": 1.0, "IAm3": 1800.0}
    assert definitions["IAm2R"] == {"IAm2": 1.0, "IAm3": -1.0}
    assert definitions["FV2R"] == {"FV2": 1.0, "FVm3": 1800.0}
    assert geared.base.clear
    theta = rng.normal(size=len(geared.standard_names))
    full = geared.idim_rows(q, v, vdot, columns="standard") @ theta
    np.testing.assert_allclose(
        geared.idim_rows(q, v, vdot) @ geared.base.values(theta),
        full,
        rtol=1e-10,
        atol=1e-10 * np.abs(full).max(),
    )


def test_a_drive_file_for_other_joints_is_an_error(urdf):
    other = DriveChain.from_dict({}, ("j2", "j1", "j3", "j4"))
    with pytest.raises(ValueError, match=r"drive chain's joints \(j2, j1"):
        RobotModel.from_urdf(urdf, drive=other)
    with pytest.raises(TypeError, match="drive must be None, a DriveChain"):
        RobotModel.from_urdf(urdf, drive=3)
    prismatic = DriveChain.from_dict({}, JOINTS, prismatic_joints=("j2",))
    with pytest.raises(ValueError, match=r"prismatic joints differ .* for j2"):
        RobotModel.from_urdf(urdf, drive=prismatic)


def test_the_sign_law_reaches_every_coulomb_column(robot):
    q, v, vdot = _states(seed=3, count=40)
    v = 0.02 * v  # many velocities inside the zone
    widths = (0.01, 0.02, 0.015, 0.005)
    zoned = robot.with_sign(DeadZoneSign(widths))
    assert zoned.base is robot.base and zoned.num_parameters == robot.num_parameters
    scale = np.max(np.abs(R), axis=1)
    motor_widths = np.sqrt(((R / scale[:, None]) ** 2) @ np.square(widths))
    rigid = _truth(q, v, vdot, sign=np.sign)[0]
    exact = robot.idim_rows(q, v, vdot) @ robot.base_values
    np.testing.assert_allclose(exact, rigid, atol=1e-9)
    dry = np.array([1.5, 1.2, 0.6, 0.4]) + np.array(
        [50 * 0.02, 60 * 0.03, 30 * 0.01, 0.0]
    )
    joint_zone = np.where(np.abs(v) <= np.asarray(widths), 0.0, np.sign(v))
    u = v @ R.T / scale
    motor_zone = np.where(np.abs(u) <= motor_widths, 0.0, np.sign(u))
    expected = (
        exact
        - dry * np.sign(v)
        + dry * joint_zone
        - (FC[3] * np.sign(u[:, 3]))[:, None] * R[3]
        + (FC[3] * motor_zone[:, 3])[:, None] * R[3]
    )
    got = zoned.idim_rows(q, v, vdot) @ robot.base_values
    np.testing.assert_allclose(got, expected, atol=1e-9)
    assert np.any(joint_zone == 0.0) and np.any(motor_zone[:, 3] == 0.0)
    # The model rows use the same law (G·θ holds the friction of the rows).
    _, G, _ = zoned.model_rows("lagrangian", q, v, np.zeros_like(v))
    _, G_exact, _ = robot.model_rows("lagrangian", q, v, np.zeros_like(v))
    np.testing.assert_allclose(
        (G - G_exact) @ robot.base_values, expected - exact, atol=1e-9
    )
    assert zoned.rows_provider() is zoned
    with pytest.raises(TypeError, match="sign must be a SignLaw"):
        robot.with_sign(np.sign)
    assert robot.with_sign(None).sign == robot.sign


def test_core_replay_equals_the_blocks_with_a_drive_and_a_dead_zone(robot):
    trajectory = random_fourier_trajectory(
        4,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=1.5,
        rng=np.random.default_rng(8),
    )
    h = 0.005
    t = h * np.arange(int(1.6 / h))
    q, v, vdot = trajectory.evaluate(t)
    tau = _truth(q, v, vdot)[0]
    rng = np.random.default_rng(9)
    q = q + 1e-4 * rng.normal(size=q.shape)
    log = RobotLog(t, q, tau, robot.joint_names, h)
    zoned = robot.with_sign(DeadZoneSign((0.02, 0.03, 0.02, 0.01)))
    # At least as many independent rows as the 35 parameters (the drivers refuse
    # fewer): 5 functions x 2 x 4 equations, 18 functions x 2 x 1 equation (inside
    # the 0.05 s differentiator's pass band).
    settings = [
        OnlineSettings(
            model=model,
            window=1.0,
            frequencies=np.arange(count),
            jacobi_window=jacobi,
            bank_time_step=0.005,
            update_period=0.05,
            weighting="none",
        )
        for model, count, jacobi in (("lagrangian", 5.0, 0.1), ("power", 18.0, 0.05))
    ]
    fast = replay_log_core(log, zoned, settings)
    reference = replay_log(log, zoned, settings)
    for got, want in zip(fast, reference, strict=True):
        assert got.names == want.names == zoned.names
        np.testing.assert_array_equal(got.valid, want.valid)
        np.testing.assert_allclose(got.theta, want.theta, rtol=1e-9, atol=1e-12)


def test_a_regrouped_friction_column_is_named_with_where_it_went():
    """Found by a review: the on-line rows refused a friction column regrouped
    into others with 'a friction column is not identifiable ...; check the
    friction kinds', naming none. The TIAGo torso's offset (a vertical prismatic
    joint) shares its column with its mass's gravity and, with the rotor
    inertia, is regrouped: the message names OFF1 and where it went."""
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"),
        joints=("torso_lift_joint", "arm_1_joint"),
        friction=("viscous", "coulomb", "offset"),
        rotor_inertia=True,
    )
    assert "OFF1" not in robot.base.names
    q = np.zeros((4, 2))
    with pytest.raises(
        ValueError, match=r"not identifiable \(all must be\): OFF1 \(regrouped into M1R"
    ):
        robot.rows_provider().mean_packed_rows("lagrangian", q, q + 1, q, 2)
