"""mRNEA: the paper's modified RNEA, the mass matrix H and bias u' in one pass (Eqs. 4-36).

Usage: ``mrnea(model, q, qd, fext, pe, H, u)`` fills ``H`` (n, n) and ``u`` (n,) so that the
joint efforts are ``tau = H @ qdd + u`` (Eq. 34) for every qdd.

The RNEA's recursion is split into the part that multiplies the accelerations and the part that
does not. Each centre-of-mass acceleration is ``sum_k b_ik qdd_k`` plus a velocity term (Eq. 5),
each link moment ``sum_k d_ik qdd_k`` plus ``d_i`` (Eqs. 9, 16-17), so every force and moment of
the backward pass is a 3 x n coefficient matrix times qdd plus a 3-vector (Eqs. 20-31):

* b_ik  (Eq. 5):  z_k x (c_i - o_k) for a revolute joint k <= i, z_k for a prismatic one.
* e_ik = m_i b_ik (Eq. 15), d_ik = I_i z_k (revolute k; 0 for prismatic) (Eq. 16).
* e_i = m_i (a_i^cm|qdd=0 - g) (Eq. 13), d_i = I_i wd_i|qdd=0 + w_i x I_i w_i (Eq. 17); the
  velocity-product sums of Eqs. 5 and 9 are evaluated by the usual recursion with qdd = 0.
* E_{(i+1)k} = sum_{j >= max(i+1, k)} e_jk: column k of the force link i+1 passes to link i
  (Eqs. 25-26: for k >= i+2 it is E_kk); E_{i+1} = sum_{j > i} e_j its velocity part (Eq. 23).
* n'_ia1 + n'_ia2 + n'_ia3 (Eqs. 29-31), accumulated tip to base into one 3 x n matrix ``M``:
  a1 adds d_ik + l_i x e_ik for k <= i (Eq. 24), a2 adds p*_i x E_{(i+1)k} for k <= i+1 (Eq. 25),
  a3 adds p*_i x E_kk for k >= i+2 (Eq. 26). n'_ic = n'_{(i+1)c} + n_ic (Eqs. 23, 28).
* h_ik = z_i . M[:, k] (Eq. 35), u'_i = z_i . n'_ic (Eq. 36).

Beyond the paper (which treats revolute joints): for a prismatic joint i the effort is the force
along its axis, so h_ik = z_i . E_ik and u'_i = z_i . E_i. Eq. 14 folds the external force f_e
into e_n; here it is E_{n+1} = f_e, acting at the point p_e, so that it enters through
p*_n = p_e - o_n exactly as Eq. 22 writes it, with n'_{(n+1)c} = n_e. Indices follow
kernels/rnea.py (docs/notation.md).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import (
    JIT,
    MASS,
    NONFINITE,
    OK,
    PRISMATIC,
    TYPE,
    add,
    cross,
    dot,
    finite,
    kinematics,
    mv,
    put,
    scale,
    sub,
    tip_point,
    vec,
    workspace,
)
from mrnea.kernels.solve import cholesky_solve


@nb.njit(**JIT)
def mrnea(model, q, qd, fext, pe, H, u):
    """H (n, n) and u' (n,) of one state, in one pass (module docstring); returns a status."""
    if not (finite(q) and finite(qd) and finite(fext) and finite(pe)):
        return NONFINITE
    n = q.shape[0]
    R, o, z, c, Ic = workspace(n)
    kinematics(model, q, R, o, z, c, Ic)
    g = (model[0, 0], model[0, 1], model[0, 2])

    buf = np.zeros(12 * n)  # e, d (n, 3); E, M (3, n), the last two starting at zero
    e = buf[:3 * n].reshape((n, 3))
    d = buf[3 * n:6 * n].reshape((n, 3))
    E = buf[6 * n:9 * n].reshape((3, n))  # column k: E_{(i+1)k} (Eqs. 25-26)
    M = buf[9 * n:].reshape((3, n))  # n'_ia1 + n'_ia2 + n'_ia3 (Eqs. 29-31)

    # forward pass: the velocity terms e_i (Eq. 13) and d_i (Eq. 17)
    w = (0.0, 0.0, 0.0)
    wd = (0.0, 0.0, 0.0)
    a_p = (0.0, 0.0, 0.0)
    o_p = (0.0, 0.0, 0.0)
    for i in range(n):
        zi, oi = vec(z, i), vec(o, i)
        p_star = sub(oi, o_p)
        a_o = add(a_p, add(cross(wd, p_star), cross(w, cross(w, p_star))))
        if model[i + 1, TYPE] == PRISMATIC:
            a_o = add(a_o, scale(cross(w, zi), 2.0 * qd[i]))
        else:
            wd = add(wd, scale(cross(w, zi), qd[i]))
            w = add(w, scale(zi, qd[i]))
        r_cm = sub(vec(c, i), oi)
        a_cm = add(a_o, add(cross(wd, r_cm), cross(w, cross(w, r_cm))))  # Eq. 5, qdd = 0
        put(e, i, scale(sub(a_cm, g), model[i + 1, MASS]))  # Eq. 13
        put(d, i, add(mv(Ic, i, wd), cross(w, mv(Ic, i, w))))  # Eq. 17
        a_p, o_p = a_o, oi

    # backward pass: E sums and n' coefficients, tip to base
    E_c = (fext[0], fext[1], fext[2])  # E_{i+1}: starts as f_{n+1} = f_e
    n_c = (fext[3], fext[4], fext[5])  # n'_{(i+1)c}: starts as n_e
    p_next = tip_point(o, R, n, pe)
    for i in range(n - 1, -1, -1):
        oi, ci, zi = vec(o, i), vec(c, i), vec(z, i)
        m_i = model[i + 1, MASS]
        l_i = sub(ci, oi)
        p_star = sub(p_next, oi)  # p*_i
        # a2 (k <= i+1, Eq. 25) and a3 (k >= i+2, Eq. 26): p*_i x E_{(i+1)k}
        for k in range(n):
            Ek = (E[0, k], E[1, k], E[2, k])
            t = cross(p_star, Ek)
            M[0, k] += t[0]
            M[1, k] += t[1]
            M[2, k] += t[2]
        # a1 (Eq. 24): d_ik + l_i x e_ik, k <= i; and E_{ik} = E_{(i+1)k} + e_ik
        for k in range(i + 1):
            zk = vec(z, k)
            if model[k + 1, TYPE] == PRISMATIC:
                e_ik = scale(zk, m_i)  # Eqs. 5, 15
                t = cross(l_i, e_ik)
            else:
                e_ik = scale(cross(zk, sub(ci, vec(o, k))), m_i)  # Eqs. 5, 15
                t = add(mv(Ic, i, zk), cross(l_i, e_ik))  # d_ik + l_i x e_ik (Eq. 16)
            M[0, k] += t[0]
            M[1, k] += t[1]
            M[2, k] += t[2]
            E[0, k] += e_ik[0]
            E[1, k] += e_ik[1]
            E[2, k] += e_ik[2]
        e_i = vec(e, i)
        # n_ic = d_i + l_i x e_i + p*_i x E_{i+1} (Eq. 23); n'_ic = n'_{(i+1)c} + n_ic (Eq. 28)
        n_c = add(n_c, add(add(vec(d, i), cross(l_i, e_i)), cross(p_star, E_c)))
        E_c = add(E_c, e_i)  # E_i
        if model[i + 1, TYPE] == PRISMATIC:
            for k in range(n):
                H[i, k] = zi[0] * E[0, k] + zi[1] * E[1, k] + zi[2] * E[2, k]
            u[i] = dot(zi, E_c)
        else:
            for k in range(n):
                H[i, k] = zi[0] * M[0, k] + zi[1] * M[1, k] + zi[2] * M[2, k]  # Eq. 35
            u[i] = dot(zi, n_c)  # Eq. 36
        p_next = oi
    return OK


@nb.njit(**{**JIT, "parallel": True})
def mrnea_batch(model, Q, QD, FEXT, PE, H, U, STATUS):
    """``mrnea`` over a batch: Q, QD, U (B, n); FEXT (B, 6); PE (B, 3); H (B, n, n); STATUS (B,)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = mrnea(model, Q[b], QD[b], FEXT[b], PE[b], H[b], U[b])


@nb.njit(**JIT)
def fd_mrnea(model, q, qd, tau, fext, pe, qdd):
    """The paper's forward dynamics: one mRNEA pass, then H qdd = tau - u' (Eq. 2).

    Returns OK, NONFINITE, or the index of the pivot where H is not positive definite.
    """
    if not finite(tau):
        return NONFINITE
    n = q.shape[0]
    buf = np.empty(2 * n * n + 2 * n)  # H, L (n, n); u', tau - u' (n,)
    H = buf[:n * n].reshape((n, n))
    L = buf[n * n:2 * n * n].reshape((n, n))
    u = buf[2 * n * n:2 * n * n + n]
    rhs = buf[2 * n * n + n:]
    status = mrnea(model, q, qd, fext, pe, H, u)
    if status != OK:
        return status
    for i in range(n):
        rhs[i] = tau[i] - u[i]
    return cholesky_solve(H, rhs, L, qdd)


@nb.njit(**{**JIT, "parallel": True})
def fd_mrnea_batch(model, Q, QD, TAU, FEXT, PE, QDD, STATUS):
    """``fd_mrnea`` over a batch; STATUS (B,) int64."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = fd_mrnea(model, Q[b], QD[b], TAU[b], FEXT[b], PE[b], QDD[b])
