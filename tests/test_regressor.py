"""The joint torque regressor (mrnea.regressor) against Pinocchio's computeJointTorqueRegressor.

The UR5 is loaded by Pinocchio from example-robot-data's URDF; the Puma 560 from the URDF mrnea's
writer makes of it (urdfdom reads it, not mrnea). Pinocchio's columns are put in our joint order
(the blocks are already in the same parameter order, in the same frame: the joint frame after the
motion, our link frame). 100 random states each, one batch call and single calls; plus
``Y @ pi == inverse_dynamics`` on random chains with prismatic joints.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PinChain, erd_path, pin_from_urdf, random_chain, random_states, rel_err

import mrnea
from mrnea.identify.regressor import (
    inertial_parameters,
    split_link_parameters,
    with_inertial_parameters,
)

B = 100


def _ur5():
    path = erd_path("ur_description/urdf/ur5_robot.urdf")
    robot = mrnea.load_urdf(path)
    return robot, pin_from_urdf(path, robot)


def _puma(tmp_path):
    robot = mrnea.robots.puma560()
    path = robot.to_urdf(tmp_path / "puma560.urdf")
    return robot, pin_from_urdf(path, robot)


def _pin_regressor(pc: PinChain, q, qd, qdd) -> np.ndarray:
    pin = pc.pin
    Y = pin.computeJointTorqueRegressor(pc.model, pc.data, pc.config(q), pc.vel(qd), pc.vel(qdd))
    blocks = np.concatenate([np.arange(10 * (i - 1), 10 * i) for i in pc.ids])
    return np.asarray(Y)[pc.iv][:, blocks]


@pytest.mark.parametrize("which", ["ur5", "puma"])
def test_regressor_equals_pinocchio(which: str, tmp_path) -> None:
    robot, model = _ur5() if which == "ur5" else _puma(tmp_path)
    pc = PinChain(robot, model)
    rng = np.random.default_rng(28)
    s = random_states(rng, robot, B)
    Y = mrnea.regressor(robot, s["q"], s["qd"], s["qdd"])
    assert Y.shape == (B, robot.n, 10 * robot.n)
    for b in range(B):
        ref = _pin_regressor(pc, s["q"][b], s["qd"][b], s["qdd"][b])
        assert rel_err(Y[b], ref) <= 1e-12, b
        if b < 4:  # one state at a time: the same numbers
            assert np.array_equal(mrnea.regressor(robot, s["q"][b], s["qd"][b], s["qdd"][b]),
                                  Y[b])
    # regressor x parameters = inverse dynamics, ours and Pinocchio's
    tau = np.einsum("bij,j->bi", Y, inertial_parameters(robot))
    assert rel_err(tau, mrnea.inverse_dynamics(robot, s["q"], s["qd"], s["qdd"])) <= 1e-12
    assert rel_err(tau[0], pc.rnea(s["q"][0], s["qd"][0], s["qdd"][0])) <= 1e-12


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_regressor_times_parameters_is_inverse_dynamics(seed: int) -> None:
    """Random chains, prismatic joints included, and the parameters of a Pinocchio Inertia."""
    import pinocchio as pin

    rng = np.random.default_rng(seed)
    robot = random_chain(rng, 7, prismatic_fraction=0.4)
    s = random_states(rng, robot, 50)
    Y = mrnea.regressor(robot, s["q"], s["qd"], s["qdd"])
    pi = inertial_parameters(robot)
    for i, lk in enumerate(robot.links):  # our parameters are Pinocchio's dynamic parameters
        ref = pin.Inertia(lk.mass, np.array(lk.com), np.array(lk.inertia)).toDynamicParameters()
        assert rel_err(pi[10 * i:10 * i + 10], ref) <= 1e-14
    tau = np.einsum("bij,j->bi", Y, pi)
    assert rel_err(tau, mrnea.inverse_dynamics(robot, s["q"], s["qd"], s["qdd"])) <= 1e-12


def test_parameters_round_trip() -> None:
    robot = mrnea.robots.puma560()
    pi = inertial_parameters(robot)
    back = with_inertial_parameters(robot, pi)
    for a, b in zip(robot.links, back.links, strict=True):
        assert abs(a.mass - b.mass) <= 1e-15 * max(1, a.mass)
        if a.mass > 0:  # a massless link's centre of mass is not a parameter: its origin
            assert np.allclose(a.com, b.com, rtol=0, atol=1e-15)
        assert np.allclose(a.inertia, b.inertia, rtol=0, atol=1e-14)
    assert rel_err(inertial_parameters(back), pi) <= 1e-15
    m, c, inertia = split_link_parameters(np.zeros(10))
    assert m == 0 and not c.any() and not inertia.any()


def test_regressor_refuses_bad_input() -> None:
    robot = mrnea.robots.puma560()
    z = np.zeros(6)
    with pytest.raises(mrnea.StateError, match="qd"):
        mrnea.regressor(robot, z, [0, 0, np.nan, 0, 0, 0], z)
    with pytest.raises(mrnea.StateError, match="q"):
        mrnea.regressor(robot, np.zeros(5), z, z)
    with pytest.raises(mrnea.StateError, match="pi"):
        with_inertial_parameters(robot, np.zeros(7))
