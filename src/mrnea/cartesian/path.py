"""One Cartesian move's path and timing: the tool poses of its cycles.

Usage: ``s, poses = move_poses(move, T0, dt, room)``: the path parameter ``s`` (N + 1,) from
0 to 1 and the tool poses (N + 1, 4, 4) (base frame) at the cycles of a ``linear`` or
``circular`` move (:class:`mrnea.io.moves.Move`) starting at the pose ``T0``;
``poses[0] = T0`` and ``poses[-1]`` the target, exactly in position.

Geometry. The tool point moves on the segment from p0 to p1 (linear) or on the circle through
p0, the ``via`` point and p1, from p0 through via to p1 (circular: centre c, radius r, the arc's
angle phi); the orientation turns from R0 to R1 about one fixed axis, ``R(s) = R0 exp(s
log(R0^T R1))`` (slerp, scipy's ``Rotation``), on the same parameter s. Length L (L = |p1 - p0|,
or r phi) and angle Theta (the angle of ``R0^T R1``): the tool speed is ``L ds/dt`` and its
angular speed ``Theta ds/dt``.

Timing. s follows the rest-to-rest profile of :mod:`mrnea.trajectory` for one coordinate going
from 0 to 1, with the tightest of the tool's limits: speed ``min(v / L, omega / Theta)``,
acceleration ``min(a / L, alpha / Theta)`` and, given a jerk, jerk ``min(j / L, j_w / Theta)``
(then the S-curve, else the trapezoid); whole cycles, so every limit holds at the cycle
instants' finite differences as for joint profiles (docs/programs.md).

Memory. Before a move's poses are made, :class:`Room` refuses a program whose cycles would not
fit the memory budget (:func:`mrnea.resources.require_memory`): a tiny ``dt`` was killed by the
system for want of memory, not refused.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import StateError
from mrnea.ik import BLOCK
from mrnea.io.moves import Move
from mrnea.resources import require_memory
from mrnea.trajectory import scurve, trapezoidal

__all__ = ["Room", "circle", "move_poses"]

#: Peak memory of solving a Cartesian program, per cycle of the program and per (joint + 2)
#: [bytes]: the rows, poses and errors kept to the end and joined, the forward kinematics of
#: every frame along a joint move, a tool move's poses, rotations and inverse kinematics, the
#: findings. Measured with tracemalloc (tests/test_hostile_s36.py): on the Puma 560 at 20 us,
#: 2314 bytes a cycle of a MoveJ, 1434 of one MoveL, 1218 of two; on the UR5 at 0.1 ms, 596-2109.
PROGRAM_BYTES = 320


@dataclass(frozen=True)
class Room:
    """The memory check of a Cartesian program's solve: ``done`` cycles already made, of a
    robot of ``n`` joints."""

    done: int
    n: int

    def check(self, N: int) -> None:
        """Refuse (StateError) a next move of ``N`` cycles whose program would not fit the
        memory budget (:data:`PROGRAM_BYTES`)."""
        need = PROGRAM_BYTES * float(self.done + N) * (self.n + 2)
        require_memory(need, f"a Cartesian program of {float(self.done + N):.3g} cycles of "
                             f"{self.n} joints", "use a coarser dt or shorter moves (higher "
                             "speed, acceleration and jerk limits shorten them), or split it "
                             "into several programs", StateError)


def circle(p0: NDArray, pv: NDArray, p1: NDArray
           ) -> tuple[NDArray, float, NDArray, NDArray, float]:
    """(centre c, radius r, e1, e2, phi) of the arc from p0 through pv to p1: its points are
    ``c + r (cos a e1 + sin a e2)`` for a in [0, phi]; e1 points to p0. StateError if the
    three points are on one line (or two coincide)."""
    a, b = pv - p0, p1 - p0
    axb = np.cross(a, b)
    den = 2.0 * float(axb @ axb)
    if not den > (1e-12 * max(float(a @ a), float(b @ b))) ** 2:
        raise StateError("start, via and target are on one line (or two coincide): no circle "
                         "through them")
    c = p0 + np.cross(float(a @ a) * b - float(b @ b) * a, axb) / den
    r = float(np.linalg.norm(p0 - c))
    e1 = (p0 - c) / r
    e2 = np.cross(axb / math.sqrt(den / 2.0), e1)  # (p0, pv, p1) turn positively about a x b
    phi = math.atan2(float((p1 - c) @ e2), float((p1 - c) @ e1)) % (2.0 * math.pi)
    return c, r, e1, e2, phi


def _limit(value: float, size: float) -> float:
    """The path parameter's limit that a tool limit ``value`` gives on a move of ``size``."""
    return value / size if size > 0.0 else math.inf


def move_poses(move: Move, T0: NDArray, dt: float, room: Room,
               checkpoint: Callable[[], None] = lambda: None) -> tuple[NDArray, NDArray]:
    """(s (N + 1,), poses (N + 1, 4, 4)) of a linear or circular move from T0 (module
    docstring); the orientations in blocks of :data:`mrnea.ik.BLOCK` cycles, ``checkpoint``
    called between two (a stop request). StateError: a move that only turns without an
    angular limit, a circle that does not exist, or cycles beyond the memory budget
    (``room``)."""
    from scipy.spatial.transform import Rotation  # here, not at the top (io.posecsv)

    p0, R0 = T0[:3, 3], T0[:3, :3]
    p1 = move.xyz
    R1 = R0 if move.R is None else move.R
    rotvec = (Rotation.from_matrix(R0).inv() * Rotation.from_matrix(R1)).as_rotvec()
    theta = float(np.linalg.norm(rotvec))
    if move.type == "circular":
        c, r, e1, e2, phi = circle(p0, move.via, p1)
        length = r * phi
    else:
        length = float(np.linalg.norm(p1 - p0))
    v, a, j, w, al, jw = move.limits
    vs, as_ = min(_limit(v, length), _limit(w, theta)), min(_limit(a, length),
                                                           _limit(al, theta))
    if length == 0.0 and theta == 0.0:
        s = np.zeros(1)
    else:
        if math.isinf(vs) or math.isinf(as_):
            raise StateError(f"the tool only turns ({theta:.4g} rad, no translation): give "
                             f"angular_speed and angular_acceleration")
        # the memory before the profile is made: a trapezoid's duration [s] (an S-curve's is
        # longer); an arc through a via almost in line with its ends is kilometres long
        trapezoid = 2.0 / math.sqrt(as_) if vs * vs >= as_ else 1.0 / vs + vs / as_
        room.check(int(min(trapezoid / dt, 1e18)))
        if math.isinf(j) and math.isinf(jw):
            s = trapezoidal([[0.0], [1.0]], dt, vs, as_)[1][:, 0]
        else:
            js = min(_limit(j, length), _limit(jw, theta))
            s = scurve([[0.0], [1.0]], dt, vs, as_, js)[1][:, 0]
    room.check(s.size)
    poses = np.zeros((s.size, 4, 4))
    poses[:, 3, 3] = 1.0
    if move.type == "circular":
        ang = s * phi
        poses[:, :3, 3] = c + r * (np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2)
    else:
        poses[:, :3, 3] = p0 + s[:, None] * (p1 - p0)
    start = Rotation.from_matrix(R0)
    for a in range(0, s.size, BLOCK):
        if a:
            checkpoint()
        b = a + BLOCK
        poses[a:b, :3, :3] = (start * Rotation.from_rotvec(s[a:b, None] * rotvec)).as_matrix()
    poses[0, :3, :3], poses[0, :3, 3] = R0, p0
    poses[-1, :3, 3] = p1
    if move.R is not None:
        poses[-1, :3, :3] = R1
    return s, poses
