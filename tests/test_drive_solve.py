"""The exact cycle solve (kernels/drive_solve.py) against brute-force enumeration of the
piecewise-linear drive law (tests/drive_oracle.py), and issue 11's first reproducer.

Per joint the law has up to 5 cells (drive below / on / above the program, combined with moving
down / stuck / moving up, where they intersect); every combination is solved with
numpy.linalg.solve and kept if consistent. Exactly one v must be consistent (ties at a boundary
give the same v), and the solver must return it to 1e-9, with H_FF refactorised at every active-set
step and with its factor updated (the path of long chains, forced here). 3050 random states, n =
2..6: H_a and u'_a from random chains (gravity, Coriolis, a wrench, rotors) or random SPD matrices
with condition numbers up to 1e6; speed-dependent limits, unpowered and unlimited joints, joints at
rest, v_des = 0, no / symmetric / asymmetric friction, both modes; symmetric effort boxes and
asymmetric ones (issue 27): the gear's driving and back-driven limits at the state's speed
(kernels/drive.py effort_box, computed here from its definition) or arbitrary lower and upper
limits.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_chain
from drive_oracle import cycle_terms, enumerate_solutions, rel, solve, torque_speed

from mrnea import Joint, Link, Robot, transform
from mrnea.achievable import achievable_accelerations
from mrnea.kernels.status import OK

STATES = {2: 900, 3: 800, 4: 600, 5: 450, 6: 300}  # 3050 in all


def random_problem(rng: np.random.Generator, n: int, terms=None) -> dict:
    """One random cycle problem (module docstring); ``terms(qd)``, if given, makes its
    (H_a, u'_a) instead (a tree's, tests/test_drive_solve_tree.py)."""
    dt = float(rng.choice([1e-3, 4e-3, 1e-2]))
    qd = rng.normal(0.0, 1.0, n)
    r = rng.random(n)
    qd[r < 0.3] = 0.0  # at rest
    small = (r >= 0.3) & (r < 0.5)
    qd[small] = rng.normal(0.0, 3.0 * dt, small.sum())  # slow: may cross zero this cycle
    if terms is not None:
        Ha, ua = terms(qd)
    elif rng.random() < 0.6:  # a real chain: gravity, Coriolis, wrench, rotors
        robot = random_chain(rng, n, 0.25).with_actuators(
            gear_ratio=rng.choice([1.0, 10.0, 50.0], n),
            rotor_inertia=rng.choice([0.0, 1e-5, 1e-4], n))
        q = rng.uniform(-np.pi, np.pi, n)
        wrench = rng.normal(0.0, 10.0, 6) if rng.random() < 0.5 else None
        point = rng.normal(0.0, 0.2, 3) if wrench is not None else None
        Ha, ua = cycle_terms(robot, q, qd, wrench, point)
        ua = ua + rng.uniform(0.0, 2.0, n) * qd  # + F_v qd
    else:  # random SPD, condition number up to 1e6, gravity- and wrench-like biases
        Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
        lam = 10.0 ** rng.uniform(0.0, 6.0 * rng.random(), n)
        Ha = Q @ np.diag(lam) @ Q.T * 10.0 ** rng.uniform(-2, 2)
        Ha = 0.5 * (Ha + Ha.T)
        ua = Ha @ rng.normal(0.0, 10.0, n) + rng.normal(0.0, 5.0, n)
    qdd_des = rng.normal(0.0, 1.0, n) * 10.0 ** rng.uniform(-1, 1.5)
    v_des = qd + dt * qdd_des
    r = rng.random(n)
    v_des[r < 0.2] = 0.0
    v_des[(r >= 0.2) & (r < 0.3)] = qd[(r >= 0.2) & (r < 0.3)]
    E = np.abs(Ha @ ((v_des - qd) / dt) + ua) + 1e-2  # effort scale per joint
    peak = E * rng.uniform(0.2, 2.0, n)
    corner = rng.uniform(0.2, 1.0, n)
    L = torque_speed(peak, corner, corner + rng.uniform(0.5, 3.0, n), qd)
    r = rng.random(n)
    L[r < 0.1] = 0.0  # no drive
    L[(r >= 0.1) & (r < 0.18)] = np.inf  # fixed to the program
    box = rng.integers(3)  # symmetric; a gear's efficiency; arbitrary lower and upper limits
    if box == 1:  # eta_d L delivering power (and at rest), L / eta_b back-driven
        eta_d, eta_b = rng.uniform(0.3, 1.0, n), rng.uniform(0.3, 1.0, n)
        drive, back = eta_d * L, L / eta_b
        Llo = np.where(qd > 0, back, drive)
        Lhi = np.where(qd < 0, back, drive)
    elif box == 2:
        Llo, Lhi = L * rng.uniform(0.0, 2.0, n), L * rng.uniform(0.0, 2.0, n)
        Llo[L == np.inf] = Lhi[L == np.inf] = np.inf
        Llo[L == 0] = Lhi[L == 0] = 0.0
    else:
        Llo, Lhi = L, L
    kind = rng.integers(3)  # no, symmetric, asymmetric friction
    Fp = (E + np.abs(ua)) * rng.uniform(0.0, 0.8, n) * (kind > 0)
    Fn = Fp if kind == 1 else (E + np.abs(ua)) * rng.uniform(0.0, 0.8, n) * (kind > 0)
    mode = "paper" if rng.random() < 0.3 else "hybrid"
    return {"Ha": Ha, "ua": ua, "qd": qd, "v_des": v_des, "dt": dt, "Llo": Llo, "Lhi": Lhi,
            "Fp": Fp, "Fn": Fn, "mode": mode}


def run_solver(p: dict, perm=None, update: bool | None = None):
    keys = ("Ha", "ua", "qd", "v_des", "dt", "Llo", "Lhi", "Fp", "Fn")
    a = [p[k] for k in keys]
    if perm is not None:
        a = [a[0][np.ix_(perm, perm)], *(x[perm] for x in a[1:4]), a[4], *(x[perm] for x in a[5:])]
    return solve(*a, p["mode"], update)


@pytest.mark.parametrize("n", sorted(STATES))
def test_unique_consistent_pattern_equals_solver(n):
    rng = np.random.default_rng(1100 + n)
    seen = {"saturated": 0, "stuck": 0, "stuck_on_program": 0, "crossed_zero": 0, "paper": 0,
            "asymmetric_binding": 0}
    for s in range(STATES[n]):
        p = random_problem(rng, n)
        sols, tau_req = enumerate_solutions(p["Ha"], p["ua"], p["qd"], p["v_des"], p["dt"],
                                            p["Llo"], p["Lhi"], p["Fp"], p["Fn"], p["mode"])
        where = f"n={n} state {s} ({p['mode']})"
        assert sols, f"{where}: no consistent pattern"
        v0, tau0, phi0, _ = sols[0]
        qdd0 = (v0 - p["qd"]) / p["dt"]
        for v, *_ in sols[1:]:  # ties at a boundary: the same v
            assert rel((v - p["qd"]) / p["dt"], qdd0) < 1e-8, f"{where}: two solutions"
        for update in (False, True):  # H_FF refactorised at every step; its factor updated
            where = f"n={n} state {s} ({p['mode']}, update={update})"
            status, v, qdd, tau, phi, treq, sat, stuck = run_solver(p, update=update)
            assert status == OK, f"{where}: status {status}"
            assert rel(qdd, qdd0) < 1e-9, f"{where}: qdd {qdd} vs {qdd0}"
            assert rel(v, v0, floor=p["dt"]) < 1e-9, f"{where}: v"
            assert rel(treq, tau_req) < 1e-12, f"{where}: tau_req"
            assert rel(tau, tau0) < 1e-9, f"{where}: tau {tau} vs {tau0}"
            assert rel(phi, phi0) < 1e-9, f"{where}: phi {phi} vs {phi0}"
            assert rel(tau - phi, p["Ha"] @ qdd + p["ua"]) < 1e-9, f"{where}: Eq. 42"
            assert np.all((tau >= -p["Llo"]) & (tau <= p["Lhi"])), f"{where}: tau outside its box"
            if len(sols) == 1:  # no tie: the flags are exact where the law has a point
                fr = p["Fp"] + p["Fn"] > 0  # held by friction: v = 0 exactly
                assert np.array_equal(stuck[fr], v0[fr] == 0.0), f"{where}: stuck {stuck}"
                assert np.array_equal(v[fr] == 0.0, v0[fr] == 0.0), f"{where}: v == 0 exactly"
                if p["mode"] == "hybrid":  # on program: v = v_des exactly
                    pw = p["Llo"] + p["Lhi"] > 0
                    assert np.array_equal(sat[pw], v0[pw] != p["v_des"][pw]), \
                        f"{where}: sat {sat}"
            if p["mode"] == "paper":
                assert np.array_equal(sat, (tau_req > p["Lhi"]) | (tau_req < -p["Llo"])), \
                    f"{where}: sat (paper)"
        seen["paper"] += p["mode"] == "paper"
        seen["saturated"] += bool(np.any(sat))
        seen["stuck"] += bool(np.any(stuck & (p["Fp"] + p["Fn"] > 0)))
        seen["stuck_on_program"] += bool(np.any(stuck & (p["v_des"] == 0) & (p["qd"] != 0)))
        seen["crossed_zero"] += bool(np.any(p["qd"] * v < 0))
        seen["asymmetric_binding"] += bool(np.any(sat & (p["Llo"] != p["Lhi"])))
    # the random states really exercise each part of the law
    frac = {k: c / STATES[n] for k, c in seen.items()}
    assert frac["saturated"] > 0.3 and frac["stuck"] > 0.1 and frac["paper"] > 0.15, frac
    assert frac["stuck_on_program"] > 0.02 and frac["crossed_zero"] > 0.02, frac
    assert frac["asymmetric_binding"] > 0.1, frac


@pytest.mark.parametrize("n", [3, 6])
def test_permutation_invariance(n):
    """The minimiser is unique, so the joints' order changes nothing but rounding."""
    rng = np.random.default_rng(1200 + n)
    for s in range(300):
        p = random_problem(rng, n)
        perm = rng.permutation(n)
        a = run_solver(p)
        b = run_solver(p, perm)
        assert a[0] == b[0] == OK
        for name, x, y in zip(("v", "qdd", "tau", "phi", "tau_req"), a[1:6], b[1:6], strict=True):
            floor = p["dt"] if name == "v" else 1.0
            assert rel(y, x[perm], floor) < 1e-10, f"n={n} state {s}: {name}"
        fr = (p["Fp"] + p["Fn"] > 0)[perm]  # v = 0 exactly only where friction holds a joint
        pw = (p["Llo"] + p["Lhi"] > 0)[perm]  # v = v_des exactly only where a drive holds it
        assert np.array_equal(a[7][perm][fr], b[7][fr]), f"n={n} state {s}: stuck"
        assert np.array_equal(a[6][perm][pw], b[6][pw]), f"n={n} state {s}: saturated"


def test_reproducer_1_hybrid_pushes_no_drive_the_wrong_way():
    """Issue 11's first reproducer through the public API: the worst-first greedy gave
    qdd = [-5.36, 6.007] with joint 2's drive pushing -1 against its wanted +17 rad/s^2; the
    drive law gives qdd = [-8.211, 16.797], tau = [-8, +1] (the issue's numbers, found there by
    MuJoCo's velocity actuators and by hand), both drives at their limits on the side the law
    demands, and qdd = H_a^-1 (tau - u'_a) (mrnea's H, u' with numpy.linalg.solve)."""
    js = [Joint("j0", "revolute", "base", "l0", axis=(0, 0, 1), effort_limit=8.0),
          Joint("j1", "revolute", "l0", "l1", origin=transform((1, 0, 0)), axis=(0, 0, 1),
                effort_limit=1.0)]
    ls = [Link(f"l{i}", mass=1.0, com=(0.5, 0, 0), inertia=np.diag([0, 1 / 12, 1 / 12]))
          for i in range(2)]
    robot = Robot(js, ls, gravity=(0, 0, 0))
    q, qd, qdd_des = np.array([0.1, 1.1]), np.zeros(2), np.array([-20.0, 17.0])
    res = achievable_accelerations(robot, q, qd, qdd_des)
    np.testing.assert_allclose(res.qdd, [-8.211, 16.797], atol=5e-4)
    np.testing.assert_array_equal(res.tau, [-8.0, 1.0])
    assert res.saturated.all() and not res.stuck.any()
    Ha, ua = cycle_terms(robot, q, qd)
    np.testing.assert_allclose(res.qdd, np.linalg.solve(Ha, res.tau - ua), rtol=1e-14)
    assert res.qdd[0] > qdd_des[0] and res.qdd[1] < qdd_des[1]  # -L: faster; +L: slower
    np.testing.assert_allclose(res.tau_required, Ha @ qdd_des + ua, rtol=1e-14)
