"""Rigid-body geometry and inertials: URDF roll-pitch-yaw angles and rotation matrices,
homogeneous transforms, and the inertials of rigidly joined bodies (parallel-axis theorem).

Plain NumPy functions that know no Robot: :mod:`mrnea.model` validates a Link's inertia with
:func:`check_inertia` and merges a payload with :func:`combine_inertials`; the robot file readers
and writers (:mod:`mrnea.io`) convert origins with the rpy functions and lump fixed links with
:func:`combine_inertials`. Units: m, rad, kg, kg m^2.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import ModelError
from mrnea.frozen import frozen_array, warn


def rotation_from_rpy(rpy: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix of URDF roll-pitch-yaw angles [rad]: ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Without negative zeros (``+ 0.0``): zero angles give ``np.eye(3)`` bit for bit, so that a
    robot file writer can name such a rotation by its angles and read the same bits back.
    """
    r, p, y = (float(v) for v in np.asarray(rpy, dtype=float))
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p),
                              math.cos(y), math.sin(y))
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]) + 0.0


def rpy_from_rotation(R: ArrayLike) -> NDArray[np.float64]:
    """URDF roll-pitch-yaw angles [rad] of a rotation matrix (inverse of rotation_from_rpy)."""
    R = np.asarray(R, dtype=float)
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.isclose(abs(pitch), math.pi / 2, abs_tol=1e-12):  # gimbal lock: put it all in yaw
        roll = 0.0
        yaw = math.atan2(-R[0, 1], R[1, 1])
    else:
        roll = math.atan2(R[2, 1], R[2, 2])
        yaw = math.atan2(R[1, 0], R[0, 0])
    return np.array([roll, pitch, yaw])


def transform(xyz: ArrayLike = (0.0, 0.0, 0.0), rpy: ArrayLike = (0.0, 0.0, 0.0)) -> NDArray:
    """4x4 homogeneous transform from a translation [m] and URDF roll-pitch-yaw angles [rad]."""
    frozen_array(xyz, (3,), "origin")
    frozen_array(rpy, (3,), "origin")
    T = np.eye(4)
    T[:3, :3] = rotation_from_rpy(rpy)
    T[:3, 3] = np.asarray(xyz, dtype=float)
    return T


def check_inertia(inertia: NDArray, what: str) -> None:
    """Refuses an inertia [kg m^2] that is not symmetric positive semi-definite (to 1e-9 of its
    largest entry); warns (ModelWarning) where its principal moments break the triangle
    inequality ``I1 + I2 >= I3``, as CAD exports do by rounding. ``what`` names its owner."""
    scale = max(1.0, float(np.max(np.abs(inertia))))
    if np.max(np.abs(inertia - inertia.T)) > 1e-9 * scale:
        raise ModelError(f"{what}: inertia is not symmetric: {inertia.tolist()}")
    eig = np.linalg.eigvalsh(inertia)
    if eig[0] < -1e-9 * scale:
        raise ModelError(
            f"{what}: inertia is not positive semi-definite (eigenvalues {eig.tolist()})"
        )
    # a rigid body's principal moments satisfy I1 + I2 >= I3; CAD exports break it by rounding
    excess = eig[2] - eig[0] - eig[1]
    if excess > 1e-9 * max(float(eig[2]), 1e-300):
        warn(
            f"{what}: inertia violates the triangle inequality (principal moments "
            f"{eig.tolist()}: {eig[0]:.6g} + {eig[1]:.6g} < {eig[2]:.6g}); physically doubtful, "
            f"used as given", stacklevel=4)


def combine_inertials(parts: Sequence[tuple[float, NDArray, NDArray]]
                      ) -> tuple[float, NDArray, NDArray]:
    """Total mass [kg], centre of mass [m] and inertia [kg m^2] about that centre of rigidly
    joined bodies, each ``(mass, com, inertia about its com)`` in one frame (parallel-axis
    theorem: ``I = sum I_k + m_k (|d_k|^2 E - d_k d_k^T)``, ``d_k = com_k - com``)."""
    mass = float(sum(m for m, _, _ in parts))
    massive = [c for m, c, _ in parts if m > 0]
    if len(massive) == 1:  # exact: no m * c / m rounding
        com = massive[0]
    elif massive:
        com = sum(m * c for m, c, _ in parts) / mass
    else:
        com = np.zeros(3)
    inertia = np.zeros((3, 3))
    for m, c, I in parts:
        inertia += I
        if m > 0:  # parallel-axis term (a massless part far away would give 0 * inf)
            d = c - com
            inertia += m * (float(d @ d) * np.eye(3) - np.outer(d, d))
    # (I + I^T) / 2 could overflow
    return mass, np.array(com, dtype=float), 0.5 * inertia + 0.5 * inertia.T
