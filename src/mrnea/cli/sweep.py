"""``mrnea sweep [ROBOT] PROGRAM... --grid GRID.toml --out DIR``: a design sweep on Dask.

ROBOT is optional: a built-in name, a URDF, or a ``.toml`` robot file (one without a
``[program]`` table); without it, the grid file's ``[sweep] robot``, else the robot the
programs name (all the same one). The robot options (``--actuators``, ``--tip``, ``--payload``,
``--gravity``) change it over the programs' own keys; a swept ``payload`` is added to a
``--payload``. PROGRAMs are program files (``demo``: the SDT demo's
training profile), else the grid file's ``[sweep] programs``. Everything is read and checked
before any work: the grid's entries against the robot (one error naming the grid file and the
entry), the output files (never replaced without ``--force``).

Writes into DIR (the run owns it: :func:`mrnea.io.writer.own_folder`) ``sweep.csv``,
``sweep.parquet`` when pyarrow is installed (else one warning line says it is not written), and
``sweep.html``, then prints one line. The files name each result column with its unit, as
cycles.csv does (:func:`with_units`). Ctrl-C
or SIGTERM stops the sweep at its next check (a quarter of a second at most): the rows done are
written and the command exits 130. The files are written all or none
(:func:`mrnea.cli.base.write_files`): a stop request or an error between two of them removes
those written and puts back the files they replaced (``--force``), exit 130 (2 on an error);
never a new sweep.csv beside an earlier run's sweep.html.
"""

from __future__ import annotations

import importlib.util
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import click
import numpy as np

from mrnea.cli import ahead
from mrnea.cli.base import (
    checkpoint,
    exit_interrupted,
    fresh_dir,
    last_checkpoint,
    main,
    one_line,
    write_files,
)
from mrnea.cli.options import FOLDER, force_opt, load_program_arg, quiet_opt, robot_options
from mrnea.errors import SweepError, quote
from mrnea.io import (
    BUILTIN_ROBOTS,
    RobotOptions,
    is_program_file,
    load_grid_file,
    load_robot_spec,
    resolve_robot,
)
from mrnea.io.dispatch import same_robot
from mrnea.io.program import Program
from mrnea.io.writer import check_new, create, own_folder
from mrnea.model import Robot

if TYPE_CHECKING:
    import pandas as pd

CSV, PARQUET, HTML = "sweep.csv", "sweep.parquet", "sweep.html"


def has_pyarrow() -> bool:
    """Whether pandas can write sweep.parquet (pyarrow, the ``parquet`` extra, is optional)."""
    return importlib.util.find_spec("pyarrow") is not None


def with_units(df: pd.DataFrame, robot: Robot) -> pd.DataFrame:
    """The sweep's rows as the files hold them: each result column with a unit named
    ``<name> [<unit>]``, as cycles.csv's are (``peak_motor_torque.cab_yaw [N m]``,
    ``duration [s]``); the parameter columns keep the grid's keys, so a row's parameters
    still rebuild its robot (``mrnea.sweep.variant``)."""
    from mrnea.sweep.rows import column_units

    units = column_units(robot, [c for c in df.columns if c not in df.attrs.get("units", {})])
    return df.rename(columns={c: f"{c} [{u}]" for c, u in units.items()})


def _is_robot(arg: str) -> bool:
    """A built-in robot's name, a URDF, or a ``.toml`` file that is not a program."""
    suffix = Path(arg).suffix.lower()
    return (arg in BUILTIN_ROBOTS or suffix in (".urdf", ".xml")
            or (suffix == ".toml" and Path(arg).is_file() and not is_program_file(arg)))


def _same_options(a: RobotOptions, b: RobotOptions) -> bool:
    """Whether two programs change their robot alike (a payload's arrays by value)."""
    pa, pb = a.payload or (), b.payload or ()
    same_payload = len(pa) == len(pb) and all(
        p.link == q.link and all(np.array_equal(x, y) for x, y in zip(p[:3], q[:3], strict=True))
        for p, q in zip(pa, pb, strict=True))
    return same_payload and (a.actuators, a.tip, a.gravity) == (b.actuators, b.tip, b.gravity)


def _robot(cli: str | None, grid_robot: str | None, programs: list[Program],
           options: RobotOptions) -> Robot:
    """The one base robot of the sweep: ROBOT, else the grid file's, else the one the programs
    name (two different ones named anywhere is an error), with the programs' robot options
    (all the same) and the command line's over them."""
    named = [(what, src) for what, src in (("the ROBOT argument", cli and resolve_robot(cli)),
                                           ("the grid file's [sweep] robot", grid_robot)) if src]
    named += [(f"program {quote(p.name)}", p.robot) for p in programs if p.robot]
    if not named:
        raise SweepError("no robot: give ROBOT, or 'robot' in the grid file's [sweep]")
    first_what, first = named[0]
    robot = load_robot_spec(first, options=options.over(programs[0].options))  # one at all
    for what, src in named[1:]:
        if not same_robot(src, first):
            raise SweepError(f"{first_what} is {quote(first)} but {what} is {quote(src)}; a "
                             "sweep runs one robot")
    for p in programs[1:]:
        if not _same_options(p.options, programs[0].options):
            raise SweepError(f"programs {quote(programs[0].name)} and {quote(p.name)} change "
                             "the robot differently (actuators, tip, payload or gravity); a "
                             "sweep runs one robot")
    for p in programs:
        p.check_path(robot)
    return robot


def _axes(value: str | None, option: str, keys: list[str], count: int) -> list[str] | None:
    """``--map X,Y`` or ``--curves P``: swept parameters of the grid."""
    if value is None:
        return None
    names = value.split(",")
    if len(names) != count:
        raise click.UsageError(f"{option}: expected {count} swept parameter(s), got "
                               f"{quote(value)}")
    for k in names:
        if k not in keys:
            raise click.UsageError(f"{option}: {quote(k)} is not a parameter of the grid "
                                   f"({', '.join(keys)})")
    return names


@main.command()
@click.argument("args", nargs=-1, metavar="[ROBOT] [PROGRAM]...")
@click.option("--grid", "grid_file", required=True, type=click.Path(dir_okay=False),
              metavar="GRID.toml", help="The grid file: parameters and their values "
                                         "(docs/sweeps.md).")
@click.option("--out", type=FOLDER, default=None,
              help="Output folder [default: a fresh ./mrnea-sweep].")
@click.option("--scheduler", default=None, metavar="ADDR",
              help="A Dask scheduler, tcp://HOST:PORT, checked first: where none answers, one "
                   "error within 12 s [default: a local cluster, one worker process per core].")
@click.option("--workers", type=click.IntRange(1), default=None, metavar="N",
              help="Worker processes of the local cluster [default: the usable cores].")
@click.option("--retime", is_flag=True, help="Also retime each run (column retimed_duration).")
@click.option("--map", "map_axes", default=None, metavar="X,Y",
              help="The feasibility map's two parameters [default: the first two swept].")
@click.option("--curves", default=None, metavar="PARAM",
              help="The load curves' parameter [default: the first swept].")
@robot_options
@force_opt
@quiet_opt
def sweep(args: tuple[str, ...], grid_file: str, out: str | None, scheduler: str | None,
          workers: int | None, retime: bool, map_axes: str | None, curves: str | None,
          robot_options: RobotOptions, force: bool, quiet: bool) -> None:
    """Run every PROGRAM on every variant of ROBOT the grid file describes.

    One row per (variant, program) in sweep.csv (and sweep.parquet with pyarrow): the swept
    parameters, achievable or not, the worst joint and its effort ratio, where it first fails,
    and per joint the peak and RMS motor torque, peak speed and bearing loads; sweep.html maps
    the feasibility over two parameters and draws the loads against one.
    """
    from mrnea.report.sweep import write_sweep_html
    from mrnea.sweep import check_grid, load_programs
    from mrnea.sweep import sweep as run_sweep
    from mrnea.sweep.cluster import check_scheduler

    spec = load_grid_file(grid_file)
    robot_arg = args[0] if args and _is_robot(args[0]) else None
    names = list(args[1:] if robot_arg is not None else args) or spec.programs
    if not names:
        raise SweepError("no program: give PROGRAM files, or 'programs' in the grid file's "
                         "[sweep]")
    programs = [load_program_arg(n) for n in names]
    robot = _robot(robot_arg, spec.robot, programs, robot_options)
    programs = load_programs(programs, robot)  # each against the robot's joint count
    keys = list(spec.grid)
    try:
        check_grid(robot, spec.grid, spec.zip, programs)
    except SweepError as exc:
        raise SweepError(f"{spec.source}: {exc}") from None
    axes = _axes(map_axes, "--map", keys, 2)
    curve = _axes(curves, "--curves", keys, 1)
    if scheduler is not None:  # a scheduler there, before the folder and the first line
        check_scheduler(scheduler)
    files = [CSV, *([PARQUET] if has_pyarrow() else []), HTML]
    if PARQUET not in files:
        warnings.warn(f"{PARQUET} is not written: pyarrow is not installed (python -m pip "
                      f"install 'mrnea[parquet]'); {CSV} holds the same rows", stacklevel=1)
    with own_folder(Path(out) if out else fresh_dir("mrnea-sweep")) as folder:
        check_new([folder / f for f in files], force)
        if not quiet:
            click.echo("mrnea sweep: starting the workers and loading the compiled kernels...",
                       err=True)
        bars: list = []  # the bar, made once the number of runs is known

        def progress(done: int, total: int) -> None:
            if not bars:
                bars.append(click.progressbar(length=total, label=f"mrnea sweep: {total} runs",
                                              file=sys.stderr, hidden=quiet).__enter__())
            bars[0].update(done - bars[0].pos)
            checkpoint()  # raised here, the sweep keeps the rows done

        if scheduler is None:  # this machine's workers: one compiles (cold cache), this helps
            ahead.start(robot.parents, False, False, retime)
        try:
            df = run_sweep(robot, programs, spec.grid, client=scheduler, retime=retime,
                           progress=progress, zip=spec.zip, workers=workers)
        finally:
            if bars:
                bars[0].__exit__(None, None, None)
        done = df.attrs["completed"]
        if not done:
            click.echo(f"mrnea: interrupted after {len(df)} of {df.attrs['cases']} rows; "
                       "writing them.", err=True)
        table = with_units(df, robot)

        def csv() -> None:
            with create(folder / CSV, force) as fh:
                table.to_csv(fh)

        def parquet() -> None:
            with create(folder / PARQUET, force, binary=True) as fh:
                table.to_parquet(fh)

        steps = [(folder / CSV, csv), *([(folder / PARQUET, parquet)] if PARQUET in files else []),
                 (folder / HTML, lambda: write_sweep_html(
                     df, folder / HTML, robot.name, keys, axes and tuple(axes),
                     curve and curve[0], overwrite=force))]
        write_files(steps)  # all or none: a stop or an error between them puts the old ones back
    if done:
        last_checkpoint()
    if not quiet:
        ok, failed = int(df["achievable"].fillna(False).sum()), int(df["error"].notna().sum())
        click.echo(one_line(
            f"{'INTERRUPTED: ' if not done else ''}{len(df)} of {df.attrs['cases']} rows "
            f"({len(programs)} program(s)): {ok} achievable, {failed} failed, "
            f"{df.attrs['seconds']['total']:.1f} s. Wrote {folder}: {', '.join(files)}"))
    if not done:
        exit_interrupted()
