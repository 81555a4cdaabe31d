"""A sweep under hostile conditions: a scheduler address where no Dask scheduler answers (a
silent listener, a web server, a Dask worker) is one error within a bounded time; SIGTERM to the
process group stops a command-line sweep as Ctrl-C does; a huge grid is refused by its size
before its values are checked; every grid-file error names the file.

The servers are real (a TCP listener, an HTTP server on 127.0.0.1), each closed at the end of
its test."""

from __future__ import annotations

import contextlib
import http.server
import socket
import threading
import time
from collections.abc import Iterator

import pytest
from conftest import mrnea_cli, one_error_line

import mrnea
from mrnea.errors import SweepError
from mrnea.robots import sdt
from mrnea.sweep import cluster


@contextlib.contextmanager
def silent_listener() -> Iterator[str]:
    """A TCP port on 127.0.0.1 that accepts connections (the kernel's backlog) and never
    answers."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        yield f"tcp://127.0.0.1:{s.getsockname()[1]}"


@contextlib.contextmanager
def web_server() -> Iterator[str]:
    """An HTTP server on 127.0.0.1 (answers 501 to everything), stopped on exit."""
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), http.server.BaseHTTPRequestHandler)
    srv.RequestHandlerClass.log_message = lambda *a: None  # type: ignore[method-assign]
    thread = threading.Thread(target=srv.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{srv.server_address[1]}"
    finally:
        srv.shutdown()
        srv.server_close()
        thread.join(5)


def sweep_at(address: str) -> tuple[str, float]:
    """The error of a sweep on ``address`` and the seconds it took."""
    t0 = time.monotonic()
    with pytest.raises(SweepError) as info:
        mrnea.sweep(sdt(), "demo", {"payload": [1.0]}, client=address, progress=False)
    return str(info.value), time.monotonic() - t0


@pytest.mark.parametrize("server, words", [
    (silent_listener, ["accepted", "nothing answered as a Dask scheduler within 2 s"]),
    (web_server, ["a web server (HTTP) answers there", "not a Dask scheduler"]),
])
def test_no_scheduler_at_the_address_is_one_error_in_bounded_time(monkeypatch, server, words):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 2)
    with server() as address:
        message, seconds = sweep_at(address)
    assert message.startswith(f"scheduler '{address}': "), message
    for w in words:
        assert w in message, (w, message)
    bound = cluster.CONNECT_TIMEOUT + cluster.HTTP_TIMEOUT + 1.0  # docs/sweeps.md
    assert seconds < bound + 1.0, seconds  # a second of slack for a loaded machine


def test_a_dask_worker_is_not_a_scheduler(scheduler_address):
    from distributed import Client

    with Client(scheduler_address) as c:
        worker = next(iter(c.scheduler_info()["workers"]))
    message, seconds = sweep_at(worker)
    assert "a Dask Worker, not a scheduler" in message and seconds < 5, message


@pytest.mark.parametrize("address, words", [
    ("tcp://127.0.0.1:9", ["cannot connect", "refused", "is the scheduler running?"]),
    ("tcp://127.0.0.1", ["not an address", "tcp://HOST:PORT"]),
])
def test_nothing_listening_is_one_error_at_once(address, words):
    message, seconds = sweep_at(address)
    assert message.startswith(f"scheduler '{address}': ") and seconds < 2, (message, seconds)
    for w in words:
        assert w in message, (w, message)


@pytest.mark.slow
def test_the_command_line_gives_up_on_a_silent_listener(tmp_path):
    """``mrnea sweep --scheduler`` at a port that accepts and stays silent: one error line
    within the documented 12 s (the default timeouts), no output folder."""
    with silent_listener() as address:
        t0 = time.monotonic()
        r = mrnea_cli("sweep", "sdt", "demo", "--grid", "g.toml", "--scheduler", address,
                      "--out", "o", cwd=tmp_path_with_grid(tmp_path), timeout=120)
        seconds = time.monotonic() - t0
    one_error_line(r, address, "nothing answered as a Dask scheduler")
    assert seconds < 12 + 8, seconds  # 12 s, and the interpreter's start and imports
    assert not (tmp_path / "o").exists()


def tmp_path_with_grid(tmp_path):
    (tmp_path / "g.toml").write_text("[grid]\npayload = [0.0, 1.0]\n")
    return tmp_path
