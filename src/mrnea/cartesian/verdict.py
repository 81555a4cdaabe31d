"""Why a robot cannot follow a Cartesian path: the findings of a solved program.

Usage: ``findings(robot, t, q, pose, move, cartesian, err, tools, joints, moves)`` (what
:func:`mrnea.cartesian.solve` has made) returns the :class:`Finding` s, the first of each kind
in each move, by move and within a move in the order below (out of reach is the cause of the
singular stretch before it); none:
the robot can follow the path as far as its kinematics go (the dynamics are judged after, on the
joint motion, as for any program). Each names the move, the instant and a joint:

* ``reach``: a pose of a linear or circular move that the inverse kinematics does not reach
  within ``REACH_POSITION`` [m] and ``REACH_ORIENTATION`` [rad] (out of reach); the joint named is
  the one that moves most along the tool Jacobian's smallest singular direction there (the
  direction the arm has lost, e.g. the elbow of an arm stretched to its full reach);
* ``singularity``: on a linear or circular move, the smallest singular value of the tool
  Jacobian (6 x m, rows [m/rad; rad/rad], the columns of the m joints the move's inverse
  kinematics moves, :func:`mrnea.ik.moving_joints`) below ``SIGMA_SINGULAR``, or a joint's speed
  ``(q[k] - q[k-1]) / dt`` over its ``velocity_limit`` while the smallest singular value within
  ``NEAR_WINDOW`` [s] is below ``SIGMA_NEAR`` (the tool speed is modest, a joint's speed explodes
  near the singularity); the joint named is the one whose speed is over its limit, else the
  fastest;
* ``joint_limit``: a commanded position outside a joint's ``lower``/``upper`` limits;
* ``configuration``: (6 moving joints) the sign of det J changes between two cycles of a Cartesian
  move: the arm has passed onto another branch of its inverse kinematics (an elbow or wrist
  flip). The joint named is the one whose motion changes det J most over those cycles
  (``|d det J / d q_i| |q_i[k] - q_i[k-1]|``): the elbow in an elbow flip, the middle wrist
  joint in a wrist flip. Arms with other joint counts have no such sign; their branch changes
  pass through the singular values above.

The thresholds are absolute, for arms of about a metre (the UR5's smallest singular value is
0.1-0.5 in most of its workspace, Pinocchio's and our Jacobian alike).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.dynamics import jacobian
from mrnea.ik import BLOCK
from mrnea.io.moves import Move
from mrnea.model import Robot
from mrnea.tool import ToolFrame

__all__ = ["NEAR_WINDOW", "REACH_ORIENTATION", "REACH_POSITION", "SIGMA_NEAR", "SIGMA_SINGULAR",
           "Finding", "findings"]

REACH_POSITION = 1e-9  # [m]: a pose left farther than this by the inverse kinematics: not reached
REACH_ORIENTATION = 1e-9  # [rad]
SIGMA_SINGULAR = 1e-3  # smallest singular value of the tool Jacobian: at a singularity below it
SIGMA_NEAR = 5e-2  # ... near one below it (a joint over its speed limit there: a singularity)
NEAR_WINDOW = 0.25  # [s] either side of a cycle: what "near" means
_ORDER = {"reach": 0, "joint_limit": 1, "singularity": 2, "configuration": 3}


@dataclass(frozen=True)
class Finding:
    """One reason the path cannot be followed: its ``kind`` (module docstring), the move
    (1-based) and its type, the instant t [s], the joint's name and one line saying it all."""

    kind: str
    move: int
    move_type: str
    t: float
    joint: str
    message: str


def _where(moves: tuple[Move, ...], move: int, t: float) -> str:
    return f"move {move} ({moves[move - 1].type}) at t = {t:.3f} s"


def _tool_jacobian(robot: Robot, q: NDArray, tool: ToolFrame, idx: NDArray) -> NDArray:
    """(B, 6, m): the Jacobian of the tool point at q (B, n), the columns of the joints idx."""
    point = np.broadcast_to(tool.T[:3, 3], (q.shape[0], 3))
    link = None if tool.link == robot.n - 1 else robot.link_names[tool.link]
    return jacobian(robot, q, point, link=link)[:, :, idx]


def _singular(robot: Robot, q: NDArray, move: NDArray, tools: tuple[ToolFrame, ...],
              joints: tuple[NDArray, ...], checkpoint: Callable[[], None]
              ) -> tuple[NDArray, NDArray, NDArray]:
    """Per cycle, with its move's tool and moving joints: the smallest singular value of the
    tool Jacobian, the joint (index) moving most along it, and det J (NaN unless 6 joints).
    In blocks of :data:`mrnea.ik.BLOCK` cycles, ``checkpoint`` called before each (an SVD of a
    million Jacobians takes seconds; per cycle the same numbers as in one call)."""
    K = q.shape[0]
    sigma, joint, det = np.empty(K), np.empty(K, np.int64), np.full(K, np.nan)
    for m in np.unique(move):
        every, idx = np.flatnonzero(move == m), joints[m - 1]
        for a in range(0, every.size, BLOCK):
            checkpoint()
            rows = every[a:a + BLOCK]
            J = _tool_jacobian(robot, q[rows], tools[m - 1], idx)
            _, S, Vt = np.linalg.svd(J)
            sigma[rows] = S[:, -1]
            # the joint motion along the smallest singular value
            joint[rows] = idx[np.argmax(np.abs(Vt[:, min(5, idx.size - 1)]), axis=1)]
            if idx.size == 6:
                det[rows] = np.linalg.det(J)
    return sigma, joint, det


def findings(robot: Robot, t: NDArray, q: NDArray, pose: NDArray, move: NDArray,
             cartesian: NDArray, err: NDArray, tools: tuple[ToolFrame, ...],
             joints: tuple[NDArray, ...], moves: tuple[Move, ...],
             checkpoint: Callable[[], None] = lambda: None) -> list[Finding]:
    """The findings of a solved Cartesian path (module docstring), in its order: ``tools``
    and ``joints`` per move, its tool frame and the joints its inverse kinematics moves;
    ``checkpoint`` called between blocks of the long computations (a stop request)."""
    out: list[Finding] = []
    names = robot.joint_names
    dt = float(t[1] - t[0])
    sigma, lost, det = _singular(robot, q, move, tools, joints, checkpoint)
    seen: set[tuple[str, int]] = set()

    def add(kind: str, k: int, joint: int, what: str) -> None:
        m = int(move[k])
        if (kind, m) in seen:  # the first of each kind per move
            return
        seen.add((kind, m))
        out.append(Finding(kind, m, moves[m - 1].type, float(t[k]), names[joint],
                           f"{_where(moves, m, float(t[k]))}: {what}"))

    # reach: the first pose not reached in each move, and the farthest the tool stays off
    unreached = cartesian & ((err[:, 0] > REACH_POSITION) | (err[:, 1] > REACH_ORIENTATION))
    for m in np.unique(move[unreached]):
        rows = np.flatnonzero(unreached & (move == m))
        k = int(rows[0])
        j = int(lost[k])
        far = err[rows, 0].max() * 1e3
        turn = err[rows, 1].max() * 1e3
        add("reach", k, j, f"pose out of reach: the tool stays up to {far:.4g} mm and "
                           f"{turn:.4g} mrad off the path ("
                           f"{rows.size} cycles from here; joint {names[j]}, smallest singular "
                           f"value {sigma[k]:.3g})")
    # joint limits
    lo, hi = robot.lower, robot.upper
    over = (q < lo) | (q > hi)
    for k in _first_per_move(np.flatnonzero(over.any(axis=1)), move):  # not every cycle
        j = int(np.argmax(over[k]))
        side, lim = ("upper", hi[j]) if q[k, j] > hi[j] else ("lower", lo[j])
        unit = robot.joints[j].unit("q")
        at, limit = f"{q[k, j]:.4g}", f"{lim:.4g}"
        if at == limit:  # just past it: the digits that tell them apart
            at, limit = repr(float(q[k, j])), repr(float(lim))
        add("joint_limit", int(k), int(j), f"joint limit crossed: joint {names[j]} at {at} "
                                           f"{unit}, beyond its {side} limit {limit} {unit}")
    # singularities: a small singular value, or a joint too fast near one
    qd = np.zeros_like(q)
    qd[1:] = np.diff(q, axis=0) / dt
    vmax = robot.velocity_limit
    from scipy.ndimage import minimum_filter1d  # here: it would cost every command ~0.1 s

    near = minimum_filter1d(sigma, 2 * max(1, round(NEAR_WINDOW / dt)) + 1, mode="nearest")
    ratio = np.abs(qd) / vmax
    fast = (ratio > 1.0) & cartesian[:, None] & (near < SIGMA_NEAR)[:, None]
    for m in np.unique(move[cartesian]):
        rows = np.flatnonzero(move == m)
        if fast[rows].any():  # the fastest joint of the move, where it is fastest
            k, j = np.unravel_index(np.argmax(np.where(fast[rows], ratio[rows], 0.0)),
                                    (rows.size, robot.n))
            k = int(rows[k])
            unit = robot.joints[j].unit("qd")
            add("singularity", k, int(j), f"singularity on the path: joint {names[j]} at "
                                          f"{abs(qd[k, j]):.4g} {unit}, over its limit "
                                          f"{vmax[j]:.4g} {unit} (smallest singular value of "
                                          f"the tool Jacobian {near[k]:.3g} < {SIGMA_NEAR:g} "
                                          f"within {NEAR_WINDOW:g} s)")
        low = rows[cartesian[rows] & (sigma[rows] < SIGMA_SINGULAR)]
        if low.size:
            k = int(low[np.argmin(sigma[low])])
            j = int(lost[k])
            add("singularity", k, j, f"singularity on the path: smallest singular value of the "
                                     f"tool Jacobian {sigma[k]:.3g} < {SIGMA_SINGULAR:g} (joint "
                                     f"{names[j]} moves along the lost direction)")
    # configuration changes (6 moving joints): det J changes sign within a Cartesian move
    keys: dict[tuple, int] = {}  # moves of one tool frame (one object) and one joint set
    group = np.array([keys.setdefault((id(f), tuple(j.tolist())), len(keys))
                      for f, j in zip(tools, joints, strict=True)])[move - 1]
    same = group[1:] == group[:-1]
    flip = np.flatnonzero(cartesian[1:] & cartesian[:-1] & same & np.isfinite(det[1:])
                          & np.isfinite(det[:-1]) & (np.sign(det[1:]) != np.sign(det[:-1]))) + 1
    for k in _first_per_move(flip, move):  # not every flip (each costs 12 Jacobians)
        m = int(move[k])
        j = _flip_joint(robot, q[k - 1], q[k], tools[m - 1], joints[m - 1])
        add("configuration", int(k), j, f"configuration change: det J changes sign (the arm "
                                        f"passes onto another branch), joint {names[j]} from "
                                        f"{q[k - 1, j]:.4g} to {q[k, j]:.4g}")
    out.sort(key=lambda f: (f.move, _ORDER[f.kind], f.t))
    return out


def _first_per_move(rows: NDArray, move: NDArray) -> NDArray:
    """The first of the cycles ``rows`` (ascending) in each move (only the first finding of a
    kind in a move is kept: the others need not be worded, a million on a long path)."""
    return rows[np.unique(move[rows], return_index=True)[1]]


def _flip_joint(robot: Robot, qa: NDArray, qb: NDArray, tool: ToolFrame, idx: NDArray,
                h: float = 1e-6) -> int:
    """The joint (of the six idx) whose motion from qa to qb changes det J most (central
    differences at the midpoint)."""
    mid = 0.5 * (qa + qb)
    step = np.zeros((6, robot.n))
    step[np.arange(6), idx] = h
    det = np.linalg.det(_tool_jacobian(robot, np.concatenate([mid + step, mid - step]), tool,
                                       idx))
    grad = (det[:6] - det[6:]) / (2 * h)
    return int(idx[np.argmax(np.abs(grad * (qb - qa)[idx]))])
