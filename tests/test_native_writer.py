"""The native TOML writer (``Robot.to_toml``, ``mrnea.io.write_native``) round-trips a Robot
bit for bit.

Random chains with every limit and actuator field of a joint set (each a random, non-default
value; the list is :data:`mrnea.io.dh.JOINT_FIELDS`, so a field added to ``Joint`` later must be
added here or the test fails), a non-default gravity and names TOML must escape; the built-in
robots (one from a DH table); real URDFs from example-robot-data (URDF -> Robot -> TOML ->
Robot). "Bit for bit": every float compared by its IEEE bytes (``-0.0`` and ``0.0`` differ),
not only by the Robot's value equality.
"""

from __future__ import annotations

import math
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import erd_path, random_chain

import mrnea
from mrnea.errors import OutputError, RobotFileError
from mrnea.io import dumps_native, load_native, load_robot, loads_native, write_native
from mrnea.io.dh import JOINT_FIELDS
from mrnea.model import Joint, Link, Robot

#: how the test draws each of JOINT_FIELDS (a field without an entry fails the test)
_LIMITS = ("lower", "upper")


def _bits(x: object) -> object:
    """A comparable form of a value in which every float is its 8 IEEE bytes."""
    if isinstance(x, np.ndarray):
        return (x.shape, x.astype(np.float64).tobytes())
    if isinstance(x, float):
        return struct.pack("<d", x)
    if isinstance(x, tuple):
        return tuple(_bits(v) for v in x)
    return x


def bits(robot: Robot) -> tuple:
    """Everything a Robot holds, floats as bytes."""
    joints = tuple(tuple((f, _bits(getattr(j, f))) for f in (
        "name", "type", "parent", "child", "origin", "axis", *JOINT_FIELDS))
        for j in robot.joints)
    links = tuple((lk.name, _bits(lk.mass), _bits(lk.com), _bits(lk.inertia))
                  for lk in robot.links)
    return (robot.name, robot.base, _bits(robot.gravity), joints, links)


def with_every_field(robot: Robot, rng: np.random.Generator) -> Robot:
    """``robot`` with every joint field of JOINT_FIELDS set to a random non-default value
    (a torque-speed curve on every other joint, a constant effort limit on the rest)."""
    n = robot.n
    fields = {
        "lower": -rng.uniform(0.1, 3.0, n), "upper": rng.uniform(0.1, 3.0, n),
        "velocity_limit": rng.uniform(0.5, 5.0, n), "effort_limit": rng.uniform(1.0, 300.0, n),
        "gear_ratio": rng.uniform(1.0, 200.0, n), "rotor_inertia": rng.uniform(1e-6, 1e-3, n),
        "viscous_friction": rng.uniform(0.0, 2.0, n),
        "coulomb_friction": rng.uniform(0.0, 5.0, n), "efficiency": rng.uniform(0.3, 1.0, n),
    }
    curves = [(float(rng.uniform(10, 100)), float(rng.uniform(0.5, 2)), float(rng.uniform(2, 9)))
              if i % 2 else None for i in range(n)]
    assert set(JOINT_FIELDS) == {*fields, "torque_speed"}, "a new joint field: draw it here"
    joints = []
    for i, j in enumerate(robot.joints):
        kw = {k: float(v[i]) for k, v in fields.items()}
        if curves[i] is not None:
            kw.pop("effort_limit")
        joints.append(Joint(j.name, j.type, j.parent, j.child, j.origin, j.axis,
                            torque_speed=curves[i], **kw))
    return robot._replace(joints=joints)


@pytest.mark.parametrize("seed", range(8))
def test_random_robots_with_every_field_round_trip_bit_for_bit(seed: int,
                                                               tmp_path: Path) -> None:
    rng = np.random.default_rng(seed)
    robot = with_every_field(random_chain(rng, int(rng.integers(1, 9)), 0.4,
                                          gravity=rng.normal(0.0, 5.0, 3)), rng)
    assert any(j.torque_speed for j in robot.joints) or robot.n == 1
    assert all(j.rotor_inertia > 0 for j in robot.joints)
    path = robot.to_toml(tmp_path / "robot.toml")
    assert path == tmp_path / "robot.toml"
    back = load_robot(path)
    assert back == robot
    assert bits(back) == bits(robot)


def test_what_toml_must_escape_and_what_a_float_can_be(tmp_path: Path) -> None:
    """Names with quotes, backslashes, a tab and non-ASCII letters; a continuous joint (no
    limits written); infinities, -0.0, subnormal and huge numbers; an inertia that is not
    exactly symmetric (written as a 3x3 array) and a rotation that roll-pitch-yaw angles do
    not give back bit for bit (written as a matrix)."""
    rng = np.random.default_rng(3)
    asym = np.diag([1.0, 2.0, 2.5])
    asym[0, 1] = 1e-12  # symmetric to within the model's tolerance only
    origin = np.eye(4)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    origin[:3, :3] = Q * np.sign(np.linalg.det(Q))
    joints = [Joint('a "quoted" \\ joint', "continuous", "bäse\twith tab", "l1", origin=origin,
                    axis=(0.6, 0.0, 0.8), viscous_friction=-0.0),
              Joint("j2", "prismatic", "l1", "Glied 2 ✓", lower=-1e300, upper=5e-324,
                    velocity_limit=math.inf, rotor_inertia=np.nextafter(1e3, 0.0))]  # 17 digits
    links = [Link("l1", 2.0, (-0.0, 1e-310, 3.0), asym),
             Link("Glied 2 ✓", 0.1, (0.0, 0.0, 0.1), np.diag([1e-3, 1e-3, 1e-3]))]
    robot = Robot(joints, links, gravity=(0.0, 9.81, -0.0), name="it's a \"robot\"",
                  base="bäse\twith tab")
    text = dumps_native(robot)
    assert "rotation = " in text and "inertia = [[" in text
    back = loads_native(text)
    assert bits(back) == bits(robot)
    assert bits(load_robot(write_native(robot, tmp_path / "x.toml"))) == bits(robot)


@pytest.mark.parametrize("name", ["sdt", "puma560"])
def test_builtin_robots_round_trip(name: str, tmp_path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Puma's published inertias draw a ModelWarning
        robot = getattr(mrnea.robots, name)()
        back = load_native(robot.to_toml(tmp_path / f"{name}.toml"))
    assert bits(back) == bits(robot)


URDFS = {"ur5": ("ur_description/urdf/ur5_robot.urdf", None),
         "panda": ("panda_description/urdf/panda.urdf", "panda_hand"),
         "kinova": ("kinova_description/robots/kinova.urdf", None),
         "pr2-right-arm": ("pr2_description/urdf/pr2.urdf", "r_wrist_roll_link")}


@pytest.mark.parametrize("name", URDFS)
def test_urdf_robot_toml_robot(name: str, tmp_path: Path) -> None:
    rel, tip = URDFS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        robot = mrnea.load_urdf(erd_path(rel), tip=tip)
    robot = robot.with_actuators(rotor_inertia=2e-5, torque_speed=(50.0, 1.5, 4.0))
    back = load_robot(robot.to_toml(tmp_path / "robot.toml"))
    assert bits(back) == bits(robot)


def test_written_file_is_refused_without_overwrite(tmp_path: Path) -> None:
    robot = random_chain(np.random.default_rng(1), 2)
    path = robot.to_toml(tmp_path / "r.toml")
    before = path.read_bytes()
    other = robot.with_gravity((0.0, 0.0, -1.62))
    with pytest.raises(OutputError, match="exists"):
        other.to_toml(path)
    assert path.read_bytes() == before
    assert load_robot(other.to_toml(path, overwrite=True)) == other
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.toml"]


def test_origin_rotation_key() -> None:
    """``rotation`` (3x3, parent link -> joint frame) is read as given; with rpy, an error."""
    doc = """[robot]
name = "r"
[[joint]]
name = "j"
type = "revolute"
axis = [0.0, 0.0, 1.0]
[joint.origin]
xyz = [0.1, 0.0, 0.0]
rotation = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
{extra}
[joint.link]
mass = 1.0
"""
    robot = loads_native(doc.format(extra=""))
    np.testing.assert_array_equal(robot.joints[0].origin[:3, :3],
                                  [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    with pytest.raises(RobotFileError, match="give 'rpy' or 'rotation', not both"):
        loads_native(doc.format(extra="rpy = [0.0, 0.0, 0.0]"))
    with pytest.raises(RobotFileError, match="origin is not a rigid transform"):
        loads_native(doc.format(extra="").replace("[1.0, 0.0, 0.0], [0.0", "[2.0, 0.0, 0.0], "
                                                                            "[0.0"))


def test_link_frames_round_trip_and_name_a_tool(tmp_path):
    """A URDF's fixed-joint frames (UR5: ee_link, tool0) are written as the link's ``frame``
    array and read back equal, bit for bit; the tool they name has the pose Pinocchio gives
    the URDF frame."""
    import pinocchio as pin

    path = erd_path("ur_description/urdf/ur5_robot.urdf")
    robot = mrnea.load_urdf(path)
    assert [f.name for f in robot.links[-1].frames] == ["ee_link", "tool0"]
    back = mrnea.load_robot(robot.to_toml(tmp_path / "ur5.toml"))
    assert back == robot
    for a, b in zip(robot.links[-1].frames, back.links[-1].frames, strict=True):
        assert a.name == b.name and np.asarray(a.origin).tobytes() == np.asarray(b.origin).tobytes()
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    q = np.random.default_rng(0).uniform(-2, 2, robot.n)
    pin.framesForwardKinematics(model, data, q)
    T = mrnea.forward_kinematics(back, q, tool="tool0")[-1]
    assert np.allclose(T, data.oMf[model.getFrameId("tool0")].homogeneous, atol=1e-12)
