"""Fuzzing the command line itself: whatever the arguments and the files, ``mrnea`` answers with
an exit code of 0, 1 or 2, never a traceback, and on 2 with exactly one ``mrnea: error:`` line.

Hypothesis builds argument lists from the real commands and options (read from the click
objects, so a new option is fuzzed too) mixed with garbage, and writes hostile files for them to
name: robot files (native TOML and URDF), programs and path CSVs, each a valid file mutated by
inserting hostile tokens (NaN, ``1_0``, non-ASCII digits, NUL bytes, deep brackets, entity
declarations, math-text names, huge and tiny numbers...), deleting or duplicating spans, or
truncating. The commands run in-process (click's test runner), in a fresh folder per example.

Beyond the exit code: no "Traceback" and no "internal error" (the last-resort message for a
bug), and stderr holds only the error line, ``mrnea: warning:`` lines, the progress labels and the
compile notice. The fast test (in the default run) fuzzes ``info`` and ``check``, which write
nothing; the ``slow`` one (``-m slow``) all commands, ``simulate``, ``demo`` and ``fig3``
included, with many more examples.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import click
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mrnea.cli import main
from mrnea.cli.base import COMPILE_NOTICE

MALFORMED = Path(__file__).resolve().parent / "malformed"
BASES = {
    "robot.toml": (MALFORMED / "reference_arm.toml").read_text(encoding="utf-8"),
    "robot.urdf": (MALFORMED / "reference_arm.urdf").read_text(encoding="utf-8"),
    "prog.toml": ('[program]\nname = "p"\nrobot = "robot.toml"\ndt = 0.01\nmode = "hybrid"\n'
                  '[path]\nprofile = "quintic"\nunits = "rad"\n'
                  "waypoints = [[0.0, 0.0], [0.2, -0.1], [0.1, 0.1]]\n"
                  "velocity_limit = [1.0, 1.0]\nacceleration_limit = 4.0\ndwell = 0.02\n"
                  "[wrench]\ntimes = [0.0, 0.2]\n"
                  "values = [[0, 0, 1, 0, 0, 0], [0, 0, -1, 0, 0, 0]]\npoint = [0, 0, 0.1]\n"),
    "sdt.toml": ('[program]\nrobot = "sdt"\ndt = 0.02\n[path]\ncsv = "path.csv"\n'
                 'units = "deg"\n'),
    "path.csv": "t,q1,q2,q3,q4\n0,0,0,0,0\n0.1,1,0.5,0,0\n0.3,2,1,0.5,0\n",
}
HOSTILE = ["nan", "inf", "-inf", "1e308", "-1e308", "1e-320", "0", "-1", "1_0", "\uff11",
           "\u0661", "\x00", "\n", "\r\n", "\t", "[[[[[[[[[[[[[[[[", "]]]]", "{", "}", "=",
           '"', "'", ",", "<", ">", "&e;", '<!DOCTYPE robot [<!ENTITY e "x">]>', "$\\frac$",
           "\U0001f916", "\ud800", "[program]", "[[joint]]", "[path]", 'csv = "/dev/zero"',
           'robot = "puma560"', 'robot = "prog.toml"', "<joint>", "</link>", "x" * 300,
           "99999999999999999999", "1e-9", "dt = 1e-7", 'profile = "trapezoidal"']
GARBAGE = ["", "-", "--", "---x", "-h", "0", "-1", "nan", "1_0", "\uff11", "x" * 200, "a\nb",
           "/dev/zero", "/", ".", "..", "~", "$HOME", "sdt", "puma560", "missing.toml"]
# how often each command is drawn: those reading the hostile files most, the fixed SDT runs
# (demo, fig3: a few seconds each) and the optimisation (excite: up to a minute) least
WEIGHT = {"check": 4, "simulate": 3, "info": 2, "demo": 1, "fig3": 1, "excite": 1}
FILES = ["robot.toml", "robot.urdf", "prog.toml", "sdt.toml", "path.csv", "out", "out/x.png",
         "fig.svg", "fig.xyz"]


@st.composite
def mutated(draw, text: str) -> str:
    """``text`` with a few hostile edits (or none: valid files must run too)."""
    for _ in range(draw(st.integers(0, 3))):
        at = draw(st.integers(0, len(text)))
        kind = draw(st.sampled_from(["insert", "replace", "delete", "duplicate", "truncate"]))
        if kind == "insert":
            text = text[:at] + draw(st.sampled_from(HOSTILE)) + text[at:]
        elif kind == "replace":
            end = min(len(text), at + draw(st.integers(1, 12)))
            text = text[:at] + draw(st.sampled_from(HOSTILE)) + text[end:]
        elif kind == "delete":
            text = text[:at] + text[at + draw(st.integers(1, 40)):]
        elif kind == "duplicate":
            end = min(len(text), at + draw(st.integers(1, 80)))
            text = text[:end] + text[at:end] + text[end:]
        else:
            text = text[:at]
    return text


def _values(param: click.Parameter) -> st.SearchStrategy[str]:
    """Plausible values for an option or argument (mostly), or garbage."""
    good: list[str] = []
    if isinstance(param.type, click.Choice):
        good = list(param.type.choices)
    elif param.name in ("dt", "catch_up"):
        good = ["0.01", "0.02", "0.05", "5", "1e-3", "0", "-0.01", "1e-300", "inf", "0.01 "]
    elif param.name == "robot":
        good = ["sdt", "puma560", "robot.toml", "robot.urdf", "prog.toml"]
    elif param.name == "program":
        good = ["prog.toml", "sdt.toml", "path.csv", "robot.toml"]
    else:
        good = FILES
    return st.integers(0, 9).flatmap(
        lambda k: st.sampled_from(good) if k < 7 else
        st.sampled_from(GARBAGE) if k < 9 else st.text(max_size=8))


@st.composite
def argv(draw, commands: tuple[str, ...]) -> list[str]:
    """Mostly well-formed calls of ``commands`` (files and values plausible or hostile), some
    with a missing, extra or unknown argument, a few that are not calls at all."""
    if draw(st.integers(0, 19)) == 0:
        return [draw(st.sampled_from(["bogus", "--help", "--version", "--bogus", ""])),
                *draw(st.lists(st.sampled_from(GARBAGE), max_size=2))]
    name = draw(st.sampled_from([c for c in commands for _ in range(WEIGHT.get(c, 3))]))
    cmd = main.commands[name]
    args = [name]
    positional = [p for p in cmd.params if isinstance(p, click.Argument)]
    options = [p for p in cmd.params if isinstance(p, click.Option)
               and p.name not in ("help",)]
    count = len(positional) + (draw(st.sampled_from([-1, 1])) if draw(st.integers(0, 9)) == 0
                               else 0)
    for k in range(max(0, count)):
        args.append(draw(_values(positional[k])) if k < len(positional)
                    else draw(st.sampled_from(GARBAGE)))
    for _ in range(draw(st.integers(0, 3))):
        if not options or draw(st.integers(0, 14)) == 0:
            args.append(draw(st.sampled_from(["--nope", "-z", "--dt=", "--out"])))
            continue
        opt = draw(st.sampled_from(options))
        args.append(draw(st.sampled_from(opt.opts)))
        if not opt.is_flag and draw(st.integers(0, 14)):  # sometimes the value is missing
            args.append(draw(_values(opt)))
    return args


def _check(args: list[str], files: dict[str, str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            for name, text in files.items():
                Path(name).write_bytes(text.encode("utf-8", "surrogatepass"))
            res = CliRunner().invoke(main, args)
        finally:
            os.chdir(cwd)
    where = f"mrnea {args!r}\nstderr: {res.stderr[-2000:]}"
    if res.exception is not None and not isinstance(res.exception, SystemExit):
        raise AssertionError(f"{where}\nescaped: {res.exception!r}") from res.exception
    assert res.exit_code in (0, 1, 2), where
    assert "Traceback" not in res.stderr and "internal error" not in res.stderr, where
    lines = res.stderr.splitlines()
    errors = [line for line in lines if line.startswith("mrnea: error:")]
    if res.exit_code == 2:
        assert len(errors) == 1 and lines[-1] == errors[0], where
    else:
        assert not errors, where
    for line in lines:
        assert (line.startswith(("mrnea: error:", "mrnea: warning:", "simulating",
                                 "identifying"))
                or line == COMPILE_NOTICE), where


def _files(draw) -> dict[str, str]:
    return {name: draw(mutated(text)) for name, text in BASES.items()}


@settings(max_examples=150, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_fuzz_cli_fast(data) -> None:
    """``info`` and ``check`` (they write nothing): 150 examples, a few seconds."""
    _check(data.draw(argv(("info", "check"))), _files(data.draw))


@pytest.mark.slow
@settings(max_examples=150, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_fuzz_cli_slow(data) -> None:
    """Every command, writing included: 150 examples, about two minutes."""
    _check(data.draw(argv(tuple(main.commands))), _files(data.draw))
