"""A joint whose speed limit is 0 and which the path moves has no timing: ``check`` says so
(not "it can be made arbitrarily fast", which 0/0 = NaN had made of it), and ``retime`` gives
the verdict, exit 1 and nothing written (not an error about the time-optimal profile)."""

from __future__ import annotations

from pathlib import Path

from conftest import mrnea_cli

PICK = str(Path(__file__).resolve().parents[1] / "examples" / "puma_pick.toml")
SAID = "joint 'joint1' may not move (its speed limit is 0) and the path moves it"


def test_a_moving_joint_with_a_velocity_limit_of_0_has_no_timing(tmp_path: Path) -> None:
    drives = tmp_path / "a.toml"
    drives.write_text("[joint1]\nvelocity_limit = 0\n")
    res = mrnea_cli("check", PICK, "--actuators", drives, cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    assert "arbitrarily fast" not in res.stdout + res.stderr
    assert f"No timing can make it achievable: {SAID}" in res.stdout + res.stderr
    res = mrnea_cli("retime", PICK, "--actuators", drives, "--out", tmp_path / "o",
                    cwd=tmp_path)
    assert res.returncode == 1, res.stderr
    assert SAID in res.stdout + res.stderr and "Traceback" not in res.stderr
    assert not (tmp_path / "o").exists()
