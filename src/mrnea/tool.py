"""The tool frame: a frame fixed to a link, in which Cartesian poses are given.

Usage: ``frame = tool_frame(robot, tool)``, a :class:`ToolFrame`: the index ``link`` of the
link the tool is fixed to and ``T`` (4, 4), the tool frame's pose in that link's frame (mrnea's
link frames, :mod:`mrnea.model`); the tool's pose in the base frame is ``T_link(q) @ T``
(:func:`mrnea.forward_kinematics` with ``tool=``). ``tool`` is one of

* ``None``: the last link's frame itself (the identity) -- on a serial chain only;
* the name of a link, or of a frame fixed to one (:attr:`mrnea.model.Link.frames`: a URDF
  link merged into a link by fixed joints, e.g. the Panda's ``"panda_hand_tcp"`` or a UR's
  ``"tool0"``);
* a mapping ``{"xyz": (3,) [m], "rpy": (3,) [rad], "link": name}`` (``xyz`` and ``rpy`` may be
  left out: zero), the tool frame in the link's frame with URDF's roll-pitch-yaw convention;
  ``link`` may be left out on a serial chain (the last link);
* a (4, 4) homogeneous transform in the last link's frame (a serial chain);
* a :class:`ToolFrame` (already resolved).

On a serial chain the tool is fixed to the last link: a frame of another link is refused (it
does not move with the tool). On a kinematic tree (:attr:`mrnea.Robot.is_serial` False) a tool
is fixed to any link, which must be named (a link's or a frame's name, or ``link``): that link
is the tip the inverse kinematics (:mod:`mrnea.ik`) and a Cartesian move drive, through the
joints that carry it (docs/trees.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import ModelError, StateError, quote, shorten
from mrnea.frozen import check_magnitude, rigid_transform
from mrnea.model import Robot
from mrnea.rigid import transform

__all__ = ["Tool", "ToolFrame", "carrying_joints", "frame_names", "tool_frame"]


class ToolFrame(NamedTuple):
    """A resolved tool frame: ``link`` the index of the link it is fixed to (0-based, link i
    moves with joint i) and ``T`` (4, 4) its pose in that link's frame [m]."""

    link: int
    T: NDArray[np.float64]


#: What ``tool`` arguments may be (module docstring).
Tool = str | Mapping[str, ArrayLike] | ArrayLike | ToolFrame | None


def frame_names(robot: Robot) -> tuple[str, ...]:
    """The names a tool may take on ``robot``: on a serial chain its last link and the frames
    fixed to it; on a tree every link and every frame fixed to one."""
    links = robot.links if not robot.is_serial else robot.links[-1:]
    return tuple(name for lk in links for name in (lk.name, *(f.name for f in lk.frames)))


def carrying_joints(robot: Robot, link: int) -> tuple[int, ...]:
    """The joints that carry ``link`` (it and its ancestors, Pinocchio's ``supports``), root
    first: the joints whose motion moves a tool fixed to it."""
    out, k = [], link
    while k >= 0:
        out.append(k)
        k = robot.parents[k]
    return tuple(reversed(out))


def _named(robot: Robot, name: str) -> ToolFrame:
    """The frame of a link or of a frame fixed to one, by name."""
    serial, last = robot.is_serial, robot.n - 1
    for i, lk in enumerate(robot.links):
        origin = np.eye(4) if name == lk.name else next(
            (np.array(f.origin) for f in lk.frames if f.name == name), None)
        if origin is None:
            continue
        if serial and i != last:
            raise StateError(f"tool {quote(name)} is fixed to link {quote(lk.name)}, not to "
                             f"the last link {quote(robot.links[-1].name)}: it does not move "
                             f"with the tool")
        return ToolFrame(i, origin)
    where = "the last link of robot" if serial else "a link of robot"
    raise StateError(f"tool {quote(name)} is no frame of {where} {quote(robot.name)}; frames "
                     f"there: {shorten(', '.join(map(quote, frame_names(robot))), 300)} (or "
                     f"give xyz [m] and rpy [rad] in {'the last' if serial else 'a'} link's "
                     f"frame{'' if serial else ' and the link'})")


def _mapping(robot: Robot, tool: Mapping[str, ArrayLike]) -> ToolFrame:
    unknown = [k for k in tool if k not in ("xyz", "rpy", "link")]
    if unknown:
        raise StateError(f"tool: unknown key {quote(unknown[0])}; a tool is given by 'xyz' [m] "
                         f"and 'rpy' [rad] in the frame of its 'link'")
    if "link" in tool:
        link = tool["link"]
        if not isinstance(link, str):
            raise StateError(f"tool: 'link' must be a link's name, got {link!r}")
        i = robot.link_index(link, "tool: 'link'", StateError)
        if robot.is_serial and i != robot.n - 1:
            raise StateError(f"tool: link {quote(link)} is not the last link "
                             f"{quote(robot.links[-1].name)}: a tool on a serial chain is "
                             f"fixed to its last link")
    elif robot.is_serial:
        i = robot.n - 1
    else:
        raise StateError(f"tool: robot {quote(robot.name)} is a kinematic tree: say which link "
                         f"the tool is fixed to ('link')")
    xyz = np.asarray(tool.get("xyz", (0.0, 0.0, 0.0)), dtype=float)
    rpy = np.asarray(tool.get("rpy", (0.0, 0.0, 0.0)), dtype=float)
    if xyz.shape != (3,) or rpy.shape != (3,) or not (
            np.isfinite(xyz).all() and np.isfinite(rpy).all()):
        raise StateError(f"tool: 'xyz' and 'rpy' must be 3 finite numbers each, got "
                         f"{xyz.tolist()} and {rpy.tolist()}")
    check_magnitude(xyz, "length", "'xyz'", "m")  # ModelError: 'tool: ' added by the caller
    return ToolFrame(i, transform(xyz, rpy))


def tool_frame(robot: Robot, tool: Tool) -> ToolFrame:
    """The tool's link and its pose (4, 4) in that link's frame (module docstring).

    Raises
    ------
    StateError
        An unknown frame or link name (the message lists the names that work), a frame fixed to
        another link than the last on a serial chain, a tool on a tree that names no link, a
        mapping with other keys than ``xyz``, ``rpy`` and ``link``, or values that are not a
        rigid transform.
    """
    if isinstance(tool, ToolFrame):
        if not 0 <= tool.link < robot.n:
            raise StateError(f"tool: link index {tool.link} is not one of robot "
                             f"{quote(robot.name)}'s {robot.n} links")
        return tool
    if tool is None:
        if not robot.is_serial:
            raise StateError(f"robot {quote(robot.name)} is a kinematic tree: name the tool "
                             f"(a link or a frame fixed to one, e.g. {quote(robot.links[-1].name)}"
                             f"), or give it as {{xyz, rpy, link}}")
        return ToolFrame(robot.n - 1, np.eye(4))
    if isinstance(tool, str):
        return _named(robot, tool)
    try:
        if isinstance(tool, Mapping):
            return _mapping(robot, tool)
        if not robot.is_serial:
            raise StateError(f"tool: robot {quote(robot.name)} is a kinematic tree: a (4, 4) "
                             f"transform does not say which link the tool is fixed to; give "
                             f"{{xyz, rpy, link}} or a frame's name")
        return ToolFrame(robot.n - 1, np.array(rigid_transform(tool, "tool")))
    except (ModelError, TypeError, ValueError) as exc:
        if isinstance(exc, StateError):
            raise
        raise StateError(f"tool: {exc}") from None
