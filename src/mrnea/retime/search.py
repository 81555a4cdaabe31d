"""The toppra method's margin search: plan at a margin, hold the plan at the cycle resolution,
verify by simulation, and find the highest margin that verifies (docs/retime.md, "Margin and
verification").

Usage: ``best = search(job, paths, margin, acc, logs)``: the fastest verified :class:`Plan`.

TOPP-RA's constraints hold at the grid points. The program, though, is its rows at dt, and the
simulation takes each cycle's effort at the row's state with the backward-difference velocity
and the acceleration to the next velocity (:func:`mrnea.actuators.program_requirement`, the
program's own requirement). A plan at margin m is therefore checked where the cycle rule
evaluates the limits: every cycle's own requirement against m x its limit (and its velocity,
and its acceleration against an acceleration limit). Where a cycle exceeds them by the ratio
r, the planning limits of the grid points its rows span (the intervals from the row before to
the row after) are divided by 1 + :data:`OVERSHOOT` (r - 1) + :data:`SLACK` and the pieces solved
again, up to :data:`CYCLE_ROUNDS` times. The limits elsewhere keep m: a local correction, not a
global one. With jerk limits (:mod:`mrnea.retime.jerk`) the rows' jerks are checked the same
way and the jerk limits tightened on their own where a cycle exceeds them (tightening the
effort limits for a jerk excess made TOPP-RA infeasible where a pose needs most of its limit to
be held); a plan verifies only if its rows keep the jerk limits (:func:`within_jerk`).

Only then is the plan simulated. If the simulation still refuses it, the next margin comes from
the program's own requirement over the true limits (what the verdict reports as
``program_effort_ratio``), never from ``tau_required``, which includes the drive catching up
after it saturated (1.28-1.70 where the program itself needed 1.0004-1.05: issue 24). The
search then probes 0.1 % above the highest margin that verified and bisects between it and the
highest that failed, on a
lattice of :data:`LATTICE` so that every asked margin above a bracket lands on the same points,
until the bracket is narrower than :data:`SEARCH_TOL`; the fastest verified plan is returned.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.actuators import program_requirement
from mrnea.errors import NoTimingError
from mrnea.retime.jerk import jerk_profile, jerks, sample_smooth
from mrnea.retime.job import Job, accelerations
from mrnea.retime.path import piece_rows
from mrnea.retime.rows import Limits, static_check
from mrnea.simulate import SimulationResult

CYCLE_ROUNDS = 4  # re-solves with the limits tightened where a cycle exceeded them
OVERSHOOT = 2.0  # ... by this many times the excess (once the excess converged in 3-4 rounds:
#                  a tightened plan also moves the cycles next to the corrected ones)
SLACK = 1e-6  # ... by this much more than the cycle's excess (TOPP-RA's rows hold to ~1e-9:
#               tightened by the excess alone, a cycle crept down over 4 rounds to 1 + 5e-9)
SEARCH_TOL = 1e-3  # the margin search stops when hi / lo - 1 is below this
LATTICE = 2.5e-4  # bisection margins are multiples of this
MIN_MARGIN = 0.5  # the search gives up below this planning margin
CHUNK = 2000  # cycles of the own requirement per compiled call (a checkpoint between)


@dataclass
class Plan:
    """One margin's result: the assembled rows ``Q`` (M, n), wrench ``FE``/``PE``, each row's
    program instant ``clock`` (M,), the path speed per piece ``speeds``, the verifying
    simulation ``sim`` (None if not simulated), whether it verified ``ok``, and ``own``: the
    largest ratio of the program's own requirement to the true limits (effort at speed,
    velocity, acceleration limit, jerk limit)."""

    margin: float
    Q: NDArray
    FE: Any
    PE: NDArray | None
    clock: NDArray
    speeds: dict[int, NDArray]
    sim: SimulationResult | None
    ok: bool
    own: float
    rounds: int

    @property
    def rows(self) -> int:
        """M: the duration is (M - 1) dt, so the row count orders plans by duration."""
        return int(self.Q.shape[0])


def cycle_ratios(job: Job, Q: NDArray, FE: Any, PE: Any,
                 acc: NDArray | None) -> NDArray:
    """(M,) per cycle, the largest ratio over joints of the program's own requirement to its
    effort limit at speed (:func:`mrnea.actuators.program_requirement`), of the commanded
    velocity (backward difference) to the velocity limit and, with acceleration limits, of the
    acceleration (as the simulation forms it) to its limit. Unscaled: compare with the
    margin."""
    tau, lim = np.empty_like(Q), np.empty_like(Q)
    for a in range(0, Q.shape[0], CHUNK):  # a checkpoint between chunks (the stop bound)
        job.checkpoint()
        b = min(a + CHUNK, Q.shape[0])
        lo, hi = max(a - 1, 0), min(b + 1, Q.shape[0])  # the cycle rule's neighbours
        part = [validate.wrench_rows(X, slice(lo, hi)) for X in (FE, PE)]
        t, L = program_requirement(job.robot, Q[lo:hi], job.dt, *part)
        if lo < a:  # the chunk's first row starts from the row before it, not from rest
            t, L = t[1:], L[1:]
        tau[a:b], lim[a:b] = t[:b - a], L[:b - a]
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(lim > 0, np.abs(tau) / lim, np.where(tau != 0, np.inf, 0.0))
        v = np.abs(np.diff(Q, axis=0, prepend=Q[:1])) / job.dt / job.robot.velocity_limit
        r = np.maximum(r, np.nan_to_num(v))
        if acc is not None:
            r = np.maximum(r, np.abs(accelerations(Q, job.dt)) / acc)
    return r.max(axis=1)


def jerk_ratios(Q: NDArray, dt: float, jerk: NDArray | None) -> NDArray:
    """(M,) per cycle, the largest ratio over joints of the rows' jerk
    (:func:`mrnea.retime.jerk.jerks`, each third difference counted at both middle rows it
    spans) to the jerk limit (n,); zeros without one. Unscaled."""
    if jerk is None:
        return np.zeros(Q.shape[0])
    r = (np.abs(jerks(Q, dt)) / jerk).max(axis=1)
    return np.maximum(r[:-1], r[1:])


def _tighten(job: Job, paths: dict[int, tuple], local: dict[int, NDArray], clock: NDArray,
             over: NDArray) -> bool:
    """Multiply the planning limits of the grid points under each cycle that exceeded them
    (``over`` (M,) its ratio to the planning limit, > 1) by 1/ratio: the grid intervals from
    the cycle's row before to its row after. False if no moving piece holds such a cycle."""
    bad = np.flatnonzero(over > 1)
    lo = clock[np.maximum(bad - 1, 0)]
    hi = clock[np.minimum(bad + 1, clock.size - 1)]
    changed = False
    for j, (_, pc, _) in paths.items():
        t0 = job.clock[job.runs[j][1]]
        inside = (hi - t0 >= pc.s[0]) & (lo - t0 <= pc.s[-1])
        if not inside.any():
            continue
        need = np.ones(pc.s.size)
        i0 = np.clip(np.searchsorted(pc.s, lo[inside] - t0, side="right") - 1, 0, pc.s.size - 1)
        i1 = np.clip(np.searchsorted(pc.s, hi[inside] - t0, side="left"), 0, pc.s.size - 1)
        count = i1 - i0 + 1  # grid points i0..i1 of each cycle, flattened
        first = np.repeat(np.cumsum(count) - count, count)
        idx = np.repeat(i0, count) + np.arange(count.sum()) - first
        r = np.repeat(over[bad[inside]], count)
        np.maximum.at(need, idx, 1 + OVERSHOOT * (r - 1) + SLACK)
        local[j] = local[j] / need
        changed = True
    return changed


def _solve_all(job: Job, paths: dict[int, tuple], m: float, local: dict[int, NDArray],
               acc: NDArray | None, jerk: NDArray | None, jlocal: dict[int, NDArray],
               logs: list) -> tuple:
    """Every moving piece solved at margin m x its local factors, sampled at dt, assembled:
    (Q, FE, PE, clock, speeds). With jerk limits (n,) the time-optimal profile is the upper
    envelope of the jerk-limited one (:mod:`mrnea.retime.jerk`), planned at the margin x the
    jerk limits x their own local factors ``jlocal``."""
    from mrnea.retime.rows import velocity_cap
    from mrnea.retime.toppra import sample_profile, toppra_profile

    base = Limits.of(job.robot, m, acc)
    retimed, speeds = {}, {}
    for j, (spline, pc, need) in paths.items():
        k0, k1 = job.runs[j][1:]
        static_check(job.robot, need, job.clock[k0] + pc.s, m)
        lim = replace(base, margin=m * local[j][:, None]) if np.any(local[j] < 1) else base
        t0 = time.perf_counter()
        stage: list = []
        sd, log = toppra_profile(pc, lim, job.dt, job.checkpoint, stage)
        t1 = time.perf_counter()
        job.timings["toppra"] += log["solver_time"]
        job.timings["rows"] += t1 - t0 - log["solver_time"]
        if jerk is None:
            s_t = sample_profile(pc.s, sd, job.dt, job.robot.n)
        else:
            job.checkpoint()
            sd, sdd = jerk_profile(pc, spline(pc.s, 3), stage[0], velocity_cap(pc, lim), sd,
                                   (m * jlocal[j])[:, None] * jerk)
            s_t = sample_smooth(pc.s, sd, sdd, job.dt, job.robot.n)
            job.timings["jerk"] += time.perf_counter() - t1
            t1 = time.perf_counter()
        retimed[j] = piece_rows(spline, s_t, job.q[k0], job.q[k1])
        job.check_resolution(j, spline, *retimed[j], largest_acceleration(pc, sd))
        job.timings["sampling"] += time.perf_counter() - t1
        speeds[j] = sd
        logs.append({"margin": m, "piece": j, "grid": pc.s.size,
                     "tightened": int(np.sum(local[j] < 1)), **log})
    return (*job.assemble(retimed), speeds)


def largest_acceleration(pc: Any, sd: NDArray) -> NDArray:
    """(n,) the largest |qdd| = |q_s sdd + q_ss sd^2| [rad/s^2 | m/s^2] of a profile sd at the
    grid points, with the path acceleration of either adjacent interval."""
    x = sd ** 2
    u = np.diff(x) / (2 * np.diff(pc.s))
    return np.max([np.max(np.abs(pc.qs * uu[:, None] + pc.qss * x[:, None]), axis=0)
                   for uu in (np.append(u, u[-1]), np.insert(u, 0, u[0]))], axis=0)


def plan_at(job: Job, paths: dict[int, tuple], m: float, acc: NDArray | None,
            jerk: NDArray | None, logs: list) -> Plan:
    """The plan at margin m held at the cycle resolution (module docstring), verified."""
    local = {j: np.ones(pc.s.size) for j, (_, pc, _) in paths.items()}
    jlocal = {j: np.ones(pc.s.size) for j, (_, pc, _) in paths.items()}
    for rounds in range(CYCLE_ROUNDS + 1):
        Q, FE, PE, clock, speeds = _solve_all(job, paths, m, local, acc, jerk, jlocal, logs)
        t0 = time.perf_counter()
        over = cycle_ratios(job, Q, FE, PE, acc) / m
        overj = jerk_ratios(Q, job.dt, jerk) / m  # the jerk limits are tightened on their own
        job.timings["verification"] += time.perf_counter() - t0
        if max(over.max(), overj.max()) <= 1 or rounds == CYCLE_ROUNDS:
            break
        changed = [_tighten(job, paths, loc, clock, r) for loc, r in ((local, over),
                                                                       (jlocal, overj))]
        if not any(changed):
            break
    sim = job.verify(Q, FE, PE)
    acc_ok = acc is None or np.all(np.abs(accelerations(Q, job.dt)) <= acc)
    acc_ok = acc_ok and (jerk is None or within_jerk(Q, job.dt, jerk))
    # the program's own requirement over the true limits: the last round's, of this plan
    return Plan(m, Q, FE, PE, clock, speeds, sim, bool(sim.achievable and acc_ok),
                float(max(over.max(), overj.max()) * m), rounds)


def within_jerk(Q: NDArray, dt: float, jerk: NDArray) -> bool:
    """Whether the jerks of rows Q (:func:`mrnea.retime.jerk.jerks`) are within the limits
    (n,), to the rounding of a third difference: 8 x the rows' largest rounding error over
    dt^3 (the rows are written exactly, as their shortest reprs)."""
    tol = 8 * np.finfo(float).eps * np.max(np.abs(Q), axis=0) / dt ** 3
    return bool(np.all(np.abs(jerks(Q, dt)) <= jerk + tol))


def search(job: Job, paths: dict[int, tuple], margin: float, acc: NDArray | None,
           logs: list, jerk: NDArray | None = None) -> Plan:
    """The fastest verified plan at the highest margin <= ``margin`` that verifies, to
    :data:`SEARCH_TOL` (module docstring).

    Raises
    ------
    NoTimingError
        No margin down to :data:`MIN_MARGIN` verifies (quoting the last verdict).
    """
    first = plan_at(job, paths, margin, acc, jerk, logs)
    if first.ok:
        return first
    hi, best, last = first, None, first
    m = margin
    while best is None:  # step down by the program's own overshoot
        if m <= MIN_MARGIN:
            if last.sim.achievable:  # the simulation accepted it: a kinematic limit failed
                raise NoTimingError(f"no planning margin down to {MIN_MARGIN} gives a program "
                                  "whose rows keep the acceleration and jerk limits (the ends "
                                  "of the moving pieces: docs/retime.md, Jerk limits); give "
                                  "larger limits")
            raise NoTimingError(f"no planning margin down to {MIN_MARGIN} gives a program the "
                              f"simulation accepts; the last one: {last.sim.verdict()}")
        m = max(MIN_MARGIN, _lattice(m * min(1 - SEARCH_TOL, 1 / max(last.own, 1 + 1e-9))))
        last = plan_at(job, paths, m, acc, jerk, logs)
        if last.ok:
            best = last
        else:
            hi = last
    lo, probe = best, True
    while hi.margin / lo.margin - 1 > SEARCH_TOL:
        mid = _lattice(math.sqrt(hi.margin * lo.margin))
        if probe:  # the own requirement's step is usually right: probe just above it first
            mid, probe = min(mid, _lattice(lo.margin * (1 + SEARCH_TOL))), False
        if mid <= lo.margin or mid >= hi.margin:
            break
        p = plan_at(job, paths, mid, acc, jerk, logs)
        if p.ok:
            lo = p
            best = p if p.rows <= best.rows else best
        else:
            hi = p
    return best


def _lattice(m: float) -> float:
    """m rounded down to a multiple of :data:`LATTICE`."""
    return math.floor(m / LATTICE + 1e-9) * LATTICE

