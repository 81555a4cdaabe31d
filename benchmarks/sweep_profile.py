"""Benchmark (not a test): where a sweep run's CPU goes, compiled kernels against Python (issue 29).

Usage: ``python benchmarks/sweep_profile.py [--runs 100] [--rounds 3] [--out FILE]``.

A sweep row is ``run_case`` (mrnea/sweep/rows.py): the variant of the robot, ``simulate``, the
summary and the flat row. This script runs the same four steps on SDT variants of the demo's
training profile (8401 cycles at 5 ms; the grid of benchmarks/sweep.py), on one thread as in a
sweep worker, and times each step with ``time.thread_time`` (CPU of this thread: a machine shared
with other jobs shows as wall time, not as CPU here). Every compiled kernel that Python calls
(each Numba dispatcher in an ``mrnea`` module's globals: the simulation loop, the program's
requirement, the motor side, the summary's pass...) is wrapped with a timer after the kernels are
loaded, so each step splits into its compiled part and the Python around it. The Python share of
a run is the CPU outside every compiled kernel; the share outside the simulation loop alone
(``simulate_cycles``, as benchmarks/sweep.py's ``gil_share`` counts it) is printed too. Each
round's rows are checked equal to ``run_case``'s. The best round (least CPU) is reported.
"""

from __future__ import annotations

import argparse
import collections
import os
import platform
import sys
import time

import numba
from numba.core.registry import CPUDispatcher

from mrnea.robots import sdt
from mrnea.robots.sdt_profile import training_program
from mrnea.simulate import simulate
from mrnea.sweep import check_grid
from mrnea.sweep.rows import run_case, summary_row, tune_worker
from mrnea.sweep.variants import variant

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep import grid_of  # benchmarks/sweep.py: the same grid

STEPS = ("variant", "simulate", "summary", "row")
SPENT: collections.Counter[str] = collections.Counter()  # CPU [s] in each kernel, by name
STEP = ["variant"]  # the step running now, for the kernels' time by step
BY_STEP: collections.Counter[str] = collections.Counter()


def timed(name: str, kernel):
    """``kernel`` with its thread CPU added to :data:`SPENT` and :data:`BY_STEP`."""
    def call(*args):
        t = time.thread_time()
        try:
            return kernel(*args)
        finally:
            dt = time.thread_time() - t
            SPENT[name] += dt
            BY_STEP[STEP[0]] += dt
    return call


def wrap_kernels() -> None:
    """Wrap every Numba dispatcher in an ``mrnea`` module's globals (kernels called from
    Python; those called from compiled code are compiled in)."""
    for mod_name, mod in list(sys.modules.items()):
        if not mod_name.startswith("mrnea") or mod is None:
            continue
        for attr, obj in list(vars(mod).items()):
            if isinstance(obj, CPUDispatcher):
                setattr(mod, attr, timed(attr, obj))


def one_round(robot, program, cases) -> tuple[dict[str, float], list]:
    """CPU [s] per step over all cases, and the rows."""
    cpu = dict.fromkeys(STEPS, 0.0)
    rows = []
    for params in cases:
        STEP[0] = "variant"
        t0 = time.thread_time()
        rob = variant(robot, **params)
        STEP[0] = "simulate"
        t1 = time.thread_time()
        res = simulate(rob, program.q_cmd, program.dt, mode=program.mode or "hybrid",
                       f_ext=program.f_ext, f_ext_point=program.f_ext_point)
        STEP[0] = "summary"
        t2 = time.thread_time()
        s = res.summary()
        STEP[0] = "row"
        t3 = time.thread_time()
        rows.append({"error": None, **summary_row(s)})
        t4 = time.thread_time()
        for step, a, b in zip(STEPS, (t0, t1, t2, t3), (t1, t2, t3, t4), strict=True):
            cpu[step] += b - a
    return cpu, rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    robot, program = sdt(), training_program()
    _, cases = check_grid(robot, grid_of(1000))
    cases = cases[:: max(1, len(cases) // args.runs)][: args.runs]
    numba.set_num_threads(1)  # as a sweep worker (a run calls no parallel kernel anyway)
    tune_worker(0, False)  # the heap settings of a sweep worker (glibc's mallopt)
    reference = [run_case(robot, program, c) for c in cases]  # also loads every kernel
    wrap_kernels()
    best = None
    for _ in range(args.rounds):
        SPENT.clear()
        BY_STEP.clear()
        cpu, rows = one_round(robot, program, cases)
        assert rows == reference or _same(rows, reference), "rows differ from run_case's"
        if best is None or sum(cpu.values()) < sum(best[0].values()):
            best = (cpu, dict(SPENT), dict(BY_STEP))
    cpu, spent, by_step = best
    total = sum(cpu.values())
    n = len(cases)
    lines = [f"Command: `python benchmarks/sweep_profile.py --runs {args.runs} --rounds "
             f"{args.rounds}`; {n} SDT variants x {program.name} ({program.K} cycles); "
             f"{platform.processor() or platform.machine()}, Numba {numba.__version__}; "
             f"load average {os.getloadavg()[0]:.1f} at the end. Best of {args.rounds} rounds.",
             "", f"CPU per run {1e3 * total / n:.2f} ms.", "",
             "| step | CPU per run [ms] | share | of which compiled [ms] | Python [ms] |",
             "|---|---:|---:|---:|---:|"]
    for step in STEPS:
        c, k = cpu[step] / n, by_step.get(step, 0.0) / n
        lines.append(f"| {step} | {1e3 * c:.2f} | {100 * cpu[step] / total:.1f} % | "
                     f"{1e3 * k:.2f} | {1e3 * (c - k):.2f} |")
    compiled = sum(spent.values())
    loop = spent.get("simulate_cycles", 0.0)
    lines += ["", "| compiled kernel called from Python | CPU per run [ms] | share of a run |",
              "|---|---:|---:|"]
    for name, s in sorted(spent.items(), key=lambda kv: -kv[1]):
        lines.append(f"| `{name}` | {1e3 * s / n:.3f} | {100 * s / total:.1f} % |")
    lines += ["", f"**Python share of a run: {100 * (1 - compiled / total):.1f} %** (outside "
              f"every compiled kernel); outside the simulation loop `simulate_cycles` alone: "
              f"{100 * (1 - loop / total):.1f} %."]
    text = "\n".join(lines)
    print(text)
    if args.out:
        with open(args.out, "w") as fh:
            fh.write(text + "\n")


def _same(a: list, b: list) -> bool:
    """Rows equal, NaN equal to NaN (``first_infeasible_time`` of a feasible run)."""
    def eq(x, y):
        return x == y or (isinstance(x, float) and isinstance(y, float) and x != x and y != y)
    return all(r.keys() == s.keys() and all(eq(r[k], s[k]) for k in r)
               for r, s in zip(a, b, strict=True))


if __name__ == "__main__":
    main()
