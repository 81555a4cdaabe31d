"""The report's state-by-state rigid-body terms and frames (mrnea.report.states), issue 22.

Against Pinocchio (RNEA, CRBA, nonLinearEffects, oMi) on random chains with prismatic joints,
real arms and a random tree; against the public batch functions to the bit (the figures' numbers
unchanged); and, on an empty Numba cache, that a simulation followed by Fig. 3's and the 3D
view's evaluations compiles no batch kernel and no second signature of the kernels it reuses.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pinocchio as pin
import pytest
from conftest import (
    COMPILE_LISTENER,
    COMPILE_REPORT,
    PinChain,
    compiled_kernels,
    random_states,
    rel_err,
    to_pinocchio,
)
from test_dynamics_pinocchio import B, get_case
from test_tree_pinocchio import random_tree

import mrnea
from mrnea.errors import StateError
from mrnea.report.states import link_frames, rigid_body_terms

TOL = 1e-9  # test_dynamics_pinocchio's
TOL_FRAMES = 1e-12  # test_kinematics's


def _check_against_pinocchio(robot: mrnea.Robot, pc: PinChain, s: dict) -> None:
    q, qd, qdd = s["q"], s["qd"], s["qdd"]
    u, H, ub = rigid_body_terms(robot, q, qd, qdd)
    T = link_frames(robot, q)
    assert u.shape == (len(q), robot.n) and H.shape == (len(q), robot.n, robot.n)
    assert T.shape == (len(q), robot.n + 1, 4, 4)
    for b in range(len(q)):
        assert rel_err(u[b], pc.rnea(q[b], qd[b], qdd[b])) <= TOL
        assert rel_err(H[b], pc.mass_matrix(q[b])) <= TOL
        assert rel_err(ub[b], pc.bias(q[b], qd[b])) <= TOL
        pin.forwardKinematics(pc.model, pc.data, pc.config(q[b]))
        ref = np.array([np.eye(4)] + [pc.data.oMi[i].homogeneous for i in pc.ids])
        assert rel_err(T[b], ref) <= TOL_FRAMES


@pytest.mark.parametrize("name", ["n1-prismatic", "n6-mixed", "ur5", "pr2-right-arm"])
def test_report_states_against_pinocchio(name: str) -> None:
    c = get_case(name)
    _check_against_pinocchio(c.robot, c.pc, {k: c.s[k][:30] for k in ("q", "qd", "qdd")})


def test_report_states_on_a_tree_against_pinocchio() -> None:
    rng = np.random.default_rng(41)
    robot = random_tree(rng, 7)
    _check_against_pinocchio(robot, PinChain(robot, to_pinocchio(robot)),
                             random_states(rng, robot, 25))


@pytest.mark.parametrize("name", ["n6-mixed", "ur5"])
def test_report_states_equal_the_public_batches_to_the_bit(name: str) -> None:
    """The same compiled code: Fig. 3 and the 3D view draw the numbers they drew before."""
    c = get_case(name)
    q, qd, qdd = c.s["q"], c.s["qd"], c.s["qdd"]
    u, H, ub = rigid_body_terms(c.robot, q, qd, qdd)
    H2, ub2 = mrnea.mass_matrix_and_bias(c.robot, q, qd)
    assert np.array_equal(u, mrnea.inverse_dynamics(c.robot, q, qd, qdd))
    assert np.array_equal(H, H2) and np.array_equal(ub, ub2)
    assert np.array_equal(link_frames(c.robot, q), mrnea.forward_kinematics(c.robot, q))
    # one state broadcast against a batch, read-only and strided inputs: as the public API
    q0 = q[0].copy()
    q0.flags.writeable = False
    u1, H1, _ = rigid_body_terms(c.robot, q0, qd[:, ::1][::2], qdd[::2])
    assert np.array_equal(u1, mrnea.inverse_dynamics(c.robot, q0, qd[::2], qdd[::2]))
    assert np.array_equal(H1, mrnea.mass_matrix_and_bias(c.robot, q0, qd[::2])[0])
    assert B == len(q)


def test_report_states_refuse_what_the_public_api_refuses() -> None:
    c = get_case("n6-mixed")
    q, qd, qdd = c.s["q"][:3], c.s["qd"][:3], c.s["qdd"][:3].copy()
    qdd[1, 2] = np.nan
    with pytest.raises(StateError, match=r"qdd: contains NaN or inf \(first at index \(1, 2\)\)"):
        rigid_body_terms(c.robot, q, qd, qdd)
    with pytest.raises(StateError, match="q: expected shape"):
        link_frames(c.robot, q[:, :2])
    with pytest.raises(StateError, match="batch sizes differ"):
        rigid_body_terms(c.robot, q, qd[:2], c.s["qdd"][:3])


FRESH = COMPILE_LISTENER + r"""
import numpy as np
import mrnea
from mrnea.report.states import link_frames, rigid_body_terms
from mrnea.trajectory import quintic
robot = mrnea.robots.sdt()
q0 = np.zeros(robot.n)
_, q_cmd = quintic([q0, q0 + 0.3], dt=0.01, velocity_limit=1.0, acceleration_limit=2.0)
res = mrnea.simulate(robot, q_cmd, dt=0.01)
event.register("numba:compile", Record())
rigid_body_terms(robot, res.q, res.qd, res.qdd)
link_frames(robot, res.q)
""" + COMPILE_REPORT


@pytest.mark.slow
def test_after_a_simulation_the_report_states_compile_only_the_frames(tmp_path) -> None:
    """Fresh process, empty Numba cache: once a simulation ran, Fig. 3's terms compile
    nothing and the frames compile ``frames_ws`` alone, with its check of a 3-D array's
    finiteness (no batch kernel, no second signature of ``rnea_ws`` or ``actuator_terms``):
    the point of mrnea.report.states (issue 22)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    out = subprocess.run([sys.executable, "-c", FRESH], env=env, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr[-2000:]
    compiled = compiled_kernels(out.stdout)
    names = sorted(name for name, _ in compiled)
    assert names in (["frames_ws"], ["finite", "frames_ws"]), compiled  # and its finite(out)
