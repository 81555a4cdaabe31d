"""``mrnea size [ROBOT] PROGRAM... --catalogue FILE --out DIR``: each joint's motor and gearbox
from a catalogue, checked on the coupled robot (issue 27; docs/sizing.md).

ROBOT is optional (a built-in name, a URDF or a ``.toml`` robot file); without it, the robot
the first program names. PROGRAMs are program files (``demo``: the SDT demo's training
profile); the duty cycle runs them in turn, then ``--dwell`` seconds at rest. Everything is
read and checked before any work (the catalogue: one error naming the entry and the field); the
output files are never replaced without ``--force``. A stop request (Ctrl-C, SIGTERM) during the
sizing is taken when it ends, and between the files: the files written are removed again,
nothing is printed, exit 130.

Writes into DIR ``sizing.csv`` (one row per joint x combination), ``chosen_drives.toml`` (a
sidecar actuator file), ``sized_robot.toml`` (the robot with the drives and their masses, a
native robot file), ``summary.json`` and ``sizing.html``, and prints one line per joint and the
verification. Exit 0 when every joint has a drive and every program is ACHIEVABLE on the sized
robot, 1 when not (a verdict: nothing in the catalogue fits a joint; then no
``chosen_drives.toml`` or ``sized_robot.toml`` is written, and with ``--force`` those of an
earlier run in DIR are removed: the folder holds one run's files, never a mixed set), 2 on bad
input.
``--scheduler tcp://HOST:PORT`` judges the combinations on a Dask cluster (as for ``sweep``).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from mrnea import validate
from mrnea.cli import ahead
from mrnea.cli.base import (
    EXIT_ACHIEVABLE,
    EXIT_NOT_ACHIEVABLE,
    compile_notice,
    fresh_dir,
    last_checkpoint,
    main,
    one_line,
    write_files,
)
from mrnea.cli.options import (
    FOLDER,
    NON_NEGATIVE,
    force_opt,
    load_robot_arg,
    quiet_opt,
    robot_options,
)
from mrnea.cli.sweep import _is_robot
from mrnea.errors import SizingError
from mrnea.io import RobotOptions, load_program
from mrnea.io.gridfile import DEMO_PROGRAM
from mrnea.io.writer import check_new, own_folder, write_file
from mrnea.robots.sdt_profile import training_program

FILES = ("sizing.csv", "chosen_drives.toml", "sized_robot.toml", "summary.json", "sizing.html")


def _write(res, folder: Path, force: bool) -> None:
    """The sizing's files (:func:`mrnea.cli.base.write_files`: a stop request taken before
    each; on a stop the files this run wrote are removed, those they replaced put back, and the
    command exits 130). When no drive fits, chosen_drives.toml and sized_robot.toml are not
    written, and an earlier run's (``--force``) are removed with the others replaced (side
    files of the all-or-none block: put back on a stop or an error), so that the folder never
    holds a sized robot beside a sizing that found none."""
    from mrnea.sizing.html import sizing_html
    from mrnea.sizing.output import chosen_toml, sizing_summary, sizing_table

    csv, drives, robot, summary, page = (folder / f for f in FILES)
    steps = [(csv, lambda: write_file(csv, sizing_table(res).to_csv(index=False), force))]
    stale = []  # an earlier run's sized robot, with no drive chosen now: removed
    if res.sized is not None:
        steps += [(drives, lambda: write_file(drives, chosen_toml(res), force)),
                  (robot, lambda: res.sized.to_toml(robot, overwrite=force))]
    else:
        stale = [drives, robot]
    steps += [(summary, lambda: write_file(summary, json.dumps(
                  sizing_summary(res), indent=2, allow_nan=False) + "\n", force)),
              (page, lambda: sizing_html(res, page, overwrite=force))]
    write_files(steps, side_files=stale)


@main.command()
@click.argument("args", nargs=-1, metavar="[ROBOT] PROGRAM...")
@click.option("--catalogue", required=True, type=click.Path(dir_okay=False), metavar="FILE",
              help="The catalogue: [[motor]], [[gearbox]] and [[drive]] entries "
                   "(docs/sizing.md).")
@click.option("--joints", default=None, metavar="NAMES",
              help="The joints to size, comma-separated [default: all].")
@click.option("--objective", type=click.Choice(["mass", "price", "margin"]), default="mass",
              show_default=True, help="What the best drive minimises (margin: the worst ratio).")
@click.option("--dwell", type=NON_NEGATIVE, default=0.0, show_default=True,
              metavar="SECONDS", help="Seconds at rest after the programs, in the duty cycle.")
@click.option("--no-drive-mass", is_flag=True,
              help="Leave the drives' masses off the parent links.")
@click.option("--scheduler", default=None, metavar="ADDR",
              help="A Dask scheduler, tcp://HOST:PORT, to judge the combinations on "
                   "[default: here].")
@click.option("--out", type=FOLDER, default=None,
              help="Output folder [default: a fresh ./mrnea-size].")
@robot_options
@force_opt
@quiet_opt
def size(args: tuple[str, ...], catalogue: str, joints: str | None, objective: str,
         dwell: float, no_drive_mass: bool, scheduler: str | None, out: str | None,
         robot_options: RobotOptions,
         force: bool, quiet: bool) -> None:
    """Choose each joint's motor and gearbox from a catalogue for the PROGRAMs.

    Every motor x gearbox combination is judged on the duty cycle from the programs' own
    requirement (motor peak and torque-speed curve, RMS, speeds, gearbox peak and cubic mean);
    the best by the objective is verified by simulating the sized robot.
    """
    from mrnea.sizing import load_catalogue, size_drives

    robot_arg = args[0] if args and _is_robot(args[0]) else None
    names = list(args[1:] if robot_arg is not None else args)
    if not names:
        raise click.UsageError("Missing argument 'PROGRAM...'.")
    programs = [training_program() if n == DEMO_PROGRAM else load_program(n) for n in names]
    if robot_arg is not None:
        robot = load_robot_arg(robot_arg, robot_options)
    elif programs[0].robot is not None:
        robot = programs[0].load_robot(options=robot_options)
    else:
        raise SizingError(f"no robot: give ROBOT, or name one in program "
                          f"{programs[0].name!r}")
    for p in programs:
        p.apply_units(robot)  # a units = "deg" path's prismatic joints in mm
        p.check_path(robot)
    cat = load_catalogue(catalogue)
    wanted = None if joints is None else [j.strip() for j in joints.split(",")]
    with own_folder(Path(out) if out else fresh_dir("mrnea-size")) as folder:
        check_new([folder / f for f in FILES], force)
        # the verifying simulation's kernels compiled while the requirement's are (cold cache)
        ahead.start(robot.parents, validate.by_link(programs[0].f_ext, programs[0].f_ext_point),
                    False)
        with compile_notice(quiet):
            res = size_drives(robot, programs, cat, joints=wanted, objective=objective,
                              dwell=dwell, drive_mass=not no_drive_mass, scheduler=scheduler)
        _write(res, folder, force)
    last_checkpoint()
    if not quiet:
        for line in res.lines():
            click.echo(line)
        click.echo(one_line(f"Wrote {folder}: "
                            + ", ".join(f for f in FILES if (folder / f).exists())))
    sys.exit(EXIT_ACHIEVABLE if res.verified else EXIT_NOT_ACHIEVABLE)
