"""Exciting-trajectory design (core.excite) and ``dynid excite``.

Done-when checks: on the iiwa7 and the UR5 (datasheet limits shipped next to the
URDFs) the optimised trajectory's condition number is at least 3x below the default
random trajectory's (the same seed, and the median of 10 seeds), and it stays within
every limit, checked with Drake's own inverse dynamics; a URDF with collision
geometry gets a collision-free motion; bad input exits 2 naming the constraint.
"""

import json
from pathlib import Path

import numpy as np
import pytest
from _cli import error_line
from _drake_dynamics import drake_torques

from drake_dynid import cli
from drake_dynid.core.excite import ExcitationSettings, _baseline, design_excitation
from drake_dynid.core.excite_problem import (
    ExcitationProblem,
    batched_rows,
    condition_number,
)
from drake_dynid.core.joint_limits import JointLimits, Margins, limit_violations
from drake_dynid.limits import joint_limits, read_limits_file
from drake_dynid.robot import RobotModel
from drake_dynid.trajectory_file import read_coefficients, read_trajectory
from drake_dynid.urdf import MODELS_DIR, model_path

# A 3R arm on a cylindrical base whose links hit the base when joint 2 folds down.
FOLDING_3R = """<robot name="folding3r">
  <link name="world"/>
  <link name="base"><collision><origin xyz="0 0 0.15"/>
    <geometry><cylinder radius="0.3" length="0.3"/></geometry></collision></link>
  <joint name="fix" type="fixed"><parent link="world"/><child link="base"/></joint>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="3" effort="100"/></joint>
  <link name="l1"><inertial><origin xyz="0 0 0.07"/><mass value="2"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.005"/></inertial>
    <collision><origin xyz="0 0 0.075"/>
    <geometry><cylinder radius="0.04" length="0.08"/></geometry></collision></link>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0 0.15"/><axis xyz="0 1 0"/>
    <limit lower="0.3" upper="2.8" velocity="3" effort="100"/></joint>
  <link name="l2"><inertial><origin xyz="0 0 0.2"/><mass value="1.5"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.003"/></inertial>
    <collision><origin xyz="0 0 0.21"/>
    <geometry><cylinder radius="0.04" length="0.32"/></geometry></collision></link>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0 0 0.4"/><axis xyz="0 1 0"/>
    <limit lower="-2.8" upper="2.8" velocity="3" effort="100"/></joint>
  <link name="l3"><inertial><origin xyz="0 0 0.15"/><mass value="1"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.002"/></inertial>
    <collision><origin xyz="0 0 0.16"/>
    <geometry><cylinder radius="0.04" length="0.24"/></geometry></collision></link>
  {transmissions}
</robot>"""
TRANSMISSION = (
    '<transmission name="t{j}"><type>transmission_interface/SimpleTransmission'
    '</type><joint name="j{j}"><hardwareInterface>EffortJointInterface'
    '</hardwareInterface></joint><actuator name="a{j}"/></transmission>'
)


def folding_urdf(tmp_path, limits=True):
    text = FOLDING_3R.format(
        transmissions="".join(TRANSMISSION.format(j=j) for j in (1, 2, 3))
    )
    if not limits:
        text = text.replace(' velocity="3" effort="100"', "")
    path = tmp_path / "folding3r.urdf"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(
    ("name", "harmonics", "f0"), [("iiwa7", 3, 0.2), ("ur5", 5, 0.25)]
)
def test_design_beats_random_trajectories_within_the_limits(name, harmonics, f0):
    robot = RobotModel.from_urdf(model_path(name))
    limits = joint_limits(robot, MODELS_DIR / f"{name}_limits.json")
    settings = ExcitationSettings(
        duration=2.0 / f0, harmonics=harmonics, base_frequency=f0, iterations=30
    )
    design = design_excitation(robot.idim_rows, robot.base_values, limits, settings)
    assert design.condition_number * 3.0 <= design.baseline_condition_number
    # The median of the default random trajectories of 10 seeds (same H, f0,
    # duration and kinematic limits).
    baselines = []
    for seed in range(10):
        problem = ExcitationProblem(
            robot.idim_rows,
            robot.base_values,
            limits,
            ExcitationSettings(
                duration=2.0 / f0, harmonics=harmonics, base_frequency=f0, seed=seed
            ),
            Margins(),
            None,
        )
        rows = batched_rows(robot.idim_rows, *_baseline(problem).evaluate(problem.t))
        baselines.append(condition_number(rows[..., problem.active]))
    assert design.condition_number * 3.0 <= np.median(baselines)
    # Within every limit (with the margins) on a dense 1 ms grid over the whole
    # duration, torques from Drake's inverse dynamics (independent of the rows).
    t = np.arange(0.0, settings.duration, 1e-3)[::7]
    q, v, vdot = design.trajectory.evaluate(t)
    tau = drake_torques(robot, q, v, vdot)
    assert limit_violations(t, q, v, vdot, tau, limits, Margins()) == []
    # The reported condition number holds on the dense grid too.
    active = [i for i in range(robot.num_parameters) if i not in design.unexcitable]
    dense = condition_number(robot.idim_rows(q, v, vdot)[..., active])
    assert dense == pytest.approx(design.condition_number, rel=0.05)


def test_gradients_match_central_differences():
    robot = RobotModel.from_urdf(model_path("ur5"))
    limits = joint_limits(robot, MODELS_DIR / "ur5_limits.json")
    settings = ExcitationSettings(duration=5.0, harmonics=3, base_frequency=0.2)
    problem = ExcitationProblem(
        robot.idim_rows, robot.base_values, limits, settings, Margins(), None
    )
    rng = np.random.default_rng(7)  # seed 7
    x = problem.pack(_baseline(problem))
    grad, jacobian = problem.gradients(x)
    for _ in range(3):
        step = rng.normal(size=x.size) * 1e-5
        plus, minus = problem.values(x + step), problem.values(x - step)
        assert (plus[0] - minus[0]) / 2 == pytest.approx(grad @ step, rel=1e-4)
        np.testing.assert_allclose(
            (plus[2] - minus[2]) / 2, jacobian @ step, atol=1e-8 * np.abs(plus[2]).max()
        )


def test_self_collision_constraint_keeps_the_links_apart(tmp_path):
    from pydrake.systems.framework import DiagramBuilder

    from drake_dynid.collision import SelfCollision
    from drake_dynid.urdf import load_plant

    urdf = folding_urdf(tmp_path)
    robot = RobotModel.from_urdf(urdf)
    limits = joint_limits(robot)
    settings = ExcitationSettings(
        duration=5.0, harmonics=3, base_frequency=0.2, iterations=40
    )
    mid = 0.5 * (limits.lower + limits.upper)
    clearance = SelfCollision.from_urdf(urdf, mid)
    free = design_excitation(robot.idim_rows, robot.base_values, limits, settings)
    safe = design_excitation(
        robot.idim_rows, robot.base_values, limits, settings, clearance_fn=clearance
    )
    # Independent check: Drake's HasCollisions along a dense grid.
    builder = DiagramBuilder()
    plant = load_plant(urdf, builder=builder, geometry=True)
    scene_graph = next(s for s in builder.GetSystems() if s.get_name() == "scene_graph")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyMutableContextFromRoot(context)
    sg_context = scene_graph.GetMyContextFromRoot(context)

    def collides(trajectory):
        for q in trajectory.evaluate(np.arange(0.0, 5.0, 0.01))[0]:
            plant.SetPositions(plant_context, q)
            if scene_graph.get_query_output_port().Eval(sg_context).HasCollisions():
                return True
        return False

    assert collides(free.trajectory)
    assert not collides(safe.trajectory)
    # The margin (0.01 m) holds at the grid samples; between them it may dip a bit.
    assert safe.clearance >= 0.9 * 0.01
    assert np.isfinite(safe.condition_number)


def test_limits_file_overrides_and_bad_files(tmp_path):
    robot = RobotModel.from_urdf(model_path("ur5"))
    limits = joint_limits(robot, MODELS_DIR / "ur5_limits.json")
    assert limits.velocity[0] == pytest.approx(3.1416)
    assert limits.effort[5] == 28.0 and limits.lower[0] == pytest.approx(-2 * np.pi)
    bad = tmp_path / "bad.json"
    bad.write_text('{"no_such_joint": {"velocity": 1}}')
    with pytest.raises(ValueError, match="unknown joint 'no_such_joint'"):
        joint_limits(robot, bad)
    bad.write_text('{"elbow_joint": {"speed": 1}}')
    with pytest.raises(ValueError, match="unknown limit 'speed'"):
        joint_limits(robot, bad)
    bad.write_text('{"elbow_joint": {"velocity": "fast"}}')
    with pytest.raises(ValueError, match="must be a number"):
        read_limits_file(bad)
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_limits_file(bad)
    # Found by a review: a joint (or a limit) given twice: the last one silently won.
    bad.write_text('{"elbow_joint": {"velocity": 1}, "elbow_joint": {"effort": 5}}')
    with pytest.raises(ValueError, match=r"bad.json: 'elbow_joint' is given twice"):
        read_limits_file(bad)
    bad.write_text('{"elbow_joint": {"velocity": 1, "velocity": 2}}')
    with pytest.raises(ValueError, match=r"bad.json: 'velocity' is given twice"):
        read_limits_file(bad)
    with pytest.raises(ValueError, match="velocity limit of joint a must be > 0"):
        JointLimits(("a",), [-1.0], [1.0], [0.0], [1.0])


def test_cli_excite_writes_the_trajectory_and_report(tmp_path, capsys):
    out, coefficients = tmp_path / "traj.csv", tmp_path / "traj.json"
    argv = [
        "excite", model_path("ur5"), "--limits", str(MODELS_DIR / "ur5_limits.json"),
        "--duration", "8", "--harmonics", "3", "--f0", "0.25", "--iterations", "20",
        "--out", str(out), "--json", str(coefficients), "--online-window", "4",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    assert "self-collision: not checked" in printed
    assert "condition number:" in printed and "default random trajectory" in printed
    assert "on-line window 4 s" in printed
    # The predicted %σ is the weighted fit's (core/excite_report): a new user's
    # walk-through read it as the default fit's (Kinova ZZ6: 0.0069 % predicted,
    # 6.2 % with the default IDIM-LS, 0.0078 % with --weighted).
    assert "predicted %σ of offline --weighted (" in printed
    robot = RobotModel.from_urdf(model_path("ur5"))
    sampled = read_trajectory(out, robot.joint_names)
    assert sampled.t[0] == 0.0 and sampled.t[-1] == pytest.approx(8.0)
    trajectory, names, duration = read_coefficients(coefficients)
    assert names == robot.joint_names and duration == 8.0
    q, v, _ = trajectory.evaluate(sampled.t)
    np.testing.assert_allclose(sampled.q, q, atol=1e-12)
    np.testing.assert_allclose(sampled.v, v, atol=1e-12)
    document = json.loads(coefficients.read_text())
    assert document["condition_number"] < document["baseline_condition_number"]
    # No acceleration limit: no usage (a review: it read 0.0, as if unused).
    assert document["usage"]["acceleration"] == [None] * 6
    assert all(0.0 < u <= 1.0 for u in document["usage"]["velocity"])
    # Periodic: the trajectory repeats after 1/f0.
    later = trajectory.evaluate(sampled.t[:50] + 4.0)[0]
    np.testing.assert_allclose(later, sampled.q[:50], atol=1e-9)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--duration", "3", "--f0", "0.2"], "duration must be at least one period"),
        (["--duration", "7", "--f0", "0.2"], "whole number of periods"),
        (["--margin", "position=2.5"], "leaves no room"),
        (["--margin", "speed=0.1"], "--margin: expected KIND=VALUE"),
        # Found by a new user's walk-through: excite prints 'velocity 20%', and
        # '--margin velocity=20%' was "velocity must be a number; got '20%'".
        (
            ["--margin", "velocity=20%"],
            "velocity must be a number, a fraction of the limit (0.2 for 20 %)",
        ),
        (["--margin", "position=5deg"], "position must be a number [rad]"),
    ],
)
def test_cli_excite_infeasible_requests_exit_2(tmp_path, capsys, extra, message):
    argv = ["excite", model_path("iiwa7"), "--out", str(tmp_path / "t.csv"), *extra]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_cli_excite_effort_too_tight_names_the_joint(tmp_path, capsys):
    limits = tmp_path / "tight.json"
    limits.write_text(json.dumps({"shoulder_lift_joint": {"effort": 5.0}}))
    argv = [
        "excite", model_path("ur5"), "--limits", str(limits), "--duration", "5",
        "--harmonics", "2", "--iterations", "15", "--out", str(tmp_path / "t.csv"),
    ]  # fmt: skip
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "no trajectory meets the limits" in err
    assert "shoulder_lift_joint: effort" in err and "N·m" in err


def test_cli_excite_missing_limits_and_never_overwrites(tmp_path, capsys):
    urdf = folding_urdf(tmp_path, limits=False)
    out = str(tmp_path / "t.csv")
    assert cli.main(["excite", urdf, "--out", out]) == 2
    err = capsys.readouterr().err
    assert "lack(s) limits" in err and "j1 (velocity, effort)" in err
    assert "--limits FILE" in err
    limits = tmp_path / "limits.json"
    limits.write_text(
        json.dumps({f"j{j}": {"velocity": 3.0, "effort": 100.0} for j in (1, 2, 3)})
    )
    argv = ["excite", urdf, "--limits", str(limits), "--out", str(limits)]
    assert cli.main(argv) == 2
    assert "is an input of this command" in capsys.readouterr().err
    argv = [
        "excite", urdf, "--limits", str(limits), "--duration", "5", "--harmonics",
        "2", "--iterations", "10", "--out", out,
    ]  # fmt: skip
    assert cli.main(argv) == 0
    assert "collision geometries" in capsys.readouterr().out


@pytest.mark.parametrize(
    "outputs, option",
    [
        (["--out", "traj.json"], "--out"),
        (["--out", "t.csv", "--json", "c.csv"], "--json"),
        (["--out", "t.csv", "--json", "c.txt"], "--json"),  # read as CSV too
        (["--out", "t.csv", "--json", "coeffs"], "--json"),
    ],
)
def test_an_output_named_as_the_other_format_is_refused(
    tmp_path, capsys, outputs, option
):
    """A user's `--out traj.json` got the CSV samples in a .json file, which
    simulate and replay then read as --json's coefficients: 'trajectory
    coefficients traj.json: unreadable (Expecting value ...); expected the JSON
    written by dynid excite --json'. Refused before the design, naming the
    format each option writes."""
    urdf = folding_urdf(tmp_path)
    argv = ["excite", urdf, *(p if p[0] == "-" else str(tmp_path / p) for p in outputs)]
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert line.startswith(f"dynid excite: error: {option} ") and "CSV" in line
    assert not any((tmp_path / p).exists() for p in outputs if p[0] != "-")


def test_a_limits_file_of_the_whole_robot_serves_a_subset_of_its_joints():
    """Found by a review: a limits file naming a joint outside --joints (a locked
    or mimic one) was 'unknown joint'; its entry is not used."""
    subset = RobotModel.from_urdf(
        model_path("ur5"), joints=["shoulder_pan_joint", "shoulder_lift_joint"]
    )
    limits = joint_limits(subset, MODELS_DIR / "ur5_limits.json")
    assert limits.joint_names == ("shoulder_pan_joint", "shoulder_lift_joint")
    assert limits.velocity[0] == pytest.approx(3.1416)


def test_noise_tau_is_checked_before_the_design(tmp_path, capsys):
    """Found by a review: --noise-tau -1 ran the design, then named an internal
    argument (excitation_report: noise_fraction)."""
    from drake_dynid import cli

    argv = ["excite", model_path("ur5"), "--noise-tau", "-1"]
    assert cli.main([*argv, "--out", str(tmp_path / "t.csv")]) == 2
    err = capsys.readouterr().err
    assert "--noise-tau must be > 0" in err and "noise_fraction" not in err


def test_the_collision_check_of_a_joint_subset_places_the_locked_joints(tmp_path):
    """excite --joints/--lock (a review: not available, so the TIAGo's torso and
    arm could not be planned): the clearance of q of the identified joints is the
    whole robot's with the locked joints at their positions."""
    from drake_dynid.collision import SelfCollision

    urdf = folding_urdf(tmp_path)
    whole = SelfCollision.from_urdf(urdf, np.zeros(3))
    subset = RobotModel.from_urdf(urdf, joints=["j1", "j3"], locked={"j2": 0.7})
    part = SelfCollision.from_urdf(urdf, np.zeros(2), subset)
    rng = np.random.default_rng(3)
    q = rng.uniform(-2.0, 2.0, (6, 2))
    full = np.column_stack([q[:, 0], np.full(6, 0.7), q[:, 1]])
    # (the reference's ignored pairs differ: compare the closest distances)
    for k in range(6):
        assert part.closest(q[k])[0] == pytest.approx(whole.closest(full[k])[0])


def test_excite_designs_for_a_joint_subset(tmp_path, capsys):
    from drake_dynid import cli

    urdf = folding_urdf(tmp_path)
    argv = ["excite", urdf, "--joints", "j1,j3", "--lock", "j2=0.7"]
    argv += ["--duration", "10", "--out", str(tmp_path / "t.csv")]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "(2 joints," in out and "self-collision: " in out
    header = (tmp_path / "t.csv").read_text().splitlines()[0]
    assert "q_j1" in header and "q_j3" in header and "q_j2" not in header


def test_a_design_worse_than_its_random_start_is_said(tmp_path, capsys):
    """Found by a review: --margin effort=0.99 gave condition 8.8e4 against the
    random trajectory's 174 (which breaks those limits) without a word."""
    from drake_dynid import cli

    argv = [
        "excite",
        model_path("iiwa7"),
        "--limits",
        str(MODELS_DIR / "iiwa7_limits.json"),
    ]
    # 5 iterations: with 10, the re-solves for the effort between the samples (up
    # to 3 x 10 more iterations) now find condition 33 within these limits.
    argv += ["--margin", "effort=0.99", "--duration", "10", "--iterations", "5"]
    assert cli.main([*argv, "--out", str(tmp_path / "t.csv")]) == 0
    err = capsys.readouterr().err
    assert "the design is worse conditioned than the random trajectory" in err
    assert "--iterations 5" in err


def test_the_dense_grid_beyond_the_margins_is_said():
    """Found by a review (the example-robot-data xArm7, default margins): the
    effort is constrained on the optimisation grid only, and between its samples
    joint2 reached 80.07 % of its limit and the clearance 0.00982 m (margins 20 %
    and 0.01 m); the 4x denser check printed "80.1" and 0.00982 m silently."""
    from types import SimpleNamespace

    from drake_dynid.commands.excite import between_samples
    from drake_dynid.core.joint_limits import Margins

    names = ["joint1", "joint2", "joint3"]

    def said(effort, clearance, margins=None):
        design = SimpleNamespace(usage={"effort": effort}, clearance=clearance)
        return between_samples(design, names, margins or Margins())

    assert said([0.3, 0.80003, 0.5], 0.0101) is None  # the optimiser's tolerance
    assert said([0.3, 0.5, 0.5], float("inf")) is None  # no collision geometry
    note = said([0.3, 0.80069, 0.5], 0.00982)
    assert note.startswith("note: ")
    assert "joint2 reaches 80.07 % of its limit (--margin effort=0.2 keeps 80" in note
    assert "clearance falls to 0.00982 m (--margin collision=0.01 m)" in note
    assert "joint1" not in note and "the limits themselves hold" in note
    warning = said([1.003, 0.5, 0.5], 0.001, Margins(effort=0.0))
    assert warning.startswith("warning: ") and "joint1 reaches 100.30 %" in warning
    assert "the limits themselves are exceeded; raise --margin" in warning
    assert said([0.5, 0.5, 0.5], -0.001, Margins(collision=0.0)).startswith("warning")


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("duration", -1.0, r"duration must be in \(0, 100000\] \[s\].*got -1"),
        ("duration", 1e12, r"duration must be in \(0, 100000\] \[s\].*got 1e\+12"),
        ("duration", "8", r"duration must be a real number \[s\]; got '8'"),
        ("base_frequency_hz", "0.5", r"base_frequency_hz must be a real number"),
        ("base_frequency_hz", True, r"base_frequency_hz must be a real number"),
        # Found by a review: q = 7e298 rad, simulated and written with exit 0.
        ("base_frequency_hz", 1e-300, r"\|q\| reaches .*e\+\d+, above 1e\+100"),
        # A review: "j" was read as its characters; harmonics was not checked.
        ("joints", "j", r"joints must be a list of joint names; got 'j'"),
        ("harmonics", 5, r"harmonics \(5\) must be the columns of a and b \(2\)"),
    ],
)
def test_a_coefficient_file_with_a_bad_duration_or_frequency_is_named(
    tmp_path, key, value, message
):
    """Found by a review: simulate --trajectory with a JSON duration of -1 was an
    IndexError, 1e12 a MemoryError (exit 1); "0.5" and true were read as numbers."""
    from drake_dynid.core.trajectory import FourierTrajectory
    from drake_dynid.trajectory_file import write_coefficients

    path = tmp_path / "t.json"
    series = FourierTrajectory(np.zeros(1), np.ones((1, 2)), np.ones((1, 2)), np.pi)
    write_coefficients(path, series, ["j"], 4.0)
    assert read_trajectory(path, ["j"]).t[-1] == 4.0
    document = json.loads(path.read_text())
    document[key] = value
    path.write_text(json.dumps(document))
    with pytest.raises(ValueError, match=f"trajectory .*t.json: .*{message}"):
        read_trajectory(path, ["j"])


def test_the_position_margin_says_its_unit_on_a_prismatic_joint(tmp_path, capsys):
    """Found by a review: the TIAGo's torso (a 0.35 m stroke) keeps the position
    margin 0.1 as 0.1 m at each end, and excite printed "position 0.1 rad"."""
    joints = "torso_lift_joint,arm_1_joint,arm_2_joint"
    argv = ["excite", "tiago_no_hand", "--joints", joints, "--duration", "5"]
    argv += ["--iterations", "3", "--out", str(tmp_path / "t.csv")]
    assert cli.main(argv) == 0
    out = capsys.readouterr().out
    assert "margins: position 0.1 rad, 0.02 m (prismatic torso_lift_joint), v" in out
    argv = ["excite", "iiwa7", "--duration", "5", "--iterations", "3"]
    assert cli.main([*argv, "--out", str(tmp_path / "i.csv")]) == 0
    assert "margins: position 0.1 rad, velocity" in capsys.readouterr().out


def test_a_prismatic_joint_has_its_own_position_margin(tmp_path, capsys):
    """Found by a review: one position margin for every joint, 0.1 "rad", kept
    0.1 m at each end of the TIAGo torso's 0.35 m stroke (0.2 m of it unusable).
    A prismatic joint now keeps --margin prismatic=M (default 0.02 m)."""
    limits = JointLimits(
        ("arm", "torso"),
        lower=[-1.0, 0.0],
        upper=[1.0, 0.35],
        velocity=[1.0, 0.1],
        effort=[10.0, 100.0],
        prismatic=(False, True),
    )
    np.testing.assert_array_equal(
        Margins().position_margins(limits.prismatic), [0.1, 0.02]
    )
    t = np.zeros(1)

    def broken(q, margins=None):
        z = np.zeros((1, 2))
        found = limit_violations(t, np.array([q]), z, z, None, limits, margins)
        return [(f.joint, f.limit) for f in found]

    assert broken([0.85, 0.32]) == []  # 0.1 m from the torso's end used to break
    assert broken([0.85, 0.34]) == [("torso", pytest.approx(0.33))]
    assert broken([0.95, 0.3], Margins(position=0.0, prismatic=0.1)) == [
        ("torso", pytest.approx(0.25))
    ]
    with pytest.raises(ValueError, match="prismatic margin must be >= 0; got -1"):
        Margins(prismatic=-1.0)
    joints = "torso_lift_joint,arm_1_joint"
    argv = ["excite", "tiago_no_hand", "--joints", joints, "--duration", "5"]
    argv += ["--iterations", "3", "--out", str(tmp_path / "t.csv")]
    assert cli.main([*argv, "--margin", "prismatic=0.2"]) == 2
    err = capsys.readouterr().err
    assert "joint torso_lift_joint: the position margin 0.2 m (margin prismatic)" in err
    assert "leaves no room within [0, 0.35] m" in err
    # Found by a new user's walk-through: `dynid excite` of example-robot-data's
    # Panda (finger stroke [0, 0.04] m) stopped there without saying what to do.
    assert "give a margin below half the range (--margin prismatic=V, V < 0.175)" in err
    assert "or lock the joint (--lock NAME=VALUE) if it is not to be identified" in err


def test_the_effort_holds_between_the_samples_of_the_grid():
    """Found by a review: the effort was constrained on the optimisation grid only,
    and between its samples the design passed the margined limit (the xArm7:
    100.09 %; here the UR5 at 0.3x its datasheet torques, seed 3: 100.033 % on a
    200 001-point grid). The dense check now re-solves with the bound tightened."""
    from dataclasses import replace

    robot = RobotModel.from_urdf(model_path("ur5"))
    limits = joint_limits(robot, MODELS_DIR / "ur5_limits.json")
    limits = replace(limits, effort=0.3 * limits.effort)
    settings = ExcitationSettings(duration=10.0, seed=3)
    design = design_excitation(robot.idim_rows, robot.base_values, limits, settings)
    t = np.linspace(0.0, design.trajectory.period, 200_001)
    q, v, vdot = design.trajectory.evaluate(t)
    tau = batched_rows(robot.idim_rows, q, v, vdot) @ robot.base_values
    used = np.abs(tau).max(axis=0) / (0.8 * limits.effort)
    assert used.max() <= 1.0 + 1e-6, used
    assert used.max() > 0.99  # the effort limit is the active one
    # The design reports the same maximum (its dense grid, refined at the peaks).
    np.testing.assert_allclose(design.usage["effort"] / 0.8, used, rtol=1e-6)


def test_a_continuous_joint_is_designed_within_one_turn(tmp_path, capsys):
    """Found by a sweep of example-robot-data (the PR2's forearm and wrist
    rolls): a continuous joint has no position limits and excite refused the
    robot ('lack(s) limits ... (position)'), asking for a limits file that such
    a joint should not need. Now it gets [-π, π] with a note; --limits still
    sets another range."""
    text = Path(folding_urdf(tmp_path)).read_text()
    text = text.replace(
        '<joint name="j1" type="revolute">', '<joint name="j1" type="continuous">'
    ).replace('<limit lower="-3" upper="3" velocity="3"', '<limit velocity="3"', 1)
    urdf = tmp_path / "continuous.urdf"
    urdf.write_text(text)
    out = tmp_path / "t.csv"
    argv = [
        "excite", str(urdf), "--duration", "5", "--harmonics", "2",
        "--iterations", "10", "--out", str(out), "--json", str(tmp_path / "c.json"),
    ]  # fmt: skip
    assert cli.main(argv) == 0
    err = capsys.readouterr().err
    assert "j1 has no position limits (continuous)" in err
    assert "[-3.142, 3.142] rad" in err
    q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1]
    assert np.all(np.abs(q) <= np.pi) and np.ptp(q) > 0.1
    limits = tmp_path / "limits.json"
    limits.write_text(json.dumps({"j1": {"lower": -0.5, "upper": 0.5}}))
    assert cli.main([*argv, "--limits", str(limits)]) == 0
    assert "no position limits" not in capsys.readouterr().err
    q = np.loadtxt(out, delimiter=",", skiprows=1)[:, 1]
    assert np.all(np.abs(q) <= 0.5)


def test_a_refusal_on_self_collision_names_the_pair_and_what_to_do():
    """Found by the example-robot-data sweep: the SO-101 and the PR2's left arm
    were refused with "self-collision clearance -0.052 m at t = 0.719 s is below
    the 0.01 m margin" (and -0.1853 m), naming neither the links that met nor
    what to change (the advice was about limits, margins, f0 and harmonics)."""

    class Clearance:
        """Every configuration 5 mm from the margin, the pair 'upper-lower'."""

        def __call__(self, q):
            return np.full(np.atleast_2d(q).shape[0], 0.005)

        def closest(self, q):
            return 0.005, "upper-lower"

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    limits = JointLimits(
        robot.joint_names, [-2.0, -2.0], [2.0, 2.0], [2.0, 2.0], [50.0, 50.0]
    )
    settings = ExcitationSettings(duration=5.0, harmonics=2, iterations=3)
    with pytest.raises(ValueError) as error:
        design_excitation(
            robot.idim_rows,
            robot.base_values,
            limits,
            settings,
            clearance_fn=Clearance(),
        )
    message = str(error.value)
    assert "self-collision clearance 0.005 m between links upper-lower" in message
    assert "--margin collision=M" in message and "--lock" in message
    assert "lower f0/harmonics" not in message  # the advice for the other limits


def test_a_pair_held_at_mid_range_leaves_room_to_move_about_it(tmp_path):
    """Found by the example-robot-data sweep: a pair closer than the collision
    margin at mid-range (the SO-101's jaw 9.4 mm from its wrist) was held no
    closer than that very distance, so mid-range sat on the bound and any motion
    about it brought the pair closer at some instant (29 of 80 samples at 1e-4
    of the start's amplitude): the design's start shrunk out of collision was a
    standstill, SLSQP stopped on it after 1 iteration, and the SO-101 was refused.
    Held no closer than half that distance, small motions keep the margin."""
    from drake_dynid.collision import SelfCollision

    urdf = folding_urdf(tmp_path)
    robot = RobotModel.from_urdf(urdf)
    limits = joint_limits(robot)
    mid = 0.5 * (limits.lower + limits.upper)
    plain = SelfCollision.from_urdf(urdf, mid)
    distance, pair = plain.closest(mid)
    assert pair == "base-l2" and 0.1 < distance < 0.12  # 0.111 m
    check = SelfCollision.from_urdf(urdf, mid, margin=0.15)
    assert check.held == (f"base-l2 ({distance:.2g} m)",)
    assert check(mid)[0] > 0.15  # 0.15 before
    steps = 0.01 * np.vstack([np.eye(3), -np.eye(3)])
    assert np.all(check(mid + steps) >= 0.15)  # j2 folding towards the base too


def test_a_refusal_lists_every_broken_limit_most_violated_first(tmp_path, capsys):
    """Found by the example-robot-data sweep: a refusal named only the constraint
    broken most in relative terms; the PR2's left arm was refused on a clearance
    of -0.1853 m (19.5 times the 0.01 m margin), while its shoulder lift needed
    39.7 N·m standing at mid-range against 24 N·m allowed, which nothing said.
    Every broken limit is listed now (each pair of links below the margin, each
    joint's effort), most violated first, each with what to change; an effort
    that mid-range alone passes says what the URDF's torques need."""
    urdf = folding_urdf(tmp_path)
    limits = tmp_path / "limits.json"
    limits.write_text(json.dumps({"j2": {"effort": 5.0}}))  # 8.34 N·m at mid-range
    argv = [
        "excite", urdf, "--limits", str(limits), "--duration", "5", "--harmonics",
        "2", "--iterations", "3", "--out", str(tmp_path / "t.csv"),
    ]  # fmt: skip
    assert cli.main(argv) == 2
    line = error_line(capsys)
    assert "breaks 3 limits, most violated first: (1) self-collision" in line
    first = line.index("between links base-l2")
    second = line.index("(2) self-collision clearance")
    assert first < second < line.index("between links base-l3 at t")
    assert line.index("margin: as (1); (3)") > second
    effort = line[line.index("(3) joint j2: effort") :]
    assert "exceeds the limit 4 N·m" in effort
    assert "standing still at mid-range it already needs 8.34 N·m" in effort
    assert "effort limit above 10.4 N·m (--limits FILE, effort)" in effort
    assert "(--lock j2=VALUE)" in effort  # the option's syntax (review)
    assert "lock one (--lock NAME=VALUE)" in line


def test_the_clearance_keys_only_the_pairs_closer_than_the_best_so_far(
    tmp_path, monkeypatch
):
    """Found profiling the SO-101's excite: the clearance computed the sorted key
    of every pair Drake returned (85 a configuration, two get_value calls each) to
    look up its offset and whether it is ignored: a fifth of the clearance's time
    (0.73 s for 560 configurations against 0.57 s for Drake's queries alone). The
    offsets are positive, so a pair no closer than the best so far cannot be the
    minimum: its key is skipped. The distances are the same."""
    from drake_dynid.collision import SelfCollision

    urdf = folding_urdf(tmp_path)
    robot = RobotModel.from_urdf(urdf)
    limits = joint_limits(robot)
    mid = 0.5 * (limits.lower + limits.upper)
    check = SelfCollision.from_urdf(urdf, mid, margin=0.15)  # base-l2 held
    q = mid + np.random.default_rng(0).uniform(-1.0, 1.0, (200, 3))
    pairs = [check._pairs(row) for row in q]
    expected = [
        min(
            [1.0]
            + [
                p.distance + check._offset.get(check._key(p), 0.0)
                for p in found
                if check._key(p) not in check._ignored
            ]
        )
        for found in pairs
    ]
    keys = []
    key = SelfCollision._key
    monkeypatch.setattr(
        SelfCollision, "_key", staticmethod(lambda p: keys.append(1) or key(p))
    )
    np.testing.assert_array_equal(check(q), expected)
    assert len(keys) < 0.8 * sum(len(found) for found in pairs)


def _brute_clearance(check, q):
    """The clearance over every pair Drake returns: the offsets of the held pairs
    added, the ignored ones left out, capped at MAX_DISTANCE."""
    from drake_dynid.collision import MAX_DISTANCE

    out = []
    for row in np.atleast_2d(q):
        best = MAX_DISTANCE
        for pair in check._pairs(row):
            key = check._key(pair)
            if key not in check._ignored:
                best = min(best, pair.distance + check._offset.get(key, 0.0))
        out.append(best)
    return np.array(out)


@pytest.mark.parametrize(
    ("reference", "margin"),
    [
        ((0.0, 1.55, 0.0), 0.3),  # base-l2, base-l3 held; l1-l3 not
        ((0.0, 1.55, 0.0), 0.6),  # all three held
        ((0.0, 2.7, 0.0), 0.3),  # base-l2, base-l3 ignored
        ((0.4, 2.3, -1.0), 0.25),  # a mix
    ],
)
def test_the_clearance_and_its_jacobian_are_the_brute_force_minimum(
    tmp_path, reference, margin
):
    """Review of the pair loop that skips a pair no closer than the best so far
    (050e141): with held pairs (offset margin - d_ref/2 > 0 added), ignored pairs
    and the minimum moving between them, the clearance equals the minimum over
    every pair Drake returns, bit for bit, and so does the design's Jacobian
    (ExcitationProblem.clearance: finite differences of the clearance)."""
    from drake_dynid.collision import SelfCollision

    urdf = folding_urdf(tmp_path)
    robot = RobotModel.from_urdf(urdf)
    limits = joint_limits(robot)
    check = SelfCollision.from_urdf(urdf, np.array(reference), margin=margin)
    rng = np.random.default_rng(11)
    q = rng.uniform(limits.lower, limits.upper, (150, 3))
    q[::10] = q[1::10]  # repeated rows
    values = check(q)
    np.testing.assert_array_equal(values, _brute_clearance(check, q))
    assert values.min() < values.max() < 1.0  # not a constant cap
    settings = ExcitationSettings(duration=5.0, harmonics=2, base_frequency=0.2)

    class Brute:
        def __call__(self, q):
            return _brute_clearance(check, q)

    problems = [
        ExcitationProblem(
            robot.idim_rows, robot.base_values, limits, settings, Margins(), fn
        )
        for fn in (check, Brute())
    ]
    for seed in range(2):
        x = problems[0].pack(_baseline(problems[0]))
        x = x + np.random.default_rng(seed).normal(0.0, 0.3, x.shape)
        (d, jacobian), (d_brute, jacobian_brute) = (p.clearance(x) for p in problems)
        np.testing.assert_array_equal(d, d_brute)
        np.testing.assert_array_equal(jacobian, jacobian_brute)
        assert np.any(jacobian != 0.0)


def test_the_pair_loop_keeps_the_minimum_with_ties_offsets_and_ignored_pairs():
    """The pair loop's skip (a pair no closer than the best so far) on made-up
    pairs with many ties: each distance a multiple of 0.05 m, a third of the pairs
    held (offset > 0), a fifth ignored, in every order; the result is the brute
    minimum."""
    from types import SimpleNamespace

    from drake_dynid.collision import MAX_DISTANCE, SelfCollision

    class Id:
        def __init__(self, value):
            self.value = value

        def get_value(self):
            return self.value

    rng = np.random.default_rng(4)
    for _ in range(300):
        count = int(rng.integers(0, 8))
        ids = [(Id(2 * k), Id(2 * k + 1)) for k in range(count)]
        pairs = [
            SimpleNamespace(
                id_A=b if rng.random() < 0.5 else a,
                id_B=a if rng.random() < 0.5 else b,
                distance=0.05 * int(rng.integers(-4, 24)),
            )
            for a, b in ids
        ]
        check = object.__new__(SelfCollision)
        keys = [SelfCollision._key(p) for p in pairs]
        check._ignored = {k for k in keys if rng.random() < 0.2}
        check._offset = {k: 0.05 * int(rng.integers(1, 5)) for k in keys}
        check._offset = {k: v for k, v in check._offset.items() if rng.random() < 0.35}
        check._pairs = lambda q, pairs=pairs: pairs
        expected = min(
            [MAX_DISTANCE]
            + [
                p.distance + check._offset.get(k, 0.0)
                for p, k in zip(pairs, keys, strict=True)
                if k not in check._ignored
            ]
        )
        assert check(np.zeros((1, 1)))[0] == expected


def test_a_refusal_orders_a_position_by_its_range_not_its_bound(tmp_path):
    """Review of the refusal's order (4ad061f): a position's excess was divided by
    the bound's own value, so 0.01 rad past a margined bound at 0 rad (j3 limited
    to [-0.1, 2.8] with the 0.1 rad margin) counted 1e7 times over and came
    before j2's effort at 2.25 times its limit. A position's excess is now
    relative to the joint's margined half range (0.01 / 1.35)."""
    from drake_dynid.core.excite import _refusal

    urdf = folding_urdf(tmp_path)
    robot = RobotModel.from_urdf(urdf)
    path = tmp_path / "limits.json"
    path.write_text(
        json.dumps({"j3": {"lower": -0.1, "upper": 2.8}, "j2": {"effort": 5.0}})
    )
    limits = joint_limits(robot, path)
    settings = ExcitationSettings(duration=5.0, harmonics=2, base_frequency=0.2)
    problem = ExcitationProblem(
        robot.idim_rows, robot.base_values, limits, settings, Margins(), None
    )
    x = problem.pack(_baseline(problem))
    q = problem.trajectory(x).evaluate(problem.t)[0]
    x[2] -= q[:, 2].min() + 0.01  # j3 0.01 rad below its margined bound, 0 rad
    message = _refusal(problem, x)
    assert "breaks 2 limits" in message
    assert "(1) joint j2: effort" in message
    assert "(2) joint j3: position -0.01 rad" in message


def test_a_refusal_gives_a_held_pair_its_geometric_distance(tmp_path, capsys):
    """Review of the refusal's pairs (4ad061f): a pair held no closer than half its
    mid-range distance (base-l2, 0.111 m at mid-range under a 0.15 m margin) was
    said at the offset clearance the optimiser sees, distance + 0.15 - 0.111/2:
    'clearance -0.1064 m ... below the 0.15 m margin' for links 0.2009 m deep
    (and a positive clearance for links that already touch). It is now said at
    its geometric distance against the half distance it is held at."""
    from drake_dynid.collision import SelfCollision

    urdf = folding_urdf(tmp_path)
    limits = tmp_path / "limits.json"
    limits.write_text(json.dumps({"j2": {"effort": 5.0}}))
    argv = [
        "excite", urdf, "--limits", str(limits), "--duration", "5", "--harmonics",
        "2", "--iterations", "3", "--margin", "collision=0.15", "--out",
        str(tmp_path / "t.csv"),
    ]  # fmt: skip
    assert cli.main(argv) == 2
    line = error_line(capsys)
    said = line[line.index("(1) self-collision clearance ") :]
    value = float(said.split()[3])
    check = SelfCollision.from_urdf(urdf, np.array([0.0, 1.55, 0.0]), margin=0.15)
    (held,) = check.held
    assert held.startswith("base-l2 (0.11 m)")
    assert "between links base-l2 (held at half its mid-range distance)" in said
    assert said.index("below the 0.0555") < said.index("(2)")
    assert value < -0.15  # the links' own depth, not the offset clearance
