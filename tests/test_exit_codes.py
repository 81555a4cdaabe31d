"""One exit-code rule for every command, each run as a real process: 0 achievable (done, for a
command without a verdict), 1 NOT ACHIEVABLE (a verdict, not an error), 2 bad input, 130
interrupted (tests/test_interrupts.py sends the signals); and every ``--help`` says it.

The verdicts are known independently: the demo's by hand in docs/sdt.md (6486 N m against the
yaw drive's 4000 N m), the fast Puma move's from its acceleration (0.5 rad quintics at up to
500 rad/s^2, far beyond what a Puma 560 joint's effort limit gives), the Puma pick's from its
headroom.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from conftest import mrnea_cli, one_error_line

from mrnea.cli import main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FAST = ('[program]\nrobot = "puma560"\ndt = 0.005\n[path]\nprofile = "quintic"\n'
        "waypoints = [[0, 0, 0, 0, 0, 0], [0.5, 0.5, 0.5, 0.5, 0.5, 0.5]]\n"
        "velocity_limit = 50\nacceleration_limit = 500\n")


@pytest.fixture
def fast(tmp_path: Path) -> Path:
    p = tmp_path / "fast.toml"
    p.write_text(FAST)
    return p


def test_every_commands_help_states_its_exit_codes():
    for name in main.commands:
        res = mrnea_cli(name, "--help")
        assert res.returncode == 0, res.stderr
        text = " ".join(res.stdout.split())
        assert "Exit code: 0 " in text and "2 bad input" in text and "130 interrupted" in text
        verdict = "1 NOT ACHIEVABLE" in text
        assert verdict == (name in ("demo", "simulate", "check", "retime")), (name, text)
    top = " ".join(mrnea_cli("--help").stdout.split())
    assert "1 NOT ACHIEVABLE" in top and "130 interrupted" in top


def test_demo_exits_1_on_its_verdict_with_every_file_written(tmp_path: Path):
    res = mrnea_cli("demo", "--out", tmp_path / "d", "--no-3d")
    assert res.returncode == 1, res.stderr
    assert res.stdout.startswith("NOT ACHIEVABLE: cab_yaw needs ")
    for name in ("summary.json", "cycles.csv", "report.html", "fig3.png"):
        assert (tmp_path / "d" / name).is_file(), name
    res = mrnea_cli("demo", "--out", tmp_path / "d", "--json", "--force", "--quiet", "--no-3d")
    assert res.returncode == 1 and json.loads(res.stdout)["achievable"] is False


def test_simulate_exits_by_the_verdict(tmp_path: Path, fast: Path):
    res = mrnea_cli("simulate", fast, "--out", tmp_path / "f", "--no-3d")
    assert res.returncode == 1, res.stderr
    assert res.stdout.startswith("NOT ACHIEVABLE: ")
    assert json.loads((tmp_path / "f" / "summary.json").read_text())["achievable"] is False
    res = mrnea_cli("simulate", EXAMPLES / "puma_pick.toml", "--out", tmp_path / "p", "--no-3d")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("ACHIEVABLE: ")
    one_error_line(mrnea_cli("simulate", "puma560", tmp_path / "missing.toml", "--out",
                             tmp_path / "m"), "missing.toml")


def test_check_exits_by_the_verdict(fast: Path):
    assert mrnea_cli("check", EXAMPLES / "puma_pick.toml").returncode == 0
    res = mrnea_cli("check", fast, "--json")
    assert res.returncode == 1 and json.loads(res.stdout)["achievable"] is False
    one_error_line(mrnea_cli("check", "puma560", fast, "--mode", "fast"), "--mode")


def test_retime_exits_0_once_verified(tmp_path: Path, fast: Path):
    res = mrnea_cli("retime", fast, "--out", tmp_path / "r", "--no-3d", "--quiet")
    assert res.returncode == 0, res.stderr
    assert mrnea_cli("check", tmp_path / "r" / "retimed.toml").returncode == 0
    one_error_line(mrnea_cli("retime", fast), "--out")


def test_commands_without_a_verdict(tmp_path: Path):
    assert mrnea_cli("info", "sdt").returncode == 0
    one_error_line(mrnea_cli("info", "nosuchrobot"), "nosuchrobot")
    one_error_line(mrnea_cli("fig3", "--out", tmp_path / "fig.xyz"), "fig.xyz")
    one_error_line(mrnea_cli("sweep", "sdt", "demo", "--grid", tmp_path / "none.toml"),
                   "none.toml")
