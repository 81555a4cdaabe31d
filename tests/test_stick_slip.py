"""Stick-slip through ``simulate``: issue 11's second reproducer (a stalled drive, and the drive
off), the closed-form slip of a pendulum, two coupled joints held together or breaking away
together, and a drive breaking away in the first cycle it can.

The one-joint pendulum: axis y, a link of 2 kg with its centre of mass 0.5 m out, inertia
1e-3 I, gear 10, rotor 1e-4 kg m^2, gravity 9.81 m/s^2 along -z. Gravity turns it towards
q = pi/2 (hanging) with the torque m g l cos q = 9.81 cos q N m, so u' = -9.81 cos q, and
I_a = m l^2 + I_yy + G^2 J_m = 0.5 + 0.001 + 0.01 = 0.511 kg m^2 (worked out by hand).
"""

from __future__ import annotations

import numpy as np
import pytest

from mrnea import Joint, Link, Robot, mass_matrix_and_bias, transform
from mrnea.simulate import simulate

MGL, IA = 9.81, 0.511


def pendulum(effort_limit: float, coulomb: float) -> Robot:
    j = Joint("j", "revolute", "base", "l", axis=(0, 1, 0), effort_limit=effort_limit,
              coulomb_friction=coulomb, gear_ratio=10.0, rotor_inertia=1e-4)
    return Robot([j], [Link("l", mass=2.0, com=(0.5, 0, 0), inertia=np.eye(3) * 1e-3)])


def bisect(f, lo: float, hi: float) -> float:
    """The root of f in [lo, hi] (f(lo), f(hi) of opposite signs) to rounding."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if (f(mid) > 0) == (f(lo) > 0) else (lo, mid)
    return 0.5 * (lo + hi)


def sign_flips(x) -> int:
    s = np.sign(x[x != 0.0])
    return int(np.count_nonzero(s[1:] != s[:-1]))


@pytest.mark.parametrize("mode", ["hybrid", "paper"])
def test_reproducer_2_stalled_drive_sticks(mode):
    """The issue's program, q_cmd = 0.3 - 1e-3 k at dt = 1 ms for 10 s (before: 956 sign flips
    of the velocity in the last 2 s, 5e-3 rad of creep in 5 s). The drive (8 N m) cannot lift
    the link (9.81 cos q), it slides down against friction (1 N m) until the holding torque left
    over, 9.81 cos q - 8, is within F_s, and then it must stay exactly where it stopped."""
    dt = 1e-3
    q_cmd = 0.3 - 1e-3 * np.arange(10001)[:, None]
    res = simulate(pendulum(8.0, 1.0), q_cmd, dt, mode=mode)
    qd = res.qd[:, 0]
    assert np.all(qd[-2000:] == 0.0), "not exactly at rest"
    assert sign_flips(qd[-2000:]) == 0
    assert res.q[-1, 0] == res.q[-2000, 0], "creep"
    assert np.any(qd > 0) and np.all(qd >= 0), "it slides down first, never back"
    assert res.stuck[-2000:, 0].all() and not res.achievable
    qf = res.q[-1, 0]
    assert np.all(res.tau[-1999:-1, 0] == -8.0)  # the drive at its limit, towards the program
    # held: friction takes the rest of gravity, within its capacity
    np.testing.assert_allclose(res.coulomb[-2, 0], -8.0 + MGL * np.cos(qf), rtol=1e-12)
    assert abs(-8.0 + MGL * np.cos(qf)) <= 1.0


def test_unpowered_pendulum_slips_with_closed_form_then_sticks():
    """Drive off; from rest where gravity (5.2 N m) just exceeds static friction (5 N m). While
    it moves, every cycle's acceleration is (m g l cos q - F_s sign(v)) / I_a (closed form); it
    stops where the friction's work has taken the energy gravity gave, and stays there (before:
    719 sign flips in 2 s)."""
    dt, K, Fs = 1e-3, 4001, 5.0
    q0 = np.arccos(5.2 / MGL)
    res = simulate(pendulum(0.0, Fs), np.full((K, 1), q0), dt)
    v, q = res.qd[1:, 0], res.q[:-1, 0]  # cycle k's velocity and the position it starts from
    qdd = (v - res.qd[:-1, 0]) / dt
    np.testing.assert_allclose(res.qdd[:-1, 0], qdd, rtol=1e-12, atol=1e-12)
    moving = v != 0.0
    assert moving[0], "it starts slipping in the first cycle"
    np.testing.assert_allclose(qdd[0], (5.2 - Fs) / IA, rtol=1e-12)
    np.testing.assert_allclose(qdd[moving], (MGL * np.cos(q[moving]) - Fs * np.sign(v[moving]))
                               / IA, rtol=1e-11, atol=1e-9)
    assert np.all(v >= 0.0), "friction never drives it backwards"
    stop = np.flatnonzero(~moving)[0]  # it stops, exactly, and stays
    assert np.all(~moving[stop:]) and res.q[-1, 0] == res.q[stop + 1, 0]
    assert sign_flips(res.qd[-2000:, 0]) == 0
    qf = res.q[-1, 0]
    assert MGL * np.cos(qf) <= Fs  # held there by static friction
    # where it stops: 9.81 (sin qf - sin q0) = F_s (qf - q0) in continuous time; the cycle's
    # update, explicit in q, errs by O(dt) in the swept angle
    qf_exact = bisect(lambda x: MGL * (np.sin(x) - np.sin(q0)) - Fs * (x - q0), q0 + 1e-6, 1.5)
    assert abs(qf - qf_exact) < 5 * dt * np.max(res.qd) + 1e-9, (qf, qf_exact)


def two_link(F1: float, F2: float) -> Robot:
    """Two links in the vertical x-z plane (axes y), unpowered, Coulomb friction F1, F2."""
    js = [Joint("j0", "revolute", "base", "l0", axis=(0, 1, 0), effort_limit=0.0,
                coulomb_friction=F1),
          Joint("j1", "revolute", "l0", "l1", origin=transform((1, 0, 0)), axis=(0, 1, 0),
                effort_limit=0.0, coulomb_friction=F2)]
    ls = [Link(f"l{i}", mass=1.0, com=(0.5, 0, 0), inertia=np.diag([1e-4, 1 / 12, 1 / 12]))
          for i in range(2)]
    return Robot(js, ls)


def test_two_joints_held_together_exactly():
    """At rest with every joint's holding torque inside its friction: nothing moves, exactly,
    for 2000 cycles (no creep of either joint), and friction carries gravity."""
    q0 = np.array([1.2, -0.4])
    _, u = mass_matrix_and_bias(two_link(0, 0), q0, np.zeros(2))
    res = simulate(two_link(*(np.abs(u) * 1.05)), np.tile(q0, (2001, 1)), 1e-3)
    assert np.all(res.qd == 0.0) and np.all(res.q == q0) and res.stuck.all()
    np.testing.assert_allclose(res.coulomb[0], -u, rtol=1e-14)
    assert res.achievable  # unpowered, but the program (stay) is kept


@pytest.mark.parametrize("drag", [False, True])
def test_coupled_breakaway(drag):
    """Joint 0 cannot be held (|u'_0| > F_0); joint 1 could be held on its own (|u'_1| < F_1).
    Solved together: if joint 1's friction can also take the reaction of joint 0's acceleration,
    joint 1 stays exactly at rest and qdd_0 = -(u'_0 + F_0 s) / H_00 (closed form); if not,
    joint 0 drags it along and both slip with the 2x2 closed form. Joint by joint (joint 1
    judged at rest against u'_1 alone) would keep it stuck in both cases."""
    q0, dt = np.array([-0.5, -1.0]), 1e-3
    H, u = mass_matrix_and_bias(two_link(0, 0), q0, np.zeros(2))
    F0 = 0.5 * abs(u[0])
    s0 = -np.sign(u[0])  # joint 0 moves the way gravity pulls it
    qdd0 = -(u[0] + F0 * s0) / H[0, 0]
    h1 = H[1, 0] * qdd0 + u[1]  # what joint 1's friction must take to stay
    assert abs(u[1]) < abs(h1), "the coupling must matter for this test"
    F1 = (abs(u[1]) + abs(h1)) / 2 if drag else 1.1 * abs(h1)
    assert abs(u[1]) < F1  # joint 1 alone would be held
    res = simulate(two_link(F0, F1), np.tile(q0, (2, 1)), dt)
    v = res.qd[1]
    if not drag:
        assert v[1] == 0.0 and res.stuck[0, 1]
        np.testing.assert_allclose(v[0] / dt, qdd0, rtol=1e-13)
        np.testing.assert_allclose(res.coulomb[0, 1], -h1, rtol=1e-12)
    else:
        s1 = np.sign(-h1)  # it moves the way the unbalanced torque pushes it
        qdd = np.linalg.solve(H, -(u + np.array([F0 * s0, F1 * s1])))
        assert np.sign(qdd[0]) == s0 and np.sign(qdd[1]) == s1  # the closed form is consistent
        np.testing.assert_allclose(v / dt, qdd, rtol=1e-12)
        assert not res.stuck[0].any()


def test_drive_breaks_away_in_the_first_cycle_it_can():
    """A joint about the vertical (no gravity torque), I_a = 0.511, static friction 2 N m, drive
    limit 3 N m, asked to move at 0.5 rad/s; a load moment resisting positive motion decreases
    from 2.5 N m by 0.025 N m per cycle (the wrench the link exerts about z: u' = +load). The
    drive (at +3) overcomes friction + load when the load falls below 1 N m: it must stay exactly
    at rest up to cycle 60 (load 1 N m: balance) and move in cycle 61, with
    qdd = (3 - load - 2) / I_a."""
    j = Joint("j", "revolute", "base", "l", axis=(0, 0, 1), effort_limit=3.0,
              coulomb_friction=2.0, gear_ratio=10.0, rotor_inertia=1e-4)
    robot = Robot([j], [Link("l", mass=2.0, com=(0.5, 0, 0), inertia=np.eye(3) * 1e-3)])
    K, dt = 71, 1e-3
    load = 2.5 - 0.025 * np.arange(K)
    wrench = np.zeros((K, 6))
    wrench[:, 5] = load
    res = simulate(robot, 0.5 * dt * np.arange(K)[:, None], dt, f_ext=wrench)
    v = res.qd[1:, 0]  # cycle k's velocity
    assert np.all(v[:61] == 0.0) and res.stuck[:61, 0].all()
    assert np.all(res.tau[:61, 0] == 3.0)  # the drive pushes at its limit all along
    np.testing.assert_allclose(v[61] / dt, (3.0 - load[61] - 2.0) / IA, rtol=1e-12)
    assert np.all(v[61:] > 0)


def test_asymmetric_friction_picks_the_direction_of_motion():
    """Coulomb friction [F+, F-] = [2, 0.5] N m on the joint about the vertical, drive off,
    pushed by a constant moment: towards +q it must exceed F+ = 2 N m to move, towards -q only
    F- = 0.5 N m; moving, the acceleration is (push - F) / I_a in each direction (closed form)."""
    for push, moves, F in ((1.0, False, 2.0), (2.5, True, 2.0), (-0.4, False, 0.5),
                           (-1.0, True, 0.5)):
        j = Joint("j", "revolute", "base", "l", axis=(0, 0, 1), effort_limit=0.0,
                  coulomb_friction=(2.0, 0.5), gear_ratio=10.0, rotor_inertia=1e-4)
        robot = Robot([j], [Link("l", mass=2.0, com=(0.5, 0, 0), inertia=np.eye(3) * 1e-3)])
        wrench = np.array([0.0, 0.0, 0.0, 0.0, 0.0, -push])  # u' = -push: it pushes q by push
        res = simulate(robot, np.zeros((3, 1)), 1e-3, f_ext=wrench)
        qdd = res.qdd[0, 0]
        if moves:
            np.testing.assert_allclose(qdd, (push - np.sign(push) * F) / IA, rtol=1e-12)
        else:
            assert qdd == 0.0 and res.stuck[0, 0]
            # held: tau - phi = u' = -push with tau = 0
            np.testing.assert_allclose(res.coulomb[0, 0], push, rtol=1e-14)
