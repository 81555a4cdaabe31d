"""Achievable accelerations: what the actuators can really do this cycle (paper Secs. II, V).

Usage: ``status = achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau,
phi, tau_req, limit, sat, stuck, ws)``; ``status = step(model, act, q, qd, q_cmd, qd_cmd, dt,
fext, pe, mode, engine, qdd_des, qdd, tau, phi, tau_req, limit, sat, stuck, q_next, qd_next,
clamp, ws)``; ``ws`` an ``ACHIEVABLE`` scratch (kernels/layout.py; from Python
``entry_scratch(n, ACHIEVABLE)``); ``mode`` is ``solve_mode(PAPER or HYBRID, n)``
(kernels/drive_solve.py: the mode with the drive solve's way for n joints, a compile-time
choice). Python calls these two per-state kernels themselves (mrnea.achievable), with exactly
the argument types the batch and simulation loops give them, so a first run compiles each once
(no entry of its own: docs/performance.md section 7); they take their arrays one by one, which
measured 3-6 % faster in the simulation loop than tuples (docs/design.md).

The drive's law (kernels/drive.py): tau = H_a qdd + u'_a + phi (Eqs. 42-43), the effort limit at
speed and set-valued Coulomb friction phi. One cycle is one exact solve of that law with the
drives' limits (kernels/drive_solve.py). The limits are the effort box at the
state's speed (kernels/drive.py ``effort_box``: the gear's efficiency makes the driving and
back-driven limits differ); ``limit`` reports the one on the side of the effort applied. The
two modes:

* PAPER (Eq. 44): every required effort is clamped to +-limit, and the accelerations follow.
* HYBRID (Sec. II: "other joint accelerations keep their values obtained from the path
  interpolator"): each drive either keeps its joint on the program with an effort within its
  limit, or gives +-limit and misses the program on the side that effort pushes it to.

``step`` is the whole cycle over dt: the velocity the drives hold over the next interval is
solved for directly, so a joint that stops is at rest exactly. ``achievable_ws`` is one state
without a cycle time, the limit dt -> 0 of the same problem: the accelerations solved at the
state (qd := 0, v_des := qdd_des, dt := 1 in the solve), a moving joint meeting its sliding
friction coulomb(qd) (it cannot reach zero in no time) and a joint at rest the set-valued one.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import finite
from mrnea.kernels.drive import actuator_terms, beyond, coulomb, effort_box
from mrnea.kernels.drive_solve import HYBRID, PAPER, solve_cycle
from mrnea.kernels.layout import (
    FNEG,
    FPOS,
    JIT,
    LOWER,
    PARALLEL,
    UPPER,
    VLIM,
    achievable_buffers,
    own_scratch,
)
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW

__all__ = ["CLAMP_POSITION", "CLAMP_VELOCITY", "HYBRID", "PAPER", "achievable_batch",
           "achievable_ws", "step"]

# clamp flags of ``step``, per joint
CLAMP_POSITION, CLAMP_VELOCITY = 1, 2


@nb.njit(**JIT)
def achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, phi, tau_req,
                  limit, sat, stuck, ws):
    """Achievable accelerations of one state (module docstring). Returns a status.

    Fills qdd (achievable), tau (effort applied, joint side), phi (Coulomb friction: the
    sliding friction of a moving joint, the resolved one of a joint at rest), tau_req (effort
    qdd_des needs), limit (the effort limit at the current speed on the side of tau, with the
    gear's efficiency: kernels/drive.py ``effort_box``), sat (True where the joint is
    saturated) and stuck (a joint at rest that static friction keeps there). ``ws``: an
    ``ACHIEVABLE`` scratch.
    """
    n = q.shape[0]
    if not finite(qdd_des):
        return NONFINITE
    Ha, ua, Fp, Fn, _, v, rest, lower = achievable_buffers(ws, n)
    status = actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws)
    if status != OK:
        return status
    for i in range(n):
        lower[i], limit[i] = effort_box(act, i, qd[i])
        rest[i] = 0.0
        if qd[i] == 0.0:  # at rest: set-valued friction
            Fp[i], Fn[i] = act[i, FPOS], act[i, FNEG]
        else:  # moving: sliding friction, Eq. 43's F_s sign(qd)
            Fp[i], Fn[i] = 0.0, 0.0
            ua[i] += coulomb(qd[i], act[i, FPOS], act[i, FNEG])
    status = solve_cycle(Ha, ua, rest, qdd_des, 1.0, lower, limit, Fp, Fn, mode, v, qdd, tau,
                         phi, tau_req, sat, stuck, ws)
    if status != OK:
        return status
    for i in range(n):
        if tau[i] < 0.0:  # the limit the effort meets
            limit[i] = lower[i]
        if qd[i] != 0.0:
            phi[i] = coulomb(qd[i], act[i, FPOS], act[i, FNEG])
            stuck[i] = False
    return OK if finite(qdd) and finite(tau) and finite(tau_req) else OVERFLOW


@nb.njit(**JIT)
def step(model, act, q, qd, q_cmd, qd_cmd, dt, fext, pe, mode, engine, qdd_des, qdd, tau, phi,
         tau_req, limit, sat, stuck, q_next, qd_next, clamp, ws):
    """One interpolation cycle of Sec. II. Returns a status.

    Clamps the commanded velocity qd_cmd to +-velocity limit and, where the commanded next
    position q_cmd lies outside [lower, upper], lowers the velocity so that the joint reaches the
    limit at the end of the cycle and goes no further. That velocity v_des is what the drives
    are asked to hold over the next interval (qdd_des = (v_des - qd) / dt); the exact solve
    (kernels/drive_solve.py) gives the velocity v they do hold, with the limits at the current
    speed and the Coulomb friction resolved, and the state advances the way Sec. II describes
    the drives: qd_next = v, held for dt, so q_next = q + v dt (a stuck joint stays exactly
    where it is). A feasible command is reproduced exactly (q_next = q_cmd when qd_cmd =
    (q_cmd - q) / dt). ``clamp`` gets CLAMP_POSITION | CLAMP_VELOCITY flags per joint; the
    caller's q_cmd and qd_cmd are not modified.
    """
    n = q.shape[0]
    if not (finite(q_cmd) and finite(qd_cmd) and np.isfinite(dt)):
        return NONFINITE
    Ha, ua, Fp, Fn, v_des, _, _, lower = achievable_buffers(ws, n)
    for i in range(n):
        flags = 0
        qc = q_cmd[i]  # read only: the caller's command is never modified
        vc = qd_cmd[i]
        lo, hi, vlim = act[i, LOWER], act[i, UPPER], act[i, VLIM]
        # beyond a limit by more than rounding (kernels/drive.py): the velocity is a difference
        # of positions over dt, so its rounding scales with |q| / dt
        vscale = vlim + (abs(qc) + abs(q[i])) / dt
        if beyond(vc, vlim, vscale) or beyond(-vc, vlim, vscale):
            vc = min(max(vc, -vlim), vlim)
            flags |= CLAMP_VELOCITY
        if beyond(qc, hi, abs(hi) + abs(qc)):  # approach the limit, do not pass it
            vc = min(vc, (hi - q[i]) / dt)
            flags |= CLAMP_POSITION
        elif beyond(-qc, -lo, abs(lo) + abs(qc)):
            vc = max(vc, (lo - q[i]) / dt)
            flags |= CLAMP_POSITION
        if beyond(vc, vlim, vscale) or beyond(-vc, vlim, vscale):  # coming back from past a limit
            vc = min(max(vc, -act[i, VLIM]), act[i, VLIM])
            flags |= CLAMP_VELOCITY
        clamp[i] = flags
        v_des[i] = vc
        qdd_des[i] = (vc - qd[i]) / dt
    status = actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws)
    if status != OK:
        return status
    for i in range(n):
        lower[i], limit[i] = effort_box(act, i, qd[i])
        Fp[i], Fn[i] = act[i, FPOS], act[i, FNEG]
    status = solve_cycle(Ha, ua, qd, v_des, dt, lower, limit, Fp, Fn, mode, qd_next, qdd, tau,
                         phi, tau_req, sat, stuck, ws)
    if status != OK:
        return status
    for i in range(n):
        q_next[i] = q[i] + qd_next[i] * dt
        if tau[i] < 0.0:  # the limit the effort meets
            limit[i] = lower[i]
    return OK if finite(qd_next) and finite(tau) and finite(tau_req) else OVERFLOW


@nb.njit(**PARALLEL)
def achievable_batch(compiled, Q, QD, QDD_DES, FEXT, PE, mode, engine, OUT, STATUS, ws):
    """``achievable`` over a batch (B, n): OUT = (QDD, TAU, PHI, TAU_REQ, LIMIT, SAT, STUCK),
    each (B, n); FEXT (B, 6), PE (B, 3), STATUS (B,); ws: an ``ACHIEVABLE`` ``batch_scratch``."""
    model, act = compiled
    QDD, TAU, PHI, TAU_REQ, LIMIT, SAT, STUCK = OUT
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = achievable_ws(model, act, Q[b], QD[b], QDD_DES[b], FEXT[b], PE[b], mode,
                                  engine, QDD[b], TAU[b], PHI[b], TAU_REQ[b], LIMIT[b], SAT[b],
                                  STUCK[b], own_scratch(ws))
