"""A command's first run on a fresh install: Numba's on-disk cache empty (``NUMBA_CACHE_DIR`` set
to a new temporary folder), the command run as a real process, its wall and CPU time measured,
and every kernel Numba compiles listed with its signature and compile time (Numba's event API,
``numba:compile``), heaviest first.

Usage::

    python benchmarks/first_run.py demo --out /tmp/x --quiet
    python benchmarks/first_run.py --warm demo --out /tmp/y --quiet   # a second run, cache kept
    python benchmarks/first_run.py --suite        # issue 22's first runs, each on an empty cache
    python benchmarks/first_run.py --no-ahead demo --out /tmp/z --quiet  # no second process
    python benchmarks/first_run.py --ahead demo --out /tmp/w --quiet     # with it, at any load

``--suite`` runs, each as a fresh process on its own empty cache: ``mrnea demo``, ``mrnea check``,
``mrnea simulate`` and ``mrnea retime`` on the Puma 560's pick program and the README's library
example (:data:`LIBRARY`), and prints one line per run (CPU, wall, kernels, the heaviest).
``--no-ahead`` (first) sets ``MRNEA_AHEAD=0``: the command compiles alone, without the second
process that compiles the simulation's later kernels on a cold cache (mrnea/cli/ahead.py);
``--ahead`` sets ``MRNEA_AHEAD=1``: with it, whatever the machine's load. The
CPU counts that process too (it is the command's child, ended and reaped at its exit); the
kernel list is the command's own process's.

Prints one JSON object: the command, wall [s], CPU [s] (user + system of the process and its
children, the compile-ahead process included), ``own_cpu_s`` (the command's process alone:
its critical path when the second process has a core of its own), the compile total [s] and
the kernels (name, signature, seconds; ``self_s``: the
seconds less those of the kernels compiled inside it, i.e. its own typing, lowering and LLVM work
on everything linked into it; ``end_s``: when its compile ended, seconds after the command's
interpreter started running mrnea, so the list reads as a timeline). On a shared machine
wall times are noisy; CPU times are the steadier figure. docs/performance.md quotes its numbers.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHILD = r"""
import json, sys, time
from numba.core import event

T0 = time.perf_counter()
events = []
stack = []  # per open compile: [start time, seconds of its direct children]

class Record(event.Listener):
    def on_start(self, ev):
        stack.append([time.perf_counter(), 0.0])
    def on_end(self, ev):
        t0, children = stack.pop()
        t = time.perf_counter() - t0
        if stack:
            stack[-1][1] += t
        d = ev.data or {}
        disp = d.get("dispatcher")
        name = getattr(getattr(disp, "py_func", None), "__qualname__", str(disp))
        mod = getattr(getattr(disp, "py_func", None), "__module__", "")
        events.append({"kernel": f"{mod}.{name}", "signature": str(d.get("args")),
                       "seconds": round(t, 3), "self_s": round(t - children, 3),
                       "nested": len(stack), "end_s": round(time.perf_counter() - T0, 2)})

event.register("numba:compile", Record())
code = 0
try:
    if sys.argv[1:2] == ["--python"]:
        exec(sys.argv[2])
    else:
        from mrnea_launcher import main  # the command's entry point, as `mrnea` runs it
        sys.argv = ["mrnea", *sys.argv[1:]]
        main()
except SystemExit as exc:  # the command's exit code, kept for the process's
    code = exc.code if isinstance(exc.code, int) else int(exc.code is not None)
finally:
    import resource
    ru = resource.getrusage(resource.RUSAGE_SELF)  # before the exit reaps the second process
    sys.stderr.write("\nFIRST_RUN_EVENTS " + json.dumps(events) + "\n")
    sys.stderr.write(f"FIRST_RUN_SELF_CPU {ru.ru_utime + ru.ru_stime}\n")
sys.exit(code)
"""

# The README's library example (the section "The library"), on the built-in Puma 560: single
# states through the fast path, one batch, the achievable accelerations and a simulation
LIBRARY = """
import numpy as np
import mrnea
robot = mrnea.robots.puma560()
q, qd, qdd = np.zeros(robot.n), np.zeros(robot.n), np.ones(robot.n)
tau = mrnea.inverse_dynamics(robot, q, qd, qdd)
H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
qdd = mrnea.forward_dynamics(robot, q, qd, tau)
W = mrnea.joint_reactions(robot, q, qd, qdd)
Q = np.random.default_rng(0).uniform(-1, 1, (10_000, robot.n))
TAU = mrnea.inverse_dynamics(robot, Q, 0 * Q, 0 * Q)
res = mrnea.achievable_accelerations(robot, q, qd, 20 * np.ones(robot.n))
from mrnea.trajectory import quintic
t, q_cmd = quintic([q, q + 1.0], dt=0.005, velocity_limit=1.0, acceleration_limit=2.0)
print(mrnea.simulate(robot, q_cmd, dt=0.005).verdict())
"""


def suite(out: str) -> list[list[str]]:
    """The first runs of issue 22 (module docstring); outputs under the folder ``out``."""
    pick = str(Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml")
    return [["demo", "--out", f"{out}/demo", "--quiet"],
            ["check", "puma560", pick, "--quiet"],
            ["simulate", "puma560", pick, "--out", f"{out}/simulate", "--quiet"],
            ["retime", "puma560", pick, "--out", f"{out}/retime", "--quiet"],
            ["--python", LIBRARY]]


def run(args: list[str], cache: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": cache, **_AHEAD}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", CHILD, *args], env=env, capture_output=True,
                         text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    events: list = []
    own = float("nan")
    for line in res.stderr.splitlines():
        if line.startswith("FIRST_RUN_EVENTS "):
            events = json.loads(line[len("FIRST_RUN_EVENTS "):])
        elif line.startswith("FIRST_RUN_SELF_CPU "):
            own = float(line.split()[1])
    top = [e for e in events if e["nested"] == 0]  # nested compiles are inside their caller's
    command = "library example" if args[0] == "--python" else "mrnea " + " ".join(args)
    return {"command": command, "exit": res.returncode, "wall_s": round(wall, 2),
            "cpu_s": round(cpu, 2), "own_cpu_s": round(own, 2),
            "compile_s": round(sum(e["seconds"] for e in top), 2),
            "kernels_compiled": len(events),
            "kernels": sorted(events, key=lambda e: -e["seconds"]),
            "stderr_tail": res.stderr.splitlines()[-3:] if res.returncode not in (0, 1) else []}


_AHEAD: dict[str, str] = {}  # MRNEA_AHEAD: "0" with --no-ahead, "1" with --ahead


def main() -> None:
    args = sys.argv[1:]
    if args[:1] in (["--no-ahead"], ["--ahead"]):
        _AHEAD["MRNEA_AHEAD"] = "0" if args[0] == "--no-ahead" else "1"
        args = args[1:]
    if args == ["--suite"]:
        with tempfile.TemporaryDirectory(prefix="mrnea-first-run-") as out:
            for cmd in suite(out):
                with tempfile.TemporaryDirectory(prefix="mrnea-numba-cache-") as cache:
                    r = run(cmd, cache)
                top = sorted((e for e in r["kernels"] if e["nested"] == 0),
                             key=lambda e: -e["seconds"])[:4]
                print(json.dumps({k: r[k] for k in ("command", "exit", "cpu_s", "own_cpu_s",
                                                    "wall_s", "kernels_compiled")}
                                 | {"heaviest": [(e["kernel"].rsplit(".", 1)[-1], e["seconds"])
                                                 for e in top]}), flush=True)
        return
    warm = bool(args) and args[0] == "--warm"
    args = args[1:] if warm else args
    with tempfile.TemporaryDirectory(prefix="mrnea-numba-cache-") as cache:
        if warm:
            run(args, cache)  # fills the cache
        print(json.dumps(run(args, cache), indent=1))


if __name__ == "__main__":
    main()
