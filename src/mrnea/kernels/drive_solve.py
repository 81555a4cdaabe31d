"""One interpolation cycle solved exactly: effort limits and Coulomb friction (paper Secs. II
and V, Eqs. 42-44).

Usage: ``status = solve_cycle(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau,
phi, tau_req, sat, stuck, ws)`` with ``how = solve_mode(PAPER or HYBRID, n, parents=λ)``
(kernels/drive_ways.py: the mode, and how H_FF's factor is kept: 'Cost' and 'Trees' below) and
``ws`` an ``ACHIEVABLE`` scratch (kernels/layout.py, ``drive_solve_buffers``).

Everything is joint side. The cycle starts at speed qd [rad/s | m/s]; the drives hold the new
velocity v over the next dt [s], so qdd = (v - qd) / dt. Eq. 42, with the Coulomb friction phi
that this cycle resolves (kernels/drive.py; u'_a = u' + F_v qd, Eq. 43 without F_s sign(qd)):

    H_a qdd + u'_a + phi = tau
    phi_i = F+_i (v_i > 0),  -F-_i (v_i < 0),  anything in [-F-_i, F+_i] (v_i = 0: stuck)
    HYBRID (Sec. II, speed-controlled drives, their velocity loops infinitely stiff):
        tau_i = +U_i if v_i < v_des_i,  -D_i if v_i > v_des_i,
        -D_i <= tau_i <= U_i if v_i = v_des_i
    PAPER (Eq. 44): tau_i = clip(tau_req_i, -D_i, U_i), whatever v does

[-D_i, U_i] = [-Llo_i, Lhi_i] is the effort box at the cycle's speed: the effort limit, scaled
by the gear's efficiency on the side where the drive delivers power and on the side where it is
driven back (kernels/drive.py ``effort_box``; D = U = L for an ideal gear). D_i, U_i >= 0, both
inf (no limit) or both finite; D_i = U_i = 0: no drive. These are the optimality conditions of
minimising the strictly convex (H_a is SPD) function

    f(v) = 1/2 (v - qd)^T H_a (v - qd) + dt u'_a^T v + dt sum_i g_i(v_i)
    g_i(v) = U_i max(v_des_i - v, 0) + D_i max(v - v_des_i, 0)
             + F+_i max(v, 0) + F-_i max(-v, 0)                       HYBRID
    g_i(v) = -tau_i v + F+_i max(v, 0) + F-_i max(-v, 0)             PAPER

(df/dv / dt = H_a qdd + u'_a + s, s_i in dg_i(v_i), s = phi - tau), so v is unique. Each g_i is
convex and piecewise linear with at most two breakpoints, 0 (if F+ + F- > 0) and v_des_i
(HYBRID, D_i + U_i > 0; merged when v_des_i = 0). A joint's *pattern* p says where v_i is: p = 2k on
the open piece k (slope sigma_k; piece k lies between breakpoints k - 1 and k), p = 2k + 1 held
at breakpoint beta_k with s_i in [sigma_k, sigma_{k+1}]. Crossing a breakpoint moves p by one.
In HYBRID, D_i = U_i = inf fixes v_i = v_des_i (slopes -inf, +inf).

Algorithm, a primal active-set method on this piecewise quadratic (W: held joints, F: free):

0. tau_req (the program's requirement, below). HYBRID fast path: if every tau_req_i lies in
   [-D_i, U_i] (up to rounding: kernels/drive.py ``beyond``), v = v_des is optimal (its
   subgradient condition) and nothing is solved.
1. Start: HYBRID v_i = v_des_i (qd_i without a drive), PAPER v = qd; each joint on the piece
   holding it, held where it sits on a breakpoint.
2. Eq. 44 for the free joints, the held ones' accelerations known:
   H_FF qdd_F = -(u'_a + sigma)_F - H_FW qdd_W,  qdd_W = (beta_W - qd_W) / dt,
   v*_F = qd_F + dt qdd_F.
3. Step from v towards v*, stopping where the first free joint reaches a breakpoint (it is held
   there, v_i = beta exactly); if one did, back to 2.
4. At v = v*: the held joints' multipliers s_W = -(H_a qdd + u'_a)_W. If each lies in its
   interval, v is optimal (KKT of a strictly convex problem). Else release the joint with the
   largest predicted decrease violation^2 / H_ii (ties: lowest index) onto the piece its
   multiplier points to, and back to 2.

Termination (exact arithmetic): every free joint lies strictly inside its piece (one that
reaches a breakpoint is held at once). After a release the released joint moves into its new
piece and every other free joint is strictly inside, so the next step has length > 0; f equals
the subproblem's strictly convex quadratic on the closure of the current cell, so it strictly
decreases between two visits of step 4. Each visit is at the unique minimiser of its pattern, so
no pattern repeats: at most prod_i (2 nb_i + 1) <= 5^n visits, with at most n partial steps
between two; beyond that bound the loop stops with CYCLE_LIMIT (never reached). The order of the
joints decides ties only: v is unique. In floating point: a multiplier within MULT_TOL
(relative) of its interval counts as inside; a free joint within SNAP_TOL (relative) of a
breakpoint is held on it (a joint that stops is at 0 exactly, so the next cycle sees qd = 0,
never 1e-18: no creep, no sign flips); a release that rounding sends the wrong way, or straight
back onto its breakpoint, is undone and that joint not released again until another release
succeeds (``tabu``). None of these acts in exact arithmetic.

Cost. Each pass through steps 2-4 costs O(n^2) besides step 2's factor of H_FF, and a saturated
cycle makes about 1.4 n of them (a 100- to 300-joint chain, every drive saturated). Made afresh
at every step (m^3 / 6 for m free joints) the factor makes a saturated cycle O(n^4); from
UPDATE_FROM joints on it is instead kept and updated (``update``, kernels/solve.py): the joint
released in step 4 is appended as the factor's last row (``factor_append``, O(m^2)), a joint
held in step 3 is removed (``factor_remove``: a rank-one update of the rows after it, O(m^2)),
so a cycle is O(n^3). The free joints then sit in the factor's order (idx[:m]); the held
joints' part of step 2's right-hand side and step 2's forward substitution are kept across
steps (kernels/drive_ways.py, ``Update``). The two ways give the same solution up to rounding
(tests/test_drive_solve_update.py); below UPDATE_FROM the refactorising way is kept operation
for operation (no faster to update there, measured: benchmarks/long_chain.py,
docs/performance.md). A singular free block is reported at the joint whose pivot fails: in
index order when refactorising, the joint being appended when updating. Which way a cycle takes
is a compile-time choice, made in Python by n (kernels/drive_ways.py ``solve_mode``: a named
tuple of class ``Refactor`` or ``Update``, or a tree's ``TreeRefactor`` below, carrying the
mode), so a kernel compiles the one path its robot takes: the update path cost a fresh ``mrnea
demo`` (4 joints) about 9 s of compiling for nothing (docs/performance.md, "A command's first
run").

Trees. On a tree whose paths are short, H_FF is factored in the order of the free joints'
forest λ_F, keeping the branch sparsity (``TreeRefactor``: kernels/drive_ways.py, where the
details and the measurements are).

Efforts. s = -(H_a qdd + u'_a) = phi - tau is unique, and so are tau and phi, except for a
HYBRID joint with v_i = 0 = v_des_i (stuck and on program), where only tau - phi = h_i =
(H_a qdd + u'_a)_i is: friction takes up to its capacity first, the drive the rest
(``holding_friction``). The program's requirement: tau_req = H_a qdd_des + u'_a + phi_des,
qdd_des = (v_des - qd) / dt, phi_des = coulomb(v_des), and for v_des_i = 0 the same split
(kernels/drive.py ``wanted_friction``).
Flags: sat_i (HYBRID) v_i != v_des_i, the drive is at U_i or -D_i and misses the program;
(PAPER) tau_req_i outside [-D_i, U_i] by more than rounding. stuck_i: v_i == 0 exactly (friction
holds the joint).
"""

from __future__ import annotations

import math

import numba as nb
from numba.extending import overload

from mrnea.kernels.drive import (
    beyond,
    coulomb,
    holding_friction,
    joint_pieces,
    start_piece,
    wanted_friction,
)
from mrnea.kernels.drive_ways import (
    Refactor,
    TreeRefactor,
    Update,
    drop_held,
    free_forest,
    free_residual,
    held_product,
    held_row,
    shift_held,
    tree_residual,
)
from mrnea.kernels.layout import (
    INLINE,
    JIT,
    drive_solve_buffers,
    tree_solve_buffers,
    update_buffers,
)
from mrnea.kernels.solve import (
    cholesky_solve,
    factor_append,
    factor_backward,
    factor_forward,
    ltl_factor,
    ltl_substitute,
)
from mrnea.kernels.status import CYCLE_LIMIT, OK

PAPER, HYBRID = 0, 1  # how the drives meet their limits (module docstring)
MULT_TOL = 1e-12  # a multiplier this close (relative) to its interval counts as inside
SNAP_TOL = 1e-14  # a free joint this close (relative) to a breakpoint is held there

@nb.njit(**INLINE)
def _required(Ha, ua, qdd_des, i, v_des_i, Fp, Fn):
    """Row i of Eq. 42 at the program's motion: (phi_des_i, tau_req_i)."""
    h = ua[i]
    for j in range(qdd_des.shape[0]):
        h += Ha[i, j] * qdd_des[j]
    phi = wanted_friction(h, v_des_i, Fp, Fn)
    return phi, h + phi


@nb.njit(**INLINE)
def _over(tau_req_i, Llo_i, Lhi_i):
    """tau_req_i outside the box [-Llo_i, Lhi_i] by more than rounding (kernels/drive.py
    ``beyond``; for a symmetric box, |tau_req_i| over L_i)."""
    scale = abs(tau_req_i)
    return beyond(tau_req_i, Lhi_i, Lhi_i + scale) or beyond(-tau_req_i, Llo_i, Llo_i + scale)


@nb.njit(**JIT)
def solve_cycle(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau, phi, tau_req,
                sat, stuck, ws):
    """Solve one cycle exactly (module docstring). Returns OK, the index of a joint whose
    pivot of a free block of H_a failed (singular), or CYCLE_LIMIT.

    Parameters
    ----------
    Ha : (n, n) H_a = H + diag(G^2 J_m) [kg m^2 | kg], symmetric positive definite.
    ua : (n,) u'_a without its Coulomb term: u' (Coriolis, gravity, wrench) + F_v qd [N m | N].
    qd : (n,) velocity at the start of the cycle [rad/s | m/s].
    v_des : (n,) velocity the program wants over the next interval (qd + qdd_des dt).
    dt : cycle time [s] > 0.
    Llo, Lhi : (n,) the effort box at speed qd [N m | N], -Llo <= tau <= Lhi, both >= 0
        (kernels/drive.py ``effort_box``); both inf = no limit (HYBRID: the joint is fixed to
        the program; PAPER: not clamped); both 0 = no drive.
    Fpos, Fneg : (n,) Coulomb friction magnitudes >= 0 against positive / negative motion.
    how : ``solve_mode(mode, n, parents=...)``: the mode (PAPER or HYBRID) and the way H_FF's
        factor is kept (``Refactor``, ``Update`` or a tree's ``TreeRefactor``; the same
        solution up to rounding).
    v, qdd, tau, phi, tau_req : (n,) out: new velocity (exactly 0 for a stuck joint, exactly
        v_des_i for a joint on program), acceleration (v - qd) / dt, drive effort, Coulomb
        friction, the program's requirement (joint side; tau - phi = H_a qdd + u'_a).
    sat, stuck : (n,) bool out: saturated, stuck (v == 0 exactly).
    ws : an ACHIEVABLE scratch (its ``drive_solve_buffers``); the arrays above are not in it.
    """
    mode = how.mode
    n = qd.shape[0]
    # 0. tau_req = H_a qdd_des + u'_a + phi_des (Eq. 42 at the program's motion), and the
    # on-program answer v = v_des, tau = tau_req, kept if it is optimal
    fast = mode == HYBRID
    for i in range(n):
        qdd[i] = (v_des[i] - qd[i]) / dt
    for i in range(n):
        phi[i], tau_req[i] = _required(Ha, ua, qdd, i, v_des[i], Fpos[i], Fneg[i])
        tau[i] = tau_req[i]
        v[i] = v_des[i]
        sat[i] = False
        stuck[i] = v_des[i] == 0.0
        fast = fast and not _over(tau_req[i], Llo[i], Lhi[i])
    if fast:  # HYBRID: v = v_des satisfies every joint's subgradient condition
        return OK
    return active_set(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau, phi,
                      tau_req, sat, stuck, ws)


def active_set(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau, phi, tau_req,
               sat, stuck, ws):
    """Steps 1-4 the way ``how`` names (arguments as :func:`solve_cycle`; tau_req filled). In
    compiled code its overload (below) compiles that way alone; this body serves Python
    (NUMBA_DISABLE_JIT)."""
    tree = isinstance(how, TreeRefactor)
    return _active_set(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how.mode, v, qdd, tau, phi,
                       tau_req, sat, stuck, ws, True if isinstance(how, Update) else None,
                       how.parent if tree else None, how.subend if tree else None)


@overload(active_set, inline="always")
def _active_set_of(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau, phi, tau_req,
                   sat, stuck, ws):
    """The way of ``how``'s type, chosen while typing: the update path and the tree's path are
    compiled only for a robot that takes them."""
    kind = getattr(how, "instance_class", None)
    if kind not in (Update, Refactor, TreeRefactor):
        return None  # not a solve mode: a typing error
    # True or None, not True or False: Numba prunes a branch on an argument's None-ness while
    # compiling (``update is None``), not on a literal bool's value, so a robot on the
    # refactorising way compiles no factor update (a fresh demo: about 3 s; docs/performance.md)
    update = True if kind is Update else None

    if kind is TreeRefactor:
        def impl(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau, phi, tau_req,
                 sat, stuck, ws):
            return _active_set(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how.mode, v, qdd,
                               tau, phi, tau_req, sat, stuck, ws, None, how.parent,
                               how.subend)
        return impl

    def impl(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how, v, qdd, tau, phi, tau_req, sat,
             stuck, ws):
        return _active_set(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, how.mode, v, qdd, tau,
                           phi, tau_req, sat, stuck, ws, update, None, None)
    return impl


@nb.njit(**JIT)
def _active_set(Ha, ua, qd, v_des, dt, Llo, Lhi, Fpos, Fneg, mode, v, qdd, tau, phi, tau_req,
                sat, stuck, ws, update, lam, nu):
    """Steps 1-4 of the module docstring (arguments as :func:`solve_cycle`, ``mode`` PAPER or
    HYBRID; tau_req filled). ``update``: True on the update way, None on the refactorising
    ones (compiled out: ``_active_set_of``). With ``update``, idx[:m] lists the free joints in
    the order of their factor Lc (L L^T = H_FF, kernels/solve.py ``factor_append``), kept in
    step with the patterns: a joint is appended where it is released, removed where it is
    held. On a tree (``lam`` λ, ``nu`` the subtrees' ends; both None otherwise: Numba then drops
    every branch on ``lam is not None``), H_FF = L^T L in the order of λ_F (module docstring,
    'Trees')."""
    n = qd.shape[0]
    hybrid = mode == HYBRID
    Hs, Lc, rhs, x, vstar, tauc, bp, sl, pat, nbp, idx, tabu = drive_solve_buffers(ws, n)
    if lam is not None:
        near, lam_f = tree_solve_buffers(ws, n)

    # 1. breakpoints, slopes and the start point
    max_iter = 1
    for i in range(n):
        # Eq. 44's clamp (PAPER); a requirement within the limit up to rounding is given whole
        tauc[i] = (min(max(tau_req[i], -Llo[i]), Lhi[i]) if _over(tau_req[i], Llo[i], Lhi[i])
                   else tau_req[i])
        nbp[i] = joint_pieces(i, hybrid, v_des[i], Llo[i], Lhi[i], Fpos[i], Fneg[i], tauc[i],
                              bp, sl)
        v[i] = v_des[i] if hybrid and Llo[i] + Lhi[i] > 0.0 else qd[i]
        pat[i] = start_piece(v[i], nbp[i], i, bp)
        if pat[i] % 2 == 1:
            qdd[i] = (v[i] - qd[i]) / dt
        tabu[i] = 0
        max_iter = min(max_iter * (2 * nbp[i] + 1), 1 << 40)
    max_iter *= n + 1  # the exact-arithmetic bound (module docstring)
    m = 0  # number of free joints
    if update is not None:  # the start's free joints in index order: H_FF's Cholesky by rows
        # g = H_a qw, qw: qdd on the held joints, 0 on the free ones (H_FW qdd_W = g_F), and
        # |H_a| |qw|, kept as joints are held and released; made afresh once there have been
        # more such moves since than joints held (rounding; O(n) a move on average)
        g, gabs = update_buffers(ws, n)
        moves = held_product(Ha, qdd, pat, g, gabs)
        # y = L^-1 rhs, its rows [:solved] current: a release appends one row and moves the
        # others by its qdd times the new row of L (the held part of rhs loses that column);
        # a hold, and g made afresh, start it over
        y, solved = Hs[0], 0
        for i in range(n):
            if pat[i] % 2 == 0:
                if not factor_append(Ha, Lc, idx, m, i):
                    return i
                m += 1

    released, side, pat_from = -1, 0, 0  # joint released last, to which side (+1 up, -1 down),
    # and its pattern before
    for _ in range(max_iter):
        # 2. Eq. 44 for the free joints: H_FF qdd_F = -(u'_a + sigma)_F - H_FW qdd_W
        if update is not None:
            if moves > n - m:
                moves = solved = held_product(Ha, qdd, pat, g, gabs)
        if lam is not None:  # idx[:m] in index order and their parent array λ_F (positions)
            m = free_forest(lam, pat, idx, near, lam_f)
        elif update is None:  # idx[:m]: the free joints in index order
            m = 0
            for i in range(n):
                if pat[i] % 2 == 0:
                    idx[m] = i
                    m += 1
        for a in range(m):
            i = idx[a]
            r = -ua[i] - sl[pat[i] // 2, i]
            if update is not None:
                r -= g[i]
            elif lam is not None:
                r -= held_row(Ha, qdd, pat, i, lam, nu)
                c = a
                while c >= 0:  # the entries of H_FF that L^T L holds: c on a's path in λ_F
                    Lc[a, c] = Ha[i, idx[c]]
                    c = lam_f[c]
            else:
                for j in range(n):
                    if pat[j] % 2 == 1:
                        r -= Ha[i, j] * qdd[j]
                for c in range(m):
                    Hs[a, c] = Ha[i, idx[c]]
            rhs[a] = r
        if update is not None:
            factor_forward(Lc, solved, m, rhs, y)
            solved = m
            for a in range(m):
                x[a] = y[a]
            factor_backward(Lc, m, x)
        elif m > 0:
            if lam is not None:
                status = ltl_factor(lam_f[:m], Lc[:m, :m])
                if status == OK:
                    ltl_substitute(lam_f[:m], Lc[:m, :m], rhs[:m], x[:m])
            else:
                status = cholesky_solve(Hs[:m, :m], rhs[:m], Lc[:m, :m], x[:m])
            if status != OK:
                return idx[status]
        for a in range(m):
            vstar[idx[a]] = qd[idx[a]] + dt * x[a]
        if released >= 0 and (vstar[released] - v[released]) * side <= 0.0:
            # rounding sent the released joint the wrong way: hold it again
            pat[released] -= side
            tabu[released] = 1
            released = -1
            if update is not None:
                moves += m
                m = drop_held(Ha, Lc, idx, m, pat, qdd, g, gabs, rhs, x)
                moves -= m
                solved = 0
        else:
            # 3. step towards v*; the first free joint to reach a breakpoint blocks it
            alpha, block = 1.0, -1
            for a in range(m):
                i = idx[a]
                d = vstar[i] - v[i]
                k = pat[i] // 2
                if d > 0.0 and k < nbp[i] and (bp[k, i] - v[i]) / d < alpha:
                    alpha, block = (bp[k, i] - v[i]) / d, i
                elif d < 0.0 and k > 0 and (bp[k - 1, i] - v[i]) / d < alpha:
                    alpha, block = (bp[k - 1, i] - v[i]) / d, i
            held_new = False
            for a in range(m):
                i = idx[a]
                d = vstar[i] - v[i]
                tol = SNAP_TOL * (abs(qd[i]) + abs(v[i]) + abs(vstar[i]))  # rounding of v
                v[i] = vstar[i] if block < 0 else v[i] + alpha * d
                k = pat[i] // 2
                if k < nbp[i] and (v[i] >= bp[k, i] - tol or (i == block and d > 0.0)):
                    v[i] = bp[k, i]  # held at the breakpoint above, exactly
                    pat[i] += 1
                elif k > 0 and (v[i] <= bp[k - 1, i] + tol or (i == block and d < 0.0)):
                    v[i] = bp[k - 1, i]  # held at the breakpoint below, exactly
                    pat[i] -= 1
                else:
                    qdd[i] = x[a]
                    continue
                qdd[i] = (v[i] - qd[i]) / dt
                held_new = True
            if update is not None and held_new:
                moves += m
                m = drop_held(Ha, Lc, idx, m, pat, qdd, g, gabs, rhs, x)
                moves -= m
                solved = 0
            if released >= 0:
                if pat[released] == pat_from:  # back on its breakpoint at once: rounding
                    tabu[released] = 1
                else:  # the release succeeded: every joint may be released again
                    for i in range(n):
                        tabu[i] = 0
                released = -1
            if held_new:
                continue
        # 4. multipliers of the held joints, s = -(H_a qdd + u'_a), against their intervals
        worst, worst_gain, worst_side = -1, 0.0, 0
        for i in range(n):
            if pat[i] % 2 == 0 or tabu[i] == 1:
                continue
            k = pat[i] // 2
            if lam is not None:
                h, scale = tree_residual(Ha, ua, qdd, i, lam, nu)
            elif update is not None:  # H_a qdd = g + the free joints' columns
                h, scale = free_residual(Ha[i], qdd, idx, m)
                h, scale = h + ua[i] + g[i], scale + abs(ua[i]) + abs(gabs[i])
            else:
                h, scale = _residual(Ha, ua, qdd, i)
            lo, hi = sl[k, i], sl[k + 1, i]
            scale += (abs(lo) if lo > -math.inf else 0.0) + (abs(hi) if hi < math.inf else 0.0)
            if -h > hi + MULT_TOL * scale:
                viol, dirn = -h - hi, 1
            elif -h < lo - MULT_TOL * scale:
                viol, dirn = lo + h, -1
            else:
                continue
            gain = viol * viol / Ha[i, i]  # predicted decrease of f (times 2 / dt)
            if gain > worst_gain:
                worst, worst_gain, worst_side = i, gain, dirn
        if worst < 0:
            _efforts(Ha, ua, v_des, Llo, Lhi, Fpos, Fneg, hybrid, v, qdd, tau, phi, tau_req,
                     sat, stuck, tauc, pat)
            return OK
        released, side, pat_from = worst, worst_side, pat[worst]
        pat[worst] += worst_side  # onto the piece its multiplier points to
        if update is not None:
            if not factor_append(Ha, Lc, idx, m, worst):
                return worst
            for a in range(m):  # y += qdd_worst L^-1 H_a[F, worst], the new row's l
                y[a] += qdd[worst] * Lc[m, a]
            m += 1
            shift_held(Ha[worst], -qdd[worst], g, gabs)
            moves += 1
    return CYCLE_LIMIT


@nb.njit(**INLINE)
def _residual(Ha, ua, qdd, i):
    """h_i = (H_a qdd + u'_a)_i and its scale |u'_a,i| + sum_j |H_a,ij qdd_j| (step 4), summed
    in index order (the refactorising paths)."""
    h, scale = ua[i], abs(ua[i])
    for j in range(qdd.shape[0]):
        t = Ha[i, j] * qdd[j]
        h += t
        scale += abs(t)
    return h, scale


@nb.njit(**INLINE)
def _efforts(Ha, ua, v_des, Llo, Lhi, Fpos, Fneg, hybrid, v, qdd, tau, phi, tau_req, sat, stuck,
             tauc, pat):
    """tau, phi and the flags at the solution (module docstring, 'Efforts')."""
    n = v.shape[0]
    for i in range(n):
        h = 0.0
        if pat[i] % 2 == 1:  # held: tau - phi = h_i = (H_a qdd + u'_a)_i
            h = ua[i]
            for j in range(n):
                h += Ha[i, j] * qdd[j]
        if not hybrid:
            tau[i] = tauc[i]
        elif v[i] != v_des[i]:
            tau[i] = Lhi[i] if v[i] < v_des[i] else 0.0 - Llo[i]
        if v[i] != 0.0:
            phi[i] = coulomb(v[i], Fpos[i], Fneg[i])
        elif not hybrid or v[i] != v_des[i]:  # stuck, the drive's effort known
            phi[i] = min(max(tau[i] - h, -Fneg[i]), Fpos[i])
        else:  # stuck on program: friction first, the drive the rest
            phi[i] = holding_friction(h, Fpos[i], Fneg[i])
        if hybrid and v[i] == v_des[i]:  # on program: the drive gives what it takes
            tau[i] = min(max(h + phi[i], -Llo[i]), Lhi[i])
        sat[i] = v[i] != v_des[i] if hybrid else _over(tau_req[i], Llo[i], Lhi[i])
        stuck[i] = v[i] == 0.0
