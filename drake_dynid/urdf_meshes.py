"""Mesh files of a URDF that Drake cannot take as they are: packages and STL.

Two things stop Drake's parser on the meshes of real robot descriptions
(example-robot-data's Panda, UR, Kinova, TIAGo, ...), although identification
needs no geometry and only ``dynid excite``'s self-collision check (and the
Meshcat replay) reads them:

* ``package://NAME/...`` with no package ``NAME`` known (no ROS workspace, or a
  package.xml whose name is not the one the URIs use: example-robot-data's URIs
  say ``example-robot-data``, its package.xml ``example_robot_descriptions``).
  :func:`add_ancestor_packages` adds ``NAME`` as the nearest ancestor folder of the
  URDF named ``NAME``, as ROS-less tools (Pinocchio's ``package_dirs``) do.
* Collision meshes in STL: Drake's proximity engine takes the convex hull of a
  mesh (``MakeConvexHull``: .obj, .vtk and .gltf only). :func:`stl_collisions_as_obj`
  writes each STL collision mesh once as a Wavefront OBJ of the same triangles in
  a temporary folder (never beside the user's files) and points the URDF text at
  it; the hull, and so every distance, is the STL's.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["add_ancestor_packages", "read_stl", "stl_collisions_as_obj"]

_PACKAGE = re.compile(r"package://([^/\"'\s]+)/")
_COLLISION = re.compile(r"<collision\b(?:[^>]*/>|.*?</collision\s*>)", re.S)
_VISUAL_OR_COLLISION = re.compile(r"<(visual|collision)\b(?:[^>]*/>|.*?</\1\s*>)", re.S)
_MESH_FILE = re.compile(r"""(<mesh\b[^>]*?\bfilename\s*=\s*)(["'])([^"']+)\2""", re.S)


def add_ancestor_packages(package_map: Any, file: Path, text: str) -> list[str]:
    """Adds each unknown package the text's ``package://`` URIs name, as an ancestor.

    For a package ``NAME`` the map does not hold, the nearest ancestor folder of
    ``file`` named ``NAME`` becomes its path (Drake's ``PackageMap.Add``).
    Returns the names added.
    """
    added = []
    for name in sorted(set(_PACKAGE.findall(text))):
        if package_map.Contains(name):
            continue
        for folder in Path(file).resolve().parents:
            if folder.name == name:
                package_map.Add(name, str(folder))
                added.append(name)
                break
    return added


def read_stl(path: str | os.PathLike) -> np.ndarray:
    """The (T, 3, 3) triangles [file units] of a binary or ASCII STL file.

    Binary: an 80-byte header, a little-endian uint32 count T, then T records of
    50 bytes (normal, three vertices as float32, a uint16), and at most a
    partial record of padding. Anything else is read as ASCII (``vertex x y z``
    lines).

    Raises:
        ValueError: no triangle, or a vertex count not a multiple of 3.
    """
    data = Path(path).read_bytes()
    if len(data) >= 84:
        count = int.from_bytes(data[80:84], "little")
        size = 84 + 50 * count
        # Binary: the records fill the file, or leave less than one record of
        # trailing bytes (some exporters pad) in a file that is not ASCII STL.
        ascii_like = b"facet" in data[:1024].lower()
        if count > 0 and (
            size == len(data) or (size < len(data) < size + 50 and not ascii_like)
        ):
            record = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
            return np.frombuffer(data, record, count, 84)["v"].astype(float)
    numbers = re.findall(
        r"vertex\s+(\S+)\s+(\S+)\s+(\S+)",
        data.decode("ascii", errors="replace"),
        flags=re.IGNORECASE,
    )
    try:
        vertices = np.array(numbers, dtype=float)
    except ValueError:
        vertices = np.empty((1, 3))  # a bad number: refused below
        numbers = []
    if not numbers or len(numbers) % 3:
        raise ValueError(
            f"STL mesh {path}: no triangles read (neither a binary STL of consistent "
            "length nor ASCII 'vertex x y z' lines in threes)."
        )
    return vertices.reshape(-1, 3, 3)


_CACHE: dict[tuple[str, int, int], Path] = {}
_FOLDER: list[Path] = []


def _obj_of(stl: Path) -> Path:
    """The OBJ written for ``stl`` (once per file version, per process)."""
    status = stl.stat()
    key = (str(stl.resolve()), status.st_mtime_ns, status.st_size)
    if key in _CACHE:
        return _CACHE[key]
    if not _FOLDER:
        import atexit  # here: not on the start-up path of the commands
        import shutil
        import tempfile

        folder = Path(tempfile.mkdtemp(prefix="drake_dynid_meshes_"))
        atexit.register(shutil.rmtree, folder, True)
        _FOLDER.append(folder)
    triangles = read_stl(stl)
    out = _FOLDER[0] / f"{len(_CACHE)}_{stl.stem}.obj"
    # UTF-8: the header comment names the STL's path, which may be non-ASCII.
    with open(out, "w", encoding="utf-8") as stream:
        stream.write(f"# {stl} as OBJ (drake_dynid.urdf_meshes)\n")
        np.savetxt(stream, triangles.reshape(-1, 3), fmt="v %.9g %.9g %.9g")
        faces = np.arange(1, 3 * len(triangles) + 1).reshape(-1, 3)
        np.savetxt(stream, faces, fmt="f %d %d %d")
    _CACHE[key] = out
    return out


def _resolved(filename: str, package_map: Any) -> Path | None:
    """The local path of a mesh ``filename`` (absolute, ``file://`` or ``package://``)."""
    if filename.startswith("file://"):
        return Path(filename[len("file://") :])
    match = re.match(r"package://([^/]+)/(.*)", filename)
    if match:
        name, rest = match.groups()
        if not package_map.Contains(name):
            return None
        return Path(package_map.GetPath(name)) / rest
    if "://" in filename:
        return None
    return Path(filename)


def stl_collisions_as_obj(text: str, package_map: Any, visual: bool = False) -> str:
    """The URDF text with each ``<collision>`` STL mesh replaced by its OBJ copy.

    Meshes that cannot be resolved or found are left as they are (Drake's parser
    then names them). ``<visual>`` meshes are not touched unless ``visual``:
    Drake's Meshcat shows .obj, .gltf and .dae meshes only (an STL visual, the
    xArm7's, is "not visualized": the replay drew an empty scene).

    Raises:
        ValueError: an STL collision mesh that holds no triangles (its path named).
    """

    def mesh(match: re.Match) -> str:
        filename = match.group(3)
        if not filename.lower().endswith(".stl"):
            return match.group(0)
        path = _resolved(filename, package_map)
        if path is None or not path.is_file():
            return match.group(0)
        obj = _obj_of(path)
        uri = f"file://{obj.resolve().as_posix()}"  # Drake takes URIs in a string
        return f"{match.group(1)}{match.group(2)}{uri}{match.group(2)}"

    elements = _VISUAL_OR_COLLISION if visual else _COLLISION
    return elements.sub(lambda m: _MESH_FILE.sub(mesh, m.group(0)), text)
