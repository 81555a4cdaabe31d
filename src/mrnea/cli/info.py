"""``mrnea info [ROBOT]``: joints, masses, limits and actuators of a robot, or the built-ins."""

from __future__ import annotations

import json
import shutil

import click

from mrnea.cli.base import last_checkpoint, main
from mrnea.cli.options import json_opt, load_robot_arg, robot_options
from mrnea.describe import describe, robot_data
from mrnea.io import BUILTIN_ROBOTS, RobotOptions, load_builtin


def _builtins(as_json: bool) -> None:
    robots = [load_builtin(name) for name in BUILTIN_ROBOTS]
    if as_json:
        click.echo(json.dumps({"builtin_robots": [
            {"name": r.name, "n": r.n, "joints": list(r.joint_names)} for r in robots]},
            indent=2))
        return
    click.echo("Built-in robots ('mrnea info NAME' describes one):")
    width = max(len(r.name) for r in robots)
    for r in robots:
        click.echo(f"  {r.name:<{width}}  {r.n} joints: {', '.join(r.joint_names)}")


@main.command()
@click.argument("robot", required=False)
@robot_options
@json_opt
def info(robot: str | None, robot_options: RobotOptions, as_json: bool) -> None:
    """Print ROBOT's joints, masses, limits and actuators; without ROBOT, list the built-ins.

    ROBOT is a built-in name, a robot file (URDF, native .toml) or a program file (its robot,
    with the program's actuators, tip, payload and gravity). The table fits the terminal;
    --json prints strict JSON (unlimited values are null).
    """
    if robot is None:
        last_checkpoint()
        _builtins(as_json)
        return
    rob = load_robot_arg(robot, robot_options)
    last_checkpoint()
    if as_json:
        click.echo(json.dumps(robot_data(rob), indent=2, allow_nan=False))
    else:
        click.echo(describe(rob, width=shutil.get_terminal_size().columns))
