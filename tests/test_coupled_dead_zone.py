"""A coupled motor's Coulomb column keeps its reversals through the dead zone off-line.

With a drive chain that couples motors (``FCmk``: R_kᵀ s(u_k/ρ_k) over several
joints' rows), ``dynid offline`` and the torque validation left every Coulomb
column in the rows, evaluated sample by sample: no reversal of a moving joint or
motor kept its sign through the zone (docs/MATH.md §2), where the uncoupled robot's
did. ``benchmarks/bench_dead_zone.py`` measured it on the UR5 with a differential
wrist at 125 Hz: p90 |err|/σ 2.92 and a largest bias of 5.5 σ, against 2.22 / 2.2
with the exact sign. Now a motor's Coulomb column is one series s(x_k), x_k =
(R_k/ρ_k)·v, with the motor's own zone and reversals, spread over the rows by R_kᵀ
(``core.idim_friction.friction_layout``).

The log: the paper's 2R trajectory (21 s at 1 kHz), τ from Drake's inverse
dynamics + the URDF's joint friction + a motor m2 turning with N (q1 + q2) whose
viscous and Coulomb friction (exact sign) act through R, in numpy: never the
library's regressor. No noise: with the dead zone the estimates and the
predictions must be the exact sign's.
"""

import numpy as np
import pytest
from _drake_dynamics import H, exact_paper_2r

from drake_dynid import paper
from drake_dynid.core.drive import DriveChain
from drake_dynid.core.friction import DeadZoneSign
from drake_dynid.logs import RobotLog
from drake_dynid.offline import identify_offline
from drake_dynid.plants import RobotModel, model_path
from drake_dynid.validation import validate_torques

RATIO = 30.0
VISCOUS, COULOMB = 2e-4, 0.01  # motor side [N·m·s/rad], [N·m]
ZONE = DeadZoneSign((0.003, 0.003))  # motor m2's: 0.0042 rad/s on (v1 + v2)
# A 3 mrad/s zone is a noisy log's, filtered well below 30 Hz: the cutoff is given
# (28.25 Hz, the automatic one before it weighed the filter's droop against the
# noise; this noise-free log now gets 34.8 Hz, where a reversal may take at most
# L = 0.125/(f_c h) = 3 samples, fewer than its slowest spends in the zone: read as
# rest by design, core.standstill.reversal_run).
ZONE_CUTOFF = 28.25


@pytest.fixture(scope="module")
def coupled():
    chain = DriveChain.from_dict(
        {
            "motors": {
                "m1": {"joint": "joint1", "gear_ratio": 50.0},
                "m2": {
                    "joints": {"joint1": RATIO, "joint2": RATIO},
                    "viscous": VISCOUS,
                    "coulomb": COULOMB,
                },
            }
        },
        ("joint1", "joint2"),
    )
    robot = RobotModel.from_urdf(model_path("planar_2r"), drive=chain)
    t, q, tau = exact_paper_2r(robot)
    _, v, _ = paper.paper_trajectory().evaluate(t)
    row = np.array([RATIO, RATIO])
    u = v @ row
    tau = tau + np.outer(VISCOUS * u + COULOMB * np.sign(u), row)
    return robot, RobotLog(t, q, tau, robot.joint_names, H)


def test_the_motors_coulomb_column_is_one_series_on_its_own_channel(coupled):
    from drake_dynid.core.idim_friction import friction_layout

    robot, _ = coupled
    zoned = robot.with_sign(ZONE)
    assert "FCm2" in robot.names
    layout = friction_layout(
        zoned.names, zoned.idim_rows, 2, zoned.sign, zoned.motor_columns
    )
    assert layout is not None
    entries = {
        zoned.names[column]: (kind, channel, tuple(weights))
        for column, (kind, channel), weights in zip(
            layout.columns, layout.friction, layout.weights, strict=True
        )
    }
    assert entries["FCm2"] == ("coulomb", 2, (RATIO, RATIO))
    assert entries["FC2"] == ("coulomb", 1, (0.0, 1.0))
    assert "FVm2" not in entries  # linear in v: with the rigid-body columns
    np.testing.assert_allclose(layout.channels.rows, [[RATIO, RATIO]])
    np.testing.assert_allclose(layout.channels.sign.width, [0.003 * np.sqrt(2)])
    # A provider whose motor column is not the law it is given: not split.
    assert friction_layout(zoned.names, zoned.idim_rows, 2, zoned.sign, None) is None
    assert (
        friction_layout(
            zoned.names, zoned.idim_rows, 2, zoned.sign, robot.motor_columns
        )
        is None
    )


def test_a_coupled_motors_reversals_keep_their_sign_off_line(coupled):
    """Before: the zoned fit was up to 4.6e-4 (relative, FCm2) off the exact
    sign's: the motor's and the joints' reversals through the zone were 0 there
    (the motor's alone at each sample: 2.2e-4, MY2). Now the same to round-off,
    on the two-stage stream (D1 was 1: every column from the rows)."""
    robot, log = coupled
    exact = identify_offline(log, robot, cutoff_hz=ZONE_CUTOFF)
    truth = robot.base_values
    assert np.max(np.abs(exact.theta - truth) / np.abs(truth)) < 1e-3
    zoned = identify_offline(log, robot.with_sign(ZONE), cutoff_hz=ZONE_CUTOFF)
    # The friction columns are split out: the two-stage stream (D1 > 1).
    assert zoned.settings["regressor_decimation"] > 1
    np.testing.assert_allclose(zoned.theta, exact.theta, rtol=1e-9)


def test_the_validation_of_a_coupled_robot_uses_the_fits_law(coupled):
    """Before: with the true parameters the zoned prediction's errors were 0.0031 /
    0.014 % (raw 0.093 / 0.42 %) against 0.0017 / 0.0013 % (0.013 / 0.0095 %) with
    the exact sign; now the same."""
    robot, log = coupled
    exact = validate_torques(log, robot, robot.base_values, cutoff_hz=ZONE_CUTOFF)
    zoned = validate_torques(
        log, robot.with_sign(ZONE), robot.base_values, cutoff_hz=ZONE_CUTOFF
    )
    np.testing.assert_allclose(
        zoned.relative_rms_percent, exact.relative_rms_percent, rtol=1e-6
    )
    np.testing.assert_allclose(
        zoned.raw_relative_rms_percent, exact.raw_relative_rms_percent, rtol=1e-6
    )


def test_the_printed_dead_zone_line_shows_the_motors_combined_widths(coupled):
    """Before: the line listed the joints' widths only, though motor m2's sign
    reads (v1 + v2) with its own width, the joints' combined (0.003·√2)."""
    from drake_dynid.commands._arguments import dead_zone_line

    robot, _ = coupled
    line = dead_zone_line(robot.with_sign(ZONE), reversals=True)
    assert line is not None
    assert "joint1 0.003 rad/s, joint2 0.003 rad/s" in line
    motors = "coupled motors, on R_k·v/ρ_k (the joints' widths combined): m2 0.0042"
    assert f"{motors} rad/s" in line
    assert line.endswith("keeps its sign")
    plain = RobotModel.from_urdf(model_path("planar_2r")).with_sign(ZONE)
    assert "coupled" not in (dead_zone_line(plain) or "")


def test_a_regrouped_motor_coulomb_column_is_split_too():
    """Found by a review: two coupled motors on the same row, opposite ways (an
    antagonistic pair: m2 turning with 30 (q1 + q2), m3 with -30 (q1 + q2)) give
    one base parameter FCm2R = FCm2 + FCm3, whose name the layout did not read:
    it returned None, and the zoned fit took the one-stage path with every
    Coulomb column's zone at each sample (up to 3.9e-4 relative off the exact
    sign's, MY2; FCm2R 2.9e-4). Now the column is split and the fit is the exact
    sign's."""
    from drake_dynid.core.idim_friction import friction_layout

    pair = {"viscous": VISCOUS, "coulomb": COULOMB}
    chain = DriveChain.from_dict(
        {
            "motors": {
                "m1": {"joint": "joint1", "gear_ratio": 50.0},
                "m2": {"joints": {"joint1": RATIO, "joint2": RATIO}, **pair},
                "m3": {"joints": {"joint1": -RATIO, "joint2": -RATIO}, **pair},
            }
        },
        ("joint1", "joint2"),
    )
    robot = RobotModel.from_urdf(model_path("planar_2r"), drive=chain)
    assert "FCm2R" in robot.names
    zoned = robot.with_sign(ZONE)
    layout = friction_layout(
        zoned.names, zoned.idim_rows, 2, zoned.sign, zoned.motor_columns
    )
    assert layout is not None
    assert zoned.names.index("FCm2R") in layout.columns
    t, q, tau = exact_paper_2r(robot)
    _, v, _ = paper.paper_trajectory().evaluate(t)
    row = np.array([RATIO, RATIO])
    u = v @ row
    tau = tau + 2.0 * np.outer(VISCOUS * u + COULOMB * np.sign(u), row)
    log = RobotLog(t, q, tau, robot.joint_names, H)
    exact = identify_offline(log, robot, cutoff_hz=ZONE_CUTOFF)
    fit = identify_offline(log, zoned, cutoff_hz=ZONE_CUTOFF)
    assert fit.settings["regressor_decimation"] > 1
    np.testing.assert_allclose(fit.theta, exact.theta, rtol=1e-9)
