"""Output folders are never written through a symbolic link: neither a command's default folder
(``./mrnea-demo``, ``./mrnea-out``, ``./mrnea-sweep``) with a link planted at its name, nor an
``--out`` that names a link. Each command runs as a real subprocess in a folder where the links
were planted, as a user (or an attacker sharing the working folder) would leave them.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line
from test_cli import EXAMPLES

from mrnea.errors import OutputError
from mrnea.io.writer import own_folder

SHORT = ('[program]\nrobot = "sdt"\ndt = 0.01\n[path]\nprofile = "quintic"\n'
         "waypoints = [[0, 0, 0, 0], [0.1, 0.1, 0.1, 0.1]]\n"
         "velocity_limit = 1\nacceleration_limit = 1\n")

# each command: its default folder's base name, its arguments, the files it writes
COMMANDS = {
    "demo": ("mrnea-demo", ["demo", "--dt", "0.05", "--no-3d", "--quiet"], "summary.json"),
    "simulate": ("mrnea-out", ["simulate", "short.toml", "--no-3d", "--quiet"], "summary.json"),
    "sweep": ("mrnea-sweep", ["sweep", "puma560", "--grid", "g.toml", "--workers", "1",
                              "--quiet"], "sweep.csv"),
}


def _plant(tmp_path: Path, base: str) -> tuple[Path, Path]:
    """``base`` a link to an empty folder elsewhere, ``base-2`` a dangling link; returns the
    folder and the dangling link's target."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / base).symlink_to(elsewhere)
    missing = tmp_path / "created-through-the-link"
    (tmp_path / f"{base}-2").symlink_to(missing)
    return elsewhere, missing


def _inputs(tmp_path: Path) -> None:
    (tmp_path / "short.toml").write_text(SHORT)
    shutil.copy(EXAMPLES / "puma_pick.toml", tmp_path)
    (tmp_path / "g.toml").write_text('[sweep]\nprograms = ["puma_pick.toml"]\n'
                                     "[grid]\npayload = [0.0]\n")


@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_link_at_a_default_folders_name_is_never_written_through(tmp_path: Path,
                                                                    command: str) -> None:
    """Both planted links count as used names: the run writes into ``base-3``, a real folder;
    the links' targets stay as they were (empty, absent) and the links stay links."""
    base, args, output = COMMANDS[command]
    _inputs(tmp_path)
    elsewhere, missing = _plant(tmp_path, base)
    res = mrnea_cli(*args, cwd=tmp_path)
    assert res.returncode in (0, 1), res.stderr  # a verdict, not an error
    chosen = tmp_path / f"{base}-3"
    assert chosen.is_dir() and not chosen.is_symlink()
    assert (chosen / output).is_file()
    assert list(elsewhere.iterdir()) == [] and not missing.exists()
    assert (tmp_path / base).is_symlink() and (tmp_path / f"{base}-2").is_symlink()


@pytest.mark.parametrize("command", ["demo", "simulate", "sweep", "retime"])
def test_out_naming_a_link_is_one_error(tmp_path: Path, command: str) -> None:
    """``--out LINK`` (to an empty folder) is refused before any work, naming the link; the
    folder it points to stays empty."""
    _inputs(tmp_path)
    elsewhere, _ = _plant(tmp_path, "link")
    args = {"demo": ["demo"], "simulate": ["simulate", "short.toml"],
            "sweep": ["sweep", "puma560", "--grid", "g.toml", "--workers", "1"],
            "retime": ["retime", "short.toml"]}[command]
    res = mrnea_cli(*args, "--out", "link", cwd=tmp_path)
    one_error_line(res, "link", "symbolic link")
    assert list(elsewhere.iterdir()) == []


def test_own_folder_refuses_a_link_before_and_after_creating(tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    """A link at the folder's name, or one planted between the check and ``mkdir`` (the race
    a default folder's choice leaves open), is refused; nothing is written through it."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "a").symlink_to(elsewhere)
    with pytest.raises(OutputError, match="symbolic link"), own_folder(tmp_path / "a"):
        pass
    real_mkdir = Path.mkdir

    def plant_then_mkdir(self: Path, *args: object, **kwargs: object) -> None:
        if self.name == "b":
            self.symlink_to(elsewhere)  # the attacker wins the race
        real_mkdir(self, *args, **kwargs)

    monkeypatch.setattr(Path, "mkdir", plant_then_mkdir)
    with pytest.raises(OutputError, match="symbolic link"), own_folder(tmp_path / "b"):
        pass
    assert list(elsewhere.iterdir()) == []
