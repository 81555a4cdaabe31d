"""DH tables, the native TOML format and the built-in robots (SDT, Puma 560).

Forward kinematics here is written independently of mrnea's loaders: the plain DH product
A_1 ... A_i (closed-form DH matrices) on one side, and the URDF-style chain
T_i = T_{i-1} @ origin_i @ motion(q_i) composed with numpy on the other.
"""

from __future__ import annotations

import math
import pathlib
import re
import textwrap
import zlib

import numpy as np
import pytest
from naive import forward_kinematics

from mrnea.errors import ModelError, ProgramFileError, RobotFileError
from mrnea.io import load_program
from mrnea.io.dh import DHRow, dh_joint_chain, dh_tip_transform
from mrnea.io.dispatch import BUILTIN_ROBOTS, load_builtin
from mrnea.io.native import load_native, loads_native
from mrnea.model import Robot
from mrnea.rigid import transform
from mrnea.robots import puma560, sdt

# --- independent kinematics -------------------------------------------------------------------


def dh_standard(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """Closed-form standard DH matrix Rz(theta) Tz(d) Tx(a) Rx(alpha)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([
        [ct, -st * ca, st * sa, a * ct],
        [st, ct * ca, -ct * sa, a * st],
        [0.0, sa, ca, d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def dh_modified(a: float, alpha: float, d: float, theta: float) -> np.ndarray:
    """Closed-form modified (Craig) DH matrix Rx(alpha) Tx(a) Rz(theta) Tz(d)."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([
        [ct, -st, 0.0, a],
        [st * ca, ct * ca, -sa, -sa * d],
        [st * sa, ct * sa, ca, ca * d],
        [0.0, 0.0, 0.0, 1.0],
    ])


def dh_frames(rows: list[dict], q: np.ndarray, convention: str) -> list[np.ndarray]:
    """Base poses of DH frames 1..n for joint positions q."""
    A = dh_standard if convention == "standard" else dh_modified
    T = np.eye(4)
    out = []
    for r, qi in zip(rows, q, strict=True):
        prismatic = r["type"] == "prismatic"
        theta = r["theta"] + (0.0 if prismatic else qi)
        d = r["d"] + (qi if prismatic else 0.0)
        T = T @ A(r["a"], r["alpha"], d, theta)
        out.append(T)
    return out


def motion(axis: np.ndarray, q: float, prismatic: bool) -> np.ndarray:
    """4x4 motion of a joint: rotation by q about axis (Rodrigues) or translation q along it."""
    M = np.eye(4)
    u = np.asarray(axis, dtype=float)
    if prismatic:
        M[:3, 3] = q * u
        return M
    K = np.array([[0.0, -u[2], u[1]], [u[2], 0.0, -u[0]], [-u[1], u[0], 0.0]])
    M[:3, :3] = np.eye(3) + math.sin(q) * K + (1.0 - math.cos(q)) * K @ K
    return M


def chain_frames(joints, q) -> list[np.ndarray]:
    """Base poses of mrnea link frames: T_i = T_{i-1} @ origin_i @ motion(q_i)."""
    T = np.eye(4)
    out = []
    for j, qi in zip(joints, q, strict=True):
        T = T @ j.origin @ motion(j.axis, qi, j.type == "prismatic")
        out.append(T)
    return out


def joint_frames(robot: Robot, q) -> list[np.ndarray]:
    """Base poses of the joint frames (parent link pose @ origin), before the joint moves."""
    links = [np.eye(4), *chain_frames(robot.joints, q)[:-1]]
    return [T @ j.origin for T, j in zip(links, robot.joints, strict=True)]


def com_base(T: np.ndarray, com: np.ndarray) -> np.ndarray:
    return T[:3, :3] @ com + T[:3, 3]


def random_spd(rng: np.random.Generator) -> np.ndarray:
    L = rng.normal(size=(3, 3))
    return L @ L.T + 0.1 * np.eye(3)


def random_rows(rng: np.random.Generator, types: list[str]) -> list[dict]:
    return [
        {
            "a": rng.uniform(-0.5, 0.5), "alpha": rng.uniform(-math.pi, math.pi),
            "d": rng.uniform(-0.5, 0.5), "theta": rng.uniform(-math.pi, math.pi),
            "type": t, "mass": rng.uniform(0.5, 5.0), "com": rng.uniform(-0.3, 0.3, 3),
            "inertia": random_spd(rng), "name": f"j{i}", "link_name": f"l{i}",
        }
        for i, t in enumerate(types, start=1)
    ]


# --- DH tables --------------------------------------------------------------------------------

TYPE_MIXES = {
    "revolute": ["revolute"] * 5,
    "prismatic": ["prismatic"] * 3,
    "mixed": ["revolute", "prismatic", "revolute", "continuous", "prismatic", "revolute"],
}


@pytest.mark.parametrize("convention", ["standard", "modified"])
@pytest.mark.parametrize("mix", sorted(TYPE_MIXES))
def test_dh_forward_kinematics_of_centres_of_mass(convention: str, mix: str) -> None:
    rng = np.random.default_rng(zlib.crc32(f"{convention}/{mix}".encode()))
    rows = random_rows(rng, TYPE_MIXES[mix])
    joints, links = dh_joint_chain(rows, convention)
    robot = Robot(joints, links)  # validates the chain
    assert [j.name for j in joints] == [r["name"] for r in rows]
    assert [lk.name for lk in links] == [r["link_name"] for r in rows]
    for j in robot.joints:
        np.testing.assert_allclose(j.axis, [0.0, 0.0, 1.0])
    for _ in range(5):
        q = rng.uniform(-2.0, 2.0, len(rows))
        dh = dh_frames(rows, q, convention)
        ours = chain_frames(robot.joints, q)
        for r, lk, F, L in zip(rows, robot.links, dh, ours, strict=True):
            np.testing.assert_allclose(com_base(L, lk.com), com_base(F, r["com"]), atol=1e-12)
            # the same inertia tensor in base axes
            np.testing.assert_allclose(L[:3, :3] @ lk.inertia @ L[:3, :3].T,
                                       F[:3, :3] @ r["inertia"] @ F[:3, :3].T, atol=1e-12)
            assert lk.mass == r["mass"]
        # joint i moves about z_{i-1} (standard) / z_i (modified), through that frame's origin
        prev = [np.eye(4), *dh[:-1]] if convention == "standard" else dh
        for jf, F in zip(joint_frames(robot, q), prev, strict=True):
            np.testing.assert_allclose(jf[:3, 2], F[:3, 2], atol=1e-12)
            np.testing.assert_allclose(np.cross(jf[:3, 3] - F[:3, 3], F[:3, 2]), 0.0,
                                       atol=1e-12)
        # the DH flange frame n = last link frame @ tip transform
        np.testing.assert_allclose(ours[-1] @ dh_tip_transform(rows, convention), dh[-1],
                                   atol=1e-12)


def test_dh_rows_as_dataclasses_and_defaults() -> None:
    rows = [DHRow(a=0.3, alpha=0.0, d=0.1),
            DHRow(a=0.2, alpha=0.5, d=0.0, type="prismatic",
                  joint={"lower": -0.1, "upper": 0.2, "gear_ratio": 3.0})]
    joints, links = dh_joint_chain(rows, base="ground")
    assert [j.name for j in joints] == ["joint1", "joint2"]
    assert [lk.name for lk in links] == ["link1", "link2"]
    assert joints[0].parent == "ground" and joints[1].parent == "link1"
    assert joints[1].type == "prismatic" and joints[1].upper == 0.2
    assert joints[1].gear_ratio == 3.0
    np.testing.assert_allclose(joints[0].origin, np.eye(4))


@pytest.mark.parametrize(
    ("rows", "convention", "match"),
    [
        ([{"a": 0, "alpha": 0, "d": 0}], "craig", "convention"),
        ([{"a": 0, "alpha": 0}], "standard", "missing DH parameter"),
        ([{"a": 0, "alpha": 0, "d": 0, "name": "elbow", "typo": 1}], "standard",
         "joint 'elbow'.*unknown field"),
        ([{"a": 0, "alpha": 0, "d": 0, "name": "elbow", "type": "ball"}], "standard",
         "joint 'elbow'.*unsupported joint type"),
        ([{"a": "x", "alpha": 0, "d": 0, "name": "elbow"}], "standard", "joint 'elbow'.*a"),
        ([{"a": 0, "alpha": 0, "d": 0, "link_name": "forearm", "mass": -1}], "modified",
         "link 'forearm'.*mass"),
        ([], "standard", "empty"),
        ([DHRow(a=0, alpha=0, d=0, name="elbow", joint={"gear": 2.0})], "standard",
         r"joint 'elbow'.*unknown joint field\(s\) gear;"),
    ],
)
def test_dh_errors(rows, convention, match) -> None:
    with pytest.raises(ModelError, match=match):
        dh_joint_chain(rows, convention)


# --- native TOML format -----------------------------------------------------------------------

ORIGIN_EXAMPLE = """
[robot]
name = "demo"
gravity = [0.0, -9.81, 0.0]
base = "ground"

[[joint]]
name = "shoulder"
type = "revolute"
origin = { xyz = [0.1, 0.2, 0.5], rpy = [0.3, -0.2, 0.7] }
axis = [0.0, 0.0, 2.0]
lower = -2.0
upper = 2.5
velocity_limit = 3.0
effort_limit = 50.0
gear_ratio = 100.0
rotor_inertia = 1e-4
viscous_friction = 0.5
coulomb_friction = 1.5

[joint.link]
name = "upper_arm"
mass = 2.0
com = [0.2, 0.0, 0.01]
inertia = { ixx = 0.01, iyy = 0.03, izz = 0.035, ixy = 0.001, ixz = -0.002, iyz = 0.0005 }

[[joint]]
name = "slide"
type = "prismatic"
origin = { xyz = [0.4, 0.0, 0.0] }
axis = [1.0, 0.0, 0.0]
upper = inf
effort_limit = 200.0

[joint.link]
name = "carriage"
mass = 1.0
inertia = [[0.002, 0.0, 0.0], [0.0, 0.003, 0.0], [0.0, 0.0, 0.004]]

[[joint]]
name = "wrist"
type = "continuous"
axis = [0.0, 1.0, 0.0]
torque_speed = [12.0, 3.0, inf]

[joint.link]
mass = 0.5
com = [0.0, 0.0, 0.05]
"""


def test_native_origin_form_round_trip(tmp_path) -> None:
    path = tmp_path / "demo.toml"
    path.write_text(ORIGIN_EXAMPLE, encoding="utf-8")
    robot = load_native(path)
    assert robot.name == "demo" and robot.base == "ground" and robot.n == 3
    np.testing.assert_allclose(robot.gravity, [0.0, -9.81, 0.0])
    assert robot.joint_names == ("shoulder", "slide", "wrist")
    assert robot.link_names == ("upper_arm", "carriage", "link3")
    sh, sl, wr = robot.joints
    np.testing.assert_allclose(sh.origin, transform([0.1, 0.2, 0.5], [0.3, -0.2, 0.7]))
    np.testing.assert_allclose(sh.axis, [0.0, 0.0, 1.0])
    assert (sh.lower, sh.upper, sh.velocity_limit, sh.effort_limit) == (-2.0, 2.5, 3.0, 50.0)
    assert (sh.gear_ratio, sh.rotor_inertia, sh.viscous_friction, sh.coulomb_friction) == (
        100.0, 1e-4, 0.5, 1.5)
    assert sl.type == "prismatic" and sl.parent == "upper_arm" and sl.upper == math.inf
    np.testing.assert_allclose(sl.origin, transform([0.4, 0.0, 0.0]))
    assert sl.lower == -math.inf and sl.gear_ratio == 1.0 and sl.velocity_limit == math.inf
    assert wr.type == "continuous"
    assert wr.torque_speed == (12.0, 3.0, math.inf) and wr.effort_limit == 12.0
    assert sh.torque_speed is None
    np.testing.assert_allclose(wr.origin, np.eye(4))
    ua, ca, l3 = robot.links
    assert ua.mass == 2.0
    np.testing.assert_allclose(ua.com, [0.2, 0.0, 0.01])
    np.testing.assert_allclose(ua.inertia, [[0.01, 0.001, -0.002],
                                            [0.001, 0.03, 0.0005],
                                            [-0.002, 0.0005, 0.035]])
    np.testing.assert_allclose(ca.com, 0.0)
    np.testing.assert_allclose(ca.inertia, np.diag([0.002, 0.003, 0.004]))
    np.testing.assert_allclose(l3.inertia, 0.0)
    # default robot name: the file's stem
    path2 = tmp_path / "noname.toml"
    path2.write_text(ORIGIN_EXAMPLE.replace('name = "demo"\n', ""), encoding="utf-8")
    assert load_native(path2).name == "noname"


@pytest.mark.parametrize("convention", ["standard", "modified"])
def test_native_dh_form_matches_dh_joint_chain(convention: str) -> None:
    rng = np.random.default_rng(7)
    rows = random_rows(rng, ["revolute", "prismatic", "revolute"])
    parts = [f'[robot]\nname = "dh_demo"\ndh = "{convention}"\n']
    for r in rows:
        I = r["inertia"]
        parts.append(textwrap.dedent(f"""
            [[joint]]
            name = "{r['name']}"
            type = "{r['type']}"
            a = {r['a']!r}
            alpha = {r['alpha']!r}
            d = {r['d']!r}
            theta = {r['theta']!r}
            effort_limit = 12.5

            [joint.link]
            name = "{r['link_name']}"
            mass = {r['mass']!r}
            com = [{', '.join(repr(float(x)) for x in r['com'])}]
            inertia = [{', '.join('[' + ', '.join(repr(float(x)) for x in row) + ']'
                                  for row in I)}]
            """))
    robot = loads_native("".join(parts))
    joints, links = dh_joint_chain(rows, convention)
    for j, ref in zip(robot.joints, joints, strict=True):
        assert (j.name, j.type, j.parent, j.child) == (ref.name, ref.type, ref.parent, ref.child)
        np.testing.assert_allclose(j.origin, ref.origin, atol=1e-15)
        assert j.effort_limit == 12.5
    for lk, ref in zip(robot.links, links, strict=True):
        assert lk.mass == ref.mass
        np.testing.assert_allclose(lk.com, ref.com, atol=1e-15)
        np.testing.assert_allclose(lk.inertia, ref.inertia, atol=1e-15)


GOOD_JOINT = """
[robot]
name = "bad"

[[joint]]
name = "elbow"
type = "revolute"
axis = [0.0, 0.0, 1.0]
{joint_extra}

[joint.link]
name = "forearm"
{link_body}
"""


def _one_joint(joint_extra: str = "", link_body: str = "mass = 1.0") -> str:
    return GOOD_JOINT.format(joint_extra=joint_extra, link_body=link_body)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (_one_joint(joint_extra="lower = = 1.0"), r"bad\.toml: invalid TOML.*line 9"),
        (_one_joint(joint_extra="velocity_limt = 2.0"),
         r"joint 'elbow': unknown key 'velocity_limt' \(did you mean 'velocity_limit'\?\)"),
        (_one_joint(link_body="mass = 1.0\ncomm = [0, 0, 0]"),
         r"joint 'elbow': link 'forearm': unknown key 'comm'"),
        (_one_joint(link_body="com = [0.0, 0.0, 0.0]"),
         r"joint 'elbow': link 'forearm': missing required key 'mass'"),
        (_one_joint(link_body="mass = -2.0"), r"joint 'elbow'.*link 'forearm'.*mass"),
        (_one_joint(link_body="mass = 1.0\ncom = [0.0, 0.1]"),
         r"link 'forearm': 'com' must be an array of 3 numbers, got 2 entries"),
        (_one_joint(link_body='mass = "heavy"'), r"link 'forearm': 'mass' must be a number"),
        (_one_joint(link_body="mass = true"), r"link 'forearm': 'mass' must be a number"),
        (_one_joint(link_body="mass = 1.0\ninertia = { ixx = 1.0, iyy = 1.0 }"),
         r"link 'forearm': inertia: missing required key 'izz'"),
        (_one_joint(link_body="mass = 1.0\ninertia = { ixx = 1.0, iyy = 1.0, izz = 1.0, "
                              "ixy = 5.0 }"),
         r"link 'forearm'.*positive semi-definite"),
        (_one_joint(link_body="mass = 1.0\ninertia = [[1.0, 0.0], [0.0, 1.0]]"),
         r"link 'forearm'.*inertia"),
        (_one_joint(link_body="mass = 1.0\ninertia = { ixx = 1, iyy = 1, izz = 1, ixq = 0 }"),
         r"link 'forearm': inertia: unknown key 'ixq'"),
        (_one_joint(joint_extra="lower = 2.0\nupper = 1.0"), r"joint 'elbow'.*lower limit"),
        (_one_joint(joint_extra="effort_limit = -5.0"), r"joint 'elbow'.*effort_limit"),
        (_one_joint(joint_extra="gear_ratio = 0.0"), r"joint 'elbow'.*gear_ratio"),
        (_one_joint(joint_extra="torque_speed = [10.0, 2.0]"),
         r"joint 'elbow': 'torque_speed' must be an array of 3 numbers"),
        (_one_joint(joint_extra="torque_speed = [10.0, 5.0, 2.0]"),
         r"joint 'elbow'.*torque_speed needs"),
        (_one_joint(joint_extra="torque_speed = [10.0, 2.0, 5.0]\neffort_limit = 8.0"),
         r"joint 'elbow': give either 'effort_limit' or 'torque_speed'"),
        (_one_joint(joint_extra="origin = { xyz = [0, 0, 1], rpyy = [0, 0, 0] }"),
         r"joint 'elbow': origin: unknown key 'rpyy'"),
        (_one_joint(joint_extra="origin = [0, 0, 1]"), r"joint 'elbow': 'origin' must be a table"),
        (_one_joint(joint_extra="a = 0.5"), r"joint 'elbow': key 'a' not allowed.*dh"),
        (_one_joint().replace('type = "revolute"', 'type = "ball"'),
         r"joint 'elbow': unsupported joint type 'ball'"),
        (_one_joint().replace('type = "revolute"\n', ""),
         r"joint 'elbow': missing required key 'type'"),
        (_one_joint().replace("axis = [0.0, 0.0, 1.0]\n", ""),
         r"joint 'elbow': missing required key 'axis'"),
        (_one_joint().replace("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 0.0, 0.0]"),
         r"joint 'elbow'.*axis is zero"),
        (_one_joint().replace('name = "elbow"\n', ""), r"joint #1: missing required key 'name'"),
        (_one_joint().replace("[joint.link]", "[joint.lnk]"), r"joint 'elbow': unknown key 'lnk'"),
        (_one_joint().replace('[robot]\nname = "bad"', '[robot]\nname = "bad"\ngravity = 9.81'),
         r"\[robot\]: 'gravity' must be an array of 3 numbers"),
        (_one_joint().replace('[robot]\nname = "bad"', '[robot]\nname = "bad"\ndh = "craig"'),
         r"\[robot\]: 'dh' must be one of"),
        (_one_joint().replace('[robot]\nname = "bad"', '[robot]\nname = "bad"\nauthor = "me"'),
         r"\[robot\]: unknown key 'author'"),
        (_one_joint().replace("[[joint]]", "[joint]"),
         r"'joint' must be an array of tables"),
        ('[robot]\nname = "bad"\n', r"no \[\[joint\]\] tables"),
        ('[robot]\nname = "bad"\n[[joints]]\nname = "x"\n', r"unknown key 'joints'"),
    ],
)
def test_native_malformed_files(tmp_path, text: str, match: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(RobotFileError, match=match):
        load_native(path)


def test_native_dh_form_errors() -> None:
    base = '[robot]\ndh = "standard"\n[[joint]]\nname = "j1"\ntype = "revolute"\n{extra}\n' \
           "[joint.link]\nname = \"l1\"\nmass = 1.0\n"
    with pytest.raises(RobotFileError, match=r"joint 'j1': missing required key 'alpha'"):
        loads_native(base.format(extra="a = 0.1\nd = 0.2"))
    with pytest.raises(RobotFileError, match=r"joint 'j1': key 'axis' not allowed.*dh"):
        loads_native(base.format(extra="a = 0.1\nalpha = 0.0\nd = 0.2\naxis = [0, 0, 1]"))
    with pytest.raises(RobotFileError, match=r"joint 'j1': 'theta' must be a number"):
        loads_native(base.format(extra='a = 0.1\nalpha = 0.0\nd = 0.2\ntheta = "90deg"'))
    with pytest.raises(RobotFileError, match=r"joint 'j1': link 'l1': mass must be >= 0"):
        loads_native(base.format(extra="a = 0.1\nalpha = 0.0\nd = 0.2").replace(
            "mass = 1.0", "mass = -1.0"))
    one = base.format(extra="a = 0.1\nalpha = 0.0\nd = 0.2")
    dup = one + one.removeprefix('[robot]\ndh = "standard"\n')
    with pytest.raises(RobotFileError, match=r"duplicate joint names: j1"):
        loads_native(dup)


def test_native_unreadable_file(tmp_path) -> None:
    with pytest.raises(RobotFileError, match=r"missing\.toml: robot file not found"):
        load_native(tmp_path / "missing.toml")
    bad = tmp_path / "latin1.toml"
    bad.write_bytes(b"[robot]\nname = \"\xe9\"\n")
    with pytest.raises(RobotFileError, match=r"latin1\.toml: cannot read"):
        load_native(bad)


def test_native_errors_are_model_errors() -> None:
    assert issubclass(RobotFileError, ModelError)
    with pytest.raises(ModelError):
        loads_native("[[joint]]\nname = 3\n")


# --- built-in robots --------------------------------------------------------------------------


def test_builtin_names_and_load() -> None:
    assert set(BUILTIN_ROBOTS) == {"sdt", "puma560"}
    for name in BUILTIN_ROBOTS:
        robot = load_builtin(name)
        assert robot.name == name
    with pytest.raises(RobotFileError, match="unknown built-in robot 'r2d2'"):
        load_builtin("r2d2")


SDT_A1, SDT_D2 = 3.0, 1.6


def test_sdt_geometry_matches_the_paper() -> None:
    robot = sdt()
    assert robot.n == 4
    assert all(j.type in ("revolute", "continuous") for j in robot.joints)
    rng = np.random.default_rng(42)
    for _ in range(20):
        q = rng.uniform(-math.pi, math.pi, 4)
        q[3] = rng.uniform(robot.joints[3].lower, robot.joints[3].upper)
        jf = joint_frames(robot, q)
        origins = [T[:3, 3] for T in jf]
        axes = [T[:3, :3] @ j.axis for T, j in zip(jf, robot.joints, strict=True)]
        # joints 1 and 2 are vertical; joint 1 passes through the base origin
        for k in (0, 1):
            np.testing.assert_allclose(np.abs(axes[k]), [0.0, 0.0, 1.0], atol=1e-12)
        np.testing.assert_allclose(origins[0], 0.0, atol=1e-12)
        # p1* = a1 [c1, s1, 0]: the cabin-yaw joint sits at the arm tip
        np.testing.assert_allclose(origins[1], SDT_A1 * np.array([math.cos(q[0]),
                                                                  math.sin(q[0]), 0.0]),
                                   atol=1e-12)
        # p2* = [0, 0, d2]: gimbal centre straight above the yaw joint; p3* = p4* = 0
        centre = origins[1] + [0.0, 0.0, SDT_D2]
        # the roll and pitch axes are lines through one point, the gimbal centre
        for k in (2, 3):
            np.testing.assert_allclose(np.cross(origins[k] - centre, axes[k]), 0.0, atol=1e-12)
        n = np.cross(axes[2], axes[3])
        assert np.linalg.norm(n) > 0.99  # perpendicular, so the lines meet in exactly one point
        assert abs(np.dot(origins[3] - origins[2], n)) < 1e-12
        # the roll axis is horizontal (it turns about the vertical yaw axis)
        assert abs(axes[2][2]) < 1e-12


def test_sdt_data_is_complete_and_plausible() -> None:
    robot = sdt()
    assert np.all(robot.masses > 100.0)
    assert 5000.0 < robot.masses.sum() < 20000.0  # several tonnes rotating
    for field in ("effort_limit", "velocity_limit"):
        values = getattr(robot, field)
        assert np.all(np.isfinite(values)) and np.all(values > 0), field
    for field in ("gear_ratio", "rotor_inertia", "viscous_friction", "coulomb_friction"):
        assert np.all(getattr(robot, field) > 0), field
    # a few g at the cabin at the planetary velocity limit
    g_radial = robot.velocity_limit[0] ** 2 * SDT_A1 / 9.81
    assert 2.0 < g_radial < 5.0
    for lk in robot.links:
        assert np.all(np.linalg.eigvalsh(lk.inertia) > 0.0), lk.name


def _rtb_puma():
    import roboticstoolbox as rtb
    return rtb.models.DH.Puma560()


def test_puma560_matches_robotics_toolbox() -> None:
    ref = _rtb_puma()
    robot = puma560()
    assert robot.n == ref.n == 6
    rng = np.random.default_rng(3)
    for L, lk, j in zip(ref.links, robot.links, robot.joints, strict=True):
        assert lk.mass == pytest.approx(L.m, abs=0)
        assert j.gear_ratio == pytest.approx(abs(L.G), rel=1e-12)
        assert j.rotor_inertia == pytest.approx(L.Jm, rel=1e-12)
        assert j.viscous_friction == pytest.approx(L.B * L.G**2, rel=1e-9)
        # asymmetric Coulomb friction as published: RTB's own friction model (joint side,
        # the sign of the joint velocity picks Tc+ or Tc-) minus its viscous part
        for v, F in ((1e-3, j.coulomb_pair[0]), (-1e-3, -j.coulomb_pair[1])):
            assert -L.friction(v) - L.B * L.G**2 * v == pytest.approx(F, rel=1e-9)
        assert j.coulomb_pair[0] != j.coulomb_pair[1]
        assert (j.lower, j.upper) == pytest.approx(tuple(L.qlim), abs=1e-12)
    qs = [np.zeros(6), *rng.uniform(-math.pi, math.pi, (4, 6))]
    for q in qs:
        frames = ref.fkine_all(q)
        dh = [frames[i].A for i in range(1, 7)]  # frames[0] is the base
        ours = chain_frames(robot.joints, q)
        for L, lk, F, T in zip(ref.links, robot.links, dh, ours, strict=True):
            # centre of mass in the base frame
            np.testing.assert_allclose(com_base(T, lk.com), com_base(F, np.asarray(L.r)),
                                       atol=1e-12)
            # inertia transformed back to DH frame i equals RTB's I
            R = F[:3, :3].T @ T[:3, :3]  # our link frame in DH frame i
            np.testing.assert_allclose(R @ lk.inertia @ R.T, L.I, atol=1e-12)
        # the DH flange frame
        rows = [{"a": L.a, "alpha": L.alpha, "d": L.d, "theta": L.offset} for L in ref.links]
        np.testing.assert_allclose(ours[-1] @ dh_tip_transform(rows), ref.fkine(q).A,
                                   atol=1e-12)


def test_puma560_effort_limits_documented_values() -> None:
    robot = puma560()
    np.testing.assert_allclose(robot.effort_limit, [97.6, 186.4, 89.4, 24.2, 20.1, 21.3])
    assert np.all(np.isinf(robot.velocity_limit))


def test_format_doc_examples_load() -> None:
    """The robot examples in docs/robot-format.md (its TOML blocks with joints) are valid robot
    files; its sidecar and payload examples are checked in test_cli_robots.py."""
    doc = pathlib.Path(__file__).resolve().parents[1] / "docs" / "robot-format.md"
    if not doc.exists():
        pytest.skip("docs/robot-format.md not available")
    blocks = re.findall(r"```toml\n(.*?)```", doc.read_text(encoding="utf-8"), re.S)
    robots = [b for b in blocks if "[[joint]]" in b]
    assert len(robots) >= 2 and len(blocks) - len(robots) == 2  # + a sidecar and a payload
    for block in robots:
        assert loads_native(block, "robot-format.md").n >= 2


# --- a program's wrench point in the DH flange frame (issue 11, part 5) ------------------------
DH_ROBOT = """
[robot]
name = "dh2"
dh = "standard"
[[joint]]
name = "j1"
type = "revolute"
a = 0.4
alpha = 0.3
d = 0.2
[joint.link]
mass = 2.0
com = [-0.2, 0.0, 0.0]
inertia = { ixx = 0.01, iyy = 0.02, izz = 0.02 }
[[joint]]
name = "j2"
type = "revolute"
a = 0.3
alpha = 1.5707963267948966
d = 0.1
theta = 0.2
[joint.link]
mass = 1.0
com = [-0.1, 0.0, 0.0]
inertia = { ixx = 0.01, iyy = 0.01, izz = 0.01 }
"""


def test_wrench_point_in_the_dh_flange_frame(tmp_path):
    """``point_frame = "flange"``: the point is given in DH frame n (the paper's frame of the
    last link); the program converts it to mrnea's last link frame. Checked in the base frame:
    the DH product A_1 A_2 p (written out here) equals the last link's pose (tests/naive.py)
    times the converted point."""
    (tmp_path / "dh2.toml").write_text(DH_ROBOT)
    prog = """
[program]
robot = "dh2.toml"
dt = 0.01
[path]
profile = "quintic"
waypoints = [[0, 0], [0.5, -0.4]]
velocity_limit = 1.0
acceleration_limit = 2.0
[wrench]
times = [0.0]
values = [[0, 0, -10, 0, 0, 0]]
point = [0.05, -0.02, 0.1]
"""
    (tmp_path / "link.toml").write_text(prog)
    (tmp_path / "flange.toml").write_text(prog + 'point_frame = "flange"\n')
    p_link = load_program(tmp_path / "link.toml").f_ext_point
    flange = load_program(tmp_path / "flange.toml")
    robot = flange.load_robot()
    p = np.array([0.05, -0.02, 0.1, 1.0])
    for q in (np.zeros(2), np.array([0.7, -1.1])):
        dh = dh_standard(0.4, 0.3, 0.2, q[0]) @ dh_standard(0.3, math.pi / 2, 0.1, 0.2 + q[1])
        T = forward_kinematics(robot, q)[0][-1]
        np.testing.assert_allclose(T[:3, :3] @ flange.f_ext_point + T[:3, 3], (dh @ p)[:3],
                                   atol=1e-14)
    np.testing.assert_array_equal(p_link, p[:3])  # the default: the last link's frame
    assert not np.allclose(flange.f_ext_point, p_link)
    # a robot not given by a DH table has no flange frame
    bad = prog.replace('"dh2.toml"', '"sdt"') + 'point_frame = "flange"\n'
    (tmp_path / "bad.toml").write_text(bad.replace("[[0, 0], [0.5, -0.4]]",
                                                   "[[0, 0, 0, 0], [0.5, -0.4, 0, 0]]"))
    with pytest.raises(ProgramFileError, match="DH table"):
        load_program(tmp_path / "bad.toml")
    (tmp_path / "typo.toml").write_text(prog + 'point_frame = "tool"\n')
    with pytest.raises(ProgramFileError, match="point_frame"):
        load_program(tmp_path / "typo.toml")
