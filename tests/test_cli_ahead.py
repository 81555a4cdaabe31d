"""Compiling ahead on a cold cache (mrnea.cli.ahead, issue 22).

The second process's signatures are those the command's calls give: on a cache it filled, a
real ``mrnea demo`` process compiles none of its kernels (Numba's own ``numba:compile`` events,
which a kernel loaded from the cache does not raise). When it starts (a cold cache, a core to
spare) and when it does not.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import CLI_COMPILES, COMPILE_LISTENER, COMPILE_REPORT, compiled_kernels

from mrnea.cli import ahead
from mrnea.compiled import cold_cache

AHEAD_MAIN = r"""
event.register("numba:compile", Record())
from mrnea.cli import ahead
ahead.main(sys.argv[1:])
""" + COMPILE_REPORT


@pytest.mark.slow
def test_a_demo_on_the_cache_it_filled_compiles_none_of_its_kernels(tmp_path) -> None:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "0"}
    sdt_parents, report = "-1,0,1,2", "1"
    filled = subprocess.run(
        [sys.executable, "-c", COMPILE_LISTENER + AHEAD_MAIN, sdt_parents, "0", report],
        env=env, check=True, capture_output=True, text=True, timeout=900)
    # the other way round: it compiles none of the kernels the command compiles first (its
    # critical path: the mRNEA's tree, the loop and its step), so no kernel is compiled by both
    own = {name.rsplit(".", 1)[-1] for name, _ in compiled_kernels(filled.stdout)}
    assert not own & {"actuator_terms", "pass_of", "simulate_cycles", "step"}, own
    out = subprocess.run([sys.executable, "-c", CLI_COMPILES, "demo", "--out",
                          str(tmp_path / "demo"), "--quiet"], env=env, capture_output=True,
                         text=True, timeout=900)
    assert out.returncode in (0, 1), out.stderr[-2000:]  # a verdict
    compiled = {name for name, _ in compiled_kernels(out.stdout)}
    ahead_names = {k.py_func.__qualname__
                   for k, _ in ahead.signatures((-1, 0, 1, 2), False, True)}
    assert len(ahead_names) == 8
    assert not compiled & ahead_names, compiled & ahead_names
    assert "simulate_cycles" in compiled and "actuator_terms" in compiled  # it did compile


@pytest.mark.slow
def test_a_retime_on_the_cache_it_filled_compiles_none_of_its_kernels(tmp_path) -> None:
    """The retiming's order (the program's requirement second) and signatures: those of the
    retiming's own calls (its cycle-resolution check, the verifying simulation, the report)."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "0"}
    puma_parents = "-1,0,1,2,3,4"
    subprocess.run([sys.executable, "-m", "mrnea.cli.ahead", puma_parents, "0", "1", "1"],
                   env=env, check=True, timeout=900)
    out = subprocess.run([sys.executable, "-c", CLI_COMPILES, "retime", "puma560",
                          "examples/puma_pick.toml", "--out", str(tmp_path / "retime"),
                          "--quiet"], env=env, capture_output=True, text=True, timeout=900,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode in (0, 1), out.stderr[-2000:]  # a verdict
    compiled = {name for name, _ in compiled_kernels(out.stdout)}
    kernels = ahead.signatures((-1, 0, 1, 2, 3, 4), False, True, retime=True)
    ahead_names = {k.py_func.__qualname__ for k, _ in kernels}
    assert len(ahead_names) == 8
    assert [k.py_func.__qualname__ for k, _ in kernels][:2] == ["program_requirement",
                                                              "solve_cycle"]
    assert not compiled & ahead_names, compiled & ahead_names
    assert "simulate_cycles" in compiled and "controllable_sets" in compiled  # it did compile


@pytest.mark.slow
def test_an_excite_on_the_cache_it_filled_compiles_none_of_its_kernels(tmp_path) -> None:
    """``mrnea excite`` starts it before its search (no reactions wanted, no report): its
    verifying simulation then loads every kernel the second process compiled."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "0"}
    subprocess.run([sys.executable, "-m", "mrnea.cli.ahead", "-1,0,1,2,3,4", "0", "0"],
                   env=env, check=True, timeout=900)
    out = subprocess.run([sys.executable, "-c", CLI_COMPILES, "excite", "puma560", "--out",
                          str(tmp_path / "excite"), "--quiet"], env=env, capture_output=True,
                         text=True, timeout=900)
    assert out.returncode in (0, 1), out.stderr[-2000:]  # a verdict
    compiled = {name for name, _ in compiled_kernels(out.stdout)}
    ahead_names = {k.py_func.__qualname__
                   for k, _ in ahead.signatures((-1, 0, 1, 2, 3, 4), False, False)}
    assert len(ahead_names) == 6
    assert not compiled & ahead_names, compiled & ahead_names
    assert "simulate_cycles" in compiled and "regressor_batch" in compiled  # it did compile
    # its effort checks one state at a time on the simulation's kernel, not the parallel batch
    assert "actuator_terms" in compiled and "actuator_terms_batch" not in compiled


@pytest.mark.slow
def test_a_size_on_the_cache_it_filled_compiles_none_of_its_kernels(tmp_path) -> None:
    """``mrnea size`` starts it (no reactions, no report): the verifying simulation of the sized
    robot, and the program's requirement, load every kernel the second process compiled."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "0"}
    subprocess.run([sys.executable, "-m", "mrnea.cli.ahead", "-1,0,1,2", "0", "0"],
                   env=env, check=True, timeout=900)
    out = subprocess.run([sys.executable, "-c", CLI_COMPILES, "size", "sdt", "demo",
                          "--catalogue", "examples/drives_catalogue.toml", "--joints", "cab_yaw",
                          "--out", str(tmp_path / "size"), "--quiet"], env=env,
                         capture_output=True, text=True, timeout=900,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.returncode in (0, 1), out.stderr[-2000:]  # a verdict
    compiled = {name for name, _ in compiled_kernels(out.stdout)}
    ahead_names = {k.py_func.__qualname__
                   for k, _ in ahead.signatures((-1, 0, 1, 2), False, False)}
    assert not compiled & ahead_names, compiled & ahead_names
    assert "simulate_cycles" in compiled  # it did compile


def test_size_starts_it_for_its_robot(monkeypatch, tmp_path) -> None:
    from click.testing import CliRunner

    from mrnea.cli import main

    calls = []

    def start(*args, **kw):  # records, then stops the command before it computes anything
        calls.append(args)
        raise SystemExit(0)

    monkeypatch.setattr(ahead, "start", start)
    catalogue = Path(__file__).resolve().parents[1] / "examples" / "drives_catalogue.toml"
    res = CliRunner().invoke(main, ["size", "sdt", "demo", "--catalogue", str(catalogue),
                                    "--out", str(tmp_path / "s"), "--quiet"])
    assert res.exit_code == 0, res.output
    assert calls == [((-1, 0, 1, 2), False, False)]


def test_it_starts_only_on_a_cold_cache_with_a_core_to_spare(monkeypatch) -> None:
    started = []

    class Popen:  # records the command instead of starting it
        def __init__(self, args, **kw) -> None:
            started.append(args)

        def poll(self) -> int:
            return 0

    monkeypatch.setattr(ahead.subprocess, "Popen", Popen)
    monkeypatch.delenv("MRNEA_AHEAD", raising=False)
    monkeypatch.setattr(ahead, "cold_cache", lambda: True)
    monkeypatch.setattr(ahead.os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setattr(ahead.os, "getloadavg", lambda: (1.2, 0.5, 0.5))
    second = ahead.start((-1, 0, 1, 2), False, True)
    assert second is not None and second.args == ([-1, 0, 1, 2], False, True, False)
    assert started[-1][1:-1] == ["-m", "mrnea.cli.ahead", "-1,0,1,2", "0", "1", "0"]
    assert started[-1][-1] == second.claims and os.path.isdir(second.claims)  # its claims
    monkeypatch.setattr(ahead.os, "getloadavg", lambda: (2.1, 0.5, 0.5))  # saturated
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    monkeypatch.setenv("MRNEA_AHEAD", "1")  # on whatever the load
    assert ahead.start((-1, 0, 1, 2), True, False, retime=True) is not None
    assert started[-1][1:-1] == ["-m", "mrnea.cli.ahead", "-1,0,1,2", "1", "0", "1"]
    monkeypatch.setattr(ahead.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    monkeypatch.setenv("MRNEA_AHEAD", "0")  # off
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    monkeypatch.delenv("MRNEA_AHEAD")
    monkeypatch.setattr(ahead.os, "sched_getaffinity", lambda pid: {0})  # one CPU
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    monkeypatch.setattr(ahead.os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setattr(ahead, "cold_cache", lambda: False)  # a warm cache
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    assert len(started) == 2


def test_cold_reads_the_simulation_loops_cache_index(tmp_path) -> None:
    """A cache index of simulate_cycles means warm; its absence, cold (a fresh process on an
    empty cache folder)."""
    code = "from mrnea.compiled import cold_cache; print(cold_cache())"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "empty")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=300, check=True)
    assert out.stdout.strip() == "True"
    from mrnea.kernels.simulate import simulate_cycles

    index = simulate_cycles._cache._cache_file._index_path
    if os.path.exists(index):  # this process's cache, filled by the suite
        assert not cold_cache()


def test_a_sweep_warms_one_worker_first_on_a_cold_cache(monkeypatch) -> None:
    """sweep/engine.py: on a cold cache one worker compiles and the others then load (none
    compiles what another does); on a warm cache all at once."""
    from mrnea.sweep import engine

    workers = ["tcp://a:1", "tcp://b:2", "tcp://c:3"]
    monkeypatch.setattr(engine, "cold_cache", lambda: True)
    assert engine._warm_order(workers) == (workers[:1], workers[1:])
    monkeypatch.setattr(engine, "cold_cache", lambda: False)
    assert engine._warm_order(workers) == (workers, [])


class _Kernel:
    """Stands for a Numba dispatcher in the claims' tests: records its compile."""

    def __init__(self, name: str, compiled: list, then=None) -> None:
        self.name, self.compiled, self.then = name, compiled, then

    def compile(self, sig) -> None:
        self.compiled.append(self.name)
        if self.then is not None:
            self.then()


def test_the_command_takes_what_the_second_process_has_not_begun(monkeypatch, tmp_path) -> None:
    """share(): the start check's kernel first, then the list's kernels the second process has
    not claimed, in order, until it has compiled the drive solve; each claimed file marks it."""
    from mrnea.kernels.drive_solve import solve_cycle

    simulation = importlib.import_module("mrnea.simulate")  # the module, not mrnea.simulate()

    claims = tmp_path / "claims"
    claims.mkdir()
    (claims / "0").touch()  # the second process: done with the first, compiling the solve
    (claims / "0.done").touch()
    (claims / "1").touch()
    compiled, checked = [], []
    kernels = [_Kernel("cholesky", compiled), solve_cycle,
               _Kernel("reactions", compiled, then=(claims / "1.done").touch),  # solve done
               _Kernel("requirement", compiled)]
    monkeypatch.setattr(ahead, "signatures", lambda *args: [(k, ()) for k in kernels])
    monkeypatch.setattr(simulation, "check_moves", lambda robot, q0: checked.append(q0))
    second = ahead.Ahead(None, str(claims), ((-1, 0), False, True, False))
    ahead.share(second, "robot", "q0")
    assert checked == ["q0"] and compiled == ["reactions"]
    assert sorted(os.listdir(claims)) == ["0", "0.done", "1", "1.done", "2", "2.done"]
    ahead.share(None, "robot", "q0")  # no second process: nothing here
    assert checked == ["q0"] and compiled == ["reactions"]


def test_the_second_process_skips_what_the_command_claimed(monkeypatch, tmp_path) -> None:
    compiled = []
    kernels = [_Kernel(name, compiled) for name in ("cholesky", "solve", "reactions")]
    monkeypatch.setattr(ahead, "signatures", lambda *args: [(k, ()) for k in kernels])
    monkeypatch.setattr(ahead.os, "nice", lambda inc: 0)  # not this test process's priority
    claims = tmp_path / "claims"
    claims.mkdir()
    (claims / "2").touch()  # the command's
    ahead.main(["-1,0,1", "0", "1", "0", str(claims)])
    assert compiled == ["cholesky", "solve"]
    assert sorted(os.listdir(claims)) == ["0", "0.done", "1", "1.done", "2"]
    compiled.clear()
    ahead.main(["-1,0,1", "0", "1"])  # no claims' folder: the whole list
    assert compiled == ["cholesky", "solve", "reactions"]


@pytest.mark.slow
def test_a_fresh_demo_with_the_second_process_compiles_each_kernel_once(tmp_path) -> None:
    """A fresh demo sharing the list with the second process (forced on, empty cache): the
    command's start check compiles ``actuator_terms`` for the types its simulation calls it
    with (one signature), and a second demo on the cache the two processes filled compiles
    nothing."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "1"}
    runs = []
    for k in range(2):
        out = subprocess.run([sys.executable, "-c", CLI_COMPILES, "demo", "--out",
                              str(tmp_path / f"demo{k}"), "--quiet"], env=env,
                             capture_output=True, text=True, timeout=900)
        assert out.returncode in (0, 1), out.stderr[-2000:]  # a verdict
        runs.append(compiled_kernels(out.stdout))
    first, second = runs
    assert [sig for name, sig in first if name == "actuator_terms"] != []
    assert len([sig for name, sig in first if name == "actuator_terms"]) == 1, first
    assert "simulate_cycles" in {name for name, _ in first}
    assert second == [], second
