"""The native TOML format's ``parent`` key (issue 25; docs/robot-format.md, ``[[joint]]``):
a tree written by hand in TOML and the same tree written by hand in URDF, both generated here
from one table of parameters. Pinocchio reads the URDF (``buildModelFromXML``); mrnea reads the
TOML. RNEA, H, u', every forward-dynamics method and every link frame equal Pinocchio's to
1e-10 at random states. The TOML gives ``parent`` only where it is not the previous joint (its
default), once as the base link's name.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PinChain, rel_err

import mrnea
from mrnea.errors import RobotFileError
from mrnea.io import loads_native

pin = pytest.importorskip("pinocchio")

TOL = 1e-10
# name, parent joint (None: the previous joint, the TOML default; "base": the base link), type,
# origin xyz, rpy, axis, mass, com, inertia (ixx, iyy, izz, ixy, ixz, iyz)
JOINTS = [
    ("waist", None, "revolute", (0, 0, 0.4), (0, 0, 0.3), (0, 0, 1), 8.0, (0.01, 0, 0.2),
     (0.30, 0.25, 0.12, 0.01, -0.02, 0.005)),
    ("l1", None, "revolute", (0.05, 0.25, 0.3), (0.2, 0, 0), (0, 1, 0), 2.0, (0, 0.02, -0.1),
     (0.02, 0.025, 0.01, 0.001, 0.0, -0.002)),
    ("l2", None, "revolute", (0, 0, -0.25), (0, 0.1, 0), (1, 0, 0), 1.5, (0.01, 0, -0.1),
     (0.015, 0.012, 0.006, 0.0, 0.001, 0.0)),
    ("l3", None, "prismatic", (0, 0, -0.2), (0, 0, 0), (0, 0, 1), 0.7, (0, 0, 0.03),
     (0.002, 0.002, 0.001, 0.0, 0.0, 0.0)),
    ("r1", "waist", "revolute", (0.05, -0.25, 0.3), (-0.2, 0, 0.1), (0, 1, 0), 2.1,
     (0, -0.02, -0.1), (0.021, 0.024, 0.011, -0.001, 0.0, 0.002)),
    ("r2", "r1", "revolute", (0, 0, -0.25), (0, -0.1, 0), (0.6, 0.8, 0), 1.4, (0.0, 0.01, -0.1),
     (0.014, 0.013, 0.005, 0.0, -0.001, 0.0)),
    ("rg", "r1", "revolute", (0.05, 0, -0.1), (0, 0, 0), (0, 0, 1), 0.3, (0.02, 0, 0),
     (0.001, 0.001, 0.001, 0.0, 0.0, 0.0)),
    ("pan", "base", "revolute", (0.3, 0, 0.1), (0, 0, -0.4), (0, 0, 1), 1.0, (0, 0, 0.05),
     (0.004, 0.004, 0.003, 0.0, 0.0, 0.0)),
    ("tilt", None, "revolute", (0, 0, 0.1), (0, 0, 0), (0, 1, 0), 0.8, (0.03, 0, 0),
     (0.003, 0.002, 0.002, 0.0, 0.0, 0.0)),
]
PARENTS = (-1, 0, 1, 2, 0, 4, 4, -1, 7)  # written by hand, the depth-first order's λ(i)


def vec(v) -> str:
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def toml_text() -> str:
    out = ['[robot]\nname = "tree_by_hand"\nbase = "world"\n']
    for name, parent, typ, xyz, rpy, axis, mass, com, (ixx, iyy, izz, ixy, ixz, iyz) in JOINTS:
        out.append(f'[[joint]]\nname = "{name}"\ntype = "{typ}"\n'
                   + ("" if parent is None else
                      f'parent = "{"world" if parent == "base" else parent}"\n')
                   + f"origin = {{ xyz = {vec(xyz)}, rpy = {vec(rpy)} }}\naxis = {vec(axis)}\n"
                   + f'[joint.link]\nname = "{name}_link"\nmass = {mass}\ncom = {vec(com)}\n'
                   + f"inertia = {{ ixx = {ixx}, iyy = {iyy}, izz = {izz}, ixy = {ixy}, "
                   + f"ixz = {ixz}, iyz = {iyz} }}\n")
    return "\n".join(out)


def urdf_text() -> str:
    out = ['<robot name="tree_by_hand"><link name="world"/>']
    for k, (name, _parent, typ, xyz, rpy, axis, mass, com, inr) in enumerate(JOINTS):
        p = "world" if PARENTS[k] < 0 else JOINTS[PARENTS[k]][0] + "_link"
        ixx, iyy, izz, ixy, ixz, iyz = inr
        out.append(
            f'<link name="{name}_link"><inertial><origin xyz="{" ".join(map(str, com))}"/>'
            f'<mass value="{mass}"/><inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="{ixy}" '
            f'ixz="{ixz}" iyz="{iyz}"/></inertial></link>'
            f'<joint name="{name}" type="{typ}"><parent link="{p}"/><child link="{name}_link"/>'
            f'<origin xyz="{" ".join(map(str, xyz))}" rpy="{" ".join(map(str, rpy))}"/>'
            f'<axis xyz="{" ".join(map(str, axis))}"/>'
            '<limit lower="-10" upper="10" effort="100" velocity="10"/></joint>')
    return "".join(out) + "</robot>"


def test_parent_keys_give_pinocchios_tree() -> None:
    assert [j[1] is None for j in JOINTS].count(False) == 4  # r2's is the default, given
    robot = loads_native(toml_text(), "tree_by_hand.toml")
    assert robot.parents == PARENTS and not robot.is_serial
    model = pin.buildModelFromXML(urdf_text())
    pc = PinChain(robot, model)
    rng = np.random.default_rng(30)
    n = robot.n
    for _ in range(20):
        q, qd = rng.uniform(-2, 2, n), rng.normal(0, 2, n)
        qdd, tau = rng.normal(0, 3, n), rng.normal(0, 10, n)
        assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd), pc.rnea(q, qd, qdd)) <= TOL
        H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
        assert rel_err(H, pc.mass_matrix(q)) <= TOL and rel_err(u, pc.bias(q, qd)) <= TOL
        for method in ("mrnea", "walker_orin", "crba", "aba"):
            assert rel_err(mrnea.forward_dynamics(robot, q, qd, tau, method=method),
                           pc.aba(q, qd, tau)) <= TOL, method
        pin.forwardKinematics(pc.model, pc.data, pc.config(q))
        T = mrnea.forward_kinematics(robot, q)
        for t in range(n):
            assert rel_err(T[t + 1], pc.data.oMi[pc.ids[t]].homogeneous) <= TOL


def test_a_parent_that_is_not_an_earlier_joint_is_refused() -> None:
    text = toml_text()
    given = 'name = "rg"\ntype = "revolute"\nparent = "r1"'
    assert given in text
    with pytest.raises(RobotFileError, match=r"joint 'rg'.*parent 'nowhere'"):
        loads_native(text.replace(given, given.replace('"r1"', '"nowhere"')), "bad.toml")
    # tilt hangs from pan's link; a later joint cannot return to the closed arm subtree
    later = text + ('\n[[joint]]\nname = "late"\ntype = "revolute"\nparent = "l2"\naxis = '
                    '[0.0, 0.0, 1.0]\n[joint.link]\nmass = 1.0\n')
    with pytest.raises(RobotFileError, match=r"joint 'late'.*depth-first"):
        loads_native(later, "late.toml")
