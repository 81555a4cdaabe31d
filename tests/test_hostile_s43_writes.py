"""A command's output files, all or none (session 43): ``sweep``, ``excite`` and ``identify``
with ``--force``, stopped (exit 130) or failing (exit 2) between two files, leave the old set as
it was, never new files beside old ones; ``size`` finding no drive removes an earlier run's
chosen drives and sized robot; ``fig3 --out DIR/`` is refused, never ``DIR.png``."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

import mrnea.cli.base as cli_base
from mrnea.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
LOG = str(EXAMPLES / "puma_identify_log.csv")


def _files(folder: Path) -> dict[str, bytes]:
    """Every entry of ``folder`` (hidden ones included: an aside copy, a temporary file)."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _old_set(folder: Path, names: list[str]) -> dict[str, bytes]:
    """An earlier run's files (their content marked old) in ``folder``."""
    folder.mkdir()
    for name in names:
        (folder / name).write_bytes(f"old {name}\n".encode())
    return _files(folder)


def _fail_between_files(monkeypatch, how: str, first: Path, modules: tuple,
                        target: object = None, attr: str = "") -> None:
    """``stop``: a stop request once the new ``first`` file is there (the command's checkpoints
    in ``modules`` and write_files'); ``error``: ``target.attr`` (a later file's writer) raises
    a disk-full OSError."""
    if how == "stop":
        old = first.read_bytes()

        def stop() -> None:
            if first.exists() and first.read_bytes() != old:
                raise KeyboardInterrupt

        for module in (cli_base, *modules):
            monkeypatch.setattr(module, "checkpoint", stop)
    else:
        def full(*args, **kw):
            raise OSError(errno.ENOSPC, "No space left on device")

        monkeypatch.setattr(target, attr, full)


CODE = {"stop": 130, "error": 2}


@pytest.mark.parametrize("how", ["stop", "error"])
def test_sweep_force_puts_the_old_files_back(monkeypatch, tmp_path: Path, how: str) -> None:
    """``sweep --force`` over an earlier run's files, stopped once the new sweep.csv is written
    (or its sweep.html failing): the old three files, as they were, nothing else. It had left
    the new sweep.csv (and sweep.parquet) beside the old sweep.html, exit 130."""
    import mrnea.cli.sweep as cli_sweep
    import mrnea.report.sweep as report_sweep

    shutil.copy(EXAMPLES / "puma_pick.toml", tmp_path)
    (tmp_path / "g.toml").write_text('[sweep]\nprograms = ["puma_pick.toml"]\n'
                                     "[grid]\npayload = [0.0, 15.0]\n")
    out = tmp_path / "o"
    before = _old_set(out, ["sweep.csv", "sweep.parquet", "sweep.html"])
    _fail_between_files(monkeypatch, how, out / "sweep.csv", (cli_sweep,), report_sweep,
                        "write_sweep_html")
    res = CliRunner().invoke(main, ["sweep", "puma560", "--grid", str(tmp_path / "g.toml"),
                                    "--out", str(out), "--workers", "1", "--quiet", "--force"])
    assert res.exit_code == CODE[how], res.output
    assert res.stdout == ""
    assert _files(out) == before


@pytest.mark.parametrize("how", ["stop", "error"])
def test_excite_force_puts_the_old_files_back(monkeypatch, tmp_path: Path, how: str) -> None:
    """``excite --force`` stopped once the new excitation.csv is written (or its program file
    failing): the old files as they were. It had written file by file (a new CSV beside the old
    program and summary), and exited 0 past a stop request."""
    import mrnea.cli.excite as cli_excite
    from mrnea.identify.excite import Excitation

    out = tmp_path / "o"
    before = _old_set(out, ["excitation.csv", "excitation.toml", "summary.json"])
    _fail_between_files(monkeypatch, how, out / "excitation.csv", (cli_excite,), Excitation,
                        "save_program")
    res = CliRunner().invoke(main, ["excite", "puma560", "--out", str(out), "--harmonics", "2",
                                    "--candidates", "2", "--starts", "0", "--dt", "0.02",
                                    "--quiet", "--force"])
    assert res.exit_code == CODE[how], res.output
    assert res.stdout == ""
    assert _files(out) == before


@pytest.mark.parametrize("how", ["stop", "error"])
def test_identify_force_puts_the_old_files_back(monkeypatch, tmp_path: Path, how: str) -> None:
    """``identify --force`` stopped once the new identified_robot.toml is written (or its page
    failing): the old four files as they were. It had left three new files beside the old
    identify.html (error), or all four new ones with exit 130 (stop)."""
    import mrnea.cli.identify as cli_identify
    import mrnea.identify.html as identify_html

    out = tmp_path / "o"
    before = _old_set(out, ["identified_robot.toml", "identified_drives.toml", "summary.json",
                            "identify.html"])
    _fail_between_files(monkeypatch, how, out / "identified_robot.toml", (cli_identify,),
                        identify_html, "identify_html")
    res = CliRunner().invoke(main, ["identify", "puma560", LOG, "--out", str(out), "--quiet",
                                    "--force"])
    assert res.exit_code == CODE[how], res.output
    assert res.stdout == ""
    assert _files(out) == before


def _small_catalogue(tmp_path: Path) -> Path:
    """The sizing case's catalogue with motor A alone: nothing fits joint j1."""
    from test_sizing import CATALOGUE

    small = CATALOGUE.split('[[motor]]\nname = "B"')[0] + CATALOGUE[CATALOGUE.index(
        "[[gearbox]]"):]
    (tmp_path / "small.toml").write_text(small)
    return tmp_path / "small.toml"


@pytest.mark.parametrize("stop", [False, True])
def test_size_force_with_no_fit_leaves_no_stale_drives(monkeypatch, tmp_path: Path,
                                                       stop: bool) -> None:
    """``size --force`` over a run that chose drives, now with a catalogue where nothing fits
    j1: exit 1 and the new set alone (sizing.csv, summary.json, sizing.html); the earlier
    run's chosen_drives.toml and sized_robot.toml had stayed beside it. Stopped after its
    first file: the earlier run's five files, as they were."""
    import json

    from test_sizing import write_cli_case

    write_cli_case(tmp_path)
    monkeypatch.chdir(tmp_path)
    args = ["size", "arm.toml", "swing.toml", "--joints", "j1", "--out", "out", "--quiet"]
    first = CliRunner().invoke(main, [*args, "--catalogue", "cat.toml"])
    assert first.exit_code == 0, first.output
    before = _files(tmp_path / "out")
    assert {"chosen_drives.toml", "sized_robot.toml"} <= set(before), before.keys()
    if stop:
        _fail_between_files(monkeypatch, "stop", tmp_path / "out" / "sizing.csv", ())
    res = CliRunner().invoke(main, [*args, "--catalogue", str(_small_catalogue(tmp_path)),
                                    "--force"])
    if stop:
        assert res.exit_code == 130, res.output
        assert _files(tmp_path / "out") == before
        return
    assert res.exit_code == 1, res.output
    after = _files(tmp_path / "out")
    assert sorted(after) == ["sizing.csv", "sizing.html", "summary.json"]
    assert all(after[name] != before[name] for name in after)  # each one new
    assert not json.loads(after["summary.json"])["fits"]


@pytest.mark.parametrize("out", ["newdir/", "newdir/.", "fig.png/"])
def test_fig3_out_naming_a_folder_is_refused(monkeypatch, tmp_path: Path, out: str) -> None:
    """``fig3 --out newdir/`` wrote ./newdir.png (``fig.png/``: ./fig.png): a name ending in a
    folder's slash is one error line naming --out, before any work, nothing written."""
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(main, ["fig3", "--out", out])
    assert res.exit_code == 2, res.output
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error: "), lines
    assert "'--out'" in lines[0] and f"'{out}' names a folder" in lines[0], lines
    assert res.stdout == "" and list(tmp_path.iterdir()) == []
