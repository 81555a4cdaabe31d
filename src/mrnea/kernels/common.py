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

# Kernel status codes: OK, NONFINITE (an input holds NaN or inf); a value >= 0 is the index of the
# joint whose pivot of H (or articulated inertia) is not positive.
OK = -1
NONFINITE = -2

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
def mv(M, v):
    """``M @ v`` for a 3x3 array ``M`` and a 3-tuple ``v``."""
    return (M[0, 0] * v[0] + M[0, 1] * v[1] + M[0, 2] * v[2],
            M[1, 0] * v[0] + M[1, 1] * v[1] + M[1, 2] * v[2],
            M[2, 0] * v[0] + M[2, 1] * v[1] + M[2, 2] * v[2])


@nb.njit(**INLINE)
def matmul(A, B, out):
    """``out = A @ B`` for 3x3 arrays (explicit loops: no BLAS call for a 3x3 product)."""
    for a in range(3):
        for b in range(3):
            out[a, b] = A[a, 0] * B[0, b] + A[a, 1] * B[1, b] + A[a, 2] * B[2, b]


@nb.njit(**INLINE)
def block(model, r, col):
    """The row-major 3x3 block ``model[r, col:col+9]`` as a (3, 3) view."""
    return model[r, col:col + 9].reshape((3, 3))


@nb.njit(**INLINE)
def triple(model, r, col):
    return (model[r, col], model[r, col + 1], model[r, col + 2])


@nb.njit(**JIT)
def kinematics(model, q, R, o, z, c, Ic):
    """Link poses in base coordinates: fills R, o, z, c, Ic (shapes in the module docstring).

    ``T_i = T_{i-1} @ origin_i @ motion_i(q_i)``. A revolute joint turns the joint frame about its
    unit axis a by q_i (Rodrigues: ``I + sin q [a]x + (1 - cos q) [a]x^2``); a prismatic joint
    moves the origin by ``z_i q_i``, z_i the axis in base coordinates.
    """
    n = q.shape[0]
    Rp = np.eye(3)  # orientation of the parent link (the base for joint 0)
    op = (0.0, 0.0, 0.0)
    Rj = np.empty((3, 3))  # joint-frame orientation Rp @ origin rotation (then scratch)
    Rz = np.empty((3, 3))  # rotation of a revolute joint, joint frame
    for i in range(n):
        r = i + 1
        matmul(Rp, block(model, r, ROT), Rj)
        ax = triple(model, r, AXIS)
        zi = mv(Rj, ax)
        oi = add(op, mv(Rp, triple(model, r, POS)))
        if model[r, TYPE] == PRISMATIC:
            oi = add(oi, scale(zi, q[i]))
            R[i] = Rj
        else:
            # R_i = Rj @ Rot(axis, q), the rotation about the unit axis in the joint frame: a
            # product of exact rotations, so rounding does not compound along the chain
            s, cq = np.sin(q[i]), np.cos(q[i])
            v = 1.0 - cq
            x, y, w = ax
            Rz[0, 0], Rz[0, 1], Rz[0, 2] = cq + x * x * v, x * y * v - w * s, x * w * v + y * s
            Rz[1, 0], Rz[1, 1], Rz[1, 2] = y * x * v + w * s, cq + y * y * v, y * w * v - x * s
            Rz[2, 0], Rz[2, 1], Rz[2, 2] = w * x * v - y * s, w * y * v + x * s, cq + w * w * v
            matmul(Rj, Rz, R[i])
        put(o, i, oi)
        put(z, i, zi)
        # centre of mass and inertia in base coordinates: c = o + R com, Ic = R I R^T
        put(c, i, add(oi, mv(R[i], triple(model, r, COM))))
        matmul(R[i], block(model, r, INER), Rj)
        for a in range(3):
            for b in range(3):
                Ic[i, a, b] = Rj[a, 0] * R[i, b, 0] + Rj[a, 1] * R[i, b, 1] + Rj[a, 2] * R[i, b, 2]
        Rp = R[i]
        op = oi
    return


@nb.njit(**JIT)
def workspace(n):
    """Per-call buffers of the kinematics pass: R, o, z, c, Ic."""
    return (np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)),
            np.empty((n, 3, 3)))


@nb.njit(**INLINE)
def tip_point(o, R, n, pe):
    """Base-frame point where the external wrench acts: o_n + R_n p_e (p_e in link-n frame)."""
    return add(vec(o, n - 1), mv(R[n - 1], pe))


@nb.njit(**INLINE)
def finite(a):
    """True when every entry of the 1-D array ``a`` is finite."""
    for x in a:
        if not np.isfinite(x):
            return False
    return True
