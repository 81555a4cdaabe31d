"""Benchmark (not a test): what a CLI command costs before and around its work, on a filled
Numba cache: interpreter start, imports, loading the cached kernels.

Usage: ``python benchmarks/cli_startup.py [--repeats 5]``.

Each command runs ``--repeats`` times as a fresh ``python -m mrnea ...`` process (the kernels
already compiled and cached by a first run that is not counted); per command it prints the best
wall time and the best CPU time (user + system of the process) [s], and, from one extra run with
``python -X importtime``, how many modules the process imported and which of the heavy
libraries among them (a library is listed if any of its modules was imported). On a shared
machine wall times are noisy; the best CPU time is the steadier figure. docs/performance.md
("Start-up", "A command's start-up") quotes its output.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
HEAVY = ("scipy.optimize", "scipy.signal", "scipy.stats", "scipy.spatial", "scipy.ndimage",
         "scipy.interpolate", "scipy.linalg", "matplotlib", "dask", "distributed", "pandas",
         "toppra", "trimesh", "jsonschema", "numba", "scipy")


def commands(folder: Path) -> list[tuple[str, list[str]]]:
    """The measured commands: (label, arguments after ``python -m mrnea``)."""
    return [
        ("python -c pass (interpreter alone)", []),
        ("mrnea --help", ["--help"]),
        ("mrnea info puma560", ["info", "puma560"]),
        ("mrnea check puma560 missing.toml (error: no such file)",
         ["check", "puma560", str(folder / "missing.toml")]),
        ("mrnea check examples/puma_pick.toml (980 cycles)",
         ["check", str(EXAMPLES / "puma_pick.toml")]),
        ("mrnea simulate examples/puma_pick.toml --no-3d (report, figures)",
         ["simulate", str(EXAMPLES / "puma_pick.toml"), "--out", "{out}", "--no-3d", "--quiet"]),
    ]


def once(args: list[str], folder: Path, i: int, importtime: bool = False) -> tuple[float, float,
                                                                                  str]:
    """One fresh process: (wall [s], CPU [s], stderr)."""
    args = [a.replace("{out}", str(folder / f"out{i}")) for a in args]
    argv = [sys.executable, *(["-X", "importtime"] if importtime else []),
            *(["-m", "mrnea", *args] if args else ["-c", "pass"])]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(argv, capture_output=True, text=True, cwd=folder)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode not in (0, 1, 2):
        raise SystemExit(f"{argv} failed ({res.returncode}):\n{res.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, res.stderr


def imported(stderr: str) -> tuple[int, list[str]]:
    """The number of modules ``-X importtime`` lists, and the heavy libraries among them."""
    names = [line.rsplit("|", 1)[1].strip() for line in stderr.splitlines()
             if line.startswith("import time:") and "|" in line]
    names = [n for n in names if n != "package"]
    heavy = []
    for h in HEAVY:
        if any(n == h or n.startswith(h + ".") for n in names):
            if not any(k.startswith(h + ".") for k in heavy):  # scipy after its submodules
                heavy.append(h)
    return len(names), heavy


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="mrnea-startup-") as tmp:
        folder = Path(tmp)
        rows = []
        for label, args in commands(folder):
            once(args, folder, 0)  # fills the Numba cache if empty; not counted
            runs = [once(args, folder, i + 1) for i in range(a.repeats)]
            n, heavy = imported(once(args, folder, a.repeats + 1, importtime=True)[2])
            rows.append((label, min(r[0] for r in runs), min(r[1] for r in runs), n, heavy))
            print(f"  {label}: done", file=sys.stderr)
    load = os.getloadavg()[0]
    print(f"best of {a.repeats} fresh processes, load average {load:.1f} at the end\n")
    print("| command | wall [s] | CPU [s] | modules imported | heavy libraries imported |")
    print("| --- | ---: | ---: | ---: | --- |")
    for label, wall, cpu, n, heavy in rows:
        print(f"| `{label}` | {wall:.2f} | {cpu:.2f} | {n} | {', '.join(heavy) or '-'} |")


if __name__ == "__main__":
    main()
