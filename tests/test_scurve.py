"""Jerk-limited (S-curve) waypoint profiles, :func:`mrnea.trajectory.scurve`.

Durations against the closed-form time of a single-joint jerk-limited move; limits checked on
finite differences of the sampled path (a k-th difference divided by dt^k is a weighted mean of
the k-th derivative, so it is within the limit whatever dt, up to rounding); waypoints exact;
the path a straight line in joint space (phase synchronisation); never faster than the
trapezoid with the same velocity and acceleration limits.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import ruckig

from mrnea.errors import ProgramFileError, StateError
from mrnea.io import load_program
from mrnea.trajectory import CYCLE_TOL, scurve, trapezoidal

EPS = np.finfo(float).eps


def seven_phase_time(d: float, v: float, a: float, j: float) -> float:
    """Closed-form duration of a rest-to-rest jerk-limited move of distance d: with the
    acceleration limit reached (v >= a^2/j), d/v + v/a + a/j; without (v < a^2/j), each ramp
    takes 2 sqrt(v/j): d/v + 2 sqrt(v/j). Both need the cruise speed v reached."""
    if v >= a * a / j:
        assert d >= v * (v / a + a / j), "cruise speed not reached"
        return d / v + v / a + a / j
    assert d >= 2.0 * v * math.sqrt(v / j), "cruise speed not reached"
    return d / v + 2.0 * math.sqrt(v / j)


@pytest.mark.parametrize(("d", "v", "a", "j", "dt"), [
    (1.0, 1.0, 2.0, 10.0, 0.004),  # 1 + 0.5 + 0.2 = 1.7 s: 425 cycles
    (2.5, 0.8, 1.5, 6.0, 0.005),  # a reached
    (3.0, 0.5, 4.0, 8.0, 0.001),  # a not reached: v < a^2/j = 2
    (-1.2, 2.0, 5.0, 100.0, 0.002),  # a negative move
])
def test_single_joint_duration_is_the_closed_form(d: float, v: float, a: float, j: float,
                                                  dt: float) -> None:
    T = seven_phase_time(abs(d), v, a, j)
    t, q = scurve([[0.3], [0.3 + d]], dt, v, a, j)
    assert q.shape[0] - 1 == math.ceil(T / dt - CYCLE_TOL)
    assert t[-1] == pytest.approx((q.shape[0] - 1) * dt)
    assert q[0, 0] == 0.3 and q[-1, 0] == 0.3 + d


def assert_within_limits(q: np.ndarray, dt: float, v, a, j) -> None:
    """First, second, third differences / dt^k within v, a, j (rounding: 2^k eps max|q|)."""
    scale = np.abs(q).max()
    for k, lim in ((1, v), (2, a), (3, j)):
        deriv = np.abs(np.diff(q, k, axis=0)) / dt**k
        bound = np.asarray(lim) * (1.0 + 1e-9) + 2**k * 4 * EPS * scale / dt**k
        assert (deriv <= bound).all(), f"derivative {k}: {deriv.max(axis=0)} > {lim}"


def test_limits_waypoints_and_straight_segments() -> None:
    rng = np.random.default_rng(7)
    w = rng.uniform(-2.0, 2.0, (5, 4))
    w[2, 1] = w[1, 1]  # a joint that does not move in one segment stays exactly still
    v, a, j = np.array([1.0, 2.0, 0.5, 3.0]), np.array([2.0, 1.0, 3.0, 8.0]), [5.0, 20.0, 4.0,
                                                                              50.0]
    dt = 0.004
    _, q = scurve(w, dt, v, a, j, dwell=[0.0, 0.1, 0.0, 0.02, 0.3])
    assert_within_limits(q, dt, v, a, j)
    # every waypoint reached exactly, in order, and each segment a straight line
    hits = [int(np.flatnonzero((q == wp).all(axis=1))[0]) for wp in w]
    assert hits == sorted(hits) and hits[0] == 0 and (q[-1] == w[-1]).all()
    for s in range(4):
        lo = hits[s] + int(np.flatnonzero((q[hits[s]:] != w[s]).any(axis=1))[0]) - 1
        seg = q[lo:hits[s + 1] + 1]
        dq = w[s + 1] - w[s]
        moving = dq != 0
        frac = (seg[:, moving] - w[s][moving]) / dq[moving]  # s(t), the same for every joint
        assert np.abs(frac - frac[:, :1]).max() < 1e-12
        assert (seg[:, ~moving] == w[s][~moving]).all()
        assert (np.diff(frac[:, 0]) >= -1e-15).all()  # rest to rest, no overshoot


@pytest.mark.parametrize("seed", range(6))
def test_never_faster_than_the_trapezoid(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    w = rng.uniform(-3.0, 3.0, (3, n))
    v, a, j = rng.uniform(0.2, 3.0, n), rng.uniform(0.5, 6.0, n), rng.uniform(1.0, 80.0, n)
    dt = 0.002
    _, q_s = scurve(w, dt, v, a, j)
    _, q_t = trapezoidal(w, dt, v, a)
    assert q_s.shape[0] >= q_t.shape[0]
    assert_within_limits(q_s, dt, v, a, j)


def _ruckig_phase(dq, v, a, j):
    """ruckig's own multi-joint profile with Synchronization.Phase: (duration, positions at
    a few instants)."""
    n = len(dq)
    inp = ruckig.InputParameter(n)
    inp.current_position, inp.target_position = [0.0] * n, list(dq)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = list(v), list(a), list(j)
    inp.synchronization = ruckig.Synchronization.Phase
    traj = ruckig.Trajectory(n)
    ruckig.Ruckig(n).calculate(inp, traj)
    return traj.duration, np.array([traj.at_time(f * traj.duration)[0] for f in (0.2, 0.5)])


def test_same_duration_as_ruckigs_phase_synchronisation_and_straight_where_it_is_not() -> None:
    dt = 1e-4
    # ruckig phase-synchronises (the slowest joint's profile, scaled, fits the other's limits)
    dq, v, a, j = [1.0, 0.5], [1.0, 1.0], [2.0, 2.0], [10.0, 10.0]
    T, _ = _ruckig_phase(dq, v, a, j)
    _, q = scurve([[0.0, 0.0], dq], dt, v, a, j)
    assert q.shape[0] - 1 == math.ceil(T / dt - CYCLE_TOL)
    # here the slowest joint's profile scaled to joint 0 would break its acceleration limit:
    # ruckig falls back to time synchronisation (not a straight line); scurve stays straight
    dq, v, a, j = [1.0, -0.5], [1.0, 0.2], [2.0, 2.0], [10.0, 10.0]
    _, pts = _ruckig_phase(dq, v, a, j)
    assert abs(pts[0, 0] / pts[0, 1] - dq[0] / dq[1]) > 0.1
    _, q = scurve([[0.0, 0.0], dq], 0.004, v, a, j)
    inner = q[1:-1]
    assert np.abs(inner[:, 0] / inner[:, 1] - dq[0] / dq[1]).max() < 1e-9
    assert_within_limits(q, 0.004, v, a, j)


def test_scurve_argument_errors() -> None:
    with pytest.raises(StateError, match=r"^jerk_limit: must be finite"):
        scurve([[0.0], [1.0]], 0.01, 1.0, 1.0, math.inf)
    with pytest.raises(StateError, match=r"^jerk_limit: must be > 0"):
        scurve([[0.0], [1.0]], 0.01, 1.0, 1.0, [0.0])
    with pytest.raises(StateError, match=r"^jerk_limit: expected a scalar or 2 values"):
        scurve([[0.0, 0.0], [1.0, 1.0]], 0.01, 1.0, 1.0, [1.0, 2.0, 3.0])
    _, q = scurve([[0.5, 0.5]], 0.01, 1.0, 1.0, 1.0, dwell=0.05)  # one waypoint: a dwell
    assert q.shape == (6, 2) and (q == 0.5).all()
    # unlimited velocity and acceleration: the jerk alone limits the move
    _, q = scurve([[0.0], [1.0]], 0.001, math.inf, math.inf, 6.0)
    T = (32.0 * 1.0 / 6.0) ** (1.0 / 3.0)  # jerk +j, -j, +j for T/4, T/2, T/4: d = j T^3 / 32
    assert q.shape[0] - 1 == math.ceil(T / 0.001 - CYCLE_TOL)


def test_program_file_scurve(tmp_path: Path) -> None:
    text = """[program]
robot = "sdt"
dt = 0.005
[path]
profile = "{profile}"
units = "deg"
waypoints = [[0, 0, 0, 0], [90, -45, 10, 0]]
velocity_limit = 60.0
acceleration_limit = 120.0
{extra}
"""
    p = tmp_path / "s.toml"
    p.write_text(text.format(profile="scurve", extra="jerk_limit = 600.0"))
    prog = load_program(p)
    _, q = scurve(np.deg2rad([[0, 0, 0, 0], [90, -45, 10, 0]]), 0.005, math.radians(60),
                  math.radians(120), math.radians(600))
    np.testing.assert_array_equal(prog.q_cmd, q)
    assert prog.interpolation is None
    p.write_text(text.format(profile="scurve", extra=""))
    with pytest.raises(ProgramFileError, match=r"\[path\]: missing required key 'jerk_limit'"):
        load_program(p)
    p.write_text(text.format(profile="trapezoidal", extra="jerk_limit = 600.0"))
    with pytest.raises(ProgramFileError, match="'jerk_limit' applies to profile = \"scurve\""):
        load_program(p)
    p.write_text(text.format(profile="scurve", extra="jerk_limit = inf"))
    with pytest.raises(ProgramFileError, match=r"\[path\]: jerk_limit: must be finite"):
        load_program(p)
