"""Solve H qdd = rhs by Cholesky (H symmetric positive definite), checking every pivot.

Usage: ``status = cholesky_solve(H, rhs, L, x)`` fills ``x`` (n,) using ``L`` (n, n) as scratch
(its strict lower triangle holds the factor, its diagonal the factor's reciprocal pivots);
``status`` is OK or the index of the first pivot that is not positive relative to the largest
diagonal entry of H (a singular or indefinite H: for example a massless moving tip link).
H and rhs are not modified. ``status = solve_forward(model, status, H, u, tau, L, rhs, qdd)``
is forward dynamics once a pass has filled H and u' (Eq. 2): qdd from ``H qdd = tau - u'``.

On a tree, ``solve_forward`` factors ``H = L^T L`` in the tree's order instead
(:func:`ltl_solve`, Featherstone's LTL: Rigid Body Dynamics Algorithms, 2008, Sec. 6.5): L is
lower triangular with ``L_ik = 0`` unless joint k carries link i (k in κ(i) ∪ {i}), the
sparsity of H itself (H_ik = 0 when neither joint carries the other), so the factor has no
fill-in and costs ``sum_i d_i^2 / 2`` multiply-adds (d_i: the number of joints carrying link
i) instead of a dense ``n^3 / 6``: for two 7-joint arms on one torso joint, about a third. A
serial chain keeps the dense Cholesky, operation for operation (its results bit for bit those
before trees).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import finite
from mrnea.kernels.layout import INTO_CALLER, JIT, TREE, parent
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW

PIVOT_TOL = 1e-13  # a pivot below PIVOT_TOL * max(diag H) counts as zero


@nb.njit(**JIT)
def cholesky_solve(H, rhs, L, x):
    """x = H^-1 rhs via H = L L^T; returns OK or the index of the failing pivot."""
    n = H.shape[0]
    dmax = 0.0
    for i in range(n):
        dmax = max(dmax, H[i, i])
    tol = PIVOT_TOL * dmax
    for j in range(n):
        s = H[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > tol:  # also catches NaN
            return j
        inv = 1.0 / np.sqrt(s)  # one division per pivot: the column and both solves multiply
        L[j, j] = inv  # the diagonal of the scratch L holds 1 / L_jj
        for i in range(j + 1, n):
            s = H[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s * inv
    for i in range(n):  # L y = rhs
        s = rhs[i]
        for k in range(i):
            s -= L[i, k] * x[k]
        x[i] = s * L[i, i]
    for i in range(n - 1, -1, -1):  # L^T x = y
        s = x[i]
        for k in range(i + 1, n):
            s -= L[k, i] * x[k]
        x[i] = s * L[i, i]
    return OK


@nb.njit(**JIT)
def ltl_solve(model, H, rhs, L, x):
    """x = H^-1 rhs via H = L^T L in the tree's order (module docstring); returns OK or the
    index of the failing pivot (as :func:`cholesky_solve`, the pivots taken tip to base).

    Featherstone's LTL factorisation and its two back-substitutions (RBDA Tables 6.3, 6.4):
    every inner loop walks the parent array λ from a joint towards the base. ``L``'s entries
    L_ik, k in κ(i) ∪ {i}, hold the factor (its diagonal the reciprocal pivots); the others
    are not read or written. H and rhs are not modified.
    """
    n = H.shape[0]
    dmax = 0.0
    for i in range(n):
        dmax = max(dmax, H[i, i])
        k = i
        while k >= 0:  # H's entries that the factor can hold: k carries i
            L[i, k] = H[i, k]
            k = parent(model, k)
    tol = PIVOT_TOL * dmax
    for k in range(n - 1, -1, -1):
        s = L[k, k]
        if not s > tol:  # also catches NaN
            return k
        inv = 1.0 / np.sqrt(s)
        L[k, k] = inv
        i = parent(model, k)
        while i >= 0:  # row k of L: L_ki = H_ki / L_kk
            L[k, i] *= inv
            i = parent(model, i)
        i = parent(model, k)
        while i >= 0:  # H_ij -= L_ki L_kj for i, j in κ(k), j carrying i
            a = L[k, i]
            j = i
            while j >= 0:
                L[i, j] -= a * L[k, j]
                j = parent(model, j)
            i = parent(model, i)
    for i in range(n):
        x[i] = rhs[i]
    for i in range(n - 1, -1, -1):  # L^T y = rhs, tip to base
        x[i] *= L[i, i]
        j = parent(model, i)
        while j >= 0:
            x[j] -= L[i, j] * x[i]
            j = parent(model, j)
    for i in range(n):  # L x = y, base to tip
        j = parent(model, i)
        while j >= 0:
            x[i] -= L[i, j] * x[j]
            j = parent(model, j)
        x[i] *= L[i, i]
    return OK


@nb.njit(**INTO_CALLER)
def solve_forward(model, status, H, u, tau, L, rhs, qdd):
    """Forward dynamics once a pass has filled H and u' and returned ``status`` (Eq. 2): qdd
    (n,) from ``H qdd = tau - u'``, ``rhs`` (n,) and ``L`` (n, n) as scratch: the dense
    Cholesky on a serial chain, the tree's LTL on a tree (module docstring). Returns NONFINITE
    if tau holds NaN or inf, else the pass's status if it is not OK, else OK, OVERFLOW or the
    index of the failing pivot."""
    if not finite(tau):
        return NONFINITE
    if status != OK:
        return status
    for i in range(tau.shape[0]):
        rhs[i] = tau[i] - u[i]
    if model[0, TREE]:
        status = ltl_solve(model, H, rhs, L, qdd)
    else:
        status = cholesky_solve(H, rhs, L, qdd)
    return status if status != OK or finite(qdd) else OVERFLOW
