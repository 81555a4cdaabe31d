"""Several figures drawn as PNG files at once: a share of them in a forked child process.

Drawing is most of a warm ``mrnea demo`` after its simulation (the Agg canvas: ticks, texts,
lines; about 0.5 s a figure for the SDT's six figures, one process, one core) and matplotlib
holds the GIL while it draws, so threads would not help. On Linux, with a CPU idle now
(:func:`mrnea.resources.idle_cpu`: on a loaded machine, or while the compile-ahead process,
cli/ahead.py, still runs, a child would only compete for the cores, and cost its own start:
fonts, text caches, about 0.3 s of CPU) and no other Python thread running,
:func:`draw_pngs` forks: the child (a copy of this process, figures included: nothing is
pickled but the PNG bytes it sends back) draws its share while this process draws the rest.
The objects both share are frozen out of the garbage collector meanwhile (``gc.freeze``), so
that neither copies the other's pages by collecting. The bytes are those of
:func:`mrnea.report.drawing.png_bytes` either way (the same figure, the same Agg code): only
the wall time differs. Elsewhere (Windows and macOS have no safe ``fork``; no idle CPU; a
thread that might hold a lock the child would need) everything is drawn here, one figure after
another.

The child never runs this process's exit handlers (it leaves by ``os._exit``), writes no file
and ignores stop requests (Ctrl-C reaches the whole process group: the command stops at its
next checkpoint, the child ends with its share or when its pipe closes). If the child fails or
has not answered within :data:`PATIENCE` seconds plus its share's estimated time, it is killed
and this process draws its share itself.
"""

from __future__ import annotations

import gc
import os
import pickle
import select
import signal
import sys
import threading
import time
from collections.abc import Sequence
from typing import cast

from matplotlib.figure import Figure

from mrnea.report.drawing import png_bytes
from mrnea.resources import idle_cpu

PATIENCE = 30.0
"""Seconds the child may take beyond this process's own drawing before it is given up."""


def _can_fork() -> bool:
    """Linux, and no other Python thread (a forked child inherits only the calling thread: a
    lock another one held would never be released in it)."""
    return sys.platform.startswith("linux") and threading.active_count() == 1


def _cost(job: tuple[Figure, float]) -> float:
    """A figure's estimated drawing time [arbitrary units]: its pixel area times four plus its
    axes' count (each axes draws its ticks, texts and lines; measured on the demo's figures,
    0.4-1.0 s each)."""
    fig, dpi = job
    w, h = fig.get_size_inches()
    return (4 + len(fig.axes)) * w * h * dpi * dpi


def _split(jobs: Sequence[tuple[Figure, float]]) -> tuple[list[int], list[int]]:
    """Indices of ``jobs`` for this process and for the child: the costliest first, each to
    the one with less so far (longest processing time first)."""
    here: list[int] = []
    child: list[int] = []
    load = [0.0, 0.0]
    for i in sorted(range(len(jobs)), key=lambda i: -_cost(jobs[i])):
        k = 0 if load[0] <= load[1] else 1
        (here, child)[k].append(i)
        load[k] += _cost(jobs[i])
    return here, child


def _child(write_fd: int, jobs: Sequence[tuple[Figure, float]]) -> None:
    """In the forked child: draw ``jobs``, send their bytes, leave without exit handlers."""
    code = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        data = pickle.dumps([png_bytes(fig, dpi) for fig, dpi in jobs])
        with os.fdopen(write_fd, "wb") as fh:
            fh.write(data)
        code = 0
    finally:
        os._exit(code)


def _collect(pid: int, read_fd: int, deadline: float) -> list[bytes] | None:
    """The child's PNG bytes, or None (it failed, or the deadline passed: it is killed).
    Reaps the child and closes ``read_fd`` whatever happens."""
    chunks = []
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([read_fd], [], [], left)[0]:
                os.kill(pid, signal.SIGKILL)
                return None
            chunk = os.read(read_fd, 1 << 20)
            if not chunk:
                break
            chunks.append(chunk)
    finally:
        os.close(read_fd)
        _, status = os.waitpid(pid, 0)
    if status != 0:
        return None
    try:
        return pickle.loads(b"".join(chunks))
    except (pickle.UnpicklingError, EOFError):
        return None


def draw_pngs(jobs: Sequence[tuple[Figure, float]]) -> list[bytes]:
    """Each ``(figure, dpi)`` of ``jobs`` drawn as a PNG file
    (:func:`mrnea.report.drawing.png_bytes`), in order; a share of them in a forked child
    where that can gain (module docstring)."""
    jobs = list(jobs)
    out: list[bytes | None] = [None] * len(jobs)
    pid = None
    here = list(range(len(jobs)))
    if len(jobs) >= 2 and _can_fork() and idle_cpu():
        here, there = _split(jobs)
        read_fd, write_fd = os.pipe()
        gc.freeze()  # neither process's collector writes to the objects they share (copy-on-write)
        try:
            pid = os.fork()
        except OSError:  # no process to spare: all drawn here
            gc.unfreeze()
            os.close(read_fd)
            os.close(write_fd)
            here = list(range(len(jobs)))
        else:
            if pid == 0:
                gc.disable()  # short-lived: its garbage goes with it
                os.close(read_fd)
                _child(write_fd, [jobs[i] for i in there])
            os.close(write_fd)
    try:
        start = time.monotonic()
        for i in here:
            out[i] = png_bytes(*jobs[i])
    except BaseException:  # failed or interrupted while drawing its share: the child goes
        if pid is not None:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            os.close(read_fd)
            gc.unfreeze()
        raise
    if pid is not None:
        ratio = (sum(_cost(jobs[i]) for i in there)
                 / max(sum(_cost(jobs[i]) for i in here), 1e-9))
        deadline = time.monotonic() + PATIENCE + ratio * (time.monotonic() - start)
        got = _collect(pid, read_fd, deadline)
        gc.unfreeze()
        if got is None or len(got) != len(there):
            got = [png_bytes(*jobs[i]) for i in there]
        for i, png in zip(there, got, strict=True):
            out[i] = png
    return cast(list[bytes], out)  # every index drawn, here or by the child
