"""Walker-Orin method 1: H and u' from n + 1 RNEA passes (the paper's baseline).

Usage: ``walker_orin(model, q, qd, fext, pe, H, u, ws)``, the same contract as ``mrnea``.

u' is the RNEA with zero acceleration (velocity, gravity and external wrench in); column k of H
is the RNEA with unit acceleration of joint k, no velocity, no gravity and no external wrench.
The link poses do not depend on the acceleration, so the kinematics pass runs once and the
Newton-Euler recursion n + 1 times. Forward dynamics through it: kernels/engines.py.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import finite, kinematics, sized
from mrnea.kernels.layout import ENTRY_ALLOC, force_buffers, pose_buffers, tree_of, tree_scratch
from mrnea.kernels.rnea import newton_euler
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW, SIZE


@nb.njit(**ENTRY_ALLOC)
def walker_orin(model, q, qd, fext, pe, H, u, ws):
    """H (n, n) and u' (n,) of one state by n + 1 Newton-Euler passes; returns a status.
    Poses and forces go to the scratch ``ws`` (kernels/layout.py).

    A serial chain's model (its type: kernels/layout.py ``tree_of``, ``tree_scratch``) runs the
    chain's copies of the kinematics and of ``newton_euler`` (``ws=None``: the tree's branches
    compiled out and the scratch not among the n + 1 calls' arguments, each array of which is
    passed as about a dozen scalars: docs/performance.md section 19); a tree's the tree's."""
    if not sized(model, q, qd, qd):
        return SIZE
    if not (finite(q) and finite(qd) and finite(fext) and finite(pe)):
        return NONFINITE
    n = q.shape[0]
    R, o, z, c, Ic = pose_buffers(ws, n)
    kinematics(model, q, R, o, z, c, Ic, tree_of(model))
    f, nm = force_buffers(ws, n)
    g = (model[0, 0], model[0, 1], model[0, 2])
    branches = tree_scratch(model, ws)
    newton_euler(model, R, o, z, c, Ic, qd, None, g, fext, pe, u, f, nm, branches)
    zero_n = np.zeros(n)
    unit = np.zeros(n)
    col = np.empty(n)
    for k in range(n):
        unit[k] = 1.0
        newton_euler(model, R, o, z, c, Ic, zero_n, unit, (0.0, 0.0, 0.0), None, None, col, f,
                     nm, branches)
        H[:, k] = col
        unit[k] = 0.0
    return OK if finite(H) and finite(u) else OVERFLOW
