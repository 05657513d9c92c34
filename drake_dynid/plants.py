"""Backward-compatible names of the former ``plants`` module.

The URDF loading lives in :mod:`drake_dynid.urdf`, the robot description in
:mod:`drake_dynid.robot`, the kinematic tree and the spatial algebra in
:mod:`drake_dynid.core.kinematics` and the regressor blocks in
:mod:`drake_dynid.core.rigid_body`. New code imports from those modules (or from the
package: ``from drake_dynid import RobotModel``).
"""

from __future__ import annotations

from drake_dynid.core.kinematics import momentum_matrix
from drake_dynid.robot import INERTIAL_NAMES, RobotModel
from drake_dynid.urdf import MODELS_DIR, load_plant, model_path, read_urdf_friction

__all__ = [
    "INERTIAL_NAMES",
    "MODELS_DIR",
    "RobotModel",
    "load_plant",
    "model_path",
    "momentum_matrix",
    "read_urdf_friction",
]
