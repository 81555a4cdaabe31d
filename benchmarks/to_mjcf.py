"""An mrnea Robot as a MuJoCo model (MJCF), for the benchmarks only.

Usage: ``xml = to_mjcf(robot)``; ``model = mujoco.MjModel.from_xml_string(xml)``.

Each moving link becomes a body nested in its parent's: the body frame is the mrnea link frame
(``pos`` and ``quat`` are the joint origin, the hinge or slide joint at the body origin turns or
moves it about ``axis``), the inertial is the link's mass, centre of mass and inertia about it
(``fullinertia``, link-frame axes). Rigid-body dynamics only: no armature, damping, friction
loss, joint limits or contacts (disabled), so ``mj_inverse`` and ``mj_forward`` compute what
``mrnea.inverse_dynamics`` and ``mrnea.forward_dynamics`` do. MuJoCo numbers its degrees of
freedom in the same order as the chain.

MuJoCo refuses a moving body whose mass or principal moments are below its ``mjMINVAL``, and an
inertia that breaks the triangle inequality (A + B >= C). Published DH models have such links:
the Puma 560's link 1 (no mass, inertia about its axis only) and link 3 (principal moments
0.0125 + 0.066 < 0.086). :func:`mujoco_ready` returns the robot MuJoCo accepts: every mass at
least ``MIN_MASS``, the two smaller principal moments raised just enough to meet the inequality
(and ``MIN_INERTIA``) about the same principal axes, and says which links it changed. run.py
checks MuJoCo against mrnea on that robot (to rounding), and reports how far its efforts are
from the original robot's.
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np
from scipy.spatial.transform import Rotation

from mrnea import Link, Robot

MIN_MASS = 1e-9  # [kg]
MIN_INERTIA = 1e-12  # [kg m^2]


def quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z), MuJoCo's order, of a rotation matrix (SciPy's is x, y, z,
    w)."""
    return np.roll(Rotation.from_matrix(R).as_quat(), 1)


def _num(x: float) -> str:
    return repr(float(x))


def _nums(a: np.ndarray) -> str:
    return " ".join(_num(x) for x in np.ravel(a))


def mujoco_inertia(inertia: np.ndarray) -> np.ndarray:
    """The inertia MuJoCo accepts: ``inertia`` itself, or, if it breaks A + B >= C or has a
    principal moment below MIN_INERTIA, the smaller moments raised about the same axes."""
    eig, V = np.linalg.eigh(0.5 * (inertia + inertia.T))  # ascending
    if eig[0] >= MIN_INERTIA and eig[2] <= eig[0] + eig[1]:
        return inertia
    eig = np.maximum(eig, MIN_INERTIA)
    deficit = eig[2] - eig[0] - eig[1]
    if deficit > 0:
        eig[:2] += 0.5 * deficit
    return V @ np.diag(eig) @ V.T


def mujoco_ready(robot: Robot) -> tuple[Robot, list[str]]:
    """``robot`` with masses and inertias MuJoCo accepts, and the names of the links changed."""
    links, changed = [], []
    for lk in robot.links:
        inertia = mujoco_inertia(np.asarray(lk.inertia))
        mass = max(lk.mass, MIN_MASS)
        if mass != lk.mass or inertia is not lk.inertia:
            changed.append(lk.name)
            lk = Link(lk.name, mass=mass, com=lk.com, inertia=inertia)
        links.append(lk)
    if not changed:
        return robot, []
    return Robot(robot.joints, links, gravity=robot.gravity, name=robot.name), changed


def to_mjcf(robot: Robot) -> str:
    """The MJCF text of ``robot``, which must be :func:`mujoco_ready` (module docstring)."""
    lines = [
        f"<mujoco model={quoteattr(robot.name)}>",
        '  <compiler angle="radian" autolimits="false"/>',
        f'  <option gravity="{_nums(robot.gravity)}" timestep="0.001">',
        '    <flag contact="disable"/>',
        "  </option>",
        "  <worldbody>",
    ]
    indent = "    "
    for j, lk in zip(robot.joints, robot.links, strict=True):
        origin = np.asarray(j.origin)
        I_ = np.asarray(lk.inertia)
        full = (I_[0, 0], I_[1, 1], I_[2, 2], I_[0, 1], I_[0, 2], I_[1, 2])
        kind = "slide" if j.is_prismatic else "hinge"
        lines += [
            f"{indent}<body name={quoteattr(lk.name)} pos=\"{_nums(origin[:3, 3])}\" "
            f"quat=\"{_nums(quaternion(origin[:3, :3]))}\">",
            f"{indent}  <joint name={quoteattr(j.name)} type=\"{kind}\" "
            f"axis=\"{_nums(j.axis)}\" limited=\"false\"/>",
            f"{indent}  <inertial mass=\"{_num(lk.mass)}\" "
            f"pos=\"{_nums(lk.com)}\" fullinertia=\"{_nums(full)}\"/>",
        ]
        indent += "  "
    for _ in robot.joints:
        indent = indent[:-2]
        lines.append(f"{indent}</body>")
    lines += ["  </worldbody>", "</mujoco>", ""]
    return "\n".join(lines)
