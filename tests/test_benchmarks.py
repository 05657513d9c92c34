"""Every benchmark runs with --quick (one test per script; a smoke test, no timing).

Each script is imported from benchmarks/ by path and its ``main(argv)`` called with
``--quick`` and ``--json`` into a temporary directory. The accuracy benchmark also
checks its own first line: the core's window solve equals the Drake blocks in the loop.
"""

import importlib.util
import json
import pathlib
import re
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def load_benchmark(name, monkeypatch):
    # The scripts import their shared helper (benchmarks/_timing.py) by name, as
    # when run from the command line.
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    path = ROOT / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", path)
    module = importlib.util.module_from_spec(spec)
    # Registered while it runs, as an imported module is (a dataclass looks its
    # module up in sys.modules).
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    "name",
    [
        "bench_bank",
        "bench_bootstrap",
        "bench_cutoff",
        "bench_jacobi",
        "bench_long_logs",
        "bench_physical",
        "bench_pipeline",
        "bench_regressors",
        "bench_sigma",
        "bench_sigma_diagnosis",
        "bench_sigma_offline",
    ],
)
def test_benchmark_quick_run(name, tmp_path, capsys, monkeypatch):
    out = tmp_path / f"{name}.json"
    assert load_benchmark(name, monkeypatch).main(["--quick", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "|---" in printed  # a markdown table
    assert json.loads(out.read_text())


def test_quick_changes_the_defaults_not_the_options_given(monkeypatch, capsys):
    """Found by a review: ``--quick --seeds 10`` ran --quick's seeds (4, 8, 1 ...)
    in eight scripts; an option typed wins now (``_timing.quick_or``)."""
    timing = load_benchmark("_timing", monkeypatch)
    assert timing.quick_or(None, True, 4, 20) == 4
    assert timing.quick_or(None, False, 4, 20) == 20
    assert timing.quick_or(10, True, 4, 20) == 10
    assert timing.quick_or(0, True, 4, 20) == 0  # a typed 0 is a value
    bench = load_benchmark("bench_bootstrap", monkeypatch)
    seen = {}

    def cases(seeds, replicates, quick):
        seen["seeds"] = list(seeds)
        raise SystemExit(0)

    monkeypatch.setattr(bench, "two_r_cases", cases)
    with pytest.raises(SystemExit):
        bench.main(["--quick", "--seeds", "2"])
    assert seen["seeds"] == [0, 1]


def test_quick_keeps_a_typed_power_seeds(monkeypatch, capsys):
    """Found by a review of the above: bench_accuracy's --quick still capped a typed
    --power-seeds at 20 (``--quick --power-seeds 50`` ran 20)."""
    bench = load_benchmark("bench_accuracy", monkeypatch)
    seen = []

    def run_2r(args, seeds, report):
        seen.append(args.power_seeds)
        raise SystemExit(0)

    monkeypatch.setattr(bench, "run_2r", run_2r)
    for argv in (["--quick", "--power-seeds", "50"], ["--quick"], []):
        with pytest.raises(SystemExit):
            bench.main([*argv, "--robot", "2r"])
    assert seen == [50, 20, 200]


@pytest.mark.slow
def test_bench_accuracy_quick_run(tmp_path, capsys, monkeypatch):
    out = tmp_path / "accuracy.json"
    bench = load_benchmark("bench_accuracy", monkeypatch)
    assert bench.main(["--quick", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    check = re.search(r"Lagrangian ([0-9.e+-]+), power ([0-9.e+-]+)", printed)
    assert float(check.group(1)) < 1e-9 and float(check.group(2)) < 1e-9
    assert "| on-line Lagrangian |" in printed and "| off-line IDIM-WLS |" in printed
    assert json.loads(out.read_text())["block_check"] == pytest.approx(
        [float(check.group(1)), float(check.group(2))], rel=0.1
    )


def test_bench_dead_zone_coupled_wrist_small_run(tmp_path, capsys, monkeypatch):
    """The coupled-wrist rows (helper-70) run: a smoke test on 2 seeds of 10 s."""
    out = tmp_path / "dz.json"
    bench = load_benchmark("bench_dead_zone", monkeypatch)
    argv = ["--seeds", "2", "--robot", "ur5-wrist", "--rates", "125"]
    argv += ["--truth", "sign", "--duration", "10", "--json", str(out)]
    assert bench.main(argv) == 0
    assert "| ur5-wrist, FC only | sign | 125 Hz |" in capsys.readouterr().out
    rows = json.loads(out.read_text())["rows"]
    assert [row["robot"] for row in rows] == ["ur5-wrist", "ur5-wrist, FC only"]
    assert all(set(row) >= {"dead zone", "exact sign"} for row in rows)
