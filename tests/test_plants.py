"""URDF plants, standard/base parameters and the Drake-based regressors.

Every identity is checked on seeded random states (numpy default_rng seeds are
given in each test) against Drake's own answers (CalcKineticEnergy,
CalcPotentialEnergy, CalcInverseDynamics) or by fourth-order finite differences,
to 1e-9.
"""

import re
from pathlib import Path

import numpy as np
import pytest
from pydrake.multibody.tree import JointActuatorIndex, MultibodyForces

from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.plants import RobotModel, load_plant, model_path, read_urdf_friction

# ---------------------------------------------------------------- test robots


def _inertial(rng):
    x, y, z = rng.uniform(0.01, 0.2, 3)  # principal moments y+z, x+z, x+y: valid
    c = rng.uniform(-0.2, 0.2, 3)
    r = rng.uniform(-1.0, 1.0, 3)
    return (
        f'<inertial><origin xyz="{c[0]} {c[1]} {c[2]}" rpy="{r[0]} {r[1]} {r[2]}"/>'
        f'<mass value="{rng.uniform(0.5, 3.0)}"/><inertia ixx="{y + z}" ixy="0" '
        f'ixz="0" iyy="{x + z}" iyz="0" izz="{x + y}"/></inertial>'
    )


def _joint(rng, name, kind, parent, child):
    xyz = rng.uniform(-0.5, 0.5, 3)
    rpy = rng.uniform(-1.0, 1.0, 3)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    limit = '<limit lower="-2" upper="2" effort="1000" velocity="10"/>'
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
        f'<child link="{child}"/><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" '
        f'rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/><axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>'
        f"{limit if kind != 'fixed' else ''}"
        f'<dynamics damping="{rng.uniform(0.1, 1)}" friction="{rng.uniform(0.1, 1)}"/>'
        "</joint>"
    )


def _transmission(name):
    return (
        f'<transmission name="{name}_t"><type>transmission_interface/'
        f'SimpleTransmission</type><joint name="{name}"/><actuator name="{name}_m">'
        "<mechanicalReduction>1</mechanicalReduction></actuator></transmission>"
    )


def random_tree_urdf(path, seed=5):
    """A tree with a branch: revolute, prismatic and fixed joints, random geometry,
    random full inertias (products of inertia included), a body welded to a link."""
    rng = np.random.default_rng(seed)
    links = ["base", "l1", "l2", "l3", "l4", "tool"]
    joints = [
        ("j1", "revolute", "base", "l1"),
        ("j2", "prismatic", "l1", "l2"),
        ("j3", "revolute", "l2", "l3"),
        ("j4", "revolute", "l1", "l4"),  # the branch
        ("tool_weld", "fixed", "l3", "tool"),
    ]
    body = "".join(f'<link name="{name}">{_inertial(rng)}</link>' for name in links)
    body += "".join(_joint(rng, *j) for j in joints)
    body += "".join(_transmission(j[0]) for j in joints if j[1] != "fixed")
    path.write_text(
        f'<robot name="tree"><link name="world"/>{body}'
        '<joint name="w" type="fixed"><parent link="world"/>'
        '<child link="base"/></joint></robot>'
    )
    return str(path)


@pytest.fixture(scope="module")
def tree_path(tmp_path_factory):
    return random_tree_urdf(tmp_path_factory.mktemp("tree") / "tree.urdf")


@pytest.fixture(scope="module")
def models(tree_path):
    return {
        "planar_2r": RobotModel.from_urdf(model_path("planar_2r")),
        "ur5": RobotModel.from_urdf(
            model_path("ur5"), friction="viscous,coulomb,offset"
        ),
        "tree": RobotModel.from_urdf(tree_path),
    }


def _states(model, seed, num=6):
    rng = np.random.default_rng(seed)
    n = model.num_joints
    q = rng.uniform(-2.0, 2.0, (num, n))
    return q, rng.normal(size=(num, n)), rng.normal(size=(num, n))


def _drake(model, q, v, vdot):
    """Energy and inverse dynamics (+ Coulomb and offset friction) from Drake."""
    plant = model.plant
    context = plant.CreateDefaultContext()
    values = model.standard_parameters()
    n = model.num_joints
    fc = np.array([values.get(f"FC{j + 1}", 0.0) for j in range(n)])
    off = np.array([values.get(f"OFF{j + 1}", 0.0) for j in range(n)])
    energy, tau = [], []
    for k in range(len(q)):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        energy.append(
            plant.CalcKineticEnergy(context) + plant.CalcPotentialEnergy(context)
        )
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)  # gravity and damping
        tau.append(
            plant.CalcInverseDynamics(context, vdot[k], forces)
            + fc * np.sign(v[k])
            + off
        )
    return np.array(energy), np.array(tau)


def _derivative(f, step=1e-3):
    return (-f(2 * step) + 8 * f(step) - 8 * f(-step) + f(-2 * step)) / (12 * step)


def _trajectory(n, t):
    """Smooth joint trajectory with exact v, vdot (seeded by n)."""
    rng = np.random.default_rng(100 + n)
    a, w, phase = rng.uniform(0.3, 1.0, (3, n))
    w = 1.0 + 2.0 * w
    arg = w * t[:, None] + phase
    return a * np.sin(arg), a * w * np.cos(arg), -a * w**2 * np.sin(arg)


# ---------------------------------------------------------------- loading


def test_model_path_and_loader():
    path = model_path("planar_2r")
    assert path.endswith("planar_2r.urdf")
    discrete = load_plant(path, 1e-3)
    continuous = load_plant(path)
    assert discrete.is_finalized() and discrete.time_step() == 1e-3
    assert continuous.time_step() == 0.0 and continuous.num_actuators() == 2
    with pytest.raises(ValueError, match=r"packaged models .*planar_2r.*ur5"):
        model_path("puma")
    assert read_urdf_friction(path) == {"joint1": 0.4, "joint2": 0.25}


@pytest.mark.parametrize("command", ["params", "simulate"])
def test_a_negative_urdf_friction_is_named(tmp_path, capsys, command):
    """Found by a review: params showed FC2 = -0.25 as the a-priori value, and
    simulate failed with "SimulatedDrive: viscous and coulomb must be >= 0"."""
    from drake_dynid import cli

    urdf = tmp_path / "r.urdf"
    text = Path(model_path("planar_2r")).read_text()
    urdf.write_text(text.replace('friction="0.25"', 'friction="-0.25"'))
    t = np.linspace(0.0, 2.0, 201)
    rows = [f"{x},{np.sin(x)},0,{np.cos(x)},0" for x in t]
    header = "t,q_joint1,q_joint2,v_joint1,v_joint2"
    (tmp_path / "trajectory.csv").write_text("\n".join([header, *rows]) + "\n")
    argv = {
        "params": ["params", str(urdf)],
        "simulate": [
            "simulate",
            str(urdf),
            "--trajectory",
            str(tmp_path / "trajectory.csv"),
            "--out",
            str(tmp_path / "log.csv"),
        ],
    }[command]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert f"joint 'joint2' in {urdf} has <dynamics friction=\"-0.25\">" in err
    assert "must be a finite number >= 0 [N·m or N]: fix the URDF" in err


def test_loader_with_builder_and_gravity():
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    plant = load_plant(
        model_path("planar_2r"), 1e-3, builder=builder, gravity=[0, 0, -1.0]
    )
    assert plant.gravity_field().gravity_vector()[2] == -1.0
    builder.Build()


ROBOT = '<robot name="r"><link name="world"/><link name="a"/>{}</robot>'


def _one_joint(kind, child="a", extra='<axis xyz="0 0 1"/>'):
    return ROBOT.format(
        f'<joint name="j" type="{kind}"><parent link="world"/>'
        f'<child link="{child}"/>{extra}</joint>'
    )


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ('<robot name="r"><link name="a"></robot>', "not well-formed XML"),
        (_one_joint("revolute", child="b"), "could not parse"),
        (_one_joint("fixed"), "no movable joint"),
        (_one_joint("planar"), "joint 'j' .* type 'planar'"),
        (_one_joint("floating", extra=""), "joint 'j' .* type 'floating'"),
    ],
)
def test_loader_errors(tmp_path, text, match):
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        load_plant(path)


def test_loader_file_and_root_errors(tmp_path):
    with pytest.raises(ValueError, match="URDF file not found"):
        load_plant(tmp_path / "missing.urdf")
    free = tmp_path / "free.urdf"
    free.write_text(
        Path(model_path("planar_2r"))
        .read_text()
        .replace('<link name="world"/>', "")
        .split('<joint name="base_weld"')[0]
        + "</robot>"
    )
    with pytest.raises(ValueError, match="floating base"):
        load_plant(free, weld_root=False)
    two = tmp_path / "two.urdf"
    two.write_text('<robot name="r"><link name="a"/><link name="b"/></robot>')
    with pytest.raises(ValueError, match="2 root links"):
        load_plant(two)


def test_root_link_is_welded_by_default(tmp_path):
    text = Path(model_path("planar_2r")).read_text()
    text = re.sub(
        r'<link name="world"/>|<joint name="base_weld".*?</joint>', "", text, flags=re.S
    )
    path = tmp_path / "noworld.urdf"
    path.write_text(text)
    model = RobotModel.from_urdf(path)
    np.testing.assert_allclose(
        model.base_values, [3.9, 0.25, 0.45, 0.1, 0.3, 0.4, 0.15, 0.25]
    )


# ---------------------------------------------------------------- parameters


def test_2r_standard_and_base_parameters(models):
    model = models["planar_2r"]
    values = model.standard_parameters()
    assert model.joint_names == ("joint1", "joint2")
    assert len(model.standard_names) == 24
    for name, value in {
        "ZZ1": 2.9,
        "M2": 1.0,
        "ZZ2": 0.25,
        "MX2": 0.45,
        "MY2": 0.1,
        "XY2": -0.045,
        "FV1": 0.3,
        "FC1": 0.4,
        "FV2": 0.15,
        "FC2": 0.25,
    }.items():
        assert values[name] == pytest.approx(value, abs=1e-12), name
    assert model.base.names == Planar2RRows().names
    assert dict(model.base.definitions[0]) == {"ZZ1": 1.0, "M2": 1.0}
    np.testing.assert_allclose(
        model.base_values, [3.9, 0.25, 0.45, 0.1, 0.3, 0.4, 0.15, 0.25], atol=1e-12
    )


def test_2r_physical_validity():
    model = RobotModel.from_urdf(model_path("planar_2r"))
    for body in model._link_bodies:
        assert body.default_spatial_inertia().IsPhysicallyValid()


def test_2r_fast_provider_equals_generic(models):
    model = models["planar_2r"]
    fast = model.rows_provider()
    assert fast == Planar2RRows(L1=1.0)
    q, v, vdot = _states(model, seed=21, num=10)
    tau = v * 3.0 - 1.0
    np.testing.assert_allclose(
        fast.energy_rows(q, v), model.energy_rows(q, v), atol=1e-12
    )
    np.testing.assert_allclose(
        fast.idim_rows(q, v, vdot), model.idim_rows(q, v, vdot), atol=1e-12
    )
    np.testing.assert_allclose(
        fast.power_rows(q, v, vdot), model.power_rows(q, v, vdot), atol=1e-12
    )
    for a, b in zip(
        fast.lagrangian_rows(q, v), model.lagrangian_rows(q, v), strict=True
    ):
        np.testing.assert_allclose(a, b, atol=1e-12)
    for kind in ("power", "lagrangian"):
        for a, b in zip(
            fast.model_rows(kind, q, v, tau),
            model.model_rows(kind, q, v, tau),
            strict=True,
        ):
            np.testing.assert_allclose(a, b, atol=1e-12)
    # A 2R whose second axis is not parallel gets the generic provider.
    ur5 = models["ur5"]
    assert ur5.rows_provider() is ur5


# ---------------------------------------------------------------- regressors vs Drake


@pytest.mark.parametrize("name", ["planar_2r", "ur5", "tree"])
def test_rows_match_drake_energy_and_inverse_dynamics(models, name):
    model = models[name]
    q, v, vdot = _states(model, seed=1)
    energy, tau = _drake(model, q, v, vdot)
    theta = model.standard_values
    h = model.energy_rows(q, v, columns="standard") @ theta
    offset = energy - h  # bodies welded to the world: a constant
    np.testing.assert_allclose(offset, offset[0], atol=1e-9)
    hb = model.energy_rows(q, v) @ model.base_values  # base: up to a constant too
    np.testing.assert_allclose(energy - hb, (energy - hb)[0], atol=1e-9)
    np.testing.assert_allclose(
        model.idim_rows(q, v, vdot, columns="standard") @ theta, tau, atol=1e-9
    )
    np.testing.assert_allclose(
        model.idim_rows(q, v, vdot) @ model.base_values, tau, atol=1e-9
    )


@pytest.mark.parametrize("name", ["ur5", "tree"])
def test_numpy_kinematics_equals_drake_kinematics(models, tree_path, name):
    model = models[name]
    other = RobotModel.from_urdf(
        model.path, kinematics="drake", friction=model.friction
    )
    q, v, vdot = _states(model, seed=2, num=3)
    np.testing.assert_allclose(
        model.idim_rows(q, v, vdot), other.idim_rows(q, v, vdot), atol=1e-12
    )
    for a, b in zip(
        model.lagrangian_rows(q, v), other.lagrangian_rows(q, v), strict=True
    ):
        np.testing.assert_allclose(a, b, atol=1e-12)


@pytest.mark.parametrize("name", ["ur5", "tree"])
def test_gradients_are_exact(models, name):
    model = models[name]
    q, v, _ = _states(model, seed=3, num=4)
    dhe_dv, dhe_dq, dhu_dq = model.lagrangian_rows(q, v, columns="standard")
    for i, unit in enumerate(np.eye(model.num_joints)):

        def kinetic(s, dq=0.0, dv=0.0, e=unit):
            return model.kinetic_potential_rows(
                q + dq * e * s, v + dv * e * s, columns="standard"
            )

        np.testing.assert_allclose(
            dhe_dv[:, i], _derivative(lambda s: kinetic(s, dv=1)[0]), atol=1e-9
        )
        np.testing.assert_allclose(
            dhe_dq[:, i], _derivative(lambda s: kinetic(s, dq=1)[0]), atol=1e-9
        )
        np.testing.assert_allclose(
            dhu_dq[:, i], _derivative(lambda s: kinetic(s, dq=1)[1]), atol=1e-9
        )
    np.testing.assert_array_equal(model.momentum_rows(q, v, columns="standard"), dhe_dv)


@pytest.mark.parametrize("name", ["ur5", "tree"])
def test_power_lagrange_and_model_identities(models, name):
    model = models[name]
    n = model.num_joints
    t = np.linspace(0.0, 3.0, 5)
    q, v, vdot = _trajectory(n, t)
    w = model.idim_rows(q, v, vdot)
    theta = model.base_values + np.random.default_rng(4).normal(
        size=model.num_parameters
    )
    # vᵀW = power row = d/dt h + friction power.
    power = model.power_rows(q, v, vdot)
    np.testing.assert_allclose(power, np.einsum("ni,nip->np", v, w), atol=1e-9)
    ddt_h = _derivative(lambda s: model.energy_rows(*_trajectory(n, t + s)[:2]))
    friction = model.model_rows("power", q, v, v)[1][:, 0]
    np.testing.assert_allclose(power, ddt_h + friction, atol=1e-9)
    # W = d/dt(∂h_E/∂v) - ∂h_E/∂q + ∂h_U/∂q + friction = d/dt(D) + G (Lagrangian).
    for kind in ("power", "lagrangian"):
        tau = w @ theta
        _, g, y = model.model_rows(kind, q, v, tau)
        ddt_d = _derivative(
            lambda s, kind=kind, tau=tau: model.model_rows(
                kind, *_trajectory(n, t + s)[:2], tau
            )[0]
        )
        np.testing.assert_allclose(ddt_d @ theta + g @ theta, y, atol=1e-9)
        if kind == "lagrangian":
            np.testing.assert_allclose(ddt_d + g, w, atol=1e-9)


@pytest.mark.parametrize("name", ["planar_2r", "ur5", "tree"])
def test_lagrangian_friction_part_is_gs_friction(models, name):
    """``lagrangian_friction_rows``: exactly G's friction columns (the only ones of
    G that friction touches), for the URDF models and the analytic 2R."""
    model = models[name]
    n = model.num_joints
    q, v, _ = _trajectory(n, np.linspace(0.0, 3.0, 7))
    providers = [model] + ([Planar2RRows()] if name == "planar_2r" else [])
    for rows in providers:
        _, g, _ = rows.model_rows("lagrangian", q, v, np.zeros_like(q))
        columns, values = rows.lagrangian_friction_rows(v)
        np.testing.assert_array_equal(g[:, :, columns], values)
        means = rows.lagrangian_friction_rows(v[:6], 3)[1]  # blocks of 3 samples
        np.testing.assert_allclose(
            means, g[:6, :, columns].reshape(2, 3, n, -1).mean(1)
        )
        kinds = len(rows.friction)  # ur5: viscous, Coulomb and offset
        assert columns.size == n * kinds and np.any(values != 0.0)
        # Joint i's row holds its own friction only.
        others = np.ones((n, n * kinds), dtype=bool)
        for i in range(n):
            others[i, i * kinds : (i + 1) * kinds] = False
        np.testing.assert_array_equal(values[:, others], 0.0)


# ---------------------------------------------------------------- base parameter counts


def test_ur5_base_count_confirmed_by_svd(models):
    model = models["ur5"]
    assert len(model.standard_names) == 6 * 10 + 18
    assert model.base.num_base == 36 + 18  # 36 inertial + FV, FC, OFF per joint
    assert model.base.largest_dropped < 1e-12 and model.base.smallest_kept > 1e-3
    q, v, vdot = _states(model, seed=77, num=60)
    rows = model.idim_rows(q, v, vdot, columns="standard").reshape(
        -1, len(model.standard_names)
    )
    s = np.linalg.svd(rows, compute_uv=False)
    assert int(np.sum(s > 1e-9 * s[0])) == 54


def test_ur5_reduced_count_confirmed_by_drake_symbolic(tmp_path):
    """The UR5 up to joint 3 (wrist joints fixed): Drake's symbolic inverse dynamics
    (DecomposeLumpedParameters) times the lumped-to-standard map equals our rows, and
    both give 15 base parameters. The lumped columns alone have rank 18 because
    Drake's 25 lumped parameters are linearly dependent (rank 21)."""
    from pydrake.all import (
        DecomposeLumpedParameters,
        Evaluate,
        Expression,
        MakeVectorVariable,
        MultibodyForces_,
        SpatialInertia_,
        UnitInertia_,
        Variable,
    )

    text = Path(model_path("ur5")).read_text()
    for joint in ("wrist_1_joint", "wrist_2_joint", "wrist_3_joint"):
        text = text.replace(
            f'<joint name="{joint}" type="revolute"',
            f'<joint name="{joint}" type="fixed"',
        )
        text = re.sub(
            rf'<transmission name="{joint}_transmission">.*?</transmission>',
            "",
            text,
            flags=re.S,
        )
    path = tmp_path / "ur5_3dof.urdf"
    path.write_text(text)
    model = RobotModel.from_urdf(path, friction=())
    assert model.base.num_base == 15

    symbolic = model.plant.ToSymbolic()
    context = symbolic.CreateDefaultContext()
    q, v, vdot = (MakeVectorVariable(3, name) for name in ("q", "v", "vd"))
    symbolic.SetPositions(context, q)
    symbolic.SetVelocities(context, v)
    params = []
    for k, body in enumerate(model._link_bodies):
        mass, cx, cy, cz, *g = (
            Variable(f"{s}{k}")
            for s in ("m", "cx", "cy", "cz", "gxx", "gyy", "gzz", "gxy", "gxz", "gyz")
        )
        params += [mass, cx, cy, cz, *g]
        symbolic.GetBodyByName(body.name()).SetSpatialInertiaInBodyFrame(
            context,
            SpatialInertia_[Expression](
                mass, [cx, cy, cz], UnitInertia_[Expression](*g), True
            ),
        )
    forces = MultibodyForces_[Expression](symbolic)
    symbolic.CalcForceElementsContribution(context, forces)
    w_lumped, alpha, _ = DecomposeLumpedParameters(
        symbolic.CalcInverseDynamics(context, vdot, forces), params
    )
    # Lumped parameters as linear functions of the standard ones (seed 8).
    rng = np.random.default_rng(8)
    alphas, thetas = [], []
    for _ in range(60):
        values = rng.normal(size=len(params))
        env = dict(zip(params, values, strict=True))
        alphas.append([a.Evaluate(env) for a in alpha])
        theta = []
        for k in range(3):
            m_, cx, cy, cz, gxx, gyy, gzz, gxy, gxz, gyz = values[10 * k : 10 * k + 10]
            theta += [
                m_ * gxx,
                m_ * gxy,
                m_ * gxz,
                m_ * gyy,
                m_ * gyz,
                m_ * gzz,
                m_ * cx,
                m_ * cy,
                m_ * cz,
                m_,
            ]
        thetas.append(theta)
    lumped_to_standard = np.linalg.lstsq(
        np.array(thetas), np.array(alphas), rcond=None
    )[0].T
    ours, drake = [], []
    for _ in range(30):
        qk, vk, ak = (
            rng.uniform(-np.pi, np.pi, 3),
            rng.normal(size=3),
            rng.normal(size=3),
        )
        env = {
            **dict(zip(q, qk, strict=True)),
            **dict(zip(v, vk, strict=True)),
            **dict(zip(vdot, ak, strict=True)),
        }
        drake.append(Evaluate(w_lumped, env) @ lumped_to_standard)
        ours.append(model.idim_rows(qk, vk, ak, columns="standard"))
    drake, ours = np.vstack(drake), np.vstack(ours)
    np.testing.assert_allclose(drake, ours, atol=1e-9)
    s = np.linalg.svd(drake, compute_uv=False)
    assert int(np.sum(s > 1e-9 * s[0])) == 15


def test_rotor_inertia_columns_match_drake_reflected_inertia():
    plant = load_plant(model_path("ur5"))
    for i in range(plant.num_actuators()):
        actuator = plant.get_joint_actuator(JointActuatorIndex(i))
        actuator.set_default_rotor_inertia(0.01 * (i + 1))
        actuator.set_default_gear_ratio(2.0)
    model = RobotModel.from_plant(plant, rotor_inertia=True, friction=("viscous",))
    assert model.standard_parameters()["IA3"] == pytest.approx(0.12)
    assert "IA1" in model.base.definitions[0]  # regrouped into ZZ1R
    q, v, vdot = _states(model, seed=9, num=4)
    energy, tau = _drake(model, q, v, vdot)
    np.testing.assert_allclose(
        model.idim_rows(q, v, vdot) @ model.base_values, tau, atol=1e-9
    )
    h = model.energy_rows(q, v, columns="standard") @ model.standard_values
    np.testing.assert_allclose(energy - h, (energy - h)[0], atol=1e-9)


def test_model_errors(models):
    model = models["planar_2r"]
    with pytest.raises(ValueError, match="kind must be one of power, lagrangian"):
        model.model_rows("energy", np.zeros(2), np.zeros(2), np.zeros(2))
    with pytest.raises(ValueError, match="columns must be one of base, standard"):
        model.energy_rows(np.zeros(2), np.zeros(2), columns="lumped")
    with pytest.raises(ValueError, match=r"RobotModel: v must have shape \(any, 2\)"):
        model.energy_rows(np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match="kinematics must be one of"):
        RobotModel.from_plant(model.plant, kinematics="pinocchio")
    d, g, y = model.model_rows("power", np.zeros(2), np.ones(2), np.ones(2))
    assert d.shape == g.shape == (1, 8) and y.shape == (1,)


@pytest.mark.parametrize("sampled", [False, True])
def test_discrete_plant_state_port_timing_seen_by_an_update(sampled):
    # docs/CONVENTIONS.md §2: a block updating at t_k must read x_k, as a logger
    # does. Drake's sampled output ports (its default) give such a block x_{k+1}.
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

    h = 1e-3

    class Recorder(LeafSystem):
        def __init__(self):
            super().__init__()
            self.DeclareVectorInputPort("x", 4)
            self.DeclareDiscreteState(4)
            self.DeclarePeriodicDiscreteUpdateEvent(h, 0.0, self._Update)

        def _Update(self, context, state):
            state.set_value(0, self.get_input_port(0).Eval(context))

    builder = DiagramBuilder()
    plant = builder.AddSystem(
        load_plant(model_path("planar_2r"), h, sampled_output_ports=sampled)
    )
    torque = builder.AddSystem(ConstantVectorSource([1.0, -1.0]))
    builder.Connect(torque.get_output_port(), plant.get_actuation_input_port())
    recorder = builder.AddSystem(Recorder())
    builder.Connect(plant.get_state_output_port(), recorder.get_input_port(0))
    log = LogVectorOutput(plant.get_state_output_port(), builder, h)
    simulator = Simulator(builder.Build())
    simulator.AdvanceTo(5 * h)  # updates at 0..4 ms, publishes at 0..5 ms
    context = simulator.get_context()
    seen = recorder.GetMyContextFromRoot(context).get_discrete_state(0).get_value()
    logged = log.FindLog(context).data().T  # x_0 .. x_5
    expected = logged[4] if not sampled else logged[5]
    np.testing.assert_array_equal(seen, expected)
    assert not np.array_equal(logged[4], logged[5])


def test_a_urdf_rotor_inertia_left_out_is_noted(tmp_path):
    # A review: a URDF whose actuators carry drake:rotor_inertia, loaded without
    # rotor_inertia, gave an a-priori model (dynid params, validate, --compare-urdf)
    # without the N²·Ia that Drake's plant of the same file has, silently; with a
    # drive file the same omission was already a note.
    source = tmp_path / "rotors.urdf"
    text = Path(model_path("planar_2r")).read_text()
    text = text.replace(
        "<robot name=", '<robot xmlns:drake="http://drake.mit.edu" name='
    )
    text = text.replace(
        '<actuator name="joint2_motor"><mechanicalReduction>1</mechanicalReduction>',
        '<actuator name="joint2_motor"><mechanicalReduction>1</mechanicalReduction>'
        '<drake:gear_ratio value="10"/><drake:rotor_inertia value="0.0005"/>',
    )
    source.write_text(text)
    notes = RobotModel.from_urdf(source).notes
    assert any(
        "rotor inertia of joint2 (0.05 kg·m²) is not modelled" in note for note in notes
    ), notes
    assert not any(
        "rotor inertia" in note
        for note in RobotModel.from_urdf(source, rotor_inertia=True).notes
    )
    plain = RobotModel.from_urdf(model_path("planar_2r")).notes
    assert not any("rotor inertia" in note for note in plain), plain


def test_a_prismatic_joints_rotor_inertia_is_noted_in_kg(tmp_path):
    # The note of 7784b13 gave every joint's reflected rotor inertia in kg·m²; a
    # prismatic joint's N²·Ia is a mass [kg] (a review).
    from tests.test_any_urdf import gripper_urdf

    source = Path(gripper_urdf(tmp_path / "g.urdf"))
    text = source.read_text().replace(
        "<robot ", '<robot xmlns:drake="http://drake.mit.edu" ', 1
    )
    source.write_text(
        text.replace(
            "</robot>",
            '<transmission name="fa_t"><type>transmission_interface/'
            'SimpleTransmission</type><joint name="fa"><hardwareInterface>'
            "EffortJointInterface</hardwareInterface></joint><actuator "
            'name="fa_motor"><drake:gear_ratio value="100"/><drake:rotor_inertia '
            'value="2e-5"/></actuator></transmission></robot>',
        )
    )
    notes = RobotModel.from_urdf(source).notes
    assert any("rotor inertia of fa (0.2 kg) is not" in note for note in notes), notes
