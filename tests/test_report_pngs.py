"""Figures drawn as PNGs with a share in a forked child (mrnea.report.pngs): the bytes are those
of one process drawing each figure in turn, the child really draws its share, and a child that
fails or hangs is replaced by drawing here."""

from __future__ import annotations

import os
import sys
import threading

import numpy as np
import pytest
from matplotlib.figure import Figure

from mrnea.report import pngs
from mrnea.report.drawing import new_figure, png_bytes

LINUX = sys.platform.startswith("linux")


def _forks(monkeypatch: pytest.MonkeyPatch) -> None:
    """draw_pngs forks whatever the machine's load and whatever threads an earlier test in
    this worker left running (the children of the tests below draw no figure: they take no
    lock another thread could hold)."""
    monkeypatch.setattr(pngs, "idle_cpu", lambda: True)
    monkeypatch.setattr(pngs, "_can_fork", lambda: True)


def _figures() -> list[tuple[Figure, float]]:
    out = []
    for k in range(5):
        fig = new_figure(4.0 + k, 2.0)
        for i in range(k + 1):
            ax = fig.add_subplot(k + 1, 1, i + 1)
            ax.plot(np.linspace(0, 1, 50), np.sin(np.linspace(0, 7 + k + i, 50)))
            ax.set_title(f"figure {k} axes {i}")
        out.append((fig, 90.0 + 10 * k))
    return out


@pytest.mark.parametrize("idle", [True, False])
def test_same_bytes_as_one_process(idle: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """In order, byte for byte what matplotlib writes for each figure alone, dpi included,
    with a child or without."""
    monkeypatch.setattr(pngs, "idle_cpu", lambda: idle)
    jobs = _figures()
    want = [png_bytes(fig, dpi) for fig, dpi in jobs]
    assert pngs.draw_pngs(jobs) == want
    assert want[0][:8] == b"\x89PNG\r\n\x1a\n" and len(set(want)) == len(want)


@pytest.mark.skipif(not LINUX, reason="no fork here: not Linux")
def test_child_draws_its_share(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each figure is drawn by one of two processes, this one among them."""
    _forks(monkeypatch)
    monkeypatch.setattr(pngs, "png_bytes", lambda fig, dpi: str(os.getpid()).encode())
    got = pngs.draw_pngs(_figures())
    assert len(got) == 5 and len(set(got)) == 2 and str(os.getpid()).encode() in got


@pytest.mark.skipif(not LINUX, reason="no fork here: not Linux")
def test_failed_child_drawn_here(monkeypatch: pytest.MonkeyPatch) -> None:
    """A child that dies without answering: its share is drawn here, same bytes."""
    _forks(monkeypatch)
    jobs = _figures()
    want = [png_bytes(fig, dpi) for fig, dpi in jobs]
    monkeypatch.setattr(pngs, "_child", lambda fd, jobs: os._exit(3))
    assert pngs.draw_pngs(jobs) == want


@pytest.mark.skipif(not LINUX, reason="no fork here: not Linux")
def test_hung_child_killed(monkeypatch: pytest.MonkeyPatch) -> None:
    """A child that never answers is killed after the patience: no hang, same bytes."""
    import time

    _forks(monkeypatch)
    jobs = _figures()
    want = [png_bytes(fig, dpi) for fig, dpi in jobs]
    monkeypatch.setattr(pngs, "PATIENCE", 0.5)
    monkeypatch.setattr(pngs, "_child", lambda fd, jobs: (time.sleep(60), os._exit(0)))
    t0 = time.monotonic()
    assert pngs.draw_pngs(jobs) == want
    assert time.monotonic() - t0 < 30


def test_no_fork_with_threads() -> None:
    """Another Python thread running: everything is drawn here (no fork)."""
    stop = threading.Event()
    th = threading.Thread(target=stop.wait)
    th.start()
    try:
        assert not pngs._can_fork()
    finally:
        stop.set()
        th.join()
