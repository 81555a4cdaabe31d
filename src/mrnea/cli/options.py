"""What the ``mrnea`` commands take: the options and arguments several commands share, and the
robot and run they name.

:func:`robot_options` (--actuators, --tip, --payload, --gravity, --package-path) changes the robot
of a command that takes one; :func:`program_args` declares ``[ROBOT] PROGRAM`` with the options of
a command that simulates a program, and :func:`load_run` reads them into a :class:`Run`. Number
options use :class:`Number`, the strict grammar of :func:`mrnea.io.source.parse_number`. How a
command runs and ends (errors, interrupts, exit codes) is :mod:`mrnea.cli.base`.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import click
import numpy as np

from mrnea.cartesian import CartesianPath
from mrnea.cartesian import solve as solve_moves
from mrnea.cli.base import checkpoint
from mrnea.errors import MrneaError, quote
from mrnea.io import RobotOptions, from_csv, is_program_file, load_program, load_robot_spec
from mrnea.io.gridfile import DEMO_PROGRAM
from mrnea.io.pathcsv import CSV_UNITS, INTERPOLATIONS
from mrnea.io.payload import parse_payload, parse_vector
from mrnea.io.program import Program, parse_toml
from mrnea.io.source import parse_number
from mrnea.model import Robot
from mrnea.robots.sdt_profile import training_program

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


class _Folder(click.Path):
    """``--out``: an output folder, never a file; an empty value is refused (a shell's unset
    ``--out "$DIR"`` would otherwise write into the current folder or a default one)."""

    def __init__(self) -> None:
        super().__init__(file_okay=False)

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        if isinstance(value, str) and not value.strip():
            self.fail("an empty path; give a folder (or leave the option out where it has a "
                      "default)", param, ctx)
        return super().convert(value, param, ctx)


FOLDER = _Folder()


class _NonEmpty(click.Path):
    """A path option (``--actuators``, ``--package-path``) that refuses an empty value: a
    shell's unset ``"$VAR"`` gave ``--actuators`` an error that did not name the option, and
    ``--package-path`` the current folder, silently."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        if isinstance(value, str) and not value.strip():
            self.fail("an empty path; give one, or leave the option out", param, ctx)
        return super().convert(value, param, ctx)


class _Payload(click.ParamType):
    """``KG[@X,Y,Z]``, ``KG@LINK[:X,Y,Z]`` or a payload file
    (:func:`mrnea.io.payload.parse_payload`)."""

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
        return command(*args, robot_options=RobotOptions(actuators, tips, payload or None, gravity,
                                                         package_path or None), **kw)

    for option in reversed([
        click.option("--actuators", type=_NonEmpty(dir_okay=False), metavar="FILE",
                     help="Sidecar actuator file (TOML: rotor inertia, gear, friction, "
                          "torque-speed curves per joint; docs/robot-format.md)."),
        click.option("--tip", metavar="LINK", multiple=True,
                     help="Keep the URDF's joints up to this link (a chain); repeated, the "
                          "subtree holding all the tips (default: the whole tree)."),
        click.option("--payload", type=_Payload(), metavar="KG[@[LINK:]X,Y,Z]|FILE",
                     multiple=True,
                     help="A payload fixed to the last link (or to LINK: KG@LINK[:X,Y,Z]): "
                          "a mass [kg] at a point [m] of that link's frame, or a TOML file "
                          "with mass, com, inertia and link; repeated, several payloads."),
        click.option("--gravity", type=_Gravity(), metavar="GX,GY,GZ",
                     help="Gravity [m/s^2] in base coordinates (ceiling-mounted: 0,0,9.81)."),
        click.option("--package-path", "package_path", multiple=True, metavar="DIR",
                     type=_NonEmpty(file_okay=False),
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
        if suffix == ".toml" and os.path.isfile(program):
            parse_toml(program)  # one that does not parse: its own error, with the line
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
    # a Cartesian program's joint path (others: unchanged), stopping on a stop request
    prog = solve_moves(prog, rob, checkpoint=checkpoint)
    return Run(rob, prog.q_cmd, prog.dt, prog.f_ext, prog.f_ext_point, prog.mode,
               prog.interpolation, prog.cartesian)
