"""The answer a designer reads (issue 11, parts 3-4): the program's own requirement against
Pinocchio and against a hand calculation for the SDT demo, strict JSON, the verdict lines with
units, and no verdict on a robot that cannot move or a start outside the joint limits."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from click.testing import CliRunner
from conftest import pin_fext, to_pinocchio

import mrnea
from mrnea import Joint, Link, Robot, SingularMassMatrixError
from mrnea.actuators import program_requirement
from mrnea.cli import main
from mrnea.robots.sdt_profile import training_profile
from mrnea.simulate import simulate


def there_and_back(q0, q1, T: float, dt: float, rest: float = 0.1) -> np.ndarray:
    """Rest, quintic q0 -> q1 over T, rest, quintic back, rest: (K, n) with reversals."""
    t = np.arange(0.0, 2 * T + 3 * rest + dt / 2, dt)

    def blend(t0):
        s = np.clip((t - t0) / T, 0.0, 1.0)
        return 10 * s**3 - 15 * s**4 + 6 * s**5

    w = blend(rest) - blend(T + 2 * rest)
    return np.asarray(q0)[None] + (np.asarray(q1) - np.asarray(q0))[None] * w[:, None]


def test_program_requirement_against_pinocchio():
    """program_effort[k] = rnea(q_cmd[k], qd_cmd[k], qdd_des) with armature G^2 J_m and the
    wrench, + F_v qd_cmd[k], + the Coulomb friction of the wanted velocity v = qd_cmd[k+1] (F+
    up, -F- down; at v = 0 friction takes up to its capacity of the holding effort first), with
    qdd_des = (v - qd_cmd[k]) / dt; program_limit the torque-speed limit at |qd_cmd[k]|. The
    Puma 560 with its asymmetric friction, a wrench at a point of the last link, a program with
    rests and reversals that saturates (the requirement does not depend on the response)."""
    dt = 0.004
    curves = [(97.6, 1.0, 4.0), (186.4, 1.0, 4.0), (89.4, 1.0, 4.0), (24.2, 2.0, 6.0),
              (20.1, 2.0, 6.0), (21.3, 2.0, 6.0)]
    robot = mrnea.robots.puma560().with_actuators(torque_speed=curves)
    q_cmd = there_and_back(np.zeros(6), [1.0, -0.8, 0.9, 1.5, -1.2, 2.0], 0.6, dt)
    fe, pe = np.array([3.0, -2.0, 15.0, 0.4, 0.1, -0.3]), np.array([0.0, 0.02, 0.1])
    res = simulate(robot, q_cmd, dt, f_ext=fe, f_ext_point=pe)
    assert res.saturated.any()  # the robot lags; the requirement is the program's anyway
    model = to_pinocchio(robot)
    model.armature = robot.gear_ratio**2 * robot.rotor_inertia
    data = model.createData()
    K = q_cmd.shape[0]
    qd_cmd = np.vstack([np.zeros(6), np.diff(q_cmd, axis=0) / dt])
    Fp, Fn = robot.coulomb_friction[:, 0], robot.coulomb_friction[:, 1]
    expect, rigid = np.empty((K, 6)), np.empty((K, 6))
    for k in range(K):
        v = qd_cmd[k + 1] if k + 1 < K else np.zeros(6)
        qdd = (v - qd_cmd[k]) / dt
        fext = pin_fext(robot, model, q_cmd[k], fe, pe)
        h = pin.rnea(model, data, q_cmd[k], qd_cmd[k], qdd, fext)
        h = np.array(h) + robot.viscous_friction * qd_cmd[k]
        expect[k] = h + np.where(v > 0, Fp, np.where(v < 0, -Fn, np.clip(-h, -Fn, Fp)))
        rigid[k] = h
    scale = np.abs(expect).max(axis=0)
    assert np.all(np.abs(res.program_effort - expect) <= 1e-9 * scale)
    # the same without a run (mrnea.retime's Hollerbach estimate), and without Coulomb friction
    req, lim = program_requirement(robot, q_cmd, dt, fe, pe)
    assert np.all(np.abs(req - expect) <= 1e-9 * scale)
    req, _ = program_requirement(robot, q_cmd, dt, fe, pe, friction=False)
    assert np.all(np.abs(req - rigid) <= 1e-9 * scale)
    peak, corner, no_load = (np.array(c) for c in zip(*curves, strict=True))
    w = np.abs(qd_cmd)
    limit = np.where(w <= corner, peak, np.minimum(peak * corner / np.maximum(w, corner),
                                                   peak * (no_load - w) / (no_load - corner)))
    np.testing.assert_allclose(res.program_limit, np.where(w >= no_load, 0.0, limit), rtol=1e-14)
    np.testing.assert_allclose(lim, np.where(w >= no_load, 0.0, limit), rtol=1e-14)
    beyond = 0
    for i, jd in enumerate(res.summary()["joints"]):
        with np.errstate(divide="ignore"):  # zero limit beyond the no-load speed: no ratio
            ratio = np.abs(expect[:, i]) / res.program_limit[:, i]
        if np.isinf(ratio.max()):
            beyond += 1
            assert jd["program_effort_ratio"] is None and jd["program_beyond_no_load_speed"]
        else:
            assert jd["program_effort_ratio"] == pytest.approx(ratio.max(), rel=1e-9)
        assert jd["program_peak_effort"] == pytest.approx(np.abs(expect[:, i]).max(), rel=1e-9)
        G = robot.gear_ratio[i]
        assert jd["program_rms_motor_torque"] == pytest.approx(
            np.sqrt(np.mean((expect[:, i] / G) ** 2)), rel=1e-9)
    assert 0 < beyond < 6  # both kinds of joints


def test_sdt_demo_effort_ratio_by_hand():
    """docs/sdt.md's hand calculation. The cabin yaw turn is a 0 -> pi quintic over T = 3 s from
    t = 14 s, with roll and pitch at 0 and the arm at a constant 2.5 rad/s. Its acceleration
    peaks at s = (3 - sqrt 3) / 6 of the move, 10 pi / (sqrt(3) T^2) = 2.015 rad/s^2, at
    t = 14.634 s. The inertia about the yaw axis: yoke Izz 1358.6 + ring Izz 1028.0 + cabin Izz
    416.4 + 920 kg (0.025 m)^2 (its centre of mass is 2.5 cm forward) = 2803.6 kg m^2, plus the
    rotor's 80^2 0.010 = 64 kg m^2. The yaw drive also turns the cabin's offset centre of mass
    with the arm's centripetal acceleration w^2 a1 = 2.5^2 3 = 18.75 m/s^2 (towards the arm's
    axis, at right angles to the offset at yaw 0): 920 0.025 18.75 cos(q_yaw). Plus Coulomb 250
    and viscous 40 q_yaw' N m."""
    T, s = 3.0, (3 - math.sqrt(3)) / 6
    qdd = math.pi / T**2 * (60 * s - 180 * s**2 + 120 * s**3)
    qd = math.pi / T * (30 * s**2 - 60 * s**3 + 30 * s**4)
    q = math.pi * (10 * s**3 - 15 * s**4 + 6 * s**5)
    assert qdd == pytest.approx(2.0153, abs=1e-4)
    inertia = 1358.6 + 1028.0 + 416.4 + 920 * 0.025**2 + 80**2 * 0.010
    need = inertia * qdd + 920 * 0.025 * 2.5**2 * 3.0 * math.cos(q) + 250.0 + 40.0 * qd
    assert need == pytest.approx(6486, abs=1)
    dt = 0.005
    res = simulate(mrnea.robots.sdt(), training_profile(dt)[1], dt)
    summary = res.summary()
    assert summary["worst_joint"] == "cab_yaw" and not summary["achievable"]
    yaw = summary["joints"][1]
    # the cycle's differences of the commanded positions: the peak to O(dt), 4e-5 here
    assert yaw["program_effort_ratio"] == pytest.approx(need / 4000.0, rel=2e-4)
    assert summary["worst_effort_ratio"] == yaw["program_effort_ratio"]
    assert yaw["program_peak_effort"] == pytest.approx(need, rel=2e-4)
    assert abs(yaw["program_ratio_time"] - (14.0 + T * s)) <= dt
    assert yaw["program_limit_at_ratio"] == 4000.0 and yaw["drive"] == "limited"
    assert yaw["program_peak_motor_torque"] == pytest.approx(need / 80.0, rel=2e-4)
    # the first cycle over the limit is where the simulated robot first saturates
    assert yaw["program_first_over_time"] == summary["first_infeasible"]["time"]
    assert res.verdict() == (
        f"NOT ACHIEVABLE: cab_yaw needs {yaw['program_effort_at_ratio']:.4g} N m, "
        f"{yaw['program_effort_ratio']:.2f} \u00d7 its 4000 N m limit, at t = "
        f"{yaw['program_ratio_time']:.3f} s (first over the limit at t = "
        f"{yaw['program_first_over_time']:.3f} s)")
    assert "1.62 \u00d7 its 4000 N m limit" in res.verdict()


def three_joints(effort=(8.0, math.inf, 0.0)) -> Robot:
    """A vertical-plane 3R arm: a limited, an unlimited and an unpowered joint (effort 0), the
    last held by its friction."""
    joints = [Joint(f"j{i}", "revolute", "base" if i == 0 else f"l{i - 1}", f"l{i}",
                    origin=mrnea.transform((0.4 if i else 0.0, 0, 0)), axis=(0, 1, 0),
                    effort_limit=effort[i], coulomb_friction=(5.0, 5.0) if i == 2 else 0.0)
              for i in range(3)]
    links = [Link(f"l{i}", 1.0, (0.2, 0, 0), np.diag([1e-3, 0.02, 0.02])) for i in range(3)]
    return Robot(joints, links, name="arm3")


def test_summary_is_strict_json_and_says_what_has_no_limit(tmp_path):
    """RFC 8259: no Infinity or NaN token; an unlimited value is null; the joint without a drive
    has no ratio (null) and is reported unpowered; the unlimited one has none either."""
    q_cmd = there_and_back(np.zeros(3), [0.3, -0.2, 0.0], 1.0, 0.01)
    res = simulate(three_joints(), q_cmd, 0.01)
    path = res.save_summary(tmp_path / "summary.json")
    text = path.read_text()
    assert "Infinity" not in text and "NaN" not in text
    s = json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict token {c}"))
    limited, unlimited, unpowered = s["joints"]
    assert limited["drive"] == "limited" and limited["program_effort_ratio"] > 0
    assert unlimited["effort_limit"] is None and unlimited["drive"] == "unlimited"
    assert unlimited["program_effort_ratio"] is None
    assert unpowered["drive"] == "unpowered" and unpowered["program_effort_ratio"] is None
    assert s["worst_joint"] == "j0"
    assert s["first_infeasible"] is None or s["first_infeasible"]["velocity_limit"] is None


def pendulum(limit: float) -> Robot:
    """1 DoF, axis y, com 0.5 m out, 2 kg, I_c = 0.01: tau = I qdd - m g l cos q (by hand,
    tests/test_simulate.py), I = 0.01 + 2 0.5^2 = 0.51 kg m^2."""
    j = Joint("hinge", "revolute", "base", "bob", axis=(0, 1, 0), effort_limit=limit)
    return Robot([j], [Link("bob", 2.0, (0.5, 0, 0), np.eye(3) * 0.01)], name="pendulum")


def test_achievable_verdict_states_the_headroom():
    """Holding the pendulum horizontal (q = 0, at rest) needs m g l = 9.81 N m; with a 12 N m
    drive the worst joint is at 9.81 / 12 = 0.82 of its limit."""
    res = simulate(pendulum(12.0), np.zeros((50, 1)), 0.01)
    assert res.achievable
    assert res.summary()["worst_effort_ratio"] == pytest.approx(9.81 / 12.0, rel=1e-12)
    assert res.verdict().startswith("ACHIEVABLE: pendulum follows the program")
    assert "worst joint hinge at 0.82 of its limit" in res.verdict()


def test_unpowered_joint_that_must_carry_a_load():
    res = simulate(pendulum(0.0), np.zeros((50, 1)), 0.01)
    assert res.achievable is False
    jd = res.summary()["joints"][0]
    assert jd["drive"] == "unpowered" and jd["program_effort_ratio"] is None
    assert jd["program_peak_effort"] == pytest.approx(9.81, rel=1e-12)
    assert res.verdict() == ("NOT ACHIEVABLE: hinge has no drive (effort limit 0) and the "
                             "program needs 9.81 N m at t = 0.000 s")


@pytest.mark.parametrize("q0, qd0, reason", [
    ([5.0], [0.0], "start outside the position limits"),
    ([0.1], [3.0], "start faster than the velocity limit"),
])
def test_a_start_outside_the_limits_is_not_achievable(q0, qd0, reason):
    """Issue 11: q0 5 rad outside a +-1.57 rad range was ACHIEVABLE. The program itself stays
    within the limits (at 0.1 rad)."""
    j = Joint("hinge", "revolute", "base", "bob", axis=(0, 0, 1), lower=-1.57, upper=1.57,
              velocity_limit=2.0, effort_limit=100.0)
    robot = Robot([j], [Link("bob", 2.0, (0.5, 0, 0), np.eye(3) * 0.01)], name="r")
    res = simulate(robot, np.full((20, 1), 0.1), 0.01, q0=q0, qd0=qd0)
    assert res.achievable is False
    s = res.summary()
    assert s["start_infeasible"][0]["reason"] == reason
    assert s["first_infeasible"]["reason"] == reason and s["first_infeasible"]["time"] == 0.0
    assert f"hinge: {reason}" in res.verdict()


def massless_urdf(path: Path) -> Path:
    path.write_text("""<?xml version="1.0"?>
<robot name="ghost">
  <link name="base"/>
  <link name="a"/>
  <link name="b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
  <joint name="j2" type="revolute"><parent link="a"/><child link="b"/>
    <origin xyz="0.5 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/></joint>
</robot>
""")
    return path


def test_a_robot_that_cannot_move_gets_no_verdict(tmp_path):
    """A URDF without inertials (was ACHIEVABLE, exit 0): H_a is singular, the library raises
    naming the links, and check and simulate exit 2 with one line."""
    urdf = massless_urdf(tmp_path / "ghost.urdf")
    with pytest.warns(mrnea.ModelWarning):
        robot = mrnea.load_urdf(urdf)
    with pytest.raises(SingularMassMatrixError, match="'a', 'b'"):
        simulate(robot, np.zeros((10, 2)), 0.01)
    csv = tmp_path / "p.csv"
    csv.write_text("t,j1,j2\n0,0,0\n1,0.5,0.5\n")
    for cmd in (["check"], ["simulate", "--out", str(tmp_path / "out")]):
        res = CliRunner().invoke(main, [cmd[0], str(urdf), str(csv), "--dt", "0.01", *cmd[1:]])
        assert res.exit_code == 2, res.output
        lines = res.stderr.strip().splitlines()
        assert lines[-1].startswith("mrnea: error:") and "'a', 'b'" in lines[-1]
        assert "no mass and no rotor inertia" in lines[-1] and "Traceback" not in res.stderr
        # the model's warnings: once each, one line each, no source line
        assert lines[:-1] == [f"mrnea: warning: link '{x}' is massless (nothing it carries has "
                              "mass either, so H is singular and forward dynamics will fail)"
                              for x in "ab"]
