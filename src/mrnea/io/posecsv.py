"""CSV files of tool poses (a Cartesian program's ``type = "poses"`` move): read and resampled.

A pose CSV is a path CSV (:mod:`mrnea.io.pathcsv`: one header row, a delimiter, ``#`` comments,
time strictly increasing) whose columns are, by their header names (case-insensitive; an
optional unit in brackets must be the one given):

* ``t`` [s], ``x`` [m], ``y`` [m], ``z`` [m]: the time and the tool frame's origin, base frame;
* the tool frame's orientation in the base frame, either
  ``qw, qx, qy, qz``: a unit quaternion (scalar first, as ``quat`` of a move; each row's norm
  within 1e-6 of 1, then normalised), or ``rx, ry, rz`` [rad]: a rotation vector, axis times
  angle (a UR controller's pose ``p[x, y, z, rx, ry, rz]``).

Usage: ``time, poses, lines = read_poses(path)`` (R,), (R, 4, 4) and the rows' line numbers;
``t, P = resample_poses(time, poses, dt, interpolation)`` the poses at the cycles ``time[0] +
k dt``: the position by the path CSVs' spline (``"cubic"``, default, or ``"linear"``,
:func:`mrnea.io.pathcsv.resample`), the orientation by scipy's ``RotationSpline`` (cubic in the
rotation vector, continuous angular acceleration) or ``Slerp`` (linear: constant angular velocity
between rows); the first and last cycles are the first and last rows exactly. Every problem is a
:class:`mrnea.errors.ProgramFileError` naming the file and the line.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mrnea.errors import ProgramFileError, StateError, quote
from mrnea.frozen import MAGNITUDES
from mrnea.io.pathcsv import data_lines, read_table, resample
from mrnea.io.writer import create

__all__ = ["POSE_INTERPOLATIONS", "QUATERNION", "ROTATION_VECTOR", "read_poses",
           "resample_poses", "save_poses"]

#: The columns of a pose CSV with either orientation, and each column's unit ("" for none).
QUATERNION = {"t": "s", "x": "m", "y": "m", "z": "m", "qw": "", "qx": "", "qy": "", "qz": ""}
ROTATION_VECTOR = {"t": "s", "x": "m", "y": "m", "z": "m", "rx": "rad", "ry": "rad",
                   "rz": "rad"}
POSE_INTERPOLATIONS = ("cubic", "linear")
QUAT_NORM_TOL = 1e-6  # a quaternion's norm may differ from 1 by this (rounded decimals)
#: The largest rotation vector's angle [rad] a pose CSV may give (1,600 turns: its rounding
#: stays below 1e-12 rad; beyond, the angle modulo a turn loses its digits and, near 1e155, the
#: rotation becomes NaN). Positions are bounded as a robot's lengths (``MAGNITUDES``).
ROTVEC_BOUND = 1e4
_NAME = re.compile(r"^\s*([A-Za-z]+)\s*(?:\[\s*([^\]]*?)\s*\])?\s*$")


def _columns(path: Path, header: list[str], line: int) -> dict[str, str]:
    names, units = [], []
    for h in header:
        m = _NAME.match(h)
        names.append(m.group(1).lower() if m else h)
        units.append(m.group(2) if m else None)
    for layout in (QUATERNION, ROTATION_VECTOR):
        if names == list(layout):
            for name, unit in zip(names, units, strict=True):
                if unit is not None and unit != layout[name]:
                    raise ProgramFileError(
                        f"{path}: line {line}: column {quote(name)} is in {quote(unit)}; a pose "
                        f"CSV gives it in {quote(layout[name]) if layout[name] else 'no unit'}")
            return layout
    raise ProgramFileError(
        f"{path}: line {line}: a pose CSV's header is 't, x, y, z, qw, qx, qy, qz' (a unit "
        f"quaternion) or 't, x, y, z, rx, ry, rz' (a rotation vector [rad]), units [s], [m]; "
        f"got {', '.join(map(quote, header))}")


def _bounded(path: Path, values: NDArray, bound: float, unit: str, lines: list[int]) -> None:
    """ProgramFileError naming the first row whose ``values`` (R, m) go beyond ``bound``: the
    positions x, y, z (one column named), or the rotation vector's norm (m = 1)."""
    rows, cols = np.nonzero(np.abs(values) > bound)
    if rows.size:
        k, c = int(rows[0]), int(cols[0])
        what = "rx, ry, rz: the rotation's angle" if values.shape[1] == 1 else "xyz"[c]
        raise ProgramFileError(
            f"{path}: line {lines[k + 1]}: {what} {abs(values[k, c]):.3g} {unit} is beyond "
            f"{bound:g} {unit}, the largest mrnea accepts; check its units")


def read_poses(path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64], list[int]]:
    """(time (R,) [s], poses (R, 4, 4) base frame [m], line numbers (R,)) of a pose CSV (module
    docstring). ProgramFileError: naming the file, the line and the column at fault."""
    from scipy.spatial.transform import Rotation  # here: scipy.spatial costs every command ~0.4 s

    header, rows = read_table(path, None)
    lines = data_lines(path)
    layout = _columns(path, list(header.names), lines[0])
    _bounded(path, rows[:, 1:4], MAGNITUDES["length"], "m", lines)
    if layout is QUATERNION:
        quat = rows[:, 4:8]
        norm = np.linalg.norm(quat, axis=1)
        bad = np.flatnonzero(np.abs(norm - 1.0) > QUAT_NORM_TOL)
        if bad.size:
            k = int(bad[0])
            raise ProgramFileError(
                f"{path}: line {lines[k + 1]}: qw, qx, qy, qz must be a unit quaternion, its "
                f"norm is {norm[k]:.9g}")
        rot = Rotation.from_quat(quat / norm[:, None], scalar_first=True)
    else:
        angle = np.hypot(np.hypot(rows[:, 4], rows[:, 5]), rows[:, 6])  # no overflow
        _bounded(path, angle[:, None], ROTVEC_BOUND, "rad", lines)
        rot = Rotation.from_rotvec(rows[:, 4:7])
    poses = np.zeros((rows.shape[0], 4, 4))
    poses[:, :3, :3], poses[:, :3, 3], poses[:, 3, 3] = rot.as_matrix(), rows[:, 1:4], 1.0
    return rows[:, 0].copy(), poses, lines[1:]


def resample_poses(time: NDArray, poses: NDArray, dt: float, interpolation: str = "cubic",
                   source: str = "poses") -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(t (K,) [s], poses (K, 4, 4)) at the cycles ``time[0] + k dt`` (module docstring).
    ProgramFileError: an interpolation not in :data:`POSE_INTERPOLATIONS`, too many cycles."""
    if interpolation not in POSE_INTERPOLATIONS:
        raise ProgramFileError(f"{source}: interpolation {quote(interpolation)} does not apply "
                               f"to poses; one of {', '.join(map(quote, POSE_INTERPOLATIONS))}")
    try:
        t, xyz = resample(time, poses[:, :3, 3], dt, interpolation, source)
    except StateError as exc:
        raise ProgramFileError(f"{source}: {exc}") from None
    from scipy.spatial.transform import Rotation, RotationSpline, Slerp  # here: see read_poses

    rot = Rotation.from_matrix(poses[:, :3, :3])
    at = np.minimum(t, time[-1])
    if np.all(poses[:, :3, :3] == poses[0, :3, :3]):
        R = np.broadcast_to(poses[0, :3, :3], (t.size, 3, 3))
    elif interpolation == "linear":
        R = Slerp(time, rot)(at).as_matrix()
    else:
        R = RotationSpline(time, rot)(at).as_matrix()
    out = np.zeros((t.size, 4, 4))
    out[:, :3, :3], out[:, :3, 3], out[:, 3, 3] = R, xyz, 1.0
    out[0], out[-1] = poses[0], poses[-1]
    return t, out


def save_poses(path: str | os.PathLike[str], t: NDArray, poses: NDArray,
               overwrite: bool = False) -> Path:
    """Write a pose CSV (:func:`read_poses` reads it): the header ``t [s], x [m], y [m], z [m],
    qw, qx, qy, qz``, then one row per pose (t (K,) [s], poses (K, 4, 4) base frame), every
    number as Python's shortest repr. Through :func:`mrnea.io.writer.create`: whole or not at
    all, an existing file replaced only with ``overwrite``."""
    from scipy.spatial.transform import Rotation  # here: see read_poses

    quat = Rotation.from_matrix(np.asarray(poses)[:, :3, :3]).as_quat(scalar_first=True)
    rows = np.column_stack([t, np.asarray(poses)[:, :3, 3], quat]).tolist()
    with create(path, overwrite) as fh:
        fh.write("t [s], x [m], y [m], z [m], qw, qx, qy, qz\n")
        fh.writelines(",".join(map(repr, r)) + "\n" for r in rows)
    return Path(path)
