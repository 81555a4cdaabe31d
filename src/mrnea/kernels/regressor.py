"""The joint torque regressor Y(q, qd, qdd): tau = Y pi, linear in each link's 10 inertial
parameters (Atkeson, An and Hollerbach 1986; Pinocchio's ``computeJointTorqueRegressor``).

Usage: ``regressor_batch(model, Q, QD, QDD, Y, STATUS, ws)`` fills ``Y`` (B, n, 10 n). Column block
``10 i : 10 i + 10`` belongs to link i, in Pinocchio's order, in link i's frame (the frame of
joint i after its motion), about that frame's origin o_i::

    pi_i = [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]

with ``I = I_c + m (|c|^2 1 - c c^T)`` the inertia about o_i (parallel axes). Serial chains only:
joint j carries link i exactly when j <= i (the public wrapper refuses a tree).

Per link, the Newton-Euler equations about o_i in its own frame are linear in pi_i (Eqs. 6-7
moved from the centre of mass to o_i): with a the acceleration of o_i minus gravity, w, wd the
angular velocity and acceleration, h = m c::

    f = m a + wd x h + w x (w x h)          n = I wd + w x (I w) + h x a

Column k of link i is the wrench (f, n) of pi_i = e_k, rotated to base coordinates; joint j <= i
takes its projection (Eq. 33) with the moment moved to o_j: ``z_j . (n + (o_i - o_j) x f)``
(revolute) or ``z_j . f`` (prismatic). The velocity recursion is ``rnea.link_forces``'s (Eqs.
4-5), the poses are ``common.kinematics``'s.
"""

from __future__ import annotations

import numba as nb

from mrnea.kernels.common import add, cross, dot, finite, kinematics, mtv, mvt, rot, scale, sub, vec
from mrnea.kernels.layout import (
    INLINE,
    JIT,
    PARALLEL,
    is_prismatic,
    own_scratch,
    pose_buffers,
    tree_of,
)
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW


@nb.njit(**INLINE)
def inertia_times(k, v):
    """``E_k v`` for the symmetric unit matrix E_k of inertia parameter k (0..5: xx, xy, yy,
    xz, yz, zz), so that ``I v = sum_k I_k E_k v``."""
    if k == 0:
        return (v[0], 0.0, 0.0)
    if k == 1:
        return (v[1], v[0], 0.0)
    if k == 2:
        return (0.0, v[1], 0.0)
    if k == 3:
        return (v[2], 0.0, v[0])
    if k == 4:
        return (0.0, v[2], v[1])
    return (0.0, 0.0, v[2])


@nb.njit(**INLINE)
def unit_wrench(k, a, w, wd):
    """The wrench (f, n) about the link origin, link frame, of parameter k of the module
    docstring set to 1 and the others to 0, for a = acceleration of the origin minus gravity,
    w, wd angular velocity and acceleration (all link frame)."""
    zero = (0.0, 0.0, 0.0)
    if k == 0:  # m: f = m a
        return a, zero
    if k <= 3:  # h = m c along axis k - 1: f = wd x h + w x (w x h), n = h x a
        e = (1.0 if k == 1 else 0.0, 1.0 if k == 2 else 0.0, 1.0 if k == 3 else 0.0)
        return add(cross(wd, e), cross(w, cross(w, e))), cross(e, a)
    # inertia about the origin: n = I wd + w x (I w)
    return zero, add(inertia_times(k - 4, wd), cross(w, inertia_times(k - 4, w)))


@nb.njit(**JIT)
def regressor_ws(model, q, qd, qdd, Y, ws):
    """Y (n, 10 n) of one state (module docstring); returns a status."""
    n = q.shape[0]
    if not (finite(q) and finite(qd) and finite(qdd)):
        return NONFINITE
    R, o, z, c, Ic = pose_buffers(ws, n)
    kinematics(model, q, R, o, z, c, Ic, tree_of(model))  # a chain's copy for a chain
    for j in range(n):
        for col in range(10 * n):
            Y[j, col] = 0.0
    g = (model[0, 0], model[0, 1], model[0, 2])
    w = (0.0, 0.0, 0.0)  # angular velocity of the parent link, base coordinates
    wd = (0.0, 0.0, 0.0)  # its angular acceleration
    a_o = scale(g, -1.0)  # acceleration of the parent's origin minus gravity
    for i in range(n):
        zi, oi = vec(z, i), vec(o, i)
        p_star = sub(oi, vec(o, i - 1)) if i > 0 else oi  # from the parent's origin to o_i
        a_o = add(a_o, add(cross(wd, p_star), cross(w, cross(w, p_star))))
        if is_prismatic(model, i):
            a_o = add(a_o, add(scale(cross(w, zi), 2.0 * qd[i]), scale(zi, qdd[i])))
        else:
            wd = add(wd, add(scale(cross(w, zi), qd[i]), scale(zi, qdd[i])))
            w = add(w, scale(zi, qd[i]))
        Ri = rot(R, i)
        a_l, w_l, wd_l = mtv(Ri, a_o), mtv(Ri, w), mtv(Ri, wd)  # link frame
        for k in range(10):
            f_l, n_l = unit_wrench(k, a_l, w_l, wd_l)
            f, nm = mvt(Ri, f_l), mvt(Ri, n_l)  # base coordinates, moment about o_i
            for j in range(i + 1):
                if is_prismatic(model, j):
                    Y[j, 10 * i + k] = dot(vec(z, j), f)
                else:
                    r = sub(oi, vec(o, j))
                    Y[j, 10 * i + k] = dot(vec(z, j), add(nm, cross(r, f)))
    return OK if finite(Y) else OVERFLOW


@nb.njit(**PARALLEL)
def regressor_batch(model, Q, QD, QDD, Y, STATUS, ws):
    """``regressor_ws`` over a batch: Q, QD, QDD (B, n), Y (B, n, 10 n), STATUS (B,); ws: a
    ``batch_scratch`` (kernels/layout.py)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = regressor_ws(model, Q[b], QD[b], QDD[b], Y[b], own_scratch(ws))
