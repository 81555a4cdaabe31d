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
from numba.extending import overload

from mrnea.kernels.common import finite
from mrnea.kernels.layout import INTO_CALLER, JIT, PARENT, model_type_is_chain, tree_of
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

    Featherstone's LTL factorisation and its two back-substitutions (RBDA Tables 6.3, 6.4) on
    the model's parent array λ (:func:`ltl_factor`, :func:`ltl_substitute`). ``L``'s entries
    L_ik, k in κ(i) ∪ {i}, hold the factor (its diagonal the reciprocal pivots); the others
    are not read or written. H and rhs are not modified.
    """
    lam = model[1:, PARENT]
    n = H.shape[0]
    for i in range(n):
        k = i
        while k >= 0:  # H's entries that the factor can hold: k carries i
            L[i, k] = H[i, k]
            k = int(lam[k])
    status = ltl_factor(lam, L)
    if status == OK:
        ltl_substitute(lam, L, rhs, x)
    return status


@nb.njit(**JIT)
def ltl_factor(lam, L):
    """Factor H = L^T L in place, in the order of the parent array ``lam`` (m,) (lam[k] < k,
    -1 for a root; integers, or exact floats as the model's PARENT column): on entry L (m, m)
    holds H_ik for every k on i's path to its root (k = i, lam[i], lam[lam[i]], ...), on exit
    the factor there (its diagonal the reciprocal pivots); no other entry is read or written.
    Returns OK or the index of the first pivot (tip to base) not above PIVOT_TOL times the
    largest diagonal entry of H. Used by :func:`ltl_solve` (a tree's forward dynamics) and by
    the drive solve on a tree's free joints (kernels/drive_solve.py, docs/notation.md λ_F)."""
    m = L.shape[0]
    dmax = 0.0
    for i in range(m):
        dmax = max(dmax, L[i, i])
    tol = PIVOT_TOL * dmax
    for k in range(m - 1, -1, -1):
        s = L[k, k]
        if not s > tol:  # also catches NaN
            return k
        inv = 1.0 / np.sqrt(s)
        L[k, k] = inv
        i = int(lam[k])
        while i >= 0:  # row k of L: L_ki = H_ki / L_kk
            L[k, i] *= inv
            i = int(lam[i])
        i = int(lam[k])
        while i >= 0:  # H_ij -= L_ki L_kj for i, j in κ(k), j carrying i
            a = L[k, i]
            j = i
            while j >= 0:
                L[i, j] -= a * L[k, j]
                j = int(lam[j])
            i = int(lam[i])
    return OK


@nb.njit(**JIT)
def ltl_substitute(lam, L, rhs, x):
    """x (m,) = (L^T L)^-1 rhs for a factor made by :func:`ltl_factor` on the parent array
    ``lam``: L^T y = rhs tip to base, then L x = y base to tip."""
    m = L.shape[0]
    for i in range(m):
        x[i] = rhs[i]
    for i in range(m - 1, -1, -1):  # L^T y = rhs, tip to base
        x[i] *= L[i, i]
        j = int(lam[i])
        while j >= 0:
            x[j] -= L[i, j] * x[i]
            j = int(lam[j])
    for i in range(m):  # L x = y, base to tip
        j = int(lam[i])
        while j >= 0:
            x[i] -= L[i, j] * x[j]
            j = int(lam[j])
        x[i] *= L[i, i]


def model_solve(model, H, rhs, L, qdd):
    """qdd from ``H qdd = rhs`` (L: scratch): the dense Cholesky for a serial chain's model, the
    tree's LTL for a tree's, chosen by the model's type (kernels/layout.py ``tree_of``), so that
    a chain does not compile the tree's. Python body for NUMBA_DISABLE_JIT; compiled code uses
    the overload."""
    if tree_of(model) is None:
        return cholesky_solve(H, rhs, L, qdd)
    return ltl_solve(model, H, rhs, L, qdd)


@overload(model_solve, inline="always")
def _model_solve_overload(model, H, rhs, L, qdd):
    if model_type_is_chain(model):
        return lambda model, H, rhs, L, qdd: cholesky_solve(H, rhs, L, qdd)
    return lambda model, H, rhs, L, qdd: ltl_solve(model, H, rhs, L, qdd)


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
    status = model_solve(model, H, rhs, L, qdd)
    return status if status != OK or finite(qdd) else OVERFLOW


# --- a Cholesky factor updated one joint at a time (kernels/drive_solve.py on long chains) -------
# L (m, m) lower triangular, L L^T = H[idx[:m], idx[:m]] with the joints in the order they were
# added (not in index order); its diagonal holds L_aa itself. Appending or removing one joint
# costs O(m^2) instead of the O(m^3) of a fresh factorisation (docs/design.md, "A 1000-joint
# chain"). Every inner loop reads L row by row.


@nb.njit(**JIT)
def dot(x, y, k):
    """sum_{j<k} x_j y_j in four partial sums: without fastmath a single running sum waits for
    each addition (about 4 cycles an element); four interleave (rounding differs from the
    single sum's, as from any other order)."""
    s0 = s1 = s2 = s3 = 0.0
    k4 = k - k % 4
    for j in range(0, k4, 4):
        s0 += x[j] * y[j]
        s1 += x[j + 1] * y[j + 1]
        s2 += x[j + 2] * y[j + 2]
        s3 += x[j + 3] * y[j + 3]
    for j in range(k4, k):
        s0 += x[j] * y[j]
    return (s0 + s1) + (s2 + s3)


@nb.njit(**JIT)
def factor_append(H, L, idx, m, i):
    """Add joint i as row and column m of the factor: row m solves L_11 l = H[idx[:m], i]
    (forward substitution), L_mm = sqrt(H_ii - l.l). Returns False, leaving the factor as it
    was, if that pivot is not above PIVOT_TOL times the largest diagonal entry of the grown
    block (as :func:`cholesky_solve`)."""
    dmax = H[i, i]
    for a in range(m):
        dmax = max(dmax, H[idx[a], idx[a]])
    row = L[m]
    for a in range(m):
        row[a] = (H[idx[a], i] - dot(row, L[a], a)) / L[a, a]
    s = H[i, i] - dot(row, row, m)
    if not s > PIVOT_TOL * dmax:  # also catches NaN
        return False
    row[m] = np.sqrt(s)
    idx[m] = i
    return True


@nb.njit(**JIT)
def factor_remove(L, idx, m, p, c, s):
    """Drop position p (joint idx[p]) from the factor of size m, leaving that of size m - 1.
    With L = [[L11, 0, 0], [l21, l22, 0], [L31, l32, L33]] the factor without row and column p
    is [[L11, 0], [L31, L33']], L33' L33'^T = L33 L33^T + l32 l32^T: a rank-one update by
    Givens rotations (orthogonal: stable). Row by row: rotation j (cosine c[j], sine s[j]) is
    made on row j's diagonal and turns the pair (L_ij, x_i) of each row i below it; each row
    moves up one and its trailing part left one as it is finished. ``c``, ``s``: (m,) scratch."""
    for i in range(p + 1, m):
        xi = L[i, p]  # row i of l32, turned into the columns after p
        for k in range(p):
            L[i - 1, k] = L[i, k]  # L31 keeps its columns
        for j in range(p + 1, i):
            lij = L[i, j]
            L[i - 1, j - 1] = c[j] * lij + s[j] * xi
            xi = c[j] * xi - s[j] * lij
        lii = L[i, i]
        r = np.sqrt(lii * lii + xi * xi)
        c[i], s[i] = lii / r, xi / r
        L[i - 1, i - 1] = r
        idx[i - 1] = idx[i]


@nb.njit(**JIT)
def factor_solve(L, m, rhs, x):
    """x (m,) = (L L^T)^-1 rhs for the updated factor L (m, m): two triangular solves."""
    factor_forward(L, 0, m, rhs, x)
    factor_backward(L, m, x)


@nb.njit(**JIT)
def factor_forward(L, start, m, rhs, y):
    """Rows start .. m - 1 of L y = rhs (forward substitution), y[:start] already solved:
    after ``factor_append`` only the new last row is left when the others' right-hand side
    has not changed (or changed by a known multiple of the appended row's l, added to y by
    the caller: kernels/drive_solve.py)."""
    for a in range(start, m):
        y[a] = (rhs[a] - dot(L[a], y, a)) / L[a, a]


@nb.njit(**JIT)
def factor_backward(L, m, x):
    """x (m,) = L^-T x in place (back substitution; column a of L^T being row a of L)."""
    for a in range(m - 1, -1, -1):
        x[a] /= L[a, a]
        for k in range(a):
            x[k] -= L[a, k] * x[a]
