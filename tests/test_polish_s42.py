"""Session 42's fixes: a command stopped while it replaces its files (``--force``) leaves the
old ones as they were."""

from __future__ import annotations

from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


@pytest.mark.parametrize("after", [1, 3])
def test_a_stop_while_replacing_files_puts_the_old_ones_back(monkeypatch, tmp_path: Path,
                                                              after: int) -> None:
    """``mrnea size --force`` over a finished run's folder, stopped after ``after`` of its new
    files: exit 130, and every file of the first run is there with its bytes, nothing else
    (it had removed the replaced files: neither the old nor the new ones were left)."""
    from click.testing import CliRunner
    from test_sizing import write_cli_case

    from mrnea.cli import base, main

    write_cli_case(tmp_path)
    monkeypatch.chdir(tmp_path)
    args = ["size", "arm.toml", "swing.toml", "--catalogue", "cat.toml", "--out", "out"]
    first = CliRunner().invoke(main, args)
    assert first.exit_code in (0, 1), first.output
    before = _files(tmp_path / "out")
    assert len(before) >= 3, before.keys()
    real, calls = base.checkpoint, []

    def stop_after_some() -> None:  # write_files' checks: one before each file
        calls.append(1)
        if len(calls) > after:
            raise KeyboardInterrupt
        real()

    monkeypatch.setattr(base, "checkpoint", stop_after_some)
    res = CliRunner().invoke(main, [*args, "--force"])
    assert res.exit_code == 130, res.output
    assert len(calls) == after + 1  # stopped while writing, after ``after`` new files
    assert _files(tmp_path / "out") == before


def test_out_of_memory_names_the_command_files(monkeypatch, tmp_path: Path) -> None:
    """A MemoryError inside a command (here the retiming of the Puma 560's pick program): one
    line naming the program file, exit 2 (it named no file)."""
    import importlib

    from click.testing import CliRunner

    from mrnea.cli import main

    def no_memory(*args, **kw):
        raise MemoryError

    # the package mrnea.retime (the name mrnea.retime is the function)
    monkeypatch.setattr(importlib.import_module("mrnea.retime"), "retime", no_memory)
    program = str(EXAMPLES / "puma_pick.toml")
    res = CliRunner().invoke(main, ["retime", program, "--out", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert res.stderr.strip() == (f"mrnea: error: out of memory (on '{program}'): use a "
                                  "coarser dt or a shorter program"), res.stderr


def test_the_report_functions_refuse_non_bool_flags(tmp_path: Path) -> None:
    """``plot_result(overwrite=...)`` without a folder and ``write_report(view3d=...)`` called
    directly refuse a non-bool, naming it (they were accepted; the result's methods alone
    checked them)."""
    import numpy as np

    import mrnea
    from mrnea.errors import MrneaError
    from mrnea.report import plot_result, write_report

    res = mrnea.simulate(mrnea.robots.puma560(), np.zeros((3, 6)), 0.01)
    with pytest.raises(MrneaError, match="overwrite"):
        plot_result(res, None, overwrite="x")
    with pytest.raises(MrneaError, match="view3d"):
        write_report(res, tmp_path / "r.html", view3d="x")
    assert not (tmp_path / "r.html").exists()


def test_an_identified_link_the_model_refuses_is_the_logs_fault() -> None:
    """A fit whose link the model refuses (link 2's centre of mass 1e6 m away: seen with a
    300,000-row log of random efforts) says the log does not determine it; it read as if the
    prior robot were wrong ("link 'link2': centre of mass: length ... is beyond 10000 m")."""
    import numpy as np

    import mrnea
    from mrnea.errors import StateError
    from mrnea.identify.estimate import _robot
    from mrnea.identify.regressor import actuator_parameters, inertial_parameters

    prior = mrnea.robots.puma560()
    pi = inertial_parameters(prior)
    pi[10 + 1:10 + 4] = pi[10] * 1e6  # link 2's first moment m c: c = 1e6 m on each axis
    with pytest.raises(StateError, match="the log does not determine it"):
        _robot(prior, np.concatenate([pi, actuator_parameters(prior)]))
    ident, offset = _robot(prior, np.concatenate([inertial_parameters(prior),
                                                  actuator_parameters(prior)]))
    assert np.array_equal(ident.links[1].mass, prior.links[1].mass) and not offset.any()


def test_a_joint_just_past_its_limit_shows_the_digits_that_tell_them_apart(tmp_path: Path
                                                                           ) -> None:
    """A MoveJ two ulps past the Puma 560's joint5 upper limit (100 deg): the verdict said "at
    1.745 rad, beyond its upper limit 1.745 rad"; it shows the digits that differ."""
    import numpy as np
    from click.testing import CliRunner

    import mrnea
    from mrnea.cli import main

    upper = mrnea.robots.puma560().joints[4].upper
    assert upper == np.deg2rad(100.0)  # the URDF-like built-in's limit
    target = float(np.nextafter(np.nextafter(upper, 2.0), 2.0))
    (tmp_path / "lim.toml").write_text(
        '[program]\nname = "lim"\nrobot = "puma560"\ndt = 0.01\nq0 = [0, 0, 0, 0, 0, 0]\n'
        f'[[move]]\ntype = "joint"\ntarget = [0, 0, 0, 0, {target!r}, 0]\n'
        "velocity_limit = 1.0\nacceleration_limit = 2.0\n")
    res = CliRunner().invoke(main, ["check", str(tmp_path / "lim.toml")])
    assert res.exit_code == 1, res.output
    assert (f"joint joint5 at {target!r} rad, beyond its upper limit {float(upper)!r} rad"
            in res.stdout), res.stdout


def test_a_pose_beyond_any_length_is_refused_by_the_inverse_kinematics() -> None:
    """A pose 1e300 m away: refused naming the pose and the bound (it was solved and said
    "position error inf m"); one at 2 m is solved and reported unreached."""
    import numpy as np

    import mrnea
    from mrnea.errors import StateError

    robot = mrnea.robots.puma560()
    T = np.eye(4)
    T[:3, 3] = (1e300, 0.0, 0.0)
    with pytest.raises(StateError, match=r"pose 0's position \[1e\+300, 0\.0, 0\.0\] m is "
                                         r"beyond 10000 m"):
        mrnea.inverse_kinematics(robot, T, np.zeros(6))
    T[:3, 3] = (2.0, 0.0, 0.0)  # out of the Puma's reach (under 1 m), within the bound
    res = mrnea.ik.solve_path(robot, T[None], np.zeros(6))
    assert not res.converged[0] and np.isfinite(res.position_error[0])


def test_an_arc_too_long_for_memory_is_refused_before_its_profile_is_made(monkeypatch,
                                                                          tmp_path: Path
                                                                          ) -> None:
    """A MoveC through a via 1e-6 m off the line beyond its target: a radius of kilometres,
    39 million cycles at 4 ms. Refused by the memory budget naming the move, and no profile of
    those cycles made first (it built one, about 7 s, then refused it)."""
    import mrnea
    import mrnea.cartesian.path as path
    from mrnea.errors import MrneaError

    made = []
    real = path.trapezoidal

    def recorded(*args, **kw):
        out = real(*args, **kw)
        made.append(out[1].shape[0])
        return out

    monkeypatch.setattr(path, "trapezoidal", recorded)
    (tmp_path / "circ.toml").write_text(
        '[program]\nname = "circ"\nrobot = "puma560"\ndt = 0.004\n'
        "q0 = [0.0, 0.5, -0.5, 0.0, 0.5, 0.0]\n"
        '[[move]]\ntype = "linear"\nxyz = [0.35, 0.0, 1.25]\nspeed = 0.1\nacceleration = 0.5\n'
        '[[move]]\ntype = "circular"\nvia = [0.25, 1e-6, 1.25]\nxyz = [0.3, 0.0, 1.25]\n'
        "speed = 0.1\nacceleration = 0.5\n")
    with pytest.raises(MrneaError, match=r"\[\[move\]\] 2 \(circular\): a Cartesian program of "
                                         r"3\.9\d+e\+07 cycles"):
        mrnea.load_program(tmp_path / "circ.toml")
    assert len(made) == 1 and made[0] < 1000, made  # the first move's profile alone


def test_a_path_with_a_nul_character_is_a_named_error(tmp_path: Path) -> None:
    """A NUL in an output or input path: one MrneaError naming the argument (os.lstat's
    ValueError 'embedded null byte' had escaped from the writer)."""
    import numpy as np

    import mrnea
    from mrnea.errors import MrneaError

    res = mrnea.simulate(mrnea.robots.puma560(), np.zeros((3, 6)), 0.01)
    for call in (lambda: res.to_csv(str(tmp_path / "a\0b.csv")),
                 lambda: res.save_summary(str(tmp_path / "a\0b.json")),
                 lambda: mrnea.simulate(mrnea.robots.puma560(), np.zeros((3, 6)), 0.01,
                                        stream=str(tmp_path / "a\0b.csv")),
                 lambda: mrnea.load_robot("x\0y.urdf")):
        with pytest.raises(MrneaError, match="cannot hold a NUL character"):
            call()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("delimiter", [",", ";", "\t", " "])
def test_a_plain_path_csv_read_at_once_equals_row_by_row(monkeypatch, tmp_path: Path,
                                                         delimiter: str) -> None:
    """The rows of a plain path CSV (digits, signs, points, exponents, CRLF and blank lines)
    read at once are the numbers the row-by-row reader gives, bit for bit; a file with a
    comment, a word or a bad row goes row by row and keeps its message naming the line."""
    import numpy as np

    import mrnea.io.pathcsv as pathcsv
    from mrnea.errors import ProgramFileError

    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(1e-3, 2e-3, 500))
    q = rng.normal(size=(500, 3)) * np.array([1e-7, 1.0, 1e5])
    cells = [[repr(float(x)) for x in row] for row in np.column_stack([t, q])]
    cells[3][1], cells[4][2], cells[5][3] = "+1.5", ".25", "-3.E+2"  # the grammar's spellings
    lines = [delimiter.join(["time", "a", "b", "c"])] + [delimiter.join(r) for r in cells]
    lines.insert(10, "")
    (tmp_path / "p.csv").write_bytes(("\r\n".join(lines) + "\r\n").encode())
    text = (tmp_path / "p.csv").read_text()
    assert pathcsv._plain_rows(text, 1, delimiter, 4) is not None  # the file is plain
    header, fast = pathcsv.read_table(tmp_path / "p.csv", 3)
    monkeypatch.setattr(pathcsv, "_plain_rows", lambda *args: None)
    header_slow, slow = pathcsv.read_table(tmp_path / "p.csv", 3)
    assert header == header_slow and fast.shape == (500, 4)
    assert fast.tobytes() == slow.tobytes()
    assert fast[3, 1] == 1.5 and fast[4, 2] == 0.25 and fast[5, 3] == -300.0
    monkeypatch.undo()
    for bad, message in (("1e", "line 8 .*column 2"), ("1_0", "line 8 .*column 2"),
                         ("nan", "line 8 .*column 2.*not a finite number")):
        rows = list(lines)
        rows[7] = delimiter.join([cells[6][0], bad, "0", "0"])
        (tmp_path / "bad.csv").write_text("\n".join(rows) + "\n")
        with pytest.raises(ProgramFileError, match=message):
            pathcsv.read_table(tmp_path / "bad.csv", 3)
