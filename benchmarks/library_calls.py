"""Warm per-call times of the library's achievable and simulation calls on the Puma 560 (the
README's library example and ``mrnea check``/``simulate``'s path), for a before/after comparison
of changes that must not slow them: run it once per checkout, e.g.

    PYTHONPATH=/path/to/other/src python benchmarks/library_calls.py
    PYTHONPATH=$PWD/src python benchmarks/library_calls.py

Prints one JSON object, seconds per call: the process's CPU time (``time.process_time``, every
thread's: the batch runs on Numba's; a loaded machine's descheduling does not inflate it as it
does the wall), the least of 15 rounds of at least 0.2 s each, after a warm-up call that
compiles or loads the kernels: ``achievable`` one state's
:func:`mrnea.achievable_accelerations` (hybrid), ``achievable_batch`` the same for 1,000 states,
``step`` one :func:`mrnea.achievable.achievable_step`, ``simulate`` :func:`mrnea.simulate` of
examples/puma_pick.toml with its wrench (every cycle with its reactions, the program's
requirement and the derived arrays, no file written), and the load average before and after.
"""

from __future__ import annotations

import json
import os
import time
import timeit
from pathlib import Path

import numpy as np

import mrnea
from mrnea.achievable import achievable_step

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    load0 = os.getloadavg()[0]
    prog = mrnea.load_program(ROOT / "examples" / "puma_pick.toml")
    robot = prog.load_robot()
    n = robot.n
    rng = np.random.default_rng(0)
    q, qd, qdd = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), 20 * rng.uniform(-1, 1, n)
    Q, QD, QDD = (rng.uniform(-1, 1, (1000, n)) for _ in range(3))
    q_cmd = prog.q_cmd
    contenders = {
        "achievable": lambda: mrnea.achievable_accelerations(robot, q, qd, qdd),
        "achievable_batch": lambda: mrnea.achievable_accelerations(robot, Q, QD, 20 * QDD),
        "step": lambda: achievable_step(robot, q, qd, q + qd * 0.004, qd, 0.004),
        "simulate": lambda: mrnea.simulate(robot, q_cmd, dt=prog.dt, f_ext=prog.f_ext,
                                           f_ext_point=prog.f_ext_point),
    }
    best = {}
    for name, fn in contenders.items():
        fn()  # compiles or loads the kernels
        timer = timeit.Timer(fn, timer=time.process_time)
        number = max(1, int(0.2 / timer.timeit(1)))
        best[name] = min(timer.repeat(15, number)) / number
    print(json.dumps({"mrnea": str(Path(mrnea.__file__).parent), "K": int(q_cmd.shape[0]),
                      **{k: float(f"{v:.4g}") for k, v in best.items()},
                      "load": [round(load0, 2), round(os.getloadavg()[0], 2)]}))


if __name__ == "__main__":
    main()
