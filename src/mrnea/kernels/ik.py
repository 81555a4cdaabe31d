"""Inverse kinematics of a tool frame: damped least squares (Levenberg-Marquardt) on the Jacobian.

Usage: ``ik_path(model, poses, t, pe, Rt, idx, q0, Q, ERR, tol_p, tol_w, max_iter, k0, k1)``
fills ``Q[k0:k1]`` (of (K, n)) with joint positions whose tool frame reaches ``poses[k0:k1]``
(of (K, 4, 4), base frame) one after the other, each solve warm-started from the previous ones
(the first at ``q0``): the continuous branch through ``q0``. A call from k0 > 0 carries on from
the rows before it (``Q[k0 - 1]``, ``Q[k0 - 2]``, ``ERR[k0 - 1]``, filled by an earlier call):
calls over consecutive ranges give exactly (bit for bit) what one call over all the poses gives,
so a long path is solved in blocks with a stop request honoured between them
(:func:`mrnea.ik.solve_path`). Only the m joints ``idx`` (m,) move (those that carry the
tool's link t, less any held; on a serial chain all n): the others keep their ``q0``, and m
counts the joints below. For m <= 6 the start of pose k is the predictor ``2 q_{k-1} - q_{k-2}``
(the last joint step again; ``q_{k-1}`` alone after a pose not reached, and for k = 0 ``q0``):
fewer iterations, and through a fold of the inverse kinematics (an arm passing through its full
stretch) the solve keeps the smooth branch, whose joint velocity is continuous, rather than
bouncing back on the other branch with a kink in q. A redundant arm (n > 6) starts at
``q_{k-1}``: a predicted start would carry the last step's null-space motion on from cycle to
cycle (a drift of the elbow), where the minimum-norm step from the previous cycle has none
(m > 6 below reads "redundant").
``ERR`` (K, 3) receives what is left: the position error [m], the orientation error [rad] and
the iterations taken. The tool frame is fixed to link t: origin ``pe`` (3,) [m] and axes
``Rt`` (3, 3), both in link t's frame.

One iteration, at q (the tool pose ``T(q) = [[R_t Rt, o_t + R_t pe], [0, 1]]``)::

    e   = [p* - p ; log(R* (R_t Rt)^T)]            the error twist, base frame (6,)
    J   = link_jacobian_ws(q, t, pe)[:, idx]       the tool point's geometric Jacobian (6, m)
    l2  = mu |e|^2 + LAMBDA2_MIN                   Levenberg-Marquardt damping (Sugihara 2011)
    dq  = J^T (J J^T + l2 I6)^-1 e                 m >= 6: the damped minimum-norm step
    dq  = (J^T J + l2 Im)^-1 J^T e                 m < 6: the damped least-squares step
    q[idx] += dq

accepted if it lowers ``|e|`` (then mu is halved, down to 1), else undone with mu times ten.
Near a solution the damping vanishes with ``|e|^2`` and the steps are Gauss-Newton steps:
quadratic convergence, down to the tolerances ``tol_p`` [m] and ``tol_w`` [rad] in one or two
iterations per cycle of a smooth path. For n = 7 each step is the minimum-norm joint step (the
least joint motion that makes the tool move as asked), so the redundancy is resolved as "move as
little as possible from the previous cycle", continuously, with no null-space goal.

The pose and the Jacobian come from one kinematics pass, ``kinematics.link_jacobian_ws`` (which
leaves the link frames R_i, o_i in the scratch's pose slots, on a tree too): nothing of the
kinematics is written again here.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from mrnea.kernels.common import finite, tip_point
from mrnea.kernels.kinematics import link_jacobian_ws
from mrnea.kernels.layout import ALLOC, INLINE, POSE, pose_buffers, scratch
from mrnea.kernels.solve import cholesky_solve
from mrnea.kernels.status import OK

LAMBDA2_MIN = 1e-12  # the damping's floor [m^2 | rad^2]: a finite step at a singular J
MU_MAX = 1e12  # mu beyond which no step lowers the error: the solve stops (a local minimum)


@nb.njit(**INLINE)
def log3(R00, R01, R02, R10, R11, R12, R20, R21, R22):
    """The rotation vector w (3-tuple, [rad]) with ``exp([w]x) = R``, |w| <= pi."""
    c = min(1.0, max(-1.0, 0.5 * (R00 + R11 + R22 - 1.0)))
    v = (0.5 * (R21 - R12), 0.5 * (R02 - R20), 0.5 * (R10 - R01))  # sin(theta) axis
    s = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    theta = math.atan2(s, c)
    if c > -0.5:  # theta < 2 pi / 3: the skew part is well conditioned
        f = theta / s if s > 0.0 else 1.0
        return (f * v[0], f * v[1], f * v[2])
    # near pi: the axis from the symmetric part, R + R^T = 2 c I + 2 (1 - c) a a^T, read off
    # the column of the largest diagonal entry
    S01, S02, S12 = 0.5 * (R01 + R10), 0.5 * (R02 + R20), 0.5 * (R12 + R21)
    g = 1.0 - c
    if R00 >= R11 and R00 >= R22:
        a0 = math.sqrt(max(0.0, (R00 - c) / g))
        a = (a0, S01 / (g * a0), S02 / (g * a0))
    elif R11 >= R22:
        a1 = math.sqrt(max(0.0, (R11 - c) / g))
        a = (S01 / (g * a1), a1, S12 / (g * a1))
    else:
        a2 = math.sqrt(max(0.0, (R22 - c) / g))
        a = (S02 / (g * a2), S12 / (g * a2), a2)
    if a[0] * v[0] + a[1] * v[1] + a[2] * v[2] < 0.0:  # the sign sin(theta) a has
        theta = -theta
    return (theta * a[0], theta * a[1], theta * a[2])


@nb.njit(**INLINE)
def pose_error(model, q, target, t, pe, Rt, idx, Jn, J, e, M, ws):
    """The Jacobian of the tool point on link t into Jn (6, n), its columns idx into J (6, m)
    (J is Jn when every joint moves), and the error twist ``[p* - p; log(R* R^T)]`` into e
    (6,), at q (M: a 3x3 buffer); returns (status, |e_p| [m], |e_w| [rad])."""
    n = q.shape[0]
    status = link_jacobian_ws(model, q, t, pe, Jn, ws)
    if status != OK:
        return status, math.inf, math.inf
    if idx.shape[0] < n:
        for a in range(6):
            for c in range(idx.shape[0]):
                J[a, c] = Jn[a, idx[c]]
    R, o, _, _, _ = pose_buffers(ws, n)  # link t's pose, left by the pass
    p = tip_point(o, R, t + 1, pe)
    for a in range(3):
        e[a] = target[a, 3] - p[a]
    # M = R* (R_n Rt)^T
    for a in range(3):
        for b in range(3):
            s = 0.0
            for k in range(3):
                tk = 0.0  # (R_n Rt)[b, k]
                for m in range(3):
                    tk += R[t, b, m] * Rt[m, k]
                s += target[a, k] * tk
            M[a, b] = s
    w = log3(M[0, 0], M[0, 1], M[0, 2], M[1, 0], M[1, 1], M[1, 2], M[2, 0], M[2, 1], M[2, 2])
    for a in range(3):
        e[3 + a] = w[a]
    ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    ew = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return OK, ep, ew


@nb.njit(**INLINE)
def damped_step(J, e, l2, A, L, rhs, x, dq):
    """The damped least-squares step dq (n,) for the error e (6,) (module docstring)."""
    n = J.shape[1]
    if n >= 6:  # dq = J^T (J J^T + l2 I)^-1 e
        for a in range(6):
            for b in range(6):
                s = l2 if a == b else 0.0
                for k in range(n):
                    s += J[a, k] * J[b, k]
                A[a, b] = s
            rhs[a] = e[a]
        status = cholesky_solve(A[:6, :6], rhs[:6], L[:6, :6], x[:6])
        for k in range(n):
            s = 0.0
            for a in range(6):
                s += J[a, k] * x[a]
            dq[k] = s
    else:  # dq = (J^T J + l2 I)^-1 J^T e
        for a in range(n):
            for b in range(n):
                s = l2 if a == b else 0.0
                for k in range(6):
                    s += J[k, a] * J[k, b]
                A[a, b] = s
            s = 0.0
            for k in range(6):
                s += J[k, a] * e[k]
            rhs[a] = s
        status = cholesky_solve(A[:n, :n], rhs[:n], L[:n, :n], dq)
    return status


@nb.njit(**ALLOC)
def ik_path(model, poses, t, pe, Rt, idx, q0, Q, ERR, tol_p, tol_w, max_iter, k0, k1):
    """Joint positions Q[k0:k1] (of (K, n)) whose tool frame on link t reaches the poses
    [k0:k1] (of (K, 4, 4)) in turn from q0 (or from the rows before k0, module docstring),
    moving the joints idx (m,) only; ERR[k0:k1] (of (K, 3)): position error [m], orientation
    error [rad], iterations."""
    n, m = q0.shape[0], idx.shape[0]
    mm = max(m, 6)
    ws = scratch(n, POSE)
    Jn, e, M = np.empty((6, n)), np.empty(6), np.empty((3, 3))
    J = Jn if m == n else np.empty((6, m))  # every joint moves (a chain): no columns to pick
    A, L = np.empty((mm, mm)), np.empty((mm, mm))
    rhs, x = np.empty(mm), np.empty(mm)
    q_new, dq = np.empty(n), np.empty(m)
    # where the solve of pose k starts from: q = Q[k - 1], q_prev = Q[k - 2] (q0 before pose 0)
    q = q0.copy() if k0 == 0 else Q[k0 - 1].copy()
    q_prev = q0.copy() if k0 < 2 else Q[k0 - 2].copy()
    for k in range(k0, k1):
        target = poses[k]
        if m <= 6 and k > 0 and ERR[k - 1, 0] <= tol_p and ERR[k - 1, 1] <= tol_w:
            for i in range(n):  # the predictor: the last cycle's joint step again
                q_prev[i], q[i] = q[i], 2.0 * q[i] - q_prev[i]
        else:
            q_prev[:] = q
        status, ep, ew = pose_error(model, q, target, t, pe, Rt, idx, Jn, J, e, M, ws)
        mu, it = 1.0, 0
        while status == OK and (ep > tol_p or ew > tol_w) and it < max_iter and mu < MU_MAX:
            it += 1
            E = ep * ep + ew * ew
            if damped_step(J, e, mu * E + LAMBDA2_MIN, A, L, rhs, x, dq) != OK:
                break
            q_new[:] = q
            for c in range(m):
                q_new[idx[c]] += dq[c]
            s_new, ep_new, ew_new = pose_error(model, q_new, target, t, pe, Rt, idx, Jn, J, e,
                                               M, ws)
            if s_new == OK and ep_new * ep_new + ew_new * ew_new < E:
                q[:] = q_new
                ep, ew, mu = ep_new, ew_new, max(1.0, 0.5 * mu)
            else:  # undo: J and e back at q, more damping
                status, ep, ew = pose_error(model, q, target, t, pe, Rt, idx, Jn, J, e, M, ws)
                mu *= 10.0
        Q[k] = q
        ERR[k, 0], ERR[k, 1], ERR[k, 2] = ep, ew, it
        if not finite(q):
            ERR[k, 0] = ERR[k, 1] = math.inf
    return OK
