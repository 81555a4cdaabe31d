"""The command line speaks command-line only (issue 22): an output that exists is refused with
"add --force", never the library's "pass overwrite=True"; the library keeps its own words."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line
from test_default_folders import SHORT

from mrnea.errors import OutputError
from mrnea.io.writer import check_new, write_file


@pytest.mark.parametrize("command", ["fig3", "simulate"])
def test_a_second_run_is_refused_in_cli_words(tmp_path: Path, command: str) -> None:
    (tmp_path / "short.toml").write_text(SHORT)
    args = (["fig3", "--out", "f.png"] if command == "fig3" else
            ["simulate", "short.toml", "--out", "o", "--no-3d", "--quiet"])
    first = mrnea_cli(*args, cwd=tmp_path)
    assert first.returncode in (0, 1), first.stderr
    line = one_error_line(mrnea_cli(*args, cwd=tmp_path), "exists", "add --force")
    assert "overwrite" not in line and "CLI" not in line


def test_the_library_names_its_argument(tmp_path: Path) -> None:
    path = write_file(tmp_path / "a.txt", "x")
    for call in (lambda: check_new([path]), lambda: write_file(path, "y")):
        with pytest.raises(OutputError) as err:
            call()
        assert "pass overwrite=True" in str(err.value) and "--force" not in str(err.value)
        assert err.value.cli is not None and "add --force" in err.value.cli
