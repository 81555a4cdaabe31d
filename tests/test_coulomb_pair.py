"""Model details of issue 11, part 5: asymmetric Coulomb friction ``[positive direction,
negative direction]`` through every way a robot is made or read, and a program's wrench point
given in the DH flange frame."""

from __future__ import annotations

import math

import numpy as np
import pytest
from naive import forward_kinematics

import mrnea
from mrnea import Joint, ModelError, RobotFileError
from mrnea.errors import ProgramFileError
from mrnea.io import load_program, load_robot, load_urdf
from mrnea.io.native import loads_native


def test_joint_takes_one_or_two_magnitudes():
    j = Joint("j", "revolute", "a", "b", coulomb_friction=[2.0, 0.5])
    assert j.coulomb_friction == (2.0, 0.5) and j.coulomb_pair == (2.0, 0.5)
    same = Joint("j", "revolute", "a", "b", coulomb_friction=(1.5, 1.5))
    assert same.coulomb_friction == 1.5 and same == Joint("j", "revolute", "a", "b",
                                                          coulomb_friction=1.5)
    for bad, match in (((-1.0, 2.0), ">= 0"), ((1.0, 2.0, 3.0), "two"),
                       ((1.0, math.nan), "finite"), ("x", "not a number")):
        with pytest.raises(ModelError, match=match):
            Joint("j", "revolute", "a", "b", coulomb_friction=bad)


def test_with_actuators_and_the_robot_array():
    robot = mrnea.robots.sdt()
    r = robot.with_actuators(coulomb_friction=[1.0, (2.0, 3.0), [4.0, 4.0], 5.0])
    np.testing.assert_array_equal(r.coulomb_friction, [[1, 1], [2, 3], [4, 4], [5, 5]])
    r = robot.with_actuators(coulomb_friction=np.array([[1.0, 2.0]] * 4))
    assert r.joints[3].coulomb_friction == (1.0, 2.0)
    assert robot.with_actuators(coulomb_friction=7.0).coulomb_friction.tolist() == [[7, 7]] * 4
    with pytest.raises(ModelError, match="4 entries"):
        robot.with_actuators(coulomb_friction=[1.0, 2.0])


def test_native_toml_and_sidecar_read_a_pair(tmp_path):
    text = """
[robot]
name = "r"
[[joint]]
name = "j1"
type = "revolute"
axis = [0, 0, 1]
coulomb_friction = [2.5, 0.75]
[joint.link]
mass = 1.0
com = [0.2, 0, 0]
inertia = { ixx = 0.01, iyy = 0.01, izz = 0.01 }
"""
    assert loads_native(text).joints[0].coulomb_pair == (2.5, 0.75)
    with pytest.raises(RobotFileError, match="coulomb_friction"):
        loads_native(text.replace("[2.5, 0.75]", "[2.5, 0.75, 1.0]"))
    (tmp_path / "r.toml").write_text(text)
    side = tmp_path / "side.toml"
    side.write_text("[j1]\ncoulomb_friction = [0.1, 0.2]\n")
    assert load_robot(tmp_path / "r.toml", actuators=side).joints[0].coulomb_pair == (0.1, 0.2)
    side.write_text("[j1]\ncoulomb_friction = 0.3\n")
    assert load_robot(tmp_path / "r.toml", actuators=side).joints[0].coulomb_friction == 0.3


def test_urdf_writes_the_mean_of_an_asymmetric_pair(tmp_path):
    """URDF's <dynamics friction> holds one value: the mean of the two (write_urdf's docstring
    says the asymmetry is lost); a symmetric value round-trips exactly."""
    puma = mrnea.robots.puma560()
    back = load_urdf(puma.to_urdf(tmp_path / "puma.urdf"))
    np.testing.assert_allclose(back.coulomb_friction[:, 0], puma.coulomb_friction.mean(axis=1),
                               rtol=1e-15)
    assert np.array_equal(back.coulomb_friction[:, 0], back.coulomb_friction[:, 1])
    sym = puma.with_actuators(coulomb_friction=0.1 * np.arange(1, 7))
    again = load_urdf(sym.to_urdf(tmp_path / "sym.urdf"))
    np.testing.assert_array_equal(again.coulomb_friction, sym.coulomb_friction)


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


def dh_frame(a, alpha, d, theta):
    """Standard DH: Rz(theta) Tz(d) Tx(a) Rx(alpha), written out."""
    ct, st, ca, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d], [0.0, 0.0, 0.0, 1.0]])


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
        dh = dh_frame(0.4, 0.3, 0.2, q[0]) @ dh_frame(0.3, math.pi / 2, 0.1, 0.2 + q[1])
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
