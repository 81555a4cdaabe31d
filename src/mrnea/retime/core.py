"""``mrnea.retime``: the same path, the fastest timing the robot can make, verified.

Usage: ``res = retime(robot, program, dt=None, method="toppra", margin=0.98)``; ``res.q_cmd``
(M, n) at ``res.dt``, ``res.simulation`` the verifying run (docs/retime.md).
"""

from __future__ import annotations

import numbers
import time
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import validate
from mrnea.actuators import actuator_mass_matrix_and_bias
from mrnea.errors import RetimeError, StateError
from mrnea.model import Robot
from mrnea.retime.job import Job
from mrnea.retime.path import grid_points, path_coefficients, piece_spline
from mrnea.retime.result import PhasePiece, RetimeResult
from mrnea.retime.rows import Limits, holding_need, motion_check, static_check
from mrnea.retime.scale import retime_scale

METHODS = {"toppra": "toppra", "scale": "scale"}
GRID = (200, 1000)  # default grid intervals per moving piece: half its rows, clipped to this
JERK_GRID = 600  # ... with jerk limits clipped to [this, GRID[1]] (docs/retime.md "Jerk limits")
#: The most grid intervals per moving piece ``grid`` takes: 10x the largest default (docs/retime.md,
#: "The grid"); beyond, toppra's per-point solves run for hours and the arrays outgrow memory.
MAX_GRID = 10_000


def retime(
    robot: Robot,
    program: Any,
    dt: float | None = None,
    method: Literal["toppra", "scale"] = "toppra",
    margin: float = 0.98,
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    *,
    acceleration_limit: ArrayLike | None = None,
    jerk_limit: ArrayLike | None = None,
    grid: int | None = None,
    mode: Literal["hybrid", "paper"] | None = None,
    checkpoint: Callable[[], None] | None = None,
) -> RetimeResult:
    """Retime a program: keep its path (the sequence of joint positions), change its timing to
    the fastest the robot can make, and verify the result by simulation.

    Parameters
    ----------
    robot : Robot
        With its actuator model: friction, rotor inertia, torque-speed curves, limits.
    program : Program, (t, q) pair, or (K, n) array
        A :class:`mrnea.io.program.Program` (its dt, wrench, point and mode are used unless given
        here), a ``(t, q)`` pair sampled at a constant step [s], [rad | m], or the rows (K, n)
        of a program whose cycle is ``dt``.
    dt : float, optional
        The retimed program's cycle [s]; default the program's. (For a bare array: its cycle.)
    method : ``"toppra"`` or ``"scale"``
        ``"toppra"``: time-optimal along the path (TOPP-RA, with viscous friction and
        torque-speed curves by safe tightening); ``"scale"``: uniform time scaling, the smallest
        factor the verification accepts, to 0.5 %.
    margin : float in (0, 1]
        toppra's planning margin: it plans against margin x every effort limit (at speed) and
        velocity limit; when the verifying simulation finds a limit exceeded, the margin shrinks
        and the path is solved again (down to 0.5). ``scale`` does not plan with it: its factor
        is the smallest the simulation accepts, and the result's ``margin`` is the largest
        fraction of a limit it uses.
    f_ext, f_ext_point : array_like, optional
        The wrench the end effector exerts on its environment, (6,) or (K, 6) [N, N m], base
        frame, on the program's clock, and its point in the last link's frame, (3,) or (K, 3)
        [m]. It moves with the path position when the timing changes.
    acceleration_limit : array_like, optional (keyword)
        Joint acceleration limits (n,) or one for all [rad/s^2 | m/s^2] (toppra; the robot
        model has none): the retimed program's accelerations, formed as the simulation forms
        them, stay within them.
    jerk_limit : array_like, optional (keyword)
        Joint jerk limits (n,) or one for all [rad/s^3 | m/s^3] (toppra): the fastest timing
        found whose joint jerks stay within them, below the time-optimal one and within every
        other limit (:mod:`mrnea.retime.jerk`, docs/retime.md "Jerk limits"); the rows' third
        differences over dt^3 (:func:`mrnea.retime.jerk.jerks`, the program at rest before and
        after) are within them, and planned at ``margin`` x them.
    grid : int, optional (keyword)
        Grid intervals per moving piece (default: half its rows, clipped to [200, 1000]; with
        ``jerk_limit`` to [600, 1000], docs/retime.md "Jerk limits").
    mode : ``"hybrid"`` or ``"paper"``, optional (keyword)
        The verifying simulation's mode; default the program's, else ``"hybrid"``.
    checkpoint : callable, optional (keyword)
        Called with no argument between the steps of the retiming (each piece's path
        coefficients, each TOPP-RA solve, each chunk of 2000 cycles of a verifying simulation:
        well under a second apart on the cases of docs/retime.md); an exception it raises
        (KeyboardInterrupt: the CLI's stop request) ends the retiming, which then returns
        nothing.

    Returns
    -------
    RetimeResult
        ``t``, ``q_cmd`` (M, n) at ``dt``, ``f_ext``, ``duration``, ``original_duration``,
        ``method``, ``margin``, ``achievable``, ``simulation``, the phase-plane data ``phase``,
        ``summary()``.

    Raises
    ------
    NoTimingError
        (a RetimeError) No timing exists: the path cannot be followed at any speed (a pose the
        robot cannot hold against gravity or the wrench: the message names the joint, the
        program instant and the ratio of need to limit), it leaves the position limits, or no
        margin down to 0.5 (no scale factor) gives a program the simulation accepts.
    RetimeError
        The program never moves, no limit binds, the cycle is too coarse for the path, or a
        dwell needs more than ``margin`` x its limit.
    StateError
        A bad argument.

    Notes
    -----
    A dwell (the robot held still, identical rows) stays a hold of the same duration; each
    moving piece between dwells is retimed from rest to rest. The import of ``mrnea.retime``
    costs nothing extra: scipy and toppra are imported on the first call.
    """
    method = validate.choice("method", method, METHODS)
    margin = validate.fraction(margin, "margin")
    job = Job.of(robot, program, dt, f_ext, f_ext_point, mode, checkpoint)
    acc = None
    if acceleration_limit is not None:
        acc = validate.per_joint(acceleration_limit, "acceleration_limit", robot.n)
        if not np.all(acc > 0):
            raise StateError(f"acceleration_limit: must be > 0, got {acc.tolist()}")
    jerk = None
    if jerk_limit is not None:
        jerk = validate.per_joint(jerk_limit, "jerk_limit", robot.n)
        if not np.all(jerk > 0):
            raise StateError(f"jerk_limit: must be > 0, got {jerk.tolist()}")
    if grid is not None and (isinstance(grid, bool) or not isinstance(grid, numbers.Integral)
                             or not 10 <= grid <= MAX_GRID):
        raise StateError(f"grid: expected an int >= 10 and <= {MAX_GRID}, got {grid!r}")
    for name, value in (("acceleration_limit", acc), ("jerk_limit", jerk)):
        if method == "scale" and value is not None:
            raise StateError(f"{name}: only method 'toppra' takes it")
    job.checkpoint()
    motion_check(robot, np.diff(job.q, axis=0), job.clock[:-1])
    _check_holds(job, margin if method == "toppra" else 1.0)
    job.checkpoint()
    if not job.moving:
        raise RetimeError("the program never moves: there is nothing to retime")
    if (acc is None and not np.isfinite(robot.effort_limit).any()
            and not np.isfinite(robot.velocity_limit).any()):
        raise RetimeError("no effort or velocity limit binds along this path: it can be made "
                          "arbitrarily fast (give the robot its limits)")
    if method == "scale":
        f, used, (Q, FE, PE, _, sim), log = retime_scale(job)
        paths = _pieces(job, grid, timed=False)
        phase = _phase(job, paths, {j: np.full(v[1].s.size, 1.0 / f) for j, v in paths.items()})
        return _result(job, Q, FE, PE, sim, "scale", used, phase, [log], f, log["estimate"])
    m, phase, Q, FE, PE, sim, logs = _retime_toppra(job, margin, acc, jerk, grid)
    return _result(job, Q, FE, PE, sim, "toppra", m, phase, logs, None, None, margin, jerk)


def _result(job: Job, Q: NDArray, FE: Any, PE: Any, sim: Any,
            method: str, margin: float, phase: tuple, log: list, factor: float | None,
            estimate: float | None, margin_asked: float | None = None,
            jerk: NDArray | None = None) -> RetimeResult:
    M = Q.shape[0]
    return RetimeResult(
        t=np.arange(M) * job.dt, q_cmd=Q, f_ext=FE, f_ext_point=PE, dt=job.dt, mode=job.mode,
        duration=(M - 1) * job.dt, original_duration=(job.K - 1) * job.program_dt,
        method=method, margin=float(margin), achievable=bool(sim.achievable), simulation=sim,
        factor=factor, estimate=estimate, phase=phase, original_q_cmd=job.q,
        original_dt=job.program_dt, original_f_ext=job.f_ext,
        original_f_ext_point=job.f_ext_point, log=log, timings=job.timings,
        margin_asked=margin_asked, jerk_limit=jerk)


HOLD_ROWS = 20_000
"""Rows of the dwells :func:`_check_holds` computes at a time: a stop request is taken between
them, and the memory stays bounded (the mass matrices come with the bias: 20,000 x n^2
values) however long the dwells are."""


def _check_holds(job: Job, margin: float) -> None:
    """A dwell the robot cannot hold (beyond what static friction takes): RetimeError."""
    rows = np.concatenate([np.arange(k0, k1 + 1) for kind, k0, k1 in job.runs
                           if kind == "hold"] or [np.zeros(0, dtype=int)])
    need = np.empty((rows.size, job.robot.n))
    for a in range(0, rows.size, HOLD_ROWS):
        job.checkpoint()
        part = rows[a:a + HOLD_ROWS]
        fe = validate.wrench_rows(job.f_ext, part)
        pe = validate.wrench_rows(job.f_ext_point, part)
        q = job.q[part]
        _, c = actuator_mass_matrix_and_bias(job.robot, q, np.zeros_like(q), fe, pe)
        need[a:a + HOLD_ROWS] = holding_need(job.robot, c, np.zeros_like(c),
                                             np.zeros(c.shape, dtype=bool))
    if rows.size:
        static_check(job.robot, need, job.clock[rows], margin)


def _piece(job: Job, j: int, s: NDArray | None, grid: int | None, lo: int = GRID[0]) -> tuple:
    """Moving piece j: (spline, path coefficients, holding need) on the grid ``s`` (None: its
    default grid, :func:`mrnea.retime.path.grid_points`, of ``grid`` intervals or half its rows
    clipped to [lo, GRID[1]])."""
    k0, k1 = job.runs[j][1:]
    qp = job.q[k0:k1 + 1]
    spline = piece_spline(qp, job.program_dt)
    if s is None:
        N = int(grid) if grid else int(np.clip(qp.shape[0] // 2, lo, GRID[1]))
        knots = np.arange(qp.shape[0]) * job.program_dt
        s = grid_points(knots, qp, N, spline(knots, 2))
    pc = path_coefficients(job.robot, spline, s, *job.wrench_at(job.clock[k0] + s))
    moving = (pc.qs != 0) | ~np.isfinite(pc.sign)
    return spline, pc, holding_need(job.robot, pc.c, pc.sign, moving)


def _pieces(job: Job, grid: int | None, timed: bool = True,
            lo: int = GRID[0]) -> dict[int, tuple]:
    """Every moving piece j: :func:`_piece` (``grid``, ``lo``); its time counts as the
    retiming's ``coefficients`` if ``timed``."""
    t0 = time.perf_counter()
    out = {}
    for j, _, _ in job.moving:
        job.checkpoint()
        out[j] = _piece(job, j, None, grid, lo)
    if timed:
        job.timings["coefficients"] += time.perf_counter() - t0
    return out


def _retime_toppra(job: Job, margin: float, acc: NDArray | None, jerk: NDArray | None,
                   grid: int | None) -> tuple:
    """The toppra method: every piece's path coefficients, then the margin search of
    :mod:`mrnea.retime.search` (TOPP-RA per piece, held at the cycle resolution, verified)."""
    from mrnea.retime.search import search

    # the jerk-limited profile loses most at the pieces' rests, less on a finer grid
    paths = _pieces(job, grid, lo=GRID[0] if jerk is None else JERK_GRID)
    logs: list[dict] = []
    best = search(job, paths, margin, acc, logs, jerk)
    return (best.margin, _phase(job, paths, best.speeds, acc), best.Q, best.FE, best.PE,
            best.sim, logs)


def _phase(job: Job, paths: dict[int, tuple], speeds: dict[int, NDArray],
           acc: NDArray | None = None) -> tuple[PhasePiece, ...]:
    """The phase-plane data of every moving piece: its grid, the retimed path speed ``speeds[j]``
    and what its limit curve at the true limits (margin 1) is computed from."""
    lim = Limits.of(job.robot, 1.0, acc)
    return tuple(PhasePiece(k0=job.runs[j][1], k1=job.runs[j][2],
                            t0=float(job.clock[job.runs[j][1]]), s=pc.s, sd=speeds[j],
                            coefficients=pc, limits=lim)
                 for j, (_, pc, _) in paths.items())
