"""BLAS/OpenMP pools of one thread in the replays and the CLI (core/_threads.py).

Each test first widens the loaded pools to 2 threads (``thread_limit(2)``), so it
fails if the code under test leaves them alone; a row provider records the pool
sizes while the replay computes its rows. The log: a noise-free random Fourier
motion of the 2R arm (numpy default_rng(4)), τ from its inverse-dynamics rows.
"""

import subprocess
import sys

import numpy as np
import pytest

from drake_dynid import cli
from drake_dynid.core._threads import (
    ENVIRONMENT,
    configure_process,
    thread_counts,
    thread_limit,
    tune_allocator,
)
from drake_dynid.core.online import OnlineSettings
from drake_dynid.core.replay import replay_log_core
from drake_dynid.core.trajectory import random_fourier_trajectory
from drake_dynid.diagrams import replay_log
from drake_dynid.logs import RobotLog
from drake_dynid.plants import RobotModel, model_path

SETTINGS = [
    OnlineSettings(
        window=0.5,
        frequencies=np.arange(4.0),
        jacobi_window=0.1,
        bank_time_step=0.01,
        update_period=0.1,
    )
]


@pytest.fixture(autouse=True)
def default_environment(monkeypatch):
    for variable in (*ENVIRONMENT, "DYNID_THREADS"):
        monkeypatch.delenv(variable, raising=False)


@pytest.fixture(scope="module")
def robot():
    return RobotModel.from_urdf(model_path("planar_2r"))


@pytest.fixture(scope="module")
def log(robot):
    trajectory = random_fourier_trajectory(
        2,
        harmonics=3,
        base_frequency=2 * np.pi * 0.5,
        max_velocity=3.0,
        rng=np.random.default_rng(4),
    )
    t = 1e-3 * np.arange(1001)
    q, v, vdot = trajectory.evaluate(t)
    tau = robot.idim_rows(q, v, vdot) @ robot.base_values
    return RobotLog(t, q, tau, robot.joint_names, 1e-3)


class RecordingRows:
    """Delegates to a row provider; records the pool sizes at every rows call."""

    def __init__(self, rows):
        self._rows = rows
        self.num_joints = rows.num_joints
        self.num_parameters = rows.num_parameters
        self.names = rows.names
        self.counts = []

    def model_rows(self, kind, q, v, tau):
        self.counts.append(thread_counts())
        return self._rows.model_rows(kind, q, v, tau)


def _widened():
    counts = thread_counts()
    if not counts:
        pytest.skip("no BLAS/OpenMP pool is loaded")
    return counts


@pytest.mark.parametrize("replay", [replay_log_core, replay_log])
def test_a_replay_runs_with_one_blas_thread(robot, log, replay):
    rows = RecordingRows(robot.rows_provider())
    with thread_limit(2):
        if set(_widened().values()) != {2}:
            pytest.skip("this BLAS does not let its pool grow to 2 threads")
        (trace,) = replay(log, rows, SETTINGS)
        after = thread_counts()
    assert rows.counts and all(set(c.values()) == {1} for c in rows.counts)
    assert set(after.values()) == {2}  # restored on exit
    assert np.asarray(trace.valid)[-1] > 0.5


def test_the_cli_pins_the_loaded_pools(capsys):
    with thread_limit(2):
        if set(_widened().values()) != {2}:
            pytest.skip("this BLAS does not let its pool grow to 2 threads")
        assert cli.main(["params", str(model_path("planar_2r"))]) == 0
        assert set(thread_counts().values()) == {1}
    assert "base parameters" in capsys.readouterr().out


@pytest.mark.parametrize(("argv", "expected"), [([], 1), (["--threads", "2"], 2)])
def test_the_cli_sets_the_environment_before_numpy_is_imported(argv, expected):
    code = (
        "import sys\n"
        "from drake_dynid import cli\n"
        f"cli._configure({argv!r})\n"
        "assert 'numpy' not in sys.modules\n"
        "import numpy, scipy.linalg\n"
        "from drake_dynid.core._threads import thread_counts\n"
        "print(sorted(set(thread_counts().values())))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() in (f"[{expected}]", "[]")


def test_bad_thread_counts_are_rejected(capsys):
    with pytest.raises(ValueError, match="threads must be an integer >= 1"):
        configure_process(-1)
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--threads", "many", "params", str(model_path("planar_2r"))])
    assert exit_info.value.code == 2
    assert "--threads: must be an integer >= 0 or 'auto'" in capsys.readouterr().err


def test_the_allocator_is_tuned_on_glibc():
    if not sys.platform.startswith("linux"):
        pytest.skip("glibc only")
    assert tune_allocator() is True
