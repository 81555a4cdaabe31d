"""Denavit-Hartenberg tables -> mrnea joints and links (URDF-style frames).

Two DH conventions are supported. In both, ``theta_i`` and ``d_i`` are the *constant* parts of the
joint-i parameters: for a revolute joint the joint angle is ``theta_i + q_i`` (``theta_i`` is the
offset) and ``d_i`` is fixed; for a prismatic joint the joint length is ``d_i + q_i`` and
``theta_i`` is fixed. Angles in rad, lengths in m.

``"standard"`` (Denavit-Hartenberg, as in Paul, Spong, Corke's Robotics Toolbox ``DHRobot``)
    ``A_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`` is the pose of DH frame i in DH frame i-1;
    DH frame i sits at the *end* of link i and joint i moves about ``z_{i-1}``. Row i holds
    ``(a_i, alpha_i, d_i, theta_i)`` and link i's inertials in DH frame i.

``"modified"`` (Craig; Robotics Toolbox ``mdh``)
    ``A_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)``; DH frame i sits at joint i, which
    moves about ``z_i``. Row i holds ``(a_{i-1}, alpha_{i-1}, d_i, theta_i)`` -- the ``a`` and
    ``alpha`` of a row describe the link *before* the joint -- and link i's inertials in frame i.

Mapping to mrnea's frames (``T_i = T_{i-1} @ origin_i @ motion(q_i)``, axis z):

* In both conventions the DH transform factors as ``A_i = M(q_i) B_i`` (standard) or
  ``A_i = B_i M(q_i)`` (modified), where ``M(q)`` is ``Rz(q)`` (revolute) or ``Tz(q)``
  (prismatic) and ``B_i`` is constant (``Rz`` and ``Tz`` commute, so the offsets move freely).
* Modified: mrnea's link frame i *is* DH frame i. ``origin_i = Rx(alpha_{i-1}) Tx(a_{i-1})
  Rz(theta_i) Tz(d_i)``; inertials are copied unchanged.
* Standard: mrnea's link frame i is DH frame i-1 moved by joint i, ``L_i = F_{i-1} M(q_i)``, so
  ``F_i = L_i B_i`` with ``B_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``. Hence
  ``origin_1 = I`` (DH frame 0 is the base frame), ``origin_{i+1} = B_i``, and link i's inertials,
  given in DH frame i, are re-expressed in L_i: ``com_L = B_i com_F`` (a point) and
  ``I_L = R_B I_F R_B^T``; its visuals too: ``origin_L = B_i origin_F``. The last fixed
  transform ``B_n`` (mrnea's last link frame -> DH frame n, the DH "flange" frame) is not a
  joint of the chain: it is only used for link n's inertials and visuals and is available from
  :func:`dh_tip_transform`, e.g. to place a tool or compare end-effector poses.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mrnea.errors import ModelError, clip, listing, quote
from mrnea.model import JOINT_TYPES, Joint, Link
from mrnea.visual import Visual

CONVENTIONS = ("standard", "modified")

__all__ = [
    "CONVENTIONS",
    "JOINT_FIELDS",
    "DHRow",
    "dh_fixed_transform",
    "dh_joint_chain",
    "dh_tip_transform",
]

#: The keyword fields of :class:`mrnea.model.Joint` beyond its place in the chain (the limits and
#: the actuator): what a DH row, a native joint entry and a sidecar actuator file may set.
JOINT_FIELDS = tuple(f.name for f in fields(Joint)
                     if f.name not in ("name", "type", "parent", "child", "origin", "axis"))


@dataclass(frozen=True)
class DHRow:
    """One row of a DH table: the DH parameters, the joint's type, the link's inertials, the names.

    Parameters
    ----------
    a, alpha, d, theta : DH parameters [m, rad, m, rad]; ``theta`` (revolute) or ``d``
        (prismatic) is the constant offset added to the joint variable. In the modified convention
        ``a`` and ``alpha`` are Craig's ``a_{i-1}``, ``alpha_{i-1}``.
    type : ``"revolute"``, ``"continuous"`` or ``"prismatic"``.
    mass : link mass [kg].
    com : (3,) centre of mass [m] in the DH link frame (frame i of the chosen convention).
    inertia : (3, 3) inertia [kg m^2] about the centre of mass, axes of the DH link frame.
    name, link_name : joint and link names (default ``joint<i>``, ``link<i>``, 1-based).
    visuals : the link's :class:`mrnea.visual.Visual` in the DH link frame, like ``com``.
    joint : the joint's limit and actuator fields (:data:`JOINT_FIELDS`), passed on to
        :class:`mrnea.model.Joint` as keywords (joint side; limits in rad or m).
    """

    a: float
    alpha: float
    d: float
    theta: float = 0.0
    type: str = "revolute"
    mass: float = 0.0
    com: ArrayLike = (0.0, 0.0, 0.0)
    inertia: ArrayLike = field(default_factory=lambda: np.zeros((3, 3)))
    name: str | None = None
    link_name: str | None = None
    visuals: tuple[Visual, ...] = ()
    joint: Mapping[str, Any] = field(default_factory=dict)


#: The names a row given as a mapping may use: the row's own and, flat, the joint's fields.
_ROW_FIELDS = tuple(f.name for f in fields(DHRow) if f.name != "joint")


def _rot_x(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _rot_z(angle: float) -> NDArray[np.float64]:
    c, s = math.cos(angle), math.sin(angle)
    T = np.eye(4)
    T[0:2, 0:2] = [[c, -s], [s, c]]
    return T


def _trans(x: float = 0.0, z: float = 0.0) -> NDArray[np.float64]:
    T = np.eye(4)
    T[0, 3], T[2, 3] = x, z
    return T


def _check_convention(convention: str) -> None:
    if convention not in CONVENTIONS:
        raise ModelError(
            f"unknown DH convention {quote(convention)} (expected one of {', '.join(CONVENTIONS)})"
        )


def _as_row(row: DHRow | Mapping[str, Any], i: int) -> DHRow:
    if isinstance(row, Mapping):
        label = f"DH row {i + 1}" + (f" (joint {quote(row['name'])})" if "name" in row else "")
        unknown = sorted(set(row) - set(_ROW_FIELDS) - set(JOINT_FIELDS))
        if unknown:
            raise ModelError(f"{label}: unknown field(s) {listing(unknown)}; allowed: "
                             f"{[*_ROW_FIELDS, *JOINT_FIELDS]}")
        missing = [k for k in ("a", "alpha", "d") if k not in row]
        if missing:
            raise ModelError(f"{label}: missing DH parameter(s) {missing}")
        return DHRow(**{k: v for k, v in row.items() if k in _ROW_FIELDS},
                     joint={k: v for k, v in row.items() if k in JOINT_FIELDS})
    if not isinstance(row, DHRow):
        raise ModelError(f"DH row {i + 1}: expected a DHRow or a mapping, got {quote(row)}")
    unknown = sorted(set(row.joint) - set(JOINT_FIELDS))
    if unknown:
        label = f"DH row {i + 1}" + (f" (joint {quote(row.name)})" if row.name else "")
        raise ModelError(f"{label}: unknown joint field(s) {listing(unknown)}; allowed: "
                         f"{list(JOINT_FIELDS)}")
    return row


def _param(row: DHRow, key: str, label: str) -> float:
    v = getattr(row, key)
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):  # not a string
        raise ModelError(f"{label}: DH parameter {key} must be a number, got {quote(v)}")
    x = float(v)
    if not math.isfinite(x):
        raise ModelError(f"{label}: DH parameter {key} must be finite, got {x}")
    return x


def dh_fixed_transform(row: DHRow | Mapping[str, Any], convention: str = "standard") -> NDArray:
    """The constant 4x4 factor ``B`` of one DH row (see the module docstring).

    Standard: ``B = Rz(theta) Tz(d) Tx(a) Rx(alpha)`` with ``A(q) = M(q) B``.
    Modified: ``B = Rx(alpha) Tx(a) Rz(theta) Tz(d)`` with ``A(q) = B M(q)``.
    """
    _check_convention(convention)
    r = _as_row(row, 0)
    label = f"joint {quote(r.name)}" if r.name else "DH row"
    a, alpha, d, theta = (_param(r, k, label) for k in ("a", "alpha", "d", "theta"))
    if convention == "standard":
        return _rot_z(theta) @ _trans(z=d) @ _trans(x=a) @ _rot_x(alpha)
    return _rot_x(alpha) @ _trans(x=a) @ _rot_z(theta) @ _trans(z=d)


def dh_tip_transform(rows: Sequence[DHRow | Mapping[str, Any]],
                     convention: str = "standard") -> NDArray:
    """Pose (4x4) of DH frame n in mrnea's last link frame.

    Standard DH: the last row's ``B_n = Rz(theta_n) Tz(d_n) Tx(a_n) Rx(alpha_n)``; modified DH:
    the identity (mrnea's last link frame is DH frame n). Compose it with the last link's pose to
    get the DH end-effector ("flange") frame ``A_1 ... A_n``.
    """
    _check_convention(convention)
    if not rows:
        raise ModelError("DH table is empty")
    if convention == "modified":
        return np.eye(4)
    return dh_fixed_transform(_as_row(rows[-1], len(rows) - 1), convention)


def dh_joint_chain(
    rows: Sequence[DHRow | Mapping[str, Any]],
    convention: str = "standard",
    *,
    base: str = "base",
) -> tuple[list[Joint], list[Link]]:
    """Build mrnea joints and links from a DH table.

    Parameters
    ----------
    rows : sequence of :class:`DHRow` (or mappings with the same field names), root to tip.
    convention : ``"standard"`` or ``"modified"`` (see the module docstring).
    base : name of the fixed base link (the parent of the first joint); DH frame 0 is the base
        frame.

    Returns
    -------
    joints, links : lists of :class:`mrnea.model.Joint` and :class:`mrnea.model.Link`, ready for
        ``Robot(joints, links)``. Every joint axis is z of its joint frame; link inertials are
        expressed in mrnea's link frames (for standard DH: com moved and inertia rotated from DH
        frame i by ``B_i``; the final ``B_n`` is only used for that, see
        :func:`dh_tip_transform`).

    Raises
    ------
    ModelError
        On an unknown convention, a malformed row or invalid values; the message names the row or
        joint.
    """
    _check_convention(convention)
    if isinstance(rows, (str, bytes)) or not isinstance(rows, Sequence):
        raise ModelError(f"DH table must be a sequence of rows, got {type(rows).__name__}")
    if not rows:
        raise ModelError("DH table is empty")
    parsed = [_as_row(r, i) for i, r in enumerate(rows)]
    joints: list[Joint] = []
    links: list[Link] = []
    parent = base
    prev_fixed = np.eye(4)  # standard DH: B_{i-1}, the origin of joint i
    for i, r in enumerate(parsed, start=1):
        jname = r.name if r.name is not None else f"joint{i}"
        lname = r.link_name if r.link_name is not None else f"link{i}"
        label = f"joint {quote(jname)}"
        if r.type not in JOINT_TYPES:
            raise ModelError(f"{label}: unsupported joint type {quote(r.type)} (supported: "
                             f"{', '.join(JOINT_TYPES)})")
        B = dh_fixed_transform(r, convention)
        if convention == "standard":
            origin = prev_fixed
            to_link = B  # DH frame i expressed in mrnea link frame i
            prev_fixed = B
        else:
            origin = B
            to_link = np.eye(4)
        # Inertials: validate in the DH frame first (error messages name the link), then move.
        try:
            lk = Link(lname, mass=r.mass, com=r.com, inertia=r.inertia, visuals=r.visuals)
        except ModelError as exc:
            raise ModelError(clip(f"{label}: {exc}")) from None
        R = to_link[:3, :3]
        com = R @ lk.com + to_link[:3, 3]
        inertia = R @ lk.inertia @ R.T
        inertia = 0.5 * inertia + 0.5 * inertia.T  # (I + I^T) / 2 could overflow
        links.append(Link(lname, mass=lk.mass, com=com, inertia=inertia,
                          visuals=tuple(v.moved(to_link) for v in lk.visuals)))
        joints.append(Joint(jname, r.type, parent, lname, origin=origin, axis=(0.0, 0.0, 1.0),
                            **r.joint))
        parent = lname
    return joints, links
