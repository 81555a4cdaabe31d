"""The actuator limits along a path as rows TOPP-RA takes, ``A sdd + B sd^2 + C <= 0``, linear on
the safe side where the true constraint is not (docs/retime.md, "Tightening").

Usage: ``lim = Limits.of(robot, margin)``; ``A, B, C = constraint_rows(pc, lim, sd_bar, lag)``
(``sd_bar`` None: the relaxation), ``acceleration_rows(pc, lim)``, ``velocity_cap(pc, lim)``;
``utilisation(pc, lim, sd, dt)`` and ``limit_curve(pc, lim)`` evaluate a profile with the true
model; ``static_check(...)`` raises for a path no timing can make.

Per joint and grid point the true constraint is ``|a u + b x + c' + k sd| <= L(|q_s| sd)``
(u = sdd, x = sd^2, k = F_v q_s, c' = c + Coulomb, L the torque-speed curve of
:mod:`mrnea.kernels.drive`). It is not linear in (u, x): sd = sqrt(x) appears in the viscous term
and in L. The rows below imply it for EVERY x >= 0 and are exact at a linearisation point
x_bar = sd_bar^2 (an inner approximation):

* the viscous term that works against the limit: ``sqrt(x) <= sd_bar/2 + x/(2 sd_bar)`` (the
  tangent of the concave sqrt);
* the viscous term that helps: ``sqrt(x) >= min(x/sd_bar, sd_bar)`` (two rows);
* the limit: each falling branch of the curve (constant power, the line to the no-load speed) is
  convex in x at w = |q_s| sqrt(x) + lag (convex non-increasing of a concave function), so its
  tangent at x_bar bounds it from below: one row per branch
  (:func:`mrnea.actuators.effort_limit_branches`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.actuators import coulomb_effort, effort_limit_branches, effort_limits_at
from mrnea.errors import NoTimingError, RetimeError
from mrnea.model import Robot
from mrnea.retime.path import PathCoefficients, friction_pair

SPARE = 1e-3  # holdable: (sdd, sd^2) = (0, 0) satisfies every row with this fraction of the peak
APART = 1e-6  # the second viscous row only where it differs from the first by this (of the peak)
SD_CAP = 1e4  # the path speed where no velocity limit binds (a path 10^4 times faster)
SD_PLOT = 1e2  # the limit curve's ceiling (limit_curve)


@dataclass(frozen=True)
class Limits:
    """The planning limits: ``margin`` times each joint's effort curve and velocity limit (a
    float, or (N + 1, 1) per grid point of one piece: the margin search's local tightening,
    :mod:`mrnea.retime.search`; :func:`limit_curve` takes a float), and
    optional acceleration limits (n,) [rad/s^2 | m/s^2]. ``peak``, ``corner`` (inf: a constant
    limit), ``fv`` and ``vlim`` (n,) are the robot's, unscaled."""

    robot: Robot
    margin: float | NDArray
    acceleration: NDArray | None
    peak: NDArray
    corner: NDArray
    fv: NDArray
    vlim: NDArray

    @classmethod
    def of(cls, robot: Robot, margin: float, acceleration: NDArray | None = None) -> Limits:
        corner = np.array([np.inf if c is None else c[1] for c in robot.torque_speed])
        no_load = np.array([np.inf if c is None else c[2] for c in robot.torque_speed])
        # a curve stepping to zero at its corner is a speed limit
        vlim = np.where(corner == no_load, np.minimum(robot.velocity_limit, no_load),
                        robot.velocity_limit)
        return cls(robot, margin, acceleration, np.asarray(robot.effort_limit), corner,
                   np.asarray(robot.viscous_friction), vlim)

    def limit(self, speed: NDArray) -> NDArray:
        """The effort limits (unscaled) at joint speeds (..., n)."""
        return effort_limits_at(self.robot, np.abs(speed))


def _scale(peak: NDArray) -> NDArray:
    """Rows are divided by the joint's peak effort (1 where it is 0 or unlimited)."""
    return np.where(np.isfinite(peak) & (peak > 0), peak, 1.0)


def speed_lag(pc: PathCoefficients, sd: NDArray, dt: float) -> NDArray:
    """How much faster than the profile a joint is when the simulation takes its effort limit.

    The simulation evaluates cycle k at the velocity of the interval before it (a backward
    difference), |qd(t_k - dt/2)| = |qd(t_k)| + |qdd| dt/2 while a joint slows down. Per grid
    point and joint (N + 1, n): |qdd| dt / 2 where the joint decelerates, else 0, with qdd of
    either adjacent interval of the profile sd.
    """
    x = sd ** 2
    u = np.diff(x) / (2 * np.diff(pc.s))
    w = pc.qs * sd[:, None]
    lag = np.zeros_like(w)
    for uu in (np.append(u, u[-1]), np.insert(u, 0, u[0])):
        qdd = pc.qs * uu[:, None] + pc.qss * x[:, None]
        lag = np.maximum(lag, np.where(w * qdd < 0, np.abs(qdd) * dt / 2, 0.0))
    return lag


def _friction_bounds(pc: PathCoefficients, lim: Limits) -> tuple[NDArray, NDArray]:
    """c + Coulomb, as an upper and a lower bound: exact where the direction of motion is the
    same at a grid point and its neighbours (none where the joint stays at rest), else widened
    by F_s on both sides (a joint reversing, starting or stopping: breakaway friction)."""
    fp, fn = friction_pair(lim.robot)
    known = np.isfinite(pc.sign)
    coul = coulomb_effort(lim.robot, np.nan_to_num(pc.sign))
    return pc.c + np.where(known, coul, fp), pc.c + np.where(known, coul, -fn)


def constraint_rows(pc: PathCoefficients, lim: Limits, sd_bar: NDArray | None,
                    lag: NDArray | float = 0.0) -> tuple[NDArray, NDArray, NDArray]:
    """The effort rows ``A u + B x + C <= 0`` (N + 1, m), u = sdd, x = sd^2.

    ``sd_bar`` None: the relaxation (peak effort, no viscous friction), not safe. Otherwise the
    inner approximation of the module docstring, exact at ``sd_bar``, the limit taken at the
    joint speed plus ``lag`` (:func:`speed_lag`). A branch's tangent is taken at
    ``max(sd_bar, corner / (2 |q_s|))``: slower, the branch is above twice the peak (not
    binding: the rows stay exact at sd_bar and well scaled). Rows are divided by the peak.
    """
    c_up, c_lo = _friction_bounds(pc, lim)
    zero = np.zeros_like(pc.a)
    peak = np.broadcast_to(lim.peak, pc.a.shape)
    lines = [(lim.margin * peak, zero)]  # limit >= L0 - beta x, per branch
    up_var = lo_var = [(zero, zero)]  # the viscous term k sd between const + coef x bounds
    if sd_bar is not None:
        sb = np.maximum(sd_bar, max(1e-3 * sd_bar.max(), 1e-9))[:, None]  # any sd_bar > 0 is safe
        qs = np.abs(pc.qs)
        with np.errstate(divide="ignore", invalid="ignore"):
            sd_t = np.maximum(sb, lim.corner / (2 * qs))
            moving = (qs > 0) & np.isfinite(sd_t)
            br = effort_limit_branches(lim.robot, np.where(moving, qs * sd_t + lag, 0.0))
            dw_dx = qs / (2 * sd_t)  # w = |q_s| sqrt(x) + lag
            for f, df in ((br[..., 0], br[..., 1]), (br[..., 2], br[..., 3])):
                ok = moving & np.isfinite(f)
                beta = -df * dw_dx
                lines.append((lim.margin * np.where(ok, f + beta * sd_t ** 2, np.nan),
                              lim.margin * np.where(ok, beta, 0.0)))
        k = lim.fv * pc.qs
        if np.any(k):
            kp, km = np.maximum(k, 0), np.minimum(k, 0)
            # the second row only where it differs from the first (seidel takes two rows that
            # close for parallel and declares the LP infeasible)
            apart = np.abs(k) / sb >= APART * peak
            # upper bound of k sd: kp by the tangent, km by the two lower bounds of sd
            up_var = [(kp * sb / 2, kp / (2 * sb) + km / sb),
                      (np.where((km < 0) & apart, kp * sb / 2 + km * sb, np.nan), kp / (2 * sb))]
            # lower bound of k sd: km by the tangent, kp by the two lower bounds of sd
            lo_var = [(km * sb / 2, km / (2 * sb) + kp / sb),
                      (np.where((kp > 0) & apart, km * sb / 2 + kp * sb, np.nan), km / (2 * sb))]
    A, B, C = [], [], []
    for L0, beta in lines:  # L0 NaN: the branch does not apply
        for const, coef in up_var:  # tau <= L0 - beta x; const NaN: the variant does not apply
            A.append(pc.a)
            B.append(pc.b + coef + beta)
            C.append(c_up + const - L0)
        for const, coef in lo_var:  # tau >= -(L0 - beta x)
            A.append(-pc.a)
            B.append(-(pc.b + coef - beta))
            C.append(-(c_lo + const) - L0)
    scale = np.tile(_scale(lim.peak), len(A))
    A, B, C = (np.concatenate(X, axis=1) / scale for X in (A, B, C))
    off = ~np.isfinite(C)  # rows that do not apply (or an unlimited joint): 0 u + 0 x - 1 <= 0
    A[off], B[off], C[off] = 0.0, 0.0, -1.0
    return A, B, C


def acceleration_rows(pc: PathCoefficients, lim: Limits
                      ) -> tuple[NDArray, NDArray, NDArray] | None:
    """Rows per stage i (not per grid point) that keep |qdd| <= margin x acceleration limit
    over the whole interval [s_i, s_i+1]: qdd(s) = q_s(s) u + q_ss(s) x(s) with
    x(s) = x_i + 2 u (s - s_i) is bilinear, so its extremes over the box (q_s in its range,
    q_ss in its range, x in {x_i, x_i + 2 delta u}) are at the 8 vertices: 16 rows a joint.
    (Rows at the grid points only let the joint accelerations inside an interval next to a rest
    overshoot the limit 2-3 times: toppra issues #41, #56, #150.) The last stage, the path's
    end, gets the point rows. None without acceleration limits."""
    if lim.acceleration is None:
        return None
    amax = lim.margin * lim.acceleration
    delta = np.diff(pc.s)[:, None]
    A, B = [], []
    for qs in (pc.qs_range[..., 0], pc.qs_range[..., 1]):
        for qss in (pc.qss_range[..., 0], pc.qss_range[..., 1]):
            for theta in (0.0, 1.0):
                a = np.vstack([qs + theta * 2 * delta * qss, pc.qs[-1:]]) / amax
                b = np.vstack([qss, pc.qss[-1:]]) / amax
                A += [a, -a]
                B += [b, -b]
    A, B = np.concatenate(A, axis=1), np.concatenate(B, axis=1)
    return A, B, -np.ones_like(A)


def velocity_cap(pc: PathCoefficients, lim: Limits) -> NDArray:
    """Largest x = sd^2 the velocity limits (times margin) allow at each grid point."""
    with np.errstate(divide="ignore"):
        sd = np.min(lim.margin * lim.vlim / np.abs(pc.qs), axis=1)
    return np.minimum(sd, SD_CAP) ** 2


def holdable(pc: PathCoefficients, lim: Limits, sd_hi: NDArray,
             lag: NDArray | float = 0.0) -> NDArray:
    """The largest sd_bar <= sd_hi per grid point at which (sdd, x) = (0, 0) still satisfies
    the rows linearised at sd_bar with :data:`SPARE` of the peak effort to spare (so the
    problem is feasible and not degenerate at rest: a row exactly through (0, 0) made TOPP-RA's
    backward pass drift away from x = 0); a bisection on every point at once."""
    def ok(sd: NDArray) -> NDArray:
        return np.all(constraint_rows(pc, lim, sd, lag)[2] <= -SPARE, axis=1)

    good = ok(sd_hi)
    if good.all():
        return sd_hi
    lo, hi = np.zeros_like(sd_hi), sd_hi.copy()
    for _ in range(40):
        mid = np.where(good, hi, (lo + hi) / 2)
        m_ok = ok(mid)
        lo = np.where(~good & m_ok, mid, lo)
        hi = np.where(~good & ~m_ok, mid, hi)
    return np.where(good, sd_hi, lo)


def holding_need(robot: Robot, c: NDArray, sign: NDArray, moving: NDArray) -> NDArray:
    """The effort each joint needs to move along the path infinitely slowly (or to hold still
    where ``moving`` is False): gravity and wrench ``c`` plus Coulomb friction against the motion
    (``sign`` NaN where the direction changes: either way), or, held still, what static friction
    (from -F- to F+) cannot take."""
    fp, fn = friction_pair(robot)
    with np.errstate(invalid="ignore"):
        against = np.where(np.isfinite(sign),
                           np.abs(c + coulomb_effort(robot, np.nan_to_num(sign))),
                           np.maximum(np.abs(c + fp), np.abs(c - fn)))
    return np.where(moving, against, np.maximum(np.maximum(c - fn, -c - fp), 0.0))


def static_check(robot: Robot, need: NDArray, t: NDArray, margin: float) -> None:
    """Raise :class:`~mrnea.errors.NoTimingError` where a joint's holding effort ``need`` (K, n)
    at the program instants ``t`` (K,) exceeds its limit (no timing can make the path), or
    :class:`RetimeError` where it exceeds its planning limit ``margin`` x limit (no timing
    within the margin: the margin asked is the fault)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(need > 0, need / robot.effort_limit, 0.0)
    k, i = np.unravel_index(np.argmax(ratio), ratio.shape)
    r = float(ratio[k, i])
    if r <= margin:
        return
    j = robot.joints[i]
    unit = "N" if j.is_prismatic else "N m"
    where = (f"at t = {t[k]:.4g} s of the program joint '{j.name}' (joint {i + 1}) needs "
             f"{need[k, i]:.4g} {unit} to hold its pose against gravity, the wrench and "
             f"friction, {r:.3f} times its limit {j.effort_limit:.4g} {unit}")
    if r > 1:
        raise NoTimingError(f"the path cannot be followed at any speed: {where}")
    raise RetimeError(f"no timing keeps the path within the planning margin {margin:g}: {where}"
                      f"; pass a margin above {r:.3f}")


def speed_limit(robot: Robot) -> NDArray:
    """Per joint, the fastest it may move [rad/s | m/s]: its velocity limit, or its
    torque-speed curve's no-load speed where that is lower."""
    no_load = np.array([np.inf if c is None else c[2] for c in robot.torque_speed])
    return np.minimum(robot.velocity_limit, no_load)


def motion_check(robot: Robot, step: NDArray, t: NDArray) -> None:
    """Raise :class:`~mrnea.errors.NoTimingError` where the path moves a joint whose speed limit
    is 0 (its velocity limit, or its torque-speed curve's no-load speed): no timing makes that
    motion (a velocity limit of 0 had read as "it can be made arbitrarily fast", or the
    time-optimal profile stopping between two grid points). ``step`` (K, n): any measure of the
    path's motion per row (only its nonzero entries matter); ``t`` (K,) [s] its instants."""
    stuck = (step != 0) & (speed_limit(robot) == 0)
    if stuck.any():
        k, i = np.argwhere(stuck)[0]
        raise NoTimingError(f"joint {robot.joint_names[i]!r} may not move (its speed limit is "
                            f"0) and the path moves it at t = {t[k]:.4g} s of the program")


def steady_speed(lim: Limits) -> NDArray:
    """Per joint, the speed [rad/s | m/s] at which the whole effort limit goes into viscous
    friction, L(w) = F_v w (inf without friction and curve): no joint can be driven faster for
    long. A bisection on every joint at once."""
    no_load = np.array([np.inf if c is None else c[2] for c in lim.robot.torque_speed])
    lo = np.zeros_like(lim.peak)
    hi = np.minimum(no_load, 1e6)
    hi = np.where(lim.fv > 0, np.minimum(hi, lim.peak / np.maximum(lim.fv, 1e-300)), hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        ok = lim.limit(mid) >= lim.fv * mid
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return np.where(np.isinf(no_load) & (lim.fv == 0), np.inf, lo)


def utilisation(pc: PathCoefficients, lim: Limits, sd: NDArray, dt: float = 0.0) -> NDArray:
    """At each grid point (N + 1,), the largest ratio over joints of |effort| / limit(speed) and
    |speed| / velocity limit, with the true model (viscous friction, the torque-speed curve),
    the path acceleration of either adjacent interval, and the limit at the speed the
    simulation at dt uses (:func:`speed_lag`). Unscaled: compare with ``lim.margin``."""
    x = sd ** 2
    u = np.diff(x) / (2 * np.diff(pc.s))
    out = np.zeros(pc.s.size)
    c_up, c_lo = _friction_bounds(pc, lim)
    w = pc.qs * sd[:, None]
    L = lim.limit(np.abs(w) + (speed_lag(pc, sd, dt) if dt > 0 else 0.0))
    rest = pc.b * x[:, None] + lim.fv * w
    with np.errstate(divide="ignore", invalid="ignore"):
        vel = np.abs(w) / lim.vlim
        for uu in (np.append(u, u[-1]), np.insert(u, 0, u[0])):
            tau = pc.a * uu[:, None] + rest
            need = np.maximum(np.abs(tau + c_up), np.abs(tau + c_lo))
            r = np.where(L > 0, need / L, np.where(need > 0, np.inf, 0.0))
            out = np.maximum(out, np.max(np.maximum(r, vel), axis=1))
    return out


def limit_curve(pc: PathCoefficients, lim: Limits, samples: int = 64) -> NDArray:
    """The phase plane's limit curve (N + 1,): at each grid point the largest path speed sd at
    which some path acceleration keeps every joint within ``margin`` x its limits, with the true
    model (viscous friction, the limit at that speed, Coulomb as the rows take it) and the
    velocity limits. The first infeasible speed of a scan up to the velocity cap (at most
    :data:`SD_PLOT`), refined by a second scan in the bracket: resolution cap / samples^2. For the
    report's plot; nothing in the retiming uses it."""
    c_up, c_lo = (c[:, None, :] for c in _friction_bounds(pc, lim))
    a = pc.a[:, None, :]

    def feasible(sd: NDArray) -> NDArray:  # sd (G, S) -> (G, S) bool
        w = pc.qs[:, None, :] * sd[..., None]
        L = lim.margin * lim.limit(w.reshape(-1, w.shape[-1])).reshape(w.shape)
        rest = pc.b[:, None, :] * (sd ** 2)[..., None] + lim.fv * w
        hi, lo = L - c_up - rest, -L - c_lo - rest  # a u must lie in [lo, hi]
        with np.errstate(divide="ignore", invalid="ignore"):
            u_hi = np.where(a > 0, hi / a, np.where(a < 0, lo / a, np.inf))
            u_lo = np.where(a > 0, lo / a, np.where(a < 0, hi / a, -np.inf))
        still = (a == 0) & ((hi < 0) | (lo > 0))
        return (np.max(u_lo, axis=2) <= np.min(u_hi, axis=2)) & ~np.any(still, axis=2)

    lo = np.zeros(pc.s.size)
    hi = np.minimum(np.sqrt(velocity_cap(pc, lim)), SD_PLOT)
    for _ in range(2):
        sd = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, samples + 1)[None, :]
        ok = feasible(sd)
        last = np.where(ok.all(axis=1), samples, np.maximum(np.argmin(ok, axis=1) - 1, 0))
        rows = np.arange(sd.shape[0])
        lo, hi = sd[rows, last], sd[rows, np.minimum(last + 1, samples)]
    return lo
