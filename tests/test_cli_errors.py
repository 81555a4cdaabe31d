"""The command line: exactly one ``mrnea: error:`` line on stderr, exit code 2, for every bad
input, click's usage errors included; warnings as one ``mrnea: warning:`` line each; no
traceback (but with ``--debug``); the compile notice only when Numba really compiles.
"""

from __future__ import annotations

import subprocess
import sys
import warnings
from pathlib import Path

import numba
import numpy as np
import pytest
from click.testing import CliRunner

import mrnea.cli.base as base
import mrnea.cli.info as info_module
from mrnea.cli import main
from mrnea.errors import ModelWarning

MALFORMED = Path(__file__).resolve().parent / "malformed"
PROGRAM = ('[program]\nrobot = "sdt"\ndt = 0.01\n[path]\nprofile = "quintic"\n'
           "waypoints = [[0, 0, 0, 0], [0.05, 0, 0, 0]]\nvelocity_limit = 1\n"
           "acceleration_limit = 1\n")


def run(*args: str | Path):
    return CliRunner().invoke(main, [str(a) for a in args])


def one_error_line(res, *words: str) -> str:
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error:"), res.stderr
    assert "Traceback" not in res.stderr and "Usage:" not in res.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.mark.parametrize(("args", "words"), [
    (["simulate"], ["simulate", "Missing argument 'PROGRAM'", "'mrnea simulate --help'"]),
    (["check", "sdt"], ["check", "Missing argument 'PROGRAM'", "'sdt' is taken as ROBOT",
                        "--help"]),
    (["info", "--gravity"], ["'--gravity' requires an argument"]),
    (["info", "sdt", "--foo"], ["No such option '--foo'", "'mrnea info --help'"]),
    (["info", "sdt", "extra"], ["unexpected extra argument", "--help"]),
    (["--bogus"], ["No such option '--bogus'", "'mrnea --help'"]),
    (["bogus"], ["No such command 'bogus'", "'mrnea --help'"]),
    (["bogus\nsecond line"], ["No such command", "\\n"]),
    (["demo", "--mode", "fast"], ["'--mode'", "'fast' is not one of 'hybrid', 'paper'"]),
    (["check", "sdt", "p.toml", "--dt", "fast"], ["'--dt'", "not a number: 'fast'"]),
    (["check", "sdt", "p.toml", "--dt"], ["--dt", "requires an argument"]),
    (["simulate", "sdt", "p.toml", "--fd", "aba"], ["'--fd'", "'aba' is not one of"]),
    (["demo", "--catch-up", "1"], ["No such option '--catch-up'"]),
    (["simulate", "sdt", "path.csv"], ["simulate", "a CSV program needs --dt"]),
])
def test_usage_errors_are_one_line(args: list[str], words: list[str]) -> None:
    one_error_line(run(*args), *words)


def test_usage_errors_from_a_real_process_are_one_line() -> None:
    res = subprocess.run([sys.executable, "-m", "mrnea", "simulate", "sdt"], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 2
    assert res.stderr.splitlines() == [
        "mrnea: error: simulate: Missing argument 'PROGRAM' ('sdt' is taken as ROBOT: a program "
        "is a .toml file with a [program] table, a path .csv or 'demo') (see 'mrnea simulate "
        "--help')"]


def test_help_and_version_exit_0() -> None:
    for args in ([], ["--help"], ["simulate", "--help"], ["--version"]):
        res = run(*args)
        assert res.exit_code == 0 and res.stderr == "", (args, res.output)
        assert res.stdout
    assert "Usage:" in run().stdout  # `mrnea` alone: the help


def test_overflowing_waypoints_give_one_line_and_no_runtime_warning(tmp_path: Path) -> None:
    (tmp_path / "p.toml").write_text(PROGRAM.replace("[0.05, 0, 0, 0]", "[-1e308, 1e308, 0, 0]")
                                     .replace("[0, 0, 0, 0]", "[1e308, -1e308, 0, 0]"))
    res = subprocess.run([sys.executable, "-m", "mrnea", "check", "sdt", tmp_path / "p.toml"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 2
    assert len(res.stderr.splitlines()) == 1 and res.stderr.startswith("mrnea: error:")
    assert "RuntimeWarning" not in res.stderr and "encountered" not in res.stderr


def test_a_model_warning_is_one_line_without_source(tmp_path: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "mrnea", "info",
                          MALFORMED / "toml" / "accepted_triangle_inequality.toml"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: warning: "), res.stderr
    assert "triangle inequality" in lines[0] and "warn(" not in res.stderr


def test_warnings_print_once_each(capsys) -> None:
    with base._warnings_as_lines():
        for _ in range(3):
            warnings.warn("link 'x' is massless", ModelWarning, stacklevel=1)
        warnings.warn("another\nwarning", UserWarning, stacklevel=1)
        warnings.warn("numpy's", RuntimeWarning, stacklevel=1)
        assert np.isinf(np.float64(1e308) * 10)
    err = capsys.readouterr().err
    assert err.splitlines() == ["mrnea: warning: link 'x' is massless",
                                "mrnea: warning: another\\nwarning"]


def test_an_internal_error_is_one_line_and_debug_shows_it(monkeypatch) -> None:
    def broken(spec: str, options: object):
        raise RuntimeError("a bug\nwith two lines")

    monkeypatch.setattr(info_module, "load_robot_arg", broken)
    line = one_error_line(run("info", "sdt"), "internal error", "RuntimeError", "--debug")
    assert "a bug\\nwith two lines" in line
    res = CliRunner().invoke(main, ["--debug", "info", "sdt"])
    assert isinstance(res.exception, RuntimeError)


def test_memory_error_is_one_line(monkeypatch) -> None:
    def exhausted(spec: str, options: object):
        raise MemoryError

    monkeypatch.setattr(info_module, "load_robot_arg", exhausted)
    one_error_line(run("info", "sdt"), "out of memory")


# --- the compile notice -------------------------------------------------------------------------
def test_the_notice_shows_when_numba_compiles(monkeypatch, capsys) -> None:
    monkeypatch.setattr(base._CompileNotice, "shown", False)

    @numba.njit(cache=False)
    def fresh(x):  # never compiled before: compiling it raises numba's compile event
        return x + 1

    with base.compile_notice(quiet=True):
        fresh(1)
    assert base.COMPILE_NOTICE not in capsys.readouterr().err

    @numba.njit(cache=False)
    def fresh2(x):
        return x + 2

    with base.compile_notice():
        fresh2(1)
        fresh2(2.0)  # a second compilation: the notice is said once
    assert capsys.readouterr().err.count(base.COMPILE_NOTICE) == 1
    monkeypatch.setattr(base._CompileNotice, "shown", False)
    with base.compile_notice():
        fresh2(3)  # compiled already: nothing to say
    assert capsys.readouterr().err == ""


def test_a_cached_run_shows_no_notice(tmp_path: Path) -> None:
    (tmp_path / "p.toml").write_text(PROGRAM)
    cmd = [sys.executable, "-m", "mrnea", "check", "sdt", tmp_path / "p.toml"]
    subprocess.run(cmd, capture_output=True, text=True, timeout=600)  # fills the cache if needed
    for extra in ([], ["--quiet"]):
        res = subprocess.run([*cmd, *extra], capture_output=True, text=True, timeout=600)
        assert res.returncode in (0, 1), res.stderr
        assert "Compiling" not in res.stderr, res.stderr
