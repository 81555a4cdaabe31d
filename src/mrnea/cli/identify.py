"""``mrnea identify ROBOT LOG --out DIR``: the robot's links, friction and rotor inertia from a
log of its own motion (issue 28; docs/identification.md).

ROBOT (a built-in name, a URDF or a ``.toml`` robot file, or a program file naming its robot,
such as an excitation program) gives the kinematics, limits and gear ratios, and the prior: its
inertials and drives. LOG is a CSV (:func:`mrnea.identify.read_log`): ``time [s]``, the joint
positions, and the joint-side efforts ``tau_<joint>``, or with ``--torque-constant`` the motor
currents ``i_<joint> [A]`` (tau = G k_t i); optional ``qd_<joint>``, ``qdd_<joint>`` columns.
Everything is read and checked before any work; a bad log is one error line naming the file, the
row and the column. ``--validate LOG2`` predicts a second log with the identified robot instead
of holding out the end of LOG.

Writes into DIR (never replacing a file without ``--force``): ``identified_robot.toml`` (a native
robot file: ``mrnea check identified_robot.toml PROGRAM``), ``identified_drives.toml`` (a sidecar
actuator file: ``--actuators identified_drives.toml`` with the robot file given), ``summary.json``
(strict JSON; every field and unit in ``identify.schema.json``) and ``identify.html``; prints one
line per joint (and, on stderr, an ``identifying ...`` label while it fits). Exit 0 done, 2 bad
input, 130 interrupted (a stop is honoured once the fit returns, before the first file, and
between the files: all of them or none, :func:`mrnea.cli.base.write_files`, the files they
replaced with ``--force`` put back).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click
import numpy as np

from mrnea.cli.base import (
    as_option,
    checkpoint,
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
    POSITIVE,
    force_opt,
    load_robot_arg,
    quiet_opt,
    robot_options,
)
from mrnea.errors import MrneaError, quote
from mrnea.io import RobotOptions
from mrnea.io.source import parse_number
from mrnea.io.writer import check_new, own_folder, write_file

#: the library's argument names as the command line spells them
OPTION = {"cutoff_hz": "--cutoff", "min_speed": "--min-speed", "prior_weight": "--prior-weight",
          "holdout": "--holdout", "a validation log": "--validate LOG2"}

FILES = ("identified_robot.toml", "identified_drives.toml", "summary.json", "identify.html")


class _Constants(click.ParamType):
    """``KT`` or ``KT1,KT2,...`` [N m/A]: finite numbers > 0 (how many: read_log checks)."""

    name = "torque_constant"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        try:
            kt = np.array([parse_number(x.strip()) for x in str(value).split(",")])
        except ValueError as exc:
            self.fail(str(exc), param, ctx)
        if not np.all(kt > 0):
            self.fail(f"must be > 0, got {quote(value)}", param, ctx)
        return kt


@main.command()
@click.argument("robot", metavar="ROBOT")
@click.argument("log", metavar="LOG", type=click.Path(dir_okay=False))
@click.option("--validate", "validation", type=click.Path(dir_okay=False), default=None,
              metavar="LOG2", help="A second log (same columns) to predict with the identified "
                                   "robot [default: hold out the end of LOG].")
@click.option("--torque-constant", "torque_constant", type=_Constants(), default=None,
              metavar="KT[,KT2,...]",
              help="LOG holds motor currents i_<joint> [A]: the motor torque constant [N m/A], "
                   "one for all joints or one per joint; tau = G k_t i (G: the gear ratio).")
@click.option("--cutoff", type=POSITIVE, default=10.0, show_default=True, metavar="HZ",
              help="Cut-off of the zero-phase low-pass filter the positions pass before they "
                   "are differentiated (unused when LOG has qd_ and qdd_ columns).")
@click.option("--holdout", type=NON_NEGATIVE, default=0.2, show_default=True,
              metavar="FRACTION", help="The end of LOG held out of the fit and predicted, "
                                       "in [0, 1) (unused with --validate).")
@click.option("--min-speed", "min_speed", type=NON_NEGATIVE, default=0.01, show_default=True,
              metavar="SPEED", help="A joint's rows slower than this [rad/s | m/s] are left "
                                    "out (Coulomb friction is set-valued at rest).")
@click.option("--prior-weight", "prior_weight", type=POSITIVE, default=1e-3, show_default=True,
              metavar="W", help="Weight of ROBOT's own values in the physically consistent "
                                "fit (what the log cannot see stays there).")
@click.option("--out", type=FOLDER, default=None,
              help="Output folder [default: a fresh ./mrnea-identify].")
@robot_options
@force_opt
@quiet_opt
def identify(robot: str, log: str, validation: str | None, torque_constant: Any,
             cutoff: float, holdout: float, min_speed: float, prior_weight: float,
             out: str | None, robot_options: RobotOptions, force: bool, quiet: bool) -> None:
    """Identify ROBOT's links, friction and rotor inertia from LOG.

    Base inertial parameters, per joint viscous and Coulomb friction (each direction) and
    reflected rotor inertia, by weighted least squares with standard errors, then the physically
    consistent robot nearest them (ROBOT's own values as the prior).
    """
    from mrnea.identify import identify as run_identify
    from mrnea.identify import read_log
    from mrnea.identify.estimate import check_log
    from mrnea.identify.html import identify_html
    from mrnea.identify.log import sample_rate
    from mrnea.identify.output import drives_toml, identify_summary

    if not holdout < 1:  # here, before the progress label, so that the error is stderr's one line
        raise click.BadParameter(f"must be in [0, 1), got {holdout:g}", param_hint="'--holdout'")
    prior = load_robot_arg(robot, robot_options)
    data = read_log(log, prior, torque_constant)
    check = None if validation is None else read_log(validation, prior, torque_constant)
    for path, d in ((log, data), (validation, check)):  # before the label, as --holdout
        if d is not None and (d.qd is None or d.qdd is None):
            try:
                sample_rate(d.time, cutoff)
            except MrneaError as exc:
                raise type(exc)(f"{path}: {as_option(str(exc), OPTION)}") from None
    try:  # what the fit would refuse, told before the label (a filter pass, no regressor)
        check_log(prior, data, validation=check, holdout=holdout, cutoff_hz=cutoff,
                  min_speed=min_speed)
    except MrneaError as exc:
        raise type(exc)(f"{log}: {as_option(str(exc), OPTION)}") from None
    with own_folder(Path(out) if out else fresh_dir("mrnea-identify")) as folder:
        check_new([folder / f for f in FILES], force)
        checkpoint()
        if not quiet:  # the progress label: the fit is one call, tens of seconds
            click.echo(f"identifying {one_line(prior.name)} from {one_line(log)} ({data.K} "
                       "samples)...", err=True)
        with compile_notice(quiet):
            try:
                res = run_identify(prior, data, validation=check, holdout=holdout,
                                   cutoff_hz=cutoff, min_speed=min_speed,
                                   prior_weight=prior_weight)
            except MrneaError as exc:  # logs that cannot identify the robot: name the files
                raise type(exc)(f"{log}{'' if validation is None else ' or ' + validation}: "
                                f"{as_option(str(exc), OPTION)}") from None
        checkpoint()
        summary = identify_summary(res, prior, data, str(log), validation, torque_constant)
        robot_file, drives, summary_file, page = (folder / f for f in FILES)
        # all or none: a stop or an error between two files puts back those they replaced
        write_files([
            (robot_file, lambda: res.robot.to_toml(robot_file, overwrite=force)),
            (drives, lambda: write_file(drives, drives_toml(res, str(log)), force)),
            (summary_file, lambda: write_file(summary_file, json.dumps(
                summary, indent=2, allow_nan=False) + "\n", force)),
            (page, lambda: identify_html(res, summary, page, overwrite=force))])
    last_checkpoint()
    if not quiet:
        for line in _lines(summary):
            click.echo(line)
        click.echo(one_line(f"Wrote {folder}: " + ", ".join(FILES)))


def _lines(s: dict[str, Any]) -> list[str]:
    """What the command prints: the log and condition number, then one line per joint."""
    from mrnea.report.drawing import fmt_number as f

    def pm(j: dict[str, Any], field: str) -> str:
        se = j[f"{field}_se"]
        return (f"{f(j[field])} (in {j['folded'][field]})" if se is None else
                f"{f(j[field])} ± {f(se, 2)}")

    out = [f"{one_line(s['robot'])} identified from {one_line(s['log'])} ({s['samples']} samples): "
           f"{s['base_parameters']} base parameters, condition number {f(s['condition'])}"]
    for j in s["joints"]:
        u = j["effort_unit"]
        val = ("" if j["validation_rms"] is None else
               f", prediction RMS {f(j['validation_rms'], 3)} {u}")
        out.append(f"{one_line(j['joint'])}: G²Jm {pm(j, 'reflected_rotor_inertia')}, "
                   f"Fv {pm(j, 'viscous_friction')}, F+ {pm(j, 'coulomb_friction_pos')} {u}, "
                   f"F- {pm(j, 'coulomb_friction_neg')} {u}; "
                   f"residual sigma {f(j['residual_std'], 3)} {u}{val}")
    return out
