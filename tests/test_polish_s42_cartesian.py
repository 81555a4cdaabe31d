"""Session 42, Cartesian programs: Ctrl-C during a long solve, and hostile moves and pose CSVs.

* A Cartesian program of about a million cycles: ``mrnea check`` (a real process) answers the
  first SIGINT within a bound, not after the whole solve (seconds: the inverse kinematics and the
  verdict's singular values were each one call over every cycle); the solve in blocks gives the
  same numbers, bit for bit, as in one call (the kernel's contract, checked against one call).
* Hostile inputs: each gets one error naming the file, the move and the key (exit 2 on the
  command line), or a verdict (exit 1); never a traceback, a NaN or a hang. Oracles: the
  geometry of the moves written here (a circle through three points, plain arithmetic).
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea import resources
from mrnea.errors import ProgramFileError
from mrnea.ik import BLOCK, solve_path
from mrnea.kernels.ik import ik_path

# The Puma 560 (built in) at a regular pose, its tool at (0.399, -0.072, 1.347) m; a MoveL of
# 0.234 m at 0.025 m/s takes 9.4 s: about 940,000 cycles at dt = 10 us.
PUMA_Q0 = [0.2, 0.6, -0.6, 0.3, 0.9, 0.2]
LONG_MOVE = """
[[move]]
type = "linear"
xyz = [0.25, 0.03, 1.2]
speed = 0.025
acceleration = 1.0
"""


def _puma_program(dt: float, moves: str = LONG_MOVE, extra: str = "") -> str:
    return f'[program]\nrobot = "puma560"\ndt = {dt}\nq0 = {PUMA_Q0}\n{extra}{moves}'


def _rss_mib(pid: int) -> float:
    """The resident memory of process ``pid`` [MiB] (Linux /proc), 0 once it is gone."""
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return 0.0


# --- Ctrl-C during a long Cartesian solve ------------------------------------------------------
@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads /proc (Linux)")
def test_ctrl_c_stops_a_long_cartesian_check_promptly(tmp_path: Path) -> None:
    """SIGINT once the million-cycle solve is under way (its tool poses allocated: 120 MB more
    than the interpreter's 170) ends ``mrnea check`` within 2.5 s, exit 130, one line."""
    short, long = tmp_path / "short.toml", tmp_path / "long.toml"
    short.write_text(_puma_program(1e-3))  # the same moves, 9,355 cycles: compiles the kernels
    long.write_text(_puma_program(1e-5))
    warm = mrnea_cli("check", short)
    assert warm.returncode == 0, warm.stderr
    proc = subprocess.Popen([sys.executable, "-m", "mrnea", "check", str(long)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while _rss_mib(proc.pid) < 260 and proc.poll() is None:  # the poses are made
            assert time.monotonic() < deadline, "the long solve never started"
            time.sleep(0.02)
        time.sleep(0.5)  # well into the inverse kinematics (about 3 s of it, 9 before the fix)
        assert proc.poll() is None, proc.communicate()
        sent = time.monotonic()
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
        took = time.monotonic() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 130, (proc.returncode, stderr)
    assert stderr.strip().splitlines() == ["mrnea: interrupted"], stderr
    assert "ACHIEVABLE" not in stdout and "Traceback" not in stderr
    assert took < 2.5, f"the interrupt took {took:.2f} s"


def test_the_solve_in_blocks_is_the_solve_in_one_call() -> None:
    """solve_path (blocks of BLOCK poses, a checkpoint between) against one call of the kernel
    over every pose: the same q and errors, bit for bit, and the checkpoint called between
    blocks only."""
    robot = mrnea.robots.puma560()
    q0 = np.array(PUMA_Q0)
    K = 2 * BLOCK + 123
    # a path that bends: a helix of the tool point, the orientation turning about z
    T0 = mrnea.forward_kinematics(robot, q0)[-1]
    s = np.linspace(0.0, 1.0, K)
    P = np.repeat(T0[None], K, axis=0)
    P[:, :3, 3] += 0.03 * np.column_stack([np.cos(3 * s) - 1, np.sin(3 * s), -s])  # within reach
    c, w = np.cos(0.5 * s), np.sin(0.5 * s)
    Rz = np.zeros((K, 3, 3))
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, -w, w, c, 1.0
    P[:, :3, :3] = Rz @ T0[:3, :3]
    calls = []
    res = solve_path(robot, P, q0, checkpoint=lambda: calls.append(1))
    assert len(calls) == 2  # between the three blocks
    Q, ERR = np.empty((K, 6)), np.empty((K, 3))
    m = mrnea.compiled.of(robot)[0]
    ik_path(m, P, robot.n - 1, np.zeros(3), np.eye(3), np.arange(6), q0, Q, ERR,
            mrnea.ik.TOL_POSITION, mrnea.ik.TOL_ORIENTATION, mrnea.ik.MAX_ITERATIONS, 0, K)
    assert res.q.tobytes() == Q.tobytes()
    assert res.position_error.tobytes() == ERR[:, 0].tobytes()
    assert res.orientation_error.tobytes() == ERR[:, 1].tobytes()
    assert res.converged.all()
    # an independent check of the numbers: the forward kinematics of q is on the path
    T = mrnea.forward_kinematics(robot, res.q[::997])[:, -1]
    assert np.abs(T - P[::997]).max() < 1e-9


def test_a_stop_request_stops_the_library_solve() -> None:
    """A checkpoint that raises (the command line's stop request) stops mrnea.cartesian.solve
    between blocks: KeyboardInterrupt, not the whole solve first."""
    from mrnea.cartesian import solve
    from mrnea.io.program import loads_program

    prog = loads_program(_puma_program(1e-4))  # 93,544 cycles: three blocks
    robot = mrnea.robots.puma560()
    calls = []

    def stop() -> None:
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        solve(prog, robot, checkpoint=stop)
    assert len(calls) == 3


# --- hostile moves ---------------------------------------------------------------------------
def test_a_dwell_beyond_the_memory_budget_is_refused_naming_the_move(monkeypatch) -> None:
    """A dwell's cycles count in the memory check as a move's do: refused before the arrays of
    a long hold are made (they were not: 10^7 cycles of hold were made, then their findings and
    simulation took minutes, or the system ran out of memory)."""
    from mrnea.cartesian import solve
    from mrnea.io.program import loads_program

    monkeypatch.setattr(resources, "available_memory", lambda: 16 * 10**7 / 3)  # 40 MB budget
    monkeypatch.setattr(resources, "BUDGET_FLOOR", 0)
    robot = mrnea.robots.puma560()
    # the move alone (9,355 cycles, 320 bytes * 8 per cycle: 24 MB) fits
    assert solve(loads_program(_puma_program(1e-3)), robot).q_cmd.shape[0] < 10_000
    held = LONG_MOVE + "dwell = 10.0\n"  # 10,000 cycles more: 50 MB in all
    with pytest.raises(ProgramFileError, match=r"\[\[move\]\] 1 \(linear\): 'dwell' 10 s: .*"
                                                r"memory"):
        solve(loads_program(_puma_program(1e-3, held), source="held.toml"), robot)


def test_a_dwell_of_too_many_cycles_names_the_file_and_move(tmp_path: Path) -> None:
    """dwell = 1e9 s at dt = 1 ms: one error line naming the file, the move and 'dwell' (it
    named neither, and its advice was the speed limits)."""
    f = tmp_path / "dwell.toml"
    f.write_text(_puma_program(1e-3, LONG_MOVE + "dwell = 1e9\n"))
    one_error_line(mrnea_cli("check", f), "dwell.toml", "[[move]] 1 (linear)", "'dwell'",
                   "1e+12 cycles")


@pytest.mark.parametrize(("key", "line"), [("rpy", "rpy = [1e300, 0.0, 0.0]"),
                                           ("tool.rpy", "tool = {xyz = [0, 0, 0.1], "
                                                        "rpy = [0.0, -2e4, 0.0]}")])
def test_an_angle_of_many_turns_is_refused(tmp_path: Path, key: str, line: str) -> None:
    """A target's or a tool's roll, pitch or yaw beyond 1e4 rad (1,600 turns; cos(1e300) is a
    number, but not the angle anyone meant) is refused as a pose CSV's rotation angle is, not
    solved (it was: exit 0 or 1)."""
    f = tmp_path / "turns.toml"
    f.write_text(_puma_program(1e-3, LONG_MOVE + line + "\n"))
    one_error_line(mrnea_cli("check", f), "turns.toml", "[[move]] 1 (linear)", f"'{key}'",
                   "10000 rad")


def test_a_joint_limit_crossed_on_every_cycle_is_found_once_per_move() -> None:
    """Every cycle of a move beyond a joint limit (q0 beyond joint 3's upper limit, 0.7854 rad):
    one finding per move, at its first cycle, with the joint and limit read off the robot (the
    findings were worded for every cycle over, then all but the first dropped)."""
    from mrnea.cartesian import solve
    from mrnea.io.program import loads_program

    robot = mrnea.robots.puma560()
    q0 = [0.2, 0.6, 1.0, 0.3, 0.9, 0.2]
    T = mrnea.forward_kinematics(robot, np.array(q0))[-1]
    target = (T[:3, 3] + [0.0, 0.0, -0.02]).tolist()
    moves = (f'[[move]]\ntype = "linear"\nxyz = {target}\nspeed = 0.1\nacceleration = 1.0\n'
             f'dwell = 0.1\n\n[[move]]\ntype = "linear"\nxyz = {T[:3, 3].tolist()}\n'
             f"speed = 0.1\nacceleration = 1.0\n")
    text = f'[program]\nrobot = "puma560"\ndt = 0.001\nq0 = {q0}\n{moves}'
    path = solve(loads_program(text), robot).cartesian
    limits = [f for f in path.findings if f.kind == "joint_limit"]
    assert [(f.move, f.joint) for f in limits] == [(1, "joint3"), (2, "joint3")]
    assert limits[0].t == 0.0
    assert f"beyond its upper limit {robot.upper[2]:.4g} rad" in limits[0].message
    first2 = int(np.flatnonzero(path.move == 2)[0])
    assert limits[1].t == pytest.approx(first2 * 0.001)
