"""``mrnea demo``, ``mrnea simulate`` and ``mrnea check``: simulate a program and answer.

``demo`` and ``simulate`` own their output folder for the run (:func:`mrnea.io.writer.own_folder`:
a second run into the same folder refuses), refuse existing output files without ``--force``
before any work, stream the per-cycle table to ``cycles.csv`` and then write ``summary.json``,
the figures and ``report.html``. All three exit by one rule
(:func:`mrnea.cli.base.exit_with_verdict`): 0 achievable, 1 NOT ACHIEVABLE, once the files are
written. An interrupted run (Ctrl-C, SIGTERM) writes the same files for the cycles done, says
so, and exits 130; so does ``check``, which writes nothing. The run stops at the end of the
chunk of cycles it is computing (:func:`mrnea.cli.base.checkpoint`). A request that lands in
the last chunk (the run then completes) or while the files are written stops the writing at the
next file boundary: the files written are whole, the rest are not written, no verdict is
printed, exit 130. The last checkpoint is just before the verdict is printed: a request after
it is too late, and the command ends with the verdict's code.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import click
import numpy as np

from mrnea import robots, validate
from mrnea.cli import ahead
from mrnea.cli.base import (
    EXIT_NOT_ACHIEVABLE,
    checkpoint,
    compile_notice,
    exit_with_verdict,
    fresh_dir,
    last_checkpoint,
    main,
    one_line,
)
from mrnea.cli.options import (
    FOLDER,
    POSITIVE,
    fd_opt,
    force_opt,
    json_opt,
    load_run,
    mode_opt,
    no_3d_opt,
    program_args,
    quiet_opt,
)
from mrnea.io import RobotOptions
from mrnea.io.writer import all_or_none, check_new, own_folder
from mrnea.model import Robot

TABLE, SUMMARY, REPORT = "cycles.csv", "summary.json", "report.html"


def _import_report() -> None:
    """The report's modules (matplotlib's figures: about 0.4 s), imported while the command
    waits for the compile-ahead process (:func:`mrnea.cli.ahead.share`) instead of after its
    simulation."""
    import mrnea.report.html  # noqa: F401


def _run(robot: Robot, q_cmd: np.ndarray, dt: float, mode: str, fd: str, catch_up: float,
         f_ext: np.ndarray | None, f_ext_point: np.ndarray | None, quiet: bool,
         out: Path | None = None, force: bool = False, cartesian=None):
    """Simulate with a progress bar; with ``out``, stream the per-cycle table to cycles.csv.

    A stop request (Ctrl-C, SIGTERM) ends the simulation after the current chunk of cycles: the
    result then holds the cycles done (``completed`` False).
    """
    from mrnea.simulate import simulate

    checkpoint()
    second = ahead.start(robot.parents, validate.by_link(f_ext, f_ext_point), out is not None,
                         shared=fd == "mrnea" and mode == "hybrid")  # a cold cache
    K = q_cmd.shape[0]
    show_bar = not quiet and K >= 20_000
    with compile_notice(quiet), click.progressbar(length=K, label="simulating", file=sys.stderr,
                                             hidden=not show_bar) as bar:
        last = [0]

        def progress(done: int, total: int) -> None:
            bar.update(done - last[0])
            last[0] = done
            if done < total:  # raised here, simulate() keeps the cycles done; after the last
                checkpoint()  # chunk the request stays for the next checkpoint (not lost)

        meanwhile = [] if out is None else [_import_report]  # while it waits for the other
        ahead.share(second, robot, q_cmd[0], meanwhile)
        res = simulate(robot, q_cmd, dt, mode=mode, fd=fd, catch_up=catch_up, f_ext=f_ext,
                       f_ext_point=f_ext_point, progress=progress,
                       stream=None if out is None else out / TABLE, overwrite=force,
                       cartesian=cartesian)
        ahead.settle(second, meanwhile)  # the summary's kernels: the other's, if it has begun
    if not res.completed:
        click.echo(f"mrnea: interrupted after {res.K} cycles; writing the partial result.",
                   err=True)
    return res


def _outputs(out: Path, extra: tuple[str, ...] = ()) -> list[Path]:
    """Every file a run writes into ``out`` (``extra``: more figures' names)."""
    from mrnea.report import FIGURES

    return [out / f for f in (TABLE, SUMMARY, REPORT, *(f"{n}.png" for n in (*FIGURES, *extra)))]


def _write_outputs(res, out: Path, force: bool, view3d: bool,
                   extra_figures: dict | None = None, interpolation: str | None = None) -> Path:
    from mrnea.report import write_report

    res.save_summary(out / SUMMARY, overwrite=force)  # cycles.csv: streamed by _run
    checkpoint()
    return write_report(res, out / REPORT, overwrite=force, extra_figures=extra_figures,
                        interpolation=interpolation, view3d=view3d, png_folder=out,
                        extra_png_dpi=110)  # fig3.png as `mrnea fig3` writes it


def _print_result(res, report: Path | None, as_json: bool, quiet: bool) -> None:
    """The verdict (or the summary as JSON), after the command's last checkpoint: a stop
    requested once it is out is too late (:func:`mrnea.cli.base.exit_with_verdict`)."""
    last_checkpoint()
    if as_json:
        s = dict(res.summary())
        if report is not None:
            s["report"] = str(report)
        click.echo(json.dumps(s, indent=2, allow_nan=False))
        return
    if not quiet:
        click.echo(res.verdict())
        if (end := res.final_position_line()) is not None:
            click.echo(end)
        if report is not None:
            click.echo(f"Report: {one_line(str(report))}")  # a newline in --out: one line


def _print_cartesian(path, quiet: bool) -> None:
    """A Cartesian program's verdict on its tool path, when the robot cannot follow it (on
    stderr: the dynamics' verdict follows on stdout; the command then exits 1)."""
    if path is not None and not path.achievable and not quiet:
        click.echo(f"Tool path: {path.verdict()}", err=True)


def _cartesian_verdict(path, as_json: bool, quiet: bool) -> None:
    """``check``'s answer for a Cartesian program the robot cannot follow: the first finding
    (all of them with --json); the dynamics are not simulated on a path the robot cannot
    take."""
    if as_json:
        click.echo(json.dumps({"achievable": False, "verdict": path.verdict(),
                               "cartesian_findings": [dataclasses.asdict(f)
                                                      for f in path.findings]},
                              indent=2, allow_nan=False))
    elif not quiet:
        click.echo(path.verdict())


@main.command()
@click.option("--out", type=FOLDER, default=None,
              help="Output folder [default: a fresh ./mrnea-demo].")
@click.option("--dt", type=POSITIVE, default=0.005, show_default=True, metavar="SECONDS",
              help="Cycle time [s].")
@mode_opt
@no_3d_opt
@force_opt
@quiet_opt
@json_opt
def demo(out: str | None, dt: float, mode: str, no_3d: bool, force: bool, quiet: bool,
         as_json: bool) -> None:
    """Simulate the built-in SDT's training profile and write the report.

    The profile (spin-up, a fast cabin yaw turn, roll and pitch manoeuvres, spin-down) exceeds
    the yaw drive's torque: the report shows where, by how much, and the loads the bearings see.
    Writes report.html, PNG figures, cycles.csv and summary.json, and the paper's Fig. 3. Its
    program is PROGRAM 'demo' of the other commands (examples/sdt_training.toml).
    """
    from mrnea.robots.sdt_profile import training_profile

    robot = robots.sdt()
    _, q_cmd = training_profile(dt)
    with own_folder(Path(out) if out else fresh_dir("mrnea-demo")) as folder:
        outputs = _outputs(folder, ("fig3",))
        check_new(outputs, force)
        with all_or_none(outputs, force, keep_on_interrupt=True):  # an error: no mixed set
            res = _run(robot, q_cmd, dt, mode, "mrnea", 0.0, None, None, quiet, folder, force)
            from mrnea.report import fig3  # matplotlib: after the second process started

            with compile_notice(quiet):  # fig3 reuses the simulation's kernels (report/states)
                figs = {"fig3": fig3(robot, res.t, res.q, res.qd, res.qdd)} if res.K else {}
            report = _write_outputs(res, folder, force, not no_3d, figs)
    _print_result(res, report, as_json, quiet)
    exit_with_verdict(res)


def _suggest(res, robot: str | None, program: str | None, options: RobotOptions,
             run: tuple, interpolation: str | None, mode: str, quiet: bool,
             as_json: bool, units: str | None = None) -> None:
    """Under a completed run that is not achievable: the retime command and the duration
    uniform scaling would give (:func:`mrnea.cli.retime.suggestion`); command line only (stderr
    with --json), never in the summary. ``run``: what :func:`load_run` returned;
    ``interpolation``, ``mode``, ``units``: the command's options."""
    if quiet or not res.completed or res.achievable is not False:
        return
    from mrnea.cli.retime import suggestion

    rob, q_cmd, dt, f_ext, f_pt, prog_mode = run[:6]
    click.echo(suggestion(rob, robot, program, options, np.asarray(q_cmd), dt, f_ext, f_pt,
                          interpolation, None if prog_mode or mode == "hybrid" else mode, units),
               err=as_json)


@main.command()
@program_args
@fd_opt
@click.option("--out", type=FOLDER, default=None,
              help="Output folder [default: a fresh ./mrnea-out].")
@no_3d_opt
@force_opt
@quiet_opt
@json_opt
def simulate(robot: str | None, program: str | None, dt: float | None,
             interpolation: str | None, units: str | None, mode: str, catch_up: float,
             robot_options: RobotOptions,
             fd: str, out: str | None, no_3d: bool, force: bool, quiet: bool,
             as_json: bool) -> None:
    """Simulate PROGRAM on ROBOT and write the report, figures, CSV and summary.json.

    PROGRAM is a program file (.toml), a path CSV (with --dt) or 'demo' (the SDT demo's
    training profile). ROBOT may be left out when the program file names its robot; given, it
    must be that robot. The robot options override the program's keys of the same names.
    """
    run = load_run(robot, program, dt, interpolation, robot_options, units)
    rob, q_cmd, dt, f_ext, f_pt, prog_mode, interp = run[:7]
    _print_cartesian(run.cartesian, quiet or as_json)
    with own_folder(Path(out) if out else fresh_dir("mrnea-out")) as folder:
        outputs = _outputs(folder)
        check_new(outputs, force)
        with all_or_none(outputs, force, keep_on_interrupt=True):  # an error: no mixed set
            res = _run(rob, q_cmd, dt, prog_mode or mode, fd, catch_up, f_ext, f_pt, quiet,
                       folder, force, run.cartesian)
            report = _write_outputs(res, folder, force, not no_3d, interpolation=interp)
    _print_result(res, report, as_json, quiet)
    _suggest(res, robot, program, robot_options, run, interpolation, mode, quiet, as_json,
             units)
    if res.completed and run.cartesian is not None and not run.cartesian.achievable:
        sys.exit(EXIT_NOT_ACHIEVABLE)  # the tool path cannot be followed, whatever the dynamics
    exit_with_verdict(res)


@main.command()
@program_args
@quiet_opt
@json_opt
def check(robot: str | None, program: str | None, dt: float | None,
          interpolation: str | None, units: str | None, mode: str, catch_up: float,
          robot_options: RobotOptions,
          quiet: bool, as_json: bool) -> None:
    """Print the verdict alone; write nothing.

    PROGRAM is a program file (.toml), a path CSV (with --dt) or 'demo'; ROBOT may be left out
    when the program file names its robot (as for simulate).
    """
    run = load_run(robot, program, dt, interpolation, robot_options, units)
    rob, q_cmd, dt, f_ext, f_pt, prog_mode, _ = run[:7]
    if run.cartesian is not None and not run.cartesian.achievable:
        _cartesian_verdict(run.cartesian, as_json, quiet)
        sys.exit(EXIT_NOT_ACHIEVABLE)
    res = _run(rob, q_cmd, dt, prog_mode or mode, "mrnea", catch_up, f_ext, f_pt, quiet,
               cartesian=run.cartesian)
    _print_result(res, None, as_json, quiet)
    _suggest(res, robot, program, robot_options, run, interpolation, mode, quiet, as_json,
             units)
    exit_with_verdict(res)
