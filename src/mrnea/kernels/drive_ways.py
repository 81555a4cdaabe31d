"""The ways the exact cycle solve (kernels/drive_solve.py) keeps step 2's factor of H_FF, the
free joints' block of H_a: the compile-time choice (``solve_mode``: a named tuple whose class is
the way, carrying the mode) and the per-step helpers of the two ways besides refactorising.

* ``Refactor``: H_FF factored afresh at every active-set step (dense Cholesky); robots under
  UPDATE_FROM joints, and trees where the tree's way does not pay.
* ``Update``: the dense factor updated one joint at a time, with the held joints' product
  g = H_a qw kept running (``shift_held``, ``held_product``, ``drop_held``) and step 4's
  residuals from g plus the free joints' columns (``free_residual``): long chains (drive_solve.py
  'Cost' and 'Update' below).
* ``TreeRefactor``: H_FF = L^T L in the order of the free joints' forest λ_F
  (``free_forest``), the products over each row's nonzeros (``held_row``, ``tree_residual``):
  trees whose paths are short (docs/notation.md, Trees).

Update. The free joints sit in the factor's order (idx[:m]), and the held joints' part of
step 2's right-hand side, g = H_a qw (qw: qdd on the held joints, 0 on the free ones), is kept
as a running product: a joint's
column times its held qdd is added where it is held and taken away where it is released, O(n)
a move (``shift_held``), and g is made afresh (``held_product``, O(n |W|)) once there have been
more moves since than joints held, which bounds the rounding it gathers. Step 4's residuals are
then g plus the free joints' columns (O(m) each instead of O(n)). Step 2's forward substitution
y = L^-1 rhs is kept too: a release leaves the factor's old rows as they were and changes
their rhs by qdd_j H_a[F, j] alone, so y moves by qdd_j times the row factor_append has just
computed and only the new row is solved (kernels/solve.py ``factor_forward``); a hold or a
fresh g start it over. The long sums run in four partial sums.

Trees. On a tree H_a keeps the branch-induced zeros (H_ij = 0 unless one of i, j carries the
other; the rotor term is diagonal), and so does every free block: for the free joints F, each
free joint's free ancestors form a path in the forest λ_F (λ_F(i): i's nearest ancestor in F,
-1 for none; docs/notation.md, Trees), and H_FF_ij != 0 only where one of i, j is an ancestor of
the other in λ_F. So on a tree (``TreeRefactor``) step 2 factors H_FF = L^T L in λ_F's order,
Featherstone's LTL with no fill-in (kernels/solve.py ``ltl_factor``, as a tree's forward
dynamics), reading only the entries on each free joint's path; λ_F is rebuilt in O(n) each step
(``free_forest``), and the products with H_a in steps 2 and 4 run over a row's nonzeros alone
(its ancestors and its subtree). A step's factor then costs sum_F d_F(i)^2 / 2 multiply-adds
(d_F(i): the free joints on i's path) instead of m^3 / 6, but every inner step walks λ_F (a
dependent load), so it pays only from about a dozen joints on and while the paths are short:
``solve_mode`` takes it on a tree from TREE_FROM joints on where sum_i d_i^2 / 2 <= n^2
(``tree_pays``; measured, benchmarks/tree_drive_solve.py, docs/performance.md "The drive
solve on trees": Baxter 1.1-1.2 times faster than the dense path, eight 7-joint arms on a
waist 3.5-3.9 times; the two-arm torso, 9 joints, and arms of 20 joints and more keep the
dense paths). A singular free block is reported at the joint whose pivot fails, the pivots
taken tip to base. Chains compile none of it (``lam`` None: Numba drops those branches).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numba as nb
import numpy as np

from mrnea.kernels.layout import INLINE
from mrnea.kernels.solve import factor_remove

# from this many joints on, step 2's factor of H_FF is updated one joint at a time (O(m^2) a
# step: kernels/drive_solve.py, 'Cost'); below it, refactorised at every step (measured:
# benchmarks/long_chain.py, docs/performance.md)
UPDATE_FROM = 16
# a tree from this many joints on takes its own factorisation where it pays (``tree_pays``);
# below it the dense refactorising path is faster (measured: benchmarks/tree_drive_solve.py)
TREE_FROM = 12


class Refactor(NamedTuple):
    """A cycle's solve with H_FF factored afresh at every step (below UPDATE_FROM joints);
    ``mode``: PAPER or HYBRID."""
    mode: int


class Update(NamedTuple):
    """A cycle's solve with H_FF's factor updated one joint at a time (from UPDATE_FROM joints
    on); ``mode``: PAPER or HYBRID."""
    mode: int


class TreeRefactor(NamedTuple):
    """A tree's cycle solve: H_FF factored afresh at every step as L^T L in the order of the
    free joints' parent array λ_F (module docstring, 'Trees'); ``mode``: PAPER or HYBRID;
    ``parent`` (n,) int64, λ(i) (-1: the base); ``subend`` (n,) int64, the end of joint i's
    subtree [i, subend[i]) in depth-first order."""
    mode: int
    parent: np.ndarray
    subend: np.ndarray


def solve_mode(mode: int, n: int, update: bool | None = None,
               parents: Sequence[int] | None = None,
               tree: bool | None = None) -> Refactor | Update | TreeRefactor:
    """``mode`` (PAPER or HYBRID) in the form the kernels take for an n-joint robot whose
    joints hang from ``parents`` (λ(i), depth-first, -1: the base; None: a serial chain). On a
    tree (some λ(i) != i - 1) where the tree's factorisation pays (:func:`tree_pays`) it is
    ``TreeRefactor`` (module docstring, 'Trees'); else the way H_FF's factor is kept is chosen
    by n (kernels/drive_solve.py, 'Cost'). ``tree`` True or False, ``update`` True or False force a
    way (tests, benchmarks). Its class is the choice: a kernel compiles one way."""
    is_tree = parents is not None and any(p != i - 1 for i, p in enumerate(parents))
    if tree or (tree is None and update is None and is_tree and tree_pays(parents)):
        lam = np.asarray(parents, dtype=np.int64)
        end = np.arange(1, n + 1, dtype=np.int64)
        for i in range(n - 1, -1, -1):  # depth-first: a subtree is a contiguous range
            if lam[i] >= 0:
                end[lam[i]] = max(end[lam[i]], end[i])
        return TreeRefactor(mode, lam, end)
    return Update(mode) if (n >= UPDATE_FROM if update is None else update) else Refactor(mode)


def tree_pays(parents: Sequence[int]) -> bool:
    """Whether a tree's drive solve takes its own factorisation: from TREE_FROM joints on, if
    its factor's cost, sum_i d_i^2 / 2 multiply-adds (d_i: the joints carrying link i, i
    included), is at most n^2, about a step's cost on the updated path (measured:
    benchmarks/tree_drive_solve.py, docs/performance.md "The drive solve on trees")."""
    n, depth = len(parents), []
    for p in parents:
        depth.append(1 + (depth[p] if p >= 0 else 0))
    return n >= TREE_FROM and sum(d * d for d in depth) / 2 <= n * n


@nb.njit(**INLINE)
def drop_held(Ha, L, idx, m, pat, qdd, g, gabs, c, s):
    """Remove the joints held since the last step from the updated factor (positions from the
    last, so that those before stay put) and add their held qdd's columns to g, gabs; c, s (n,)
    scratch for the rotations. Returns the new number of free joints."""
    for a in range(m - 1, -1, -1):
        i = idx[a]
        if pat[i] % 2 == 1:
            factor_remove(L, idx, m, a, c, s)
            m -= 1
            shift_held(Ha[i], qdd[i], g, gabs)
    return m


@nb.njit(**INLINE)
def shift_held(row, c, g, gabs):
    """g += c row, gabs += |c row| (c < 0: gabs -= |c row|): a joint's column of H_a (its row:
    H_a is symmetric) times its held qdd c, added when it is held, taken away (-c) when it is
    released."""
    sign = 1.0 if c >= 0.0 else -1.0
    for k in range(g.shape[0]):
        t = c * row[k]
        g[k] += t
        gabs[k] += sign * abs(t)


@nb.njit(**INLINE)
def held_product(Ha, qdd, pat, g, gabs):
    """g = H_a qw and gabs = |H_a| |qw| afresh (qw: qdd on the held joints, 0 on the free
    ones), a held joint's row at a time; returns 0, the moves since."""
    for k in range(g.shape[0]):
        g[k] = gabs[k] = 0.0
    for j in range(g.shape[0]):
        if pat[j] % 2 == 1:
            shift_held(Ha[j], qdd[j], g, gabs)
    return 0


@nb.njit(**INLINE)
def free_residual(row, qdd, idx, m):
    """sum_a row[idx[a]] qdd[idx[a]] over the free joints idx[:m] and the sum of the terms'
    magnitudes, in four partial sums (as kernels/solve.py ``dot``)."""
    h0 = h1 = h2 = h3 = a0 = a1 = a2 = a3 = 0.0
    m4 = m - m % 4
    for a in range(0, m4, 4):
        i0, i1, i2, i3 = idx[a], idx[a + 1], idx[a + 2], idx[a + 3]
        t0, t1, t2, t3 = row[i0] * qdd[i0], row[i1] * qdd[i1], row[i2] * qdd[i2], \
            row[i3] * qdd[i3]
        h0, h1, h2, h3 = h0 + t0, h1 + t1, h2 + t2, h3 + t3
        a0, a1, a2, a3 = a0 + abs(t0), a1 + abs(t1), a2 + abs(t2), a3 + abs(t3)
    for a in range(m4, m):
        t = row[idx[a]] * qdd[idx[a]]
        h0 += t
        a0 += abs(t)
    return (h0 + h1) + (h2 + h3), (a0 + a1) + (a2 + a3)


@nb.njit(**INLINE)
def free_forest(lam, pat, idx, near, lam_f):
    """The free joints (pattern even) in index order, idx[:m], and their parent array λ_F by
    position, lam_f[:m]: lam_f[a] is the position of idx[a]'s nearest free ancestor (-1: none;
    docs/notation.md, Trees). ``near`` (n,) scratch: by joint, the position of its nearest free
    ancestor-or-self. Returns m. O(n)."""
    m = 0
    for i in range(lam.shape[0]):
        p = lam[i]
        up = near[p] if p >= 0 else -1
        if pat[i] % 2 == 0:
            idx[m] = i
            lam_f[m] = up
            near[i] = m
            m += 1
        else:
            near[i] = up
    return m


@nb.njit(**INLINE)
def held_row(Ha, qdd, pat, i, lam, nu):
    """(H_FW qdd_W)_i on a tree: row i of H_a is zero but for i's ancestors and its subtree
    [i, nu[i]) (branch-induced sparsity), so only those held joints are summed."""
    r = 0.0
    j = lam[i]
    while j >= 0:
        if pat[j] % 2 == 1:
            r += Ha[i, j] * qdd[j]
        j = lam[j]
    for j in range(i + 1, nu[i]):
        if pat[j] % 2 == 1:
            r += Ha[i, j] * qdd[j]
    return r


@nb.njit(**INLINE)
def tree_residual(Ha, ua, qdd, i, lam, nu):
    """:func:`_residual` on a tree: the sums over row i's nonzeros alone (i's ancestors and its
    subtree [i, nu[i]))."""
    h, scale = ua[i], abs(ua[i])
    j = lam[i]
    while j >= 0:
        t = Ha[i, j] * qdd[j]
        h += t
        scale += abs(t)
        j = lam[j]
    for j in range(i, nu[i]):
        t = Ha[i, j] * qdd[j]
        h += t
        scale += abs(t)
    return h, scale
