"""A slow, obviously-correct NumPy reference for the dynamics, independent of ``mrnea.kernels``.

Only :class:`mrnea.Robot`'s description (joints, links, gravity) is read; nothing here imports or
mirrors the compiled kernels. Three independent pieces:

* :func:`forward_kinematics`: link poses by composing 4x4 homogeneous transforms,
  ``T_i = T_{i-1} @ origin_i @ motion_i(q_i)`` (the model's stated convention).
* :func:`inverse_dynamics`: the textbook recursive Newton-Euler algorithm written with 6-D
  spatial vectors in base coordinates (Featherstone, *Rigid Body Dynamics Algorithms*, Sec. 5.3,
  with every quantity expressed in the fixed base frame, moments about the base origin):
  ``v_i = v_{i-1} + S_i qd_i``, ``a_i = a_{i-1} + S_i qdd_i + (v_i x) S_i qd_i``, gravity by a
  fictitious base acceleration ``a_0 = -g``, ``f_i = I_i a_i + (v_i x*) I_i v_i``, summed tip to
  base, ``tau_i = S_i . f_i``. This is a different formulation from the kernels' 3-vector
  recursion (paper Eqs. 4-19), so agreement is a real check.
* :func:`mass_matrix_jacobian`: ``H = sum_i m_i Jv_i^T Jv_i + Jw_i^T I_i Jw_i`` from the geometric
  centre-of-mass Jacobians (no Newton-Euler at all), and :func:`static_bias_jacobian`, the
  velocity-free bias ``g(q) + J^T f_ext = -sum_i m_i Jv_i^T g + J_tip^T f_ext``.
* :func:`forward_dynamics`: ``qdd = H^-1 (tau - u')`` with those two, by NumPy's LU solve.

External wrench ``f_ext = [f_e; n_e]`` (base coordinates): the wrench the last link exerts on the
environment, at ``f_ext_point`` (last link's frame), as in ``mrnea.dynamics``.
"""

from __future__ import annotations

import numpy as np

from mrnea.model import Robot


def skew(v: np.ndarray) -> np.ndarray:
    """The matrix ``[v]x`` with ``[v]x @ w = v x w``."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation by ``angle`` about the unit ``axis`` (Rodrigues' formula)."""
    K = skew(np.asarray(axis, dtype=float) / np.linalg.norm(axis))
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def motion(joint, qi: float) -> np.ndarray:
    """The joint's 4x4 motion transform at position ``qi``."""
    M = np.eye(4)
    if joint.is_prismatic:
        M[:3, 3] = np.asarray(joint.axis) * qi
    else:
        M[:3, :3] = axis_angle(joint.axis, qi)
    return M


def forward_kinematics(robot: Robot, q) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``(T_link, T_joint)``: per moving link, its 4x4 pose in the base frame and the pose of its
    joint frame (``T_{i-1} @ origin_i``, before the joint's motion)."""
    T = np.eye(4)
    links, joints = [], []
    for j, qi in zip(robot.joints, np.asarray(q, dtype=float), strict=True):
        Tj = T @ np.asarray(j.origin)
        T = Tj @ motion(j, qi)
        joints.append(Tj)
        links.append(T)
    return links, joints


def _geometry(robot: Robot, q):
    """Base-frame joint axes z, joint points o, centres of mass c and inertias about them."""
    T_link, T_joint = forward_kinematics(robot, q)
    z = [Tj[:3, :3] @ np.asarray(j.axis) for Tj, j in zip(T_joint, robot.joints, strict=True)]
    o = [Tj[:3, 3].copy() for Tj in T_joint]
    c = [T[:3, :3] @ np.asarray(lk.com) + T[:3, 3] for T, lk in zip(T_link, robot.links,
                                                                    strict=True)]
    Ic = [T[:3, :3] @ np.asarray(lk.inertia) @ T[:3, :3].T
          for T, lk in zip(T_link, robot.links, strict=True)]
    return T_link, T_joint, z, o, c, Ic


# --- spatial algebra (6-vectors [angular; linear], base frame, about the base origin) ----------
def motion_subspace(joint, z: np.ndarray, o: np.ndarray) -> np.ndarray:
    """``S``: the spatial velocity of a unit joint rate (the axis z through the point o)."""
    if joint.is_prismatic:
        return np.concatenate([np.zeros(3), z])
    return np.concatenate([z, np.cross(o, z)])


def spatial_inertia(m: float, c: np.ndarray, Ic: np.ndarray) -> np.ndarray:
    """6x6 inertia of a body of mass m, centre of mass c, inertia Ic about c, about the origin."""
    C = skew(c)
    return np.block([[Ic + m * C @ C.T, m * C], [m * C.T, m * np.eye(3)]])


def crm(v: np.ndarray) -> np.ndarray:
    """Motion cross product ``(v x)``."""
    W, V = skew(v[:3]), skew(v[3:])
    return np.block([[W, np.zeros((3, 3))], [V, W]])


def crf(v: np.ndarray) -> np.ndarray:
    """Force cross product ``(v x*) = -(v x)^T``."""
    return -crm(v).T


def _external(robot: Robot, T_link, f_ext, f_ext_point) -> np.ndarray:
    """The wrench the robot exerts on its environment as a spatial force about the base origin."""
    fe = np.zeros(6) if f_ext is None else np.asarray(f_ext, dtype=float)
    pe = np.zeros(3) if f_ext_point is None else np.asarray(f_ext_point, dtype=float)
    p = T_link[-1][:3, :3] @ pe + T_link[-1][:3, 3]
    return np.concatenate([fe[3:] + np.cross(p, fe[:3]), fe[:3]])


def newton_euler(robot: Robot, q, qd, qdd, f_ext=None, f_ext_point=None, gravity=True):
    """Spatial RNEA. Returns ``(tau, F)``: efforts (n,) and ``F`` (n, 6), the spatial force
    [moment about the base origin; force] that link i-1 exerts on link i through joint i."""
    n = robot.n
    qd, qdd = np.asarray(qd, dtype=float), np.asarray(qdd, dtype=float)
    T_link, _, z, o, c, Ic = _geometry(robot, q)
    g = np.asarray(robot.gravity, dtype=float) if gravity else np.zeros(3)
    v = np.zeros(6)
    a = np.concatenate([np.zeros(3), -g])
    F = np.zeros((n, 6))
    S = []
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True)):
        Si = motion_subspace(j, z[i], o[i])
        S.append(Si)
        v = v + Si * qd[i]
        a = a + Si * qdd[i] + crm(v) @ Si * qd[i]
        I = spatial_inertia(lk.mass, c[i], Ic[i])
        F[i] = I @ a + crf(v) @ I @ v
    F[-1] += _external(robot, T_link, f_ext, f_ext_point)
    for i in range(n - 1, 0, -1):
        F[i - 1] += F[i]
    tau = np.array([S[i] @ F[i] for i in range(n)])
    return tau, F


def inverse_dynamics(robot: Robot, q, qd, qdd, f_ext=None, f_ext_point=None) -> np.ndarray:
    """``tau = H qdd + C qd + g + J^T f_ext``, by the spatial Newton-Euler recursion."""
    return newton_euler(robot, q, qd, qdd, f_ext, f_ext_point)[0]


def joint_reactions(robot: Robot, q, qd, qdd, f_ext=None, f_ext_point=None) -> np.ndarray:
    """(n, 6): ``[f; n]`` that link i-1 exerts on link i, in joint i's frame (before the joint's
    motion), the moment about that frame's origin."""
    _, F = newton_euler(robot, q, qd, qdd, f_ext, f_ext_point)
    _, T_joint = forward_kinematics(robot, q)
    out = np.zeros((robot.n, 6))
    for i, Tj in enumerate(T_joint):
        R, o = Tj[:3, :3], Tj[:3, 3]
        f = F[i, 3:]
        m_o = F[i, :3] - np.cross(o, f)  # moment about the joint frame's origin
        out[i] = np.concatenate([R.T @ f, R.T @ m_o])
    return out


def mass_matrix_columns(robot: Robot, q) -> np.ndarray:
    """H by columns: naive ID with unit accelerations, no velocity, gravity nor external wrench."""
    n = robot.n
    H = np.zeros((n, n))
    for k in range(n):
        e = np.zeros(n)
        e[k] = 1.0
        H[:, k] = newton_euler(robot, q, np.zeros(n), e, gravity=False)[0]
    return H


def bias(robot: Robot, q, qd, f_ext=None, f_ext_point=None) -> np.ndarray:
    """``u' = C qd + g + J^T f_ext``: naive ID with zero acceleration."""
    return inverse_dynamics(robot, q, qd, np.zeros(robot.n), f_ext, f_ext_point)


def com_jacobians(robot: Robot, q) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Geometric Jacobians (3, n) of each link's centre-of-mass velocity and angular velocity."""
    n = robot.n
    _, _, z, o, c, _ = _geometry(robot, q)
    Jv, Jw = [], []
    for i in range(n):
        A, B = np.zeros((3, n)), np.zeros((3, n))
        for k in range(i + 1):
            if robot.joints[k].is_prismatic:
                A[:, k] = z[k]
            else:
                A[:, k] = np.cross(z[k], c[i] - o[k])
                B[:, k] = z[k]
        Jv.append(A)
        Jw.append(B)
    return Jv, Jw


def mass_matrix_jacobian(robot: Robot, q) -> np.ndarray:
    """``H = sum_i m_i Jv_i^T Jv_i + Jw_i^T I_i Jw_i`` (kinetic energy), no Newton-Euler."""
    _, _, _, _, _, Ic = _geometry(robot, q)
    Jv, Jw = com_jacobians(robot, q)
    H = np.zeros((robot.n, robot.n))
    for lk, A, B, I in zip(robot.links, Jv, Jw, Ic, strict=True):
        H += lk.mass * A.T @ A + B.T @ I @ B
    return H


def static_bias_jacobian(robot: Robot, q, f_ext=None, f_ext_point=None) -> np.ndarray:
    """The bias at zero velocity, ``g(q) + J^T f_ext``, from Jacobians (virtual work)."""
    n = robot.n
    T_link, _, z, o, _, _ = _geometry(robot, q)
    Jv, _ = com_jacobians(robot, q)
    g = np.asarray(robot.gravity, dtype=float)
    u = -sum(lk.mass * A.T @ g for lk, A in zip(robot.links, Jv, strict=True))
    fe = np.zeros(6) if f_ext is None else np.asarray(f_ext, dtype=float)
    pe = np.zeros(3) if f_ext_point is None else np.asarray(f_ext_point, dtype=float)
    p = T_link[-1][:3, :3] @ pe + T_link[-1][:3, 3]
    J = np.zeros((6, n))  # velocity of the point p (rows 0-2) and angular velocity (rows 3-5)
    for k in range(n):
        if robot.joints[k].is_prismatic:
            J[:3, k] = z[k]
        else:
            J[:3, k] = np.cross(z[k], p - o[k])
            J[3:, k] = z[k]
    return u + J.T @ fe


def forward_dynamics(robot: Robot, q, qd, tau, f_ext=None, f_ext_point=None) -> np.ndarray:
    """``qdd`` of ``H qdd = tau - u'`` (Eq. 2): H from the Jacobians, u' by the spatial
    Newton-Euler recursion, solved by ``np.linalg.solve`` (LU, not a Cholesky factorisation)."""
    u = bias(robot, q, qd, f_ext, f_ext_point)
    return np.linalg.solve(mass_matrix_jacobian(robot, q), np.asarray(tau, dtype=float) - u)
