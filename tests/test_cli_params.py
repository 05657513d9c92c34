"""``dynid params``: the 2R table and JSON, counts, bad input -> exit 2."""

import json
import re

from drake_dynid import cli
from drake_dynid.plants import model_path


def test_2r_table_and_json(tmp_path, capsys):
    out_file = tmp_path / "params.json"
    assert cli.main(["params", model_path("planar_2r"), "--json", str(out_file)]) == 0
    out = capsys.readouterr().out
    assert "standard parameters: 24; base parameters: 8" in out
    assert re.search(r"^ZZ1R\s+3\.9\s+ZZ1 \+ 1\.0 M2$", out, flags=re.M)
    for name, value in [
        ("ZZ2", "0.25"),
        ("MX2", "0.45"),
        ("MY2", "0.1"),
        ("FC2", "0.25"),
    ]:
        assert re.search(rf"^{name}\s+{re.escape(value)}\s+{name}$", out, flags=re.M)
    document = json.loads(out_file.read_text())
    names = [p["name"] for p in document["parameters"]]
    assert names == ["ZZ1R", "ZZ2", "MX2", "MY2", "FV1", "FC1", "FV2", "FC2"]
    first = document["parameters"][0]
    assert first["definition"] == {"ZZ1": 1.0, "M2": 1.0}
    assert first["std"] is None and abs(first["value"] - 3.9) < 1e-12
    assert document["num_standard"] == 24 and document["num_base"] == 8
    assert document["settings"]["friction"] == ["viscous", "coulomb"]


def test_friction_and_rotor_options(capsys):
    assert cli.main(["params", model_path("planar_2r"), "--friction", "none"]) == 0
    assert "standard parameters: 20; base parameters: 4" in capsys.readouterr().out
    argv = ["params", model_path("ur5"), "--friction", "viscous,coulomb,offset"]
    assert cli.main([*argv, "--rotor-inertia"]) == 0
    out = capsys.readouterr().out
    # 6 x 11 + 18 standard; 36 inertial + 4 identifiable IAj + 18 friction.
    assert "standard parameters: 84; base parameters: 58" in out


def test_bad_input_exits_2_without_traceback(tmp_path, capsys):
    assert cli.main(["params", str(tmp_path / "missing.urdf")]) == 2
    err = capsys.readouterr().err
    assert "URDF file not found" in err and "Traceback" not in err
    bad = tmp_path / "bad.urdf"
    bad.write_text('<robot name="r"><link name="a"></robot>')
    assert cli.main(["params", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "not well-formed XML" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert cli.main(["params", model_path("planar_2r"), "--friction", "dry"]) == 2
    assert "friction kinds must be among" in capsys.readouterr().err
    argv = [
        "params",
        model_path("planar_2r"),
        "--json",
        str(tmp_path / "no/dir/x.json"),
    ]
    assert cli.main(argv) == 2


def test_json_written_whole(tmp_path, monkeypatch, capsys):
    """dynid params --json goes through files.write_text_whole as every --json:
    a failed write leaves the previous file, exit 2 naming it."""
    import errno

    from drake_dynid import files

    out_file = tmp_path / "params.json"
    out_file.write_text("previous")

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files.os, "replace", full)
    code = cli.main(["params", model_path("planar_2r"), "--json", str(out_file)])
    assert code == 2
    assert "params.json" in capsys.readouterr().err
    assert out_file.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["params.json"]
