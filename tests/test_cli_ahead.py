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
    ahead_names = {u.kernel.py_func.__qualname__
                   for u in ahead.signatures((-1, 0, 1, 2), False, True)}
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
    ahead_names = {u.kernel.py_func.__qualname__ for u in kernels}
    assert len(ahead_names) == 8
    assert [u.kernel.py_func.__qualname__ for u in kernels][:2] == ["program_requirement",
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
    ahead_names = {u.kernel.py_func.__qualname__
                   for u in ahead.signatures((-1, 0, 1, 2, 3, 4), False, False)}
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
    ahead_names = {u.kernel.py_func.__qualname__
                   for u in ahead.signatures((-1, 0, 1, 2), False, False)}
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
    assert second is not None and second.args == ([-1, 0, 1, 2], False, True, False, False)
    assert started[-1][1:-1] == ["-m", "mrnea.cli.ahead", "-1,0,1,2", "0", "1", "0", "0"]
    assert started[-1][-1] == second.claims and os.path.isdir(second.claims)  # its claims
    monkeypatch.setattr(ahead.os, "getloadavg", lambda: (2.1, 0.5, 0.5))  # saturated
    monkeypatch.setattr(ahead, "idle_cpu", lambda: False)  # and no CPU idle now
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    monkeypatch.setattr(ahead, "idle_cpu", lambda: True)  # the last minute's job has ended
    assert ahead.start((-1, 0, 1, 2), False, True) is not None
    monkeypatch.setattr(ahead, "idle_cpu", lambda: False)
    monkeypatch.setenv("MRNEA_AHEAD", "1")  # on whatever the load
    assert ahead.start((-1, 0, 1, 2), True, False, retime=True) is not None
    assert started[-1][1:-1] == ["-m", "mrnea.cli.ahead", "-1,0,1,2", "1", "0", "1", "0"]
    monkeypatch.setattr(ahead.os, "getloadavg", lambda: (0.0, 0.0, 0.0))
    monkeypatch.setenv("MRNEA_AHEAD", "0")  # off
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    monkeypatch.delenv("MRNEA_AHEAD")
    monkeypatch.setattr(ahead.os, "sched_getaffinity", lambda pid: {0})  # one CPU
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    monkeypatch.setattr(ahead.os, "sched_getaffinity", lambda pid: {0, 1})
    monkeypatch.setattr(ahead, "cold_cache", lambda: False)  # a warm cache
    assert ahead.start((-1, 0, 1, 2), False, True) is None
    assert len(started) == 3


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


def _units(compiled: list, then: dict | None = None) -> list:
    """A shared list as signatures() makes it: 0 the start check, 4 the step after 0 and the
    drive solve 1, 5 the loop after the step and the reactions 3, 6 and 7 what the
    simulation's chunks call (the command's share ends there), 8 the summary's peaks."""
    then = then or {}
    names = ["check", "solve", "cholesky", "reactions", "step", "loop", "requirement",
             "derived", "peaks"]
    after = {4: (0, 1), 5: (4, 3)}
    return [ahead.Unit(_Kernel(name, compiled, then.get(name)), (), after.get(i, ()))
            for i, name in enumerate(names)]


class _Proc:
    def __init__(self, code=None) -> None:
        self.code = code

    def poll(self):
        return self.code


def _claims(tmp_path, name: str, *files: str):
    folder = tmp_path / name
    folder.mkdir()
    for f in files:
        (folder / f).touch()
    return folder


def test_the_command_takes_what_is_ready_up_to_what_its_simulation_calls(monkeypatch,
                                                                          tmp_path) -> None:
    """share(): the start check first (unit 0), then the units neither process has begun, each
    once the units it calls are done, up to what the simulation's chunks call; the rest stays
    with the second process. A file marks each claim, another each compile."""
    simulation = importlib.import_module("mrnea.achievable")  # the module, not mrnea.simulate()
    compiled, checked = [], []
    monkeypatch.setattr(simulation, "check_moves", lambda robot, q0: checked.append(q0))
    claims = _claims(tmp_path, "a", "1")  # the second process: on the drive solve
    units = _units(compiled, {"reactions": (claims / "1.done").touch})  # done meanwhile
    monkeypatch.setattr(ahead, "signatures", lambda *args: units)
    second = ahead.Ahead(_Proc(), str(claims), ((-1, 0), False, True, False, True))
    ahead.share(second, "robot", "q0")
    assert checked == ["q0"]
    assert compiled == ["cholesky", "reactions", "step", "loop", "requirement", "derived"]
    assert {f for f in os.listdir(claims) if f[0] == "8"} == set()  # the second process's
    ahead.share(None, "robot", "q0")  # no second process: nothing here
    ahead.share(second._replace(args=((-1, 0), False, True, False, False)), "robot", "q0")
    assert checked == ["q0"]  # nor with one that does not share (another engine or mode)


def test_the_command_waits_for_what_the_second_process_is_compiling(monkeypatch,
                                                                     tmp_path) -> None:
    """With every other unit taken, the loop waiting for the step the second process is
    compiling: the command waits for it (no second compile of it); with the second process
    ended it stops sharing."""
    import threading

    simulation = importlib.import_module("mrnea.achievable")
    monkeypatch.setattr(simulation, "check_moves", lambda robot, q0: None)
    compiled = []
    monkeypatch.setattr(ahead, "signatures", lambda *args: _units(compiled))
    claims = _claims(tmp_path, "b", "1", "1.done", "4")  # the solve done, the step begun
    timer = threading.Timer(0.3, (claims / "4.done").touch)
    timer.start()
    ahead.share(ahead.Ahead(_Proc(), str(claims), ((-1, 0), False, True, False, True)), "r",
                "q0")
    timer.join()
    assert compiled == ["cholesky", "reactions", "requirement", "derived", "loop"]
    compiled.clear()
    claims = _claims(tmp_path, "c", "1", "1.done", "4")  # the step never done: ended
    ahead.share(ahead.Ahead(_Proc(0), str(claims), ((-1, 0), False, True, False, True)), "r",
                "q0")
    assert compiled == []  # the second process gone: simulate compiles each as it needs it


def test_the_command_waits_for_what_its_simulation_and_summary_call(monkeypatch,
                                                                     tmp_path) -> None:
    """The second process compiling the requirement (6) as the command's share ends: share()
    returns once it is compiled (the simulation's first chunk calls it); after the simulation
    settle() waits for the peaks (8) it is compiling, which the summary calls: no kernel
    compiled twice. While waiting, each does the command's own work (``meanwhile``: the
    report's imports) once. Neither waits for the second process once it has ended, nor for
    a unit it has not begun; unshared, settle() does nothing."""
    import threading

    simulation = importlib.import_module("mrnea.achievable")
    monkeypatch.setattr(simulation, "check_moves", lambda robot, q0: None)
    compiled = []
    monkeypatch.setattr(ahead, "signatures", lambda *args: _units(compiled))
    claims = _claims(tmp_path, "g", "1", "1.done", "4", "4.done", "5", "5.done", "6")
    second = ahead.Ahead(_Proc(), str(claims), ((-1, 0), False, True, False, True))
    timer = threading.Timer(0.4, (claims / "6.done").touch)
    timer.start()
    done = []

    def broken() -> None:
        raise ImportError("its error is its caller's, where the work is needed")

    meanwhile = [lambda: done.append("import"), broken, lambda: done.append("more")]
    ahead.share(second, "r", "q0", meanwhile)
    assert (claims / "6.done").exists()  # waited for it, doing the command's own work first
    timer.join()
    assert compiled == ["cholesky", "reactions", "derived"]
    assert done == ["import", "more"] and meanwhile == []  # each task once
    (claims / "8").touch()  # the second process begins the peaks
    timer = threading.Timer(0.4, (claims / "8.done").touch)
    timer.start()
    meanwhile = [lambda: done.append("after")]
    ahead.settle(second, meanwhile)
    assert (claims / "8.done").exists() and done[-1] == "after"
    timer.join()
    assert compiled == ["cholesky", "reactions", "derived"]  # none compiled by the command
    (claims / "9").touch()  # begun, never done: no wait without the second process
    ahead.settle(second._replace(proc=_Proc(0)))
    ahead.settle(second._replace(args=((-1, 0), False, True, False, False)))  # unshared
    ahead.settle(None)


def test_the_second_process_takes_what_the_command_has_not(monkeypatch, tmp_path) -> None:
    """The second process never takes the start check, waits for what a unit calls (the
    reactions the command is compiling), and, shared, keeps its priority (the command may
    wait for it); without a claims' folder it compiles its whole list in order."""
    import threading

    compiled, niced = [], []
    monkeypatch.setattr(ahead.os, "nice", niced.append)  # not this test process's priority
    monkeypatch.setattr(ahead, "signatures", lambda *args: _units(compiled))
    claims = _claims(tmp_path, "d", "0", "0.done", "3")  # the command's check, its reactions
    timer = threading.Timer(0.3, (claims / "3.done").touch)
    timer.start()
    ahead.main(["-1,0,1", "0", "1", "0", "1", str(claims)])
    timer.join()
    assert compiled == ["solve", "cholesky", "step", "requirement", "derived", "peaks", "loop"]
    assert niced == []
    compiled.clear()
    ahead.main(["-1,0,1", "0", "1"])  # no claims' folder: the whole list
    assert compiled == ["check", "solve", "cholesky", "reactions", "step", "loop",
                        "requirement", "derived", "peaks"]
    assert niced == [10]


@pytest.mark.slow
@pytest.mark.parametrize("command", [("demo",), ("simulate", "examples/puma_pick.toml"),
                                     ("simulate", "examples/waist_left_swing.toml")])
def test_a_shared_run_on_the_cache_its_list_filled_compiles_none_of_it(tmp_path,
                                                                       command) -> None:
    """The shared list (the start check, the loop's step and top, ...) has the argument types
    the command's calls give, on a chain (the SDT demo; a program file's read-only rows, the
    Puma 560) and a tree (the two-armed torso): on the cache ``ahead.main`` filled with the
    whole list, the command compiles none of its kernels (a drifted signature would make both
    processes compile a kernel on a fresh run)."""
    import mrnea

    root = Path(__file__).resolve().parents[1]
    if command[0] == "demo":
        parents = (-1, 0, 1, 2)
    else:
        parents = mrnea.load_program(root / command[1]).load_robot().parents
    tree = any(p != i - 1 for i, p in enumerate(parents))
    assert tree == (command[1:] == ("examples/waist_left_swing.toml",))  # the torso branches
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "MRNEA_AHEAD": "0"}
    subprocess.run([sys.executable, "-m", "mrnea.cli.ahead", ",".join(map(str, parents)), "0",
                    "1", "0", "1"], env=env, check=True, timeout=900)
    out = subprocess.run([sys.executable, "-c", CLI_COMPILES, *command, "--out",
                          str(tmp_path / "run"), "--quiet"], env=env, capture_output=True,
                         text=True, timeout=900, cwd=root)
    assert out.returncode in (0, 1), out.stderr[-2000:]  # a verdict
    compiled = {name for name, _ in compiled_kernels(out.stdout)}
    units = ahead.signatures(parents, False, True, shared=True)
    names = {u.kernel.py_func.__qualname__ for u in units}
    assert {"actuator_terms", "step", "simulate_cycles", "solve_cycle"} <= names
    assert not compiled & names, compiled & names


def test_a_unit_that_no_longer_types_costs_time_never_the_command(monkeypatch,
                                                                   tmp_path) -> None:
    """A kernel of the list whose compile fails (its signature drifted): the command goes on,
    the unit is marked done (its callers compile it), and the units after it do not wait."""
    simulation = importlib.import_module("mrnea.achievable")
    monkeypatch.setattr(simulation, "check_moves", lambda robot, q0: None)
    compiled = []

    def drifted() -> None:
        raise TypeError("no matching definition")

    monkeypatch.setattr(ahead, "signatures", lambda *args: _units(compiled, {"step": drifted}))
    claims = _claims(tmp_path, "e", "1", "1.done")
    ahead.share(ahead.Ahead(_Proc(), str(claims), ((-1, 0), False, True, False, True)), "r",
                "q0")
    assert compiled == ["cholesky", "reactions", "step", "loop", "requirement", "derived"]
    assert (claims / "4.done").exists()


def test_no_temporary_folder_means_no_second_process(monkeypatch) -> None:
    """No temporary folder to be had (a full or read-only TMPDIR): the command compiles alone
    instead of failing."""
    started = []

    def mkdtemp(**kw):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(ahead.subprocess, "Popen", lambda *a, **kw: started.append(a))
    monkeypatch.setattr(ahead, "cold_cache", lambda: True)
    monkeypatch.setenv("MRNEA_AHEAD", "1")
    monkeypatch.setattr(ahead.tempfile, "mkdtemp", mkdtemp)
    assert ahead.start((-1, 0, 1, 2), False, True, shared=True) is None
    assert started == []


def test_the_second_process_stops_when_its_command_is_gone(monkeypatch, tmp_path) -> None:
    """The command ended (its claims' folder removed; or killed: another parent): the second
    process stops after the kernel it is compiling instead of compiling the rest for no one."""
    import shutil

    compiled = []
    claims = _claims(tmp_path, "f", "0", "0.done")
    gone = {"solve": lambda: shutil.rmtree(claims)}
    monkeypatch.setattr(ahead, "signatures", lambda *args: _units(compiled, gone))
    ahead.main(["-1,0,1", "0", "1", "0", "1", str(claims)])
    assert compiled == ["solve"]
