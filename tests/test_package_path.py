"""Missing URDF meshes (issue 22): the warning is short, and how to point mrnea at the meshes
(``--package-path DIR`` or ``ROS_PACKAGE_PATH``) is a line of its own; with ``--package-path`` the
UR5 of example-robot-data, copied away from its package, is drawn with its meshes again."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import pytest
from conftest import erd_path, mrnea_cli

from mrnea.errors import MeshWarning
from mrnea.io import load_robot
from mrnea.io.dispatch import with_package_path
from mrnea.report import shapes

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture
def lone_ur5(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    """The UR5 URDF alone in tmp_path (its package:// meshes unresolvable), and the folder that
    holds the package 'example-robot-data'."""
    urdf = erd_path("ur_description/urdf/ur5_robot.urdf")
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    shutil.copy(urdf, tmp_path / "ur5.urdf")
    return tmp_path / "ur5.urdf", urdf.parents[3]  # .../share holds example-robot-data


def test_the_warning_is_short_and_hints_at_the_package(lone_ur5) -> None:
    urdf, share = lone_ur5
    robot = load_robot(urdf)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        shapes.robot_shapes(robot)
    assert len(caught) == 1 and isinstance(caught[0].message, MeshWarning)
    w = caught[0].message
    assert len(str(w)) < 300 and "7 mesh file(s) not drawn" in str(w), str(w)
    assert "'example-robot-data'" in w.hint and "--package-path" in w.hint
    assert "ROS_PACKAGE_PATH" in w.hint
    found = with_package_path(robot, [share])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every mesh found and read
        bodies = shapes.robot_shapes(found)
    assert all(s.kind == "mesh" for body in bodies[1:] for s in body)


def test_cli_prints_the_hint_on_its_own_line_and_takes_package_path(lone_ur5) -> None:
    urdf, share = lone_ur5
    prog = urdf.parent / "ur5_pick.toml"
    shutil.copy(EXAMPLES / "ur5_pick.toml", prog)
    shutil.copy(EXAMPLES / "ur5_drives.toml", urdf.parent)
    res = mrnea_cli("simulate", urdf, prog, "--out", "o", "--quiet", cwd=urdf.parent)
    assert res.returncode in (0, 1), res.stderr
    lines = [x for x in res.stderr.splitlines() if x.startswith("mrnea: ")]
    warn = [i for i, x in enumerate(lines) if "mesh file(s) not drawn" in x]
    assert len(warn) == 1, res.stderr
    hint = lines[warn[0] + 1]
    assert hint.startswith("mrnea: hint: ") and "--package-path DIR" in hint, res.stderr
    again = mrnea_cli("simulate", urdf, prog, "--out", "p", "--quiet", "--package-path", share,
                      cwd=urdf.parent)
    assert again.returncode in (0, 1), again.stderr
    assert "not drawn" not in again.stderr and "hint" not in again.stderr, again.stderr
