"""The regressor's public side: ``tau = Y(q, qd, qdd) pi`` (:func:`regressor`), the parameter
vector pi of a Robot (:func:`inertial_parameters`) and back (:func:`with_inertial_parameters`), and
the actuator columns of the drive law (:func:`actuator_regressor`).

Parameter order, per link i, link frame, about its origin (Pinocchio's
``Inertia.toDynamicParameters``)::

    pi_i = [m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]       (10 per link)

and per joint j, joint side (the law of :mod:`mrnea.actuators`, plus an effort offset)::

    a_j = [G^2 J_m, F_v, F+, F-, offset]                                        (5 per joint)
    tau_j += G^2 J_m qdd_j + F_v qd_j + F+ [qd_j > 0] - F- [qd_j < 0] + offset
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.errors import ModelError, StateError
from mrnea.kernels.layout import batch_scratch
from mrnea.kernels.regressor import regressor_batch
from mrnea.model import Link, Robot

#: names of the 10 inertial parameters of a link, in the order of the module docstring
INERTIAL_NAMES = ("m", "mcx", "mcy", "mcz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")
#: names of the 5 actuator parameters of a joint (the module docstring)
ACTUATOR_NAMES = ("rotor", "viscous", "coulomb_pos", "coulomb_neg", "offset")
_SYM = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))  # I_xx, I_xy, I_yy, I_xz, I_yz, I_zz


def require_serial(robot: Robot, who: str) -> None:
    """A ModelError unless joint i's parent is link i - 1 for every i (the regressor and the
    identification assume a serial chain)."""
    validate.require_robot(robot)
    parents = [robot.base, *robot.link_names[:-1]]
    for j, p in zip(robot.joints, parents, strict=True):
        if j.parent != p:
            raise ModelError(f"{who}: robot '{robot.name}' is not a serial chain (joint "
                             f"'{j.name}' hangs from '{j.parent}', not '{p}'); {who} supports "
                             f"serial chains only")


def regressor(robot: Robot, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
    """The joint torque regressor Y, (n, 10 n) or (B, n, 10 n): rigid-body efforts
    ``tau = Y @ inertial_parameters(robot)`` [N m | N], exactly :func:`mrnea.inverse_dynamics`
    without an external wrench.

    q [rad | m], qd [rad/s | m/s], qdd [rad/s^2 | m/s^2], (n,) or (B, n) each (broadcast as
    :func:`mrnea.inverse_dynamics`). Columns ``10 i : 10 i + 10`` belong to link i, in the order
    and frame of the module docstring (Pinocchio's ``computeJointTorqueRegressor``). A compiled,
    parallel loop over the batch (:mod:`mrnea.kernels.regressor`). Serial chains only.
    """
    require_serial(robot, "regressor")
    args = {"q": q, "qd": qd, "qdd": qdd}
    batched, (Q, QD, QDD), _, _ = validate.inputs(robot, args, None, None)
    if not batched:
        Q, QD, QDD = Q[None], QD[None], QDD[None]
    n = robot.n
    Y = np.empty((Q.shape[0], n, 10 * n))
    status = np.empty(Q.shape[0], dtype=np.int64)
    regressor_batch(compiled.of(robot)[0], Q, QD, QDD, Y, status, batch_scratch(n))
    validate.check_status(robot, status if batched else int(status[0]), args)
    return Y if batched else Y[0]


def actuator_regressor(robot: Robot, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
    """The actuator columns, (n, 5 n) or (B, n, 5 n): joint j's efforts are linear in
    ``a_j = [G^2 J_m, F_v, F+, F-, offset]`` (module docstring) with the row
    ``[qdd_j, qd_j, [qd_j > 0], -[qd_j < 0], 1]`` in columns ``5 j : 5 j + 5``."""
    validate.require_robot(robot)
    _, (QD, QDD), _, _ = validate.inputs(robot, {"qd": qd, "qdd": qdd}, None, None)
    n = robot.n
    A = np.zeros((*QD.shape[:-1], n, 5 * n))
    j = np.arange(n)
    A[..., j, 5 * j] = QDD
    A[..., j, 5 * j + 1] = QD
    A[..., j, 5 * j + 2] = QD > 0
    A[..., j, 5 * j + 3] = -(QD < 0).astype(float)
    A[..., j, 5 * j + 4] = 1.0
    return A


def link_parameters(link: Link) -> NDArray[np.float64]:
    """The 10 parameters of one link (module docstring): inertia moved from the centre of mass
    to the link origin."""
    m, c = link.mass, np.asarray(link.com)
    inertia_o = np.asarray(link.inertia) + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([m, *(m * c), *(inertia_o[a, b] for a, b in _SYM)])


def inertial_parameters(robot: Robot) -> NDArray[np.float64]:
    """pi (10 n,): every link's 10 parameters, root to tip (module docstring)."""
    validate.require_robot(robot)
    return np.concatenate([link_parameters(lk) for lk in robot.links])


def actuator_parameters(robot: Robot) -> NDArray[np.float64]:
    """a (5 n,): every joint's ``[G^2 J_m, F_v, F+, F-, offset = 0]``, root to tip."""
    validate.require_robot(robot)
    a = np.zeros((robot.n, 5))
    a[:, 0] = robot.gear_ratio ** 2 * robot.rotor_inertia
    a[:, 1] = robot.viscous_friction
    a[:, 2:4] = robot.coulomb_friction
    return a.ravel()


def split_link_parameters(p: ArrayLike) -> tuple[float, NDArray, NDArray]:
    """(mass [kg], com [m, link frame], inertia about the com [kg m^2]) of 10 parameters;
    the centre of mass of a massless link is its origin."""
    p = np.asarray(p, dtype=float)
    m = float(p[0])
    inertia_o = np.zeros((3, 3))
    for v, (a, b) in zip(p[4:], _SYM, strict=True):
        inertia_o[a, b] = inertia_o[b, a] = v
    c = p[1:4] / m if m > 0 else np.zeros(3)
    return m, c, inertia_o - m * (c @ c * np.eye(3) - np.outer(c, c))


def with_inertial_parameters(robot: Robot, pi: ArrayLike) -> Robot:
    """A copy of ``robot`` whose links have the parameters pi (10 n,); a ModelError names the
    link whose parameters are not a rigid body (negative mass, inertia not valid)."""
    pi = validate.array(pi, "pi", 10 * robot.n)
    if pi.ndim != 1:
        raise StateError(f"pi: expected ({10 * robot.n},), got {pi.shape}")
    links = []
    for i, lk in enumerate(robot.links):
        m, c, inertia = split_link_parameters(pi[10 * i:10 * i + 10])
        links.append(Link(lk.name, m, c, (inertia + inertia.T) / 2, lk.visuals))
    return robot._replace(links=tuple(links))
