"""The tool frame's forward kinematics and the inverse kinematics, against Pinocchio.

Oracles: Pinocchio's operational frames (``framesForwardKinematics``, ``data.oMf``) of the URDF's
own fixed frames (UR5 ``tool0``, Panda ``panda_hand_tcp``) and of a frame added with
``pin.Frame`` at an xyz/rpy placement made by ``pin.rpy.rpyToMatrix`` (Puma 560); ``pin.log3``
for orientation errors; ``pin.computeFrameJacobian`` for the minimum-norm step of a redundant arm.
Every IK result is judged by Pinocchio's forward kinematics of the q it returns, never by mrnea's.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import PinChain, erd_path, pin_from_urdf, to_pinocchio

import mrnea
from mrnea.errors import StateError
from mrnea.ik import solve_path

UR5 = ("ur_description/urdf/ur5_robot.urdf", None, "tool0")
PANDA = ("panda_description/urdf/panda.urdf", "panda_hand_tcp", "panda_hand_tcp")
UR5_5DOF = ("ur_description/urdf/ur5_robot.urdf", "wrist_2_link", "wrist_2_link")
PUMA_TOOL = {"xyz": [0.01, -0.02, 0.15], "rpy": [0.3, -0.2, 0.5]}


class PinTool:
    """Pinocchio's pose of a tool frame (by name in the URDF, or added at xyz/rpy)."""

    def __init__(self, robot: mrnea.Robot, model, frame: str | None, tool: dict | None = None
                 ) -> None:
        self.pc = PinChain(robot, model)
        if frame is None:  # a frame on the last joint at the tool's placement
            M = pin.SE3(pin.rpy.rpyToMatrix(*tool["rpy"]), np.array(tool["xyz"], dtype=float))
            frame = "tool"
            model.addFrame(pin.Frame(frame, self.pc.ids[-1], M, pin.FrameType.OP_FRAME))
            self.pc.data = model.createData()
        self.model, self.fid = model, model.getFrameId(frame)
        assert self.fid < model.nframes

    def pose(self, q) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.pc.data, self.pc.config(q))
        return self.pc.data.oMf[self.fid].homogeneous.copy()

    def jacobian(self, q) -> np.ndarray:
        J = pin.computeFrameJacobian(self.model, self.pc.data, self.pc.config(q), self.fid,
                                     pin.LOCAL_WORLD_ALIGNED)
        return np.asarray(J)[:, self.pc.iv]


def _urdf(case):
    rel, tip, frame = case
    path = erd_path(rel)
    robot = mrnea.load_urdf(path, tip=tip)
    return robot, PinTool(robot, pin_from_urdf(path, robot), frame), frame


def _puma():
    robot = mrnea.robots.puma560()
    return robot, PinTool(robot, to_pinocchio(robot), None, PUMA_TOOL), PUMA_TOOL


def _random_q(robot, rng, count):
    lo = np.where(np.isfinite(robot.lower), robot.lower, -np.pi)
    hi = np.where(np.isfinite(robot.upper), robot.upper, np.pi)
    return rng.uniform(lo, hi, size=(count, robot.n))


def _errors(T, ref):
    """(position error [m], orientation error [rad]) of pose T against ref, by Pinocchio."""
    return (float(np.linalg.norm(T[:3, 3] - ref[:3, 3])),
            float(np.linalg.norm(pin.log3(ref[:3, :3].T @ T[:3, :3]))))


CASES = {"ur5": lambda: _urdf(UR5), "panda": lambda: _urdf(PANDA), "puma560": _puma}


@pytest.mark.parametrize("name", CASES)
def test_tool_forward_kinematics_against_pinocchio(name):
    robot, ref, tool = CASES[name]()
    Q = _random_q(robot, np.random.default_rng(1), 50)
    T = mrnea.forward_kinematics(robot, Q, tool=tool)
    assert T.shape == (50, robot.n + 2, 4, 4)
    np.testing.assert_array_equal(T[:, :-1], mrnea.forward_kinematics(robot, Q))
    for q, Tq in zip(Q, T, strict=True):
        assert np.abs(Tq[-1] - ref.pose(q)).max() <= 1e-12
        single = mrnea.forward_kinematics(robot, q, tool=tool)
        assert single.shape == (robot.n + 2, 4, 4)
        np.testing.assert_array_equal(single, Tq)


def test_named_frames_are_the_urdf_fixed_frames():
    robot, _, _ = _urdf(PANDA)
    names = [f.name for f in robot.links[-1].frames]
    assert names == ["panda_link8", "panda_hand", "panda_hand_tcp"]  # the fingers move: not kept
    tcp = dict((f.name, f.origin) for f in robot.links[-1].frames)["panda_hand_tcp"]
    np.testing.assert_allclose(tcp[:3, 3], [0, 0, 0.107 + 0.1034], atol=1e-15)


@pytest.mark.parametrize("name", CASES)
def test_ik_round_trip_from_nearby_starts(name):
    robot, ref, tool = CASES[name]()
    rng = np.random.default_rng(2)
    for q in _random_q(robot, rng, 20):
        target = ref.pose(q)
        q0 = q + rng.normal(0.0, 0.15, robot.n)
        sol = mrnea.inverse_kinematics(robot, target, q0, tool=tool)
        assert sol.shape == (robot.n,)
        ep, ew = _errors(ref.pose(sol), target)
        assert ep <= 1e-10 and ew <= 1e-9, (ep, ew)


def test_ik_five_joints_reaches_its_reachable_poses():
    robot, ref, tool = _urdf(UR5_5DOF)
    assert robot.n == 5
    rng = np.random.default_rng(3)
    for q in _random_q(robot, rng, 20):
        target = ref.pose(q)
        sol = mrnea.inverse_kinematics(robot, target, q + rng.normal(0.0, 0.1, 5), tool=tool)
        ep, ew = _errors(ref.pose(sol), target)
        assert ep <= 1e-10 and ew <= 1e-9, (ep, ew)


@pytest.mark.parametrize("name", ["ur5", "puma560"])
def test_ik_path_follows_the_branch_of_q0(name):
    """A smooth joint path's tool poses (Pinocchio), solved from its first q: the same q back
    (a 6-joint arm has isolated solutions, and the warm start keeps the branch)."""
    robot, ref, tool = CASES[name]()
    rng = np.random.default_rng(4)
    qa, qb = _random_q(robot, rng, 2) * 0.5
    s = np.linspace(0.0, 1.0, 400)[:, None]
    Q = qa + (qb - qa) * (3 * s**2 - 2 * s**3)
    poses = np.array([ref.pose(q) for q in Q])
    sol = mrnea.inverse_kinematics(robot, poses, Q[0], tool=tool)
    assert sol.shape == Q.shape
    assert np.abs(sol - Q).max() <= 1e-7
    for q, T in zip(sol, poses, strict=True):
        ep, ew = _errors(ref.pose(q), T)
        assert ep <= 1e-10 and ew <= 1e-9


def _panda_line(robot, ref, tool, q0, step, K=100):
    """The Panda's IK of a line along x (``step`` [m] per cycle); (solution, max deviation of
    each joint step from pinv(J) times the tool's twist, Pinocchio's frame Jacobian)."""
    T0 = ref.pose(q0)
    poses = np.repeat(T0[None], K, axis=0)
    poses[:, 0, 3] += step * np.arange(K)
    sol = mrnea.inverse_kinematics(robot, poses, q0, tool=tool)
    dev = 0.0
    for k in range(1, K):
        ep, ew = _errors(ref.pose(sol[k]), poses[k])
        assert ep <= 1e-10 and ew <= 1e-9
        expected = np.linalg.pinv(ref.jacobian(sol[k - 1])) @ np.array([step, 0, 0, 0, 0, 0])
        dev = max(dev, float(np.linalg.norm(sol[k] - sol[k - 1] - expected)))
    return sol, dev


def test_ik_seven_joints_takes_the_minimum_norm_step():
    """Panda: each cycle's joint step is, to first order, pinv(J) times the tool's twist (the
    minimum-norm step from the previous cycle), J Pinocchio's frame Jacobian: the deviation
    is second order (a quarter of the step, a sixteenth of the deviation; a step with a
    first-order null-space part would give a quarter)."""
    robot, ref, tool = _urdf(PANDA)
    q0 = np.array([0.0, -0.4, 0.1, -2.0, 0.1, 1.6, 0.7])
    sol, dev = _panda_line(robot, ref, tool, q0, 4e-4)
    _, dev4 = _panda_line(robot, ref, tool, q0, 1e-4, K=397)
    assert dev < 1e-5 and dev4 < dev / 10, (dev, dev4)
    # without a null-space goal the elbow does not drift: the last q stays near q0
    assert np.abs(sol[-1] - q0).max() < 0.2


def test_ik_reports_an_unreachable_pose():
    robot, ref, tool = _urdf(UR5)
    q = np.array([0.3, -1.2, 1.4, -1.6, -1.5, 0.2])
    far = ref.pose(q)
    far[:3, 3] = [2.0, 0.0, 0.5]  # the UR5 reaches about 0.95 m
    res = solve_path(robot, far, q, tool=tool)
    assert res.position_error[0] > 0.9 and not res.converged[0]
    with pytest.raises(StateError, match=r"pose 0 is not reached: position error"):
        mrnea.inverse_kinematics(robot, far, q, tool=tool)


def test_tool_arguments_are_checked():
    robot, _, _ = _urdf(PANDA)
    q = np.zeros(robot.n)
    with pytest.raises(StateError, match=r"'nope' is no frame of the last link .* 'panda_hand_"):
        mrnea.forward_kinematics(robot, q, tool="nope")
    with pytest.raises(StateError, match=r"fixed to link 'panda_link3', not to the last link"):
        mrnea.forward_kinematics(robot, q, tool="panda_link3")
    with pytest.raises(StateError, match=r"unknown key 'xzy'"):
        mrnea.forward_kinematics(robot, q, tool={"xzy": [0, 0, 1]})
    with pytest.raises(StateError, match=r"not a rigid transform"):
        mrnea.forward_kinematics(robot, q, tool=np.ones((4, 4)))
    with pytest.raises(StateError, match=r"poses: expected a \(4, 4\) pose"):
        mrnea.inverse_kinematics(robot, np.eye(3), q)
    with pytest.raises(StateError, match=r"pose 0 is not a rigid transform"):
        mrnea.inverse_kinematics(robot, 2 * np.eye(4), q)
    with pytest.raises(StateError, match=r"q0: expected shape \(7,\)"):
        mrnea.inverse_kinematics(robot, np.eye(4), np.zeros(6))
    from test_tree_pinocchio import random_tree

    tree = random_tree(np.random.default_rng(5), 6)
    assert not tree.is_serial
    with pytest.raises(StateError, match=r"is a kinematic tree: name the tool"):
        mrnea.inverse_kinematics(tree, np.eye(4), np.zeros(tree.n))
    with pytest.raises(StateError, match=r"kinematic tree: a \(4, 4\) transform does not say"):
        mrnea.inverse_kinematics(tree, np.eye(4), np.zeros(tree.n), tool=np.eye(4))
    with pytest.raises(StateError, match=r"kinematic tree: say which link"):
        mrnea.forward_kinematics(tree, np.zeros(tree.n), tool={"xyz": [0, 0, 0.1]})
    with pytest.raises(StateError, match=r"hold: no joint named 'nope'"):
        mrnea.inverse_kinematics(robot, np.eye(4), q, hold=["nope"])
    with pytest.raises(StateError, match=r"hold: every joint that carries link"):
        mrnea.inverse_kinematics(robot, np.eye(4), q, hold=list(robot.joint_names))
