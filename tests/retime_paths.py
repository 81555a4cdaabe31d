"""Random smooth paths of the UR5, Panda, Puma 560 and SDT and TOPP-RA driven by
pinocchio.rnea on them: the oracle of tests/test_retime_margin.py and
benchmarks/retime_margin.py (issue 24)."""

from __future__ import annotations

import time
import warnings

import numpy as np

import mrnea

DT = 0.004


def robots() -> dict[str, mrnea.Robot]:
    """The four robots (UR5 and Panda from example-robot-data when installed)."""
    from conftest import robots_dir

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = {"puma560": mrnea.robots.puma560(), "sdt": mrnea.robots.sdt()}
        d = robots_dir()
        if d is not None:
            out["ur5"] = mrnea.load_robot(d / "ur_description/urdf/ur5_robot.urdf")
            out["panda"] = mrnea.load_robot(d / "panda_description/urdf/panda.urdf",
                                            tip="panda_link8")
    return out


def variant(robot: mrnea.Robot, friction: bool) -> mrnea.Robot:
    """Frictionless with constant limits, or symmetric Coulomb friction (3 % of the limit) and
    rotor inertia (gear ratio 50, the rotor 1e-5 kg m^2 / 50^2 of ... ), no viscous friction."""
    zero = np.zeros(robot.n)
    if not friction:
        return robot.with_actuators(viscous_friction=zero, coulomb_friction=zero,
                                    rotor_inertia=zero, effort_limit=robot.effort_limit)
    return robot.with_actuators(viscous_friction=zero,
                                coulomb_friction=0.03 * robot.effort_limit,
                                gear_ratio=np.full(robot.n, 50.0),
                                rotor_inertia=np.full(robot.n, 2e-5),
                                effort_limit=robot.effort_limit)


def random_path(robot: mrnea.Robot, seed: int, waypoints: int = 5) -> tuple:
    """(t, q): the clamped cubic spline (at rest at both ends, not at the waypoints between)
    through random waypoints in the middle half of the joint ranges, 1 s apart, at DT."""
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    mid, half = (lo + hi) / 2, (hi - lo) / 4
    wp = mid + half * rng.uniform(-1, 1, (waypoints, robot.n))
    t = np.arange(round((waypoints - 1) / DT) + 1) * DT
    return t, CubicSpline(np.arange(waypoints), wp, bc_type="clamped")(t)


def pinocchio_toppra(robot: mrnea.Robot, t, q, grid, scale: float) -> tuple[float, float]:
    """(duration, solve wall time) of TOPP-RA with toppra's JointTorqueConstraint calling
    pinocchio.rnea; velocity limits scale x the robot's."""
    import pinocchio as pin
    import toppra
    import toppra.algorithm as algo
    import toppra.constraint as constraint
    from conftest import to_pinocchio

    model = to_pinocchio(robot)
    model.armature = robot.gear_ratio ** 2 * robot.rotor_inertia
    data = model.createData()
    lim = scale * robot.effort_limit
    path = toppra.SplineInterpolator(t, q, bc_type="clamped")
    t0 = time.perf_counter()
    tau = constraint.JointTorqueConstraint(
        lambda qq, v, a: pin.rnea(model, data, qq, v, a), np.stack([-lim, lim], 1),
        robot.coulomb_friction[:, 0], discretization_scheme=1)
    vl = scale * robot.velocity_limit
    vel = constraint.JointVelocityConstraint(np.stack([-vl, vl], 1))
    inst = algo.TOPPRA([tau, vel], path, gridpoints=grid, solver_wrapper="seidel")
    _, sd, _ = inst.compute_parameterization(0.0, 0.0)
    took = time.perf_counter() - t0
    return float(toppra.ParametrizeConstAccel(path, grid, sd).duration), took
