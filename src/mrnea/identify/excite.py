"""``mrnea.excitation``: a trajectory that makes the identification well conditioned
(Swevers et al. 1997; docs/identification.md).

A finite Fourier series per joint (:mod:`mrnea.identify.fourier`): periodic with the base
frequency f, at rest at its start and at every whole period, so a duration of whole periods
ends at rest where it began. Its free coefficients are chosen by ``scipy.optimize.minimize``
(L-BFGS-B) to minimise the condition number of the base regressor (:mod:`mrnea.identify.base`,
columns scaled to unit norm: the rigid body and the drives) over ``SAMPLES`` instants of one
period. Limits hold by construction: every candidate is first scaled, joint by joint, about its
centre, down to the largest amplitude that keeps the position within the limits less a margin of
``MARGIN`` of their range, the speed within the velocity limit and the acceleration within
``acceleration_limit``, checked on the program's own cycles (``dt``). The optimiser starts from
``starts`` random coefficient sets (seeded) and keeps the best.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from mrnea import validate
from mrnea.errors import StateError
from mrnea.identify.base import base_parameters, full_regressor
from mrnea.identify.fourier import coefficients, evaluate
from mrnea.identify.regressor import require_serial
from mrnea.io.program import Program
from mrnea.model import Robot

SAMPLES = 120  # instants of one period the condition number is computed on
MARGIN = 0.05  # of each position range, kept free at both ends
DEFAULT_SPEED = (1.0, 0.25)  # [rad/s, m/s] where the robot has no velocity limit
DEFAULT_ACCELERATION = (3.0, 1.0)  # [rad/s^2, m/s^2] default acceleration limit


def _limits(robot: Robot, acceleration_limit: ArrayLike | None
            ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """(lower, upper, velocity, acceleration) (n,) each, finite."""
    pris = robot.is_prismatic
    span = np.where(pris, 0.5, np.pi)
    lo = np.where(np.isfinite(robot.lower), robot.lower, -span)
    hi = np.where(np.isfinite(robot.upper), robot.upper, span)
    room = MARGIN * (hi - lo)
    vel = np.where(np.isfinite(robot.velocity_limit), robot.velocity_limit,
                   np.where(pris, DEFAULT_SPEED[1], DEFAULT_SPEED[0]))
    acc = (np.where(pris, DEFAULT_ACCELERATION[1], DEFAULT_ACCELERATION[0])
           if acceleration_limit is None
           else validate.per_joint(acceleration_limit, "acceleration_limit", robot.n))
    if np.any(acc <= 0):
        raise StateError("acceleration_limit: must be > 0 for every joint")
    return lo + room, hi - room, vel, acc


class _Series:
    """Free coefficients -> the limited series (c, a, b) and its states on a time grid."""

    def __init__(self, robot: Robot, harmonics: int, f: float, t_check: NDArray,
                 limits: tuple[NDArray, NDArray, NDArray, NDArray]) -> None:
        self.n, self.L, self.f, self.t = robot.n, harmonics, f, t_check
        self.lo, self.hi, self.vel, self.acc = limits

    def series(self, x: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        c, a, b = coefficients(x, self.n, self.L)
        c = np.clip(c, self.lo, self.hi)
        q, qd, qdd = evaluate(np.zeros(self.n), a, b, self.f, self.t)  # about the centre
        tiny = 1e-300
        s = np.minimum.reduce([np.ones(self.n),
                               (self.hi - c) / np.maximum(q.max(axis=0), tiny),
                               (c - self.lo) / np.maximum(-q.min(axis=0), tiny),
                               self.vel / np.maximum(np.abs(qd).max(axis=0), tiny),
                               self.acc / np.maximum(np.abs(qdd).max(axis=0), tiny)])
        return c, a * s[:, None], b * s[:, None]


def condition_number(robot: Robot, q: NDArray, qd: NDArray, qdd: NDArray) -> float:
    """The condition number of the base regressor over the states (K, n), its columns scaled to
    unit norm (the figure :func:`excitation` minimises)."""
    bp = base_parameters(robot)
    W = bp.reduce(full_regressor(robot, q, qd, qdd)).reshape(-1, bp.r)
    norms = np.linalg.norm(W, axis=0)
    return float(np.linalg.cond(W / np.maximum(norms, 1e-300)))


def excitation(robot: Robot, duration: float = 20.0, harmonics: int = 5,
               base_frequency: float = 0.1, dt: float = 0.01,
               acceleration_limit: ArrayLike | None = None, starts: int = 3, seed: int = 0,
               maxiter: int = 60, name: str | None = None) -> Program:
    """An excitation program for ``robot`` (module docstring); :func:`excite` also returns
    its condition number.

    ``duration`` [s]: rounded to whole periods of ``base_frequency`` [Hz] (at least one);
    ``harmonics``: L >= 2 per joint; ``dt`` [s]: the program's cycle; ``acceleration_limit``
    [rad/s^2 | m/s^2]: one or one per joint (default 3 rad/s^2, 1 m/s^2); velocity limits are the
    robot's (1 rad/s, 0.25 m/s where it has none), position limits the robot's (+-pi rad, +-0.5 m
    where it has none) less the margin. Returns the program (robot ``robot.name``, cycle dt, no
    wrench; ``q_cmd`` (K, n) from t = 0 to the end, both at rest).
    """
    return excite(robot, duration, harmonics, base_frequency, dt, acceleration_limit, starts,
                  seed, maxiter, name)[0]


def excite(robot: Robot, duration: float = 20.0, harmonics: int = 5,
           base_frequency: float = 0.1, dt: float = 0.01,
           acceleration_limit: ArrayLike | None = None, starts: int = 3, seed: int = 0,
           maxiter: int = 60, name: str | None = None) -> tuple[Program, float]:
    """:func:`excitation`'s program and the condition number of the base regressor over one
    period of it."""
    require_serial(robot, "excitation")
    duration = validate.real(duration, "duration")
    f = validate.real(base_frequency, "base_frequency")
    dt = validate.time_step(dt)
    if not (f > 0 and np.isfinite(f)):
        raise StateError(f"base_frequency: must be a finite frequency > 0 Hz, got {f}")
    if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or \
            not 2 <= harmonics <= 50:
        raise StateError(f"harmonics: must be an integer in [2, 50], got {harmonics!r}")
    if harmonics * f >= 0.25 / dt:
        raise StateError(f"harmonics: the highest harmonic, {harmonics * f:g} Hz, must be below "
                         f"a quarter of the program's rate 1/dt = {1 / dt:g} Hz")
    periods = max(1, round(duration * f))
    period = 1.0 / f
    limits = _limits(robot, acceleration_limit)
    t_one = np.arange(0.0, period, dt)
    ser = _Series(robot, harmonics, f, t_one, limits)
    t_obj = np.linspace(0.0, period, SAMPLES, endpoint=False)

    def cost(x: NDArray) -> float:
        c, a, b = ser.series(x)
        return np.log(condition_number(robot, *evaluate(c, a, b, f, t_obj)))

    rng = np.random.default_rng(seed)
    best = None
    for _ in range(starts):
        x0 = rng.normal(0.0, 1.0, size=(robot.n, 1 + 2 * (harmonics - 1)))
        x0[:, 0] = rng.uniform(limits[0], limits[1])
        sol = scipy.optimize.minimize(cost, x0.ravel(), method="L-BFGS-B",
                                      options={"maxiter": maxiter})
        if best is None or sol.fun < best.fun:
            best = sol
    c, a, b = ser.series(best.x)
    K = round(periods * period / dt) + 1
    t = np.arange(K) * dt
    q = evaluate(c, a, b, f, t)[0]
    q.setflags(write=False)
    t.setflags(write=False)
    prog = Program(robot=robot.name, dt=dt, t=t, q_cmd=q, f_ext=None, f_ext_point=None,
                   mode=None, name=name or f"{robot.name}-excitation")
    return prog, float(np.exp(best.fun))
