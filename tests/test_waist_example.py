"""The branching example of issue 25: a torso on a waist joint carrying two arms
(``examples/waist_two_arms.urdf``), and a program in which the left arm's fast swing loads the
waist through the torso until it saturates (``examples/waist_left_swing.toml``, joints by name).

Oracle: a Python loop driven by Pinocchio's own model of the same URDF (``pinocchio.rnea`` for
the efforts a cycle asks for, ``pinocchio.aba`` for the motion the clipped efforts make,
semi-implicit Euler as docs/simulation.md states the cycle), compared with ``simulate`` cycle
by cycle: positions, velocities, efforts, the waist's above all.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, rel_err

import mrnea
from mrnea.simulate import simulate

pin = pytest.importorskip("pinocchio")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
URDF = EXAMPLES / "waist_two_arms.urdf"
PROGRAM = EXAMPLES / "waist_left_swing.toml"


@pytest.fixture(scope="module")
def setup():
    prog = mrnea.load_program(PROGRAM)
    robot = prog.load_robot()
    model = pin.buildModelFromUrdf(str(URDF))  # its own gravity, -9.81 m/s^2 along z
    # the same joints in the same order (depth first, children in file order), 1 dof each
    assert [model.names[i] for i in range(1, model.njoints)] == list(robot.joint_names)
    assert model.nq == model.nv == robot.n == 9
    assert np.allclose(model.gravity.linear, robot.gravity)
    # a URDF has no rotor inertia nor friction: the cycle is rigid-body dynamics alone
    assert not np.any(robot.rotor_inertia) and not np.any(robot.viscous_friction)
    assert not np.any(robot.coulomb_friction)
    return prog, robot, model


@pytest.mark.parametrize("fd", ["mrnea", "walker_orin", "crba"])
def test_the_waist_saturates_through_the_coupling_paper_mode_against_pinocchio(setup, fd) -> None:
    """Every way a cycle forms H and u' (``simulate(fd=...)``) on the tree, the same loop."""
    prog, robot, model = setup
    data = model.createData()
    dt, q_cmd = prog.dt, prog.q_cmd
    K = q_cmd.shape[0]
    res = simulate(robot, q_cmd, dt, mode="paper", fd=fd)
    assert not res.position_clamped.any()
    L, vmax = robot.effort_limit, robot.velocity_limit
    q, qd = q_cmd[0].copy(), np.zeros(robot.n)
    waist_req = np.empty(K - 1)
    for k in range(K - 1):
        assert rel_err(res.q[k], q) < 1e-9 and rel_err(res.qd[k], qd) < 1e-9, f"cycle {k}"
        v = np.clip((q_cmd[k + 1] - q_cmd[k]) / dt, -vmax, vmax)
        tau_req = pin.rnea(model, data, q, qd, (v - qd) / dt)
        tau = np.clip(tau_req, -L, L)
        assert rel_err(res.tau[k], tau) < 1e-9, f"cycle {k}: tau"
        waist_req[k] = tau_req[0]
        qd = qd + pin.aba(model, data, q, qd, tau) * dt
        q = q + qd * dt
    # the waist is commanded to stay still, yet the left arm's swing asks more of it than its
    # limit (Pinocchio's own numbers), and only the waist saturates
    assert np.all(q_cmd[:, 0] == 0.0)
    assert np.max(np.abs(waist_req)) > 1.05 * L[0]
    assert res.saturated[:, 0].any() and not res.saturated[:, 1:].any()


def test_hybrid_mode_every_cycle_is_pinocchio_dynamics_and_the_verdict_names_the_waist(setup):
    prog, robot, model = setup
    data = model.createData()
    res = simulate(robot, prog.q_cmd, prog.dt)  # hybrid, the default
    L = robot.effort_limit
    for k in range(res.q.shape[0] - 1):
        tau = pin.rnea(model, data, res.q[k], res.qd[k], res.qdd[k])
        assert rel_err(res.tau[k], tau) < 1e-9, f"cycle {k}: tau"
        req = pin.rnea(model, data, res.q[k], res.qd[k], res.qdd_des[k])
        assert rel_err(res.tau_required[k], req) < 1e-9, f"cycle {k}: tau_required"
        assert np.all(np.abs(res.tau[k]) <= L * (1 + 1e-12))
    assert not res.achievable
    assert res.verdict().startswith("NOT ACHIEVABLE: waist needs")


def test_the_command_line_gives_the_waist_verdict() -> None:
    out = mrnea_cli("check", PROGRAM)
    assert out.returncode == 1, out.stderr
    assert out.stdout.startswith("NOT ACHIEVABLE: waist needs"), out.stdout
