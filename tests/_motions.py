"""A 2R test motion shared by the tests that need a moving arm, not accuracy: the
paper's 2R arm on a random Fourier reference (3 harmonics, 0.25 Hz, |v| <= 2
rad/s, numpy default_rng(4)), torques from the library's rows with the URDF's
base values (these tests check reading, timing and messages)."""

import numpy as np

from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.plants import RobotModel, model_path

URDF_2R = model_path("planar_2r")


def fourier_2r(samples: int, h: float = 1e-3):
    """(robot, t, q, τ) of ``samples`` samples at step h [s]."""
    robot = RobotModel.from_urdf(URDF_2R)
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.25,
        max_velocity=2.0,
        rng=np.random.default_rng(4),
    )
    t = np.arange(samples) * h
    q, v, vdot = trajectory.evaluate(t)
    return robot, t, q, robot.idim_rows(q, v, vdot) @ robot.base_values
