"""Test motions shared by several test files.

``fourier_2r``: the paper's 2R arm on a random Fourier reference (3 harmonics,
0.25 Hz, |v| <= 2 rad/s, numpy default_rng(4)), torques from the library's rows
with the URDF's base values (for tests of reading, timing and messages, not
accuracy). ``band_limited``: two joints' band-limited positions with white noise
and their exact acceleration (for the noise floor and the automatic cutoff)."""

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


def band_limited(fs, duration, noise_std, seed=3, t=None):
    """``(t, q + noise, acceleration)`` of an excite-like design of two joints.

    Five lines of 0.2 Hz (top 1 Hz) per joint, amplitudes and phases from numpy
    default_rng(``seed``), sampled at ``fs`` [Hz] for ``duration`` [s] (or at the
    times ``t`` [s]), plus white noise of ``noise_std`` [rad] (default_rng(7));
    the acceleration is the noise-free one [rad/s²].
    """
    rng = np.random.default_rng(seed)
    t = np.arange(round(duration * fs)) / fs if t is None else t
    q, acceleration = np.zeros((t.size, 2)), np.zeros((t.size, 2))
    for j in range(2):
        for k in range(1, 6):
            phase, w = rng.uniform(0.0, 2 * np.pi), 0.4 * np.pi * k
            line = rng.uniform(0.2, 1.0) / k**2 * np.sin(w * t + phase)
            q[:, j] += line
            acceleration[:, j] -= w**2 * line
    noise = np.random.default_rng(7).normal(0.0, noise_std, q.shape)
    return t, q + noise, acceleration
