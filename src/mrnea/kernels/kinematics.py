"""Forward kinematics and the geometric Jacobian, from the kinematics pass (``common.kinematics``).

Usage: ``frames(model, q, out, ws)`` fills ``out`` (n + 1, 4, 4) with the homogeneous poses of
the base (the identity) and of every link frame in base coordinates, ``T_i = T_{i-1} @ origin_i
@ motion_i(q_i)`` (``T_{λ(i)}`` on a tree): ``out[i + 1]`` is link i's ``[[R_i, o_i], [0, 1]]``
(the paper's D_i and p_i). ``jacobian(model, q, pe, J, ws)`` fills ``J`` (6, n): column k is
the velocity ``[v; w]`` [m/s; rad/s] of the point p = o_n + R_n pe, fixed to the last link
(``pe=None``: its origin o_n), per unit rate of joint k, in base coordinates (rows linear then
angular, Pinocchio's order)::

    revolute k:   v = z_k x (p - o_k),   w = z_k       (the paper's b_ik, Eq. 5, at the point p)
    prismatic k:  v = z_k,               w = 0

so that the joints supply ``J^T [f_e; n_e]`` against a wrench the last link exerts at p (Eq. 1's
J^T k_e). Scratch: a ``POSE`` one or larger (the pose slots of ``layout.pose_buffers``). The
kinematics pass is a chain's copy for a chain's model, a tree's for a tree's (its type:
kernels/layout.py ``tree_of``).
"""

from __future__ import annotations

import numba as nb

from mrnea.kernels.common import cross, finite, kinematics, sub, tip_point, vec
from mrnea.kernels.layout import (
    ENTRY,
    JIT,
    PARALLEL,
    carries,
    is_prismatic,
    own_scratch,
    pose_buffers,
    tree_of,
)
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW, SIZE


@nb.njit(**JIT)
def frames_ws(model, q, out, ws):
    """The base's and every link's pose of one state into ``out`` (n + 1, 4, 4); a status."""
    n = q.shape[0]
    if not finite(q):
        return NONFINITE
    R, o, z, c, Ic = pose_buffers(ws, n)
    kinematics(model, q, R, o, z, c, Ic, tree_of(model))
    for a in range(4):  # the base frame: the identity
        for b in range(4):
            out[0, a, b] = 1.0 if a == b else 0.0
    for i in range(n):  # T_i = [[R_i, o_i], [0, 0, 0, 1]]
        for a in range(3):
            for b in range(3):
                out[i + 1, a, b] = R[i, a, b]
            out[i + 1, a, 3] = o[i, a]
            out[i + 1, 3, a] = 0.0
        out[i + 1, 3, 3] = 1.0
    return OK if finite(out) else OVERFLOW


@nb.njit(**ENTRY)
def frames(model, q, out, ws):
    """``frames_ws`` after checking q's length (status SIZE)."""
    if q.shape[0] != model.shape[0] - 1:
        return SIZE
    return frames_ws(model, q, out, ws)


@nb.njit(**JIT)
def jacobian_ws(model, q, pe, J, ws):
    """The geometric Jacobian (6, n) of one state at the point pe of the last link (module
    docstring) into ``J``; a status."""
    return link_jacobian_ws(model, q, q.shape[0] - 1, pe, J, ws)


@nb.njit(**JIT)
def link_jacobian_ws(model, q, t, pe, J, ws):
    """As :func:`jacobian_ws` at the point pe of link t (0 <= t < n): column k is zero unless
    joint k carries link t (on a tree: k in κ(t) ∪ {t}, docs/notation.md)."""
    n = q.shape[0]
    if not (finite(q) and finite(pe)):
        return NONFINITE
    R, o, z, c, Ic = pose_buffers(ws, n)
    kinematics(model, q, R, o, z, c, Ic, tree_of(model))
    p = tip_point(o, R, t + 1, pe)  # o_t + R_t p_e, base coordinates
    for k in range(n):
        zk = vec(z, k)
        if k > t or not carries(model, k, t):
            v, w = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        elif is_prismatic(model, k):
            v, w = zk, (0.0, 0.0, 0.0)
        else:
            v, w = cross(zk, sub(p, vec(o, k))), zk  # Eq. 5 at the point p
        for a in range(3):
            J[a, k] = v[a]
            J[3 + a, k] = w[a]
    return OK if finite(J) else OVERFLOW


@nb.njit(**ENTRY)
def jacobian(model, q, pe, J, ws):
    """``jacobian_ws`` after checking the lengths of q and pe (status SIZE)."""
    if q.shape[0] != model.shape[0] - 1 or (pe is not None and pe.shape[0] != 3):
        return SIZE
    return jacobian_ws(model, q, pe, J, ws)


@nb.njit(**PARALLEL)
def frames_batch(model, Q, OUT, STATUS, ws):
    """``frames`` over a batch: Q (B, n), OUT (B, n + 1, 4, 4), STATUS (B,); ws: a
    ``batch_scratch`` (kernels/layout.py)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = frames_ws(model, Q[b], OUT[b], own_scratch(ws))


@nb.njit(**PARALLEL)
def jacobian_batch(model, Q, PE, J, STATUS, ws):
    """``jacobian`` over a batch, as ``frames_batch``: PE (B, 3), J (B, 6, n)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = jacobian_ws(model, Q[b], PE[b], J[b], own_scratch(ws))
