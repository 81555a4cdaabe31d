"""Every public function refuses an argument of the wrong type with a MrneaError naming it.

Each public function (the top-level exports, ``mrnea.io``, ``mrnea.trajectory``,
``mrnea.simulate``, ``mrnea.report``, ``mrnea.robots``, ``mrnea.retime``, ``mrnea.sweep``'s
helpers (the sweep itself: tests/test_sweep.py), the methods of ``Robot``, ``SimulationResult``
and ``RetimeResult``) is called with valid arguments, then with each argument replaced in turn by
None, an int, a str, a dict, a complex number, bytes and the path of a directory. Where a value
is of an accepted type for that argument (an int for a time step, a str for a path, None for an
optional argument, a folder for a base folder) it is skipped. Everything else must raise a
:class:`mrnea.errors.MrneaError` (never a TypeError, AttributeError or IndexError) whose message
names the argument (or, for a path that is a directory, says so).
"""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import mrnea
import mrnea.io
import mrnea.report
import mrnea.trajectory
from mrnea.errors import MrneaError
from mrnea.report.retime import write_retime_report
from mrnea.report.sweep import write_sweep_html
from mrnea.retime import scale_estimate
from mrnea.robots.sdt_profile import training_program
from mrnea.simulate import simulate
from mrnea.sweep import check_grid, time_scaled, variant
from mrnea.sweep.engine import _frame
from mrnea.sweep.rows import run_case

MALFORMED = Path(__file__).resolve().parent / "malformed"
BAD = ("None", "int", "str", "dict", "complex", "bytes", "dir")

# kinds of argument, and the bad values that are of an accepted type for each ("?": None too)
PATH, OUT, FOLDER, NAME, NUMBER, ARRAY, FLAG, MAPPING, OPTIONAL = (
    "path", "out", "folder", "name", "number", "array", "flag", "mapping", "?")
ACCEPTED = {
    PATH: {"str"},  # "abc" is a (missing) file: a ProgramFileError, not about the type
    OUT: {"str"},  # a file to write: "abc" is fine
    FOLDER: {"str", "dir"},  # a folder: "abc" and a directory are fine
    NAME: {"str"},  # "abc" is an unknown name: an error, but of value
    NUMBER: {"int"},
    ARRAY: {"int"},  # a scalar where a scalar or an array is allowed
    FLAG: set(),
    MAPPING: {"dict"},
}


@pytest.fixture(scope="module")
def env(tmp_path_factory) -> dict:
    d = tmp_path_factory.mktemp("api")
    (d / "a_folder").mkdir()
    shutil.copy(MALFORMED / "reference_arm.toml", d / "r.toml")
    shutil.copy(MALFORMED / "reference_arm.urdf", d / "r.urdf")
    (d / "act.toml").write_text("[planetary]\ngear_ratio = 2.0\n")
    (d / "p.csv").write_text("t,a,b,c,d\n0,0,0,0,0\n1,0.1,0,0,0\n")
    (d / "prog.toml").write_text('[program]\nrobot = "sdt"\ndt = 0.1\n[path]\n'
                                 'profile = "quintic"\nwaypoints = [[0, 0, 0, 0], [0.1, 0, 0, 0]]\n'
                                 "velocity_limit = 1\nacceleration_limit = 1\n")
    robot = mrnea.robots.sdt()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = simulate(robot, np.zeros((3, 4)), 0.01)
        retimed = mrnea.retime(robot, mrnea.load_program(d / "prog.toml"))
    (d / "g.toml").write_text("[grid]\npayload = [0.0]\n")
    program = training_program(0.5)
    rows = {0: run_case(robot, program, {"payload": 0.0})}
    sweep_rows = _frame(("payload",), [program.name], [(0, (0, 1.0), {"payload": 0.0})], rows,
                        False)
    return {"dir": d, "robot": robot, "result": result, "retimed": retimed, "program": program,
            "rows": sweep_rows,
            "bad": {"None": None, "int": 123, "str": "abc", "dict": {"a": 1}, "complex": 1 + 2j,
                    "bytes": b"x", "dir": d / "a_folder"}}


def _cases(e: dict) -> list[tuple[str, object, dict, dict]]:
    """(name, function, valid keyword arguments, kind of each argument)."""
    d, robot, res = e["dir"], e["robot"], e["result"]
    q = np.zeros(4)
    K = np.zeros((3, 4))
    tr, io, rp = mrnea.trajectory, mrnea.io, mrnea.report
    way = {"waypoints": [[0.0], [1.0]], "dt": 0.1, "velocity_limit": 1.0,
           "acceleration_limit": 1.0, "t0": 0.0, "dwell": 0.0}
    way_kinds = {"waypoints": ARRAY, "dt": NUMBER, "velocity_limit": ARRAY,
                 "acceleration_limit": ARRAY, "t0": NUMBER, "dwell": ARRAY}
    return [
        ("forward_dynamics", mrnea.forward_dynamics,
         {"robot": robot, "q": q, "qd": q, "tau": q, "method": "mrnea"},
         {"robot": "", "q": "", "qd": "", "tau": "", "method": NAME}),
        ("inverse_dynamics", mrnea.inverse_dynamics, {"robot": robot, "q": q, "qd": q, "qdd": q},
         {"robot": "", "q": "", "qd": "", "qdd": ""}),
        ("mass_matrix_and_bias", mrnea.mass_matrix_and_bias, {"robot": robot, "q": q, "qd": q},
         {"robot": "", "q": "", "qd": ""}),
        ("joint_reactions", mrnea.joint_reactions, {"robot": robot, "q": q, "qd": q, "qdd": q},
         {"robot": "", "q": "", "qd": "", "qdd": ""}),
        ("transform", mrnea.transform, {"xyz": (0.0, 0.0, 0.0), "rpy": (0.0, 0.0, 0.0)},
         {"xyz": "", "rpy": ""}),
        ("load_program", mrnea.load_program, {"path": d / "prog.toml"}, {"path": PATH}),
        ("load_robot", mrnea.load_robot, {"path": d / "r.toml"}, {"path": PATH}),
        ("load_urdf", mrnea.load_urdf, {"path": d / "r.urdf", "tip": None, "actuators": None},
         {"path": PATH, "tip": NAME + "?", "actuators": PATH + "?"}),
        ("apply_actuator_file", io.apply_actuator_file, {"robot": robot, "path": d / "act.toml"},
         {"robot": "", "path": PATH}),
        ("from_csv", io.from_csv, {"path": d / "p.csv", "dt": 0.1, "n": 4},
         {"path": PATH, "dt": NUMBER, "n": OPTIONAL}),
        ("load_builtin", io.load_builtin, {"name": "sdt"}, {"name": NAME}),
        ("load_native", io.load_native, {"path": d / "r.toml", "actuators": None},
         {"path": PATH, "actuators": PATH + "?"}),
        ("load_robot_spec", io.load_robot_spec, {"spec": "sdt", "base_dir": None},
         {"spec": NAME, "base_dir": FOLDER + "?"}),
        ("loads_native", io.loads_native, {"text": "", "source": "x"},
         {"text": NAME, "source": NAME}),
        ("loads_program", io.loads_program, {"text": "", "source": "x", "base_dir": None},
         {"text": NAME, "source": NAME, "base_dir": FOLDER + "?"}),
        ("resolve_robot", io.resolve_robot, {"spec": "sdt", "base_dir": None},
         {"spec": NAME, "base_dir": FOLDER + "?"}),
        ("cycles", tr.cycles, {"duration": 1.0, "dt": 0.1}, {"duration": ARRAY, "dt": NUMBER}),
        ("trapezoidal", tr.trapezoidal, way, way_kinds),
        ("quintic", tr.quintic, way, way_kinds),
        ("simulate", simulate,
         {"robot": robot, "q_cmd": K, "dt": 0.01, "mode": "hybrid", "fd": "mrnea",
          "catch_up": 0.0, "progress": None, "stream": d / "stream.csv", "overwrite": True},
         {"robot": "", "q_cmd": "", "dt": NUMBER, "mode": NAME, "fd": NAME, "catch_up": NUMBER,
          "progress": OPTIONAL, "stream": OUT + "?", "overwrite": FLAG}),
        ("SimulationResult.to_csv", res.to_csv, {"path": d / "o.csv", "overwrite": True},
         {"path": OUT, "overwrite": FLAG}),
        ("SimulationResult.save_summary", res.save_summary,
         {"path": d / "o.json", "overwrite": True}, {"path": OUT, "overwrite": FLAG}),
        ("plot_result", rp.plot_result, {"result": res, "path": d / "figs", "overwrite": True},
         {"result": "", "path": FOLDER + "?", "overwrite": FLAG}),
        ("write_report", rp.write_report,
         {"result": res, "path": d / "r.html", "overwrite": True, "extra_figures": None},
         {"result": "", "path": OUT, "overwrite": FLAG, "extra_figures": OPTIONAL}),
        ("fig3", rp.fig3, {"robot": robot, "t": np.arange(3.0), "q": K, "qd": K, "qdd": K},
         {"robot": "", "t": "", "q": "", "qd": "", "qdd": ""}),
        ("Robot.with_actuators(gear_ratio)", robot.with_actuators, {"gear_ratio": 2.0},
         {"gear_ratio": ARRAY}),
        ("Robot.with_actuators(rotor_inertia)", robot.with_actuators, {"rotor_inertia": 1e-4},
         {"rotor_inertia": ARRAY}),
        ("Robot.with_actuators(effort_limit)", robot.with_actuators, {"effort_limit": 100.0},
         {"effort_limit": ARRAY}),
        ("Robot.with_actuators(torque_speed)", robot.with_actuators,
         {"torque_speed": (100.0, 1.0, 2.0)}, {"torque_speed": OPTIONAL}),
        ("Robot.with_gravity", robot.with_gravity, {"gravity": (0.0, 0.0, -9.81)},
         {"gravity": ""}),
        ("Robot.to_urdf", robot.to_urdf, {"path": d / "w.urdf"}, {"path": OUT}),
        ("retime", mrnea.retime,
         {"robot": robot, "program": np.linspace(np.zeros(4), np.full(4, 0.1), 20), "dt": 0.1,
          "method": "scale", "margin": 0.9, "f_ext": None, "f_ext_point": None},
         {"robot": "", "program": "", "dt": NUMBER + "?", "method": NAME, "margin": NUMBER,
          "f_ext": OPTIONAL, "f_ext_point": OPTIONAL}),
        ("scale_estimate", scale_estimate,
         {"robot": robot, "q": np.linspace(np.zeros(4), np.full(4, 0.1), 20), "dt": 0.1,
          "f_ext": None, "f_ext_point": None},
         {"robot": "", "q": "", "dt": NUMBER, "f_ext": OPTIONAL, "f_ext_point": OPTIONAL}),
        ("RetimeResult.save_csv", e["retimed"].save_csv, {"path": d / "r.csv", "overwrite": True},
         {"path": OUT, "overwrite": FLAG}),
        ("RetimeResult.save_program", e["retimed"].save_program,
         {"path": d / "rp.toml", "robot": "sdt", "csv": "r.csv", "name": "x",
          "program_keys": None, "overwrite": True},
         {"path": OUT, "robot": NAME, "csv": NAME, "name": NAME, "program_keys": MAPPING + "?",
          "overwrite": FLAG}),
        ("RetimeResult.save_summary", e["retimed"].save_summary,
         {"path": d / "rs.json", "overwrite": True}, {"path": OUT, "overwrite": FLAG}),
        ("write_retime_report", write_retime_report,
         {"result": e["retimed"], "path": d / "rr.html", "overwrite": True, "files": None,
          "view3d": False},
         {"result": "", "path": OUT, "overwrite": FLAG, "files": MAPPING + "?", "view3d": FLAG}),
        ("variant", variant, {"robot": robot, "payload": 1.0}, {"robot": "", "payload": NUMBER}),
        ("time_scaled", time_scaled, {"program": e["program"], "factor": 2.0},
         {"program": "", "factor": NUMBER}),
        ("check_grid", check_grid, {"robot": robot, "grid": {"payload": [1.0]}, "zip": False},
         {"robot": "", "grid": "", "zip": FLAG}),
        ("load_grid_file", io.load_grid_file, {"path": d / "g.toml"}, {"path": PATH}),
        ("write_sweep_html", write_sweep_html,
         {"df": e["rows"], "path": d / "s.html", "robot": "sdt", "keys": None,
          "map_axes": None, "curves": None, "overwrite": True},
         {"df": "", "path": OUT, "robot": NAME, "keys": OPTIONAL, "map_axes": OPTIONAL,
          "curves": NAME + "?", "overwrite": FLAG}),
    ]


def _calls(e: dict):
    for name, fn, kw, kinds in _cases(e):
        for arg in kw:
            for bad in BAD:
                kind = kinds[arg]
                accepted = ACCEPTED.get(kind.rstrip("?"), set()) | (
                    {"None"} if kind.endswith("?") else set())
                if bad not in accepted:
                    yield name, fn, kw, arg, bad


def test_the_valid_calls_succeed(env) -> None:
    """The baseline: each function accepts the valid arguments the matrix starts from (so the
    errors below are caused by the replaced argument)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, fn, kw, _ in _cases(env):
            if name in ("loads_native", "loads_program"):
                continue  # an empty document is not a robot or a program
            fn(**kw)


# messages that name the argument otherwise: transform's xyz and rpy make an "origin"
ALIAS = {("transform", "xyz"): "origin", ("transform", "rpy"): "origin"}

NAMES = ("forward_dynamics", "inverse_dynamics", "mass_matrix_and_bias", "joint_reactions",
         "transform", "load_program", "load_robot", "load_urdf", "apply_actuator_file",
         "from_csv", "load_builtin", "load_native", "load_robot_spec", "loads_native",
         "loads_program", "resolve_robot", "cycles", "trapezoidal", "quintic", "simulate",
         "SimulationResult.to_csv", "SimulationResult.save_summary", "plot_result",
         "write_report", "fig3", "Robot.with_actuators(gear_ratio)",
         "Robot.with_actuators(rotor_inertia)", "Robot.with_actuators(effort_limit)",
         "Robot.with_actuators(torque_speed)", "Robot.with_gravity", "Robot.to_urdf", "retime",
         "scale_estimate", "RetimeResult.save_csv", "RetimeResult.save_program",
         "RetimeResult.save_summary", "write_retime_report", "variant", "time_scaled",
         "check_grid", "load_grid_file", "write_sweep_html")


def test_every_case_is_named(env) -> None:
    assert [name for name, *_ in _cases(env)] == list(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_a_wrong_type_is_a_named_error(env, name: str) -> None:
    """Each argument of ``name`` in turn, with each bad value of a wrong type."""
    failures = []
    for fname, fn, kw, a, bad in _calls(env):
        if fname != name:
            continue
        args = dict(kw)
        args[a] = env["bad"][bad]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fn(**args)
        except MrneaError as exc:
            message = str(exc)
            named = (ALIAS.get((name, a), a) in message
                     or (bad == "dir" and "directory" in message))
            if not named:
                failures.append(f"{a}={bad}: message does not name it: {message}")
            elif len(message) > 500:
                failures.append(f"{a}={bad}: message of {len(message)} characters")
        except Exception as exc:  # the point: nothing but a MrneaError escapes
            failures.append(f"{a}={bad}: {type(exc).__name__}: {exc}")
        else:
            failures.append(f"{a}={bad}: accepted")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("arg", ["dt", "catch_up"])
def test_simulate_refuses_numbers_given_as_text(env, arg: str) -> None:
    """``"0.001"`` is text, not a time step or a gain (Python's float() would take it)."""
    kw = {"dt": 0.01, "catch_up": 0.0, arg: "0.001"}
    with pytest.raises(MrneaError, match=arg):
        simulate(env["robot"], np.zeros((3, 4)), **kw)


# --- model fields and result tables ---------------------------------------------------------------
@pytest.mark.parametrize("value", ["1_0", b"1", "1.0"])
def test_model_fields_refuse_text(value: object) -> None:
    with pytest.raises(MrneaError, match="mass"):
        mrnea.Link("l", mass=value)


@pytest.mark.parametrize("bad", ["None", "str", "dict"])
def test_columns_refuses_rows_that_are_not_a_slice(env, bad: str) -> None:
    with pytest.raises(MrneaError, match="rows"):
        env["result"].columns(env["bad"][bad])
