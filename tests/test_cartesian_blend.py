"""Blended corners between linear moves (``blend`` [m]), and a wrench during moves, through
Pinocchio.

Oracles: Pinocchio's forward kinematics of the UR5's ``tool0`` frame (``data.oMf``) for every
commanded q; the corner's inscribed circle from closed-form plane geometry (its centre on the
angle's bisector at ``sqrt(r^2 + rho^2)`` from the corner, ``rho = r cot(theta / 2)``), the
distances to the segments from plain linear algebra; the moves' limits as written in the file;
the command line as a real process for the errors.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import erd_path, mrnea_cli, one_error_line, pin_from_urdf
from test_ik import PinTool

import mrnea
from mrnea.cartesian import solve
from mrnea.io.program import loads_program

UR5 = "ur_description/urdf/ur5_robot.urdf"
Q0 = [0.3, -1.2, 1.5, -1.9, -1.5708, 0.3]
CORNERS = np.array([[0.45, 0.15, 0.15], [0.45, 0.35, 0.15], [0.35, 0.35, 0.25]])
BLEND = (0.05, 0.04)
SPEED, ACC = (0.25, 0.2, 0.25), (1.0, 0.6, 1.0)
MOVES = f"""
[[move]]
type = "linear"
xyz = {CORNERS[0].tolist()}
speed = {SPEED[0]}
acceleration = {ACC[0]}
blend = {BLEND[0]}

[[move]]
type = "linear"
xyz = {CORNERS[1].tolist()}
rpy = [3.0, 0.1, 0.2]
speed = {SPEED[1]}
acceleration = {ACC[1]}
angular_speed = 0.8
angular_acceleration = 2.0
blend = {BLEND[1]}

[[move]]
type = "linear"
xyz = {CORNERS[2].tolist()}
speed = {SPEED[2]}
acceleration = {ACC[2]}
"""


def _program(robot_path, moves: str, q0=Q0, dt: float = 0.004) -> str:
    return (f'[program]\nrobot = "{robot_path}"\ndt = {dt}\ntool = "tool0"\n'
            f"q0 = {list(map(float, q0))}\n{moves}")


@pytest.fixture(scope="module")
def blended():
    path = erd_path(UR5)
    robot = mrnea.load_urdf(path)
    ref = PinTool(robot, pin_from_urdf(path, robot), "tool0")
    prog = solve(loads_program(_program(path, MOVES)), robot)
    fk = np.array([ref.pose(q) for q in prog.q_cmd])  # Pinocchio, every cycle
    return path, robot, prog, fk


def _to_segment(p, a, b):
    u = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(a + np.outer(u, b - a) - p, axis=1)


def test_the_tool_leaves_each_corner_within_its_radius_on_the_inscribed_arc(blended):
    _, _, prog, fk = blended
    assert prog.cartesian.achievable
    p = fk[:, :3, 3]
    pts = np.vstack([p[0], CORNERS])
    # the programmed pose is Pinocchio's pose of the commanded q
    assert np.abs(fk - prog.cartesian.pose).max() <= 1e-9
    d_seg = np.array([_to_segment(p, pts[i], pts[i + 1]) for i in range(3)])
    d_corner = np.array([np.linalg.norm(p - c, axis=1) for c in CORNERS[:2]])
    off = d_seg.min(axis=0) > 1e-9  # the cycles off every segment
    assert off.sum() > 20
    for k in np.flatnonzero(off):  # each within the radius of a corner
        assert any(d_corner[i, k] < BLEND[i] for i in range(2)), k
    for i in range(2):  # near corner i: the inscribed circle, tangent at r from the corner
        u1 = (pts[i + 1] - pts[i]) / np.linalg.norm(pts[i + 1] - pts[i])
        u2 = (pts[i + 2] - pts[i + 1]) / np.linalg.norm(pts[i + 2] - pts[i + 1])
        theta = np.arccos(u1 @ u2)
        r = BLEND[i]
        rho = r / np.tan(theta / 2)
        bis = (u2 - u1) / np.linalg.norm(u2 - u1)
        centre = CORNERS[i] + np.hypot(r, rho) * bis
        near = np.flatnonzero(d_corner[i] < r - 1e-9)
        assert near.size > 5
        np.testing.assert_allclose(np.linalg.norm(p[near] - centre, axis=1), rho, atol=1e-9)
        # the corner is not reached: the closest cycle is where the arc comes closest
        closest = np.hypot(r, rho) - rho
        assert d_corner[i].min() >= closest - 1e-9
        assert d_corner[i].min() <= closest + 1e-3
        # and the target poses are the corners (markers), not the rounded points
        assert np.array_equal(prog.cartesian.targets[i][1][:3, 3], CORNERS[i])
    np.testing.assert_allclose(p[-1], CORNERS[-1], atol=1e-10)


def test_blended_path_is_tangent_continuous_and_within_the_limits(blended):
    _, _, prog, fk = blended
    dt = prog.dt
    p = fk[:, :3, 3]
    chord = np.diff(p, axis=0)
    speed = np.linalg.norm(chord, axis=1) / dt
    d_corner = np.array([np.linalg.norm(p - c, axis=1) for c in CORNERS[:2]])
    # no stop at a corner: the speed at the cycle closest to it is that of the arc
    for i in range(2):
        k = int(np.argmin(d_corner[i]))
        assert speed[k] > 0.05
    # no kink: consecutive chords turn by at most the arc's chord angle
    cosang = np.einsum("ij,ij->i", chord[1:], chord[:-1]) / np.maximum(
        np.linalg.norm(chord[1:], axis=1) * np.linalg.norm(chord[:-1], axis=1), 1e-300)
    turn = np.arccos(np.clip(cosang, -1, 1))
    moving = speed[1:] > 1e-6
    rho_min = min(r / np.tan(np.arccos(
        (CORNERS[i] - (p[0] if i == 0 else CORNERS[i - 1])) @ (CORNERS[i + 1] - CORNERS[i])
        / np.linalg.norm(CORNERS[i] - (p[0] if i == 0 else CORNERS[i - 1]))
        / np.linalg.norm(CORNERS[i + 1] - CORNERS[i])) / 2) for i, r in enumerate(BLEND))
    assert turn[moving].max() <= np.linalg.norm(chord, axis=1).max() / rho_min * (1 + 1e-6)
    # limits: speed within the owning move's (and on an arc both moves'), |acceleration| too
    acc = np.linalg.norm(np.diff(p, 2, axis=0), axis=1) / dt**2
    move = prog.cartesian.move
    for m in (1, 2, 3):
        rows = np.flatnonzero(move[1:] == m)
        assert speed[rows].max() <= SPEED[m - 1] * (1 + 1e-9)
        assert acc[rows[rows < acc.size]].max() <= max(ACC[m - 1:m + 1]) * (1 + 1e-6)
    near = (d_corner[:, 1:-1] < np.array(BLEND)[:, None]).any(axis=0)
    arc_limit = np.where(d_corner[0, 1:-1] < BLEND[0], min(ACC[:2]), min(ACC[1:]))
    assert np.all(acc[near] <= arc_limit[near] * (1 + 1e-6))
    # the orientation: Pinocchio's angular speed within the second move's angular limit
    R = fk[:, :3, :3]
    w = np.array([np.linalg.norm(pin.log3(R[k].T @ R[k + 1])) for k in range(len(R) - 1)]) / dt
    assert w.max() <= 0.8 * (1 + 1e-9) and w.max() > 0.1
    # and its angular acceleration (the rate's change, base frame) within 2 rad/s^2
    ws = np.array([R[k] @ pin.log3(R[k].T @ R[k + 1]) for k in range(len(R) - 1)]) / dt
    alpha = np.linalg.norm(np.diff(ws, axis=0), axis=1) / dt
    assert alpha.max() <= 2.0 * (1 + 1e-6) and alpha.max() > 1.0
    np.testing.assert_allclose(R[-1], pin.rpy.rpyToMatrix(3.0, 0.1, 0.2), atol=1e-10)


def test_blending_is_faster_than_stopping_at_the_corners(blended):
    path, robot, prog, _ = blended
    stop = solve(loads_program(_program(path, MOVES.replace("blend = ", "dwell = 0 #"))), robot)
    assert prog.t[-1] < stop.t[-1] - 0.2


@pytest.mark.parametrize("edit, words", [
    (lambda m: m.replace("blend = 0.05", "blend = 0.2"),
     ["[[move]] 1 (linear)", "'blend' 0.2 m is more than half the shorter", "0.1 m"]),
    (lambda m: m.replace("blend = 0.04", "blend = 0.04\ndwell = 0.1"),
     ["[[move]] 2 (linear)", "'dwell' stops there"]),
    (lambda m: m + "blend = 0.01\n", ["[[move]] 3 (linear)", "this is the last move"]),
])
def test_bad_blends_are_one_error_line(tmp_path, edit, words):
    f = tmp_path / "prog.toml"
    f.write_text(_program(erd_path(UR5), edit(MOVES)))
    one_error_line(mrnea_cli("check", f), "prog.toml", *words)


@pytest.mark.parametrize("moves, words", [
    ('[[move]]\ntype = "circular"\nvia = [0.4, 0.2, 0.3]\nxyz = [0.45, 0.15, 0.15]\n'
     'speed = 0.1\nacceleration = 1\nblend = 0.01\n', ["[[move]] 1 (circular)",
                                                       "joins two linear moves"]),
    ('[[move]]\ntype = "linear"\nxyz = [0.45, 0.15, 0.15]\nspeed = 0.1\nacceleration = 1\n'
     'blend = 0.01\n[[move]]\ntype = "linear"\nxyz = [0.45, 0.35, 0.15]\nspeed = 0.1\n'
     'acceleration = 1\njerk = 5\n', ["[[move]] 2 (linear)", "'jerk'", "'blend'"]),
    ('[[move]]\ntype = "linear"\nxyz = [0.45, 0.15, 0.15]\nspeed = 0.1\nacceleration = 1\n'
     'blend = 0.01\n[[move]]\ntype = "joint"\ntarget = [0, -1, 1, -1, -1, 0]\n'
     'velocity_limit = 1\nacceleration_limit = 1\n', ["[[move]] 1 (linear)",
                                                      "move 2 is joint"]),
])
def test_blend_only_joins_linear_moves(tmp_path, moves, words):
    f = tmp_path / "prog.toml"
    f.write_text(_program(erd_path(UR5), moves))
    one_error_line(mrnea_cli("check", f), "prog.toml", *words)


def test_a_wrench_with_moves_acts_at_the_tcp(tmp_path, blended):
    """A [wrench] in a Cartesian program: on the program's clock, at the tool point. The
    joint efforts it adds are Pinocchio's J^T f of the tool0 frame (at the frame's origin, base
    axes); a wrench the wrist cannot hold makes the program NOT ACHIEVABLE (exit 1)."""
    path, robot, _, _ = blended
    ref = PinTool(robot, pin_from_urdf(path, robot), "tool0")
    times, values = [0.5, 1.5], [[0, 0, -40.0, 0, 0, 0], [0, 0, -40.0, 2.0, 0, 1.0]]
    wrench = f"[wrench]\ntimes = {times}\nvalues = {values}\n"
    prog = solve(loads_program(_program(path, MOVES + wrench)), robot)
    assert prog.f_ext.shape == (prog.K, 6)
    k = int(np.argmin(np.abs(prog.t - 1.0)))  # halfway between the breakpoints
    f = np.array(values[0]) + (prog.t[k] - 0.5) / 1.0 * (np.array(values[1]) - values[0])
    np.testing.assert_allclose(prog.f_ext[k], f, atol=1e-12)
    np.testing.assert_array_equal(prog.f_ext[0], values[0])  # held before the first time
    q = prog.q_cmd[k]
    pc = ref.pc
    g = pc.ours(pin.computeGeneralizedGravity(pc.model, pc.data, pc.config(q)))
    expected = g + ref.jacobian(q).T @ f
    tau = mrnea.inverse_dynamics(robot, q, np.zeros(6), np.zeros(6), f_ext=prog.f_ext[k],
                                 f_ext_point=prog.f_ext_point)
    np.testing.assert_allclose(tau, expected, rtol=1e-10, atol=1e-9)
    heavy = tmp_path / "heavy.toml"
    heavy.write_text(_program(path, MOVES + wrench.replace("40.0", "4000.0")))
    res = mrnea_cli("check", heavy)
    assert res.returncode == 1 and res.stdout.startswith("NOT ACHIEVABLE"), res.stdout


def test_wrenches_on_named_links_with_moves(tmp_path, blended):
    """[[wrench]] tables in a Cartesian program (issue 25): one without ``link`` acts at the
    TCP as a single [wrench] does, one on ``forearm_link`` at that link's origin. The efforts
    they add are Pinocchio's J^T f of the tool0 frame plus J^T f of the forearm's joint frame
    (``getJointJacobian``, LOCAL_WORLD_ALIGNED: its origin, base axes)."""
    path, robot, _, _ = blended
    ref = PinTool(robot, pin_from_urdf(path, robot), "tool0")
    f_tcp, f_arm = [0, 0, -40.0, 0, 0, 1.0], [5.0, -3.0, 2.0, 0.5, 0, 0]
    wrench = (f"[[wrench]]\ntimes = [0.0]\nvalues = [{f_tcp}]\n\n[[wrench]]\n"
              f'link = "forearm_link"\ntimes = [0.0]\nvalues = [{f_arm}]\n')
    prog = solve(loads_program(_program(path, MOVES + wrench)), robot)
    last = robot.link_names[-1]
    assert set(prog.f_ext) == {last, "forearm_link"} and set(prog.f_ext_point) == {last}
    single = solve(loads_program(_program(path, MOVES + f"[wrench]\ntimes = [0.0]\n"
                                                      f"values = [{f_tcp}]\n")), robot)
    np.testing.assert_array_equal(prog.f_ext_point[last], single.f_ext_point)  # the TCP
    pc = ref.pc
    for k in (0, prog.K // 2, prog.K - 1):
        q = prog.q_cmd[k]
        conf = pc.config(q)
        g = pc.ours(pin.computeGeneralizedGravity(pc.model, pc.data, conf))
        pin.computeJointJacobians(pc.model, pc.data, conf)
        J = pin.getJointJacobian(pc.model, pc.data, pc.model.getJointId("elbow_joint"),
                                 pin.LOCAL_WORLD_ALIGNED)[:, pc.iv]
        expected = g + ref.jacobian(q).T @ np.array(f_tcp) + J.T @ np.array(f_arm)
        tau = mrnea.inverse_dynamics(robot, q, np.zeros(6), np.zeros(6),
                                     f_ext={n: f[k] for n, f in prog.f_ext.items()},
                                     f_ext_point=prog.f_ext_point)
        np.testing.assert_allclose(tau, expected, rtol=1e-10, atol=1e-9)
