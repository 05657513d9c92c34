"""Every example runs with its short-run flag (one test per example; append yours).

Each example is imported from examples/ by path and its ``main(argv)`` is called
with ``--quick`` and a temporary ``--out`` directory.
"""

import importlib.util
import pathlib
import re
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def load_example(name):
    # The scripts import their shared frame (examples/_example.py) by name, as
    # when run from the command line.
    folder = str(ROOT / "examples")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    path = ROOT / "examples" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"example_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_jacobi_velocity_quick(tmp_path, capsys):
    example = load_example("jacobi_velocity")
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "jacobi_velocity.png").stat().st_size > 10_000
    assert (tmp_path / "jacobi_tuning.png").stat().st_size > 10_000
    rms = float(re.search(r"RMS error: ([0-9.]+) rad/s", printed).group(1))
    # closed-form prediction 0.038 rad/s for the default settings (seed 1)
    assert rms < 0.06
    delay = float(re.search(r"delay: ([0-9.]+) s", printed).group(1))
    assert abs(delay - 0.110557) < 1e-6


def test_paper_fig3_quick(tmp_path, capsys):
    example = load_example("paper_fig3")
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "fig3_estimates.png").stat().st_size > 10_000
    assert "| lagrangian |" in printed and "| power |" in printed
    # Found by a new user's walk-through: numpy's repr of the errors broke a
    # row over two lines ('(error % [-6.69600e+01  9.70200e+01 ...\n  9.7...]')
    # and the time printed as 3.3000000000000003 s.
    rows = [line for line in printed.splitlines() if line.startswith("| power |")]
    assert len(rows) == 1 and rows[0].endswith(")"), printed
    assert re.search(r"error % -?\d[\d.e+-]*(, -?\d[\d.e+-]*){7}; first", rows[0])
    assert re.search(r"first valid at t = \d+(\.\d{1,3})? s", rows[0]), rows[0]


def test_paper_fig4_quick(tmp_path, capsys):
    example = load_example("paper_fig4")
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "fig4_tracking.png").stat().st_size > 10_000
    # SNR 30 dB, T = 3 s, jump at 4 s: the Lagrangian estimate ends near 4.5.
    final = float(re.search(r"lagrangian: .* at the end ([0-9.]+);", printed).group(1))
    assert abs(final - 4.5) < 0.05 * 4.5
    # Found by a new user's walk-through: the power model, outside the band at
    # the end of the quick run, was "within 2 % of 4.5 from inf s after the jump".
    assert "inf" not in printed, printed
    assert re.search(r"^power: .*; not within 2 % of 4\.5 at the end ", printed, re.M)


def test_fig4_settling_time_helper():
    import numpy as np

    example = load_example("paper_fig4")
    t = np.arange(0.0, 10.0, 0.5)
    estimate = np.where(t < 6.0, 3.9, 4.5)
    estimate[t == 7.0] = 4.0  # leaves the band once after entering it
    assert example.settling_time(t, estimate, 4.5, after=5.0) == 2.5
    assert example.settling_time(t, np.full_like(t, 3.9), 4.5, after=5.0) == np.inf


def test_paper_fig1_quick(tmp_path, capsys):
    example = load_example("paper_fig1")
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert (tmp_path / "fig1_estimates.png").stat().st_size > 10_000
    paper = re.search(r"\| paper form \(k = 2\) \| ([0-9.]+) \|", printed)
    # ZZ = 3 within 3 % after 6 s with T = 4 s at SNR 40 dB.
    assert abs(float(paper.group(1)) - 3.0) < 0.09


def test_paper_table2_quick(tmp_path, capsys):
    example = load_example("paper_table2")
    assert example.main(["--quick", "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    for name in ("table2.md", "table2.csv", "table2_estimates.png"):
        assert (tmp_path / name).stat().st_size > 100
    assert "| on-line Lagrangian |" in printed and "| off-line IDIM-LS |" in printed
    lagrangian = re.search(r"\| on-line Lagrangian \| ([0-9.]+) \|", printed)
    # ZZ1R within 3 % with T = 6 s at SNR 30 dB (seed 1).
    assert abs(float(lagrangian.group(1)) - 3.9) < 0.03 * 3.9


def test_payload_pick_never_writes_its_log_over_a_script(tmp_path):
    """Found by a review: --log examples/payload_pick.py replaced the script."""
    example = load_example("payload_pick")
    script = tmp_path / "payload_pick.py"
    script.write_text("print('me')\n")
    with pytest.raises(SystemExit) as stop:
        example.main(["--quick", "--log", str(script), "--out", str(tmp_path)])
    assert stop.value.code == 2 and script.read_text() == "print('me')\n"
    with pytest.raises(SystemExit):
        example.main(["--pick", "8", "--place", "7", "--out", str(tmp_path)])


@pytest.mark.parametrize(
    ("name", "argv"),
    [
        ("paper_table2", ["--window", "0"]),
        ("paper_table2", ["--window", "20", "--duration", "10"]),
        ("paper_fig4", ["--jump-time", "30"]),
        ("paper_fig3", ["--window", "30"]),
        ("paper_fig1", ["--duration", "0"]),
        ("jacobi_velocity", ["--window", "0"]),
    ],
)
def test_examples_refuse_bad_options_before_any_work(name, argv, tmp_path):
    """Found by a review: --window 0 was a traceback, a duration shorter than the
    window printed -100 % errors, a jump after the end "from inf s"."""
    with pytest.raises(SystemExit) as stop:
        load_example(name).main([*argv, "--out", str(tmp_path)])
    assert stop.value.code == 2


EXAMPLES = (
    "jacobi_velocity",
    "paper_fig1",
    "paper_fig3",
    "paper_fig4",
    "paper_table2",
    "payload_pick",
)


@pytest.mark.parametrize("name", EXAMPLES)
def test_an_out_that_is_a_file_exits_2_naming_it(name, tmp_path, capsys):
    """Found by a review: ``--out`` naming a file (or a path under one) was a
    FileExistsError (NotADirectoryError) traceback, exit 1."""
    taken = tmp_path / "table.csv"
    taken.write_text("kept\n")
    for out in (taken, taken / "figures"):
        with pytest.raises(SystemExit) as stop:
            load_example(name).main(["--quick", "--out", str(out)])
        assert stop.value.code == 2
        assert f"--out {out}: not a folder" in capsys.readouterr().err
    assert taken.read_text() == "kept\n"


@pytest.mark.parametrize("name", ["paper_fig1", "paper_table2"])
@pytest.mark.parametrize("snr", ["nan", "inf", "-inf"])
def test_a_non_finite_snr_exits_2_naming_it(name, snr, tmp_path, capsys):
    """Found by a review: ``--snr nan`` was SimulationSettings' ValueError
    traceback, exit 1."""
    with pytest.raises(SystemExit) as stop:
        load_example(name).main(["--quick", f"--snr={snr}", "--out", str(tmp_path)])
    assert stop.value.code == 2
    assert "--snr must be a finite SNR [dB]" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "argv", "message"),
    [
        ("paper_table2", ["--seed", "-1", "--quick"], "seed must be >= 0; got -1"),
        ("paper_table2", ["--duration", "1e9"], "at most 1e+07 simulation steps"),
        ("payload_pick", ["--duration", "1e9"], "at most 1e+07 simulation steps"),
        ("payload_pick", ["--seed", "-1", "--quick"], "--seed must be >= 0; got -1"),
        ("jacobi_velocity", ["--seed", "-1", "--quick"], "--seed must be in [0, 2^32)"),
        (
            "jacobi_velocity",
            ["--q", "99", "--quick"],
            "q must be an integer in [0, 10]",
        ),
        (
            "paper_fig4",
            ["--window", "1e-3", "--jump-time", "1", "--duration", "2"],
            "jacobi_window must be < window",
        ),
    ],
)
def test_a_value_the_library_refuses_exits_2_naming_it(
    name, argv, message, tmp_path, capsys
):
    """Found by a review: values the library's checks refuse (a negative seed, a
    window shorter than the differentiator's) were ValueError or TypeError
    tracebacks, exit 1, and --duration 1e9 a 745 GiB MemoryError."""
    with pytest.raises(SystemExit) as stop:
        load_example(name).main([*argv, "--out", str(tmp_path)])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(
    ("name", "given", "presets"),
    [
        ("paper_fig1", {"duration": "7.5"}, {}),
        ("paper_fig1", {"snr": "30"}, {"duration": 6.0}),
        ("paper_fig3", {"window": "2"}, {"duration": 4.0}),
        ("paper_fig4", {"window": "5", "jump_time": "6"}, {"duration": 8.0}),
        ("paper_table2", {"window": "5"}, {}),
        ("paper_table2", {"duration": "9"}, {"window": 6.0}),
        ("payload_pick", {"duration": "2.5", "place": "2"}, {"pick": 1.5}),
    ],
)
def test_explicit_options_win_over_quick(name, given, presets, monkeypatch):
    """Found by a review: ``--quick --window 5`` ran with --quick's window (3 s,
    6 s in paper_table2), the explicit option ignored without a word."""
    example = load_example(name)
    seen = []
    monkeypatch.setattr(example, "_run", lambda args, parser: seen.append(args) or 0)
    argv = ["--quick"]
    for key, value in given.items():
        argv += [f"--{key.replace('_', '-')}", value]
    assert example.main(argv) == 0
    for key, value in given.items():
        assert getattr(seen[-1], key) == float(value), key
    for key, value in presets.items():  # the options not given: --quick's
        assert getattr(seen[-1], key) == value, key
    assert example.main([]) == 0  # without --quick: the parser's defaults
    assert all(getattr(seen[-1], key) != value for key, value in presets.items())
