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

A ``[wrench]`` (``program.wrench``) becomes ``f_ext`` at the cycle times (t = 0 at q0) and acts
at the tool point (the tool frame's origin) unless its ``point`` says otherwise.

The verdict on the Cartesian path (reach, singularities, joint limits, configuration changes)
is :mod:`mrnea.cartesian.verdict`'s, in ``CartesianPath.findings``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.cartesian.blend import chain_poses
from mrnea.cartesian.path import move_poses
from mrnea.cartesian.verdict import Finding, findings
from mrnea.dynamics import forward_kinematics
from mrnea.errors import ProgramFileError, StateError
from mrnea.ik import solve_path
from mrnea.io.moves import Move
from mrnea.io.program import Program
from mrnea.io.wrench import LinkWrenches, wrench_at, wrenches_on
from mrnea.model import Robot
from mrnea.tool import tool_transform
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
    tool : (4, 4) the tool frame in the last link's frame.
    pose : (K, 4, 4) the programmed tool pose of every cycle, base frame [m] (on a joint move:
        the forward kinematics of the commanded q).
    move : (K,) the move (1-based) each cycle belongs to (its dwell included); cycle 0, the
        start, belongs to move 1.
    cartesian : (K,) True on the cycles of linear and circular moves (solved by IK).
    position_error, orientation_error : (K,) what the inverse kinematics left [m], [rad]
        (zero on joint moves).
    targets : ((move index, (4, 4) target pose), ...) of the linear and circular moves.
    findings : the reasons the robot cannot follow the path (:mod:`mrnea.cartesian.verdict`);
        empty: it can, as far as kinematics go.
    """

    tool: NDArray[np.float64]
    pose: NDArray[np.float64]
    move: NDArray[np.int64]
    cartesian: NDArray[np.bool_]
    position_error: NDArray[np.float64]
    orientation_error: NDArray[np.float64]
    targets: tuple[tuple[int, NDArray[np.float64]], ...]
    findings: tuple[Finding, ...]
    moves: tuple[Move, ...]

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


def solve(program: Program, robot: Robot) -> Program:
    """``program`` with ``t``, ``q_cmd`` and ``cartesian`` made by inverse kinematics on ``robot``
    (module docstring); a joint program in the robot's joint order
    (:meth:`mrnea.io.Program.on`: a program naming its joints), else unchanged.

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
    where = program.source or program.name
    try:
        Tt = tool_transform(robot, spec.tool)
    except StateError as exc:
        raise ProgramFileError(f"{where}: [program]: {exc}") from None
    dt, q = program.dt, np.array(spec.q0, dtype=float)
    T = forward_kinematics(robot, q, tool=Tt)[-1]
    start_err, first = np.zeros((1, 2)), spec.moves[0]
    if first.type == "poses":  # q0 is the seed of the first pose's inverse kinematics
        res = solve_path(robot, first.poses[:1], q, Tt)
        q, T = res.q[0], first.poses[0]
        start_err = np.column_stack([res.position_error, res.orientation_error])
    rows, poses, owner, is_cart, errs = [q[None]], [T[None]], [np.ones(1, np.int64)], \
        [np.full(1, first.type == "poses")], [start_err]
    targets = []
    for chain in _chains(spec.moves):
        mv = chain[-1]
        try:
            if mv.type == "joint":
                prof = _JOINT_PROFILES[mv.profile]
                _, qs = prof(np.array([q, mv.target]), dt, *mv.limits)
                qs = qs[1:]
                Ts = forward_kinematics(robot, qs, tool=Tt)[:, -1] if len(qs) else qs[:, :0]
                e = np.zeros((len(qs), 2))
                own, cart = np.full(len(qs), mv.index, np.int64), False
            else:
                if len(chain) > 1:
                    Ts, own, ends = chain_poses(chain, T, dt)
                    targets += [(m.index, end) for m, end in zip(chain, ends, strict=True)]
                else:
                    Ts = _poses_of(mv, T, where) if mv.type == "poses" else \
                        move_poses(mv, T, dt)[1]
                    own = np.full(len(Ts), mv.index, np.int64)
                    targets.append((mv.index, Ts[-1]))
                Ts, own = Ts[1:], own[1:]
                res = solve_path(robot, Ts, q, Tt) if len(Ts) else None
                qs = res.q if res else np.empty((0, robot.n))
                e = (np.column_stack([res.position_error, res.orientation_error]) if res
                     else np.zeros((0, 2)))
                cart = True
        except StateError as exc:
            raise ProgramFileError(f"{where}: [[move]] {chain[0].index} ({chain[0].type}): "
                                   f"{exc}") from None
        if len(qs):
            q, T = qs[-1], Ts[-1]
        hold = int(cycles(mv.dwell, dt))
        rows += [qs, _hold(q, hold)]
        poses += [Ts, _hold(T, hold)]
        owner += [own, np.full(hold, mv.index, np.int64)]
        is_cart += [np.full(len(qs), cart), np.zeros(hold, bool)]
        errs += [e, np.zeros((hold, 2))]
    q_cmd, pose = np.concatenate(rows), np.concatenate(poses)
    move, cart, err = np.concatenate(owner), np.concatenate(is_cart), np.concatenate(errs)
    t = np.arange(q_cmd.shape[0]) * dt
    if q_cmd.shape[0] < 2:
        raise ProgramFileError(f"{where}: the moves take a single cycle (every target is where "
                               f"the robot is and no dwell); give a move that moves")
    found = findings(robot, t, q_cmd, pose, move, cart, err, Tt, spec.moves)
    path = CartesianPath(tool=Tt, pose=pose, move=move, cartesian=cart,
                         position_error=err[:, 0], orientation_error=err[:, 1],
                         targets=tuple(targets), findings=tuple(found), moves=spec.moves)
    for a in (t, q_cmd, pose, move, cart, path.position_error, path.orientation_error):
        a.setflags(write=False)
    f_ext, point = None, program.f_ext_point
    if isinstance(program.wrench, LinkWrenches):  # on named links; at the TCP by default
        f_ext, point = wrenches_on(program.wrench, robot, t, where, Tt[:3, 3].copy())
    elif program.wrench is not None:  # [wrench] on the program's clock; at the TCP by default
        f_ext = wrench_at(*program.wrench, t)
        point = Tt[:3, 3].copy() if point is None else point
        for a in (f_ext, point):
            a.setflags(write=False)
    return dataclasses.replace(program, t=t, q_cmd=q_cmd, cartesian=path, f_ext=f_ext,
                               f_ext_point=point)
