"""The tool frame: a frame fixed to the last link, in which Cartesian poses are given.

Usage: ``T_tool = tool_transform(robot, tool)`` (4, 4), the tool frame's pose in the last
link's frame (mrnea's link frame n, :mod:`mrnea.model`); the tool's pose in the base frame is
``T_n(q) @ T_tool`` (:func:`mrnea.forward_kinematics` with ``tool=``). ``tool`` is one of

* ``None``: the last link's frame itself (the identity);
* the name of the last link, or of a frame fixed to it (:attr:`mrnea.model.Link.frames`: a URDF
  link merged into the last link by fixed joints, e.g. the Panda's ``"panda_hand_tcp"`` or a
  UR's ``"tool0"``);
* a mapping ``{"xyz": (3,) [m], "rpy": (3,) [rad]}`` (either key may be left out: zero), the
  tool frame in the last link's frame with URDF's roll-pitch-yaw convention;
* a (4, 4) homogeneous transform, the same.

A frame fixed to another link than the last is refused (it does not move with the tool), and
so is a robot that is a kinematic tree (:attr:`mrnea.Robot.is_serial` False): the tool, the
inverse kinematics (:mod:`mrnea.ik`) and Cartesian programs assume a serial chain.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import ModelError, StateError, quote
from mrnea.frozen import check_magnitude, rigid_transform
from mrnea.model import Robot
from mrnea.rigid import transform

__all__ = ["Tool", "frame_names", "tool_transform"]

#: What ``tool`` arguments may be (module docstring).
Tool = str | Mapping[str, ArrayLike] | ArrayLike | None


def frame_names(robot: Robot) -> tuple[str, ...]:
    """The names a tool may take on ``robot``: its last link and the frames fixed to it."""
    last = robot.links[-1]
    return (last.name, *(f.name for f in last.frames))


def tool_transform(robot: Robot, tool: Tool) -> NDArray[np.float64]:
    """The tool frame's pose (4, 4) in the last link's frame (module docstring).

    Raises
    ------
    StateError
        An unknown frame name (the message lists the names that work), a frame fixed to another
        link than the last, a mapping with other keys than ``xyz`` and ``rpy``, or values that
        are not a rigid transform.
    """
    if not robot.is_serial:
        raise StateError(f"robot {quote(robot.name)} is a kinematic tree: a tool frame (and the "
                         f"inverse kinematics and Cartesian programs built on it) needs a serial "
                         f"chain; load one branch of it (--tip LINK, load_urdf(..., tip=...))")
    if tool is None:
        return np.eye(4)
    if isinstance(tool, str):
        last = robot.links[-1]
        if tool == last.name:
            return np.eye(4)
        for f in last.frames:
            if f.name == tool:
                return np.array(f.origin)
        for lk in robot.links[:-1]:
            if tool == lk.name or any(f.name == tool for f in lk.frames):
                raise StateError(f"tool {quote(tool)} is fixed to link {quote(lk.name)}, not to "
                                 f"the last link {quote(last.name)}: it does not move with the "
                                 f"tool")
        raise StateError(f"tool {quote(tool)} is no frame of the last link of robot "
                         f"{quote(robot.name)}; frames there: "
                         f"{', '.join(map(quote, frame_names(robot)))} (or give xyz [m] and rpy "
                         f"[rad] in the last link's frame)")
    try:
        if isinstance(tool, Mapping):
            unknown = [k for k in tool if k not in ("xyz", "rpy")]
            if unknown:
                raise StateError(f"tool: unknown key {quote(unknown[0])}; a tool is given by "
                                 f"'xyz' [m] and 'rpy' [rad] in the last link's frame")
            xyz = np.asarray(tool.get("xyz", (0.0, 0.0, 0.0)), dtype=float)
            rpy = np.asarray(tool.get("rpy", (0.0, 0.0, 0.0)), dtype=float)
            if xyz.shape != (3,) or rpy.shape != (3,) or not (
                    np.isfinite(xyz).all() and np.isfinite(rpy).all()):
                raise StateError(f"tool: 'xyz' and 'rpy' must be 3 finite numbers each, got "
                                 f"{xyz.tolist()} and {rpy.tolist()}")
            check_magnitude(xyz, "length", "'xyz'", "m")  # ModelError: 'tool: ' added below
            return transform(xyz, rpy)
        return np.array(rigid_transform(tool, "tool"))
    except (ModelError, TypeError, ValueError) as exc:
        if isinstance(exc, StateError):
            raise
        raise StateError(f"tool: {exc}") from None
