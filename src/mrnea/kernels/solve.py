"""Solve H qdd = rhs by Cholesky (H symmetric positive definite), checking every pivot.

Usage: ``status = cholesky_solve(H, rhs, L, x)`` fills ``x`` (n,) using ``L`` (n, n) as scratch
(its strict lower triangle holds the factor, its diagonal the factor's reciprocal pivots);
``status`` is OK or the index of the first pivot that is not positive relative to the largest
diagonal entry of H (a singular or indefinite H: for example a massless moving tip link).
H and rhs are not modified. ``status = solve_forward(status, H, u, tau, L, rhs, qdd)`` is forward
dynamics once a pass has filled H and u' (Eq. 2): qdd from ``H qdd = tau - u'``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import finite
from mrnea.kernels.layout import INTO_CALLER, JIT
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


@nb.njit(**INTO_CALLER)
def solve_forward(status, H, u, tau, L, rhs, qdd):
    """Forward dynamics once a pass has filled H and u' and returned ``status`` (Eq. 2): qdd
    (n,) from ``H qdd = tau - u'``, ``rhs`` (n,) and ``L`` (n, n) as scratch. Returns NONFINITE
    if tau holds NaN or inf, else the pass's status if it is not OK, else OK, OVERFLOW or the
    index of the failing pivot."""
    if not finite(tau):
        return NONFINITE
    if status != OK:
        return status
    for i in range(tau.shape[0]):
        rhs[i] = tau[i] - u[i]
    status = cholesky_solve(H, rhs, L, qdd)
    return status if status != OK or finite(qdd) else OVERFLOW
