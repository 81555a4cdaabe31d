"""``mrnea sweep`` end to end: its files, nothing but the result on the terminal, bad input as
one line with exit code 2 before any work, Ctrl-C writing the rows done and exiting 130."""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from conftest import environment
from test_cli import EXAMPLES, html_text
from test_cli import run as run_in_process
from test_sweep import serial

import mrnea
from mrnea.io import load_program
from mrnea.robots import puma560
from mrnea.sweep import time_scaled, variant


def run(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mrnea", *args], cwd=cwd, env=environment(),
                          capture_output=True, text=True, timeout=900)


@pytest.fixture
def puma_grid(tmp_path: Path) -> Path:
    shutil.copy(EXAMPLES / "puma_pick.toml", tmp_path)
    grid = tmp_path / "g.toml"
    grid.write_text('[sweep]\nprograms = ["puma_pick.toml"]\n'
                    "[grid]\npayload = [0.0, 15.0]\ntime_scale = [0.5, 1.0]\n")
    return grid


def test_sweep_writes_its_files_and_nothing_else_reaches_the_terminal(tmp_path, puma_grid):
    """The local cluster's start, its workers and their end print nothing (even with the
    dashboard's usual port taken); the files hold the rows in grid order, of the robot with
    the command line's options."""
    with socket.socket() as s:
        try:
            s.bind(("", 8787))
            s.listen()
        except OSError:
            pass  # held by another process: the same situation
        r = run("sweep", "puma560", "--grid", str(puma_grid), "--out", "o", "--payload",
                "1.5@0,0,0.05", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert r.stderr.splitlines() == [
        "mrnea sweep: starting the workers and loading the compiled kernels...",
        "mrnea sweep: 4 runs"], r.stderr  # a bar that is not on a terminal: its label
    assert r.stdout.startswith("4 of 4 rows (1 program(s)): ") and r.stdout.count("\n") == 1
    assert "achievable, 0 failed" in r.stdout
    out = tmp_path / "o"
    csv = pd.read_csv(out / "sweep.csv", index_col="case")
    assert csv[["payload", "time_scale"]].values.tolist() == [[0, 0.5], [0, 1], [15, 0.5],
                                                              [15, 1]]
    # --payload is on the base robot; a swept payload adds to it
    expected = serial(puma560().with_payload(1.5, (0.0, 0.0, 0.05)),
                      load_program(EXAMPLES / "puma_pick.toml"),
                      {"payload": [0.0, 15.0], "time_scale": [0.5, 1.0]})
    assert csv["achievable"].tolist() == [s["achievable"] for _, s in expected]
    assert csv["worst_effort_ratio"].tolist() == [s["worst_effort_ratio"] for _, s in expected]
    assert (csv["program"] == "puma_pick").all() and csv["error"].isna().all()
    parquet = pd.read_parquet(out / "sweep.parquet")
    assert list(parquet.columns) == list(csv.columns)
    assert parquet["worst_effort_ratio"].tolist() == csv["worst_effort_ratio"].tolist()
    page = (out / "sweep.html").read_text()
    assert page.count("<img") == 2 and "Design sweep: puma560" in html_text(out / "sweep.html")
    assert sorted(p.name for p in out.iterdir()) == ["sweep.csv", "sweep.html",
                                                     "sweep.parquet"]
    again = run("sweep", "puma560", "--grid", str(puma_grid), "--out", "o", "--quiet", cwd=tmp_path)
    assert again.returncode == 2 and again.stdout == ""
    assert again.stderr.startswith("mrnea: error: ") and "exists" in again.stderr


def test_scheduler_option_runs_on_that_cluster(tmp_path, puma_grid, scheduler_address):
    """--scheduler: the rows of a cluster in processes of its own (one worker) are the serial
    loop's; --retime adds each row's retimed duration, mrnea.retime's."""
    r = run_in_process("sweep", "puma560", "--grid", str(puma_grid), "--out",
                       str(tmp_path / "o"), "--scheduler", scheduler_address, "--quiet",
                       "--retime")
    assert r.exit_code == 0 and r.stdout == "" and r.stderr == "", r.stderr
    csv = pd.read_csv(tmp_path / "o/sweep.csv", index_col="case")
    pick, grid = load_program(EXAMPLES / "puma_pick.toml"), {"payload": [0.0, 15.0],
                                                            "time_scale": [0.5, 1.0]}
    expected = serial(puma560(), pick, grid)
    assert csv["worst_effort_ratio"].tolist() == [s["worst_effort_ratio"] for _, s in expected]
    assert csv["achievable"].tolist() == [s["achievable"] for _, s in expected]
    assert csv["retimed_duration [s]"].tolist() == [
        mrnea.retime(variant(puma560(), **p), time_scaled(pick, p["time_scale"])).duration
        for p, _ in expected]
    assert csv["retime_error"].isna().all()


@pytest.mark.parametrize("text, args, words", [
    ('[grid]\n"gear_ratio.cab_yow" = [100]\n', ["sdt", "demo"],
     ["g.toml", "gear_ratio.cab_yow", "no joint 'cab_yow'"]),
    ('[grid]\n"gear_ratio.cab_yaw" = [100, -80]\n', ["sdt", "demo"],
     ["g.toml", "'gear_ratio.cab_yaw' value 2 (-80)", "gear_ratio must be > 0"]),
    ("[grid]\npayload = []\n", ["sdt", "demo"], ["g.toml", "'payload'", "empty"]),
    ("[grids]\npayload = [1]\n", ["sdt", "demo"], ["g.toml", "unknown key 'grids'",
                                                   "did you mean 'grid'"]),
    ('[sweep]\nrobot = "sdt"\n[grid]\npayload = [1]\n', ["puma560", "demo"],
     ["'puma560'", "'sdt'", "one robot"]),
    ("[grid]\npayload = [1]\n", ["sdt"], ["no program"]),
    ("[grid]\npayload = [1]\n", ["puma560", "demo"], ["ROBOT argument is 'puma560'",
                                                      "program 'sdt_training' is 'sdt'"]),
    ("[grid]\npayload = [1]\ntime_scale = [1]\n", ["sdt", "demo", "--map", "payload,speed"],
     ["--map", "'speed' is not a parameter of the grid"]),
    ("[grid]\npayload = [1]\n", ["sdt", "demo", "--scheduler", "tcp://127.0.0.1:9",
                                 "--workers", "0"], ["--workers", "0"]),
])
def test_bad_input_is_one_line_before_any_work(tmp_path, text, args, words):
    (tmp_path / "g.toml").write_text(text)
    r = run_in_process("sweep", *args, "--grid", str(tmp_path / "g.toml"), "--out",
                       str(tmp_path / "o"))
    assert r.exit_code == 2, r.output
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("mrnea: error: "), r.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_ctrl_c_writes_the_rows_done_and_exits_130(tmp_path):
    """SIGINT to the whole process group, as a terminal's Ctrl-C, in the middle of a sweep of
    5000 runs: the command writes the rows done, says so and exits 130; no worker prints a
    traceback, and no process of the group is left."""
    # some rows done: tasks of 29 runs take 1-15 s on the 2-core machine
    p, out, stderr = signalled_sweep(tmp_path, [float(x) for x in range(5000)], 25.0,
                                     signal.SIGINT)
    assert p.returncode == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    assert "mrnea: interrupted after" in stderr and out.startswith("INTERRUPTED: ")
    csv = pd.read_csv(tmp_path / "o/sweep.csv", index_col="case")
    assert 0 < len(csv) < 5000 and csv["error"].isna().all()
    assert csv["payload"].tolist() == sorted(csv["payload"].tolist())
    assert len(pd.read_parquet(tmp_path / "o/sweep.parquet")) == len(csv)
    assert "INTERRUPTED" in html_text(tmp_path / "o/sweep.html")
    deadline = time.monotonic() + 30
    while session(p.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not session(p.pid)  # the workers went with the cluster


def signalled_sweep(tmp_path: Path, payloads: list[float], after: float, sig: int
                    ) -> tuple[subprocess.Popen, str, str]:
    """``mrnea sweep`` of the demo over ``payloads`` on 2 local workers, as a real process in
    its own session; ``after`` [s] past its "N runs" line, ``sig`` to the whole process group.
    Returns the process (ended), its stdout and its stderr."""
    grid = tmp_path / "g.toml"
    grid.write_text('[sweep]\nrobot = "sdt"\nprograms = ["demo"]\n[grid]\n'
                    f"payload = {payloads}\n")
    err_path = tmp_path / "stderr.txt"
    with open(err_path, "w") as err:
        p = subprocess.Popen([sys.executable, "-m", "mrnea", "sweep", "--grid", str(grid),
                              "--out", "o", "--workers", "2"], cwd=tmp_path, env=environment(),
                             stdout=subprocess.PIPE, stderr=err, text=True,
                             start_new_session=True)
        deadline = time.monotonic() + 300
        while f"{len(payloads)} runs" not in err_path.read_text() and \
                time.monotonic() < deadline:
            assert p.poll() is None, err_path.read_text()
            time.sleep(0.05)
        time.sleep(after)
        os.killpg(p.pid, sig)
        out, _ = p.communicate(timeout=300)
    return p, out, err_path.read_text()


def session(sid: int) -> list[int]:
    """The live processes (zombies waiting to be reaped aside) of session ``sid``."""
    out = []
    for d in Path("/proc").iterdir():
        try:
            stat = (d / "stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2:].split()  # after the command's name
        if int(fields[3]) == sid and fields[0] != "Z":
            out.append(int(d.name))
    return out
