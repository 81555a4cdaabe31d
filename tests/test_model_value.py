"""A Robot (and its Joints and Links) is plain immutable data: equal by value, hashable, safe to
pickle, copy, deep-copy and send to another process, every copy validated by the constructor
again and its arrays read-only; and its actuator fields are one list (model.ACTUATOR_FIELDS)
that describe() and docs/robot-format.md follow.
"""

from __future__ import annotations

import copy
import multiprocessing
import pickle
import re
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from conftest import random_chain

import mrnea
from mrnea.describe import describe
from mrnea.errors import ModelError, ModelWarning
from mrnea.model import ACTUATOR_FIELDS, Joint, Link, Robot

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _arrays(robot: Robot) -> list[np.ndarray]:
    return [robot.gravity, *(a for j in robot.joints for a in (j.origin, j.axis)),
            *(a for lk in robot.links for a in (lk.com, lk.inertia))]


COPIES = {"pickle": lambda r: pickle.loads(pickle.dumps(r)), "copy": copy.copy,
          "deepcopy": copy.deepcopy}


@pytest.mark.parametrize("how", COPIES)
def test_copies_are_equal_validated_and_read_only(how: str) -> None:
    rng = np.random.default_rng(4)
    robot = random_chain(rng, 6, 0.3).with_actuators(torque_speed=(40.0, 2.0, 6.0))
    twin = COPIES[how](robot)
    assert twin is not robot and twin == robot and hash(twin) == hash(robot)
    for a, b in zip(_arrays(twin), _arrays(robot), strict=True):
        assert not a.flags.writeable
        np.testing.assert_array_equal(a, b)
        if how != "copy":
            assert not np.shares_memory(a, b)
    q, qd, tau = rng.uniform(-1, 1, (3, 6))
    np.testing.assert_array_equal(mrnea.forward_dynamics(twin, q, qd, tau),
                                  mrnea.forward_dynamics(robot, q, qd, tau))


@pytest.mark.parametrize("obj", [Link("l", mass=1.0), Joint("j", "revolute", "a", "b")])
def test_rebuilding_runs_the_constructors_checks(obj) -> None:
    """What unpickling and copying call is the constructor: a tampered field is refused."""
    rebuild, (cls, fields) = obj.__reduce__()
    assert rebuild(cls, fields) == obj
    bad = {**fields, "mass": -1.0} if cls is Link else {**fields, "gear_ratio": 0.0}
    with pytest.raises(ModelError):
        rebuild(cls, bad)


def test_copies_do_not_repeat_the_warnings() -> None:
    """A massless link warns once, when the Robot is made; its copies are the same robot."""
    joints = [Joint("j1", "revolute", "base", "l1"), Joint("j2", "revolute", "l1", "l2")]
    with pytest.warns(ModelWarning, match="massless"):
        robot = Robot(joints, [Link("l1"), Link("l2", mass=1.0, com=(0.1, 0.0, 0.0))])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for make in COPIES.values():
            assert make(robot) == robot
    with pytest.warns(ModelWarning, match="massless"):  # a new robot still warns
        Robot(joints, [Link("l1"), Link("l2", mass=1.0, com=(0.1, 0.0, 0.0))])


def test_value_equality_and_hash() -> None:
    a, b = mrnea.robots.puma560(), mrnea.robots.puma560()
    assert a is not b and a == b and hash(a) == hash(b) and len({a, b}) == 1
    assert a != a.with_actuators(gear_ratio=2.0)
    assert a != a.with_gravity((0.0, 0.0, -9.8))
    assert a != mrnea.robots.sdt() and a != "puma560" and a.joints[0] != a.links[0]
    # -0.0 and 0.0 are the same number, in __eq__ and in __hash__
    l1, l2 = Link("l", 1.0, com=(0.0, 0.0, 0.0)), Link("l", 1.0, com=(-0.0, 0.0, 0.0))
    assert l1 == l2 and hash(l1) == hash(l2)
    j = Joint("j", "revolute", "a", "b", effort_limit=5.0)
    assert j == Joint("j", "revolute", "a", "b", effort_limit=5)
    assert j != Joint("j", "revolute", "a", "b", effort_limit=5.0, coulomb_friction=0.1)


def test_a_robot_crosses_to_another_process() -> None:
    """Pickled to a fresh (spawned) process, the Robot is compiled there and gives the same
    forward dynamics bit for bit."""
    robot = mrnea.robots.sdt()
    rng = np.random.default_rng(6)
    q, qd, tau = rng.uniform(-1, 1, (3, robot.n))
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        there = pool.submit(mrnea.forward_dynamics, robot, q, qd, tau).result(timeout=300)
    np.testing.assert_array_equal(there, mrnea.forward_dynamics(robot, q, qd, tau))


def test_actuator_fields_are_one_list() -> None:
    """with_actuators takes exactly the listed fields; describe() has a column per field (its
    unit for revolute joints in the header);
    docs/robot-format.md's actuator table lists the same fields, symbols, units and meanings."""
    names = [f.name for f in ACTUATOR_FIELDS]
    robot = mrnea.robots.puma560()
    with pytest.raises(ModelError, match="unknown field"):
        robot.with_actuators(velocity_limit=1.0)
    lines = describe(robot, width=1000).splitlines()  # one table: all revolute, N m
    header = re.split(" {2,}", lines[1])
    revolute = {"effort_limit": "N m", "gear_ratio": "-", "rotor_inertia": "kg m^2",
                "viscous_friction": "N m s/rad", "coulomb_friction": "N m",
                "torque_speed": "N m, rad/s", "efficiency": "-"}
    assert header[-len(names):] == [f"{f.symbol} [{revolute[f.name]}]" for f in ACTUATOR_FIELDS]
    j = robot.joints[1]
    assert j.coulomb_pair == (13.58469, 7.654865)  # asymmetric: both magnitudes
    assert re.split(" {2,}", lines[3])[-len(names):] == [
        f"{getattr(j, f.name):.5g}" for f in ACTUATOR_FIELDS[:-3]] + ["13.585/7.6549", "-", "1"]
    doc = (DOCS / "robot-format.md").read_text()
    section = doc.split("### Actuator fields", 1)[1].split("\n\n")[2]
    rows = [[c.strip() for c in line.strip("|").split("|")] for line in section.splitlines()[2:]]
    assert rows == [[f"`{f.name}`", f.symbol, f.unit, f.meaning] for f in ACTUATOR_FIELDS]
    for name in names:  # the [[joint]] table names them too
        assert f"| `{name}` | no |" in doc
