"""What a link looks like: its visual geometry (URDF's ``<visual>``), for the report's 3D view.

A :class:`Visual` is one shape in a link's frame: a box, a cylinder, a sphere, a capsule or a
mesh file. Links carry them (:attr:`mrnea.model.Link.visuals`; the fixed base's:
:attr:`mrnea.model.Robot.base_visuals`); the dynamics never read them. They come from URDF
``<visual>`` elements (:mod:`mrnea.io.urdf`) and from the native format's ``visual`` tables
(docs/robot-format.md); a fixed joint merged away moves its child's visuals into the chain link
with :meth:`Visual.moved`, as it moves the child's inertia.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from mrnea.errors import ModelError, quote
from mrnea.frozen import Frozen, frozen_array, rigid_transform

#: The shapes and the number of sizes each takes (see :class:`Visual`).
VISUAL_KINDS = {"box": 3, "cylinder": 2, "sphere": 1, "capsule": 2, "mesh": 3}


@dataclass(frozen=True, eq=False)
class Visual(Frozen):
    """One visual shape of a link, in the link's frame (URDF conventions).

    Parameters
    ----------
    kind : ``"box"``, ``"cylinder"``, ``"sphere"``, ``"capsule"`` or ``"mesh"``.
    size : the shape's sizes [m], all finite and > 0: ``box`` (x, y, z) edge lengths, centred;
        ``cylinder`` (radius, length) along the shape frame's z, centred; ``sphere`` (radius,);
        ``capsule`` (radius, length) along z, the length between the centres of the two
        hemispherical caps; ``mesh`` (sx, sy, sz), the scale applied to the file's vertices.
    origin : (4, 4) the shape's frame in the link's frame (URDF's ``<visual><origin>``).
    color : ``(r, g, b, a)`` in [0, 1], or None (the viewer's colour).
    mesh : for ``kind="mesh"``, the mesh file's path (STL, OBJ, DAE: what trimesh reads); the
        file is read when a view is drawn, not when the robot is loaded.
    """

    kind: str
    size: tuple[float, ...]
    origin: ArrayLike = field(default_factory=lambda: np.eye(4))
    color: tuple[float, float, float, float] | None = None
    mesh: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in VISUAL_KINDS:
            raise ModelError(f"visual kind {self.kind!r}: expected one of "
                             f"{', '.join(VISUAL_KINDS)}")
        what = f"{self.kind} visual"
        count = VISUAL_KINDS[self.kind]
        raw = self.size if isinstance(self.size, (tuple, list, np.ndarray)) else (self.size,)
        size = frozen_array(raw, (count,), f"{what}: size")
        if not np.all(size > 0):
            raise ModelError(f"{what}: size must be > 0, got {size.tolist()}")
        color = self.color
        if color is not None:
            rgba = frozen_array(color, (4,), f"{what}: color (r, g, b, a)")
            if not np.all((rgba >= 0) & (rgba <= 1)):
                raise ModelError(f"{what}: color components must be in [0, 1], got "
                                 f"{rgba.tolist()}")
            color = tuple(float(c) for c in rgba)
        if (self.kind == "mesh") != (self.mesh is not None):
            raise ModelError(f"{what}: a mesh visual needs the mesh file, and only a mesh visual "
                             f"has one (got mesh={self.mesh!r})")
        if self.mesh is not None and (not isinstance(self.mesh, str) or not self.mesh):
            raise ModelError(f"{what}: mesh must be a file path, got {self.mesh!r}")
        object.__setattr__(self, "size", tuple(float(x) for x in size))
        object.__setattr__(self, "origin", rigid_transform(self.origin, f"{what}: origin"))
        object.__setattr__(self, "color", color)

    def moved(self, T: ArrayLike) -> Visual:
        """This visual with its frame expressed in another frame: ``origin -> T @ origin``, T
        (4, 4) the pose of this visual's link frame in the new one."""
        return dataclasses.replace(self, origin=np.asarray(T, dtype=float) @ self.origin)


def visual_tuple(visuals: object, what: str) -> tuple[Visual, ...]:
    """``visuals`` (a tuple or list of Visual) as a tuple; ``what`` names the owner in the
    ModelError otherwise."""
    out = tuple(visuals) if isinstance(visuals, (tuple, list)) else None
    if out is None or not all(isinstance(v, Visual) for v in out):
        raise ModelError(f"{what}: visuals must be a sequence of mrnea.visual.Visual, got "
                         f"{quote(visuals)}")
    return out
