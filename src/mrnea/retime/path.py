"""The geometric path of a program: its pieces, their splines and grids, and the second-order
form of the efforts along them (docs/retime.md, "The path").

Usage: ``runs = pieces(q)``; per moving piece ``spline = piece_spline(q[k0:k1 + 1], dt)``,
``s = grid_points(t, q, N)``, ``pc = path_coefficients(robot, spline, s, f_ext, f_ext_point)``;
``rows, s_rows = piece_rows(spline, s_new, q[k0], q[k1])`` samples a piece at new positions.

The path parameter ``s`` is the program's own clock [s] (0 at the piece's first row), so the path
speed ``sd = ds/dt = 1`` is the program's timing and ``sd = 1/f`` a uniform slowing by f. With
``q' = q_s sd`` and ``q'' = q_s sdd + q_ss sd^2``, and mrnea's actuator convention
``tau = H_a q'' + u'_a`` (Eqs. 42-43), every joint effort along the path is::

    tau = a sdd + b sd^2 + c + F_C(sign q_s) + F_v q_s sd
    a = H_a q_s,   b = H_a q_ss + u'(q, q_s) - u'(q, 0),   c = u'(q, 0)

(u' the rigid-body bias with the wrench; its velocity-product part is quadratic in q', so
u'(q, q_s sd) - u'(q, 0) = sd^2 (u'(q, q_s) - u'(q, 0)); F_C the Coulomb friction against the
direction of motion, F_v the viscous friction). :func:`path_coefficients` gets a, b, c at every
grid point from H_a and u'_a of the 2 (N + 1) states (q, q_s) and (q, 0), ONE call of
:func:`mrnea.actuators.actuator_mass_matrix_and_bias`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from mrnea.actuators import actuator_mass_matrix_and_bias, coulomb_effort
from mrnea.model import Robot
from mrnea.validate import wrench_map

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

REST = 1e-12  # a joint slower than this fraction of the fastest one is at rest (path_coefficients)
SWING = 0.05  # a row where d2q/ds2 swings by this fraction of its largest value is a grid point
VIA = 0.01  # a row is a via point (the program passes through rest) below this fraction of the
#            program's fastest interval (grid_points)


def pieces(q: NDArray) -> list[tuple[str, int, int]]:
    """The runs of a program (K, n): ``("move", k0, k1)`` rows k0..k1 moving, ``("hold", k0,
    k1)`` rows k0..k1 identical (a dwell). Consecutive runs share their boundary row."""
    moving = np.any(q[1:] != q[:-1], axis=1)  # interval k: row k -> k + 1
    change = np.flatnonzero(moving[1:] != moving[:-1]) + 1
    edges = [0, *change.tolist(), moving.size]
    return [("move" if moving[a] else "hold", a, b) for a, b in itertools.pairwise(edges)]


def friction_pair(robot: Robot) -> tuple[NDArray, NDArray]:
    """Each joint's Coulomb friction magnitudes (n,) against positive and against negative
    motion, F+ and F- [N m | N], joint side (equal for a symmetric joint)."""
    F = robot.coulomb_friction  # (n, 2): [F+, F-] per joint
    return F[:, 0], F[:, 1]


def at_clock(t: NDArray, tk: NDArray, rows: Any) -> Any:
    """A wrench or its point given at the program's instants tk (rows (K, m); one row (m,) is
    every instant's), at the instants t of the same clock (linear), per link for a mapping."""
    def interp(a: NDArray) -> NDArray:
        if a.ndim == 1:
            return a
        return np.stack([np.interp(t, tk, a[:, c]) for c in range(a.shape[1])], axis=1)

    return wrench_map(rows, interp)


def piece_spline(q: NDArray, dt: float) -> CubicSpline:
    """The clamped cubic spline through a moving piece's rows (K, n) on its clock ``k dt``: at
    rest at both ends, as the program is (a piece starts and ends at a dwell or the program's
    ends). (SciPy is imported here, on the first retiming, not with mrnea.)"""
    from scipy.interpolate import CubicSpline

    return CubicSpline(np.arange(q.shape[0]) * dt, q, bc_type="clamped")


def piece_rows(spline: CubicSpline, s: NDArray, first: NDArray, last: NDArray
               ) -> tuple[NDArray, NDArray]:
    """A moving piece's rows at path positions s (M,), its ends exactly the program's rows, and
    the positions kept. Near the ends the path creeps (sd -> 0): a row equal to an end to the
    last bit would read as a dwell the program does not have, so it is dropped."""
    r = spline(s)
    r[0], r[-1] = first, last
    keep = np.ones(len(r), dtype=bool)
    keep[1:-1] = np.any(r[1:-1] != first, axis=1) & np.any(r[1:-1] != last, axis=1)
    return r[keep], s[keep]


def polyline_error(spline: CubicSpline, q: NDArray, dt: float, rows: NDArray, s: NDArray,
                   cache: dict | None = None) -> tuple[NDArray, NDArray, NDArray]:
    """How far a piece's retimed rows leave its path, per joint (n,) [rad | m].

    ``q`` (K, n) the program's rows of the piece at ``k dt`` (``spline`` through them), ``rows``
    (M, n) the retimed rows at path positions ``s`` (M,). At each program row and half-way
    between two, the path (the spline) against the straight line between the retimed rows
    around it (linear in s, as in time within a cycle). Returns ``(own, err, where)``: the
    program's own bulge (its rows' straight lines against the spline half-way between them),
    the retimed rows' largest deviation, and the path position [s] of that largest deviation.
    ``cache``: a dict kept for the same piece (its path side is computed once).
    """
    cache = {} if cache is None else cache
    if "ref" not in cache:
        k = np.arange(q.shape[0]) * dt
        mid = k[:-1] + dt / 2
        path_mid = spline(mid)
        cache["own"] = np.max(np.abs(path_mid - (q[:-1] + q[1:]) / 2), axis=0)
        cache["ref"] = np.concatenate([k, mid])
        cache["path"] = np.concatenate([q, path_mid])
    own, ref = cache["own"], cache["ref"]
    line = np.stack([np.interp(ref, s, rows[:, c]) for c in range(rows.shape[1])], axis=1)
    dev = np.abs(cache["path"] - line)
    return own, dev.max(axis=0), ref[np.argmax(dev, axis=0)]


def grid_points(s: NDArray, q: NDArray, N: int, qss: NDArray | None = None,
                grading: int = 4) -> NDArray:
    """About N + 1 grid points in [s_0, s_end] for a moving piece's rows q at s: equal steps of
    a blend of joint-space arc length and program time (slow stretches are not sampled more
    finely than fast ones, stretches where little moves are not skipped), graded towards the
    rests, with the rows where the path's curvature swings.

    Swings: ``qss`` (K, n), the spline's d^2q/ds^2 at the rows (its knots; linear between
    them), has a local extremum at a row that changes it by :data:`SWING` of the joint's largest
    |d^2q/ds^2| or more; that row is a grid point. Between two such grid points d^2q/ds^2 is
    then monotone, so the constraints at the grid points bound it. A program whose rows are
    piecewise linear (a CSV resampled linearly) swings at every row: measured on
    ``examples/sdt_csv.toml`` read linearly, 300 grid intervals without the swings gave no
    margin the simulation accepted; smooth programs have few or none (the Puma quintic and the
    SDT profile none, the trapezoidal pick example 48 where its accelerations step).

    Rests are the piece's ends and the rows where the program passes through rest (via points:
    the slower of a row's two intervals a local minimum below :data:`VIA` of the fastest). Each
    rest is a grid point, and ``grading`` more points halve the distance to it on either side
    (h/2, h/4, ...): near a rest dq/ds -> 0 and the phase plane's limit curve is steep (~
    1/sqrt(s - s_rest) after a quintic's rest); with a uniform grid the path acceleration of one
    interval is large and the joint accelerations inside it overshoot what the constraints at
    its ends allow (measured: 2.3 to 3 times an acceleration limit).
    """
    ds = np.diff(s)
    dl = np.linalg.norm(np.diff(q, axis=0), axis=1)
    w = ds / ds.sum() + (dl / dl.sum() if dl.sum() > 0 else 0)
    cum = np.concatenate([[0.0], np.cumsum(w)])
    g = np.interp(np.linspace(0, cum[-1], N + 1), cum, s)
    speed = dl / ds  # of the interval after each row but the last
    r = np.minimum(speed[:-1], speed[1:])  # rows 1 .. K-2: the slower of their two intervals
    before, after = np.concatenate([[np.inf], r[:-1]]), np.concatenate([r[1:], [np.inf]])
    via = 1 + np.flatnonzero((r < VIA * speed.max()) & (r <= before) & (r < after))
    for k in via:  # the nearest grid point moves onto the via row
        i = int(np.clip(np.argmin(np.abs(g - s[k])), 1, N - 1))
        g[i] = s[k]
    g[0], g[-1] = s[0], s[-1]
    if qss is not None and s.size > 2:
        d1, d2 = qss[1:-1] - qss[:-2], qss[2:] - qss[1:-1]
        big = np.maximum(np.abs(d1), np.abs(d2)) >= SWING * np.abs(qss).max(axis=0)
        g = np.concatenate([g, s[1:-1][np.any((d1 * d2 < 0) & big, axis=1)]])
    g = np.unique(g)
    extra = []
    for r0 in [s[0], *s[via], s[-1]]:
        i = int(np.argmin(np.abs(g - r0)))
        for side in (-1, 1):
            if 0 <= i + side < g.size:
                h = g[i + side] - r0
                extra += [r0 + h / 2 ** j for j in range(1, grading + 1)]
    g = np.unique(np.concatenate([g, extra]))
    # a point within rounding of a row is that row: two points 1e-11 apart make an interval
    # whose path acceleration is noise
    k = np.clip(np.searchsorted(s, g), 1, s.size - 1)
    near = np.where(g - s[k - 1] < s[k] - g, s[k - 1], s[k])
    return np.unique(np.where(np.abs(g - near) <= 1e-9 * (s[-1] - s[0]), near, g))


@dataclass(frozen=True)
class PathCoefficients:
    """The second-order form along a grid (module docstring); arrays (N + 1, n), joint side, SI.

    Attributes
    ----------
    s : (N + 1,) grid [s, the program's clock]. q, qs, qss : q(s), dq/ds, d^2q/ds^2.
    a : H_a q_s. b : H_a q_ss + u'(q, q_s) - u'(q, 0) (rigid body, no friction).
    c : u'(q, 0): gravity and the wrench.
    sign : sign(q_s) where it is the same at the point and both neighbours, else NaN (there the
        direction of the Coulomb friction is not known over the adjacent intervals).
    qs_range, qss_range : (N, n, 2) min and max of q_s and q_ss over each interval (sampled at
        9 points), for the interval-robust acceleration rows (computed when first asked:
        only acceleration limits need them).
    """

    s: NDArray
    q: NDArray
    qs: NDArray
    qss: NDArray
    a: NDArray
    b: NDArray
    c: NDArray
    sign: NDArray
    spline: CubicSpline = field(repr=False, compare=False)
    _ranges: dict = field(default_factory=dict, repr=False, compare=False)

    def _range(self, k: int) -> NDArray:
        if not self._ranges:
            s = self.s
            sub = s[:-1, None] + np.diff(s)[:, None] * np.linspace(0.0, 1.0, 9)[None, :]
            for d in (1, 2):  # (N, 9, n) -> (N, n, 2)
                v = self.spline(sub, d)
                self._ranges[d] = np.stack([v.min(axis=1), v.max(axis=1)], axis=-1)
        return self._ranges[k]

    @property
    def qs_range(self) -> NDArray:
        return self._range(1)

    @property
    def qss_range(self) -> NDArray:
        return self._range(2)


def path_coefficients(robot: Robot, spline: CubicSpline, s: NDArray, f_ext: Any,
                      f_ext_point: Any) -> PathCoefficients:
    """a, b, c at every grid point s from H_a and u'_a of the 2 (N + 1) states (q, q_s) and
    (q, 0) (module docstring). ``f_ext`` (N + 1, 6) or None,
    ``f_ext_point`` (3,), (N + 1, 3) or None: the wrench at each grid point; or both by link
    name (each link's arrays so)."""
    q, qs, qss = spline(s), spline(s, 1), spline(s, 2)
    # a spline's coefficients decay away from a change but reach zero only far below any
    # meaning (1e-323 seen on the SDT, which broke the rows' scaling)
    rest = np.abs(qs) < REST * np.abs(qs).max()
    qs[rest] = 0.0
    qss[rest & (np.abs(qss) < REST * np.abs(qss).max())] = 0.0
    G = s.size

    def twice(x: Any) -> Any:
        return wrench_map(x, lambda a: a if a.ndim == 1 else np.concatenate([a, a]))

    H2, u2 = actuator_mass_matrix_and_bias(robot, np.concatenate([q, q]),
                                  np.concatenate([qs, np.zeros_like(qs)]), twice(f_ext),
                                  twice(f_ext_point))
    sgn = np.sign(qs)
    u1 = u2[:G] - robot.viscous_friction * qs - coulomb_effort(robot, sgn)  # rigid u'(q, q_s)
    c = u2[G:]
    a = np.einsum("kij,kj->ki", H2[:G], qs)
    b = np.einsum("kij,kj->ki", H2[:G], qss) + u1 - c
    padded = np.concatenate([sgn[:1], sgn, sgn[-1:]])
    same = (padded[:-2] == sgn) & (padded[2:] == sgn)
    return PathCoefficients(s=s, q=q, qs=qs, qss=qss, a=a, b=b, c=c,
                            sign=np.where(same, sgn, np.nan), spline=spline)
