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
import shutil
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
    """Also: every command has --help (and the group: below), run as ``python -m mrnea``."""
    for name in main.commands:
        res = mrnea_cli(name, "--help")
        assert res.returncode == 0 and "Usage" in res.stdout, (name, res.stderr)
        text = " ".join(res.stdout.split())
        assert "Exit code: 0 " in text and "2 bad input" in text and "130 interrupted" in text
        verdict = "1 NOT ACHIEVABLE" in text
        assert verdict == (name in ("demo", "simulate", "check", "retime")), (name, text)
    res = mrnea_cli("--help")
    assert res.returncode == 0 and "Usage" in res.stdout, res.stderr
    top = " ".join(res.stdout.split())
    assert "1 NOT ACHIEVABLE" in top and "130 interrupted" in top


def test_demo_exits_1_on_its_verdict_with_every_file_written(tmp_path: Path, demo_run):
    res, out = demo_run  # mrnea demo --out DIR --no-3d (conftest; shared with test_summary_schema)
    assert res.returncode == 1, res.stderr
    assert res.stdout.startswith("NOT ACHIEVABLE: cab_yaw needs ")
    for name in ("summary.json", "cycles.csv", "report.html", "fig3.png"):
        assert (out / name).is_file(), name
    shutil.copytree(out, tmp_path / "d")  # --force below replaces the files of a finished run
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


def test_retime_exits_1_when_no_timing_exists(tmp_path: Path):
    """A program the robot cannot follow in any timing is a verdict (exit 1, one NOT
    ACHIEVABLE line, nothing written, no folder left), not bad input. Independently of mrnea:
    the program turns joint 6 only, holding joints 1-5 at 0, and Pinocchio's gravity torque of
    joint 2 there, with a 40 kg payload at the flange, is 214.9 N m, over the Puma 560's
    186.4 N m (static friction, up to 13.6 N m, cannot make up for it); and joint 3's upper
    limit is 45 deg (Corke's Puma 560), which the second program passes (1 rad)."""
    import numpy as np
    import pinocchio as pin
    from conftest import to_pinocchio

    import mrnea

    heavy = mrnea.robots.puma560().with_payload(40.0)
    model = to_pinocchio(heavy)
    g = pin.rnea(model, model.createData(), np.zeros(6), np.zeros(6), np.zeros(6))
    ratio = g[1] / 186.4
    assert ratio - 13.6 / 186.4 > 1.0  # the oracle: no timing holds the pose
    wrist = tmp_path / "wrist.toml"
    wrist.write_text(FAST.replace("[0.5, 0.5, 0.5, 0.5, 0.5, 0.5]", "[0, 0, 0, 0, 0, 0.5]"))
    res = mrnea_cli("retime", wrist, "--out", tmp_path / "r", "--payload", "40")
    assert res.returncode == 1, (res.stdout, res.stderr)
    assert "error" not in res.stderr and "Traceback" not in res.stderr  # (a compile notice)
    assert len(res.stdout.splitlines()) == 1
    line = res.stdout.strip()
    assert line.startswith("NOT ACHIEVABLE at any timing: ") and "wrist.toml" in line
    assert "at any speed" in line and "joint 'joint2' (joint 2)" in line, line
    quoted = float(line.split(" times its limit")[0].split(", ")[-1])
    assert abs(quoted - ratio) <= 13.6 / 186.4  # within joint 2's Coulomb friction
    assert not (tmp_path / "r").exists()
    res = mrnea_cli("retime", wrist, "--out", tmp_path / "r", "--payload", "40", "--json")
    assert res.returncode == 1 and json.loads(res.stdout) == {
        "achievable": False, "retimed": False, "verdict": line}
    beyond = tmp_path / "beyond.toml"
    beyond.write_text(FAST.replace("[0.5, 0.5, 0.5, 0.5, 0.5, 0.5]", "[0, 0, 1.0, 0, 0, 0]"))
    res = mrnea_cli("retime", beyond, "--out", tmp_path / "b", "--quiet")
    assert res.returncode == 1 and res.stdout == "" and res.stderr == "", res.stderr
    res = mrnea_cli("retime", beyond, "--out", tmp_path / "b")
    assert res.returncode == 1 and "joint 'joint3' (joint 3) leaves its position limits" in (
        res.stdout) and f"{np.deg2rad(45):.4g}]" in res.stdout, res.stdout
    assert not (tmp_path / "b").exists()
    # bad input stays bad input: a program that never moves
    still = tmp_path / "still.toml"
    still.write_text(FAST.replace("[0.5, 0.5, 0.5, 0.5, 0.5, 0.5]", "[0, 0, 0, 0, 0, 0]"))
    one_error_line(mrnea_cli("retime", still, "--out", tmp_path / "s"), "single cycle")


def test_commands_without_a_verdict(tmp_path: Path):
    assert mrnea_cli("info", "sdt").returncode == 0
    one_error_line(mrnea_cli("info", "nosuchrobot"), "nosuchrobot")
    one_error_line(mrnea_cli("fig3", "--out", tmp_path / "fig.xyz"), "fig.xyz")
    one_error_line(mrnea_cli("sweep", "sdt", "demo", "--grid", tmp_path / "none.toml"),
                   "none.toml")
