"""Section 8 of the benchmark: ``mrnea.retime`` (toppra, the verifying simulation included).

Usage: ``python benchmarks/retime_bench.py [--quick]`` prints the section alone; ``run.py``
includes it. The issue's case: a Puma 560 path of 400 grid points (a quintic program through
four waypoints, 958 rows at 5 ms; 361 grid intervals plus the points graded towards its four
rests), retimed by toppra, with the split of the time: constraint building (the spline and
the one batched mRNEA call, then the rows and their linearisation), the TOPP-RA solves
(toppra's set-up included), sampling the profile at dt, and the verifying simulation. Three
actuator models: no friction with constant limits (one solve), the built-in friction (viscous
and Coulomb: the tightening rounds), and torque-speed curves on every joint. The SDT's training
profile (8001 moving rows, its default grid) is the long case. Each retiming runs once to warm
up (Numba's cache, toppra's imports), then ``repeats`` times; the table gives the median wall
time with its run's split, the fastest, and the median CPU time of the process (the machine is
shared: wall time includes waiting for a core).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings

import numpy as np

import mrnea
from mrnea.robots.sdt_profile import training_profile
from mrnea.trajectory import quintic

DT = 0.005
GRID = 361  # + the graded points at the four rests = 400 grid points
TARGET = 0.5  # s, the issue's
PUMA_WAYPOINTS_DEG = [[0, 45, -135, 0, -45, 0], [60, 20, -100, 90, 40, 120],
                      [-30, 60, -160, -60, -20, -90], [0, 45, -135, 0, -45, 0]]


def cases() -> list[tuple[str, mrnea.Robot, tuple, int | None]]:
    """(label, robot, program (t, q), grid) of each case."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Puma's published inertias draw a ModelWarning
        puma = mrnea.robots.puma560()
    path = quintic(np.deg2rad(PUMA_WAYPOINTS_DEG), DT, np.deg2rad([90, 90, 90, 180, 180, 180]),
                   np.deg2rad([180, 180, 180, 360, 360, 360]))
    curves = puma.with_actuators(torque_speed=[(j.effort_limit, 1.5, 4.0) for j in puma.joints])
    return [
        ("Puma 560, no friction, constant limits",
         puma.with_actuators(viscous_friction=0.0, coulomb_friction=0.0), path, GRID),
        ("Puma 560, friction, constant limits", puma, path, GRID),
        ("Puma 560, friction + torque-speed curves", curves, path, GRID),
        ("SDT training profile (default grid)", mrnea.robots.sdt(), training_profile(DT), None),
    ]


def retime_section(repeats: int) -> list[dict]:
    """Time every case (module docstring)."""
    out = []
    for label, robot, program, grid in cases():
        res = mrnea.retime(robot, program, grid=grid)  # warm-up
        runs = []
        for _ in range(repeats):
            c0, t0 = time.process_time(), time.perf_counter()
            res = mrnea.retime(robot, program, grid=grid)
            runs.append((time.perf_counter() - t0, time.process_time() - c0, res))
        runs.sort(key=lambda r: r[0])
        wall, _, med = runs[len(runs) // 2]
        out.append({"label": label, "wall": wall, "fastest": runs[0][0],
                    "cpu": statistics.median(r[1] for r in runs), "timings": med.timings,
                    "points": sum(p.s.size for p in med.phase),
                    "solves": med.summary()["toppra_solves"], "margin": med.margin,
                    "duration": med.duration, "original": med.original_duration})
    print("  retime done", file=sys.stderr)
    return out


def retime_table(res: list[dict], repeats: int) -> str:
    """The section's Markdown table."""
    head = ["case", "grid points", "median [ms]", "fastest [ms]", "CPU [ms]",
            "constraints (spline + mRNEA; rows)", "TOPP-RA", "sampling", "verification",
            "solves", "duration [s] (program)", "< 0.5 s"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in res:
        t = {k: 1e3 * v for k, v in r["timings"].items()}
        lines.append("| " + " | ".join([
            r["label"], str(r["points"]), f"{1e3 * r['wall']:.0f}", f"{1e3 * r['fastest']:.0f}",
            f"{1e3 * r['cpu']:.0f}", f"{t['coefficients']:.1f}; {t['rows']:.1f}",
            f"{t['toppra']:.1f}", f"{t['sampling']:.1f}", f"{t['verification']:.1f}",
            str(r["solves"]), f"{r['duration']:.3f} ({r['original']:.3f})",
            "yes" if r["wall"] < TARGET else "no"]) + " |")
    return (f"`mrnea.retime(robot, (t, q), method=\"toppra\")`, the verifying simulation "
            f"included: median of {repeats} runs after a warm-up, the split (ms) of that run. "
            "Constraints: the spline and the one batched mRNEA call; the rows, their "
            "linearisation and the speed lag. The Puma cases are the issue's (400 grid points, "
            "target < 0.5 s).\n\n" + "\n".join(lines))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeats", type=int, default=None)
    args = ap.parse_args()
    repeats = args.repeats or (3 if args.quick else 15)
    print(retime_table(retime_section(repeats), repeats))


if __name__ == "__main__":
    main()
