"""The ``mrnea`` group: error handling, interrupts and exit codes.

Every command module (``run``, ``info``, ``paper``...) adds its commands to :data:`main` with
``@main.command()`` and takes the shared options and arguments from :mod:`mrnea.cli.options`.

Exit codes, one rule for every command: 0 achievable (a command without a verdict -- info,
fig3, sweep -- done), 1 NOT ACHIEVABLE (the verdict of demo, simulate, check and retime, after
their files are written: :func:`exit_with_verdict`), 2 bad input, 130 interrupted.

Errors: every bad input ends the command with exactly one ``mrnea: error:`` line on stderr and
exit code 2: an :class:`~mrnea.errors.MrneaError` or an OSError, click's usage errors (a missing
argument, an unknown option or command, a bad value), and, as a last resort, any other exception
(said to be an internal error). The line is one line whatever it quotes (control characters are
escaped) and of bounded length. ``--debug`` lets an exception (and its traceback) through.
Warnings print once each as one ``mrnea: warning:`` line (no source line); NumPy's floating-point
warnings are off during a command (the values that matter are checked).

Interrupts: Ctrl-C (SIGINT) and SIGTERM are handled alike. The first one is a request that the
command honours at its next :func:`checkpoint` (between two chunks of a simulation, between two
output files, at the end: its :func:`last_checkpoint` just before it prints its answer, after
which a request is too late), never in the middle of a library call: a KeyboardInterrupt raised
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
import re
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

import click
import numpy as np
from numba.core import event as numba_event

from mrnea.errors import MrneaError, clip, quote
from mrnea.io.writer import all_or_none

EXIT_ACHIEVABLE, EXIT_NOT_ACHIEVABLE, EXIT_BAD_INPUT = 0, 1, 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report an interrupted command
MAX_LINE = 1000  # characters of an error or warning line (a safety net: messages quote briefly)
# "up to a minute": the slowest first run, mrnea demo, compiles for 70 s CPU on a loaded 2-core
# machine (docs/performance.md, Start-up: 90 s there before the engine cut, which measured
# 65.6 s on a quieter one)
COMPILE_NOTICE = ("Compiling mrnea's kernels (first run only, up to a minute; cached "
                  "afterwards)...")


class _CompileNotice(numba_event.Listener):
    """Prints :data:`COMPILE_NOTICE` when Numba starts compiling a kernel, once per process.

    Numba raises the ``numba:compile`` event only when it really compiles (a kernel loaded from
    its disk cache raises none), so a cached run never sees the notice, and listening costs
    nothing there.
    """

    shown = False

    def on_start(self, event: numba_event.Event) -> None:
        if not _CompileNotice.shown:
            _CompileNotice.shown = True
            click.echo(COMPILE_NOTICE, err=True)

    def on_end(self, event: numba_event.Event) -> None:
        pass


@contextlib.contextmanager
def compile_notice(quiet: bool = False) -> Iterator[None]:
    """Say once on stderr that the kernels are compiling, if Numba compiles one within the
    block (never with ``quiet``).

    Numba compiles each kernel on its first call and caches it on disk; later runs load it.
    """
    if quiet:
        yield
        return
    with numba_event.install_listener("numba:compile", _CompileNotice()):
        yield


_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def one_line(text: str) -> str:
    """``text`` as one printable line: control characters (a newline in a file name...) escaped,
    characters the terminal cannot encode (a file name's undecodable bytes) escaped, at most
    :data:`MAX_LINE` characters."""
    text = _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), str(text))
    text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    if len(text) > MAX_LINE:
        text = f"{text[:MAX_LINE // 2]} ... {text[-MAX_LINE // 3:]}"
    return text


def as_option(message: str, options: Mapping[str, str]) -> str:
    """A library error's ``message`` in the command's words: each argument name of ``options``
    (the library's keyword: the command's option) that the message mentions as a word
    (``cutoff_hz: ...``, ``faster than min_speed``) becomes the option (``--cutoff``,
    ``--min-speed``)."""
    if not options:
        return message
    words = "|".join(sorted(map(re.escape, options), key=len, reverse=True))
    return re.sub(rf"(?<![\w-])({words})(?![\w-])", lambda m: options[m[1]], message)


def fail(message: str) -> NoReturn:
    """End the command with one ``mrnea: error:`` line and exit code 2."""
    click.echo(f"mrnea: error: {one_line(clip(message))}", err=True)
    sys.exit(EXIT_BAD_INPUT)


def fresh_dir(base: str) -> Path:
    """A command's default output folder: ``base``, or ``base-2``, ``base-3``... , the first that
    does not exist or is an empty folder. A symbolic link at a name (to a folder, empty or not,
    or dangling) is never taken: it counts as used, as a file does, so that a link planted at
    ``./mrnea-out`` is not written through (:func:`mrnea.io.writer.own_folder` refuses one that
    appears between this choice and the run)."""
    for k in range(1, 10_000):
        p = Path(base if k == 1 else f"{base}-{k}")
        if not os.path.lexists(p):
            return p
        if not p.is_symlink() and p.is_dir() and not any(p.iterdir()):
            return p
    raise click.ClickException(f"no free output folder next to {base}")


def exit_interrupted() -> NoReturn:
    """End a command whose run was interrupted (its partial result already written)."""
    sys.exit(EXIT_INTERRUPTED)


def exit_with_verdict(res: Any) -> NoReturn:
    """End a command that simulated a run (:class:`mrnea.simulate.SimulationResult`), its
    output written, by the one rule of every command: 0 achievable, 1 NOT ACHIEVABLE (a verdict,
    not an error), 130 interrupted (the partial result written); bad input never gets here
    (exit 2, :func:`fail`). The caller's :func:`last_checkpoint` is before it prints the
    verdict: a stop requested once the verdict is out is too late (the answer was given), so
    the verdict's code stands."""
    if not res.completed:
        exit_interrupted()
    sys.exit(EXIT_ACHIEVABLE if res.achievable else EXIT_NOT_ACHIEVABLE)


class _Stop:
    """Whether SIGINT or SIGTERM asked the running command to stop (see the module docstring),
    and whether the command has passed its :func:`last_checkpoint`."""

    requested = False
    answered = False


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


def write_files(steps: Sequence[tuple[Path, Callable[[], object]]],
                side_files: Sequence[Path] = ()) -> None:
    """A command's output files: each ``(path, write)`` of ``steps`` in turn, a
    :func:`checkpoint` before each and after the last. ``side_files``: files a step may write
    besides its own (a retimed program's payload). All of the new files or none
    (:func:`mrnea.io.writer.all_or_none`): a file about to be replaced (``--force``: a file
    there has passed ``check_new``) is moved aside first; on a stop request (or any error) the
    files written are removed and the old ones put back, and the interrupt goes on."""
    with all_or_none([*(path for path, _ in steps), *side_files], overwrite=True):
        for _, write in steps:
            checkpoint()
            write()
        checkpoint()


def last_checkpoint() -> None:
    """The command's last :func:`checkpoint`: after its files, just before it prints its answer.
    A stop requested from here on is too late (the answer is given) and leaves the command's
    exit code as it is: printing the answer and then exiting 130 said both."""
    checkpoint()
    _Stop.answered = True


@contextlib.contextmanager
def _stop_requests() -> Iterator[None]:
    """SIGINT and SIGTERM become stop requests within the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _Stop.requested = _Stop.answered = False
    previous = {sig: signal.signal(sig, _request_stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)
        _Stop.requested = _Stop.answered = False


@contextlib.contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """Within the block every warning of the UserWarning family (ModelWarning included) prints
    once, as one ``mrnea: warning:`` line; other warnings (NumPy's RuntimeWarnings, deprecations
    in libraries) and NumPy's floating-point warnings are off."""
    seen: set[str] = set()

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: object = None, line: str | None = None) -> None:
        # a warning worded for the command line where the library's names an API argument
        text = one_line(getattr(message, "cli", None) or str(message))
        if text not in seen:
            seen.add(text)
            click.echo(f"mrnea: warning: {text}", err=True)
            hint = getattr(message, "hint", None)  # what to do, on its own line (MeshWarning)
            if hint:
                click.echo(f"mrnea: hint: {one_line(hint)}", err=True)

    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        warnings.simplefilter("always", UserWarning)
        warnings.showwarning = show
        yield


def _usage_line(exc: click.UsageError) -> str:
    """A click usage error as one line naming the command and pointing to its ``--help``."""
    names = []
    ctx = exc.ctx
    while ctx is not None and ctx.parent is not None:
        names.append(ctx.info_name or "")
        ctx = ctx.parent
    command = " ".join(["mrnea", *reversed(names)])
    where = f"{command.removeprefix('mrnea ')}: " if names else ""
    message = exc.format_message().strip().rstrip(".")
    return f"{where}{message} (see '{command} --help')"


#: Every command's ``--help`` epilog stating its exit codes (:meth:`_Group.add_command` sets
#: it): the commands whose answer is a verdict by name, every other one :data:`EXIT_DONE`.
EXIT_CODES = {
    "demo": "Exit code: 0 achievable, 1 NOT ACHIEVABLE (the demo's verdict, on purpose; the "
            "files are written), 2 bad input, 130 interrupted (the partial result written).",
    "simulate": "Exit code: 0 achievable, 1 NOT ACHIEVABLE (the verdict; the files are "
                "written), 2 bad input, 130 interrupted (the partial result written).",
    "check": "Exit code: 0 achievable, 1 NOT ACHIEVABLE (the verdict), 2 bad input, 130 "
             "interrupted.",
    "retime": "Exit code: 0 retimed and verified achievable, 1 NOT ACHIEVABLE (the "
              "verification, or no timing exists: nothing written), 2 bad input, 130 "
              "interrupted (nothing written).",
    "sweep": "Exit code: 0 done (each row holds its own verdict), 2 bad input, 130 interrupted "
             "(the rows done written).",
    "size": "Exit code: 0 every joint sized and the sized robot verified achievable, 1 no "
            "drive in the catalogue fits a joint or the sized robot is not achievable (the "
            "files are written), 2 bad input, 130 interrupted.",
}
EXIT_DONE = "Exit code: 0 done, 2 bad input, 130 interrupted."


class _Group(click.Group):
    """Turns every error into one line on stderr and exit code 2, interrupts into exit 130;
    gives every command the epilog of its exit codes (:data:`EXIT_CODES`)."""

    def add_command(self, cmd: click.Command, name: str | None = None) -> None:
        cmd.epilog = EXIT_CODES.get(name or cmd.name or "", EXIT_DONE)
        super().add_command(cmd, name)

    def main(self, args: Any = None, prog_name: str | None = None,
             complete_var: str | None = None, standalone_mode: bool = True, **extra: Any) -> Any:
        # the command says it compiles in its own words (compile_notice, never with --quiet):
        # the library's notice (mrnea/compiled.py) off here and in the processes it starts
        os.environ["MRNEA_COMPILE_NOTICE"] = "0"
        self.argv = [str(a) for a in (sys.argv[1:] if args is None else args)]
        try:
            rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click.exceptions.NoArgsIsHelpError as exc:  # ``mrnea`` alone: the help
            click.echo(exc.ctx.get_help() if exc.ctx else "")
            rv = 0
        except click.UsageError as exc:
            fail(_usage_line(exc))
        except click.ClickException as exc:
            fail(exc.format_message())
        except click.Abort:  # Ctrl-C while click parsed the command line
            click.echo("mrnea: interrupted", err=True)
            exit_interrupted()
        if not standalone_mode:
            return rv
        sys.exit(rv if isinstance(rv, int) else 0)

    def invoke(self, ctx: click.Context) -> object:
        debug = bool(ctx.params.get("debug"))
        with _stop_requests(), _warnings_as_lines():
            try:
                result = super().invoke(ctx)
                if not _Stop.answered:  # a request after the command's last checkpoint
                    checkpoint()
                return result
            except KeyboardInterrupt:
                click.echo("mrnea: interrupted", err=True)
                exit_interrupted()
            except (click.ClickException, click.exceptions.Exit, click.Abort):
                raise  # usage errors, --help, --version: main() deals with them
            except (MrneaError, OSError) as exc:
                if debug:
                    raise
                fail(getattr(exc, "cli", None) or str(exc))  # in the command line's words
            except MemoryError:
                if debug:
                    raise
                files = ", ".join(dict.fromkeys(  # the command's input files, if any
                    quote(a) for a in getattr(self, "argv", ()) if os.path.isfile(a)))
                fail(f"out of memory{f' (on {files})' if files else ''}: use a coarser dt or "
                     "a shorter program")
            except Exception as exc:  # a bug: still one line, the traceback with --debug
                if debug:
                    raise
                fail(f"internal error, please report it ({type(exc).__name__}: "
                     f"{quote(str(exc), 200)}; --debug shows the traceback)")


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--debug", is_flag=True, help="Show full tracebacks on errors.")
@click.version_option(package_name="mrnea")
def main(debug: bool) -> None:
    """mrnea: robot dynamics with the modified recursive Newton-Euler algorithm.

    Tells, cycle by cycle, which joint accelerations the actuators can achieve and simulates the
    motion the robot will really make.

    Exit codes, every command: 0 achievable (or done, for info, fig3 and sweep), 1 NOT
    ACHIEVABLE (a verdict: demo, simulate, check, retime), 2 bad input (one 'mrnea: error:'
    line), 130 interrupted (a run writes its partial result first).
    """
