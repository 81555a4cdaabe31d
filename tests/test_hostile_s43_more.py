"""Hostile inputs (session 43, leftovers): a log's line ends, a NUL in a pose move's CSV, a
figure file named by a folder's path.

* Logs: only LF, CRLF and a lone CR end a line (:func:`mrnea.io.source.line_blocks`, as path
  CSVs): a lone-CR log (an old Mac file) was one row, refused as "row 1: not valid CSV"; a form
  feed, U+2028... inside a row neither splits it nor shifts the rows' numbers.
* ``[[move]] type = "poses"`` with a TOML ``"\\u0000"`` in ``csv``: the error named the argument
  ``path``, not the program file (as ``[path] csv`` before).
* ``figure_file`` / ``save_figure`` given ``"newdir/"``, ``"x/."``, ``"x/.."`` wrote
  ``newdir.png`` (pathlib drops the trailing slash): one OutputError naming the argument; the
  ``fig3`` command says it of ``--out`` (tests/test_hostile_s43_writes.py).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import mrnea
from mrnea.errors import LogFileError, OutputError, ProgramFileError
from mrnea.identify import read_log
from mrnea.identify.log import log_columns
from mrnea.report.drawing import figure_file, new_figure, save_figure


# --- a log's line ends --------------------------------------------------------------------------
def _log_lines(robot, K=40):
    rng = np.random.default_rng(7)
    rows = np.column_stack([np.arange(K) * 0.01, rng.normal(size=(K, 2 * robot.n))])
    return rows, [",".join(log_columns(robot))] + [",".join(map(repr, r.tolist())) for r in rows]


@pytest.mark.parametrize("end", ["\r", "\r\n", "\n"])
def test_a_log_whose_lines_end_in_a_lone_cr_reads_as_any_other(tmp_path: Path, end: str):
    robot = mrnea.robots.puma560()
    rows, lines = _log_lines(robot)
    p = tmp_path / "log.csv"
    p.write_bytes(end.join(lines).encode() + end.encode())
    log = read_log(p, robot)
    assert np.array_equal(log.time, rows[:, 0]) and np.array_equal(log.q, rows[:, 1:7])
    assert np.array_equal(log.tau, rows[:, 7:])


def test_a_bad_cell_in_a_lone_cr_log_names_its_row(tmp_path: Path):
    robot = mrnea.robots.puma560()
    _, lines = _log_lines(robot)
    lines[11] = lines[11].replace(",", ",x", 1)  # row 12: the header is row 1
    p = tmp_path / "cr.csv"
    p.write_bytes("\r".join(lines).encode() + b"\r")
    with pytest.raises(LogFileError, match=r"cr\.csv: row 12: column 'joint1': not a number"):
        read_log(p, robot)


@pytest.mark.parametrize("char", ["\x0c", "\x0b", "\x1c", "\x85", "\u2028"])
def test_a_line_end_of_str_splitlines_in_a_row_neither_splits_it_nor_shifts_rows(
        tmp_path: Path, char: str):
    """A form feed, vertical tab, U+001C, U+0085 or U+2028 ends no line: a row holding one (in a
    column the log does not use) is one row, and the rows' numbers are the file's lines."""
    robot = mrnea.robots.puma560()
    rows, lines = _log_lines(robot)
    lines = [lines[0] + ",note"] + [line + ",ok" for line in lines[1:]]
    lines[1] = lines[1].replace(",ok", f",a{char}b")  # row 2
    p = tmp_path / "ff.csv"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    log = read_log(p, robot)
    assert log.K == 40 and np.array_equal(log.tau, rows[:, 7:])
    lines[5] = lines[5].replace(",", ",y", 1)  # row 6
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(LogFileError, match=r"ff\.csv: row 6: column 'joint1': not a number"):
        read_log(p, robot)


# --- a NUL in a pose move's csv -----------------------------------------------------------------
def test_a_nul_in_a_pose_moves_csv_names_the_program_file(tmp_path: Path):
    f = tmp_path / "prog.toml"
    f.write_text('[program]\nrobot = "puma560"\ndt = 0.01\nq0 = [0, 0, 0, 0, 0, 0]\n'
                 '[[move]]\ntype = "poses"\ncsv = "p.csv\\u0000x"\n')
    with pytest.raises(ProgramFileError) as err:
        mrnea.load_program(f)
    message = str(err.value)
    assert message.startswith(f"{f}: [[move]] 1 (poses): 'csv' cannot hold a NUL character"), \
        message
    assert message.endswith("got 'p.csv\\x00x'") and "PosixPath" not in message, message


# --- a figure file named by a folder's path -----------------------------------------------------
@pytest.mark.parametrize("name", ["newdir/", "newdir/.", "newdir/..", "fig.png/", ".", ""])
def test_a_figure_file_named_by_a_folder_is_refused(monkeypatch, tmp_path: Path, name: str):
    monkeypatch.chdir(tmp_path)
    said = rf"^path: '{re.escape(name)}' names a folder; name the figure file to write"
    with pytest.raises(OutputError, match=said):
        figure_file(name)
    with pytest.raises(OutputError, match=said):
        save_figure(new_figure(1, 1), name)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "newdir").mkdir()  # an existing folder: the same
    with pytest.raises(OutputError, match=said):
        save_figure(new_figure(1, 1), name)
    assert [p.name for p in tmp_path.iterdir()] == ["newdir"]
    assert list((tmp_path / "newdir").iterdir()) == []


def test_a_figure_file_name_still_reads(tmp_path: Path):
    assert figure_file(str(tmp_path / "fig")) == (tmp_path / "fig.png", "png")
    assert figure_file(tmp_path / "a" / "fig.svg") == (tmp_path / "a" / "fig.svg", "svg")
    assert save_figure(new_figure(1, 1), f"{tmp_path}/f").read_bytes()[:4] == b"\x89PNG"
