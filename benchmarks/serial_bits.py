"""Serial kernels, bit for bit: every kernel's output on the Puma 560 and the SDT (specialised and
general models, with a wrench) computed in pure Python (NUMBA_DISABLE_JIT=1: the same IEEE
operations, no compilation), saved to an .npz. Run it in two checkouts and compare the files:
the tree kernels (issue 25) take none of their tree branches on a chain, so the chain's
operations and their order are unchanged and every array must be equal bit for bit.

Usage, in each checkout's root::

    NUMBA_DISABLE_JIT=1 PYTHONPATH=$PWD/src python benchmarks/serial_bits.py OUT.npz

then ``[k for k in a if not np.array_equal(a[k], b[k])]`` over ``a, b = np.load(A), np.load(B)``.
"""

from __future__ import annotations

import sys

import numba
import numpy as np


def _njit(*a, **k):  # as NUMBA_DISABLE_JIT's, keeping .py_func (which summary.py reads)
    if a and callable(a[0]):
        a[0].py_func = a[0]
        return a[0]

    def deco(f):
        f.py_func = f
        return f
    return deco


numba.njit = _njit

from mrnea.kernels.aba import aba  # noqa: E402 (after the patch above)
from mrnea.kernels.crba import crba_bias  # noqa: E402
from mrnea.kernels.kinematics import frames_ws, jacobian_ws  # noqa: E402
from mrnea.kernels.layout import compile_model, entry_scratch  # noqa: E402
from mrnea.kernels.mrnea import fd_mrnea, mrnea_ws  # noqa: E402
from mrnea.kernels.rnea import reactions_ws, rnea_ws  # noqa: E402
from mrnea.kernels.walker_orin import walker_orin  # noqa: E402
from mrnea.robots import puma560, sdt  # noqa: E402


def outputs() -> dict[str, np.ndarray]:
    out = {}
    rng = np.random.default_rng(0)
    for name, r in {"puma": puma560(), "sdt": sdt()}.items():
        n = r.n
        for spec in (True, False):
            m = compile_model(r, specialise=spec)
            for s in range(3):
                q, qd, qdd, tau = (rng.standard_normal(n) for _ in range(4))
                fe, pe = rng.standard_normal(6), rng.standard_normal(3)
                k = f"{name}{spec}{s}"
                ws = entry_scratch(n)
                out[k + "tau"] = np.empty(n)
                rnea_ws(m, q, qd, qdd, fe, pe, out[k + "tau"], ws, False)
                out[k + "rx"] = np.empty((n, 6))
                reactions_ws(m, q, qd, qdd, fe, pe, out[k + "rx"], ws, False)
                for tag, engine in (("mrnea", None), ("full", None), ("wo", walker_orin),
                                    ("crba", crba_bias)):
                    H, u = np.empty((n, n)), np.empty(n)
                    if engine is None:
                        mrnea_ws(m, q, qd, fe, pe, H, u, tag == "full", ws)
                    else:
                        engine(m, q, qd, fe, pe, H, u, ws)
                    out[k + tag + "H"], out[k + tag + "u"] = H, u
                out[k + "aba"], out[k + "fd"] = np.empty(n), np.empty(n)
                aba(m, q, qd, tau, fe, pe, out[k + "aba"], ws)
                fd_mrnea(m, q, qd, tau, fe, pe, out[k + "fd"], ws)
                out[k + "T"], out[k + "J"] = np.empty((n + 1, 4, 4)), np.empty((6, n))
                frames_ws(m, q, out[k + "T"], ws)
                jacobian_ws(m, q, pe, out[k + "J"], ws)
    return out


if __name__ == "__main__":
    np.savez(sys.argv[1], **outputs())
