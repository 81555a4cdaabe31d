"""Linear moves joined by blended corners (``blend`` [m]): one tool path, timed as one.

Usage: ``poses, owner, targets = chain_poses(moves, T0, dt, room)``: the tool poses (N + 1, 4, 4)
(base frame) at the cycles of consecutive ``linear`` moves (:class:`mrnea.io.moves.Move`),
each but the last with ``blend`` r > 0, starting at rest at the pose ``T0`` and ending at rest
at the last move's target; ``owner`` (N + 1,) the move (1-based index) each cycle belongs to
(``poses[0] = T0`` belongs to the first move; a corner's arc to the move whose blend it is);
``targets`` (M, 4, 4) the moves' target poses (the corners, passed within their blends
without stopping).

Geometry (the industrial MoveL "zone" or "blend radius"). Move i goes from P_{i-1} to its target
P_i along u_i. A blend r at P_i replaces the corner by the circular arc tangent to both segments
at A = P_i - r u_i and B = P_i + r u_{i+1}: turning angle theta (between u_i and u_{i+1}),
radius ``rho = r / tan(theta / 2)``, length ``rho theta``. The tool point leaves segment i at A
and joins segment i + 1 at B, both at the distance r from P_i, and stays within r of P_i in
between (the arc bulges towards the corner); the path is tangent-continuous (C1). The corner
point itself is not reached. ``r`` must be at most half the shorter of the two segments, so
that the two blends of one segment do not overlap (a larger r is refused, not clipped: the
program would not be the one written). Collinear segments (theta = 0) pass straight on; a
segment that turns straight back (theta = pi) is refused.

Orientation. On segment i (outside its blends) the orientation is the move's slerp, ``R_{i-1}
exp(sigma w_i)`` at the fraction sigma of the segment (w_i the rotation vector of
``R_{i-1}^T R_i``). On the arc, with lambda in [0, 1] the fraction of its length,
``R(lambda) = R_A exp(g1(lambda) w1) exp(g2(lambda) w2)``, w1 = (r / L_i) w_i the turn that
segment i still had to make, w2 = (r / L_{i+1}) w_{i+1} the turn segment i + 1 makes in its
first r; g1 and g2 are the cubic Hermite polynomials with g(0) = 0, g(1) = 1 and the slopes
(c, 0) and (0, c), c = arc length / r, so the angular rate per unit path length is that of
segment i at A and of segment i + 1 at B: the angular velocity is continuous at constant speed.

Timing. The path length s follows the shortest profile that keeps, on segment i, the tool speed
and tangential acceleration within move i's limits (its ``speed``, ``acceleration`` and the
angular ones, through the turn per metre ``Theta_i / L_i``, as in
:mod:`mrnea.cartesian.path`), and crosses each arc at one constant speed, the largest under both
moves' speeds, with the centripetal acceleration ``v^2 / rho`` under the smaller of their
accelerations and the arc's angular speed and acceleration (computed on 512 points of the arc)
under the smaller of their angular limits: each segment accelerates and decelerates at its own
limit between the speeds of its ends (0 at the chain's start and end), a forward and a backward
pass making every speed change possible within its segment. The duration is rounded up to whole
cycles by slowing the whole profile uniformly (speeds scale by ``T / T'``, accelerations by its
square): every limit still holds. ``jerk`` is not applied to a blended chain (refused when the
file is read, :mod:`mrnea.io.moves`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from mrnea.cartesian.path import Room
from mrnea.errors import StateError
from mrnea.io.moves import Move
from mrnea.trajectory import cycles

if TYPE_CHECKING:  # imported where used: scipy.spatial costs every command ~0.4 s
    from scipy.spatial.transform import Rotation

__all__ = ["chain_poses", "hermite"]

ARC_SAMPLES = 512  # points on an arc where its angular rate and acceleration are taken
STRAIGHT = 1e-12  # [rad]: a turn below this is no turn (the blend passes straight on)
REVERSAL = math.pi - 1e-9  # [rad]: a turn beyond this turns straight back


def hermite(lam: NDArray, c: float) -> tuple[NDArray, NDArray]:
    """(g1, g2) at lambda: cubic, g(0) = 0, g(1) = 1; g1'(0) = c, g1'(1) = 0; g2'(0) = 0,
    g2'(1) = c (module docstring)."""
    h01 = lam * lam * (3.0 - 2.0 * lam)
    return c * lam * (1.0 - lam) ** 2 + h01, h01 - c * lam * lam * (1.0 - lam)


@dataclass(frozen=True)
class _Segment:
    p0: NDArray
    p1: NDArray
    R0: Rotation
    w: NDArray  # rotation vector, body frame: R(sigma) = R0 exp(sigma w)
    length: float
    v: float  # the path speed and acceleration limits [m/s, m/s^2]
    a: float
    omega: float  # the move's angular limits [rad/s, rad/s^2]
    alpha: float

    def point(self, sigma: NDArray) -> NDArray:
        return self.p0 + sigma[:, None] * (self.p1 - self.p0)

    def rotation(self, sigma: NDArray) -> Rotation:
        from scipy.spatial.transform import Rotation

        return self.R0 * Rotation.from_rotvec(sigma[:, None] * self.w)


@dataclass(frozen=True)
class _Arc:
    A: NDArray  # entry point [m]
    u: NDArray  # direction at A
    n: NDArray  # towards the centre (zero for a straight blend)
    r: float
    theta: float
    length: float
    RA: Rotation
    w1: NDArray
    w2: NDArray
    v: float  # the one speed it is crossed at [m/s]

    def point(self, lam: NDArray) -> NDArray:
        if self.theta <= STRAIGHT:
            return self.A + (self.length * lam)[:, None] * self.u
        rho = self.r / math.tan(0.5 * self.theta)
        a = lam * self.theta  # no cancellation for small turns: rho sin a, 2 rho sin^2(a/2)
        return (self.A + (rho * np.sin(a))[:, None] * self.u
                + (2.0 * rho * np.sin(0.5 * a) ** 2)[:, None] * self.n)

    def rotation(self, lam: NDArray) -> Rotation:
        from scipy.spatial.transform import Rotation

        g1, g2 = hermite(lam, self.length / self.r)
        return (self.RA * Rotation.from_rotvec(g1[:, None] * self.w1)
                * Rotation.from_rotvec(g2[:, None] * self.w2))


def _segments(moves: Sequence[Move], T0: NDArray) -> list[_Segment]:
    from scipy.spatial.transform import Rotation

    out = []
    p, R = T0[:3, 3].copy(), Rotation.from_matrix(T0[:3, :3])
    for mv in moves:
        R1 = R if mv.R is None else Rotation.from_matrix(mv.R)
        w = (R.inv() * R1).as_rotvec()
        L, theta = float(np.linalg.norm(mv.xyz - p)), float(np.linalg.norm(w))
        if L == 0.0:
            raise StateError(f"move {mv.index}: a blended move must go somewhere: its target is "
                             f"where it starts")
        v, a, _, om, al, _ = mv.limits
        per = theta / L  # the turn per metre [rad/m]
        v_s = min(v, om / per) if per > 0 else v
        a_s = min(a, al / per) if per > 0 else a
        out.append(_Segment(p, mv.xyz.copy(), R, w, L, v_s, a_s, om, al))
        p, R = mv.xyz.copy(), R1
    return out


def _arc(mv: Move, s1: _Segment, s2: _Segment) -> _Arc:
    r = mv.blend
    half = 0.5 * min(s1.length, s2.length)
    if r > half * (1.0 + 1e-12):
        raise StateError(f"move {mv.index}: 'blend' {r:g} m is more than half the shorter of "
                         f"the two segments it joins ({half:.6g} m, of {s1.length:.6g} m and "
                         f"{s2.length:.6g} m): the corner's blends would overlap; give at "
                         f"most {half:.6g}")
    r = min(r, half)
    u1 = (s1.p1 - s1.p0) / s1.length
    u2 = (s2.p1 - s2.p0) / s2.length
    theta = math.atan2(float(np.linalg.norm(np.cross(u1, u2))), float(u1 @ u2))
    if theta > REVERSAL:
        raise StateError(f"move {mv.index}: the next move turns straight back: there is no "
                         f"corner to round with 'blend'")
    if theta <= STRAIGHT:
        n, length, v_turn = np.zeros(3), 2.0 * r, math.inf
    else:
        n = u2 - (u2 @ u1) * u1
        n /= np.linalg.norm(n)
        rho = r / math.tan(0.5 * theta)
        length = rho * theta
        v_turn = math.sqrt(min(s1.a, s2.a) * rho)  # the centripetal acceleration v^2 / rho
    RA = s1.rotation(np.array([1.0 - r / s1.length]))[0]
    arc = _Arc(s1.p1 - r * u1, u1, n, r, theta, length, RA, (r / s1.length) * s1.w,
               (r / s2.length) * s2.w, 0.0)
    v = min(s1.v, s2.v, v_turn, *_angular_caps(arc, min(s1.omega, s2.omega),
                                                 min(s1.alpha, s2.alpha)))
    return dataclasses.replace(arc, v=v)


def _angular_caps(arc: _Arc, omega: float, alpha: float) -> tuple[float, float]:
    """The arc's speed limits from the angular ones: its angular rate per metre k1 [rad/m]
    and the rate's change per metre k2 [rad/m^2] (on ARC_SAMPLES points), v <= omega / k1 and
    v^2 <= alpha / k2 at constant speed."""
    lam = np.linspace(0.0, 1.0, ARC_SAMPLES)
    R = arc.rotation(lam)
    h = arc.length / (ARC_SAMPLES - 1)
    rate = (R[:-1].inv() * R[1:]).as_rotvec() / h  # body frame, per metre
    k1 = float(np.linalg.norm(rate, axis=1).max())
    k2 = float(np.linalg.norm(np.diff(rate, axis=0), axis=1).max() / h) if len(rate) > 1 else 0
    cap1 = omega / k1 if k1 > 0 else math.inf
    cap2 = math.sqrt(alpha / k2) if k2 > 0 else math.inf
    return cap1, cap2


def _line_phases(length: float, vs: float, ve: float, v: float, a: float
                 ) -> list[tuple[float, float, float]]:
    """(duration [s], start speed [m/s], acceleration [m/s^2]) of the phases that cover
    ``length`` from speed vs to ve within v and a (accelerate, cruise, decelerate)."""
    if length <= 0.0:
        return []
    vp = min(v, math.sqrt(a * length + 0.5 * (vs * vs + ve * ve)))
    vp = max(vp, vs, ve)
    d1, d3 = (vp * vp - vs * vs) / (2 * a), (vp * vp - ve * ve) / (2 * a)
    cruise = max(0.0, length - d1 - d3)
    phases = [((vp - vs) / a, vs, a), (cruise / vp if vp > 0 else 0.0, vp, 0.0),
              ((vp - ve) / a, vp, -a)]
    return [p for p in phases if p[0] > 0.0]


def chain_poses(moves: Sequence[Move], T0: NDArray, dt: float, room: Room
                ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """(poses (N + 1, 4, 4), owner (N + 1,), targets (M, 4, 4)) of linear moves joined by
    their blends (module docstring). StateError: a blend too large for its segments, a move
    that goes nowhere, a corner that turns straight back, cycles beyond the memory budget
    (``room``)."""
    from scipy.spatial.transform import Rotation

    segs = _segments(moves, T0)
    arcs = [_arc(mv, s1, s2) for mv, s1, s2 in zip(moves[:-1], segs[:-1], segs[1:],
                                                    strict=True)]
    # the straight part of each segment, between its blends
    cut_in = [0.0] + [a.r for a in arcs]
    cut_out = [a.r for a in arcs] + [0.0]
    lines = [s.length - ci - co for s, ci, co in zip(segs, cut_in, cut_out, strict=True)]
    node = [0.0] + [a.v for a in arcs] + [0.0]  # the speed at each segment's ends
    for i, (s, ell) in enumerate(zip(segs, lines, strict=True)):  # forward pass
        node[i + 1] = min(node[i + 1], math.sqrt(node[i] ** 2 + 2 * s.a * ell))
    for i in range(len(segs) - 1, -1, -1):  # backward pass
        node[i] = min(node[i], math.sqrt(node[i + 1] ** 2 + 2 * segs[i].a * lines[i]))
    # the pieces in order: (kind, index, path length at its start); the phases of s(t)
    pieces, phases, s_at = [], [], 0.0
    for i, s in enumerate(segs):
        pieces.append(("line", i, s_at))
        for dur, v0, acc in _line_phases(lines[i], node[i], node[i + 1], s.v, s.a):
            phases.append((dur, v0, acc))
        s_at += lines[i]
        if i < len(arcs):
            pieces.append(("arc", i, s_at))
            if arcs[i].length > 0.0:
                phases.append((arcs[i].length / node[i + 1], node[i + 1], 0.0))
            s_at += arcs[i].length
    total = s_at
    durs = np.array([p[0] for p in phases])
    t_start = np.concatenate([[0.0], np.cumsum(durs)])
    s_start = np.concatenate([[0.0], np.cumsum([d * v0 + 0.5 * acc * d * d
                                                for d, v0, acc in phases])])
    T = float(t_start[-1])
    N = int(cycles(T, dt))
    room.check(N + 1)
    tau = np.arange(N + 1) * (T / N)  # uniformly slowed to whole cycles
    ph = np.clip(np.searchsorted(t_start, tau, side="right") - 1, 0, len(phases) - 1)
    d = tau - t_start[ph]
    v0 = np.array([p[1] for p in phases])[ph]
    acc = np.array([p[2] for p in phases])[ph]
    s = np.clip(s_start[ph] + v0 * d + 0.5 * acc * d * d, 0.0, total)
    s[0], s[-1] = 0.0, total
    # poses along the path
    starts = np.array([p[2] for p in pieces])
    which = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(pieces) - 1)
    poses = np.zeros((N + 1, 4, 4))
    poses[:, 3, 3] = 1.0
    owner = np.empty(N + 1, np.int64)
    for k, (kind, i, s0) in enumerate(pieces):
        rows = np.flatnonzero(which == k)
        if not rows.size:
            continue
        x = s[rows] - s0
        if kind == "line":
            sigma = (cut_in[i] + x) / segs[i].length
            pos, rot = segs[i].point(sigma), segs[i].rotation(sigma)
        else:
            lam = x / arcs[i].length if arcs[i].length > 0 else np.zeros_like(x)
            pos, rot = arcs[i].point(lam), arcs[i].rotation(lam)
        poses[rows, :3, 3], poses[rows, :3, :3] = pos, rot.as_matrix()
        owner[rows] = moves[i].index
    owner[0] = moves[0].index
    targets = np.zeros((len(segs), 4, 4))
    targets[:, 3, 3] = 1.0
    for k, sg in enumerate(segs):
        targets[k, :3, 3] = moves[k].xyz
        targets[k, :3, :3] = (sg.R0 * Rotation.from_rotvec(sg.w)).as_matrix() \
            if moves[k].R is None else moves[k].R
    poses[0] = T0
    poses[-1] = targets[-1]
    return poses, owner, targets
