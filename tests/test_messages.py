"""Error messages quote at most the offending value, shortened, and list at most ten things.

:func:`mrnea.errors.quote` (a value's repr, at most 60 characters) and
:func:`mrnea.errors.listing` (the first ten names, then "and N more") are the two helpers every
reader uses; here they are checked on their own, then through the readers with values a
megabyte long, and on the command line, where an error is always exactly one line.
"""

from __future__ import annotations

import functools
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli

from mrnea.errors import LIST_LIMIT, QUOTE_LIMIT, MrneaError, listing, quote
from mrnea.io import from_csv, load_urdf, loads_native, loads_program

mrnea = functools.partial(mrnea_cli, timeout=120)  # [s]: the hang guard

MALFORMED = Path(__file__).resolve().parent / "malformed"
BIG = "x" * 1_000_000


@pytest.mark.parametrize("value", [
    BIG, BIG.encode(), list(range(100_000)), {f"k{i}": i for i in range(10_000)},
    np.zeros((1000, 1000)), [[[[[[[[1]]]]]]]], 1e300, 10**1000, 1 + 2j, None, object(),
])
def test_quote_is_short_whatever_the_value(value: object) -> None:
    text = quote(value)
    assert 0 < len(text) <= QUOTE_LIMIT


def test_quote_keeps_short_values_whole() -> None:
    assert quote("abc") == "'abc'"
    assert quote(1.5) == "1.5"
    assert quote([1, 2]) == "[1, 2]"
    assert quote(BIG).endswith("...'") and quote(BIG).startswith("'xxx")


def test_listing_names_ten_then_counts() -> None:
    names = [f"link_{k}" for k in range(20_000)]
    text = listing(names)
    assert text.startswith("link_0, link_1, ") and text.endswith("link_9 and 19990 more")
    assert text.count(",") == LIST_LIMIT - 1
    assert listing(["a", "b"]) == "a, b"
    assert len(listing([BIG] * 3)) < 3 * (QUOTE_LIMIT + 2)


# --- through the readers ----------------------------------------------------------------------
def _short(call) -> str:
    with pytest.raises(MrneaError) as info:
        call()
    message = str(info.value)
    assert len(message) < 600, f"{len(message)} characters: {message[:200]}..."
    return message


def test_native_toml_messages_quote_briefly() -> None:
    ref = (MALFORMED / "reference_arm.toml").read_text()
    _short(lambda: loads_native(f'[robot]\nname = "ok"\ngravity = "{BIG}"\n'))
    _short(lambda: loads_native(ref.replace("mass = 2.0", f'mass = "{BIG}"', 1)))
    _short(lambda: loads_native(ref.replace('name = "shoulder"', f'name = "{BIG}"', 1)
                                .replace("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 0.0, 0.0]", 1)))
    msg = _short(lambda: loads_native(f"[robot]\n{BIG} = 1\n"))
    assert "unknown key 'xxx" in msg


def test_program_messages_quote_briefly() -> None:
    base = ('[program]\nrobot = "sdt"\ndt = 0.01\nmode = "{mode}"\n[path]\nprofile = "quintic"\n'
            "waypoints = [[0, 0, 0, 0], [1, 0, 0, 0]]\nvelocity_limit = 1\n"
            "acceleration_limit = 1\n")
    _short(lambda: loads_program(base.format(mode=BIG)))
    _short(lambda: loads_program(base.format(mode="hybrid").replace('"sdt"', f'"{BIG}"')))
    _short(lambda: loads_program(base.format(mode="hybrid").replace(
        "velocity_limit = 1", f"velocity_limit = [{', '.join(['1'] * 100_000)}]")))


def test_csv_messages_quote_briefly(tmp_path: Path) -> None:
    p = tmp_path / "path.csv"
    p.write_text(f"t,q1\n0,0\n1,{BIG}\n")
    _short(lambda: from_csv(p, 0.1))  # the csv module refuses a field over 128 kB
    p.write_text(f"t,q1\n0,0\n1,{BIG[:100_000]}\n")
    assert "'xxx" in _short(lambda: from_csv(p, 0.1))
    p.write_text(f"t,{BIG}\n0,0\n1,abc\n")
    _short(lambda: from_csv(p, 0.1))
    p.write_text(f"{BIG}\n0\n1\n")
    assert "xxx" not in _short(lambda: from_csv(p, 0.1))  # the header line is not quoted


def test_urdf_messages_quote_briefly(tmp_path: Path) -> None:
    ref = (MALFORMED / "reference_arm.urdf").read_text()
    p = tmp_path / "arm.urdf"
    cases = [ref.replace('<mass value="2.0"/>', f'<mass value="{" 1" * 500_000}"/>', 1),
             ref.replace('<mass value="2.0"/>', f'<mass value="{BIG}"/>', 1),
             ref.replace('type="revolute"', f'type="{BIG}"', 1),
             ref.replace("</robot>", f'<link name="{BIG}"/><link name="{BIG}"/></robot>')]
    for text in cases:
        p.write_text(text)
        _short(lambda: load_urdf(p))


# --- the command line -----------------------------------------------------------------------------
def test_cli_error_is_one_bounded_line_even_for_a_file_name_with_a_newline(tmp_path: Path) -> None:
    weird = tmp_path / "two\nlines.toml"
    shutil.copy(MALFORMED / "reference_arm.toml", weird)
    with open(weird, "a") as fh:
        fh.write("[[joint]]\nname = 1\n")
    res = mrnea("info", weird)
    assert res.returncode == 2
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error:"), res.stderr
    assert "two\\nlines.toml" in lines[0]


def test_cli_error_with_a_huge_argument_is_bounded(tmp_path: Path) -> None:
    res = mrnea("info", "y" * 100_000 + ".toml")
    assert res.returncode == 2
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error:") and len(lines[0]) < 1100
