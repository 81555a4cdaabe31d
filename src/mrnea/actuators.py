"""The actuator model: gear, rotor inertia, friction and effort limits (paper Eqs. 42-43).

Per joint, joint side unless said otherwise (the fields:
:data:`mrnea.actuator_fields.ACTUATOR_FIELDS`): gear ratio G (motor turns per joint turn), rotor
inertia J_m [kg m^2, motor side], viscous friction F_v, Coulomb friction F+ and F- (the magnitudes
opposing positive and negative motion; one value for both, or two), effort limit (constant, or a
torque-speed curve: see :class:`mrnea.model.Joint`), velocity and position limits. The convention
for a joint that moves on with its velocity qd, exactly::

    tau = ID_rigid(q, qd, qdd, f_ext) + G^2 J_m qdd + F_v qd + phi(qd) = H_a qdd + u'_a
    phi(qd) = F+ (qd > 0), -F- (qd < 0), 0 (qd = 0)

``tau`` is the joint-side effort; the motor torque is ``tau / G`` with an ideal gear, and with
the gear's efficiency eta (``efficiency``: driving, back-driven) ``tau / (G eta_d)`` while the
drive delivers power, ``tau eta_b / G`` while it is driven back (:func:`motor_torque`); the
effort limits become eta_d times the limit driving, 1 / eta_b times it back-driven. At rest
Coulomb friction is set-valued (anything in [-F-, F+] while the joint is stuck): a cycle
resolves it with the drives' limits (:mod:`mrnea.kernels.drive_solve`, docs/achievable.md). The
law itself, in compiled code: :mod:`mrnea.kernels.drive`; the functions here are its Python side.
:mod:`mrnea.dynamics` is the rigid-body model alone.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.errors import StateError
from mrnea.kernels.drive import (
    actuator_terms,
    actuator_terms_batch,
    effort_limits,
    limit_tangents,
    motor_torques,
)
from mrnea.kernels.engines import ENGINE_MRNEA
from mrnea.kernels.layout import ACHIEVABLE, batch_scratch, entry_scratch
from mrnea.kernels.simulate import program_requirement as requirement_kernel
from mrnea.kernels.status import OK
from mrnea.model import Robot

# True within one_state_at_a_time (the CLI): one single-state kernel call a state
_ONE_AT_A_TIME: ContextVar[bool] = ContextVar("mrnea_one_state_at_a_time", default=False)


@contextmanager
def one_state_at_a_time() -> Iterator[None]:
    """Within the block (this thread or task), :func:`actuator_mass_matrix_and_bias` (and so
    :func:`actuator_efforts`, and the retiming's and the excitation's efforts, which call it)
    evaluates its states one at a time on the single-state kernel a simulation compiles,
    instead of the parallel batch kernel: what a one-shot process, the CLI, wants.

    Each state is one call, from Python, of ``kernels.drive.actuator_terms`` with exactly the
    argument types :func:`mrnea.simulate`'s start check gives it (C-contiguous writable rows,
    ``ENGINE_MRNEA``, an ``entry_scratch``), so that a command that also simulates (``retime``,
    ``excite``) compiles the mRNEA's call tree once: the batch kernel cost a fresh ``mrnea
    retime`` 3.5 s of its own compiling, and loading it from the cache starts Numba's threads
    (issue 22, docs/performance.md section 7). The values are the batch's to the bit. The
    trade-off: the loop's dispatch, about 3.4 us a state (the Puma 560), against about 0.9 us in
    the batch: 2 ms more for 400 grid points, nothing against a process's start, but several per
    cent of a warm retiming, which library users (a sweep) repeat."""
    token = _ONE_AT_A_TIME.set(True)
    try:
        yield
    finally:
        _ONE_AT_A_TIME.reset(token)


def actuator_mass_matrix_and_bias(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """H_a = H + diag(G^2 J_m) [kg m^2 | kg] and u'_a = u' + F_v qd + phi(qd) [N m | N]
    (Eqs. 42-43; phi: the module docstring, 0 at rest).

    One state or a batch, as :func:`mrnea.mass_matrix_and_bias`: a parallel batch kernel, or
    within :func:`one_state_at_a_time` one single-state call a state.
    """
    args = {"q": q, "qd": qd}
    batched, (q, qd), fe, pe = validate.inputs(robot, args, f_ext, f_ext_point)
    (m, _, _, act), n = compiled.of(robot), robot.n
    Q, QD = (q, qd) if batched else (q[None], qd[None])
    FE, PE = (fe, pe) if batched else (fe[None], pe[None])
    H = np.empty((Q.shape[0], n, n))
    u = np.empty((Q.shape[0], n))
    status = np.empty(Q.shape[0], dtype=np.int64)
    if _ONE_AT_A_TIME.get():
        Q, QD, FE, PE = (np.require(a, np.float64, "CW") for a in (Q, QD, FE, PE))
        ws = entry_scratch(n)  # its own: the kernel runs without the GIL
        for k in range(Q.shape[0]):
            status[k] = actuator_terms(m, act, Q[k], QD[k], FE[k], PE[k], ENGINE_MRNEA, H[k],
                                       u[k], ws)
        u += coulomb_effort(robot, QD)  # as the batch kernel adds it
    else:
        actuator_terms_batch((m, act), Q, QD, FE, PE, ENGINE_MRNEA, H, u, status,
                             batch_scratch(n))
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


def coulomb_effort(robot: Robot, qd: ArrayLike) -> NDArray[np.float64]:
    """phi(qd) of the module docstring: each joint's Coulomb friction effort [N m | N], joint
    side, at joint velocity qd [rad/s | m/s], (n,) or (B, n): F+ where qd > 0, -F- where
    qd < 0, 0 at rest (where friction is set-valued; a cycle resolves it). The law of
    ``kernels/drive.coulomb``, vectorised for whole paths (:mod:`mrnea.retime`)."""
    _, (qd,), _, _ = validate.inputs(robot, {"qd": qd}, None, None)
    F = robot.coulomb_friction  # (n, 2): [F+, F-]
    return np.where(qd > 0.0, F[:, 0], np.where(qd < 0.0, -F[:, 1], 0.0))


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


def program_requirement(
    robot: Robot,
    q_cmd: ArrayLike,
    dt: float,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    friction: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A program's own requirement, as :func:`mrnea.simulate` computes it
    (``SimulationResult.program_effort`` and ``program_limit``; kernels/simulate.py): the
    effort (K, n) [N m | N], joint side, each cycle k needs at the program's state q_cmd[k],
    qd_cmd[k] (backward differences at dt [s], starting from rest) to make the program's next
    velocity (0 after the last row), with the full actuator model; and each joint's effort
    limit at the program's speed (K, n). f_ext (6,) or (K, 6), f_ext_point (3,) or (K, 3), or
    both by link name, as :func:`mrnea.simulate`. ``friction=False`` leaves Coulomb friction
    out (its share at rest is set-valued: the drive and static friction share the holding
    effort)."""
    validate.require_robot(robot)
    dt = validate.time_step(dt)
    friction = validate.flag(friction, "friction")
    Q = validate.array(q_cmd, "q_cmd", robot.n)
    if Q.ndim != 2 or Q.shape[0] < 2:
        raise StateError(f"q_cmd: expected (K, {robot.n}) with K >= 2 cycles, got {Q.shape}")
    Q = np.ascontiguousarray(Q)
    K = Q.shape[0]
    V = np.zeros_like(Q)
    V[1:] = np.diff(Q, axis=0) / dt
    program = (Q, V, *validate.wrench_per_cycle(robot, f_ext, f_ext_point, K))
    m, _, _, act = compiled.of(robot)
    req, limit, status = np.empty_like(Q), np.empty_like(Q), np.empty(K, dtype=np.int64)
    requirement_kernel((m, act), program, dt, friction, 0, K, (req, limit), status,
                       entry_scratch(robot.n, ACHIEVABLE))
    for k in np.flatnonzero(status != OK):
        validate.check_cycle(robot, int(k), int(status[k]), Q[k], V[k], dt)
    return req, limit


def motor_torque(robot: Robot, tau: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
    """Motor-side torque [N m] of joint-side efforts tau [N m | N] at joint speeds qd
    [rad/s | m/s], (n,) or (B, n) each: ``tau / (G eta_d)`` where the drive delivers power or
    the joint is at rest (tau qd >= 0), ``tau eta_b / G`` where it is driven back (the gear's
    efficiency, kernels/drive.py ``motor_side``; ``tau / G`` for an ideal gear)."""
    _, (tau, qd), _, _ = validate.inputs(robot, {"tau": tau, "qd": qd}, None, None)
    TAU = np.ascontiguousarray(np.atleast_2d(tau))
    QD = np.ascontiguousarray(np.broadcast_to(np.atleast_2d(qd), TAU.shape))
    out = np.empty_like(TAU)
    motor_torques(compiled.of(robot)[3], QD, TAU, out)
    return out.reshape(np.shape(tau))
