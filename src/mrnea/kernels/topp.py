"""TOPP-RA compiled: the backward pass of controllable sets and the forward pass of Pham and Pham,
*A new approach to time-optimal path parameterization based on reachability analysis* (2018),
for rows already in the interpolation form, each stage's LP in two variables solved in closed
form (docs/retime.md, "The solver").

Stage i (grid points s_i, s_i+1 = s_i + d_i) has the variables u (the path acceleration sdd over
the interval) and x = sd_i^2, the rows ``A[i] u + B[i] x + C[i] <= 0`` (m each) and
``x_lo[i] <= x <= x_hi[i]``; the next point's x is ``y = x + 2 d_i u``.

Backward pass (Eq. 14 of the paper): ``K_N = {0}`` (at rest at the end) and K_i the set of x
from which some admissible u reaches y in K_i+1. With u = (y - x) / (2 d_i) each row becomes
``gx x + gy y <= h`` (gx = B - A / (2 d), gy = A / (2 d), h = -C), and y is eliminated
(Fourier-Motzkin): every pair of a row bounding y from above (gy > 0) and one bounding it from
below (gy < 0), the bounds y_lo <= y <= y_hi among them, gives ``(gy_u gx_l - gy_l gx_u) x <=
gy_u h_l - gy_l h_u``; rows with gy = 0 bound x alone. K_i is the interval those half-lines
leave: exact, O(m^2) a stage, no iteration.

Forward pass (Eq. 15): from x_0 = 0, the largest u the rows and ``K_i+1`` allow (a 1-D LP:
the tightest bound of each row), ``x_i+1 = x_i + 2 d_i u``. As toppra does (its
``compute_parameterization``), x_i+1 is lowered by max(1e-8, 1e-4 x_i+1) and clipped into
K_i+1, so that rounding never leaves the controllable sets, and a step the rounding made
infeasible retries from x_i lowered by 0.1 % (10 times at most).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from mrnea.kernels.layout import JIT

TINY = 1e-8  # toppra's constants: x_i+1 lowered by max(TINY, SHRINK x_i+1)
SHRINK = 1e-4
RETRIES = 10  # a forward step infeasible by rounding: x_i lowered by 0.1 %, this many times


@nb.njit(**JIT)
def _x_interval(a, b, c, d, y_lo, y_hi, x_lo, x_hi):
    """(lo, hi): the x of stage rows (a, b, c) (m,) from which y = x + 2 d u in [y_lo, y_hi]
    (module docstring); lo > hi when empty."""
    lo, hi = x_lo, x_hi
    m = a.shape[0]
    two_d = 2.0 * d
    for k in range(m + 2):
        if k < m:
            gx_u, gy_u, h_u = b[k] - a[k] / two_d, a[k] / two_d, -c[k]
        elif k == m:
            gx_u, gy_u, h_u = 0.0, 1.0, y_hi
        else:
            gx_u, gy_u, h_u = 0.0, -1.0, -y_lo
        if gy_u == 0.0:  # a bound on x alone
            if gx_u > 0.0:
                hi = min(hi, h_u / gx_u)
            elif gx_u < 0.0:
                lo = max(lo, h_u / gx_u)
            elif h_u < 0.0:
                return 1.0, 0.0
            continue
        if gy_u < 0.0:
            continue
        for j in range(m + 2):  # every lower bound of y against this upper bound
            if j < m:
                gx_l, gy_l, h_l = b[j] - a[j] / two_d, a[j] / two_d, -c[j]
            elif j == m:
                continue
            else:
                gx_l, gy_l, h_l = 0.0, -1.0, -y_lo
            if gy_l >= 0.0:
                continue
            p = gy_u * gx_l - gy_l * gx_u
            r = gy_u * h_l - gy_l * h_u
            if p > 0.0:
                hi = min(hi, r / p)
            elif p < 0.0:
                lo = max(lo, r / p)
            elif r < 0.0:
                return 1.0, 0.0
    return lo, hi


@nb.njit(**JIT)
def controllable_sets(A, B, C, x_lo, x_hi, d, K):
    """Backward pass: K (N + 1, 2) [x_min, x_max] of every grid point, at rest at the end.
    Returns -1, or the stage whose set is empty (K from there on is NaN)."""
    N = d.shape[0]
    K[N, 0] = 0.0
    K[N, 1] = 0.0
    for i in range(N - 1, -1, -1):
        lo, hi = _x_interval(A[i], B[i], C[i], d[i], K[i + 1, 0], K[i + 1, 1], x_lo[i],
                             x_hi[i])
        lo = max(lo, 0.0)
        if lo > hi + 1e-12 * max(1.0, abs(hi)):
            for j in range(i + 1):
                K[j, 0] = np.nan
                K[j, 1] = np.nan
            return i
        K[i, 0] = min(lo, hi)
        K[i, 1] = hi
    return -1


@nb.njit(**JIT)
def _largest_u(a, b, c, d, x, y_lo, y_hi):
    """(lo, hi): the path accelerations of stage rows (a, b, c) at x = x_i with x_i+1 in
    [y_lo, y_hi]."""
    u_lo = (y_lo - x) / (2.0 * d)
    u_hi = (y_hi - x) / (2.0 * d)
    for k in range(a.shape[0]):
        r = -(b[k] * x + c[k])
        if a[k] > 0.0:
            u_hi = min(u_hi, r / a[k])
        elif a[k] < 0.0:
            u_lo = max(u_lo, r / a[k])
    return u_lo, u_hi


@nb.njit(**JIT)
def forward_pass(A, B, C, d, K, xs):
    """Forward pass from rest: xs (N + 1,) the squared path speeds. Returns -1, or the stage
    the pass failed at (xs from there on NaN)."""
    N = d.shape[0]
    xs[0] = 0.0
    i, tries = 0, 0
    while i < N:
        u_lo, u_hi = _largest_u(A[i], B[i], C[i], d[i], xs[i], K[i + 1, 0], K[i + 1, 1])
        if u_hi < u_lo - 1e-12 * max(1.0, abs(u_lo)):
            if tries < RETRIES:
                xs[i] = max(xs[i] - TINY, 0.999 * xs[i])
                tries += 1
                continue
            for j in range(i + 1, N + 1):
                xs[j] = np.nan
            return i
        tries = 0
        x_next = xs[i] + 2.0 * d[i] * u_hi
        x_next = max(x_next - TINY, (1.0 - SHRINK) * x_next)
        xs[i + 1] = min(K[i + 1, 1], max(K[i + 1, 0], x_next))
        i += 1
    return -1
