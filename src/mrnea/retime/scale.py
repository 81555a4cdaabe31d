"""Uniform time scaling with the full actuator model: Hollerbach's dynamic time scaling, then a
bisection on the verifying simulation (docs/retime.md, "scale").

Usage: ``f = scale_estimate(robot, q, dt, f_ext, f_ext_point)``: the closed-form estimate of the
smallest factor that makes a program achievable (``mrnea check`` and ``mrnea simulate`` print it
for a program that is not); ``result = retime_scale(job)``.

Slowing a program by f (time t -> f t, y = 1/f) scales its velocities by y and accelerations
by y^2, so each joint effort of each cycle is a quadratic in y (Hollerbach 1984)::

    tau(y) = A y^2 + B y + C
    A = H_a qdd + u'(q, qd) - u'(q, 0)     (inertia and velocity products)
    B = F_v qd                             (viscous friction)
    C = u'(q, 0) + phi(direction)          (gravity, wrench, Coulomb friction)

at the program's own state, as the program's requirement forms it
(:func:`mrnea.actuators.program_requirement`, kernels/simulate.py: qd_k backward differences,
qdd_k the next interval's velocity minus this one's over dt, the program ending at rest): A + B +
C at y = 1 is that requirement, so A follows from it, B and C. Coulomb friction takes the side
of the velocity the cycle makes (the program's next one, unchanged by the scaling); where that
is 0 the joint comes to rest and static friction takes up to F+ or F- of the effort, which
widens the band the rest must stay in. With constant limits the largest safe y is the first
positive root of ``tau(y) = +-L`` over all cycles and joints, or the velocity limits'; with a
torque-speed curve, y is safe when the first root with L taken at the speed |qd| y is >= y
(slower, L only grows), and a bisection finds the largest such y.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.actuators import (
    actuator_mass_matrix_and_bias,
    coulomb_effort,
    effort_limits_at,
    program_requirement,
)
from mrnea.errors import NoTimingError, RetimeError, StateError
from mrnea.model import Robot
from mrnea.retime.job import Job, peak_ratio
from mrnea.retime.path import friction_pair, piece_rows, piece_spline
from mrnea.retime.rows import holding_need, motion_check, speed_limit, static_check
from mrnea.trajectory import require_path_memory

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

CHUNK = 20_000  # rows per call of actuator_mass_matrix_and_bias (it holds H for CHUNK states)
TOL = 0.005  # the bisection's relative resolution of the factor
STEP = 1.02  # bracketing steps from the estimate


@dataclass(frozen=True)
class Hollerbach:
    """The quadratic ``h(y) = A y^2 + B y + C`` of every cycle and joint (module docstring):
    (K, n) arrays; ``c`` = u'(q, 0) (gravity and wrench), ``direction`` the sign of the
    velocity each cycle makes (the program's next one: Coulomb friction's side, 0 where the
    joint comes to rest), ``qd`` the program's velocities. Where a joint comes to rest static
    friction takes up to F+ and F- of h, so its effort stays within L while
    ``-(L + lower) <= h <= L + upper`` (``lower``, ``upper``: F+ and F- there, 0 where the
    joint moves)."""

    A: NDArray
    B: NDArray
    C: NDArray
    c: NDArray
    direction: NDArray
    qd: NDArray
    lower: NDArray
    upper: NDArray


def hollerbach(robot: Robot, q: NDArray, dt: float, f_ext: Any = None,
               f_ext_point: Any = None) -> Hollerbach:
    """The coefficients of a program (K, n) at dt [s] with its wrench (K, 6) and point ((3,) or
    (K, 3)), or both by link name (:func:`mrnea.validate.program_wrench`): A + B + C at y = 1
    is the program's own requirement (:func:`mrnea.actuators.program_requirement`, the
    simulation's ``program_effort``) with Coulomb friction apart; c from
    :func:`mrnea.actuators.actuator_mass_matrix_and_bias` on (q, 0), :data:`CHUNK` rows at a
    time."""
    h, _ = program_requirement(robot, q, dt, f_ext, f_ext_point, friction=False)
    K, n = q.shape
    c = np.empty((K, n))
    for k0 in range(0, K, CHUNK):
        r = slice(k0, min(K, k0 + CHUNK))
        fe, pe = validate.wrench_rows(f_ext, r), validate.wrench_rows(f_ext_point, r)
        c[r] = actuator_mass_matrix_and_bias(robot, q[r], np.zeros((r.stop - r.start, n)), fe,
                                             pe)[1]
    qd = np.zeros_like(q)
    qd[1:] = np.diff(q, axis=0) / dt
    direction = np.zeros_like(q)
    direction[:-1] = np.sign(qd[1:])  # the program ends at rest
    B = robot.viscous_friction * qd
    fp, fn = friction_pair(robot)
    still = direction == 0
    return Hollerbach(h - B - c, B, c + coulomb_effort(robot, direction), c, direction, qd,
                      np.where(still, fp, 0.0), np.where(still, fn, 0.0))


def _first_root(A: NDArray, B: NDArray, C: NDArray) -> NDArray:
    """Smallest y > 0 with A y^2 + B y + C = 0 (inf if none); elementwise, stable."""
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = B * B - 4 * A * C
        sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
        qq = -0.5 * (B + np.copysign(sq, B))
        r1 = np.where(A != 0, qq / A, np.nan)
        r2 = np.where(qq != 0, C / qq, np.nan)
        lin = np.where((A == 0) & (B != 0), -C / B, np.nan)
    roots = np.stack([r1, r2, lin])
    return np.min(np.where(roots > 0, roots, np.inf), axis=0)


def scale_estimate(robot: Robot, q: NDArray, dt: float, f_ext: Any = None,
                   f_ext_point: Any = None, t0: float = 0.0) -> float:
    """The smallest factor f (time -> f time) with ``|tau(1/f)| <= L(|qd| / f)`` and the velocity
    limits at every cycle, in closed form (module docstring). q (K, n) at dt [s]; f_ext (K, 6) or
    None; f_ext_point (3,), (K, 3) or None; or both by link name (mappings); t0 [s]: the
    instant of q's first row, for messages.

    Raises
    ------
    NoTimingError
        A pose the robot cannot hold or move through slowly (names the joint, the instant and
        the ratio of need to limit), or no factor makes the program achievable.
    RetimeError
        No limit binds at any speed.
    """
    validate.require_robot(robot)
    dt = validate.time_step(dt)
    q = validate.array(q, "q", robot.n)
    if q.ndim != 2 or q.shape[0] < 2:
        raise StateError(f"q: expected (K, {robot.n}) rows with K >= 2, got {q.shape}")
    K = q.shape[0]
    f_ext, f_ext_point = validate.program_wrench(robot, f_ext, f_ext_point, K)
    t0 = validate.real(t0, "t0")
    h = hollerbach(robot, q, dt, f_ext, f_ext_point)
    t = t0 + np.arange(q.shape[0]) * dt  # the program's instants, for messages
    static_check(robot, holding_need(robot, h.c, h.direction, h.direction != 0), t, 1.0)
    motion_check(robot, h.qd, t)
    speed = np.abs(h.qd)  # a joint at rest has no speed to limit (0/0 was NaN)
    y_vel = float(np.min(np.divide(speed_limit(robot), speed,
                                   out=np.full(speed.shape, np.inf), where=speed > 0)))

    def first_exit(L: NDArray) -> float:
        up, down = L + h.upper, L + h.lower
        y = np.minimum(_first_root(h.A, h.B, h.C - up), _first_root(h.A, h.B, h.C + down))
        return min(y_vel, float(np.min(np.where((h.C > up) | (h.C < -down), 0.0, y))))

    y_hi = first_exit(np.broadcast_to(robot.effort_limit, h.C.shape))
    if not math.isfinite(y_hi):
        raise RetimeError("no effort or velocity limit binds along this path: it can be made "
                          "arbitrarily fast")
    if all(c is None for c in robot.torque_speed):
        return 1 / y_hi
    lo, hi = 0.0, y_hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if first_exit(effort_limits_at(robot, np.abs(h.qd) * mid)) >= mid:
            lo = mid
        else:
            hi = mid
    return 1 / lo


def scaled(spline: CubicSpline, q: NDArray, program_dt: float, dt: float, f: float
           ) -> tuple[NDArray, NDArray]:
    """A moving piece's rows q (K, n) on its clock (k program_dt, ``spline`` through them),
    slowed by f, at dt: (rows, the path position of each on the piece's clock). They must fit
    the memory budget (:func:`mrnea.trajectory.require_path_memory`)."""
    T = (q.shape[0] - 1) * program_dt
    M = math.ceil(f * T / dt - 1e-9) + 1
    require_path_memory(M, q.shape[1])
    s = np.minimum(np.arange(M) * dt / f, T)
    s[-1] = T
    return piece_rows(spline, s, q[0], q[-1])


def retime_scale(job: Job) -> tuple[float, float, tuple, dict]:
    """The smallest factor f, to :data:`TOL`, for which the program slowed by f (every moving
    piece, dwells kept) passes the verifying simulation: from :func:`scale_estimate`, steps of
    :data:`STEP` to bracket it, then a geometric bisection. The searching simulations skip the
    joint reactions; the accepted program is simulated again with them.

    Returns (f, utilisation, (Q, FE, PE, clock, simulation), log): the utilisation is the largest
    fraction of a limit the accepted program uses; ``log``: ``estimate`` and the factors
    ``evaluated``.
    """
    t0 = time.perf_counter()
    f_est = scale_estimate(job.robot, job.q, job.program_dt, job.f_ext, job.f_ext_point)
    job.timings["coefficients"] += time.perf_counter() - t0
    splines = {j: piece_spline(job.q[k0:k1 + 1], job.program_dt) for j, k0, k1 in job.moving}
    cache: dict[float, tuple] = {}

    def run(f: float) -> tuple:
        if f not in cache:
            t1 = time.perf_counter()
            retimed = {j: scaled(splines[j], job.q[k0:k1 + 1], job.program_dt, job.dt, f)
                       for j, k0, k1 in job.moving}
            job.timings["sampling"] += time.perf_counter() - t1
            for j, (rows, s) in retimed.items():
                job.check_resolution(j, splines[j], rows, s,
                                     np.max(np.abs(splines[j](s, 2)), axis=0) / f ** 2)
            Q, FE, PE, clk = job.assemble(retimed)
            cache[f] = (Q, FE, PE, clk, job.verify(Q, FE, PE, reactions=False))
        return cache[f]

    lo = hi = None
    f = f_est
    for _ in range(120):  # bracket: 2 % steps from the estimate
        if run(f)[4].achievable:
            hi = f
            if lo is not None:
                break
            f /= STEP
        else:
            lo = f
            if hi is not None:
                break
            f *= STEP
    if hi is None:
        raise NoTimingError(f"scale: no factor up to {f:.4g} makes the program achievable; the "
                          f"last try: {run(lo)[4].verdict()}")
    lo = hi / STEP if lo is None else lo
    while hi / lo > 1 + TOL:
        mid = math.sqrt(lo * hi)
        if run(mid)[4].achievable:
            hi = mid
        else:
            lo = mid
    Q, FE, PE, clk, _ = run(hi)
    sim = job.verify(Q, FE, PE)
    return hi, peak_ratio(sim), (Q, FE, PE, clk, sim), {
        "estimate": f_est, "evaluated": sorted(cache)}
