"""The comparison forward-dynamics kernels of several checkouts, interleaved in one process: per
call [ns] of CRBA (``fd_crba``: H, u' and the solve; ``crba_bias``: H and u'), Walker-Orin
method 1 (``fd_walker_orin``; ``walker_orin``: H and u') and the articulated-body algorithm
(``aba``) on the Puma 560, the SDT and the UR5 (where example-robot-data is installed).

The method of benchmarks/serial_kernels.py (each checkout's ``src/mrnea`` copied as a package
of its own, every version called from a compiled loop of 1000 calls on the same state,
alternating call by call, thread CPU time, best of 5 per round; medians over the rounds)::

    python benchmarks/fd_kernels.py ROUNDS OLD/src/mrnea NEW/src/mrnea [...]

prints per call and version the median (and best) over the rounds [ns] and each version's
median over the first's (docs/performance.md, section 19). ``FD_CALLS=aba,fd_crba`` limits
the calls timed.
"""

from __future__ import annotations

import importlib
import os
import shutil
import site
import statistics
import sys
import tempfile
from pathlib import Path

import numba as nb
import numpy as np
from serial_kernels import best_ns, copy_package

CALLS = ("fd_crba", "crba_bias", "fd_walker_orin", "walker_orin", "aba")


def loops(E, C, W, A):
    """Compiled loops of N calls of one version's fd_crba, crba_bias, fd_walker_orin,
    walker_orin and aba."""
    fdc, cb, fdw, wo, aba = E.fd_crba, C.crba_bias, E.fd_walker_orin, W.walker_orin, A.aba

    @nb.njit
    def loop_fdc(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += fdc(m, q, qd, tau, None, None, qdd, ws)
        return s

    @nb.njit
    def loop_cb(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += cb(m, q, qd, None, None, H, u, ws)
        return s

    @nb.njit
    def loop_fdw(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += fdw(m, q, qd, tau, None, None, qdd, ws)
        return s

    @nb.njit
    def loop_wo(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += wo(m, q, qd, None, None, H, u, ws)
        return s

    @nb.njit
    def loop_aba(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += aba(m, q, qd, tau, None, None, qdd, ws)
        return s
    return dict(zip(CALLS, (loop_fdc, loop_cb, loop_fdw, loop_wo, loop_aba), strict=True))


def calls_of(pkg: str, urdf: Path | None, names: list[str]) -> dict:
    """Zero-argument calls (1000 kernel calls each) of one version, by (robot, call)."""
    M = importlib.import_module(pkg)
    robots = importlib.import_module(pkg + ".robots")
    lay = importlib.import_module(pkg + ".kernels.layout")
    E, C, W, A = (importlib.import_module(f"{pkg}.kernels.{mod}")
                  for mod in ("engines", "crba", "walker_orin", "aba"))
    lp = loops(E, C, W, A)
    out = {}
    chains = {"puma": robots.puma560(), "sdt": robots.sdt()}
    if urdf is not None:
        chains["ur5"] = M.load_urdf(urdf)
    for name, r in chains.items():
        q, qd, tau = (np.random.default_rng(0).standard_normal((3, r.n)))
        m, ws, n = lay.compile_model(r), lay.entry_scratch(r.n), r.n
        a = (m, q, qd, tau, np.empty(n), np.empty((n, n)), np.empty(n), ws)
        for call in names:
            out[name, call] = lambda f=lp[call], a=a: f(*a, 1000)
    return out


def main() -> None:
    rounds, sources = int(sys.argv[1]), [Path(a).resolve() for a in sys.argv[2:]]
    names = os.environ.get("FD_CALLS", ",".join(CALLS)).split(",")
    urdf = next((p for p in (Path(sp) / "cmeel.prefix/share/example-robot-data/robots"
                             / "ur_description/urdf/ur5_robot.urdf"
                             for sp in site.getsitepackages()) if p.is_file()), None)
    tmp = Path(tempfile.mkdtemp(prefix="mrnea_versions_"))
    sys.path.insert(0, str(tmp))
    pkgs = [f"mrnea_v{i}" for i in range(len(sources))]
    for src, pkg in zip(sources, pkgs, strict=True):
        copy_package(src, tmp, pkg)
    calls = {pkg: calls_of(pkg, urdf, names) for pkg in pkgs}
    for c in calls.values():
        for f in c.values():
            assert f() == -1000  # compile; every call returns OK (-1)
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


if __name__ == "__main__":
    main()
