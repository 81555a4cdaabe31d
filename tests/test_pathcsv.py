"""Resampling a path CSV: the spline interpolations, their end conditions, the PathWarning.

References are closed forms: ``sin(pi t)`` (acceleration amplitude pi^2), polynomials a spline
of that degree reproduces exactly, a path at rest (zero end velocity).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mrnea
from mrnea.cli import main
from mrnea.errors import PathWarning, ProgramFileError, StateError
from mrnea.io import from_csv, load_program
from mrnea.io.pathcsv import _spline, resample
from mrnea.model import Joint, Link, Robot


def write_csv(path: Path, t: np.ndarray, q: np.ndarray) -> Path:
    rows = "\n".join(",".join(repr(float(x)) for x in (ti, *np.atleast_1d(qi)))
                     for ti, qi in zip(t, q, strict=True))
    names = ",".join(f"q{i}" for i in range(np.atleast_2d(q.T).shape[0]))
    path.write_text(f"t,{names}\n{rows}\n", encoding="utf-8")
    return path


def peak_acceleration(q: np.ndarray, dt: float) -> float:
    """The largest second difference / dt^2: the acceleration the simulator asks for."""
    return float(np.abs(np.diff(q, 2, axis=0)).max() / dt**2)


def test_the_issues_example_50_ms_rows_at_5_ms(tmp_path: Path) -> None:
    """sin(pi t) sampled every 50 ms, resampled at 5 ms: the path's acceleration amplitude is
    pi^2 = 9.87 rad/s^2. Linear interpolation asks for 98.5 (ten times it: the velocity jumps by
    pi^2 * 50 ms at every row, within one 5 ms cycle); either spline for pi^2 to within 1 %, and
    follows the path to within its interpolation error."""
    rows_t = np.arange(21) * 0.05
    p = write_csv(tmp_path / "sin.csv", rows_t, np.sin(np.pi * rows_t))
    dt = 0.005
    peaks = {}
    for kind in ("linear", "cubic", "quintic"):
        t, q = from_csv(p, dt, interpolation=kind)
        assert t.size == 201 and q[0, 0] == 0.0 and q[-1, 0] == math.sin(math.pi * 1.0)
        peaks[kind] = peak_acceleration(q[:, 0], dt)
        if kind != "linear":
            assert np.abs(q[:, 0] - np.sin(np.pi * t)).max() < 1e-5
    assert peaks["linear"] == pytest.approx(98.5, abs=0.1)
    assert peaks["cubic"] == pytest.approx(math.pi**2, rel=0.01)
    assert peaks["quintic"] == pytest.approx(math.pi**2, rel=0.01)
    assert from_csv(p, dt)[1].tolist() == from_csv(p, dt, interpolation="cubic")[1].tolist()


@pytest.mark.parametrize(("kind", "degree"), [("cubic", 3), ("quintic", 5)])
def test_not_a_knot_ends_reproduce_a_polynomial_of_the_splines_degree(kind: str,
                                                                      degree: int) -> None:
    """Ends not at rest: nothing is imposed there, so the spline is exact on a polynomial of
    its degree, accelerations at the ends included (a natural spline would force them to 0)."""
    rng = np.random.default_rng(degree)
    time = np.sort(rng.uniform(0.0, 1.0, 9))
    time[0], time[-1] = 0.0, 1.0
    coef = rng.normal(size=degree + 1)
    q = np.polyval(coef, time)[:, None]
    t, out = resample(time, q, 0.01, kind)
    assert np.abs(out[:, 0] - np.polyval(coef, t)).max() < 1e-12
    acc = np.polyval(np.polyder(coef, 2), 0.0)
    assert abs(acc) > 0.1  # the end accelerates: a natural spline would not reproduce it


@pytest.mark.parametrize(("kind", "degree"), [("cubic", 3), ("quintic", 5)])
def test_at_rest_ends_have_zero_velocity(kind: str, degree: int) -> None:
    """First (last) two rows equal: the joint starts (ends) at rest; the spline's velocity there
    is 0 (the quintic's acceleration too), the other end is free."""
    time = np.arange(12) * 0.1
    y = np.r_[0.0, 0.0, 0.1, 0.4, 0.9, 1.5, 2.0, 2.3, 2.4, 2.4, 2.4, 2.4]
    s = _spline(time, y, degree)
    for end in (time[0], time[-1]):
        assert s.derivative(1)(end) == pytest.approx(0.0, abs=1e-12)
        if degree == 5:
            assert s.derivative(2)(end) == pytest.approx(0.0, abs=1e-10)
    free = np.r_[y[:-2], 2.5, 2.7]  # moves at the end: no condition there
    assert abs(_spline(time, free, degree).derivative(1)(time[-1])) > 0.5
    assert np.abs(s(time) - y).max() < 1e-12  # through every row


def test_resample_keeps_still_joints_and_both_ends_exact() -> None:
    time = np.array([0.0, 0.1, 0.25, 0.4])
    q = np.array([[0.3, 1.0 / 3.0], [0.3, 0.5], [0.3, 0.7], [0.3, 0.9]])
    for kind in ("linear", "cubic"):
        t, out = resample(time, q, 0.03, kind)  # 0.4 / 0.03: 13.3 cycles, the last holds
        assert (out[:, 0] == 0.3).all()
        assert out[0].tolist() == q[0].tolist() and out[-1].tolist() == q[-1].tolist()
        assert t.size == 15


def test_quintic_needs_enough_rows(tmp_path: Path) -> None:
    p = write_csv(tmp_path / "short.csv", np.arange(5) * 0.1, np.arange(5.0) ** 2)
    with pytest.raises(ProgramFileError, match=r"short\.csv: a quintic spline through 5 rows "
                                                r"needs at least 6"):
        from_csv(p, 0.01, interpolation="quintic")
    from_csv(p, 0.01, interpolation="cubic")  # a cubic one takes it
    with pytest.raises(StateError, match=r"^interpolation: unknown 'spline'"):
        from_csv(p, 0.01, interpolation="spline")


def one_joint_robot(lower: float, upper: float) -> Robot:
    return Robot([Joint("j0", "revolute", "base", "l0", lower=lower, upper=upper)],
                 [Link("l0", 1.0, (0.1, 0.0, 0.0), np.diag([0.01, 0.01, 0.01]))])


STEP_T = np.arange(8) * 0.1
STEP_Q = np.array([0.0, 0.0, 0.0, 0.2, 0.8, 1.0, 1.0, 1.0])  # within [-1, 1]; a spline overshoots


def test_a_spline_leaving_a_limit_the_rows_respect_is_a_path_warning(tmp_path: Path) -> None:
    robot = one_joint_robot(-1.0, 1.0)
    p = write_csv(tmp_path / "step.csv", STEP_T, STEP_Q)
    with pytest.warns(PathWarning, match=r"step\.csv: joint 'j0': the cubic interpolation "
                                         r"between the rows leaves the position limits "
                                         r"\[-1, 1\] rad at t = 0\.\d+ s"):
        _, q = from_csv(p, 0.01, robot=robot)
    assert q.max() > 1.0  # it does
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        from_csv(p, 0.01, interpolation="linear", robot=robot)  # linear never leaves the rows
        from_csv(p, 0.01, robot=one_joint_robot(-1.0, 0.9))  # the rows themselves leave it
    with pytest.raises(StateError, match=r"^n: 2 joints, but robot"):
        from_csv(p, 0.01, n=2, robot=robot)


def test_program_interpolation_key_and_its_warning(tmp_path: Path) -> None:
    write_csv(tmp_path / "step.csv", STEP_T, STEP_Q)
    one_joint_robot(-1.0, 1.0).to_toml(tmp_path / "arm.toml")
    text = '[program]\nrobot = "arm.toml"\ndt = 0.01\n[path]\ncsv = "step.csv"\n{extra}'
    prog_file = tmp_path / "p.toml"
    prog_file.write_text(text.format(extra=""))
    prog = load_program(prog_file)
    assert prog.interpolation == "cubic" and prog.csv_rows.shape == (8, 2)
    with pytest.warns(PathWarning, match=r"p\.toml: joint 'j0'"):
        prog.load_robot()
    prog_file.write_text(text.format(extra='interpolation = "linear"'))
    lin = load_program(prog_file)
    assert lin.interpolation == "linear"
    np.testing.assert_array_equal(lin.q_cmd[:, 0], np.interp(lin.t, STEP_T, STEP_Q))
    prog_file.write_text(text.format(extra='interpolation = "akima"'))
    with pytest.raises(ProgramFileError, match=r"\[path\]: 'interpolation' must be one of "
                                               r"'cubic', 'quintic', 'linear', got 'akima'"):
        load_program(prog_file)
    prog_file.write_text('[program]\nrobot = "arm.toml"\ndt = 0.01\n[path]\n'
                         'profile = "quintic"\nwaypoints = [[0.0], [1.0]]\n'
                         'velocity_limit = 1.0\nacceleration_limit = 1.0\n')
    assert load_program(prog_file).interpolation is None
    prog_file.write_text(prog_file.read_text() + 'interpolation = "linear"\n')
    with pytest.raises(ProgramFileError, match="'interpolation' applies to a 'csv' path only"):
        load_program(prog_file)


def test_cli_interpolation_option_and_report(tmp_path: Path) -> None:
    rows_t = np.arange(21) * 0.05
    p = write_csv(tmp_path / "sin.csv", rows_t, np.c_[np.sin(np.pi * rows_t) * 0.1,
                                                       np.zeros((21, 3))])
    runner = CliRunner()
    out = tmp_path / "out"
    res = runner.invoke(main, ["simulate", "sdt", str(p), "--dt", "0.005", "--interpolation",
                               "quintic", "--out", str(out), "--quiet"])
    assert res.exit_code in (0, 1), res.output
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "CSV path resampled by" in html and "quintic spline" in html
    prog = tmp_path / "prog.toml"
    prog.write_text(f'[program]\nrobot = "sdt"\ndt = 0.005\n[path]\ncsv = "{p.name}"\n')
    res = runner.invoke(main, ["check", "sdt", str(prog), "--interpolation", "linear"])
    assert res.exit_code == 2
    assert "--interpolation linear differs from the program's (cubic)" in res.stderr
    res = runner.invoke(main, ["check", "sdt", str(prog), "--interpolation", "cubic", "--quiet"])
    assert res.exit_code in (0, 1), res.output


def test_top_level_names() -> None:
    assert mrnea.PathWarning is PathWarning and issubclass(PathWarning, UserWarning)
