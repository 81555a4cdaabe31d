"""Hostile output locations (session 42): a run's files are all written or none, a path with
a newline stays one line, fig3 never makes NAME.png next to a device or pipe."""

from __future__ import annotations

import os
from pathlib import Path

from conftest import mrnea_cli, one_error_line

from mrnea.errors import OutputError

PICK = str(Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml")


def _failing_report(monkeypatch) -> None:
    """``write_report`` fails after the table and summary.json are written (a full disk)."""
    import mrnea.report

    def broken(res, path, *args, **kw):
        raise OutputError(f"{path}: cannot write: No space left on device")

    monkeypatch.setattr(mrnea.report, "write_report", broken)


def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())} if folder.exists() else {}


def test_a_failed_run_with_force_puts_the_old_files_back(monkeypatch, tmp_path) -> None:
    """--force over a previous run, failing on its report: the old set is back byte for byte,
    no new file and no moved-aside copy left (it had left the new cycles.csv and summary.json
    next to the old report and figures: a mixed set)."""
    from click.testing import CliRunner

    from mrnea.cli import main

    out = tmp_path / "o"
    first = mrnea_cli("simulate", PICK, "--out", out, "--no-3d", "--quiet")
    assert first.returncode == 0, first.stderr
    (out / "cycles.csv").write_text("old table\n")  # tells the old one from a new one
    before = _files(out)
    _failing_report(monkeypatch)
    res = CliRunner().invoke(main, ["simulate", PICK, "--out", str(out), "--no-3d", "--force",
                                    "--quiet"])
    assert res.exit_code == 2, res.output
    assert "No space left" in res.stderr
    assert _files(out) == before


def test_a_failed_run_leaves_no_partial_set(monkeypatch, tmp_path) -> None:
    """A fresh folder, failing on the report: nothing left (it had kept cycles.csv and
    summary.json of a run that said 'error')."""
    from click.testing import CliRunner

    from mrnea.cli import main

    out = tmp_path / "o"
    _failing_report(monkeypatch)
    res = CliRunner().invoke(main, ["demo", "--out", str(out), "--no-3d", "--quiet",
                                    "--dt", "0.05"])
    assert res.exit_code == 2, res.output
    assert not out.exists(), _files(out).keys()


def test_a_newline_in_out_stays_one_line(tmp_path) -> None:
    """The 'Report:' line quotes a folder with a newline escaped (it printed two lines)."""
    res = mrnea_cli("simulate", PICK, "--out", "a\nb", "--no-3d", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.splitlines()[-1] == "Report: a\\nb/report.html", res.stdout
    assert (tmp_path / "a\nb" / "report.html").is_file()
    res = mrnea_cli("retime", PICK, "--out", "c\nd", "--no-3d", cwd=tmp_path)  # and its kin
    assert res.returncode == 0, res.stderr
    written = [line for line in res.stdout.splitlines() if line.startswith("Written: ")]
    assert len(written) == 1 and written[0].startswith("Written: c\\nd/retimed.csv, "), res.stdout
    # (its "Check it:" line is a shell command: the newline stays, quoted, as the shell reads it)
    assert "Check it: mrnea check 'c\nd/retimed.toml'" in res.stdout, res.stdout


def test_fig3_refuses_a_pipe_or_device(tmp_path) -> None:
    """``fig3 --out PIPE`` (a FIFO, /dev/null...) is one error line; no PIPE.png is made next to
    it (it wrote /dev/null.png into /dev as root)."""
    os.mkfifo(tmp_path / "pipe")
    one_error_line(mrnea_cli("fig3", "--out", "pipe", cwd=tmp_path), "pipe", "not a regular")
    assert sorted(os.listdir(tmp_path)) == ["pipe"]
    one_error_line(mrnea_cli("fig3", "--out", "/dev/null", cwd=tmp_path), "/dev/null")
