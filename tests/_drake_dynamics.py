"""Independent test data: Drake's inverse dynamics of the paper's 2R trajectory."""

import numpy as np

from drake_dynid import paper

H = 1e-3


def exact_paper_2r(robot, duration_samples: int = 21001):
    """``(t, q, τ)``: the paper trajectory evaluated every H for 21 s, τ from
    Drake's ``CalcInverseDynamics`` (gravity, URDF damping) + the URDF's Coulomb
    friction (0.4, 0.25 N·m), never the library's regressor."""
    from pydrake.multibody.tree import MultibodyForces

    t = H * np.arange(duration_samples)
    q, v, vdot = paper.paper_trajectory().evaluate(t)
    plant = robot.plant
    context = plant.CreateDefaultContext()
    tau = np.empty_like(q)
    for k in range(len(t)):
        plant.SetPositions(context, q[k])
        plant.SetVelocities(context, v[k])
        forces = MultibodyForces(plant)
        plant.CalcForceElementsContribution(context, forces)
        tau[k] = plant.CalcInverseDynamics(context, vdot[k], forces)
    tau += np.array([0.4, 0.25]) * np.sign(v)
    return t, q, tau
