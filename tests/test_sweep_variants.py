"""The sweep's parameters and their rules (variant, with_payload, time_scaled), the grid check
and grid files.

Oracles: the rules written out by hand on the joints' fields; Pinocchio's spatial-inertia
addition for the payload; a closed-form quintic for time scaling; the wrench's own times."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pinocchio as pin
import pytest
from test_cli import EXAMPLES

import mrnea
from mrnea.actuators import effort_limits_at
from mrnea.errors import ModelError, StateError, SweepError
from mrnea.io import load_grid_file, load_program
from mrnea.io.program import Program
from mrnea.model import Joint, Link, Robot
from mrnea.rigid import transform
from mrnea.robots import puma560, sdt
from mrnea.sweep import check_grid, time_scaled, variant
from mrnea.sweep.engine import _frame
from mrnea.sweep.rows import run_case
from mrnea.sweep.variants import ROW_BYTES, ROW_BYTES_PER_JOINT, units
from mrnea.trajectory import quintic

CURVE = (4000.0, 1.0, 3.5)  # peak [N m], corner and no-load speed [rad/s], joint side


def two_link_arm(tip_mass: float) -> Robot:
    """A planar 2R arm (z axes, 0.5 m links, gravity -y) whose second link, of ``tip_mass``,
    has its centre of mass on joint 2's axis: with no mass there and no rotor inertia, joint 2
    moves nothing and H is singular."""
    joints = [Joint("j1", "revolute", "base", "l1", axis=(0, 0, 1), effort_limit=200.0),
              Joint("j2", "revolute", "l1", "l2", origin=transform((0.5, 0, 0)),
                    axis=(0, 0, 1), effort_limit=100.0)]
    links = [Link("l1", 2.0, (0.25, 0, 0), np.diag([0.0, 0.05, 0.05])),
             Link("l2", tip_mass, (0.0, 0, 0), np.zeros((3, 3)))]
    return Robot(joints, links, gravity=(0, -9.81, 0), name="arm2")


@pytest.fixture(scope="module")
def robot() -> Robot:
    return sdt()


@pytest.fixture(scope="module")
def curved(robot) -> Robot:
    """The SDT with a torque-speed curve on the cabin yaw joint (G = 80)."""
    return robot.with_actuators(torque_speed=[None, CURVE, None, None])


def test_the_function_carries_variant():
    """mrnea.sweep is the function; mrnea.sweep.variant and the module imports still work."""
    from mrnea.sweep import engine

    assert callable(mrnea.sweep) and mrnea.sweep.variant is variant
    assert mrnea.sweep.time_scaled is time_scaled and engine.sweep is mrnea.sweep


def test_gear_ratio_keeps_the_motor(curved):
    j0 = curved.joints[1]
    v = variant(curved, **{"gear_ratio.cab_yaw": 120.0})
    j = v.joints[1]
    peak, corner, no_load = j.torque_speed
    # the motor's torque and speeds are those of the base drive (motor side: / G, x G)
    assert peak / 120.0 == pytest.approx(CURVE[0] / j0.gear_ratio, rel=1e-15)
    assert corner * 120.0 == pytest.approx(CURVE[1] * j0.gear_ratio, rel=1e-15)
    assert no_load * 120.0 == pytest.approx(CURVE[2] * j0.gear_ratio, rel=1e-15)
    assert j.effort_limit == peak
    # what is not the motor's torque or speed stays
    for f in ("velocity_limit", "rotor_inertia", "viscous_friction", "coulomb_friction"):
        assert getattr(j, f) == getattr(j0, f)
    assert v.gear_ratio.tolist() == [60.0, 120.0, 100.0, 120.0]
    assert [v.joints[i] for i in (0, 2, 3)] == [curved.joints[i] for i in (0, 2, 3)]


def test_gear_ratio_without_curve_scales_the_limit(robot):
    v = variant(robot, gear_ratio=[30.0, 40.0, 50.0, 60.0])
    G0 = robot.gear_ratio
    assert v.effort_limit.tolist() == (robot.effort_limit * [30, 40, 50, 60] / G0).tolist()
    assert v.velocity_limit.tolist() == robot.velocity_limit.tolist()


def test_effort_limit_scales_the_curve(curved):
    """The curve keeps its shape: its limit at every speed scales with the new peak."""
    v = variant(curved, **{"effort_limit.cab_yaw": 6000.0})
    assert v.joints[1].torque_speed == (6000.0, CURVE[1], CURVE[2])
    assert [j.torque_speed for j in v.joints] == [None, v.joints[1].torque_speed, None, None]
    assert v.effort_limit[[0, 2, 3]].tolist() == curved.effort_limit[[0, 2, 3]].tolist()
    for w in (0.5, 1.0, 2.0, 3.0, 3.5):  # the law of mrnea.model, by hand
        law = min(1.0, CURVE[1] / w, (CURVE[2] - w) / (CURVE[2] - CURVE[1])) if w > 1 else 1.0
        assert effort_limits_at(v, [0, w, 0, 0])[1] == pytest.approx(
            6000.0 * law, rel=1e-12)


def test_effort_limit_with_gear_ratio_is_explicit(curved):
    j = variant(curved, **{"gear_ratio.cab_yaw": 160.0, "effort_limit.cab_yaw": 5000.0}
                ).joints[1]
    assert j.torque_speed == (5000.0, CURVE[1] * 80 / 160, CURVE[2] * 80 / 160)


def test_motor_torque_limit(robot, curved):
    v = variant(robot, **{"gear_ratio.cab_yaw": 100.0, "motor_torque_limit.cab_yaw": 45.0})
    assert v.joints[1].effort_limit == 4500.0
    j = variant(curved, **{"motor_torque_limit.cab_yaw": 60.0}).joints[1]
    assert j.torque_speed == (60.0 * 80.0, CURVE[1], CURVE[2])


def test_joint_value_overrides_all_joints(robot):
    v = variant(robot, viscous_friction=1.0, **{"viscous_friction.cab_roll": 7.0})
    assert v.viscous_friction.tolist() == [1.0, 1.0, 7.0, 1.0]


def test_nothing_changed_is_the_robot(robot):
    assert variant(robot, time_scale=3.0) is robot
    assert variant(robot, payload=0.0) is robot
    assert variant(robot, gear_ratio=robot.gear_ratio.tolist()) is robot


@pytest.mark.parametrize("mass, point", [(90.0, (0.3, -0.2, 0.5)), (5.0, (0.0, 0.0, 0.0))])
def test_payload_matches_pinocchio(robot, mass, point):
    last = robot.links[-1]
    expected = (pin.Inertia(last.mass, last.com, last.inertia)
                + pin.Inertia(mass, np.array(point), np.zeros((3, 3))))
    got = variant(robot, payload=mass, payload_point=point).links[-1]
    assert got.mass == pytest.approx(expected.mass, rel=1e-15)
    np.testing.assert_allclose(got.com, expected.lever, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(got.inertia, expected.inertia, rtol=1e-12, atol=1e-10)
    assert variant(robot, payload=mass, payload_point=point).links[:-1] == robot.links[:-1]


def test_payload_on_a_massless_link_is_the_payload():
    got = variant(two_link_arm(0.0), payload=2.0, payload_point=[0.3, 0.0, 0.0]).links[-1]
    assert got.mass == 2.0 and got.com.tolist() == [0.3, 0.0, 0.0] and not got.inertia.any()


def test_time_scaled_follows_the_path_in_time():
    """A quintic rest-to-rest program scaled by f: row m is the path at m dt / f (closed form),
    to dt^2 max|a| / 8 + dt^3 max|jerk| / 6 (the interpolant's bound, derived in its
    docstring), and no acceleration exceeds the original's / f^2."""
    dt = 0.005
    t, q = quintic([[0.0, 0.0], [1.0, -0.5]], dt, velocity_limit=2.0, acceleration_limit=5.0)
    prog = Program(robot="sdt", dt=dt, t=t, q_cmd=q, f_ext=None, f_ext_point=None, mode=None,
                   name="quintic")
    T = t[-1]
    for f in (0.6, 1.37, 2.0, 3.3):
        s = time_scaled(prog, f)
        M = s.K
        assert (M - 1) * dt >= f * T - 1e-9 and (M - 2) * dt < f * T
        u = np.clip(np.arange(M) * dt / f / T, 0, 1)
        exact = q[-1] * (10 * u**3 - 15 * u**4 + 6 * u**5)[:, None]
        a_max = np.abs(np.diff(q, 2, axis=0)).max(axis=0) / dt**2
        j_max = 60 * np.abs(q[-1]) / T**3  # the quintic's jerk peaks at its ends: 60 dq / T^3
        assert np.all(np.abs(s.q_cmd - exact) <= dt**2 * a_max / 8 + dt**3 * j_max / 6)
        a_new = np.abs(np.diff(s.q_cmd, 2, axis=0)).max(axis=0) / dt**2
        assert np.all(a_new <= a_max / f**2 * (1 + 1e-9))
        assert np.array_equal(s.q_cmd[[0, -1]], q[[0, -1]])
        assert not s.q_cmd.flags.writeable and s.dt == dt
    assert time_scaled(prog, 1.0) is prog


def test_time_scaled_wrench_moves_with_the_path():
    """puma_pick.toml presses with 20 N from 1.5 to 1.95 s of its clock: at 3.0-3.9 s when
    twice as slow."""
    prog = load_program(EXAMPLES / "puma_pick.toml")
    s = time_scaled(prog, 2.0)
    press = s.f_ext[:, 2] == -20.0
    assert s.t[press].min() == pytest.approx(3.0, abs=s.dt)
    assert s.t[press].max() == pytest.approx(3.9, abs=s.dt)


@pytest.mark.parametrize("factor", [0.0, -1.0, math.inf, math.nan, "2", True])
def test_time_scaled_refuses(factor):
    prog = load_program(EXAMPLES / "puma_pick.toml")
    with pytest.raises(StateError, match="factor"):
        time_scaled(prog, factor)


# --- the grid check: one clear error naming the entry, before any work -----------------------

def test_units_follow_the_joint_type():
    """A prismatic joint's effort is a force: N, not N m; a ratio has no unit."""
    j = [Joint("turn", "revolute", "base", "a"), Joint("slide", "prismatic", "a", "b")]
    arm = Robot(j, [Link("a", 1.0, (0, 0, 0), np.eye(3) * 0.01),
                    Link("b", 1.0, (0, 0, 0), np.eye(3) * 0.01)], name="rp")
    assert units(arm, ["effort_limit.turn", "effort_limit.slide", "effort_limit",
                       "motor_torque_limit.slide", "viscous_friction.slide", "gear_ratio",
                       "payload", "time_scale"]) == {
        "effort_limit.turn": "N m", "effort_limit.slide": "N", "effort_limit": "N m | N",
        "motor_torque_limit.slide": "N m", "viscous_friction.slide": "N s/m",
        "gear_ratio": "", "payload": "kg", "time_scale": ""}


@pytest.mark.parametrize("grid, words", [
    ({"gear_ratio.cab_yow": [100]}, ["'gear_ratio.cab_yow'", "no joint 'cab_yow'",
                                      "did you mean 'cab_yaw'"]),
    ({"gearratio": [100]}, ["'gearratio'", "unknown parameter", "did you mean 'gear_ratio'"]),
    ({"gear_ratio": []}, ["'gear_ratio'", "empty"]),
    ({"gear_ratio.cab_yaw": [100, -80]}, ["'gear_ratio.cab_yaw' value 2 (-80)",
                                          "gear_ratio must be > 0"]),
    ({"effort_limit.cab_roll": [-1]}, ["'effort_limit.cab_roll' value 1", ">= 0"]),
    ({"payload": [5, -2]}, ["'payload' value 2 (-2)", ">= 0"]),
    ({"time_scale": [1, 0]}, ["'time_scale' value 2 (0)", "> 0"]),
    ({"velocity_limit": ["fast"]}, ["'velocity_limit' value 1", "not a number"]),
    ({"rotor_inertia": [math.nan]}, ["'rotor_inertia' value 1", "not a finite number"]),
    ({"gear_ratio": [[60, 80]]}, ["'gear_ratio'", "4 (one per joint)"]),
    ({"gear_ratio": 100}, ["'gear_ratio'", "expected a list"]),
    ({"payload.cab_yaw": [1]}, ["'payload.cab_yaw'", "not a joint parameter"]),
    ({"payload_point": [[0, 0, 1]]}, ["'payload_point'", "needs 'payload'"]),
    ({"payload": [1], "payload_point": [[0, 1]]}, ["'payload_point' value 1", "[x, y, z]"]),
    ({"effort_limit": [1e3], "motor_torque_limit.cab_yaw": [40]},
     ["effort_limit and motor_torque_limit", "cab_yaw"]),
    ({}, ["no parameter"]),
])
def test_bad_grid(robot, grid, words):
    with pytest.raises(SweepError) as info:
        check_grid(robot, grid)
    for w in words:
        assert w in str(info.value), (w, str(info.value))


def test_zip_needs_equal_lengths(robot):
    with pytest.raises(SweepError, match="zip needs lists of one length"):
        check_grid(robot, {"gear_ratio": [1, 2], "payload": [1, 2, 3]}, zip=True)


def test_product_and_zip(robot):
    keys, cases = check_grid(robot, {"payload": [0, 10], "time_scale": [1, 2, 3]})
    assert keys == ("payload", "time_scale")
    assert [tuple(c.values()) for c in cases] == [(0, 1), (0, 2), (0, 3), (10, 1), (10, 2),
                                                  (10, 3)]
    _, cases = check_grid(robot, {"payload": [0, 10], "time_scale": [1, 2]}, zip=True)
    assert [tuple(c.values()) for c in cases] == [(0, 1), (10, 2)]


def test_a_grid_too_large_for_memory_is_refused_before_it_is_made(robot):
    grid = {k: list(range(1, 101)) for k in ("rotor_inertia", "viscous_friction",
                                             "coulomb_friction", "payload", "time_scale")}
    with pytest.raises(SweepError, match=r"a sweep of 1e\+10 variants needs about .* memory"):
        check_grid(robot, grid)


@pytest.mark.parametrize("make", [sdt, puma560])
def test_the_memory_estimate_bounds_the_rows_peak(make):
    """The client's rows and the DataFrame made of them, measured with tracemalloc: below the
    estimate check_grid holds the grid to, and above a quarter of it."""
    robot = make()
    q = np.zeros((50, robot.n))
    prog = Program(robot="x", dt=0.01, t=np.arange(50) * 0.01, q_cmd=q, f_ext=None,
                   f_ext_point=None, mode=None, name="rest")
    row = run_case(robot, prog, {"payload": 0.0})
    _frame(("payload",), ["rest"], [(0, (0, 1.0), {"payload": 0.0})], {0: row}, False)  # pandas'
    N = 2000  # lazy imports and caches, once per process, are not the rows'
    tracemalloc.start()
    try:
        keys, cases = check_grid(robot, {"payload": [float(x) for x in range(N)]})
        rows = {k: {c: (v + k if isinstance(v, float) else v) for c, v in row.items()}
                for k in range(N)}  # every row its own floats, as rows from the workers are
        _frame(keys, [prog.name], [(k, (0, 1.0), c) for k, c in enumerate(cases)], rows,
               False)
        peak = tracemalloc.get_traced_memory()[1] / N
    finally:
        tracemalloc.stop()
    estimate = ROW_BYTES + ROW_BYTES_PER_JOINT * robot.n
    assert estimate / 4 < peak < estimate, (peak, estimate)


def test_curve_peak_must_stay_finite(curved):
    with pytest.raises(SweepError, match=r"'effort_limit.cab_yaw' value 1 \(inf\)"):
        check_grid(curved, {"effort_limit.cab_yaw": [math.inf]})


def test_a_singular_variant_is_valid_input():
    """A variant that is a valid model but fails to simulate passes the check (its row will
    carry the error); a value the model refuses does not."""
    arm = two_link_arm(0.0)
    assert len(check_grid(arm, {"payload": [0.0, 2.0]})[1]) == 2
    with pytest.raises(ModelError, match=r"j2.*gear_ratio"):
        variant(arm, **{"gear_ratio.j2": 0.0})


# --- grid files ---------------------------------------------------------------------------------

def test_the_examples_read(tmp_path):
    sdt_grid = load_grid_file(EXAMPLES / "sdt_yaw_grid.toml")
    assert sdt_grid.robot == "sdt" and sdt_grid.programs == ["demo"] and not sdt_grid.zip
    assert list(sdt_grid.grid) == ["gear_ratio.cab_yaw", "motor_torque_limit.cab_yaw"]
    puma = load_grid_file(EXAMPLES / "puma_payload_grid.toml")
    assert puma.programs == [str(EXAMPLES / "puma_pick.toml")]
    assert puma.grid["payload_point"] == [[0.0, 0.0, 0.05]]
    keys, cases = check_grid(mrnea.robots.puma560(), puma.grid)
    assert len(cases) == 7 * 6 and keys == ("payload", "payload_point", "time_scale")


@pytest.mark.parametrize("text, words", [
    ("[grid\npayload = [1]\n", ["g.toml", "invalid TOML", "line 1"]),
    ("[grids]\npayload = [1]\n", ["g.toml", "unknown key 'grids'", "did you mean 'grid'"]),
    ("[sweep]\nrobot = 'sdt'\n", ["g.toml", "missing required key 'grid'"]),
    ("[grid]\n", ["g.toml", "[grid]", "no parameter"]),
    ("[grid]\npayload = 1\n", ["g.toml", "'payload' must be an array"]),
    ("[grid]\ngear_ratio.cab_yaw = [60]\n", ["g.toml", "'gear_ratio' must be an array",
                                              "quote a per-joint key, 'gear_ratio.cab_yaw'"]),
    ("[grid]\npayload = []\n", ["g.toml", "'payload'", "empty"]),
    ("[sweep]\nzip = 'yes'\n[grid]\npayload = [1]\n", ["'zip' must be true or false"]),
    ("[sweep]\nprograms = 'a.toml'\n[grid]\npayload = [1]\n", ["'programs' must be an array"]),
    ("[sweep]\nrobt = 'sdt'\n[grid]\npayload = [1]\n", ["unknown key 'robt'",
                                                        "did you mean 'robot'"]),
])
def test_bad_grid_file(tmp_path, text, words):
    (tmp_path / "g.toml").write_text(text)
    with pytest.raises(SweepError) as info:
        load_grid_file(tmp_path / "g.toml")
    for w in words:
        assert w in str(info.value), (w, str(info.value))


def test_a_missing_grid_file(tmp_path):
    with pytest.raises(SweepError, match=r"nothing\.toml"):
        load_grid_file(tmp_path / "nothing.toml")


def test_efficiency_sets_both_sides_of_the_gear(robot):
    """``efficiency`` (rule 4) replaces the gear's eta, driving and back-driven alike; a joint's
    key overrides the all-joints value; a value outside (0, 1] is refused naming the key."""
    v = variant(robot, efficiency=0.8, **{"efficiency.cab_yaw": 0.5})
    assert v.efficiency.tolist() == [[0.8, 0.8], [0.5, 0.5], [0.8, 0.8], [0.8, 0.8]]
    assert [j.gear_ratio for j in v.joints] == [j.gear_ratio for j in robot.joints]
    assert variant(robot, efficiency=1.0) is robot  # the default: nothing changes
    with pytest.raises((ModelError, SweepError), match="efficiency") as err:
        check_grid(robot, {"efficiency.cab_roll": [0.9, 1.5]})
    assert "cab_roll" in str(err.value) and "1.5" in str(err.value)
