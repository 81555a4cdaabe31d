"""Session 39: a stop request after a command's answer no longer turns it into "interrupted".

Every command that answers by printing (``info``, ``fig3``, ``identify``, ``sweep``, and the
verdicts of ``demo`` / ``simulate`` / ``check``) calls ``cli.base.last_checkpoint`` after its files
and just before its answer: a request until there exits 130 without the answer; one that lands
while it prints is too late, and the answer's exit code stands (before, ``info`` printed the
robot's table and then exited 130, ``fig3`` printed "Fig. 3: PATH" and exited 130). In process:
the request is what SIGINT or SIGTERM sets, placed at a moment by wrapping the function the
command calls there (``conftest.stop_requested_at``).
"""

from __future__ import annotations

from pathlib import Path

from click.testing import CliRunner
from conftest import stop_requested_at

from mrnea.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_info_answers_or_stops_never_both(monkeypatch) -> None:
    from mrnea.cli import info

    stop_requested_at(monkeypatch, info, "describe", before=True)  # while it prints: too late
    res = CliRunner().invoke(main, ["info", "puma560"])
    assert res.exit_code == 0, res.output
    assert "interrupted" not in res.output and res.stdout.startswith("puma560: 6 moving joints")

    monkeypatch.undo()
    stop_requested_at(monkeypatch, info, "load_robot_arg")  # as it loads the robot: no table
    res = CliRunner().invoke(main, ["info", "puma560"])
    assert res.exit_code == 130, res.output
    assert res.stdout == "" and "mrnea: interrupted" in res.output


def test_fig3_stopped_while_writing_says_no_file_name(monkeypatch, tmp_path) -> None:
    """A request while the figure is written: exit 130 and no "Fig. 3:" line (the file is
    whole: written to a temporary file and renamed); one while it prints the line: exit 0."""
    from mrnea.cli import paper
    from mrnea.report import drawing

    stop_requested_at(monkeypatch, drawing, "save_figure")
    out = tmp_path / "fig3.png"
    res = CliRunner().invoke(main, ["fig3", "--out", str(out)])
    assert res.exit_code == 130, res.output
    assert "Fig. 3:" not in res.stdout and "mrnea: interrupted" in res.output
    assert out.read_bytes().startswith(b"\x89PNG")

    monkeypatch.undo()  # the request lands just after the last checkpoint
    stop_requested_at(monkeypatch, paper, "last_checkpoint")
    res = CliRunner().invoke(main, ["fig3", "--out", str(tmp_path / "again.png")])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith("Fig. 3:") and "interrupted" not in res.output


def test_identify_prints_its_answer_once_it_is_past_the_last_checkpoint(monkeypatch,
                                                                       tmp_path) -> None:
    from mrnea.cli import identify

    stop_requested_at(monkeypatch, identify, "_lines", before=True)  # as it prints: too late
    res = CliRunner().invoke(main, ["identify", "puma560",
                                    str(EXAMPLES / "puma_identify_log.csv"), "--out",
                                    str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    assert "interrupted" not in res.output and f"Wrote {tmp_path / 'o'}" in res.stdout
