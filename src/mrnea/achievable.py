"""Achievable joint accelerations (paper Secs. II and V, Eqs. 42-44).

Each interpolation cycle the path planner commands the next positions and velocities; the
actuators may not be able to follow. :func:`achievable_accelerations` answers, for desired
accelerations, which ones the actuators can really achieve and with which efforts;
:func:`achievable_step` is the whole cycle of Sec. II (clamp the command to the joint limits,
desired acceleration, achievable acceleration, next state).

Modes (docs/achievable.md explains when each models a real drive):

* ``"paper"`` -- Eq. 44 literally: every required effort is clamped to +-limit and the
  accelerations solve ``H_a qdd = tau - u'_a - phi`` for all joints at once.
* ``"hybrid"`` (default) -- Sec. II's speed-controlled drives, their velocity loops infinitely
  stiff and their efforts limited: each joint either keeps its desired acceleration with an
  effort within its limit, or its drive gives +-limit and the joint falls short of (or
  overshoots) the desired acceleration on the side that effort pushes it to.

Coulomb friction phi is set-valued: +F+ or -F- while a joint moves, anything in [-F-, F+] while
it is stuck. Each mode's law with it is solved exactly, all joints together
(:mod:`mrnea.kernels.drive_solve`; docs/achievable.md). The actuator convention:
:mod:`mrnea.kernels.drive` and :mod:`mrnea.actuators`. Efforts are joint side [N m | N];
``tau_motor = tau / G``.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.actuators import motor_torque
from mrnea.errors import SingularMassMatrixError
from mrnea.kernels.achievable import (
    CLAMP_POSITION,
    CLAMP_VELOCITY,
    HYBRID,
    PAPER,
    achievable_batch,
    achievable_ws,
    step,
)
from mrnea.kernels.drive import actuator_terms
from mrnea.kernels.drive_ways import solve_mode
from mrnea.kernels.engines import ENGINE_MRNEA
from mrnea.kernels.layout import ACHIEVABLE, batch_scratch, entry_scratch
from mrnea.kernels.solve import cholesky_solve
from mrnea.kernels.status import OK
from mrnea.model import Robot

Mode = Literal["hybrid", "paper"]
MODES = {"hybrid": HYBRID, "paper": PAPER}
_SCRATCH = threading.local()  # per Python thread, per n: the ACHIEVABLE scratch of one state


def _scratch(n: int) -> tuple[np.ndarray, ...]:
    """This thread's ``ACHIEVABLE`` scratch for n joints, made on its first use: the per-state
    kernels release the GIL, so threads must not share one; made once, not per call (about
    5 us: measured with benchmarks/library_calls.py's achievable call, about 100 us)."""
    kept = _SCRATCH.__dict__
    return kept.get(n) or kept.setdefault(n, entry_scratch(n, ACHIEVABLE))


@dataclass(frozen=True)
class AchievableResult:
    """What the actuators can do at one state (arrays (n,), or (B, n) for a batch).

    Attributes
    ----------
    qdd : achievable joint accelerations [rad/s^2 | m/s^2].
    tau : joint-side efforts the drives apply [N m | N]: ``tau = H_a qdd + u' + F_v qd +
        coulomb`` (rigid body with rotor inertia, viscous and Coulomb friction).
    tau_motor : motor torques, ``tau / G`` [N m].
    tau_required : efforts the desired accelerations would need.
    saturated : True where the joint's drive is at its limit and misses the desired
        acceleration (``"paper"``: where the required effort exceeded the limit).
    margin : ``limit - |tau|``, >= 0 up to rounding.
    limit : effort limit at the current speed.
    coulomb : the Coulomb friction effort phi [N m | N], joint side: ``F+`` for a joint moving
        up, ``-F-`` moving down, and for a joint at rest the part of the effort static friction
        takes (within ``[-F-, F+]``).
    stuck : True where a joint at rest stays at rest (``qdd = 0``), held by static friction
        (:func:`achievable_step`: where the new velocity is exactly 0).
    """

    qdd: NDArray[np.float64]
    tau: NDArray[np.float64]
    tau_motor: NDArray[np.float64]
    tau_required: NDArray[np.float64]
    saturated: NDArray[np.bool_]
    margin: NDArray[np.float64]
    limit: NDArray[np.float64]
    coulomb: NDArray[np.float64]
    stuck: NDArray[np.bool_]

    @property
    def achievable(self) -> bool:
        """True when no joint saturated (the desired accelerations are achievable)."""
        return not bool(np.any(self.saturated))


@dataclass(frozen=True)
class StepResult(AchievableResult):
    """One interpolation cycle (:func:`achievable_step`); adds to :class:`AchievableResult`:

    Attributes
    ----------
    q_next, qd_next : the state after dt: the velocity the drives hold over the cycle, and the
        position it leads to (a stuck joint stays exactly where it is).
    qdd_des : the desired accelerations, ``(qd_next_cmd_clamped - qd) / dt``.
    q_cmd, qd_cmd : the command after clamping to the joint limits.
    position_clamped : True where the commanded position was outside [lower, upper].
    velocity_clamped : True where the commanded velocity exceeded the velocity limit.
    """

    q_next: NDArray[np.float64] = None  # type: ignore[assignment]
    qd_next: NDArray[np.float64] = None  # type: ignore[assignment]
    qdd_des: NDArray[np.float64] = None  # type: ignore[assignment]
    q_cmd: NDArray[np.float64] = None  # type: ignore[assignment]
    qd_cmd: NDArray[np.float64] = None  # type: ignore[assignment]
    position_clamped: NDArray[np.bool_] = None  # type: ignore[assignment]
    velocity_clamped: NDArray[np.bool_] = None  # type: ignore[assignment]


def achievable_accelerations(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    qdd_des: ArrayLike,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    mode: Mode = "hybrid",
) -> AchievableResult:
    """The accelerations the actuators can achieve when qdd_des is asked for (Eqs. 42-44).

    q, qd, qdd_des: (n,) or (B, n). f_ext, f_ext_point as in :mod:`mrnea.dynamics` (the wrench
    the last link exerts on its environment). Effort limits are taken at the current speed qd.
    The limit of the cycle solve for dt -> 0: a moving joint meets its sliding friction, a
    joint at rest static friction (it stays at rest where that can hold it).
    """
    code = validate.choice("mode", mode, MODES)
    args = {"q": q, "qd": qd, "qdd_des": qdd_des}
    batched, (q, qd, qdd_des), fe, pe = validate.inputs(robot, args, f_ext, f_ext_point)
    m, _, _, act = compiled.of(robot)
    how = solve_mode(code, robot.n, parents=robot.parents)  # a compile-time choice
    out = (*(np.empty_like(q) for _ in range(5)),
           np.empty(q.shape, dtype=np.bool_), np.empty(q.shape, dtype=np.bool_))
    # qdd, tau, phi, tau_req, limit, sat, stuck
    if batched:
        status = np.empty(q.shape[0], dtype=np.int64)
        achievable_batch((m, act), q, qd, qdd_des, fe, pe, how, ENGINE_MRNEA, out, status,
                         batch_scratch(robot.n, ACHIEVABLE))
    else:  # the per-state kernel itself, as achievable_step calls step: no entry of its own
        status = achievable_ws(m, act, q, qd, qdd_des, fe, pe, how, ENGINE_MRNEA, *out,
                               _scratch(robot.n))
    validate.check_status(robot, status, {**args, "f_ext": f_ext, "f_ext_point": f_ext_point})
    qdd, tau, phi, tau_req, limit, sat, stuck = out
    return AchievableResult(qdd=qdd, tau=tau, tau_motor=motor_torque(robot, tau, qd),
                            tau_required=tau_req, saturated=sat,
                            margin=limit - np.abs(tau), limit=limit, coulomb=phi, stuck=stuck)


def achievable_step(
    robot: Robot,
    q: ArrayLike,
    qd: ArrayLike,
    q_next_cmd: ArrayLike,
    qd_next_cmd: ArrayLike,
    dt: float,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    mode: Mode = "hybrid",
) -> StepResult:
    """One interpolation cycle of Sec. II for one state (n,).

    Clamps the commanded velocity to +-velocity limit and, where the commanded next position is
    outside [lower, upper], lowers the velocity so the joint stops at the limit; forms the desired
    acceleration ``(qd_next_cmd - qd) / dt``, solves the cycle exactly (the velocity the drives
    hold over dt, with their limits and Coulomb friction) and advances the state as the paper's
    speed-controlled drives do: ``qd_next`` = that velocity, ``qdd = (qd_next - qd) / dt`` and
    ``q_next = q + qd_next dt``. dt [s] > 0.
    """
    code = validate.choice("mode", mode, MODES)
    validate.require_robot(robot)
    dt = validate.time_step(dt)
    states = {"q": q, "qd": qd, "q_next_cmd": q_next_cmd, "qd_next_cmd": qd_next_cmd}
    arrays, fe, pe = validate.one_state(robot, states, f_ext, f_ext_point, "achievable_step")
    (m, _, _, act), n = compiled.of(robot), robot.n
    qdd, tau, phi, tau_req, limit, qdd_des, q_next, qd_next = (np.empty(n) for _ in range(8))
    sat, stuck = np.empty(n, dtype=np.bool_), np.empty(n, dtype=np.bool_)
    clamp = np.empty(n, dtype=np.int64)
    status = step(m, act, arrays["q"], arrays["qd"], arrays["q_next_cmd"], arrays["qd_next_cmd"],
                  dt, fe, pe, solve_mode(code, n, parents=robot.parents), ENGINE_MRNEA, qdd_des,
                  qdd, tau, phi, tau_req, limit, sat, stuck, q_next, qd_next, clamp,
                  _scratch(n))
    validate.check_status(robot, status, {**states, "f_ext": f_ext, "f_ext_point": f_ext_point})
    return StepResult(
        qdd=qdd, tau=tau, tau_motor=motor_torque(robot, tau, arrays["qd"]), tau_required=tau_req,
        saturated=sat, margin=limit - np.abs(tau), limit=limit, coulomb=phi, stuck=stuck,
        q_next=q_next, qd_next=qd_next,
        qdd_des=qdd_des, q_cmd=np.clip(arrays["q_next_cmd"], robot.lower, robot.upper),
        qd_cmd=arrays["qd"] + qdd_des * dt,
        position_clamped=(clamp & CLAMP_POSITION) != 0,
        velocity_clamped=(clamp & CLAMP_VELOCITY) != 0,
    )


def check_moves(robot: Robot, q0: NDArray) -> None:
    """Refuse, before the run, a robot whose actuated mass matrix H_a is singular at the start
    (a joint that moves no mass and no rotor inertia: the cycle's accelerations are undefined,
    and no verdict can be given): SingularMassMatrixError naming the joint and the links."""
    n = robot.n
    m, _, _, act = compiled.of(robot)
    Ha, ua, zero = np.empty((n, n)), np.empty(n), np.zeros(n)
    # q0 as a writable C row, the type the loop's step passes: a program's rows are read-only
    # (io.program), which compiled the mRNEA's call tree a second time (issue 22)
    actuator_terms(m, act, np.array(q0, dtype=np.float64), zero, np.zeros(6), np.zeros(3),
                   ENGINE_MRNEA, Ha, ua,
                   entry_scratch(n))  # SOLVE's rows: a tree's mRNEA stashes columns in S[n:2n]
    # H_a and L as (n, n) views of wider buffers, typed layout A as the drive solve's blocks
    # are (kernels/drive_solve.py): one compiled cholesky_solve serves both (issue 22)
    H, L = np.empty((n, n + 1))[:, :n], np.empty((n, n + 1))[:, :n]
    H[...] = Ha
    j = cholesky_solve(H, zero, L, np.empty(n))
    if j == OK:
        return
    joint = robot.joints[j]
    moved = robot.links[j:]
    bare = [lk.name for lk in moved if lk.mass == 0.0 and not np.any(lk.inertia)]
    d = np.diag(Ha)
    k = int(np.argmax(d))
    if d[j] > 0.0 and d[k] > 1e12 * d[j]:  # the pivot failed against another joint's inertia
        big = robot.joints[k]
        rotor = big.gear_ratio ** 2 * big.rotor_inertia
        unit = "kg" if big.is_prismatic else "kg m^2"  # H_a's diagonal entry's unit
        cause = (f"its rotor inertia through its gear, G^2 J_m = {big.gear_ratio:.3g}^2 x "
                 f"{big.rotor_inertia:.3g} kg m^2; check its rotor_inertia and gear_ratio"
                 if rotor > 0.5 * d[k] else "the links it moves; check their masses, inertias "
                 "and lengths")
        raise SingularMassMatrixError(
            f"robot '{robot.name}': the actuated mass matrix H_a is too ill-conditioned to "
            f"solve: joint '{big.name}' has {d[k]:.3g} {unit} about its axis against {d[j]:.3g} at "
            f"joint '{joint.name}' ({d[k] / d[j]:.2g} times, beyond double precision), from "
            f"{cause}")
    if len(bare) == len(moved) and joint.rotor_inertia == 0.0:
        why = (f"joint '{joint.name}' moves no mass and no rotor inertia (link"
               f"{'s' if len(bare) > 1 else ''} {', '.join(repr(b) for b in bare)} without "
               "inertials)")
    else:
        why = (f"joint '{joint.name}' moves no inertia about its axis at the start state (links "
               f"{', '.join(repr(lk.name) for lk in moved)})")
    raise SingularMassMatrixError(
        f"robot '{robot.name}': the actuated mass matrix H_a is singular: {why}; give the links "
        "their masses and inertias (or the joint a rotor inertia): no verdict without them")
