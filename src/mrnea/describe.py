"""A robot described for a reader: text tables (``mrnea info``, the report) and JSON data.

:func:`describe` prints the joints, links, limits and every actuator field of
:data:`mrnea.actuator_fields.ACTUATOR_FIELDS` (the torque-speed curve included) with their units in
the headers, fitted to a width: one table if it fits, else a geometry table and an actuator table,
else one block per joint. Units follow the joints: ``rad``, ``N m`` for revolute joints, ``m``,
``N`` for prismatic ones, ``rad or m`` in a column that has both. :func:`robot_data` is the same as
strict JSON data (RFC 8259: no Infinity or NaN; an unlimited value is ``None``, JSON null).
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from typing import Any

from mrnea.actuator_fields import ACTUATOR_FIELDS
from mrnea.model import JOINT_UNITS, Joint, Robot

__all__ = ["describe", "robot_data"]

_GAP = "  "
_WORDS = ("joint", "type", "link")  # the left-aligned columns


def _unit(unit: str, prismatic: set[bool]) -> str:
    """``unit`` ("N m or N", "N m or N, rad/s or m/s"...) for the joint kinds of a column."""
    if len(prismatic) != 1:
        return unit
    k = int(next(iter(prismatic)))
    return ", ".join(alt[k] if len(alt := part.split(" or ")) == 2 else part
                     for part in unit.split(", "))


def _text(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, tuple):
        return "/".join(_text(x) for x in v)
    return f"{v:.5g}" if isinstance(v, float) else str(v)


def _columns(robot: Robot) -> tuple[list[tuple[str, list[str]]], list[tuple[str, list[str]]]]:
    """(geometry columns, actuator columns): each ``(header with unit, one cell per joint)``."""
    kinds = {j.is_prismatic for j in robot.joints}

    def unit(quantity: str) -> str:
        return " or ".join(dict.fromkeys(JOINT_UNITS[quantity][k] for k in sorted(kinds)))

    def col(head: str, get: Any) -> tuple[str, list[str]]:
        return head, [_text(get(j, lk)) for j, lk in zip(robot.joints, robot.links, strict=True)]

    geometry = [col("type", lambda j, lk: j.type), col("link", lambda j, lk: lk.name),
                col("mass [kg]", lambda j, lk: lk.mass),
                col(f"lower [{unit('q')}]", lambda j, lk: j.lower),
                col(f"upper [{unit('q')}]", lambda j, lk: j.upper),
                col(f"vel limit [{unit('qd')}]", lambda j, lk: j.velocity_limit)]
    actuators = [col(f"{f.symbol} [{_unit(f.unit, kinds)}]",
                     lambda j, lk, name=f.name: getattr(j, name)) for f in ACTUATOR_FIELDS]
    return geometry, actuators


def _table(names: list[str], columns: list[tuple[str, list[str]]]) -> list[str]:
    """Rows of a table: names and words left-aligned, numbers right-aligned."""
    cols = [("joint", names), *columns]
    widths = [max(len(h), *(len(c) for c in cells)) for h, cells in cols]
    left = {k for k, (h, _) in enumerate(cols) if h in _WORDS}

    def line(cells: list[str]) -> str:
        return _GAP.join(c.ljust(w) if k in left else c.rjust(w)
                         for k, (c, w) in enumerate(zip(cells, widths, strict=True))).rstrip()

    return [line([h for h, _ in cols]),
            *(line([cells[i] for _, cells in cols]) for i in range(len(names)))]


def _pack(names: list[str], columns: list[tuple[str, list[str]]], width: int
          ) -> list[list[tuple[str, list[str]]]]:
    """``columns`` split, in order, into as few tables as fit ``width`` each."""
    tables: list[list[tuple[str, list[str]]]] = [[]]
    for col in columns:
        if tables[-1] and max(map(len, _table(names, [*tables[-1], col]))) > width:
            tables.append([])
        tables[-1].append(col)
    return tables


def _forks(parents: Sequence[int]) -> list[bool]:
    """Whether each joint's parent (a joint, or the base) has more than one child joint."""
    children = [0] * (len(parents) + 1)  # children[p + 1]: joint p's (p = -1: the base's)
    for p in parents:
        children[p + 1] += 1
    return [children[p + 1] > 1 for p in parents]


def branch_depths(parents: Sequence[int]) -> list[int]:
    """How many branch points lie above each joint (a joint, or the base, with more than one
    child joint): the indentation of a tree's joints in ``info``, so that each branch is one
    block, set in under the joint it hangs from. All zero for a serial chain."""
    depth: list[int] = []
    for p, fork in zip(parents, _forks(parents), strict=True):
        depth.append((0 if p < 0 else depth[p]) + fork)
    return depth


def branches(parents: Sequence[int]) -> list[list[int]]:
    """A tree's branches: its maximal chains, each a list of joint indices (depth-first order
    makes each consecutive). A branch starts at the first joint and at every joint whose parent
    (or the base) has several children. One branch for a serial chain."""
    out: list[list[int]] = []
    for i, fork in enumerate(_forks(parents)):
        if i == 0 or fork:
            out.append([])
        out[-1].append(i)
    return out


def describe(robot: Robot, width: int = 100) -> str:
    """A text description of ``robot`` at most ``width`` characters wide where possible.

    A heading line (name, joints, base, gravity), then the joints' table: type, link, mass
    [kg], position and velocity limits, and one column per actuator field (its symbol and unit
    in the header; ``-``: no torque-speed curve; the curve as peak/corner speed/no-load speed),
    then a legend of the actuator symbols. A tree's joints are set in by two spaces per branch
    point above them (:func:`branch_depths`), each listed under the joint it hangs from (depth
    first, as the robot numbers them), and a line after the heading names each branch's first
    joint and its parent. If the table is wider than ``width`` it is split into
    a geometry table and an actuator table, else into as many tables as it takes; if a single
    column is still too wide, each joint is a block of ``field [unit]: value``
    lines.
    """
    g = robot.gravity.tolist()
    head = textwrap.wrap(f"{robot.name}: {robot.n} moving joints, base '{robot.base}', gravity "
                         f"[{', '.join(f'{x:.4g}' for x in g)}] m/s^2", max(width, 40),
                         subsequent_indent="    ")
    geometry, actuators = _columns(robot)
    names = list(robot.joint_names)
    if not robot.is_serial:
        parents = robot.parents
        parts = [names[b[0]] + (f"..{names[b[-1]]}" if len(b) > 1 else "")
                 + (f" (on {names[parents[b[0]]]})" if parents[b[0]] >= 0 else "")
                 for b in branches(parents)]
        head += textwrap.wrap(f"a tree of {len(parts)} branches: {'; '.join(parts)}",
                              max(width, 40), subsequent_indent="    ")
        depth = branch_depths(parents)
        names = ["  " * (d - min(depth)) + name for d, name in zip(depth, names, strict=True)]
    legend = [""] + [line for f in ACTUATOR_FIELDS for line in textwrap.wrap(
        f"{f.symbol}: {f.meaning}", max(width, 40), subsequent_indent="    ")]
    for tables in ([geometry + actuators], [geometry, actuators],
                   _pack(names, geometry + actuators, width)):
        blocks = [_table(names, cols) for cols in tables]
        if all(len(row) <= width for block in blocks for row in block):
            body = [row for k, block in enumerate(blocks) for row in ([""] * (k > 0) + block)]
            return "\n".join(head + body + legend)
    rows = []
    for i, name in enumerate(names):
        rows += ["", f"joint '{name}'"]
        rows += [f"  {h}: {cells[i]}" for h, cells in geometry + actuators]
    return "\n".join(head + rows + legend)


def _strict(v: Any) -> Any:
    """``v`` with every infinite or NaN float (unlimited) replaced by None, tuples as lists."""
    if isinstance(v, float):
        return v if math.isfinite(v) else None
    if isinstance(v, (tuple, list)):
        return [_strict(x) for x in v]
    if isinstance(v, dict):
        return {k: _strict(x) for k, x in v.items()}
    return v


def _joint(j: Joint) -> dict[str, Any]:
    out: dict[str, Any] = {"name": j.name, "type": j.type, "parent": j.parent,
                           "origin": j.origin.tolist(), "axis": j.axis.tolist(),
                           "lower": j.lower, "upper": j.upper,
                           "velocity_limit": j.velocity_limit}
    for f in ACTUATOR_FIELDS:
        out[f.name] = getattr(j, f.name)
    curve = j.torque_speed
    out["torque_speed"] = None if curve is None else dict(
        zip(("peak", "corner_speed", "no_load_speed"), curve, strict=True))
    out["units"] = {q: j.unit(q) for q in JOINT_UNITS}
    return out


def robot_data(robot: Robot) -> dict[str, Any]:
    """``robot`` as JSON-ready data (``json.dumps(..., allow_nan=False)`` accepts it).

    ``name``, ``n``, ``base``, ``gravity`` [m/s^2], and per joint (root to tip): its name,
    type, parent link, parent joint (``parent_joint``, None on the base: a tree's structure),
    origin (4x4, parent link frame -> joint frame) and axis, its limits and
    actuator fields (SI units, joint side; the torque-speed curve as ``peak``,
    ``corner_speed``, ``no_load_speed`` or None), ``units`` (of q, qd, qdd, tau) and the
    ``link`` it moves (name, mass [kg], com [m, link frame], inertia [kg m^2, about the com]).
    Unlimited values (infinite limits) are None.
    """
    joints = []
    for j, lk, p in zip(robot.joints, robot.links, robot.parents, strict=True):
        d = _joint(j)
        d["parent_joint"] = None if p < 0 else robot.joint_names[p]
        d["link"] = {"name": lk.name, "mass": lk.mass, "com": lk.com.tolist(),
                     "inertia": lk.inertia.tolist()}
        joints.append(d)
    return _strict({"name": robot.name, "n": robot.n, "base": robot.base,
                    "gravity": robot.gravity.tolist(), "joints": joints})
