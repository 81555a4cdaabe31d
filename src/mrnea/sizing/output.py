"""What drive sizing writes (issue 27; docs/sizing.md): the table of every joint x combination
(``sizing.csv``), the chosen drives as a sidecar actuator file (``chosen_drives.toml``: ``mrnea
check ROBOT PROGRAM --actuators chosen_drives.toml`` reproduces the verification) and the
summary (``summary.json``, strict JSON). The page is :mod:`mrnea.sizing.html`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from mrnea.sizing.checks import CHECKS, reason
from mrnea.sizing.core import JointSizing, SizingResult

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ALTERNATIVES", "chosen_toml", "sizing_summary", "sizing_table"]

ALTERNATIVES = 3
"""The passing combinations after the chosen one that the summary lists per joint."""


def _none(x: float | None) -> float | None:
    """A finite float, else None (JSON null: strict JSON has no infinity or NaN)."""
    return None if x is None or not math.isfinite(x) else float(x)


def _status(js: JointSizing, c: int) -> str:
    if c == js.chosen:
        return "chosen"
    return "passes" if js.judged.worst[c] <= 1.0 else "rejected"


def sizing_table(result: SizingResult) -> pd.DataFrame:
    """One row per joint x combination: joint, drive, motor, gearbox, ratio G, mass [kg],
    price, each check's ratio (``<check>_ratio``, need / rating), ``worst_ratio``, ``margin``
    (1 - worst), ``status`` (chosen, passes, rejected), ``rank`` (1 = chosen, among the passing
    ones by the objective; empty for the rejected) and ``reason`` (the failed checks, worst
    first). A ratio whose rating is 0 where it is needed (above a motor's no-load speed) is
    empty, as its margin: the reason says why."""
    import pandas as pd

    rows = []
    for js in result.joints:
        rank = {c: k + 1 for k, c in enumerate(js.order)}
        for c, t in enumerate(js.trains):
            r = js.judged.ratios[c]
            rows.append({"joint": js.joint, "drive": t.name, "motor": t.motor.name,
                         "gearbox": t.gearbox.name, "ratio": t.gearbox.ratio, "mass": t.mass,
                         "price": t.price,
                         **{f"{k}_ratio": _none(float(v)) for k, v in zip(CHECKS, r,
                                                                            strict=True)},
                         "worst_ratio": _none(float(js.judged.worst[c])),
                         "margin": _none(1.0 - float(js.judged.worst[c])),
                         "status": _status(js, c), "rank": rank.get(c), "reason": reason(r)})
    df = pd.DataFrame(rows)
    df["rank"] = df["rank"].astype("Int64")
    return df


def _drive(js: JointSizing, c: int) -> dict[str, Any]:
    t = js.trains[c]
    r = js.judged.ratios[c]
    return {"drive": t.name, "motor": t.motor.name, "gearbox": t.gearbox.name,
            "ratio": t.gearbox.ratio, "mass": t.mass, "price": _none(t.price),
            "ratios": {k: _none(float(v)) for k, v in zip(CHECKS, r, strict=True)},
            "worst_ratio": _none(float(js.judged.worst[c])),
            "margin": _none(1.0 - float(js.judged.worst[c])),
            "rms_motor_torque": float(js.judged.rms[c]),
            "peak_motor_torque": float(np.abs(js.judged.motor[c]).max()),
            "reason": reason(r)}


def sizing_summary(result: SizingResult) -> dict[str, Any]:
    """The answer as strict JSON data: the options, ``fits``, ``verified`` (with each program's
    verdict), ``rounds``, and per joint the chosen drive (or null) with its ratios, margin, peak
    and RMS motor torque [N m], the next :data:`ALTERNATIVES` passing ones, the best one when
    nothing fits, and the one-line message."""
    joints = []
    for js in result.joints:
        joints.append({
            "joint": js.joint, "message": js.message(),
            "chosen": None if js.chosen is None else _drive(js, js.chosen),
            "alternatives": [_drive(js, c) for c in js.order[1:1 + ALTERNATIVES]],
            "best": _drive(js, js.best),
            "combinations": len(js.trains), "passing": len(js.order)})
    return {"objective": result.objective, "dwell": result.dwell,
            "drive_mass": result.drive_mass, "fits": result.fits, "verified": result.verified,
            "rounds": result.rounds,
            "programs": [{"name": c.name, "verdict": r.verdict(), "achievable": r.achievable}
                         for c, r in zip(result.cases, result.runs, strict=False)],
            "joints": joints}


def chosen_toml(result: SizingResult) -> str:
    """The chosen drives as a sidecar actuator file (docs/robot-format.md): per joint its gear
    ratio, rotor inertia (motor + gearbox), efficiency, effort limit or torque-speed curve and
    velocity limit, joint side, as :func:`mrnea.sizing.apply_trains` sets them (the drives'
    masses are not a sidecar's business: the verification ran with them on the parent links
    when ``drive_mass``)."""
    sized = result.sized
    if sized is None:
        raise ValueError("nothing to write: a joint has no drive that fits")
    lines = ["# The drives mrnea size chose (docs/sizing.md): a sidecar actuator file.",
             f"# objective {result.objective}, dwell {result.dwell} s, drive masses on the "
             f"parent links: {'yes' if result.drive_mass else 'no'}", ""]
    for js in result.joints:
        j = sized.joints[sized.joint_names.index(js.joint)]
        t = js.trains[js.chosen]
        lines += [f"[{js.joint}]  # {t.name}", f"gear_ratio = {j.gear_ratio!r}",
                  f"rotor_inertia = {j.rotor_inertia!r}",
                  f"efficiency = [{j.efficiency_pair[0]!r}, {j.efficiency_pair[1]!r}]"]
        if j.torque_speed is None:
            lines.append(f"effort_limit = {j.effort_limit!r}")
        else:
            lines.append("torque_speed = [" + ", ".join(repr(x) for x in j.torque_speed) + "]")
        if math.isfinite(j.velocity_limit):
            lines.append(f"velocity_limit = {j.velocity_limit!r}")
        lines.append("")
    return "\n".join(lines)
