"""The path interpolator (mrnea.trajectory): trapezoidal and quintic profiles through waypoints.

Path CSVs are tested in test_pathcsv.py, program files and the examples in test_programs.py.

Expected values are closed forms worked out by hand (durations, positions of a trapezoid or a
quintic at given times, peak velocities), never outputs of the code under test.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mrnea.errors import StateError
from mrnea.trajectory import quintic, trapezoidal

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
DOCS = ROOT / "docs" / "programs.md"


# --- helpers ----------------------------------------------------------------------------------


def fd_velocity(q: np.ndarray, dt: float) -> np.ndarray:
    return np.diff(q, axis=0) / dt


def fd_acceleration(q: np.ndarray, dt: float) -> np.ndarray:
    return np.diff(q, n=2, axis=0) / dt**2


def trapezoid_1d(t: np.ndarray, dq: float, T: float, ta: float) -> np.ndarray:
    """Closed-form rest-to-rest trapezoid of duration T, accel time ta, distance dq."""
    v = dq / (T - ta)
    a = v / ta
    return np.where(t < ta, 0.5 * a * t**2,
                    np.where(t <= T - ta, 0.5 * a * ta**2 + v * (t - ta),
                             dq - 0.5 * a * (T - t) ** 2))


def quintic_1d(t: np.ndarray, dq: float, T: float) -> np.ndarray:
    u = t / T
    return dq * (10 * u**3 - 15 * u**4 + 6 * u**5)


def waypoint_rows(q: np.ndarray, w: np.ndarray) -> list[int]:
    """First row index at which each waypoint is reached exactly, in order."""
    rows, start = [], 0
    for wp in w:
        hit = np.flatnonzero(np.all(q[start:] == wp, axis=1))
        assert hit.size, f"waypoint {wp} never reached exactly"
        rows.append(start + int(hit[0]))
        start = rows[-1]
    return rows


def check_limits(q: np.ndarray, dt: float, vmax, amax) -> None:
    v = np.abs(fd_velocity(q, dt))
    a = np.abs(fd_acceleration(q, dt))
    assert np.all(v <= np.asarray(vmax) * (1 + 1e-9) + 1e-12), v.max(axis=0)
    assert np.all(a <= np.asarray(amax) * (1 + 1e-9) + 1e-9), a.max(axis=0)


# --- trapezoidal --------------------------------------------------------------------------------


@pytest.mark.parametrize(("dt", "cycles"), [(0.01, 200), (0.004, 500), (0.003, 667),
                                            (0.007, 286)])
def test_trapezoidal_duration_cruise(dt: float, cycles: int) -> None:
    # dq = 1, v = 1, a = 1: T = dq/v + v/a = 2 s, rounded up to whole cycles.
    t, q = trapezoidal([[0.0], [1.0]], dt, 1.0, 1.0)
    assert q.shape == (cycles + 1, 1)
    assert t[-1] == pytest.approx(cycles * dt, abs=1e-12)
    assert q[0, 0] == 0.0 and q[-1, 0] == 1.0
    assert np.all(np.diff(q[:, 0]) > 0)  # moving on every cycle until the end


@pytest.mark.parametrize(("dt", "cycles"), [(0.01, 100), (0.003, 334), (0.008, 125)])
def test_trapezoidal_duration_triangle(dt: float, cycles: int) -> None:
    # dq = 0.25 < v²/a = 1: the cruise speed is not reached, T = 2 sqrt(dq/a) = 1 s.
    t, q = trapezoidal([[0.0], [0.25]], dt, 1.0, 1.0)
    assert q.shape == (cycles + 1, 1)
    assert t[-1] == pytest.approx(cycles * dt, abs=1e-12)
    T = cycles * dt
    # triangle stretched to T: q(t) = 2 dq (t/T)² before T/2
    expected = trapezoid_1d(t, 0.25, T, T / 2)
    np.testing.assert_allclose(q[:, 0], expected, atol=1e-14)
    assert np.abs(fd_velocity(q, dt)).max() <= 0.5 * (1 + 1e-12)  # peak 2 dq / T = 0.5 m/s


def test_trapezoidal_closed_form_whole_cycles() -> None:
    # dq = 2, v = 1, a = 1: ta = 1 s, cruise 1 s, T = 3 s = 300 cycles of 10 ms.
    dt = 0.01
    t, q = trapezoidal([[0.0], [2.0]], dt, 1.0, 1.0)
    assert q.shape == (301, 1)
    np.testing.assert_allclose(q[:, 0], trapezoid_1d(t, 2.0, 3.0, 1.0), atol=1e-13)
    assert q[150, 0] == pytest.approx(1.0, abs=1e-14)  # mid-time: half way
    assert q[50, 0] == pytest.approx(0.125, abs=1e-14)  # t = 0.5 s: a t²/2
    assert q[250, 0] == pytest.approx(2.0 - 0.125, abs=1e-14)


def test_trapezoidal_closed_form_stretched_and_negative() -> None:
    # T = 3 s is 428.57 cycles of 7 ms: rounded up to 429 cycles = 3.003 s, the profile stretched
    # in time by 3.003 / 3 (same phase fractions: ta = 1/3 of the segment).
    dt = 0.007
    t, q = trapezoidal([[1.0], [-1.0]], dt, 1.0, 1.0, t0=5.0)
    Tp = 429 * dt
    assert q.shape == (430, 1)
    np.testing.assert_allclose(t, 5.0 + dt * np.arange(430), rtol=0, atol=1e-12)
    expected = 1.0 + trapezoid_1d(t - 5.0, -2.0, Tp, Tp / 3)
    np.testing.assert_allclose(q[:, 0], expected, atol=1e-13)
    assert q[-1, 0] == -1.0
    check_limits(q, dt, 1.0, 1.0)


def test_trapezoidal_constant_speed_when_acceleration_unlimited() -> None:
    dt = 0.01
    t, q = trapezoidal([[0.0], [1.0]], dt, 0.5, np.inf)  # T = dq/v = 2 s, linear
    assert q.shape == (201, 1)
    np.testing.assert_allclose(q[:, 0], 0.5 * t, atol=1e-14)


def test_trapezoidal_velocity_unlimited_is_triangle() -> None:
    dt = 0.01
    _, q = trapezoidal([[0.0], [1.0]], dt, np.inf, 4.0)  # T = 2 sqrt(1/4) = 1 s
    assert q.shape == (101, 1)
    assert q[50, 0] == pytest.approx(0.5, abs=1e-14)


def test_trapezoidal_multi_joint_limits_and_synchronisation() -> None:
    rng = np.random.default_rng(7)
    n, W, dt = 4, 6, 0.005
    w = rng.uniform(-2.0, 2.0, (W, n))
    w[3, 1] = w[2, 1]  # joint 1 does not move in segment 2
    vmax = np.array([1.0, 2.0, 0.7, 3.0])
    amax = np.array([2.0, 1.5, 5.0, 10.0])
    dwell = np.array([0.0, 0.1, 0.0, 0.033, 0.0, 0.2])
    t, q = trapezoidal(w, dt, vmax, amax, dwell=dwell)
    assert q[0].tolist() == w[0].tolist() and q[-1].tolist() == w[-1].tolist()
    check_limits(q, dt, vmax, amax)
    rows = waypoint_rows(q, w)
    for j in range(W - 1):
        start = rows[j] + math.ceil(dwell[j] / dt - 1e-9)  # the dwell ends here
        seg = q[start:rows[j + 1] + 1]
        assert np.all(q[rows[j]:start + 1] == w[j])  # held during the dwell
        dq = w[j + 1] - w[j]
        moving = dq != 0
        # one common normalised progress s for every moving joint: same phases, start and stop
        # together
        s = (seg[:, moving] - w[j, moving]) / dq[moving]
        np.testing.assert_allclose(s, s[:, :1].repeat(moving.sum(), axis=1), atol=1e-12)
        assert s[0, 0] == 0.0 and s[-1, 0] == 1.0
        assert np.all(np.diff(s[:, 0]) > 0)  # every cycle of the segment moves
        assert np.all(seg[:, ~moving] == w[j, ~moving])
        # time-optimal up to the rounding: one cycle fewer would break a limit. Closed form of
        # the shortest common profile: tau_v = max |dq|/v, c = max |dq|/a.
        tau_v = np.max(np.abs(dq) / vmax)
        c = np.max(np.abs(dq) / amax)
        T = tau_v + c / tau_v if tau_v**2 >= c else 2 * math.sqrt(c)
        assert len(seg) - 1 == math.ceil(T / dt - 1e-9)
    assert t[-1] == pytest.approx((len(t) - 1) * dt)


def test_trapezoidal_longest_joint_sets_duration() -> None:
    # Joint 2 moves twice as far with twice the limits: same single-joint time T = 2 s. Joint 3
    # moves less: scaled-down profile, same duration.
    dt = 0.01
    t, q = trapezoidal([[0.0, 0.0, 0.0], [1.0, 2.0, -0.3]], dt, [1.0, 2.0, 1.0],
                       [1.0, 2.0, 1.0])
    assert q.shape == (201, 3)
    np.testing.assert_allclose(q[:, 0], trapezoid_1d(t, 1.0, 2.0, 1.0), atol=1e-13)
    np.testing.assert_allclose(q[:, 1], trapezoid_1d(t, 2.0, 2.0, 1.0), atol=1e-13)
    np.testing.assert_allclose(q[:, 2], trapezoid_1d(t, -0.3, 2.0, 1.0), atol=1e-13)


def test_trapezoidal_speed_and_acceleration_bound_joints() -> None:
    # Joint 1: dq = 1, v = 1, a = inf (1 s alone); joint 2: dq = 1, v = inf, a = 4 (1 s alone).
    # Shared phases: s' <= 1 and s'' <= 4 give ta = 0.25 s, T = 1.25 s.
    dt = 0.01
    t, q = trapezoidal([[0.0, 0.0], [1.0, 1.0]], dt, [1.0, np.inf], [np.inf, 4.0])
    assert q.shape == (126, 2)
    np.testing.assert_allclose(q[:, 0], trapezoid_1d(t, 1.0, 1.25, 0.25), atol=1e-13)
    check_limits(q[:, :1], dt, 1.0, np.inf)
    check_limits(q[:, 1:], dt, np.inf, 4.0)


def test_trapezoidal_dwell_and_repeated_waypoint() -> None:
    dt = 0.01
    _, q = trapezoidal([[0.0], [0.0], [0.25]], dt, 1.0, 1.0, dwell=0.05)
    # 1 start row, 5 + 5 dwell rows at the repeated start (no motion), 100 moving, 5 dwell
    assert q.shape == (1 + 5 + 5 + 100 + 5, 1)
    assert np.all(q[:11] == 0.0) and np.all(q[-6:] == 0.25)
    _, q = trapezoidal([[0.0], [0.0]], dt, 1.0, 1.0)
    assert q.shape == (1, 1)


def test_trapezoidal_single_waypoint_and_list_limits() -> None:
    t, q = trapezoidal([[0.5, -0.5]], 0.01, [1, 1], 1, dwell=[0.1])
    assert q.shape == (11, 2) and np.all(q == [0.5, -0.5])
    assert t[-1] == pytest.approx(0.1)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"dt": 0.0}, "dt"), ({"dt": -0.01}, "dt"), ({"dt": math.nan}, "dt"),
    ({"dt": math.inf}, "dt"), ({"dt": "x"}, "dt"),
    ({"velocity_limit": 0.0}, "velocity_limit"), ({"velocity_limit": -1.0}, "velocity_limit"),
    ({"velocity_limit": math.nan}, "velocity_limit"),
    ({"velocity_limit": [1.0, 1.0, 1.0]}, "velocity_limit"),
    ({"acceleration_limit": [1.0, 0.0]}, "acceleration_limit.*joint 1"),
    ({"waypoints": [0.0, 1.0]}, "waypoints"), ({"waypoints": [[0.0, math.nan]]}, "waypoints"),
    ({"waypoints": [[0.0], [1.0, 2.0]]}, "waypoints"),
    ({"dwell": -1.0}, "dwell"), ({"dwell": [0.1, 0.2, 0.3]}, "dwell"),
    ({"t0": math.nan}, "t0"),
    ({"velocity_limit": math.inf, "acceleration_limit": math.inf}, "infinite"),
])
@pytest.mark.parametrize("fn", [trapezoidal, quintic])
def test_profile_argument_errors(fn, kwargs: dict, match: str) -> None:
    args = {"waypoints": [[0.0, 0.0], [1.0, 1.0]], "dt": 0.01, "velocity_limit": 1.0,
            "acceleration_limit": 1.0}
    args.update(kwargs)
    with pytest.raises(StateError, match=match):
        fn(**args)


# --- quintic ----------------------------------------------------------------------------------


def test_quintic_velocity_bound_closed_form() -> None:
    # dq = 1, v = 1, a = 100: T = 15/8 dq/v = 1.875 s -> 187.5 cycles -> 188 cycles = 1.88 s.
    dt = 0.01
    t, q = quintic([[0.0], [1.0]], dt, 1.0, 100.0)
    T = 1.88
    assert q.shape == (189, 1)
    assert q[0, 0] == 0.0 and q[-1, 0] == 1.0
    np.testing.assert_allclose(q[:, 0], quintic_1d(t, 1.0, T), atol=1e-14)
    # peak velocity 15/8 dq/T at mid-segment (row 94): central difference, error dt² q'''/6
    v_mid = (q[95, 0] - q[93, 0]) / (2 * dt)
    assert v_mid == pytest.approx(15 / 8 / T, rel=1e-4)
    v = fd_velocity(q, dt)[:, 0]
    assert np.argmax(v) in (93, 94)
    # zero velocity at both ends: first step is dq s(1/N) ~ 10 dq / N³
    assert abs(q[1, 0] - q[0, 0]) <= 10.0 / 188**3 * 1.0001
    assert abs(q[-1, 0] - q[-2, 0]) <= 10.0 / 188**3 * 1.0001
    check_limits(q, dt, 1.0, 100.0)


def test_quintic_acceleration_bound_closed_form() -> None:
    # dq = -1, v = 100, a = 1: T = sqrt(10/√3 dq/a) = 2.4028 s -> 241 cycles of 10 ms.
    dt = 0.01
    t, q = quintic([[0.5], [-0.5]], dt, 100.0, 1.0)
    assert q.shape == (242, 1)
    np.testing.assert_allclose(q[:, 0], 0.5 + quintic_1d(t, -1.0, 2.41), atol=1e-14)
    check_limits(q, dt, 100.0, 1.0)
    # the peak second difference is close to the limit (time-optimal up to one cycle)
    assert np.abs(fd_acceleration(q, dt)).max() > 0.99


def test_quintic_multi_joint() -> None:
    rng = np.random.default_rng(3)
    n, W, dt = 3, 5, 0.004
    w = rng.uniform(-1.5, 1.5, (W, n))
    vmax = np.array([0.8, 2.0, 1.2])
    amax = np.array([3.0, 1.0, 6.0])
    _, q = quintic(w, dt, vmax, amax)
    assert q[0].tolist() == w[0].tolist() and q[-1].tolist() == w[-1].tolist()
    check_limits(q, dt, vmax, amax)
    rows = waypoint_rows(q, w)
    for j in range(W - 1):
        dq = np.abs(w[j + 1] - w[j])
        N = rows[j + 1] - rows[j]
        T = N * dt
        # within limits with N cycles, beyond a limit with N - 1
        assert np.all(15 / 8 * dq / T <= vmax * (1 + 1e-12))
        assert np.all(10 / math.sqrt(3) * dq / T**2 <= amax * (1 + 1e-12))
        Tm = (N - 1) * dt
        assert np.any(15 / 8 * dq / Tm > vmax) or np.any(10 / math.sqrt(3) * dq / Tm**2 > amax)
        # all joints follow the same quintic s(u)
        seg = q[rows[j]:rows[j + 1] + 1]
        u = np.arange(N + 1) / N
        s = 10 * u**3 - 15 * u**4 + 6 * u**5
        np.testing.assert_allclose(seg, w[j] + np.outer(s, w[j + 1] - w[j]), atol=1e-13)
