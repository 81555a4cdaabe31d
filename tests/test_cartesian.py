"""Cartesian programs: every cycle against the programmed tool path, and the verdicts.

Oracles: Pinocchio's forward kinematics of the URDF's ``tool0`` frame (``data.oMf``) for every
commanded q, ``pin.log3`` for the orientation; the segment and the circle through three points
computed here by plain linear algebra (the circumcentre from a linear solve); the closed-form
trapezoid duration ``L/v + v/a``; the limits of the URDF for the verdicts, through the command
line as a real process (``mrnea check``: exit 1 and the reason).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import erd_path, mrnea_cli, one_error_line, pin_from_urdf
from test_ik import PinTool

import mrnea
from mrnea.cartesian import solve
from mrnea.errors import ProgramFileError
from mrnea.io.program import loads_program

UR5 = "ur_description/urdf/ur5_robot.urdf"
Q_HOME = [0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0]


def _ur5():
    path = erd_path(UR5)
    robot = mrnea.load_urdf(path)
    return path, robot, PinTool(robot, pin_from_urdf(path, robot), "tool0")


def _program(robot_path: Path, q0, moves: str, dt: float = 0.004) -> str:
    return (f'[program]\nrobot = "{robot_path}"\ndt = {dt}\ntool = "tool0"\n'
            f"q0 = {list(map(float, q0))}\n{moves}")


PICK = """
[[move]]
type = "joint"
target = [0.3, -1.2, 1.5, -1.9, -1.5708, 0.3]
velocity_limit = 1.0
acceleration_limit = 2.0

[[move]]
type = "linear"
xyz = [0.45, 0.15, 0.15]
speed = 0.25
acceleration = 1.0
dwell = 0.2

[[move]]
type = "linear"
xyz = [0.45, 0.15, 0.30]
rpy = [3.0, 0.1, 0.2]
speed = 0.25
acceleration = 1.0
angular_speed = 0.8
angular_acceleration = 2.0

[[move]]
type = "circular"
via = [0.35, 0.30, 0.30]
xyz = [0.20, 0.40, 0.25]
speed = 0.2
acceleration = 1.0
jerk = 10.0
"""


@pytest.fixture(scope="module")
def pick(tmp_path_factory):
    path, robot, ref = _ur5()
    f = tmp_path_factory.mktemp("cart") / "pick.toml"
    f.write_text(_program(path, Q_HOME, PICK))
    return mrnea.load_program(f), robot, ref


def _arc_length_param(p, start):
    return np.linalg.norm(p - start, axis=1)


def test_every_cycle_reproduces_the_programmed_pose(pick):
    prog, _, ref = pick
    c = prog.cartesian
    assert prog.q_cmd.shape == (prog.K, 6) and c.pose.shape == (prog.K, 4, 4)
    assert c.achievable and c.verdict() is None
    for k in range(prog.K):
        T = ref.pose(prog.q_cmd[k])  # Pinocchio
        assert np.linalg.norm(T[:3, 3] - c.pose[k, :3, 3]) <= 1e-9
        assert np.linalg.norm(pin.log3(c.pose[k, :3, :3].T @ T[:3, :3])) <= 1e-9
    assert c.cartesian.sum() > 0.5 * prog.K  # most cycles are on Cartesian moves


def test_linear_moves_lie_on_their_segments(pick):
    prog, _, _ = pick
    c = prog.cartesian
    for m, (v, a, w, al) in ((2, (0.25, 1.0, np.inf, np.inf)), (3, (0.25, 1.0, 0.8, 2.0))):
        rows = np.flatnonzero((c.move == m) & c.cartesian)
        p = c.pose[np.r_[rows[0] - 1, rows], :3, 3]
        p0, p1 = p[0], p[-1]
        np.testing.assert_allclose(p1, [0.45, 0.15, 0.15 if m == 2 else 0.30], atol=1e-15)
        u = (p1 - p0) / np.linalg.norm(p1 - p0)
        off = (p - p0) - np.outer((p - p0) @ u, u)
        assert np.abs(off).max() <= 1e-12  # on the line
        s = (p - p0) @ u
        assert s.min() >= -1e-12 and s.max() <= np.linalg.norm(p1 - p0) + 1e-12
        assert np.all(np.diff(s) >= -1e-15)  # forward only
        speed = np.diff(s) / prog.dt
        acc = np.diff(s, 2) / prog.dt**2
        assert speed.max() <= v * (1 + 1e-9) and np.abs(acc).max() <= a * (1 + 1e-9)
        # the orientation turns about one axis from the start's to the target's
        R = c.pose[np.r_[rows[0] - 1, rows], :3, :3]
        ang = np.array([np.linalg.norm(pin.log3(R[0].T @ Rk)) for Rk in R])
        total = np.linalg.norm(pin.log3(R[0].T @ R[-1]))
        if m == 2:
            assert total <= 1e-12  # no rpy: the orientation is kept
        else:
            np.testing.assert_allclose(R[-1], pin.rpy.rpyToMatrix(3.0, 0.1, 0.2), atol=1e-12)
            # slerp: the angle grows in proportion to the distance travelled
            np.testing.assert_allclose(ang / total, s / s[-1], atol=1e-9)
            assert np.diff(ang).max() / prog.dt <= w * (1 + 1e-9)
            assert np.abs(np.diff(ang, 2)).max() / prog.dt**2 <= al * (1 + 1e-6)
        # shortest time: the closed-form trapezoid of the binding limit, rounded up to cycles
        L = np.linalg.norm(p1 - p0)
        times = [L / v + v / a if L >= v * v / a else 2 * np.sqrt(L / a)]
        if m == 3:
            times.append(total / w + w / al if total >= w * w / al else 2 * np.sqrt(total / al))
        T = max(times)
        assert len(rows) == int(np.ceil(T / prog.dt - 1e-9))


def test_circular_move_lies_on_its_arc(pick):
    prog, _, _ = pick
    c = prog.cartesian
    rows = np.flatnonzero((c.move == 4) & c.cartesian)
    p = c.pose[np.r_[rows[0] - 1, rows], :3, 3]
    a, b, e = p[0], np.array([0.35, 0.30, 0.30]), np.array([0.20, 0.40, 0.25])
    np.testing.assert_allclose(p[-1], e, atol=1e-15)
    # the circumcentre: in the plane of a, b, e, equidistant from the three
    nrm = np.cross(b - a, e - a)
    A = np.array([2 * (b - a), 2 * (e - a), nrm])
    rhs = np.array([b @ b - a @ a, e @ e - a @ a, nrm @ a])
    centre = np.linalg.solve(A, rhs)
    r = np.linalg.norm(a - centre)
    assert np.abs(np.linalg.norm(p - centre, axis=1) - r).max() <= 1e-12
    assert np.abs((p - centre) @ nrm).max() / np.linalg.norm(nrm) <= 1e-12
    # through the via point: the angle from a grows through via's to e's
    e1 = (a - centre) / r
    e2 = np.cross(nrm / np.linalg.norm(nrm), e1)
    ang = np.unwrap(np.arctan2((p - centre) @ e2, (p - centre) @ e1))
    via = np.arctan2((b - centre) @ e2, (b - centre) @ e1) % (2 * np.pi)
    assert np.all(np.diff(ang) >= -1e-15) and 0 < via < ang[-1]
    s = r * ang  # arc length
    assert np.diff(s).max() / prog.dt <= 0.2 * (1 + 1e-9)
    assert np.abs(np.diff(s, 2)).max() / prog.dt**2 <= 1.0 * (1 + 1e-6)
    assert np.abs(np.diff(s, 3)).max() / prog.dt**3 <= 10.0 * (1 + 1e-6)  # the jerk


def _check(tmp_path: Path, text: str, name: str = "prog.toml"):
    f = tmp_path / name
    f.write_text(text)
    return mrnea_cli("check", f, "--json")


def _wrist_program(path, robot, ref, tilt: float) -> str:
    """A linear move at constant orientation across the UR5's wrist singularity (wrist 2 at 0),
    the orientation tilted by ``tilt`` [rad] about x: 0 passes through it, > 0 beside it."""
    qs = np.array([0.0, -1.2, 1.5, -1.9, 0.0, 0.3])
    T = ref.pose(qs)
    R = pin.rpy.rpyToMatrix(tilt, 0.0, 0.0) @ T[:3, :3]
    Ta = np.eye(4)
    Ta[:3, :3], Ta[:3, 3] = R, T[:3, 3] - [0, 0.1, 0]
    q0 = mrnea.inverse_kinematics(robot, Ta, qs + np.array([0, 0, 0, 0, 0.3, 0]), tool="tool0")
    pb = (T[:3, 3] + [0, 0.1, 0]).tolist()
    return _program(path, q0, f'[[move]]\ntype = "linear"\nxyz = {pb}\nspeed = 0.1\n'
                              f"acceleration = 0.5\n")


def test_linear_move_near_the_wrist_singularity_is_not_achievable(tmp_path):
    path, robot, ref = _ur5()
    res = _check(tmp_path, _wrist_program(path, robot, ref, 0.01))
    assert res.returncode == 1, res.stderr
    out = json.loads(res.stdout)
    first = out["cartesian_findings"][0]
    assert first["kind"] == "singularity" and first["move"] == 1
    assert first["joint"] == "wrist_1_joint"  # wrist 1 and 3 spin about their aligned axes
    assert "over its limit 3.2 rad/s" in out["verdict"] and "move 1 (linear)" in out["verdict"]
    # the speed named is that of the commanded q, whose tool poses Pinocchio confirms
    prog = solve(loads_program((tmp_path / "prog.toml").read_text()), robot)
    qd = np.abs(np.diff(prog.q_cmd[:, 3])) / prog.dt
    assert qd.max() > 3.2 and abs(qd.max() - float(first["message"].split(" at ")[2].split()[0])
                                  ) < 1e-3 * qd.max()
    for k in np.flatnonzero(qd > 3.2)[:5]:
        T = ref.pose(prog.q_cmd[k + 1])
        assert np.linalg.norm(T[:3, 3] - prog.cartesian.pose[k + 1, :3, 3]) <= 1e-9


def test_wrist_flip_through_the_singularity_is_a_configuration_change(tmp_path):
    path, robot, ref = _ur5()
    text = _wrist_program(path, robot, ref, 0.0)
    prog = solve(loads_program(text), robot)
    kinds = {f.kind: f for f in prog.cartesian.findings}
    assert kinds["configuration"].joint == "wrist_2_joint"
    q5 = prog.q_cmd[:, 4]
    assert q5[0] > 0.1 and q5[-1] < -0.1  # wrist 2 changes sign: the wrist flips
    assert kinds["singularity"].move == 1


def test_elbow_flip_at_full_stretch_is_reported(tmp_path):
    """A circular move inside the workspace that touches its boundary (the elbow straight) at
    one point: the arm passes through full stretch and the elbow flips."""
    path, robot, ref = _ur5()
    qs = np.array([0.0, -0.6, 0.0, -1.2, -1.5708, 0.0])  # elbow straight
    T = ref.pose(qs)
    U = np.linalg.svd(ref.jacobian(qs))[0]
    inside = -U[:3, -1] / np.linalg.norm(U[:3, -1])  # the direction the arm cannot go, inward
    assert mrnea.ik.solve_path(robot, np.r_[np.c_[T[:3, :3], T[:3, 3] + 0.01 * inside],
                                            [[0, 0, 0, 1]]], qs, "tool0").converged[0]
    tang = np.cross(inside, [0, 1.0, 0])
    tang /= np.linalg.norm(tang)
    c, rho = T[:3, 3] + 0.06 * inside, 0.06

    def at(a):
        return (c + rho * (-np.cos(a) * inside + np.sin(a) * tang)).tolist()

    Ta = T.copy()
    Ta[:3, 3] = at(-0.5)
    q0 = mrnea.inverse_kinematics(robot, Ta, qs + np.array([0, 0, 0.3, 0, 0, 0]), tool="tool0")
    text = _program(path, q0, f'[[move]]\ntype = "circular"\nvia = {T[:3, 3].tolist()}\n'
                              f'xyz = {at(0.5)}\nspeed = 0.1\nacceleration = 0.5\n')
    res = _check(tmp_path, text)
    assert res.returncode == 1
    found = {f["kind"]: f for f in json.loads(res.stdout)["cartesian_findings"]}
    assert found["configuration"]["joint"] == "elbow_joint"
    assert found["singularity"]["joint"] == "elbow_joint"
    prog = solve(loads_program(text), robot)
    assert prog.q_cmd[0, 2] > 0.1 and prog.q_cmd[-1, 2] < -0.1  # the elbow flipped
    for k in range(0, prog.K, 7):  # and the tool stayed on its arc (Pinocchio)
        assert np.linalg.norm(ref.pose(prog.q_cmd[k])[:3, 3] - prog.cartesian.pose[k, :3, 3]
                              ) <= 1e-9


def test_target_out_of_reach_names_the_move(tmp_path):
    path, _, _ = _ur5()
    moves = PICK.split("[[move]]")
    text = _program(path, Q_HOME, "[[move]]".join(moves[:3]) + """[[move]]
type = "linear"
xyz = [1.2, 0.15, 0.30]
speed = 0.25
acceleration = 1.0
""")
    res = _check(tmp_path, text)
    assert res.returncode == 1
    out = json.loads(res.stdout)
    assert out["verdict"].startswith("NOT ACHIEVABLE: move 3 (linear)")
    assert "pose out of reach" in out["verdict"]
    reach = next(f for f in out["cartesian_findings"] if f["kind"] == "reach")
    assert reach["move"] == 3


def test_joint_limit_crossed_on_a_linear_move(tmp_path):
    """The Puma 560's wrist joint 5 is limited to +-100 deg: a straight line from q5 = 1.5 to the
    pose of q5 = 2.0 crosses it."""
    robot = mrnea.robots.puma560()
    qa = np.array([0.2, 0.8, -2.4, 0.1, 1.5, 0.2])
    qb = qa + np.array([0, 0, 0, 0, 0.5, 0])
    Tb = mrnea.forward_kinematics(robot, qb)[-1]
    text = (f'[program]\nrobot = "puma560"\ndt = 0.004\nq0 = {qa.tolist()}\n[[move]]\n'
            f'type = "linear"\nxyz = {Tb[:3, 3].tolist()}\n'
            f"quat = {pin.Quaternion(Tb[:3, :3]).coeffs()[[3, 0, 1, 2]].tolist()}\n"
            f"speed = 0.1\nacceleration = 0.5\nangular_speed = 1.0\nangular_acceleration = 2.0\n")
    res = _check(tmp_path, text)
    assert res.returncode == 1
    out = json.loads(res.stdout)
    lim = next(f for f in out["cartesian_findings"] if f["kind"] == "joint_limit")
    assert lim["joint"] == "joint5" and "upper limit 1.745 rad" in lim["message"]


@pytest.mark.parametrize("moves, words", [
    ('[[move]]\ntype = "lineer"\n', ["[[move]] 1", "unknown type 'lineer'", "'linear'"]),
    ('[[move]]\ntype = "linear"\nxyz = [0.4, 0.1, 0.3]\nacceleration = 1.0\n',
     ["[[move]] 1 (linear)", "missing required key 'speed'"]),
    ('[[move]]\ntype = "linear"\nxyz = [0.4, 0.1, 0.3]\nquat = [1, 1, 0, 0]\nspeed = 0.1\n'
     'acceleration = 1.0\n', ["[[move]] 1 (linear)", "'quat'", "unit quaternion"]),
    ('[[move]]\ntype = "circular"\nvia = [0.4, 0.1, 0.3]\nxyz = [0.4, 0.1, 0.3]\nspeed = 0.1\n'
     'acceleration = 1.0\n', ["[[move]] 1 (circular)", "on one line"]),
    ('[[move]]\ntype = "linear"\nxyz = [0.4, 0.1, 0.3]\nspeed = -1\nacceleration = 1.0\n',
     ["[[move]] 1 (linear)", "'speed' must be > 0"]),
    ('[[move]]\ntype = "joint"\ntarget = [0, 0, 0]\nvelocity_limit = 1\n'
     'acceleration_limit = 1\n', ["[[move]] 1 (joint)",
                                   "'target' has 3 values but [program] q0 has 6"]),
])
def test_bad_moves_are_one_error_line(tmp_path, moves, words):
    path, _, _ = _ur5()
    res = _check(tmp_path, _program(path, Q_HOME, moves))
    one_error_line(res, "prog.toml", *words)


def test_bad_tool_and_mixed_tables_are_errors(tmp_path):
    path, _, _ = _ur5()
    line = '[[move]]\ntype = "linear"\nxyz = [0.4, 0.1, 0.3]\nspeed = 0.1\nacceleration = 1\n'
    bad_tool = _program(path, Q_HOME, line).replace('"tool0"', '"flange"')
    one_error_line(_check(tmp_path, bad_tool), "prog.toml", "[program]", "tool 'flange'",
                   "'tool0'")
    nameless = tmp_path / "nameless.toml"
    nameless.write_text(_program(path, Q_HOME, line).replace(f'robot = "{path}"\n', ""))
    with pytest.raises(ProgramFileError, match=r"names none .*load_program\(path, robot=\.\.\.\)"):
        mrnea.load_program(nameless)
    assert mrnea.load_program(nameless, robot=str(path)).cartesian.achievable
    with pytest.raises(ProgramFileError, match=r"cannot have a \[path\] table"):
        loads_program(_program(path, Q_HOME, line) + '[path]\nprofile = "quintic"\n')
    with pytest.raises(ProgramFileError, match=r"'q0' belongs to a program of \[\[move\]\]"):
        loads_program('[program]\ndt = 0.01\nq0 = [0.0]\n[path]\nprofile = "quintic"\n'
                      'waypoints = [[0.0], [1.0]]\nvelocity_limit = 1\nacceleration_limit = 1\n')


def test_simulated_tool_errors_against_pinocchio(tmp_path):
    """A payload the wrist cannot carry: the real motion leaves the programmed path; its tool
    errors (table, summary, report) are Pinocchio's distance of the real q's tool0 frame from
    the programmed pose."""
    path, robot, ref = _ur5()
    heavy = robot.with_payload(30.0, [0.0, 0.0, 0.1])
    prog = solve(loads_program(_program(path, Q_HOME, PICK)), heavy)
    res = mrnea.simulate(heavy, prog.q_cmd, prog.dt, cartesian=prog.cartesian)
    assert not res.achievable
    pe, oe = res.tool_position_error, res.tool_orientation_error
    for k in range(0, res.K, 37):
        T = ref.pose(res.q[k])
        P = prog.cartesian.pose[k]
        assert abs(pe[k] - np.linalg.norm(T[:3, 3] - P[:3, 3])) <= 1e-9
        assert abs(oe[k] - np.linalg.norm(pin.log3(P[:3, :3].T @ T[:3, :3]))) <= 1e-9
    assert pe.max() > 0.1  # it falls far off the path
    s = res.summary()
    k = int(np.argmax(pe))
    assert s["max_tool_position_error"] == pe[k] and s["max_tool_position_error_time"] == res.t[k]
    assert s["max_tool_orientation_error"] == oe.max()
    cols = res.columns()
    np.testing.assert_array_equal(cols["tool_position_error [m]"], pe)
    np.testing.assert_array_equal(cols["tool_orientation_error [rad]"], oe)
    from mrnea.report import write_report
    html = write_report(res, tmp_path / "report.html", view3d=False).read_text()
    assert f"max position error {pe.max() * 1e3:,.0f} mm" in html
    # the 3D view draws the tool point's paths: the commanded one is the programmed path
    from mrnea.report.view3d import result_scene
    assert result_scene(res)["tip"] == [0.0, 0.0823, 0.0] == list(res.tool_point)
    # a program the robot follows: the tool stays on the programmed pose
    light = solve(loads_program(_program(path, Q_HOME, PICK)), robot)
    ok = mrnea.simulate(robot, light.q_cmd, light.dt, cartesian=light.cartesian)
    assert ok.achievable and ok.summary()["max_tool_position_error"] <= 1e-9
    assert ok.summary()["max_tool_orientation_error"] <= 1e-9


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("example, urdf", [
    ("ur5_cartesian_pick.toml", UR5),
    ("ur5_blended_square.toml", UR5),
    ("panda_cartesian_hand.toml", "panda_description/urdf/panda.urdf"),
])
def test_examples_are_achievable(example, urdf):
    res = mrnea_cli("check", erd_path(urdf), EXAMPLES / example)
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.startswith("ACHIEVABLE:")


def test_retime_keeps_the_tool_path(tmp_path):
    """mrnea retime of a Cartesian program: the retimed joint rows, run through Pinocchio's
    forward kinematics, stay on the programmed segments and arc (to the resampling's accuracy)."""
    path, _, ref = _ur5()
    f = tmp_path / "pick.toml"
    f.write_text(_program(path, Q_HOME, PICK))
    res = mrnea_cli("retime", f, "--out", tmp_path / "out", "--no-3d", "--quiet", "--dt", "0.002")
    assert res.returncode == 0, res.stderr
    rows = np.loadtxt(tmp_path / "out" / "retimed.csv", delimiter=",", skiprows=1)
    prog = mrnea.load_program(f)
    a, b = prog.cartesian.pose[:-1, :3, 3], prog.cartesian.pose[1:, :3, 3]
    ab = b - a
    L2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    worst = 0.0
    for q in rows[:, 1:]:  # the distance to the polyline through the programmed cycles
        p = ref.pose(q)[:3, 3]
        u = np.clip(np.einsum("ij,ij->i", p - a, ab) / L2, 0.0, 1.0)
        worst = max(worst, float(np.min(np.linalg.norm(a + u[:, None] * ab - p, axis=1))))
    assert worst <= 1e-5, worst
    assert rows[-1, 0] < prog.t[-1]  # and faster
    # the retimed Cartesian timing: the tool poses of the retimed rows (Pinocchio), and a
    # program of one pose CSV move that gives the retimed rows back by inverse kinematics
    poses = np.loadtxt(tmp_path / "out" / "retimed_poses.csv", delimiter=",", skiprows=1)
    np.testing.assert_array_equal(poses[:, 0], rows[:, 0])
    for r, q in zip(poses[::25], rows[::25, 1:], strict=True):
        T = ref.pose(q)
        assert np.linalg.norm(T[:3, 3] - r[1:4]) <= 1e-12
        R = pin.Quaternion(r[4], r[5], r[6], r[7]).toRotationMatrix()
        assert np.linalg.norm(pin.log3(R.T @ T[:3, :3])) <= 1e-12
    back = mrnea.load_program(tmp_path / "out" / "retimed_cartesian.toml")
    assert back.dt == 0.002 and back.K == rows.shape[0] and back.cartesian.achievable
    assert np.abs(back.q_cmd - rows[:, 1:]).max() <= 1e-8
    res = mrnea_cli("check", tmp_path / "out" / "retimed_cartesian.toml")
    assert res.returncode == 0 and res.stdout.startswith("ACHIEVABLE"), res.stdout + res.stderr


def test_simulate_writes_the_tool_errors_and_exits_1_on_a_bad_path(tmp_path):
    """mrnea simulate of a Cartesian program past the wrist singularity: the tool path's
    verdict on stderr, the files written (cycles.csv with the tool columns, summary.json with
    their peaks), exit 1."""
    path, robot, ref = _ur5()
    f = tmp_path / "wrist.toml"
    f.write_text(_wrist_program(path, robot, ref, 0.01))
    res = mrnea_cli("simulate", f, "--out", tmp_path / "out", "--no-3d")
    assert res.returncode == 1, res.stderr
    assert "Tool path: NOT ACHIEVABLE: move 1 (linear)" in res.stderr
    header = (tmp_path / "out" / "cycles.csv").read_text().splitlines()[0].split(",")
    assert header[-2:] == ["tool_position_error [m]", "tool_orientation_error [rad]"]
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert {"max_tool_position_error", "max_tool_orientation_error_time"} <= set(s)
