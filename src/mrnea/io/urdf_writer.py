"""URDF writer: :func:`write_urdf` writes a :class:`mrnea.Robot` as a URDF file that urdfdom (and
so Pinocchio, ROS) accepts and :func:`mrnea.io.urdf.load_urdf` reads back to the same robot.
Only the Python standard library's :mod:`xml.etree.ElementTree` is used.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from mrnea.errors import StateError
from mrnea.io.urdf import UNBOUNDED
from mrnea.io.writer import write_file
from mrnea.model import Robot
from mrnea.rigid import rpy_from_rotation

__all__ = ["write_urdf"]


def _fmt(*values: float) -> str:
    """Shortest exact decimal form; infinities as +-UNBOUNDED (urdfdom rejects ``inf``)."""
    out = []
    for v in values:
        v = float(v)
        if math.isinf(v):
            v = math.copysign(UNBOUNDED, v)
        out.append(repr(v + 0.0))  # + 0.0 turns -0.0 into 0.0
    return " ".join(out)


def write_urdf(robot: Robot, path: str | Path, overwrite: bool = False) -> Path:
    """Write ``robot`` as a URDF file.

    The file has the base link, then per joint its ``<origin xyz rpy>`` (rpy [rad] from
    :func:`mrnea.rigid.rpy_from_rotation`), ``<axis>``, ``<limit>``, ``<dynamics damping
    friction>``, the child link's ``<inertial>`` (origin at the centre of mass, axes of the link
    frame) and, when the gear ratio is not 1, a ``<transmission>`` with that
    ``<mechanicalReduction>``. :func:`load_urdf` reads it back to the same robot (up to the
    rounding of the rpy angles, ~1e-16).

    Parameters, return value and errors (OutputError) are those of
    :func:`mrnea.io.write_native`: ``path`` is written whole or not at all, never over an
    existing file unless ``overwrite``.

    Notes
    -----
    * urdfdom rejects ``inf`` and requires ``lower``/``upper``/``effort``/``velocity`` on
      revolute and prismatic joints, so unbounded limits are written as
      ``+-1.7976931348623157e+308`` (the largest double, Pinocchio's own "no limit");
      :func:`load_urdf` reads that value back as infinite. Continuous joints get no
      ``lower``/``upper``.
    * Not representable in plain URDF, hence dropped: the rotor inertia, a torque-speed curve
      (its peak is the ``effort`` written), a non-default gravity, and the asymmetry of a
      Coulomb friction ``(positive direction, negative direction)``: URDF's ``friction`` is one
      value, written as the mean of the two (:func:`mrnea.io.write_native` keeps them all).
    * Numbers are written in their shortest exact decimal form, so masses, centres of mass,
      inertias, translations, axes and limits round-trip exactly.
    """
    if not isinstance(robot, Robot):
        raise StateError(f"robot: expected a mrnea.Robot, got {type(robot).__name__}")
    root = ET.Element("robot", name=robot.name)
    ET.SubElement(root, "link", name=robot.base)
    transmissions = []
    for j, lk in zip(robot.joints, robot.links, strict=True):
        je = ET.SubElement(root, "joint", name=j.name, type=j.type)
        ET.SubElement(je, "parent", link=j.parent)
        ET.SubElement(je, "child", link=j.child)
        origin = np.asarray(j.origin)
        ET.SubElement(je, "origin", xyz=_fmt(*origin[:3, 3]),
                      rpy=_fmt(*rpy_from_rotation(origin[:3, :3])))
        ET.SubElement(je, "axis", xyz=_fmt(*j.axis))
        limit = {"effort": _fmt(j.effort_limit), "velocity": _fmt(j.velocity_limit)}
        if j.type != "continuous":
            limit = {"lower": _fmt(j.lower), "upper": _fmt(j.upper), **limit}
        ET.SubElement(je, "limit", limit)
        ET.SubElement(je, "dynamics", damping=_fmt(j.viscous_friction),
                      friction=_fmt(sum(j.coulomb_pair) / 2))  # URDF holds one value
        le = ET.SubElement(root, "link", name=lk.name)
        inertial = ET.SubElement(le, "inertial")
        ET.SubElement(inertial, "origin", xyz=_fmt(*lk.com), rpy="0.0 0.0 0.0")
        ET.SubElement(inertial, "mass", value=_fmt(lk.mass))
        inertia = np.asarray(lk.inertia)
        ET.SubElement(inertial, "inertia", {
            key: _fmt(inertia[a, b]) for key, (a, b) in (
                ("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)),
                ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2)))
        })
        if j.gear_ratio != 1.0:
            transmissions.append(j)
    for j in transmissions:
        te = ET.SubElement(root, "transmission", name=f"{j.name}_transmission")
        ET.SubElement(te, "type").text = "transmission_interface/SimpleTransmission"
        ET.SubElement(ET.SubElement(te, "joint", name=j.name), "hardwareInterface").text = (
            "hardware_interface/EffortJointInterface")
        ae = ET.SubElement(te, "actuator", name=f"{j.name}_motor")
        ET.SubElement(ae, "mechanicalReduction").text = _fmt(j.gear_ratio)
    ET.indent(root)
    text = ET.tostring(root, encoding="unicode")
    return write_file(path, f'<?xml version="1.0" encoding="utf-8"?>\n{text}\n'.encode(), overwrite)
