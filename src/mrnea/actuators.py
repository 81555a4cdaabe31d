"""The actuator model: gear, rotor inertia, friction and effort limits (paper Eqs. 42-43).

Per joint, joint side unless said otherwise (the fields: :data:`mrnea.model.ACTUATOR_FIELDS`):
gear ratio G (motor turns per joint turn), rotor inertia J_m [kg m^2, motor side], viscous
friction F_v, Coulomb friction F_s, effort limit (constant, or a torque-speed curve: see
:class:`mrnea.model.Joint`), velocity and position limits. The convention, exactly::

    tau = ID_rigid(q, qd, qdd, f_ext) + G^2 J_m qdd + F_v qd + F_s sign(qd) = H_a qdd + u'_a

``tau`` is the joint-side effort; the motor torque is ``tau / G`` (:func:`motor_torque`). The
law itself, in compiled code, including Coulomb friction at rest: :mod:`mrnea.kernels.drive`;
the functions here are its Python side. :mod:`mrnea.dynamics` is the rigid-body model alone.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.kernels.drive import actuator_terms_batch, effort_limits, limit_tangents
from mrnea.kernels.engines import ENGINE_MRNEA
from mrnea.model import Robot


def actuator_mass_matrix_and_bias(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """H_a = H + diag(G^2 J_m) and u'_a = u' + F_v qd + F_s sign(qd) (Eqs. 42-43).

    One state or a batch, as :func:`mrnea.mass_matrix_and_bias`; sign(0) = 0.
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
    """Each joint's effort limit [N m | N] at joint speed qd [rad/s | m/s], (n,) or (B, n):
    the torque-speed curve of :mod:`mrnea.kernels.drive`, one compiled loop over the batch."""
    _, (qd,), _, _ = validate.inputs(robot, {"qd": qd}, None, None)
    flat = np.ascontiguousarray(np.atleast_2d(qd))
    out = np.empty_like(flat)
    effort_limits(compiled.of(robot)[3], flat, out)
    return out.reshape(np.shape(qd))


def effort_limit_branches(robot: Robot, speed: ArrayLike) -> NDArray[np.float64]:
    """The falling branches of each joint's torque-speed curve at ``speed`` >= 0 [rad/s | m/s],
    (n,) or (B, n), with their slopes: (..., n, 4) ``[P / w, -P / w^2, line, -gamma]`` (constant
    power ``P = peak corner``; the line ``gamma (no_load - w)`` down to the no-load speed,
    ``gamma = peak / (no_load - corner)``). A joint with a constant limit gets
    ``[inf, 0, inf, 0]``. The limit is ``max(0, min(peak, P / w, line))`` (each branch is convex
    in w: a tangent is a lower bound), for linearising it, as :mod:`mrnea.retime` does."""
    _, (w,), _, _ = validate.inputs(robot, {"speed": speed}, None, None)
    flat = np.ascontiguousarray(np.abs(np.atleast_2d(w)))
    out = np.empty((*flat.shape, 4))
    limit_tangents(compiled.of(robot)[3], flat, out)
    return out.reshape((*np.shape(w), 4))


def motor_torque(robot: Robot, tau: ArrayLike) -> NDArray[np.float64]:
    """Motor-side torque ``tau / G`` of joint-side efforts tau, (n,) or (B, n) [N m]."""
    return np.asarray(tau, dtype=float) / robot.gear_ratio
