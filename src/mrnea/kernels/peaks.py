"""A run's summary numbers, per joint, in one compiled pass over its arrays.

Usage: ``run_peaks(response, program, drive, idx, val)`` with
``response = (tau, tau_motor, qd, tracking_error, saturated, stuck, wrench)`` (K, n), the wrench
(K, n, 6) or (0, n, 6) for a run without reactions, ``program = (req, limit, qd_cmd)`` (K, n):
the program's own requirement, the limit at the program's speed and the program's velocity,
``drive = (act, limited, axes)``: the actuator array (kernels/layout.py), (n,) True for a joint
with a finite nonzero effort limit, the unit joint axes (n, 3). Fills, per joint i, ``idx[i]``
(cycles and counts, the ``K_*`` and ``N_*`` columns) and ``val[i]`` (the other columns), what
:func:`mrnea.summary.summarize` reports (mrnea/summary.py says what each entry means):

* the program's requirement: the cycle of the peak |req| (``K_REQ``); its RMS; the motor side
  |req| / eta_d driving, |req| eta_b back-driven (req qd_cmd < 0; kernels/drive.py
  ``motor_side``, before the division by G that the caller makes): its peak and RMS; for a
  limited joint, the ratio |req| / limit (0 where req = 0, inf for a zero limit), its peak and
  cycle (``K_RATIO``); the first cycle over the limit by more than rounding (kernels/drive.py
  ``beyond``, scale |req| + limit; ``K_OVER``, -1 if none);
* the response: cycles saturated and stuck (counts), the peak and RMS motor torque, the peaks of
  |tau| and |qd|, the cycle of the peak |tracking error| (``K_ERR``), and the peak bearing loads
  (kernels/bearing.py; NaN without reactions).

A peak's cycle is its first, and a NaN counts as the peak (``np.argmax``); an RMS is
sqrt(sum x^2 / K) with the sum in NumPy's pairwise order (:func:`pairwise_sum`): every number is
the same bits as the NumPy expressions this pass replaced (tests/test_run_peaks.py).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from mrnea.kernels.bearing import split
from mrnea.kernels.drive import beyond
from mrnea.kernels.layout import ALLOC, ETAB, ETAD, INLINE

# columns of idx: the cycles of the peaks, the first cycle over the limit, the counts
K_REQ, K_RATIO, K_OVER, K_ERR, N_SATURATED, N_STUCK = range(6)
NIDX = 6
# columns of val: the program's requirement, then the response, then the peak bearing loads in
# kernels/bearing.py's order (FORCE_PEAK + bearing.FORCE ...)
(REQ_RMS, MOTOR_REQ_PEAK, MOTOR_REQ_RMS, RATIO_PEAK, TAU_MOTOR_PEAK, TAU_MOTOR_RMS, TAU_PEAK,
 QD_PEAK, FORCE_PEAK) = range(9)
NVAL = FORCE_PEAK + 6
PAIRWISE_BLOCK = 128  # NumPy's PW_BLOCKSIZE


@nb.njit(**INLINE)
def _block_sum(a, lo, m):
    """NumPy's sum of a[lo:lo + m], m <= 128 terms: below 8 one after another, else in 8
    interleaved partial sums, added pairwise, then the remainder."""
    if m < 8:
        s = 0.0
        for k in range(lo, lo + m):
            s += a[k]
        return s
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    end = lo + m - m % 8
    for k in range(lo + 8, end, 8):
        r0 += a[k]
        r1 += a[k + 1]
        r2 += a[k + 2]
        r3 += a[k + 3]
        r4 += a[k + 4]
        r5 += a[k + 5]
        r6 += a[k + 6]
        r7 += a[k + 7]
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for k in range(end, lo + m):
        s += a[k]
    return s


@nb.njit(**ALLOC)
def pairwise_sum(a):
    """The sum of a contiguous float64 array a in NumPy's order (its ``pairwise_sum``, what
    ``np.sum`` and ``np.mean`` do): up to 128 terms :func:`_block_sum`; above, the two halves,
    the first a multiple of 8 long, summed apart and added. NumPy recurses; here an explicit
    stack of (start, length, halved) takes the recursion's place (a recursive kernel cannot be
    loaded from Numba's cache), the same tree of additions."""
    start, length = np.empty(128, np.int64), np.empty(128, np.int64)
    halved, sums = np.empty(128, np.bool_), np.empty(128)
    start[0], length[0], halved[0] = 0, a.shape[0], False
    top, done = 0, 0  # the stack's top entry; the sums done and not yet added
    while top >= 0:
        lo, m = start[top], length[top]
        if m <= PAIRWISE_BLOCK:
            sums[done] = _block_sum(a, lo, m)
            done += 1
            top -= 1
        elif halved[top]:  # both halves done: add them
            sums[done - 2] += sums[done - 1]
            done -= 1
            top -= 1
        else:  # the second half below the first on the stack: the first is summed first
            halved[top] = True
            half = m // 2
            half -= half % 8
            start[top + 1], length[top + 1], halved[top + 1] = lo + half, m - half, False
            start[top + 2], length[top + 2], halved[top + 2] = lo, half, False
            top += 2
    return sums[0]


@nb.njit(**INLINE)
def _peak(x, best, k, kb):
    """(new peak, its cycle) after x at cycle k: the first maximum; a NaN, once seen, kept.
    Where only the value is wanted, callers pass ``kb = k`` (a variable, as elsewhere): a
    literal 0 typed differently and compiled the helper a second time."""
    if x > best or (x != x and best == best):
        return x, k
    return best, kb


@nb.njit(**ALLOC)
def run_peaks(response, program, drive, idx, val):
    """The summary numbers of a run of K >= 1 cycles (module docstring)."""
    tau, tau_motor, qd, err, sat, stuck, wrench = response
    req, limit, qd_cmd = program
    act, limited, axes = drive
    K, n = tau.shape
    loads = wrench.shape[0] > 0
    sq = np.empty((3, n, K))  # squares of req, its motor side and tau_motor, for the RMS
    # running peaks: of |req|, |tracking error| (their cycles in idx), then val's columns;
    # -1 is below every value (each is >= 0), so cycle 0 sets each peak
    peak = np.empty((n, 2))
    peak[:] = -1.0
    val[:] = -1.0
    idx[:] = 0
    idx[:, K_OVER] = -1
    for k in range(K):  # cycle by cycle, as the arrays lie in memory
        for i in range(n):
            r = req[k, i]
            a = abs(r)
            # the motor side (kernels/drive.py motor_side, without the division by G)
            m = a * (act[i, ETAB] if r * qd_cmd[k, i] < 0.0 else 1.0 / act[i, ETAD])
            tm = tau_motor[k, i]
            sq[0, i, k], sq[1, i, k], sq[2, i, k] = r * r, m * m, tm * tm
            peak[i, 0], idx[i, K_REQ] = _peak(a, peak[i, 0], k, idx[i, K_REQ])
            val[i, MOTOR_REQ_PEAK] = _peak(m, val[i, MOTOR_REQ_PEAK], k, k)[0]
            lim = limit[k, i]
            if limited[i]:
                val[i, RATIO_PEAK], idx[i, K_RATIO] = _peak(
                    a / lim if a > 0.0 else 0.0, val[i, RATIO_PEAK], k, idx[i, K_RATIO])
            if idx[i, K_OVER] < 0 and beyond(a, lim, lim + a):
                idx[i, K_OVER] = k
            val[i, TAU_MOTOR_PEAK] = _peak(abs(tm), val[i, TAU_MOTOR_PEAK], k, k)[0]
            val[i, TAU_PEAK] = _peak(abs(tau[k, i]), val[i, TAU_PEAK], k, k)[0]
            val[i, QD_PEAK] = _peak(abs(qd[k, i]), val[i, QD_PEAK], k, k)[0]
            peak[i, 1], idx[i, K_ERR] = _peak(abs(err[k, i]), peak[i, 1], k, idx[i, K_ERR])
            idx[i, N_SATURATED] += sat[k, i]
            idx[i, N_STUCK] += stuck[k, i]
            if loads:
                here = split(wrench[k, i], axes[i])
                for c in range(6):
                    val[i, FORCE_PEAK + c] = _peak(here[c], val[i, FORCE_PEAK + c], k, k)[0]
    for i in range(n):
        val[i, REQ_RMS] = math.sqrt(pairwise_sum(sq[0, i]) / K)
        val[i, MOTOR_REQ_RMS] = math.sqrt(pairwise_sum(sq[1, i]) / K)
        val[i, TAU_MOTOR_RMS] = math.sqrt(pairwise_sum(sq[2, i]) / K)
        if not limited[i]:
            val[i, RATIO_PEAK] = 0.0
        if not loads:
            val[i, FORCE_PEAK:] = np.nan
