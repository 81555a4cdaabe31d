"""URDF ``<visual>`` elements: what the links look like, for the report's 3D view.

Each ``<visual>`` becomes a :class:`mrnea.visual.Visual` in its link's frame: ``<origin>``, the
``<geometry>`` (``<box size>``, ``<cylinder radius length>``, ``<sphere radius>``, ``<capsule
radius length>``, ``<mesh filename scale>``) and the colour of its ``<material>`` (given inline
or by the name of a top-level ``<material>``; textures are not read). :func:`load_urdf
<mrnea.io.urdf.load_urdf>` moves them into the chain links with the fixed joints, as it moves
the inertias.

Mesh files are located when the URDF is read (:func:`mrnea.io.mesh.mesh_path`: ``package://``,
``file://`` or a path relative to the URDF's folder) and read only when a view is drawn, which
says which it could not read (a URDF copied without its meshes, a URL: nothing is fetched).

Malformed numbers raise :class:`~mrnea.errors.RobotFileError` like any other element; a visual
the viewer cannot draw (no or unknown geometry, a size <= 0) is left out with one UserWarning
per file, since it does not change the dynamics.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from typing import TYPE_CHECKING

from mrnea.errors import ModelError, quote, shorten
from mrnea.io.mesh import mesh_path
from mrnea.visual import Visual

if TYPE_CHECKING:
    from mrnea.io.urdf import _Reader

__all__ = ["materials", "visuals"]

_SHAPES = {"box": (("size", 3),), "cylinder": (("radius", 1), ("length", 1)),
           "sphere": (("radius", 1),), "capsule": (("radius", 1), ("length", 1))}


def materials(rd: _Reader, root: ET.Element) -> dict[str, tuple[float, ...]]:
    """Colour ``(r, g, b, a)`` of each top-level ``<material name>`` that has a ``<color>``."""
    out = {}
    for m in root.findall("material"):
        name, color = m.get("name"), m.find("color")
        if name and color is not None:
            out[name] = tuple(rd.floats(color, "rgba", 4, f"material {quote(name)}"))
    return out


def _color(rd: _Reader, visual: ET.Element, named: dict[str, tuple[float, ...]],
           what: str) -> tuple[float, ...] | None:
    m = visual.find("material")
    if m is None:
        return None
    color = m.find("color")
    if color is not None:
        return tuple(rd.floats(color, "rgba", 4, f"{what} <material>"))
    return named.get(m.get("name") or "")


def visuals(rd: _Reader, link: ET.Element, name: str, named: dict[str, tuple[float, ...]],
            left_out: list[str]) -> list[Visual]:
    """The visuals of one ``<link>`` element, in its frame; what cannot be drawn is appended to
    ``left_out`` (one line each) instead."""
    out = []
    for k, elem in enumerate(link.findall("visual")):
        what = f"link {quote(name)} <visual> #{k + 1}"
        origin = rd.origin(elem, what)
        geometry = elem.find("geometry")
        shape = None if geometry is None else next(iter(geometry), None)
        if shape is None or shape.tag not in (*_SHAPES, "mesh"):
            left_out.append(f"{what}: no geometry the viewer draws "
                            f"({'none' if shape is None else f'<{shorten(shape.tag)}>'})")
            continue
        color = _color(rd, elem, named, what)
        mesh = None
        if shape.tag == "mesh":
            filename = rd.required(shape, "filename", what)
            size = tuple(rd.floats(shape, "scale", 3, what, (1.0, 1.0, 1.0)))
            mesh = mesh_path(filename, rd.path)
        else:
            size = tuple(float(x) for attr, count in _SHAPES[shape.tag]
                         for x in rd.floats(shape, attr, count, what))
        try:
            out.append(Visual(shape.tag, size, origin, color, mesh))
        except ModelError as exc:
            left_out.append(f"{what}: {exc}")
    return out
