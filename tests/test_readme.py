"""The README quick start holds exactly two commands, and CI runs the second; the
README's snippets and shown outputs are what the code runs and prints."""

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def quick_start_commands():
    text = (ROOT / "README.md").read_text()
    section = text.split("## Quick start", 1)[1]
    block = re.search(r"```bash\n(.*?)```", section, re.S).group(1)
    return [line for line in block.splitlines() if line.strip()]


def test_quick_start_has_two_commands():
    commands = quick_start_commands()
    assert len(commands) == 2
    assert "pip install" in commands[0] and "examples/" in commands[0]
    assert "pip install" in commands[1] and "pytest" in commands[1]


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text()
    assert quick_start_commands()[1] in ci


def test_main_example_exists():
    script = re.search(r"(examples/\S+\.py)", quick_start_commands()[0]).group(1)
    assert (ROOT / script).is_file()


def test_compose_snippet_runs(tmp_path, monkeypatch, capsys):
    # The README's "Compose the blocks" snippet, run on a simulated 21 s log.
    import numpy as np

    from drake_dynid.diagrams import SimulationSettings, simulate_identification
    from drake_dynid.logs import write_log
    from drake_dynid.paper import TRUE_VALUES, paper_trajectory
    from drake_dynid.plants import RobotModel, model_path

    robot = RobotModel.from_urdf(model_path("planar_2r"))
    result = simulate_identification(
        robot, paper_trajectory(), SimulationSettings(duration=21.0, snr_db=None), []
    )
    write_log(
        tmp_path / "robot_log.csv", result.t, result.q, result.tau, robot.joint_names
    )
    text = (ROOT / "README.md").read_text()
    section = text.split("## Compose the blocks in your own diagram", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    printed = capsys.readouterr().out
    theta = np.array(
        re.search(r"^theta \[(.*?)\]", printed, re.M | re.S).group(1).split(), float
    )
    np.testing.assert_allclose(theta[:4], TRUE_VALUES[:4], rtol=0.02)
    assert re.search(r"^valid \[1\.\]", printed, re.M)


_TIMINGS = (  # what a run's speed changes: the time and the optimiser's iterations
    (re.compile(r"\d+ SLSQP iterations, [0-9.]+ s"), "N SLSQP iterations, T s"),
    (re.compile(r"in [0-9.]+ s \([0-9.]+× real time\)"), "in T s (R× real time)"),
    (re.compile(r"\((Clarabel|SCS), [0-9.e-]+ s;"), r"(\1, T s;"),
)
_NUMBER = re.compile(r"-?\d+(\.\d+)?(e[+-]?\d+)?")


def _shown(line: str, digits: bool) -> str:
    """A printed line as compared: timings masked; with ``digits`` False, every
    number and the column widths (a block whose digits depend on the BLAS kernel)."""
    for pattern, mask in _TIMINGS:
        line = pattern.sub(mask, line)
    return line if digits else " ".join(_NUMBER.sub("#", line).split())


@pytest.mark.slow
@pytest.mark.parametrize(
    "heading,commands,folder,digits",
    [
        (
            "## Try it on your own URDF",
            "params excite simulate offline identify simulate validate".split(),
            "models",
            True,
        ),
        # excite's SLSQP optimum of the 4R wrist moves in its last digits with
        # OpenBLAS's kernel (5.54 after 41 iterations with OPENBLAS_CORETYPE=
        # SandyBridge): the lines are checked, their numbers not.
        (
            "### Motors, gears, a coupled wrist: `--drive`",
            "excite simulate head offline".split(),
            "tests",
            False,
        ),
        # The UR5's excite too: its digits are this machine's (README says so).
        (
            "### Validate, constrain, export",
            "excite excite simulate simulate offline validate".split(),
            "models",
            False,
        ),
    ],
)
def test_console_blocks_show_what_the_commands_print(
    heading, commands, folder, digits, tmp_path, monkeypatch, capsys
):
    """A README console block, run as written (from a folder holding the
    repository's ``models`` or ``tests``): every line it shows after a command is
    a line that command prints (the '...' elisions and the timings apart), so
    that the README cannot drift from the code (both had, by a few digits)."""
    import shlex

    from drake_dynid import cli

    text = (ROOT / "README.md").read_text()
    section = text.split(heading, 1)[1]
    block = re.search(r"```console\n(.*?)```", section, re.S).group(1)
    runs: list[tuple[list[str], list[str]]] = []
    exact_lines: list[list[str]] = []  # each run's shown lines, digits kept
    for line in block.splitlines():
        if line.startswith("$ "):
            runs.append((shlex.split(line[2:]), []))
            exact_lines.append([])
        elif line and line != "...":
            runs[-1][1].append(_shown(line, digits))
            exact_lines[-1].append(_shown(line, True))
    assert [words[1] if words[0] == "dynid" else words[0] for words, _ in runs] == (
        commands
    )
    (tmp_path / folder).symlink_to(ROOT / folder)
    monkeypatch.chdir(tmp_path)
    # A block whose digits are the BLAS kernel's (``digits`` False) is checked
    # with its digits too when the first command prints the README's digits:
    # the kernel is then the README's, and a digit that differs downstream is
    # a stale README (the wrist4 block's offline lines were, on the kernel of
    # its excite line).
    same_kernel = None
    for (words, shown), wanted in zip(runs, exact_lines, strict=True):
        if words[0] == "head":  # head -N FILE
            lines = pathlib.Path(words[2]).read_text().splitlines()
            printed = lines[: int(words[1][1:])]
        else:
            assert words[0] == "dynid"
            assert cli.main(words[1:]) == 0, words
            printed = capsys.readouterr().out.splitlines()
        exact = [_shown(line, True) for line in printed]
        printed = [_shown(line, digits) for line in printed]
        missing = [line for line in shown if line not in printed]
        assert not missing, (words, missing)
        if digits:
            continue
        missing = [line for line in wanted if line not in exact]
        if same_kernel is None:
            same_kernel = not missing
        elif same_kernel:
            assert not missing, (words, "the README's kernel, other digits", missing)


def test_the_compose_section_s_names_import_from_the_package():
    """Found by a review: the Compose section names ChangeTrackingIdentifier,
    SignalWindow, chain_trace, final_row and replay_payload_log for a user's own
    diagram, but ``from drake_dynid import ...`` had none of them (only their
    modules did)."""
    import drake_dynid
    from drake_dynid import diagrams, payload_diagrams
    from drake_dynid.systems import change, signal_window

    text = (ROOT / "README.md").read_text()
    section = text.split("## Compose the blocks in your own diagram", 1)[1]
    section = section.split("\n## ", 1)[0]
    named = set(re.findall(r"`([A-Za-z_]\w*)[`(]", section))
    modules = (diagrams, payload_diagrams, change, signal_window)
    public = {
        name
        for module in modules
        for name in named
        if callable(getattr(module, name, None)) and not name.startswith("_")
    }
    assert {"ChangeTrackingIdentifier", "SignalWindow", "final_row"} <= public
    assert sorted(public - set(drake_dynid.__all__)) == []


def test_the_differentiator_snippets_run_as_written():
    """Found by a review: the README's two differentiator snippets used
    ``q_samples``, ``builder`` and ``q_measured`` without defining them."""
    import numpy as np
    from pydrake.systems.analysis import Simulator

    text = (ROOT / "README.md").read_text()
    section = text.split("## Causal Jacobi differentiator", 1)[1].split("\n## ", 1)[0]
    design, diagram = re.findall(r"```python\n(.*?)```", section, re.S)
    names: dict = {}
    exec(compile(design, "README.md", "exec"), names)
    t, f = names["t"], names["f"]
    late = t >= 0.4
    np.testing.assert_allclose(
        names["v_hat"][late], 2.0 * np.cos(2.0 * (t[late] - f.delay)), atol=3e-3
    )
    names = {}
    exec(compile(diagram, "README.md", "exec"), names)
    simulator = Simulator(names["builder"].Build())
    diff = names["diff"]
    for end, valid in ((0.4, 0.0), (0.4005, 1.0)):  # 400, then 401 samples
        simulator.AdvanceTo(end)
        context = diff.GetMyContextFromRoot(simulator.get_context())
        assert names["valid"].Eval(context)[0] == valid
    np.testing.assert_allclose(names["q_hat"].Eval(context), [0.1, 0.2], rtol=1e-12)
    np.testing.assert_allclose(names["v_hat"].Eval(context), 0.0, atol=1e-12)


def test_the_regularizer_table_s_commands_are_explicit_and_parse():
    """Found by a review: the README's physical-consistency numbers (an emptied
    iiwa_link_7, a UR5 shoulder_link at 86 kg) came from logs no command in the
    README made, and did not reproduce. The regularizer table's iiwa7 rows now
    come from a console block: its command lines parse, fix every seed, duration
    and noise level, and each reads only what an earlier one wrote (or a
    repository file). Running it takes about 20 s (it printed its lines as shown
    when written): its numbers, as the table's, are checked by hand."""
    import shlex

    from drake_dynid import cli

    text = (ROOT / "README.md").read_text()
    section = text.split("**What λ weighs (`--regularizer`).**", 1)[1]
    section = section.split("\n**", 1)[0]
    block = re.search(r"```console\n(.*?)```", section, re.S).group(1)
    runs = [shlex.split(line[2:]) for line in block.splitlines() if line[:2] == "$ "]
    assert [words[:2] for words in runs] == [["dynid", name] for name in (
        "excite excite simulate simulate offline offline validate".split()
    )]  # fmt: skip
    parser = cli.build_parser()
    written: set[str] = set()
    for words in runs:
        args = parser.parse_args(words[1:])
        explicit = {
            "excite": ("--seed", "--duration"),
            "simulate": ("--seed", "--duration", "--noise-q", "--noise-tau"),
        }.get(args.command, ())
        assert all(option in words for option in explicit), words
        read = [getattr(args, name, None) for name in ("trajectory", "params", "log")]
        read += [args.urdf, getattr(args, "limits", None)]
        for path in [p for p in read if p]:
            assert path in written or (ROOT / path).is_file(), path
        written |= {getattr(args, name) for name in ("out", "json") if getattr(
            args, name, None)}  # fmt: skip
