"""The ``mrnea`` command: will the robot really make the programmed motion?

``mrnea demo`` runs the built-in SDT's training profile and writes the report;
``mrnea simulate ROBOT PROGRAM`` does the same for any robot and program; ``mrnea check`` prints
the verdict alone (exit 0 achievable, 1 not, 2 bad input); ``mrnea info ROBOT`` lists joints,
masses, limits and actuators; ``mrnea fig3`` reproduces the paper's Fig. 3.

ROBOT is a built-in name (sdt, puma560), a URDF or a native ``.toml`` robot file. PROGRAM is a
program ``.toml`` file or a CSV of (time, q1..qn) (docs/programs.md). Bad input ends with one
clear line on stderr and exit code 2 (``--debug`` shows the traceback). Output files are never
overwritten unless ``--force`` is given; without ``--out`` a fresh folder is chosen.
"""

from __future__ import annotations

import contextlib
import json
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import click
import numpy as np

from mrnea import robots
from mrnea.errors import MrneaError
from mrnea.io import from_csv, load_program, load_robot_spec
from mrnea.model import Robot

EXIT_ACHIEVABLE, EXIT_NOT_ACHIEVABLE, EXIT_BAD_INPUT = 0, 1, 2


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
        if not p.exists() or (p.is_dir() and not any(p.iterdir())):
            return p
    raise click.ClickException(f"no free output folder next to {base}")


class _Group(click.Group):
    """Turns input errors into one line on stderr and exit code 2."""

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
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


def _run(robot: Robot, q_cmd: np.ndarray, dt: float, mode: str, fd: str, catch_up: float,
         f_ext: np.ndarray | None, f_ext_point: np.ndarray | None, quiet: bool,
         out: Path | None = None, force: bool = False):
    """Simulate with a progress bar; with ``out``, stream the per-cycle table to cycles.csv."""
    from mrnea.simulate import simulate

    K = q_cmd.shape[0]
    show_bar = not quiet and K >= 20_000
    with compile_notice(), click.progressbar(length=K, label="simulating", file=sys.stderr,
                                             hidden=not show_bar) as bar:
        last = [0]

        def progress(done: int, total: int) -> None:
            bar.update(done - last[0])
            last[0] = done

        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
        res = simulate(robot, q_cmd, dt, mode=mode, fd=fd, catch_up=catch_up, f_ext=f_ext,
                       f_ext_point=f_ext_point, progress=progress,
                       stream=None if out is None else out / "cycles.csv", overwrite=force)
    if not res.completed:
        click.echo("mrnea: interrupted; writing the partial result.", err=True)
    return res


OUTPUTS = ("cycles.csv", "summary.json", "report.html", "fig3.png")


def _refuse_existing(out: Path, force: bool) -> None:
    """Before any work: no output file may replace an existing one without --force."""
    from mrnea.report import FIGURES, refuse_existing

    refuse_existing([out / f for f in (*OUTPUTS, *(f"{n}.png" for n in FIGURES))], force)


def _write_outputs(res, out: Path, force: bool, extra_figures: dict | None = None) -> Path:
    from mrnea.report import plot_result, write_report

    res.save_summary(out / "summary.json", overwrite=force)  # cycles.csv: streamed by _run
    plot_result(res, out, overwrite=force)
    for name, fig in (extra_figures or {}).items():
        fig.savefig(out / f"{name}.png", dpi=110)
    return write_report(res, out / "report.html", overwrite=force, extra_figures=extra_figures)


def _print_result(res, report: Path | None, as_json: bool, quiet: bool) -> None:
    if as_json:
        s = dict(res.summary())
        if report is not None:
            s["report"] = str(report)
        click.echo(json.dumps(s, indent=2))
        return
    if not quiet:
        click.echo(res.verdict())
        if report is not None:
            click.echo(f"Report: {report}")


_mode_opt = click.option("--mode", type=click.Choice(["hybrid", "paper"]), default="hybrid",
                         show_default=True, help="How saturation is resolved (docs/achievable.md).")
_fd_opt = click.option("--fd", type=click.Choice(["mrnea", "walker_orin", "crba"]),
                       default="mrnea", show_default=True,
                       help="How each cycle forms H and u' (results agree; cost differs).")
_catch_opt = click.option("--catch-up", type=float, default=0.0, metavar="GAIN",
                          help="Position-loop gain [1/s] that steers back to the program after a "
                               "saturation (default 0: the paper's behaviour, the lag stays).")
_quiet_opt = click.option("--quiet", "-q", is_flag=True, help="No progress bar, no verdict text.")
_json_opt = click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
_force_opt = click.option("--force", is_flag=True, help="Overwrite existing output files.")


@main.command()
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Output folder [default: a fresh ./mrnea-demo].")
@click.option("--dt", type=float, default=0.005, show_default=True, help="Cycle time [s].")
@_mode_opt
@_force_opt
@_quiet_opt
@_json_opt
def demo(out: str | None, dt: float, mode: str, force: bool, quiet: bool, as_json: bool) -> None:
    """Simulate the built-in SDT's training profile and write the report.

    The profile (spin-up, a fast cabin yaw turn, roll and pitch manoeuvres, spin-down) exceeds
    the yaw drive's torque: the report shows where, by how much, and the loads the bearings see.
    Writes report.html, PNG figures, cycles.csv and summary.json, and the paper's Fig. 3.
    """
    from mrnea.report import fig3
    from mrnea.robots.sdt_profile import training_profile

    robot = robots.sdt()
    _, q_cmd = training_profile(dt)
    folder = Path(out) if out else fresh_dir("mrnea-demo")
    _refuse_existing(folder, force)
    res = _run(robot, q_cmd, dt, mode, "mrnea", 0.0, None, None, quiet, folder, force)
    figs = {"fig3": fig3(robot, res.t, res.q, res.qd, res.qdd)}
    report = _write_outputs(res, folder, force, figs)
    _print_result(res, report, as_json, quiet)


def _load_program(robot: Robot, program: str, dt: float | None):
    """(q_cmd, dt, f_ext, f_ext_point, mode) from a program .toml or a CSV file."""
    if program.lower().endswith(".csv"):
        if dt is None:
            raise click.UsageError("a CSV program needs --dt (the cycle time to resample to)")
        _, q = from_csv(program, dt, n=robot.n)
        return q, dt, None, None, None
    prog = load_program(program)
    if dt is not None and not np.isclose(dt, prog.dt):
        raise click.UsageError(
            f"--dt {dt} differs from the program's dt {prog.dt}; edit the program instead")
    return prog.q_cmd, prog.dt, prog.f_ext, prog.f_ext_point, prog.mode


@main.command()
@click.argument("robot")
@click.argument("program", type=click.Path(dir_okay=False))
@click.option("--dt", type=float, default=None, help="Cycle time [s] (needed for a CSV).")
@_mode_opt
@_fd_opt
@_catch_opt
@click.option("--out", type=click.Path(file_okay=False), default=None,
              help="Output folder [default: a fresh ./mrnea-out].")
@_force_opt
@_quiet_opt
@_json_opt
def simulate(robot: str, program: str, dt: float | None, mode: str, fd: str, catch_up: float,
             out: str | None, force: bool, quiet: bool, as_json: bool) -> None:
    """Simulate PROGRAM on ROBOT and write the report, figures, CSV and summary.json."""
    rob = load_any(robot)
    q_cmd, dt, f_ext, f_pt, prog_mode = _load_program(rob, program, dt)
    folder = Path(out) if out else fresh_dir("mrnea-out")
    _refuse_existing(folder, force)
    res = _run(rob, q_cmd, dt, prog_mode or mode, fd, catch_up, f_ext, f_pt, quiet, folder, force)
    report = _write_outputs(res, folder, force)
    _print_result(res, report, as_json, quiet)


@main.command()
@click.argument("robot")
@click.argument("program", type=click.Path(dir_okay=False))
@click.option("--dt", type=float, default=None, help="Cycle time [s] (needed for a CSV).")
@_mode_opt
@_catch_opt
@_quiet_opt
@_json_opt
def check(robot: str, program: str, dt: float | None, mode: str, catch_up: float, quiet: bool,
          as_json: bool) -> None:
    """Print the verdict alone. Exit code 0: achievable, 1: not, 2: bad input."""
    rob = load_any(robot)
    q_cmd, dt, f_ext, f_pt, prog_mode = _load_program(rob, program, dt)
    res = _run(rob, q_cmd, dt, prog_mode or mode, "mrnea", catch_up, f_ext, f_pt, quiet)
    _print_result(res, None, as_json, quiet)
    sys.exit(EXIT_ACHIEVABLE if res.achievable else EXIT_NOT_ACHIEVABLE)


@main.command()
@click.argument("robot")
@_json_opt
def info(robot: str, as_json: bool) -> None:
    """Print ROBOT's joints, masses, limits and actuators (built-ins: sdt, puma560)."""
    rob = load_any(robot)
    if not as_json:
        click.echo(rob.describe())
        return
    click.echo(json.dumps({
        "name": rob.name, "n": rob.n, "gravity": rob.gravity.tolist(),
        "joints": [{"name": j.name, "type": j.type, "link": lk.name, "mass": lk.mass,
                    "lower": j.lower, "upper": j.upper, "velocity_limit": j.velocity_limit,
                    "effort_limit": j.effort_limit, "gear_ratio": j.gear_ratio,
                    "rotor_inertia": j.rotor_inertia, "viscous_friction": j.viscous_friction,
                    "coulomb_friction": j.coulomb_friction, "torque_speed": j.torque_speed}
                   for j, lk in zip(rob.joints, rob.links, strict=True)],
    }, indent=2))


@main.command()
@click.option("--out", type=click.Path(dir_okay=False), default="fig3.png", show_default=True)
@_force_opt
def fig3(out: str, force: bool) -> None:
    """Reproduce the paper's Fig. 3 on the SDT: RNEA vs mRNEA torques, input vs FD accelerations.

    The trajectory is the demo's training profile; its velocities and accelerations are the
    positions' finite differences.
    """
    from mrnea.report import fig3 as make_fig3
    from mrnea.robots.sdt_profile import training_profile

    path = Path(out)
    if path.exists() and not force:
        raise FileExistsError(f"{path} exists; pass --force to overwrite")
    dt = 0.005
    t, q = training_profile(dt)
    qd = np.gradient(q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    with compile_notice():
        fig = make_fig3(robots.sdt(), t, q, qd, qdd)
    fig.savefig(path, dpi=110)
    click.echo(f"Fig. 3: {path}")
