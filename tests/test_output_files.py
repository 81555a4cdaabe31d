"""Output files: every file mrnea writes is created exclusively, never through a link, never over
a file it was not allowed to replace, whole or not at all; a run owns its output folder.

The writer (:mod:`mrnea.io.writer`) is tested directly, then every output of the command line
is tested the way a hostile user would attack it: a symbolic link planted at each output name
(with and without ``--force``: the link's target must stay untouched), a dangling link, the
user's own files, a directory at a file's place, two runs into one folder at the same time. The
command runs as a subprocess (``python -m mrnea``), as a user runs it.
"""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.errors import OutputError
from mrnea.io.writer import LOCK_NAME, check_new, create, own_folder

FIGURES = ("motion", "efforts", "reactions", "tracking")
OUTPUTS = ("cycles.csv", "summary.json", "report.html", *(f"{f}.png" for f in FIGURES))
SHORT = ('[program]\nrobot = "sdt"\ndt = 0.01\n[path]\nprofile = "quintic"\n'
         "waypoints = [[0, 0, 0, 0], [0.1, 0.1, 0.1, 0.1]]\n"
         "velocity_limit = 1\nacceleration_limit = 1\n")
# about 100 s of motion at 1 ms: a run long enough to be caught in the act
LONG = ('[program]\nrobot = "sdt"\ndt = 0.001\n[path]\nprofile = "quintic"\n'
        "waypoints = [[0, 0, 0, 0], [0.5, 0.15, 0.15, 0.15]]\n"
        "velocity_limit = 0.01\nacceleration_limit = 0.01\n")
VICTIM = "the user's precious data\n"


def leftovers(folder: Path) -> list[str]:
    """Names in ``folder`` that look like temporary or lock files."""
    return sorted(p.name for p in folder.iterdir()
                  if p.name.startswith(".") or p.name.endswith((".tmp", ".partial")))


@pytest.fixture
def victim(tmp_path: Path) -> Path:
    v = tmp_path / "victim.txt"
    v.write_text(VICTIM)
    return v


@pytest.fixture
def short(tmp_path: Path) -> Path:
    p = tmp_path / "short.toml"
    p.write_text(SHORT)
    return p


# --- the writer ----------------------------------------------------------------------------------
def test_create_writes_a_new_file_whole_with_the_umask_mode(tmp_path: Path) -> None:
    umask = os.umask(0o027)
    try:
        with create(tmp_path / "a.txt") as fh:
            fh.write("héllo\r\n")
            assert not (tmp_path / "a.txt").exists()  # not there until the block ends
        with create(tmp_path / "b.bin", binary=True) as fh:
            fh.write(b"\x00\x01")
    finally:
        os.umask(umask)
    assert (tmp_path / "a.txt").read_bytes() == "héllo\r\n".encode()
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"
    for name in ("a.txt", "b.bin"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~0o027
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.bin"]


def test_an_existing_file_is_replaced_only_when_allowed(tmp_path: Path) -> None:
    p = tmp_path / "out.csv"
    p.write_text(VICTIM)
    with pytest.raises(OutputError, match="exists"), create(p) as fh:
        fh.write("new")
    assert p.read_text() == VICTIM
    with create(p, overwrite=True) as fh:
        fh.write("new")
    assert p.read_text() == "new"
    assert [q.name for q in tmp_path.iterdir()] == ["out.csv"]


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_link_is_never_followed(tmp_path: Path, victim: Path, overwrite: bool) -> None:
    link = tmp_path / "out.json"
    link.symlink_to(victim)
    if overwrite:
        with create(link, overwrite=True) as fh:
            fh.write("{}")
        assert not link.is_symlink() and link.read_text() == "{}"  # the link itself replaced
    else:
        with pytest.raises(OutputError, match="symbolic link"):
            check_new([link])
        with pytest.raises(OutputError, match="symbolic link"), create(link) as fh:
            fh.write("{}")
        assert link.is_symlink()
    assert victim.read_text() == VICTIM
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_dangling_link_counts_as_existing(tmp_path: Path, overwrite: bool) -> None:
    target = tmp_path / "not-yet.txt"
    link = tmp_path / "out.html"
    link.symlink_to(target)
    if overwrite:
        with create(link, overwrite=True) as fh:
            fh.write("<html>")
        assert not link.is_symlink() and link.read_text() == "<html>"
    else:
        with pytest.raises(OutputError, match="exists"), create(link) as fh:
            fh.write("<html>")
        assert link.is_symlink()
    assert not target.exists()  # never created through the link


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_directory_in_a_files_place_is_an_error(tmp_path: Path, overwrite: bool) -> None:
    d = tmp_path / "summary.json"
    d.mkdir()
    (d / "keep").write_text("x")
    with pytest.raises(OutputError, match="is a directory"):
        check_new([d], overwrite)
    with pytest.raises(OutputError, match="is a directory"), create(d, overwrite) as fh:
        fh.write("{}")
    assert (d / "keep").read_text() == "x"
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("exc", [RuntimeError, KeyboardInterrupt])
def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path: Path,
                                                             exc: type) -> None:
    p = tmp_path / "report.html"
    p.write_text(VICTIM)
    with pytest.raises(exc), create(p, overwrite=True) as fh:
        fh.write("half a report")
        raise exc
    assert p.read_text() == VICTIM
    assert [q.name for q in tmp_path.iterdir()] == ["report.html"]


def test_a_file_that_appears_during_the_write_is_not_replaced(tmp_path: Path) -> None:
    """The check before the write is not the only one: publishing refuses too (a hard link,
    which fails if anything is at the destination)."""
    p = tmp_path / "cycles.csv"
    with pytest.raises(OutputError, match="exists"), create(p) as fh:
        fh.write("ours")
        p.write_text(VICTIM)  # another process, between our check and our rename
    assert p.read_text() == VICTIM
    assert [q.name for q in tmp_path.iterdir()] == ["cycles.csv"]


def test_a_missing_folder_is_an_output_error(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match="cannot write"), create(tmp_path / "no" / "x.csv"):
        pass


def test_a_folder_has_one_owner_and_a_stale_lock_does_not_block(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with own_folder(out):
        assert (out / LOCK_NAME).is_file()
        with pytest.raises(OutputError, match="another mrnea run"), own_folder(out):
            pass
    assert list(out.iterdir()) == []  # the lock file is removed at the end
    (out / LOCK_NAME).write_text("")  # left behind by a killed run: nobody holds it
    with own_folder(out):
        pass
    assert list(out.iterdir()) == []


def test_a_failed_run_leaves_no_empty_folder_it_created(tmp_path: Path) -> None:
    new, kept, existing = tmp_path / "a" / "new", tmp_path / "kept", tmp_path / "existing"
    existing.mkdir()
    for folder, write in ((new, False), (kept, True), (existing, False)):
        with pytest.raises(OutputError, match="bad program"), own_folder(folder):
            if write:
                (folder / "cycles.csv").write_text("t\n")
            raise OutputError("bad program")
    assert not new.exists() and (tmp_path / "a").is_dir()  # only the folder it made itself
    assert [q.name for q in kept.iterdir()] == ["cycles.csv"]  # a partial result stays
    assert existing.is_dir() and list(existing.iterdir()) == []


def test_cli_error_after_the_folder_leaves_none(tmp_path: Path) -> None:
    prog = tmp_path / "still.toml"
    prog.write_text('[program]\nrobot = "puma560"\ndt = 0.01\n[path]\nprofile = "trapezoidal"\n'
                    "waypoints = [[0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0]]\n"
                    "velocity_limit = 1\nacceleration_limit = 1\ndwell = 1.0\n")
    res = subprocess.run([sys.executable, "-m", "mrnea", "retime", str(prog), "--out",
                          str(tmp_path / "out")], capture_output=True, text=True, timeout=300)
    assert res.returncode == 2 and "never moves" in res.stderr, res.stderr
    assert not (tmp_path / "out").exists()


def test_a_planted_lock_link_or_a_file_in_the_folders_place_is_refused(tmp_path: Path,
                                                                       victim: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(victim)
    with pytest.raises(OutputError, match="cannot lock"), own_folder(out):
        pass
    assert victim.read_text() == VICTIM
    with pytest.raises(OutputError, match="not a folder"), own_folder(victim):
        pass


# --- the command line ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", OUTPUTS)
def test_cli_refuses_a_link_at_an_output_name(tmp_path: Path, victim: Path, short: Path,
                                              name: str) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / name).symlink_to(victim)
    one_error_line(mrnea_cli("simulate", "sdt", short, "--out", out, "--quiet"), name, "exists")
    assert victim.read_text() == VICTIM and (out / name).is_symlink()
    assert sorted(p.name for p in out.iterdir()) == [name]


@pytest.mark.parametrize("name", ["cycles.csv", "report.html"])
def test_cli_refuses_a_dangling_link_and_the_users_files(tmp_path: Path, short: Path,
                                                         name: str) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / name).symlink_to(tmp_path / "nothing-here")
    one_error_line(mrnea_cli("simulate", "sdt", short, "--out", out), name)
    assert not (tmp_path / "nothing-here").exists()
    (out / name).unlink()
    (out / name).write_text(VICTIM)
    one_error_line(mrnea_cli("simulate", "sdt", short, "--out", out), name, "--force")
    assert (out / name).read_text() == VICTIM


def test_cli_force_replaces_links_never_their_targets(tmp_path: Path, victim: Path,
                                                      short: Path) -> None:
    """A link at every output name, and at the old streamed table's predictable name
    ``cycles.csv.partial``: with --force each output replaces its link, no target changes."""
    out = tmp_path / "out"
    out.mkdir()
    for name in OUTPUTS:
        (out / name).symlink_to(victim)
    (out / "cycles.csv.partial").symlink_to(victim)
    res = mrnea_cli("simulate", "sdt", short, "--out", out, "--force", "--quiet")
    assert res.returncode == 1, res.stderr  # SHORT is NOT ACHIEVABLE (planetary): files written
    assert victim.read_text() == VICTIM
    for name in OUTPUTS:
        assert not (out / name).is_symlink() and (out / name).stat().st_size > 0, name
    assert (out / "cycles.csv").read_text().startswith("t [s],")
    assert (out / "cycles.csv.partial").is_symlink()  # not ours: left alone
    (out / "cycles.csv.partial").unlink()
    assert leftovers(out) == []


@pytest.mark.parametrize("force", [[], ["--force"]])
def test_cli_a_directory_at_an_output_name_is_one_error(tmp_path: Path, short: Path,
                                                        force: list[str]) -> None:
    out = tmp_path / "out"
    (out / "summary.json").mkdir(parents=True)
    one_error_line(mrnea_cli("simulate", "sdt", short, "--out", out, *force), "summary.json",
                   "is a directory")
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]


def test_cli_out_naming_a_file_is_one_error(tmp_path: Path, victim: Path, short: Path) -> None:
    res = mrnea_cli("simulate", "sdt", short, "--out", victim)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert victim.read_text() == VICTIM


def test_demo_refuses_a_link_at_fig3(tmp_path: Path, victim: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "fig3.png").symlink_to(victim)
    one_error_line(mrnea_cli("demo", "--out", out), "fig3.png")
    assert victim.read_text() == VICTIM


def _start(*args: str | Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "mrnea", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_table(proc: subprocess.Popen, out: Path, rows: int = 1) -> None:
    """Until the run streams at least ``rows`` rows into its private temporary table."""
    deadline = time.monotonic() + 300  # the first run in a tree may compile the kernels
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        for p in out.glob(".cycles.csv.*.tmp"):
            with open(p, "rb") as fh:
                if fh.read().count(b"\n") > rows:
                    return
        time.sleep(0.05)
    proc.kill()
    raise AssertionError("the run did not start streaming its table")


def test_cli_two_runs_into_one_folder(tmp_path: Path) -> None:
    """While a run writes into a folder, a second run into it refuses with one line naming the
    folder, and changes nothing there."""
    long = tmp_path / "long.toml"
    long.write_text(LONG)
    out = tmp_path / "out"
    first = _start("simulate", "sdt", long, "--out", out, "--quiet")
    try:
        wait_for_table(first, out)
        before = sorted(p.name for p in out.iterdir())
        second = mrnea_cli("simulate", "sdt", long, "--out", out, "--quiet", "--force")
        one_error_line(second, str(out), "another mrnea run")
        assert sorted(p.name for p in out.iterdir()) == before
    finally:
        first.send_signal(signal.SIGINT)  # no need to wait for the whole run
        _, err = first.communicate(timeout=300)
    assert first.returncode == 130, err
    assert (out / "summary.json").is_file() and leftovers(out) == []


def test_cli_a_killed_runs_lock_does_not_block_the_next(tmp_path: Path, short: Path) -> None:
    long = tmp_path / "long.toml"
    long.write_text(LONG)
    out = tmp_path / "out"
    first = _start("simulate", "sdt", long, "--out", out, "--quiet")
    wait_for_table(first, out)
    first.kill()  # SIGKILL: no clean-up at all
    first.communicate(timeout=60)
    assert (out / LOCK_NAME).exists()
    res = mrnea_cli("simulate", "sdt", short, "--out", out, "--quiet")
    assert res.returncode == 1, res.stderr  # SHORT is NOT ACHIEVABLE: a verdict, files written
    assert (out / "summary.json").is_file() and not (out / LOCK_NAME).exists()


# --- fig3 ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("out", ["fig.xyz", "fig3.png.bak", "fig.pgf"])
def test_fig3_unsupported_suffix_is_one_error(tmp_path: Path, out: str) -> None:
    line = one_error_line(mrnea_cli("fig3", "--out", tmp_path / out), "unsupported figure format")
    assert ".png" in line
    assert list(tmp_path.iterdir()) == []


def test_fig3_without_suffix_never_replaces_the_png(tmp_path: Path) -> None:
    (tmp_path / "fig.png").write_text(VICTIM)
    one_error_line(mrnea_cli("fig3", "--out", tmp_path / "fig"), "fig.png", "exists")
    assert (tmp_path / "fig.png").read_text() == VICTIM
    (tmp_path / "figs").mkdir()
    one_error_line(mrnea_cli("fig3", "--out", tmp_path / "figs"), "is a directory")
    assert list((tmp_path / "figs").iterdir()) == []


def test_fig3_links(tmp_path: Path, victim: Path) -> None:
    """A dangling link is refused without --force (its target is not created); a link is
    replaced itself with --force, its target untouched."""
    dangling = tmp_path / "d.png"
    dangling.symlink_to(tmp_path / "created-through-the-link.png")
    one_error_line(mrnea_cli("fig3", "--out", dangling), "d.png")
    assert not (tmp_path / "created-through-the-link.png").exists()
    link = tmp_path / "f.png"
    link.symlink_to(victim)
    one_error_line(mrnea_cli("fig3", "--out", link), "f.png")
    res = mrnea_cli("fig3", "--out", link, "--force")
    assert res.returncode == 0, res.stderr
    assert victim.read_text() == VICTIM
    assert not link.is_symlink() and link.read_bytes()[:4] == b"\x89PNG"
    assert leftovers(tmp_path) == []
