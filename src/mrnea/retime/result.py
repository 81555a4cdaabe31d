"""What :func:`mrnea.retime` returns: the retimed program, its verification, the phase-plane data,
and a JSON-ready summary."""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.actuators import program_requirement
from mrnea.errors import OutputError, StateError
from mrnea.io.pathcsv import save_csv
from mrnea.io.program import save_program
from mrnea.io.source import as_path
from mrnea.io.writer import create
from mrnea.model import Robot
from mrnea.retime.path import PathCoefficients
from mrnea.retime.rows import Limits, limit_curve
from mrnea.simulate import SimulationResult


@dataclass(frozen=True)
class PhasePiece:
    """One moving piece of the program in the phase plane (path speed against path position).

    Attributes
    ----------
    k0, k1 : the program's rows the piece spans.
    t0 : the program instant of row k0 [s]; the piece's path position s runs from 0 at k0.
    s : (N + 1,) grid [s, the program's clock].
    sd : (N + 1,) the retimed path speed ds/dt at the grid (1: the program's own timing).
    coefficients, limits : the piece's second-order form and the true limits (margin 1), for
        :meth:`limit_curve`.
    """

    k0: int
    k1: int
    t0: float
    s: NDArray
    sd: NDArray
    coefficients: PathCoefficients = field(repr=False)
    limits: Limits = field(repr=False)
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def limit_curve(self) -> NDArray:
        """(N + 1,) the limit curve: the largest path speed at which some path acceleration
        keeps every joint within its limits, with the true model
        (:func:`mrnea.retime.rows.limit_curve`; computed on the first call, for the report)."""
        if "limit" not in self._cache:
            self._cache["limit"] = limit_curve(self.coefficients, self.limits)
        return self._cache["limit"]


@dataclass(frozen=True)
class RetimeResult:
    """A retimed program and the simulation that verifies it. Arrays (M, n) at ``dt`` [s].

    Attributes
    ----------
    t : (M,) time [s]. q_cmd : (M, n) the retimed program [rad | m].
    f_ext : (M, 6) the wrench moved with the path [N, N m] (base frame, what the end effector
        exerts), or None; f_ext_point : (3,) or (M, 3) its point in the last link's frame [m].
        Or both by link name, as the program gave them: ``{link: (M, 6)}`` and ``{link: (3,)
        or (M, 3)}``, each point in its link's frame.
    dt : the retimed program's cycle [s]. mode : the simulation's mode.
    duration, original_duration : (M - 1) dt and the program's (K - 1) dt [s].
    method : ``"toppra"`` or ``"scale"``.
    margin : toppra: the planning margin the verified result ended with (the limits it planned
        against were margin x the effort and velocity limits). scale: the largest fraction of
        a limit the accepted program uses (its factor is the smallest the verification accepts).
    achievable, simulation : the verification (:func:`mrnea.simulate.simulate`, same robot, mode
        and wrench).
    factor : scale: the time factor (new time = factor x program time); toppra: None.
    estimate : scale: Hollerbach's closed-form estimate of the factor; toppra: None.
    phase : per moving piece, the phase-plane data (:class:`PhasePiece`).
    original_q_cmd, original_dt, original_f_ext, original_f_ext_point : the program retimed.
    log : per margin tried (toppra) or the factors evaluated (scale).
    timings : seconds spent (:data:`mrnea.retime.job.TIMINGS`).
    margin_asked : toppra: the planning margin asked; ``margin`` is below it only where no plan
        at it verified (the highest that verifies, to 0.1 %: :mod:`mrnea.retime.search`).
    jerk_limit : toppra: the joint jerk limits (n,) [rad/s^3 | m/s^3] the timing keeps, or None
        (:mod:`mrnea.retime.jerk`).
    """

    t: NDArray
    q_cmd: NDArray
    f_ext: Any
    f_ext_point: Any
    dt: float
    mode: str
    duration: float
    original_duration: float
    method: str
    margin: float
    achievable: bool
    simulation: SimulationResult
    factor: float | None
    estimate: float | None
    phase: tuple[PhasePiece, ...]
    original_q_cmd: NDArray
    original_dt: float
    original_f_ext: Any
    original_f_ext_point: Any
    log: list[dict[str, Any]] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    margin_asked: float | None = None
    jerk_limit: NDArray | None = None
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def robot(self) -> Robot:
        """The robot the program was retimed for."""
        return self.simulation.robot

    def effort_ratios(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """``(t_before, before, t_after, after)``: each program's own requirement over its
        limit per cycle and joint, |program effort| / limit at the commanded speed
        (:func:`mrnea.actuators.program_requirement`, the simulation's ``program_effort``), the
        program retimed and the retimed one, each on its own clock [s]. A joint without a drive
        (limit 0) has an infinite ratio where it needs an effort."""
        if "ratios" not in self._cache:
            before = program_requirement(self.robot, self.original_q_cmd, self.original_dt,
                                         self.original_f_ext, self.original_f_ext_point)
            after = (self.simulation.program_effort, self.simulation.program_limit)
            out = []
            for (tau, lim), dt in ((before, self.original_dt), (after, self.dt)):
                with np.errstate(divide="ignore", invalid="ignore"):
                    r = np.where(lim > 0, np.abs(tau) / lim, np.where(tau != 0, np.inf, 0.0))
                out += [np.arange(tau.shape[0]) * dt, r]
            self._cache["ratios"] = tuple(out)
        return self._cache["ratios"]

    def verdict(self) -> str:
        """One line: the retimed duration against the program's, and the verification's
        verdict."""
        if self.method == "toppra":
            how = f"TOPP-RA along the path at planning margin {self.margin:.4g}"
            if self.margin_asked is not None and self.margin < self.margin_asked:
                how += (f" (asked {self.margin_asked:.4g}: the highest margin that verifies, "
                        "to 0.1 %)")
        else:
            how = f"uniform time scaling by {self.factor:.4g}"
        M = self.t.size
        return (f"RETIMED ({self.method}): {self.duration:.4g} s from its first row to its last "
                f"({M} rows; simulated as {M} cycles of {self.dt:g} s, {M * self.dt:.4g} s) "
                f"instead of {self.original_duration:.4g} s, {how}. Verification: "
                f"{self.simulation.verdict()}")

    def summary(self) -> dict[str, Any]:
        """The retiming as plain, strict JSON data (SI units; no NaN or infinity: an unbounded
        ratio is null).

        ``duration``, ``original_duration`` [s], ``speedup`` (their ratio), ``method``,
        ``achievable``, ``margin`` (:class:`RetimeResult`), ``dt``, ``original_dt``, ``cycles``,
        ``mode``, ``factor`` and ``scale_estimate`` (scale, else null), ``moving_pieces``,
        ``dwells``, ``toppra_solves`` (toppra), ``margin_asked`` (toppra, else null),
        ``margins_tried`` (every margin planned, highest first), ``jerk_limit`` (per joint
        [rad/s^3 | m/s^3], else null), ``verdict``, ``timings`` [s]; per joint
        ``peak_effort_ratio_before`` and ``_after`` (:meth:`effort_ratios`) and the time of each;
        ``worst_joint_before`` / ``_after``.
        """
        if "summary" in self._cache:
            return self._cache["summary"]
        t0, before, t1, after = self.effort_ratios()
        names = self.robot.joint_names

        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        joints = []
        for i, name in enumerate(names):
            kb, ka = int(np.argmax(before[:, i])), int(np.argmax(after[:, i]))
            joints.append({"joint": name,
                           "peak_effort_ratio_before": num(before[kb, i]),
                           "peak_effort_ratio_before_time": float(t0[kb]),
                           "peak_effort_ratio_after": num(after[ka, i]),
                           "peak_effort_ratio_after_time": float(t1[ka])})
        solves = sum(len(lg.get("safe", ())) + ("relaxed" in lg) for lg in self.log)
        out = {
            "robot": self.robot.name, "method": self.method, "achievable": self.achievable,
            "margin": self.margin, "duration": self.duration,
            "original_duration": self.original_duration,
            "speedup": num(self.original_duration / self.duration) if self.duration else None,
            "dt": self.dt, "original_dt": self.original_dt, "cycles": int(self.t.size),
            "mode": self.mode, "factor": self.factor, "scale_estimate": self.estimate,
            "moving_pieces": len(self.phase),
            "dwells": _dwells(self.original_q_cmd),
            "toppra_solves": solves if self.method == "toppra" else None,
            "margin_asked": self.margin_asked,
            "margins_tried": sorted({float(lg["margin"]) for lg in self.log if "margin" in lg},
                                    reverse=True),
            "jerk_limit": None if self.jerk_limit is None else self.jerk_limit.tolist(),
            "verdict": self.simulation.verdict(),
            "timings": {k: float(v) for k, v in self.timings.items()},
            "worst_joint_before": names[int(np.argmax(before.max(axis=0)))],
            "worst_joint_after": names[int(np.argmax(after.max(axis=0)))],
            "joints": joints,
        }
        self._cache["summary"] = out
        return out

    def save_csv(self, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
        """Write the retimed program as a path CSV (``t, <joint names>``, one row per cycle;
        :func:`mrnea.io.pathcsv.save_csv`): ``mrnea check ROBOT FILE --dt DT`` reads it back
        bit for bit."""
        return save_csv(path, self.t, self.q_cmd, self.robot.joint_names, overwrite)

    def save_program(self, path: str | os.PathLike[str], robot: str, csv: str,
                     name: str = "retimed", program_keys: Mapping[str, Any] | None = None,
                     overwrite: bool = False) -> Path:
        """Write a program file (docs/programs.md) that runs the retimed program as it was
        verified: ``robot`` (a built-in name or a robot file's path), ``csv`` (the file
        :meth:`save_csv` wrote, relative to the program file), this result's cycle and mode, the
        retimed wrench (its breakpoints: linear interpolation between them reproduces every
        cycle's) and ``program_keys`` (more ``[program]`` keys, e.g. an actuator file).

        Raises
        ------
        StateError
            A wrench point per cycle: the program format holds one point.
        """
        path = as_path(path, "path", OutputError)
        for key, value in (("robot", robot), ("csv", csv), ("name", name)):
            if not isinstance(value, str):
                raise StateError(f"{key}: expected a str, got {type(value).__name__}")
        if program_keys is not None and not isinstance(program_keys, Mapping):
            raise StateError(f"program_keys: expected a mapping of [program] keys, got "
                             f"{type(program_keys).__name__}")
        def by_link(x):  # a wrench (or point) by link; one of the last link's keyed by None
            return x if isinstance(x, Mapping) else {None: x}

        points = by_link(self.f_ext_point)
        if any(p is not None and np.ndim(p) == 2 for p in points.values()):
            raise StateError("f_ext_point: a program file holds one point, not one per cycle")
        program = {"name": name, "robot": robot, "dt": self.dt, "mode": self.mode,
                   **(program_keys or {})}
        tables = []
        for link, f in by_link(self.f_ext).items():  # a [wrench], or a [[wrench]] per link
            if f is None or not np.any(f):
                continue
            k = _breakpoints(f)
            table = {**({} if link is None else {"link": link}), "times": self.t[k],
                     "values": f[k]}
            if points.get(link) is not None:
                table["point"] = np.asarray(points[link])
            tables.append(table)
        wrench = (tables or None) if isinstance(self.f_ext, Mapping) else next(iter(tables), None)
        how = ("TOPP-RA, planning margin " + f"{self.margin:.4g}"
               if self.method == "toppra" else f"uniform time scaling by {self.factor:.6g}")
        comment = (f"Retimed by mrnea ({how}): {self.duration:.6g} s instead of "
                   f"{self.original_duration:.6g} s. Verified: "
                   f"{'achievable' if self.achievable else 'NOT achievable'}.\n"
                   f"Run: mrnea check {Path(path).name}")
        # the rows are the program, one per cycle: read back as they are
        return save_program(path, program, {"csv": csv, "interpolation": "linear"}, wrench,
                            comment, overwrite)

    def report(self, path: str | os.PathLike[str], overwrite: bool = False,
               view3d: bool = True) -> Path:
        """Write the HTML report of this retiming (the phase plane, the effort ratios before and
        after, the verdict, the 3D view of the retimed motion unless ``view3d`` is False):
        :func:`mrnea.report.retime.write_retime_report` (see there)."""
        from mrnea.report.retime import write_retime_report  # matplotlib: loaded when asked

        return write_retime_report(self, path, overwrite, view3d=view3d)

    def save_summary(self, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
        """Write :meth:`summary` as strict JSON through :func:`mrnea.io.writer.create`."""
        with create(path, overwrite) as fh:
            json.dump(self.summary(), fh, indent=2, allow_nan=False)
            fh.write("\n")
        return Path(path)


def _breakpoints(rows: NDArray) -> NDArray:
    """Indices of the rows (M, m) at t = k dt that linear interpolation between them reproduces
    the others from: the ends and every row off the line through its neighbours."""
    d2 = np.abs(rows[2:] - 2 * rows[1:-1] + rows[:-2])
    bent = np.any(d2 > 1e-12 * max(1.0, float(np.abs(rows).max())), axis=1)
    return np.concatenate([[0], 1 + np.flatnonzero(bent), [rows.shape[0] - 1]])


def _dwells(q: NDArray) -> int:
    """The number of dwells (runs of identical rows) in a program."""
    still = ~np.any(q[1:] != q[:-1], axis=1)
    return int(np.sum(still[1:] & ~still[:-1]) + still[0]) if still.size else 0
