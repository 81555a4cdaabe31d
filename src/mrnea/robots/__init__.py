"""Built-in robot models, each a native TOML file in ``mrnea/robots/data``.

* :func:`sdt` -- the paper's 4-DoF spatial disorientation trainer (geometry from the paper,
  inertial and drive data are documented engineering estimates: ``docs/sdt.md``).
* :func:`puma560` -- the classic Puma 560 as in Robotics Toolbox for Python
  (``rtb.models.DH.Puma560()``), with RTB's motor-side friction mapped to the joint side.

:func:`names` and :func:`load` serve the command line (``mrnea ... --robot sdt``).
"""

from __future__ import annotations

import warnings
from importlib import resources
from typing import TYPE_CHECKING

from mrnea.errors import ModelWarning, RobotFileError

if TYPE_CHECKING:
    from mrnea.model import Robot

__all__ = ["load", "names", "puma560", "sdt"]

_BUILTIN = ("sdt", "puma560")


def names() -> tuple[str, ...]:
    """Names of the built-in robots, as accepted by :func:`load`."""
    return _BUILTIN


def load(name: str) -> Robot:
    """Load a built-in robot by name (see :func:`names`).

    Raises
    ------
    RobotFileError
        If ``name`` is not a built-in robot.
    """
    if name not in _BUILTIN:
        raise RobotFileError(
            f"unknown built-in robot {name!r}; available: {', '.join(_BUILTIN)}"
        )
    # Imported here: mrnea.io imports modules that may import this package.
    from mrnea.io.native import load_native

    resource = resources.files(__name__).joinpath("data", f"{name}.toml")
    # Built-ins are curated, not the user's input: no ModelWarning. (The published Puma 560's
    # link 1 is a lumped inertia about its axis only, Izz = 0.35 with no mass, and its link 3's
    # principal moments 0.0125 + 0.066 < 0.086: both break the triangle inequality as published.)
    with resources.as_file(resource) as path, warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        return load_native(path)


def sdt() -> Robot:
    """The paper's 4-DoF spatial disorientation trainer (planetary, cabin yaw, roll, pitch).

    Geometry as in the paper (Sec. IV): ``p1* = a1 [c1, s1, 0]`` with ``a1 = 3.0 m``,
    ``p2* = [0, 0, d2]`` with ``d2 = 1.6 m``, roll and pitch axes intersecting. Masses, inertias,
    limits, gears and friction are engineering estimates for a full-size trainer
    (``docs/sdt.md``). Base frame: origin on the planetary axis at arm height, z up.
    """
    return load("sdt")


def puma560() -> Robot:
    """The Puma 560 with Robotics Toolbox's published parameters (standard DH, SI units).

    Joint-side actuator mapping: ``gear_ratio = |G|``, ``rotor_inertia = Jm``,
    ``viscous_friction = B G^2``, ``coulomb_friction = |G| (|Tc+| + |Tc-|) / 2``;
    effort limits from Armstrong, Khatib & Burdick (1986). Details in ``puma560.toml``.
    """
    return load("puma560")
