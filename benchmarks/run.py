"""Per-call cost of mrnea's forward dynamics against pinocchio.aba, side by side in one process.

Usage: ``python benchmarks/run.py [--out docs/benchmark-latest.md]``

The machine is shared and noisy, so the two are timed in alternation, many rounds, and each
figure is the minimum over rounds; the ratio mrnea / pinocchio is the result (below 1: faster).
Every call goes through the public Python API of each library, as a user calls it.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
import timeit
from pathlib import Path

import numpy as np

import mrnea
from mrnea.dynamics import forward_dynamics

try:
    import pinocchio as pin
except ImportError:  # pragma: no cover - the benchmark needs the test extra
    sys.exit("benchmarks need Pinocchio: pip install -e '.[test]'")


def example_robot_data_dir() -> Path:
    import site

    for p in site.getsitepackages():
        d = Path(p) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if d.is_dir():
            return d
    sys.exit("example-robot-data not found: pip install -e '.[test]'")


def best(fn, number: int, rounds: int) -> float:
    return min(timeit.repeat(fn, number=number, repeat=rounds)) / number


def per_call(robot: mrnea.Robot, urdf: Path, number: int = 2000, rounds: int = 15) -> dict:
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    rng = np.random.default_rng(0)
    q, qd, tau = rng.uniform(-1, 1, size=(3, robot.n))
    methods = ("mrnea", "aba", "crba", "walker_orin")
    for m in methods:  # compile (or load from cache) before timing
        forward_dynamics(robot, q, qd, tau, method=m)
    results = {m: [] for m in (*methods, "pinocchio.aba")}
    for _ in range(rounds):  # alternate so that noise hits every entry alike
        results["pinocchio.aba"].append(best(lambda: pin.aba(model, data, q, qd, tau), number, 1))
        for m in methods:
            results[m].append(
                best(lambda m=m: forward_dynamics(robot, q, qd, tau, method=m), number, 1))
    return {k: min(v) for k, v in results.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, help="also write the Markdown table to this file")
    args = ap.parse_args()
    erd = example_robot_data_dir()
    cases = [("UR5 (6 DoF)", erd / "ur_description" / "urdf" / "ur5_robot.urdf")]
    t0 = time.perf_counter()
    lines = [
        "| robot | call | time per call [us] | ratio to pinocchio.aba |",
        "|---|---|---:|---:|",
    ]
    for label, urdf in cases:
        robot = mrnea.load_urdf(urdf)
        res = per_call(robot, urdf)
        ref = res["pinocchio.aba"]
        for k, v in res.items():
            name = k if k.startswith("pinocchio") else f"forward_dynamics(method='{k}')"
            lines.append(f"| {label} | `{name}` | {v * 1e6:.2f} | {v / ref:.2f} |")
    table = "\n".join(lines)
    header = (f"Machine: {platform.processor() or platform.machine()}, {platform.system()}, "
              f"Python {platform.python_version()}, NumPy {np.__version__}, "
              f"Pinocchio {pin.__version__}, mrnea {mrnea.__version__}; "
              f"{time.perf_counter() - t0:.0f} s.\n")
    print(header)
    print(table)
    if args.out:
        args.out.write_text(header + "\n" + table + "\n")


if __name__ == "__main__":
    main()
