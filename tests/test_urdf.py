"""URDF loader and writer: real arms against Pinocchio, hand-computed lumping, malformed files."""

from __future__ import annotations

import math
import site
import sys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from mrnea.errors import ModelError, OutputError, RobotFileError
from mrnea.io.dispatch import load_robot, load_robot_spec, resolve_robot
from mrnea.io.urdf import UNBOUNDED, load_urdf
from mrnea.io.urdf_writer import write_urdf
from mrnea.model import Joint, Link, Robot
from mrnea.rigid import rotation_from_rpy, transform

RTOL = 1e-12


def _robots_dir() -> Path | None:
    for sp in [*site.getsitepackages(), site.getusersitepackages()]:
        d = Path(sp) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if d.is_dir():
            return d
    return None


ROBOTS = _robots_dir()


def erd(rel: str) -> Path:
    if ROBOTS is None or not (ROBOTS / rel).is_file():
        pytest.skip(f"example-robot-data file {rel} not installed")
    return ROBOTS / rel


def assert_close(actual, expected, rtol: float = RTOL) -> None:
    """Equal to ``rtol`` relative to the largest entry of ``expected``."""
    actual, expected = np.asarray(actual, dtype=float), np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape
    scale = max(float(np.max(np.abs(expected), initial=0.0)), 1e-300)
    err = float(np.max(np.abs(actual - expected), initial=0.0))
    assert err <= rtol * scale + 1e-300, f"{actual} != {expected} (max err {err:.3g})"


def write(tmp_path: Path, body: str, name: str = "r.urdf") -> Path:
    p = tmp_path / name
    p.write_text(f'<?xml version="1.0"?>\n<robot name="t">\n{body}\n</robot>\n')
    return p


def link(name: str, mass: float | None = None, xyz: str = "0 0 0", rpy: str = "0 0 0",
         inertia: tuple[float, ...] = (0, 0, 0, 0, 0, 0)) -> str:
    if mass is None:
        return f'<link name="{name}"/>'
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    return (f'<link name="{name}"><inertial><origin xyz="{xyz}" rpy="{rpy}"/>'
            f'<mass value="{mass}"/><inertia ixx="{ixx}" ixy="{ixy}" ixz="{ixz}" iyy="{iyy}" '
            f'iyz="{iyz}" izz="{izz}"/></inertial></link>')


def joint(name: str, parent: str, child: str, type_: str = "revolute", xyz: str = "0 0 0",
          rpy: str = "0 0 0", extra: str = "") -> str:
    return (f'<joint name="{name}" type="{type_}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/>{extra}</joint>')


# --- real arms against Pinocchio ------------------------------------------------------------------
def _pin_limit(v: float) -> float:
    """Pinocchio's (and our export's) value for a limit: +-DBL_MAX stands for none."""
    return math.copysign(sys.float_info.max, v) if math.isinf(v) else v


def compare_with_pinocchio(robot: Robot, model) -> None:
    """Pinocchio merges fixed-joint children too: its joints and bodies must be ours."""
    assert model.njoints - 1 == robot.n
    assert [model.names[i] for i in range(1, model.njoints)] == list(robot.joint_names)
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True), start=1):
        Y = model.inertias[i]
        assert lk.mass == pytest.approx(Y.mass, rel=RTOL, abs=1e-300)
        assert_close(lk.com, Y.lever)
        assert_close(lk.inertia, Y.inertia)
        assert_close(j.origin, model.jointPlacements[i].homogeneous)
        iv = model.joints[i].idx_v
        assert _pin_limit(j.effort_limit) == pytest.approx(model.effortLimit[iv], rel=RTOL)
        assert _pin_limit(j.velocity_limit) == pytest.approx(model.velocityLimit[iv], rel=RTOL)
        assert j.viscous_friction == pytest.approx(model.damping[iv], rel=RTOL, abs=0)
        assert j.coulomb_friction == pytest.approx(model.friction[iv], rel=RTOL, abs=0)
        if j.type == "continuous":
            assert (j.lower, j.upper) == (-math.inf, math.inf)
        else:
            iq = model.joints[i].idx_q
            assert _pin_limit(j.lower) == pytest.approx(model.lowerPositionLimit[iq], rel=RTOL)
            assert _pin_limit(j.upper) == pytest.approx(model.upperPositionLimit[iq], rel=RTOL)


ARMS = {  # file: (n, root link, expected gear ratio: the files' mechanicalReduction)
    "ur_description/urdf/ur5_robot.urdf": (6, "world", 1.0),
    "kinova_description/robots/kinova.urdf": (6, "base", 160.0),
    "xarm_description/urdf/xarm7.urdf": (7, "world", 100.0),
    "z1_description/urdf/z1.urdf": (7, "world", 1.0),
}


@pytest.mark.parametrize("rel", list(ARMS))
def test_serial_arm_matches_pinocchio(rel: str) -> None:
    path = erd(rel)
    robot = load_urdf(path)
    n, base, gear = ARMS[rel]
    assert robot.n == n
    assert robot.base == base
    compare_with_pinocchio(robot, pin.buildModelFromUrdf(str(path)))
    np.testing.assert_array_equal(robot.gear_ratio, gear)
    np.testing.assert_array_equal(robot.gravity, (0.0, 0.0, -9.81))


def test_ur5_known_values() -> None:
    """Spot values typed from the file (ee_link and tool0 are massless; base_link's 4 kg is
    part of the fixed base)."""
    robot = load_urdf(erd("ur_description/urdf/ur5_robot.urdf"))
    assert robot.name == "ur5"
    np.testing.assert_allclose(robot.masses, [3.7, 8.393, 2.275, 1.219, 1.219, 0.1879])
    assert robot.joint_names[0] == "shoulder_pan_joint"
    assert_close(robot.joints[0].origin[:3, 3], [0.0, 0.0, 0.089159])


def test_panda_needs_a_tip_and_matches_reduced_pinocchio() -> None:
    path = erd("panda_description/urdf/panda.urdf")
    # whole, the tree keeps panda_finger_joint2, a <mimic> of finger 1: refused, naming it
    with pytest.raises(RobotFileError, match=r"panda_finger_joint2.*<mimic>.*tip") as info:
        load_urdf(path)
    msg = str(info.value)
    # the candidates avoid the mimic joint: the left finger's chain moves the hand and a
    # finger, the tool point's the hand alone
    assert msg.endswith("panda_leftfinger, panda_hand_tcp")
    assert str(path) in msg and "--tip LINK" in msg

    full = pin.buildModelFromUrdf(str(path))
    locked = [full.getJointId(n) for n in ("panda_finger_joint1", "panda_finger_joint2")]
    reduced = pin.buildReducedModel(full, locked, np.zeros(full.nq))
    for tip in ("panda_link8", "panda_hand_tcp", "panda_link7"):
        robot = load_urdf(path, tip=tip)
        assert robot.n == 7
        assert robot.link_names[-1] == "panda_link7"
        compare_with_pinocchio(robot, reduced)
    # the file's masses: link 7 (0.735522 kg) carries the hand (0.73 kg) and fingers (2 x 0.015)
    assert robot.masses[-1] == pytest.approx(0.735522 + 0.73 + 0.03, rel=RTOL)
    assert full.inertias[7].mass == pytest.approx(0.735522 + 0.73, rel=RTOL)  # fingers separate


def test_panda_tip_on_a_finger_is_a_chain_with_a_mimic_joint() -> None:
    path = erd("panda_description/urdf/panda.urdf")
    robot = load_urdf(path, tip="panda_leftfinger")
    assert robot.n == 8
    assert robot.joints[-1].type == "prismatic"
    assert robot.joints[-1].upper == pytest.approx(0.04)
    with pytest.raises(RobotFileError, match=r"panda_finger_joint2.*mimic"):
        load_urdf(path, tip="panda_rightfinger")


# --- hand-written files: closed-form results ----------------------------------------------------
def test_fixed_merge_parallel_axis(tmp_path: Path) -> None:
    # a: 2 kg point at its origin; b: 1 kg, fixed 0.3 m along x and yawed by 90 deg, with its own
    # inertia diag(1, 2, 3) mg m^2 (in b's axes: after the yaw, diag(2, 1, 3) in a's axes).
    p = write(tmp_path, "\n".join([
        link("base"),
        joint("j1", "base", "a", extra='<axis xyz="0 0 1"/>'),
        link("a", 2.0),
        joint("fix", "a", "b", "fixed", xyz="0.3 0 0", rpy=f"0 0 {math.pi / 2}"),
        link("b", 1.0, inertia=(1e-3, 0, 0, 2e-3, 0, 3e-3)),
    ]))
    robot = load_urdf(p)
    assert robot.n == 1
    lk = robot.links[0]
    assert lk.name == "a"
    assert lk.mass == 3.0
    assert_close(lk.com, [0.1, 0.0, 0.0])
    # point masses 0.1 m (2 kg) and 0.2 m (1 kg) from the combined com along x:
    # Iyy = Izz = 2 * 0.01 + 1 * 0.04 = 0.06
    assert_close(lk.inertia, np.diag([2e-3, 0.06 + 1e-3, 0.06 + 3e-3]))


def test_fixed_chain_merges_transitively_and_composes_origins(tmp_path: Path) -> None:
    # root -fixed-> f1 -fixed-> f2 -revolute-> a -fixed-> t1 -fixed-> t2 (tool: 1 kg at 0.5 m z)
    p = write(tmp_path, "\n".join([
        link("root", 100.0, inertia=(1, 0, 0, 1, 0, 1)),
        joint("f1j", "root", "f1", "fixed", xyz="1 0 0", rpy=f"0 0 {math.pi / 2}"),
        link("f1", 50.0, inertia=(1, 0, 0, 1, 0, 1)),
        joint("f2j", "f1", "f2", "fixed", xyz="0 2 0"),
        link("f2"),
        joint("j", "f2", "a", xyz="0 0 3", extra='<axis xyz="0 1 0"/>'),
        link("a", 1.0),
        joint("t1j", "a", "t1", "fixed", xyz="0 0 0.25"),
        link("t1"),
        joint("t2j", "t1", "t2", "fixed", xyz="0 0 0.25"),
        link("t2", 1.0),
    ]))
    robot = load_urdf(p)
    assert robot.n == 1 and robot.base == "root"
    j = robot.joints[0]
    assert j.parent == "root"
    # f1 is at (1, 0, 0) yawed 90 deg: its y axis is the root's -x.  f2: (1 - 2, 0, 0).
    expected = transform((1.0, 0.0, 0.0), (0.0, 0.0, math.pi / 2)) @ transform((0.0, 2.0, 3.0))
    assert_close(j.origin, expected)
    assert_close(j.origin[:3, 3], [-1.0, 0.0, 3.0])
    lk = robot.links[0]  # the base links' 150 kg is dropped
    assert lk.mass == 2.0
    assert_close(lk.com, [0.0, 0.0, 0.25])
    assert_close(lk.inertia, np.diag([0.125, 0.125, 0.0]))  # 2 * 1 kg * 0.25^2


def test_inertial_origin_rotation(tmp_path: Path) -> None:
    theta = 0.3
    p = write(tmp_path, "\n".join([
        link("base"),
        joint("j1", "base", "a"),
        link("a", 1.0, xyz="0.1 0.2 0.3", rpy=f"0 0 {theta}", inertia=(1, 0, 0, 2, 0, 3)),
        joint("j2", "a", "b"),
        link("b", 1.0, rpy=f"{math.pi / 2} 0 0", inertia=(1, 0, 0, 2, 0, 3)),
    ]))
    robot = load_urdf(p)
    c, s = math.cos(theta), math.sin(theta)
    # rotating diag(a, b, c) by theta about z: Ixx = a c^2 + b s^2, Iyy = a s^2 + b c^2,
    # Ixy = (a - b) s c
    assert_close(robot.links[0].inertia, [[c * c + 2 * s * s, -s * c, 0.0],
                                          [-s * c, s * s + 2 * c * c, 0.0],
                                          [0.0, 0.0, 3.0]])
    assert_close(robot.links[0].com, [0.1, 0.2, 0.3])
    assert_close(robot.links[1].inertia, np.diag([1.0, 3.0, 2.0]))  # roll 90 deg swaps y and z


def test_defaults_limits_dynamics_and_transmission(tmp_path: Path) -> None:
    p = write(tmp_path, "\n".join([
        link("base"),
        joint("j1", "base", "a", extra=('<axis xyz="0 0 2"/><limit lower="-1" upper="2" '
                                        'effort="30" velocity="4"/>'
                                        '<dynamics damping="0.5" friction="0.25"/>')),
        link("a"),  # no inertial: massless
        joint("j2", "a", "b", "continuous",
              extra='<limit lower="-1" upper="1" effort="7" velocity="8"/>'),
        link("b", 1.0),
        joint("j3", "b", "c", "prismatic", extra=f'<limit lower="-{UNBOUNDED!r}" upper="0.5"/>'),
        link("c", 1.0),
        '<transmission name="t1"><type>transmission_interface/SimpleTransmission</type>'
        '<joint name="j1"><hardwareInterface>x</hardwareInterface></joint>'
        '<actuator name="m1"><mechanicalReduction>-50</mechanicalReduction></actuator>'
        '</transmission>',
        '<transmission name="t3"><joint name="j3"/><actuator name="m3"/>'
        '<mechanicalReduction>2.5</mechanicalReduction></transmission>',  # old pr2 format
    ]))
    r = load_urdf(p)
    j1, j2, j3 = r.joints
    assert_close(j1.axis, [0, 0, 1])
    assert_close(j2.axis, [1, 0, 0])  # URDF default axis
    assert (j1.lower, j1.upper, j1.effort_limit, j1.velocity_limit) == (-1, 2, 30, 4)
    assert (j1.viscous_friction, j1.coulomb_friction) == (0.5, 0.25)
    assert (j2.lower, j2.upper) == (-math.inf, math.inf)  # continuous: no position limits
    assert (j2.effort_limit, j2.velocity_limit) == (7, 8)
    assert (j2.viscous_friction, j2.coulomb_friction) == (0, 0)
    assert (j3.lower, j3.upper) == (-math.inf, 0.5)  # -DBL_MAX reads as unbounded
    assert (j3.effort_limit, j3.velocity_limit) == (math.inf, math.inf)  # missing: unlimited
    np.testing.assert_array_equal(r.gear_ratio, [50.0, 1.0, 2.5])  # sign of -50 dropped
    assert r.links[0].mass == 0.0


def test_fixed_base_links_are_dropped_unchecked(tmp_path: Path) -> None:
    """The base's inertia never enters the model (as in Pinocchio), so it is not validated;
    transmissions of joints not in the file are ignored (cut-down files keep them)."""
    p = write(tmp_path, "\n".join([
        link("base", 1.0, inertia=(1, 0, 0, -1, 0, 1)),  # not PSD
        joint("j1", "base", "a"), link("a", 1.0),
        '<transmission name="t"><joint name="gone"/><actuator><mechanicalReduction>9'
        '</mechanicalReduction></actuator></transmission>',
    ]))
    r = load_urdf(p)
    assert r.n == 1 and r.gear_ratio[0] == 1.0


def test_coupled_transmission_warns_and_keeps_unit_gear(tmp_path: Path) -> None:
    p = write(tmp_path, "\n".join([
        BASE, GOOD_J, GOOD_A, joint("j2", "a", "b"), link("b", 1.0),
        '<transmission name="diff"><joint name="j1"/><joint name="j2"/>'
        '<actuator name="m1"><mechanicalReduction>-1</mechanicalReduction></actuator>'
        '<actuator name="m2"><mechanicalReduction>1</mechanicalReduction></actuator>'
        '</transmission>',
    ]))
    with pytest.warns(UserWarning, match=r"transmission 'diff' couples joint\(s\) j1, j2"):
        r = load_urdf(p)
    np.testing.assert_array_equal(r.gear_ratio, [1.0, 1.0])


def test_tip_lumps_moving_side_branch_at_zero(tmp_path: Path) -> None:
    # l1 carries two moving branches: j2 -> l2 and the prismatic j3 -> l3 (1 kg, 0.4 m along y).
    p = write(tmp_path, "\n".join([
        link("base"),
        joint("j1", "base", "l1", extra='<axis xyz="0 0 1"/>'),
        link("l1", 1.0),
        joint("j2", "l1", "l2", xyz="0 0 1"),
        link("l2", 2.0),
        joint("j3", "l1", "l3", "prismatic", xyz="0 0.4 0",
              extra='<axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'),
        link("l3", 1.0),
        joint("tool", "l2", "tool_link", "fixed", xyz="0 0 0.5"),
        link("tool_link", 2.0),
    ]))
    # whole: a tree, j2 and j3 both hang from l1 (file order)
    whole = load_urdf(p)
    assert whole.joint_names == ("j1", "j2", "j3") and whole.parents == (-1, 0, 0)
    assert load_urdf(p, tip=["tool_link", "l3"]) == whole  # both tips: the same subtree
    r = load_urdf(p, tip="tool_link")
    assert r.joint_names == ("j1", "j2")
    # l1 + l3 at q3 = 0: 2 kg, com (0, 0.2, 0); Ixx = Izz = 2 * 1 kg * 0.2^2 = 0.08
    assert r.links[0].mass == 2.0
    assert_close(r.links[0].com, [0, 0.2, 0])
    assert_close(r.links[0].inertia, np.diag([0.08, 0.0, 0.08]))
    # l2 + tool: 4 kg, com (0, 0, 0.25), Ixx = Iyy = 4 * 0.25^2 = 0.25
    assert r.links[1].mass == 4.0
    assert_close(r.links[1].com, [0, 0, 0.25])
    assert_close(r.links[1].inertia, np.diag([0.25, 0.25, 0.0]))
    # tip in the middle: everything below l1 is lumped (l2 at its q2 = 0 pose)
    r1 = load_urdf(p, tip="l1")
    assert r1.n == 1 and r1.links[0].mass == 6.0
    r3 = load_urdf(p, tip="l3")
    assert r3.joint_names == ("j1", "j3") and r3.links[0].mass == 5.0
    with pytest.raises(RobotFileError, match="tip link 'nope' does not exist"):
        load_urdf(p, tip="nope")
    with pytest.raises(RobotFileError, match=r"'base'.*no moving joint"):
        load_urdf(p, tip="base")


def test_dispatch(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    body = "\n".join([link("base"), joint("j1", "base", "a"), link("a", 1.0)])
    for name in ("r.urdf", "r.XML"):
        assert load_robot(write(tmp_path, body, name)).n == 1
    with pytest.raises(RobotFileError, match=r"\.urdf.*\.xml.*\.toml"):
        load_robot(tmp_path / "r.yaml")
    import mrnea.io.native

    calls = []
    monkeypatch.setattr(mrnea.io.native, "load_native", lambda path: calls.append(path))
    load_robot(tmp_path / "r.toml")
    assert calls == [tmp_path / "r.toml"]


def test_resolve_robot_name_or_path(tmp_path: Path) -> None:
    """A built-in name wins; a relative path is taken in base_dir (as given without one)."""
    assert resolve_robot("sdt", tmp_path) == "sdt"
    assert resolve_robot("cell/r.urdf", tmp_path) == str(tmp_path / "cell" / "r.urdf")
    assert resolve_robot("cell/r.urdf") == str(Path("cell/r.urdf"))
    assert resolve_robot(str(tmp_path / "r.urdf"), "elsewhere") == str(tmp_path / "r.urdf")
    body = "\n".join([link("base"), joint("j1", "base", "a"), link("a", 1.0)])
    write(tmp_path, body, "r.urdf")
    assert load_robot_spec("r.urdf", tmp_path).n == 1
    assert load_robot_spec("puma560", tmp_path).n == 6


# --- malformed files ----------------------------------------------------------------------------
BASE = link("base")
GOOD_J = joint("j1", "base", "a")
GOOD_A = link("a", 1.0)

MALFORMED = {
    "negative mass": ([BASE, GOOD_J, link("a", -1.0)], r"link 'a'.*mass must be >= 0"),
    "nan mass": ([BASE, GOOD_J, link("a", "nan")], r"link 'a'.*mass"),
    "non-psd inertia": ([BASE, GOOD_J, link("a", 1.0, inertia=(1, 0, 0, -1, 0, 1))],
                        r"link 'a'.*positive semi-definite"),
    "zero axis": ([BASE, joint("j1", "base", "a", extra='<axis xyz="0 0 0"/>'), GOOD_A],
                  r"joint 'j1'.*axis is zero"),
    "floating": ([BASE, joint("j1", "base", "a", "floating"), GOOD_A],
                 r"joint 'j1'.*'floating' is not supported"),
    "planar": ([BASE, joint("j1", "base", "a", "planar"), GOOD_A],
               r"joint 'j1'.*'planar' is not supported"),
    "unknown type": ([BASE, joint("j1", "base", "a", "ball"), GOOD_A],
                     r"joint 'j1'.*unknown joint type 'ball'"),
    "missing link": ([BASE, joint("j1", "base", "ghost"), GOOD_A],
                     r"joint 'j1'.*link 'ghost', which does not exist"),
    "cycle": ([link("a"), link("b"), joint("j1", "a", "b"), joint("j2", "b", "a")], r"cycle"),
    "detached cycle": ([BASE, GOOD_J, GOOD_A, link("b"), link("c"), joint("j2", "b", "c"),
                        joint("j3", "c", "b")], r"links b, c are not connected.*cycle"),
    "two roots": ([BASE, GOOD_J, GOOD_A, link("other")], r"2 root links.*base, other"),
    "two parents": ([BASE, GOOD_J, GOOD_A, link("b"), joint("j2", "b", "a")],
                    r"joint 'j2'.*link 'a' is already the child of joint 'j1'"),
    "duplicate link": ([BASE, GOOD_J, GOOD_A, link("a")], r"duplicate link name 'a'"),
    "duplicate joint": ([BASE, GOOD_J, GOOD_A, link("b"), joint("j1", "a", "b")],
                        r"duplicate joint name 'j1'"),
    "lower > upper": ([BASE, joint("j1", "base", "a", extra='<limit lower="1" upper="-1" '
                                   'effort="1" velocity="1"/>'), GOOD_A],
                      r"joint 'j1'.*lower limit 1.0 is above upper limit -1.0"),
    "non-numeric": ([BASE, joint("j1", "base", "a", xyz="0 abc 0"), GOOD_A],
                    r"joint 'j1'.*<origin xyz=\"0 abc 0\">.*not a number"),
    "non-numeric limit": ([BASE, joint("j1", "base", "a", extra='<limit effort="lots"/>'),
                           GOOD_A], r"joint 'j1' <limit>.*effort=\"lots\".*not a number"),
    "non-numeric inertia": ([BASE, GOOD_J, link("a", 1.0, inertia=(1, 0, 0, "x", 0, 1))],
                            r"link 'a' <inertial>.*iyy=\"x\""),
    "wrong count": ([BASE, joint("j1", "base", "a", rpy="0 0"), GOOD_A],
                    r"joint 'j1'.*rpy.*expected 3 number\(s\), got 2"),
    "missing mass": ([BASE, GOOD_J, '<link name="a"><inertial/></link>'],
                     r"link 'a' <inertial>: no <mass>"),
    "no parent": ([BASE, '<joint name="j1" type="revolute"><child link="a"/></joint>', GOOD_A],
                  r"joint 'j1': no <parent>"),
    "no joint type": ([BASE, '<joint name="j1"><parent link="base"/><child link="a"/></joint>',
                       GOOD_A], r"joint 'j1'.*no 'type' attribute"),
    "no moving joint": ([BASE, joint("j1", "base", "a", "fixed"), GOOD_A], r"no moving joint"),
    "zero reduction": ([BASE, GOOD_J, GOOD_A, '<transmission name="t"><joint name="j1"/>'
                        '<actuator><mechanicalReduction>0</mechanicalReduction></actuator>'
                        '</transmission>'], r"transmission 't'.*non-zero"),
    "bad reduction": ([BASE, GOOD_J, GOOD_A, '<transmission name="t"><joint name="j1"/>'
                       '<actuator><mechanicalReduction>x</mechanicalReduction></actuator>'
                       '</transmission>'], r"transmission 't'.*not a number"),
    "mimic on chain": ([BASE, joint("j1", "base", "a", extra='<mimic joint="j2"/>'), GOOD_A],
                       r"joint 'j1'.*mimic"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_malformed(tmp_path: Path, case: str) -> None:
    parts, pattern = MALFORMED[case]
    p = write(tmp_path, "\n".join(parts))
    with pytest.raises(RobotFileError, match=pattern) as info:
        load_urdf(p)
    assert str(info.value).startswith(f"{p}: ")


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(RobotFileError, match=r"nothere\.urdf: robot file not found"):
        load_urdf(tmp_path / "nothere.urdf")
    with pytest.raises(RobotFileError, match="cannot read robot file: it is a directory"):
        load_urdf(tmp_path)  # a directory
    empty = tmp_path / "empty.urdf"
    empty.write_text("  \n")
    with pytest.raises(RobotFileError, match=r"empty\.urdf: file is empty"):
        load_urdf(empty)
    truncated = tmp_path / "trunc.urdf"
    truncated.write_text('<robot name="t">\n  <link name="a">\n')
    with pytest.raises(RobotFileError, match=r"trunc\.urdf: invalid XML at line 3, column \d+"):
        load_urdf(truncated)
    other = tmp_path / "other.urdf"
    other.write_text('<sdf version="1.6"><model name="m"/></sdf>')
    with pytest.raises(RobotFileError, match="root element is <sdf>, expected <robot>"):
        load_urdf(other)


# --- writer ---------------------------------------------------------------------------------------
def assert_same_robot(a: Robot, b: Robot, rtol: float = RTOL) -> None:
    assert (a.name, a.base, a.joint_names, a.link_names) == (b.name, b.base, b.joint_names,
                                                             b.link_names)
    for ja, jb, la, lb in zip(a.joints, b.joints, a.links, b.links, strict=True):
        assert (ja.type, ja.parent, ja.child) == (jb.type, jb.parent, jb.child)
        assert_close(ja.origin, jb.origin, rtol)
        assert_close(ja.axis, jb.axis, rtol)
        for f in ("lower", "upper", "effort_limit", "velocity_limit", "gear_ratio",
                  "viscous_friction", "coulomb_friction"):
            assert getattr(ja, f) == getattr(jb, f), f
        assert la.mass == lb.mass
        np.testing.assert_array_equal(la.com, lb.com)
        np.testing.assert_array_equal(la.inertia, lb.inertia)


def handmade_robot() -> Robot:
    I = np.array([[0.3, 0.01, -0.02], [0.01, 0.2, 0.005], [-0.02, 0.005, 0.1]])
    joints = [
        Joint("j1", "continuous", "world", "l1", transform((0.1, 0, 0.3), (0.1, -0.2, 0.3)),
              (0, 0, 1), effort_limit=150.0, gear_ratio=100.0, rotor_inertia=1e-4,
              viscous_friction=0.7, coulomb_friction=1.5),
        Joint("j2", "revolute", "l1", "l2", transform((0, 0.2, 0), (math.pi / 2, 0, 0)),
              (1, 2, 3), lower=-2.0, upper=math.inf),
        Joint("j3", "prismatic", "l2", "l3", transform((0.5, 0, 0), (0, math.pi / 2, 0)),
              (0, 1, 0), lower=-0.1, upper=0.4, velocity_limit=0.5, effort_limit=800.0,
              gear_ratio=1 / 3),
    ]
    links = [Link("l1", 2.5, (0.01, 0.02, 0.1), I), Link("l2", 0.0),
             Link("l3", 1 / 3, (0.0, 0.0, -0.05), 2 * I)]
    return Robot(joints, links, name="hand<made>&", base="world")


def test_round_trip_handmade(tmp_path: Path) -> None:
    robot = handmade_robot()
    out = write_urdf(robot, tmp_path / "h.urdf")
    assert out == tmp_path / "h.urdf"
    back = load_urdf(out)
    assert back.rotor_inertia[0] == 0.0  # not representable in URDF: dropped
    assert_same_robot(back, robot.with_actuators(rotor_inertia=0.0))
    assert back.joints[1].upper == math.inf
    if hasattr(Joint, "torque_speed"):  # a curve is not URDF: its peak becomes the effort limit
        curved = robot.with_actuators(torque_speed=[(40.0, 2.0, 5.0), None, None])
        again = load_urdf(write_urdf(curved, tmp_path / "c.urdf"))
        assert again.joints[0].effort_limit == 40.0
        assert again.joints[0].torque_speed is None
        (tmp_path / "c.urdf").unlink()
    # Pinocchio reads our export with the same inertias, placements and limits
    model = pin.buildModelFromUrdf(str(out))
    compare_with_pinocchio(back, model)
    assert model.upperPositionLimit[model.joints[2].idx_q] == sys.float_info.max
    # never over a file without overwrite; overwriting (here through Robot.to_urdf) is atomic
    # and leaves no temporary file behind
    with pytest.raises(OutputError, match="exists"):
        robot.to_urdf(out)
    assert robot.with_actuators(gear_ratio=1.0).to_urdf(out, overwrite=True) == out
    assert "<transmission" not in out.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.urdf"]


@pytest.mark.parametrize("rel", ["ur_description/urdf/ur5_robot.urdf",
                                 "kinova_description/robots/kinova.urdf"])
def test_round_trip_real_arm(tmp_path: Path, rel: str) -> None:
    robot = load_urdf(erd(rel))
    out = write_urdf(robot, tmp_path / "x.urdf")
    assert_same_robot(load_urdf(out), robot)
    compare_with_pinocchio(robot, pin.buildModelFromUrdf(str(out)))


def test_round_trip_extreme_values(tmp_path: Path) -> None:
    """Values at the largest magnitudes mrnea accepts (mrnea.frozen.MAGNITUDES) survive the round
    trip bit for bit; a file beyond them (an inertia near float64's limit, whose symmetrising
    (I + I^T) / 2 would overflow, found by the fuzz test; a joint 1e200 m from its parent) is
    one ModelError naming the link or joint and the field, with no overflow on the way."""
    big = np.nextafter(1e10, 0.0)  # kg m^2, 17 digits
    joints = [Joint("j1", "revolute", "base", "l1", transform((1e4, 0.0, 0.0))),
              Joint("j2", "revolute", "l1", "l2", transform((0.0, 0.0, 0.5)))]
    links = [Link("l1", 0.0, (-1e4, 0.0, 0.0), np.diag([1.0, 1.0, 1.0])),
             Link("l2", 1.0, (0.0, 0.0, 0.1), np.diag([big, big, big]))]
    robot = Robot(joints, links)
    path = write_urdf(robot, tmp_path / "x.urdf")
    back = load_urdf(path)
    assert np.array_equal(back.links[1].inertia, robot.links[1].inertia)
    assert np.array_equal(back.joints[0].origin, robot.joints[0].origin)
    text = path.read_text()
    huge = text.replace('ixx="9999999999.999998"', 'ixx="8.98846567431158e307"')
    far = text.replace('xyz="10000.0 0.0 0.0"', 'xyz="1e200 0.0 0.0"')
    assert huge != text and far != text
    for variant, field in ((huge, "link 'l2'.*inertia"), (far, "joint 'j1'.*origin")):
        (tmp_path / "y.urdf").write_text(variant)
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # no overflow on the way
            with pytest.raises(ModelError, match=f"{field}.*largest mrnea"):
                load_urdf(tmp_path / "y.urdf")


def test_write_into_missing_directory(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="cannot write"):
        write_urdf(handmade_robot(), tmp_path / "no" / "such" / "dir.urdf")


def test_rotation_helper_is_urdf_convention() -> None:
    """Sanity check of the rpy convention the loader relies on (URDF: Rz(y) Ry(p) Rx(r))."""
    r, p, y = 0.1, 0.2, 0.3
    assert_close(rotation_from_rpy((r, p, y)),
                 pin.rpy.rpyToMatrix(r, p, y))


def test_model_error_is_the_base_class() -> None:
    assert issubclass(RobotFileError, ModelError)


def test_a_branching_file_loads_whole_as_a_tree() -> None:
    """A file whose moving joints branch (two arms on the base; once refused without a tip):
    every moving joint, depth first, children in file order."""
    path = Path(__file__).parent / "malformed" / "urdf" / "branching_without_tip.urdf"
    robot = load_urdf(path)
    assert robot.joint_names == ("shoulder", "elbow", "second_shoulder")
    assert robot.parents == (-1, 0, -1) and not robot.is_serial
    assert load_urdf(path, tip="tool").joint_names == ("shoulder", "elbow")
