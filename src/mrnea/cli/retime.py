"""``mrnea retime [ROBOT] PROGRAM --out DIR``: the same path, the fastest timing the robot can make.

Writes into DIR (its own for the run: :func:`mrnea.io.writer.own_folder`; existing files are
refused without ``--force`` before any work): ``retimed.csv`` (time, q1..qn at dt: ``mrnea check
ROBOT DIR/retimed.csv --dt DT`` reads it), ``retimed.toml`` (a program file naming the robot, the
csv, dt, the mode and the retimed wrench: ``mrnea check ROBOT DIR/retimed.toml`` reproduces the
verification), ``summary.json`` (strict JSON: :meth:`mrnea.retime.RetimeResult.summary`) and
``report.html`` (the phase plane, the effort ratios before and after, the verdict). A stop
request (Ctrl-C, SIGTERM) during the retiming writes nothing; once it is done, the four files
are written together.

Also :func:`suggestion`: what ``check`` and ``simulate`` print under a program that is not
achievable (the command, and the duration uniform scaling would give by Hollerbach's closed-form
estimate).
"""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import click

from mrnea.cli.base import (
    checkpoint,
    compile_notice,
    force_opt,
    json_opt,
    load_any,
    main,
    mode_opt,
    quiet_opt,
)
from mrnea.errors import MrneaError
from mrnea.io import BUILTIN_ROBOTS, from_csv, load_program, resolve_robot
from mrnea.io.writer import check_new, own_folder
from mrnea.model import Robot

CSV, PROGRAM, SUMMARY, REPORT = "retimed.csv", "retimed.toml", "summary.json", "report.html"


def _robot_spec(spec: str) -> str:
    """What a program file names the robot by: a built-in name, or a robot file's absolute
    path (the program file lives elsewhere)."""
    source = resolve_robot(spec)
    return source if source in BUILTIN_ROBOTS else str(Path(source).resolve())


@main.command()
@click.argument("robot_or_program", metavar="[ROBOT] PROGRAM")
@click.argument("program", required=False, metavar="")
@click.option("--out", type=click.Path(file_okay=False), required=True,
              help="Output folder (created if missing).")
@click.option("--method", type=click.Choice(["toppra", "scale"]), default="toppra",
              show_default=True,
              help="toppra: time-optimal along the path; scale: uniform time scaling.")
@click.option("--margin", type=float, default=0.98, show_default=True,
              help="toppra: plan against MARGIN x every effort and velocity limit, in (0, 1] "
                   "(shrunk until the simulation accepts the result).")
@click.option("--dt", type=float, default=None,
              help="Cycle time [s] of the retimed program (default the program's; a CSV "
                   "program needs it).")
@mode_opt
@force_opt
@quiet_opt
@json_opt
def retime(robot_or_program: str, program: str | None, out: str, method: str, margin: float,
           dt: float | None, mode: str, force: bool, quiet: bool, as_json: bool) -> None:
    """Retime PROGRAM: keep its path, give it the fastest timing ROBOT can make, verify it.

    ROBOT may be left out when PROGRAM is a program file that names its robot. Writes
    retimed.csv, retimed.toml, summary.json and report.html into --out.
    """
    from mrnea.report.retime import write_retime_report
    from mrnea.retime import retime as retime_program

    if program is None:
        robot_arg, program = None, robot_or_program
    else:
        robot_arg = robot_or_program
    name = Path(program).stem
    if program.lower().endswith(".csv"):
        if robot_arg is None or dt is None:
            raise click.UsageError("a CSV program needs ROBOT and --dt (its cycle time)")
        rob = load_any(robot_arg)
        spec = _robot_spec(robot_arg)
        _, q = from_csv(program, dt, n=rob.n)
        prog, prog_mode = q, None
    else:
        prog = load_program(program)
        spec = _robot_spec(prog.robot if robot_arg is None else robot_arg)
        rob = prog.load_robot() if robot_arg is None else load_any(robot_arg)
        prog.check_path(rob)
        prog_mode = prog.mode
    with own_folder(Path(out)) as folder:
        paths = {k: folder / k for k in (CSV, PROGRAM, SUMMARY, REPORT)}
        check_new(paths.values(), force)
        with compile_notice():
            res = retime_program(rob, prog, dt=dt, method=method, margin=margin,
                                 mode=prog_mode or mode)
        checkpoint()
        res.save_csv(paths[CSV], force)  # the four files are written together or not at all
        res.save_program(paths[PROGRAM], spec, CSV, name=f"{name}-retimed", overwrite=force)
        res.save_summary(paths[SUMMARY], force)
        write_retime_report(res, paths[REPORT], force, files={
            "retimed program (CSV)": paths[CSV], "program file": paths[PROGRAM],
            "summary": paths[SUMMARY]})
    if as_json:
        click.echo(json.dumps({**res.summary(), "report": str(paths[REPORT])}, indent=2,
                              allow_nan=False))
    elif not quiet:
        click.echo(res.verdict())
        click.echo(f"Written: {paths[CSV]}, {paths[PROGRAM]}, {paths[SUMMARY]}, "
                   f"{paths[REPORT]}")
        click.echo(f"Check it: mrnea check {shlex.quote(spec)} "
                   f"{shlex.quote(str(paths[PROGRAM]))}")


def suggestion(robot: Robot, robot_arg: str, program: str, q_cmd, dt: float, f_ext,
               f_ext_point) -> str:
    """What ``check`` and ``simulate`` print under a program that is not achievable: the
    ``retime`` command, and the duration uniform time scaling would give by Hollerbach's
    closed-form estimate on the program's own requirement (or why no timing can help)."""
    from mrnea.retime import scale_estimate

    T = (q_cmd.shape[0] - 1) * dt
    cmd = (f"mrnea retime {shlex.quote(robot_arg)} {shlex.quote(program)} --out "
           f"{shlex.quote(Path(program).stem + '-retimed')}")
    try:
        f = scale_estimate(robot, q_cmd, dt, f_ext, f_ext_point)
    except MrneaError as exc:
        return f"No timing can make it achievable: {exc}"
    return (f"Retime it: {cmd}\n(uniform time scaling would take about {f * T:.4g} s instead of "
            f"{T:.4g} s, {f:.3g} x, by Hollerbach's estimate; the default method, toppra, is "
            "time-optimal along the path and usually faster)")
