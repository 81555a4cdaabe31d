"""Coulomb friction as a model field and as a law: a magnitude or an asymmetric pair ``[positive
direction, negative direction]`` (issue 11, part 5) through every way a robot is made or read;
static friction holds a joint at rest while the net effort on it is below ``F_s``, through
``achievable_accelerations`` and through the simulator.

Friction is also tested where it meets another feature: the drive law's cycle solve against
enumeration (test_drive_solve.py) and MuJoCo (test_drive_mujoco.py), stick-slip through
``simulate`` (test_stick_slip.py), the achievable accelerations' Coulomb cases at rest by closed
form and Pinocchio (test_achievable.py, "Coulomb friction at rest"), viscous friction's energy
balance (test_physics.py), the program's requirement with friction (test_verdict.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mrnea
from mrnea import Joint, ModelError, RobotFileError
from mrnea.achievable import achievable_accelerations
from mrnea.actuators import coulomb_effort
from mrnea.io import load_robot, load_urdf
from mrnea.io.native import loads_native
from mrnea.simulate import simulate


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


def test_coulomb_effort_is_the_law_by_hand():
    """phi(qd) (actuators.coulomb_effort): F+ moving forward, -F- moving back, 0 at rest, per
    joint, one state or a batch; the joints' own pairs, asymmetric included."""
    robot = mrnea.robots.puma560()  # RTB's Tc+ != Tc-
    F = np.array([j.coulomb_pair for j in robot.joints])
    assert np.any(F[:, 0] != F[:, 1])
    qd = np.array([0.3, -2.0, 0.0, 1e-300, -1e-300, 5.0])
    expect = [F[0, 0], -F[1, 1], 0.0, F[3, 0], -F[4, 1], F[5, 0]]
    assert coulomb_effort(robot, qd).tolist() == expect
    batch = coulomb_effort(robot, np.stack([qd, -qd]))
    assert batch.shape == (2, 6) and batch[0].tolist() == expect
    assert batch[1].tolist() == [-F[0, 1], F[1, 0], 0.0, -F[3, 1], F[4, 0], -F[5, 1]]
    with pytest.raises(mrnea.StateError, match="qd"):
        coulomb_effort(robot, [0.0, math.nan, 0, 0, 0, 0])


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


# --- Coulomb friction at rest ---------------------------------------------------------------------
@pytest.mark.parametrize("gravity", [(0.0, 0.0, 0.0), (0.0, 0.0, -9.81)], ids=["free", "gravity"])
@pytest.mark.parametrize("mode", ["hybrid", "paper"])
def test_static_friction_holds_a_joint_at_rest(gravity, mode: str) -> None:
    """Static (Coulomb) friction: a joint at rest stays at rest while the net effort on it (motor
    plus gravity) is below F_s. Puma 560 at rest, every motor limited to 1 N m, each joint's
    F_s = |gravity load| + 2 N m: whatever acceleration is asked for, qdd = 0 exactly, the motors
    give their limit and nothing moves. Exact zeros: the stick decision is a comparison, not a
    computation with rounding. The same robot with weak friction moves (the test can fail)."""
    base = mrnea.robots.puma560().with_gravity(gravity)
    rng = np.random.default_rng(3)
    q, z = rng.uniform(-1.0, 1.0, 6), np.zeros(6)
    _, hold = mrnea.mass_matrix_and_bias(base, q, z)
    robot = base.with_actuators(coulomb_friction=np.abs(hold) + 2.0, effort_limit=1.0)
    for _ in range(5):
        res = achievable_accelerations(robot, q, z, rng.normal(0.0, 50.0, 6), mode=mode)
        np.testing.assert_array_equal(res.qdd, 0.0)
        assert np.all(np.abs(res.tau) <= 1.0)
    weak = base.with_actuators(coulomb_friction=0.5, effort_limit=np.abs(hold) + 2.0)
    res = achievable_accelerations(weak, q, z, rng.normal(0.0, 50.0, 6), mode=mode)
    assert np.all(res.qdd != 0.0)


def test_static_friction_holds_through_a_simulation() -> None:
    """The same through the simulator: a program that asks the stuck Puma to move 0.5 rad per
    joint in 0.5 s leaves every joint exactly where it started, at rest, for all 100 cycles."""
    base = mrnea.robots.puma560()
    q0 = np.random.default_rng(3).uniform(-1.0, 1.0, 6)
    _, hold = mrnea.mass_matrix_and_bias(base, q0, np.zeros(6))
    robot = base.with_actuators(coulomb_friction=np.abs(hold) + 2.0, effort_limit=1.0)
    res = simulate(robot, np.linspace(q0, q0 + 0.5, 100), 0.005)
    np.testing.assert_array_equal(res.q, np.broadcast_to(q0, res.q.shape))
    np.testing.assert_array_equal(res.qd, 0.0)
    assert not res.achievable and res.saturated[:-1].all()
