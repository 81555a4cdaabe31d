"""The per-joint checks of drive sizing, exact from the programs' own requirement (issue 27).

A joint's duty cycle (:class:`Duty`) is what the programs ask of it, cycle by cycle, at their
own states (:func:`mrnea.actuators.program_requirement`): h0, the effort without the joint's own
reflected rotor inertia and without Coulomb friction, the program's speed qd and acceleration
qdd_des, and each cycle's duration. A drive train with gear ratio G and motor plus gearbox
inertia J (motor side) adds G^2 J qdd_des to the joint's own row only (H_a = H + diag(G^2 J),
Eqs. 42-43), so the joint effort a train needs is, exactly::

    h = h0 + G^2 J qdd_des,   tau = h + phi(h),   phi: the wanted motion's Coulomb friction
                                                   (kernels/drive.py wanted_friction)

With the gearbox's efficiency (kernels/drive.py ``motor_side``) the motor torque is
tau / (G eta_d) driving (tau qd >= 0) and tau eta_b / G back-driven. The checks, each a ratio
(need / rating, <= 1 passes):

* ``peak``: max over cycles of |motor torque| / the motor's limit at its speed G |qd| (its
  torque-speed curve, or its peak torque);
* ``rms``: the RMS motor torque over the duty cycle (each cycle weighted by its duration) /
  rated_torque;
* ``speed``: max G |qd| / max_speed; ``input_speed``: the same / the gearbox's max_input_speed;
* ``gear_peak``: max |tau| / the gearbox's peak_torque; ``gear_rated``: the cubic mean output
  torque (sum |qd| |tau|^3 dt / sum |qd| dt)^(1/3) / its rated_torque (0 if it never turns).

Every ratio is computed for all trains of a joint at once (arrays (C, K)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.sizing.catalogue import Train

#: the checks, in the order tables show them, with their words for a failure
CHECKS = {"peak": "its peak torque (at speed)", "rms": "its RMS rating",
          "speed": "its maximum speed", "input_speed": "the gearbox's input speed",
          "gear_peak": "the gearbox's peak torque", "gear_rated": "the gearbox's rated torque"}


@dataclass(frozen=True)
class Duty:
    """One joint's duty cycle, (K,) each: effort without its own rotor and without Coulomb
    friction h0 [N m | N], speed qd, acceleration qdd_des, the velocity v each cycle wants
    (whose friction the drive meets), cycle duration dt [s]; its Coulomb friction magnitudes
    (F+, F-)."""

    h0: NDArray
    qd: NDArray
    qdd: NDArray
    v: NDArray
    dt: NDArray
    coulomb: tuple[float, float]


@dataclass(frozen=True)
class Judged:
    """All trains of one joint judged on its duty: ``ratios`` (C, 6) in :data:`CHECKS` order,
    ``worst`` (C,), ``effort`` (C, K) the joint effort, ``motor`` (C, K) the motor torque,
    ``rms`` (C,) the RMS motor torque [N m], ``rms_speed`` (C,) the RMS motor speed [rad/s]."""

    ratios: NDArray
    worst: NDArray
    effort: NDArray
    motor: NDArray
    rms: NDArray
    rms_speed: NDArray


def motor_limit(trains: list[Train], w: NDArray) -> NDArray:
    """Each train's motor torque limit [N m] at motor speeds w (C, K) >= 0: the torque-speed
    curve of docs/achievable.md (peak up to the corner, then constant power or the line to
    the no-load speed, whichever is lower), or the peak torque."""
    out = np.empty_like(w)
    for c, t in enumerate(trains):
        m = t.motor
        if m.torque_speed is None:
            out[c] = m.peak_torque
            continue
        peak, corner, no_load = m.torque_speed
        wc = np.maximum(w[c], corner)
        line = peak * (no_load - w[c]) / (no_load - corner) if no_load > corner else 0.0
        mid = np.minimum(peak * corner / wc, line)
        out[c] = np.where(w[c] <= corner, peak, np.where(w[c] >= no_load, 0.0, mid))
    return out


def judge(trains: list[Train], duty: Duty) -> Judged:
    """Every check of :data:`CHECKS` for every train on this duty (module docstring)."""
    G = np.array([t.gearbox.ratio for t in trains])[:, None]
    J = np.array([t.motor.rotor_inertia + t.gearbox.inertia for t in trains])[:, None]
    eta = np.array([t.gearbox.efficiency for t in trains])
    h = duty.h0[None] + G**2 * J * duty.qdd[None]
    Fp, Fn = duty.coulomb
    v = duty.v[None]
    phi = np.where(v > 0, Fp, np.where(v < 0, -Fn, np.clip(-h, -Fn, Fp)))
    tau = h + phi
    back = tau * duty.qd[None] < 0.0
    motor = np.where(back, tau * eta[:, 1:2] / G, tau / (G * eta[:, 0:1]))
    w = G * np.abs(duty.qd)[None]
    lim = motor_limit(trains, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        peak = np.where(np.abs(motor) > 0, np.abs(motor) / lim, 0.0).max(axis=1)
    T = duty.dt.sum()
    rms = np.sqrt((motor**2 * duty.dt[None]).sum(axis=1) / T)
    rms_speed = np.sqrt((w**2 * duty.dt[None]).sum(axis=1) / T)
    wmax = w.max(axis=1)
    turn = (np.abs(duty.qd) * duty.dt).sum()
    cubic = (((np.abs(duty.qd) * duty.dt)[None] * np.abs(tau) ** 3).sum(axis=1) / turn) ** (1 / 3) \
        if turn > 0 else np.zeros(len(trains))

    def rating(get) -> NDArray:
        return np.array([get(t) for t in trains])

    ratios = np.stack([
        peak,
        rms / rating(lambda t: t.motor.rated_torque),
        wmax / rating(lambda t: t.motor.max_speed),
        wmax / rating(lambda t: t.gearbox.max_input_speed),
        np.abs(tau).max(axis=1) / rating(lambda t: t.gearbox.peak_torque),
        cubic / rating(lambda t: t.gearbox.rated_torque),
    ], axis=1)
    return Judged(ratios, ratios.max(axis=1), tau, motor, rms, rms_speed)


def times(ratio: float, check: str) -> str:
    """A need against a check's rating in words: ``"1.3 x its RMS rating"``; an infinite ratio
    (the rating is 0 where the need is not: above the motor's no-load speed) says so."""
    if np.isfinite(ratio):
        return f"{ratio:.3g} x {CHECKS[check]}"
    return f"beyond {CHECKS[check]}, which gives nothing where it is needed"


def reason(ratios: NDArray) -> str:
    """Why a train fails (every check over 1, worst first), or "" if it passes."""
    over = sorted(((r, k) for k, r in zip(CHECKS, ratios.tolist(), strict=True) if r > 1.0),
                  reverse=True)
    return "; ".join(times(r, k) for r, k in over)
