"""mrnea.retime against independent references: TOPP-RA driven by pinocchio.rnea (frictionless),
closed-form time-optimal motions of one joint (constant limit; viscous and Coulomb friction; a
torque-speed curve, integrated by SciPy), Hollerbach's closed form for uniform scaling; the
drive helpers against the curve's formula; simulate(reactions=False); errors."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import mrnea
from mrnea.actuators import effort_limit_branches, effort_limits_at
from mrnea.errors import ModelWarning, RetimeError, StateError
from mrnea.model import Joint, Link, Robot
from mrnea.simulate import simulate
from mrnea.trajectory import quintic, trapezoidal

DT = 0.005
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PUMA_WAYPOINTS_DEG = [[0, 45, -135, 0, -45, 0], [60, 20, -100, 90, 40, 120],
                      [-30, 60, -160, -60, -20, -90], [0, 45, -135, 0, -45, 0]]
PUMA_V = np.deg2rad([90, 90, 90, 180, 180, 180])
PUMA_A = np.deg2rad([180, 180, 180, 360, 360, 360])


def curve(peak: float, corner: float, no_load: float, w: np.ndarray) -> np.ndarray:
    """The torque-speed curve as docs/achievable.md states it, written out here."""
    w = np.abs(w)
    with np.errstate(divide="ignore", invalid="ignore"):
        falling = np.minimum(peak * corner / w, peak * (no_load - w) / (no_load - corner))
    return np.where(w <= corner, peak, np.where(w >= no_load, 0.0, falling))


def turntable(izz: float = 2.0, **actuator) -> Robot:
    """One revolute joint about the vertical: a disc of inertia izz [kg m^2] on its axis (no
    gravity torque), with the given actuator fields."""
    joint = Joint("table", "revolute", "base", "disc", axis=(0, 0, 1), **actuator)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        return Robot([joint], [Link("disc", mass=5.0, inertia=np.diag([1.0, 1.0, izz]))])


def move(D: float, T: float) -> tuple[np.ndarray, np.ndarray]:
    """A slow quintic rest-to-rest move of one joint by D [rad] in about T [s]."""
    return quintic(np.array([[0.0], [D]]), DT, np.array([1.875 * D / T]),
                   np.array([5.78 * D / T ** 2]))


# --- the drive helpers: one home for the torque-speed curve --------------------------------

def test_effort_limits_at_is_the_curve():
    robot = turntable(torque_speed=(30.0, 2.0, 7.0))
    w = np.linspace(-8, 8, 161)[:, None]
    np.testing.assert_array_equal(effort_limits_at(robot, w)[:, 0],
                                  curve(30.0, 2.0, 7.0, w[:, 0]))
    assert effort_limits_at(robot, np.array([3.0])).shape == (1,)


def test_effort_limit_branches_values_and_slopes():
    peak, corner, no_load = 30.0, 2.0, 7.0
    robot = turntable(torque_speed=(peak, corner, no_load))
    w = np.array([[0.5], [2.0], [3.0], [6.5], [8.0]])
    b = effort_limit_branches(robot, w)[:, 0, :]
    P, gamma = peak * corner, peak / (no_load - corner)
    np.testing.assert_allclose(b[:, 0], P / w[:, 0], rtol=1e-15)
    np.testing.assert_allclose(b[:, 1], -P / w[:, 0] ** 2, rtol=1e-15)
    np.testing.assert_allclose(b[:, 2], gamma * (no_load - w[:, 0]), rtol=1e-15)
    np.testing.assert_allclose(b[:, 3], -gamma, rtol=1e-15)
    # the limit is the smallest of peak and both branches, never below 0
    lim = np.maximum(0, np.minimum(peak, np.minimum(b[:, 0], b[:, 2])))
    np.testing.assert_allclose(lim, curve(peak, corner, no_load, w[:, 0]), rtol=1e-15)
    flat = effort_limit_branches(turntable(effort_limit=30.0), w)[:, 0, :]
    assert np.all(np.isinf(flat[:, [0, 2]])) and np.all(flat[:, [1, 3]] == 0)


def test_simulate_without_reactions_same_verdict_and_efforts():
    from mrnea.robots.sdt_profile import training_profile

    sdt = mrnea.robots.sdt()  # its training profile is not achievable (the yaw turn)
    _, q = training_profile(DT)
    full, check = simulate(sdt, q, DT), simulate(sdt, q, DT, reactions=False)
    assert check.reaction is None and full.reaction is not None
    assert check.achievable == full.achievable is False
    for name in ("q", "qd", "qdd", "tau", "tau_required", "limit", "saturated"):
        np.testing.assert_array_equal(getattr(check, name), getattr(full, name))
    s = check.summary()
    assert s["joints"][0]["peak_reaction_force"] is None
    assert s["first_infeasible"] == full.summary()["first_infeasible"]
    with pytest.raises(StateError, match="reactions"):
        check.bearing_loads()
    with pytest.raises(StateError, match="reactions"):
        simulate(sdt, q, DT, reactions="no")


# --- acceptance (a): frictionless, against TOPP-RA driven by pinocchio.rnea ------------------

def pinocchio_toppra(robot: Robot, t: np.ndarray, q: np.ndarray, grid: np.ndarray,
                     scale: float) -> float:
    """Duration of TOPP-RA with toppra's own JointTorqueConstraint calling pinocchio.rnea (rotor
    inertia as Pinocchio's armature), limits scale x effort_limit, rest to rest, on the clamped
    spline through (t, q), interpolation scheme, seidel."""
    import pinocchio as pin
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as constraint
    from conftest import to_pinocchio

    model = to_pinocchio(robot)
    model.armature = robot.gear_ratio ** 2 * robot.rotor_inertia
    data = model.createData()
    lim = scale * robot.effort_limit
    tau = constraint.JointTorqueConstraint(
        lambda qq, v, a: pin.rnea(model, data, qq, v, a), np.stack([-lim, lim], 1),
        np.zeros(robot.n), discretization_scheme=1)
    path = toppra.SplineInterpolator(t, q, bc_type="clamped")
    inst = algo.TOPPRA([tau], path, gridpoints=grid, solver_wrapper="seidel")
    _, sd, _ = inst.compute_parameterization(0.0, 0.0)
    return float(toppra.ParametrizeConstAccel(path, grid, sd).duration)


@pytest.fixture(scope="module")
def frictionless():
    return mrnea.robots.puma560().with_actuators(viscous_friction=0.0, coulomb_friction=0.0)


def test_frictionless_matches_toppra_with_pinocchio(frictionless):
    """The same path (a trapezoidal program through four waypoints; toppra's own torque
    constraint fails at a quintic's rest, where its rows are too short for seidel) and grid:
    the profile from one batched mRNEA call equals the reference, and so does the verified
    retime() (its program is sampled at dt: longer by less than a cycle)."""
    from mrnea.retime import path as rpath
    from mrnea.retime import rows as rrows
    from mrnea.retime import toppra as rtoppra

    t, q = trapezoidal(np.deg2rad(PUMA_WAYPOINTS_DEG), DT, PUMA_V, PUMA_A)
    t = t - t[0]
    grid = rpath.grid_points(t, q, 400)
    pc = rpath.path_coefficients(frictionless, rpath.piece_spline(q, DT), grid, None, None)
    sd, _ = rtoppra.toppra_profile(pc, rrows.Limits.of(frictionless, 1.0), DT)
    ref = pinocchio_toppra(frictionless, t, q, grid, 1.0)
    assert rtoppra.duration_of(grid, sd) == pytest.approx(ref, rel=1e-6)
    res = mrnea.retime(frictionless, (t, q), grid=400)
    assert res.achievable and res.method == "toppra"
    ref = pinocchio_toppra(frictionless, t, q, res.phase[0].s, res.margin)
    assert ref - 1e-9 <= res.duration < ref + DT
    assert abs(res.duration - ref) < 0.01 * ref


# --- one joint: time-optimal in closed form ---------------------------------------------------

def bang_bang_time(D: float, inertia: float, push: float, brake: float, fv: float) -> float:
    """Minimum rest-to-rest time over D for I w' = push - fv w (accelerating) and I w' =
    -brake - fv w (braking): accelerate, then brake; the switch where they meet (closed form
    per phase, the switch by brentq)."""
    if fv == 0:
        t_a = math.sqrt(2 * D * inertia / push / (1 + push / brake))
        return t_a * (1 + push / brake)
    tau, Wa, Wb = inertia / fv, push / fv, brake / fv

    def accel(t):  # speed and distance after t of accelerating from rest
        return Wa * (1 - math.exp(-t / tau)), Wa * (t - tau * (1 - math.exp(-t / tau)))

    def brake_from(w0):  # time and distance to stop from w0
        ts = tau * math.log((w0 + Wb) / Wb)
        return ts, tau * w0 - Wb * ts

    def gap(t):
        w, x = accel(t)
        return x + brake_from(w)[1] - D

    t1 = brentq(gap, 0.0, 1e3, xtol=1e-14)
    return t1 + brake_from(accel(t1)[0])[0]


@pytest.mark.parametrize("fv,fs", [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0)],
                         ids=["no friction", "viscous", "viscous+Coulomb"])
def test_one_joint_bang_bang_closed_form(fv, fs):
    """A turntable (I = 2 kg m^2 + rotor) turning 2 rad: the retimed duration equals the
    closed-form bang-bang time at the result's margin, rounded up to whole cycles, to within
    0.5 % (the grid: its constraints hold at the grid points, so it may even be 0.2 % faster).
    A plan that ignored friction would be faster than the reference (and fail verification)."""
    robot = turntable(effort_limit=20.0, gear_ratio=10.0, rotor_inertia=2e-3,
                      viscous_friction=fv, coulomb_friction=fs)
    t, q = move(2.0, 6.0)
    res = mrnea.retime(robot, (t, q))
    assert res.achievable
    inertia = 2.0 + 10.0 ** 2 * 2e-3
    L = res.margin * 20.0
    ref = bang_bang_time(2.0, inertia, L - fs, L + fs, fv)
    assert 0.998 * ref <= res.duration <= 1.005 * ref + DT, (res.duration, ref)


def test_one_joint_torque_speed_curve_ode():
    """With a torque-speed curve and no friction the optimum accelerates at the full curve to
    half way and brakes symmetrically; its time from SciPy's ODE solver. The retimed duration is
    within 1 % and a cycle (the simulation takes the limit at the previous cycle's speed: the
    plan keeps that lag on the safe side)."""
    peak, corner, no_load = 20.0, 1.0, 3.0
    robot = turntable(torque_speed=(peak, corner, no_load))
    t, q = move(3.0, 8.0)
    res = mrnea.retime(robot, (t, q))
    assert res.achievable

    def rhs(_, y):
        return [y[1], res.margin * curve(peak, corner, no_load, np.array(y[1])) / 2.0]

    half = solve_ivp(rhs, (0, 100), [0.0, 0.0], events=lambda _, y: y[0] - 1.5, rtol=1e-11,
                     atol=1e-12)
    ref = 2 * float(half.t_events[0][0])
    assert 0.998 * ref <= res.duration <= 1.01 * ref + DT, (res.duration, ref)


def test_scale_estimate_is_hollerbachs_closed_form():
    """No friction, constant limit: tau = I qdd, so the smallest factor is
    sqrt(I max|qdd| / L) with qdd the program's second differences (as the simulation forms
    them); the bisection on the simulation lands within its 0.5 % of it."""
    robot = turntable(effort_limit=20.0, gear_ratio=10.0, rotor_inertia=2e-3)
    t, q = move(2.0, 3.0)
    v = np.diff(q[:, 0], prepend=q[0, 0]) / DT
    qdd = np.diff(v, append=0.0) / DT
    ref = math.sqrt((2.0 + 0.2) * np.abs(qdd).max() / 20.0)
    from mrnea.retime import scale_estimate

    assert scale_estimate(robot, q, DT) == pytest.approx(ref, rel=1e-12)
    res = mrnea.retime(robot, (t, q), method="scale")
    assert res.achievable and res.estimate == pytest.approx(ref, rel=1e-12)
    assert abs(res.factor / ref - 1) < 0.01
    assert res.duration == pytest.approx(res.factor * (q.shape[0] - 1) * DT, abs=DT)


def test_scale_estimate_with_friction_and_wrench_against_pinocchio():
    """The Puma 560 with its asymmetric viscous and Coulomb friction, a wrench and rests at the
    waypoints: the program slowed by f (dt -> f dt) has, by pinocchio.rnea with armature
    G^2 J_m, viscous friction and the Coulomb friction of the velocity each cycle makes (at rest:
    static friction takes up to its capacity first), every effort within its limit and every
    speed within its limit for f just above the estimate (here below 1: the program can be made
    faster) and any larger f tried, and not just below it."""
    import pinocchio as pin
    from conftest import pin_fext, to_pinocchio

    from mrnea.retime import scale_estimate

    robot = mrnea.robots.puma560()
    _, q = quintic(np.deg2rad(PUMA_WAYPOINTS_DEG), DT, 3 * PUMA_V, 3 * PUMA_A)
    fe, pe = np.array([5.0, -3.0, 20.0, 0.5, 0.2, -0.4]), np.array([0.0, 0.02, 0.1])
    model = to_pinocchio(robot)
    model.armature = robot.gear_ratio ** 2 * robot.rotor_inertia
    data = model.createData()
    fext = [pin_fext(robot, model, qk, fe, pe) for qk in q]
    Fp, Fn = robot.coulomb_friction[:, 0], robot.coulomb_friction[:, 1]

    def within(f: float) -> bool:
        dt = f * DT
        qd = np.vstack([np.zeros(6), np.diff(q, axis=0) / dt])
        v = np.vstack([qd[1:], np.zeros(6)])
        for k in range(q.shape[0]):
            h = np.array(pin.rnea(model, data, q[k], qd[k], (v[k] - qd[k]) / dt, fext[k]))
            h += robot.viscous_friction * qd[k]
            tau = h + np.where(v[k] > 0, Fp, np.where(v[k] < 0, -Fn, np.clip(-h, -Fn, Fp)))
            if np.any(np.abs(tau) > robot.effort_limit) or np.any(
                    np.abs(qd[k]) > robot.velocity_limit):
                return False
        return True

    f = scale_estimate(robot, q, DT, np.broadcast_to(fe, (q.shape[0], 6)), pe)
    assert not within(f * (1 - 1e-6))
    assert all(within(f * x) for x in (1 + 1e-9, 1.01, 1.3, 2.0, 5.0))


# --- behaviour ---------------------------------------------------------------------------------

def test_dwells_kept_and_resampling_to_another_dt():
    """A dwell stays a hold of the same duration, at the program's dt and at another one; the
    retimed rows at 2 dt are verified at 2 dt."""
    robot = turntable(effort_limit=20.0)
    _, q = quintic(np.array([[0.0], [1.0], [2.0]]), DT, np.array([0.4]), np.array([0.3]),
                   dwell=np.array([0.1, 0.5, 0.2]))
    for dt in (DT, 2 * DT):
        res = mrnea.retime(robot, q, dt=DT) if dt == DT else mrnea.retime(robot, (
            np.arange(q.shape[0]) * DT, q), dt=dt)
        assert res.dt == dt and res.simulation.dt == dt and res.achievable
        held = np.flatnonzero(np.all(res.q_cmd[1:] == res.q_cmd[:-1], axis=1))
        runs = np.split(held, np.flatnonzero(np.diff(held) > 1) + 1)
        assert [round(len(r) * dt, 9) for r in runs] == [0.1, 0.5, 0.2]
        assert [res.q_cmd[r[0], 0] for r in runs] == [0.0, 1.0, 2.0]
        assert res.duration < res.original_duration


def test_margin_one_and_acceleration_limits():
    puma = mrnea.robots.puma560()
    t, q = quintic(np.deg2rad(PUMA_WAYPOINTS_DEG), DT, PUMA_V, PUMA_A)
    res = mrnea.retime(puma, (t, q), margin=1.0, grid=300)
    assert res.achievable and res.simulation.achievable and res.margin <= 1.0
    amax = np.full(6, 4.0)
    slow = mrnea.retime(puma, (t, q), acceleration_limit=amax, grid=300)
    v = np.vstack([np.zeros((1, 6)), np.diff(slow.q_cmd, axis=0) / DT, np.zeros((1, 6))])
    assert np.abs(np.diff(v, axis=0) / DT).max() <= 4.0
    assert np.abs(np.diff(res.q_cmd, 2, axis=0) / DT ** 2).max() > 1.5 * 4.0
    assert slow.duration > res.duration


def test_pose_not_holdable_names_joint_instant_ratio():
    """Joint 2 limited to 10 N m cannot hold the arm against gravity: both methods refuse,
    naming the joint, the instant and the ratio of need to limit; the need is mrnea's RNEA at
    rest plus Coulomb friction against the motion."""
    puma = mrnea.robots.puma560()
    t, q = quintic(np.deg2rad(PUMA_WAYPOINTS_DEG), DT, PUMA_V, PUMA_A)
    weak = puma.with_actuators(effort_limit=[97.6, 10.0, 89.4, 24.2, 20.1, 21.3])
    g2 = mrnea.inverse_dynamics(puma, q, 0 * q, 0 * q)[:, 1]
    up, down = np.diff(q[:, 1]) > 0, np.diff(q[:, 1]) < 0  # the motion of each interval
    fp, fn = puma.coulomb_friction[1]  # (F+, F-): against positive, negative motion
    need = max(np.abs(g2[:-1] + fp)[up].max(initial=0.0), np.abs(g2[:-1] - fn)[down].max(
        initial=0.0))
    for method in ("toppra", "scale"):
        with pytest.raises(RetimeError, match=r"at any speed: at t = [0-9.]+ s .*joint "
                                              r"'joint2' \(joint 2\)") as e:
            mrnea.retime(weak, (t, q), method=method, margin=1.0)
        ratio = float(str(e.value).split(" times its limit")[0].split(", ")[-1])
        assert ratio == pytest.approx(need / 10.0, rel=0.02)


@pytest.mark.parametrize("kwargs,match", [
    ({"method": "fastest"}, "method: unknown 'fastest'"),
    ({"margin": 0.0}, r"margin: must be in \(0, 1\]"),
    ({"margin": 1.5}, r"margin: must be in \(0, 1\]"),
    ({"dt": -1.0}, "dt: must be a finite time step"),
    ({"grid": 3}, "grid: expected an int >= 10"),
    ({"acceleration_limit": [1.0, 2.0]}, "acceleration_limit"),
    ({"f_ext": np.zeros(5)}, "f_ext"),
])
def test_bad_arguments(kwargs, match):
    robot = turntable(effort_limit=20.0)
    t, q = move(1.0, 2.0)
    with pytest.raises(StateError, match=match):
        mrnea.retime(robot, (t, q), **kwargs)


def test_bad_programs():
    robot = turntable(effort_limit=20.0)
    t, q = move(1.0, 2.0)
    with pytest.raises(StateError, match="array program needs its cycle time"):
        mrnea.retime(robot, q)
    with pytest.raises(StateError, match="constant step"):
        mrnea.retime(robot, (t ** 2, q))
    with pytest.raises(StateError, match=r"program: expected shape \(1,\)"):
        mrnea.retime(robot, np.zeros((5, 2)), dt=DT)
    with pytest.raises(RetimeError, match="never moves"):
        mrnea.retime(robot, np.zeros((5, 1)), dt=DT)
    with pytest.raises(RetimeError, match="arbitrarily fast"):
        mrnea.retime(turntable(), (t, q))  # no effort or velocity limit
    limited = turntable(effort_limit=20.0, lower=-0.5, upper=0.5)
    with pytest.raises(RetimeError, match="leaves its position limits"):
        mrnea.retime(limited, (t, q))


def test_program_file_reads_back_the_retimed_program(tmp_path):
    """save_csv + save_program: the program file alone gives back the rows bit for bit, the
    cycle, the mode and the retimed wrench at every cycle (from its breakpoints); a result
    with a wrench point per cycle is refused."""
    prog = mrnea.load_program(EXAMPLES / "puma_pick.toml")
    res = mrnea.retime(prog.load_robot(), prog)
    res.save_csv(tmp_path / "r.csv")
    res.save_program(tmp_path / "r.toml", "puma560", "r.csv", name="again")
    back = mrnea.load_program(tmp_path / "r.toml")
    assert np.array_equal(back.q_cmd, res.q_cmd) and back.dt == res.dt
    assert back.mode == res.mode and back.name == "again" and back.robot == "puma560"
    np.testing.assert_allclose(back.f_ext, res.f_ext, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.f_ext_point, res.f_ext_point)
    assert "interpolation = \"linear\"" in (tmp_path / "r.toml").read_text()
    per_cycle = mrnea.retime(prog.load_robot(), prog, f_ext_point=np.tile(
        prog.f_ext_point, (prog.K, 1)))
    with pytest.raises(StateError, match="one point"):
        per_cycle.save_program(tmp_path / "p.toml", "puma560", "r.csv")


def test_cycles_over_the_plan_are_tightened_where_they_are():
    """A coarse grid (50 intervals) on the Puma 560's quintic path: between grid points the plan
    exceeds a limit, the cycle check finds where, and the limits of the grid points there are
    tightened (not the margin lowered): the result keeps margin 0.98, and no cycle's own
    requirement exceeds 0.98 of its limit."""
    t, q = quintic(np.deg2rad(PUMA_WAYPOINTS_DEG), DT, PUMA_V, PUMA_A)
    res = mrnea.retime(mrnea.robots.puma560(), (t, q), grid=50)
    assert res.achievable and res.margin == 0.98
    assert res.log[0]["tightened"] == 0 and res.log[-1]["tightened"] > 0
    assert {lg["margin"] for lg in res.log} == {0.98}
    _, _, _, after = res.effort_ratios()
    assert after.max() <= 0.98 * (1 + 1e-9)
