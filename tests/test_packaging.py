"""What a non-editable install (`pip install .`) ships."""

import fnmatch
import pathlib

import tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_every_packaged_model_file_is_package_data():
    """Found by a new user's walk-through: package-data held models/*.urdf and
    *.json but not *.toml, so `pip install .` (not -e) left out tiago.toml and
    `--drive tiago`, which the README offers from any folder, failed."""
    setup = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    patterns = setup["package-data"]["drake_dynid"]
    package = ROOT / "drake_dynid"
    files = sorted(str(p.relative_to(package)) for p in (package / "models").iterdir())
    assert files
    left_out = [f for f in files if not any(fnmatch.fnmatch(f, g) for g in patterns)]
    assert left_out == []
