"""The drive: what an actuator adds to the rigid body, and what it can give (paper Eqs. 42-43).

Usage: ``status = actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws)`` fills H_a
(n, n) and u'_a (n,) without the Coulomb term (``actuator_terms_batch(compiled, ...)``,
``compiled = (model, act)``, over a batch, with it); ``drive_effort(act, i, qd_i, qdd_i)``, the
same terms of one joint; ``effort_limit(act, i, qd_i)`` (``effort_limits`` over a batch,
``limit_tangents`` the curve's branches and slopes for a linearisation); the gear's efficiency,
``effort_box(act, i, qd_i)`` (the lower and upper effort limits of a cycle), ``side_limit`` (the
one an effort meets) and ``motor_side`` (``motor_torques`` over a batch); the Coulomb friction
law, ``coulomb`` (a moving joint), ``holding_friction`` (a joint held at rest) and
``wanted_friction`` (a wanted motion); a cycle's cost of each joint's velocity, piecewise linear
(``joint_pieces``, ``start_piece``: the drive solve's, kernels/drive_solve.py). The actuator
array ``act`` (n, NACT) as kernels/layout.py describes it: per joint, joint side, gear ratio G
(motor turns per joint turn), rotor inertia J_m (motor side), viscous friction F_v, Coulomb
friction F+ and F- (the magnitudes opposing positive and negative motion), the torque-speed
curve, the joint limits and the gear efficiency eta (driving, back-driven).

Actuator equation (Eqs. 42-43), joint side, on the rigid-body H and u' of one engine
(kernels/engines.py)::

    tau = H_a qdd + u'_a + phi,   H_a = H + diag(G^2 J_m),   u'_a = u' + F_v qd

G^2 J_m is the rotor's inertia reflected through the gear. phi is the Coulomb friction the
drive must overcome, Eq. 43's F_s sign(qd) made set-valued (the velocity v the joint moves
with):

    phi_i = F+_i  (v_i > 0),   -F-_i  (v_i < 0),   any value in [-F-_i, F+_i]  (v_i = 0: stuck)

A cycle resolves phi together with the drives' efforts (kernels/drive_solve.py); where the
velocity is known and not zero, phi = ``coulomb(v, F+, F-)``. A joint held at rest whose drive
and friction share a holding effort h (only their difference is fixed): friction takes up to its
capacity first, the drive the rest, phi = ``holding_friction(h, F+, F-)`` = clip(-h, -F-, F+).
The public u'_a (``actuator_terms_batch``, :mod:`mrnea.actuators`) adds ``coulomb(qd)``, the
friction of a joint that moves on (0 at rest). The motor torque is tau / G
(mrnea.actuators.motor_torque) with an ideal gear; with efficiency, below.

Effort limit at speed |qd|: ``peak`` up to the corner speed, then the smaller of constant power
``peak * corner / |qd|`` and the straight line from ``(corner, peak)`` down to zero at the no-load
speed; zero beyond it. A constant limit has corner = no-load = inf.

Gear efficiency. The effort limit L above (``effort_limit``) is the ideal gear's, G times the
motor's peak torque T_pk. A gear of efficiency eta loses power in the direction it flows: while
the drive delivers power (effort and speed of the same sign) the joint gets eta_d G T_pk; while
the load drives it back (braking: effort against the speed) the motor holds G T_pk / eta_b at
the joint. A cycle knows its speed qd at its start, so its effort box is (``effort_box``)::

    qd > 0:  -L / eta_b <= tau <= eta_d L      qd < 0:  -eta_d L <= tau <= L / eta_b
    qd = 0:  -eta_d L <= tau <= eta_d L        (at rest the drive must deliver power)

and the motor torque of a joint-side effort tau is (``motor_side``)::

    tau / (G eta_d)   driving (tau qd >= 0: at rest, or effort and speed of the same sign)
    tau eta_b / G     back-driven (tau qd < 0)

eta = 1 (the default) gives the ideal gear's numbers bit for bit (x 1.0 and / 1.0 are exact).

Limits and rounding: a value is over a limit (effort, velocity, position) only when it exceeds
it by more than rounding, ``beyond(x, limit, scale)``: x > limit + LIMIT_RTOL * scale, with
LIMIT_RTOL = 8 ulps of 1 (8 eps, 1.8e-15) and ``scale`` the magnitude of the quantities x is
computed from (velocity: the limit and |q| / dt of the positions it is the difference of;
position: the limit and |q|; effort: the limit and |tau_req|). A program planned exactly to a
limit (a commanded speed of 2.0000000000000004 against 2.0) is within it; one over it by a real
amount (1e-12 relative and more) is not.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from mrnea.kernels.engines import mass_matrix_bias
from mrnea.kernels.layout import (
    CORNER,
    ETAB,
    ETAD,
    FNEG,
    FPOS,
    FV,
    GEAR,
    INLINE,
    JIT,
    JM,
    NOLOAD,
    PARALLEL,
    PEAK,
    own_scratch,
)
from mrnea.kernels.status import OK

LIMIT_RTOL = 8.0 * float(np.finfo(np.float64).eps)
"""Relative tolerance of a limit comparison (module docstring, 'Limits and rounding')."""


@nb.njit(**INLINE)
def beyond(x, limit, scale):
    """True if x exceeds limit by more than rounding: x > limit + LIMIT_RTOL * scale, ``scale``
    >= 0 the magnitude of the quantities x and limit are computed from (inf: never beyond)."""
    return x > limit + LIMIT_RTOL * scale


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


@nb.njit(**INLINE)
def effort_box(act, i, qd_i):
    """Joint i's effort box at speed qd_i, with the gear's efficiency (module docstring): the
    magnitudes ``(lower, upper)`` of the limits on a negative and on a positive effort,
    ``-lower <= tau <= upper``."""
    L = effort_limit(act, i, qd_i)
    drive, back = act[i, ETAD] * L, L / act[i, ETAB]
    if qd_i > 0.0:
        return back, drive
    if qd_i < 0.0:
        return drive, back
    return drive, drive


@nb.njit(**INLINE)
def side_limit(act, i, qd_i, tau_i):
    """The limit of joint i's effort box at speed qd_i on the side of the effort tau_i (the upper
    one for tau_i >= 0): what tau_i is measured against."""
    lower, upper = effort_box(act, i, qd_i)
    return upper if tau_i >= 0.0 else lower


@nb.njit(**INLINE)
def motor_side(act, i, qd_i, tau_i):
    """The motor torque of joint i's joint-side effort tau_i at speed qd_i (module docstring):
    tau / (G eta_d) driving or at rest, tau eta_b / G back-driven."""
    if tau_i * qd_i < 0.0:
        return tau_i * act[i, ETAB] / act[i, GEAR]
    return tau_i / (act[i, GEAR] * act[i, ETAD])


@nb.njit(**JIT)
def motor_torques(act, QD, TAU, out):
    """``motor_side`` of every joint over a batch: out (B, n) from speeds QD and efforts TAU."""
    for b in range(QD.shape[0]):
        for i in range(QD.shape[1]):
            out[b, i] = motor_side(act, i, QD[b, i], TAU[b, i])


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
def coulomb(v, Fp, Fn):
    """Coulomb friction of a joint moving with velocity v: F+ (v > 0), -F- (v < 0), 0 (v = 0)."""
    if v > 0.0:
        return Fp
    if v < 0.0:
        return 0.0 - Fn  # (0.0 - 0.0 is +0.0; -0.0 would print as "-0")
    return 0.0


@nb.njit(**INLINE)
def holding_friction(h, Fp, Fn):
    """Friction's share of the effort h that holds a joint at rest: up to its capacity first,
    clip(-h, -F-, F+) (h = tau - phi: the drive gives h + phi)."""
    return min(max(-h, -Fn), Fp)


@nb.njit(**INLINE)
def wanted_friction(h, v_des, Fp, Fn):
    """The Coulomb friction of a joint that makes the wanted velocity v_des, its drive and
    friction sharing the effort h = (H_a qdd_des + u'_a)_i: coulomb(v_des), or, held at rest
    (v_des = 0), holding_friction(h)."""
    return coulomb(v_des, Fp, Fn) if v_des != 0.0 else holding_friction(h, Fp, Fn)


@nb.njit(**INLINE)
def joint_pieces(i, hybrid, v_des_i, Llo_i, Lhi_i, Fp, Fn, tauc_i, bp, sl):
    """Breakpoints (sorted) into ``bp[:, i]`` and piece slopes into ``sl[:, i]`` of joint i's
    convex piecewise-linear cost g_i in its velocity v (the drive's effort against its limits,
    or -tau v, plus the Coulomb friction's; kernels/drive_solve.py, module docstring); returns
    the number of breakpoints."""
    if hybrid and Lhi_i == math.inf:  # fixed to the program: held at v_des forever
        bp[0, i] = v_des_i
        sl[0, i], sl[1, i] = -math.inf, math.inf
        return 1
    has_zero = Fp + Fn > 0.0
    has_vdes = hybrid and Llo_i + Lhi_i > 0.0
    nb_, iz, iv = 0, 2, 2  # number of breakpoints; index of the breakpoint 0, of v_des (2: none)
    if has_zero and has_vdes and v_des_i == 0.0:  # merged
        bp[0, i] = 0.0
        nb_, iz, iv = 1, 0, 0
    elif has_zero and has_vdes:
        bp[0, i], bp[1, i] = min(0.0, v_des_i), max(0.0, v_des_i)
        nb_ = 2
        iz, iv = (0, 1) if v_des_i > 0.0 else (1, 0)
    elif has_zero:
        bp[0, i] = 0.0
        nb_, iz = 1, 0
    elif has_vdes:
        bp[0, i] = v_des_i
        nb_, iv = 1, 0
    for k in range(nb_ + 1):  # piece k lies above breakpoints 0..k-1
        fric = Fp if iz < k else -Fn  # slope of F+ max(v, 0) + F- max(-v, 0)
        # of U max(v_des - v, 0) + D max(v - v_des, 0), or -tau v
        drive = (Llo_i if iv < k else -Lhi_i) if hybrid else -tauc_i
        sl[k, i] = drive + fric
    return nb_


@nb.njit(**INLINE)
def start_piece(v0, nb_, i, bp):
    """Pattern of a joint at v0: held (2k + 1) on breakpoint k, else free (2k) on piece k."""
    k = 0
    for j in range(nb_):
        if v0 == bp[j, i]:
            return 2 * j + 1
        if v0 > bp[j, i]:
            k = j + 1
    return 2 * k


@nb.njit(**INLINE)
def drive_effort(act, i, qd_i, qdd_i):
    """What the drive adds to joint i's rigid-body effort, Coulomb friction aside (Eqs. 42-43):
    G^2 J_m qdd + F_v qd."""
    return act[i, GEAR] ** 2 * act[i, JM] * qdd_i + act[i, FV] * qd_i


@nb.njit(**INLINE)
def add_drive(act, qd, Ha, ua):
    """H += diag(G^2 J_m) and u' += F_v qd, in place: H_a and u'_a (Eqs. 42-43)."""
    for i in range(qd.shape[0]):
        Ha[i, i] += act[i, GEAR] ** 2 * act[i, JM]
        ua[i] += act[i, FV] * qd[i]


@nb.njit(**JIT)
def actuator_terms(model, act, q, qd, fext, pe, engine, Ha, ua, ws):
    """H_a (n, n) and u'_a (n,) of Eqs. 42-43 without the Coulomb term, the rigid-body part by
    ``engine`` (kernels/engines.py); ``ws``: scratch (kernels/layout.py). Returns a status."""
    status = mass_matrix_bias(model, q, qd, fext, pe, engine, Ha, ua, ws)
    if status != OK:
        return status
    add_drive(act, qd, Ha, ua)
    return OK


@nb.njit(**PARALLEL)
def actuator_terms_batch(compiled, Q, QD, FEXT, PE, engine, HA, UA, STATUS, ws):
    """H_a and u'_a with the Coulomb friction of the joints' motion, ``coulomb(qd)``, over a
    batch: HA (B, n, n), UA (B, n), STATUS (B,); ws: a ``batch_scratch``."""
    model, act = compiled
    for b in nb.prange(Q.shape[0]):
        STATUS[b] = actuator_terms(model, act, Q[b], QD[b], FEXT[b], PE[b], engine, HA[b],
                                   UA[b], own_scratch(ws))
        for i in range(Q.shape[1]):
            UA[b, i] += coulomb(QD[b, i], act[i, FPOS], act[i, FNEG])
