"""The exact cycle solve on a tree (kernels/drive_solve.py ``TreeRefactor``: H_FF = L^T L in the
order of the free joints' parent array λ_F, kernels/solve.py ``ltl_factor``) against
independent references.

* The factor on a free forest: random tree-sparse SPD matrices and random sets of free joints,
  λ_F found here by walking the parent array; L^T L equals H_FF, x equals numpy.linalg.solve,
  and no entry off the paths of λ_F is read or written (the factor keeps the branch sparsity).
* n = 2 ... 6: brute-force enumeration of the law's cells (tests/drive_oracle.py) on random
  trees, H_a and u'_a from Pinocchio (CRBA, nonlinear effects) plus rotors and viscous
  friction, or random tree-sparse SPD matrices with condition numbers up to 1e6; every path
  forced (dense refactorised, updated, the tree's) and each equal to the oracle.
* n = 8 ... 60, Baxter's shape (three chains from the base) and the Allegro hand's (four
  fingers): the law's optimality conditions from v (drive_oracle.law_violation), and the same
  solution as the dense path.
* ``solve_mode``: a tree takes the tree's path where its factor's flop count says it pays
  (counted here from the parent array), a chain and other trees the paths they took before;
  the subtree ends against the descendants found by walking the parent array.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PinChain, to_pinocchio
from drive_oracle import enumerate_solutions, law_violation, rel, solve
from test_drive_solve import random_problem
from test_tree_pinocchio import random_tree

from mrnea.kernels.drive_ways import (
    TREE_FROM,
    UPDATE_FROM,
    Refactor,
    TreeRefactor,
    Update,
    solve_mode,
)
from mrnea.kernels.solve import ltl_factor, ltl_substitute
from mrnea.kernels.status import OK

KEYS = ("Ha", "ua", "qd", "v_des", "dt", "Llo", "Lhi", "Fp", "Fn")
STATES = {2: 150, 3: 150, 4: 150, 5: 120, 6: 80}


def random_parents(rng: np.random.Generator, n: int) -> list[int]:
    """A random depth-first parent array: joint i hangs from the base or from a joint on the
    path to joint i - 1."""
    parents: list[int] = []
    for i in range(n):
        path, k = [-1], i - 1
        while k >= 0:
            path.append(k)
            k = parents[k]
        parents.append(int(rng.choice(path)))
    return parents


def path(parents, i: int) -> list[int]:
    """i and its ancestors, tip to base."""
    out = []
    while i >= 0:
        out.append(i)
        i = parents[i]
    return out


def tree_spd(rng: np.random.Generator, parents) -> np.ndarray:
    """A random SPD matrix with the tree's sparsity: L^T L, L_ik random for k on i's path
    (so (L^T L)_jk != 0 only where one of j, k carries the other), condition number up to
    about 1e6."""
    n = len(parents)
    L = np.zeros((n, n))
    for i in range(n):
        for k in path(parents, i):
            L[i, k] = rng.normal()
        L[i, i] = abs(L[i, i]) + 0.1
    L *= 10.0 ** rng.uniform(0.0, 3.0 * rng.random(), n)[:, None]
    return L.T @ L * 10.0 ** rng.uniform(-2, 2)


def is_tree(parents) -> bool:
    return any(p != i - 1 for i, p in enumerate(parents))


def tree_terms(rng: np.random.Generator, n: int):
    """(parents, terms): a random tree (not a chain) and a maker of its cycle's (H_a, u'_a)
    from qd: 60 % a random tree robot through Pinocchio (CRBA + G^2 J_m, nonlinear effects +
    F_v qd), else a random tree-sparse SPD H_a with gravity-like u'_a."""
    if rng.random() < 0.6:
        robot = random_tree(rng, n)
        while robot.is_serial:
            robot = random_tree(rng, n)
        gear, rotor = rng.choice([1.0, 10.0, 50.0], n), rng.choice([0.0, 1e-5, 1e-4], n)
        fv = rng.uniform(0.0, 2.0, n)
        pc = PinChain(robot, to_pinocchio(robot))
        q = rng.uniform(-np.pi, np.pi, n)

        def terms(qd):
            return (pc.mass_matrix(q) + np.diag(gear**2 * rotor), pc.bias(q, qd) + fv * qd)
        return list(robot.parents), terms
    parents = random_parents(rng, n)
    while not is_tree(parents):
        parents = random_parents(rng, n)
    Ha = tree_spd(rng, parents)
    return parents, lambda qd: (Ha, Ha @ rng.normal(0.0, 10.0, n) + rng.normal(0.0, 5.0, n))


def tree_problem(rng: np.random.Generator, n: int) -> tuple[list[int], list, str]:
    parents, terms = tree_terms(rng, n)
    p = random_problem(rng, n, terms)
    return parents, [p[k] for k in KEYS], p["mode"]


def test_ltl_on_a_free_forest_equals_numpy():
    rng = np.random.default_rng(2530)
    for trial in range(60):
        n = int(rng.integers(1, 30))
        parents = random_parents(rng, n)
        H = tree_spd(rng, parents)
        free = np.flatnonzero(rng.random(n) < rng.uniform(0.3, 1.0))
        if free.size == 0:
            continue
        m, pos = free.size, {int(j): a for a, j in enumerate(free)}
        lam_f = np.array([next((pos[k] for k in path(parents, int(j))[1:] if k in pos), -1)
                          for j in free])  # nearest free ancestor, by position
        on_path = np.zeros((m, m), bool)
        L = np.full((m, m), np.nan)
        for a in range(m):
            c = a
            while c >= 0:
                on_path[a, c] = True
                L[a, c] = H[free[a], free[c]]
                c = lam_f[c]
        HFF = H[np.ix_(free, free)]
        assert np.all(HFF[~(on_path | on_path.T)] == 0.0)  # the sparsity λ_F keeps
        assert ltl_factor(lam_f, L) == OK, f"trial {trial}"
        assert np.isnan(L[~on_path]).all() and np.isfinite(L[on_path]).all()
        F = np.where(on_path, L, 0.0)
        F[np.diag_indices(m)] = 1.0 / np.diag(L)  # the diagonal holds the reciprocal pivots
        assert rel(F.T @ F, HFF, floor=0.0) < 1e-12, f"trial {trial}"
        b, x = rng.normal(size=m), np.zeros(m)
        ltl_substitute(lam_f, L, b, x)
        assert rel(x, np.linalg.solve(HFF, b), floor=0.0) < 1e-12 * np.linalg.cond(HFF)


@pytest.mark.parametrize("n", sorted(STATES))
def test_every_path_on_trees_equals_enumeration(n):
    rng = np.random.default_rng(2540 + n)
    saturated = 0
    for s in range(STATES[n]):
        parents, args, mode = tree_problem(rng, n)
        sols, tau_req = enumerate_solutions(*args, mode)
        assert sols, f"state {s}: no consistent pattern"
        qd, dt = args[2], args[4]
        v0, tau0, phi0, _ = sols[0]
        qdd0 = (v0 - qd) / dt
        for way, update, tree in (("dense", False, None), ("update", True, None),
                                  ("tree", None, True)):
            where = f"n={n} state {s} ({mode}, {way}, parents {parents})"
            status, v, qdd, tau, phi, treq, sat, _ = solve(*args, mode, update, parents, tree)
            assert status == OK, f"{where}: status {status}"
            assert rel(qdd, qdd0) < 1e-9, f"{where}: qdd {qdd} vs {qdd0}"
            assert rel(v, v0, floor=dt) < 1e-9, f"{where}: v"
            assert rel(treq, tau_req) < 1e-12, f"{where}: tau_req"
            assert rel(tau, tau0) < 1e-9, f"{where}: tau"
            assert rel(phi, phi0) < 1e-9, f"{where}: phi"
            assert rel(tau - phi, args[0] @ qdd + args[1]) < 1e-9, f"{where}: Eq. 42"
        saturated += int(np.sum(sat))
    assert saturated > STATES[n] // 2, saturated


def shaped(rng: np.random.Generator, name: str) -> list[int]:
    """Parent arrays of Baxter's shape (head pan, two 7-joint arms, all from the base) and the
    Allegro hand's (four 4-joint fingers from the palm)."""
    if name == "baxter":
        return [-1, -1, *range(1, 7), -1, *range(8, 14)]
    return [p for f in range(4) for p in (-1, 4 * f, 4 * f + 1, 4 * f + 2)]


@pytest.mark.parametrize("n", [8, 20, 60, "baxter", "allegro"])
def test_tree_path_satisfies_the_law_and_equals_dense(n):
    rng = np.random.default_rng(2550 + (n if isinstance(n, int) else len(n)))
    saturated = 0
    for s in range(40 if n != 60 else 15):
        if isinstance(n, str):
            parents = shaped(rng, n)
            Ha = tree_spd(rng, parents)
            k = len(parents)
            p = random_problem(rng, k, lambda qd, Ha=Ha, k=k: (
                Ha, Ha @ rng.normal(0.0, 10.0, k) + rng.normal(0.0, 5.0, k)))
            args, mode = [p[key] for key in KEYS], p["mode"]
        else:
            parents, args, mode = tree_problem(rng, n)
        a = solve(*args, mode, False)
        b = solve(*args, mode, None, parents, True)
        where = f"n={n} state {s} ({mode})"
        assert a[0] == b[0] == OK, where
        assert law_violation(*args, mode, b[1]) < 1e-9, f"{where}: KKT (tree)"
        if mode == "hybrid":  # on the program exactly (in PAPER v_des is no breakpoint)
            np.testing.assert_array_equal(b[1] == args[3], a[1] == args[3], err_msg=where)
        np.testing.assert_array_equal(b[1] == 0.0, a[1] == 0.0, err_msg=where)
        np.testing.assert_array_equal(b[6], a[6], err_msg=where)
        np.testing.assert_array_equal(b[7], a[7], err_msg=where)
        for k in (2, 3, 4, 5):  # qdd, tau, phi, tau_req
            assert rel(b[k], a[k]) < 1e-10, f"{where}: output {k}"
        saturated += int(np.sum(b[6]))
    assert saturated > 40, saturated


def test_a_singular_free_block_on_a_tree_names_its_joint():
    """A joint whose row and column of H_a are zero (a massless, rotorless leaf), free from the
    start (PAPER, no drive, no friction): every path reports that joint."""
    rng = np.random.default_rng(2560)
    parents = [-1, 0, 1, 0, 3, -1, 5]
    n = len(parents)
    for leaf in (2, 4, 6):
        Ha = tree_spd(rng, parents)
        Ha[leaf, :] = Ha[:, leaf] = 0.0
        z = np.zeros(n)
        args = [Ha, rng.normal(size=n), z, z + 1e-3, 1e-3, z, z, z, z]
        for update, tree in ((False, None), (True, None), (None, True)):
            assert solve(*args, "paper", update, parents, tree)[0] == leaf, (leaf, update, tree)


def test_solve_mode_takes_the_trees_path_where_it_pays():
    """The tree's path where its factor costs at most n^2 multiply-adds (sum of the squared
    depths over 2, counted here by walking the parent array) from TREE_FROM joints on; a chain,
    a small tree and a tree of long arms keep the dense paths, by n as before trees."""
    rng = np.random.default_rng(2570)
    arms = [-1, *range(0, 50), 0, *range(51, 100)]  # two 50-joint arms on a waist: long paths
    cases = [shaped(rng, "baxter"), shaped(rng, "allegro"), list(range(-1, 19)), arms,
             [-1, 0, 1, 2, 3, 0, 5, 6, 7]]  # the two-arm torso: under TREE_FROM
    cases += [random_parents(rng, int(rng.integers(2, 40))) for _ in range(30)]
    for parents in cases:
        n = len(parents)
        flops = sum(len(path(parents, i)) ** 2 for i in range(n)) / 2
        pays = is_tree(parents) and n >= TREE_FROM and flops <= n * n
        how = solve_mode(1, n, parents=parents)
        if pays:
            assert type(how) is TreeRefactor and how.mode == 1
        else:
            assert type(how) is (Update if n >= UPDATE_FROM else Refactor), parents
        assert type(solve_mode(0, n, update=True, parents=parents)) is Update
        assert type(solve_mode(0, n, update=False, parents=parents)) is Refactor
    assert type(solve_mode(1, 15, parents=cases[0])) is TreeRefactor  # Baxter
    assert type(solve_mode(1, 101, parents=arms)) is Update


def test_the_trees_path_knows_each_subtree():
    rng = np.random.default_rng(2571)
    for _ in range(30):
        n = int(rng.integers(2, 40))
        parents = random_parents(rng, n)
        how = solve_mode(1, n, parents=parents, tree=True)
        assert type(how) is TreeRefactor and how.mode == 1
        np.testing.assert_array_equal(how.parent, parents)
        for i in range(n):  # the subtree [i, subend[i]): exactly i's descendants and i
            below = [j for j in range(n) if i in path(parents, j)]
            assert below == list(range(i, how.subend[i]))
