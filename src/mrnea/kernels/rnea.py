"""RNEA: recursive Newton-Euler inverse dynamics in base coordinates (paper Eqs. 4-19, 32-33).

Usage: ``rnea(model, q, qd, qdd, fext, pe, tau, f, nm)`` fills ``tau`` (n,) with the joint efforts
and ``f``, ``nm`` (n, 3) with the force and moment that link i-1 exerts on link i through joint i,
in base coordinates, the moment taken about the joint's point o_i (Eqs. 18-19).

Index convention (docs/notation.md): the paper's joint i turns about z_{i-1} through the origin of
frame i-1; here joint i turns about z[i] through o[i], the origin of link i's frame. The paper's
p*_i, the vector between consecutive joint points, is ``o[i+1] - o[i]``; its l_i, from the joint
point to the centre of mass, is ``c[i] - o[i]``.

External wrench: ``fext = [f_e; n_e]`` (6,), base coordinates, is what the last link exerts on
its environment (the paper's k_e), applied at ``pe`` (3,), a point given in the last link's frame.
It enters as the force f_{n+1} = f_e and moment n_{n+1} = n_e of a virtual link n+1 (Eqs. 10-11).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import (
    JIT,
    MASS,
    NONFINITE,
    OK,
    OVERFLOW,
    PRISMATIC,
    ROT,
    TYPE,
    add,
    cross,
    dot,
    finite,
    kinematics,
    mat,
    mm,
    mtv,
    mv,
    put,
    rot,
    scale,
    sub,
    tip_point,
    vec,
    workspace,
)


@nb.njit(**JIT)
def link_forces(model, o, z, c, Ic, qd, qdd, g, F, N):
    """Forward pass, base to tip: each link's total force F (Eq. 6) and moment N about its
    centre of mass (Eq. 7), given the kinematics of this state; fills F, N (n, 3)."""
    w = (0.0, 0.0, 0.0)  # angular velocity of the parent link
    wd = (0.0, 0.0, 0.0)  # its angular acceleration
    a_p = (0.0, 0.0, 0.0)  # linear acceleration of the parent's origin
    o_p = (0.0, 0.0, 0.0)  # parent's origin
    for i in range(qd.shape[0]):
        zi, oi = vec(z, i), vec(o, i)
        p_star = sub(oi, o_p)
        # acceleration of the point of the parent coinciding with o_i
        a_o = add(a_p, add(cross(wd, p_star), cross(w, cross(w, p_star))))
        if model[i + 1, TYPE] == PRISMATIC:
            a_o = add(a_o, add(scale(zi, qdd[i]), scale(cross(w, zi), 2.0 * qd[i])))
        else:
            wd = add(wd, add(scale(zi, qdd[i]), scale(cross(w, zi), qd[i])))
            w = add(w, scale(zi, qd[i]))
        r_cm = sub(vec(c, i), oi)
        # Eq. 4: acceleration of the centre of mass
        a_cm = add(a_o, add(cross(wd, r_cm), cross(w, cross(w, r_cm))))
        put(F, i, scale(sub(a_cm, g), model[i + 1, MASS]))  # Eq. 6
        put(N, i, add(mv(Ic, i, wd), cross(w, mv(Ic, i, w))))  # Eq. 7
        a_p, o_p = a_o, oi


@nb.njit(**JIT)
def newton_euler(model, R, o, z, c, Ic, qd, qdd, g, fext, pe, tau, f, nm):
    """The two Newton-Euler passes, given the kinematics (R, o, z, c, Ic) of this state.

    ``g`` is the gravity 3-tuple (Walker-Orin's columns pass zero). Fills tau, f, nm.
    """
    n = qd.shape[0]
    buf = np.empty((2 * n, 3))
    F = buf[:n]  # total force on link i, Eq. 6
    N = buf[n:]  # total moment on link i about its centre of mass, Eq. 7
    link_forces(model, o, z, c, Ic, qd, qdd, g, F, N)

    # backward pass: forces and moments, tip to base
    f_next = (fext[0], fext[1], fext[2])  # f_{n+1} = f_e, Eq. 10
    n_next = (fext[3], fext[4], fext[5])  # n_{n+1} = n_e, Eq. 11
    p_next = tip_point(o, R, n, pe)  # where f_{n+1} acts
    for i in range(n - 1, -1, -1):
        oi = vec(o, i)
        Fi = vec(F, i)
        fi = add(Fi, f_next)  # Eq. 18
        l_i = sub(vec(c, i), oi)
        p_star = sub(p_next, oi)
        ni = add(add(n_next, vec(N, i)), add(cross(l_i, Fi), cross(p_star, f_next)))  # Eq. 19
        put(f, i, fi)
        put(nm, i, ni)
        # Eq. 33: projection on the axis of motion (force for a prismatic joint)
        tau[i] = dot(vec(z, i), fi if model[i + 1, TYPE] == PRISMATIC else ni)
        f_next, n_next, p_next = fi, ni, oi


@nb.njit(**JIT)
def rnea(model, q, qd, qdd, fext, pe, tau, f, nm):
    """Inverse dynamics of one state; fills tau (n,), f (n, 3), nm (n, 3) (module docstring).

    Returns OK, or NONFINITE if an input holds NaN or inf.
    """
    if not (finite(q) and finite(qd) and finite(qdd) and finite(fext) and finite(pe)):
        return NONFINITE
    R, o, z, c, Ic = workspace(q.shape[0])
    kinematics(model, q, R, o, z, c, Ic)
    g = (model[0, 0], model[0, 1], model[0, 2])
    newton_euler(model, R, o, z, c, Ic, qd, qdd, g, fext, pe, tau, f, nm)
    return OK if finite(tau) and finite(f) and finite(nm) else OVERFLOW


@nb.njit(**JIT)
def reactions(model, q, qd, qdd, fext, pe, tau, out):
    """Joint reaction wrenches of one state, each in its joint frame (Eq. 32).

    ``out[i] = [f; n]`` (6,): force [N] and moment [N m] that link i-1 exerts on link i through
    joint i, in the joint frame (the parent's frame moved by the joint origin, fixed to the
    parent: the bearing's housing), the moment about the joint frame's origin o_i.
    """
    if not (finite(q) and finite(qd) and finite(qdd) and finite(fext) and finite(pe)):
        return NONFINITE
    n = q.shape[0]
    R, o, z, c, Ic = workspace(n)
    kinematics(model, q, R, o, z, c, Ic)
    g = (model[0, 0], model[0, 1], model[0, 2])
    f = np.empty((n, 3))
    nm = np.empty((n, 3))
    newton_euler(model, R, o, z, c, Ic, qd, qdd, g, fext, pe, tau, f, nm)
    for i in range(n):
        # joint frame: the parent's orientation times the origin rotation, D_{i-1} in Eq. 32
        Rp = rot(R, i - 1) if i > 0 else (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        Rj = mm(Rp, mat(model, i + 1, ROT))
        if model[i + 1, TYPE] == PRISMATIC:
            # moment about the joint frame's origin, o_i - z_i q_i: add (z_i q_i) x f_i
            t = cross(scale(vec(z, i), q[i]), vec(f, i))
            for a in range(3):
                nm[i, a] += t[a]
        fj = mtv(Rj, vec(f, i))  # Rj^T f, Rj^T n
        nj = mtv(Rj, vec(nm, i))
        for a in range(3):
            out[i, a] = fj[a]
            out[i, 3 + a] = nj[a]
    return OK if finite(out) else OVERFLOW


@nb.njit(**{**JIT, "parallel": True})
def rnea_batch(model, Q, QD, QDD, FEXT, PE, TAU, STATUS):
    """``rnea`` over a batch: Q, QD, QDD, TAU (B, n); FEXT (B, 6); PE (B, 3); STATUS (B,)."""
    n = Q.shape[1]
    for b in nb.prange(Q.shape[0]):
        f = np.empty((n, 3))
        nm = np.empty((n, 3))
        STATUS[b] = rnea(model, Q[b], QD[b], QDD[b], FEXT[b], PE[b], TAU[b], f, nm)


@nb.njit(**{**JIT, "parallel": True})
def reactions_batch(model, Q, QD, QDD, FEXT, PE, TAU, OUT, STATUS):
    """``reactions`` over a batch: OUT (B, n, 6), STATUS (B,)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = reactions(model, Q[b], QD[b], QDD[b], FEXT[b], PE[b], TAU[b], OUT[b])
