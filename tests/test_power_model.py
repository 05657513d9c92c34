"""The power model: its row count, its default ℓ set, its noise-bias compensation.

Independent references: Drake's mass matrix and energies (``CalcMassMatrix``,
``CalcKineticEnergy``, ``CalcPotentialEnergy``) for the energy rows' noise bias,
Monte-Carlo expectations for the friction power columns, and an exact log (the
trajectory evaluated, torques from Drake's ``CalcInverseDynamics`` + the URDF's
Coulomb friction) for the modulated equations.
"""

import dataclasses
import json
import re
from types import SimpleNamespace

import numpy as np
import pytest
from _drake_dynamics import exact_paper_2r

from drake_dynid import cli
from drake_dynid.core.ell_rule import (
    functions_for_rows,
    independent_rows,
    usable_frequency,
)
from drake_dynid.core.friction import EXACT_SIGN, DeadZoneSign, TanhSign
from drake_dynid.core.noise_bias import coulomb_power_mean, noise_compensated_rows
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core, window_equations
from drake_dynid.logs import RobotLog, write_log
from drake_dynid.plants import RobotModel, model_path

H = 1e-3


@pytest.fixture(scope="module")
def arm2():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def exact_2r(arm2):
    """The paper trajectory evaluated for 21 s, torques from Drake (independent)."""
    t, q, tau = exact_paper_2r(arm2)
    return RobotLog(t, q, tau, arm2.joint_names, H)


# ------------------------------------------------------------------- row count
def test_too_few_rows_are_refused_before_any_solve(arm2, exact_2r):
    # 2 functions x 2 rows x 1 equation = 4 rows for 8 parameters: the drivers
    # refuse with the count and what to change, instead of "condition number inf".
    settings = OnlineSettings(model="power", window=20.0, frequencies=[0.0, 1.0])
    with pytest.raises(
        ValueError,
        match=r"gives 4 independent rows \(2 modulating functions x 2 rows x 1 "
        r"equation of the power model\) for 8 parameters: no window can identify "
        r"them; use at least 4 integer ℓ \(frequencies 0:1:3, up to 0.2 Hz .*"
        r"lagrangian model",
    ):
        replay_log_core(exact_2r, arm2.rows_provider(), [settings])


def test_row_count_messages_multiply_out():
    # The parenthesis's factors multiply to the count it explains, for integer ℓ
    # and for the paper's grid, whose 201 functions give 23 independent rows (the
    # message said "201 modulating functions x 1 equation" for 23 rows).
    paper = OnlineSettings(model="power", window=20.0, frequencies="paper")
    with pytest.raises(
        ValueError,
        match=r"gives 23 independent rows \(201 modulating functions whose "
        r"neighbouring ℓ repeat each other: 23 independent rows x 1 equation of the "
        r"power model\) for 57 parameters: no window",
    ):
        paper.for_robot(H, 7, 57)
    with pytest.raises(
        ValueError,
        match=r"gives 23 independent rows \(201 modulating functions whose "
        r"neighbouring ℓ repeat each other: 23 independent rows x 1 equation of the "
        r"power model\) for 20 parameters; an honest σ needs at least 24",
    ):
        paper.for_log(H, 60.0, num_joints=2, num_parameters=20)


def test_integer_sets_count_every_row_and_accept_the_set_they_are_told_to_use():
    # 64 parameters (iiwa7 with offsets) need 68 rows: the message asks for 34
    # integer ℓ, and 34 integer ℓ give 68 exactly independent rows (integer lines
    # are orthogonal over the window). The numerical rank of their correlation
    # (smallest eigenvalue ~ L^-2: shared lines) counted 67 and refused the set
    # with the same advice again.
    told = OnlineSettings(model="power", window=20.0, frequencies=list(range(20)))
    with pytest.raises(ValueError, match=r"use at least 34 integer ℓ"):
        told.for_log(H, 60.0, num_joints=7, num_parameters=64)
    used = dataclasses.replace(told, frequencies=list(range(34)))
    assert len(used.for_log(H, 60.0, num_joints=7, num_parameters=64).ell()) == 34
    for frequencies, order, rows in (
        (range(116), 1, 232),  # the covariance weighting's set (was 228)
        (range(100), 2, 200),
        ([-1, 0, 1], 1, 4),  # g_-1 = -conj(g_0): the same two rows
        (list(range(-3, 4)), 3, 10),  # ℓ and -ℓ - 3 pair up: 5 distinct
    ):
        settings = OnlineSettings(
            model="power",
            window=20.0,
            frequencies=list(frequencies),
            order=order,
            jacobi_window=0.05,
        )
        assert independent_rows(settings) == rows
    paper = OnlineSettings(model="power", window=20.0, frequencies="paper")
    assert independent_rows(paper) == 23  # a fine grid: the numerical rank
    with pytest.raises(
        ValueError,
        match=r"\(3 modulating functions whose ℓ and -ℓ - k give the same rows: 4 "
        r"independent rows x 1 equation",
    ):
        dataclasses.replace(told, frequencies=[-1, 0, 1]).for_robot(H, 2, 8)


def test_cli_row_count_message_names_the_options(arm2, exact_2r, tmp_path, capsys):
    path = tmp_path / "log.csv"
    write_log(path, exact_2r.t, exact_2r.q, exact_2r.tau, exact_2r.joint_names)
    code = cli.main(
        [
            "identify",
            "--urdf",
            str(arm2.path),
            "--model",
            "power",
            "--frequencies",
            "0,1,2,3",
            str(path),
        ]
    )
    assert code == 2
    error = capsys.readouterr().err
    assert (
        "--frequencies gives 8 independent rows (4 modulating functions x 2 " in error
    )
    assert (
        "an honest σ needs at least 12: use at least 6 integer ℓ (--frequencies "
        in (error)
    )
    assert "0:1:5, up to 0.3 Hz with --window 20 s" in error
    # Where the needed functions do not fit in the pass band: the window to use.
    code = cli.main(
        [
            "identify",
            "--urdf",
            str(arm2.path),
            "--model",
            "power",
            "--window",
            "5",
            "--jacobi-window",
            "2",
            "--frequencies",
            "0,1",
            str(path),
        ]
    )
    assert code == 2
    assert "lengthen --window to at least" in capsys.readouterr().err


def test_default_set_scales_with_the_parameters_within_the_pass_band():
    # A 7-DOF arm (p = 57): twice the 61 rows a window needs -> 61 functions for
    # the power model (one equation); the Lagrangian model keeps its band's set.
    assert functions_for_rows(1, 57) == 61 and functions_for_rows(7, 57) == 9
    power = OnlineSettings.for_model("power", window=20.0, bandwidth=0.52)
    grid = power.for_robot(H, 7, 57)
    assert grid.min_functions == 61 and len(grid.ell()) == 61
    top = (len(grid.ell()) - 1 + grid.order) / grid.window
    assert top == pytest.approx(3.05) and top <= usable_frequency(grid, H)  # 5.8 Hz
    lagrangian = OnlineSettings.for_model("lagrangian", window=20.0, bandwidth=0.52)
    assert len(lagrangian.for_robot(H, 7, 57).ell()) == 10
    # The power set covers twice the band (its rows are products of velocities).
    assert power.ell()[-1] == 19 and lagrangian.ell()[-1] == 9
    # A short window: capped at the pass band (0.3 s Jacobi window: 3.87 Hz); 30
    # functions are 60 rows, enough to solve (57) but not for an honest σ (61).
    short = OnlineSettings.for_model(
        "power", window=8.0, bandwidth=0.52, jacobi_window=0.3
    )
    assert len(short.for_robot(H, 7, 57).ell()) == 30
    with pytest.raises(ValueError, match=r"lengthen window to at least 8.01 s"):
        short.for_log(H, 60.0, num_joints=7, num_parameters=57)
    # Shorter: no window can be solved; the drivers refuse it.
    with pytest.raises(ValueError, match=r"lengthen window to at least 7.5 s"):
        dataclasses.replace(short, window=5.0).for_robot(H, 7, 57)


# ------------------------------------------------------------- noise bias
@pytest.mark.parametrize(
    "law",
    [EXACT_SIGN, DeadZoneSign((0.02, 0.1)), TanhSign(0.05)],
    ids=["sign", "dead zone", "tanh"],
)
def test_coulomb_power_mean_matches_monte_carlo(law):
    v = np.array([[-0.3, 0.0], [0.01, -0.05], [0.12, 0.4]])
    sigma = np.array([0.05, 0.08])
    x = v[None] + sigma * np.random.default_rng(0).standard_normal((400_000, 1, 2))
    expected = (x * law(x)).mean(axis=0)
    got = coulomb_power_mean(v, sigma, law)
    np.testing.assert_allclose(got, expected, atol=4e-4)
    assert np.abs(got - v * law(v)).max() > 0.02  # a bias that matters


@pytest.mark.parametrize("rows_from", ["filtered", "raw"])
def test_velocity_and_position_noise_of_the_rows_are_uncorrelated(rows_from):
    # docs/MATH.md §3: the compensation adds the biases of v̂ and q̂ separately,
    # which needs Σ c₀c₁ = 0; it holds for asymmetric taps too (ξ != ½, κ != μ):
    # the matched c₁ is the derivative of c₀'s kernel, which vanishes at both ends.
    for settings in (
        OnlineSettings.for_model("power", rows_from=rows_from),
        OnlineSettings(
            model="power", kappa=0.5, mu=2.0, jacobi_q=2, rows_from=rows_from
        ),
    ):
        grid = settings.on_grid(H)
        if rows_from == "raw":
            design = grid.raw_design(H)
            velocity = design.velocity.taps
            smooth = np.zeros_like(velocity)
            smooth[(len(velocity) - 1) // 2] = 1.0
        else:
            smooth, velocity = (f.taps for f in grid.jacobi_filters(H))
            assert np.abs(smooth - smooth[::-1]).max() > 0.5 * np.abs(smooth).max()
        correlation = smooth @ velocity / np.linalg.norm(smooth)
        assert abs(correlation) < 1e-6 * np.linalg.norm(velocity)


def test_energy_bias_is_drakes_mass_matrix_trace():
    # E[h(q, v + e)] - h(q, v) = ½ Σ σ_a² M_aa(q) (kinetic energy quadratic in v)
    # and ½ Σ σ_q,a² ∂²H/∂q_a² for position noise: Drake's mass matrix and energies.
    robot = RobotModel.from_urdf(model_path("iiwa7"))
    rng = np.random.default_rng(3)
    q, v = rng.uniform(-1, 1, (5, 7)), rng.uniform(-1, 1, (5, 7))
    tau = np.zeros((5, 7))
    sigma_v, sigma_q = rng.uniform(0.01, 0.05, 7), np.full(7, 1e-3)
    theta = robot.base_values
    plant, context = robot.plant, robot.plant.CreateDefaultContext()

    def energy(qk, vk):
        plant.SetPositions(context, qk)
        plant.SetVelocities(context, vk)
        return plant.CalcKineticEnergy(context) + plant.CalcPotentialEnergy(context)

    plain = robot.model_rows("power", q, v, tau)[0][:, 0] @ theta
    wrapped = noise_compensated_rows(robot, sigma_v, 0.0)
    bias = plain - wrapped.model_rows("power", q, v, tau)[0][:, 0] @ theta
    for k in range(5):
        plant.SetPositions(context, q[k])
        mass = plant.CalcMassMatrix(context)
        assert bias[k] == pytest.approx(0.5 * sigma_v**2 @ np.diag(mass), rel=1e-9)
    wrapped = noise_compensated_rows(robot, 0.0, sigma_q)
    bias = plain - wrapped.model_rows("power", q, v, tau)[0][:, 0] @ theta
    step = 1e-3
    for k in range(5):
        curvature = [
            energy(q[k] + step * e, v[k])
            + energy(q[k] - step * e, v[k])
            - 2 * energy(q[k], v[k])
            for e in np.eye(7)
        ]
        assert bias[k] == pytest.approx(
            0.5 * sigma_q**2 @ np.array(curvature) / step**2, rel=1e-3
        )


def test_compensated_power_equations_are_unbiased(arm2, exact_2r):
    # The modulated power equations of the independent log with white position
    # noise (σ = 0.05 rad, SNR ~30 dB), averaged over antithetic noise pairs (the
    # terms linear in the noise cancel, the bias stays): their friction columns
    # match the noise-free equations at least twice as well once compensated.
    rows = arm2.rows_provider()
    settings = OnlineSettings.for_model("power", window=20.0, bandwidth=0.62)
    compensated = dataclasses.replace(settings, position_noise=0.05)
    end = exact_2r.num_samples - 1
    clean = window_equations(rows, settings, exact_2r.q, exact_2r.tau, end, H)[0]
    mean = {"plain": 0.0, "compensated": 0.0}
    for seed in range(6):
        e = 0.05 * np.random.default_rng(seed).standard_normal(exact_2r.q.shape)
        for sign in (1.0, -1.0):
            q = exact_2r.q + sign * e
            for key, s in (("plain", settings), ("compensated", compensated)):
                mean[key] += window_equations(rows, s, q, exact_2r.tau, end, H)[0] / 12
    error = {
        key: np.linalg.norm(a - clean, axis=0) / np.linalg.norm(clean, axis=0)
        for key, a in mean.items()
    }
    friction = slice(4, 8)
    assert error["plain"][friction].sum() > 2.0 * error["compensated"][friction].sum()
    assert np.all(error["compensated"][2:4] <= error["plain"][2:4])  # MX2, MY2
    np.testing.assert_allclose(error["plain"][:2], error["compensated"][:2], rtol=1e-9)


def test_position_noise_setting_is_checked():
    with pytest.raises(ValueError, match=r"noise bias of the power model's rows"):
        OnlineSettings(position_noise=0.01)
    with pytest.raises(ValueError, match=r"position_noise must be None, a std >= 0"):
        OnlineSettings(model="power", position_noise=-1.0)
    with pytest.raises(TypeError, match=r"position_noise must be None"):
        OnlineSettings(model="power", position_noise="0.1")
    settings = OnlineSettings(model="power", position_noise=[0.1, 0.2])
    assert settings.position_noise == (0.1, 0.2)
    with pytest.raises(ValueError, match=r"one std per joint \(7\)"):
        settings.for_log(H, 60.0, num_joints=7, num_parameters=57)
    unnamed = SimpleNamespace(
        num_joints=1, num_parameters=1, names=("A",), friction=("viscous",)
    )
    unnamed.sign = EXACT_SIGN
    with pytest.raises(ValueError, match=r"rows must name the friction column of "):
        noise_compensated_rows(unnamed, 0.1, 0.0)
    with pytest.raises(ValueError, match=r"velocity_std must be finite and >= 0"):
        noise_compensated_rows(unnamed, -0.1, 0.0)


def test_cli_measures_prints_and_echoes_the_position_noise(
    arm2, exact_2r, tmp_path, capsys
):
    noise = 0.01 * np.random.default_rng(1).standard_normal(exact_2r.q.shape)
    path = tmp_path / "log.csv"
    write_log(path, exact_2r.t, exact_2r.q + noise, exact_2r.tau, exact_2r.joint_names)
    common = ["identify", "--urdf", str(arm2.path), "--model", "power"]
    common += ["--update-period", "0.5", str(path)]
    out = tmp_path / "out.json"
    assert cli.main([*common, "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert re.search(r"position noise: 0\.0\d+, 0\.0\d+ \(measured on the log", printed)
    document = json.loads(out.read_text())
    measured = document["settings"]["position_noise"]
    assert document["settings"]["position_noise_measured"] is True
    np.testing.assert_allclose(measured, 0.01, rtol=0.05)
    # The covariance weighting's σ models the regressor noise: no bootstrap by default.
    assert document["settings"]["weighting"] == "covariance"
    assert document["bootstrap"]["applied"] is False
    assert document["bootstrap"]["replicates"] == 0
    assert "covariance weighting's σ models" in document["bootstrap"]["reason"]
    # A given torque noise with the power model's default weighting (was refused
    # as if the weighting were 'frequency'); an asked bootstrap uses the given std.
    argv = [*common, "--json", str(out), "--torque-noise", "0.3", "--bootstrap", "3"]
    assert cli.main(argv) == 0
    capsys.readouterr()
    document = json.loads(out.read_text())
    assert document["settings"]["weighting"] == "covariance"
    assert document["settings"]["torque_noise"] == 0.3
    assert document["bootstrap"]["applied"] is True
    assert document["bootstrap"]["torque_noise"] == [0.3, 0.3]
    np.testing.assert_allclose(document["bootstrap"]["position_noise"], measured)
    assert cli.main([*common, "--json", str(out), "--position-noise", "none"]) == 0
    assert "position noise" not in capsys.readouterr().out
    assert json.loads(out.read_text())["settings"]["position_noise"] is None
    assert cli.main([*common, "--json", str(out), "--position-noise", "0.02,0"]) == 0
    assert "position noise: 0.02, 0 (--position-noise)" in capsys.readouterr().out
    assert json.loads(out.read_text())["settings"]["position_noise"] == [0.02, 0.0]
    code = cli.main([*common[:3], "--position-noise", "0.01", str(path)])
    assert code == 2
    assert "--position-noise compensates the noise bias of the power model" in (
        capsys.readouterr().err
    )
    assert cli.main([*common, "--position-noise", "x"]) == 2
    assert "--position-noise must be 'auto', 'none' or stds" in capsys.readouterr().err


def test_replay_uses_the_compensated_rows(arm2, exact_2r):
    # The drivers wrap the rows (tests/test_fast_replay.py checks blocks == core
    # with position_noise): the compensation reaches the estimate.
    noisy = dataclasses.replace(
        exact_2r,
        q=exact_2r.q + 0.02 * np.random.default_rng(2).standard_normal((21001, 2)),
    )
    base = OnlineSettings.for_model(
        "power", window=20.0, bandwidth=0.62, update_period=0.5
    )
    runs = [base, dataclasses.replace(base, position_noise=0.02)]
    traces = replay_log_core(noisy, arm2.rows_provider(), runs)
    final = [trace.final()["theta"] for trace in traces]
    assert traces[1].settings.position_noise == 0.02
    assert np.abs(final[0] - final[1]).max() > 1e-4 * np.abs(final[0]).max()
