"""The sweep on Dask: one summary row per (robot variant, program), from a laptop to a cluster.

``sweep(robot, programs, grid)`` checks everything first (:func:`~mrnea.sweep.variants
.check_grid`, the programs), then runs the rows on a ``distributed`` cluster:

* ``client=None`` starts a ``distributed.LocalCluster`` of one single-threaded worker process
  per usable core and closes it afterwards; a ``distributed.Client``, or a scheduler address
  (``"tcp://host:8786"``, checked first: :func:`~mrnea.sweep.cluster.check_scheduler`), runs
  the same sweep on an existing cluster. Processes, not threads:
  a run holds the GIL for about half its time (docs/sweeps.md), so threads of one process
  would give at most 2x however many cores.
* The robot and every (program, time scale) are sent to each worker once; a task is a batch
  of runs of about :data:`TARGET_CYCLES` cycles (well above Dask's per-task overhead) and
  returns summary rows, never per-cycle arrays.
* Before the runs, each worker loads the compiled kernels (:func:`~mrnea.sweep.rows.warm`)
  and reports the code it runs: a worker with other code is an error (its rows would differ);
  then it receives the robot and the programs and makes one full-length run as a task
  (:func:`_warm_up`), so that the run phase, like a serial loop after its first run, times
  runs only.
* Ctrl-C (or a ``progress`` callback raising KeyboardInterrupt; the command line turns
  SIGTERM into the same) cancels what is left and returns the rows done, never a row for a
  run not done; ``df.attrs["completed"]`` is then False.
* Nothing but the progress bar reaches the terminal: distributed's logs and warnings are
  silenced during the sweep, the dashboard is off, the local cluster's workers ignore SIGINT
  and SIGTERM (a terminal, a container stop or a batch scheduler sends them to the whole
  process group; this process alone acts on them: :func:`~mrnea.sweep.cluster.spawning`).

The LocalCluster starts its workers with ``spawn``: a script that calls :func:`sweep` without a
client needs the ``if __name__ == "__main__":`` guard (a notebook does not).
"""

from __future__ import annotations

import builtins
import contextlib
import math
import os
import queue
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from mrnea import validate
from mrnea.cartesian import solve
from mrnea.compiled import cold_cache
from mrnea.errors import SweepError, quote
from mrnea.io.gridfile import DEMO_PROGRAM
from mrnea.io.program import Program, load_program
from mrnea.model import Robot
from mrnea.resources import require_memory
from mrnea.robots.sdt_profile import training_program
from mrnea.sweep import cluster
from mrnea.sweep.rows import (
    FIRST_COLUMNS,
    RETIME_COLUMNS,
    TOP_COLUMNS,
    code_version,
    run_batch,
    warm,
)
from mrnea.sweep.variants import grid_cases, units

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["DEMO_PROGRAM", "TARGET_CYCLES", "batch_size", "load_programs", "sweep"]

#: Cycles one task should simulate: 29 runs of the SDT demo program, about 0.6 s of CPU.
TARGET_CYCLES = 250_000
#: Tasks per worker thread at least, for load balance and a progress bar that moves.
TASKS_PER_THREAD = 4
#: Seconds to wait for a cluster's first worker.
WORKER_TIMEOUT = 60
#: A local worker process's memory [bytes]: Python, NumPy, Numba, distributed and mrnea loaded,
#: a run done (193 MB measured, the Puma 560); ``workers`` is refused beyond the memory budget.
WORKER_BYTES = 200e6
#: Seconds between two calls of a progress callback while no task finishes.
POLL = 0.25


# --- inputs --------------------------------------------------------------------------------


def load_programs(programs: Any, robot: Robot) -> list[Program]:
    """The sweep's programs: :class:`~mrnea.io.Program` objects or program file paths, one or
    a list (:data:`DEMO_PROGRAM` is the SDT demo's training profile), each checked against the
    robot's joint count.

    Raises
    ------
    SweepError
        An empty list, something that is not a program, a program of another joint count.
    ProgramFileError
        A program file that cannot be read.
    """
    items = [programs] if isinstance(programs, (Program, str, os.PathLike)) else programs
    if not isinstance(items, (list, tuple)):
        raise SweepError(f"programs: expected a Program, a program file's path or a list of "
                         f"them, got {type(programs).__name__} {quote(programs)}")
    if not items:
        raise SweepError("programs: the list is empty")
    out = []
    for p in items:
        if isinstance(p, Program):
            prog = p
        elif isinstance(p, (str, os.PathLike)):
            prog = training_program() if str(p) == DEMO_PROGRAM else load_program(p)
        else:
            raise SweepError(f"programs: expected Program objects or program file paths, got "
                             f"{type(p).__name__} {quote(p)}")
        # joints by name in the robot's order (units = deg: mm); a Cartesian program's joint
        # path (its q0 and joint targets checked on the robot)
        prog = solve(prog, robot)
        if prog.n != robot.n:
            raise SweepError(f"program {quote(prog.name)} ({prog.source or 'object'}) commands "
                             f"{prog.n} joints but robot {quote(robot.name)} has {robot.n}")
        out.append(prog)
    return out


def _labels(programs: Sequence[Program]) -> list[str]:
    """The ``program`` column: each program's name, its file where two share a name."""
    names = [p.name for p in programs]
    labels = [p.source if names.count(p.name) > 1 and p.source else p.name for p in programs]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise SweepError(f"programs: the same program given twice: {', '.join(dup)}")
    return labels


# --- the cluster ---------------------------------------------------------------------------


def batch_size(jobs: int, cycles: float, threads: int) -> int:
    """Runs per task: about :data:`TARGET_CYCLES` cycles, and at least
    :data:`TASKS_PER_THREAD` tasks per worker thread."""
    by_time = max(1, int(TARGET_CYCLES // max(cycles, 1.0)))
    by_balance = max(1, math.ceil(jobs / (TASKS_PER_THREAD * max(threads, 1))))
    return min(by_time, by_balance)


class _Bar:
    """``progress=True``: a line when the workers load the kernels, then a bar, on stderr."""

    def __init__(self) -> None:
        self.bar: Any = None
        self.done = 0

    def say(self, text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            import click

            self.bar = click.progressbar(length=total, file=sys.stderr,
                                         label=f"mrnea sweep: {total} runs")
            self.bar.__enter__()
        self.bar.update(done - self.done)
        self.done = done

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


# --- the sweep -----------------------------------------------------------------------------


def sweep(robot: Robot, programs: Any, grid: Mapping[str, Any], client: Any = None,
          retime: bool = False, progress: bool | Callable[[int, int], None] = True,
          zip: bool = False, *, workers: int | None = None, batch: int | None = None
          ) -> pd.DataFrame:
    """Simulate every program on every robot variant of ``grid``; one summary row each.

    Parameters
    ----------
    robot : Robot
        The base robot.
    programs : Program, str or path-like, or a list of them
        Programs (:class:`mrnea.io.Program`) or program files; ``"demo"``: the SDT demo's
        training profile.
    grid : mapping
        Parameter -> list of values (the parameters and their rules:
        :mod:`mrnea.sweep.variants`, docs/sweeps.md), e.g. ``{"gear_ratio.cab_yaw": [60, 80],
        "payload": [0, 100]}``.
    client : None, distributed.Client or str
        None: a LocalCluster on this machine (one worker process per usable core), closed
        afterwards. A Client, or a scheduler address ``"tcp://host:port"``: that cluster.
    retime : bool
        Also retime each (variant, program) with :func:`mrnea.retime`: columns
        ``retimed_duration`` [s] and ``retime_error``.
    progress : bool or callable
        True: a line and a progress bar on stderr. A callable: ``progress(rows_done, rows)``,
        called after the workers loaded their kernels and then at least every 0.25 s; raising
        KeyboardInterrupt from it stops the sweep as Ctrl-C does. False: silent.
    zip : bool
        Take the grid's lists in step (all of one length) instead of their product.
    workers : int, optional (keyword)
        Worker processes of the LocalCluster (default: the usable cores).
    batch : int, optional (keyword)
        Runs per task (default: :func:`batch_size`).

    Returns
    -------
    pandas.DataFrame
        One row per (variant, program), index ``case`` = variant number x number of programs
        + program number. Columns: the parameters (named as the grid keys), ``program``,
        ``error`` (None, or why the variant failed), ``achievable``, ``worst_joint``,
        ``worst_effort_ratio``, ``duration``, ``max_tracking_error``, ``runaway_time``,
        ``first_infeasible_time`` / ``_joint`` / ``_reason``, and each joint's summary numbers
        as ``<entry>.<joint>`` (:mod:`mrnea.sweep.rows`); with ``retime`` also
        ``retimed_duration`` and ``retime_error``. A row equals, bit for bit,
        ``simulate(variant(robot, **params), program.q_cmd, ...).summary()`` of the
        time-scaled program. ``attrs``: ``completed`` (False after an interrupt: the rows
        done), ``cases`` (rows asked for), ``threads`` (worker threads), ``tasks``, ``batch``
        (runs per task), ``seconds`` (prepare, cluster, warm, run, total: wall time),
        ``units`` (each parameter's unit, "" for a ratio).

    Raises
    ------
    SweepError
        A bad grid (an unknown parameter or joint, an empty list, a value the robot cannot
        take: naming the entry), bad programs, a scheduler that cannot be reached, workers
        running other code: all before any simulation runs.
    """
    t0 = time.perf_counter()
    validate.require_robot(robot)
    for name, flag in (("retime", retime), ("zip", zip)):
        if not isinstance(flag, bool):
            raise SweepError(f"{name}: expected True or False, got {quote(flag)}")
    if not (isinstance(progress, bool) or callable(progress)):
        raise SweepError(f"progress: expected True, False or a callable, got {quote(progress)}")
    for name, value in (("workers", workers), ("batch", batch)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int)
                                  or value < 1):
            raise SweepError(f"{name}: expected a whole number >= 1, got {quote(value)}")
    if workers is not None and client is None:  # each a process of its own, mrnea loaded
        require_memory(float(workers) * WORKER_BYTES, f"a local cluster of {workers} worker "
                       "processes", "use fewer workers", SweepError)
    if not (client is None or isinstance(client, str) or hasattr(client, "submit")):
        raise SweepError(f"client: expected None, a distributed.Client or a scheduler address "
                         f"(str), got {type(client).__name__}")
    progs = load_programs(programs, robot)
    labels = _labels(progs)
    keys, cases, scaled = grid_cases(robot, grid, zip, progs)  # each program scaled once
    jobs = [(v * len(progs) + p, (p, float(case.get("time_scale", 1.0))), case)
            for v, case in enumerate(cases) for p in range(len(progs))]
    rows: dict[int, dict[str, Any]] = {}
    info: dict[str, Any] = {"threads": 0, "tasks": 0, "batch": batch}
    clock = {"prepare": time.perf_counter() - t0}
    bar = _Bar() if progress is True else None
    report = bar or (progress if callable(progress) else None)
    completed = True
    try:
        with cluster.quiet(), cluster.client(client, workers) as c:
            clock["cluster"] = time.perf_counter() - t0 - clock["prepare"]
            _run(c, robot, scaled, jobs, retime, report, bar, rows, info, clock)
    except KeyboardInterrupt:  # rows holds what was done; the cluster is closed or left as given
        completed = False
    finally:
        if bar is not None:
            bar.close()
    completed = completed and len(rows) == len(jobs)  # a task cancelled by someone else
    df = _frame(keys, labels, jobs, rows, retime)
    clock["total"] = time.perf_counter() - t0
    df.attrs.update(completed=completed, cases=len(jobs), seconds=clock,
                    units=units(robot, keys), **info)
    if bar is not None and not completed:
        bar.say(f"mrnea sweep: interrupted; {len(rows)} of {len(jobs)} rows done.")
    return df


def _run(c: Any, robot: Robot, scaled: Mapping[tuple[int, float], Program],
         jobs: list[tuple[int, tuple[int, float], dict[str, Any]]], retime: bool,
         report: Callable[[int, int], None] | None, bar: _Bar | None,
         rows: dict[int, dict[str, Any]], info: dict[str, Any], clock: dict[str, float]
         ) -> None:
    """Warm the workers, send the robot and the programs once, run the batches; rows, info
    and clock filled as they come (the caller keeps them when an interrupt ends this: the
    tasks left are cancelled)."""
    t = time.perf_counter()
    try:  # a worker may register a moment after its cluster says it started
        c.wait_for_workers(1, timeout=WORKER_TIMEOUT)
    except TimeoutError:
        raise SweepError(f"the cluster has no workers (waited {WORKER_TIMEOUT} s)") from None
    nthreads = c.nthreads()
    info["threads"] = threads = sum(nthreads.values())
    if bar is not None:
        bar.say(f"mrnea sweep: loading the compiled kernels on {len(nthreads)} worker(s)...")
    first, rest = _warm_order(list(nthreads))
    try:
        answers = {}
        for group in (first, rest):  # on a cold cache: one compiles, the others load
            if group:
                answers.update(c.run(warm, robot, os.getpid(), retime, workers=group))
    except Exception as exc:  # a worker without mrnea, or one that cannot unpickle the robot
        raise SweepError(f"the workers cannot run mrnea's sweep ({type(exc).__name__}: "
                         f"{quote(str(exc), 200)}); give every worker the same mrnea") from None
    _check_workers(answers)
    r_fut, p_fut = c.scatter([robot, dict(scaled)], broadcast=True, hash=False)
    _warm_up(c, list(nthreads), jobs[0], r_fut, p_fut)
    clock["warm"] = time.perf_counter() - t
    t = time.perf_counter()
    cycles = sum(scaled[key].K for _, key, _ in jobs) / len(jobs)
    size = info["batch"] = info["batch"] or batch_size(len(jobs), cycles, threads)
    batches = [jobs[k:k + size] for k in range(0, len(jobs), size)]
    info["tasks"] = len(batches)
    futures = c.map(run_batch, batches, robot=r_fut, programs=p_fut, retime=retime,
                    client_pid=os.getpid(), pure=False)
    which = {f.key: b for f, b in builtins.zip(futures, batches, strict=True)}
    try:
        _collect(futures, which, rows, report, len(jobs))
    except KeyboardInterrupt:
        c.cancel(futures)
        rows.update(_done_rows(futures))
        raise
    finally:
        clock["run"] = time.perf_counter() - t


def _warm_order(addresses: list[str]) -> tuple[list[str], list[str]]:
    """The workers to warm first, then the rest. On a cold Numba cache (no compiled simulation
    loop yet: :func:`mrnea.compiled.cold_cache`) one worker compiles the kernels and writes the
    cache, then the others load them: warmed at once, every worker would compile the same
    kernels, and the command's compile-ahead process (mrnea/cli/ahead.py) would compete with
    all of them for the cores (a fresh `mrnea sweep` of the Puma payload grid on 2 cores: 16 s
    against 22 s, docs/performance.md section 7). On a warm cache all at once. A cluster
    elsewhere shares no cache with this machine: there the check says nothing, and warming one
    worker first costs about a second."""
    return (addresses[:1], addresses[1:]) if cold_cache() else (addresses, [])


def _warm_up(c: Any, addresses: Sequence[str], job: tuple[int, Any, Any], robot: Any,
             programs: Any) -> None:
    """One full-length run of the sweep's first job on each worker, as a task (its row is
    dropped), before the run phase: a worker's first run in its task thread grows that
    thread's heap arena to the run's size (about 1800 page faults, 7 MB, on the SDT demo) and
    tunes the worker (:func:`~mrnea.sweep.rows.tune_worker`), as the serial loop's first run
    does for a loop. :func:`~mrnea.sweep.rows.warm` (``Client.run``) runs on the worker's
    event-loop thread, not the task thread. A task may run elsewhere if its worker leaves."""
    warm_ups = [c.submit(run_batch, [job], robot=robot, programs=programs,
                         client_pid=os.getpid(), workers=[a], allow_other_workers=True,
                         pure=False) for a in addresses]
    try:
        c.gather(warm_ups, errors="skip")  # a failed warm-up is the real task's row to report
    finally:
        c.cancel(warm_ups)


def _check_workers(answers: Mapping[str, Mapping[str, Any]]) -> None:
    """Every worker runs this process's code (else its rows would differ from a serial
    loop's)."""
    mine = code_version()
    for addr, w in answers.items():
        if w["code"] != mine:
            raise SweepError(f"worker {addr} runs other code ({w['code']}) than this process "
                             f"({mine}); give every worker the same mrnea and Numba")


def _batch_rows(batch: Sequence[tuple[int, Any, Any]], result: Any, future: Any
                ) -> list[tuple[int, dict[str, Any]]]:
    """A finished task's rows; for each run of a task that failed, a row with the task's error;
    none for a task cancelled (the sweep stopping: its runs are not done, not failed) or whose
    result could not be fetched."""
    if future.status == "finished":
        return [] if result is None else result
    if future.status != "error":
        return []
    try:
        exc = future.exception(timeout=10)
    except Exception as err:  # cancelled, or the scheduler lost it
        exc = err
    return [(k, {"error": f"{type(exc).__name__}: {exc} (task failed)"}) for k, _, _ in batch]


def _collect(futures: list, which: dict, rows: dict[int, dict[str, Any]],
             report: Callable[[int, int], None] | None, total: int) -> None:
    """Rows into ``rows`` as tasks finish, ``report(done, total)`` at least every
    :data:`POLL` seconds.

    Each future puts itself in a queue when it is done (distributed calls the callback from its
    own thread); the loop takes what is there and gathers it in one round trip. Not
    ``distributed.wait(pending, FIRST_COMPLETED)`` in a loop: each call waits on every pending
    future again, O(tasks^2) over a sweep (13 s more for 1000 one-run tasks, measured); not
    ``as_completed(with_results=True)``: it once never yielded a finished future (the third
    sweep through one client; dask/distributed#7331)."""
    finished: queue.SimpleQueue = queue.SimpleQueue()
    for fut in futures:
        fut.add_done_callback(finished.put)
    left = len(futures)
    if report is not None:
        report(0, total)
    while left:
        try:
            done = [finished.get(timeout=POLL)]
        except queue.Empty:
            done = []
        while done and not finished.empty():
            done.append(finished.get())
        ok = [f for f in done if f.status == "finished"]
        results = dict(builtins.zip([f.key for f in ok], _gather(ok), strict=True))
        for fut in done:
            rows.update(_batch_rows(which[fut.key], results.get(fut.key), fut))
            fut.release()
        left -= len(done)
        if report is not None:
            report(len(rows), total)


def _gather(futures: list) -> list:
    """The results of finished futures, in one round trip; None for one whose result is gone
    (cancelled meanwhile: the sweep is stopping)."""
    if not futures:
        return []
    try:
        return futures[0].client.gather(futures)
    except Exception:  # one of them cancelled or lost since it finished: each alone
        out = []
        for fut in futures:
            try:
                out.append(fut.result(timeout=5))
            except Exception:
                out.append(None)
        return out


def _done_rows(futures: list) -> dict[int, dict[str, Any]]:
    """The rows of the tasks that had finished, not yet collected, when the sweep stopped."""
    rows: dict[int, dict[str, Any]] = {}
    for fut in futures:
        if fut.status == "finished":
            with contextlib.suppress(Exception):
                rows.update(fut.result(timeout=5))
    return rows


def _frame(keys: Sequence[str], labels: Sequence[str],
           jobs: Sequence[tuple[int, Any, Mapping[str, Any]]],
           rows: Mapping[int, Mapping[str, Any]], retime: bool) -> pd.DataFrame:
    """The rows in case order: the parameters, ``program``, ``error``, the top-level columns
    (always, even when no run succeeded), then the per-joint columns in the order they first
    appear."""
    import pandas as pd

    columns: dict[str, None] = dict.fromkeys([*keys, "program", "error", *TOP_COLUMNS,
                                              *FIRST_COLUMNS, *(RETIME_COLUMNS if retime
                                                                else ())])
    records, order = [], []
    for k, (p, _), case in jobs:
        if k in rows:
            rec = {**case, "program": labels[p], **rows[k]}
            columns.update(dict.fromkeys(rec))
            records.append(rec)
            order.append(k)
    df = pd.DataFrame.from_records(records, columns=list(columns),
                                   index=pd.Index(order, name="case", dtype="int64"))
    df.index.name = "case"  # from_records drops it when there is no record
    df["achievable"] = df["achievable"].astype("boolean")
    return df

