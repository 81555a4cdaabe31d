"""CRBA: the composite-rigid-body algorithm for H (Featherstone, RBDA Sec. 6.2), base coordinates.

Usage: ``crba(model, q, H)`` fills ``H`` (n, n); ``crba_bias(model, q, qd, fext, pe, H, u, ws)``
adds the bias u' of one Newton-Euler pass (forward dynamics through it: kernels/engines.py).

The composite body j is link j and everything it carries: mass M_j, centre of mass C_j, inertia
Ic_j about C_j, accumulated tip to base. A unit acceleration of joint j, everything else at rest,
moves the composite body rigidly: for a revolute joint it needs the force
F = M_j z_j x (C_j - o_j) and the moment Ic_j z_j + (C_j - P) x F about a point P; for a prismatic
joint F = M_j z_j and the moment (C_j - P) x F. Joint i <= j carries it, so
H_ij = z_i . (moment about o_i) for revolute i and z_i . F for prismatic i.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import add, cross, dot, finite, kinematics, mv, put, scale, sub, vec
from mrnea.kernels.layout import (
    ALLOC,
    BRANCH,
    JIT,
    MASS,
    carries,
    force_buffers,
    is_prismatic,
    parent,
    pose_arrays,
    pose_buffers,
    tree_of,
    tree_scratch,
)
from mrnea.kernels.rnea import newton_euler
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW


@nb.njit(**ALLOC)
def crba(model, q, H):
    """The mass matrix H (n, n) of one state (a chain's or a tree's copies by the model's type,
    as :func:`crba_bias`)."""
    R, o, z, c, Ic = pose_arrays(q.shape[0])
    kinematics(model, q, R, o, z, c, Ic, tree_of(model))
    composite(model, o, z, c, Ic, H, tree_of(model))


@nb.njit(**ALLOC)
def crba_bias(model, q, qd, fext, pe, H, u, ws):
    """H by CRBA and u' by one Newton-Euler pass with qdd = 0, on one kinematics pass; the
    same contract (and status) as ``mrnea``. Poses and forces go to the scratch ``ws``.

    A serial chain's model (its type: kernels/layout.py ``tree_of``, ``tree_scratch``) compiles
    the chain's copies of the kinematics, ``newton_euler`` and :func:`composite` alone; a tree's
    the tree's. (A run-time test of the TREE flag compiled both into every chain's kernel, and
    cost a chain 2-4 % a call: docs/performance.md section 20.)"""
    if not (finite(q) and finite(qd) and finite(fext) and finite(pe)):
        return NONFINITE
    n = q.shape[0]
    R, o, z, c, Ic = pose_buffers(ws, n)
    f, nm = force_buffers(ws, n)  # the joint forces and moments, not needed here
    g = (model[0, 0], model[0, 1], model[0, 2])
    tree = tree_of(model)
    kinematics(model, q, R, o, z, c, Ic, tree)
    newton_euler(model, R, o, z, c, Ic, qd, None, g, fext, pe, u, f, nm, tree_scratch(model, ws))
    composite(model, o, z, c, Ic, H, tree)
    return OK if finite(H) and finite(u) else OVERFLOW


@nb.njit(**JIT)
def join(J, r, M1, h1, C1, J2, r2, M2, h2, C2):
    """Body 2 (mass M2, first moment h2 = M2 C2, inertia ``J2[r2]`` about its centre of mass C2)
    joined to body 1 (M1, h1, C1, inertia ``J[r]``): ``J[r]`` becomes the inertia of the two
    about their common centre of mass (parallel-axis theorem); returns its mass, first moment
    and centre of mass."""
    M_new = M1 + M2
    C_new = scale(add(h1, h2), 1.0 / M_new) if M_new > 0.0 else C2
    d_1 = sub(C1, C_new)
    d_2 = sub(C2, C_new)
    for a in range(3):
        for b in range(3):
            kron = 1.0 if a == b else 0.0
            J[r, a, b] += (J2[r2, a, b]
                           + M1 * (dot(d_1, d_1) * kron - d_1[a] * d_1[b])
                           + M2 * (dot(d_2, d_2) * kron - d_2[a] * d_2[b]))
    return M_new, add(h1, h2), C_new


@nb.njit(**ALLOC)
def composite(model, o, z, c, Ic, H, tree):
    """The composite-rigid-body recursion, given the kinematics of this state; fills H.

    The composite body of the first child (j + 1) is carried, as on a chain; on a tree a later
    child's is joined to its parent's stash (``Ms``, ``hs``, ``Js``, ``Cs``, by branch point)
    and joined to the parent's composite at its step (docs/notation.md, Trees). H_ij = 0 unless
    one of i, j carries the other. ``tree=None`` compiles a serial chain's copy, without the
    stash and the parent look-ups (as ``kinematics``); ``tree=True`` runs any tree.
    """
    n = o.shape[0]
    Mc = 0.0  # composite mass
    hc = (0.0, 0.0, 0.0)  # composite first moment, sum m_k c_k
    Jc = np.zeros((1, 3, 3))  # composite inertia about the composite centre of mass
    Cc = (0.0, 0.0, 0.0)  # composite centre of mass
    if tree is not None:  # a tree's later children's composites, by parent
        Ms, hs, Js, Cs = np.zeros(n), np.zeros((n, 3)), np.zeros((n, 3, 3)), np.zeros((n, 3))
    for j in range(n - 1, -1, -1):
        # add link j to the composite body (parallel-axis theorem about the new centre of mass)
        m = model[j + 1, MASS]
        cj = vec(c, j)
        Mc, hc, Cc = join(Jc, 0, Mc, hc, Cc, Ic, j, m, scale(cj, m), cj)
        if tree is not None and model[j + 1, BRANCH]:  # the later children's, stashed
            Mc, hc, Cc = join(Jc, 0, Mc, hc, Cc, Js, j, Ms[j], vec(hs, j), vec(Cs, j))

        # force and moment (about C_j) that a unit acceleration of joint j needs
        zj = vec(z, j)
        if is_prismatic(model, j):
            F = scale(zj, Mc)
            Nc = (0.0, 0.0, 0.0)
        else:
            F = scale(cross(zj, sub(Cc, vec(o, j))), Mc)
            Nc = mv(Jc, 0, zj)
        for i in range(j + 1):
            h = 0.0  # unless joint i carries link j
            if tree is None or carries(model, i, j):
                zi = vec(z, i)
                if is_prismatic(model, i):
                    h = dot(zi, F)
                else:
                    h = dot(zi, add(Nc, cross(sub(Cc, vec(o, i)), F)))
            H[i, j] = h
            H[j, i] = h
        if tree is None:
            continue
        b = parent(model, j)
        if b != j - 1:  # a later child: to its parent's stash; a leaf starts from nothing
            if b >= 0:
                Ms[b], hb, Cb = join(Js, b, Ms[b], vec(hs, b), vec(Cs, b), Jc, 0, Mc, hc, Cc)
                put(hs, b, hb)
                put(Cs, b, Cb)
            Mc, hc, Cc = 0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
            Jc[0] = 0.0
