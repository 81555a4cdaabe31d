"""The per-cycle arrays a simulation derives from its loop's, cycles k0 <= k < k1, in one pass.

Usage: ``derived(act, run, out, resolution, k0, k1)`` with ``run = (q_cmd, q, qd, tau, limit,
clamp)`` (K, n), the loop's arrays (kernels/simulate.py), and ``out = (tau_motor, margin,
tracking_error, position_clamped, velocity_clamped)`` (K, n); ``act`` the actuator array
(kernels/layout.py), ``resolution`` (n,) the tracking errors that are rounding
(:attr:`mrnea.simulate.SimulationResult.tracking_error`). Per cycle and joint::

    tau_motor = motor_side(tau) at the cycle's starting speed qd   (kernels/drive.py)
    margin = limit - |tau|
    tracking_error = q_cmd - q, or 0 where |q_cmd - q| <= resolution
    position_clamped, velocity_clamped = the clamp's CLAMP_POSITION, CLAMP_VELOCITY bits

the same operations as the NumPy expressions they replaced (issue 29: a sweep run's Python
share), so the same bits.
"""

from __future__ import annotations

import numba as nb

from mrnea.kernels.achievable import CLAMP_POSITION, CLAMP_VELOCITY
from mrnea.kernels.drive import motor_side
from mrnea.kernels.layout import JIT


@nb.njit(**JIT)
def derived(act, run, out, resolution, k0, k1):
    """Fill ``out``'s rows k0 <= k < k1 from ``run``'s (module docstring)."""
    q_cmd, q, qd, tau, limit, clamp = run
    tau_motor, margin, tracking_error, position_clamped, velocity_clamped = out
    n = q.shape[1]
    for k in range(k0, k1):
        for i in range(n):
            tau_motor[k, i] = motor_side(act, i, qd[k, i], tau[k, i])
            margin[k, i] = limit[k, i] - abs(tau[k, i])
            e = q_cmd[k, i] - q[k, i]
            tracking_error[k, i] = 0.0 if abs(e) <= resolution[i] else e
            position_clamped[k, i] = (clamp[k, i] & CLAMP_POSITION) != 0
            velocity_clamped[k, i] = (clamp[k, i] & CLAMP_VELOCITY) != 0
