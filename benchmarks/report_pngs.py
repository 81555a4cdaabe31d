"""The demo's six PNGs drawn one after another (:func:`mrnea.report.drawing.png_bytes`) against
:func:`mrnea.report.pngs.draw_pngs` (a share in a forked child), alternately, on the same
figures: wall and CPU (this process and its reaped children) per round, and whether the bytes
agree. The figures are those ``mrnea demo`` writes: the four of :func:`mrnea.report.plot_result`
and Fig. 3 at the report's 100 dpi, and Fig. 3 again at 110 dpi (``fig3.png``).

Usage::

    python benchmarks/report_pngs.py [ROUNDS] [--fork]   # default 3; docs/performance.md section 7

``draw_pngs`` forks only when a CPU is idle at that instant (``mrnea.resources.idle_cpu``);
``--fork`` forks whatever the load (to measure the split itself on a loaded machine). Each round
says whether it forked.
"""

from __future__ import annotations

import os
import resource
import sys
import time


def _cpu() -> float:
    a = resource.getrusage(resource.RUSAGE_SELF)
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def main(rounds: int = 3, force: bool = False) -> None:
    from mrnea import robots, simulate
    from mrnea.report import fig3, plot_result, pngs
    from mrnea.report.drawing import DPI, png_bytes
    from mrnea.report.pngs import draw_pngs

    idle = pngs.idle_cpu
    forked: list[bool] = []
    pngs.idle_cpu = lambda: forked.append(force or idle()) or forked[-1]
    from mrnea.robots.sdt_profile import training_profile

    robot = robots.sdt()
    _, q_cmd = training_profile(0.005)
    res = simulate(robot, q_cmd, 0.005)
    figs = [*plot_result(res).values(), fig3(robot, res.t, res.q, res.qd, res.qdd)]
    jobs = [(f, DPI) for f in figs] + [(figs[-1], 110)]
    for fig, dpi in jobs:  # fonts and caches loaded before timing
        png_bytes(fig, dpi)
    for r in range(rounds):
        c, t = _cpu(), time.perf_counter()
        one = [png_bytes(fig, dpi) for fig, dpi in jobs]
        c1, t1 = _cpu(), time.perf_counter()
        two = draw_pngs(jobs)
        c2, t2 = _cpu(), time.perf_counter()
        print(f"round {r + 1}: one process {t1 - t:.2f} s wall, {c1 - c:.2f} s CPU; draw_pngs "
              f"{t2 - t1:.2f} s wall, {c2 - c1:.2f} s CPU; same bytes {one == two}; forked "
              f"{forked[-1]}; load {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--fork"]
    main(int(args[0]) if args else 3, "--fork" in sys.argv[1:])
