"""Session 41: what a hostile-input hunt found in Cartesian programs and retiming.

* A joint move (MoveJ) to where the robot already is: no cycle of its own (its dwell, if any,
  holds); it had stopped the program with an internal error (an empty pose array of the wrong
  dimensions).
* A pose CSV's positions and rotation vectors, and a move's ``xyz`` and ``via``, are bounded as a
  robot's lengths are (1e4 m; a rotation vector's angle 1e4 rad): beyond, the tool path printed
  "inf mm" and the simulation's summary failed, or scipy's rotation became NaN.
* The retiming's check of the dwells computes them in blocks of ``HOLD_ROWS`` rows with a stop
  request taken between blocks: a program with a 1000 s dwell at 1 ms took 8 s to answer Ctrl-C
  (the guarantee is 1 s) and held 2e6 mass matrices at once.
"""

from __future__ import annotations

import importlib
import json
import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mrnea
from mrnea.cartesian import solve
from mrnea.errors import ProgramFileError
from mrnea.io.program import loads_program
from mrnea.trajectory import quintic

Q0 = [0.0, 0.785, -2.356, 0.0, -0.785, 0.0]
HEAD = f'[program]\nrobot = "puma560"\ndt = 0.005\nq0 = {Q0}\n'


def _solved(text: str, folder: Path | None = None):
    if folder is not None:
        (folder / "prog.toml").write_text(text)
        return solve(mrnea.load_program(folder / "prog.toml"), mrnea.robots.puma560())
    return solve(loads_program(text), mrnea.robots.puma560())


def _joint_move(target, dwell: float | None = None) -> str:
    extra = "" if dwell is None else f"dwell = {dwell}\n"
    return (f'[[move]]\ntype = "joint"\ntarget = {list(target)}\nvelocity_limit = 1.0\n'
            f"acceleration_limit = 1.0\n{extra}")


def test_a_joint_move_to_where_the_robot_is_holds_its_dwell() -> None:
    """Its dwell of 0.1 s at 5 ms: the start row and 20 cycles at q0; with a move after it,
    that move's cycles follow the hold."""
    prog = _solved(HEAD + _joint_move(Q0, dwell=0.1))
    assert prog.q_cmd.shape == (21, 6)
    assert np.array_equal(prog.q_cmd, np.tile(Q0, (21, 1)))
    moved = list(Q0)
    moved[0] = 0.2
    prog = _solved(HEAD + _joint_move(Q0) + _joint_move(Q0, 0.1) + _joint_move(moved))
    assert np.array_equal(prog.q_cmd[:21], np.tile(Q0, (21, 1)))
    assert prog.q_cmd[-1, 0] == pytest.approx(0.2) and np.all(np.diff(prog.q_cmd[20:, 0]) > 0)
    with pytest.raises(ProgramFileError, match="the moves take a single cycle"):
        _solved(HEAD + _joint_move(Q0))  # nothing moves and nothing holds: one cycle


def _pose_program(tmp_path: Path, rows: list[str]) -> str:
    (tmp_path / "poses.csv").write_text("t,x,y,z,rx,ry,rz\n" + "\n".join(rows) + "\n")
    return HEAD + '[[move]]\ntype = "poses"\ncsv = "poses.csv"\n'


@pytest.mark.parametrize("row,match", [
    ("2,1e160,-0.15,0.95,0,0,0", r"poses.csv: line 4: x 1e\+160 m is beyond 10000 m"),
    ("2,0.7,-0.15,-2e4,0,0,0", r"poses.csv: line 4: z 2e\+04 m is beyond 10000 m"),
    ("2,0.7,-0.15,0.95,0,1e155,0", r"poses.csv: line 4: rx, ry, rz: the rotation's angle "
                                   r"1e\+155 rad is beyond 10000 rad"),
    ("2,0.7,-0.15,0.95,8e3,8e3,0", r"line 4: rx, ry, rz: the rotation's angle 1.13e\+04 rad"),
])
def test_a_pose_csv_beyond_the_bounds_names_its_line(tmp_path: Path, row: str,
                                                     match: str) -> None:
    start = "0,0.737246111104231,-0.15005,0.9566491675329917,0,0,0"
    text = _pose_program(tmp_path, [start, "1,0.73,-0.15,0.95,0,0,0", row])
    with pytest.raises(ProgramFileError, match=match):
        _solved(text, tmp_path)


@pytest.mark.parametrize("key,value", [("xyz", "[1e160, -0.15, 0.9]"),
                                       ("via", "[0.5, 2e4, 0.9]")])
def test_a_moves_point_beyond_the_bound_is_named(key: str, value: str) -> None:
    move = ('[[move]]\ntype = "circular"\nxyz = [0.5, -0.1, 0.9]\nvia = [0.55, -0.12, 0.9]\n'
            "speed = 0.1\nacceleration = 1.0\n")
    move = move.replace(f"{key} = [", f"{key} = {value}\nold_{key} = [", 1)
    move = "\n".join(line for line in move.splitlines() if not line.startswith("old_"))
    with pytest.raises(ProgramFileError,
                       match=rf"\[\[move\]\] 1 \(circular\): '{key}' .* m is beyond 10000 m"):
        _solved(HEAD + move + "\n")


def test_the_dwells_are_checked_in_blocks_between_stop_requests(monkeypatch) -> None:
    """HOLD_ROWS rows at a time, a checkpoint before each block: the retimed program is the one
    the unblocked check gives, and a stop request during the check ends it at the next block."""
    core = importlib.import_module("mrnea.retime.core")
    robot = mrnea.robots.puma560()
    q = quintic(np.array([[0.0] * 6, [0.5] * 6]), 0.01, np.full(6, 0.5), np.full(6, 1.0),
                dwell=np.array([2.0, 1.0]))[1]
    whole = mrnea.retime(robot, q, dt=0.01)
    sizes = []
    real = core.actuator_mass_matrix_and_bias

    def counted(robot, q, *args):
        sizes.append(q.shape[0])
        return real(robot, q, *args)

    monkeypatch.setattr(core, "actuator_mass_matrix_and_bias", counted)
    monkeypatch.setattr(core, "HOLD_ROWS", 16)
    blocked = mrnea.retime(robot, q, dt=0.01)
    assert np.array_equal(blocked.q_cmd, whole.q_cmd)
    assert max(sizes) == 16 and sum(sizes) >= 300  # the 3 s of dwells, 16 rows at a time
    calls = []

    def stop_on_the_third_block() -> None:
        calls.append(len(sizes))
        if len(calls) > 1 and len(sizes) - first >= 3:
            raise KeyboardInterrupt

    sizes.clear()
    first = 0
    with pytest.raises(KeyboardInterrupt):
        mrnea.retime(robot, q, dt=0.01, checkpoint=stop_on_the_third_block)
    assert len(sizes) == 3  # stopped before the fourth block


# --- the library and sweep hunt -------------------------------------------------------------

PICK = Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml"


def test_a_time_scale_that_skips_the_path_is_refused_with_one_that_keeps_it() -> None:
    """0.001 left the pick program two rows (start and end are one pose): it was 'achievable'
    without moving. The refusal's factor keeps the path: the rows then
    meet every program row within 1e-3 rad (checked here by NumPy's interpolation)."""
    prog = mrnea.load_program(PICK)
    with pytest.raises(mrnea.MrneaError, match=r"factor: 0.001 makes program 'puma_pick' too "
                                               r"fast .* a factor of ([0-9.]+) or more"
                       ) as e:
        mrnea.sweep.time_scaled(prog, 1e-3)
    keep = float(str(e.value).split("a factor of ")[1].split(" ")[0])
    scaled = mrnea.sweep.time_scaled(prog, keep)
    s = np.minimum(np.arange(scaled.q_cmd.shape[0]) * prog.dt / keep, prog.t[-1])
    for j in range(6):
        assert np.abs(np.interp(prog.t, s, scaled.q_cmd[:, j]) - prog.q_cmd[:, j]).max() <= 1e-3
    assert mrnea.sweep.time_scaled(prog, 0.5).q_cmd.shape[0] == math.ceil(0.5 * (980 - 1)) + 1


def test_sweep_grid_refusals_before_any_work(tmp_path: Path) -> None:
    """A time scale that skips the path and a payload point beyond 1e4 m name the grid file;
    an unknown robot is named as such (not as a mismatch); no output folder is made."""
    shutil.copy(PICK, tmp_path / "pick.toml")
    cases = {"time_scale = [1e-3]": r"g.toml: grid entry 'time_scale' value 1 \(0.001\): factor",
             "payload = [1]\npayload_point = [[1e300, 0, 0]]":
                 r"g.toml: grid entry 'payload_point' value 1 .* is beyond 10000 m"}
    for grid, match in cases.items():
        (tmp_path / "g.toml").write_text(f'[sweep]\nrobot = "puma560"\nprograms = '
                                         f'["pick.toml"]\n[grid]\n{grid}\n')
        out = subprocess.run([sys.executable, "-m", "mrnea", "sweep", "--grid", "g.toml", "--out",
                              "o", "-q"], cwd=tmp_path, capture_output=True, text=True,
                             timeout=120)
        assert out.returncode == 2, out.stderr
        lines = out.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("mrnea: error: ")
        assert re.search(match, lines[0]), lines[0]
        assert not (tmp_path / "o").exists()
    (tmp_path / "g.toml").write_text('[sweep]\nrobot = "nosuch"\nprograms = ["pick.toml"]\n'
                                     "[grid]\npayload = [1]\n")
    out = subprocess.run([sys.executable, "-m", "mrnea", "sweep", "--grid", "g.toml", "--out",
                          "o", "-q"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "'nosuch' is neither a built-in robot" in out.stderr


def test_more_local_workers_than_memory_holds_are_refused_before_any_starts() -> None:
    robot = mrnea.robots.puma560()
    prog = mrnea.load_program(PICK)
    with pytest.raises(mrnea.errors.SweepError,
                       match=r"a local cluster of 100000000000000000000 worker processes needs "
                             r"about .* of memory"):
        mrnea.sweep(robot, [prog], {"payload": [0.0, 1.0]}, workers=10**20)


def test_jerk_limits_too_small_are_a_jerk_limit_error(recwarn) -> None:
    """1e-12 rad/s^3: the jerk-limited solve's speed was 0 everywhere and the next weights
    1/0 (scipy's ValueError escaped, after two RuntimeWarnings)."""
    robot, z = mrnea.robots.puma560(), np.zeros(6)
    q = quintic([z, z + 0.3], dt=0.01, velocity_limit=1.0, acceleration_limit=2.0)[1]
    for jerk in (1e-12, 1e-300):
        with pytest.raises(mrnea.errors.JerkLimitError, match="jerk_limit: too small to plan"):
            mrnea.retime(robot, q, dt=0.01, jerk_limit=np.full(6, jerk))
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


@pytest.mark.parametrize("call,match", [
    (lambda r: mrnea.jacobian(r, np.zeros(6), link=["link6"]),
     r"^link: expected a link's or frame's name \(str\), got list \['link6'\]$"),
    (lambda r: r.with_actuators(effort_limit=np.ones((6, 2))),
     r"^with_actuators: effort_limit must be .* got ndarray array\(\[\[1\., 1\.\], \[1\.,"),
    (lambda r: mrnea.simulate(r, np.zeros((3, 6)), 1e300),
     r"^dt: must be a finite time step > 0 s and at most 1000 s, got 1e\+300$"),
])
def test_api_refusals_are_one_line_errors(call, match: str) -> None:
    with pytest.raises(mrnea.MrneaError) as e:
        call(mrnea.robots.puma560())
    assert "\n" not in str(e.value)
    assert re.search(match, str(e.value)), str(e.value)


# --- the command's entry point ----------------------------------------------------------------

def _launch(code: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)


def test_a_stop_while_python_imports_mrnea_is_a_stop_not_a_traceback() -> None:
    """Ctrl-C in the half second the imports take (here raised by the import of mrnea.cli
    itself): one line, exit 130, as any stop before the work."""
    out = _launch("import builtins, sys\n"
                  "real = builtins.__import__\n"
                  "def imp(name, *a, **k):\n"
                  "    if name == 'mrnea.cli':\n"
                  "        raise KeyboardInterrupt\n"
                  "    return real(name, *a, **k)\n"
                  "builtins.__import__ = imp\n"
                  "sys.argv = ['mrnea', 'info', 'puma560']\n"
                  "import mrnea_launcher\n"
                  "mrnea_launcher.main()\n")
    assert out.returncode == 130 and out.stderr == "mrnea: interrupted\n" and out.stdout == ""


def test_a_signal_after_the_answer_leaves_its_exit_code() -> None:
    """SIGINT and SIGTERM sent once the command returned (here from an exit handler, in the
    interpreter's teardown): the answer printed and its exit code 0 stand (it was 130)."""
    for sig in ("SIGINT", "SIGTERM"):
        out = _launch("import atexit, os, signal, sys\n"
                      f"atexit.register(lambda: os.kill(os.getpid(), signal.{sig}))\n"
                      "sys.argv = ['mrnea', 'info', 'puma560']\n"
                      "import mrnea_launcher\n"
                      "mrnea_launcher.main()\n")
        assert out.returncode == 0, (sig, out.returncode, out.stderr)
        assert "joint1" in out.stdout and out.stderr == ""


@pytest.mark.parametrize("at", ["sizing", "writing"])
def test_size_stopped_writes_nothing(monkeypatch, tmp_path: Path, at: str) -> None:
    """A stop request during the sizing (taken when it ends) or while its files are written
    (after summary.json's contents are made): exit 130, 'mrnea: interrupted', no file left,
    nothing printed on stdout (it had exited 0 with every file written)."""
    from click.testing import CliRunner
    from test_sizing import write_cli_case

    import mrnea.sizing
    import mrnea.sizing.output
    from mrnea.cli import base, main

    write_cli_case(tmp_path)
    module, name = ((mrnea.sizing, "size_drives") if at == "sizing"
                    else (mrnea.sizing.output, "sizing_summary"))
    real = getattr(module, name)

    def then_stop(*args, **kw):
        out = real(*args, **kw)
        base._request_stop(15, None)
        return out

    monkeypatch.setattr(module, name, then_stop)
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(main, ["size", "arm.toml", "swing.toml", "--catalogue", "cat.toml",
                                    "--out", "out"])
    assert res.exit_code == 130, res.output
    assert res.stdout == "" and "mrnea: interrupted" in res.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


# --- a robot that runs away is a verdict ------------------------------------------------------

def test_a_robot_thrown_by_a_wrench_runs_away_as_a_verdict() -> None:
    """A 1e6 N force on the Puma 560's flange, 4,800 times what joint 3 holds: the simulated
    robot accelerates without bound (the run had ended with 'the state became non-finite',
    exit 2). The run stops at the first cycle faster than RUNAWAY_SPEED: its cycles are those
    before it, every number finite, the summary valid, the verdict NOT ACHIEVABLE saying when.
    At 1e4 N the drives saturate and the robot sags, but it does not run away."""
    from test_summary_schema import valid

    from mrnea.simulate import RUNAWAY_SPEED

    robot = mrnea.robots.puma560()
    q = quintic(np.array([[0.0] * 6, [1.0] + [0.0] * 5]), 0.005, np.ones(6), np.ones(6))[1]
    res = mrnea.simulate(robot, q, 0.005, f_ext=np.array([1e6, 0, 0, 0, 0, 0]))
    assert res.completed and res.achievable is False and res.runaway_time is not None
    assert 0 < res.K < q.shape[0] and res.runaway_time == pytest.approx(res.K * 0.005)
    assert np.abs(res.qd).max() <= RUNAWAY_SPEED
    for name in ("q", "qd", "qdd", "tau", "tau_required", "reaction", "program_effort"):
        assert np.isfinite(getattr(res, name)).all(), name
    s = valid(res.summary())
    assert s["runaway_time"] == res.runaway_time and s["cycles"] == res.K
    assert re.fullmatch(r"NOT ACHIEVABLE: joint3 needs .* at t = [0-9.]+ s \(first over the "
                        r"limit at t = 0\.000 s\); the simulated robot ran away at t = "
                        rf"{res.runaway_time:.3f} s \(its speed grew without bound: the drives "
                        r"cannot hold it\) and the run stops there", res.verdict())
    assert res.final_position_line() is None
    sagged = mrnea.simulate(robot, q, 0.005, f_ext=np.array([1e4, 0, 0, 0, 0, 0]))
    assert sagged.runaway_time is None and sagged.K == q.shape[0] and not sagged.achievable
    assert valid(sagged.summary())["runaway_time"] is None


def test_a_run_away_on_the_command_line_is_exit_1_with_whole_files(tmp_path: Path) -> None:
    (tmp_path / "thrown.toml").write_text(
        '[program]\nrobot = "puma560"\ndt = 0.005\n[path]\nprofile = "trapezoidal"\n'
        "waypoints = [[0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0]]\nvelocity_limit = 1\n"
        "acceleration_limit = 1\n[wrench]\ntimes = [0]\nvalues = [[1e6, 0, 0, 0, 0, 0]]\n")
    out = subprocess.run([sys.executable, "-m", "mrnea", "simulate", "thrown.toml", "--out", "o",
                          "--no-3d"], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert out.returncode == 1, out.stderr
    assert "the simulated robot ran away at t = " in out.stdout
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    rows = (tmp_path / "o" / "cycles.csv").read_text().splitlines()
    assert len(rows) == 1 + summary["cycles"] and summary["runaway_time"] > 0
    assert not re.search(r"(?i)\b(inf|nan)\b", "\n".join(rows[1:]))
    assert "the robot ran away" in (tmp_path / "o" / "report.html").read_text()


@pytest.mark.parametrize("extra,match", [
    ("values = [[1e200, 0, 0, 0, 0, 0]]", r"\[wrench\]: 'values' row 1: 1e\+200 is beyond 1e\+10"),
    ("values = [[1, 1, 1, 0, 0, 0]]\npoint = [1e300, 0, 0]",
     r"\[wrench\]: 'point' 1e\+300 m is beyond 10000 m"),
])
def test_a_wrench_beyond_the_bounds_names_its_key(extra: str, match: str) -> None:
    """1e200 N ended in the cycle solve's step bound ('please report'); a point at 1e300 m in
    a non-finite state."""
    text = ('[program]\nrobot = "puma560"\ndt = 0.005\n[path]\nprofile = "trapezoidal"\n'
            "waypoints = [[0, 0, 0, 0, 0, 0], [1, 0, 0, 0, 0, 0]]\nvelocity_limit = 1\n"
            f"acceleration_limit = 1\n[wrench]\ntimes = [0]\n{extra}\n")
    with pytest.raises(ProgramFileError, match=match):
        loads_program(text)


def test_a_log_in_other_units_is_refused_naming_the_column(tmp_path: Path) -> None:
    """A log whose header says degrees (or milliseconds) was read as radians (seconds): the
    identification ran and wrote a wrong robot. Now an error naming the column; mrnea's own
    units in other spellings ([Nm], [rad/s^2] as [rad/s2]) are read."""
    from mrnea.errors import LogFileError
    from mrnea.identify.log import read_log

    robot = mrnea.robots.puma560()
    lines = (Path(__file__).resolve().parents[1] / "examples"
             / "puma_identify_log.csv").read_text().splitlines()
    for old, new, match in (("joint2 [rad]", "joint2 [deg]", "column 'joint2' is in 'deg'"),
                            ("time [s]", "time [ms]", "column 'time' is in 'ms'")):
        (tmp_path / "log.csv").write_text("\n".join([lines[0].replace(old, new), *lines[1:]]))
        with pytest.raises(LogFileError, match=rf"log.csv: row 1: {re.escape(match)}; a log "):
            read_log(tmp_path / "log.csv", robot)
    (tmp_path / "log.csv").write_text("\n".join([lines[0].replace("[N m]", "[Nm]"), *lines[1:]]))
    assert read_log(tmp_path / "log.csv", robot).q.shape[1] == 6


def test_a_log_value_beyond_the_bound_names_its_row_and_column(tmp_path: Path) -> None:
    """It said 'tau of joint 3 ... at sample 499' (the docs promise the file's row and the
    column's name)."""
    from mrnea.errors import LogFileError
    from mrnea.identify.log import read_log

    lines = (Path(__file__).resolve().parents[1] / "examples"
             / "puma_identify_log.csv").read_text().splitlines()
    cells = lines[500].split(",")
    cells[9] = "1e200"  # tau_joint3, on the file's row 501
    lines[500] = ",".join(cells)
    (tmp_path / "log.csv").write_text("\n".join(lines))
    with pytest.raises(LogFileError, match=r"log.csv: row 501: column 'tau_joint3' is 1e\+200, "
                                           r"beyond 1e\+12"):
        read_log(tmp_path / "log.csv", mrnea.robots.puma560())


def test_excitation_limits_name_what_was_given() -> None:
    """More than 20 harmonics refused (100 ran SLSQP steps of minutes that a stop request waited
    for); a base frequency whose one period is too many cycles blames the frequency (it blamed a
    duration that was not given)."""
    robot = mrnea.robots.puma560()
    with pytest.raises(mrnea.MrneaError, match=r"^harmonics: at most 20 .* got 100$"):
        mrnea.excitation(robot, harmonics=100)
    with pytest.raises(mrnea.MrneaError, match=r"^base_frequency: one period, 1 / base_frequency "
                                               r"= 1e\+300 s, at dt = 0.005 s is 2e\+302 cycles"):
        mrnea.excitation(robot, base_frequency=1e-300)
    with pytest.raises(mrnea.MrneaError, match=r"^duration: 1e\+07 s at dt"):
        mrnea.excitation(robot, base_frequency=0.1, duration=1e7)


def test_drive_and_sizing_bounds() -> None:
    """Efficiency below 0.01 is refused (1e-300 gave a 300-digit effort ratio); a check whose
    rating is 0 where it is needed says so in words, never 'inf x'; a joint named twice."""
    from mrnea.sizing import size_drives
    from mrnea.sizing.checks import CHECKS, reason, times

    with pytest.raises(mrnea.MrneaError, match=r"efficiency must be in \[0.01, 1\], got 0.005"):
        mrnea.robots.puma560().with_actuators(efficiency=0.005)
    assert mrnea.robots.puma560().with_actuators(efficiency=0.01).joints[0].efficiency == 0.01
    ratios = np.array([np.inf, 1.5] + [0.0] * (len(CHECKS) - 2))
    assert reason(ratios) == ("beyond its peak torque (at speed), which gives nothing where it "
                              "is needed; 1.5 x its RMS rating")
    assert times(2.0, "rms") == "2 x its RMS rating"
    with pytest.raises(mrnea.MrneaError, match="joints: 'cab_yaw' given twice"):
        size_drives(mrnea.robots.sdt(), "demo", EXAMPLES_DIR / "drives_catalogue.toml",
                    joints=["cab_yaw", "cab_yaw"])


EXAMPLES_DIR = Path(__file__).resolve().parents[1] / "examples"


def test_a_wrench_beyond_the_bound_through_the_api_and_a_runaway_row() -> None:
    """The bound holds for the library's simulate too (1e21 N ended in the cycle solve's
    'please report'); a sweep row carries the run's runaway_time [s]."""
    from mrnea.sweep.rows import QUANTITY, TOP_COLUMNS

    robot = mrnea.robots.puma560()
    q = np.zeros((3, 6))
    with pytest.raises(mrnea.MrneaError, match=r"^f_ext: 1e\+21 is beyond 1e\+10 N"):
        mrnea.simulate(robot, q, 0.01, f_ext=np.array([1e21, 0, 0, 0, 0, 0]))
    with pytest.raises(mrnea.MrneaError, match=r"^f_ext: 1e\+21 is beyond 1e\+10 N"):
        mrnea.simulate(robot, q, 0.01, f_ext={"link6": np.array([1e21, 0, 0, 0, 0, 0])})
    assert "runaway_time" in TOP_COLUMNS and QUANTITY["runaway_time"] == "time"


def test_log_units_in_other_spellings(tmp_path: Path) -> None:
    """[rad/sec] and [sec] are mrnea's units; [nm] is not N m (case matters)."""
    from mrnea.errors import LogFileError
    from mrnea.identify.log import read_log

    robot = mrnea.robots.puma560()
    lines = (EXAMPLES_DIR / "puma_identify_log.csv").read_text().splitlines()
    (tmp_path / "a.csv").write_text("\n".join([lines[0].replace("time [s]", "time [sec]"),
                                               *lines[1:]]))
    assert read_log(tmp_path / "a.csv", robot).K == len(lines) - 1
    (tmp_path / "b.csv").write_text("\n".join([lines[0].replace("[N m]", "[nm]"), *lines[1:]]))
    with pytest.raises(LogFileError, match="column 'tau_joint1' is in 'nm'"):
        read_log(tmp_path / "b.csv", robot)


def test_a_value_just_over_its_magnitude_shows_its_digits() -> None:
    """One ulp over 1e7 kg said '1e+07 kg is beyond 1e+07 kg' (three digits)."""
    from mrnea.frozen import check_magnitude

    with pytest.raises(mrnea.MrneaError, match=r"mass 10000000.000000002 kg is beyond 1e\+07 kg"):
        check_magnitude(np.nextafter(1e7, np.inf), "mass", "link 'arm'", "kg")
    with pytest.raises(mrnea.MrneaError, match=r"mass 2e\+07 kg is beyond 1e\+07 kg"):
        check_magnitude(2e7, "mass", "link 'arm'", "kg")
