"""Mesh files of visuals: where a robot file's mesh is (:func:`mesh_path`), and its triangles
(:func:`read_mesh`, through trimesh: STL, OBJ, DAE with pycollada, PLY, ...).

A robot is loaded without reading its meshes: a :class:`mrnea.visual.Visual` holds the path,
and the report's 3D view reads the file when it draws the robot, with trimesh (a dependency,
imported on the first mesh read, not with mrnea; pyproject.toml also declares what trimesh
imports for these formats: charset-normalizer for text that is not UTF-8, as the Latin-1 solid
names of some CAD exports' ASCII STL files, and networkx).
"""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import RobotFileError
from mrnea.io.source import expand_home, read_bytes, refused_prolog

__all__ = ["MAX_MESH_FILE", "find_package_file", "mesh_path", "read_mesh"]

#: Largest mesh file read [bytes] (a detailed CAD export is a few MB).
MAX_MESH_FILE = 64 * 2**20


def mesh_path(filename: str, referrer: Path) -> str:
    """Where the mesh file ``filename`` named in the robot file ``referrer`` is: an absolute
    path, or ``filename`` itself where no folder resolves it (a ``package://`` name whose
    package is not found, a URL: mrnea fetches nothing). Whether the file exists is checked
    when it is read (:func:`read_mesh`), so a robot file copied without its meshes still loads.

    ``package://PKG/path`` is looked for in the referrer's folder and every folder above it
    (``PKG`` itself, or a folder holding ``PKG``), then in the folders of ``$ROS_PACKAGE_PATH``;
    ``file://path`` and plain paths are taken relative to the referrer's folder.
    """
    try:
        return _resolve(filename, referrer)
    except (OSError, ValueError):  # a name the file system refuses (too long, a NUL byte...)
        return filename


def _resolve(filename: str, referrer: Path) -> str:
    here = referrer.resolve().parent
    if filename.startswith("package://"):
        folders = [here, *here.parents]
        folders += [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)
                    if p]
        return find_package_file(filename, folders)
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    elif "://" in filename:
        return filename
    path = expand_home(Path(filename), lambda m: RobotFileError(f"{referrer}: mesh: {m}"))
    return str((here / path).resolve())  # an absolute path stays


def find_package_file(filename: str, folders: list[Path]) -> str:
    """The file a ``package://PKG/path`` name means, looked for in ``folders`` in order (each
    ``PKG`` itself, or a folder holding ``PKG``); ``filename`` itself where none holds it (and
    for a name that is not ``package://``)."""
    if not filename.startswith("package://"):
        return filename
    package, _, rest = filename[len("package://"):].partition("/")
    for folder in folders:
        candidates = [folder / package / rest]
        if folder.name == package:
            candidates.insert(0, folder / rest)
        try:
            found = next((c for c in candidates if c.is_file()), None)
        except (OSError, ValueError):  # a name the file system refuses
            found = None
        if found is not None:
            return str(found.resolve())
    return filename


def read_mesh(path: str | os.PathLike[str]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The triangles of a mesh file: vertices (V, 3) [file units] and faces (F, 3) (vertex
    indices), all parts of the file merged.

    Raises
    ------
    RobotFileError
        trimesh is not installed, the file is not a regular file of at most
        :data:`MAX_MESH_FILE` bytes (:func:`mrnea.io.source.read_bytes`), a COLLADA file has a
        DTD (:func:`mrnea.io.source.refused_prolog`), or trimesh cannot read it or finds no
        triangle; the message names the file.
    """
    if "://" in str(path):
        raise RobotFileError(f"{path}: mesh file not found (no folder resolves this name, and "
                             "mrnea fetches nothing)")
    p = Path(path)
    import trimesh
    data = read_bytes(p, "mesh file", RobotFileError, MAX_MESH_FILE)
    refused = refused_prolog(data) if p.suffix.lower() == ".dae" else None  # XML: no DTD
    if refused is not None:
        raise RobotFileError(f"{p}: mesh file refused: {refused}")
    try:  # from memory: a file that names other files (textures) cannot make trimesh read them
        mesh = trimesh.load(io.BytesIO(data), file_type=p.suffix.lstrip(".").lower(),
                            force="mesh", process=False)
        V = np.asarray(mesh.vertices, dtype=np.float64)
        F = np.asarray(mesh.faces, dtype=np.int64)
    except Exception as exc:  # trimesh and its loaders raise many kinds
        raise RobotFileError(f"{p}: trimesh cannot read the mesh: {exc}") from None
    if F.ndim != 2 or F.shape[0] == 0 or F.shape[1] != 3 or not np.all(np.isfinite(V)):
        raise RobotFileError(f"{p}: no triangles with finite vertices in the mesh")
    return V, F
