"""Any fixed-base description loads: no transmissions, missing meshes, parser noise,
continuous joints, mimic joints, chosen and locked joints (seeds stated per test)."""

import logging
import re
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
from pydrake.systems.framework import DiagramBuilder

from drake_dynid.robot import RobotModel
from drake_dynid.urdf import (
    _strip_geometry,
    load_plant,
    load_urdf,
    model_path,
    read_urdf_mimic,
)

TIAGO_ARM = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))


def _inertial(mass=1.0, x=0.1):
    return (
        f'<inertial><origin xyz="{x} 0.02 0.03"/><mass value="{mass}"/>'
        '<inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/>'
        "</inertial>"
    )


MESH = (
    '<visual><geometry><mesh filename="package://nowhere/meshes/{0}.stl"/>'
    "</geometry></visual><collision><geometry>"
    '<mesh filename="meshes/{0}_collision.dae"/></geometry></collision>'
)


def gripper_urdf(path):
    """No world link, no <transmission>, package:// meshes that do not exist, a
    continuous joint, a prismatic finger with a mimic, an unsupported tag."""
    links = "".join(
        f'<link name="{name}">{_inertial(x=0.1 * k)}{MESH.format(name)}</link>'
        for k, name in enumerate(("base", "l1", "l2", "fa", "fb"))
    )
    joints = (
        '<joint name="j1" type="continuous"><parent link="base"/><child link="l1"/>'
        '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/></joint>'
        '<joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>'
        '<origin xyz="0.2 0 0" rpy="1.5707963267949 0 0"/><axis xyz="0 0 1"/>'
        '<limit lower="-2" upper="2" effort="10" velocity="1"/>'
        '<safety_controller k_velocity="1"/></joint>'
        '<joint name="fa" type="prismatic"><parent link="l2"/><child link="fa"/>'
        '<origin xyz="0.3 0 0"/><axis xyz="0 1 0"/>'
        '<limit lower="0" upper="0.04" effort="10" velocity="1"/>'
        '<dynamics damping="0.3" friction="0.1"/></joint>'
        '<joint name="fb" type="prismatic"><parent link="l2"/><child link="fb"/>'
        '<origin xyz="0.3 0 0"/><axis xyz="0 -1 0"/>'
        '<limit lower="0" upper="0.04" effort="10" velocity="1"/>'
        '<mimic joint="fa" multiplier="1.5" offset="0.01"/>'
        '<dynamics damping="0.2" friction="0.05"/></joint>'
    )
    path.write_text(
        f'<?xml version="1.0"?><robot name="gripper"><!-- <visual> -->{links}{joints}'
        "</robot>"
    )
    return path


@pytest.fixture(scope="module")
def gripper(tmp_path_factory):
    return gripper_urdf(tmp_path_factory.mktemp("gripper") / "gripper.urdf")


def test_description_without_transmissions_or_meshes_loads(gripper, caplog):
    # Drake alone fails on the missing package:// meshes.
    builder = DiagramBuilder()
    with pytest.raises(RuntimeError, match="unknown package 'nowhere'"):
        Parser(AddMultibodyPlantSceneGraph(builder, 0.0)[0]).AddModels(str(gripper))
    assert load_plant(gripper, builder=DiagramBuilder()).num_positions() == 4
    with pytest.raises(ValueError, match="unknown package 'nowhere'"):
        load_plant(gripper, builder=DiagramBuilder(), geometry=True)
    with caplog.at_level(logging.INFO, logger="drake_dynid"):
        plant = load_plant(gripper)
    # Every movable joint but the mimic one is actuated, without effort limit.
    actuated = sorted(
        plant.get_joint_actuator(i).joint().name()
        for i in plant.GetJointActuatorIndices()
    )
    assert actuated == ["fa", "j1", "j2"]
    assert plant.GetJointByName("j1").type_name() == "revolute"  # continuous
    notes = [r.getMessage() for r in caplog.records if r.name == "drake_dynid"]
    assert len(notes) == 2
    assert "3 joints without a (simple) <transmission> treated as actuated" in notes[0]
    assert "1 ignored <safety_controller>" in notes[1]
    assert not [r for r in caplog.records if r.name == "drake"]  # no flood


def test_mimic_is_read_and_followed(gripper):
    assert read_urdf_mimic(gripper) == {"fb": ("fa", 1.5, 0.01)}
    model = RobotModel.from_urdf(gripper)
    assert model.joint_names == ("j1", "j2", "fa") and model.links[-1] == "fb"
    assert dict(model.mimic) == {"fb": ("fa", 1.5, 0.01)}
    assert "XX4" in model.standard_names and "FV4" not in model.standard_names
    values = model.standard_parameters()
    # The mimic's friction acts on its leader: FV += a² FV_fb, FC += |a| FC_fb.
    assert values["FV3"] == pytest.approx(0.3 + 1.5**2 * 0.2)
    assert values["FC3"] == pytest.approx(0.1 + 1.5 * 0.05)
    q = np.array([0.1, 0.2, 0.03])
    np.testing.assert_allclose(model.plant_positions(q), [0.1, 0.2, 0.03, 0.055])
    np.testing.assert_allclose(model.plant_velocities(q), [0.1, 0.2, 0.03, 0.045])
    # Numpy and Drake kinematics agree with the mimic link (seed 4).
    drake = RobotModel.from_urdf(gripper, kinematics="drake")
    rng = np.random.default_rng(4)
    q, v, vdot = rng.normal(size=(3, 3, 3))
    np.testing.assert_allclose(
        model.idim_rows(q, v, vdot), drake.idim_rows(q, v, vdot), atol=1e-12
    )
    for a, b in zip(
        model.lagrangian_rows(q, v), drake.lagrangian_rows(q, v), strict=True
    ):
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_power_and_lagrangian_identities_hold_with_locked_and_mimic(gripper):
    """vᵀW = d/dt h + friction power and W = d/dt(∂h_E/∂v) + G with a locked
    joint and a mimic link (fourth-order differences, seed-free trajectory)."""
    model = RobotModel.from_urdf(gripper, joints=["j2", "fa"], locked={"j1": 0.4})
    t = np.linspace(0.0, 2.0, 4)

    def trajectory(s):
        arg = np.stack([1.3 * (t + s), 0.7 * (t + s) + 1.0], 1)
        amp = np.array([1.0, 0.02])
        return (
            amp * np.sin(arg),
            amp * np.cos(arg) * [1.3, 0.7],
            -amp * np.sin(arg) * [1.3**2, 0.7**2],
        )

    def derivative(f, h=1e-3):
        return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)

    q, v, vdot = trajectory(0.0)
    w = model.idim_rows(q, v, vdot)
    friction = model.model_rows("power", q, v, v)[1][:, 0]
    ddt_h = derivative(lambda s: model.energy_rows(*trajectory(s)[:2]))
    np.testing.assert_allclose(
        model.power_rows(q, v, vdot), ddt_h + friction, atol=1e-8
    )
    d_dot = derivative(lambda s: model.model_rows("lagrangian", *trajectory(s))[0])
    g = model.model_rows("lagrangian", q, v, v)[1]
    np.testing.assert_allclose(d_dot + g, w, atol=1e-8)


def test_tiago_arm_with_wheels_and_head_locked():
    model = RobotModel.from_urdf(
        model_path("tiago_no_hand"),
        joints=list(reversed(TIAGO_ARM)),
        locked={"head_2_joint": -0.2},
    )
    assert model.joint_names == TIAGO_ARM  # the plant's order
    assert dict(model.locked) == {
        "wheel_right_joint": 0.0,
        "wheel_left_joint": 0.0,
        "head_1_joint": 0.0,
        "head_2_joint": -0.2,
    }
    assert len(model.standard_names) == 8 * 10 + 8 * 2
    assert model.num_parameters == 44 + 16  # independent ranks: test_real_robots
    assert model.base.clear
    # Actuated arm_6/arm_7; one parser summary; the links Drake's parser gave
    # another inertia (issue 14: named, with the file's and Drake's values).
    assert len(model.notes) == 3
    assert "arm_6_joint, arm_7_joint" in model.notes[0]
    assert re.search(
        r"Drake's parser: 15 warnings .*3 non-physical inertia", model.notes[1]
    )
    assert re.search(
        r"non-physical <inertial> .*'base_antenna_left_link'.*'base_antenna_right_"
        r"link'.*'arm_1_link': principal moments 0.00191, 0.00846, 0.01059 kg·m² "
        r"break the triangle inequality; Drake holds mass 2.083 kg",
        model.notes[2],
    )
    # The provenance comment of the shipped copy.
    head = Path(model_path("tiago_no_hand")).read_text()[:600]
    assert "github.com/thanhndv212/figaroh-examples" in head and "c0b5c7f" in head


def test_joint_choice_errors_name_the_joints():
    path = model_path("tiago_no_hand")
    with pytest.raises(ValueError, match=r"'arm_8_joint' is not a movable.*arm_7"):
        RobotModel.from_urdf(path, joints=[*TIAGO_ARM, "arm_8_joint"])
    with pytest.raises(ValueError, match="'arm_1_joint' is both identified and locked"):
        RobotModel.from_urdf(path, joints=TIAGO_ARM, locked={"arm_1_joint": 0.0})
    with pytest.raises(ValueError, match=r"locked joint 'head' is not.*head_1_joint"):
        RobotModel.from_urdf(path, locked={"head": 0.0})


def test_strip_geometry_keeps_the_rest_and_absolute_paths():
    text = (
        '<robot xmlns:drake="http://drake.mit.edu"><!-- <collision> --><link name="a">'
        '<visual><geometry><mesh filename="m.stl"/></geometry></visual>'
        '<collision name="c"/><drake:thing filename="data/x.obj"/>'
        '<other filename="package://p/y.obj"/></link></robot>'
    )
    out = _strip_geometry(text, Path("/robots/r"))
    assert "visual" not in out and "collision" not in out
    assert '<drake:thing filename="file:///robots/r/data/x.obj"/>' in out
    assert 'filename="package://p/y.obj"' in out


def test_floating_base_is_refused_and_a_mobile_base_is_welded(gripper):
    with pytest.raises(ValueError, match="floating base"):
        load_urdf(gripper, weld_root=False)
    plant = load_urdf(model_path("tiago_no_hand")).plant
    assert plant.num_positions() == 12  # base_footprint welded: no floating joint


def test_simulated_setup_refuses_a_model_with_locked_joints(gripper):
    from drake_dynid.core.online import OnlineSettings
    from drake_dynid.core.trajectory import random_fourier_trajectory
    from drake_dynid.simulation import SimulationSettings, simulate_identification

    model = RobotModel.from_urdf(gripper, joints=["j2", "fa"], locked={"j1": 0.4})
    trajectory = random_fourier_trajectory(
        2,
        harmonics=2,
        base_frequency=1.0,
        max_velocity=1.0,
        max_position=1.0,
        rng=np.random.default_rng(0),
    )
    with pytest.raises(ValueError, match="locked or mimic joints"):
        simulate_identification(
            model, trajectory, SimulationSettings(duration=1.0), [OnlineSettings()]
        )


def test_a_joint_actuated_for_want_of_a_transmission_keeps_its_urdf_effort():
    """Found by a review: <limit effort="50"> was ignored for joints without a
    <transmission> (no effort limit; excite then asked for a limits file)."""
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(model_path("tiago_no_hand"))
    plant = robot.plant
    limits = {
        plant.get_joint_actuator(i).joint().name(): plant.get_joint_actuator(
            i
        ).effort_limit()
        for i in plant.GetJointActuatorIndices()
    }
    assert limits["arm_6_joint"] == 6.6 and limits["arm_7_joint"] == 6.6


def test_a_fixed_joint_with_mimic_and_an_orphan_transmission_load(tmp_path):
    # Drake refuses both (the Talos arms of example-robot-data): the <mimic> of
    # a fixed joint means nothing, and a <transmission> of a joint the file does
    # not have is ignored, with a note; a missing joint is not "a missing file".
    links = "".join(
        f'<link name="{name}">{_inertial()}</link>' for name in ("base", "l1", "l2")
    )
    joints = (
        '<joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>'
        '<axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="10" velocity="1"/>'
        "</joint>"
        '<joint name="tip" type="fixed"><parent link="l1"/><child link="l2"/>'
        '<origin xyz="0.2 0 0"/><mimic joint="j1" multiplier="-1"/></joint>'
    )
    transmission = (
        '<transmission name="{0}_trans"><type>transmission_interface/'
        'SimpleTransmission</type><joint name="{0}"><hardwareInterface>'
        "EffortJointInterface</hardwareInterface></joint><actuator "
        'name="{0}_motor"/></transmission>'
    )
    path = tmp_path / "arm.urdf"
    path.write_text(
        f'<robot name="arm">{links}{joints}{transmission.format("j1")}'
        f"{transmission.format('torso_joint')}</robot>"
    )
    loaded = load_urdf(path)
    assert loaded.plant.num_velocities() == 1
    assert any(
        "ignored: torso_joint_trans (torso_joint)" in note for note in loaded.notes
    )
    assert read_urdf_mimic(path) == {}
    assert RobotModel.from_urdf(path).joint_names == ("j1",)
    # Drake's own message for a joint that is missing elsewhere gets its own hint.
    bad = tmp_path / "bad.urdf"
    bad.write_text(path.read_text().replace('<child link="l2"/>', '<child link="x"/>'))
    with pytest.raises(ValueError) as error:
        load_urdf(bad)
    assert "a file it names is missing" not in str(error.value)


def test_package_uris_resolve_through_ros_package_path(tmp_path, monkeypatch):
    # A ROS workspace's package://: found through ROS_PACKAGE_PATH, as ROS tools do
    # (a review: excite's self-collision check could not load a package mesh).
    package = tmp_path / "ws" / "my_robot"
    (package / "meshes").mkdir(parents=True)
    (package / "package.xml").write_text(
        '<?xml version="1.0"?><package format="2"><name>my_robot</name>'
        "<version>0.0.0</version><description>d</description>"
        '<maintainer email="a@b.c">a</maintainer><license>BSD</license></package>'
    )
    (package / "meshes" / "box.obj").write_text(
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    mesh = (
        '<collision><geometry><mesh filename="package://my_robot/meshes/box.obj"/>'
        "</geometry></collision>"
    )
    urdf = tmp_path / "r.urdf"
    urdf.write_text(
        f'<robot name="r"><link name="base"/><link name="l1">{_inertial()}{mesh}'
        '</link><joint name="j1" type="revolute"><parent link="base"/>'
        '<child link="l1"/><axis xyz="0 0 1"/></joint></robot>'
    )
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    with pytest.raises(ValueError, match="unknown package 'my_robot'"):
        load_plant(urdf, builder=DiagramBuilder(), geometry="collision")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ws"))
    plant = load_plant(urdf, builder=DiagramBuilder(), geometry="collision")
    assert plant.num_velocities() == 1


def _one_collision_mesh(folder, mesh_name, mesh_bytes):
    """The 2R with a collision mesh on link1 at ``meshes/<mesh_name>``."""
    text = Path(model_path("planar_2r")).read_text()
    at = text.index("</inertial>", text.index('<link name="link1"')) + 11
    collision = (
        f'<collision><geometry><mesh filename="meshes/{mesh_name}"/></geometry>'
        "</collision>"
    )
    (folder / "meshes").mkdir(exist_ok=True)
    (folder / "meshes" / mesh_name).write_bytes(mesh_bytes)
    path = folder / f"r_{mesh_name}.urdf"
    path.write_text(text[:at] + collision + text[at:])
    return path


_TETRAHEDRON = np.array(
    [[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 0, 0], [1, 0, 0], [0, 0, 1]],
     [[0, 0, 0], [0, 1, 0], [0, 0, 1]], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]],
    dtype=float,
) * 0.1  # fmt: skip


def _binary_stl(triangles):
    record = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    data = np.zeros(len(triangles), record)
    data["v"] = triangles
    return b"\0" * 80 + len(triangles).to_bytes(4, "little") + data.tobytes()


def _ascii_stl(triangles):
    lines = ["solid t"]
    for triangle in triangles:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += [f"vertex {x:.17g} {y:.17g} {z:.17g}" for x, y, z in triangle]
        lines += ["endloop", "endfacet"]
    return ("\n".join([*lines, "endsolid t"]) + "\n").encode()


@pytest.mark.parametrize("kind", ["obj", "binary.stl", "ascii.stl"])
def test_relative_and_stl_collision_meshes_load_for_the_collision_check(tmp_path, kind):
    """A review: any relative collision mesh made the self-collision check fail
    (Drake refuses a bare absolute path in a string: now a file:// URI), and STL
    collision meshes (the Panda's, the UR's) too (Drake hulls .obj, .vtk and .gltf
    only: each STL is now read and written as an OBJ in a temporary folder)."""
    from drake_dynid.collision import SelfCollision

    if kind == "obj":
        lines = [
            f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in _TETRAHEDRON.reshape(-1, 3)
        ]
        lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(4)]
        data = ("\n".join(lines) + "\n").encode()
    else:
        data = (_binary_stl if kind.startswith("binary") else _ascii_stl)(_TETRAHEDRON)
        np.testing.assert_allclose(read_stl_bytes(tmp_path, data), _TETRAHEDRON)
    folder = tmp_path / "a folder"  # a space in the path
    folder.mkdir()
    path = _one_collision_mesh(folder, f"m.{kind}", data)
    robot = RobotModel.from_urdf(path)
    check = SelfCollision.from_urdf(path, np.zeros(2), robot)
    assert check is not None and check.num_geometries == 1


def read_stl_bytes(folder, data):
    from drake_dynid.urdf_meshes import read_stl

    path = folder / "probe.stl"
    path.write_bytes(data)
    return read_stl(path)


def test_a_bad_stl_collision_mesh_is_named(tmp_path):
    from drake_dynid.collision import SelfCollision
    from drake_dynid.urdf import MissingFileError

    path = _one_collision_mesh(tmp_path, "bad.stl", b"solid x\nnot a mesh\n")
    robot = RobotModel.from_urdf(path)  # identification needs no geometry
    with pytest.raises(MissingFileError, match=r"bad\.stl: no triangles read"):
        SelfCollision.from_urdf(path, np.zeros(2), robot)


def test_a_package_named_like_an_ancestor_folder_resolves(tmp_path):
    """example-robot-data's URIs say package://example-robot-data/..., its
    package.xml another name: the URDF's ancestor folder of that name is used."""
    from drake_dynid.collision import SelfCollision

    root = tmp_path / "my-robot-pkg" / "robots"
    root.mkdir(parents=True)
    path = _one_collision_mesh(root, "m.stl", _binary_stl(_TETRAHEDRON))
    text = path.read_text().replace(
        'filename="meshes/', 'filename="package://my-robot-pkg/robots/meshes/'
    )
    path.write_text(text)
    robot = RobotModel.from_urdf(path)
    check = SelfCollision.from_urdf(path, np.zeros(2), robot)
    assert check is not None and check.num_geometries == 1


def test_a_collision_mesh_drake_cannot_hull_skips_the_check_with_its_reason(
    tmp_path,
):
    """A .dae collision mesh (the Kinova's): excite skips its self-collision check
    with the reason (MissingFileError) instead of refusing the whole run."""
    from drake_dynid.collision import SelfCollision
    from drake_dynid.urdf import MissingFileError

    path = _one_collision_mesh(tmp_path, "m.dae", b"<COLLADA/>")
    robot = RobotModel.from_urdf(path)
    with pytest.raises(MissingFileError, match=r"unsupported extension '\.dae'") as e:
        SelfCollision.from_urdf(path, np.zeros(2), robot)
    assert ".obj, .vtk, .gltf or .stl" in str(e.value)


def test_an_stl_collision_mesh_under_a_non_ascii_folder_loads(tmp_path):
    """A review: the OBJ copy of an STL was written as ASCII with the STL's path in
    its header comment, so a robot under a folder such as 'Téléchargements'
    failed the collision check ('ascii' codec can't encode character)."""
    from drake_dynid.collision import SelfCollision

    folder = tmp_path / "Téléchargements"
    folder.mkdir()
    path = _one_collision_mesh(folder, "bøx.stl", _binary_stl(_TETRAHEDRON))
    robot = RobotModel.from_urdf(path)
    check = SelfCollision.from_urdf(path, np.zeros(2), robot)
    assert check is not None and check.num_geometries == 1


@pytest.mark.parametrize("kind", ["obj", "binary.stl"])
def test_an_absolute_collision_mesh_path_loads(tmp_path, kind):
    """A review: Drake refuses a bare absolute path in a string; relative paths
    became file:// URIs, absolute ones were left bare, so the self-collision check
    of a URDF naming /abs/path/mesh.obj failed with 'invalid when parsing a
    string' (a ValueError: dynid excite refused the run)."""
    from drake_dynid.collision import SelfCollision

    path = _one_collision_mesh(tmp_path, f"m.{kind}", _mesh_bytes(kind))
    mesh = (tmp_path / "meshes" / f"m.{kind}").resolve().as_posix()
    text = path.read_text().replace(f'filename="meshes/m.{kind}"', f'filename="{mesh}"')
    assert mesh in text
    path.write_text(text)
    robot = RobotModel.from_urdf(path)
    check = SelfCollision.from_urdf(path, np.zeros(2), robot)
    assert check is not None and check.num_geometries == 1
    # The Meshcat replay's load (every geometry kept) too.
    plant = load_plant(path, builder=DiagramBuilder(), geometry=True)
    assert plant.num_velocities() == 2


def _mesh_bytes(kind):
    if kind == "obj":
        lines = [
            f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in _TETRAHEDRON.reshape(-1, 3)
        ]
        lines += [f"f {3 * k + 1} {3 * k + 2} {3 * k + 3}" for k in range(4)]
        return ("\n".join(lines) + "\n").encode()
    return _binary_stl(_TETRAHEDRON)


def test_a_binary_stl_with_trailing_padding_is_read(tmp_path):
    """A review: a binary STL with a few bytes after its records (some exporters
    pad) fell to the ASCII reader and was refused."""
    from drake_dynid.urdf_meshes import read_stl

    path = tmp_path / "padded.stl"
    path.write_bytes(_binary_stl(_TETRAHEDRON) + b"\0\0\0\0")
    np.testing.assert_allclose(read_stl(path), _TETRAHEDRON, rtol=1e-7)


def test_an_stl_visual_mesh_is_shown_by_meshcat(tmp_path):
    """Found by a review (the example-robot-data xArm7, STL visuals): Drake's
    Meshcat shows .obj, .gltf and .dae meshes only, so `dynid replay` and
    `simulate --meshcat` of the xArm7 drew an empty scene (Drake: "will not be
    visualized"), with no note and no inertia ellipsoids. The STL visual meshes
    are loaded through their OBJ copy, as the collision ones, with their scale."""
    from pydrake.geometry import Role

    path = _one_collision_mesh(tmp_path, "m.stl", _binary_stl(_TETRAHEDRON))
    text = path.read_text().replace(
        "<collision><geometry>",
        '<visual><geometry><mesh filename="meshes/m.stl" '
        'scale="0.001 0.001 0.001"/></geometry></visual><collision><geometry>',
    )
    path.write_text(text)
    builder = DiagramBuilder()
    plant = load_plant(path, builder=builder, geometry=True)
    scene_graph = next(s for s in builder.GetSystems() if s.get_name() == "scene_graph")
    inspector = scene_graph.model_inspector()
    link1 = plant.GetBodyByName("link1")
    for role, scale in ((Role.kIllustration, 0.001), (Role.kProximity, 1.0)):
        (geometry,) = [
            g
            for g in inspector.GetGeometries(plant.GetBodyFrameIdOrThrow(link1.index()))
            if inspector.GetProperties(g, role) is not None
        ]
        shape = inspector.GetShape(geometry)
        assert shape.extension() == ".obj", role
        assert shape.scale3()[0] == pytest.approx(scale)


def test_the_collision_check_skips_the_pairs_no_identified_joint_moves():
    """Found by the example-robot-data sweep: `dynid excite` of the Talos' left arm
    (talos_reduced.urdf, the rest locked) took 1072 s CPU with --iterations 30:
    each configuration computed 1167 pairs (5.3 ms), most of them between the
    locked legs, torso, head and right arm, whose distances never change (and
    one such pair closer than the margin would have made every design
    infeasible). Those pairs are filtered now: only pairs with a left-arm link
    (659 pairs, 2.4 ms)."""
    from test_real_robots import example_robot

    from drake_dynid.collision import SelfCollision

    path = example_robot("talos_data/robots/talos_reduced.urdf")
    arm = [f"arm_left_{i}_joint" for i in range(1, 8)]
    robot = RobotModel.from_urdf(path, joints=arm)
    check = SelfCollision.from_urdf(path, np.zeros(7), robot)
    q = np.random.default_rng(5).uniform(-1.0, 1.0, 7)
    pairs = check._pairs(q)
    names = [check._describe(p.id_A, p.id_B).split("-") for p in pairs]
    assert names and all(
        any(b.startswith(("arm_left", "gripper_left", "wrist_left")) for b in pair)
        for pair in names
    )
    assert len(pairs) < 700  # 1167 before
    assert np.isfinite(check(q)).all()


def test_a_pair_closer_than_the_margin_at_mid_range_is_held_there():
    """Found by the example-robot-data sweep: at mid-range the SO-101's jaw is
    9.4 mm from its wrist and finger_edu's middle link 2.8 mm from its base
    (Talos' gripper links 0.7 mm, the G1's elbow and wrist 9.5 mm): below the
    0.01 m margin, so no design could start, and `dynid excite` refused naming
    an unrelated constraint of the last iterate ("joint gripper: position
    -2.979 rad ... exceeds the limit -0.07453 rad", after 111 s). Such a pair
    is now held no closer than half its mid-range distance (finger_edu here:
    the SO-101's STL meshes take 15 s to hull)."""
    from test_real_robots import example_robot

    from drake_dynid.collision import SelfCollision
    from drake_dynid.limits import joint_limits

    path = example_robot("finger_edu_description/robots/finger_edu.urdf")
    pair = "finger_base_link-finger_middle_link"
    robot = RobotModel.from_urdf(path)
    limits = joint_limits(robot)
    mid = 0.5 * (limits.lower + limits.upper)
    plain = SelfCollision.from_urdf(path, mid, robot)
    assert plain.closest(mid)[0] < 0.01 and pair in plain.closest(mid)[1]
    check = SelfCollision.from_urdf(path, mid, robot, margin=0.01)
    assert check(mid)[0] > 0.01  # room to move about mid-range
    assert any(pair in held for held in check.held)
    # Elsewhere that pair counts by its distance less half the mid-range one,
    # plus 0.01.
    q = mid + np.random.default_rng(2).uniform(-0.3, 0.3, mid.size)
    assert check(q)[0] <= plain(q)[0] + 0.01 - plain.closest(mid)[0] / 2 + 1e-12
