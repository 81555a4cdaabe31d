"""The path interpolator (mrnea.trajectory) and the files it reads (mrnea.io: CSV paths, programs).

Expected values are closed forms worked out by hand (durations, positions of a trapezoid or a
quintic at given times, peak velocities), never outputs of the code under test.
"""

from __future__ import annotations

import dataclasses
import math
import re
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from mrnea.errors import MrneaError, ProgramFileError, StateError
from mrnea.io import Program, from_csv, load_program, loads_program
from mrnea.simulate import simulate
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


# --- from_csv ---------------------------------------------------------------------------------


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_from_csv_linear_exact(tmp_path: Path) -> None:
    times = [0.2, 0.213, 0.25, 0.51, 0.7]  # non-uniform rows; span 0.5 s = 50 cycles
    rows = "\n".join(f"{x!r}, {2 + 3 * x!r}, {-x!r}" for x in times)
    p = write(tmp_path / "lin.csv", f"# a comment\n\ntime,q1,q2\n{rows}\n")
    t, q = from_csv(p, 0.01)
    assert q.shape == (51, 2)
    np.testing.assert_allclose(t, 0.2 + 0.01 * np.arange(51), atol=1e-12)
    np.testing.assert_allclose(q[:, 0], 2 + 3 * t, atol=1e-12)
    np.testing.assert_allclose(q[:, 1], -t, atol=1e-12)
    _, q2 = from_csv(str(p), 0.01, n=2)
    np.testing.assert_array_equal(q2, q)


def test_from_csv_holds_last_row(tmp_path: Path) -> None:
    p = write(tmp_path / "p.csv", "\ufefft,a\n0,0\n0.105,1.05\n")  # BOM, span 10.5 cycles
    t, q = from_csv(p, 0.01)
    assert q.shape == (12, 1)  # ceil(10.5) + 1
    np.testing.assert_allclose(q[:11, 0], 10 * t[:11], atol=1e-12)
    assert q[-1, 0] == 1.05


@pytest.mark.parametrize(("text", "match"), [
    ("t,q1\n0,0\n0.1,abc\n",
     r"line 3 \(data row 2\), column 2 \('q1'\): not a number: 'abc' \(numbers are "),
    ("t,q1\n0,0\n0.1,nan\n", r"line 3 .*column 2 .*not a finite number"),
    ("t,q1\n0,0\n0.1,inf\n", r"line 3 .*column 2 .*not a finite number"),
    ("t,q1\n0,0\n0.1,\n", r"line 3 .*column 2 .*empty cell"),
    ("t,q1\n0,0\n0.1,1\n0.1,2\n", r"line 4 .*column 1 \('t'\).*strictly increasing"),
    ("t,q1\n0,0\n0.2,1\n0.1,2\n", r"line 4 .*not greater than"),
    ("t,q1,q2\n0,0,0\n0.1,1\n", r"line 3 .*expected 3 columns.*got 2"),
    ("t,q1\n0,0,0\n", r"line 2 .*expected 2 columns.*got 3"),
    ("", "empty file"),
    ("\n# only a comment\n", "empty file"),
    ("t,q1\n", "0 data row"),
    ("t,q1\n0,1\n", "1 data row"),
    ("0,1\n0.1,2\n", "line 1: the first row must be a header"),
    ("t\n0\n1\n", "line 1: the header row needs a time column"),
])
def test_from_csv_errors(tmp_path: Path, text: str, match: str) -> None:
    p = write(tmp_path / "bad.csv", text)
    with pytest.raises(ProgramFileError, match=match) as info:
        from_csv(p, 0.01)
    assert "bad.csv" in str(info.value)


def test_from_csv_other_errors(tmp_path: Path) -> None:
    with pytest.raises(ProgramFileError, match=r"missing\.csv: path CSV file not found"):
        from_csv(tmp_path / "missing.csv", 0.01)
    p = write(tmp_path / "p.csv", "t,a,b\n0,0,0\n1,1,1\n")
    with pytest.raises(ProgramFileError, match=r"line 1: expected 4 columns \(time \+ 3 joints\)"):
        from_csv(p, 0.01, n=3)
    with pytest.raises(StateError, match="dt"):
        from_csv(p, 0.0)
    with pytest.raises(StateError, match="n:"):
        from_csv(p, 0.01, n=0)


def test_error_types() -> None:
    assert issubclass(ProgramFileError, MrneaError)
    assert issubclass(ProgramFileError, ValueError)


# --- program files ----------------------------------------------------------------------------


def prog_file(tmp_path: Path, text: str, name: str = "prog.toml") -> Path:
    return write(tmp_path / name, text)


def test_program_trapezoidal_waypoints(tmp_path: Path) -> None:
    p = prog_file(tmp_path, """
[program]
robot = "sdt"
dt = 0.01
mode = "paper"

[path]
profile = "trapezoidal"
waypoints = [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
velocity_limit = 1.0
acceleration_limit = [1.0, 1.0, 1.0, 1.0]
""", name="move_it.toml")
    prog = load_program(p)
    assert isinstance(prog, Program)
    assert prog.name == "move_it" and prog.robot == "sdt" and prog.mode == "paper"
    assert prog.dt == 0.01 and prog.K == 201 and prog.n == 4
    assert prog.duration == pytest.approx(2.0)
    np.testing.assert_allclose(prog.t, 0.01 * np.arange(201), atol=1e-12)
    np.testing.assert_allclose(prog.q_cmd[:, 0], trapezoid_1d(prog.t, 1.0, 2.0, 1.0),
                               atol=1e-13)
    assert np.all(prog.q_cmd[:, 1:] == 0.0)
    assert prog.f_ext is None and prog.f_ext_point is None
    assert not prog.q_cmd.flags.writeable
    with pytest.raises(dataclasses.FrozenInstanceError):
        prog.dt = 0.02  # type: ignore[misc]


def test_program_quintic_degrees(tmp_path: Path) -> None:
    p = prog_file(tmp_path, """
[program]
name = "deg"
robot = "sdt"
dt = 0.01

[path]
profile = "quintic"
units = "deg"
waypoints = [[0, 0, 0, 0], [90, -45, 0, 0]]
velocity_limit = 90.0           # deg/s: joint 1 needs 15/8 * 90/90 = 1.875 s
acceleration_limit = 1000.0     # deg/s^2
dwell = [0.0, 0.1]
""")
    prog = load_program(p)
    assert prog.name == "deg" and prog.mode is None
    assert prog.K == 189 + 10
    T = 1.88
    t = prog.t[:189]
    np.testing.assert_allclose(prog.q_cmd[:189, 0], quintic_1d(t, math.pi / 2, T), atol=1e-14)
    np.testing.assert_allclose(prog.q_cmd[:189, 1], quintic_1d(t, -math.pi / 4, T), atol=1e-14)
    np.testing.assert_allclose(prog.q_cmd[-1], [math.pi / 2, -math.pi / 4, 0, 0], atol=1e-15)
    assert prog.q_cmd[94, 0] == pytest.approx(math.pi / 4, abs=1e-14)  # mid-segment: half way


def test_program_csv_and_wrench(tmp_path: Path) -> None:
    sub = tmp_path / "data"
    sub.mkdir()
    write(sub / "path.csv", "t,a,b,c,d\n0,0,0,0,0\n0.4,40,4,0,-4\n")
    p = prog_file(tmp_path, """
[program]
robot = "sdt"
dt = 0.01

[path]
csv = "data/path.csv"
units = "deg"

[wrench]
times = [0.1, 0.3]
values = [[0, 0, -10, 0, 0, 0], [20, 0, 10, 0, 1, 0]]
point = [0.0, 0.0, 0.1]
""")
    prog = load_program(p)
    assert prog.K == 41
    np.testing.assert_allclose(prog.q_cmd[:, 0], np.deg2rad(100 * prog.t), atol=1e-12)
    np.testing.assert_allclose(prog.q_cmd[:, 3], np.deg2rad(-10 * prog.t), atol=1e-12)
    f = prog.f_ext
    assert f.shape == (41, 6)
    np.testing.assert_allclose(f[:11], [[0, 0, -10, 0, 0, 0]] * 11, atol=1e-12)  # held, at 0.1
    np.testing.assert_allclose(f[20], [10, 0, 0, 0, 0.5, 0], atol=1e-12)  # half way
    np.testing.assert_allclose(f[15], [5, 0, -5, 0, 0.25, 0], atol=1e-12)  # a quarter
    np.testing.assert_allclose(f[30:], [[20, 0, 10, 0, 1, 0]] * 11, atol=1e-12)  # at 0.3, held
    np.testing.assert_array_equal(prog.f_ext_point, [0.0, 0.0, 0.1])


def test_program_constant_wrench_and_robot_file(tmp_path: Path) -> None:
    sub = tmp_path / "cell"
    sub.mkdir()
    src = resources.files("mrnea.robots").joinpath("data", "sdt.toml")
    with resources.as_file(src) as f:
        shutil.copy(f, sub / "my_robot.toml")
    p = prog_file(sub, """
[program]
robot = "my_robot.toml"
dt = 0.005

[path]
profile = "trapezoidal"
waypoints = [[0, 0, 0, 0]]
velocity_limit = 1
acceleration_limit = 1
dwell = 0.05

[wrench]
times = [0.0]
values = [[1, 2, 3, 4, 5, 6]]
""")
    prog = load_program(p)
    assert Path(prog.robot) == sub / "my_robot.toml"
    assert prog.K == 11  # the start row + 0.05 s / 5 ms of dwell
    np.testing.assert_array_equal(prog.f_ext, np.tile([1, 2, 3, 4, 5, 6], (11, 1)))
    robot = prog.load_robot()
    assert robot.n == 4


def test_program_joint_count_mismatch(tmp_path: Path) -> None:
    prog = loads_program("""
[program]
robot = "sdt"
dt = 0.01
[path]
profile = "quintic"
waypoints = [[0, 0], [1, 1]]
velocity_limit = 1
acceleration_limit = 1
""", source="two.toml")
    with pytest.raises(ProgramFileError,
                       match=r"^two\.toml: 2 joint values per waypoint, robot sdt has 4$"):
        prog.load_robot()


GOOD = {
    "program": 'robot = "sdt"\ndt = 0.01',
    "path": ('profile = "trapezoidal"\nwaypoints = [[0, 0, 0, 0], [1, 0, 0, 0]]\n'
             "velocity_limit = 1.0\nacceleration_limit = 1.0"),
}


def doc(program: str = GOOD["program"], path: str | None = GOOD["path"],
        extra: str = "") -> str:
    text = f"[program]\n{program}\n"
    if path is not None:
        text += f"\n[path]\n{path}\n"
    return text + extra


@pytest.mark.parametrize(("text", "match"), [
    ("[program]\nrobot = \"sdt\"\ndt = = 0.01\n", r"invalid TOML: .*\(at line 3, column 6\)"),
    ("[program]\nrobot = [\"sdt\"\n", r"invalid TOML: .*line 2, column \d+: end of document"),
    (doc(extra="\n[wrenches]\ntimes = [0]\n"), "unknown key 'wrenches' .*did you mean 'wrench'"),
    (doc(program=GOOD["program"] + "\ndt_s = 1"), r"\[program\]: unknown key 'dt_s'"),
    (doc(path=GOOD["path"].replace("velocity_limit", "velocity_limt")),
     r"\[path\]: unknown key 'velocity_limt' \(did you mean 'velocity_limit'\?\)"),
    (doc(extra="\n[wrench]\ntimes = [0]\nvalues = [[0,0,0,0,0,0]]\npoynt = [0,0,0]\n"),
     r"\[wrench\]: unknown key 'poynt' \(did you mean 'point'\?\)"),
    (doc(path=GOOD["path"].replace("[1, 0, 0, 0]]", "[1, 0, 0, 0], [1, 0, 0]]")),
     r"'waypoints' row 3 has 3 values, expected 4"),
    (doc(path=GOOD["path"].replace("[1, 0, 0, 0]]", "[1, 0, 0, \"x\"]]")),
     r"'waypoints row 2\[3\]' must be a number"),
    (doc(program='robot = "sdt"'), "missing required key 'dt'"),
    (doc(program='robot = ""\ndt = 0.01'), "'robot' must be a non-empty string"),
    (doc(program='robot = "sdt"\ndt = 0.0'), r"'dt' must be a time step > 0 s, got 0.0"),
    (doc(program='robot = "sdt"\ndt = -0.01'), r"'dt' must be a time step > 0 s"),
    (doc(program='robot = "sdt"\ndt = inf'), r"'dt' must be a finite number"),
    (doc(program='robot = "sdt"\ndt = nan'), r"'dt' must be a finite number"),
    (doc(program='robot = "sdt"\ndt = "10 ms"'), r"'dt' must be a number, got string"),
    (doc(program='robot = "sdt"\ndt = 0.01\nmode = "fast"'), r"'mode' must be one of"),
    (doc(program='robot = "nope"\ndt = 0.01'), r"robot 'nope' is neither a built-in robot"),
    (doc(path=None), "missing required key 'path'"),
    ("[path]\ncsv = \"x.csv\"\n", "missing required key 'program'"),
    (doc(path=GOOD["path"].replace("trapezoidal", "trapezoid")),
     r"unknown profile 'trapezoid' \(did you mean 'trapezoidal'\?\)"),
    (doc(path=GOOD["path"] + '\nunits = "grad"'), r"'units' must be one of"),
    (doc(path=GOOD["path"] + '\ncsv = "x.csv"'), r"key 'profile' cannot be used with 'csv'"),
    (doc(path='units = "deg"'), r"give either 'csv'"),
    (doc(path=GOOD["path"].replace("velocity_limit = 1.0", "velocity_limit = 0.0")),
     r"'velocity_limit' must be > 0"),
    (doc(path=GOOD["path"].replace("velocity_limit = 1.0", "velocity_limit = [1, 1]")),
     r"'velocity_limit' must be an array of 4 numbers, got 2"),
    (doc(path=GOOD["path"].replace("acceleration_limit = 1.0", "")),
     "missing required key 'acceleration_limit'"),
    (doc(path=GOOD["path"] + "\ndwell = -1"), r"'dwell' must be >= 0"),
    (doc(path=GOOD["path"].replace("[1, 0, 0, 0]]", "[0, 0, 0, 0]]")), "single cycle"),
    (doc(extra="\n[wrench]\ntimes = [0, 0]\nvalues = [[0,0,0,0,0,0],[0,0,0,0,0,0]]\n"),
     r"'times' must be strictly increasing"),
    (doc(extra="\n[wrench]\ntimes = [0, 1]\nvalues = [[0,0,0,0,0,0]]\n"),
     r"'values' has 1 rows, expected 2"),
    (doc(extra="\n[wrench]\ntimes = [0]\nvalues = [[0,0,0]]\n"),
     r"'values' row 1 has 3 values, expected 6"),
    (doc(extra="\n[wrench]\ntimes = [0]\nvalues = [[0,0,0,0,0,0]]\npoint = [0, 0]\n"),
     r"'point' must be an array of 3 numbers"),
    (doc(extra="\n[wrench]\nvalues = [[0,0,0,0,0,0]]\n"), "missing required key 'times'"),
    ("wrench = 3\n" + doc(), r"top level: 'wrench' must be a table"),
])
def test_program_errors(tmp_path: Path, text: str, match: str) -> None:
    p = prog_file(tmp_path, text, name="broken.toml")
    with pytest.raises(ProgramFileError, match=match) as info:
        load_program(p)
    assert str(info.value).startswith(str(p))


def test_program_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ProgramFileError, match=r"nothing\.toml: program file not found"):
        load_program(tmp_path / "nothing.toml")
    # an error in the CSV it names is reported with the CSV's file, line and column
    write(tmp_path / "p.csv", "t,a,b,c,d\n0,0,0,0,0\n0.1,0,x,0,0\n")
    p = prog_file(tmp_path, doc(path='csv = "p.csv"'))
    with pytest.raises(ProgramFileError, match=r"p.csv: line 3 .*column 3 \('b'\)"):
        load_program(p)
    with pytest.raises(ProgramFileError, match=r"missing\.csv: path CSV file not found"):
        load_program(prog_file(tmp_path, doc(path='csv = "missing.csv"')))


# --- examples and documentation ---------------------------------------------------------------


def test_example_files_small() -> None:
    for name in ("puma_pick.toml", "sdt_csv.toml", "sdt_profile.csv"):
        assert (EXAMPLES / name).stat().st_size < 50_000


def test_example_puma_pick() -> None:
    prog = load_program(EXAMPLES / "puma_pick.toml")
    assert prog.robot == "puma560" and prog.n == 6 and prog.dt == 0.005
    home = np.deg2rad([0.0, 45.0, -135.0, 0.0, -45.0, 0.0])
    np.testing.assert_allclose(prog.q_cmd[0], home, atol=1e-15)
    np.testing.assert_allclose(prog.q_cmd[-1], home, atol=1e-15)
    vmax = np.deg2rad([90, 90, 90, 180, 180, 180])
    amax = np.deg2rad([180, 180, 180, 360, 360, 360])
    check_limits(prog.q_cmd, prog.dt, vmax, amax)
    # the press: -20 N along z between 1.5 and 1.95 s, nothing before 1.45 or after 2.0 s
    fz = prog.f_ext[:, 2]
    assert np.all(fz[prog.t <= 1.45 + 1e-9] == 0.0) and np.all(fz[prog.t >= 2.0 - 1e-9] == 0.0)
    inside = (prog.t >= 1.5 - 1e-9) & (prog.t <= 1.95 + 1e-9)
    np.testing.assert_allclose(fz[inside], -20.0, atol=1e-9)
    # the robot is at rest on the part while pressing
    on_part = np.deg2rad([30.0, 70.0, -118.0, 0.0, -72.0, 30.0])
    np.testing.assert_allclose(prog.q_cmd[inside], np.tile(on_part, (inside.sum(), 1)),
                               atol=1e-15)


def test_example_sdt_csv() -> None:
    prog = load_program(EXAMPLES / "sdt_csv.toml")
    assert prog.robot == "sdt" and prog.n == 4 and prog.mode == "paper"
    t, q = from_csv(EXAMPLES / "sdt_profile.csv", prog.dt, n=4)
    np.testing.assert_array_equal(q, prog.q_cmd)
    assert t[-1] == pytest.approx(6.0)


@pytest.mark.parametrize("name", ["puma_pick.toml", "sdt_csv.toml"])
def test_examples_simulate_achievable(name: str) -> None:
    prog = load_program(EXAMPLES / name)
    mode = {} if prog.mode is None else {"mode": prog.mode}
    res = simulate(prog.load_robot(), prog.q_cmd, prog.dt, f_ext=prog.f_ext,
                   f_ext_point=prog.f_ext_point, **mode)
    assert res.achievable, res.verdict()
    assert res.mode == (prog.mode or "hybrid")


def test_docs_toml_examples_parse(tmp_path: Path) -> None:
    blocks = re.findall(r"```toml\n(.*?)```", DOCS.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 3
    write(tmp_path / "two_link.toml", "")  # robot files are only checked to exist
    shutil.copy(EXAMPLES / "sdt_profile.csv", tmp_path / "sdt_profile.csv")
    for k, block in enumerate(blocks):
        prog = load_program(prog_file(tmp_path, block, name=f"block{k}.toml"))
        assert prog.K >= 2
