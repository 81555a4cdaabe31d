"""Optimised excitation trajectories for identification (Swevers, Ganseman, Tukel, De Schutter and
Van Brussel 1997): a finite Fourier series per joint (:mod:`mrnea.identify.fourier`; Swevers'
``a_l / (w l)``, ``-b_l / (w l)`` are its sine and cosine amplitudes) whose coefficients make the
base regressor well conditioned, within the joints' limits.

**Criterion.** The log of the condition number of the base regressor stacked over one period,
columns scaled to unit norm (:mod:`mrnea.identify.criterion`; the number
:func:`mrnea.identify.identify` reports). Chosen over the log-determinant (D-optimality) because
the condition number bounds how much the efforts' noise is amplified in the worst-determined
direction of the base parameters, which is what fails an identification; a large determinant can
hide one weak direction behind strong ones. The column scaling makes it independent of the
parameters' units.

**Optimisation** (:class:`mrnea.identify.criterion.Problem`). ``scipy.optimize.minimize``
(SLSQP) over the free numbers of every joint
(the offset ``c_j`` and the amplitudes of harmonics 2..L; harmonic 1 keeps the motion at rest at
t = 0). The criterion and its gradient come from ``samples`` instants per period, the gradient
analytic through the SVD and by exact differences of the regressor
(:func:`mrnea.identify.criterion.derivatives`). Constraints on the same instants: the position
limits (``c_j`` also within them), the velocity and acceleration limits (all linear in the free
numbers) and ``|tau| <= effort_margin * effort_limit`` (tau = W theta of the robot's own
parameters, the drive law included; its Jacobian from the same derivatives). Starts: the best
``starts`` of ``candidates`` random series (each scaled into the limits), each optimised; the best
result is kept.

**Verification on the program's cycles.** The result is scaled about ``c`` (the oscillating part
times s <= 1: velocities and accelerations scale by s, positions move towards c) by the largest s
for which every limit holds at every cycle ``t = k dt`` and between them: a sampled maximum plus
``dt^2 / 8`` times a bound on the next derivative (``sum_l (l w)^(d + 2) (|a_l| + |b_l|)``) stays
within the limit; and the efforts ``H_a qdd + u'_a`` (Eqs. 42-43,
:func:`mrnea.actuators.actuator_efforts`: the command line's runs evaluate them one state at a
time on the kernel its simulation compiles, :func:`mrnea.actuators.one_state_at_a_time`) within
``effort_margin`` times
:func:`mrnea.actuators.effort_limits_at` (bisection on s). The condition number reported is over
those cycles; then mrnea simulates the program (the verdict).

**BLAS on one thread.** The search's linear algebra is on small matrices (the stacked base
regressor of the Puma 560 is 360 x 58): OpenBLAS's threads cost more there than they save (an SVD
4.1 ms on two threads against 1.0 ms on one, on the 2-core machine), so the search runs with the
BLAS libraries limited to one thread (``threadpoolctl``, for the call's duration, process-wide)
and its result does not depend on the machine's core count (docs/performance.md section 7).
"""

from __future__ import annotations

import heapq
import math
import numbers
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import threadpool_limits

from mrnea import validate
from mrnea.actuators import actuator_efforts, effort_limits_at
from mrnea.errors import StateError, quote
from mrnea.identify import criterion
from mrnea.identify.base import base_parameters
from mrnea.identify.criterion import Limits, Problem
from mrnea.identify.fourier import coefficients, evaluate
from mrnea.identify.regressor import require_serial
from mrnea.io.pathcsv import save_csv
from mrnea.io.program import Program, save_program
from mrnea.model import Robot
from mrnea.resources import require_memory
from mrnea.simulate import simulate

UNLIMITED_SPAN = math.pi  # [rad | m] the position range +-span of a joint without limits
BISECTIONS = 30  # steps of the bisection on the scale s for the efforts
MAX_CYCLES = 10_000_000  # rows of a program, at most (about 0.5 GB for 6 joints)
#: The most harmonics per joint: the search's SLSQP is dense in the n (2 L - 1) coefficients
#: (its step costs their cube). A first `mrnea excite puma560` took 17 s at 10 harmonics and
#: 109 s at 20 on the 2-core machine; at 100 one SLSQP iteration took minutes, and a stop
#: request waited for it (session 41).
MAX_HARMONICS = 20
#: The most random candidates: each is scored on its own (about 10 ms for a 2-joint arm, 25 ms
#: for the Puma 560 on the 2-core machine), so 10 000 take minutes; a billion would take months.
MAX_CANDIDATES = 10_000


@dataclass(frozen=True, eq=False)
class Excitation:
    """An excitation trajectory (:func:`excitation`), periodic and at rest at t = 0.

    Attributes
    ----------
    robot : the robot it was made for (its limits and parameters).
    base_frequency : f [Hz]; the period is 1 / f.
    c, a, b : (n,), (n, L), (n, L): ``q_j(t) = c_j + sum_l a_jl sin(2 pi f l t) + b_jl cos(2 pi
        f l t)`` [rad | m] (:mod:`mrnea.identify.fourier`).
    limits : what it keeps within (:class:`Limits`).
    dt : cycle time [s] of the program; ``t`` (K,) [s] and ``q_cmd`` (K, n) [rad | m]: its
        cycles over ``duration`` (a whole number of periods), the last row the first.
    condition : cond of the base regressor over one period's cycles, columns scaled to unit norm
        (:func:`mrnea.identify.criterion.condition`).
    condition_start : the same for the best random series, scaled into the limits the same way:
        what the optimisation started from.
    achievable, verdict : mrnea's simulation of the program on ``robot``.
    """

    robot: Robot
    base_frequency: float
    c: NDArray[np.float64]
    a: NDArray[np.float64]
    b: NDArray[np.float64]
    limits: Limits
    dt: float
    t: NDArray[np.float64]
    q_cmd: NDArray[np.float64]
    condition: float
    condition_start: float
    achievable: bool
    verdict: str

    @property
    def harmonics(self) -> int:
        return int(self.a.shape[1])

    @property
    def duration(self) -> float:
        """[s]"""
        return float(self.t[-1])

    def evaluate(self, t: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
        """q, qd, qdd (K, n) at times t (K,) [s], from the closed form."""
        t = np.asarray(t, dtype=float).reshape(-1)
        return evaluate(self.c, self.a, self.b, self.base_frequency, t)

    @property
    def program(self) -> Program:
        """The program (:class:`mrnea.io.Program`, naming no robot): ``simulate(robot,
        program.q_cmd, program.dt)`` runs it."""
        return Program(robot=None, dt=self.dt, t=self.t, q_cmd=self.q_cmd, f_ext=None,
                       f_ext_point=None, mode=None, name="excitation")

    def save_csv(self, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
        """Write the program as a path CSV (``t, <joint names>``, one row per cycle,
        :func:`mrnea.io.pathcsv.save_csv`): it reads back bit for bit."""
        return save_csv(path, self.t, self.q_cmd, self.robot.joint_names, overwrite)

    def save_program(self, path: str | os.PathLike[str], robot: str, csv: str,
                     program_keys: Mapping[str, Any] | None = None,
                     overwrite: bool = False) -> Path:
        """Write a program file (docs/programs.md) running the CSV :meth:`save_csv` wrote
        (``csv``, relative to the program file) on ``robot`` (a built-in name or a robot file's
        path), its rows read as they are; ``program_keys``: more ``[program]`` keys (an actuator
        file, a payload)."""
        comment = (f"Excitation trajectory for identification, made by mrnea: {self.harmonics} "
                   f"harmonics of {self.base_frequency:g} Hz, {self.duration:g} s; condition "
                   f"number of the base regressor {self.condition:.4g} (best random start "
                   f"{self.condition_start:.4g}). Verified: "
                   f"{'achievable' if self.achievable else 'NOT achievable'}.\n"
                   f"Run: mrnea check {Path(path).name}")
        program = {"name": "excitation", "robot": robot, "dt": self.dt, **(program_keys or {})}
        return save_program(path, program, {"csv": csv, "interpolation": "linear"}, None,
                            comment, overwrite)

    def summary(self) -> dict[str, object]:
        """The numbers, as plain JSON-ready values."""
        lim = self.limits

        def finite(v: NDArray) -> list[float | None]:
            return [float(x) if np.isfinite(x) else None for x in v]

        return {"robot": self.robot.name, "base_frequency": self.base_frequency,
                "harmonics": self.harmonics, "duration": self.duration, "dt": self.dt,
                "condition": self.condition,
                "condition_start": (self.condition_start if math.isfinite(self.condition_start)
                                    else None),
                "achievable": self.achievable, "verdict": self.verdict,
                "c": self.c.tolist(), "a": self.a.tolist(), "b": self.b.tolist(),
                "limits": {"lower": finite(lim.lower), "upper": finite(lim.upper),
                           "velocity": finite(lim.velocity),
                           "acceleration": finite(lim.acceleration),
                           "effort": finite(lim.effort)}}


def _limit(value: ArrayLike | None, default: ArrayLike, name: str, robot: Robot
           ) -> NDArray[np.float64]:
    """A per-joint limit > 0 (inf: none): one number or (n,); None: ``default``."""
    n = robot.n
    v = np.asarray(default if value is None else value)
    if v.dtype.kind not in "iuf" or v.ndim > 1 or (v.ndim == 1 and v.shape[0] != n):
        raise StateError(f"{name}: expected one number > 0 or {n} numbers (one per joint), got "
                         f"{value!r}")
    v = np.broadcast_to(v.astype(float), (n,))
    bad = np.flatnonzero(~(v > 0))
    if bad.size:
        raise StateError(f"{name}: must be > 0 (inf: none), got {v[bad[0]]} for joint "
                         f"'{robot.joint_names[bad[0]]}'")
    return v.copy()


def limits_of(robot: Robot, velocity_limit: ArrayLike | None = None,
              acceleration_limit: ArrayLike | None = None, effort_margin: float = 0.9) -> Limits:
    """The :class:`Limits` of :func:`excitation` (see there) for these arguments."""
    margin = validate.fraction(effort_margin, "effort_margin")
    lower = np.where(np.isfinite(robot.lower), robot.lower, -UNLIMITED_SPAN)
    upper = np.where(np.isfinite(robot.upper), robot.upper, UNLIMITED_SPAN)
    return Limits(lower, upper,
                  _limit(velocity_limit, robot.velocity_limit, "velocity_limit", robot),
                  _limit(acceleration_limit, np.inf, "acceleration_limit", robot),
                  margin * robot.effort_limit)


def _count(value: object, name: str, least: int) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) \
            or value < least:
        raise StateError(f"{name}: expected a whole number >= {least}, got {value!r}")
    return int(value)


def _whole(ratio: float, what: str) -> int:
    """round(ratio), a StateError unless ratio is a whole number >= 1 (to 1e-9)."""
    k = round(ratio)
    if k < 1 or abs(ratio - k) > 1e-9 * max(1.0, ratio):
        raise StateError(what)
    return int(k)


def _bounds_ok(limits: Limits, c: NDArray, a: NDArray, b: NDArray, f: float, dt: float,
               t: NDArray) -> float:
    """The largest s in [0, 1] for which c + s (the oscillation) keeps the position, velocity and
    acceleration limits at the cycles t and between them (module docstring)."""
    L = a.shape[1]
    q, qd, qdd = evaluate(np.zeros_like(c), a, b, f, t)
    amp = np.abs(a) + np.abs(b)  # (n, L)
    lw = 2 * np.pi * f * np.arange(1, L + 1)
    bound = [dt ** 2 / 8 * (amp * lw ** (d + 2)).sum(axis=1) for d in range(3)]  # (n,) each
    need = [(q.max(axis=0) + bound[0], limits.upper - c),
            (-q.min(axis=0) + bound[0], c - limits.lower),
            (np.abs(qd).max(axis=0) + bound[1], limits.velocity),
            (np.abs(qdd).max(axis=0) + bound[2], limits.acceleration)]
    s = 1.0
    for reach, room in need:
        with np.errstate(divide="ignore", invalid="ignore"):
            s = min(s, float(np.min(np.where(reach > 0, room / reach, np.inf))))
    return max(s, 0.0)


def _efforts_ok(robot: Robot, limits: Limits, q: NDArray, qd: NDArray, qdd: NDArray) -> bool:
    """Whether every cycle's efforts (:func:`mrnea.actuators.actuator_efforts`) stay within the
    effort margin of the limits at its speed (:func:`mrnea.actuators.effort_limits_at`)."""
    margin = limits.effort / robot.effort_limit  # effort_margin, or nan where both are inf
    cap = np.where(np.isfinite(limits.effort), effort_limits_at(robot, qd) * margin, np.inf)
    return bool(np.all(np.abs(actuator_efforts(robot, q, qd, qdd)) <= cap))


def into_limits(robot: Robot, limits: Limits, x: NDArray, harmonics: int, f: float, dt: float,
                 t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """(c, a, b) of the free numbers x, the oscillation scaled by the largest s that keeps every
    limit at the cycles t (module docstring)."""
    c, a, b = coefficients(x, robot.n, harmonics)
    s = _bounds_ok(limits, c, a, b, f, dt, t)

    def fits(scale: float) -> bool:
        return _efforts_ok(robot, limits, *evaluate(c, scale * a, scale * b, f, t))

    if not fits(s):
        lo, hi = 0.0, s
        for _ in range(BISECTIONS):
            lo, hi = ((lo + hi) / 2, hi) if fits((lo + hi) / 2) else (lo, (lo + hi) / 2)
        s = lo
    return c, s * a, s * b


def random_free(rng: np.random.Generator, limits: Limits, harmonics: int) -> NDArray:
    """Random free numbers (n, m): c uniform over the middle half of each joint's range,
    amplitudes of harmonic l normal with standard deviation 1 / l (scaled into the limits
    later)."""
    n, ell = limits.lower.size, np.arange(2, harmonics + 1)
    x = rng.normal(size=(n, 2 * harmonics - 1)) / np.concatenate([[1.0], ell, ell])
    mid, half = (limits.lower + limits.upper) / 2, (limits.upper - limits.lower) / 2
    x[:, 0] = mid + rng.uniform(-0.5, 0.5, n) * half
    return x


def excitation(robot: Robot, *, base_frequency: float = 0.1, harmonics: int = 5,
               duration: float | None = None, dt: float = 0.005,
               velocity_limit: ArrayLike | None = None,
               acceleration_limit: ArrayLike | None = None, effort_margin: float = 0.9,
               candidates: int = 100, starts: int = 3, maxiter: int = 100,
               samples: int | None = None, seed: int = 0,
               checkpoint: Callable[[], None] | None = None) -> Excitation:
    """An optimised excitation trajectory for identifying ``robot`` (module docstring).

    Parameters
    ----------
    robot : a serial chain; its position limits (a joint without: +-pi rad or m about 0), its
        inertial and drive parameters (the criterion's regressor, the efforts) and effort limits.
    base_frequency : f [Hz] of the Fourier series; the period is 1 / f.
    harmonics : 2 <= L <= :data:`MAX_HARMONICS`, the harmonics per joint (the highest at L f).
    duration : [s], a whole number of periods; None: one period.
    dt : the program's cycle time [s]; the period must be a whole number of cycles, at least
        10 L of them.
    velocity_limit, acceleration_limit : per joint (one number or (n,)) [rad/s | m/s, rad/s^2 |
        m/s^2], > 0, inf: none. Defaults: the robot's velocity limits; no acceleration limit.
    effort_margin : in (0, 1]: the efforts stay within this fraction of the effort limits.
    candidates, starts : random series drawn, and how many of the best are optimised.
    maxiter : SLSQP iterations per start.
    samples : instants per period of the optimisation's criterion and constraints; None: 12 L
        (at least twice the base parameters' count over n).
    seed : of the random series.
    checkpoint : called between candidates and every SLSQP iteration (the command line's stop
        requests, :func:`mrnea.cli.base.checkpoint`); None: nothing.

    Returns
    -------
    Excitation
    """
    require_serial(robot, "excitation")
    f = validate.real(base_frequency, "base_frequency")
    if not (math.isfinite(f) and f > 0):
        raise StateError(f"base_frequency: must be a finite frequency > 0 Hz, got {f}")
    L = _count(harmonics, "harmonics", 2)
    if L > MAX_HARMONICS:
        raise StateError(f"harmonics: at most {MAX_HARMONICS} (the search's cost grows as the "
                         f"cube of the coefficients, n (2 L - 1)), got {L}")
    dt = validate.time_step(dt)
    period = 1.0 / f
    duration = period if duration is None else validate.real(duration, "duration")
    periods = _whole(duration * f, f"duration: must be a whole number of periods (1 / "
                                   f"base_frequency = {period:g} s), got {duration:g} s")
    cycles = _whole(period / dt, f"dt: the period (1 / base_frequency = {period:g} s) must be "
                                 f"a whole number of cycles, got dt = {dt:g} s")
    if periods * cycles >= MAX_CYCLES:
        what = (f"duration: {duration:g} s", "a shorter duration") if periods > 1 else (
            f"base_frequency: one period, 1 / base_frequency = {period:g} s,",
            "a higher base frequency")  # one period: the frequency's fault
        raise StateError(f"{what[0]} at dt = {dt:g} s is {float(periods * cycles):.3g} cycles; "
                         f"at most {MAX_CYCLES} ({what[1]} or a coarser dt)")
    if cycles < 10 * L:
        raise StateError(f"dt: {dt:g} s gives {cycles} cycles per period; {L} harmonics need at "
                         f"least {10 * L} (dt <= {period / (10 * L):g} s)")
    limits = limits_of(robot, velocity_limit, acceleration_limit, effort_margin)
    candidates = _count(candidates, "candidates", 1)
    if candidates > MAX_CANDIDATES:
        raise StateError(f"candidates: at most {MAX_CANDIDATES} (each random series is scored on "
                         f"its own, tens of milliseconds each), got {candidates}")
    starts = _count(starts, "starts", 0)
    if starts > candidates:
        raise StateError(f"starts: at most candidates ({candidates}), got {starts}")
    maxiter = _count(maxiter, "maxiter", 1)
    base = base_parameters(robot)
    least = max(12 * L, -(-2 * base.r // robot.n))
    samples = least if samples is None else _count(samples, "samples", -(-base.r // robot.n) + 1)
    # the criterion's regressor and its derivatives (K, 3, n, n, 15 n) at the samples, and the
    # constraints' Jacobian [bytes]
    n, m = robot.n, 2 * L - 1
    require_memory(8.0 * samples * n * (15 * n * (3 * n + 2) + 8 * n * m),
                   f"samples: {samples} instants per period of {n} joints",
                   "fewer samples (None: 12 per harmonic)", StateError)
    seed = _count(seed, "seed", 0)
    validate.callable_or_none(checkpoint, "checkpoint")
    stop = checkpoint or (lambda: None)

    problem = Problem(robot, base, limits, L, f, samples)
    rng = np.random.default_rng(seed)
    t_opt = np.arange(samples) / (samples * f)
    t = np.arange(cycles) * dt  # one period's cycles
    pool: list[tuple[float, int, NDArray]] = []  # the best max(starts, 1): a max-heap of -value
    scored = []
    with threadpool_limits(limits=1, user_api="blas"):  # small matrices (module docstring)
        for k in range(candidates):
            c, a, b = coefficients(random_free(rng, limits, L), robot.n, L)
            s = _bounds_ok(limits, c, a, b, f, 1.0 / (samples * f), t_opt)
            x = _free(c, s * a, s * b)
            heapq.heappush(pool, (-problem.value(x), -k, x))  # ties: the earlier one kept
            if len(pool) > max(starts, 1):
                heapq.heappop(pool)
            stop()
        pool = sorted(pool, reverse=True)
        pool = [(-v, x) for v, _, x in pool]
        results = [pool[0][1]] + [problem.solve(x, maxiter, stop) for _, x in pool[:starts]]
        for x in filter(lambda x: np.all(np.isfinite(x)), results):
            c, a, b = into_limits(robot, limits, x, L, f, dt, t)
            W = criterion.stacked(robot, base, *evaluate(c, a, b, f, t))
            scored.append((criterion.condition(W), c, a, b))
    best = min(scored, key=lambda s: s[0])
    if not math.isfinite(best[0]):  # name the limits given (the robot's own: its name)
        given = [name for name, v in (("velocity_limit", velocity_limit),
                                      ("acceleration_limit", acceleration_limit)) if v is not None]
        given += ["effort_margin"] if np.isfinite(limits.effort).any() else []
        who = (f"{' or '.join(given)}: the limits" if given else
               f"robot {quote(robot.name)}: its limits")
        raise StateError(f"{who} leave no motion that excites every base parameter (the "
                         "condition number is infinite); allow larger velocities, accelerations "
                         "or efforts")
    t_all = np.arange(periods * cycles + 1) * dt
    q_cmd = evaluate(best[1], best[2], best[3], f, t_all)[0]
    q_cmd[-1] = q_cmd[0]  # the period closes exactly
    res = simulate(robot, q_cmd, dt, reactions=False)
    for arr in (t_all, q_cmd, best[1], best[2], best[3]):
        arr.setflags(write=False)
    return Excitation(robot, f, best[1], best[2], best[3], limits, dt, t_all, q_cmd, best[0],
                      scored[0][0], bool(res.achievable), res.verdict())


def _free(c: NDArray, a: NDArray, b: NDArray) -> NDArray:
    """The free numbers (n m,) of (c, a, b) (the inverse of
    :func:`mrnea.identify.fourier.coefficients`)."""
    return np.concatenate([c[:, None], a[:, 1:], b[:, 1:]], axis=1).ravel()
