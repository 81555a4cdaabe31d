"""Program files (mrnea.io.program): a robot, a cycle time, a path (waypoints through a profile,
or a path CSV) and an optional wrench, in TOML; the example programs and the TOML examples of
docs/programs.md.

Expected values are closed forms worked out by hand (the profiles of test_trajectory.py), never
outputs of the code under test.
"""

from __future__ import annotations

import dataclasses
import math
import re
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from test_trajectory import check_limits, quintic_1d, trapezoid_1d

from mrnea.errors import MrneaError, ProgramFileError
from mrnea.io import Program, from_csv, load_program, loads_program
from mrnea.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
DOCS = ROOT / "docs" / "programs.md"


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def test_error_types() -> None:
    assert issubclass(ProgramFileError, MrneaError)
    assert issubclass(ProgramFileError, ValueError)


# --- program files ----------------------------------------------------------------------------


def prog_file(tmp_path: Path, text: str, name: str = "prog.toml") -> Path:
    return write(tmp_path / name, text)


def test_program_trapezoidal_waypoints(tmp_path: Path) -> None:
    p = prog_file(tmp_path, """
[program]
robot = "sdt"
dt = 0.01
mode = "paper"

[path]
profile = "trapezoidal"
waypoints = [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]]
velocity_limit = 1.0
acceleration_limit = [1.0, 1.0, 1.0, 1.0]
""", name="move_it.toml")
    prog = load_program(p)
    assert isinstance(prog, Program)
    assert prog.name == "move_it" and prog.robot == "sdt" and prog.mode == "paper"
    assert prog.dt == 0.01 and prog.K == 201 and prog.n == 4
    assert prog.duration == pytest.approx(2.0)
    np.testing.assert_allclose(prog.t, 0.01 * np.arange(201), atol=1e-12)
    np.testing.assert_allclose(prog.q_cmd[:, 0], trapezoid_1d(prog.t, 1.0, 2.0, 1.0),
                               atol=1e-13)
    assert np.all(prog.q_cmd[:, 1:] == 0.0)
    assert prog.f_ext is None and prog.f_ext_point is None
    assert not prog.q_cmd.flags.writeable
    with pytest.raises(dataclasses.FrozenInstanceError):
        prog.dt = 0.02  # type: ignore[misc]


def test_program_quintic_degrees(tmp_path: Path) -> None:
    p = prog_file(tmp_path, """
[program]
name = "deg"
robot = "sdt"
dt = 0.01

[path]
profile = "quintic"
units = "deg"
waypoints = [[0, 0, 0, 0], [90, -45, 0, 0]]
velocity_limit = 90.0           # deg/s: joint 1 needs 15/8 * 90/90 = 1.875 s
acceleration_limit = 1000.0     # deg/s^2
dwell = [0.0, 0.1]
""")
    prog = load_program(p)
    assert prog.name == "deg" and prog.mode is None
    assert prog.K == 189 + 10
    T = 1.88
    t = prog.t[:189]
    np.testing.assert_allclose(prog.q_cmd[:189, 0], quintic_1d(t, math.pi / 2, T), atol=1e-14)
    np.testing.assert_allclose(prog.q_cmd[:189, 1], quintic_1d(t, -math.pi / 4, T), atol=1e-14)
    np.testing.assert_allclose(prog.q_cmd[-1], [math.pi / 2, -math.pi / 4, 0, 0], atol=1e-15)
    assert prog.q_cmd[94, 0] == pytest.approx(math.pi / 4, abs=1e-14)  # mid-segment: half way


def test_program_csv_and_wrench(tmp_path: Path) -> None:
    sub = tmp_path / "data"
    sub.mkdir()
    write(sub / "path.csv", "t,a,b,c,d\n0,0,0,0,0\n0.4,40,4,0,-4\n")
    p = prog_file(tmp_path, """
[program]
robot = "sdt"
dt = 0.01

[path]
csv = "data/path.csv"
units = "deg"

[wrench]
times = [0.1, 0.3]
values = [[0, 0, -10, 0, 0, 0], [20, 0, 10, 0, 1, 0]]
point = [0.0, 0.0, 0.1]
""")
    prog = load_program(p)
    assert prog.K == 41
    np.testing.assert_allclose(prog.q_cmd[:, 0], np.deg2rad(100 * prog.t), atol=1e-12)
    np.testing.assert_allclose(prog.q_cmd[:, 3], np.deg2rad(-10 * prog.t), atol=1e-12)
    f = prog.f_ext
    assert f.shape == (41, 6)
    np.testing.assert_allclose(f[:11], [[0, 0, -10, 0, 0, 0]] * 11, atol=1e-12)  # held, at 0.1
    np.testing.assert_allclose(f[20], [10, 0, 0, 0, 0.5, 0], atol=1e-12)  # half way
    np.testing.assert_allclose(f[15], [5, 0, -5, 0, 0.25, 0], atol=1e-12)  # a quarter
    np.testing.assert_allclose(f[30:], [[20, 0, 10, 0, 1, 0]] * 11, atol=1e-12)  # at 0.3, held
    np.testing.assert_array_equal(prog.f_ext_point, [0.0, 0.0, 0.1])


def test_program_constant_wrench_and_robot_file(tmp_path: Path) -> None:
    sub = tmp_path / "cell"
    sub.mkdir()
    src = resources.files("mrnea.robots").joinpath("data", "sdt.toml")
    with resources.as_file(src) as f:
        shutil.copy(f, sub / "my_robot.toml")
    p = prog_file(sub, """
[program]
robot = "my_robot.toml"
dt = 0.005

[path]
profile = "trapezoidal"
waypoints = [[0, 0, 0, 0]]
velocity_limit = 1
acceleration_limit = 1
dwell = 0.05

[wrench]
times = [0.0]
values = [[1, 2, 3, 4, 5, 6]]
""")
    prog = load_program(p)
    assert Path(prog.robot) == sub / "my_robot.toml"
    assert prog.K == 11  # the start row + 0.05 s / 5 ms of dwell
    np.testing.assert_array_equal(prog.f_ext, np.tile([1, 2, 3, 4, 5, 6], (11, 1)))
    robot = prog.load_robot()
    assert robot.n == 4


def test_program_joint_count_mismatch(tmp_path: Path) -> None:
    prog = loads_program("""
[program]
robot = "sdt"
dt = 0.01
[path]
profile = "quintic"
waypoints = [[0, 0], [1, 1]]
velocity_limit = 1
acceleration_limit = 1
""", source="two.toml")
    with pytest.raises(ProgramFileError,
                       match=r"^two\.toml: 2 joint values per waypoint, robot sdt has 4$"):
        prog.load_robot()


GOOD = {
    "program": 'robot = "sdt"\ndt = 0.01',
    "path": ('profile = "trapezoidal"\nwaypoints = [[0, 0, 0, 0], [1, 0, 0, 0]]\n'
             "velocity_limit = 1.0\nacceleration_limit = 1.0"),
}


def doc(program: str = GOOD["program"], path: str | None = GOOD["path"],
        extra: str = "") -> str:
    text = f"[program]\n{program}\n"
    if path is not None:
        text += f"\n[path]\n{path}\n"
    return text + extra


@pytest.mark.parametrize(("text", "match"), [
    ("[program]\nrobot = \"sdt\"\ndt = = 0.01\n", r"invalid TOML: .*\(at line 3, column 6\)"),
    ("[program]\nrobot = [\"sdt\"\n", r"invalid TOML: .*line 2, column \d+: end of document"),
    (doc(extra="\n[wrenches]\ntimes = [0]\n"), "unknown key 'wrenches' .*did you mean 'wrench'"),
    (doc(program=GOOD["program"] + "\ndt_s = 1"), r"\[program\]: unknown key 'dt_s'"),
    (doc(path=GOOD["path"].replace("velocity_limit", "velocity_limt")),
     r"\[path\]: unknown key 'velocity_limt' \(did you mean 'velocity_limit'\?\)"),
    (doc(extra="\n[wrench]\ntimes = [0]\nvalues = [[0,0,0,0,0,0]]\npoynt = [0,0,0]\n"),
     r"\[wrench\]: unknown key 'poynt' \(did you mean 'point'\?\)"),
    (doc(path=GOOD["path"].replace("[1, 0, 0, 0]]", "[1, 0, 0, 0], [1, 0, 0]]")),
     r"'waypoints' row 3 has 3 values, expected 4"),
    (doc(path=GOOD["path"].replace("[1, 0, 0, 0]]", "[1, 0, 0, \"x\"]]")),
     r"'waypoints row 2\[3\]' must be a number"),
    (doc(program='robot = "sdt"'), "missing required key 'dt'"),
    (doc(program='robot = ""\ndt = 0.01'), "'robot' must be a non-empty string"),
    (doc(program='robot = "sdt"\ndt = 0.0'), r"'dt' must be a time step > 0 s, got 0.0"),
    (doc(program='robot = "sdt"\ndt = -0.01'), r"'dt' must be a time step > 0 s"),
    (doc(program='robot = "sdt"\ndt = inf'), r"'dt' must be a finite number"),
    (doc(program='robot = "sdt"\ndt = nan'), r"'dt' must be a finite number"),
    (doc(program='robot = "sdt"\ndt = "10 ms"'), r"'dt' must be a number, got string"),
    (doc(program='robot = "sdt"\ndt = 0.01\nmode = "fast"'), r"'mode' must be one of"),
    (doc(program='robot = "nope"\ndt = 0.01'), r"robot 'nope' is neither a built-in robot"),
    (doc(path=None), "missing required key 'path'"),
    ("[path]\ncsv = \"x.csv\"\n", "missing required key 'program'"),
    (doc(path=GOOD["path"].replace("trapezoidal", "trapezoid")),
     r"unknown profile 'trapezoid' \(did you mean 'trapezoidal'\?\)"),
    (doc(path=GOOD["path"] + '\nunits = "grad"'), r"'units' must be one of"),
    (doc(path=GOOD["path"] + '\ncsv = "x.csv"'), r"key 'profile' cannot be used with 'csv'"),
    (doc(path='units = "deg"'), r"give either 'csv'"),
    (doc(path=GOOD["path"].replace("velocity_limit = 1.0", "velocity_limit = 0.0")),
     r"'velocity_limit' must be > 0"),
    (doc(path=GOOD["path"].replace("velocity_limit = 1.0", "velocity_limit = [1, 1]")),
     r"'velocity_limit' must be an array of 4 numbers, got 2"),
    (doc(path=GOOD["path"].replace("acceleration_limit = 1.0", "")),
     "missing required key 'acceleration_limit'"),
    (doc(path=GOOD["path"] + "\ndwell = -1"), r"'dwell' must be >= 0"),
    (doc(path=GOOD["path"].replace("[1, 0, 0, 0]]", "[0, 0, 0, 0]]")), "single cycle"),
    (doc(extra="\n[wrench]\ntimes = [0, 0]\nvalues = [[0,0,0,0,0,0],[0,0,0,0,0,0]]\n"),
     r"'times' must be strictly increasing"),
    (doc(extra="\n[wrench]\ntimes = [0, 1]\nvalues = [[0,0,0,0,0,0]]\n"),
     r"'values' has 1 rows, expected 2"),
    (doc(extra="\n[wrench]\ntimes = [0]\nvalues = [[0,0,0]]\n"),
     r"'values' row 1 has 3 values, expected 6"),
    (doc(extra="\n[wrench]\ntimes = [0]\nvalues = [[0,0,0,0,0,0]]\npoint = [0, 0]\n"),
     r"'point' must be an array of 3 numbers"),
    (doc(extra="\n[wrench]\nvalues = [[0,0,0,0,0,0]]\n"), "missing required key 'times'"),
    ("wrench = 3\n" + doc(), r"top level: 'wrench' must be a table"),
])
def test_program_errors(tmp_path: Path, text: str, match: str) -> None:
    p = prog_file(tmp_path, text, name="broken.toml")
    with pytest.raises(ProgramFileError, match=match) as info:
        load_program(p)
    assert str(info.value).startswith(str(p))


def test_program_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ProgramFileError, match=r"nothing\.toml: program file not found"):
        load_program(tmp_path / "nothing.toml")
    # an error in the CSV it names is reported with the CSV's file, line and column
    write(tmp_path / "p.csv", "t,a,b,c,d\n0,0,0,0,0\n0.1,0,x,0,0\n")
    p = prog_file(tmp_path, doc(path='csv = "p.csv"'))
    with pytest.raises(ProgramFileError, match=r"p.csv: line 3 .*column 3 \('b'\)"):
        load_program(p)
    with pytest.raises(ProgramFileError, match=r"missing\.csv: path CSV file not found"):
        load_program(prog_file(tmp_path, doc(path='csv = "missing.csv"')))


# --- examples and documentation ---------------------------------------------------------------


def test_example_files_small() -> None:
    for name in ("puma_pick.toml", "sdt_csv.toml", "sdt_profile.csv"):
        assert (EXAMPLES / name).stat().st_size < 50_000


def test_example_puma_pick() -> None:
    prog = load_program(EXAMPLES / "puma_pick.toml")
    assert prog.robot == "puma560" and prog.n == 6 and prog.dt == 0.005
    home = np.deg2rad([0.0, 45.0, -135.0, 0.0, -45.0, 0.0])
    np.testing.assert_allclose(prog.q_cmd[0], home, atol=1e-15)
    np.testing.assert_allclose(prog.q_cmd[-1], home, atol=1e-15)
    vmax = np.deg2rad([90, 90, 90, 180, 180, 180])
    amax = np.deg2rad([180, 180, 180, 360, 360, 360])
    check_limits(prog.q_cmd, prog.dt, vmax, amax)
    # the press: -20 N along z between 1.5 and 1.95 s, nothing before 1.45 or after 2.0 s
    fz = prog.f_ext[:, 2]
    assert np.all(fz[prog.t <= 1.45 + 1e-9] == 0.0) and np.all(fz[prog.t >= 2.0 - 1e-9] == 0.0)
    inside = (prog.t >= 1.5 - 1e-9) & (prog.t <= 1.95 + 1e-9)
    np.testing.assert_allclose(fz[inside], -20.0, atol=1e-9)
    # the robot is at rest on the part while pressing
    on_part = np.deg2rad([30.0, 70.0, -118.0, 0.0, -72.0, 30.0])
    np.testing.assert_allclose(prog.q_cmd[inside], np.tile(on_part, (inside.sum(), 1)),
                               atol=1e-15)


def test_example_sdt_csv() -> None:
    prog = load_program(EXAMPLES / "sdt_csv.toml")
    assert prog.robot == "sdt" and prog.n == 4 and prog.mode == "paper"
    t, q = from_csv(EXAMPLES / "sdt_profile.csv", prog.dt, n=4)
    np.testing.assert_array_equal(q, prog.q_cmd)
    assert t[-1] == pytest.approx(6.0)


@pytest.mark.parametrize("name", ["puma_pick.toml", "sdt_csv.toml"])
def test_examples_simulate_achievable(name: str) -> None:
    prog = load_program(EXAMPLES / name)
    mode = {} if prog.mode is None else {"mode": prog.mode}
    res = simulate(prog.load_robot(), prog.q_cmd, prog.dt, f_ext=prog.f_ext,
                   f_ext_point=prog.f_ext_point, **mode)
    assert res.achievable, res.verdict()
    assert res.mode == (prog.mode or "hybrid")


def test_docs_toml_examples_parse(tmp_path: Path) -> None:
    blocks = re.findall(r"```toml\n(.*?)```", DOCS.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 3
    write(tmp_path / "two_link.toml", "")  # robot files are only checked to exist
    shutil.copy(EXAMPLES / "sdt_profile.csv", tmp_path / "sdt_profile.csv")
    for k, block in enumerate(blocks):
        prog = load_program(prog_file(tmp_path, block, name=f"block{k}.toml"))
        if prog.moves is not None:  # Cartesian moves: solved on a robot (tests/test_cartesian.py)
            assert len(prog.moves.moves) >= 1 and prog.q_cmd is None
            continue
        if prog.named is not None:  # joints by name: on a robot (tests/test_program_names.py)
            assert prog.q_cmd is None and prog.n >= 1
            continue
        assert prog.K >= 2
