"""What every kernel shares: the compiled model layout, 3-vector helpers and the kinematics pass.

Compiled model (``Robot.compiled``): one float64 array of shape ``(n + 1, NCOL)``.
Row 0 holds the gravity vector in ``[0:3]``; row ``i + 1`` describes joint ``i`` and link ``i``::

    TYPE        0 revolute (and continuous), 1 prismatic
    ROT  (9)    origin rotation, parent link frame -> joint frame, row-major
    POS  (3)    origin translation [m], parent link frame
    AXIS (3)    unit joint axis, joint frame
    MASS        link mass [kg]
    COM  (3)    centre of mass [m], link frame
    INER (9)    inertia about the centre of mass [kg m^2], link-frame axes, row-major

Every kernel works in base coordinates, as the paper does: ``R[i]`` (3, 3) is link i's orientation,
``o[i]`` (3,) its frame origin (a point on joint i's axis), ``z[i]`` (3,) joint i's unit axis,
``c[i]`` (3,) its centre of mass and ``Ic[i]`` (3, 3) its inertia about the centre of mass.

3-vectors inside kernels are tuples ``(x, y, z)``: Numba keeps them in registers, so the
equations read as written and allocate nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numba as nb
import numpy as np

if TYPE_CHECKING:
    from mrnea.model import Robot

TYPE, ROT, POS, AXIS, MASS, COM, INER = 0, 1, 10, 13, 16, 17, 20
NCOL = 29
PRISMATIC = 1.0

# Kernel status codes: OK, NONFINITE (an input holds NaN or inf), OVERFLOW (finite inputs gave a
# result that is not finite: values too large for float64); a value >= 0 is the index of the
# joint whose pivot of H (or articulated inertia) is not positive.
OK = -1
NONFINITE = -2
OVERFLOW = -3

# Numba options, set in one place: compiled code is cached on disk next to the sources.
JIT = {"cache": True, "nogil": True, "fastmath": False, "error_model": "numpy"}
INLINE = JIT


def compile_model(robot: Robot) -> np.ndarray:
    """Flatten a validated Robot into the ``(n + 1, NCOL)`` array described above."""
    m = np.zeros((robot.n + 1, NCOL))
    m[0, :3] = robot.gravity
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True), start=1):
        m[i, TYPE] = PRISMATIC if j.is_prismatic else 0.0
        m[i, ROT:ROT + 9] = j.origin[:3, :3].ravel()
        m[i, POS:POS + 3] = j.origin[:3, 3]
        m[i, AXIS:AXIS + 3] = j.axis
        m[i, MASS] = lk.mass
        m[i, COM:COM + 3] = lk.com
        m[i, INER:INER + 9] = lk.inertia.ravel()
    m.setflags(write=False)
    return m


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


@nb.njit(**INLINE)
def triple(model, r, col):
    """``model[r, col:col+3]`` as a 3-tuple."""
    return (model[r, col], model[r, col + 1], model[r, col + 2])


# 3x3 matrices inside kernels are row-major 9-tuples, like 3-vectors kept in registers

@nb.njit(**INLINE)
def mat(model, r, col):
    """The row-major 3x3 block ``model[r, col:col+9]`` as a 9-tuple."""
    return (model[r, col], model[r, col + 1], model[r, col + 2],
            model[r, col + 3], model[r, col + 4], model[r, col + 5],
            model[r, col + 6], model[r, col + 7], model[r, col + 8])


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


@nb.njit(**INLINE)
def rotation(ax, angle):
    """Rodrigues: rotation by ``angle`` about the unit axis ``ax``, as a 9-tuple."""
    s, c = np.sin(angle), np.cos(angle)
    v = 1.0 - c
    x, y, w = ax
    return (c + x * x * v, x * y * v - w * s, x * w * v + y * s,
            y * x * v + w * s, c + y * y * v, y * w * v - x * s,
            w * x * v - y * s, w * y * v + x * s, c + w * w * v)


@nb.njit(**JIT)
def kinematics(model, q, R, o, z, c, Ic):
    """Link poses in base coordinates: fills R, o, z, c, Ic (shapes in the module docstring).

    ``T_i = T_{i-1} @ origin_i @ motion_i(q_i)``. A revolute joint turns the joint frame about its
    unit axis a by q_i, ``R_i = R_joint @ Rot(a, q_i)``: a product of exact rotations, so rounding
    does not compound along the chain. A prismatic joint moves the origin by ``z_i q_i``, z_i the
    axis in base coordinates.
    """
    Rp = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)  # orientation of the parent (the base)
    op = (0.0, 0.0, 0.0)
    for i in range(q.shape[0]):
        r = i + 1
        Rj = mm(Rp, mat(model, r, ROT))  # joint frame
        ax = triple(model, r, AXIS)
        zi = mvt(Rj, ax)
        oi = add(op, mvt(Rp, triple(model, r, POS)))
        if model[r, TYPE] == PRISMATIC:
            oi = add(oi, scale(zi, q[i]))
            Ri = Rj
        else:
            Ri = mm(Rj, rotation(ax, q[i]))
        put_mat(R, i, Ri)
        put(o, i, oi)
        put(z, i, zi)
        # centre of mass and inertia in base coordinates: c = o + R com, Ic = R I R^T
        put(c, i, add(oi, mvt(Ri, triple(model, r, COM))))
        RI = mm(Ri, mat(model, r, INER))
        for a in range(3):
            for b in range(3):
                Ic[i, a, b] = (RI[3 * a] * Ri[3 * b] + RI[3 * a + 1] * Ri[3 * b + 1]
                               + RI[3 * a + 2] * Ri[3 * b + 2])
        Rp = Ri
        op = oi


@nb.njit(**JIT)
def workspace(n):
    """Per-call buffers of the kinematics pass, R, o, z, c, Ic, carved from one allocation."""
    mats = np.empty((2 * n, 3, 3))  # row slices of C arrays are views without a reshape
    vecs = np.empty((3 * n, 3))
    return mats[:n], vecs[:n], vecs[n:2 * n], vecs[2 * n:], mats[n:]


@nb.njit(**INLINE)
def tip_point(o, R, n, pe):
    """Base-frame point where the external wrench acts: o_n + R_n p_e (p_e in link-n frame)."""
    return add(vec(o, n - 1), mv(R, n - 1, (pe[0], pe[1], pe[2])))


@nb.njit(**INLINE)
def finite(a):
    """True when every entry of the array ``a`` is finite."""
    for x in a.flat:
        if not np.isfinite(x):
            return False
    return True
