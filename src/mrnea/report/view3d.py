"""The data of the report's 3D view: the robot as the program commands it (a ghost) and as it
really moves, frame by frame, packed compactly into the page (:mod:`mrnea.report.view3d_html`
writes the page fragment and its viewer).

* Frames. The link poses at the frame times, decimated from the simulation's cycles to at most
  :data:`MAX_FPS` per second and :data:`MAX_FRAME_BYTES` of poses (:func:`frame_indices`),
  always with the last cycle. Per link and frame: the origin quantised to int16 in the box the
  origins span (step: the box's extent / 65534, 0.05 mm for a 3 m robot) and the unit
  quaternion ``(x, y, z, w)`` as int16 / 32767 (about 3e-5 rad): 14 bytes, far below a pixel;
  stored as frame-to-frame differences with their bytes in planes (:func:`pack`), which gzip
  compresses well. The viewer interpolates between frames (lerp and slerp), so the slider,
  whose step is the cycle dt, shows any cycle's time.
* Saturation. Per frame and joint one byte, 1 when the joint saturated in any cycle from this
  frame to the next (:func:`pool_flags`): a one-cycle saturation still shows.
* Geometry. Per body (base, then link 0 .. n-1) the :class:`~mrnea.report.shapes.Shape` list
  in that body's frame (JSON; meshes as float32 vertices and uint16 or uint32 faces).

The binary arrays are one payload, gzip-compressed (the browser inflates it with
``DecompressionStream``) and base64-encoded; the JSON spec beside it gives each array's offset.
"""

from __future__ import annotations

import base64
import gzip
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import StateError
from mrnea.report.shapes import Shape, leaves, robot_shapes, tip_point
from mrnea.report.states import link_frames

if TYPE_CHECKING:
    from mrnea.simulate import SimulationResult

MAX_FPS = 30.0
"""At most this many frames per second of motion are embedded."""
MAX_FRAME_BYTES = 600_000
"""At most about this many bytes of link poses (before compression) are embedded."""
POSE_BYTES = 14
"""Bytes per link and frame: origin and quaternion, seven int16."""


def frame_indices(t: ArrayLike, n_links: int, max_fps: float = MAX_FPS,
                  max_bytes: int = MAX_FRAME_BYTES, ghost: bool = True) -> NDArray[np.int64]:
    """Cycle indices of the embedded frames: every m-th cycle, and the last one.

    m is the smallest step giving at most ``max_fps`` frames per second of ``t`` (cycle times,
    uniform [s]) and at most ``max_bytes`` of poses (:data:`POSE_BYTES` per link and frame,
    twice with the ``ghost``).
    """
    t = np.asarray(t, dtype=float)
    K = t.shape[0]
    if K < 2:
        return np.arange(K)
    dt = (t[-1] - t[0]) / (K - 1)
    m = max(1, math.ceil(1.0 / (max_fps * dt) - 1e-9))
    per_frame = POSE_BYTES * n_links * (2 if ghost else 1)
    m = max(m, math.ceil(K / max(2, max_bytes // per_frame)))
    idx = np.arange(0, K, m)
    return idx if idx[-1] == K - 1 else np.append(idx, K - 1)


def pool_flags(flags: ArrayLike, idx: NDArray[np.int64]) -> NDArray[np.uint8]:
    """(F, n): 1 where ``flags`` (K, n) holds in any cycle from frame k's cycle to the cycle
    before frame k + 1's (the last frame: its own cycle to the end)."""
    flags = np.asarray(flags, dtype=bool)
    return np.logical_or.reduceat(flags, idx, axis=0).astype(np.uint8)


def quaternions(R: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions ``(x, y, z, w)`` (..., 4) of rotation matrices R (..., 3, 3).

    Shepperd's method: the largest of the four squared components comes from the trace or a
    diagonal entry, so there is no division by a small number (rotations by pi included).
    """
    R = np.asarray(R, dtype=float)
    m00, m11, m22 = R[..., 0, 0], R[..., 1, 1], R[..., 2, 2]
    cand = np.stack([1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22,
                     1 + m00 + m11 + m22], axis=-1)  # 4 x^2, 4 y^2, 4 z^2, 4 w^2
    best = cand.argmax(axis=-1)
    s = 2.0 * np.sqrt(np.take_along_axis(cand, best[..., None], axis=-1)[..., 0])
    d21, d02, d10 = (R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                     R[..., 1, 0] - R[..., 0, 1])
    s01, s02, s12 = (R[..., 0, 1] + R[..., 1, 0], R[..., 0, 2] + R[..., 2, 0],
                     R[..., 1, 2] + R[..., 2, 1])
    q = np.empty((*R.shape[:-2], 4))
    rows = [(s / 4, s01 / s, s02 / s, d21 / s), (s01 / s, s / 4, s12 / s, d02 / s),
            (s02 / s, s12 / s, s / 4, d10 / s), (d21 / s, d02 / s, d10 / s, s / 4)]
    for b, comps in enumerate(rows):
        sel = best == b
        for a in range(4):
            q[..., a][sel] = comps[a][sel]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _continuous(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Flip signs along the frame axis (0) so consecutive quaternions have a dot product >= 0
    (q and -q are the same rotation; the viewer's slerp takes the short way between them)."""
    q = q.copy()
    for k in range(1, q.shape[0]):
        q[k, np.einsum("ij,ij->i", q[k], q[k - 1]) < 0] *= -1
    return q


def quantise(T: NDArray[np.float64], lo: NDArray, hi: NDArray) -> NDArray[np.int16]:
    """(F, n, 7) int16 of frames (F, n, 4, 4): origins mapped from the box [lo, hi] to
    -32767..32767, quaternions (sign-continuous over the frames) times 32767."""
    span = np.where(hi > lo, hi - lo, 1.0)
    p = np.rint((T[..., :3, 3] - lo) / span * 65534.0 - 32767.0)
    q = np.rint(_continuous(quaternions(T[..., :3, :3])) * 32767.0)
    return np.concatenate([p, q], axis=-1).clip(-32767, 32767).astype(np.int16)


def pack(Q: NDArray[np.int16]) -> NDArray[np.uint8]:
    """Quantised poses (F, n, 7) as compressible bytes (2, n, 7, F): per link and component the
    change from the previous frame (modulo 2^16, so exact), low bytes first, then high bytes.

    Smooth motion changes little from frame to frame, so most high bytes are 0 or 255: gzip
    packs the whole about 2.5 times, int16 values as they are 1.3 times (measured)."""
    D = np.diff(Q.astype(np.int32), axis=0, prepend=0) & 0xFFFF
    return np.stack([D & 0xFF, D >> 8]).astype(np.uint8).transpose(0, 2, 3, 1).copy()


def _bounds(T_all: Sequence[NDArray], shapes: Sequence[Sequence[Shape]],
            tips: Sequence[tuple[int, NDArray]]
            ) -> tuple[list[float], list[float], list[list[float]]]:
    """Low and high corners [m] of a box holding every shape of every body over all frames and
    the tip paths, and 26 support points of that swept volume (the camera fits those)."""
    pts, rad = [], []
    for body, S in enumerate(shapes):
        for s in S:
            c, r = s.bounding_sphere()
            new = [c[None]] if body == 0 else [T[:, body - 1, :3, :3] @ c + T[:, body - 1, :3, 3]
                                               for T in T_all]
            pts += new
            rad += [np.full(p.shape[0], r) for p in new]
    for T in T_all:
        for link, tip in tips:
            pts.append(T[:, link, :3, :3] @ tip + T[:, link, :3, 3])
            rad.append(np.zeros(pts[-1].shape[0]))
    P, Rr = np.concatenate(pts), np.concatenate(rad)
    D = np.array([d for d in np.ndindex(3, 3, 3) if d != (1, 1, 1)], dtype=float) - 1.0
    D /= np.linalg.norm(D, axis=1, keepdims=True)
    best = (P @ D.T + Rr[:, None]).argmax(axis=0)  # the farthest reach along each direction
    support = P[best] + Rr[best, None] * D
    R3 = Rr[:, None]
    return ((P - R3).min(axis=0).tolist(), (P + R3).max(axis=0).tolist(),
            np.round(support, 5).tolist())


class _Payload:
    """Binary sections, each padded to 8 bytes, and their ``[offset, count]``."""

    def __init__(self) -> None:
        self.parts: list[bytes] = []
        self.size = 0

    def add(self, a: NDArray) -> list[int]:
        b = np.ascontiguousarray(a).tobytes()
        where = [self.size, int(a.size)]
        self.parts.append(b + bytes(-len(b) % 8))
        self.size += len(self.parts[-1])
        return where


def _shape_json(s: Shape, payload: _Payload, meshes: list[dict]) -> dict[str, Any]:
    o = s.origin
    d: dict[str, Any] = {"k": s.kind, "s": [round(float(x), 6) for x in s.size],
                         "p": [round(float(x), 7) for x in
                               [*o[:3, 3], *quaternions(o[:3, :3])]],
                         "j": -1 if s.joint is None else int(s.joint)}
    if s.color is not None:
        d["c"] = int(s.color)
    if s.kind == "mesh":
        assert s.vertices is not None and s.faces is not None
        d["m"] = len(meshes)
        wide = s.vertices.shape[0] > 65535
        meshes.append({"v": payload.add(np.asarray(s.vertices, dtype=np.float32)),
                       "f": payload.add(np.asarray(s.faces, dtype=np.uint32 if wide
                                                   else np.uint16)), "f32": wide})
    return d


def scene_data(t: ArrayLike, frames_real: ArrayLike, frames_cmd: ArrayLike | None,
               shapes: Sequence[Sequence[Shape]], saturated: ArrayLike,
               joint_names: Sequence[str], clock: tuple[float, float, float],
               tip: ArrayLike = (0.0, 0.0, 0.0), compress: bool = True,
               targets: ArrayLike | None = None,
               tips: Sequence[tuple[int, ArrayLike]] | None = None) -> dict[str, Any]:
    """The JSON spec the page embeds.

    Parameters
    ----------
    t : (F,) array_like
        Frame times [s], increasing.
    frames_real, frames_cmd : (F, n, 4, 4) array_like
        Each link's frame in base coordinates (``T_i``, URDF conventions) at the frame times,
        for the real motion and the commanded one (None: no ghost).
    shapes : n + 1 sequences of Shape
        Base shapes, then each link's, in that body's frame (:func:`~mrnea.report.shapes.
        robot_shapes`).
    saturated : (F, n) array_like of bool
        Joint j saturated between frame k and frame k + 1 (:func:`pool_flags`).
    joint_names : n str
    clock : (t0, t1, dt)
        The slider's range and step [s]: the cycle clock.
    tip : (3,) array_like
        The end-effector point [m] in the last link's frame whose paths are drawn.
    compress : bool
        gzip the binary payload.
    targets : (M, 4, 4) array_like or None
        A Cartesian program's move targets, tool poses in base coordinates: each drawn as a dot
        at the tool point and a stick along the tool's z axis; in the spec as ``targets``, rows
        ``[x, y, z, qx, qy, qz, qw]`` (three.js' quaternion order).
    tips : sequence of (link index, (3,) point [m] in that link's frame), optional
        Every point whose paths are drawn (a tree: each branch's tip); None: ``tip`` on the
        last link alone.
    """
    t = np.asarray(t, dtype=np.float64)
    Tr = np.asarray(frames_real, dtype=np.float64)
    Tc = None if frames_cmd is None else np.asarray(frames_cmd, dtype=np.float64)
    F, n = Tr.shape[:2]
    sat = np.asarray(saturated, dtype=np.uint8)
    if (t.shape != (F,) or F == 0 or Tr.shape != (F, n, 4, 4) or sat.shape != (F, n)
            or (Tc is not None and Tc.shape != Tr.shape) or len(shapes) != n + 1
            or len(joint_names) != n):
        raise StateError(f"scene_data: expected t (F,), frames (F, n, 4, 4), saturated (F, n), "
                         f"n + 1 shape lists and n joint names; got t {t.shape}, frames_real "
                         f"{Tr.shape}, frames_cmd {None if Tc is None else Tc.shape}, saturated "
                         f"{sat.shape}, {len(shapes)} shape lists, {len(joint_names)} names")
    tip = np.asarray(tip, dtype=float)
    traced = ([(n - 1, tip)] if tips is None else
              [(int(k) % n, np.asarray(p, dtype=float)) for k, p in tips])
    both = [Tr] if Tc is None else [Tr, Tc]
    box_lo, box_hi, support = _bounds(both, shapes, traced)
    origins = np.concatenate([T[..., :3, 3].reshape(-1, 3) for T in both])
    lo, hi = origins.min(axis=0), origins.max(axis=0)
    payload = _Payload()
    bins = {"time": payload.add(t), "real": payload.add(pack(quantise(Tr, lo, hi))),
            "sat": payload.add(sat)}
    if Tc is not None:
        bins["cmd"] = payload.add(pack(quantise(Tc, lo, hi)))
    meshes: list[dict] = []
    shape_json = [[_shape_json(s, payload, meshes) for s in body] for body in shapes]
    raw = b"".join(payload.parts)
    blob = gzip.compress(raw, compresslevel=9, mtime=0) if compress else raw
    marks = []
    if targets is not None and len(targets):
        from scipy.spatial.transform import Rotation  # here: a report without targets needs no
        # scipy.spatial (~0.4 s)

        Tg = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
        marks = np.column_stack([Tg[:, :3, 3], Rotation.from_matrix(Tg[:, :3, :3]).as_quat()
                                 ]).tolist()
    return {"version": 1, "frames": F, "targets": marks, "joints": [str(x) for x in joint_names],
            "clock": {"t0": float(clock[0]), "t1": float(clock[1]), "dt": float(clock[2])},
            "box": [lo.tolist(), hi.tolist()], "bounds": [box_lo, box_hi], "support": support,
            "tip": tip.tolist(), "tips": [[k, *p.tolist()] for k, p in traced],
            "shapes": shape_json, "meshes": meshes, "bin": bins,
            "gzip": compress, "raw_bytes": len(raw),
            "payload": base64.b64encode(blob).decode("ascii")}


def result_scene(result: SimulationResult) -> dict[str, Any]:
    """:func:`scene_data` of a simulation run (at least one cycle): frames at
    :func:`frame_indices` from :func:`mrnea.forward_kinematics` of ``q`` (real) and ``q_cmd``
    (the ghost), the pooled saturation flags, the robot's shapes and the slider on the cycle
    clock. The end-effector paths are those of a Cartesian program's tool point (its commanded
    path is the programmed Cartesian path), else of :func:`tip_point` of every branch's last
    link (:func:`~mrnea.report.shapes.leaves`: a tree's tips); the program's move targets are
    marked."""
    robot = result.robot
    idx = frame_indices(result.t, robot.n)
    # forward_kinematics state by state on the kernel the simulation compiled (report/states.py)
    real = link_frames(robot, result.q[idx])[:, 1:]  # the links' frames, not the base's
    cmd = link_frames(robot, result.q_cmd[idx])[:, 1:]
    t = result.t
    return scene_data(t[idx], real, cmd, robot_shapes(robot), pool_flags(result.saturated, idx),
                      robot.joint_names, (float(t[0]), float(t[-1]), float(result.dt)),
                      tip_point(robot) if result.tool_point is None else result.tool_point,
                      targets=result.tool_targets,
                      tips=None if result.tool_point is not None else
                      [(i, tip_point(robot, i)) for i in leaves(robot)])
