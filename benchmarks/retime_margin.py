"""Issue 24 part 1: the margin loop on random smooth paths of the UR5, Panda, Puma 560 and SDT,
frictionless and with (symmetric) Coulomb friction and rotor inertia, asked margin 1.0.

For each case: mrnea.retime's duration, the margin it reports and the margins tried, against
TOPP-RA driven by pinocchio.rnea (toppra's own JointTorqueConstraint, rotor inertia as
Pinocchio's armature, Coulomb friction as its ``fs_coef``) on mrnea's first grid, at margin 1.0
and at the reported margin; and the whole retime's wall time (verification included) against
one bare TOPP-RA solve with that Python inverse-dynamics callback on the same grid (its set-up
included), each the fastest of three runs after a warm-up.

Run: ``python benchmarks/retime_margin.py [--seeds 3]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from retime_paths import pinocchio_toppra, random_path, robots, variant

import mrnea

REPEATS = 3  # the fastest of this many runs of each (the machine is shared)


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
                walls = []
                for _ in range(REPEATS):
                    t0 = time.perf_counter()
                    res = mrnea.retime(robot, (t, q), margin=1.0)
                    walls.append(time.perf_counter() - t0)
                grid = res.phase[0].s
                bares = [pinocchio_toppra(robot, t, q, grid, 1.0) for _ in range(REPEATS)]
                ref1, bare, wall = bares[0][0], min(b[1] for b in bares), min(walls)
                refm, _ = pinocchio_toppra(robot, t, q, grid, res.margin)
                tried = res.summary()["margins_tried"]
                print(f"| {name} | {'yes' if friction else 'no'} | {seed} | {res.duration:.4f} "
                      f"| {res.margin:.4f} | {len(tried)} | {ref1:.4f} | "
                      f"{100 * (res.duration / ref1 - 1):+.2f} % | {refm:.4f} | "
                      f"{100 * (res.duration / refm - 1):+.2f} % | {1e3 * wall:.0f} | "
                      f"{1e3 * bare:.0f} | {wall / bare:.2f} |", flush=True)


if __name__ == "__main__":
    main()
