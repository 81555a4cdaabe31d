"""What a simulation run answers: the summary a designer reads and the one-line verdict.

:func:`summarize` makes :meth:`mrnea.simulate.SimulationResult.summary` (strict JSON data: no
NaN or infinity, an unlimited value is ``None``, JSON ``null``), :func:`verdict` the line the
command line prints. Two things are kept apart: the **simulated response** (what the robot
really did: saturation, lag, tracking error, the efforts the drives applied; it decides
achievable or not) and the **program's requirement** (what the commanded motion itself needs,
cycle by cycle, before any lag: it says by how much a drive falls short).

Units: efforts in N m (revolute joints) or N (prismatic), motor torques in N m, positions in
rad or m, velocities in rad/s or m/s, times in s; each joint names its own (``effort_unit``,
``position_unit``, ``velocity_unit``). Every field, its unit and its meaning are in the JSON
Schema shipped with the package, ``summary.schema.json`` (:func:`schema_path`; the tests
validate every summary they write against it; docs/simulation.md lists the fields).
"""

from __future__ import annotations

import math
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from mrnea import compiled
from mrnea.kernels import bearing, peaks
from mrnea.kernels.drive import beyond

_beyond = getattr(beyond, "py_func", beyond)  # the kernels' limit comparison, run as Python
# (nothing to compile; under NUMBA_DISABLE_JIT=1 `beyond` is the plain function)

if TYPE_CHECKING:
    from mrnea.simulate import SimulationResult

EFFORT_UNIT = {False: "N m", True: "N"}  # by is_prismatic
TIMES = "\u00d7"  # the multiplication sign of "1.62 × its limit"
POSITION_UNIT = {False: "rad", True: "m"}
# summary keys of the per-joint peak reaction loads (null for a run without reactions), and the
# bearing load of each (kernels/bearing.py, BearingLoads' fields in mrnea/cycles.py)
PEAK_LOADS = (("peak_reaction_force", bearing.FORCE), ("peak_axial_force", bearing.AXIAL_FORCE),
              ("peak_radial_force", bearing.RADIAL_FORCE),
              ("peak_reaction_moment", bearing.MOMENT),
              ("peak_bending_moment", bearing.BENDING_MOMENT))


def schema_path() -> Any:
    """The JSON Schema (draft 2020-12) of a summary, shipped in the package: every field with
    its ``description`` and, for a number, its ``unit``. A :class:`importlib.resources`
    traversable (``.read_text()``; a path for an installed package)."""
    return resources.files("mrnea").joinpath("summary.schema.json")


def finite_or_none(x: float) -> float | None:
    """``x`` as a float, or None (JSON ``null``) when it is infinite or NaN (an unlimited
    value)."""
    x = float(x)
    return x if math.isfinite(x) else None


def start_violations(r: SimulationResult) -> list[dict[str, Any]]:
    """The joints whose start state is outside their limits by more than rounding
    (kernels/drive.py ``beyond``): a position outside [lower, upper] or a speed above the
    velocity limit (each a dict: joint, reason, value, limits)."""
    if r.K == 0:
        return []
    out = []
    rob = r.robot
    for i, j in enumerate(rob.joints):
        q, qd = float(r.q[0, i]), float(r.qd[0, i])
        if (_beyond(q, j.upper, abs(q) + abs(j.upper))  # outside by more than rounding
                or _beyond(-q, -j.lower, abs(q) + abs(j.lower))):
            out.append({"joint": j.name, "reason": "start outside the position limits",
                        "value": q, "limits": [finite_or_none(j.lower), finite_or_none(j.upper)]})
        if _beyond(abs(qd), j.velocity_limit, abs(qd) + j.velocity_limit):
            out.append({"joint": j.name, "reason": "start faster than the velocity limit",
                        "value": qd, "limits": [finite_or_none(-j.velocity_limit),
                                                finite_or_none(j.velocity_limit)]})
    return out


def _drive(j: Any) -> str:
    """A joint's drive: ``"unpowered"`` (effort limit 0), ``"unlimited"`` or ``"limited"``."""
    return ("unpowered" if j.effort_limit == 0 else
            "unlimited" if math.isinf(j.effort_limit) else "limited")


def _program(r: SimulationResult, i: int, idx: np.ndarray, val: np.ndarray) -> dict[str, Any]:
    """Joint i's program requirement (module docstring): peak, RMS, motor side, and the peak
    ratio to the limit at the program's speed; ``idx``, ``val``: the run's summary numbers
    (kernels/peaks.py ``run_peaks``)."""
    j = r.robot.joints[i]
    k, kr, ko = (int(x) for x in idx[i, [peaks.K_REQ, peaks.K_RATIO, peaks.K_OVER]])
    drive = _drive(j)
    limited = drive == "limited"
    lim = float(r.program_limit[kr, i])  # the limit at the ratio's instant
    ratio = float(val[i, peaks.RATIO_PEAK])
    # where the limit at the ratio's instant comes from: the constant effort limit, or the
    # torque-speed curve at the program's speed there (below the peak effort limit)
    curve = limited and lim < j.effort_limit
    return {
        "program_peak_effort": abs(float(r.program_effort[k, i])),
        "program_peak_time": float(r.t[k]),
        "program_rms_effort": float(val[i, peaks.REQ_RMS]),
        # the motor side, with the gear's efficiency (kernels/drive.py motor_side): x 1 / eta_d
        # driving, x eta_b back-driven, then / G (an ideal gear: exactly today's tau / G)
        "program_peak_motor_torque": float(val[i, peaks.MOTOR_REQ_PEAK]) / j.gear_ratio,
        "program_rms_motor_torque": float(val[i, peaks.MOTOR_REQ_RMS]) / j.gear_ratio,
        "drive": drive,
        # peak of |required| / limit at the program's speed; null: no limit to compare with
        # (unpowered, unlimited), or a zero limit (commanded beyond the no-load speed)
        "program_effort_ratio": finite_or_none(ratio) if limited else None,
        "program_ratio_time": float(r.t[kr]) if limited else None,
        "program_effort_at_ratio": abs(float(r.program_effort[kr, i])) if limited else None,
        "program_limit_at_ratio": lim if limited else None,
        "program_speed_at_ratio": abs(float(r.qd_cmd[kr, i])) if limited else None,
        "program_limit_source": (None if not limited else
                                 "torque-speed curve" if curve else "effort limit"),
        "program_beyond_no_load_speed": limited and math.isinf(ratio),
        # first over the limit by more than rounding, as the kernels compare
        "program_first_over_time": float(r.t[ko]) if ko >= 0 else None,
    }


def _first_infeasible(r: SimulationResult) -> dict[str, Any] | None:
    """The first cycle and joint the simulated robot did not follow, or None."""
    start = start_violations(r)
    if start:
        return {"time": 0.0, "cycle": 0, **start[0]}
    infeasible = r.saturated | r.position_clamped | r.velocity_clamped
    if not infeasible.any():
        return None
    k, i = (int(x) for x in np.argwhere(infeasible)[0])
    j = r.robot.joints[i]
    reasons = [name for name, m in (("effort saturated", r.saturated),
                                    ("position limit", r.position_clamped),
                                    ("velocity limit", r.velocity_clamped)) if m[k, i]]
    # the program's next row, which cycle k headed for; after the last cycle held, the
    # program's own next row or its end at rest (program_next)
    q_next, qd_next = ((r.q_cmd[k + 1], r.qd_cmd[k + 1]) if k + 1 < r.K
                       else program_next(r))
    return {
        "time": float(r.t[k]), "cycle": k, "joint": j.name, "reason": ", ".join(reasons),
        "required_effort": float(r.tau_required[k, i]),
        "available_effort": finite_or_none(r.limit[k, i]),
        "commanded_velocity": float(qd_next[i]),
        "velocity_limit": finite_or_none(j.velocity_limit),
        "commanded_position": float(q_next[i]),
        "position_limits": [finite_or_none(j.lower), finite_or_none(j.upper)],
    }


def summarize(r: SimulationResult) -> dict[str, Any]:
    """The summary of a run (:meth:`mrnea.simulate.SimulationResult.summary`)."""
    head = {"robot": r.robot.name, "achievable": r.achievable, "mode": r.mode, "fd": r.fd,
            "dt": r.dt, "cycles": r.K, "duration": float(r.K * r.dt), "completed": r.completed,
            "interrupted_after_cycles": None if r.completed else r.K,
            "runaway_time": r.runaway_time}
    if r.K == 0:  # interrupted before the first chunk ended
        return {**head, "first_infeasible": None, "start_infeasible": [],
                "max_tracking_error": 0.0, "worst_joint": None, "worst_effort_ratio": None,
                "joints": []}
    idx, val = _numbers(r)
    joints = []
    for i, j in enumerate(r.robot.joints):
        ke = int(idx[i, peaks.K_ERR])
        joints.append({
            "joint": j.name,
            "effort_unit": EFFORT_UNIT[j.is_prismatic],
            "position_unit": POSITION_UNIT[j.is_prismatic],
            "velocity_unit": f"{POSITION_UNIT[j.is_prismatic]}/s",
            "effort_limit": finite_or_none(j.effort_limit),
            **_program(r, i, idx, val),
            # the simulated response
            "time_saturated": float(int(idx[i, peaks.N_SATURATED]) * r.dt),
            "time_stuck": float(int(idx[i, peaks.N_STUCK]) * r.dt),
            "peak_motor_torque": float(val[i, peaks.TAU_MOTOR_PEAK]),
            "rms_motor_torque": float(val[i, peaks.TAU_MOTOR_RMS]),
            "peak_effort": float(val[i, peaks.TAU_PEAK]),
            "peak_speed": float(val[i, peaks.QD_PEAK]),
            **{key: None if r.reaction is None else float(val[i, peaks.FORCE_PEAK + c])
               for key, c in PEAK_LOADS},
            "max_tracking_error": abs(float(r.tracking_error[ke, i])),
            "max_tracking_error_time": float(r.t[ke]),
            "final_position_error": float(r.tracking_error[-1, i]),
        })
    worst = _worst(joints)
    tool = {}
    if r.tool_position_error is not None:  # a Cartesian program: the tool's error, its peak
        for key, e in (("max_tool_position_error", r.tool_position_error),
                       ("max_tool_orientation_error", r.tool_orientation_error)):
            k = int(np.argmax(e))
            tool |= {key: float(e[k]), f"{key}_time": float(r.t[k])}
    return {**head, "first_infeasible": _first_infeasible(r),
            "start_infeasible": start_violations(r),
            "max_tracking_error": max((jd["max_tracking_error"] for jd in joints), default=0.0),
            "worst_joint": None if worst is None else worst["joint"],
            "worst_effort_ratio": None if worst is None else worst["program_effort_ratio"],
            **tool, "joints": joints}


def _numbers(r: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    """The run's summary numbers per joint, ``(idx, val)`` (kernels/peaks.py ``run_peaks``:
    one compiled pass over the run's arrays, the same bits as NumPy's reductions gave)."""
    rob = r.robot
    idx, val = np.empty((rob.n, peaks.NIDX), dtype=np.int64), np.empty((rob.n, peaks.NVAL))
    wrench = np.empty((0, rob.n, 6)) if r.reaction is None else r.reaction
    limited = np.array([_drive(j) == "limited" for j in rob.joints])
    axes = np.array([j.axis for j in rob.joints])  # unit axes, joint frames
    peaks.run_peaks((r.tau, r.tau_motor, r.qd, r.tracking_error, r.saturated, r.stuck, wrench),
                    (r.program_effort, r.program_limit, r.qd_cmd),
                    (compiled.of(rob)[3], limited, axes), idx, val)
    return idx, val


def _worst(joints: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The limited joint with the largest program effort ratio (one commanded beyond its
    no-load speed first), or None if no joint has a finite effort limit."""
    limited = [jd for jd in joints if jd["drive"] == "limited"]
    if not limited:
        return None
    return max(limited, key=lambda jd: (jd["program_beyond_no_load_speed"],
                                        jd["program_effort_ratio"] or 0.0))


def limit_origin(jd: dict[str, Any]) -> str:
    """The limit a limited joint's program effort ratio is taken against, and where it comes
    from (``jd``: a joint of the summary): ``4000 N m limit``, or ``7.842 N m limit at
    3.14 rad/s on its torque-speed curve (peak 150 N m)`` where the curve lowers the limit at
    the program's speed."""
    u = jd["effort_unit"]
    text = f"{_g(jd['program_limit_at_ratio'])} {u} limit"
    if jd["program_limit_source"] == "torque-speed curve":
        text += (f" at {_g(jd['program_speed_at_ratio'])} {jd['velocity_unit']} on its "
                 f"torque\u2013speed curve (peak {_g(jd['effort_limit'])} {u})")
    return text


def _g(x: float) -> str:
    """A number as the verdict prints it: 4 significant digits, no exponent below 1e6."""
    return f"{x:.4g}" if abs(x) < 1e6 else f"{x:.3e}"


def verdict(r: SimulationResult) -> str:
    """One line (:meth:`mrnea.simulate.SimulationResult.verdict`): achievable with the headroom
    of the worst joint, or where and by how much not; an interrupted run says after how many
    cycles, and is never called achievable; a run whose robot ran away says when."""
    s = r.summary()
    head = ("" if r.completed else
            f"INTERRUPTED (partial result): interrupted after {r.K} cycles; ")
    if r.runaway_time is not None:
        return f"{_answer(r, s, head).rstrip('.')}; {_runaway(r)}"
    return _answer(r, s, head)


def _runaway(r: SimulationResult) -> str:
    return (f"the simulated robot ran away at t = {r.runaway_time:.3f} s (its speed grew "
            "without bound: the drives cannot hold it) and the run stops there")


def _answer(r: SimulationResult, s: dict[str, Any], head: str) -> str:
    """The verdict without a run-away's note (:func:`verdict`)."""
    if r.K == 0:
        return (f"{head}NOT ACHIEVABLE: no cycle was completed" if r.runaway_time is not None
                else f"{head}no cycle was completed.")
    by_name = {jd["joint"]: jd for jd in s["joints"]}
    worst = by_name.get(s["worst_joint"]) if s["worst_joint"] else None
    if s["achievable"] is None:
        return (f"{head}no limit exceeded in the {s['duration']:.3f} s simulated; whether the "
                "rest of the program is achievable is unknown.")
    if s["achievable"]:
        room = ("no joint has a finite effort limit" if worst is None else
                f"worst joint {worst['joint']} at {worst['program_effort_ratio']:.2f} of its "
                f"limit (t = {worst['program_ratio_time']:.3f} s)")
        return (f"{head}ACHIEVABLE: {r.robot.name} follows the program ({r.K} cycles, "
                f"{s['duration']:.3f} s) within every limit; {room}.")
    return f"{head}NOT ACHIEVABLE: {_shortfall(r, s, worst)}"


def _shortfall(r: SimulationResult, s: dict[str, Any], worst: dict[str, Any] | None) -> str:
    """Why the run is not achievable: the start, the worst effort ratio, an unpowered joint
    that must carry a load, or the first clamp or saturation of the simulated robot."""
    fi = s["first_infeasible"]
    units = {j.name: j.is_prismatic for j in r.robot.joints}
    if s["start_infeasible"]:
        v = s["start_infeasible"][0]
        lo, hi = v["limits"]
        unit = POSITION_UNIT[units[v["joint"]]] + ("/s" if "velocity" in v["reason"] else "")
        return (f"{v['joint']}: {v['reason']} ({_g(v['value'])} {unit}, limits "
                f"[{_g(lo) if lo is not None else '-inf'}, {_g(hi) if hi is not None else 'inf'}])")
    if worst is not None and worst["program_beyond_no_load_speed"]:
        u = EFFORT_UNIT[units[worst["joint"]]]
        return (f"{worst['joint']} needs {_g(worst['program_effort_at_ratio'])} {u} at t = "
                f"{worst['program_ratio_time']:.3f} s, where the program drives it beyond its "
                "no-load speed (no effort left)")
    if (worst is not None and worst["program_effort_ratio"] > 1.0
            and worst["program_first_over_time"] is not None):  # over by more than rounding
        u = EFFORT_UNIT[units[worst["joint"]]]
        return (f"{worst['joint']} needs {_g(worst['program_effort_at_ratio'])} {u}, "
                f"{worst['program_effort_ratio']:.2f} {TIMES} its {limit_origin(worst)}, at t = "
                f"{worst['program_ratio_time']:.3f} s (first over the limit at t = "
                f"{worst['program_first_over_time']:.3f} s)")
    for jd in s["joints"]:
        if jd["drive"] == "unpowered" and jd["program_peak_effort"] > 0.0:
            u = EFFORT_UNIT[units[jd["joint"]]]
            return (f"{jd['joint']} has no drive (effort limit 0) and the program needs "
                    f"{_g(jd['program_peak_effort'])} {u} at t = "
                    f"{jd['program_peak_time']:.3f} s")
    if fi is None:  # no cycle over a limit before the robot ran away (its note follows)
        return f"{r.robot.name} did not follow the program"
    prismatic = units[fi["joint"]]
    if fi["reason"].startswith("effort"):
        u = EFFORT_UNIT[prismatic]
        what = (f"the robot, lagging its program, needs {_g(fi['required_effort'])} {u} "
                f"against {_g(fi['available_effort'])} {u} available")
    elif fi["reason"].startswith("position"):
        lo, hi = fi["position_limits"]
        what = (f"position commanded {_g(fi['commanded_position'])} "
                f"{POSITION_UNIT[prismatic]}, range [{_g(lo) if lo is not None else '-inf'}, "
                f"{_g(hi) if hi is not None else 'inf'}] {POSITION_UNIT[prismatic]}")
    else:
        what = (f"velocity commanded {_g(fi['commanded_velocity'])} "
                f"{POSITION_UNIT[prismatic]}/s, limit {_g(fi['velocity_limit'])} "
                f"{POSITION_UNIT[prismatic]}/s")
    worst_err = max(s["joints"], key=lambda jd: jd["max_tracking_error"])
    return (f"first at t = {fi['time']:.3f} s, joint '{fi['joint']}' ({fi['reason']}): {what}; "
            f"worst tracking error {_g(worst_err['max_tracking_error'])} "
            f"{POSITION_UNIT[units[worst_err['joint']]]} ('{worst_err['joint']}').")


def final_position_line(r: SimulationResult) -> str | None:
    """None when the run completed and the robot ended where the program ends; else one line
    stating each joint's final position error q_cmd - q [rad | m]
    (:meth:`mrnea.simulate.SimulationResult.final_position_line`)."""
    if not r.completed or r.runaway_time is not None or not r.tracking_error[-1].any():
        return None
    errors = ", ".join(f"{j.name} {e:.4g} {j.unit('q')}"
                       for j, e in zip(r.robot.joints, r.tracking_error[-1].tolist(), strict=True))
    return f"The robot did not reach the program's end: final position error {errors}."


def program_next(res: SimulationResult) -> tuple[NDArray, NDArray]:
    """What the program commands after the last cycle of ``res``, (n,) each: its position
    [rad | m] and its velocity [rad/s | m/s] over the next interval. A run that stopped before
    the program's end (interrupted, or a runaway): the program's next row (q_cmd[K], qd_cmd[K]
    of the whole program); at the program's end: its last position, at rest (the last cycle
    commands zero velocity, kernels/simulate.py)."""
    if res._next is not None:
        return res._next[0], res._next[1]
    rest = np.zeros(res.robot.n)
    return (res.q_cmd[-1] if res.K else rest), rest
