"""drake_dynid.files: outputs written whole, one file by any name."""

import errno
import json
import os
import stat

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_dynid import files
from drake_dynid.files import same_file, write_text_whole


def test_a_failed_write_leaves_the_previous_file_and_no_temporary(
    tmp_path, monkeypatch
):
    """A review: a full disk left a truncated --urdf-out file while the message
    said it was not written."""
    path = tmp_path / "out.urdf"
    path.write_text("previous")
    os.chmod(path, 0o640)

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files.os, "replace", full)
    with pytest.raises(OSError, match=r"No space left on device: '.*out.urdf'"):
        write_text_whole(path, "new text")
    assert path.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.urdf"]
    monkeypatch.undo()
    write_text_whole(path, "new text")
    assert path.read_text() == "new text"
    assert stat.S_IMODE(path.stat().st_mode) == 0o640  # its permissions kept


def test_a_link_is_followed_and_a_device_written_in_place(tmp_path):
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    write_text_whole(link, "new")
    assert link.is_symlink() and target.read_text() == "new"
    write_text_whole(os.devnull, "nothing")  # not replaced by a regular file
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)
    fresh = tmp_path / "fresh.json"
    write_text_whole(fresh, "x")
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~umask


def test_same_file_by_any_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.csv").write_text("x")
    os.link(tmp_path / "a.csv", tmp_path / "hard.csv")
    (tmp_path / "soft.csv").symlink_to(tmp_path / "a.csv")
    for other in ("./a.csv", "hard.csv", "soft.csv", str(tmp_path / "a.csv")):
        assert same_file("a.csv", other)
    assert same_file("missing.csv", "./missing.csv")
    assert not same_file("a.csv", "missing.csv")


def test_a_pipe_named_by_a_link_is_written_in_place():
    """--json /dev/stdout piped to another program: the link resolves to
    '/proc/<pid>/fd/pipe:[...]', no file; the pipe itself is written."""
    reader, writer = os.pipe()
    try:
        write_text_whole(f"/proc/self/fd/{writer}", "through the pipe\n")
        os.close(writer)
        writer = -1
        with os.fdopen(reader, encoding="utf-8") as stream:
            reader = -1
            assert stream.read() == "through the pipe\n"
    finally:
        for descriptor in (reader, writer):
            if descriptor >= 0:
                os.close(descriptor)


def test_the_umask_is_never_set_and_a_long_name_is_written(tmp_path, monkeypatch):
    """Reading the umask sets it: a Dask worker's threads writing JSONs at once
    could leave it at 0. A 250-character name had a temporary file name over
    the file system's 255 bytes ('File name too long')."""

    def no_umask(mask):
        raise AssertionError("os.umask called")

    umask = os.umask(0)
    os.umask(umask)
    monkeypatch.setattr(files.os, "umask", no_umask)
    fresh = tmp_path / ("a" * 245 + ".json")
    write_text_whole(fresh, "x")
    assert fresh.read_text() == "x"
    assert stat.S_IMODE(fresh.stat().st_mode) == 0o666 & ~umask
    assert sorted(p.name for p in tmp_path.iterdir()) == [fresh.name]


def test_repeated_file_is_one_stat_a_path(tmp_path, monkeypatch):
    """dynid fleet of thousands of logs: one same_file per pair was n²/2 pairs
    of stats before any log ran. The same answers as same_file."""
    from drake_dynid.files import repeated_file

    monkeypatch.chdir(tmp_path)
    names = [f"log{i}.csv" for i in range(60)]
    for name in names:
        (tmp_path / name).write_text("x")
    (tmp_path / "soft.csv").symlink_to(tmp_path / "log7.csv")
    calls = []
    real_stat = os.stat

    def counted(*args, **kwargs):
        calls.append(args)
        return real_stat(*args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(files.os, "stat", counted)
        assert repeated_file(names) is None
    assert len(calls) <= 3 * len(names)
    assert repeated_file([*names, "soft.csv"]) == ("log7.csv", "soft.csv")
    assert repeated_file(["./log3.csv", "log1.csv", "log3.csv"]) == (
        "./log3.csv",
        "log3.csv",
    )
    assert repeated_file(["new.csv", "./new.csv"]) == ("new.csv", "./new.csv")
    assert repeated_file(["new.csv", "other.csv"]) is None


def test_a_file_mounted_on_its_own_is_written_in_place(tmp_path, monkeypatch):
    """A container's bind mount of one output file cannot be replaced: rename
    fails with EBUSY, where a plain write (before 0ad4977) worked."""
    path = tmp_path / "out.json"
    path.write_text("previous")

    def busy(*args, **kwargs):
        raise OSError(errno.EBUSY, "Device or resource busy")

    monkeypatch.setattr(files.os, "replace", busy)
    write_text_whole(path, "new text")
    assert path.read_text() == "new text"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_a_symbolic_link_loop_is_an_os_error(tmp_path, monkeypatch):
    """An output (or input) path that is a link to itself: Path.resolve raised
    RuntimeError ('Symlink loop'), exit 1 with a traceback."""
    from drake_dynid.files import repeated_file

    monkeypatch.chdir(tmp_path)
    (tmp_path / "loop.json").symlink_to(tmp_path / "loop.json")
    (tmp_path / "a.csv").write_text("x")
    assert not same_file("loop.json", "a.csv")
    assert same_file("loop.json", "./loop.json")
    assert repeated_file(["loop.json", "a.csv", "./loop.json"]) == (
        "loop.json",
        "./loop.json",
    )
    with pytest.raises(OSError, match=r"loop\.json"):
        write_text_whole("loop.json", "x")


def _csv_writers():
    """Every CSV writer of the package, each writing one small file."""
    import numpy as np

    from drake_dynid.commands._report import write_estimates_csv
    from drake_dynid.core.drive import DriveChain
    from drake_dynid.logs import write_log
    from drake_dynid.raw_log import write_raw_log
    from drake_dynid.trajectory_file import SampledTrajectory, write_trajectory

    t = 0.01 * np.arange(5)
    x = np.column_stack([t, 2 * t])
    drive = {"log": {"time": "t", "position": "q_{joint}", "torque": "tau_{joint}"}}
    chain = DriveChain.from_dict(drive, ("a", "b"), source="test")
    path = SampledTrajectory(t, x, x, x, ("a", "b"))
    return {
        "write_log": lambda p: write_log(p, t, x, x, ("a", "b")),
        "write_raw_log": lambda p: write_raw_log(p, chain, t, x, x),
        "write_trajectory": lambda p: write_trajectory(p, path),
        "write_estimates_csv": lambda p: write_estimates_csv(
            p, t, np.ones(5), x, ["A", "B"], x
        ),
    }


@pytest.mark.parametrize("name", sorted(_csv_writers()))
def test_a_csv_output_is_written_whole(tmp_path, monkeypatch, name):
    """A review: the JSON and URDF outputs were written whole, the CSV outputs
    (logs of dynid simulate, --out estimates, trajectories) in place, so a
    failure mid-write left a truncated file. A write that fails before the end
    (a full disk) or at the replace leaves the previous file and no temporary."""
    import numpy as np

    write = _csv_writers()[name]
    path = tmp_path / "out.csv"
    path.write_text("previous")
    calls = []

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(files.os, "replace", full)
    with pytest.raises(OSError, match="No space left on device"):
        write(path)
    assert path.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    monkeypatch.undo()
    write(path)
    whole = path.read_text()
    assert whole.count("\n") == 6 and whole != "previous"
    # Cut short: the stream fails after its first line (savetxt, csv rows).
    real = np.savetxt

    def cut(stream, *args, **kwargs):
        calls.append(1)
        stream.write("0.0,")
        raise OSError(errno.ENOSPC, "No space left on device")

    import csv

    class Cut:
        def __init__(self, stream, *args, **kwargs):
            self.stream, self.rows = stream, 0

        def writerow(self, row):
            self.rows += 1
            if self.rows > 2:
                cut(self.stream)
            self.stream.write(",".join(map(str, row)) + "\n")

    monkeypatch.setattr(np, "savetxt", cut)
    monkeypatch.setattr(csv, "writer", Cut)
    with pytest.raises(OSError, match="No space left on device"):
        write(path)
    assert calls and path.read_text() == whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]
    monkeypatch.setattr(np, "savetxt", real)


_JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**20), 10**20)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(alphabet='[]{},:\n\\" 0123456789-eEnul', max_size=12),
    lambda inner: (
        st.lists(inner, max_size=5)
        | st.dictionaries(st.text(max_size=5), inner, max_size=4)
    ),
    max_leaves=30,
)


@given(_JSON_VALUES)
@settings(max_examples=300, deadline=None)
def test_json_text_is_the_same_document(document):
    text = files.json_text(document)
    assert json.loads(text) == document
    assert text.endswith("\n")


def test_json_text_writes_a_matrix_one_row_per_line():
    covariance = [[1.5e-3, -2.0e-7, 0.0], [-2.0e-7, 4.0, None], [0.0, None, 1e300]]
    document = {"covariance": covariance, "names": ["M1R", "ZZ1R"], "n": 3}
    text = files.json_text(document)
    assert json.loads(text) == document
    assert "    [0.0015, -2e-07, 0.0],\n" in text
    assert len(text.splitlines()) == 12  # { cov [ 3 rows ] names n }: not 3x3 lines
    assert '"flags": [true, false, null, 1]' in files.json_text(
        {"flags": [True, False, None, 1]}
    )
    with pytest.raises(ValueError):
        files.json_text({"x": [float("nan")]})
    assert json.loads(files.json_text([float("nan")], allow_nan=True))[0] != 0


@pytest.mark.parametrize("encoding", ["ascii", "latin-1"])
def test_standard_output_gets_the_files_utf8_bytes(monkeypatch, encoding):
    """'-' (standard output) is the file: its UTF-8 bytes whatever the locale's
    encoding (a bag's joint named '関節1' made 'dynid bag2csv BAG --out -' fail
    under PYTHONIOENCODING=ascii: "'ascii' codec can't encode characters");
    the stream's encoding is restored after."""
    import io
    import sys

    raw = io.BytesIO()
    stream = io.TextIOWrapper(raw, encoding=encoding, newline="")
    monkeypatch.setattr(sys, "stdout", stream)
    files.write_whole("-", lambda s: s.write("t,q_関節1,q_é\n0,1,2\n"))
    assert raw.getvalue() == "t,q_関節1,q_é\n0,1,2\n".encode()
    assert stream.encoding == encoding
