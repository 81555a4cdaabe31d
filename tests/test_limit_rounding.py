"""Rounding at a limit (issue 23): a program planned exactly to a velocity, position or effort
limit is ACHIEVABLE although rounding puts the computed value an ulp or a few over it; a program
over the limit by a real amount, or by more than the documented tolerance, is not.

The tolerance (docs/guarantees.md, kernels/drive.py ``beyond``): x is over a limit L when
x > L + 8 eps * scale, scale the magnitude of what x is computed from (velocity: L + (|q_cmd| +
|q|) / dt; position: |L| + |q|; effort: L + |tau_req|). Every case below places the value a
counted number of ulps from the limit, on each side of that documented bound, with positions and
cycle times chosen so that the commanded values are exact in floating point; the effort case
holds a point mass on a vertical slider, whose required force is m g exactly (closed form).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import mrnea
from mrnea.model import Joint, Link, Robot

EPS = float(np.finfo(np.float64).eps)


def _with_velocity_limit(robot: Robot, v: float) -> Robot:
    joints = [dataclasses.replace(j, velocity_limit=v) for j in robot.joints]
    return Robot(joints, robot.links, gravity=robot.gravity, name=robot.name)


@pytest.fixture(scope="module")
def puma() -> Robot:
    """The Puma 560 with drives strong enough that only the joint limits can bind."""
    return mrnea.robots.puma560().with_actuators(effort_limit=1e9)


def test_a_ramp_planned_to_the_velocity_limit_is_achievable(puma: Robot) -> None:
    """The issue's case: positions 2 dt k (2 rad/s exactly as planned) whose differences over dt
    come out above 2.0 by rounding; the same ramp 1e-9 faster is over the limit."""
    robot = _with_velocity_limit(puma, 2.0)
    dt, K = 0.01, 60
    q = np.zeros((K, 6))
    q[:, 1], q[:, 2] = 0.5, -0.5
    q[:, 0] = 2.0 * dt * np.arange(K)
    res = mrnea.simulate(robot, q, dt)
    assert res.qd_cmd[:, 0].max() > 2.0  # rounding put the plan over the limit
    assert res.achievable and not res.velocity_clamped.any(), res.verdict()
    q[:, 0] *= 1.0 + 1e-9
    over = mrnea.simulate(robot, q, dt)
    assert not over.achievable and over.velocity_clamped[:, 0].any()
    assert "velocity limit" in over.verdict()


@pytest.mark.parametrize(("ulps", "achievable"), [(0, True), (8, True), (32, False),
                                                  (-8, True), (-32, False)])
def test_velocity_on_both_sides_of_the_tolerance(puma: Robot, ulps: int,
                                                 achievable: bool) -> None:
    """dt = 0.5 s, from q = 0 to q1 = v dt: the commanded velocity is v exactly (a power of two
    scaling). Limit 2 rad/s: scale = 2 + |q1| / dt = 4, tolerance 32 eps = 16 ulps of 2.0; 8 ulps
    over is within it, 32 ulps over is not (either sign of motion)."""
    robot = _with_velocity_limit(puma, 2.0)
    sign = 1.0 if ulps >= 0 else -1.0
    v = sign * (2.0 + abs(ulps) * np.spacing(2.0))
    dt = 0.5
    q = np.zeros((3, 6))
    q[:, 1], q[:, 2] = 0.5, -0.5
    q[1:, 0] = v * dt
    res = mrnea.simulate(robot, q, dt)
    assert res.qd_cmd[1, 0] == v  # exact, as planned
    assert res.achievable is achievable, res.verdict()
    assert bool(res.velocity_clamped[:, 0].any()) is not achievable


@pytest.mark.parametrize(("ulps", "achievable"), [(0, True), (4, True), (11, True),
                                                  (44, False)])
@pytest.mark.parametrize("side", ["upper", "lower"])
def test_position_on_both_sides_of_the_tolerance(puma: Robot, ulps: int, achievable: bool,
                                                 side: str) -> None:
    """Joint 1 of the Puma (limits +-2.7925 rad, no velocity limit) commanded to its limit plus
    ulps: scale = 2 |L|, tolerance 16 eps |L| = 22 ulps of 2.79 (ulp = 2 eps); 11 ulps beyond is
    within it and not clamped, 44 beyond is clamped and not achievable."""
    lim = puma.joints[0].upper if side == "upper" else puma.joints[0].lower
    target = lim
    for _ in range(ulps):
        target = np.nextafter(target, np.sign(lim) * np.inf)
    q = np.zeros((40, 6))
    q[:, 1], q[:, 2] = 0.5, -0.5
    q[:, 0] = np.linspace(0.0, 1.0, 40) * lim
    q[-5:, 0] = target
    res = mrnea.simulate(puma, q, 0.05)
    assert res.achievable is achievable, res.verdict()
    assert bool(res.position_clamped[:, 0].any()) is not achievable
    if not achievable:
        assert "position limit" in res.verdict()


def _slider(limit: float) -> Robot:
    """A point mass of 2 kg on a vertical prismatic joint, gravity -8 m/s^2 along it: holding
    it takes 16 N exactly (closed form m g; every product in the pass is exact)."""
    joint = Joint("lift", "prismatic", "base", "carriage", axis=[0.0, 0.0, 1.0],
                  effort_limit=limit)
    link = Link("carriage", mass=2.0, com=[0.0, 0.0, 0.0], inertia=np.zeros((3, 3)))
    return Robot([joint], [link], gravity=(0.0, 0.0, -8.0), name="slider")


@pytest.mark.parametrize(("mode", "short", "achievable"), [
    ("hybrid", 0, True), ("hybrid", 4, True), ("hybrid", 1e-11, False),
    ("paper", 0, True), ("paper", 4, True), ("paper", 64, False)])
def test_effort_on_both_sides_of_the_tolerance(mode: str, short: float, achievable: bool) -> None:
    """Holding the slider needs 16 N; the limit is ``short`` ulps below it (an int) or short by
    that fraction (a float). Tolerance 8 eps (L + 16) = 256 eps = 32 ulps of the values just
    below 16 (ulp 8 eps): 4 ulps short is within it. PAPER: 64 ulps short is over it. HYBRID:
    once a drive is not on program its solve holds a joint whose multiplier is within 1e-12 of
    its interval (relative to the row's terms: 16 + 2 L = 48 N here, so 3e-12 of 16 N); 1e-11
    short is beyond that, so over. A limit 1e-9 short is over in both modes."""
    limit = 16.0
    if isinstance(short, float):
        limit *= 1.0 - short
    for _ in range(short if isinstance(short, int) else 0):
        limit = np.nextafter(limit, 0.0)
    q = np.zeros((20, 1))
    res = mrnea.simulate(_slider(limit), q, 0.01, mode=mode)
    assert res.tau_required[0, 0] == 16.0  # m g, the closed form, exactly
    assert res.achievable is achievable, res.verdict()
    assert bool(res.saturated.any()) is not achievable
    far = mrnea.simulate(_slider(16.0 * (1 - 1e-9)), q, 0.01, mode=mode)
    assert not far.achievable and far.saturated.any()


def test_start_at_a_limit_up_to_rounding_is_not_a_start_violation(puma: Robot) -> None:
    """The summary's start check compares as the kernels do: a start 4 ulps beyond the upper
    position limit is at the limit; 1e-9 rad beyond is outside it."""
    up = puma.joints[0].upper
    q = np.zeros((10, 6))
    q[:, 1], q[:, 2] = 0.5, -0.5
    q[:, 0] = up - 0.01
    for _ in range(4):
        up = np.nextafter(up, np.inf)
    res = mrnea.simulate(puma, q, 0.01, q0=[up, 0.5, -0.5, 0, 0, 0])
    assert not any(v["reason"].startswith("start outside") for v in res.summary()
                   ["start_infeasible"])
    far = mrnea.simulate(puma, q, 0.01, q0=[puma.joints[0].upper + 1e-9, 0.5, -0.5, 0, 0, 0])
    assert any(v["reason"].startswith("start outside") for v in far.summary()["start_infeasible"])
