"""Hostile output locations (session 43): a file the run does not write is never deleted, a
file at an old file's aside name is never replaced, an output folder below a dangling link is
named as such."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.errors import OutputError
from mrnea.io.writer import all_or_none

PICK = str(Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml")


def test_retime_leaves_a_payload_file_it_does_not_write(tmp_path: Path) -> None:
    """Without a payload (or with a point mass) retime writes no payload.toml; it had moved
    the one in --out aside and deleted it, without --force."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "payload.toml").write_text("mass = 1.0\n")
    res = mrnea_cli("retime", PICK, "--out", out, "--no-3d", "--quiet", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert (out / "payload.toml").read_text() == "mass = 1.0\n"
    assert sorted(p.name for p in out.iterdir()) == [
        "payload.toml", "report.html", "retimed.csv", "retimed.toml", "summary.json"]


def test_force_never_replaces_a_file_at_the_aside_name(tmp_path: Path) -> None:
    """``.report.html.mrnea-old`` (a killed run's old report, or a user's file) was replaced by
    the report moved aside and deleted; now one error line, before any work, nothing changed."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "report.html").write_text("mine")
    (out / ".report.html.mrnea-old").write_text("precious")
    res = mrnea_cli("simulate", PICK, "--out", out, "--no-3d", "--force", cwd=tmp_path)
    one_error_line(res, ".report.html.mrnea-old")
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        "report.html": "mine", ".report.html.mrnea-old": "precious"}


@pytest.mark.parametrize("aside", ["directory", "unmovable"])
def test_all_or_none_never_replaces_a_file_it_cannot_put_back(tmp_path: Path,
                                                              aside: str) -> None:
    """A file that cannot be moved aside (a directory at the aside name; a name too long for
    the aside's) was replaced anyway, and lost if the block then failed: an OutputError, the
    files already moved put back."""
    a, b = tmp_path / "a.csv", tmp_path / ("b" * 250 if aside == "unmovable" else "b.csv")
    a.write_text("old a")
    b.write_text("old b")
    if aside == "directory":
        (tmp_path / ".b.csv.mrnea-old").mkdir()
    with pytest.raises(OutputError, match=r"mrnea-old exists|cannot move it aside"):
        with all_or_none([a, b], overwrite=True):
            raise AssertionError("the block must not run")
    assert a.read_text() == "old a" and b.read_text() == "old b"
    assert not (tmp_path / ".a.csv.mrnea-old").exists()


def test_out_below_a_dangling_link_names_the_link(tmp_path: Path) -> None:
    """``--out LINK/sub`` with LINK dangling said ``LINK/sub exists and is not a folder``."""
    os.symlink(tmp_path / "nowhere", tmp_path / "gone")
    res = mrnea_cli("simulate", PICK, "--out", "gone/sub/x", "--no-3d", cwd=tmp_path)
    line = one_error_line(res, "gone/sub/x", "gone is a dangling symbolic link")
    assert "exists" not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["gone"]
