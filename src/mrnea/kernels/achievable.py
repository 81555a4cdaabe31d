"""Achievable accelerations: what the actuators can really do this cycle (paper Secs. II, V).

Usage: ``status = achievable(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau,
tau_req, limit, sat)``; ``status = step(model, act, q, qd, q_cmd, qd_cmd, dt, fext, pe, mode,
engine, qdd_des, qdd, tau, tau_req, limit, sat, q_next, qd_next, clamp, ws)`` (``ws``: a
scratch, kernels/common.py).

Actuator equation (Eqs. 42-43), joint side, with the rigid-body mass matrix and bias of one
mRNEA pass::

    tau = H_a qdd + u'_a,   H_a = H + diag(G^2 J_m),   u'_a = u' + F_v qd + F_s sign(qd)

Modes:

* PAPER (Eq. 44): clamp every required effort to +-limit and solve H_a qdd = tau - u'_a.
* HYBRID (Sec. II: "other joint accelerations keep their values obtained from the path
  interpolator"): joints whose required effort exceeds the limit deliver the limit; every other
  joint keeps qdd_des and takes the effort that needs. The saturated set is found one joint at a
  time: the joint furthest over its limit (|tau| / limit) saturates, the rest are solved again,
  and so on (an active set that only grows: at most n rounds). One at a time, because another
  joint's excess may come only from its coupling to the first one's unachievable acceleration.

Both are one mixed linear system: per joint either the acceleration or the effort is known.

Coulomb friction at rest (qd_i = 0, F_s > 0), the model mrnea uses:

* a joint whose acceleration is prescribed and non-zero breaks away: friction F_s sign(qdd_i);
* a joint prescribed to stay at rest (qdd_i = 0) gets up to F_s of its holding effort from
  static friction, the actuator supplies the rest;
* a joint whose effort is prescribed (saturated, or any joint in PAPER mode) is first taken to
  move the way the program wants (friction F_s against that direction), or to stay at rest if
  the program wants it to. The guess is then checked and revised until consistent: a joint held
  at rest whose holding friction would exceed F_s starts moving the way the net effort pushes;
  a moving joint that would accelerate against its own friction stays at rest instead. With
  several coupled joints at rest this is a small complementarity problem; the revision stops
  after 4n + 2 rounds, which has sufficed in every case tested.

Actuator array ``act`` (n, NACT), joint side: G, J_m, F_v, F_s, peak effort, corner speed,
no-load speed, lower, upper, velocity limit. A constant limit has corner = no-load = inf.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from mrnea.kernels.common import (
    ALLOC,
    JIT,
    NONFINITE,
    OK,
    OVERFLOW,
    chunk,
    finite,
    n_chunks,
    scratch,
)
from mrnea.kernels.crba import crba_bias
from mrnea.kernels.mrnea import mrnea_ws
from mrnea.kernels.solve import cholesky_solve
from mrnea.kernels.walker_orin import walker_orin

if TYPE_CHECKING:
    from mrnea.model import Robot

GEAR, JM, FV, FS, PEAK, CORNER, NOLOAD, LOWER, UPPER, VLIM = range(10)
NACT = 10
PAPER, HYBRID = 0, 1
# how H and u' are formed: the paper's mRNEA, Walker-Orin method 1, or CRBA + RNEA
ENGINE_MRNEA, ENGINE_WALKER_ORIN, ENGINE_CRBA = 0, 1, 2
# clamp flags of ``step``, per joint
CLAMP_POSITION, CLAMP_VELOCITY = 1, 2


def compile_actuators(robot: Robot) -> np.ndarray:
    """The ``(n, NACT)`` actuator array of a validated Robot."""
    a = np.empty((robot.n, NACT))
    for i, j in enumerate(robot.joints):
        curve = j.torque_speed or (j.effort_limit, math.inf, math.inf)
        a[i] = (j.gear_ratio, j.rotor_inertia, j.viscous_friction, j.coulomb_friction,
                *curve, j.lower, j.upper, j.velocity_limit)
    a.setflags(write=False)
    return a


@nb.njit(**JIT)
def effort_limit(act, i, qd_i):
    """Effort limit of joint i at speed qd_i: torque-speed curve or constant (module docstring)."""
    peak, corner, no_load = act[i, PEAK], act[i, CORNER], act[i, NOLOAD]
    w = abs(qd_i)
    if w <= corner:
        return peak
    if w >= no_load:
        return 0.0
    return min(peak * corner / w, peak * (no_load - w) / (no_load - corner))


@nb.njit(**JIT)
def actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws):
    """H_a (n, n) and u'_a (n,) of Eqs. 42-43 (Coulomb term F_s sign(qd), sign(0) = 0);
    ``ws``: scratch (kernels/common.py)."""
    if engine == ENGINE_WALKER_ORIN:
        status = walker_orin(model, q, qd, fext, pe, Ha, ua, ws)
    elif engine == ENGINE_CRBA:
        status = crba_bias(model, q, qd, fext, pe, Ha, ua, ws)
    else:
        status = mrnea_ws(model, q, qd, fext, pe, Ha, ua, False, ws)
    if status != OK:
        return status
    for i in range(q.shape[0]):
        Ha[i, i] += act[i, GEAR] ** 2 * act[i, JM]
        ua[i] += act[i, FV] * qd[i] + act[i, FS] * np.sign(qd[i])
    return OK


@nb.njit(**{**ALLOC, "parallel": True})
def actuator_terms_batch(model, act, Q, QD, FEXT, PE, engine, HA, UA, STATUS):
    """``actuator_terms`` over a batch: HA (B, n, n), UA (B, n), STATUS (B,)."""
    B, n = Q.shape
    nc = n_chunks(B)
    for ch in nb.prange(nc):
        ws = scratch(n, 0, 0)
        lo, hi = chunk(ch, nc, B)
        for b in range(lo, hi):
            STATUS[b] = actuator_terms(model, act, Q[b], QD[b], FEXT[b], PE[b], engine, HA[b],
                                       UA[b], ws)


@nb.njit(**JIT)
def _mixed_solve(Ha, ua, fric, known, qdd, tau, Hs, rhs, L, x, idx):
    """Solve ``H_a qdd + u'_a + fric = tau`` where qdd[i] is given if known[i], else tau[i].

    Fills the unknown entries: qdd where not known; tau = H_a qdd + u'_a (friction excluded)
    where known. Returns OK or the joint index of a failed pivot.
    """
    n = Ha.shape[0]
    m = 0
    for i in range(n):
        if not known[i]:
            idx[m] = i
            m += 1
    for a in range(m):
        i = idx[a]
        s = tau[i] - ua[i] - fric[i]
        for j in range(n):
            if known[j]:
                s -= Ha[i, j] * qdd[j]
        rhs[a] = s
        for b in range(m):
            Hs[a, b] = Ha[i, idx[b]]
    if m > 0:
        status = cholesky_solve(Hs[:m, :m], rhs[:m], L[:m, :m], x[:m])
        if status != OK:
            return idx[status]
        for a in range(m):
            qdd[idx[a]] = x[a]
    for i in range(n):
        if known[i]:
            s = ua[i]
            for j in range(n):
                s += Ha[i, j] * qdd[j]
            tau[i] = s
    return OK


@nb.njit(**JIT)
def _with_static_friction(need, fs, moving, qdd_i):
    """Effort of a joint with prescribed acceleration, adding Coulomb friction at rest."""
    if moving or fs == 0.0:
        return need
    if qdd_i != 0.0:
        return need + fs * np.sign(qdd_i)  # breakaway
    return need - min(max(need, -fs), fs)  # static friction holds up to F_s


@nb.njit(**JIT)
def _start_from_rest(act, qd, qdd_des, i, held, slip):
    """First guess for a joint at rest whose effort is prescribed: it moves the way the program
    wants (friction F_s opposing that), or, asked to stay, static friction holds it."""
    if qd[i] != 0.0 or act[i, FS] == 0.0:
        return
    if qdd_des[i] != 0.0:
        slip[i] = np.sign(qdd_des[i])
    else:
        held[i] = True


@nb.njit(**ALLOC)
def achievable(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, tau_req, limit,
               sat):
    """``achievable_ws`` with its own scratch."""
    return achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, tau_req,
                         limit, sat, scratch(q.shape[0], 3 * q.shape[0] + 6, 4))


@nb.njit(**JIT)
def achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, tau_req, limit,
                  sat, ws):
    """Achievable accelerations of one state (module docstring). Returns a status.

    Fills qdd (achievable), tau (effort applied, joint side), tau_req (effort qdd_des needs),
    limit (effort limit at the current speed) and sat (True where the joint is saturated).
    Scratch (kernels/common.py) rows: S[:n] H_a, S[n:3n] the system of the unknown
    accelerations and its Cholesky factor, S[3n:3n + 6] vectors, I[:4] flags and indices.
    """
    n = q.shape[0]
    if not finite(qdd_des):
        return NONFINITE
    S, ints = ws[2], ws[3]
    Ha, Hs, L = S[:n], S[n:2 * n], S[2 * n:3 * n]
    ua = S[3 * n]
    slip = S[3 * n + 1]  # direction (+-1) of a joint starting from rest, its effort prescribed
    tau_cmd = S[3 * n + 2]  # the prescribed efforts
    fric = S[3 * n + 3]  # Coulomb friction of joints starting from rest
    rhs, x = S[3 * n + 4], S[3 * n + 5]
    known = ints[0]  # 0/1: acceleration prescribed (HYBRID, unsaturated)
    held = ints[1]  # 0/1: effort prescribed, kept at rest by static friction
    fixed = ints[2]  # 0/1: acceleration known this round (known or held)
    idx = ints[3]  # the unknowns' joint indices (_mixed_solve)
    status = actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws)
    if status != OK:
        return status

    # Eq. 42 with qdd_des: the efforts the programmed motion needs, and the limits at this speed
    for i in range(n):
        need = ua[i]
        for j in range(n):
            need += Ha[i, j] * qdd_des[j]
        tau_req[i] = _with_static_friction(need, act[i, FS], qd[i] != 0.0, qdd_des[i])
        limit[i] = effort_limit(act, i, qd[i])

    for i in range(n):
        known[i] = mode == HYBRID
        held[i] = False
        slip[i] = 0.0
        fric[i] = 0.0
        tau_cmd[i] = min(max(tau_req[i], -limit[i]), limit[i])  # Eq. 44's clamp
        if not known[i]:
            _start_from_rest(act, qd, qdd_des, i, held, slip)
    for _ in range(4 * n + 2):
        for i in range(n):
            fixed[i] = known[i] or held[i]
            fric[i] = act[i, FS] * slip[i]
            if known[i]:
                qdd[i] = qdd_des[i]
            elif held[i]:
                qdd[i] = 0.0
            else:
                tau[i] = tau_cmd[i]
        status = _mixed_solve(Ha, ua, fric, fixed, qdd, tau, Hs, rhs, L, x, idx)
        if status != OK:
            return status
        changed = False
        worst, worst_ratio = -1, 1.0  # HYBRID: the joint furthest over its limit
        for i in range(n):
            if held[i]:
                d = tau_cmd[i] - tau[i]  # what static friction must absorb to hold the joint
                if abs(d) > act[i, FS]:  # it cannot: the joint starts moving that way
                    held[i] = False
                    slip[i] = np.sign(d)
                    changed = True
                tau[i] = tau_cmd[i]
            elif slip[i] != 0.0 and qdd[i] * slip[i] < 0.0:
                # friction cannot drive a joint backwards: it stays at rest instead
                held[i] = True
                slip[i] = 0.0
                changed = True
            elif known[i]:
                tau[i] = _with_static_friction(tau[i], act[i, FS], qd[i] != 0.0, qdd[i])
                ratio = abs(tau[i]) / limit[i] if limit[i] > 0.0 else np.inf
                if abs(tau[i]) > limit[i] and ratio > worst_ratio:
                    worst, worst_ratio = i, ratio
        if worst >= 0 and not changed:
            # saturate one joint per round: another joint's excess may only come from its
            # coupling to this one's unachievable acceleration
            known[worst] = False
            tau_cmd[worst] = limit[worst] * np.sign(tau[worst])
            _start_from_rest(act, qd, qdd_des, worst, held, slip)
            changed = True
        if not changed:
            break
    for i in range(n):
        sat[i] = abs(tau_req[i]) > limit[i] if mode == PAPER else not known[i]
    return OK if finite(qdd) and finite(tau) and finite(tau_req) else OVERFLOW


@nb.njit(**JIT)
def step(model, act, q, qd, q_cmd, qd_cmd, dt, fext, pe, mode, engine,
         qdd_des, qdd, tau, tau_req, limit, sat, q_next, qd_next, clamp, ws):
    """One interpolation cycle of Sec. II. Returns a status.

    Clamps the commanded velocity qd_cmd to +-velocity limit and, where the commanded next
    position q_cmd lies outside [lower, upper], lowers the velocity so that the joint reaches the
    limit at the end of the cycle and goes no further. Forms qdd_des = (qd_cmd - qd) / dt,
    computes the achievable accelerations and advances the state the way Sec. II describes the
    drives: the velocity changes to qd_next = qd + qdd dt and the speed controller holds it for
    dt, so q_next = q + qd_next dt. A feasible command is reproduced exactly (q_next = q_cmd when
    qd_cmd = (q_cmd - q) / dt). ``clamp`` gets CLAMP_POSITION | CLAMP_VELOCITY flags per joint;
    the caller's q_cmd and qd_cmd are not modified.
    """
    n = q.shape[0]
    if not (finite(q_cmd) and finite(qd_cmd) and np.isfinite(dt)):
        return NONFINITE
    for i in range(n):
        flags = 0
        qc = q_cmd[i]  # read only: the caller's command is never modified
        vc = qd_cmd[i]
        if vc > act[i, VLIM] or vc < -act[i, VLIM]:
            vc = min(max(vc, -act[i, VLIM]), act[i, VLIM])
            flags |= CLAMP_VELOCITY
        if qc > act[i, UPPER]:  # approach the limit, do not pass it
            vc = min(vc, (act[i, UPPER] - q[i]) / dt)
            flags |= CLAMP_POSITION
        elif qc < act[i, LOWER]:
            vc = max(vc, (act[i, LOWER] - q[i]) / dt)
            flags |= CLAMP_POSITION
        if vc > act[i, VLIM] or vc < -act[i, VLIM]:  # coming back from past a limit
            vc = min(max(vc, -act[i, VLIM]), act[i, VLIM])
            flags |= CLAMP_VELOCITY
        clamp[i] = flags
        qdd_des[i] = (vc - qd[i]) / dt
    status = achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, tau_req,
                           limit, sat, ws)
    if status != OK:
        return status
    for i in range(n):
        qd_next[i] = qd[i] + qdd[i] * dt
        q_next[i] = q[i] + qd_next[i] * dt
    return OK


@nb.njit(**{**ALLOC, "parallel": True})
def achievable_batch(model, act, Q, QD, QDD_DES, FEXT, PE, mode, engine, QDD, TAU, TAU_REQ,
                     LIMIT, SAT, STATUS):
    """``achievable`` over a batch (B, n) (FEXT (B, 6), PE (B, 3), STATUS (B,))."""
    B, n = Q.shape
    nc = n_chunks(B)
    for ch in nb.prange(nc):
        ws = scratch(n, 3 * n + 6, 4)
        lo, hi = chunk(ch, nc, B)
        for b in range(lo, hi):
            STATUS[b] = achievable_ws(model, act, Q[b], QD[b], QDD_DES[b], FEXT[b], PE[b], mode,
                                      engine, QDD[b], TAU[b], TAU_REQ[b], LIMIT[b], SAT[b], ws)
