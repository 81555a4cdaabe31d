"""Compiling ahead on a cold cache: while a command compiles the simulation's first kernel, a
second process compiles the ones it needs later (issue 22, docs/performance.md).

On an empty Numba cache a command compiles its kernels one after another, on one core. The
simulation's first kernel, ``actuator_terms`` (H_a and u'_a: the mRNEA's whole call tree,
compiled by :func:`mrnea.simulate`'s start check), is about a third of a fresh ``mrnea demo``'s
compiling, and the simulation loop cannot start before it. Meanwhile :func:`start` runs
``python -m mrnea.cli.ahead`` in a second process, which compiles (``Dispatcher.compile``,
nothing run) the kernels the command reaches after it that do not contain it, each for exactly
the argument types the command's calls give it (:func:`signatures`): the drive solve of the
robot's way, the reactions, the program's requirement, the per-chunk derived arrays, the
summary's pass and, for a report, the bearing loads and the 3D view's frames. Numba's disk cache
is shared by the processes (each file is written whole, then renamed): when the command reaches
one of those kernels it loads it if the second process has finished it, and compiles it
itself otherwise: the same machine code either way, only the time differs. A signature here
that drifts from the callers' costs the second process's time and nothing else;
tests/test_cli_ahead.py checks that a command on a cache this module filled compiles none of
them.

It starts only where it can gain: the JIT on, a cold cache (no cache index of the simulation
loop yet: a warm run loads everything in about a second and starts nothing), and a core to
spare: at least two CPUs for this process, and a load average (last minute) below their number
or a CPU idle now.
On the 2-core machine at load 0.9-1.2 (the previous run's), a fresh demo took 18.4-19.1 s of
wall with it against 28.9-30.9 s without; on a saturated machine it only competes with the
command for a core: at load 5-6 it took 74-90 s of wall with it against 62 s without
(docs/performance.md). ``MRNEA_AHEAD=0`` in the environment turns it off,
``MRNEA_AHEAD=1`` on whatever the load (on a cold cache; benchmarks/first_run.py ``--no-ahead``,
``--ahead``). The second process is ended when the command exits
(:func:`start` registers it), whatever it has left; its output is discarded. Its list done,
it leaves at once (``os._exit``: no interpreter teardown), so that the core is idle when the
command draws its figures (report/pngs.py forks a child for a share of them only then).

``demo``, ``simulate`` and ``check`` (the paper's mRNEA, the hybrid mode) share the work with
it (``shared``, :func:`share`): the list then also holds the command's start check (unit 0,
the command's) and the simulation loop's two tops, the cycle's ``step`` and ``simulate_cycles``,
each marked with the units whose kernels it calls. Both processes run the same loop
(:func:`_work`): take the first unit in the list's order whose callees are compiled and which
neither has begun, claimed with a file named by its index in a temporary folder (created
exclusively; the second process's argument; removed when the command exits), compile it, mark
it done with a second file; wait while what is left waits for the other. The command's
share ends at what its simulation's chunks call (the loop, the requirement, the derived
arrays: it waits for those the other is compiling), and it runs; after the simulation it
waits for a later unit the other is compiling (:func:`settle`: the summary's peaks) rather
than compile it again. So no kernel is compiled by both, and the
loop's tops, whose compiling optimises and emits everything they call once more (Numba links
the callees' code into each caller), are compiled by whichever process is free first: a fresh
demo 14.1-15.7 s of wall and 26-28 s of CPU for both processes, against 17.5-20.5 s and 32-38 s
with the unshared list (docs/performance.md section 7). Shared, the second process keeps the
command's priority (the command may wait for it); the command shares for at most
:data:`PATIENCE` seconds.

``mrnea excite`` starts it before its search for the trajectory (which compiles the regressor
and runs for seconds), so that the verifying simulation at its end finds its later kernels
compiled. Unshared, the second process runs at a lower priority (``nice`` 10): where the command
needs both cores (excite's search runs the parallel regressor batch) it yields to it, and
elsewhere it takes the idle core as before (a first ``excite`` of the Puma 560: 22.8-24.0 s of
wall, against 29.3-29.7 s at the same priority and 31.7-33.1 s without it, session 37; with the
search's BLAS on one thread and its effort checks on ``actuator_terms``, 16.5-17.8 s; the demo,
retime, simulate and sweep unchanged by the priority; docs/performance.md section 7).

``mrnea size`` starts it before its sizing (whose programs' requirement it compiles itself
first): the verifying simulation of the sized robot finds the drive solve, the reactions and
the summary's kernels compiled (a first ``size sdt demo``: 14.6-14.8 s against 23.8 s).

``mrnea sweep`` starts it for a sweep on this machine's workers, of which one compiles on a
cold cache (mrnea/sweep/engine.py ``_warm_order``) while this process compiles the later
kernels: a fresh sweep of the Puma payload grid 16 s against 22 s.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple

from mrnea.compiled import cold_cache
from mrnea.resources import cpus, idle_cpu

if TYPE_CHECKING:
    import numpy as np

    from mrnea.model import Robot


def _spare_core() -> bool:
    """At least two CPUs for this process, and the last minute's load average below their
    number (the machine not saturated) or a CPU idle now (:func:`mrnea.resources.idle_cpu`):
    the load average still counts, for a minute, a job that has ended (the previous command's
    compiling: on the 2-core machine a fresh demo started 20 s after another found load 2.0,
    started no second process and took 19.8 s of wall, against 11.8-12.8 s with it)."""
    n = cpus()
    if n < 2:
        return False
    try:
        load = os.getloadavg()[0]
    except OSError:  # not available: a snapshot of the runnable tasks decides
        load = float("inf")
    return load < n or idle_cpu()


PATIENCE = 60.0
"""Seconds after which the command stops sharing (:func:`share`) and goes on, compiling what it
still needs as it reaches it (a second process stopped or starved; a fresh demo shares for about
10 s and waits for the other process a few seconds at most)."""


# the shared list's first units (signatures): the command's start check, then the drive solve,
# the Cholesky solve, the reactions, the cycle's step, the simulation loop, the per-chunk
# requirement and derived arrays (the command's share ends there); then the later ones
CHECK, SOLVE, CHOLESKY, REACTIONS, STEP, LOOP, REQUIREMENT, DERIVED = range(8)


class Ahead(NamedTuple):
    """The second process, the folder where both processes claim the units of its list (one
    empty file per unit, named by its index, created exclusively; ``INDEX.done`` once compiled)
    and the arguments of :func:`signatures` both give that list by."""
    proc: subprocess.Popen
    claims: str
    args: tuple

    @property
    def shared(self) -> bool:
        """Whether the command shares the list with it (:func:`share`)."""
        return bool(self.args[4])


class Unit(NamedTuple):
    """A kernel of the list, the argument types to compile it for, and the units whose kernels
    it calls and which must be compiled (in the cache) first, so that it compiles only its own
    code (its ``after``)."""
    kernel: Any
    sig: tuple
    after: tuple[int, ...] = ()


def start(parents: Sequence[int], per_link: bool, report: bool, retime: bool = False,
          shared: bool = False) -> Ahead | None:
    """Start the second process on a cold cache (module docstring) for a simulation of a robot
    whose joints hang from ``parents`` (:attr:`mrnea.Robot.parents`) with reactions (the CLI's),
    its wrench given per link (``per_link``) or not, with a report (``report``: bearing
    loads, 3D view), for a retiming (``retime``: :func:`signatures`' order), and shared with the
    command (``shared``: :func:`share`; a simulation by the paper's mRNEA). Returns it (with the
    folder of the two processes' claims), or None where it would not gain. Unshared, none of
    the kernels it compiles depends on the engine (``--fd``)."""
    wanted = os.environ.get("MRNEA_AHEAD")
    if wanted == "0" or not (wanted == "1" or _spare_core()) or not cold_cache():
        return None
    args = [",".join(map(str, parents)), *(str(int(x)) for x in (per_link, report, retime,
                                                                     shared))]
    try:
        claims = tempfile.mkdtemp(prefix="mrnea-ahead-")
    except OSError:  # no temporary folder (TMPDIR not writable): the command compiles alone
        return None
    try:
        proc = subprocess.Popen([sys.executable, "-m", "mrnea.cli.ahead", *args, claims],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:  # no process to spare: the command compiles alone
        shutil.rmtree(claims, ignore_errors=True)
        return None
    ahead = Ahead(proc, claims, (list(parents), per_link, report, retime, shared))
    atexit.register(_end, ahead)
    return ahead


def _claim(claims: str, i: int) -> bool:
    """Unit ``i`` of the list for the calling process, unless the other one has it."""
    try:
        os.close(os.open(os.path.join(claims, str(i)), os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except OSError:  # claimed by the other process (or the folder gone: the command ended)
        return False
    return True


def _compiled(claims: str, i: int) -> None:
    """Unit ``i`` compiled (in Numba's cache) by the calling process."""
    with contextlib.suppress(OSError):
        os.close(os.open(os.path.join(claims, f"{i}.done"), os.O_CREAT | os.O_WRONLY))


def _done(claims: str, i: int) -> bool:
    return os.path.exists(os.path.join(claims, f"{i}.done"))


def _alive(ahead: Ahead) -> Callable[[], bool]:
    """Whether the command still shares: the second process running, and :data:`PATIENCE`
    seconds from now not passed."""
    deadline = time.monotonic() + PATIENCE
    return lambda: ahead.proc.poll() is None and time.monotonic() < deadline


def _work(claims: str, units: Sequence[Unit], todo: list[int], alive: Callable[[], bool],
          meanwhile: list[Callable[[], object]] | None = None) -> None:
    """Compile, one after another, the units of ``todo`` this process claims first: each time
    the first in the list's order whose ``after`` units are done; a unit the other process
    claimed is its. With nothing to take now (what is left waits for a unit the other
    process is compiling) it waits. Until ``todo`` is empty (each unit compiled by this
    process or claimed by the other) or ``alive()`` is no longer true (the other process gone:
    a second process whose command was killed stops after its current kernel). ``meanwhile``:
    work to do instead of waiting (:func:`_wait`)."""
    while todo and alive():
        ready = [i for i in todo if all(_done(claims, j) for j in units[i].after)]
        if not ready:
            _wait(meanwhile)
            continue
        i = ready[0]
        todo.remove(i)
        if _claim(claims, i):
            # a list that no longer types (a kernel with a new argument: the slow tests of
            # tests/test_cli_ahead.py compile it whole) costs time, never the command: its
            # caller compiles the kernel, and the units after it do not wait
            with contextlib.suppress(Exception):
                units[i].kernel.compile(units[i].sig)
            _compiled(claims, i)


def share(ahead: Ahead | None, robot: Robot, q0: np.ndarray,
          meanwhile: list[Callable[[], object]] | None = None) -> None:
    """The command's share of the compiling, before its simulation (a second process started
    ``shared``): first the start check's kernel (H_a and u'_a, :func:`mrnea.achievable.check_moves`,
    unit 0: the second process never takes it), then, as the second process does, the units
    of the list neither has begun, each once the kernels it calls are compiled, up to what the
    simulation's chunks call (the loop, the requirement, the derived arrays: :data:`DERIVED`);
    where all that is left of those waits for the second process, or is being compiled by
    it, it waits. So no kernel is compiled by both, and neither process idles while the other
    compiles what the simulation needs (docs/performance.md section 7). ``meanwhile``: the
    command's own work that needs no kernel (importing what its report draws with), done
    where it would wait instead (each task once, taken from the list). Without a shared
    second process it does nothing: the command compiles each kernel as it reaches it."""
    if ahead is None or not ahead.shared:
        return
    from mrnea.achievable import check_moves

    check_moves(robot, q0)  # unit CHECK: never the second process's, so not claimed
    _compiled(ahead.claims, CHECK)
    alive, mine = _alive(ahead), range(CHECK + 1, DERIVED + 1)
    _work(ahead.claims, signatures(*ahead.args), list(mine), alive, meanwhile)
    _settle(ahead.claims, mine, alive, meanwhile)


def _wait(meanwhile: list[Callable[[], object]] | None) -> None:
    """A moment of waiting for the other process: the next of the command's ``meanwhile``
    tasks (taken from the list: each done once; its errors are its caller's later, where
    the task's work is needed), else 20 ms of sleep."""
    if meanwhile:
        with contextlib.suppress(Exception):
            meanwhile.pop(0)()
    else:
        time.sleep(0.02)


def _settle(claims: str, indices: Sequence[int], alive: Callable[[], bool],
            meanwhile: list[Callable[[], object]] | None = None) -> None:
    """Wait while one of the units ``indices`` is claimed and not compiled yet (by the other
    process: the calling one compiles its claims before it goes on) and ``alive()``: what is
    left of the other's compile is never longer than compiling the kernel again."""
    while alive() and any(os.path.exists(os.path.join(claims, str(i))) and not _done(claims, i)
                          for i in indices):  # claimed (the file _claim creates), not done
        _wait(meanwhile)


def settle(ahead: Ahead | None, meanwhile: list[Callable[[], object]] | None = None) -> None:
    """After the command's simulation (a second process started ``shared``): the later units
    of the list (the summary's peaks, the report's kernels) as :func:`share` does its own:
    each one neither has begun compiled here, and a wait while the second process compiles
    one, which the command would otherwise compile a second time as it reaches it; what is
    left of ``meanwhile`` done instead of waiting. Bounded by :data:`PATIENCE` and the second
    process's life; without a shared one it does nothing."""
    if ahead is None or not ahead.shared:
        return
    alive, later = _alive(ahead), range(DERIVED + 1, len(signatures(*ahead.args)))
    _work(ahead.claims, signatures(*ahead.args), list(later), alive, meanwhile)
    _settle(ahead.claims, later, alive, meanwhile)


def _end(ahead: Ahead) -> None:
    proc = ahead.proc
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            proc.kill()
    shutil.rmtree(ahead.claims, ignore_errors=True)


def signatures(parents: Sequence[int], per_link: bool, report: bool, retime: bool = False,
               shared: bool = False) -> list[Unit]:
    """The units (kernel, argument types, the units it calls) the command will call, in the
    order it reaches them: arrays of the dtypes, dimensions, layouts and read-only flags its
    callers pass (mrnea.simulate, kernels/simulate.py, kernels/achievable.py, summary.py,
    cycles.py, report/states.py).

    A retiming (``retime``) reaches the program's requirement before its simulation, in its
    cycle-resolution check (:func:`mrnea.retime.search.cycle_ratios`), as soon as its own
    compiling of ``actuator_terms`` and the TOPP-RA passes ends (about 13 s into a fresh
    ``mrnea retime`` on an idle 2-core machine), and the drive solve a second or two later,
    inside the simulation loop's compile: so the requirement comes first (5 s of compiling,
    ready at about 8 s), then the drive solve (5 s more). The retiming's own kernels
    (``kernels/topp.py``, the effort limits and their tangents: 2 s) are left to the command,
    which reaches them as ``actuator_terms`` ends: compiled here first, they would make the
    requirement late (docs/performance.md section 7, "A fresh ``mrnea retime``").

    Shared (``shared``, :func:`share`): unit 0 is the command's start check
    (``actuator_terms``), and the simulation loop's two tops join the list, each after what it
    calls: the cycle's ``step`` after the start check's kernel and the drive solve, and
    ``simulate_cycles`` after ``step`` and the reactions (the indices :data:`CHECK` ...
    :data:`LOOP`; then :data:`REQUIREMENT` and :data:`DERIVED`, the last of the command's
    share)."""
    import numba as nb
    import numpy as np

    from mrnea.kernels import bearing, peaks
    from mrnea.kernels.achievable import step
    from mrnea.kernels.derived import derived
    from mrnea.kernels.drive import actuator_terms
    from mrnea.kernels.drive_solve import HYBRID, solve_cycle
    from mrnea.kernels.drive_ways import solve_mode
    from mrnea.kernels.engines import ENGINE_MRNEA
    from mrnea.kernels.kinematics import frames_ws
    from mrnea.kernels.layout import entry_scratch
    from mrnea.kernels.rnea import reactions_ws
    from mrnea.kernels.simulate import program_requirement, simulate_cycles
    from mrnea.kernels.solve import cholesky_solve

    t = nb.typeof
    tree = any(p != i - 1 for i, p in enumerate(parents))
    ro2 = np.zeros((2, 2), order="F" if tree else "C")  # the model: a tree's is F order (layout.py)
    ro2.flags.writeable = False
    act = np.zeros((2, 2))  # the actuators' table (compiled.compile_actuators): C order
    act.flags.writeable = False
    f1, f2, f3 = t(np.zeros(1)), t(np.zeros((1, 1))), t(np.zeros((1, 1, 1)))
    b1, b2 = t(np.zeros(1, bool)), t(np.zeros((1, 1), bool))
    i1, i2 = t(np.zeros(1, np.int64)), t(np.zeros((1, 1), np.int64))
    a2 = t(np.zeros((2, 3))[:, :2])  # layout A: the drive solve's blocks
    ws, model, act_t, both = t(entry_scratch(1)), t(ro2), t(act), t((ro2, act))
    fe = f2 if per_link else f1  # a cycle's wrench and point: (n, 6), (n, 3) per link, else
    FE = f3 if per_link else f2  # (6,), (3,); the program's, (K, ...)
    # its class is the way (the mode's value is not typed): by n, or a tree's own
    how = t(solve_mode(HYBRID, len(parents), parents=parents))
    boolean, f64, i64 = nb.types.boolean, nb.types.float64, nb.types.int64
    program = nb.types.Tuple((f2, f2, FE, FE))
    cholesky = Unit(cholesky_solve, (a2, f1, a2, f1))
    solve = Unit(solve_cycle, (f2, f1, f1, f1, f64, f1, f1, f1, f1, how, f1, f1, f1, f1, f1, b1,
                               b1, ws))
    reactions = Unit(reactions_ws, (model, f1, f1, f1, fe, fe, f2, ws, boolean))
    requirement = Unit(program_requirement, (both, program, f64, boolean, i64, i64,
                                             nb.types.UniTuple(f2, 2), i1, ws))
    later = [  # these take the actuators' table (C order), not the model (a tree's: F)
        Unit(derived, (act_t, nb.types.Tuple((f2, f2, f2, f2, f2, i2)),
                       nb.types.Tuple((f2, f2, f2, b2, b2)), f1, i64, i64)),
        Unit(peaks.run_peaks, (nb.types.Tuple((f2, f2, f2, f2, b2, b2, f3)),
                               nb.types.UniTuple(f2, 3), nb.types.Tuple((act_t, b1, f2)), i2,
                               f2)),
    ]
    if report:
        later += [Unit(bearing.bearing_loads, (f3, f2, f3)),
                  Unit(frames_ws, (model, f1, f3, ws))]
    if retime:
        return [requirement, solve, cholesky, reactions, *later]
    if not shared:
        return [cholesky, solve, reactions, requirement, *later]
    mrnea_t = t(ENGINE_MRNEA)
    check = Unit(actuator_terms, (model, act_t, f1, f1, f1, f1, mrnea_t, f2, f1, ws))
    cycle = Unit(step, (model, act_t, f1, f1, f1, f1, f64, fe, fe, how, mrnea_t, f1, f1, f1, f1,
                        f1, f1, b1, b1, f1, f1, i1, ws), after=(CHECK, SOLVE))
    run = nb.types.Tuple((f2,) * 8 + (b2, b2, i2, f3))
    loop = Unit(simulate_cycles, (both, program, f64, how, mrnea_t, f64, boolean, i64, i64, run,
                                  ws), after=(STEP, REACTIONS))
    units = [check, solve, cholesky, reactions, cycle, loop]  # CHECK ... LOOP
    return [*units, requirement, *later]


def main(argv: list[str]) -> None:
    """Compile the units of :func:`signatures` of ``argv`` = (the parents, comma-separated,
    per_link 0/1, report 0/1[, retime 0/1, default 0[, shared 0/1, the claims' folder]]): each
    unit the command has not claimed, once the units it calls are done (:func:`share`), or all
    of them in order without a folder."""
    parents = [int(p) for p in argv[0].split(",")]
    per_link, report, retime = argv[1] == "1", argv[2] == "1", argv[3:4] == ["1"]
    shared, claims = argv[4:5] == ["1"], (argv[5] if len(argv) > 5 else None)
    if hasattr(os, "nice") and not shared:  # POSIX; the command first (module docstring:
        os.nice(10)  # excite's search); shared, the command may wait for this process
    units = signatures(parents, per_link, report, retime, shared)
    if claims is None:
        for unit in units:
            unit.kernel.compile(unit.sig)
        return
    parent = os.getppid()
    _work(claims, units, list(range(CHECK + 1 if shared else 0, len(units))),
          lambda: os.getppid() == parent and os.path.isdir(claims))


if __name__ == "__main__":
    main(sys.argv[1:])
    # its list compiled (each cache file written whole, then renamed): no interpreter teardown,
    # which kept a core busy for a second while the command drew its figures (report/pngs.py
    # draws a share in a forked child only with a core idle)
    os._exit(0)
