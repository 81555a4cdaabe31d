"""Cartesian programs (issue 26): ``[[move]]`` tables made into joint positions by inverse
kinematics, the tool path kept alongside, and the verdict on it.

* :func:`solve` -- a program's moves into ``t``, ``q_cmd`` and ``program.cartesian`` on a robot;
* :func:`load_program` -- a program file, solved on its robot when it is Cartesian
  (``mrnea.load_program``);
* :class:`CartesianPath` -- the programmed tool pose of every cycle, its move, the inverse
  kinematics' errors and the findings (:mod:`mrnea.cartesian.verdict`).

Docs: ``docs/cartesian.md`` and ``docs/programs.md`` ("Cartesian moves").
"""

from __future__ import annotations

from pathlib import Path

from mrnea.cartesian.solve import CartesianPath, solve
from mrnea.cartesian.verdict import Finding
from mrnea.errors import ProgramFileError
from mrnea.io.dispatch import RobotOptions
from mrnea.io.program import Program
from mrnea.io.program import load_program as read_program
from mrnea.model import Robot

__all__ = ["CartesianPath", "Finding", "load_program", "solve"]


def load_program(path: str | Path, robot: Robot | str | None = None,
                 options: RobotOptions | None = None) -> Program:
    """A program file (:func:`mrnea.io.load_program`), its Cartesian moves solved.

    Parameters
    ----------
    path : the ``.toml`` program file.
    robot : for a Cartesian program, a program naming its joints or a CSV path (whose header
        may name them), the robot to put it on: a :class:`mrnea.Robot`, or a built-in name or
        robot file (the program's own if it names one, :meth:`mrnea.io.Program.load_robot`);
        None: the robot the program names. Unused for a path of waypoint arrays.
    options : robot options over the program's (:meth:`mrnea.io.Program.load_robot`).

    Returns
    -------
    Program
        ``t``, ``q_cmd`` (K, n) and, for a Cartesian program, ``cartesian`` (the tool path and
        its verdict, :class:`CartesianPath`).

    Raises
    ------
    ProgramFileError
        As :func:`mrnea.io.load_program`; a Cartesian program without a robot; a move that
        cannot be timed.
    """
    prog = read_program(path)
    if prog.moves is None and prog.named is None and prog.columns is None:
        return prog
    if robot is None and prog.robot is None:
        if prog.columns is not None:  # a CSV path without a robot: its columns in order
            return prog
        what = "Cartesian program" if prog.moves is not None else "program naming its joints"
        raise ProgramFileError(f"{prog.source}: a {what} is solved on its robot, and "
                               f"this one names none ([program] robot); give one: "
                               f"mrnea.load_program(path, robot=...)")
    rob = robot if isinstance(robot, Robot) else prog.load_robot(robot, options)
    return solve(prog, rob)
