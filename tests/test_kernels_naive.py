"""Each dynamics kernel, called directly on compiled arrays, against tests/naive.py (a slow NumPy
reference that shares no code with the kernels: spatial Newton-Euler, H from centre-of-mass
Jacobians, an LU solve): ``rnea`` and ``reactions`` (efforts, joint wrenches), ``mrnea``,
``walker_orin`` and ``crba_bias``/``crba`` (H and u'), ``fd_mrnea``, ``aba`` and the engines'
forward dynamics (qdd). The public API is checked against the same reference in
test_dynamics_properties.py; this module pins each kernel, its batch loop included.

Random chains (conftest.random_chain) of 1 to 12 joints, revolute and prismatic, with and
without an external wrench. Tolerances (``conftest.rel_err``): 1e-9 for efforts, H and u'
(``TOL_REF`` of test_dynamics_properties.py); for accelerations the solve's bound
``1e-13 cond(H) max(1, |qdd|)`` (test_dynamics_properties.fd_tolerance).
"""

from __future__ import annotations

import naive
import numba as nb
import numpy as np
import pytest
from conftest import random_chain, random_states, rel_err

from mrnea.kernels.aba import aba, aba_batch
from mrnea.kernels.crba import crba, crba_bias
from mrnea.kernels.engines import (
    ENGINE_CRBA,
    ENGINE_MRNEA,
    ENGINE_WALKER_ORIN,
    fd_batch,
    fd_crba,
    fd_walker_orin,
    mass_matrix_bias_batch,
)
from mrnea.kernels.layout import batch_scratch, compile_model, entry_scratch
from mrnea.kernels.mrnea import fd_mrnea, mrnea
from mrnea.kernels.rnea import reactions, reactions_batch, rnea, rnea_batch
from mrnea.kernels.status import OK
from mrnea.kernels.walker_orin import walker_orin

TOL_REF = 1e-9
CASES = [(1, 0.0), (2, 1.0), (3, 0.5), (6, 0.0), (7, 0.3), (12, 0.4)]  # (n, prismatic fraction)
HB_KERNELS = {"mrnea": mrnea, "walker_orin": walker_orin, "crba_bias": crba_bias}
FD_KERNELS = {"fd_mrnea": fd_mrnea, "fd_walker_orin": fd_walker_orin, "fd_crba": fd_crba,
              "aba": aba}


def _states(n: int, frac: float, with_fext: bool, count: int = 5):
    """(robot, compiled model, states): ``count`` random states, the wrench zero or random."""
    rng = np.random.default_rng(1000 * n + int(10 * frac) + with_fext)
    robot = random_chain(rng, n, frac)
    states = []
    for _ in range(count):
        s = random_states(rng, robot)
        if not with_fext:
            s["f_ext"], s["f_ext_point"] = np.zeros(6), np.zeros(3)
        states.append(s)
    return robot, compile_model(robot), states


def _fd_tolerance(H: np.ndarray, qdd: np.ndarray) -> float:
    return 1e-13 * np.linalg.cond(H) * max(1.0, float(np.max(np.abs(qdd))))


@pytest.mark.parametrize("with_fext", [False, True])
@pytest.mark.parametrize("n, frac", CASES)
def test_rnea_and_reactions_kernels_against_naive(n, frac, with_fext):
    robot, m, states = _states(n, frac, with_fext)
    for s in states:
        args = (s["q"], s["qd"], s["qdd"], s["f_ext"], s["f_ext_point"])
        tau, W = np.empty(n), np.empty((n, 6))
        assert rnea(m, *args, tau, entry_scratch(n)) == OK
        assert reactions(m, *args, W, entry_scratch(n)) == OK
        assert rel_err(tau, naive.inverse_dynamics(robot, *args)) <= TOL_REF
        assert rel_err(W, naive.joint_reactions(robot, *args)) <= TOL_REF


@pytest.mark.parametrize("kernel", HB_KERNELS)
@pytest.mark.parametrize("with_fext", [False, True])
@pytest.mark.parametrize("n, frac", CASES)
def test_mass_matrix_and_bias_kernels_against_naive(kernel, n, frac, with_fext):
    robot, m, states = _states(n, frac, with_fext)
    for s in states:
        q, qd, fe, pe = s["q"], s["qd"], s["f_ext"], s["f_ext_point"]
        H, u = np.empty((n, n)), np.empty(n)
        assert HB_KERNELS[kernel](m, q, qd, fe, pe, H, u, entry_scratch(n)) == OK
        assert rel_err(H, naive.mass_matrix_jacobian(robot, q)) <= TOL_REF
        assert rel_err(u, naive.bias(robot, q, qd, fe, pe)) <= TOL_REF


@pytest.mark.parametrize("n, frac", CASES)
def test_crba_mass_matrix_against_naive(n, frac):
    robot, m, states = _states(n, frac, False)
    for s in states:
        H = np.empty((n, n))
        crba(m, s["q"], H)
        assert rel_err(H, naive.mass_matrix_jacobian(robot, s["q"])) <= TOL_REF
        assert rel_err(H, naive.mass_matrix_columns(robot, s["q"])) <= TOL_REF


@pytest.mark.parametrize("kernel", FD_KERNELS)
@pytest.mark.parametrize("with_fext", [False, True])
@pytest.mark.parametrize("n, frac", CASES)
def test_forward_dynamics_kernels_against_naive(kernel, n, frac, with_fext):
    robot, m, states = _states(n, frac, with_fext)
    for s in states:
        q, qd, tau, fe, pe = s["q"], s["qd"], s["tau"], s["f_ext"], s["f_ext_point"]
        qdd = np.empty(n)
        assert FD_KERNELS[kernel](m, q, qd, tau, fe, pe, qdd, entry_scratch(n)) == OK
        ref = naive.forward_dynamics(robot, q, qd, tau, fe, pe)
        err = float(np.max(np.abs(qdd - ref)))
        assert err <= _fd_tolerance(naive.mass_matrix_jacobian(robot, q), ref), err


@pytest.mark.parametrize("threads", [1, nb.config.NUMBA_NUM_THREADS])
@pytest.mark.parametrize("n, frac", [(1, 0.0), (5, 0.4), (9, 0.2)])
def test_batch_kernels_against_naive(n, frac, threads):
    """The batch loops (one scratch per thread, the engine picked by its code) give each state
    the naive result on one thread and on all: rnea, reactions, H and u' by every engine, qdd
    by every method."""
    robot, m, states = _states(n, frac, True, count=70)  # many more states than threads
    before = nb.get_num_threads()
    nb.set_num_threads(threads)  # for the stack (one scratch a thread) and the kernels
    try:
        ws = batch_scratch(n)
        assert ws[0].shape[0] == threads
        _check_batches(robot, m, states, ws)
    finally:
        nb.set_num_threads(before)


def _check_batches(robot, m, states, ws):
    n = robot.n
    Q, QD, QDD, TAU, FE, PE = (np.array([s[k] for s in states]) for k in
                               ("q", "qd", "qdd", "tau", "f_ext", "f_ext_point"))
    B = len(states)
    status = np.empty(B, dtype=np.int64)
    tau, W = np.empty((B, n)), np.empty((B, n, 6))
    rnea_batch(m, Q, QD, QDD, FE, PE, tau, status, ws)
    assert (status == OK).all()
    reactions_batch(m, Q, QD, QDD, FE, PE, W, status, ws)
    assert (status == OK).all()
    H_ref = [naive.mass_matrix_jacobian(robot, q) for q in Q]
    for b in range(B):
        args = (Q[b], QD[b], QDD[b], FE[b], PE[b])
        assert rel_err(tau[b], naive.inverse_dynamics(robot, *args)) <= TOL_REF
        assert rel_err(W[b], naive.joint_reactions(robot, *args)) <= TOL_REF
    for engine in (ENGINE_MRNEA, ENGINE_WALKER_ORIN, ENGINE_CRBA):
        H, u = np.empty((B, n, n)), np.empty((B, n))
        mass_matrix_bias_batch(m, Q, QD, FE, PE, H, u, status, ws, engine)
        assert (status == OK).all()
        for b in range(B):
            assert rel_err(H[b], H_ref[b]) <= TOL_REF, engine
            assert rel_err(u[b], naive.bias(robot, Q[b], QD[b], FE[b], PE[b])) <= TOL_REF
    for method in (ENGINE_MRNEA, ENGINE_WALKER_ORIN, ENGINE_CRBA, "aba"):
        qdd = np.empty((B, n))
        if method == "aba":
            aba_batch(m, Q, QD, TAU, FE, PE, qdd, status, ws)
        else:
            fd_batch(m, Q, QD, TAU, FE, PE, qdd, status, ws, method)
        assert (status == OK).all()
        for b in range(B):
            ref = naive.forward_dynamics(robot, Q[b], QD[b], TAU[b], FE[b], PE[b])
            assert np.max(np.abs(qdd[b] - ref)) <= _fd_tolerance(H_ref[b], ref), method
