"""mRNEA: the paper's modified RNEA, the mass matrix H and bias u' in one pass (Eqs. 4-36).

Usage: ``mrnea(model, q, qd, fext, pe, H, u, ws)`` fills ``H`` (n, n) and ``u`` (n,) so that the
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
* n'_ia1 + n'_ia2 + n'_ia3 (Eqs. 29-31), accumulated tip to base into one matrix ``M`` (row k
  for column k): a1 adds d_ik + l_i x e_ik for k <= i (Eq. 24), a2 adds p*_i x E_{(i+1)k} for
  k <= i+1 (Eq. 25), a3 adds p*_i x E_kk for k >= i+2 (Eq. 26). n'_ic = n'_{(i+1)c} + n_ic
  (Eqs. 23, 28).
* h_ik = z_i . M[k] (Eq. 35), u'_i = z_i . n'_ic (Eq. 36).
* a3 only feeds h_ik with k >= i+2, the upper triangle, which equals h_ki because H is
  symmetric; ``mrnea`` fills it so and skips a3 (half the cross products), ``mrnea_full``
  computes every h_ik the paper's way, and the tests check that the two agree.
* Sec. IV's simplification for a given robot: where p*_i = 0 (joint i+1 revolute with a zero
  origin offset: consecutive axes intersect in o_i) the a2/a3 terms and p*_i x E_{i+1} vanish, and
  where l_i = 0 (the centre of mass at o_i) the l_i x e terms do; the model's NOPOS/NOCOM flags
  (kernels/layout.py) skip them, and the tests check the result is bit-for-bit the general one.

``ws`` is a scratch (kernels/layout.py). ``mrnea`` and ``fd_mrnea`` are the
single-state entries (they check the state's lengths, status SIZE, and layout, LAYOUT, and call
``mrnea_ws`` with the loops' types: kernels/entry.py); ``mrnea_ws``, which does not check, is
what the batch kernels and the simulation loop call.

Beyond the paper (which treats revolute joints): for a prismatic joint i the effort is the force
along its axis, so h_ik = z_i . E_ik and u'_i = z_i . E_i. Eq. 14 folds the external force f_e
into e_n; here it is E_{n+1} = f_e, acting at the point p_e, so that it enters through
p*_n = p_e - o_n exactly as Eq. 22 writes it, with n'_{(n+1)c} = n_e. A wrench per link
(``fext`` (n, 6), kernels/common.py) is folded into each link's e_i and d_i instead: it has no
qdd part, so it only changes u'. Indices follow
kernels/rnea.py (docs/notation.md).
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
    mv,
    put,
    scale,
    sized,
    sub,
    tip_wrench,
    vec,
)
from mrnea.kernels.entry import contiguous, loop_args
from mrnea.kernels.layout import (
    BRANCH,
    DEPTH,
    ENTRY,
    INLINE,
    INTO_CALLER,
    JIT,
    MASS,
    NOCOM,
    NOPOS,
    STASH,
    SUBEND,
    carries,
    column_stash,
    is_prismatic,
    mrnea_buffers,
    parent,
    pose_buffers,
    solve_buffers,
    stash_buffers,
    tree_of,
)
from mrnea.kernels.rnea import link_forces
from mrnea.kernels.solve import solve_forward
from mrnea.kernels.status import LAYOUT, NONFINITE, OK, OVERFLOW, SIZE


@nb.njit(**INLINE)
def slot(SC, t):
    """3-vector t of the column stash ``SC`` (n, n), read as a flat row-major array."""
    n = SC.shape[1]
    f = 3 * t
    return (SC[f // n, f % n], SC[(f + 1) // n, (f + 1) % n], SC[(f + 2) // n, (f + 2) % n])


@nb.njit(**INLINE)
def put_slot(SC, t, v):
    """Writes 3-vector t of the column stash ``SC`` (as :func:`slot`)."""
    n = SC.shape[1]
    f = 3 * t
    SC[f // n, f % n] = v[0]
    SC[(f + 1) // n, (f + 1) % n] = v[1]
    SC[(f + 2) // n, (f + 2) % n] = v[2]


@nb.njit(**ENTRY)
def mrnea(model, q, qd, fext, pe, H, u, ws):
    """H (n, n) and u' (n,) of one state, in one pass (module docstring); returns a status.

    Rows are formed tip to base with n'_ia1 and n'_ia2 (h_ik, k <= i); the upper triangle is
    h_ik = h_ki (H is symmetric), so n'_ia3 is not formed: :func:`mrnea_full` forms it.
    ``ws``: a scratch (kernels/layout.py ``entry_scratch``).
    """
    if not sized(model, q, qd, qd):
        return SIZE
    if not (contiguous(q) and contiguous(qd) and contiguous(fext) and contiguous(pe)):
        return LAYOUT  # the wrapper's validated path (kernels/entry.py)
    qc, qdc, _, fe, p = loop_args(q, qd, None, fext, pe)  # the loops' types: one pass for all
    return mrnea_ws(model, qc, qdc, fe, p, H, u, False, ws)


@nb.njit(**ENTRY)
def mrnea_full(model, q, qd, fext, pe, H, u, ws):
    """As :func:`mrnea`, every h_ik from Eq. 35 with all three of n'_ia1, n'_ia2, n'_ia3.

    The paper's form, kept to test that it equals the symmetric fill (tests/).
    """
    if not sized(model, q, qd, qd):
        return SIZE
    return mrnea_ws(model, q, qd, fext, pe, H, u, True, ws)


@nb.njit(**INTO_CALLER)
def mrnea_ws(model, q, qd, fext, pe, H, u, full, ws):
    """:func:`mrnea` (``full``: :func:`mrnea_full`) on the scratch ``ws`` (kernels/layout.py).

    Compiled into its caller: it passes :func:`pass_of` the chain/tree choice the model's type
    makes (kernels/layout.py ``tree_of``: None for a chain, True for a tree), so that a chain
    compiles neither the tree's copy of the pass nor its callees (docs/performance.md
    section 18).
    """
    return pass_of(model, q, qd, fext, pe, H, u, full, ws, tree_of(model))


@nb.njit(**JIT)
def pass_of(model, q, qd, fext, pe, H, u, full, ws, tree):
    """:func:`mrnea_ws`'s pass; ``tree``: None on a serial chain, True on a tree.

    A serial chain runs :func:`mrnea_pass` compiled for ``tree=None``: Numba drops the tree's
    branches from that copy, so a chain runs the operations of the pass before trees, at its
    speed (the branches left in, never taken, cost a chain 14-19 % of the pass:
    docs/performance.md section 14). That copy is compiled into this function
    (``chain_pass``): a call of its own passed every array argument as a dozen scalars, about
    80 a state, 2-4 % of a chain's pass (docs/performance.md section 16). A tree runs the
    tree's copy (``tree_pass``), a call of its own. Numba prunes ``tree is None`` on an
    argument's type, so each compiles only its own branch (a choice read from the model's
    values compiled both: section 18).
    """
    if not (finite(q) and finite(qd) and finite(fext) and finite(pe)):
        return NONFINITE
    if tree is None:
        return chain_pass(model, q, qd, fext, pe, H, u, full, ws, None)
    return tree_pass(model, q, qd, fext, pe, H, u, full, ws, True)


def mrnea_pass(model, q, qd, fext, pe, H, u, full, ws, tree):
    """The pass of :func:`mrnea_ws` on finite inputs; ``tree``: None on a serial chain (the
    tree's branches compiled out), True on a tree. Compiled twice below (``chain_pass``,
    ``tree_pass``: :func:`pass_of` calls one), never called as is."""
    n = q.shape[0]
    R, o, z, c, Ic = pose_buffers(ws, n)
    kinematics(model, q, R, o, z, c, Ic, tree)
    g = (model[0, 0], model[0, 1], model[0, 2])
    # E row k: E_{(i+1)k} (Eqs. 25-26); M row k: column k of n'_ia1 + n'_ia2 (+ n'_ia3) (Eqs. 29-31)
    e, d, E, M = mrnea_buffers(ws, n)
    for k in range(n):
        put(E, k, (0.0, 0.0, 0.0))
        put(M, k, (0.0, 0.0, 0.0))

    # forward pass: the velocity terms e_i (Eq. 13) and d_i (Eq. 17) are the link forces and
    # moments of the RNEA's forward pass with qdd = 0 (Eqs. 5 and 9 without their qdd sums)
    if tree is None:
        link_forces(model, o, z, c, Ic, qd, None, g, e, d, None)
    else:
        link_forces(model, o, z, c, Ic, qd, None, g, e, d, ws)
    fold_wrenches(R, o, c, fext, pe, e, d)  # a wrench per link, if given (kernels/common.py)
    # a tree's later children put their sums aside here (docs/notation.md, Trees)
    Sc, Sn = stash_buffers(ws, n)
    SC = column_stash(ws, n)

    # backward pass: E sums and n' coefficients, tip to base
    # E_{i+1} starts as f_{n+1} = f_e, n'_{(i+1)c} as n_e
    E_c, n_c, p_next = tip_wrench(o, R, n, fext, pe)
    for i in range(n - 1, -1, -1):
        oi, ci, zi = vec(o, i), vec(c, i), vec(z, i)
        m_i = model[i + 1, MASS]
        l_i = sub(ci, oi)
        p_star = sub(p_next, oi)  # p*_i
        # the first child i + 1 (on a chain, every link but the last has it); on a tree a leaf
        # starts from zero sums (a later child's step cleared them)
        first = i < n - 1 and (tree is None or parent(model, i + 1) == i)
        # Sec. IV's simplifications: terms with p*_i = 0 (o_{i+1} = o_i, NOPOS) or l_i = 0
        # (NOCOM) vanish; at i = n-1 the a2, a3 terms do too (E_{(n+1)k} = 0: f_e has no qdd part)
        has_p = first and not model[i + 2, NOPOS]
        has_l = not model[i + 1, NOCOM]
        if has_p:  # a2 (Eq. 25): p*_i x E_{(i+1)k}, k <= i+1 (k in κ(i+1) ∪ {i+1} on a tree)
            for k in range(i + 2):
                if tree is None or carries(model, k, i + 1):
                    put(M, k, add(vec(M, k), cross(p_star, vec(E, k))))
            if full:  # a3 (Eq. 26): p*_i x E_kk, k >= i+2 (in ν(i+1) on a tree)
                for k in range(i + 2, int(model[i + 2, SUBEND])):
                    put(M, k, add(vec(M, k), cross(p_star, vec(E, k))))
        branch = tree is not None and model[i + 1, BRANCH]
        if branch:  # the later children's columns k in κ(i) ∪ {i}, stashed at o_i
            s0 = int(model[i + 1, STASH])
            k = i
            while k >= 0:
                s = s0 + int(model[k + 1, DEPTH])
                put(E, k, add(vec(E, k), slot(SC, 2 * s)))
                put(M, k, add(vec(M, k), slot(SC, 2 * s + 1)))
                k = parent(model, k)
        # a1 (Eq. 24): d_ik + l_i x e_ik, k <= i (k in κ(i) ∪ {i}); and E_{ik} = E_{(i+1)k} + e_ik
        for k in range(i + 1):
            if tree is not None and not carries(model, k, i):
                continue
            zk = vec(z, k)
            if is_prismatic(model, k):
                e_ik = scale(zk, m_i)  # Eqs. 5, 15
                t = cross(l_i, e_ik) if has_l else (0.0, 0.0, 0.0)
            else:
                e_ik = scale(cross(zk, sub(ci, vec(o, k))), m_i)  # Eqs. 5, 15
                t = mv(Ic, i, zk)  # d_ik (Eq. 16)
                if has_l:
                    t = add(t, cross(l_i, e_ik))
            put(M, k, add(vec(M, k), t))
            put(E, k, add(vec(E, k), e_ik))
        e_i = vec(e, i)
        # n_ic = d_i + l_i x e_i + p*_i x E_{i+1} (Eq. 23); n'_ic = n'_{(i+1)c} + n_ic (Eq. 28)
        n_ic = vec(d, i)
        if has_l:
            n_ic = add(n_ic, cross(l_i, e_i))
        if i == n - 1 or has_p:
            n_ic = add(n_ic, cross(p_star, E_c))
        n_c = add(n_c, n_ic)
        E_c = add(E_c, e_i)  # E_i
        if branch:  # the later children's velocity parts, stashed at o_i
            n_c, E_c = add(n_c, vec(Sn, i)), add(E_c, vec(Sc, i))
        # Eqs. 35-36: moments projected on the axis; forces for a prismatic joint
        prismatic = is_prismatic(model, i)
        C = E if prismatic else M
        end = model[i + 1, SUBEND]
        for k in range(n if full else i + 1):
            # h_ik = 0 unless k carries i or i carries k (the latter: the full form only)
            if tree is None or (carries(model, k, i) if k <= i else k < end):
                H[i, k] = dot(zi, vec(C, k))
            else:
                H[i, k] = 0.0
            if not full:
                H[k, i] = H[i, k]
        u[i] = dot(zi, E_c if prismatic else n_c)
        p_next = oi
        b = i - 1 if tree is None else parent(model, i)
        if b != i - 1:
            # a later child of b: its sums moved to o_b and put aside until b's step (b's last
            # child opens b's stash: written, not added to), then a leaf starts from zero
            if b >= 0:
                ob = vec(o, b)
                r = sub(oi, ob)
                opens = model[i + 1, SUBEND] == model[b + 1, SUBEND]
                n_b = add(n_c, cross(r, E_c))
                put(Sc, b, E_c if opens else add(vec(Sc, b), E_c))
                put(Sn, b, n_b if opens else add(vec(Sn, b), n_b))
                s0 = int(model[b + 1, STASH])
                k = b
                while k >= 0:
                    s = s0 + int(model[k + 1, DEPTH])
                    Ek = vec(E, k)
                    Mk = add(vec(M, k), cross(r, Ek))
                    put_slot(SC, 2 * s, Ek if opens else add(slot(SC, 2 * s), Ek))
                    put_slot(SC, 2 * s + 1, Mk if opens else add(slot(SC, 2 * s + 1), Mk))
                    put(E, k, (0.0, 0.0, 0.0))
                    put(M, k, (0.0, 0.0, 0.0))
                    k = parent(model, k)
                if full:  # its own columns, to o_b in place
                    for k in range(i, int(model[i + 1, SUBEND])):
                        put(M, k, add(vec(M, k), cross(r, vec(E, k))))
            E_c, n_c = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    return OK if finite(H) and finite(u) else OVERFLOW


chain_pass = nb.njit(**INTO_CALLER)(mrnea_pass)  # a chain's copy, compiled into pass_of
tree_pass = nb.njit(**JIT)(mrnea_pass)  # a tree's, a call of its own


@nb.njit(**ENTRY)
def fd_mrnea(model, q, qd, tau, fext, pe, qdd, ws):
    """The paper's forward dynamics: one mRNEA pass, then H qdd = tau - u' (Eq. 2).

    Returns OK, SIZE (a state of the wrong length), NONFINITE, or the index of the pivot where
    H is not positive definite. Scratch: a ``SOLVE`` one (kernels/layout.py ``solve_buffers``:
    H, L, u', tau - u').
    """
    if not sized(model, q, qd, tau):
        return SIZE
    if not (contiguous(q) and contiguous(qd) and contiguous(fext) and contiguous(pe)):
        return LAYOUT  # as mrnea
    H, L, u, rhs = solve_buffers(ws, q.shape[0])
    qc, qdc, _, fe, p = loop_args(q, qd, None, fext, pe)
    status = mrnea_ws(model, qc, qdc, fe, p, H, u, False, ws)
    return solve_forward(model, status, H, u, tau, L, rhs, qdd)
