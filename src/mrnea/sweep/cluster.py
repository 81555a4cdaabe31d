"""The sweep's Dask cluster: mrnea's own LocalCluster, or a scheduler address checked first.

* :func:`client` gives the ``distributed.Client`` a sweep runs on: the one given, one of a new
  LocalCluster (closed on exit), or one connected to a scheduler address after
  :func:`check_scheduler` found a Dask scheduler there.
* :func:`check_scheduler` bounds the time an address can take: a ``tcp://`` address that
  refuses, accepts and stays silent, or answers as something else (a web server, a Dask
  worker) is one :class:`~mrnea.errors.SweepError` naming the address and what was wrong,
  within :data:`CONNECT_TIMEOUT` + :data:`HTTP_TIMEOUT` seconds (``distributed.Client`` alone
  waits forever on a silent listener, whatever its ``timeout``, and takes a web server's
  reply for a message gigabytes long).
* :func:`quiet` silences distributed's logs and warnings during the sweep.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import socket
import threading
import time
import warnings
from collections.abc import Iterator
from typing import Any

from mrnea.errors import SweepError, quote

__all__ = ["CLUSTER_CONFIG", "CONNECT_TIMEOUT", "HTTP_TIMEOUT", "WORKER_ENVIRON",
           "WORKER_MALLOC", "check_scheduler", "client",
           "quiet", "spawning"]

#: glibc settings of the LocalCluster's workers (:func:`spawning`): trim at 128 MB, arrays of
#: up to 32 MB from the heap.
WORKER_MALLOC = {"MALLOC_TRIM_THRESHOLD_": 134217728, "MALLOC_MMAP_THRESHOLD_": 33554432}
#: The LocalCluster's workers' environment (:func:`spawning`): the glibc settings, and Numba's
#: thread pool of one thread (a worker runs one task at a time, each on one thread; a pool of
#: the machine's size, started by a retime's parallel kernels, only competes for the cores).
WORKER_ENVIRON = {**WORKER_MALLOC, "NUMBA_NUM_THREADS": 1}
#: The LocalCluster's Dask settings, scheduler and workers (:func:`spawning`): no statistical
#: profiler (it samples every thread's stack each 10 ms on a worker's event-loop thread, for a
#: dashboard this cluster does not have) and the event loops' tick check once a second instead
#: of every 20 ms (it only warns of a blocked loop, and the sweep silences the warnings). An
#: idle 1-worker cluster took 5.2 % of a core with Dask's defaults and the profiler off, 2.0 %
#: with these (docs/performance.md section 12); on a machine whose cores are all busy that CPU
#: comes out of the runs.
CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False,
                  "distributed.admin.tick.interval": "1000ms"}
#: Seconds a scheduler address has to accept the connection and answer as a Dask scheduler,
#: all told (a scheduler answers in milliseconds).
CONNECT_TIMEOUT = 10
#: Seconds more, after an address did not answer as a scheduler, to tell whether a web server
#: listens there (the usual mistake: the dashboard's port, 8787, for the scheduler's, 8786).
HTTP_TIMEOUT = 1
#: Signals the LocalCluster's workers ignore: a terminal's Ctrl-C and a service manager's stop
#: reach the whole process group; only the client acts on them.
WORKER_IGNORES = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def spawning() -> Iterator[None]:
    """The settings under which this process starts its LocalCluster's worker processes.

    * SIGINT and SIGTERM ignored while they start, so they inherit them ignored (an ignored
      signal stays ignored across ``exec``): Ctrl-C in a terminal, and the SIGTERM a container
      stop, systemd or a batch scheduler sends, reach the whole process group, and only this
      process should act on them (cancel, keep the rows, close the cluster), not every worker
      dying with its tasks (their rows would be lost or turn into failures). A worker still
      ends with this process: distributed's workers exit when their parent goes away. A
      signal during those 1-3 s is lost (blocking the signal instead did not keep it pending:
      a thread distributed starts takes it).
    * glibc's heap kept for the runs' arrays: distributed's ``MALLOC_TRIM_THRESHOLD_=65536``
      also fixes glibc's mmap threshold at 128 kB, so each run's MB-sized arrays are mapped and
      faulted in afresh (5x the page faults, +35 % CPU per run, measured); trim at 128 MB with
      a 32 MB mmap threshold instead (:data:`WORKER_MALLOC`); Numba's thread pool of one
      thread (:data:`WORKER_ENVIRON`).
    * ``os.environ`` restored afterwards: distributed's Nanny writes its worker variables
      (``OMP_NUM_THREADS=1``...) into this process's environment. Meanwhile the variables of
      :data:`WORKER_ENVIRON` are taken out of it: the Nanny lets a variable of this process's
      environment override its config, and an earlier cluster of this process (a user's,
      started without these settings) leaves distributed's ``MALLOC_TRIM_THRESHOLD_=65536``
      there.
    * Dask's statistical profiler off and a slow tick (:data:`CLUSTER_CONFIG`; the scheduler
      is created here, and a Nanny hands its worker the configuration it was created under).
    """
    import dask

    environ = dict(os.environ)
    main = threading.current_thread() is threading.main_thread()
    old = {s: signal.signal(s, signal.SIG_IGN) for s in WORKER_IGNORES} if main else {}
    try:
        key = "distributed.nanny.pre-spawn-environ"
        for name in WORKER_ENVIRON:
            os.environ.pop(name, None)
        with dask.config.set({key: {**dask.config.get(key), **WORKER_ENVIRON},
                              **CLUSTER_CONFIG}):
            yield
    finally:
        os.environ.clear()
        os.environ.update(environ)
        for s, handler in old.items():
            signal.signal(s, handler)


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """distributed's logs and warnings off (a failed task becomes its rows' error)."""
    log = logging.getLogger("distributed")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            yield
    finally:
        log.setLevel(level)


# --- a scheduler's address -----------------------------------------------------------------


def _host_port(address: str) -> tuple[str, int] | None:
    """(host, port) of a ``tcp://`` address (or one without a protocol), else None."""
    from distributed.comm import parse_address, parse_host_port

    try:
        protocol, location = parse_address(address)
        if protocol != "tcp":
            return None
        host, port = parse_host_port(location)
    except (ValueError, TypeError):
        raise SweepError(f"scheduler {quote(address)}: not an address; expected "
                         "tcp://HOST:PORT") from None
    if not port:
        raise SweepError(f"scheduler {quote(address)}: no port; expected tcp://HOST:PORT "
                         "(a scheduler listens on 8786 by default)")
    return host, int(port)


async def _identity(address: str, timeout: float) -> Any:
    """What the server at ``address`` says it is, through distributed's own protocol."""
    from distributed.comm import connect

    comm = await connect(address, timeout=timeout)
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    finally:
        comm.abort()


def _in_thread(address: str, timeout: float) -> Any:
    """:func:`_identity` in a thread of its own (so it also runs under a running event loop,
    as in a notebook), given up after ``timeout`` seconds; its exception, or TimeoutError."""
    out: list[Any] = [TimeoutError()]

    def ask() -> None:
        try:
            out[0] = asyncio.run(asyncio.wait_for(_identity(address, timeout), timeout))
        except BaseException as exc:  # a garbled answer may raise anything (MemoryError)
            out[0] = exc

    thread = threading.Thread(target=ask, name="mrnea-scheduler-check", daemon=True)
    thread.start()
    thread.join(timeout + 1.0)
    return out[0]


def _speaks_http(host: str, port: int) -> bool:
    """Whether a web server answers at (host, port) within :data:`HTTP_TIMEOUT` seconds."""
    try:
        with socket.create_connection((host, port), timeout=HTTP_TIMEOUT) as s:
            s.settimeout(HTTP_TIMEOUT)
            s.sendall(b"HEAD / HTTP/1.0\r\n\r\n")
            return s.recv(5) == b"HTTP/"
    except OSError:
        return False


def check_scheduler(address: str) -> None:
    """Raise :class:`~mrnea.errors.SweepError` unless a Dask scheduler answers at ``address``.

    For a ``tcp://`` address (distributed's default protocol) it takes at most
    :data:`CONNECT_TIMEOUT` seconds, plus :data:`HTTP_TIMEOUT` when the address does not
    answer as a scheduler (to say whether a web server is there); other protocols (``tls://``,
    ``ucx://``) are left to ``distributed.Client``.

    Raises
    ------
    SweepError
        Naming the address and what was wrong: not an address, nothing listening (connection
        refused), a host that cannot be reached, a listener that stays silent, a web server,
        a Dask worker, something else that does not speak Dask's protocol.
    """
    where = _host_port(address)
    if where is None:
        return
    host, port = where
    name = f"scheduler {quote(address)}"
    t0 = time.monotonic()
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT).close()
    except TimeoutError:
        raise SweepError(f"{name}: cannot connect: no answer from {host} within "
                         f"{CONNECT_TIMEOUT} s (a firewall, or a host that is down)") from None
    except OSError as exc:
        why = exc.strerror or type(exc).__name__
        hint = "; is the scheduler running?" if isinstance(exc, ConnectionRefusedError) else ""
        raise SweepError(f"{name}: cannot connect ({why}){hint}") from None
    left = max(CONNECT_TIMEOUT - (time.monotonic() - t0), 1.0)
    answer = _in_thread(address, left)
    if isinstance(answer, dict) and answer.get("type") == "Scheduler":
        return
    if isinstance(answer, dict) and answer.get("type"):
        raise SweepError(f"{name}: a Dask {answer['type']}, not a scheduler, answers there; "
                         "give the scheduler's address")
    if _speaks_http(host, port):
        raise SweepError(f"{name}: a web server (HTTP) answers there, not a Dask scheduler "
                         "(the dashboard's port, 8787 by default, is not the scheduler's, "
                         "8786)")
    if isinstance(answer, TimeoutError):
        raise SweepError(f"{name}: the connection was accepted but nothing answered as a Dask "
                         f"scheduler within {left:.0f} s; not a Dask scheduler (or one too "
                         "busy to answer)")
    raise SweepError(f"{name}: the server there does not speak Dask's protocol "
                     f"({type(answer).__name__}: {quote(str(answer), 120)}); not a Dask "
                     "scheduler")


@contextlib.contextmanager
def client(given: Any, workers: int | None) -> Iterator[Any]:
    """A ``distributed.Client``: the one given, one connected to a scheduler address (checked
    first: :func:`check_scheduler`), or one of a new LocalCluster (closed on exit)."""
    from distributed import Client, LocalCluster

    if given is None:
        n = workers or len(os.sched_getaffinity(0))
        with spawning():  # the dashboard off, and the scheduler's HTTP server on a free port:
            cluster = LocalCluster(  # on 8787 it warns when another cluster holds that port
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                silence_logs=logging.CRITICAL, scheduler_kwargs={"dashboard_address": ":0"})
        with cluster, Client(cluster) as c:
            yield c
    elif isinstance(given, str):
        check_scheduler(given)
        try:
            c = Client(given, timeout=f"{CONNECT_TIMEOUT}s")
        except (OSError, TimeoutError, ValueError) as exc:
            raise SweepError(f"scheduler {quote(given)}: cannot connect ({exc})") from None
        with c:
            yield c
    else:
        yield given
