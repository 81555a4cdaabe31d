"""Grid files: a design sweep's parameters, and optionally its robot and programs, in TOML.

:func:`load_grid_file` reads one into a :class:`GridFile` (format and examples:
``docs/sweeps.md``)::

    [sweep]                       # optional
    robot = "sdt"                 # a built-in name or a robot file (relative to this file)
    programs = ["demo"]           # program files (relative to this file); "demo": the SDT demo
    zip = false                   # true: the lists in step instead of their product

    [grid]                        # required: parameter -> list of values
    "gear_ratio.cab_yaw" = [60, 80, 100, 120]
    "motor_torque_limit.cab_yaw" = [30, 40, 50, 60]

The reader checks the file's shape (tables, keys, arrays); the values are checked against the
robot by the sweep (:func:`mrnea.sweep.check_grid`), which names the grid entry. Every problem
raises :class:`mrnea.errors.SweepError` naming the file and the table and key at fault.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mrnea.errors import SweepError, quote
from mrnea.io.dispatch import resolve_robot
from mrnea.io.source import as_path, expand_home, read_text
from mrnea.io.tomlcheck import TomlCheck, type_name

__all__ = ["DEMO_PROGRAM", "GridFile", "load_grid_file"]

_TOP = ("sweep", "grid")
_SWEEP = ("robot", "programs", "zip")
DEMO_PROGRAM = "demo"
"""The program name that stands for the SDT demo's training profile (not a path): in grid
files, on ``mrnea sweep``'s command line and in :func:`mrnea.sweep`'s ``programs``."""


@dataclass(frozen=True)
class GridFile:
    """What a grid file says.

    Attributes
    ----------
    source : the file read.
    grid : parameter -> list of values, in the file's order.
    zip : take the lists in step instead of their product.
    robot : the robot (a built-in name or a path resolved against the file's folder), or None.
    programs : program files resolved against the file's folder (``"demo"`` as is); may be
        empty.
    """

    source: str
    grid: dict[str, list[Any]]
    zip: bool = False
    robot: str | None = None
    programs: list[str] = field(default_factory=list)


def load_grid_file(path: str | os.PathLike[str]) -> GridFile:
    """Read a grid file (module docstring).

    Raises
    ------
    SweepError
        The file is missing or not a regular file, TOML syntax (with line and column), an
        unknown table or key (did-you-mean), ``[grid]`` missing or empty, an entry that is not
        an array or is empty, ``zip`` not a boolean, ``robot`` or ``programs`` not text.
    """
    p = as_path(path, "path", SweepError)
    check = TomlCheck(str(p), SweepError, finite=False)
    doc = check.parse(read_text(p, "grid file", SweepError))
    check.check_keys(doc, _TOP, "top level")
    sweep = check.table(doc.get("sweep", {}), "top level", "sweep")
    check.check_keys(sweep, _SWEEP, "[sweep]")
    grid = check.table(check.require(doc, "grid", "top level"), "top level", "grid")
    if not grid:
        raise check.error("[grid]", "no parameter: give at least one, e.g. "
                                    "\"gear_ratio.cab_yaw\" = [60, 80, 100]")
    for key, values in grid.items():
        if isinstance(values, dict) and values:  # gear_ratio.cab_yaw = [...] unquoted
            joint = next(iter(values))
            raise check.error("[grid]", f"{quote(key)} must be an array of values, got a table "
                                        f"(TOML reads an unquoted dotted key as one): quote a "
                                        f"per-joint key, {quote(f'{key}.{joint}')} = [...]")
        if not isinstance(values, list):
            raise check.error("[grid]", f"{quote(key)} must be an array of values, got "
                                        f"{type_name(values)} {quote(values)}")
        if not values:
            raise check.error("[grid]", f"{quote(key)}: the list of values is empty")
    zip_ = sweep.get("zip", False)
    if not isinstance(zip_, bool):
        raise check.error("[sweep]", f"'zip' must be true or false, got {quote(zip_)}")
    robot = None
    if "robot" in sweep:
        spec = check.string(sweep["robot"], "[sweep]", "robot")
        robot = resolve_robot(str(expand_home(Path(spec), lambda m: check.error(
            "[sweep]", f"'robot': {m}"))), p.parent)
    programs = sweep.get("programs", [])
    if not isinstance(programs, list) or not all(isinstance(x, str) and x for x in programs):
        raise check.error("[sweep]", f"'programs' must be an array of file names, got "
                                     f"{quote(programs)}")
    resolved = [x if x == DEMO_PROGRAM else str(p.parent / expand_home(
                    Path(x), lambda m: check.error("[sweep]", f"'programs': {m}")))
                for x in programs]
    return GridFile(str(p), dict(grid), zip_, robot, resolved)

