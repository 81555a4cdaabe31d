"""``mrnea info ROBOT``: joints, masses, limits and actuators of a robot."""

from __future__ import annotations

import json

import click

from mrnea.cli.base import json_opt, load_any, main


@main.command()
@click.argument("robot")
@json_opt
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
