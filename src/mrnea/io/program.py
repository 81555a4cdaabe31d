"""Program files: a robot, a cycle time, a path and an optional external wrench, in TOML.

:func:`load_program` reads one into a :class:`~mrnea.io.program_value.Program` (format and
examples: ``docs/programs.md``).
A waypoint path is made by the profiles of :mod:`mrnea.trajectory` (pure NumPy, below ``io``), a
CSV path by :mod:`mrnea.io.pathcsv`; the robot is a built-in name or a robot file
(:func:`mrnea.io.dispatch.resolve_robot`). Every problem raises
:class:`mrnea.errors.ProgramFileError` naming the file and the table and key at fault.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import MrneaError, ProgramFileError, StateError, quote
from mrnea.io.dispatch import BUILTIN_ROBOTS, RobotOptions, resolve_robot
from mrnea.io.jointnames import PROFILES, CsvHeader, read_named_path
from mrnea.io.moves import MOVE_KEYS, read_moves
from mrnea.io.pathcsv import INTERPOLATIONS, read_table, resample
from mrnea.io.payload import parse_payload
from mrnea.io.program_value import Program
from mrnea.io.source import as_path, expand_home, read_text
from mrnea.io.tomlcheck import TomlCheck, did_you_mean
from mrnea.io.wrench import WRENCH_KEYS, LinkWrenches, read_wrenches, wrench_at
from mrnea.io.writer import create

__all__ = ["Program", "dumps_program", "is_program_file", "load_program", "loads_program",
           "save_program"]

#: The values of ``[program] mode`` and ``[path] units`` (``[path] profile``: ``PROFILES``).
MODES = ("hybrid", "paper")
UNITS = ("rad", "deg")


_TOP_KEYS = ("program", "path", "wrench", "move")
_PROGRAM_KEYS = ("name", "robot", "dt", "mode", "actuators", "tip", "payload", "gravity", "tool",
                 "q0")
_MOVE_KEYS = ("tool", "q0")  # [program] keys of a Cartesian program only
_CSV_KEYS = ("csv", "units", "interpolation")
_PATH_KEYS = ("profile", "waypoints", "velocity_limit", "acceleration_limit", "jerk_limit",
              "dwell", "csv", "units", "interpolation")


def _robot(check: TomlCheck, value: str, base_dir: Path) -> str:
    source = resolve_robot(value, base_dir)
    if source not in BUILTIN_ROBOTS and not os.path.isfile(source):
        raise check.error("[program]", f"robot {quote(value)} is neither a built-in robot "
                                       f"({', '.join(BUILTIN_ROBOTS)}) nor an existing robot "
                                       f"file (looked for {quote(source)})")
    return source


def _options(check: TomlCheck, prog: Mapping[str, Any], base_dir: Path) -> RobotOptions:
    """The robot options a [program] table sets (paths relative to ``base_dir``)."""
    where, kw = "[program]", {}
    if "actuators" in prog:
        p = expand_home(Path(check.string(prog["actuators"], where, "actuators")),
                        lambda m: check.error(where, f"'actuators': {m}"))
        kw["actuators"] = str(p if p.is_absolute() else base_dir / p)
    if "tip" in prog:  # one link, or several (a URDF tree's subtree holding them)
        tip = prog["tip"]
        kw["tip"] = (tuple(check.string(t, where, "tip") for t in tip)
                     if isinstance(tip, list) and tip else check.string(tip, where, "tip"))
    if "payload" in prog:  # one, or a list: several, each on its own link
        given = prog["payload"]
        specs = [check.string(s, where, "payload")  # its own error names the file once
                 for s in (given if isinstance(given, list) and given else [given])]
        try:
            kw["payload"] = tuple(parse_payload(s, base_dir, ProgramFileError) for s in specs)
        except MrneaError as exc:
            raise check.error(where, str(exc)) from None
    if "gravity" in prog:
        kw["gravity"] = tuple(check.vector(prog["gravity"], where, "gravity", 3).tolist())
    return RobotOptions(**kw)


def _limit(check: TomlCheck, value: Any, where: str, key: str, n: int) -> NDArray[np.float64]:
    """A per-joint limit: a number or n numbers, each > 0 (inf = unlimited)."""
    if isinstance(value, list):
        a = check.vector(value, where, key, n, allow_inf=True)
    else:
        a = np.full(n, check.number(value, where, key, allow_inf=True))
    if not (a > 0).all():
        raise check.error(where, f"'{key}' must be > 0 for every joint (inf = unlimited), "
                                 f"got {a.tolist()}")
    return a


def _path(check: TomlCheck, table: Mapping[str, Any], dt: float, base_dir: Path
          ) -> tuple[NDArray, NDArray, str | None, NDArray | None, CsvHeader | None]:
    """(t, q_cmd, interpolation, CSV rows, CSV header) of the [path] table (the last three
    None for waypoints)."""
    where = "[path]"
    check.check_keys(table, _PATH_KEYS, where)
    units = table.get("units", "rad")
    if units not in UNITS:
        raise check.error(where, f"'units' must be one of {', '.join(map(repr, UNITS))}, got "
                                 f"{quote(units)}")
    scale = math.pi / 180.0 if units == "deg" else 1.0
    if "csv" in table:
        for key in table:
            if key not in _CSV_KEYS:
                raise check.error(where, f"key {quote(key)} cannot be used with 'csv' (a CSV path "
                                         "gives its own positions and times; allowed with csv: "
                                         f"{', '.join(_CSV_KEYS)})")
        p = expand_home(Path(check.string(table["csv"], where, "csv")),
                        lambda m: check.error(where, f"'csv': {m}"))
        if "\0" in str(p):  # a TOML "\u0000": name the program file, not only the path
            raise check.error(where, f"'csv' cannot hold a NUL character, got {quote(str(p))}")
        if not p.is_absolute():
            p = base_dir / p
        interpolation = table.get("interpolation", "cubic")
        if not isinstance(interpolation, str) or interpolation not in INTERPOLATIONS:
            raise check.error(where, f"'interpolation' must be one of "
                                     f"{', '.join(map(repr, INTERPOLATIONS))}, got "
                                     f"{interpolation!r}")
        header, data = read_table(p, None)
        data[:, 1:] *= scale
        try:
            return (*resample(data[:, 0], data[:, 1:], dt, interpolation, str(p)),
                    interpolation, data, header)
        except StateError as exc:  # too many cycles for dt
            raise check.error(where, f"{quote(str(p))}: {exc}") from None
    if "interpolation" in table:
        raise check.error(where, "'interpolation' applies to a 'csv' path only (waypoints are "
                                 "joined by the profile)")
    if "waypoints" not in table and "profile" not in table:
        raise check.error(where, "give either 'csv' (a path CSV file) or 'profile' and "
                                 "'waypoints' (with velocity_limit and acceleration_limit)")
    profile = check.string(check.require(table, "profile", where), where, "profile")
    if profile not in PROFILES:
        raise check.error(where, f"unknown profile {quote(profile)}"
                                 f"{did_you_mean(profile, [*PROFILES])}"
                                 f"; expected one of {', '.join(map(repr, PROFILES))}")
    w = check.matrix(check.require(table, "waypoints", where), where, "waypoints") * scale
    n = w.shape[1]
    vmax = _limit(check, check.require(table, "velocity_limit", where), where, "velocity_limit",
                  n) * scale
    amax = _limit(check, check.require(table, "acceleration_limit", where), where,
                  "acceleration_limit", n) * scale
    dwell: float | NDArray = 0.0
    if "dwell" in table:
        d = table["dwell"]
        dwell = (check.vector(d, where, "dwell", w.shape[0]) if isinstance(d, list)
                 else check.number(d, where, "dwell"))
        if np.any(np.asarray(dwell) < 0):
            raise check.error(where, f"'dwell' must be >= 0 s, got {np.asarray(dwell).tolist()}")
    jerk = {}
    if profile == "scurve":
        jerk["jerk_limit"] = _limit(check, check.require(table, "jerk_limit", where), where,
                                    "jerk_limit", n) * scale
    elif "jerk_limit" in table:
        raise check.error(where, f"'jerk_limit' applies to profile = \"scurve\" only, not "
                                 f"{profile!r}")
    try:
        return (*PROFILES[profile](w, dt, vmax, amax, dwell=dwell, **jerk), None, None, None)
    except StateError as exc:
        raise check.error(where, str(exc)) from None


def loads_program(text: str, source: str = "<string>", base_dir: str | Path | None = None
                  ) -> Program:
    """Parse a program from a TOML string (format: ``docs/programs.md``).

    Parameters
    ----------
    text : the TOML document.
    source : a name for it in error messages (the file name).
    base_dir : folder against which relative robot and CSV paths resolve; None: the current
        folder.

    Returns
    -------
    Program

    Raises
    ------
    ProgramFileError
        TOML syntax (with line and column), unknown keys (with a suggestion), missing keys,
        wrong types and values; the message names ``source`` and the table and key at fault.
    """
    check = TomlCheck(source, ProgramFileError)
    base = Path.cwd() if base_dir is None else as_path(base_dir, "base_dir", ProgramFileError)
    doc = check.parse(text)
    if "program" not in doc and ("joint" in doc or "robot" in doc):
        raise check.error("", "a robot file (it has no [program] table), not a program")
    check.check_keys(doc, _TOP_KEYS, "top level")
    prog = check.table(check.require(doc, "program", "top level"), "top level", "program")
    check.check_keys(prog, _PROGRAM_KEYS, "[program]")
    default_name = Path(source).stem if source != "<string>" else "program"
    name = check.string(prog.get("name", default_name), "[program]", "name")
    robot = (_robot(check, check.string(prog["robot"], "[program]", "robot"), base)
             if "robot" in prog else None)
    options = _options(check, prog, base)
    dt = check.number(check.require(prog, "dt", "[program]"), "[program]", "dt")
    if not dt > 0:
        raise check.error("[program]", f"'dt' must be a time step > 0 s, got {dt}")
    mode = prog.get("mode")
    if mode is not None and mode not in MODES:
        raise check.error("[program]", f"'mode' must be one of {', '.join(map(repr, MODES))}, "
                                       f"got {quote(mode)}")
    if "move" in doc:
        if "path" in doc:
            raise check.error("", "a program of [[move]] tables cannot have a [path] table (its "
                                  "path is its moves)")
        moves = read_moves(check, prog, doc["move"], dt, base)
        wrench = point = None
        if "wrench" in doc:
            wrench, point = read_wrenches(check, doc["wrench"], robot)
        return Program(robot=robot, dt=dt, t=None, q_cmd=None, f_ext=None, f_ext_point=point,
                       mode=mode, name=name, source=source, options=options, moves=moves,
                       wrench=wrench)
    for key in _MOVE_KEYS:
        if key in prog:
            raise check.error("[program]", f"'{key}' belongs to a program of [[move]] tables "
                                           f"(Cartesian moves), not to a [path]")
    path = check.table(check.require(doc, "path", "top level"), "top level", "path")
    waypoints = path.get("waypoints")
    if isinstance(waypoints, list) and waypoints and isinstance(waypoints[0], dict):
        return _named(check, doc, path, dict(robot=robot, dt=dt, mode=mode, name=name,
                                             source=source, options=options))
    t, q, interpolation, rows, header = _path(check, path, dt, base)
    if q.shape[0] < 2:
        raise check.error("[path]", "the program is a single cycle (all waypoints equal and no "
                                    "dwell); give at least two distinct waypoints or a dwell")
    f_ext = point = wrench = None
    if "wrench" in doc:
        wrench, point = read_wrenches(check, doc["wrench"], robot)
        if not isinstance(wrench, LinkWrenches):  # on named links: made on the robot (on())
            f_ext, wrench = wrench_at(*wrench, t), None
    for a in (t, q, f_ext, point, rows):
        if a is not None:
            a.setflags(write=False)
    return Program(robot=robot, dt=dt, t=t, q_cmd=q, f_ext=f_ext, f_ext_point=point, wrench=wrench,
                   mode=mode, name=name, source=source, options=options,
                   csv=path["csv"] if "csv" in path else None, interpolation=interpolation,
                   csv_rows=rows, columns=header, units=path.get("units", "rad"),
                   _mm_pending=path.get("units") == "deg")


def _named(check: TomlCheck, doc: Mapping[str, Any], path: Mapping[str, Any],
           fields: dict[str, Any]) -> Program:
    """A program whose waypoints are tables by joint name: its rows are made on a robot
    (:meth:`Program.on`)."""
    check.check_keys(path, _PATH_KEYS, "[path]")
    for key in ("csv", "interpolation"):
        if key in path:
            raise check.error("[path]", f"{quote(key)} cannot be used with 'waypoints'")
    units = path.get("units", "rad")
    if units not in UNITS:
        raise check.error("[path]", f"'units' must be one of {', '.join(map(repr, UNITS))}, "
                                    f"got {quote(units)}")
    named = read_named_path(check, path, math.pi / 180.0 if units == "deg" else 1.0)
    wrench = point = None
    if "wrench" in doc:
        wrench, point = read_wrenches(check, doc["wrench"], fields["robot"])
    return Program(t=None, q_cmd=None, f_ext=None, f_ext_point=point, named=named,
                   wrench=wrench, units=units,
                   _mm_pending=units == "deg", **fields)


def load_program(path: str | Path) -> Program:
    """Load a program file (TOML, format in ``docs/programs.md``).

    Parameters
    ----------
    path : the ``.toml`` program file. Relative robot and CSV paths in it resolve against its
        folder.

    Returns
    -------
    Program
        robot, dt [s], t (K,) [s], q_cmd (K, n) [rad | m], f_ext (K, 6) [N, N m] or None,
        f_ext_point (3,) [m] or None, mode, name, options (the robot's actuators, tip,
        payload, gravity).

    Raises
    ------
    ProgramFileError
        Missing or unreadable file, TOML syntax error (line and column), unknown key (with a
        did-you-mean suggestion), missing key, bad value; or an error in the path CSV it names.
    """
    p = as_path(path, "path", ProgramFileError)
    return loads_program(read_text(p, "program file", ProgramFileError), source=str(p),
                         base_dir=p.parent)


def _toml_value(v: Any) -> str:
    """A TOML value: a string, a bool, a number (shortest repr: it reads back bit for bit), a
    (nested) list of them or an inline table."""
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string: JSON's escapes are TOML's
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        return repr(x) if math.isfinite(x) else ("nan" if x != x else "inf" if x > 0 else "-inf")
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, Mapping):  # an inline table (a tool's xyz and rpy)
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(x)}"
                               for k, x in v.items()) + "}"
    raise TypeError(f"cannot write {type(v).__name__} to a program file")


def dumps_program(program: Mapping[str, Any], path: Mapping[str, Any] | None,
                  wrench: Mapping[str, Any] | Sequence[Mapping[str, Any]] | None = None,
                  comment: str = "",
                  moves: Sequence[Mapping[str, Any]] = ()) -> str:
    """The text of a program file (the format :func:`loads_program` reads) from the keys of its
    ``[program]``, ``[path]`` (None for a Cartesian program) and optional ``[wrench]`` table (a
    list of them: ``[[wrench]]`` tables, each naming its ``link``), and a Cartesian program's
    ``[[move]]`` tables (``moves``, each with its ``type``); ``comment``: lines put first as
    TOML comments. Numbers are written as their shortest repr, so they read back bit for bit.
    A list of rows (the wrench's values) gets one row per line. A key the table does not know
    is a StateError (the file would not load)."""
    lines = [f"# {c}" if c else "#" for c in comment.splitlines()]
    allowed = {"program": _PROGRAM_KEYS, "path": _PATH_KEYS, "wrench": WRENCH_KEYS,
               "[wrench]": WRENCH_KEYS}
    wrenches = ([("[wrench]", w) for w in wrench] if isinstance(wrench, Sequence)
                else [("wrench", wrench)])
    tables = [("program", program), ("path", path), *wrenches,
              *(("[move]", m) for m in moves)]
    for table, keys in tables:
        if keys is None:
            continue
        if table == "[move]":
            allowed[table] = MOVE_KEYS.get(keys.get("type"), ("type",))
        unknown = [k for k in keys if k not in allowed[table]]
        if unknown:
            raise StateError(f"{table}: unknown key {quote(unknown[0])} for a program file's "
                             f"[{table}]; allowed keys: {', '.join(allowed[table])}")
        lines += ["" if lines else None, f"[{table}]"]
        for k, v in keys.items():
            rows = np.asarray(v).tolist() if isinstance(v, np.ndarray) else v
            if isinstance(rows, list) and rows and isinstance(rows[0], list):
                lines += [f"{k} = ["] + [f"    {_toml_value(r)}," for r in rows] + ["]"]
            else:
                lines.append(f"{k} = {_toml_value(v)}")
    return "\n".join(x for x in lines if x is not None) + "\n"


def save_program(path: str | os.PathLike[str], program: Mapping[str, Any],
                 path_table: Mapping[str, Any] | None,
                 wrench: Mapping[str, Any] | Sequence[Mapping[str, Any]] | None = None,
                 comment: str = "", overwrite: bool = False,
                 moves: Sequence[Mapping[str, Any]] = ()) -> Path:
    """Write :func:`dumps_program`'s text to ``path`` through :func:`mrnea.io.writer.create`
    (whole or not at all, never through a link, an existing file replaced only with
    ``overwrite``)."""
    with create(path, overwrite) as fh:
        fh.write(dumps_program(program, path_table, wrench, comment, moves))
    return Path(path)


def is_program_file(path: str | Path) -> bool:
    """Whether ``path`` is a program file: a ``.toml`` file with a ``[program]`` table (a
    ``.toml`` file without one is a robot file). An unreadable or malformed file is neither:
    its reader says what is wrong."""
    if not isinstance(path, (str, os.PathLike)) or Path(path).suffix.lower() != ".toml":
        return False
    try:
        return "program" in parse_toml(path)
    except MrneaError:
        return False


def parse_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A ``.toml`` file read and parsed as every reader does (a regular file of bounded size,
    bounded depth); a ProgramFileError names the file and, for a syntax error, its line."""
    return TomlCheck(str(path), ProgramFileError).parse(
        read_text(path, "program file", ProgramFileError))
