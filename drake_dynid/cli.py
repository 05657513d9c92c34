"""The ``dynid`` command line tool.

Subcommands live in ``drake_dynid.commands.<name>``; each module defines ``HELP``
(one line), ``add_arguments(parser)`` and ``run(args) -> int``, and imports pydrake
only inside ``run`` so that ``dynid --help`` stays fast.

Exit codes: 0 success, 2 bad input (a one-line message on stderr, no traceback),
1 internal error (a traceback: please report it). A closed standard output (``dynid
... | head``) is not an error: the rest of the printout is dropped, the command
runs to its end and writes its files (:class:`_ClosableStream`; so for a
closed standard error), but where standard output is the data written
(``dynid bag2csv --out -``), which stops there (exit 2).

Before anything else, :func:`main` sets the process up
(``drake_dynid.core._threads.configure_process``): BLAS/OpenMP pools of one thread
(``--threads N`` or ``DYNID_THREADS`` to change it) and glibc's allocator
thresholds (README "Performance").
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import sys
import traceback
import warnings
from collections.abc import Sequence
from typing import Any

from drake_dynid import __version__
from drake_dynid.core._threads import configure_process

# Order shown in ``dynid --help``. A name whose module does not exist yet is skipped.
SUBCOMMANDS = (
    "params",
    "excite",
    "simulate",
    "identify",
    "payload",
    "offline",
    "validate",
    "fleet",
    "replay",
    "bag2csv",
)

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2


class _ClosableStream:
    """``sys.stdout`` or ``sys.stderr`` whose reader may go away.

    ``dynid offline ... | head``, ``2>&1 | head``: the first write or flush that
    meets a closed pipe (``BrokenPipeError``) sends this and every later output to
    ``os.devnull`` (its file descriptor too, so that nothing fails at exit): the
    command runs to its end and writes its files, as if the printout had been read,
    instead of stopping with an error at its first lost line. Other write errors (a
    full disk) are raised.
    """

    def __init__(self, stream: Any) -> None:
        self._stream = stream
        self._original = stream

    def _closed(self) -> None:
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, self._original.fileno())
        except (OSError, ValueError, AttributeError):
            pass  # not a file descriptor (a test's capture): only this stream
        finally:
            os.close(devnull)
        if self._stream is self._original:
            self._stream = open(os.devnull, "w", encoding="utf-8")

    @property
    def closed_pipe(self) -> bool:
        """Whether the reader has gone away (the output now goes to os.devnull).

        A command whose standard output is its data, not a printout (``dynid
        bag2csv --out -``), stops there with an error (``ros_bag``).
        """
        return self._stream is not self._original

    def write(self, text: str) -> int:
        try:
            return int(self._stream.write(text))
        except BrokenPipeError:
            self._closed()
            return len(text)
        except UnicodeEncodeError:
            # A terminal that cannot show σ, ×, · (PYTHONIOENCODING=ascii, a C
            # locale): the characters as escapes, not the command stopped by its
            # report (dynid excite exited 2 on its first 'σ').
            encoding = getattr(self._stream, "encoding", None) or "ascii"
            self.write(text.encode(encoding, "backslashreplace").decode(encoding))
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._closed()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors exit with code 2 and no traceback."""


def _available() -> list[str]:
    names = []
    for name in SUBCOMMANDS:
        if importlib.util.find_spec(f"drake_dynid.commands.{name}") is not None:
            names.append(name)
    return names


def build_parser() -> argparse.ArgumentParser:
    """Returns the ``dynid`` argument parser with every available subcommand."""
    parser = _Parser(
        prog="dynid",
        description=(
            "On-line robot dynamic identification with Drake: base parameters of a "
            "URDF robot, on-line identification (modulating functions + sliding QR) "
            "and off-line IDIM-LS from recorded logs."
        ),
        epilog="Exit codes: 0 success, 2 bad input, 1 internal error.",
    )
    parser.add_argument("--version", action="version", version=f"dynid {__version__}")
    parser.add_argument(
        "--threads",
        type=_thread_count,
        metavar="N",
        help="threads per BLAS/OpenMP pool (default 1, or the DYNID_THREADS "
        "environment variable; 0 or auto: the libraries' defaults). The small "
        "least squares of identification only lose time with more",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in _available():
        module = importlib.import_module(f"drake_dynid.commands.{name}")
        description = getattr(module, "DESCRIPTION", module.HELP)
        sub = subparsers.add_parser(name, help=module.HELP, description=description)
        module.add_arguments(sub)
        sub.set_defaults(_run=module.run)
    return parser


def _thread_count(text: str) -> int:
    """``--threads``: an integer >= 0 or ``auto`` (0: the libraries' defaults)."""
    value = text.strip().lower()
    if value == "auto":
        return 0
    if not value.isdigit():
        raise argparse.ArgumentTypeError(
            f"must be an integer >= 0 or 'auto'; got {text!r}"
        )
    return int(value)


def _configure(argv: list[str]) -> None:
    """Process settings before any numerical import (``--threads`` read early)."""
    early = argparse.ArgumentParser(add_help=False)
    early.add_argument("--threads", type=_thread_count)
    try:
        known, _ = early.parse_known_args(argv)
    except SystemExit:  # a bad value: the full parser reports it
        known = argparse.Namespace(threads=None)
    if known.threads == 0:  # the libraries' own defaults
        os.environ["DYNID_THREADS"] = "auto"
        configure_process()
    else:
        configure_process(known.threads)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``dynid`` on ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    # A missing stream (``dynid ... >&-``: None, print() drops the text) stays so.
    saved = {name: getattr(sys, name) for name in ("stdout", "stderr")}
    wrapped = {
        name: _ClosableStream(stream)
        for name, stream in saved.items()
        if stream is not None
    }
    for name, wrapper in wrapped.items():
        setattr(sys, name, wrapper)
    try:
        code = _main(argv)
        out = wrapped.get("stdout")
        if out is not None:
            try:
                out.flush()  # what is left: a write error is the command's
            except OSError as error:  # not a closed pipe: a full disk, ...
                print(f"dynid: error: standard output: {error}", file=sys.stderr)
                out._closed()  # the unwritten text is dropped, not reported at exit
                code = EXIT_BAD_INPUT
        return code
    finally:
        # Restored; a wrapper kept by a logging handler still writes through
        # (to os.devnull once its pipe closed: that stream is left open).
        for name in wrapped:
            setattr(sys, name, saved[name])


def _main(argv: list[str]) -> int:
    _configure(argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    run = getattr(args, "_run", None)
    if run is None:
        parser.print_help()
        return EXIT_OK
    try:
        with warnings.catch_warnings():
            # numpy/scipy numeric warnings (overflow, invalid value, ill-conditioned
            # solves) never reach the user as Python warnings: every result they
            # could affect is checked for finiteness and rank, and reported in the
            # command's own words (an invalid window, a non-finite input).
            warnings.simplefilter("ignore", RuntimeWarning)
            return int(run(args) or EXIT_OK)
    except (ValueError, OSError) as error:
        # Bad input: the message names the problem; no traceback.
        print(f"dynid {args.command}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"dynid {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERNAL
    except Exception:
        traceback.print_exc()
        print(
            f"dynid {args.command}: internal error (a bug in drake_dynid; please "
            "report it with the traceback above).",
            file=sys.stderr,
        )
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
