"""The SDT demo's training profile as a program: ``examples/sdt_training.toml`` and the PROGRAM
name ``demo`` give the demo's own commands and verdict, so check -> retime -> sweep work on it.

Oracles: the built-in profile (:func:`mrnea.robots.sdt_profile.training_profile`, itself written
from the phases in docs/sdt.md) for the file's rows, and the README's quoted demo verdict (worked
out by hand in docs/sdt.md) for what the commands print.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.io import load_program
from mrnea.robots.sdt_profile import training_profile

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "sdt_training.toml"


def readme_demo_verdict() -> str:
    """The demo's verdict line as the README quotes it."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return re.search(r"^NOT ACHIEVABLE: cab_yaw needs .*$", text, re.M).group()


def test_the_example_is_the_demo_profile_bit_for_bit():
    prog = load_program(EXAMPLE)
    t, q = training_profile(0.005)
    assert prog.robot == "sdt" and prog.dt == 0.005 and prog.interpolation == "linear"
    assert np.array_equal(prog.t, t) and np.array_equal(prog.q_cmd, q)


@pytest.mark.parametrize("args", [[EXAMPLE], ["sdt", EXAMPLE], ["demo"], ["sdt", "demo"]],
                         ids=["file", "sdt-file", "demo", "sdt-demo"])
def test_check_gives_the_demo_verdict(args):
    res = mrnea_cli("check", *args)
    assert res.returncode == 1, (res.stdout, res.stderr)
    assert res.stdout.splitlines()[0] == readme_demo_verdict()
    program = "demo" if "demo" in args else str(EXAMPLE)
    assert f"Retime it: mrnea retime {'sdt ' if 'sdt' in args else ''}{program} --out" in res.stdout


def test_demo_needs_its_robot_to_be_the_sdt():
    one_error_line(mrnea_cli("check", "puma560", "demo"), "sdt", "puma560")


def test_a_program_that_is_none_of_the_three_names_demo():
    one_error_line(mrnea_cli("check", "sdt", "training"), "demo", ".toml", ".csv")


def test_retime_the_demo_and_check_the_result(tmp_path):
    out = tmp_path / "r"
    res = mrnea_cli("retime", "sdt", "demo", "--out", out, "--no-3d")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("RETIMED (toppra): ")
    assert (out / "retimed.toml").is_file()
    check = mrnea_cli("check", out / "retimed.toml")
    assert check.returncode == 0, (check.stdout, check.stderr)
    assert check.stdout.startswith("ACHIEVABLE: sdt follows the program")
