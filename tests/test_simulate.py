"""``dynid simulate`` (drake_dynid.experiment): a first log from a URDF.

Done-when checks: the excite -> simulate -> offline path on the paper's 2R arm
(20 s, default noise, seed 0) recovers every well-excited base parameter (predicted
%σ <= 0.1 by dynid excite) within 1 % of the truth file (the 7-DOF and UR5 numbers
are in benchmarks/bench_excite.py); runs that leave the limits or diverge exit 2
naming the joint, the time and the limit; outputs never overwrite inputs.
"""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core.joint_limits import JointLimits
from drake_dynid.experiment import ExperimentSettings, simulate_experiment
from drake_dynid.logs import read_log
from drake_dynid.offline import identify_offline
from drake_dynid.robot import RobotModel
from drake_dynid.trajectory_file import SampledTrajectory, write_trajectory
from drake_dynid.urdf import model_path

LIMITS_2R = {
    "joint1": {"lower": -3.0, "upper": 3.0, "velocity": 3.0, "effort": 100.0},
    "joint2": {"lower": -3.0, "upper": 3.0, "velocity": 3.0, "effort": 100.0},
}


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    """excite (20 s) then simulate on the 2R arm; paths of the files."""
    folder = tmp_path_factory.mktemp("experiment")
    limits = folder / "limits.json"
    limits.write_text(json.dumps(LIMITS_2R))
    urdf = model_path("planar_2r")
    files = {
        "urdf": urdf,
        "limits": str(limits),
        "traj": str(folder / "traj.csv"),
        "coeffs": str(folder / "traj.json"),
        "log": str(folder / "log.csv"),
    }
    argv = [
        "excite", urdf, "--limits", files["limits"], "--duration", "20",
        "--out", files["traj"], "--json", files["coeffs"], "--quiet",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    argv = [
        "simulate", urdf, "--trajectory", files["traj"], "--limits", files["limits"],
        "--out", files["log"], "--quiet",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    return files


def test_offline_recovers_the_well_excited_parameters(experiment, tmp_path):
    robot = RobotModel.from_urdf(experiment["urdf"])
    truth = json.loads(
        Path(experiment["log"].replace(".csv", ".truth.json")).read_text()
    )
    # The truth file is the dynid params --json document of the same URDF.
    params = tmp_path / "params.json"
    assert cli.main(["params", experiment["urdf"], "--json", str(params)]) == 0
    expected = json.loads(params.read_text())
    assert truth["parameters"] == expected["parameters"]
    assert truth["simulation"]["seed"] == 0 and truth["simulation"]["rate"] == 1000
    log = read_log(experiment["log"], robot.joint_names)
    assert log.num_samples == 20001 and log.time_step == pytest.approx(1e-3)
    result = identify_offline(log, robot)
    assert result.valid
    true = {p["name"]: p["value"] for p in truth["parameters"]}
    predicted = json.loads(Path(experiment["coeffs"]).read_text())["predicted"]
    well = [
        p["name"]
        for p in predicted
        if p["relative_std_percent"] is not None and p["relative_std_percent"] <= 0.1
    ]
    assert len(well) >= 5
    for name in well:
        estimate = result.theta[result.names.index(name)]
        assert abs(estimate - true[name]) <= 0.01 * abs(true[name]), name


def _limits_2r(**changes):
    values = {
        "lower": [-3.0, -3.0],
        "upper": [3.0, 3.0],
        "velocity": [3.0, 3.0],
        "effort": [100.0, 100.0],
    }
    values.update(changes)
    return JointLimits(("joint1", "joint2"), **values)


def _reference(q, v, t):
    return SampledTrajectory(t, q, v, np.full_like(q, np.nan), ("joint1", "joint2"))


def _sine(duration=2.0, amplitude=1.0, frequency=0.5):
    t = np.arange(0.0, duration + 1e-9, 0.01)
    w = 2 * np.pi * frequency
    q = amplitude * np.column_stack([np.sin(w * t), 0.5 * np.sin(2 * w * t)])
    v = amplitude * np.column_stack([w * np.cos(w * t), w * np.cos(2 * w * t)])
    return _reference(q, v, t)


def _too_tight_tracking():
    """A tracking threshold below what the controller achieves: the run stops."""
    with pytest.raises(ValueError, match=r"tracking error of joint joint\d reached"):
        simulate_experiment(
            model_path("planar_2r"),
            _sine(),
            _limits_2r(),
            ExperimentSettings(max_tracking_error=1e-6),
        )


def test_noise_is_seeded_and_decimated():
    urdf = model_path("planar_2r")
    settings = ExperimentSettings(rate=500.0, seed=3)
    first = simulate_experiment(urdf, _sine(), _limits_2r(), settings)
    again = simulate_experiment(urdf, _sine(), _limits_2r(), settings)
    np.testing.assert_array_equal(first.q, again.q)
    np.testing.assert_array_equal(first.tau, again.tau)
    assert first.t[1] == pytest.approx(0.002) and first.t.size == 1001
    noise = first.q - first.q_true
    assert np.std(noise) == pytest.approx(1e-4, rel=0.1)
    other = simulate_experiment(
        urdf, _sine(), _limits_2r(), ExperimentSettings(rate=500.0, seed=4)
    )
    assert not np.array_equal(other.q, first.q)
    # The noise-free log tracks the reference.
    assert first.max_tracking_error.max() < 1e-2


def test_reference_outside_the_position_limits_is_refused():
    with pytest.raises(ValueError, match=r"joint joint1 reaches 1 rad at t = 0\.500"):
        simulate_experiment(
            model_path("planar_2r"), _sine(), _limits_2r(upper=[0.8, 3.0])
        )


def test_divergence_is_stopped_with_the_joint_and_the_time():
    # Effort limit 0.5 N·m: the commands exceed 10x of it within the first steps.
    with pytest.raises(ValueError, match=r"diverged: joint joint1 was commanded .*"):
        simulate_experiment(
            model_path("planar_2r"), _sine(), _limits_2r(effort=[0.5, 100.0])
        )
    # A step in the reference: its spline asks for 3e4 rad/s² within 10 ms.
    step = _sine()
    q = step.q.copy()
    q[100:, 1] += 0.5
    jump = _reference(q, step.v, step.t)
    with pytest.raises(ValueError, match=r"diverged: .* at t = 0\.99"):
        simulate_experiment(model_path("planar_2r"), jump, _limits_2r())
    # A threshold below what the controller achieves.
    _too_tight_tracking()


def test_motion_leaving_the_limits_during_the_run(tmp_path, capsys):
    # The reference stays inside 1.3 rad; the step makes joint 2 overshoot it.
    step = _sine(amplitude=1.0)
    q = step.q.copy()
    q[100:, 1] = np.clip(q[100:, 1] + 0.79, None, 1.29)
    path = tmp_path / "jump.csv"
    write_trajectory(path, _reference(q, step.v, step.t))
    limits = tmp_path / "limits.json"
    limits.write_text(json.dumps({"joint2": {"lower": -1.3, "upper": 1.3}}))
    argv = [
        "simulate", model_path("planar_2r"), "--trajectory", str(path), "--limits",
        str(limits), "--max-tracking-error", "5", "--out", str(tmp_path / "log.csv"),
    ]  # fmt: skip
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "left the position limits: joint joint2 reached" in err
    assert "(limit 1.3 rad)" in err and "Traceback" not in err
    assert not (tmp_path / "log.csv").exists()


def test_cli_bad_input_exits_2(experiment, tmp_path, capsys):
    urdf, traj = experiment["urdf"], experiment["traj"]
    cases = [
        (["--out", traj], "is an input of this command"),
        (["--out", str(tmp_path / "x.csv"), "--snr", "30", "--noise-q", "1e-3"],
         "either --snr or --noise-q"),
        (["--out", str(tmp_path / "x.csv"), "--rate", "300"], "rate must divide"),
        (["--out", str(tmp_path / "x.csv"), "--duration", "50"],
         "duration must be <= the trajectory's 20 s"),
    ]  # fmt: skip
    for extra, message in cases:
        argv = ["simulate", urdf, "--trajectory", traj, *extra]
        assert cli.main(argv) == 2, extra
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err
    bad = tmp_path / "bad.csv"
    bad.write_text("t,q_joint1,v_joint1\n0,0,0\n")
    argv = ["simulate", urdf, "--trajectory", str(bad), "--out", str(tmp_path / "y")]
    assert cli.main(argv) == 2
    assert "missing column(s) q_joint2, v_joint2" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--duration", "1e-12"], "at least 16 samples"),
        (["--duration", "1e-12"], "--duration >= 0.015 [s]; got --duration 1e-12"),
        (["--rate", "0.001"], "the trajectory lasts 20 s (1 sample)"),
        (["--rate", "10", "--duration", "1"], "--duration >= 1.5 [s]"),
        (["--snr", "-10"], "--snr must be in [0, 400] [dB]"),
        (["--noise-tau", "5"], "--noise-tau must be in [0, 1]"),
        (["--noise-q", "10"], "--noise-q must be below the motion"),
        (["--noise-q", "-1"], "--noise-q must be >= 0"),
        (["--time-step", "0.5", "--rate", "2"], "--time-step must be <= 1/kd = 0.01 s"),
        # With the default --rate, the step's own bound is what is named, not the
        # rate that does not divide 1/--time-step (README "Bad options").
        (["--time-step", "0.02"], "--time-step must be <= 1/kd = 0.01 s"),
        (["--max-tracking-error", "0"], "--max-tracking-error must be > 0"),
        (["--meshcat-wait"], "--meshcat-wait needs --meshcat"),
        (["--drive", "no_such.toml"], "no_such.toml: no such file"),
    ],
)
def test_bad_options_exit_2_naming_the_option(
    experiment, tmp_path, capsys, extra, message
):
    argv = [
        "simulate", experiment["urdf"], "--trajectory", experiment["traj"],
        "--limits", experiment["limits"], "--out", str(tmp_path / "log.csv"), *extra,
    ]  # fmt: skip
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err, err
    assert not (tmp_path / "log.csv").exists()


def test_the_shortest_log_is_accepted_and_identifiable_in_principle(
    experiment, tmp_path
):
    # 16 samples at 1 kHz: the floor is a floor, not a promise (the fit says why).
    out = tmp_path / "short.csv"
    argv = [
        "simulate", experiment["urdf"], "--trajectory", experiment["traj"],
        "--limits", experiment["limits"], "--duration", "0.015", "--out", str(out),
        "--quiet",
    ]  # fmt: skip
    assert cli.main(argv) == 0
    assert read_log(out, ("joint1", "joint2")).num_samples == 16


def test_meshcat_replay_runs_headless_and_exits(experiment, tmp_path, capsys):
    out = tmp_path / "log.csv"
    argv = [
        "simulate", experiment["urdf"], "--trajectory", experiment["traj"],
        "--limits", experiment["limits"], "--duration", "2", "--meshcat",
        "--out", str(out),
    ]  # fmt: skip
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    assert re.search(r"Meshcat: http://localhost:\d+ \(65 frames\)", captured.out)
    assert "links are shown by their inertia" in captured.err
    page = tmp_path / "log.meshcat.html"
    assert page.is_file() and "animation" in page.read_text(encoding="utf-8")


def test_replay_of_a_trajectory_and_its_bad_options(experiment, tmp_path, capsys):
    urdf, traj = experiment["urdf"], experiment["traj"]
    page = tmp_path / "traj.html"
    assert cli.main(["replay", urdf, traj, "--html", str(page), "--quiet"]) == 0
    assert re.fullmatch(r"Meshcat: http://localhost:\d+\n", capsys.readouterr().out)
    assert page.is_file()
    for extra, message in [
        (["--fps", "0"], "--fps must be > 0 [Hz]"),
        (["--fps", "1e9"], "at most 115201 frames"),
        (["--fps", "1e9"], "Hz or less, or replay part of the log"),
        (["--html", traj], "--html "),
    ]:
        assert cli.main(["replay", urdf, traj, *extra]) == 2
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err


@pytest.mark.parametrize("rate", [1000.0, 250.0])
def test_the_simulation_in_chunks_is_the_simulation_in_one_piece(monkeypatch, rate):
    """The Simulator advances CHUNK_SECONDS at a time, the loggers handing over the
    kept rows and the reference holding that chunk's Hermite pieces: the same log,
    bit for bit, as one AdvanceTo with the whole reference (chunks of 0.37 s, not
    a multiple of the knots' 10 ms nor of the decimation)."""
    from drake_dynid import experiment

    urdf = model_path("planar_2r")
    settings = ExperimentSettings(rate=rate, seed=5)
    logs = []
    for seconds in (1e9, 0.37):
        monkeypatch.setattr(experiment, "CHUNK_SECONDS", seconds)
        logs.append(simulate_experiment(urdf, _sine(), _limits_2r(), settings))
    whole, chunked = logs
    for name in ("t", "q", "tau", "q_true", "tau_true", "noise_std"):
        np.testing.assert_array_equal(getattr(chunked, name), getattr(whole, name))
    np.testing.assert_array_equal(chunked.max_tracking_error, whole.max_tracking_error)
    assert chunked.saturated == whole.saturated
    assert whole.t.size == round(2.0 * rate) + 1


def test_a_run_the_monitor_stops_is_not_continued(monkeypatch):
    """A failure mid-chunk ends the run: no later chunk steps on from the failed
    state (review: it used to, and a later divergence could change the error)."""
    from pydrake.systems.primitives import TrajectorySource

    from drake_dynid import experiment

    monkeypatch.setattr(experiment, "CHUNK_SECONDS", 0.1)
    pieces = []
    update = TrajectorySource.UpdateTrajectory
    monkeypatch.setattr(
        TrajectorySource,
        "UpdateTrajectory",
        lambda self, piece: (pieces.append(piece.end_time()), update(self, piece)),
    )
    _too_tight_tracking()
    assert len(pieces) <= 1, pieces  # 2 s in chunks of 0.1 s: 19 before the fix


def test_a_coulomb_friction_too_stiff_for_the_step_is_named():
    """Found by a review: the UR5's wrist 3 (FC 0.3 N·m on about 1e-4 kg·m²)
    chatters under the explicit tanh(v/0.01) law at 1 ms, and a failed run said
    "lower its speed or raise the gains"."""
    import numpy as np

    from drake_dynid.experiment import stiff_coulomb
    from drake_dynid.experiment_drive import simulated_drive_of, truth_model
    from drake_dynid.plants import model_path
    from drake_dynid.urdf import load_plant

    urdf = model_path("ur5")
    drive = simulated_drive_of(truth_model(urdf, ("viscous", "coulomb")), 0.01)
    plant = load_plant(urdf, 1e-3)
    context = plant.CreateDefaultContext()
    speed = np.full(6, 2.0)  # rad/s
    stiff = stiff_coulomb(plant, context, drive, np.zeros((1, 6)), 1e-3, speed)
    assert set(stiff) == {5}  # wrist_3_joint only: 3.6 rad/s per step
    assert "--friction viscous" in stiff[5] and "--time-step" in stiff[5]
    assert stiff_coulomb(plant, context, drive, np.zeros((1, 6)), 1e-6) == {}


def test_a_step_simulate_would_refuse_is_not_suggested():
    """Found by a review: the Unitree Z1's gripper (FC 1 N·m on 2.9e-4 kg·m²) on a
    60 s trajectory was told "simulate with --time-step 5e-06 (slow)", which
    simulate then refused (1.2e7 steps, more than its 1e7); the TIAGo's wrist was
    told 6.4e-08 s. Holding the joint still (a gripper) was not offered."""
    import numpy as np

    from drake_dynid.experiment import MAX_STEPS, stiff_coulomb
    from drake_dynid.experiment_drive import simulated_drive_of, truth_model
    from drake_dynid.plants import model_path
    from drake_dynid.urdf import load_plant

    urdf = model_path("ur5")
    drive = simulated_drive_of(truth_model(urdf, ("viscous", "coulomb")), 0.01)
    plant = load_plant(urdf, 1e-3)
    context = plant.CreateDefaultContext()
    q, speed = np.zeros((1, 6)), np.full(6, 2.0)

    def advice(duration):
        return stiff_coulomb(
            plant, context, drive, q, 1e-3, speed, log_step=1e-3, duration=duration
        )[5]

    short = advice(10.0)  # wrist_3_joint: 5e-06 s, 2e6 steps
    assert "--time-step 5e-06 (slow)" in short
    assert "--lock wrist_3_joint=POSITION" in short
    long = advice(60.0)  # 1.2e7 steps
    assert "--time-step 5e-06" not in long and "1.2e+07 steps" in long
    assert f"more than the {MAX_STEPS:g}" in long and "duration 50 at most" in long
    assert "--friction viscous" in long and "--lock wrist_3_joint=POSITION" in long


def test_speeds_and_torques_beyond_the_limits_are_said():
    """Found by a review: a trajectory designed on the URDF's inflated limits ran
    an iiwa at 4.4x its datasheet speed under --limits without a word."""
    import types

    import numpy as np

    from drake_dynid.commands.simulate import _beyond_limits
    from drake_dynid.limits import joint_limits
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(model_path("ur5"))
    limits = joint_limits(robot)
    speed = 2.0 * np.asarray(limits.velocity)
    reference = types.SimpleNamespace(
        t=np.array([0.0, 1.0, 2.0]), v=np.vstack([0.5 * speed, speed, 3 * speed])
    )
    log = types.SimpleNamespace(tau_true=np.zeros((2, 6)), t=np.array([0.0, 1.0]))
    notes = _beyond_limits(reference, log, limits)
    assert len(notes) == 6 and "2x its limit" in notes[0], notes  # not 3x: unrun
    reference.v = 0.5 * reference.v
    assert _beyond_limits(reference, log, limits) == []


def test_the_suggested_step_divides_the_log_period():
    """Found by a review: 5.6e-06 s was suggested, then refused (--rate must
    divide 1/--time-step)."""
    from drake_dynid.experiment import _dividing_step

    assert _dividing_step(1e-3, 5.56e-6) == 5e-6
    assert _dividing_step(1e-3, 9e-5) == 6.25e-5  # 1e-3 / 16
    step = _dividing_step(1e-3, 1e-3)
    assert step == 1e-3
    # Found by a review: a drive file's coulomb = 1e300 hung simulate here (a loop
    # over about 1e300 divisors); the alarm turns a hang into a failure.
    import signal

    def hung(*_):
        raise TimeoutError("_dividing_step did not return")

    previous = signal.signal(signal.SIGALRM, hung)
    signal.alarm(60)
    try:
        assert _dividing_step(1e-3, 1e-3 / 1.234e15) == 1e-3 / 1.234e15
        assert _dividing_step(1e-3, 0.0) == 0.0
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_actuators_out_of_joint_order_log_each_joints_torque(tmp_path):
    """Drake's actuation input is in actuator order (the URDF's transmissions
    first, in file order): a review found the TIAGo's torque columns shifted by
    one joint (arm_5's transmission comes first) and clipped with the wrong
    limits. The 2R with its transmissions swapped simulates and logs as the 2R."""
    text = Path(model_path("planar_2r")).read_text()
    first = text.index('  <transmission name="joint1_transmission">')
    second = text.index('  <transmission name="joint2_transmission">')
    end = text.index("</robot>")
    swapped = text[:first] + text[second:end] + text[first:second] + text[end:]
    assert swapped != text
    urdf = tmp_path / "swapped.urdf"
    urdf.write_text(swapped)
    from drake_dynid.urdf import load_plant

    plant = load_plant(urdf)
    order = [plant.get_joint_actuator(i).joint().name()
             for i in plant.GetJointActuatorIndices()]  # fmt: skip
    assert order == ["joint2", "joint1"]
    limits = _limits_2r(effort=[100.0, 5.0])  # joint2's limit is the tighter
    settings = ExperimentSettings(noise_q=0.0, noise_tau=0.0)
    want = simulate_experiment(model_path("planar_2r"), _sine(), limits, settings)
    got = simulate_experiment(str(urdf), _sine(), limits, settings)
    np.testing.assert_allclose(got.q, want.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got.tau, want.tau, rtol=0, atol=1e-9)
    assert got.saturated == want.saturated


def test_a_joint_damped_far_above_its_inertia_tracks(tmp_path):
    """Drake damps implicitly: (M + h·D)(v_{k+1} − v_k)/h = τ − c − g − D v_k, so
    a command M·a + D v_k gave the joint (M + h·D)⁻¹M·a (the TIAGo's wrist: a
    251st of it, and the run stopped). The controller now commands with h·D added
    to the reflected inertia: a joint with h·FV five times its inertia tracks as
    an undamped one does."""
    text = Path(model_path("planar_2r")).read_text()
    damped = text.replace('damping="0.15"', 'damping="200"')
    assert damped != text
    urdf = tmp_path / "damped.urdf"
    urdf.write_text(damped)
    settings = ExperimentSettings(noise_q=0.0, noise_tau=0.0, friction=("viscous",))
    limits = _limits_2r(effort=[1000.0, 1000.0])
    want = simulate_experiment(model_path("planar_2r"), _sine(), limits, settings)
    got = simulate_experiment(str(urdf), _sine(), limits, settings)
    assert np.all(got.max_tracking_error <= 1.5 * want.max_tracking_error + 1e-5)


def test_the_stiff_coulomb_message_gives_its_units(tmp_path):
    """Found by a review (xArm7's joint 7, Unitree Z1's gripper): the message read
    "FC = 1 on an inertia as small as 0.00014 ... chatters at reversals, by up to
    7.4 per step", without units; a prismatic joint's are N, kg and m/s."""
    import numpy as np

    from drake_dynid.experiment import stiff_coulomb
    from drake_dynid.experiment_drive import simulated_drive_of, truth_model
    from drake_dynid.plants import model_path
    from drake_dynid.urdf import load_plant

    def named(urdf, n):
        drive = simulated_drive_of(truth_model(urdf, ("viscous", "coulomb")), 0.01)
        plant = load_plant(urdf, 1e-3)
        context = plant.CreateDefaultContext()
        return stiff_coulomb(plant, context, drive, np.zeros((1, n)), 1e-3)

    wrist = named(model_path("ur5"), 6)[5]
    assert "FC = 0.3 N·m" in wrist and "kg·m² is too stiff" in wrist
    assert "rad/s per step" in wrist
    slider = tmp_path / "slider.urdf"
    slider.write_text(
        """<robot name="slider">
  <link name="base"/>
  <link name="carriage">
    <inertial><mass value="0.01"/>
      <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="rail" type="prismatic">
    <parent link="base"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="10" velocity="1"/>
    <dynamics damping="0.1" friction="0.5"/>
  </joint>
</robot>
"""
    )
    rail = named(slider, 1)[0]
    assert "FC = 0.5 N on an inertia as small as 0.01 kg is" in rail
    assert "m/s per step" in rail and "rad" not in rail


def test_an_actuated_mimic_joint_is_named(tmp_path, capsys):
    """Found by a review: a <mimic> joint with a <transmission> gave "the plant's
    actuated joints are joint1, joint2" without a word about the mimic."""
    from pathlib import Path

    import numpy as np

    from drake_dynid import cli
    from drake_dynid.plants import model_path

    text = Path(model_path("planar_2r")).read_text()
    end = '<dynamics damping="0.15" friction="0.25"/>\n  </joint>'
    assert end in text
    mimic = '<dynamics damping="0.15" friction="0.25"/>\n    <mimic joint="joint1"/>'
    urdf = tmp_path / "mimic.urdf"
    urdf.write_text(text.replace(end, mimic + "\n  </joint>"))
    t = np.linspace(0.0, 2.0, 201)
    rows = "".join(f"{x},{0.1 * np.sin(x)},{0.1 * np.cos(x)}\n" for x in t)
    (tmp_path / "t.csv").write_text("t,q_joint1,v_joint1\n" + rows)
    argv = ["simulate", str(urdf), "--trajectory", str(tmp_path / "t.csv")]
    assert cli.main([*argv, "--out", str(tmp_path / "log.csv")]) == 2
    err = capsys.readouterr().err
    assert "joint2: a <mimic> joint with a <transmission>, which the simulator" in err
