"""``dynid simulate --drive``: a robot with motors, gears, currents and a coupled wrist.

The robot is tests/data/wrist4.urdf with a TX40-style drive file: motor 4 turns with
q3 + q4 (row N4·(e3 + e4)); every motor has rotor inertia and friction; the log is
what the robot's controller records (motor encoders in degrees with zero offsets,
motor currents in mA, time stamps in ns). Checks, each against something the
simulation does not compute itself:

* ``DriveForces`` (the coupled motors' inertia and viscous friction through the
  plant's midpoint step) reproduces Drake's own reflected inertia and damping when
  the rows are diagonal;
* the noise-free log, read back through the drive file, obeys the motor model
  written out here (Drake's ``CalcInverseDynamics`` of the bare URDF, the joint
  friction and the motors through R, at the central differences of the positions)
  to round-off;
* ``dynid offline --drive`` on the noisy log of an excite trajectory recovers the
  well-excited parameters, the coupled motor's IAm4, FVm4, FCm4 among them,
  within 1 % of the truth file.

About 8 s.
"""

import json
import pathlib
import re

import numpy as np
import pytest
import tomllib
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JointActuatorIndex, MultibodyForces
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Sine

from drake_dynid import cli
from drake_dynid.core.drive import DriveChain
from drake_dynid.core.drive_columns import MotorColumns
from drake_dynid.core.drive_dynamics import SimulatedDrive
from drake_dynid.core.friction import TanhSign
from drake_dynid.raw_log import read_raw_log, write_raw_log
from drake_dynid.systems.drive_forces import DriveForces
from drake_dynid.urdf import load_plant

DATA = pathlib.Path(__file__).parent / "data"
URDF = DATA / "wrist4.urdf"
JOINTS = ("j1", "j2", "j3", "j4")
# Motors: gear ratio N, torque constant k_t [N*m/A], rotor inertia Ia [kg*m^2],
# motor-side viscous Fv [N*m*s/rad] and Coulomb Fc [N*m] friction.
N = np.array([60.0, 80.0, 40.0, 32.0])
KT = np.array([0.12, 0.15, -0.08, 0.06])
IA = np.array([6e-5, 5e-5, 4e-5, 3e-5])
FV = np.array([2e-4, 1.5e-4, 2e-4, 1.5e-4])
FC = np.array([0.01, 0.012, 0.008, 0.006])
OFFSET_DEG = np.array([12.0, -30.0, 5.0, 200.0])
DAMPING = np.array([0.8, 0.6, 0.3, 0.2])  # the URDF's <dynamics>
DRY = np.array([1.5, 1.2, 0.6, 0.4])
R = np.diag(N)
R[3, 2] = N[3]  # motor 4 turns with q3 + q4
LIMITS = {j: {"lower": -2, "upper": 2, "velocity": 2, "effort": 100} for j in JOINTS}
SMOOTHING = 1e-2  # the simulated Coulomb law tanh(v/ε)


def _drive_text() -> str:
    lines = [
        "[log]",
        'time = "stamp"',
        'time_unit = "ns"',
        'position = "enc_{motor}"',
        'position_side = "motor"',
        'angle_unit = "deg"',
        'torque = "cur_{motor}"',
        'torque_side = "motor"',
        'torque_unit = "mA"',
        "[log.position_offset]",
        *(f"m{k + 1} = {float(OFFSET_DEG[k])!r}" for k in range(4)),
    ]
    for k in range(4):
        lines.append(f"[motors.m{k + 1}]")
        if k == 3:
            ratio = float(N[3])
            lines.append(f"joints = {{ j3 = {ratio!r}, j4 = {ratio!r} }}")
        else:
            lines += [f'joint = "j{k + 1}"', f"gear_ratio = {float(N[k])!r}"]
        lines += [
            f"torque_constant = {float(KT[k])!r}",
            f"rotor_inertia = {float(IA[k])!r}",
            f"viscous = {float(FV[k])!r}",
            f"coulomb = {float(FC[k])!r}",
        ]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """excite (10 s, coupled drive) then simulate: noisy and noise-free logs."""
    folder = tmp_path_factory.mktemp("drive")
    paths = {
        "drive": DATA / "wrist4.toml",  # the README's example
        "limits": DATA / "wrist4_limits.json",
        "traj": folder / "traj.csv",
        "coeffs": folder / "traj.json",
        "log": folder / "log.csv",
        "exact": folder / "exact.csv",
    }
    assert tomllib.loads(paths["drive"].read_text()) == tomllib.loads(_drive_text())
    assert json.loads(paths["limits"].read_text()) == LIMITS
    common = ["--drive", str(paths["drive"]), "--limits", str(paths["limits"])]
    argv = [
        "excite", str(URDF), *common, "--rotor-inertia", "--duration", "10",
        "--out", str(paths["traj"]), "--json", str(paths["coeffs"]), "--quiet",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    simulate = ["simulate", str(URDF), "--trajectory", str(paths["traj"]), *common]
    assert cli.main([*simulate, "--out", str(paths["log"]), "--quiet"]) == 0
    argv = [
        *simulate, "--duration", "2", "--noise-q", "0", "--noise-tau", "0",
        "--out", str(paths["exact"]), "--quiet",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    return {name: str(path) for name, path in paths.items()}


def _chain(path: str) -> DriveChain:
    from drake_dynid.drive_urdf import load_drive

    return load_drive(str(URDF), JOINTS, path)


def test_the_log_is_in_the_drive_files_raw_columns(files):
    header = pathlib.Path(files["log"]).read_text().splitlines()[0].split(",")
    assert header == ["stamp"] + [f"enc_m{k}" for k in range(1, 5)] + [
        f"cur_m{k}" for k in range(1, 5)
    ]
    stamps = np.loadtxt(files["log"], delimiter=",", skiprows=1, usecols=0)
    np.testing.assert_array_equal(stamps[:3], [0.0, 1e6, 2e6])  # ns at 1 kHz
    truth = json.loads(pathlib.Path(files["log"][:-4] + ".truth.json").read_text())
    values = {p["name"]: p["value"] for p in truth["standard_parameters"]}
    # The drive's parameters: reflected inertia N² Ia, the motors' friction
    # folded into the joints', the coupled motor's own columns (motor side).
    assert values["IA1"] == pytest.approx(N[0] ** 2 * IA[0])
    assert values["IA4"] == 0.0  # joint 4 has no motor of its own
    assert values["FV3"] == pytest.approx(DAMPING[2] + N[2] ** 2 * FV[2])
    assert values["FC3"] == pytest.approx(DRY[2] + N[2] * FC[2])
    assert (values["IAm4"], values["FVm4"], values["FCm4"]) == (IA[3], FV[3], FC[3])
    assert truth["simulation"]["rotor_inertia"] is True
    assert truth["settings"]["drive"] == files["drive"]
    assert truth["drive_chain"]["motors"][3]["joints"] == {"j3": 32.0, "j4": 32.0}


def test_the_noise_free_log_obeys_the_motor_model(files):
    """τ of the log = the drive's model at the central differences, to round-off.

    With v_k = (q_{k+1} - q_{k-1})/2h, a_k = (q_{k+1} - 2 q_k + q_{k-1})/h² (the
    midpoint step of ``DriveForces``; every identification path differentiates
    centrally) and Coulomb friction tanh(·/ε)::

        τ_k = ID(q_k, v_k, a_k) + D v_k + FC tanh(v_k/ε)
              + Rᵀ [Ia ⊙ R a_k + Fv ⊙ R v_k + Fc ⊙ tanh(R v_k/(ρ ε))]

    (Drake's own step had the bias and the friction at (q_k - q_{k-1})/h and the
    damping at (q_{k+1} - q_k)/h: 1-10 % of the wrist torques off this model.)
    """
    log = read_raw_log(files["exact"], _chain(files["drive"]))
    h = log.time_step
    assert h == pytest.approx(1e-3) and log.num_samples == 2001
    q = log.q
    v = (q[2:] - q[:-2]) / (2 * h)
    a = (q[2:] - 2 * q[1:-1] + q[:-2]) / h**2
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(
        re.sub(r"<dynamics[^>]*/>", "", URDF.read_text()), "urdf"
    )
    plant.Finalize()
    context = plant.CreateDefaultContext()
    forces = MultibodyForces(plant)
    rigid = np.empty_like(v)
    for k in range(v.shape[0]):
        plant.SetPositions(context, q[k + 1])
        plant.SetVelocities(context, v[k])
        forces.SetZero()
        plant.CalcForceElementsContribution(context, forces)
        rigid[k] = plant.CalcInverseDynamics(context, a[k], forces)
    rho = np.max(np.abs(R), axis=1)
    motor = (
        IA * (a @ R.T) + FV * (v @ R.T) + FC * np.tanh((v @ R.T) / (rho * SMOOTHING))
    )
    model = rigid + DAMPING * v + DRY * np.tanh(v / SMOOTHING) + motor @ R
    tau = log.tau[1:-1]
    error = np.max(np.abs(model - tau), axis=0) / np.max(np.abs(tau), axis=0)
    # Measured: 4e-10 (the midpoint step's Newton tolerance; the positions' 17
    # digits in degrees, differentiated twice: 2e-11).
    assert np.all(error < 1e-7), error
    # Without the coupled motor's inertia the wrist is 4 % and 17 % off (measured):
    # the check can fail.
    coupled = (IA[3] * (a @ R[3]))[:, None] * R[3]
    off = np.max(np.abs(model - coupled - tau), axis=0) / np.max(np.abs(tau), axis=0)
    assert np.max(off) > 1e-3


def test_offline_drive_recovers_the_parameters(files, tmp_path):
    result = tmp_path / "offline.json"
    argv = [
        "offline", files["log"], "--urdf", str(URDF), "--drive", files["drive"],
        "--rotor-inertia", "--json", str(result), "--quiet",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    estimates = {
        p["name"]: p["value"] for p in json.loads(result.read_text())["parameters"]
    }
    truth = json.loads(pathlib.Path(files["log"][:-4] + ".truth.json").read_text())
    true = {p["name"]: p["value"] for p in truth["parameters"]}
    assert set(estimates) == set(true)
    predicted = json.loads(pathlib.Path(files["coeffs"]).read_text())["predicted"]
    well = [
        p["name"]
        for p in predicted
        if p["relative_std_percent"] is not None and p["relative_std_percent"] <= 0.1
    ]
    assert {"IAm4", "FVm4", "FCm4"} <= set(well) and len(well) >= 12, well
    errors = {
        name: 100 * abs(estimates[name] - true[name]) / abs(true[name]) for name in well
    }
    # Measured: worst 0.55 % (FV3), IAm4 0.35 %, FVm4 0.29 %, FCm4 0.22 %
    # (the README's run).
    assert max(errors.values()) < 1.0, errors


def test_drive_forces_give_drakes_own_reflected_inertia_and_damping():
    """Diagonal rows through DriveForces = Drake's actuator rotor inertia + damping.

    Both runs take DriveForces' midpoint step: one with the motors' inertia and
    viscous friction as Drake's actuator rotor inertia and joint damping, the
    other with them as a drive's diagonal K and B."""
    h = 1e-3
    sign = TanhSign(SMOOTHING)
    zeros = np.zeros(4)

    def run(native: bool) -> np.ndarray:
        builder = DiagramBuilder()
        plant = builder.AddSystem(load_plant(URDF, h))
        model = load_plant(URDF, h)
        model_context = model.CreateDefaultContext()
        if native:  # DriveForces reads the model's parameters when built
            _motors_as_drakes_own(model, model_context)
        torque = builder.AddSystem(
            Sine(np.array([20.0, 15, 5, 3]), np.array([1.0, 2, 3, 4]), np.zeros(4), 4)
        )
        builder.Connect(torque.get_output_port(0), plant.get_actuation_input_port())
        motors = MotorColumns(
            rows=np.diag(N),
            numbers=(1, 2, 3, 4),
            friction=("viscous",),
            values=np.concatenate([IA, FV]),
            sign=sign,
        )
        drive = SimulatedDrive(
            JOINTS, None, zeros, zeros, zeros, None if native else motors, sign
        )
        forces = builder.AddSystem(DriveForces(drive, model, model_context))
        builder.Connect(torque.get_output_port(0), forces.get_input_port_actuation())
        builder.Connect(plant.get_state_output_port(), forces.get_input_port_state())
        builder.Connect(
            forces.get_output_port_generalized_force(),
            plant.get_applied_generalized_force_input_port(),
        )
        log = LogVectorOutput(plant.get_state_output_port(), builder, h)
        simulator = Simulator(builder.Build())
        context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
        if native:
            _motors_as_drakes_own(plant, context)
        simulator.AdvanceTo(1.0)  # the joints stay well inside their ±9 rad limits
        return log.FindLog(simulator.get_context()).data().T

    native, through_forces = run(True), run(False)
    assert np.max(np.abs(native[:, :4])) < 8.0
    # The same equations, to the midpoint step's Newton tolerance.
    np.testing.assert_allclose(through_forces, native, rtol=0, atol=1e-9)
    # Without the forces the motion differs: the comparison can fail.
    assert np.max(np.abs(native - run_plain(h))) > 1e-2


def _motors_as_drakes_own(plant, context) -> None:
    """The motors as Drake's actuator rotor inertia and joint damping."""
    for i in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        j = actuator.joint().velocity_start()
        actuator.SetRotorInertia(context, IA[j])
        actuator.SetGearRatio(context, N[j])
        actuator.joint().SetDamping(context, DAMPING[j] + N[j] ** 2 * FV[j])


def run_plain(h: float) -> np.ndarray:
    """The URDF alone under the same torques (no motors)."""
    builder = DiagramBuilder()
    plant = builder.AddSystem(load_plant(URDF, h))
    torque = builder.AddSystem(
        Sine(np.array([20.0, 15, 5, 3]), np.array([1.0, 2, 3, 4]), np.zeros(4), 4)
    )
    builder.Connect(torque.get_output_port(0), plant.get_actuation_input_port())
    log = LogVectorOutput(plant.get_state_output_port(), builder, h)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(1.0)
    return log.FindLog(simulator.get_context()).data().T


def test_raw_log_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    chain = _chain_from_text(tmp_path)
    t = np.arange(50) * 1e-3
    q = rng.uniform(-2, 2, (50, 4))
    tau = rng.uniform(-30, 30, (50, 4))
    path = tmp_path / "raw.csv"
    write_raw_log(path, chain, t, q, tau)
    log = read_raw_log(path, chain)
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(log.q, q, rtol=0, atol=1e-13)
    np.testing.assert_allclose(log.tau, tau, rtol=1e-14, atol=1e-12)


def _chain_from_text(folder) -> DriveChain:
    path = folder / "wrist.toml"
    path.write_text(_drive_text())
    return _chain(str(path))


def test_replay_of_the_raw_log_in_meshcat(files, tmp_path, capsys):
    page = tmp_path / "log.html"
    argv = [
        "replay", str(URDF), files["exact"], "--drive", files["drive"],
        "--html", str(page),
    ]  # fmt: skip
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "2001 samples over 2 s; 65 frames" in out and "Meshcat: http://" in out
    assert "animation" in page.read_text(encoding="utf-8")


def test_the_blocks_fast_path_is_the_core_law():
    from drake_dynid.systems.drive_forces import _joint_friction

    sign = TanhSign(SMOOTHING)
    drive = SimulatedDrive(
        JOINTS, None, np.zeros(4), DRY, np.array([0.1, 0, 0, -0.2]), None, sign
    )
    v = np.random.default_rng(1).normal(scale=0.05, size=(20, 4))
    for row in v:
        np.testing.assert_allclose(
            _joint_friction(drive, row), drive.applied_friction(row), rtol=1e-15
        )


def test_a_coupled_motor_damped_far_above_its_inertia_tracks(tmp_path):
    """Drake's step damps implicitly, and DriveForces makes the plant step as one
    with damping D + B: (M + h D + K + h B) a = u - c - (D + B) v. The controller
    commanded (M + h D) a + D v + K a + B v_r (implicit_damping_context,
    DriveFeedforward): h B a was missing and B (v_r - v) fed the tracking error
    back. With m4's viscous friction 0.1 N·m·s/rad (B = 102 on K = 0.03 kg·m²,
    h B = 3.3 K) joint j4 ran 1.5 mrad off the run with m4's nominal friction.
    With (K + h B) a + B v in the feedforward the plant steps with a exactly,
    whatever B: the runs agree."""
    from drake_dynid.core.joint_limits import JointLimits
    from drake_dynid.experiment import ExperimentSettings, simulate_experiment
    from drake_dynid.experiment_drive import simulated_drive_of, truth_model
    from drake_dynid.trajectory_file import SampledTrajectory

    t = np.arange(0.0, 2.0 + 1e-9, 0.01)
    w = np.pi
    q = 0.5 * np.column_stack([np.sin(w * t)] * 3 + [-0.5 * np.sin(2 * w * t)])
    v = 0.5 * np.column_stack([w * np.cos(w * t)] * 3 + [-w * np.cos(2 * w * t)])
    reference = SampledTrajectory(t, q, v, np.full_like(q, np.nan), JOINTS)
    limits = JointLimits(
        JOINTS, lower=[-2] * 4, upper=[2] * 4, velocity=[2] * 4, effort=[1e4] * 4
    )
    settings = ExperimentSettings(noise_q=0.0, noise_tau=0.0, friction=("viscous",))
    runs = []
    for viscous in (1.5e-4, 0.1):
        text = (DATA / "wrist4.toml").read_text()
        old = "rotor_inertia = 3e-05\nviscous = 0.00015"
        assert old in text
        drive_file = tmp_path / f"wrist4_{viscous}.toml"
        drive_file.write_text(
            text.replace(old, f"rotor_inertia = 3e-05\nviscous = {viscous}")
        )
        model = truth_model(
            str(URDF), settings.friction, drive=drive_file, joints=JOINTS
        )
        drive = simulated_drive_of(model, settings.coulomb_smoothing)
        runs.append(
            simulate_experiment(str(URDF), reference, limits, settings, drive=drive).q
        )
    assert np.max(np.abs(runs[1] - runs[0])) < 1e-4
