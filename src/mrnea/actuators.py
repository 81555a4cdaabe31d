"""The actuator model: gear, rotor inertia, friction and effort limits (paper Eqs. 42-43).

Per joint, joint side unless said otherwise (the fields: :data:`mrnea.model.ACTUATOR_FIELDS`):
gear ratio G (motor turns per joint turn), rotor inertia J_m [kg m^2, motor side], viscous
friction F_v, Coulomb friction F+ and F- (the magnitudes opposing positive and negative
motion; one value for both, or two), effort limit (constant, or a torque-speed curve: see
:class:`mrnea.model.Joint`), velocity and position limits. The convention for a joint that moves
on with its velocity qd, exactly::

    tau = ID_rigid(q, qd, qdd, f_ext) + G^2 J_m qdd + F_v qd + phi(qd) = H_a qdd + u'_a
    phi(qd) = F+ (qd > 0), -F- (qd < 0), 0 (qd = 0)

``tau`` is the joint-side effort; the motor torque is ``tau / G`` (:func:`motor_torque`). At rest
Coulomb friction is set-valued (anything in [-F-, F+] while the joint is stuck): a cycle
resolves it with the drives' limits (:mod:`mrnea.kernels.drive_solve`, docs/achievable.md). The
law itself, in compiled code: :mod:`mrnea.kernels.drive`; the functions here are its Python side.
:mod:`mrnea.dynamics` is the rigid-body model alone.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.kernels.drive import actuator_terms_batch, effort_limit
from mrnea.kernels.engines import ENGINE_MRNEA
from mrnea.model import Robot


def actuator_mass_matrix_and_bias(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """H_a = H + diag(G^2 J_m) and u'_a = u' + F_v qd + phi(qd) (Eqs. 42-43; phi: the module
    docstring, 0 at rest).

    One state or a batch, as :func:`mrnea.mass_matrix_and_bias`.
    """
    args = {"q": q, "qd": qd}
    batched, (q, qd), fe, pe = validate.inputs(robot, args, f_ext, f_ext_point)
    (m, _, _, act), n = compiled.of(robot), robot.n
    Q, QD = (q, qd) if batched else (q[None], qd[None])
    FE, PE = (fe, pe) if batched else (fe[None], pe[None])
    H = np.empty((Q.shape[0], n, n))
    u = np.empty((Q.shape[0], n))
    status = np.empty(Q.shape[0], dtype=np.int64)
    actuator_terms_batch((m, act), Q, QD, FE, PE, ENGINE_MRNEA, H, u, status)
    validate.check_status(robot, status if batched else int(status[0]),
                          {**args, "f_ext": f_ext, "f_ext_point": f_ext_point})
    return (H, u) if batched else (H[0], u[0])


def actuator_efforts(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Joint-side efforts ``tau = H_a qdd + u'_a`` the actuators must give for this motion."""
    H, u = actuator_mass_matrix_and_bias(robot, q, qd, f_ext, f_ext_point)
    qdd = np.asarray(qdd, dtype=float)
    return np.einsum("...ij,...j->...i", H, qdd) + u


def effort_limits_at(robot: Robot, qd: ArrayLike) -> NDArray[np.float64]:
    """Each joint's effort limit [N m | N] at joint speed qd, (n,) or (B, n)."""
    _, (qd,), _, _ = validate.inputs(robot, {"qd": qd}, None, None)
    act = compiled.of(robot)[3]
    flat = np.atleast_2d(qd)
    out = np.array([[effort_limit(act, i, row[i]) for i in range(robot.n)] for row in flat])
    return out.reshape(np.shape(qd))


def motor_torque(robot: Robot, tau: ArrayLike) -> NDArray[np.float64]:
    """Motor-side torque ``tau / G`` of joint-side efforts tau, (n,) or (B, n) [N m]."""
    return np.asarray(tau, dtype=float) / robot.gear_ratio
