"""Benchmark (not a test): the throughput of a design sweep, and what Dask costs per task.

Usage: ``python benchmarks/sweep.py [--n 1000] [--rounds 3] [--out benchmarks/results/sweep.md]``;
``python benchmarks/sweep.py --n 125 --rounds 7 --scaling 1 2`` for the scaling table only
(issue 29): at each worker count W, the machine's own limit (W independent processes each
running the serial loop on 1/W of the grid at the same time), mrnea's own cluster and a plain
``Client(LocalCluster(n_workers=W, threads_per_worker=1))`` passed as ``client=``, and the
issue's ratios (own / serial at W = 1, own / reference and plain / reference at each W) as the
median and range of per-round ratios.

About n SDT variants (cabin-yaw gear ratio x yaw motor torque limit x payload, n^(1/3) values
each) of the demo's training profile (8401 cycles at 5 ms), run

1. in a serial loop in this process, as a user writes it (``run_case``: variant, simulate,
   summary row), and the same loop with Numba's parallel kernels on one thread, as in a worker;
2. on LocalClusters started as :func:`mrnea.sweep` starts its own: 1 and 2 worker processes
   (one thread each: the default), 1 process with 2 threads, 2 threads in this process;
3. with one run per task (``batch=1``) against the default batches, at 1 and 2 workers: what a
   task costs beyond its runs; and Dask's own round trip of a no-op task;
4. 1 and 2 worker processes again, alternated in rounds on two live clusters (on a shared
   machine the load changes from one minute to the next; alternating spreads it over both);
5. the share of a run that holds the GIL (the nogil simulation kernel timed apart): why
   threads cannot scale as processes do, on any machine.

Throughput is variants per second of the run phase (cluster start and warm-up are fixed costs,
reported apart). CPU seconds are counted in the workers (``time.process_time``; the serial loop:
its thread's), so that a machine shared with other jobs shows as lost wall time, not as a
slower mrnea; the load average is printed with each line. Every configuration's rows are
checked equal to the serial loop's (``DataFrame.equals``). The last lines apply the measured
figures to W workers (docs/performance.md, "Design sweeps").
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import math
import multiprocessing
import os
import platform
import statistics
import time

import numba
import numpy as np
import pandas as pd
import psutil
from distributed import Client, LocalCluster

from mrnea.robots import sdt
from mrnea.robots.sdt_profile import training_program
from mrnea.sweep import check_grid, sweep
from mrnea.sweep.cluster import WORKER_ENVIRON, spawning
from mrnea.sweep.cluster import quiet as cluster_quiet
from mrnea.sweep.engine import _frame
from mrnea.sweep.rows import run_case


def grid_of(n: int) -> dict[str, list[float]]:
    """About n variants: k x k x k values of three parameters."""
    k = max(1, round(n ** (1 / 3)))
    return {"gear_ratio.cab_yaw": np.linspace(60, 150, k).tolist(),
            "motor_torque_limit.cab_yaw": np.linspace(30, 75, k).tolist(),
            "payload": np.linspace(0, 450, k).tolist()}


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def serial(robot, program, grid, one_thread: bool) -> tuple[pd.DataFrame, float, float]:
    """The loop in this process: (rows, wall [s], thread CPU [s])."""
    keys, cases = check_grid(robot, grid)
    numba.set_num_threads(1 if one_thread else numba.config.NUMBA_NUM_THREADS)
    run_case(robot, program, cases[0])  # load the kernels first
    w, c = time.perf_counter(), time.thread_time()
    rows = {k: run_case(robot, program, case) for k, case in enumerate(cases)}
    wall, cpu = time.perf_counter() - w, time.thread_time() - c
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    jobs = [(k, (0, 1.0), case) for k, case in enumerate(cases)]
    return _frame(keys, [program.name], jobs, rows, False), wall, cpu


def cpu_seconds(client: Client) -> float:
    return sum(client.run(time.process_time).values())


@contextlib.contextmanager
def cluster(**kw):
    """A LocalCluster started as mrnea.sweep starts its own, a client of it, and the seconds
    the start took."""
    t = time.perf_counter()
    with spawning():
        lc = LocalCluster(dashboard_address=None, silence_logs=logging.CRITICAL,
                          scheduler_kwargs={"dashboard_address": ":0"}, **kw)
    with lc, Client(lc) as c:
        c.wait_for_workers(1)
        start = time.perf_counter() - t
        sweep(sdt(), training_program(), {"payload": [0.0]}, client=c, progress=False)
        yield c, start  # the workers' kernels loaded: the sweeps measured count runs only


def on_cluster(c: Client, robot, program, grid, reference, batch=None) -> dict:
    cpu0 = cpu_seconds(c)
    df = sweep(robot, program, grid, client=c, progress=False, batch=batch)
    cpu = cpu_seconds(c) - cpu0
    s = df.attrs["seconds"]
    return {"warm": s["warm"], "run": s["run"], "cpu": cpu, "rate": len(df) / s["run"],
            "tasks": df.attrs["tasks"], "batch": df.attrs["batch"],
            "same": df.equals(reference), "rows": len(df)}


def noop(x: int) -> int:
    return x


def round_trip(c: Client, tasks: int = 2000) -> float:
    """Seconds per no-op task, submitted at once and gathered."""
    c.gather(c.map(noop, range(100), pure=False))  # the connections warm
    t = time.perf_counter()
    c.gather(c.map(noop, range(tasks), pure=False))
    return (time.perf_counter() - t) / tasks


def gil_share(robot, program, grid, runs: int = 100) -> tuple[float, float]:
    """(CPU per run [s], the share of it outside the nogil simulation kernel)."""
    _, cases = check_grid(robot, grid)
    cases = cases[:runs]
    msim = importlib.import_module("mrnea.simulate")  # the module (mrnea.simulate: the function)
    kernel, spent = msim.simulate_cycles, [0.0]

    def timed(*a):
        t = time.thread_time()
        try:
            return kernel(*a)
        finally:
            spent[0] += time.thread_time() - t

    numba.set_num_threads(1)
    run_case(robot, program, cases[0])
    msim.simulate_cycles = timed
    try:
        t = time.thread_time()
        for case in cases:
            run_case(robot, program, case)
        total = time.thread_time() - t
    finally:
        msim.simulate_cycles = kernel
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return total / len(cases), 1 - spent[0] / total


# --- scaling: against the machine's own limit ----------------------------------------------


def _reference_process(k: int, w: int, n: int, barrier, results) -> None:
    """One of W independent processes: the serial loop over its share of the grid (every W-th
    variant), started with the others at a barrier once its kernels are loaded."""
    robot, program = sdt(), training_program()
    _, cases = check_grid(robot, grid_of(n))
    mine = list(range(k, len(cases), w))
    run_case(robot, program, cases[0])  # the kernels loaded
    barrier.wait()
    t0, cpu = time.time(), time.process_time()
    rows = {i: run_case(robot, program, cases[i]) for i in mine}
    results.put((t0, time.time(), time.process_time() - cpu, rows))


def reference(w: int, n: int) -> tuple[float, dict, float]:
    """The machine's limit at W workers: W independent processes each running the serial loop
    (on 1/W of the variants) at the same time, in the environment mrnea's cluster gives its
    workers. Returns (variants per second from the first start to the last end, the rows,
    CPU seconds of the processes per variant)."""
    ctx = multiprocessing.get_context("spawn")
    barrier, results = ctx.Barrier(w), ctx.Queue()
    environ = dict(os.environ)
    os.environ.update({k: str(v) for k, v in WORKER_ENVIRON.items()})
    try:
        procs = [ctx.Process(target=_reference_process, args=(k, w, n, barrier, results))
                 for k in range(w)]
        for p in procs:
            p.start()
    finally:
        os.environ.clear()
        os.environ.update(environ)
    got = [results.get(timeout=3600) for _ in procs]
    for p in procs:
        p.join()
    rows = {k: r for *_, part in got for k, r in part.items()}
    wall = max(e for _, e, _, _ in got) - min(s for s, _, _, _ in got)
    return len(rows) / wall, rows, sum(c for _, _, c, _ in got) / len(rows)


class CpuMeter:
    """A sweep's ``progress`` callback: the CPU seconds of this process (client, and a
    LocalCluster's scheduler) and of all its descendants (nannies, workers) from the first call
    (the run phase starts) to the call with every row done: what a sweep's run phase costs the
    machine, Dask's processes and threads included."""

    def __init__(self) -> None:
        self.start: float | None = None
        self.cpu = math.nan

    @staticmethod
    def _now() -> float:
        total = time.process_time()
        for child in psutil.Process().children(recursive=True):
            with contextlib.suppress(psutil.Error):
                total += sum(child.cpu_times()[:2])
        return total

    def __call__(self, done: int, total: int) -> None:
        if self.start is None:
            self.start = self._now()
        elif done == total and math.isnan(self.cpu):
            self.cpu = self._now() - self.start


def _spread(values: list[float]) -> str:
    """Median (min-max) of per-round ratios."""
    return f"{statistics.median(values):.2f} ({min(values):.2f}-{max(values):.2f})"


def scaling(workers: list[int], n: int, rounds: int, say) -> None:
    """At each worker count W (1, 2, 4... as the machine has the cores), in ``rounds`` rounds,
    each round's three measurements in a rotated order (a load that drifts falls on each in
    turn): the reference (W independent serial loops), mrnea's own cluster (``workers=W``)
    and a plain ``Client(LocalCluster(n_workers=W, threads_per_worker=1))`` passed as
    ``client=``; both clusters started afresh each round, before their sweep (start and
    warm-up are fixed costs, reported apart: run-phase throughput). Each round's ratios are
    taken within the round; the table gives their median and range, the targets' ratios:
    own / serial at W = 1 (the 1-process reference is the serial loop, in a process of its
    own), own / reference and plain / reference at every W. Beside them, the CPU per variant
    of each (all processes: :class:`CpuMeter`), which a machine shared with other jobs does
    not change as it changes throughput. Rows checked equal to the reference's."""
    robot, program = sdt(), training_program()
    grid = grid_of(n)
    keys, cases = check_grid(robot, grid)
    jobs = [(k, (0, 1.0), case) for k, case in enumerate(cases)]
    say(f"Scaling: {len(cases)} SDT variants x {program.name} ({program.K} cycles), "
        f"{rounds} round(s) per worker count, the three configurations in a rotated order "
        "each round. Run-phase variants/s (start and warm-up apart); ratios taken within "
        "each round: median (min-max) over the rounds. CPU per variant: all the processes' "
        "CPU in the run phase (the reference's processes; a cluster's workers, nannies, "
        "scheduler and client) per variant.")
    say()
    say("| W | reference (W serial loops) | mrnea's cluster | plain LocalCluster as client= "
        "| **own / serial** (W = 1) | **own / reference** | **plain / reference** "
        "| CPU per variant [ms]: ref, own, plain | rows = serial | load |")
    say("|---:|---:|---:|---:|---:|---:|---:|---|---:|---|")
    for w in workers:
        rates: dict[str, list[float]] = {"ref": [], "own": [], "plain": []}
        cpus: dict[str, list[float]] = {"ref": [], "own": [], "plain": []}
        loads: list[float] = []
        same = True
        for r in range(rounds):
            ref_df = None
            dfs = []
            order = ["ref", "own", "plain"]
            for name in order[r % 3:] + order[:r % 3]:
                meter = CpuMeter()
                if name == "ref":
                    rate, rows, cpu = reference(w, n)
                    ref_df = _frame(keys, [program.name], jobs, rows, False)
                else:
                    if name == "own":
                        df = sweep(robot, program, grid, workers=w, progress=meter)
                    else:
                        with cluster_quiet(), Client(LocalCluster(
                                n_workers=w, threads_per_worker=1, dashboard_address=":0")) as c:
                            df = sweep(robot, program, grid, client=c, progress=meter)
                    rate, cpu = len(df) / df.attrs["seconds"]["run"], meter.cpu / len(df)
                    dfs.append(df)
                rates[name].append(rate)
                cpus[name].append(cpu)
            same = same and all(df.equals(ref_df) for df in dfs)
            loads.append(os.getloadavg()[0])
            got = {k: v[-1] for k, v in rates.items()}
            print(f"  W={w} round {r + 1}: variants/s reference {got['ref']:.1f}, own "
                  f"{got['own']:.1f}, plain {got['plain']:.1f}; own / ref "
                  f"{got['own'] / got['ref']:.2f}, plain / ref {got['plain'] / got['ref']:.2f};"
                  f" CPU per variant {', '.join(f'{1e3 * v[-1]:.1f}' for v in cpus.values())}"
                  f" ms ({load()})", flush=True)
        own_ref = [o / f for o, f in zip(rates["own"], rates["ref"], strict=True)]
        plain_ref = [p / f for p, f in zip(rates["plain"], rates["ref"], strict=True)]
        cpu = ", ".join(f"{1e3 * statistics.median(v):.1f}" for v in cpus.values())
        say(f"| {w} | {statistics.median(rates['ref']):.1f} | "
            f"{statistics.median(rates['own']):.1f} | {statistics.median(rates['plain']):.1f} | "
            f"{_spread(own_ref) if w == 1 else '-'} | {_spread(own_ref)} | {_spread(plain_ref)} "
            f"| {cpu} | {same} | {min(loads):.1f}-{max(loads):.1f} |")
    per_run, g = gil_share(robot, program, grid)
    say()
    say("(variants/s and CPU: medians over the rounds; load: the 1-minute load average after "
        "each round.)")
    say(f"Python per run: {1e3 * per_run:.1f} ms of CPU per run, {100 * g:.0f} % of it outside "
        "the compiled simulation kernel.")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=None)
    ap.add_argument("--scaling", type=int, nargs="+", default=None, metavar="W",
                    help="only the scaling table, at these worker counts (e.g. 1 2 4 8 16)")
    args = ap.parse_args()
    robot, program = sdt(), training_program()
    grid = grid_of(args.n)
    n = int(np.prod([len(v) for v in grid.values()]))
    lines: list[str] = []

    def say(text: str = "") -> None:
        print(text, flush=True)
        lines.append(text)

    if args.scaling:
        say(f"Command: `python benchmarks/sweep.py --n {args.n} --rounds {args.rounds} "
            f"--scaling {' '.join(map(str, args.scaling))}`. Machine: "
            f"{platform.processor() or platform.machine()}, {len(os.sched_getaffinity(0))} "
            f"usable cores ({os.cpu_count()} logical CPUs); Numba {numba.__version__}, "
            f"distributed {__import__('distributed').__version__}.")
        say()
        scaling(args.scaling, args.n, args.rounds, say)
        if args.out:
            with open(args.out, "w") as fh:
                fh.write("\n".join(lines) + "\n")
        return
    t_start = time.perf_counter()
    say(f"# Sweep benchmark: {n} SDT variants x {program.name} ({program.K} cycles)")
    say()
    say(f"Command: `python benchmarks/sweep.py --n {args.n} --rounds {args.rounds}`. Machine: "
        f"{platform.processor() or platform.machine()}, {len(os.sched_getaffinity(0))} usable "
        f"cores; Python {platform.python_version()}, Numba {numba.__version__}, pandas "
        f"{pd.__version__}, distributed {__import__('distributed').__version__}. "
        f"Load average (1 min) {os.getloadavg()[0]:.2f} at the start.")
    say()
    say("| configuration | run [s] | variants/s | CPU per run [ms] | cores used | fixed [s] "
        "| tasks x runs | rows = serial | load |")
    say("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    reference, _, _ = serial(robot, program, grid, one_thread=False)
    cpu_runs = []
    for one in (False, True):
        df, wall, cpu = serial(robot, program, grid, one)
        cpu_runs.append(cpu / n)
        name = "serial loop, Numba on 1 thread" if one else "serial loop as a user writes it"
        say(f"| {name} | {wall:.1f} | {n / wall:.1f} | {1e3 * cpu / n:.1f} | {cpu / wall:.2f} "
            f"| - | - | {df.equals(reference)} | {load()} |")
    configs = [("1 worker process", {"n_workers": 1, "threads_per_worker": 1}),
               ("2 worker processes (the default here)",
                {"n_workers": 2, "threads_per_worker": 1}),
               ("1 process x 2 threads", {"n_workers": 1, "threads_per_worker": 2}),
               ("2 threads in this process",
                {"n_workers": 1, "threads_per_worker": 2, "processes": False})]
    rates: dict[str, float] = {}
    overhead = {}
    for name, cfg in configs:
        with cluster(**cfg) as (c, start):
            m = on_cluster(c, robot, program, grid, reference)
            rates[name] = m["rate"]
            say(f"| {name} | {m['run']:.1f} | {m['rate']:.1f} | {1e3 * m['cpu'] / n:.1f} | "
                f"{m['cpu'] / m['run']:.2f} | {start:.1f} + {m['warm']:.1f} | {m['tasks']} x "
                f"{m['batch']} | {m['same']} | {load()} |")
            if cfg.get("processes", True) and cfg["threads_per_worker"] == 1:
                one = on_cluster(c, robot, program, grid, reference, batch=1)
                extra = ((one["run"] - m["run"]) * cfg["n_workers"]
                         / max(one["tasks"] - m["tasks"], 1))
                overhead[name] = (round_trip(c), extra, one, m)
    say()
    say("Per-task overhead (the same sweep with one run per task, against the default batches; "
        "Dask's round trip of a no-op task, 2000 submitted at once):")
    say()
    for name, (trip, extra, one, m) in overhead.items():
        say(f"* {name}: no-op round trip {1e3 * trip:.2f} ms per task; {one['tasks']} tasks "
            f"of 1 run took {one['run']:.1f} s against {m['run']:.1f} s for {m['tasks']} of "
            f"{m['batch']}: {1e3 * extra:.1f} ms more per task and worker ({load()})")
    say()
    say(f"1 and 2 worker processes alternated, both clusters up, {args.rounds} rounds (each "
        "sees the other's moments of load; the best round is the closest to an idle machine):")
    say()
    with cluster(n_workers=1, threads_per_worker=1) as (c1, _), \
            cluster(n_workers=2, threads_per_worker=1) as (c2, _):
        best: dict[int, list[float]] = {1: [], 2: []}
        for r in range(args.rounds):
            for w, c in ((1, c1), (2, c2)):
                m = on_cluster(c, robot, program, grid, reference)
                best[w].append(m["rate"])
                say(f"* round {r + 1}, {w} worker(s): {m['rate']:.1f} variants/s, "
                    f"{m['cpu'] / m['run']:.2f} cores used, {1e3 * m['cpu'] / n:.1f} ms CPU per "
                    f"run, rows = serial {m['same']} ({load()})")
        say(f"* best: 1 worker {max(best[1]):.1f}, 2 workers {max(best[2]):.1f} variants/s "
            f"({max(best[2]) / max(best[1]):.2f}x); median {statistics.median(best[1]):.1f} and "
            f"{statistics.median(best[2]):.1f}")
    per_run, g = gil_share(robot, program, grid)
    say()
    say(f"GIL: a run costs {1e3 * per_run:.1f} ms of CPU, of which {100 * g:.0f} % outside the "
        f"nogil simulation kernel (variant, set-up, summary: Python and NumPy, holding the GIL "
        f"most of it): T threads in one process give at most 1/g = {1 / g:.1f}x, T processes "
        f"T x.")
    c_run = statistics.median(cpu_runs)
    o = statistics.median([t for t, *_ in overhead.values()])
    b = next(iter(overhead.values()))[3]["batch"]
    say()
    say(f"On paper, W worker processes on W free cores: throughput = W / (c + o / b) with "
        f"c = {1e3 * c_run:.1f} ms CPU per run, o = {1e3 * o:.1f} ms per task, b = {b} runs "
        f"per task: {1 / (c_run + o / b):.0f} variants/s per worker; 8 workers "
        f"{8 / (c_run + o / b):.0f}/s, 64 workers {64 / (c_run + o / b):.0f}/s. A task of b "
        f"runs lasts {b * c_run:.2f} s, so W workers ask the scheduler for W / {b * c_run:.2f} "
        f"tasks per second; at o per task (an upper bound of the scheduler's own cost) it "
        f"keeps up to W = {b * c_run / o:.0f} workers.")
    say()
    say(f"Whole benchmark {time.perf_counter() - t_start:.0f} s; load average (1 min) "
        f"{os.getloadavg()[0]:.2f} at the end.")
    if args.out:
        with open(args.out, "w") as fh:
            fh.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
