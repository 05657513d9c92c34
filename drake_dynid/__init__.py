"""drake_dynid: on-line robot dynamic identification with Drake.

The public names are loaded lazily (PEP 562) so that importing the pure numpy/scipy
core, or running ``dynid --help``, does not pay for importing pydrake.

Layers (see ``docs/CONVENTIONS.md``):

* ``drake_dynid.core``: pure numpy/scipy, functional (design functions return
  immutable data, step functions take state and return new state). Never imports
  pydrake.
* ``drake_dynid.systems``: thin Drake ``LeafSystem`` blocks over the core; all state
  lives in the Context.
* ``drake_dynid.urdf``, ``drake_dynid.robot``, ``drake_dynid.diagrams``,
  ``drake_dynid.simulation``, ``drake_dynid.cli``: URDF plants, the robot
  description, diagram builders, the simulated set-up and the ``dynid`` command.
"""

from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.1.0"

# Public name -> module that defines it. Add one line per public name.
_LAZY: dict[str, str] = {
    # core (no pydrake)
    "jacobi_filter": "drake_dynid.core.jacobi",
    "JacobiFilter": "drake_dynid.core.jacobi",
    "jacobi_filters": "drake_dynid.core.jacobi",
    "jacobi_minimum_delay_xi": "drake_dynid.core.jacobi",
    "jacobi_kernel": "drake_dynid.core.jacobi",
    "jacobi_frequency_response": "drake_dynid.core.jacobi",
    "jacobi_sinusoid_error": "drake_dynid.core.jacobi",
    "jacobi_apply": "drake_dynid.core.jacobi",
    "jacobi_batch": "drake_dynid.core.jacobi",
    "JacobiRing": "drake_dynid.core.jacobi",
    "jacobi_ring": "drake_dynid.core.jacobi",
    "jacobi_initial_state": "drake_dynid.core.jacobi",
    "jacobi_step": "drake_dynid.core.jacobi",
    "jacobi_outputs": "drake_dynid.core.jacobi",
    "jacobi_valid": "drake_dynid.core.jacobi",
    "ChunkRing": "drake_dynid.core.ring",
    "FourierBank": "drake_dynid.core.modulating",
    "fourier_bank": "drake_dynid.core.modulating",
    "default_frequencies": "drake_dynid.core.modulating",
    "paper_frequencies": "drake_dynid.core.modulating",
    "assemble_equations": "drake_dynid.core.modulating",
    "direct_fourier_integrals": "drake_dynid.core.modulating",
    "modulated_integrals": "drake_dynid.core.modulating",
    "sliding_init": "drake_dynid.core.modulating",
    "sliding_push": "drake_dynid.core.modulating",
    "sliding_push_many": "drake_dynid.core.modulating",
    "sliding_fourier_integrals": "drake_dynid.core.modulating",
    "LeastSquaresResult": "drake_dynid.core.lsq",
    "solve_least_squares": "drake_dynid.core.lsq",
    "solve_weighted_least_squares": "drake_dynid.core.lsq",
    "offline_derivatives": "drake_dynid.core.idim",
    "parallel_decimation": "drake_dynid.core.idim",
    "idim_least_squares": "drake_dynid.core.idim",
    "noise_std_for_snr": "drake_dynid.core.noise",
    "add_noise": "drake_dynid.core.noise",
    "estimate_bandwidth": "drake_dynid.core.excitation",
    "frequencies_for": "drake_dynid.core.excitation",
    "velocity_spectrum": "drake_dynid.core.excitation",
    "position_noise_std": "drake_dynid.core.excitation",
    "rows_from_noise": "drake_dynid.core.raw_rows",
    "jackknife_std": "drake_dynid.core.jackknife",
    "bootstrap_std": "drake_dynid.core.bootstrap",
    "motion_and_noise": "drake_dynid.core.excitation",
    "motion_noise_band": "drake_dynid.core.excitation",
    "FourierTrajectory": "drake_dynid.core.trajectory",
    "random_fourier_trajectory": "drake_dynid.core.trajectory",
    "optimize_fourier_trajectory": "drake_dynid.core.trajectory",
    "ExcitationSettings": "drake_dynid.core.excite",
    "ExcitationDesign": "drake_dynid.core.excite",
    "design_excitation": "drake_dynid.core.excite",
    "excitation_report": "drake_dynid.core.excite_report",
    "JointLimits": "drake_dynid.core.joint_limits",
    "Margins": "drake_dynid.core.joint_limits",
    "limit_violations": "drake_dynid.core.joint_limits",
    "Planar2RRows": "drake_dynid.core.planar2r",
    "RowProvider": "drake_dynid.core.rows",
    "pack_rows": "drake_dynid.core.rows",
    "ModulatingBank": "drake_dynid.core.bank",
    "band_frequencies": "drake_dynid.core.fourier_bank",
    "SignLaw": "drake_dynid.core.friction",
    "ExactSign": "drake_dynid.core.friction",
    "TanhSign": "drake_dynid.core.friction",
    "Status": "drake_dynid.core.identifier",
    "identifier_init": "drake_dynid.core.identifier",
    "identifier_update": "drake_dynid.core.identifier",
    "OnlineSettings": "drake_dynid.core.online",
    "OnlineTrace": "drake_dynid.core.online",
    "replay_log_core": "drake_dynid.core.replay",
    "BaseParameters": "drake_dynid.core.base_parameters",
    "base_parameters": "drake_dynid.core.base_parameters",
    "JointMap": "drake_dynid.core.joint_map",
    "joint_map": "drake_dynid.core.joint_map",
    # drive chains: motors, gears, currents, coupled joints (no pydrake)
    "DriveChain": "drake_dynid.core.drive",
    "read_drive": "drake_dynid.core.drive",
    "MotorColumns": "drake_dynid.core.drive_columns",
    "motor_columns": "drake_dynid.core.drive_columns",
    "SimulatedDrive": "drake_dynid.core.drive_dynamics",
    "simulated_drive": "drake_dynid.core.drive_dynamics",
    # URDF loading and the robot description (pydrake)
    "RobotModel": "drake_dynid.robot",
    "load_plant": "drake_dynid.urdf",
    "model_path": "drake_dynid.urdf",
    "read_urdf_friction": "drake_dynid.urdf",
    "read_urdf_mimic": "drake_dynid.urdf",
    "load_urdf": "drake_dynid.urdf",
    "UrdfDrive": "drake_dynid.drive_urdf",
    "load_drive": "drake_dynid.drive_urdf",
    "read_urdf_drive": "drake_dynid.drive_urdf",
    "joint_limits": "drake_dynid.limits",
    "SelfCollision": "drake_dynid.collision",
    # experiment rehearsal: trajectory files and the simulated log (pydrake)
    "SampledTrajectory": "drake_dynid.trajectory_file",
    "read_trajectory": "drake_dynid.trajectory_file",
    "write_trajectory": "drake_dynid.trajectory_file",
    "ExperimentSettings": "drake_dynid.experiment",
    "ExperimentLog": "drake_dynid.experiment",
    "simulate_experiment": "drake_dynid.experiment",
    "truth_model": "drake_dynid.experiment_drive",
    "simulated_drive_of": "drake_dynid.experiment_drive",
    "replay_in_meshcat": "drake_dynid.meshcat_replay",
    # systems (pydrake)
    "CausalJacobiDifferentiator": "drake_dynid.systems.jacobi",
    "JointFriction": "drake_dynid.systems.friction",
    "HeldSamples": "drake_dynid.systems.held_samples",
    "DriveForces": "drake_dynid.systems.drive_forces",
    "DriveFeedforward": "drake_dynid.systems.drive_forces",
    "ModelRows": "drake_dynid.systems.identification",
    "RawModelRows": "drake_dynid.systems.identification",
    "ModulatingIntegralBank": "drake_dynid.systems.identification",
    "SlidingQRIdentifier": "drake_dynid.systems.identification",
    "ChangeTrackingIdentifier": "drake_dynid.systems.change",
    "SignalWindow": "drake_dynid.systems.signal_window",
    # logs (no pydrake)
    "RobotLog": "drake_dynid.logs",
    "read_log": "drake_dynid.logs",
    "write_log": "drake_dynid.logs",
    # off-line identification on logs (no pydrake)
    "OfflineResult": "drake_dynid.offline",
    "identify_offline": "drake_dynid.offline",
    # validation, physical consistency, identified URDF
    "TorqueValidation": "drake_dynid.validation",
    "validate_estimates": "drake_dynid.validation",
    "validate_torques": "drake_dynid.validation",
    "split_log": "drake_dynid.validation",
    "PhysicalCheck": "drake_dynid.physical",
    "PhysicalResult": "drake_dynid.physical",
    "check_physical": "drake_dynid.physical",
    "solve_physical": "drake_dynid.physical",
    "project_physical": "drake_dynid.physical",
    "pseudo_inertia": "drake_dynid.physical",
    "UrdfExport": "drake_dynid.urdf_writer",
    "write_identified_urdf": "drake_dynid.urdf_writer",
    # diagrams and the simulated set-up (pydrake)
    "add_online_identifier": "drake_dynid.diagrams",
    "add_online_identifiers": "drake_dynid.diagrams",
    "log_source": "drake_dynid.diagrams",
    "chain_trace": "drake_dynid.diagrams",
    "final_row": "drake_dynid.diagrams",
    "replay_log": "drake_dynid.diagrams",
    "SimulationSettings": "drake_dynid.simulation",
    "SimulationResult": "drake_dynid.simulation",
    "simulate_identification": "drake_dynid.simulation",
    # payload identification (issue 16): core, block, diagrams
    "PayloadRows": "drake_dynid.core.payload",
    "payload_rows": "drake_dynid.core.payload",
    "payload_transform": "drake_dynid.core.payload",
    "payload_parameters": "drake_dynid.core.payload",
    "shift_parameters": "drake_dynid.core.payload",
    "payload_settings": "drake_dynid.core.payload_step",
    "payload_update": "drake_dynid.core.payload_step",
    "PayloadTrace": "drake_dynid.core.payload_replay",
    "replay_payload_core": "drake_dynid.core.payload_replay",
    "payload_summary": "drake_dynid.core.payload_report",
    "payload_model": "drake_dynid.payload",
    "PayloadIdentifier": "drake_dynid.systems.payload",
    "add_payload_identifier": "drake_dynid.payload_diagrams",
    "replay_payload_log": "drake_dynid.payload_diagrams",
}

__all__ = ["__version__", *sorted(_LAZY)]


def __getattr__(name: str) -> Any:
    module_name = _LAZY.get(name)
    if module_name is None:
        raise AttributeError(f"module 'drake_dynid' has no attribute {name!r}")
    value = getattr(importlib.import_module(module_name), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
