"""The ``mrnea`` command end to end, in temporary folders."""

from __future__ import annotations

import json
from html.parser import HTMLParser
from pathlib import Path

import pytest
from click.testing import CliRunner

from mrnea.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run(*args: str, cwd: Path | None = None):
    """Run the CLI in-process; returns click's Result (exit_code, stdout, stderr)."""
    runner = CliRunner()
    if cwd is None:
        return runner.invoke(main, list(args), catch_exceptions=False)
    with runner.isolated_filesystem(temp_dir=cwd):
        return runner.invoke(main, list(args), catch_exceptions=False)


class _Text(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.chunks: list[str] = []

    def handle_data(self, data: str) -> None:
        self.chunks.append(data)


def html_text(path: Path) -> str:
    p = _Text()
    p.feed(path.read_text(encoding="utf-8"))
    p.close()
    return " ".join(p.chunks)


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "out"
    res = run("demo", "--out", str(out))
    assert res.exit_code == 1, res.output  # NOT ACHIEVABLE, on purpose
    return out, res


def test_demo_writes_the_report_and_says_where_it_fails(demo_out):
    out, res = demo_out
    for name in ("report.html", "cycles.csv", "summary.json", "motion.png", "efforts.png",
                 "reactions.png", "tracking.png", "fig3.png"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["achievable"] is False
    first = summary["first_infeasible"]
    assert first["joint"] == "cab_yaw" and first["reason"] == "effort saturated"
    assert abs(first["required_effort"]) > first["available_effort"]
    assert "NOT ACHIEVABLE" in res.output and str(out / "report.html") in res.output
    text = html_text(out / "report.html")
    assert "NOT ACHIEVABLE" in text and "cab_yaw" in text
    assert (out / "motion.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_demo_never_overwrites(demo_out):
    out, _ = demo_out
    before = (out / "summary.json").read_bytes()
    res = CliRunner().invoke(main, ["demo", "--out", str(out)])
    assert res.exit_code == 2
    assert "exists" in res.stderr and "Traceback" not in res.output + res.stderr
    assert (out / "summary.json").read_bytes() == before


def test_simulate_an_example_program(tmp_path):
    out = tmp_path / "puma"
    res = run("simulate", "puma560", str(EXAMPLES / "puma_pick.toml"), "--out", str(out),
              "--json")
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout)
    assert summary["achievable"] is True and summary["robot"] == "puma560"
    assert Path(summary["report"]).is_file()
    assert "ACHIEVABLE" in html_text(out / "report.html")
    assert 'class="mv3d"' in (out / "report.html").read_text()  # the 3D view, by default
    res = run("simulate", "puma560", str(EXAMPLES / "puma_pick.toml"), "--out", str(out),
              "--force", "--quiet", "--no-3d")
    assert res.exit_code == 0, res.output
    doc = (out / "report.html").read_text()
    assert "ACHIEVABLE" in doc and "<script" not in doc and 'class="mv3d"' not in doc


def test_check_exit_codes(tmp_path):
    assert run("check", "puma560", str(EXAMPLES / "puma_pick.toml")).exit_code == 0
    fast = tmp_path / "fast.toml"
    fast.write_text(
        '[program]\nrobot = "puma560"\ndt = 0.005\n[path]\nprofile = "quintic"\n'
        "waypoints = [[0, 0, 0, 0, 0, 0], [2, 2, 2, 2, 2, 2]]\n"
        "velocity_limit = 50\nacceleration_limit = 500\n")
    res = run("check", "puma560", str(fast))
    assert res.exit_code == 1 and "NOT ACHIEVABLE" in res.output
    res = run("check", "puma560", str(fast), "--json")
    assert res.exit_code == 1 and json.loads(res.stdout)["achievable"] is False


@pytest.mark.parametrize("content, match", [
    ("[program\nrobot = 'puma560'\n", "line 1"),
    ("[program]\nrobot = 'puma560'\ndt = 0.005\n[path]\nprofil = 'quintic'\n", "profile"),
    ("[program]\nrobot = 'nosuchrobot'\ndt = 0.005\n", "nosuchrobot"),
])
def test_bad_program_file_exit_2_one_line(tmp_path, content, match):
    bad = tmp_path / "bad.toml"
    bad.write_text(content)
    res = CliRunner().invoke(main, ["check", "puma560", str(bad)])
    assert res.exit_code == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error:") and match in lines[0]
    assert "Traceback" not in res.output + res.stderr


def test_bad_robot_file_exit_2(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/>")
    res = CliRunner().invoke(main, ["info", str(bad)])
    assert res.exit_code == 2 and res.stderr.startswith("mrnea: error:")
    assert len(res.stderr.strip().splitlines()) == 1


def test_csv_program_needs_dt(tmp_path):
    res = CliRunner().invoke(main, ["check", "sdt", str(EXAMPLES / "sdt_profile.csv")])
    assert res.exit_code == 2 and "--dt" in res.output + res.stderr
    assert run("check", "sdt", str(EXAMPLES / "sdt_profile.csv"), "--dt", "0.01").exit_code == 0


def test_info(tmp_path):
    res = run("info", "sdt")
    assert res.exit_code == 0 and "planetary" in res.output and "cab_pitch" in res.output
    data = json.loads(run("info", "puma560", "--json").stdout)
    assert data["n"] == 6 and data["joints"][1]["effort_limit"] > 0


def test_fig3(tmp_path):
    out = tmp_path / "f.png"
    assert run("fig3", "--out", str(out)).exit_code == 0
    assert out.read_bytes()[:4] == b"\x89PNG"
    res = CliRunner().invoke(main, ["fig3", "--out", str(out)])
    assert res.exit_code == 2  # exists: not overwritten without --force


# every command's --help, run as python -m mrnea (exit 0, "Usage"): the one test of it is
# tests/test_exit_codes.py::test_every_commands_help_states_its_exit_codes
