"""The simulation system's loop: the Sec. II cycle, k0 <= k < k1, in compiled code; and the
program's own requirement, every cycle at once.

Usage: ``k, status = simulate_cycles(compiled, program, dt, mode, engine, catch_up, reactions,
k0, k1, run, ws)``
with ``compiled = (model, act)``, ``mode = solve_mode(PAPER or HYBRID, n)``
(kernels/drive_solve.py), ``program = (q_cmd, qd_cmd, fext, pe)`` and
``run = (q, qd, qdd_des, qdd, tau, phi, tau_req, limit, sat, stuck, clamp, wrench)``, unpacked
once per call: the per-cycle ``step`` takes its arrays one by one (docs/design.md).
``program_requirement(compiled, program, dt, friction, k0, k1, out, status, ws)`` with
``out = (req, limit)`` fills rows k0 <= k < k1. ``ws``: an ``ACHIEVABLE`` scratch made in
Python (kernels/layout.py ``entry_scratch``), which both may share (each writes a slot before
it reads it); one made here would compile ``layout.scratch`` into a first run (about 0.8 s).

Row k describes instant t_k = k dt: the program q_cmd[k], its velocity over the interval that ends
at t_k, qd_cmd[k] = (q_cmd[k] - q_cmd[k-1]) / dt (the paper's desired velocity), the robot's state
q[k], qd[k] (qd[k] is the velocity the drives held over that interval), and what cycle k does:
qdd_des[k] = (v - qd[k]) / dt with v the velocity wanted over the next interval, the achievable
qdd[k], the drives' efforts tau, the Coulomb friction phi, the requirement tau_req, the limits,
saturation, stuck and clamp flags, and each joint's reaction wrench (kernels/rnea.py
``reactions``) at q[k], qd[k], qdd[k] (only if ``reactions``: a check that needs the verdict
alone skips that pass). Then q[k+1], qd[k+1] follow (kernels/achievable.py ``step``).

v is the program's qd_cmd[k+1] (the paper's behaviour: after a saturation the robot lags its
program and keeps the lag), plus, with a position-loop gain ``catch_up`` > 0 [1/s],
catch_up * (q_cmd[k] - q[k]): the velocity feed-forward and proportional position loop of a
cascaded servo, which closes the lag exponentially (rate catch_up) once the limits allow.
On entry q[k0], qd[k0] hold the state.
Returns (k1, OK), or the cycle and status of a failure.

The program's requirement is the same cycle's requirement at the program's own state, before
any lag: at q_cmd[k], qd_cmd[k], wanting qd_cmd[k+1] (zero after the last cycle), not clamped:
qdd_des = (qd_cmd[k+1] - qd_cmd[k]) / dt, h = ID(q_cmd[k], qd_cmd[k], qdd_des, f_ext) + G^2 J_m
qdd_des + F_v qd_cmd[k] (the RNEA pass, Eq. 42's H_a qdd_des + u'_a without forming H_a), and
the requirement h + phi_des with the friction of that motion (kernels/drive.py
``wanted_friction``), as the cycle's exact solve forms it; the effort limit at the program's
speed on the side of that requirement (kernels/drive.py ``side_limit``: with the gear's
efficiency, the driving or the back-driven limit).
"""

from __future__ import annotations

import numba as nb

from mrnea.kernels.achievable import step
from mrnea.kernels.drive import drive_effort, side_limit, wanted_friction
from mrnea.kernels.engines import ENGINE_MRNEA
from mrnea.kernels.layout import FNEG, FPOS, JIT, loop_buffers
from mrnea.kernels.rnea import reactions_ws, rnea_ws
from mrnea.kernels.status import OK


@nb.njit(**JIT)
def simulate_cycles(compiled, program, dt, mode, engine, catch_up, reactions, k0, k1, run, ws):
    """Run cycles k0 <= k < k1 (module docstring); arrays are (K, n), wrench (K, n, 6).
    Allocates nothing (no Numba runtime: no reference counts on the cycle's views)."""
    model, act = compiled
    q_cmd, qd_cmd, fext, pe = program
    q, qd, qdd_des, qdd, tau, phi, tau_req, limit, sat, stuck, clamp, wrench = run
    K, n = q_cmd.shape  # ws: step's, then the reactions'; and the loop's own rows:
    q_next, qd_next, v = loop_buffers(ws, n)  # the next state, the velocity wanted next
    for k in range(k0, k1):
        last = k + 1 >= K
        for i in range(n):
            v[i] = 0.0 if last else qd_cmd[k + 1, i]  # the program ends at rest
            v[i] += catch_up * (q_cmd[k, i] - q[k, i])
        status = step(model, act, q[k], qd[k], q_cmd[k] if last else q_cmd[k + 1], v, dt,
                      fext[k], pe[k], mode, engine, qdd_des[k], qdd[k], tau[k], phi[k],
                      tau_req[k], limit[k], sat[k], stuck[k], q_next, qd_next, clamp[k], ws)
        if status != OK:
            return k, status
        if reactions:
            # step's mRNEA pass (ENGINE_MRNEA) left the kinematics of q[k] in the scratch
            status = reactions_ws(model, q[k], qd[k], qdd[k], fext[k], pe[k], wrench[k], ws,
                                  engine == ENGINE_MRNEA)
            if status != OK:
                return k, status
        if not last:  # entry by entry: a slice assignment compiles Numba's shape-mismatch
            for i in range(n):  # message (string formatting), seconds of a first run
                q[k + 1, i] = q_next[i]
                qd[k + 1, i] = qd_next[i]
    return k1, OK


@nb.njit(**JIT)
def program_requirement(compiled, program, dt, friction, k0, k1, out, status, ws):
    """The program's own requirement (module docstring) in cycles k0 <= k < k1: out = (req,
    limit), each (K, n) [N m | N], joint side; status (K,) per cycle; ``friction`` False leaves
    the Coulomb term out (its share is set-valued at rest: Hollerbach's time scaling,
    mrnea.retime.scale, adds it itself). One thread, as the loop: a parallel kernel's worker
    threads would compete with the loop for the cores."""
    model, act = compiled
    q_cmd, qd_cmd, fext, pe = program
    req, limit = out
    K, n = q_cmd.shape  # ws: more rows than the RNEA needs, the loop's type: compiled once
    qdd_des = loop_buffers(ws, n)[2]  # the loop's rows (the RNEA's are others): no allocation
    # the scratch never holds q_cmd[k]'s kinematics: pose_ready False, as a run-time bool, the
    # type the loop's reactions_ws passes, so both share one compiled rnea_ws (a literal False
    # or the default would be a second signature; docs/performance.md section 7)
    pose_ready = k1 < k0
    for k in range(k0, k1):
        for i in range(n):
            v = 0.0 if k + 1 >= K else qd_cmd[k + 1, i]  # the program ends at rest
            qdd_des[i] = (v - qd_cmd[k, i]) / dt
        status[k] = rnea_ws(model, q_cmd[k], qd_cmd[k], qdd_des, fext[k], pe[k], req[k], ws,
                            pose_ready)
        for i in range(n):
            v = 0.0 if k + 1 >= K else qd_cmd[k + 1, i]
            h = req[k, i] + drive_effort(act, i, qd_cmd[k, i], qdd_des[i])
            req[k, i] = h + wanted_friction(h, v, act[i, FPOS], act[i, FNEG]) if friction else h
            limit[k, i] = side_limit(act, i, qd_cmd[k, i], req[k, i])
