"""Mesh files of every format :func:`mrnea.io.mesh.read_mesh` claims (STL binary and ASCII, OBJ,
DAE, PLY binary and ASCII), made in the test with trimesh's exporters, including the text files some
CAD exports write: an ASCII STL whose solid name, or an OBJ whose comment, is Latin-1 (issue 23).

The oracle is independent of the reader: the box is 1 x 2 x 3 m, so the triangles read back must
enclose 6 m^3 (divergence theorem over the faces, in NumPy) with 22 m^2 of surface, and span
the box's corners. A second test checks that every distribution a mesh read imports is declared
in pyproject.toml's dependencies (directly or through a declared one), so a fresh install reads
these files (the missing charset_normalizer of the issue).
"""

from __future__ import annotations

import importlib.metadata as md
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mrnea.io.mesh import read_mesh

trimesh = pytest.importorskip("trimesh")
ROOT = Path(__file__).resolve().parents[1]
EXTENTS = (1.0, 2.0, 3.0)


def _box_files(folder: Path) -> dict[str, Path]:
    box = trimesh.creation.box(extents=EXTENTS)
    files = {}
    for name, kind, kw in (("binary.stl", "stl", {}), ("ascii.stl", "stl_ascii", {}),
                           ("box.obj", "obj", {}), ("box.dae", "dae", {}),
                           ("binary.ply", "ply", {"encoding": "binary"}),
                           ("ascii.ply", "ply", {"encoding": "ascii"})):
        data = box.export(file_type=kind, **kw)
        path = folder / name
        path.write_bytes(data if isinstance(data, bytes) else data.encode("ascii"))
        files[name] = path
    stl = box.export(file_type="stl_ascii").replace("solid", "solid Gehäuse µ-Teil", 1)
    files["latin1.stl"] = folder / "latin1.stl"
    files["latin1.stl"].write_bytes(stl.encode("latin-1"))
    obj = "# Gehäuse, exportiert aus CAD (µm)\n" + box.export(file_type="obj")
    files["latin1.obj"] = folder / "latin1.obj"
    files["latin1.obj"].write_bytes(obj.encode("latin-1"))
    return files


def _volume_and_area(V: np.ndarray, F: np.ndarray) -> tuple[float, float]:
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    volume = float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum()) / 6.0
    area = float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()) / 2.0
    return volume, area


@pytest.mark.parametrize("name", ["binary.stl", "ascii.stl", "latin1.stl", "box.obj",
                                  "latin1.obj", "box.dae", "binary.ply", "ascii.ply"])
def test_each_format_reads_the_box(tmp_path: Path, name: str) -> None:
    V, F = read_mesh(_box_files(tmp_path)[name])
    volume, area = _volume_and_area(V, F)
    assert volume == pytest.approx(6.0, rel=1e-6)  # outward faces: a positive volume
    assert area == pytest.approx(22.0, rel=1e-6)
    half = np.array(EXTENTS) / 2
    assert np.allclose(V.min(axis=0), -half) and np.allclose(V.max(axis=0), half)


def _declared() -> set[str]:
    """The distributions pyproject.toml's dependencies name, and all they require, installed."""
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    todo = [re.split(r"[\s<>=!~;\[]", d, maxsplit=1)[0] for d in deps]
    seen: set[str] = set()
    while todo:
        name = todo.pop().lower().replace("_", "-")
        if name in seen:
            continue
        seen.add(name)
        try:
            requires = md.requires(name) or []
        except md.PackageNotFoundError:
            continue
        todo += [re.split(r"[\s<>=!~;\[(]", r, maxsplit=1)[0] for r in requires
                 if "extra ==" not in r]
    return seen


def test_what_a_mesh_read_imports_is_declared(tmp_path: Path) -> None:
    """A fresh process reads every file; each distribution it imported (outside the standard
    library) is a declared dependency or one of theirs."""
    files = _box_files(tmp_path)
    code = ("import sys\nstart = set(sys.modules)  # the interpreter's, its site hooks'\n"
            "from mrnea.io.mesh import read_mesh\n"
            "for p in sys.argv[1:]:\n    read_mesh(p)\n"
            "print(' '.join(sorted({m.split('.')[0] for m in set(sys.modules) - start})))")
    res = subprocess.run([sys.executable, "-c", code, *map(str, files.values())],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    owners = md.packages_distributions()
    used = {d.lower().replace("_", "-") for m in res.stdout.split()
            if m not in sys.stdlib_module_names for d in owners.get(m, [])}
    assert "charset-normalizer" in used  # the Latin-1 files need it
    assert used - {"mrnea"} <= _declared(), used - _declared()
