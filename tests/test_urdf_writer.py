"""Identified URDF: Drake's inverse dynamics of the written file reproduce W·θ.

Truth: Drake's ``CalcInverseDynamics`` (with the force elements: gravity and joint
damping) on the written URDF, plus Coulomb friction FCj·sign(vj), against the
identified model's W·θ at random states (default_rng(0), (1), (4)).
"""

import xml.etree.ElementTree as ElementTree
from pathlib import Path

import numpy as np
import pytest

from drake_dynid.physical import pseudo_inertia
from drake_dynid.plants import RobotModel, model_path, read_urdf_friction
from drake_dynid.urdf_writer import (
    DRIVE_TOTALS,
    HEADER,
    drive_totals,
    implausible_links,
    implausible_note,
    write_identified_urdf,
)


def _consistent_values(robot, rng):
    """URDF standard values with each link moved to a random consistent body."""
    values = np.array(robot.standard_values, dtype=float)
    index = {name: k for k, name in enumerate(robot.standard_names)}
    for j in range(1, len(robot.links) + 1):
        masses = rng.uniform(0.2, 1.5, 3)
        points = 0.2 * rng.normal(size=(3, 3)) + [0.1, 0.05, 0.0]
        inertia = sum(
            m * (p @ p * np.eye(3) - np.outer(p, p))
            for m, p in zip(masses, points, strict=True)
        )
        first = masses @ points
        for name, value in zip(
            ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M"),
            (
                *inertia[0],
                inertia[1, 1],
                inertia[1, 2],
                inertia[2, 2],
                *first,
                masses.sum(),
            ),
            strict=True,
        ):
            values[index[f"{name}{j}"]] = value
        if f"IA{j}" in index:
            values[index[f"IA{j}"]] = rng.uniform(0.01, 0.3)
        for kind in ("FV", "FC"):
            if f"{kind}{j}" in index:
                values[index[f"{kind}{j}"]] = rng.uniform(0.05, 1.0)
    return values


def _inverse_dynamics(plant, q, v, vdot):
    """Drake's CalcInverseDynamics with the force elements (gravity, damping)."""
    from pydrake.multibody.tree import MultibodyForces

    context = plant.CreateDefaultContext()
    out = []
    for k in range(q.shape[0]):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        out.append(plant.CalcInverseDynamics(context, vdot[k], forces))
    return np.array(out)


def _drake_torques(path, robot, q, v, vdot):
    plant = RobotModel.from_urdf(path, rotor_inertia=robot.rotor_inertia).plant
    coulomb = read_urdf_friction(path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    return _inverse_dynamics(plant, q, v, vdot) + fc * np.sign(v)


@pytest.mark.parametrize(
    ("name", "rotor_inertia", "seed"),
    [("planar_2r", True, 0), ("iiwa7", False, 1)],
)
def test_written_urdf_reproduces_the_identified_torques(
    tmp_path, name, rotor_inertia, seed
):
    robot = RobotModel.from_urdf(model_path(name), rotor_inertia=rotor_inertia)
    rng = np.random.default_rng(seed)
    values = _consistent_values(robot, rng)
    theta = robot.base.values(values)
    out = tmp_path / f"{name}_identified.urdf"
    export = write_identified_urdf(robot, values, out)
    assert export.path == str(out) and len(export.links) == robot.num_joints
    assert export.lumped == () and export.skipped == ()
    q = rng.uniform(-np.pi, np.pi, (6, robot.num_joints))
    v, vdot = rng.normal(size=(2, 6, robot.num_joints))
    expected = robot.idim_rows(q, v, vdot) @ theta
    np.testing.assert_allclose(
        _drake_torques(out, robot, q, v, vdot), expected, rtol=1e-9, atol=1e-9
    )
    # Read back by drake_dynid: the same standard parameters.
    again = RobotModel.from_urdf(out, rotor_inertia=rotor_inertia)
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-9, atol=1e-12)
    text = out.read_text()
    assert "Identified by drake_dynid" in text
    if rotor_inertia:
        assert "drake:rotor_inertia" in text and 'xmlns:drake="http' in text
    # The input's comments before <robot> survive.
    assert text.count("<!--") >= 2


def test_welded_links_are_lumped_with_mass_zero(tmp_path):
    # The 2R with a 0.5 kg tool welded to link2 at 1 m: drake_dynid lumps it into
    # link 2; the written file carries the lumped inertia on link2 and mass 0 on
    # the tool, and Drake computes the same torques.
    source = tmp_path / "with_tool.urdf"
    text = Path(model_path("planar_2r")).read_text()
    tool = """
  <link name="tool">
    <inertial>
      <origin xyz="0.05 0 0" rpy="0 0 0"/>
      <mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/>
    </inertial>
    <visual><geometry><mesh filename="meshes/tool.obj"/></geometry></visual>
  </link>
  <joint name="tool_weld" type="fixed">
    <parent link="link2"/>
    <child link="tool"/>
    <origin xyz="1 0 0" rpy="0 0 0"/>
  </joint>
  <gazebo><plugin name="control" filename="libgazebo_ros_control.so"/></gazebo>
</robot>"""
    source.write_text(text.replace("</robot>", tool))
    robot = RobotModel.from_urdf(source)
    assert robot.standard_parameters()["M2"] == pytest.approx(1.5)
    values = np.array(robot.standard_values)
    (tmp_path / "out").mkdir()
    out = tmp_path / "out" / "identified.urdf"
    export = write_identified_urdf(robot, values, out)
    assert export.lumped == ("tool",)
    root = ElementTree.parse(out).getroot()
    tool_link = next(link for link in root.iter("link") if link.get("name") == "tool")
    assert float(tool_link.find("inertial/mass").get("value")) == 0.0
    # A relative mesh name is made absolute (the output is in another directory);
    # a Gazebo plugin's library name is not a file beside the URDF (a review).
    mesh = tool_link.find("visual/geometry/mesh").get("filename")
    assert mesh == str((tmp_path / "meshes" / "tool.obj").resolve())
    plugin = root.find("gazebo/plugin")
    assert plugin.get("filename") == "libgazebo_ros_control.so"
    again = RobotModel.from_urdf(out)
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-9, atol=1e-12)
    rng = np.random.default_rng(4)
    q = rng.uniform(-np.pi, np.pi, (4, 2))
    v, vdot = rng.normal(size=(2, 4, 2))
    np.testing.assert_allclose(
        _drake_torques(out, robot, q, v, vdot),
        robot.idim_rows(q, v, vdot, columns="standard") @ values,
        rtol=1e-9,
        atol=1e-9,
    )


def test_refuses_to_overwrite_the_input_or_write_impossible_links(tmp_path):
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    values = np.array(robot.standard_values)
    with pytest.raises(ValueError, match="path must differ from the input URDF"):
        write_identified_urdf(robot, values, model_path("planar_2r"))
    bad = values.copy()
    bad[robot.standard_names.index("ZZ2")] = -1.0
    assert np.linalg.eigvalsh(pseudo_inertia(bad[10:20])).min() < 0
    with pytest.raises(ValueError, match=r"link 'link2' .* not physically consistent"):
        write_identified_urdf(robot, bad, tmp_path / "bad.urdf")
    bad = values.copy()
    bad[robot.standard_names.index("FV1")] = -0.1
    with pytest.raises(ValueError, match="FV1 must be >= 0"):
        write_identified_urdf(robot, bad, tmp_path / "bad.urdf")
    with pytest.raises(ValueError, match=r"standard_values must have shape \(24\)"):
        write_identified_urdf(robot, values[:5], tmp_path / "bad.urdf")
    assert not (tmp_path / "bad.urdf").exists()


def _drake_full_torques(path, q_full, v_full, a_full):
    """Drake alone on the written file: every movable joint's torque [N·m, N]."""
    from drake_dynid.urdf import load_plant

    return _inverse_dynamics(load_plant(path), q_full, v_full, a_full)


def _check_2r_in_drake(out, robot, values, rng):
    """Drake's inverse dynamics of the written 2R file plus its FC·sign(v)
    (``_drake_torques``) equal the model's W·θ at four random states."""
    q = rng.uniform(-np.pi, np.pi, (4, 2))
    v, vdot = rng.normal(size=(2, 4, 2))
    expected = robot.idim_rows(q, v, vdot) @ robot.base.values(values)
    np.testing.assert_allclose(
        _drake_torques(out, robot, q, v, vdot), expected, rtol=1e-9, atol=1e-9
    )


def _check_gripper_in_drake(out, robot, values, rng):
    """Drake's inverse dynamics of the written gripper (its mimic finger fb
    follows fa with ratio 1.5, offset 0.01) plus the file's FC·sign(v) equal
    the identified model's W·θ; returns the file's Coulomb frictions."""
    q = rng.uniform(-1.0, 1.0, (5, 3))
    q[:, 2] = rng.uniform(0.0, 0.02, 5)
    v, vdot = rng.normal(size=(2, 5, 3))

    def full(x, offset):
        return np.column_stack([x, 1.5 * x[:, 2] + offset])

    tau = _drake_full_torques(out, full(q, 0.01), full(v, 0.0), full(vdot, 0.0))
    tau = tau[:, :3] + np.outer(tau[:, 3], [0.0, 0.0, 1.5])
    coulomb = read_urdf_friction(out)
    tau += np.array([coulomb.get(n, 0.0) for n in robot.joint_names]) * np.sign(v)
    expected = robot.idim_rows(q, v, vdot, columns="standard") @ values
    np.testing.assert_allclose(tau, expected, rtol=1e-9, atol=1e-9)
    return coulomb


def test_locked_joints_are_written_fixed_with_their_links_lumped(tmp_path):
    # iiwa7 identified on joints 1, 2, 4, the others locked: the bodies beyond a
    # locked joint are lumped into the identified link at the locked pose. The
    # written file has those joints fixed there and those links at mass 0 (a
    # review found them counted twice: the head of the TIAGo in its torso).
    locked = {
        "iiwa_joint_3": 0.4,
        "iiwa_joint_5": -0.6,
        "iiwa_joint_6": 0.9,
        "iiwa_joint_7": 1.0,
    }
    joints = ("iiwa_joint_1", "iiwa_joint_2", "iiwa_joint_4")
    robot = RobotModel.from_urdf(model_path("iiwa7"), joints=joints, locked=locked)
    rng = np.random.default_rng(5)
    values = _consistent_values(robot, rng)
    out = tmp_path / "part.urdf"
    export = write_identified_urdf(robot, values, out)
    assert set(export.locked) == set(locked)
    assert set(export.lumped) >= {f"iiwa_link_{i}" for i in (5, 6, 7)}
    root = ElementTree.parse(out).getroot()
    kinds = {j.get("name"): j.get("type") for j in root.iter("joint")}
    assert all(kinds[name] == "fixed" for name in locked)
    assert "Locked in the identification, fixed here" in out.read_text()
    q = rng.uniform(-2.0, 2.0, (5, 3))
    v, vdot = rng.normal(size=(2, 5, 3))
    expected = robot.idim_rows(q, v, vdot, columns="standard") @ values
    again = RobotModel.from_urdf(out)
    assert again.joint_names == joints
    np.testing.assert_allclose(
        _drake_torques(out, again, q, v, vdot), expected, rtol=1e-9, atol=1e-9
    )
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-9, atol=1e-12)


def test_a_moving_mimic_link_is_written(tmp_path):
    # The gripper: j1, j2, fa identified, fb = 1.5 fa + 0.01 moves with fa (link 4
    # of the model). Its link's identified inertia is written, its joint's
    # friction (not in the model) is 0; Drake on the written file with
    # τ = Pᵀ τ_full (virtual work) gives W·θ.
    from tests.test_any_urdf import gripper_urdf

    robot = RobotModel.from_urdf(gripper_urdf(tmp_path / "g.urdf"))
    assert robot.links == ("j1", "j2", "fa", "fb")
    rng = np.random.default_rng(6)
    values = _consistent_values(robot, rng)
    out = tmp_path / "gripper_identified.urdf"
    export = write_identified_urdf(robot, values, out)
    assert export.links == ("l1", "l2", "fa", "fb")
    coulomb = _check_gripper_in_drake(out, robot, values, rng)
    assert coulomb.get("fb", 0.0) == 0.0
    # fb's friction is in fa's FV3, FC3 (the model folds it): said so, not "not
    # identified" (a review: restoring them would count them twice).
    text = out.read_text()
    assert "part of its leader's FVj, FCj" in text and "damping of fb" in text
    assert "Not identified, written as 0" not in text


def test_unidentified_friction_is_zero_and_rotor_inertia_finds_a_place(tmp_path):
    # --friction viscous: the URDF's Coulomb values are not the identified model's,
    # so they are written as 0 (they were kept). Rotor inertia on a URDF without
    # <transmission>: a SimpleTransmission is added (the writer refused, after
    # the whole fit).
    robot = RobotModel.from_urdf(
        "tests/data/wrist4.urdf", friction=("viscous",), rotor_inertia=True
    )
    values = _consistent_values(robot, np.random.default_rng(7))
    index = {name: k for k, name in enumerate(robot.standard_names)}
    for j in range(1, robot.num_joints + 1):
        values[index[f"IA{j}"]] = 0.01 * j
    out = tmp_path / "w.urdf"
    export = write_identified_urdf(robot, values, out)
    assert export.skipped == ()
    assert not any(read_urdf_friction(out).values())
    again = RobotModel.from_urdf(out, friction=("viscous",), rotor_inertia=True)
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-9, atol=1e-12)
    assert "Not identified, written as 0: friction of" in out.read_text()
    # No Coulomb column: the header names no Coulomb law of the fit (a review: it
    # said "FCj * sign(v)").
    assert "Coulomb friction of the fit" not in out.read_text()


def test_a_differential_transmission_has_no_rotor_inertia_field(tmp_path):
    # The TIAGo's wrist (arm_6, arm_7 in one DifferentialTransmission, which Drake
    # does not read): IA7, IA8 are listed as not written (IA7 went to arm_6's
    # motor and was overwritten by IA8).
    joints = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"), joints=joints, rotor_inertia=True
    )
    values = _consistent_values(robot, np.random.default_rng(8))
    export = write_identified_urdf(robot, values, tmp_path / "t.urdf")
    assert export.skipped == ("IA7", "IA8")
    # The head (locked at 0) is lumped into the torso link and fixed.
    assert {"head_1_link", "head_2_link"} <= set(export.lumped)
    assert {"head_1_joint", "head_2_joint"} <= set(export.locked)


def test_names_with_a_double_hyphen_make_well_formed_comments(tmp_path):
    # "--" may not appear in an XML comment: a lumped link named "tool--x" made
    # the written file unreadable (a review).
    source = tmp_path / "hyphens--robot.urdf"
    text = Path(model_path("planar_2r")).read_text()
    tool = """
  <link name="tool--x">
    <inertial><mass value="0.5"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/>
    </inertial>
  </link>
  <joint name="weld--x" type="fixed">
    <parent link="link2"/><child link="tool--x"/><origin xyz="1 0 0"/>
  </joint>
</robot>"""
    source.write_text(text.replace("</robot>", tool))
    robot = RobotModel.from_urdf(source)
    out = tmp_path / "out.urdf"
    export = write_identified_urdf(
        robot, robot.standard_values, out, notes=["a note -- with hyphens"]
    )
    assert export.lumped == ("tool--x",)
    ElementTree.parse(out)  # well-formed
    np.testing.assert_allclose(
        RobotModel.from_urdf(out).standard_values, robot.standard_values, atol=1e-12
    )


def test_a_friction_held_at_zero_is_written_as_zero(tmp_path):
    # The consistent solve leaves a friction at its bound as 1.7e-11 (a review):
    # written as 0, as Drake's parser warns on any non-zero friction attribute.
    robot = RobotModel.from_urdf(model_path("planar_2r"))
    values = np.array(robot.standard_values, dtype=float)
    index = {name: k for k, name in enumerate(robot.standard_names)}
    values[index["FC1"]], values[index["FV2"]] = 1.7e-11, 0.3
    out = tmp_path / "out.urdf"
    write_identified_urdf(robot, values, out)
    joints = {
        j.get("name"): j for j in ElementTree.parse(out).getroot().findall("joint")
    }
    assert joints["joint1"].find("dynamics").get("friction") == "0.0"
    assert joints["joint2"].find("dynamics").get("damping") == "0.3"


def test_rotor_inertia_keeps_the_transmission_ratio_of_mechanical_reduction(tmp_path):
    # A URDF whose actuators give their ratio as <mechanicalReduction> only (no
    # drake:gear_ratio): drake_dynid's drive chain reads R from it. The writer
    # used to add drake:gear_ratio = 1, which then won over the reduction: the
    # written file, loaded with the same drive file, had R = 1 instead of 50, and
    # a motor-side log validated against it was off by 1886 % (a review).
    source = tmp_path / "geared.urdf"
    text = Path(model_path("planar_2r")).read_text()
    text = text.replace(
        "<mechanicalReduction>1</mechanicalReduction>",
        "<mechanicalReduction>50</mechanicalReduction>",
    )
    source.write_text(text)
    drive = tmp_path / "empty.toml"
    drive.write_text("")
    robot = RobotModel.from_urdf(source, rotor_inertia=True, drive=str(drive))
    values = _consistent_values(robot, np.random.default_rng(9))
    out = tmp_path / "geared_identified.urdf"
    write_identified_urdf(robot, values, out)
    again = RobotModel.from_urdf(out, rotor_inertia=True, drive=str(drive))
    np.testing.assert_array_equal(again.drive.coupling, robot.drive.coupling)
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-9, atol=1e-12)
    # Drake (which ignores <mechanicalReduction>) reflects the same IAj.
    _check_2r_in_drake(out, robot, values, np.random.default_rng(10))


def test_rotor_inertia_not_identified_is_written_as_zero(tmp_path):
    # A URDF with drake:rotor_inertia identified without --rotor-inertia: the
    # identified model has no IAj (the data's rotor inertia went into ZZ1R, ...),
    # but the writer kept the input's rotor inertia, so Drake's inverse dynamics of
    # the written file were W·θ + IA_URDF·v̇, not W·θ (a review: 0.4 N·m on the
    # iiwa7 with 0.2 kg·m² per joint). Written as 0, as a friction kind not
    # identified.
    source = tmp_path / "rotors.urdf"
    text = Path(model_path("planar_2r")).read_text()
    text = text.replace(
        '<robot name="', '<robot xmlns:drake="http://drake.mit.edu" name="'
    )
    text = text.replace(
        "<mechanicalReduction>1</mechanicalReduction>",
        "<mechanicalReduction>1</mechanicalReduction>"
        '<drake:rotor_inertia value="0.05"/>',
    )
    source.write_text(text)
    robot = RobotModel.from_urdf(source)
    assert not robot.rotor_inertia
    values = _consistent_values(robot, np.random.default_rng(11))
    out = tmp_path / "rotors_identified.urdf"
    write_identified_urdf(robot, values, out)
    _check_2r_in_drake(out, robot, values, np.random.default_rng(12))
    assert "Not identified, written as 0: rotor inertia of joint1" in out.read_text()


def test_rotor_inertia_is_written_with_the_drive_files_gear_ratio(tmp_path):
    # A drive file that overrides a URDF actuator's ratio (tiago.toml: 100 for a
    # <mechanicalReduction>1): the writer used the URDF's 1, so the written file
    # loaded again with the same drive file had an a-priori IAj of 50² times the
    # identified one (a review). The drive's ratio serves Drake and the drive.
    drive = tmp_path / "geared.toml"
    drive.write_text("[motors.joint2_motor]\ngear_ratio = 50\n")
    source = model_path("planar_2r")
    robot = RobotModel.from_urdf(source, rotor_inertia=True, drive=str(drive))
    values = _consistent_values(robot, np.random.default_rng(13))
    out = tmp_path / "geared_identified.urdf"
    write_identified_urdf(robot, values, out)
    again = RobotModel.from_urdf(out, rotor_inertia=True, drive=str(drive))
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-9, atol=1e-12)
    _check_2r_in_drake(out, robot, values, np.random.default_rng(14))


def test_the_same_drive_file_reads_the_written_rotor_inertia_back(tmp_path):
    # The TIAGo with its drive file (gear ratios 100 and 336 on motors named after
    # the URDF actuators, no rotor inertia of their own): the drive's ratio N
    # reflects the URDF actuator's drake:rotor_inertia, so the file holds
    # Ia = IAj/N² with drake:gear_ratio N. It held IAj with ratio 1, which the
    # same drive file read back as N² IAj (1e4 and 1.1e5 times the fit).
    joints = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
    drive = Path(model_path("tiago_no_hand")).parent / "tiago.toml"
    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"), joints=joints, drive=drive, rotor_inertia=True
    )
    values = _consistent_values(robot, np.random.default_rng(9))
    out = tmp_path / "t.urdf"
    export = write_identified_urdf(robot, values, out)
    assert export.skipped == ("IA7", "IA8")  # the URDF's differential wrist
    assert "drake:gear_ratio N, drake:rotor_inertia IAj/N²" in out.read_text()
    inertias = [f"IA{j}" for j in range(1, 7)]
    for kwargs in ({"drive": drive}, {}):  # with the drive file, and Drake's own
        again = RobotModel.from_urdf(out, joints=joints, rotor_inertia=True, **kwargs)
        read = dict(zip(again.standard_names, again.standard_values, strict=True))
        expected = dict(zip(robot.standard_names, values, strict=True))
        np.testing.assert_allclose(
            [read[name] for name in inertias],
            [expected[name] for name in inertias],
            rtol=1e-9,
        )


def test_the_totals_read_back_are_said_only_of_a_drive_file_with_motor_friction(
    tmp_path,
):
    # The TIAGo's drive file gives no motor friction: nothing would be added
    # again when the written file is loaded with it, and nothing says so. The
    # wrist4 drive file gives its motors' viscous and Coulomb friction: the
    # header and a note say that the file's totals are read as they are.
    joints = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
    cases = [
        (model_path("tiago_no_hand"), joints, "tiago.toml", False),
        ("tests/data/wrist4.urdf", None, "wrist4.toml", True),
    ]
    for urdf, names, drive_name, twice in cases:
        drive = Path(urdf).parent / drive_name
        robot = RobotModel.from_urdf(urdf, joints=names, drive=drive)
        values = _consistent_values(robot, np.random.default_rng(10))
        out = tmp_path / f"{drive_name}.urdf"
        write_identified_urdf(robot, values, out)
        assert ("reads them as they are" in out.read_text()) is twice
        # Without rotor inertia columns none is written, and none is described.
        assert "drake:gear_ratio N" not in out.read_text()
        again = RobotModel.from_urdf(out, joints=names, drive=drive)
        assert any("read as they are" in note for note in again.notes) is twice


def test_the_drive_header_names_rotor_inertia_only_when_written(tmp_path):
    # Without rotor inertia columns the written file's rotor inertia is 0 (not
    # identified), so it is no joint-side total of anything: the header said
    # "the joint damping, friction and rotor inertia are joint-side totals" for
    # every fit with a drive file (a review).
    for rotor_inertia in (False, True):
        robot = RobotModel.from_urdf(
            "tests/data/wrist4.urdf",
            drive="tests/data/wrist4.toml",
            rotor_inertia=rotor_inertia,
        )
        values = _consistent_values(robot, np.random.default_rng(15))
        out = tmp_path / f"w{rotor_inertia}.urdf"
        write_identified_urdf(robot, values, out)
        text = out.read_text()
        assert ("friction and rotor inertia are joint-side" in text) is rotor_inertia
        assert "joint-side totals" in text
        again = RobotModel.from_urdf(
            out, drive="tests/data/wrist4.toml", rotor_inertia=rotor_inertia
        )
        assert any("read as they are" in note for note in again.notes)


def test_a_moving_mimic_joints_rotor_inertia_is_written_as_zero(tmp_path):
    # The gripper's mimic finger fb with a drake:rotor_inertia of its own: no
    # model has a column for it (a mimic link has inertial columns only), but the
    # writer zeroed the rotor inertia of the identified joints only, so Drake's
    # inverse dynamics of the written file were W·θ plus 1.5²·0.05·v̇_fa on fa
    # (a review: 0.2 N off).
    from tests.test_any_urdf import gripper_urdf

    source = Path(gripper_urdf(tmp_path / "g.urdf"))
    text = source.read_text().replace(
        "<robot ", '<robot xmlns:drake="http://drake.mit.edu" ', 1
    )
    source.write_text(
        text.replace(
            "</robot>",
            '<transmission name="fb_t"><type>transmission_interface/'
            'SimpleTransmission</type><joint name="fb"><hardwareInterface>'
            "EffortJointInterface</hardwareInterface></joint><actuator "
            'name="fb_motor"><drake:gear_ratio value="1"/><drake:rotor_inertia '
            'value="0.05"/></actuator></transmission></robot>',
        )
    )
    for rotor_inertia in (False, True):
        robot = RobotModel.from_urdf(source, rotor_inertia=rotor_inertia)
        rng = np.random.default_rng(16)
        values = _consistent_values(robot, rng)
        out = tmp_path / f"g_{rotor_inertia}.urdf"
        write_identified_urdf(robot, values, out)
        assert "written as 0: rotor inertia of fb" in out.read_text()
        _check_gripper_in_drake(out, robot, values, rng)


def test_the_header_says_a_dead_zone_keeps_the_sign_at_reversals_off_line(tmp_path):
    """Found in review: the header gave the dead zone as 0 at every sample
    inside it, while the off-line fit and the validations restore a moving
    joint's reversals (core.standstill.reversal_signs, docs/MATH.md §2): a
    prediction made from the header's law differs at those samples."""
    from drake_dynid.core.friction import DeadZoneSign

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    robot = robot.with_sign(DeadZoneSign((0.003, 0.004)))
    out = tmp_path / "out.urdf"
    write_identified_urdf(robot, robot.standard_values, out)
    text = " ".join(out.read_text().split())
    assert "0 for |v| <= w (dead zone, w: joint1 0.003, joint2 0.004)" in text
    assert "reversal" in text and "reversal_signs" in text


def _emptied_link_7(robot):
    """The iiwa7's URDF values with link 7 as a review reported `dynid offline
    --physical` writing it on a noisy Drake log (σ_q 1e-4, τ 1 %, λ = 1e-3; not
    reproduced since: the README's simulated logs keep every link above 3 % of
    its mass, weakly excited programs empty it, tests/test_physical.py): consistent
    (12.7 mg at (1.54, -1.77, -16.3) m, the URDF's inertia about the origin), base
    parameters changed only through the regrouped M7, MZ7."""
    values = np.array(robot.standard_values, dtype=float)
    index = {name: k for k, name in enumerate(robot.standard_names)}
    mass, com = 1.27e-5, np.array([1.54, -1.77, -16.3])
    values[index["M7"]] = mass
    for axis, value in zip("XYZ", mass * com, strict=True):
        values[index[f"M{axis}7"]] = value
    # Ī about the origin: the URDF's plus the point mass's m(|c|²1 − c cᵀ).
    extra = mass * (com @ com * np.eye(3) - np.outer(com, com))
    for name, (a, b) in {
        "XX": (0, 0), "XY": (0, 1), "XZ": (0, 2), "YY": (1, 1), "YZ": (1, 2),
        "ZZ": (2, 2),
    }.items():  # fmt: skip
        values[index[f"{name}7"]] += extra[a, b]
    return values


def test_a_consistent_but_emptied_link_is_named_in_the_header_and_a_warning(
    tmp_path, capsys
):
    """Found in review: on the iiwa7 (noisy Drake log, default λ) `--urdf-out`
    wrote iiwa_link_7 with mass 1.27e-5 kg (URDF 0.3) and its centre of mass
    16.5 m from the joint (URDF 0.02), consistent and reproducing W·θ, without a
    word: the written URDF looked like a measured link. Such links are named."""
    import argparse
    from types import SimpleNamespace

    from drake_dynid.commands._model import _write_urdf
    from drake_dynid.urdf_writer import doubtful_links

    robot = RobotModel.from_urdf(model_path("iiwa7"))
    values = _emptied_link_7(robot)
    link7 = [
        values[robot.standard_names.index(f"{p}7")]
        for p in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M")
    ]
    assert np.linalg.eigvalsh(pseudo_inertia(link7))[0] > 0.0  # consistent
    assert doubtful_links(robot, robot.standard_values) == ()
    (named,) = doubtful_links(robot, values)
    assert named.startswith("iiwa_link_7: mass 1.27e-05 kg (URDF 0.3)")
    assert "16.5 m from its origin (URDF 0.02)" in named
    args = argparse.Namespace(urdf_out=str(tmp_path / "out.urdf"), quiet=True)
    theta = robot.base.values(values)
    fit = SimpleNamespace(names=robot.base.names, theta=theta, std=0.01 * abs(theta))
    entry: dict = {}
    _write_urdf(args, robot, SimpleNamespace(standard_values=values), entry, fit)
    assert entry["urdf_doubtful_links"] == ["iiwa_link_7"]
    assert "1 link(s) written with a mass outside 1 % - 10" in capsys.readouterr().err
    text = " ".join((tmp_path / "out.urdf").read_text().split())
    assert "Consistent but implausible, check before use" in text
    assert "iiwa_link_7: mass 1.27e-05 kg" in text


def test_a_link_ten_times_heavier_than_the_urdfs_is_named():
    """Found in review: with --regularization 0 nothing holds the directions
    the data do not see; on a noisy Drake log of the UR5 `--urdf-out` wrote
    shoulder_link (its mass regrouped away) at 85.7 kg for the URDF's 3.7 (the
    README's UR5 log, --regularization 0: 78.8 kg)."""
    from drake_dynid.urdf_writer import doubtful_links

    robot = RobotModel.from_urdf(model_path("ur5"))
    values = np.array(robot.standard_values, dtype=float)
    scaled = values.copy()
    for p in ("XX", "XY", "XZ", "YY", "YZ", "ZZ", "MX", "MY", "MZ", "M"):
        k = robot.standard_names.index(f"{p}1")
        scaled[k] = 23.0 * values[k]  # the same body, 23 times as dense
    (named,) = doubtful_links(robot, scaled)
    assert named.startswith("shoulder_link: mass 85.1 kg (URDF 3.7)")
    for k in range(len(values)):
        scaled[k] = values[k] * (9.0 if robot.standard_names[k].endswith("1") else 1)
    assert doubtful_links(robot, scaled) == ()  # 9 times: within the bounds


def _wrist4_fit(drive, **options):
    """The wrist4 robot with ``drive`` and rotor inertia, and consistent values."""
    robot = RobotModel.from_urdf(
        "tests/data/wrist4.urdf", drive=drive, rotor_inertia=True, **options
    )
    return robot, _consistent_values(robot, np.random.default_rng(16))


def test_the_same_drive_file_reads_the_written_totals_back_exactly(tmp_path):
    # The wrist4 fit with its drive file (motor viscous and Coulomb friction,
    # rotor inertia of m1-m3) and rotor inertia columns: the written file holds
    # the joint-side totals. Loaded with the same drive file, the motors'
    # friction was added to them again (FV1 +0.72, FC1 +0.6: 60² and 60 times
    # m1's) and their rotor inertia replaced the written one, so the a-priori
    # torques of the round trip were not the fit's (a review). Now the file's
    # totals are read as they are and a note says so.
    drive = "tests/data/wrist4.toml"
    robot, values = _wrist4_fit(drive)
    out = tmp_path / "w.urdf"
    write_identified_urdf(robot, values, out)
    again = RobotModel.from_urdf(out, drive=drive, rotor_inertia=True)
    assert again.standard_names == robot.standard_names
    np.testing.assert_allclose(again.standard_values, values, rtol=1e-12, atol=1e-15)
    rng = np.random.default_rng(17)
    q, v, vdot = (rng.normal(size=(20, 4)) for _ in range(3))
    before = robot.idim_rows(q, v, vdot, columns="standard") @ values
    after = again.idim_rows(q, v, vdot, columns="standard") @ again.standard_values
    np.testing.assert_allclose(after, before, rtol=1e-12, atol=1e-12)
    assert any("read as they are" in note for note in again.notes)


def test_the_drive_totals_are_only_the_fields_the_fit_identified(tmp_path):
    # A review: a file written with a drive file was read back as holding the
    # joint-side totals of every friction kind, so the drive file's motor
    # offset (OFFj, no URDF field) and its Coulomb friction of a fit without
    # Coulomb columns (written as 0) were dropped: OFF1 0.18 -> 0, FC1 0.6 -> 0.
    # Only the damping, friction, rotor inertia the fit identified are totals.
    drive = tmp_path / "wrist4.toml"
    text = Path("tests/data/wrist4.toml").read_text()
    drive.write_text(
        text.replace("coulomb = 0.01\n", "coulomb = 0.01\noffset = 0.003\n")
    )
    full = ("viscous", "coulomb", "offset")
    for friction in (full, ("viscous",)):
        robot, values = _wrist4_fit(drive, friction=friction)
        out = tmp_path / f"w{len(friction)}.urdf"
        write_identified_urdf(robot, values, out)
        kinds = {"viscous", "inertia"} | (
            {"coulomb"} if "coulomb" in friction else set()
        )
        again = RobotModel.from_urdf(
            out, drive=drive, rotor_inertia=True, friction=full
        )
        read = dict(zip(again.standard_names, again.standard_values, strict=True))
        fit = dict(zip(robot.standard_names, values, strict=True))
        assert read["OFF1"] == pytest.approx(60 * 0.003)  # the drive file's
        assert read["FV1"] == pytest.approx(fit["FV1"], rel=1e-12)  # the total
        if "coulomb" in friction:
            assert read["FC1"] == pytest.approx(fit["FC1"], rel=1e-12)
        else:  # written as 0 (not identified): the drive file's motor adds its own
            assert read["FC1"] == pytest.approx(60 * 0.01)
        assert drive_totals(out.read_text()) == kinds


def test_only_the_files_own_header_says_what_it_holds(tmp_path):
    # A review: the words were looked for anywhere in the file, so a file
    # identified again from a written one (whose header it keeps as a comment)
    # was read with the old file's totals and implausible links.
    drive = "tests/data/wrist4.toml"
    robot, values = _wrist4_fit(drive)
    first = tmp_path / "first.urdf"
    write_identified_urdf(
        robot,
        values,
        first,
        notes=[
            implausible_note(
                [
                    "l1: mass 0.01 kg (URDF 1), "
                    "centre of mass 9 m from its origin (URDF 0.1)"
                ]
            )
        ],
    )
    assert implausible_links(first.read_text()) == (("l1", 0.01, 9.0, 1.0, 0.1),)
    plain = RobotModel.from_urdf(first)  # no drive file, no rotor inertia
    second = tmp_path / "second.urdf"
    write_identified_urdf(plain, plain.standard_values, second)
    text = second.read_text()
    assert implausible_links(text) == ()
    assert text.count(HEADER) == 1
    assert drive_totals(text) == frozenset()
    assert drive_totals(first.read_text()) == {"viscous", "coulomb", "inertia"}
    # The words in another comment (a user's) are not the header.
    other = (
        Path("tests/data/wrist4.urdf")
        .read_text()
        .replace(
            "<link", f"<!-- the joint damping, friction {DRIVE_TOTALS} -->\n<link", 1
        )
    )
    assert drive_totals(other) == frozenset()
    # A header re-wrapped by an editor still is.
    wrapped = first.read_text().replace(
        " are joint-side totals,", "\n   are joint-side\n totals,"
    )
    assert drive_totals(wrapped) == {"viscous", "coulomb", "inertia"}


def test_a_rotor_inertia_the_file_could_not_hold_is_the_drive_files(tmp_path):
    # A review: the TIAGo's arm_6 and arm_7 joints sit in the URDF's differential
    # transmission, which has no rotor inertia field: IA7, IA8 are not written
    # (the header says so). Read back with a drive file giving arm_6_motor's
    # rotor inertia, IA7 was taken as a written total, 0, not the drive file's
    # 336² · 2e-6 = 0.2258 kg·m² it is for any URDF.
    joints = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
    drive = tmp_path / "tiago.toml"
    text = Path(model_path("tiago_no_hand")).with_name("tiago.toml").read_text()
    anchor = "[motors.arm_6_motor]"
    drive.write_text(text.replace(anchor, f"{anchor}\nrotor_inertia = 2e-6", 1))
    robot = RobotModel.from_urdf(
        model_path("tiago_no_hand"), joints=joints, drive=drive, rotor_inertia=True
    )
    values = _consistent_values(robot, np.random.default_rng(3))
    out = tmp_path / "t.urdf"
    write_identified_urdf(robot, values, out)
    again = RobotModel.from_urdf(out, joints=joints, drive=drive, rotor_inertia=True)
    read = dict(zip(again.standard_names, again.standard_values, strict=True))
    assert read["IA7"] == pytest.approx(336.0**2 * 2e-6)
    assert read["IA8"] == 0.0  # arm_7_motor gives none
    fit = dict(zip(robot.standard_names, values, strict=True))
    assert read["IA6"] == pytest.approx(fit["IA6"], rel=1e-12)  # written: the total


def test_a_placeholder_inertia_does_not_make_a_near_centre_of_mass_implausible(
    tmp_path,
):
    """Found by a review: a link whose URDF holds a placeholder inertia (1e-6
    kg·m² on 1 kg, centre of mass at its origin) has a radius of gyration of
    1.2 mm, and a fitted centre of mass 20 mm out was named implausible; the
    radius now counts at least 1 cm (a centre of mass 0.2 m out is named)."""
    from drake_dynid.urdf_writer import doubtful_links

    urdf = tmp_path / "placeholder.urdf"
    urdf.write_text(
        '<robot name="p"><link name="base"/>'
        '<link name="l1"><inertial><mass value="1"/><origin xyz="0 0 0"/>'
        '<inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/>'
        "</inertial></link>"
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/>'
        "</joint></robot>"
    )
    robot = RobotModel.from_urdf(urdf)
    names = list(robot.standard_names)
    for offset, named in ((0.02, False), (0.2, True)):
        values = np.array(robot.standard_values, dtype=float)
        values[names.index("MX1")] = offset  # m·c with m = 1 kg
        for p in ("XX", "YY", "ZZ"):  # the inertia about the origin holds m·c²
            values[names.index(f"{p}1")] += offset**2 * (p != "XX")
        assert bool(doubtful_links(robot, values)) is named, offset
