"""Programs that name their joints: waypoint tables and path CSV headers matched by joint name.

A branching robot (a torso with two arms, a hand) has many joints whose order the user did not
choose (depth first from the root, children in file order: :mod:`mrnea.io.urdf`), so a program
may give joints by name instead of by position (format: ``docs/programs.md``, "Joints by name"):

* **waypoint tables** -- ``waypoints = [{shoulder_l = 0.3}, {shoulder_l = -0.2, elbow_l = 1.0}]``.
  A joint a waypoint does not name holds the previous waypoint's value; in the first waypoint
  it is at 0 (the robot's zero position, Pinocchio's neutral configuration), which must be
  within its position limits (else the error names the joint: name it). The limits
  (``velocity_limit``, ``acceleration_limit``, ``jerk_limit``) are one number for every joint
  or a table by name that names every joint the waypoints name (the joints that hold still
  need no limit). Such a path becomes rows only on a robot: :func:`named_rows`.
* **CSV headers** -- when any joint column's header is the name of one of the robot's joints,
  the columns are matched by name in any order (:func:`column_order`); every joint of the
  robot must then have its column, and every column must be a joint (an error names the file,
  the header's line and the name). A header naming no joint is read by position, as before.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ProgramFileError, StateError, quote, shorten
from mrnea.io.tomlcheck import TomlCheck, did_you_mean
from mrnea.model import Robot
from mrnea.trajectory import quintic, scurve, trapezoidal

__all__ = ["CsvHeader", "NamedPath", "column_order", "named_rows", "number_table",
           "read_named_path", "unknown_joint"]

PROFILES = {"trapezoidal": trapezoidal, "quintic": quintic, "scurve": scurve}
LIMITS = ("velocity_limit", "acceleration_limit", "jerk_limit")


def unknown_joint(name: str, robot: Robot) -> str:
    """``'x' is not a joint of robot 'R' (did you mean 'y'?); its joints: a, b, ...``"""
    joints = ", ".join(robot.joint_names)
    return (f"{quote(name)} is not a joint of robot {quote(shorten(robot.name))}"
            f"{did_you_mean(name, robot.joint_names)}; its joints: {shorten(joints, 300)}")


class CsvHeader(NamedTuple):
    """A path CSV's header row: its column names (time first), its file and its line."""

    names: tuple[str, ...]
    source: str
    line: int


#: A header cell ``name [unit]``: the joint's name and its unit in brackets.
_UNIT = re.compile(r"(.*?)\s*\[\s*([^\[\]]*?)\s*\]")


def column_order(header: CsvHeader, robot: Robot, units: str = "rad"
                 ) -> NDArray[np.int64] | None:
    """The CSV column of each of ``robot``'s joints when the header names them, else None.

    Parameters
    ----------
    header : the CSV's header row (:func:`mrnea.io.pathcsv.read_table`).
    robot : the robot the path is for.
    units : the file's units, ``"rad"`` (rad, m) or ``"deg"`` (deg, mm): a column's header
        ``name [unit]`` is the joint ``name``, and its unit, when given, must be that joint's.

    Returns
    -------
    (n,) int: joint i's positions are data column ``order[i]`` (time is column 0, so
    ``rows[:, order]`` is the path in the robot's joint order); None when no joint column's
    header is a joint name (the columns are then taken in order).

    Raises
    ------
    ProgramFileError
        A column that is not a joint, a joint named twice, a joint without a column, or a
        unit that is not the joint's; the message names the file, the line and the name.
    """
    cells = [_UNIT.fullmatch(cell) for cell in header.names[1:]]
    names = [m.group(1) if m else cell for m, cell in zip(cells, header.names[1:], strict=True)]
    index = {name: i for i, name in enumerate(robot.joint_names)}
    if not any(name in index for name in names):
        return None
    where = f"{header.source}: line {header.line} (header)"
    order = np.full(robot.n, -1, dtype=np.int64)
    for col, (name, m) in enumerate(zip(names, cells, strict=True), start=1):
        if name not in index:
            raise ProgramFileError(f"{where}: column {col + 1} {unknown_joint(name, robot)} (the "
                                   f"header names joints, so every column after time must)")
        joint = robot.joints[index[name]]
        unit = ("mm" if units == "deg" else "m") if joint.is_prismatic else units
        if m and m.group(2) != unit:
            raise ProgramFileError(f"{where}: column {col + 1} {quote(header.names[col])}: "
                                   f"joint {quote(name)} is read in {unit!r} here (units "
                                   f"{units!r}), not {quote(m.group(2))}")
        if order[index[name]] >= 0:
            raise ProgramFileError(f"{where}: joint {quote(name)} has two columns "
                                   f"({order[index[name]] + 1} and {col + 1})")
        order[index[name]] = col
    missing = [robot.joint_names[i] for i in np.flatnonzero(order < 0)]
    if missing:
        raise ProgramFileError(f"{where}: no column for joint {quote(missing[0])}"
                               f"{f' (and {len(missing) - 1} more)' if len(missing) > 1 else ''}"
                               f" of robot {quote(shorten(robot.name))}; a CSV naming its "
                               f"joints gives every joint's column")
    return order


@dataclass(frozen=True)
class NamedPath:
    """A ``[path]`` of waypoint tables, made into rows on a robot by :func:`named_rows`.

    Attributes
    ----------
    profile : ``trapezoidal``, ``quintic`` or ``scurve``.
    waypoints : one mapping a waypoint, joint name -> position [rad | m].
    limits : ``velocity_limit``, ``acceleration_limit`` (and ``jerk_limit``) each a number
        for every joint [rad/s^k | m/s^k], or a mapping joint name -> number.
    dwell : [s] at each waypoint: one number, or one per waypoint.
    source : the program file, for messages.
    """

    profile: str
    waypoints: tuple[Mapping[str, float], ...]
    limits: Mapping[str, float | Mapping[str, float]]
    dwell: float | tuple[float, ...]
    source: str


def number_table(check: TomlCheck, value: Any, where: str, key: str, scale: float,
                  allow_inf: bool = False) -> dict[str, float]:
    if not isinstance(value, dict) or not value:
        raise check.error(where, f"{key} must be a non-empty table of joint names and numbers, "
                                 f"e.g. {{shoulder = 0.3}}, got {quote(value)}")
    return {name: check.number(v, where, f"{key}.{name}", allow_inf=allow_inf) * scale
            for name, v in value.items()}


def read_named_path(check: TomlCheck, table: Mapping[str, Any], scale: float) -> NamedPath:
    """The ``[path]`` of a program whose ``waypoints`` are tables (module docstring);
    ``scale`` converts the file's units to rad (``units = "deg"``). Names are checked on the
    robot later (:func:`named_rows`)."""
    where = "[path]"
    profile = check.string(check.require(table, "profile", where), where, "profile")
    if profile not in PROFILES:
        raise check.error(where, f"unknown profile {quote(profile)}"
                                 f"{did_you_mean(profile, [*PROFILES])}"
                                 f"; expected one of {', '.join(map(repr, PROFILES))}")
    rows = table["waypoints"]
    if not all(isinstance(w, dict) for w in rows):
        raise check.error(where, "'waypoints' mixes tables and arrays: give every waypoint as "
                                 "a table of joint names ({shoulder = 0.3}) or every one as "
                                 "an array of all the joints")
    waypoints = tuple(number_table(check, w, where, f"waypoints[{k}]", scale)
                      for k, w in enumerate(rows))
    needed = ["velocity_limit", "acceleration_limit"] + (["jerk_limit"] if profile == "scurve"
                                                         else [])
    if "jerk_limit" in table and profile != "scurve":
        raise check.error(where, f"'jerk_limit' applies to profile = \"scurve\" only, not "
                                 f"{profile!r}")
    limits: dict[str, float | dict[str, float]] = {}
    for key in needed:
        v = check.require(table, key, where)
        if isinstance(v, list):
            raise check.error(where, f"'{key}' with waypoint tables is one number for every "
                                     f"joint or a table by joint name, not an array (the "
                                     f"array's order would be the robot's)")
        limits[key] = (number_table(check, v, where, key, scale, allow_inf=True)
                       if isinstance(v, dict) else
                       check.number(v, where, key, allow_inf=True) * scale)
        values = list(limits[key].values()) if isinstance(limits[key], dict) else [limits[key]]
        if not all(x > 0 for x in values):
            raise check.error(where, f"'{key}' must be > 0 for every joint (inf = unlimited), "
                                     f"got {quote(v)}")
    dwell: float | tuple[float, ...] = 0.0
    if "dwell" in table:
        d = table["dwell"]
        dwell = (tuple(check.vector(d, where, "dwell", len(waypoints)).tolist())
                 if isinstance(d, list) else check.number(d, where, "dwell"))
        if np.any(np.asarray(dwell) < 0):
            raise check.error(where, f"'dwell' must be >= 0 s, got {quote(d)}")
    return NamedPath(profile, waypoints, limits, dwell, check.source)


def named_rows(path: NamedPath, robot: Robot, dt: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(t, q)`` of a waypoint-table path on ``robot``: (K,) [s] and (K, n) [rad | m] in the
    robot's joint order (module docstring for the joints a waypoint does not name).

    Raises
    ------
    ProgramFileError
        A name that is not one of the robot's joints, a joint held at 0 outside its limits, a
        moving joint without a limit, or a path the profile cannot make; the message names the
        file, the waypoint or key and the joint.
    """
    index = {name: i for i, name in enumerate(robot.joint_names)}
    where = f"{path.source}: [path]"

    def check_names(table: Mapping[str, float], key: str) -> None:
        for name in table:
            if name not in index:
                raise ProgramFileError(f"{where}: {key}: {unknown_joint(name, robot)}")

    w = np.zeros((len(path.waypoints), robot.n))
    for k, table in enumerate(path.waypoints):
        check_names(table, f"waypoints[{k}]")
        if k:
            w[k] = w[k - 1]
        for name, v in table.items():
            w[k, index[name]] = v
    first = path.waypoints[0]
    for i, name in enumerate(robot.joint_names):
        if name not in first and not robot.lower[i] <= 0.0 <= robot.upper[i]:
            raise ProgramFileError(
                f"{where}: waypoints[0] does not name joint {quote(name)}, which then starts "
                f"at 0, outside its limits [{robot.lower[i]:g}, {robot.upper[i]:g}]; name it")
    named = {name for table in path.waypoints for name in table}
    kw = {}
    for key, value in path.limits.items():
        if isinstance(value, float):
            kw[key] = np.full(robot.n, value)
            continue
        check_names(value, key)
        missing = sorted(named - set(value), key=index.__getitem__)
        if missing:
            raise ProgramFileError(f"{where}: {key} does not name joint {quote(missing[0])}, "
                                   f"which the waypoints move; give its limit (or one number "
                                   f"for every joint)")
        kw[key] = np.array([value.get(name, np.inf) for name in robot.joint_names])
    vmax, amax = kw.pop("velocity_limit"), kw.pop("acceleration_limit")
    dwell = path.dwell if isinstance(path.dwell, float) else np.array(path.dwell)
    try:
        return PROFILES[path.profile](w, dt, vmax, amax, dwell=dwell, **kw)
    except StateError as exc:
        raise ProgramFileError(f"{where}: {exc} (joints in the robot's order: "
                               f"{shorten(', '.join(robot.joint_names), 200)})") from None
