import subprocess
import sys

import pytest

import drake_dynid
from drake_dynid import cli


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"dynid {drake_dynid.__version__}"


def test_help_lists_exit_codes(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["--help"])
    assert exit_info.value.code == 0
    assert "Exit codes" in capsys.readouterr().out


def test_every_option_with_a_default_says_it_in_its_help():
    """Found by a new user's walk-through: `dynid simulate --help` gave '--rate HZ
    log rate [Hz]' and '--seed S noise seed', not their defaults (1000 Hz, 0),
    where every other option with one states it."""
    import argparse

    silent = []

    def walk(parser, command):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, f"{command} {name}")
            elif (
                action.option_strings
                and not any(action.default is v for v in (None, False))
                and action.default != argparse.SUPPRESS
                and action.help not in (None, argparse.SUPPRESS)
                and action.nargs != 0
                and "default" not in action.help
            ):
                silent.append(f"{command} {action.option_strings[-1]}")

    walk(cli.build_parser(), "dynid")
    assert silent == []


def test_no_command_prints_help(capsys):
    assert cli.main([]) == 0
    assert "usage: dynid" in capsys.readouterr().out


def test_unknown_command_is_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["no-such-command"])
    assert exit_info.value.code == 2
    assert "invalid choice" in capsys.readouterr().err


def test_console_script_installed():
    out = subprocess.run(
        [sys.executable, "-m", "drake_dynid.cli", "--version"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip() == f"dynid {drake_dynid.__version__}"


def test_every_public_name_resolves():
    for name in drake_dynid.__all__:
        assert getattr(drake_dynid, name) is not None


def test_the_parser_imports_no_process_pool():
    """Every dynid command builds the whole parser (each subcommand's options):
    `dynid fleet`'s must not import its process pool's modules (multiprocessing,
    concurrent.futures: 13 ms of every command's start-up), only a fleet run does."""
    code = (
        "import sys\n"
        "from drake_dynid import cli\n"
        "cli.build_parser()\n"
        "print(sorted(k for k in sys.modules if k.split('.')[0] in "
        "('multiprocessing', 'concurrent')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "[]"


def test_replay_s_help_does_not_say_it_identifies(capsys):
    """Found by a new user's walk-through: `dynid replay --help` described
    --joints as 'comma-separated joints to identify', a command that only shows
    a motion."""
    with pytest.raises(SystemExit):
        cli.main(["replay", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "identif" not in out, out
    assert "comma-separated joints to replay from the log" in out
    assert "without --joints, the joints not locked are replayed" in out
