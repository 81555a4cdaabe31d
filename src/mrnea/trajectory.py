"""The path interpolator: commanded joint positions at every interpolation cycle dt (paper Sec. II).

A path planner sends the servo controllers one row of joint positions every interpolation cycle
Δt (3-10 ms in current controllers); :func:`mrnea.simulate.simulate` takes such rows. This module
makes them from waypoints:

* :func:`trapezoidal` -- rest-to-rest segments through waypoints with synchronised trapezoidal
  (or triangular) velocity profiles, within per-joint velocity and acceleration limits;
* :func:`quintic` -- rest-to-rest quintic polynomial segments (zero velocity and acceleration at
  both ends of every segment), synchronised, within the same limits;
* :func:`scurve` -- rest-to-rest jerk-limited (S-curve, seven-phase) segments, synchronised,
  within velocity, acceleration and jerk limits: the time-optimal profile computed by ruckig.

Paths from files are read in :mod:`mrnea.io`: a recorded path CSV (:func:`mrnea.io.from_csv`,
resampled to dt on the same cycle grid as here, :func:`cycles`) and a program file
(:func:`mrnea.io.load_program`, whose waypoint paths are made here).

Conventions. Joint positions in rad (revolute) or m (prismatic), times in s, velocity limits in
rad/s or m/s, acceleration limits in rad/s² or m/s². Every returned path is sampled exactly at
the cycle instants ``t[k] = t0 + k dt``; its first row is the first waypoint and its last row the
last waypoint, exactly (bit for bit). Each segment is a whole number of cycles long, so every
waypoint is reached exactly on a cycle.

Errors. Bad arguments raise :class:`mrnea.errors.StateError` naming the argument.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import ruckig
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import StateError, quote
from mrnea.resources import require_memory
from mrnea.validate import real, time_step

__all__ = ["cycles", "quintic", "scurve", "trapezoidal"]

#: A normalised profile s(u), u = time / segment duration in [0, 1], s(0) = 0, s(1) = 1.
Shape = Callable[[NDArray], NDArray]
#: A segment's timing: (dq, vmax, amax) -> (shortest duration T [s], its profile s).
Segment = Callable[[NDArray, NDArray, NDArray], tuple[float, Shape]]

#: A duration within this fraction of a cycle above a whole number of cycles is rounded down to
#: it (guards against ``2.0 / 0.01 = 200.00000000000003``-style rounding adding a cycle).
CYCLE_TOL = 1e-9
MAX_CYCLES = 1e9  # cycles in one program (at 1 ms, 11.6 days)
#: Peak memory of making a path, per cycle and per (joint + 1) [bytes]: the path itself, its
#: pieces before they are joined, and a segment's temporaries (measured: tests/test_resources.py).
PATH_BYTES = 48

# Quintic rest-to-rest s(u) = 10u³ - 15u⁴ + 6u⁵: peak ds/du at u = 1/2 and peak |d²s/du²| at
# u = 1/2 ± √3/6.
#: How far beyond what binds within a jerk-limited move's time scale its limits are kept
#: (:func:`_scurve_timing`): velocity x1e8, acceleration x1e16, jerk x1e24.
SCURVE_REACH = 1e8
QUINTIC_PEAK_VELOCITY = 15.0 / 8.0
QUINTIC_PEAK_ACCELERATION = 10.0 / math.sqrt(3.0)


# --- argument checks ------------------------------------------------------------------------


def _numbers(x: object, name: str, what: str = "a number or numeric array"
             ) -> NDArray[np.float64]:
    """``x`` as a float64 array if it holds real numbers (not strings, booleans or complex)."""
    try:
        a = np.asarray(x)
    except (TypeError, ValueError):  # ragged nesting
        a = np.asarray(None)
    if a.dtype.kind not in "iuf":
        raise StateError(f"{name}: expected {what}, got {type(x).__name__} {quote(x)}")
    return a.astype(np.float64)


def _t0(t0: object) -> float:
    value = real(t0, "t0")
    if not math.isfinite(value):
        raise StateError(f"t0: must be finite, got {value}")
    return value


def _waypoints(waypoints: ArrayLike) -> NDArray[np.float64]:
    w = _numbers(waypoints, "waypoints", "a numeric (W, n) array")
    if w.ndim != 2 or w.shape[0] < 1 or w.shape[1] < 1:
        raise StateError(f"waypoints: expected shape (W, n) with W >= 1 waypoints of n >= 1 "
                         f"joints, got {w.shape}")
    if not np.isfinite(w).all():
        bad = np.argwhere(~np.isfinite(w))[0]
        raise StateError(f"waypoints: NaN or inf at waypoint {bad[0]}, joint {bad[1]}")
    return w


def _per_item(x: ArrayLike, size: int, name: str, item: str) -> NDArray[np.float64]:
    """A scalar (repeated) or ``size`` values, one per ``item``, as a (size,) float array."""
    a = _numbers(x, name)
    if a.ndim == 0:
        a = np.full(size, float(a))
    if a.shape != (size,):
        raise StateError(f"{name}: expected a scalar or {size} values (one per {item}), got "
                         f"shape {a.shape}")
    return a


def _limit(x: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    """A per-joint limit, (n,) or scalar, each > 0 (inf = unlimited)."""
    a = _per_item(x, n, name, "joint")
    bad = np.isnan(a) | ~(a > 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise StateError(f"{name}: must be > 0 for every joint (inf = unlimited), joint {i} "
                         f"has {a[i]}")
    return a


def _dwell(dwell: ArrayLike, W: int) -> NDArray[np.float64]:
    d = _per_item(dwell, W, "dwell", "waypoint")
    bad = ~np.isfinite(d) | (d < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise StateError(f"dwell: must be finite and >= 0 s, waypoint {i} has {d[i]}")
    return d


def cycles(duration: float | NDArray, dt: float) -> NDArray[np.int64]:
    """Whole cycles covering a duration: ``ceil(duration / dt)``, to within :data:`CYCLE_TOL`.

    Parameters
    ----------
    duration : scalar or array of durations [s], >= 0.
    dt : interpolation cycle [s], already checked finite and > 0.

    Returns
    -------
    Number(s) of cycles, same shape as ``duration``.

    Raises
    ------
    StateError
        Beyond :data:`MAX_CYCLES` (a program that long is a mistake: a tiny dt or limit), or
        arguments that are not numbers.
    """
    dt = time_step(dt)
    k = np.ceil(_numbers(duration, "duration") / dt - CYCLE_TOL).clip(0)
    if not (np.all(np.isfinite(k)) and np.all(k <= MAX_CYCLES)):
        raise StateError(
            f"the program would take {np.max(k):.3g} cycles of dt = {dt:g} s "
            f"(more than {MAX_CYCLES:.0e}): check dt and the velocity and acceleration limits")
    return k.astype(np.int64)


def require_path_memory(K: float, n: int) -> None:
    """Refuse, before it is made, a path of ``K`` cycles of ``n`` joints that does not fit the
    memory budget (:func:`mrnea.resources.require_memory`).

    Raises
    ------
    StateError
        Saying how much memory the path needs and what to change.
    """
    require_memory(PATH_BYTES * float(K) * (n + 1),
                   f"a path of {float(K):.3g} cycles of {n} joint{'s' if n != 1 else ''}",
                   "use a coarser dt or a shorter program (fewer or closer waypoints, shorter "
                   "dwells, a shorter CSV path), or split it into several programs", StateError)


# --- normalised profiles s(u), u = time / segment duration in [0, 1] -------------------------


def _trapezoid_shape(u: NDArray, f: float) -> NDArray:
    """Rest-to-rest trapezoid in normalised time with acceleration fraction ``f`` in [0, 1/2].

    Velocity ds/du rises at constant rate for ``u < f``, is ``1 / (1 - f)`` while cruising and
    falls symmetrically for ``u > 1 - f``; ``f = 1/2`` is the triangle, ``f = 0`` constant speed.
    ``s(0) = 0`` and ``s(1) = 1`` exactly.
    """
    if f <= 0.0:
        return u.copy()
    v = 1.0 / (1.0 - f)
    a = v / f
    s = v * (u - 0.5 * f)
    s = np.where(u < f, 0.5 * a * u * u, s)
    return np.where(u > 1.0 - f, 1.0 - 0.5 * a * (1.0 - u) ** 2, s)


def _quintic_shape(u: NDArray) -> NDArray:
    """``10u³ - 15u⁴ + 6u⁵``: rest to rest, zero acceleration at both ends; s(1) = 1 exactly."""
    return u * u * u * (10.0 + u * (-15.0 + 6.0 * u))


def _trapezoid_timing(dq: NDArray, vmax: NDArray, amax: NDArray) -> tuple[float, float]:
    """(T, f): shortest duration [s] and acceleration fraction of a synchronised trapezoid.

    All joints follow ``q_i = q0_i + dq_i s(t)`` with one normalised profile s, so every joint
    has the same acceleration, cruise and deceleration phases. s must satisfy
    ``|ds/dt| <= 1 / tau_v`` with ``tau_v = max_i |dq_i| / v_i`` and ``|d²s/dt²| <= 1 / c`` with
    ``c = max_i |dq_i| / a_i``: the classic minimum-time trapezoid for s, which is
    ``T = tau_v + c / tau_v`` (cruise reached, ``ta = c / tau_v``) if ``tau_v² >= c``, else the
    triangle ``T = 2 sqrt(c)``. When one joint binds both limits (e.g. a single joint, or joints
    with proportional limits) T is exactly the longest single-joint time; in general it can be
    longer (one joint limited by speed, another by acceleration).
    """
    d = np.abs(dq)
    tau_v = float(np.max(d / vmax))
    c = float(np.max(d / amax))
    if tau_v * tau_v >= c:
        if tau_v == 0.0:
            return 0.0, 0.0
        T = tau_v + c / tau_v
        return T, (c / tau_v) / T
    return 2.0 * math.sqrt(c), 0.5


def _quintic_timing(dq: NDArray, vmax: NDArray, amax: NDArray) -> float:
    """Shortest duration [s] of a synchronised quintic: peak velocity 15/8 |dq|/T <= v and
    peak acceleration 10/√3 |dq|/T² <= a for every joint."""
    d = np.abs(dq)
    t_v = QUINTIC_PEAK_VELOCITY * float(np.max(d / vmax))
    t_a = math.sqrt(QUINTIC_PEAK_ACCELERATION * float(np.max(d / amax)))
    return max(t_v, t_a)


def _assemble(w: NDArray, dt: float, t0: float, dwell: NDArray, durations: list[float],
              shapes: list[Shape]) -> tuple[NDArray, NDArray]:
    """Concatenate the segments, each rounded up to whole cycles, plus the dwells."""
    n = w.shape[1]
    dwell_cycles = cycles(dwell, dt)
    Ns = [max(int(cycles(T, dt)), 1 if T > 0.0 else 0) for T in durations]
    K = 1 + float(np.sum(dwell_cycles, dtype=float)) + float(sum(Ns))
    if K > MAX_CYCLES:
        raise StateError(
            f"the program would take {K:.3g} cycles of dt = {dt:g} s (more than "
            f"{MAX_CYCLES:.0e}): check dt and the velocity and acceleration limits")
    require_path_memory(K, n)
    pieces = [w[:1]]
    if dwell_cycles[0]:
        pieces.append(np.broadcast_to(w[0], (int(dwell_cycles[0]), n)))
    for j, (N, shape) in enumerate(zip(Ns, shapes, strict=True)):
        if N:
            u = np.arange(1, N + 1, dtype=float) / N
            s = shape(u)[:, None]
            d = w[j + 1] - w[j]
            # Measured from the nearer end: exactly q0 at s = 0, q1 at s = 1 (q0 + s d may miss
            # it by an ulp) and a joint that does not move stays exactly where it is.
            pieces.append(np.where(s <= 0.5, w[j] + s * d, w[j + 1] - (1.0 - s) * d))
        if dwell_cycles[j + 1]:
            pieces.append(np.broadcast_to(w[j + 1], (int(dwell_cycles[j + 1]), n)))
    q = np.concatenate(pieces, axis=0)
    t = t0 + np.arange(q.shape[0], dtype=float) * dt
    return t, q


def _moving_check(dq: NDArray, T: float, j: int) -> None:
    if T == 0.0 and np.any(dq != 0.0):
        i = int(np.argmax(dq != 0.0))
        raise StateError(f"segment {j} (waypoint {j} -> {j + 1}): joint {i} moves but every "
                         "moving joint has infinite velocity and acceleration limits; give "
                         "at least one finite limit")


def _through_waypoints(
    waypoints: ArrayLike, dt: float, velocity_limit: ArrayLike, acceleration_limit: ArrayLike,
    t0: float, dwell: ArrayLike, segment: Segment,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Check the arguments, time each segment with ``segment(dq, vmax, amax) -> (T, s)``, sample."""
    dt = time_step(dt)
    t0 = _t0(t0)
    w = _waypoints(waypoints)
    W, n = w.shape
    vmax = _limit(velocity_limit, n, "velocity_limit")
    amax = _limit(acceleration_limit, n, "acceleration_limit")
    dw = _dwell(dwell, W)
    durations: list[float] = []
    shapes: list[Shape] = []
    for j in range(W - 1):
        dq = w[j + 1] - w[j]
        T, shape = segment(dq, vmax, amax)
        _moving_check(dq, T, j)
        durations.append(T)
        shapes.append(shape)
    return _assemble(w, dt, t0, dw, durations, shapes)


def trapezoidal(
    waypoints: ArrayLike,
    dt: float,
    velocity_limit: ArrayLike,
    acceleration_limit: ArrayLike,
    t0: float = 0.0,
    dwell: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rest-to-rest synchronised trapezoidal velocity profiles through waypoints.

    Every segment (waypoint j to j + 1) starts and ends at rest. All joints move along one
    normalised profile ``q(t) = q_j + (q_{j+1} - q_j) s(t)``, so they share the acceleration,
    cruise and deceleration phases and start and stop together; the joint that needs the longest
    time sets the duration and the others run scaled-down profiles. The duration is the
    shortest for which every joint stays within its limits (with a cruise phase if the cruise
    speed is reached, a triangular profile otherwise; with one joint: ``T = dq/v + v/a`` or
    ``T = 2 sqrt(dq/a)``). It is then rounded **up** to a whole number of cycles N and the
    profile is stretched in time to ``N dt`` (same phase fractions): velocities scale by
    ``T / (N dt) <= 1``, accelerations by its square, so the limits still hold, and each
    waypoint is reached exactly on a cycle.

    Parameters
    ----------
    waypoints : (W, n) joint positions [rad | m], W >= 1.
    dt : interpolation cycle [s], finite and > 0.
    velocity_limit : (n,) or scalar, > 0 [rad/s | m/s]; ``inf`` = unlimited.
    acceleration_limit : (n,) or scalar, > 0 [rad/s² | m/s²]; ``inf`` = unlimited (then the
        velocity jumps: a constant-speed segment). A moving joint needs at least one finite
        limit; a joint that does not move in a segment is unconstrained there.
    t0 : time of the first cycle [s].
    dwell : hold time at each waypoint [s], scalar (every waypoint, the first and last included)
        or (W,); rounded up to whole cycles.

    Returns
    -------
    t : (K,) cycle times ``t0 + k dt`` [s].
    q : (K, n) commanded positions; ``q[0]`` is the first waypoint, ``q[-1]`` the last, exactly.

    Raises
    ------
    StateError
        Bad shapes or values (non-finite waypoints, limits <= 0 or NaN, dt <= 0, ...).
    """

    def segment(dq: NDArray, vmax: NDArray, amax: NDArray) -> tuple[float, Shape]:
        T, f = _trapezoid_timing(dq, vmax, amax)
        return T, lambda u: _trapezoid_shape(u, f)

    return _through_waypoints(waypoints, dt, velocity_limit, acceleration_limit, t0, dwell,
                              segment)


def quintic(
    waypoints: ArrayLike,
    dt: float,
    velocity_limit: ArrayLike,
    acceleration_limit: ArrayLike,
    t0: float = 0.0,
    dwell: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rest-to-rest synchronised quintic polynomial segments through waypoints.

    Each segment is ``q(t) = q_j + (q_{j+1} - q_j) s(t / T)`` with
    ``s(u) = 10u³ - 15u⁴ + 6u⁵``: zero velocity and acceleration at both ends, peak velocity
    ``15/8 |dq| / T`` (at mid-segment) and peak acceleration ``10/√3 |dq| / T²``. T is the
    smallest whole number of cycles for which both peaks stay within every joint's limits.

    Parameters
    ----------
    waypoints, dt, velocity_limit, acceleration_limit, t0, dwell
        As for :func:`trapezoidal` (shapes, units; ``inf`` = unlimited, a moving joint needs at
        least one finite limit).

    Returns
    -------
    t, q : (K,) cycle times [s] and (K, n) commanded positions, as :func:`trapezoidal`'s.

    Raises
    ------
    StateError
        Bad shapes or values, as for :func:`trapezoidal`.
    """
    return _through_waypoints(
        waypoints, dt, velocity_limit, acceleration_limit, t0, dwell,
        lambda dq, vmax, amax: (_quintic_timing(dq, vmax, amax), _quintic_shape))


def _scurve_timing(dq: NDArray, vmax: NDArray, amax: NDArray, jmax: NDArray
                   ) -> tuple[float, Shape]:
    """(T, s): shortest duration [s] and normalised profile of a synchronised jerk-limited
    segment.

    Every joint follows ``q_i = q0_i + dq_i s(t)``, so joint i's velocity, acceleration and jerk
    are ``dq_i`` times those of s: s must keep within ``min_i v_i / |dq_i|``, and likewise for
    the acceleration and jerk (moving joints only). ruckig computes the time-optimal
    rest-to-rest profile of s from 0 to 1 within those limits (seven phases, or fewer where a
    limit is not reached); ``s(u) = p(u T)``, with s(1) = 1 exactly.
    """
    d = np.abs(dq)
    moving = d > 0.0
    if not moving.any():
        return 0.0, lambda u: np.ones_like(u)
    v, a, j = (float(np.min(lim[moving] / d[moving])) for lim in (vmax, amax, jmax))
    # ruckig overflows on limits far beyond any the move reaches (a jerk of 1e200, every limit
    # 1e100): each is capped at SCURVE_REACH times what binds within the move's time scale Ts
    # (the caps only lower limits the profile cannot use: the same profile but for phases
    # below ~1e-8 Ts), and a Ts far from 1 s is scaled out (ruckig then plans in t / Ts)
    Ts = max(1.0 / v, a ** -0.5, j ** (-1.0 / 3.0))
    v, a, j = (min(v, SCURVE_REACH / Ts), min(a, SCURVE_REACH ** 2 / Ts ** 2),
               min(j, SCURVE_REACH ** 3 / Ts ** 3))
    c = Ts if not 1e-3 <= Ts <= 1e3 else 1.0
    inp = ruckig.InputParameter(1)
    inp.current_position, inp.target_position = [0.0], [1.0]
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = [v * c], [a * c ** 2], [j * c ** 3]
    traj = ruckig.Trajectory(1)
    result = ruckig.Ruckig(1).calculate(inp, traj)
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        raise StateError(f"ruckig found no jerk-limited profile ({result.name}) for a move of "
                         f"{dq.tolist()} within the limits")
    T_c = float(traj.duration)  # in t / c
    T = T_c * c

    def shape(u: NDArray) -> NDArray:
        s = np.array([traj.at_time(x * T_c)[0][0] for x in u.tolist()])
        return np.where(u >= 1.0, 1.0, s)

    return T, shape


def scurve(
    waypoints: ArrayLike,
    dt: float,
    velocity_limit: ArrayLike,
    acceleration_limit: ArrayLike,
    jerk_limit: ArrayLike,
    t0: float = 0.0,
    dwell: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rest-to-rest synchronised jerk-limited (S-curve) segments through waypoints.

    Each segment is ``q(t) = q_j + (q_{j+1} - q_j) s(t)``: every joint moves along one
    normalised profile s, so the joints start and stop together and the path is a straight
    line in joint space (phase synchronisation). s is the time-optimal rest-to-rest profile with
    limited velocity, acceleration and jerk (zero velocity and acceleration at both ends), which
    ruckig computes; its limits are the tightest of the joints' own divided by their distances,
    so no joint exceeds any of its limits. With one joint and every limit reached (``v >= a²/j``
    and ``|dq| >= v (v/a + a/j)``) the duration is ``|dq|/v + v/a + a/j``. It is never shorter
    than :func:`trapezoidal`'s with the same velocity and acceleration limits. The duration is
    rounded **up** to a whole number of cycles N and the profile stretched in time to ``N dt``:
    velocities scale by ``T / (N dt) <= 1``, accelerations by its square and jerks by its cube,
    so the limits still hold and each waypoint is reached exactly on a cycle.

    (ruckig's own multi-joint phase synchronisation, ``Synchronization.Phase``, takes the
    slowest joint's profile and scales it to the others; where that breaks another joint's
    limit it falls back to time synchronisation, whose path is no straight line. Posing the
    problem for s gives the same profile where ruckig's is phase synchronised, and a phase
    synchronised one always. Its intermediate-waypoint mode needs ruckig's cloud service: each
    segment here is a rest-to-rest move of its own.)

    Parameters
    ----------
    waypoints, dt, velocity_limit, acceleration_limit, t0, dwell
        As for :func:`trapezoidal` (shapes, units; ``inf`` = unlimited).
    jerk_limit : (n,) or scalar, finite and > 0 [rad/s³ | m/s³].

    Returns
    -------
    t, q : (K,) cycle times [s] and (K, n) commanded positions, as :func:`trapezoidal`'s.

    Raises
    ------
    StateError
        Bad shapes or values, as for :func:`trapezoidal`; a jerk limit that is not finite.
    """
    n = _waypoints(waypoints).shape[1]
    jmax = _limit(jerk_limit, n, "jerk_limit")
    if not np.isfinite(jmax).all():
        i = int(np.argmax(~np.isfinite(jmax)))
        raise StateError(f"jerk_limit: must be finite for every joint, joint {i} has {jmax[i]}")
    return _through_waypoints(
        waypoints, dt, velocity_limit, acceleration_limit, t0, dwell,
        lambda dq, vmax, amax: _scurve_timing(dq, vmax, amax, jmax))
