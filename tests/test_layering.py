"""The numerical core must never import pydrake (house rule)."""

import ast
import pathlib
import subprocess
import sys

CORE = pathlib.Path(__file__).resolve().parents[1] / "drake_dynid" / "core"


def test_core_sources_do_not_import_pydrake():
    offenders = []
    for path in sorted(CORE.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            if any(name.split(".")[0] == "pydrake" for name in names):
                offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []


def test_importing_every_core_module_leaves_pydrake_unloaded():
    modules = sorted(
        "drake_dynid.core." + p.stem for p in CORE.glob("*.py") if p.stem != "__init__"
    )
    code = (
        "import importlib, sys\n"
        f"for m in {modules!r}: importlib.import_module(m)\n"
        "import drake_dynid\n"
        "print(any(k.split('.')[0] == 'pydrake' for k in sys.modules))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == "False"
