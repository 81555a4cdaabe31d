"""The variants of a design sweep: its parameters, their rules, and the check of a grid.

Usage: ``robot_b = variant(robot, payload=5.0, **{"gear_ratio.cab_yaw": 100})``;
``keys, cases = check_grid(robot, grid)`` (the program side, ``time_scale``:
:mod:`mrnea.sweep.timescale`).

Parameters (a grid key is ``param`` for every joint or ``param.<joint>`` for one):

====================== ======= ==========================================================
``payload``            robot   mass [kg] fixed to the last link, merged into its inertials
``payload_point``      robot   (3,) its position [m] in the last link's frame (default the
                               frame's origin); only with ``payload``
``gear_ratio``         joint   G, motor turns per joint turn (> 0); keeps the motor (rule 1)
``effort_limit``       joint   joint-side peak effort [N m | N]; a torque-speed curve is
                               scaled to it, its shape kept (rule 2)
``motor_torque_limit`` joint   motor-side peak torque [N m]: the joint-side peak is it x G
``rotor_inertia``      joint   J_m [kg m^2], motor side
``viscous_friction``   joint   F_v [N m s/rad | N s/m], joint side
``coulomb_friction``   joint   F_s [N m | N], joint side
``velocity_limit``     joint   the joint's speed limit [rad/s | m/s]
``efficiency``         joint   the gear's efficiency eta in [0.01, 1], driving and back-driven
                               alike (a [driving, back-driven] pair: the robot's own file)
``time_scale``         program the program's duration x this factor (2: twice as slow)
====================== ======= ==========================================================

A value for every joint is one number (the same for each joint) or n numbers (root to tip); a
``param.<joint>`` key overrides the all-joints value for that joint.

Rules, per joint, in this order:

1. ``gear_ratio`` G_old -> G keeps the motor: its motor-side torque limit and its speeds stay.
   So the joint-side effort limit (a torque-speed curve's peak too) scales by G / G_old and the
   curve's corner and no-load speeds (joint side) by G_old / G. ``velocity_limit`` does not
   scale: it is the joint's limit (the application's: the SDT's planetary limit is a g-load
   limit, a URDF's limits are the joint's specification); the motor's speed is its
   torque-speed curve, which does. Rotor inertia (motor side) stays, so the reflected G^2 J_m
   changes; the friction values (joint side) stay.
2. ``effort_limit`` sets the joint-side peak (after rule 1: with ``gear_ratio`` it is the peak
   of the new drive); a curve keeps its speeds, so its shape: every point of it scales with
   the peak.
3. ``motor_torque_limit`` sets the peak to the motor limit x the variant's G. It and
   ``effort_limit`` on the same joint is an error.
4. ``rotor_inertia``, ``viscous_friction``, ``coulomb_friction``, ``velocity_limit`` and
   ``efficiency`` replace the joint's value.
5. ``payload``: the last link's mass, centre of mass and inertia become those of the link and
   the payload together (:meth:`mrnea.Robot.with_payload`, a point mass). A robot that carries
   a payload already (the command line's ``--payload``) carries both.

``time_scale`` acts on the program (:func:`mrnea.sweep.timescale.time_scaled`);
:func:`variant` accepts and ignores it, so that ``variant(robot, **params)`` rebuilds the robot
of any sweep row from its parameter columns.
"""

from __future__ import annotations

import builtins
import dataclasses
import itertools
import math
import numbers
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.errors import MrneaError, SweepError, listing, quote
from mrnea.frozen import MAGNITUDES
from mrnea.io.program import Program
from mrnea.io.tomlcheck import did_you_mean
from mrnea.model import Robot
from mrnea.resources import require_memory
from mrnea.sweep.timescale import time_scaled

__all__ = ["JOINT_PARAMETERS", "PARAMETERS", "check_grid", "units", "variant"]

JOINT_PARAMETERS = ("gear_ratio", "effort_limit", "motor_torque_limit", "rotor_inertia",
                    "viscous_friction", "coulomb_friction", "velocity_limit", "efficiency")
ROBOT_PARAMETERS = ("payload", "payload_point")
PROGRAM_PARAMETERS = ("time_scale",)
PARAMETERS = (*ROBOT_PARAMETERS, *JOINT_PARAMETERS, *PROGRAM_PARAMETERS)
#: Each parameter's unit, (revolute joint, prismatic joint); "" for a pure number.
UNITS = {"payload": ("kg", "kg"), "payload_point": ("m", "m"), "gear_ratio": ("", ""),
         "effort_limit": ("N m", "N"), "motor_torque_limit": ("N m", "N m"),
         "rotor_inertia": ("kg m^2", "kg m^2"), "viscous_friction": ("N m s/rad", "N s/m"),
         "coulomb_friction": ("N m", "N"), "velocity_limit": ("rad/s", "m/s"),
         "efficiency": ("", ""), "time_scale": ("", "")}
_UNBOUNDED = ("effort_limit", "motor_torque_limit", "velocity_limit")  # inf: unlimited
_REPLACED = ("rotor_inertia", "viscous_friction", "coulomb_friction", "velocity_limit",
             "efficiency")
#: Peak memory per row in the client [bytes], ROW_BYTES + ROW_BYTES_PER_JOINT n: the case's
#: dict, the row's dict as it came back, and the DataFrame made of them (measured with
#: tracemalloc: 12.1 kB per row for n = 4, 14.4 kB for n = 6 with the summary's 25 numbers
#: per joint; 12.3 and 21.2 kB after the summary grew, 2026-11-27; tests/test_sweep_variants.py
#: checks the bound).
ROW_BYTES, ROW_BYTES_PER_JOINT = 3000, 4000


# --- parameters ----------------------------------------------------------------------------


def _split(robot: Robot, key: str) -> tuple[str, int | None]:
    """``param`` or ``param.<joint>`` -> (param, joint index or None); names the key at fault."""
    if not isinstance(key, str):
        raise SweepError(f"grid: keys are parameter names (str), got {quote(key)}")
    param, dot, joint = key.partition(".")
    if param not in PARAMETERS:
        raise SweepError(f"grid entry {quote(key)}: unknown parameter {quote(param)}"
                         f"{did_you_mean(param, PARAMETERS)}; parameters: "
                         f"{', '.join(PARAMETERS)}")
    if not dot:
        return param, None
    if param not in JOINT_PARAMETERS:
        raise SweepError(f"grid entry {quote(key)}: '{param}' is not a joint parameter; write "
                         f"'{param}' alone")
    if joint not in robot.joint_names:
        raise SweepError(f"grid entry {quote(key)}: robot {quote(robot.name)} has no joint "
                         f"{quote(joint)}{did_you_mean(joint, robot.joint_names)}; its joints: "
                         f"{listing(robot.joint_names)}")
    return param, robot.joint_names.index(joint)


def units(robot: Robot, keys: Sequence[str]) -> dict[str, str]:
    """Each grid key's unit on ``robot`` ("" for a ratio; ``"N m | N"`` for an all-joints key
    on a robot with both kinds of joint), e.g. for a figure's axis."""
    out = {}
    for key in keys:
        param, i = _split(robot, key)
        kinds = {robot.joints[k].is_prismatic for k in ([i] if i is not None
                                                         else range(robot.n))}
        out[key] = " | ".join(dict.fromkeys(UNITS[param][p] for p in sorted(kinds)))
    return out


def _number(key: str, value: Any, allow_inf: bool) -> float:
    """``value`` as a float: a real number (not a bool or text), not NaN, finite unless
    ``allow_inf``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise SweepError(f"grid entry {quote(key)}: {quote(value)} is not a number")
    v = float(value)
    if math.isnan(v) or (math.isinf(v) and not allow_inf):
        raise SweepError(f"grid entry {quote(key)}: {v} is not a finite number")
    return v


def _joint_values(robot: Robot, params: Mapping[str, Any]) -> dict[str, dict[int, float]]:
    """Per joint parameter: {joint index: value}; all-joints values first, then overrides."""
    out: dict[str, dict[int, float]] = {p: {} for p in JOINT_PARAMETERS}
    split = [(key, *_split(robot, key)) for key in params]
    for key, param, i in sorted(split, key=lambda s: s[2] is not None):
        if param not in JOINT_PARAMETERS:
            continue
        value, inf = params[key], param in _UNBOUNDED
        if i is not None:
            out[param][i] = _number(key, value, inf)
        elif isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, (str, bytes)):
            if len(value) != robot.n:
                raise SweepError(f"grid entry {quote(key)}: a value for every joint is one "
                                 f"number or {robot.n} (one per joint), got {len(value)}")
            out[param].update({k: _number(key, v, inf) for k, v in enumerate(value)})
        else:
            out[param].update(dict.fromkeys(range(robot.n), _number(key, value, inf)))
    both = sorted(set(out["effort_limit"]) & set(out["motor_torque_limit"]))
    if both:
        raise SweepError(f"grid: effort_limit and motor_torque_limit both set the limit of "
                         f"joint(s) {listing(robot.joint_names[i] for i in both)}; give one")
    return out


def _payload_point(value: Any) -> NDArray:
    """``payload_point`` as a (3,) array of finite numbers."""
    try:
        p = np.asarray(value, dtype=float) if isinstance(value, (Sequence, np.ndarray)) and \
            not isinstance(value, (str, bytes)) else None
    except (TypeError, ValueError):
        p = None
    if p is None or p.shape != (3,) or not np.isfinite(p).all() or any(
            isinstance(x, (bool, np.bool_)) for x in value):
        raise SweepError(f"grid entry 'payload_point': expected [x, y, z], three finite "
                         f"numbers [m], got {quote(value)}")
    if np.abs(p).max() > MAGNITUDES["length"]:
        raise SweepError(f"grid entry 'payload_point': {quote(value)} is beyond "
                         f"{MAGNITUDES['length']:g} m, the largest length mrnea accepts")
    return p


def variant(robot: Robot, **params: Any) -> Robot:
    """The robot with the sweep parameters ``params`` applied (rules: the module docstring).

    Parameters
    ----------
    robot : Robot
        The base robot.
    **params
        Grid keys and one value each, e.g. ``variant(robot, payload=5.0,
        **{"gear_ratio.cab_yaw": 100})``; ``time_scale`` is accepted and ignored (it acts on
        the program: :func:`time_scaled`).

    Returns
    -------
    Robot
        A new validated Robot, or ``robot`` itself when nothing changes.

    Raises
    ------
    SweepError
        An unknown parameter or joint, a value that is not a number, conflicting limits.
    ModelError
        A value the robot cannot take (a negative gear ratio...), naming the joint.
    """
    validate.require_robot(robot)
    per_joint = _joint_values(robot, params)
    joints, changed = list(robot.joints), False
    for i, j in enumerate(robot.joints):
        change: dict[str, Any] = {}
        peak, curve = j.effort_limit, j.torque_speed
        speeds = None if curve is None else curve[1:]
        G = per_joint["gear_ratio"].get(i, j.gear_ratio)
        if G != j.gear_ratio:  # rule 1: the motor stays
            dataclasses.replace(j, gear_ratio=G)  # the model's check of G, before it is used
            change["gear_ratio"] = G
            r = G / j.gear_ratio
            peak = peak * r
            speeds = None if curve is None else (curve[1] / r, curve[2] / r)
        peak = per_joint["effort_limit"].get(i, peak)  # rule 2
        if i in per_joint["motor_torque_limit"]:  # rule 3
            peak = per_joint["motor_torque_limit"][i] * G
        if curve is not None and (peak, *speeds) != curve:
            change["torque_speed"] = (peak, *speeds)
        elif curve is None and peak != j.effort_limit:
            change["effort_limit"] = peak
        for name in _REPLACED:  # rule 4
            if i in per_joint[name] and per_joint[name][i] != getattr(j, name):
                change[name] = per_joint[name][i]
        if change:
            joints[i], changed = dataclasses.replace(j, **change), True
    if changed:
        robot = Robot(joints, robot.links, gravity=robot.gravity, name=robot.name,
                      base=robot.base)
    if "payload" in params:  # rule 5
        mass = _number("payload", params["payload"], False)
        point = _payload_point(params.get("payload_point", (0.0, 0.0, 0.0)))
        if mass != 0.0:
            robot = robot.with_payload(mass, point)
    elif "payload_point" in params:
        raise SweepError("grid entry 'payload_point': needs 'payload' (the mass) too")
    return robot


# --- the grid ------------------------------------------------------------------------------


def _list(key: str, values: Any) -> Sequence[Any]:
    """A grid entry's list of values (a list, tuple or 1-D array), not empty; not copied."""
    if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, (Sequence,
                                                                            np.ndarray)):
        raise SweepError(f"grid entry {quote(key)}: expected a list of values, got "
                         f"{type(values).__name__} {quote(values)}")
    if len(values) == 0:
        raise SweepError(f"grid entry {quote(key)}: the list of values is empty")
    return values


def _values(values: Sequence[Any]) -> list[Any]:
    """A grid entry's values as Python objects (an array's rows as lists)."""
    return [v.tolist() if isinstance(v, np.ndarray) else v for v in values]


def _check_value(robot: Robot, key: str, value: Any) -> None:
    """The value alone, on the robot: the model's own checks name what is wrong."""
    if key == "time_scale":
        if _number(key, value, False) <= 0:
            raise SweepError("a time scale must be > 0")
    elif key == "payload_point":
        _payload_point(value)
    else:
        variant(robot, **{key: value})


def check_grid(robot: Robot, grid: Mapping[str, Any], zip: bool = False,
               programs: Sequence[Program] = ()
               ) -> tuple[tuple[str, ...], list[dict[str, Any]]]:
    """Check a grid against ``robot`` (and ``programs``) and list its cases, before any
    simulation runs.

    The grid's size is checked first (lengths only: a list of 10^7 values is refused by the
    memory its rows would take in about a second, before any value is looked at); then every
    value is tried alone on the robot (``variant(robot, **{key: value})``), so a value the
    robot cannot take is reported with its grid entry and position; then each program at each
    ``time_scale`` (:func:`time_scaled`: its memory, at least two cycles, its path kept at the
    same dt). Combinations that fail later become rows with an error.

    Parameters
    ----------
    robot : Robot
    grid : mapping
        Parameter (module docstring) -> list of values.
    zip : bool
        Take the lists in step (all of one length) instead of their product.
    programs : sequence of Program
        The sweep's programs, each checked at each ``time_scale`` (none: not checked).

    Returns
    -------
    keys : tuple of str
        The grid's keys, in its order.
    cases : list of dict
        One dict of parameter values per variant: the product of the lists (first key
        slowest), or with ``zip`` the lists taken in step.

    Raises
    ------
    SweepError
        A bad grid, naming the entry (and the value's position in its list).
    """
    keys, cases, _ = grid_cases(robot, grid, zip, programs)
    return keys, cases


def grid_cases(robot: Robot, grid: Mapping[str, Any], zip: bool, programs: Sequence[Program]
               ) -> tuple[tuple[str, ...], list[dict[str, Any]], dict[tuple[int, float], Program]]:
    """:func:`check_grid`'s keys and cases, and each program at each time scale of the grid,
    scaled once for both the check and the runs: ``{(program number, scale): program}`` (the
    scale 1.0 alone without ``time_scale``: each program itself)."""
    validate.require_robot(robot)
    if not isinstance(grid, Mapping):
        raise SweepError(f"grid: expected a mapping of parameter -> list of values, got "
                         f"{type(grid).__name__}")
    if not isinstance(zip, (bool, np.bool_)):
        raise SweepError(f"zip: expected True or False, got {type(zip).__name__} {quote(zip)}")
    if not grid:
        raise SweepError("grid: no parameter; give at least one, e.g. "
                         "{'gear_ratio': [60, 80, 100]}")
    keys = tuple(grid)
    for key in keys:
        _split(robot, key)
    lengths = [len(_list(key, grid[key])) for key in keys]
    if zip and len(set(lengths)) > 1:
        raise SweepError("grid: zip needs lists of one length, got " + ", ".join(
            f"{quote(k)}: {n}" for k, n in builtins.zip(keys, lengths, strict=True)))
    count = lengths[0] if zip else math.prod(lengths)  # the size first, then the values
    require_memory(float(count) * (ROW_BYTES + ROW_BYTES_PER_JOINT * robot.n),
                   f"a sweep of {count:.3g} variants", "sweep fewer values at once, or split "
                   "the grid into several sweeps", SweepError)
    if "payload_point" in keys and "payload" not in keys:
        raise SweepError("grid entry 'payload_point': needs 'payload' (the mass) too")
    lists = {key: _values(grid[key]) for key in keys}
    for key, vals in lists.items():
        for k, value in enumerate(vals):
            try:
                _check_value(robot, key, value)
            except MrneaError as exc:
                raise SweepError(f"grid entry {quote(key)} value {k + 1} ({quote(value)}): "
                                 f"{str(exc).removeprefix(f'grid entry {quote(key)}: ')}"
                                 ) from None
    _joint_values(robot, {key: lists[key][0] for key in keys})  # conflicting limit keys
    scaled: dict[tuple[int, float], Program] = {}
    for k, value in enumerate(lists.get("time_scale", [1.0])):  # each program at each scale
        for p, prog in enumerate(programs):
            try:  # its memory, its cycles, its path kept (time_scaled's own checks)
                scaled[p, float(value)] = time_scaled(prog, float(value))
            except MrneaError as exc:
                raise SweepError(f"grid entry 'time_scale' value {k + 1} ({quote(value)}): "
                                 f"{exc}") from None
    combos = builtins.zip(*lists.values(), strict=True) if zip else itertools.product(
        *lists.values())
    return keys, [dict(builtins.zip(keys, c, strict=True)) for c in combos], scaled
