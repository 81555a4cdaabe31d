"""Malformed input, end to end: the corpus in tests/malformed/, the public API, the CLI.

* **Robot files.** ``tests/malformed/cases.toml`` lists every file of the corpus with the
  exception class it must raise and a regular expression its message must match (the element at
  fault and what is wrong), or, for awkward but valid files, that it must load. Each case is
  loaded with :func:`mrnea.load_robot` and run through ``mrnea info FILE`` (exit code 2, one
  ``mrnea: error:`` line, no traceback; with ``--debug`` the exception propagates).
* **Awkward but valid models** (an inertia that breaks the triangle inequality by rounding, a
  massless link that keeps H positive definite) load, and give a ModelWarning.
* **The public API** beyond tests/test_api_errors.py (which covers mrnea.dynamics):
  achievable_accelerations, achievable_step, simulate and the trajectory functions.
* **Known bugs** are ``xfail(strict=True)`` tests: they fail once the bug is fixed (then drop
  the mark, or the ``xfail`` key of the corpus entry).
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
import tomllib
import traceback
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mrnea
import mrnea.errors
from mrnea.achievable import achievable_accelerations, achievable_step
from mrnea.cli import main
from mrnea.errors import ModelError, MrneaError, ProgramFileError, RobotFileError, StateError
from mrnea.io import from_csv, load_robot
from mrnea.io.native import loads_native
from mrnea.model import Joint, Link, Robot
from mrnea.rigid import transform
from mrnea.simulate import simulate
from mrnea.trajectory import quintic, trapezoidal

CORPUS = Path(__file__).resolve().parent / "malformed"
CASES = tomllib.loads((CORPUS / "cases.toml").read_text(encoding="utf-8"))
ERRORS: list[dict] = CASES["error"]
ACCEPTED: list[dict] = CASES["accepted"]
NOT_CASES = {"cases.toml", ".gitattributes"}  # corpus files that are not inputs
FD_METHODS = ("mrnea", "walker_orin", "crba", "aba")


def _case_id(case: dict) -> str:
    kw = case.get("kwargs", {})
    return case["file"] + "".join(f"[{k}={v}]" for k, v in kw.items())


def _params(cases: list[dict]) -> list:
    return [pytest.param(c, id=_case_id(c),
                         marks=[pytest.mark.xfail(strict=True, reason=c["xfail"])]
                         if "xfail" in c else [])
            for c in cases]


def _error_class(case: dict) -> type[MrneaError]:
    return getattr(mrnea.errors, case["error"])


# --- the corpus itself ----------------------------------------------------------------------------
def _inputs_on_disk() -> set[str]:
    """Every input in the corpus folder: its files, and the directories that are cases
    themselves (named like a robot file; what they contain is not an input)."""
    case_dirs = [p for p in CORPUS.rglob("*") if p.is_dir() and p.suffix in (".urdf", ".toml")]
    out = {p.relative_to(CORPUS).as_posix() for p in case_dirs}
    for p in CORPUS.rglob("*"):
        if p.is_file() and p.name not in NOT_CASES and not any(d in p.parents for d in case_dirs):
            out.add(p.relative_to(CORPUS).as_posix())
    return out


def test_corpus_is_complete_and_consistent() -> None:
    """Every input has an entry, every entry an input (or is deliberately absent); class names
    are mrnea errors; regexes compile; each entry says why."""
    listed = {c["file"] for c in ERRORS + ACCEPTED}
    on_disk = _inputs_on_disk()
    assert sorted(on_disk - listed) == [], "corpus files without an entry in cases.toml"
    absent = {c["file"] for c in ERRORS if c.get("absent")}
    assert sorted(listed - on_disk - absent) == [], "entries in cases.toml without a file"
    for c in ERRORS:
        if c.get("absent"):
            assert not (CORPUS / c["file"]).exists(), c["file"]
        cls = _error_class(c)
        assert issubclass(cls, MrneaError) and issubclass(cls, ValueError), c["error"]
        re.compile(c["match"])
        assert c["why"].strip(), c["file"]
    for c in ACCEPTED:
        assert c["why"].strip() and c["n"] >= 1, c["file"]
    # the cases cover both formats and the things the issue lists
    text = " ".join(c["file"] for c in ERRORS)
    for needle in ("empty.urdf", "empty.toml", "truncated", "negative_mass", "nan_mass",
                   "inertia_not_psd", "axis_zero", "origin_nan", "floating", "planar",
                   "unknown_joint_type", "child_link_missing", "cycle", "two_parents",
                   "two_roots", "duplicate_link", "duplicate_joint", "lower_above_upper",
                   "negative_velocity", "negative_effort", "mimic_on_chain",
                   "invalid_utf8", "a_directory", "does_not_exist"):
        assert needle in text, needle


# Whole-file cases whose content is the defect (or that no comment fits): no header comment.
NO_HEADER = {"urdf/empty.urdf", "urdf/whitespace_only.urdf", "urdf/plain_text.urdf",
             "urdf/html_error_page.urdf", "urdf/accepted_utf16.urdf", "urdf/accepted_utf8_bom.urdf",
             "urdf/accepted_latin1.urdf", "urdf/robot.sdf", "toml/empty.toml",
             "toml/urdf_content.toml", "toml/utf16.toml", "toml/accepted_utf8_bom.toml",
             "toml/robot.yaml"}


def test_every_case_file_says_what_is_wrong() -> None:
    """Readable corpus: a case file opens with a comment naming its defect (URDF: right after
    the XML declaration; TOML: the first line), except the whole-file cases in NO_HEADER."""
    for c in ERRORS + ACCEPTED:
        p = CORPUS / c["file"]
        if not p.is_file() or c["file"].startswith("reference_") or c["file"] in NO_HEADER:
            continue
        lines = p.read_bytes().split(b"\n")
        header = lines[1] if p.suffix == ".urdf" else lines[0]
        prefix, end = (b"<!-- ", b" -->") if p.suffix == ".urdf" else (b"# ", b"")
        assert header.startswith(prefix) and header.endswith(end), c["file"]
        assert len(header) > len(prefix) + len(end) + 8, c["file"]


# --- robot files: rejected with the right error -------------------------------------------------
@pytest.mark.parametrize("case", _params(ERRORS))
def test_malformed_file_is_rejected(case: dict) -> None:
    """load_robot raises exactly the listed mrnea error; its message starts with the file and
    names the element and what is wrong, on one line."""
    path = CORPUS / case["file"]
    cls = _error_class(case)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrnea.errors.ModelWarning)  # not what is tested here
        with pytest.raises(MrneaError) as info:
            load_robot(path, **case.get("kwargs", {}))
    exc = info.value
    msg = str(exc)
    assert type(exc) is cls, f"{type(exc).__name__}: {msg}"
    assert msg.startswith(f"{path}: "), msg
    assert re.search(case["match"], msg[len(f"{path}: "):]), msg
    assert "\n" not in msg, msg


@pytest.mark.parametrize("case", _params(ACCEPTED))
def test_awkward_file_loads(case: dict) -> None:
    """Valid but awkward files load, and their dynamics is finite and consistent."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrnea.errors.ModelWarning)
        robot = load_robot(CORPUS / case["file"])
    assert robot.n == case["n"]
    rng = np.random.default_rng(0)
    q, qd, tau = (rng.uniform(-1.0, 1.0, robot.n) for _ in range(3))
    results = [mrnea.forward_dynamics(robot, q, qd, tau, method=m) for m in FD_METHODS]
    for qdd in results:
        assert np.isfinite(qdd).all()
        np.testing.assert_allclose(qdd, results[0], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("case", [c for c in ACCEPTED if "warns" in c], ids=_case_id)
def test_awkward_file_warns(case: dict) -> None:
    with pytest.warns(UserWarning, match=case["warns"]):
        load_robot(CORPUS / case["file"])


@pytest.mark.parametrize("name", ["reference_arm.urdf", "reference_arm.toml",
                                  "reference_dh_arm.toml"])
def test_reference_files_load_without_any_warning(name: str) -> None:
    """The references every case is derived from are clean: each case has one defect."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        robot = load_robot(CORPUS / name)
    assert robot.joint_names == ("shoulder", "elbow")


# --- awkward models through the Python API --------------------------------------------------------
CAD_INERTIA = np.diag([0.0123, 0.0456, 0.0579001])  # ixx + iyy = 0.0579 < izz: CAD rounding


def massless_middle_arm() -> Robot:
    """A 2R arm whose first link has no mass and no inertia but carries the second: H is positive
    definite wherever the second link's centre of mass is off the first axis."""
    joints = [Joint("j1", "revolute", "base", "l1", axis=(0, 0, 1)),
              Joint("j2", "revolute", "l1", "l2", origin=transform((0.3, 0, 0)), axis=(0, 1, 0))]
    links = [Link("l1"), Link("l2", 2.0, (0.25, 0, 0), np.diag([0.002, 0.02, 0.02]))]
    return Robot(joints, links, name="massless_middle")


def test_triangle_violating_inertia_is_accepted() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrnea.errors.ModelWarning)
        link = Link("cad", 1.0, (0, 0, 0), CAD_INERTIA)
    np.testing.assert_array_equal(link.inertia, CAD_INERTIA)  # used as given


def test_triangle_violating_inertia_warns() -> None:
    with pytest.warns(UserWarning, match="triangle"):
        Link("cad", 1.0, (0, 0, 0), CAD_INERTIA)


def test_thin_plate_on_the_triangle_boundary_does_not_warn() -> None:
    """I1 + I2 = I3 exactly (a thin plate), in any orientation: only rounding (~1e-16) from the
    rotation, far below the 1e-9 relative threshold, so no warning."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        inertia = Q @ np.diag([0.25, 0.5, 0.75]) @ Q.T
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            Link("plate", 3.0, (0, 0, 0), 0.5 * (inertia + inertia.T))


def test_massless_middle_link_is_well_posed() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mrnea.errors.ModelWarning)
        robot = massless_middle_arm()
    q, qd, tau = np.array([0.3, 0.4]), np.array([0.5, -0.2]), np.array([1.0, -2.0])
    H, _ = mrnea.mass_matrix_and_bias(robot, q, qd)
    assert np.linalg.eigvalsh(H)[0] > 1e-3
    ref = mrnea.forward_dynamics(robot, q, qd, tau)
    for m in FD_METHODS:
        np.testing.assert_allclose(mrnea.forward_dynamics(robot, q, qd, tau, method=m), ref,
                                   rtol=1e-12)


def test_massless_middle_link_warns() -> None:
    with pytest.warns(UserWarning, match="massless"):
        massless_middle_arm()


# --- the command line ----------------------------------------------------------------------------
CLI_CASES = [c for c in ERRORS if "kwargs" not in c]  # the CLI cannot pass tip=


@pytest.mark.parametrize("case", _params(CLI_CASES))
def test_cli_info_reports_one_line(case: dict) -> None:
    """``mrnea info FILE``: exit code 2, exactly one stderr line ``mrnea: error: <message>``,
    nothing on stdout, no traceback."""
    res = CliRunner().invoke(main, ["info", str(CORPUS / case["file"])])
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exc_info
    assert res.exit_code == 2
    assert res.stdout == ""
    assert "Traceback" not in res.output + res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("mrnea: error: ")
    assert re.search(case["match"], lines[0]), lines[0]


@pytest.mark.parametrize("case", _params(CLI_CASES))
def test_cli_debug_lets_the_exception_propagate(case: dict) -> None:
    """``mrnea --debug info FILE``: the mrnea error itself leaves the command (traceback)."""
    res = CliRunner().invoke(main, ["--debug", "info", str(CORPUS / case["file"])])
    assert type(res.exception) is _error_class(case), res.exc_info
    tb = "".join(traceback.format_exception(*res.exc_info))
    assert tb.startswith("Traceback (most recent call last)")
    assert re.search(case["match"], tb)
    assert "mrnea: error:" not in res.stderr


def test_cli_debug_traceback_in_a_real_process() -> None:
    """The same through ``python -m mrnea``: the traceback reaches the terminal (stderr)."""
    bad = str(CORPUS / "urdf" / "negative_mass.urdf")
    plain = subprocess.run([sys.executable, "-m", "mrnea", "info", bad], capture_output=True,
                           text=True, timeout=120)
    assert plain.returncode == 2
    assert plain.stderr.strip().splitlines()[-1].startswith("mrnea: error: ")
    assert "Traceback" not in plain.stderr
    debug = subprocess.run([sys.executable, "-m", "mrnea", "--debug", "info", bad],
                           capture_output=True, text=True, timeout=120)
    assert debug.returncode == 1
    assert "Traceback (most recent call last)" in debug.stderr
    assert "mrnea.errors.RobotFileError" in debug.stderr and "forearm" in debug.stderr


@pytest.mark.parametrize("name", [
    "sdt",
    "puma560",
])
def test_cli_builtin_robots_print_no_warnings(name: str) -> None:
    """A built-in robot is not the user's input: no ModelWarning on the terminal."""
    res = subprocess.run([sys.executable, "-m", "mrnea", "info", name], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0
    assert "Warning" not in res.stderr, res.stderr


@pytest.mark.filterwarnings("ignore::mrnea.errors.ModelWarning")
def test_cli_never_replaces_a_users_file_without_force(tmp_path: Path) -> None:
    """The folder given to --out holds a file of the user's named like an output: without
    --force it is left alone (whatever else the command does)."""
    program = tmp_path / "short.toml"
    program.write_text('[program]\nrobot = "sdt"\ndt = 0.01\n[path]\nprofile = "quintic"\n'
                       "waypoints = [[0, 0, 0, 0], [0.1, 0.1, 0.1, 0.1]]\n"
                       "velocity_limit = 1\nacceleration_limit = 1\n", encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    (out / "motion.png").write_text("the user's own figure")
    res = CliRunner().invoke(main, ["simulate", "sdt", str(program), "--out", str(out),
                                    "--quiet"])
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exc_info
    assert (out / "motion.png").read_bytes() == b"the user's own figure"


# --- public API: achievable_accelerations and achievable_step ------------------------------------
@pytest.fixture(scope="module")
def puma() -> Robot:
    return mrnea.robots.puma560()


def _names(arg: str):
    return pytest.raises(StateError, match=rf"^{re.escape(arg)}:")


AA_ARGS = {"q": 6, "qd": 6, "qdd_des": 6, "f_ext": 6, "f_ext_point": 3}
BAD_SHAPES = {"short": lambda w: np.zeros(w - 1), "3-D": lambda w: np.zeros((2, 2, w)),
              "empty-batch": lambda w: np.zeros((0, w)), "scalar": lambda w: np.float64(0.1)}
BAD_VALUES = {"nan": lambda w: np.r_[np.zeros(w - 1), np.nan],
              "inf": lambda w: np.r_[np.zeros(w - 1), np.inf],
              "batch-nan": lambda w: np.r_[np.zeros((2, w)), [[np.nan] * w]],
              "strings": lambda w: ["0.1"] * w, "complex": lambda w: np.full(w, 0.1 + 1j),
              "objects": lambda w: [object()] * w}


def _aa(robot, **override):
    kw = {"q": np.zeros(6), "qd": np.zeros(6), "qdd_des": np.zeros(6), "f_ext": np.zeros(6),
          "f_ext_point": np.zeros(3)}
    kw.update(override)
    return achievable_accelerations(robot, **kw)


@pytest.mark.parametrize("arg", list(AA_ARGS))
@pytest.mark.parametrize("kind", [*BAD_SHAPES, *BAD_VALUES])
def test_achievable_accelerations_names_the_bad_argument(puma, arg: str, kind: str) -> None:
    make = {**BAD_SHAPES, **BAD_VALUES}[kind]
    with _names(arg):
        _aa(puma, **{arg: make(AA_ARGS[arg])})


def test_achievable_accelerations_rejects_a_non_robot_and_mixed_batches(puma) -> None:
    with _names("robot"):
        achievable_accelerations("puma560", np.zeros(6), np.zeros(6), np.zeros(6))
    with pytest.raises(StateError, match=r"batch sizes differ: q \(2, 6\), qd \(3, 6\)"):
        _aa(puma, q=np.zeros((2, 6)), qd=np.zeros((3, 6)))


STEP_ARGS = {"q": 6, "qd": 6, "q_next_cmd": 6, "qd_next_cmd": 6, "f_ext": 6, "f_ext_point": 3}


def _step(robot, **override):
    kw = {k: np.zeros(w) for k, w in STEP_ARGS.items()}
    kw["dt"] = 0.01
    kw.update(override)
    return achievable_step(robot, **kw)


@pytest.mark.parametrize("arg", list(STEP_ARGS))
@pytest.mark.parametrize("kind", ["short", "3-D", "scalar", "nan", "inf", "strings", "complex"])
def test_achievable_step_names_the_bad_argument(puma, arg: str, kind: str) -> None:
    make = {**BAD_SHAPES, **BAD_VALUES}[kind]
    with _names(arg):
        _step(puma, **{arg: make(STEP_ARGS[arg])})


@pytest.mark.parametrize("arg", list(STEP_ARGS))
def test_achievable_step_takes_one_state(puma, arg: str) -> None:
    with pytest.raises(StateError, match="one state"):
        _step(puma, **{arg: np.zeros((2, STEP_ARGS[arg]))})


@pytest.mark.parametrize("mode", ["Hybrid", None, ["paper"]])
def test_achievable_step_rejects_unknown_modes(puma, mode) -> None:
    with _names("mode"):
        _step(puma, mode=mode)


@pytest.mark.parametrize("bad", ["puma560", None])
def test_achievable_step_rejects_a_non_robot(bad) -> None:
    z = np.zeros(6)
    with _names("robot"):
        achievable_step(bad, z, z, z, z, 0.01)


# --- public API: simulate -------------------------------------------------------------------------
Q_CMD = np.linspace(np.zeros(6), np.full(6, 0.01), 10)


@pytest.mark.parametrize(("kwargs", "arg"), [
    ({"q_cmd": np.zeros(6)}, "q_cmd"),
    ({"q_cmd": np.zeros((2, 3, 6))}, "q_cmd"),
    ({"q_cmd": [["a"] * 6] * 3}, "q_cmd"),
    ({"q_cmd": None}, "q_cmd"),
    ({"q_cmd": np.full((10, 6), np.inf)}, "q_cmd"),
    ({"dt": "x"}, "dt"), ({"dt": None}, "dt"), ({"dt": math.inf}, "dt"), ({"dt": -0.01}, "dt"),
    ({"catch_up": "x"}, "catch_up"), ({"catch_up": math.nan}, "catch_up"),
    ({"catch_up": math.inf}, "catch_up"),
    ({"mode": None}, "mode"), ({"mode": ["hybrid"]}, "mode"),
    ({"fd": ["mrnea"]}, "fd"), ({"fd": "MRNEA"}, "fd"),
    ({"q0": np.zeros(5)}, "q0"), ({"q0": [math.nan] * 6}, "q0"), ({"q0": ["x"] * 6}, "q0"),
    ({"q0": np.zeros((2, 6))}, "q0"),
    ({"qd0": [math.inf] * 6}, "qd0"), ({"qd0": np.zeros((2, 6))}, "qd0"),
    ({"f_ext": np.zeros((9, 6))}, "f_ext"), ({"f_ext": [math.nan] * 6}, "f_ext"),
    ({"f_ext": np.zeros(3)}, "f_ext"),
    ({"f_ext_point": [0.0, 0.0]}, "f_ext_point"),
    ({"f_ext_point": np.zeros((3, 3))}, "f_ext_point"),
    ({"f_ext_point": [0.0, math.nan, 0.0]}, "f_ext_point"),
], ids=lambda v: str(v) if isinstance(v, str) else None)
def test_simulate_names_the_bad_argument(puma, kwargs: dict, arg: str) -> None:
    args = {"q_cmd": Q_CMD, "dt": 0.01, **kwargs}
    with _names(arg):
        simulate(puma, **args)


@pytest.mark.parametrize("bad", ["puma560", None])
def test_simulate_rejects_a_non_robot(bad) -> None:
    with _names("robot"):
        simulate(bad, Q_CMD, 0.01)


# --- public API: trajectory functions -------------------------------------------------------------
W = [[0.0, 0.0], [1.0, 1.0]]


@pytest.mark.parametrize("fn", [trapezoidal, quintic])
@pytest.mark.parametrize(("kwargs", "arg"), [
    ({"dt": "x"}, "dt"), ({"dt": None}, "dt"), ({"dt": math.inf}, "dt"), ({"dt": -0.0}, "dt"),
    ({"t0": "x"}, "t0"), ({"t0": math.inf}, "t0"),
    ({"waypoints": [["a", "b"]]}, "waypoints"), ({"waypoints": None}, "waypoints"),
    ({"waypoints": np.zeros((2, 2, 2))}, "waypoints"),
    ({"waypoints": np.zeros((0, 2))}, "waypoints"),
    ({"waypoints": [[0.0, 1j]]}, "waypoints"), ({"waypoints": [[0.0, math.inf]]}, "waypoints"),
    ({"velocity_limit": "fast"}, "velocity_limit"),
    ({"velocity_limit": [[1.0, 1.0]]}, "velocity_limit"),
    ({"velocity_limit": None}, "velocity_limit"), ({"velocity_limit": 1 + 1j}, "velocity_limit"),
    ({"acceleration_limit": -math.inf}, "acceleration_limit"),
    ({"acceleration_limit": [1.0, math.nan]}, "acceleration_limit"),
    ({"dwell": math.nan}, "dwell"), ({"dwell": math.inf}, "dwell"), ({"dwell": "x"}, "dwell"),
], ids=lambda v: str(v) if isinstance(v, str) else None)
def test_profiles_name_the_bad_argument(fn, kwargs: dict, arg: str) -> None:
    args = {"waypoints": W, "dt": 0.01, "velocity_limit": 1.0, "acceleration_limit": 1.0,
            **kwargs}
    with _names(arg):
        fn(**args)


@pytest.mark.parametrize(("kwargs", "arg"), [
    ({"dt": "x"}, "dt"), ({"dt": 0.0}, "dt"), ({"dt": math.nan}, "dt"),
    ({"n": 0}, "n"), ({"n": "2"}, "n"), ({"n": True}, "n"), ({"n": 1.5}, "n"),
])
def test_from_csv_names_the_bad_argument(tmp_path: Path, kwargs: dict, arg: str) -> None:
    p = tmp_path / "path.csv"
    p.write_text("t,q1\n0,0\n1,1\n", encoding="utf-8")
    with _names(arg):
        from_csv(p, **{"dt": 0.01, **kwargs})


@pytest.mark.parametrize(("call", "what"), [
    (lambda: trapezoidal(W, 0.01, 1e-300, 1.0), "tiny velocity limit"),
    (lambda: quintic(W, 1e-300, 1.0, 1.0), "tiny dt"),
    (lambda: trapezoidal([[0.0], [1e308]], 0.01, 1.0, 1.0), "huge waypoint"),
    (lambda: quintic(W, 1e-12, 1.0, 1.0), "2e12 cycles"),
], ids=lambda v: v if isinstance(v, str) else None)
def test_paths_too_long_to_sample_are_refused(call, what: str) -> None:
    """A path of more cycles than can be held must raise a StateError, never return a path
    that breaks the limits it was asked to respect (here: 1 rad in one 10 ms cycle)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(StateError):
            call()


def test_from_csv_with_a_tiny_dt_is_refused(tmp_path: Path) -> None:
    p = tmp_path / "path.csv"
    p.write_text("t,q1\n0,0\n1,1\n", encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(ProgramFileError, match=r"path\.csv: the program would take 1e\+300 "
                                                    r"cycles"):
            from_csv(p, 1e-300)


# --- no silent NaN: known gaps --------------------------------------------------------------------
def _finite_or_mrnea_error(call) -> None:
    """The guarantee: a result is finite, or a MrneaError says why not."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = call()
    except MrneaError:
        return
    for a in out if isinstance(out, tuple) else (out,):
        assert np.isfinite(a).all(), f"silent non-finite result: {a}"


@pytest.mark.parametrize("fn", ["inverse_dynamics", "mass_matrix_and_bias", "forward_dynamics",
                                "joint_reactions"])
def test_overflowing_state_is_not_silent(puma, fn: str) -> None:
    z, big = np.zeros(6), np.full(6, 1e200)
    call = {"inverse_dynamics": lambda: mrnea.inverse_dynamics(puma, z, big, z),
            "mass_matrix_and_bias": lambda: mrnea.mass_matrix_and_bias(puma, z, big),
            "forward_dynamics": lambda: mrnea.forward_dynamics(puma, z, z, np.full(6, 1e308)),
            "joint_reactions": lambda: mrnea.joint_reactions(puma, z, big, z)}[fn]
    _finite_or_mrnea_error(call)


def test_absurd_mass_is_not_silent() -> None:
    def call():
        robot = Robot([Joint("j1", "revolute", "base", "a", axis=(0, 0, 1))],
                      [Link("a", 1e308, (0.1, 0, 0), np.eye(3))])
        return mrnea.forward_dynamics(robot, [0.3], [0.3], [0.3])

    _finite_or_mrnea_error(call)


def test_huge_axis_is_normalised_or_rejected() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            j = Joint("j", "revolute", "a", "b", axis=(1e308, 1e308, 0.0))
        except ModelError:
            return
    assert np.linalg.norm(j.axis) == pytest.approx(1.0)


def test_names_xml_cannot_hold_are_refused() -> None:
    """Whatever loads can be written: a name with control characters (legal in TOML) is refused
    at load, naming the problem, since no URDF could hold it."""
    text = (CORPUS / "reference_arm.toml").read_text(encoding="utf-8")
    with pytest.raises(RobotFileError, match="control characters"):
        loads_native(text.replace('name = "arm"', 'name = "arm\\u001f"'))
