"""Built-in robot models, each a native TOML file in ``mrnea/robots/data``.

* :func:`sdt` -- the paper's 4-DoF spatial disorientation trainer (geometry from the paper,
  inertial and drive data are documented engineering estimates: ``docs/sdt.md``).
* :func:`puma560` -- the classic Puma 560 as in Robotics Toolbox for Python
  (``rtb.models.DH.Puma560()``), with RTB's motor-side friction mapped to the joint side.

Loading any of them by name (the command line's ``mrnea info sdt``) is
:func:`mrnea.io.load_robot_spec`; the list of names is :data:`mrnea.io.BUILTIN_ROBOTS`.
"""

from __future__ import annotations

from mrnea.io.dispatch import load_builtin
from mrnea.model import Robot

__all__ = ["puma560", "sdt"]


def sdt() -> Robot:
    """The paper's 4-DoF spatial disorientation trainer (planetary, cabin yaw, roll, pitch).

    Geometry as in the paper (Sec. IV): ``p1* = a1 [c1, s1, 0]`` with ``a1 = 3.0 m``,
    ``p2* = [0, 0, d2]`` with ``d2 = 1.6 m``, roll and pitch axes intersecting. Masses, inertias,
    limits, gears and friction are engineering estimates for a full-size trainer
    (``docs/sdt.md``). Base frame: origin on the planetary axis at arm height, z up.
    """
    return load_builtin("sdt")


def puma560() -> Robot:
    """The Puma 560 with Robotics Toolbox's published parameters (standard DH, SI units).

    Joint-side actuator mapping: ``gear_ratio = |G|``, ``rotor_inertia = Jm``,
    ``viscous_friction = B G^2``, ``coulomb_friction = |G| [Tc+, |Tc-|]`` (asymmetric, as
    published: positive direction, negative direction);
    effort limits from Armstrong, Khatib & Burdick (1986). Details in ``puma560.toml``.
    """
    return load_builtin("puma560")
