"""The cycle's drive law against MuJoCo (4.x) with the same actuator model (tests/mjcf.py),
through the public API.

(i)   PAPER mode = torque-controlled drives: MuJoCo motors with forcerange +-L/G, fed the
      program's requirement from MuJoCo's own mj_inverse; ``achievable_accelerations`` equals
      mj_forward's qacc, and ``simulate`` equals MuJoCo stepped cycle by cycle (Euler, eulerdamp
      disabled: damping explicit, as in mrnea).
(ii)  HYBRID mode = the limit of a stiff velocity loop: MuJoCo velocity actuators of joint-side
      gain K, forcerange +-L, implicitfast, one mj_step, against ``achievable_step``. Tolerance
      derived below from the gain.
(iii) Coulomb friction: MuJoCo's frictionloss made a hard constraint (solref, solimp, noslip set
      as explained below) against the set-valued friction of ``achievable_step``, PAPER mode,
      joints stuck and slipping.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import random_chain
from drive_oracle import cycle_terms, rel, torque_speed
from mjcf import to_mjcf

from mrnea import Joint, Link, Robot, transform
from mrnea.achievable import achievable_accelerations, achievable_step
from mrnea.simulate import simulate


def _model(xml: str):
    m = mujoco.MjModel.from_xml_string(xml)
    return m, mujoco.MjData(m)


def chain(rng: np.random.Generator, n: int, viscous: bool) -> Robot:
    """A random chain with random gears, rotors and (``viscous``) viscous friction."""
    return random_chain(rng, n, 0.25).with_actuators(
        gear_ratio=rng.choice([1.0, 10.0, 50.0], n), rotor_inertia=rng.choice([0.0, 1e-5, 1e-4], n),
        viscous_friction=rng.uniform(0.0, 2.0, n) if viscous else 0.0)


def _limits(rng, n, qd, scale):
    """Speed-dependent limits: a torque-speed curve at |qd| with peak ~ the effort scale."""
    peak = scale * rng.uniform(0.2, 1.5, n) + 0.05
    corner = rng.uniform(0.3, 1.0, n)
    return torque_speed(peak, corner, corner + rng.uniform(0.5, 3.0, n), qd)


# --- (i) PAPER: motors, mj_forward and stepping -----------------------------------------------
@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_paper_mode_equals_mujoco_qacc(n):
    rng = np.random.default_rng(300 + n)
    dt = 2e-3
    for s in range(60):
        robot = chain(rng, n, viscous=True)
        G = robot.gear_ratio
        m, d = _model(to_mjcf(robot, "motor", L=np.ones(n), timestep=dt))
        q, qd = rng.uniform(-np.pi, np.pi, n), rng.normal(0.0, 1.0, n)
        qdd_des = rng.normal(0.0, 5.0, n)
        # the requirement, by MuJoCo: qfrc_inverse at qacc = qdd_des
        d.qpos[:], d.qvel[:], d.qacc[:] = q, qd, qdd_des
        mujoco.mj_inverse(m, d)
        need = d.qfrc_inverse.copy()
        L = _limits(rng, n, qd, np.abs(need))
        m.actuator_forcerange[:] = np.c_[-L / G, L / G]  # MuJoCo clamps (Eq. 44's clip)
        d.ctrl[:] = need / G
        mujoco.mj_forward(m, d)
        res = achievable_accelerations(robot.with_actuators(effort_limit=L), q, qd, qdd_des,
                                       mode="paper")
        where = f"n={n} state {s}"
        assert rel(res.tau_required, need) < 1e-10, f"{where}: tau_req"
        assert rel(res.tau, G * d.actuator_force) < 1e-10, f"{where}: tau"
        assert rel(res.qdd, d.qacc) < 1e-10, f"{where}: qdd {res.qdd} vs {d.qacc}"
        assert np.array_equal(res.saturated, np.abs(need) > L)


@pytest.mark.parametrize("n", [2, 4, 6])
def test_paper_mode_simulation_steps_like_mujoco_euler(n):
    """300 cycles of a program that saturates the drives at times (torque-speed curves): MuJoCo's
    semi-implicit Euler (eulerdamp off) and ``simulate(mode="paper")`` give the same states."""
    rng = np.random.default_rng(400 + n)
    dt, K = 2e-3, 300
    peak = rng.uniform(5.0, 30.0, n)
    robot = chain(rng, n, viscous=True).with_actuators(
        torque_speed=[(p, 1.0, 4.0) for p in peak])
    G = robot.gear_ratio
    m, d = _model(to_mjcf(robot, "motor", L=np.ones(n), timestep=dt))
    t = np.arange(K + 1) * dt
    q_cmd = rng.uniform(-1, 1, n) + rng.uniform(0.5, 1.5, n) * np.sin(
        np.outer(t, rng.uniform(2.0, 6.0, n)))
    res = simulate(robot, q_cmd, dt, mode="paper")
    d.qpos[:], d.qvel[:] = q_cmd[0], 0.0
    for k in range(K):
        assert rel(d.qpos, res.q[k]) < 1e-9, f"cycle {k}: q"
        assert rel(d.qvel, res.qd[k]) < 1e-9, f"cycle {k}: qd"
        v_des = (q_cmd[k + 1] - q_cmd[k]) / dt
        L = torque_speed(peak, 1.0, 4.0, d.qvel)
        d.qacc[:] = (v_des - d.qvel) / dt  # MuJoCo's own requirement, clamped by forcerange
        mujoco.mj_inverse(m, d)
        m.actuator_forcerange[:] = np.c_[-L / G, L / G]
        d.ctrl[:] = d.qfrc_inverse / G
        mujoco.mj_step(m, d)
    assert res.saturated.any(axis=1).sum() > 10  # the drives did saturate


# --- (ii) HYBRID: stiff velocity actuators -----------------------------------------------------
def issue_two_link() -> Robot:
    js = [Joint("j0", "revolute", "base", "l0", axis=(0, 0, 1), effort_limit=8.0),
          Joint("j1", "revolute", "l0", "l1", origin=transform((1, 0, 0)), axis=(0, 0, 1),
                effort_limit=1.0)]
    # MuJoCo needs a positive moment about the link's axis: 1e-9 instead of the issue's 0
    ls = [Link(f"l{i}", mass=1.0, com=(0.5, 0, 0), inertia=np.diag([1e-9, 1 / 12, 1 / 12]))
          for i in range(2)]
    return Robot(js, ls, gravity=(0, 0, 0))


def test_hybrid_issue_example_equals_mujoco_velocity_actuators():
    """Both drives end at their limits, so MuJoCo's clamped actuators give exactly the hybrid
    answer at any gain: qdd = [-8.211, 16.797], tau = [-8, +1]."""
    robot, dt = issue_two_link(), 1e-3
    q, qd, v_des = np.array([0.1, 1.1]), np.zeros(2), np.array([-20.0, 17.0]) * dt
    res = achievable_step(robot, q, qd, q + v_des * dt, v_des, dt)
    for kv in (1e4, 1e8):
        m, d = _model(to_mjcf(robot, "velocity", kv=kv, timestep=dt, integrator="implicitfast"))
        d.qpos[:], d.qvel[:], d.ctrl[:] = q, qd, v_des
        mujoco.mj_step(m, d)
        assert rel(d.qvel, res.qd_next, floor=dt) < 1e-10
        assert rel(d.actuator_force, res.tau) < 1e-12


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_hybrid_equals_stiff_velocity_actuators(n):
    """One implicitfast step with velocity actuators of joint-side gain K = kv G^2.

    MuJoCo clamps each actuator at the *old* velocity (force clamp(K (v_des - qd), +-L)) and
    treats the unclamped ones implicitly (mjd_actuator_vel skips clamped actuators), so its new
    velocity v' solves  H_a (v' - qd) / dt + u'_a = tau',  tau'_i = +-L_i (clamped) or
    K (v_des_i - v'_i) (unclamped). When that is self-consistent (every unclamped
    |K (v_des - v')| <= L, every clamped K (v_des - v') beyond +-L on its side: checked on
    MuJoCo's output alone), v' is the solution of the same problem with each stiff drive
    replaced by a drive of finite gain K. Tolerance the gain implies: with the same saturated set
    S (U the others), subtracting the two systems gives e = v' - v with
        e_U = -tau'_U / K   (|e_U| <= L_U / K),   e_S = -H_SS^-1 H_SU e_U
    (rows S: H_a e / dt = tau'_S - tau_S = 0), so |e| <= |P| L_U / K with P = [I; -H_SS^-1 H_SU].
    Checked at K = 1e6 and 1e9 (the error falls ~1000 x): no tolerance beyond that bound.
    """
    rng = np.random.default_rng(500 + n)
    dt = 1e-3
    compared = 0
    for s in range(150):
        robot = chain(rng, n, viscous=False)  # no damping: implicitfast would make it implicit
        G = robot.gear_ratio
        q, qd = rng.uniform(-np.pi, np.pi, n), rng.normal(0.0, 1.0, n)
        Ha, ua = cycle_terms(robot, q, qd)
        hold = np.abs(ua) + 1.0  # rough effort scale
        far = rng.random(n) < 0.5  # these are asked for large accelerations: they saturate
        L = hold * np.where(far, rng.uniform(0.3, 1.0, n), rng.uniform(2.0, 6.0, n))
        big = rng.choice([-1, 1], n) * rng.uniform(50, 200, n) * hold / np.diag(Ha)
        w = rng.uniform(-1, 1, n)
        limited = robot.with_actuators(effort_limit=L)
        errors = {}
        for K in (1e6, 1e9):  # the others start within L / (2K) of v_des: not clamped
            v_des = np.where(far, qd + dt * big, qd + 0.5 * L / K * w)
            kv = K / G**2
            m, d = _model(to_mjcf(robot, "velocity", L=L, kv=1.0, timestep=dt,
                                  integrator="implicitfast"))
            m.actuator_gainprm[:, 0] = kv  # velocity actuator: gain kv, bias -kv * velocity
            m.actuator_biasprm[:, 2] = -kv
            d.qpos[:], d.qvel[:], d.ctrl[:] = q, qd, G * v_des
            mujoco.mj_step(m, d)
            vm = d.qvel.copy()
            clamped = K * np.abs(v_des - qd) > L
            pull = K * (v_des - vm)  # the finite-gain drive's effort at the new velocity
            consistent = np.all(np.where(clamped, pull * np.sign(v_des - qd) >= L,
                                         np.abs(pull) <= L))
            if not consistent:
                break
            res = achievable_step(limited, q, qd, q + v_des * dt, v_des, dt)
            v, sat = res.qd_next, res.saturated
            assert np.array_equal(sat, clamped), f"n={n} state {s}: saturated set"
            U, Sa = ~sat, sat
            P = np.eye(n)[:, U]
            if Sa.any():
                P[Sa] = -np.linalg.solve(Ha[np.ix_(Sa, Sa)], Ha[np.ix_(Sa, U)])
            bound = np.abs(P) @ (L[U] / K) + 1e-13 * (np.abs(v) + np.abs(qd) + 1.0)
            e = np.abs(vm - v)
            assert np.all(e <= bound), f"n={n} state {s} K={K:g}: {e} > {bound}"
            errors[K] = e.max()
        else:
            compared += 1
            assert errors[1e9] < 1e-2 * errors[1e6] + 1e-13
    assert compared >= 40, compared


# --- (iii) Coulomb friction: hard frictionloss ---------------------------------------------------
NOSLIP = ('integrator="Euler" noslip_iterations="200" noslip_tolerance="1e-15" '
          'tolerance="1e-15" iterations="500"')


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_set_valued_friction_equals_hard_frictionloss(n):
    """PAPER-mode drives and frictionloss F_s per joint; one Euler step.

    MuJoCo's dry friction is a soft constraint: it asks for the reference acceleration
    aref = -B J qvel with B = -solreffriction[1] / dmax (direct form), and regularises the
    force by the impedance d <= dmax = 0.9999. Made hard: solreffriction = (-1, -dmax / dt)
    gives B = 1 / dt, i.e. zero velocity at the end of the step where the joint sticks (the
    same velocity-level law as ours); the noslip pass (Gauss-Seidel sweeps) then solves the
    friction forces without the regularisation. What remains is noslip's own stopping rule (it
    rejects a force update that lowers its cost by less than 1e-10): |v_mujoco - v| < 1e-9
    [rad/s | m/s] (observed on the prototype: 2e-16 for n = 1, up to 2.2e-10 for n = 4).
    With MuJoCo's default solref/solimp a held joint creeps (1e-3 of its free velocity per
    step): that is the softness the set-valued law removes.
    """
    rng = np.random.default_rng(600 + n)
    dt, dmax = 1e-3, 0.9999
    stuck_seen = slip_from_rest = 0  # joints
    for s in range(150):
        robot = chain(rng, n, viscous=True)
        G = robot.gear_ratio
        q, qd = rng.uniform(-np.pi, np.pi, n), rng.normal(0.0, 0.5, n)
        qd[rng.random(n) < 0.5] = 0.0
        Ha, ua = cycle_terms(robot, q, qd)
        F = np.abs(ua) * rng.uniform(0.0, 1.5, n) + 0.1
        v_des = qd + dt * rng.normal(0.0, 5.0, n)
        L = np.abs(Ha @ ((v_des - qd) / dt) + ua) * rng.uniform(0.2, 1.5, n) + 0.1
        res = achievable_step(robot.with_actuators(effort_limit=L, coulomb_friction=F), q, qd,
                              q + v_des * dt, v_des, dt, mode="paper")
        xml = to_mjcf(robot, "motor", L=L, frictionloss=F, solreffriction=(-1.0, -dmax / dt),
                      solimpfriction=(dmax, dmax, 0.001, 0.5, 2), timestep=dt)
        m, d = _model(xml.replace('integrator="Euler"', NOSLIP))
        d.qpos[:], d.qvel[:], d.ctrl[:] = q, qd, res.tau / G
        mujoco.mj_step(m, d)
        assert np.all(np.abs(d.qvel - res.qd_next) < 1e-9), f"n={n} state {s}"
        stuck_seen += int(res.stuck.sum())
        slip_from_rest += int(np.sum((qd == 0) & (res.qd_next != 0)))
    assert stuck_seen > 20 and slip_from_rest > 20, (stuck_seen, slip_from_rest)
