"""Sidecar actuator files, and the joint limit and actuator keys every TOML robot file uses.

A sidecar says what URDF cannot (rotor inertia, a torque-speed curve) or overrides what it
says; it is given next to a URDF or a native file (``load_urdf(path, actuators=...)``). The keys
are :data:`mrnea.io.dh.JOINT_FIELDS`, read by :func:`joint_fields` the same way in a native
robot file's ``[[joint]]`` tables.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from mrnea.errors import ModelError, RobotFileError, listing, quote
from mrnea.io.dh import JOINT_FIELDS
from mrnea.io.source import read_text
from mrnea.io.tomlcheck import TomlCheck, did_you_mean
from mrnea.model import Robot

__all__ = ["apply_actuator_file", "joint_fields"]


def joint_fields(check: TomlCheck, table: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The limit and actuator fields (:data:`JOINT_FIELDS`) a table sets, as Joint keywords.

    Numbers, ``torque_speed`` a ``[peak, corner_speed, no_load_speed]`` triple,
    ``coulomb_friction`` a number or a ``[positive direction, negative direction]`` pair,
    ``efficiency`` a number or a ``[driving, back-driven]`` pair; NaN is refused.
    ``effort_limit`` alone sets a constant limit (``torque_speed = None``: it replaces a curve);
    given with ``torque_speed``, it must equal the curve's peak.
    """
    out: dict[str, Any] = {}
    for key in JOINT_FIELDS:
        if key not in table:
            continue
        if key == "torque_speed":
            out[key] = tuple(check.vector(table[key], where, key, 3).tolist())
            continue
        if key in ("coulomb_friction", "efficiency") and isinstance(table[key], list):
            out[key] = tuple(check.vector(table[key], where, key, 2).tolist())
            continue
        out[key] = check.number(table[key], where, key)
        if math.isnan(out[key]):
            raise check.error(where, f"'{key}' is NaN")
    if "effort_limit" in out and "torque_speed" not in out:
        out["torque_speed"] = None
    elif "effort_limit" in out and out["effort_limit"] != out["torque_speed"][0]:
        raise check.error(where, "give either 'effort_limit' or 'torque_speed' (whose peak is "
                                 "the effort limit), not both: they differ, "
                                 f"{out['effort_limit']} != {out['torque_speed'][0]}")
    return out


def apply_actuator_file(robot: Robot, path: str | Path) -> Robot:
    """A copy of ``robot`` with the joint fields a sidecar actuator file sets.

    One TOML table per joint, named like the joint; keys (joint side, SI units)
    ``gear_ratio``, ``rotor_inertia`` [kg m^2, motor side], ``viscous_friction``,
    ``coulomb_friction`` (a number, or ``[positive direction, negative direction]``),
    ``effort_limit``, ``torque_speed = [peak, corner_speed, no_load_speed]``,
    ``efficiency`` (a number in (0, 1], or ``[driving, back-driven]``),
    ``velocity_limit``, ``lower``, ``upper``::

        [shoulder_pan_joint]
        rotor_inertia = 3.3e-5
        gear_ratio = 101
        torque_speed = [150.0, 2.0, 3.5]

    Joints the file does not name keep their values. ``effort_limit`` sets a constant limit and
    removes a curve; giving both for one joint is an error unless they agree.

    Raises
    ------
    RobotFileError
        Unreadable file, TOML syntax, a joint the robot does not have, an unknown key, a bad
        value; the message names the file and the joint.
    """
    if not isinstance(robot, Robot):
        raise RobotFileError(f"robot: expected a mrnea.Robot, got {type(robot).__name__}")
    text = read_text(path, "actuator file", RobotFileError)
    check = TomlCheck(str(path), RobotFileError, finite=False)
    data = check.parse(text)
    names = robot.joint_names
    joints = list(robot.joints)
    for jname, table in data.items():
        if jname not in names:
            raise check.error("", f"no joint named {quote(jname)} in robot {quote(robot.name)}"
                                  f"{did_you_mean(jname, names)}; its joints: {listing(names)}")
        where = f"joint {quote(jname)}"
        table = check.table(table, "", jname)
        check.check_keys(table, JOINT_FIELDS, where)
        i = names.index(jname)
        fields = joint_fields(check, table, where)  # its errors name the file already
        try:
            joints[i] = dataclasses.replace(joints[i], **fields)
        except ModelError as exc:
            raise check.error("", str(exc)) from None
    return robot._replace(joints=joints)
