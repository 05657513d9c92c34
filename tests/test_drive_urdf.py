"""URDF transmissions -> drive chains, checked against Drake and ros_control's maps.

Truths: Drake's mass matrix and inverse dynamics with actuator rotor inertia and
gear ratio (Drake adds N² Ia to M), the actuator-to-joint maps documented in
ros_control's transmission headers, and the real TIAGo recording converted with
FIGAROH's formula.
"""

import pathlib

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import MultibodyForces

from drake_dynid.core.drive import DriveChain
from drake_dynid.core.drive_columns import MotorColumns, motor_columns
from drake_dynid.drive_urdf import load_drive, read_urdf_drive

ROOT = pathlib.Path(__file__).resolve().parents[1]
TIAGO = ROOT / "tests" / "data" / "tiago"
MODELS = ROOT / "drake_dynid" / "models"

LINKS = """
 <link name="world"/>
 <link name="l1"><inertial><mass value="1.2"/><origin xyz="0.1 0.02 0"/>
  <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial></link>
 <link name="l2"><inertial><mass value="0.8"/><origin xyz="0.15 0 0.01"/>
  <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="IZZ2"/></inertial></link>
 <joint name="j1" type="revolute"><parent link="world"/><child link="l1"/>
  <axis xyz="0 0 1"/><limit effort="1e3" lower="-9" upper="9" velocity="99"/></joint>
 <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
  <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>
  <limit effort="1e3" lower="-9" upper="9" velocity="99"/></joint>
"""


def _simple(joint, actuator, extra=""):
    return f"""
 <transmission name="t_{joint}"><type>transmission_interface/SimpleTransmission</type>
  <joint name="{joint}"><hardwareInterface>EffortJointInterface</hardwareInterface>
  </joint><actuator name="{actuator}">{extra}</actuator></transmission>"""


def _urdf(tmp_path, body, izz2=0.02, name="robot.urdf"):
    text = (
        '<?xml version="1.0"?>\n<robot name="r" xmlns:drake="http://drake.mit.edu">'
        + LINKS.replace("IZZ2", repr(izz2))
        + body
        + "</robot>"
    )
    path = tmp_path / name
    path.write_text(text)
    return path


def _plant(path):
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(str(path))
    plant.Finalize()
    return plant


def _mass_and_inverse_dynamics(plant, q, v, vdot):
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    forces = MultibodyForces(plant)
    return plant.CalcMassMatrix(context), plant.CalcInverseDynamics(
        context, vdot, forces
    )


def test_reflected_rotor_inertia_matches_drake(tmp_path):
    rotor = (
        '<drake:rotor_inertia value="0.0012"/><drake:gear_ratio value="-30"/>'
        "<mechanicalReduction>-30</mechanicalReduction>"
    )
    rotor2 = '<drake:rotor_inertia value="0.0005"/><drake:gear_ratio value="12.5"/>'
    with_rotor = _urdf(
        tmp_path, _simple("j1", "m1", rotor) + _simple("j2", "m2", rotor2)
    )
    without = _urdf(tmp_path, _simple("j1", "m1") + _simple("j2", "m2"), name="b.urdf")
    chain = load_drive(with_rotor, ("j1", "j2"))
    assert chain.notes == ()  # gear ratio and mechanicalReduction agree
    np.testing.assert_array_equal(chain.coupling, np.diag([-30.0, 12.5]))
    plants = _plant(with_rotor), _plant(without)
    # All motors as columns (simple rows too): τ_rotor = Σ_k R_kᵀ Ia_k R_k v̇.
    columns = MotorColumns(
        rows=chain.coupling,
        numbers=(1, 2),
        friction=(),
        values=[m.rotor_inertia for m in chain.motors],
    )
    rng = np.random.default_rng(4)
    for _ in range(3):
        q, v, vdot = rng.normal(size=(3, 2))
        m_with, tau_with = _mass_and_inverse_dynamics(plants[0], q, v, vdot)
        m_without, tau_without = _mass_and_inverse_dynamics(plants[1], q, v, vdot)
        np.testing.assert_allclose(
            m_with - m_without, np.diag(chain.reflected_inertia()), atol=1e-12
        )
        np.testing.assert_allclose(
            tau_with - tau_without,
            columns.idim_columns(v, vdot) @ columns.values,
            atol=1e-10,
        )
    np.testing.assert_allclose(
        chain.reflected_inertia(), [0.0012 * 900, 0.0005 * 156.25]
    )


def test_coupled_rotor_turning_with_q1_plus_q2_matches_drake(tmp_path):
    # Parallel axes: link 2's absolute angle is q1 + q2, so a rotor turning at
    # N (v1 + v2) adds N² Ia to link 2's ZZ: the coupled row R_k = N [1, 1].
    ratio, inertia = 25.0, 4e-5
    transmissions = _simple("j1", "m1") + _simple("j2", "m2")
    plain = _plant(_urdf(tmp_path, transmissions, izz2=0.02))
    rotor = _plant(_urdf(tmp_path, transmissions, 0.02 + ratio**2 * inertia, "b.urdf"))
    motors = {
        "m1": {"joint": "j1"},
        "m2": {"joints": {"j1": ratio, "j2": ratio}, "rotor_inertia": inertia},
    }
    chain = DriveChain.from_dict({"motors": motors}, ("j1", "j2"))
    columns = motor_columns(chain, friction=())
    assert columns.names == ("IAm2",)
    rng = np.random.default_rng(5)
    q, v, vdot = rng.normal(size=(3, 2))
    m_rotor, tau_rotor = _mass_and_inverse_dynamics(rotor, q, v, vdot)
    m_plain, tau_plain = _mass_and_inverse_dynamics(plain, q, v, vdot)
    np.testing.assert_allclose(
        tau_rotor - tau_plain,
        columns.idim_columns(v, vdot) @ columns.values,
        atol=1e-10,
    )
    np.testing.assert_allclose(
        m_rotor - m_plain, ratio**2 * inertia * np.ones((2, 2)), atol=1e-12
    )


def _coupled(kind, na, nj, swap=False):
    actuators = [
        f'<actuator name="a{k + 1}"><role>actuator{k + 1}</role>'
        f"<mechanicalReduction>{na[k]}</mechanicalReduction></actuator>"
        for k in range(2)
    ]
    joints = [
        f'<joint name="j{k + 1}"><role>joint{k + 1}</role>'
        f"<mechanicalReduction>{nj[k]}</mechanicalReduction>"
        "<hardwareInterface>EffortJointInterface</hardwareInterface></joint>"
        for k in range(2)
    ]
    if swap:
        actuators.reverse()
        joints.reverse()
    return (
        f'<transmission name="w"><type>transmission_interface/{kind}</type>'
        + "".join(actuators + joints)
        + "</transmission>"
    )


@pytest.mark.parametrize("swap", [False, True])
def test_differential_and_four_bar_rows_follow_ros_control(tmp_path, swap):
    na, nj = (3.0, -5.0), (2.0, 0.5)
    xa = np.array([0.7, -1.3])
    # ros_control DifferentialTransmission, actuator -> joint position.
    path = _urdf(tmp_path, _coupled("DifferentialTransmission", na, nj, swap))
    rows = read_urdf_drive(path).motors
    r = np.array(
        [
            [rows["a1"]["joints"][j] for j in ("j1", "j2")],
            [rows["a2"]["joints"][j] for j in ("j1", "j2")],
        ]
    )
    xj = np.linalg.solve(r, xa)
    s1, s2 = xa[0] / na[0], xa[1] / na[1]
    np.testing.assert_allclose(xj, [(s1 + s2) / (2 * nj[0]), (s1 - s2) / (2 * nj[1])])
    # ros_control FourBarLinkageTransmission, position map; effort τ = Rᵀ τ_a is
    # the power-consistent map of ros2_control pull request #1837.
    path = _urdf(
        tmp_path, _coupled("FourBarLinkageTransmission", na, nj, swap), name="f.urdf"
    )
    chain = load_drive(path, ("j1", "j2"))
    assert chain.motor_names == ("a1", "a2") and chain.coupled_motors == (1,)
    xj = np.linalg.solve(chain.coupling, xa)
    first = xa[0] / (nj[0] * na[0])
    np.testing.assert_allclose(xj, [first, (xa[1] / na[1] - first) / nj[1]])
    tau_a = np.array([0.4, -0.9])
    np.testing.assert_allclose(
        chain.coupling.T @ tau_a,
        [nj[0] * na[0] * tau_a[0] + na[1] * tau_a[1], nj[1] * na[1] * tau_a[1]],
    )


def test_tiago_urdf_wrist_and_real_log_with_the_shipped_drive_file():
    urdf = TIAGO / "tiago_no_hand.urdf"
    drive = read_urdf_drive(urdf)
    assert drive.prismatic_joints == ("torso_lift_joint",)
    # wrist_trans: DifferentialTransmission, n_a = (-1, 1), n_j = (1, -1).
    assert dict(drive.motors["arm_6_motor"]["joints"]) == {
        "arm_6_joint": -1.0,
        "arm_7_joint": 1.0,
    }
    assert dict(drive.motors["arm_7_motor"]["joints"]) == {
        "arm_6_joint": 1.0,
        "arm_7_joint": 1.0,
    }
    joints = ("torso_lift_joint", *(f"arm_{k}_joint" for k in range(1, 8)))
    urdf_only = load_drive(urdf, joints)
    assert urdf_only.coupled_motors == (6, 7)
    chain = load_drive(urdf, joints, MODELS / "tiago.toml")
    assert chain.coupled_motors == ()
    assert sum("gets the drive file's row" in note for note in chain.notes) == 8 - 1
    columns = {}
    for name in ("tiago_position_excerpt.csv", "tiago_effort_excerpt.csv"):
        header = (TIAGO / name).read_text().split("\n", 1)[0].split(",")
        data = np.loadtxt(TIAGO / name, delimiter=",", skiprows=1)
        columns.update({h: data[:, k] for k, h in enumerate(header)})
    out = chain.convert(columns)
    assert out.q.shape == (200, 8) and np.ptp(out.tau[:, 2]) > 10.0  # moving arm
    ratio = np.array([1, 100, 100, 100, 100, 336, 336, 336])
    constant = np.array([1, 0.136, 0.136, -0.087, -0.087, -0.0613, -0.0613, -0.0613])
    current = np.column_stack([columns[f"- {j}_effort"] for j in joints])
    np.testing.assert_allclose(out.tau, current * ratio * constant)
    np.testing.assert_array_equal(
        out.q, np.column_stack([columns[f"- {j}_position"] for j in joints])
    )


def test_urdf_warnings_and_old_formats(tmp_path):
    body = (
        _simple(
            "j1",
            "m1",
            '<drake:gear_ratio value="7"/><mechanicalReduction>5</mechanicalReduction>',
        )
        + '<transmission name="old" type="pr2_mechanism_model/SimpleTransmission">'
        '<actuator name="m2"/><joint name="j2"><offset>0.25</offset></joint>'
        "<mechanicalReduction>9</mechanicalReduction></transmission>"
        + '<transmission name="odd"><type>transmission_interface/Custom</type>'
        '<joint name="j2"/><actuator name="m9"/></transmission>'
    )
    drive = read_urdf_drive(_urdf(tmp_path, body))
    assert dict(drive.motors["m1"]["joints"]) == {"j1": 7.0}
    assert dict(drive.motors["m2"]["joints"]) == {"j2": 9.0}
    assert "m9" not in drive.motors
    assert drive.joint_offsets == {"j2": 0.25}
    text = " ".join(drive.warnings)
    assert "drake:gear_ratio 7 is used" in text and "mechanicalReduction 5" in text
    assert "joint offset 0.25 of j2 is not applied" in text
    assert "type 'transmission_interface/Custom' is not supported" in text


@pytest.mark.parametrize(
    ("body", "message"),
    [
        (_simple("j9", "m1"), "joint 'j9' is not a joint of the URDF"),
        (
            _simple("j1", "m1") + _simple("j2", "m1"),
            "actuator name 'm1' is used by two",
        ),
        (
            _simple("j1", "m1", "<mechanicalReduction>x</mechanicalReduction>"),
            "mechanicalReduction 'x' is not a number",
        ),
        (
            _simple("j1", "m1", "<mechanicalReduction>0</mechanicalReduction>"),
            "mechanicalReduction must be non-zero",
        ),
        (
            _coupled("DifferentialTransmission", (1, 1), (1, 1)).replace(
                "<mechanicalReduction>1</mechanicalReduction></actuator>",
                "</actuator>",
                1,
            ),
            "actuator a1: missing <mechanicalReduction>",
        ),
        (
            _coupled("DifferentialTransmission", (1, 1), (1, 1)).replace(
                "actuator2</role>", "actuator1</role>"
            ),
            "roles must be actuator1 and actuator2",
        ),
    ],
)
def test_bad_transmissions(tmp_path, body, message):
    with pytest.raises(ValueError, match=message):
        read_urdf_drive(_urdf(tmp_path, body))


def test_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="URDF file not found"):
        read_urdf_drive(tmp_path / "none.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot>")
    with pytest.raises(ValueError, match="is not well-formed XML"):
        read_urdf_drive(bad)
    path = _urdf(tmp_path, _simple("j1", "m1"))
    with pytest.raises(ValueError, match=r"load_drive: joint\(s\) j7 are not joints"):
        load_drive(path, ("j1", "j7"))


def test_drake_tags_without_their_namespace_declaration_are_read(tmp_path):
    """A review: a URDF using drake:rotor_inertia without declaring xmlns:drake
    (Drake's parser reads it) was refused by ElementTree ('unbound prefix')."""
    from pathlib import Path

    from drake_dynid.plants import RobotModel, model_path

    text = Path(model_path("planar_2r")).read_text()
    assert "xmlns:drake" not in text
    text = text.replace(
        "<mechanicalReduction>1</mechanicalReduction>",
        "<mechanicalReduction>1</mechanicalReduction>"
        '<drake:rotor_inertia value="0.05"/>',
    )
    urdf = tmp_path / "undeclared.urdf"
    urdf.write_text(text)
    robot = RobotModel.from_urdf(urdf, rotor_inertia=True)
    values = dict(zip(robot.standard_names, robot.standard_values, strict=True))
    assert values["IA1"] == pytest.approx(0.05) and values["IA2"] == pytest.approx(0.05)
    # And --urdf-out writes it with the declaration, read back the same.
    from drake_dynid.urdf_writer import write_identified_urdf

    out = tmp_path / "written.urdf"
    write_identified_urdf(robot, robot.standard_values, out)
    assert 'xmlns:drake="http://drake.mit.edu"' in out.read_text()
    again = RobotModel.from_urdf(out, rotor_inertia=True)
    assert again.standard_values == pytest.approx(robot.standard_values)


def test_undeclared_drake_tags_with_a_comment_naming_robot_first(tmp_path):
    """The declaration goes into the <robot> tag, not into a '<robot' of a
    comment before it (the file was refused: 'unbound prefix')."""
    from drake_dynid.drive_urdf import DRAKE_NAMESPACE, parse_urdf_xml

    urdf = tmp_path / "commented.urdf"
    urdf.write_text(
        '<?xml version="1.0"?>\n<!-- written from <robot name="x"> by hand -->\n'
        '<robot name="r">\n<link name="a"><drake:x value="1"/></link></robot>\n'
    )
    root = parse_urdf_xml(urdf)
    assert root.tag == "robot" and root.attrib == {"name": "r"}
    assert root.find(f"link/{{{DRAKE_NAMESPACE}}}x") is not None
