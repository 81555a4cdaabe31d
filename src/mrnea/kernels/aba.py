"""ABA: the articulated-body algorithm, O(n) forward dynamics (Featherstone, RBDA Sec. 7.3).

Usage: ``status = aba(model, q, qd, tau, fext, pe, qdd, ws)`` fills ``qdd`` (n,);
``aba_batch(model, Q, QD, TAU, FEXT, PE, QDD, STATUS, ws)`` does it over a batch. ``status`` is OK,
NONFINITE (an input holds NaN or inf), or the index of the first joint whose articulated inertia
D_i is not positive (a singular H).

Spatial vectors in base coordinates, Plucker style about the base origin O: motion
``[w; v_O]``, force ``[n_O; f]``. Joint i's motion subspace is S_i = [z_i; o_i x z_i] (revolute)
or [0; z_i] (prismatic); link i's spatial inertia about O is
``[[Ic - m [c]x [c]x, m [c]x], [-m [c]x, m 1]]``. Gravity enters as the base acceleration
[0; -g]; the external wrench k_e as the force [n_e + p x f_e; f_e] the environment takes from
the last link (so the last link receives its negative); a wrench per link (``fext`` (n, 6),
kernels/common.py) so on each link.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba.extending import overload

from mrnea.kernels.common import (
    add,
    cross,
    finite,
    kinematics,
    link_wrench,
    per_link_type,
    sized,
    tip_wrench,
    vec,
)
from mrnea.kernels.layout import (
    ENTRY_ALLOC,
    JIT,
    MASS,
    PARALLEL,
    is_prismatic,
    own_scratch,
    parent,
    pose_buffers,
    tree_of,
)
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW, SIZE


@nb.njit(**JIT)
def _motion_cross(v, m, out):
    """out = v x m for spatial motion vectors (6,)."""
    w, vo = (v[0], v[1], v[2]), (v[3], v[4], v[5])
    mw, mv_ = (m[0], m[1], m[2]), (m[3], m[4], m[5])
    a = cross(w, mw)
    b = add(cross(w, mv_), cross(vo, mw))
    out[0], out[1], out[2], out[3], out[4], out[5] = a[0], a[1], a[2], b[0], b[1], b[2]


@nb.njit(**JIT)
def _force_cross(v, f, out):
    """out = v x* f for a motion vector v and a force vector f (6,)."""
    w, vo = (v[0], v[1], v[2]), (v[3], v[4], v[5])
    fn, ff = (f[0], f[1], f[2]), (f[3], f[4], f[5])
    a = add(cross(w, fn), cross(vo, ff))
    b = cross(w, ff)
    out[0], out[1], out[2], out[3], out[4], out[5] = a[0], a[1], a[2], b[0], b[1], b[2]


@nb.njit(**JIT)
def _spatial(R, o, fext, pe, pA):
    for i in range(pA.shape[0]):
        f, m, p = link_wrench(o, R, fext, pe, i)
        m = add(m, cross(p, f))
        for a in range(3):
            pA[i, a] += m[a]
            pA[i, 3 + a] += f[a]


@nb.njit(**JIT)
def _no_spatial(R, o, fext, pe, pA):
    return


def spatial_wrenches(R, o, fext, pe, pA):
    """A per-link ``fext`` (n, 6) (kernels/common.py): each link's bias force takes its wrench
    as the environment's reaction, ``pA_i += [n_i + p_i x f_i; f_i]`` (as the last link's below).
    No-op otherwise. Python body for NUMBA_DISABLE_JIT; compiled code uses the overload."""
    if fext is not None and np.ndim(fext) == 2:
        _spatial(R, o, fext, pe, pA)


@overload(spatial_wrenches, inline="always")
def _spatial_overload(R, o, fext, pe, pA):
    return (_spatial if per_link_type(fext) else _no_spatial).py_func


@nb.njit(**ENTRY_ALLOC)
def aba(model, q, qd, tau, fext, pe, qdd, ws):
    """Forward dynamics of one state by the articulated-body algorithm (module docstring);
    the link poses go to the scratch ``ws`` (kernels/layout.py), the spatial quantities to arrays
    of its own."""
    if not sized(model, q, qd, tau):
        return SIZE
    if not (finite(q) and finite(qd) and finite(tau) and finite(fext) and finite(pe)):
        return NONFINITE
    n = q.shape[0]
    R, o, z, c, Ic = pose_buffers(ws, n)
    # a chain's copy, without the parent look-ups, for a chain's model (its type: layout.py)
    kinematics(model, q, R, o, z, c, Ic, tree_of(model))
    S = np.zeros((n, 6))
    v = np.zeros((n, 6))
    cb = np.zeros((n, 6))  # velocity-product accelerations c_i = v_i x S_i qd_i
    IA = np.zeros((n, 6, 6))  # articulated inertias
    pA = np.zeros((n, 6))  # articulated bias forces
    U = np.zeros((n, 6))
    D = np.zeros(n)
    u = np.zeros(n)
    tmp = np.zeros(6)
    Iv = np.zeros(6)

    # pass 1, base to tip: velocities, bias accelerations, rigid-body inertias and bias forces
    for i in range(n):
        zi = vec(z, i)
        if is_prismatic(model, i):
            S[i, 3:] = zi
        else:
            S[i, :3] = zi
            oz = cross(vec(o, i), zi)
            S[i, 3:] = oz
        p = parent(model, i)
        if p >= 0:
            v[i] = v[p]
        for a in range(6):
            v[i, a] += S[i, a] * qd[i]
            tmp[a] = S[i, a] * qd[i]
        _motion_cross(v[i], tmp, cb[i])
        m = model[i + 1, MASS]
        cx = np.array(((0.0, -c[i, 2], c[i, 1]), (c[i, 2], 0.0, -c[i, 0]),
                       (-c[i, 1], c[i, 0], 0.0)))
        for a in range(3):
            for b in range(3):
                cc = cx[a, 0] * cx[0, b] + cx[a, 1] * cx[1, b] + cx[a, 2] * cx[2, b]
                IA[i, a, b] = Ic[i, a, b] - m * cc
                IA[i, a, 3 + b] = m * cx[a, b]
                IA[i, 3 + a, b] = -m * cx[a, b]
            IA[i, 3 + a, 3 + a] = m
        for a in range(6):
            Iv[a] = 0.0
            for b in range(6):
                Iv[a] += IA[i, a, b] * v[i, b]
        _force_cross(v[i], Iv, pA[i])
    # the environment's reaction on the last link: p_n -= -[n_e + p x f_e; f_e]
    fe, ne, p = tip_wrench(o, R, n, fext, pe)
    spatial_wrenches(R, o, fext, pe, pA)  # a wrench per link, if given: each link's own
    ne = add(ne, cross(p, fe))
    for a in range(3):
        pA[n - 1, a] += ne[a]
        pA[n - 1, 3 + a] += fe[a]

    # pass 2, tip to base: articulated inertias and bias forces
    status = OK  # or the tipmost joint whose D_i is not positive
    for i in range(n - 1, -1, -1):
        scale_i = 0.0
        for a in range(6):
            U[i, a] = 0.0
            for b in range(6):
                U[i, a] += IA[i, a, b] * S[i, b]
            scale_i = max(scale_i, abs(IA[i, a, a]))
        D[i] = 0.0
        sp = 0.0
        for a in range(6):
            D[i] += S[i, a] * U[i, a]
            sp += S[i, a] * pA[i, a]
        if not D[i] > 1e-13 * scale_i:
            if status == OK:
                status = i
            D[i] = 1.0
        u[i] = tau[i] - sp
        p = parent(model, i)
        if p >= 0:
            # Ia = IA - U U^T / D; pa = pA + Ia c + U u / D, added to the parent's
            for a in range(6):
                for b in range(6):
                    IA[i, a, b] -= U[i, a] * U[i, b] / D[i]
            for a in range(6):
                acc = pA[i, a] + U[i, a] * u[i] / D[i]
                for b in range(6):
                    acc += IA[i, a, b] * cb[i, b]
                pA[p, a] += acc
                for b in range(6):
                    IA[p, a, b] += IA[i, a, b]
    if status != OK:
        return status

    # pass 3, base to tip: accelerations, each link's from its parent's (the base's: -g), into
    # cb, not read again (no array of its own: one allocation less a call): a_i = a_λ(i) + c_i,
    # then a_i += S_i qdd_i
    g = (model[0, 0], model[0, 1], model[0, 2])
    base = (0.0, 0.0, 0.0, -g[0], -g[1], -g[2])
    for i in range(n):
        p = parent(model, i)
        if p >= 0:
            for a in range(6):
                cb[i, a] = cb[p, a] + cb[i, a]
        else:
            for a in range(6):
                cb[i, a] = base[a] + cb[i, a]
        s = 0.0
        for a in range(6):
            s += U[i, a] * cb[i, a]
        qdd[i] = (u[i] - s) / D[i]
        for a in range(6):
            cb[i, a] += S[i, a] * qdd[i]
    return OK if finite(qdd) else OVERFLOW


@nb.njit(**PARALLEL)
def aba_batch(model, Q, QD, TAU, FEXT, PE, QDD, STATUS, ws):
    """``aba`` over a batch: Q, QD, TAU, QDD (B, n); FEXT (B, 6); PE (B, 3); STATUS (B,); ws: a
    ``batch_scratch`` (kernels/layout.py)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = aba(model, Q[b], QD[b], TAU[b], FEXT[b], PE[b], QDD[b], own_scratch(ws))
