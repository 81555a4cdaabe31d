"""The exact cycle solve (kernels/drive_solve.py) on tree robots with every drive saturated: H_FF
factored densely (``Refactor``, the solve before the tree's path; ``Update``, the long chains'
updated factor) against the tree's L^T L in the order of the free joints' parent array
(``TreeRefactor``), side by side in one process.

Usage: ``PYTHONPATH=<tree>/src python benchmarks/tree_drive_solve.py [--rounds R]
[--states S]``. Robots: the two-arm torso of examples/waist_two_arms.urdf (a waist joint
carrying two 4-joint arms, n = 9); Baxter (example-robot-data, the head and both arms: three
chains from the base, n = 15); the Allegro hand (four 4-joint fingers, n = 16); synthetic
waists carrying four and eight 7-joint arms (n = 29, 57) and two arms of 20 and of 50 joints
(n = 41, 101: long paths, where the tree's factor costs more than a step of the updated
one). For each robot S random states (pose, speed 0.5 rad/s normal), effort limits at a tenth
of each joint's gravity-and-Coriolis effort plus 0.1 N m, a program asking 2000 rad/s^2
(normal) of each joint, hybrid mode: every drive saturates. Prints per robot the CPU time of
one cycle's solve on each path [us] (the best of 5 timed loops of R compiled repeats, R
scaled by (15 / n)^3, averaged over the states), the ratios, the share of saturated joints,
the largest relative difference of the paths' accelerations, and the way ``solve_mode``
picks.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numba as nb
import numpy as np

import mrnea
from mrnea import mass_matrix_and_bias
from mrnea.kernels.drive_solve import HYBRID, solve_cycle
from mrnea.kernels.drive_ways import solve_mode
from mrnea.kernels.layout import ACHIEVABLE, entry_scratch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import robots_dir

ROOT = Path(__file__).resolve().parent.parent


@nb.njit  # not cached: Numba would not see a change in the kernels it calls
def _repeat(R, Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, out, sat, stuck, ws, how):
    """R solves of the same cycle the way ``how`` names; returns the last status."""
    status = 0
    for _ in range(R):
        status = solve_cycle(Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, how, out[0], out[1],
                             out[2], out[3], out[4], sat, stuck, ws)
    return status


def arms(count: int, length: int) -> mrnea.Robot:
    """A waist joint carrying ``count`` arms of ``length`` joints (0.3 m links of 2 kg)."""
    J, L = mrnea.Joint, mrnea.Link
    rod = np.diag([0.002, 0.015, 0.015])
    joints, links = [J("waist", "revolute", "base", "torso", axis=(0, 0, 1))], [
        L("torso", mass=20.0, com=(0, 0, 0.3), inertia=np.eye(3))]
    for a in range(count):
        for k in range(length):
            origin = np.eye(4)
            origin[:3, 3] = (0.3, 0.0, 0.0) if k else (0.2 * np.cos(a * np.pi / 2),
                                                       0.2 * np.sin(a * np.pi / 2), 0.5)
            joints.append(J(f"a{a}j{k}", "revolute", f"a{a}l{k - 1}" if k else "torso",
                            f"a{a}l{k}", origin=origin, axis=(0, 0, 1) if k % 2 else (0, 1, 0)))
            links.append(L(f"a{a}l{k}", mass=2.0, com=(0.15, 0, 0), inertia=rod))
    return mrnea.Robot(joints, links, name=f"{count}_arms_of_{length}")


def robots() -> list[mrnea.Robot]:
    out = [mrnea.load_urdf(ROOT / "examples" / "waist_two_arms.urdf")]
    d = robots_dir()
    if d is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out.append(mrnea.load_urdf(d / "baxter_description/urdf/baxter.urdf",
                                       tip=["head", "left_wrist", "right_wrist"]))
            out.append(mrnea.load_urdf(d / "allegro_hand_description/urdf/"
                                       "allegro_right_hand.urdf"))
    else:
        print("example-robot-data is not installed: Baxter and the Allegro hand left out")
    out += [arms(4, 7), arms(8, 7), arms(2, 20), arms(2, 50)]
    return out


def problems(robot: mrnea.Robot, rng: np.random.Generator, S: int) -> list[tuple]:
    """S saturated cycles' arrays (module docstring), dt = 1 ms, no friction."""
    n, out = robot.n, []
    for _ in range(S):
        q, qd = rng.uniform(-1.0, 1.0, n), rng.normal(0.0, 0.5, n)
        H, u = mass_matrix_and_bias(robot, q, qd)
        L = 0.1 * np.abs(u) + 0.1
        z = np.zeros(n)
        out.append((np.ascontiguousarray(H), u, qd, qd + 1e-3 * rng.normal(0.0, 2000.0, n),
                    1e-3, L, L.copy(), z, z.copy()))
    return out


def run(cases: list[tuple], R: int, how) -> tuple[float, list[np.ndarray], int]:
    """CPU time of one cycle [s] summed over the cases (best of 5 loops of R repeats each), the
    accelerations and the number of saturated joints."""
    n = cases[0][2].shape[0]
    out, sat, stuck = np.empty((5, n)), np.empty(n, np.bool_), np.empty(n, np.bool_)
    ws = entry_scratch(n, ACHIEVABLE)
    total, qdds, nsat = 0.0, [], 0
    for args in cases:
        _repeat(1, *args, out, sat, stuck, ws, how)  # compile, warm
        best = np.inf
        for _ in range(5):
            t0 = time.process_time()  # one thread: steadier than the wall time
            status = _repeat(R, *args, out, sat, stuck, ws, how)
            best = min(best, (time.process_time() - t0) / R)
        assert status == -1, status  # OK
        total += best
        qdds.append(out[1].copy())
        nsat += int(sat.sum())
    return total / len(cases), qdds, nsat


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=2000)
    ap.add_argument("--states", type=int, default=10)
    a = ap.parse_args()
    rng = np.random.default_rng(34)
    print(f"{'robot':22s} {'n':>3s} {'dense':>9s} {'update':>9s} {'tree':>9s}  "
          f"dense/tree update/tree  saturated  qdd rel diff  solve_mode's choice")
    for robot in robots():
        n = robot.n
        cases = problems(robot, rng, a.states)
        R = max(1, a.rounds * 15**3 // n**3)  # about the same time per robot
        t_d, q_d, s_d = run(cases, R, solve_mode(HYBRID, n, update=False))
        t_u, q_u, _ = run(cases, R, solve_mode(HYBRID, n, update=True))
        t_t, q_t, s_t = run(cases, R, solve_mode(HYBRID, n, parents=robot.parents,
                                                         tree=True))
        chosen = type(solve_mode(HYBRID, n, parents=robot.parents)).__name__
        assert s_d == s_t
        diff = max(float(np.max(np.abs(x - y)) / max(1.0, np.max(np.abs(y))))
                   for x, y in zip(q_t + q_u, q_d + q_d, strict=True))
        print(f"{robot.name:22s} {n:3d} {t_d * 1e6:7.2f}us {t_u * 1e6:7.2f}us "
              f"{t_t * 1e6:7.2f}us  {t_d / t_t:10.2f} {t_u / t_t:11.2f}  "
              f"{s_t:4d}/{n * len(cases):<4d}  {diff:.1e}  {chosen}")


if __name__ == "__main__":
    main()
