"""The simulation system (paper Secs. II and VI): will the robot really make the programmed motion?

:func:`simulate` takes the commanded positions a path planner sends, one row per interpolation
cycle dt, and runs the Sec. II cycle every cycle in compiled code (kernels/simulate.py): clamp
the command to the joint limits, desired acceleration, required efforts, saturation, achievable
accelerations, next state, joint reaction loads. The :class:`SimulationResult` holds every cycle
and its :meth:`SimulationResult.summary` answers the designer's questions.

Time convention (row k is the instant t_k = k dt): ``q_cmd[k]`` is the program,
``qd_cmd[k] = (q_cmd[k] - q_cmd[k-1]) / dt`` its velocity over the interval ending at t_k (the
paper's desired velocity; ``qd_cmd[0]`` is the initial velocity), ``q[k], qd[k]`` the robot's
state, and ``qdd[k], tau[k], ...`` what cycle k does on its way to t_{k+1}. The program is taken
to end at rest: the last cycle commands zero velocity.
"""

from __future__ import annotations

import contextlib
import dataclasses
import inspect
import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, cycles, validate
from mrnea.achievable import MODES, check_moves
from mrnea.cartesian import CartesianPath
from mrnea.errors import OutputError, StateError
from mrnea.io.source import as_path
from mrnea.io.writer import check_new, create
from mrnea.kernels.drive_ways import solve_mode
from mrnea.kernels.engines import ENGINE_CRBA, ENGINE_MRNEA, ENGINE_WALKER_ORIN
from mrnea.kernels.layout import ACHIEVABLE, entry_scratch
from mrnea.kernels.simulate import program_requirement, simulate_cycles
from mrnea.kernels.status import NONFINITE, OK, OVERFLOW
from mrnea.model import Robot
from mrnea.resources import require_memory
from mrnea.summary import final_position_line, start_violations, summarize, verdict

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: A tracking error at most this many times max(1, max |q_cmd|) of its joint [rad | m] is 0:
#: rounding, not lag (q's float resolution is 2.2e-16 |q|; this leaves room for the rounding of
#: many cycles and is far below any drive's resolution).
TRACKING_RESOLUTION = 1e-12
FD_ENGINES = {"mrnea": ENGINE_MRNEA, "walker_orin": ENGINE_WALKER_ORIN, "crba": ENGINE_CRBA}
CHUNK = 2000  # cycles per compiled call: the progress callback runs between chunks
#: A joint speed [rad/s | m/s] no machine comes near: a simulated robot beyond it has run away
#: (:attr:`SimulationResult.runaway_time`), well before its numbers overflow.
RUNAWAY_SPEED = 1e6


@dataclass(frozen=True)
class SimulationResult:
    """Every cycle of a simulation. Arrays are (K, n) unless said otherwise; SI units.

    Attributes
    ----------
    robot : the simulated Robot.
    dt : interpolation cycle [s].
    mode : ``"hybrid"`` or ``"paper"`` (see :mod:`mrnea.achievable`).
    t : (K,) time [s].
    q_cmd, qd_cmd : the program: positions and velocities (see the module docstring).
    qdd_des : accelerations each cycle asked for, after clamping to the joint limits.
    q, qd, qdd : the motion the robot really makes (the simulated response).
    tau : joint-side efforts the drives apply [N m | N]; tau_motor = tau / G; limit: the effort
        limit at the current speed; margin = limit - |tau|.
    tau_required : what qdd_des needed at the robot's own state [N m | N]. After a saturation
        the robot lags its program and this includes recovering the lag within one cycle
        ((v - qd) / dt): use program_effort to size a drive.
    coulomb : the Coulomb friction effort phi each cycle resolved [N m | N], joint side: F+
        moving up, -F- moving down, within [-F-, F+] while stuck (tau = H_a qdd + u' + F_v qd
        + coulomb).
    stuck : (K, n) bool, the joint is at rest over the cycle (its new velocity is exactly 0).
    program_effort : the program's own requirement [N m | N], joint side: the effort cycle k
        needs at the program's state q_cmd[k], qd_cmd[k] to make the program's next velocity,
        with the full actuator model, before any lag (kernels/simulate.py
        ``program_requirement``); program_limit: the effort limit at the program's speed.
    saturated : (K, n) bool, the drive is at its limit and misses the command.
    position_clamped, velocity_clamped : (K, n) bool, the command exceeded a joint limit.
    reaction : (K, n, 6) each joint's reaction wrench [f; n] in its joint frame
        (:func:`mrnea.joint_reactions`); None when the run did not compute them
        (``simulate(..., reactions=False)``).
    tracking_error : q_cmd - q, 0 where it is rounding: at most :data:`TRACKING_RESOLUTION`
        times ``max(1, max |q_cmd|)`` of its joint.
    completed : False if the run was interrupted; the arrays then hold the cycles done (K of
        them) and the run is never reported achievable (see :attr:`achievable`).
    runaway_time : the time [s] at which the simulated robot ran away: a joint's speed passed
        :data:`RUNAWAY_SPEED`, or its state overflowed (a wrench or a load far beyond what the
        drives hold accelerates it without bound; the rigid-body motion itself diverges). The
        run stops there: the arrays hold the K cycles before it, and the run is NOT ACHIEVABLE
        (a verdict, not an error). None: it did not.
    tool_position_error, tool_orientation_error : (K,) for a Cartesian program
        (``simulate(..., cartesian=prog.cartesian)``): how far the real motion's tool frame is
        from the programmed pose, ``|p(q) - p*|`` [m] and the angle of ``R*^T R(q)`` [rad];
        None otherwise.
    tool_point : for a Cartesian program of one tool on the last link, the tool frame's origin
        [m] in the last link's frame (the 3D view draws its path, the programmed Cartesian path,
        and the real one); None otherwise (the 3D view traces every branch's tip).
    tool_targets : for a Cartesian program, (M, 4, 4) the target poses of its Cartesian moves,
        base frame [m] (the 3D view marks them); None otherwise.
    """

    robot: Robot
    dt: float
    mode: str
    t: NDArray
    q_cmd: NDArray
    qd_cmd: NDArray
    qdd_des: NDArray
    q: NDArray
    qd: NDArray
    qdd: NDArray
    tau: NDArray
    tau_motor: NDArray
    tau_required: NDArray
    limit: NDArray
    margin: NDArray
    saturated: NDArray
    position_clamped: NDArray
    velocity_clamped: NDArray
    reaction: NDArray | None
    tracking_error: NDArray
    coulomb: NDArray
    stuck: NDArray
    program_effort: NDArray
    program_limit: NDArray
    completed: bool = True
    runaway_time: float | None = None
    fd: str = "mrnea"
    tool_position_error: NDArray | None = None
    tool_orientation_error: NDArray | None = None
    tool_point: tuple[float, float, float] | None = None
    tool_targets: NDArray | None = None
    _summary: dict = field(default_factory=dict, repr=False, compare=False)
    #: (2, n): q_cmd[K], qd_cmd[K] of the program, when the run stopped before its end; None:
    #: the run held the program's last cycle (:func:`mrnea.summary.program_next`)
    _next: NDArray | None = field(default=None, repr=False, compare=False)

    @property
    def K(self) -> int:
        """Number of cycles."""
        return self.t.shape[0]

    @property
    def achievable(self) -> bool | None:
        """True when the whole program ran from a start within the joint limits with no
        saturated effort and no clamped command; False when the start is outside the limits or
        some cycle saturated or clamped; None when the run was interrupted before any did
        (unknown: the rest of the program was not simulated)."""
        if (self.saturated.any() or self.position_clamped.any() or self.velocity_clamped.any()
                or self.runaway_time is not None or start_violations(self)):
            return False
        return True if self.completed else None

    def bearing_loads(self) -> cycles.BearingLoads:
        """The reaction loads of every cycle split along and across each joint's axis.

        Raises
        ------
        StateError
            The run did not compute reactions (``simulate(..., reactions=False)``).
        """
        return cycles.bearing_loads(self)

    def summary(self) -> dict[str, Any]:
        """The answers a designer wants, as strict JSON data (RFC 8259: an unlimited value is
        ``None``, JSON ``null``; no NaN or infinity), SI units; :mod:`mrnea.summary`.

        Top level: ``achievable`` (:attr:`achievable`: true, false, or null for an interrupted
        run that exceeded no limit in the cycles it did), ``completed`` and
        ``interrupted_after_cycles``; ``first_infeasible`` (time, cycle, joint, reason, and what
        was commanded or needed against what was available) or null; ``start_infeasible`` (the
        joints whose start is outside their position or velocity limits); ``worst_joint`` and
        ``worst_effort_ratio`` (the program's largest required effort / limit, below).

        Per joint, the program's own requirement (:attr:`program_effort`, before any lag):
        ``program_peak_effort`` [N m | N] and ``program_peak_time`` [s], ``program_rms_effort``,
        ``program_peak_motor_torque`` and ``program_rms_motor_torque`` [N m, motor side],
        ``program_effort_ratio`` (peak of |required| / the limit at the program's speed; null
        for a joint without a drive, ``drive = "unpowered"``, or without a limit,
        ``"unlimited"``, or commanded beyond its no-load speed), with its time, effort and
        limit, and ``program_first_over_time``. Then the simulated response: time saturated
        and stuck [s], peak and RMS motor torque [N m], peak effort [N m | N] against
        ``effort_limit``, peak speed [rad/s | m/s], peak reaction force [N] and moment [N m]
        (magnitudes; axial and radial split of the force along the joint axis, bending
        moment), worst tracking error and when, and the position error q_cmd - q at the last cycle
        (``final_position_error``; tracking errors [rad | m] are 0 below the resolution
        :attr:`tracking_error` states).
        """
        if not self._summary:
            object.__setattr__(self, "_summary", summarize(self))
        return self._summary

    def verdict(self) -> str:
        """One line: ACHIEVABLE with the worst joint's headroom, or NOT ACHIEVABLE with the
        worst joint's requirement against its limit (units: N m or N) and when; an
        interrupted run says after how many cycles, and is never called achievable
        (:func:`mrnea.summary.verdict`)."""
        return verdict(self)

    def final_position_line(self) -> str | None:
        """None when the run completed and the robot ended where the program ends; else one
        line stating each joint's final position error q_cmd - q [rad | m] (0: within the
        resolution of :attr:`tracking_error`; :func:`mrnea.summary.final_position_line`)."""
        return final_position_line(self)

    def program_qdd(self, rows: slice = slice(None)) -> NDArray:
        """The program's own acceleration [rad/s^2 | m/s^2] at the cycles ``rows``: the one
        :attr:`program_effort` is computed for, ``(qd_cmd[k + 1] - qd_cmd[k]) / dt``, unclamped;
        after the last row the program's own next velocity, 0 at the program's end (a run that
        stopped before it: :func:`mrnea.summary.program_next`). What the drive asked for once the
        robot lags is ``qdd_des`` (the catch-up)."""
        return cycles.program_qdd(self, rows)

    def columns(self, rows: slice = slice(None)) -> dict[str, NDArray]:
        """The per-cycle table as named 1-D columns: ``t [s]``, then ``<quantity>_<joint>
        [<unit>]`` (SI units of that joint, :data:`mrnea.model.JOINT_UNITS`; the flags
        ``saturated``, ``position_clamped``, ``velocity_clamped``, ``stuck`` are booleans,
        without a unit), then ``reaction_<fx..nz>_<joint> [N | N m]``.

        The quantities, in order: the program (``q_cmd``, ``qd_cmd``) and its own requirement
        (``program_qdd``, ``program_effort``, ``program_limit``: the limit at the program's
        speed), the simulated response (``q``, ``qd``, ``qdd``, ``tau``, ``tau_motor``,
        ``limit``, ``margin``, the flags, ``tracking_error``, ``coulomb``), and last what each
        cycle asked for from the robot's own state: ``catch_up_qdd`` (:attr:`qdd_des`) and
        ``catch_up_effort`` (:attr:`tau_required`), the program's own while the robot keeps
        up, the catch-up of the whole lag in one cycle once it lags. For a Cartesian program,
        ``tool_position_error [m]`` and ``tool_orientation_error [rad]`` come last."""
        return cycles.columns(self, rows)

    def to_csv(self, path: str | os.PathLike, overwrite: bool = False) -> Path:
        """Write the per-cycle table (:meth:`columns`: one header row of names with units, one
        row per cycle, flags as ``True``/``False``): ``pandas.read_csv(path)`` reads it, the
        flags as booleans.

        Written through :func:`mrnea.io.writer.create`: whole or not at all, never through a
        symbolic link; an existing file (or link) is replaced only with ``overwrite``, else
        :class:`~mrnea.errors.OutputError`.
        """
        with create(path, overwrite, binary=True) as fh:
            for k in range(0, max(self.K, 1), CHUNK):
                fh.write(cycles.csv_rows(self, slice(k, k + CHUNK), header=k == 0))
        return Path(path)

    def _first(self, k: int) -> SimulationResult:
        """The first k cycles (an interrupted run), as views, and the program's row after them."""
        arrays = {f.name: getattr(self, f.name)[:k] for f in dataclasses.fields(self)
                  if isinstance(getattr(self, f.name), np.ndarray) and f.name[0] != "_"}
        nxt = self._next if k >= self.K else np.stack((self.q_cmd[k], self.qd_cmd[k]))
        return dataclasses.replace(self, **arrays, completed=False, _summary={}, _next=nxt)

    def save_summary(self, path: str | os.PathLike, overwrite: bool = False) -> Path:
        """Write :meth:`summary` as JSON (``summary.json``), as :meth:`to_csv` writes."""
        with create(path, overwrite) as fh:
            json.dump(self.summary(), fh, indent=2, allow_nan=False)
            fh.write("\n")
        return Path(path)

    def plot(self, path: str | os.PathLike | None = None,
             overwrite: bool = False) -> dict[str, Figure]:
        """The report's figures of this run, optionally saved as PNG files in the folder
        ``path``: :func:`mrnea.report.plot_result` (see there)."""
        from mrnea.report.figures import plot_result  # matplotlib: loaded when first asked for

        return plot_result(self, path, overwrite)

    def report(self, path: str | os.PathLike, overwrite: bool = False,
               view3d: bool = True) -> Path:
        """Write the HTML report of this run, with the interactive 3D view of the motion unless
        ``view3d`` is False: :func:`mrnea.report.write_report` (see there)."""
        from mrnea.report.html import write_report  # matplotlib: loaded when first asked for

        return write_report(self, path, overwrite, view3d=view3d)


def simulate(
    robot: Robot,
    q_cmd: ArrayLike,
    dt: float,
    mode: Literal["hybrid", "paper"] = "hybrid",
    f_ext: ArrayLike | None = None,
    f_ext_point: ArrayLike | None = None,
    fd: Literal["mrnea", "walker_orin", "crba"] = "mrnea",
    q0: ArrayLike | None = None,
    qd0: ArrayLike | None = None,
    catch_up: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
    stream: str | os.PathLike | None = None,
    overwrite: bool = False,
    reactions: bool = True,
    cartesian: CartesianPath | None = None,
) -> SimulationResult:
    """Simulate the programmed motion q_cmd (K, n) [rad | m], one row per interpolation cycle dt
    [s]; a program (or qd0) faster than :data:`RUNAWAY_SPEED` is refused: a unit mistake.

    Parameters
    ----------
    mode : ``"hybrid"`` (default) or ``"paper"``: how saturation is resolved each cycle.
    f_ext, f_ext_point : the wrench the last link exerts on its environment, (6,) constant or
        (K, 6) per cycle, and its point in the last link's frame, (3,) or (K, 3). Or wrenches on
        any links, by name: ``f_ext={"hand_l": w, ...}``, each w (6,) or (K, 6), and
        ``f_ext_point={"hand_l": p, ...}``, each p (3,) or (K, 3) in that link's frame
        (:mod:`mrnea.dynamics`, "External wrench").
    fd : how each cycle forms H_a and u'_a: ``"mrnea"`` (the paper: one pass),
        ``"walker_orin"`` (n + 1 RNEA passes) or ``"crba"`` (CRBA + RNEA). The results agree to
        rounding; the choice reproduces the paper's cost comparison. (ABA gives no H, which the
        hybrid mode needs, so it is not offered here.)
    q0, qd0 : initial state; default the first programmed position, at rest.
    catch_up : position-loop gain [1/s]. 0 (default, the paper's behaviour): every cycle asks
        for the program's velocity, so a lag caused by saturation persists. > 0: every cycle asks
        for the program's velocity plus ``catch_up * (q_cmd - q)``, as a cascaded servo's
        position loop does, so the lag closes at that rate once the limits allow; keep
        ``catch_up * dt`` well below 1 (e.g. 10-50 1/s at dt = 5 ms).
    progress : called as ``progress(cycles_done, K)`` between compiled chunks; what else than
        KeyboardInterrupt (below) it raises reaches the caller as it is, no stream written.
    stream : a CSV path: the per-cycle table is written while the simulation runs, chunk by
        chunk (the same table as :meth:`SimulationResult.to_csv`), for long runs, to a private
        temporary file in the same folder that is renamed to ``stream`` when the run ends or is
        interrupted, and removed if it fails (:func:`mrnea.io.writer.create`). ``overwrite``
        allows replacing an existing file or link (the link itself, never its target).
    reactions : compute each joint's reaction wrench every cycle (default). False: a check
        that needs the verdict alone (e.g. :func:`mrnea.retime`'s search) skips that pass,
        which is about a quarter of a run's time (measured: a run without them takes 0.74-0.75 of
        the time on the Puma 560 and the SDT); the result's ``reaction`` is then None and the
        summary's reaction peaks null.
    cartesian : a Cartesian program's tool path (``prog.cartesian``, :mod:`mrnea.cartesian`;
        q_cmd must be its ``prog.q_cmd``): the result then has the real motion's tool errors
        against the programmed pose every cycle (``tool_position_error``,
        ``tool_orientation_error``), in the table and the summary.

    On KeyboardInterrupt the cycles done so far are returned with ``completed=False``, and a
    streamed table holds exactly those cycles; also when ``progress`` raises it after the last
    chunk (all K cycles, still ``completed=False``: the stop request is never swallowed).
    """
    code = validate.choice("mode", mode, MODES)
    validate.require_robot(robot)
    engine = validate.choice("fd", fd, FD_ENGINES)
    dt = validate.time_step(dt)
    _check_progress(progress)
    catch_up = validate.catch_up(catch_up, dt)
    reactions = validate.flag(reactions, "reactions")
    check_new([], overwrite)  # its type, with or without a stream: an OutputError, as create's
    stream = None if stream is None else as_path(stream, "stream", OutputError)
    n = robot.n
    how = solve_mode(code, n, parents=robot.parents)  # the drive solve's way, chosen here
    Qc = _program(q_cmd, n)
    K = Qc.shape[0]
    x0, v0 = (Qc[0] if q0 is None else _state(q0, "q0", n),
              np.zeros(n) if qd0 is None else _state(qd0, "qd0", n))
    FE, PE = validate.wrench_per_cycle(robot, f_ext, f_ext_point, K)
    Vc = _velocities(robot, Qc, v0, dt)

    def zeros(dtype: type = float) -> NDArray:
        return np.zeros((K, n), dtype=dtype)

    if cartesian is not None and (not isinstance(cartesian, CartesianPath)
                                  or cartesian.pose.shape[0] != K):
        raise StateError(f"cartesian: expected the CartesianPath of this program ({K} cycles), "
                         f"got {type(cartesian).__name__}")

    m, _, _, act = compiled.of(robot)
    check_moves(robot, x0)
    res = SimulationResult(
        robot=robot, dt=dt, mode=mode, fd=fd, t=np.arange(K) * dt, q_cmd=Qc, qd_cmd=Vc,
        qdd_des=zeros(), q=zeros(), qd=zeros(), qdd=zeros(), tau=zeros(), tau_motor=zeros(),
        tau_required=zeros(), limit=zeros(), margin=zeros(), saturated=zeros(np.bool_),
        position_clamped=zeros(np.bool_), velocity_clamped=zeros(np.bool_),
        reaction=np.zeros((K, n, 6)) if reactions else None, tracking_error=zeros(),
        coulomb=zeros(), stuck=zeros(np.bool_), program_effort=zeros(), program_limit=zeros(),
        tool_position_error=None if cartesian is None else np.zeros(K),
        tool_orientation_error=None if cartesian is None else np.zeros(K),
        tool_point=None if cartesian is None or cartesian.tool is None
        or cartesian.tool.link != n - 1 else tuple(map(float, cartesian.tool.T[:3, 3])),
        tool_targets=None if cartesian is None or not cartesian.targets
        else np.array([T for _, T in cartesian.targets]))
    clamp = zeros(np.int64)
    status_k = np.empty(K, dtype=np.int64)  # the program requirement's, per cycle
    res.q[0], res.qd[0] = x0, v0
    resolution = TRACKING_RESOLUTION * np.maximum(1.0, np.abs(Qc).max(axis=0))
    program = (Qc, Vc, FE, PE)
    run = (res.q, res.qd, res.qdd_des, res.qdd, res.tau, res.coulomb, res.tau_required,
           res.limit, res.saturated, res.stuck, clamp,
           np.empty((0, n, 6)) if res.reaction is None else res.reaction)
    ws = entry_scratch(n, ACHIEVABLE)  # the loop's and the requirement's, in turn
    done = kept = 0  # cycles done, and the bytes of the streamed table that hold them
    runaway = None  # the time the robot ran away [s]
    with contextlib.nullcontext() if stream is None else create(stream, overwrite,
                                                                 binary=True) as fh:
        try:
            while done < K:
                k1 = min(K, done + CHUNK)
                k, status = simulate_cycles((m, act), program, dt, how, engine,
                                            catch_up, reactions, done, k1, run, ws)
                wild = np.flatnonzero(np.abs(res.qd[done + 1:k + 1]).max(axis=1, initial=0.0)
                                      > RUNAWAY_SPEED)
                if wild.size or status in (NONFINITE, OVERFLOW):  # ran away at cycle k1: the
                    k1 = done + 1 + int(wild[0]) if wild.size else k  # cycles before stand
                    runaway = k1 * dt
                elif status != OK:
                    validate.check_cycle(robot, k, status, res.q[k], res.qd[k], dt)
                program_requirement((m, act), program, dt, True, done, k1,
                                    (res.program_effort, res.program_limit), status_k, ws)
                for k in np.flatnonzero(status_k[done:k1] != OK) + done:
                    validate.check_cycle(robot, int(k), int(status_k[k]), Qc[k], Vc[k], dt)
                rows = slice(done, k1)
                cycles.derive(res, rows, clamp, resolution)
                if cartesian is not None:
                    cycles.tool_errors(res, rows, cartesian)
                if fh is not None:  # on disk at once: after a hard kill the temporary file
                    fh.write(cycles.csv_rows(res, rows, header=done == 0))  # keeps the cycles done
                    fh.flush()
                done, kept = k1, (0 if fh is None else fh.tell())  # one step: no interrupt between
                if runaway is not None:
                    return dataclasses.replace(res._first(done), completed=True,
                                               runaway_time=runaway)
                if progress is not None:
                    progress(done, K)
        except KeyboardInterrupt:
            if fh is not None:  # it may have landed inside a chunk's write: keep whole cycles
                fh.truncate(kept)
                if not kept:  # no chunk whole: the header alone, as to_csv writes it
                    fh.seek(0)
                    fh.write(cycles.csv_rows(res, slice(0, 0), header=True))
            return res._first(done)  # even after the last chunk (progress raised): not lost
    return res


def _require_memory(K: int, n: int) -> None:
    """Refuse, before it allocates, a run of K cycles of n joints that would not fit the memory
    budget (:mod:`mrnea.resources`): the result's arrays, the program's copies and the
    temporaries of :meth:`SimulationResult.summary` and the report take about 250 bytes per
    cycle and joint, and 100 per cycle (measured with tracemalloc: tests/test_resources.py)."""
    require_memory(8.0 * K * (32 * n + 12), f"simulating {K:.3g} cycles of {n} joints",
                   "use a coarser dt or a shorter program, or split the program and simulate "
                   "the parts one after another", StateError)


def _check_progress(progress: object) -> None:
    """A StateError unless ``progress`` is None or a callable that takes (cycles_done, K): one
    that cannot would fail only after the first chunk's cycles."""
    validate.callable_or_none(progress, "progress")
    try:
        progress is None or inspect.signature(progress).bind(0, 0)  # type: ignore[arg-type]
    except ValueError:  # a callable without a signature (some builtins): taken as it is
        return
    except TypeError as exc:
        raise StateError(f"progress: must take two arguments, (cycles_done, K): {exc}") from None


def _program(q_cmd: ArrayLike, n: int) -> NDArray:
    """q_cmd as a C-contiguous (K, n) float64 array of finite numbers with K >= 2
    (:func:`mrnea.validate.array`); an array too large for the memory budget is refused before
    any copy of it is made (:func:`_require_memory`)."""
    def check(shape: tuple[int, ...]) -> None:
        if len(shape) != 2 or shape[0] < 2 or shape[1] != n:
            raise StateError(f"q_cmd: expected (K, {n}) with K >= 2 cycles, got {shape}")
        _require_memory(shape[0], n)

    if isinstance(q_cmd, np.ndarray):  # a view of anything (broadcast, memory-mapped)
        check(q_cmd.shape)
    Qc = validate.array(q_cmd, "q_cmd", n)
    check(Qc.shape)
    return Qc


def _state(x: ArrayLike, name: str, n: int) -> NDArray:
    """The initial position q0 [rad | m] or velocity qd0 [rad/s | m/s], (n,) finite."""
    if (a := validate.array(x, name, n)).ndim != 1:
        raise StateError(f"{name}: expected shape ({n},), got {a.shape}")
    return a


def _velocities(robot: Robot, Qc: NDArray, v0: NDArray, dt: float) -> NDArray:
    """The program's velocities qd_cmd (module docstring) [rad/s | m/s], qd_cmd[0] = v0 (the
    initial velocity qd0). A StateError for one beyond :data:`RUNAWAY_SPEED` (overflowing
    included): a unit mistake in q_cmd, dt or qd0, a speed no machine comes near; the run
    would only report a runaway (or an overflow) at its first cycle."""
    Vc = np.empty_like(Qc)
    Vc[0] = v0
    with np.errstate(over="ignore"):  # a step of 1e308: inf, refused below
        np.subtract(Qc[1:], Qc[:-1], out=Vc[1:])
        Vc[1:] /= dt
    if max(Vc.max(), -Vc.min()) <= RUNAWAY_SPEED:  # no temporary of the array's size
        return Vc
    k, i = (int(x) for x in np.argwhere(np.abs(Vc) > RUNAWAY_SPEED)[0])
    j = robot.joints[i]
    what = (f"qd0: {Vc[0, i]:.3g} {j.unit('qd')} for joint {j.name!r}" if k == 0 else
            f"q_cmd: the program moves joint {j.name!r} at {Vc[k, i]:.3g} {j.unit('qd')} at "
            f"cycle {k} (t = {k * dt:.6g} s, dt = {dt:g} s)")
    raise StateError(f"{what}, beyond {RUNAWAY_SPEED:g} {j.unit('qd')}, faster than any machine "
                     f"moves; check the units of q_cmd, dt and qd0")
