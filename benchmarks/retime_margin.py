"""Issue 24 part 1: the margin loop on random smooth paths of the UR5, Panda, Puma 560 and SDT,
frictionless and with (symmetric) Coulomb friction and rotor inertia, asked margin 1.0.

For each case: mrnea.retime's duration, the margin it reports and the margins tried, against
TOPP-RA driven by pinocchio.rnea (toppra's own JointTorqueConstraint, rotor inertia as
Pinocchio's armature, Coulomb friction as its ``fs_coef``) on mrnea's first grid, at margin 1.0
and at the reported margin; and the whole retime's wall time against one bare TOPP-RA solve
with that Python inverse-dynamics callback on the same grid.

Run: ``python benchmarks/retime_margin.py [--seeds 3]``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import mrnea
from mrnea.trajectory import quintic

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


def random_path(robot: mrnea.Robot, seed: int, waypoints: int = 4) -> tuple:
    """(t, q): a quintic through random waypoints in the middle half of the joint ranges."""
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    mid, half = (lo + hi) / 2, (hi - lo) / 4
    wp = mid + half * rng.uniform(-1, 1, (waypoints, robot.n))
    t, q = quintic(wp, DT, robot.velocity_limit * 0.5, robot.velocity_limit)
    return t - t[0], q


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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    print("| robot | friction | seed | mrnea [s] | margin | tried | TOPP-RA 1.0 [s] | vs 1.0 | "
          "TOPP-RA at margin [s] | vs margin | retime [ms] | bare solve [ms] | ratio |")
    print("|" + "---|" * 13)
    for name, base in robots().items():
        for friction in (False, True):
            robot = variant(base, friction)
            for seed in range(args.seeds):
                t, q = random_path(robot, seed)
                mrnea.retime(robot, (t, q), margin=1.0)  # warm-up
                t0 = time.perf_counter()
                res = mrnea.retime(robot, (t, q), margin=1.0)
                wall = time.perf_counter() - t0
                grid = res.phase[0].s
                ref1, bare = pinocchio_toppra(robot, t, q, grid, 1.0)
                refm, _ = pinocchio_toppra(robot, t, q, grid, res.margin)
                tried = res.summary()["margins_tried"]
                print(f"| {name} | {'yes' if friction else 'no'} | {seed} | {res.duration:.4f} "
                      f"| {res.margin:.4f} | {len(tried)} | {ref1:.4f} | "
                      f"{100 * (res.duration / ref1 - 1):+.2f} % | {refm:.4f} | "
                      f"{100 * (res.duration / refm - 1):+.2f} % | {1e3 * wall:.0f} | "
                      f"{1e3 * bare:.0f} | {wall / bare:.2f} |", flush=True)


if __name__ == "__main__":
    main()
