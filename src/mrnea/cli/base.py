"""The ``mrnea`` group: error handling, interrupts, exit codes and the options commands share.

Every command module (``run``, ``info``, ``paper``...) adds its commands to :data:`main` with
``@main.command()`` and takes the shared options from here.

Errors: an :class:`~mrnea.errors.MrneaError` (or an OSError) ends the command with one
``mrnea: error:`` line on stderr and exit code 2 (``--debug``: the traceback instead).

Interrupts: Ctrl-C (SIGINT) and SIGTERM are handled alike. The first one is a request that the
command honours at its next :func:`checkpoint` (between two chunks of a simulation, between two
output files, at the end), never in the middle of a library call: a KeyboardInterrupt raised
asynchronously inside Numba's compiler or matplotlib can be swallowed (ctypes callbacks) or turn
the exit code into a death by SIGINT (CPython marks a KeyboardInterrupt that escapes an ``eval``
as unhandled). A simulation stopped this way keeps the cycles done and its command writes the
partial result, then exits 130, as shells do; elsewhere the command ends with
``mrnea: interrupted`` and exit code 130. A second signal stops at once (KeyboardInterrupt).
Files are written through :mod:`mrnea.io.writer`, so no temporary file is left behind.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NoReturn

import click

from mrnea.errors import MrneaError
from mrnea.io import load_robot_spec
from mrnea.io.pathcsv import INTERPOLATIONS
from mrnea.model import Robot

EXIT_ACHIEVABLE, EXIT_NOT_ACHIEVABLE, EXIT_BAD_INPUT = 0, 1, 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report an interrupted command


@contextlib.contextmanager
def compile_notice(delay: float = 2.0) -> Iterator[None]:
    """Say once on stderr that the kernels are compiling, if the block takes longer than delay.

    Numba compiles each kernel on its first call and caches it on disk; later runs skip this.
    """
    timer = threading.Timer(delay, lambda: click.echo(
        "Compiling mrnea's kernels (first run only, about a minute; cached afterwards)...",
        err=True))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


def load_any(spec: str) -> Robot:
    """A built-in robot by name, else a robot file (URDF or native TOML) by path."""
    return load_robot_spec(spec)


def fresh_dir(base: str) -> Path:
    """``base``, or ``base-2``, ``base-3``... : the first that does not exist or is empty."""
    for k in range(1, 10_000):
        p = Path(base if k == 1 else f"{base}-{k}")
        if not os.path.lexists(p) or (p.is_dir() and not any(p.iterdir())):
            return p
    raise click.ClickException(f"no free output folder next to {base}")


def exit_interrupted() -> NoReturn:
    """End a command whose run was interrupted (its partial result already written)."""
    sys.exit(EXIT_INTERRUPTED)


class _Stop:
    """Whether SIGINT or SIGTERM asked the running command to stop (see the module docstring)."""

    requested = False


def _request_stop(signum: int, frame: object) -> None:
    if _Stop.requested:  # a second signal: stop at once
        raise KeyboardInterrupt
    _Stop.requested = True


def checkpoint() -> None:
    """Raise KeyboardInterrupt here if a stop was requested since the last checkpoint that
    raised (a command calls it where stopping leaves a consistent state)."""
    if _Stop.requested:
        _Stop.requested = False
        raise KeyboardInterrupt


@contextlib.contextmanager
def _stop_requests() -> Iterator[None]:
    """SIGINT and SIGTERM become stop requests within the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _Stop.requested = False
    previous = {sig: signal.signal(sig, _request_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        _Stop.requested = False


class _Group(click.Group):
    """Turns input errors into one line on stderr and exit code 2, interrupts into exit 130."""

    def invoke(self, ctx: click.Context) -> object:
        with _stop_requests():
            try:
                result = super().invoke(ctx)
                checkpoint()  # a request after the command's last checkpoint
                return result
            except KeyboardInterrupt:
                click.echo("mrnea: interrupted", err=True)
                exit_interrupted()
            except (MrneaError, OSError) as exc:
                if ctx.params.get("debug"):
                    raise
                click.echo(f"mrnea: error: {exc}", err=True)
                sys.exit(EXIT_BAD_INPUT)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--debug", is_flag=True, help="Show full tracebacks on errors.")
@click.version_option(package_name="mrnea")
def main(debug: bool) -> None:
    """mrnea: robot dynamics with the modified recursive Newton-Euler algorithm.

    Tells, cycle by cycle, which joint accelerations the actuators can achieve and simulates the
    motion the robot will really make.
    """


# --- options shared by several commands ----------------------------------------------------------
mode_opt = click.option("--mode", type=click.Choice(["hybrid", "paper"]), default="hybrid",
                        show_default=True, help="How saturation is resolved (docs/achievable.md).")
fd_opt = click.option("--fd", type=click.Choice(["mrnea", "walker_orin", "crba"]),
                      default="mrnea", show_default=True,
                      help="How each cycle forms H and u' (results agree; cost differs).")
catch_opt = click.option("--catch-up", type=float, default=0.0, metavar="GAIN",
                         help="Position-loop gain [1/s] that steers back to the program after a "
                              "saturation (default 0: the paper's behaviour, the lag stays).")
quiet_opt = click.option("--quiet", "-q", is_flag=True, help="No progress bar, no verdict text.")
json_opt = click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
force_opt = click.option("--force", is_flag=True,
                         help="Replace existing output files (a link is replaced, never its "
                              "target).")


def program_args(command: Callable[..., Any]) -> Callable[..., Any]:
    """ROBOT PROGRAM [--dt] [--interpolation] [--mode] [--catch-up]: what a command simulating
    a program takes."""
    for option in reversed([
        click.argument("robot"),
        click.argument("program", type=click.Path(dir_okay=False)),
        click.option("--dt", type=float, default=None, help="Cycle time [s] (needed for a CSV)."),
        click.option("--interpolation", type=click.Choice(list(INTERPOLATIONS)), default=None,
                     help="How a CSV PROGRAM's rows are resampled to --dt [default: cubic]; "
                          "a program file sets it in [path]."),
        mode_opt,
        catch_opt,
    ]):
        command = option(command)
    return command
