"""Time per cycle of ``mrnea.simulate`` on the SDT and the Puma 560 (issue 11's budget for the
exact per-cycle solve: at most 1.5 x the cycle before it).

Usage: ``PYTHONPATH=<tree>/src python benchmarks/cycle_timing.py [--rounds R] [--label L]``;
prints per case the best wall time and the best process CPU time (every thread) of one
``simulate`` call over R rounds, divided by its number of cycles [us]. To compare two trees, run
it on each in turn, several times, alternating (this machine is shared: the CPU time is the
steadier of the two).

Cases: the SDT's training profile (the demo, dt = 5 ms: the yaw drive saturates; Coulomb
friction on) and the same with generous limits; a fast Puma 560 program (1000 cycles of
models.py's ``puma_program`` at dt = 2 ms: its drives saturate most of the time) and a
slow one with generous limits (20 000 cycles); each in hybrid and paper mode.
"""

from __future__ import annotations

import argparse
import time

from models import puma_program

import mrnea
from mrnea.robots.sdt_profile import training_profile
from mrnea.simulate import simulate


def cases() -> dict[str, tuple]:
    sdt, puma = mrnea.robots.sdt(), mrnea.robots.puma560()
    q_sdt = training_profile(0.005)[1]
    out = {}
    for mode in ("hybrid", "paper"):
        out[f"sdt demo ({mode})"] = (sdt, q_sdt, 0.005, mode)
        out[f"sdt generous ({mode})"] = (sdt.with_actuators(effort_limit=1e9), q_sdt, 0.005,
                                         mode)
        out[f"puma fast ({mode})"] = (puma, puma_program(1000, 0.002), 0.002, mode)
        out[f"puma generous ({mode})"] = (puma.with_actuators(effort_limit=1e9),
                                          puma_program(20_000, 0.002), 0.002, mode)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--label", default="")
    args = ap.parse_args()
    cs = cases()
    for robot, q, dt, mode in cs.values():  # compile (first run) and warm up
        simulate(robot, q[:50], dt, mode=mode)
    for name, (robot, q, dt, mode) in cs.items():
        wall, cpu = [], []
        for _ in range(args.rounds):
            t0, c0 = time.perf_counter(), time.process_time()
            res = simulate(robot, q, dt, mode=mode)
            cpu.append((time.process_time() - c0) / res.K * 1e6)
            wall.append((time.perf_counter() - t0) / res.K * 1e6)
        print(f"{args.label}\t{name:24s}\twall {min(wall):6.3f} us\tcpu {min(cpu):6.3f} us")


if __name__ == "__main__":
    main()
