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
import sys
from pathlib import Path

import numba as nb
import numpy as np
from serial_kernels import compare, serial_states, ur5_urdf

CALLS = ("fd_crba", "crba_bias", "fd_walker_orin", "walker_orin", "aba")


def _fd_loop(f):
    """A compiled loop of N calls of a forward-dynamics kernel ``f(model, q, qd, tau, fext, pe,
    qdd, ws)``."""
    @nb.njit
    def loop(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += f(m, q, qd, tau, None, None, qdd, ws)
        return s
    return loop


def _hb_loop(f):
    """A compiled loop of N calls of an H-and-u' kernel ``f(model, q, qd, fext, pe, H, u,
    ws)``."""
    @nb.njit
    def loop(m, q, qd, tau, qdd, H, u, ws, N):
        s = 0
        for _ in range(N):
            s += f(m, q, qd, None, None, H, u, ws)
        return s
    return loop


def loops(E, C, W, A):
    """Compiled loops of N calls of one version's fd_crba, crba_bias, fd_walker_orin,
    walker_orin and aba."""
    return dict(zip(CALLS, (_fd_loop(E.fd_crba), _hb_loop(C.crba_bias),
                            _fd_loop(E.fd_walker_orin), _hb_loop(W.walker_orin),
                            _fd_loop(A.aba)), strict=True))


def calls_of(pkg: str, urdf: Path | None, names: list[str]) -> dict:
    """Zero-argument calls (1000 kernel calls each) of one version, by (robot, call)."""
    E, C, W, A = (importlib.import_module(f"{pkg}.kernels.{mod}")
                  for mod in ("engines", "crba", "walker_orin", "aba"))
    lp = loops(E, C, W, A)
    out = {}
    for name, m, q, qd, tau, ws in serial_states(pkg, urdf):
        n = q.size
        a = (m, q, qd, tau, np.empty(n), np.empty((n, n)), np.empty(n), ws)
        for call in names:
            out[name, call] = lambda f=lp[call], a=a: f(*a, 1000)
    return out


def main() -> None:
    names = os.environ.get("FD_CALLS", ",".join(CALLS)).split(",")
    urdf = ur5_urdf()
    compare(int(sys.argv[1]), [Path(a).resolve() for a in sys.argv[2:]],
            lambda pkg: calls_of(pkg, urdf, names), expect=-1000)  # every call OK (-1)


if __name__ == "__main__":
    main()
