"""A Cartesian program made into joint positions, cycle by cycle, and what it keeps of its path.

Usage: ``prog = solve(program, robot)``: a :class:`mrnea.io.Program` of ``[[move]]`` tables
(``program.moves``) gets its ``t`` and ``q_cmd`` (what ``simulate``, ``check``, ``retime`` and
``sweep`` take) and ``program.cartesian``, a :class:`CartesianPath`. A joint program is returned
as it is.

The moves run in order from ``q0``, each from where the previous one ended, rest to rest
unless a ``blend`` joins linear moves:

* ``joint``: the joint profile of :mod:`mrnea.trajectory` (trapezoidal, quintic or S-curve)
  from the current q to the target; the tool pose of its cycles is the forward kinematics of q;
* ``linear`` / ``circular``: the tool poses of :func:`mrnea.cartesian.path.move_poses` from the
  current programmed pose (after a joint move: the forward kinematics of its target), solved by
  :func:`mrnea.ik.solve_path` warm-started at the current q: the continuous branch through q0;
* linear moves joined by ``blend`` > 0: one path through rounded corners, timed as one
  (:func:`mrnea.cartesian.blend.chain_poses`), solved likewise;
* ``poses``: the tool poses of a pose CSV at the cycles (:mod:`mrnea.io.posecsv`), solved
  likewise; as the first move, ``q0`` is the seed of its first pose's inverse kinematics (the
  program starts at that pose); after another move, its first pose must be where the tool is
  (``JOIN_POSITION``, ``JOIN_ORIENTATION``);
* ``dwell``: the last cycle held, rounded up to whole cycles.

Each move is of its own ``tool`` or the program's (:mod:`mrnea.tool`): on a tree the tool names
the tip the move drives (one arm of several), and the inverse kinematics moves the joints that
carry it less the move's ``hold`` (:func:`mrnea.ik.moving_joints`); every other joint keeps its
position. A move whose tool differs from the previous move's starts at the pose its tool has
there (the forward kinematics of q).

A ``[wrench]`` (``program.wrench``) becomes ``f_ext`` at the cycle times (t = 0 at q0) and acts
at the tool point (the tool frame's origin, on the tool's link) unless its ``point`` or ``link``
says otherwise; with tools on several links, a ``[wrench]`` names its link.

The verdict on the Cartesian path (reach, singularities, joint limits, configuration changes)
is :mod:`mrnea.cartesian.verdict`'s, in ``CartesianPath.findings``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.cartesian.blend import chain_poses
from mrnea.cartesian.path import Room, move_poses
from mrnea.cartesian.verdict import Finding, findings
from mrnea.dynamics import forward_kinematics
from mrnea.errors import ProgramFileError, StateError, quote
from mrnea.ik import moving_joints, solve_path
from mrnea.io.jointnames import unknown_joint
from mrnea.io.moves import Move, Moves
from mrnea.io.program import Program
from mrnea.io.wrench import LinkWrenches, wrench_at, wrenches_on
from mrnea.model import Robot
from mrnea.tool import ToolFrame, tool_frame
from mrnea.trajectory import cycles, quintic, scurve, trapezoidal

__all__ = ["CartesianPath", "solve"]

JOIN_POSITION = 1e-6  # [m]: how far a pose CSV's first pose may be from where the tool is
JOIN_ORIENTATION = 1e-6  # [rad]: the same for its orientation
_JOINT_PROFILES = {"trapezoidal": trapezoidal, "quintic": quintic, "scurve": scurve}


@dataclass(frozen=True, eq=False)
class CartesianPath:
    """The Cartesian side of a solved program, one row per cycle (as ``q_cmd``).

    Attributes
    ----------
    tools : per move (``tools[move - 1]``), its tool frame (:class:`mrnea.tool.ToolFrame`: the
        link's index and the (4, 4) pose in that link's frame).
    joints : per move, the indices (m,) of the joints its inverse kinematics moves.
    pose : (K, 4, 4) the programmed pose of every cycle's tool (its move's), base frame [m] (on
        a joint move: the forward kinematics of the commanded q).
    move : (K,) the move (1-based) each cycle belongs to (its dwell included); cycle 0, the
        start, belongs to move 1.
    cartesian : (K,) True on the cycles of linear and circular moves (solved by IK).
    position_error, orientation_error : (K,) what the inverse kinematics left [m], [rad]
        (zero on joint moves).
    targets : ((move index, (4, 4) target pose), ...) of the linear and circular moves.
    findings : the reasons the robot cannot follow the path (:mod:`mrnea.cartesian.verdict`);
        empty: it can, as far as kinematics go.
    """

    tools: tuple[ToolFrame, ...]
    joints: tuple[NDArray[np.int64], ...]
    pose: NDArray[np.float64]
    move: NDArray[np.int64]
    cartesian: NDArray[np.bool_]
    position_error: NDArray[np.float64]
    orientation_error: NDArray[np.float64]
    targets: tuple[tuple[int, NDArray[np.float64]], ...]
    findings: tuple[Finding, ...]
    moves: tuple[Move, ...]

    @property
    def tool(self) -> ToolFrame | None:
        """The tool frame of every move when they share one (the same link and pose), else
        None (moves of several tools: on a tree, several arms)."""
        first = self.tools[0]
        same = all(f.link == first.link and np.array_equal(f.T, first.T) for f in self.tools)
        return first if same else None

    def tool_poses(self, robot: Robot, q: NDArray, rows: slice = slice(None)
                   ) -> NDArray[np.float64]:
        """(B, 4, 4) the pose of the tool of the path's cycles ``rows`` (their moves',
        :attr:`move`) at the joint positions q (B, n) of those cycles, base frame [m]."""
        T = forward_kinematics(robot, q)
        of = self.move[rows] - 1
        link = np.array([f.link for f in self.tools])[of]
        return T[np.arange(q.shape[0]), link + 1] @ np.stack([f.T for f in self.tools])[of]

    @property
    def achievable(self) -> bool:
        """Whether the path has no finding."""
        return not self.findings

    def verdict(self) -> str | None:
        """None when the robot can follow the path; else ``NOT ACHIEVABLE: <the first finding>``
        (and how many more)."""
        if not self.findings:
            return None
        more = len(self.findings) - 1
        tail = f" ({more} more finding{'s' if more > 1 else ''})" if more else ""
        return f"NOT ACHIEVABLE: {self.findings[0].message}{tail}"


def _hold(q: NDArray, count: int) -> NDArray:
    return np.repeat(q[None], count, axis=0)


def _chains(moves: tuple[Move, ...]) -> list[tuple[Move, ...]]:
    """The moves in runs that are timed as one: linear moves joined by their blends, every
    other move alone."""
    out, run = [], []
    for mv in moves:
        run.append(mv)
        if mv.blend == 0:
            out.append(tuple(run))
            run = []
    return out  # the last move has no blend (io.moves)


def _poses_of(move: Move, T: NDArray, where: str) -> NDArray:
    """The poses of a pose CSV move (its first row included), which must start where the tool
    is (within ``JOIN_POSITION`` [m] and ``JOIN_ORIENTATION`` [rad])."""
    from scipy.spatial.transform import Rotation  # here, not at the top (io.posecsv)

    P = move.poses
    gap = float(np.linalg.norm(P[0, :3, 3] - T[:3, 3]))
    turn = float(np.linalg.norm(Rotation.from_matrix(T[:3, :3].T @ P[0, :3, :3]).as_rotvec()))
    if gap > JOIN_POSITION or turn > JOIN_ORIENTATION:
        raise ProgramFileError(
            f"{where}: [[move]] {move.index} (poses): {move.csv}: line {move.csv_line}: the "
            f"first pose is {gap * 1e3:.4g} mm and {turn * 1e3:.4g} mrad from where the tool is "
            f"when the move starts (the previous move's end): a pose CSV after another move "
            f"continues the path from there (within {JOIN_POSITION:g} m and "
            f"{JOIN_ORIENTATION:g} rad)")
    return P


def solve(program: Program, robot: Robot, checkpoint: Callable[[], None] | None = None
          ) -> Program:
    """``program`` with ``t``, ``q_cmd`` and ``cartesian`` made by inverse kinematics on ``robot``
    (module docstring); a joint program in the robot's joint order
    (:meth:`mrnea.io.Program.on`: a program naming its joints), else unchanged.

    ``checkpoint`` is called between the blocks of a long solve (every
    :data:`mrnea.ik.BLOCK` cycles: the inverse kinematics, the verdict's singular values) and
    between moves; raising from it (KeyboardInterrupt) stops the solve (the command line
    passes its stop request, :func:`mrnea.cli.base.checkpoint`: Ctrl-C stops ``mrnea check`` of
    a program of a million cycles within a fraction of a second). None: no stop.

    Raises
    ------
    ProgramFileError
        A move that cannot be timed (a pure rotation without angular limits, a circle through
        three points on one line) or a tool the robot does not have: the message names the
        file, the move and the key.
    """
    program = program.on(robot)  # a program naming its joints: its rows in the robot's order
    spec = program.moves
    if spec is None:
        return program
    stop = checkpoint or _never
    where = program.source or program.name
    frames, joints = _tools(robot, spec, where)
    dt, q = program.dt, _positions(spec.q0, np.zeros(robot.n), robot, f"{where}: [program] q0")
    frame = frames[0]
    T = forward_kinematics(robot, q, tool=frame)[-1]
    start_err, first = np.zeros((1, 2)), spec.moves[0]
    if first.type == "poses":  # q0 is the seed of the first pose's inverse kinematics
        res = solve_path(robot, first.poses[:1], q, frame, first.hold)
        q, T = res.q[0], first.poses[0]
        start_err = np.column_stack([res.position_error, res.orientation_error])
    rows, poses, owner, is_cart, errs = [q[None]], [T[None]], [np.ones(1, np.int64)], \
        [np.full(1, first.type == "poses")], [start_err]
    targets, done = [], 1  # done: the cycles made so far (the memory check's, Room)
    for chain in _chains(spec.moves):
        stop()
        mv = chain[-1]
        if frames[mv.index - 1] is not frame:  # another tool: from where it is now
            frame = frames[mv.index - 1]
            T = forward_kinematics(robot, q, tool=frame)[-1]
        try:
            if mv.type == "joint":
                target, limits = _joint_move(mv, q, robot, where)
                _, qs = _JOINT_PROFILES[mv.profile](np.array([q, target]), dt, *limits)
                qs = qs[1:]
                Room(done, robot.n).check(len(qs))
                Ts = (forward_kinematics(robot, qs, tool=frame)[:, -1] if len(qs)
                      else np.empty((0, 4, 4)))  # a move to where it is: none
                e = np.zeros((len(qs), 2))
                own, cart = np.full(len(qs), mv.index, np.int64), False
            else:
                if len(chain) > 1:
                    Ts, own, ends = chain_poses(chain, T, dt, Room(done, robot.n))
                    targets += [(m.index, end) for m, end in zip(chain, ends, strict=True)]
                else:
                    Ts = _poses_of(mv, T, where) if mv.type == "poses" else \
                        move_poses(mv, T, dt, Room(done, robot.n), stop)[1]
                    own = np.full(len(Ts), mv.index, np.int64)
                    targets.append((mv.index, Ts[-1]))
                Ts, own = Ts[1:], own[1:]
                res = solve_path(robot, Ts, q, frame, mv.hold, stop) if len(Ts) else None
                qs = res.q if res else np.empty((0, robot.n))
                e = (np.column_stack([res.position_error, res.orientation_error]) if res
                     else np.zeros((0, 2)))
                cart = True
        except StateError as exc:
            raise ProgramFileError(f"{where}: [[move]] {chain[0].index} ({chain[0].type}): "
                                   f"{exc}") from None
        if len(qs):
            q, T = qs[-1], Ts[-1]
        hold = _dwell(mv, dt, done + len(qs), robot.n, where)
        done += len(qs) + hold
        rows += [qs, _hold(q, hold)]
        poses += [Ts, _hold(T, hold)]
        owner += [own, np.full(hold, mv.index, np.int64)]
        is_cart += [np.full(len(qs), cart), np.zeros(hold, bool)]
        errs += [e, np.zeros((hold, 2))]
    stop()
    q_cmd, pose = np.concatenate(rows), np.concatenate(poses)
    move, cart, err = np.concatenate(owner), np.concatenate(is_cart), np.concatenate(errs)
    t = np.arange(q_cmd.shape[0]) * dt
    if q_cmd.shape[0] < 2:
        raise ProgramFileError(f"{where}: the moves take a single cycle (every target is where "
                               f"the robot is, or a pose CSV shorter than a cycle of "
                               f"{dt:g} s, and no dwell); give a move that moves")
    found = findings(robot, t, q_cmd, pose, move, cart, err, frames, joints, spec.moves, stop)
    path = CartesianPath(tools=frames, joints=joints, pose=pose, move=move, cartesian=cart,
                         position_error=err[:, 0], orientation_error=err[:, 1],
                         targets=tuple(targets), findings=tuple(found), moves=spec.moves)
    for a in (t, q_cmd, pose, move, cart, path.position_error, path.orientation_error, *joints):
        a.setflags(write=False)
    return dataclasses.replace(program, t=t, q_cmd=q_cmd, cartesian=path,
                               **_wrench(program, robot, t, path.tool, where))


def _never() -> None:
    """No stop request (:func:`solve` without a ``checkpoint``)."""


def _dwell(mv: Move, dt: float, done: int, n: int, where: str) -> int:
    """The cycles of a move's ``dwell`` [s] (rounded up), the program having ``done`` cycles
    before it: ProgramFileError naming the move and the key where they are more than a
    program may have or would not fit the memory budget (:class:`Room`), as a move's own."""
    try:
        hold = int(cycles(mv.dwell, dt))
        Room(done, n).check(hold)
    except StateError as exc:
        raise ProgramFileError(f"{where}: [[move]] {mv.index} ({mv.type}): 'dwell' "
                               f"{mv.dwell:g} s: {exc}") from None
    return hold


def _positions(given: NDArray | Mapping[str, float], q: NDArray, robot: Robot, where: str
               ) -> NDArray:
    """Joint positions (n,) [rad | m]: an array of the robot's n, or a table by joint name
    over ``q`` (the joints it does not name keep their q)."""
    if isinstance(given, Mapping):
        q = q.copy()
        for name, v in given.items():
            if name not in robot.joint_names:
                raise ProgramFileError(f"{where}: {unknown_joint(name, robot)}")
            q[robot.joint_names.index(name)] = v
        return q
    if given.size != robot.n:
        raise ProgramFileError(f"{where}: {given.size} joint positions, but robot "
                               f"{quote(robot.name)} has {robot.n} joints (or name them: "
                               f"{{{robot.joint_names[0]} = ...}})")
    return np.array(given, dtype=float)


def _joint_move(mv: Move, q: NDArray, robot: Robot, where: str
                ) -> tuple[NDArray, list[NDArray]]:
    """A joint move's target (n,) from q, and its limits per joint (n,) each: a number for
    every joint, an array of n, or a table by name that names every joint the move moves
    (the others unlimited)."""
    at = f"{where}: [[move]] {mv.index} (joint)"
    target = _positions(mv.target, q, robot, f"{at} target")
    moving = {name for name, a, b in zip(robot.joint_names, q, target, strict=True) if a != b}
    limits = []
    for key, lim in zip(("velocity_limit", "acceleration_limit", "jerk_limit"), mv.limits,
                        strict=False):  # no jerk limit unless an S-curve
        if isinstance(lim, Mapping):
            missing = sorted(moving - set(lim), key=robot.joint_names.index)
            if missing:
                raise ProgramFileError(f"{at}: {key} does not name joint {quote(missing[0])}, "
                                       f"which the move moves; give its limit (or one number "
                                       f"for every joint)")
            lim = _positions(lim, np.full(robot.n, np.inf), robot, f"{at} {key}")
        elif lim.ndim == 0:
            lim = np.full(robot.n, float(lim))
        elif lim.size != robot.n:
            raise ProgramFileError(f"{at}: {key}: {lim.size} limits, but robot "
                                   f"{quote(robot.name)} has {robot.n} joints")
        limits.append(lim)
    return target, limits


def _tools(robot: Robot, spec: Moves, where: str
           ) -> tuple[tuple[ToolFrame, ...], tuple[NDArray[np.int64], ...]]:
    """Per move, its tool frame (its own ``tool`` or the program's; moves of one tool share
    one :class:`ToolFrame` object) and the joints its inverse kinematics moves."""
    resolved: dict[str, ToolFrame] = {}
    frames, joints = [], []
    for mv in spec.moves:
        own = mv.tool is not None
        key = repr(mv.tool if own else spec.tool)
        try:
            if key not in resolved:
                resolved[key] = tool_frame(robot, mv.tool if own else spec.tool)
            frame = resolved[key]
        except StateError as exc:
            table = f"[[move]] {mv.index} ({mv.type})" if own else "[program]"
            raise ProgramFileError(f"{where}: {table}: {exc}") from None
        try:
            idx = moving_joints(robot, frame.link, mv.hold)
        except StateError as exc:
            raise ProgramFileError(f"{where}: [[move]] {mv.index} ({mv.type}): {exc}") from None
        frames.append(frame)
        joints.append(idx)
    return tuple(frames), tuple(joints)


def _wrench(program: Program, robot: Robot, t: NDArray, tool: ToolFrame | None, where: str
            ) -> dict[str, object]:
    """``f_ext`` and ``f_ext_point`` of a solved program's ``[wrench]`` tables: a table without
    ``link`` acts on the tool's link at the tool point unless its ``point`` says otherwise
    (moves of several tools: a ``[wrench]`` names its link)."""
    if program.wrench is None:
        return {"f_ext": None, "f_ext_point": program.f_ext_point}
    wrenches = program.wrench
    if isinstance(wrenches, LinkWrenches) and None not in wrenches:
        return dict(zip(("f_ext", "f_ext_point"), wrenches_on(wrenches, robot, t, where),
                        strict=True))
    if tool is None:
        raise ProgramFileError(f"{where}: [wrench]: the moves are of several tools, so a wrench "
                               f"without 'link' has no tool point to act at: give its 'link' "
                               f"(and 'point')")
    tcp = (tool.link, tool.T[:3, 3].copy())
    if isinstance(wrenches, LinkWrenches):
        return dict(zip(("f_ext", "f_ext_point"), wrenches_on(wrenches, robot, t, where, tcp),
                        strict=True))
    if tool.link != robot.n - 1:  # one [wrench] at a tool on another link than the last
        table = LinkWrenches({None: (*wrenches, program.f_ext_point)})
        return dict(zip(("f_ext", "f_ext_point"), wrenches_on(table, robot, t, where, tcp),
                        strict=True))
    f_ext = wrench_at(*wrenches, t)  # one [wrench] on the program's clock, the last link's
    point = tcp[1] if program.f_ext_point is None else program.f_ext_point
    for a in (f_ext, point):
        a.setflags(write=False)
    return {"f_ext": f_ext, "f_ext_point": point}
