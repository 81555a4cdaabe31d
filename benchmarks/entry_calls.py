"""The public single-state calls from Python (the fast path of mrnea.dynamics), several checkouts
interleaved in one process, with Pinocchio's calls for reference: per call [ns] of
``inverse_dynamics``, ``mass_matrix_and_bias``, ``forward_dynamics`` and ``joint_reactions`` on
the Puma 560 (one state, float64 arrays of shape (6,)), against ``pinocchio.rnea``,
``pinocchio.crba`` + ``pinocchio.nonLinearEffects`` (H and the bias) and ``pinocchio.aba``
on the same chain (benchmarks/models.py ``to_pinocchio``).

Each checkout's ``src/mrnea`` is imported as a package of its own (benchmarks/serial_kernels.py
``copy_package``), so that every version runs in the same process on the same states, call by
call alternating: ROUNDS rounds, each timing every version once per call (``timeit``, 20,000
calls, process CPU time, best of 3). Usage, from a checkout's root::

    python benchmarks/entry_calls.py ROUNDS OLD/src/mrnea NEW/src/mrnea [...]

prints per call and version the median and best over the rounds [ns] and each version's median
over the first's.
"""

from __future__ import annotations

import importlib
import statistics
import sys
import tempfile
import time
import timeit
from functools import partial
from pathlib import Path

import numpy as np
import pinocchio as pin

import mrnea

sys.path.insert(0, str(Path(__file__).resolve().parent))
from models import to_pinocchio  # benchmarks/models.py: the same chain, joint by joint
from serial_kernels import copy_package

CALLS = ("inverse_dynamics", "mass_matrix_and_bias", "forward_dynamics", "joint_reactions")


def timer(fn) -> float:
    """Seconds per call of ``fn()``: process CPU time, best of 3 runs of 20,000 calls."""
    return min(timeit.repeat(fn, timer=time.process_time, number=20_000, repeat=3)) / 20_000


def main() -> None:
    rounds, srcs = int(sys.argv[1]), [Path(s).resolve() for s in sys.argv[2:]]
    tmp = Path(tempfile.mkdtemp(prefix="mrnea-entry-calls-"))
    sys.path.insert(0, str(tmp))
    rng = np.random.default_rng(0)
    q, qd, qdd = (rng.uniform(-1, 1, 6) for _ in range(3))
    tau = mrnea.inverse_dynamics(mrnea.robots.puma560(), q, qd, qdd)
    cases = {}
    for v, src in enumerate(srcs):
        copy_package(src, tmp, f"mrnea_v{v}")
        m = importlib.import_module(f"mrnea_v{v}")
        r = m.robots.puma560()
        cases[f"v{v} inverse_dynamics"] = partial(m.inverse_dynamics, r, q, qd, qdd)
        cases[f"v{v} mass_matrix_and_bias"] = partial(m.mass_matrix_and_bias, r, q, qd)
        cases[f"v{v} forward_dynamics"] = partial(m.forward_dynamics, r, q, qd, tau)
        cases[f"v{v} joint_reactions"] = partial(m.joint_reactions, r, q, qd, qdd)
    model = to_pinocchio(mrnea.robots.puma560())
    data = model.createData()

    def pin_hb() -> None:
        pin.crba(model, data, q)
        pin.nonLinearEffects(model, data, q, qd)

    cases["pinocchio rnea"] = partial(pin.rnea, model, data, q, qd, qdd)
    cases["pinocchio crba + nonLinearEffects"] = pin_hb
    cases["pinocchio aba"] = partial(pin.aba, model, data, q, qd, tau)
    for fn in cases.values():
        fn()  # compiles or loads the kernels
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(rounds):
        for k, fn in cases.items():
            times[k].append(timer(fn))
    for call in CALLS:
        base = statistics.median(times[f"v0 {call}"])
        for v in range(len(srcs)):
            t = times[f"v{v} {call}"]
            print(f"{call:22s} v{v}: median {statistics.median(t) * 1e9:6.0f} ns, best "
                  f"{min(t) * 1e9:6.0f} ns, median / v0's {statistics.median(t) / base:.3f}")
    for k, t in times.items():
        if k.startswith("pinocchio"):
            print(f"{k:34s} median {statistics.median(t) * 1e9:6.0f} ns, "
                  f"best {min(t) * 1e9:6.0f} ns")


if __name__ == "__main__":
    main()
