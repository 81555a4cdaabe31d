"""Achievable accelerations: what the actuators can really do this cycle (paper Secs. II, V).

Usage: ``status = achievable(compiled, q, qd, qdd_des, fext, pe, mode, engine, out)`` with
``compiled = (model, act)`` and ``out = (qdd, tau, tau_req, limit, sat)``; ``status =
step(model, act, q, qd, q_cmd, qd_cmd, dt, fext, pe, mode, engine, qdd_des, qdd, tau, tau_req,
limit, sat, q_next, qd_next, clamp, ws)`` with ``ws`` an ``ACHIEVABLE`` scratch
(kernels/layout.py). The kernels Python calls take tuples; the per-state kernels inside the
batch and simulation loops (``achievable_ws``, ``step``) take their arrays one by one, which
measured 3-6 % faster in the simulation loop (docs/design.md).

The drive's law (kernels/drive.py): tau = H_a qdd + u'_a (Eqs. 42-43), the effort limit at speed
and Coulomb friction at rest.

Modes:

* PAPER (Eq. 44): clamp every required effort to +-limit and solve H_a qdd = tau - u'_a.
* HYBRID (Sec. II: "other joint accelerations keep their values obtained from the path
  interpolator"): joints whose required effort exceeds the limit deliver the limit; every other
  joint keeps qdd_des and takes the effort that needs. The saturated set is found one joint at a
  time: the joint furthest over its limit (|tau| / limit) saturates, the rest are solved again,
  and so on (an active set that only grows: at most n rounds). One at a time, because another
  joint's excess may come only from its coupling to the first one's unachievable acceleration.

Both are one mixed linear system: per joint either the acceleration or the effort is known.

Coulomb friction at rest (kernels/drive.py) makes the mixed system a small complementarity
problem: a joint whose effort is prescribed (saturated, or any joint in PAPER mode) is first taken
to move the way the program wants (friction against that direction), or to stay at rest if the
program wants it to. The guess is then checked and revised until consistent: a joint held at
rest whose holding friction would exceed F_s starts moving the way the net effort pushes; a
moving joint that would accelerate against its own friction stays at rest instead. The revision
stops after 4n + 2 rounds, which has sufficed in every case tested.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import chunk, finite, n_chunks
from mrnea.kernels.drive import (
    actuator_terms,
    effort_limit,
    sliding_friction,
    slips,
    static_friction,
)
from mrnea.kernels.layout import (
    ACHIEVABLE,
    ALLOC,
    FS,
    JIT,
    LOWER,
    UPPER,
    VLIM,
    achievable_buffers,
    scratch,
)
from mrnea.kernels.solve import cholesky_solve
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW

PAPER, HYBRID = 0, 1
# clamp flags of ``step``, per joint
CLAMP_POSITION, CLAMP_VELOCITY = 1, 2


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
def achievable(compiled, q, qd, qdd_des, fext, pe, mode, engine, out):
    """``achievable_ws`` with its own scratch; ``compiled = (model, act)``, ``out = (qdd, tau,
    tau_req, limit, sat)``."""
    model, act = compiled
    qdd, tau, tau_req, limit, sat = out
    return achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, tau_req,
                         limit, sat, scratch(q.shape[0], ACHIEVABLE))


@nb.njit(**JIT)
def achievable_ws(model, act, q, qd, qdd_des, fext, pe, mode, engine, qdd, tau, tau_req, limit,
                  sat, ws):
    """Achievable accelerations of one state (module docstring). Returns a status.

    Fills qdd (achievable), tau (effort applied, joint side), tau_req (effort qdd_des needs),
    limit (effort limit at the current speed) and sat (True where the joint is saturated).
    ``ws``: an ``ACHIEVABLE`` scratch (its ``achievable_buffers``).
    """
    n = q.shape[0]
    if not finite(qdd_des):
        return NONFINITE
    Ha, Hs, L, ua, slip, tau_cmd, fric, rhs, x, known, held, fixed, idx = achievable_buffers(ws, n)
    # slip: direction (+-1) of a joint starting from rest, its effort prescribed; tau_cmd: the
    # prescribed efforts; fric: Coulomb friction of joints starting from rest; known: 0/1,
    # acceleration prescribed (HYBRID, unsaturated); held: 0/1, effort prescribed, kept at rest
    # by static friction; fixed: 0/1, acceleration known this round (known or held); idx: the
    # unknowns' joint indices (_mixed_solve)
    status = actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws)
    if status != OK:
        return status

    # Eq. 42 with qdd_des: the efforts the programmed motion needs, and the limits at this speed
    for i in range(n):
        need = ua[i]
        for j in range(n):
            need += Ha[i, j] * qdd_des[j]
        tau_req[i] = static_friction(need, act, i, qd[i] != 0.0, qdd_des[i])
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
            fric[i] = sliding_friction(act, i, slip[i])
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
                if slips(act, i, d):  # it cannot: the joint starts moving that way
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
                tau[i] = static_friction(tau[i], act, i, qd[i] != 0.0, qdd[i])
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
def achievable_batch(compiled, Q, QD, QDD_DES, FEXT, PE, mode, engine, OUT, STATUS):
    """``achievable`` over a batch (B, n): OUT = (QDD, TAU, TAU_REQ, LIMIT, SAT), each (B, n);
    FEXT (B, 6), PE (B, 3), STATUS (B,)."""
    B, n = Q.shape
    model, act = compiled
    QDD, TAU, TAU_REQ, LIMIT, SAT = OUT
    nc = n_chunks(B)
    for ch in nb.prange(nc):
        ws = scratch(n, ACHIEVABLE)
        lo, hi = chunk(ch, nc, B)
        for b in range(lo, hi):
            STATUS[b] = achievable_ws(model, act, Q[b], QD[b], QDD_DES[b], FEXT[b], PE[b], mode,
                                      engine, QDD[b], TAU[b], TAU_REQ[b], LIMIT[b], SAT[b], ws)
