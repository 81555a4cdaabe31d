"""The compiled mRNEA kernels of several checkouts, interleaved in one process: per call [ns]
of forward dynamics (``fd_mrnea``: the pass and the solve), of the pass alone (``mrnea``: H and
u'), of the Cholesky solve and of inverse dynamics (``rnea``), on the Puma 560, the SDT and the
UR5 (where example-robot-data is installed).

Each checkout's ``src/mrnea`` is copied into a temporary folder as a package of its own
(``mrnea_v0``, ``mrnea_v1``, ...: the imports renamed), so that every version runs in the same
process, on the same states, alternating call by call: ROUNDS rounds, each timing every
version once per call (a compiled loop of 1000 calls, thread CPU time, best of 5). Thread CPU
time and the interleaving make the ratio hold on a loaded machine, where wall-clock timings
of separate runs cannot resolve a few per cent (docs/performance.md, sections 13-14). The
entries are called from a compiled loop, so the Python wrapper's cost (about 1 us a call) is
not in these figures. Usage, from a checkout's root::

    python benchmarks/serial_kernels.py ROUNDS OLD/src/mrnea NEW/src/mrnea [...]

prints per call and version the median (and best) over the rounds [ns] and each version's
median over the first's.
"""

from __future__ import annotations

import importlib
import re
import shutil
import site
import statistics
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import numba as nb
import numpy as np


def copy_package(src: Path, dest: Path, name: str) -> None:
    """``src`` (a ``mrnea`` package folder) as the package ``name`` under ``dest``."""
    shutil.copytree(src, dest / name, ignore=shutil.ignore_patterns("__pycache__"))
    for f in (dest / name).rglob("*.py"):
        text = f.read_text()
        text = re.sub(r"\bfrom mrnea([. ])", rf"from {name}\1", text)
        text = re.sub(r"\bimport mrnea\.", f"import {name}.", text)
        text = re.sub(r"^import mrnea$", f"import {name} as mrnea", text, flags=re.M)
        f.write_text(text)


def loops(K, S, ID):
    """Compiled loops of N calls of one version's fd_mrnea, mrnea, cholesky_solve and rnea."""
    fd, hb, chol, rnea = K.fd_mrnea, K.mrnea, S.cholesky_solve, ID.rnea

    @nb.njit
    def loop_fd(m, q, qd, tau, out, ws, N):
        s = 0
        for _ in range(N):
            s += fd(m, q, qd, tau, None, None, out, ws)
        return s

    @nb.njit
    def loop_hb(m, q, qd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += hb(m, q, qd, None, None, H, u, ws)
        return s

    @nb.njit
    def loop_chol(H, rhs, L, x, N):
        s = 0
        for _ in range(N):
            s += chol(H, rhs, L, x)
        return s

    @nb.njit
    def loop_id(m, q, qd, qdd, tau, ws, N):
        s = 0
        for _ in range(N):
            s += rnea(m, q, qd, qdd, None, None, tau, ws)
        return s
    return loop_fd, loop_hb, loop_chol, loop_id


def serial_states(pkg: str, urdf: Path | None) -> Iterator[tuple]:
    """Per serial robot of one version (Puma 560, SDT, and the UR5 where ``urdf`` is given):
    its name, compiled model, a random state q, qd, tau (seed 0) and entry scratch."""
    M = importlib.import_module(pkg)
    robots = importlib.import_module(pkg + ".robots")
    lay = importlib.import_module(pkg + ".kernels.layout")
    chains = {"puma": robots.puma560(), "sdt": robots.sdt()}
    if urdf is not None:
        chains["ur5"] = M.load_urdf(urdf)
    for name, r in chains.items():
        q, qd, tau = np.random.default_rng(0).standard_normal((3, r.n))
        yield name, lay.compile_model(r), q, qd, tau, lay.entry_scratch(r.n)


def calls_of(pkg: str, urdf: Path | None) -> dict:
    """Zero-argument calls (1000 kernel calls each) of one version, by (robot, call)."""
    K = importlib.import_module(pkg + ".kernels.mrnea")
    S = importlib.import_module(pkg + ".kernels.solve")
    ID = importlib.import_module(pkg + ".kernels.rnea")
    loop_fd, loop_hb, loop_chol, loop_id = loops(K, S, ID)
    out = {}
    for name, m, q, qd, tau, ws in serial_states(pkg, urdf):
        n = q.size
        qdd, H, u, tau_id = np.empty(n), np.empty((n, n)), np.empty(n), np.empty(n)
        assert K.mrnea(m, q, qd, None, None, H, u, ws) == -1  # OK
        H0, L, x = H.copy(), np.empty((n, n)), np.empty(n)
        out[name, "fd_mrnea"] = lambda a=(m, q, qd, tau, qdd, ws): loop_fd(*a, 1000)
        out[name, "mrnea"] = lambda a=(m, q, qd, H, u, ws): loop_hb(*a, 1000)
        out[name, "cholesky"] = lambda a=(H0, tau, L, x): loop_chol(*a, 1000)
        out[name, "rnea"] = lambda a=(m, q, qd, tau, tau_id, ws): loop_id(*a, 1000)
    return out


def best_ns(f) -> float:
    best = np.inf
    for _ in range(5):
        t = time.thread_time_ns()
        f()
        best = min(best, time.thread_time_ns() - t)
    return best / 1000


def ur5_urdf() -> Path | None:
    """example-robot-data's UR5 URDF where it is installed, else None."""
    return next((p for p in (Path(sp) / "cmeel.prefix/share/example-robot-data/robots"
                             / "ur_description/urdf/ur5_robot.urdf"
                             for sp in site.getsitepackages()) if p.is_file()), None)


def compare(rounds: int, sources: list[Path], calls_of, expect: int | None = None) -> None:
    """Copy each checkout's package (:func:`copy_package`), make its calls (``calls_of(pkg)``:
    zero-argument calls by (robot, call)), compile them (each first call's sum must equal
    ``expect`` where given), time them interleaved for ``rounds`` rounds (:func:`best_ns`) and
    print the table of medians (and bests) [ns] and ratios."""
    tmp = Path(tempfile.mkdtemp(prefix="mrnea_versions_"))
    sys.path.insert(0, str(tmp))
    pkgs = [f"mrnea_v{i}" for i in range(len(sources))]
    for src, pkg in zip(sources, pkgs, strict=True):
        copy_package(src, tmp, pkg)
    calls = {pkg: calls_of(pkg) for pkg in pkgs}
    for c in calls.values():
        for f in c.values():
            s = f()  # compile
            assert expect is None or s == expect, s
    keys = list(calls[pkgs[0]])
    res = {(pkg, k): [] for pkg in pkgs for k in keys}
    for _ in range(rounds):
        for k in keys:
            for pkg in pkgs:
                res[pkg, k].append(best_ns(calls[pkg][k]))
    for i, src in enumerate(sources):
        print(f"v{i}: {src}")
    print("| call | " + " | ".join(f"v{i} median (best) [ns]" for i in range(len(pkgs)))
          + " | " + " | ".join(f"v{i} / v0" for i in range(1, len(pkgs))) + " |")
    for k in keys:
        med = [statistics.median(res[pkg, k]) for pkg in pkgs]
        best = [min(res[pkg, k]) for pkg in pkgs]
        print(f"| {k[0]} {k[1]} | " + " | ".join(f"{a:.0f} ({b:.0f})" for a, b in
                                                 zip(med, best, strict=True))
              + " | " + " | ".join(f"{a / med[0]:.3f}" for a in med[1:]) + " |")
    shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    urdf = ur5_urdf()
    compare(int(sys.argv[1]), [Path(a).resolve() for a in sys.argv[2:]],
            lambda pkg: calls_of(pkg, urdf))


if __name__ == "__main__":
    main()
