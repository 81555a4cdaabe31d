"""What ``mrnea identify`` writes besides the robot file and the page (issue 28;
docs/identification.md): the summary (``summary.json``, strict JSON, every field and unit in the
schema the package ships, ``identify.schema.json``: :func:`schema_path`) and the identified drives
as a sidecar actuator file (``identified_drives.toml``: ``mrnea check ROBOT PROGRAM --actuators
identified_drives.toml`` answers with the identified friction and rotor inertia).

Units. A parameter's unit is its own column's (a base parameter into which others fold has the
unit of the one it is named after): m [kg], m c [kg m], I [kg m^2] about the link origin; per
joint, joint side, the reflected rotor inertia G^2 J_m [kg m^2 | kg], viscous friction
[N m s/rad | N s/m], Coulomb friction and offset [N m | N].

Standard errors of the drives. A drive parameter gets the standard error of its base parameter
when that base parameter is the drive parameter itself (the Coulomb pair with the offset folded
in, which is the pair the identified robot holds). A drive parameter that is not a base
parameter of its own (joint 1's rotor inertia about a vertical axis folds into link 1's I_zz)
has none (null, and ``folded`` names the base parameter that holds it): the log identifies only
the combination, and how the identified robot splits it follows the prior.
"""

from __future__ import annotations

import math
import re
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from mrnea.identify.regressor import (
    ACTUATOR_NAMES,
    INERTIAL_NAMES,
    actuator_parameters,
    inertial_parameters,
)
from mrnea.io.native import _string as toml_string

if TYPE_CHECKING:
    from mrnea.identify.estimate import IdentificationResult
    from mrnea.identify.log import Log
    from mrnea.model import Robot

__all__ = ["drive_standard_errors", "drives_toml", "identify_summary", "parameter_units",
           "schema_path"]

_LINK_UNITS = {"m": "kg", "mcx": "kg m", "mcy": "kg m", "mcz": "kg m"}
_DRIVE_UNITS = {"rotor": ("kg m^2", "kg"), "viscous": ("N m s/rad", "N s/m"),
                "coulomb_pos": ("N m", "N"), "coulomb_neg": ("N m", "N"), "offset": ("N m", "N")}


def schema_path() -> Any:
    """The JSON Schema (draft 2020-12) of ``mrnea identify``'s summary.json, shipped in the
    package (an :mod:`importlib.resources` traversable: ``.read_text()``)."""
    return resources.files("mrnea").joinpath("identify.schema.json")


def parameter_units(robot: Robot) -> list[str]:
    """The unit of each of theta's 15 n parameters (module docstring), in theta's order."""
    link = [_LINK_UNITS.get(p, "kg m^2") for p in INERTIAL_NAMES]
    drive = [u for j in robot.joints for p in ACTUATOR_NAMES
             for u in [_DRIVE_UNITS[p][j.is_prismatic]]]
    return link * robot.n + drive


def drive_standard_errors(result: IdentificationResult
                          ) -> tuple[NDArray[np.float64], list[list[str | None]]]:
    """(se (n, 4), within (n, 4)): the standard errors of each joint's ``G^2 J_m, F_v, F+, F-``
    (module docstring), NaN where the parameter is not a base parameter of its own, and there
    the name of the base parameter(s) whose combination holds it (else None)."""
    base, n = result.base, result.robot.n
    se = np.full((n, 4), np.nan)
    within: list[list[str | None]] = [[None] * 4 for _ in range(n)]
    row_of = {int(c): k for k, c in enumerate(base.columns)}
    for j in range(n):
        offset = 10 * n + 5 * j + 4
        for p in range(4):
            c = 10 * n + 5 * j + p
            k = row_of.get(c)
            if k is not None and not (set(np.flatnonzero(np.abs(base.K[k]) > 1e-12).tolist())
                                      - {c, offset}):
                se[j, p] = result.beta_std[k]
            else:
                rows = np.flatnonzero(np.abs(base.K[:, c]) > 1e-12)
                within[j][p] = " + ".join(base.names[base.columns[r]] for r in rows) or "none"
    return se, within


def _num(x: float) -> float | None:
    """A finite float, else None (strict JSON)."""
    x = float(x)
    return x if math.isfinite(x) else None


def _rms(p: Any, j: int) -> float | None:
    return None if p is None else _num(p.rms[j])


def identify_summary(result: IdentificationResult, prior: Robot, log: Log, log_name: str,
                     validation_log: str | None = None,
                     torque_constant: NDArray | None = None) -> dict[str, Any]:
    """``summary.json`` of an identification (identify.schema.json documents every field):
    the log and options, the condition number, every base parameter (least squares estimate,
    standard error, the identified robot's value, the prior's, unit), per joint the identified
    drive with standard errors and residuals, per link the identified rigid body."""
    robot, base = result.robot, result.base
    units = parameter_units(robot)
    prior_theta = np.concatenate([inertial_parameters(prior), actuator_parameters(prior)])
    beta_prior = base.K @ prior_theta
    params = []
    for k, (name, col) in enumerate(zip(base.base_names(), base.columns, strict=True)):
        params.append({
            "name": name, "parameter": base.names[col],
            "folded": int(np.count_nonzero(np.abs(base.K[k]) > 1e-12) - 1),
            "unit": units[col], "estimate": _num(result.beta[k]),
            "standard_error": _num(result.beta_std[k]),
            "identified": _num(result.beta_consistent[k]), "prior": _num(beta_prior[k])})
    se, within = drive_standard_errors(result)
    fields = ("reflected_rotor_inertia", "viscous_friction", "coulomb_friction_pos",
              "coulomb_friction_neg")
    joints = []
    for j, jt in enumerate(robot.joints):
        G = float(jt.gear_ratio)
        fp, fm = (float(x) for x in robot.coulomb_friction[j])
        joints.append({
            "joint": jt.name, "effort_unit": jt.unit("tau"), "gear_ratio": G,
            "rotor_inertia": float(robot.rotor_inertia[j]),
            "reflected_rotor_inertia": G ** 2 * float(robot.rotor_inertia[j]),
            "reflected_rotor_inertia_se": _num(se[j, 0]),
            "viscous_friction": float(robot.viscous_friction[j]),
            "viscous_friction_se": _num(se[j, 1]),
            "coulomb_friction_pos": fp, "coulomb_friction_pos_se": _num(se[j, 2]),
            "coulomb_friction_neg": fm, "coulomb_friction_neg_se": _num(se[j, 3]),
            "folded": {f: w for f, w in zip(fields, within[j], strict=True) if w is not None},
            "residual_std": _num(result.sigma[j]), "fit_rms": _rms(result.fit, j),
            "validation_rms": _rms(result.validation, j)})
    links = [{"link": lk.name, "mass": float(lk.mass), "com": [float(x) for x in lk.com],
              "inertia": np.asarray(lk.inertia).tolist(), "consistent": bool(ok)}
             for lk, ok in zip(robot.links, result.options["consistent"], strict=True)]
    opts = result.options
    dt = np.diff(log.time)
    return {
        "robot": robot.name, "log": log_name, "samples": int(log.K),
        "sample_rate": float(1.0 / np.median(dt)), "duration": float(log.time[-1] - log.time[0]),
        "rates": "from the log" if log.qd is not None and log.qdd is not None else "filtered",
        "cutoff": float(opts["cutoff_hz"]), "min_speed": float(opts["min_speed"]),
        "prior_weight": float(opts["prior_weight"]),
        "torque_constant": None if torque_constant is None else
        [float(x) for x in np.broadcast_to(torque_constant, (robot.n,))],
        "fit_samples": int(result.fit.time.size),
        "validation": opts["validation"],
        "validation_log": validation_log, "holdout": float(opts["holdout"]),
        "validation_samples": None if result.validation is None else
        int(result.validation.time.size),
        "condition": _num(result.condition), "base_parameters": len(params),
        "physically_consistent": all(opts["consistent"]),
        "parameters": params, "joints": joints, "links": links}


def drives_toml(result: IdentificationResult, log_name: str) -> str:
    """The identified drives as a sidecar actuator file (docs/robot-format.md): per joint its
    gear ratio (the prior's: a log cannot tell it), rotor inertia (motor side), viscous and
    Coulomb friction (F+ and F-, the offset folded in), each commented with its standard error
    or why it has none (module docstring)."""
    robot = result.robot
    se, within = drive_standard_errors(result)
    name = re.sub(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]",
                  lambda m: m.group().encode("unicode_escape").decode("ascii"), log_name)
    lines = [f"# The drives mrnea identify found from {name} (docs/identification.md): a "
             "sidecar actuator file.", "# Rotor inertia motor side, friction joint side; '+- x' "
             "is one standard error.", ""]

    def note(s: float, unit: str, w: str | None) -> str:
        return (f"  # +- {s:.3g} {unit}" if w is None else
                f"  # not a base parameter of its own: identified only within {w}")

    for j, jt in enumerate(robot.joints):
        tau = jt.unit("tau")
        fp, fm = (float(x) for x in robot.coulomb_friction[j])
        G = float(jt.gear_ratio)
        rotor_se = se[j, 0] / G ** 2 if math.isfinite(se[j, 0]) else math.nan
        lines += [f"[{_key(jt.name)}]", f"gear_ratio = {G!r}",
                  f"rotor_inertia = {float(robot.rotor_inertia[j])!r}"
                  + note(rotor_se, "kg m^2 (motor side)", within[j][0]),
                  f"viscous_friction = {float(robot.viscous_friction[j])!r}"
                  + note(se[j, 1], _DRIVE_UNITS["viscous"][jt.is_prismatic], within[j][1]),
                  f"coulomb_friction = [{fp!r}, {fm!r}]"
                  + (f"  # +- [{se[j, 2]:.3g}, {se[j, 3]:.3g}] {tau}"
                     if np.isfinite(se[j, 2:]).all() else
                     note(math.nan, tau, within[j][2] or within[j][3])), ""]
    return "\n".join(lines)


def _key(name: str) -> str:
    """A joint name as a TOML table key: bare where TOML allows it, else a basic string."""
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else toml_string(name)
