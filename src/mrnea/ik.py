"""Inverse kinematics of a tool frame, the public API: ``mrnea.inverse_kinematics``.

Usage: ``q = inverse_kinematics(robot, T, q0, tool=None)`` for one pose T (4, 4), or a path
(K, 4, 4) followed continuously, each cycle warm-started at the previous cycle's solution (the
first at ``q0``): the branch through ``q0``, never a jump to another configuration.

The joints that move are those that carry the tool's link (:func:`mrnea.tool.carrying_joints`:
on a serial chain all of them; on a tree the path from the root to the tool's link, a shared
waist included) less the joints named in ``hold``; every other joint keeps its ``q0``. On a tree
a shared joint that moves carries the other branches with it (their joints held, their tips not):
hold it to keep them still (docs/trees.md).
:func:`solve_path` returns what is left of the error besides q, for callers that judge a path
(:mod:`mrnea.cartesian`) rather than fail on it.

The solver is damped least squares (Levenberg-Marquardt) on the tool point's geometric Jacobian
(:func:`mrnea.jacobian`), compiled with Numba (``mrnea/kernels/ik.py``, where the iteration is
written out); it stops at ``TOL_POSITION`` [m] and ``TOL_ORIENTATION`` [rad] (the position error
of the tool frame's origin and the angle of the rotation left). Redundant arms (more than 6
moving joints) take the minimum-norm joint step of each iteration: the solution moves least from
the previous cycle. Arms with fewer than 6 reach a pose only where it lies on their reachable
set; elsewhere the least-squares residual is what :func:`solve_path` reports. Joint limits are
not enforced (a limit crossed is a verdict of :mod:`mrnea.cartesian`, not something to hide).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea import compiled, validate
from mrnea.errors import StateError, quote
from mrnea.frozen import MAGNITUDES
from mrnea.kernels.ik import ik_path
from mrnea.model import Robot
from mrnea.tool import Tool, carrying_joints, tool_frame

__all__ = ["BLOCK", "MAX_ITERATIONS", "TOL_ORIENTATION", "TOL_POSITION", "IKPath",
           "inverse_kinematics", "moving_joints", "solve_path"]

TOL_POSITION = 1e-10  # [m]: the tool frame's origin at most this far from the target
TOL_ORIENTATION = 1e-10  # [rad]: the rotation left between the tool's axes and the target's
MAX_ITERATIONS = 200  # per pose (a warm-started cycle of a smooth path takes one to three)
#: Poses per compiled call of a path's solve, a ``checkpoint`` between two: about 0.05 s of
#: solving (1-2 us a warm-started pose of a 6-joint arm), so that a stop request (Ctrl-C) is
#: honoured promptly on a path of a million cycles; the blocks give exactly what one call does.
BLOCK = 32768


class IKPath(NamedTuple):
    """What :func:`solve_path` returns: q (K, n) [rad | m]; position_error (K,) [m] and
    orientation_error (K,) [rad] left at each pose; iterations (K,)."""

    q: NDArray[np.float64]
    position_error: NDArray[np.float64]
    orientation_error: NDArray[np.float64]
    iterations: NDArray[np.int64]

    @property
    def converged(self) -> NDArray[np.bool_]:
        """(K,): whether each pose was reached within the tolerances."""
        return (self.position_error <= TOL_POSITION) & (self.orientation_error <= TOL_ORIENTATION)


def _poses(poses: ArrayLike) -> tuple[NDArray[np.float64], bool]:
    """The poses as a C-contiguous (K, 4, 4) array, and whether they were a path (K, 4, 4);
    their values are checked block by block (:func:`_check_rigid`)."""
    P = validate.numeric(poses, "poses")
    if P.ndim not in (2, 3) or P.shape[-2:] != (4, 4) or (P.ndim == 3 and P.shape[0] == 0):
        raise StateError(f"poses: expected a (4, 4) pose or (K, 4, 4) poses, got shape {P.shape}")
    return np.ascontiguousarray(P.reshape(-1, 4, 4)), P.ndim == 3


def _check_rigid(P3: NDArray, first: int) -> None:
    """StateError naming the first of the poses P3 (B, 4, 4) (pose ``first`` of the path and
    on) that has a NaN or inf or is no rigid transform (a rotation orthonormal to 1e-9, a last
    row 0, 0, 0, 1)."""
    if not np.isfinite(P3).all():
        k = first + int(np.flatnonzero(~np.isfinite(P3).all(axis=(1, 2)))[0])
        raise StateError(f"poses: pose {k} contains NaN or inf")
    far = np.flatnonzero(np.abs(P3[:, :3, 3]).max(axis=1) > MAGNITUDES["length"])
    if far.size:  # a robot's lengths are bounded so (mrnea.frozen): out of any reach
        k = int(far[0])
        raise StateError(f"poses: pose {first + k}'s position {P3[k, :3, 3].tolist()} m is "
                         f"beyond {MAGNITUDES['length']:g} m, the largest length mrnea accepts "
                         "(check its units)")
    R = P3[:, :3, :3]
    bad = np.flatnonzero((np.abs(R @ R.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2)) > 1e-9)
                         | (np.linalg.det(R) < 0) | (np.abs(P3[:, 3] - (0, 0, 0, 1)).max(axis=1)
                                                     > 0))
    if bad.size:
        raise StateError(f"poses: pose {first + int(bad[0])} is not a rigid transform (a "
                         f"rotation orthonormal to 1e-9 and a last row 0, 0, 0, 1)")


def moving_joints(robot: Robot, link: int, hold: Sequence[str] = ()) -> NDArray[np.int64]:
    """The indices (m,) of the joints the inverse kinematics of a tool on ``link`` moves: those
    that carry it, less the joints named in ``hold`` (module docstring). StateError: a name in
    ``hold`` that is no joint of the robot, or every carrying joint held."""
    if isinstance(hold, str):
        raise StateError(f"hold: expected a list of joint names, got the string {hold!r}")
    if not isinstance(hold, (list, tuple, set, frozenset)):
        raise StateError(f"hold: expected a list of joint names, got {type(hold).__name__} "
                         f"{hold!r}")
    names = robot.joint_names
    for name in hold:
        if name not in names:
            raise StateError(f"hold: no joint named {quote(name)} in robot "
                             f"{quote(robot.name)}")
    idx = [k for k in carrying_joints(robot, link) if names[k] not in hold]
    if not idx:
        raise StateError(f"hold: every joint that carries link {quote(robot.link_names[link])} "
                         f"is held: the tool cannot move")
    return np.array(idx, dtype=np.int64)


def solve_path(robot: Robot, poses: ArrayLike, q0: ArrayLike, tool: Tool = None,
               hold: Sequence[str] = (), checkpoint: Callable[[], None] | None = None
               ) -> IKPath:
    """Joint positions for the tool poses (K, 4, 4) in turn from q0, and the error left.

    Parameters
    ----------
    robot : Robot (a serial chain or a tree).
    poses : (K, 4, 4) or (4, 4) target poses of the tool frame, base frame [m].
    q0 : (n,) the joint positions the first solve starts from [rad | m].
    tool : the tool frame (:mod:`mrnea.tool`); None: the last link's frame (a serial chain).
    hold : names of joints kept at their q0 (module docstring).
    checkpoint : called between two blocks of :data:`BLOCK` poses (a long path is solved in
        blocks, with the same result as in one); raising from it (the command line's stop
        request: KeyboardInterrupt) stops the solve. None: nothing.

    Returns
    -------
    IKPath
        q (K, n), position_error (K,) [m], orientation_error (K,) [rad], iterations (K,).
    """
    validate.require_robot(robot)
    validate.callable_or_none(checkpoint, "checkpoint")
    P, _ = _poses(poses)
    q0 = validate.array(q0, "q0", robot.n)
    if q0.ndim != 1:
        raise StateError(f"q0: expected shape ({robot.n},), got {q0.shape}")
    link, Tt = tool_frame(robot, tool)
    idx = moving_joints(robot, link, hold)
    m = compiled.of(robot)[0]
    Q, ERR = np.empty((P.shape[0], robot.n)), np.empty((P.shape[0], 3))
    pe, Rt = np.ascontiguousarray(Tt[:3, 3]), np.ascontiguousarray(Tt[:3, :3])
    for k0 in range(0, P.shape[0], BLOCK):
        if k0 and checkpoint is not None:
            checkpoint()
        k1 = min(k0 + BLOCK, P.shape[0])
        _check_rigid(P[k0:k1], k0)
        ik_path(m, P, link, pe, Rt, idx, q0, Q, ERR, TOL_POSITION, TOL_ORIENTATION,
                MAX_ITERATIONS, k0, k1)
    return IKPath(Q, ERR[:, 0].copy(), ERR[:, 1].copy(), ERR[:, 2].astype(np.int64))


def inverse_kinematics(robot: Robot, poses: ArrayLike, q0: ArrayLike, tool: Tool = None,
                       hold: Sequence[str] = ()) -> NDArray[np.float64]:
    """Joint positions whose tool frame is at the given pose(s), on the branch through q0.

    Parameters
    ----------
    robot : Robot (a serial chain of any length: 5, 6, 7 joints..., or a tree).
    poses : (4, 4) one target pose of the tool frame, or (K, 4, 4) a path of them, in base
        coordinates [m]; a path is followed continuously, each pose's solve starting at the
        previous pose's solution.
    q0 : (n,) where the (first) solve starts [rad | m]: it picks the branch (elbow, wrist).
    tool : the tool frame (:mod:`mrnea.tool`): None (the last link's frame), a frame's name,
        ``{"xyz": ..., "rpy": ...}`` in the last link's frame, or a (4, 4) transform; on a tree
        a link's or frame's name, or ``{"xyz", "rpy", "link"}``: the tip to move.
    hold : names of joints that keep their q0 (by default only the joints that do not carry
        the tool's link do).

    Returns
    -------
    q : (n,) for one pose, (K, n) for a path [rad | m]; forward_kinematics(robot, q, tool)[-1]
        is within 1e-10 m and 1e-10 rad of each pose.

    Raises
    ------
    StateError
        Malformed arguments, or a pose not reached within the tolerances (out of reach, or a
        singularity where the solve stalls): the message names the first such pose and the
        error left. :func:`solve_path` returns the errors instead.
    """
    res = solve_path(robot, poses, q0, tool, hold)
    bad = np.flatnonzero(~res.converged)
    if bad.size:
        k = int(bad[0])
        raise StateError(
            f"inverse_kinematics: pose {k} is not reached: position error "
            f"{res.position_error[k]:.3g} m, orientation error {res.orientation_error[k]:.3g} "
            f"rad after {res.iterations[k]} iterations (out of reach, or a singularity); "
            f"{bad.size} of {res.q.shape[0]} poses not reached")
    return res.q if np.ndim(poses) == 3 else res.q[0]
