"""Bearing loads: a joint's reaction wrench split along and across its axis.

Usage: ``bearing_loads(wrench, axes, out)`` fills ``out`` (6, K, n) from the reaction wrenches
(K, n, 6) of a run (kernels/rnea.py ``reactions``: ``w = [f; n]`` that link i-1 exerts on link i,
joint frame) and the joints' unit axes (n, 3), same frame; ``split(w, a)`` gives one joint's
six loads at one cycle, in the order of ``out``'s rows::

    |f|,  |f . a|,  |f - (f . a) a|,  |n|,  |n . a|,  |n - (n . a) a|

force, axial force, radial force, moment, axial moment, bending moment [N, N m].

Rounding: the three-term sums are added in the order NumPy gave them when these loads were NumPy
code (``np.linalg.norm(x, axis=2)``: ``(x0 x0 + x1 x1) + x2 x2``; ``np.einsum("kij,ij->ki")``:
``(x0 a0 + x2 a2) + x1 a1``), so the loads, their peaks in a run's summary and the sweep rows are
the same bits as before they were compiled (tests/test_run_peaks.py checks both orders against
NumPy itself).
"""

from __future__ import annotations

import math

import numba as nb

from mrnea.kernels.layout import INLINE, JIT

FORCE, AXIAL_FORCE, RADIAL_FORCE, MOMENT, AXIAL_MOMENT, BENDING_MOMENT = range(6)


@nb.njit(**INLINE)
def _along_across(x0, x1, x2, a0, a1, a2):
    """|x . a| and |x - (x . a) a| of a 3-vector x and a unit axis a."""
    along = (x0 * a0 + x2 * a2) + x1 * a1
    d0, d1, d2 = x0 - along * a0, x1 - along * a1, x2 - along * a2
    return abs(along), math.sqrt((d0 * d0 + d1 * d1) + d2 * d2)


@nb.njit(**INLINE)
def split(w, a):
    """The six bearing loads (module docstring) of one wrench w (6,) about the unit axis a (3,)."""
    f0, f1, f2, n0, n1, n2 = w[0], w[1], w[2], w[3], w[4], w[5]
    axial_f, radial_f = _along_across(f0, f1, f2, a[0], a[1], a[2])
    axial_n, bending = _along_across(n0, n1, n2, a[0], a[1], a[2])
    return (math.sqrt((f0 * f0 + f1 * f1) + f2 * f2), axial_f, radial_f,
            math.sqrt((n0 * n0 + n1 * n1) + n2 * n2), axial_n, bending)


@nb.njit(**JIT)
def bearing_loads(wrench, axes, out):
    """Every cycle's bearing loads: out[:, k, i] = split(wrench[k, i], axes[i])."""
    K, n = wrench.shape[0], wrench.shape[1]
    for k in range(K):
        for i in range(n):
            loads = split(wrench[k, i], axes[i])
            for c in range(6):
                out[c, k, i] = loads[c]
