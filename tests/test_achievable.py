"""Achievable accelerations, the actuator model and the interpolation cycle (paper Secs. II, V).

Every expected number comes from outside the code under test:

* closed forms worked out by hand here (a 1-DoF pendulum and a vertical slider, a planar 2-link
  arm with the textbook mass matrix, Coulomb friction at rest, the torque-speed curve, the
  clamping and integration of one cycle);
* Pinocchio (``pin.rnea`` with ``model.armature = G^2 J_m``, friction added here) for the efforts
  the actuators must give, with and without an external wrench;
* identities between independent computations: the defining properties of the two modes are
  checked with ``mrnea.inverse_dynamics`` (the plain RNEA kernel, not the mRNEA pass that
  ``achievable_accelerations`` uses) plus the actuator terms written out here.

Error measure: ``conftest.rel_err`` (max abs deviation / max(1, max |reference|)).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from conftest import pin_fext, random_chain, rel_err, to_pinocchio
from hypothesis import given
from hypothesis import strategies as st

import mrnea
from mrnea import Joint, Link, Robot, StateError, inverse_dynamics, mass_matrix_and_bias
from mrnea.achievable import AchievableResult, StepResult, achievable_accelerations, achievable_step
from mrnea.actuators import (
    actuator_efforts,
    actuator_mass_matrix_and_bias,
    effort_limits_at,
    motor_torque,
)
from mrnea.rigid import transform

TOL = 1e-9  # numerical agreement between independent computations
MODES = ("paper", "hybrid")
G0 = 9.81


# --- references -----------------------------------------------------------------------------------
def armature(robot: Robot) -> np.ndarray:
    """G^2 J_m per joint [kg m^2 | kg], joint side."""
    return robot.gear_ratio**2 * robot.rotor_inertia


def coulomb(robot: Robot, v) -> np.ndarray:
    """Coulomb friction of joints moving with velocity v: F+ (v > 0), -F- (v < 0), 0 at rest."""
    v = np.asarray(v, dtype=float)
    Fp, Fn = robot.coulomb_friction[:, 0], robot.coulomb_friction[:, 1]
    return np.where(v > 0, Fp, np.where(v < 0, -Fn, 0.0))


def actuator_terms(robot: Robot, qd, qdd) -> np.ndarray:
    """G^2 J_m qdd + F_v qd + F_s sign(qd), written out (Eq. 43's additions to Eq. 1)."""
    qd, qdd = np.asarray(qd, dtype=float), np.asarray(qdd, dtype=float)
    return armature(robot) * qdd + robot.viscous_friction * qd + coulomb(robot, qd)


def id_efforts(robot: Robot, q, qd, qdd, f_ext=None, f_ext_point=None) -> np.ndarray:
    """Actuator-side efforts from mrnea's plain RNEA (inverse_dynamics) + actuator terms."""
    return inverse_dynamics(robot, q, qd, qdd, f_ext, f_ext_point) + actuator_terms(robot, qd, qdd)


class PinRef:
    """Pinocchio's actuator-side inverse dynamics of ``robot`` (armature = G^2 J_m)."""

    def __init__(self, robot: Robot) -> None:
        self.robot = robot
        self.model = to_pinocchio(robot)
        self.model.armature = armature(robot)
        self.data = self.model.createData()

    def efforts(self, q, qd, qdd, f_ext=None, f_ext_point=None) -> np.ndarray:
        args = [self.model, self.data, np.asarray(q, float), np.asarray(qd, float),
                np.asarray(qdd, float)]
        if f_ext is not None:
            args.append(pin_fext(self.robot, self.model, q, f_ext, f_ext_point))
        tau = np.array(pin.rnea(*args))
        qd = np.asarray(qd, float)
        return tau + self.robot.viscous_friction * qd + coulomb(self.robot, qd)


# --- robots ---------------------------------------------------------------------------------------
BARE = {"gear_ratio": 1.0, "rotor_inertia": 0.0, "viscous_friction": 0.0, "coulomb_friction": 0.0}


def with_random_actuators(robot: Robot, rng: np.random.Generator) -> Robot:
    n = robot.n
    return robot.with_actuators(
        gear_ratio=rng.uniform(1.0, 120.0, n), rotor_inertia=rng.uniform(1e-6, 3e-4, n),
        viscous_friction=rng.uniform(0.0, 5.0, n), coulomb_friction=rng.uniform(0.0, 4.0, n))


def make_robots() -> dict[str, Robot]:
    puma = mrnea.robots.puma560()
    out = {"puma": puma, "puma-bare": puma.with_actuators(**BARE)}
    for n, seed in ((2, 101), (5, 102), (8, 103)):
        rng = np.random.default_rng(seed)
        chain = random_chain(rng, n)
        out[f"chain{n}"] = with_random_actuators(chain, rng)
        out[f"chain{n}-bare"] = chain
    return out


ROBOTS = make_robots()
PIN = {}


def pin_ref(name: str) -> PinRef:
    if name not in PIN:
        PIN[name] = PinRef(ROBOTS[name])
    return PIN[name]


def pendulum(*, m=2.0, l=0.5, Ic=0.01, axis=(1.0, 0.0, 0.0), gravity=(0.0, 0.0, -G0), **joint):
    """1 revolute joint; the com sits at (0, l, 0) in the link frame, the inertia about it is
    Ic * I_3. With axis x and gravity -z the com height is l sin q, so holding the pendulum takes
    m g l cos q; with axis z (gravity along the axis) gravity exerts no torque."""
    j = Joint("j", "revolute", "base", "bob", axis=axis, **joint)
    return Robot([j], [Link("bob", mass=m, com=(0.0, l, 0.0), inertia=Ic * np.eye(3))],
                 gravity=gravity)


def slider(*, m=3.0, **joint):
    """1 prismatic joint along +z against gravity -z: tau = (m + G^2 J_m) qdd + m g + friction."""
    j = Joint("j", "prismatic", "base", "car", axis=(0.0, 0.0, 1.0), **joint)
    return Robot([j], [Link("car", mass=m, com=(0.1, 0.0, 0.0), inertia=0.02 * np.eye(3))])


# planar 2-link arm (both axes z, gravity off): link i's com on its x axis at lc_i
M1, M2, L1, LC1, LC2, I1, I2 = 3.0, 2.0, 0.6, 0.3, 0.25, 0.05, 0.03


def two_link(gear=(30.0, 20.0), jm=(1e-4, 5e-5), effort=(math.inf, math.inf), **joint):
    joints = [
        Joint("j1", "revolute", "base", "l1", axis=(0, 0, 1), gear_ratio=gear[0],
              rotor_inertia=jm[0], effort_limit=effort[0], **joint),
        Joint("j2", "revolute", "l1", "l2", origin=transform((L1, 0, 0)), axis=(0, 0, 1),
              gear_ratio=gear[1], rotor_inertia=jm[1], effort_limit=effort[1], **joint),
    ]
    links = [Link("l1", M1, (LC1, 0, 0), np.diag([0.01, 0.01, I1])),
             Link("l2", M2, (LC2, 0, 0), np.diag([0.01, 0.01, I2]))]
    return Robot(joints, links, gravity=(0.0, 0.0, 0.0))


def two_link_H(q2: float, arm=(0.0, 0.0)) -> np.ndarray:
    """The textbook mass matrix of the planar 2-link arm, plus the rotor armature G^2 J_m."""
    c = math.cos(q2)
    h11 = I1 + M1 * LC1**2 + I2 + M2 * (L1**2 + LC2**2 + 2 * L1 * LC2 * c) + arm[0]
    h12 = I2 + M2 * (LC2**2 + L1 * LC2 * c)
    h22 = I2 + M2 * LC2**2 + arm[1]
    return np.array([[h11, h12], [h12, h22]])


def random_moving_state(rng: np.random.Generator, robot: Robot):
    """q, qd (every joint moving: |qd| >= 0.05), qdd_des."""
    n = robot.n
    q = np.where(robot.is_prismatic, rng.uniform(-0.4, 0.4, n), rng.uniform(-np.pi, np.pi, n))
    qd = rng.choice([-1.0, 1.0], n) * rng.uniform(0.05, 2.0, n)
    return q, qd, rng.normal(0.0, 6.0, n)


def tight_limits(rng: np.random.Generator, req: np.ndarray) -> np.ndarray:
    """Limits below |req| on a random non-empty subset of joints; on the others either unlimited
    or a little above |req| (so that in "hybrid" mode the saturation of one joint can push
    another one over its limit)."""
    n = req.size
    tight = rng.random(n) < 0.5
    tight[rng.integers(n)] = True
    above = np.where(rng.random(n) < 0.5, math.inf, rng.uniform(1.02, 1.6, n) * np.abs(req))
    return np.where(tight, rng.uniform(0.1, 0.9, n) * np.abs(req), above)


# --- defining properties of the two modes ---------------------------------------------------------
@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_paper_mode_clips_required_efforts_and_solves_eq44(name):
    """Eq. 44: tau = clip(tau_required, +-limit) for every joint, H_a qdd + u'_a = tau, and the
    joints flagged saturated are exactly those whose required effort exceeded the limit."""
    base = ROBOTS[name]
    ref = pin_ref(name)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(12):
        q, qd, qdd_des = random_moving_state(rng, base)
        req = ref.efforts(q, qd, qdd_des)
        lim = tight_limits(rng, req)
        robot = base.with_actuators(effort_limit=lim)
        res = achievable_accelerations(robot, q, qd, qdd_des, mode="paper")
        clipped = np.clip(req, -lim, lim)
        errs = [rel_err(res.tau_required, req), rel_err(res.tau, clipped),
                rel_err(id_efforts(robot, q, qd, res.qdd), clipped),
                rel_err(ref.efforts(q, qd, res.qdd), clipped)]
        if name.endswith("bare"):  # no actuator terms: plain inverse dynamics
            errs.append(rel_err(inverse_dynamics(robot, q, qd, res.qdd), clipped))
        worst = max(worst, *errs)
        np.testing.assert_array_equal(res.saturated, np.abs(req) > lim)
        np.testing.assert_array_equal(res.limit, lim)
        np.testing.assert_allclose(res.margin, lim - np.abs(res.tau), rtol=0, atol=1e-12)
        assert res.achievable is False
    assert worst <= TOL, worst


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_hybrid_mode_satisfies_the_drive_law(name):
    """Sec. II with infinitely stiff velocity loops and limited efforts: per joint either
    qdd_i = qdd_des_i exactly with |tau_i| <= L_i, or tau_i = +L_i with qdd_i < qdd_des_i, or
    tau_i = -L_i with qdd_i > qdd_des_i; and H_a qdd + u'_a = tau (Pinocchio, mrnea's plain
    RNEA). These are the optimality conditions of a strictly convex problem (docs/achievable.md),
    so a result that meets them is the unique answer; the joints moving here, Coulomb friction
    is their sliding friction."""
    base = ROBOTS[name]
    ref = pin_ref(name)
    rng = np.random.default_rng(8)
    worst = 0.0
    cascades = 0
    for _ in range(12):
        q, qd, qdd_des = random_moving_state(rng, base)
        req = ref.efforts(q, qd, qdd_des)
        lim = tight_limits(rng, req)
        robot = base.with_actuators(effort_limit=lim)
        res = achievable_accelerations(robot, q, qd, qdd_des, mode="hybrid")
        sat = res.saturated
        np.testing.assert_array_equal(res.qdd[~sat], qdd_des[~sat])
        assert np.all(np.abs(res.tau[~sat]) <= lim[~sat])
        np.testing.assert_array_equal(np.abs(res.tau[sat]), lim[sat])
        below = sat & (res.tau > 0)  # pushing up at +L: it falls short from below
        assert np.all(res.qdd[below] < qdd_des[below])
        assert np.all(res.qdd[sat & ~below] > qdd_des[sat & ~below])
        over = np.abs(req) > lim
        assert sat.any() == over.any()  # on program everywhere iff every requirement fits
        cascades += int(np.any(sat & ~over))
        errs = [rel_err(res.tau_required, req), rel_err(id_efforts(robot, q, qd, res.qdd), res.tau),
                rel_err(ref.efforts(q, qd, res.qdd), res.tau)]
        if name.endswith("bare"):
            errs.append(rel_err(inverse_dynamics(robot, q, qd, res.qdd), res.tau))
        worst = max(worst, *errs)
    assert worst <= TOL, worst
    if base.n > 2:
        assert cascades > 0, "no state exercised a joint pushed over its limit by another"


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_generous_limits_change_nothing(name, mode):
    base = ROBOTS[name]
    ref = pin_ref(name)
    rng = np.random.default_rng(9)
    for _ in range(5):
        q, qd, qdd_des = random_moving_state(rng, base)
        req = ref.efforts(q, qd, qdd_des)
        robot = base.with_actuators(effort_limit=10 * np.abs(req) + 1.0)
        res = achievable_accelerations(robot, q, qd, qdd_des, mode=mode)
        if mode == "hybrid":
            np.testing.assert_array_equal(res.qdd, qdd_des)
        else:
            assert rel_err(res.qdd, qdd_des) <= 1e-9 * max(1.0, np.abs(qdd_des).max())
        np.testing.assert_array_equal(res.tau, res.tau_required)
        assert rel_err(res.tau, id_efforts(robot, q, qd, qdd_des)) <= TOL
        assert rel_err(res.tau_required, req) <= TOL
        assert not res.saturated.any() and res.achievable


@pytest.mark.parametrize("name", ["puma", "chain5", "chain8"])
def test_tau_required_against_pinocchio_with_external_wrench(name):
    """tau_required = rnea(q, qd, qdd_des, f_ext) + G^2 J_m qdd_des + F_v qd + F_s sign(qd) with
    Pinocchio's fext: our f_ext is what the last link exerts ON the environment (base axes, at
    f_ext_point in the last link's frame), Pinocchio's the force ON the body in its local frame."""
    robot, ref = ROBOTS[name], pin_ref(name)
    rng = np.random.default_rng(10)
    worst = 0.0
    for k in range(8):
        q, qd, qdd_des = random_moving_state(rng, robot)
        fe = rng.normal(0.0, 30.0, 6)
        pe = rng.normal(0.0, 0.1, 3) if k % 2 else None
        expect = ref.efforts(q, qd, qdd_des, fe, pe)
        expect_id = id_efforts(robot, q, qd, qdd_des, fe, pe)
        for mode in MODES:
            res = achievable_accelerations(robot, q, qd, qdd_des, f_ext=fe, f_ext_point=pe,
                                           mode=mode)
            worst = max(worst, rel_err(res.tau_required, expect),
                        rel_err(res.tau_required, expect_id),
                        rel_err(id_efforts(robot, q, qd, res.qdd, fe, pe), res.tau))
    assert worst <= TOL, worst


def test_external_wrench_on_pendulum_by_hand():
    """The pendulum's tip pushes down on a table with F at the com point (0, l, 0): the motor
    must add l cos(q) F (moment arm about x of the point (0, l cos q, l sin q))."""
    m, l, F, q = 2.0, 0.5, 40.0, 0.6
    robot = pendulum(m=m, l=l)
    fe = np.array([0.0, 0.0, -F, 0.0, 0.0, 0.0])
    for mode in MODES:
        on_axis = achievable_accelerations(robot, [q], [0.0], [0.0], f_ext=fe, mode=mode)
        at_com = achievable_accelerations(robot, [q], [0.0], [0.0], f_ext=fe,
                                          f_ext_point=[0.0, l, 0.0], mode=mode)
        hold = m * G0 * l * math.cos(q)
        assert on_axis.tau_required[0] == pytest.approx(hold, rel=1e-12)
        assert at_com.tau_required[0] == pytest.approx(hold - l * math.cos(q) * F, rel=1e-12)


# --- hand-solvable cases --------------------------------------------------------------------------
PEND = {"m": 2.0, "l": 0.5, "Ic": 0.01}
PEND_ACT = {"gear_ratio": 50.0, "rotor_inertia": 2e-5, "viscous_friction": 0.3,
            "coulomb_friction": 0.8}


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize(("qd", "qdd_des", "limit"), [
    (1.2, 20.0, 5.0),  # saturates upwards
    (1.2, -40.0, 5.0),  # saturates downwards
    (-0.7, 30.0, 4.0),  # moving the other way
    (1.2, 2.0, 50.0),  # within the limit: qdd = qdd_des
])
def test_pendulum_closed_form(mode, qd, qdd_des, limit):
    """qdd = (+-limit - m g l cos q - F_v qd - F_s sign qd) / (m l^2 + I_c + G^2 J_m)."""
    m, l, Ic = PEND["m"], PEND["l"], PEND["Ic"]
    G, Jm, Fv, Fs = (PEND_ACT[k] for k in ("gear_ratio", "rotor_inertia", "viscous_friction",
                                          "coulomb_friction"))
    robot = pendulum(**PEND, effort_limit=limit, **PEND_ACT)
    q = 0.3
    H = m * l**2 + Ic + G**2 * Jm
    bias = m * G0 * l * math.cos(q) + Fv * qd + Fs * math.copysign(1.0, qd)
    req = H * qdd_des + bias
    tau = min(max(req, -limit), limit)
    res = achievable_accelerations(robot, [q], [qd], [qdd_des], mode=mode)
    assert res.tau_required[0] == pytest.approx(req, rel=1e-12)
    assert res.tau[0] == pytest.approx(tau, rel=1e-12)
    assert res.qdd[0] == pytest.approx((tau - bias) / H, rel=1e-12, abs=1e-12)
    assert res.tau_motor[0] == pytest.approx(tau / G, rel=1e-12)
    assert bool(res.saturated[0]) == (abs(req) > limit)


@pytest.mark.parametrize("mode", MODES)
def test_slider_closed_form(mode):
    """Vertical prismatic joint: qdd = (+-limit - m g - F_v qd - F_s sign qd) / (m + G^2 J_m)."""
    m, G, Jm, Fv, Fs, limit = 3.0, 12.0, 1e-3, 20.0, 5.0, 60.0
    robot = slider(m=m, gear_ratio=G, rotor_inertia=Jm, viscous_friction=Fv,
                   coulomb_friction=Fs, effort_limit=limit)
    q, qd, qdd_des = 0.2, -0.4, 25.0
    H, bias = m + G**2 * Jm, m * G0 + Fv * qd - Fs
    res = achievable_accelerations(robot, [q], [qd], [qdd_des], mode=mode)
    assert res.tau_required[0] == pytest.approx(H * qdd_des + bias, rel=1e-12)
    assert res.tau[0] == limit and res.saturated[0]
    assert res.qdd[0] == pytest.approx((limit - bias) / H, rel=1e-12)


@given(
    m=st.floats(0.1, 20.0), l=st.floats(0.05, 2.0), Ic=st.floats(1e-4, 0.5),
    G=st.floats(1.0, 200.0), Jm=st.floats(0.0, 1e-3), Fv=st.floats(0.0, 10.0),
    Fs=st.floats(0.0, 10.0), q=st.floats(-math.pi, math.pi),
    qd=st.floats(0.01, 10.0) | st.floats(-10.0, -0.01), qdd_des=st.floats(-100.0, 100.0),
    limit=st.floats(0.0, 300.0),
)
def test_pendulum_closed_form_fuzz(m, l, Ic, G, Jm, Fv, Fs, q, qd, qdd_des, limit):
    robot = pendulum(m=m, l=l, Ic=Ic, gear_ratio=G, rotor_inertia=Jm, viscous_friction=Fv,
                     coulomb_friction=Fs, effort_limit=limit)
    H = m * l**2 + Ic + G**2 * Jm
    bias = m * G0 * l * math.cos(q) + Fv * qd + Fs * math.copysign(1.0, qd)
    req = H * qdd_des + bias
    tau = min(max(req, -limit), limit)
    for mode in MODES:
        res = achievable_accelerations(robot, [q], [qd], [qdd_des], mode=mode)
        scale = max(1.0, abs(req), abs(bias))
        assert abs(res.tau_required[0] - req) <= 1e-12 * scale
        assert abs(res.tau[0] - tau) <= 1e-12 * scale
        assert abs(res.qdd[0] - (tau - bias) / H) <= 1e-12 * scale / H


Q2 = (0.4, 1.1)
ARM = (30.0**2 * 1e-4, 20.0**2 * 5e-5)


@pytest.mark.parametrize("mode", MODES)
def test_two_link_mass_matrix_by_hand(mode):
    """The hand-derived H_a reproduces the required efforts at rest without gravity (u'_a = 0)."""
    H = two_link_H(Q2[1], ARM)
    robot = two_link()
    qdd = np.array([1.3, -0.7])
    res = achievable_accelerations(robot, Q2, [0.0, 0.0], qdd, mode=mode)
    assert rel_err(res.tau_required, H @ qdd) <= 1e-12
    Ha, ua = actuator_mass_matrix_and_bias(robot, Q2, [0.0, 0.0])
    assert rel_err(Ha, H) <= 1e-12 and rel_err(ua, [0.0, 0.0]) <= 1e-15


def test_two_link_paper_and_hybrid_differ():
    """Joint 1 saturates (limit 0.4 |tau_req1|), joint 2 is unlimited.
    paper:  qdd = solve(H, clip(H qdd_des)) -- joint 2 keeps its required effort.
    hybrid: joint 2 keeps qdd_des_2; row 1, H11 qdd1 + H12 qdd_des_2 = +-L1, gives qdd1."""
    H = two_link_H(Q2[1], ARM)
    qdd_des = np.array([8.0, -3.0])
    req = H @ qdd_des
    L1 = 0.4 * abs(req[0])
    robot = two_link(effort=(L1, math.inf))
    lim = np.array([L1, math.inf])
    paper_qdd = np.linalg.solve(H, np.clip(req, -lim, lim))
    hyb_qdd1 = (math.copysign(L1, req[0]) - H[0, 1] * qdd_des[1]) / H[0, 0]
    hyb_qdd = np.array([hyb_qdd1, qdd_des[1]])
    hyb_tau = H @ hyb_qdd

    paper = achievable_accelerations(robot, Q2, [0.0, 0.0], qdd_des, mode="paper")
    hybrid = achievable_accelerations(robot, Q2, [0.0, 0.0], qdd_des, mode="hybrid")
    assert rel_err(paper.qdd, paper_qdd) <= 1e-12
    assert rel_err(paper.tau, [math.copysign(L1, req[0]), req[1]]) <= 1e-12
    assert rel_err(hybrid.qdd, hyb_qdd) <= 1e-12
    assert hybrid.qdd[1] == qdd_des[1]
    assert rel_err(hybrid.tau, hyb_tau) <= 1e-12
    np.testing.assert_array_equal(paper.saturated, [True, False])
    np.testing.assert_array_equal(hybrid.saturated, [True, False])
    assert np.abs(paper.qdd - hybrid.qdd).max() > 0.5  # the two models really differ here


def test_two_link_hybrid_saturation_cascades():
    """Saturating joint 1 raises the effort joint 2 needs for qdd_des_2 above L2, which lies
    between |tau_req2| and that effort: joint 2 saturates too, and qdd = solve(H, [+-L1, +-L2]).
    "paper" only clips the required efforts, so joint 2 gets its required effort there."""
    H = two_link_H(Q2[1], ARM)
    qdd_des = np.array([8.0, -20.0])
    req = H @ qdd_des
    L1 = 0.4 * abs(req[0])
    qdd1 = (math.copysign(L1, req[0]) - H[0, 1] * qdd_des[1]) / H[0, 0]
    tau2 = H[1, 0] * qdd1 + H[1, 1] * qdd_des[1]
    assert abs(tau2) > 1.2 * abs(req[1])  # the case is built that way
    L2 = 0.5 * (abs(tau2) + abs(req[1]))
    robot = two_link(effort=(L1, L2))
    expect = np.linalg.solve(H, [math.copysign(L1, req[0]), math.copysign(L2, tau2)])
    res = achievable_accelerations(robot, Q2, [0.0, 0.0], qdd_des, mode="hybrid")
    assert rel_err(res.qdd, expect) <= 1e-12
    np.testing.assert_array_equal(res.saturated, [True, True])
    np.testing.assert_array_equal(res.tau, [math.copysign(L1, req[0]), math.copysign(L2, tau2)])
    paper = achievable_accelerations(robot, Q2, [0.0, 0.0], qdd_des, mode="paper")
    assert rel_err(paper.qdd, np.linalg.solve(H, [math.copysign(L1, req[0]), req[1]])) <= 1e-12
    np.testing.assert_array_equal(paper.saturated, [True, False])


# --- actuator convention --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["puma", "chain5", "chain8"])
def test_actuator_convention(name):
    """tau = ID + G^2 J_m qdd + F_v qd + F_s sign(qd) (sign(0) = 0), H_a = H + diag(G^2 J_m),
    u'_a = u' + F_v qd + F_s sign(qd), motor torque = tau / G; single states and a batch."""
    robot = ROBOTS[name]
    rng = np.random.default_rng(11)
    B, n = 6, robot.n
    Q = rng.uniform(-np.pi, np.pi, (B, n)) * np.where(robot.is_prismatic, 0.1, 1.0)
    QD = rng.normal(0.0, 1.5, (B, n))
    QD[rng.random((B, n)) < 0.3] = 0.0  # joints at rest: no Coulomb term
    QDD = rng.normal(0.0, 5.0, (B, n))
    FE = rng.normal(0.0, 20.0, (B, 6))
    tau = actuator_efforts(robot, Q, QD, QDD, FE)
    expect = inverse_dynamics(robot, Q, QD, QDD, FE) + actuator_terms(robot, QD, QDD)
    assert tau.shape == (B, n)
    for b in range(B):
        assert rel_err(tau[b], expect[b]) <= 1e-12
        assert rel_err(actuator_efforts(robot, Q[b], QD[b], QDD[b], FE[b]), expect[b]) <= 1e-12
        assert rel_err(tau[b], pin_ref(name).efforts(Q[b], QD[b], QDD[b], FE[b])) <= TOL
    Ha, ua = actuator_mass_matrix_and_bias(robot, Q, QD, FE)
    H, u = mass_matrix_and_bias(robot, Q, QD, FE)
    np.testing.assert_array_equal(Ha, H + np.diag(armature(robot)))
    np.testing.assert_allclose(ua, u + robot.viscous_friction * QD
                               + coulomb(robot, QD), rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(motor_torque(robot, tau, QD), tau / robot.gear_ratio, rtol=0, atol=0)
    res = achievable_accelerations(robot, Q, QD, QDD, FE)
    np.testing.assert_array_equal(res.tau_motor, res.tau / robot.gear_ratio)


# --- Coulomb friction at rest ---------------------------------------------------------------------
FS = 3.0
FLAT = {"axis": (0.0, 0.0, 1.0)}  # the pendulum turns about the vertical: no gravity torque
H_FLAT = PEND["m"] * PEND["l"] ** 2 + PEND["Ic"]


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize(("limit", "qdd_des", "tau", "qdd"), [
    # no motion asked: static friction holds, nothing is required
    (0.0, 0.0, 0.0, 0.0),
    # motion asked, motor off (limit 0): the joint stays at rest
    (0.0, 4.0, 0.0, 0.0),
    # the motor gives 1 N m < F_s: static friction still holds it
    (1.0, 4.0, 1.0, 0.0),
    (1.0, -4.0, -1.0, 0.0),
    # 5 N m > F_s: it breaks away, sliding friction F_s opposes the motion
    (5.0, 20.0, 5.0, (5.0 - FS) / H_FLAT),
    (5.0, -20.0, -5.0, (-5.0 + FS) / H_FLAT),
])
def test_coulomb_at_rest_without_gravity_torque(mode, limit, qdd_des, tau, qdd):
    robot = pendulum(**PEND, **FLAT, coulomb_friction=FS, effort_limit=limit)
    res = achievable_accelerations(robot, [0.7], [0.0], [qdd_des], mode=mode)
    req = H_FLAT * qdd_des + FS * np.sign(qdd_des)  # breakaway F_s sign(qdd_des)
    assert res.tau_required[0] == pytest.approx(req, rel=1e-12)
    assert res.tau[0] == pytest.approx(tau, rel=1e-12, abs=1e-15)
    assert res.qdd[0] == pytest.approx(qdd, rel=1e-12, abs=1e-15)
    assert bool(res.saturated[0]) == (abs(req) > limit)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("qdd_des", [4.0, -4.0])
def test_coulomb_breakaway_is_paid_in_tau_required(mode, qdd_des):
    robot = pendulum(**PEND, **FLAT, coulomb_friction=FS)
    res = achievable_accelerations(robot, [0.0], [0.0], [qdd_des], mode=mode)
    assert res.tau_required[0] == pytest.approx(H_FLAT * qdd_des + math.copysign(FS, qdd_des),
                                                rel=1e-12)
    assert res.qdd[0] == pytest.approx(qdd_des, rel=1e-12)
    assert res.tau[0] == res.tau_required[0]


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("q", [0.3, 2.5])  # gravity pulls towards -q, then towards +q
def test_coulomb_at_rest_with_gravity(mode, q):
    """Holding effort hold = m g l cos q. Motor off (limit 0): with F_s > |hold| the joint stays
    at rest; with F_s < |hold| it slips, qdd = (-hold + F_s sign(hold)) / H. A joint asked to
    stay (qdd_des = 0) needs hold - F_s sign(hold) when |hold| > F_s, else nothing; asked to move
    it needs H qdd_des + hold + F_s sign(qdd_des)."""
    m, l, Ic = PEND["m"], PEND["l"], PEND["Ic"]
    H = m * l**2 + Ic
    hold = m * G0 * l * math.cos(q)
    s = math.copysign(1.0, hold)
    # motor off, friction strong enough: stays
    res = achievable_accelerations(pendulum(**PEND, coulomb_friction=1.5 * abs(hold),
                                            effort_limit=0.0), [q], [0.0], [2.0], mode=mode)
    assert res.qdd[0] == 0.0 and res.tau[0] == 0.0
    # motor off, friction too weak: slips with friction F_s opposing the motion
    Fs = 0.4 * abs(hold)
    res = achievable_accelerations(pendulum(**PEND, coulomb_friction=Fs, effort_limit=0.0),
                                   [q], [0.0], [0.0], mode=mode)
    assert res.qdd[0] == pytest.approx((-hold + Fs * s) / H, rel=1e-12)
    assert res.tau[0] == 0.0 and res.saturated[0]
    # ask to stay, generous motor: friction takes F_s of the load, the motor the rest
    robot = pendulum(**PEND, coulomb_friction=Fs, effort_limit=100.0)
    res = achievable_accelerations(robot, [q], [0.0], [0.0], mode=mode)
    assert res.tau_required[0] == pytest.approx(hold - Fs * s, rel=1e-12)
    assert res.tau[0] == pytest.approx(hold - Fs * s, rel=1e-12) and res.qdd[0] == 0.0
    # ... and with F_s > |hold| nothing at all
    res = achievable_accelerations(pendulum(**PEND, coulomb_friction=1.5 * abs(hold),
                                            effort_limit=100.0), [q], [0.0], [0.0], mode=mode)
    assert res.tau_required[0] == 0.0 and res.qdd[0] == 0.0
    # ask to move: breakaway friction in the direction of qdd_des
    for qdd_des in (3.0, -3.0):
        res = achievable_accelerations(robot, [q], [0.0], [qdd_des], mode=mode)
        expect = H * qdd_des + hold + math.copysign(Fs, qdd_des)
        assert res.tau_required[0] == pytest.approx(expect, rel=1e-12)
        assert res.qdd[0] == pytest.approx(qdd_des, rel=1e-12)
    # a limited motor (below the net need but above hold - F_s): holds up to the limit,
    # the rest is friction
    lim = abs(hold) - 0.5 * Fs
    res = achievable_accelerations(pendulum(**PEND, coulomb_friction=Fs, effort_limit=lim),
                                   [q], [0.0], [5.0 * s], mode=mode)
    assert res.qdd[0] == 0.0 and res.tau[0] == pytest.approx(lim * s, rel=1e-12)


def arm_with_friction(fs, effort=(math.inf, math.inf)):
    """The planar 2-link arm with Coulomb friction fs [N m] per joint (no rotor inertia)."""
    robot = two_link(gear=(1.0, 1.0), jm=(0.0, 0.0), effort=effort)
    return robot.with_actuators(coulomb_friction=fs)


@pytest.mark.parametrize("mode", [
    "hybrid",
    "paper",
])
def test_generous_limits_at_rest_change_nothing(mode):
    """At rest with Coulomb friction and no effort limit, tau_required = H qdd_des +
    F_s sign(qdd_des) is exactly the effort that produces qdd_des, so both modes return it."""
    robot = arm_with_friction((1.0, 1.0))
    qdd_des = np.array([8.0, -0.5])
    H = two_link_H(Q2[1])
    req = H @ qdd_des + np.sign(qdd_des) * 1.0
    res = achievable_accelerations(robot, Q2, [0.0, 0.0], qdd_des, mode=mode)
    assert rel_err(res.tau_required, req) <= 1e-12
    assert not res.saturated.any()
    assert rel_err(res.qdd, qdd_des) <= 1e-12


@pytest.mark.parametrize("mode", MODES)
def test_sliding_friction_opposes_the_resulting_motion(mode):
    """Coulomb friction at rest, two coupled joints, both motors saturated: each joint either
    stays (qdd_i = 0, friction needed <= F_s) or slides with friction F_s against its motion:
    H qdd - tau = -F_s sign(qdd) (no velocity, no gravity)."""
    fs = np.array([0.2, 2.6])
    robot = arm_with_friction(fs, effort=(5.2, 5.3))
    res = achievable_accelerations(robot, Q2, [0.0, 0.0], [-10.0, -2.5], mode=mode)
    assert res.saturated.any()
    net = two_link_H(Q2[1]) @ res.qdd - res.tau
    for i in range(2):
        if abs(res.qdd[i]) < 1e-9:
            assert abs(net[i]) <= fs[i] * (1 + 1e-12)
        else:
            assert net[i] == pytest.approx(-fs[i] * np.sign(res.qdd[i]), abs=1e-9)


@pytest.mark.parametrize("name", ["puma", "chain5"])
def test_at_rest_breakaway_against_pinocchio(name):
    """Hybrid mode at rest, generous limits, every joint asked to move: tau_required =
    rnea(q, 0, qdd_des) + G^2 J_m qdd_des + F_s sign(qdd_des) and qdd = qdd_des."""
    robot, ref = ROBOTS[name].with_actuators(effort_limit=1e6), pin_ref(name)
    rng = np.random.default_rng(14)
    n = robot.n
    for _ in range(5):
        q, _, qdd_des = random_moving_state(rng, robot)
        qd = np.zeros(n)
        expect = ref.efforts(q, qd, qdd_des) + coulomb(robot, qdd_des)
        res = achievable_accelerations(robot, q, qd, qdd_des, mode="hybrid")
        assert rel_err(res.tau_required, expect) <= TOL
        np.testing.assert_array_equal(res.qdd, qdd_des)
        np.testing.assert_array_equal(res.tau, res.tau_required)


# --- torque-speed curve ---------------------------------------------------------------------------
CURVE = (10.0, 1.0, 3.0)  # peak 10 N m up to 1 rad/s, zero from 3 rad/s
# worked out by hand: 10 below the corner; min(10 * 1 / w, 10 * (3 - w) / 2) above it
CURVE_POINTS = [(0.0, 10.0), (0.5, 10.0), (1.0, 10.0), (1.5, 10.0 / 1.5), (2.0, 5.0),
                (2.5, 2.5), (2.9, 0.5), (3.0, 0.0), (4.0, 0.0), (1e6, 0.0)]


def test_torque_speed_curve_values():
    robot = pendulum(**PEND, torque_speed=CURVE)
    assert robot.effort_limit[0] == 10.0 and robot.torque_speed == (CURVE,)
    for w, expect in CURVE_POINTS:
        for sign in (1.0, -1.0):
            assert effort_limits_at(robot, [sign * w])[0] == pytest.approx(expect, rel=1e-14)
    W = np.array([[w] for w, _ in CURVE_POINTS])
    np.testing.assert_allclose(effort_limits_at(robot, -W), [[e] for _, e in CURVE_POINTS],
                               rtol=1e-14)
    # just above the corner it is the constant-power branch, near no-load the straight line
    assert effort_limits_at(robot, [1.001])[0] == pytest.approx(10.0 / 1.001, rel=1e-14)
    assert effort_limits_at(robot, [2.99])[0] == pytest.approx(10.0 * 0.01 / 2.0, rel=1e-12)


def test_torque_speed_curve_mixed_joints_and_batch():
    robot = two_link(effort=(math.inf, 7.0)).with_actuators(torque_speed=[(8.0, 2.0, 5.0), None])
    assert robot.torque_speed == ((8.0, 2.0, 5.0), None)
    qd = np.array([[0.0, 0.0], [3.0, 50.0], [-4.5, -1.0]])
    expect = np.array([[8.0, 7.0], [8.0 * 2.0 / 3.0, 7.0], [8.0 * 0.5 / 3.0, 7.0]])
    np.testing.assert_allclose(effort_limits_at(robot, qd), expect, rtol=1e-14)
    # effort_limit=... removes the curve
    flat = robot.with_actuators(effort_limit=6.0)
    assert flat.torque_speed == (None, None)
    np.testing.assert_array_equal(effort_limits_at(flat, qd), np.full((3, 2), 6.0))


def test_one_torque_speed_triple_for_a_three_joint_robot():
    robot = random_chain(np.random.default_rng(15), 3)
    assert robot.with_actuators(torque_speed=CURVE).torque_speed == (CURVE,) * 3


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("qd", [0.5, 1.5, -2.5, 3.5])
def test_limit_is_taken_at_the_current_speed(mode, qd):
    m, l, Ic = PEND["m"], PEND["l"], PEND["Ic"]
    robot = pendulum(**PEND, torque_speed=CURVE)
    lim = dict(CURVE_POINTS).get(abs(qd), 0.0)
    q, qdd_des = 0.2, 80.0
    res = achievable_accelerations(robot, [q], [qd], [qdd_des], mode=mode)
    assert res.limit[0] == pytest.approx(lim, rel=1e-14)
    H, hold = m * l**2 + Ic, m * G0 * l * math.cos(q)
    assert res.tau[0] == pytest.approx(lim, rel=1e-14) and res.saturated[0]
    assert res.qdd[0] == pytest.approx((lim - hold) / H, rel=1e-12)


# --- achievable_step ------------------------------------------------------------------------------
def limited_two_link():
    joints = [
        Joint("j1", "revolute", "base", "l1", axis=(0, 0, 1), lower=-1.0, upper=1.0,
              velocity_limit=2.0),
        Joint("j2", "revolute", "l1", "l2", origin=transform((L1, 0, 0)), axis=(0, 0, 1),
              lower=-2.0, upper=2.0, velocity_limit=3.0),
    ]
    links = [Link("l1", M1, (LC1, 0, 0), np.diag([0.01, 0.01, I1])),
             Link("l2", M2, (LC2, 0, 0), np.diag([0.01, 0.01, I2]))]
    return Robot(joints, links, gravity=(0.0, 0.0, 0.0))


DT = 0.004


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize(("q", "q_cmd", "qd_cmd", "qd_exp", "pos", "vel"), [
    # inside every limit: nothing changes
    ((0.05, 0.1), (0.1, 0.2), (0.5, -0.4), (0.5, -0.4), (False, False), (False, False)),
    # velocity over the limit: clamped to +-velocity_limit
    ((0.05, 0.1), (0.1, 0.2), (5.0, -4.0), (2.0, -3.0), (False, False), (True, True)),
    # past the upper / lower limit but far from it: the limit cannot be reached within dt,
    # the velocity is kept
    ((0.05, 0.1), (1.5, -2.5), (0.5, -0.4), (0.5, -0.4), (True, True), (False, False)),
    # past the limits, 1 mrad away from them: slowed to reach the limit at the end of the cycle,
    # (1 - 0.999) / 0.004 = 0.25 rad/s and (-2 + 1.999) / 0.004 = -0.25 rad/s
    ((0.999, -1.999), (1.5, -2.5), (0.5, -0.4), (0.25, -0.25), (True, True), (False, False)),
    # ... unless heading back in, which is kept
    ((0.999, -1.999), (1.5, -2.5), (-0.5, 0.4), (-0.5, 0.4), (True, True), (False, False)),
    # both at once: 9 -> 2 rad/s (velocity limit) -> 0.25 rad/s (position limit); 9 -> 3 rad/s
    ((0.999, 0.0), (1.2, 0.0), (9.0, 9.0), (0.25, 3.0), (True, False), (True, True)),
])
def test_step_clamps_the_command(mode, q, q_cmd, qd_cmd, qd_exp, pos, vel):
    robot = limited_two_link()
    q, qd = np.array(q), np.array([0.3, -0.2])
    res = achievable_step(robot, q, qd, q_cmd, qd_cmd, DT, mode=mode)
    assert isinstance(res, StepResult) and isinstance(res, AchievableResult)
    np.testing.assert_array_equal(res.q_cmd, np.clip(q_cmd, [-1.0, -2.0], [1.0, 2.0]))
    np.testing.assert_allclose(res.qd_cmd, qd_exp, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(res.position_clamped, pos)
    np.testing.assert_array_equal(res.velocity_clamped, vel)
    np.testing.assert_allclose(res.qdd_des, (np.array(qd_exp) - qd) / DT, rtol=1e-12)
    # generous efforts: the clamped command is followed, and a joint slowed at a position
    # limit ends the cycle on it
    assert res.achievable
    np.testing.assert_allclose(res.qd_next, qd_exp, rtol=0, atol=1e-9)
    lim = np.where(np.array(q_cmd) > 0, 1.0, -1.0) * np.array([1.0, 2.0])
    slowed = np.array(pos) & (np.abs(np.array(qd_exp)) < np.abs(np.array(qd_cmd)))
    np.testing.assert_allclose(res.q_next[slowed], lim[slowed], rtol=0, atol=1e-12)
    assert np.all((res.q_next >= -np.array([1.0, 2.0]) - 1e-12)
                  & (res.q_next <= np.array([1.0, 2.0]) + 1e-12))


@pytest.mark.parametrize("mode", MODES)
def test_step_advances_like_a_speed_controlled_drive(mode):
    """The achievable accelerations are those of achievable_accelerations at qdd_des; the
    velocity changes to qd' = qd + qdd dt and is held over the cycle: q' = q + qd' dt
    (here with joint 1 saturated)."""
    robot = two_link(effort=(2.0, math.inf))
    q, qd, dt = np.array([0.4, 1.1]), np.array([0.8, -0.5]), 0.01
    q_cmd, qd_cmd = q + 0.01, np.array([1.5, -0.6])
    args = (q.copy(), qd.copy(), q_cmd.copy(), qd_cmd.copy())
    res = achievable_step(robot, q, qd, q_cmd, qd_cmd, dt, mode=mode)
    for a, b in zip(args, (q, qd, q_cmd, qd_cmd), strict=True):  # the caller's arrays
        np.testing.assert_array_equal(a, b)
    qdd_des = (qd_cmd - qd) / dt
    np.testing.assert_allclose(res.qdd_des, qdd_des, rtol=1e-14)
    ref = achievable_accelerations(robot, q, qd, res.qdd_des, mode=mode)
    np.testing.assert_array_equal(res.qdd, ref.qdd)
    np.testing.assert_array_equal(res.tau, ref.tau)
    np.testing.assert_array_equal(res.saturated, ref.saturated)
    assert res.saturated[0] and not res.achievable
    np.testing.assert_allclose(res.qd_next, qd + res.qdd * dt, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(res.q_next, q + res.qd_next * dt, rtol=1e-15, atol=1e-15)
    assert res.qd_next[0] < qd_cmd[0]  # the saturated joint falls behind the command


def test_step_reproduces_a_feasible_command():
    """qd_cmd = (q_cmd - q) / dt within every limit: q' = q_cmd and qd' = qd_cmd."""
    robot = ROBOTS["puma"]
    rng = np.random.default_rng(13)
    q, qd, dt = rng.uniform(-0.5, 0.5, 6), rng.normal(0.0, 0.5, 6), 0.005
    qd_cmd = qd + rng.normal(0.0, 0.05, 6)
    q_cmd = q + qd_cmd * dt
    for mode in MODES:
        res = achievable_step(robot, q, qd, q_cmd, qd_cmd, dt, mode=mode)
        assert res.achievable and not res.position_clamped.any()
        np.testing.assert_allclose(res.qd_next, qd_cmd, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.q_next, q_cmd, rtol=0, atol=1e-14)


def test_step_position_clamp_respects_the_velocity_limit():
    robot = limited_two_link()
    res = achievable_step(robot, [1.5, 0.1], [0.0, 0.0], [1.2, 0.1], [0.0, 0.0], DT)
    assert np.all(np.abs(res.qd_cmd) <= robot.velocity_limit * (1 + 1e-12))
    assert np.all(np.abs(res.qd_next) <= robot.velocity_limit * (1 + 1e-12))


@pytest.mark.parametrize("dt", [0.0, -0.01, math.nan, math.inf, "x", None])
def test_step_rejects_bad_dt(dt):
    robot = limited_two_link()
    with pytest.raises(StateError, match="dt"):
        achievable_step(robot, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], dt)


def test_step_rejects_batches_and_nan():
    robot = limited_two_link()
    z = np.zeros(2)
    with pytest.raises(StateError):
        achievable_step(robot, np.zeros((3, 2)), z, z, z, 0.01)
    with pytest.raises(StateError, match="qd_next_cmd"):
        achievable_step(robot, z, z, z, [0.0, math.nan], 0.01)
    with pytest.raises(StateError, match="mode"):
        achievable_step(robot, z, z, z, z, 0.01, mode="exact")


# --- batches and errors ---------------------------------------------------------------------------
@pytest.mark.parametrize("mode", MODES)
def test_batch_equals_loop(mode):
    base = ROBOTS["puma"]
    robot = base.with_actuators(effort_limit=0.3 * base.effort_limit)
    rng = np.random.default_rng(12)
    B, n = 16, robot.n
    Q = rng.uniform(-np.pi, np.pi, (B, n))
    QD = rng.normal(0.0, 1.0, (B, n))
    QD[rng.random((B, n)) < 0.3] = 0.0  # some joints at rest
    QDD = rng.normal(0.0, 20.0, (B, n))
    FE = rng.normal(0.0, 20.0, (B, 6))
    PE = rng.normal(0.0, 0.1, (B, 3))
    res = achievable_accelerations(robot, Q, QD, QDD, f_ext=FE, f_ext_point=PE, mode=mode)
    fields = ("qdd", "tau", "tau_motor", "tau_required", "saturated", "margin", "limit")
    for f in fields:
        assert getattr(res, f).shape == (B, n), f
    assert res.saturated.any()
    for b in range(B):
        one = achievable_accelerations(robot, Q[b], QD[b], QDD[b], f_ext=FE[b],
                                       f_ext_point=PE[b], mode=mode)
        for f in fields:
            assert getattr(one, f).shape == (n,)
            np.testing.assert_array_equal(getattr(res, f)[b], getattr(one, f), err_msg=f)
    # broadcasting a single q against a batch of qd
    bq = achievable_accelerations(robot, Q[0], QD, QDD, mode=mode)
    one = achievable_accelerations(robot, Q[0], QD[3], QDD[3], mode=mode)
    np.testing.assert_array_equal(bq.qdd[3], one.qdd)


@pytest.mark.parametrize("mode", ["Paper", "exact", "", None, 1])
def test_bad_mode(mode):
    robot = ROBOTS["puma"]
    with pytest.raises(StateError, match="mode"):
        achievable_accelerations(robot, np.zeros(6), np.zeros(6), np.zeros(6), mode=mode)


@pytest.mark.parametrize("batched", [False, True])
@pytest.mark.parametrize("as_list", [False, True])
def test_nan_in_qdd_des_is_named(batched, as_list):
    robot = ROBOTS["puma"]
    qdd = np.zeros((3, 6) if batched else 6)
    qdd[..., 2] = math.nan
    z = np.zeros_like(qdd)
    qdd = qdd.tolist() if as_list else qdd
    for mode in MODES:
        with pytest.raises(StateError, match="qdd_des"):
            achievable_accelerations(robot, z, z, qdd, mode=mode)
