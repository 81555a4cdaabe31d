"""The single-state entries call the passes with the loops' types (kernels/entry.py, issue 22).

Against Pinocchio (RNEA, CRBA, nonLinearEffects, ABA) on a chain and a tree, one state at a
time through the fast path, with C arrays and with strided views (the entry's LAYOUT status
sends those to the validated path); to the bit against the batch functions' rows (one compiled
pass serves both, so the no-wrench state and the batch's zero wrench give the same floats);
and, on an empty Numba cache, that the single-state calls and the batches compile each pass
(``rnea_ws``, ``reactions_ws``, ``newton_euler``, the kinematics, the mRNEA's ``pass_of``) once.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from conftest import (
    COMPILE_LISTENER,
    COMPILE_REPORT,
    PinChain,
    compiled_kernels,
    rel_err,
    to_pinocchio,
)
from test_dynamics_pinocchio import get_case
from test_tree_pinocchio import random_tree

import mrnea

TOL = 1e-9  # test_dynamics_pinocchio's


def _single_calls(robot: mrnea.Robot, q, qd, qdd, tau) -> list[np.ndarray]:
    H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
    return [mrnea.inverse_dynamics(robot, q, qd, qdd), H, u,
            mrnea.forward_dynamics(robot, q, qd, tau), mrnea.joint_reactions(robot, q, qd, qdd)]


@pytest.mark.parametrize("name", ["n6-mixed", "ur5"])
def test_single_states_against_pinocchio_and_the_batch(name: str) -> None:
    c = get_case(name)
    robot, pc = c.robot, c.pc
    Q, QD, QDD = (np.ascontiguousarray(c.s[k][:8]) for k in ("q", "qd", "qdd"))
    TAU = np.array([pc.rnea(q, qd, qdd) for q, qd, qdd in zip(Q, QD, QDD, strict=True)])
    H_b, u_b = mrnea.mass_matrix_and_bias(robot, Q, QD)
    batch = [mrnea.inverse_dynamics(robot, Q, QD, QDD), H_b, u_b,
             mrnea.forward_dynamics(robot, Q, QD, TAU), mrnea.joint_reactions(robot, Q, QD, QDD)]
    wide = np.zeros((4, 2 * robot.n))
    for b in range(len(Q)):
        want = [TAU[b], pc.mass_matrix(Q[b]), pc.bias(Q[b], QD[b]), QDD[b]]
        wide[:, ::2] = Q[b], QD[b], QDD[b], TAU[b]
        for args in ((Q[b], QD[b], QDD[b], TAU[b]), tuple(wide[:, ::2])):  # C, then strided
            got = _single_calls(robot, *args)
            for g, w in zip(got, want, strict=False):
                assert rel_err(g, w) <= TOL
            for g, row in zip(got, batch, strict=True):
                np.testing.assert_array_equal(g, row[b])  # the same compiled pass, bit for bit


def test_a_tree_single_state_against_pinocchio() -> None:
    rng = np.random.default_rng(7)
    robot = random_tree(rng, 9, 0.3)
    pc = PinChain(robot, to_pinocchio(robot))
    n = robot.n
    for _ in range(5):
        q, qd, qdd = rng.uniform(-1, 1, (3, n))
        tau = pc.rnea(q, qd, qdd)
        H, u = mrnea.mass_matrix_and_bias(robot, q, qd)
        assert rel_err(mrnea.inverse_dynamics(robot, q, qd, qdd), tau) <= TOL
        assert rel_err(H, pc.mass_matrix(q)) <= TOL
        assert rel_err(u, pc.bias(q, qd)) <= TOL
        assert rel_err(mrnea.forward_dynamics(robot, q, qd, tau), qdd) <= TOL


FRESH = COMPILE_LISTENER + r"""
event.register("numba:compile", Record())
import numpy as np
import mrnea
robot = mrnea.robots.puma560()
q, qd, qdd = np.zeros(robot.n), np.ones(robot.n), np.ones(robot.n)
mrnea.inverse_dynamics(robot, q, qd, qdd)
mrnea.mass_matrix_and_bias(robot, q, qd)
mrnea.forward_dynamics(robot, q, qd, qdd)
mrnea.joint_reactions(robot, q, qd, qdd)
Q = np.random.default_rng(0).uniform(-1, 1, (50, robot.n))
mrnea.inverse_dynamics(robot, Q, Q, Q)
mrnea.joint_reactions(robot, Q, Q, Q)
mrnea.mass_matrix_and_bias(robot, Q, Q)
""" + COMPILE_REPORT


@pytest.mark.slow
def test_single_states_and_batches_compile_each_pass_once(tmp_path) -> None:
    """Fresh process, empty Numba cache: the four single-state calls and three batches compile
    one ``rnea_ws``, ``reactions_ws``, ``newton_euler``, ``kinematics`` and ``pass_of`` (the
    entries took layout ``A`` and no wrench, which compiled a second copy of each), and none of
    them on an array of layout ``A``."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    out = subprocess.run([sys.executable, "-c", FRESH], env=env, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    compiled = compiled_kernels(out.stdout)
    for name in ("rnea_ws", "reactions_ws", "newton_euler", "kinematics", "pass_of"):
        sigs = [sig for k, sig in compiled if k == name]
        assert len(sigs) == 1, (name, sigs)
        assert "'A'" not in sigs[0], (name, sigs)
    entries = {k for k, _ in compiled} & {"rnea", "mrnea", "fd_mrnea", "reactions"}
    assert entries == {"rnea", "mrnea", "fd_mrnea", "reactions"}  # the listener saw them
