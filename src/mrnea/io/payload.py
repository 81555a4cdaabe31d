"""Payloads: a mass rigidly fixed to a link (the last by default), given as ``KG[@X,Y,Z]``,
``KG@LINK[:X,Y,Z]`` or a small TOML file.

The command line's ``--payload`` and a program's ``payload`` key take the same three forms:

* ``"2.5"`` or ``"2.5@0,0,0.08"``: a point mass [kg] at a point [m] of the last link's frame
  (its origin if no point is given), the frame of ``f_ext_point``;
* ``"2@left_hand:0,0,0.1"`` or ``"2@left_hand"``: the same on the link named (a branching
  robot's hand), the point in that link's frame; a link the robot does not have is an error
  naming it when the robot is loaded;
* the path of a payload file (any other string), with an inertia too::

      mass = 2.5                        # kg
      com = [0.0, 0.0, 0.08]            # m, the link's frame (default: its origin)
      inertia = { ixx = 0.004, iyy = 0.004, izz = 0.002 }   # kg m^2 about the com (default 0)
      link = "left_hand"                # default: the last link

  ``inertia`` is written as in a robot file's link table (a table, products ``ixy``, ``ixz``,
  ``iyz`` default 0, or a 3x3 array), in axes parallel to the link's frame.

:meth:`mrnea.model.Robot.with_payload` merges it into the link.
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ModelError, MrneaError, RobotFileError, quote
from mrnea.io.native import _inertia
from mrnea.io.source import expand_home, parse_number, read_text
from mrnea.io.tomlcheck import TomlCheck
from mrnea.model import Link

__all__ = ["Payload", "parse_payload", "parse_vector"]

_KEYS = ("mass", "com", "inertia", "link")
_POINT_MASS = re.compile(r"\s*([^@\s]+)\s*(?:@(.*))?")


class Payload(NamedTuple):
    """A payload: ``mass`` [kg], ``com`` (3,) [m] and ``inertia`` (3, 3) [kg m^2] about the com,
    both in the frame of ``link`` (None: the last link); the arguments of
    :meth:`mrnea.Robot.with_payload`."""

    mass: float
    com: NDArray[np.float64]
    inertia: NDArray[np.float64]
    link: str | None = None


def parse_vector(text: str, length: int, what: str, error: type[MrneaError]) -> NDArray:
    """``"x,y,z"`` as ``length`` finite numbers (:func:`~mrnea.io.source.parse_number`'s
    grammar, spaces around the commas allowed); ``error`` names ``what`` otherwise."""
    try:
        v = np.array([parse_number(x.strip()) for x in text.split(",")])
    except ValueError:
        v = np.array([])
    if v.size != length:
        raise error(f"{what}: expected {length} finite numbers separated by commas, got "
                    f"{quote(text)}")
    return v


def parse_payload(spec: str, base_dir: str | Path | None = None,
                  error: type[MrneaError] = RobotFileError) -> Payload:
    """A payload from ``KG[@X,Y,Z]`` or from a payload file (see the module docstring).

    Parameters
    ----------
    spec : the text: a number, optionally ``@`` and three numbers or ``@LINK[:X,Y,Z]``, else
        a file's path.
    base_dir : the folder a relative file path is taken in (a program's folder); None: the
        current folder.
    error : the error raised for a malformed ``KG[@X,Y,Z]`` (the file's errors are
        :class:`~mrnea.errors.RobotFileError`, naming the file and key).
    """
    if not isinstance(spec, str):
        raise error(f"payload: expected KG[@X,Y,Z] or a payload file's path (str), got "
                    f"{type(spec).__name__} {quote(spec)}")
    m = _POINT_MASS.fullmatch(spec)
    try:
        mass = parse_number(m.group(1)) if m else math.nan
    except ValueError:
        mass = math.nan
    if m and (math.isfinite(mass) or m.group(2) is not None):
        if not (math.isfinite(mass) and mass >= 0):
            raise error(f"payload {quote(spec)}: the mass must be a number >= 0 [kg]")
        where, link = m.group(2), None
        if where is not None and not where.strip():  # "2@": not a link named ""
            raise error(f"payload {quote(spec)}: nothing after '@' (give X,Y,Z or LINK[:X,Y,Z])")
        if where is not None and (":" in where or "," not in where):  # KG@LINK[:X,Y,Z]
            link, colon, where = where.partition(":")
            link, where = link.strip(), where or None
            if not link:
                raise error(f"payload {quote(spec)}: no link name between '@' and ':'")
            if colon and where is None:  # "2@hand:": a point forgotten, not the origin
                raise error(f"payload {quote(spec)}: no point after ':' (give X,Y,Z, or leave "
                            f"':' out for the link's origin)")
        com = (np.zeros(3) if where is None else
               parse_vector(where, 3, f"payload {quote(spec)}: the point after "
                                      f"'{':' if link else '@'}'", error))
        return Payload(mass, com, np.zeros((3, 3)), link)
    if not spec.strip():  # Path("") is the current folder: "looked for ." said nothing
        raise error("payload: an empty value; give KG[@X,Y,Z], KG@LINK[:X,Y,Z] or a payload "
                    "file's path")
    path = expand_home(Path(spec), lambda m: error(f"payload: {m}"))
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    try:
        is_file = path.is_file()
    except OSError:  # a name the system refuses (too long): not a file
        is_file = False
    if path.suffix.lower() != ".toml" and not is_file:
        raise error(f"payload {quote(spec)}: neither a mass with an optional point, KG[@X,Y,Z] "
                    f"(e.g. 2.5@0,0,0.1), nor a payload file (looked for {path})")
    return _read(path)


def _read(path: Path) -> Payload:
    check = TomlCheck(str(path), RobotFileError)
    doc = check.parse(read_text(path, "payload file", RobotFileError))
    check.check_keys(doc, _KEYS, "top level")
    mass = check.number(check.require(doc, "mass", "top level"), "top level", "mass")
    if mass < 0:
        raise check.error("top level", f"'mass' must be >= 0 kg, got {mass}")
    com = check.vector(doc.get("com", [0.0, 0.0, 0.0]), "top level", "com", 3)
    inertia = (_inertia(check, doc["inertia"], "top level") if "inertia" in doc
               else np.zeros((3, 3)))
    link = check.string(doc["link"], "top level", "link") if "link" in doc else None
    try:
        Link("payload", mass, com, inertia)
    except ModelError as exc:
        raise check.error("", str(exc)) from None
    return Payload(mass, com, inertia, link)
