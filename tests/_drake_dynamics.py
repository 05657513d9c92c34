"""Independent test data: torques from Drake's inverse dynamics, never the library's
regressor."""

import numpy as np

from drake_dynid import paper
from drake_dynid.urdf import read_urdf_friction

H = 1e-3


def drake_torques(robot, q, v, vdot):
    """(N, n) τ: Drake's ``CalcInverseDynamics`` (gravity, URDF damping) at each
    sample + the URDF's Coulomb friction·sign(v) (0 for a joint without one)."""
    from pydrake.multibody.tree import MultibodyForces

    plant = robot.plant
    context = plant.CreateDefaultContext()
    coulomb = read_urdf_friction(robot.path)
    fc = np.array([coulomb.get(name, 0.0) for name in robot.joint_names])
    out = np.empty_like(q)
    for k in range(q.shape[0]):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        out[k] = plant.CalcInverseDynamics(context, vdot[k], forces)
    return out + fc * np.sign(v)


def exact_paper_2r(robot, duration_samples: int = 21001):
    """``(t, q, τ)``: the paper trajectory evaluated every H for 21 s on the 2R,
    τ from :func:`drake_torques` (its URDF's Coulomb friction 0.4, 0.25 N·m)."""
    t = H * np.arange(duration_samples)
    q, v, vdot = paper.paper_trajectory().evaluate(t)
    return t, q, drake_torques(robot, q, v, vdot)
