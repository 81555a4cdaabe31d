"""Interrupts: an interrupted run keeps a valid partial result and is never called achievable.

Ctrl-C (SIGINT) and SIGTERM are sent to a real ``mrnea`` process in the middle of a run: it
exits 130, its summary says ``"completed": false`` and after how many cycles, the streamed table
holds exactly those cycles, and no temporary file is left. In-process tests cover what a signal
cannot aim at: an interrupt that lands in the middle of a chunk's write.
"""

from __future__ import annotations

import contextlib
import csv
import importlib
import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_output_files import LONG, leftovers, wait_for_table

from mrnea.model import Joint, Link, Robot
from mrnea.report import write_report
from mrnea.simulate import CHUNK, simulate

# the module (mrnea.simulate, the attribute, is the function)
simulate_module = importlib.import_module("mrnea.simulate")


def pendulum(effort_limit: float = 1e6) -> Robot:
    joints = [Joint("j1", "revolute", "base", "l1", axis=(0, 1, 0), effort_limit=effort_limit,
                    velocity_limit=100.0)]
    links = [Link("l1", 1.0, (0.5, 0.0, 0.0), np.eye(3) * 1e-2)]
    return Robot(joints, links)


def ramp(K: int, dt: float, speed: float = 0.2) -> np.ndarray:
    return (np.arange(K) * dt * speed)[:, None]


def stop_after(cycles: int):
    def progress(done: int, total: int) -> None:
        if done >= cycles:
            raise KeyboardInterrupt
    return progress


# --- in process ----------------------------------------------------------------------------------
def test_an_interrupted_run_is_never_achievable() -> None:
    """Within limits so far: achievable is None (unknown), not True; the verdict and summary say
    after how many cycles the run stopped."""
    dt = 0.001
    res = simulate(pendulum(), ramp(3 * CHUNK, dt), dt, progress=stop_after(CHUNK))
    assert not res.completed and res.K == CHUNK
    assert res.achievable is None
    s = res.summary()
    assert s["achievable"] is None and s["completed"] is False
    assert s["interrupted_after_cycles"] == CHUNK == s["cycles"]
    assert f"interrupted after {CHUNK} cycles" in res.verdict()
    assert "ACHIEVABLE" not in res.verdict()
    assert json.loads(json.dumps(s))["achievable"] is None

    full = simulate(pendulum(), ramp(3 * CHUNK, dt), dt)
    assert full.achievable is True and full.summary()["interrupted_after_cycles"] is None


def test_an_interrupted_run_that_already_failed_says_not_achievable() -> None:
    dt = 0.001
    res = simulate(pendulum(effort_limit=1.0), ramp(3 * CHUNK, dt), dt,
                   progress=stop_after(CHUNK))
    assert not res.completed and res.saturated.any()
    assert res.achievable is False and res.summary()["achievable"] is False
    verdict = res.verdict()
    assert f"interrupted after {CHUNK} cycles" in verdict and "NOT ACHIEVABLE" in verdict


def test_a_run_interrupted_before_its_first_chunk_has_a_valid_summary_and_report(
        tmp_path: Path) -> None:
    dt = 0.001
    empty = simulate(pendulum(), ramp(10, dt), dt)._first(0)  # as if stopped in the first chunk
    s = json.loads(empty.save_summary(tmp_path / "summary.json").read_text())
    assert s["cycles"] == 0 and s["interrupted_after_cycles"] == 0 and s["achievable"] is None
    html = write_report(empty, tmp_path / "report.html").read_text()
    assert "interrupted after 0 cycles" in html and "No cycle was completed" in html
    assert "verdict partial" in html
    empty.to_csv(tmp_path / "cycles.csv")
    assert (tmp_path / "cycles.csv").read_text().count("\n") == 1  # the header alone


def test_an_interrupt_inside_a_chunks_write_keeps_whole_cycles(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch
                                                               ) -> None:
    """The interrupt lands after half of the third chunk's bytes reached the file: the table
    is cut back to the two chunks the result keeps."""
    real_create = simulate_module.create

    class HalfWrite:
        def __init__(self, fh) -> None:
            self.fh, self.writes = fh, 0

        def write(self, data: bytes) -> int:
            self.writes += 1
            if self.writes == 3:
                self.fh.write(data[: len(data) // 2])
                raise KeyboardInterrupt
            return self.fh.write(data)

        def __getattr__(self, name: str):
            return getattr(self.fh, name)

    @contextlib.contextmanager
    def create(*args, **kwargs):
        with real_create(*args, **kwargs) as fh:
            yield HalfWrite(fh)

    monkeypatch.setattr(simulate_module, "create", create)
    dt = 0.001
    res = simulate(pendulum(), ramp(4 * CHUNK, dt), dt, stream=tmp_path / "cycles.csv")
    assert not res.completed and res.K == 2 * CHUNK
    with open(tmp_path / "cycles.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 2 * CHUNK
    assert float(rows[-1]["q_j1 [rad]"]) == res.q[-1, 0]
    assert float(rows[-1]["t [s]"]) == res.t[-1]
    assert [p.name for p in tmp_path.iterdir()] == ["cycles.csv"]


def test_an_error_mid_run_leaves_no_temporary_file(tmp_path: Path) -> None:
    """A run that fails (here the progress callback) removes its streamed temporary table."""
    def boom(done: int, total: int) -> None:
        raise RuntimeError("callback failed")

    dt = 0.001
    with pytest.raises(RuntimeError, match="callback failed"):
        simulate(pendulum(), ramp(3 * CHUNK, dt), dt, stream=tmp_path / "cycles.csv",
                 progress=boom)
    assert list(tmp_path.iterdir()) == []


# --- a real process ------------------------------------------------------------------------------
def _start(*args: str | Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "mrnea", *map(str, args)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_simulate_interrupted_by_a_signal(tmp_path: Path, sig: signal.Signals) -> None:
    program = tmp_path / "long.toml"
    program.write_text(LONG)
    out = tmp_path / "out"
    proc = _start("simulate", "sdt", program, "--out", out)
    wait_for_table(proc, out, rows=CHUNK)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "interrupted after" in stderr
    summary = json.loads((out / "summary.json").read_text())
    N = summary["cycles"]
    assert N >= CHUNK and N % CHUNK == 0  # whole chunks
    assert summary["completed"] is False and summary["interrupted_after_cycles"] == N
    assert summary["achievable"] is None
    with open(out / "cycles.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == N
    assert float(rows[-1]["t [s]"]) == pytest.approx((N - 1) * summary["dt"])
    assert f"interrupted after {N} cycles" in stdout
    assert not re.search(r"(?<!NOT )ACHIEVABLE", stdout)
    report = (out / "report.html").read_text()
    assert "verdict partial" in report and f"interrupted after {N} cycles" in report
    assert leftovers(out) == []
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["cycles.csv", "summary.json", "report.html", "motion.png", "efforts.png",
         "reactions.png", "tracking.png"])


def test_check_interrupted_exits_130(tmp_path: Path) -> None:
    """``mrnea check`` never says achievable for a run it did not finish."""
    program = tmp_path / "long.toml"
    program.write_text(LONG)
    proc = _start("check", "sdt", program, "--json")
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline:  # the progress label: the run is starting
        line = proc.stderr.readline()
        if "simulating" in line or not line:
            break
    proc.send_signal(signal.SIGINT)  # honoured at the end of the first chunk
    stdout, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    summary = json.loads(stdout)
    assert summary["completed"] is False and summary["achievable"] is None
    N = summary["cycles"]
    assert summary["interrupted_after_cycles"] == N and N >= CHUNK and N % CHUNK == 0
