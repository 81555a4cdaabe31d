"""RNEA: recursive Newton-Euler inverse dynamics in base coordinates (paper Eqs. 4-19, 32-33).

Usage: ``rnea(model, q, qd, qdd, fext, pe, tau, ws)`` fills ``tau`` (n,) with the joint efforts
and the scratch ``ws``'s (kernels/layout.py) f, nm (n, 3): the force
and moment that link i-1 exerts on link i through joint i, in base coordinates, the moment taken
about the joint's point o_i (Eqs. 18-19).

Index convention (docs/notation.md): the paper's joint i turns about z_{i-1} through the origin of
frame i-1; here joint i turns about z[i] through o[i], the origin of link i's frame. The paper's
p*_i, the vector between consecutive joint points, is ``o[i+1] - o[i]``; its l_i, from the joint
point to the centre of mass, is ``c[i] - o[i]``.

External wrench: ``fext = [f_e; n_e]`` (6,), base coordinates, is what the last link exerts on
its environment (the paper's k_e), applied at ``pe`` (3,), a point given in the last link's frame.
It enters as the force f_{n+1} = f_e and moment n_{n+1} = n_e of a virtual link n+1 (Eqs. 10-11).
A wrench per link, ``fext`` (n, 6) with points ``pe`` (n, 3) each in its own link's frame, is
added to each link's F_i, N_i instead (kernels/common.py ``fold_wrenches``).
"""

from __future__ import annotations

import numba as nb

from mrnea.kernels.common import (
    add,
    cross,
    dot,
    finite,
    fold_wrenches,
    kinematics,
    mat,
    mm,
    mtv,
    mv,
    put,
    rot,
    scale,
    sized,
    sub,
    tip_wrench,
    vec,
)
from mrnea.kernels.entry import contiguous, loop_args
from mrnea.kernels.layout import (
    BRANCH,
    ENTRY,
    INTO_CALLER,
    JIT,
    MASS,
    NOCOM,
    NOPOS,
    PARALLEL,
    ROT,
    SUBEND,
    branch_buffers,
    effort_buffer,
    force_buffers,
    is_prismatic,
    own_scratch,
    parent,
    pose_buffers,
    stash_buffers,
    tree_of,
    tree_scratch,
)
from mrnea.kernels.status import LAYOUT, NONFINITE, OK, OVERFLOW, SIZE


@nb.njit(**JIT)
def link_forces(model, o, z, c, Ic, qd, qdd, g, F, N, ws):
    """Forward pass, base to tip: each link's total force F (Eq. 6) and moment N about its
    centre of mass (Eq. 7), given the kinematics of this state; fills F, N (n, 3).

    ``qdd=None`` means qdd = 0 (the velocity terms alone, as mRNEA needs them): Numba compiles
    that case without the qdd terms. On a tree, the parent's w, wd, a_o are carried from the
    previous link when λ(i) = i - 1, else read back from the scratch ``ws``'s
    ``branch_buffers``, where each link with a second child keeps them (docs/notation.md).
    ``ws=None`` compiles a serial chain's copy, without those branches and without the scratch
    among its arguments (kernels/mrnea.py ``mrnea_ws``): every array argument is passed as
    about a dozen scalars, and the scratch's four cost a chain's pass a few per cent
    (docs/performance.md, section 16).
    """
    n = qd.shape[0]
    w = (0.0, 0.0, 0.0)  # angular velocity of the parent link
    wd = (0.0, 0.0, 0.0)  # its angular acceleration
    a_o = (0.0, 0.0, 0.0)  # linear acceleration of the parent's origin
    for i in range(n):
        zi, oi = vec(z, i), vec(o, i)
        p = i - 1
        if ws is not None:
            p = parent(model, i)
            if p != i - 1:  # a later child: its parent's values (the base's: zero)
                if p >= 0:
                    Wb, WDb, Ab = branch_buffers(ws, n)
                    w, wd, a_o = vec(Wb, p), vec(WDb, p), vec(Ab, p)
                else:
                    w, wd, a_o = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        if not model[i + 1, NOPOS]:  # p*: from the parent's origin to o_i (zero: skipped)
            p_star = sub(oi, vec(o, p)) if p >= 0 else oi
            # acceleration of the point of the parent coinciding with o_i
            a_o = add(a_o, add(cross(wd, p_star), cross(w, cross(w, p_star))))
        if is_prismatic(model, i):
            a_o = add(a_o, scale(cross(w, zi), 2.0 * qd[i]))
            if qdd is not None:
                a_o = add(a_o, scale(zi, qdd[i]))
        else:
            wd = add(wd, scale(cross(w, zi), qd[i]))
            if qdd is not None:
                wd = add(wd, scale(zi, qdd[i]))
            w = add(w, scale(zi, qd[i]))
        if ws is not None:
            if model[i + 1, BRANCH]:  # kept for the later children
                Wb, WDb, Ab = branch_buffers(ws, n)
                put(Wb, i, w)
                put(WDb, i, wd)
                put(Ab, i, a_o)
        # Eq. 4: acceleration of the centre of mass
        a_cm = a_o
        if not model[i + 1, NOCOM]:
            r_cm = sub(vec(c, i), oi)
            a_cm = add(a_o, add(cross(wd, r_cm), cross(w, cross(w, r_cm))))
        put(F, i, scale(sub(a_cm, g), model[i + 1, MASS]))  # Eq. 6
        put(N, i, add(mv(Ic, i, wd), cross(w, mv(Ic, i, w))))  # Eq. 7


@nb.njit(**JIT)
def newton_euler(model, R, o, z, c, Ic, qd, qdd, g, fext, pe, tau, f, nm, ws):
    """The two Newton-Euler passes, given the kinematics (R, o, z, c, Ic) of this state.

    ``g`` is the gravity 3-tuple (Walker-Orin's columns pass zero); ``qdd=None`` means zero.
    Fills tau, f, nm; f and nm first hold each link's F (Eq. 6) and N (Eq. 7), which the
    backward pass reads once, tip to base, before it writes the joint force and moment there.
    On a tree (docs/notation.md, Trees) the first child's f, n are carried as on a chain, a
    later child's are moved to its parent's point and stashed (``ws``'s ``stash_buffers``)
    until the parent's step adds them (Eqs. 18-19 summed over the children). ``ws=None``
    compiles a serial chain's copy, without the tree's branches and without the scratch among
    its arguments (as ``link_forces``'s; :func:`rnea_ws` chooses by the model's type,
    kernels/layout.py ``tree_scratch``); any scratch runs any tree.
    """
    n = qd.shape[0]
    link_forces(model, o, z, c, Ic, qd, qdd, g, f, nm, ws)
    if ws is not None:
        Sf, Sn = stash_buffers(ws, n)
    fold_wrenches(R, o, c, fext, pe, f, nm)  # a wrench per link, if given (kernels/common.py)

    # backward pass: forces and moments, tip to base
    # f_{n+1} = f_e, n_{n+1} = n_e (Eqs. 10-11), acting at p_next
    f_next, n_next, p_next = tip_wrench(o, R, n, fext, pe)
    for i in range(n - 1, -1, -1):
        oi = vec(o, i)
        Fi = vec(f, i)
        fi = add(Fi, f_next)  # Eq. 18
        ni = add(n_next, vec(nm, i))  # Eq. 19: n_{i+1} + N_i + l_i x F_i + p*_i x f_{i+1}
        if not model[i + 1, NOCOM]:
            ni = add(ni, cross(sub(vec(c, i), oi), Fi))
        # p*_i x f_{i+1} with the first child i + 1 (p*_i = 0 where o_{i+1} = o_i); at the
        # last link, the wrench's point
        if i == n - 1 or ((ws is None or parent(model, i + 1) == i)
                          and not model[i + 2, NOPOS]):
            ni = add(ni, cross(sub(p_next, oi), f_next))
        if ws is not None:
            if model[i + 1, BRANCH]:  # the later children's, stashed at o_i
                fi, ni = add(fi, vec(Sf, i)), add(ni, vec(Sn, i))
        put(f, i, fi)
        put(nm, i, ni)
        # Eq. 33: projection on the axis of motion (force for a prismatic joint)
        tau[i] = dot(vec(z, i), fi if is_prismatic(model, i) else ni)
        f_next, n_next, p_next = fi, ni, oi
        if ws is not None:
            b = parent(model, i)
            if b != i - 1:  # a later child: to its parent's stash, moved to o_b; then a leaf
                if b >= 0:
                    n_b = add(ni, cross(sub(oi, vec(o, b)), fi))
                    if model[i + 1, SUBEND] == model[b + 1, SUBEND]:  # b's last child: opens
                        put(Sf, b, fi)
                        put(Sn, b, n_b)
                    else:
                        put(Sf, b, add(vec(Sf, b), fi))
                        put(Sn, b, add(vec(Sn, b), n_b))
                f_next, n_next = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)


@nb.njit(**JIT)
def rnea_ws(model, q, qd, qdd, fext, pe, tau, ws, pose_ready):
    """Inverse dynamics of one state; fills tau (n,) and the scratch's ``force_buffers`` f, nm
    (n, 3) (module docstring). Returns OK, or NONFINITE if an input holds NaN or inf.
    ``pose_ready``: the scratch's pose buffers already hold the kinematics of this q (the
    simulation loop, after an mRNEA pass on the same state), so they are not computed again.
    Every caller passes it as a run-time bool (:func:`fresh` where it is False): a literal or
    an omitted default would type another signature, a second compiled copy of the passes
    (docs/performance.md section 7).
    A serial chain's model (its type: kernels/layout.py ``tree_of``) runs the chain's copies of
    the kinematics and of :func:`newton_euler`, without the tree's branches (as ``mrnea_ws``:
    docs/performance.md sections 16, 18); a tree's, the tree's.
    """
    f, nm = force_buffers(ws, q.shape[0])
    if not (finite(q) and finite(qd) and finite(qdd) and finite(fext) and finite(pe)):
        return NONFINITE
    R, o, z, c, Ic = pose_buffers(ws, q.shape[0])
    g = (model[0, 0], model[0, 1], model[0, 2])
    if not pose_ready:
        kinematics(model, q, R, o, z, c, Ic, tree_of(model))
    newton_euler(model, R, o, z, c, Ic, qd, qdd, g, fext, pe, tau, f, nm, tree_scratch(model, ws))
    return OK if finite(tau) and finite(f) and finite(nm) else OVERFLOW


@nb.njit(**INTO_CALLER)
def fresh(q):
    """``pose_ready`` False as a run-time bool (``rnea_ws``): the type the loop's passes give."""
    return q.shape[0] < 0


@nb.njit(**ENTRY)
def rnea(model, q, qd, qdd, fext, pe, tau, ws):
    """Joint efforts tau (n,) of one state; returns a status (``rnea_ws``, after checking the
    state's lengths, SIZE, and layout, LAYOUT: ``rnea_ws`` is called with the batch's and the
    loop's types, kernels/entry.py)."""
    if not sized(model, q, qd, qdd):
        return SIZE
    if not (contiguous(q) and contiguous(qd) and contiguous(qdd) and contiguous(fext)
            and contiguous(pe)):
        return LAYOUT
    qc, qdc, qddc, fe, p = loop_args(q, qd, qdd, fext, pe)
    return rnea_ws(model, qc, qdc, qddc, fe, p, tau, ws, fresh(q))


@nb.njit(**JIT)
def reactions_ws(model, q, qd, qdd, fext, pe, out, ws, pose_ready):
    """Joint reaction wrenches of one state, each in its joint frame (Eq. 32).

    ``out[i] = [f; n]`` (6,): force [N] and moment [N m] that link i-1 exerts on link i through
    joint i, in the joint frame (the parent's frame moved by the joint origin, fixed to the
    parent: the bearing's housing), the moment about the joint frame's origin o_i.
    Scratch: any kind (its ``effort_buffer`` holds the efforts, not returned). ``pose_ready``:
    as ``rnea_ws`` (a run-time bool).
    """
    n = q.shape[0]
    status = rnea_ws(model, q, qd, qdd, fext, pe, effort_buffer(ws), ws, pose_ready)
    if status != OK:
        return status
    R, _, z, _, _ = pose_buffers(ws, n)
    f, nm = force_buffers(ws, n)
    for i in range(n):
        # joint frame: the parent's orientation times the origin rotation, D_{i-1} in Eq. 32
        # (D_{λ(i)} on a tree)
        p = parent(model, i)
        Rp = rot(R, p) if p >= 0 else (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
        Rj = mm(Rp, mat(model[i + 1, ROT:ROT + 9]))
        if is_prismatic(model, i):
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


@nb.njit(**ENTRY)
def reactions(model, q, qd, qdd, fext, pe, out, ws):
    """``reactions_ws`` after checking the state's lengths (status SIZE) and layout (LAYOUT),
    with the loop's types (as :func:`rnea`)."""
    if not sized(model, q, qd, qdd):
        return SIZE
    if not (contiguous(q) and contiguous(qd) and contiguous(qdd) and contiguous(fext)
            and contiguous(pe)):
        return LAYOUT
    qc, qdc, qddc, fe, p = loop_args(q, qd, qdd, fext, pe)
    return reactions_ws(model, qc, qdc, qddc, fe, p, out, ws, fresh(q))


@nb.njit(**PARALLEL)
def rnea_batch(model, Q, QD, QDD, FEXT, PE, TAU, STATUS, ws):
    """``rnea`` over a batch: Q, QD, QDD, TAU (B, n); FEXT (B, 6); PE (B, 3); STATUS (B,); ws: a
    ``batch_scratch`` (kernels/layout.py)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = rnea_ws(model, Q[b], QD[b], QDD[b], FEXT[b], PE[b], TAU[b], own_scratch(ws),
                            fresh(Q))


@nb.njit(**PARALLEL)
def reactions_batch(model, Q, QD, QDD, FEXT, PE, OUT, STATUS, ws):
    """``reactions`` over a batch, as ``rnea_batch``: OUT (B, n, 6)."""
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = reactions_ws(model, Q[b], QD[b], QDD[b], FEXT[b], PE[b], OUT[b],
                                 own_scratch(ws), fresh(Q))
