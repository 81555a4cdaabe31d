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
    visual = [                      # what it looks like (optional; the report's 3D view)
        { box = [0.5, 0.08, 0.08], xyz = [0.25, 0.0, 0.0], color = [0.36, 0.5, 0.65] },
        { cylinder = [0.06, 0.12], rpy = [1.5707963267948966, 0.0, 0.0] },
    ]

Every problem is reported as :class:`mrnea.errors.RobotFileError` (a :class:`ModelError`) whose
message names the file and the joint or link at fault: TOML syntax errors (with line and column),
unknown keys (typos), missing required keys, wrong types and shapes, unphysical values.

:func:`write_native` (behind :meth:`mrnea.Robot.to_toml`) writes a Robot in this format with
every field, the actuator's included, each number in its shortest exact decimal form
(``repr``): :func:`load_native` reads it back equal to the Robot, bit for bit.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ModelError, RobotFileError, quote
from mrnea.io.dh import CONVENTIONS, JOINT_FIELDS, DHRow, dh_joint_chain, dh_tip_transform
from mrnea.io.mesh import mesh_path
from mrnea.io.sidecar import apply_actuator_file, joint_fields
from mrnea.io.source import as_path, read_text
from mrnea.io.tomlcheck import TomlCheck
from mrnea.io.writer import write_file
from mrnea.model import DEFAULT_GRAVITY, JOINT_TYPES, Frame, Joint, Link, Robot
from mrnea.rigid import rotation_from_rpy, rpy_from_rotation, transform
from mrnea.visual import VISUAL_KINDS, Visual

__all__ = ["dumps_native", "load_native", "loads_native", "native_flange", "write_native"]

_TOP_KEYS = ("robot", "joint")
_ROBOT_KEYS = ("name", "gravity", "dh", "base", "base_visual")
_COMMON_JOINT_KEYS = ("name", "type", "link", *JOINT_FIELDS)
_ORIGIN_JOINT_KEYS = ("origin", "axis", "parent")
_DH_JOINT_KEYS = ("a", "alpha", "d", "theta")
_ORIGIN_KEYS = ("xyz", "rpy", "rotation")
_LINK_KEYS = ("name", "mass", "com", "inertia", "visual", "frame")
_FRAME_KEYS = ("name", *_ORIGIN_KEYS)
_VISUAL_KEYS = (*VISUAL_KINDS, *_ORIGIN_KEYS, "scale", "color")
_INERTIA_KEYS = ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")


def _inertia(check: TomlCheck, value: Any, where: str) -> np.ndarray:
    """A 3x3 list of lists or a table {ixx, iyy, izz[, ixy, ixz, iyz]} -> (3, 3) array."""
    if isinstance(value, dict):
        check.check_keys(value, _INERTIA_KEYS, f"{where}: inertia")
        for key in ("ixx", "iyy", "izz"):
            check.require(value, key, f"{where}: inertia")
        v = {k: check.number(value.get(k, 0.0), f"{where}: inertia", k) for k in _INERTIA_KEYS}
        return np.array([[v["ixx"], v["ixy"], v["ixz"]],
                         [v["ixy"], v["iyy"], v["iyz"]],
                         [v["ixz"], v["iyz"], v["izz"]]])
    if isinstance(value, list) and len(value) == 3 and all(
            isinstance(r, list) for r in value):
        return np.array([check.vector(r, where, f"inertia[{k}]", 3)
                         for k, r in enumerate(value)])
    raise check.error(where, "'inertia' must be a 3x3 array of numbers or a table "
                             f"{{ixx, iyy, izz, ixy, ixz, iyz}}, got {quote(value)}")


def _visuals(check: TomlCheck, value: Any, where: str) -> tuple[Visual, ...]:
    """A ``visual`` array of tables (docs/robot-format.md) as Visuals in the link's frame (a
    mesh file is read when a view is drawn: :mod:`mrnea.io.mesh`)."""
    if not isinstance(value, list):
        raise check.error(where, "'visual' must be an array of tables: write visual = [{ ... }] "
                                 "or [[...visual]]")
    out = []
    for k, entry in enumerate(value, start=1):
        what = f"{where}: visual #{k}"
        check.table(entry, where, f"visual #{k}")
        check.check_keys(entry, _VISUAL_KEYS, what)
        kinds = [kind for kind in VISUAL_KINDS if kind in entry]
        if len(kinds) != 1:
            raise check.error(what, f"give exactly one of {', '.join(VISUAL_KINDS)}, got "
                                    f"{', '.join(kinds) or 'none'}")
        kind, mesh = kinds[0], None
        if "scale" in entry and kind != "mesh":
            raise check.error(what, "'scale' goes with a mesh only")
        if kind == "mesh":
            mesh = mesh_path(check.string(entry["mesh"], what, "mesh"), Path(check.source))
            size = check.vector(entry.get("scale", [1.0, 1.0, 1.0]), what, "scale", 3)
        elif kind == "sphere":
            size = [check.number(entry[kind], what, kind)]
        else:
            size = check.vector(entry[kind], what, kind, VISUAL_KINDS[kind])
        color = None
        if "color" in entry:
            color = list(check.vector(entry["color"], what, "color"))
            if len(color) not in (3, 4):
                raise check.error(what, f"'color' must be [r, g, b] or [r, g, b, a] in [0, 1], "
                                        f"got {entry['color']!r}")
            color += [1.0] * (4 - len(color))
        origin = _pose(check, entry, what, what)
        try:
            out.append(Visual(kind, tuple(size), origin, color, mesh))
        except ModelError as exc:
            raise check.error(what, str(exc)) from None
    return tuple(out)


def _frames(check: TomlCheck, value: Any, where: str) -> tuple[Frame, ...]:
    """A ``frame`` array of tables (docs/robot-format.md): named frames fixed to the link, each
    its pose in the link's frame (a tool frame such as a URDF's ``tool0``)."""
    if not isinstance(value, list):
        raise check.error(where, "'frame' must be an array of tables: write frame = [{ name = "
                                 "..., xyz = [...], rpy = [...] }]")
    out = []
    for k, entry in enumerate(value, start=1):
        what = f"{where}: frame #{k}"
        check.table(entry, where, f"frame #{k}")
        check.check_keys(entry, _FRAME_KEYS, what)
        name = check.string(check.require(entry, "name", what), what, "name")
        try:
            out.append(Frame(name, _pose(check, entry, what, what)))
        except ModelError as exc:
            raise check.error(what, str(exc)) from None
    return tuple(out)


def _link(check: TomlCheck, joint: Mapping[str, Any], jname: str, index: int) -> dict[str, Any]:
    where = f"joint {quote(jname)}"
    table = check.table(check.require(joint, "link", where), where, "link")
    lname = table.get("name", f"link{index}")
    lname = check.string(lname, f"{where}: link", "name")
    lwhere = f"joint {quote(jname)}: link {quote(lname)}"
    check.check_keys(table, _LINK_KEYS, lwhere)
    mass = check.number(check.require(table, "mass", lwhere), lwhere, "mass")
    com = check.vector(table.get("com", [0.0, 0.0, 0.0]), lwhere, "com", 3)
    inertia = (_inertia(check, table["inertia"], lwhere) if "inertia" in table
               else np.zeros((3, 3)))
    visuals = _visuals(check, table.get("visual", []), lwhere)
    frames = _frames(check, table.get("frame", []), lwhere)
    return {"link_name": lname, "mass": mass, "com": com, "inertia": inertia, "visuals": visuals,
            "frames": frames}


def _origin(check: TomlCheck, table: Mapping[str, Any], joint: str) -> np.ndarray:
    """The 4x4 origin of ``{xyz, rpy}`` or ``{xyz, rotation}`` (a 3x3 rotation matrix) of the
    joint ``joint`` (its label in messages)."""
    where = f"{joint}: origin"
    check.check_keys(table, _ORIGIN_KEYS, where)
    return _pose(check, table, where, joint)


def _pose(check: TomlCheck, table: Mapping[str, Any], where: str, label: str) -> np.ndarray:
    """The 4x4 transform of the ``xyz`` and ``rpy`` or ``rotation`` keys of ``table`` (the
    other keys are not looked at); ``where`` and ``label`` name it in messages."""
    xyz = check.vector(table.get("xyz", [0.0, 0.0, 0.0]), where, "xyz", 3)
    if "rotation" not in table:
        rpy = check.vector(table.get("rpy", [0.0, 0.0, 0.0]), where, "rpy", 3)
        try:
            return transform(xyz, rpy)
        except ModelError as exc:
            raise check.error(label, str(exc)) from None
    if "rpy" in table:
        raise check.error(where, "give 'rpy' or 'rotation', not both")
    T = np.eye(4)
    T[:3, :3] = check.matrix(table["rotation"], where, "rotation", width=3, rows=3)
    T[:3, 3] = xyz
    return T


def _parse_joints(check: TomlCheck, entries: list[Any], dh: str | None, base: str
                  ) -> tuple[list[Joint], list[Link], NDArray | None]:
    """The joints, the links, and for a DH table the pose of DH frame n (the flange) in the last
    link's frame (:func:`mrnea.io.dh.dh_tip_transform`; None without a DH table)."""
    allowed = _COMMON_JOINT_KEYS + (_DH_JOINT_KEYS if dh else _ORIGIN_JOINT_KEYS)
    hint_other = (" ('origin'/'axis' are not used when [robot] dh is set)" if dh else
                  " (DH parameters need dh = \"standard\" or \"modified\" in [robot])")
    rows: list[DHRow] = []
    joints: list[Joint] = []
    links: list[Link] = []
    parent = base
    link_of = {base: base}  # joint name (or the base) -> the link it moves (issue 25: trees)
    for i, entry in enumerate(entries, start=1):
        if not isinstance(entry, dict):
            raise check.error(f"joint #{i}", f"expected a table, got {quote(entry)}")
        raw_name = entry.get("name")
        jname = raw_name if isinstance(raw_name, str) and raw_name else f"#{i}"
        where = f"joint {quote(jname)}" if jname != f"#{i}" else f"joint #{i}"
        for key in entry:
            if key not in allowed and key in (_DH_JOINT_KEYS + _ORIGIN_JOINT_KEYS):
                raise check.error(where, f"key '{key}' not allowed here{hint_other}")
        check.check_keys(entry, allowed, where)
        jname = check.string(check.require(entry, "name", where), where, "name")
        jtype = check.string(check.require(entry, "type", where), where, "type")
        if jtype not in JOINT_TYPES:
            raise check.error(where, f"unsupported joint type {quote(jtype)} "
                                     f"(supported: {', '.join(JOINT_TYPES)})")
        link = _link(check, entry, jname, i)
        fields = joint_fields(check, entry, where)
        if dh:
            if link.pop("frames"):
                raise check.error(where, "link frames ('frame') are for the origin/axis form; "
                                         "with a DH table, give the tool as a program's tool")
            params = {k: check.number(check.require(entry, k, where), where, k)
                      for k in ("a", "alpha", "d")}
            params["theta"] = check.number(entry.get("theta", 0.0), where, "theta")
            rows.append(DHRow(type=jtype, name=jname, **params, **link, joint=fields))
            continue
        origin = _origin(check, check.table(entry.get("origin", {}), where, "origin"), where)
        axis = check.vector(check.require(entry, "axis", where), where, "axis", 3)
        lname = link.pop("link_name")
        if "parent" in entry:  # the joint whose link carries this one; default: the previous
            named = check.string(entry["parent"], where, "parent")
            if named == base and link_of[named] != base:  # an earlier joint has the base's name
                raise check.error(where, f"parent {quote(named)} names both the base link and "
                                         f"an earlier joint: rename that joint")
            if named not in link_of:
                raise check.error(where, f"parent {quote(named)} is neither the base "
                                         f"{quote(base)} nor an earlier joint")
            parent = link_of[named]
        try:
            links.append(Link(lname, **link))
            joints.append(Joint(jname, jtype, parent, lname, origin=origin, axis=axis,
                                **fields))
        except ModelError as exc:
            raise check.error(where, str(exc)) from None
        parent = link_of[jname] = lname
    if dh:
        try:
            return (*dh_joint_chain(rows, dh, base=base), dh_tip_transform(rows, dh))
        except ModelError as exc:
            raise check.error("", str(exc)) from None
    return joints, links, None


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
    # The model checks every value and names the field: no finiteness check here.
    check = TomlCheck(source, RobotFileError, finite=False)
    doc = check.parse(text)
    if "program" in doc:
        raise check.error("", "a program file (it has a [program] table), not a robot file")
    check.check_keys(doc, _TOP_KEYS, "top level")
    robot = check.table(doc.get("robot", {}), "top level", "robot")
    check.check_keys(robot, _ROBOT_KEYS, "[robot]")
    default_name = Path(source).stem if source != "<string>" else ""
    name = check.string(robot.get("name", default_name or "robot"), "[robot]", "name")
    gravity = check.vector(robot.get("gravity", list(DEFAULT_GRAVITY)), "[robot]", "gravity", 3)
    base = check.string(robot.get("base", "base"), "[robot]", "base")
    dh = robot.get("dh")
    if dh is not None and dh not in CONVENTIONS:
        raise check.error("[robot]", f"'dh' must be one of {', '.join(map(repr, CONVENTIONS))}, "
                                     f"got {quote(dh)}")
    entries = doc.get("joint")
    if entries is None:
        raise check.error("", "no [[joint]] tables: a robot needs at least one joint")
    if not isinstance(entries, list):
        raise check.error("", "'joint' must be an array of tables: write [[joint]], not [joint]")
    base_visuals = _visuals(check, robot.get("base_visual", []), "[robot] base")
    joints, links, _ = _parse_joints(check, entries, dh, base)
    try:
        return Robot(joints, links, gravity=gravity, name=name, base=base,
                     base_visuals=base_visuals)
    except ModelError as exc:
        raise check.error("", str(exc)) from None


def native_flange(path: str | Path) -> NDArray | None:
    """Pose (4x4) of the DH flange frame (DH frame n) in the last link's frame of the native
    robot file ``path``, given by a DH table (:func:`mrnea.io.dh.dh_tip_transform`); None for a
    file in the origin/axis form. Raises RobotFileError as :func:`load_native`."""
    text = read_text(path, "robot file", RobotFileError)
    loads_native(text, str(path))  # the whole file checked, errors naming it
    check = TomlCheck(str(path), RobotFileError, finite=False)
    doc = check.parse(text)
    robot = doc.get("robot", {})
    if robot.get("dh") is None:
        return None
    return _parse_joints(check, doc["joint"], robot["dh"], robot.get("base", "base"))[2]


def load_native(path: str | Path, actuators: str | Path | None = None) -> Robot:
    """Load a robot from a native TOML file.

    Parameters
    ----------
    path : path of the ``.toml`` file (format in ``docs/robot-format.md``).
    actuators : a sidecar actuator file applied on top
        (:func:`mrnea.io.sidecar.apply_actuator_file`).

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
    if actuators is not None:
        actuators = as_path(actuators, "actuators", RobotFileError)
    robot = loads_native(read_text(path, "robot file", RobotFileError), source=str(path))
    return robot if actuators is None else apply_actuator_file(robot, actuators)


# --- writer -----------------------------------------------------------------------------------
_DEFAULTS = {f.name: f.default for f in dataclasses.fields(Joint) if f.name in JOINT_FIELDS}


def _string(text: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    return '"' + "".join(
        f"\\u{ord(ch):04x}" if ch in '"\\' or ord(ch) < 0x20 or ord(ch) == 0x7F else ch
        for ch in text) + '"'


def _number(x: float) -> str:
    """Shortest exact decimal form (``repr``), which TOML and ``float`` read back bit for bit;
    infinities as TOML's ``inf``, ``-inf``."""
    return repr(float(x))


def _numbers(xs: Iterable[float]) -> str:
    return "[" + ", ".join(_number(x) for x in xs) + "]"


def _origin_lines(origin: np.ndarray) -> list[str]:
    """``xyz`` and the rotation: ``rpy`` where those angles give back the same matrix bit for
    bit (the identity, rotations about one axis by exact angles...), else ``rotation``."""
    R = origin[:3, :3]
    rpy = rpy_from_rotation(R) + 0.0  # no "-0.0" in the file
    lines = [f"xyz = {_numbers(origin[:3, 3])}"]
    if rotation_from_rpy(rpy).tobytes() == R.tobytes():
        return [*lines, f"rpy = {_numbers(rpy)}"]
    return [*lines, "rotation = [" + ", ".join(_numbers(row) for row in R) + "]"]


def _inertia_value(inertia: np.ndarray) -> str:
    """The ``{ixx, ...}`` table of a symmetric inertia, else the 3x3 array."""
    if not np.array_equal(inertia, inertia.T):
        return "[" + ", ".join(_numbers(row) for row in inertia) + "]"
    keys = (("ixx", 0, 0), ("iyy", 1, 1), ("izz", 2, 2), ("ixy", 0, 1), ("ixz", 0, 2),
            ("iyz", 1, 2))
    return "{ " + ", ".join(f"{k} = {_number(inertia[a, b])}" for k, a, b in keys) + " }"


def _joint_field_lines(joint: Joint) -> list[str]:
    """``key = value`` for each of :data:`JOINT_FIELDS` that differs from its default (a
    number, or a tuple of numbers such as ``torque_speed``; ``effort_limit`` is the peak of a
    torque-speed curve, so it is not written with one)."""
    out = []
    for key in JOINT_FIELDS:
        value = getattr(joint, key)
        if value is None or repr(value) == repr(_DEFAULTS[key]) or (
                key == "effort_limit" and joint.torque_speed is not None):
            continue
        text = _numbers(value) if isinstance(value, tuple) else _number(value)
        out.append(f"{key} = {text}")
    return out


def _visual_lines(key: str, visuals: tuple[Visual, ...]) -> list[str]:
    """``key = [...]``: one inline table per visual (none: no line)."""
    if not visuals:
        return []
    out = [f"{key} = ["]
    for v in visuals:
        if v.kind == "mesh":
            parts = [f"mesh = {_string(str(v.mesh))}", f"scale = {_numbers(v.size)}"]
        else:
            parts = [f"{v.kind} = " + (_number(v.size[0]) if v.kind == "sphere"
                                       else _numbers(v.size))]
        parts += _origin_lines(np.asarray(v.origin))
        if v.color is not None:
            parts.append(f"color = {_numbers(v.color)}")
        out.append("    { " + ", ".join(parts) + " },")
    return [*out, "]"]


def _frame_lines(frames: tuple[Frame, ...]) -> list[str]:
    """``frame = [...]``: one inline table per named frame of a link (none: no line)."""
    if not frames:
        return []
    return ["frame = [", *("    { " + ", ".join([f"name = {_string(f.name)}",
                                                  *_origin_lines(np.asarray(f.origin))]) + " },"
                          for f in frames), "]"]


def dumps_native(robot: Robot) -> str:
    """The native TOML text of ``robot`` (format: ``docs/robot-format.md``): ``[robot]``, then
    per joint a ``[[joint]]`` table with its limit and actuator fields (those that differ from
    the defaults), ``[joint.origin]`` and ``[joint.link]``. :func:`loads_native` reads it back
    equal to ``robot``, every number bit for bit."""
    if not isinstance(robot, Robot):
        raise TypeError(f"dumps_native: expected a Robot, got {type(robot).__name__}")
    lines = ["# mrnea robot file (docs/robot-format.md); SI units: m, rad, kg, kg m^2, N m, s",
             "[robot]", f"name = {_string(robot.name)}", f"base = {_string(robot.base)}",
             f"gravity = {_numbers(robot.gravity)}",
             *_visual_lines("base_visual", robot.base_visuals)]
    for i, (j, lk) in enumerate(zip(robot.joints, robot.links, strict=True)):
        p = robot.parents[i]
        if p != i - 1 and robot.base in robot.joint_names[:i]:
            raise ModelError(f"robot {quote(robot.name)}: joint {quote(j.name)}: its parent "
                             f"cannot be written: an earlier joint has the base link's name "
                             f"{quote(robot.base)}, and a native file's 'parent' names either; "
                             f"rename that joint")
        parent = [] if p == i - 1 else [  # a tree: the joint whose link carries this one
            f"parent = {_string(robot.base if p < 0 else robot.joints[p].name)}"]
        lines += ["", "[[joint]]", f"name = {_string(j.name)}", f"type = {_string(j.type)}",
                  *parent,
                  f"axis = {_numbers(j.axis)}", *_joint_field_lines(j),
                  "[joint.origin]", *_origin_lines(j.origin),
                  "[joint.link]", f"name = {_string(lk.name)}", f"mass = {_number(lk.mass)}",
                  f"com = {_numbers(lk.com)}", f"inertia = {_inertia_value(lk.inertia)}",
                  *_visual_lines("visual", lk.visuals), *_frame_lines(lk.frames)]
    return "\n".join(lines) + "\n"


def write_native(robot: Robot, path: str | Path, overwrite: bool = False) -> Path:
    """Write ``robot`` as a native TOML robot file (:func:`dumps_native`).

    Everything a Robot holds is written, what URDF cannot hold included (rotor inertia,
    torque-speed curves, gravity, visuals; a mesh by its absolute path), every number exactly:
    :func:`load_native` reads the file back equal to ``robot``, bit for bit.

    Parameters
    ----------
    robot : Robot
    path : str or Path
        The ``.toml`` file; its folder must exist. Written through
        :func:`mrnea.io.writer.write_file`: whole or not at all.
    overwrite : bool, default False
        Replace an existing file (a symbolic link: the link itself, never its target).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputError
        ``path`` exists and ``overwrite`` is False, is a directory or cannot be written
        (missing folder, permission...).
    """
    return write_file(path, dumps_native(robot), overwrite)
