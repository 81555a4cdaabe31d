"""The drive: what an actuator adds to the rigid body, and what it can give (paper Eqs. 42-43).

Usage: ``status = actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws)`` fills H_a
(n, n) and u'_a (n,) (``actuator_terms_batch(compiled, ...)``, ``compiled = (model, act)``, over
a batch); ``effort_limit(act, i, qd_i)`` (``effort_limits`` over a batch, ``limit_tangents``
the curve's branches and slopes for a linearisation); the friction law at rest,
``static_friction``, ``slips``, ``sliding_friction``. The actuator array ``act`` (n, NACT) as
kernels/layout.py describes it: per joint, joint side, gear ratio G (motor turns per joint
turn), rotor inertia J_m (motor side), viscous friction F_v, Coulomb friction F_s, the
torque-speed curve and the joint limits.

Actuator equation (Eqs. 42-43), joint side, on the rigid-body H and u' of one engine
(kernels/engines.py)::

    tau = H_a qdd + u'_a,   H_a = H + diag(G^2 J_m),   u'_a = u' + F_v qd + F_s sign(qd)

G^2 J_m is the rotor's inertia reflected through the gear; sign(0) = 0. The motor torque is
tau / G (mrnea.actuators.motor_torque).

Effort limit at speed |qd|: ``peak`` up to the corner speed, then the smaller of constant power
``peak * corner / |qd|`` and the straight line from ``(corner, peak)`` down to zero at the no-load
speed; zero beyond it. A constant limit has corner = no-load = inf.

Coulomb friction at rest (qd_i = 0, F_s > 0):

* a joint whose acceleration is prescribed and non-zero breaks away: friction F_s sign(qdd_i);
* a joint prescribed to stay at rest gets up to F_s of its holding effort from static friction,
  the actuator supplies the rest (``static_friction``);
* a joint whose effort is prescribed and that starts moving one way (direction s = +-1) meets the
  friction F_s s (``sliding_friction``); held at rest, it slips when the effort static friction
  would have to absorb exceeds F_s (``slips``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.common import chunk, n_chunks
from mrnea.kernels.engines import mass_matrix_bias
from mrnea.kernels.layout import (
    ALLOC,
    CORNER,
    FS,
    FV,
    GEAR,
    INLINE,
    JIT,
    JM,
    NOLOAD,
    PEAK,
    POSE,
    scratch,
)
from mrnea.kernels.status import OK


@nb.njit(**INLINE)
def curve_branches(act, i, w):
    """The falling branches of joint i's torque-speed curve at speed w > 0, and their slopes:
    ``(P / w, -P / w^2, gamma (no_load - w), -gamma)``, ``P = peak corner``,
    ``gamma = peak / (no_load - corner)``. Only for a finite corner below the no-load speed."""
    peak, corner, no_load = act[i, PEAK], act[i, CORNER], act[i, NOLOAD]
    power = peak * corner / w
    return power, -power / w, peak * (no_load - w) / (no_load - corner), -peak / (no_load - corner)


@nb.njit(**JIT)
def effort_limit(act, i, qd_i):
    """Effort limit of joint i at speed qd_i: torque-speed curve or constant (module docstring)."""
    peak, corner, no_load = act[i, PEAK], act[i, CORNER], act[i, NOLOAD]
    w = abs(qd_i)
    if w <= corner:
        return peak
    if w >= no_load:
        return 0.0
    power, _, line, _ = curve_branches(act, i, w)
    return min(power, line)


@nb.njit(**JIT)
def effort_limits(act, QD, out):
    """``effort_limit`` of every joint over a batch of speeds: out (B, n) from QD (B, n)."""
    for b in range(QD.shape[0]):
        for i in range(QD.shape[1]):
            out[b, i] = effort_limit(act, i, QD[b, i])


@nb.njit(**JIT)
def limit_tangents(act, W, out):
    """Each falling branch of the torque-speed curve at speeds W (B, n) >= 0, for a tangent:
    out (B, n, 4) = ``curve_branches`` (values and slopes d/dw). A joint without a falling
    branch (a constant limit, or corner = no-load speed: a step to zero, i.e. a speed limit)
    gets (inf, 0, inf, 0). The limit is ``max(0, min(peak, P / w, line))``: each branch bounds
    it from above wherever it is >= 0."""
    for b in range(W.shape[0]):
        for i in range(W.shape[1]):
            if act[i, CORNER] < act[i, NOLOAD] and W[b, i] > 0.0:
                out[b, i, 0], out[b, i, 1], out[b, i, 2], out[b, i, 3] = curve_branches(
                    act, i, W[b, i])
            else:
                out[b, i, 0], out[b, i, 1], out[b, i, 2], out[b, i, 3] = np.inf, 0.0, np.inf, 0.0


@nb.njit(**INLINE)
def add_drive(act, qd, Ha, ua):
    """H += diag(G^2 J_m) and u' += F_v qd + F_s sign(qd), in place: H_a and u'_a (Eqs. 42-43)."""
    for i in range(qd.shape[0]):
        Ha[i, i] += act[i, GEAR] ** 2 * act[i, JM]
        ua[i] += act[i, FV] * qd[i] + act[i, FS] * np.sign(qd[i])


@nb.njit(**JIT)
def actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws):
    """H_a (n, n) and u'_a (n,) of Eqs. 42-43, the rigid-body part by ``engine``
    (kernels/engines.py); ``ws``: scratch (kernels/layout.py). Returns a status."""
    status = mass_matrix_bias(model, q, qd, fext, pe, engine, Ha, ua, ws)
    if status != OK:
        return status
    add_drive(act, qd, Ha, ua)
    return OK


@nb.njit(**{**ALLOC, "parallel": True})
def actuator_terms_batch(compiled, Q, QD, FEXT, PE, engine, HA, UA, STATUS):
    """``actuator_terms`` over a batch: HA (B, n, n), UA (B, n), STATUS (B,)."""
    B, n = Q.shape
    model, act = compiled
    nc = n_chunks(B)
    for ch in nb.prange(nc):
        ws = scratch(n, POSE)
        lo, hi = chunk(ch, nc, B)
        for b in range(lo, hi):
            STATUS[b] = actuator_terms(model, act, Q[b], QD[b], FEXT[b], PE[b], engine, HA[b],
                                       UA[b], ws)


@nb.njit(**JIT)
def static_friction(need, act, i, moving, qdd_i):
    """Effort of joint i, its acceleration qdd_i prescribed, when the rigid body and the drive's
    other terms need ``need``: Coulomb friction at rest added (module docstring)."""
    fs = act[i, FS]
    if moving or fs == 0.0:
        return need
    if qdd_i != 0.0:
        return need + fs * np.sign(qdd_i)  # breakaway
    return need - min(max(need, -fs), fs)  # static friction holds up to F_s


@nb.njit(**INLINE)
def sliding_friction(act, i, direction):
    """Coulomb friction of joint i starting from rest in ``direction`` (+-1; 0: none)."""
    return act[i, FS] * direction


@nb.njit(**INLINE)
def slips(act, i, d):
    """True when static friction cannot absorb the effort d of joint i held at rest."""
    return abs(d) > act[i, FS]
