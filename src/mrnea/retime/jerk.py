"""Jerk-limited path speed below the time-optimal one (docs/retime.md, "Jerk limits").

Usage: ``sd, sdd = jerk_profile(pc, q_sss, rows, xmax, sd_opt, jmax)``: the path speed and
acceleration at every grid point of a moving piece, rest to rest, whose joint jerks stay within
``jmax``; ``s_t = sample_smooth(pc.s, sd, sdd, dt, n)``: its path positions at the cycles, a
motion with continuous path acceleration; ``jerks(Q, dt)``: the jerks of written rows.

Along the path, with x = sd^2 a function of s (x' = 2 sdd, sd x'' / 2 = sddd), every joint jerk
is::

    q''' = q_s sddd + 3 q_ss sd sdd + q_sss sd^3 = sd (q_s x''/2 + 3 q_ss x'/2 + q_sss x)

linear in x but for the factor sd = sqrt(x). The problem is solved as a sequence of linear
programs in x at the grid points (HiGHS, ``scipy.optimize.linprog``): the factor is taken from
the previous solution (first: the time-optimal profile, the upper envelope ``sd_opt``), x'' and
x' by the three-point differences of the non-uniform grid, the dynamic limits as TOPP-RA's own
stage rows (the ones its last solve used: every effort, velocity and acceleration limit, on
the safe side), ``x <= sd_opt^2`` (no jerk-limited profile can be faster anywhere than the
time-optimal one, which is the pointwise largest feasible one), rest at both ends, and the
objective the largest ``sum x ds`` (the time-optimal profile maximises every x at once; with the
jerk rows this is the usual proxy, cf. Verscheure et al. 2009). Rounds stop when sd changes by
less than :data:`TOL` of its largest value.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.interpolate import BPoly
from scipy.optimize import linprog

from mrnea.errors import JerkLimitError, RetimeError
from mrnea.retime.job import accelerations
from mrnea.retime.path import PathCoefficients
from mrnea.trajectory import require_path_memory

ROUNDS = 24  # linear programs at most
TOL = 1e-3  # a round counts when it shortens the duration by this fraction
GROW = 0.25  # the trust region: sd may grow by this fraction of the best round's ...
FLOOR = 0.1  # ... plus this fraction (times GROW) of its largest value; halved after a round
#              without gain, until below MIN_GROW
MIN_GROW = 0.005


def _differences(s: NDArray) -> tuple[NDArray, NDArray]:
    """The three-point first and second derivative weights (N - 1, 3) at the interior points
    of a non-uniform grid s (N + 1,), on (x_i-1, x_i, x_i+1)."""
    hm, hp = np.diff(s)[:-1], np.diff(s)[1:]
    d1 = np.stack([-hp / (hm * (hm + hp)), (hp - hm) / (hm * hp), hm / (hp * (hm + hp))], 1)
    d2 = np.stack([2 / (hm * (hm + hp)), -2 / (hm * hp), 2 / (hp * (hm + hp))], 1)
    return d1, d2


def _stage_matrix(s: NDArray, rows: tuple[NDArray, NDArray, NDArray]) -> tuple:
    """TOPP-RA's stage rows ``A u + B x_i + C <= 0`` with u = (x_i+1 - x_i) / (2 ds_i), stages
    0..N-1, as a sparse matrix on x and its right-hand side."""
    A, B, C = (np.asarray(X, dtype=float)[:-1] for X in rows)
    N, m = A.shape
    d = np.diff(s)[:, None]
    keep = (A != 0) | (B != 0)
    if np.any(~keep & (C > 0)):
        raise RetimeError("TOPP-RA's rows admit no path speed at some grid point")
    i = np.broadcast_to(np.arange(N)[:, None], (N, m))[keep]
    k = np.arange(keep.sum())
    G = sparse.coo_matrix((np.concatenate([(B - A / (2 * d))[keep], (A / (2 * d))[keep]]),
                           (np.concatenate([k, k]), np.concatenate([i, i + 1]))),
                          shape=(k.size, N + 1))
    return G.tocsr(), -C[keep]


def _interval_accelerations(s: NDArray) -> sparse.csr_matrix:
    """(N + 2, N + 1): from x, the path acceleration u = (x_i+1 - x_i) / (2 ds_i) of each grid
    interval (TOPP-RA's), with u = 0 before the first and after the last (at rest)."""
    N = s.size - 1
    k = np.arange(N)
    g = 1 / (2 * np.diff(s))
    return sparse.coo_matrix((np.concatenate([-g, g]),
                              (np.tile(k + 1, 2), np.concatenate([k, k + 1]))),
                             shape=(N + 2, N + 1)).tocsr()


def _jerk_matrix(pc: PathCoefficients, q_sss: NDArray, sd_bar: NDArray, dt_bar: NDArray,
                 jmax: NDArray) -> sparse.csr_matrix:
    """Rows ``+-(joint jerk at grid point i) / jmax <= 1`` in x: the path jerk is the change of
    the intervals' path accelerations u from the middle of one to the middle of the next, over
    that time taken from the intervals' times dt_bar (N,), no longer than the true ones (on the
    safe side), and with
    sd = sd_bar, sdd the mean of the two u: ``q_s (u_i - u_i-1) / tau_i + 3 q_ss sd sdd +
    q_sss sd x``. At the ends the rest's u = 0 half an interval away. A sparse matrix
    (2 (N + 1) n, N + 1)."""
    U = _interval_accelerations(pc.s)
    diff, mean = U[1:] - U[:-1], (U[1:] + U[:-1]) / 2
    dt = np.concatenate([[0.0], dt_bar, [0.0]])
    tau = (dt[1:] + dt[:-1]) / 2
    out = [sparse.diags(pc.qs[:, j] / tau / jmax[:, j]) @ diff
           + sparse.diags(3 * pc.qss[:, j] * sd_bar / jmax[:, j]) @ mean
           + sparse.diags(q_sss[:, j] * sd_bar / jmax[:, j]) for j in range(pc.qs.shape[1])]
    J = sparse.vstack(out)
    return sparse.vstack([J, -J]).tocsr()


def _equilibrate(A: sparse.csr_matrix, b: NDArray) -> tuple[sparse.csr_matrix, NDArray]:
    """``A x <= b`` with every row divided by its largest |coefficient| (the same set of x).
    A small jerk limit (or a fine grid near a rest) gives jerk rows with coefficients beyond
    HiGHS's 1e15, which it refuses as a "Model error"; scaled, they solve, and any slack of the
    solver's tolerances is caught by the check of the written rows
    (:func:`mrnea.retime.search.within_jerk`)."""
    big = np.maximum(abs(A).max(axis=1).toarray().ravel(), 1e-300)
    return sparse.diags(1.0 / big) @ A, b / big


def _active(G: sparse.csr_matrix, h: NDArray, hi: NDArray) -> tuple:
    """The rows ``G x <= h`` that some x in the box [0, hi] can violate (the others never
    bind)."""
    worst = G.maximum(0) @ hi
    keep = worst > h
    return G[keep], h[keep]


def jerk_profile(pc: PathCoefficients, q_sss: NDArray, rows: tuple[NDArray, NDArray, NDArray],
                 xmax: NDArray, sd_opt: NDArray, jmax: NDArray) -> tuple[NDArray, NDArray]:
    """The jerk-limited path speed sd and acceleration sdd (N + 1,) of a moving piece at its
    grid points, rest to rest (module docstring).

    Parameters
    ----------
    pc : PathCoefficients
        The piece's grid ``s`` and path derivatives ``qs``, ``qss`` (N + 1, n).
    q_sss : (N + 1, n)
        d^3q/ds^3 at the grid points.
    rows : (A, B, C), each (N + 1, m)
        TOPP-RA's stage rows of the time-optimal solve (every dynamic limit, planning margin
        included).
    xmax : (N + 1,)
        The velocity limits' cap on x = sd^2.
    sd_opt : (N + 1,)
        The time-optimal path speed: the upper envelope.
    jmax : (N + 1, n)
        The planning jerk limits [rad/s^3 | m/s^3] at each grid point.

    Raises
    ------
    RetimeError
        A linear program has no solution (the rows admit no motion).
    """
    s = pc.s
    G, h = _stage_matrix(s, rows)
    hi = np.minimum(xmax, sd_opt ** 2)
    hi[0] = hi[-1] = 0.0
    G, h = _active(G, h, hi)
    ds = np.zeros(s.size)
    ds[:-1] += np.diff(s) / 2
    ds[1:] += np.diff(s) / 2
    sd_bar, sd, best = np.sqrt(hi), np.zeros(s.size), math.inf
    grow = GROW
    dt_bar = 2 * np.diff(s) / np.maximum(sd_bar[1:] + sd_bar[:-1], 1e-300)
    for _ in range(ROUNDS):
        if not sd_bar.max() > 0.0:  # the last solve's speed 0 everywhere: no motion fits
            raise _too_small(jmax, "its path speed is 0 everywhere")
        Jm = _jerk_matrix(pc, q_sss, sd_bar, dt_bar, jmax)
        # the duration sum ds / sd, linearised in x at sd_bar: weights ds / sd_bar^3
        w = ds / np.maximum(sd_bar, FLOOR * sd_bar.max()) ** 3
        A_ub, b_ub = _equilibrate(sparse.vstack([G, Jm]).tocsr(),
                                  np.concatenate([h, np.ones(Jm.shape[0])]))
        res = linprog(-w / w.max(), A_ub=A_ub, b_ub=b_ub,
                      bounds=np.stack([np.zeros_like(hi), sd_bar ** 2], 1), method="highs")
        if res.status != 0:  # x = 0 is feasible: only limits too small for HiGHS's tolerances
            raise _too_small(jmax, f"it has no solution at HiGHS's tolerances: {res.message}")
        new = np.sqrt(np.maximum(res.x, 0.0))
        try:
            T = float(np.sum(interval_times(s, new, _accelerations(s, new))))
        except RetimeError:  # it stalls at a point the trust region held down: let it grow
            T = math.inf
        if T < best * (1 - TOL) or not math.isfinite(best):
            sd, best = new, T
            times = interval_times(s, sd, _accelerations(s, sd)) if math.isfinite(T) else None
        else:  # no gain at this trust region: shrink it (the rows' time gets closer to true)
            grow /= 2
            if grow < MIN_GROW:
                break
        sd_bar = np.minimum(np.sqrt(hi), (1 + grow) * sd + grow * FLOOR * sd.max())
        # a profile below sd_bar takes at least these times (the trapezoid where the best one
        # stalls)
        trap = 2 * np.diff(s) / np.maximum(sd_bar[1:] + sd_bar[:-1], 1e-300)
        dt_bar = trap if times is None else np.minimum(trap, times / (1 + 2 * grow))
    if not math.isfinite(best):
        raise RetimeError("the jerk-limited path speed stops between two grid points")
    return sd, _accelerations(s, sd)


def _too_small(jmax: NDArray, why: str) -> JerkLimitError:
    """The error for jerk limits too small to plan a path with (``why``: what the linear
    program of the jerk-limited path speed gave)."""
    return JerkLimitError(
        f"too small to plan this path with (the smallest planning limit {jmax.min():.3g} "
        f"[rad/s^3 | m/s^3], the jerk limits times the planning margin; the linear program of "
        f"the jerk-limited path speed: {why}); give larger jerk limits")


def _accelerations(s: NDArray, sd: NDArray) -> NDArray:
    """sdd (N + 1,) at the grid points of a profile sd: the mean of the path accelerations of
    the intervals either side (:func:`_interval_accelerations`; 0 at the rests)."""
    u = _interval_accelerations(s) @ sd ** 2
    return (u[1:] + u[:-1]) / 2


def interval_times(s: NDArray, sd: NDArray, sdd: NDArray) -> NDArray:
    """(N,) the time of each grid interval for path speeds sd and accelerations sdd at its ends:
    the root of ``ds = dt (sd_i + sd_i+1)/2 + dt^2 (sdd_i - sdd_i+1)/12``, exact where sd is a
    quadratic in time (constant path jerk: from rest, s = j t^3/6; the trapezoidal rule,
    constant sdd, takes 2/3 of that first interval's time)."""
    d = np.diff(s)
    a = (sdd[:-1] - sdd[1:]) / 12
    b = (sd[:-1] + sd[1:]) / 2
    disc = b ** 2 + 4 * a * d
    with np.errstate(divide="ignore", invalid="ignore"):
        dt = np.where(disc >= 0, 2 * d / (b + np.sqrt(np.maximum(disc, 0.0))), d / b)
    if not np.all(np.isfinite(dt) & (dt > 0)):
        raise RetimeError("the jerk-limited profile stops between two grid points")
    return dt


def sample_smooth(s: NDArray, sd: NDArray, sdd: NDArray, dt: float, n: int) -> NDArray:
    """Path positions s(t_k) at t_k = k dt: the quintic through (s, sd, sdd) at each grid point
    (``scipy.interpolate.BPoly.from_derivatives``: continuous path acceleration, bounded path
    jerk) at the times of :func:`interval_times`. The last sample is the path's end, at the
    first t_k >= the profile's duration (n joints: the memory budget)."""
    tg = np.concatenate([[0.0], np.cumsum(interval_times(s, sd, sdd))])
    M = math.ceil(tg[-1] / dt - 1e-9) + 1
    require_path_memory(M, n)
    poly = BPoly.from_derivatives(tg, np.stack([s, sd, sdd], 1))
    out = poly(np.minimum(np.arange(M) * dt, tg[-1]))
    out = np.clip(np.maximum.accumulate(out), s[0], s[-1])
    out[-1] = s[-1]
    return out


def jerks(Q: NDArray, dt: float) -> NDArray:
    """(M + 1, n) the jerks of rows Q (M, n) at dt [rad/s^3 | m/s^3], at rest before the first
    row and after the last: the differences of the accelerations the simulation forms
    (:func:`mrnea.retime.job.accelerations`), the third differences of the rows over dt^3.
    Each is the average of a motion's jerk over three cycles (weighted by the quadratic
    B-spline), so a motion through the rows within a jerk limit gives rows within it."""
    a = accelerations(Q, dt)
    return np.diff(a, axis=0, prepend=np.zeros((1, Q.shape[1])),
                   append=np.zeros((1, Q.shape[1]))) / dt
