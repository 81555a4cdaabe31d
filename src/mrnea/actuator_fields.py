"""The actuator fields of a :class:`~mrnea.model.Joint`: their list and their checks.

:data:`ACTUATOR_FIELDS` names each field once, with its symbol, unit and meaning (the model's
conventions: :mod:`mrnea.model`). :func:`check_actuator_fields` validates a joint's fields when it
is constructed (the efforts, gear, friction and torque-speed curve, each error naming the joint);
:func:`actuator_values` turns the keywords of :meth:`mrnea.model.Robot.with_actuators` into one
value per joint. The model imports this module, never the reverse (docs/design.md).
"""

from __future__ import annotations

import math
import numbers
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from mrnea.errors import ModelError, quote
from mrnea.frozen import check_magnitude, real_number

if TYPE_CHECKING:
    from mrnea.model import Joint


class ActuatorField(NamedTuple):
    """One actuator field of a :class:`~mrnea.model.Joint`: its name, the symbol tables use,
    unit, meaning."""

    name: str
    symbol: str
    unit: str
    meaning: str


# The actuator fields, in one list: the keywords of Robot.with_actuators, the columns of
# mrnea.describe's tables, the actuator array of the kernels (kernels/layout.py
# compile_actuators) and the table of docs/robot-format.md (a test checks that the two agree).
# Adding a field starts here.
ACTUATOR_FIELDS = (
    ActuatorField("effort_limit", "effort", "N m or N",
                  "joint-side effort limit (inf: unlimited); with a torque-speed curve, its peak"),
    ActuatorField("gear_ratio", "G", "-", "motor turns per joint turn, in [1e-6, 1e6]"),
    ActuatorField("rotor_inertia", "J_m", "kg m^2", "rotor inertia, motor side"),
    ActuatorField("viscous_friction", "F_v", "N m s/rad or N s/m", "viscous friction, joint side"),
    ActuatorField("coulomb_friction", "F_s", "N m or N",
                  "Coulomb friction, joint side: one magnitude, or two (positive direction, "
                  "negative direction)"),
    ActuatorField("torque_speed", "curve", "N m or N, rad/s or m/s",
                  "(peak, corner_speed, no_load_speed), joint side: above the corner speed "
                  "the effort limit falls (None, '-' in tables: a constant limit)"),
    ActuatorField("efficiency", "eta", "-",
                  "gear efficiency in [0.01, 1]: one value, or two (driving, back-driven); the "
                  "limit is eta times the effort limit driving, 1 / eta times it back-driven"),
)
GEAR_RANGE = (1e-6, 1e6)  # motor turns per joint turn; beyond it tau / G and G^2 J_m overflow


def _coulomb(value: object, what: str) -> float | tuple[float, float]:
    """Coulomb friction: a magnitude >= 0, or two ``(positive direction, negative direction)``;
    an equal pair is stored as one number."""
    pair = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value, value]
    if len(pair) != 2:
        raise ModelError(f"{what}: coulomb_friction must be a number or two, [positive "
                         f"direction, negative direction], got {value!r}")
    p, m = (real_number(v, f"{what}: coulomb_friction") for v in pair)
    if p < 0 or m < 0:
        raise ModelError(f"{what}: coulomb_friction must be >= 0, got {value!r}")
    return p if p == m else (p, m)


#: The smallest gear efficiency mrnea takes: below 1 % a gear delivers next to nothing and the
#: drive law's tau / eta runs out of every bound (1e-300 gave a 300-digit effort ratio).
EFFICIENCY_MIN = 0.01


def _efficiency(value: object, what: str) -> float | tuple[float, float]:
    """Gear efficiency: a value in [:data:`EFFICIENCY_MIN`, 1], or two ``(driving,
    back-driven)``; an equal pair is stored as one number."""
    pair = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value, value]
    if len(pair) != 2:
        raise ModelError(f"{what}: efficiency must be a number or two, [driving, back-driven], "
                         f"got {value!r}")
    d, b = (real_number(v, f"{what}: efficiency") for v in pair)
    if not (EFFICIENCY_MIN <= d <= 1.0 and EFFICIENCY_MIN <= b <= 1.0):
        raise ModelError(f"{what}: efficiency must be in [{EFFICIENCY_MIN:g}, 1], got "
                         f"{quote(value)}")
    return d if d == b else (d, b)


def _pairs_per_joint(key: str, value: object, n: int, pair: str) -> list[object]:
    """with_actuators' coulomb_friction or efficiency: one number, or n entries (a number or a
    pair each)."""
    if not isinstance(value, (list, tuple)) and np.ndim(value) == 0:  # type: ignore[arg-type]
        return [value] * n
    if len(value) != n:
        raise ModelError(f"with_actuators: {key} must be a number or {n} entries (a "
                         f"number or a [{pair}] pair each), got {value!r}")
    return [tuple(e) if isinstance(e, (list, tuple, np.ndarray)) else e for e in value]


def check_actuator_fields(joint: Joint, what: str) -> dict[str, object]:
    """The validated actuator fields and velocity limit of ``joint`` (``what`` names it in
    errors), by field name: velocity and effort limits >= 0 (``inf``: unlimited), rotor inertia
    and viscous friction >= 0, Coulomb friction and efficiency as one value or a pair, the gear
    ratio within :data:`GEAR_RANGE`, a torque-speed curve (its peak becomes the effort limit).
    Raises ModelError."""
    values: dict[str, object] = {}
    for name in ("velocity_limit", "effort_limit"):
        v = real_number(getattr(joint, name), f"{what}: {name}", allow_inf=True)
        if v < 0:
            raise ModelError(f"{what}: {name} must be >= 0, got {v}")
        values[name] = v
    for name in ("rotor_inertia", "viscous_friction"):
        v = real_number(getattr(joint, name), f"{what}: {name}")
        if v < 0:
            raise ModelError(f"{what}: {name} must be >= 0, got {v}")
        check_magnitude(v, name, what, "kg m^2" if name == "rotor_inertia" else
                        "N s/m" if joint.type == "prismatic" else "N m s/rad")
        values[name] = v
    values["coulomb_friction"] = _coulomb(joint.coulomb_friction, what)
    check_magnitude(values["coulomb_friction"], "coulomb_friction", what,
                    "N" if joint.type == "prismatic" else "N m")
    values["efficiency"] = _efficiency(joint.efficiency, what)
    g = real_number(joint.gear_ratio, f"{what}: gear_ratio")
    if g <= 0:
        raise ModelError(f"{what}: gear_ratio must be > 0, got {g}")
    if not GEAR_RANGE[0] <= g <= GEAR_RANGE[1]:
        raise ModelError(f"{what}: gear_ratio {g} is outside {list(GEAR_RANGE)}, the range "
                         f"of real drive trains mrnea accepts")
    values["gear_ratio"] = g
    if joint.torque_speed is not None:
        try:
            peak, corner, no_load = (float(x) for x in joint.torque_speed)
        except (TypeError, ValueError):
            raise ModelError(
                f"{what}: torque_speed must be (peak, corner_speed, no_load_speed), "
                f"got {joint.torque_speed!r}") from None
        if not (0 <= peak < math.inf and 0 < corner <= no_load and math.isfinite(corner)):
            raise ModelError(
                f"{what}: torque_speed needs 0 <= peak < inf and "
                f"0 < corner_speed <= no_load_speed, got {joint.torque_speed!r}")
        values["torque_speed"] = (peak, corner, no_load)
        values["effort_limit"] = peak
    return values


def actuator_values(fields: dict[str, object], n: int) -> dict[str, list]:
    """The keywords of :meth:`mrnea.model.Robot.with_actuators` (any of :data:`ACTUATOR_FIELDS`,
    see there) as one value per joint of a robot of n joints, by field name (``effort_limit``
    also clears every torque-speed curve). Raises ModelError naming the keyword."""
    fields = dict(fields)
    names = [f.name for f in ACTUATOR_FIELDS]
    unknown = set(fields) - set(names)
    if unknown:
        raise ModelError(
            f"with_actuators: unknown field(s) {sorted(unknown)}; "
            f"expected some of {names}"
        )

    def values(key: str, v: object) -> list[float]:
        """A real number for every joint, or one for each (n,)."""
        try:
            arr = np.asarray(v)
        except (TypeError, ValueError):  # ragged
            arr = np.asarray(None)
        if arr.dtype.kind not in "iuf" or arr.ndim > 1 or arr.size not in (1, n):
            raise ModelError(f"with_actuators: {key} must be a real number or {n} of them "
                             f"(one per joint), got {type(v).__name__} {quote(v)}")
        return [float(x) for x in np.broadcast_to(arr.astype(float), (n,))]

    def triple(c: object, key: str) -> tuple[float, float, float]:
        arr = np.asarray(c) if isinstance(c, (list, tuple, np.ndarray)) else np.asarray(None)
        if arr.dtype.kind not in "iuf" or arr.shape != (3,):
            raise ModelError(f"with_actuators: {key} must be (peak, corner_speed, "
                             f"no_load_speed), got {type(c).__name__} {quote(c)}")
        return tuple(float(x) for x in arr)  # type: ignore[return-value]

    per_joint: dict[str, list] = {}
    if "torque_speed" in fields:
        curves = fields.pop("torque_speed")
        if curves is None:
            per_joint["torque_speed"] = [None] * n
        elif isinstance(curves, (list, tuple, np.ndarray)) and all(
                isinstance(c, numbers.Real) for c in curves):  # one triple for every joint
            per_joint["torque_speed"] = [triple(curves, "torque_speed")] * n
        elif isinstance(curves, (list, tuple, np.ndarray)) and len(curves) == n:
            per_joint["torque_speed"] = [None if c is None else
                                         triple(c, f"torque_speed[{i}]")
                                         for i, c in enumerate(curves)]
        else:
            raise ModelError(f"with_actuators: torque_speed must be None, one (peak, "
                             f"corner_speed, no_load_speed) triple or {n} entries (a triple "
                             f"or None each), got {type(curves).__name__} {quote(curves)}")
    if "effort_limit" in fields:
        per_joint["torque_speed"] = [None] * n
    if "coulomb_friction" in fields:
        per_joint["coulomb_friction"] = _pairs_per_joint(
            "coulomb_friction", fields.pop("coulomb_friction"), n,
            "positive, negative")
    if "efficiency" in fields:
        per_joint["efficiency"] = _pairs_per_joint("efficiency", fields.pop("efficiency"), n,
                                                   "driving, back-driven")
    for k, v in fields.items():
        per_joint[k] = values(k, v)
    return per_joint
