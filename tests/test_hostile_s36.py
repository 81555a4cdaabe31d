"""Hostile inputs found in session 36: each was an internal error or a silent NaN before, and
is one clear error now.

* ``mrnea identify`` on a log too short to determine every base parameter (the first 400 of the
  shipped Puma log's 2000 samples): the standard errors came out NaN, summary.json wrote null
  and the page's writer failed on it ("internal error"). The oracle that the log cannot
  determine them: numpy's rank of the base regressor over the fitted rows is below its number
  of columns.
* ``mrnea identify`` on a log whose efforts are all 0 (a log recorded without them): the
  weights overflowed and numpy's SVD did not converge ("internal error").
* A Cartesian program with a tiny ``dt`` (1e-7 s on the UR5): killed by the system for want of
  memory (exit 137) instead of refused. Its estimate (mrnea.cartesian.path.PROGRAM_BYTES) is
  checked against tracemalloc's peak, as tests/test_resources.py checks the others'.
* A jerk limit of 1e300 (a MoveL's ``jerk``, a joint move's ``jerk_limit``) or every S-curve
  limit 1e100: ruckig raised ("internal error"). The oracle: the trapezoid's closed-form
  duration D / v + v / a, which a jerk limit that large must give.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
import mrnea.resources as resources
from mrnea.cartesian.path import PROGRAM_BYTES
from mrnea.cartesian.solve import solve
from mrnea.errors import MrneaError, ProgramFileError
from mrnea.identify import identify, read_log
from mrnea.identify.base import base_parameters
from mrnea.identify.estimate import base_rows
from mrnea.io.program import loads_program
from mrnea.trajectory import scurve

LOG = Path(__file__).resolve().parents[1] / "examples" / "puma_identify_log.csv"


def _part(tmp_path: Path, rows: int, zero_efforts: bool = False) -> Path:
    lines = LOG.read_text().splitlines()[:rows + 1]
    if zero_efforts:
        n = 6
        lines = lines[:1] + [",".join(c.split(",")[:1 + n] + ["0"] * n) for c in lines[1:]]
    path = tmp_path / "log.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.slow
def test_a_log_too_short_to_determine_the_parameters_is_one_error(tmp_path: Path) -> None:
    path = _part(tmp_path, 400)
    robot = mrnea.robots.puma560()
    log = read_log(path, robot)
    base = base_parameters(robot)
    W, used = base_rows(robot, base, log, 10.0, 1e-2)
    K_fit = round(log.K * 0.8)
    A = W[:K_fit][used[:K_fit]]
    scaled = A / np.maximum(np.linalg.norm(A, axis=0), 1e-300)  # a column of zeros stays one
    assert np.linalg.matrix_rank(scaled) < A.shape[1]  # the oracle
    with pytest.raises(MrneaError, match="do not determine every base parameter"):
        identify(robot, log)
    res = mrnea_cli("identify", "puma560", path, "--out", tmp_path / "out", "--quiet")
    one_error_line(res, "log.csv", "do not determine every base parameter", "mrnea excite")
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_a_log_without_efforts_is_one_error(tmp_path: Path) -> None:
    path = _part(tmp_path, 300, zero_efforts=True)
    res = mrnea_cli("identify", "puma560", path, "--out", tmp_path / "out", "--quiet")
    one_error_line(res, "log.csv", "the effort of joint 'joint1' is 0")
    assert not (tmp_path / "out").exists()


# --- Cartesian programs: memory ------------------------------------------------------------------
Q_A = [0.2, 0.8, -2.4, 0.1, 1.0, 0.2]
TOOL = 'tool = { xyz = [0.0, 0.0, 0.1], rpy = [0.0, 0.0, 0.0] }\n'


def _cartesian(dt: float, moves: str) -> str:
    return f'[program]\nrobot = "puma560"\ndt = {dt}\nq0 = {Q_A}\n{TOOL}{moves}'


JOINT = ('[[move]]\ntype = "joint"\ntarget = [0.5, 0.6, -2.2, 0.3, 1.2, 0.4]\n'
         'velocity_limit = 0.5\nacceleration_limit = 1.0\n')


def _linear(robot: mrnea.Robot, dz: float) -> str:
    T = mrnea.forward_kinematics(robot, Q_A, tool={"xyz": [0, 0, 0.1], "rpy": [0, 0, 0]})[-1]
    return (f'[[move]]\ntype = "linear"\nxyz = {(T[:3, 3] + [0, 0, dz]).tolist()}\n'
            'speed = 0.05\nacceleration = 0.5\n')


@pytest.mark.parametrize("kind", ["joint", "linear", "two linear"])
def test_the_cartesian_estimate_bounds_a_programs_peak(kind: str) -> None:
    robot = mrnea.robots.puma560()
    moves = {"joint": JOINT, "linear": _linear(robot, 0.05),
             "two linear": _linear(robot, 0.05) + _linear(robot, 0.0)}[kind]
    solve(loads_program(_cartesian(0.004, moves)), robot)  # compiled: not the program's memory
    tracemalloc.start()
    try:
        prog = solve(loads_program(_cartesian(2e-5, moves)), robot)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    K = prog.q_cmd.shape[0]
    assert K > 50_000
    estimate = PROGRAM_BYTES * K * (robot.n + 2)
    assert peak <= estimate, (peak, estimate)
    assert peak >= estimate / 4, (peak, estimate)  # an estimate, not a blanket refusal


@pytest.mark.parametrize("name, budget", [("joint", 10e6), ("linear", 4e6)])
def test_a_cartesian_program_over_the_budget_is_refused(monkeypatch, name: str,
                                                        budget: float) -> None:
    """A budget the move's own profile fits (its check is the trajectory's, 336 and 96 bytes a
    cycle here) but the program does not (11,000 cycles)."""
    monkeypatch.setattr(resources, "available_memory", lambda: budget * 4 / 3)
    monkeypatch.setattr(resources, "BUDGET_FLOOR", 0)
    robot = mrnea.robots.puma560()
    moves = JOINT if name == "joint" else _linear(robot, 0.05)
    with pytest.raises(ProgramFileError, match=rf"\[\[move\]\] 1 \({name}\): a Cartesian "
                       r"program of .* cycles of 6 joints needs about .*coarser dt"):
        solve(loads_program(_cartesian(1e-4, moves)), robot)


@pytest.mark.slow
def test_cli_cartesian_program_with_a_tiny_dt(tmp_path: Path) -> None:
    """2e-9 s: 1.8e8 cycles of the joint move, about 400 GB: refused on any machine."""
    (tmp_path / "p.toml").write_text(_cartesian(2e-9, JOINT))
    res = mrnea_cli("check", tmp_path / "p.toml", timeout=300)
    one_error_line(res, "p.toml", "[[move]] 1 (joint)", "of memory", "coarser dt")


# --- S-curves with limits far beyond reach --------------------------------------------------------
@pytest.mark.parametrize("jerk", [1e200, 1e300])
def test_a_huge_jerk_limit_gives_the_trapezoid(jerk: float) -> None:
    dt, v, a = 0.004, 1.0, 2.0
    _, q = scurve([[0.0, 0.0], [1.0, -0.5]], dt, v, a, jerk)
    T = 1.0 / v + v / a  # the trapezoid's duration over D = 1 (the leading joint)
    assert len(q) == round(T / dt) + 1
    qd = np.diff(q, axis=0) / dt
    assert np.abs(qd).max() <= v * (1 + 1e-9)
    assert np.abs(np.diff(qd, axis=0) / dt).max() <= a * (1 + 1e-6)


def test_every_scurve_limit_huge_moves_in_one_cycle() -> None:
    _, q = scurve([[0.0], [1.0]], 0.004, 1e100, 1e100, 1e100)
    assert q[:, 0].tolist() == [0.0, 1.0]


@pytest.mark.slow
def test_cli_jerk_limit_1e300(tmp_path: Path) -> None:
    (tmp_path / "p.toml").write_text(
        '[program]\nrobot = "puma560"\ndt = 0.004\nq0 = [0, 0, 0, 0, 0, 0]\n[[move]]\n'
        'type = "joint"\ntarget = [0.5, 0.2, 0.1, 0, 0, 0]\nprofile = "scurve"\n'
        'velocity_limit = 1e100\nacceleration_limit = 1e100\njerk_limit = 1e300\n')
    res = mrnea_cli("check", tmp_path / "p.toml", "--quiet", timeout=300)
    assert res.returncode in (0, 1), res.stderr  # a verdict, whichever: no internal error
    assert "error" not in res.stderr
