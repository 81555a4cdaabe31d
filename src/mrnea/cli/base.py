"""The ``mrnea`` group: error handling, interrupts, exit codes and the options commands share.

Every command module (``run``, ``info``, ``paper``...) adds its commands to :data:`main` with
``@main.command()`` and takes the shared options from here.

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
import functools
import os
import re
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NamedTuple, NoReturn

import click
import numpy as np
from numba.core import event as numba_event

from mrnea.cartesian import CartesianPath
from mrnea.cartesian import solve as solve_moves
from mrnea.errors import MrneaError, clip, quote
from mrnea.io import RobotOptions, from_csv, is_program_file, load_program, load_robot_spec
from mrnea.io.gridfile import DEMO_PROGRAM
from mrnea.io.pathcsv import CSV_UNITS, INTERPOLATIONS
from mrnea.io.payload import parse_payload, parse_vector
from mrnea.io.program import Program
from mrnea.io.source import parse_number
from mrnea.model import Robot
from mrnea.robots.sdt_profile import training_program

EXIT_ACHIEVABLE, EXIT_NOT_ACHIEVABLE, EXIT_BAD_INPUT = 0, 1, 2
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report an interrupted command
MAX_LINE = 1000  # characters of an error or warning line (a safety net: messages quote briefly)
COMPILE_NOTICE = "Compiling mrnea's kernels (first run only, about a minute; cached afterwards)..."


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
    (exit 2, :func:`fail`)."""
    if not res.completed:
        exit_interrupted()
    checkpoint()  # a request after the run's last checkpoint
    sys.exit(EXIT_ACHIEVABLE if res.achievable else EXIT_NOT_ACHIEVABLE)


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


@contextlib.contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """Within the block every warning of the UserWarning family (ModelWarning included) prints
    once, as one ``mrnea: warning:`` line; other warnings (NumPy's RuntimeWarnings, deprecations
    in libraries) and NumPy's floating-point warnings are off."""
    seen: set[str] = set()

    def show(message: Warning | str, category: type[Warning], filename: str, lineno: int,
             file: object = None, line: str | None = None) -> None:
        text = one_line(str(message))
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
              "verification), 2 bad input or no timing found (the error says why), 130 "
              "interrupted (nothing written).",
    "sweep": "Exit code: 0 done (each row holds its own verdict), 2 bad input, 130 interrupted "
             "(the rows done written).",
    "size": "Exit code: 0 every joint sized and the sized robot verified achievable, 1 no "
            "drive in the catalogue fits a joint (the files are written), 2 bad input, 130 "
            "interrupted.",
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
                checkpoint()  # a request after the command's last checkpoint
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
                fail("out of memory; use a coarser dt or a shorter program")
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


# --- options shared by several commands ----------------------------------------------------------
mode_opt = click.option("--mode", type=click.Choice(["hybrid", "paper"]), default="hybrid",
                        show_default=True, help="How saturation is resolved (docs/achievable.md).")
fd_opt = click.option("--fd", type=click.Choice(["mrnea", "walker_orin", "crba"]),
                      default="mrnea", show_default=True,
                      help="How each cycle forms H and u' (results agree; cost differs).")
class Number(click.ParamType):
    """A number option in the strict grammar of :func:`mrnea.io.source.parse_number` (ASCII
    decimal or scientific notation; never ``1_0``, ``nan`` or ``inf``), finite, and either
    > 0 (``positive``) or >= 0."""

    name = "number"

    def __init__(self, positive: bool, at_most: float | None = None) -> None:
        self.positive, self.at_most = positive, at_most  # at_most: an upper bound, or None

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> float:
        if isinstance(value, float):  # a default
            number = value
        else:
            try:
                number = parse_number(value)
            except ValueError as exc:
                self.fail(str(exc), param, ctx)
        if self.positive and not number > 0:
            self.fail(f"must be > 0, got {quote(value)}", param, ctx)
        if not self.positive and not number >= 0:
            self.fail(f"must be >= 0, got {quote(value)}", param, ctx)
        if self.at_most is not None and number > self.at_most:
            self.fail(f"must be in (0, {self.at_most:g}], got {quote(value)}", param, ctx)
        return number


POSITIVE, NON_NEGATIVE = Number(positive=True), Number(positive=False)
FRACTION = Number(positive=True, at_most=1.0)  # in (0, 1]

catch_opt = click.option("--catch-up", type=NON_NEGATIVE, default=0.0, metavar="GAIN",
                         help="Position-loop gain [1/s] that steers back to the program after a "
                              "saturation (default 0: the paper's behaviour, the lag stays).")
quiet_opt = click.option("--quiet", "-q", is_flag=True, help="No progress bar, no verdict text.")
json_opt = click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
force_opt = click.option("--force", is_flag=True,
                         help="Replace existing output files (a link is replaced, never its "
                              "target).")
no_3d_opt = click.option("--no-3d", "no_3d", is_flag=True,
                         help="Leave the interactive 3D view out of report.html (then the page "
                              "has no script).")


class _Payload(click.ParamType):
    """``KG[@X,Y,Z]`` or a payload file (:func:`mrnea.io.payload.parse_payload`)."""

    name = "payload"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        try:
            return parse_payload(value, error=MrneaError)
        except MrneaError as exc:
            self.fail(str(exc), param, ctx)


class _Gravity(click.ParamType):
    """``GX,GY,GZ`` [m/s^2]: three finite numbers."""

    name = "gravity"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        try:
            return tuple(parse_vector(value, 3, "gravity", MrneaError).tolist())
        except MrneaError as exc:
            self.fail(str(exc), param, ctx)


def robot_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """--actuators, --tip, --payload, --gravity, --package-path: what changes the robot of a
    command that takes one. The command receives them as one keyword, ``robot_options`` (a
    :class:`~mrnea.io.RobotOptions`); they override a program file's keys of the same names."""
    @functools.wraps(command)
    def wrapper(*args: Any, actuators: str | None, tip: tuple[str, ...], payload: Any,
                gravity: Any, package_path: tuple[str, ...], **kw: Any) -> Any:
        tips = None if not tip else tip[0] if len(tip) == 1 else tuple(tip)
        return command(*args, robot_options=RobotOptions(actuators, tips, payload, gravity,
                                                         package_path or None), **kw)

    for option in reversed([
        click.option("--actuators", type=click.Path(dir_okay=False), metavar="FILE",
                     help="Sidecar actuator file (TOML: rotor inertia, gear, friction, "
                          "torque-speed curves per joint; docs/robot-format.md)."),
        click.option("--tip", metavar="LINK", multiple=True,
                     help="Keep the URDF's joints up to this link (a chain); repeated, the "
                          "subtree holding all the tips (default: the whole tree)."),
        click.option("--payload", type=_Payload(), metavar="KG[@X,Y,Z]|FILE",
                     help="A payload fixed to the last link: a mass [kg] at a point [m] of the "
                          "last link's frame, or a TOML file with mass, com and inertia."),
        click.option("--gravity", type=_Gravity(), metavar="GX,GY,GZ",
                     help="Gravity [m/s^2] in base coordinates (ceiling-mounted: 0,0,9.81)."),
        click.option("--package-path", "package_path", multiple=True, metavar="DIR",
                     type=click.Path(file_okay=False),
                     help="Where the URDF's package:// meshes are: a package's folder or one "
                          "holding it (repeatable; $ROS_PACKAGE_PATH is also searched)."),
    ]):
        wrapper = option(wrapper)
    return wrapper


def load_robot_arg(robot: str, options: RobotOptions) -> Robot:
    """The robot a command's ROBOT argument names (a built-in, a robot file, or a program
    file naming its robot), with ``options`` applied (over the program's)."""
    if is_program_file(robot):
        return load_program(robot).load_robot(options=options)
    return load_robot_spec(robot, options=options)


def load_program_arg(program: str) -> Program:
    """The program a command's PROGRAM argument names: ``demo`` (:data:`DEMO_PROGRAM`, the SDT
    demo's training profile, as ``examples/sdt_training.toml``) or a program file (.toml)."""
    return training_program() if program == DEMO_PROGRAM else load_program(program)


units_opt = click.option(
    "--units", type=click.Choice(list(CSV_UNITS)), default=None,
    help="The joint columns of a CSV PROGRAM: rad (SI: rad, m) [default] or deg (degrees for "
         "revolute joints, mm for prismatic ones); a program file sets it in [path].")


def program_args(command: Callable[..., Any]) -> Callable[..., Any]:
    """[ROBOT] PROGRAM [--dt] [--interpolation] [--units] [--mode] [--catch-up] and the robot
    options: what a command simulating a program takes (:func:`load_run` reads them)."""
    for option in reversed([
        click.argument("robot", required=False, metavar="[ROBOT]"),
        click.argument("program", required=False, metavar="PROGRAM",
                       type=click.Path(dir_okay=False)),
        click.option("--dt", type=POSITIVE, default=None, metavar="SECONDS",
                     help="Cycle time [s] (needed for a CSV)."),
        click.option("--interpolation", type=click.Choice(list(INTERPOLATIONS)), default=None,
                     help="How a CSV PROGRAM's rows are resampled to --dt [default: cubic]; "
                          "a program file sets it in [path]."),
        units_opt,
        mode_opt,
        catch_opt,
        robot_options,
    ]):
        command = option(command)
    return command


class Run(NamedTuple):
    """What :func:`load_run` reads: the robot and what to simulate on it."""

    robot: Robot
    q_cmd: np.ndarray  # (K, n) [rad | m]
    dt: float  # [s]
    f_ext: np.ndarray | None  # (K, 6) [N, N m] or None
    f_ext_point: np.ndarray | None  # (3,) [m] or None
    mode: str | None  # the program's mode, or None
    interpolation: str | None  # of a CSV path's rows; None for waypoints
    cartesian: CartesianPath | None = None  # a Cartesian program's tool path and verdict


def load_run(robot: str | None, program: str | None, dt: float | None,
             interpolation: str | None, options: RobotOptions, units: str | None = None) -> Run:
    """The :class:`Run` the arguments :func:`program_args` declares describe: ``[ROBOT]
    PROGRAM``, a program file (which may name its robot) or a CSV path.

    One argument is the program: it must name its robot. ``demo`` is the SDT demo's training
    profile (:func:`load_program_arg`). With both, ROBOT must be the robot the program names,
    if it names one (:meth:`mrnea.io.Program.load_robot`, which also warns
    where a resampled CSV path leaves a limit its rows respect).
    """
    if program is None:
        robot, program = None, robot
    suffix = "" if program is None else Path(program).suffix.lower()
    if program is None:
        raise click.UsageError("Missing argument 'PROGRAM'.")
    if units is not None and suffix != ".csv":
        raise click.UsageError("--units applies to a CSV PROGRAM; a program file sets 'units' in "
                               "its [path]")
    if robot is None and program != DEMO_PROGRAM and (suffix not in (".csv", ".toml") or (
            suffix == ".toml" and os.path.isfile(program) and not is_program_file(program))):
        raise click.UsageError(f"Missing argument 'PROGRAM' ({quote(program)} is taken as ROBOT: a "
                               f"program is a .toml file with a [program] table, a path .csv or "
                               f"{DEMO_PROGRAM!r})")
    if suffix == ".csv":
        if dt is None:
            raise click.UsageError("a CSV program needs --dt (the cycle time to resample to)")
        if robot is None:
            raise click.UsageError("a CSV program needs ROBOT (ROBOT PATH.csv --dt SECONDS)")
        rob = load_robot_spec(robot, options=options)
        interpolation = interpolation or "cubic"
        _, q = from_csv(program, dt, interpolation=interpolation, robot=rob,
                        units=units or "rad")
        return Run(rob, q, dt, None, None, None, interpolation)
    if suffix != ".toml" and program != DEMO_PROGRAM:
        raise click.UsageError(f"PROGRAM {program!r} is neither a program file (.toml), a "
                               f"path CSV (.csv) nor {DEMO_PROGRAM!r} (the SDT demo's profile)")
    prog = load_program_arg(program)
    if dt is not None and not np.isclose(dt, prog.dt):
        raise click.UsageError(
            f"--dt {dt} differs from the program's dt {prog.dt}; edit the program instead")
    if interpolation is not None and interpolation != prog.interpolation:
        raise click.UsageError(
            f"--interpolation {interpolation} differs from the program's "
            f"({prog.interpolation or 'a waypoint path'}); set 'interpolation' in its [path]")
    rob = prog.load_robot(robot, options)
    prog = solve_moves(prog, rob)  # a Cartesian program's joint path (others: unchanged)
    return Run(rob, prog.q_cmd, prog.dt, prog.f_ext, prog.f_ext_point, prog.mode,
               prog.interpolation, prog.cartesian)
