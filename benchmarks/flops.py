"""Floating-point operations of mrnea's forward-dynamics kernels, counted by running their source.

Usage: ``NUMBA_DISABLE_JIT=1 python benchmarks/flops.py [--n 2 4 8]`` prints JSON (run.py runs it
in a subprocess). With the JIT off the Numba kernels are plain Python functions, so they can be
run on a float that counts: every number they see is a :class:`Flop`, a float whose +, -, *, /
each add one to the count, and the kernel modules' ``np`` is a shim whose ``empty``/``zeros``
give arrays of Flops and whose ``sqrt`` counts one flop and ``sin``/``cos`` one transcendental
each. Comparisons, ``min``/``max``, ``abs`` and sign changes are not counted.

The counts are of the operations as the source writes them, every execution of every line:
an upper bound on what the compiled code does (LLVM may merge a repeated product, never adds
one), exact for the algorithm as written, whatever the kernels look like the day it runs.

Stages: ``kinematics`` (every call of ``kinematics``), ``Cholesky solve`` (every call of
``cholesky_solve``), and, for the mRNEA pass, each line of kernels/mrnea.py attributed to the
section its ``# forward pass`` / ``# backward pass`` comment opens; the rest (``tau - u'``) is
``other``.
"""

from __future__ import annotations

import argparse
import inspect
import json
import math
import os
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

METHODS = ("mrnea", "walker_orin", "crba", "aba")
_MARKER = re.compile(r"#\s*(forward pass|backward pass)\b")


class _Count:
    """Where counts go: flops per stage, transcendental functions per stage."""

    def __init__(self) -> None:
        self.flops: dict[str, int] = defaultdict(int)
        self.trig: dict[str, int] = defaultdict(int)
        self.override: str | None = None  # set while inside kinematics / cholesky_solve
        self.line_stage = "other"

    @property
    def stage(self) -> str:
        return self.override or self.line_stage


COUNT = _Count()


class Flop(float):
    """A float that counts the arithmetic it takes part in (module docstring)."""

    __slots__ = ()

    def __neg__(self) -> Flop:
        return Flop(-float(self))

    def __pos__(self) -> Flop:
        return self

    def __abs__(self) -> Flop:
        return Flop(abs(float(self)))


def _counted(name: str):
    base = getattr(float, name)

    def op(a, b):
        r = base(a, b)
        if r is NotImplemented:
            return r
        COUNT.flops[COUNT.stage] += 1
        return Flop(r)

    op.__name__ = name
    return op


for _name in ("__add__", "__radd__", "__sub__", "__rsub__", "__mul__", "__rmul__",
              "__truediv__", "__rtruediv__", "__pow__", "__rpow__"):
    setattr(Flop, _name, _counted(_name))


def _flops(shape, dtype=float) -> np.ndarray:
    if dtype in (float, np.float64):
        return np.full(shape, Flop(0.0), dtype=object)
    return np.zeros(shape, dtype=dtype)


class _CountingNumpy:
    """``np`` for the kernel modules: arrays of Flops, counted sqrt, sin and cos."""

    empty = staticmethod(_flops)
    zeros = staticmethod(_flops)

    def __getattr__(self, name: str):
        return getattr(np, name)

    @staticmethod
    def sqrt(x):
        COUNT.flops[COUNT.stage] += 1
        return Flop(math.sqrt(x))

    @staticmethod
    def sin(x):
        COUNT.trig[COUNT.stage] += 1
        return Flop(math.sin(x))

    @staticmethod
    def cos(x):
        COUNT.trig[COUNT.stage] += 1
        return Flop(math.cos(x))

    @staticmethod
    def isfinite(x) -> bool:
        return math.isfinite(x)

    @staticmethod
    def sign(x):
        return Flop(math.copysign(1.0, x) if x != 0 else 0.0)


def _staged(stage: str, fn):
    def wrapper(*args):
        prev, COUNT.override = COUNT.override, COUNT.override or stage
        try:
            return fn(*args)
        finally:
            COUNT.override = prev

    return wrapper


def _instrument() -> dict:
    """Patch the kernel modules (this process only) and return the forward-dynamics kernels."""
    if os.environ.get("NUMBA_DISABLE_JIT") != "1":
        sys.exit("flops.py needs NUMBA_DISABLE_JIT=1 (run.py sets it)")
    from mrnea.kernels import aba, common, crba, engines, layout, rnea, solve, walker_orin
    from mrnea.kernels import mrnea as mr

    mods = (aba, common, crba, engines, layout, mr, rnea, solve, walker_orin)
    shim = _CountingNumpy()
    for mod in mods:
        mod.np = shim
        if hasattr(mod, "kinematics"):
            mod.kinematics = _staged("kinematics", common.kinematics)
        if hasattr(mod, "cholesky_solve"):
            mod.cholesky_solve = _staged("Cholesky solve", solve.cholesky_solve)
    # line -> stage for every function of kernels/mrnea.py that has the pass markers
    stages = {}
    for fn in vars(mr).values():
        if inspect.isfunction(fn) and fn.__module__ == mr.__name__:
            lines, start = inspect.getsourcelines(fn)
            current = None
            for k, text in enumerate(lines):
                m = _MARKER.search(text)
                current = m.group(1) if m else current
                if current:
                    stages[(fn.__code__, start + k)] = current
    mr_file = mr.__file__

    def tracer(frame, event, arg):
        if event != "call" or frame.f_code.co_filename != mr_file:
            return None

        def local(frame, event, arg):
            if event == "line":
                COUNT.line_stage = stages.get((frame.f_code, frame.f_lineno), "other")
            return local

        return local

    sys.settrace(tracer)
    return {"mrnea": mr.fd_mrnea, "walker_orin": engines.fd_walker_orin,
            "crba": engines.fd_crba, "aba": aba.aba}


def _as_flops(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return np.vectorize(Flop, otypes=[object])(a) if a.size else a.astype(object)


def count(kernel, robot, rng: np.random.Generator) -> dict:
    """Flops (per stage) and transcendental calls of one forward-dynamics call."""
    n = robot.n
    from mrnea.kernels.layout import compile_model, entry_scratch
    from mrnea.kernels.status import OK

    model = _as_flops(compile_model(robot))
    q, qd, tau = (_as_flops(x) for x in rng.uniform(-1.0, 1.0, (3, n)))
    qdd = _flops(n)
    COUNT.flops.clear()
    COUNT.trig.clear()
    COUNT.line_stage = "other"
    ws = entry_scratch(n)  # arrays of Flops: the kernel modules' np is the counting one
    status = kernel(model, q, qd, tau, None, None, qdd, ws)  # free motion, as the public call
    assert status == OK, f"kernel status {status}"
    return {"flops": dict(COUNT.flops), "trig": dict(COUNT.trig),
            "total": sum(COUNT.flops.values()), "trig_total": sum(COUNT.trig.values())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[], help="random chains of these sizes")
    ap.add_argument("--seed", type=int, default=0, help="seed of the random chains (run.py's)")
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).parent))
    import models

    kernels = _instrument()
    rng = np.random.default_rng(1)
    erd = models.erd_dir()
    import mrnea

    out = {"ur5": {m: count(k, mrnea.load_urdf(erd / "ur_description" / "urdf" /
                                                "ur5_robot.urdf"), rng)
                   for m, k in kernels.items()}}
    chains = models.random_chains(args.n, args.seed)
    out["random"] = {}
    for n in args.n:
        counts = {m: count(k, chains[n], rng) for m, k in kernels.items()}
        out["random"][str(n)] = {m: c["total"] for m, c in counts.items()}
        out["random"][str(n)]["mrnea stages"] = counts["mrnea"]["flops"]
    sys.settrace(None)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
