"""``mrnea retime`` end to end (a real ``python -m mrnea`` process), its files, the hint of
``check`` and ``simulate`` under a program that is not achievable, and bad input (one error
line, exit 2)."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import mrnea
from mrnea.cli import main
from mrnea.io import from_csv

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
FILES = ("retimed.csv", "retimed.toml", "summary.json", "report.html")


def mrnea_cmd(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mrnea", *args], capture_output=True, text=True,
                          timeout=600, cwd=cwd)


def one_error_line(stderr: str, match: str) -> None:
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("mrnea: error:") and match in lines[0], lines[0]


@pytest.fixture(scope="module")
def pick(tmp_path_factory):
    out = tmp_path_factory.mktemp("retime") / "pick"
    done = mrnea_cmd("retime", "puma560", str(EXAMPLES / "puma_pick.toml"), "--out", str(out))
    assert done.returncode == 0, done.stdout + done.stderr
    return out, done


def test_retime_writes_its_files(pick):
    out, done = pick
    for name in FILES:
        assert (out / name).is_file(), name
    assert not (out / ".mrnea.lock").exists()
    assert done.stdout.startswith("RETIMED (toppra)") and "ACHIEVABLE" in done.stdout
    # strict JSON: Python's parser refuses NaN and Infinity when asked to
    s = json.loads((out / "summary.json").read_text(),
                   parse_constant=lambda c: pytest.fail(f"non-strict JSON token {c}"))
    prog = mrnea.load_program(EXAMPLES / "puma_pick.toml")
    assert s["method"] == "toppra" and s["achievable"] is True and s["robot"] == "puma560"
    assert s["original_duration"] == pytest.approx(prog.duration)
    assert s["duration"] < s["original_duration"] and 0.5 <= s["margin"] <= 0.98
    html = (out / "report.html").read_text()
    assert html.count('src="data:image/png;base64,') == 2
    assert "phase plane" in html and "RETIMED (toppra)" in html
    assert re.search(r'(src|href)="(?!data:|#)', html) is None  # self-contained
    assert "3D view (retimed)" in html and "<script" in html and "three.js" in html


def test_retimed_files_reproduce_the_verification(pick):
    """retimed.toml alone and retimed.csv with its robot and --dt are the program that was
    verified: check exits 0 on both, and the CSV reads back bit for bit."""
    out, _ = pick
    s = json.loads((out / "summary.json").read_text())
    done = mrnea_cmd("check", str(out / "retimed.toml"), "--json")
    assert done.returncode == 0, done.stdout + done.stderr
    assert json.loads(done.stdout)["achievable"] is True
    done = mrnea_cmd("check", "puma560", str(out / "retimed.csv"), "--dt", str(s["dt"]))
    assert done.returncode == 0, done.stdout + done.stderr
    _t, q = from_csv(out / "retimed.csv", s["dt"], n=6)
    prog = mrnea.load_program(out / "retimed.toml")
    assert prog.robot == "puma560" and prog.dt == s["dt"] and prog.mode == "hybrid"
    assert np.array_equal(prog.q_cmd, q) and q.shape[0] == s["cycles"]
    assert (q.shape[0] - 1) * s["dt"] == pytest.approx(s["duration"])
    # the wrench moved with the path: the same peak, held for the same time on the part
    orig = mrnea.load_program(EXAMPLES / "puma_pick.toml")
    assert prog.f_ext.min() == pytest.approx(orig.f_ext.min())
    pressing = np.isclose(prog.f_ext[:, 2], -20.0, rtol=0, atol=1e-9)
    assert abs(pressing.sum() - np.isclose(orig.f_ext[:, 2], -20.0, rtol=0, atol=1e-9).sum()) <= 2
    np.testing.assert_array_equal(prog.f_ext_point, orig.f_ext_point)


def test_second_run_refuses_then_force(pick, tmp_path):
    out, _ = pick
    before = (out / "summary.json").read_bytes()
    res = CliRunner().invoke(main, ["retime", "puma560", str(EXAMPLES / "puma_pick.toml"),
                                    "--out", str(out), "--method", "scale"])
    assert res.exit_code == 2
    one_error_line(res.stderr, "exists")
    assert (out / "summary.json").read_bytes() == before
    res = CliRunner().invoke(main, ["retime", "puma560", str(EXAMPLES / "puma_pick.toml"),
                                    "--out", str(out), "--method", "scale", "--force", "--json",
                                    "--no-3d"])
    assert res.exit_code == 0, res.output
    assert "<script" not in (out / "report.html").read_text()
    s = json.loads(res.stdout)
    assert s["method"] == "scale" and s["factor"] > 0 and s["scale_estimate"] > 0
    assert s["duration"] >= json.loads(before)["duration"]  # toppra is never longer


def test_program_naming_its_robot_and_a_csv_program(tmp_path):
    """ROBOT may be left out when the program file names it; a CSV program takes ROBOT and
    --dt, and another --dt resamples the retimed program."""
    res = CliRunner().invoke(main, ["retime", str(EXAMPLES / "sdt_csv.toml"), "--out",
                                    str(tmp_path / "a"), "--quiet"])
    assert res.exit_code == 0, res.output
    assert mrnea.load_program(tmp_path / "a" / "retimed.toml").mode == "paper"
    res = CliRunner().invoke(main, ["retime", "sdt", str(EXAMPLES / "sdt_profile.csv"),
                                    "--dt", "0.01", "--out", str(tmp_path / "b"), "--json"])
    assert res.exit_code == 0, res.output
    s = json.loads(res.stdout)
    assert s["dt"] == 0.01 and s["achievable"] is True


def test_check_and_simulate_suggest_retime(tmp_path):
    """Under a program that is not achievable (the SDT's training profile: the yaw turn), check
    and simulate print the retime command and the duration uniform scaling would give, by
    Hollerbach's estimate (the library's); not in the JSON summary (stderr with --json)."""
    from mrnea.io.pathcsv import save_csv
    from mrnea.retime import scale_estimate
    from mrnea.robots.sdt_profile import training_profile

    t, q = training_profile(0.005)
    save_csv(tmp_path / "training.csv", t, q, mrnea.robots.sdt().joint_names)
    prog = tmp_path / "training.toml"
    prog.write_text('[program]\nrobot = "sdt"\ndt = 0.005\n[path]\ncsv = "training.csv"\n')
    f = scale_estimate(mrnea.robots.sdt(), q, 0.005)
    T = (q.shape[0] - 1) * 0.005
    res = CliRunner().invoke(main, ["check", "sdt", str(prog)])
    assert res.exit_code == 1
    assert f"Retime it: mrnea retime sdt {prog} --out training-retimed" in res.stdout
    assert f"about {f * T:.4g} s instead of {T:.4g} s" in res.stdout
    res = CliRunner().invoke(main, ["check", "sdt", str(prog), "--json"])
    assert res.exit_code == 1 and "Retime it" in res.stderr
    assert "etime" not in json.dumps(json.loads(res.stdout))
    res = CliRunner().invoke(main, ["simulate", "sdt", str(prog), "--out", str(tmp_path / "s")])
    assert res.exit_code == 1 and "Retime it: mrnea retime sdt" in res.stdout
    assert "etime" not in (tmp_path / "s" / "summary.json").read_text()
    res = CliRunner().invoke(main, ["check", "sdt", str(prog), "--quiet"])
    assert res.exit_code == 1 and res.output == ""
    res = CliRunner().invoke(main, ["check", "puma560", str(EXAMPLES / "puma_pick.toml")])
    assert res.exit_code == 0 and "Retime" not in res.output


def test_the_suggested_command_runs(tmp_path):
    """For a CSV program checked with --dt, --interpolation and --mode paper, the suggested
    command carries them, and it runs: exit 0, and its program passes check."""
    from mrnea.io.pathcsv import save_csv
    from mrnea.robots.sdt_profile import training_profile

    t, q = training_profile(0.005)
    csv = tmp_path / "training.csv"
    save_csv(csv, t, q, mrnea.robots.sdt().joint_names)
    res = CliRunner().invoke(main, ["check", "sdt", str(csv), "--dt", "0.005",
                                    "--interpolation", "linear", "--mode", "paper"])
    assert res.exit_code == 1
    line = next(x for x in res.stdout.splitlines() if x.startswith("Retime it: mrnea retime "))
    args = shlex.split(line.removeprefix("Retime it: mrnea "))
    assert args[:2] == ["retime", "sdt"]
    for opt, value in (("--dt", "0.005"), ("--interpolation", "linear"), ("--mode", "paper")):
        assert args[args.index(opt) + 1] == value
    args[args.index("--out") + 1] = str(tmp_path / "out")
    res = CliRunner().invoke(main, args)
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(main, ["check", str(tmp_path / "out" / "retimed.toml")])
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize("args,match", [
    (["--margin", "0"], "'--margin': must be > 0"),
    (["--margin", "1.5"], "'--margin': must be in (0, 1]"),
    (["--margin", "nan"], "'--margin'"),
    (["--dt", "0"], "'--dt': must be > 0"),
])
def test_bad_options_one_line_exit_2(tmp_path, args, match):
    res = CliRunner().invoke(main, ["retime", "puma560", str(EXAMPLES / "puma_pick.toml"),
                                    "--out", str(tmp_path / "x"), *args])
    assert res.exit_code == 2
    one_error_line(res.stderr, match)
    assert not any((tmp_path / "x" / f).exists() for f in FILES)


def test_unfollowable_path_is_a_verdict_exit_1(tmp_path):
    """A drive too weak to hold the pose (a sidecar file, --actuators): no timing exists, a
    verdict (exit 1), one NOT ACHIEVABLE line naming the joint and the ratio to its limit;
    nothing written, no error line (a real process: no traceback). The number itself is checked
    against Pinocchio's gravity torque in test_exit_codes.py."""
    (tmp_path / "weak.toml").write_text("[joint2]\neffort_limit = 10.0\n")
    done = mrnea_cmd("retime", str(EXAMPLES / "puma_pick.toml"), "--actuators",
                     str(tmp_path / "weak.toml"), "--out", str(tmp_path / "out"))
    assert done.returncode == 1
    assert "mrnea: error:" not in done.stderr
    verdicts = [x for x in done.stdout.splitlines() if x.startswith("NOT ACHIEVABLE")]
    assert len(verdicts) == 1 and "cannot be followed at any speed" in verdicts[0]
    assert "joint 'joint2'" in verdicts[0] and "times its limit 10" in verdicts[0]
    assert "Traceback" not in done.stderr + done.stdout
    assert not any((tmp_path / "out" / f).exists() for f in FILES)


def test_robot_options_go_into_the_program_file(tmp_path):
    """The robot options the run used (the command line's over the program's) are in
    retimed.toml, so that `mrnea check DIR/retimed.toml` alone reproduces the verification:
    actuators by absolute path, a point-mass payload inline, one with an inertia in
    payload.toml beside it, gravity."""
    (tmp_path / "drives.toml").write_text("[joint2]\nviscous_friction = 9.0\n")
    (tmp_path / "part.toml").write_text("mass = 1.5\ncom = [0.0, 0.0, 0.05]\n"
                                        "inertia = { ixx = 0.01, iyy = 0.01, izz = 0.004 }\n")
    for payload, key in (("1.5@0,0,0.05", "1.5@0.0,0.0,0.05"), (str(tmp_path / "part.toml"),
                                                                 "payload.toml")):
        out = tmp_path / ("inline" if "@" in payload else "file")
        res = CliRunner().invoke(main, [
            "retime", str(EXAMPLES / "puma_pick.toml"), "--actuators",
            str(tmp_path / "drives.toml"), "--payload", payload, "--gravity", "0,0,-9.7",
            "--out", str(out), "--quiet"])
        assert res.exit_code == 0, res.output
        text = (out / "retimed.toml").read_text()
        assert f'actuators = "{tmp_path / "drives.toml"}"' in text
        assert f'payload = "{key}"' in text and "gravity = [0.0, 0.0, -9.7]" in text
        assert (out / "payload.toml").is_file() == (key == "payload.toml")
        prog = mrnea.load_program(out / "retimed.toml")
        robot = prog.load_robot()
        assert robot.viscous_friction[1] == 9.0 and robot.gravity.tolist() == [0, 0, -9.7]
        assert robot.links[-1].mass == pytest.approx(
            mrnea.robots.puma560().links[-1].mass + 1.5)
        done = mrnea_cmd("check", str(out / "retimed.toml"))
        assert done.returncode == 0, done.stdout + done.stderr


def test_csv_without_dt_and_unknown_method(tmp_path):
    res = CliRunner().invoke(main, ["retime", "sdt", str(EXAMPLES / "sdt_profile.csv"), "--out",
                                    str(tmp_path / "x")])
    assert res.exit_code == 2 and "--dt" in res.stderr
    res = CliRunner().invoke(main, ["retime", "sdt", str(EXAMPLES / "sdt_csv.toml"), "--out",
                                    str(tmp_path / "x"), "--method", "fast"])
    assert res.exit_code == 2 and "fast" in res.stderr
