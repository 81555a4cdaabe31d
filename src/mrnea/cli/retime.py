"""``mrnea retime [ROBOT] PROGRAM --out DIR``: the same path, the fastest timing the robot can make.

Writes into DIR (its own for the run: :func:`mrnea.io.writer.own_folder`; existing files are
refused without ``--force`` before any work): ``retimed.csv`` (time, q1..qn at dt: ``mrnea check
ROBOT DIR/retimed.csv --dt DT`` reads it), ``retimed.toml`` (a program file naming the robot, the
csv, dt, the mode, the retimed wrench and the robot options the run used: ``mrnea check
DIR/retimed.toml`` alone reproduces the verification; a payload with an inertia goes to
``payload.toml`` beside it), ``summary.json`` (strict JSON:
:meth:`mrnea.retime.RetimeResult.summary`) and ``report.html`` (the phase plane, the effort
ratios before and after, the verdict). A stop request (Ctrl-C, SIGTERM) ends the command
within about a second (the retiming calls :func:`mrnea.cli.base.checkpoint` between its solves
and simulation chunks; the files are written with a checkpoint between each) and writes
nothing: files this run had already written are removed again. Exit code 130. A program no
timing makes achievable (:class:`~mrnea.errors.NoTimingError`) is a verdict: one ``NOT ACHIEVABLE
at any timing:`` line, exit code 1, nothing written.

Also :func:`suggestion`: what ``check`` and ``simulate`` print under a program that is not
achievable (the command, and the duration uniform scaling would give by Hollerbach's closed-form
estimate).
"""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import click
import numpy as np

from mrnea import validate
from mrnea.cli import ahead
from mrnea.cli.base import (
    EXIT_ACHIEVABLE,
    EXIT_NOT_ACHIEVABLE,
    checkpoint,
    compile_notice,
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
    load_program_arg,
    load_run,
    mode_opt,
    no_3d_opt,
    quiet_opt,
    robot_options,
    units_opt,
)
from mrnea.errors import JerkLimitError, MrneaError, NoTimingError, RetimeError
from mrnea.io import BUILTIN_ROBOTS, Payload, RobotOptions, resolve_robot
from mrnea.io.pathcsv import INTERPOLATIONS
from mrnea.io.source import parse_number
from mrnea.io.writer import check_new, create, own_folder
from mrnea.model import Robot

CSV, PROGRAM, SUMMARY, REPORT, PAYLOAD = ("retimed.csv", "retimed.toml", "summary.json",
                                          "report.html", "payload.toml")
#: A Cartesian program's retimed timing: its tool poses at the retimed cycles, and the program
#: of one pose CSV move that runs them (docs/cartesian.md, "Retiming").
POSES, CARTESIAN = "retimed_poses.csv", "retimed_cartesian.toml"


class _JerkLimit(click.ParamType):
    """``J`` or ``J1,J2,...,Jn``: joint jerk limits [rad/s^3 | m/s^3], each a finite number > 0
    in the strict grammar of :func:`mrnea.io.source.parse_number` (the count is checked against
    the robot once it is loaded)."""

    name = "jerk"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None
                ) -> Any:
        if isinstance(value, tuple):
            return value
        out = []
        for part in str(value).split(","):
            try:
                number = parse_number(part.strip())
            except ValueError as exc:
                self.fail(f"{exc} (in {value!r})", param, ctx)
            if not number > 0:
                self.fail(f"every limit must be > 0, got {value!r}", param, ctx)
            out.append(number)
        return tuple(out)


def _jerk_limits(jerk: tuple[float, ...] | None, robot: Robot) -> list[float] | None:
    """``--jerk-limit``'s numbers, one for every joint or one per joint."""
    if jerk is None or len(jerk) in (1, robot.n):
        return None if jerk is None else list(jerk)
    raise MrneaError(f"--jerk-limit: expected one number or {robot.n} (one per joint: "
                     f"{', '.join(robot.joint_names)}), got {len(jerk)}")


def _robot_spec(spec: str) -> str:
    """What a program file names the robot by: a built-in name, or a robot file's absolute
    path (the program file lives elsewhere)."""
    source = resolve_robot(spec)
    return source if source in BUILTIN_ROBOTS else str(Path(source).resolve())


def _point_mass(p: Payload) -> str | None:
    """A payload as ``KG@X,Y,Z`` or ``KG@LINK:X,Y,Z`` (shortest reprs), or None when it has
    an inertia."""
    if np.any(p.inertia):
        return None
    return (f"{float(p.mass)!r}@" + (f"{p.link}:" if p.link is not None else "")
            + ",".join(repr(float(c)) for c in p.com))


def _payload_specs(options: RobotOptions) -> list[str]:
    """The retimed program's ``payload`` entries: each payload's point mass, or PAYLOAD for the
    one with an inertia (a MrneaError for several such: one payload file holds one)."""
    specs = [_point_mass(p) or PAYLOAD for p in options.payload or ()]
    if specs.count(PAYLOAD) > 1:
        raise MrneaError("retime writes one payload file: give at most one payload with an "
                         "inertia (the others as KG@LINK:X,Y,Z point masses)")
    return specs


def _program_keys(options: RobotOptions, folder: Path, force: bool) -> dict[str, Any]:
    """The [program] keys that give the retimed program the robot options the run used; a
    payload with an inertia is written to ``folder``/payload.toml (one such payload: a
    MrneaError for several, which one file cannot hold)."""
    keys: dict[str, Any] = {}
    if options.actuators is not None:
        keys["actuators"] = str(Path(options.actuators).resolve())
    if options.tip is not None:
        keys["tip"] = options.tip if isinstance(options.tip, str) else list(options.tip)
    if options.payload is not None:
        specs = _payload_specs(options)
        keys["payload"] = specs[0] if len(specs) == 1 else specs
        if PAYLOAD in specs:
            p = options.payload[specs.index(PAYLOAD)]
            with create(folder / PAYLOAD, force) as fh:
                fh.write(f"# The payload of the retimed program ({PROGRAM}).\n"
                         f"mass = {float(p.mass)!r}\ncom = {[float(c) for c in p.com]!r}\n"
                         f"inertia = {np.asarray(p.inertia, dtype=float).tolist()!r}\n"
                         + (f"link = {json.dumps(p.link)}\n" if p.link is not None else ""))
    if options.gravity is not None:
        keys["gravity"] = [float(g) for g in options.gravity]
    return keys


@main.command()
@click.argument("robot", required=False, metavar="[ROBOT]")
@click.argument("program", required=False, metavar="PROGRAM", type=click.Path(dir_okay=False))
@click.option("--out", type=FOLDER, required=True,
              help="Output folder (created if missing).")
@click.option("--method", type=click.Choice(["toppra", "scale"]), default="toppra",
              show_default=True,
              help="toppra: time-optimal along the path; scale: uniform time scaling.")
@click.option("--margin", type=FRACTION, default=0.98, show_default=True, metavar="M",
              help="toppra: plan against M x every effort and velocity limit, 0 < M <= 1 "
                   "(lowered until the simulation accepts the result).")
@click.option("--jerk-limit", "jerk", type=_JerkLimit(), default=None, metavar="J[,J2,...]",
              help="toppra: joint jerk limits [rad/s^3 | m/s^3], one for every joint or one per "
                   "joint: the fastest timing found whose jerks stay within them.")
@click.option("--dt", type=POSITIVE, default=None, metavar="SECONDS",
              help="Cycle time [s] of the retimed program (default the program's; a CSV "
                   "PROGRAM needs it).")
@click.option("--interpolation", type=click.Choice(list(INTERPOLATIONS)), default=None,
              help="How a CSV PROGRAM's rows are resampled to --dt [default: cubic].")
@units_opt
@mode_opt
@robot_options
@no_3d_opt
@force_opt
@quiet_opt
@json_opt
def retime(robot: str | None, program: str | None, out: str, method: str, margin: float,
           jerk: tuple[float, ...] | None, dt: float | None, interpolation: str | None,
           units: str | None, mode: str, robot_options: RobotOptions,
           no_3d: bool, force: bool, quiet: bool, as_json: bool) -> None:
    """Retime PROGRAM: keep its path, give it the fastest timing ROBOT can make, verify it.

    PROGRAM is a program file (.toml), a path CSV (with --dt) or ``demo`` (the SDT demo's
    training profile, as examples/sdt_training.toml). ROBOT may be left out when PROGRAM names
    its robot; the robot options override the program's. Writes retimed.csv, retimed.toml,
    summary.json and report.html into --out.
    """
    robot_arg, program_arg = (None, robot) if program is None else (robot, program)
    csv = (program_arg or "").lower().endswith(".csv")
    run = load_run(robot_arg, program_arg, dt if csv else None, interpolation, robot_options,
                   units)
    if csv:
        spec, options = _robot_spec(robot_arg), robot_options
    else:
        prog = load_program_arg(program_arg)
        spec = _robot_spec(robot_arg or prog.robot)
        options = robot_options.over(prog.options)
    jerk_limit = _jerk_limits(jerk, run.robot)
    if jerk_limit is not None and method != "toppra":
        raise MrneaError("--jerk-limit: only --method toppra takes it")
    t = np.arange(run.q_cmd.shape[0]) * run.dt
    tool, cartesian = _one_tool(run.cartesian, prog if not csv else None)
    # the second process first, so that it compiles while this one imports toppra (issue 22;
    # a run refused below ends it at exit)
    ahead.start(run.robot.parents, validate.by_link(run.f_ext, run.f_ext_point), True,
                retime=True)
    # toppra and SciPy take 1-4 s to import: before the run owns its folder (the stop bound)
    import mrnea.retime.toppra  # noqa: F401
    from mrnea.actuators import one_state_at_a_time
    from mrnea.retime import retime as retime_program

    try:
        with own_folder(Path(out)) as folder:
            paths = {k: folder / k for k in (CSV, PROGRAM, SUMMARY, REPORT,
                                             *((POSES, CARTESIAN) if cartesian else ()))}
            # payload.toml only when this run writes it: a point-mass payload's run (or one
            # without a payload) leaves a payload.toml there alone, as it does the folder's
            # other files
            side = [folder / PAYLOAD] if PAYLOAD in _payload_specs(options) else []
            check_new([*paths.values(), *side], force)
            # one process, one retiming: the single-state kernels the simulation compiles anyway
            # (mrnea.actuators.one_state_at_a_time; issue 22)
            with compile_notice(quiet), one_state_at_a_time():
                try:
                    res = retime_program(run.robot, (t, run.q_cmd), dt=dt, method=method,
                                         margin=margin, f_ext=run.f_ext,
                                         f_ext_point=run.f_ext_point, mode=run.mode or mode,
                                         checkpoint=checkpoint, jerk_limit=jerk_limit)
                except NoTimingError:
                    raise
                except JerkLimitError as exc:  # about the option: name it
                    raise MrneaError(f"--jerk-limit: {exc.detail}") from None
                except RetimeError as exc:  # about the program: say which file it is
                    raise RetimeError(f"{program_arg}: {exc}") from None
            _write(res, folder, paths, spec, options, f"{Path(program_arg).stem}-retimed",
                   force, not no_3d, (tool, cartesian), side)
    except NoTimingError as exc:  # a verdict: nothing written, the new folder removed
        _no_timing(f"{program_arg}: {exc}", as_json, quiet)
    if as_json:
        click.echo(json.dumps({**res.summary(), "report": str(paths[REPORT])}, indent=2,
                              allow_nan=False))
    elif not quiet:
        click.echo(res.verdict())
        click.echo(one_line(f"Written: {paths[CSV]}, {paths[PROGRAM]}, {paths[SUMMARY]}, "
                            f"{paths[REPORT]}" + (f", {paths[POSES]}, {paths[CARTESIAN]}"
                                                  if CARTESIAN in paths else "")))
        click.echo(f"Check it: mrnea check {shlex.quote(str(paths[PROGRAM]))}")
    sys.exit(EXIT_ACHIEVABLE if res.achievable else EXIT_NOT_ACHIEVABLE)


def _no_timing(why: str, as_json: bool, quiet: bool) -> NoReturn:
    """End the command on the verdict that no timing of the path is achievable
    (:class:`~mrnea.errors.NoTimingError`): one ``NOT ACHIEVABLE`` line on stdout (the JSON
    object ``{"achievable": false, "retimed": false, "verdict": ...}`` with --json), exit 1."""
    verdict = f"NOT ACHIEVABLE at any timing: {why}"
    if as_json:
        click.echo(json.dumps({"achievable": False, "retimed": False, "verdict": verdict},
                              indent=2, allow_nan=False))
    elif not quiet:
        click.echo(verdict)
    checkpoint()
    sys.exit(EXIT_NOT_ACHIEVABLE)


def _one_tool(cartesian: Any, prog: Any) -> tuple[Any, Any]:
    """(the tool and hold as the retimed Cartesian program gives them, the CartesianPath) of a
    Cartesian program whose moves are of one tool with one ``hold``; (None, None) for a joint
    program and for moves of several tools (on a tree, several arms: a pose CSV holds one tool's
    poses, so only the joint program is written)."""
    if cartesian is None or cartesian.tool is None or len({m.hold for m in cartesian.moves}) > 1:
        return None, None
    first = cartesian.moves[0]
    return (first.tool if first.tool is not None else prog.moves.tool, first.hold), cartesian


def _cartesian_program(res: Any, paths: dict[str, Path], tool: Any, force: bool) -> None:
    """A program of one ``poses`` move running :data:`POSES` from the first retimed row, with
    the joint program's [program] keys and [wrench] (read back from its file); ``tool`` the
    (tool, hold) of :func:`_one_tool`."""
    import tomllib

    from mrnea.io.program import save_program

    joint = tomllib.loads(paths[PROGRAM].read_text(encoding="utf-8"))
    spec, hold = tool
    program = {**joint["program"], "q0": res.q_cmd[0],
               **({"tool": spec} if spec is not None else {})}
    save_program(paths[CARTESIAN], program, None, joint.get("wrench"),
                 f"The retimed Cartesian program: its tool poses at the retimed cycles "
                 f"({POSES}), solved by inverse kinematics from q0.\nRun: mrnea check "
                 f"{CARTESIAN}", force,
                 moves=[{"type": "poses", "csv": POSES, "interpolation": "linear",
                         **({"hold": list(hold)} if hold else {})}])


def _cartesian_steps(res: Any, paths: dict[str, Path], tool: Any, cartesian: Any,
                     force: bool) -> list[tuple[Path, Callable[[], Any]]]:
    """The writes of a Cartesian program's retimed timing (none for a joint program): the
    tool poses of the retimed rows (forward kinematics of the tool frame) as a pose CSV, and
    :func:`_cartesian_program`."""
    if cartesian is None:
        return []
    from mrnea.dynamics import forward_kinematics
    from mrnea.io.posecsv import save_poses

    def poses() -> None:
        T = forward_kinematics(res.robot, res.q_cmd, tool=cartesian.tool)[:, -1]
        save_poses(paths[POSES], res.t, T, force)

    return [(paths[POSES], poses),
            (paths[CARTESIAN], lambda: _cartesian_program(res, paths, tool, force))]


def _write(res: Any, folder: Path, paths: dict[str, Path], spec: str, options: RobotOptions,
           name: str, force: bool, view3d: bool, cartesian: tuple[Any, Any] = (None, None),
           side: list[Path] | None = None) -> None:
    """Write the run's files, a checkpoint before each; a stop request removes the files this
    run wrote so far and puts back those they replaced (:func:`mrnea.cli.base.write_files`).
    ``cartesian``: a Cartesian program's (tool spec, CartesianPath), whose retimed timing is
    written too. ``side``: the payload file, when the program keys write one (only then is a
    file at its name replaced: write_files moves every file it names aside and deletes it)."""
    from mrnea.report.retime import write_retime_report

    steps = [
        (paths[CSV], lambda: res.save_csv(paths[CSV], force)),
        (paths[PROGRAM], lambda: res.save_program(
            paths[PROGRAM], spec, CSV, name=name,
            program_keys=_program_keys(options, folder, force), overwrite=force)),
        *_cartesian_steps(res, paths, *cartesian, force),
        (paths[SUMMARY], lambda: res.save_summary(paths[SUMMARY], force)),
        (paths[REPORT], lambda: write_retime_report(res, paths[REPORT], force, files={
            "retimed program (CSV)": paths[CSV], "program file": paths[PROGRAM],
            "summary": paths[SUMMARY]}, view3d=view3d)),
    ]
    write_files(steps, side_files=side or [])  # the program's payload file


def _option_args(options: RobotOptions) -> list[str]:
    """The robot options as command-line arguments (a payload with an inertia as its point
    mass: its file's name is not kept)."""
    args = []
    if options.actuators is not None:
        args += ["--actuators", options.actuators]
    if options.tip is not None:
        for t in (options.tip,) if isinstance(options.tip, str) else options.tip:
            args += ["--tip", t]
    for p in options.payload or ():
        args += ["--payload", _point_mass(p) or "FILE"]
    if options.gravity is not None:
        args += ["--gravity", ",".join(repr(float(g)) for g in options.gravity)]
    return args


def outside_limits(robot: Robot, q_cmd: np.ndarray, dt: float) -> str | None:
    """Why no timing can help a path ``q_cmd`` (K, n) [rad | m] at ``dt`` [s]: the first joint
    whose path starts outside its position limits, else the first that leaves them (retiming
    keeps the path); None when it stays within them."""
    lower, upper = robot.lower, robot.upper
    outside = (q_cmd < lower) | (q_cmd > upper)
    if not outside.any():
        return None
    k, i = (int(x) for x in np.argwhere(outside)[0])
    j = robot.joints[i]
    where = (f"joint '{j.name}' starts at {q_cmd[0, i]:.4g} {j.unit('q')}" if k == 0 else
             f"joint '{j.name}' reaches {q_cmd[k, i]:.4g} {j.unit('q')} at t = {k * dt:.4g} s")
    return (f"{where}, outside its position limits [{lower[i]:.4g}, {upper[i]:.4g}] "
            f"{j.unit('q')}, and retiming keeps the path")


def suggestion(robot: Robot, robot_arg: str | None, program_arg: str | None,
               options: RobotOptions, q_cmd: np.ndarray, dt: float, f_ext: np.ndarray | None,
               f_ext_point: np.ndarray | None, interpolation: str | None = None,
               mode: str | None = None, units: str | None = None) -> str:
    """What ``check`` and ``simulate`` print under a program that is not achievable: the
    ``retime`` command with the same robot, program, robot options and run (a CSV program's
    --dt [s], --interpolation and --units, a --mode the program file does not set), and the
    duration uniform time scaling would give by Hollerbach's closed-form estimate on the
    program's own requirement; or why no timing can help: a path that starts or goes outside a
    joint's position limits (:func:`outside_limits`), a requirement no speed can meet."""
    from mrnea.actuators import one_state_at_a_time
    from mrnea.retime import scale_estimate

    if (why := outside_limits(robot, q_cmd, dt)) is not None:
        return f"No timing can make it achievable: {why}"
    program = program_arg or robot_arg or "PROGRAM"
    run = ["--dt", repr(float(dt))] if program.lower().endswith(".csv") else []
    run += [*(["--interpolation", interpolation] if interpolation else []),
            *(["--units", units] if units else []), *(["--mode", mode] if mode else [])]
    args = [*([robot_arg] if robot_arg and program_arg else []), program, "--out",
            f"{Path(program).stem}-retimed", *run, *_option_args(options)]
    T = (q_cmd.shape[0] - 1) * dt
    try:
        with one_state_at_a_time():  # the kernels check and simulate compiled (issue 22)
            f = scale_estimate(robot, q_cmd, dt, f_ext, f_ext_point)
    except MrneaError as exc:
        return f"No timing can make it achievable: {exc}"
    return (f"Retime it: mrnea retime {shlex.join(args)}\n(uniform time scaling would take "
            f"about {f * T:.4g} s instead of {T:.4g} s, {f:.3g} x, by Hollerbach's estimate; the "
            "default method, toppra, is time-optimal along the path and usually faster)")
