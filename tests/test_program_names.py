"""Programs that name their joints (issue 25): waypoint tables by joint name and path CSV headers
matched by name in any column order, on the torso-with-two-arms example (a tree).

The oracle of each path is the same path written out by hand in the robot's joint order (the
profile functions of mrnea.trajectory, or the CSV with its columns in that order, read by
position): what names stand for, spelled out.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import ProgramFileError
from mrnea.io import from_csv
from mrnea.trajectory import trapezoidal

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
URDF = EXAMPLES / "waist_two_arms.urdf"
JOINTS = ("waist", "shoulder_pitch_l", "shoulder_roll_l", "elbow_l", "wrist_l",
          "shoulder_pitch_r", "shoulder_roll_r", "elbow_r", "wrist_r")


@pytest.fixture(scope="module")
def robot():
    return mrnea.load_urdf(URDF)


def _program(tmp_path: Path, path_table: str, name: str = "p.toml") -> Path:
    shutil.copy(URDF, tmp_path / URDF.name)
    p = tmp_path / name
    p.write_text(f'[program]\nrobot = "{URDF.name}"\ndt = 0.01\n\n[path]\n{path_table}\n')
    return p


def test_the_tree_loads_in_its_documented_order(robot) -> None:
    assert robot.joint_names == JOINTS
    assert robot.parents == (-1, 0, 1, 2, 3, 0, 5, 6, 7)


def test_waypoint_tables_are_the_arrays_they_stand_for(tmp_path, robot) -> None:
    p = _program(tmp_path, """profile = "trapezoidal"
waypoints = [{elbow_r = 0.5, shoulder_roll_l = 1.2}, {elbow_l = 1.0, waist = 0.3},
             {shoulder_roll_l = 0.0}]
velocity_limit = 2.0
acceleration_limit = {waist = 1.0, elbow_l = 4.0, shoulder_roll_l = 3.0, elbow_r = 5.0}
dwell = 0.1""")
    prog = mrnea.load_program(p)
    # by hand, in the robot's order: unnamed joints at 0 first, then each holds its value
    w = np.zeros((3, 9))
    w[0, 7], w[0, 2] = 0.5, 1.2
    w[1] = w[0]
    w[1, 3], w[1, 0] = 1.0, 0.3
    w[2] = w[1]
    w[2, 2] = 0.0
    amax = np.full(9, np.inf)
    amax[[0, 3, 2, 7]] = [1.0, 4.0, 3.0, 5.0]
    t, q = trapezoidal(w, 0.01, np.full(9, 2.0), amax, dwell=0.1)
    assert np.array_equal(prog.q_cmd, q) and np.array_equal(prog.t, t)
    assert prog.q_cmd.shape[1] == robot.n and prog.named is None
    # unbound (io.load_program) it has no rows yet, and says how to get them
    raw = mrnea.io.load_program(p)
    assert raw.q_cmd is None and raw.n == 4
    with pytest.raises(mrnea.errors.StateError, match=r"program\.on\(robot\)"):
        _ = raw.K
    assert np.array_equal(raw.on(robot).q_cmd, q)


def test_a_named_program_with_a_wrench_interpolates_it_on_its_cycles(tmp_path) -> None:
    p = _program(tmp_path, """profile = "quintic"
waypoints = [{waist = 0.0}, {waist = 0.5}]
velocity_limit = 1.0
acceleration_limit = 2.0

[wrench]
times = [0.0, 10.0]
values = [[0, 0, 0, 0, 0, 0], [10, 0, 0, 0, 0, 1]]""")
    prog = mrnea.load_program(p)
    assert prog.f_ext.shape == (prog.K, 6)
    assert np.allclose(prog.f_ext[:, 0], prog.t, rtol=0, atol=1e-12)  # 10 N over 10 s
    assert np.allclose(prog.f_ext[:, 5], prog.t / 10.0, rtol=0, atol=1e-12)


@pytest.mark.parametrize(("table", "words"), [
    ('waypoints = [{waist = 0.1}, {elbw_l = 1.0}]\nvelocity_limit = 1.0\n'
     'acceleration_limit = 1.0', ["waypoints[1]", "'elbw_l' is not a joint", "'elbow_l'"]),
    ('waypoints = [{waist = 0.1}, {elbow_l = 1.0}]\nvelocity_limit = {waist = 1.0}\n'
     'acceleration_limit = 1.0', ["velocity_limit does not name joint 'elbow_l'"]),
    ('waypoints = [{waist = 0.1}, {elbow_l = 1.0}]\nvelocity_limit = [1.0, 2.0]\n'
     'acceleration_limit = 1.0', ["'velocity_limit' with waypoint tables"]),
    ('waypoints = [{waist = 0.1}, [0, 0, 0, 0, 0, 0, 0, 0, 0]]\nvelocity_limit = 1.0\n'
     'acceleration_limit = 1.0', ["mixes tables and arrays"]),
])
def test_a_bad_name_is_one_error_naming_file_waypoint_and_joint(tmp_path, table, words) -> None:
    p = _program(tmp_path, f'profile = "trapezoidal"\n{table}')
    with pytest.raises(ProgramFileError) as exc:
        mrnea.load_program(p)
    for w in [str(p), *words]:
        assert w in str(exc.value), (w, str(exc.value))
    res = mrnea_cli("check", p)
    one_error_line(res, str(p.name), *words)


def _csv(path: Path, names: list[str], rows: np.ndarray) -> Path:
    path.write_text("t," + ",".join(names) + "\n"
                    + "".join(",".join(repr(float(x)) for x in r) + "\n" for r in rows))
    return path


@pytest.fixture()
def rows() -> np.ndarray:
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 1.0, 11)
    return np.column_stack([t, 0.2 * np.sin(np.outer(t, rng.uniform(1, 3, 9)))])


def test_a_csv_header_by_name_is_read_in_any_column_order(tmp_path, robot, rows) -> None:
    by_position = _csv(tmp_path / "pos.csv", [f"c{i}" for i in range(9)], rows)
    perm = np.random.default_rng(1).permutation(9)
    shuffled = _csv(tmp_path / "named.csv", [JOINTS[i] for i in perm], rows[:, np.r_[0, perm + 1]])
    _, q_ref = from_csv(by_position, 0.01, robot=robot)
    _, q = from_csv(shuffled, 0.01, robot=robot)
    assert np.array_equal(q, q_ref)
    # the same through a program file, its robot named, and as the command line reads it
    prog_file = _program(tmp_path, 'csv = "named.csv"')
    prog = mrnea.load_program(prog_file)
    assert np.array_equal(prog.q_cmd, q_ref)
    assert np.array_equal(prog.csv_rows, rows)
    ref_file = _program(tmp_path, 'csv = "pos.csv"', "ref.toml")
    a = mrnea_cli("check", prog_file, "--json")
    b = mrnea_cli("check", ref_file, "--json")
    assert a.returncode == b.returncode and a.returncode in (0, 1), a.stderr
    import json
    ja, jb = json.loads(a.stdout), json.loads(b.stdout)
    for key in ("achievable", "worst_joint", "worst_ratio", "program_peak_ratio"):
        if key in jb:
            assert ja[key] == jb[key], key


@pytest.mark.parametrize(("names", "words"), [
    ([*JOINTS[:8], "wrist"],
     ["line 1", "column 10", "'wrist' is not a joint", "did you mean 'wrist_r'"]),
    ([*JOINTS[:8], "waist"], ["line 1", "joint 'waist' has two columns"]),
    (list(JOINTS[:8]), ["line 1", "no column for joint 'wrist_r'"]),
])
def test_a_csv_naming_a_wrong_or_missing_joint_is_one_error(tmp_path, robot, rows, names,
                                                            words) -> None:
    f = _csv(tmp_path / "bad.csv", names, rows[:, : len(names) + 1])
    with pytest.raises(ProgramFileError) as exc:
        from_csv(f, 0.01, robot=robot)
    for w in [str(f), *words]:
        assert w in str(exc.value), (w, str(exc.value))
    res = mrnea_cli("check", URDF, f, "--dt", "0.01")
    one_error_line(res, "bad.csv", *words)
    res = mrnea_cli("simulate", _program(tmp_path, 'csv = "bad.csv"'), "--out", tmp_path / "o")
    one_error_line(res, "bad.csv", *words)
