"""Helpers of the command-line tests."""


def error_line(capsys) -> str:
    """The one line a refused command prints on stderr (notes apart), no traceback."""
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.strip().splitlines() if ": note: " not in line]
    assert len(lines) == 1, lines
    return lines[0]
