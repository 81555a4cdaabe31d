"""Time-optimal path speed with TOPP-RA under mrnea's full actuator model (docs/retime.md).

Usage: ``sd, log = toppra_profile(pc, lim, dt)``: the path speed at every grid point of a moving
piece, rest to rest; ``s_t = sample_profile(pc.s, sd, dt, n)``: its path positions at the cycles.

TOPP-RA (Pham and Pham 2018, the ``toppra`` package) solves the time-optimal problem for
constraints linear in (sdd, sd^2) per grid point. Those come from :mod:`mrnea.retime.rows`
(precomputed arrays: toppra calls no Python function per grid point). Without viscous friction
and torque-speed curves one solve is exact. Otherwise the speed-dependent terms are linearised
on the safe side at a previous profile and the problem solved again (:func:`toppra_profile`).
The interpolation discretisation (constraints at both ends of each interval) is used: with
collocation the Puma 560's first verification overshot so far that the margin fell from 0.98
to 0.5 in one step. The solver is toppra's ``seidel`` (its 2-D LP), the one it ships compiled.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linprog  # here, not on the first stall: 1-2 s (the stop bound)
from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate

from mrnea.errors import RetimeError
from mrnea.retime.path import PathCoefficients
from mrnea.retime.rows import (
    Limits,
    acceleration_rows,
    constraint_rows,
    holdable,
    speed_lag,
    steady_speed,
    utilisation,
    velocity_cap,
)
from mrnea.trajectory import require_path_memory

ROUNDS = 8  # linearisation rounds at most
TOL = 0.002  # rounds stop when the duration changes by less than this fraction
LAG_TOL = 1.001  # a round is accepted when, with its own speed lag, it is within margin x this
REVERSAL_CYCLES = 1  # Coulomb friction both ways this many cycles before a change of direction
STALL = 1e-6  # an interior grid point with x = sd^2 below this fraction of the largest stalls ...
STALL_HEIGHT = 1e-3  # ... if its controllable set reaches above this fraction (_solve) ...
STALL_COST = 1e-3  # ... and the stall costs more than this fraction of the profile's duration
START = 1e-5  # the rest at the start must be in the first controllable set to this (toppra's)
STALL_REPAIRS = 20  # re-solves with capped x to repair stalls, at most (a stall near a via
#                    point can move one grid point back per repair: 2-3 re-solves measured)


def _stage_rows(s: NDArray, rows: tuple[NDArray, NDArray, NDArray], xmax: NDArray,
                stage: tuple[NDArray, NDArray, NDArray] | None) -> tuple:
    """``A u + B x + C <= 0`` per grid point in toppra's interpolation form (each stage i holds
    point i's rows and point i + 1's in terms of (u, x_i): toppra's
    ``canlinear_colloc_to_interpolate``), optional rows already per stage (which must not be
    paired up again), every row scaled to a unit normal in (u, x), and the bounds ``[0, xmax]``
    on x: (A, B, C, xb)."""
    m = rows[0].shape[1]
    A, B, C, *_ = canlinear_colloc_to_interpolate(*rows, np.eye(m), np.zeros(m), None, None,
                                                   s, identical=True)
    if stage is not None:
        A, B, C = (np.concatenate([X, Y], axis=1) for X, Y in zip((A, B, C), stage,
                                                                 strict=True))
    # unit normals: toppra's seidel bounded each 1-D subproblem by +-1e10 in the line's
    # parameter, so a row with a short (a, b) lost its box bounds; the compiled passes keep the
    # scaling, which also keeps their tolerances relative
    norm = np.hypot(A, B)
    tiny = norm < 1e-12
    norm = np.where(tiny, 1.0, norm)
    A, B = np.where(tiny, 0.0, A / norm), np.where(tiny, 0.0, B / norm)
    C = np.where(tiny, np.where(C <= 0, -1.0, 1.0), C / norm)
    return A, B, C, np.stack([np.zeros_like(xmax), xmax], axis=1)


def _solve(s: NDArray, rows: tuple[NDArray, NDArray, NDArray], xmax: NDArray,
           stage: tuple[NDArray, NDArray, NDArray] | None) -> tuple[NDArray, int, tuple]:
    """TOPP-RA rest to rest: the path speed sd at every grid point s, with no stall (below),
    the number of stall repairs (caps applied, over all re-solves) and the stage rows
    ``(A, B, C)`` it solved (:func:`_stage_rows`).

    TOPP-RA's forward pass takes the largest path acceleration from the largest controllable
    x_i = sd_i^2; that is time-optimal only while a larger x_i never lowers the largest
    reachable x_i+1. With the interpolation scheme it can: a row of point i + 1 in stage i,
    ``A (x_i+1 - x_i) / (2 ds) + B x_i + C <= 0``, has the coefficient ``B - A / (2 ds)`` of
    x_i, positive where q_s -> 0 towards a rest with little effort to spare, so from the top of
    the controllable set only x_i+1 = 0 is left: the path **stalls** one grid point early and
    the last interval takes 2 ds / sd_i with sd_i ~ 1e-4 (measured: the Puma 560 with 15 kg
    stopping at home, 5.87 s for 0.3 mrad; 10.5 s in all where 4.8 s is possible). A stall at
    an interior point i (x_i ~ 0 while its controllable set reaches higher) that costs time
    (its two intervals, at the top of its controllable set, would be faster by more than
    :data:`STALL_COST` of the duration: stalls at a via point between fast neighbours cost
    nothing, and repairing them made the Puma's quintic 4 times slower to plan) is repaired by
    capping x_i-1 at the largest value from which stage i - 1 reaches the highest x_i it can
    (a 2-variable LP) and solving again, at most :data:`STALL_REPAIRS` times. The highest
    reachable x_i is a concave function of x_i-1 (the maximum over a slice of a polygon), so
    below the cap it never falls as x_i-1 rises: there the greedy choice is optimal again.
    """
    repaired, attempts = 0, 0
    while True:
        A, B, C, xb = _stage_rows(s, rows, xmax, stage)
        x, K = topp_ra(s, A, B, C, xb)
        sd = np.sqrt(x)
        i = 1 + np.flatnonzero((x[1:-1] <= STALL * x.max())
                               & (K[1:-1, 1] > STALL_HEIGHT * x.max()))
        # what each costs: its two intervals' time now and at the top of its controllable set
        with np.errstate(divide="ignore"):
            now = (2 * (s[i] - s[i - 1]) / (sd[i - 1] + sd[i])
                   + 2 * (s[i + 1] - s[i]) / (sd[i] + sd[i + 1]))
        top = np.sqrt(K[i, 1])
        best = (2 * (s[i] - s[i - 1]) / (sd[i - 1] + top)
                + 2 * (s[i + 1] - s[i]) / (top + sd[i + 1]))
        stalls = i[now - best > STALL_COST * duration_of(s, sd)]
        if stalls.size == 0 or attempts == STALL_REPAIRS:
            return sd, repaired, (A, B, C)
        attempts, repaired = attempts + 1, repaired + stalls.size
        xmax = xmax.copy()
        for i in stalls:
            xmax[i - 1] = min(xmax[i - 1], _unstall(A[i - 1], B[i - 1], C[i - 1],
                                                    s[i] - s[i - 1], K[i - 1], K[i]))


def topp_ra(s: NDArray, A: NDArray, B: NDArray, C: NDArray, xb: NDArray
            ) -> tuple[NDArray, NDArray]:
    """TOPP-RA from rest to rest on the grid s (N + 1,) for stage rows ``A u + B x + C <= 0``
    (N + 1, m) in the interpolation form and bounds ``xb`` (N + 1, 2) on x = sd^2: (x (N + 1,),
    the controllable sets K (N + 1, 2)), by the compiled passes of :mod:`mrnea.kernels.topp`
    (the same algorithm as toppra's ``TOPPRA`` with its ``seidel`` solver, each stage's LP in
    closed form: tests/test_retime_margin.py checks them against each other).

    Raises
    ------
    RetimeError
        The path is not controllable from rest to rest, or the forward pass fails.
    """
    from mrnea.kernels.topp import controllable_sets, forward_pass

    A, B, C = (np.ascontiguousarray(X, dtype=float) for X in (A, B, C))
    d = np.ascontiguousarray(np.diff(s), dtype=float)
    K = np.empty((s.size, 2))
    xs = np.empty(s.size)
    lo, hi = (np.ascontiguousarray(xb[:, c], dtype=float) for c in (0, 1))
    if (controllable_sets(A, B, C, lo, hi, d, K) >= 0 or K[0, 0] > START
            or forward_pass(A, B, C, d, K, xs) >= 0):
        raise RetimeError("TOPP-RA found no parameterisation of the path from rest to "
                          "rest within the limits")
    return xs, K


def _unstall(A: NDArray, B: NDArray, C: NDArray, ds: float, Kj: NDArray, Ki: NDArray
             ) -> float:
    """The largest x_j in Kj from which stage j (rows ``A u + B x_j + C <= 0``, u = (x_i -
    x_j) / (2 ds)) reaches the highest x_i in Ki it can: two LPs in (x_j, x_i)."""
    G = np.stack([B - A / (2 * ds), A / (2 * ds)], axis=1)  # G (x_j, x_i) <= -C
    bounds = [(Kj[0], Kj[1]), (Ki[0], Ki[1])]
    top = linprog([0.0, -1.0], A_ub=G, b_ub=-C, bounds=bounds)
    if top.status != 0:
        return float(Kj[1])
    bounds[1] = (min(top.x[1] * (1 - 1e-6), Ki[1]), Ki[1])
    cap = linprog([-1.0, 0.0], A_ub=G, b_ub=-C, bounds=bounds)
    return float(cap.x[0]) if cap.status == 0 else float(top.x[0])


def near_reversals(pc: PathCoefficients, sd: NDArray, dt: float) -> PathCoefficients:
    """``pc`` with the direction of Coulomb friction unknown (``sign`` NaN: friction taken on
    both sides) wherever a joint is within :data:`REVERSAL_CYCLES` cycles of dt [s] before it
    reverses or starts from rest, on the clock of the profile sd.

    A cycle takes the Coulomb friction of the velocity it makes, the next one
    (kernels/drive_solve.py), so the cycle that contains a reversal already brakes against
    the new direction's friction while its effort is still the old direction's. ``sd`` must
    be at least as fast as the profile planned with the result (the relaxation is): a slower
    profile takes longer from a point to a reversal, so it stays within the marked points.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        tg = np.concatenate([[0.0], np.cumsum(2 * np.diff(pc.s) / (sd[1:] + sd[:-1]))])
    sgn = np.sign(pc.qs)
    # joint i reverses or starts over interval g (a stop needs nothing: at rest static friction
    # takes its share of the effort, never more than sliding friction against the motion)
    g, i = np.nonzero((sgn[1:] != sgn[:-1]) & (sgn[1:] != 0))
    if g.size == 0 or not np.all(np.isfinite(tg)):
        return pc
    w = REVERSAL_CYCLES * dt
    lo = np.searchsorted(tg, tg[g] - w, side="left")
    hi = np.searchsorted(tg, tg[g + 1], side="right")
    mark = np.zeros((pc.s.size + 1, pc.qs.shape[1]), dtype=np.int64)
    np.add.at(mark, (lo, i), 1)
    np.add.at(mark, (hi, i), -1)
    near = np.cumsum(mark, axis=0)[:-1] > 0
    return replace(pc, sign=np.where(near, np.nan, pc.sign))


def duration_of(s: NDArray, sd: NDArray) -> float:
    """Duration [s] of a profile with constant sdd between grid points: sum 2 ds / (sd_i +
    sd_i+1)."""
    with np.errstate(divide="ignore"):
        return float(np.sum(2 * np.diff(s) / (sd[1:] + sd[:-1])))


def toppra_profile(pc: PathCoefficients, lim: Limits, dt: float = 0.0,
                   checkpoint: Callable[[], None] | None = None,
                   rows_out: list | None = None) -> tuple[NDArray, dict[str, Any]]:
    """The time-optimal path speed sd (N + 1,) of a piece under the full actuator model.

    Without viscous friction and torque-speed curves one solve is exact. Otherwise: a relaxed
    solve (peak efforts, no viscous friction, joint speeds below :func:`steady_speed`) gives the
    first linearisation point, which is not safe; each round linearises the speed-dependent terms
    at the last profile, lowered where the robot could not even hold still under that
    linearisation (:func:`holdable`), and solves again. Every round's profile satisfies the true
    constraints at the grid points (rows.py), and TOPP-RA returns the pointwise largest feasible
    profile, which the last one is: a round is never slower than the one before (except where
    ``holdable`` lowered the point). The effort limit is taken at the speed the simulation at
    ``dt`` uses (:func:`speed_lag`, from the previous round; the running maximum from the third
    round on); a round counts only if, with its own lag, it is within the planning limits to
    :data:`LAG_TOL`. Rounds stop when the duration is within :data:`TOL` of the linearisation
    point's, after at most :data:`ROUNDS`.

    Returns the fastest accepted profile and a log: ``safe`` (the duration of each round's
    profile [s]), ``relaxed`` (the relaxation's), ``solver_time`` [s] (TOPP-RA alone),
    ``solver_failures`` (rounds seidel failed; the last good profile is kept),
    ``stalls_repaired`` (grid points where TOPP-RA's forward pass stalled, :func:`_solve`).
    ``checkpoint`` is called before each solve (:func:`mrnea.retime`). ``rows_out``, if given,
    receives the stage rows ``(A, B, C)`` the returned profile was solved with (the jerk-limited
    profile of :mod:`mrnea.retime.jerk` keeps to them).
    """
    vcap = velocity_cap(pc, lim)
    stage = acceleration_rows(pc, lim)
    log: dict[str, Any] = {"safe": [], "solver_time": 0.0, "solver_failures": 0,
                           "stalls_repaired": 0}
    solved: list[tuple[NDArray, tuple]] = []  # each profile solved and its stage rows

    def solve(rows: tuple[NDArray, NDArray, NDArray], xmax: NDArray) -> NDArray:
        if checkpoint is not None:
            checkpoint()
        t0 = time.perf_counter()
        try:
            sd, repaired, stage_rows = _solve(pc.s, rows, xmax, stage)
            solved.append((sd, stage_rows))
            log["stalls_repaired"] += repaired
            return sd
        finally:
            log["solver_time"] += time.perf_counter() - t0

    coulomb = dt > 0 and np.any(lim.robot.coulomb_friction)
    if not np.any(lim.fv) and np.all(np.isinf(lim.corner)):
        sd = solve(constraint_rows(pc, lim, None), vcap)  # nothing depends on speed: exact
        if coulomb:  # exact again with friction both ways near the reversals
            sd = solve(constraint_rows(near_reversals(pc, sd, dt), lim, None), vcap)
        log["safe"].append(duration_of(pc.s, sd))
        if rows_out is not None:
            rows_out.append(next(r for p, r in solved if p is sd))
        return sd, log
    with np.errstate(divide="ignore"):
        cap = np.min(steady_speed(lim) / np.abs(pc.qs), axis=1) ** 2
    sd = solve(constraint_rows(pc, lim, None), np.minimum(vcap, cap))
    t_lin = log["relaxed"] = duration_of(pc.s, sd)
    if coulomb:
        pc = near_reversals(pc, sd, dt)
    best, t_best = None, math.inf
    lag = np.zeros_like(pc.qs)
    if np.all(np.isinf(lim.corner)):
        dt = 0.0  # constant limits: the speed the limit is taken at does not matter
    for k in range(ROUNDS):
        new_lag = speed_lag(pc, sd, dt) if dt > 0 else lag
        lag = new_lag if k < 2 else np.maximum(lag, new_lag)
        try:
            sd = solve(constraint_rows(pc, lim, holdable(pc, lim, sd, lag), lag), vcap)
        except RetimeError:  # seidel's numerics (docs/retime.md): keep the last good profile
            if best is None:
                raise
            log["solver_failures"] += 1
            break
        t = duration_of(pc.s, sd)
        log["safe"].append(t)
        consistent = dt == 0 or bool(np.all(utilisation(pc, lim, sd, dt)
                                            <= np.ravel(lim.margin) * LAG_TOL))
        if t < t_best and consistent:
            best, t_best = sd, t
        if abs(t - t_lin) < TOL * t and consistent:
            break
        t_lin = t
    sd = sd if best is None else best
    if rows_out is not None:
        rows_out.append(next(r for p, r in solved if p is sd))
    return sd, log


def sample_profile(s: NDArray, sd: NDArray, dt: float, n: int) -> NDArray:
    """Path positions s(t_k) at t_k = k dt of a profile with constant sdd between grid points
    (toppra's ``ParametrizeConstAccel``, vectorised; toppra's spline parametrizer is what its
    issue #150 blames for retimed paths that exceed their limits). The last sample is the path's
    end, at the first t_k >= the profile's duration. The rows of n joints they become must fit
    the memory budget (:func:`mrnea.trajectory.require_path_memory`)."""
    dt_i = 2 * np.diff(s) / (sd[1:] + sd[:-1])
    if not np.all(np.isfinite(dt_i)):
        raise RetimeError("the time-optimal profile stops between two grid points")
    tg = np.concatenate([[0.0], np.cumsum(dt_i)])
    u = (sd[1:] ** 2 - sd[:-1] ** 2) / (2 * np.diff(s))
    M = math.ceil(tg[-1] / dt - 1e-9) + 1
    require_path_memory(M, n)
    t = np.arange(M) * dt
    i = np.clip(np.searchsorted(tg, t, side="right") - 1, 0, s.size - 2)
    tau = t - tg[i]
    out = s[i] + sd[i] * tau + 0.5 * u[i] * tau ** 2
    out = np.clip(np.maximum.accumulate(np.minimum(out, s[i + 1])), s[0], s[-1])
    out[-1] = s[-1]
    return out
