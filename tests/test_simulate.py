"""The simulation system against closed forms and against its own per-cycle table."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

import mrnea
from mrnea.errors import OutputError, StateError
from mrnea.model import Joint, Link, Robot
from mrnea.rigid import transform
from mrnea.simulate import CHUNK, simulate

G0 = 9.81


def pendulum(m=2.0, l=0.5, Ic=0.01, limit=5.0, G=10.0, Jm=1e-4, Fv=0.2) -> Robot:
    """A 1-DoF pendulum: revolute about the base y axis, centre of mass at x = l (q = 0 horizontal).

    Closed form: tau = I qdd - m g l cos(q) + F_v qd with I = Ic + m l^2 + G^2 J_m. (Gravity
    (0, 0, -g); a rotation about +y turns +x towards -z, the centre of mass is at
    l (cos q, 0, -sin q) and gravity's moment about +y is r_z F_x - r_x F_z = +m g l cos(q),
    which the motor must cancel.)
    """
    j = Joint("hinge", "revolute", "base", "bob", axis=(0, 1, 0), effort_limit=limit,
              gear_ratio=G, rotor_inertia=Jm, viscous_friction=Fv)
    lk = Link("bob", mass=m, com=(l, 0, 0), inertia=np.diag([Ic, Ic, Ic]))
    return Robot([j], [lk], name="pendulum")


def two_link(limit1=math.inf, limit2=math.inf) -> Robot:
    """A planar 2R arm in the horizontal plane (gravity along the axes: no gravity torque)."""
    joints = [
        Joint("j1", "revolute", "base", "l1", axis=(0, 0, 1), effort_limit=limit1),
        Joint("j2", "revolute", "l1", "l2", origin=transform((1.0, 0, 0)), axis=(0, 0, 1),
              effort_limit=limit2),
    ]
    links = [Link("l1", 3.0, (0.5, 0, 0), np.diag([0.01, 0.25, 0.25])),
             Link("l2", 2.0, (0.4, 0, 0), np.diag([0.01, 0.1, 0.1]))]
    return Robot(joints, links, name="2R")


def smooth_move(q0, q1, T, dt, rest=0.2):
    """Rest, quintic rest-to-rest move from q0 to q1 over T, rest: (K, n)."""
    t = np.arange(0, T + 2 * rest + dt / 2, dt)
    s = np.clip((t - rest) / T, 0, 1)
    blend = 10 * s**3 - 15 * s**4 + 6 * s**5
    return np.asarray(q0)[None] + (np.asarray(q1) - np.asarray(q0))[None] * blend[:, None]


@pytest.mark.parametrize("mode", ["hybrid", "paper"])
@pytest.mark.parametrize("fd", ["mrnea", "walker_orin", "crba"])
def test_generous_limits_reproduce_the_program(mode, fd):
    robot = mrnea.robots.puma560().with_actuators(effort_limit=1e12)  # asymmetric friction
    there = np.linspace(0.3, 1.2, 6)
    q_cmd = np.vstack([smooth_move(np.zeros(6), there, 1.0, 0.004),
                       smooth_move(there, np.zeros(6), 1.0, 0.004)[1:]])  # out and back
    res = simulate(robot, q_cmd, 0.004, mode=mode, fd=fd)
    assert res.achievable
    np.testing.assert_allclose(res.q, q_cmd, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.qd[1:], np.diff(q_cmd, axis=0) / 0.004, rtol=0, atol=1e-7)
    # the efforts are the actuator-side inverse dynamics of the motion made (rigid body by the
    # plain RNEA, rotor G^2 J_m qdd, viscous F_v qd) plus the Coulomb friction of the velocity v
    # the drives hold over the cycle, qd[k+1]: F+ moving up, -F- moving down, and at rest
    # static friction taking up to its capacity of the holding effort (docs/achievable.md)
    rigid = mrnea.inverse_dynamics(robot, res.q, res.qd, res.qdd)
    h = (rigid + robot.gear_ratio**2 * robot.rotor_inertia * res.qdd
         + robot.viscous_friction * res.qd)
    v = np.vstack([res.qd[1:], np.zeros((1, 6))])  # the program ends at rest
    Fp, Fn = robot.coulomb_friction[:, 0], robot.coulomb_friction[:, 1]
    phi = np.where(v > 0, Fp, np.where(v < 0, -Fn, np.clip(-h, -Fn, Fp)))
    assert (v == 0).any() and (v > 0).any() and (v < 0).any()
    np.testing.assert_allclose(res.coulomb, phi, rtol=0, atol=1e-12)
    np.testing.assert_allclose(res.tau, h + phi, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(res.stuck, v == 0)


def test_saturating_pendulum_against_closed_form():
    m, l, Ic, lim, G, Jm, Fv = 2.0, 0.5, 0.01, 5.0, 10.0, 1e-4, 0.2
    robot = pendulum(m, l, Ic, lim, G, Jm, Fv)
    dt = 0.002
    q_cmd = smooth_move([0.0], [1.5], 0.4, dt)  # far too fast for a 5 N m motor
    I = Ic + m * l * l + G * G * Jm
    for mode in ("hybrid", "paper"):  # for n = 1 both modes are the same model
        res = simulate(robot, q_cmd, dt, mode=mode)
        q, qd = 0.0, 0.0
        K = q_cmd.shape[0]
        for k in range(K):
            v = (q_cmd[k + 1, 0] - q_cmd[k, 0]) / dt if k + 1 < K else 0.0
            qdd_des = (v - qd) / dt
            tau_req = I * qdd_des - m * G0 * l * math.cos(q) + Fv * qd
            tau = min(max(tau_req, -lim), lim)
            qdd = (tau + m * G0 * l * math.cos(q) - Fv * qd) / I
            assert res.q[k, 0] == pytest.approx(q, abs=1e-9)
            assert res.qd[k, 0] == pytest.approx(qd, abs=1e-9)
            assert res.tau[k, 0] == pytest.approx(tau, abs=1e-9)
            assert res.saturated[k, 0] == (abs(tau_req) > lim)
            qd = qd + qdd * dt
            q = q + qd * dt
        assert not res.achievable
        assert res.saturated.any()


def test_hybrid_and_paper_modes_differ_on_a_two_link_arm():
    robot = two_link(limit1=2.0)
    dt = 0.005
    q_cmd = smooth_move([0.0, 0.0], [1.0, -1.0], 0.5, dt)
    hy = simulate(robot, q_cmd, dt, mode="hybrid")
    pa = simulate(robot, q_cmd, dt, mode="paper")
    k = int(np.argmax(hy.saturated[:, 0]))
    assert hy.saturated[k, 0] and not hy.saturated[k, 1]
    # hybrid: the unsaturated joint keeps the acceleration the program asks for
    assert hy.qdd[k, 1] == pytest.approx(hy.qdd_des[k, 1], abs=1e-12)
    assert abs(hy.tau[k, 0]) == pytest.approx(2.0)
    # paper: the coupling changes the unsaturated joint's acceleration too
    assert pa.saturated[k, 0]
    assert abs(pa.qdd[k, 1] - pa.qdd_des[k, 1]) > 1e-3
    assert not np.allclose(hy.q, pa.q)


def test_summary_matches_the_per_cycle_table(tmp_path):
    """The CSV (read by pandas in one call: units in the column names, the flags as booleans)
    holds what the summary sums up."""
    import pandas
    robot = two_link(limit1=2.0, limit2=1.0)
    dt = 0.005
    res = simulate(robot, smooth_move([0.0, 0.0], [1.0, -1.0], 0.5, dt), dt)
    table = pandas.read_csv(res.to_csv(tmp_path / "cycles.csv"))
    assert len(table) == res.K
    s = json.loads(res.save_summary(tmp_path / "summary.json").read_text())
    assert s["achievable"] is False
    for i, name in enumerate(robot.joint_names):
        sat = table[f"saturated_{name}"]
        assert sat.dtype == bool and (sat.to_numpy() == res.saturated[:, i]).all()
        tau_m = table[f"tau_motor_{name} [N m]"].to_numpy()
        err = table[f"tracking_error_{name} [rad]"].to_numpy()
        qd = table[f"qd_{name} [rad/s]"].to_numpy()
        fx, fy, fz = (table[f"reaction_{c}_{name} [N]"].to_numpy() for c in ("fx", "fy", "fz"))
        j = s["joints"][i]
        assert j["time_saturated"] == pytest.approx(sat.sum() * dt)
        assert j["peak_motor_torque"] == pytest.approx(np.abs(tau_m).max())
        assert j["rms_motor_torque"] == pytest.approx(np.sqrt(np.mean(tau_m**2)))
        assert j["max_tracking_error"] == pytest.approx(np.abs(err).max())
        assert j["peak_speed"] == pytest.approx(np.abs(qd).max())
        assert j["peak_reaction_force"] == pytest.approx(np.sqrt(fx**2 + fy**2 + fz**2).max())
    flags = table[[f"saturated_{nm}" for nm in robot.joint_names]].any(axis=1).to_numpy()
    first = int(np.argmax(flags))
    assert s["first_infeasible"]["cycle"] == first
    assert s["first_infeasible"]["time"] == pytest.approx(table["t [s]"][first])


def test_reactions_in_the_table_are_joint_reactions():
    robot = mrnea.robots.puma560()
    dt = 0.005
    res = simulate(robot, smooth_move(np.zeros(6), np.full(6, 0.5), 0.6, dt), dt)
    ref = mrnea.joint_reactions(robot, res.q, res.qd, res.qdd)
    np.testing.assert_allclose(res.reaction, ref, rtol=1e-12, atol=1e-9)


def test_lag_persists_without_catch_up_and_closes_with_it():
    robot = two_link(limit1=2.0)
    dt = 0.005
    q_cmd = smooth_move([0.0, 0.0], [1.0, -1.0], 0.5, dt, rest=8.0)
    lag = simulate(robot, q_cmd, dt)
    catch = simulate(robot, q_cmd, dt, catch_up=1.0)
    # the paper's behaviour: the lag stays, constant, once the program has stopped
    assert abs(lag.tracking_error[-1, 0]) > 0.5
    assert lag.tracking_error[-1, 0] == pytest.approx(lag.tracking_error[-400, 0], abs=1e-12)
    # a position loop of gain 1/s closes it (exponentially, e^-t, once the effort is free)
    assert abs(catch.tracking_error[-1, 0]) < 1e-3 * abs(lag.tracking_error[-1, 0])
    assert np.abs(catch.tracking_error[:, 0]).max() <= np.abs(lag.tracking_error[:, 0]).max()


def test_velocity_and_position_clamping_are_reported():
    robot = two_link()
    robot = Robot([Joint(**{**j.__dict__, "velocity_limit": 1.0, "upper": 0.8})
                   for j in robot.joints], robot.links, name="clamped")
    dt = 0.005
    res = simulate(robot, smooth_move([0.0, 0.0], [1.0, 0.5], 0.4, dt), dt)
    assert res.velocity_clamped[:, 0].any() and res.position_clamped[:, 0].any()
    assert np.all(np.abs(res.qd) <= 1.0 + 1e-12)
    assert res.q[:, 0].max() <= 0.8 + 1e-12
    assert res.summary()["first_infeasible"]["reason"] in ("velocity limit", "position limit")


def test_interrupt_keeps_a_valid_partial_result():
    robot = two_link()
    dt = 0.001
    q_cmd = smooth_move([0.0, 0.0], [1.0, -1.0], 3 * CHUNK * dt, dt)

    def stop(done, total):
        raise KeyboardInterrupt

    res = simulate(robot, q_cmd, dt, progress=stop)
    assert not res.completed and res.K == CHUNK
    assert "INTERRUPTED" in res.verdict()
    assert np.isfinite(res.q).all()


def test_outputs_never_overwrite_without_permission(tmp_path):
    robot = two_link()
    res = simulate(robot, smooth_move([0.0, 0.0], [0.1, 0.1], 0.2, 0.01), 0.01)
    p = tmp_path / "cycles.csv"
    p.write_text("user data")
    with pytest.raises(OutputError, match="exists"):
        res.to_csv(p)
    assert p.read_text() == "user data"
    res.to_csv(p, overwrite=True)
    assert p.read_text().startswith("t [s],")
    assert [f.name for f in tmp_path.iterdir()] == ["cycles.csv"]  # no temporary files left


@pytest.mark.parametrize("kwargs, match", [
    ({"dt": 0.0}, "dt"), ({"dt": float("nan")}, "dt"), ({"mode": "fast"}, "mode"),
    ({"fd": "aba"}, "fd"), ({"f_ext": np.zeros(5)}, "f_ext"), ({"catch_up": 200.0}, "catch_up"),
    ({"catch_up": -1.0}, "catch_up"),
])
def test_bad_arguments(kwargs, match):
    robot = two_link()
    args = {"q_cmd": np.zeros((10, 2)), "dt": 0.01, **kwargs}
    with pytest.raises(StateError, match=match):
        simulate(robot, **args)


def test_bad_program_shapes():
    robot = two_link()
    with pytest.raises(StateError, match="q_cmd"):
        simulate(robot, np.zeros((10, 3)), 0.01)
    with pytest.raises(StateError, match="q_cmd"):
        simulate(robot, np.zeros((1, 2)), 0.01)
    bad = np.zeros((10, 2))
    bad[3, 1] = np.nan
    with pytest.raises(StateError, match="q_cmd"):
        simulate(robot, bad, 0.01)


def test_streaming_writes_the_same_table_while_running(tmp_path):
    robot = two_link(limit1=2.0)
    dt = 0.001
    q_cmd = smooth_move([0.0, 0.0], [1.0, -1.0], 2.5 * CHUNK * dt, dt)
    seen = []

    def progress(done, total):  # the rows done so far are already on disk, in a private file
        (tmp,) = [p for p in tmp_path.iterdir() if p.name != "run.csv"]
        assert tmp.name.startswith(".run.csv.") and tmp.name.endswith(".tmp")
        with open(tmp, newline="") as fh:
            seen.append(sum(1 for _ in fh) - 1)

    res = simulate(robot, q_cmd, dt, stream=tmp_path / "run.csv", progress=progress)
    assert seen[:2] == [CHUNK, 2 * CHUNK]
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"]  # no temporary left
    assert (tmp_path / "run.csv").read_text() == res.to_csv(tmp_path / "after.csv").read_text()
    with pytest.raises(OutputError, match="exists"):
        simulate(robot, q_cmd, dt, stream=tmp_path / "run.csv")


def test_interrupted_stream_keeps_the_cycles_done(tmp_path):
    robot = two_link()
    dt = 0.001
    q_cmd = smooth_move([0.0, 0.0], [1.0, -1.0], 3 * CHUNK * dt, dt)

    def stop(done, total):
        if done >= 2 * CHUNK:
            raise KeyboardInterrupt

    res = simulate(robot, q_cmd, dt, progress=stop, stream=tmp_path / "run.csv")
    assert not res.completed and res.K == 2 * CHUNK
    with open(tmp_path / "run.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * CHUNK
    assert float(rows[-1]["q_j1 [rad]"]) == res.q[-1, 0]


def test_interrupted_before_any_cycle():
    robot = two_link()

    def stop(done, total):
        raise KeyboardInterrupt

    res = simulate(robot, smooth_move([0.0, 0.0], [1.0, -1.0], 0.5, 0.01), 0.01,
                   progress=lambda d, t: None)
    assert res.completed
    # a run interrupted in its first chunk returns no cycle, and says so
    empty = res._first(0)
    assert empty.K == 0 and "no cycle" in empty.verdict() and empty.summary()["cycles"] == 0
