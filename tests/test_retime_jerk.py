"""mrnea.retime(..., jerk_limit=...) (issue 24 part 2) against Ruckig, the reference for
jerk-limited time-optimal motion: on a straight-line joint path from rest to rest with velocity,
acceleration and jerk limits only (efforts 1e6 N m, far away), Ruckig with phase
synchronisation gives the time-optimal straight-line motion. Also: the rows' jerk by third
differences (of the CSV the CLI writes), the torque limits still verified, bad input."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import ruckig
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import ModelWarning, StateError
from mrnea.model import Joint, Link, Robot
from mrnea.trajectory import quintic

DT = 0.004
V = np.array([1.5, 2.0, 3.0])  # rad/s
A = np.array([4.0, 6.0, 10.0])  # rad/s^2
J = np.array([20.0, 40.0, 80.0])  # rad/s^3
ROOT = Path(__file__).resolve().parents[1]


def arm() -> Robot:
    """Three revolute joints about vertical axes, 0.5 m apart (no gravity torque), velocity
    limits V and effort limits of 1e6 N m (never binding)."""
    T = np.eye(4)
    T[0, 3] = 0.5
    joints = [Joint(f"j{i}", "revolute", f"l{i - 1}" if i else "base", f"l{i}",
                    origin=T if i else np.eye(4), velocity_limit=V[i], effort_limit=1e6)
              for i in range(3)]
    links = [Link(f"l{i}", mass=2.0, com=(0.25, 0, 0), inertia=np.diag([0.01, 0.05, 0.05]))
             for i in range(3)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        return Robot(joints, links)


def straight(q1: np.ndarray, K: int = 700) -> tuple[np.ndarray, np.ndarray]:
    """A slow program along the straight line from 0 to q1 (a quintic in time, at DT)."""
    x = np.linspace(0.0, 1.0, K)
    return np.arange(K) * DT, (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5)[:, None] * q1


def ruckig_duration(q1: np.ndarray) -> float:
    """Ruckig's time-optimal duration from rest at 0 to rest at q1, phase-synchronised, after
    checking that its motion is the straight line."""
    inp = ruckig.InputParameter(3)
    inp.current_position, inp.target_position = [0.0] * 3, q1.tolist()
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = V.tolist(), A.tolist(), J.tolist()
    inp.synchronization = ruckig.Synchronization.Phase
    traj = ruckig.Trajectory(3)
    assert ruckig.Ruckig(3).calculate(inp, traj) == ruckig.Result.Working
    for t in np.linspace(0, traj.duration, 11):
        p = np.array(traj.at_time(t)[0])
        np.testing.assert_allclose(np.cross(p, q1), 0.0, atol=1e-9)  # on the line
    return traj.duration


def third_differences(q: np.ndarray, dt: float) -> np.ndarray:
    """The rows' jerk, at rest before and after: third differences over dt^3."""
    padded = np.vstack([q[:1], q[:1], q[:1], q, q[-1:], q[-1:], q[-1:]])
    return np.diff(padded, 3, axis=0) / dt ** 3


@pytest.mark.slow
@pytest.mark.parametrize("q1", [[1.2, -1.6, 2.0],  # the velocity limits bind (joints 1, 2)
                                [0.3, -0.2, 0.25]])  # a short move: jerk only
def test_straight_line_within_2_percent_of_ruckig(q1):
    q1 = np.array(q1)
    t, q = straight(q1)  # the default grid (with jerk limits 600 intervals here)
    res = mrnea.retime(arm(), (t, q), margin=1.0, acceleration_limit=A, jerk_limit=J)
    reference = ruckig_duration(q1)
    assert res.achievable
    assert reference - DT <= res.duration <= 1.02 * reference, (res.duration, reference)
    # the rows keep every limit: jerk by third differences (each a B-spline-weighted mean of
    # the motion's jerk over 3 cycles, so a motion within J gives rows within J, up to the
    # rounding of the rows, 8 eps |q| / dt^3 ~ 1e-7 rad/s^3)
    tol = 8 * np.finfo(float).eps * np.abs(res.q_cmd).max() / DT ** 3
    assert np.all(np.abs(third_differences(res.q_cmd, DT)) <= J + tol)
    # acceleration as the simulation forms it, velocity by backward differences
    v = np.diff(res.q_cmd, axis=0, prepend=res.q_cmd[:1], append=res.q_cmd[-1:]) / DT
    assert np.all(np.abs(np.diff(v, axis=0)) / DT <= A * (1 + 1e-9))
    assert np.all(np.abs(v) <= V * (1 + 1e-9))
    # the unlimited retime is faster and its rows jump in acceleration
    fast = mrnea.retime(arm(), (t, q), margin=1.0, acceleration_limit=A)
    assert fast.duration < res.duration
    assert np.abs(third_differences(fast.q_cmd, DT)).max() > 5 * J.max()


@pytest.mark.slow
def test_cli_jerk_limit_written_program_within_limit_and_verified(tmp_path):
    """Puma 560, a quintic move at its own limits: the CSV the CLI writes, read back, has
    every joint's jerk within the limit, and the retimed program passes ``mrnea check`` (the
    torque limits hold in the simulation)."""
    q = np.deg2rad([[0, 45, -135, 0, -45, 0], [60, 20, -100, 90, 40, 120]])
    t, rows = quintic(q, 0.005, np.deg2rad([90, 90, 90, 180, 180, 180]),
                      np.deg2rad([180, 180, 180, 360, 360, 360]))
    src = tmp_path / "move.csv"
    np.savetxt(src, np.column_stack([t, rows]), delimiter=",",
               header="t,q1,q2,q3,q4,q5,q6", comments="")
    jmax = np.array([60.0, 60.0, 60.0, 150.0, 150.0, 150.0])
    out = tmp_path / "out"
    res = mrnea_cli("retime", "puma560", src, "--dt", "0.005", "--out", out, "--quiet",
                    "--jerk-limit", ",".join(map(str, jmax)))
    assert res.returncode == 0, res.stderr
    written = np.loadtxt(out / "retimed.csv", delimiter=",", skiprows=1)[:, 1:]
    tol = 8 * np.finfo(float).eps * np.abs(written).max() / 0.005 ** 3
    assert np.all(np.abs(third_differences(written, 0.005)) <= jmax + tol)
    assert np.abs(third_differences(written, 0.005)).max(axis=0)[:3].max() > 0.5 * 60
    check = mrnea_cli("check", out / "retimed.toml")
    assert check.returncode == 0, check.stdout + check.stderr


@pytest.mark.parametrize("value, words", [
    ("1,2", ["--jerk-limit", "one number or 6", "joint1"]),
    ("0", ["--jerk-limit", "> 0"]),
    ("-5", ["--jerk-limit", "> 0"]),
    ("nan", ["--jerk-limit", "finite"]),
    ("inf", ["--jerk-limit"]),
    ("1,,2", ["--jerk-limit", "not a number"]),
])
def test_cli_bad_jerk_limit(tmp_path, value, words):
    res = mrnea_cli("retime", "puma560", "examples/puma_pick.toml", "--out", tmp_path / "o",
                    "--jerk-limit", value, cwd=ROOT)
    one_error_line(res, *words)
    assert not (tmp_path / "o").exists()


def test_cli_jerk_limit_needs_toppra(tmp_path):
    res = mrnea_cli("retime", "puma560", "examples/puma_pick.toml", "--out", tmp_path / "o",
                    "--method", "scale", "--jerk-limit", "100", cwd=ROOT)
    one_error_line(res, "--jerk-limit", "toppra")


@pytest.mark.parametrize("kwargs, match", [
    ({"jerk_limit": [1.0, 2.0]}, "jerk_limit"),
    ({"jerk_limit": 0.0}, "jerk_limit"),
    ({"jerk_limit": -3.0}, "jerk_limit"),
    ({"jerk_limit": np.nan}, "jerk_limit"),
    ({"jerk_limit": np.inf}, "jerk_limit"),
    ({"jerk_limit": "fast"}, "jerk_limit"),
    ({"jerk_limit": 10.0, "method": "scale"}, "jerk_limit"),
])
def test_bad_jerk_limit(kwargs, match):
    t, q = straight(np.array([0.3, -0.2, 0.25]), K=50)
    with pytest.raises(StateError, match=match):
        mrnea.retime(arm(), (t, q), **kwargs)



def test_search_failing_on_the_rows_says_so(monkeypatch):
    """When every margin's simulation is accepted but its rows exceed a kinematic limit, the
    error names those limits instead of quoting an ACHIEVABLE verdict."""
    from mrnea.errors import RetimeError
    from mrnea.retime import search as rsearch

    def plan_at(job, paths, m, acc, jerk, logs):
        sim = type("S", (), {"verdict": lambda self: "ACHIEVABLE", "achievable": True})()
        return rsearch.Plan(m, np.zeros((3, 1)), None, None, np.zeros(3), {}, sim, False,
                            2.0, 0)

    monkeypatch.setattr(rsearch, "plan_at", plan_at)
    with pytest.raises(RetimeError, match="acceleration and jerk limits"):
        rsearch.search(None, {}, 1.0, None, [], np.ones(1))


@pytest.mark.parametrize("value, code", [("1e-9", 2), ("1", 1)])
def test_cli_tiny_jerk_limit_is_an_error_or_a_verdict_never_highs_model_error(tmp_path, value,
                                                                              code):
    """Jerk limits far below the Puma pick's needs: 1e-9 rad/s^3 (no linear program solves at
    HiGHS's tolerances) is one error line naming --jerk-limit; 1 rad/s^3 (HiGHS refused its
    rows' coefficients beyond 1e15 as a "Model error" before the rows were equilibrated) is
    a verdict: no timing keeps it. Neither writes anything."""
    res = mrnea_cli("retime", "puma560", "examples/puma_pick.toml", "--out", tmp_path / "o",
                    "--jerk-limit", value, cwd=ROOT)
    assert "Model error" not in res.stderr + res.stdout
    if code == 2:
        one_error_line(res, "--jerk-limit", "too small", "give larger jerk limits")
    else:
        assert res.returncode == 1 and "NOT ACHIEVABLE" in res.stdout + res.stderr, res
    assert not (tmp_path / "o").exists()
