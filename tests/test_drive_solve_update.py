"""The exact cycle solve with H_FF's Cholesky factor updated one joint at a time
(kernels/drive_solve.py ``solve_cycle`` with ``solve_mode(mode, n, update=True)``, kernels/solve.py
``factor_append`` / ``factor_remove``: issue 25, long chains) against independent references.

* The factor updates against numpy.linalg.cholesky of the same block, after random sequences
  of appends and removals.
* Small n forced onto the update path: brute-force enumeration of the law's cells
  (tests/drive_oracle.py), in test_drive_solve.py's loop (both paths, every state).
* n = 8 ... 60: the law's optimality (KKT) conditions checked directly from v
  (drive_oracle.law_violation), and the same solution as the refactorising path: the same
  saturated and stuck joints, v on the same breakpoints, qdd equal up to rounding.
"""

from __future__ import annotations

import numpy as np
import pytest
from drive_oracle import law_violation, rel, solve
from test_drive_solve import random_problem

from mrnea.kernels.drive_ways import UPDATE_FROM
from mrnea.kernels.solve import factor_append, factor_remove, factor_solve
from mrnea.kernels.status import OK

KEYS = ("Ha", "ua", "qd", "v_des", "dt", "Llo", "Lhi", "Fp", "Fn")


def test_factor_updates_equal_numpy_cholesky():
    rng = np.random.default_rng(2500)
    for trial in range(40):
        n = int(rng.integers(2, 40))
        A = rng.normal(size=(n, n)) * 10.0 ** rng.uniform(-2, 2, n)
        H = A @ A.T + 1e-3 * np.eye(n)
        L, idx = np.zeros((n, n)), np.zeros(n, np.int64)
        c, s, m = np.zeros(n), np.zeros(n), 0
        inside = np.zeros(n, bool)
        for _ in range(3 * n):
            if m > 0 and (m == n or rng.random() < 0.4):  # remove a random position
                p = int(rng.integers(m))
                inside[idx[p]] = False
                factor_remove(L, idx, m, p, c, s)
                m -= 1
            else:
                i = int(rng.choice(np.flatnonzero(~inside)))
                assert factor_append(H, L, idx, m, i)
                inside[i] = True
                m += 1
            J = idx[:m]
            assert sorted(J) == list(np.flatnonzero(inside))
            if m == 0:
                continue
            ref = np.linalg.cholesky(H[np.ix_(J, J)])
            assert rel(np.tril(L[:m, :m]), ref, floor=0.0) < 1e-9, f"trial {trial}"
            b, x = rng.normal(size=m), np.zeros(m)
            factor_solve(L, m, b, x)
            want = np.linalg.solve(H[np.ix_(J, J)], b)
            assert rel(x, want, floor=0.0) < 1e-12 * np.linalg.cond(H[np.ix_(J, J)])


def test_factor_append_refuses_a_singular_block():
    """A joint whose column depends on those in the factor (H singular there) is refused and
    the factor left as it was."""
    B = np.random.default_rng(2501).normal(size=(4, 3))
    H = B @ B.T  # rank 3
    L, idx = np.zeros((4, 4)), np.zeros(4, np.int64)
    for m in range(3):
        assert factor_append(H, L, idx, m, m)
    before = L.copy()
    assert not factor_append(H, L, idx, 3, 3)
    np.testing.assert_array_equal(L[:3], before[:3])


def _problem(rng, n):
    p = random_problem(rng, n)
    return [p[k] for k in KEYS], p["mode"]


@pytest.mark.parametrize("n", [8, 20, 60])
def test_update_path_satisfies_the_law_and_equals_refactorising(n):
    rng = np.random.default_rng(2510 + n)
    saturated = 0
    for s in range(60 if n < 60 else 25):
        args, mode = _problem(rng, n)
        v_des = args[3]
        a = solve(*args, mode, update=False)
        b = solve(*args, mode, update=True)
        where = f"n={n} state {s} ({mode})"
        assert a[0] == b[0] == OK, where
        assert law_violation(*args, mode, b[1]) < 1e-9, f"{where}: KKT (update)"
        assert law_violation(*args, mode, a[1]) < 1e-9, f"{where}: KKT (refactorise)"
        # the same active set: the same joints on the program, at rest, saturated
        np.testing.assert_array_equal(b[1] == v_des, a[1] == v_des, err_msg=where)
        np.testing.assert_array_equal(b[1] == 0.0, a[1] == 0.0, err_msg=where)
        np.testing.assert_array_equal(b[6], a[6], err_msg=where)
        np.testing.assert_array_equal(b[7], a[7], err_msg=where)
        # rounding: the refactorised and the updated factor of H_FF, whose condition number
        # reaches 1e6 in these problems
        assert rel(b[2], a[2]) < 1e-10, f"{where}: qdd"
        for k in (3, 4, 5):  # tau, phi, tau_req
            assert rel(b[k], a[k]) < 1e-10, f"{where}: output {k}"
        saturated += int(np.sum(b[6]))
    assert saturated > 3 * n, saturated  # the states exercise the active set


def test_default_path_by_size():
    """solve_mode takes the update path from UPDATE_FROM joints on: its result is bit for bit
    that path's, and below it the refactorising path's."""
    rng = np.random.default_rng(2520)
    for n in (UPDATE_FROM - 1, UPDATE_FROM):
        for _ in range(10):
            args, mode = _problem(rng, n)
            d = solve(*args, mode)
            f = solve(*args, mode, update=n >= UPDATE_FROM)
            for x, y in zip(d[1:], f[1:], strict=True):
                np.testing.assert_array_equal(x, y)


def test_a_saturated_100_joint_chain_keeps_its_running_product():
    """A 100-joint random chain with every drive far below its requirement: many
    active-set steps, each moving a joint in or out of the held set, so the running product
    H_a qw (kernels/drive_solve.py, 'Cost') is shifted and made afresh many times. The
    updated way satisfies the law (KKT from v) and equals the refactorising way."""
    from conftest import random_chain

    from mrnea import mass_matrix_and_bias

    rng = np.random.default_rng(2530)
    n = 100
    robot = random_chain(rng, n, 0.25)
    for s in range(3):
        q, qd = rng.uniform(-np.pi, np.pi, n), rng.normal(0.0, 0.5, n)
        H, u = mass_matrix_and_bias(robot, q, qd)
        dt = 1e-3
        v_des = qd + dt * rng.normal(0.0, 5000.0, n)
        L = 0.1 * np.abs(u) + 0.1
        z = np.zeros(n)
        args = [H, u, qd, v_des, dt, L, L, z, z]
        a = solve(*args, "hybrid", update=False)
        b = solve(*args, "hybrid", update=True)
        assert a[0] == b[0] == OK
        assert int(b[6].sum()) > n // 2, int(b[6].sum())  # most drives saturate
        assert law_violation(*args, "hybrid", b[1]) < 1e-9, f"state {s}"
        np.testing.assert_array_equal(b[6], a[6])
        assert rel(b[2], a[2]) < 1e-9, f"state {s}: qdd"


def test_forward_substitution_kept_across_an_append():
    """The kept forward substitution of the updated way (kernels/drive_solve.py 'Cost'): after
    ``factor_append`` of joint j, y = L^-1 rhs for a right-hand side that moved by c H[F, j]
    is the old y plus c times the new row's l, and ``factor_forward`` from row m solves the
    new row alone; both against numpy.linalg.solve on the grown block."""
    from mrnea.kernels.solve import factor_forward

    rng = np.random.default_rng(2540)
    for trial in range(30):
        n = int(rng.integers(2, 30))
        A = rng.normal(size=(n, n))
        H = A @ A.T + 0.1 * np.eye(n)
        order = rng.permutation(n)
        L, idx = np.zeros((n, n)), np.zeros(n, np.int64)
        for m, i in enumerate(order[:-1]):
            assert factor_append(H, L, idx, m, i)
        m, j = n - 1, order[-1]
        F = idx[:m].copy()
        r = rng.normal(size=m)
        y = np.zeros(n)
        factor_forward(L, 0, m, r, y)
        assert factor_append(H, L, idx, m, j)
        c = rng.normal()
        y[:m] += c * L[m, :m]  # the caller's move of the old rows
        r_new = np.append(r + c * H[F, j], rng.normal())
        factor_forward(L, m, m + 1, r_new, y)
        Lf = np.tril(L[:n, :n])
        assert rel(y, np.linalg.solve(Lf, r_new), floor=0.0) < 1e-10, f"trial {trial}"
        assert rel(Lf @ Lf.T, H[np.ix_(idx, idx)], floor=0.0) < 1e-12, f"trial {trial}"
