"""Visuals (mrnea.visual.Visual on links and the base): the value object, the URDF and native
TOML readers, fixed-joint merging and the DH form, against closed forms (poses composed by hand)
and Robotics Toolbox's DH frames."""

from __future__ import annotations

import copy
import math
import pickle
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import erd_path

import mrnea
from mrnea import ModelError, RobotFileError
from mrnea.io import load_urdf
from mrnea.io.mesh import mesh_path, read_mesh
from mrnea.io.native import loads_native
from mrnea.model import Joint, Link, Robot
from mrnea.report import shapes
from mrnea.rigid import transform
from mrnea.visual import Visual


def test_visual_is_a_validated_value() -> None:
    v = Visual("box", (0.1, 0.2, 0.3), transform((0, 0, 1), (0.1, 0.2, 0.3)), (1, 0, 0, 1))
    w = Visual("box", [0.1, 0.2, 0.3], transform((0, 0, 1), (0.1, 0.2, 0.3)),
               (1.0, 0.0, 0.0, 1.0))
    assert v == w and hash(v) == hash(w)
    assert pickle.loads(pickle.dumps(v)) == v and copy.deepcopy(v) == v
    assert v != Visual("box", (0.1, 0.2, 0.31), v.origin, v.color)
    assert Visual("sphere", 0.5).size == (0.5,)
    for bad, match in ((("cone", (1.0,)), "expected one of"),
                       (("box", (1.0, 1.0)), "shape"),
                       (("sphere", (0.0,)), "> 0"),
                       (("sphere", (math.nan,)), "NaN"),
                       (("mesh", (1.0, 1.0, 1.0)), "needs the mesh file")):
        with pytest.raises(ModelError, match=match):
            Visual(*bad)
    with pytest.raises(ModelError, match="rigid"):
        Visual("sphere", 1.0, np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(ModelError, match=r"\[0, 1\]"):
        Visual("sphere", 1.0, color=(1.5, 0, 0, 1))
    with pytest.raises(ModelError, match="only a mesh visual"):
        Visual("box", (1, 1, 1), mesh="a.stl")
    T = transform((1, 2, 3), (0.3, -0.2, 0.1))
    np.testing.assert_allclose(v.moved(T).origin, T @ v.origin, atol=0)


def test_visuals_are_part_of_a_robots_value() -> None:
    v = Visual("cylinder", (0.1, 0.5))
    joints = [Joint("j", "revolute", "base", "a")]

    def robot(link_visuals: tuple, base: tuple = ()) -> Robot:
        return Robot(joints, [Link("a", 1.0, visuals=link_visuals)], base_visuals=base)

    r = robot((v,), (Visual("sphere", 0.3),))
    assert r == robot((v,), (Visual("sphere", 0.3),))
    assert r != robot((v,)) and r != robot(())
    back = pickle.loads(pickle.dumps(r))
    assert back == r and back.links[0].visuals == (v,) and back.base_visuals == r.base_visuals
    assert r.with_actuators(effort_limit=3.0).links[0].visuals == (v,)
    loaded = r.with_payload(2.0, (0.1, 0.0, 0.0))  # a payload merges into the last link's mass
    assert loaded.links[0].mass == 3.0 and loaded.links[0].visuals == (v,)
    assert loaded.base_visuals == r.base_visuals
    with pytest.raises(ModelError, match="visuals must be"):
        Link("a", 1.0, visuals=("box",))
    with pytest.raises(ModelError, match="base: visuals must be"):
        Robot(joints, [Link("a", 1.0)], base_visuals=[1])


URDF = """<?xml version="1.0"?>
<robot name="vis">
  <material name="orange"><color rgba="1 0.5 0 1"/></material>
  <link name="world"/>
  <link name="pedestal">
    <visual><origin xyz="0 0 0.25"/><geometry><box size="0.3 0.3 0.5"/></geometry></visual>
  </link>
  <link name="upper">
    <inertial><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0.2 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.05" length="0.4"/></geometry>
      <material name="orange"/></visual>
  </link>
  <link name="tool">
    <visual><origin xyz="0 0 0.02"/><geometry><sphere radius="0.03"/></geometry>
      <material name="inline"><color rgba="0 0 1 0.5"/></material></visual>
    <visual><geometry>
      <mesh filename="package://vispkg/meshes/part.stl" scale="0.001 0.001 0.001"/>
    </geometry></visual>
    <visual><geometry><mesh filename="meshes/missing.stl"/></geometry></visual>
    <visual><geometry><mesh filename="https://example.com/part.stl"/></geometry></visual>
  </link>
  <joint name="fix0" type="fixed"><parent link="world"/><child link="pedestal"/>
    <origin xyz="1 0 0" rpy="0 0 0.5"/></joint>
  <joint name="j1" type="revolute"><parent link="pedestal"/><child link="upper"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <joint name="flange" type="fixed"><parent link="upper"/><child link="tool"/>
    <origin xyz="0.4 0 0" rpy="0.3 0 0"/></joint>
</robot>
"""


@pytest.fixture
def vis_urdf(tmp_path: Path) -> Path:
    """``URDF`` in ``vispkg/urdf/``, with the mesh ``vispkg/meshes/part.stl`` (a ROS layout)."""
    import trimesh
    pkg = tmp_path / "vispkg"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    trimesh.creation.box((10.0, 20.0, 30.0)).export(pkg / "meshes" / "part.stl")
    path = pkg / "urdf" / "vis.urdf"
    path.write_text(URDF)
    return path


def test_urdf_visuals_move_with_the_fixed_joints(vis_urdf: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # missing mesh files are the 3D view's business
        robot = load_urdf(vis_urdf)
    # the base: the pedestal, behind the fixed joint fix0 (world is the root)
    (ped,) = robot.base_visuals
    assert ped.kind == "box" and ped.size == (0.3, 0.3, 0.5) and ped.color is None
    np.testing.assert_allclose(ped.origin, transform((1, 0, 0), (0, 0, 0.5))
                               @ transform((0, 0, 0.25)), atol=1e-15)
    # the moving link: its own visual, then the tool's, moved by the fixed joint 'flange'
    cyl, sphere, mesh, missing, url = robot.links[0].visuals
    assert cyl.kind == "cylinder" and cyl.size == (0.05, 0.4) and cyl.color == (1, 0.5, 0, 1)
    np.testing.assert_allclose(cyl.origin, transform((0.2, 0, 0), (0, math.pi / 2, 0)),
                               atol=1e-15)
    flange = transform((0.4, 0, 0), (0.3, 0, 0))
    assert sphere.size == (0.03,) and sphere.color == (0, 0, 1, 0.5)
    np.testing.assert_allclose(sphere.origin, flange @ transform((0, 0, 0.02)), atol=1e-15)
    assert mesh.kind == "mesh" and mesh.size == (0.001, 0.001, 0.001)
    assert Path(mesh.mesh) == vis_urdf.parents[1] / "meshes" / "part.stl"
    np.testing.assert_allclose(mesh.origin, flange, atol=1e-15)
    V, F = read_mesh(mesh.mesh)
    np.testing.assert_allclose(np.ptp(V, axis=0), (10, 20, 30))
    assert F.shape == (12, 3)
    # the files the view cannot read: where it would be, and the URL as written
    assert Path(missing.mesh) == vis_urdf.parent / "meshes" / "missing.stl"
    assert url.mesh == "https://example.com/part.stl"
    with pytest.raises(RobotFileError, match="not found"):
        read_mesh(missing.mesh)
    with pytest.raises(RobotFileError, match="fetches nothing"):
        read_mesh(url.mesh)
    # the view draws what it can and says, once, what it could not
    with pytest.warns(UserWarning, match=r"'vis': 2 mesh file\(s\) not drawn") as caught:
        bodies = shapes.robot_shapes(robot)
    assert len(caught) == 1
    assert [s.kind for s in bodies[1]] == ["cylinder", "sphere", "mesh"]


def test_urdf_visual_errors_name_the_element(vis_urdf: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text(URDF.replace('<sphere radius="0.03"/>', '<sphere radius="0.03 m"/>'))
    with pytest.raises(RobotFileError, match=r"link 'tool' <visual> #1.*sphere"):
        load_urdf(bad)
    bad.write_text(URDF.replace('<box size="0.3 0.3 0.5"/>', '<box size="0.3 0.3"/>'))
    with pytest.raises(RobotFileError, match=r"link 'pedestal' <visual> #1.*expected 3"):
        load_urdf(bad)
    # a shape the viewer cannot draw, or a size of 0, leaves that visual out: a warning
    bad.write_text(URDF.replace('<box size="0.3 0.3 0.5"/>', '<box size="0.3 0 0.5"/>'))
    with pytest.warns(UserWarning, match="1 visual.*size must be > 0"):
        assert load_urdf(bad).base_visuals == ()
    bad.write_text(URDF.replace('<box size="0.3 0.3 0.5"/>', '<cone radius="1"/>'))
    with pytest.warns(UserWarning, match=r"no geometry the viewer draws \(<cone>\)"):
        assert load_urdf(bad).base_visuals == ()


def test_mesh_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "a" / "pkg" / "m").mkdir(parents=True)
    (tmp_path / "ros" / "other" / "m").mkdir(parents=True)
    for f in ("a/pkg/m/x.stl", "ros/other/m/y.stl", "a/z.stl"):
        (tmp_path / f).write_text("solid x\nendsolid x\n")
    urdf = tmp_path / "a" / "pkg" / "robot.urdf"
    assert mesh_path("package://pkg/m/x.stl", urdf) == str(tmp_path / "a" / "pkg" / "m" / "x.stl")
    assert mesh_path("package://other/m/y.stl", urdf) == "package://other/m/y.stl"
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "ros"))
    assert mesh_path("package://other/m/y.stl", urdf) == str(tmp_path / "ros" / "other" / "m"
                                                            / "y.stl")
    assert mesh_path("../z.stl", urdf) == str(tmp_path / "a" / "z.stl")
    assert mesh_path(f"file://{tmp_path}/a/z.stl", urdf) == str(tmp_path / "a" / "z.stl")
    assert mesh_path("m/x.stl", urdf) == str(tmp_path / "a" / "pkg" / "m" / "x.stl")
    assert mesh_path("gone.stl", urdf) == str(tmp_path / "a" / "pkg" / "gone.stl")
    assert mesh_path("http://example.com/x.stl", urdf) == "http://example.com/x.stl"
    assert mesh_path("x\0.stl", urdf) == "x\0.stl"  # a name the file system refuses
    with pytest.raises(RobotFileError, match="not a regular file"):
        read_mesh(tmp_path / "a")
    bomb = tmp_path / "bomb.dae"  # COLLADA is XML: a DTD's entities are refused, as in a URDF
    bomb.write_text('<?xml version="1.0"?><!DOCTYPE c [<!ENTITY a "aaaa">]><COLLADA>&a;'
                    "</COLLADA>")
    with pytest.raises(RobotFileError, match=r"bomb\.dae: mesh file refused: it has a DOCTYPE"):
        read_mesh(bomb)


def test_real_urdfs_have_their_meshes() -> None:
    """example-robot-data's UR5: one mesh per link and the base, all found and readable."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no visual left out
        robot = load_urdf(erd_path("ur_description/urdf/ur5_robot.urdf"))
    assert [len(lk.visuals) for lk in robot.links] == [1] * 6 and len(robot.base_visuals) == 1
    assert all(v.kind == "mesh" and Path(v.mesh).is_file() for lk in robot.links
               for v in lk.visuals)
    V, F = read_mesh(robot.links[1].visuals[0].mesh)  # upper arm: 0.425 m long
    assert F.shape[0] > 1000 and 0.45 < np.ptp(V[:, 2]) < 0.6


TOML = """
[robot]
name = "toml_vis"
base_visual = [{ cylinder = [0.2, 0.1], xyz = [0.0, 0.0, -0.05], color = [0.2, 0.2, 0.2] }]

[[joint]]
name = "j1"
type = "revolute"
origin = { xyz = [0.0, 0.0, 0.3] }
axis = [0.0, 0.0, 1.0]

[joint.link]
name = "l1"
mass = 1.0
inertia = { ixx = 0.01, iyy = 0.01, izz = 0.01 }

[[joint.link.visual]]
box = [0.5, 0.1, 0.1]
xyz = [0.25, 0.0, 0.0]
color = [1.0, 0.5, 0.0, 0.5]

[[joint.link.visual]]
capsule = [0.05, 0.4]
rpy = [0.0, 1.5707963267948966, 0.0]

[[joint.link.visual]]
sphere = 0.08
"""


def test_native_visuals() -> None:
    robot = loads_native(TOML)
    (base,) = robot.base_visuals
    assert base.kind == "cylinder" and base.color == (0.2, 0.2, 0.2, 1.0)
    np.testing.assert_array_equal(base.origin, transform((0, 0, -0.05)))
    box, capsule, sphere = robot.links[0].visuals
    assert (box.kind, box.size, box.color) == ("box", (0.5, 0.1, 0.1), (1.0, 0.5, 0.0, 0.5))
    np.testing.assert_array_equal(box.origin, transform((0.25, 0, 0)))
    assert capsule.size == (0.05, 0.4) and sphere.size == (0.08,)
    np.testing.assert_array_equal(capsule.origin, transform(rpy=(0, math.pi / 2, 0)))


@pytest.mark.parametrize("edit, match", [
    (("sphere = 0.08", "sphere = 0.08\nbox = [1.0, 1.0, 1.0]"), "exactly one of"),
    (("sphere = 0.08", "sphere = 0.08\nscale = [1.0, 1.0, 1.0]"), "'scale' goes with a mesh"),
    (("sphere = 0.08", "sphere = 0.08\ncolour = [1.0, 1.0, 1.0]"), "did you mean 'color'"),
    (("sphere = 0.08", "sphere = -0.08"), "size must be > 0"),
    (("color = [1.0, 0.5, 0.0, 0.5]", "color = [1.0, 0.5]"), r"\[r, g, b\]"),
    (("color = [1.0, 0.5, 0.0, 0.5]", "color = [2.0, 0.5, 0.0]"), r"in \[0, 1\]"),
    (("box = [0.5, 0.1, 0.1]", "box = [0.5, 0.1]"), "array of 3 numbers"),
    (("base_visual = [{", "base_visual = 3 #"), "array of tables"),
])
def test_native_visual_errors_name_the_link(edit: tuple[str, str], match: str) -> None:
    with pytest.raises(RobotFileError, match=match) as err:
        loads_native(TOML.replace(*edit), "robot.toml")
    assert str(err.value).startswith("robot.toml: ")
    assert "visual" in str(err.value)


def test_native_mesh_is_relative_to_the_file(tmp_path: Path) -> None:
    (tmp_path / "m").mkdir()
    (tmp_path / "m" / "part.stl").write_text("solid x\nendsolid x\n")
    text = TOML + '\n[[joint.link.visual]]\nmesh = "m/part.stl"\nscale = [0.001, 0.001, 0.001]\n'
    (tmp_path / "r.toml").write_text(text)
    robot = mrnea.load_robot(tmp_path / "r.toml")
    mesh = robot.links[0].visuals[-1]
    assert Path(mesh.mesh) == tmp_path / "m" / "part.stl" and mesh.size == (0.001,) * 3
    (tmp_path / "r.toml").write_text(text.replace("m/part.stl", "m/gone.stl"))
    gone = mrnea.load_robot(tmp_path / "r.toml").links[0].visuals[-1]  # read when drawn
    assert Path(gone.mesh) == tmp_path / "m" / "gone.stl"


def test_builtin_robots_have_visuals() -> None:
    for robot in (mrnea.robots.sdt(), mrnea.robots.puma560()):
        assert robot.base_visuals and all(lk.visuals for lk in robot.links), robot.name
        assert all(v.kind != "mesh" for lk in robot.links for v in lk.visuals)


def test_puma_visuals_sit_in_the_dh_frames() -> None:
    """The Puma 560's visuals are given in its DH link frames (as its centres of mass): placed
    by mrnea's link frames they land where Robotics Toolbox's DH frames put them."""
    import tomllib
    from importlib import resources

    import roboticstoolbox as rtb

    puma = mrnea.robots.puma560()
    doc = tomllib.loads(resources.files("mrnea").joinpath("robots", "data", "puma560.toml")
                        .read_text())
    ref = rtb.models.DH.Puma560()
    rng = np.random.default_rng(5)
    for q in rng.uniform(-2, 2, (5, 6)):
        ours = mrnea.forward_kinematics(puma, q)
        theirs = ref.fkine_all(q)  # DH frames 0..6 (base and each link)
        for i, entry in enumerate(doc["joint"]):
            for v, table in zip(puma.links[i].visuals, entry["link"]["visual"], strict=True):
                local = transform(table.get("xyz", (0, 0, 0)), table.get("rpy", (0, 0, 0)))
                np.testing.assert_allclose(ours[i + 1] @ v.origin, theirs[i + 1].A @ local,
                                           atol=1e-12)


def test_visuals_round_trip_through_the_native_writer(vis_urdf: Path, tmp_path: Path) -> None:
    """to_toml writes every visual (a mesh by its absolute path, an origin as rpy or as the
    rotation matrix where rpy would not read back bit for bit); the file reads back equal."""
    robot = load_urdf(vis_urdf)
    assert any(v.kind == "mesh" for v in robot.links[0].visuals) and robot.base_visuals
    back = mrnea.load_robot(robot.to_toml(tmp_path / "r.toml"))
    assert back == robot
    assert back.links[0].visuals == robot.links[0].visuals
    assert back.base_visuals == robot.base_visuals
