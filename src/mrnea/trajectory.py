"""The path interpolator: commanded joint positions at every interpolation cycle dt (paper Sec. II).

A path planner sends the servo controllers one row of joint positions every interpolation cycle
Δt (3-10 ms in current controllers); :func:`mrnea.simulate.simulate` takes such rows. This module
makes them:

* :func:`trapezoidal` -- rest-to-rest segments through waypoints with synchronised trapezoidal
  (or triangular) velocity profiles, within per-joint velocity and acceleration limits;
* :func:`quintic` -- rest-to-rest quintic polynomial segments (zero velocity and acceleration at
  both ends of every segment), synchronised, within the same limits;
* :func:`from_csv` -- a recorded or externally planned path (time, q1..qn), resampled to dt;
* :func:`load_program` -- a small TOML program file (robot, dt, path, optional external wrench)
  into a :class:`Program`; the format is documented in ``docs/programs.md``.

Conventions. Joint positions in rad (revolute) or m (prismatic), times in s, velocity limits in
rad/s or m/s, acceleration limits in rad/s² or m/s². Every returned path is sampled exactly at
the cycle instants ``t[k] = t0 + k dt``; its first row is the first waypoint and its last row the
last waypoint, exactly (bit for bit). Each segment is a whole number of cycles long, so every
waypoint is reached exactly on a cycle.

Errors. Bad arguments raise :class:`mrnea.errors.StateError`; problems in a program or CSV file
raise :class:`ProgramFileError` (a :class:`mrnea.errors.MrneaError`, hence a ``ValueError``)
naming the file and the key, row or column at fault.
"""

from __future__ import annotations

import csv
import difflib
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.dynamics import _time_step
from mrnea.errors import MrneaError, StateError

if TYPE_CHECKING:
    from mrnea.model import Robot
    from mrnea.simulate import SimulationResult

__all__ = [
    "Program",
    "ProgramFileError",
    "from_csv",
    "load_program",
    "loads_program",
    "quintic",
    "trapezoidal",
]

#: A duration within this fraction of a cycle above a whole number of cycles is rounded down to
#: it (guards against ``2.0 / 0.01 = 200.00000000000003``-style rounding adding a cycle).
CYCLE_TOL = 1e-9
MAX_CYCLES = 1e9  # cycles in one program (at 1 ms, 11.6 days)

# Quintic rest-to-rest s(u) = 10u³ - 15u⁴ + 6u⁵: peak ds/du at u = 1/2 and peak |d²s/du²| at
# u = 1/2 ± √3/6.
QUINTIC_PEAK_VELOCITY = 15.0 / 8.0
QUINTIC_PEAK_ACCELERATION = 10.0 / math.sqrt(3.0)

MODES = ("hybrid", "paper")
PROFILES = ("trapezoidal", "quintic")
UNITS = ("rad", "deg")


class ProgramFileError(MrneaError):
    """A program file (TOML) or path CSV cannot be read, parsed or validated.

    The message names the file and the key, row or column at fault (TOML syntax errors: line
    and column). A subclass of :class:`mrnea.errors.MrneaError`, hence of ``ValueError``.
    """


# --- argument checks ------------------------------------------------------------------------


def _t0(t0: object) -> float:
    try:
        value = float(t0)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise StateError(f"t0: not a number: {t0!r}") from None
    if not math.isfinite(value):
        raise StateError(f"t0: must be finite, got {value}")
    return value


def _waypoints(waypoints: ArrayLike) -> NDArray[np.float64]:
    try:
        w = np.array(waypoints, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise StateError(f"waypoints: not a numeric (W, n) array ({exc})") from None
    if w.ndim != 2 or w.shape[0] < 1 or w.shape[1] < 1:
        raise StateError(f"waypoints: expected shape (W, n) with W >= 1 waypoints of n >= 1 "
                         f"joints, got {w.shape}")
    if not np.isfinite(w).all():
        bad = np.argwhere(~np.isfinite(w))[0]
        raise StateError(f"waypoints: NaN or inf at waypoint {bad[0]}, joint {bad[1]}")
    return w


def _limit(x: ArrayLike, n: int, name: str) -> NDArray[np.float64]:
    """A per-joint limit, (n,) or scalar, each > 0 (inf = unlimited)."""
    try:
        a = np.array(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise StateError(f"{name}: not a number or numeric array: {x!r}") from None
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise StateError(f"{name}: expected a scalar or {n} values (one per joint), got shape "
                         f"{a.shape}")
    bad = np.isnan(a) | ~(a > 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise StateError(f"{name}: must be > 0 for every joint (inf = unlimited), joint {i} "
                         f"has {a[i]}")
    return a


def _dwell(dwell: ArrayLike, W: int) -> NDArray[np.float64]:
    try:
        d = np.array(dwell, dtype=np.float64)
    except (TypeError, ValueError):
        raise StateError(f"dwell: not a number or numeric array: {dwell!r}") from None
    if d.ndim == 0:
        d = np.full(W, float(d))
    if d.shape != (W,):
        raise StateError(f"dwell: expected a scalar or {W} values (one per waypoint), got shape "
                         f"{d.shape}")
    bad = ~np.isfinite(d) | (d < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise StateError(f"dwell: must be finite and >= 0 s, waypoint {i} has {d[i]}")
    return d


def _cycles(duration: float | NDArray, dt: float) -> NDArray[np.int64]:
    """Whole cycles covering ``duration`` [s]: ceil(duration / dt), to within CYCLE_TOL.

    Raises StateError beyond MAX_CYCLES (a program that long is a mistake: a tiny dt or limit).
    """
    cycles = np.ceil(np.asarray(duration, dtype=float) / dt - CYCLE_TOL).clip(0)
    if not (np.all(np.isfinite(cycles)) and np.all(cycles <= MAX_CYCLES)):
        raise StateError(
            f"the program would take {np.max(cycles):.3g} cycles of dt = {dt:g} s "
            f"(more than {MAX_CYCLES:.0e}): check dt and the velocity and acceleration limits")
    return cycles.astype(np.int64)


# --- normalised profiles s(u), u = time / segment duration in [0, 1] -------------------------


def _trapezoid_shape(u: NDArray, f: float) -> NDArray:
    """Rest-to-rest trapezoid in normalised time with acceleration fraction ``f`` in [0, 1/2].

    Velocity ds/du rises at constant rate for ``u < f``, is ``1 / (1 - f)`` while cruising and
    falls symmetrically for ``u > 1 - f``; ``f = 1/2`` is the triangle, ``f = 0`` constant speed.
    ``s(0) = 0`` and ``s(1) = 1`` exactly.
    """
    if f <= 0.0:
        return u.copy()
    v = 1.0 / (1.0 - f)
    a = v / f
    s = v * (u - 0.5 * f)
    s = np.where(u < f, 0.5 * a * u * u, s)
    return np.where(u > 1.0 - f, 1.0 - 0.5 * a * (1.0 - u) ** 2, s)


def _quintic_shape(u: NDArray) -> NDArray:
    """``10u³ - 15u⁴ + 6u⁵``: rest to rest, zero acceleration at both ends; s(1) = 1 exactly."""
    return u * u * u * (10.0 + u * (-15.0 + 6.0 * u))


def _trapezoid_timing(dq: NDArray, vmax: NDArray, amax: NDArray) -> tuple[float, float]:
    """(T, f): shortest duration [s] and acceleration fraction of a synchronised trapezoid.

    All joints follow ``q_i = q0_i + dq_i s(t)`` with one normalised profile s, so every joint
    has the same acceleration, cruise and deceleration phases. s must satisfy
    ``|ds/dt| <= 1 / tau_v`` with ``tau_v = max_i |dq_i| / v_i`` and ``|d²s/dt²| <= 1 / c`` with
    ``c = max_i |dq_i| / a_i``: the classic minimum-time trapezoid for s, which is
    ``T = tau_v + c / tau_v`` (cruise reached, ``ta = c / tau_v``) if ``tau_v² >= c``, else the
    triangle ``T = 2 sqrt(c)``. When one joint binds both limits (e.g. a single joint, or joints
    with proportional limits) T is exactly the longest single-joint time; in general it can be
    longer (one joint limited by speed, another by acceleration).
    """
    d = np.abs(dq)
    tau_v = float(np.max(d / vmax))
    c = float(np.max(d / amax))
    if tau_v * tau_v >= c:
        if tau_v == 0.0:
            return 0.0, 0.0
        T = tau_v + c / tau_v
        return T, (c / tau_v) / T
    return 2.0 * math.sqrt(c), 0.5


def _quintic_timing(dq: NDArray, vmax: NDArray, amax: NDArray) -> float:
    """Shortest duration [s] of a synchronised quintic: peak velocity 15/8 |dq|/T <= v and
    peak acceleration 10/√3 |dq|/T² <= a for every joint."""
    d = np.abs(dq)
    t_v = QUINTIC_PEAK_VELOCITY * float(np.max(d / vmax))
    t_a = math.sqrt(QUINTIC_PEAK_ACCELERATION * float(np.max(d / amax)))
    return max(t_v, t_a)


def _assemble(w: NDArray, dt: float, t0: float, dwell: NDArray, durations: list[float],
              shapes: list[Any]) -> tuple[NDArray, NDArray]:
    """Concatenate the segments, each rounded up to whole cycles, plus the dwells."""
    n = w.shape[1]
    dwell_cycles = _cycles(dwell, dt)
    pieces = [w[:1]]
    if dwell_cycles[0]:
        pieces.append(np.broadcast_to(w[0], (int(dwell_cycles[0]), n)))
    for j, (T, shape) in enumerate(zip(durations, shapes, strict=True)):
        N = int(_cycles(T, dt))
        if T > 0.0:
            N = max(N, 1)
        if N:
            u = np.arange(1, N + 1, dtype=float) / N
            s = shape(u)[:, None]
            d = w[j + 1] - w[j]
            # Measured from the nearer end: exactly q0 at s = 0, q1 at s = 1 (q0 + s d may miss
            # it by an ulp) and a joint that does not move stays exactly where it is.
            pieces.append(np.where(s <= 0.5, w[j] + s * d, w[j + 1] - (1.0 - s) * d))
        if dwell_cycles[j + 1]:
            pieces.append(np.broadcast_to(w[j + 1], (int(dwell_cycles[j + 1]), n)))
    q = np.concatenate(pieces, axis=0)
    t = t0 + np.arange(q.shape[0], dtype=float) * dt
    return t, q


def _moving_check(dq: NDArray, T: float, j: int) -> None:
    if T == 0.0 and np.any(dq != 0.0):
        i = int(np.argmax(dq != 0.0))
        raise StateError(f"segment {j} (waypoint {j} -> {j + 1}): joint {i} moves but every "
                         "moving joint has infinite velocity and acceleration limits; give "
                         "at least one finite limit")


def trapezoidal(
    waypoints: ArrayLike,
    dt: float,
    velocity_limit: ArrayLike,
    acceleration_limit: ArrayLike,
    t0: float = 0.0,
    dwell: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rest-to-rest synchronised trapezoidal velocity profiles through waypoints.

    Every segment (waypoint j to j + 1) starts and ends at rest. All joints move along one
    normalised profile ``q(t) = q_j + (q_{j+1} - q_j) s(t)``, so they share the acceleration,
    cruise and deceleration phases and start and stop together; the joint that needs the longest
    time sets the duration and the others run scaled-down profiles. The duration is the
    shortest for which every joint stays within its limits (with a cruise phase if the cruise
    speed is reached, a triangular profile otherwise; with one joint: ``T = dq/v + v/a`` or
    ``T = 2 sqrt(dq/a)``). It is then rounded **up** to a whole number of cycles N and the
    profile is stretched in time to ``N dt`` (same phase fractions): velocities scale by
    ``T / (N dt) <= 1``, accelerations by its square, so the limits still hold, and each
    waypoint is reached exactly on a cycle.

    Parameters
    ----------
    waypoints : (W, n) joint positions [rad | m], W >= 1.
    dt : interpolation cycle [s], finite and > 0.
    velocity_limit : (n,) or scalar, > 0 [rad/s | m/s]; ``inf`` = unlimited.
    acceleration_limit : (n,) or scalar, > 0 [rad/s² | m/s²]; ``inf`` = unlimited (then the
        velocity jumps: a constant-speed segment). A moving joint needs at least one finite
        limit; a joint that does not move in a segment is unconstrained there.
    t0 : time of the first cycle [s].
    dwell : hold time at each waypoint [s], scalar (every waypoint, the first and last included)
        or (W,); rounded up to whole cycles.

    Returns
    -------
    t : (K,) cycle times ``t0 + k dt`` [s].
    q : (K, n) commanded positions; ``q[0]`` is the first waypoint, ``q[-1]`` the last, exactly.

    Raises
    ------
    StateError
        Bad shapes or values (non-finite waypoints, limits <= 0 or NaN, dt <= 0, ...).
    """
    dt = _time_step(dt)
    t0 = _t0(t0)
    w = _waypoints(waypoints)
    W, n = w.shape
    vmax = _limit(velocity_limit, n, "velocity_limit")
    amax = _limit(acceleration_limit, n, "acceleration_limit")
    dw = _dwell(dwell, W)
    durations: list[float] = []
    shapes: list[Any] = []
    for j in range(W - 1):
        dq = w[j + 1] - w[j]
        T, f = _trapezoid_timing(dq, vmax, amax)
        _moving_check(dq, T, j)
        durations.append(T)
        shapes.append(lambda u, f=f: _trapezoid_shape(u, f))
    return _assemble(w, dt, t0, dw, durations, shapes)


def quintic(
    waypoints: ArrayLike,
    dt: float,
    velocity_limit: ArrayLike,
    acceleration_limit: ArrayLike,
    t0: float = 0.0,
    dwell: ArrayLike = 0.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Rest-to-rest synchronised quintic polynomial segments through waypoints.

    Each segment is ``q(t) = q_j + (q_{j+1} - q_j) s(t / T)`` with
    ``s(u) = 10u³ - 15u⁴ + 6u⁵``: zero velocity and acceleration at both ends, peak velocity
    ``15/8 |dq| / T`` (at mid-segment) and peak acceleration ``10/√3 |dq| / T²``. T is the
    smallest whole number of cycles for which both peaks stay within every joint's limits.

    Parameters
    ----------
    waypoints : (W, n) joint positions [rad | m], W >= 1.
    dt : interpolation cycle [s], finite and > 0.
    velocity_limit : (n,) or scalar, > 0 [rad/s | m/s]; ``inf`` = unlimited.
    acceleration_limit : (n,) or scalar, > 0 [rad/s² | m/s²]; ``inf`` = unlimited. A moving joint
        needs at least one finite limit.
    t0 : time of the first cycle [s].
    dwell : hold time at each waypoint [s], scalar (every waypoint) or (W,); rounded up to whole
        cycles.

    Returns
    -------
    t : (K,) cycle times ``t0 + k dt`` [s].
    q : (K, n) commanded positions; ``q[0]`` is the first waypoint, ``q[-1]`` the last, exactly.

    Raises
    ------
    StateError
        Bad shapes or values.
    """
    dt = _time_step(dt)
    t0 = _t0(t0)
    w = _waypoints(waypoints)
    W, n = w.shape
    vmax = _limit(velocity_limit, n, "velocity_limit")
    amax = _limit(acceleration_limit, n, "acceleration_limit")
    dw = _dwell(dwell, W)
    durations: list[float] = []
    for j in range(W - 1):
        dq = w[j + 1] - w[j]
        T = _quintic_timing(dq, vmax, amax)
        _moving_check(dq, T, j)
        durations.append(T)
    return _assemble(w, dt, t0, dw, durations, [_quintic_shape] * (W - 1))


# --- CSV paths --------------------------------------------------------------------------------


def _read_text(path: Path, what: str) -> str:
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ProgramFileError(f"{path}: {what} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ProgramFileError(f"{path}: cannot read {what}: {exc}") from None


def _csv_table(path: Path, n: int | None) -> tuple[list[str], NDArray[np.float64]]:
    """Header and (R, 1 + n) numeric rows of a path CSV, every cell checked."""
    text = _read_text(path, "path CSV file")
    header: list[str] | None = None
    header_line = 0
    rows: list[list[float]] = []
    reader = csv.reader(text.splitlines())
    for cells in reader:
        line = reader.line_num
        cells = [c.strip() for c in cells]
        if not any(cells) or cells[0].startswith("#"):
            continue  # blank line or comment
        if header is None:
            header, header_line = cells, line
            if len(header) < 2:
                raise ProgramFileError(
                    f"{path}: line {line}: the header row needs a time column and at least one "
                    f"joint column, got {len(header)} column(s): {header}")
            if n is not None and len(header) != n + 1:
                raise ProgramFileError(
                    f"{path}: line {line}: expected {n + 1} columns (time + {n} joints), the "
                    f"header row has {len(header)}: {header}")
            if _is_number(header[0]):
                raise ProgramFileError(
                    f"{path}: line {line}: the first row must be a header (e.g. t,q1,q2,...), "
                    f"got numbers: {header}")
            continue
        if len(cells) != len(header):
            raise ProgramFileError(
                f"{path}: line {line} (data row {len(rows) + 1}): expected {len(header)} "
                f"columns as in the header (line {header_line}), got {len(cells)}")
        values = []
        for col, cell in enumerate(cells):
            where = (f"{path}: line {line} (data row {len(rows) + 1}), column {col + 1} "
                     f"('{header[col]}')")
            try:
                v = float(cell)
            except ValueError:
                raise ProgramFileError(
                    f"{where}: not a number: {cell!r}" if cell else f"{where}: empty cell"
                ) from None
            if not math.isfinite(v):
                raise ProgramFileError(f"{where}: {cell!r} is not a finite number")
            values.append(v)
        if rows and values[0] <= rows[-1][0]:
            raise ProgramFileError(
                f"{path}: line {line} (data row {len(rows) + 1}), column 1 ('{header[0]}'): "
                f"time {values[0]!r} s is not greater than the previous row's {rows[-1][0]!r} s "
                "(time must be strictly increasing)")
        rows.append(values)
    if header is None:
        raise ProgramFileError(f"{path}: empty file: expected a header row (time, then one column "
                               "per joint) and at least two data rows")
    if len(rows) < 2:
        raise ProgramFileError(f"{path}: {len(rows)} data row(s) after the header: a path needs "
                               "at least two (time strictly increasing)")
    return header, np.array(rows, dtype=np.float64)


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def from_csv(
    path: str | Path, dt: float, n: int | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read a path CSV (time, q1..qn) and resample it to the interpolation cycle dt.

    File layout: one header row (column names, free text), then one row per sample: time [s]
    (strictly increasing, need not be uniform) and n joint positions [rad | m]. Cells may be
    padded with spaces; blank lines and lines whose first cell starts with ``#`` are ignored.

    Resampling is **linear interpolation** between the rows, at ``t[k] = t_first + k dt`` from
    the first row's time to the last's. It reproduces the rows exactly (and any path linear in
    time), never overshoots (no position outside the rows' range, so no new limit violations)
    and needs no smoothing parameter. But between rows the velocity is constant, so it steps at
    every row: when the rows are coarser than dt, the second difference (the acceleration the
    simulator asks for) spikes at each row. Give the path at dt or finer, or smooth it first.
    If the time span is not a whole number of cycles, the last cycle falls after the last row
    and holds its position: the last commanded row always equals the CSV's last row.

    Parameters
    ----------
    path : the ``.csv`` file.
    dt : interpolation cycle [s], finite and > 0.
    n : expected number of joints (columns after the time column); None: any, from the header.

    Returns
    -------
    t : (K,) cycle times ``t_first + k dt`` [s], K >= 2.
    q : (K, n) commanded positions.

    Raises
    ------
    ProgramFileError
        Missing or empty file, wrong column count, non-numeric / empty / NaN / inf cell, time not
        strictly increasing, fewer than two data rows; the message names the file, the line
        (data row) and the column.
    StateError
        Bad ``dt`` or ``n``.
    """
    dt = _time_step(dt)
    if n is not None and (isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1):
        raise StateError(f"n: expected a number of joints >= 1 or None, got {n!r}")
    p = Path(path)
    _, data = _csv_table(p, None if n is None else int(n))
    return _resample(data[:, 0], data[:, 1:], dt)


def _resample(time: NDArray, q: NDArray, dt: float) -> tuple[NDArray, NDArray]:
    K = int(_cycles(time[-1] - time[0], dt)) + 1
    t = time[0] + np.arange(K, dtype=float) * dt
    out = np.empty((K, q.shape[1]))
    for i in range(q.shape[1]):
        out[:, i] = np.interp(t, time, q[:, i])
    out[0] = q[0]
    out[-1] = q[-1]
    return t, out


# --- program files ----------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Program:
    """A robot program ready for :func:`mrnea.simulate.simulate`, read by :func:`load_program`.

    Attributes
    ----------
    robot : a built-in robot name (``sdt``, ``puma560``) or the path of a robot file, resolved
        relative to the program file's folder.
    dt : interpolation cycle [s].
    t : (K,) cycle times [s] (``k dt`` for waypoint paths, the CSV's clock for CSV paths).
    q_cmd : (K, n) commanded joint positions [rad | m].
    f_ext : (K, 6) wrench ``[f; n]`` [N, N m] the end effector exerts on its environment, base
        frame, one row per cycle; None: no external wrench.
    f_ext_point : (3,) point [m] of the last link's frame where f_ext acts; None: its origin.
    mode : ``"hybrid"``, ``"paper"`` or None (the simulator's default).
    name : the program's name.
    source : the program file it was read from (for messages).

    The arrays are read-only.
    """

    robot: str
    dt: float
    t: NDArray[np.float64]
    q_cmd: NDArray[np.float64]
    f_ext: NDArray[np.float64] | None
    f_ext_point: NDArray[np.float64] | None
    mode: Literal["hybrid", "paper"] | None
    name: str
    source: str = ""

    @property
    def K(self) -> int:
        """Number of cycles."""
        return int(self.q_cmd.shape[0])

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.q_cmd.shape[1])

    @property
    def duration(self) -> float:
        """``(K - 1) dt`` [s]: from the first to the last cycle."""
        return (self.K - 1) * self.dt

    def load_robot(self) -> Robot:
        """The robot the program names: a built-in one or a robot file (any supported format).

        Raises
        ------
        ProgramFileError
            If the robot's joint count differs from the program's.
        RobotFileError
            If the robot file cannot be read.
        """
        from mrnea import robots
        from mrnea.io import load_robot

        robot = robots.load(self.robot) if self.robot in robots.names() else load_robot(
            self.robot)
        if robot.n != self.n:
            raise ProgramFileError(
                f"{self.source or self.name}: the program commands {self.n} joints but robot "
                f"'{robot.name}' ({self.robot}) has {robot.n}")
        return robot

    def simulate(self, robot: Robot | None = None, **kwargs: Any) -> SimulationResult:
        """Run the program with :func:`mrnea.simulate.simulate`.

        Parameters
        ----------
        robot : the robot to use; None: :meth:`load_robot`.
        **kwargs : passed on (``fd``, ``catch_up``, ``mode`` overrides the program's, ...).
        """
        from mrnea.simulate import simulate

        if robot is None:
            robot = self.load_robot()
        kw: dict[str, Any] = {"f_ext": self.f_ext, "f_ext_point": self.f_ext_point}
        if self.mode is not None:
            kw["mode"] = self.mode
        kw.update(kwargs)
        return simulate(robot, self.q_cmd, self.dt, **kw)


_TOP_KEYS = ("program", "path", "wrench")
_PROGRAM_KEYS = ("name", "robot", "dt", "mode")
_CSV_KEYS = ("csv", "units")
_PATH_KEYS = ("profile", "waypoints", "velocity_limit", "acceleration_limit", "dwell", "csv",
              "units")
_WRENCH_KEYS = ("times", "values", "point")


class _Context:
    """Builds ProgramFileError messages: ``<file>: <where>: <what>``."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, where: str, what: str) -> ProgramFileError:
        return ProgramFileError(f"{self.source}: {where}: {what}" if where else
                                f"{self.source}: {what}")

    def check_keys(self, table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                raise self.error(where, f"unknown key '{key}'{hint}; allowed keys: "
                                        f"{', '.join(allowed)}")

    def require(self, table: Mapping[str, Any], key: str, where: str) -> Any:
        if key not in table:
            raise self.error(where, f"missing required key '{key}'")
        return table[key]

    def table(self, value: Any, where: str, key: str) -> Mapping[str, Any]:
        if not isinstance(value, dict):
            raise self.error(where, f"'{key}' must be a table ([{key}]), got "
                                    f"{_type_name(value)} {value!r}")
        return value

    def string(self, value: Any, where: str, key: str) -> str:
        if not isinstance(value, str) or not value:
            raise self.error(where, f"'{key}' must be a non-empty string, got {value!r}")
        return value

    def number(self, value: Any, where: str, key: str, *, allow_inf: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(where, f"'{key}' must be a number, got {_type_name(value)} "
                                    f"{value!r}")
        v = float(value)
        if math.isnan(v) or (math.isinf(v) and not allow_inf):
            raise self.error(where, f"'{key}' must be a finite number, got {v}")
        return v

    def vector(self, value: Any, where: str, key: str, length: int | None = None, *,
               allow_inf: bool = False) -> NDArray[np.float64]:
        if not isinstance(value, list) or not value or (length is not None
                                                         and len(value) != length):
            size = f"{length} numbers" if length is not None else "numbers"
            got = f"{len(value)} entries" if isinstance(value, list) else _type_name(value)
            raise self.error(where, f"'{key}' must be an array of {size}, got {got}: {value!r}")
        return np.array([self.number(v, where, f"{key}[{k}]", allow_inf=allow_inf)
                         for k, v in enumerate(value)])

    def matrix(self, value: Any, where: str, key: str, width: int | None = None,
               rows: int | None = None) -> NDArray[np.float64]:
        """An array of equal-length arrays of finite numbers; the error names the row (1-based)."""
        if not isinstance(value, list) or not value:
            raise self.error(where, f"'{key}' must be a non-empty array of arrays, got "
                                    f"{value!r}")
        if rows is not None and len(value) != rows:
            raise self.error(where, f"'{key}' has {len(value)} rows, expected {rows}")
        expected = width if width is not None else (
            len(value[0]) if isinstance(value[0], list) else None)
        out = []
        for r, row in enumerate(value, start=1):
            if not isinstance(row, list):
                raise self.error(where, f"'{key}' row {r} must be an array of numbers, got "
                                        f"{_type_name(row)} {row!r}")
            if expected is not None and len(row) != expected:
                ref = "" if width is not None else " (the length of row 1)"
                raise self.error(where, f"'{key}' row {r} has {len(row)} values, expected "
                                        f"{expected}{ref}")
            out.append(self.vector(row, where, f"{key} row {r}"))
        return np.array(out)

    def limit(self, value: Any, where: str, key: str, n: int) -> NDArray[np.float64]:
        if isinstance(value, list):
            a = self.vector(value, where, key, n, allow_inf=True)
        else:
            a = np.full(n, self.number(value, where, key, allow_inf=True))
        if not (a > 0).all():
            raise self.error(where, f"'{key}' must be > 0 for every joint (inf = unlimited), "
                                    f"got {a.tolist()}")
        return a


def _type_name(value: object) -> str:
    return {dict: "table", list: "array", str: "string", bool: "boolean"}.get(
        type(value), type(value).__name__)


def _toml_error(text: str, exc: tomllib.TOMLDecodeError) -> str:
    """tomllib's message, with line and column also for errors 'at end of document'."""
    msg = str(exc)
    if "(at end of document)" in msg:
        lines = text.splitlines() or [""]
        msg = msg.replace("(at end of document)",
                          f"(at line {len(lines)}, column {len(lines[-1]) + 1}: end of document)")
    return msg


def _resolve_robot(ctx: _Context, value: str, base_dir: Path) -> str:
    from mrnea import robots

    if value in robots.names():
        return value
    p = Path(value).expanduser()
    if not p.is_absolute():
        p = base_dir / p
    if not p.is_file():
        raise ctx.error("[program]", f"robot {value!r} is neither a built-in robot "
                                     f"({', '.join(robots.names())}) nor an existing robot file "
                                     f"(looked for {p})")
    return str(p)


def _path(ctx: _Context, table: Mapping[str, Any], dt: float, base_dir: Path
          ) -> tuple[NDArray, NDArray]:
    where = "[path]"
    ctx.check_keys(table, _PATH_KEYS, where)
    units = table.get("units", "rad")
    if units not in UNITS:
        raise ctx.error(where, f"'units' must be one of {', '.join(map(repr, UNITS))}, got "
                               f"{units!r}")
    scale = math.pi / 180.0 if units == "deg" else 1.0
    if "csv" in table:
        for key in table:
            if key not in _CSV_KEYS:
                raise ctx.error(where, f"key '{key}' cannot be used with 'csv' (a CSV path gives "
                                       "its own positions and times; allowed with csv: "
                                       f"{', '.join(_CSV_KEYS)})")
        name = ctx.string(table["csv"], where, "csv")
        p = Path(name).expanduser()
        if not p.is_absolute():
            p = base_dir / p
        _, data = _csv_table(p, None)
        return _resample(data[:, 0], data[:, 1:] * scale, dt)
    if "waypoints" not in table and "profile" not in table:
        raise ctx.error(where, "give either 'csv' (a path CSV file) or 'profile' and "
                               "'waypoints' (with velocity_limit and acceleration_limit)")
    profile = ctx.string(ctx.require(table, "profile", where), where, "profile")
    if profile not in PROFILES:
        close = difflib.get_close_matches(profile, PROFILES, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ctx.error(where, f"unknown profile {profile!r}{hint}; expected one of "
                               f"{', '.join(map(repr, PROFILES))}")
    w = ctx.matrix(ctx.require(table, "waypoints", where), where, "waypoints") * scale
    n = w.shape[1]
    vmax = ctx.limit(ctx.require(table, "velocity_limit", where), where, "velocity_limit",
                     n) * scale
    amax = ctx.limit(ctx.require(table, "acceleration_limit", where), where,
                     "acceleration_limit", n) * scale
    dwell: float | NDArray = 0.0
    if "dwell" in table:
        d = table["dwell"]
        dwell = (ctx.vector(d, where, "dwell", w.shape[0]) if isinstance(d, list)
                 else ctx.number(d, where, "dwell"))
        if np.any(np.asarray(dwell) < 0):
            raise ctx.error(where, f"'dwell' must be >= 0 s, got {np.asarray(dwell).tolist()}")
    fn = trapezoidal if profile == "trapezoidal" else quintic
    try:
        return fn(w, dt, vmax, amax, dwell=dwell)
    except StateError as exc:
        raise ctx.error(where, str(exc)) from None


def _wrench(ctx: _Context, table: Mapping[str, Any], t: NDArray
            ) -> tuple[NDArray, NDArray | None]:
    where = "[wrench]"
    ctx.check_keys(table, _WRENCH_KEYS, where)
    times = ctx.vector(ctx.require(table, "times", where), where, "times")
    if np.any(np.diff(times) <= 0):
        k = int(np.argmax(np.diff(times) <= 0)) + 1
        raise ctx.error(where, f"'times' must be strictly increasing: times[{k}] = {times[k]} "
                               f"follows {times[k - 1]}")
    values = ctx.matrix(ctx.require(table, "values", where), where, "values", width=6,
                        rows=times.size)
    f_ext = np.empty((t.size, 6))
    for c in range(6):
        f_ext[:, c] = np.interp(t, times, values[:, c])
    point = None
    if "point" in table:
        point = ctx.vector(table["point"], where, "point", 3)
    return f_ext, point


def loads_program(text: str, source: str = "<string>", base_dir: str | Path | None = None
                  ) -> Program:
    """Parse a program from a TOML string (format: ``docs/programs.md``).

    Parameters
    ----------
    text : the TOML document.
    source : a name for it in error messages (the file name).
    base_dir : folder against which relative robot and CSV paths resolve; None: the current
        folder.

    Returns
    -------
    Program

    Raises
    ------
    ProgramFileError
        TOML syntax (with line and column), unknown keys (with a suggestion), missing keys,
        wrong types and values; the message names ``source`` and the table and key at fault.
    """
    ctx = _Context(source)
    base = Path.cwd() if base_dir is None else Path(base_dir)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ctx.error("", f"invalid TOML: {_toml_error(text, exc)}") from None
    ctx.check_keys(doc, _TOP_KEYS, "top level")
    prog = ctx.table(ctx.require(doc, "program", "top level"), "top level", "program")
    ctx.check_keys(prog, _PROGRAM_KEYS, "[program]")
    default_name = Path(source).stem if source != "<string>" else "program"
    name = ctx.string(prog.get("name", default_name), "[program]", "name")
    robot = _resolve_robot(ctx, ctx.string(ctx.require(prog, "robot", "[program]"), "[program]",
                                           "robot"), base)
    dt = ctx.number(ctx.require(prog, "dt", "[program]"), "[program]", "dt")
    if not dt > 0:
        raise ctx.error("[program]", f"'dt' must be a time step > 0 s, got {dt}")
    mode = prog.get("mode")
    if mode is not None and mode not in MODES:
        raise ctx.error("[program]", f"'mode' must be one of {', '.join(map(repr, MODES))}, "
                                     f"got {mode!r}")
    path = ctx.table(ctx.require(doc, "path", "top level"), "top level", "path")
    t, q = _path(ctx, path, dt, base)
    if q.shape[0] < 2:
        raise ctx.error("[path]", "the program is a single cycle (all waypoints equal and no "
                                  "dwell); give at least two distinct waypoints or a dwell")
    f_ext = point = None
    if "wrench" in doc:
        f_ext, point = _wrench(ctx, ctx.table(doc["wrench"], "top level", "wrench"), t)
    for a in (t, q, f_ext, point):
        if a is not None:
            a.setflags(write=False)
    return Program(robot=robot, dt=dt, t=t, q_cmd=q, f_ext=f_ext, f_ext_point=point,
                   mode=mode, name=name, source=source)


def load_program(path: str | Path) -> Program:
    """Load a program file (TOML, format in ``docs/programs.md``).

    Parameters
    ----------
    path : the ``.toml`` program file. Relative robot and CSV paths in it resolve against its
        folder.

    Returns
    -------
    Program
        robot, dt [s], t (K,) [s], q_cmd (K, n) [rad | m], f_ext (K, 6) [N, N m] or None,
        f_ext_point (3,) [m] or None, mode, name.

    Raises
    ------
    ProgramFileError
        Missing or unreadable file, TOML syntax error (line and column), unknown key (with a
        did-you-mean suggestion), missing key, bad value; or an error in the path CSV it names.
    """
    p = Path(path)
    text = _read_text(p, "program file")
    return loads_program(text, source=str(p), base_dir=p.parent)

