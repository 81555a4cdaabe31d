"""One strict number grammar for every number written as text: URDF attributes, CSV cells, the
command line's options (docs/robot-format.md, "Numbers").

Python's ``float()`` (and NumPy's string conversion) accept ``1_0`` (= 10), non-ASCII digits,
surrounding whitespace, ``nan`` and ``Infinity``: none of them is a number here. The accepted
numbers are checked against Python's own ``repr`` of floats (an independent spelling of the same
values), the refused ones against a list of spellings that ``float()`` accepts.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

import mrnea
from mrnea.cli import main
from mrnea.errors import ProgramFileError, RobotFileError
from mrnea.io import from_csv, load_urdf, loads_native
from mrnea.io.source import parse_number

MALFORMED = Path(__file__).resolve().parent / "malformed"

# spellings Python's float() reads as a number, which the grammar refuses
LOOSE = ["1_0", "1_000.5", "\uff11", "\u0661\u0662", "\u0663.\u0665", " 1", "1 ", "\t1", "1\n",
         "\u00a01", "nan", "NaN", "-nan", "Infinity", "-Infinity", "INF", "iNf", "+Infinity",
         "1e1_0", "0_1"]
# not numbers for anyone
GARBAGE = ["", "+", "-", ".", "e5", "1e", "1e+", "0x10", "1,5", "1.0.0", "--1", "1 0", "1kg",
           "\u00bd", "1e5.5", "\u221e", "inf inf", "'1'"]


@pytest.mark.parametrize("text", LOOSE)
def test_what_float_accepts_is_not_a_number_here(text: str) -> None:
    float(text)  # Python reads it...
    with pytest.raises(ValueError):  # ...the grammar does not
        parse_number(text)
    with pytest.raises(ValueError):
        parse_number(text, allow_inf=True)


@pytest.mark.parametrize("text", GARBAGE)
def test_garbage_is_not_a_number(text: str) -> None:
    with pytest.raises(ValueError, match=r"not a number|not a finite number"):
        parse_number(text, allow_inf=True)


@pytest.mark.parametrize(("text", "value"), [
    ("0", 0.0), ("-0", -0.0), ("+1", 1.0), ("1.", 1.0), (".5", 0.5), ("-.5", -0.5),
    ("1e3", 1000.0), ("1E-3", 0.001), ("2.5e+2", 250.0), ("007", 7.0),
    ("1e-400", 0.0),  # below the smallest double: rounds to zero, as any reader does
    ("1.7976931348623157e308", 1.7976931348623157e308),
])
def test_decimal_and_scientific_notation(text: str, value: float) -> None:
    assert parse_number(text) == value
    assert math.copysign(1.0, parse_number(text)) == math.copysign(1.0, value)


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_every_double_reads_back_from_its_shortest_repr(x: float) -> None:
    """Python's repr of a double is in the grammar and reads back to the same double."""
    assert parse_number(repr(x)) == x


@given(st.text(min_size=1, max_size=12))
def test_a_character_outside_the_grammar_is_never_a_number(text: str) -> None:
    if any(c not in "0123456789+-.eE" for c in text) and text not in ("inf", "+inf", "-inf"):
        with pytest.raises(ValueError):
            parse_number(text, allow_inf=True)


def test_infinity_only_where_a_limit_allows_it() -> None:
    assert parse_number("inf", allow_inf=True) == math.inf
    assert parse_number("+inf", allow_inf=True) == math.inf
    assert parse_number("-inf", allow_inf=True) == -math.inf
    for text in ("inf", "-inf"):
        with pytest.raises(ValueError, match="not a finite number"):
            parse_number(text)
    with pytest.raises(ValueError, match="out of range"):
        parse_number("1e999", allow_inf=True)  # a finite spelling that overflows is not inf


# --- the readers ------------------------------------------------------------------------------
def _urdf(tmp_path: Path, old: str, new: str) -> Path:
    text = (MALFORMED / "reference_arm.urdf").read_text()
    assert old in text
    p = tmp_path / "arm.urdf"
    p.write_text(text.replace(old, new, 1))
    return p


def _mass_line() -> str:
    text = (MALFORMED / "reference_arm.urdf").read_text()
    start = text.index("<mass value=")
    return text[start:text.index("/>", start) + 2]


@pytest.mark.parametrize("value", ["1_0", "\uff11", "1.0\u00a0", "Infinity", "nan", "0x1"])
def test_urdf_attributes_are_strict(tmp_path: Path, value: str) -> None:
    p = _urdf(tmp_path, _mass_line(), f'<mass value="{value}"/>')
    with pytest.raises(RobotFileError, match=r"<mass value=.*(not a number|not a finite)"):
        load_urdf(p)


def test_urdf_limits_may_be_inf(tmp_path: Path) -> None:
    text = (MALFORMED / "reference_arm.urdf").read_text()
    start = text.index("<limit ")
    limit = text[start:text.index("/>", start) + 2]
    p = _urdf(tmp_path, limit, '<limit lower="-inf" upper="inf" effort="inf" velocity="+inf"/>')
    robot = load_urdf(p)
    j = robot.joints[robot.joint_names.index(_limited_joint(text, start))]
    assert (j.lower, j.upper, j.effort_limit, j.velocity_limit) == (
        -math.inf, math.inf, math.inf, math.inf)
    p = _urdf(tmp_path, limit, '<limit lower="-1" upper="1" effort="Infinity" velocity="1"/>')
    with pytest.raises(RobotFileError, match="not a finite number"):
        load_urdf(p)


def _limited_joint(text: str, limit_at: int) -> str:
    start = text.rindex("<joint ", 0, limit_at)
    name_at = text.index('name="', start) + 6
    return text[name_at:text.index('"', name_at)]


@pytest.mark.parametrize("cell", ["1_0", "\u0661", "\u00a01", "nan", "inf", "-Infinity", "0x1"])
def test_csv_cells_are_strict(tmp_path: Path, cell: str) -> None:
    p = tmp_path / "path.csv"
    p.write_text(f"t,q1\n0,0\n1,{cell}\n", encoding="utf-8")
    with pytest.raises(ProgramFileError, match=r"line 3 \(data row 2\), column 2"):
        from_csv(p, 0.1)


def test_csv_cells_may_be_padded_with_spaces(tmp_path: Path) -> None:
    p = tmp_path / "path.csv"
    p.write_text("t , q1\n 0 , 0\n1,\t0.5 \n", encoding="utf-8")
    t, q = from_csv(p, 0.5)
    assert q[-1, 0] == 0.5 and t.tolist() == [0.0, 0.5, 1.0]


def test_toml_numbers_given_as_strings_are_refused() -> None:
    text = (MALFORMED / "reference_arm.toml").read_text()
    assert "mass = 2.0" in text
    with pytest.raises(RobotFileError, match="'mass' must be a number, got string '1_0'"):
        loads_native(text.replace("mass = 2.0", 'mass = "1_0"', 1))


@pytest.mark.parametrize("value", ["1_0", "0.01 ", "\u0661", "nan", "inf", "0", "-1", "1e999"])
def test_cli_numbers_are_strict(tmp_path: Path, value: str) -> None:
    shutil.copy(MALFORMED / "reference_arm.toml", tmp_path / "arm.toml")
    (tmp_path / "p.csv").write_text("t,q1,q2\n0,0,0\n1,0.1,0.1\n")
    for args in (["check", str(tmp_path / "arm.toml"), str(tmp_path / "p.csv"), "--dt", value],
                 ["demo", "--dt", value, "--out", str(tmp_path / "o")]):
        res = CliRunner().invoke(main, args)
        lines = res.stderr.strip().splitlines()
        assert res.exit_code == 2, res.output
        assert len(lines) == 1 and lines[0].startswith("mrnea: error:"), res.stderr
        assert "--dt" in lines[0] and "--help" in lines[0], lines[0]
    assert not (tmp_path / "o").exists()


def test_cli_catch_up_is_strict(tmp_path: Path) -> None:
    res = CliRunner().invoke(main, ["check", "sdt", str(tmp_path / "x.toml"), "--catch-up", "1_0"])
    assert res.exit_code == 2 and res.stderr.count("\n") == 1 and "--catch-up" in res.stderr


def test_the_library_loads_a_robot_as_before() -> None:
    """The built-in robots' files (native TOML) and the corpus' reference files still load."""
    assert mrnea.robots.sdt().n == 4 and mrnea.robots.puma560().n == 6
    assert mrnea.load_robot(MALFORMED / "reference_arm.urdf").n > 0
