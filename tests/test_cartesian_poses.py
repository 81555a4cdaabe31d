"""Cartesian programs from CSV files of tool poses (``[[move]] type = "poses"``).

Oracles: the poses are Pinocchio's forward kinematics of the UR5's ``tool0`` frame along a smooth
joint path (written to the CSV as a quaternion by ``pin.Quaternion`` or a rotation vector by
``pin.log3``); Pinocchio's forward kinematics of the commanded q must give them back at the rows'
instants; the command line as a real process for the errors and the verdict.
"""

from __future__ import annotations

import json

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
QA = np.array([0.3, -1.2, 1.5, -1.9, -1.5708, 0.3])
DQ = np.array([0.4, 0.2, -0.3, 0.3, 0.25, -0.5])


@pytest.fixture(scope="module")
def ur5():
    path = erd_path(UR5)
    robot = mrnea.load_urdf(path)
    return path, robot, PinTool(robot, pin_from_urdf(path, robot), "tool0")


def _rows(ref, times, T_end, rotvec=False):
    """Pinocchio's tool0 poses along q(t) = QA + DQ (3u^2 - 2u^3), u = t / T_end."""
    out = []
    for t in times:
        u = t / T_end
        T = ref.pose(QA + DQ * (3 * u * u - 2 * u**3))
        rot = (pin.log3(T[:3, :3]).tolist() if rotvec
               else pin.Quaternion(T[:3, :3]).coeffs()[[3, 0, 1, 2]].tolist())
        out.append([t, *T[:3, 3].tolist(), *rot])
    return np.array(out)


def _write(f, rows, rotvec=False, comment=""):
    head = ("t [s], x [m], y [m], z [m], rx [rad], ry [rad], rz [rad]" if rotvec
            else "t, x, y, z, qw, qx, qy, qz")
    f.write_text(comment + head + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                                    for r in rows) + "\n")


def _program(path, q0, moves, dt=0.004):
    return (f'[program]\nrobot = "{path}"\ndt = {dt}\ntool = "tool0"\n'
            f"q0 = {list(map(float, q0))}\n{moves}")


@pytest.mark.parametrize("rotvec", [False, True])
def test_every_row_is_reached_through_pinocchio(tmp_path, ur5, rotvec):
    """Rows every 20 ms, cycles of 4 ms, cubic: at every row's instant the commanded q's tool0
    pose (Pinocchio) is the row's, and between rows the path is smooth and near the source."""
    path, _, ref = ur5
    times = np.arange(0.0, 1.5 + 1e-9, 0.02)
    rows = _rows(ref, times, 1.5, rotvec)
    _write(tmp_path / "poses.csv", rows, rotvec)
    f = tmp_path / "prog.toml"
    f.write_text(_program(path, QA + 0.05, '[[move]]\ntype = "poses"\ncsv = "poses.csv"\n'))
    prog = mrnea.load_program(f)
    c = prog.cartesian
    assert c.achievable and prog.K == 376  # 1.5 s at 4 ms, both ends
    for k in range(0, prog.K, 5):  # the rows' instants
        T = ref.pose(prog.q_cmd[k])
        r = rows[k // 5]
        R = (pin.exp3(r[4:7]) if rotvec
             else pin.Quaternion(r[4], r[5], r[6], r[7]).toRotationMatrix())
        assert np.linalg.norm(T[:3, 3] - r[1:4]) <= 1e-9
        assert np.linalg.norm(pin.log3(R.T @ T[:3, :3])) <= 1e-9
    # between the rows: Pinocchio's pose of the commanded q is the programmed pose, and within
    # a few micrometres of the source path (the cubic spline's error at 20 ms)
    src = _rows(ref, prog.t, 1.5)
    for k in range(1, prog.K, 3):
        T = ref.pose(prog.q_cmd[k])
        assert np.linalg.norm(T[:3, 3] - c.pose[k, :3, 3]) <= 1e-9
        assert np.linalg.norm(T[:3, 3] - src[k, 1:4]) <= 1e-5
    np.testing.assert_allclose(prog.q_cmd[0], QA, atol=1e-8)  # q0 seeded the first pose's IK


def test_after_a_linear_move_and_its_verdict(tmp_path, ur5):
    """A pose CSV continuing a linear move; a row beyond reach is a verdict (exit 1)."""
    path, robot, ref = ur5
    times = np.arange(0.0, 1.0 + 1e-9, 0.004)
    rows = _rows(ref, times, 1.0)
    start = rows[0, 1:4] + [0.0, -0.05, 0.0]
    T0 = ref.pose(QA)
    q_start = mrnea.inverse_kinematics(robot, np.r_[np.c_[T0[:3, :3], start], [[0, 0, 0, 1]]],
                                       QA, tool="tool0")
    line = (f'[[move]]\ntype = "linear"\nxyz = {rows[0, 1:4].tolist()}\nspeed = 0.1\n'
            f'acceleration = 0.5\n[[move]]\ntype = "poses"\ncsv = "p.csv"\n'
            f'interpolation = "linear"\n')
    _write(tmp_path / "p.csv", rows)
    f = tmp_path / "prog.toml"
    f.write_text(_program(path, q_start, line))
    prog = mrnea.load_program(f)
    assert prog.cartesian.achievable
    k0 = int(np.flatnonzero(prog.cartesian.move == 2)[0]) - 1  # the CSV's first row
    for j in range(0, len(rows), 10):
        T = ref.pose(prog.q_cmd[k0 + j])
        assert np.linalg.norm(T[:3, 3] - rows[j, 1:4]) <= 1e-9
    far = rows.copy()
    far[-40:, 1] += np.linspace(0.0, 1.2, 40)  # leaves the workspace at the end
    _write(tmp_path / "p.csv", far)
    res = mrnea_cli("check", f, "--json")
    assert res.returncode == 1, res.stderr
    out = json.loads(res.stdout)
    assert out["verdict"].startswith("NOT ACHIEVABLE: move 2 (poses)")
    assert "pose out of reach" in out["verdict"]


@pytest.mark.parametrize("mutate, words", [
    (lambda p: p.write_text("t, x, y, z, roll, pitch, yaw\n0, 0.4, 0.1, 0.3, 0, 0, 0\n"
                            "1, 0.4, 0.1, 0.3, 0, 0, 0\n"),
     ["p.csv: line 1", "'t, x, y, z, qw, qx, qy, qz'", "'roll'"]),
    (lambda p: p.write_text("# poses\n\nt, x, y, z, qw, qx, qy, qz\n0, 0.4, 0.1, 0.3, 1, 0, 0, 0\n"
                            "# the next is not unit\n1, 0.4, 0.1, 0.3, 1, 0.1, 0, 0\n"),
     ["p.csv: line 6", "unit quaternion", "1.00498756"]),
    (lambda p: p.write_text("t, x [mm], y, z, rx, ry, rz\n0, 400, 100, 300, 0, 0, 0\n"
                            "1, 400, 100, 300, 0, 0, 0\n"),
     ["p.csv: line 1", "column 'x' is in 'mm'", "'m'"]),
    (lambda p: p.write_text("t, x, y, z, rx, ry, rz\n0, 0.4, 0.1, 0.3, 0, 0, 0\n"
                            "0, 0.4, 0.1, 0.3, 0, 0, 0\n"),
     ["p.csv: line 3", "strictly increasing"]),
])
def test_bad_pose_files_are_one_error_line(tmp_path, ur5, mutate, words):
    path, _, _ = ur5
    mutate(tmp_path / "p.csv")
    f = tmp_path / "prog.toml"
    f.write_text(_program(path, QA, '[[move]]\ntype = "poses"\ncsv = "p.csv"\n'))
    one_error_line(mrnea_cli("check", f), *words)


def test_a_pose_file_that_does_not_continue_the_path_is_refused(tmp_path, ur5):
    path, robot, ref = ur5
    rows = _rows(ref, np.arange(0.0, 0.2 + 1e-9, 0.004), 1.0)
    _write(tmp_path / "p.csv", rows, comment="# a comment\n")
    moves = ('[[move]]\ntype = "joint"\ntarget = [0, -1.5, 1.5, -1.5, -1.5, 0]\n'
             'velocity_limit = 1\nacceleration_limit = 1\n'
             '[[move]]\ntype = "poses"\ncsv = "p.csv"\n')
    text = _program(path, QA, moves)
    with pytest.raises(ProgramFileError, match=r"\[\[move\]\] 2 \(poses\): .*p\.csv: line 3: "
                                               r"the first pose is [\d.]+ mm"):
        solve(loads_program(text, source=str(tmp_path / "prog.toml"), base_dir=tmp_path), robot)
    with pytest.raises(ProgramFileError, match=r"'interpolation' must be one of 'cubic', "
                                               r"'linear', got 'quintic'"):
        loads_program(_program(path, QA, '[[move]]\ntype = "poses"\ncsv = "p.csv"\n'
                                         'interpolation = "quintic"\n'), base_dir=tmp_path)


def test_a_written_pose_program_reads_back(tmp_path, ur5):
    """save_poses and dumps_program (what retime writes): a tool given by xyz/rpy (an inline
    table) and a poses move read back to the same poses (positions bit for bit, rotations to
    rounding) and tool."""
    from mrnea.io.posecsv import read_poses, save_poses
    from mrnea.io.program import dumps_program

    path, _, ref = ur5
    rows = _rows(ref, np.arange(0.0, 0.1 + 1e-9, 0.004), 1.0)
    P = np.array([np.r_[np.c_[pin.Quaternion(*r[[4, 5, 6, 7]]).toRotationMatrix(), r[1:4]],
                        [[0, 0, 0, 1]]] for r in rows])
    save_poses(tmp_path / "p.csv", rows[:, 0], P)
    t, back, _ = read_poses(tmp_path / "p.csv")
    np.testing.assert_array_equal(t, rows[:, 0])
    np.testing.assert_array_equal(back[:, :3, 3], P[:, :3, 3])
    assert np.abs(back - P).max() <= 1e-15
    tool = {"xyz": [0.0, 0.0, 0.1], "rpy": [0.1, 0.0, 0.0]}
    text = dumps_program({"name": "w", "robot": str(path), "dt": 0.004, "tool": tool,
                          "q0": QA}, None,
                         moves=[{"type": "poses", "csv": "p.csv", "interpolation": "linear"}])
    prog = loads_program(text, base_dir=tmp_path)
    assert prog.moves.tool == tool and prog.moves.moves[0].type == "poses"
    sampled = prog.moves.moves[0].poses  # the rows are the cycles: met to rounding
    np.testing.assert_array_equal(sampled[:, :3, 3], back[:, :3, 3])
    assert np.abs(sampled - back).max() <= 1e-15
