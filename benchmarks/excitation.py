"""Excitation trajectories: the optimised Fourier series of ``mrnea.identify.excite`` against
the best of N random ones (docs/identification.md, "Excitation").

Both sides are the same kind of series (L harmonics of f, at rest at t = 0), scaled into the
same limits by the same rule (``into_limits``: positions, velocities, accelerations at every
cycle and between them, efforts within the margin), and scored by the same number: the
condition number of the base regressor over one period's cycles, columns scaled to unit norm.
The random series are drawn as the optimiser's candidates are (``random_free``), from another
seed. The optimiser runs with its defaults (100 candidates, the best 3 optimised by SLSQP).

    OPENBLAS_NUM_THREADS=1 python benchmarks/excitation.py [--random N] [--robots ur5,puma]

(one BLAS thread: the matrices are small, and on a shared machine threads only wait).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from conftest import erd_path

import mrnea
from mrnea.identify import criterion
from mrnea.identify.base import base_parameters
from mrnea.identify.excite import excitation, into_limits, limits_of, random_free
from mrnea.identify.fourier import evaluate

F, L, DT = 0.1, 5, 0.01  # base frequency [Hz], harmonics, cycle [s]
V, A = 2.0, 10.0  # velocity [rad/s] and acceleration [rad/s^2] limits, every joint


def robots() -> dict[str, mrnea.Robot]:
    ur5 = mrnea.load_urdf(erd_path("ur_description/urdf/ur5_robot.urdf")).with_actuators(
        gear_ratio=100.0, rotor_inertia=4e-5, viscous_friction=2.0, coulomb_friction=3.0)
    return {"ur5": ur5, "puma": mrnea.robots.puma560()}


def random_conditions(robot: mrnea.Robot, count: int, seed: int) -> tuple[list[float], float]:
    """The condition numbers of ``count`` random series scaled into the limits; seconds."""
    limits, base = limits_of(robot, V, A), base_parameters(robot)
    rng = np.random.default_rng(seed)
    t = np.arange(round(1 / (F * DT))) * DT
    out, start = [], time.perf_counter()
    for _ in range(count):
        x = random_free(rng, limits, L)
        c, a, b = into_limits(robot, limits, x, L, F, DT, t)
        out.append(criterion.condition(criterion.stacked(robot, base, *evaluate(c, a, b, F, t))))
    return out, time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--random", type=int, default=1000, help="random series per robot")
    ap.add_argument("--robots", default="ur5,puma")
    args = ap.parse_args()
    print(f"f = {F} Hz, L = {L}, dt = {DT} s, velocity <= {V} rad/s, acceleration <= {A} "
          f"rad/s^2, efforts <= 0.9 x limit")
    print("| robot | optimised: cond | time [s] | random (N) | best | median | time [s] | "
          "random within the optimiser's time: best |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.robots.split(","):
        robot = robots()[name]
        start = time.perf_counter()
        exc = excitation(robot, base_frequency=F, harmonics=L, dt=DT, velocity_limit=V,
                         acceleration_limit=A)
        t_opt = time.perf_counter() - start
        conds, t_rand = random_conditions(robot, args.random, seed=12345)
        within = max(1, int(len(conds) * min(1.0, t_opt / t_rand)))
        print(f"| {name} | {exc.condition:.3f} (start {exc.condition_start:.3f}, "
              f"{'achievable' if exc.achievable else 'NOT achievable'}) | {t_opt:.0f} | "
              f"{len(conds)} | {min(conds):.3f} | {np.median(conds):.3f} | {t_rand:.0f} | "
              f"{min(conds[:within]):.3f} ({within}) |", flush=True)


if __name__ == "__main__":
    main()
