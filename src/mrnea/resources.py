"""The machine's resources: the memory budget, how much memory mrnea lets one allocation of a
run take, checked before it allocates; and the CPUs, whether one is idle now.

A run keeps every cycle in memory (the path, then about 20 arrays of ``(K, n)`` values and the
``(K, n, 6)`` reactions), so a tiny ``dt`` or a very long program can ask for more memory than
the machine has. Rather than a ``MemoryError`` traceback, or the kernel's out-of-memory killer,
each place that allocates memory in proportion to the number of cycles (or to a file's size)
first estimates what it needs and calls :func:`require_memory`, which refuses with one line
saying how much was needed, how much is available and what to change.

The budget (:func:`memory_budget`) is :data:`BUDGET_FRACTION` of the memory available when the
check runs, never less than :data:`BUDGET_FLOOR`. "Available" is the smallest of: the kernel's
``MemAvailable`` (``/proc/meminfo``; elsewhere the free physical pages, ``os.sysconf``), the
room left under a cgroup memory limit (containers) and under an address-space limit
(``ulimit -v``).

Whether a CPU is idle now (:func:`idle_cpu`) decides whether a command starts a second process
to share its work: drawing its figures (report/pngs.py), compiling ahead on a cold cache
(cli/ahead.py).
"""

from __future__ import annotations

import os
import resource
import time

from mrnea.errors import MrneaError

__all__ = ["BUDGET_FLOOR", "BUDGET_FRACTION", "IDLE_READS", "available_memory", "cpus",
           "format_bytes", "idle_cpu", "memory_budget", "require_memory"]

BUDGET_FRACTION = 0.75
"""The share of the available memory one run may plan to use (the rest: Python, matplotlib,
the estimates' margin of error, and the other programs on the machine)."""
BUDGET_FLOOR = 256 * 2**20
"""A run that needs no more than this (256 MiB) is never refused, whatever memory reads."""

_CGROUP_FILES = (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),  # cgroup v2
                 ("/sys/fs/cgroup/memory/memory.limit_in_bytes",  # cgroup v1
                  "/sys/fs/cgroup/memory/memory.usage_in_bytes"))


def _read_int(path: str) -> int | None:
    try:
        with open(path, encoding="ascii") as fh:
            text = fh.read().strip()
    except (OSError, UnicodeDecodeError):
        return None
    return int(text) if text.isdigit() else None  # "max": no limit


def _proc_kb(path: str, key: str) -> int | None:
    """The entry ``key`` [bytes] of a ``/proc`` file of ``key: value kB`` lines (``/proc/meminfo``,
    ``/proc/self/status``), or None."""
    try:
        with open(path, encoding="ascii") as fh:
            for line in fh:
                name, _, value = line.partition(":")
                if name == key:
                    return int(value.split()[0]) * 1024  # given in kB
    except (OSError, ValueError, IndexError):
        pass
    return None


def available_memory() -> int:
    """The memory [bytes] this process can still allocate without making the system swap or
    kill it: the smallest of MemAvailable, the room under a cgroup limit and under
    ``RLIMIT_AS`` (see the module docstring)."""
    limits = []
    avail = _proc_kb("/proc/meminfo", "MemAvailable")
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            avail = None
    if avail is not None:
        limits.append(avail)
    for limit_file, usage_file in _CGROUP_FILES:
        limit, usage = _read_int(limit_file), _read_int(usage_file)
        if limit is not None and usage is not None and limit < 2**60:
            limits.append(max(0, limit - usage))
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        size = _proc_kb("/proc/self/status", "VmSize")  # the address space in use
        limits.append(max(0, soft - (size or 0)))
    return min(limits) if limits else 2**63 - 1


def memory_budget() -> int:
    """The memory [bytes] a run may plan to use: :data:`BUDGET_FRACTION` of
    :func:`available_memory`, at least :data:`BUDGET_FLOOR`."""
    return max(BUDGET_FLOOR, int(BUDGET_FRACTION * available_memory()))


def format_bytes(n: float) -> str:
    """``n`` bytes as a short readable size: ``512 B``, ``3.2 MB``, ``41 GB``, ``2e+09 TB``."""
    for unit in ("B", "kB", "MB", "GB"):
        if abs(n) < 1000:
            return f"{n:.3g} {unit}"
        n /= 1000
    return f"{n:.3g} TB"


def require_memory(nbytes: float, what: str, advice: str,
                   error: type[MrneaError] = MrneaError) -> None:
    """Refuse, before allocating, a task that needs more memory than :func:`memory_budget`.

    Parameters
    ----------
    nbytes : the estimated peak memory of the task [bytes] (may be a float, inf or NaN: a
        count too large to compute is refused).
    what : what needs it, the start of the message (``"simulating 4.2e8 cycles of 4 joints"``).
    advice : what to change (``"use a coarser dt or a shorter program"``).
    error : the error type to raise (the caller's: a file reader's error names the file).

    Raises
    ------
    error
        ``<what> needs about X of memory, more than the Y mrnea may use (75 % of the Z
        available); <advice>``.
    """
    if nbytes <= BUDGET_FLOOR:  # also False for NaN: refused below
        return
    budget = memory_budget()
    if nbytes <= budget:
        return
    need = format_bytes(nbytes) if nbytes < 1e30 else "an impossible amount"
    avail = format_bytes(budget / BUDGET_FRACTION)
    raise error(f"{what} needs about {need} of memory, more than the {format_bytes(budget)} "
                f"mrnea may use ({BUDGET_FRACTION:.0%} of the {avail} available); {advice}")


def cpus() -> int:
    """The number of CPUs this process may run on (its affinity where the system tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


IDLE_READS = 5
"""Snapshots of the runnable tasks (:func:`idle_cpu`), 4 ms apart, of which one must show a
CPU idle: a task runnable for a moment (after a fresh run's compiling, with the second process
gone, the first snapshot showed one more every time: presumably the kernel writing back the
files just written) is not a busy core."""


def idle_cpu() -> bool:
    """A CPU idle now besides this process's: fewer runnable tasks (this one included) than
    CPUs for this process (/proc/loadavg's fourth field, a snapshot) in one of
    :data:`IDLE_READS` reads. False where /proc/loadavg cannot be read (not Linux: do not
    guess)."""
    n = cpus()
    for k in range(IDLE_READS):
        if k:
            time.sleep(0.004)
        try:
            with open("/proc/loadavg") as fh:
                running = int(fh.read().split()[3].split("/")[0])
        except (OSError, ValueError, IndexError):
            return False
        if running < n:
            return True
    return False
