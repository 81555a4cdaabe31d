"""mrnea's native robot format: a human-editable TOML file (read with the standard ``tomllib``).

The full description, with a complete example, is in ``docs/robot-format.md``. In short::

    [robot]
    name = "two_link"
    gravity = [0.0, 0.0, -9.81]     # m/s^2, base frame (optional, this default)
    # dh = "standard"               # or "modified": joints give a, alpha, d, theta instead
    # base = "base"                 # name of the fixed base link (optional)

    [[joint]]                       # one table per joint, root to tip
    name = "shoulder"
    type = "revolute"               # revolute | continuous | prismatic
    origin = { xyz = [0.0, 0.0, 0.5], rpy = [0.0, 0.0, 0.0] }   # parent link -> joint frame
    axis = [0.0, 0.0, 1.0]          # joint frame
    lower = -3.0                    # rad or m (optional; inf/-inf = none)
    effort_limit = 50.0             # N m or N, joint side (optional)
    # torque_speed = [50.0, 2.0, 6.0]   # or a torque-speed curve: peak, corner and no-load speed

    [joint.link]                    # the link this joint moves
    name = "upper_arm"
    mass = 2.0                      # kg
    com = [0.2, 0.0, 0.0]           # m, link frame
    inertia = { ixx = 0.01, iyy = 0.03, izz = 0.03 }   # kg m^2 about the com (or a 3x3 list)

Every problem is reported as :class:`mrnea.errors.RobotFileError` (a :class:`ModelError`) whose
message names the file and the joint or link at fault: TOML syntax errors (with line and column),
unknown keys (typos), missing required keys, wrong types and shapes, unphysical values.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from mrnea.errors import ModelError, RobotFileError
from mrnea.io.dh import CONVENTIONS, DHRow, dh_joint_chain
from mrnea.model import DEFAULT_GRAVITY, JOINT_TYPES, Joint, Link, Robot, transform

__all__ = ["apply_actuator_file", "load_native", "loads_native"]

_TOP_KEYS = ("robot", "joint")
_ROBOT_KEYS = ("name", "gravity", "dh", "base")
_LIMIT_KEYS = ("lower", "upper", "velocity_limit", "effort_limit")
_ACTUATOR_KEYS = ("gear_ratio", "rotor_inertia", "viscous_friction", "coulomb_friction",
                  "torque_speed")
_COMMON_JOINT_KEYS = ("name", "type", "link", *_LIMIT_KEYS, *_ACTUATOR_KEYS)
_ORIGIN_JOINT_KEYS = ("origin", "axis")
_DH_JOINT_KEYS = ("a", "alpha", "d", "theta")
_ORIGIN_KEYS = ("xyz", "rpy")
_LINK_KEYS = ("name", "mass", "com", "inertia")
_INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")


class _Context:
    """Formats error messages: ``<file>: <where>: <what>``."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, where: str, what: str) -> RobotFileError:
        return RobotFileError(f"{self.source}: {where}: {what}" if where else
                              f"{self.source}: {what}")


def _type_name(value: object) -> str:
    return {dict: "table", list: "array", str: "string", bool: "boolean"}.get(
        type(value), type(value).__name__)


def _check_keys(ctx: _Context, table: Mapping[str, Any], allowed: tuple[str, ...], where: str,
                hint: str = "") -> None:
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1)
            suggestion = f" (did you mean '{close[0]}'?)" if close else ""
            raise ctx.error(where, f"unknown key '{key}'{suggestion}{hint}; "
                                   f"allowed keys: {', '.join(allowed)}")


def _require(ctx: _Context, table: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in table:
        raise ctx.error(where, f"missing required key '{key}'")
    return table[key]


def _number(ctx: _Context, value: Any, where: str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ctx.error(where, f"'{key}' must be a number, got {_type_name(value)} {value!r}")
    return float(value)


def _vector(ctx: _Context, value: Any, n: int, where: str, key: str) -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        got = f"{len(value)} entries" if isinstance(value, list) else _type_name(value)
        raise ctx.error(where, f"'{key}' must be an array of {n} numbers, got {got}: {value!r}")
    return [_number(ctx, v, where, f"{key}[{k}]") for k, v in enumerate(value)]


def _string(ctx: _Context, value: Any, where: str, key: str) -> str:
    if not isinstance(value, str) or not value:
        raise ctx.error(where, f"'{key}' must be a non-empty string, got {value!r}")
    return value


def _table(ctx: _Context, value: Any, where: str, key: str) -> Mapping[str, Any]:
    if not isinstance(value, dict):
        raise ctx.error(where, f"'{key}' must be a table, got {_type_name(value)} {value!r}")
    return value


def _inertia(ctx: _Context, value: Any, where: str) -> np.ndarray:
    """A 3x3 list of lists or a table {ixx, iyy, izz[, ixy, ixz, iyz]} -> (3, 3) array."""
    if isinstance(value, dict):
        _check_keys(ctx, value, _INERTIA_KEYS, f"{where}: inertia")
        for key in ("ixx", "iyy", "izz"):
            _require(ctx, value, key, f"{where}: inertia")
        v = {k: _number(ctx, value.get(k, 0.0), f"{where}: inertia", k) for k in _INERTIA_KEYS}
        return np.array([[v["ixx"], v["ixy"], v["ixz"]],
                         [v["ixy"], v["iyy"], v["iyz"]],
                         [v["ixz"], v["iyz"], v["izz"]]])
    if isinstance(value, list) and len(value) == 3 and all(
            isinstance(r, list) for r in value):
        return np.array([_vector(ctx, r, 3, where, f"inertia[{k}]")
                         for k, r in enumerate(value)])
    raise ctx.error(where, "'inertia' must be a 3x3 array of numbers or a table "
                           f"{{ixx, iyy, izz, ixy, ixz, iyz}}, got {value!r}")


def _link(ctx: _Context, joint: Mapping[str, Any], jname: str, index: int) -> dict[str, Any]:
    where = f"joint '{jname}'"
    table = _table(ctx, _require(ctx, joint, "link", where), where, "link")
    lname = table.get("name", f"link{index}")
    lname = _string(ctx, lname, f"{where}: link", "name")
    lwhere = f"joint '{jname}': link '{lname}'"
    _check_keys(ctx, table, _LINK_KEYS, lwhere)
    mass = _number(ctx, _require(ctx, table, "mass", lwhere), lwhere, "mass")
    com = _vector(ctx, table.get("com", [0.0, 0.0, 0.0]), 3, lwhere, "com")
    inertia = (_inertia(ctx, table["inertia"], lwhere) if "inertia" in table
               else np.zeros((3, 3)))
    return {"link_name": lname, "mass": mass, "com": com, "inertia": inertia}


def _joint_fields(ctx: _Context, joint: Mapping[str, Any], where: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key in (*_LIMIT_KEYS, *_ACTUATOR_KEYS):
        if key not in joint:
            continue
        if key == "torque_speed":
            out[key] = tuple(_vector(ctx, joint[key], 3, where, key))
            continue
        out[key] = _number(ctx, joint[key], where, key)
        if math.isnan(out[key]):
            raise ctx.error(where, f"'{key}' is NaN")
    if "torque_speed" in out and "effort_limit" in out \
            and out["effort_limit"] != out["torque_speed"][0]:
        raise ctx.error(where, "give either 'effort_limit' or 'torque_speed' (whose peak is the "
                               f"effort limit), not both: {out['effort_limit']} != "
                               f"{out['torque_speed'][0]}")
    return out


def _parse_joints(ctx: _Context, entries: list[Any], dh: str | None, base: str
                  ) -> tuple[list[Joint], list[Link]]:
    allowed = _COMMON_JOINT_KEYS + (_DH_JOINT_KEYS if dh else _ORIGIN_JOINT_KEYS)
    hint_other = (" ('origin'/'axis' are not used when [robot] dh is set)" if dh else
                  " (DH parameters need dh = \"standard\" or \"modified\" in [robot])")
    rows: list[DHRow] = []
    joints: list[Joint] = []
    links: list[Link] = []
    parent = base
    for i, entry in enumerate(entries, start=1):
        if not isinstance(entry, dict):
            raise ctx.error(f"joint #{i}", f"expected a table, got {entry!r}")
        raw_name = entry.get("name")
        jname = raw_name if isinstance(raw_name, str) and raw_name else f"#{i}"
        where = f"joint '{jname}'" if jname != f"#{i}" else f"joint #{i}"
        for key in entry:
            if key not in allowed and key in (_DH_JOINT_KEYS + _ORIGIN_JOINT_KEYS):
                raise ctx.error(where, f"key '{key}' not allowed here{hint_other}")
        _check_keys(ctx, entry, allowed, where)
        jname = _string(ctx, _require(ctx, entry, "name", where), where, "name")
        jtype = _string(ctx, _require(ctx, entry, "type", where), where, "type")
        if jtype not in JOINT_TYPES:
            raise ctx.error(where, f"unsupported joint type '{jtype}' "
                                   f"(supported: {', '.join(JOINT_TYPES)})")
        link = _link(ctx, entry, jname, i)
        fields = _joint_fields(ctx, entry, where)
        if dh:
            params = {k: _number(ctx, _require(ctx, entry, k, where), where, k)
                      for k in ("a", "alpha", "d")}
            params["theta"] = _number(ctx, entry.get("theta", 0.0), where, "theta")
            rows.append(DHRow(type=jtype, name=jname, **params, **link, **fields))
            continue
        origin = _table(ctx, entry.get("origin", {}), where, "origin")
        _check_keys(ctx, origin, _ORIGIN_KEYS, f"{where}: origin")
        xyz = _vector(ctx, origin.get("xyz", [0.0, 0.0, 0.0]), 3, f"{where}: origin", "xyz")
        rpy = _vector(ctx, origin.get("rpy", [0.0, 0.0, 0.0]), 3, f"{where}: origin", "rpy")
        axis = _vector(ctx, _require(ctx, entry, "axis", where), 3, where, "axis")
        lname = link.pop("link_name")
        try:
            links.append(Link(lname, **link))
            joints.append(Joint(jname, jtype, parent, lname, origin=transform(xyz, rpy),
                                axis=axis, **fields))
        except ModelError as exc:
            raise ctx.error(where, str(exc)) from None
        parent = lname
    if dh:
        try:
            return dh_joint_chain(rows, dh, base=base)
        except ModelError as exc:
            raise ctx.error("", str(exc)) from None
    return joints, links


def loads_native(text: str, source: str = "<string>") -> Robot:
    """Parse a native TOML robot description from a string.

    Parameters
    ----------
    text : the TOML document (format in ``docs/robot-format.md``).
    source : a name for the document used in error messages (e.g. the file name).

    Returns
    -------
    Robot
        The validated robot (joint frames, inertials and units as in :mod:`mrnea.model`).

    Raises
    ------
    RobotFileError
        On any syntax, structure or value error; the message names ``source`` and the joint or
        link at fault.
    """
    ctx = _Context(source)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ctx.error("", f"invalid TOML: {exc}") from None
    _check_keys(ctx, doc, _TOP_KEYS, "top level")
    robot = _table(ctx, doc.get("robot", {}), "top level", "robot")
    _check_keys(ctx, robot, _ROBOT_KEYS, "[robot]")
    default_name = Path(source).stem if source != "<string>" else ""
    name = _string(ctx, robot.get("name", default_name or "robot"), "[robot]", "name")
    gravity = _vector(ctx, robot.get("gravity", list(DEFAULT_GRAVITY)), 3, "[robot]", "gravity")
    base = _string(ctx, robot.get("base", "base"), "[robot]", "base")
    dh = robot.get("dh")
    if dh is not None and dh not in CONVENTIONS:
        raise ctx.error("[robot]", f"'dh' must be one of {', '.join(map(repr, CONVENTIONS))}, "
                                   f"got {dh!r}")
    entries = doc.get("joint")
    if entries is None:
        raise ctx.error("", "no [[joint]] tables: a robot needs at least one joint")
    if not isinstance(entries, list):
        raise ctx.error("", "'joint' must be an array of tables: write [[joint]], not [joint]")
    joints, links = _parse_joints(ctx, entries, dh, base)
    try:
        return Robot(joints, links, gravity=gravity, name=name, base=base)
    except ModelError as exc:
        raise ctx.error("", str(exc)) from None


def load_native(path: str | Path, actuators: str | Path | None = None) -> Robot:
    """Load a robot from a native TOML file.

    Parameters
    ----------
    path : path of the ``.toml`` file (format in ``docs/robot-format.md``).

    Returns
    -------
    Robot
        The validated robot. Lengths in m, angles in rad, masses in kg, inertias in kg m^2
        (about the centre of mass), efforts in N m or N (joint side).

    Raises
    ------
    RobotFileError
        If the file cannot be read or is malformed; the message names the file and the joint or
        link at fault (TOML syntax errors give line and column).
    """
    robot = loads_native(_read(path, "robot file"), source=str(path))
    return robot if actuators is None else apply_actuator_file(robot, actuators)


def _read(path: str | Path, what: str) -> str:
    p = Path(path)
    try:
        return p.read_text(encoding="utf-8-sig")  # a byte-order mark is not an error
    except (OSError, UnicodeDecodeError) as exc:
        raise RobotFileError(f"{p}: cannot read {what}: {exc}") from None


_SIDECAR_KEYS = (*_LIMIT_KEYS, *_ACTUATOR_KEYS)


def apply_actuator_file(robot: Robot, path: str | Path) -> Robot:
    """A copy of ``robot`` with the joint fields a sidecar actuator file sets.

    The sidecar says what URDF cannot (rotor inertia, a torque-speed curve) or overrides what it
    says. One TOML table per joint, named like the joint; keys (joint side, SI units)
    ``gear_ratio``, ``rotor_inertia`` [kg m^2, motor side], ``viscous_friction``,
    ``coulomb_friction``, ``effort_limit``, ``torque_speed = [peak, corner_speed,
    no_load_speed]``, ``velocity_limit``, ``lower``, ``upper``::

        [shoulder_pan_joint]
        rotor_inertia = 3.3e-5
        gear_ratio = 101
        torque_speed = [150.0, 2.0, 3.5]

    Joints the file does not name keep their values. ``effort_limit`` sets a constant limit and
    removes a curve; giving both for one joint is an error unless they agree.
    """
    source = str(path)
    ctx = _Context(source)
    try:
        data = tomllib.loads(_read(path, "actuator file"))
    except tomllib.TOMLDecodeError as exc:
        raise ctx.error("", f"invalid TOML: {exc}") from None
    names = robot.joint_names
    joints = list(robot.joints)
    for jname, table in data.items():
        if jname not in names:
            close = difflib.get_close_matches(jname, names, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise ctx.error("", f"no joint named '{jname}' in robot '{robot.name}'{hint}; "
                                f"its joints: {', '.join(names)}")
        where = f"joint '{jname}'"
        table = _table(ctx, table, "", jname)
        _check_keys(ctx, table, _SIDECAR_KEYS, where)
        fields: dict[str, Any] = {}
        for key, value in table.items():
            if key == "torque_speed":
                fields[key] = tuple(_vector(ctx, value, 3, where, key))
            else:
                fields[key] = _number(ctx, value, where, key)
        if "effort_limit" in fields and "torque_speed" not in fields:
            fields["torque_speed"] = None
        elif "effort_limit" in fields and fields["effort_limit"] != fields["torque_speed"][0]:
            raise ctx.error(where, "'effort_limit' and the peak of 'torque_speed' differ; "
                                   "give one of them")
        i = names.index(jname)
        try:
            joints[i] = dataclasses.replace(joints[i], **fields)
        except ModelError as exc:
            raise ctx.error("", str(exc)) from None
    return robot._replace(joints=joints)
