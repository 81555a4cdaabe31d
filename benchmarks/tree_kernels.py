"""The compiled mRNEA pass (``mrnea``: H and u') and inverse dynamics (``rnea``) of several
checkouts on a tree, Baxter (n = 17, loaded as benchmarks/tree_fd.py loads it), interleaved in
one process: per call [ns]. The method of benchmarks/serial_kernels.py (each checkout's
``src/mrnea`` a package of its own, a compiled loop of 1000 calls, thread CPU time, best of 5,
ROUNDS rounds alternating the versions); the checkouts must load trees (after issue 25).
Usage, from a checkout's root::

    PYTHONPATH=$PWD/src python benchmarks/tree_kernels.py ROUNDS A/src/mrnea B/src/mrnea [...]
"""

from __future__ import annotations

import importlib
import shutil
import statistics
import sys
import tempfile
from pathlib import Path

import numpy as np
from serial_kernels import best_ns, copy_package, loops
from tree_fd import TREES, robots_dir


def calls_of(pkg: str) -> dict:
    """Zero-argument calls (1000 kernel calls each) of one version, by call name."""
    M = importlib.import_module(pkg)
    K, S, ID, lay = (importlib.import_module(pkg + mod) for mod in (
        ".kernels.mrnea", ".kernels.solve", ".kernels.rnea", ".kernels.layout"))
    _, loop_hb, _, loop_id = loops(K, S, ID)  # serial_kernels.py's compiled loops

    path, tips = TREES["baxter"]
    r = M.load_urdf(robots_dir() / path, tip=tips)
    n = r.n
    m, ws = lay.compile_model(r), lay.entry_scratch(n)
    q, qd, qdd = np.random.default_rng(0).standard_normal((3, n))
    H, u, tau = np.empty((n, n)), np.empty(n), np.empty(n)
    return {"mrnea": lambda a=(m, q, qd, H, u, ws): loop_hb(*a, 1000),
            "rnea": lambda a=(m, q, qd, qdd, tau, ws): loop_id(*a, 1000)}


def main() -> None:
    rounds, sources = int(sys.argv[1]), [Path(a).resolve() for a in sys.argv[2:]]
    tmp = Path(tempfile.mkdtemp(prefix="mrnea_versions_"))
    sys.path.insert(0, str(tmp))
    pkgs = [f"mrnea_v{i}" for i in range(len(sources))]
    for src, pkg in zip(sources, pkgs, strict=True):
        copy_package(src, tmp, pkg)
    calls = {pkg: calls_of(pkg) for pkg in pkgs}
    for c in calls.values():
        for f in c.values():
            f()  # compile
    res = {(pkg, k): [] for pkg in pkgs for k in ("mrnea", "rnea")}
    for _ in range(rounds):
        for k in ("mrnea", "rnea"):
            for pkg in pkgs:
                res[pkg, k].append(best_ns(calls[pkg][k]))
    for i, src in enumerate(sources):
        print(f"v{i}: {src}")
    for k in ("mrnea", "rnea"):
        med = [statistics.median(res[pkg, k]) for pkg in pkgs]
        print(f"| baxter {k} | " + " | ".join(f"{a:.0f} ({min(res[p, k]):.0f})"
                                             for a, p in zip(med, pkgs, strict=True))
              + " | " + " | ".join(f"{a / med[0]:.3f}" for a in med[1:]) + " |")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
