"""The exact cycle solve (kernels/drive_solve.py) with every drive saturated: H_FF refactorised
at every active-set step (O(n^4) a cycle) against its factor updated one joint at a time
(O(n^3)), side by side in one process, on long chains and on 6- and 7-joint robots.

Usage: ``PYTHONPATH=<tree>/src python benchmarks/long_chain.py [--sizes 100 300 1000]
[--small-rounds R] [--small 6 7 ...] [--update-only]``. Prints per case the wall time of one
cycle's solve on each path [ms for the long chains, us for the small robots; the process's CPU
time: the solve runs on one thread], their ratio, the number of saturated joints, and the
largest relative difference of the two paths' accelerations (and whether their saturated and
stuck joints are the same); ``--update-only`` times the updated way alone (the refactorising
one takes about 40 s at n = 1000).

Long chain (docs/design.md, "A 1000-joint chain"): n revolute joints, axes alternating z and y,
0.1 m links of 1 kg along x, a random pose, at rest, effort limits 5 N m, a program asking each
joint for a random acceleration of about 5e4 rad/s^2 (normal, standard deviation 5e4): every
drive saturates (holding still, the chain falls as a few rigid pieces and only a few do), hybrid
mode. The long chains are timed once each (n <= 300: the best of 3). Small robots: random
chains (tests/conftest.py) with limits at a fifth to a half of the requirement of a random
acceleration, hybrid mode, the best of R timed loops of a compiled repeat of the same cycle.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

from mrnea import Joint, Link, Robot, mass_matrix_and_bias
from mrnea.kernels.drive_solve import HYBRID, solve_cycle
from mrnea.kernels.drive_ways import solve_mode
from mrnea.kernels.layout import ACHIEVABLE, entry_scratch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from conftest import random_chain


@nb.njit  # not cached: Numba would not see a change in the kernels it calls
def _repeat(R, Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, out, sat, stuck, ws, how):
    """R solves of the same cycle the way ``how`` names (``solve_mode``); returns the last
    status."""
    status = 0
    for _ in range(R):
        status = solve_cycle(Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, how, out[0], out[1],
                             out[2], out[3], out[4], sat, stuck, ws)
    return status


def long_chain(n: int) -> Robot:
    """The chain of docs/design.md's 1000-joint measurement (module docstring)."""
    rod = np.diag([1e-4, 0.1**2 / 12, 0.1**2 / 12])
    joints = [Joint(f"j{i}", "revolute", "base" if i == 0 else f"l{i - 1}", f"l{i}",
                    origin=np.array([[1, 0, 0, 0.1 * (i > 0)], [0, 1, 0, 0], [0, 0, 1, 0],
                                     [0, 0, 0, 1.0]]),
                    axis=(0, 0, 1) if i % 2 == 0 else (0, 1, 0), effort_limit=5.0)
              for i in range(n)]
    links = [Link(f"l{i}", mass=1.0, com=(0.05, 0, 0), inertia=rod) for i in range(n)]
    return Robot(joints, links, name=f"chain{n}")


def problem(robot: Robot, q, qd, v_des, L) -> tuple:
    """One cycle's arrays (no friction, symmetric limits L, dt = 1 ms)."""
    H, u = mass_matrix_and_bias(robot, q, qd)
    z = np.zeros(robot.n)
    return (np.ascontiguousarray(H), u, np.asarray(qd, float), np.asarray(v_des, float), 1e-3,
            np.array(L, float), np.array(L, float), z, z.copy())


def run(args: tuple, R: int, update: bool) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """Best CPU time of ``R`` repeats [s] (one timed call of R solves, best of 3), and the last
    solution's qdd, saturated and stuck flags."""
    n = args[2].shape[0]
    out, sat, stuck = np.empty((5, n)), np.empty(n, np.bool_), np.empty(n, np.bool_)
    ws = entry_scratch(n, ACHIEVABLE)
    best = np.inf
    for _ in range(3 if R > 1 or n <= 300 else 1):
        t0 = time.process_time()  # one thread: steadier than the wall time on a busy machine
        status = _repeat(R, *args, out, sat, stuck, ws, solve_mode(HYBRID, n, update))
        best = min(best, (time.process_time() - t0) / R)
    assert status == -1, status  # OK
    return best, out[1].copy(), sat.copy(), stuck.copy()


def compare(name: str, args: tuple, R: int, unit: float, label: str,
            update_only: bool = False) -> None:
    t_new, qdd_new, sat_new, st_new = run(args, R, True)
    if update_only:
        print(f"{name:14s} update {t_new * unit:10.2f} {label}  saturated "
              f"{int(sat_new.sum()):4d}/{len(sat_new)}")
        return
    t_old, qdd_old, sat_old, st_old = run(args, R, False)
    diff = np.max(np.abs(qdd_new - qdd_old)) / max(1.0, np.max(np.abs(qdd_old)))
    same = np.array_equal(sat_old, sat_new) and np.array_equal(st_old, st_new)
    print(f"{name:14s} refactorise {t_old * unit:10.2f} {label}  update {t_new * unit:10.2f} "
          f"{label}  ratio {t_old / t_new:6.2f}  saturated {int(sat_new.sum()):4d}/{len(sat_new)}"
          f"  qdd rel diff {diff:.1e}  same flags {same}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[100, 300, 1000])
    ap.add_argument("--small", type=int, nargs="*", default=[6, 7, 10, 16, 24])
    ap.add_argument("--small-rounds", type=int, default=20000)
    ap.add_argument("--update-only", action="store_true",
                    help="time the updated way alone (the refactorising one takes ~40 s at 1000)")
    a = ap.parse_args()
    rng = np.random.default_rng(25)
    tiny = problem(long_chain(3), np.zeros(3), np.zeros(3), np.zeros(3), [5.0] * 3)
    run(tiny, 1, False)  # compile
    for n in a.small:
        robot = random_chain(rng, n, 0.25)
        q, qd = rng.uniform(-np.pi, np.pi, n), rng.normal(0.0, 1.0, n)
        qdd_des = rng.normal(0.0, 10.0, n)
        H, u = mass_matrix_and_bias(robot, q, qd)
        L = np.abs(H @ qdd_des + u) * rng.uniform(0.2, 0.5, n)
        compare(f"random n={n}", problem(robot, q, qd, qd + 1e-3 * qdd_des, L),
                a.small_rounds, 1e6, "us")
    for n in a.sizes:
        robot = long_chain(n)
        v_des = 1e-3 * rng.normal(0.0, 5e4, n)  # dt qdd_des
        compare(f"chain n={n}", problem(robot, rng.uniform(-1.0, 1.0, n), np.zeros(n), v_des,
                                        [5.0] * n), 1, 1e3, "ms", a.update_only)


if __name__ == "__main__":
    main()
