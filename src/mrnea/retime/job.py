"""One retiming job: the program's rows, their pieces, the wrench on the program's clock, and
how retimed pieces become a program that is simulated (docs/retime.md, "Dwells and the wrench").

Usage: ``job = Job.of(robot, program, dt, f_ext, f_ext_point, mode)``; ``Q, FE, PE =
job.assemble({j: (rows, s_rows)})`` with each moving piece's new rows and their path positions
(on the program's clock, 0 at the piece's first row); ``sim = job.verify(Q, FE, PE)``.

A dwell (rows held bit for bit) stays a hold of the same duration: its h intervals of the
program's cycle become round(h dt_program / dt) intervals of the retimed one (at least one).
The wrench, given per row on the program's clock, is carried to every new row at the program
instant of its path position (linear interpolation): a wrench applied during a dwell keeps its
timing inside that dwell, one applied during motion moves with the path.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea import validate
from mrnea.achievable import MODES
from mrnea.errors import NoTimingError, RetimeError, StateError
from mrnea.io.program import Program
from mrnea.model import Robot
from mrnea.retime.path import at_clock, pieces, polyline_error
from mrnea.simulate import SimulationResult, simulate

TIMINGS = ("coefficients", "rows", "toppra", "jerk", "sampling", "verification")
"""What :attr:`Job.timings` splits a retiming's time into (seconds each): the splines and the
one mRNEA call over the grid per piece (scale: the Hollerbach coefficients), the constraint rows and
their linearisation, the TOPP-RA solves (toppra's set-up included), the jerk-limited linear
programs (0 without a jerk limit), the sampling of the profile
at dt with the wrench, and the verifying simulations."""

PATH_TOL = 1e-3  # rad | m: how far the retimed rows, joined by straight lines, may leave the path
#                  (or the program's own bulge out of its spline, if larger: Job.check_resolution)


def _never() -> None:
    """The default checkpoint: no stop is ever requested."""


@dataclass
class Job:
    """A program to retime (module docstring). ``q`` (K, n) rows at ``program_dt`` [s]; ``dt``
    the retimed program's cycle [s]; ``f_ext`` (K, 6) or None and ``f_ext_point`` (3,), (K, 3)
    or None on the program's clock, or both by link name
    (:func:`mrnea.validate.program_wrench`); ``mode`` the simulation's; ``runs`` :func:`pieces`;
    ``checkpoint`` called between the steps of the retiming (raising from it stops it)."""

    robot: Robot
    q: NDArray
    program_dt: float
    dt: float
    f_ext: Any
    f_ext_point: Any
    mode: str
    runs: list[tuple[str, int, int]]
    timings: dict[str, float] = field(default_factory=lambda: dict.fromkeys(TIMINGS, 0.0))
    checkpoint: Callable[[], None] = _never
    _paths: dict[int, dict] = field(default_factory=dict, repr=False)  # polyline_error's cache

    @classmethod
    def of(cls, robot: Robot, program: Any, dt: float | None, f_ext: Any, f_ext_point: Any,
           mode: str | None, checkpoint: Callable[[], None] | None = None) -> Job:
        """The job of :func:`mrnea.retime`'s arguments: ``program`` a :class:`Program`, a
        ``(t, q)`` pair at a constant step, or a (K, n) array whose cycle is ``dt``."""
        validate.require_robot(robot)
        n, pmode = robot.n, None
        if isinstance(program, Program):
            q, pdt = program.q_cmd, program.dt
            f_ext = program.f_ext if f_ext is None else f_ext
            f_ext_point = program.f_ext_point if f_ext_point is None else f_ext_point
            pmode = program.mode
        elif isinstance(program, tuple) and len(program) == 2:
            t = np.ravel(validate.array(np.ravel(program[0]), "program: t",
                                        np.size(program[0])))
            q = program[1]
            steps = np.diff(t)
            if steps.size == 0 or not np.all(steps > 0):
                raise StateError("program: t must be strictly increasing, two instants or more")
            pdt = float(steps.mean())
            if np.ptp(steps) > 1e-9 * pdt:
                raise StateError("program: (t, q) must be sampled at a constant step (resample "
                                 "it first: mrnea.io.pathcsv.resample)")
        else:
            q, pdt = program, None
        q = validate.array(q, "program", n)
        if q.ndim != 2 or q.shape[0] < 2:
            raise StateError(f"program: expected (K, {n}) joint positions with K >= 2, got "
                             f"shape {q.shape}")
        if pdt is None:
            if dt is None:
                raise StateError("dt: an array program needs its cycle time dt [s]")
            pdt = dt
        pdt = validate.time_step(pdt, "program dt")
        dt = pdt if dt is None else validate.time_step(dt)
        K = q.shape[0]
        fe, pe = validate.program_wrench(robot, f_ext, f_ext_point, K)
        mode = mode or pmode or "hybrid"
        validate.choice("mode", mode, MODES)
        lower, upper = robot.lower, robot.upper
        out = np.any((q < lower) | (q > upper), axis=0)
        if out.any():
            i = int(np.argmax(out))
            k = int(np.argmax((q[:, i] < lower[i]) | (q[:, i] > upper[i])))
            raise NoTimingError(f"joint '{robot.joint_names[i]}' (joint {i + 1}) leaves its "
                              f"position limits [{lower[i]:.4g}, {upper[i]:.4g}] at t = "
                              f"{k * pdt:.4g} s of the program ({q[k, i]:.4g}); no timing "
                              "can fix that")
        return cls(robot, np.ascontiguousarray(q), pdt, dt, fe, pe, mode, pieces(q),
                   checkpoint=checkpoint or _never)

    @property
    def K(self) -> int:
        """Rows of the program."""
        return self.q.shape[0]

    @property
    def clock(self) -> NDArray:
        """(K,) the program's instants [s]."""
        return np.arange(self.K) * self.program_dt

    @property
    def moving(self) -> list[tuple[int, int, int]]:
        """``(j, k0, k1)`` of every moving piece (j its index in :attr:`runs`)."""
        return [(j, k0, k1) for j, (kind, k0, k1) in enumerate(self.runs) if kind == "move"]

    def wrench_at(self, t: NDArray) -> tuple[NDArray | None, NDArray | None]:
        """The wrench (M, 6) and its point ((3,) or (M, 3)) at program instants t (M,)."""
        return at_clock(t, self.clock, self.f_ext), at_clock(t, self.clock, self.f_ext_point)

    def assemble(self, retimed: dict[int, tuple[NDArray, NDArray]]
                 ) -> tuple[NDArray, NDArray | None, NDArray | None, NDArray]:
        """The retimed program: rows (M, n), wrench, its point, and each row's instant on the
        program's clock (M,). ``retimed[j]`` = (rows, path positions) of moving piece j."""
        t0 = time.perf_counter()
        tk = self.clock
        rows, clock = [self.q[:1]], [np.zeros(1)]
        for j, (kind, k0, k1) in enumerate(self.runs):
            if kind == "hold":
                m = max(1, round((k1 - k0) * self.program_dt / self.dt))
                rows.append(np.repeat(self.q[k0:k0 + 1], m, axis=0))
                clock.append(tk[k0] + (tk[k1] - tk[k0]) * np.arange(1, m + 1) / m)
            else:
                r, s = retimed[j]
                rows.append(r[1:])
                clock.append(tk[k0] + s[1:])
        Q, clk = np.concatenate(rows), np.concatenate(clock)
        FE, PE = self.wrench_at(clk)
        self.timings["sampling"] += time.perf_counter() - t0
        return Q, FE, PE, clk

    def verify(self, Q: NDArray, FE: Any, PE: Any,
               reactions: bool = True) -> SimulationResult:
        """Simulate the retimed rows with the job's robot, mode and wrench."""
        t0 = time.perf_counter()
        self.checkpoint()
        sim = simulate(self.robot, Q, self.dt, mode=self.mode, f_ext=FE, f_ext_point=PE,
                       reactions=reactions, progress=lambda done, total: self.checkpoint())
        self.timings["verification"] += time.perf_counter() - t0
        if not sim.completed:  # the checkpoint raised KeyboardInterrupt: simulate kept it
            raise KeyboardInterrupt
        return sim

    def check_resolution(self, j: int, spline: Any, rows: NDArray, s: NDArray,
                         qdd_max: NDArray) -> None:
        """Refuse a cycle too coarse for moving piece j's path: its retimed ``rows`` (M, n) at
        path positions ``s`` (M,), joined by straight lines as the simulation and a controller
        take them, must stay within :data:`PATH_TOL` of the path (``spline``), or within the
        program's own bulge out of the spline if that is larger, at every program row of the
        piece and half-way between (:func:`mrnea.retime.path.polyline_error`).

        ``qdd_max`` (n,) the largest joint acceleration of the retimed piece [rad/s^2 | m/s^2]:
        a curve sampled every dt leaves its chord by at most |qdd| dt^2 / 8, which gives the
        cycle the message suggests.

        Raises
        ------
        RetimeError
            Naming dt, the joint, the program instant, the deviation and a cycle that keeps it.
        """
        k0, k1 = self.runs[j][1:]
        own, err, where = polyline_error(spline, self.q[k0:k1 + 1], self.program_dt, rows, s,
                                         self._paths.setdefault(j, {}))
        tol = np.maximum(PATH_TOL, own)
        bad = err > tol
        if not bad.any():
            return
        i = int(np.argmax(np.where(bad, err / tol, 0.0)))
        joint = self.robot.joints[i]
        unit = "m" if joint.is_prismatic else "rad"
        with np.errstate(divide="ignore"):
            fit = float(np.min(np.sqrt(8 * tol / qdd_max)))
        hint = (f"; a cycle of {fit:.3g} s or shorter keeps it" if 0 < fit < self.dt else "")
        raise RetimeError(
            f"dt = {self.dt:g} s is too coarse for this path: the retimed rows, joined by "
            f"straight lines as the simulation and a controller take them, leave the path by "
            f"{err[i]:.3g} {unit} at joint '{joint.name}' (t = "
            f"{self.clock[k0] + where[i]:.4g} s of the program), more than the "
            f"{tol[i]:.3g} {unit} allowed{hint}")


def peak_ratio(sim: SimulationResult) -> float:
    """How close a simulated program came to its limits: the largest ratio of required to
    available effort and of commanded velocity to its limit (> 1: over them)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r_eff = np.where(sim.limit > 0, np.abs(sim.tau_required) / sim.limit,
                         np.where(sim.tau_required != 0, np.inf, 0.0))
        r_vel = np.abs(sim.qd_cmd) / sim.robot.velocity_limit
    return float(max(np.nanmax(r_eff), np.nanmax(r_vel)))


def accelerations(Q: NDArray, dt: float) -> NDArray:
    """The accelerations a program's rows ask for, as the simulation forms them: the velocity of
    the next interval minus this one's, over dt; the last cycle stops."""
    v = np.diff(Q, axis=0, prepend=Q[:1]) / dt
    return np.diff(v, axis=0, append=np.zeros((1, Q.shape[1]))) / dt
