"""The ``mrnea`` command.

``mrnea demo`` runs the main job on the built-in spatial disorientation trainer;
``mrnea info ROBOT`` prints a robot's joints, masses, limits and actuators. ROBOT is a built-in
name (``mrnea info --help`` lists them), a URDF or a native ``.toml`` file. Bad input ends with
one clear line on stderr and exit code 2 (``--debug`` shows the traceback).
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator

import click
import numpy as np

from mrnea import robots
from mrnea.errors import MrneaError
from mrnea.model import Robot


@contextlib.contextmanager
def compile_notice(delay: float = 1.5) -> Iterator[None]:
    """Say once on stderr that the kernels are compiling, if the block takes longer than delay.

    Numba compiles each kernel on its first call and caches it on disk; later runs skip this.
    """
    timer = threading.Timer(delay, lambda: click.echo(
        "Compiling mrnea's kernels (first run only; cached for later runs)...", err=True))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


def load_any(spec: str) -> Robot:
    """A built-in robot by name, else a robot file (URDF or native TOML) by path."""
    if spec in robots.names():
        return robots.load(spec)
    from mrnea.io import load_robot

    return load_robot(spec)


class _Group(click.Group):
    """Turns the package's input errors into one line on stderr and exit code 2."""

    def invoke(self, ctx: click.Context) -> object:
        try:
            return super().invoke(ctx)
        except (MrneaError, OSError) as exc:
            if ctx.params.get("debug"):
                raise
            click.echo(f"mrnea: error: {exc}", err=True)
            sys.exit(2)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.option("--debug", is_flag=True, help="Show full tracebacks on errors.")
@click.version_option(package_name="mrnea")
def main(debug: bool) -> None:
    """mrnea: robot dynamics with the modified recursive Newton-Euler algorithm."""


@main.command()
def demo() -> None:
    """Load the built-in SDT, print its model and one forward-dynamics result."""
    from mrnea.dynamics import forward_dynamics, inverse_dynamics, mass_matrix_and_bias

    robot = robots.sdt()
    click.echo(robot.describe())
    q = np.array([0.3, -0.5, 0.4, 0.2])
    qd = np.array([1.0, 0.5, -0.3, 0.2])
    tau = np.zeros(robot.n)
    with compile_notice():
        H, u = mass_matrix_and_bias(robot, q, qd)
        qdd = forward_dynamics(robot, q, qd, tau)
        check = inverse_dynamics(robot, q, qd, qdd)
    np.set_printoptions(precision=5, suppress=False, linewidth=100)
    click.echo("\nOne state, unpowered joints (tau = 0):")
    click.echo(f"  q   [rad]      = {q}")
    click.echo(f"  qd  [rad/s]    = {qd}")
    click.echo(f"  H   [kg m^2]   =\n{H}")
    click.echo(f"  u'  [N m]      = {u}")
    click.echo(f"  qdd [rad/s^2]  = {qdd}   (mRNEA + Cholesky)")
    click.echo(f"  RNEA(q, qd, qdd) [N m] = {check}   (should be ~0)")


@main.command()
@click.argument("robot")
def info(robot: str) -> None:
    """Print ROBOT's joints, masses, limits and actuators (built-ins: sdt, puma560)."""
    click.echo(load_any(robot).describe())
