"""The library's compile notice (mrnea/compiled.py): one line on stderr the first time in a process
that Numba compiles one of mrnea's kernels, nothing on a warm cache, nothing for the caller's own
Numba functions, off with ``MRNEA_COMPILE_NOTICE=0`` or the ``"mrnea"`` logger's level; the
``mrnea`` command says it in its own words instead."""

from __future__ import annotations

import gc
import logging
import os
import subprocess
import sys

import numba
import pytest

from mrnea import compiled
from mrnea.compiled import COMPILE_NOTICE


def _mrnea_kernel(k: int):
    """A fresh (never compiled) Numba function that Numba sees as one of mrnea's."""

    def f(x):
        return x + k

    f.__module__ = "mrnea.kernels.fake"
    return numba.njit(cache=False)(f)


def _user_kernel():
    @numba.njit(cache=False)
    def g(x):
        return x * 2

    return g


def test_said_once_per_process_for_mrnea_kernels_only(monkeypatch, caplog) -> None:
    monkeypatch.delenv("MRNEA_COMPILE_NOTICE", raising=False)
    monkeypatch.setattr(compiled._CompileNotice, "shown", False)
    caplog.set_level(logging.INFO, logger="mrnea")
    _user_kernel()(1)  # the caller's own function: nothing to say
    assert not caplog.records
    k = _mrnea_kernel(1)
    k(1)
    k(2.0)  # a second compilation
    _mrnea_kernel(2)(1)  # and a third kernel
    notices = [r for r in caplog.records if r.getMessage() == COMPILE_NOTICE]
    assert len(notices) == 1 and notices[0].levelno == logging.WARNING
    assert notices[0].name == "mrnea"


def test_off_with_the_environment_variable(monkeypatch, caplog) -> None:
    monkeypatch.setenv("MRNEA_COMPILE_NOTICE", "0")
    monkeypatch.setattr(compiled._CompileNotice, "shown", False)
    caplog.set_level(logging.INFO, logger="mrnea")
    _mrnea_kernel(3)(1)
    assert not caplog.records


SCRIPT = """
import sys
import numba
import numpy as np
import mrnea
from mrnea.actuators import motor_torque

numba.njit(cache=False)(lambda x: x + 1)(1)  # the caller's own function
sys.stderr.write("user done\\n")
robot = mrnea.robots.puma560()
motor_torque(robot, np.ones(robot.n), np.ones(robot.n))  # compiles drive.motor_torques
mrnea.forward_kinematics(robot, np.zeros(robot.n))  # compiles the frames: a second kernel
sys.stderr.write("end\\n")
"""


@pytest.mark.parametrize("level", [None, "ERROR"])
def test_one_line_on_a_cold_cache_none_on_a_warm_one(tmp_path, level) -> None:
    """A real process on an empty Numba cache, then again on the cache it filled; with the
    ``"mrnea"`` logger at ERROR, nothing either time."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    env.pop("MRNEA_COMPILE_NOTICE", None)
    script = SCRIPT if level is None else (
        f"import logging; logging.getLogger('mrnea').setLevel(logging.{level})\n{SCRIPT}")
    cold, warm = (subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                                 text=True, timeout=600) for _ in range(2))
    assert cold.returncode == 0 and warm.returncode == 0, cold.stderr[-2000:]
    said = [] if level else [COMPILE_NOTICE]
    assert cold.stderr.splitlines() == ["user done", *said, "end"]
    assert warm.stderr.splitlines() == ["user done", "end"]


COMMAND = """
import os
import numba
from mrnea.cli import main

main(["info", "puma560"], standalone_mode=False)
def f(x):
    return x + 1
f.__module__ = "mrnea.kernels.fake"  # what Numba compiles later in the command's process
numba.njit(cache=False)(f)(1)
print("children get", os.environ.get("MRNEA_COMPILE_NOTICE"))  # a child inherits os.environ
"""


def test_the_command_and_its_children_leave_it_to_the_command() -> None:
    """The ``mrnea`` command prints its own notice (mrnea/cli/base.py ``compile_notice``, never
    with --quiet); the library's is off in its process and the processes it starts (the
    compile-ahead process, a sweep's workers)."""
    env = {k: v for k, v in os.environ.items() if k != "MRNEA_COMPILE_NOTICE"}
    res = subprocess.run([sys.executable, "-c", COMMAND], env=env, capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert COMPILE_NOTICE not in res.stderr
    assert res.stdout.splitlines()[-1] == "children get 0"


class _Thresholds(numba.core.event.Listener):
    """The collector's thresholds each time Numba starts compiling (listeners are called in
    the order they were registered: mrnea's first, at its import)."""

    def __init__(self) -> None:
        self.seen: list[tuple[int, ...]] = []

    def on_start(self, ev) -> None:
        self.seen.append(gc.get_threshold())

    def on_end(self, ev) -> None:
        pass


def test_collector_runs_less_often_while_a_kernel_compiles_then_as_before() -> None:
    from numba.core import event
    from numba.core.errors import TypingError

    caller = (900, 11, 12)  # the caller's own thresholds, not Python's defaults
    before = gc.get_threshold()
    gc.set_threshold(*caller)
    try:
        spy = _Thresholds()
        with event.install_listener("numba:compile", spy):
            _user_kernel()(1)  # the caller's function: its thresholds untouched
            _mrnea_kernel(7)(1)

            def bad(x):
                return x + "a"  # no such addition: Numba's typing fails

            bad.__module__ = "mrnea.kernels.fake"
            with pytest.raises(TypingError):
                numba.njit(cache=False)(bad)(1)
            after = gc.get_threshold()
    finally:
        gc.set_threshold(*before)
    assert spy.seen == [caller, compiled.COMPILE_GC_THRESHOLD, compiled.COMPILE_GC_THRESHOLD]
    assert after == caller  # restored after a compile, a failed one included
