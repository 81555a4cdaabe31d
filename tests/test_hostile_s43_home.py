"""A ``~user`` that cannot be expanded (no such user) in any path mrnea takes is one error
naming where it was given, never an internal error (``Path.expanduser`` raises RuntimeError);
a sweep's time scale near 1e308 is refused by the memory it would need, never an overflow."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.errors import ProgramFileError, RobotFileError
from mrnea.io import load_program, parse_payload
from mrnea.io.dispatch import resolve_robot

NOUSER = "~no_such_user_mrnea_s43"


def test_a_robot_file_under_an_unknown_home() -> None:
    with pytest.raises(RobotFileError, match="cannot expand '~'"):
        resolve_robot(f"{NOUSER}/r.toml")


def test_the_command_line_says_it_in_one_line(tmp_path: Path) -> None:
    res = mrnea_cli("check", f"{NOUSER}/r.toml", "demo", cwd=tmp_path)
    one_error_line(res, "cannot expand '~'", NOUSER)


def test_a_payload_file_under_an_unknown_home() -> None:
    with pytest.raises(RobotFileError, match="payload: cannot expand '~'"):
        parse_payload(f"{NOUSER}/p.toml")


@pytest.mark.parametrize("text", [
    '[program]\nrobot = "puma560"\ndt = 0.01\n[path]\ncsv = "{u}/x.csv"\n',
    '[program]\nrobot = "puma560"\ndt = 0.01\nactuators = "{u}/a.toml"\n[path]\n'
    'csv = "x.csv"\n',
])
def test_a_programs_file_under_an_unknown_home_names_the_program(tmp_path: Path,
                                                                  text: str) -> None:
    prog = tmp_path / "p.toml"
    prog.write_text(text.format(u=NOUSER))
    with pytest.raises(ProgramFileError, match="cannot expand '~'") as err:
        load_program(prog)
    assert str(prog) in str(err.value)


def test_a_time_scale_near_the_largest_float_is_refused_by_memory(tmp_path: Path) -> None:
    grid = tmp_path / "g.toml"
    grid.write_text('[sweep]\nrobot = "sdt"\nprograms = ["demo"]\n[grid]\n'
                    'time_scale = [1e308]\n')
    res = mrnea_cli("sweep", "--grid", grid, "--out", tmp_path / "o", cwd=tmp_path)
    one_error_line(res, "time_scale", "memory")


def test_a_payload_key_of_the_wrong_type_names_the_file_once(tmp_path: Path) -> None:
    prog = tmp_path / "p.toml"
    prog.write_text('[program]\nrobot = "puma560"\ndt = 0.01\npayload = 5\n[path]\n'
                    'csv = "x.csv"\n')
    with pytest.raises(ProgramFileError) as err:
        load_program(prog)
    assert str(err.value).count(str(prog)) == 1 and "'payload'" in str(err.value)
