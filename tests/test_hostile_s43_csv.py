"""Hostile program inputs (session 43): path CSVs read through ``mrnea check`` and the library.

* Line ends: only LF, CRLF and a lone CR end a line (``str.splitlines`` also split at a form
  feed, a vertical tab, U+001C..U+001E, U+0085, U+2028, U+2029: a comment's rest became a row,
  a row holding one was read as two, later line numbers were off).
* Rows spanning less than CYCLE_TOL of a cycle: a path of one cycle, refused later without the
  file's name.
* A cell over the csv module's field limit: the error names the line.
* Memory and time of reading: no list of every line (16 bytes per byte of a short-rowed file,
  over the reading's budget of 9), comment lines and lone-CR line ends on the fast path.
"""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.errors import ProgramFileError
from mrnea.io import from_csv
from mrnea.io.pathcsv import _plain_rows, read_table

HEADER = "t,a,b,c,d,e,f\n"
ZEROS = ",0,0,0,0,0,0\n"


def test_a_form_feed_in_a_comment_does_not_start_a_row(tmp_path):
    p = tmp_path / "ff.csv"
    p.write_text("# page one\x0cpage two\n" + HEADER + "0" + ZEROS + "0.5" + ZEROS + "1" + ZEROS)
    header, rows = read_table(p, None)
    assert header.line == 2 and rows.shape == (3, 7)


def test_line_numbers_count_only_real_line_ends(tmp_path):
    p = tmp_path / "ffline.csv"
    p.write_text("# note\x0c\n" + HEADER + "0" + ZEROS + "0.5" + ZEROS + "1,0,0,0,0,x,0\n")
    one_error_line(mrnea_cli("check", "puma560", p, "--dt", "0.01", timeout=120),
                   "ffline.csv: line 5 (data row 3), column 6", "'x'")


@pytest.mark.parametrize("char", ["\x0b", "\x0c", "\x1c", "\x85", "\u2028"])
def test_a_row_holding_a_line_separator_is_refused(tmp_path, char):
    """Was read as two rows: here two good ones, a path the file does not hold."""
    p = tmp_path / "sep.csv"
    p.write_text(HEADER + "0" + ZEROS + "0.5" + ZEROS[:-1] + char + "1,0.1,0,0,0,0,0\n",
                 encoding="utf-8")
    with pytest.raises(ProgramFileError, match=r"sep\.csv: line 3 \(data row 2\): expected 7 "
                                               r"columns .*, got 13"):
        read_table(p, None)


def test_rows_closer_than_a_cycle_tolerance_make_two_cycles(tmp_path):
    p = tmp_path / "tiny.csv"
    p.write_text(HEADER + "0" + ZEROS + "1e-12,0.1,0,0,0,0,0\n")
    t, q = from_csv(p, 0.01)
    assert t.tolist() == [0.0, 0.01] and q[-1, 0] == 0.1
    res = mrnea_cli("check", "puma560", p, "--dt", "0.01", "--interpolation", "linear",
                    timeout=120)
    assert res.returncode in (0, 1) and "Traceback" not in res.stderr, res.stderr


def test_a_cell_over_the_csv_field_limit_names_the_line(tmp_path):
    p = tmp_path / "long.csv"
    p.write_text(HEADER + "0," + "1" * 200_000 + ",0,0,0,0,0\n1" + ZEROS)
    with pytest.raises(ProgramFileError, match=r"long\.csv: line 2: not valid CSV: field larger"):
        read_table(p, None)


@pytest.mark.parametrize("text", [
    HEADER + "# units: rad\n0" + ZEROS + "0.5" + ZEROS,
    (HEADER + "0" + ZEROS + "0.5" + ZEROS).replace("\n", "\r"),
])
def test_comments_and_lone_cr_stay_on_the_fast_path(text):
    """Row by row, a million rows took 18 s instead of 6."""
    rows = _plain_rows(text, 1, ",", 7)
    assert rows is not None and rows[:, 0].tolist() == [0.0, 0.5]


def test_short_rows_are_read_within_the_memory_budget(tmp_path):
    """9 bytes per byte of the file (docs/design.md); a list of every line took 16 (the lines
    are split a block at a time: 1 MiB of them costs about 7 MB, hence a file of 4 MB)."""
    p = tmp_path / "short.csv"
    n = 600_000
    p.write_text("t,a\n" + "".join(f"{i},0\n" for i in range(n)))
    size = p.stat().st_size
    tracemalloc.start()
    try:
        _, rows = read_table(p, None)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert rows.shape == (n, 2) and np.array_equal(rows[:, 0], np.arange(n))
    assert peak <= 9 * size, peak / size


def test_a_file_of_blank_lines_is_read_once(tmp_path):
    """After the header, only blank lines: the fast path says so (the rows were read twice)."""
    text = HEADER + "\n" * 1000 + "0" + ZEROS
    assert _plain_rows(text, 1, ",", 7).shape == (1, 7)
    p = tmp_path / "blank.csv"
    p.write_text(text)
    with pytest.raises(ProgramFileError, match=r"blank\.csv: 1 data row\(s\) after the header"):
        read_table(p, None)


def test_a_nul_in_a_programs_csv_names_the_program_file(tmp_path):
    """A TOML ``\\u0000`` in [path] csv: the error named only the argument ``path`` and a
    ``PosixPath(...)`` repr, not the program file."""
    f = tmp_path / "prog.toml"
    f.write_text('[program]\nname = "x"\nrobot = "puma560"\ndt = 0.01\n[path]\n'
                 'csv = "a.csv\\u0000x"\n')
    line = one_error_line(mrnea_cli("check", f, timeout=120), "prog.toml: [path]: 'csv'",
                          "NUL character", "'a.csv\\x00x'")
    assert "PosixPath" not in line


def test_a_nul_in_a_path_is_quoted_as_text():
    with pytest.raises(ProgramFileError, match=r"NUL character, got 'a\.csv\\x00x'$"):
        read_table(Path("a.csv\0x"), None)
