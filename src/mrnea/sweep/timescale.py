"""A sweep's ``time_scale``: a program run slower or faster at the same cycle.

Usage: ``program_b = time_scaled(program, 2.0)`` (twice the duration). The grid's check
(:func:`mrnea.sweep.variants.check_grid`) scales each program at each of its scales before any
work, so that a scale a program cannot take is one error naming the grid entry.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.errors import MrneaError, StateError, quote
from mrnea.io.program import Program
from mrnea.resources import require_memory
from mrnea.retime.job import PATH_TOL

__all__ = ["time_scaled"]


def time_scaled(program: Program, factor: float) -> Program:
    """The program run ``factor`` times slower (2: twice the duration), at the same dt.

    The path between the cycles is the one whose velocity is linear between the program's own
    cycle-mean velocities ``(q[k+1] - q[k]) / dt`` (taken at the mid-cycle instants, held
    before the first and after the last): its acceleration between mid-cycles is exactly the
    program's second difference, so the scaled program's accelerations are weighted means of
    the original ones divided by factor^2, never above them (a cubic spline through a
    trapezoidal profile overshoots by 8-13 % at each acceleration step). The path passes
    through the first and last rows exactly and within dt^2 |a_k| / 8 of the others (its
    integral over cycle k is dt (w_{k-1} + 6 w_k + w_{k+1}) / 8, whose excess over
    q[k+1] - q[k] telescopes); between them it is within dt^2 |a| / 8 + dt^3 |jerk| / 6 of a
    smooth path through the rows.

    Row m is that path at program time m dt / factor; the last row is the program's last,
    held for the fraction of a cycle the rounding up adds. The wrench is interpolated linearly
    on the program's clock (it moves with the path). ``factor = 1`` returns ``program``
    itself.

    Parameters
    ----------
    program : Program
    factor : float
        > 0, finite.

    Returns
    -------
    Program
        A copy with ``t``, ``q_cmd`` (M, n), M = ceil(factor (K - 1)) + 1, and ``f_ext``
        replaced (read-only arrays).

    Raises
    ------
    StateError
        A factor that leaves fewer than two cycles, or whose rows, joined by straight lines,
        leave the program's path by more than :data:`mrnea.retime.job.PATH_TOL` at one of its
        rows (a faster program at the same dt skips its path: the message gives a factor that
        keeps it), or whose rows would not fit in memory.
    """
    if not isinstance(program, Program):
        raise StateError(f"program: expected a mrnea.io.Program, got {type(program).__name__}")
    f = validate.real(factor, "factor")
    if not (math.isfinite(f) and f > 0):
        raise StateError(f"factor: must be a finite number > 0, got {f}")
    if f == 1.0:
        return program
    q, dt = np.asarray(program.q_cmd, dtype=float), program.dt
    K = q.shape[0]
    M = _require_scaled_memory(program, f, StateError)
    if M < 2:
        raise StateError(f"factor: {f} leaves program {quote(program.name)} ({K} cycles) "
                         "less than two cycles")
    s, q_new = _scaled_rows(q, dt, f, M)
    tk = np.arange(K) * dt
    _require_resolution(program, f, q, s, q_new)

    def moved(f: NDArray) -> NDArray:  # a wrench (K, 6) at the new rows
        out = np.stack([np.interp(s, tk, f[:, c]) for c in range(6)], axis=1)
        out.setflags(write=False)
        return out

    f_ext = program.f_ext
    if isinstance(f_ext, dict):  # wrenches by link name
        f_ext = {link: moved(f) for link, f in f_ext.items()}
    elif f_ext is not None:
        f_ext = moved(f_ext)
    t = np.arange(M) * dt
    for a in (t, q_new):
        a.setflags(write=False)
    return dataclasses.replace(program, t=t, q_cmd=q_new, f_ext=f_ext)


def _scaled_rows(q: NDArray, dt: float, f: float, M: int) -> tuple[NDArray, NDArray]:
    """The M rows of the program ``q`` (K, n) run ``f`` times slower (:func:`time_scaled`) and
    the program instants [s] they are taken at (M,)."""
    K = q.shape[0]
    T = (K - 1) * dt
    s = np.minimum(np.arange(M) * dt / f, T)  # program-clock instants of the new rows
    w = np.diff(q, axis=0) / dt  # (K - 1, n): velocity at mid-cycle (k + 1/2) dt
    x = np.concatenate(([0.0], (np.arange(K - 1) + 0.5) * dt, [T]))  # velocity knots
    v = np.concatenate((w[:1], w, w[-1:]))
    h = np.diff(x)
    Q = q[0] + np.concatenate((np.zeros((1, q.shape[1])),
                               np.cumsum(0.5 * (v[:-1] + v[1:]) * h[:, None], axis=0)))
    seg = np.clip(np.searchsorted(x, s, side="right") - 1, 0, len(h) - 1)
    u = (s - x[seg])[:, None]
    q_new = Q[seg] + v[seg] * u + (v[seg + 1] - v[seg]) * u**2 / (2 * h[seg, None])
    q_new[0], q_new[-1] = q[0], q[-1]
    return s, q_new


def _deviation(q: NDArray, dt: float, s: NDArray, q_new: NDArray) -> NDArray:
    """(K, n) how far the rows ``q_new`` (at the program instants ``s``), joined by straight
    lines, pass from each program row of ``q`` [rad | m]."""
    tk = np.arange(q.shape[0]) * dt
    return np.abs(np.stack([np.interp(tk, s, q_new[:, j]) for j in range(q.shape[1])],
                           axis=1) - q)


def _require_resolution(program: Program, f: float, q: NDArray, s: NDArray,
                        q_new: NDArray) -> None:
    """Refuse a factor whose rows skip the program's path: the scaled rows ``q_new`` (at the
    program instants ``s``), joined by straight lines as the simulation and a controller take
    them, must pass within :data:`mrnea.retime.job.PATH_TOL` of every program row ``q``. A
    faster program (f < 1) has fewer rows. The factor the message suggests is found by the
    chord's law, its error growing as 1 / f^2 (f <- f sqrt(error / tol), a few steps, each
    checked: far below it rows skip whole features and the law alone undershoots)."""
    if f >= 1.0:  # as many rows or more: every row is met within dt^2 |a| / 8 (docstring)
        return
    dt = program.dt
    dev = _deviation(q, dt, s, q_new)
    k, j = np.unravel_index(int(np.argmax(dev)), dev.shape)
    if dev[k, j] <= PATH_TOL:
        return
    keep, err = f, float(dev[k, j])
    for _ in range(8):
        keep = min(1.0, 1.01 * keep * math.sqrt(err / PATH_TOL))
        if keep == 1.0:
            break
        err = float(_deviation(q, dt, *_scaled_rows(q, dt, keep, _rows(q.shape[0], keep))
                               ).max())
        if err <= PATH_TOL:
            break
    step = 10.0 ** (math.floor(math.log10(keep)) - 2)
    keep = math.ceil(keep / step) * step  # three digits, rounded up: the one shown keeps it
    raise StateError(
        f"factor: {f:g} makes program {quote(program.name)} too fast for its cycle "
        f"dt = {dt:g} s: the scaled rows, joined by straight lines, leave its path by "
        f"{dev[k, j]:.3g} rad (m for a prismatic joint) at joint {j + 1} (t = {k * dt:.4g} s "
        f"of the program), more than {PATH_TOL:g}; a factor of {keep:.3g} or more keeps it")


def _rows(K: int, factor: float) -> int:
    """The rows of a program of K rows run ``factor`` times slower (:func:`time_scaled`)."""
    return math.ceil(factor * (K - 1) - 1e-9) + 1


def _require_scaled_memory(program: Program, factor: float, error: type[MrneaError]) -> int:
    """The rows M of ``time_scaled(program, factor)``, once the memory it allocates (about
    8 M (4 n + 8) bytes) is known to be there, else ``error``."""
    K, n = program.q_cmd.shape
    span = factor * (K - 1)  # inf for a factor near 1e308: refused here, never ceil'd
    require_memory(8.0 * (span + 2) * (4 * n + 8), f"time-scaling program "
                   f"{quote(program.name)} by {factor:g} ({span + 1:.3g} cycles)",
                   "use a smaller time_scale or a coarser dt", error)
    return _rows(K, factor)
