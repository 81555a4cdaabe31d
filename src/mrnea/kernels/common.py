"""What every kernel shares: 3-vector and 3x3 algebra on tuples, the kinematics pass and the
entries' checks. The layout of the compiled model, of the scratch and the Numba options are in
``layout.py``.

Every kernel works in base coordinates, as the paper does: ``R[i]`` (3, 3) is link i's orientation,
``o[i]`` (3,) its frame origin (a point on joint i's axis), ``z[i]`` (3,) joint i's unit axis,
``c[i]`` (3,) its centre of mass and ``Ic[i]`` (3, 3) its inertia about the centre of mass.

3-vectors inside kernels are tuples ``(x, y, z)``: Numba keeps them in registers, so the
equations read as written and allocate nothing.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numba.extending import overload

from mrnea.kernels.layout import (
    COM,
    INER,
    INLINE,
    JIT,
    NOCOM,
    NOPOS,
    POS,
    ROT,
    ROTB,
    ROTC,
    ZAX,
    is_prismatic,
    parent,
)

# --- 3-vector algebra on tuples -----------------------------------------------------------------

@nb.njit(**INLINE)
def vec(a, k):
    """Row ``k`` of an (m, 3) array as a tuple."""
    return (a[k, 0], a[k, 1], a[k, 2])


@nb.njit(**INLINE)
def put(a, k, v):
    a[k, 0] = v[0]
    a[k, 1] = v[1]
    a[k, 2] = v[2]


@nb.njit(**INLINE)
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@nb.njit(**INLINE)
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@nb.njit(**INLINE)
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@nb.njit(**INLINE)
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@nb.njit(**INLINE)
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@nb.njit(**INLINE)
def mv(M, k, v):
    """``M[k] @ v`` for a stack of 3x3 matrices M (m, 3, 3), read entry by entry (no view)."""
    return (M[k, 0, 0] * v[0] + M[k, 0, 1] * v[1] + M[k, 0, 2] * v[2],
            M[k, 1, 0] * v[0] + M[k, 1, 1] * v[1] + M[k, 1, 2] * v[2],
            M[k, 2, 0] * v[0] + M[k, 2, 1] * v[1] + M[k, 2, 2] * v[2])


# ``triple`` and ``mat`` take a slice of a model row, ``model[r, COL:COL + 3]``: given the column
# constant itself, Numba would type it as a literal and compile them once per constant (seven
# compilations in the kinematics alone, about 0.8 s of a first call, measured).

@nb.njit(**INLINE)
def triple(a):
    """``a[0:3]`` as a 3-tuple."""
    return (a[0], a[1], a[2])


# 3x3 matrices inside kernels are row-major 9-tuples, like 3-vectors kept in registers

@nb.njit(**INLINE)
def mat(a):
    """The row-major 3x3 matrix ``a[0:9]`` as a 9-tuple."""
    return (a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8])


@nb.njit(**INLINE)
def mm(A, B):
    """``A @ B`` for 9-tuples."""
    return (A[0] * B[0] + A[1] * B[3] + A[2] * B[6], A[0] * B[1] + A[1] * B[4] + A[2] * B[7],
            A[0] * B[2] + A[1] * B[5] + A[2] * B[8],
            A[3] * B[0] + A[4] * B[3] + A[5] * B[6], A[3] * B[1] + A[4] * B[4] + A[5] * B[7],
            A[3] * B[2] + A[4] * B[5] + A[5] * B[8],
            A[6] * B[0] + A[7] * B[3] + A[8] * B[6], A[6] * B[1] + A[7] * B[4] + A[8] * B[7],
            A[6] * B[2] + A[7] * B[5] + A[8] * B[8])


@nb.njit(**INLINE)
def mmt(A, B):
    """The upper triangle (xx, xy, xz, yy, yz, zz) of ``A @ B.T`` for 9-tuples, where the
    product is known to be symmetric."""
    return (A[0] * B[0] + A[1] * B[1] + A[2] * B[2], A[0] * B[3] + A[1] * B[4] + A[2] * B[5],
            A[0] * B[6] + A[1] * B[7] + A[2] * B[8], A[3] * B[3] + A[4] * B[4] + A[5] * B[5],
            A[3] * B[6] + A[4] * B[7] + A[5] * B[8], A[6] * B[6] + A[7] * B[7] + A[8] * B[8])


@nb.njit(**INLINE)
def put_sym(M, k, S):
    """``M[k] = S`` for a stack of 3x3 matrices M and the upper triangle S of ``mmt``."""
    M[k, 0, 0], M[k, 0, 1], M[k, 0, 2] = S[0], S[1], S[2]
    M[k, 1, 0], M[k, 1, 1], M[k, 1, 2] = S[1], S[3], S[4]
    M[k, 2, 0], M[k, 2, 1], M[k, 2, 2] = S[2], S[4], S[5]


@nb.njit(**INLINE)
def mvt(A, v):
    """``A @ v`` for a 9-tuple A and a 3-tuple v."""
    return (A[0] * v[0] + A[1] * v[1] + A[2] * v[2],
            A[3] * v[0] + A[4] * v[1] + A[5] * v[2],
            A[6] * v[0] + A[7] * v[1] + A[8] * v[2])


@nb.njit(**INLINE)
def mtv(A, v):
    """``A.T @ v`` for a 9-tuple A and a 3-tuple v."""
    return (A[0] * v[0] + A[3] * v[1] + A[6] * v[2],
            A[1] * v[0] + A[4] * v[1] + A[7] * v[2],
            A[2] * v[0] + A[5] * v[1] + A[8] * v[2])


@nb.njit(**INLINE)
def rot(R, k):
    """``R[k]`` of an (m, 3, 3) array as a 9-tuple."""
    return (R[k, 0, 0], R[k, 0, 1], R[k, 0, 2], R[k, 1, 0], R[k, 1, 1], R[k, 1, 2],
            R[k, 2, 0], R[k, 2, 1], R[k, 2, 2])


@nb.njit(**INLINE)
def put_mat(M, k, A):
    for a in range(3):
        for b in range(3):
            M[k, a, b] = A[3 * a + b]


@nb.njit(**JIT)
def kinematics(model, q, R, o, z, c, Ic, tree):
    """Link poses in base coordinates: fills R, o, z, c, Ic (shapes in the module docstring).

    ``T_i = T_{λ(i)} @ origin_i @ motion_i(q_i)``: the parent's pose is carried from the previous
    link when λ(i) = i - 1 (always, on a chain), else read back from R, o (docs/notation.md).
    A revolute joint turns the joint frame about its unit axis a by q_i:
    ``R_i = R_{i-1} (A + sin q_i A[a]x + (1 - cos q_i) A[a]x^2)``, a product of exact rotations,
    so rounding does not compound along the chain. A prismatic joint moves the origin by
    ``z_i q_i``. ``z_i = R_{i-1} (A a)`` (``R_{λ(i)}`` on a tree). Terms of a zero offset are
    skipped (NOPOS, NOCOM). ``tree=None`` compiles a serial chain's copy, without the
    parent look-up (kernels/mrnea.py ``mrnea_ws``); ``tree=True`` runs any tree. Every caller
    passes ``tree`` (no default): an omitted argument and a literal True type differently, and
    Numba compiled the pass once for each (docs/performance.md, Start-up).
    """
    Rp = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)  # orientation of the parent (the base)
    op = (0.0, 0.0, 0.0)
    for i in range(q.shape[0]):
        r = i + 1
        p = i - 1 if tree is None else parent(model, i)
        if p != i - 1:  # a later child: its parent's pose (the base's: the identity)
            if p >= 0:
                Rp, op = rot(R, p), vec(o, p)
            else:
                Rp, op = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0)
        zi = mvt(Rp, triple(model[r, ZAX:ZAX + 3]))
        oi = op if model[r, NOPOS] else add(op, mvt(Rp, triple(model[r, POS:POS + 3])))
        A = mat(model[r, ROT:ROT + 9])
        if is_prismatic(model, i):
            oi = add(oi, scale(zi, q[i]))
            Ri = mm(Rp, A)
        else:
            s = np.sin(q[i])
            v = 1.0 - np.cos(q[i])
            B, C = mat(model[r, ROTB:ROTB + 9]), mat(model[r, ROTC:ROTC + 9])
            Ri = mm(Rp, (A[0] + s * B[0] + v * C[0], A[1] + s * B[1] + v * C[1],
                         A[2] + s * B[2] + v * C[2], A[3] + s * B[3] + v * C[3],
                         A[4] + s * B[4] + v * C[4], A[5] + s * B[5] + v * C[5],
                         A[6] + s * B[6] + v * C[6], A[7] + s * B[7] + v * C[7],
                         A[8] + s * B[8] + v * C[8]))
        put_mat(R, i, Ri)
        put(o, i, oi)
        put(z, i, zi)
        # centre of mass and inertia in base coordinates: c = o + R com, Ic = R I R^T (symmetric)
        put(c, i, oi if model[r, NOCOM] else add(oi, mvt(Ri, triple(model[r, COM:COM + 3]))))
        put_sym(Ic, i, mmt(mm(Ri, mat(model[r, INER:INER + 9])), Ri))
        Rp = Ri
        op = oi


@nb.njit(**INLINE)
def tip_point(o, R, n, pe):
    """Base-frame point where the external wrench acts: o_n + R_n p_e (p_e in link-n frame;
    ``pe=None``: the link frame's origin o_n)."""
    if pe is None:
        return vec(o, n - 1)
    return add(vec(o, n - 1), mv(R, n - 1, (pe[0], pe[1], pe[2])))


# --- external wrenches --------------------------------------------------------------------------
# ``fext`` is None (no wrench), (6,) (the last link's wrench, ``pe`` (3,) its point in that link's
# frame: the paper's k_e, entered as a virtual link n + 1) or (n, 6) (one wrench per link, base
# coordinates, ``pe`` (n, 3) the point of each in its own link's frame: Pinocchio's fext, a
# wrench per body). Which one is a compile-time choice (the overloads below read the array's
# type), so the free-motion and last-link paths compile exactly as before.

@nb.njit(**INLINE)
def link_wrench(o, R, fext, pe, i):
    """Link i's wrench of a per-link ``fext`` (n, 6): (f, n, p), its force and moment (base
    coordinates) and the base-frame point p = o_i + R_i pe[i] where it acts."""
    f = (fext[i, 0], fext[i, 1], fext[i, 2])
    m = (fext[i, 3], fext[i, 4], fext[i, 5])
    if pe is None:
        return f, m, vec(o, i)
    return f, m, add(vec(o, i), mv(R, i, (pe[i, 0], pe[i, 1], pe[i, 2])))


def per_link_type(fext) -> bool:
    """True for a per-link wrench array's Numba type (a 2-D array)."""
    return isinstance(fext, nb.types.Array) and fext.ndim == 2


@nb.njit(**INLINE)
def _tip_wrench(o, R, n, fext, pe):
    f, m = wrench(fext)
    return f, m, tip_point(o, R, n, pe)


@nb.njit(**INLINE)
def _no_tip_wrench(o, R, n, fext, pe):
    return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), vec(o, n - 1)


def tip_wrench(o, R, n, fext, pe):
    """(f_{n+1}, n_{n+1}, p): the virtual link n + 1's force and moment (Eqs. 10-11) and the
    base-frame point where they act: the last link's wrench at its point; zero for a per-link
    ``fext`` (those are folded into the links' own F, N by :func:`fold_wrenches`). Python body
    for NUMBA_DISABLE_JIT; compiled code uses the overload."""
    if fext is not None and np.ndim(fext) == 2:
        return _no_tip_wrench(o, R, n, fext, pe)
    return _tip_wrench(o, R, n, fext, pe)


@overload(tip_wrench, inline="always")
def _tip_wrench_overload(o, R, n, fext, pe):
    return (_no_tip_wrench if per_link_type(fext) else _tip_wrench).py_func


@nb.njit(**INLINE)
def _fold(R, o, c, fext, pe, F, N):
    for i in range(F.shape[0]):
        f, m, p = link_wrench(o, R, fext, pe, i)
        put(F, i, add(vec(F, i), f))
        put(N, i, add(vec(N, i), add(m, cross(sub(p, vec(c, i)), f))))


@nb.njit(**INLINE)
def _no_fold(R, o, c, fext, pe, F, N):
    return


def fold_wrenches(R, o, c, fext, pe, F, N):
    """A per-link ``fext``: link i's wrench, exerted on its environment, is a force and a moment
    the link needs on top of its own, so it adds to the link's total force F_i (Eq. 6) f_i and to
    its moment N_i about the centre of mass (Eq. 7) n_i + (p_i - c_i) x f_i; the backward passes
    then carry it to every joint that supports link i. No-op for None or a last-link (6,)
    ``fext``. Python body for NUMBA_DISABLE_JIT; compiled code uses the overload."""
    if fext is not None and np.ndim(fext) == 2:
        _fold(R, o, c, fext, pe, F, N)


@overload(fold_wrenches, inline="always")
def _fold_overload(R, o, c, fext, pe, F, N):
    return (_fold if per_link_type(fext) else _no_fold).py_func


@nb.njit(**INLINE)
def finite(a):
    """True when every entry of the array ``a`` is finite (``None``: no array, True)."""
    if a is None:
        return True
    for x in a.flat:
        if not np.isfinite(x):
            return False
    return True


@nb.njit(**INLINE)
def wrench(fext):
    """The external wrench ``fext = [f_e; n_e]`` (6,) as two 3-tuples; ``None``: no wrench
    (Numba compiles that case without reading an array: the free-motion fast path)."""
    if fext is None:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    return (fext[0], fext[1], fext[2]), (fext[3], fext[4], fext[5])


@nb.njit(**INLINE)
def sized(model, a, b, c):
    """True when the state arrays a, b, c (n,) each hold one entry per joint of ``model``."""
    n = model.shape[0] - 1
    return a.shape[0] == n and b.shape[0] == n and c.shape[0] == n
