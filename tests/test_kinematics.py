"""Forward kinematics and the geometric Jacobian against Pinocchio, and J^T f against the dynamics.

Every test robot of ``test_dynamics_pinocchio`` (random chains with prismatic joints, UR5, Panda,
Kinova, PR2's right arm), 100 random states each, as one batch and as single calls.
Pinocchio's references: ``data.oMi`` after ``forwardKinematics`` (our link i is the body of the
joint named like our joint i: its frame is the URDF joint frame after the motion), and
``computeFrameJacobian`` in ``LOCAL_WORLD_ALIGNED`` of an operational frame placed at the point
on our last joint, columns reordered to our joints. Every comparison: ``rel_err <= 1e-12``.

Independently of Pinocchio: ``J^T f_ext`` equals the effort the external wrench adds to the
inverse dynamics (mrnea's RNEA with the wrench minus without, Eq. 1's J^T k_e).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import rel_err
from test_dynamics_pinocchio import ALL, N_SINGLE, B, get_case

import mrnea
from mrnea.errors import StateError

TOL = 1e-12


def _pin_frames(c, q) -> np.ndarray:
    """(n + 1, 4, 4): the identity, then oMi of our joints, from Pinocchio."""
    pin.forwardKinematics(c.pc.model, c.pc.data, c.pc.config(q))
    return np.array([np.eye(4)] + [c.pc.data.oMi[i].homogeneous for i in c.pc.ids])


class _PinPoint:
    """Pinocchio's LOCAL_WORLD_ALIGNED Jacobian of a frame on our last joint at a point."""

    def __init__(self, c) -> None:
        self.c = c
        self.model = pin.Model(c.pc.model)
        last = c.pc.ids[-1]
        self.fid = self.model.addFrame(pin.Frame("point", last, pin.SE3.Identity(),
                                                 pin.FrameType.OP_FRAME))
        self.data = self.model.createData()

    def __call__(self, q, point) -> np.ndarray:
        frame = self.model.frames[self.fid]
        frame.placement = pin.SE3(np.eye(3), np.asarray(point, dtype=float))
        self.model.frames[self.fid] = frame
        J = pin.computeFrameJacobian(self.model, self.data, self.c.pc.config(q), self.fid,
                                     pin.LOCAL_WORLD_ALIGNED)
        return np.asarray(J).reshape(6, -1)[:, self.c.pc.iv]  # (6,) when nv = 1


@pytest.mark.parametrize("name", ALL)
def test_forward_kinematics_against_pinocchio(name: str) -> None:
    c = get_case(name)
    q = c.s["q"]
    T = mrnea.forward_kinematics(c.robot, q)
    assert T.shape == (B, c.robot.n + 1, 4, 4)
    for b in range(B):
        ref = _pin_frames(c, q[b])
        assert rel_err(T[b], ref) <= TOL, f"{name} state {b}"
        if b < N_SINGLE:
            assert rel_err(mrnea.forward_kinematics(c.robot, q[b]), ref) <= TOL
    # the batch and the single-state fast path run the same kernel: equal bit for bit
    assert np.array_equal(mrnea.forward_kinematics(c.robot, q[0]), T[0])


@pytest.mark.parametrize("at_point", [False, True], ids=["origin", "point"])
@pytest.mark.parametrize("name", ALL)
def test_jacobian_against_pinocchio(name: str, at_point: bool) -> None:
    c = get_case(name)
    q, pts = c.s["q"], c.s["f_ext_point"]
    ref_of = _PinPoint(c)
    J = mrnea.jacobian(c.robot, q, pts if at_point else None)
    assert J.shape == (B, 6, c.robot.n)
    for b in range(B):
        ref = ref_of(q[b], pts[b] if at_point else np.zeros(3))
        assert rel_err(J[b], ref) <= TOL, f"{name} state {b}"
        if b < N_SINGLE:
            single = mrnea.jacobian(c.robot, q[b], pts[b] if at_point else None)
            assert rel_err(single, ref) <= TOL


@pytest.mark.parametrize("name", ALL)
def test_jacobian_transpose_is_the_effort_of_the_external_wrench(name: str) -> None:
    """J(q, p)^T f_ext = tau(q, qd, qdd, f_ext at p) - tau(q, qd, qdd): the wrench's share of
    the inverse dynamics (RNEA's backward pass, no Jacobian), to the rounding of the two
    efforts it is the difference of."""
    c = get_case(name)
    q, qd, qdd, fe, pe = (c.s[k] for k in ("q", "qd", "qdd", "f_ext", "f_ext_point"))
    with_wrench = mrnea.inverse_dynamics(c.robot, q, qd, qdd, fe, pe)
    without = mrnea.inverse_dynamics(c.robot, q, qd, qdd)
    J = mrnea.jacobian(c.robot, q, pe)
    JTf = np.einsum("bkj,bk->bj", J, fe)
    scale = np.abs(with_wrench).max() + np.abs(without).max()
    assert np.abs(JTf - (with_wrench - without)).max() <= 1e-13 * scale


def test_kinematics_broadcast_and_checks() -> None:
    robot = get_case("n6-mixed").robot
    q = np.zeros((3, 6))
    # one point for a batch, a batch of points for one state
    J1 = mrnea.jacobian(robot, q, [0.1, 0.0, 0.0])
    J2 = mrnea.jacobian(robot, q[0], np.tile([0.1, 0.0, 0.0], (3, 1)))
    assert J1.shape == J2.shape == (3, 6, 6)
    assert np.array_equal(J1, J2)
    assert mrnea.forward_kinematics(robot, q.tolist()).shape == (3, 7, 4, 4)
    with pytest.raises(StateError, match=r"^q: expected shape"):
        mrnea.forward_kinematics(robot, np.zeros(5))
    with pytest.raises(StateError, match=r"^point: expected shape"):
        mrnea.jacobian(robot, np.zeros(6), np.zeros(2))
    with pytest.raises(StateError, match=r"^point: contains NaN"):
        mrnea.jacobian(robot, np.zeros(6), np.array([0.0, np.nan, 0.0]))
    with pytest.raises(StateError, match=r"^q: contains NaN"):
        mrnea.forward_kinematics(robot, np.full(6, np.inf))
    with pytest.raises(StateError, match="batch sizes differ"):
        mrnea.jacobian(robot, q, np.zeros((2, 3)))
    with pytest.raises(StateError, match=r"robot: expected a mrnea\.Robot"):
        mrnea.jacobian("ur5", np.zeros(6))
    q0 = np.zeros(6)
    mrnea.jacobian(robot, q0, np.zeros(3))
    assert not q0.any()  # the caller's arrays are never written
    # any layout, read-only or not, and lists: the same numbers
    qs = np.linspace(-1.0, 1.0, 12)[::2]
    ro = qs.copy()
    ro.setflags(write=False)
    for args in ((qs,), (ro,), (qs.tolist(),), (qs, [0.0, 0.0, 0.0])):
        assert np.array_equal(mrnea.jacobian(robot, *args), mrnea.jacobian(robot, qs.copy()))
        assert np.array_equal(mrnea.forward_kinematics(robot, args[0]),
                              mrnea.forward_kinematics(robot, qs.copy()))
