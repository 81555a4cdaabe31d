"""``mrnea excite ROBOT --out DIR``: an optimised excitation trajectory for identifying ROBOT
(issue 28; :func:`mrnea.identify.excite.excitation`, docs/identification.md).

Writes into DIR (its own for the run: :func:`mrnea.io.writer.own_folder`; existing files are
refused without ``--force`` before any work): ``excitation.csv`` (time, q1..qn at dt, one
period after another, at rest at both ends), ``excitation.toml`` (a program file naming the
robot, the CSV read as it is, dt, and the robot options used: ``mrnea check
DIR/excitation.toml`` alone simulates it) and ``summary.json`` (the Fourier coefficients, the
limits, the condition number and the best random start's, the verdict). Exit 0 when mrnea's
simulation of the program is ACHIEVABLE, 1 when not (the files are written), 2 on bad input.
A stop request (Ctrl-C, SIGTERM) ends the command within one SLSQP iteration
(:func:`mrnea.cli.base.checkpoint`, called by the optimisation) and writes nothing: exit 130.
The files are written all or none (:func:`mrnea.cli.base.write_files`): a stop request or an
error between two of them removes those written and puts back the files they replaced
(``--force``).
"""

from __future__ import annotations

import json
import math
import shlex
import sys
from pathlib import Path
from typing import Any

import click

from mrnea.cli import ahead
from mrnea.cli.base import (
    EXIT_ACHIEVABLE,
    EXIT_NOT_ACHIEVABLE,
    as_option,
    checkpoint,
    compile_notice,
    fresh_dir,
    main,
    one_line,
    write_files,
)
from mrnea.cli.options import (
    FOLDER,
    FRACTION,
    POSITIVE,
    force_opt,
    json_opt,
    load_robot_arg,
    quiet_opt,
    robot_options,
)
from mrnea.cli.retime import PAYLOAD, _payload_specs, _program_keys, _robot_spec
from mrnea.errors import StateError, quote
from mrnea.io import RobotOptions, is_program_file, load_program
from mrnea.io.source import parse_number
from mrnea.io.writer import check_new, own_folder, write_file

CSV, PROGRAM, SUMMARY = "excitation.csv", "excitation.toml", "summary.json"
#: the library's argument names as the command line spells them
OPTION = {"base_frequency": "--base-frequency", "harmonics": "--harmonics",
          "duration": "--duration", "dt": "--dt", "velocity_limit": "--velocity-limit",
          "acceleration_limit": "--acceleration-limit", "effort_margin": "--effort-margin",
          "candidates": "--candidates", "starts": "--starts", "seed": "--seed"}


class _PerJoint(click.ParamType):
    """``X`` or ``X1,...,Xn``: numbers > 0 (:func:`mrnea.io.source.parse_number`) or ``inf``
    (no limit); the count is checked against the robot."""

    name = "limit"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        if isinstance(value, tuple):
            return value
        out = []
        for item in str(value).split(","):
            item = item.strip()
            try:
                x = math.inf if item == "inf" else parse_number(item)
            except ValueError as exc:
                self.fail(str(exc), param, ctx)
            if not x > 0:
                self.fail(f"must be > 0 (or inf), got {quote(item)}", param, ctx)
            out.append(x)
        return tuple(out)


PER_JOINT = _PerJoint()


def _limit(value: tuple[float, ...] | None, option: str, n: int) -> Any:
    if value is None:
        return None
    if len(value) not in (1, n):
        raise click.BadParameter(f"expected one number or {n} (one per joint), got "
                                 f"{len(value)}", param_hint=f"'{option}'")
    return value[0] if len(value) == 1 else list(value)


@main.command()
@click.argument("robot", metavar="ROBOT")
@click.option("--out", type=FOLDER, default=None,
              help="Output folder [default: a fresh ./mrnea-excite].")
@click.option("--base-frequency", type=POSITIVE, default=0.1, show_default=True, metavar="HZ",
              help="Base frequency f of the Fourier series [Hz]; the period is 1/f.")
@click.option("--harmonics", type=click.IntRange(2), default=5, show_default=True, metavar="L",
              help="Harmonics per joint (the highest at L f), at most 20.")
@click.option("--duration", type=POSITIVE, default=None, metavar="SECONDS",
              help="Length [s], a whole number of periods [default: one period].")
@click.option("--dt", type=POSITIVE, default=0.005, show_default=True, metavar="SECONDS",
              help="Cycle time [s] of the program.")
@click.option("--velocity-limit", type=PER_JOINT, default=None, metavar="V[,V...]",
              help="[rad/s | m/s] one for all joints or one per joint, inf: none "
                   "[default: the robot's].")
@click.option("--acceleration-limit", type=PER_JOINT, default=None, metavar="A[,A...]",
              help="[rad/s^2 | m/s^2] one for all joints or one per joint [default: none, the "
                   "efforts bound it].")
@click.option("--effort-margin", type=FRACTION, default=0.9, show_default=True, metavar="M",
              help="The efforts stay within M x the effort limits, 0 < M <= 1.")
@click.option("--candidates", type=click.IntRange(1), default=100, show_default=True,
              metavar="N", help="Random Fourier series drawn.")
@click.option("--starts", type=click.IntRange(0), default=3, show_default=True, metavar="N",
              help="How many of the best candidates are optimised (0: the best candidate).")
@click.option("--seed", type=click.IntRange(0), default=0, show_default=True,
              help="Seed of the random candidates.")
@robot_options
@force_opt
@quiet_opt
@json_opt
def excite(robot: str, out: str | None, base_frequency: float, harmonics: int,
           duration: float | None, dt: float, velocity_limit: tuple[float, ...] | None,
           acceleration_limit: tuple[float, ...] | None, effort_margin: float, candidates: int,
           starts: int, seed: int, robot_options: RobotOptions, force: bool, quiet: bool,
           as_json: bool) -> None:
    """An excitation trajectory for identifying ROBOT: a Fourier series per joint, its
    coefficients optimised for a well-conditioned base regressor, within the limits.

    ROBOT is a built-in name, a robot file, or a program file naming its robot (with its
    robot options).

    Writes excitation.csv, excitation.toml (run it: mrnea check DIR/excitation.toml) and
    summary.json into --out; exit 1 when mrnea's simulation finds it NOT ACHIEVABLE.
    """
    from mrnea.actuators import one_state_at_a_time
    from mrnea.identify.excite import excitation

    spec, options = robot, robot_options
    if is_program_file(robot):  # a program names the robot (and its options)
        prog = load_program(robot)
        if prog.robot is None:
            raise click.BadParameter(f"the program {robot} names no robot; give the robot",
                                     param_hint="'ROBOT'")
        spec, options = prog.robot, robot_options.over(prog.options)
    rob = load_robot_arg(robot, robot_options)
    limits = {"velocity_limit": _limit(velocity_limit, "--velocity-limit", rob.n),
              "acceleration_limit": _limit(acceleration_limit, "--acceleration-limit", rob.n)}
    spec = _robot_spec(spec)
    with own_folder(Path(out) if out else fresh_dir("mrnea-excite")) as folder:
        paths = {k: folder / k for k in (CSV, PROGRAM, SUMMARY)}
        check_new([*paths.values(), *([folder / PAYLOAD] if options.payload else [])],
                  force)
        # the verifying simulation's later kernels, compiled while the search runs
        ahead.start(rob.parents, False, False)  # cold cache only (cli/ahead.py)
        # the effort checks on the single-state kernel the simulation compiles (issue 22)
        with compile_notice(quiet), one_state_at_a_time():
            try:
                exc = excitation(rob, base_frequency=base_frequency, harmonics=harmonics,
                                 duration=duration, dt=dt, effort_margin=effort_margin,
                                 candidates=candidates, starts=min(starts, candidates),
                                 seed=seed, checkpoint=checkpoint, **limits)
            except StateError as err:  # an argument: say it as the command line spells it
                raise StateError(as_option(str(err), OPTION)) from None
        checkpoint()  # a stop request during the simulation: nothing written

        # all or none (as retime's): the payload file, when the program keys write one
        side = [folder / PAYLOAD] if PAYLOAD in _payload_specs(options) else []
        write_files([(paths[CSV], lambda: exc.save_csv(paths[CSV], force)),
                     (paths[PROGRAM], lambda: exc.save_program(
                         paths[PROGRAM], spec, CSV,
                         program_keys=_program_keys(options, folder, force), overwrite=force)),
                     (paths[SUMMARY], lambda: write_file(paths[SUMMARY], json.dumps(
                         exc.summary(), indent=2, allow_nan=False) + "\n", force))],
                    side_files=side)
    if as_json:
        click.echo(json.dumps(exc.summary(), indent=2, allow_nan=False))
    elif not quiet:
        click.echo(f"Excitation: {exc.harmonics} harmonics of {exc.base_frequency:g} Hz, "
                   f"{exc.duration:g} s; condition number {exc.condition:.4g} (best random "
                   f"start {exc.condition_start:.4g})")
        click.echo(exc.verdict)
        click.echo(one_line(f"Written: {paths[CSV]}, {paths[PROGRAM]}, {paths[SUMMARY]}"))
        click.echo(f"Check it: mrnea check {shlex.quote(str(paths[PROGRAM]))}")
    sys.exit(EXIT_ACHIEVABLE if exc.achievable else EXIT_NOT_ACHIEVABLE)
