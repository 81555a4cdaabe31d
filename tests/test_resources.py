"""Resources: a run that needs more memory than the budget is refused, with one line, before
anything large is allocated (mrnea.resources; docs/design.md "Memory budget"); a CPU idle now
is read from /proc/loadavg's runnable tasks.

The estimates are checked against what the code really allocates, measured with tracemalloc
(NumPy reports its arrays to it): each estimate must be an upper bound of the measured peak, and
not a gross one. The refusals are checked in-process with a small budget (the budget function is
replaced) and on the command line with requests no machine can meet (``demo --dt 1e-7``, a CSV
spanning 1e7 s at 0.01 s, a waypoint program of 5e8 cycles).
"""

from __future__ import annotations

import functools
import os
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from conftest import mrnea_cli, one_error_line, random_chain

import mrnea.resources as resources
from mrnea.errors import MrneaError, ProgramFileError, StateError
from mrnea.io import from_csv, loads_program
from mrnea.resources import format_bytes, memory_budget, require_memory
from mrnea.robots.sdt_profile import training_profile
from mrnea.simulate import simulate
from mrnea.trajectory import PATH_BYTES, quintic, trapezoidal

mrnea = functools.partial(mrnea_cli, timeout=300)  # [s]: the hang guard


@pytest.fixture
def small_budget(monkeypatch):
    """A budget of 1 MB (no floor): what a run of a few thousand cycles exceeds."""
    monkeypatch.setattr(resources, "available_memory", lambda: 4 * 10**6 / 3)
    monkeypatch.setattr(resources, "BUDGET_FLOOR", 0)
    assert memory_budget() == 10**6


# --- the budget ---------------------------------------------------------------------------------
def test_the_budget_is_a_share_of_the_available_memory() -> None:
    avail = resources.available_memory()
    with open("/proc/meminfo") as fh:
        total = int(next(line for line in fh if line.startswith("MemTotal")).split()[1]) * 1024
    assert 0 < avail <= total
    assert memory_budget() == max(resources.BUDGET_FLOOR, int(resources.BUDGET_FRACTION * avail))


def test_small_requests_are_never_refused(monkeypatch) -> None:
    monkeypatch.setattr(resources, "available_memory", lambda: 0)
    require_memory(resources.BUDGET_FLOOR, "a small task", "nothing")
    with pytest.raises(MrneaError, match=r"^a big task needs about 268 MB of memory, more than "
                                         r"the 268 MB mrnea may use .*; do less$"):
        require_memory(resources.BUDGET_FLOOR + 1, "a big task", "do less")


def test_a_count_too_large_to_compute_is_refused() -> None:
    for nbytes in (float("inf"), float("nan"), 1e300):
        with pytest.raises(MrneaError, match="an impossible amount"):
            require_memory(nbytes, "this", "that")


def test_format_bytes() -> None:
    assert [format_bytes(x) for x in (512, 3.2e6, 4.1e10, 2e21)] == [
        "512 B", "3.2 MB", "41 GB", "2e+09 TB"]


# --- the estimates are upper bounds of what is allocated ------------------------------------------
def _peak(fn):
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        out = fn()
        return out, tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("n", [1, 6])
def test_the_path_estimate_bounds_a_profiles_peak(n: int) -> None:
    w = np.zeros((2, n))
    w[1] = 1.0
    (_, q), peak = _peak(lambda: quintic(w, 1e-4, 0.2, 1.0))
    K = q.shape[0]
    assert K > 50_000
    estimate = PATH_BYTES * K * (n + 1)
    assert peak <= estimate, (peak, estimate)
    assert peak >= estimate / 4, (peak, estimate)  # an estimate, not a blanket refusal


@pytest.mark.parametrize("n", [2, 12])
def test_the_run_estimate_bounds_a_simulations_peak(n: int) -> None:
    """simulate, then the summary (bearing loads: the largest temporaries after the run)."""
    robot = random_chain(np.random.default_rng(1), n)
    # compiles (or loads) the loop and the summary's kernels: not the run's memory
    simulate(robot, np.zeros((3, n)), 0.001).summary()
    K = 20_000
    q = np.linspace(0.0, 0.01, K)[:, None] * np.ones(n)
    q.setflags(write=False)  # as a program's path: simulate copies it

    def run():
        res = simulate(robot, q, 0.001)
        res.summary()
        return res

    _, peak = _peak(run)
    estimate = 8.0 * K * (32 * n + 12)  # simulate._require_memory
    assert peak <= estimate, (peak, estimate)
    assert peak >= estimate / 3, (peak, estimate)


# --- refusals before allocating -------------------------------------------------------------------
def test_simulate_refuses_a_run_over_the_budget(small_budget) -> None:
    robot = random_chain(np.random.default_rng(2), 6)
    q = np.zeros((10_000, 6))
    with pytest.raises(StateError, match=r"^simulating 1e\+04 cycles of 6 joints needs about "
                                         r"16\.3 MB of memory, more than the 1 MB mrnea may use "
                                         r".*coarser dt or a shorter program"):
        simulate(robot, q, 0.001)


def test_paths_are_refused_before_they_are_made() -> None:
    """5e8 cycles: refused at once, on any machine (it would need ~170 GB)."""
    start = time.perf_counter()
    for profile, vmax in ((quintic, 3.75e-7), (trapezoidal, 2e-7)):  # 5e6 s at 10 ms
        with pytest.raises(StateError, match=r"^a path of 5e\+08 cycles of 6 joints needs about "):
            profile(np.array([[0.0] * 6, [1.0] * 6]), 0.01, vmax, np.inf)
    assert time.perf_counter() - start < 5.0


def test_a_program_too_long_for_memory_names_the_file(small_budget) -> None:
    text = ('[program]\nrobot = "sdt"\ndt = 0.001\n[path]\nprofile = "quintic"\n'
            "waypoints = [[0, 0, 0, 0], [1, 0, 0, 0]]\nvelocity_limit = 0.1\n"
            "acceleration_limit = 1\n")
    with pytest.raises(ProgramFileError, match=r"^long\.toml: \[path\]: a path of 1\.88e\+04 "
                                               r"cycles of 4 joints needs about"):
        loads_program(text, source="long.toml")


def test_a_csv_resampled_too_finely_is_refused(tmp_path: Path, small_budget) -> None:
    p = tmp_path / "path.csv"
    p.write_text("t,q1\n0,0\n100,1\n")
    with pytest.raises(ProgramFileError, match=r"path\.csv: a path of 1e\+05 cycles of 1 joint "
                                               r"needs about"):
        from_csv(p, 0.001)


def test_a_csv_too_large_to_read_is_refused(tmp_path: Path, small_budget) -> None:
    p = tmp_path / "path.csv"
    p.write_text("t,q1\n" + "".join(f"{k},0.5\n" for k in range(20_000)))
    with pytest.raises(ProgramFileError, match=r"reading this 189 kB path CSV file needs "
                                               r"about .* split it"):
        from_csv(p, 0.1)


def test_the_demo_profile_is_refused_before_it_is_made(small_budget) -> None:
    with pytest.raises(StateError, match=r"^a path of 8\.4e\+04 cycles of 4 joints"):
        training_profile(0.0005)


# --- the command line -----------------------------------------------------------------------------
def test_cli_demo_with_a_tiny_dt(tmp_path: Path) -> None:
    line = one_error_line(mrnea("demo", "--dt", "1e-7", "--out", tmp_path / "o"),
                          "4.2e+08 cycles", "needs about", "GB of memory", "coarser dt")
    assert len(line) < 400
    one_error_line(mrnea("demo", "--dt", "1e-300", "--out", tmp_path / "o"), "cycles", "dt")
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_cli_csv_spanning_1e7_seconds(tmp_path: Path) -> None:
    (tmp_path / "long.csv").write_text("t,q1,q2,q3,q4\n0,0,0,0,0\n1e7,1,1,1,1\n")
    one_error_line(mrnea("check", "sdt", tmp_path / "long.csv", "--dt", "0.01"),
                   "long.csv", "1e+09 cycles of 4 joints", "needs about")


def test_cli_waypoint_program_of_5e8_cycles(tmp_path: Path) -> None:
    (tmp_path / "huge.toml").write_text(
        '[program]\nrobot = "sdt"\ndt = 0.01\n[path]\nprofile = "quintic"\n'
        "waypoints = [[0, 0, 0, 0], [1, 0, 0, 0]]\nvelocity_limit = 3.75e-7\n"
        "acceleration_limit = 1\n")
    one_error_line(mrnea("simulate", "sdt", tmp_path / "huge.toml", "--out", tmp_path / "o"),
                   "huge.toml", "[path]", "5e+08 cycles", "needs about")


# --- a long chain's figures -----------------------------------------------------------------------
def test_a_long_chains_figures_draw_twelve_joints() -> None:
    """40 joints, effort limits that some exceed: each figure has 12 rows of axes, those of the
    first infeasible joint and the joints that exceeded a limit most often, and says so."""
    from mrnea.report import plot_result
    from mrnea.report.drawing import MAX_JOINTS
    from mrnea.report.figures import shown_joints

    robot = random_chain(np.random.default_rng(3), 40).with_actuators(
        effort_limit=[1e6] * 35 + [0.5] * 5)
    K = 50
    res = simulate(robot, np.linspace(0.0, 0.05, K)[:, None] * np.ones(40), 0.01)
    bad = (res.saturated | res.position_clamped | res.velocity_clamped).sum(axis=0)
    shown = shown_joints(res)
    assert len(shown) == MAX_JOINTS == 12 and shown == sorted(shown)
    first = robot.joint_names.index(res.summary()["first_infeasible"]["joint"])
    assert first in shown
    assert 0 < np.count_nonzero(bad) <= 12 and set(np.flatnonzero(bad)) <= set(shown)
    start = time.perf_counter()
    figs = plot_result(res)
    assert time.perf_counter() - start < 30.0
    for name, fig in figs.items():
        rows = {round(ax.get_position().y0, 6) for ax in fig.axes if ax.get_title(loc="left")}
        assert len(rows) == MAX_JOINTS, name
        assert "12 of 40 joints" in fig._suptitle.get_text(), name


def test_idle_cpu_reads_the_runnable_tasks(monkeypatch: pytest.MonkeyPatch) -> None:
    """/proc/loadavg's runnable count against this process's CPUs: fewer, a CPU is idle."""
    import builtins
    import io

    cpus = len(os.sched_getaffinity(0))
    real_open = builtins.open
    for running, idle in ((1, cpus > 1), (cpus, False), (cpus + 5, False)):
        text = f"0.5 0.4 0.3 {running}/900 1234\n"
        monkeypatch.setattr(builtins, "open", lambda p, *a, _t=text, **k: io.StringIO(_t)
                            if p == "/proc/loadavg" else real_open(p, *a, **k))
        assert resources.idle_cpu() is idle, (running, cpus)


def test_idle_cpu_is_not_fooled_by_a_moment_s_busy_snapshot(monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    """One busy snapshot (a task runnable for a moment, seen after every fresh demo's
    compiling) and then an idle one: a CPU is idle. Busy in every one of the IDLE_READS
    snapshots: not idle, after reading each."""
    import builtins
    import io

    cpus = len(os.sched_getaffinity(0))
    real_open = builtins.open
    for counts, idle in (([cpus, cpus - 1], True), ([cpus] * resources.IDLE_READS, False)):
        reads = iter(counts)
        seen = []

        def fake(p, *a, _reads=reads, _seen=seen, **k):
            if p != "/proc/loadavg":
                return real_open(p, *a, **k)
            _seen.append(1)
            return io.StringIO(f"0.5 0.4 0.3 {next(_reads)}/900 1234\n")

        monkeypatch.setattr(builtins, "open", fake)
        assert resources.idle_cpu() is idle, counts
        assert len(seen) == len(counts)
