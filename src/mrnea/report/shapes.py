"""The shapes the report's 3D view draws: a robot's visuals, or simple shapes made from its joints.

Per body (the fixed base, then link 0 .. n-1) a list of :class:`Shape` in that body's frame,
each with the joint whose saturation reddens it. A body with visuals
(:attr:`mrnea.model.Link.visuals`, :attr:`mrnea.model.Robot.base_visuals`) is drawn as those;
a body without, or whose mesh files cannot be read, as capsules between the joint origins and
short cylinders along the joint axes (:func:`fallback`). Meshes are read through
:func:`mrnea.io.mesh.read_mesh` and decimated so that the whole scene holds at most
:data:`MAX_SCENE_FACES` triangles (:func:`decimate`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import MeshWarning, MrneaError, StateError, quote
from mrnea.io.mesh import read_mesh
from mrnea.model import Robot
from mrnea.visual import VISUAL_KINDS

MAX_SCENE_FACES = 40_000
"""At most this many mesh triangles in one view (all meshes together)."""
LINK_COLOR, DRIVE_COLOR = 0x5B7FA6, 0x3B4048


@dataclass(frozen=True, eq=False)
class Shape:
    """One shape as the page draws it: a :class:`mrnea.visual.Visual`'s kind, size and origin
    (``"mesh"``: size is the scale and ``vertices`` (V, 3), ``faces`` (F, 3) the triangles),
    its colour ``0xRRGGBB`` (None: the view's), and the joint whose saturation reddens it
    (None: none)."""

    kind: str
    size: tuple[float, ...]
    origin: NDArray[np.float64] = field(default_factory=lambda: np.eye(4))
    color: int | None = None
    joint: int | None = None
    vertices: NDArray[np.float32] | None = None
    faces: NDArray[np.int64] | None = None

    def __post_init__(self) -> None:
        if self.kind not in VISUAL_KINDS or len(self.size) != VISUAL_KINDS[self.kind]:
            raise StateError(f"shape {self.kind!r} with sizes {self.size!r}: see Visual")
        if (self.kind == "mesh") != (self.vertices is not None and self.faces is not None):
            raise StateError("vertices and faces go with a mesh, and a mesh needs both")

    def bounding_sphere(self) -> tuple[NDArray[np.float64], float]:
        """Centre (3,) in the body frame and radius [m] of a sphere holding the shape."""
        o = self.origin
        if self.kind == "mesh":
            v = np.asarray(self.vertices, dtype=float) * np.asarray(self.size)
            c = 0.5 * (v.min(axis=0) + v.max(axis=0))
            return o[:3, :3] @ c + o[:3, 3], float(np.linalg.norm(v - c, axis=1).max())
        s = self.size
        if self.kind == "box":
            r = 0.5 * math.hypot(*s)
        elif self.kind == "sphere":
            r = s[0]
        elif self.kind == "cylinder":
            r = math.hypot(s[0], s[1] / 2)
        else:  # capsule
            r = s[0] + s[1] / 2
        return o[:3, 3].copy(), float(r)


def frame_z_to(d: ArrayLike, at: ArrayLike) -> NDArray[np.float64]:
    """(4, 4) frame at the point ``at`` whose z axis is along the vector ``d`` (not zero)."""
    z = np.asarray(d, dtype=float) / np.linalg.norm(d)
    x = np.cross([0.0, 0.0, 1.0] if abs(z[2]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    T[:3, 3] = at
    return T


def capsule_between(a: ArrayLike, b: ArrayLike, radius: float, joint: int | None = None,
                    color: int | None = None) -> Shape:
    """A capsule of ``radius`` [m] from point ``a`` to point ``b`` (3,) [m] of a body frame."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return Shape("capsule", (radius, float(np.linalg.norm(b - a))),
                 frame_z_to(b - a, 0.5 * (a + b)), color, joint)


def tip_point(robot: Robot, link: int = -1) -> NDArray[np.float64]:
    """The end-effector point whose path the view draws, in link ``link``'s frame [m] (the
    last link by default): twice its centre of mass (the far end of a uniform bar from its
    joint), its origin when the centre of mass is there."""
    return 2.0 * np.asarray(robot.links[link].com, dtype=float)


def leaves(robot: Robot) -> list[int]:
    """The links no joint hangs from: a chain's last link, each branch's tip on a tree."""
    has_child = set(robot.parents)
    return [i for i in range(robot.n) if i not in has_child]


def fallback(robot: Robot, body: int) -> list[Shape]:
    """Simple shapes of body ``body`` (0: the base, i + 1: link i) from the joints alone.

    A capsule from the body's origin to each child joint's origin (a tree's body may carry
    several; a body carrying none: to :func:`tip_point`; a sphere where they coincide),
    reddened with the joint that moves the body; a short cylinder (revolute) or a square rail
    (prismatic) along the axis of each joint the body carries, reddened with that joint; under
    the base a plinth. Sizes scale with the robot's reach (the longest root-to-tip path).
    """
    offsets = [np.asarray(j.origin[:3, 3], dtype=float) for j in robot.joints]
    reach = [0.0] * robot.n  # from the base to each joint's child link, along its branch
    for i, p in enumerate(robot.parents):
        reach[i] = (0.0 if p < 0 else reach[p]) + float(np.linalg.norm(offsets[i]))
    longest = max(reach[i] + float(np.linalg.norm(tip_point(robot, i))) for i in leaves(robot))
    r = 0.035 * (longest if longest > 0 else 1.0)
    moved_by = None if body == 0 else body - 1
    out = []
    if body == 0:
        out.append(Shape("cylinder", (3.0 * r, r), frame_z_to((0, 0, 1.0), (0, 0, -r / 2)),
                         DRIVE_COLOR))
    carried = [i for i, p in enumerate(robot.parents) if p == body - 1]
    ends = [offsets[i] for i in carried] or [tip_point(robot, body - 1)] * (body > 0)
    for nxt in ends:
        if np.linalg.norm(nxt) > 1e-9:
            out.append(capsule_between((0, 0, 0), nxt, r, moved_by, LINK_COLOR))
        elif body > 0:
            out.append(Shape("sphere", (1.3 * r,), color=LINK_COLOR, joint=moved_by))
    for i in carried:  # the drive of each joint this body carries
        j = robot.joints[i]
        frame = frame_z_to(j.origin[:3, :3] @ np.asarray(j.axis), offsets[i])
        out.append(Shape("box", (1.8 * r, 1.8 * r, 8.0 * r), frame, DRIVE_COLOR, i)
                   if j.is_prismatic else
                   Shape("cylinder", (1.6 * r, 3.2 * r), frame, DRIVE_COLOR, i))
    return out


def decimate(vertices: ArrayLike, faces: ArrayLike, max_faces: int
             ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """A mesh of at most ``max_faces`` (>= 4) triangles approximating (V, 3), (F, 3).

    Quadric decimation (the ``fast_simplification`` package, gentle first, more aggressive
    where a gentle run stops short of the budget) where it meets the budget; otherwise the
    convex hull of every k-th vertex, at most ``max_faces // 2`` of them
    (a hull of m points has at most 2 m - 4 faces; holes and concavities are lost). The mesh
    is welded first (:func:`weld`): CAD and COLLADA files repeat a vertex on each side of a
    seam (normals, texture coordinates), and decimating those sides apart tears holes along
    every seam (the UR5's meshes: 2022 of 2898 edges of its base open before, 0 after).
    """
    V, F = np.asarray(vertices, dtype=float), np.asarray(faces, dtype=np.int64)
    if F.shape[0] <= max_faces:
        return V, F
    import fast_simplification
    import trimesh

    V, F = weld(V, F)
    # gentle first: its default aggressiveness (7) lost 20-37 % of the UR5 upper arm's and
    # forearm's volume where 3 kept 97 %; a gentler run can stop short of the target, so the
    # next one is more aggressive
    for agg in (3, 5, 7, 10):
        V2, F2 = fast_simplification.simplify(V, F, target_count=max_faces, agg=agg)
        if 0 < F2.shape[0] <= max_faces:
            return np.asarray(V2, dtype=float), np.asarray(F2, dtype=np.int64)

    every = math.ceil(V.shape[0] / max(4, max_faces // 2))
    hull = trimesh.convex.convex_hull(V[::every])
    return np.asarray(hull.vertices, dtype=float), np.asarray(hull.faces, dtype=np.int64)


def weld(vertices: NDArray[np.float64], faces: NDArray[np.int64]
         ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The mesh with vertices closer than 1e-7 of its size merged into one, and the triangles
    that merging collapses (two corners the same) dropped."""
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    key = np.round(vertices / (1e-7 * size)) if size > 0 else vertices
    _, first, index = np.unique(key, axis=0, return_index=True, return_inverse=True)
    F = index.reshape(-1)[faces]
    keep = (F[:, 0] != F[:, 1]) & (F[:, 1] != F[:, 2]) & (F[:, 0] != F[:, 2])
    return vertices[first], F[keep]


def _rgb(color: tuple[float, ...] | None) -> int | None:
    if color is None:
        return None
    r, g, b = (round(255 * c) for c in color[:3])
    return (r << 16) | (g << 8) | b


def _missing_meshes(robot: Robot, failed: dict[str, str]) -> MeshWarning:
    """The warning for the mesh files not drawn (``failed``: name -> why): short, the first
    reason only; its hint names the ``package://`` packages not found and how to point mrnea at
    them."""
    first = next(iter(failed.values()))
    more = f" (and {len(failed) - 1} more)" if len(failed) > 1 else ""
    packages = sorted({name[len("package://"):].split("/")[0] for name in failed
                       if name.startswith("package://")})
    hint = None
    if packages:
        hint = (f"to draw the meshes, point mrnea at package {', '.join(map(quote, packages))}: "
                "--package-path DIR (the package's folder or one holding it), or "
                "ROS_PACKAGE_PATH=DIR")
    return MeshWarning(f"3D view of {quote(robot.name)}: {len(failed)} mesh file(s) not drawn, "
                       f"their links drawn as capsules: {first}{more}", hint)


def robot_shapes(robot: Robot, max_faces: int = MAX_SCENE_FACES) -> list[list[Shape]]:
    """The shapes of every body: ``[base, link 0, ..., link n-1]``, each in its body's frame.

    Mesh files that cannot be read (not found, not installed trimesh, not a mesh) give one
    :class:`~mrnea.errors.MeshWarning` saying why (and, for ``package://`` names, how to point
    mrnea at them), and a body is drawn as if it had no visual (:func:`fallback`) when
    none of its visuals is left.
    """
    bodies = [robot.base_visuals, *(lk.visuals for lk in robot.links)]
    meshes: dict[str, tuple[NDArray, NDArray]] = {}
    failed: dict[str, str] = {}
    for v in (v for vs in bodies for v in vs if v.kind == "mesh"):
        if v.mesh not in meshes and v.mesh not in failed:
            try:
                meshes[v.mesh] = read_mesh(v.mesh)
            except MrneaError as exc:
                failed[str(v.mesh)] = str(exc)
    if failed:
        warnings.warn(_missing_meshes(robot, failed), stacklevel=3)
    total = sum(F.shape[0] for _, F in meshes.values())
    for path, (V, F) in meshes.items():  # the budget shared in proportion to the faces
        meshes[path] = decimate(V, F, max(100, max_faces * F.shape[0] // max(total, 1)))
    out = []
    for b, visuals in enumerate(bodies):
        joint = None if b == 0 else b - 1
        shapes = []
        for v in visuals:
            if v.kind != "mesh":
                shapes.append(Shape(v.kind, v.size, v.origin, _rgb(v.color), joint))
            elif v.mesh in meshes:
                V, F = meshes[v.mesh]
                shapes.append(Shape("mesh", v.size, v.origin, _rgb(v.color), joint,
                                    V.astype(np.float32), F))
        out.append(shapes or fallback(robot, b))
    return out
