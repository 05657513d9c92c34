"""Part of a robot simulated: locked joints welded at their positions (load_urdf
``locked=``, ``dynid simulate --joints/--lock``), checked against Drake's inverse
dynamics of the whole plant and by identifying the simulated log."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.tree import MultibodyForces

from drake_dynid import cli
from drake_dynid.core.joint_limits import JointLimits
from drake_dynid.experiment import simulate_experiment
from drake_dynid.logs import read_log
from drake_dynid.meshcat_replay import replay_in_meshcat
from drake_dynid.trajectory_file import SampledTrajectory
from drake_dynid.urdf import load_plant, model_path
from tests.test_any_urdf import gripper_urdf

TIAGO = "tiago_no_hand"


def _inverse_dynamics(plant, q, v, a):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    return plant.CalcInverseDynamics(context, a, MultibodyForces(plant))


@pytest.mark.parametrize(
    ("urdf", "locked", "leaders"),
    [
        ("iiwa7", {"iiwa_joint_3": 0.4, "iiwa_joint_6": -0.7}, {}),
        # A prismatic joint (the torso, [m]) and every joint but arm_1..arm_4.
        (
            TIAGO,
            {"torso_lift_joint": 0.2, "arm_5_joint": 1.1, "arm_7_joint": -0.5},
            {},
        ),
        # A mimic joint (fb = 1.5 fa + 0.01) follows its locked leader.
        ("gripper", {"fa": 0.02, "j2": 0.7}, {"fb": 1.5 * 0.02 + 0.01}),
    ],
)
def test_a_locked_joint_is_a_weld_at_its_position(urdf, locked, leaders, tmp_path):
    path = gripper_urdf(tmp_path / "g.urdf") if urdf == "gripper" else model_path(urdf)
    full = load_plant(path)
    welded = load_plant(path, locked=locked)
    held = {**locked, **leaders}
    everything = [full.get_joint(i) for i in full.GetJointIndices()]
    movable = [j for j in everything if j.num_velocities() == 1]
    free = [j for j in movable if j.name() not in held]
    for name in held:  # a weld at the position, no actuator left
        assert (
            not welded.HasJointNamed(name)
            or welded.GetJointByName(name).num_velocities() == 0
        )
    assert welded.num_velocities() == len(free) == welded.num_actuators()
    index = [j.velocity_start() for j in free]
    rng = np.random.default_rng(3)
    for _ in range(4):
        q, v, a = rng.uniform(-1.0, 1.0, size=(3, len(free)))
        q_full = np.zeros(full.num_positions())
        for joint in movable:
            q_full[joint.position_start()] = held.get(joint.name(), 0.0)
        q_full[index] = q
        v_full, a_full = np.zeros((2, full.num_velocities()))
        v_full[index], a_full[index] = v, a
        expected = _inverse_dynamics(full, q_full, v_full, a_full)[index]
        got = _inverse_dynamics(welded, q, v, a)
        scale = max(1.0, float(np.max(np.abs(expected))))
        assert np.max(np.abs(got - expected)) <= 1e-12 * scale


def test_a_bad_locked_joint_is_named(tmp_path):
    with pytest.raises(ValueError, match="locked joint 'nope' is not a movable joint"):
        load_plant(model_path("iiwa7"), locked={"nope": 0.0})
    with pytest.raises(ValueError, match="'iiwa_joint_2' needs a finite position"):
        load_plant(model_path("iiwa7"), locked={"iiwa_joint_2": float("nan")})
    with pytest.raises(ValueError, match="locked joint 'nope' is not a joint"):
        replay_in_meshcat(
            model_path("iiwa7"),
            np.array([0.0, 1.0]),
            np.zeros((2, 7)),
            [f"iiwa_joint_{i}" for i in range(1, 8)],
            locked={"nope": 0.0},
            meshcat=object(),
        )


def test_a_mimic_joint_of_a_simulated_leader_is_refused(tmp_path):
    # The simulator does not couple a mimic joint to its leader: said, not wrong.
    path = gripper_urdf(tmp_path / "g.urdf")
    t = np.linspace(0.0, 1.0, 11)
    q = np.column_stack([0.1 * t, 0.01 + 0.01 * t])
    reference = SampledTrajectory(
        t, q, np.gradient(q, t, axis=0), np.full_like(q, np.nan), ("j1", "fa")
    )
    limits = JointLimits(
        ("j1", "fa"),
        lower=[-3.0, 0.0],
        upper=[3.0, 0.04],
        velocity=[1.0, 1.0],
        effort=[10.0, 10.0],
    )
    with pytest.raises(ValueError, match=r"fb move unactuated \(a mimic joint"):
        simulate_experiment(path, reference, limits, locked={"j2": 0.0})


JOINTS = "iiwa_joint_1,iiwa_joint_2,iiwa_joint_4"
LOCK = "iiwa_joint_3=0.4,iiwa_joint_5=-0.6,iiwa_joint_6=0.9,iiwa_joint_7=1.0"


def test_simulate_part_of_an_arm_and_identify_it(tmp_path, capsys):
    # excite designs for the chosen joints, simulate welds the others at --lock,
    # and the log identified with the printed command recovers the truth (the
    # truth: the URDF's base parameters of the same joints; the log: Drake's
    # simulation of the welded plant, not the library's regressor).
    traj, coeffs, log = (tmp_path / n for n in ("traj.csv", "traj.json", "log.csv"))
    common = ["iiwa7", "--joints", JOINTS, "--lock", LOCK]
    argv = ["excite", *common, "--duration", "10", "--out", str(traj)]
    assert cli.main([*argv, "--json", str(coeffs), "--quiet"]) == 0
    argv = ["simulate", *common, "--trajectory", str(traj), "--out", str(log)]
    assert cli.main([*argv, "--noise-q", "0", "--noise-tau", "0"]) == 0
    printed = capsys.readouterr().out
    hint = re.search(r"score it with: dynid (offline .*)", printed)
    assert hint is not None
    assert f"--joints {JOINTS}" in hint.group(1)
    assert "--lock iiwa_joint_3=0.4,iiwa_joint_5=-0.6," in hint.group(1)
    header = Path(log).read_text().splitlines()[0]
    assert header == "t," + ",".join(
        f"{kind}_{name}" for kind in ("q", "tau") for name in JOINTS.split(",")
    )
    truth = json.loads((tmp_path / "log.truth.json").read_text())
    assert truth["joints"] == JOINTS.split(",")
    assert truth["locked"]["iiwa_joint_6"] == 0.9
    result = tmp_path / "offline.json"
    argv = [*hint.group(1).split(), "--json", str(result), "--quiet"]
    assert cli.main(argv) == 0
    estimates = {
        p["name"]: p["value"] for p in json.loads(result.read_text())["parameters"]
    }
    true = {p["name"]: p["value"] for p in truth["parameters"]}
    assert estimates.keys() == true.keys()
    well = [
        p["name"]
        for p in json.loads(coeffs.read_text())["predicted"]
        if p["relative_std_percent"] is not None and p["relative_std_percent"] <= 0.1
    ]
    assert len(well) >= 5
    for name in well:
        assert estimates[name] == pytest.approx(true[name], rel=0.01), name
    # The same log read with the locked joints elsewhere: a worse fit.
    assert read_log(str(log), tuple(JOINTS.split(","))).num_samples == 10001


def test_the_couplers_of_joints_that_stay_are_kept(tmp_path):
    # Drake removes joints only from a plant without constraints: the <mimic>
    # coupler of fa and fb is removed and added again when j2 alone is locked.
    path = gripper_urdf(tmp_path / "g.urdf")
    assert load_plant(path).num_constraints() == 1
    assert load_plant(path, locked={"j2": 0.7}).num_constraints() == 1
    assert load_plant(path, locked={"fa": 0.02}).num_constraints() == 0


def test_a_lock_of_a_joint_the_written_urdf_fixed_is_explained(tmp_path, capsys):
    # A review: the written URDF fed back with the fit's --lock said only "not a
    # movable joint". The writer fixes the locked joints: the message says so.
    from drake_dynid.plants import RobotModel
    from drake_dynid.urdf_writer import write_identified_urdf

    robot = RobotModel.from_urdf(
        model_path("iiwa7"), joints=JOINTS.split(","), locked={"iiwa_joint_3": 0.4}
    )
    out = tmp_path / "part.urdf"
    write_identified_urdf(robot, robot.standard_values, out)
    argv = ["params", str(out), "--joints", JOINTS, "--lock", "iiwa_joint_3=0.4"]
    assert cli.main(argv) == 2
    assert "It is a fixed joint of" in capsys.readouterr().err
