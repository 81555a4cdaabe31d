"""The moves of a Cartesian program file: ``[program] tool``, ``q0`` and the ``[[move]]`` tables
(each may name its own ``tool``, and the joints its inverse kinematics ``hold``).

:func:`read_moves` checks them and returns :class:`Moves`, plain data: the joint program is made
from them with the robot, by inverse kinematics (:func:`mrnea.cartesian.solve`). Format and
examples: ``docs/programs.md`` ("Cartesian moves") and ``docs/cartesian.md``. Every problem is a
:class:`mrnea.errors.ProgramFileError` naming the file, the move (1-based, with its type) and
the key at fault.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import quote
from mrnea.frozen import MAGNITUDES
from mrnea.io.jointnames import number_table
from mrnea.io.posecsv import POSE_INTERPOLATIONS, ROTVEC_BOUND, read_poses, resample_poses
from mrnea.io.source import expand_home
from mrnea.io.tomlcheck import TomlCheck, did_you_mean
from mrnea.rigid import rotation_from_rpy

__all__ = ["MOVE_KEYS", "MOVE_TYPES", "Move", "Moves", "ToolSpec", "read_moves"]

MOVE_TYPES = ("joint", "linear", "circular", "poses")
JOINT_PROFILES = ("trapezoidal", "quintic", "scurve")
_COMMON = ("type", "dwell", "blend", "tool")
MOVE_KEYS = {
    "joint": (*_COMMON, "target", "profile", "velocity_limit", "acceleration_limit",
              "jerk_limit"),
    "linear": (*_COMMON, "hold", "xyz", "rpy", "quat", "speed", "acceleration", "angular_speed",
               "angular_acceleration", "jerk", "angular_jerk"),
}
MOVE_KEYS["circular"] = (*MOVE_KEYS["linear"], "via")
MOVE_KEYS["poses"] = (*_COMMON, "hold", "csv", "interpolation")

#: A tool as a program file gives it: a frame's name, or a table of xyz, rpy and link.
ToolSpec = str | dict[str, Any] | None


@dataclass(frozen=True, eq=False)
class Move:
    """One ``[[move]]`` of a program file (1-based ``index``, as in messages).

    Joint moves: ``target`` (n,) [rad | m] or a table of the joints it moves by name (the others
    hold), ``profile`` and ``limits`` (velocity, acceleration[, jerk]): each a number for every
    joint (a 0-d array), an (n,) array or a table by joint name (:func:`mrnea.cartesian.solve`
    makes them per joint on the robot). Linear and circular moves: ``xyz`` (3,) [m] and ``R``
    (3, 3) the target tool pose in the base frame (``R`` None: keep the orientation the move
    starts with), ``via`` (3,) [m] the circle's intermediate point (circular only), and
    ``limits`` the tool's (speed [m/s], acceleration [m/s^2], jerk [m/s^3], angular speed
    [rad/s], angular acceleration [rad/s^2], angular jerk [rad/s^3]), ``inf`` where not given (a
    jerk: no jerk limit, the trapezoid). ``dwell`` [s] is the hold at the move's end; ``blend``
    [m] the radius of the corner into the next move (0: stop there). Pose CSV moves: ``poses``
    (N + 1, 4, 4) the tool poses at the move's cycles (:mod:`mrnea.io.posecsv`), ``csv`` the
    file and ``csv_line`` the line of its first data row (for messages). ``tool`` the move's own
    tool (None: the program's, :class:`Moves`); ``hold`` the names of the joints its inverse
    kinematics keeps still (linear, circular and pose CSV moves).
    """

    index: int
    type: str
    dwell: float
    blend: float
    target: NDArray[np.float64] | dict[str, float] | None = None
    profile: str = "trapezoidal"
    limits: tuple[NDArray[np.float64] | dict[str, float] | float, ...] = ()
    xyz: NDArray[np.float64] | None = None
    R: NDArray[np.float64] | None = None
    via: NDArray[np.float64] | None = None
    poses: NDArray[np.float64] | None = None
    csv: str | None = None
    csv_line: int = 0
    tool: ToolSpec = None
    hold: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """``move 3 (linear)``: how messages name it."""
        return f"move {self.index} ({self.type})"


@dataclass(frozen=True, eq=False)
class Moves:
    """A Cartesian program's moves: the tool (a frame name, ``{"xyz", "rpy", "link"}`` or None:
    the last link's frame; :mod:`mrnea.tool`), the start ``q0`` (n,) [rad | m] or a table by
    joint name (the joints it does not name start at 0) and the moves (a move's own ``tool``
    replaces the program's for that move)."""

    tool: ToolSpec
    q0: NDArray[np.float64] | dict[str, float]
    moves: tuple[Move, ...]

    @property
    def n(self) -> int:
        """The number of joints q0 gives (a table: those it names)."""
        return len(self.q0)


def _tool(check: TomlCheck, value: Any, where: str) -> str | dict[str, Any]:
    if isinstance(value, str):
        return check.string(value, where, "tool")
    if not isinstance(value, dict):
        raise check.error(where, f"'tool' must be a frame's name or a table with xyz [m], rpy "
                                 f"[rad] and link, got {value!r}")
    check.check_keys(value, ("xyz", "rpy", "link"), f"{where} tool")
    out: dict[str, Any] = {}
    for k in value:
        if k == "link":
            out[k] = check.string(value[k], where, "tool.link")
        elif k == "rpy":
            out[k] = _rpy(check, value[k], where, "tool.rpy").tolist()
        else:
            out[k] = check.vector(value[k], where, f"tool.{k}", 3).tolist()
    return out


def _rpy(check: TomlCheck, value: Any, where: str, key: str) -> NDArray:
    """Roll, pitch and yaw (3,) [rad]: finite, and each within :data:`ROTVEC_BOUND` (as a pose
    CSV's rotation angle: beyond, the angle modulo a turn loses its digits)."""
    rpy = check.vector(value, where, key, 3)
    big = float(np.max(np.abs(rpy)))
    if big > ROTVEC_BOUND:
        raise check.error(where, f"'{key}' {big:.3g} rad is beyond {ROTVEC_BOUND:g} rad, the "
                                 f"largest angle mrnea accepts; check its units")
    return rpy


def _hold(check: TomlCheck, value: Any, where: str) -> tuple[str, ...]:
    if not isinstance(value, list):
        raise check.error(where, f"'hold' must be a list of joint names, got {value!r}")
    return tuple(check.string(v, where, "hold") for v in value)


def _positive(check: TomlCheck, table: Mapping[str, Any], key: str, where: str,
              required: bool) -> float:
    if key not in table:
        if required:
            raise check.error(where, f"missing required key '{key}'")
        return float("inf")
    v = check.number(table[key], where, key)
    if not v > 0:
        raise check.error(where, f"'{key}' must be > 0, got {v}")
    return v


def _as_q0(check: TomlCheck, value: Any, where: str, key: str, n: int | None) -> None:
    """A move's array of one value per joint against ``[program] q0``'s n (the robot is not
    known yet: either may be the wrong one, so the message names both)."""
    if n is not None and isinstance(value, list) and value and len(value) != n:
        raise check.error(where, f"'{key}' has {len(value)} values but [program] q0 has {n}; "
                                 f"both give one per joint of the robot")


def _per_joint(check: TomlCheck, value: Any, where: str, key: str, n: int | None
               ) -> NDArray | dict[str, float]:
    """A joint move's limit: an (n,) array, a table by joint name or one number (0-d)."""
    _as_q0(check, value, where, key, n)
    if isinstance(value, dict):
        a = number_table(check, value, where, key, 1.0, allow_inf=True)
    else:
        a = (check.vector(value, where, key, n, allow_inf=True) if isinstance(value, list)
             else np.array(check.number(value, where, key, allow_inf=True)))
    if not (np.array(list(a.values()) if isinstance(a, dict) else a) > 0).all():
        got = a if isinstance(a, dict) else a.tolist()
        raise check.error(where, f"'{key}' must be > 0 for every joint (inf = unlimited), got "
                                 f"{got}")
    return a


def _joints(check: TomlCheck, value: Any, where: str, key: str, n: int | None
            ) -> NDArray | dict[str, float]:
    """Joint positions: an array of n, or a table by joint name."""
    _as_q0(check, value, where, key, n)
    if isinstance(value, dict):
        return number_table(check, value, where, key, 1.0)
    return check.vector(value, where, key, n)


def _orientation(check: TomlCheck, table: Mapping[str, Any], where: str) -> NDArray | None:
    if "rpy" in table and "quat" in table:
        raise check.error(where, "give the orientation once: 'rpy' or 'quat', not both")
    if "rpy" in table:
        return rotation_from_rpy(_rpy(check, table["rpy"], where, "rpy"))
    if "quat" in table:
        w, x, y, z = check.vector(table["quat"], where, "quat", 4)
        norm = float(np.sqrt(w * w + x * x + y * y + z * z))
        if abs(norm - 1.0) > 1e-6:
            raise check.error(where, f"'quat' [w, x, y, z] must be a unit quaternion, its norm "
                                     f"is {norm:.9g}")
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    return None


def _position(check: TomlCheck, table: Mapping[str, Any], key: str, where: str) -> NDArray:
    """A move's point ``key`` (3,) [m], base frame: finite, and within the largest length mrnea
    accepts (:data:`mrnea.frozen.MAGNITUDES`, as a tool's and a link's origin)."""
    xyz = check.vector(check.require(table, key, where), where, key, 3)
    big, bound = float(np.max(np.abs(xyz))), MAGNITUDES["length"]
    if big > bound:
        raise check.error(where, f"'{key}' {big:.3g} m is beyond {bound:g} m, the largest "
                                 f"mrnea accepts; check its units")
    return xyz


def _poses(check: TomlCheck, index: int, table: Mapping[str, Any], where: str, dwell: float,
           dt: float, base_dir: Path) -> Move:
    p = expand_home(Path(check.string(check.require(table, "csv", where), where, "csv")),
                    lambda m: check.error(where, f"'csv': {m}"))
    if "\0" in str(p):  # a TOML "\u0000": name the program file, not only the path
        raise check.error(where, f"'csv' cannot hold a NUL character, got {quote(str(p))}")
    if not p.is_absolute():
        p = base_dir / p
    interpolation = table.get("interpolation", "cubic")
    if interpolation not in POSE_INTERPOLATIONS:
        raise check.error(where, f"'interpolation' must be one of "
                                 f"{', '.join(map(repr, POSE_INTERPOLATIONS))}, got "
                                 f"{interpolation!r}")
    time, poses, lines = read_poses(p)
    _, sampled = resample_poses(time, poses, dt, interpolation, str(p))
    sampled.setflags(write=False)
    return Move(index, "poses", dwell, 0.0, poses=sampled, csv=str(p), csv_line=lines[0])


def _move(check: TomlCheck, index: int, table: Any, n: int | None, dt: float, base_dir: Path
          ) -> Move:
    where = f"[[move]] {index}"
    table = check.table(table, "", f"move {index}")
    kind = check.string(check.require(table, "type", where), where, "type")
    if kind not in MOVE_TYPES:
        raise check.error(where, f"unknown type {kind!r}{did_you_mean(kind, MOVE_TYPES)}; "
                                 f"expected one of {', '.join(map(repr, MOVE_TYPES))}")
    where = f"[[move]] {index} ({kind})"
    check.check_keys(table, MOVE_KEYS[kind], where)
    dwell = check.number(table.get("dwell", 0.0), where, "dwell")
    blend = check.number(table.get("blend", 0.0), where, "blend")
    if dwell < 0 or blend < 0:
        raise check.error(where, f"'{'dwell' if dwell < 0 else 'blend'}' must be >= 0, got "
                                 f"{min(dwell, blend)}")
    if blend > 0 and kind != "linear":
        raise check.error(where, "'blend' > 0 (a rounded corner) joins two linear moves; a "
                                 f"{kind} move stops at its target (blend = 0)")
    if blend > 0 and dwell > 0:
        raise check.error(where, "'blend' > 0 passes the corner without stopping, 'dwell' "
                                 "stops there: give one of them")
    own = {"tool": _tool(check, table["tool"], where) if "tool" in table else None,
           "hold": _hold(check, table["hold"], where) if "hold" in table else ()}
    if kind == "poses":
        return dataclasses.replace(_poses(check, index, table, where, dwell, dt, base_dir),
                                   **own)
    if kind == "joint":
        target = _joints(check, check.require(table, "target", where), where, "target", n)
        profile = table.get("profile", "trapezoidal")
        if profile not in JOINT_PROFILES:
            raise check.error(where, f"unknown profile {profile!r}; expected one of "
                                     f"{', '.join(map(repr, JOINT_PROFILES))}")
        limits = [_per_joint(check, check.require(table, k, where), where, k, n)
                  for k in ("velocity_limit", "acceleration_limit")]
        if profile == "scurve":
            limits.append(_per_joint(check, check.require(table, "jerk_limit", where), where,
                                     "jerk_limit", n))
        elif "jerk_limit" in table:
            raise check.error(where, f"'jerk_limit' applies to profile = \"scurve\" only, not "
                                     f"{profile!r}")
        return Move(index, kind, dwell, blend, target=target, profile=profile,
                    limits=tuple(limits), tool=own["tool"])
    xyz = _position(check, table, "xyz", where)
    R = _orientation(check, table, where)
    limits = tuple(_positive(check, table, k, where, k in ("speed", "acceleration"))
                   for k in ("speed", "acceleration", "jerk", "angular_speed",
                             "angular_acceleration", "angular_jerk"))
    via = _position(check, table, "via", where) if kind == "circular" else None
    return Move(index, kind, dwell, blend, xyz=xyz, R=R, via=via, limits=limits, **own)


def _check_blend(check: TomlCheck, mv: Move, nxt: Move | None) -> None:
    """A blend joins a linear move to the next, also linear, neither jerk-limited."""
    where = f"[[move]] {mv.index} ({mv.type})"
    if nxt is None or nxt.type != "linear":
        raise check.error(where, "'blend' > 0 rounds the corner into the next move, which must "
                                 "be linear" + (f"; move {nxt.index} is {nxt.type}" if nxt
                                                else "; this is the last move"))
    if (nxt.tool, nxt.hold) != (mv.tool, mv.hold):
        raise check.error(f"[[move]] {nxt.index} (linear)",
                          f"a 'blend' from move {mv.index} joins it into one path of one "
                          f"tool: give both moves the same 'tool' and 'hold'")
    for m in (mv, nxt):
        if np.isfinite(m.limits[2]) or np.isfinite(m.limits[5]):
            raise check.error(f"[[move]] {m.index} ({m.type})",
                              "'jerk' and 'angular_jerk' do not apply to moves joined by a "
                              "'blend' (their timing is the trapezoid, docs/cartesian.md)")


def read_moves(check: TomlCheck, prog: Mapping[str, Any], moves: Any, dt: float,
               base_dir: Path) -> Moves:
    """The :class:`Moves` of a program whose ``[program]`` table is ``prog`` and whose
    ``[[move]]`` array is ``moves``; ``dt`` [s] the cycle (pose CSVs are resampled to it),
    ``base_dir`` the folder relative CSV paths resolve against."""
    if not isinstance(moves, list) or not moves:
        raise check.error("", "'move' must be an array of tables ([[move]]), at least one")
    q0 = _joints(check, check.require(prog, "q0", "[program]"), "[program]", "q0", None)
    tool = _tool(check, prog["tool"], "[program]") if "tool" in prog else None
    n = None if isinstance(q0, dict) else q0.size
    out = tuple(_move(check, k, m, n, dt, base_dir) for k, m in enumerate(moves, start=1))
    for mv, nxt in zip(out, (*out[1:], None), strict=True):
        if mv.blend > 0:
            _check_blend(check, mv, nxt)
    if n is not None:
        q0.setflags(write=False)
    return Moves(tool, q0, out)
