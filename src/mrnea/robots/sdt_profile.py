"""The demo's training profile for the SDT: what a pilot-training centrifuge is programmed to do.

Phases (times in s, angles in rad, joint order planetary, cabin yaw, roll, pitch):

====== ================================================================================
0-2     at rest
2-12    planetary arm spin-up to 2.5 rad/s (about 1.9 g radial at the 3 m arm), with a
        smooth (smoothstep) velocity ramp: peak 0.375 rad/s^2
12-32   constant planetary speed, with cabin manoeuvres, each a rest-to-rest quintic:
        14-17  yaw +pi (a fast 180 deg turn of the cabin: peak 2.1 rad/s^2)
        19-23  roll to +45 deg, 23-27 back to 0
        27-30  pitch to +30 deg, 30-33 back to 0
32-42   planetary spin-down to rest
====== ================================================================================

The fast yaw turn is deliberate: against the arm's rotation it needs more torque than the yaw
drive has (docs/sdt.md), so the demo shows what mrnea reports when a program is not achievable.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mrnea.io.program import Program
from mrnea.trajectory import cycles, require_path_memory
from mrnea.validate import time_step

DURATION = 42.0


def _smoothstep(s: NDArray) -> NDArray:
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _smoothstep_integral(s: NDArray) -> NDArray:
    s = np.clip(s, 0.0, 1.0)
    return s**3 - 0.5 * s**4


def _quintic(t: NDArray, t0: float, t1: float, q0: float, q1: float) -> NDArray:
    s = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    return q0 + (q1 - q0) * (10 * s**3 - 15 * s**4 + 6 * s**5)


def training_profile(dt: float = 0.005) -> tuple[NDArray, NDArray]:
    """Commanded positions of the SDT training profile: ``(t (K,), q_cmd (K, 4))`` at dt [s].

    Raises
    ------
    StateError
        ``dt`` is not a finite time step > 0 s, or so small that the profile would have more
        cycles than :data:`mrnea.trajectory.MAX_CYCLES` or than memory allows.
    """
    dt = time_step(dt)
    # the profile's dozen temporaries of K values each count as a path of 4 joints
    require_path_memory(float(cycles(DURATION, dt)) + 1, 4)
    t = np.arange(0.0, DURATION + 0.5 * dt, dt)
    w, up0, up1, down0, down1 = 2.5, 2.0, 12.0, 32.0, 42.0
    # planetary angle: integral of the smooth velocity ramp up, hold, ramp down
    T_up, T_down = up1 - up0, down1 - down0
    angle_up = w * T_up * _smoothstep_integral((t - up0) / T_up)
    hold = w * np.clip(t - up1, 0.0, down0 - up1)
    s_down = np.clip((t - down0) / T_down, 0.0, 1.0)
    angle_down = w * T_down * (s_down - _smoothstep_integral(s_down))
    planetary = angle_up + hold + angle_down
    yaw = _quintic(t, 14.0, 17.0, 0.0, np.pi)
    roll = _quintic(t, 19.0, 23.0, 0.0, np.pi / 4) + _quintic(t, 23.0, 27.0, 0.0, -np.pi / 4)
    pitch = _quintic(t, 27.0, 30.0, 0.0, np.pi / 6) + _quintic(t, 30.0, 33.0, 0.0, -np.pi / 6)
    return t, np.stack([planetary, yaw, roll, pitch], axis=1)


def training_program(dt: float = 0.005) -> Program:
    """The training profile (:func:`training_profile`) as a :class:`mrnea.io.Program` for the
    built-in SDT, named ``sdt_training``: what ``mrnea demo`` simulates, and the program
    ``"demo"`` of a sweep (docs/sweeps.md)."""
    t, q = training_profile(dt)
    t.setflags(write=False)
    q.setflags(write=False)
    return Program(robot="sdt", dt=time_step(dt), t=t, q_cmd=q, f_ext=None, f_ext_point=None,
                   mode=None, name="sdt_training", source="built-in")
