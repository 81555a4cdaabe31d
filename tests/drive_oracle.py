"""Independent references for one cycle of the drive law (issue 11): the brute-force enumeration
oracle, the torque-speed curve, the cycle's inputs from mrnea's rigid-body H and u', and a call
of the compiled solve with its own outputs and scratch.

The oracle is built from the physical law (docs/achievable.md), not from the solver's
breakpoints, slopes or patterns: per joint the drive states {below, on, above the program} (one
state for PAPER, a joint without a drive, an unlimited one) times the friction states {moving
down, stuck, moving up}, where their sets of velocities intersect (3 or 5 cells: the three open
pieces and the breakpoints); every combination, one cell per joint, is solved with
``numpy.linalg.solve`` and kept if it is consistent.
"""

from __future__ import annotations

import itertools

import numpy as np

from mrnea import Robot, mass_matrix_and_bias
from mrnea.kernels.drive_solve import HYBRID, PAPER, solve_cycle
from mrnea.kernels.drive_ways import solve_mode
from mrnea.kernels.layout import ACHIEVABLE, entry_scratch

CODE = {"hybrid": HYBRID, "paper": PAPER}


def rel(a, b, floor: float = 1.0) -> float:
    """``max|a - b| / max(floor, max|b|)`` (conftest.rel_err with a chosen floor)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    return float(np.max(np.abs(a - b), initial=0.0) / max(floor, float(np.max(np.abs(b)))))


def torque_speed(peak, corner, no_load, w):
    """The torque-speed curve (docs/achievable.md) at speed |w|, elementwise."""
    w = np.abs(w)
    wc = np.maximum(w, corner)  # the middle branch is used only above the corner
    mid = np.minimum(peak * corner / wc, peak * (no_load - w) / (no_load - corner))
    return np.where(w <= corner, peak, np.where(w >= no_load, 0.0, mid))


def cycle_terms(robot: Robot, q, qd, f_ext=None, f_ext_point=None):
    """H_a = H + diag(G^2 J_m) and u'_a without its Coulomb term, u' + F_v qd, from mrnea's
    rigid-body H and u' (what a cycle passes to the solve)."""
    H, u = mass_matrix_and_bias(robot, q, qd, f_ext, f_ext_point)
    return (H + np.diag(robot.gear_ratio**2 * robot.rotor_inertia),
            u + robot.viscous_friction * np.asarray(qd, float))


def solve(Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, mode: str, update: bool | None = None,
          parents=None, tree: bool | None = None):
    """The compiled cycle solve with its own outputs and scratch; the effort box
    -Llo <= tau <= Lhi. ``update``: None, the factorisation ``solve_mode`` picks by n; True or
    False, H_FF's factor updated or made afresh at every step. ``parents``: a tree's parent
    array (H_a with its sparsity); ``tree`` True forces the tree's factorisation on it, None
    lets ``solve_mode`` choose.

    Returns (status, v, qdd, tau, phi, tau_req, sat, stuck)."""
    args = [np.ascontiguousarray(a, dtype=float) for a in (Ha, ua, qd, v_des)]
    lim = [np.ascontiguousarray(a, dtype=float) for a in (Llo, Lhi, Fp, Fn)]
    n = args[2].shape[0]
    out = [np.empty(n) for _ in range(5)]
    flags = [np.empty(n, dtype=np.bool_) for _ in range(2)]
    ws = entry_scratch(n, ACHIEVABLE)
    how = solve_mode(CODE[mode], n, update, parents, tree)
    status = solve_cycle(*args, float(dt), *lim, how, *out, *flags, ws)
    return (status, *out, *flags)


def required_efforts(Ha, ua, qd, v_des, dt, Fp, Fn):
    """The program's requirement, straight from its definition: H_a qdd_des + u'_a plus the
    friction of the wanted motion (at v_des = 0 friction takes up to its capacity first)."""
    h = Ha @ ((v_des - qd) / dt) + ua
    phi = np.where(v_des > 0, Fp, np.where(v_des < 0, -Fn, np.clip(-h, -Fn, Fp)))
    return h + phi


def _cells(mode, v_des_i, Llo_i, Lhi_i, Fp_i, Fn_i, tauc_i):
    """The cells of one joint's law: each state of the drive combined with each state of the
    friction whose sets of v intersect. A state: (lo, hi, lo_closed, hi_closed, known value of
    its effort or None). Returns a list of dicts."""
    inf = np.inf
    if mode == "paper":
        drive = [(-inf, inf, False, False, tauc_i)]
    elif Lhi_i == inf:
        drive = [(v_des_i, v_des_i, True, True, None)]
    elif Llo_i == 0.0 and Lhi_i == 0.0:
        drive = [(-inf, inf, False, False, 0.0)]
    else:  # tau = +Lhi below the program, -Llo above, anything in [-Llo, Lhi] on it
        drive = [(-inf, v_des_i, False, False, Lhi_i), (v_des_i, v_des_i, True, True, None),
                 (v_des_i, inf, False, False, -Llo_i)]
    if Fp_i + Fn_i == 0.0:
        fric = [(-inf, inf, False, False, 0.0)]
    else:  # phi = -F- moving down, F+ moving up, anything in [-F-, F+] stuck
        fric = [(-inf, 0.0, False, False, -Fn_i), (0.0, 0.0, True, True, None),
                (0.0, inf, False, False, Fp_i)]
    cells = []
    for d, f in itertools.product(drive, fric):
        lo = max(d[0], f[0])  # the intersection of the two sets of v, with its closed ends
        hi = min(d[1], f[1])
        lo_c = (d[2] or d[0] < lo) and (f[2] or f[0] < lo)
        hi_c = (d[3] or d[1] > hi) and (f[3] or f[1] > hi)
        if lo > hi or (lo == hi and not (lo_c and hi_c)):
            continue  # empty
        cells.append({"lo": lo, "hi": hi, "point": lo == hi, "tau": d[4], "phi": f[4]})
    return cells


def enumerate_solutions(Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, mode, tol=1e-9):
    """Every consistent combination of cells (one per joint) and its solution; the drives'
    effort box -Llo <= tau <= Lhi.

    For each combination: joints on a point cell have v fixed; the others satisfy their row of
    Eq. 42, ``H_a (v - qd) / dt + u'_a + phi - tau = 0`` with the cell's known tau and phi; the
    system is solved with numpy.linalg.solve. A combination is consistent when each v lies in its
    cell (closed, tolerance ``tol`` relative) and the unknown efforts of point cells lie in their
    intervals. Returns (list of (v, tau, phi, cells) of the consistent combinations, tau_req).
    """
    n = len(qd)
    tau_req = required_efforts(Ha, ua, qd, v_des, dt, Fp, Fn)
    tauc = np.clip(tau_req, -Llo, Lhi)
    per_joint = [_cells(mode, v_des[i], Llo[i], Lhi[i], Fp[i], Fn[i], tauc[i])
                 for i in range(n)]
    combos = np.array(list(itertools.product(*[range(len(c)) for c in per_joint])))
    width = max(len(c) for c in per_joint)

    def table(key, fill):  # one cell property per joint, gathered per combination (P, n)
        t = np.full((n, width), fill, dtype=float)
        for i, cs in enumerate(per_joint):
            for c, cell in enumerate(cs):
                val = cell[key]
                t[i, c] = fill if val is None else float(val)
        return t[np.arange(n), combos]

    lo, hi = table("lo", 0.0), table("hi", 0.0)
    point = table("point", 0.0).astype(bool)
    tau_k, phi_k = table("tau", np.nan), table("phi", np.nan)
    M = np.where(point[:, :, None], np.eye(n)[None], Ha[None])
    rhs = np.where(point, lo, (Ha @ qd)[None] - dt * (ua[None] + np.nan_to_num(phi_k)
                                                      - np.nan_to_num(tau_k)))
    v = np.linalg.solve(M, rhs[..., None])[..., 0]
    v = np.where(point, lo, v)  # exactly on the point
    h = np.einsum("ij,pj->pi", Ha, (v - qd) / dt) + ua
    # the problem's effort scale, per combination (a wildly inconsistent one must not widen
    # the tolerance of the others)
    escale = (1.0 + np.max(np.abs(ua)) + np.max(np.abs(Ha))
              * np.max(np.abs(v - qd), axis=1, keepdims=True) / dt
              + np.max(np.where(np.isfinite(Llo), Llo, 0.0))
              + np.max(np.where(np.isfinite(Lhi), Lhi, 0.0)) + np.max(Fp) + np.max(Fn))
    vscale = np.max(np.abs(qd)) + np.max(np.abs(v_des)) + dt
    te, tv = tol * escale, tol * vscale
    ok = np.all((v >= lo - tv) & (v <= hi + tv), axis=1)
    tau_unknown, phi_unknown = np.isnan(tau_k), np.isnan(phi_k)
    # derived efforts of point cells: tau - phi = h
    tau = np.where(tau_unknown, h + np.where(phi_unknown, 0.0, phi_k), tau_k)
    phi = np.where(phi_unknown, tau_k - h, phi_k)
    both = tau_unknown & phi_unknown
    split = np.clip(-h, -Fn, Fp)  # friction first, the drive the rest
    phi = np.where(both, split, phi)
    tau = np.where(both, h + split, tau)
    lo_b, hi_b = np.broadcast_to(Llo, v.shape), np.broadcast_to(Lhi, v.shape)
    ok &= np.all(~tau_unknown | phi_unknown | ((tau >= -lo_b - te) & (tau <= hi_b + te)), axis=1)
    ok &= np.all(~phi_unknown | tau_unknown | ((phi >= -Fn - te) & (phi <= Fp + te)), axis=1)
    ok &= np.all(~both | ((h >= -lo_b - Fp - te) & (h <= hi_b + Fn + te)), axis=1)  # tau - phi
    return [(v[p], tau[p], phi[p], combos[p]) for p in np.flatnonzero(ok)], tau_req


def law_violation(Ha, ua, qd, v_des, dt, Llo, Lhi, Fp, Fn, mode: str, v) -> float:
    """How far a new velocity v is from satisfying the drive law, from v alone: the largest
    distance of h = H_a (v - qd) / dt + u'_a (= tau - phi, Eq. 42) from the set of efforts the
    law allows at v, over the joints, relative to the problem's effort scale. The law's sets, per
    joint: drive (HYBRID) tau = Lhi below the program, -Llo above, [-Llo, Lhi] on it, v = v_des
    when unlimited; (PAPER) tau = clip(tau_req); friction phi = Fp moving up, -Fn moving down,
    [-Fn, Fp] at rest. These are the optimality (KKT) conditions of the strictly convex problem
    the solve minimises (kernels/drive_solve.py), so a v with violation ~0 is the solution;
    the comparisons with v_des and 0 are exact, as the solver puts v there exactly."""
    h = Ha @ ((v - qd) / dt) + ua
    tauc = np.clip(required_efforts(Ha, ua, qd, v_des, dt, Fp, Fn), -Llo, Lhi)
    worst = 0.0
    for i in range(len(v)):
        if mode == "paper":
            t_lo = t_hi = tauc[i]
        elif Lhi[i] == np.inf:
            if v[i] != v_des[i]:
                return np.inf
            t_lo, t_hi = -np.inf, np.inf
        elif v[i] < v_des[i]:
            t_lo = t_hi = Lhi[i]
        elif v[i] > v_des[i]:
            t_lo = t_hi = -Llo[i]
        else:
            t_lo, t_hi = -Llo[i], Lhi[i]
        if Fp[i] + Fn[i] == 0.0:
            f_lo = f_hi = 0.0
        elif v[i] > 0.0:
            f_lo = f_hi = Fp[i]
        elif v[i] < 0.0:
            f_lo = f_hi = -Fn[i]
        else:
            f_lo, f_hi = -Fn[i], Fp[i]
        worst = max(worst, t_lo - f_hi - h[i], h[i] - (t_hi - f_lo))  # h in [lo, hi]
    fin = [x[np.isfinite(x)] for x in (Llo, Lhi)]
    scale = (1.0 + np.max(np.abs(ua)) + np.max(np.abs(Ha)) * np.max(np.abs(v - qd)) / dt
             + max(float(np.max(x, initial=0.0)) for x in fin) + np.max(Fp) + np.max(Fn))
    return worst / scale
